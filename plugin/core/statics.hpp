// Static equilibrium under gravity, external loads and actuator inputs:
//   r(q) = K (q - q_ref) + lambda (gravity + external - actuation)(q) = 0,  lambda = 1,
// by Newton's method with a backtracking line search, falling back to load continuation in
// lambda when a full step fails. Floating bases have no equilibrium and are refused.
#pragma once

#include <string>

#include "model.hpp"

namespace cosserat {

struct StaticsOptions {
  int max_iterations = 50;      // Newton iterations per load step
  double tolerance = 1e-10;     // on |r| relative to the load scale (see StaticsResult)
  int max_load_halvings = 12;   // continuation: smallest load increment 2^-12
};

struct StaticsResult {
  bool converged = false;
  int iterations = 0;       // Newton iterations in total
  int load_steps = 0;       // continuation steps taken (1: solved directly)
  double residual = 0.0;    // |r| / scale at the end
  double scale = 0.0;       // load scale: max(|K (q - q_ref)|, |gravity + external - actuation|)
  std::string message;
};

// Solves for d.q in place (d.v is set to zero). On failure d.q holds the last converged load step.
StaticsResult equilibrium(const Model& m, Data& d, const StaticsOptions& opt = {});
// r(q) at load factor lambda into r; returns the load scale. Uses d's scratch.
double static_residual(const Model& m, Data& d, double lambda, VecX& r);
// Tangent stiffness dr/dq at lambda (central differences of the residual).
void tangent_stiffness(const Model& m, Data& d, double lambda, MatX& Kt);
// A continuation's load factor as its failure messages print it: exactly enough to evaluate the
// loads it stood at again.
std::string load_factor_text(double lambda);

}  // namespace cosserat
