#include "linearize.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "statics.hpp"

namespace cosserat {

Linearization linearize(const Model& m, Data& d) {
  const int n = m.nv, nu = m.nu();
  Linearization L;
  tangent_stiffness(m, d, 1.0, L.Kt);
  d.v.setZero();
  fwd_position(m, d);
  crba(m, d);
  L.M = d.M;
  L.D = m.D;
  // actuation is linear in u at fixed q: one column per unit input
  L.Bu = MatX::Zero(n, nu);
  const VecX u0 = d.ctrl;
  for (int k = 0; k < nu; ++k) {
    d.ctrl.setZero();
    d.ctrl(k) = 1.0;
    actuation(m, d);
    L.Bu.col(k) = d.qfrc_actuator;
  }
  d.ctrl = u0;
  actuation(m, d);

  state_space(L);
  return L;
}

bool unstable_mode(const VecX& x, const MatX& K, const MatX& M, double noise) {
  const double mass = x.dot(M * x);
  if (!(mass > 0)) return false;
  const VecX ax = x.cwiseAbs();
  return x.dot(K * x) < -std::max(1e-4 * ax.dot(K.cwiseAbs() * ax), noise);
}

bool unstable_mode_fd(const VecX& x, const MatX& K, const MatX& M, double noise, const MatX* held) {
  const double mass = x.dot(M * x);
  if (!(mass > 0)) return false;
  const VecX ax = x.cwiseAbs();
  const double held_scale = held && held->size() ? ax.dot(held->cwiseAbs() * ax) : 0.0;
  const double rounding = static_cast<double>(x.size()) * std::numeric_limits<double>::epsilon() * ax.dot(K.cwiseAbs() * ax);
  return x.dot(K * x) < -std::max({noise, 1e-4 * held_scale, rounding});
}

double noise_bound(const VecX& ax, const MatX& N) { return ax.dot(N * ax); }

MatX state_matrix(const Eigen::PartialPivLU<MatX>& M, const MatX& K, const MatX& D) {
  const int n = static_cast<int>(K.rows());
  MatX A = MatX::Zero(2 * n, 2 * n);
  A.topRightCorner(n, n).setIdentity();
  A.bottomLeftCorner(n, n) = -M.solve(K);
  A.bottomRightCorner(n, n) = -M.solve(D);
  return A;
}

GrowthModes growth_modes(const MatX& A, double floor) {
  GrowthModes g;
  const int n = static_cast<int>(A.rows()) / 2;
  if (n == 0) return g;
  Eigen::EigenSolver<MatX> es(A);
  if (es.info() != Eigen::Success) return g;
  // (the eigensolver's rounding, relative to A's norm: a rod's stiff axial modes set it)
  const double rounding = 64.0 * std::numeric_limits<double>::epsilon() * A.cwiseAbs().rowwise().sum().maxCoeff();
  for (int i = 0; i < 2 * n; ++i) {
    const std::complex<double> s = es.eigenvalues()(i);
    if (!(s.real() > std::max({floor, 1e-6 * std::abs(s), rounding}))) continue;
    if (std::abs(s.imag()) > 1e-6 * std::abs(s)) {
      if (s.imag() > 0) ++g.growing_pairs;
      if (s.real() > g.rate) {
        g.rate = s.real(), g.hz = std::abs(s.imag()) / (2.0 * M_PI);
        g.flutter_mode = es.eigenvectors().col(i).head(n).real();
      }
    } else {
      ++g.diverging;
      if (-s.real() * s.real() < g.divergence_omega2) {
        g.divergence_omega2 = -s.real() * s.real();
        g.divergence_mode = es.eigenvectors().col(i).head(n).real();
      }
    }
  }
  return g;
}

void state_space(Linearization& L) {
  const int n = static_cast<int>(L.M.rows()), nu = static_cast<int>(L.Bu.cols());
  if (n == 0) {  // nothing moves (every motion held by constraints): no modes (Eigen's solvers fail on 0 x 0)
    L.A = MatX(0, 0);
    L.B = MatX(0, nu);
    L.frequencies_hz = L.omega2 = L.damping_ratios = VecX(0);
    L.modes = MatX(0, 0);
    L.unstable_modes = 0;
    return;
  }
  Eigen::PartialPivLU<MatX> lu(L.M);
  const MatX K_motion = L.dMa.size() ? MatX(L.Kt + L.dMa) : L.Kt;  // (the motion's stiffness in A)
  L.A = state_matrix(lu, K_motion, L.D);
  L.B = MatX::Zero(2 * n, nu);
  L.B.bottomRows(n) = lu.solve(L.Bu);
  // (the structure's, for the growth of its modes below: without the motion's dMa)
  const MatX A_settled = L.dMa.size() ? state_matrix(lu, L.Kt, L.D) : L.A;
  if (const int na = static_cast<int>(L.Fa.cols()); na > 0) {
    MatX A = MatX::Zero(2 * n + na, 2 * n + na);
    A.topLeftCorner(2 * n, 2 * n) =
        state_matrix(lu, L.dKt.size() ? MatX(K_motion + L.dKt) : K_motion, L.dD.size() ? MatX(L.D + L.dD) : L.D);
    A.block(n, 2 * n, n, na) = lu.solve(L.Fa);
    if (L.Gq.size()) A.block(2 * n, 0, na, n) = L.Gq;
    if (L.Gv.size()) A.block(2 * n, n, na, n) = L.Gv;
    A.bottomRightCorner(na, na) = L.Ga;
    L.A = A;
    L.B = MatX::Zero(2 * n + na, nu);
    L.B.middleRows(n, n) = lu.solve(L.Bd);
    L.B.bottomRows(na) = L.Gu;
  }

  // Kt is symmetric for conservative loads; follower loads make it slightly unsymmetric.
  const MatX Ks = 0.5 * (L.Kt + L.Kt.transpose());
  // the noise bound of a mode x (in L's coordinates; dq = basis x where there is a basis)
  auto noise = [&L](const VecX& x) {
    if (L.Kt_noise.size() == 0) return 0.0;
    const VecX ax = L.basis.size() ? VecX(L.basis.cwiseAbs() * x.cwiseAbs()) : VecX(x.cwiseAbs());
    return noise_bound(ax, L.Kt_noise);
  };
  // (unstable_mode_fd where Kt comes from finite differences with their noise bound)
  auto unstable = [&L, &noise](const VecX& x, const MatX& K) {
    return L.Kt_noise.size() ? unstable_mode_fd(x, K, L.M, noise(x), &L.Kt_held) : unstable_mode(x, K, L.M);
  };
  L.frequencies_hz.resize(n);
  L.omega2.resize(n);
  L.damping_ratios.resize(0);
  L.unstable_modes = 0;
  if ((L.Kt - Ks).norm() <= 1e-6 * Ks.norm()) {
    Eigen::GeneralizedSelfAdjointEigenSolver<MatX> es(Ks, L.M);  // ascending, x^T M x = 1
    L.modes = es.eigenvectors();
    L.damping_ratios.resize(n);
    for (int i = 0; i < n; ++i) {
      L.omega2(i) = es.eigenvalues()(i);
      const double w = es.eigenvalues()(i) > 0 ? std::sqrt(es.eigenvalues()(i)) : 0.0;  // (not -0 for -0)
      const VecX x = es.eigenvectors().col(i);
      L.frequencies_hz(i) = w / (2.0 * M_PI);
      L.damping_ratios(i) = w > 0 ? x.dot(L.D * x) / (2.0 * w) + 0.0 : std::nan("");  // (+ 0: not -0)
      if (L.omega2(i) < -L.neutral_omega2 && unstable(x, Ks)) ++L.unstable_modes;
    }
    L.diverging_modes = L.unstable_modes;
  } else {
    // (follower loads) a real mode's quotient x'Kt x = x'Ks x (its eigenvector's real part)
    Eigen::EigenSolver<MatX> es(lu.solve(L.Kt));
    std::vector<std::pair<double, VecX>> modes;
    for (int i = 0; i < n; ++i) modes.emplace_back(es.eigenvalues()(i).real(), es.eigenvectors().col(i).real());
    std::sort(modes.begin(), modes.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    L.modes.resize(n, n);
    L.damping_ratios.resize(n);
    for (int i = 0; i < n; ++i) {
      const double mass = modes[i].second.dot(L.M * modes[i].second);
      L.modes.col(i) = mass > 0 ? VecX(modes[i].second / std::sqrt(mass)) : modes[i].second;
      L.omega2(i) = modes[i].first;
      const double w = modes[i].first > 0 ? std::sqrt(modes[i].first) : 0.0;
      L.frequencies_hz(i) = w / (2.0 * M_PI);
      const VecX x = L.modes.col(i);
      L.damping_ratios(i) = w > 0 ? x.dot(L.D * x) / (2.0 * w) + 0.0 : std::nan("");
    }
    // stability from the damped state matrix, which the damping decides where the loads turn with
    // the structure (outside probe BR: a rod under a follower end moment with viscosity 6e3 Pa s
    // grew at 0.0034 1/s in its own run, and had been read stable from M^-1 Kt's real parts):
    // divergence, a real eigenvalue above the floor; flutter, a growing complex pair
    // (where constraint rows held rigid carry loads, the smooth forces are out of balance and their
    // stiffness unsymmetric whatever the loads, a contact's friction at a pin too: divergence is
    // judged from the real modes' quotients as before, below the noise)
    if (L.Kt_held.size() > 0) {
      for (int i = 0; i < n; ++i)
        if (modes[i].first < -L.neutral_omega2 && unstable(modes[i].second, Ks)) ++L.unstable_modes;
      L.diverging_modes = L.unstable_modes;
      return;
    }
    const GrowthModes g = growth_modes(A_settled, std::sqrt(std::max(L.neutral_omega2, 0.0)));
    L.diverging_modes = g.diverging;
    L.unstable_modes = g.diverging + g.growing_pairs;
    L.flutter_rate = g.rate;
    L.flutter_hz = g.hz;
  }
}

}  // namespace cosserat
