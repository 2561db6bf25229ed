// A picture of a scene after some simulated time, rendered headless (OSMesa).
//
//   build/examples/snapshot [MODEL.xml] [SECONDS] [OUT.png]
//       (default: models/octopus_arm.xml, 0.5 s, snapshot.png in the working directory)
//
// The renderer only reads the state: step the simulation yourself, bring the positions up to date
// (mj::fwd_position), then render. The model's first camera is used if it has one, else a free
// camera framing the scene; RenderOptions has the command line's `render` options.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "png_io.hpp"
#include "renderer.hpp"
#include "scene.hpp"

using namespace cosserat;

// The shipped models' directory: examples/CMakeLists.txt defines it; a copy built elsewhere reads
// them from ./models (or define COSSERAT_MODELS_DIR="/path/to/models" when compiling).
#ifndef COSSERAT_MODELS_DIR
#define COSSERAT_MODELS_DIR "models"
#endif

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : COSSERAT_MODELS_DIR "/octopus_arm.xml";
  char* end = nullptr;
  const double seconds = argc > 2 ? std::strtod(argv[2], &end) : 0.5;
  if (argc > 2 && (*end != '\0' || !(seconds >= 0 && seconds <= 1e6))) {  // (not "1e999", "-1", "abc")
    std::fprintf(stderr, "SECONDS: a number of seconds from 0 to 1e6, got '%s'\n", argv[2]);
    return 1;
  }
  const std::string out = argc > 3 ? argv[3] : "snapshot.png";
  try {
    auto scene = mj::load_scene(path);
    mj::SceneData data(*scene);
    for (long k = std::lround(seconds / scene->m->opt.timestep); k > 0; --k)
      if (mj::step(*scene, data) == Status::Diverged) {
        std::fprintf(stderr, "diverged: %s\n", data.warning.c_str());
        return 1;
      }
    mj::fwd_position(*scene, data);
    render::RenderOptions options;  // 0 x 0: the model's <visual><global offwidth offheight>
    if (scene->m->ncam > 0) options.camera.name = mj_id2name(scene->m, mjOBJ_CAMERA, 0);
    render::Renderer renderer(*scene, options);
    render::write_png(out, renderer.render(data));
    std::printf("%s at t = %.3f s: %d x %d pixels in %s\n", path.c_str(), data.d->time, renderer.width(),
                renderer.height(), out.c_str());
  } catch (const std::exception& e) {  // mj::LoadError, a renderer or file error
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
