// --step-tol of the commands that simulate (run, compare, render, snapshot).
#pragma once

#include <cstdio>
#include <optional>
#include <string>

#include "cli.hpp"
#include "integrators.hpp"
#include "scene.hpp"

namespace cosserat::cli {

// Sets the command line's tolerance (`flag`, if given) as the scene's adaptive substep tolerance
// for a run with `method`. Methods without substeps (mj::takes_substeps) refuse the flag, and say
// that they do not apply a model's own <custom> tolerance rather than dropping it silently (a
// warning on stderr and in Scene::load_warnings, and no tolerance left in the scene).
inline void apply_step_tol(mj::Scene& scene, Integrator method, std::optional<double> flag) {
  if (flag) {
    if (!mj::takes_substeps(method))
      fail(std::string("--step-tol: adaptive substeps are for implicit, trapezoidal, genalpha and midpoint, not ") +
           integrator_name(method));
    scene.step_tol = *flag;
  } else if (scene.step_tol > 0 && !mj::takes_substeps(method)) {
    const std::string w = std::string("the model's cosserat:step_tol (adaptive substeps) does not apply to ") +
                          integrator_name(method) + ": fixed steps";
    std::fprintf(stderr, "warning: %s\n", w.c_str());
    scene.load_warnings.push_back(w);  // (already printed: the outputs' warning lists carry it)
    scene.step_tol = 0;
  }
}

}  // namespace cosserat::cli
