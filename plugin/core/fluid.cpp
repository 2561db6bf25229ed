#include "fluid.hpp"

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

#include "dynamics.hpp"

namespace cosserat {

RftCoefficients gray_hancock(double mu, double a, double lambda) {
  const double L = std::log(2.0 * lambda / a);
  return {2.0 * M_PI * mu / (L - 0.5), 4.0 * M_PI * mu / (L + 0.5), 4.0 * M_PI * mu * a * a};
}

RftCoefficients lighthill(double mu, double a, double Lambda) {
  const double L = std::log(2.0 * 0.09 * Lambda / a);
  return {2.0 * M_PI * mu / L, 8.0 * M_PI * mu / (1.0 + 2.0 * L), 4.0 * M_PI * mu * a * a};
}

Helix helix_of(const Vec6& xi) {
  const Vec3 k = xi.head<3>(), p = xi.tail<3>();
  const double k2 = k.squaredNorm();
  Helix h;
  if (k2 == 0.0) return h;
  h.radius = k.cross(p).norm() / k2;
  h.pitch = 2.0 * M_PI * k.dot(p) / k2;
  const double scale = 1.0 / std::sqrt(k2);
  h.helical = h.radius > 1e-9 * scale && std::abs(h.pitch) > 1e-9 * scale;
  return h;
}

RodFluidInfo set_rod_drag(Model& m, int rod, const RodFluid& f) {
  const Rod& r = m.rods.at(rod);
  RodFluidInfo info;
  // the wave: the first helical section's rest strain, unless given. A helix whose pitch is under
  // a tenth of a turn's arc length (its tangent within 6 degrees of the plane the turns lie in) is
  // taken as planar: as the twist of a curved section goes to zero its pitch does too, and the
  // pitch as the slender-body length made the coefficients grow without bound (outside probe BD: an
  // arc of 0.2 m twisted by 0.03 1/m, 0.6 mm out of its plane, had c_t 31 times the planar
  // arc's; at 1e-3 1/m they came out negative and the model was refused)
  Helix hx;
  for (int s = r.first_section; s < r.first_section + r.nsections && !hx.helical; ++s) {
    const Helix h = helix_of(m.sections[s].rest_strain);
    const double turn = 2.0 * M_PI / m.sections[s].rest_strain.head<3>().norm();  // arc length of a turn
    if (h.helical && std::abs(h.pitch) < kPlanarPitch * turn) {
      if (info.nearly_planar_section < 0) info.nearly_planar_section = s - r.first_section;
      continue;
    }
    hx = h;
  }
  info.helical = hx.helical;
  double lambda = f.wavelength > 0 ? f.wavelength : hx.helical ? std::abs(hx.pitch) : 0.5 * r.length;
  info.default_wavelength = !(f.wavelength > 0);
  if (f.drag) lambda = 0.0;
  info.wavelength = lambda;
  // Lambda along the filament: one turn of the helix (lambda / cos(pitch angle)); lambda itself
  // on a rod without a helical section
  const double Lambda = hx.helical ? std::hypot(lambda, 2.0 * M_PI * hx.radius) : lambda;
  info.law = f.drag                                                            ? RodFluidInfo::Law::Explicit
             : f.model == RftModel::Lighthill && (hx.helical || f.wavelength > 0) ? RodFluidInfo::Law::Lighthill
                                                                                   : RodFluidInfo::Law::GrayHancock;
  if (info.law == RodFluidInfo::Law::Lighthill) info.along_filament = Lambda;
  auto coefficients = [&](double a) {
    if (f.drag) {
      RftCoefficients c = *f.drag;
      if (c.crot <= 0) c.crot = 4.0 * M_PI * f.viscosity * a * a;
      return c;
    }
    if (info.law == RodFluidInfo::Law::Lighthill) return lighthill(f.viscosity, a, Lambda);
    return gray_hancock(f.viscosity, a, lambda);
  };
  info.base = coefficients(r.radius(0.0));
  for (int i = r.first_node; i <= r.tip_node; ++i) {
    Node& n = m.nodes[i];
    n.drag.setZero();
    if (!f.enabled || n.dX <= 0.0) continue;
    const RftCoefficients c = coefficients(r.radius(n.X));
    if (!valid(c))
      throw std::invalid_argument("rod '" + r.name + "': resistive-force coefficients are not positive (c_t = " +
                                  std::to_string(c.ct) + ", c_n = " + std::to_string(c.cn) +
                                  "): the filament is too thick for its wavelength " + std::to_string(lambda) +
                                  " m; give the drag coefficients explicitly");
    n.drag.diagonal() << c.crot, 0.0, 0.0, c.ct, c.cn, c.cn;
    n.drag *= n.dX;
  }
  if (m.finalized) m.update_fixed_composites();
  return info;
}

bool has_drag(const Model& m) {
  for (const Node& n : m.nodes)
    if (!n.drag.isZero(0.0)) return true;
  return false;
}

void fluid_damping(const Model& m, Data& d) { composite(m, d, NodeMatrix::Drag, d.D_fluid, d.Dc_base, d.DF_base); }

void add_fluid_force(const Model& m, const Data& d, VecX& tau, Vec6* base_wrench) {
  (void)m;
  tau.noalias() -= d.D_fluid * d.v;
  tau.noalias() -= d.DF_base.transpose() * d.base_twist;
  if (base_wrench) *base_wrench = -(d.DF_base * d.v + d.Dc_base * d.base_twist);
}

Mat6 sphere_resistance(double mu, double a) {
  Mat6 C = Mat6::Zero();
  C.diagonal() << Vec3::Constant(8.0 * M_PI * mu * a * a * a), Vec3::Constant(6.0 * M_PI * mu * a);
  return C;
}

namespace {
// Adaptive Gauss-Legendre quadrature of a smooth f on [a, b]: a 10-point rule against the sum of
// its two halves, bisecting until they agree to `tol` (relative to the running total).
double integrate(const std::function<double(double)>& f, double a, double b, double tol, int depth = 0) {
  struct Rule {
    std::vector<double> x, w;
    Rule() { gauss_legendre01(10, x, w); }
  };
  static const Rule gl;  // thread-safe initialisation
  auto rule = [&](double lo, double hi) {
    double s = 0.0;
    for (size_t k = 0; k < gl.x.size(); ++k) s += gl.w[k] * f(lo + (hi - lo) * gl.x[k]);
    return s * (hi - lo);
  };
  const double whole = rule(a, b), mid = 0.5 * (a + b);
  const double halves = rule(a, mid) + rule(mid, b);
  if (std::abs(whole - halves) <= tol * std::abs(halves) || depth > 40) return halves;
  return integrate(f, a, mid, tol, depth + 1) + integrate(f, mid, b, tol, depth + 1);
}
}  // namespace

Mat6 ellipsoid_resistance(double mu, const Vec3& s) {
  if (!(s.minCoeff() > 0)) throw std::invalid_argument("ellipsoid_resistance: semi-axes must be positive");
  // substitution l = c (1/t^2 - 1), c = min s_i^2, t in (0, 1]: s_i^2 + l = P_i(t) / t^2 with
  // P_i = c + (s_i^2 - c) t^2 >= c > 0, and both integrands become smooth on [0, 1]:
  //   chi = int_0^1 2c / sqrt(P_1 P_2 P_3) dt,   alpha_i = int_0^1 2c t^2 / (P_i sqrt(P_1 P_2 P_3)) dt
  const Vec3 s2 = s.cwiseProduct(s);
  const double c = s2.minCoeff();
  auto P = [&](int i, double t) { return c + (s2(i) - c) * t * t; };
  auto root = [&](double t) { return std::sqrt(P(0, t) * P(1, t) * P(2, t)); };
  const double tol = 1e-13;
  const double chi = integrate([&](double t) { return 2.0 * c / root(t); }, 0.0, 1.0, tol);
  Vec3 alpha;
  for (int i = 0; i < 3; ++i)
    alpha(i) = integrate([&](double t) { return 2.0 * c * t * t / (P(i, t) * root(t)); }, 0.0, 1.0, tol);
  Mat6 C = Mat6::Zero();
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    C(i, i) = 16.0 * M_PI * mu * (s2(j) + s2(k)) / (3.0 * (s2(j) * alpha(j) + s2(k) * alpha(k)));
    C(3 + i, 3 + i) = 16.0 * M_PI * mu / (chi + s2(i) * alpha(i));
  }
  return C;
}

Mat6 segment_resistance(const RftCoefficients& c, double L, int axis) {
  Mat6 C = Mat6::Zero();
  for (int i = 0; i < 3; ++i) {
    const bool along = i == axis;
    C(i, i) = along ? c.crot * L : c.cn * L * L * L / 12.0;
    C(3 + i, 3 + i) = along ? c.ct * L : c.cn * L;
  }
  return C;
}

}  // namespace cosserat
