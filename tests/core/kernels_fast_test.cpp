// The block-structured kernels against straightforward dense references:
//  - dexp / ddexp (plugin/core/lie.cpp, 3x3 block algebra) against the dense 6x6 power formulas;
//  - composite / crba (plugin/core/dynamics.cpp: structured Ad^-T A Ad^-1 congruence, the
//    per-section group blocks from the group Jacobians and the off-diagonal walk) against
//    sum_i J_i^T A_i J_i from node_jacobian and against the original per-node recursion, for
//    inertias, full symmetric and diagonal (some zero) per-node matrices, on a tree with PCS and
//    GVS sections, sub-stepped GVS, fixed frames, joints, bodies and a rod branching from the
//    middle of a section.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "lie.hpp"
#include "support/test_models.hpp"

using namespace cosserat;
using namespace cosserat::testing;
namespace lc = cosserat::lie_coefficients;

namespace {

// ---- dense references (the formulas as written with 6x6 products) ----

Mat6 dexp_dense(const Vec6& Om) {
  const double t = Om.head<3>().norm();
  const Mat6 A = ad(Om);
  const Mat6 A2 = A * A;
  const Mat6 A3 = A2 * A;
  const Mat6 A4 = A2 * A2;
  return Mat6::Identity() + lc::c1(t) * A + lc::c2(t) * A2 + lc::c3(t) * A3 + lc::c4(t) * A4;
}

Mat6 ddexp_dense(const Vec6& Om, const Vec6& de) {
  const double t = Om.head<3>().norm();
  const double kdk = Om.head<3>().dot(de.head<3>());
  const double C1 = lc::c1(t), C2 = lc::c2(t), C3 = lc::c3(t), C4 = lc::c4(t);
  const double D3 = lc::d3(t), D4 = lc::d4(t), D1 = t * t * D3, D2 = t * t * D4;
  const Mat6 A = ad(Om), B = ad(de);
  const Mat6 A2 = A * A, A3 = A2 * A, A4 = A2 * A2;
  Mat6 out = kdk * (D1 * A + D2 * A2 + D3 * A3 + D4 * A4);
  out += C1 * B;
  out += C2 * (B * A + A * B);
  out += C3 * (B * A2 + A * B * A + A2 * B);
  out += C4 * (B * A3 + A * B * A2 + A2 * B * A + A3 * B);
  return out;
}

Vec6 random_twist(std::mt19937& gen, double theta, double vscale) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 w(n(gen), n(gen), n(gen));
  w *= theta / w.norm();
  Vec3 v(n(gen), n(gen), n(gen));
  v *= vscale / v.norm();
  Vec6 x;
  x << w, v;
  return x;
}

std::string sci(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", x);
  return buf;
}

const std::vector<double>& test_angles() {
  static const std::vector<double> a = {0.0,  1e-12, 1e-9, 1e-6, 1e-4, 1e-2, 0.3,    1.0,  1.4999, 1.5001,
                                        2.2,  2.3,   2.5,  3.0,  M_PI, 3.5,  4.0,    5.0,  2 * M_PI, 7.0,
                                        10.0, 12.5,  20.0, 50.0};
  return a;
}

TEST(KernelsFast, DexpMatchesDenseReference) {
  std::mt19937 gen(11);
  double worst = 0.0;
  for (double th : test_angles())
    for (double vs : {0.0, 1e-3, 1.0, 30.0})
      for (int rep = 0; rep < 8; ++rep) {
        const Vec6 Om = random_twist(gen, th, vs);
        const Mat6 ref = dexp_dense(Om), got = dexp(Om);
        const double err = (got - ref).norm() / ref.norm();
        worst = std::max(worst, err);
        EXPECT_LT(err, 1e-12) << "theta " << th << " |v| " << vs;
        // the block structure is exact: zero upper-right block, equal diagonal blocks
        EXPECT_TRUE((got.topRightCorner<3, 3>().isZero(0.0)));
        EXPECT_TRUE((got.topLeftCorner<3, 3>().array() == got.bottomRightCorner<3, 3>().array()).all());
      }
  RecordProperty("worst_relative_error", sci(worst));
}

TEST(KernelsFast, DdexpMatchesDenseReference) {
  std::mt19937 gen(12);
  double worst = 0.0;
  for (double th : test_angles())
    for (double vs : {0.0, 1e-3, 1.0, 30.0})
      for (double ds : {1e-8, 1.0, 10.0})
        for (int rep = 0; rep < 6; ++rep) {
          const Vec6 Om = random_twist(gen, th, vs);
          Vec6 de = random_twist(gen, ds, ds * (rep % 3));
          if (rep == 5) de.head<3>() = Om.head<3>().cross(de.head<3>());  // k.dk = 0
          const Mat6 ref = ddexp_dense(Om, de), got = ddexp(Om, de);
          const double scale = ref.norm();
          if (scale == 0.0) {
            EXPECT_EQ(got.norm(), 0.0);
            continue;
          }
          const double err = (got - ref).norm() / scale;
          worst = std::max(worst, err);
          EXPECT_LT(err, 1e-12) << "theta " << th << " |v| " << vs << " |de| " << ds << " rep " << rep;
          EXPECT_TRUE((got.topRightCorner<3, 3>().isZero(0.0)));
        }
  RecordProperty("worst_relative_error", sci(worst));
}

// Independent of the dense formulas: ddexp is the derivative of dexp.
TEST(KernelsFast, DdexpIsTheDerivativeOfDexp) {
  std::mt19937 gen(13);
  for (double th : {0.0, 1e-5, 0.4, 1.7, 3.0, 4.5, 9.0}) {
    for (int rep = 0; rep < 4; ++rep) {
      const Vec6 Om = random_twist(gen, th, 1.0), de = random_twist(gen, 1.0, 1.0);
      const double e = 1e-6;
      const Mat6 fd = (dexp(Vec6(Om + e * de)) - dexp(Vec6(Om - e * de))) / (2 * e);
      const Mat6 an = ddexp(Om, de);
      EXPECT_LT((fd - an).norm(), 1e-7 * (1.0 + an.norm())) << "theta " << th;
    }
  }
}

// ---- composite rigid body ----

// The original implementation: dense Ad^-T Ic Ad^-1 and one walk to the root per node.
void composite_reference(const Model& m, const Data& d, Mat6 Node::*field, MatX& M, Mat6& base,
                         Mat6X& F_base) {
  const int nn = static_cast<int>(m.nodes.size());
  auto children = [&](int p, auto&& f) {
    for (int k = m.children_begin[p + 1]; k < m.children_begin[p + 2]; ++k) f(m.children[k]);
  };
  std::vector<Mat6> Ic(nn);
  for (int i = nn - 1; i >= 0; --i) {
    Mat6 I = m.nodes[i].*field;
    children(i, [&](int c) {
      const Mat6 X = Ad_inv(d.g_rel[c]);
      I += X.transpose() * Ic[c] * X;
    });
    Ic[i] = I;
  }
  base.setZero();
  children(-1, [&](int c) {
    const Mat6 X = Ad_inv(d.g_rel[c]);
    base += X.transpose() * Ic[c] * X;
  });
  M = MatX::Zero(m.nv, m.nv);
  F_base = Mat6X::Zero(6, m.nv);
  for (int a = 0; a < nn; ++a) {
    const Node& na = m.nodes[a];
    if (na.ndof == 0) continue;
    Mat6X Fa = Ic[a] * d.S[a];
    M.block(na.dof0, na.dof0, na.ndof, na.ndof) += d.S[a].transpose() * Fa;
    for (int j = a;; j = m.nodes[j].parent) {
      const int b = m.nodes[j].parent;
      for (int c = 0; c < na.ndof; ++c) Fa.col(c) = coAd_apply(d.g_rel[j], Vec6(Fa.col(c)));
      if (b < 0) {
        F_base.middleCols(na.dof0, na.ndof) += Fa;
        break;
      }
      const Node& nb = m.nodes[b];
      if (nb.ndof == 0) continue;
      M.block(na.dof0, nb.dof0, na.ndof, nb.ndof) += Fa.transpose() * d.S[b];
      M.block(nb.dof0, na.dof0, nb.ndof, na.ndof) += d.S[b].transpose() * Fa;
    }
  }
}

// sum_i J_i^T A_i J_i, sum_i X_i^T A_i X_i and sum_i X_i^T A_i J_i with X_i = Ad^-1 of the node's
// pose in the base frame.
void composite_from_jacobians(const Model& m, const Data& d, Mat6 Node::*field, MatX& M, Mat6& base,
                              Mat6X& F_base) {
  M = MatX::Zero(m.nv, m.nv);
  base.setZero();
  F_base = Mat6X::Zero(6, m.nv);
  MatX J;
  const SE3 base_inv = d.base_pose.inverse();
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    const Mat6& A = m.nodes[i].*field;
    node_jacobian(m, d, static_cast<int>(i), J);
    const Mat6 X = Ad_inv(base_inv * d.g[i]);
    M += J.transpose() * A * J;
    base += X.transpose() * A * X;
    F_base += X.transpose() * A * J;
  }
}

// A tree with several PCS and GVS sections (different strain bases, so different dof counts),
// sub-stepped GVS (intermediate nodes without inertia), a rod branching from the middle of a
// section, a fixed frame carrying a body and a joint, and rigid bodies on joints.
Model mixed_tree() {
  Model m;
  RodSpec r = rod_spec("kl", 1, 0, 0.6, 0.01);
  r.name = "main";
  r.radius_tip = 0.007;
  SectionSpec pcs = r.section, gvs = r.section, pcs6 = r.section, gvs_sub = r.section;
  pcs.rest_strain << 0.2, -0.1, 0.3, 1.0, 0.0, 0.0;
  gvs.dofs = *strain_mask_from_name("sr");
  gvs.order = 2;
  pcs6.dofs = StrainMask{true, true, true, true, true, true};
  gvs_sub.order = 1;
  gvs_sub.substeps = 3;
  gvs_sub.rest_strain << 0.0, 1.5, 0.0, 1.0, 0.0, 0.0;
  r.overrides = {pcs, gvs, pcs, pcs6, gvs_sub, gvs};
  SE3 p0;
  p0.R = exp_so3(Vec3(0.1, -0.4, 0.2));
  p0.u = Vec3(0.01, -0.02, 0.03);
  const int rm = m.add_rod(-1, p0, r);
  // a rod hanging from the middle of the GVS section (between two nodes of one dof block)
  const Section& s1 = m.sections[m.rods[rm].first_section + 1];
  const int mid = s1.first_node + (s1.end_node - s1.first_node) / 2;
  RodSpec br = rod_spec("icc", 2, 0, 0.2, 0.005);
  br.name = "branch";
  SE3 pb;
  pb.R = exp_so3(Vec3(0.0, 0.0, 1.2));
  pb.u = Vec3(0.0, 0.01, 0.0);
  m.add_rod(mid, pb, br);
  // a fixed frame in the middle of the sub-stepped section with a body and a joint on it
  const Section& s4 = m.sections[m.rods[rm].first_section + 4];
  SE3 pf;
  pf.u = Vec3(0.0, 0.02, -0.01);
  const int fr = m.add_frame(s4.first_node + 2, pf);
  m.add_body(fr, 0.03, Vec3(0.0, 0.01, 0.0), Vec3(1e-5, 2e-5, 3e-5).asDiagonal());
  const int jf = m.add_joint(fr, SE3::Identity(), JointType::Revolute, Vec3(1, 0, 0));
  m.add_body(jf, 0.01, Vec3(0.02, 0.0, 0.0), Vec3(1e-6, 2e-6, 2e-6).asDiagonal());
  // at the tip: a spherical joint with a body and another GVS rod
  const int tip = m.rods[rm].tip_node;
  m.add_body(tip, 0.05, Vec3(0.01, 0, 0.005), Vec3(2e-5, 1e-5, 1e-5).asDiagonal());
  const int js = m.add_joint(tip, SE3::Identity(), JointType::Spherical);
  m.add_body(js, 0.02, Vec3(0.0, 0.0, 0.01), Vec3(3e-6, 3e-6, 1e-6).asDiagonal());
  RodSpec t = rod_spec("kl", 2, 3, 0.15, 0.004);
  t.name = "tip_rod";
  m.add_rod(js, SE3::Identity(), t);
  // a second rod at the base, PCS
  RodSpec c = rod_spec("sr", 3, 0, 0.25, 0.006);
  c.name = "base2";
  m.add_rod(-1, SE3::Identity(), c);
  m.finalize();
  return m;
}

void randomize(Data& d, unsigned seed, double scale = 0.5) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < d.q.size(); ++i) d.q(i) = scale * u(gen);
  for (int i = 0; i < d.v.size(); ++i) d.v(i) = scale * u(gen);
}

struct CompositeOut {
  MatX M;
  Mat6 base;
  Mat6X F_base;
};

void expect_close(const CompositeOut& got, const CompositeOut& ref, double tol, const char* what) {
  EXPECT_LT((got.M - ref.M).norm(), tol * ref.M.norm()) << what << ": M";
  EXPECT_LT((got.base - ref.base).norm(), tol * ref.base.norm()) << what << ": base";
  EXPECT_LT((got.F_base - ref.F_base).norm(), tol * ref.F_base.norm()) << what << ": F_base";
}

void check_composite(Model& m, unsigned seed) {
  Data d(m);
  randomize(d, seed);
  d.base_pose.R = exp_so3(Vec3(0.3, 0.2, -0.1));
  d.base_pose.u = Vec3(0.5, -0.2, 1.0);
  fwd_position(m, d);

  // the mass matrix (symmetric per-node inertia)
  crba(m, d);
  CompositeOut got{d.M, d.Ic_base, d.F_base}, ref, jac;
  composite_reference(m, d, &Node::inertia, ref.M, ref.base, ref.F_base);
  composite_from_jacobians(m, d, &Node::inertia, jac.M, jac.base, jac.F_base);
  expect_close(got, ref, 1e-13, "crba vs original recursion");
  expect_close(got, jac, 1e-12, "crba vs sum J^T I J");
  EXPECT_LT((d.M - d.M.transpose()).norm(), 1e-14 * d.M.norm());

  // other per-node matrices through the same routine (composite takes symmetric ones): a full
  // symmetric one on every node, then a diagonal one (a rod's drag in its node frames) with some
  // nodes left at zero
  std::mt19937 gen(seed + 100);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Node& n : m.nodes) {
    n.drag = Mat6::NullaryExpr([&](Eigen::Index, Eigen::Index) { return u(gen); });
    n.drag = (0.5 * (n.drag + n.drag.transpose())).eval();
    n.drag.diagonal().array() += 3.0;
  }
  CompositeOut gd, rd, jd;
  gd.M.resize(m.nv, m.nv);
  gd.F_base.resize(6, m.nv);
  composite(m, d, NodeMatrix::Drag, gd.M, gd.base, gd.F_base);
  composite_reference(m, d, &Node::drag, rd.M, rd.base, rd.F_base);
  composite_from_jacobians(m, d, &Node::drag, jd.M, jd.base, jd.F_base);
  expect_close(gd, rd, 1e-13, "symmetric drag vs original recursion");
  expect_close(gd, jd, 1e-12, "symmetric drag vs sum J^T A J");
  int k = 0;
  for (Node& n : m.nodes) {
    const Vec6 w = Vec6::NullaryExpr([&](Eigen::Index) { return 1.0 + u(gen); });
    n.drag = (k++ % 3 == 1 ? Vec6::Zero() : w).asDiagonal();
  }
  composite(m, d, NodeMatrix::Drag, gd.M, gd.base, gd.F_base);
  composite_reference(m, d, &Node::drag, rd.M, rd.base, rd.F_base);
  composite_from_jacobians(m, d, &Node::drag, jd.M, jd.base, jd.F_base);
  expect_close(gd, rd, 1e-13, "diagonal drag vs original recursion");
  expect_close(gd, jd, 1e-12, "diagonal drag vs sum J^T A J");
  for (Node& n : m.nodes) n.drag.setZero();
}

TEST(KernelsFast, CompositeMixedTree) {
  Model m = mixed_tree();
  // the model exercises groups of several nodes and a branch from inside a group
  int groups_gt1 = 0;
  for (size_t i = 1; i < m.nodes.size(); ++i)
    groups_gt1 += m.nodes[i].parent == static_cast<int>(i) - 1 && m.nodes[i].ndof > 0 &&
                  m.nodes[i].dof0 == m.nodes[i - 1].dof0 && m.nodes[i].ndof == m.nodes[i - 1].ndof;
  EXPECT_GT(groups_gt1, 10);
  for (unsigned seed : {1u, 2u, 3u}) check_composite(m, seed);
}

TEST(KernelsFast, CompositeHybridTree) {
  Model m = hybrid_tree();
  for (unsigned seed : {4u, 5u}) check_composite(m, seed);
}

TEST(KernelsFast, CompositeSingleRods) {
  for (auto [s, o] : {std::pair{1, 0}, {8, 0}, {2, 2}, {2, 4}}) {
    Model m;
    m.add_rod(-1, SE3::Identity(), rod_spec("kl", s, o));
    m.finalize();
    check_composite(m, 7 + s + o);
  }
}

// ---- fixed subtrees (Node::fixed_subtree): the cached composites against node by node ----

// A rod whose sections alternate soft and rigid, with a soft rod hanging from the middle of a
// rigid section (the rigid nodes above the branch point are not fixed subtrees, those below are),
// a rigid tip section carrying a fixed frame with a body, and a fully rigid second rod.
Model rigid_sections_tree() {
  Model m;
  RodSpec r = rod_spec("kl", 1, 0, 0.6, 0.01);
  r.name = "main";
  SectionSpec soft = r.section, rigid = r.section, gvs = r.section;
  rigid.dofs = *strain_mask_from_name("rigid");
  rigid.rest_strain << 0.3, 0.8, -0.2, 1.0, 0.0, 0.0;
  rigid.quadrature = 4;
  gvs.order = 2;
  r.overrides = {soft, rigid, gvs, rigid};
  const int rm = m.add_rod(-1, SE3::Identity(), r);
  const Section& s1 = m.sections[m.rods[rm].first_section + 1];
  RodSpec br = rod_spec("sr", 2, 0, 0.2, 0.005);
  br.name = "branch";
  SE3 pb;
  pb.R = exp_so3(Vec3(0.4, 0.0, 1.2));
  m.add_rod(s1.first_node + 1, pb, br);
  const int tip = m.rods[rm].tip_node;
  m.add_body(tip, 0.05, Vec3(0.01, 0, 0.005), Vec3(2e-5, 1e-5, 1e-5).asDiagonal());
  SE3 pf;
  pf.R = exp_so3(Vec3(0.0, 0.7, 0.0));
  pf.u = Vec3(0.02, 0.01, 0.0);
  const int fr = m.add_frame(tip, pf);
  m.add_body(fr, 0.02, Vec3(0.0, 0.01, 0.0), Vec3(1e-5, 2e-5, 3e-5).asDiagonal());
  RodSpec stiff = rod_spec("rigid", 3, 0, 0.3, 0.004);
  stiff.name = "stiff";
  stiff.section.rest_strain << 0.0, 2.0, 0.0, 1.0, 0.0, 0.0;
  SE3 ps;
  ps.u = Vec3(0.0, 0.05, 0.0);
  m.add_rod(-1, ps, stiff);
  m.finalize();
  return m;
}

TEST(KernelsFast, FixedSubtreesEqualNodeByNode) {
  Model m = rigid_sections_tree();
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Node& n : m.nodes) {  // a symmetric drag on every node
    Mat6 A = Mat6::NullaryExpr([&](Eigen::Index, Eigen::Index) { return u(gen); });
    n.drag = A * A.transpose() + Mat6::Identity();
  }
  m.update_fixed_composites();
  // the reference: the same model with the subtrees visited node by node
  Model ref = m;
  int roots = 0, inside = 0;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    const Node& n = m.nodes[i];
    if (!n.fixed_subtree) continue;
    (n.parent >= 0 && m.nodes[n.parent].fixed_subtree ? inside : roots)++;
    ref.nodes[i].fixed_subtree = false;
  }
  // roots: the rigid tip section and the rigid rod (rigid section 1 carries soft sections below
  // it, so it is no fixed subtree); inside: 4 + 1 tip nodes and the frame, 3 x 3 rigid-rod nodes
  EXPECT_EQ(roots, 2);
  EXPECT_EQ(inside, 5 + 8);
  const int branch_parent = m.rods[1].first_section >= 0 ? m.nodes[m.sections[m.rods[1].first_section].first_node].parent : -1;
  EXPECT_FALSE(m.nodes[branch_parent].fixed_subtree);  // the branch hangs from a rigid node above it

  for (unsigned seed : {1u, 2u}) {
    Data d(m), dr(ref);
    randomize(d, seed);
    d.base_pose.R = exp_so3(Vec3(0.3, 0.2, -0.1));
    d.base_pose.u = Vec3(0.5, -0.2, 1.0);
    d.base_twist << 0.3, -0.2, 0.1, 0.05, 0.2, -0.1;
    d.base_accel << -0.5, 0.1, 0.4, 1.0, -2.0, 0.5;
    for (int i = 0; i < static_cast<int>(m.nodes.size()); i += 5) {  // loads, inside subtrees too
      d.f_ext_body[i] << u(gen), u(gen), u(gen), u(gen), u(gen), u(gen);
      d.f_ext_world[i + 2] << u(gen), u(gen), u(gen), u(gen), u(gen), u(gen);
    }
    dr.q = d.q;
    dr.v = d.v;
    dr.base_pose = d.base_pose;
    dr.base_twist = d.base_twist;
    dr.base_accel = d.base_accel;
    dr.f_ext_body = d.f_ext_body;
    dr.f_ext_world = d.f_ext_world;
    for (Data* x : {&d, &dr}) {
      fwd_position(x == &d ? m : ref, *x);
      fwd_velocity(x == &d ? m : ref, *x);
    }
    crba(m, d);
    crba(ref, dr);
    expect_close({d.M, d.Ic_base, d.F_base}, {dr.M, dr.Ic_base, dr.F_base}, 1e-13, "crba");
    CompositeOut gd{MatX(m.nv, m.nv), Mat6(), Mat6X(6, m.nv)}, rd = gd;
    composite(m, d, NodeMatrix::Drag, gd.M, gd.base, gd.F_base);
    composite(ref, dr, NodeMatrix::Drag, rd.M, rd.base, rd.F_base);
    expect_close(gd, rd, 1e-13, "drag composite");
    VecX qacc(m.nv), tau(m.nv), tau_ref(m.nv);
    for (int k = 0; k < m.nv; ++k) qacc(k) = u(gen);
    rnea(m, d, qacc, true, true, tau);
    rnea(ref, dr, qacc, true, true, tau_ref);
    EXPECT_LT((tau - tau_ref).norm(), 1e-12 * tau_ref.norm());
    EXPECT_LT((d.f_base - dr.f_base).norm(), 1e-12 * dr.f_base.norm());
    // and without the loads (the subtrees' nodes are then skipped altogether)
    rnea(m, d, qacc, true, false, tau);
    rnea(ref, dr, qacc, true, false, tau_ref);
    EXPECT_LT((tau - tau_ref).norm(), 1e-12 * tau_ref.norm());
    EXPECT_LT((d.f_base - dr.f_base).norm(), 1e-12 * dr.f_base.norm());
  }
}

// Group Jacobians (Data::Jg, Jgdot, g_grp) against section_jacobian at every node (a group is the
// steps of one section), and Jgdot against a central difference of Jg along the motion.
TEST(KernelsFast, GroupJacobiansEqualSectionJacobians) {
  Model m = mixed_tree();
  Data d(m);
  randomize(d, 21);
  fwd_position(m, d);
  fwd_velocity(m, d);
  group_jacobian_dot(m, d);
  Mat6X J, Jd;
  int checked = 0;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    const Node& n = m.nodes[i];
    if (n.rod < 0 || n.ndof == 0) continue;
    SE3 gX;
    section_jacobian(m, d, n.rod, n.X, J, &Jd, &gX, n.section);
    EXPECT_LT((d.Jg[i] - J).norm(), 1e-13 * (1 + J.norm())) << i;
    EXPECT_LT((d.Jgdot[i] - Jd).norm(), 1e-12 * (1 + Jd.norm())) << i;
    EXPECT_LT((d.g_grp[i].u - gX.u).norm() + (d.g_grp[i].R - gX.R).norm(), 1e-13) << i;
    ++checked;
  }
  EXPECT_GT(checked, 30);
  // between nodes: section_jacobian without Jdot starts from the group Jacobian of the previous
  // node, with Jdot it walks the section's steps: the same J and pose
  for (const Section& sec : m.sections) {
    for (double f : {0.0, 0.13, 0.5, 0.77, 1.0}) {
      const double X = sec.X0 + f * sec.length;
      const int si = static_cast<int>(&sec - m.sections.data());
      Mat6X J1, J2, Jd2;
      SE3 g1, g2;
      section_jacobian(m, d, sec.rod, X, J1, nullptr, &g1, si);
      section_jacobian(m, d, sec.rod, X, J2, &Jd2, &g2, si);
      EXPECT_LT((J1 - J2).norm(), 1e-13 * (1 + J2.norm())) << si << " " << f;
      EXPECT_LT((g1.u - g2.u).norm() + (g1.R - g2.R).norm(), 1e-13) << si << " " << f;
    }
  }
  const double eps = 1e-6;
  Data dp(m), dm(m);
  dp.q = d.q + eps * d.v;
  dm.q = d.q - eps * d.v;
  fwd_position(m, dp);
  fwd_position(m, dm);
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    if (m.nodes[i].ndof == 0) continue;
    const Mat6X fd = (dp.Jg[i] - dm.Jg[i]) / (2 * eps);
    EXPECT_LT((d.Jgdot[i] - fd).norm(), 1e-7 * (1 + fd.norm())) << i;
  }
}

// The kinematics (poses, motion subspaces, group Jacobians, their rates, bias accelerations) of
// two models of the same tree from one random state agree to `tol` (relative where they scale).
void expect_same_kinematics(const Model& m, const Model& ref, unsigned seed, double tol) {
  Data d(m), dr(ref);
  randomize(d, seed);
  dr.q = d.q;
  dr.v = d.v;
  fwd_position(m, d);
  fwd_velocity(m, d);
  fwd_position(ref, dr);
  fwd_velocity(ref, dr);
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    EXPECT_LT((d.g[i].u - dr.g[i].u).norm() + (d.g[i].R - dr.g[i].R).norm(), tol) << i;
    EXPECT_LE((d.S[i] - dr.S[i]).norm(), tol * dr.S[i].norm()) << i;  // (0 = 0 at a base node)
    EXPECT_LE((d.Jg[i] - dr.Jg[i]).norm(), tol * dr.Jg[i].norm()) << i;
    EXPECT_LT((d.Sdot[i] - dr.Sdot[i]).norm(), tol * (1 + dr.Sdot[i].norm())) << i;
    EXPECT_LT((d.cbias[i] - dr.cbias[i]).norm(), tol * (1 + dr.cbias[i].norm())) << i;
  }
}

// PCS steps of equal length (the quadrature is symmetric) are computed once (Node::same_step):
// the kinematics equal those of the same model computing every step.
TEST(KernelsFast, RepeatedPcsStepsEqualRecomputedOnes) {
  for (int quadrature : {0, 2, 3, 4}) {  // 0: the 3-point Gauss-Lobatto rule
    Model m;
    RodSpec r = rod_spec("sr", 3, 0, 0.5, 0.01);
    r.section.quadrature = quadrature;
    r.section.lobatto = quadrature == 0;
    r.section.rest_strain << 0.5, -1.0, 2.0, 1.0, 0.0, 0.0;
    m.add_rod(-1, SE3::Identity(), r);
    m.finalize();
    Model ref = m;
    int reused = 0;
    for (Node& n : ref.nodes) {
      reused += n.same_step >= 0;
      n.same_step = -1;
    }
    // Gauss: quadrature + 1 steps per section, symmetric in pairs (the middle one alone when
    // even); Gauss-Lobatto: a base node and two equal steps per section, one exponential each
    if (quadrature == 0) {
      EXPECT_EQ(m.nodes.size(), 1u + 3 * 2);
      EXPECT_EQ(reused, 3);
    } else {
      EXPECT_EQ(reused, 3 * ((quadrature + 1) / 2)) << quadrature;
    }
    expect_same_kinematics(m, ref, 5 + quadrature, 1e-14);
  }
}

// GVS steps whose basis columns each select one strain component (Node::sparse_basis) take the
// Magnus twist, its Jacobian G and the strain rates without the dense 6 x ndof products: the
// kinematics equal those of the same model taking the dense products, on rods of several strain
// sets, orders, rest strains and Magnus substeps.
TEST(KernelsFast, SparseGvsBasesEqualDenseProducts) {
  struct Case {
    const char* basis;
    int sections, order, substeps;
  };
  for (const Case& c : {Case{"ikl", 1, 2, 1}, Case{"sr", 2, 1, 1}, Case{"kl", 2, 3, 2}, Case{"sr", 1, 4, 3}}) {
    Model m;
    RodSpec r = rod_spec(c.basis, c.sections, c.order, 0.5, 0.01);
    r.section.substeps = c.substeps;
    r.section.rest_strain << 0.5, -1.0, 2.0, 1.0, 0.1, -0.05;
    m.add_rod(-1, SE3::Identity(), r);
    m.finalize();
    Model ref = m;
    int sparse = 0;
    for (Node& n : ref.nodes) {
      sparse += n.sparse_basis;
      n.sparse_basis = false;
    }
    int stepping = 0;  // the nodes with a strain step (every one of them is sparse)
    for (const Node& n : m.nodes) stepping += n.ndof > 0;
    EXPECT_EQ(sparse, stepping) << c.basis << " order " << c.order;
    EXPECT_GT(sparse, 0);
    expect_same_kinematics(m, ref, 11 + c.order, 1e-13);
  }
}

// Without the base coupling (Data::crba_base false: a base that cannot move), crba gives the same
// mass matrix bit for bit and leaves Ic_base and F_base zero; with it, they are as before.
TEST(KernelsFast, CrbaWithoutTheBaseCouplingKeepsTheMassMatrix) {
  std::vector<Model> models;
  models.push_back(mixed_tree());
  models.push_back(hybrid_tree());
  for (int sections : {1, 3}) {
    Model m;
    m.add_rod(-1, SE3::Identity(), rod_spec("ikl", sections, 2));
    m.finalize();
    models.push_back(m);
  }
  for (size_t k = 0; k < models.size(); ++k) {
    const Model& m = models[k];
    Data with(m), without(m);
    randomize(with, 21 + static_cast<unsigned>(k));
    without.q = with.q;
    without.crba_base = false;
    fwd_position(m, with);
    fwd_position(m, without);
    crba(m, with);
    crba(m, without);
    EXPECT_TRUE(with.M == without.M) << k;
    EXPECT_GT(with.F_base.norm(), 0.0) << k;
    EXPECT_GT(with.Ic_base.norm(), 0.0) << k;
    EXPECT_EQ(without.F_base.norm(), 0.0) << k;
    EXPECT_EQ(without.Ic_base.norm(), 0.0) << k;
  }
}

}  // namespace
