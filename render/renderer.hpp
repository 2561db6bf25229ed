// Pictures of a Scene's current state through MuJoCo's own renderer in an OSMesa context.
// Only reads Scene/SceneData: bring the state up to date first (cosserat::mj::fwd_position or
// forward), and step the simulation between pictures yourself.
//
//   auto scene = mj::load_scene("models/cantilever.xml");
//   mj::SceneData data(*scene);
//   mj::fwd_position(*scene, data);
//   render::RenderOptions options;
//   options.width = 800, options.height = 600;
//   render::Renderer renderer(*scene, options);
//   render::write_png("cantilever.png", renderer.render(data));
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "camera.hpp"
#include "image.hpp"
#include "rod_visual.hpp"
#include "scene.hpp"
#include "tube_mesh.hpp"

namespace cosserat::render {

struct RenderOptions {
  int width = 0, height = 0;  // pixels; 0: the model's <visual><global offwidth/offheight>
  CameraOptions camera;
  RodVisualOptions rods;
  // where nothing is drawn, and seen through translucent geoms (a model's skybox covers it)
  float background[3] = {0.86f, 0.89f, 0.93f};
  bool shadows = true;
  // multisampling per pixel; < 0: the model's <quality offsamples>, at most OpenGL's GL_MAX_SAMPLES
  // (more is refused here, and a model's larger value is lowered to it with a warning)
  int samples = -1;
};

class OSMesaGLContext;

class Renderer {
 public:
  // Creates the OpenGL context and MuJoCo's rendering context (larger than the model's off-screen
  // buffer when asked). Throws std::invalid_argument on bad options (unknown camera or body, size
  // or samples beyond what OpenGL allows) and std::runtime_error when no context can be made.
  Renderer(const mj::Scene& s, const RenderOptions& o);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // The picture of the current state.
  Image render(const mj::SceneData& sd);
  // Whether the pictures use the free camera (no model camera named), and framing it on `e`
  // (scene_extent of states under option(), merged) for the pictures to come; without it the free
  // camera frames the first picture's state.
  bool free_camera() const { return rig_.free(); }
  void frame(const Extent& e) { rig_.frame(s_.m, e, static_cast<double>(width_) / height_); }

  // What the pictures will not show as the model asks (a model's offsamples beyond OpenGL's, a
  // texture on a rod's material), one sentence each, for the caller to report.
  const std::vector<std::string>& warnings() const { return warnings_; }
  // Multisamples per pixel of the pictures (0: none).
  int samples() const { return samples_; }

  int width() const { return width_; }
  int height() const { return height_; }
  // The abstract scene of the last picture: its geoms and cameras (scene().camera[0..1]).
  const mjvScene& scene() const { return scn_; }
  const mjvOption& option() const { return opt_; }

 private:
  const mj::Scene& s_;
  RenderOptions options_;
  int width_ = 0, height_ = 0, samples_ = 0;
  std::vector<std::string> warnings_;
  std::unique_ptr<OSMesaGLContext> gl_;
  CameraRig rig_;
  mjvScene scn_{};
  mjvCamera cam_{};
  mjvOption opt_{};
  mjrContext con_{};
  std::unique_ptr<TubeMeshes> tubes_;
  std::vector<unsigned char> buffer_;  // bottom-up rgb rows from OpenGL
};

}  // namespace cosserat::render
