#include "integrators.hpp"

#include <stdexcept>

#include "dynamics.hpp"
#include "kinematics.hpp"

namespace cosserat {

std::optional<Integrator> integrator_from_name(std::string_view n) {
  if (n == "euler") return Integrator::Euler;
  if (n == "implicit") return Integrator::Implicit;
  if (n == "rk4") return Integrator::RK4;
  if (n == "trapezoidal") return Integrator::Trapezoidal;
  if (n == "genalpha") return Integrator::GeneralizedAlpha;
  if (n == "midpoint") return Integrator::Midpoint;
  if (n == "rosenbrock") return Integrator::Rosenbrock;
  return std::nullopt;
}

const char* integrator_name(Integrator method) {
  switch (method) {
    case Integrator::Euler: return "euler";
    case Integrator::Implicit: return "implicit";
    case Integrator::RK4: return "rk4";
    case Integrator::Trapezoidal: return "trapezoidal";
    case Integrator::GeneralizedAlpha: return "genalpha";
    case Integrator::Midpoint: return "midpoint";
    case Integrator::Rosenbrock: return "rosenbrock";
  }
  return "?";
}

namespace {
// Semi-implicit step; `stiffness_implicit` selects Implicit (theta = 1) or Trapezoidal
// (theta = 1/2) over Euler (damping implicit, stiffness explicit). With v+ = v + dv:
//   (M + theta h D + theta^2 h^2 K) v+ = (M + theta h D + theta^2 h^2 K) v + h M a - theta h^2 K v,
//   q+ = q + h ((1 - theta) v + theta v+),   M a = tau_act - bias - K (q - q_ref) - D v.
void step_semi_implicit(const Model& m, Data& d, double h, bool stiffness_implicit, double theta = 1.0) {
  smooth_forces(m, d);  // qfrc_passive is an output; the force used below splits it
  d.tmp = d.q - m.q_ref;
  d.rhs = d.qfrc_actuator - d.qfrc_bias;
  d.rhs.noalias() -= m.K * d.tmp;
  d.rhs *= h;
  d.rhs.noalias() += d.M * d.v;
  if (theta != 1.0) {  // (theta h D + theta^2 h^2 K) v - h D v - theta h^2 K v (d.tmp: scratch)
    d.tmp.noalias() = m.D * d.v;
    d.rhs += ((theta - 1.0) * h) * d.tmp;
    d.tmp.noalias() = m.K * d.v;
    d.rhs += ((theta * theta - theta) * h * h) * d.tmp;
  }
  d.A = d.M + (theta * h) * m.D;
  if (stiffness_implicit) d.A += (theta * theta * h * h) * m.K;
  d.ldlt.compute(d.A);
  d.tmp = d.ldlt.solve(d.rhs);  // v+
  d.qacc = (d.tmp - d.v) / h;
  d.q.noalias() += ((1.0 - theta) * h) * d.v;
  d.v = d.tmp;
  d.q.noalias() += (theta * h) * d.v;
}

void step_rk4(const Model& m, Data& d, double h) {
  d.q0 = d.q;
  d.v0 = d.v;
  static constexpr double a[3] = {0.5, 0.5, 1.0};
  for (int s = 0; s < 4; ++s) {
    if (s > 0) {
      d.q = d.q0 + (a[s - 1] * h) * d.kq[s - 1];
      d.v = d.v0 + (a[s - 1] * h) * d.kv[s - 1];
    }
    forward(m, d);
    d.kq[s] = d.v;
    d.kv[s] = d.qacc;
  }
  d.q = d.q0 + (h / 6.0) * (d.kq[0] + 2.0 * d.kq[1] + 2.0 * d.kq[2] + d.kq[3]);
  d.v = d.v0 + (h / 6.0) * (d.kv[0] + 2.0 * d.kv[1] + 2.0 * d.kv[2] + d.kv[3]);
  d.qacc = (1.0 / 6.0) * (d.kv[0] + 2.0 * d.kv[1] + 2.0 * d.kv[2] + d.kv[3]);
}

// ROS34PW2 (integrators.hpp) with u_q, u_v in kq, kv.
void step_rosenbrock(const Model& m, Data& d, double h) {
  namespace R = ros34pw2;
  const double hg = h * R::gamma, t0 = d.time;
  for (int st = 0; st < R::kStages; ++st) {
    if (st > 0) {  // Y_st = y + sum_j a_stj u_j
      d.q = d.q0;
      d.v = d.v0;
      for (int j = 0; j < st; ++j) {
        d.q += R::a[st][j] * d.kq[j];
        d.v += R::a[st][j] * d.kv[j];
      }
      d.time = t0 + R::c[st] * h;
    }
    forward(m, d);  // (uses d.ldlt and d.rhs: the step's matrix has its own factor)
    if (st == 0) {
      d.M0 = d.M;
      d.A = d.M + hg * m.D + (hg * hg) * m.K;
      d.ldlt_w.compute(d.A);
    }
    d.tmp = d.v;     // r_q
    d.rhs = d.qacc;  // r_v
    for (int j = 0; j < st; ++j) {
      d.tmp += (R::C[st][j] / h) * d.kq[j];
      d.rhs += (R::C[st][j] / h) * d.kv[j];
    }
    VecX& uv = d.kv[st];
    uv.noalias() = hg * d.M0 * d.rhs;
    uv.noalias() -= (hg * hg) * m.K * d.tmp;
    d.ldlt_w.solveInPlace(uv);
    d.kq[st] = hg * (d.tmp + uv);
  }
  d.q = d.q0;
  d.v = d.v0;
  for (int st = 0; st < R::kStages; ++st) {
    d.q += R::b[st] * d.kq[st];
    d.v += R::b[st] * d.kv[st];
  }
  d.qacc = (d.v - d.v0) / h;
  d.time = t0;  // step() adds h
}
}  // namespace

Status step(const Model& m, Data& d, double h, Integrator method) {
  d.q0 = d.q;
  d.v0 = d.v;
  switch (method) {
    case Integrator::Euler: step_semi_implicit(m, d, h, false); break;
    case Integrator::Implicit: step_semi_implicit(m, d, h, true); break;
    case Integrator::RK4: step_rk4(m, d, h); break;
    case Integrator::Trapezoidal: step_semi_implicit(m, d, h, true, 0.5); break;
    case Integrator::GeneralizedAlpha:
      throw std::invalid_argument("the generalized-alpha integrator is the scene's (mj::step) only");
    case Integrator::Midpoint:
      throw std::invalid_argument("the midpoint integrator is the scene's (mj::step) only");
    case Integrator::Rosenbrock: step_rosenbrock(m, d, h); break;
  }
  if (!d.q.allFinite() || !d.v.allFinite()) {
    // our own divergence check: restore the last good state and report
    d.q = d.q0;
    d.v = d.v0;
    d.status = Status::Diverged;
    return d.status;
  }
  d.time += h;
  d.status = Status::Ok;
  return d.status;
}

}  // namespace cosserat
