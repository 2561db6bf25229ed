// External loads (plugin/core/dynamics.cpp): distributed and point loads against gravity and
// against node loads, which are independent code paths.
#include <gtest/gtest.h>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "support/test_models.hpp"

using namespace cosserat;
using namespace cosserat::testing;

namespace {

// A rod's weight is a uniform force rho A g per length: applying it as a distributed load with
// gravity off must give the same generalised force as gravity (untapered rod, no other bodies).
TEST(Loads, DistributedForceEqualsOwnWeight) {
  for (int order : {0, 2}) {
    Model m;
    RodSpec s = rod_spec("sr", 3, order, 0.4, 0.01);
    m.add_rod(-1, SE3(exp_so3(Vec3(0.2, -0.4, 0.1)), Vec3(0.1, 0, 0)), s);
    m.finalize();
    Data d(m);
    d.q = 0.3 * VecX::Random(m.nv);
    fwd_position(m, d);
    fwd_velocity(m, d);
    VecX tg(m.nv), tf(m.nv);
    rnea(m, d, VecX::Zero(m.nv), true, false, tg);
    const double rhoA = s.section.material.density * M_PI * 0.01 * 0.01;
    add_distributed_force(m, d, 0, rhoA * m.gravity);
    rnea(m, d, VecX::Zero(m.nv), false, true, tf);
    EXPECT_LT((tg - tf).norm(), 1e-12 * tg.norm()) << "order " << order;
  }
}

// A world force at a node's abscissa through the rod Jacobian equals the node load through RNEA.
TEST(Loads, PointWrenchAtAbscissaEqualsNodeLoad) {
  Model m = hybrid_tree(false);
  Data d(m);
  d.q = 0.4 * VecX::Random(m.nv);
  fwd_position(m, d);
  fwd_velocity(m, d);
  const int r = 0;
  const int node = m.sections[m.rods[r].first_section + 1].first_node + 1;
  const Vec3 mo(0.01, -0.02, 0.03), fo(0.5, -1.0, 2.0);
  VecX tau = VecX::Zero(m.nv);
  add_rod_point_wrench(m, d, r, m.nodes[node].X, mo, fo, tau);
  d.f_ext_world[node] << mo, fo;
  VecX t0(m.nv), t1(m.nv);
  rnea(m, d, VecX::Zero(m.nv), false, false, t0);
  rnea(m, d, VecX::Zero(m.nv), false, true, t1);
  // rnea subtracts external loads: bias(ext) = bias(no ext) - J^T F
  EXPECT_LT((t0 - t1 - tau).norm(), 1e-12 * (1 + tau.norm()));
}

// Virtual work: a world force at X does work f . dp(X) for a displacement dq.
TEST(Loads, PointForceIsVirtualWorkOfDisplacement) {
  Model m = hybrid_tree(false);
  Data d(m);
  d.q = 0.4 * VecX::Random(m.nv);
  fwd_position(m, d);
  const Vec3 f(0.3, -0.7, 1.1);
  const double X = 0.37 * m.rods[0].length;
  VecX tau = VecX::Zero(m.nv);
  add_rod_point_wrench(m, d, 0, X, Vec3::Zero(), f, tau);
  const double e = 1e-6;
  for (int k = 0; k < m.nv; ++k) {
    Data dp = d, dm = d;
    dp.q(k) += e;
    dm.q(k) -= e;
    fwd_position(m, dp);
    fwd_position(m, dm);
    const double work = f.dot(rod_pose(m, dp, 0, X).u - rod_pose(m, dm, 0, X).u) / (2 * e);
    EXPECT_NEAR(work, tau(k), 1e-7 * (1 + std::abs(tau(k))));  // central difference, sqrt-eps level
  }
}

}  // namespace
