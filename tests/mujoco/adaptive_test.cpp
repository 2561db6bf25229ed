// Adaptive substeps (Scene::step_tol, scene.cpp adaptive_step): each step of the model's time step
// is taken as substeps h / 2^k, refined where the mean acceleration changes between substeps by
// more than the tolerance (kinetic-energy norm, against the velocity scale) or the Newton iteration
// fails, coarsened where it changes by less than an eighth of it. Checked on the heavy tip of
// docs/bench/repro/heavy_tip.xml (a whipping rod whose fixed trapezoidal steps wander in energy)
// against a fine fixed-step reference, and on the shipped cantilever for the coarsening.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const std::string kHeavyTip = COSSERAT_SOURCE_DIR "/docs/bench/repro/heavy_tip.xml";

struct TipRun {
  Vec3 tip;
  double energy_wander = 0.0;  // largest |E - E0|
  SceneData::AdaptiveStats stats;
  long steps = 0;
  double time = 0.0;
};

// `duration` of the heavy tip at time step h with `method` (refreshed Newton matrix), adaptive to
// `tol` (0: fixed steps).
TipRun heavy_tip(Integrator method, double h, double tol, double duration) {
  auto s = load_scene(kHeavyTip);
  s->m->opt.timestep = h;
  s->step_tol = tol;
  s->newton_refresh = true;
  SceneData sd(*s);
  TipRun r;
  forward(*s, sd);
  const double e0 = energy(*s, sd).total();
  r.steps = std::lround(duration / h);
  for (long k = 0; k < r.steps; ++k) {
    EXPECT_EQ(step(*s, sd, method), Status::Ok) << "step " << k;
    if (k % 10 == 9) {
      forward(*s, sd);
      r.energy_wander = std::max(r.energy_wander, std::abs(energy(*s, sd).total() - e0));
    }
  }
  forward(*s, sd);
  const int tip = mj_name2id(s->m, mjOBJ_SITE, "rod/tip");
  r.tip = Vec3(sd.d->site_xpos[3 * tip], sd.d->site_xpos[3 * tip + 1], sd.d->site_xpos[3 * tip + 2]);
  r.stats = sd.adapt_stats;
  r.time = sd.d->time;
  return r;
}

}  // namespace

// Error against a fixed step 64 times smaller (its own error about 1e-6 L), at t = 1 s before the
// rod whips: the tolerance controls the error (measured at 5 ms: fixed 3.4e-3 L, tol 1e-2 3.2e-3
// with 2.1 substeps per step, tol 1e-3 3.7e-4 with 5.8), the substeps tile the steps (each ends at
// the time the fixed steps do), and every substep met the tolerance.
TEST(Adaptive, TheToleranceControlsTheError) {
  const double h = 0.005, L = 0.5;
  const TipRun ref = heavy_tip(Integrator::Trapezoidal, h / 64, 0.0, 1.0);
  const TipRun fixed = heavy_tip(Integrator::Trapezoidal, h, 0.0, 1.0);
  const TipRun coarse = heavy_tip(Integrator::Trapezoidal, h, 1e-2, 1.0);
  const TipRun fine = heavy_tip(Integrator::Trapezoidal, h, 1e-3, 1.0);
  const double e_fixed = (fixed.tip - ref.tip).norm() / L, e_coarse = (coarse.tip - ref.tip).norm() / L,
               e_fine = (fine.tip - ref.tip).norm() / L;
  std::printf("tip error / L at 1 s: fixed %.2e, tol 1e-2 %.2e (%.2f substeps per step), tol 1e-3 %.2e (%.2f)\n",
              e_fixed, e_coarse, double(coarse.stats.substeps) / coarse.steps, e_fine,
              double(fine.stats.substeps) / fine.steps);
  EXPECT_LE(e_coarse, 1.05 * e_fixed);
  EXPECT_LT(e_fine, e_coarse / 4);
  EXPECT_GT(fine.stats.substeps, coarse.stats.substeps);
  EXPECT_EQ(fine.stats.steps, fine.steps);
  EXPECT_EQ(fine.stats.kept_at_min, 0);
  EXPECT_EQ(fine.time, fixed.time);  // bit for bit: each step ends at its start + h, not at a sum of substeps
}

// Over 2 s the rod whips (strain rates of hundreds per second): the trapezoidal rule with the
// refreshed Newton matrix at fixed 5 ms steps converges at the full step and wanders in energy
// (measured: 0.56 J of 4.2), at adaptive substeps (tol 1e-2) its energy stays within 1% (measured
// 0.0047 J: 20 substeps per step, finest h/64, none kept above the tolerance).
TEST(Adaptive, HeavyTipKeepsItsEnergy) {
  const TipRun fixed = heavy_tip(Integrator::Trapezoidal, 0.005, 0.0, 2.0);
  const TipRun adaptive = heavy_tip(Integrator::Trapezoidal, 0.005, 1e-2, 2.0);
  std::printf("energy wander over 2 s: fixed %.3g J, adaptive %.3g J (%.1f substeps per step, finest h/%d)\n",
              fixed.energy_wander, adaptive.energy_wander, double(adaptive.stats.substeps) / adaptive.steps,
              1 << adaptive.stats.finest);
  EXPECT_GT(fixed.energy_wander, 0.1);
  EXPECT_LT(adaptive.energy_wander, 0.04);
  EXPECT_EQ(adaptive.stats.kept_at_min, 0);
}

// Where the motion is smooth the levels coarsen back: the shipped cantilever released under
// gravity refines during the first steps only (measured: 1.01 substeps per step over 2 s under
// backward Euler, finest h/4), and a state set between steps (here: a reset) starts without the
// previous substep's history.
TEST(Adaptive, SmoothMotionKeepsTheFullStep) {
  auto s = load_scene(COSSERAT_SOURCE_DIR "/models/cantilever.xml");
  s->step_tol = 1e-2;
  SceneData sd(*s);
  const long n = std::lround(2.0 / s->m->opt.timestep);
  for (long k = 0; k < n; ++k) ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok);
  EXPECT_EQ(sd.adapt_stats.steps, n);
  EXPECT_LT(double(sd.adapt_stats.substeps) / n, 1.1);
  EXPECT_GT(sd.adapt_stats.finest, 0);  // the release did refine
  EXPECT_EQ(sd.adapt.level, 0);
  reset(*s, sd);
  EXPECT_FALSE(sd.adapt.valid);
  EXPECT_EQ(sd.adapt.level, 0);
}

// A model asks for adaptive substeps with <custom><numeric name="cosserat:step_tol" data="TOL"/>:
// the scene loads with it, and its steps take substeps (a rod released straight refines at first).
TEST(Adaptive, ModelSetsTheTolerance) {
  auto s = load_scene_string(R"(<mujoco><custom><numeric name="cosserat:step_tol" data="0.001"/></custom>
  <worldbody><cosserat name="q" length="0.3" radius="0.01" sections="2"/></worldbody></mujoco>)",
                             "/tmp/cosserat_adaptive_test.xml");
  EXPECT_EQ(s->step_tol, 1e-3);
  SceneData sd(*s);
  for (int k = 0; k < 50; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
  EXPECT_EQ(sd.adapt_stats.steps, 50);
  EXPECT_GT(sd.adapt_stats.substeps, 50);
  auto plain = load_scene_string(R"(<mujoco><worldbody><cosserat name="q" length="0.3" radius="0.01"/></worldbody></mujoco>)",
                                 "/tmp/cosserat_adaptive_test.xml");
  EXPECT_EQ(plain->step_tol, 0.0);
}

// An episode replayed after MuJoCo's own reset (mj_resetData on the same SceneData, as an RL
// environment resets) is the first episode bit for bit: a step that does not start where the last
// ended starts from whole steps, as a new SceneData does. Outside probe AB: the level carried over
// the reset, and the octopus arm's replay under trapezoidal ended 1.2 cm away from the first.
TEST(Adaptive, AnEpisodeReplayedAfterMujocosResetIsTheFirstBitForBit) {
  auto s = load_scene(kHeavyTip);
  s->m->opt.timestep = 0.005;
  s->step_tol = 1e-2;
  SceneData sd(*s);
  auto episode = [&] {
    for (int k = 0; k < 100; ++k) EXPECT_EQ(step(*s, sd, Integrator::Trapezoidal), Status::Ok);
    return std::vector<double>(sd.d->qpos, sd.d->qpos + s->m->nq);
  };
  const std::vector<double> first = episode();
  ASSERT_GT(sd.adapt.level, 0);  // the episode ends refined: the level a reset must not carry
  mj_resetData(s->m, sd.d);
  EXPECT_EQ(episode(), first);
}
