// A shipped model (models/NAME), loaded and stepped to time t with its default integrator, its
// positions evaluated: what the rendering tests draw.
#pragma once

#include <cmath>
#include <memory>
#include <string>

#include "scene.hpp"

namespace cosserat::testing {

inline const std::string kModelsDir = std::string(COSSERAT_SOURCE_DIR) + "/models/";

struct LoadedScene {
  std::unique_ptr<mj::Scene> scene;
  std::unique_ptr<mj::SceneData> data;
  explicit LoadedScene(const std::string& model, double t = 0.0) : scene(mj::load_scene(kModelsDir + model)) {
    data = std::make_unique<mj::SceneData>(*scene);
    for (long k = std::lround(t / scene->m->opt.timestep); k > 0; --k) mj::step(*scene, *data);
    mj::fwd_position(*scene, *data);
  }
};

}  // namespace cosserat::testing
