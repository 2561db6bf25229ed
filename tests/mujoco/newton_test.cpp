// The fully implicit steps of the scene (scene.cpp, newton_step): backward Euler, the trapezoidal
// rule and the generalized-alpha method solved by simplified Newton iterations. Each is checked
// against its defining equation at the end of a step, against its order of accuracy (RK4 at a tiny
// step as the reference), and on the stress cases that made them necessary (bench/README.md,
// docs/bench/repro/).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "scene.hpp"
#include "support/text_file.hpp"
#include "support/weighted_cantilever.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const char* kPath = "/tmp/cosserat_newton_test.xml";

std::string cantilever_xml(double young, double radius, int sections, double timestep) {
  return cosserat::testing::weighted_cantilever_xml(young, radius, sections, timestep);
}

std::vector<double> qpos(const SceneData& sd, int nq) { return std::vector<double>(sd.d->qpos, sd.d->qpos + nq); }

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double e = 0.0;
  for (size_t i = 0; i < a.size(); ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return e;
}

double max_abs(const mjtNum* x, int n) {
  double e = 0.0;
  for (int i = 0; i < n; ++i) e = std::max(e, std::abs(x[i]));
  return e;
}

// After `warmup` steps, one more step from (q, v) to (q+, v+); returns the largest violation of
//   (v+ - v) / h = (1 - theta) f(q, v) + theta f(q+, v+)    and of    q+ = q + h v + h theta (v+ - v)
// relative to max |f|, for a clamped rod (qpos = strains: nq = nv, linear).
struct Residual {
  double velocity = 0.0, position = 0.0;
};
Residual theta_residual(Integrator it, int newton, double theta, int warmup) {
  auto s = load_scene_string(cantilever_xml(1e7, 0.005, 4, 2e-3), kPath);
  s->newton_iterations = newton;
  s->newton_tol = 1e-12;
  SceneData sd(*s);
  const mjModel* m = s->m;
  const int nv = m->nv;
  EXPECT_EQ(m->nq, nv);
  for (int k = 0; k < warmup; ++k) EXPECT_EQ(step(*s, sd, it), Status::Ok);
  const std::vector<double> q0(sd.d->qpos, sd.d->qpos + nv), v0(sd.d->qvel, sd.d->qvel + nv);
  forward(*s, sd);
  const std::vector<double> f0(sd.d->qacc, sd.d->qacc + nv);
  EXPECT_EQ(step(*s, sd, it), Status::Ok);
  const std::vector<double> q1(sd.d->qpos, sd.d->qpos + nv), v1(sd.d->qvel, sd.d->qvel + nv);
  forward(*s, sd);
  const double h = m->opt.timestep, scale = std::max(max_abs(sd.d->qacc, nv), max_abs(f0.data(), nv));
  Residual r;
  for (int i = 0; i < nv; ++i) {
    const double a = (v1[i] - v0[i]) / h;
    r.velocity = std::max(r.velocity, std::abs(a - (1 - theta) * f0[i] - theta * sd.d->qacc[i]) / scale);
    r.position = std::max(r.position, std::abs(q1[i] - q0[i] - h * v0[i] - h * h * theta * a) / (h * h * scale));
  }
  return r;
}

// The generalized alpha carries its end acceleration to the next step when that starts where this
// one ended. MuJoCo's kinematics normalises qpos's quaternions in place, so a forward between two
// steps (for the end state's sensors, a render) moves them by an ulp: with an exact test the carry
// was dropped there, and at a contact's onset that moved the step by 5.2e-5 m and the runs 4.7e-3
// m apart over 0.3 s (outside probe T). A box dropped on a rod: the run with a forward before
// every step and the run without agree to round-off, through the impact.
TEST(Newton, GeneralizedAlphaIgnoresARoundOffChangeOfTheStartState) {
  const char* xml = R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <cosserat name="rod" pos="0 0 0.3" length="0.4" sections="6" strain="kl" radius="0.01" density="1000"
              young="5e7" poisson="0.45" viscosity="20" condim="3" friction="0.8 0.005 0.0001"/>
    <body name="box" pos="0.3 0 0.34"><freejoint/><geom name="box" type="box" size="0.02 0.02 0.02" mass="0.2"/></body>
    </worldbody></mujoco>)";
  auto s = load_scene_string(xml, kPath);
  SceneData plain(*s), looked_at(*s);
  double largest = 0.0;
  int contacts = 0;
  for (int k = 0; k < 300; ++k) {
    forward(*s, looked_at);
    ASSERT_EQ(step(*s, plain, Integrator::GeneralizedAlpha), Status::Ok);
    ASSERT_EQ(step(*s, looked_at, Integrator::GeneralizedAlpha), Status::Ok);
    contacts = std::max(contacts, plain.d->ncon);
    for (int i = 0; i < s->m->nq; ++i) largest = std::max(largest, std::abs(plain.d->qpos[i] - looked_at.d->qpos[i]));
  }
  EXPECT_GT(contacts, 0);
  EXPECT_LT(largest, 1e-10);
}

TEST(Newton, BackwardEulerSolvesItsImplicitEquation) {
  const Residual nw = theta_residual(Integrator::Implicit, 50, 1.0, 100);
  const Residual lin = theta_residual(Integrator::Implicit, 0, 1.0, 100);
  EXPECT_LT(nw.velocity, 1e-8);
  EXPECT_LT(nw.position, 1e-12);
  // the linearised step leaves gravity, Coriolis and geometric stiffness explicit: it misses
  EXPECT_GT(lin.velocity, 1e3 * nw.velocity) << "the linearised step should not satisfy the implicit equation";
}

TEST(Newton, TrapezoidalRuleSolvesItsImplicitEquation) {
  const Residual nw = theta_residual(Integrator::Trapezoidal, 50, 0.5, 100);
  const Residual lin = theta_residual(Integrator::Trapezoidal, 0, 0.5, 100);
  EXPECT_LT(nw.velocity, 1e-8);
  EXPECT_LT(nw.position, 1e-12);
  EXPECT_GT(lin.velocity, 1e3 * nw.velocity);
}

// Error at T = 0.2 s against RK4 at h = 1e-5, for steps h, h/2, h/4 (`newton`: the corrections
// per step, Scene::newton_iterations).
std::vector<double> errors(Integrator it, double rho, const std::vector<double>& steps, int newton = 50) {
  const double T = 0.2;
  auto run = [&](Integrator method, double h) {
    auto s = load_scene_string(cantilever_xml(1e6, 0.01, 3, h), kPath);
    s->newton_tol = 1e-12;
    s->newton_iterations = newton;
    s->rho_inf = rho;
    SceneData sd(*s);
    const long n = std::lround(T / h);
    for (long k = 0; k < n; ++k) EXPECT_EQ(step(*s, sd, method), Status::Ok);
    return qpos(sd, s->m->nq);
  };
  const std::vector<double> ref = run(Integrator::RK4, 1e-5);
  std::vector<double> e;
  for (double h : steps) e.push_back(max_abs_diff(run(it, h), ref));
  return e;
}

void expect_order(Integrator it, double rho, double lo, double hi, int newton = 50) {
  const std::vector<double> e = errors(it, rho, {4e-3, 2e-3, 1e-3}, newton);
  std::printf("errors at h = 4, 2, 1 ms: %.3e %.3e %.3e\n", e[0], e[1], e[2]);
  for (size_t k = 0; k + 1 < e.size(); ++k) {
    const double ratio = e[k] / e[k + 1];
    EXPECT_GT(ratio, lo) << "errors " << e[k] << " -> " << e[k + 1];
    EXPECT_LT(ratio, hi) << "errors " << e[k] << " -> " << e[k + 1];
  }
}

TEST(Newton, TrapezoidalRuleIsSecondOrder) { expect_order(Integrator::Trapezoidal, 0.8, 3.2, 5.0); }
TEST(Newton, GeneralizedAlphaIsSecondOrder) { expect_order(Integrator::GeneralizedAlpha, 0.8, 3.2, 5.0); }
TEST(Newton, GeneralizedAlphaWithMostDampingIsSecondOrder) {
  expect_order(Integrator::GeneralizedAlpha, 0.0, 3.2, 5.0);
}
TEST(Newton, BackwardEulerIsFirstOrder) { expect_order(Integrator::Implicit, 0.8, 1.6, 2.5); }
TEST(Newton, MidpointRuleIsSecondOrder) { expect_order(Integrator::Midpoint, 0.8, 3.2, 5.0); }
// The linearised trapezoidal rule (--newton 0) takes gravity's and the inertial forces'
// configuration derivative explicitly (its matrix has the rods' K only): first order. One
// correction per step with the start's matrix (--newton 1) restores the rule's second order.
TEST(Newton, LinearisedTrapezoidalRuleIsFirstOrder) { expect_order(Integrator::Trapezoidal, 0.8, 1.6, 2.5, 0); }
TEST(Newton, OneCorrectionMakesTheTrapezoidalRuleSecondOrder) {
  expect_order(Integrator::Trapezoidal, 0.8, 3.2, 5.0, 1);
}

// rho_inf = 1: generalized alpha is the trapezoidal rule (its A stays f(q, v) when converged).
TEST(Newton, GeneralizedAlphaWithRhoOneIsTheTrapezoidalRule) {
  auto run = [](Integrator it) {
    auto s = load_scene_string(cantilever_xml(1e7, 0.005, 4, 2e-3), kPath);
    s->newton_tol = 1e-12;
    s->newton_iterations = 50;
    s->rho_inf = 1.0;
    SceneData sd(*s);
    for (int k = 0; k < 200; ++k) EXPECT_EQ(step(*s, sd, it), Status::Ok);
    return qpos(sd, s->m->nq);
  };
  const std::vector<double> a = run(Integrator::GeneralizedAlpha), b = run(Integrator::Trapezoidal);
  double scale = 0.0;
  for (double x : b) scale = std::max(scale, std::abs(x));
  ASSERT_GT(scale, 0.1);  // it moved
  EXPECT_LT(max_abs_diff(a, b), 1e-8 * scale);
}

// The stress finding (docs/bench/RESULTS.md, long runs): the linearised trapezoidal rule on an
// undamped cantilever (E = 1e7, L/r = 100) at h = 1 ms diverged after 13209 steps. Solved fully
// implicitly (the default), 20000 steps keep the energy within 1%.
TEST(Newton, TrapezoidalRuleKeepsEnergyOverALongRun) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <cosserat name="rod" pos="0 0 1" length="0.5" sections="4" strain="kl" radius="0.005" density="1000"
              young="1e7" poisson="0.5" viscosity="0"/></worldbody></mujoco>)",
                             kPath);
  SceneData sd(*s);
  ASSERT_EQ(s->newton_for(Integrator::Trapezoidal), 10);
  forward(*s, sd);
  const double e0 = energy(*s, sd).total();
  double worst = 0.0;
  for (int k = 0; k < 20000; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::Trapezoidal), Status::Ok) << "step " << k;
    if (k % 100 == 0) {
      forward(*s, sd);
      worst = std::max(worst, std::abs(energy(*s, sd).total() - e0) / std::abs(e0));
    }
  }
  EXPECT_LT(worst, 1e-2);
  EXPECT_EQ(sd.newton_stats.unconverged, 0);
}

// The stress finding docs/bench/repro/soft_string_collapse.xml: a string too soft for its own
// weight diverged under the linearised implicit step at 2 ms. Fully implicit it runs, and backward
// Euler only dissipates.
TEST(Newton, SoftStringRunsFullyImplicit) {
  auto s = load_scene(std::string(COSSERAT_SOURCE_DIR) + "/docs/bench/repro/soft_string_collapse.xml");
  s->m->opt.timestep = 2e-3;
  s->newton_iterations = 10;
  SceneData sd(*s);
  forward(*s, sd);
  const double e0 = energy(*s, sd).total();
  for (int k = 0; k < 1500; ++k) ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << "step " << k;
  forward(*s, sd);
  EXPECT_LE(energy(*s, sd).total(), e0 * (1 + 1e-9));
  EXPECT_EQ(sd.newton_stats.unconverged, 0);
}

// A step whose iterations run out is redone as two half steps: with two corrections allowed and a
// tight tolerance the steps split (one correction is kept as it is: OneCorrectionPerStepIsKept), and the result is the fully implicit solution at the finer
// steps (close to the converged one at h; both are within the method's error of each other).
TEST(Newton, UnconvergedStepsSplit) {
  auto run = [](int iterations, double tol, SceneData::NewtonStats* stats) {
    auto s = load_scene_string(cantilever_xml(1e7, 0.005, 4, 2e-3), kPath);
    s->newton_iterations = iterations;
    s->newton_tol = tol;
    SceneData sd(*s);
    for (int k = 0; k < 50; ++k) EXPECT_EQ(step(*s, sd, Integrator::Trapezoidal), Status::Ok);
    if (stats) *stats = sd.newton_stats;
    EXPECT_NEAR(sd.d->time, 0.1, 1e-12);
    return qpos(sd, s->m->nq);
  };
  SceneData::NewtonStats st;
  const std::vector<double> split = run(2, 1e-12, &st), full = run(50, 1e-12, nullptr);
  EXPECT_GT(st.splits, 0);
  double scale = 0.0;
  for (double x : full) scale = std::max(scale, std::abs(x));
  EXPECT_LT(max_abs_diff(split, full), 1e-2 * scale);
}

// A step of h/64 whose corrections still fail: where they ran out still contracting, the last
// iterate is kept (with two corrections and a tolerance no step meets, every step splits down to
// h/64 and each of its 64 pieces is kept so); where they stopped (non-finite, or grown tenfold) it
// is taken as a linearised backward Euler step. Outside probe AP's soft leg buckling under a
// weight with its foot on a floor (docs/bench/repro/buckling_leg_on_floor.xml) had diverged under
// genalpha at 1 ms at 0.68 s with every such piece kept. Its foot's contacts now change state
// within steps, which are taken as linearised backward Euler steps before they come to splitting
// (constraint_pattern): it runs through 0.75 s without the fallback. The repro rod impact at 10 ms,
// ten times its model's step, takes it after the impact.
TEST(Newton, StepsThatFailAtTheFinestSplitFallBackWhereTheirCorrectionsStopped) {
  {
    auto s = load_scene_string(cantilever_xml(1e7, 0.005, 4, 2e-3), kPath);
    SceneData sd(*s);
    for (int i = 0; i < s->m->nv; ++i) sd.d->qvel[i] = 1.0;  // moving: no correction falls to 1e-12
    s->newton_iterations = 2;
    s->newton_tol = 1e-300;
    for (int k = 0; k < 5; ++k) ASSERT_EQ(step(*s, sd, Integrator::Trapezoidal), Status::Ok);
    EXPECT_EQ(sd.newton_stats.unconverged, 5 * 64);
    EXPECT_EQ(sd.newton_stats.linearised, 0);
  }
  auto run = [](const char* file, double h, double duration) {
    auto s = load_scene(std::string(COSSERAT_SOURCE_DIR) + "/docs/bench/repro/" + file);
    s->m->opt.timestep = h;
    auto sd = std::make_unique<SceneData>(*s);
    Status st = Status::Ok;
    while (st == Status::Ok && sd->d->time < duration - 1e-9) st = step(*s, *sd, Integrator::GeneralizedAlpha);
    const auto& n = sd->newton_stats;
    std::printf("%s: %s at %.3f s, %ld split, %ld unconverged, %ld linearised, %ld events\n", file,
                st == Status::Ok ? "ran" : "diverged", sd->d->time, n.splits, n.unconverged, n.linearised, n.events);
    EXPECT_EQ(st, Status::Ok) << file;
    return std::make_pair(std::move(s), std::move(sd));
  };
  const auto leg = run("buckling_leg_on_floor.xml", 0.001, 0.75);
  EXPECT_GT(leg.second->newton_stats.events, 0);
  const auto impact = run("rod_cross_impact.xml", 0.01, 0.4);
  EXPECT_GT(impact.second->newton_stats.linearised, 0);
}

// The split pieces of a step evaluate MuJoCo's constraints as the whole step does
// (SceneData::constraint_timestep): MuJoCo's refsafe raises a solref time constant to twice the
// step, and pieces of h/64 had seen a hard floor (solref 0.002 at 5 ms) 25 times stiffer than the
// whole steps do. (Outside probe AW: the repro heavy tip dropped on that floor under trapezoidal at
// 5 ms ended with its hub 12 mm along the rod from where implicit puts it, 3.5 mm; now 3.1 mm.)
TEST(Newton, SplitStepsKeepTheWholeStepsConstraints) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.005"/><worldbody>
      <geom type="plane" size="1 1 0.1" solref="0.002 1"/>
      <body name="ball" pos="0 0 0.0299"><freejoint/><geom type="sphere" size="0.03" mass="1" solref="0.002 1"/></body>
      <cosserat name="rod" pos="0 0.5 0.5" length="0.1" sections="1" strain="kl" radius="0.005" young="1e7"/>
    </worldbody></mujoco>)",
                             kPath);
  SceneData sd(*s);
  const double h = s->m->opt.timestep;
  auto stiffness = [&](double timestep) {  // the contact's K (efc_KBIP) as forward evaluates it
    s->m->opt.timestep = timestep;
    forward(*s, sd);
    EXPECT_EQ(s->m->opt.timestep, timestep);
    EXPECT_GT(sd.d->nefc, 0);
    const double K = sd.d->efc_KBIP[0];
    s->m->opt.timestep = h;
    return K;
  };
  const double whole = stiffness(h), piece = stiffness(h / 64);
  EXPECT_GT(piece, 20 * whole);  // refsafe: time constants 0.002 against 2h = 0.01
  sd.constraint_timestep = h;
  EXPECT_NEAR(stiffness(h / 64), whole, 1e-12 * whole);
  sd.constraint_timestep = 0.0;
  // a step split down to h/64 (the ball lifted and moving, two corrections, a tolerance none
  // meets) leaves the constraint step and the time step as it found them
  sd.d->qpos[2] = 0.1;
  for (int i = 0; i < s->m->nv; ++i) sd.d->qvel[i] = 0.1;
  s->newton_iterations = 2;
  s->newton_tol = 1e-300;
  ASSERT_EQ(step(*s, sd, Integrator::Trapezoidal), Status::Ok);
  EXPECT_EQ(sd.newton_stats.unconverged, 64);
  EXPECT_EQ(sd.constraint_timestep, 0.0);
  EXPECT_EQ(s->m->opt.timestep, h);
}

// The linearised implicit step holds the equality rows on rods in its matrix, as the Newton
// schemes' matrix does (add_constraint_terms, equalities only), with their start's force and the
// linearised change of -D (J a + B J v + K I r) over the step on the right-hand side. Outside probe
// AX: a rod pinned by a connect at its last section flipped over the pin at 5 ms (the tip at
// -131 mm, then +846 mm; the equilibrium -1.04 mm); an undamped rod welded at its tip diverged at
// 1 ms and 5 ms (outside probe AV's e3_weld). Both now hold.
TEST(Newton, TheImplicitStepHoldsEqualitiesOnRods) {
  auto pinned = load_scene_string(R"(<mujoco><worldbody>
      <cosserat name="rod" length="1" sections="16" strain="kl" radius="0.01" density="1000" young="1e9"
                poisson="0.3" viscosity="50"/></worldbody>
      <equality><connect body1="rod/s15" anchor="0 0 0"/></equality></mujoco>)",
                                  kPath);
  auto welded = load_scene_string(R"(<mujoco><worldbody>
      <cosserat name="r" pos="0 0 1" length="0.5" sections="8" strain="kl" radius="0.01" density="1000" young="1e7"
                poisson="0.5" viscosity="0" contype="0" conaffinity="0"/></worldbody>
      <equality><weld body1="r/s7"/></equality></mujoco>)",
                                  kPath);
  for (const double h : {0.001, 0.005}) {
    SCOPED_TRACE(h);
    {
      pinned->m->opt.timestep = h;
      SceneData sd(*pinned);
      for (int k = 0; k < static_cast<int>(std::lround(2.0 / h)); ++k) ASSERT_EQ(step(*pinned, sd), Status::Ok) << k;
      EXPECT_NEAR(rod_frame(*pinned, sd, 0, 1.0).u.z(), -1.04e-3, 2e-5);  // equilibrium: -1.041 mm
    }
    {
      welded->m->opt.timestep = h;
      SceneData sd(*welded);
      forward(*welded, sd);
      const double e0 = energy(*welded, sd).total();
      for (int k = 0; k < static_cast<int>(std::lround(1.0 / h)); ++k) ASSERT_EQ(step(*welded, sd), Status::Ok) << k;
      forward(*welded, sd);
      EXPECT_LE(energy(*welded, sd).total(), e0 + 1e-6);  // undamped: backward Euler only takes energy
      EXPECT_NEAR(rod_frame(*welded, sd, 0, 0.5).u.z(), 1.0, 5e-3);  // the weld holds the tip up
    }
  }
}

// The same for an equality row that closes a loop, which ties two branches of the tree (MuJoCo's qM
// pattern cannot hold its term: a Woodbury row holds it). Outside probe BY: two undamped rods
// clamped to two walls and welded tip to tip, a clamped-clamped beam in two halves, tapped and
// left free, gained energy under the default step at any step size (1e-4 J to 0.09 J in 5 s at
// 1 ms; a damped parallel robot released from rest reached 10.8 J), the weld acting explicitly.
// Reference: the undamped loop under midpoint keeps its energy; backward Euler only takes some.
TEST(Newton, TheImplicitStepHoldsAWeldClosingALoopOfRods) {
  auto loop = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 0"/><worldbody>
      <cosserat name="a" length="0.5" sections="8" strain="kl" radius="0.01" density="1000" young="1e7"
                poisson="0.5" contype="0" conaffinity="0"/>
      <cosserat name="b" pos="1 0 0" euler="0 0 180" length="0.5" sections="8" strain="kl" radius="0.01" density="1000"
                young="1e7" poisson="0.5" contype="0" conaffinity="0"/></worldbody>
      <equality><weld body1="a/s7" body2="b/s7"/></equality></mujoco>)",
                                kPath);
  const int tap = mj_name2id(loop->m, mjOBJ_BODY, "a/s4");
  auto run = [&](Integrator method) {
    SceneData sd(*loop);
    for (int k = 0; k < 300; ++k) {  // tapped sideways for 0.3 s
      sd.d->xfrc_applied[6 * tap + 1] = 0.02;
      EXPECT_EQ(step(*loop, sd, method), Status::Ok) << k;
    }
    sd.d->xfrc_applied[6 * tap + 1] = 0.0;
    forward(*loop, sd);
    const double e0 = energy(*loop, sd).total();
    double e_max = e0;
    for (int k = 0; k < 3000; ++k) {
      EXPECT_EQ(step(*loop, sd, method), Status::Ok) << k;
      if (k % 100 == 99) {
        forward(*loop, sd);
        e_max = std::max(e_max, energy(*loop, sd).total());
      }
    }
    return std::make_pair(e0, e_max);
  };
  const auto [e0, e_max] = run(Integrator::Implicit);
  const auto [m0, m_max] = run(Integrator::Midpoint);
  EXPECT_GT(e0, 1e-6);
  EXPECT_LE(e_max, e0 * (1 + 1e-9));    // was 40x in 2 s
  EXPECT_LT(m_max, m0 * (1 + 1e-3));   // the loop's own energy, kept by midpoint
  EXPECT_NEAR(e0, m0, 0.05 * m0);      // the same tap
}

// The Newton schemes' matrix holds a loop's equality rows too (the Woodbury rows of the linearised
// steps): without them the iteration met the weld only in its residual, and a stiffly welded loop
// of rods sagging under gravity at 5 ms took 9.6 corrections a step under backward Euler and split
// 20 of its 400 steps (trapezoidal 7.7 and 9, midpoint similar); held, 4.4 and none.
TEST(Newton, TheNewtonSchemesHoldAWeldClosingALoopOfRods) {
  auto loop = load_scene_string(R"(<mujoco><option timestep="0.005"/><worldbody>
      <cosserat name="a" length="0.5" sections="8" strain="kl" radius="0.01" density="1000" young="1e7"
                poisson="0.5" contype="0" conaffinity="0"/>
      <cosserat name="b" pos="1 0 0" euler="0 0 180" length="0.5" sections="8" strain="kl" radius="0.01" density="1000"
                young="1e7" poisson="0.5" contype="0" conaffinity="0"/></worldbody>
      <equality><weld body1="a/s7" body2="b/s7" solimp="0.9999 0.9999 0.001"/></equality></mujoco>)",
                                kPath);
  for (const Integrator method : {Integrator::Implicit, Integrator::Trapezoidal, Integrator::Midpoint}) {
    SCOPED_TRACE(integrator_name(method));
    SceneData sd(*loop);
    loop->newton_iterations = 10;
    const int steps = 400;
    for (int k = 0; k < steps; ++k) ASSERT_EQ(step(*loop, sd, method), Status::Ok) << k;
    EXPECT_EQ(sd.newton_stats.splits, 0);
    EXPECT_LT(sd.newton_stats.iterations, 5.5 * steps);
    forward(*loop, sd);
    const int a = mj_name2id(loop->m, mjOBJ_BODY, "a/s7"), b = mj_name2id(loop->m, mjOBJ_BODY, "b/s7");
    EXPECT_LT(std::abs(sd.d->xpos[3 * a + 2] - sd.d->xpos[3 * b + 2]), 1e-4);  // the weld holds
    EXPECT_LT(sd.d->xpos[3 * a + 2], -1e-3);                                    // and the loop sags
  }
}

// Anderson acceleration (Scene::newton_memory) extrapolates the corrections of the simplified
// Newton iteration, and Scene::newton_refresh factorises its matrix again at the first iterate. On
// the undamped cantilever at 5 ms (E = 1e7, L/r = 100) over 20 s (the first seconds converge in 3-4
// corrections either way: the gains are where the steps are hard; measured corrections per step):
// - with the matrix of the step's start, Anderson needs about a sixth fewer corrections (5.9 -> 4.9);
// - the matrix refreshed at the first iterate needs a third fewer plain (5.9 -> 4.1) and a fifth
//   fewer with Anderson (4.9 -> 3.9), Anderson then adding little (4.1 -> 3.9);
// and with a tight tolerance all reach the same solution.
TEST(Newton, AndersonAccelerationAndMatrixRefreshCutCorrections) {
  struct Out {
    std::vector<double> q;
    long iterations;
  };
  auto run = [](int memory, bool refresh, double tol, int steps) {
    auto s = load_scene_string(R"(<mujoco><option timestep="0.005" gravity="0 0 -9.81"/><worldbody>
      <cosserat name="rod" pos="0 0 1" length="0.5" sections="4" strain="kl" radius="0.005" density="1000"
                young="1e7" poisson="0.5" viscosity="0"/></worldbody></mujoco>)",
                               kPath);
    s->newton_memory = memory;
    s->newton_refresh = refresh;
    s->newton_tol = tol;
    s->newton_iterations = 50;
    SceneData sd(*s);
    for (int k = 0; k < steps; ++k) EXPECT_EQ(step(*s, sd, Integrator::Trapezoidal), Status::Ok);
    EXPECT_EQ(sd.newton_stats.splits, 0);
    return Out{qpos(sd, s->m->nq), sd.newton_stats.iterations};
  };
  const Out plain = run(0, false, 1e-6, 4000), accelerated = run(3, false, 1e-6, 4000);
  const Out refreshed = run(0, true, 1e-6, 4000), both = run(3, true, 1e-6, 4000);
  std::printf("corrections over 4000 steps: plain %ld, Anderson(3) %ld; matrix refreshed: plain %ld, Anderson(3) %ld\n",
              plain.iterations, accelerated.iterations, refreshed.iterations, both.iterations);
  EXPECT_LT(accelerated.iterations, 0.9 * plain.iterations);
  EXPECT_LT(refreshed.iterations, 0.75 * plain.iterations);
  EXPECT_LT(both.iterations, 0.85 * accelerated.iterations);
  EXPECT_LE(both.iterations, refreshed.iterations);
  const Out a = run(0, false, 1e-11, 100), b = run(3, false, 1e-11, 100), c = run(3, true, 1e-11, 100);
  double scale = 0.0;
  for (double x : a.q) scale = std::max(scale, std::abs(x));
  EXPECT_LT(max_abs_diff(a.q, b.q), 1e-8 * scale);
  EXPECT_LT(max_abs_diff(a.q, c.q), 1e-8 * scale);
}

// ------------------------------------------------------------- energy-conserving midpoint rule --

const char* kUndampedCantilever = R"(<mujoco><option timestep="0.005" gravity="0 0 -9.81"/><worldbody>
    <cosserat name="rod" pos="0 0 1" length="0.5" sections="4" strain="kl" radius="0.005" density="1000"
              young="%g" poisson="0.5" viscosity="%g"/></worldbody></mujoco>)";

std::string undamped_cantilever(double young = 1e7, double viscosity = 0.0) {
  char buf[1024];
  std::snprintf(buf, sizeof buf, kUndampedCantilever, young, viscosity);
  return buf;
}

// Largest relative change of the total energy over `steps` steps (sampled every step).
double energy_drift(Scene& s, Integrator it, int steps, double* e_last = nullptr) {
  SceneData sd(s);
  forward(s, sd);
  const double e0 = energy(s, sd).total();
  double worst = 0.0, e = e0;
  for (int k = 0; k < steps; ++k) {
    EXPECT_EQ(step(s, sd, it), Status::Ok) << "step " << k;
    if (sd.status != Status::Ok) return INFINITY;
    forward(s, sd);
    e = energy(s, sd).total();
    worst = std::max(worst, std::abs(e - e0) / std::abs(e0));
  }
  if (e_last) *e_last = e;
  return worst;
}

// The step solves its defining equation: (v+ - v)/h = f(q_m, v_m) + mu v_m, with f MuJoCo's forward
// acceleration at the midpoint state (q_m = q + h/2 v_m, v_m = (v + v+)/2) and a small scalar mu
// (the energy correction). Checked by taking out of the residual its component along v_m.
TEST(Newton, MidpointRuleSolvesItsEquation) {
  auto s = load_scene_string(cantilever_xml(1e7, 0.005, 4, 2e-3), kPath);
  s->newton_tol = 1e-12;
  s->newton_iterations = 50;
  SceneData sd(*s);
  const mjModel* m = s->m;
  const int nv = m->nv;
  ASSERT_EQ(m->nq, nv);  // strains: linear coordinates
  for (int k = 0; k < 100; ++k) ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
  const std::vector<double> q0(sd.d->qpos, sd.d->qpos + nv), v0(sd.d->qvel, sd.d->qvel + nv);
  ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
  EXPECT_EQ(sd.newton_stats.splits, 0);
  const std::vector<double> q1(sd.d->qpos, sd.d->qpos + nv), v1(sd.d->qvel, sd.d->qvel + nv);
  const double h = m->opt.timestep;
  std::vector<double> vm(nv);
  for (int i = 0; i < nv; ++i) {
    vm[i] = 0.5 * (v0[i] + v1[i]);
    EXPECT_NEAR(q1[i], q0[i] + h * vm[i], 1e-14) << "q+ = q + h v_m";
    sd.d->qpos[i] = q0[i] + 0.5 * h * vm[i];
    sd.d->qvel[i] = vm[i];
  }
  sd.d->time -= 0.5 * h;
  forward(*s, sd);
  std::vector<double> r(nv);
  double rv = 0.0, vv = 0.0, scale = 0.0;
  for (int i = 0; i < nv; ++i) {
    r[i] = (v1[i] - v0[i]) / h - sd.d->qacc[i];
    rv += r[i] * vm[i];
    vv += vm[i] * vm[i];
    scale = std::max(scale, std::abs(sd.d->qacc[i]));
  }
  const double mu = rv / vv;
  double off = 0.0;
  for (int i = 0; i < nv; ++i) off = std::max(off, std::abs(r[i] - mu * vm[i]));
  std::printf("mu h = %.3e, residual off v_m %.3e (max |f| %.3e)\n", mu * h, off, scale);
  EXPECT_LT(off, 1e-8 * scale);
  EXPECT_LT(std::abs(mu * h), 1e-3);
}

// The stress finding (docs/bench/RESULTS.md, long runs): the trapezoidal rule on the undamped
// cantilever (E = 1e7, L/r = 100) at 5 ms wanders in energy and diverges after 4-7e4 steps (Simo
// and Tarnow's instability of the trapezoidal and midpoint rules in nonlinear elastodynamics). The
// energy-corrected midpoint rule keeps the energy to the Newton tolerance; over the first 4000
// steps the trapezoidal rule already loses or gains more than 100 times as much.
TEST(Newton, MidpointRuleKeepsTheEnergyWhereTheTrapezoidalRuleWanders) {
  auto s = load_scene_string(undamped_cantilever(), kPath);
  const double mid = energy_drift(*s, Integrator::Midpoint, 4000);
  const double trap = energy_drift(*s, Integrator::Trapezoidal, 4000);
  std::printf("largest relative energy change over 4000 steps at 5 ms: midpoint %.2e, trapezoidal %.2e\n", mid,
              trap);
  EXPECT_LT(mid, 2e-5);
  EXPECT_GT(trap, 100 * mid);
  // with a tight tolerance the balance is exact to round-off over a few hundred steps
  s->newton_tol = 1e-13;
  s->newton_iterations = 50;
  EXPECT_LT(energy_drift(*s, Integrator::Midpoint, 300), 1e-10);
}

// With the rod's Kelvin-Voigt damping the energy can only decrease (the correction balances the
// energy against the work of the non-conservative forces at the midpoint): every step, to the
// tolerance.
TEST(Newton, MidpointRuleDissipatesWithDamping) {
  auto s = load_scene_string(undamped_cantilever(1e7, 2e3), kPath);
  s->newton_tol = 1e-12;
  s->newton_iterations = 50;
  SceneData sd(*s);
  forward(*s, sd);
  const double e0 = energy(*s, sd).total();
  double prev = e0;
  for (int k = 0; k < 400; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
    forward(*s, sd);
    const double e = energy(*s, sd).total();
    EXPECT_LE(e, prev + 1e-12 * std::abs(e0)) << "step " << k;
    prev = e;
  }
  EXPECT_LT(prev, e0 - 1e-3 * std::abs(e0));  // the damping did dissipate
}

// Scene::newton_refresh under the midpoint rule (no constraint rows): a rod (6 `sr` sections, a 2 g
// tip, no gravity) released bent and twisted at once whips at strain rates of 500 1/s; with its
// start matrix the midpoint rule's corrections fail on most 1 ms steps and split them (outside
// probe AP: 838 split steps in 500); taken again at the first midpoint state they converge at the
// full step. Both keep the energy; after 0.1 s the refreshed run's tip is 2e-4 m from RK4's at
// 0.05 ms (the split run, on smaller steps, 8e-5 m), the midpoint rule's error at 1 ms.
TEST(Newton, MidpointRuleRefreshesItsMatrixAtTheMidpoint) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 0"/><worldbody>
    <cosserat name="rod" length="0.4" sections="6" strain="sr" radius="0.008" density="1100" young="2e6" poisson="0.45">
      <body name="B" pos="0.03 0 0"><geom type="sphere" size="0.03" mass="0.002"/></body></cosserat></worldbody>
    </mujoco>)",
                             kPath);
  auto release = [&](SceneData& sd) {
    for (int k = 0; k < s->m->nq; k += 6) {
      sd.d->qpos[k] = 3.0;      // twist, 1/m
      sd.d->qpos[k + 2] = 6.0;  // curvature, 1/m
    }
  };
  auto tip = [&](SceneData& sd) { return Vec3(sd.d->xpos[3 * (s->m->nbody - 1)], sd.d->xpos[3 * (s->m->nbody - 1) + 1], sd.d->xpos[3 * (s->m->nbody - 1) + 2]); };
  const double T = 0.1;
  SceneData ref(*s);
  release(ref);
  s->m->opt.timestep = 5e-5;
  while (ref.d->time < T - 1e-9) ASSERT_EQ(step(*s, ref, Integrator::RK4), Status::Ok);
  forward(*s, ref);
  s->m->opt.timestep = 0.001;
  double error[2], e_drift[2];
  long splits[2];
  for (int refresh = 0; refresh < 2; ++refresh) {
    s->newton_refresh = refresh;
    SceneData sd(*s);
    release(sd);
    forward(*s, sd);
    const double e0 = energy(*s, sd).total();
    double drift = 0.0;
    while (sd.d->time < T - 1e-9) {
      ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
      forward(*s, sd);
      drift = std::max(drift, std::abs(energy(*s, sd).total() - e0) / e0);
    }
    splits[refresh] = sd.newton_stats.splits;
    e_drift[refresh] = drift;
    error[refresh] = (tip(sd) - tip(ref)).norm();
  }
  std::printf("split steps %ld -> %ld, energy drift %.1e -> %.1e, tip error %.2e -> %.2e m\n", splits[0], splits[1],
              e_drift[0], e_drift[1], error[0], error[1]);
  EXPECT_GT(splits[0], 20);
  EXPECT_EQ(splits[1], 0);
  EXPECT_LT(e_drift[1], 1e-4);
  EXPECT_LT(error[1], 1e-3);
  // adaptive substeps refresh it whatever newton_refresh says (Scene::newton_refresh), as for the
  // other schemes: the same corrections with and without it (they had taken twice as many without)
  long iterations[2];
  s->step_tol = 1e-2;
  for (int refresh = 0; refresh < 2; ++refresh) {
    s->newton_refresh = refresh;
    SceneData sd(*s);
    release(sd);
    while (sd.d->time < T - 1e-9) ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
    iterations[refresh] = sd.newton_stats.iterations;
  }
  EXPECT_EQ(iterations[0], iterations[1]);
  s->step_tol = 0.0;
  s->newton_refresh = false;
}

// MuJoCo's own bodies: an undamped double pendulum on hinge joints with springs, and a box
// tumbling freely (free joint: quaternion positions, integrated along their geodesic). Energy
// kept to round-off with a tight tolerance.
TEST(Newton, MidpointRuleKeepsTheEnergyOfRigidBodies) {
  auto pend = load_scene_string(R"(<mujoco><option timestep="0.01" gravity="0 0 -9.81"/><worldbody>
    <body><joint type="hinge" axis="0 1 0" stiffness="3" springref="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.4"/>
      <body pos="0.3 0 0"><joint type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.02" mass="0.3"/></body></body>
  </worldbody></mujoco>)",
                                kPath);
  pend->newton_tol = 1e-13;
  pend->newton_iterations = 50;
  EXPECT_LT(energy_drift(*pend, Integrator::Midpoint, 500), 1e-10);
  auto box = load_scene_string(R"(<mujoco><option timestep="0.01" gravity="0 0 0"/><worldbody>
    <body><freejoint/><geom type="box" size="0.1 0.05 0.02" mass="1"/></body>
  </worldbody><keyframe><key qvel="0.1 0 0 0.3 4 0.2"/></keyframe></mujoco>)",
                               kPath);
  box->newton_tol = 1e-13;
  box->newton_iterations = 50;
  SceneData sd(*box);
  mj_resetDataKeyframe(box->m, sd.d, 0);
  forward(*box, sd);
  const double e0 = energy(*box, sd).total();
  ASSERT_GT(e0, 0.01);
  for (int k = 0; k < 500; ++k) ASSERT_EQ(step(*box, sd, Integrator::Midpoint), Status::Ok);
  forward(*box, sd);
  EXPECT_NEAR(energy(*box, sd).total(), e0, 1e-10 * e0);
}

// Springs whose energy is not quadratic in the coordinates: a rod and a body on a ball joint with a
// spring, tied to each other and to the world by stretched spatial tendon springs, undamped, no
// gravity. Their energy is in the midpoint rule's balance (outside probe AQ; left to the midpoint
// forces, it drifted 7.2e-5 of the total over these 300 steps); with a tight tolerance it is kept to
// round-off, and the tendons and the ball spring do exchange energy with the rod.
TEST(Newton, MidpointRuleKeepsTheEnergyOfTendonAndBallSprings) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 0"/><worldbody>
    <site name="anchor" pos="0.2 0.1 0.15"/>
    <body name="B" pos="0 0.3 0"><joint type="ball" stiffness="0.5"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.2" contype="0" conaffinity="0"/>
      <site name="bs" pos="0.2 0 0"/></body>
    <cosserat name="rod" length="0.3" sections="4" strain="kl" radius="0.005" density="1000" young="1e7" poisson="0.5" contype="0" conaffinity="0"/>
  </worldbody><tendon>
    <spatial stiffness="5" springlength="0.02"><site site="rod/tip"/><site site="anchor"/></spatial>
    <spatial stiffness="2" springlength="0.05"><site site="rod/tip"/><site site="bs"/></spatial>
  </tendon></mujoco>)",
                             kPath);
  s->newton_tol = 1e-12;
  s->newton_iterations = 50;
  SceneData sd(*s);
  forward(*s, sd);
  const SceneEnergy e0 = energy(*s, sd);
  ASSERT_GT(e0.elastic, 0.1);
  double worst = 0.0, kinetic = 0.0;
  for (int k = 0; k < 300; ++k) {
    ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok) << "step " << k;
    forward(*s, sd);
    const SceneEnergy e = energy(*s, sd);
    worst = std::max(worst, std::abs(e.total() - e0.total()) / e0.total());
    kinetic = std::max(kinetic, e.kinetic);
  }
  std::printf("largest relative energy change over 300 steps at 1 ms: %.2e (kinetic energy up to %.2f of the total)\n",
              worst, kinetic / e0.total());
  EXPECT_GT(kinetic, 0.1 * e0.total());
  EXPECT_LT(worst, 1e-10);
}


// A ball joint's spring whose rotation from rest passes pi, where mj_passive's force flips: the
// step across is left to its midpoint force (outside probe AR: balanced there, a spinning free body
// carrying a rod left steps unconverged and its energy jumped 12%). A box spinning at 30 rad/s on a
// weak spring (docs/bench/repro/spin_ball.xml): every step converges, the energy is kept to
// round-off at every step but those across pi, where it changes by less than 1% of itself.
TEST(Newton, MidpointRuleStepsOverABallSpringsFlipAtPi) {
  auto s = load_scene(std::string(COSSERAT_SOURCE_DIR) + "/docs/bench/repro/spin_ball.xml");
  s->newton_tol = 1e-12;
  s->newton_iterations = 50;
  SceneData sd(*s);
  mj_resetDataKeyframe(s->m, sd.d, 0);
  forward(*s, sd);
  double e = energy(*s, sd).total();
  const double e0 = e;
  int crossings = 0;
  for (int k = 0; k < 1500; ++k) {
    const double w0 = mju_dot(sd.d->qpos, s->m->qpos_spring, 4);
    ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok) << "step " << k;
    forward(*s, sd);
    const double e1 = energy(*s, sd).total(), w1 = mju_dot(sd.d->qpos, s->m->qpos_spring, 4);
    if (w0 * w1 < 0) {
      ++crossings;
      EXPECT_LT(std::abs(e1 - e), 0.01 * e0) << "step " << k;
    } else {
      EXPECT_LT(std::abs(e1 - e), 1e-10 * e0) << "step " << k;
    }
    e = e1;
  }
  EXPECT_GT(crossings, 4);
  EXPECT_EQ(sd.newton_stats.splits, 0);
}

}  // namespace

namespace {

// A rod resting on the floor on a free hub (the stress run's contact case): the kinetic energy is
// about zero, and so is the energy defect; the correction must not chase round-off (it did:
// every step split down to h/64 without converging). Converges without splits, and stays put.
TEST(Newton, MidpointRuleRestsOnTheFloor) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="hub" pos="0 0 0.006"><freejoint/><geom type="sphere" size="0.006" mass="0.01"/>
      <cosserat name="rod" length="0.5" sections="4" strain="kl" radius="0.005" density="1000" young="1e6"
                poisson="0.5" viscosity="5"/></body></worldbody></mujoco>)",
                             kPath);
  SceneData sd(*s);
  for (int k = 0; k < 1500; ++k) ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok) << "step " << k;
  EXPECT_EQ(sd.newton_stats.splits, 0);
  EXPECT_EQ(sd.newton_stats.unconverged, 0);
  EXPECT_LT(sd.newton_stats.iterations, 6 * 1500);
  forward(*s, sd);
  EXPECT_GT(sd.d->ncon, 0);  // it lies on the floor
  const double x0 = sd.d->qpos[0];
  for (int k = 0; k < 500; ++k) ASSERT_EQ(step(*s, sd, Integrator::Midpoint), Status::Ok);
  EXPECT_LT(std::abs(sd.d->qpos[0] - x0), 1e-6);
}

}  // namespace

namespace {

// A model chooses its integrator with <custom><text name="cosserat:integrator" data="midpoint"/>
// (the command line's --integrator overrides it): the scene's default becomes the midpoint rule,
// whose steps keep the energy where the default (linearised implicit, backward Euler) loses it.
TEST(Newton, ModelChoosesTheMidpointRule) {
  std::string xml = undamped_cantilever();
  const std::string plain = xml;
  xml.replace(xml.find("<worldbody>"), 11, R"(<custom><text name="cosserat:integrator" data="midpoint"/></custom><worldbody>)");
  auto s = load_scene_string(xml, kPath);
  EXPECT_EQ(s->integrator, Integrator::Midpoint);
  EXPECT_EQ(load_scene_string(plain, kPath)->integrator, Integrator::Implicit);
  SceneData sd(*s);
  forward(*s, sd);
  const double e0 = energy(*s, sd).total();
  for (int k = 0; k < 200; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
  forward(*s, sd);
  EXPECT_NEAR(energy(*s, sd).total(), e0, 1e-5 * std::abs(e0));
  EXPECT_GT(sd.newton_stats.iterations, 0);  // stepped by the Newton scheme
}

}  // namespace

namespace {

// --newton 1 is one correction per step, kept without a convergence test: a linearly implicit step
// of the scheme. It used to split every step towards h/64 chasing a tolerance that one correction
// cannot meet (genalpha with --newton 1 on the shipped cantilever: 127 corrections and 64
// unconverged pieces per step). Now 100 steps take 100 corrections, and for each scheme the result
// is closer to the converged solution than the linearised step's (trapezoidal --newton 0).
TEST(Newton, OneCorrectionPerStepIsKept) {
  auto run = [](Integrator it, int newton, SceneData::NewtonStats* stats) {
    auto s = load_scene_string(cantilever_xml(1e7, 0.005, 4, 2e-3), kPath);
    s->newton_iterations = newton;
    s->newton_tol = 1e-12;
    SceneData sd(*s);
    for (int k = 0; k < 100; ++k) EXPECT_EQ(step(*s, sd, it), Status::Ok);
    if (stats) *stats = sd.newton_stats;
    return qpos(sd, s->m->nq);
  };
  const std::vector<double> linearised = run(Integrator::Trapezoidal, 0, nullptr);
  for (Integrator it : {Integrator::Trapezoidal, Integrator::GeneralizedAlpha, Integrator::Midpoint}) {
    SCOPED_TRACE(static_cast<int>(it));
    SceneData::NewtonStats one;
    const std::vector<double> q1 = run(it, 1, &one), converged = run(it, 50, nullptr);
    EXPECT_EQ(one.iterations, 100);
    EXPECT_EQ(one.splits, 0);
    EXPECT_EQ(one.unconverged, 0);
    const double e1 = max_abs_diff(q1, converged), e0 = max_abs_diff(linearised, converged);
    std::printf("distance to the converged step after 100 steps: one correction %.3e, linearised %.3e\n", e1, e0);
    EXPECT_LT(e1, e0);
  }
}

// The Newton matrix keeps the rods' pivots below mjMINVAL: a 6 mm section of a 1 mm wire has a
// twist inertia of 1.3e-16 kg m^4 in SI, and at h = 1e-5 s M + h^2 K / 4 stays there. Raised to
// 1e-15 (MuJoCo's rule, which its factorisation had followed) the matrix was wrong on those dofs:
// outside probe Z's twisted wire failed to converge at 6400 of 6400 steps, split each step 63 times
// and took 0.34 s a step under `midpoint`. Now one correction a step, the energy kept to round-off
// (the undamped rule keeps it exactly for this quadratic twist energy).
TEST(Newton, ThinShortSectionsConvergeInOneCorrection) {
  std::string key;
  for (int k = 0; k < 32; ++k) key += "0.1 0 0 0 ";
  auto s = load_scene_string(R"(<mujoco><option gravity="0 0 0" timestep="1e-5"/><worldbody>
    <cosserat name="c" length="0.2" sections="32" strain="kl" radius="0.001" density="1000" young="1e9" poisson="0.3"/>
    </worldbody><keyframe><key name="tw" qpos=")" + key + R"("/></keyframe></mujoco>)",
                             kPath);
  EXPECT_TRUE(s->load_warnings.empty());  // nothing can constrain it: its Jacobians stay as MuJoCo sets them
  for (const Integrator method : {Integrator::Midpoint, Integrator::Trapezoidal}) {
    SceneData sd(*s);
    mj_resetDataKeyframe(s->m, sd.d, 0);
    s->newton_iterations = 10;
    forward(*s, sd);
    const double e0 = energy(*s, sd).total();
    for (int k = 0; k < 50; ++k) ASSERT_EQ(step(*s, sd, method), Status::Ok) << k;
    forward(*s, sd);
    EXPECT_EQ(sd.newton_stats.splits, 0);
    EXPECT_EQ(sd.newton_stats.unconverged, 0);
    EXPECT_LE(sd.newton_stats.iterations, 60);
    EXPECT_NEAR(energy(*s, sd).total(), e0, 1e-9 * e0);
    EXPECT_GT(std::abs(sd.d->qvel[0]), 0.0);  // the twist did move
  }
}

// A MuJoCo error inside a Newton iterate counts as a failed correction: the step splits, as for a
// non-finite iterate (outside probe AA: with sparse Jacobians a wild iterate of three hard-pulled
// cable-driven arms under genalpha stopped MuJoCo's sparse Newton solver, "Rank-defficient
// Hessian", ending the run at its first step; with dense ones it split and ran on). Errors reach
// the step through a throwing mju_user_error handler, as the command line installs. Reference: the
// same scene with dense Jacobians, whose solver never stops there.
void throwing_mujoco_error(const char* msg) { throw std::runtime_error(msg); }

TEST(Newton, AMujocoErrorInAnIterateSplitsTheStep) {
  const std::string path = std::string(COSSERAT_SOURCE_DIR) + "/tests/mujoco/data/violent_cables_sparse.xml";
  auto sparse = load_scene(path);
  std::string xml = cosserat::testing::read_text(path);
  xml.replace(xml.find("jacobian=\"sparse\""), 17, "jacobian=\"dense\"");
  auto dense = load_scene_string(xml, path);
  ASSERT_TRUE(mj_isSparse(sparse->m));
  ASSERT_FALSE(mj_isSparse(dense->m));
  void (*previous)(const char*) = mju_user_error;
  mju_user_error = throwing_mujoco_error;
  SceneData a(*sparse), b(*dense);
  const double ctrl[5] = {1.5, 1.95, 2.4, 2.85, 3.3};
  for (SceneData* sd : {&a, &b}) std::copy(ctrl, ctrl + 5, sd->d->ctrl);
  // the first step's error: the sparse run splits it, and its first half again; the dense run,
  // which meets no error, takes the same steps (h/4, h/4, h/2)
  const double h = dense->m->opt.timestep;
  EXPECT_EQ(step(*sparse, a, Integrator::GeneralizedAlpha), Status::Ok);
  for (const double f : {0.25, 0.25, 0.5}) {
    dense->m->opt.timestep = f * h;
    EXPECT_EQ(step(*dense, b, Integrator::GeneralizedAlpha), Status::Ok) << f;
  }
  dense->m->opt.timestep = h;
  mju_user_error = previous;
  EXPECT_EQ(b.newton_stats.splits, 0);
  EXPECT_EQ(a.newton_stats.splits, 2);
  EXPECT_EQ(sparse->m->opt.timestep, h);  // h again after the half steps
  for (int i = 0; i < sparse->m->nq; ++i) EXPECT_NEAR(a.d->qpos[i], b.d->qpos[i], 1e-8) << i;
}

// The fully implicit schemes' iteration matrix holds the active constraint rows on the rods
// (add_constraint_terms). Outside probe AA: a free 1 mm wire of 32 sections of 6 mm lying on a
// floor took about 300 corrections and 15 splits per 1 ms step under trapezoidal, midpoint and
// genalpha, the contacts' dependence on the iterate outside the matrix; now about 27 and 1. The
// wire stays on the floor and its energy does not grow.
TEST(Newton, AWireLyingOnAFloorConvergesInFewCorrections) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001"/><size nconmax="800" njmax="4000"/><worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="hub" pos="0 0 0.001"><freejoint/><inertial pos="0 0 0" mass="0.0001" diaginertia="1e-10 1e-10 1e-10"/>
      <cosserat name="w" length="0.192" sections="32" strain="kl" radius="0.001" density="1100" young="1e7"
        poisson="0.45" friction="1 0.005 0.0001"/></body></worldbody></mujoco>)",
                             kPath);
  for (const Integrator method : {Integrator::Trapezoidal, Integrator::Midpoint}) {
    SCOPED_TRACE(integrator_name(method));
    SceneData sd(*s);
    s->newton_iterations = s->newton_for(method);
    forward(*s, sd);
    const double e0 = energy(*s, sd).total();
    const int steps = 10;
    for (int k = 0; k < steps; ++k) ASSERT_EQ(step(*s, sd, method), Status::Ok) << k;
    EXPECT_LT(sd.newton_stats.iterations, 60 * steps);  // was about 300 a step
    EXPECT_LT(sd.newton_stats.splits, 3 * steps);       // was about 15 a step
    forward(*s, sd);
    EXPECT_GT(sd.d->ncon, 0);
    EXPECT_LE(energy(*s, sd).total(), e0 + 1e-9);
    EXPECT_GT(sd.d->site_xpos[3 * mj_name2id(s->m, mjOBJ_SITE, "w/tip") + 2], 0.0);
  }
}

// Contact rows that tie two branches of the tree (a free box lying on the free wire above) are
// held by the Newton schemes' matrix as Woodbury rows: before, one such row made the matrix take
// none of the rows, and the wire under the box split 91 of its 20 steps in halves under
// trapezoidal (88 corrections a step), 244 under backward Euler with Newton; now none, in about 8
// corrections a step, the box tipping off the wire as under the default step. The box needs 192
// rows at its first steps, more than the room SceneData makes at first (it grows).
TEST(Newton, ContactsBetweenARodAndAFreeBodyAreHeldByTheMatrix) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001"/><size nconmax="800" njmax="4000"/><worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="hub" pos="0 0 0.001"><freejoint/><inertial pos="0 0 0" mass="0.0001" diaginertia="1e-10 1e-10 1e-10"/>
      <cosserat name="w" length="0.192" sections="32" strain="kl" radius="0.001" density="1100" young="1e7"
        poisson="0.45" friction="1 0.005 0.0001"/></body>
    <body name="box" pos="0.1 0 0.0035"><freejoint/><geom type="box" size="0.01 0.01 0.0015" density="1000"/></body>
    </worldbody></mujoco>)",
                             kPath);
  const int box = mj_name2id(s->m, mjOBJ_BODY, "box");
  const int steps = 20;
  double z_linearised = 0.0;  // the box, tipping off the wire: where the default step has it
  {
    SceneData sd(*s);
    s->newton_iterations = 0;
    for (int k = 0; k < steps; ++k) ASSERT_EQ(step(*s, sd, Integrator::Implicit), Status::Ok) << k;
    z_linearised = sd.d->xpos[3 * box + 2];
  }
  const double drop = 0.0035 - z_linearised;
  ASSERT_GT(drop, 1e-4);
  for (const Integrator method : {Integrator::Trapezoidal, Integrator::Implicit}) {
    SCOPED_TRACE(integrator_name(method));
    SceneData sd(*s);
    s->newton_iterations = 10;
    forward(*s, sd);
    const double e0 = energy(*s, sd).total();
    for (int k = 0; k < steps; ++k) ASSERT_EQ(step(*s, sd, method), Status::Ok) << k;
    EXPECT_EQ(sd.newton_stats.splits, 0);
    EXPECT_LT(sd.newton_stats.iterations, 10 * steps);
    forward(*s, sd);
    EXPECT_LE(energy(*s, sd).total(), e0 + 1e-9);
    EXPECT_NEAR(sd.d->xpos[3 * box + 2], z_linearised, 0.1 * drop);
  }
}

}  // namespace
