// Strain bases (DESIGN.md section 5), rigid-joint bases, and the quadrature rules the rod model
// uses. Pure functions of their arguments.
#pragma once

#include <array>
#include <optional>
#include <string_view>
#include <vector>

#include "lie.hpp"

namespace cosserat {

using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

// A x for a 6 x n matrix and n values, column by column in fixed-size arithmetic (at the few
// columns of a section, Eigen's general matrix-vector product costs more than its arithmetic).
inline Vec6 mul_cols(const Mat6X& A, const double* x) {
  Vec6 r = Vec6::Zero();
  for (int k = 0; k < A.cols(); ++k) r += A.col(k) * x[k];
  return r;
}

// Which of the six strain components [kx ky kz px py pz] are free coordinates.
using StrainMask = std::array<bool, 6>;

// The named bases of DESIGN.md section 5: rigid, spring, pcc, icc, cc, ikl, kl, sr (and long
// names such as "kirchhoff-love", "simo-reissner", "cosserat", "constant-curvature").
std::optional<StrainMask> strain_mask_from_name(std::string_view name);
int mask_count(const StrainMask& m);
// 6 x (number of free components) selection matrix B.
Mat6X basis_from_mask(const StrainMask& m);

// Rigid joints as constant-twist pieces of unit length (DESIGN.md section 5).
enum class JointType { Revolute, Prismatic, Helical, Cylindrical, Planar, Spherical, Free };
// Basis B of a joint. `axis` is the joint axis (revolute, prismatic, helical, cylindrical) or the
// plane normal (planar); `pitch` is the helical advance per full turn [m/rev].
Mat6X joint_basis(JointType type, const Vec3& axis, double pitch = 0.0);
int joint_dofs(JointType type);

// Gauss-Legendre rule with n points on [0, 1] (weights sum to 1).
void gauss_legendre01(int n, std::vector<double>& x, std::vector<double>& w);
// Shifted Legendre polynomials P_k(2x - 1), k = 0..order, at x in [0, 1].
void legendre01(int order, double x, double* P);
// Their means over [x0, x1] (the value at x0 when x1 == x0): exact, by a Gauss rule of
// order / 2 + 1 points on the interval.
void legendre01_mean(int order, double x0, double x1, double* P);

}  // namespace cosserat
