// Time integration.
//  - Euler: semi-implicit Euler with the damping D treated implicitly (MuJoCo's mj_Euler):
//      (M + h D) v+ = M v + h (tau_act - bias - K (q - q_ref)),  q+ = q + h v+.
//  - Implicit: stiffness and damping both implicit (stable at millisecond steps for stiff rods):
//      (M + h D + h^2 K) v+ = M v + h (tau_act - bias - K (q - q_ref)),  q+ = q + h v+.
//  - RK4: classic 4th-order Runge-Kutta on (q, v).
// A step that produces non-finite values restores the previous state and returns Diverged.
#pragma once

#include <optional>
#include <string_view>

#include "model.hpp"

namespace cosserat {

enum class Integrator { Euler, Implicit, RK4 };
std::optional<Integrator> integrator_from_name(std::string_view name);

Status step(const Model& m, Data& d, double h, Integrator method = Integrator::Implicit);

}  // namespace cosserat
