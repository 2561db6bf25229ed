// Dynamics of the node tree against finite differences and against each other
// (plugin/core/kinematics.cpp, dynamics.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "support/test_models.hpp"

using namespace cosserat;
using namespace cosserat::testing;

namespace {

void randomize(Data& d, unsigned seed, double scale = 0.5) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < d.q.size(); ++i) d.q(i) = scale * u(gen);
  for (int i = 0; i < d.v.size(); ++i) d.v(i) = scale * u(gen);
}

// Body twist of node i as the finite difference of its pose along a velocity: log(g(q)^-1 g(q+eps v))/eps.
TEST(Kinematics, NodeJacobianMatchesFiniteDifferences) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 1);
  fwd_position(m, d);
  MatX J;
  const double e = 1e-6;
  for (size_t i = 0; i < m.nodes.size(); i += 3) {
    node_jacobian(m, d, static_cast<int>(i), J);
    for (int k = 0; k < m.nv; ++k) {
      Data dp = d, dm = d;
      dp.q(k) += e;
      dm.q(k) -= e;
      fwd_position(m, dp);
      fwd_position(m, dm);
      const Vec6 fd = log_se3(dm.g[i].inverse() * dp.g[i]) / (2 * e);
      // central difference: truncation O(e^2) ~ 1e-12, round-off ~ eps/e ~ 1e-10
      EXPECT_LT((fd - J.col(k)).norm(), 1e-7 * (1 + J.col(k).norm())) << "node " << i << " dof " << k;
    }
  }
}

TEST(Kinematics, TwistEqualsJacobianTimesVelocity) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 2);
  fwd_position(m, d);
  fwd_velocity(m, d);
  MatX J;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    node_jacobian(m, d, static_cast<int>(i), J);
    EXPECT_LT((J * d.v - d.eta[i]).norm(), 1e-12 * (1 + d.eta[i].norm()));
  }
}

// fwd_velocity computes the velocity-product term Sdot v as vectors (ddexp_apply) and the matrix
// Sdot only when asked: the matrix times v is that vector (to rounding, relative 1e-12), and
// without the matrix every output is the same bit for bit. PCS (steps sharing one step's rates) and
// GVS (the commutator) rods.
TEST(Kinematics, SdotMatrixTimesVelocityIsTheVectorTerm) {
  Model pcs;
  pcs.add_rod(-1, SE3::Identity(), rod_spec("sr", 3, 0));
  pcs.finalize();
  std::vector<Model> models;
  models.push_back(std::move(pcs));
  models.push_back(hybrid_tree());
  for (Model& model : models) {
    const Model* m = &model;
    Data d(*m), e(*m);
    randomize(d, 7, 1.5);
    e.q = d.q;
    e.v = d.v;
    fwd_position(*m, d);
    fwd_position(*m, e);
    fwd_velocity(*m, d, true);
    fwd_velocity(*m, e, false);
    double largest = 0.0;  // (a joint's Sdot is zero; the rods' are not)
    for (size_t i = 0; i < m->nodes.size(); ++i) {
      const Node& n = m->nodes[i];
      EXPECT_EQ(d.cbias[i], e.cbias[i]) << "node " << i;
      EXPECT_EQ(d.eta[i], e.eta[i]) << "node " << i;
      if (n.ndof == 0) continue;
      const Vec6 mv = d.Sdot[i] * d.v.segment(n.dof0, n.ndof);
      EXPECT_LT((mv - d.Sdot_v[i]).norm(), 1e-12 * (1 + mv.norm())) << "node " << i;
      largest = std::max(largest, mv.norm());
    }
    EXPECT_GT(largest, 1e-5);
  }
}

// J-dot v = d/dt (J(q) v) at constant v: central difference along q + t v.
TEST(Kinematics, JdotVMatchesFiniteDifferences) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 3);
  fwd_position(m, d);
  fwd_velocity(m, d);
  const double e = 1e-6;
  Data dp = d, dm = d;
  dp.q += e * d.v;
  dm.q -= e * d.v;
  fwd_position(m, dp);
  fwd_position(m, dm);
  MatX Jp, Jm;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    node_jacobian(m, dp, static_cast<int>(i), Jp);
    node_jacobian(m, dm, static_cast<int>(i), Jm);
    const Vec6 fd = (Jp - Jm) * d.v / (2 * e);
    const Vec6 an = node_jdot_v(m, d, static_cast<int>(i));
    EXPECT_LT((fd - an).norm(), 1e-7 * (1 + an.norm())) << "node " << i;
  }
}

TEST(Kinematics, RodJacobianAtAnyAbscissaMatchesFiniteDifferences) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 4);
  fwd_position(m, d);
  MatX J;
  const double e = 1e-6;
  for (int r = 0; r < static_cast<int>(m.rods.size()); ++r) {
    for (double f : {0.0, 0.13, 0.5, 0.77, 1.0}) {
      const double X = f * m.rods[r].length;
      rod_jacobian(m, d, r, X, J);
      const SE3 g0 = rod_pose(m, d, r, X);
      for (int k = 0; k < m.nv; ++k) {
        Data dp = d, dm = d;
        dp.q(k) += e;
        dm.q(k) -= e;
        fwd_position(m, dp);
        fwd_position(m, dm);
        const Vec6 fd = log_se3(rod_pose(m, dm, r, X).inverse() * rod_pose(m, dp, r, X)) / (2 * e);
        EXPECT_LT((fd - J.col(k)).norm(), 1e-7 * (1 + J.col(k).norm())) << "rod " << r << " X " << X;
      }
      (void)g0;
    }
  }
}

TEST(Kinematics, RodPoseAtNodesEqualsNodePose) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 5);
  fwd_position(m, d);
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    if (m.nodes[i].rod < 0) continue;
    const SE3 g = rod_pose(m, d, m.nodes[i].rod, m.nodes[i].X);
    EXPECT_LT((g.matrix() - d.g[i].matrix()).norm(), 1e-12);
  }
}

TEST(Dynamics, MassMatrixSymmetricPositiveDefiniteAndEqualsSumJtMJ) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 6);
  fwd_position(m, d);
  crba(m, d);
  EXPECT_LT((d.M - d.M.transpose()).norm(), 1e-14 * d.M.norm());
  Eigen::SelfAdjointEigenSolver<MatX> es(d.M);
  EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
  MatX ref = MatX::Zero(m.nv, m.nv), J;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    node_jacobian(m, d, static_cast<int>(i), J);
    ref += J.transpose() * m.nodes[i].inertia * J;
  }
  EXPECT_LT((ref - d.M).norm(), 1e-12 * d.M.norm());
}

TEST(Dynamics, InverseDynamicsConsistentWithForwardDynamics) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 7);
  d.ctrl << 0.7, 0.02;
  d.f_ext_world[m.rods[1].tip_node] << 0.001, 0.0, 0.0, 0.0, 0.05, -0.1;
  forward(m, d);
  // rnea at the computed acceleration must return the applied forces
  VecX tau(m.nv);
  rnea(m, d, d.qacc, true, true, tau);
  const VecX applied = d.qfrc_passive + d.qfrc_actuator;
  EXPECT_LT((tau - applied).norm(), 1e-9 * (1 + applied.norm()));
  // and rnea is affine in qacc with slope M
  VecX tau0(m.nv), a = VecX::Random(m.nv);
  rnea(m, d, VecX::Zero(m.nv), true, true, tau0);
  rnea(m, d, a, true, true, tau);
  EXPECT_LT((tau - tau0 - d.M * a).norm(), 1e-10 * (1 + (d.M * a).norm()));
}

// Lagrange's equations from the energy: the bias at v = 0 with gravity is dU/dq.
TEST(Dynamics, GravityForceIsGradientOfPotential) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 8);
  d.v.setZero();
  fwd_position(m, d);
  fwd_velocity(m, d);
  VecX tau(m.nv);
  rnea(m, d, VecX::Zero(m.nv), true, false, tau);
  const double e = 1e-6;
  for (int k = 0; k < m.nv; ++k) {
    Data dp = d, dm = d;
    dp.q(k) += e;
    dm.q(k) -= e;
    fwd_position(m, dp);
    fwd_velocity(m, dp);
    fwd_position(m, dm);
    fwd_velocity(m, dm);
    const double fd = (energy(m, dp).gravity - energy(m, dm).gravity) / (2 * e);
    EXPECT_NEAR(fd, tau(k), 1e-7 * (1 + std::abs(tau(k))));
  }
}

// The cable's generalised force is -T dl/dq: compare with a finite difference of the length.
TEST(Dynamics, CableForceIsMinusTensionTimesLengthGradient) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 9, 0.3);
  fwd_position(m, d);
  VecX grad;
  cable_length(m, d, 0, &grad);
  const double e = 1e-6;
  for (int k = 0; k < m.nv; ++k) {
    Data dp = d, dm = d;
    dp.q(k) += e;
    dm.q(k) -= e;
    const double fd = (cable_length(m, dp, 0) - cable_length(m, dm, 0)) / (2 * e);
    EXPECT_NEAR(fd, grad(k), 1e-8 * (1 + std::abs(grad(k))));
  }
  d.ctrl << 2.0, 0.0;
  actuation(m, d);
  EXPECT_LT((d.qfrc_actuator + 2.0 * grad).norm(), 1e-12);
}

// Kinetic energy 1/2 v^T M v, and its rate: d/dt T = v^T (applied - C v - g) ... checked through
// the power balance dE/dt = v^T (qfrc_actuator - D v) when K, gravity are part of E.
TEST(Dynamics, PowerBalance) {
  Model m = hybrid_tree();
  Data d(m);
  randomize(d, 10);
  d.ctrl << 0.3, 0.5;
  forward(m, d);
  const double E0 = energy(m, d).total();
  EXPECT_NEAR(energy(m, d).kinetic, 0.5 * d.v.dot(d.M * d.v), 1e-12 * (1 + energy(m, d).kinetic));
  // dE/dt by central differences along the exact flow (q + v t, v + qacc t), Richardson
  // extrapolated: the stiff axial modes make the O(t^2) error of a plain difference ~1e-5.
  auto dEdt_at = [&](double dt) {
    Data dp = d, dm = d;
    dp.q += dt * d.v;
    dp.v += dt * d.qacc;
    dm.q -= dt * d.v;
    dm.v -= dt * d.qacc;
    fwd_position(m, dp);
    fwd_velocity(m, dp);
    fwd_position(m, dm);
    fwd_velocity(m, dm);
    return (energy(m, dp).total() - energy(m, dm).total()) / (2 * dt);
  };
  const double dEdt = (4.0 * dEdt_at(5e-7) - dEdt_at(1e-6)) / 3.0;
  const double power = d.v.dot(d.qfrc_actuator - m.D * d.v);
  // remaining error: O(t^4) truncation and eps E0 / t round-off, both ~1e-9 relative
  EXPECT_NEAR(dEdt, power, 1e-7 * (std::abs(power) + std::abs(E0)));
}

}  // namespace

namespace {

// The coupling to a moving base (Ic_base, F_base, f_base) equals what a free joint at the base
// sees: put the same rods on a free joint at q = 0 (identity pose, body twist = v_free).
// (a GVS rod, and a PCS one with the Gauss-Lobatto mass rule, which puts a fixed node at the base)
class BaseCoupling : public ::testing::TestWithParam<int> {};

TEST_P(BaseCoupling, EqualsFreeJointBlocks) {
  RodSpec a = rod_spec("sr", 2, GetParam(), 0.3, 0.01);
  a.section.lobatto = GetParam() == 0;
  a.section.rest_strain << 0.2, -0.3, 0.5, 1.0, 0.0, 0.02;
  SE3 place(exp_so3(Vec3(0.3, 0.1, -0.2)), Vec3(0.05, 0.01, 0.0));
  auto [fixed, floating] = fixed_and_floating(a, place);
  Data df(fixed), dl(floating);
  df.q = 0.3 * VecX::Random(fixed.nv);
  df.v = 0.5 * VecX::Random(fixed.nv);
  const Vec6 vb = Vec6::Random(), ab = Vec6::Random();
  df.base_twist = vb;
  df.base_accel = ab;
  dl.q << VecX::Zero(6), df.q;
  dl.v << vb, df.v;
  VecX acc_f = VecX::Random(fixed.nv), acc_l(floating.nv), tau_f(fixed.nv), tau_l(floating.nv);
  acc_l << ab, acc_f;
  for (Data* d : {&df, &dl}) {
    const Model& m = d == &df ? fixed : floating;
    fwd_position(m, *d);
    fwd_velocity(m, *d);
    crba(m, *d);
  }
  rnea(fixed, df, acc_f, true, false, tau_f);
  rnea(floating, dl, acc_l, true, false, tau_l);
  const double s = dl.M.norm();
  EXPECT_LT((dl.M.topLeftCorner(6, 6) - df.Ic_base).norm(), 1e-13 * s);
  EXPECT_LT((dl.M.topRightCorner(6, fixed.nv) - df.F_base).norm(), 1e-13 * s);
  EXPECT_LT((dl.M.bottomRightCorner(fixed.nv, fixed.nv) - df.M).norm(), 1e-13 * s);
  EXPECT_LT((tau_l.head(6) - df.f_base).norm(), 1e-12 * (1 + tau_l.norm()));
  EXPECT_LT((tau_l.tail(fixed.nv) - tau_f).norm(), 1e-12 * (1 + tau_l.norm()));
}
INSTANTIATE_TEST_SUITE_P(PcsAndGvs, BaseCoupling, ::testing::Values(0, 1));

// The mass quadratures of a rod mixing PCS sections (3-point Gauss-Lobatto, end points shared with
// the neighbours; 2-point Gauss, the default and given explicitly), GVS and rigid sections (with
// either rule): every point of the rod is counted once. Straight and uniform, the rod is a cylinder, whose spatial inertia about its
// base the rules integrate exactly (polynomials of degree <= 2 in X); tapered, mass and first
// moment (degree <= 3) stay exact.
TEST(Dynamics, MassQuadraturesCountEveryPointOnce) {
  for (const double taper : {1.0, 0.5}) {
    const double L = 0.4, r0 = 0.01, r1 = taper * r0, rho = 1100.0;
    RodSpec spec = rod_spec("sr", 1, 0, L, r0);
    spec.radius_tip = r1;
    SectionSpec pcs = spec.section, lobatto = pcs, gauss2 = pcs, gvs = pcs, rigid = pcs;
    lobatto.lobatto = true;
    gauss2.quadrature = 2;
    gvs.order = 1;
    rigid.dofs = *strain_mask_from_name("rigid");
    SectionSpec rigid_lobatto = rigid;
    rigid_lobatto.lobatto = true;
    spec.overrides = {lobatto, gauss2, gvs, lobatto, rigid_lobatto, pcs, lobatto, rigid, lobatto};
    Model m;
    const int r = m.add_rod(-1, SE3::Identity(), spec);
    m.finalize();
    const Rod& rod = m.rods[r];
    EXPECT_EQ(rod.base_node, rod.first_node);  // the first section is Gauss-Lobatto
    double length = 0.0;
    for (int i = rod.first_node; i <= rod.tip_node; ++i) length += m.nodes[i].dX;
    EXPECT_NEAR(length, L, 1e-14);
    Data d(m);
    fwd_position(m, d);
    crba(m, d);
    const Mat6& Ic = d.Ic_base;
    // analytic: A(X) = pi r(X)^2 with r linear from r0 to r1
    auto integral = [&](int k) {  // int_0^L A(X) X^k dX, by 8-point Gauss (exact: degree k + 2)
      std::vector<double> x, w;
      gauss_legendre01(8, x, w);
      double sum = 0.0;
      for (size_t j = 0; j < x.size(); ++j) {
        const double X = x[j] * L, rr = r0 + (r1 - r0) * x[j];
        sum += w[j] * L * M_PI * rr * rr * std::pow(X, k);
      }
      return sum;
    };
    const double mass = rho * integral(0), first = rho * integral(1);
    EXPECT_NEAR(Ic(3, 3), mass, 1e-13 * mass) << taper;
    EXPECT_NEAR(unskew(Ic.topRightCorner<3, 3>()).x(), first, 1e-13 * first) << taper;
    EXPECT_LT(unskew(Ic.topRightCorner<3, 3>()).tail<2>().norm(), 1e-15 * first);
    if (taper != 1.0) continue;
    // the uniform cylinder about its base end: I = diag(m r^2 / 2, m r^2 / 4 + m L^2 / 3, same)
    const Vec3 I(mass * r0 * r0 / 2, mass * r0 * r0 / 4 + mass * L * L / 3, mass * r0 * r0 / 4 + mass * L * L / 3);
    EXPECT_LT((Ic.topLeftCorner<3, 3>() - Mat3(I.asDiagonal())).norm(), 1e-13 * I.norm());
  }
}

// rnea's every_node mode: the same tau and base wrench as the fixed subtrees' lumped inertia, and
// node wrenches across a rigid part that carry the part beyond (at rest under gravity: its weight).
TEST(Dynamics, InverseDynamicsOfEveryNodeCarriesTheWrenchesAcrossRigidSections) {
  RodSpec spec = rod_spec("sr", 1, 0, 0.4, 0.01);
  SectionSpec pcs = spec.section, rigid = pcs;
  rigid.dofs = *strain_mask_from_name("rigid");
  spec.overrides = {pcs, pcs, rigid, rigid};  // a rigid tip part: a fixed subtree
  Model m;
  m.gravity = Vec3(0, 0, -9.81);
  const int r = m.add_rod(-1, SE3::Identity(), spec);
  m.finalize();
  Data d(m);
  randomize(d, 7);
  d.base_twist << 0.1, -0.2, 0.3, 0.05, 0.0, -0.1;
  d.base_accel << 0.3, 0.1, -0.2, 0.0, 0.4, 0.2;
  fwd_position(m, d);
  fwd_velocity(m, d);
  VecX qacc = VecX::LinSpaced(m.nv, -1.0, 1.0), tau_lumped(m.nv), tau_every(m.nv);
  rnea(m, d, qacc, true, false, tau_lumped);
  const Vec6 f_lumped = d.f_base;
  rnea(m, d, qacc, true, false, tau_every, true);
  EXPECT_LT((tau_every - tau_lumped).norm(), 1e-12 * tau_lumped.norm());
  EXPECT_LT((d.f_base - f_lumped).norm(), 1e-12 * f_lumped.norm());
  // at rest: the wrench into each node's subtree is the weight beyond it (world z)
  d.v.setZero();
  d.base_twist.setZero();
  d.base_accel.setZero();
  fwd_velocity(m, d);
  rnea(m, d, VecX::Zero(m.nv), true, false, tau_every, true);
  const Rod& rod = m.rods[r];
  int inside_rigid = 0;
  for (int i = rod.first_node; i <= rod.tip_node; ++i) {
    double beyond = 0.0;
    for (int j = i; j <= rod.tip_node; ++j) beyond += m.nodes[j].inertia(3, 3);
    const Vec3 force_world = d.g[i].R * d.F[i].tail<3>();
    EXPECT_LT((force_world - Vec3(0, 0, 9.81 * beyond)).norm(), 1e-12) << "node " << i;
    if (m.nodes[i].fixed_subtree && m.nodes[i].parent >= 0 && m.nodes[m.nodes[i].parent].fixed_subtree) ++inside_rigid;
  }
  EXPECT_GT(inside_rigid, 0);  // the check covers nodes inside a fixed subtree
}

}  // namespace
