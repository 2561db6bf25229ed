// SE(3) Lie group operations for strain-based Cosserat rods.
//
// Conventions (DESIGN.md section 3): twists, strains and wrenches are ordered angular first,
// eta = [w; v], xi = [k; p], F = [m; n], all expressed in the body (cross-section) frame.
//   ad_eta  = [[w~, 0], [v~, w~]]         coad_eta = ad*_eta = [[w~, v~], [0, w~]] = -ad_eta^T
//   Ad_g    = [[R, 0], [u~R, R]]          coAd_g   = Ad*_g   = [[R, u~R], [0, R]]  = Ad_g^-T
//
// The closed forms of DESIGN.md section 4 are written here for a unit parameter: for a twist
// Omega (e.g. Omega = X xi for a constant strain xi over a length X),
//   exp_se3(Omega) = e^{Omega^},   dexp(Omega) = int_0^1 e^{s ad_Omega} ds,
// so that the design's tangent operator is T(X) = X dexp(X xi) (see tangent()). Every closed-form
// coefficient is 0/0 at theta -> 0; each is switched to its Taylor series at its own threshold
// (see lie_coefficients below and tests/core/lie_test.cpp).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace cosserat {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// Eigen aligns fixed-size members (Mat6, ...) and its heap blocks to what the instruction set
// wants: 32 bytes with AVX, 16 without. The layout of every struct of this library, and which
// allocator frees Eigen's heap blocks, follow. A program compiled with other instruction-set flags
// than the libraries (built for x86-64-v3 by default: CMake option COSSERAT_NATIVE) corrupts memory
// when it shares them (outside probe AB: a double free inside load_scene, garbage read from
// Scene::rods). So every translation unit that includes this header compares its Eigen alignments
// with the libraries' at start-up (check_eigen_layout, lie.cpp), which ends the program (exit status
// 1) with a message naming the flags to use. Linking the CMake targets passes the libraries' flags on.
int check_eigen_layout(int static_align, int heap_align);
namespace {
[[maybe_unused]] const int eigen_layout_checked =
    check_eigen_layout(EIGEN_MAX_STATIC_ALIGN_BYTES, EIGEN_DEFAULT_ALIGN_BYTES);
}  // namespace

// A rigid transformation g = (R, u): x -> R x + u.
struct SE3 {
  Mat3 R = Mat3::Identity();
  Vec3 u = Vec3::Zero();

  static SE3 Identity() { return SE3{}; }
  SE3 operator*(const SE3& b) const { return SE3{R * b.R, R * b.u + u}; }
  SE3 inverse() const { return SE3{R.transpose(), -(R.transpose() * u)}; }
  Vec3 act(const Vec3& x) const { return R * x + u; }
  Mat4 matrix() const;
};

// a~ : the skew matrix with a~ b = a x b.
Mat3 skew(const Vec3& a);
Vec3 unskew(const Mat3& A);  // inverse of skew (antisymmetric part)

// hat: R^6 -> se(3) (4x4) and its inverse vee.
Mat4 hat(const Vec6& xi);
Vec6 vee(const Mat4& X);

// Group exponential and logarithm.
SE3 exp_se3(const Vec6& Omega);
inline SE3 exp_se3(double X, const Vec6& xi) { return exp_se3(Vec6(X * xi)); }
Vec6 log_se3(const SE3& g);  // principal logarithm, rotation angle in [0, pi]
// SO(3) exponential of a rotation vector, and rotation matrix to unit quaternion (w, x, y, z).
Mat3 exp_so3(const Vec3& k);
Eigen::Vector4d quat_from_matrix(const Mat3& R);

// Adjoint maps.
Mat6 Ad(const SE3& g);
Mat6 Ad_inv(const SE3& g);  // Ad_{g^-1}
Mat6 coAd(const SE3& g);    // Ad*_g = Ad_g^{-T}
Mat6 ad(const Vec6& eta);
Mat6 coad(const Vec6& eta);  // ad*_eta = -ad_eta^T

// Fast actions, without forming 6x6 matrices. Inline: the recursions and the tangent operators'
// products call them tens of times per node (out of line, ad_apply's calls alone took 31% of the
// velocity pass of an 8-section rod).
// Ad_{g^-1} eta
inline Vec6 Ad_inv_apply(const SE3& g, const Vec6& e) {
  const Vec3 w = e.head<3>(), v = e.tail<3>();
  Vec6 r;
  r.head<3>() = g.R.transpose() * w;
  r.tail<3>() = g.R.transpose() * (v - g.u.cross(w));
  return r;
}
// Ad*_g F: wrench from frame g to its parent
inline Vec6 coAd_apply(const SE3& g, const Vec6& F) {
  const Vec3 n = g.R * F.tail<3>();
  Vec6 r;
  r.head<3>() = g.R * F.head<3>() + g.u.cross(n);
  r.tail<3>() = n;
  return r;
}
// column r of ad_a (ad_a e_r) without the 6 x 6 matrix: for r < 3 (w x e_r, v x e_r), else (0, w x e_(r-3))
inline Vec6 ad_column(const Vec6& a, int r) {
  const auto cross_unit = [](const auto& w, int i) {  // w x e_i
    return i == 0 ? Vec3(0.0, w(2), -w(1)) : i == 1 ? Vec3(-w(2), 0.0, w(0)) : Vec3(w(1), -w(0), 0.0);
  };
  Vec6 col;
  if (r < 3) {
    col.head<3>() = cross_unit(a.head<3>(), r);
    col.tail<3>() = cross_unit(a.tail<3>(), r);
  } else {
    col.head<3>().setZero();
    col.tail<3>() = cross_unit(a.head<3>(), r - 3);
  }
  return col;
}
// ad_a b
inline Vec6 ad_apply(const Vec6& a, const Vec6& b) {
  Vec6 r;
  r.head<3>() = a.head<3>().cross(b.head<3>());
  r.tail<3>() = a.tail<3>().cross(b.head<3>()) + a.head<3>().cross(b.tail<3>());
  return r;
}
// ad*_a F
inline Vec6 coad_apply(const Vec6& a, const Vec6& F) {
  Vec6 r;
  r.head<3>() = a.head<3>().cross(F.head<3>()) + a.tail<3>().cross(F.tail<3>());
  r.tail<3>() = a.head<3>().cross(F.tail<3>());
  return r;
}

// dexp(Omega) = int_0^1 e^{s ad_Omega} ds = I + c1 ad + c2 ad^2 + c3 ad^3 + c4 ad^4
// (DESIGN.md section 4 with X = 1). The body velocity of e^{Omega^} is dexp(-Omega) Omega_dot.
Mat6 dexp(const Vec6& Omega);
// Tangent operator of the design document: T(X) = int_0^X e^{s ad_xi} ds = X dexp(X xi).
inline Mat6 tangent(double X, const Vec6& xi) { return X * dexp(Vec6(X * xi)); }
// Directional derivative of dexp at Omega along delta: d/de dexp(Omega + e delta) at e = 0.
Mat6 ddexp(const Vec6& Omega, const Vec6& delta);
// The same applied to a vector, without forming the matrices: dexp(Omega) x and
// ddexp(Omega, delta) x (a few ad products each; the kinematics' velocity-product terms).
Vec6 dexp_apply(const Vec6& Omega, const Vec6& x);
Vec6 ddexp_apply(const Vec6& Omega, const Vec6& delta, const Vec6& x);
// ddexp(Omega, -x) x, a step's velocity product dS/dt v = ddexp(-Omega, -Omega_dot) Omega_dot
// (its term ad_{-x} x = 0 left out: two ad products fewer than ddexp_apply).
Vec6 ddexp_apply_self(const Vec6& Omega, const Vec6& x);

// The scalar coefficients of the closed forms, each with its own small-angle switch. Exposed for
// the continuity tests. theta >= 0 is the norm of the angular part.
namespace lie_coefficients {
double a1(double theta);  // sin t / t
double a2(double theta);  // (1 - cos t) / t^2
double a3(double theta);  // (t - sin t) / t^3
double c1(double theta);  // (4 - 4 cos t - t sin t) / (2 t^2)
double c2(double theta);  // (4 t - 5 sin t + t cos t) / (2 t^3)
double c3(double theta);  // (2 - 2 cos t - t sin t) / (2 t^4)
double c4(double theta);  // (2 t - 3 sin t + t cos t) / (2 t^5)
double d3(double theta);  // c1'(t) / t^3 = c3'(t) / t
double d4(double theta);  // c2'(t) / t^3 = c4'(t) / t
// Series/closed-form switch points (theta below: series).
extern const double switch_a3, switch_c1, switch_c2, switch_c3, switch_c4, switch_d3, switch_d4;
}  // namespace lie_coefficients

}  // namespace cosserat
