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
                          Integrator::GeneralizedAlpha, Integrator::Midpoint})
    for (double tol : {0.0, 1e-2}) {  // fixed steps, and adaptive substeps (Scene::step_tol)
      if (tol > 0 && (it == Integrator::Euler || it == Integrator::RK4)) continue;
      SCOPED_TRACE(name + " integrator " + std::to_string(static_cast<int>(it)) + " step_tol " + std::to_string(tol));
      s->step_tol = 0.0;
      SceneData sd(*s);
      if (s->m->nkey > 0) mj_resetDataKeyframe(s->m, sd.d, 0);
      // 0.3 s with the implicit integrator at the model's step: rods bend, contacts appear
      s->m->opt.timestep = h;
      for (int k = 0; k < static_cast<int>(0.3 / h); ++k) ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
      // the explicit integrators need small steps on the stiff rods (bench/README.md, stress)
      const bool a_stable = it == Integrator::Implicit || it == Integrator::Trapezoidal ||
                            it == Integrator::GeneralizedAlpha || it == Integrator::Midpoint;
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

}  // namespace
