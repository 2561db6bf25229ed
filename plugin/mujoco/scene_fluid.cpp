// Fluid forces of a scene: see scene_fluid.hpp for the rules.
#include "scene_fluid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "scene.hpp"

namespace cosserat::mj {

namespace {

constexpr const char* kFluidText = "cosserat:fluid";
constexpr const char* kDragPrefix = "cosserat:drag:";

std::string name_of(const mjModel* m, int type, int id) {
  const char* n = mj_id2name(m, type, id);
  return n ? n : "";
}

// Body-frame columns of `chain`'s dofs: Ad^-1 of the body frame (in MuJoCo's com-based spatial
// coordinates) applied to cdof.
void body_columns(const mjModel* m, const mjData* d, int b, const std::vector<int>& chain, Mat6X& cols) {
  SE3 G;
  const mjtNum* c = d->subtree_com + 3 * m->body_rootid[b];
  for (int i = 0; i < 3; ++i) {
    G.u(i) = d->xpos[3 * b + i] - c[i];
    for (int j = 0; j < 3; ++j) G.R(i, j) = d->xmat[9 * b + 3 * i + j];
  }
  for (size_t t = 0; t < chain.size(); ++t) {
    Vec6 cd;
    for (int e = 0; e < 6; ++e) cd(e) = d->cdof[6 * chain[t] + e];
    cols.col(static_cast<int>(t)) = Ad_inv_apply(G, cd);
  }
}

// qD += cols^T C cols over a dof chain (nearest first): entry (chain[u], chain[t]), u >= t, is the
// (u - t)-th ancestor of chain[t] in MuJoCo's sparse layout.
template <class Cols>
void add_chain_block(const mjModel* m, mjtNum* qD, const std::vector<int>& chain, const Cols& cols, const Mat6& C) {
  const int n = static_cast<int>(chain.size());
  for (int t = 0; t < n; ++t) {
    const Vec6 Cc = C * cols.col(t);
    for (int u = t; u < n; ++u) qD[m->dof_Madr[chain[t]] + (u - t)] += cols.col(u).dot(Cc);
  }
}

// Capsules and cylinders: the geoms that drag coefficients per unit length apply to.
bool slender(const mjModel* m, int g) {
  return m->geom_type[g] == mjGEOM_CAPSULE || m->geom_type[g] == mjGEOM_CYLINDER;
}

// The resistance of one geom in its own frame, or false (with a warning) when it feels no fluid.
bool geom_resistance(const mjModel* m, int g, double mu, const std::vector<double>* drag, Mat6& C,
                     std::vector<std::string>& notes, std::vector<std::string>& warnings) {
  const mjtNum* size = m->geom_size + 3 * g;
  const std::string name = name_of(m, mjOBJ_GEOM, g);
  const std::string label = name.empty() ? "geom " + std::to_string(g) : "geom '" + name + "'";
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE: C = sphere_resistance(mu, size[0]); return true;
    case mjGEOM_ELLIPSOID: C = ellipsoid_resistance(mu, Vec3(size[0], size[1], size[2])); return true;
    case mjGEOM_BOX:
      C = ellipsoid_resistance(mu, Vec3(size[0], size[1], size[2]));
      notes.push_back(label + " (box): Stokes resistance of the ellipsoid with its half-sizes");
      return true;
    case mjGEOM_CAPSULE:
    case mjGEOM_CYLINDER: {
      const double a = size[0], h = size[1];
      if (drag) {  // a piece of a longer filament: RFT over its segment
        RftCoefficients c{(*drag)[0], (*drag)[1], drag->size() > 2 ? (*drag)[2] : 4.0 * M_PI * mu * a * a};
        C = segment_resistance(c, 2.0 * h, 2);
        return true;
      }
      const double L = 2.0 * h + (m->geom_type[g] == mjGEOM_CAPSULE ? 2.0 * a : 0.0);
      const RftCoefficients c = gray_hancock(mu, a, 0.5 * L);
      if (L >= 10.0 * a && valid(c)) {
        C = segment_resistance(c, L, 2);
      } else {
        C = ellipsoid_resistance(mu, Vec3(a, a, 0.5 * L));
        notes.push_back(label + ": not slender (length < 10 radii), Stokes resistance of the spheroid with its radius and half-length");
      }
      return true;
    }
    default:
      warnings.push_back(label + ": no fluid force on this geom type (only spheres, ellipsoids, boxes, capsules, cylinders)");
      return false;
  }
}

}  // namespace

void setup_fluid(Scene& s) {
  mjModel* m = s.m;
  SceneFluid& f = s.fluid;
  f = SceneFluid();
  f.viscosity = m->opt.viscosity;
  f.density = m->opt.density;
  f.rod_enabled.assign(s.rods.size(), false);

  // the global choice
  bool marked = false, mujoco = false;
  const int tid = mj_name2id(m, mjOBJ_TEXT, kFluidText);
  if (tid >= 0) {
    const std::string v = m->text_data + m->text_adr[tid];
    if (v == "gray-hancock") f.model = RftModel::GrayHancock;
    else if (v == "lighthill") f.model = RftModel::Lighthill;
    else if (v == "mujoco") mujoco = true;
    else throw LoadError(s.path, 0, std::string("<text name=\"") + kFluidText + "\">: data must be 'gray-hancock', 'lighthill' or 'mujoco', got '" + v + "'");
    marked = true;
  }
  // per geom/body overrides (the preprocessor refuses names of a rod's own bodies and geoms)
  std::vector<const std::vector<double>*> geom_drag(m->ngeom, nullptr), body_drag(m->nbody, nullptr);
  std::vector<std::string> drag_name(m->nbody);
  bool coefficients = false;  // some drag coefficients given (a numeric, or a rod's drag)
  for (const auto& rb : s.rods) coefficients = coefficients || rb.decl.drag.size() >= 2;
  std::vector<std::vector<double>> values;
  values.reserve(m->nnumeric);
  for (int k = 0; k < m->nnumeric; ++k) {
    const std::string name = name_of(m, mjOBJ_NUMERIC, k);
    if (name.rfind(kDragPrefix, 0) != 0) continue;
    marked = true;
    const std::string target = name.substr(std::strlen(kDragPrefix));
    values.emplace_back(m->numeric_data + m->numeric_adr[k], m->numeric_data + m->numeric_adr[k] + m->numeric_size[k]);
    const std::vector<double>& v = values.back();
    const bool off = v.size() == 1 && v[0] == 0.0;
    const bool coeffs = (v.size() == 2 || v.size() == 3) && std::all_of(v.begin(), v.end(), [](double x) { return x > 0; });
    if (!off && !coeffs)
      throw LoadError(s.path, 0, "<numeric name=\"" + name + "\">: data must be 'c_t c_n [c_rot]' (positive) or '0'");
    const int g = mj_name2id(m, mjOBJ_GEOM, target.c_str()), b = mj_name2id(m, mjOBJ_BODY, target.c_str());
    if (g >= 0) geom_drag[g] = &v;
    else if (b >= 0) body_drag[b] = &v, drag_name[b] = name;
    else throw LoadError(s.path, 0, "<numeric name=\"" + name + "\">: no geom or body named '" + target + "'");
    coefficients = coefficients || coeffs;
    // coefficients per unit length are for slender geoms: say so where they would be dropped
    if (coeffs && g >= 0 && !slender(m, g))
      f.warnings.push_back("<numeric name=\"" + name + "\">: drag coefficients per unit length apply to capsules and "
                           "cylinders; geom '" + target + "' keeps its Stokes resistance");
  }
  for (int b = 1; b < m->nbody; ++b) {
    if (!body_drag[b] || body_drag[b]->size() == 1) continue;
    bool any_slender = false;
    for (int g = m->body_geomadr[b]; g >= 0 && g < m->body_geomadr[b] + m->body_geomnum[b]; ++g)
      any_slender = any_slender || slender(m, g);
    if (!any_slender)
      f.warnings.push_back("<numeric name=\"" + drag_name[b] + "\">: drag coefficients per unit length apply to capsules "
                           "and cylinders, and body '" + name_of(m, mjOBJ_BODY, b) + "' has none: its geoms keep their "
                           "Stokes resistance");
  }
  f.active = f.viscosity > 0 && !mujoco && (marked || !s.rods.empty());
  // (outside probe AL: such a rod had fallen through MuJoCo's fluid without a word)
  if (mujoco && !s.rods.empty() && (f.viscosity > 0 || f.density > 0))
    f.warnings.push_back(std::string("<text name=\"") + kFluidText + "\" data=\"mujoco\">: MuJoCo's own fluid model acts " +
                         "on the rigid bodies only; the rods feel no fluid force (MuJoCo skips their massless proxies)");
  if (!f.active) {
    if (coefficients && f.viscosity <= 0)
      f.warnings.push_back("drag coefficients are given but <option viscosity> is 0: no fluid force at all");
    // (outside probe BG: 4.5 N of buoyancy on a rigid hub, and nothing on the rod, without a word)
    if (!mujoco && !s.rods.empty() && f.viscosity <= 0 && f.density > 0)
      // (outside probe BZ: an octopus arm in water at Reynolds number 4000 followed the advice to a
      // Stokes drag 600 times too small, and no buoyancy)
      f.warnings.push_back("<option density> without <option viscosity>: MuJoCo's own fluid model (buoyancy, quadratic "
                           "drag) acts on the rigid bodies only; the rods feel no fluid force, neither buoyancy nor "
                           "drag. <option viscosity> gives the plugin's fluid on rods and bodies, which is Stokes flow "
                           "(low Reynolds number: drag linear in the velocity, no buoyancy); for a rod in water at high "
                           "Reynolds number there is no fluid model here (its buoyancy: scale its density or gravity by "
                           "the net weight)");
    return;
  }
  m->opt.viscosity = 0.0;  // the plugin owns the fluid: MuJoCo's own model must not act as well
  m->opt.density = 0.0;
  if (f.density > 0)
    f.warnings.push_back("<option density> ignored: the plugin's fluid is Stokes flow (no fluid inertia, no buoyancy)");
  if (m->opt.wind[0] != 0 || m->opt.wind[1] != 0 || m->opt.wind[2] != 0)
    f.warnings.push_back("<option wind> ignored: the plugin's fluid is at rest");
  const double mu = f.viscosity;

  // rods
  f.rods.resize(s.rods.size());
  for (size_t r = 0; r < s.rods.size(); ++r) {
    RodBinding& rb = s.rods[r];
    RodFluid rf;
    rf.viscosity = mu;
    rf.model = f.model;
    rf.wavelength = rb.decl.wavelength;
    if (rb.decl.drag.size() == 1) rf.enabled = false;
    if (rb.decl.drag.size() >= 2)
      rf.drag = RftCoefficients{rb.decl.drag[0], rb.decl.drag[1], rb.decl.drag.size() > 2 ? rb.decl.drag[2] : 0.0};
    try {
      f.rods[r] = set_rod_drag(rb.model, 0, rf);
    } catch (const std::invalid_argument& e) {
      throw LoadError(rb.decl.file, rb.decl.line, std::string("<cosserat>: ") + e.what());
    }
    if (const RodFluidInfo& info = f.rods[r]; rf.enabled && !rf.drag && info.default_wavelength &&
                                              info.nearly_planar_section >= 0)
      f.warnings.push_back("rod '" + rb.decl.name + "': section " + std::to_string(info.nearly_planar_section) +
                           "'s rest shape is a helix whose pitch is under a tenth of a turn's arc length (nearly "
                           "planar, or tightly coiled): the default drag does not take that pitch as its wavelength" +
                           (info.helical ? " but the next helical section's" : " but the planar rule's, L/2") +
                           "; give the rod a wavelength (or drag) to set it");
    f.rod_enabled[r] = rf.enabled;
  }

  // rigid bodies: every geom of a body that can move, except the rods' own
  std::vector<bool> rod_body(m->nbody, false);
  for (const auto& rb : s.rods)
    for (int b = rb.base_body; b <= rb.proxy_body.back(); ++b) rod_body[b] = true;
  for (int b = 1; b < m->nbody; ++b) {
    if (rod_body[b]) continue;
    FluidBody fb;
    fb.body = b;
    for (int b2 = b; b2 > 0 && fb.chain.empty(); b2 = m->body_parentid[b2])
      if (m->body_dofnum[b2] > 0)
        for (int j = m->body_dofadr[b2] + m->body_dofnum[b2] - 1; j >= 0; j = m->dof_parentid[j]) fb.chain.push_back(j);
    if (fb.chain.empty()) continue;  // welded to the world
    bool any = false;
    for (int g = m->body_geomadr[b]; g < m->body_geomadr[b] + m->body_geomnum[b]; ++g) {
      if (g < 0 || s.geom_rod[g] >= 0) continue;
      const std::vector<double>* drag = geom_drag[g] ? geom_drag[g] : body_drag[b];
      if (drag && drag->size() == 1) continue;  // "0": no fluid force
      Mat6 Cg;
      if (!geom_resistance(m, g, mu, slender(m, g) ? drag : nullptr, Cg, f.notes, f.warnings)) continue;
      // geom frame in the body frame: eta_geom = Ad^-1_{g_bg} eta_body
      SE3 gbg;
      gbg.u = Vec3(m->geom_pos[3 * g], m->geom_pos[3 * g + 1], m->geom_pos[3 * g + 2]);
      mjtNum mat[9];
      mju_quat2Mat(mat, m->geom_quat + 4 * g);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) gbg.R(i, j) = mat[3 * i + j];
      const Mat6 X = Ad_inv(gbg);
      fb.C.noalias() += X.transpose() * Cg * X;
      any = true;
    }
    if (!any) continue;
    f.max_chain = std::max(f.max_chain, static_cast<int>(fb.chain.size()));
    f.bodies.push_back(std::move(fb));
  }
}

void fluid_damping(const Scene& s, SceneData& sd) {
  const SceneFluid& f = s.fluid;
  if (!f.active) return;
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  mjtNum* qD = sd.fluid_qD.data();
  std::fill(sd.fluid_qD.begin(), sd.fluid_qD.end(), 0.0);
  // rods: rod block, cross terms with the ancestors and the ancestor block, as patch_qM does with
  // the inertia (sd.scratch[r].C: the ancestors' base-frame columns, from patch_qM)
  for (size_t r = 0; r < s.rods.size(); ++r) {
    if (!f.rod_enabled[r]) continue;
    const RodBinding& rb = s.rods[r];
    cosserat::Data& rd = sd.rod[r];
    cosserat::fluid_damping(rb.model, rd);
    const SceneData::RodScratch& sc = sd.scratch[r];
    const int n = rb.model.nv, na = static_cast<int>(sc.anc.size());
    for (int i = 0; i < n; ++i) {
      const int adr = m->dof_Madr[rb.dof0 + i];
      for (int j = 0; j <= i; ++j) qD[adr + (i - j)] += rd.D_fluid(i, j);
      for (int t = 0; t < na; ++t) qD[adr + i + 1 + t] += rd.DF_base.col(i).dot(sc.C.col(t));
    }
    add_chain_block(m, qD, sc.anc, sc.C, rd.Dc_base);
  }
  // rigid bodies
  for (const FluidBody& fb : f.bodies) {
    body_columns(m, d, fb.body, fb.chain, sd.fluid_cols);  // first chain.size() columns
    add_chain_block(m, qD, fb.chain, sd.fluid_cols, fb.C);
  }
}

void fluid_forces(const Scene& s, SceneData& sd) {
  if (!s.fluid.active) return;
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const mjtNum* qD = sd.fluid_qD.data();
  // sparse symmetric product (MuJoCo's mj_mulM on qD): f = D qvel
  std::vector<mjtNum>& out = sd.fluid_f;
  for (int i = 0; i < m->nv; ++i) {
    const int adr = m->dof_Madr[i];
    double acc = qD[adr] * d->qvel[i];
    int k = 1;
    for (int j = m->dof_parentid[i]; j >= 0; j = m->dof_parentid[j], ++k) acc += qD[adr + k] * d->qvel[j];
    out[i] = acc;
  }
  for (int i = 0; i < m->nv; ++i) {
    const int adr = m->dof_Madr[i];
    int k = 1;
    for (int j = m->dof_parentid[i]; j >= 0; j = m->dof_parentid[j], ++k) out[j] += qD[adr + k] * d->qvel[i];
  }
  for (int i = 0; i < m->nv; ++i) d->qfrc_passive[i] -= out[i];
}

void add_fluid_damping(const Scene& s, const SceneData& sd, double h, double* A) {
  if (!s.fluid.active) return;
  for (int k = 0; k < s.m->nM; ++k) A[k] += h * sd.fluid_qD[k];
}

}  // namespace cosserat::mj
