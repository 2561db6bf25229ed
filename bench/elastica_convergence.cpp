// Convergence of the static cantilever (self-weight + tip load, large deflection) against the
// independent elastica reference of tests/support/elastica.hpp. Same problem as
// tests/core/statics_test.cpp (Cantilever.*).
//
// Usage: elastica_convergence [--quick] [--quadrature N] [--substeps K]
//   --quick: a few rows only (CI smoke run).
//   --substeps: Magnus steps between GVS quadrature points (default 1).
//   quadrature: mass quadrature points per GVS section (0, the default: order + 2). The model puts
//   one 4th-order Magnus step per quadrature point, so this also sets the kinematic resolution.
//
// Columns: discretisation, dofs, |tip - elastica| [m], observed order (PCS: log2 of the error ratio
// between successive section doublings), Newton iterations, and the wall time of equilibrium()
// (best of several repetitions).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>
#include <cstdlib>

#include "kinematics.hpp"
#include "model.hpp"
#include "statics.hpp"
#include "support/elastica.hpp"

using namespace cosserat;

namespace {

constexpr double kPi = 3.14159265358979323846;
// L = 0.5 m, r = 5 mm, E = 100 MPa, rho = 1000 kg/m^3, g = 9.81, tip load P = 0.15 N:
// w L^3/EI = 1.96, P L^2/EI = 0.76, tip drop ~0.42 L.
constexpr double L = 0.5, R = 0.005, E = 1e8, RHO = 1000.0, P = 0.15, G = 9.81;

struct Result {
  int nv = 0, iterations = 0;
  double err = 0.0, seconds = 0.0;
  bool converged = false;
};

Result run(int sections, int order, int quadrature, int substeps, const elastica::Solution& ref) {
  Model m;
  m.gravity = Vec3(0, 0, -G);
  RodSpec s;
  s.name = "cantilever";
  s.length = L;
  s.radius_base = R;
  s.sections = sections;
  s.section.dofs = *strain_mask_from_name("ikl");
  s.section.order = order;
  s.section.quadrature = order > 0 ? quadrature : 0;
  s.section.substeps = substeps;
  s.section.material.density = RHO;
  s.section.material.young = E;
  const int rod = m.add_rod(-1, SE3::Identity(), s);
  m.finalize();
  Result out;
  out.nv = m.nv;
  out.seconds = 1e300;
  // repeat until at least 0.2 s has been spent (at most 50 times) and keep the fastest solve
  double spent = 0.0;
  for (int rep = 0; rep < 50 && (rep < 3 || spent < 0.2); ++rep) {
    Data d(m);
    d.f_ext_world[m.rods[rod].tip_node] << 0, 0, 0, 0, 0, -P;
    const auto t0 = std::chrono::steady_clock::now();
    const StaticsResult res = equilibrium(m, d);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    spent += t;
    out.seconds = std::min(out.seconds, t);
    out.converged = res.converged;
    out.iterations = res.iterations;
    fwd_position(m, d);
    const Vec3 tip = d.g[m.rods[rod].tip_node].u;
    out.err = Vec3(tip.x() - ref.x, tip.y(), tip.z() - ref.z).norm();
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int quadrature = 0, substeps = 1;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") quick = true;
    else if (a == "--quadrature" && i + 1 < argc) quadrature = std::atoi(argv[++i]);
    else if (a == "--substeps" && i + 1 < argc) substeps = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: elastica_convergence [--quick] [--quadrature N] [--substeps K]\n");
      return 1;
    }
  }
  if (quadrature < 0 || substeps < 1) {
    std::fprintf(stderr, "elastica_convergence: --quadrature must be >= 0 and --substeps >= 1\n");
    return 1;
  }
  elastica::Cantilever c;
  c.L = L;
  c.EI = E * kPi * R * R * R * R / 4.0;
  c.w = RHO * kPi * R * R * G;
  c.P = P;
  const auto t0 = std::chrono::steady_clock::now();
  const elastica::Solution ref = elastica::solve(c);
  const double t_ref = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("Cantilever L = %g m, r = %g m, E = %g Pa, rho = %g kg/m^3, P = %g N, g = %g m/s^2\n", L, R, E, RHO,
              P, G);
  std::printf("EI = %.6g N m^2, w = %.6g N/m, wL^3/EI = %.4f, PL^2/EI = %.4f\n", c.EI, c.w, c.w * L * L * L / c.EI,
              P * L * L / c.EI);
  std::printf("elastica tip: x = %.12f m, z = %.12f m (drop %.3f L; linear theory %.3f L), %d Newton its, %.3f s\n\n",
              ref.x, ref.z, -ref.z / L, -elastica::linear_tip(c) / L, ref.newton_iterations, t_ref);

  std::printf("%-22s %5s  %11s  %6s  %4s  %11s\n", "discretisation", "dofs", "tip error", "order", "its",
              "solve time");
  double prev = 0.0;
  const std::vector<int> pcs = quick ? std::vector<int>{1, 2, 4} : std::vector<int>{1, 2, 4, 8, 16, 32, 64};
  for (int n : pcs) {
    const Result r = run(n, 0, 0, 1, ref);
    char name[64], order[16] = "     -";
    std::snprintf(name, sizeof name, "PCS %d section%s", n, n > 1 ? "s" : "");
    if (prev > 0) std::snprintf(order, sizeof order, "%6.2f", std::log2(prev / r.err));
    std::printf("%-22s %5d  %11.4e  %6s  %4d  %9.3f ms%s\n", name, r.nv, r.err, order, r.iterations, 1e3 * r.seconds,
                r.converged ? "" : "  (NOT CONVERGED)");
    prev = r.err;
  }
  for (int ns : {1, 2}) {
    if (quick && ns > 1) break;
    std::printf("\n");
    for (int k = 1; k <= (quick ? 2 : 6); ++k) {
      const Result r = run(ns, k, quadrature, substeps, ref);
      char name[64];
      std::snprintf(name, sizeof name, "GVS %d sec, order %d", ns, k);
      std::printf("%-22s %5d  %11.4e  %6s  %4d  %9.3f ms%s\n", name, r.nv, r.err, "     -", r.iterations,
                  1e3 * r.seconds, r.converged ? "" : "  (NOT CONVERGED)");
    }
  }
  std::printf("\nGVS quadrature points per section: %s; Magnus steps per quadrature interval: %d\n",
              quadrature > 0 ? std::to_string(quadrature).c_str() : "order + 2 (default)", substeps);
  return 0;
}
