#include "renderer.hpp"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "osmesa_context.hpp"

namespace cosserat::render {

namespace {

// Room in the abstract scene: MuJoCo's own geoms (bodies, sites, tendons, decor) plus the tubes.
int scene_capacity(const mj::Scene& s) {
  const mjModel* m = s.m;
  return 1000 + 2 * (m->ngeom + m->nsite + m->nbody) + 100 * m->ntendon + max_rod_tubes(s);
}

}  // namespace

Renderer::Renderer(const mj::Scene& s, const RenderOptions& o)
    : s_(s),
      options_(o),
      width_(o.width > 0 ? o.width : s.m->vis.global.offwidth),
      height_(o.height > 0 ? o.height : s.m->vis.global.offheight),
      rig_(s, o.camera) {
  if (width_ <= 0 || height_ <= 0) throw std::invalid_argument("picture size must be positive");
  gl_ = std::make_unique<OSMesaGLContext>(16, 16);  // MuJoCo draws into its own off-screen framebuffer
  const int limit = gl_->max_size();
  if (width_ > limit || height_ > limit)
    throw std::invalid_argument("picture " + std::to_string(width_) + "x" + std::to_string(height_) +
                                " is larger than OpenGL allows here (" + std::to_string(limit) + " pixels a side)");

  if (o.samples > 0) {  // (outside probe BB: --samples 1000 drew what 64 draws, without a word)
    GLint most = 0;
    glGetIntegerv(GL_MAX_SAMPLES, &most);
    if (o.samples > most)
      throw std::invalid_argument("--samples " + std::to_string(o.samples) + ": OpenGL here multisamples at most " +
                                  std::to_string(most) + " per pixel");
  }
  mjv_defaultOption(&opt_);
  mjv_defaultScene(&scn_);
  mjv_makeScene(s.m, &scn_, scene_capacity(s));
  scn_.flags[mjRND_SHADOW] = o.shadows;
  mjr_defaultContext(&con_);
  // mjr_makeContext sizes its buffers from the model: this picture's size (a model's larger
  // offwidth/offheight had sized it, up to 2.3 GB for 100x100 pixels or a framebuffer OpenGL
  // refuses) and no shadow map without shadows (an outside probe)
  mjVisual& vis = s.m->vis;
  const mjVisual saved = vis;
  vis.global.offwidth = width_;
  vis.global.offheight = height_;
  if (!o.shadows) vis.quality.shadowsize = 0;
  if (o.samples >= 0) vis.quality.offsamples = o.samples;
  mjr_makeContext(s.m, &con_, mjFONTSCALE_100);
  vis = saved;
  mjr_setBuffer(mjFB_OFFSCREEN, &con_);
  if (con_.currentBuffer != mjFB_OFFSCREEN || con_.offWidth < width_ || con_.offHeight < height_) {
    mjr_freeContext(&con_);
    mjv_freeScene(&scn_);
    throw std::runtime_error("MuJoCo could not make a " + std::to_string(width_) + "x" + std::to_string(height_) +
                             " off-screen buffer");
  }
  tubes_ = std::make_unique<TubeMeshes>(con_, std::max(2 * s.m->vis.quality.numslices, 32));
  buffer_.resize(static_cast<size_t>(width_) * height_ * 3);
  alpha_.resize(static_cast<size_t>(width_) * height_);
  for (int k = 0; k < 3; ++k) background_[k] = static_cast<int>(std::lround(255 * std::clamp(o.background[k], 0.0f, 1.0f)));
}

Renderer::~Renderer() {
  gl_->make_current();
  tubes_.reset();
  mjr_freeContext(&con_);
  mjv_freeScene(&scn_);
}

Image Renderer::render(const mj::SceneData& sd) {
  gl_->make_current();
  rig_.update(s_, sd, opt_, static_cast<double>(width_) / height_, &cam_);
  mjv_updateScene(s_.m, sd.d, &opt_, nullptr, &cam_, mjCAT_ALL, &scn_);
  tubes_->add(rod_tubes(s_, sd, options_.rods, &scn_), &scn_);
  const mjrRect viewport{0, 0, width_, height_};
  mjr_render(viewport, &scn_, &con_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);  // rows of any width, unpadded
  mjr_readPixels(buffer_.data(), nullptr, viewport, &con_);  // resolves the multisamples, reads rgb
  // MuJoCo clears to transparent black: alpha is each pixel's coverage, the background shows through the rest
  glBindFramebuffer(GL_READ_FRAMEBUFFER, con_.offSamples ? con_.offFBO_r : con_.offFBO);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, width_, height_, GL_ALPHA, GL_UNSIGNED_BYTE, alpha_.data());
  glBindFramebuffer(GL_FRAMEBUFFER, con_.offFBO);

  Image image(width_, height_);
  for (int y = 0; y < height_; ++y) {  // OpenGL's rows run bottom-up
    const size_t src = static_cast<size_t>(height_ - 1 - y) * width_;
    std::uint8_t* out = image.pixel(0, y);
    for (int x = 0; x < width_; ++x) {
      const int transparency = 255 - alpha_[src + x];
      for (int k = 0; k < 3; ++k) {
        const int c = buffer_[3 * (src + x) + k] + (transparency * background_[k] + 127) / 255;
        out[3 * x + k] = static_cast<std::uint8_t>(std::min(c, 255));
      }
    }
  }
  return image;
}

}  // namespace cosserat::render
