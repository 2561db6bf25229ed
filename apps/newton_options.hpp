// The Newton iteration and genalpha options of the commands that simulate (run, compare, render,
// snapshot): --newton, --newton-tol, --newton-memory, --newton-refresh and --rho.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cli.hpp"
#include "integrators.hpp"
#include "scene.hpp"

namespace cosserat::cli {

struct NewtonOptions {
  std::optional<int> newton;
  double newton_tol = 1e-6;
  int newton_memory = 3;
  bool newton_refresh = false;
  std::optional<double> rho;
  std::vector<std::string> given;  // the Newton options the command line set (not --newton)

  // --newton, --newton-tol, --newton-memory and --newton-refresh
  void add_newton_to(CommandLine& c) {
    c.options.push_back({"--newton", "N",
                         "implicit, trapezoidal, genalpha and midpoint: up to N Newton corrections per step, making the step fully implicit "
                         "(every force, constraints included, at the end of the step); a step that does not converge is "
                         "split in halves. 1: one correction per step, without a convergence test or splitting (a "
                         "linearly implicit step). 0: one linearised solve (default: 10 for trapezoidal, genalpha and "
                         "midpoint, 0 for implicit; genalpha and midpoint always make at least 1)",
                         [this](const std::string& v) { newton = parse_int("--newton", v, 0); }});
    c.options.push_back({"--newton-tol", "TOL",
                         "tolerance of the Newton corrections: h |delta a| <= TOL (|v| + h |a|), max norms over the "
                         "dofs (default 1e-6)",
                         [this](const std::string& v) {
                           newton_tol = parse_positive("--newton-tol", v);
                           given.push_back("--newton-tol");
                         }});
    c.options.push_back({"--newton-memory", "M",
                         "Anderson acceleration of the Newton corrections from the last M corrections, 0 <= M <= 4 "
                         "(default 3; 0: plain simplified Newton with the step's frozen matrix)",
                         [this](const std::string& v) {
                           newton_memory = parse_int("--newton-memory", v, 0);
                           if (newton_memory > 4) fail("--newton-memory: " + v + " is more than 4");
                           given.push_back("--newton-memory");
                         }});
    c.options.push_back(flag_option("--newton-refresh",
                                    "trapezoidal, genalpha, implicit with --newton: factorise the Newton matrix again at "
                                    "the first iterate (fewer corrections on smooth motion; at steps where the default "
                                    "iteration fails and splits, the scheme's full step is taken instead); midpoint: at "
                                    "its first midpoint state, where no constraint row acts. Always on with --step-tol",
                                    newton_refresh));
  }

  void add_rho_to(CommandLine& c) {
    c.options.push_back({"--rho", "R",
                         "genalpha: spectral radius at infinite frequency, 0 <= R <= 1 (default 0.8; 1: no damping of "
                         "stiff modes, the trapezoidal rule; 0: the most damping)",
                         [this](const std::string& v) {
                           rho = parse_number("--rho", v);
                           if (!(*rho >= 0.0 && *rho <= 1.0)) fail("--rho: " + v + " is not in [0, 1]");
                         }});
  }

  // Into the scene for a run with `method`: --newton with a method that has no Newton iteration
  // (euler, rk4, rosenbrock), --newton-tol, --newton-memory or --newton-refresh with a step that does not
  // iterate (those, and implicit without --newton), or --rho with any but genalpha, is refused
  // (they had been accepted and ignored).
  void apply(mj::Scene& s, Integrator method) const {
    const bool explicit_or_rosenbrock =
        method == Integrator::Euler || method == Integrator::RK4 || method == Integrator::Rosenbrock;
    if (newton && explicit_or_rosenbrock)
      fail(std::string("--newton: Newton corrections are for implicit, trapezoidal, genalpha and midpoint, not ") +
           integrator_name(method));
    // the Newton iteration's own settings, where the step has none (the linearised implicit step)
    const int iterations = newton ? *newton : s.newton_for(method);
    const bool iterates = !explicit_or_rosenbrock && (method != Integrator::Implicit || iterations > 0);
    const std::string first = !given.empty() ? given.front() : newton_refresh ? "--newton-refresh" : "";
    if (!first.empty() && !iterates)
      fail(first + ": the " + integrator_name(method) + " step" +
           (method == Integrator::Implicit ? " without --newton has no Newton iteration (--newton N makes one)"
                                           : " has no Newton iteration"));
    if (rho && method != Integrator::GeneralizedAlpha)
      fail(std::string("--rho: the spectral radius at infinite frequency is genalpha's, not ") + integrator_name(method) +
           "'s");
    if (newton) s.newton_iterations = *newton;
    s.newton_tol = newton_tol;
    s.newton_memory = newton_memory;
    s.newton_refresh = newton_refresh;
    if (rho) s.rho_inf = *rho;
  }
};

}  // namespace cosserat::cli
