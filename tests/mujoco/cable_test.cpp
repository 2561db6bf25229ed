// Cables: a MuJoCo tendon through sites along an arm (the discrete routing a MuJoCo user writes)
// against the core's continuous internal cable actuation (tau = -T dl/dq, plugin/core), which it
// must approach as the sites get denser.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "scene.hpp"
#include "statics.hpp"

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

}  // namespace
