#include "rod_visual.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "kinematics.hpp"

namespace cosserat::render {

namespace {

constexpr int kEndRings = 8;  // rings of a round end

// Section (global index in the rod's model) containing abscissa X of its rod.
const Section& section_at(const Model& m, double X) {
  const Rod& rod = m.rods[0];
  int k = rod.first_section;
  while (k + 1 < rod.first_section + rod.nsections && X > m.sections[k].X0 + m.sections[k].length) ++k;
  return m.sections[k];
}

// Axial (e) and shear (g) surface strain at X, see rod_strain_magnitude.
std::pair<double, double> surface_strain(const mj::Scene& s, const mj::SceneData& sd, int r, double X) {
  const Model& m = s.rods[r].model;
  const Vec6 dxi = rod_strain(m, sd.rod[r], 0, X) - section_at(m, X).rest_strain;
  const double radius = m.rods[0].radius(X);
  const double e = std::abs(dxi[3]) + radius * std::hypot(dxi[1], dxi[2]);
  const double g = std::hypot(dxi[4], dxi[5]) + radius * std::abs(dxi[0]);
  return {e, g};
}

// The automatic "<rod>/base" and "<rod>/tip" sites (not drawn: the tube shows where they are).
bool generated_site(const mj::Scene& s, int site) {
  const char* n = mj_id2name(s.m, mjOBJ_SITE, site);
  const std::string name = n ? n : "";
  for (const mj::RodBinding& rb : s.rods)
    if (name == rb.decl.name + "/base" || name == rb.decl.name + "/tip") return true;
  return false;
}

double field(const mj::Scene& s, const mj::SceneData& sd, int r, double X, RodColoring c) {
  return c == RodColoring::Stress ? rod_stress_magnitude(s, sd, r, X) : rod_strain_magnitude(s, sd, r, X);
}

}  // namespace

RodColoring parse_rod_coloring(const std::string& name) {
  if (name == "model") return RodColoring::Model;
  if (name == "strain") return RodColoring::Strain;
  if (name == "stress") return RodColoring::Stress;
  throw std::invalid_argument("unknown rod colouring '" + name + "' (model, strain or stress)");
}

std::vector<double> rod_samples(const mj::Scene& s, const mj::SceneData& sd, int r, const RodVisualOptions& o) {
  const Model& m = s.rods[r].model;
  const Rod& rod = m.rods[0];
  const double L = rod.length;
  std::vector<double> X{0.0};
  if (o.segments > 0) {
    for (int i = 1; i <= o.segments; ++i) X.push_back(L * i / o.segments);
    return X;
  }
  // longest interval starting at x: the tangent turns by at most 0.05 rad
  auto longest = [&](double x) {
    const Vec6 xi = rod_strain(m, sd.rod[r], 0, x);
    const Vec3 k = xi.head<3>(), p = xi.tail<3>();
    const double turning = p.norm() > 0 ? k.cross(p).norm() / p.norm() : k.norm();  // tangent's rate of turn
    return turning > 0 ? 0.05 / turning : L;
  };
  const double h_min = L / kMaxRodSegments, h_max = L / 16;
  for (double x = 0; x < L;) {
    double h = longest(x);
    h = std::min(h, longest(std::min(x + h, L)));  // do not run into a more curved section
    h = std::clamp(h, h_min, h_max);
    x = x + h > L - 0.25 * h_min ? L : x + h;
    X.push_back(x);
  }
  return X;
}

int max_rod_tubes(const mj::Scene& s) {
  int n = 0;
  for (const auto& rod : s.rods) n += static_cast<int>(rod.geom_id.size() + 1) / 2;  // runs of shown capsules
  return n;
}

double rod_strain_magnitude(const mj::Scene& s, const mj::SceneData& sd, int r, double X) {
  const auto [e, g] = surface_strain(s, sd, r, X);
  return std::hypot(e, g);
}

double rod_stress_magnitude(const mj::Scene& s, const mj::SceneData& sd, int r, double X) {
  const auto [e, g] = surface_strain(s, sd, r, X);
  const RodMaterial& mat = section_at(s.rods[r].model, X).material;
  const double E = mat.young, G = mat.shear_modulus();
  return std::sqrt((E * e) * (E * e) + 3.0 * (G * g) * (G * g));
}

void colormap(double t, float rgb[3]) {
  static const float stops[5][3] = {{0.267f, 0.005f, 0.329f},
                                    {0.229f, 0.322f, 0.546f},
                                    {0.128f, 0.567f, 0.551f},
                                    {0.369f, 0.789f, 0.383f},
                                    {0.993f, 0.906f, 0.144f}};
  t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) * 4.0 : 0.0;
  const int i = std::min(static_cast<int>(t), 3);
  const float f = static_cast<float>(t - i);
  for (int k = 0; k < 3; ++k) rgb[k] = (1 - f) * stops[i][k] + f * stops[i + 1][k];
}

std::vector<Tube> rod_tubes(const mj::Scene& s, const mj::SceneData& sd, const RodVisualOptions& o, mjvScene* scn) {
  // take the rods' capsules out, keeping each one's look, and their generated sites
  std::vector<std::vector<const mjvGeom*>> look(s.rods.size());
  for (size_t r = 0; r < s.rods.size(); ++r) look[r].assign(s.rods[r].geom_id.size(), nullptr);
  std::vector<mjvGeom> removed;
  removed.reserve(scn->ngeom);
  int kept = 0;
  for (int i = 0; i < scn->ngeom; ++i) {
    const mjvGeom& g = scn->geoms[i];
    if (g.objtype == mjOBJ_GEOM && g.objid >= 0 && s.geom_rod[g.objid] >= 0)
      removed.push_back(g);
    else if (!(g.objtype == mjOBJ_SITE && g.objid >= 0 && generated_site(s, g.objid)))
      scn->geoms[kept++] = g;
  }
  scn->ngeom = kept;
  for (const mjvGeom& g : removed) look[s.geom_rod[g.objid]][s.geom_index[g.objid]] = &g;

  // ring abscissae along each rod, and the colouring field there
  std::vector<std::vector<double>> X(s.rods.size()), value(s.rods.size());
  double vmax = o.color_max;
  for (size_t r = 0; r < s.rods.size(); ++r) {
    X[r] = rod_samples(s, sd, static_cast<int>(r), o);
    if (o.coloring == RodColoring::Model) continue;
    for (double x : X[r]) value[r].push_back(field(s, sd, static_cast<int>(r), x, o.coloring));
    if (o.color_max <= 0) vmax = std::max(vmax, *std::max_element(value[r].begin(), value[r].end()));
  }

  std::vector<Tube> tubes;
  for (size_t r = 0; r < s.rods.size(); ++r) {
    const Model& m = s.rods[r].model;
    const Rod& rod = m.rods[0];
    const auto& capsules = s.rods[r].decl.geoms;
    const double taper = (rod.radius_tip - rod.radius_base) / rod.length;  // dr/dX
    // the capsule shown at X (null: hidden)
    auto shown = [&](double x) -> const mjvGeom* {
      size_t c = 0;
      while (c + 1 < capsules.size() && x > capsules[c].X_end) ++c;
      return c < look[r].size() ? look[r][c] : nullptr;
    };
    auto ring_at = [&](size_t i, const mjvGeom& run_look) {
      const double x = X[r][i];
      const SE3 g = rod_pose(m, sd.rod[r], 0, x);
      const Vec3 p = rod_strain(m, sd.rod[r], 0, x).tail<3>();
      TubeRing ring;
      ring.centre = g.u;
      ring.t = p.norm() > 0 ? Vec3((g.R * p).normalized()) : Vec3(g.R.col(0));
      ring.u = g.R.col(1) - g.R.col(1).dot(ring.t) * ring.t;  // the cross-section's y axis, made normal to t
      if (ring.u.norm() < 1e-9) ring.u = ring.t.unitOrthogonal();
      ring.u.normalize();
      ring.v = ring.t.cross(ring.u);
      ring.radius = rod.radius(x);
      const double slope = -taper / std::max(p.norm(), 1e-12);  // -dr/ds
      ring.tilt = slope / std::sqrt(1 + slope * slope);
      const mjvGeom* like = shown(x);
      if (!like) like = &run_look;  // a run's end ring on a hidden capsule
      std::copy(like->rgba, like->rgba + 4, ring.rgba);
      if (!value[r].empty()) colormap(vmax > 0 ? value[r][i] / vmax : 0.0, ring.rgba);
      return ring;
    };
    // a round end: rings shrinking to a point behind (dir -1) or beyond (dir +1) `end`, in tube order
    auto round_end = [](const TubeRing& end, int dir) {
      std::vector<TubeRing> rings;
      for (int k = 1; k <= kEndRings; ++k) {
        const double a = 0.5 * M_PI * k / kEndRings;
        TubeRing ring = end;
        ring.centre = end.centre + dir * end.radius * std::sin(a) * end.t;
        ring.radius = end.radius * std::cos(a);
        ring.tilt = dir * std::sin(a);
        rings.push_back(ring);
      }
      if (dir < 0) std::reverse(rings.begin(), rings.end());
      return rings;
    };

    // runs of intervals whose capsule is shown
    const size_t n = X[r].size() - 1;
    for (size_t i = 0; i < n;) {
      const mjvGeom* like = shown(0.5 * (X[r][i] + X[r][i + 1]));
      if (!like) {
        ++i;
        continue;
      }
      Tube tube;
      tube.rod = static_cast<int>(r);
      tube.look = *like;
      size_t j = i;
      while (j < n && shown(0.5 * (X[r][j] + X[r][j + 1]))) ++j;
      std::vector<TubeRing> rings;
      for (size_t k = i; k <= j; ++k) rings.push_back(ring_at(k, *like));
      tube.ring_colors = !value[r].empty();
      for (const TubeRing& ring : rings) tube.ring_colors |= !std::equal(ring.rgba, ring.rgba + 4, like->rgba);
      tube.rings = round_end(rings.front(), -1);
      tube.rings.insert(tube.rings.end(), rings.begin(), rings.end());
      const auto tip = round_end(rings.back(), +1);
      tube.rings.insert(tube.rings.end(), tip.begin(), tip.end());
      tubes.push_back(std::move(tube));
      i = j;
    }
  }
  return tubes;
}

}  // namespace cosserat::render
