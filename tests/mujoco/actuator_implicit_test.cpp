// The Implicit integrator treats the velocity dependence of actuators on hinge and slide joints
// implicitly (scene.cpp, implicit_step): a velocity servo on a light body is a stiff damper.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const char* kPath = "/tmp/cosserat_actuator_implicit_test.xml";

// A light wheel on a hinge (no gravity, no contacts) driven by a velocity servo of gain kv.
std::string wheel_xml(double kv, const char* extra = "") {
  char buf[1024];
  std::snprintf(buf, sizeof buf, R"(<mujoco>
  <option timestep="0.01" gravity="0 0 0"/>
  <worldbody>
    <body name="wheel">
      <joint name="spin" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.01 0.002" mass="0.001" contype="0" conaffinity="0"/>
    </body>
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
