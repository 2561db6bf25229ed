// Heap allocations in a step (forty-fourth session): malloc counted around each of 5 steps of a
// model from its first keyframe. Build as first_step.cpp (without S/bench and the bench library),
// adding -ldl. usage: step_allocations MODEL.xml [implicit|trapezoidal|midpoint|rk4|rosenbrock|euler|genalpha]
#include <cstdio>
#include <cstdlib>
#include <string>

#include <mujoco/mujoco.h>

#include "scene.hpp"

using namespace cosserat;

static long g_mallocs = 0;
static bool g_counting = false;
extern "C" void* __libc_malloc(size_t);
extern "C" void* malloc(size_t n) {
  if (g_counting) ++g_mallocs;
  return __libc_malloc(n);
}

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: step_allocations MODEL.xml [INTEGRATOR]\n");
    return 2;
  }
  auto s = mj::load_scene(argv[1]);
  const std::string n = argc > 2 ? argv[2] : "implicit";
  Integrator in = Integrator::Implicit;
  if (n == "trapezoidal") in = Integrator::Trapezoidal;
  if (n == "midpoint") in = Integrator::Midpoint;
  if (n == "genalpha") in = Integrator::GeneralizedAlpha;
  if (n == "rk4") in = Integrator::RK4;
  if (n == "rosenbrock") in = Integrator::Rosenbrock;
  if (n == "euler") in = Integrator::Euler;
  mj::SceneData sd(*s);
  mj::reset(*s, sd);
  if (s->m->nkey > 0) mj_resetDataKeyframe(s->m, sd.d, 0);
  for (int k = 0; k < 5; ++k) {
    g_mallocs = 0;
    g_counting = true;
    const Status st = mj::step(*s, sd, in);
    g_counting = false;
    std::printf("step %d: %ld allocations%s\n", k, g_mallocs, st == Status::Ok ? "" : " (the step diverged)");
  }
}
