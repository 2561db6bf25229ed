// The work-precision study times short runs warm (bench/work_precision_main.cpp: kWarmBelow): a run
// once after the model's load, the state reset (Sim::reset), the same run again, timed. That is
// only the same computation if a reset leaves nothing of the first run behind: the integrators'
// histories (Newton's Anderson memory, generalized-alpha's pseudo-acceleration, adaptive substeps),
// the contacts' and constraint rows' patterns, the controls.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <string>
#include <vector>

#include "common.hpp"
#include "native_chain.hpp"

using namespace cosserat;
using namespace cosserat::bench;

namespace {

const std::string kModels = COSSERAT_SOURCE_DIR "/models/";

// Two runs of `sim` from its initial state (the first keyframe's controls), the second after reset().
void expect_reset_reproduces(Sim& sim, double T, double h, const std::string& what) {
  const std::vector<int> sites = {0, sim.m()->nsite - 1};
  std::vector<Trajectory> runs;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass) sim.reset();
    for (int i = 0; i < sim.m()->nu && sim.m()->nkey > 0; ++i) sim.d()->ctrl[i] = sim.m()->key_ctrl[i];
    runs.push_back(run(sim, T, h, h, sites));
  }
  ASSERT_FALSE(runs[0].diverged) << what;
  ASSERT_EQ(runs[0].t.size(), runs[1].t.size()) << what;
  ASSERT_GT(runs[0].t.size(), 10u) << what;
  bool moved = false;
  for (size_t k = 0; k < runs[0].t.size(); ++k) {
    EXPECT_EQ(runs[0].t[k], runs[1].t[k]) << what;
    for (size_t i = 0; i < sites.size(); ++i) {
      for (int c = 0; c < 3; ++c) ASSERT_EQ(runs[0].p[k][i](c), runs[1].p[k][i](c)) << what << ", sample " << k;
      moved = moved || (runs[0].p[k][i] - runs[0].p[0][i]).norm() > 1e-4;
    }
  }
  EXPECT_TRUE(moved) << what << ": nothing moved, the comparison shows nothing";
}

}  // namespace

// The shipped octopus arm (three cables through rod sites, contacts with its object and the table,
// the "curl" controls) under each of our integrators, adaptive substeps too.
TEST(SimReset, OurRunsFromTheResetStateRepeatTheFirstBitForBit) {
  const std::string path = kModels + "octopus_arm.xml";
  const std::string xml = read_file(path);
  for (Method m : {Method::Euler, Method::Implicit, Method::RK4, Method::Trapezoidal, Method::TrapezoidalLinear,
                   Method::GeneralizedAlpha, Method::ImplicitNewton, Method::Midpoint, Method::Rosenbrock}) {
    const double h = m == Method::Euler || m == Method::RK4 ? 2e-4 : 2e-3;
    auto sim = make_rod_sim(xml, path, m, h);
    expect_reset_reproduces(*sim, 0.1, h, method_name(m));
  }
  rod_sim_options().step_tol = 1e-2;
  auto sim = make_rod_sim(xml, path, Method::Trapezoidal, 5e-3);
  rod_sim_options().step_tol = 0.0;
  expect_reset_reproduces(*sim, 0.1, 5e-3, "trapezoidal with adaptive substeps");
}

// MuJoCo's side: the native chain of the shipped cantilever under MuJoCo's integrators.
TEST(SimReset, MujocosRunsFromTheResetStateRepeatTheFirstBitForBit) {
  const std::string path = kModels + "cantilever.xml";
  NativeChainOptions o;
  o.segments = 6;
  const std::string xml = native_chain_xml(read_file(path), path, o);
  for (Method m : {Method::Euler, Method::RK4, Method::Implicit}) {
    auto sim = make_mujoco_sim(xml, path, m, 1e-4);
    expect_reset_reproduces(*sim, 0.05, 1e-4, method_name(m));
  }
}
