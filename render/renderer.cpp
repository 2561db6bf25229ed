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

// Room in the abstract scene: MuJoCo's own geoms (bodies, sites, tendons, decor) plus the tubes
// and the backdrop.
int scene_capacity(const mj::Scene& s) {
  const mjModel* m = s.m;
  return 1001 + 2 * (m->ngeom + m->nsite + m->nbody) + 100 * m->ntendon + max_rod_tubes(s);
}

// The background as an opaque box just inside the far clipping plane, filling the view: MuJoCo
// clears to black, and blends the alpha channel as it blends colours, so the alpha it leaves is
// not the pixel's coverage (outside probe BF: compositing a background by it lit translucent geoms
// in front of opaque ones). Drawn by mjr_render among the opaque geoms, the backdrop is what
// translucent geoms blend with where nothing else is behind them, as MuJoCo's skybox is (which is
// nearer, at 0.7 of the far plane, and covers it). Its colour is its emission: rgba scaled down by
// kEmission, so lights add less than 1e-3 of it; decor, so it casts no shadow.
void add_backdrop(const float rgb[3], double aspect, mjvScene* scn) {
  constexpr float kEmission = 1e4f;
  if (scn->ngeom >= scn->maxgeom) return;
  const mjvGLCamera cam = mjv_averageCamera(&scn->camera[0], &scn->camera[1]);
  const Vec3 pos(cam.pos[0], cam.pos[1], cam.pos[2]);
  const Vec3 fwd = Vec3(cam.forward[0], cam.forward[1], cam.forward[2]).normalized();
  const Vec3 up = Vec3(cam.up[0], cam.up[1], cam.up[2]).normalized(), right = fwd.cross(up), back = right.cross(up);
  const double depth = 0.99 * cam.frustum_far, thickness = 1e-3 * cam.frustum_far;
  const double tan_y = std::max(std::abs(cam.frustum_top), std::abs(cam.frustum_bottom)) / cam.frustum_near;
  const double tan_x = (std::abs(cam.frustum_center) + 0.5 * aspect * (cam.frustum_top - cam.frustum_bottom)) / cam.frustum_near;
  mjvGeom& g = scn->geoms[scn->ngeom++];
  mjv_initGeom(&g, mjGEOM_BOX, nullptr, nullptr, nullptr, nullptr);
  g.category = mjCAT_DECOR;
  g.objtype = mjOBJ_UNKNOWN;
  g.objid = -1;
  g.segid = -1;
  g.texid = -1;
  const Vec3 centre = pos + (depth + thickness) * fwd;
  const Vec3 size(1.5 * depth * tan_x, 1.5 * depth * tan_y, thickness);
  for (int k = 0; k < 3; ++k) {
    g.pos[k] = static_cast<float>(centre[k]);
    g.size[k] = static_cast<float>(size[k]);
    g.mat[3 * k] = static_cast<float>(right[k]), g.mat[3 * k + 1] = static_cast<float>(up[k]);
    g.mat[3 * k + 2] = static_cast<float>(back[k]);  // its +z face towards the camera
    g.rgba[k] = std::clamp(rgb[k], 0.0f, 1.0f) / kEmission;
  }
  g.rgba[3] = 1;
  g.emission = kEmission;
  g.specular = 0, g.shininess = 0, g.reflectance = 0;
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

  // multisamples: beyond GL_MAX_SAMPLES OpenGL draws its most without a word (outside probe BB:
  // --samples 1000 drew what 64 draws); refused as an option, lowered with a warning from the
  // model's offsamples (outside probe BF: offsamples="8" drew 4 silently)
  GLint most = 0;
  glGetIntegerv(GL_MAX_SAMPLES, &most);
  if (o.samples > most)
    throw std::invalid_argument("--samples " + std::to_string(o.samples) + ": OpenGL here multisamples at most " +
                                std::to_string(most) + " per pixel");
  samples_ = o.samples >= 0 ? o.samples : std::max(s.m->vis.quality.offsamples, 0);
  if (samples_ > most) {
    warnings_.push_back("the model's <visual><quality offsamples=\"" + std::to_string(samples_) +
                        "\"> is more than OpenGL here multisamples (" + std::to_string(most) + " per pixel): drawing " +
                        std::to_string(most));
    samples_ = most;
  }
  // rods are drawn as tubes without texture coordinates: a texture of their material is left out
  if (o.rods.coloring == RodColoring::Model)
    for (const mj::RodBinding& rb : s.rods) {
      const int g = rb.geom_id.empty() ? -1 : rb.geom_id[0];
      const int mat = g >= 0 ? s.m->geom_matid[g] : -1;
      if (mat >= 0 && s.m->mat_texid[mat] >= 0) {
        const char* name = mj_id2name(s.m, mjOBJ_MATERIAL, mat);
        warnings_.push_back("rod '" + rb.decl.name + "': the texture of its material" +
                            (name && *name ? " '" + std::string(name) + "'" : std::string()) +
                            " is not drawn (the rod's tube has its colour, specular, shininess and emission)");
      }
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
  vis.quality.offsamples = samples_;
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
  rig_.clip(&scn_);  // the free camera's planes hold what it framed
  tubes_->add(rod_tubes(s_, sd, options_.rods, &scn_), &scn_);
  add_backdrop(options_.background, static_cast<double>(width_) / height_, &scn_);
  const mjrRect viewport{0, 0, width_, height_};
  mjr_render(viewport, &scn_, &con_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);  // rows of any width, unpadded
  mjr_readPixels(buffer_.data(), nullptr, viewport, &con_);  // resolves the multisamples, reads rgb

  Image image(width_, height_);
  const size_t row = static_cast<size_t>(width_) * 3;
  for (int y = 0; y < height_; ++y)  // OpenGL's rows run bottom-up
    std::memcpy(image.pixel(0, y), buffer_.data() + static_cast<size_t>(height_ - 1 - y) * row, row);
  return image;
}

}  // namespace cosserat::render
