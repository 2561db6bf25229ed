// The fluid of a MuJoCo scene (plugin/mujoco/scene_fluid.cpp): who owns it, Stokes drag on a
// sphere (6 pi mu a U) and its terminal velocity, the assembled damping matrix against twists of
// every rod node and geom by finite differences, the implicit integration against RK4, and the
// MJCF checks of the fluid's attributes and custom fields.
#include "scene_fluid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "fluid.hpp"
#include "mjcf.hpp"
#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const char* kPath = "/tmp/cosserat_fluid_test.xml";

// The fluid damping in MuJoCo's sparse qM layout, as a dense symmetric matrix.
MatX dense_damping(const mjModel* m, const std::vector<mjtNum>& qD) {
  MatX D = MatX::Zero(m->nv, m->nv);
  for (int i = 0; i < m->nv; ++i) {
    int k = 0;
    for (int j = i; j >= 0; j = m->dof_parentid[j], ++k) D(i, j) = D(j, i) = qD[m->dof_Madr[i] + k];
  }
  return D;
}

const char* kSphere = R"(<mujoco>
  <option timestep="0.001" viscosity="3" density="1000" gravity="0 0 -9.81"/>
  <custom><text name="cosserat:fluid" data="gray-hancock"/></custom>
  <worldbody>
    <body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.02" mass="0.05"/></body>
  </worldbody>
</mujoco>)";

TEST(SceneFluid, SphereFeelsStokesDrag) {
  auto s = load_scene_string(kSphere, kPath);
  ASSERT_TRUE(s->fluid.active);
  EXPECT_EQ(s->fluid.viscosity, 3.0);
  EXPECT_EQ(s->m->opt.viscosity, 0.0);  // MuJoCo's own fluid is off
  EXPECT_EQ(s->m->opt.density, 0.0);
  SceneData sd(*s);
  const double mu = 3.0, a = 0.02;
  const Vec3 U(0.1, -0.2, 0.05), W(3.0, -1.0, 2.0);
  for (int i = 0; i < 3; ++i) sd.d->qvel[i] = U(i), sd.d->qvel[3 + i] = W(i);
  forward(*s, sd);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(sd.d->qfrc_passive[i], -6 * M_PI * mu * a * U(i), 1e-14);
    EXPECT_NEAR(sd.d->qfrc_passive[3 + i], -8 * M_PI * mu * a * a * a * W(i), 1e-16);
  }
}

// Falling under gravity, the sphere reaches U = m g / (6 pi mu a), stably even with a step far
// longer than its relaxation time m / (6 pi mu a) = 44 ms (the drag is implicit).
TEST(SceneFluid, SphereReachesStokesTerminalVelocity) {
  for (double h : {1e-3, 0.2}) {
    auto s = load_scene_string(kSphere, kPath);
    s->m->opt.timestep = h;
    EXPECT_EQ(s->integrator, Integrator::Euler);
    SceneData sd(*s);
    const int n = static_cast<int>(std::lround(4.0 / h));
    for (int k = 0; k < n; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
    const double Ut = 0.05 * 9.81 / (6 * M_PI * 3.0 * 0.02);
    EXPECT_NEAR(sd.d->qvel[2], -Ut, 1e-9 * Ut) << "h = " << h;
    EXPECT_NEAR(sd.d->qvel[0], 0.0, 1e-15);
  }
}

const char* kRodScene = R"(<mujoco>
  <option timestep="0.001" viscosity="VISC"/>
  <worldbody>
    <body name="hub" pos="0 0 0.5"><joint type="hinge" axis="0 0 1"/><geom type="sphere" size="0.02" mass="0.1"/>
      <cosserat name="r" length="0.2" sections="2" radius="0.003" young="1e6" ATTR/>
    </body>
  </worldbody>
</mujoco>)";

std::string rod_scene(const std::string& visc, const std::string& attr = "") {
  std::string x = kRodScene;
  x.replace(x.find("VISC"), 4, visc);
  x.replace(x.find("ATTR"), 4, attr);
  return x;
}

// Who owns the fluid: rods + viscosity: the plugin; no viscosity: nobody; a rod-free scene
// without markers: MuJoCo, bit for bit.
TEST(SceneFluid, OwnershipRules) {
  {
    auto s = load_scene_string(rod_scene("2"), kPath);
    EXPECT_TRUE(s->fluid.active);
    EXPECT_EQ(s->m->opt.viscosity, 0.0);
    EXPECT_GT(s->rods[0].model.nodes[s->rods[0].model.sections[0].first_node].drag.norm(), 0.0);
    ASSERT_EQ(s->fluid.bodies.size(), 1u);  // the hub's sphere
  }
  {
    auto s = load_scene_string(rod_scene("0"), kPath);
    EXPECT_FALSE(s->fluid.active);
    EXPECT_FALSE(has_drag(s->rods[0].model));
    EXPECT_TRUE(s->fluid.warnings.empty());
  }
  {  // density without viscosity: MuJoCo's own model on the rigid bodies, nothing on the rod, said
    std::string x = rod_scene("0");
    x.replace(x.find("viscosity=\"0\""), 13, "density=\"1000\"");
    auto s = load_scene_string(x, kPath);
    EXPECT_FALSE(s->fluid.active);
    EXPECT_EQ(s->m->opt.density, 1000.0);
    ASSERT_EQ(s->fluid.warnings.size(), 1u);
    EXPECT_NE(s->fluid.warnings[0].find("<option density> without <option viscosity>"), std::string::npos);
  }
  {
    auto s = load_scene_string(rod_scene("2", "drag=\"0\""), kPath);  // this rod is not in the fluid
    EXPECT_TRUE(s->fluid.active);
    for (const Node& n : s->rods[0].model.nodes) EXPECT_EQ(n.drag.norm(), 0.0);
  }
  {  // explicit coefficients: c_t, c_n, and c_rot = 4 pi mu a^2 by default
    auto s = load_scene_string(rod_scene("2", "drag=\"3 5\""), kPath);
    const Node& n = s->rods[0].model.nodes[s->rods[0].model.sections[0].first_node];
    EXPECT_NEAR(n.drag(3, 3), 3 * n.dX, 1e-15);
    EXPECT_NEAR(n.drag(4, 4), 5 * n.dX, 1e-15);
    EXPECT_NEAR(n.drag(0, 0), 4 * M_PI * 2 * 0.003 * 0.003 * n.dX, 1e-18);
  }
  {  // a given wavelength: Gray & Hancock with it
    auto s = load_scene_string(rod_scene("2", "wavelength=\"0.05\""), kPath);
    const Node& n = s->rods[0].model.nodes[s->rods[0].model.sections[0].first_node];
    EXPECT_NEAR(n.drag(4, 4), gray_hancock(2, 0.003, 0.05).cn * n.dX, 1e-14);
  }
  {  // Lighthill's coefficients for a helical rod: Lambda = one turn's arc length
    std::string x = rod_scene("2", "reststrain=\"40 0 60 1 0 0\"");
    x.replace(x.find("<worldbody>"), 11, R"(<custom><text name="cosserat:fluid" data="lighthill"/></custom><worldbody>)");
    auto s = load_scene_string(x, kPath);
    const Node& n = s->rods[0].model.nodes[s->rods[0].model.sections[0].first_node];
    const Helix hx = helix_of((Vec6() << 40, 0, 60, 1, 0, 0).finished());
    const RftCoefficients c = lighthill(2, 0.003, std::hypot(hx.pitch, 2 * M_PI * hx.radius));
    EXPECT_NEAR(n.drag(4, 4), c.cn * n.dX, 1e-14);
    EXPECT_NEAR(n.drag(3, 3), c.ct * n.dX, 1e-14);
  }
  {  // ... with a given wavelength: it is lambda along the helix's axis, Lambda = hypot(lambda, 2 pi R)
     // (outside probe AL: the README had said Lambda = wavelength; on a straight rod it is)
    std::string x = rod_scene("2", "reststrain=\"40 0 60 1 0 0\" wavelength=\"0.05\"");
    x.replace(x.find("<worldbody>"), 11, R"(<custom><text name="cosserat:fluid" data="lighthill"/></custom><worldbody>)");
    auto s = load_scene_string(x, kPath);
    const Node& n = s->rods[0].model.nodes[s->rods[0].model.sections[0].first_node];
    const Helix hx = helix_of((Vec6() << 40, 0, 60, 1, 0, 0).finished());
    const RftCoefficients c = lighthill(2, 0.003, std::hypot(0.05, 2 * M_PI * hx.radius));
    EXPECT_NEAR(n.drag(4, 4), c.cn * n.dX, 1e-14);
    EXPECT_NEAR(n.drag(3, 3), c.ct * n.dX, 1e-14);
    const RodFluidInfo& info = s->fluid.rods[0];
    EXPECT_EQ(info.law, RodFluidInfo::Law::Lighthill);
    EXPECT_EQ(info.wavelength, 0.05);
    EXPECT_NEAR(info.along_filament, std::hypot(0.05, 2 * M_PI * hx.radius), 1e-15);
    EXPECT_FALSE(info.default_wavelength);
    std::string straight = rod_scene("2", "wavelength=\"0.05\"");
    straight.replace(straight.find("<worldbody>"), 11,
                     R"(<custom><text name="cosserat:fluid" data="lighthill"/></custom><worldbody>)");
    auto t = load_scene_string(straight, kPath);
    const Node& nt = t->rods[0].model.nodes[t->rods[0].model.sections[0].first_node];
    EXPECT_NEAR(nt.drag(4, 4), lighthill(2, 0.003, 0.05).cn * nt.dX, 1e-14);
    EXPECT_EQ(t->fluid.rods[0].along_filament, 0.05);
  }
  {  // a curved rod twisted a little is no helix to the default wavelength: the planar rule's L/2,
     // the same coefficients as untwisted, and a warning; a real helix keeps its pitch (outside
     // probe BD: the pitch, going to zero with the twist, made c_t 31 times the planar arc's at a
     // twist of 0.03 1/m, and non-positive coefficients, refused, at 1e-3)
    auto arc = load_scene_string(rod_scene("2", "reststrain=\"0 0 10 1 0 0\""), kPath);
    const Node& na = arc->rods[0].model.nodes[arc->rods[0].model.sections[0].first_node];
    for (const char* twist : {"1e-6", "1e-3", "0.03", "0.9"}) {
      auto s = load_scene_string(rod_scene("2", std::string("reststrain=\"") + twist + " 0 10 1 0 0\""), kPath);
      const Node& n = s->rods[0].model.nodes[s->rods[0].model.sections[0].first_node];
      EXPECT_EQ(n.drag(3, 3), na.drag(3, 3)) << twist;
      EXPECT_EQ(n.drag(4, 4), na.drag(4, 4)) << twist;
      EXPECT_EQ(s->fluid.rods[0].wavelength, arc->fluid.rods[0].wavelength) << twist;
      ASSERT_EQ(s->fluid.warnings.size(), 1u) << twist;
      EXPECT_NE(s->fluid.warnings[0].find("section 0's rest shape is a helix whose pitch is under a tenth of a turn's "
                                          "arc length"),
                std::string::npos)
          << s->fluid.warnings[0];
    }
    auto helix = load_scene_string(rod_scene("2", "reststrain=\"1.2 0 10 1 0 0\""), kPath);
    EXPECT_TRUE(helix->fluid.rods[0].helical);
    EXPECT_NEAR(helix->fluid.rods[0].wavelength, 2 * M_PI * 1.2 / (100 + 1.44), 1e-15);
    EXPECT_TRUE(helix->fluid.warnings.empty());
  }
  {  // "mujoco": the rods feel no fluid, MuJoCo's own model stays on; a warning says so (outside
     // probe AL: a rod had sunk through it ten times as fast without a word)
    std::string x = rod_scene("2");
    x.replace(x.find("<worldbody>"), 11, R"(<custom><text name="cosserat:fluid" data="mujoco"/></custom><worldbody>)");
    auto s = load_scene_string(x, kPath);
    EXPECT_FALSE(s->fluid.active);
    EXPECT_EQ(s->m->opt.viscosity, 2.0);
    ASSERT_EQ(s->fluid.warnings.size(), 1u);
    EXPECT_NE(s->fluid.warnings[0].find("the rods feel no fluid force"), std::string::npos) << s->fluid.warnings[0];
  }
  // a rod-free scene with viscosity and no markers: MuJoCo's fluid, and Euler is mj_step
  const char* rigid = R"(<mujoco><option timestep="0.002" viscosity="0.5" density="1.2"/>
    <worldbody><body pos="0 0 1"><freejoint/><geom type="box" size="0.05 0.03 0.02" mass="0.3"/></body>
    <body pos="0.3 0 1"><joint type="hinge" axis="0 1 0" damping="0.1"/><geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01"/></body>
    </worldbody></mujoco>)";
  auto s = load_scene_string(rigid, kPath);
  EXPECT_FALSE(s->fluid.active);
  EXPECT_EQ(s->m->opt.viscosity, 0.5);
  SceneData sd(*s);
  mjData* ref = mj_makeData(s->m);
  for (int i = 0; i < s->m->nv; ++i) sd.d->qvel[i] = ref->qvel[i] = 0.3 * (i + 1);
  for (int k = 0; k < 200; ++k) {
    step(*s, sd);
    mj_step(s->m, ref);
  }
  for (int i = 0; i < s->m->nq; ++i) EXPECT_EQ(sd.d->qpos[i], ref->qpos[i]);
  mj_deleteData(ref);
}

// A tree with every kind of fluid element: a free body (ellipsoid, rotated and offset box, a
// slender capsule), a hinged child (cylinder with explicit coefficients), a soft rod on it and a
// sphere at the rod's tip.
const char* kTree = R"(<mujoco>
  <option timestep="0.001" viscosity="1.7" gravity="0 0 0"/>
  <custom>
    <numeric name="cosserat:drag:stick" data="4 7 0.01"/>
    <numeric name="cosserat:drag:deco" data="0"/>
  </custom>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" euler="0.3 0.2 0.1"><freejoint/>
      <geom type="ellipsoid" size="0.05 0.03 0.02" pos="0.01 0 0" density="1000"/>
      <geom type="box" size="0.02 0.01 0.015" pos="0.02 0.03 -0.01" euler="0.5 0.1 -0.3" density="1000"/>
      <geom type="capsule" fromto="-0.05 0 0 -0.05 0.2 0.05" size="0.004" density="1000"/>
      <geom name="deco" type="sphere" size="0.01" pos="0 0 0.05" density="1000"/>
      <body name="arm" pos="0.06 0 0">
        <joint type="hinge" axis="0 1 0.3"/>
        <geom name="stick" type="cylinder" fromto="0 0 0 0.08 0.01 0" size="0.005" density="1000"/>
        <cosserat name="r" pos="0.08 0.01 0" length="0.15" sections="2" strain="kl" radius="0.004 0.002"
                  reststrain="8 0 20 1 0 0" young="2e5">
          <body name="tip"><geom type="sphere" size="0.008" pos="0.01 0 0" density="1000"/></body>
        </cosserat>
      </body>
    </body>
  </worldbody>
</mujoco>)";

// Resistance of a geom in its own frame, from the core formulas (the rules of scene_fluid.hpp).
Mat6 geom_C(const mjModel* m, int g, double mu) {
  const mjtNum* sz = m->geom_size + 3 * g;
  const char* name = mj_id2name(m, mjOBJ_GEOM, g);
  const std::string n = name ? name : "";
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE: return n == "deco" ? Mat6::Zero() : sphere_resistance(mu, sz[0]);
    case mjGEOM_ELLIPSOID:
    case mjGEOM_BOX: return ellipsoid_resistance(mu, Vec3(sz[0], sz[1], sz[2]));
    case mjGEOM_CAPSULE: {
      const double L = 2 * sz[1] + 2 * sz[0];
      return segment_resistance(gray_hancock(mu, sz[0], L / 2), L, 2);
    }
    case mjGEOM_CYLINDER: return segment_resistance(RftCoefficients{4, 7, 0.01}, 2 * sz[1], 2);
  }
  return Mat6::Zero();
}

// D = sum over rod nodes and geoms of J^T C J, the twists J by finite differences of the frames.
TEST(SceneFluid, DampingMatchesFiniteDifferenceTwists) {
  auto s = load_scene_string(kTree, kPath);
  ASSERT_TRUE(s->fluid.active);
  const mjModel* m = s->m;
  SceneData sd(*s);
  // a bent, moved configuration
  for (int i = 0; i < m->nv; ++i) sd.d->qvel[i] = 0.0;
  mj_integratePos(m, sd.d->qpos, std::vector<mjtNum>(m->nv, 0.3).data(), 1.0);
  const std::vector<mjtNum> q0(sd.d->qpos, sd.d->qpos + m->nq);
  forward(*s, sd);
  const MatX D = dense_damping(m, sd.fluid_qD);

  const auto& rod = s->rods[0];
  std::vector<int> nodes;
  for (size_t i = 0; i < rod.model.nodes.size(); ++i)
    if (rod.model.nodes[i].dX > 0) nodes.push_back(static_cast<int>(i));
  auto frames = [&](const std::vector<mjtNum>& q) {
    std::copy(q.begin(), q.end(), sd.d->qpos);
    fwd_position(*s, sd);
    std::vector<SE3> f;
    for (int i : nodes) f.push_back(rod_frame(*s, sd, 0, rod.model.nodes[i].X));
    for (int g = 0; g < m->ngeom; ++g) {
      SE3 x;
      for (int r = 0; r < 3; ++r) {
        x.u(r) = sd.d->geom_xpos[3 * g + r];
        for (int c = 0; c < 3; ++c) x.R(r, c) = sd.d->geom_xmat[9 * g + 3 * r + c];
      }
      f.push_back(x);
    }
    return f;
  };
  const std::vector<SE3> f0 = frames(q0);
  std::vector<Mat6> C;
  for (int i : nodes) C.push_back(rod.model.nodes[i].drag);
  for (int g = 0; g < m->ngeom; ++g) C.push_back(s->geom_rod[g] >= 0 ? Mat6::Zero() : geom_C(m, g, 1.7));
  std::vector<MatX> J(f0.size(), MatX::Zero(6, m->nv));
  const double e = 1e-6;
  for (int k = 0; k < m->nv; ++k) {
    std::vector<mjtNum> dv(m->nv, 0.0), qp = q0, qm = q0;
    dv[k] = 1.0;
    mj_integratePos(m, qp.data(), dv.data(), e);
    mj_integratePos(m, qm.data(), dv.data(), -e);
    const auto fp = frames(qp), fm = frames(qm);
    for (size_t x = 0; x < f0.size(); ++x)
      J[x].col(k) = (log_se3(f0[x].inverse() * fp[x]) - log_se3(f0[x].inverse() * fm[x])) / (2 * e);
  }
  MatX ref = MatX::Zero(m->nv, m->nv);
  for (size_t x = 0; x < f0.size(); ++x) ref.noalias() += J[x].transpose() * C[x] * J[x];
  EXPECT_LT((D - ref).norm(), 1e-7 * ref.norm()) << "D\n" << D << "\nref\n" << ref;

  // and the force is -D qvel
  std::copy(q0.begin(), q0.end(), sd.d->qpos);
  VecX v = VecX::Random(m->nv);
  for (int i = 0; i < m->nv; ++i) sd.d->qvel[i] = v(i);
  forward(*s, sd);
  const VecX Dv = Eigen::Map<const VecX>(sd.fluid_f.data(), m->nv);
  EXPECT_LT((Dv - dense_damping(m, sd.fluid_qD) * v).norm(), 1e-12 * (D * v).norm());
}

// The implicit treatment of the fluid is consistent with the explicit force: a motor-driven soft
// rod in a viscous fluid, implicit Euler against RK4 at the same small step (they agree to O(h)),
// and the implicit step stays stable at a step where explicit drag would not.
TEST(SceneFluid, ImplicitDragAgreesWithRK4) {
  // (kl: the twist relaxes in rho a^2 / (8 mu) = 0.25 ms, within RK4's reach at 20 us)
  std::string x = rod_scene("5", "strain=\"kl\" reststrain=\"0 0 30 1 0 0\" density=\"1100\"");
  x.replace(x.find("</worldbody>"), 12, "</worldbody><actuator><motor joint=\"hinge\" gear=\"1\"/></actuator>");
  x.replace(x.find("<joint type=\"hinge\""), 19, "<joint name=\"hinge\" type=\"hinge\"");
  auto run = [&](Integrator integ, double h, double T) {
    auto s = load_scene_string(x, kPath);
    s->m->opt.timestep = h;
    SceneData sd(*s);
    sd.d->ctrl[0] = 0.02;
    const int n = static_cast<int>(std::lround(T / h));
    for (int k = 0; k < n; ++k)
      if (step(*s, sd, integ) != Status::Ok) return Vec3(Vec3::Constant(NAN));
    forward(*s, sd);
    return rod_frame(*s, sd, 0, 0.2).u;
  };
  const Vec3 a = run(Integrator::Implicit, 2e-5, 0.1), b = run(Integrator::RK4, 2e-5, 0.1);
  const Vec3 c = run(Integrator::Implicit, 1e-5, 0.1);
  ASSERT_TRUE(a.allFinite() && b.allFinite());
  const double moved = (b - run(Integrator::Implicit, 1e-3, 0.0)).norm();
  EXPECT_GT(moved, 0.01);
  // first order: halving h halves the gap to RK4
  std::printf("tip moved %.4g m; |implicit - RK4| = %.3g (h = 2e-5), %.3g (h = 1e-5)\n", moved, (a - b).norm(), (c - b).norm());
  EXPECT_LT((a - b).norm(), 1e-4 * moved);
  EXPECT_NEAR((a - b).norm() / (c - b).norm(), 2.0, 0.3);
  EXPECT_TRUE(run(Integrator::Implicit, 1e-3, 0.3).allFinite());
  EXPECT_FALSE(run(Integrator::RK4, 1e-3, 0.3).allFinite());  // explicit drag at 1 ms: unstable
}

// Bad fluid input is a LoadError naming the file and line.
// What a scene asks of the fluid and does not get is a warning (SceneFluid::warnings, which the
// command-line tool prints): MuJoCo's density and wind, coefficients per unit length on a sphere or
// on a body without capsules or cylinders, coefficients without viscosity. Until an outside probe,
// all of it was silent. The shipped swimmers have none.
TEST(SceneFluid, WarningsSayWhatTheFluidIgnores) {
  auto warned = [](const std::string& xml, const std::string& text) {
    auto s = load_scene_string(xml, kPath);
    for (const auto& w : s->fluid.warnings)
      if (w.find(text) != std::string::npos) return true;
    ADD_FAILURE() << "no warning with '" << text << "' (" << s->fluid.warnings.size() << " warnings)";
    return false;
  };
  std::string windy = rod_scene("2");
  windy.replace(windy.find("<option "), 8, "<option density=\"1000\" wind=\"0.1 0 0\" ");
  EXPECT_TRUE(warned(windy, "<option density> ignored"));
  EXPECT_TRUE(warned(windy, "<option wind> ignored"));
  // coefficients per unit length on the hub (a body with one sphere) and on the sphere itself
  std::string on_hub = rod_scene("2");
  on_hub.replace(on_hub.find("<worldbody>"), 11,
                 R"(<custom><numeric name="cosserat:drag:hub" data="1 2"/></custom><worldbody>)");
  EXPECT_TRUE(warned(on_hub, "body 'hub' has none"));
  std::string on_sphere = rod_scene("2");
  on_sphere.replace(on_sphere.find("<geom type=\"sphere\""), 5, "<geom name=\"ball\"");
  on_sphere.replace(on_sphere.find("<worldbody>"), 11,
                    R"(<custom><numeric name="cosserat:drag:ball" data="1 2"/></custom><worldbody>)");
  EXPECT_TRUE(warned(on_sphere, "geom 'ball' keeps its Stokes resistance"));
  EXPECT_TRUE(warned(rod_scene("0", "drag=\"1 2\""), "<option viscosity> is 0"));
  for (const char* model : {"flagellate.xml", "flagellate_rigid.xml", "lophotrichous.xml"}) {
    auto s = load_scene(std::string(COSSERAT_SOURCE_DIR) + "/models/" + model);
    EXPECT_TRUE(s->fluid.warnings.empty()) << model << ": " << s->fluid.warnings.front();
  }
}

TEST(SceneFluid, BadInputNamesFileAndLine) {
  struct Case {
    std::string xml;
    int line;
    std::string message;
  };
  const std::string head = "<mujoco>\n<option viscosity=\"1\"/>\n";
  const std::string body = "<worldbody>\n<body name=\"b\"><freejoint/><geom name=\"g\" type=\"sphere\" size=\"0.1\"/></body>\n</worldbody>\n";
  const std::string rod = "<worldbody>\n<cosserat name=\"a\" length=\"1\" ";
  const std::vector<Case> cases = {
      {head + rod + "drag=\"1\"/>\n</worldbody>\n</mujoco>", 4, "'drag' needs 'c_t c_n [c_rot]'"},
      {head + rod + "drag=\"-1 2\"/>\n</worldbody>\n</mujoco>", 4, "'drag' coefficients must be positive"},
      {head + rod + "drag=\"1 2 3 4\"/>\n</worldbody>\n</mujoco>", 4, "'drag' needs 1 to 3"},
      {head + rod + "wavelength=\"0\"/>\n</worldbody>\n</mujoco>", 4, "'wavelength' must be positive"},
      {head + rod + "wavelength=\"1\" drag=\"1 2\"/>\n</worldbody>\n</mujoco>", 4, "conflicts with 'drag'"},
      {head + rod + "radius=\"0.5\" wavelength=\"0.3\"/>\n</worldbody>\n</mujoco>", 4, "too thick"},
      {head + "<custom>\n<numeric name=\"cosserat:drag:nosuch\" data=\"1 2\"/>\n</custom>\n" + body + "</mujoco>", 4,
       "names no geom or body 'nosuch'"},
      // the rod's own bodies take its drag attribute (this said "names no geom or body 'a/base'")
      {head + "<custom>\n<numeric name=\"cosserat:drag:a/base\" data=\"1 2\"/>\n</custom>\n" + rod + "/>\n</worldbody>\n</mujoco>",
       4, "names rod 'a' or a part of it"},
      {head + "<custom>\n<numeric name=\"cosserat:drag:g\" data=\"1\"/>\n</custom>\n" + body + "</mujoco>", 4,
       "needs 'c_t c_n [c_rot]'"},
      {head + "<custom>\n<numeric name=\"cosserat:drag:b\" data=\"1 -2\"/>\n</custom>\n" + body + "</mujoco>", 4,
       "must be positive"},
      {head + "<custom>\n\n<text name=\"cosserat:fluid\" data=\"stokes\"/>\n</custom>\n" + body + "</mujoco>", 5,
       "'gray-hancock', 'lighthill' or 'mujoco'"},
      {head + "<custom>\n<numeric name=\"cosserat:dreg:g\" data=\"1 2\"/>\n</custom>\n" + body + "</mujoco>", 4,
       "unknown cosserat field"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.xml);
    try {
      load_scene_string(c.xml, kPath);
      ADD_FAILURE() << "no LoadError";
    } catch (const LoadError& e) {
      EXPECT_EQ(e.line, c.line) << e.what();
      EXPECT_NE(e.message.find(c.message), std::string::npos) << e.what();
    }
  }
}

}  // namespace
