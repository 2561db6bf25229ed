// The coupled step must not touch the heap once SceneData is constructed (MuJoCo's own step
// works in its arena; the rod patches use memory sized at construction or scratch kept between
// steps). Every shipped model, every integrator, from its first keyframe (controls included).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "scene.hpp"

#include "support/alloc_probe.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const std::string kModels = std::string(COSSERAT_SOURCE_DIR) + "/models/";

std::vector<std::string> shipped_models() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(kModels))
    if (e.path().extension() == ".xml") out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

// The probe counts (otherwise zero below would prove nothing).
TEST(SceneStepAlloc, ProbeCountsAllocations) {
  alloc_probe::arm();
  std::vector<double>* v = new std::vector<double>(100);
  alloc_probe::disarm();
  delete v;
  EXPECT_GE(alloc_probe::g_new_calls, 2);
}

TEST(SceneStepAlloc, NoHeapAllocationInStep) {
  const std::vector<std::string> models = shipped_models();
  ASSERT_GE(models.size(), 5u);
  for (const std::string& name : models) {
    auto s = load_scene(kModels + name);
    const double h = s->m->opt.timestep;
    for (Integrator it : {Integrator::Euler, Integrator::Implicit, Integrator::RK4, Integrator::Trapezoidal,
                          Integrator::GeneralizedAlpha, Integrator::Midpoint, Integrator::Rosenbrock})
    for (double tol : {0.0, 1e-2}) {  // fixed steps, and adaptive substeps (Scene::step_tol)
      if (tol > 0 && !takes_substeps(it)) continue;
      SCOPED_TRACE(name + " integrator " + std::to_string(static_cast<int>(it)) + " step_tol " + std::to_string(tol));
      s->step_tol = 0.0;
      SceneData sd(*s);
      if (s->m->nkey > 0) mj_resetDataKeyframe(s->m, sd.d, 0);
      // 0.3 s with the implicit integrator at the model's step: rods bend, contacts appear
      s->m->opt.timestep = h;
      for (int k = 0; k < static_cast<int>(0.3 / h); ++k) ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
      // the explicit integrators need small steps on the stiff rods (bench/README.md, stress)
      const bool a_stable = it == Integrator::Implicit || it == Integrator::Trapezoidal ||
                            it == Integrator::GeneralizedAlpha || it == Integrator::Midpoint ||
                            it == Integrator::Rosenbrock;
      s->m->opt.timestep = a_stable ? h : std::min(h, 1e-5);
      s->step_tol = tol;
      for (int k = 0; k < 5; ++k) ASSERT_EQ(step(*s, sd, it), Status::Ok);  // scratch reaches its size
      const int ncon = sd.d->ncon;
      alloc_probe::arm();
      Status st = Status::Ok;
      for (int k = 0; k < 20 && st == Status::Ok; ++k) st = step(*s, sd, it);
      alloc_probe::disarm();
      EXPECT_EQ(st, Status::Ok);
      if (name == "octopus_arm.xml") EXPECT_GT(ncon, 0) << "the arm should touch the table";
      EXPECT_EQ(alloc_probe::g_malloc_calls, 0) << "heap allocations in 20 steps";
      EXPECT_EQ(alloc_probe::g_new_calls, 0) << "operator new calls in 20 steps";
      if (alloc_probe::g_malloc_calls > 0 || alloc_probe::g_new_calls > 0) alloc_probe::print_first_allocation();
    }
  }
}

// The same with what reads rod sites through MuJoCo: nested rods (GVS, PCS, rigid), a tendon with a
// pulley, site and slider-crank actuators on rod sites, and every sensor kind that the step
// evaluates again on rod sites (velocities, accelerations, forces, subtrees).
TEST(SceneStepAlloc, NoHeapAllocationWithSensorsAndActuatorsOnRodSites) {
  const char* xml = R"(<mujoco><option gravity="0 0 -9.81" timestep="0.001"/><worldbody>
  <body name="hub" pos="0 0 1"><freejoint/><geom type="sphere" size="0.02" mass="0.1" contype="0" conaffinity="0"/>
    <site name="hs"/>
    <cosserat name="outer" length="0.3" sections="3" strain="ikl" order="2" radius="0.01" young="1e6" viscosity="1e3">
      <site name="o1" at="0.05" pos="0 0.004 0"/><site name="o2" at="0.1"/>
      <body name="joint_mass"><geom type="sphere" size="0.008" mass="0.02" contype="0" conaffinity="0"/>
        <cosserat name="inner" length="0.1" sections="2" strain="kl" radius="0.004" young="1e6">
          <site name="i1" at="0.03" pos="0.001 0 0.002"/><site name="i2" at="0.1"/>
        </cosserat>
      </body>
    </cosserat>
    <cosserat name="rigidrod" euler="0 0 90" length="0.2" sections="2" strain="rigid" radius="0.01" contype="0" conaffinity="0">
      <site name="r1" at="0.07"/>
    </cosserat>
  </body></worldbody>
  <tendon><spatial name="t"><site site="hs"/><site site="o1"/><pulley divisor="2"/><site site="o2"/><site site="i1"/></spatial></tendon>
  <actuator><motor tendon="t"/><motor site="i1" gear="0 1 0 0 0 0"/><motor cranksite="o1" slidersite="i1" cranklength="0.5"/></actuator>
  <sensor><velocimeter site="o1"/><gyro site="i1"/><accelerometer site="i1"/><framelinacc objtype="site" objname="o1"/>
    <force site="i1"/><torque site="r1"/><force site="hs"/><framelinvel objtype="site" objname="o1" reftype="site" refname="i1"/>
    <subtreecom body="hub"/><subtreelinvel body="joint_mass"/><subtreeangmom body="world"/></sensor>
</mujoco>)";
  auto s = load_scene_string(xml, "/tmp/cosserat_step_alloc_test.xml");
  for (Integrator it : {Integrator::Implicit, Integrator::Trapezoidal}) {
    SceneData sd(*s);
    for (int i = 0; i < s->m->nu; ++i) sd.d->ctrl[i] = 0.05;
    for (int k = 0; k < 5; ++k) ASSERT_EQ(step(*s, sd, it), Status::Ok);  // scratch reaches its size
    alloc_probe::arm();
    Status st = Status::Ok;
    for (int k = 0; k < 20 && st == Status::Ok; ++k) st = step(*s, sd, it);
    alloc_probe::disarm();
    EXPECT_EQ(st, Status::Ok);
    EXPECT_EQ(alloc_probe::g_malloc_calls, 0) << "heap allocations in 20 steps";
    EXPECT_EQ(alloc_probe::g_new_calls, 0) << "operator new calls in 20 steps";
    if (alloc_probe::g_malloc_calls > 0 || alloc_probe::g_new_calls > 0) alloc_probe::print_first_allocation();
  }
}

}  // namespace

// From the first step on: a soft GVS rod and a PCS rod dropped on a floor, stepped from a fresh
// SceneData through their first contacts, with no warm-up at all (the core's section-Jacobian
// scratch had been sized at its first use, the first contact: a one-time allocation).
TEST(SceneStepAlloc, NoHeapAllocationFromTheFirstStepThroughTheFirstContact) {
  const char* xml = R"(<mujoco><option timestep="0.001"/><worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body name="a" pos="0 0 0.03"><freejoint/><geom type="sphere" size="0.01" mass="0.01"/>
      <cosserat name="gvs" length="0.3" sections="2" order="2" strain="kl" radius="0.01" young="1e6"/></body>
    <body name="b" pos="0 0.2 0.03"><freejoint/><geom type="sphere" size="0.01" mass="0.01"/>
      <cosserat name="pcs" length="0.3" sections="6" strain="kl" radius="0.01" young="1e6"/></body>
  </worldbody></mujoco>)";
  for (Integrator it : {Integrator::Implicit, Integrator::Trapezoidal, Integrator::Rosenbrock}) {
    SCOPED_TRACE(integrator_name(it));
    auto s = load_scene_string(xml, "/tmp/cosserat_first_contact_alloc.xml");
    SceneData sd(*s);
    int first_contact = -1;
    alloc_probe::arm();
    Status st = Status::Ok;
    for (int k = 0; k < 200 && st == Status::Ok; ++k) {
      st = step(*s, sd, it);
      if (first_contact < 0 && sd.d->ncon > 0) first_contact = k;
    }
    alloc_probe::disarm();
    EXPECT_EQ(st, Status::Ok);
    EXPECT_GE(first_contact, 1) << "the rods should land within the run, not start on the floor";
    EXPECT_EQ(alloc_probe::g_malloc_calls, 0) << "heap allocations in 200 steps from the start";
    EXPECT_EQ(alloc_probe::g_new_calls, 0);
    if (alloc_probe::g_malloc_calls > 0 || alloc_probe::g_new_calls > 0) alloc_probe::print_first_allocation();
  }
}
