// SE(3) operations; see lie.hpp for conventions. Formulas: DESIGN.md sections 3 and 4.
#include "lie.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace cosserat {

int check_eigen_layout(int static_align, int heap_align) {
  if (static_align == EIGEN_MAX_STATIC_ALIGN_BYTES && heap_align == EIGEN_DEFAULT_ALIGN_BYTES) return 0;
  std::fprintf(stderr,
               "cosserat: this program was compiled with Eigen alignments of %d bytes (fixed-size) and %d "
               "(heap), the cosserat libraries with %d and %d: their structs would not match (memory "
               "corruption). Compile it with the libraries' instruction-set flags (%s), e.g. by linking "
               "the CMake targets cosserat_core / cosserat_mujoco, which pass them on, or rebuild the "
               "libraries to match (cmake -DCOSSERAT_NATIVE=OFF for the baseline instruction set).\n",
               static_align, heap_align, EIGEN_MAX_STATIC_ALIGN_BYTES, EIGEN_DEFAULT_ALIGN_BYTES,
#ifdef __AVX2__
               "-march=x86-64-v3"
#else
               "no -march, or -march=x86-64"
#endif
  );
  std::_Exit(EXIT_FAILURE);  // (before static destructors and atexit handlers: nothing is safe to run)
}

namespace {
// Taylor coefficients in theta^2 of each closed form (exact rationals from sympy, 16 terms).
// The switch points were chosen so that, in double precision, series below and closed form above
// are both within ~1e-15 relative error of 50-digit references on (0, 6].
constexpr double k_a3[] = {
    1.0 / 6.0,
    -1.0 / 120.0,
    1.0 / 5040.0,
    -1.0 / 362880.0,
    1.0 / 39916800.0,
    -1.0 / 6227020800.0,
    1.0 / 1307674368000.0,
    -1.0 / 355687428096000.0,
    1.0 / 121645100408832000.0,
    -1.0 / 51090942171709440000.0,
    1.0 / 25852016738884976640000.0,
    -1.0 / 15511210043330985984000000.0,
    1.0 / 10888869450418352160768000000.0,
    -1.0 / 8841761993739701954543616000000.0,
    1.0 / 8222838654177922817725562880000000.0,
    -1.0 / 8683317618811886495518194401280000000.0};
constexpr double k_c1[] = {
    1.0 / 2.0,
    0.0,
    -1.0 / 720.0,
    1.0 / 20160.0,
    -1.0 / 1209600.0,
    1.0 / 119750400.0,
    -1.0 / 17435658240.0,
    1.0 / 3487131648000.0,
    -1.0 / 914624815104000.0,
    1.0 / 304112751022080000.0,
    -1.0 / 124888969753067520000.0,
    1.0 / 62044840173323943936000.0,
    -1.0 / 36662860102418694144000000.0,
    1.0 / 25407362050976155041792000000.0,
    -1.0 / 20404066139399312202792960000000.0,
    1.0 / 18795059780978109297658429440000000.0};
constexpr double k_c2[] = {
    1.0 / 6.0,
    0.0,
    -1.0 / 5040.0,
    1.0 / 181440.0,
    -1.0 / 13305600.0,
    1.0 / 1556755200.0,
    -1.0 / 261534873600.0,
    1.0 / 59281238016000.0,
    -1.0 / 17377871486976000.0,
    1.0 / 6386367771463680000.0,
    -1.0 / 2872446304320552960000.0,
    1.0 / 1551121004333098598400000.0,
    -1.0 / 989897222765304741888000000.0,
    1.0 / 736813499478308496211968000000.0,
    -1.0 / 632526050321378678286581760000000.0,
    1.0 / 620236972772277606822728171520000000.0};
constexpr double k_c3[] = {
    1.0 / 24.0,
    -1.0 / 360.0,
    1.0 / 13440.0,
    -1.0 / 907200.0,
    1.0 / 95800320.0,
    -1.0 / 14529715200.0,
    1.0 / 2988969984000.0,
    -1.0 / 800296713216000.0,
    1.0 / 270322445352960000.0,
    -1.0 / 112400072777760768000.0,
    1.0 / 56404400157567221760000.0,
    -1.0 / 33607621760550469632000000.0,
    1.0 / 23452949585516450807808000000.0,
    -1.0 / 18946632843727932759736320000000.0,
    1.0 / 17542055795579568677814534144000000.0,
    -1.0 / 18452049939975258802976163102720000000.0};
constexpr double k_c4[] = {
    1.0 / 120.0,
    -1.0 / 2520.0,
    1.0 / 120960.0,
    -1.0 / 9979200.0,
    1.0 / 1245404160.0,
    -1.0 / 217945728000.0,
    1.0 / 50812489728000.0,
    -1.0 / 15205637551104000.0,
    1.0 / 5676771352412160000.0,
    -1.0 / 2585201673888497664000.0,
    1.0 / 1410110003939180544000000.0,
    -1.0 / 907405787534862680064000000.0,
    1.0 / 680135537979977073426432000000.0,
    -1.0 / 587345618155565915551825920000000.0,
    1.0 / 578887841254125766367879626752000000.0,
    -1.0 / 645821747899134058104165708595200000000.0};
constexpr double k_d3[] = {
    -1.0 / 180.0,
    1.0 / 3360.0,
    -1.0 / 151200.0,
    1.0 / 11975040.0,
    -1.0 / 1452971520.0,
    1.0 / 249080832000.0,
    -1.0 / 57164050944000.0,
    1.0 / 16895152834560000.0,
    -1.0 / 6244448487653376000.0,
    1.0 / 2820220007878361088000.0,
    -1.0 / 1527619170934112256000000.0,
    1.0 / 977206232729852116992000000.0,
    -1.0 / 728716647835689721528320000000.0,
    1.0 / 626501992699270309921947648000000.0,
    -1.0 / 615068331332508626765872103424000000.0,
    1.0 / 683811262481436061522057809100800000000.0};
constexpr double k_d4[] = {
    -1.0 / 1260.0,
    1.0 / 30240.0,
    -1.0 / 1663200.0,
    1.0 / 155675520.0,
    -1.0 / 21794572800.0,
    1.0 / 4234374144000.0,
    -1.0 / 1086116967936000.0,
    1.0 / 354798209525760000.0,
    -1.0 / 143622315216027648000.0,
    1.0 / 70505500196959027200000.0,
    -1.0 / 41245717615221030912000000.0,
    1.0 / 28338980749165711392768000000.0,
    -1.0 / 22590216082906381367377920000000.0,
    1.0 / 20674565759075920227424272384000000.0,
    -1.0 / 21527391596637801936805523619840000000.0,
    1.0 / 25301016711813134276316138936729600000000.0};

// Terms of the series above that reach below 1e-17 of every coefficient's value for t^2 below
// each bound (their tails, summed in absolute value, need 8, 9 and 11 terms at t^2 = 0.25, 1 and
// 2.25: one more is kept); the small angles of short sections' steps take half the work of 16 terms.
template <int N>
int series_terms(double t2) {
  static_assert(N >= 16, "the bounds below assume 16-term series");
  return t2 < 0.25 ? 9 : t2 < 1.0 ? 11 : t2 < 2.25 ? 13 : N;
}

template <int N>
double horner(const double (&c)[N], double t2) {
  const int n = series_terms<N>(t2);
  double r = c[n - 1];
  for (int i = n - 2; i >= 0; --i) r = r * t2 + c[i];
  return r;
}
}  // namespace

namespace lie_coefficients {
const double switch_a3 = 1.5, switch_c1 = 1.5, switch_c2 = 2.5, switch_c3 = 2.3, switch_c4 = 2.2,
             switch_d3 = 3.0, switch_d4 = 3.5;
}  // namespace lie_coefficients

namespace {
// sin t and cos t of one angle, evaluated once (on first use) for all the closed forms an operator
// needs: dexp has four coefficients and ddexp six, each with sin t and cos t above its switch.
// (One sincos gives the same values as separate sin and cos calls.)
class Trig {
 public:
  explicit Trig(double t) : t(t) {}
  const double t;
  double sin() {
    eval();
    return s_;
  }
  double cos() {
    eval();
    return c_;
  }

 private:
  void eval() {
    if (done_) return;
    ::sincos(t, &s_, &c_);
    done_ = true;
  }
  double s_ = 0.0, c_ = 0.0;
  bool done_ = false;
};

// sin t / t has no cancellation; only t = 0 itself needs care (series below 1e-4: error t^4/120).
double a1(Trig& T) { return T.t < 1e-4 ? 1.0 - T.t * T.t / 6.0 : T.sin() / T.t; }
double a3(Trig& T) {
  const double t = T.t;
  return t < lie_coefficients::switch_a3 ? horner(k_a3, t * t) : (t - T.sin()) / (t * t * t);
}
double c1(Trig& T) {
  const double t = T.t;
  return t < lie_coefficients::switch_c1 ? horner(k_c1, t * t)
                                         : (4.0 - 4.0 * T.cos() - t * T.sin()) / (2.0 * t * t);
}
double c2(Trig& T) {
  const double t = T.t;
  return t < lie_coefficients::switch_c2 ? horner(k_c2, t * t)
                                         : (4.0 * t - 5.0 * T.sin() + t * T.cos()) / (2.0 * t * t * t);
}
double c3(Trig& T) {
  const double t = T.t, t2 = t * t;
  return t < lie_coefficients::switch_c3 ? horner(k_c3, t2) : (2.0 - 2.0 * T.cos() - t * T.sin()) / (2.0 * t2 * t2);
}
double c4(Trig& T) {
  const double t = T.t, t2 = t * t;
  return t < lie_coefficients::switch_c4 ? horner(k_c4, t2)
                                         : (2.0 * t - 3.0 * T.sin() + t * T.cos()) / (2.0 * t2 * t2 * t);
}
double d3(Trig& T) {
  const double t = T.t, t2 = t * t;
  return t < lie_coefficients::switch_d3
             ? horner(k_d3, t2)
             : (-t2 * T.cos() + 5.0 * t * T.sin() + 8.0 * T.cos() - 8.0) / (2.0 * t2 * t2 * t2);
}
double d4(Trig& T) {
  const double t = T.t, t2 = t * t;
  return t < lie_coefficients::switch_d4
             ? horner(k_d4, t2)
             : (-t2 * T.sin() - 7.0 * t * T.cos() - 8.0 * t + 15.0 * T.sin()) / (2.0 * t2 * t2 * t2 * t);
}

// c1..c4, and d3 and d4 when asked, of one angle. Below every switch (t < 1.5) their 16-term series
// run in lockstep: six independent Horner chains the CPU overlaps, where one call after another
// each chain waited on its own latency (the coefficients were 6% of a short rod's step, more than
// the exponentials' sincos). The same operations in the same order: bit for bit c1(T)..d4(T).
struct Coefficients {
  double C1, C2, C3, C4, D3 = 0.0, D4 = 0.0;
};
Coefficients coefficients(Trig& T, bool with_d) {
  using namespace lie_coefficients;
  const double t = T.t;
  constexpr int N = sizeof(k_c1) / sizeof(double);
  static_assert(N == sizeof(k_c2) / sizeof(double) && N == sizeof(k_c3) / sizeof(double) &&
                    N == sizeof(k_c4) / sizeof(double) && N == sizeof(k_d3) / sizeof(double) &&
                    N == sizeof(k_d4) / sizeof(double),
                "lockstep series need equal lengths");
  const double lowest = std::min({switch_c1, switch_c2, switch_c3, switch_c4, switch_d3, switch_d4});
  Coefficients k;
  if (t >= lowest) {
    k.C1 = c1(T), k.C2 = c2(T), k.C3 = c3(T), k.C4 = c4(T);
    if (with_d) k.D3 = d3(T), k.D4 = d4(T);
    return k;
  }
  const double t2 = t * t;
  const int n = series_terms<N>(t2);
  double r1 = k_c1[n - 1], r2 = k_c2[n - 1], r3 = k_c3[n - 1], r4 = k_c4[n - 1];
  if (with_d) {
    double r5 = k_d3[n - 1], r6 = k_d4[n - 1];
    for (int i = n - 2; i >= 0; --i) {
      r1 = r1 * t2 + k_c1[i], r2 = r2 * t2 + k_c2[i], r3 = r3 * t2 + k_c3[i];
      r4 = r4 * t2 + k_c4[i], r5 = r5 * t2 + k_d3[i], r6 = r6 * t2 + k_d4[i];
    }
    k.D3 = r5, k.D4 = r6;
  } else {
    for (int i = n - 2; i >= 0; --i)
      r1 = r1 * t2 + k_c1[i], r2 = r2 * t2 + k_c2[i], r3 = r3 * t2 + k_c3[i], r4 = r4 * t2 + k_c4[i];
  }
  k.C1 = r1, k.C2 = r2, k.C3 = r3, k.C4 = r4;
  return k;
}
}  // namespace

namespace lie_coefficients {

double a1(double t) {
  Trig T(t);
  return cosserat::a1(T);
}
// 2 sin^2(t/2) / t^2 avoids the cancellation of 1 - cos t entirely.
double a2(double t) {
  if (t < 1e-4) return 0.5 - t * t / 24.0;
  const double s = std::sin(0.5 * t) / t;
  return 2.0 * s * s;
}
double a3(double t) {
  Trig T(t);
  return cosserat::a3(T);
}
double c1(double t) {
  Trig T(t);
  return cosserat::c1(T);
}
double c2(double t) {
  Trig T(t);
  return cosserat::c2(T);
}
double c3(double t) {
  Trig T(t);
  return cosserat::c3(T);
}
double c4(double t) {
  Trig T(t);
  return cosserat::c4(T);
}
double d3(double t) {
  Trig T(t);
  return cosserat::d3(T);
}
double d4(double t) {
  Trig T(t);
  return cosserat::d4(T);
}
}  // namespace lie_coefficients

namespace lc = lie_coefficients;

Mat4 SE3::matrix() const {
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() = R;
  m.topRightCorner<3, 1>() = u;
  return m;
}

Mat3 skew(const Vec3& a) {
  Mat3 m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

Vec3 unskew(const Mat3& A) {
  return 0.5 * Vec3(A(2, 1) - A(1, 2), A(0, 2) - A(2, 0), A(1, 0) - A(0, 1));
}

Mat4 hat(const Vec6& xi) {
  Mat4 m = Mat4::Zero();
  m.topLeftCorner<3, 3>() = skew(xi.head<3>());
  m.topRightCorner<3, 1>() = xi.tail<3>();
  return m;
}

Vec6 vee(const Mat4& X) {
  Vec6 v;
  v.head<3>() = unskew(X.topLeftCorner<3, 3>());
  v.tail<3>() = X.topRightCorner<3, 1>();
  return v;
}

Mat3 exp_so3(const Vec3& k) {
  const double t = k.norm();
  const Mat3 K = skew(k);
  return Mat3::Identity() + lc::a1(t) * K + lc::a2(t) * K * K;
}

// e^{Omega^} = I + Omega^ + a2 Omega^2 + a3 Omega^3 (DESIGN.md section 4, X = 1), i.e.
// R = I + a1 k~ + a2 k~^2 and u = (I + a2 k~ + a3 k~^2) p.
SE3 exp_se3(const Vec6& Om) {
  const Vec3 k = Om.head<3>(), p = Om.tail<3>();
  const double t = k.norm();
  Trig T(t);
  const double A1 = a1(T), A2 = lc::a2(t), A3 = a3(T);
  const Vec3 kp = k.cross(p), kkp = k.cross(kp);
  SE3 g;
  const Mat3 K = skew(k);
  g.R = Mat3::Identity() + A1 * K + A2 * K * K;
  g.u = p + A2 * kp + A3 * kkp;
  return g;
}

Eigen::Vector4d quat_from_matrix(const Mat3& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
}

Vec6 log_se3(const SE3& g) {
  // Angle from atan2 (accurate everywhere, unlike acos near 0 and pi); axis from the
  // antisymmetric part, or near pi from the symmetric part n n^T = (sym(R) - c I) / (1 - c).
  const Mat3& R = g.R;
  const Vec3 s = unskew(R);  // = sin t n
  const double c = 0.5 * (R.trace() - 1.0);
  const double t = std::atan2(s.norm(), c);
  Vec3 k;
  if (t < M_PI - 1e-3) {
    k = s / lc::a1(t);  // t / sin t, finite for t < pi
  } else {
    const Mat3 nn = (0.5 * (R + R.transpose()) - c * Mat3::Identity()) / (1.0 - c);
    int i = 0;
    nn.diagonal().maxCoeff(&i);
    Vec3 n = nn.col(i) / std::sqrt(std::max(nn(i, i), 1e-300));
    n.normalize();
    if (n.dot(s) < 0) n = -n;
    k = t * n;
  }
  // u = V p with V = I + a2 k~ + a3 k~^2; solve V p = u (V is invertible for t < 2 pi).
  const double tk = k.norm();
  const Mat3 K = skew(k);
  const Mat3 V = Mat3::Identity() + lc::a2(tk) * K + lc::a3(tk) * K * K;
  Vec6 out;
  out.head<3>() = k;
  out.tail<3>() = V.partialPivLu().solve(g.u);
  return out;
}

Mat6 Ad(const SE3& g) {
  Mat6 m;
  m << g.R, Mat3::Zero(), skew(g.u) * g.R, g.R;
  return m;
}

Mat6 Ad_inv(const SE3& g) {
  const Mat3 Rt = g.R.transpose();
  Mat6 m;
  m << Rt, Mat3::Zero(), -Rt * skew(g.u), Rt;
  return m;
}

Mat6 coAd(const SE3& g) {
  Mat6 m;
  m << g.R, skew(g.u) * g.R, Mat3::Zero(), g.R;
  return m;
}

Mat6 ad(const Vec6& e) {
  const Mat3 W = skew(e.head<3>());
  Mat6 m;
  m << W, Mat3::Zero(), skew(e.tail<3>()), W;
  return m;
}

Mat6 coad(const Vec6& e) {
  const Mat3 W = skew(e.head<3>());
  Mat6 m;
  m << W, skew(e.tail<3>()), Mat3::Zero(), W;
  return m;
}

namespace {
// Every matrix below is block lower triangular with equal diagonal blocks, [[X, 0], [Y, X]]:
// ad_eta = [[w~, 0], [v~, w~]], its powers, their sums and their derivatives. With the identities
// of skew matrices a~ b~ = b a^T - (a.b) I and w~^3 = -t^2 w~ (t = |w|, s = w.v), the powers of
// A = ad_Omega = [[W, 0], [V, W]] are, block by block,
//   A^1 = (W, V)
//   A^2 = (W^2, P),                  W^2 = w w^T - t^2 I,  P = W V + V W = v w^T + w v^T - 2 s I
//   A^3 = (-t^2 W, -t^2 V - 2 s W)
//   A^4 = (-t^2 W^2, -t^2 P - 2 s W^2)
// so no 6x6 (or even 3x3) product is needed, and the coefficient of each power is unchanged.
struct Blk {
  Mat3 X, Y;
};

inline Mat6 to_mat6(const Blk& B) {
  Mat6 m;
  m.topLeftCorner<3, 3>() = B.X;
  m.topRightCorner<3, 3>().setZero();
  m.bottomLeftCorner<3, 3>() = B.Y;
  m.bottomRightCorner<3, 3>() = B.X;
  return m;
}

// a b^T + b a^T - 2 (a.b) I (= a~ b~ + b~ a~)
inline Mat3 sym_outer(const Vec3& a, const Vec3& b) {
  Mat3 m = a * b.transpose();
  m += m.transpose().eval();
  m.diagonal().array() -= 2.0 * a.dot(b);
  return m;
}
}  // namespace

Mat6 dexp(const Vec6& Om) {
  const Vec3 w = Om.head<3>(), v = Om.tail<3>();
  const double t = w.norm(), t2 = t * t, s = w.dot(v);
  Trig T(t);
  const Coefficients k = coefficients(T, false);
  const double C1 = k.C1, C2 = k.C2, C3 = k.C3, C4 = k.C4;
  const Mat3 W = skew(w), V = skew(v);
  Mat3 W2 = w * w.transpose();
  W2.diagonal().array() -= t2;
  const Mat3 P = sym_outer(w, v);
  // I + c1 A + c2 A^2 + c3 A^3 + c4 A^4
  Blk out;
  out.X = C1 * W + C2 * W2 + C3 * (-t2 * W) + C4 * (-t2 * W2);
  out.X.diagonal().array() += 1.0;
  out.Y = C1 * V + C2 * P + C3 * (-t2 * V - 2.0 * s * W) + C4 * (-t2 * P - 2.0 * s * W2);
  return to_mat6(out);
}

// d/de sum_k c_k(theta) ad^k: the coefficients change with theta (d theta = k.dk / theta, so
// dc_k = (c_k'/theta)(k.dk), with c1'/t = t^2 d3 and c2'/t = t^2 d4), and each power ad^k
// changes as E_k = sum_j ad^j ad_delta ad^{k-1-j}, the derivative of A^k along B = ad_delta: with
// the block forms of the powers above (dt^2 = 2 k.dk, ds = dk.v + k.dv),
//   E_1 = (Wd, Vd)
//   E_2 = (dW^2, dP),  dW^2 = w dw^T + dw w^T - 2 (w.dw) I,  dP = sym_outer(w, dv) + sym_outer(dw, v)
//   E_3 = (-t^2 Wd - 2 (k.dk) W, -t^2 Vd - 2 (k.dk) V - 2 ds W - 2 s Wd)
//   E_4 = (-t^2 dW^2 - 2 (k.dk) W^2, -t^2 dP - 2 (k.dk) P - 2 ds W^2 - 2 s dW^2)
// (E_2 = B A + A B, E_3 = B A^2 + A B A + A^2 B, ...).
Mat6 ddexp(const Vec6& Om, const Vec6& de) {
  const Vec3 w = Om.head<3>(), v = Om.tail<3>();
  const Vec3 dw = de.head<3>(), dv = de.tail<3>();
  const double t = w.norm(), t2 = t * t;
  const double kdk = w.dot(dw), s = w.dot(v), ds = dw.dot(v) + w.dot(dv);
  Trig T(t);
  const Coefficients k = coefficients(T, true);
  const double C1 = k.C1, C2 = k.C2, C3 = k.C3, C4 = k.C4;
  const double D3 = k.D3, D4 = k.D4, D1 = t2 * D3, D2 = t2 * D4;
  const Mat3 W = skew(w), V = skew(v), Wd = skew(dw), Vd = skew(dv);
  Mat3 W2 = w * w.transpose();
  W2.diagonal().array() -= t2;
  const Mat3 P = sym_outer(w, v);
  const Mat3 dW2 = sym_outer(w, dw);
  const Mat3 dP = sym_outer(w, dv) + sym_outer(dw, v);
  Blk out;
  // kdk (D1 A + D2 A^2 + D3 A^3 + D4 A^4)
  out.X = kdk * (D1 * W + D2 * W2 + D3 * (-t2 * W) + D4 * (-t2 * W2));
  out.Y = kdk * (D1 * V + D2 * P + D3 * (-t2 * V - 2.0 * s * W) + D4 * (-t2 * P - 2.0 * s * W2));
  // + C1 E_1 + C2 E_2 + C3 E_3 + C4 E_4
  out.X += C1 * Wd + C2 * dW2 + C3 * (-t2 * Wd - 2.0 * kdk * W) + C4 * (-t2 * dW2 - 2.0 * kdk * W2);
  out.Y += C1 * Vd + C2 * dP + C3 * (-t2 * Vd - 2.0 * kdk * V - 2.0 * ds * W - 2.0 * s * Wd) +
           C4 * (-t2 * dP - 2.0 * kdk * P - 2.0 * ds * W2 - 2.0 * s * dW2);
  return to_mat6(out);
}

// dexp(Omega) x = x + c1 A x + c2 A^2 x + c3 A^3 x + c4 A^4 x (A = ad_Omega), Horner-like.
Vec6 dexp_apply(const Vec6& Om, const Vec6& x) {
  Trig T(Om.head<3>().norm());
  const Coefficients k = coefficients(T, false);
  const double C1 = k.C1, C2 = k.C2, C3 = k.C3, C4 = k.C4;
  return x + ad_apply(Om, C1 * x + ad_apply(Om, C2 * x + ad_apply(Om, C3 * x + ad_apply(Om, C4 * x))));
}

// ddexp(Omega, delta) x without the 6 x 6 matrix: with A = ad_Omega, B = ad_delta and
// y_m = B A^m x, sum_k c_k E_k x = sum_j A^j z_j with z_j = sum_{k > j} c_k y_{k-1-j}
// (E_k = sum_j A^j B A^{k-1-j}, see ddexp), plus the coefficients' change kdk sum_k D_k A^k x.
Vec6 ddexp_apply(const Vec6& Om, const Vec6& de, const Vec6& x) {
  const Vec3 w = Om.head<3>();
  const double t = w.norm(), t2 = t * t, kdk = w.dot(de.head<3>());
  Trig T(t);
  const Coefficients k = coefficients(T, true);
  const double C1 = k.C1, C2 = k.C2, C3 = k.C3, C4 = k.C4;
  const double D3 = k.D3, D4 = k.D4, D1 = t2 * D3, D2 = t2 * D4;
  // x1..x4 = A^k x
  const Vec6 x1 = ad_apply(Om, x), x2 = ad_apply(Om, x1), x3 = ad_apply(Om, x2), x4 = ad_apply(Om, x3);
  const Vec6 y0 = ad_apply(de, x), y1 = ad_apply(de, x1), y2 = ad_apply(de, x2), y3 = ad_apply(de, x3);
  const Vec6 z3 = C4 * y0, z2 = C3 * y0 + C4 * y1, z1 = C2 * y0 + C3 * y1 + C4 * y2,
             z0 = C1 * y0 + C2 * y1 + C3 * y2 + C4 * y3;
  return z0 + ad_apply(Om, z1 + ad_apply(Om, z2 + ad_apply(Om, z3))) +
         kdk * (D1 * x1 + D2 * x2 + D3 * x3 + D4 * x4);
}

Vec6 ddexp_apply_self(const Vec6& Om, const Vec6& x) {
  // ddexp_apply with delta = -x: y_k = ad_{-x} A^k x, y0 = 0
  const Vec3 w = Om.head<3>();
  const double t = w.norm(), t2 = t * t, kdk = -w.dot(x.head<3>());
  Trig T(t);
  const Coefficients k = coefficients(T, true);
  const double C2 = k.C2, C3 = k.C3, C4 = k.C4;
  const double D3 = k.D3, D4 = k.D4, D1 = t2 * D3, D2 = t2 * D4;
  const Vec6 x1 = ad_apply(Om, x), x2 = ad_apply(Om, x1), x3 = ad_apply(Om, x2), x4 = ad_apply(Om, x3);
  const Vec6 mx = -x;
  const Vec6 y1 = ad_apply(mx, x1), y2 = ad_apply(mx, x2), y3 = ad_apply(mx, x3);
  const Vec6 z2 = C4 * y1, z1 = C3 * y1 + C4 * y2, z0 = C2 * y1 + C3 * y2 + C4 * y3;
  return z0 + ad_apply(Om, z1 + ad_apply(Om, z2)) + kdk * (D1 * x1 + D2 * x2 + D3 * x3 + D4 * x4);
}

}  // namespace cosserat
