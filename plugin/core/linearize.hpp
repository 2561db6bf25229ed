// Linearisation about an equilibrium (q0, v = 0, u0):
//   M dqacc + D dv + Kt dq = Bu du,   x = [dq; dv],   x_dot = A x + B du,
//   A = [[0, I], [-M^-1 Kt, -M^-1 D]],   B = [[0], [M^-1 Bu]],
// with Kt the tangent stiffness (elastic + geometric stiffness of gravity, loads and actuation).
#pragma once

#include <Eigen/LU>

#include "model.hpp"

namespace cosserat {

struct Linearization {
  MatX A, B;            // state-space matrices (2 nv x 2 nv, 2 nv x nu; with activations, below,
                        // (2 nv + na) x (2 nv + na) and (2 nv + na) x nu)
  MatX M, D, Kt, Bu;    // second-order form (activations at their steady state under the controls)
  // Actuator activations (MuJoCo's act: filters, integrators, muscles), na of them, as states of
  // their own where Fa has columns: x = [dq; dv; dact], and
  //   M dqacc + (D + dD) dv + (Kt + dKt) dq = Fa dact + Bd du,
  //   dact_dot = Gq dq + Gv dv + Ga dact + Gu du,
  // Fa = d force / d act and Bd = d force / d ctrl at fixed activations, Ga, Gu the activation
  // dynamics' derivatives, and where a control law sets the controls from the state, Gq, Gv its
  // dependence through the activations' inputs and dKt, dD the dependence the second-order form
  // took through activations settled at once (empty: zero). The second-order form above keeps
  // the activations at their steady state (act = ctrl for filters and muscles): its Bu is the
  // static gain, its frequencies those of the structure.
  MatX Fa, Bd, Ga, Gu, Gq, Gv, dKt, dD;
  // At a state that is no equilibrium (forces unbalanced at rest, qacc0 != 0): d(M(q) qacc0)/dq,
  // the mass matrix's turning with the configuration times that acceleration, in A's lower-left
  // block with Kt, -M^-1 (Kt + dMa) (empty: zero, as at an equilibrium). The modes and frequencies
  // are Kt's.
  MatX dMa;
  VecX frequencies_hz;  // undamped natural frequencies, ascending (from Kt x = w^2 M x; an unstable
                        // mode, w^2 < 0, shows as 0 Hz: see omega2 and unstable_modes)
  VecX omega2;          // the eigenvalues w^2 [1/s^2], ascending, signed (real parts if Kt is unsymmetric)
  int unstable_modes = 0;  // modes with w^2 below the noise (unstable_mode), and where Kt is not
                           // symmetric (follower loads) oscillations that grow (flutter): the
                           // equilibrium is unstable
  VecX damping_ratios;  // modal damping x^T D x / (2 w x^T M x) of those modes (NaN for w = 0; where
                        // Kt is not symmetric, of the real parts of their eigenvectors)
  // Where Kt is not symmetric: the largest real part of A's complex eigenvalues [1/s] (> 0: an
  // oscillation that grows, flutter; its frequency Im / 2 pi in flutter_hz), 0 where Kt is symmetric
  double flutter_rate = 0.0, flutter_hz = 0.0;
  // of unstable_modes, those that fall away without oscillating (omega^2 < 0 where Kt is symmetric;
  // where it is not, real eigenvalues of A above the floor): listed first in omega2 where their
  // omega^2 is negative
  int diverging_modes = 0;
  MatX modes;           // their eigenvectors (columns, in the order of omega2; x^T M x = 1), in the
                        // coordinates below (real parts where Kt is not symmetric)
  // Constrained coordinates (a MuJoCo scene's equality constraints held rigid): dq = basis y, the
  // matrices above in y. Empty (and constraint_rows 0): the coordinates are dq itself.
  MatX basis;
  int constraint_rows = 0;
  // Bounds of the rounding noise of Kt's entries where Kt comes from finite differences of forces,
  // entry by entry, in the coordinates of dq (before any basis); empty: Kt is exact (up to its own
  // rounding). unstable_mode takes modes within it for neutral.
  MatX Kt_noise;
  // The part of Kt that is the stiffness of loads carried by constraint rows held rigid (a scene's
  // StaticProblem::held_loads, in the coordinates of Kt); empty: none. unstable_mode_fd weighs its
  // modelling error.
  MatX Kt_held;
  // Modes with omega^2 >= -neutral_omega2 are not counted unstable: too slow a fall to act on (a
  // MuJoCo scene under gravity sets 1e-6 g / extent, an e-folding time of 1000 sqrt(extent / g), as
  // its equilibrium's stability check does). 0: every mode below the noise counts.
  double neutral_omega2 = 0.0;
};

// Whether the mode x (an eigenvector of K x = omega^2 M x, K symmetric) shows the equilibrium
// unstable beyond the noise of a finite-difference stiffness: its Rayleigh quotient
//   rho = x'K x / x'M x  <  -1e-4 |x|'|K||x| / x'M x      (|.| entrywise).
// rho bounds the smallest eigenvalue from above whatever the eigensolver's accuracy (so rho < 0
// proves an unstable direction), and the bound on the right is the mode's own stiffness scale,
// what the rounding of K's entries can move rho by (the probe measured the two bending planes of
// a symmetric column 2e-5 of it apart). No scale relative to the largest eigenvalue enters: an
// outside probe's column at twice its buckling load had omega^2 = -6.2 1/s^2 beside axial modes
// at 1e12, which thresholds of 1e-7, 1e-9 and then 1e-15 of the largest eigenvalue (a 1 mm
// column's at 6.7e18) took for stable.
// `noise` (default 0) is a bound of x'E x for the noise E of a finite-difference K (noise_bound):
// the quotient must also lie below -noise / x'M x. (A neutral family of equilibria, outside probe
// AM's buckled zig-zag under two antagonistic cables, has modes whose own stiffness scale is 0 and
// whose quotients are the differences' rounding, 1e-10 of the forces' scale: read as unstable.)
bool unstable_mode(const VecX& x, const MatX& K, const MatX& M, double noise = 0.0);

// The same test where K comes from finite differences of forces with a bound of their rounding
// (`noise`, as above): the quotient must lie below
//   -max(noise, 1e-4 |x|'|Kh||x|, n eps |x|'|K||x|) / x'M x,
// Kh (`held`, may be null) the stiffness of the loads that constraint rows held rigid carry. The
// rows' Jacobians (MuJoCo's weld takes its rotation rows from a quaternion difference) are not the
// exact gradients of what they hold, and that stiffness is modelled to a relative 1e-4 of its own
// scale on the mode (a rod buckled between two welds past Greenhill's moment has a neutral family,
// its buckled shape turned about the axis, read at omega^2 = -9.9e-4 against a held-load scale of
// 50 and a rounding bound of 2.9e-4); the rest of K is exact to its rounding and the product's
// (n eps). Without the held term, the whole of K's scale entered as in unstable_mode, and the stiff
// stretch and shear of `kl` and `sr` rods hid an instability: the same rod twisted straight at 1.03
// times Greenhill's moment, omega^2 = -0.76, against 1e-4 |x|'|K||x| = 3.2 (`kl`) and 47 (`sr`).
bool unstable_mode_fd(const VecX& x, const MatX& K, const MatX& M, double noise, const MatX* held);

// ax' N ax: the bound of x'E x for |x| <= ax entrywise and noise |E_ij| <= N_ij (or N_ji: E's
// symmetric part is what the eigenproblems use).
double noise_bound(const VecX& ax, const MatX& N);

// Stability of an equilibrium under loads that turn with the structure (follower loads: Kt not
// symmetric), where the symmetric part of Kt decides nothing (outside probe BR: a rod bent into a
// half circle by a follower end moment, stable, has a negative one; with little damping it
// flutters, as Ziegler's column does). From the eigenvalues s of the state matrix
// [[0, I], [-M^-1 K, -M^-1 D]]: the largest real part of the complex ones (flutter, `rate` and its
// frequency |Im s| / 2 pi in `hz`) and of the real ones (divergence, returned as omega^2 = -s^2 in
// `divergence_omega2`, 0 where none is positive), each counted where it exceeds `floor`, 1e-6 |s|
// and 64 eps |A| (the eigensolver's rounding on a matrix whose stiff modes reach 1e12 1/s^2: a
// slower growth of a stiff rod's mode is not seen).
struct GrowthModes {
  double rate = 0.0, hz = 0.0;   // the fastest-growing oscillation (rate > 0: flutter)
  double divergence_omega2 = 0.0;  // < 0: the fastest monotone fall, -s^2
  int growing_pairs = 0, diverging = 0;  // how many of each
  VecX flutter_mode, divergence_mode;  // their displacements (real parts)
  bool unstable() const { return growing_pairs + diverging > 0; }
};
GrowthModes growth_modes(const MatX& A, double floor);

// The state matrix [[0, I], [-M^-1 K, -M^-1 D]] (M factorised).
MatX state_matrix(const Eigen::PartialPivLU<MatX>& M, const MatX& K, const MatX& D);

// Linearises at d.q (call equilibrium() first) and d.ctrl.
Linearization linearize(const Model& m, Data& d);

// From the second-order form (M, D, Kt, Bu) of L: A, B, natural frequencies and modal damping.
// Shared by every linearisation (the standalone core's and a MuJoCo scene's).
void state_space(Linearization& L);

}  // namespace cosserat
