// The scene's Rosenbrock-W step (scene.cpp, rosenbrock_step; the method ROS34PW2 of
// integrators.hpp): its order against RK4 at a tiny step, on a clamped rod and on a rod riding a
// hinged body with activation dynamics, and its L-stability on a stiff undamped rod at steps where
// the explicit RK4 diverges.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>
#include <vector>

#include "integrators.hpp"
#include "scene.hpp"
#include "support/weighted_cantilever.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const char* kPath = "/tmp/cosserat_rosenbrock_test.xml";

// The Newton tests' cantilever (support/weighted_cantilever.hpp); run() sets the step.
std::string cantilever_xml(double young, double radius, int sections) {
  return cosserat::testing::weighted_cantilever_xml(young, radius, sections, 1e-3);
}

// |R(i y)| for ROS34PW2's stability function (the method on y' = i y, W exact), from its
// transformed tableau: (1/gamma - z) u_i = z (1 + sum_j a_ij u_j) + sum_j C_ij u_j, z = i y.
double stability_function_modulus(double y) {
  namespace R = cosserat::ros34pw2;
  const std::complex<double> z(0.0, y);
  std::complex<double> u[R::kStages], out = 1.0;
  for (int i = 0; i < R::kStages; ++i) {
    std::complex<double> Y = 1.0, r = 0.0;
    for (int j = 0; j < i; ++j) Y += R::a[i][j] * u[j], r += R::C[i][j] * u[j];
    u[i] = (z * Y + r) / (1.0 / R::gamma - z);
    out += R::b[i] * u[i];
  }
  return std::abs(out);
}

// A damped GVS rod on a hinged arm driven by a motor through a first-order filter (an activation):
// every part of the state (qpos, qvel, act) moves.
const char* kCoupled = R"(<mujoco>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01" density="500" contype="0" conaffinity="0"/>
      <cosserat name="rod" pos="0.1 0 0" length="0.3" sections="2" order="1" strain="kl" radius="0.006"
                density="1000" young="2e6" poisson="0.5" viscosity="200"/>
    </body>
  </worldbody>
  <actuator><general name="motor" joint="hinge" dyntype="filter" dynprm="0.05" gear="1"/></actuator>
</mujoco>)";

struct State {
  std::vector<double> x;  // qpos, qvel, act
};

State run(const std::string& xml, Integrator it, double h, double T, double ctrl) {
  auto s = load_scene_string(xml, kPath);
  s->m->opt.timestep = h;
  SceneData sd(*s);
  for (int i = 0; i < s->m->nu; ++i) sd.d->ctrl[i] = ctrl;
  const long n = std::lround(T / h);
  for (long k = 0; k < n; ++k) EXPECT_EQ(step(*s, sd, it), Status::Ok) << "step " << k;
  State st;
  const mjModel* m = s->m;
  st.x.assign(sd.d->qpos, sd.d->qpos + m->nq);
  st.x.insert(st.x.end(), sd.d->qvel, sd.d->qvel + m->nv);
  st.x.insert(st.x.end(), sd.d->act, sd.d->act + m->na);
  return st;
}

double max_abs_diff(const State& a, const State& b) {
  double e = 0.0;
  for (size_t i = 0; i < a.x.size(); ++i) e = std::max(e, std::abs(a.x[i] - b.x[i]));
  return e;
}

// Errors at the steps `hs` against RK4 at 1e-5 s: each halving divides them by 2^3 = 8 for a
// third-order method (6 to 10.5 allowed; a second-order method gives 4, a fourth-order one 16).
void expect_third_order(const std::string& xml, double T, double ctrl, const std::vector<double>& hs) {
  const State ref = run(xml, Integrator::RK4, 1e-5, T, ctrl);
  std::vector<double> e;
  for (double h : hs) e.push_back(max_abs_diff(run(xml, Integrator::Rosenbrock, h, T, ctrl), ref));
  for (size_t k = 0; k < e.size(); ++k)
    std::printf("rosenbrock h = %.2e: error %.3e%s", hs[k], e[k], k + 1 < e.size() ? ", " : "\n");
  for (size_t k = 0; k + 1 < e.size(); ++k) {
    EXPECT_GT(e[k] / e[k + 1], 6.0) << "errors " << e[k] << " -> " << e[k + 1];
    EXPECT_LT(e[k] / e[k + 1], 10.5) << "errors " << e[k] << " -> " << e[k + 1];
  }
}

// Measured ratios 6.39, 7.26, 7.65 from h = 2 ms down (5.63 from 4 ms: not yet asymptotic).
TEST(Rosenbrock, IsThirdOrderOnTheCantilever) {
  expect_third_order(cantilever_xml(1e6, 0.01, 3), 0.2, 0.0, {2e-3, 1e-3, 5e-4, 2.5e-4});
}

// The hinge's motor: a constant control of 0.04 N m through the filter (act rises from 0 to it).
// The rod's Kelvin-Voigt damping makes its fast modes decay at rates up to about E / (3 mu) = 3e3
// 1/s: from h = 1 ms down (h lambda >= -3) the ratios are 7.67, 8.09 (5.48 from 2 ms).
TEST(Rosenbrock, IsThirdOrderOnARodRidingAHingeWithAnActivation) {
  expect_third_order(kCoupled, 0.2, 0.04, {1e-3, 5e-4, 2.5e-4});
}

// A filter's decay is in the method's W (activation_jacobian): a filter faster than the step
// (tau = h / 2.5 and h / 100) settles on its control as the exact act = ctrl (1 - exp(-t / tau))
// does, and the rod it bends follows. Outside probe CF: the activation was explicit, and tau =
// h / 2.5 diverged (at 10 ms) where rk4 holds it.
TEST(Rosenbrock, FiltersFasterThanTheStepSettle) {
  for (const double ratio : {2.5, 100.0}) {
    SCOPED_TRACE(ratio);
    const double h = 1e-3, tau = h / ratio, u = 0.01;
    auto s = load_scene_string(R"(<mujoco><option gravity="0 0 0" timestep="0.001"/><worldbody>
      <cosserat name="r" length="0.3" sections="2" strain="kl" radius="0.01" young="1e7" viscosity="3e5" contype="0" conaffinity="0"/>
      </worldbody><actuator><general joint="r/s0/ky" dyntype="filter" dynprm=")" + std::to_string(tau) + R"("/></actuator></mujoco>)",
                               kPath);
    SceneData sd(*s);
    sd.d->ctrl[0] = u;
    for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(*s, sd, Integrator::Rosenbrock), Status::Ok) << k;
    EXPECT_NEAR(sd.d->act[0], u, 1e-12);
    // the bend the constant torque u holds on the first section, damped to rest: EI k l = u (l = 0.15 m)
    const double EI = 1e7 * M_PI * 1e-8 / 4;
    EXPECT_NEAR(sd.d->qpos[s->m->jnt_qposadr[mj_name2id(s->m, mjOBJ_JOINT, "r/s0/ky")]], u / (EI * 0.15), 1e-3 * u / (EI * 0.15));
  }
}

// L-stability: an undamped stiff rod (E = 1e9 Pa, L/r = 100, 8 sections) released under gravity at
// h = 5 ms, where its stiffest modes have h w >> 1: RK4 diverges, the Rosenbrock step damps those
// modes and runs 2000 steps without gaining energy (the total energy may only fall), and the rod
// keeps swinging (the slow modes are not damped away: it is third order on them).
TEST(Rosenbrock, StiffUndampedRodAtLargeStepsGainsNoEnergy) {
  const std::string xml = cantilever_xml(1e9, 0.005, 8);
  {
    auto s = load_scene_string(xml, kPath);
    s->m->opt.timestep = 5e-3;
    SceneData sd(*s);
    Status st = Status::Ok;
    for (int k = 0; k < 200 && st == Status::Ok; ++k) st = step(*s, sd, Integrator::RK4);
    EXPECT_EQ(st, Status::Diverged) << "RK4 should not be stable at this step";
  }
  auto s = load_scene_string(xml, kPath);
  s->m->opt.timestep = 5e-3;
  SceneData sd(*s);
  forward(*s, sd);
  const double e0 = energy(*s, sd).total();
  // the energy scale: the weight's and the rod's potential energy over the rod's length
  const double scale = 9.81 * 0.5 * (0.05 + 1000 * M_PI * 0.005 * 0.005 * 0.5);
  double highest = -1e300, lowest = 1e300, tip_lowest = 1e300, tip_highest = -1e300;
  const int tip = mj_name2id(s->m, mjOBJ_BODY, "weight");
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::Rosenbrock), Status::Ok) << "step " << k;
    forward(*s, sd);
    const double e = energy(*s, sd).total() - e0;
    highest = std::max(highest, e);
    lowest = std::min(lowest, e);
    if (k > 1000) {
      tip_lowest = std::min(tip_lowest, sd.d->xpos[3 * tip + 2]);
      tip_highest = std::max(tip_highest, sd.d->xpos[3 * tip + 2]);
    }
  }
  std::printf("stiff rod, h = 5 ms, 2000 steps: energy change in [%.3e, %.3e] of %.3e J; tip height range over the "
              "last 5 s %.3e m\n", lowest, highest, scale, tip_highest - tip_lowest);
  EXPECT_LT(highest, 1e-6 * scale);
  EXPECT_GT(lowest, -0.5 * scale);
  EXPECT_GT(tip_highest - tip_lowest, 1e-4);  // still oscillating
}

// MuJoCo's joint springs and position servos on hinge and slide joints are in the method's matrix
// (factor_implicit's K). Outside probe S: a slide joint's spring (w = 100 rad/s, undamped) was
// explicit, and its energy grew by a factor 1 + O((h w)^4) per step at every step (0.5 J to 0.70 J
// over 3 s at 4 ms, to 10 J at 8 ms, 45 kJ at 12 ms). With the spring in W the linear oscillation
// is integrated by the L-stable method itself: the energy may only fall, at every step size; the
// same for a position servo (kp = 1e4, the same frequency), whose energy is counted by hand, and
// (twenty-fourth session) for a tendon's spring and a position servo on a tendon (a fixed tendon
// 2 s: k = 2500 gives the same 1e4 N/m on the slide), which had stayed explicit.
TEST(Rosenbrock, JointAndTendonSpringsAndPositionServosGainNoEnergy) {
  enum Kind { JointSpring, JointServo, TendonSpring, TendonServo };
  auto xml = [](Kind kind) {
    return std::string(R"(<mujoco><option gravity="0 0 0"/><worldbody><body name="b">
      <joint name="s" type="slide" axis="1 0 0" )") + (kind == JointSpring ? R"(stiffness="10000")" : "") +
           R"(/><geom type="sphere" size="0.05" mass="1" contype="0" conaffinity="0"/></body></worldbody>)" +
           (kind >= TendonSpring ? std::string(R"(<tendon><fixed name="t" )") + (kind == TendonSpring ? R"(stiffness="2500")" : "") +
                                       R"(><joint joint="s" coef="2"/></fixed></tendon>)"
                                 : "") +
           (kind == JointServo ? R"(<actuator><position joint="s" kp="10000"/></actuator>)" : "") +
           (kind == TendonServo ? R"(<actuator><position tendon="t" kp="2500"/></actuator>)" : "") + "</mujoco>";
  };
  const char* names[] = {"joint spring", "joint servo", "tendon spring", "tendon servo"};
  for (const Kind kind : {JointSpring, JointServo, TendonSpring, TendonServo})
    for (const double h : {1e-3, 4e-3, 8e-3, 12e-3, 16e-3}) {
      SCOPED_TRACE(std::string(names[kind]) + ", h = " + std::to_string(h));
      auto s = load_scene_string(xml(kind), kPath);
      s->m->opt.timestep = h;
      SceneData sd(*s);
      sd.d->qpos[0] = 0.01;
      auto e = [&] { return 0.5 * sd.d->qvel[0] * sd.d->qvel[0] + 0.5 * 1e4 * sd.d->qpos[0] * sd.d->qpos[0]; };
      const double e0 = e();
      double highest = 0.0;
      const int n = static_cast<int>(std::lround(3.0 / h));
      for (int k = 0; k < n; ++k) {
        ASSERT_EQ(step(*s, sd, Integrator::Rosenbrock), Status::Ok);
        highest = std::max(highest, e() - e0);
      }
      EXPECT_LE(highest, 1e-12 * e0);
      // the linear oscillator's exact answer: the energy scales by |R(i h w)|^2 per step, R the
      // method's stability function (from the tableau alone)
      const double R = stability_function_modulus(h * 100.0);
      EXPECT_LT(R, 1.0);
      EXPECT_NEAR(e(), e0 * std::pow(R, 2 * n), 1e-9 * e0);
    }
}

// A model selects it with <custom><text name="cosserat:integrator" data="rosenbrock"/>.
TEST(Rosenbrock, ModelChoosesIt) {
  auto s = load_scene_string(R"(<mujoco><custom><text name="cosserat:integrator" data="rosenbrock"/></custom>
    <worldbody><cosserat name="rod" length="0.3" radius="0.01"/></worldbody></mujoco>)",
                             kPath);
  EXPECT_EQ(s->integrator, Integrator::Rosenbrock);
  EXPECT_EQ(s->newton_for(Integrator::Rosenbrock), 0);
  EXPECT_FALSE(takes_substeps(Integrator::Rosenbrock));
}

}  // namespace

namespace {

// The springs of ball and free joints are in the matrix too (k I on their dofs; twenty-fourth
// session: they had stayed explicit). A sphere of isotropic inertia 1 on a ball joint turned about
// a fixed axis, and a free body displaced along x, are linear oscillators of w = 100 rad/s
// (k = 1e4): under rosenbrock their energy falls by the stability function, as a slide's, and
// under implicit they follow backward Euler's recurrence (at h w = 5, where explicit springs
// diverge).
TEST(Rosenbrock, BallAndFreeJointSpringsAreInTheMatrix) {
  for (const bool ball : {true, false}) {
    const std::string xml = std::string(R"(<mujoco><option gravity="0 0 0"/><worldbody><body name="b" pos="0 0 1">
      <joint name="j" type=")") + (ball ? "ball" : "free") + R"(" stiffness="10000"/>
      <geom type="sphere" size="0.05" contype="0" conaffinity="0"/>
      <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>
      <cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody></mujoco>)";
    // the displacement x and its rate v: the turn about x (ball), or the shift along x (free)
    auto state = [&](const mjData* d, double& x, double& v) {
      if (ball) {
        x = 2.0 * std::atan2(d->qpos[1], d->qpos[0]);
        v = d->qvel[0];
      } else {
        x = d->qpos[0];
        v = d->qvel[0];
      }
    };
    auto start = [&](mjData* d) {
      if (ball) {
        d->qpos[0] = std::cos(0.005);
        d->qpos[1] = std::sin(0.005);  // 0.01 rad about x
      } else {
        d->qpos[0] = 0.01;
      }
    };
    for (const double h : {1e-3, 4e-3, 16e-3}) {
      SCOPED_TRACE(std::string(ball ? "ball" : "free") + ", rosenbrock, h = " + std::to_string(h));
      auto s = load_scene_string(xml, kPath);
      s->m->opt.timestep = h;
      SceneData sd(*s);
      start(sd.d);
      double x, v;
      state(sd.d, x, v);
      const double e0 = 0.5 * v * v + 0.5 * 1e4 * x * x;
      const int n = static_cast<int>(std::lround(1.0 / h));
      for (int k = 0; k < n; ++k) ASSERT_EQ(step(*s, sd, Integrator::Rosenbrock), Status::Ok);
      state(sd.d, x, v);
      const double R = stability_function_modulus(h * 100.0);
      EXPECT_NEAR(0.5 * v * v + 0.5 * 1e4 * x * x, e0 * std::pow(R, 2 * n), 1e-9 * e0);
    }
    SCOPED_TRACE(std::string(ball ? "ball" : "free") + ", implicit, h = 50 ms");
    auto s = load_scene_string(xml, kPath);
    const double h = 0.05, k = 1e4;
    s->m->opt.timestep = h;
    SceneData sd(*s);
    start(sd.d);
    double x = 0.01, v = 0.0, xs, vs;
    for (int n = 0; n < 40; ++n) {
      ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << "step " << n;
      v += h * -(k * x + h * k * v) / (1.0 + h * h * k);
      x += h * v;
      state(sd.d, xs, vs);
      ASSERT_NEAR(xs, x, 1e-12) << "step " << n;
      ASSERT_NEAR(vs, v, 1e-12) << "step " << n;
    }
  }
}

}  // namespace
