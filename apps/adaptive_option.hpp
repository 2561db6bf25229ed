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
// that they do not apply a model's own <custom> tolerance rather than dropping it silently.
inline void apply_step_tol(mj::Scene& scene, Integrator method, std::optional<double> flag) {
  if (flag) {
    if (!mj::takes_substeps(method))
      fail(std::string("--step-tol: adaptive substeps are for implicit, trapezoidal, genalpha and midpoint, not ") +
           integrator_name(method));
    scene.step_tol = *flag;
  } else if (scene.step_tol > 0 && !mj::takes_substeps(method)) {
    std::fprintf(stderr, "warning: the model's cosserat:step_tol (adaptive substeps) does not apply to %s: fixed steps\n",
                 integrator_name(method));
  }
}

}  // namespace cosserat::cli
