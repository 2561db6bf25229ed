// The smallest program: load a scene with rods, step it, read the state.
//
//   build/examples/basic [MODEL.xml] [SECONDS]      (default: models/cantilever.xml, 1 s)
//
// Prints the time, the tip of the first rod (world position of its end cross-section) and the
// scene's total energy ten times over the run. Shows the three things every program needs: the
// load error (file:line: what is wrong), the step loop, and what to do when a step diverges.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "scene.hpp"

using namespace cosserat;

// The shipped models' directory: examples/CMakeLists.txt defines it; a copy built elsewhere reads
// them from ./models (or define COSSERAT_MODELS_DIR="/path/to/models" when compiling).
#ifndef COSSERAT_MODELS_DIR
#define COSSERAT_MODELS_DIR "models"
#endif

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : COSSERAT_MODELS_DIR "/cantilever.xml";
  char* end = nullptr;
  const double seconds = argc > 2 ? std::strtod(argv[2], &end) : 1.0;
  if (argc > 2 && (*end != '\0' || !(seconds >= 0 && seconds <= 1e6))) {  // (not "1e999", "-1", "abc")
    std::fprintf(stderr, "SECONDS: a number of seconds from 0 to 1e6, got '%s'\n", argv[2]);
    return 1;
  }

  std::unique_ptr<mj::Scene> scene;
  try {
    scene = mj::load_scene(path);  // an mjModel plus one solver model per <cosserat>
  } catch (const mj::LoadError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // "file:line: what is wrong"
    return 1;
  }
  for (const std::string& w : scene->load_warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  if (scene->rods.empty()) {
    std::fprintf(stderr, "%s has no <cosserat> rod\n", path.c_str());
    return 1;
  }
  mj::SceneData data(*scene);  // an mjData plus one solver state per rod
  const mjModel* m = scene->m;
  const mjData* d = data.d;
  const double L = scene->rods[0].model.rods[0].length;

  const long steps = std::lround(seconds / m->opt.timestep);
  std::printf("%s: %d rods, nq %d, nv %d, timestep %g s, %s\n", path.c_str(), static_cast<int>(scene->rods.size()),
              m->nq, m->nv, m->opt.timestep, integrator_name(scene->integrator));
  std::printf("%8s %10s %10s %10s %12s\n", "t", "tip x", "tip y", "tip z", "energy");
  for (long k = 0; k <= steps; ++k) {
    if (k % std::max(1L, steps / 10) == 0) {
      mj::forward(*scene, data);  // the current state's positions, velocities and forces
      const Vec3 tip = mj::rod_frame(*scene, data, 0, L).u;
      std::printf("%8.3f %10.5f %10.5f %10.5f %12.6g\n", d->time, tip.x(), tip.y(), tip.z(),
                  mj::energy(*scene, data).total());
    }
    if (k == steps) break;
    if (mj::step(*scene, data) == Status::Diverged) {  // the state is the step's start
      std::fprintf(stderr, "diverged: %s (%s)\n", data.warning.c_str(),
                   mj::divergence_hint(*scene, data, scene->integrator).c_str());
      return 1;
    }
  }
  return 0;
}
