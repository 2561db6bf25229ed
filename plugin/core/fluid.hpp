// Low-Reynolds-number fluid: resistive force theory (RFT) for rods and slender bodies, and the
// Stokes resistance of spheres and ellipsoids. Everything here is linear in the velocity (the
// fluid is at rest, inertia of the fluid neglected), so every resistance is a symmetric positive
// semi-definite 6x6 matrix C in a body frame: the fluid's wrench on the body is -C eta
// (angular first, eta the body twist, DESIGN.md section 3).
//
// Rods: each mass quadrature node i of a rod stands for a length dX_i of filament (Node::dX) and
// carries, in its cross-section frame (x = tangent),
//     C_i = dX_i diag(c_rot, 0, 0, c_t, c_n, c_n)                                      (Node::drag)
// (torque about the tangent, force along and across it). The generalised drag of the whole tree
// is -D v with D = sum_i J_i^T C_i J_i: the composite-rigid-body recursion with C_i in place of
// the inertias (dynamics.hpp: composite), including the coupling to a moving base.
//
// Coefficients per unit length (mu the dynamic viscosity, a the filament radius):
//  - Gray & Hancock (1955), "The propulsion of sea-urchin spermatozoa", J. Exp. Biol. 32:802:
//        c_n = 4 pi mu / (ln(2 lambda / a) + 1/2),   c_t = 2 pi mu / (ln(2 lambda / a) - 1/2),
//    lambda the wavelength of the filament's wave (the pitch of a helix, along its axis);
//  - Lighthill (1976), "Flagellar hydrodynamics", SIAM Review 18:161:
//        c_n = 8 pi mu / (1 + 2 ln(2 q / a)),   c_t = 2 pi mu / ln(2 q / a),   q = 0.09 Lambda,
//    Lambda the wavelength measured along the filament (one helical turn's arc length);
//  - rotation about the tangent: c_rot = 4 pi mu a^2 (a cylinder spinning in Stokes flow).
// A filament without a helical wave (straight, planar) uses Gray & Hancock with lambda = L/2, i.e.
// the logarithm ln(L/a) of slender-body theory for a straight filament of length L (the leading
// terms of the exact resistance of a prolate spheroid of length L and radius a).
#pragma once

#include <optional>

#include "model.hpp"

namespace cosserat {

enum class RftModel { GrayHancock, Lighthill };

// Resistance per unit length: c_t, c_n [N s / m^2] and c_rot [N s].
struct RftCoefficients {
  double ct = 0.0, cn = 0.0, crot = 0.0;
};

// The formulas above. Both return non-positive coefficients when the filament is too thick for
// its wavelength (ln(2 lambda / a) <= 1/2, resp. ln(2 q / a) <= 0): callers check valid().
RftCoefficients gray_hancock(double mu, double radius, double wavelength);
RftCoefficients lighthill(double mu, double radius, double wavelength_along_filament);
inline bool valid(const RftCoefficients& c) { return c.ct > 0 && c.cn > 0 && c.crot >= 0; }

// The helix a constant strain xi = [k; p] traces: radius |k x p| / |k|^2 and pitch (axial advance
// per turn) 2 pi (k . p) / |k|^2. `helical` when both are non-zero (relative to the scale 1/|k|).
struct Helix {
  bool helical = false;
  double radius = 0.0, pitch = 0.0;
};
Helix helix_of(const Vec6& strain);
// A helix whose pitch is under this fraction of a turn's arc length counts as planar for a rod's
// default wavelength (set_rod_drag): nearly planar, or coiled tighter than the slender-body law.
constexpr double kPlanarPitch = 0.1;

// How a rod meets the fluid.
struct RodFluid {
  double viscosity = 0.0;                // mu [Pa s]
  RftModel model = RftModel::GrayHancock;
  double wavelength = 0.0;               // lambda [m], the wave's length along its axis (a helix's
                                         // pitch); 0: the pitch of the rod's first helical section
                                         // (its rest strain), or L/2 without one. Lighthill's Lambda
                                         // along the filament is hypot(lambda, 2 pi R) on a helix.
  std::optional<RftCoefficients> drag;   // explicit c_t, c_n (and c_rot; 0: 4 pi mu a^2)
  bool enabled = true;                   // false: no fluid force on this rod
};

// What set_rod_drag decided (for reports).
struct RodFluidInfo {
  enum class Law { Explicit, GrayHancock, Lighthill } law = Law::GrayHancock;  // the one applied
  double wavelength = 0.0;      // lambda used (0 with explicit coefficients)
  double along_filament = 0.0;  // Lighthill's Lambda: hypot(lambda, 2 pi R) on a helix, else lambda
  bool helical = false;         // the rod has a helical section (R: its radius)
  bool default_wavelength = false;  // lambda is the default: the helix's pitch, or L/2
  // the first section (index in the rod) whose rest shape is a helix of pitch under kPlanarPitch of
  // a turn's arc length, taken as planar for the default wavelength; -1: none
  int nearly_planar_section = -1;
  RftCoefficients base;         // coefficients at X = 0
};

// Fills Node::drag of every quadrature node of rod `rod` (overwriting it). Throws
// std::invalid_argument when the coefficients come out non-positive (filament too thick for its
// wavelength: give the drag explicitly). Call before creating Data (it only changes the model).
RodFluidInfo set_rod_drag(Model& m, int rod, const RodFluid& f);
bool has_drag(const Model& m);

// Fluid damping of the tree, d.D_fluid, d.DF_base, d.Dc_base (model.hpp), by the composite
// recursion with Node::drag. After fwd_position.
void fluid_damping(const Model& m, Data& d);
// Generalised fluid force -(D_fluid v + DF_base^T eta_b) added to tau, with eta_b = d.base_twist,
// and (if base_wrench) the wrench -(DF_base v + Dc_base eta_b) the fluid exerts on the tree,
// reduced to the base frame. After fluid_damping (and with d.v, d.base_twist current).
void add_fluid_force(const Model& m, const Data& d, VecX& tau, Vec6* base_wrench = nullptr);

// ---- rigid bodies (body frame at the centre, angular first) -----------------------------------
// Sphere of radius a: Stokes, torque 8 pi mu a^3 Omega and force 6 pi mu a U.
Mat6 sphere_resistance(double mu, double a);
// Ellipsoid with semi-axes s (along the frame's axes), exact Stokes resistance: translation
// 16 pi mu U_i / (chi + s_i^2 alpha_i) (Oberbeck 1876), rotation
// 16 pi mu (s_j^2 + s_k^2) / (3 (s_j^2 alpha_j + s_k^2 alpha_k)) Omega_i (Jeffery 1922), with
// chi = int_0^inf dl / D(l), alpha_i = int_0^inf dl / ((s_i^2 + l) D(l)),
// D(l) = sqrt((s_1^2 + l)(s_2^2 + l)(s_3^2 + l)), evaluated by adaptive quadrature.
Mat6 ellipsoid_resistance(double mu, const Vec3& semi_axes);
// A straight slender segment of length L along axis `axis` (0, 1, 2) of the frame, centred at its
// origin, by RFT: forces c_t L (along), c_n L (across), torques c_rot L (about the axis) and
// c_n L^3 / 12 (about the transverse axes).
Mat6 segment_resistance(const RftCoefficients& c, double length, int axis = 0);

}  // namespace cosserat
