#include "statics.hpp"

#include <cmath>
#include <cstdio>

#include <Eigen/LU>

#include "dynamics.hpp"
#include "kinematics.hpp"

namespace cosserat {

double static_residual(const Model& m, Data& d, double lambda, VecX& r) {
  d.v.setZero();
  fwd_position(m, d);
  fwd_velocity(m, d);
  d.rhs.setZero();
  rnea(m, d, d.rhs, true, true, d.qfrc_bias);  // gravity and external loads at rest
  actuation(m, d);
  const VecX load = d.qfrc_bias - d.qfrc_actuator;
  const VecX el = m.K * (d.q - m.q_ref);
  r = el + lambda * load;
  return std::max({el.norm(), load.norm(), 1e-300});
}

void tangent_stiffness(const Model& m, Data& d, double lambda, MatX& Kt) {
  const int n = m.nv;
  Kt.resize(n, n);
  VecX rp(n), rm(n);
  const VecX q = d.q;
  for (int j = 0; j < n; ++j) {
    const double e = 1e-6 * std::max(1.0, std::abs(q(j)));
    d.q = q;
    d.q(j) += e;
    static_residual(m, d, lambda, rp);
    d.q(j) = q(j) - e;
    static_residual(m, d, lambda, rm);
    Kt.col(j) = (rp - rm) / (2.0 * e);
  }
  d.q = q;
}

namespace {
// Newton with backtracking at a fixed load factor. Returns true on convergence.
bool newton(const Model& m, Data& d, double lambda, const StaticsOptions& opt, StaticsResult& res) {
  const int n = m.nv;
  VecX r(n), rt(n), dq(n);
  MatX Kt;
  double scale = static_residual(m, d, lambda, r);
  for (int it = 0; it < opt.max_iterations; ++it) {
    res.residual = r.norm() / scale;
    res.scale = scale;
    if (res.residual <= opt.tolerance) return true;
    ++res.iterations;
    tangent_stiffness(m, d, lambda, Kt);
    Eigen::PartialPivLU<MatX> lu(Kt);
    dq = -lu.solve(r);
    if (!dq.allFinite()) return false;
    const VecX q = d.q;
    const double f0 = r.norm();
    double alpha = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 30; ++ls, alpha *= 0.5) {
      d.q = q + alpha * dq;
      const double s = static_residual(m, d, lambda, rt);
      if (rt.allFinite() && rt.norm() <= (1.0 - 1e-4 * alpha) * f0) {
        r = rt;
        scale = s;
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      d.q = q;
      // a residual already at round-off level cannot decrease further
      res.residual = f0 / scale;
      return res.residual <= 1e3 * opt.tolerance;
    }
  }
  res.residual = r.norm() / scale;
  return res.residual <= opt.tolerance;
}
}  // namespace

StaticsResult equilibrium(const Model& m, Data& d, const StaticsOptions& opt) {
  StaticsResult res;
  for (const auto& n : m.nodes) {
    if (n.free_joint) {
      res.message = "a free-floating base has no static equilibrium";
      return res;
    }
  }
  double lam = 0.0, dlam = 1.0;
  VecX q_good = d.q;
  int halvings = 0;
  while (lam < 1.0) {
    const double target = std::min(1.0, lam + dlam);
    if (newton(m, d, target, opt, res)) {
      lam = target;
      q_good = d.q;
      ++res.load_steps;
      dlam *= 2.0;
    } else {
      d.q = q_good;
      dlam *= 0.5;
      if (++halvings > opt.max_load_halvings) {
        res.message = "no convergence: load continuation stalled at load factor " + load_factor_text(lam);
        d.v.setZero();
        return res;
      }
    }
  }
  res.converged = true;
  res.message = "converged";
  d.v.setZero();
  return res;
}

std::string load_factor_text(double lambda) {
  char b[32];
  std::snprintf(b, sizeof b, "%.10g", lambda);
  return b;
}

}  // namespace cosserat
