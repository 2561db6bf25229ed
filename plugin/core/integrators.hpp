// Time integration.
//  - Euler: semi-implicit Euler with the damping D treated implicitly (MuJoCo's mj_Euler):
//      (M + h D) v+ = M v + h (tau_act - bias - K (q - q_ref)),  q+ = q + h v+.
//  - Implicit: stiffness and damping both implicit (stable at millisecond steps for stiff rods):
//      (M + h D + h^2 K) v+ = M v + h (tau_act - bias - K (q - q_ref)),  q+ = q + h v+.
//  - Trapezoidal: the same linearisation with the trapezoidal rule (theta = 1/2):
//      (M + h/2 D + h^2/4 K) dv = h M a - h^2/2 K v,  q+ = q + h (v + dv/2),  v+ = v + dv,
//    a the explicit acceleration at (q, v). No numerical damping of the linear modes (Implicit's
//    backward Euler damps them: an undamped rod in its linear regime keeps its energy to 1e-6
//    where Implicit loses 40% at the same step). Second order on the linear elastic and damping
//    part only: gravity, Coriolis and geometric stiffness are explicit, so the method is first
//    order overall (a W-method). A-stable; stiff modes are not damped (Implicit damps them).
//  - RK4: classic 4th-order Runge-Kutta on (q, v).
//  - GeneralizedAlpha and Midpoint (the energy-conserving implicit midpoint rule): the MuJoCo
//    scene's only (mj::step, scene.hpp; step() here throws std::invalid_argument). The scene also solves Implicit and Trapezoidal fully implicitly by
//    Newton iterations (Scene::newton_iterations; Trapezoidal does by default): this core step is
//    always the linearised one above.
// A step that produces non-finite values restores the previous state and returns Diverged.
#pragma once

#include <optional>
#include <string_view>

#include "model.hpp"

namespace cosserat {

enum class Integrator { Euler, Implicit, RK4, Trapezoidal, GeneralizedAlpha, Midpoint };
std::optional<Integrator> integrator_from_name(std::string_view name);
// The name integrator_from_name takes for `method`.
const char* integrator_name(Integrator method);
// The names integrator_from_name knows, for messages.
constexpr const char* kIntegratorNames = "euler, implicit, trapezoidal, genalpha, midpoint, rk4";

Status step(const Model& m, Data& d, double h, Integrator method = Integrator::Implicit);

}  // namespace cosserat
