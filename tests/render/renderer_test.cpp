// Headless pictures of shipped models (render/renderer.hpp): size, content, where the rod shows up
// (against our own projection of its centreline through the scene's camera), background where
// nothing is, cameras, determinism; all without a display.
#include "renderer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <set>
#include <string>
#include <vector>


#include "support/loaded_scene.hpp"

using namespace cosserat;
namespace rd = cosserat::render;

namespace {

using Loaded = cosserat::testing::LoadedScene;

// Pixel (column, row from the top) of a world point seen by the scene's camera; false when behind.
bool project(const mjvScene& scn, int width, int height, const Vec3& p, double& col, double& row) {
  const mjvGLCamera cam = mjv_averageCamera(&scn.camera[0], &scn.camera[1]);
  const Vec3 pos(cam.pos[0], cam.pos[1], cam.pos[2]);
  const Vec3 fwd = Vec3(cam.forward[0], cam.forward[1], cam.forward[2]).normalized();
  const Vec3 up = Vec3(cam.up[0], cam.up[1], cam.up[2]).normalized(), right = fwd.cross(up);
  const Vec3 d = p - pos;
  const double z = d.dot(fwd);
  if (z <= cam.frustum_near) return false;
  const double x = d.dot(right) / z * cam.frustum_near, y = d.dot(up) / z * cam.frustum_near;
  const double half = 0.5 * width / height * (cam.frustum_top - cam.frustum_bottom);  // left/right match the aspect
  col = (x - (cam.frustum_center - half)) / (2 * half) * width;
  row = height - (y - cam.frustum_bottom) / (cam.frustum_top - cam.frustum_bottom) * height;
  return true;
}

// The world ray through the centre of pixel (col, row).
void pixel_ray(const mjvScene& scn, int width, int height, int col, int row, Vec3& origin, Vec3& dir) {
  const mjvGLCamera cam = mjv_averageCamera(&scn.camera[0], &scn.camera[1]);
  const Vec3 fwd = Vec3(cam.forward[0], cam.forward[1], cam.forward[2]).normalized();
  const Vec3 up = Vec3(cam.up[0], cam.up[1], cam.up[2]).normalized(), right = fwd.cross(up);
  const double half = 0.5 * width / height * (cam.frustum_top - cam.frustum_bottom);
  const double x = cam.frustum_center - half + (col + 0.5) / width * 2 * half;
  const double y = cam.frustum_bottom + (height - row - 0.5) / height * (cam.frustum_top - cam.frustum_bottom);
  origin = Vec3(cam.pos[0], cam.pos[1], cam.pos[2]);
  dir = (cam.frustum_near * fwd + x * right + y * up).normalized();
}

double ray_distance(const Vec3& o, const Vec3& d, const Vec3& p) {
  const double s = std::max(0.0, (p - o).dot(d));
  return (o + s * d - p).norm();
}

// True when the ray passes within `margin` of any geom (its box, or its bounding sphere), any site,
// any rod, or hits a plane inside its (drawn) extent.
bool near_geometry(const mj::Scene& s, const mj::SceneData& sd, const Vec3& o, const Vec3& d, double margin) {
  const mjModel* m = s.m;
  const mjData* dd = sd.d;
  for (int g = 0; g < m->ngeom; ++g) {
    const Vec3 c(dd->geom_xpos[3 * g], dd->geom_xpos[3 * g + 1], dd->geom_xpos[3 * g + 2]);
    if (m->geom_type[g] == mjGEOM_PLANE) {
      const Vec3 n(dd->geom_xmat[9 * g + 2], dd->geom_xmat[9 * g + 5], dd->geom_xmat[9 * g + 8]);
      if (std::abs(d.dot(n)) < 1e-9) continue;
      const double t = (c - o).dot(n) / d.dot(n);
      if (t <= 0) continue;
      const Vec3 hit = o + t * d - c;
      const Vec3 ax(dd->geom_xmat[9 * g], dd->geom_xmat[9 * g + 3], dd->geom_xmat[9 * g + 6]);
      const Vec3 ay(dd->geom_xmat[9 * g + 1], dd->geom_xmat[9 * g + 4], dd->geom_xmat[9 * g + 7]);
      if (std::abs(hit.dot(ax)) < m->geom_size[3 * g] + margin && std::abs(hit.dot(ay)) < m->geom_size[3 * g + 1] + margin)
        return true;
    } else if (m->geom_type[g] == mjGEOM_BOX) {  // slab test against the box grown by the margin
      double t0 = 0, t1 = 1e300;
      for (int k = 0; k < 3; ++k) {
        const Vec3 axis(dd->geom_xmat[9 * g + k], dd->geom_xmat[9 * g + 3 + k], dd->geom_xmat[9 * g + 6 + k]);
        const double oc = (o - c).dot(axis), dk = d.dot(axis), h = m->geom_size[3 * g + k] + margin;
        if (std::abs(dk) < 1e-12) {
          if (std::abs(oc) > h) t1 = -1;
          continue;
        }
        const double a = (-h - oc) / dk, b = (h - oc) / dk;
        t0 = std::max(t0, std::min(a, b)), t1 = std::min(t1, std::max(a, b));
      }
      if (t0 <= t1) return true;
    } else if (ray_distance(o, d, c) < m->geom_rbound[g] + margin) {
      return true;
    }
  }
  for (int i = 0; i < m->nsite; ++i)
    if (ray_distance(o, d, Vec3(dd->site_xpos[3 * i], dd->site_xpos[3 * i + 1], dd->site_xpos[3 * i + 2])) <
        m->site_size[3 * i] + margin)
      return true;
  for (size_t r = 0; r < s.rods.size(); ++r)
    for (const Vec3& p : mj::rod_centerline(s, sd, static_cast<int>(r), 200))
      if (ray_distance(o, d, p) < s.rods[r].model.rods[0].radius_base + margin) return true;
  return false;
}

// Hue in degrees and saturation of an 8-bit colour.
void hue_saturation(const std::uint8_t* c, double& hue, double& sat) {
  const double r = c[0] / 255.0, g = c[1] / 255.0, b = c[2] / 255.0;
  const double mx = std::max({r, g, b}), mn = std::min({r, g, b}), d = mx - mn;
  sat = mx > 0 ? d / mx : 0;
  if (d <= 0) {
    hue = 0;
  } else if (mx == r) {
    hue = 60 * std::fmod((g - b) / d + 6, 6.0);
  } else if (mx == g) {
    hue = 60 * ((b - r) / d + 2);
  } else {
    hue = 60 * ((r - g) / d + 4);
  }
}
double hue_difference(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 360.0);
  return std::min(d, 360 - d);
}

rd::RenderOptions sized(int width, int height) {
  rd::RenderOptions o;
  o.width = width, o.height = height;
  return o;
}

std::array<std::uint8_t, 3> background(const rd::RenderOptions& o) {
  std::array<std::uint8_t, 3> c{};
  for (int k = 0; k < 3; ++k) c[k] = static_cast<std::uint8_t>(std::lround(255 * o.background[k]));
  return c;
}

// Checks a picture of `l` by `r`: its size, that it is not blank, that pixels at the projected
// centreline of every rod have the rod's hue, and that pixels far from all geometry are background.
void check_picture(const Loaded& l, const rd::Renderer& r, const rd::Image& img, const rd::RenderOptions& o) {
  const mj::Scene& s = *l.scene;
  ASSERT_EQ(img.width, r.width());
  ASSERT_EQ(img.height, r.height());
  ASSERT_EQ(img.rgb.size(), static_cast<size_t>(img.width) * img.height * 3);

  std::set<int> colours;
  for (size_t i = 0; i < img.rgb.size(); i += 3) colours.insert(img.rgb[i] << 16 | img.rgb[i + 1] << 8 | img.rgb[i + 2]);
  EXPECT_GT(colours.size(), 100u) << "picture looks blank";

  const mjvScene& scn = r.scene();
  for (size_t k = 0; k < s.rods.size(); ++k) {
    const int geom = s.rods[k].geom_id[0];
    const std::uint8_t rod_rgb[3] = {static_cast<std::uint8_t>(255 * s.m->geom_rgba[4 * geom]),
                                     static_cast<std::uint8_t>(255 * s.m->geom_rgba[4 * geom + 1]),
                                     static_cast<std::uint8_t>(255 * s.m->geom_rgba[4 * geom + 2])};
    double rod_hue, rod_sat;
    hue_saturation(rod_rgb, rod_hue, rod_sat);
    int inside = 0, matching = 0;
    for (const Vec3& p : mj::rod_centerline(s, *l.data, static_cast<int>(k), 60)) {
      double col, row;
      if (!project(scn, img.width, img.height, p, col, row)) continue;
      const int c = static_cast<int>(col), rr = static_cast<int>(row);
      if (c < 0 || rr < 0 || c >= img.width || rr >= img.height) continue;
      ++inside;
      double hue, sat;
      hue_saturation(img.pixel(c, rr), hue, sat);
      if (hue_difference(hue, rod_hue) < 20 && sat > 0.3) ++matching;
    }
    EXPECT_GE(inside, 30) << "rod " << k << " is mostly outside the picture";
    EXPECT_GE(matching, 0.85 * inside) << "rod " << k << ": " << matching << " of " << inside
                                       << " centreline pixels have the rod's colour";
  }

  const auto bg = background(o);
  const double pixel = 2.0 * s.m->stat.extent / img.height;  // generous margin in world units
  int far = 0;
  for (int row = 0; row < img.height; row += 7)
    for (int col = 0; col < img.width; col += 7) {
      Vec3 origin, dir;
      pixel_ray(scn, img.width, img.height, col, row, origin, dir);
      if (near_geometry(s, *l.data, origin, dir, 0.02 * s.m->stat.extent + pixel)) continue;
      ++far;
      const std::uint8_t* p = img.pixel(col, row);
      ASSERT_TRUE(p[0] == bg[0] && p[1] == bg[1] && p[2] == bg[2])
          << "pixel (" << col << ", " << row << ") far from all geometry is (" << int(p[0]) << ", " << int(p[1]) << ", "
          << int(p[2]) << "), not the background";
    }
  EXPECT_GT(far, 50) << "too few pixels far from geometry to check the background";
}

class RendererTest : public ::testing::Test {
 protected:
  void SetUp() override { unsetenv("DISPLAY"); }  // no display: OSMesa only
};

TEST_F(RendererTest, CantileverSnapshotShowsTheRodWhereItsCentrelineProjects) {
  Loaded l("cantilever.xml", 0.3);
  for (const std::string camera : {"", "side"}) {
    SCOPED_TRACE("camera '" + camera + "'");
    rd::RenderOptions o;
    o.width = 481, o.height = 321;  // odd: rows are not padded
    o.camera.name = camera;
    rd::Renderer r(*l.scene, o);
    const rd::Image img = r.render(*l.data);
    check_picture(l, r, img, o);
  }
}

TEST_F(RendererTest, OctopusArmSnapshotShowsTheTaperedArm) {
  Loaded l("octopus_arm.xml", 0.2);
  for (const std::string camera : {"", "side"}) {
    SCOPED_TRACE("camera '" + camera + "'");
    rd::RenderOptions o;
    o.width = 400, o.height = 300;
    o.camera.name = camera;
    rd::Renderer r(*l.scene, o);
    check_picture(l, r, r.render(*l.data), o);
  }
}

TEST_F(RendererTest, SizeDefaultsToTheModelsOffscreenBuffer) {
  Loaded l("cantilever.xml");
  rd::Renderer r(*l.scene, {});
  const rd::Image img = r.render(*l.data);
  EXPECT_EQ(img.width, l.scene->m->vis.global.offwidth);
  EXPECT_EQ(img.height, l.scene->m->vis.global.offheight);
}

TEST_F(RendererTest, PicturesLargerThanTheModelsBufferAreNotCropped) {
  Loaded l("cantilever.xml");
  ASSERT_EQ(l.scene->m->vis.global.offwidth, 1280);
  rd::RenderOptions o;
  o.width = 2000, o.height = 400;  // wider than offwidth 1280
  rd::Renderer r(*l.scene, o);
  const rd::Image img = r.render(*l.data);
  check_picture(l, r, img, o);
  EXPECT_EQ(l.scene->m->vis.global.offwidth, 1280) << "the model is left as it was";
  // the rod reaches beyond column 1280, and is drawn there
  int beyond = 0;
  for (const Vec3& p : mj::rod_centerline(*l.scene, *l.data, 0, 100)) {
    double col, row;
    ASSERT_TRUE(project(r.scene(), img.width, img.height, p, col, row));
    if (col < 1300 || col >= img.width) continue;
    const std::uint8_t* c = img.pixel(static_cast<int>(col), static_cast<int>(row));
    if (c[0] > c[1] + 40 && c[1] > c[2]) ++beyond;  // the rod's orange
  }
  EXPECT_GT(beyond, 10);
}

// The picture's own size sizes MuJoCo's off-screen buffer, not a model's larger offwidth and
// offheight: 16385 pixels, beyond what OpenGL allows here, had made every picture fail with
// MuJoCo's line-less "Offscreen framebuffer is not complete", even at 100x100 (an outside probe).
TEST_F(RendererTest, AModelsLargerOffscreenBufferDoesNotSizeASmallerPicture) {
  Loaded l("cantilever.xml");
  l.scene->m->vis.global.offwidth = 16385;
  l.scene->m->vis.global.offheight = 16385;
  rd::RenderOptions o = sized(100, 80);
  o.shadows = false;
  rd::Renderer r(*l.scene, o);
  const rd::Image img = r.render(*l.data);
  EXPECT_EQ(img.width, 100);
  EXPECT_EQ(img.height, 80);
  check_picture(l, r, img, o);
  EXPECT_EQ(l.scene->m->vis.global.offwidth, 16385) << "the model is left as it was";
  EXPECT_EQ(l.scene->m->vis.quality.shadowsize, 4096);
}

TEST_F(RendererTest, RodCapsulesAreReplacedByTubes) {
  Loaded l("octopus_arm.xml");
  rd::Renderer r(*l.scene, sized(320, 240));
  r.render(*l.data);
  const mjvScene& scn = r.scene();
  int tubes = 0;
  for (int i = 0; i < scn.ngeom; ++i) {
    const mjvGeom& g = scn.geoms[i];
    if (g.objtype == mjOBJ_GEOM) {
      EXPECT_LT(l.scene->geom_rod[g.objid], 0) << "a rod capsule is still drawn";
    }
    if (g.objtype == mjOBJ_UNKNOWN && g.type == mjGEOM_MESH) ++tubes;
  }
  EXPECT_EQ(tubes, 1);
}

TEST_F(RendererTest, SamePictureTwice) {
  Loaded l("octopus_arm.xml", 0.1);
  rd::RenderOptions o;
  o.width = 320, o.height = 240;
  rd::Renderer a(*l.scene, o);
  const rd::Image first = a.render(*l.data), again = a.render(*l.data);
  rd::Renderer b(*l.scene, o);
  const rd::Image other = b.render(*l.data);
  EXPECT_TRUE(first.rgb == again.rgb);
  EXPECT_TRUE(first.rgb == other.rgb);
}

TEST_F(RendererTest, FreeCameraFramesBodiesAndRods) {
  Loaded l("cantilever.xml");
  rd::RenderOptions o;
  o.width = 400, o.height = 300;
  rd::Renderer r(*l.scene, o);
  const rd::Image img = r.render(*l.data);
  // the rod and the tip weight are inside the picture, with some border, and fill a good part of it
  double lo = 1e9, hi = -1e9;
  for (const Vec3& p : mj::rod_centerline(*l.scene, *l.data, 0, 50)) {
    double col, row;
    ASSERT_TRUE(project(r.scene(), img.width, img.height, p, col, row));
    EXPECT_GT(col, 0.0);
    EXPECT_LT(col, img.width);
    EXPECT_GT(row, 0.0);
    EXPECT_LT(row, img.height);
    lo = std::min(lo, col), hi = std::max(hi, col);
  }
  EXPECT_GT(hi - lo, 0.5 * img.width);
}

TEST_F(RendererTest, TrackingCameraFollowsABody) {
  // a ball falling freely next to a rod: tracked, it stays at the same pixel
  const std::string xml = R"(<mujoco>
    <worldbody>
      <light pos="0 0 3" dir="0 0 -1" directional="true"/>
      <cosserat name="rod" pos="0 0 1" length="0.3" sections="2" strain="kl" radius="0.01" young="1e7" rgba="0.2 0.4 0.9 1"/>
      <body name="ball" pos="0.2 0 1.2"><freejoint/><geom type="sphere" size="0.03" rgba="0.9 0.1 0.1 1"/></body>
    </worldbody></mujoco>)";
  auto s = mj::load_scene_string(xml, "/tmp/cosserat_render_track.xml");
  mj::SceneData sd(*s);
  mj::fwd_position(*s, sd);
  const int ball = mj_name2id(s->m, mjOBJ_BODY, "ball");
  rd::RenderOptions o;
  o.width = 320, o.height = 240;
  o.camera.track = "ball";
  rd::Renderer tracking(*s, o);
  rd::Renderer fixed(*s, sized(320, 240));
  double c0, r0, c1, r1;
  tracking.render(sd);
  fixed.render(sd);
  const Vec3 p0(sd.d->xpos[3 * ball], sd.d->xpos[3 * ball + 1], sd.d->xpos[3 * ball + 2]);
  ASSERT_TRUE(project(tracking.scene(), 320, 240, p0, c0, r0));
  for (int k = 0; k < 300; ++k) mj::step(*s, sd);
  mj::fwd_position(*s, sd);
  const Vec3 p1(sd.d->xpos[3 * ball], sd.d->xpos[3 * ball + 1], sd.d->xpos[3 * ball + 2]);
  ASSERT_GT((p1 - p0).norm(), 0.3);  // it fell
  tracking.render(sd);
  ASSERT_TRUE(project(tracking.scene(), 320, 240, p1, c1, r1));
  EXPECT_NEAR(c1, c0, 0.5);
  EXPECT_NEAR(r1, r0, 0.5);
  fixed.render(sd);
  ASSERT_TRUE(project(fixed.scene(), 320, 240, p1, c1, r1));
  EXPECT_GT(std::abs(r1 - r0), 20) << "without tracking the ball moves in the picture";
}

TEST_F(RendererTest, StrainColouringFollowsTheBendingMoment) {
  Loaded l("cantilever.xml", 0.3);
  rd::RenderOptions o;
  o.width = 480, o.height = 320;
  o.camera.name = "side";
  o.rods.coloring = rd::RodColoring::Strain;
  rd::Renderer r(*l.scene, o);
  const rd::Image img = r.render(*l.data);
  // largest strain at the clamp (top of the colour map: yellow), smallest at the tip (violet)
  const auto pts = mj::rod_centerline(*l.scene, *l.data, 0, 41);
  double col, row;
  ASSERT_TRUE(project(r.scene(), img.width, img.height, pts[2], col, row));
  const std::uint8_t* base = img.pixel(static_cast<int>(col), static_cast<int>(row));
  ASSERT_TRUE(project(r.scene(), img.width, img.height, pts[38], col, row));
  const std::uint8_t* tip = img.pixel(static_cast<int>(col), static_cast<int>(row));
  EXPECT_GT(base[0] + base[1], 2 * base[2] + 100) << "yellow near the clamp";
  EXPECT_GT(tip[2], tip[1]) << "violet near the tip";
  EXPECT_GT(rd::rod_strain_magnitude(*l.scene, *l.data, 0, 0.01), 3 * rd::rod_strain_magnitude(*l.scene, *l.data, 0, 0.45));
  EXPECT_GT(rd::rod_stress_magnitude(*l.scene, *l.data, 0, 0.01), 1e4);
}

// Translucent geoms blend with what is behind them as MuJoCo draws them: twice (front to back, then
// back to front), each time over the colour there, so an alpha a covers 1 - (1 - a)^2 of it. Unlit
// (emissive) panes and a rod of alpha 0.4 in front of a dark opaque wall and in front of the
// background. The background had been composited by the alpha channel left in the framebuffer,
// which MuJoCo blends like a colour: 0.4 green over the wall came out brighter than the opaque
// green, and the wall did not darken it at all (outside probe BF).
TEST_F(RendererTest, TranslucentGeomsBlendWithWhatIsBehindThem) {
  auto picture = [](const std::string& alpha) {
    const std::string xml = R"(<mujoco><option gravity="0 0 0"/>
      <visual><headlight active="0" ambient="0 0 0" diffuse="0 0 0" specular="0 0 0"/></visual>
      <asset>
        <material name="wall" emission="1" specular="0" shininess="0" rgba="0.1 0.1 0.1 1"/>
        <material name="pane" emission="1" specular="0" shininess="0" rgba="0 0.5 0 )" + alpha + R"("/>
      </asset>
      <worldbody>
        <camera name="front" pos="0 -2 0" xyaxes="1 0 0 0 0 1"/>
        <geom type="box" pos="-0.5 0.5 0" size="0.5 0.01 1" material="wall" contype="0" conaffinity="0"/>
        <geom type="box" pos="0 0 0.2" size="0.6 0.01 0.1" material="pane" contype="0" conaffinity="0"/>
        <cosserat name="rod" pos="-0.6 0 -0.2" length="1.2" radius="0.05" material="pane" contype="0" conaffinity="0"/>
      </worldbody></mujoco>)";
    auto s = mj::load_scene_string(xml, "/tmp/cosserat_render_translucent.xml");
    mj::SceneData sd(*s);
    mj::fwd_position(*s, sd);
    rd::RenderOptions o = sized(200, 150);
    o.camera.name = "front";
    rd::Renderer r(*s, o);
    return r.render(sd);
  };
  const rd::Image glass = picture("0.4"), opaque = picture("1");
  const auto bg = background(sized(1, 1));
  // the wall alone (above the pane), at x = -0.3; the pane (z = 0.2) and the rod (z = -0.2) at x = -0.3
  // over the wall and at x = 0.3 over the background: 90.5 pixels a metre at the panes' depth
  const std::uint8_t* wall = glass.pixel(73, 30);
  for (const int row : {57, 93}) {
    SCOPED_TRACE(row == 57 ? "pane" : "rod");
    const std::uint8_t* solid = opaque.pixel(73, row);
    ASSERT_GT(solid[1], 150);  // the opaque green
    const double w = 1 - 0.6 * 0.6;
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(glass.pixel(73, row)[k], w * solid[k] + (1 - w) * wall[k], 3.0) << "over the wall, channel " << k;
      EXPECT_NEAR(glass.pixel(127, row)[k], w * opaque.pixel(127, row)[k] + (1 - w) * bg[k], 3.0)
          << "over the background, channel " << k;
    }
    EXPECT_LT(glass.pixel(73, row)[1], solid[1] - 30) << "darker than the opaque pane: the dark wall shows through";
  }
  EXPECT_LT(wall[0], 40);  // the wall is dark, and not the background
}

// The free camera draws what it frames whatever MuJoCo's clipping planes (<visual><map znear zfar>
// times stat.extent) say: a 5 cm rod 5 cm above a 50 m floor (framed about 7 cm away, where the near
// plane was at 0.01 x the floor's extent) was missing from the picture (outside probe BF).
TEST_F(RendererTest, FreeCameraIsNotClippedByMuJoCosPlanes) {
  const std::string xml = R"(<mujoco><option timestep="0.0005"/>
    <worldbody>
      <light pos="0 -1 3" dir="0 0.3 -1" directional="true"/>
      <geom name="ground" type="plane" size="50 50 0.1" rgba="0.3 0.3 0.35 1"/>
      <camera name="close" pos="0.025 -0.07 0.05" xyaxes="1 0 0 0 0 1"/>
      <cosserat name="whisker" pos="0 0 0.05" length="0.05" sections="2" radius="0.001" young="1e7" rgba="1 0 0 1"/>
    </worldbody></mujoco>)";
  auto s = mj::load_scene_string(xml, "/tmp/cosserat_render_whisker.xml");
  mj::SceneData sd(*s);
  mj::fwd_position(*s, sd);
  rd::Renderer r(*s, sized(320, 240));
  const rd::Image img = r.render(sd);
  int red = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const std::uint8_t* c = img.pixel(x, y);
      red += c[0] > 120 && c[1] < 60 && c[2] < 60;
    }
  EXPECT_GT(red, 500) << "the rod is drawn";
  const mjvGLCamera cam = mjv_averageCamera(&r.scene().camera[0], &r.scene().camera[1]);
  EXPECT_LT(cam.frustum_near, s->m->vis.map.znear * s->m->stat.extent) << "nearer than MuJoCo's plane";
  // a model camera keeps the model's planes
  rd::RenderOptions o = sized(64, 48);
  o.camera.name = "close";
  rd::Renderer fixed(*s, o);
  fixed.render(sd);
  EXPECT_FLOAT_EQ(mjv_averageCamera(&fixed.scene().camera[0], &fixed.scene().camera[1]).frustum_near,
                  static_cast<float>(s->m->vis.map.znear * s->m->stat.extent));
}

// What the pictures do not show as the model asks is said: a model's offsamples beyond OpenGL's
// most is lowered to it (outside probe BF: 8 drew 4 without a word, where --samples 8 is refused),
// and a texture on a rod's material is not drawn on its tube (the README had said the material
// passes to the rod).
TEST_F(RendererTest, WhatIsNotDrawnAsAskedIsSaid) {
  const std::string xml = R"(<mujoco>
    <visual><quality offsamples="1000"/></visual>
    <asset>
      <texture name="chk" type="2d" builtin="checker" rgb1="1 1 1" rgb2="0 0 0" width="64" height="64"/>
      <material name="chk" texture="chk" texrepeat="4 4"/>
      <material name="plain" rgba="0 0 1 1"/>
    </asset>
    <worldbody>
      <cosserat name="striped" pos="0 0 1" length="0.5" sections="2" radius="0.01" young="1e7" material="chk"/>
      <cosserat name="blue" pos="0 0.2 1" length="0.5" sections="2" radius="0.01" young="1e7" material="plain"/>
    </worldbody></mujoco>)";
  auto s = mj::load_scene_string(xml, "/tmp/cosserat_render_warnings.xml");
  rd::Renderer r(*s, sized(64, 48));
  ASSERT_EQ(r.warnings().size(), 2u);
  EXPECT_LT(r.samples(), 1000);
  EXPECT_GT(r.samples(), 0);
  EXPECT_NE(r.warnings()[0].find("offsamples=\"1000\"> is more than OpenGL here multisamples (" + std::to_string(r.samples())),
            std::string::npos)
      << r.warnings()[0];
  EXPECT_NE(r.warnings()[1].find("rod 'striped': the texture of its material 'chk' is not drawn"), std::string::npos)
      << r.warnings()[1];
  // coloured by strain, the texture is not missed; the option's samples are the option's
  rd::RenderOptions o = sized(64, 48);
  o.rods.coloring = rd::RodColoring::Strain;
  o.samples = 2;
  rd::Renderer strain(*s, o);
  EXPECT_TRUE(strain.warnings().empty());
  EXPECT_EQ(strain.samples(), 2);
}

TEST_F(RendererTest, BadCameraOrBodyIsAClearError) {
  Loaded l("cantilever.xml");
  rd::RenderOptions o;
  o.camera.name = "nope";
  try {
    rd::Renderer r(*l.scene, o);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("side"), std::string::npos) << e.what();  // lists the cameras
  }
  o.camera.name.clear();
  o.camera.track = "nobody";
  EXPECT_THROW(rd::Renderer(*l.scene, o), std::invalid_argument);
  o.camera.track.clear();
  o.width = 1 << 20;
  EXPECT_THROW(rd::Renderer(*l.scene, o), std::invalid_argument);
}

}  // namespace
