// Step times right after a model's load, and again after resets (forty-fourth session,
// docs/bench/HISTORY.md "Warm timing in the forty-fourth session"): 8 loads, each timed for 4
// steps, then twice more from the reset state (mj::reset, or mj_resetData for a plain MuJoCo
// model). The sampling stage (positions) runs between steps as in bench_work_precision.
// Build against a build directory B of this repository (S: the source tree):
//   g++ -O2 -march=x86-64-v3 -std=c++17 -I S/plugin/mujoco -I S/plugin/core -I S/bench \
//       -I/usr/include/eigen3 first_step.cpp B/bench/libcosserat_bench_common.a \
//       B/plugin/mujoco/libcosserat_mujoco.a B/plugin/core/libcosserat_core.a -lmujoco -ltinyxml2 -o first_step
// usage: first_step MODEL.xml H implicit|trap-lin|euler [native]
//   first_step circle1.xml 0.5 implicit          (the circle's one-section rod)
//   first_step native4.xml 0.05 euler native     (bench_native_chain cantilever05.xml --segments 4
//                                                 --base-spring 2 --armature 30 --out native4.xml)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <mujoco/mujoco.h>

#include "common.hpp"

using namespace cosserat;
using namespace cosserat::bench;

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: first_step MODEL.xml H implicit|trap-lin|euler [native]\n");
    return 2;
  }
  const std::string xml = read_file(argv[1]);
  const double h = std::atof(argv[2]);
  const std::string in = argv[3];
  const Method method = in == "euler" ? Method::Euler : in == "trap-lin" ? Method::TrapezoidalLinear : Method::Implicit;
  const bool native = argc > 4;
  for (int rep = 0; rep < 8; ++rep) {
    auto sim = native ? make_mujoco_sim(xml, argv[1], method, h) : make_rod_sim(xml, argv[1], method, h);
    for (int pass = 0; pass < 3; ++pass) {
      if (pass) sim->reset();
      sim->positions();
      std::printf(pass ? " | after reset:" : "load %d:", rep);
      for (int k = 0; k < 4; ++k) {
        const auto t0 = std::chrono::steady_clock::now();
        sim->step();
        const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
        sim->positions();
        std::printf(" %.2f", us);
      }
    }
    std::printf(" us\n");
  }
}
