// Step time of a model under one integrator: the best of REPS repetitions of STEPS steps from the
// model's initial state (mj::reset between repetitions, outside the timing). Used for the A/B
// timings of docs/bench/HISTORY.md (forty-first session), two builds run alternately.
// Build against a build directory B of this repository (S: the source tree):
//   g++ -O2 -march=x86-64-v3 -std=c++17 -I S/plugin/mujoco -I S/plugin/core -I/usr/include/eigen3 \
//       step_time.cpp B/plugin/mujoco/libcosserat_mujoco.a B/plugin/core/libcosserat_core.a \
//       -lmujoco -ltinyxml2 -o step_time
// usage: step_time MODEL.xml [implicit|trapezoidal|trapezoidal-lin|rk4|euler|rosenbrock] [STEPS] [REPS]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <mujoco/mujoco.h>

#include "scene.hpp"

using namespace cosserat;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: step_time MODEL.xml [INTEGRATOR] [STEPS] [REPS]\n");
    return 2;
  }
  auto s = mj::load_scene(argv[1]);
  const std::string n = argc > 2 ? argv[2] : "rosenbrock";
  Integrator in = Integrator::Rosenbrock;
  if (n == "implicit") in = Integrator::Implicit;
  if (n == "trapezoidal") in = Integrator::Trapezoidal;
  if (n == "trapezoidal-lin") in = Integrator::Trapezoidal, s->newton_iterations = 0;
  if (n == "rk4") in = Integrator::RK4;
  if (n == "euler") in = Integrator::Euler;
  const int steps = argc > 3 ? std::atoi(argv[3]) : 100;
  const int reps = argc > 4 ? std::atoi(argv[4]) : 200;
  mj::SceneData sd(*s);
  double best = 1e300;
  for (int r = 0; r < reps; ++r) {
    mj::reset(*s, sd);
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < steps; ++i) mj::step(*s, sd, in);
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    if (us < best) best = us;
  }
  std::printf("%s: %d steps, best %.1f us, %.2f us/step\n", n.c_str(), steps, best, best / steps);
}
