// Section-relative Jacobians (plugin/core/kinematics.cpp: section_jacobian) against finite
// differences: they become the cdof / cdof_dot of MuJoCo proxies and the rod columns of contacts.
#include <gtest/gtest.h>

#include <utility>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "support/test_models.hpp"

using namespace cosserat;
using namespace cosserat::testing;

namespace {

// One kl rod of `sections` PCS sections from the world frame, with the default or the
// Gauss-Lobatto mass rule.
Model kl_rod(int sections, bool lobatto) {
  RodSpec spec = rod_spec("kl", sections, 0);
  spec.section.lobatto = lobatto;
  Model m;
  m.add_rod(-1, SE3::Identity(), spec);
  m.finalize();
  return m;
}

// The hybrid tree (PCS and GVS sections, nested rods) at a random configuration, moving: after
// fwd_position and fwd_velocity.
Data moving_hybrid_tree(const Model& m) {
  Data d(m);
  d.q = 0.4 * VecX::Random(m.nv);
  d.v = 0.7 * VecX::Random(m.nv);
  fwd_position(m, d);
  fwd_velocity(m, d);
  return d;
}

// d moved by +-e along its velocity (q +- e v), after fwd_position: central differences in time.
std::pair<Data, Data> moved_along_v(const Model& m, const Data& d, double e) {
  Data dp = d, dm = d;
  dp.q += e * d.v;
  dm.q -= e * d.v;
  fwd_position(m, dp);
  fwd_position(m, dm);
  return {dp, dm};
}

// pose of the frame at X relative to the start of its section, for a given q
SE3 relative_pose(const Model& m, const Data& d, int r, double X) {
  Mat6X J;
  SE3 g;
  section_jacobian(m, d, r, X, J, nullptr, &g);
  return g;
}

TEST(SectionJacobian, MatchesFiniteDifferencesOfRelativePose) {
  Model m = hybrid_tree(false);
  Data d(m);
  d.q = 0.4 * VecX::Random(m.nv);
  fwd_position(m, d);
  const double e = 1e-6;
  for (int r = 0; r < static_cast<int>(m.rods.size()); ++r) {
    for (double f : {0.05, 0.3, 0.5, 0.71, 1.0}) {
      const double X = f * m.rods[r].length;
      Mat6X J;
      SE3 g;
      const int s = section_jacobian(m, d, r, X, J, nullptr, &g);
      const Section& sec = m.sections[s];
      // the relative pose agrees with world poses: g_start^-1 g_X
      const SE3 gs = sec.start_node < 0 ? d.base_pose : d.g[sec.start_node];
      const SE3 gw = gs * g;
      EXPECT_LT((gw.matrix() - rod_pose(m, d, r, X).matrix()).norm(), 1e-12);
      for (int k = 0; k < sec.ndof; ++k) {
        Data dp = d, dm = d;
        dp.q(sec.dof0 + k) += e;
        dm.q(sec.dof0 + k) -= e;
        fwd_position(m, dp);
        fwd_position(m, dm);
        const Vec6 fd = log_se3(relative_pose(m, dm, r, X).inverse() * relative_pose(m, dp, r, X)) / (2 * e);
        EXPECT_LT((fd - J.col(k)).norm(), 1e-7 * (1 + J.col(k).norm())) << "rod " << r << " X " << X;
      }
    }
  }
}

TEST(SectionJacobian, TimeDerivativeMatchesFiniteDifferences) {
  const Model m = hybrid_tree(false);
  Data d = moving_hybrid_tree(m);
  const double e = 1e-6;
  for (int r = 0; r < static_cast<int>(m.rods.size()); ++r) {
    for (double f : {0.2, 0.5, 0.83, 1.0}) {
      const double X = f * m.rods[r].length;
      Mat6X J, Jd, Jp, Jm;
      section_jacobian(m, d, r, X, J, &Jd);
      const auto [dp, dm] = moved_along_v(m, d, e);
      section_jacobian(m, dp, r, X, Jp);
      section_jacobian(m, dm, r, X, Jm);
      const Mat6X fd = (Jp - Jm) / (2 * e);
      // central difference: O(e^2) truncation, eps/e round-off: sqrt-eps level
      EXPECT_LT((fd - Jd).norm(), 1e-7 * (1 + Jd.norm())) << "rod " << r << " X " << X;
    }
  }
}

// point_motion_at_rest_acceleration: the cross-section's pose, its twist (the body Jacobian times
// v) and its velocity-product acceleration (d/dt (J v) along q + t v, v fixed, by central
// differences), inside sections with dofs, at their nodes and ends, PCS and GVS (the hybrid tree's
// nested rods: the twist and acceleration carried from the parent rod), after an rnea at qacc = 0.
TEST(PointMotion, IsTheCrossSectionsTwistAndVelocityProductAcceleration) {
  const Model m = hybrid_tree(false);
  Data d = moving_hybrid_tree(m);
  VecX tau(m.nv);
  rnea(m, d, VecX::Zero(m.nv), false, false, tau);
  const double e = 1e-6;
  int checked = 0;
  for (int r = 0; r < static_cast<int>(m.rods.size()); ++r) {
    std::vector<double> Xs = {m.rods[r].length};
    for (double f : {0.02, 0.2, 0.5, 0.83}) Xs.push_back(f * m.rods[r].length);
    for (const Node& n : m.nodes)
      if (n.rod == r) Xs.push_back(n.X);
    for (double X : Xs) {
      MatX J, Jp, Jm;
      SE3 g;
      Mat6X Js;
      const int si = section_jacobian(m, d, r, X, Js, nullptr, &g);
      if (m.sections[si].ndof == 0) continue;
      const PointMotion pm = point_motion_at_rest_acceleration(m, d, r, X, si);
      rod_jacobian(m, d, r, X, J);
      const auto [dp, dm] = moved_along_v(m, d, e);
      rod_jacobian(m, dp, r, X, Jp);
      rod_jacobian(m, dm, r, X, Jm);
      const Vec6 eta = J * d.v, acc = (Jp - Jm) * d.v / (2 * e);
      EXPECT_LT((pm.pose.matrix() - rod_pose(m, d, r, X).matrix()).norm(), 1e-12) << "rod " << r << " X " << X;
      EXPECT_LT((pm.eta - eta).norm(), 1e-12 * (1 + eta.norm())) << "rod " << r << " X " << X;
      EXPECT_LT((pm.acc - acc).norm(), 1e-7 * (1 + acc.norm())) << "rod " << r << " X " << X;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

}  // namespace

namespace {

// The smallest axial stretch (min_axial_stretch) is the axial strain p_x of the most compressed
// section: exactly for PCS (under both mass rules), the Magnus steps' mean for GVS; sections whose
// axial strain is fixed (ikl) do not count.
TEST(MinAxialStretch, IsTheMostCompressedSectionsAxialStrain) {
  for (bool lobatto : {false, true}) {
    const Model m = kl_rod(3, lobatto);
    Data d(m);
    // kl: dofs (k_x, k_y, k_z, p_x - 1) per section; bend every section, compress the middle one
    d.q = 0.3 * VecX::Random(m.nv);
    d.q(m.sections[0].dof0 + 3) = -0.2;
    d.q(m.sections[1].dof0 + 3) = -0.75;
    d.q(m.sections[2].dof0 + 3) = 0.4;
    fwd_position(m, d);
    int section = -1;
    EXPECT_NEAR(min_axial_stretch(m, d, &section), 0.25, 1e-14) << "lobatto " << lobatto;
    EXPECT_EQ(section, 1);
    EXPECT_NEAR(rod_strain(m, d, 0, m.sections[1].X0 + 0.5 * m.sections[1].length)(3), 0.25, 1e-14);
    // an inverted section reads below zero
    d.q(m.sections[2].dof0 + 3) = -1.5;
    fwd_position(m, d);
    EXPECT_NEAR(min_axial_stretch(m, d, &section), -0.5, 1e-14);
    EXPECT_EQ(section, 2);
  }
  // GVS order 1: p_x linear along the section, the steps' means lie between its end values
  {
    Model m;
    m.add_rod(-1, SE3::Identity(), rod_spec("kl", 1, 1));
    m.finalize();
    Data d(m);
    d.q.setZero();
    // dof index c*(order+1)+k: the axial strain's P_0 and P_1 weights
    d.q(3 * 2 + 0) = -0.5;
    d.q(3 * 2 + 1) = 0.4;
    fwd_position(m, d);
    const double lo = rod_strain(m, d, 0, 0.0)(3), hi = rod_strain(m, d, 0, m.rods[0].length)(3);
    const double s = min_axial_stretch(m, d);
    EXPECT_GT(s, std::min(lo, hi) - 1e-12);
    EXPECT_LT(s, 0.5);  // the mean p_x is 0.5: the smallest step mean lies below it
  }
  // inextensible: nothing can collapse
  {
    Model m;
    m.add_rod(-1, SE3::Identity(), rod_spec("ikl", 2, 0));
    m.finalize();
    Data d(m);
    d.q = 0.3 * VecX::Random(m.nv);
    fwd_position(m, d);
    EXPECT_TRUE(std::isinf(min_axial_stretch(m, d)));
  }
}

}  // namespace

namespace {

// rod_pose_and_jacobian is rod_pose and section_jacobian in one pass: both results bit for bit
// theirs, inside sections, at nodes, at section boundaries (either section), at the ends, for PCS
// (both mass rules) and GVS sections (the hybrid tree).
TEST(RodPoseAndJacobian, IsRodPoseAndSectionJacobianBitForBit) {
  std::vector<Model> models;
  models.push_back(hybrid_tree(false));
  for (bool lobatto : {false, true}) models.push_back(kl_rod(3, lobatto));
  int compared = 0;
  for (const Model& m : models) {
    Data d(m);
    d.q = 0.4 * VecX::Random(m.nv);
    fwd_position(m, d);
    for (int r = 0; r < static_cast<int>(m.rods.size()); ++r) {
      std::vector<double> Xs = {0.0, m.rods[r].length};
      for (double f : {0.05, 0.3, 0.5, 0.71}) Xs.push_back(f * m.rods[r].length);
      for (const Node& n : m.nodes)
        if (n.rod == r) Xs.push_back(n.X);  // nodes: section ends, Gauss or Lobatto points
      for (double X : Xs) {
        Mat6X J0;
        SE3 g0;
        const int s = section_jacobian(m, d, r, X, J0, nullptr, &g0);
        // the section section_jacobian picks, and at a boundary the later one too
        std::vector<int> sections = {s};
        if (s + 1 < static_cast<int>(m.sections.size()) && m.sections[s + 1].rod == r &&
            m.sections[s + 1].X0 == X)
          sections.push_back(s + 1);
        for (int si : sections) {
          section_jacobian(m, d, r, X, J0, nullptr, &g0, si);
          Mat6X J1;
          SE3 g1;
          const SE3 p1 = rod_pose_and_jacobian(m, d, r, X, si, J1, &g1);
          const SE3 p0 = rod_pose(m, d, r, X);
          ASSERT_EQ(J1.rows(), J0.rows());
          ASSERT_EQ(J1.cols(), J0.cols());
          EXPECT_TRUE((J1.array() == J0.array()).all()) << "X " << X << " section " << si;
          EXPECT_TRUE((g1.matrix().array() == g0.matrix().array()).all()) << "X " << X;
          EXPECT_TRUE((p1.matrix().array() == p0.matrix().array()).all()) << "X " << X;
          ++compared;
        }
      }
    }
  }
  EXPECT_GT(compared, 30);
}


// Model::keep_midpoint_pose: the middle of a Gauss-rule PCS section (the middle of its middle
// step) is kept by fwd_position as exp(Omega / 2) and returned by rod_pose and
// rod_pose_and_jacobian to the bit; it equals the partial step's pose to round-off, and the
// section's own steps do not move. Only PCS steps' midpoints are taken.
TEST(RodPose, KeptMidpointsAreThePartialStepsPose) {
  Model plain = kl_rod(3, false), kept = plain;
  const double L = plain.rods[0].length, ds = L / 3;
  int taken = 0;
  for (int k = 0; k < 3; ++k) {
    const double X = (k + 0.5) * ds;
    const int i = kept.keep_midpoint_pose(0, X);
    ASSERT_GE(i, 0) << "section " << k;
    EXPECT_TRUE(kept.nodes[i].keep_mid);
    ++taken;
  }
  EXPECT_EQ(kept.keep_midpoint_pose(0, 0.3 * ds), -1);  // inside the first step, not its middle
  EXPECT_EQ(kept.keep_midpoint_pose(0, ds), -1);        // a section end
  Model gvs;
  gvs.add_rod(-1, SE3::Identity(), rod_spec("kl", 1, 2));
  gvs.finalize();
  const Node& gn = gvs.nodes[gvs.rod_node_at(0, 0.5 * gvs.rods[0].length)];
  EXPECT_EQ(gvs.keep_midpoint_pose(0, gn.X - 0.5 * gn.h), -1);  // a GVS step (commutator)
  EXPECT_EQ(taken, 3);
  Data dp(plain), dk(kept);
  dp.q = dk.q = 2.0 * VecX::Random(plain.nv);  // bent well beyond small angles
  dk.base_pose = dp.base_pose = SE3{exp_so3(Vec3(0.2, -0.5, 0.3)), Vec3(0.1, 0.2, -0.3)};
  fwd_position(plain, dp);
  fwd_position(kept, dk);
  for (size_t i = 0; i < plain.nodes.size(); ++i) {
    EXPECT_LT((dk.g[i].matrix() - dp.g[i].matrix()).norm(), 1e-14) << "node " << i;
    EXPECT_LT((dk.g_rel[i].matrix() - dp.g_rel[i].matrix()).norm(), 1e-14) << "node " << i;
  }
  for (int k = 0; k < 3; ++k) {
    const double X = (k + 0.5) * ds;
    const SE3 want = rod_pose(plain, dp, 0, X), got = rod_pose(kept, dk, 0, X);
    EXPECT_LT((got.matrix() - want.matrix()).norm(), 1e-14) << "X " << X;
    EXPECT_TRUE((got.matrix().array() == dk.g_mid[kept.rod_node_at(0, X)].matrix().array()).all());
    Mat6X J;
    const SE3 p = rod_pose_and_jacobian(kept, dk, 0, X, -1, J, nullptr);
    EXPECT_TRUE((p.matrix().array() == got.matrix().array()).all()) << "X " << X;
  }
}

}  // namespace
