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
//  - Rosenbrock: the linearly implicit Rosenbrock-W method ROS34PW2 (below) on (q, v) with the
//    Jacobian approximation W = [0 I; -M0^-1 K  -M0^-1 D] (M0 the mass matrix at the step's start):
//    4 evaluations of the dynamics and one factorisation of M0 + gamma h D + gamma^2 h^2 K per
//    step, no Newton iteration. Third order overall (W leaves gravity, Coriolis and the change of M
//    out, which a W-method allows), L-stable on the linear elastic and damping part: stiff modes
//    are damped, not resolved, as Implicit does, but the slow motion is third-order accurate.
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

enum class Integrator { Euler, Implicit, RK4, Trapezoidal, GeneralizedAlpha, Midpoint, Rosenbrock };
std::optional<Integrator> integrator_from_name(std::string_view name);
// The name integrator_from_name takes for `method`.
const char* integrator_name(Integrator method);
// The names integrator_from_name knows, for messages.
constexpr const char* kIntegratorNames = "euler, implicit, trapezoidal, genalpha, midpoint, rk4, rosenbrock";

Status step(const Model& m, Data& d, double h, Integrator method = Integrator::Implicit);

// Rang and Angermann's Rosenbrock-W method ROS34PW2 (BIT Numer. Math. 45 (2005) 761-787) in Hairer
// and Wanner's transformed form (Solving ODEs II, IV.7): for y' = F(y), with a matrix W,
//   (I / (h gamma) - W) u_i = F(y + sum_j a_ij u_j) + sum_j C_ij / h u_j   (i = 0..3),
//   y+ = y + sum_i b_i u_i,
// third order whatever W is (a W-method), L-stable when W is F's Jacobian. Time-dependent forces
// are evaluated at t + c_i h (the method on the autonomous system with W's time column zero).
// For y = (q, v), F = (v, qacc) and W = [0 I; -M0^-1 K  -M0^-1 D], eliminating u_q leaves
//   (M0 + gamma h D + gamma^2 h^2 K) u_v = h gamma (M0 r_v - h gamma K r_q),  u_q = h gamma (r_q + u_v),
// with (r_q, r_v) the stage's right-hand side F(Y_i) + sum_j C_ij / h u_j.
namespace ros34pw2 {
constexpr int kStages = 4;
constexpr double gamma = 0.435866521508459;
constexpr double a[4][3] = {{0, 0, 0}, {2.0, 0, 0}, {1.4192173174557647, -0.2592322116729697, 0},
                            {4.18476048231916, -0.28519201735549593, 2.294280360279042}};
constexpr double C[4][3] = {{0, 0, 0}, {-4.588560720558084, 0, 0}, {-4.18476048231916, 0.28519201735549593, 0},
                            {-6.368179200128359, -6.795620944466837, 2.8700986043310563}};
constexpr double b[4] = {4.1847604823191595, -0.28519201735549565, 2.2942803602790414, 1.0};
constexpr double c[4] = {0.0, 0.871733043016918, 0.7315799577888524, 1.0};
}  // namespace ros34pw2

}  // namespace cosserat
