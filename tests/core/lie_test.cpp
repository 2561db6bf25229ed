// Unit tests for plugin/core/lie.{hpp,cpp}: SE(3) exponential and logarithm, adjoint maps, dexp,
// ddexp and the scalar closed-form coefficients.
//
// Every reference below is independent of lie.cpp:
//  - exponentials: Eigen's Pade scaling-and-squaring expm (unsupported/Eigen/MatrixFunctions);
//  - int_0^1 e^{sA} ds: the Van Loan block trick, expm([[A, I], [0, 0]]) = [[e^A, int_0^1 e^{sA} ds],
//    [0, I]], again with Eigen's expm;
//  - derivatives: central finite differences;
//  - scalar coefficients: long-double power series built here from the sin/cos series, and the
//    closed forms in long double, each with a running error bound;
//  - hat, ad, Ad and the rotation of a quaternion are re-implemented here from their definitions.
//
// Conventions: twists are angular first, eta = [w; v]; ad_eta = [[w~, 0], [v~, w~]];
// Ad_g = [[R, 0], [u~R, R]]; coad = -ad^T; coAd_g = Ad_g^{-T}.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

#include "lie.hpp"

namespace cosserat {
namespace {

namespace lc = lie_coefficients;

constexpr double kPi = 3.14159265358979323846;
constexpr double kEps = std::numeric_limits<double>::epsilon();  // 2.2e-16

// ---------------------------------------------------------------------------------------------
// Deterministic random numbers. std::uniform_real_distribution is implementation-defined, so the
// raw 32-bit mt19937 output (fully specified by the standard) is mapped to [lo, hi) by hand.
class Rng {
 public:
  explicit Rng(uint32_t seed) : gen_(seed) {}
  double uniform(double lo, double hi) { return lo + (hi - lo) * (gen_() / 4294967296.0); }
  Vec3 vec3(double scale = 1.0) {
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = scale * uniform(-1.0, 1.0);
    return v;
  }
  Vec3 unit3() {
    for (;;) {
      const Vec3 v = vec3();
      if (v.norm() > 0.1 && v.norm() <= 1.0) return v.normalized();
    }
  }
  Vec6 vec6(double scale = 1.0) {
    Vec6 v;
    v << vec3(scale), vec3(scale);
    return v;
  }

 private:
  std::mt19937 gen_;
};

// A twist with rotation angle exactly |k| = theta about a random axis and a random translation.
Vec6 random_twist(Rng& rng, double theta, double p_scale = 1.0) {
  Vec6 x;
  x << theta * rng.unit3(), rng.vec3(p_scale);
  return x;
}

// Rotation angles exercised by the matrix tests: identity, tiny, small, moderate, pi, and several
// full turns (where the closed forms must still agree with the true exponential).
const std::vector<double> kThetas = {0.0, 1e-8, 1e-4, 1e-2, 1.0, kPi, 2.0 * kPi + 0.3, 5.0 * kPi, 13.0};

// All series/closed-form switch points exposed by lie.hpp.
std::vector<double> switch_points() {
  return {lc::switch_a3, lc::switch_c1, lc::switch_c2, lc::switch_c3,
          lc::switch_c4, lc::switch_d3, lc::switch_d4};
}

// kThetas plus, for every switch s, s (1 - 1e-9), s and s (1 + 1e-9).
std::vector<double> thetas_with_switches() {
  std::vector<double> t = kThetas;
  for (double s : switch_points()) {
    t.push_back(s * (1.0 - 1e-9));
    t.push_back(s);
    t.push_back(s * (1.0 + 1e-9));
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
// Reference operators written from their definitions (not calling lie.cpp).
Mat3 skew_ref(const Vec3& a) {  // column i of a~ is a x e_i
  Mat3 m;
  for (int i = 0; i < 3; ++i) m.col(i) = a.cross(Vec3::Unit(i));
  return m;
}
Mat4 hat_ref(const Vec6& x) {
  Mat4 m = Mat4::Zero();
  m.topLeftCorner<3, 3>() = skew_ref(x.head<3>());
  m.topRightCorner<3, 1>() = x.tail<3>();
  return m;
}
Mat6 ad_ref(const Vec6& x) {
  Mat6 m = Mat6::Zero();
  m.topLeftCorner<3, 3>() = skew_ref(x.head<3>());
  m.bottomRightCorner<3, 3>() = skew_ref(x.head<3>());
  m.bottomLeftCorner<3, 3>() = skew_ref(x.tail<3>());
  return m;
}
Mat6 Ad_ref(const Mat4& g) {
  const Mat3 R = g.topLeftCorner<3, 3>();
  const Vec3 u = g.topRightCorner<3, 1>();
  Mat6 m = Mat6::Zero();
  m.topLeftCorner<3, 3>() = R;
  m.bottomRightCorner<3, 3>() = R;
  m.bottomLeftCorner<3, 3>() = skew_ref(u) * R;
  return m;
}
Mat4 to_mat(const SE3& g) {
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() = g.R;
  m.topRightCorner<3, 1>() = g.u;
  return m;
}
Vec6 vee_ref(const Mat4& X) {  // angular part from the antisymmetric part of the 3x3 block
  const Mat3 W = 0.5 * (X.topLeftCorner<3, 3>() - X.topLeftCorner<3, 3>().transpose());
  Vec6 v;
  v << W(2, 1), W(0, 2), W(1, 0), X.topRightCorner<3, 1>();
  return v;
}
// Rotation matrix of a unit quaternion (w, x, y, z): (w^2 - |q|^2) I + 2 q q^T + 2 w q~.
Mat3 rotation_of_quaternion(const Eigen::Vector4d& wq) {
  const double w = wq[0];
  const Vec3 q = wq.tail<3>();
  return (w * w - q.squaredNorm()) * Mat3::Identity() + 2.0 * q * q.transpose() + 2.0 * w * skew_ref(q);
}

// int_0^X e^{s A} ds via Van Loan: expm([[X A, X I], [0, 0]]) has it as its top-right block.
Mat6 integral_of_exp(const Mat6& A, double X = 1.0) {
  Eigen::Matrix<double, 12, 12> M = Eigen::Matrix<double, 12, 12>::Zero();
  M.topLeftCorner<6, 6>() = X * A;
  M.topRightCorner<6, 6>() = X * Mat6::Identity();
  const Eigen::Matrix<double, 12, 12> E = M.exp();
  return E.topRightCorner<6, 6>();
}

// ||A - B||_F / max(1, ||B||_F): relative error for O(1)-or-larger references, absolute below.
template <class A, class B>
double rel_err(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  return (a - b).norm() / std::max(1.0, b.norm());
}

std::string str(const Vec6& x) {
  const Eigen::IOFormat f(Eigen::FullPrecision, Eigen::DontAlignCols, ", ", ", ", "", "", "[", "]");
  std::ostringstream os;
  os << x.transpose().format(f);
  return os.str();
}
std::string num(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}
std::string trace_msg(double theta, const Vec6& x) {
  std::ostringstream os;
  os.precision(17);
  os << "theta = " << theta << ", Omega = " << str(x);
  return os.str();
}

// ---------------------------------------------------------------------------------------------
// High-precision references for the scalar coefficients.
//
// Each coefficient is f(t) = N(t) / t^m, with N a combination of terms coef * t^power * F(t),
// F in {1, cos, sin}, transcribed from the formulas in lie.hpp / the brief.
enum class Fn { One, Cos, Sin };
struct NumTerm {
  long double coef;
  int power;
  Fn fn;
};
struct CoefSpec {
  const char* name;
  double (*f)(double);
  double switch_point;  // 0: no exposed switch
  int m;                // f = N / t^m
  std::vector<NumTerm> num;
  long double value_at_zero;  // known limit, a sanity check on the transcription
};

const std::vector<CoefSpec>& coef_specs() {
  static const std::vector<CoefSpec> specs = {
      {"a1", lc::a1, 0.0, 1, {{1, 0, Fn::Sin}}, 1.0L},                                      // sin t / t
      {"a2", lc::a2, 0.0, 2, {{1, 0, Fn::One}, {-1, 0, Fn::Cos}}, 0.5L},                    // (1-cos)/t^2
      {"a3", lc::a3, lc::switch_a3, 3, {{1, 1, Fn::One}, {-1, 0, Fn::Sin}}, 1.0L / 6},     // (t-sin)/t^3
      {"c1", lc::c1, lc::switch_c1, 2,  // (4 - 4 cos t - t sin t) / (2 t^2)
       {{2, 0, Fn::One}, {-2, 0, Fn::Cos}, {-0.5L, 1, Fn::Sin}}, 0.5L},
      {"c2", lc::c2, lc::switch_c2, 3,  // (4 t - 5 sin t + t cos t) / (2 t^3)
       {{2, 1, Fn::One}, {-2.5L, 0, Fn::Sin}, {0.5L, 1, Fn::Cos}}, 1.0L / 6},
      {"c3", lc::c3, lc::switch_c3, 4,  // (2 - 2 cos t - t sin t) / (2 t^4)
       {{1, 0, Fn::One}, {-1, 0, Fn::Cos}, {-0.5L, 1, Fn::Sin}}, 1.0L / 24},
      {"c4", lc::c4, lc::switch_c4, 5,  // (2 t - 3 sin t + t cos t) / (2 t^5)
       {{1, 1, Fn::One}, {-1.5L, 0, Fn::Sin}, {0.5L, 1, Fn::Cos}}, 1.0L / 120},
      {"d3", lc::d3, lc::switch_d3, 6,  // (-t^2 cos t + 5 t sin t + 8 cos t - 8) / (2 t^6)
       {{-0.5L, 2, Fn::Cos}, {2.5L, 1, Fn::Sin}, {4, 0, Fn::Cos}, {-4, 0, Fn::One}}, -1.0L / 180},
      {"d4", lc::d4, lc::switch_d4, 7,  // (-t^2 sin t - 7 t cos t - 8 t + 15 sin t) / (2 t^7)
       {{-0.5L, 2, Fn::Sin}, {-3.5L, 1, Fn::Cos}, {-4, 1, Fn::One}, {7.5L, 0, Fn::Sin}}, -1.0L / 1260},
  };
  return specs;
}

constexpr long double kUld = std::numeric_limits<long double>::epsilon() / 2;  // unit roundoff
constexpr int kSeriesDegree = 120;  // 4^120 / 120! < 1e-120: truncation is irrelevant for t < 4

// A long-double value with a first-order bound on its rounding error.
struct Ref {
  long double value;
  long double err;
};

// Power series of N(t): a[k] are the coefficients of t^k, a_abs[k] the sums of the magnitudes of
// the contributions to a[k] (so that the rounding error of a[k] is below ~(k + 4) u a_abs[k]).
struct Series {
  std::array<long double, kSeriesDegree + 1> a{}, a_abs{};
};
Series numerator_series(const CoefSpec& c) {
  std::array<long double, kSeriesDegree + 1> inv_fact{};  // 1 / n!
  inv_fact[0] = 1.0L;
  for (int n = 1; n <= kSeriesDegree; ++n) inv_fact[n] = inv_fact[n - 1] / n;
  Series s;
  auto add = [&](int k, long double v) {
    if (k > kSeriesDegree) return;
    s.a[k] += v;
    s.a_abs[k] += std::fabs(v);
  };
  for (const NumTerm& term : c.num) {
    if (term.fn == Fn::One) {
      add(term.power, term.coef);
      continue;
    }
    // cos t = sum (-1)^n t^{2n} / (2n)!,  sin t = sum (-1)^n t^{2n+1} / (2n+1)!
    for (int n = 0; 2 * n + 1 <= kSeriesDegree; ++n) {
      const int k = term.fn == Fn::Cos ? 2 * n : 2 * n + 1;
      add(term.power + k, (n % 2 ? -1.0L : 1.0L) * term.coef * inv_fact[k]);
    }
  }
  return s;
}

// sum_{k >= m} a[k] t^{k - m}, with the error bound u sum (k + 6) a_abs[k] t^{k-m} + 2 u |S|
// (coefficient rounding, powers of t, and compensated summation).
Ref series_ref(const CoefSpec& c, long double t) {
  const Series s = numerator_series(c);
  long double sum = 0.0L, comp = 0.0L, bound = 0.0L, tp = 1.0L;
  for (int k = c.m; k <= kSeriesDegree; ++k) {
    const long double y = s.a[k] * tp - comp;  // Kahan summation
    const long double next = sum + y;
    comp = (next - sum) - y;
    sum = next;
    bound += (k + 6) * s.a_abs[k] * tp;
    tp *= t;
  }
  return {sum, kUld * bound + 2 * kUld * std::fabs(sum)};
}

// The closed form N(t) / t^m in long double; libm's sinl/cosl are within a couple of ulps, so
// every term carries fewer than (power + 8) roundings, and the division by t^m another ~2m.
Ref closed_ref(const CoefSpec& c, long double t) {
  long double n = 0.0L, n_abs = 0.0L;
  for (const NumTerm& term : c.num) {
    const long double f = term.fn == Fn::One ? 1.0L : term.fn == Fn::Cos ? std::cos(t) : std::sin(t);
    const long double v = term.coef * std::pow(t, static_cast<long double>(term.power)) * f;
    n += v;
    n_abs += (term.power + 8) * std::fabs(v);
  }
  const long double tm = std::pow(t, static_cast<long double>(c.m));
  return {n / tm, kUld * (n_abs + 2 * c.m * std::fabs(n)) / tm};
}

// The better of the two (series only for t < 4 as its terms then decay fast; closed form only for
// t > 0), judged by the error bounds.
Ref coefficient_ref(const CoefSpec& c, double t) {
  const long double tl = t;
  if (t == 0.0) return series_ref(c, tl);
  const Ref closed = closed_ref(c, tl);
  if (t >= 4.0) return closed;
  const Ref series = series_ref(c, tl);
  return series.err <= closed.err ? series : closed;
}

// =============================================================================================
// 0. Small building blocks against their definitions.
TEST(LieBasics, SkewHatVeeAndAdMatchDefinitions) {
  Rng rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 a = rng.vec3(3.0), b = rng.vec3(3.0);
    const Vec6 x = rng.vec6(2.0);
    // skew / hat / ad are assembled from the inputs without arithmetic: exact equality expected.
    EXPECT_EQ(skew(a), skew_ref(a));
    EXPECT_EQ(hat(x), hat_ref(x));
    EXPECT_EQ(ad(x), ad_ref(x));
    EXPECT_EQ(vee(hat(x)), x);
    EXPECT_EQ(unskew(skew(a)), a);
    // skew(a) b: 3 products summed in a different order from cross(): a few ulps of |a||b|.
    EXPECT_LT((skew(a) * b - a.cross(b)).norm(), 4 * kEps * a.norm() * b.norm());
    // vee of a general 4x4 keeps the antisymmetric part only.
    Mat4 M;
    for (int k = 0; k < 16; ++k) M(k / 4, k % 4) = rng.uniform(-1.0, 1.0);
    EXPECT_LT((vee(M) - vee_ref(M)).norm(), 4 * kEps * M.norm());
  }
}

// =============================================================================================
// 1. exp_se3 against Eigen's matrix exponential.
//
// Tolerance 2e-14 (~90 eps, relative Frobenius): Eigen's expm (Pade 13 with scaling and squaring)
// is backward stable and the matrices here are nearly normal with |A| <= ~25, so its forward error
// is O(|A| eps); the closed form is a few eps. Observed maximum: 1.1e-15.
constexpr double kTolExp = 2e-14;

TEST(LieExp, MatchesMatrixExponential) {
  Rng rng(1);
  for (double theta : kThetas) {
    for (double p_scale : {0.0, 1.0, 1.0, 10.0}) {
      const Vec6 x = random_twist(rng, theta, p_scale);
      SCOPED_TRACE(trace_msg(theta, x));
      const SE3 g = exp_se3(x);
      const Mat4 ref = hat_ref(x).exp();
      EXPECT_LT(rel_err(to_mat(g), ref), kTolExp);
      EXPECT_EQ(g.matrix(), to_mat(g));
      // R must stay orthonormal: a1, a2 are each within ~1 ulp (observed 5.7 eps).
      EXPECT_LT((g.R.transpose() * g.R - Mat3::Identity()).norm(), 32 * kEps);
      // SO(3) exponential = rotation block; also Eigen's independent AngleAxis formula.
      EXPECT_LT(rel_err(exp_so3(x.head<3>()), ref.topLeftCorner<3, 3>()), kTolExp);
      if (theta > 0) {
        const Mat3 Raa = Eigen::AngleAxisd(theta, x.head<3>() / theta).toRotationMatrix();
        EXPECT_LT(rel_err(exp_so3(x.head<3>()), Raa), 32 * kEps);  // two closed forms, few ulps
      }
      // Ad(exp(Omega)) = e^{ad_Omega} (6x6).
      EXPECT_LT(rel_err(Ad(g), Mat6(ad_ref(x).exp())), kTolExp);
      // The (X, xi) overload is exp_se3(X xi).
      EXPECT_LT(rel_err(to_mat(exp_se3(2.5, Vec6(x / 2.5))), ref), kTolExp);
    }
  }
}

// =============================================================================================
// 2. dexp against int_0^1 e^{s ad} ds (Van Loan block exponential).
//
// Tolerance 2e-14 (~90 eps): same expm accuracy argument as above (the 12x12 block matrix has norm
// <= ~|ad| + 1); the closed form sums c_k ad^k with |c_k ad^k| = O(1) at these angles.
// Observed maximum: 1.1e-15.
constexpr double kTolDexp = 2e-14;

TEST(LieDexp, MatchesVanLoanIntegral) {
  Rng rng(2);
  for (double theta : thetas_with_switches()) {
    for (double p_scale : {0.0, 1.0, 3.0}) {
      const Vec6 x = random_twist(rng, theta, p_scale);
      SCOPED_TRACE(trace_msg(theta, x));
      const Mat6 D = dexp(x);
      EXPECT_LT(rel_err(D, integral_of_exp(ad_ref(x))), kTolDexp);

      // tangent(X, xi) = int_0^X e^{s ad_xi} ds, for a strain xi with |X k_xi| = theta.
      for (double X : {0.37, 2.5}) {
        const Vec6 xi = x / X;
        const Mat6 T = tangent(X, xi);
        EXPECT_LT(rel_err(T, integral_of_exp(ad_ref(xi), X)), kTolDexp * X);
        EXPECT_LT(rel_err(T, Mat6(X * dexp(Vec6(X * xi)))), 10 * kEps);  // same arithmetic up to X
      }

      // Ad_{exp(Omega)^-1} dexp(Omega) = int_0^1 e^{(s-1) ad} ds = dexp(-Omega).
      EXPECT_LT(rel_err(Mat6(Ad_inv(exp_se3(x)) * D), dexp(Vec6(-x))), kTolDexp);
      // ad_Omega Omega = 0, so dexp(Omega) Omega = Omega (a few ulps of |D||x|).
      EXPECT_LT((D * x - x).norm(), 50 * kEps * std::max(1.0, D.norm()) * x.norm() + 1e-300);
    }
  }
}

// =============================================================================================
// 3. ddexp against central finite differences of dexp.
//
// Step h = 1e-6 max(1, |Omega|) / |delta|. Central differences err by ~h^2 |dexp'''| / 6 (~1e-13
// relative) plus rounding ~eps |dexp| / h (~1e-10), and the series/closed-form switches can add a
// jump of ~1e-15 / h ~ 1e-9 when the stencil straddles one. Tolerance 1e-8 relative
// (sqrt(eps) ~ 1.5e-8): 10x above the worst expected error (observed 1.4e-10), while any wrong
// term would be O(1).
constexpr double kTolFd = 1e-8;

TEST(LieDdexp, MatchesFiniteDifferences) {
  Rng rng(3);
  for (double theta : thetas_with_switches()) {
    const Vec6 x = random_twist(rng, theta, 1.0);
    // Directions: generic, pure rotation, pure translation, rotation along the axis of k.
    std::vector<Vec6> deltas = {rng.vec6(), rng.vec6(), rng.vec6()};
    deltas[1].tail<3>().setZero();
    deltas[2].head<3>().setZero();
    Vec6 along = rng.vec6();
    along.head<3>() = theta > 0 ? Vec3(x.head<3>() / theta) : rng.unit3();
    deltas.push_back(along);
    for (const Vec6& d : deltas) {
      SCOPED_TRACE(trace_msg(theta, x) + ", delta = " + str(d));
      const double h = 1e-6 * std::max(1.0, x.norm()) / d.norm();
      const Mat6 fd = (dexp(Vec6(x + h * d)) - dexp(Vec6(x - h * d))) / (2.0 * h);
      const Mat6 dd = ddexp(x, d);
      EXPECT_LT((dd - fd).norm() / std::max({1.0, fd.norm(), dexp(x).norm()}), kTolFd);
    }
    // Linearity in delta (exact up to rounding of the O(1) terms).
    const Vec6 d1 = rng.vec6(), d2 = rng.vec6();
    EXPECT_LT(rel_err(ddexp(x, Vec6(2.0 * d1 - 3.0 * d2)), Mat6(2.0 * ddexp(x, d1) - 3.0 * ddexp(x, d2))),
              1e-13);
  }
}

// The vector forms (dexp_apply, ddexp_apply) are the matrices applied to a vector, to rounding:
// they sum the same series in another order (relative 1e-13 of the O(1) terms; a missing or wrong
// term would be O(1)). Includes x along delta, the kinematics' own case (ad_delta x = 0).
TEST(LieDdexp, VectorFormsAreTheMatricesApplied) {
  Rng rng(5);
  for (double theta : thetas_with_switches()) {
    const Vec6 Om = random_twist(rng, theta, 1.0);
    for (int k = 0; k < 4; ++k) {
      const Vec6 d = rng.vec6(), x = k == 3 ? Vec6(0.7 * d) : rng.vec6();
      SCOPED_TRACE(trace_msg(theta, Om) + ", x = " + str(x));
      const double scale = std::max(1.0, Om.norm() * Om.norm()) * x.norm() * std::max(1.0, d.norm());
      EXPECT_LT((dexp_apply(Om, x) - dexp(Om) * x).norm() / scale, 1e-13);
      EXPECT_LT((ddexp_apply(Om, d, x) - ddexp(Om, d) * x).norm() / scale, 1e-13);
      const double sx = std::max(1.0, Om.norm() * Om.norm()) * x.norm() * std::max(1.0, x.norm());
      EXPECT_LT((ddexp_apply_self(Om, x) - ddexp(Om, Vec6(-x)) * x).norm() / sx, 1e-13);
    }
  }
}

// =============================================================================================
// 4. Scalar coefficients against independent long-double references, and their continuity at the
// series/closed-form switches.
//
// Tolerance 1e-14 relative (~45 eps): the implementation evaluates either a 16-term Horner series
// in t^2 or a closed form whose numerator cancels by at most ~10x above the switch points, i.e.
// a few eps up to ~1e-15 (observed maximum 5.8e-16). The references are required to be good to
// 1e-16 by their own error bounds (checked below; observed bound <= 1.4e-17), so they contribute
// at most 1% of the tolerance.
constexpr double kTolCoef = 1e-14;
constexpr double kTolRef = 1e-16;

TEST(LieCoefficients, ReferenceSeriesIsSelfConsistent) {
  for (const CoefSpec& c : coef_specs()) {
    SCOPED_TRACE(c.name);
    const Series s = numerator_series(c);
    // N(t) must vanish to order t^m for the division by t^m (a check on the transcription).
    for (int k = 0; k < c.m; ++k) EXPECT_LE(std::fabs(s.a[k]), 16 * kUld * s.a_abs[k]) << "k = " << k;
    EXPECT_NEAR(static_cast<double>(s.a[c.m] / c.value_at_zero), 1.0, 4 * kEps);
  }
  // d3 = c3'/t = c1'/t^3 and d4 = c4'/t = c2'/t^3, compared coefficient by coefficient in t.
  auto find = [](const char* n) {
    for (const CoefSpec& c : coef_specs())
      if (std::string(c.name) == n) return c;
    ADD_FAILURE() << "no coefficient " << n;
    return coef_specs()[0];
  };
  auto deriv_over_tp = [](const CoefSpec& c, int p, int j) {  // coefficient of t^j in f'(t)/t^p
    const Series s = numerator_series(c);
    const int i = j + p + 1;  // f = sum a[m + i] t^i, f' = sum i a[m + i] t^{i-1}
    return i * s.a[c.m + i];
  };
  const CoefSpec c1 = find("c1"), c2 = find("c2"), c3 = find("c3"), c4 = find("c4"), d3 = find("d3"),
                 d4 = find("d4");
  const Series s3 = numerator_series(d3), s4 = numerator_series(d4);
  for (int j = 0; j < 40; ++j) {
    const long double r3 = s3.a[d3.m + j], r4 = s4.a[d4.m + j];
    // Each coefficient carries ~(k + 4) roundings of its contributions: 64 u |contributions|.
    const long double tol3 = 64 * kUld * s3.a_abs[d3.m + j], tol4 = 64 * kUld * s4.a_abs[d4.m + j];
    EXPECT_LE(std::fabs(deriv_over_tp(c3, 1, j) - r3), tol3) << "d3 vs c3'/t, j = " << j;
    EXPECT_LE(std::fabs(deriv_over_tp(c1, 3, j) - r3), tol3) << "d3 vs c1'/t^3, j = " << j;
    EXPECT_LE(std::fabs(deriv_over_tp(c4, 1, j) - r4), tol4) << "d4 vs c4'/t, j = " << j;
    EXPECT_LE(std::fabs(deriv_over_tp(c2, 3, j) - r4), tol4) << "d4 vs c2'/t^3, j = " << j;
  }
}

TEST(LieCoefficients, MatchHighPrecisionReferences) {
  std::vector<double> ts = {0.0, 1e-8, 1e-4 * (1 - 1e-9), 1e-4, 1e-4 * (1 + 1e-9), 1e-2, 0.5, 1.0, kPi, 10.0};
  for (double s : switch_points()) {
    ts.push_back(s * (1.0 - 1e-9));
    ts.push_back(std::nextafter(s, 0.0));
    ts.push_back(s);
    ts.push_back(s * (1.0 + 1e-9));
  }
  // just below the angles where the series drop terms (lie.cpp, series_terms: t^2 = 0.25, 1,
  // 2.25), where the fewest terms meet the largest angle
  for (double b : {0.5, 1.0, 1.5}) ts.push_back(std::nextafter(b, 0.0));
  for (const CoefSpec& c : coef_specs()) {
    for (double t : ts) {
      SCOPED_TRACE(std::string(c.name) + " at t = " + num(t));
      const Ref ref = coefficient_ref(c, t);
      const double r = static_cast<double>(ref.value);
      ASSERT_LT(static_cast<double>(ref.err / std::fabs(ref.value)), kTolRef) << "reference not accurate";
      EXPECT_LT(std::fabs(c.f(t) - r) / std::fabs(r), kTolCoef) << "got " << c.f(t) << ", expected " << r;
    }
  }
}

// Where the series drop terms (series_terms in lie.cpp) the value moves by no more than round-off.
TEST(LieCoefficients, ContinuousWhereTheSeriesDropTerms) {
  for (const CoefSpec& c : coef_specs())
    for (double b : {0.5, 1.0, 1.5}) {
      if (c.switch_point != 0.0 && b >= c.switch_point) continue;  // the closed form there
      SCOPED_TRACE(std::string(c.name) + " at " + num(b));
      EXPECT_LT(std::fabs(c.f(b) - c.f(std::nextafter(b, 0.0))) / std::fabs(c.f(b)), 4e-16);
    }
}

TEST(LieCoefficients, ContinuousAcrossSwitches) {
  for (const CoefSpec& c : coef_specs()) {
    if (c.switch_point == 0.0) continue;
    const double s = c.switch_point;
    SCOPED_TRACE(std::string(c.name) + " switch at " + num(s));
    // Over +-1e-9 relative the true function moves by ~1e-9; subtract the reference's change so
    // that only the jump of the implementation remains.
    const double lo = s * (1.0 - 1e-9), hi = s * (1.0 + 1e-9);
    const double jump = (c.f(hi) - c.f(lo)) -
                        static_cast<double>(coefficient_ref(c, hi).value - coefficient_ref(c, lo).value);
    EXPECT_LT(std::fabs(jump) / std::fabs(c.f(s)), kTolCoef);
    // Over one ulp the true change is ~1e-16 relative: the raw difference is the jump.
    const double below = c.f(std::nextafter(s, 0.0));
    EXPECT_LT(std::fabs(c.f(s) - below) / std::fabs(c.f(s)), kTolCoef);
  }
}

// =============================================================================================
// 5. Group identities at the identity, at a 1e-8 tangent and at random elements.
//
// Tolerance 2e-14 relative (~90 eps) for products / inverses of O(1)..O(10) matrices (|u| up to ~5
// enters Ad through u~R; the 6x6 LU inverse adds cond(Ad) ~ 10); observed maximum 1.6e-15.
// Identities that are exact rearrangements use exact equality or a few eps.
constexpr double kTolId = 2e-14;

std::vector<Vec6> identity_test_points() {
  Rng rng(5);
  std::vector<Vec6> xs = {Vec6::Zero(), 1e-8 * rng.vec6(), 1e-8 * rng.vec6()};
  for (int i = 0; i < 12; ++i) xs.push_back(random_twist(rng, rng.uniform(0.0, 3.0), 2.0));
  return xs;
}

TEST(LieIdentities, GroupAndAdjointIdentities) {
  const std::vector<Vec6> xs = identity_test_points();
  Rng rng(6);
  for (size_t i = 0; i < xs.size(); ++i) {
    const Vec6& x = xs[i];
    const Vec6& y = xs[(i + 1) % xs.size()];
    SCOPED_TRACE(trace_msg(x.head<3>().norm(), x));
    const SE3 g = exp_se3(x), h = exp_se3(y);
    const Mat6 I6 = Mat6::Identity();

    // Principal log inverts exp for |k| < pi (here |k| <= 3); relative to |x|, as the log is
    // well conditioned there; 1e-13 allows the acos-based angle, whose error grows like
    // eps / (pi - t)^2 ~ 1e-14 at t = 3 (observed 1.3e-14). x = 0 must give exactly 0.
    EXPECT_LE((log_se3(g) - x).norm(), 1e-13 * x.norm());

    // SE3 struct operations against 4x4 matrices.
    EXPECT_LT(rel_err(to_mat(g * h), Mat4(to_mat(g) * to_mat(h))), kTolId);
    EXPECT_LT(rel_err(to_mat(g.inverse()), Mat4(to_mat(g).inverse())), kTolId);
    const Vec3 pt = rng.vec3(2.0);
    EXPECT_LT((g.act(pt) - (to_mat(g) * pt.homogeneous()).head<3>()).norm(), kTolId * (1 + pt.norm()));
    // exp(x) exp(-x) = identity.
    EXPECT_LT(rel_err(to_mat(g * exp_se3(Vec6(-x))), Mat4::Identity()), kTolId);

    // Adjoint maps.
    EXPECT_LT(rel_err(Ad(g), Ad_ref(to_mat(g))), 4 * kEps);
    EXPECT_LT(rel_err(Mat6(Ad(g) * Ad_inv(g)), I6), kTolId);
    EXPECT_LT(rel_err(Ad_inv(g), Ad(g.inverse())), kTolId);
    EXPECT_LT(rel_err(coAd(g), Mat6(Ad(g).inverse().transpose())), kTolId);
    EXPECT_LT(rel_err(Ad(g * h), Mat6(Ad(g) * Ad(h))), kTolId);
    EXPECT_EQ(coad(x), Mat6(-ad(x).transpose()));  // pure sign/transposition of the same entries

    // Fast actions equal the matrix forms (same products, different summation order).
    const Vec6 e = rng.vec6(2.0), F = rng.vec6(2.0);
    EXPECT_LT(rel_err(Ad_inv_apply(g, e), Vec6(Ad_inv(g) * e)), kTolId);
    EXPECT_LT(rel_err(coAd_apply(g, F), Vec6(coAd(g) * F)), kTolId);
    EXPECT_LT(rel_err(ad_apply(x, e), Vec6(ad_ref(x) * e)), kTolId);
    EXPECT_LT(rel_err(coad_apply(x, F), Vec6(-ad_ref(x).transpose() * F)), kTolId);
    for (int r = 0; r < 6; ++r)  // the columns of ad, entry for entry (each a component or its negative)
      EXPECT_EQ(ad_column(x, r), Vec6(ad_ref(x).col(r))) << "column " << r;

    // Unit quaternion with the same rotation, w >= 0 (the convention of quat_from_matrix).
    const Eigen::Vector4d q = quat_from_matrix(g.R);
    EXPECT_NEAR(q.norm(), 1.0, 4 * kEps);
    EXPECT_GE(q[0], 0.0);
    EXPECT_LT(rel_err(rotation_of_quaternion(q), g.R), 1e-14);  // ~10 eps: normalised + 2 products
  }
}

// log_se3 near theta = pi (its near-pi branch starts at pi - 1e-3). The sign of the axis is
// ambiguous at pi, so exp(log(g)) is compared with g; below pi - 1e-6 the log is unique and well
// conditioned (|d log| <= pi/2 |dR|), so the vector itself is compared too.
// Tolerance 1e-12 relative: the rotation log is well conditioned up to pi. Taking the angle as
// atan2(|antisym(R)|, (tr R - 1)/2), the axis from antisym(R) / sin t below pi - 1e-3 (error
// ~eps / sin t <= 2e-13 there) and from n n^T = (sym(R) - cos t I) / (1 - cos t) above, a scratch
// implementation reproduced g and x to <= 2e-13 (1e-15 away from the switch) over 1000 random
// samples per theta.
TEST(LieIdentities, LogNearPi) {
  Rng rng(7);
  const std::vector<double> thetas = {kPi - 1e-2,         kPi - 1e-3 * (1 + 1e-9), kPi - 1e-3,
                                      kPi - 1e-3 * (1 - 1e-9), kPi - 1e-4, kPi - 1e-6,
                                      kPi - 1e-9,         kPi};
  for (double theta : thetas) {
    for (int trial = 0; trial < 4; ++trial) {
      const Vec6 x = random_twist(rng, theta, 2.0);
      SCOPED_TRACE(trace_msg(theta, x));
      const SE3 g = exp_se3(x);
      const Vec6 l = log_se3(g);
      EXPECT_LE(l.head<3>().norm(), kPi + 1e-12);  // principal branch
      EXPECT_LT(rel_err(to_mat(exp_se3(l)), to_mat(g)), 1e-12) << "log = " << str(l);
      if (kPi - theta >= 1e-6) {  // unique log: compare the vector too
        EXPECT_LT((l - x).norm() / x.norm(), 1e-12) << "log = " << str(l);
      }
      const Eigen::Vector4d q = quat_from_matrix(g.R);
      EXPECT_LT(rel_err(rotation_of_quaternion(q), g.R), 1e-14);
    }
  }
}

// =============================================================================================
// 6. Physics: the body velocity of g(t) = exp(Omega0 + t Omega_dot) is g^-1 g' =
// (dexp(-Omega) Omega_dot)^, and the spatial velocity g' g^-1 = (dexp(Omega) Omega_dot)^.
//
// g' by central differences with h = 1e-5: truncation ~h^2 |g'''| / 6 ~ 1e-10 |Omega_dot|^3-ish,
// rounding ~eps |g| / h ~ 1e-10 for |u| ~ 5. Tolerance 1e-8 relative (observed 1.5e-10).
TEST(LiePhysics, BodyVelocityIsDexpOfMinusOmega) {
  Rng rng(8);
  for (double theta : kThetas) {
    for (int trial = 0; trial < 3; ++trial) {
      const Vec6 x = random_twist(rng, theta, 2.0);
      const Vec6 xd = rng.vec6();
      SCOPED_TRACE(trace_msg(theta, x));
      const double h = 1e-5;
      const Mat4 g = to_mat(exp_se3(x));
      const Mat4 gdot = (to_mat(exp_se3(Vec6(x + h * xd))) - to_mat(exp_se3(Vec6(x - h * xd)))) / (2 * h);
      const Mat4 body = g.inverse() * gdot, spatial = gdot * g.inverse();
      // Both must be elements of se(3): zero last row, antisymmetric rotation block.
      const double scale = std::max(1.0, body.norm());
      EXPECT_LT(body.row(3).norm() / scale, 1e-8);
      EXPECT_LT((body.topLeftCorner<3, 3>() + body.topLeftCorner<3, 3>().transpose()).norm() / scale, 1e-8);
      EXPECT_LT(rel_err(vee_ref(body), Vec6(dexp(Vec6(-x)) * xd)), 1e-8);
      EXPECT_LT(rel_err(vee_ref(spatial), Vec6(dexp(x) * xd)), 1e-8);
    }
  }
}

}  // namespace
}  // namespace cosserat
