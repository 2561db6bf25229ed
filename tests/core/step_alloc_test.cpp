// step() must not touch the heap once Data is constructed (model.hpp: "sized once by the
// constructor (no allocation when stepping)").
//
// Two independent nets:
//  1. Eigen's own guard. The core is compiled with EIGEN_RUNTIME_NO_MALLOC, so with
//     Eigen::internal::set_is_malloc_allowed(false) an Eigen heap allocation fails an eigen_assert
//     and aborts. An abort cannot be caught in-process, so the guarded loop runs in a GoogleTest
//     death test that must exit with code 0. NOTE: eigen_assert is compiled out under NDEBUG,
//     i.e. in the default Release build of plugin/core this guard is inert; it only bites in
//     Debug (or RelWithAssert) builds. Net 2 does not depend on it.
//  2. Counting allocators in this executable: the global operator new/delete family is
//     replaced, and (glibc only) malloc/calloc/realloc/memalign/posix_memalign/aligned_alloc are
//     interposed, forwarding to glibc's __libc_* entry points. Eigen allocates with std::malloc,
//     so this catches Eigen temporaries in any build type, as well as std::vector/std::string.
//     Counters are thread-local and armed only around the guarded steps; the first allocation
//     while armed records a backtrace (execinfo), printed after disarming.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "integrators.hpp"
#include "support/test_models.hpp"

#include "support/alloc_probe.hpp"

using namespace cosserat;
using namespace cosserat::testing;

namespace {

constexpr Integrator kAll[] = {Integrator::Euler, Integrator::Implicit, Integrator::RK4, Integrator::Rosenbrock};

const char* name_of(Integrator it) {
  switch (it) {
    case Integrator::Euler: return "Euler";
    case Integrator::Implicit: return "Implicit";
    case Integrator::RK4: return "RK4";
    case Integrator::Rosenbrock: return "Rosenbrock";
    default: break;
  }
  return "?";
}

// The soft-rigid tree of tests/support (joints, bodies, PCS and GVS rods, a cable and a motor),
// in a generic state so that every branch of the step runs (nonzero cable tension: the cable
// integral is skipped at zero tension).
struct Fixture {
  Model m = hybrid_tree();
  Data d{m};
  Fixture() {
    for (int i = 0; i < m.nv; ++i) {
      d.q(i) = 0.05 * std::sin(1.3 * i);
      d.v(i) = 0.1 * std::cos(0.7 * i);
    }
  }
  void set_ctrl(int n) {
    d.ctrl(0) = 0.5 + 0.1 * std::sin(0.1 * n);  // cable tension
    d.ctrl(1) = 0.01 * std::cos(0.1 * n);       // motor torque
  }
};

constexpr double kH = 1e-4;
constexpr int kSteps = 20;

// Runs kSteps guarded steps; returns the number of malloc-family calls (and operator new calls
// through *news) made during them.
long guarded_steps(Fixture& f, Integrator it, long* news, bool eigen_guard) {
  f.set_ctrl(0);
  EXPECT_EQ(step(f.m, f.d, kH, it), Status::Ok);  // warm-up, outside the guard
  if (eigen_guard) Eigen::internal::set_is_malloc_allowed(false);
  alloc_probe::arm();
  for (int n = 1; n <= kSteps; ++n) {
    f.set_ctrl(n);
    if (step(f.m, f.d, kH, it) != Status::Ok) break;
  }
  alloc_probe::disarm();
  if (eigen_guard) Eigen::internal::set_is_malloc_allowed(true);
  *news = alloc_probe::g_new_calls;
  return alloc_probe::g_malloc_calls;
}

// The counters themselves work (otherwise a zero count below would prove nothing).
TEST(StepAlloc, ProbeCountsAllocations) {
  alloc_probe::arm();
  int* p = new int(3);
  void* q = std::malloc(64);
  Eigen::VectorXd v(100);  // Eigen heap storage
  alloc_probe::disarm();
  delete p;
  std::free(q);
  EXPECT_GE(alloc_probe::g_new_calls, 1);
#if ALLOC_PROBE_MALLOC
  EXPECT_GE(alloc_probe::g_malloc_calls, 3);  // new, malloc, Eigen
#endif
  EXPECT_EQ(v.size(), 100);
}

// Net 2 in-process, per integrator.
TEST(StepAlloc, NoHeapAllocationInStep) {
  for (Integrator it : kAll) {
    Fixture f;
    long news = 0;
    const long mallocs = guarded_steps(f, it, &news, /*eigen_guard=*/false);
    EXPECT_EQ(f.d.status, Status::Ok) << name_of(it);
    EXPECT_EQ(news, 0) << name_of(it) << ": operator new called during " << kSteps << " steps";
    EXPECT_EQ(mallocs, 0) << name_of(it) << ": heap allocations during " << kSteps << " steps";
    if (mallocs > 0 || news > 0) {
      std::fprintf(stderr, "%s: %ld heap allocations in %d steps (%.1f per step)\n", name_of(it), mallocs,
                   kSteps, static_cast<double>(mallocs) / kSteps);
      alloc_probe::print_first_allocation();
    }
  }
}

// Nets 1 and 2 together in a child process: exit code 0 only if neither Eigen's guard aborted
// nor the counters saw an allocation (exit 1) nor the step diverged (exit 2).
TEST(StepAllocDeathTest, NoEigenAllocationInStep) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  for (Integrator it : kAll) {
    EXPECT_EXIT(
        {
          Fixture f;
          long news = 0;
          const long mallocs = guarded_steps(f, it, &news, /*eigen_guard=*/true);
          if (mallocs > 0 || news > 0) {
            alloc_probe::print_first_allocation();
            std::exit(1);
          }
          std::exit(f.d.status == Status::Ok ? 0 : 2);
        },
        ::testing::ExitedWithCode(0), "")
        << name_of(it);
  }
}

}  // namespace
