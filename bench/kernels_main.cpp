// Google Benchmark micro-benchmarks of the solver kernels, so that regressions show:
// SE(3) exponential, tangent operator (dexp) and its derivative, the section Jacobian (with and
// without its time derivative), rod poses, mass-matrix assembly (composite rigid body), recursive
// Newton-Euler, the kinematics passes and whole core steps, for PCS and GVS rods.
// Usage: bench_kernels [Google Benchmark flags, e.g. --benchmark_min_time=0.05
//        --benchmark_format=json --benchmark_out=FILE]
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <tuple>

#include "dynamics.hpp"
#include "integrators.hpp"
#include "kinematics.hpp"
#include "lie.hpp"
#include "model.hpp"
#include "support/test_models.hpp"

using namespace cosserat;

namespace {

Vec6 twist(double theta) {
  Vec6 x;
  x << 0.3, -0.5, 0.81, 1.0, 0.1, -0.05;
  x.head<3>() *= theta / x.head<3>().norm();
  return x;
}

// theta = |angular part|: 1e-6 (series branches), 1 (closed forms), 20 (several turns)
void BM_exp_se3(benchmark::State& st) {
  const Vec6 x = twist(st.range(0) * 1e-3);
  for (auto _ : st) benchmark::DoNotOptimize(exp_se3(x));
}
BENCHMARK(BM_exp_se3)->Arg(0)->Arg(1)->Arg(1000)->Arg(20000);

void BM_dexp(benchmark::State& st) {
  const Vec6 x = twist(st.range(0) * 1e-3);
  for (auto _ : st) benchmark::DoNotOptimize(dexp(x));
}
BENCHMARK(BM_dexp)->Arg(1)->Arg(1000)->Arg(20000);

void BM_ddexp(benchmark::State& st) {
  const Vec6 x = twist(st.range(0) * 1e-3), d = twist(0.7);
  for (auto _ : st) benchmark::DoNotOptimize(ddexp(x, d));
}
BENCHMARK(BM_ddexp)->Arg(1)->Arg(1000);

void BM_Ad_inv_apply(benchmark::State& st) {
  const SE3 g = exp_se3(twist(1.0));
  const Vec6 e = twist(0.3);
  for (auto _ : st) benchmark::DoNotOptimize(Ad_inv_apply(g, e));
}
BENCHMARK(BM_Ad_inv_apply);

// A clamped rod: PCS with n sections (order 0) or GVS (2 sections of order n), kl strain; PCS
// with the default 2 Gauss mass points per section or the Gauss-Lobatto rule (lobatto = 1).
struct Rod {
  Model m;
  std::unique_ptr<Data> d;
  Rod(int sections, int order, bool lobatto = false, const char* strain = "kl") {
    RodSpec s = testing::rod_spec(strain, sections, order, 0.5, 0.01);
    s.section.lobatto = lobatto;
    m.add_rod(-1, SE3::Identity(), s);
    m.finalize();
    d = std::make_unique<Data>(m);
    for (int i = 0; i < m.nv; ++i) d->q(i) = 0.3 * std::sin(1.0 + i), d->v(i) = 0.2 * std::cos(2.0 + i);
    fwd_position(m, *d);
    fwd_velocity(m, *d);
  }
};

void rod_args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"sections", "order", "lobatto"});
  for (auto [s, o, l] : {std::tuple{1, 0, 0}, {8, 0, 0}, {8, 0, 1}, {32, 0, 0}, {32, 0, 1}, {2, 2, 0}, {2, 4, 0}})
    b->Args({s, o, l});
}

void BM_section_jacobian(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  Mat6X J(6, r.m.max_ndof);
  const Section& sec = r.m.sections.back();
  for (auto _ : st) section_jacobian(r.m, *r.d, 0, sec.X0 + sec.length, J);
}
BENCHMARK(BM_section_jacobian)->Apply(rod_args);

void BM_section_jacobian_dot(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  Mat6X J(6, r.m.max_ndof), Jd(6, r.m.max_ndof);
  const Section& sec = r.m.sections.back();
  for (auto _ : st) section_jacobian(r.m, *r.d, 0, sec.X0 + sec.length, J, &Jd);
}
BENCHMARK(BM_section_jacobian_dot)->Apply(rod_args);

void BM_rod_pose(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  const double X = 0.37 * r.m.rods[0].length;
  for (auto _ : st) benchmark::DoNotOptimize(rod_pose(r.m, *r.d, 0, X));
}
BENCHMARK(BM_rod_pose)->Apply(rod_args);

// a cable's path point at 0.37 L: its pose and its section Jacobian, in one pass
// (BM_rod_pose_and_jacobian) or as rod_pose and section_jacobian (BM_rod_pose_then_section_jacobian)
struct PathPoint {
  Rod r;
  double X;
  int section;
  Mat6X J;
  SE3 g;
  explicit PathPoint(const benchmark::State& st)
      : r(st.range(0), st.range(1), st.range(2)), X(0.37 * r.m.rods[0].length),
        section(r.m.nodes[r.m.rod_node_at(0, X)].section), J(6, r.m.max_ndof) {}
};

void BM_rod_pose_and_jacobian(benchmark::State& st) {
  PathPoint p(st);
  for (auto _ : st) benchmark::DoNotOptimize(rod_pose_and_jacobian(p.r.m, *p.r.d, 0, p.X, p.section, p.J, &p.g));
}
BENCHMARK(BM_rod_pose_and_jacobian)->Apply(rod_args);

void BM_rod_pose_then_section_jacobian(benchmark::State& st) {
  PathPoint p(st);
  for (auto _ : st) {
    benchmark::DoNotOptimize(rod_pose(p.r.m, *p.r.d, 0, p.X));
    section_jacobian(p.r.m, *p.r.d, 0, p.X, p.J, nullptr, &p.g, p.section);
  }
}
BENCHMARK(BM_rod_pose_then_section_jacobian)->Apply(rod_args);

void BM_fwd_position(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  for (auto _ : st) fwd_position(r.m, *r.d);
}
BENCHMARK(BM_fwd_position)->Apply(rod_args);

void BM_fwd_velocity(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  for (auto _ : st) fwd_velocity(r.m, *r.d);
}
BENCHMARK(BM_fwd_velocity)->Apply(rod_args);

void BM_mass_matrix_crba(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  for (auto _ : st) crba(r.m, *r.d);
  st.counters["nv"] = r.m.nv;
}
BENCHMARK(BM_mass_matrix_crba)->Apply(rod_args);

void BM_rnea(benchmark::State& st) {
  Rod r(st.range(0), st.range(1), st.range(2));
  VecX a = VecX::Zero(r.m.nv), tau(r.m.nv);
  for (auto _ : st) rnea(r.m, *r.d, a, true, true, tau);
}
BENCHMARK(BM_rnea)->Apply(rod_args);

void BM_step(benchmark::State& st) {
  Rod r(st.range(0), st.range(1));
  const Integrator I = static_cast<Integrator>(st.range(2));
  const Data saved = *r.d;
  for (auto _ : st) {
    step(r.m, *r.d, 1e-5, I);
    st.PauseTiming();
    r.d->q = saved.q;
    r.d->v = saved.v;
    st.ResumeTiming();
  }
  st.counters["nv"] = r.m.nv;
}
BENCHMARK(BM_step)
    ->ArgNames({"sections", "order", "integrator"})
    ->Args({8, 0, static_cast<int>(Integrator::Euler)})
    ->Args({8, 0, static_cast<int>(Integrator::Implicit)})
    ->Args({8, 0, static_cast<int>(Integrator::RK4)})
    ->Args({2, 2, static_cast<int>(Integrator::Implicit)});

}  // namespace

BENCHMARK_MAIN();
