// The coupled MuJoCo step (plugin/mujoco/scene.cpp) against references it does not share code
// with: MuJoCo's own mj_step on rod-free scenes, native MuJoCo bodies on rigid rods, and the
// standalone solver core on soft-rigid trees without contact.
#include "scene.hpp"
#include "scene_statics.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dynamics.hpp"
#include "integrators.hpp"
#include "kinematics.hpp"
#include "support/text_file.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const char* kPath = "/tmp/cosserat_scene_test.xml";

std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

using cosserat::testing::replace_all;

struct Loaded {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  explicit Loaded(const std::string& xml) {
    auto s = load_scene_string(xml, kPath);  // pre-processing is harmless without rods
    m = mj_copyModel(nullptr, s->m);
    d = mj_makeData(m);
  }
  ~Loaded() {
    mj_deleteData(d);
    mj_deleteModel(m);
  }
};

// A rod-free scene exercising contacts, a tendon, an actuator and joint damping.
const char* kRigidScene = R"(<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <body name="box" pos="0 0 0.3"><freejoint/><geom type="box" size="0.05 0.04 0.03" mass="0.4"/>
      <site name="s1" pos="0.05 0 0"/></body>
    <body name="arm" pos="0.3 0 0.5"><joint name="h" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/>
      <site name="s2" pos="0.2 0 0"/>
      <body pos="0.2 0 0"><joint name="b" type="ball"/><geom type="sphere" size="0.03" pos="0.05 0 0" mass="0.1"/></body>
    </body>
    <body name="hand" mocap="true" pos="0.5 0 0.8" quat="0.9 0.1 0.2 0"><site name="s3" pos="0 0.02 0"/>
      <geom type="box" size="0.02 0.02 0.02" pos="0.01 0 0" contype="0" conaffinity="0"/></body>
  </worldbody>
  <tendon><spatial name="t" stiffness="5"><site site="s1"/><site site="s2"/></spatial>
    <spatial name="pull" stiffness="3" damping="0.4"><site site="s2"/><site site="s3"/></spatial></tendon>
  <actuator><motor name="m0" joint="h" gear="1"/></actuator>
  <sensor><accelerometer site="s1"/><framepos objtype="site" objname="s2"/><touch site="s1"/><jointpos joint="h"/>
    <actuatorfrc actuator="m0"/></sensor>
</mujoco>)";

// MuJoCo's control callback (mjcb_control) for the tests: a time-dependent control, counted.
int control_calls = 0;
void sine_control(const mjModel*, mjData* d) {
  d->ctrl[0] = 0.2 * std::sin(10.0 * d->time);
  ++control_calls;
}

// Our step against mj_step, 300 steps of the rigid scene with the model's <option> integrator
// (`option`: the attribute added to kRigidScene's <option>), stepped with s->integrator; with
// `callback` the control comes from mjcb_control (sine_control) instead of being set between steps.
void expect_mj_step_bit_for_bit(const std::string& option, Integrator expected, bool callback = false) {
  std::string xml = kRigidScene;
  xml.replace(xml.find("<option "), 8, "<option " + option + " ");
  auto s = load_scene_string(xml, kPath);
  ASSERT_EQ(s->integrator, expected);
  SceneData sd(*s);
  mjModel* m = mj_copyModel(nullptr, s->m);
  mjData* d = mj_makeData(m);
  d->qvel[0] = 0.3;
  sd.d->qvel[0] = 0.3;
  if (callback) mjcb_control = sine_control;
  for (int k = 0; k < 300; ++k) {
    if (!callback) d->ctrl[0] = sd.d->ctrl[0] = 0.2 * std::sin(0.01 * k);
    // the mocap body moves (and its quaternion is not normalised: the kinematics normalises it)
    const double mocap[7] = {0.5 + 0.1 * std::sin(0.02 * k), 0.0, 0.8, 1.0, 0.1 * k / 300.0, 0.2, 0.0};
    for (mjData* x : {d, sd.d}) {
      std::copy(mocap, mocap + 3, x->mocap_pos);
      std::copy(mocap + 3, mocap + 7, x->mocap_quat);
    }
    mj_step(m, d);
    ASSERT_EQ(step(*s, sd), Status::Ok);
  }
  mjcb_control = nullptr;
  EXPECT_GT(d->ncon, 0);  // the box rests on the plane: contacts were exercised
  EXPECT_EQ(std::memcmp(d->qpos, sd.d->qpos, sizeof(mjtNum) * m->nq), 0);
  EXPECT_EQ(std::memcmp(d->qvel, sd.d->qvel, sizeof(mjtNum) * m->nv), 0);
  // the kinematics of the last step, mocap body and its site included
  EXPECT_EQ(std::memcmp(d->xpos, sd.d->xpos, sizeof(mjtNum) * 3 * m->nbody), 0);
  EXPECT_EQ(std::memcmp(d->xquat, sd.d->xquat, sizeof(mjtNum) * 4 * m->nbody), 0);
  EXPECT_EQ(std::memcmp(d->geom_xmat, sd.d->geom_xmat, sizeof(mjtNum) * 9 * m->ngeom), 0);
  EXPECT_EQ(std::memcmp(d->site_xpos, sd.d->site_xpos, sizeof(mjtNum) * 3 * m->nsite), 0);
  EXPECT_EQ(std::memcmp(d->mocap_quat, sd.d->mocap_quat, sizeof(mjtNum) * 4 * m->nmocap), 0);
  EXPECT_EQ(std::memcmp(d->ten_velocity, sd.d->ten_velocity, sizeof(mjtNum) * m->ntendon), 0);
  // the sensors of the last step's start state (mj_step's forward)
  EXPECT_EQ(std::memcmp(d->sensordata, sd.d->sensordata, sizeof(mjtNum) * m->nsensordata), 0);
  mj_deleteData(d);
  mj_deleteModel(m);
}

TEST(Scene, StagedPipelineReproducesMjStepBitForBit) { expect_mj_step_bit_for_bit("", Integrator::Euler); }

// MuJoCo keeps the tendon Jacobian compressed where its Jacobians are sparse (jacobian="auto" from
// nv = 60 on): the tendon velocities (tendon damping, tendonvel sensors) had been read from it as
// dense rows, wrong from the second tendon on
TEST(Scene, StagedPipelineReproducesMjStepBitForBitWithSparseJacobians) {
  expect_mj_step_bit_for_bit("jacobian=\"sparse\"", Integrator::Euler);
  expect_mj_step_bit_for_bit("jacobian=\"sparse\" integrator=\"implicit\"", Integrator::Implicit);
}

// The same with long compressed tendon rows: four hinge chains of 16 links (64 dofs, sparse
// Jacobians), a damped spatial tendon along each (16 dofs a row) and tendonvel sensors. Outside
// probe AA: the compressed rows' sums had been compiled with fused multiply-adds, and the tendon
// velocities differed from mj_step's in the last bit (damping carried it into qvel).
TEST(Scene, ChainsWithLongTendonsReproduceMjStepBitForBitWithSparseJacobians) {
  std::string xml = "<mujoco><option timestep=\"0.002\"/><worldbody>", tendons, sensors;
  for (int c = 0; c < 4; ++c) {
    xml += "<body pos=\"0 " + std::to_string(0.2 * c) + " 0.6\" euler=\"0 20 0\">";
    tendons += "<spatial name=\"t" + std::to_string(c) + "\" damping=\"0.3\" stiffness=\"2\">";
    for (int k = 0; k < 16; ++k) {
      const std::string n = std::to_string(c) + "_" + std::to_string(k);
      xml += std::string("<body pos=\"") + (k ? "0.03" : "0") + " 0 0\"><joint type=\"hinge\" axis=\"" +
             (k % 2 ? "0 0 1" : "0 1 0") + "\" damping=\"0.002\"/><geom type=\"capsule\" fromto=\"0 0 0 0.03 0 0\" "
             "size=\"0.006\"/><site name=\"s" + n + "\" pos=\"0.015 0.008 0\"/>";
      tendons += "<site site=\"s" + n + "\"/>";
    }
    for (int k = 0; k <= 16; ++k) xml += "</body>";
    tendons += "</spatial>";
    sensors += "<tendonvel tendon=\"t" + std::to_string(c) + "\"/>";
  }
  xml += "</worldbody><tendon>" + tendons + "</tendon><sensor>" + sensors + "</sensor></mujoco>";
  auto s = load_scene_string(xml, kPath);
  ASSERT_EQ(s->m->nv, 64);
  ASSERT_TRUE(mj_isSparse(s->m));
  SceneData sd(*s);
  mjModel* m = mj_copyModel(nullptr, s->m);
  mjData* d = mj_makeData(m);
  for (int i = 0; i < m->nv; ++i) d->qvel[i] = sd.d->qvel[i] = 0.5 * std::sin(1.3 * i + 0.2);
  for (int k = 0; k < 100; ++k) {
    mj_step(m, d);
    ASSERT_EQ(step(*s, sd, Integrator::Euler), Status::Ok);
    ASSERT_EQ(std::memcmp(d->sensordata, sd.d->sensordata, sizeof(mjtNum) * m->nsensordata), 0) << k;
    ASSERT_EQ(std::memcmp(d->qvel, sd.d->qvel, sizeof(mjtNum) * m->nv), 0) << k;
  }
  EXPECT_EQ(std::memcmp(d->qpos, sd.d->qpos, sizeof(mjtNum) * m->nq), 0);
  mj_deleteData(d);
  mj_deleteModel(m);
}

// <option integrator="implicit"> on a rod-free scene is MuJoCo's implicit integrator (it had been
// run as Euler, silently)
TEST(Scene, RodFreeImplicitIsMujocosImplicitBitForBit) {
  expect_mj_step_bit_for_bit("integrator=\"implicit\"", Integrator::Implicit);
}

// MuJoCo's control callback: mj_step calls it in its forward, and so does our step, at each of
// its evaluations (outside probe S: it was never called, and a controller ported from mj_step ran
// with its controls frozen). Euler and MuJoCo's implicit integrator: bit for bit with mj_step; RK4
// and the Rosenbrock-W method call it at each of their 4 stages, at the stage's time.
TEST(Scene, ControlCallbackIsCalledAtEveryEvaluationAsMjStepCallsIt) {
  control_calls = 0;
  expect_mj_step_bit_for_bit("", Integrator::Euler, true);
  EXPECT_EQ(control_calls, 600);  // 300 mj_step and 300 of ours
  expect_mj_step_bit_for_bit("integrator=\"implicit\"", Integrator::Implicit, true);
  for (const Integrator it : {Integrator::RK4, Integrator::Rosenbrock}) {
    auto s = load_scene_string(kRigidScene, kPath);
    SceneData sd(*s);
    mjcb_control = [](const mjModel*, mjData* d) { d->ctrl[0] = 0.2 * std::sin(10.0 * d->time); ++control_calls; };
    control_calls = 0;
    for (int k = 0; k < 10; ++k) ASSERT_EQ(step(*s, sd, it), Status::Ok);
    mjcb_control = nullptr;
    EXPECT_EQ(control_calls, 40) << integrator_name(it);
    EXPECT_NE(sd.d->ctrl[0], 0.0);
  }
}

// Activations of actuators with actlimited stay within their actrange under every integrator, as
// mj_step leaves them (outside probe BR: rk4 and rosenbrock had let an integrator actuator's
// activation reach 0.5 against its limit 0.1 and a filter's 0.993 against 0.3, forces 5x and 3.3x
// too large); on a rod-free scene RK4 is MuJoCo's own RK4 to rounding, the clipped activations too.
TEST(Scene, ActivationsStayWithinTheirRangeUnderEveryIntegrator) {
  const char* actuators = R"(<actuator>
      <general name="i" joint="J1" dyntype="integrator" gainprm="1e-3" actlimited="true" actrange="-0.1 0.1"/>
      <general name="f" joint="J2" dyntype="filter" dynprm="0.1" gainprm="1e-3" actlimited="true" actrange="-0.3 0.3"/>
    </actuator></mujoco>)";
  const std::string rod = replace_all(replace_all(std::string(R"(<mujoco><option timestep="0.0005" gravity="0 0 0"/><worldbody>
      <cosserat name="r" length="0.5" sections="4" strain="kl" radius="0.01" young="1e6" viscosity="1e3"/></worldbody>)") +
                                                  actuators,
                                              "J1", "r/s1/ky"),
                                  "J2", "r/s2/kz");
  for (const Integrator it : {Integrator::Euler, Integrator::Implicit, Integrator::Trapezoidal, Integrator::GeneralizedAlpha,
                              Integrator::Midpoint, Integrator::RK4, Integrator::Rosenbrock}) {
    SCOPED_TRACE(integrator_name(it));
    auto s = load_scene_string(rod, kPath);
    SceneData sd(*s);
    sd.d->ctrl[0] = sd.d->ctrl[1] = 1.0;
    for (int k = 0; k < 400; ++k) ASSERT_EQ(step(*s, sd, it), Status::Ok);
    EXPECT_EQ(sd.d->act[0], 0.1);  // (reached: the integrator's activation grows by ctrl t)
    EXPECT_EQ(sd.d->act[1], 0.3);  // (the filter's: 1 - exp(-t / 0.1) passes 0.3 at 36 ms)
  }
  const std::string rigid = replace_all(replace_all(std::string(R"(<mujoco><option timestep="0.0005" gravity="0 0 0" integrator="RK4"/>
      <worldbody><body name="b"><joint name="j" type="hinge" axis="0 1 0" stiffness="1"/>
        <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.01" mass="0.1"/></body></worldbody>)") + actuators,
                                                    "J1", "j"),
                                        "J2", "j");
  auto s = load_scene_string(rigid, kPath);
  SceneData sd(*s);
  mjData* raw = mj_makeData(s->m);
  for (int k = 0; k < 1000; ++k) {
    raw->ctrl[0] = raw->ctrl[1] = sd.d->ctrl[0] = sd.d->ctrl[1] = 1.0;
    mj_step(s->m, raw);
    ASSERT_EQ(step(*s, sd, Integrator::RK4), Status::Ok);
  }
  EXPECT_EQ(sd.d->act[0], raw->act[0]);
  EXPECT_EQ(sd.d->act[1], raw->act[1]);
  EXPECT_EQ(raw->act[0], 0.1);
  EXPECT_NEAR(sd.d->qpos[0], raw->qpos[0], 1e-15);
  EXPECT_GT(std::abs(raw->qpos[0]), 1e-5);
  mj_deleteData(raw);
}

// Two threads stepping SceneData of one Scene at once would each write their rod capsules into the
// Scene's mjModel and read the other's (outside probe AB: wrong results without an error): the
// second is refused while the first is inside a step (held there by its control callback), and
// steps in turn on one thread, or from either thread once the other is done, go on.
std::atomic<int> held_phase{0};
TEST(Scene, TwoThreadsSteppingOneSceneAtOnceAreRefused) {
  auto s = load_scene_string(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <cosserat name="rod" pos="0 0 1" length="0.3" sections="3" strain="kl" radius="0.01" young="1e6"/></worldbody>
    <actuator><motor joint="rod/s0/kz"/></actuator></mujoco>)",
                             kPath);
  SceneData a(*s), b(*s);
  held_phase = 0;
  mjcb_control = [](const mjModel*, mjData*) {
    if (held_phase == 0) {
      held_phase = 1;  // inside the first thread's step: wait for the other's attempt
      for (int k = 0; k < 20000 && held_phase == 1; ++k) std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  };
  std::thread first([&] { EXPECT_EQ(step(*s, a), Status::Ok); });
  while (held_phase == 0) std::this_thread::sleep_for(std::chrono::microseconds(100));
  std::string refused, refused_statics;
  std::thread second([&] {
    try {
      step(*s, b);
    } catch (const std::logic_error& e) {
      refused = e.what();
    }
    try {  // a statics solve changes the mjModel for its whole run (outside probe BW)
      equilibrium(*s, b);
    } catch (const std::logic_error& e) {
      refused_statics = e.what();
    }
    held_phase = 2;
  });
  second.join();
  first.join();
  mjcb_control = nullptr;
  EXPECT_NE(refused.find("two threads step or evaluate one Scene at once"), std::string::npos) << refused;
  EXPECT_NE(refused_statics.find("two threads step or evaluate one Scene at once"), std::string::npos) << refused_statics;
  // in turn, from either thread: fine
  std::thread later([&] { EXPECT_EQ(step(*s, b), Status::Ok); });
  later.join();
  EXPECT_EQ(step(*s, a), Status::Ok);
  forward(*s, b);
}

// After a step, d->sensordata holds the sensors of the step's start state, as after mj_step,
// whatever the integrator (outside probe S: the Rosenbrock-W method left its last stage's, O(h^2)
// from the end state, and the trapezoidal rule its end state's). A rod on a servoed hinge with
// position, velocity and acceleration sensors on the rod; no constraints, so that the forward at
// the start state below is the step's own first evaluation, bit for bit.
TEST(Scene, AStepLeavesTheSensorsOfItsStartStateWhateverTheIntegrator) {
  const char* xml = R"(<mujoco><option timestep="0.0002"/><worldbody>
    <body name="hub" pos="0 0 0.5"><joint name="h" type="hinge" axis="0 1 0" stiffness="2"/>
      <geom type="sphere" size="0.03" mass="0.2" contype="0" conaffinity="0"/>
      <cosserat name="rod" length="0.4" sections="3" radius="0.006" density="1100" young="2e6"
                contype="0" conaffinity="0"><site name="m" at="0.2"/></cosserat></body></worldbody>
    <actuator><position name="servo" joint="h" kp="4"/></actuator>
    <sensor><framepos objtype="site" objname="rod/tip"/><velocimeter site="m"/><accelerometer site="m"/>
      <gyro site="rod/tip"/><jointvel joint="h"/><actuatorfrc actuator="servo"/></sensor></mujoco>)";
  for (const Integrator it : {Integrator::Euler, Integrator::Implicit, Integrator::Trapezoidal,
                              Integrator::GeneralizedAlpha, Integrator::Midpoint, Integrator::RK4,
                              Integrator::Rosenbrock}) {
    for (const double tol : {0.0, 1e-3}) {
      if (tol > 0 && !takes_substeps(it)) continue;
      SCOPED_TRACE(std::string(integrator_name(it)) + (tol > 0 ? " with step_tol" : ""));
      auto s = load_scene_string(xml, kPath);
      s->step_tol = tol;
      SceneData sd(*s);
      sd.d->ctrl[0] = 0.8;
      const int n = s->m->nsensordata;
      std::vector<mjtNum> start(n);
      for (int k = 0; k < 20; ++k) {
        forward(*s, sd);  // (changes no state)
        std::copy(sd.d->sensordata, sd.d->sensordata + n, start.begin());
        ASSERT_EQ(step(*s, sd, it), Status::Ok);
      }
      EXPECT_EQ(std::memcmp(start.data(), sd.d->sensordata, sizeof(mjtNum) * n), 0);
      // and not the end state's (the sensors move)
      forward(*s, sd);
      EXPECT_NE(std::memcmp(start.data(), sd.d->sensordata, sizeof(mjtNum) * n), 0);
    }
  }
}

TEST(Scene, RecomputedInvweight0EqualsMujocosOnRigidScene) {
  auto s = load_scene_string(kRigidScene, kPath);
  const mjModel* m = s->m;
  std::vector<double> body(m->body_invweight0, m->body_invweight0 + 2 * m->nbody),
      dof(m->dof_invweight0, m->dof_invweight0 + m->nv), ten(m->tendon_invweight0, m->tendon_invweight0 + m->ntendon);
  recompute_qpos0_constants(*s);
  for (int i = 2; i < 2 * m->nbody; ++i) EXPECT_NEAR(m->body_invweight0[i], body[i], 1e-10 * (1 + body[i])) << i;
  for (int i = 0; i < m->nv; ++i) EXPECT_NEAR(m->dof_invweight0[i], dof[i], 1e-10 * (1 + dof[i])) << i;
  for (int i = 0; i < m->ntendon; ++i) EXPECT_NEAR(m->tendon_invweight0[i], ten[i], 1e-10 * (1 + ten[i])) << i;
}

// rod_inertia at the rod's own mass points is the rod's part of qM, whatever the mass rule; with
// the same Gauss rule it is the same sum (points at the same abscissae).
TEST(Scene, RodInertiaAtItsMassPointsIsTheRodsPartOfQm) {
  for (const std::string& rule : {std::string(), std::string(R"( quadrature="3")"), std::string(R"( quadrature="lobatto")"),
                                  std::string(R"( order="1")")}) {
    for (bool free_hub : {false, true}) {
      const std::string xml = std::string(R"(<mujoco><worldbody><body name="hub" pos="0 0 1">)") +
                              (free_hub ? "<freejoint/>" : R"(<joint type="hinge" axis="0 1 0"/>)") +
                              R"(<geom type="sphere" size="0.03" mass="0.2"/>
          <cosserat name="rod" length="0.4" sections="3" strain="kl" radius="0.01")" + rule + R"(/>
        </body></worldbody></mujoco>)";
      auto s = load_scene_string(xml, kPath);
      SceneData sd(*s);
      const mjModel* m = s->m;
      mju_copy(sd.d->qpos, m->qpos0, m->nq);  // bent and moved: qpos0 + a displacement
      std::vector<mjtNum> dq(m->nv);
      for (int i = 0; i < m->nv; ++i) dq[i] = std::sin(1.7 * i + 0.3);
      mj_integratePos(m, sd.d->qpos, dq.data(), 1.0);
      fwd_position(*s, sd);
      const int nv = m->nv;
      Eigen::MatrixXd M(nv, nv);
      mj_fullM(m, M.data(), sd.d->qM);
      const Eigen::MatrixXd R = rod_inertia(*s, sd, 0, 0);
      // what is left is the hub's own inertia: in its own dofs only
      const Eigen::MatrixXd H = M - R;
      const int nh = free_hub ? 6 : 1;
      EXPECT_LT(H.bottomRows(nv - nh).norm(), 1e-12 * M.norm()) << rule << free_hub;
      EXPECT_LT(H.rightCols(nv - nh).norm(), 1e-12 * M.norm()) << rule << free_hub;
      EXPECT_GT(R.bottomRightCorner(nv - nh, nv - nh).norm(), 1e-4) << rule;  // not a trivial pass
      if (rule.find('3') != std::string::npos || rule.find("order") != std::string::npos)
        EXPECT_LT((rod_inertia(*s, sd, 0, 3) - R).norm(), 1e-12 * R.norm()) << rule << free_hub;
    }
  }
}

// The constants MuJoCo derives from the mass at qpos0 (inverse weights: the softness of contacts
// and limits) take the rod's continuum inertia, not the mass rule of the dynamics. A free
// one-section rod's 2 Gauss points leave a mode that moves neither of them (the ends swing
// against the middle, held by the cross-sections' rotary inertia only), which made its end's
// inverse weight 70x the continuum's: MuJoCo's contact regulariser grew with it and the rod sank
// 8 radii into the floor. Reference: a uniform rod whose points move by a base translation, a
// linear stretch and a parabola across it (one PCS section's motions near rest), with the
// cross-sections turning by the parabola's slope, and a point mass at its end: the inverse weights
// there along the rod and across it (m/4 and m/9 without rotary inertia and end mass), averaged.
TEST(Scene, InverseWeightsTakeTheRodsContinuumInertia) {
  const double L = 0.5, r = 0.01, rho = 1000.0, A = M_PI * r * r, I = A * r * r / 4.0, m_hub = 1e-5;
  auto end_inverse_weight = [&](int n) {  // fields 1, s, .. s^(n-1)
    Eigen::MatrixXd K(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        K(i, j) = rho * A * std::pow(L, i + j + 1) / (i + j + 1) +
                  (i > 0 && j > 0 && n == 3 ? rho * I * i * j * std::pow(L, i + j - 1) / (i + j - 1) : 0.0);
    K(0, 0) += m_hub;
    return K.inverse()(0, 0);
  };
  const double want = (end_inverse_weight(2) + 2.0 * end_inverse_weight(3)) / 3.0;
  EXPECT_NEAR(want * rho * A * L, 22.0 / 3.0, 0.03);  // 7.33: with rotary inertia and the hub
  std::vector<double> hub;
  for (const char* rule : {"", R"( quadrature="3")", R"( quadrature="lobatto")", R"( quadrature="8")"}) {
    auto s = load_scene_string(std::string(R"(<mujoco><worldbody><geom name="floor" type="plane" size="5 5 0.1"/>
        <body name="hub" pos="0 0 0.0099"><freejoint/><inertial pos="0 0 0" mass="1e-5" diaginertia="1e-10 1e-10 1e-10"/>
          <cosserat name="rod" length="0.5" sections="1" strain="kl" radius="0.01" density="1000")") +
                                   rule + R"(/></body></worldbody></mujoco>)",
                               kPath);
    hub.push_back(s->m->body_invweight0[2 * mj_name2id(s->m, mjOBJ_BODY, "hub")]);
    EXPECT_NEAR(hub.back(), want, 1e-4 * want) << rule;
    EXPECT_NEAR(hub.back(), hub.front(), 1e-9 * hub.front()) << rule;
    // and the rod rests on the floor (its centre line r above it, less MuJoCo's soft penetration:
    // 0.6 mm here; it was 8.8 cm below the floor)
    SceneData sd(*s);
    reset(*s, sd);
    for (int k = 0; k < 2000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok) << rule;
    const std::vector<Vec3> c = rod_centerline(*s, sd, 0, 5);
    for (const Vec3& p : c) EXPECT_NEAR(p.z(), r, 1e-3) << rule;
  }
}

// recompute_qpos0_constants works on MuJoCo's sparse factor of qM (with the rods' continuum
// inertia added on each point's dof chain), as mj_setConst does: it equals the dense computation
// (the full matrix, each rod's metric as a dense nv x nv matrix, a dense inverse), which loads of
// many rods could not afford (50 arms, 1600 dofs: 6.5 s).
void expect_qpos0_constants_dense(const Scene& scene, const std::string& what) {
  SCOPED_TRACE(what);
  const Scene* s = &scene;
  const mjModel* m = s->m;
  SceneData sd(*s);
  mju_copy(sd.d->qpos, m->qpos0, m->nq);
  fwd_position(*s, sd);
  const int nv = m->nv;
  Eigen::MatrixXd M(nv, nv);
  mj_fullM(m, M.data(), sd.d->qM);
  for (int r = 0; r < static_cast<int>(s->rods.size()); ++r) {
    int points = kConstantsQuadrature;
    for (const Section& sec : s->rods[r].model.sections) points = std::max(points, sec.order + 6);
    M += rod_inertia(*s, sd, r, points) - rod_inertia(*s, sd, r, 0);
  }
  const Eigen::MatrixXd Minv = M.inverse();
  auto near = [](double got, double want, const std::string& what) {
    EXPECT_NEAR(got, want, 1e-10 * std::abs(want) + 1e-300) << what;
  };
  for (int j = 0; j < m->njnt; ++j) {
    const int a = m->jnt_dofadr[j];
    const int n = m->jnt_type[j] == mjJNT_FREE ? 6 : m->jnt_type[j] == mjJNT_BALL ? 3 : 1;
    for (int k = 0; k < n; ++k) {
      const int blk = m->jnt_type[j] == mjJNT_FREE ? a + 3 * (k / 3) : a;  // averaged per triple
      const int cnt = n == 1 ? 1 : 3;
      double want = 0.0;
      for (int i = 0; i < cnt; ++i) want += Minv(blk + i, blk + i) / cnt;
      near(m->dof_invweight0[a + k], want, "dof " + std::to_string(a + k));
    }
  }
  std::vector<mjtNum> jp(3 * nv), jr(3 * nv);
  std::vector<bool> proxy(m->nbody, false);
  for (const RodBinding& rb : s->rods)
    for (int b : rb.proxy_body) proxy[b] = true;
  int others = 0;
  for (int b = 1; b < m->nbody; ++b) {
    if (proxy[b]) continue;  // taken at its section's centre of mass, checked elsewhere
    ++others;
    mj_jacBodyCom(m, sd.d, jp.data(), jr.data(), b);
    const Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>> Jp(jp.data(), 3, nv), Jr(jr.data(), 3, nv);
    near(m->body_invweight0[2 * b], (Jp * Minv * Jp.transpose()).trace() / 3.0, std::string("body ") + mj_id2name(m, mjOBJ_BODY, b));
    near(m->body_invweight0[2 * b + 1], (Jr * Minv * Jr.transpose()).trace() / 3.0, std::string("body rot ") + mj_id2name(m, mjOBJ_BODY, b));
  }
  EXPECT_GT(others, 0);  // rigid bodies and the strain joints' helper bodies
  for (int t = 0; t < m->ntendon; ++t) {
    const Eigen::Map<const Eigen::RowVectorXd> Jt(sd.d->ten_J + t * nv, nv);
    near(m->tendon_invweight0[t], Jt * Minv * Jt.transpose(), "tendon " + std::to_string(t));
  }
  for (int i = 0; i < m->nu; ++i)
    near(m->actuator_acc0[i], (Minv * Eigen::Map<const Eigen::VectorXd>(sd.d->actuator_moment + i * nv, nv)).norm(),
         "actuator " + std::to_string(i));
  near(m->stat.meaninertia, M.trace() / nv, "meaninertia");
}

// Two rods on a free hub (one of them nested under a hinged body), a rod on a hinge beside them, a
// tendon and actuators; every shipped model; rods on a ball joint, a welded body and the world.
TEST(Scene, Qpos0ConstantsEqualTheDenseComputation) {
  auto s = load_scene_string(R"(<mujoco><worldbody>
      <body name="hub" pos="0 0 1"><freejoint/><geom type="box" size="0.05 0.04 0.03" mass="0.3"/>
        <cosserat name="a" length="0.3" sections="3" strain="kl" radius="0.01" quadrature="lobatto">
          <site name="a1" at="0.1" pos="0 0.006 0"/><site name="a2" at="0.25" pos="0 0.006 0"/></cosserat>
        <body name="arm" pos="0.05 0 0"><joint name="elbow" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01" mass="0.05"/>
          <cosserat name="b" pos="0.1 0 0" length="0.2" sections="2" strain="sr" radius="0.008" order="1">
            <body name="tip"><geom type="sphere" size="0.015" mass="0.02"/></body></cosserat></body></body>
      <body name="post" pos="1 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.02"/>
        <cosserat name="c" length="0.4" sections="4" strain="ikl" radius="0.01"/></body></worldbody>
    <tendon><spatial name="cable"><site site="a1"/><site site="a2"/></spatial></tendon>
    <actuator><motor joint="elbow"/><motor tendon="cable"/><motor joint="a/s1/kz"/></actuator>
  </mujoco>)",
                             kPath);
  expect_qpos0_constants_dense(*s, "inline tree");
  // every shipped model, and rods on a ball joint, on a welded body and with rigid sections
  for (const char* f : {"cantilever", "flagellate", "flagellate_rigid", "lophotrichous", "hybrid_arm", "octopus_arm"})
    expect_qpos0_constants_dense(*load_scene(std::string(COSSERAT_SOURCE_DIR "/models/") + f + ".xml"), f);
  auto odd = load_scene_string(R"(<mujoco><worldbody>
      <body name="ball" pos="0 0 1"><joint type="ball"/><geom type="sphere" size="0.03" mass="0.2"/>
        <cosserat name="r1" length="0.3" sections="2" strain="kl" radius="0.01">
          <section length="0.1" strain="rigid"/><section length="0.2"/></cosserat>
        <body name="welded" pos="0.1 0 0"><geom type="sphere" size="0.01" mass="0.01"/>
          <cosserat name="r2" length="0.2" sections="3" strain="ikl" radius="0.008"/></body></body>
      <cosserat name="r3" pos="1 0 1" length="0.2" sections="2" strain="kl" radius="0.01"/></worldbody></mujoco>)",
                               kPath);
  expect_qpos0_constants_dense(*odd, "ball joint, welded body, rigid section, rod on the world");
}

// MuJoCo's own compiler errors name lines of the generated MJCF; the user must see their file and
// line, also inside included files and around <cosserat> elements.
// Loading `xml` (named dir/name) fails with a LoadError at `file` (default: the same) and `line`
// whose message contains `text`.
void expect_load_error(const std::string& xml, const std::string& dir, const std::string& name, int line,
                       const std::string& text, const std::string& file = "") {
  try {
    load_scene_string(xml, dir + "/" + name);
    ADD_FAILURE() << "no error for " << name;
  } catch (const LoadError& e) {
    EXPECT_EQ(e.file, dir + "/" + (file.empty() ? name : file)) << e.what();
    EXPECT_EQ(e.line, line) << e.what();
    EXPECT_NE(e.message.find(text), std::string::npos) << e.what();
  }
}

TEST(Scene, MujocoCompileErrorsPointAtTheUsersFileAndLine) {
  const std::string dir = "/tmp/cosserat_scene_test_include";
  std::system(("mkdir -p " + dir).c_str());
  {
    FILE* f = std::fopen((dir + "/part.xml").c_str(), "w");
    std::fputs("<mujoco>\n<worldbody>\n<body name=\"b\">\n<joint type=\"hinge\" range=\"0 1\"/>\n"
               "<geom size=\"0.1\"/>\n</body>\n</worldbody>\n</mujoco>\n", f);
    std::fclose(f);
  }
  expect_load_error("<mujoco>\n<worldbody>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"3\"/>\n</worldbody>\n"
                    "<include file=\"part.xml\"/>\n</mujoco>\n",
                    dir, "main.xml", 4, "range", "part.xml");
  // an error in the main file after a rod (whose generated bodies add many lines)
  const std::string rod5 = "<mujoco>\n<worldbody>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"5\"/>\n";
  expect_load_error(rod5 + "<body name=\"c\">\n<joint type=\"slide\" range=\"0 1\"/>\n<geom size=\"0.1\"/>\n</body>\n"
                           "</worldbody>\n</mujoco>\n",
                    dir, "bad.xml", 5, "range");
  // MuJoCo's XML reader (schema) errors say "Element 'geom', line N" instead of the compiler's
  // "line = N" (found by fuzzing: they were reported at line 0)
  for (const std::string& attr : {std::string("frobnicate=\"2\""), std::string("size=\"0.1 0.2 0.3 0.4\"")})
    expect_load_error(rod5 + "<body name=\"c\">\n<joint type=\"slide\"/>\n<geom " + attr + "/>\n</body>\n"
                             "</worldbody>\n</mujoco>\n",
                      dir, "schema.xml", 6, "XML Error");
  // MuJoCo's errors on a rod's capsules point at the <cosserat>, on a rod site at its <site> (an
  // outside probe found them at the parent body's line, seventeenth session)
  const std::string in_body = "<mujoco>\n<worldbody>\n<body name=\"b\">\n<geom size=\"0.1\"/>\n";
  expect_load_error(in_body + "<cosserat name=\"a\" length=\"0.3\" sections=\"2\" condim=\"2\"/>\n</body>\n"
                              "</worldbody>\n</mujoco>\n",
                    dir, "condim.xml", 5, "invalid condim in geom 'a/s0/g0'");
  for (const std::string& attr : {std::string("type=\"blob\""), std::string("size=\"-1\"")})
    expect_load_error(in_body + "<cosserat name=\"a\" length=\"0.3\" sections=\"2\">\n<site name=\"s\" at=\"0.1\" " +
                          attr + "/>\n</cosserat>\n</body>\n</worldbody>\n</mujoco>\n",
                      dir, "site.xml", 6, "MuJoCo");
  // a moving body whose only mass is a rod's: MuJoCo's refusal says what to do (the rod's mass is
  // its own; an outside probe had to find that out)
  expect_load_error("<mujoco>\n<worldbody>\n<body name=\"hub\">\n<freejoint/>\n"
                    "<cosserat name=\"rod\" length=\"0.3\" sections=\"2\"/>\n</body>\n</worldbody>\n</mujoco>\n",
                    dir, "hub.xml", 3, "object 'hub'): a rod's mass is the rod's own, not its parent body's; a massless body holding a rod needs an <inertial>");
  // a body with a mass of its own below the floor, a micrometre-sized head in SI units: the hint
  // says to scale the units, not to add mass (outside probe BZ: the mass it had offered slowed a
  // bacterium's swimming 2600-fold)
  expect_load_error("<mujoco>\n<worldbody>\n<body name=\"head\">\n<freejoint/>\n<geom size=\"5e-7\" density=\"1100\"/>\n"
                    "<cosserat name=\"rod\" length=\"8e-6\" radius=\"1e-8\" sections=\"2\"/>\n</body>\n</worldbody>\n</mujoco>\n",
                    dir, "head.xml", 3, "do not add mass, which changes its motion: write the model in scaled units");
  // under inertiafromgeom="false" the hub's geom adds no mass: the hint says so (probe P)
  expect_load_error("<mujoco>\n<compiler inertiafromgeom=\"false\"/>\n<worldbody>\n<body name=\"hub\">\n<joint/>\n"
                    "<geom size=\"0.02\"/>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"2\"/>\n</body>\n</worldbody>\n</mujoco>\n",
                    dir, "nogeommass.xml", 4, "under <compiler inertiafromgeom=\"false\"> a body's geoms add no mass");
  // a <default> geom pos reaching the capsules (placed with fromto): MuJoCo's error says why (outside
  // probe P: the user wrote neither)
  expect_load_error("<mujoco>\n<default>\n<geom pos=\"0 0 0.01\"/>\n</default>\n<worldbody>\n"
                    "<cosserat name=\"arm\" length=\"0.3\" sections=\"2\"/>\n</worldbody>\n</mujoco>\n",
                    dir, "default_pos.xml", 6, "a <default> geom pos reaches the rod's capsules, which are placed with fromto");
  // keyframe errors name the key's index and no line: the index's <key> (was line 0); a value
  // MuJoCo reads as NaN (with only a warning) is refused at its <key>
  const std::string rod2 = "<mujoco>\n<worldbody>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"2\"/>\n</worldbody>\n"
                           "<keyframe>\n<key name=\"fine\"/>\n";
  expect_load_error(rod2 + "<key qpos=\"1 2\"/>\n</keyframe>\n</mujoco>\n", dir, "keys.xml", 7, "key 1");
  // a keyframe of the wrong length says how many coordinates are the rods' (outside probe AD)
  expect_load_error(rod2 + "<key qpos=\"1 2\"/>\n</keyframe>\n</mujoco>\n", dir, "keys.xml", 7,
                    "expected length 8 (the rods' strain coordinates, in the model's joint order: rod 'rod' 8;");
  // a strain joint the rod does not have, or a section beyond its last, names the rod's joints
  // (outside probe AD: MuJoCo's bare "unknown transmission target")
  const std::string kl3 = "<mujoco>\n<worldbody>\n<cosserat name=\"A\" length=\"0.3\" sections=\"3\"/>\n</worldbody>\n";
  for (const std::string& joint : {std::string("A/s1/py"), std::string("A/s5/kz")})
    expect_load_error(kl3 + "<actuator>\n<motor joint=\"" + joint + "\"/>\n</actuator>\n</mujoco>\n", dir,
                      "strain_joint.xml", 6,
                      "rod 'A' has no '" + joint + "'. Its sections are A/s0 to A/s2 (bodies), its strain joints "
                      "A/s<i>/<coordinate>, section A/s" + (joint == "A/s1/py" ? "1" : "0") +
                          "'s coordinates: kx ky kz px");
  // a capsule the rod generates is no unknown name: a bad condim on the rod says the capsule takes
  // the rod's geom attributes (outside probe BB: "rod 'A' has no 'A/s0/g0'")
  expect_load_error("<mujoco>\n<worldbody>\n<cosserat name=\"A\" length=\"0.3\" condim=\"5\"/>\n</worldbody>\n</mujoco>\n",
                    dir, "condim.xml", 3,
                    "invalid condim in geom 'A/s0/g0' (id = 0) (object 'A/s0/g0'): 'A/s0/g0' is a capsule of rod 'A', "
                    "which takes the rod's geom attributes");
  // a rod's name, or a name the rod makes of another kind, where MuJoCo wants an object it has: what
  // the rod becomes (outside probe BL: MuJoCo's bare "not found"; a sensor's error named the sensor,
  // not the object)
  expect_load_error(kl3 + "<actuator>\n<motor joint=\"A/s1\"/>\n</actuator>\n</mujoco>\n", dir, "body_as_joint.xml", 6,
                    "unknown transmission target 'A/s1' for actuator id = 0: 'A/s1' is a body of rod 'A', which MuJoCo "
                    "knows by what the rod becomes: rod 'A' becomes the bodies A/base and A/s0 to A/s2 (each section's "
                    "end), the sites A/base, A/tip, the strain joints A/s<i>/<coordinate> (slides) and the capsules A/s<i>/g<k>");
  expect_load_error(kl3 + "<sensor>\n<framepos objtype=\"body\" objname=\"A\"/>\n</sensor>\n</mujoco>\n", dir,
                    "rod_as_body.xml", 6,
                    "unrecognized name of sensorized object in sensor '' (id = 0) (objname 'A'): 'A' is a rod, which MuJoCo "
                    "knows by what it becomes: rod 'A' becomes the bodies A/base");
  // with sections of different strains, the named section's coordinates (outside probe AE)
  expect_load_error("<mujoco>\n<worldbody>\n<cosserat name=\"A\" length=\"0.3\" sections=\"2\">\n<section/>\n"
                    "<section strain=\"ikl\"/>\n</cosserat>\n</worldbody>\n<actuator>\n<motor joint=\"A/s1/px\"/>\n"
                    "</actuator>\n</mujoco>\n",
                    dir, "mixed_sections.xml", 9, "section A/s1's coordinates: kx ky kz (the strain");
  expect_load_error(rod2 + "<key time=\"nan\"/>\n</keyframe>\n</mujoco>\n", dir, "nan_key.xml", 7,
                    "'time' has a number that is not finite");
  // errors MuJoCo reports with an element's index and no line (outside probe, fourteenth session):
  // the sensor or actuator it names, the first stateless actuator after a stateful one
  const std::string world = "<mujoco>\n<worldbody>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"2\"/>\n</worldbody>\n";
  expect_load_error(world + "<sensor>\n<framepos name=\"x\" objtype=\"site\" objname=\"rod/tip\"/>\n"
                            "<framepos name=\"x\" objtype=\"site\" objname=\"rod/tip\"/>\n</sensor>\n</mujoco>\n",
                    dir, "dup_sensor.xml", 7, "repeated name in sensor array");
  expect_load_error(world + "<sensor>\n<framepos objtype=\"site\" objname=\"rod/tip\"/>\n"
                            "<framepos name=\"fp\" objtype=\"site\" objname=\"nowhere\"/>\n</sensor>\n</mujoco>\n",
                    dir, "unknown_sensor_object.xml", 7, "unrecognized name of sensorized object");
  expect_load_error(world + "<actuator>\n<muscle joint=\"rod/s0/kz\" lengthrange=\"-1 1\"/>\n"
                            "<motor joint=\"rod/s0/kz\"/>\n</actuator>\n</mujoco>\n",
                    dir, "actuator_order.xml", 7, "stateless actuators must come before stateful actuators");
  expect_load_error(world.substr(0, world.size() - 13) + "</worldbody>\n<tendon>\n<spatial name=\"c\">\n"
                    "<site site=\"rod/base\"/>\n<site site=\"rod/tip\"/>\n</spatial>\n</tendon>\n<actuator>\n"
                    "<motor tendon=\"c\"/>\n<muscle tendon=\"c\"/>\n</actuator>\n</mujoco>\n",
                    dir, "lengthrange.xml", 13, "an actuator acting on a rod needs an explicit lengthrange");
  // where MuJoCo's lengthrange simulation of the placeholder rod converges (a loose tolerance), its
  // result is no range of the rod: refused at the muscle's line; an explicit one loads
  const std::string loose = "<mujoco>\n<compiler>\n<lengthrange tolrange=\"100\"/>\n</compiler>\n"
                            "<worldbody>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"2\"/>\n</worldbody>\n"
                            "<tendon>\n<spatial name=\"c\">\n<site site=\"rod/base\"/>\n<site site=\"rod/tip\"/>\n"
                            "</spatial>\n</tendon>\n<actuator>\n<muscle tendon=\"c\"LR/>\n</actuator>\n</mujoco>\n";
  expect_load_error(replace_all(loose, "LR", ""), dir, "loose_lengthrange.xml", 15,
                    "a muscle acting on rod 'rod' needs an explicit lengthrange");
  EXPECT_NO_THROW(load_scene_string(replace_all(loose, "LR", " lengthrange=\"0.25 0.31\""), dir + "/given.xml"));
  // a velocity sensor of a rod capsule (no material frame) is refused at its line; of a site, not
  const std::string rod2s = "<mujoco>\n<worldbody>\n<cosserat name=\"rod\" length=\"0.3\" sections=\"2\">\n"
                            "<site name=\"m\" at=\"0.1\"/>\n</cosserat>\n</worldbody>\n<sensor>\n";
  expect_load_error(rod2s + "<framepos objtype=\"geom\" objname=\"rod/s0/g0\"/>\n"
                            "<framelinvel objtype=\"geom\" objname=\"rod/s0/g0\"/>\n</sensor>\n</mujoco>\n",
                    dir, "capsule_sensor.xml", 9, "rod capsule 'rod/s0/g0'");
  expect_load_error(rod2s + "<frameangacc objtype=\"site\" objname=\"m\"/>\n<framelinvel objtype=\"site\" "
                            "objname=\"m\" reftype=\"geom\" refname=\"rod/s1/g1\"/>\n</sensor>\n</mujoco>\n",
                    dir, "capsule_ref.xml", 9, "rod capsule 'rod/s1/g1'");
  EXPECT_NO_THROW(load_scene_string(rod2s + "<framelinvel objtype=\"site\" objname=\"m\"/>\n</sensor>\n</mujoco>\n",
                                    dir + "/site_sensor.xml"));
}

// ---- soft-rigid trees: MuJoCo-coupled against the standalone core --------------------------

const char* kArm = R"(<mujoco>
  <option timestep="0.001" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="hub" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0.2"/>
      <inertial pos="0.02 0 0.01" mass="0.3" diaginertia="1e-3 2e-3 3e-3"/>
      <cosserat name="rod" pos="0.05 0 0" euler="0 0 0.3" length="0.4" sections="SECTIONS" strain="STRAIN"
                order="ORDER" radius="0.01 0.006" density="1100" young="3e5" poisson="0.45" viscosity="VISC"
                reststrain="0 0.5 -1 1 0 0">
        <body name="tip"><inertial pos="0.01 0 0" mass="0.05" diaginertia="2e-5 1e-5 1e-5"/></body>
      </cosserat>
    </body>
  </worldbody>
</mujoco>)";

std::string arm_xml(const char* strain, int sections, int order, double visc) {
  std::string x = kArm;
  x = replace_all(x, "SECTIONS", std::to_string(sections));
  x = replace_all(x, "STRAIN", strain);
  x = replace_all(x, "ORDER", std::to_string(order));
  return replace_all(x, "VISC", fmt(visc));
}

// The same tree built with the core API.
Model core_arm(const Scene& s) {
  const RodBinding& rb = s.rods[0];
  Model m;
  m.gravity = Vec3(0, 0, -9.81);
  SE3 hub;
  hub.u = Vec3(0, 0, 1);
  const int j = m.add_joint(-1, hub, JointType::Revolute, Vec3(0, 1, 0.2));
  m.add_body(j, 0.3, Vec3(0.02, 0, 0.01), Vec3(1e-3, 2e-3, 3e-3).asDiagonal());
  // the rod's base pose as MuJoCo compiled it (euler, in the compiler's angle unit)
  const int base = rb.base_body;
  SE3 pb;
  for (int k = 0; k < 3; ++k) pb.u(k) = s.m->body_pos[3 * base + k];
  mjtNum mat[9];
  mju_quat2Mat(mat, s.m->body_quat + 4 * base);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) pb.R(a, b) = mat[3 * a + b];
  const int r = m.add_rod(j, pb, rb.decl.spec);
  m.add_body(m.rods[r].tip_node, 0.05, Vec3(0.01, 0, 0), Vec3(2e-5, 1e-5, 1e-5).asDiagonal());
  m.finalize();
  return m;
}

void expect_same_trajectory(const char* strain, int sections, int order, double visc, Integrator it, double tol) {
  SCOPED_TRACE(std::string(strain) + " sections " + std::to_string(sections) + " order " + std::to_string(order));
  auto s = load_scene_string(arm_xml(strain, sections, order, visc), kPath);
  s->newton_iterations = 0;  // the core's implicit and trapezoidal steps are the linearised ones
  SceneData sd(*s);
  const Model cm = core_arm(*s);
  Data cd(cm);
  ASSERT_EQ(cm.nv, s->m->nv);
  sd.d->qvel[0] = cd.v(0) = 1.5;  // spin the shoulder
  double worst = 0.0, qmax = 0.0;
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(*s, sd, it), Status::Ok);
    ASSERT_EQ(step(cm, cd, 1e-3, it), Status::Ok);
    for (int i = 0; i < cm.nv; ++i) {
      worst = std::max(worst, std::abs(sd.d->qpos[i] - cd.q(i)));
      qmax = std::max(qmax, std::abs(cd.q(i)));
    }
  }
  EXPECT_GT(qmax, 0.1);  // it really moved
  // both integrate the same equations with the same scheme: differences are round-off growth
  EXPECT_LT(worst, tol) << "max |q_mujoco - q_core| over 1000 steps";
}

TEST(Scene, SoftRigidTreeMatchesStandaloneCore) {
  expect_same_trajectory("kl", 3, 0, 0.0, Integrator::RK4, 1e-9);
  expect_same_trajectory("sr", 2, 0, 0.5, Integrator::Implicit, 1e-9);
  expect_same_trajectory("icc", 3, 0, 0.0, Integrator::Euler, 1e-9);
  // GVS with 8 dofs per section: MuJoCo needs helper bodies (6 dofs per body at most)
  expect_same_trajectory("kl", 2, 1, 0.2, Integrator::Implicit, 1e-9);
  expect_same_trajectory("sr", 2, 0, 0.5, Integrator::Trapezoidal, 1e-9);
  expect_same_trajectory("kl", 2, 1, 0.2, Integrator::Trapezoidal, 1e-9);
}

// A rod hanging from a rigid body at the tip of another rod (nested rods): the inner rod's base
// moves with the outer rod's strain dofs through MuJoCo's cdof of the outer proxies.
TEST(Scene, NestedRodsMatchStandaloneCore) {
  const char* xml = R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <cosserat name="outer" pos="0 0 1" length="0.3" sections="2" strain="kl" radius="0.01" density="1000"
              young="5e5" reststrain="0 0.5 1 1 0 0">
      <body name="knuckle" pos="0.01 0 0"><inertial pos="0 0 0" mass="0.03" diaginertia="1e-5 1e-5 1e-5"/>
        <cosserat name="inner" euler="0 30 0" length="0.2" sections="2" order="1" strain="icc" radius="0.006"
                  density="1100" young="3e5"/>
      </body>
    </cosserat></worldbody></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  SceneData sd(*s);
  ASSERT_EQ(s->rods.size(), 2u);
  const RodBinding& outer = s->rods[0];
  const RodBinding& inner = s->rods[1];
  ASSERT_LT(outer.base_body, inner.base_body);  // outer first: its patch moves the inner base
  Model m;
  SE3 p0;
  p0.u = Vec3(0, 0, 1);
  const int a = m.add_rod(-1, p0, outer.decl.spec);
  SE3 knuckle;
  knuckle.u = Vec3(0.01, 0, 0);
  const int kn = m.add_frame(m.rods[a].tip_node, knuckle);
  m.add_body(kn, 0.03, Vec3::Zero(), 1e-5 * Mat3::Identity());
  SE3 pb;  // the inner base as MuJoCo compiled it (relative to the knuckle)
  for (int k = 0; k < 3; ++k) pb.u(k) = s->m->body_pos[3 * inner.base_body + k];
  mjtNum mat[9];
  mju_quat2Mat(mat, s->m->body_quat + 4 * inner.base_body);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) pb.R(i, j) = mat[3 * i + j];
  m.add_rod(kn, pb, inner.decl.spec);
  m.finalize();
  Data cd(m);
  ASSERT_EQ(m.nv, s->m->nv);
  double worst = 0.0, qmax = 0.0;
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::RK4), Status::Ok);
    ASSERT_EQ(step(m, cd, 1e-3, Integrator::RK4), Status::Ok);
    for (int i = 0; i < m.nv; ++i) {
      worst = std::max(worst, std::abs(sd.d->qpos[i] - cd.q(i)));
      qmax = std::max(qmax, std::abs(cd.q(i)));
    }
  }
  EXPECT_GT(qmax, 0.1);
  EXPECT_LT(worst, 1e-9);
}

// The shape API: frames and strains of a rod at rest under no load equal its rest shape.
TEST(Scene, RodShapeAccess) {
  const char* xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <cosserat name="coil" pos="0 0 1" length="0.5" sections="4" strain="kl" reststrain="3 0 8 1 0 0"/>
  </worldbody></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  SceneData sd(*s);
  forward(*s, sd);
  const int r = rod_index(*s, "coil");
  ASSERT_EQ(r, 0);
  EXPECT_EQ(rod_index(*s, "nope"), -1);
  Vec6 rest;
  rest << 3, 0, 8, 1, 0, 0;
  for (double X : {0.0, 0.13, 0.5}) EXPECT_LT((rod_strain(*s, sd, r, X) - rest).norm(), 1e-12);
  // the centre line is the helix exp(X xi*) of the rest strain, from the base at (0, 0, 1)
  const auto pts = rod_centerline(*s, sd, r, 11);
  ASSERT_EQ(pts.size(), 11u);
  for (int i = 0; i < 11; ++i) {
    const Vec3 expected = Vec3(0, 0, 1) + exp_se3(0.05 * i, rest).u;
    EXPECT_LT((pts[i] - expected).norm(), 1e-12);
    EXPECT_LT((rod_frame(*s, sd, r, 0.05 * i).u - expected).norm(), 1e-12);
  }
}

TEST(Scene, ProxiesAndHelpersCarryNoInertia) {
  auto s = load_scene_string(arm_xml("kl", 2, 1, 0.0), kPath);
  const RodBinding& rb = s->rods[0];
  ASSERT_FALSE(rb.helper_body[0].empty());
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    EXPECT_EQ(s->m->body_mass[rb.proxy_body[i]], 0.0);
    for (int h : rb.helper_body[i]) EXPECT_EQ(s->m->body_mass[h], 0.0);
  }
  for (int k = 0; k < rb.model.nv; ++k) EXPECT_EQ(s->m->dof_armature[rb.dof0 + k], 0.0);
}

// A user's <default> joint attributes reach the user's joints, never the generated strain joints
// (the rod's elasticity, damping and inertia are the solver's): a springdamper (from which MuJoCo's
// compiler computes stiffness and damping), stiffness, damping, armature, friction loss, limits,
// range and margin, and the softness of limits (outside probe BQ: a default's solreflimit and
// solimplimit reached the limited strain joints of a rod with a strainrange, moving its resting tip
// by 0.12 m; they take the rod's, or MuJoCo's defaults).
TEST(Scene, UserJointDefaultsDoNotReachTheStrainJoints) {
  const std::string plain = arm_xml("kl", 3, 0, 0.0);
  const std::string with_defaults = replace_all(
      plain, "<worldbody>",
      R"(<default><joint springdamper="0.05 1" stiffness="10" damping="3" armature="0.1" frictionloss="0.2"
           limited="true" range="-0.1 0.1" margin="0.02" solreflimit="0.1 0.5" solimplimit="0.5 0.6 0.01 0.4 3"/></default><worldbody>)");
  ASSERT_NE(with_defaults, plain);
  auto s = load_scene_string(with_defaults, kPath);
  const mjModel* m = s->m;
  const RodBinding& rb = s->rods[0];
  for (int k = 0; k < rb.model.nv; ++k) {
    const int dof = rb.dof0 + k, j = m->dof_jntid[dof];
    EXPECT_EQ(m->jnt_stiffness[j], 0.0) << k;
    EXPECT_EQ(m->dof_damping[dof], 0.0) << k;
    EXPECT_EQ(m->dof_armature[dof], 0.0) << k;
    EXPECT_EQ(m->dof_frictionloss[dof], 0.0) << k;
    EXPECT_EQ(m->jnt_limited[j], 0) << k;
    // nor a range and margin that a program setting jnt_limited from C would inherit (probe P)
    EXPECT_EQ(m->jnt_range[2 * j], 0.0) << k;
    EXPECT_EQ(m->jnt_range[2 * j + 1], 0.0) << k;
    EXPECT_EQ(m->jnt_margin[j], 0.0) << k;
  }
  // the user's hinge has them
  EXPECT_GT(m->jnt_stiffness[0], 0.0);
  EXPECT_EQ(m->jnt_solref[0], 0.1);
  // limited strain joints: MuJoCo's default softness, or the rod's own
  for (const std::string rod_softness : {"", R"( solreflimit="0.03 0.8" solimplimit="0.8 0.9 0.002")"}) {
    SCOPED_TRACE(rod_softness);
    const std::string limited = replace_all(with_defaults, "<cosserat ",
                                            R"(<cosserat strainrange="0 0 -5 5 -5 5 0 0 0 0 0 0")" + rod_softness + " ");
    ASSERT_NE(limited, with_defaults);
    auto sl = load_scene_string(limited, kPath);
    const RodBinding& rl = sl->rods[0];
    const double solref[2] = {rod_softness.empty() ? 0.02 : 0.03, rod_softness.empty() ? 1.0 : 0.8};
    const double solimp[5] = {rod_softness.empty() ? 0.9 : 0.8, rod_softness.empty() ? 0.95 : 0.9,
                              rod_softness.empty() ? 0.001 : 0.002, 0.5, 2.0};
    int nlimited = 0;
    for (int k = 0; k < rl.model.nv; ++k) {
      const int j = sl->m->dof_jntid[rl.dof0 + k];
      if (!sl->m->jnt_limited[j]) continue;
      ++nlimited;
      for (int e = 0; e < 2; ++e) EXPECT_EQ(sl->m->jnt_solref[mjNREF * j + e], solref[e]) << k;
      for (int e = 0; e < 5; ++e) EXPECT_EQ(sl->m->jnt_solimp[mjNIMP * j + e], solimp[e]) << k;
    }
    EXPECT_GT(nlimited, 0);
  }
  // the rod sags as without the defaults (the hub's hinge held still by its own)
  auto tip_after = [](const std::string& xml) {
    auto sc = load_scene_string(xml, kPath);
    SceneData sd(*sc);
    sc->m->jnt_stiffness[0] = 0.0;
    sc->m->dof_damping[0] = 0.0;
    sc->m->dof_armature[0] = 0.0;
    sc->m->dof_frictionloss[0] = 0.0;
    sc->m->jnt_limited[0] = 0;
    const int tip = mj_name2id(sc->m, mjOBJ_SITE, "rod/tip");
    auto at = [&] { return Vec3(sd.d->site_xpos[3 * tip], sd.d->site_xpos[3 * tip + 1], sd.d->site_xpos[3 * tip + 2]); };
    forward(*sc, sd);
    const Vec3 start = at();
    for (int k = 0; k < 200; ++k) step(*sc, sd);
    return std::make_pair(start, at());
  };
  const auto [a0, a] = tip_after(plain);
  const auto [b0, b] = tip_after(with_defaults);
  EXPECT_GT((a - a0).norm(), 0.01);  // it sags
  EXPECT_LT((a - b).norm(), 1e-12) << a.transpose() << " against " << b.transpose();
}

// MuJoCo's compiled model at qpos0 is the rod's rest shape (curved here; one GVS section): MuJoCo's
// own kinematics place the proxies, capsules and sites where the rod puts them at rest, so that
// what its compiler computes there is the rod's: a weld of the tip body and a connect at a proxy
// (relative poses from qpos0) and a tendon spring with no springlength (rest length from qpos0)
// hold the rod at rest, and the tendon's length at qpos0 is its rest length.
TEST(Scene, MujocosQpos0IsTheRodsRestShape) {
  const char* xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" pos="0.02 0 0" euler="0 20 0" length="0.3" sections="3" strain="kl" radius="0.01"
                reststrain="1 0 4 1 0 0" viscosity="1">
        <section/><section order="2" reststrain="0 -3 2 1 0 0"/><section/>
        <site name="c1" at="0.15" pos="0 0.005 0"/>
        <body name="tip"><geom type="sphere" size="0.01" mass="0.01"/></body>
      </cosserat></body></worldbody>
    <equality><weld body1="tip"/><connect body1="arm/s1" body2="hub" anchor="0.01 0 0"/></equality>
    <tendon><spatial name="t" stiffness="50"><site site="c1"/><site site="arm/tip"/></spatial></tendon>
  </mujoco>)";
  auto s = load_scene_string(xml, kPath);
  const mjModel* m = s->m;
  SceneData sd(*s);
  forward(*s, sd);
  // MuJoCo's kinematics at qpos0, on its own
  mjData* raw = mj_makeData(m);
  mj_kinematics(m, raw);
  const RodBinding& rb = s->rods[0];
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    const int b = rb.proxy_body[i];
    for (int e = 0; e < 3; ++e) EXPECT_NEAR(raw->xpos[3 * b + e], sd.d->xpos[3 * b + e], 1e-14) << i;
    for (int e = 0; e < 9; ++e) EXPECT_NEAR(raw->xmat[9 * b + e], sd.d->xmat[9 * b + e], 1e-14) << i;
  }
  for (int id : rb.site_id)
    for (int e = 0; e < 3; ++e) EXPECT_NEAR(raw->site_xpos[3 * id + e], sd.d->site_xpos[3 * id + e], 1e-14) << id;
  for (int id : rb.geom_id)
    for (int e = 0; e < 3; ++e) EXPECT_NEAR(raw->geom_xpos[3 * id + e], sd.d->geom_xpos[3 * id + e], 1e-14) << id;
  mj_deleteData(raw);
  EXPECT_NEAR(m->tendon_lengthspring[0], sd.d->ten_length[0], 1e-14);
  EXPECT_NEAR(m->tendon_length0[0], sd.d->ten_length[0], 1e-14);
  const int tip = mj_name2id(m, mjOBJ_SITE, "arm/tip");
  const Vec3 start(sd.d->site_xpos + 3 * tip);
  for (int k = 0; k < 300; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
  EXPECT_LT((Vec3(sd.d->site_xpos + 3 * tip) - start).norm(), 1e-12);
}

// With <flag energy="enable"/> MuJoCo's d->energy (potential, kinetic) counts the rods: the
// kinetic part is 1/2 v^T M v with the scene's mass matrix, and both are energy()'s.
TEST(Scene, EnergyFlagFillsMujocosEnergyWithTheRods) {
  const std::string xml = replace_all(arm_xml("kl", 3, 0, 0.0), "<option timestep=\"0.001\"",
                                      "<option timestep=\"0.001\"><flag energy=\"enable\"/></option><option");
  auto s = load_scene_string(xml, kPath);
  ASSERT_TRUE(s->m->opt.enableflags & mjENBL_ENERGY);
  SceneData sd(*s);
  for (int k = 0; k < 50; ++k) step(*s, sd);
  forward(*s, sd);
  const double potential = sd.d->energy[0], kinetic = sd.d->energy[1];
  std::vector<mjtNum> Mv(s->m->nv);
  mj_mulM(s->m, sd.d, Mv.data(), sd.d->qvel);
  const double vMv = 0.5 * mju_dot(sd.d->qvel, Mv.data(), s->m->nv);
  EXPECT_GT(kinetic, 1e-4);
  EXPECT_NEAR(kinetic, vMv, 1e-9 * vMv);
  const SceneEnergy e = energy(*s, sd);
  EXPECT_NEAR(potential, e.gravity + e.elastic, 1e-12);
  EXPECT_GT(e.elastic, 1e-6);
}

// The springs of ball and free joints are in energy() as in MuJoCo's mj_energyPos (outside probe W:
// they had been left out, and a conservative scene read "drift 1.00"): a rod-free scene, whose
// forward is MuJoCo's, turned and shifted from the springs' rest, against d->energy.
TEST(Scene, EnergyCountsBallAndFreeJointSpringsAsMujocoDoes) {
  const char* xml = R"(<mujoco><option><flag energy="enable"/></option><worldbody>
    <body name="a" pos="0 0 1"><joint type="ball" stiffness="300"/><geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/></body>
    <body name="b" pos="1 0 1"><freejoint/><geom type="box" size="0.05 0.04 0.03"/></body>
    <body name="c" pos="2 0 1"><joint type="free" stiffness="200"/><geom type="sphere" size="0.05"/></body>
  </worldbody></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  SceneData sd(*s);
  const mjtNum turn[4] = {std::cos(0.3), 0.3 * std::sin(0.3), -0.8 * std::sin(0.3), 0.52 * std::sin(0.3)};
  mju_copy4(sd.d->qpos, turn);                // ball: 0.6 rad about an oblique axis
  sd.d->qpos[11] += 0.1;                      // c: shifted
  mju_copy4(sd.d->qpos + 14, turn);           // and turned
  forward(*s, sd);
  const SceneEnergy e = energy(*s, sd);
  EXPECT_GT(e.elastic, 0.5 * 300 * 0.36 * 0.99);
  EXPECT_NEAR(e.gravity + e.elastic, sd.d->energy[0], 1e-12 * std::abs(sd.d->energy[0]));
}

// Conservation: no gravity, no damping, RK4: the whole scene's energy stays put.
TEST(Scene, EnergyConservedUndampedRK4) {
  std::string x = replace_all(arm_xml("kl", 3, 0, 0.0), "gravity=\"0 0 -9.81\"", "gravity=\"0 0 0\"");
  auto s = load_scene_string(x, kPath);
  SceneData sd(*s);
  sd.d->qvel[0] = 2.0;
  sd.d->qpos[s->rods[0].qpos0 + 1] = 0.8;  // bend the first section
  forward(*s, sd);
  const double E0 = energy(*s, sd).total();
  double drift = 0.0;
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::RK4), Status::Ok);
    forward(*s, sd);
    drift = std::max(drift, std::abs(energy(*s, sd).total() - E0));
  }
  std::printf("relative energy drift over 2000 RK4 steps (h = 1 ms): %.2e\n", drift / E0);
  EXPECT_LT(drift, 1e-6 * E0);  // RK4 at h = 1 ms on modes of ~50 Hz: O((w h)^4) per period
}

// Free-floating conservation: a free hub carrying a PCS and a GVS rod, gravity off, no damping,
// driven by motors on strain coordinates (internal forces). Linear and angular momentum stay
// constant to integrator accuracy (RK4: the drift shrinks ~16x when the step halves).
TEST(Scene, FreeFloatingMomentumConservedUnderInternalActuation) {
  const char* xml = R"(<mujoco>
    <option timestep="TIMESTEP" gravity="0 0 0"/>
    <worldbody>
      <body name="hub" pos="0 0 1"><freejoint/>
        <inertial pos="0.01 0 0" mass="0.2" diaginertia="2e-4 3e-4 4e-4"/>
        <cosserat name="a" length="0.3" sections="3" strain="kl" radius="0.01" density="1000" young="2e5"
                  reststrain="0 1 2 1 0 0"/>
        <cosserat name="b" euler="0 0 120" length="0.2" sections="1" order="2" strain="icc" radius="0.008"
                  density="1200" young="3e5"/>
      </body>
    </worldbody>
    <actuator><motor joint="a/s0/kz"/><motor joint="b/s0/ky1"/></actuator>
  </mujoco>)";
  double drift[2];
  for (int run = 0; run < 2; ++run) {
    const double h = run == 0 ? 1e-3 : 5e-4;
    auto s = load_scene_string(replace_all(xml, "TIMESTEP", fmt(h)), kPath);
    SceneData sd(*s);
    for (int i = 0; i < 6; ++i) sd.d->qvel[i] = 0.3 * std::cos(1.0 + i);  // tumbling start
    forward(*s, sd);
    const Vec6 h0 = momentum(*s, sd);
    double worst = 0.0;
    const int n = static_cast<int>(0.5 / h);
    for (int k = 0; k < n; ++k) {
      // generalised forces on curvature coordinates: 1e-4 N m^2 against K = EI L_s ~ 1.6e-4 N m^3
      sd.d->ctrl[0] = 1e-4 * std::sin(20.0 * sd.d->time);
      sd.d->ctrl[1] = 1e-4 * std::cos(13.0 * sd.d->time);
      ASSERT_EQ(step(*s, sd, Integrator::RK4), Status::Ok);
      forward(*s, sd);
      worst = std::max(worst, (momentum(*s, sd) - h0).norm());
    }
    drift[run] = worst / h0.norm();
    std::printf("h = %g: relative momentum drift over 0.5 s (RK4) %.2e\n", h, drift[run]);
  }
  EXPECT_LT(drift[0], 1e-6);
  EXPECT_TRUE(drift[1] < drift[0] / 8 || drift[1] < 1e-12);  // 4th order: ~16x per halving
}

// ---- rigid rods against native MuJoCo bodies ------------------------------------------------

// rod: length L, radius r, density rho, `rigid` sections. Native: one body with the rod's inertia.
constexpr double kL = 0.3, kR = 0.01, kRho = 1000.0;

std::string rigid_rod_scene(bool native, const std::string& joint, const char* gravity, const std::string& extra = "") {
  const double m = kRho * M_PI * kR * kR * kL;
  const double ixx = 0.5 * m * kR * kR, iyy = 0.25 * m * kR * kR + m * kL * kL / 12.0;
  std::string rod;
  if (native)
    rod = "<body name=\"rod\" pos=\"0.02 0 0\"><inertial pos=\"" + fmt(kL / 2) + " 0 0\" mass=\"" + fmt(m) +
          "\" diaginertia=\"" + fmt(ixx) + " " + fmt(iyy) + " " + fmt(iyy) + "\"/></body>";
  else
    rod = "<cosserat name=\"rod\" pos=\"0.02 0 0\" length=\"" + fmt(kL) + "\" sections=\"3\" strain=\"rigid\" radius=\"" +
          fmt(kR) + "\" density=\"" + fmt(kRho) + "\"/>";
  return std::string("<mujoco><option timestep=\"0.001\" gravity=\"") + gravity +
         "\"/><worldbody><body name=\"hub\" pos=\"0 0 1\">" + joint +
         "<inertial pos=\"0 0 0\" mass=\"0.05\" diaginertia=\"1e-5 1e-5 1e-5\"/>" + rod + "</body></worldbody>" + extra +
         "</mujoco>";
}

void expect_rigid_equivalence(const std::string& joint, const char* gravity, const std::vector<double>& v0,
                              const std::string& extra = "") {
  SCOPED_TRACE(joint + " gravity " + gravity + " " + extra);
  auto sr = load_scene_string(rigid_rod_scene(false, joint, gravity, extra), kPath);
  auto sn = load_scene_string(rigid_rod_scene(true, joint, gravity, extra), kPath);
  SceneData dr(*sr), dn(*sn);
  ASSERT_EQ(sr->m->nv, sn->m->nv);
  for (size_t i = 0; i < v0.size(); ++i) dr.d->qvel[i] = dn.d->qvel[i] = v0[i];
  double worst = 0.0;
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(*sr, dr, Integrator::Euler), Status::Ok);
    ASSERT_EQ(step(*sn, dn, Integrator::Euler), Status::Ok);
    for (int i = 0; i < sr->m->nq; ++i) worst = std::max(worst, std::abs(dr.d->qpos[i] - dn.d->qpos[i]));
  }
  EXPECT_LT(worst, 1e-9);
}

// Tracking cameras: MuJoCo computes their offsets at compile time, when the proxies still carry
// temporary masses; after loading they must sit where the user placed them, as in the native
// scene. (At run time trackcom follows MuJoCo's subtree centre of mass: rigid bodies only.)
TEST(Scene, TrackingCamerasStartWhereTheyArePlaced) {
  for (const char* mode : {"trackcom", "track"}) {
    SCOPED_TRACE(mode);
    const std::string cam = std::string("<camera name=\"c\" mode=\"") + mode +
                            "\" pos=\"0.1 -0.5 0.2\"/>";
    const std::string j = "<joint type=\"hinge\" axis=\"0 1 0\"/>" + cam;
    auto sr = load_scene_string(rigid_rod_scene(false, j, "0 0 -9.81"), kPath);
    auto sn = load_scene_string(rigid_rod_scene(true, j, "0 0 -9.81"), kPath);
    SceneData dr(*sr), dn(*sn);
    forward(*sr, dr);
    forward(*sn, dn);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(dr.d->cam_xpos[k], dn.d->cam_xpos[k], 1e-12) << k;
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(dr.d->cam_xmat[k], dn.d->cam_xmat[k], 1e-12) << k;
  }
}

// Cameras and lights that follow (trackcom) or look at (targetbodycom) a subtree's centre of mass
// count the rod in it: as in the native scene with the rod's inertia, at qpos0 and moved.
TEST(Scene, CentreOfMassTrackingCountsTheRod) {
  const std::string j =
      "<joint type=\"hinge\" axis=\"0.3 1 0\"/><camera name=\"c\" mode=\"trackcom\" pos=\"0.1 -0.5 0.2\"/>"
      "<light name=\"l\" mode=\"trackcom\" pos=\"0 0 0.5\"/>";
  const std::string extra =
      "<worldbody><camera name=\"t\" mode=\"targetbodycom\" target=\"hub\" pos=\"0.5 -0.5 1.5\"/>"
      "<light name=\"tl\" mode=\"targetbodycom\" target=\"hub\" pos=\"-0.5 0.3 2\"/></worldbody>";
  auto sr = load_scene_string(rigid_rod_scene(false, j, "0 0 -9.81", extra), kPath);
  auto sn = load_scene_string(rigid_rod_scene(true, j, "0 0 -9.81", extra), kPath);
  EXPECT_EQ(sr->com_cameras.size(), 2u);
  EXPECT_EQ(sr->com_lights.size(), 2u);
  SceneData dr(*sr), dn(*sn);
  for (double q : {0.0, 0.7}) {
    SCOPED_TRACE(q);
    dr.d->qpos[0] = dn.d->qpos[0] = q;
    forward(*sr, dr);
    forward(*sn, dn);
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(dr.d->cam_xpos[k], dn.d->cam_xpos[k], 1e-12) << k;
    for (int k = 0; k < 18; ++k) EXPECT_NEAR(dr.d->cam_xmat[k], dn.d->cam_xmat[k], 1e-12) << k;
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(dr.d->light_xpos[k], dn.d->light_xpos[k], 1e-12) << k;
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(dr.d->light_xdir[k], dn.d->light_xdir[k], 1e-12) << k;
  }
}

TEST(Scene, RigidRodOnHingeBehavesLikeNativeBody) {
  for (const char* g : {"0 0 -9.81", "0 0 0"})
    expect_rigid_equivalence("<joint type=\"hinge\" axis=\"0.3 1 0\"/>", g, {2.0});
}

TEST(Scene, RigidRodOnFreeBodyBehavesLikeNativeBody) {
  for (const char* g : {"0 0 -9.81", "0 0 0"})
    expect_rigid_equivalence("<freejoint/>", g, {0.1, -0.2, 0.3, 1.0, 2.0, -0.5});
}

// A free hub welded to the world by an equality constraint holds the rod's weight: the
// constraint rows see the rod's inertia through the hub's dofs.
TEST(Scene, RigidRodOnWeldedBodyBehavesLikeNativeBody) {
  expect_rigid_equivalence("<freejoint/>", "0 0 -9.81", {0.1, 0, 0, 0, 0.5, 0},
                           "<equality><weld body1=\"hub\"/></equality>");
}

// Capsules and sites on rigid sections keep a pose cached relative to their section's start
// frame: at a bent, moving state they sit where the rod puts them (chord of the centreline,
// capsule axis along the chord; a site at its abscissa and cross-section offset).
TEST(Scene, RigidSectionPlacementsFollowTheRod) {
  const char* xml = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><freejoint/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" length="0.4" strain="kl" radius="0.01">
        <section length="0.15"/>
        <section length="0.1" strain="rigid" reststrain="6 0 9 1 0 0"/>
        <section length="0.1"/>
        <section length="0.05" strain="rigid"/>
        <site name="on_rigid" at="0.2" pos="0 0.01 0.002"/>
        <site name="on_tip" at="0.38" pos="0.003 0 0.01"/>
      </cosserat>
    </body></worldbody></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  const RodBinding& rb = s->rods[0];
  int fixed_geoms = 0, fixed_sites = 0;
  for (const auto& f : rb.geom_fixed) fixed_geoms += f.fixed;
  for (const auto& f : rb.site_fixed) fixed_sites += f.fixed;
  EXPECT_GE(fixed_geoms, 2);  // the capsules of both rigid sections
  EXPECT_EQ(fixed_sites, 2 + 1 + 1);  // the two user sites, "arm/tip" and "arm/base" (on the base body)
  SceneData sd(*s);
  for (int i = 0; i < 7; ++i) sd.d->qpos[i] += 0.1 * std::sin(1.0 + i);
  for (int k = 0; k < rb.model.nv; ++k) sd.d->qpos[rb.qpos0 + k] = 0.7 * std::cos(0.5 + 1.3 * k);
  forward(*s, sd);
  for (size_t k = 0; k < rb.geom_id.size(); ++k) {
    const RodGeomDecl& gd = rb.decl.geoms[k];
    const Vec3 a = rod_frame(*s, sd, 0, gd.X_begin).u, b = rod_frame(*s, sd, 0, gd.X_end).u;
    const int id = rb.geom_id[k];
    const Vec3 centre = Eigen::Map<const Vec3>(sd.d->geom_xpos + 3 * id);
    const Vec3 z(sd.d->geom_xmat[9 * id + 2], sd.d->geom_xmat[9 * id + 5], sd.d->geom_xmat[9 * id + 8]);
    EXPECT_LT((centre - 0.5 * (a + b)).norm(), 1e-12) << gd.name;
    EXPECT_LT((z - (b - a).normalized()).norm(), 1e-12) << gd.name;
    EXPECT_NEAR(s->m->geom_size[3 * id + 1], 0.5 * (b - a).norm(), 1e-12) << gd.name;
  }
  // the soft sections' capsules meet in the middle of a step: that pose comes with the kinematics
  // (Model::keep_midpoint_pose), and it is the partial step's pose there
  int kept = 0;
  cosserat::Model plain = rb.model;
  for (cosserat::Node& n : plain.nodes) {
    kept += n.keep_mid;
    n.keep_mid = false;
  }
  EXPECT_EQ(kept, 2);
  cosserat::Data dp(plain);
  dp.q = sd.rod[0].q;
  dp.base_pose = sd.rod[0].base_pose;
  cosserat::fwd_position(plain, dp);
  for (const RodGeomDecl& gd : rb.decl.geoms)
    for (double X : {gd.X_begin, gd.X_end})
      EXPECT_LT((rod_frame(*s, sd, 0, X).matrix() - cosserat::rod_pose(plain, dp, 0, X).matrix()).norm(), 1e-14) << X;
  for (size_t k = 0; k < rb.site_id.size(); ++k) {
    const RodSiteDecl& sdl = rb.decl.sites[k];
    const SE3 g = rod_frame(*s, sd, 0, sdl.X);
    const int id = rb.site_id[k];
    EXPECT_LT((Eigen::Map<const Vec3>(sd.d->site_xpos + 3 * id) - (g.u + g.R * sdl.pos)).norm(), 1e-12) << sdl.name;
    for (int e = 0; e < 9; ++e) EXPECT_NEAR(sd.d->site_xmat[9 * id + e], g.R(e / 3, e % 3), 1e-12) << sdl.name;
  }
}

}  // namespace

namespace {

// --- the implicit steps without the accelerations (Need::Forces, SceneData::forces_only) ---

// A rod on a motorised hinge, with viscosity, a tip weight pushed by xfrc_applied and no contact;
// `accelerometer` adds a sensor of the acceleration stage, which makes forward compute them.
std::string forces_only_xml(bool accelerometer) {
  return std::string(R"(<mujoco>
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="hub" pos="0 0 1">
      <joint name="h" type="hinge" axis="0 1 0.2" damping="0.01"/>
      <geom type="sphere" size="0.03" mass="0.1" contype="0" conaffinity="0"/>
      <cosserat name="rod" length="0.4" sections="3" strain="kl" radius="0.01" density="1000"
                young="1e6" poisson="0.5" viscosity="5" contype="0" conaffinity="0">
        <site name="mid" at="0.2"/>
        <body name="weight" pos="0.02 0 0"><geom type="sphere" size="0.02" mass="0.05" contype="0" conaffinity="0"/></body>
      </cosserat>
    </body>
  </worldbody>
  <actuator><velocity joint="h" kv="0.5"/></actuator>)") +
         (accelerometer ? "<sensor><accelerometer site=\"mid\"/></sensor>" : "") + "</mujoco>";
}

void push_weight(const Scene& s, SceneData& sd) {
  const int b = mj_name2id(s.m, mjOBJ_BODY, "weight");
  const double w[6] = {0.1, -0.2, 0.05, 0.003, 0.01, -0.002};
  std::copy(w, w + 6, sd.d->xfrc_applied + 6 * b);
  sd.d->ctrl[0] = 2.0;
}

// forward(Need::Forces) skips the accelerations only where nothing needs them, and its
// qfrc_smooth (computed without MuJoCo's mj_fwdAcceleration) is MuJoCo's.
TEST(Scene, ForcesOnlyForwardGivesMujocosSmoothForces) {
  auto s = load_scene_string(forces_only_xml(false), kPath);
  SceneData sd(*s);
  const int nv = s->m->nv;
  for (int i = 0; i < nv; ++i) sd.d->qvel[i] = 0.3 * std::sin(1.7 * i + 0.2);
  sd.d->qpos[0] = 0.4;
  push_weight(*s, sd);
  forward(*s, sd, Need::Forces);
  ASSERT_TRUE(sd.forces_only) << "no constraint, no acceleration sensor: the accelerations are not needed";
  const std::vector<double> f(sd.d->qfrc_smooth, sd.d->qfrc_smooth + nv);
  forward(*s, sd);
  EXPECT_FALSE(sd.forces_only);
  double scale = 0.0, err = 0.0;
  for (int i = 0; i < nv; ++i) {
    scale = std::max(scale, std::abs(sd.d->qfrc_smooth[i]));
    err = std::max(err, std::abs(sd.d->qfrc_smooth[i] - f[i]));
  }
  EXPECT_GT(scale, 0.0);
  EXPECT_LE(err, 1e-14 * scale);

  // an acceleration-stage sensor needs qacc: nothing is skipped
  auto sa = load_scene_string(forces_only_xml(true), kPath);
  SceneData sda(*sa);
  forward(*sa, sda, Need::Forces);
  EXPECT_FALSE(sda.forces_only);
}

// Need::StaticForces (the static solver's finite differences) gives the full pipeline's qfrc_smooth
// at rest without assembling the mass matrix (qM is left as it was), with and without constraint
// rows (a joint limit in force, which makes the full pipeline factorise M).
TEST(Scene, StaticForcesAreMujocosWithoutTheMassMatrix) {
  for (const bool limited : {false, true}) {
    SCOPED_TRACE(limited ? "a joint limit in force" : "no constraint");
    std::string xml = forces_only_xml(false);
    if (limited) xml = replace_all(xml, R"(damping="0.01")", R"(damping="0.01" limited="true" range="-0.1 0.1")");
    auto s = load_scene_string(xml, kPath);
    SceneData sd(*s);
    const int nv = s->m->nv;
    sd.d->qpos[0] = 0.4;
    for (int i = 1; i < s->m->nq; ++i) sd.d->qpos[i] = 0.2 * std::sin(1.3 * i);
    push_weight(*s, sd);
    forward(*s, sd);
    EXPECT_EQ(sd.d->nefc > 0, limited);
    const std::vector<double> f(sd.d->qfrc_smooth, sd.d->qfrc_smooth + nv);
    std::fill(sd.d->qM, sd.d->qM + s->m->nM, std::nan(""));  // a sentinel: must stay
    mju_zero(sd.d->qfrc_smooth, nv);
    fwd_position(*s, sd, Need::StaticForces);
    fwd_velocity(*s, sd);
    mj_fwdActuation(s->m, sd.d);
    smooth_forces(s->m, sd.d);
    EXPECT_TRUE(sd.forces_only);
    double scale = 0.0, err = 0.0;
    for (int i = 0; i < nv; ++i) {
      scale = std::max(scale, std::abs(f[i]));
      err = std::max(err, std::abs(sd.d->qfrc_smooth[i] - f[i]));
    }
    EXPECT_GT(scale, 0.0);
    EXPECT_LE(err, 1e-14 * scale);
    for (int i = 0; i < s->m->nM; ++i) ASSERT_TRUE(std::isnan(sd.d->qM[i])) << "qM[" << i << "] was assembled";
  }
}

// Steps that skip the accelerations equal those that compute them (the scene with the sensor),
// for every scheme that solves with the implicit matrix: the linearised implicit and trapezoidal
// steps and the Newton iterations of backward Euler, the trapezoidal rule and the generalized alpha.
TEST(Scene, StepsWithoutAccelerationsEqualTheFullPipeline) {
  struct Case {
    Integrator it;
    int newton;
    double rho;
  };
  for (const Case c : {Case{Integrator::Implicit, 0, 0.8}, Case{Integrator::Trapezoidal, 0, 0.8},
                       Case{Integrator::Implicit, 10, 0.8}, Case{Integrator::Trapezoidal, 10, 0.8},
                       Case{Integrator::GeneralizedAlpha, 10, 0.8}, Case{Integrator::GeneralizedAlpha, 10, 0.0}}) {
    std::vector<double> q[2];
    bool skipped[2] = {false, false};
    for (int with_sensor = 0; with_sensor < 2; ++with_sensor) {
      auto s = load_scene_string(forces_only_xml(with_sensor), kPath);
      s->newton_iterations = c.newton;
      s->rho_inf = c.rho;
      SceneData sd(*s);
      push_weight(*s, sd);
      for (int k = 0; k < 200; ++k) {
        ASSERT_EQ(step(*s, sd, c.it), Status::Ok);
        skipped[with_sensor] = skipped[with_sensor] || sd.forces_only;
      }
      q[with_sensor].assign(sd.d->qpos, sd.d->qpos + s->m->nq);
    }
    SCOPED_TRACE("integrator " + std::to_string(static_cast<int>(c.it)) + ", newton " + std::to_string(c.newton) +
                 ", rho " + std::to_string(c.rho));
    EXPECT_TRUE(skipped[0]);
    // with the sensor, the step's first evaluation (the start state's, whose sensors a step leaves)
    // computes the accelerations; the Newton iterates, which skip the sensors, skip them too
    EXPECT_EQ(skipped[1], c.newton > 0);
    double moved = 0.0, diff = 0.0;
    for (size_t i = 0; i < q[0].size(); ++i) {
      moved = std::max(moved, std::abs(q[1][i]));
      diff = std::max(diff, std::abs(q[0][i] - q[1][i]));
    }
    EXPECT_GT(moved, 0.1);
    EXPECT_LE(diff, 1e-9) << "skipping the accelerations changed the trajectory";
  }
}

// A sensor of the acceleration stage makes forward solve for qacc, but the implicit steps still take
// the forces without constraints (M qacc = qfrc_smooth): on a rod whose mass matrix is nearly
// singular (20 icc sections of order 6: MuJoCo warns) M (M^-1 f) is f only to cond(M) times the
// round-off, and with it the midpoint rule's Newton iteration needed 2.87 corrections per step
// instead of 1.97 (30 sections: 176, a hundred times the wall time; an outside fuzzing probe).
TEST(Scene, AnAccelerationSensorLeavesTheNewtonIterationOfAnIllConditionedRodAlone) {
  auto xml = [](bool sensor) {
    return std::string(R"(<mujoco><option timestep="0.001"/><worldbody>
      <body name="hub" pos="0 0 0.5"><joint name="shoulder" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
        <cosserat name="arm" pos="0.02 0 0" length="0.3" sections="20" strain="icc" order="6"
                  radius="0.012 0.004" density="1080" young="5e5" poisson="0.45"/>
      </body></worldbody>)") +
           (sensor ? "<sensor><touch site=\"arm/tip\"/></sensor>" : "") + "</mujoco>";
  };
  long iterations[2];
  std::vector<double> q[2];
  void (*warn)(const char*) = mju_user_warning;
  mju_user_warning = [](const char*) {};  // MuJoCo's "inertia matrix is too close to singular", each step
  for (int sensor = 0; sensor < 2; ++sensor) {
    auto s = load_scene_string(xml(sensor), kPath);
    SceneData sd(*s);
    for (int k = 0; k < 30; ++k) ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
    iterations[sensor] = sd.newton_stats.iterations;
    q[sensor].assign(sd.d->qpos, sd.d->qpos + s->m->nq);
  }
  mju_user_warning = warn;
  EXPECT_EQ(iterations[1], iterations[0]);
  EXPECT_LE(iterations[1], 2 * 30);
  double diff = 0.0, moved = 0.0;
  for (size_t i = 0; i < q[0].size(); ++i) {
    diff = std::max(diff, std::abs(q[1][i] - q[0][i]));
    moved = std::max(moved, std::abs(q[0][i]));
  }
  EXPECT_GT(moved, 1e-3);
  EXPECT_LE(diff, 1e-9 * moved);
}

}  // namespace

namespace {

// SceneData::compression records the smallest axial stretch the steps saw. The string of
// docs/bench/repro/soft_string_collapse.xml (E = 1e3 Pa, stretching 6-8x under its own weight) run
// accurately (the energy-keeping midpoint rule at 2 ms; the linearised implicit step at 0.2 ms
// agrees) inverts its second section at about 1.8 s: the record stops there, at a stretch <= 0.
// The same string a hundred times stiffer, and an extensible arm swinging under gravity, stay
// near 1; an inextensible rod has nothing to record; reset() clears the record, and a step after
// MuJoCo's mj_resetData starts a new one.
TEST(Scene, CompressionRecordsTheMostCompressedSection) {
  const std::string soft = cosserat::testing::read_text(COSSERAT_SOURCE_DIR "/docs/bench/repro/soft_string_collapse.xml");
  ASSERT_FALSE(soft.empty());
  auto run = [](const std::string& xml, Integrator in, double T) {
    auto s = load_scene_string(xml, kPath);
    SceneData sd(*s);
    const long n = std::lround(T / s->m->opt.timestep);
    for (long k = 0; k < n; ++k) EXPECT_EQ(step(*s, sd, in), Status::Ok) << "step " << k;
    SceneData::Compression c = sd.compression;
    if (c.stretch <= 0) {
      // MuJoCo's own reset starts a new run: its first step records afresh (outside probe AB: the
      // collapse outlived mj_resetData)
      mj_resetData(s->m, sd.d);
      EXPECT_EQ(step(*s, sd, in), Status::Ok);
      EXPECT_GT(sd.compression.stretch, 0.5);
      EXPECT_EQ(sd.compression.time, 0.0);
      reset(*s, sd);  // and reset() clears the record
      EXPECT_TRUE(std::isinf(sd.compression.stretch));
    }
    return c;
  };
  const SceneData::Compression c = run(soft, Integrator::Midpoint, 2.0);
  EXPECT_LE(c.stretch, 0.0);
  EXPECT_EQ(c.rod, 0);
  EXPECT_EQ(c.section, 1);
  EXPECT_GT(c.time, 1.7);
  EXPECT_LT(c.time, 1.9);
  const SceneData::Compression stiff =
      run(replace_all(soft, "young=\"1000\"", "young=\"1e5\""), Integrator::Midpoint, 0.5);
  EXPECT_GT(stiff.stretch, 0.9);
  EXPECT_LT(stiff.stretch, 1.0);
  const SceneData::Compression arm = run(arm_xml("kl", 3, 0, 0.0), Integrator::Implicit, 0.5);
  EXPECT_GT(arm.stretch, 0.99);
  EXPECT_LT(arm.stretch, 1.01);
  const SceneData::Compression ikl = run(arm_xml("ikl", 3, 0, 0.0), Integrator::Implicit, 0.1);
  EXPECT_TRUE(std::isinf(ikl.stretch));
  EXPECT_EQ(ikl.rod, -1);
}

}  // namespace

namespace {

// --- skipping the collision detection of scenes where nothing can touch (Scene::may_collide) ---

// Every geom overlaps every other (a floor, a ball on it, a rod lying across both, a body on the
// rod's tip), so MuJoCo's collision detection reports a contact for every pair its filters let
// through. `rod`, `ball`, `tip`: contype/conaffinity attributes; `extra`: more MJCF.
std::string overlap_xml(const std::string& rod, const std::string& ball, const std::string& tip,
                        const std::string& extra = "") {
  return R"(<mujoco>
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0.4 0 0.02"><freejoint/><geom name="ball" type="sphere" size="0.03" mass="0.1" )" +
         ball + R"(/></body>
    <cosserat name="rod" pos="0 0 0.004" length="0.4" sections="3" strain="kl" radius="0.005" density="1000"
              young="1e6" poisson="0.5" )" +
         rod + R"(>
      <body name="tip" pos="0 0 0"><geom type="sphere" size="0.02" mass="0.05" )" +
         tip + R"(/></body>
    </cosserat>
  </worldbody>)" + extra +
         "</mujoco>";
}

// The load-time test agrees with MuJoCo's own filters on scenes where every pair overlaps: where
// it says nothing can touch, MuJoCo's collision detection finds nothing; where it says something
// can, MuJoCo finds contacts.
TEST(Scene, CollisionDetectionIsSkippedOnlyWhereNothingCanTouch) {
  const std::string off = R"(contype="0" conaffinity="0")";
  struct Row {
    std::string what, xml;
    bool may_collide;
  };
  const std::vector<Row> rows = {
      {"nothing collides", overlap_xml(off, off, off), false},
      {"only the floor has masks (world geoms never collide with each other)", overlap_xml(off, off, off,
          R"(<worldbody><geom type="box" pos="0 0 -0.05" size="0.1 0.1 0.1"/></worldbody>)"), false},
      {"rod on the floor", overlap_xml(R"(contype="1" conaffinity="1")", off, off), true},
      {"ball on the floor, one-sided masks", overlap_xml(off, R"(contype="1" conaffinity="0")", off), true},
      {"rod and ball in their own group, off the floor's",
       overlap_xml(R"(contype="2" conaffinity="2")", R"(contype="2" conaffinity="2")", off), true},
      {"tip and ball, the floor's group 1 not in their affinity",
       overlap_xml(off, R"(contype="2" conaffinity="4")", R"(contype="4" conaffinity="2")"), true},
      {"the only pair excluded", overlap_xml(off, R"(contype="2" conaffinity="2")", R"(contype="2" conaffinity="2")",
          R"(<contact><exclude body1="ball" body2="tip"/></contact>)"), false},
      {"an explicit pair", overlap_xml(off, off, off, R"(<contact><pair geom1="floor" geom2="ball"/></contact>)"), true},
  };
  for (const Row& row : rows) {
    auto s = load_scene_string(row.xml, kPath);
    EXPECT_EQ(s->may_collide, row.may_collide) << row.what;
    SceneData sd(*s);
    forward(*s, sd);
    const int ncon_step = sd.d->ncon;
    mj_collision(s->m, sd.d);  // MuJoCo's own detection on the same poses
    EXPECT_EQ(ncon_step, sd.d->ncon) << row.what;
    if (row.may_collide)
      EXPECT_GT(sd.d->ncon, 0) << row.what << ": the scene overlaps everywhere";
    else
      EXPECT_EQ(sd.d->ncon, 0) << row.what << ": MuJoCo finds a contact the skip would miss";
  }
}
}  // namespace

namespace {

// --- the rods' cdof_dot patch, only where something reads it (RodBinding::cdof_dot_read) ---

// A rod on a swinging hinged arm (so the rod's base accelerates), horizontal under gravity, with a
// body at its tip: `tip` holds that body's content, `sensors` a <sensor> section.
std::string swinging_rod_xml(const std::string& tip, const std::string& sensors = "") {
  return R"(<mujoco>
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="swing" type="hinge" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01" mass="0.2" contype="0" conaffinity="0"/>
      <cosserat name="rod" pos="0.1 0 0" length="0.3" sections="3" strain="kl" radius="0.005" density="1000"
                young="1e6" poisson="0.5" viscosity="0.5" contype="0" conaffinity="0">
        <body name="tip" pos="0 0 0">)" +
         tip + R"(</body>
      </cosserat>
    </body>
  </worldbody>)" + sensors +
         "</mujoco>";
}

// The state after 100 implicit steps, with the rod's cdof_dot patch as detected or forced, and
// with or without the velocity passes' skip (Scene::velocity_skip); without it, MuJoCo's passes
// carry the bodies below the rods too (no RodBinding::payload: every cdof_dot patched).
std::vector<double> swing(const std::string& xml, int force_rod = -1, bool force_to = true, bool no_skip = false) {
  auto s = load_scene_string(xml, kPath);
  if (force_rod >= 0) s->rods[force_rod].cdof_dot_read = force_to;
  if (no_skip) {
    s->velocity_skip.assign(s->m->nbody, 0);
    s->payload_body.assign(s->m->nbody, 0);
    for (const RodBinding& rb : s->rods) {
      if (rb.payload) rb.cdof_dot_read = true;  // (MuJoCo's bias pass accelerates the payload with them)
      rb.payload = false;
    }
  }
  SceneData sd(*s);
  sd.d->qvel[0] = 2.0;
  for (int k = 0; k < 100; ++k) EXPECT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
  std::vector<double> x(sd.d->qpos, sd.d->qpos + s->m->nq);
  x.insert(x.end(), sd.d->qvel, sd.d->qvel + s->m->nv);
  x.insert(x.end(), sd.d->sensordata, sd.d->sensordata + s->m->nsensordata);
  return x;
}

// Where the load says nothing reads the rod's cdof_dot, patching it anyway changes no bit of the
// motion; where it says something does (a body with dofs and mass below the rod, a rod hanging
// from it, an acceleration sensor), leaving it unpatched changes the motion or the sensor: the
// test that says "nothing reads it" too often fails here. The com-velocity and bias passes that
// skip such rods' bodies (Scene::velocity_skip; not with velocity or acceleration sensors) give the
// motion of MuJoCo's full passes: bit for bit, or, where the rod carries a rigid payload's inertia
// (RodBinding::payload: a weight at the tip), to round-off.
TEST(Scene, RodJacobianRatesArePatchedOnlyWhereSomethingReadsThem) {
  struct Row {
    std::string what, xml;
    std::vector<bool> read;  // per rod
    bool velocity_skip;      // some rod's bodies skipped in the com-velocity and bias passes
    bool payload = false;    // the first rod carries its tip body's inertia
  };
  const std::string inner = R"(<cosserat name="inner" pos="0 0 0" length="0.1" sections="2" strain="kl"
      radius="0.003" density="1000" young="1e6" poisson="0.5" contype="0" conaffinity="0"/>)";
  const std::vector<Row> rows = {
      {"a massless marker at the tip", swinging_rod_xml(R"(<site name="mark"/>)"), {false}, true},
      {"a weight at the tip",
       swinging_rod_xml(R"(<geom type="sphere" size="0.01" mass="0.05" contype="0" conaffinity="0"/>)"), {false},
       true, true},
      {"an offset, tilted box at the tip and a ball below it",
       swinging_rod_xml(R"(<geom type="box" pos="0.03 0.01 -0.02" euler="20 30 40" size="0.02 0.01 0.005" mass="0.05"
                                 contype="0" conaffinity="0"/>
                           <body pos="0.05 -0.01 0.01" euler="0 0 30">
                             <geom type="sphere" pos="0.01 0 0" size="0.01" mass="0.02" contype="0" conaffinity="0"/>
                           </body>)"),
       {false}, true, true},
      {"a weight on a hinge at the tip",
       swinging_rod_xml(R"(<joint type="hinge" axis="0 0 1" damping="0.001"/>
                           <geom type="sphere" pos="0.02 0 0" size="0.01" mass="0.05" contype="0" conaffinity="0"/>)"),
       {true}, false},
      {"a weight at the tip, a velocimeter on it",
       swinging_rod_xml(R"(<geom type="sphere" size="0.01" mass="0.05" contype="0" conaffinity="0"/><site name="w"/>)",
                        R"(<sensor><velocimeter site="w"/></sensor>)"),
       {true}, false},
      {"a rod hanging from the tip", swinging_rod_xml(inner), {true, false}, true},
      {"an accelerometer at the massless tip",
       swinging_rod_xml(R"(<site name="mark"/>)", R"(<sensor><accelerometer site="mark"/></sensor>)"), {true}, false},
      {"a velocimeter at the massless tip",
       swinging_rod_xml(R"(<site name="mark"/>)", R"(<sensor><velocimeter site="mark"/></sensor>)"), {false}, false},
  };
  // a rigid last section: the payload hangs on the root of its fixed subtree
  std::string rigid_end = swinging_rod_xml(R"(<geom type="box" pos="0.02 0 0.01" size="0.01 0.01 0.01" mass="0.05"
                                                    contype="0" conaffinity="0"/>)");
  const std::string open = R"(contype="0" conaffinity="0">)";
  rigid_end.replace(rigid_end.find(open), open.size(),
                    open + R"(<section/><section/><section strain="rigid" reststrain="0 0.5 1 1 0 0"/>)");
  std::vector<Row> all = rows;
  all.push_back({"a weight at the tip of a rigid last section", rigid_end, {false}, true, true});
  for (const Row& row : all) {
    auto s = load_scene_string(row.xml, kPath);
    ASSERT_EQ(s->rods.size(), row.read.size()) << row.what;
    const std::vector<double> as_loaded = swing(row.xml);
    // MuJoCo's full com-velocity and bias passes, and every rod's cdof_dot patched: the same motion
    const std::vector<double> full = swing(row.xml, -1, true, true);
    EXPECT_EQ(s->rods[0].payload, row.payload) << row.what;
    if (row.xml == rigid_end)  // (the rigid section's end lies inside a fixed subtree)
      EXPECT_NE(s->rods[0].payload_node, s->rods[0].model.sections.back().end_node);
    if (row.payload) {  // the payload's cvel (MuJoCo's pass skips it) is the one mj_comVel gives
      SceneData sd(*s);
      sd.d->qvel[0] = 2.0;
      for (int k = 0; k < 20; ++k) ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
      forward(*s, sd);
      mjData* ref = mj_copyData(nullptr, s->m, sd.d);
      mj_comVel(s->m, ref);
      for (int b = s->rods[0].below_begin; b < s->rods[0].below_end; ++b)
        for (int e = 0; e < 6; ++e)
          EXPECT_NEAR(sd.d->cvel[6 * b + e], ref->cvel[6 * b + e], 1e-12 * (1 + std::abs(ref->cvel[6 * b + e])))
              << row.what << ", body " << b;
      mj_deleteData(ref);
    }
    if (row.payload) {
      ASSERT_EQ(full.size(), as_loaded.size());
      for (size_t k = 0; k < full.size(); ++k)
        EXPECT_NEAR(full[k], as_loaded[k], 1e-10 * (1 + std::abs(full[k]))) << row.what << ", state entry " << k;
      EXPECT_NE(full, swing(row.xml, -1, true, false)) << "(the payload changes the arithmetic: the test compares two paths)";
    } else {
      EXPECT_EQ(full, as_loaded) << row.what << ": skipping the velocity passes must be exact";
    }
    bool any_skip = false;
    for (char k : s->velocity_skip) any_skip |= k != 0;
    EXPECT_EQ(any_skip, row.velocity_skip) << row.what;
    for (size_t r = 0; r < row.read.size(); ++r) {
      EXPECT_EQ(s->rods[r].cdof_dot_read, row.read[r]) << row.what << ", rod " << r;
      const std::vector<double> flipped = swing(row.xml, static_cast<int>(r), !s->rods[r].cdof_dot_read);
      if (s->rods[r].cdof_dot_read)
        EXPECT_NE(flipped, as_loaded) << row.what << ", rod " << r << ": the patch is read, skipping it must show";
      else
        EXPECT_EQ(flipped, as_loaded) << row.what << ", rod " << r << ": skipping the patch must be exact";
    }
  }
}

}  // namespace

// A payload's mass randomised at run time, the MuJoCo way (m->body_mass and inertia set from C
// between steps), counts as if the model had given it, also where the body was massless at load:
// the velocity passes' skip of massless rods (RodBinding::cdof_dot_read, Scene::velocity_skip) is
// decided again when a body below such a rod gains mass. Outside probe AB: its weight had been left
// out (a static payload at -0.030 m, the rod's own sag, instead of -0.079 m).
TEST(Scene, AMassGivenAtRunTimeCountsAsTheModelsOwn) {
  auto model = [](const char* inertial) {
    return std::string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/>
      <worldbody>
        <cosserat name="rod" pos="0 0 1" length="0.5" sections="4" strain="kl" radius="0.01"
                  density="1000" young="1e8" poisson="0.5" viscosity="1e4" contype="0" conaffinity="0">
          <body name="payload">)") + inertial + R"(<site name="p"/></body>
        </cosserat>
      </worldbody>
    </mujoco>)";
  };
  auto ref = load_scene_string(model(R"(<inertial pos="0 0 0" mass="0.1" diaginertia="1e-6 1e-6 1e-6"/>)"), "ref.xml");
  auto run = load_scene_string(model(""), "massless.xml");
  const int b = mj_name2id(run->m, mjOBJ_BODY, "payload");
  ASSERT_EQ(b, mj_name2id(ref->m, mjOBJ_BODY, "payload"));
  ASSERT_FALSE(run->rods[0].cdof_dot_read);  // skipped at load: nothing massive below the rod
  ASSERT_FALSE(run->rods[0].payload);
  ASSERT_TRUE(ref->rods[0].payload);  // the massive body without dofs: the rod carries its inertia
  SceneData dr(*ref), da(*run);
  for (int i = 0; i < 300; ++i) {
    if (i == 100) {  // the payload's mass given between steps
      run->m->body_mass[b] = 0.1;
      for (int k = 0; k < 3; ++k) run->m->body_inertia[3 * b + k] = 1e-6;
      mju_copy(da.d->qpos, dr.d->qpos, run->m->nq);
      mju_copy(da.d->qvel, dr.d->qvel, run->m->nv);
    }
    ASSERT_EQ(step(*ref, dr), Status::Ok);
    ASSERT_EQ(step(*run, da), Status::Ok);
  }
  const int p = mj_name2id(run->m, mjOBJ_SITE, "p");
  EXPECT_TRUE(run->rods[0].payload);
  // from the same state with the same mass, the same motion (with the load-time skip kept, the
  // payload 4 cm higher after 0.2 s)
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(da.d->site_xpos[3 * p + k], dr.d->site_xpos[3 * p + k], 1e-12);
}

// After a divergence a program gets the command line's advice in its own terms (outside probe AD:
// SceneData::warning said what happened, and only the command line said what to try).
TEST(Scene, ADivergenceHintNamesTheRemedyInTheProgramsTerms) {
  const std::string xml = R"(<mujoco><option timestep="0.002"/><worldbody>
    <cosserat name="rod" length="0.5" sections="4" strain="kl" radius="0.005" young="1e9"/>
  </worldbody></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  SceneData sd(*s);
  Status st = Status::Ok;
  for (int k = 0; k < 500 && st == Status::Ok; ++k) st = step(*s, sd, Integrator::RK4);
  ASSERT_EQ(st, Status::Diverged);
  const std::string cpp = divergence_hint(*s, sd, Integrator::RK4);
  EXPECT_EQ(cpp.rfind("try a smaller time step (m->opt.timestep), or Integrator::Implicit: explicit", 0), 0u) << cpp;
  const std::string cli = divergence_hint(*s, sd, Integrator::RK4, Vocabulary::CommandLine);
  EXPECT_EQ(cli.rfind("try a smaller --timestep, or --integrator implicit: explicit", 0), 0u) << cli;
  // (rk4 crushed a section on its way: the step's advice leads, the collapse follows)
  EXPECT_NE(cpp.find("; a rod section also collapsed on the way"), std::string::npos) << cpp;
  // the linearised trapezoidal rule's remedy is its Newton corrections (a run without a collapse)
  SceneData fresh(*s);
  s->newton_iterations = 0;
  const std::string lin = divergence_hint(*s, fresh, Integrator::Trapezoidal);
  EXPECT_EQ(lin.rfind("try Scene::newton_iterations = 10 (gravity", 0), 0u) << lin;
  // backward Euler's, with the matrix refreshed (energy cannot grow by it there)
  const std::string be = divergence_hint(*s, fresh, Integrator::Implicit, Vocabulary::CommandLine);
  EXPECT_EQ(be.rfind("try --newton 10 --newton-refresh (gravity", 0), 0u) << be;
  s->newton_iterations = 10;
  const std::string full = divergence_hint(*s, fresh, Integrator::Trapezoidal);
  EXPECT_EQ(full.rfind("try a smaller time step (m->opt.timestep), or more Newton corrections", 0), 0u) << full;
}

// Full contact buffers lead the advice unless they first filled in the last steps before the
// divergence, as a blowing-up state makes contacts everywhere (outside probe CB: a pile of rods
// gained energy for 0.35 s with its buffers a quarter full, filled them two steps before the
// state went non-finite, and was told first to raise nconmax). The record is the step's
// (SceneData::buffers_full_at, run_start); here set by hand on a diverged run.
TEST(Scene, FullContactBuffersLeadTheAdviceOnlyWhenTheyCameFirst) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.002"/><worldbody>
    <cosserat name="rod" length="0.5" sections="4" strain="kl" radius="0.005" young="1e9"/>
  </worldbody></mujoco>)",
                             kPath);
  SceneData sd(*s);
  Status st = Status::Ok;
  for (int k = 0; k < 500 && st == Status::Ok; ++k) st = step(*s, sd, Integrator::RK4);
  ASSERT_EQ(st, Status::Diverged);
  EXPECT_EQ(sd.run_start, 0.0);
  EXPECT_TRUE(std::isnan(sd.buffers_full_at));  // (no contacts here)
  const double t = sd.d->time;
  sd.run_start = t - 1.0;  // a run of a second
  sd.d->warning[mjWARN_CONTACTFULL].number = 3;
  sd.buffers_full_at = t - 2 * s->m->opt.timestep;  // two steps before: a consequence
  const std::string late = divergence_hint(*s, sd, Integrator::RK4, Vocabulary::CommandLine);
  EXPECT_EQ(late.rfind("try a smaller --timestep", 0), 0u) << late;
  EXPECT_NE(late.find("; MuJoCo's contact buffers also filled (3 times), first 2 steps before the divergence, likely as "
                      "the state blew up; if contacts were dropped before that, raise <size nconmax"),
            std::string::npos)
      << late;
  sd.buffers_full_at = t - 0.5;  // long before: contacts were dropped, bodies passed through
  const std::string early = divergence_hint(*s, sd, Integrator::RK4, Vocabulary::CommandLine);
  EXPECT_EQ(early.rfind("MuJoCo's contact buffers were full 3 times and contacts were dropped: raise <size", 0), 0u) << early;
  // filled inside the diverging step (not yet recorded), in a run's first steps: a consequence too
  // (outside probe CE: a gripper under rk4 blew up in its first step and was told to raise nconmax)
  sd.buffers_full_at = std::numeric_limits<double>::quiet_NaN();
  sd.run_start = t - s->m->opt.timestep;
  const std::string inside = divergence_hint(*s, sd, Integrator::RK4, Vocabulary::CommandLine);
  EXPECT_EQ(inside.rfind("try a smaller --timestep", 0), 0u) << inside;
  EXPECT_NE(inside.find("first 0 steps before the divergence"), std::string::npos) << inside;
  sd.d->warning[mjWARN_CONTACTFULL].number = 0;
}

// Misuse of the API is refused, not undefined (outside probe BE): a SceneData stepped with another
// Scene (it wrote past a heap buffer), a rod index out of range (rod_index's -1 for a misspelt name
// crashed rod_frame); and a diverged step restores the constraint solver's warm start with the
// state (it was left at the diverged step's 1e17-1e75).
TEST(Scene, MisuseIsRefusedAndADivergedStepRestoresTheWarmStart) {
  const std::string rod = R"(<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
      <cosserat name="r" pos="0 0 0.003" length="0.3" sections="3" radius="0.004"/></worldbody></mujoco>)";
  auto a = load_scene_string(rod, kPath);
  auto b = load_scene_string(rod, kPath);
  SceneData da(*a);
  EXPECT_THROW(step(*b, da), std::invalid_argument);
  EXPECT_THROW(forward(*b, da), std::invalid_argument);
  forward(*a, da);
  EXPECT_THROW(rod_frame(*a, da, -1, 0.0), std::out_of_range);
  EXPECT_THROW(rod_frame(*a, da, 1, 0.0), std::out_of_range);
  EXPECT_THROW(rod_strain(*a, da, 1, 0.0), std::out_of_range);
  EXPECT_NO_THROW(rod_frame(*a, da, 0, 0.3));

  for (int k = 0; k < 20; ++k) ASSERT_EQ(step(*a, da), Status::Ok);  // resting on the floor: a warm start
  const std::vector<mjtNum> warm(da.d->qacc_warmstart, da.d->qacc_warmstart + a->m->nv);
  const std::vector<mjtNum> q(da.d->qpos, da.d->qpos + a->m->nq);
  ASSERT_GT(Eigen::Map<const Eigen::VectorXd>(warm.data(), a->m->nv).norm(), 0.0);
  da.d->qfrc_applied[0] = std::numeric_limits<double>::infinity();
  ASSERT_EQ(step(*a, da), Status::Diverged);
  for (int i = 0; i < a->m->nv; ++i) EXPECT_EQ(da.d->qacc_warmstart[i], warm[i]) << i;
  for (int i = 0; i < a->m->nq; ++i) EXPECT_EQ(da.d->qpos[i], q[i]) << i;
}

// An exception the control callback throws leaves step() under every integrator, with the step's
// start state (outside probe BE: the Newton schemes took it for a failed correction, split the
// step and returned Ok; rk4 and rosenbrock left the time and velocities at the failed stage).
int throw_at_call = 0;
TEST(Scene, AnExceptionOfTheControlCallbackLeavesTheStepWithItsStartState) {
  const std::string xml = R"(<mujoco><option timestep="0.001"/><worldbody><body name="hub" pos="0 0 0.5">
      <joint name="h" type="hinge" axis="0 1 0"/><inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
      <cosserat name="r" length="0.3" sections="3" radius="0.005"/></body></worldbody>
      <actuator><motor joint="h"/></actuator></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  for (const Integrator it : {Integrator::Euler, Integrator::Implicit, Integrator::Trapezoidal, Integrator::GeneralizedAlpha,
                              Integrator::Midpoint, Integrator::RK4, Integrator::Rosenbrock}) {
    SceneData sd(*s);
    mjcb_control = [](const mjModel*, mjData* d) {
      d->ctrl[0] = 0.01;
      if (++control_calls == throw_at_call) throw std::runtime_error("controller failed");
    };
    control_calls = 0;
    throw_at_call = 1 << 30;
    for (int k = 0; k < 5; ++k) ASSERT_EQ(step(*s, sd, it), Status::Ok) << integrator_name(it);
    const std::vector<mjtNum> q(sd.d->qpos, sd.d->qpos + s->m->nq), v(sd.d->qvel, sd.d->qvel + s->m->nv);
    const double t = sd.d->time;
    // the step's second evaluation (a stage, an iterate; euler and the linearised implicit step
    // make one)
    throw_at_call = control_calls + (it == Integrator::Euler || it == Integrator::Implicit ? 1 : 2);
    EXPECT_THROW(step(*s, sd, it), std::runtime_error) << integrator_name(it);
    mjcb_control = nullptr;
    EXPECT_EQ(sd.d->time, t) << integrator_name(it);
    for (int i = 0; i < s->m->nq; ++i) EXPECT_EQ(sd.d->qpos[i], q[i]) << integrator_name(it) << " " << i;
    for (int i = 0; i < s->m->nv; ++i) EXPECT_EQ(sd.d->qvel[i], v[i]) << integrator_name(it) << " " << i;
  }
}
