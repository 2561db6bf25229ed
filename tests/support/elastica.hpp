// Independent reference for the planar Kirchhoff elastica cantilever (no solver code is used).
//
// Problem: an inextensible, unshearable rod of length L and bending stiffness EI, clamped at the
// origin with its tangent along +x, loaded in the x-z plane (z up) by its own weight w per unit
// length (pointing along -z) and a dead tip force P (also along -z).
//
// Unknowns: the tangent angle theta(s), measured from +x towards +z, and the centreline
//     x' = cos theta,   z' = sin theta,   x(0) = z(0) = 0.
// Let m(s) = EI theta'(s) be the bending moment that the part [s, L] exerts on the part [0, s]
// (positive counter-clockwise in the (x, z) plane, i.e. in the sense of increasing theta). With the
// planar cross product a x b = a_x b_z - a_z b_x, the moment balance of the piece [s, L] about
// r(s) reads
//     -m(s) + (r(L) - r(s)) x (0, -P) + int_s^L (r(sigma) - r(s)) x (0, -w) dsigma = 0,
// and since a x (0, -F) = -F a_x,
//     m(s) = -P (x(L) - x(s)) - w int_s^L (x(sigma) - x(s)) dsigma.
// Differentiating in s (x' = cos theta):
//     EI theta'' = m' = (P + w (L - s)) cos theta,
// with the clamp theta(0) = 0 and the free end theta'(L) = 0 (no tip moment). Then theta'' > 0 and
// theta' rises to 0 at L, so theta' < 0 and theta < 0: the rod bends downwards, as it must.
// (Equivalently, with the downward angle phi = -theta: EI phi'' = -(P + w (L - s)) cos phi.)
//
// Small loads: theta ~ theta_1 with EI theta_1'' = P + w (L - s), whence the linear beam tip
// deflection z(L) = -(P L^3 / (3 EI) + w L^4 / (8 EI)). A regular perturbation expansion in the
// loads (a = P L^2/EI, b = w L^3/EI scaled together by eps; derived symbolically, see
// linear_tip() and third_order_tip() below) gives
//     z(L)/L = -(8a + 3b)/24 + (4a^3/105 + 37a^2 b/960 + 43 a b^2/3240 + b^3/640) + O(eps^5),
//     x(L)/L = 1 - (a^2/15 + 7ab/144 + b^2/112) + O(eps^4).
//
// Numerical method: shooting on c = theta'(0). The boundary value problem is integrated as an
// initial value problem for (theta, theta', x, z) together with its sensitivity to c,
// (u, u') = d(theta, theta')/dc, which obeys EI u'' = -(P + w (L - s)) sin(theta) u, u(0) = 0,
// u'(0) = 1, by classical RK4 with a fixed step (default 20000 steps: the local error is
// O(h^5) ~ 1e-23 L for these smooth solutions, so the result is limited by round-off, ~1e-14 L).
// Newton's method on F(c) = theta'(L) with F'(c) = u'(L), started from the linear solution
// c = -(P L + w L^2 / 2) / EI, iterates until |F| <= 1e-13 |c_linear| (and the Newton update is
// below 1e-13 |c|). The load is ramped in (continuation) if Newton fails to contract at full load.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace elastica {

struct Cantilever {
  double L = 1.0;   // length [m]
  double EI = 1.0;  // bending stiffness [N m^2]
  double w = 0.0;   // weight per unit length [N/m], acting along -z
  double P = 0.0;   // tip force [N], acting along -z
};

struct Solution {
  double x = 0.0, z = 0.0;  // tip position
  double theta_tip = 0.0;   // tip angle (negative: pointing down)
  double kappa0 = 0.0;      // theta'(0): clamp curvature (the clamp moment is EI kappa0)
  double residual = 0.0;    // |theta'(L)| at the end of the shooting
  int newton_iterations = 0;
  bool converged = false;
};

namespace detail {

// State y = (theta, theta', x, z, u, u') with u = d theta / dc.
struct State {
  double th, k, x, z, u, up;
};

inline State rhs(const Cantilever& c, double lam, double s, const State& y) {
  const double load = lam * (c.P + c.w * (c.L - s)) / c.EI;
  const double cs = std::cos(y.th), sn = std::sin(y.th);
  return State{y.k, load * cs, cs, sn, y.up, -load * sn * y.u};
}

inline State axpy(const State& y, double h, const State& k) {
  return State{y.th + h * k.th, y.k + h * k.k, y.x + h * k.x, y.z + h * k.z, y.u + h * k.u, y.up + h * k.up};
}

// Integrates from s = 0 to L with theta'(0) = c0 at load factor lam.
inline State shoot(const Cantilever& c, double lam, double c0, int steps) {
  State y{0.0, c0, 0.0, 0.0, 0.0, 1.0};
  const double h = c.L / steps;
  for (int i = 0; i < steps; ++i) {
    const double s = i * h;
    const State k1 = rhs(c, lam, s, y);
    const State k2 = rhs(c, lam, s + 0.5 * h, axpy(y, 0.5 * h, k1));
    const State k3 = rhs(c, lam, s + 0.5 * h, axpy(y, 0.5 * h, k2));
    const State k4 = rhs(c, lam, s + h, axpy(y, h, k3));
    y.th += h / 6.0 * (k1.th + 2 * k2.th + 2 * k3.th + k4.th);
    y.k += h / 6.0 * (k1.k + 2 * k2.k + 2 * k3.k + k4.k);
    y.x += h / 6.0 * (k1.x + 2 * k2.x + 2 * k3.x + k4.x);
    y.z += h / 6.0 * (k1.z + 2 * k2.z + 2 * k3.z + k4.z);
    y.u += h / 6.0 * (k1.u + 2 * k2.u + 2 * k3.u + k4.u);
    y.up += h / 6.0 * (k1.up + 2 * k2.up + 2 * k3.up + k4.up);
  }
  return y;
}

// Newton on theta'(L) = 0 at load factor lam from the guess c0. Returns false if it stalls.
inline bool newton(const Cantilever& c, double lam, double& c0, int steps, double tol, Solution& sol) {
  State y = shoot(c, lam, c0, steps);
  for (int it = 0; it < 60; ++it) {
    sol.residual = std::abs(y.k);
    if (sol.residual <= tol) return true;
    ++sol.newton_iterations;
    if (!(std::abs(y.up) > 0.0)) return false;
    const double dc = -y.k / y.up;
    // damped Newton: halve the step until |theta'(L)| decreases
    double a = 1.0;
    bool ok = false;
    for (int ls = 0; ls < 40; ++ls, a *= 0.5) {
      const State yt = shoot(c, lam, c0 + a * dc, steps);
      if (std::isfinite(yt.k) && std::abs(yt.k) < std::abs(y.k)) {
        c0 += a * dc;
        y = yt;
        ok = true;
        break;
      }
    }
    if (!ok) {
      // no decrease possible: accept only if the last Newton step is at round-off level
      return std::abs(dc) <= 1e-13 * std::abs(c0) && sol.residual <= 100 * tol;
    }
    if (std::abs(a * dc) <= 1e-15 * std::abs(c0) && sol.residual <= 100 * tol) return true;
  }
  sol.residual = std::abs(y.k);
  return sol.residual <= tol;
}

}  // namespace detail

// Tip of the elastica cantilever. Throws std::runtime_error if the shooting does not converge.
inline Solution solve(const Cantilever& c, int steps = 20000) {
  if (!(c.L > 0 && c.EI > 0 && steps > 0)) throw std::invalid_argument("elastica::solve: bad input");
  Solution sol;
  const double c_lin = -(c.P * c.L + 0.5 * c.w * c.L * c.L) / c.EI;
  const double tol = 1e-13 * std::max(std::abs(c_lin), 1e-300);
  double kappa0 = 0.0, lam = 0.0, dlam = 1.0;
  while (lam < 1.0) {
    const double target = std::min(1.0, lam + dlam);
    // predictor: the linear clamp curvature for the load increment
    double guess = kappa0 + (target - lam) * c_lin;
    if (detail::newton(c, target, guess, steps, target * tol, sol)) {
      lam = target;
      kappa0 = guess;
      dlam = std::min(1.0, 2.0 * dlam);
    } else {
      dlam *= 0.5;
      if (dlam < 1e-6) throw std::runtime_error("elastica::solve: shooting did not converge");
    }
  }
  const detail::State y = detail::shoot(c, 1.0, kappa0, steps);
  sol.x = y.x;
  sol.z = y.z;
  sol.theta_tip = y.th;
  sol.kappa0 = kappa0;
  sol.residual = std::abs(y.k);
  sol.converged = true;
  return sol;
}

// Linear (Euler-Bernoulli) tip deflection z(L) = -(P L^3/(3 EI) + w L^4/(8 EI)).
inline double linear_tip(const Cantilever& c) {
  return -(c.P * c.L * c.L * c.L / (3.0 * c.EI) + c.w * c.L * c.L * c.L * c.L / (8.0 * c.EI));
}

// Tip position to third order in the loads (see the header comment): {x(L), z(L)}.
struct Tip {
  double x, z;
};
inline Tip third_order_tip(const Cantilever& c) {
  const double a = c.P * c.L * c.L / c.EI, b = c.w * c.L * c.L * c.L / c.EI;
  const double z = -(8 * a + 3 * b) / 24.0 +
                   (4 * a * a * a / 105.0 + 37 * a * a * b / 960.0 + 43 * a * b * b / 3240.0 + b * b * b / 640.0);
  const double x = 1.0 - (a * a / 15.0 + 7 * a * b / 144.0 + b * b / 112.0);
  return Tip{c.L * x, c.L * z};
}

}  // namespace elastica
