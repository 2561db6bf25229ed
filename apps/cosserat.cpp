// The `cosserat` command-line tool. Until the MuJoCo coupling lands (issue 3) it offers the
// core-only `demo`: a tapered soft arm clamped horizontally, released under gravity, lifted by a
// cable whose tension ramps up; prints the static equilibrium, natural frequencies and the motion.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <algorithm>
#include <chrono>
#include <unistd.h>

#include "dynamics.hpp"
#include "integrators.hpp"
#include "kinematics.hpp"
#include "linearize.hpp"
#include "statics.hpp"

using namespace cosserat;

namespace {

const char* kUsage =
    "usage: cosserat demo [--duration T] [--timestep h] [--integrator implicit|euler|rk4]\n"
    "                     [--sections N] [--order P] [--tension T] [--out DIR]\n"
    "  demo   core-only simulation of a tapered soft arm (no MuJoCo yet): writes DIR/demo.csv\n"
    "         with time,energy,tip.x,tip.y,tip.z,tension and prints a summary.\n";

[[noreturn]] void fail(const std::string& msg) {
  std::cerr << "cosserat: " << msg << "\n";
  std::exit(1);
}

double parse_double(const std::string& flag, const char* s) {
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  if (end == s || *end) fail(flag + ": '" + s + "' is not a number");
  return v;
}

struct DemoOptions {
  double duration = 2.0, timestep = 1e-3, tension = 1.5;
  int sections = 6, order = 0;
  Integrator integrator = Integrator::Implicit;
  std::string out = "out/demo";
};

Model demo_model(const DemoOptions& o) {
  Model m;
  RodSpec s;
  s.name = "arm";
  s.length = 0.4;
  s.radius_base = 0.012;
  s.radius_tip = 0.005;
  s.sections = o.sections;
  s.section.dofs = *strain_mask_from_name("sr");
  s.section.order = o.order;
  s.section.material = RodMaterial{1080.0, 5e5, 0.45, 2.0};  // silicone: density, E, nu, mu
  const int rod = m.add_rod(-1, SE3::Identity(), s);
  m.add_body(m.rods[rod].tip_node, 0.01, Vec3::Zero(), 1e-7 * Mat3::Identity());  // 10 g tip mass
  Cable c;  // a cable 8 mm above the centreline at the base, 3 mm at the tip
  c.rod = rod;
  c.d_begin = Vec3(0, 0, 0.008);
  c.d_end = Vec3(0, 0, 0.003);
  m.add_cable(c, "cable");
  m.finalize();
  return m;
}

int demo(const DemoOptions& o) {
  const Model m = demo_model(o);
  Data d(m);
  const int tip = m.rods[0].tip_node;
  std::printf("demo: tapered silicone arm, L = 0.4 m, %d sections, order %d, %d dofs\n", o.sections, o.order, m.nv);

  // static equilibrium under gravity alone, and the natural frequencies there
  Data ds(m);
  const StaticsResult st = equilibrium(m, ds);
  fwd_position(m, ds);
  std::printf("equilibrium under gravity: %s after %d Newton iterations (residual %.1e), tip at (%.4f, %.4f, %.4f) m\n",
              st.converged ? "converged" : "NOT converged", st.iterations, st.residual, ds.g[tip].u.x(),
              ds.g[tip].u.y(), ds.g[tip].u.z());
  const Linearization lin = linearize(m, ds);
  std::printf("natural frequencies there [Hz]: %.3f %.3f %.3f %.3f\n", lin.frequencies_hz(0),
              lin.frequencies_hz(1), lin.frequencies_hz(2), lin.frequencies_hz(3));

  std::filesystem::create_directories(o.out);
  const std::string csv = o.out + "/demo.csv";
  std::ofstream f(csv);
  if (!f) fail("cannot write " + csv);
  f << "time,energy,tip.x,tip.y,tip.z,tension\n";
  const int steps = static_cast<int>(o.duration / o.timestep + 0.5);
  const bool tty = isatty(STDERR_FILENO);
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k <= steps; ++k) {
    // tension: zero for the first half, then a smooth ramp to its final value
    const double s = std::clamp((d.time - 0.5 * o.duration) / (0.25 * o.duration), 0.0, 1.0);
    d.ctrl(0) = o.tension * s * s * (3 - 2 * s);
    if (k > 0 && step(m, d, o.timestep, o.integrator) != Status::Ok)
      fail("simulation diverged at t = " + std::to_string(d.time) + " s (try a smaller --timestep)");
    fwd_position(m, d);
    fwd_velocity(m, d);
    const Vec3 p = d.g[tip].u;
    f << d.time << "," << energy(m, d).total() << "," << p.x() << "," << p.y() << "," << p.z() << ","
      << d.ctrl(0) << "\n";
    if (tty && (k % 100 == 0 || k == steps))
      std::fprintf(stderr, "\r  step %d/%d  t = %.3f s", k, steps, d.time);
  }
  if (tty) std::fprintf(stderr, "\n");
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Vec3 p = d.g[tip].u;
  std::printf("simulated %.2f s in %d steps (%s, h = %g s) in %.2f s wall: tip at (%.4f, %.4f, %.4f) m, cable %.2f N\n",
              o.duration, steps, o.integrator == Integrator::RK4 ? "rk4" : o.integrator == Integrator::Euler ? "euler" : "implicit",
              o.timestep, wall, p.x(), p.y(), p.z(), d.ctrl(0));
  std::printf("wrote %s\n", csv.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cout << kUsage;
    return argc < 2 ? 1 : 0;
  }
  const std::string cmd = argv[1];
  if (cmd != "demo") fail("unknown command '" + cmd + "' (the MuJoCo commands arrive with the coupling)\n" + kUsage);
  DemoOptions o;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) fail(a + " needs a value");
      return argv[++i];
    };
    if (a == "--duration") o.duration = parse_double(a, value());
    else if (a == "--timestep") o.timestep = parse_double(a, value());
    else if (a == "--tension") o.tension = parse_double(a, value());
    else if (a == "--sections") o.sections = static_cast<int>(parse_double(a, value()));
    else if (a == "--order") o.order = static_cast<int>(parse_double(a, value()));
    else if (a == "--out") o.out = value();
    else if (a == "--integrator") {
      const std::string n = value();
      auto in = integrator_from_name(n);
      if (!in) fail("--integrator: unknown '" + n + "' (euler, implicit, rk4)");
      o.integrator = *in;
    } else fail("unknown option '" + a + "'\n" + kUsage);
  }
  if (!(o.duration > 0)) fail("--duration must be positive");
  if (!(o.timestep > 0)) fail("--timestep must be positive");
  if (o.sections < 1) fail("--sections must be >= 1");
  if (o.order < 0) fail("--order must be >= 0");
  return demo(o);
}
