// Cables: a MuJoCo tendon through sites along an arm (the discrete routing a MuJoCo user writes)
// against the core's continuous internal cable actuation (tau = -T dl/dq, plugin/core), which it
// must approach as the sites get denser.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "scene.hpp"
#include "statics.hpp"
#include "support/bent_motion.hpp"
#include "support/text_file.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

constexpr double kL = 0.3, kR = 0.01, kD = 0.006, kT = 0.5;  // cable 6 mm off-centre, 0.5 N

std::string arm(int nsites) {
  std::string sites, path;
  for (int i = 0; i < nsites; ++i) {
    const double X = kL * i / (nsites - 1);
    sites += "<site name=\"c" + std::to_string(i) + "\" at=\"" + std::to_string(X) + "\" pos=\"0 " + std::to_string(kD) +
             " 0\"/>";
    path += "<site site=\"c" + std::to_string(i) + "\"/>";
  }
  // heavy Kelvin-Voigt damping: the run relaxes to the static shape
  return "<mujoco><option timestep=\"0.001\" gravity=\"0 0 0\"/><worldbody>"
         "<cosserat name=\"arm\" length=\"0.3\" sections=\"6\" strain=\"kl\" radius=\"0.01\" density=\"1000\" "
         "young=\"1e6\" poisson=\"0.5\" viscosity=\"3e4\">" +
         sites + "</cosserat></worldbody><tendon><spatial name=\"cable\">" + path +
         "</spatial></tendon><actuator><motor tendon=\"cable\" gear=\"-1\"/></actuator></mujoco>";
}

// tip position of the MuJoCo arm pulled by the tendon, after relaxing
Vec3 mujoco_tip(int nsites) {
  auto s = load_scene_string(arm(nsites), "/tmp/cosserat_cable_test.xml");
  SceneData sd(*s);
  sd.d->ctrl[0] = kT;
  for (int k = 0; k < 12000; ++k) EXPECT_EQ(step(*s, sd), Status::Ok);
  forward(*s, sd);
  double vmax = 0.0;
  for (int i = 0; i < s->m->nv; ++i) vmax = std::max(vmax, std::abs(sd.d->qvel[i]));
  EXPECT_LT(vmax, 1e-6) << "not at rest after relaxing";
  const int tip = mj_name2id(s->m, mjOBJ_SITE, "arm/tip");
  return Vec3(sd.d->site_xpos[3 * tip], sd.d->site_xpos[3 * tip + 1], sd.d->site_xpos[3 * tip + 2]);
}

TEST(Cable, TendonThroughSitesConvergesToContinuousCable) {
  // reference: the same rod with the core's continuous cable, solved statically
  Model m;
  m.gravity.setZero();
  RodSpec spec;
  spec.name = "arm";
  spec.length = kL;
  spec.radius_base = kR;
  spec.sections = 6;
  spec.section.dofs = *strain_mask_from_name("kl");
  spec.section.material = RodMaterial{1000.0, 1e6, 0.5, 0.0};
  const int r = m.add_rod(-1, SE3::Identity(), spec);
  Cable c;
  c.rod = r;
  c.d_begin = c.d_end = Vec3(0, kD, 0);
  m.add_cable(c);
  m.finalize();
  Data d(m);
  d.ctrl(0) = kT;
  ASSERT_TRUE(equilibrium(m, d).converged);
  fwd_position(m, d);
  const Vec3 ref = d.g[m.rods[r].tip_node].u;
  // the cable bends the arm toward its side (+y) and shortens it
  EXPECT_GT(ref.y(), 0.01);
  EXPECT_LT(ref.x(), kL);
  double prev = 1e300;
  for (int n : {3, 5, 9, 17}) {
    const double err = (mujoco_tip(n) - ref).norm();
    std::printf("%2d sites: tip %.3e m from the continuous cable (tip deflection %.3f m)\n", n, err, ref.y());
    EXPECT_LT(err, 0.7 * prev);  // denser routing approaches the continuous cable
    prev = err;
  }
  EXPECT_LT(prev, 0.02 * ref.y());
}

// Every tendon's Jacobian row (ten_J, with the coupling's correction for sites that ride on rod
// cross-sections between the proxies) against a central difference of its length along the
// velocity of cosserat::testing::BentMotion: every dof's column is right. Leaves the scene evaluated there.
void expect_tendon_rows_match_length_differences(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  ASSERT_EQ(m->nq, m->nv);  // hinges and strains: qpos moves linearly with qvel
  const cosserat::testing::BentMotion motion(m);
  const std::vector<double>& v = motion.v;
  auto lengths_at = [&](double t) {
    motion.at(s, sd, t);
    return std::vector<double>(sd.d->ten_length, sd.d->ten_length + m->ntendon);
  };
  const double eps = 1e-6;
  const std::vector<double> lp = lengths_at(eps), lm = lengths_at(-eps);
  lengths_at(0.0);
  for (int t = 0; t < m->ntendon; ++t) {
    const double fd = (lp[t] - lm[t]) / (2 * eps);
    double Jv = 0.0, scale = 0.0;
    const mjtNum* J = tendon_jacobian_row(s, sd, t);
    for (int i = 0; i < m->nv; ++i) {
      Jv += J[i] * v[i];
      scale += std::abs(J[i] * v[i]);
    }
    EXPECT_GT(scale, 1e-3) << "tendon " << t;
    EXPECT_NEAR(Jv, fd, 1e-7 * scale) << "tendon " << t;
  }
}

// A cable through four sites at a bent state with a rigid hinge above the rod; a second one from
// the rod's generated base site (on the rod's base body, which MuJoCo moves itself: no correction)
// through a site of section 0 to the generated tip site, the README's own cable.
TEST(Cable, TendonJacobianMatchesLengthDifferences) {
  const std::string xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01">
        <site name="a" at="0.04" pos="0 0.006 0"/><site name="b" at="0.13" pos="0 0.006 0.002"/>
        <site name="c" at="0.2" pos="0 -0.004 0.005"/><site name="d" at="0.29" pos="0 0.006 0"/>
      </cosserat></body></worldbody>
    <tendon><spatial name="cable"><site site="a"/><site site="b"/><site site="c"/><site site="d"/></spatial>
      <spatial name="from_base"><site site="arm/base"/><site site="a"/><site site="arm/tip"/></spatial></tendon>
  </mujoco>)";
  auto s = load_scene_string(xml, "/tmp/cosserat_cable_test.xml");
  SceneData sd(*s);
  expect_tendon_rows_match_length_differences(*s, sd);
}

// Three cables through the same cross-sections (an arm's spacer disks: one abscissa, three offsets)
// share each abscissa's pose and section Jacobian (RodBinding::site_point): every site stays where
// rod_pose puts it, bit for bit, and every cable's Jacobian row matches its length differences.
TEST(Cable, CablesThroughOneCrossSectionShareItsPoseAndJacobian) {
  std::string sites, tendons;
  const char* offsets[3] = {"0 0 0.006", "0 -0.0052 -0.003", "0 0.0052 -0.003"};
  for (int c = 0; c < 3; ++c) {
    tendons += "<spatial name=\"t" + std::to_string(c) + "\">";
    for (int i = 0; i < 5; ++i) {
      const std::string name = "s" + std::to_string(c) + std::to_string(i);
      sites += "<site name=\"" + name + "\" at=\"" + std::to_string(0.07 * i + 0.01) + "\" pos=\"" + offsets[c] + "\"/>";
      tendons += "<site site=\"" + name + "\"/>";
    }
    tendons += "</spatial>";
  }
  const std::string xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01">)" +
                          sites + "</cosserat></body></worldbody><tendon>" + tendons + "</tendon></mujoco>";
  auto s = load_scene_string(xml, "/tmp/cosserat_cable_test.xml");
  const mjModel* m = s->m;
  const RodBinding& rb = s->rods[0];
  auto index = [&](int c, int i) {  // the rod's index of site s<c><i>
    const int id = mj_name2id(m, mjOBJ_SITE, ("s" + std::to_string(c) + std::to_string(i)).c_str());
    return static_cast<int>(std::find(rb.site_id.begin(), rb.site_id.end(), id) - rb.site_id.begin());
  };
  for (int c = 0; c < 3; ++c)  // the first cable's site at each abscissa holds it for all three
    for (int i = 0; i < 5; ++i) EXPECT_EQ(rb.site_point[index(c, i)], index(0, i)) << "cable " << c << " site " << i;
  SceneData sd(*s);
  expect_tendon_rows_match_length_differences(*s, sd);
  for (size_t k = 0; k < rb.site_id.size(); ++k) {
    const RodSiteDecl& sdl = rb.decl.sites[k];
    SE3 g = rod_pose(rb.model, sd.rod[0], 0, sdl.X);
    g.u += g.R * sdl.pos;
    for (int e = 0; e < 3; ++e) EXPECT_EQ(sd.d->site_xpos[3 * rb.site_id[k] + e], g.u(e)) << "site " << k;
  }
}

// A cable from a fixed anchor around a cylinder (a pulley at the arm's base, sidesite above it) to
// sites on the rod: the length's derivative by a rod site's position is the unit vector from the
// path point before it (here the cylinder's tangent point: the wrapped length is stationary in the
// tangent points), so the rod sites' corrections hold next to a wrapping geom too.
TEST(Cable, TendonWrappingAGeomNextToARodSiteMatchesLengthDifferences) {
  const std::string xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <site name="anchor" pos="-0.08 0 0.985"/><site name="side" pos="-0.03 0 1.03"/>
    <geom name="pulley" type="cylinder" pos="-0.03 0 0.995" size="0.012 0.01" euler="90 0 0" contype="0" conaffinity="0"/>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.005" contype="0" conaffinity="0"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
        <site name="a" at="0.06" pos="0 0.003 0.006"/><site name="b" at="0.17" pos="0 0.006 0.002"/>
        <site name="c" at="0.28" pos="0 -0.004 0.005"/>
      </cosserat></body></worldbody>
    <tendon><spatial name="cable"><site site="anchor"/><geom geom="pulley" sidesite="side"/><site site="a"/>
      <site site="b"/><site site="c"/></spatial></tendon>
  </mujoco>)";
  auto s = load_scene_string(xml, "/tmp/cosserat_cable_test.xml");
  SceneData sd(*s);
  expect_tendon_rows_match_length_differences(*s, sd);
  // the cable wraps the cylinder at that state: two tangent points between the anchor and site a
  ASSERT_EQ(sd.d->ten_wrapnum[0], 6);
  EXPECT_EQ(sd.d->wrap_obj[1], mj_name2id(s->m, mjOBJ_GEOM, "pulley"));
  EXPECT_EQ(sd.d->wrap_obj[2], mj_name2id(s->m, mjOBJ_GEOM, "pulley"));
}

// A cable with a pulley (MuJoCo's <pulley divisor>: the branches after it count 1/divisor of their
// length) through rod sites on both sides of it.
TEST(Cable, TendonWithAPulleyThroughRodSitesMatchesLengthDifferences) {
  const std::string xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <site name="anchor" pos="-0.08 0 0.985"/><site name="anchor2" pos="-0.08 0 1.02"/>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.005"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01">
        <site name="a" at="0.06" pos="0 0.003 0.006"/><site name="b" at="0.17" pos="0 0.006 0.002"/>
        <site name="c" at="0.28" pos="0 -0.004 0.005"/>
      </cosserat></body></worldbody>
    <tendon><spatial name="cable"><site site="anchor"/><site site="a"/><pulley divisor="2"/><site site="anchor2"/>
      <site site="b"/><site site="c"/></spatial></tendon>
  </mujoco>)";
  auto s = load_scene_string(xml, "/tmp/cosserat_cable_test.xml");
  SceneData sd(*s);
  expect_tendon_rows_match_length_differences(*s, sd);
}

}  // namespace

namespace {

// Two cable-driven arms on separate bodies: 64 dofs, where MuJoCo 2.2.2's jacobian="auto" stores
// the tendon Jacobian compressed, which the coupling reads and patches as dense rows. Outside probe
// X: arm B's cable then pulled with the wrong forces (its tip 11 mm, 5.5% of the arm, from where
// the same arm alone ends up) and a two-arm grasp blew up. A scene with rods and tendons now uses
// dense Jacobians: both rows match length differences, and arm B under its cable ends where the
// lone arm B does, to round-off.
// MuJoCo 2.2.2 keeps the tendon Jacobian compressed where its Jacobians are sparse (jacobian="auto"
// from nv = 60 on): the rod-site corrections go into those rows (outside probe X: as dense rows
// they had given a second cable-driven arm the wrong cable forces, and a two-arm grasp blew up).
TEST(Cable, TwoArmsWithCablesBeyondSixtyDofsMatchTheLoneArm) {
  const std::string data = std::string(COSSERAT_SOURCE_DIR) + "/tests/mujoco/data/";
  auto two = load_scene(data + "two_arms_cables.xml");
  ASSERT_GE(two->m->nv, 60);
  ASSERT_TRUE(mj_isSparse(two->m));
  {
    SceneData sd(*two);
    expect_tendon_rows_match_length_differences(*two, sd);
    // MuJoCo's compressed rows carry the corrected values: the actuators' moments it computes
    // from them (gear -1) are the rows
    const mjModel* m = two->m;
    for (int a = 0; a < m->nu; ++a) {
      const mjtNum* J = tendon_jacobian_row(*two, sd, m->actuator_trnid[2 * a]);
      for (int i = 0; i < m->nv; ++i) ASSERT_EQ(sd.d->actuator_moment[a * m->nv + i], -J[i]) << a << " " << i;
    }
  }
  auto one = load_scene(data + "one_arm_cable.xml");
  SceneData sd2(*two), sd1(*one);
  sd2.d->ctrl[1] = 1.0;  // arm B's cable only
  sd1.d->ctrl[0] = 1.0;
  for (int k = 0; k < 300; ++k) {
    ASSERT_EQ(step(*two, sd2), Status::Ok);
    ASSERT_EQ(step(*one, sd1), Status::Ok);
  }
  const int tip2 = mj_name2id(two->m, mjOBJ_SITE, "B/tip"), tip1 = mj_name2id(one->m, mjOBJ_SITE, "B/tip");
  for (int e = 0; e < 3; ++e) EXPECT_NEAR(sd2.d->site_xpos[3 * tip2 + e], sd1.d->site_xpos[3 * tip1 + e], 1e-12) << e;
  EXPECT_GT(std::abs(sd1.d->site_xpos[3 * tip1 + 1] - 0.1), 1e-3);  // the cable did bend it
}

// The same two-arm scene with sparse and with dense Jacobians, with what reads the tendon rows:
// tendon damping and springs (mj_passive, from the tendon velocities; the implicit matrix's
// rows), a tendon limit that engages (a constraint row MuJoCo copies from the tendon row) and the
// cables' motors, under four integrators (2 ms steps: implicit ones and rosenbrock): the same motion to round-off.
TEST(Cable, SparseAndDenseTendonJacobiansGiveTheSameMotion) {
  const std::string data = std::string(COSSERAT_SOURCE_DIR) + "/tests/mujoco/data/";
  std::string xml = cosserat::testing::read_text(data + "two_arms_cables.xml");
  xml.replace(xml.find("<spatial name=\"A_r\""), 20, "<spatial name=\"A_r\" damping=\"0.2\" limited=\"true\" range=\"0 LMAX\"");
  xml.replace(xml.find("<spatial name=\"B_l\""), 20, "<spatial name=\"B_l\" damping=\"0.5\" stiffness=\"30\"");
  {  // the limit: 1 mm longer than A's cable at rest (its motor pushes, and the arm bent by it
     // would stretch the cable by 2.6 mm)
    std::string probe = xml;
    probe.replace(probe.find("LMAX"), 4, "1");
    const auto s = load_scene_string(probe, data + "limit.xml");
    SceneData sd(*s);
    forward(*s, sd);
    xml.replace(xml.find("LMAX"), 4, std::to_string(sd.d->ten_length[0] + 0.001));
  }
  std::string dense_xml = xml;
  dense_xml.replace(dense_xml.find("<worldbody>"), 11, "<option jacobian=\"dense\"/><worldbody>");
  const auto sparse = load_scene_string(xml, data + "sparse.xml");
  const auto dense = load_scene_string(dense_xml, data + "dense.xml");
  ASSERT_TRUE(mj_isSparse(sparse->m));
  ASSERT_FALSE(mj_isSparse(dense->m));
  EXPECT_TRUE(sparse->load_warnings.empty());
  for (const Integrator method : {Integrator::Implicit, Integrator::Trapezoidal, Integrator::Midpoint, Integrator::Rosenbrock}) {
    SceneData a(*sparse), b(*dense);
    for (SceneData* sd : {&a, &b}) {
      sd->d->ctrl[0] = -0.5;  // A's cable pushed: its arm bends the other way, stretching the cable
      sd->d->ctrl[1] = 1.0;
    }
    int limit_rows = 0;
    for (int k = 0; k < 200; ++k) {
      ASSERT_EQ(step(*sparse, a, method), Status::Ok) << k;
      ASSERT_EQ(step(*dense, b, method), Status::Ok) << k;
      for (int r = 0; r < a.d->nefc; ++r) limit_rows += a.d->efc_type[r] == mjCNSTR_LIMIT_TENDON;
    }
    EXPECT_GT(limit_rows, 0) << static_cast<int>(method);  // the limit did engage
    for (int i = 0; i < sparse->m->nq; ++i) EXPECT_NEAR(a.d->qpos[i], b.d->qpos[i], 1e-11) << static_cast<int>(method) << " " << i;
    for (int t = 0; t < sparse->m->ntendon; ++t)
      EXPECT_NEAR(a.d->ten_velocity[t], b.d->ten_velocity[t], 1e-9) << static_cast<int>(method) << " " << t;
    EXPECT_GT(std::abs(a.d->ten_velocity[0]) + std::abs(a.d->ten_velocity[1]), 1e-4);
  }
}

}  // namespace

namespace {

// scene_tendons' outputs (tendons_by_wrenches on these scenes) against MuJoCo 2.2.2's own mj_tendon
// from the same state: lengths and path points bit for bit, the compressed layout's pattern
// exactly, the Jacobian to rounding.
void expect_tendons_as_mj_tendon(const Scene& s, SceneData& sd, const std::string& what) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  ASSERT_TRUE(tendons_of_sites_only(m)) << what;
  scene_tendons(s, sd);
  const int nten = m->ntendon, nv = m->nv, nJ = nten * nv;
  const std::vector<mjtNum> L(d->ten_length, d->ten_length + nten), J(d->ten_J, d->ten_J + nJ);
  const std::vector<int> wadr(d->ten_wrapadr, d->ten_wrapadr + nten), wnum(d->ten_wrapnum, d->ten_wrapnum + nten);
  const std::vector<int> nnz(d->ten_J_rownnz, d->ten_J_rownnz + nten), adr(d->ten_J_rowadr, d->ten_J_rowadr + nten),
      col(d->ten_J_colind, d->ten_J_colind + nJ);
  int nwrap = 0;
  for (int t = 0; t < nten; ++t) nwrap = std::max(nwrap, wadr[t] + wnum[t]);
  const std::vector<int> obj(d->wrap_obj, d->wrap_obj + nwrap);
  const std::vector<mjtNum> xpos(d->wrap_xpos, d->wrap_xpos + 3 * nwrap);
  mj_tendon(m, d);
  double scale = 0.0;
  for (int k = 0; k < nJ; ++k) scale = std::max(scale, std::abs(d->ten_J[k]));
  ASSERT_GT(scale, 1e-3) << what;  // moment arms of millimetres: not all zero
  for (int t = 0; t < nten; ++t) {
    EXPECT_EQ(L[t], d->ten_length[t]) << what << " tendon " << t;
    EXPECT_EQ(wadr[t], d->ten_wrapadr[t]) << what << " tendon " << t;
    ASSERT_EQ(wnum[t], d->ten_wrapnum[t]) << what << " tendon " << t;
  }
  for (int k = 0; k < nwrap; ++k) {
    EXPECT_EQ(obj[k], d->wrap_obj[k]) << what << " path point " << k;
    for (int e = 0; e < 3; ++e) EXPECT_EQ(xpos[3 * k + e], d->wrap_xpos[3 * k + e]) << what << " path point " << k;
  }
  if (!mj_isSparse(m)) {
    for (int k = 0; k < nJ; ++k) EXPECT_NEAR(J[k], d->ten_J[k], 1e-13 * scale) << what << " " << k / nv << " " << k % nv;
    return;
  }
  for (int t = 0; t < nten; ++t) {
    ASSERT_EQ(nnz[t], d->ten_J_rownnz[t]) << what << " tendon " << t;
    ASSERT_EQ(adr[t], d->ten_J_rowadr[t]) << what << " tendon " << t;
    for (int k = adr[t]; k < adr[t] + nnz[t]; ++k) {
      ASSERT_EQ(col[k], d->ten_J_colind[k]) << what << " tendon " << t;
      EXPECT_NEAR(J[k], d->ten_J[k], 1e-13 * scale) << what << " tendon " << t << " dof " << col[k];
    }
  }
}

// Cables through rod sites (and rigid bodies' sites, through a pulley) summed as wrenches up the
// tree (scene_tendons) give mj_tendon's lengths, path points and Jacobian, dense and compressed,
// in bent states; the rods' corrections then follow as before (the length-difference tests above
// read the corrected rows).
TEST(Cable, TendonsOfSitesTakeMuJoCosLengthsAndJacobians) {
  const std::string data = std::string(COSSERAT_SOURCE_DIR) + "/tests/mujoco/data/";
  const std::string pulley = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <site name="anchor" pos="-0.08 0 0.985"/><site name="anchor2" pos="-0.08 0 1.02"/>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.005"/>
      <site name="h1" pos="0.004 0 0"/><site name="h2" pos="0 0.004 0"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01">
        <site name="a" at="0.06" pos="0 0.003 0.006"/><site name="b" at="0.17" pos="0 0.006 0.002"/>
        <site name="c" at="0.28" pos="0 -0.004 0.005"/>
      </cosserat></body></worldbody>
    <tendon><spatial name="cable"><site site="anchor"/><site site="a"/><pulley divisor="2"/><site site="anchor2"/>
      <site site="h1"/><site site="h2"/><site site="b"/><site site="c"/></spatial>
      <spatial name="short"><site site="h1"/><site site="c"/></spatial></tendon>
    <actuator><motor tendon="cable" gear="-1"/></actuator>
  </mujoco>)";
  std::string sparse = pulley;
  sparse.replace(sparse.find("<worldbody>"), 11, "<option jacobian=\"sparse\"/><worldbody>");
  std::vector<std::pair<std::string, std::unique_ptr<Scene>>> scenes;
  scenes.emplace_back("pulley, dense", load_scene_string(pulley, "/tmp/cosserat_cable_test.xml"));
  scenes.emplace_back("pulley, sparse", load_scene_string(sparse, "/tmp/cosserat_cable_test.xml"));
  scenes.emplace_back("two arms (sparse)", load_scene(data + "two_arms_cables.xml"));
  scenes.emplace_back("octopus arm", load_scene(std::string(COSSERAT_SOURCE_DIR) + "/models/octopus_arm.xml"));
  ASSERT_TRUE(mj_isSparse(scenes[1].second->m));
  ASSERT_TRUE(mj_isSparse(scenes[2].second->m));
  for (auto& [what, s] : scenes) {
    SceneData sd(*s);
    for (int u = 0; u < s->m->nu; ++u) sd.d->ctrl[u] = 0.3;
    for (int k = 0; k < 100; ++k) ASSERT_EQ(step(*s, sd), Status::Ok) << what;
    forward(*s, sd);
    expect_tendons_as_mj_tendon(*s, sd, what);
  }
}

}  // namespace
