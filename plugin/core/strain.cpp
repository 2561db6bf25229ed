#include "strain.hpp"

#include <cctype>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cosserat {

std::optional<StrainMask> strain_mask_from_name(std::string_view name) {
  std::string n(name);
  for (auto& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  //                          kx     ky     kz     px     py     pz
  if (n == "rigid") return StrainMask{false, false, false, false, false, false};
  if (n == "spring" || n == "linear-spring") return StrainMask{false, false, false, true, false, false};
  if (n == "pcc" || n == "planar-constant-curvature")
    return StrainMask{false, false, true, true, false, false};
  if (n == "icc" || n == "inextensible-constant-curvature")
    return StrainMask{false, true, true, false, false, false};
  if (n == "cc" || n == "constant-curvature") return StrainMask{false, true, true, true, false, false};
  if (n == "ikl" || n == "inextensible-kirchhoff-love")
    return StrainMask{true, true, true, false, false, false};
  if (n == "kl" || n == "kirchhoff-love" || n == "kirchhoff") return StrainMask{true, true, true, true, false, false};
  if (n == "sr" || n == "simo-reissner" || n == "cosserat") return StrainMask{true, true, true, true, true, true};
  return std::nullopt;
}

int mask_count(const StrainMask& m) {
  int c = 0;
  for (bool b : m) c += b;
  return c;
}

Mat6X basis_from_mask(const StrainMask& m) {
  Mat6X B = Mat6X::Zero(6, mask_count(m));
  int j = 0;
  for (int i = 0; i < 6; ++i)
    if (m[i]) B(i, j++) = 1.0;
  return B;
}

int joint_dofs(JointType t) {
  switch (t) {
    case JointType::Revolute:
    case JointType::Prismatic:
    case JointType::Helical: return 1;
    case JointType::Cylindrical: return 2;
    case JointType::Planar:
    case JointType::Spherical: return 3;
    case JointType::Free: return 6;
  }
  return 0;
}

Mat6X joint_basis(JointType t, const Vec3& axis_in, double pitch) {
  const Vec3 a = axis_in.normalized();
  Mat6X B = Mat6X::Zero(6, joint_dofs(t));
  switch (t) {
    case JointType::Revolute: B.col(0).head<3>() = a; break;
    case JointType::Prismatic: B.col(0).tail<3>() = a; break;
    case JointType::Helical:
      B.col(0).head<3>() = a;
      B.col(0).tail<3>() = pitch / (2.0 * M_PI) * a;
      break;
    case JointType::Cylindrical:
      B.col(0).head<3>() = a;
      B.col(1).tail<3>() = a;
      break;
    case JointType::Planar: {
      // rotation about the normal, translations along two in-plane axes
      Vec3 e1 = a.unitOrthogonal(), e2 = a.cross(e1);
      B.col(0).head<3>() = a;
      B.col(1).tail<3>() = e1;
      B.col(2).tail<3>() = e2;
      break;
    }
    case JointType::Spherical: B.topRows<3>().setIdentity(); break;
    case JointType::Free: B.setIdentity(); break;
  }
  return B;
}

void gauss_legendre01(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(n, 0.0);
  w.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    // Newton on P_n from the Chebyshev-like initial guess; symmetric rule on [-1, 1].
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1.0, p1 = z;
      dp = n * (z * p1 - p0) / (z * z - 1.0);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-16) break;
    }
    x[n - 1 - i] = 0.5 * (1.0 + z);  // ascending order on [0, 1]
    w[n - 1 - i] = 1.0 / ((1.0 - z * z) * dp * dp);  // (2/((1-z^2)dp^2)) / 2
  }
}

void legendre01(int order, double x, double* P) {
  const double z = 2.0 * x - 1.0;
  P[0] = 1.0;
  if (order >= 1) P[1] = z;
  for (int k = 2; k <= order; ++k) P[k] = ((2.0 * k - 1.0) * z * P[k - 1] - (k - 1.0) * P[k - 2]) / k;
}

void legendre01_mean(int order, double x0, double x1, double* P) {
  // the rules of 1..16 points (orders up to 30), computed once
  static const std::vector<std::vector<double>> rules = [] {
    std::vector<std::vector<double>> r(2 * 17);
    for (int n = 1; n <= 16; ++n) gauss_legendre01(n, r[2 * n], r[2 * n + 1]);
    return r;
  }();
  if (order < 0 || order > 30) throw std::invalid_argument("legendre01_mean: order outside 0..30");
  const int n = order / 2 + 1;
  const std::vector<double>&x = rules[2 * n], &w = rules[2 * n + 1];
  double Q[31];
  for (int k = 0; k <= order; ++k) P[k] = 0.0;
  for (int j = 0; j < n; ++j) {
    legendre01(order, x0 + (x1 - x0) * x[j], Q);
    for (int k = 0; k <= order; ++k) P[k] += w[j] * Q[k];
  }
}

}  // namespace cosserat
