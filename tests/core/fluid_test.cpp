// Low-Reynolds fluid (plugin/core/fluid.cpp): the composite fluid damping against direct sums
// over node Jacobians, the base coupling, resistive force theory on straight rods and on a rigid
// helix against the closed forms of RFT, and the Stokes resistance of ellipsoids against the
// closed forms for spheres and prolate spheroids.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Eigenvalues>

#include "dynamics.hpp"
#include "fluid.hpp"
#include "kinematics.hpp"
#include "support/test_models.hpp"

using namespace cosserat;
using namespace cosserat::testing;

namespace {

constexpr double kMu = 2.5;  // Pa s

// Puts Gray-Hancock drag on every rod of m.
void add_drag(Model& m) {
  RodFluid f;
  f.viscosity = kMu;
  for (size_t r = 0; r < m.rods.size(); ++r) set_rod_drag(m, static_cast<int>(r), f);
}

TEST(Fluid, CoefficientFormulas) {
  // Gray & Hancock: a = 1 mm, lambda = 20 mm: ln(2 lambda / a) = ln 40
  const RftCoefficients g = gray_hancock(kMu, 1e-3, 0.02);
  EXPECT_NEAR(g.cn, 4 * M_PI * kMu / (std::log(40.0) + 0.5), 1e-14 * g.cn);
  EXPECT_NEAR(g.ct, 2 * M_PI * kMu / (std::log(40.0) - 0.5), 1e-14 * g.ct);
  EXPECT_NEAR(g.crot, 4 * M_PI * kMu * 1e-6, 1e-20);
  EXPECT_GT(g.cn / g.ct, 1.0);  // drag anisotropy: broadside resists more
  EXPECT_LT(g.cn / g.ct, 2.0);
  const RftCoefficients l = lighthill(kMu, 1e-3, 0.05);  // q = 4.5 mm: ln(2q/a) = ln 9
  EXPECT_NEAR(l.ct, 2 * M_PI * kMu / std::log(9.0), 1e-14 * l.ct);
  EXPECT_NEAR(l.cn, 8 * M_PI * kMu / (1 + 2 * std::log(9.0)), 1e-14 * l.cn);
  EXPECT_FALSE(valid(gray_hancock(kMu, 1e-3, 0.8e-3)));  // ln(1.6) < 1/2: too thick
}

TEST(Fluid, HelixOfRestStrain) {
  // DESIGN.md section 5: [tau 0 kappa 1 0 0] has radius kappa/(kappa^2+tau^2), pitch 2 pi tau/(...)
  const double tau = 40.0, kappa = 90.0, k2 = tau * tau + kappa * kappa;
  const Helix h = helix_of((Vec6() << tau, 0, kappa, 1, 0, 0).finished());
  EXPECT_TRUE(h.helical);
  EXPECT_NEAR(h.radius, kappa / k2, 1e-15);
  EXPECT_NEAR(h.pitch, 2 * M_PI * tau / k2, 1e-15);
  EXPECT_FALSE(helix_of((Vec6() << 0, 0, 0, 1, 0, 0).finished()).helical);   // straight
  EXPECT_FALSE(helix_of((Vec6() << 0, 0, 30, 1, 0, 0).finished()).helical);  // planar circle
  EXPECT_FALSE(helix_of((Vec6() << 30, 0, 0, 1, 0, 0).finished()).helical);  // twisted straight
}

// D_fluid = sum_i J_i^T C_i J_i over the nodes (node Jacobians with a fixed base), on a tree of
// joints, rods, GVS sections and a helical rod.
TEST(Fluid, DampingEqualsSumOverNodeJacobians) {
  Model m = hybrid_tree(false);
  add_drag(m);
  ASSERT_TRUE(has_drag(m));
  Data d(m);
  d.q = 0.4 * VecX::Random(m.nv);
  fwd_position(m, d);
  fluid_damping(m, d);
  MatX ref = MatX::Zero(m.nv, m.nv), J;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    node_jacobian(m, d, static_cast<int>(i), J);
    ref.noalias() += J.transpose() * m.nodes[i].drag * J;
  }
  EXPECT_LT((d.D_fluid - ref).norm(), 1e-13 * ref.norm());
  // symmetric positive semi-definite
  EXPECT_LT((d.D_fluid - d.D_fluid.transpose()).norm(), 1e-14 * ref.norm());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<MatX>(d.D_fluid).eigenvalues().minCoeff(), -1e-12 * ref.norm());
}

// With a moving base: the generalised force and the base wrench equal -sum J^T C eta_i and
// -sum Ad*_{g_i} C eta_i with the node twists eta_i of fwd_velocity; and the base blocks equal
// the free-joint blocks of the same rod on a free joint.
TEST(Fluid, ForceAndBaseCouplingWithMovingBase) {
  RodSpec a = rod_spec("sr", 3, 1, 0.3, 0.01);
  a.radius_tip = 0.004;
  a.section.rest_strain << 12.0, 0.0, 25.0, 1.0, 0.0, 0.0;  // helical
  SE3 place(exp_so3(Vec3(0.3, 0.1, -0.2)), Vec3(0.05, 0.01, 0.0));
  auto [fixed, floating] = fixed_and_floating(a, place);
  RodFluid f;
  f.viscosity = kMu;
  const RodFluidInfo info = set_rod_drag(fixed, 0, f);
  set_rod_drag(floating, 0, f);
  EXPECT_TRUE(info.helical);
  EXPECT_NEAR(info.wavelength, std::abs(helix_of(a.section.rest_strain).pitch), 1e-15);

  Data df(fixed), dl(floating);
  df.q = 0.3 * VecX::Random(fixed.nv);
  df.v = 0.5 * VecX::Random(fixed.nv);
  df.base_twist = Vec6::Random();
  dl.q << VecX::Zero(6), df.q;
  dl.v << df.base_twist, df.v;
  for (Data* d : {&df, &dl}) {
    const Model& m = d == &df ? fixed : floating;
    fwd_position(m, *d);
    fwd_velocity(m, *d);
    fluid_damping(m, *d);
  }
  const double s = dl.D_fluid.norm();
  EXPECT_LT((dl.D_fluid.topLeftCorner(6, 6) - df.Dc_base).norm(), 1e-13 * s);
  EXPECT_LT((dl.D_fluid.topRightCorner(6, fixed.nv) - df.DF_base).norm(), 1e-13 * s);
  EXPECT_LT((dl.D_fluid.bottomRightCorner(fixed.nv, fixed.nv) - df.D_fluid).norm(), 1e-13 * s);

  VecX tau = VecX::Zero(fixed.nv), ref = VecX::Zero(fixed.nv);
  Vec6 wrench, wref = Vec6::Zero();
  add_fluid_force(fixed, df, tau, &wrench);
  MatX J;
  for (size_t i = 0; i < fixed.nodes.size(); ++i) {
    const Vec6 fi = -fixed.nodes[i].drag * df.eta[i];
    node_jacobian(fixed, df, static_cast<int>(i), J);
    ref.noalias() += J.transpose() * fi;
    wref += coAd_apply(df.g[i], fi);  // node frame -> base frame (the base pose is the identity)
  }
  EXPECT_LT((tau - ref).norm(), 1e-12 * (1 + ref.norm()));
  EXPECT_LT((wrench - wref).norm(), 1e-12 * (1 + wref.norm()));
}

// A rigid straight rod translating and spinning in the fluid: RFT's c_t L U, c_n L U, c_rot L W,
// and about its midpoint the segment resistance (c_n L^3 / 12 for a transverse rotation).
TEST(Fluid, StraightRodResistance) {
  const double L = 0.2, r = 2e-3;
  RodSpec s = rod_spec("rigid", 3, 0, L, r);
  Model m;
  m.add_rod(-1, SE3::Identity(), s);
  m.finalize();
  RodFluid f;
  f.viscosity = kMu;
  const RodFluidInfo info = set_rod_drag(m, 0, f);
  EXPECT_FALSE(info.helical);
  EXPECT_NEAR(info.wavelength, L / 2, 1e-15);  // slender body: ln(2 lambda / a) = ln(L / a)
  const RftCoefficients c = gray_hancock(kMu, r, L / 2);
  Data d(m);
  fwd_position(m, d);
  fluid_damping(m, d);
  // base frame at X = 0; move it to the midpoint: C_mid = Ad_g^T C_base Ad_g, g = (I, L/2 e_x)
  SE3 mid;
  mid.u = Vec3(L / 2, 0, 0);
  const Mat6 Cmid = Ad(mid).transpose() * d.Dc_base * Ad(mid);
  const Mat6 ref = segment_resistance(c, L, 0);
  EXPECT_LT((Cmid - ref).norm(), 1e-12 * ref.norm()) << Cmid << "\n\n" << ref;
  EXPECT_NEAR(Cmid(3, 3), c.ct * L, 1e-12 * c.ct * L);
  EXPECT_NEAR(Cmid(4, 4), c.cn * L, 1e-12 * c.cn * L);
  EXPECT_NEAR(Cmid(0, 0), c.crot * L, 1e-12 * c.crot * L);
  EXPECT_NEAR(Cmid(1, 1), c.cn * L * L * L / 12, 1e-12 * c.cn * L * L * L);
}

// A rigid helix of whole turns: about its axis, RFT gives the propulsion matrix
//   force  = -A U + B W,   torque = B U - D W   (U, W along the axis; sign of B by handedness)
// A = L (c_t cos^2 t + c_n sin^2 t), B = L R (c_n - c_t) sin t cos t,
// D = L R^2 (c_n cos^2 t + c_t sin^2 t) + L c_rot cos^2 t, t the angle between tangent and axis,
// and no lateral force from an axial motion.
TEST(Fluid, RigidHelixPropulsionMatrix) {
  const double R = 8e-3, lambda = 0.05, a = 1.5e-3;
  const double c_ = lambda / (2 * M_PI), s2 = R * R + c_ * c_;
  const double kappa = R / s2, tau = c_ / s2;
  const double turn = 2 * M_PI * std::sqrt(s2), L = 2 * turn;  // two whole turns
  for (double hand : {1.0, -1.0}) {
    RodSpec s = rod_spec("rigid", 16, 0, L, a);
    s.section.rest_strain << hand * tau, 0, kappa, 1, 0, 0;
    s.section.quadrature = 4;
    Model m;
    m.add_rod(-1, SE3::Identity(), s);
    m.finalize();
    RodFluid f;
    f.viscosity = kMu;
    const RodFluidInfo info = set_rod_drag(m, 0, f);
    ASSERT_TRUE(info.helical);
    EXPECT_NEAR(info.wavelength, lambda, 1e-12);
    const RftCoefficients c = gray_hancock(kMu, a, lambda);
    Data d(m);
    fwd_position(m, d);
    fluid_damping(m, d);
    // helix frame H: origin on the axis (base + R y), x along the axis (hand tau, 0, kappa)/|k|
    const Vec3 ax = Vec3(hand * tau, 0, kappa).normalized();
    SE3 H;
    H.R.col(0) = ax;
    H.R.col(1) = Vec3(0, 1, 0);
    H.R.col(2) = ax.cross(Vec3(0, 1, 0));
    H.u = Vec3(0, R, 0);
    const Mat6 C = Ad(H).transpose() * d.Dc_base * Ad(H);
    const double ct = c_ / std::sqrt(s2), st = R / std::sqrt(s2);  // cos and sin of t
    const double A = L * (c.ct * ct * ct + c.cn * st * st);
    const double B = L * R * (c.cn - c.ct) * st * ct;
    const double D = L * R * R * (c.cn * ct * ct + c.ct * st * st) + L * c.crot * ct * ct;
    EXPECT_NEAR(C(3, 3), A, 1e-9 * A);
    EXPECT_NEAR(C(0, 0), D, 1e-9 * D);
    // a right-handed helix (hand > 0) spun positively about its axis is pushed along +axis
    EXPECT_NEAR(C(3, 0), -hand * B, 1e-9 * B);
    for (int k : {4, 5}) {  // lateral forces (lateral torques remain: the turns are offset along the axis)
      EXPECT_NEAR(C(3, k), 0.0, 1e-9 * A) << k;
      EXPECT_NEAR(C(0, k), 0.0, 1e-9 * D / R) << k;
    }
  }
}

// Stokes resistance of ellipsoids: the sphere (6 pi mu a, 8 pi mu a^3) and the prolate spheroid
// (semi-axes a > b = b, e = sqrt(1 - b^2/a^2), L = ln((1+e)/(1-e))), closed forms of Chwang & Wu
// (1975) / Kim & Karrila (1991):
//   axial force      16 pi mu a e^3 / ((1 + e^2) L - 2e)
//   transverse force 32 pi mu a e^3 / (2e + (3e^2 - 1) L)
//   axial torque     32/3 pi mu a b^2 e^3 / (2e - (1 - e^2) L)
//   transverse torque 32/3 pi mu a^3 e^3 (2 - e^2) / ((1 + e^2) L - 2e)
TEST(Fluid, EllipsoidResistance) {
  const double r = 0.013;
  const Mat6 S = ellipsoid_resistance(kMu, Vec3(r, r, r));
  EXPECT_LT((S - sphere_resistance(kMu, r)).norm(), 1e-12 * S.norm());
  EXPECT_NEAR(S(3, 3), 6 * M_PI * kMu * r, 1e-12 * S(3, 3));
  EXPECT_NEAR(S(0, 0), 8 * M_PI * kMu * r * r * r, 1e-12 * S(0, 0));
  for (double aspect : {1.05, 2.0, 5.0, 50.0}) {
    const double b = 0.01, a = aspect * b;
    const double e = std::sqrt(1 - b * b / (a * a)), Le = std::log((1 + e) / (1 - e)), e3 = e * e * e;
    const double Fa = 16 * M_PI * kMu * a * e3 / ((1 + e * e) * Le - 2 * e);
    const double Ft = 32 * M_PI * kMu * a * e3 / (2 * e + (3 * e * e - 1) * Le);
    const double Ta = 32.0 / 3 * M_PI * kMu * a * b * b * e3 / (2 * e - (1 - e * e) * Le);
    const double Tt = 32.0 / 3 * M_PI * kMu * a * a * a * e3 * (2 - e * e) / ((1 + e * e) * Le - 2 * e);
    // the long axis along y: the result must not depend on which axis it is
    const Mat6 C = ellipsoid_resistance(kMu, Vec3(b, a, b));
    // closed forms lose digits to cancellation at small e (aspect 1.05): 1e-8 there
    const double tol = aspect < 1.5 ? 1e-8 : 1e-11;
    EXPECT_NEAR(C(4, 4), Fa, tol * Fa) << aspect;
    EXPECT_NEAR(C(3, 3), Ft, tol * Ft) << aspect;
    EXPECT_NEAR(C(5, 5), Ft, tol * Ft) << aspect;
    EXPECT_NEAR(C(1, 1), Ta, tol * Ta) << aspect;
    EXPECT_NEAR(C(0, 0), Tt, tol * Tt) << aspect;
    EXPECT_NEAR(C(2, 2), Tt, tol * Tt) << aspect;
  }
  // a slender spheroid approaches slender-body RFT with ln(L/a): the same leading logarithm
  const double b = 1e-4, a = 0.1;  // aspect 1000
  const Mat6 C = ellipsoid_resistance(kMu, Vec3(a, b, b));
  const RftCoefficients g = gray_hancock(kMu, b, a);  // lambda = L/2 = a
  EXPECT_NEAR(C(3, 3) / (2 * a * g.ct), 1.0, 0.15);
  EXPECT_NEAR(C(4, 4) / (2 * a * g.cn), 1.0, 0.15);
}

}  // namespace
