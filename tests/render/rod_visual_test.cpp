// Rod tubes as geometry (render/rod_visual.hpp), without OpenGL: rings on the solver's centreline
// with the tapered radius, sampling that follows the bending, visibility and colouring fields.
#include "rod_visual.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "kinematics.hpp"

#include "support/loaded_scene.hpp"

using namespace cosserat;
namespace rd = cosserat::render;

namespace {

using Loaded = cosserat::testing::LoadedScene;

// The abstract scene MuJoCo makes for the state (what the renderer hands to rod_tubes).
struct AbstractScene {
  mjvScene scn;
  mjvOption opt;
  mjvCamera cam;
  AbstractScene(const mj::Scene& s, const mj::SceneData& sd, int show_group = -1) {
    mjv_defaultScene(&scn);
    mjv_defaultOption(&opt);
    mjv_defaultCamera(&cam);
    if (show_group >= 0) opt.geomgroup[show_group] = 1;
    mjv_makeScene(s.m, &scn, 1000);
    mjv_updateScene(s.m, sd.d, &opt, nullptr, &cam, mjCAT_ALL, &scn);
  }
  ~AbstractScene() { mjv_freeScene(&scn); }
};

TEST(RodVisualTest, TubeFollowsTheCentrelineWithTheTaperedRadius) {
  Loaded l("octopus_arm.xml", 0.1);
  AbstractScene a(*l.scene, *l.data);
  const int before = a.scn.ngeom;
  const auto tubes = rd::rod_tubes(*l.scene, *l.data, {}, &a.scn);
  EXPECT_EQ(a.scn.ngeom, before - static_cast<int>(l.scene->rods[0].geom_id.size()) - 2)  // capsules, base and tip sites
      << "the rod's capsules and generated sites leave the scene";
  for (int i = 0; i < a.scn.ngeom; ++i) {
    if (a.scn.geoms[i].objtype == mjOBJ_GEOM) {
      EXPECT_LT(l.scene->geom_rod[a.scn.geoms[i].objid], 0);
    }
  }
  ASSERT_EQ(tubes.size(), 1u);
  const Rod& rod = l.scene->rods[0].model.rods[0];
  const auto& rings = tubes[0].rings;
  EXPECT_NEAR(rings.front().radius, 0.0, 1e-12);  // round ends
  EXPECT_NEAR(rings.back().radius, 0.0, 1e-12);
  const auto X = rd::rod_samples(*l.scene, *l.data, 0, {});
  ASSERT_EQ(rings.size(), X.size() + 16);  // 8 rings per round end
  for (size_t i = 0; i < X.size(); ++i) {
    const rd::TubeRing& ring = rings[i + 8];
    EXPECT_LT((ring.centre - rod_pose(l.scene->rods[0].model, l.data->rod[0], 0, X[i]).u).norm(), 1e-12);
    EXPECT_NEAR(ring.radius, rod.radius(X[i]), 1e-12);
    EXPECT_NEAR(ring.t.dot(ring.u), 0.0, 1e-12);
    EXPECT_NEAR(ring.v.dot(ring.t.cross(ring.u)), 1.0, 1e-12);
    EXPECT_GT(ring.tilt, 0.0);  // the surface faces a little towards the thinner tip
  }
}

TEST(RodVisualTest, TubesFollowTheVisibilityOfTheRodsCapsules) {
  const std::string xml = R"(<mujoco><worldbody>
      <cosserat name="rod" length="0.3" sections="3" radius="0.01" rgba="0.2 0.4 0.9 1" group="3"/>
    </worldbody></mujoco>)";
  auto s = mj::load_scene_string(xml, "/tmp/cosserat_render_group.xml");
  mj::SceneData sd(*s);
  mj::fwd_position(*s, sd);
  AbstractScene hidden(*s, sd);
  EXPECT_TRUE(rd::rod_tubes(*s, sd, {}, &hidden.scn).empty()) << "group 3 is hidden by default";
  AbstractScene shown(*s, sd, 3);
  const auto tubes = rd::rod_tubes(*s, sd, {}, &shown.scn);
  ASSERT_EQ(tubes.size(), 1u);
  EXPECT_FALSE(tubes[0].ring_colors);
  EXPECT_FLOAT_EQ(tubes[0].look.rgba[2], 0.9f);
}

TEST(RodVisualTest, TubesAreSmoothAtAnyPhysicsResolution) {
  // the samples follow the solver's strain: dense where the centreline bends, not per section
  Loaded l("octopus_arm.xml");
  const auto straight = rd::rod_samples(*l.scene, *l.data, 0, {});
  EXPECT_GE(straight.size(), 17u);
  EXPECT_NEAR(straight.back(), 0.35, 1e-12);
  // bend it: a curvature change of 20 rad/m in every section (1 rad over 5 cm)
  const auto& binding = l.scene->rods[0];
  for (size_t j = 0; j < binding.decl.joints.size(); ++j)
    if (binding.decl.joints[j].ends_with("/kz")) l.data->d->qpos[binding.qpos0 + j] = 20.0;
  mj::fwd_position(*l.scene, *l.data);
  const auto bent = rd::rod_samples(*l.scene, *l.data, 0, {});
  const auto pts = mj::rod_centerline(*l.scene, *l.data, 0, 2);
  ASSERT_GT((pts[1] - pts[0]).norm(), 0.0);
  EXPECT_GE(bent.size(), 0.35 * 20 / 0.05);  // at most 0.05 rad between rings
  for (size_t i = 0; i + 1 < bent.size(); ++i) EXPECT_LE((bent[i + 1] - bent[i]) * 20.0, 0.05 + 1e-9);
}

TEST(RodVisualTest, StrainAndStressOfAUniformBend) {
  // curvature change kz = c everywhere: surface strain r c, stress E r c (no shear)
  Loaded l("cantilever.xml");
  const auto& binding = l.scene->rods[0];
  for (size_t j = 0; j < binding.decl.joints.size(); ++j)
    if (binding.decl.joints[j].ends_with("/kz")) l.data->d->qpos[binding.qpos0 + j] = 0.5;
  mj::fwd_position(*l.scene, *l.data);
  const double r = 0.01, E = 1e8;
  for (double X : {0.01, 0.2, 0.49}) {
    EXPECT_NEAR(rd::rod_strain_magnitude(*l.scene, *l.data, 0, X), r * 0.5, 1e-12);
    EXPECT_NEAR(rd::rod_stress_magnitude(*l.scene, *l.data, 0, X), E * r * 0.5, 1e-3);
  }
  // coloured by strain: every ring carries the top colour of the map (uniform field)
  AbstractScene a(*l.scene, *l.data);
  rd::RodVisualOptions o;
  o.coloring = rd::RodColoring::Strain;
  const auto tubes = rd::rod_tubes(*l.scene, *l.data, o, &a.scn);
  ASSERT_EQ(tubes.size(), 1u);
  EXPECT_TRUE(tubes[0].ring_colors);
  float top[3];
  rd::colormap(1.0, top);
  for (const auto& ring : tubes[0].rings) EXPECT_FLOAT_EQ(ring.rgba[0], top[0]);
  // with a fixed scale twice the strain, the middle of the map
  o.color_max = 2 * r * 0.5;
  AbstractScene b(*l.scene, *l.data);
  float mid[3];
  rd::colormap(0.5, mid);
  EXPECT_NEAR(rd::rod_tubes(*l.scene, *l.data, o, &b.scn)[0].rings[10].rgba[1], mid[1], 1e-6);
}

TEST(RodVisualTest, ColourMapEndsAndNames) {
  float lo[3], hi[3], nan[3];
  rd::colormap(-1.0, lo);
  rd::colormap(2.0, hi);
  rd::colormap(std::nan(""), nan);
  EXPECT_LT(lo[1], 0.1f);  // dark violet
  EXPECT_GT(hi[0] + hi[1], 1.8f);  // yellow
  EXPECT_FLOAT_EQ(nan[0], lo[0]);
  EXPECT_EQ(rd::parse_rod_coloring("stress"), rd::RodColoring::Stress);
  EXPECT_THROW(rd::parse_rod_coloring("heat"), std::invalid_argument);
}

}  // namespace
