// The Implicit integrator treats the velocity dependence of actuators on hinge and slide joints
// implicitly (scene.cpp, implicit_step): a velocity servo on a light body is a stiff damper.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const char* kPath = "/tmp/cosserat_actuator_implicit_test.xml";

// A light wheel on a hinge (no gravity, no contacts) driven by a velocity servo of gain kv, and a
// rod standing apart (at rest: without gravity nothing moves it) that makes the step ours: on a
// scene without rods, Implicit is MuJoCo's own integrator.
std::string wheel_xml(double kv, const char* extra = "") {
  char buf[1024];
  std::snprintf(buf, sizeof buf, R"(<mujoco>
  <option timestep="0.01" gravity="0 0 0"/>
  <worldbody>
    <body name="wheel">
      <joint name="spin" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.01 0.002" mass="0.001" contype="0" conaffinity="0"/>
    </body>
    <cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/>
  </worldbody>
  <actuator>
    <velocity name="servo" joint="spin" kv="%g" gear="2" %s/>
  </actuator>
</mujoco>)", kv, extra);
  return buf;
}

// I w' = -g^2 kv w + g kv u: backward Euler gives w+ = (w + (h g kv / I) u) / (1 + h g^2 kv / I).
TEST(ActuatorImplicit, VelocityServoIsBackwardEuler) {
  const double kv = 0.01, g = 2.0, u = 3.0;
  auto s = load_scene_string(wheel_xml(kv), kPath);
  SceneData sd(*s);
  sd.d->ctrl[0] = u;
  forward(*s, sd);
  const double I = sd.d->qM[0], h = s->m->opt.timestep;
  ASSERT_GT(h * g * g * kv / I, 10.0);  // explicit damping would be unstable (needs < 2)
  double w = 0.0;
  for (int k = 0; k < 50; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
    w = (w + h * g * kv / I * u) / (1.0 + h * g * g * kv / I);
    EXPECT_NEAR(sd.d->qvel[0], w, 1e-12 * std::abs(u / g)) << "step " << k;
  }
  EXPECT_NEAR(sd.d->qvel[0], u / g, 1e-9);  // the servo's target speed
}

// Euler keeps MuJoCo's semantics (actuators explicit): the same servo diverges there.
TEST(ActuatorImplicit, EulerKeepsActuatorsExplicit) {
  auto s = load_scene_string(wheel_xml(0.01), kPath);
  SceneData sd(*s);
  sd.d->ctrl[0] = 3.0;
  Status st = Status::Ok;
  for (int k = 0; k < 200 && st == Status::Ok; ++k) st = step(*s, sd, Integrator::Euler);
  EXPECT_TRUE(st == Status::Diverged || std::abs(sd.d->qvel[0]) > 1e6);
}

// A saturated servo (force at its limit) does not damp: the wheel accelerates at forcerange / I.
TEST(ActuatorImplicit, SaturatedServoIsNotDamped) {
  auto s = load_scene_string(wheel_xml(0.01, R"(forcelimited="true" forcerange="-1e-6 1e-6")"), kPath);
  SceneData sd(*s);
  sd.d->ctrl[0] = 3.0;
  forward(*s, sd);
  const double I = sd.d->qM[0], h = s->m->opt.timestep;
  ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
  EXPECT_NEAR(sd.d->qvel[0], h * 2.0 * 1e-6 / I, 1e-12);
}

}  // namespace

// A step that diverges leaves the whole state it started from: positions, velocities, time and the
// actuators' activations (a filtered servo, whose activation the diverging step changed too).
TEST(ActuatorImplicit, DivergedStepRestoresTheStartStateWithActivations) {
  // the velocity servo of wheel_xml as a <general> actuator with a first-order filter on the control
  std::string xml = wheel_xml(0.01);
  const size_t a = xml.find("<velocity"), b = xml.find("/>", a);
  xml.replace(a, b + 2 - a,
              R"(<general name="servo" joint="spin" gear="2" dyntype="filter" dynprm="0.05" gainprm="0.01"
                         biastype="affine" biasprm="0 0 -0.01"/>)");
  auto s = load_scene_string(xml, kPath);
  ASSERT_EQ(s->m->na, 1);
  SceneData sd(*s);
  sd.d->ctrl[0] = 3.0;
  std::vector<double> q, v, act;
  double t = 0.0;
  Status st = Status::Ok;
  int k = 0;
  for (; k < 2000 && st == Status::Ok; ++k) {
    q.assign(sd.d->qpos, sd.d->qpos + s->m->nq);
    v.assign(sd.d->qvel, sd.d->qvel + s->m->nv);
    act.assign(sd.d->act, sd.d->act + s->m->na);
    t = sd.d->time;
    st = step(*s, sd, Integrator::Euler);
  }
  ASSERT_EQ(st, Status::Diverged) << "the explicit servo should diverge (step " << k << ")";
  ASSERT_GT(k, 1);
  EXPECT_EQ(sd.d->time, t);
  EXPECT_EQ(std::vector<double>(sd.d->qpos, sd.d->qpos + s->m->nq), q);
  EXPECT_EQ(std::vector<double>(sd.d->qvel, sd.d->qvel + s->m->nv), v);
  EXPECT_EQ(std::vector<double>(sd.d->act, sd.d->act + s->m->na), act);
}

namespace {

// Tendon damping and the velocity gains of actuators on tendons are implicit too (A += h J' d J),
// as MuJoCo's implicit integrator takes them on a scene without rods. Outside probe T: with a rod
// in the scene they were explicit, and a slide damped through a fixed tendon (h d / m = 10)
// diverged at 0.02 s. Backward Euler on v' = -(d/m) v gives v_n = v0 r^n, r = 1/(1 + h d/m), and
// q_n = h v0 (r + ... + r^n) exactly. The same where the two dofs of a tendon lie on different
// branches of the tree (qM's pattern cannot couple them): that tendon stays explicit and the step
// diverges, as the documentation says.
std::string tendon_xml(const char* tendon_attr, const char* actuator, bool branches = false) {
  return std::string(R"(<mujoco><option timestep="0.002" gravity="0 0 0"/><worldbody>
    <body name="b"><joint name="s" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.05" mass="1" contype="0" conaffinity="0"/></body>)") +
         (branches ? R"(<body name="c" pos="0 1 0"><joint name="s2" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.05" mass="1" contype="0" conaffinity="0"/></body>)"
                   : "") +
         R"(<cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody>
    <tendon><fixed name="t" )" + tendon_attr + R"(><joint joint="s" coef="2"/>)" +
         (branches ? R"(<joint joint="s2" coef="1"/>)" : "") + R"(</fixed></tendon>)" + actuator + "</mujoco>";
}

using Vec2 = Eigen::Vector2d;

// The scene of tendon_xml with its tendon across two branches, started at q = (0.01, 0), v =
// (1, 0), stepped 40 times by Implicit at h and compared with `recurrence` to 1e-12.
template <class Recurrence>
void cross_branch_recurrence(const char* tendon_attr, double h, Recurrence recurrence, const char* actuator = "") {
  SCOPED_TRACE(std::string("across two branches: ") + tendon_attr + actuator);
  auto s = load_scene_string(tendon_xml(tendon_attr, actuator, true), kPath);
  s->m->opt.timestep = h;
  SceneData sd(*s);
  Vec2 q(0.01, 0.0), v(1.0, 0.0);
  sd.d->qpos[0] = q(0);
  sd.d->qvel[0] = v(0);
  for (int n = 0; n < 40; ++n) {
    ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << "step " << n;
    recurrence(q, v, h);
    for (int i = 0; i < 2; ++i) {
      ASSERT_NEAR(sd.d->qpos[i], q(i), 1e-12) << "step " << n << ", dof " << i;
      ASSERT_NEAR(sd.d->qvel[i], v(i), 1e-12) << "step " << n << ", dof " << i;
    }
  }
}

TEST(ActuatorImplicit, TendonDampingAndTendonVelocityServosAreBackwardEuler) {
  // d = 5000 N s/m on the slide: tendon damping 1250 with coef 2, or a velocity servo kv = 1250
  for (const bool servo : {false, true}) {
    SCOPED_TRACE(servo ? "velocity servo on the tendon" : "tendon damping");
    auto s = load_scene_string(
        tendon_xml(servo ? "" : R"(damping="1250")", servo ? R"(<actuator><velocity tendon="t" kv="1250"/></actuator>)" : ""),
        kPath);
    SceneData sd(*s);
    sd.d->qvel[0] = 1.0;
    const double h = 0.002, r = 1.0 / (1.0 + h * 5000.0);
    double q = 0.0, rn = 1.0;
    for (int k = 0; k < 50; ++k) {
      ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << "step " << k;
      rn *= r;
      q += h * rn;
    }
    EXPECT_NEAR(sd.d->qpos[0], q, 1e-12);
    EXPECT_NEAR(sd.d->qvel[0], rn, 1e-12);
  }
  // a tendon across two branches (J = (2, 1) on two unit masses on separate slides), which qM's
  // pattern cannot hold, is implicit too, by the low-rank correction (outside probe V: it stayed
  // explicit, and h d / m = 10 diverged): backward Euler's v+ = v - h d u (u.v) / (1 + h d |u|^2)
  cross_branch_recurrence(R"(damping="1250")", 0.002, [](Vec2& q, Vec2& v, double h) {
    const Vec2 u(2.0, 1.0);
    const double d = 1250.0;
    v -= h * d * u * u.dot(v) / (1.0 + h * d * u.squaredNorm());
    q += h * v;
  });
}

// Tendon springs and position servos on tendons are in K too (twenty-fourth session; they had
// stayed explicit). On the slide of tendon_xml (m = 1, coef 2) a tendon stiffness of 2500, or a
// position servo kp = 2500 on the tendon, is k = 1e4 N/m: at h = 50 ms (h w = 5) the explicit
// spring diverges; the linearised backward Euler step (A = m + h^2 k, A a = -k q - h k v,
// v+ = v + h a, q+ = q + h v+) is followed exactly, across two branches too.
TEST(ActuatorImplicit, TendonSpringsAndTendonPositionServosAreBackwardEuler) {
  for (const bool servo : {false, true}) {
    SCOPED_TRACE(servo ? "position servo on the tendon" : "tendon spring");
    auto s = load_scene_string(
        tendon_xml(servo ? "" : R"(stiffness="2500")", servo ? R"(<actuator><position tendon="t" kp="2500"/></actuator>)" : ""),
        kPath);
    const double h = 0.05, k = 1e4;
    s->m->opt.timestep = h;
    SceneData sd(*s);
    sd.d->qpos[0] = 0.01;
    double q = 0.01, v = 0.0;
    for (int n = 0; n < 40; ++n) {
      ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << "step " << n;
      v += h * -(k * q + h * k * v) / (1.0 + h * h * k);
      q += h * v;
      ASSERT_NEAR(sd.d->qpos[0], q, 1e-12) << "step " << n;
      ASSERT_NEAR(sd.d->qvel[0], v, 1e-12) << "step " << n;
    }
    EXPECT_LT(std::abs(q), 1e-3);  // backward Euler damps it
  }
  // a spring and a damper on one tendon across two branches, and a servo with both gains on it:
  // one row of the correction each, their coefficients summed (outside probe W: added as two rows,
  // they overflowed its buffer, sized one per tendon and actuator, and the tool crashed);
  // A = I + (h d + h^2 k) u u'
  for (const bool servo : {false, true})
    cross_branch_recurrence(
        servo ? "" : R"(stiffness="2500" damping="1250")", 0.01,
        [](Vec2& q, Vec2& v, double h) {
          const Vec2 u(2.0, 1.0);
          const double k = 2500.0, d = 1250.0;
          v -= h * u * (k * u.dot(q) + (d + h * k) * u.dot(v)) / (1.0 + (h * d + h * h * k) * u.squaredNorm());
          q += h * v;
        },
        servo ? R"(<actuator><general tendon="t" biastype="affine" gainprm="2500" biasprm="0 -2500 -1250"/></actuator>)" : "");
  // across two branches (J = (2, 1) on two unit masses): A = I + h^2 k u u', A a = -k u u.(q + h v)
  cross_branch_recurrence(R"(stiffness="2500")", 0.05, [](Vec2& q, Vec2& v, double h) {
    const Vec2 u(2.0, 1.0);
    const double k = 2500.0;
    v -= h * k * u * u.dot(q + h * v) / (1.0 + h * h * k * u.squaredNorm());
    q += h * v;
  });
}
}  // namespace

namespace {

// Negative springs and positive feedback stay explicit: in the step's matrix they would make it
// indefinite (outside probe T: a joint stiffness of -1e4 on 1 kg, or an affine bias of +1e4 per
// m, made the implicit steps end "non-finite" at step 0 at 20 ms, where euler runs). Explicit,
// the implicit step is the semi-implicit Euler recurrence v+ = v + h k q / m, q+ = q + h v+.
TEST(ActuatorImplicit, NegativeSpringsAndPositiveFeedbackStayExplicit) {
  for (const char* spring : {R"(stiffness="-10000")", ""}) {
    const std::string xml = std::string(R"(<mujoco><option timestep="0.02" gravity="0 0 0"/><worldbody>
      <body name="b"><joint name="s" type="slide" axis="1 0 0" )") + spring +
                            R"(/><geom type="sphere" size="0.05" mass="1" contype="0" conaffinity="0"/></body>
      <cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody>)" +
                            (*spring ? "" : R"(<actuator><general joint="s" biastype="affine" biasprm="0 10000 -5"/></actuator>)") +
                            "</mujoco>";
    SCOPED_TRACE(*spring ? "negative joint stiffness" : "positive position feedback, negative velocity feedback");
    auto s = load_scene_string(xml, kPath);
    SceneData sd(*s);
    sd.d->qpos[0] = 0.01;
    double q = 0.01, v = 0.0;
    const double h = 0.02, c = *spring ? 0.0 : 5.0;  // the servo's damping (kv = 5) is implicit
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << "step " << k;
      v = (v + h * 1e4 * q) / (1.0 + h * c);
      q += h * v;
    }
    EXPECT_NEAR(sd.d->qpos[0], q, 1e-12 * std::abs(q));
    EXPECT_NEAR(sd.d->qvel[0], v, 1e-12 * std::abs(v));
  }
}

}  // namespace

namespace {

// Steps `xml` (one actuator with a filter's dynamics, act' = (ctrl - act) / tau, however given)
// by `it` at h over T from act 0.1 towards ctrl 0.5, and expects the scheme's exact recurrence
// act_n - ctrl = (act_0 - ctrl) r^n to 1e-12, r = 1 / (1 + h / tau) for backward Euler and
// (1 - h / 2 tau) / (1 + h / 2 tau) for the trapezoidal rule. Returns the final activation.
double expect_filter_recurrence(const char* xml, Integrator it, double h, double tau, double T) {
  auto s = load_scene_string(xml, kPath);
  EXPECT_EQ(s->m->na, 1);
  s->m->opt.timestep = h;
  s->rho_inf = 0.0;  // genalpha's most damping variant (whose cq1 is backward Euler's)
  SceneData sd(*s);
  sd.d->act[0] = 0.1;
  sd.d->ctrl[0] = 0.5;
  const int n = static_cast<int>(std::lround(T / h));
  for (int k = 0; k < n; ++k) EXPECT_EQ(step(*s, sd, it), Status::Ok) << k;
  const double x = h / tau;
  const double r = it == Integrator::Implicit ? 1.0 / (1.0 + x) : (1.0 - x / 2) / (1.0 + x / 2);
  EXPECT_NEAR(sd.d->act[0], 0.5 - 0.4 * std::pow(r, n), 1e-12);
  return sd.d->act[0];
}

// Filter activations (act' = (ctrl - act) / tau) follow the scheme: backward Euler under implicit,
// the trapezoidal rule under trapezoidal, genalpha and midpoint (outside probe T: all advanced them
// by Euler's rule, so the second-order schemes were first order on any scene with a filter). Exact
// recurrences act_n - ctrl = (act_0 - ctrl) r^n, r = 1 / (1 + h / tau) and (1 - h / 2 tau) / (1 +
// h / 2 tau); the trapezoidal rule's error against exp(-t / tau) falls fourfold per halved step.
TEST(ActuatorImplicit, FilterActivationsFollowTheScheme) {
  const char* xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="b"><joint name="h" type="hinge" axis="0 0 1" damping="0.1"/>
      <geom type="box" size="0.1 0.02 0.02" mass="0.5" contype="0" conaffinity="0"/></body>
    <cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody>
    <actuator><general joint="h" dyntype="filter" dynprm="0.05" gainprm="0.01"/></actuator></mujoco>)";
  const double tau = 0.05, T = 0.3;
  double previous = 0.0;
  for (const double h : {2e-3, 1e-3, 5e-4}) {
    for (const Integrator it : {Integrator::Implicit, Integrator::Trapezoidal, Integrator::GeneralizedAlpha,
                                Integrator::Midpoint}) {
      SCOPED_TRACE(std::string(integrator_name(it)) + " at h = " + std::to_string(h));
      const double act = expect_filter_recurrence(xml, it, h, tau, T);
      if (it == Integrator::Trapezoidal) {
        const double err = std::abs(act - (0.5 - 0.4 * std::exp(-T / tau)));
        if (previous > 0) EXPECT_NEAR(previous / err, 4.0, 0.05);
        previous = err;
      }
    }
  }
}

// Muscle activations too (twenty-fourth session; they had kept Euler's rule): MuJoCo's muscle
// dynamics f(ctrl, act) (time constants depending on act and on the sign of ctrl - act) by
// backward Euler under implicit, act+ = act0 + h f(act+), and by the trapezoidal rule under
// trapezoidal, act+ = act0 + h/2 (f(act0) + f(act+)), each step's equation met to 1e-12 (f from
// mju_muscleDynamics, MuJoCo's own); the trapezoidal rule's error against a fine RK4 integration
// of the scalar equation falls fourfold per halved step, through an activation and a release.
TEST(ActuatorImplicit, MuscleActivationsFollowTheScheme) {
  const char* xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="b"><joint name="h" type="hinge" axis="0 0 1" damping="0.1"/>
      <geom type="box" size="0.1 0.02 0.02" mass="0.5" contype="0" conaffinity="0"/></body>
    <cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody>
    <actuator><muscle joint="h" lengthrange="-1 1" timeconst="0.01 0.04" force="0.01"/></actuator></mujoco>)";
  const double T = 0.1;
  auto ctrl_at = [](double t) { return t < 0.05 ? 0.8 : 0.1; };  // activate, then release
  auto f = [](const mjModel* m, double ctrl, double act) { return mju_muscleDynamics(ctrl, act, m->actuator_dynprm); };
  double previous = 0.0;
  for (const double h : {2e-3, 1e-3, 5e-4}) {
    for (const Integrator it : {Integrator::Implicit, Integrator::Trapezoidal}) {
      SCOPED_TRACE(std::string(integrator_name(it)) + " at h = " + std::to_string(h));
      auto s = load_scene_string(xml, kPath);
      ASSERT_EQ(s->m->na, 1);
      s->m->opt.timestep = h;
      SceneData sd(*s);
      sd.d->act[0] = 0.05;
      const int n = static_cast<int>(std::lround(T / h));
      for (int k = 0; k < n; ++k) {
        const double a0 = sd.d->act[0], c = ctrl_at(k * h);
        sd.d->ctrl[0] = c;
        ASSERT_EQ(step(*s, sd, it), Status::Ok);
        const double a1 = sd.d->act[0];
        const double residual = it == Integrator::Implicit ? a1 - a0 - h * f(s->m, c, a1)
                                                           : a1 - a0 - 0.5 * h * (f(s->m, c, a0) + f(s->m, c, a1));
        ASSERT_NEAR(residual, 0.0, 1e-12) << "step " << k;
      }
      if (it == Integrator::Trapezoidal) {
        double a = 0.05;  // the scalar equation by RK4 at h / 100, the control switching on the grid
        const double dt = h / 100;
        for (int k = 0; k < 100 * n; ++k) {
          const double c = ctrl_at((k / 100) * h);
          const double k1 = f(s->m, c, a), k2 = f(s->m, c, a + dt / 2 * k1), k3 = f(s->m, c, a + dt / 2 * k2),
                       k4 = f(s->m, c, a + dt * k3);
          a += dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
        }
        const double err = std::abs(sd.d->act[0] - a);
        if (previous > 0) EXPECT_NEAR(previous / err, 4.0, 0.4) << previous << " " << err;
        std::printf("trapezoidal muscle activation at h = %g: error %.3e\n", h, err);
        previous = err;
      }
    }
  }
}

// User activation dynamics (mjcb_act_dyn) follow the scheme too (twenty-fifth session; they had
// kept Euler's rule, first order under the second-order schemes): a linear callback, act' =
// (ctrl - act) / tau, gives the filter's exact recurrences to 1e-12 under all four schemes, and a
// nonlinear one, act' = ctrl - act^3, meets each step's equation (backward Euler's, the
// trapezoidal rule's) to 1e-12.
double g_user_tau = 0.05;
bool g_user_cubic = false;
mjtNum user_dynamics(const mjModel* m, const mjData* d, int id) {
  const int j = id - (m->nu - m->na);
  return g_user_cubic ? d->ctrl[id] - d->act[j] * d->act[j] * d->act[j] : (d->ctrl[id] - d->act[j]) / g_user_tau;
}

TEST(ActuatorImplicit, UserActivationDynamicsFollowTheScheme) {
  const char* xml = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="b"><joint name="h" type="hinge" axis="0 0 1" damping="0.1"/>
      <geom type="box" size="0.1 0.02 0.02" mass="0.5" contype="0" conaffinity="0"/></body>
    <cosserat name="apart" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody>
    <actuator><general joint="h" dyntype="user" gainprm="0.01"/></actuator></mujoco>)";
  mjcb_act_dyn = user_dynamics;
  const double tau = g_user_tau, h = 1e-3, T = 0.3;
  g_user_cubic = false;
  for (const Integrator it : {Integrator::Implicit, Integrator::Trapezoidal, Integrator::GeneralizedAlpha,
                              Integrator::Midpoint}) {
    SCOPED_TRACE(integrator_name(it));
    expect_filter_recurrence(xml, it, h, tau, T);
  }
  g_user_cubic = true;
  for (const Integrator it : {Integrator::Implicit, Integrator::Trapezoidal}) {
    SCOPED_TRACE(integrator_name(it));
    auto s = load_scene_string(xml, kPath);
    s->m->opt.timestep = 0.05;  // large steps: Euler's update is far from the scheme's
    SceneData sd(*s);
    sd.d->act[0] = 2.0;
    sd.d->ctrl[0] = 1.0;
    auto f = [](double c, double a) { return c - a * a * a; };
    for (int k = 0; k < 100; ++k) {
      const double a0 = sd.d->act[0];
      ASSERT_EQ(step(*s, sd, it), Status::Ok);
      const double a1 = sd.d->act[0], hh = 0.05;
      const double residual = it == Integrator::Implicit ? a1 - a0 - hh * f(1.0, a1)
                                                         : a1 - a0 - 0.5 * hh * (f(1.0, a0) + f(1.0, a1));
      ASSERT_NEAR(residual, 0.0, 1e-12) << "step " << k;
    }
    EXPECT_NEAR(sd.d->act[0], 1.0, 1e-4);  // settled on the root of ctrl - act^3 (rate 3 1/s, 5 s)
  }
  mjcb_act_dyn = nullptr;
}

}  // namespace
