// Rods inside MuJoCo 2.2.2: loading and the staged, strongly coupled step (DESIGN.md section 6).
//
// The step is MuJoCo's own pipeline, stage by stage, with the rod patches in between:
//   position: kinematics | patch poses (capsules' margins: their chords' sag) | comPos |
//             patch cdof | camlight (| com tracking) | tendon | patch ten_J | crb | patch qM |
//             fluid damping | collision | patch contact distances (the centre line's) |
//             makeConstraint | patch contact rows | transmission (| site transmissions) |
//             factorM | projectConstraint; then sensorPos (| sensors)
//   velocity: ten/actuator velocity | comVel | patch cdof_dot | passive | referenceConstraint |
//             rne | patch bias (+ rod elastic and damping forces) | patch the contact, equality
//             and tendon rows' reference accelerations (velocity products) | fluid forces; sensorVel
//   then actuation, acceleration, constraint, sensorAcc (| sensors), and an integrator of ours
//   (the fluid's damping implicit in euler and implicit: scene_fluid.hpp). The stages in
//   parentheses are MuJoCo's features that read rod sites or mass, made to read the rod's material
//   (scene_sites.hpp). The implicit steps need only the forces:
//   without constraint rows and acceleration sensors they skip factorM, the acceleration and the
//   constraint stages (Need::Forces), one factorisation of M per evaluation less.
// Rod inertia enters as an articulated subtree on the rod's parent body: the core provides the
// rod block of M, the base-frame force subspace F_base and the composite inertia Ic_base, which
// are projected on the parent's dofs through the parent's Jacobian (from MuJoCo's cdof).
#include "scene.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <tuple>
#include <unordered_set>
#include <vector>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "mujoco_ports.hpp"
#include "scene_sites.hpp"
#include "tree_ldl.hpp"

// MuJoCo 2.2.2's implicit-in-velocity integrator (mj_step's for <option integrator="implicit">),
// exported by libmujoco but not declared in its public header.
extern "C" void mj_implicit(const mjModel* m, mjData* d);

namespace cosserat::mj {

namespace {
constexpr int kMaxNewtonMemory = 4;  // Scene::newton_memory is clamped to this
// The Newton schemes' Woodbury rows for contact rows that tie two branches of the tree (a rod
// pressing a free object): room for this many at first (12 pyramidal contacts of condim 3), grown
// on demand up to nv more rows than the tendons', actuators' and equalities' (beyond that the
// correction would cost more than a dense factorisation: the iteration matrix takes none of the
// constraint rows, add_constraint_terms).
constexpr int kLoopContactRows = 48;
// The Woodbury rows a scene's elements can need: one per tendon and actuator (its damping and
// spring together: add_row_terms), six per equality constraint (add_constraint_terms).
size_t woodbury_rows_of_elements(const mjModel* m) { return static_cast<size_t>(m->ntendon + m->nu + 6 * m->neq); }

using Vec3m = Eigen::Map<Vec3>;
using Mat3r = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;  // MuJoCo's xmat layout

// ---------------------------------------------------------------------------------- loading --

// MuJoCo's compiler or XML reader error, located in the user's file: its line ("line = N", or
// "Element 'NAME', line N") refers to the generated MJCF; Preprocessed maps that back to the
// element's origin.
LoadError mujoco_error(const Preprocessed& pre, const std::string& error) {
  std::string msg = error;
  const size_t nl = msg.find('\n');
  std::string first = msg.substr(0, nl);
  if (first.rfind("Error: ", 0) == 0) first = first.substr(7);
  if (!first.empty() && first.back() == ':') first.pop_back();  // its details follow on other lines
  int line = 0;  // the compiler's "line = N", or the XML reader's "Element 'geom', line N"
  if (const size_t at = msg.find("line = "); at != std::string::npos)
    line = std::atoi(msg.c_str() + at + 7);
  else if (const size_t el = msg.find("Element '"); el != std::string::npos)
    if (const size_t at = msg.find(", line ", el); at != std::string::npos) line = std::atoi(msg.c_str() + at + 7);
  std::string object;
  if (const size_t at = msg.find("Object name = "); at != std::string::npos) {
    object = msg.substr(at + 14);
    object = object.substr(0, object.find(','));
  }
  SourceLine where = pre.origin_of_line(line);
  // errors that carry an element's index instead of a line
  auto nth = [&](const std::vector<SourceLine>& origins, size_t at) {
    const int k = std::atoi(msg.c_str() + at);
    if (k >= 0 && k < static_cast<int>(origins.size())) where = origins[k];
  };
  auto after = [&](const char* text) {
    const size_t at = msg.find(text);
    return at == std::string::npos ? at : at + std::strlen(text);
  };
  std::string hint;
  if (line == 0) {
    if (first.rfind("key ", 0) == 0) {  // "key N: ...": the N-th <key>
      nth(pre.key_origin, msg.find("key ") + 4);
      // the rods' share of the length (outside probe AD: the user had to count strain coordinates)
      if (first.find("invalid qpos size") != std::string::npos && !pre.rods.empty()) {
        hint = " (the rods' strain coordinates, in the model's joint order:";
        for (const RodDecl& r : pre.rods)
          hint += " rod '" + r.name + "' " + std::to_string(r.joints.size()) + ",";
        hint.back() = ';';
        hint += " the other joints are yours: free 7, ball 4, hinge and slide 1)";
      }
    } else if (const size_t at = after("sensor array, position "); at != std::string::npos) {  // repeated name
      nth(pre.sensor_origin, at);
    } else if (const size_t at2 = after("actuator array, position "); at2 != std::string::npos) {
      nth(pre.actuator_origin, at2);
    } else if (first.find("in sensor") != std::string::npos && after("(id = ") != std::string::npos) {
      nth(pre.sensor_origin, after("(id = "));
      // the object it could not find (outside probe BL: a rod's name as a framepos's objname)
      const int k = std::atoi(msg.c_str() + after("(id = "));
      if (first.find("sensorized object") != std::string::npos && k >= 0 &&
          k < static_cast<int>(pre.sensor_objname.size()) && !pre.sensor_objname[k].empty())
        first += " (objname '" + pre.sensor_objname[k] + "')";
    } else if (const size_t at3 = after("in actuator "); at3 != std::string::npos) {  // lengthrange
      nth(pre.actuator_origin, at3);
      if (!pre.rods.empty())
        hint = " (an actuator acting on a rod needs an explicit lengthrange: MuJoCo computes it by simulating the "
               "compiled model, in which the rods are massless placeholders)";
    } else if (first.find("stateless actuators must come before stateful") != std::string::npos) {
      for (size_t k = 1; k < pre.actuator_origin.size(); ++k)  // the first stateless one after a stateful one
        if (!pre.actuator_stateful[k] &&
            std::any_of(pre.actuator_stateful.begin(), pre.actuator_stateful.begin() + k, [](char c) { return c; })) {
          where = pre.actuator_origin[k];
          break;
        }
    }
  }
  if (first.find("mass and inertia of moving bodies must be larger than mjMINVAL") != std::string::npos &&
      !pre.rods.empty()) {
    // (outside probe P: under inertiafromgeom="false" a geom does not help, and the rod is not the cause)
    if (pre.xml.find("inertiafromgeom=\"false\"") != std::string::npos)
      hint = ": under <compiler inertiafromgeom=\"false\"> a body's geoms add no mass, and a rod's mass is the "
             "rod's own, not its parent body's; give the body an <inertial>";
    else
      // (outside probe BZ: a bacterium's 0.5 um head has a geom and weighs 5.8e-16 kg, below the
      // floor; the mass the hint had offered, 1.7e9 times the head's, slowed its swimming 2600-fold)
      hint = ": a rod's mass is the rod's own, not its parent body's; a massless body holding a rod needs an "
             "<inertial> or a geom, light against what it carries (e.g. mass=\"1e-6\" diaginertia=\"1e-12 1e-12 "
             "1e-12\" under a rod of grams). If the body has a mass of its own below MuJoCo's floor of 1e-15 (a "
             "micrometre-sized body in SI units), do not add mass, which changes its motion: write the model in "
             "scaled units (README, Swimming flagellates: micrometres, milliseconds, picograms)";
  }
  // a <default> geom pos reaching the capsules, which are placed with fromto (outside probe P: the
  // user wrote neither)
  auto names_a_capsule = [&](const RodDecl& r) { return first.find("'" + r.name + "/s") != std::string::npos; };
  if (first.find("both pos and fromto defined") != std::string::npos &&
      std::any_of(pre.rods.begin(), pre.rods.end(), names_a_capsule))
    hint = ": a <default> geom pos reaches the rod's capsules, which are placed with fromto; give the rod a class "
           "without a geom pos";
  // what a rod becomes, by the names MuJoCo knows (outside probe BL: a rod's name, or its section's
  // body, given as a sensor's object, an actuator's joint or site or an exclude's body read as
  // MuJoCo's bare "not found")
  auto what_rod_makes = [](const RodDecl& r) {
    std::string sites;
    for (size_t k = 0; k < r.sites.size() && k < 6; ++k) sites += (k ? ", " : "") + r.sites[k].name;
    if (r.sites.size() > 6) sites += " and " + std::to_string(r.sites.size() - 6) + " more";
    return "rod '" + r.name + "' becomes the bodies " + r.name + "/base and " + r.name + "/s0 to " + r.name + "/s" +
           std::to_string(r.proxies.size() - 1) + " (each section's end), the sites " + sites + ", the strain joints " +
           r.name + "/s<i>/<coordinate> (slides) and the capsules " + r.name + "/s<i>/g<k>";
  };
  for (const RodDecl& r : pre.rods)
    if (hint.empty() && first.find("'" + r.name + "'") != std::string::npos)
      hint = ": '" + r.name + "' is a rod, which MuJoCo knows by what it becomes: " + what_rod_makes(r);
  // a name under a rod's prefix that the rod does not generate (outside probe AD: a strain joint
  // the rod's strain has not, or a section beyond its last, read "unknown transmission target")
  for (const RodDecl& r : pre.rods) {
    const size_t at = first.find("'" + r.name + "/");
    if (at == std::string::npos || !hint.empty()) continue;
    const size_t end = first.find('\'', at + 1);
    const std::string name = first.substr(at + 1, end == std::string::npos ? std::string::npos : end - at - 1);
    // (outside probe BB: a bad condim on a rod, MuJoCo's message naming a capsule, read "has no")
    const bool capsule = std::any_of(r.geoms.begin(), r.geoms.end(), [&](const RodGeomDecl& g) { return g.name == name; });
    if (capsule || std::find(r.joints.begin(), r.joints.end(), name) != r.joints.end() ||
        std::find(r.proxies.begin(), r.proxies.end(), name) != r.proxies.end() || name == r.name + "/base" ||
        std::any_of(r.sites.begin(), r.sites.end(), [&](const RodSiteDecl& x) { return x.name == name; }) ||
        (name.rfind(r.name + "/s", 0) == 0 && name.find("/h") != std::string::npos)) {
      if (capsule)
        hint = ": '" + name + "' is a capsule of rod '" + r.name +
               "', which takes the rod's geom attributes (contype, conaffinity, condim, friction, solref, solimp, "
               "margin, gap, rgba, group, material)";
      else  // a name of another kind than the element wants
        hint = ": '" + name + "' is " +
               (std::find(r.joints.begin(), r.joints.end(), name) != r.joints.end() ? "a strain joint"
                : std::any_of(r.sites.begin(), r.sites.end(), [&](const RodSiteDecl& x) { return x.name == name; })
                    ? (name == r.name + "/base" ? "a body and a site" : "a site")
                    : "a body") +
               " of rod '" + r.name + "', which MuJoCo knows by what the rod becomes: " + what_rod_makes(r);
      continue;
    }
    // the coordinates of the section the name points at, if it has one, else of the first (outside
    // probe AE: with sections of different strains the first section's misled)
    std::string section = r.name + "/s0";
    if (const size_t slash = name.find('/', r.name.size() + 1); slash != std::string::npos)
      if (std::find(r.proxies.begin(), r.proxies.end(), name.substr(0, slash)) != r.proxies.end())
        section = name.substr(0, slash);
    std::string coordinates;
    for (const std::string& j : r.joints)
      if (j.rfind(section + "/", 0) == 0) coordinates += " " + j.substr(section.size() + 1);
    hint = ": rod '" + r.name + "' has no '" + name + "'. Its sections are " + r.name + "/s0 to " + r.name + "/s" +
           std::to_string(r.proxies.size() - 1) + " (bodies), its strain joints " + r.name +
           "/s<i>/<coordinate>, section " + section + "'s coordinates:" + coordinates +
           " (the strain or dofs attribute sets them; GVS adds the polynomial degree)";
  }
  return LoadError(where.file, where.line,
                   "MuJoCo: " + first + (object.empty() ? "" : " (object '" + object + "')") + hint);
}

mjModel* compile_xml(const Preprocessed& pre) {
  // MuJoCo 2.2 reads files; a VFS entry named after the original file keeps its directory as the
  // model directory for relative asset paths.
  const std::string& xml = pre.xml;
  const std::string& path = pre.path;
  auto vfs = std::make_unique<mjVFS>();  // about 2 MB: not on the stack
  mj_defaultVFS(vfs.get());
  const int err = mj_makeEmptyFileVFS(vfs.get(), path.c_str(), static_cast<int>(xml.size()));
  if (err) throw LoadError(path, 0, "cannot create the virtual file for MuJoCo (code " + std::to_string(err) + ")");
  std::memcpy(vfs->filedata[vfs->nfile - 1], xml.data(), xml.size());
  char error[1024] = "";
  mjModel* m = mj_loadXML(path.c_str(), vfs.get(), error, sizeof(error));
  mj_deleteVFS(vfs.get());
  if (!m) throw mujoco_error(pre, error);
  return m;
}

int require_id(const mjModel* m, int type, const std::string& name, const RodDecl& r) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0) throw LoadError(r.file, r.line, "internal: generated element '" + name + "' missing in the compiled model");
  return id;
}

}  // namespace

bool is_descendant(const mjModel* m, int b, int ancestor) {
  for (; b > 0; b = m->body_parentid[b])
    if (b == ancestor) return true;
  return ancestor == 0;
}

namespace {

// Pose of a capsule along the chord a-b of its stretch of centreline, its local x from the
// cross-section frame Rm at its end (MuJoCo capsules lie along local z; the roll about the axis
// only shows in rendering); `half` gets the chord's half-length.
SE3 capsule_frame(const Vec3& a, const Vec3& b, const Mat3& Rm, double& half) {
  // (each norm taken once: the same arithmetic as normalized())
  const Vec3 ab = b - a;
  const double len = ab.norm();
  const Vec3 z = len > 1e-300 ? Vec3(ab / len) : Vec3(Rm.col(0));
  Vec3 x = Rm.col(1) - Rm.col(1).dot(z) * z;
  const double xn = x.norm();
  x = xn > 1e-9 ? Vec3(x / xn) : Vec3(z.unitOrthogonal());
  SE3 g;
  g.R << x, z.cross(x), z;
  g.u = 0.5 * (a + b);
  half = 0.5 * len;
  return g;
}

SE3 capsule_pose(const cosserat::Model& m, const cosserat::Data& d, const RodGeomDecl& gd, double& half) {
  const SE3 b = rod_pose(m, d, 0, gd.X_end);
  return capsule_frame(rod_pose(m, d, 0, gd.X_begin).u, b.u, b.R, half);
}

SE3 site_pose(const cosserat::Model& m, const cosserat::Data& d, const RodSiteDecl& sd) {
  SE3 g = rod_pose(m, d, 0, sd.X);
  g.u += g.R * sd.pos;
  return g;
}

}  // namespace

const SE3& anchor_pose(const cosserat::Data& d, int anchor) { return anchor < 0 ? d.base_pose : d.g[anchor]; }

namespace {

// RodBinding::geom_fixed and site_fixed: placements on rigid sections, from the rest state (they
// do not depend on the state), and sites on the rod's base body (the generated "<rod>/base" site),
// which ride rigidly with that body (MuJoCo's own Jacobians are exact there).
void fix_rigid_placements(const mjModel* mm, RodBinding& rb) {
  const cosserat::Model& m = rb.model;
  cosserat::Data d(m);
  cosserat::fwd_position(m, d);
  rb.geom_fixed.assign(rb.decl.geoms.size(), {});
  for (size_t k = 0; k < rb.decl.geoms.size(); ++k) {
    const RodGeomDecl& gd = rb.decl.geoms[k];
    const Section& sec = m.sections[gd.section];
    if (sec.ndof != 0 || gd.X_begin < sec.X0 || gd.X_end > sec.X0 + sec.length) continue;
    RodBinding::Fixed& f = rb.geom_fixed[k];
    f.fixed = true;
    f.anchor = sec.start_node;
    f.rel = anchor_pose(d, f.anchor).inverse() * capsule_pose(m, d, gd, f.half);
  }
  rb.site_fixed.assign(rb.decl.sites.size(), {});
  for (size_t k = 0; k < rb.decl.sites.size(); ++k) {
    const RodSiteDecl& sdl = rb.decl.sites[k];
    const Section& sec = m.sections[m.nodes[m.rod_node_at(0, sdl.X)].section];
    const bool on_base = mm->site_bodyid[rb.site_id[k]] == rb.base_body;
    if (sec.ndof != 0 && !on_base) continue;
    RodBinding::Fixed& f = rb.site_fixed[k];
    f.fixed = true;
    f.anchor = on_base ? -1 : sec.start_node;
    f.rel = anchor_pose(d, f.anchor).inverse() * site_pose(m, d, sdl);
  }
}

RodBinding bind_rod(const mjModel* m, const RodDecl& decl) {
  RodBinding rb;
  rb.decl = decl;
  rb.model.gravity = Vec3(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]);
  rb.model.add_rod(-1, SE3::Identity(), decl.spec);
  rb.model.finalize();
  // capsule ends in the middle of a PCS step (the default two capsules per Gauss-rule section
  // meet there): their poses come with the kinematics instead of a partial step each
  for (const RodGeomDecl& gd : decl.geoms)
    for (double X : {gd.X_begin, gd.X_end}) rb.model.keep_midpoint_pose(0, X);
  for (const RodGeomDecl& gd : decl.geoms) {
    RodBinding::PoseSource src;
    src.node = cosserat::kept_pose_node(rb.model, 0, gd.X_end, src.mid);
    rb.geom_end.push_back(src);
  }
  rb.base_body = require_id(m, mjOBJ_BODY, decl.name + "/base", decl);
  for (const auto& p : decl.proxies) rb.proxy_body.push_back(require_id(m, mjOBJ_BODY, p, decl));
  // helper bodies: the bodies between a proxy and the previous proxy (or the base)
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    const int stop = i == 0 ? rb.base_body : rb.proxy_body[i - 1];
    std::vector<int> h;
    for (int b = m->body_parentid[rb.proxy_body[i]]; b != stop; b = m->body_parentid[b]) {
      if (b <= 0) throw LoadError(decl.file, decl.line, "internal: proxy chain is broken");
      h.push_back(b);
    }
    rb.helper_body.push_back(h);
  }
  if (static_cast<int>(decl.joints.size()) != rb.model.nv)
    throw LoadError(decl.file, decl.line, "internal: joint count differs from the rod's dof count");
  // the rod's dofs must be one contiguous block in core order
  for (size_t k = 0; k < decl.joints.size(); ++k) {
    const int j = require_id(m, mjOBJ_JOINT, decl.joints[k], decl);
    if (k == 0) {
      rb.dof0 = m->jnt_dofadr[j];
      rb.qpos0 = m->jnt_qposadr[j];
    } else if (m->jnt_dofadr[j] != rb.dof0 + static_cast<int>(k) || m->jnt_qposadr[j] != rb.qpos0 + static_cast<int>(k)) {
      throw LoadError(decl.file, decl.line, "internal: rod dofs are not contiguous");
    }
  }
  for (const auto& g : decl.geoms) {
    // MuJoCo's <compiler discardvisual="true"> drops geoms that cannot collide (outside probe P: an
    // "internal" error for a rod with contype = conaffinity = 0)
    const int id = mj_name2id(m, mjOBJ_GEOM, g.name.c_str());
    if (id < 0)
      throw LoadError(decl.file, decl.line,
                      "<cosserat>: the rod's capsule '" + g.name + "' is missing in the compiled model: <compiler "
                      "discardvisual=\"true\"> discards the capsules of a rod that cannot collide (contype = "
                      "conaffinity = 0), and a rod needs them (they draw it and carry its contacts): remove "
                      "discardvisual, or let the rod collide");
    rb.geom_id.push_back(id);
  }
  for (const auto& s : decl.sites) rb.site_id.push_back(require_id(m, mjOBJ_SITE, s.name, decl));
  const int last_proxy = rb.proxy_body.back();
  auto on_rod = [&](int body) { return body > rb.base_body && body <= last_proxy; };
  for (int g = 0; g < m->ngeom; ++g)
    if (on_rod(m->geom_bodyid[g]) && std::find(rb.geom_id.begin(), rb.geom_id.end(), g) == rb.geom_id.end())
      rb.other_geom_id.push_back(g);
  for (int i = 0; i < m->nsite; ++i)
    if (on_rod(m->site_bodyid[i]) && std::find(rb.site_id.begin(), rb.site_id.end(), i) == rb.site_id.end())
      rb.other_site_id.push_back(i);
  fix_rigid_placements(m, rb);
  rb.extensible = std::any_of(rb.model.sections.begin(), rb.model.sections.end(),
                              [](const Section& sec) { return sec.axial_free(); });
  // the node the payload hangs on (RodBinding::payload): the last proxy's frame, or the root of the
  // fixed subtree holding it (cosserat::crba and rnea lump a fixed subtree at its root)
  rb.payload_node = rb.model.sections.back().end_node;
  while (cosserat::inside_fixed_subtree(rb.model, rb.model.nodes[rb.payload_node]))
    rb.payload_node = rb.model.nodes[rb.payload_node].parent;
  const int last = rb.proxy_body.back();
  rb.below_begin = last + 1;
  rb.below_end = rb.below_begin;
  while (rb.below_end < m->nbody && is_descendant(m, rb.below_end, last)) ++rb.below_end;
  return rb;
}

// Proxies carry no inertia of their own (the core owns the rod's inertia): zero their masses, fix
// the subtree masses MuJoCo divides by, and disable the "simple body" shortcuts that ignore cdof.
void strip_proxies(mjModel* m, const std::vector<RodBinding>& rods) {
  for (const auto& r : rods) {
    for (int b = r.base_body + 1; b <= r.proxy_body.back(); ++b) {  // proxies and helpers
      m->body_mass[b] = 0.0;
      for (int k = 0; k < 3; ++k) m->body_inertia[3 * b + k] = 0.0;
    }
    for (int b = r.base_body + 1; b < r.below_end; ++b) m->body_simple[b] = 0;
    for (int k = 0; k < r.model.nv; ++k) m->dof_armature[r.dof0 + k] = 0.0;
  }
  for (int i = 0; i < m->nv; ++i) {
    const int b = m->dof_bodyid[i];
    for (const auto& r : rods)
      if (b > r.base_body && b < r.below_end) m->dof_simplenum[i] = 0;
  }
  for (int b = 0; b < m->nbody; ++b) m->body_subtreemass[b] = m->body_mass[b];
  for (int b = m->nbody - 1; b > 0; --b) m->body_subtreemass[m->body_parentid[b]] += m->body_subtreemass[b];
}

// ------------------------------------------------------------------------------- kinematics --

void set_pose(mjtNum* xpos, mjtNum* xmat, const SE3& g) {
  for (int i = 0; i < 3; ++i) {
    xpos[i] = g.u(i);
    for (int j = 0; j < 3; ++j) xmat[3 * i + j] = g.R(i, j);
  }
}

SE3 get_pose(const mjtNum* xpos, const mjtNum* xmat) {
  SE3 g;
  for (int i = 0; i < 3; ++i) {
    g.u(i) = xpos[i];
    for (int j = 0; j < 3; ++j) g.R(i, j) = xmat[3 * i + j];
  }
  return g;
}

// Pose of a proxy (or helper) body: frame, inertial frame (inertia is zero) and joint axes. Its
// quaternion is the one of the two nearer its parent's (set first): continuous in time as MuJoCo's
// own parent * local composition is, where mju_mat2Quat's choice of sign jumps.
void set_body_pose(const mjModel* m, mjData* d, int b, const SE3& g) {
  set_pose(d->xpos + 3 * b, d->xmat + 9 * b, g);
  mjtNum* q = d->xquat + 4 * b;
  mju_mat2Quat(q, d->xmat + 9 * b);
  if (mju_dot(q, d->xquat + 4 * m->body_parentid[b], 4) < 0) mju_scl(q, q, -1, 4);
  mju_copy3(d->xipos + 3 * b, d->xpos + 3 * b);
  mju_copy(d->ximat + 9 * b, d->xmat + 9 * b, 9);
  for (int j = m->body_jntadr[b]; j < m->body_jntadr[b] + m->body_jntnum[b]; ++j) {
    mju_copy3(d->xanchor + 3 * j, d->xpos + 3 * b);
    mju_rotVecMat(d->xaxis + 3 * j, m->jnt_axis + 3 * j, d->xmat + 9 * b);
  }
}

// Geoms and sites of bodies [b0, b1) from their (final) body poses.
void attached_kinematics(const mjModel* m, mjData* d, int b0, int b1) {
  for (int g = 0; g < m->ngeom; ++g)
    if (m->geom_bodyid[g] >= b0 && m->geom_bodyid[g] < b1) geom_kinematics(m, d, g);
  for (int s = 0; s < m->nsite; ++s)
    if (m->site_bodyid[s] >= b0 && m->site_bodyid[s] < b1) site_kinematics(m, d, s);
}

// An upper bound on how far the centre line between a capsule's ends strays from its chord: an arc
// of length l and curvature kappa rises kappa l^2 / 8 above its chord (less for large angles), with
// kappa at most the strain's angular magnitude |xi_ang| (twist included) and l the stretched length,
// both taken at the ends and the middle (PCS: constant; GVS: a margin of 25% for what lies between).
// From the strains alone (no pose evaluation): the per-step cost of RodBinding::geom_sagging.
double chord_sag_bound(const cosserat::Model& m, const cosserat::Data& d, const RodGeomDecl& gd) {
  double kappa = 0.0, stretch = 0.0;
  const bool pcs = m.sections[gd.section].order == 0;
  for (const double f : {0.5, 0.0, 1.0}) {
    const Vec6 xi = cosserat::rod_strain(m, d, 0, gd.X_begin + f * (gd.X_end - gd.X_begin));
    kappa = std::max(kappa, xi.head<3>().norm());
    stretch = std::max(stretch, xi.tail<3>().norm());
    if (pcs) break;
  }
  const double l = (gd.X_end - gd.X_begin) * stretch;
  return (pcs ? 1.0 : 1.25) * kappa * l * l / 8.0;
}

// The composite spatial inertia of MuJoCo bodies [b0, b1) about the origin of frame g, in g's axes
// (cosserat's layout [[I_o, h~], [-h~, m 1]], h = m c), from their masses, principal inertias and
// inertial frames as the kinematics placed them: a rod's payload (RodBinding::payload).
Mat6 payload_inertia(const mjModel* m, const mjData* d, int b0, int b1, const SE3& g) {
  Mat6 A = Mat6::Zero();
  const Mat3 Rt = g.R.transpose();
  for (int b = b0; b < b1; ++b) {
    const double mass = m->body_mass[b];
    const Vec3 I(m->body_inertia[3 * b], m->body_inertia[3 * b + 1], m->body_inertia[3 * b + 2]);
    if (mass == 0.0 && I.isZero(0.0)) continue;
    const Mat3 Ri = Rt * Eigen::Map<const Mat3r>(d->ximat + 9 * b);
    const Vec3 c = Rt * (Vec3(d->xipos[3 * b], d->xipos[3 * b + 1], d->xipos[3 * b + 2]) - g.u);
    A += cosserat::spatial_inertia(mass, c, Ri * I.asDiagonal() * Ri.transpose());
  }
  return A;
}

// The rod's payload, if it carries one, hung on its node for cosserat::crba and rnea (after the
// kinematics of the bodies below the rod).
void hang_payload(const mjModel* m, const mjData* d, const RodBinding& rb, cosserat::Data& rd) {
  rd.attached_node = rb.payload ? rb.payload_node : -1;
  if (rb.payload) rd.attached_inertia = payload_inertia(m, d, rb.below_begin, rb.below_end, rd.g[rb.payload_node]);
}

// Patch point 1: proxy poses, rod capsules and sites from the rod solution; then everything below.
void patch_rod_kinematics(const Scene& s, SceneData& sd, int r) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  cosserat::Data& rd = sd.rod[r];
  for (int k = 0; k < rb.model.nv; ++k) rd.q(k) = d->qpos[rb.qpos0 + k];
  rd.base_pose = get_pose(d->xpos + 3 * rb.base_body, d->xmat + 9 * rb.base_body);
  cosserat::fwd_position(rb.model, rd);
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    const int p = rb.proxy_body[i];
    const SE3& g = rd.g[rb.model.sections[i].end_node];
    // helpers sit at the proxy's frame (they only hold dofs)
    for (int b : rb.helper_body[i]) set_body_pose(m, d, b, g);
    set_body_pose(m, d, p, g);
  }
  // capsules along the chord of their stretch of centreline
  double X_prev = -1.0;  // consecutive capsules share their end points
  Vec3 p_prev = Vec3::Zero();
  for (size_t k = 0; k < rb.geom_id.size(); ++k) {
    const RodGeomDecl& gd = rb.decl.geoms[k];
    const RodBinding::Fixed& f = rb.geom_fixed[k];
    SE3 g;
    double half;
    if (f.fixed) {
      g = anchor_pose(rd, f.anchor) * f.rel;
      half = f.half;
      X_prev = -1.0;
    } else {
      const Vec3 a = gd.X_begin == X_prev ? p_prev : rod_pose(rb.model, rd, 0, gd.X_begin).u;
      const RodBinding::PoseSource& e = rb.geom_end[k];
      const SE3 b = e.node < 0 ? rod_pose(rb.model, rd, 0, gd.X_end) : e.mid ? rd.g_mid[e.node] : rd.g[e.node];
      X_prev = gd.X_end;
      p_prev = b.u;
      g = capsule_frame(a, b.u, b.R, half);
    }
    const int id = rb.geom_id[k];
    set_pose(d->geom_xpos + 3 * id, d->geom_xmat + 9 * id, g);
    // the capsule spans its chord: its length follows bending and stretch (DESIGN.md section 6:
    // geom_size and geom_rbound are state-dependent for rod capsules)
    s.m->geom_size[3 * id + 1] = half;
    s.m->geom_rbound[id] = half + s.m->geom_size[3 * id];
    if (rb.geom_sagging[k]) sd.geom_sag[id] = chord_sag_bound(rb.model, rd, gd);  // widen_contact_margins
  }
  for (size_t k = 0; k < rb.site_id.size(); ++k) {
    const RodBinding::Fixed& f = rb.site_fixed[k];
    const int id = rb.site_id[k];
    SE3 g;
    if (f.fixed) {
      g = anchor_pose(rd, f.anchor) * f.rel;
    } else if (const int kp = rb.site_point[k]; kp >= 0) {  // site_pose's pose, and patch_tendons' Jacobian
      SceneData::RodScratch& sc = sd.scratch[r];
      const RodSiteDecl& sdl = rb.decl.sites[k];
      if (kp == static_cast<int>(k))  // the first path point at this abscissa: evaluated for all
        sc.site_center[k] =
            rod_pose_and_jacobian(rb.model, rd, 0, sdl.X, s.site_section[id], sc.site_J[k], &sc.site_g_start[k]);
      g = sc.site_center[kp];
      g.u += g.R * sdl.pos;
    } else {
      g = site_pose(rb.model, rd, rb.decl.sites[k]);
    }
    set_pose(d->site_xpos + 3 * id, d->site_xmat + 9 * id, g);
  }
  for (int g : rb.other_geom_id) geom_kinematics(m, d, g);
  for (int i : rb.other_site_id) site_kinematics(m, d, i);
  for (int b = rb.below_begin; b < rb.below_end; ++b) body_kinematics(m, d, b);
  attached_kinematics(m, d, rb.below_begin, rb.below_end);
  hang_payload(m, d, rb, rd);
}

}  // namespace

// Spatial transform MuJoCo's com-based vectors live in, for a frame g: G = (R, p - c).
SE3 com_frame(const SE3& g, const mjtNum* c) { return SE3{g.R, g.u - Vec3(c[0], c[1], c[2])}; }

namespace {

// Patch point 2: cdof of each strain dof = twist of its section's end per unit dof velocity.
void patch_cdof(const Scene& s, SceneData& sd, int r) {
  mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  cosserat::Data& rd = sd.rod[r];
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    const Section& sec = rb.model.sections[i];
    if (sec.ndof == 0) continue;
    const Mat6X& J = rd.Jg[sec.end_node];  // section_jacobian at the section end
    const mjtNum* c = d->subtree_com + 3 * s.m->body_rootid[rb.proxy_body[i]];
    const Mat6 A = Ad(com_frame(rd.g[sec.end_node], c));
    for (int k = 0; k < sec.ndof; ++k) {
      const Vec6 v = A * J.col(k);
      for (int e = 0; e < 6; ++e) d->cdof[6 * (rb.dof0 + sec.dof0 + k) + e] = v(e);
    }
  }
}

// Patch point 4: cdof_dot = d/dt (Ad_G J) = Ad_G (ad_eta J + Jdot), eta the end frame's twist.
void patch_cdof_dot(const Scene& s, SceneData& sd, int r) {
  mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  cosserat::Data& rd = sd.rod[r];
  cosserat::group_jacobian_dot(rb.model, rd);
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    const Section& sec = rb.model.sections[i];
    if (sec.ndof == 0) continue;
    const Mat6X& J = rd.Jg[sec.end_node];  // section_jacobian and its Jdot at the section end
    const Mat6X& Jd = rd.Jgdot[sec.end_node];
    const mjtNum* c = d->subtree_com + 3 * s.m->body_rootid[rb.proxy_body[i]];
    const Mat6 A = Ad(com_frame(rd.g[sec.end_node], c));
    const Mat6 ade = ad(rd.eta[sec.end_node]);
    for (int k = 0; k < sec.ndof; ++k) {
      const Vec6 v = A * (ade * J.col(k) + Jd.col(k));
      for (int e = 0; e < 6; ++e) d->cdof_dot[6 * (rb.dof0 + sec.dof0 + k) + e] = v(e);
    }
  }
}

// Jacobian columns of the dofs of section `si` (the section whose proxy carries the point), for a
// point p (world) riding with the cross-section at X in that section, minus what MuJoCo computed
// treating p as fixed to the proxy (the section end). dJ rows: translation (0-2) and rotation
// (3-5), world axes. Returns the section's first MuJoCo dof (ndof = dJ.cols()). Needs
// fwd_position and the patched cdof.
// The same from the section Jacobian J at X and the pose g_start_X of X in the section's start
// frame (section_jacobian's).
int point_correction(const Scene& s, const SceneData& sd, int r, int si, const Mat6X& J, const SE3& g_start_X,
                     const Vec3& p, SectionCols& dJ) {
  const mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  const cosserat::Data& rd = sd.rod[r];
  const Section& sec = rb.model.sections[si];
  const SE3 gX = anchor_pose(rd, sec.start_node) * g_start_X;  // the section starts at its start node
  const mjtNum* c = d->subtree_com + 3 * s.m->body_rootid[rb.proxy_body[si]];
  const Vec3 pc = p - Vec3(c[0], c[1], c[2]), r_w = p - gX.u;
  dJ.resize(6, sec.ndof);
  for (int k = 0; k < sec.ndof; ++k) {
    const Vec3 w = gX.R * J.col(k).head<3>();
    const Vec3 v = gX.R * J.col(k).tail<3>() + w.cross(r_w);  // true velocity of the material point
    const mjtNum* cd = d->cdof + 6 * (rb.dof0 + sec.dof0 + k);
    const Vec3 wm(cd[0], cd[1], cd[2]);
    const Vec3 vm = Vec3(cd[3], cd[4], cd[5]) + wm.cross(pc);  // MuJoCo's: rigid with the proxy
    dJ.col(k).head<3>() = v - vm;
    dJ.col(k).tail<3>() = w - wm;
  }
  return rb.dof0 + sec.dof0;
}

int point_correction(const Scene& s, const SceneData& sd, int r, int si, double X, const Vec3& p, SectionCols& dJ) {
  Mat6X& J = sd.scratch[r].section_J[si];
  SE3 g_start_X;
  section_jacobian(s.rods[r].model, sd.rod[r], 0, X, J, nullptr, &g_start_X, si);
  return point_correction(s, sd, r, si, J, g_start_X, p, dJ);
}

// The Jacobian in MuJoCo's dofs of the point p riding with the cross-section at abscissa X of
// section si of rod r, in world axes as mj_jac writes it: jp (3 x nv) its translation, jr (3 x nv)
// the cross-section's rotation. After fwd_position.
void cross_section_jacobian_world(const Scene& s, const SceneData& sd, int r, int si, double X, const Vec3& p,
                                  mjtNum* jp, mjtNum* jr) {
  const int nv = s.m->nv;
  mj_jac(s.m, sd.d, jp, jr, p.data(), s.rods[r].proxy_body[si]);
  SectionCols dJ;
  const int c0 = point_correction(s, sd, r, si, X, p, dJ);
  for (int e = 0; e < 3; ++e)
    for (int k = 0; k < dJ.cols(); ++k) {
      jp[e * nv + c0 + k] += dJ(e, k);
      jr[e * nv + c0 + k] += dJ(3 + e, k);
    }
}

// The body Jacobian (rows: rotation, translation, in the frame's own axes) in MuJoCo's dofs of the
// cross-section frame g at abscissa X of section si of rod r. After fwd_position.
void cross_section_jacobian(const Scene& s, const SceneData& sd, int r, int si, double X, const SE3& g,
                            Eigen::MatrixXd& Jb) {
  const int nv = s.m->nv;
  std::vector<mjtNum> jp(3 * nv), jr(3 * nv);
  cross_section_jacobian_world(s, sd, r, si, X, g.u, jp.data(), jr.data());
  Eigen::MatrixXd Jw(6, nv);  // world axes: rotation, translation
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < nv; ++k) Jw(i, k) = jr[i * nv + k], Jw(3 + i, k) = jp[i * nv + k];
  Jb.resize(6, nv);
  Jb.topRows<3>().noalias() = g.R.transpose() * Jw.topRows<3>();
  Jb.bottomRows<3>().noalias() = g.R.transpose() * Jw.bottomRows<3>();
}

}  // namespace

namespace {
// The last dof of `body` or of its nearest ancestor with dofs (-1: none).
int first_ancestor_dof(const mjModel* m, int body) {
  for (int b = body; b > 0; b = m->body_parentid[b])
    if (m->body_dofnum[b] > 0) return m->body_dofadr[b] + m->body_dofnum[b] - 1;
  return -1;
}

// MuJoCo's velocity-product acceleration of `body` (com-based spatial layout, as cacc with
// qacc = 0 and without gravity): sum of cdof_dot qvel over its dofs and its ancestors'.
Vec6 velocity_product_acceleration(const mjModel* m, const mjData* d, int body) {
  Vec6 a = Vec6::Zero();
  for (int j = first_ancestor_dof(m, body); j >= 0; j = m->dof_parentid[j])
    for (int e = 0; e < 6; ++e) a(e) += d->cdof_dot[6 * j + e] * d->qvel[j];
  return a;
}

// Rod r's kinetic-energy metric, point by point: for each mass point (points = 0: the dynamics'
// mass rule, else a `points`-point Gauss rule on each section), add(chain, A) with `chain` the
// dofs that move the point, deepest first, each the parent (dof_parentid) of the one before, and
// A = Jc^T I Jc the point's inertia on them. The point's Jacobian vanishes off that chain, so this
// is O(nv) (mj_jac) + O(chain^2) per point, where the dense metric would be O(nv^2).
template <class Add>
void rod_inertia_blocks(const Scene& s, SceneData& sd, int r, int points, Add&& add) {
  const cosserat::Model& rm = s.rods[r].model;
  const cosserat::Data& rd = sd.rod[r];
  Eigen::MatrixXd Jb, Jc;
  std::vector<int> chain;
  auto point = [&](int si, double X, const SE3& g, const Mat6& I) {
    chain.clear();
    for (int j = first_ancestor_dof(s.m, s.rods[r].proxy_body[si]); j >= 0; j = s.m->dof_parentid[j])
      chain.push_back(j);
    cross_section_jacobian(s, sd, r, si, X, g, Jb);
    Jc.resize(6, static_cast<Eigen::Index>(chain.size()));
    for (size_t a = 0; a < chain.size(); ++a) Jc.col(static_cast<Eigen::Index>(a)) = Jb.col(chain[a]);
    const Eigen::MatrixXd A = Jc.transpose() * I * Jc;
    add(chain, A);
  };
  if (points <= 0) {
    for (int i = rm.rods[0].first_node; i <= rm.rods[0].tip_node; ++i) {
      const Node& n = rm.nodes[i];
      if (n.inertia.isZero()) continue;
      point(std::max(n.section, 0), n.X, rd.g[i], n.inertia);
    }
    return;
  }
  std::vector<double> x, w;
  cosserat::gauss_legendre01(points, x, w);
  const cosserat::Rod& rod = rm.rods[0];
  for (int si = 0; si < static_cast<int>(rm.sections.size()); ++si) {
    const Section& sec = rm.sections[si];
    for (int k = 0; k < points; ++k) {
      const double X = sec.X0 + x[k] * sec.length;
      const Mat6 I = (w[k] * sec.length * section_inertia_density(sec.material, rod.radius(X))).asDiagonal();
      point(si, X, cosserat::rod_pose(rm, rd, 0, X), I);
    }
  }
}

// qM += sign * rod r's metric (rod_inertia), in MuJoCo's sparse layout: M(i, k-th ancestor of i)
// at qM[dof_Madr[i] + k].
void add_rod_inertia_sparse(const Scene& s, SceneData& sd, int r, int points, double sign, mjtNum* qM) {
  rod_inertia_blocks(s, sd, r, points, [&](const std::vector<int>& chain, const Eigen::MatrixXd& A) {
    const int n = static_cast<int>(chain.size());
    for (int a = 0; a < n; ++a)
      for (int b = a; b < n; ++b) qM[s.m->dof_Madr[chain[a]] + (b - a)] += sign * A(a, b);
  });
}
}  // namespace

Eigen::MatrixXd rod_inertia(const Scene& s, SceneData& sd, int r, int points) {
  const int nv = s.m->nv;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(nv, nv);
  rod_inertia_blocks(s, sd, r, points, [&](const std::vector<int>& chain, const Eigen::MatrixXd& A) {
    for (size_t a = 0; a < chain.size(); ++a)
      for (size_t b = 0; b < chain.size(); ++b) M(chain[a], chain[b]) += A(a, b);
  });
  return M;
}

// point_correction for the material point of rod site `site` at world position p (the cached
// section Jacobian of a tendon path point, RodBinding::site_point, when it has one).
int site_correction(const Scene& s, const SceneData& sd, int site, const Vec3& p, SectionCols& dJ) {
  const int r = s.site_rod[site], k = s.site_index[site];
  const int kp = s.rods[r].site_point[k];
  const SceneData::RodScratch& sc = sd.scratch[r];
  return kp >= 0 ? point_correction(s, sd, r, s.site_section[site], sc.site_J[kp], sc.site_g_start[kp], p, dJ)
                 : point_correction(s, sd, r, s.site_section[site], s.rods[r].decl.sites[k].X, p, dJ);
}

namespace {
// A capsule's axis: its centre, unit axis and half-length (the chord's, this evaluation's).
struct CapsuleAxis {
  Vec3 centre, axis;
  double half;
  explicit CapsuleAxis(const mjModel* m, const mjData* d, int geom)
      : centre(d->geom_xpos[3 * geom], d->geom_xpos[3 * geom + 1], d->geom_xpos[3 * geom + 2]),
        axis(d->geom_xmat[9 * geom + 2], d->geom_xmat[9 * geom + 5], d->geom_xmat[9 * geom + 8]),
        half(m->geom_size[3 * geom + 1]) {}
  // the signed distance along the axis from the centre of p's projection, clamped to the capsule
  double along(const Vec3& p) const { return std::clamp((p - centre).dot(axis), -half, half); }
  // the material abscissa of p projected on the axis, for the capsule declared as gd
  double abscissa(const RodGeomDecl& gd, const Vec3& p) const {
    return gd.X_begin + (0.5 + along(p) / (2.0 * half)) * (gd.X_end - gd.X_begin);
  }
};

}  // namespace

double capsule_abscissa(const Scene& s, const SceneData& sd, int geom, const Vec3& p) {
  return CapsuleAxis(s.m, sd.d, geom).abscissa(s.rods[s.geom_rod[geom]].decl.geoms[s.geom_index[geom]], p);
}

int capsule_correction(const Scene& s, const SceneData& sd, int geom, const Vec3& p, SectionCols& dJ) {
  const int r = s.geom_rod[geom];
  return point_correction(s, sd, r, s.rods[r].decl.geoms[s.geom_index[geom]].section, capsule_abscissa(s, sd, geom, p),
                          p, dJ);
}

namespace {

// Add `val` at (row, col) of efc_J, dense or sparse (the column is in the row's pattern: the
// section's dofs are in the chain of the contact's body). A sparse efc_J has a transposed copy,
// efc_JT, made by mj_makeConstraint and used by the solvers (the Newton Hessian): patch it too.
void efc_add(const mjModel* m, mjData* d, int row, int col, double val) {
  if (!mj_isSparse(m)) {
    d->efc_J[row * m->nv + col] += val;
    return;
  }
  const auto add = [val](mjtNum* data, const int* colind, int adr, int nnz, int c) {
    for (int k = 0; k < nnz; ++k)
      if (colind[adr + k] == c) {
        data[adr + k] += val;
        return;
      }
  };
  add(d->efc_J, d->efc_J_colind, d->efc_J_rowadr[row], d->efc_J_rownnz[row], col);
  add(d->efc_JT, d->efc_JT_colind, d->efc_JT_rowadr[col], d->efc_JT_rownnz[col], row);
}

// Patch point 5: contact rows touching rod capsules get the true point Jacobian of the section's
// own dofs at the contact's material abscissa. MuJoCo's rows are linear in the contact-frame
// Jacobian difference J2 - J1 (normal, tangents, then rotations about normal, t1, t2); pyramidal
// rows are the edges J_n +- mu_j J_j (mju_decodePyramid's basis).
void patch_contacts(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  thread_local SectionCols dJ, C;  // scratch: no heap memory
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& con = d->contact[i];
    if (con.efc_address < 0) continue;
    for (int side = 0; side < 2; ++side) {
      const int g = side == 0 ? con.geom1 : con.geom2;
      if (s.geom_rod[g] < 0) continue;
      const int col0 = capsule_correction(s, sd, g, Vec3(con.pos[0], con.pos[1], con.pos[2]), dJ);
      Eigen::Map<const Mat3r> frame(con.frame);
      C.resize(6, dJ.cols());  // contact-frame rows of the correction, signed as J2 - J1
      C.topRows<3>().noalias() = frame * dJ.topRows<3>();
      C.bottomRows<3>().noalias() = frame * dJ.bottomRows<3>();
      if (side == 0) C = -C;
      const int row0 = con.efc_address, type = d->efc_type[row0];
      for (int k = 0; k < C.cols(); ++k) {
        if (type == mjCNSTR_CONTACT_PYRAMIDAL) {
          for (int j = 1; j < con.dim; ++j) {
            efc_add(m, d, row0 + 2 * (j - 1), col0 + k, C(0, k) + con.friction[j - 1] * C(j, k));
            efc_add(m, d, row0 + 2 * (j - 1) + 1, col0 + k, C(0, k) - con.friction[j - 1] * C(j, k));
          }
        } else {  // frictionless or elliptic: one row per contact-frame direction
          for (int j = 0; j < con.dim; ++j) efc_add(m, d, row0 + j, col0 + k, C(j, k));
        }
      }
    }
  }
}

// The explicit <pair> of geoms g1 and g2 (either order), or -1.
int geom_pair(const Scene& s, int g1, int g2) {
  const long long key = static_cast<long long>(g1) * s.m->ngeom + g2;
  const auto it = std::lower_bound(s.pair_by_geoms.begin(), s.pair_by_geoms.end(), std::make_pair(key, -1));
  return it != s.pair_by_geoms.end() && it->first == key ? it->second : -1;
}

// Patch point 4b (after mj_collision, before mj_makeConstraint, which turns contact distances into
// the rows' positions and impedances): a contact on a capsule of a section with strain dofs is
// measured on the rod's centre line. MuJoCo measures it on the capsule, a chord between two
// centre-line points, while the rows act on the material point at the contact's abscissa: where a
// section bends fast the two move apart, and a stiff contact measured on one and pushing the
// other is not conservative (a GVS rod dropped on a sphere with 2 capsules per section, solref
// 0.004, gained 5.6% of its energy). The capsule's axis point where MuJoCo measured is the contact
// point moved back by the radius and half the distance along the normal n (from geom1 to geom2);
// the distance moves by n . (centre line at the contact's abscissa - that point): on a plane,
// exactly the centre line's height there minus the radius. MuJoCo found the contact within the
// capsule's margin widened by the chord's sag (RodBinding::geom_sagging); it is dropped when the
// centre line's distance is not below the user's margin (MuJoCo's rule: the larger of the geoms',
// or the pair's), its inclusion margin goes back to the user's (margin - the larger gap), and it is
// excluded, as MuJoCo excludes a contact in the gap, while the distance is not below that.
void patch_contact_distances(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  int kept = 0;  // contacts kept, compacted in place
  const bool override_margin = (m->opt.enableflags & mjENBL_OVERRIDE) && !s.sagging_geoms.empty();
  for (int i = 0; i < d->ncon; ++i) {
    mjContact con = d->contact[i];
    const Vec3 n(con.frame[0], con.frame[1], con.frame[2]), p(con.pos[0], con.pos[1], con.pos[2]);
    const double dist = con.dist;  // MuJoCo's, for both sides
    double margin[2], gap[2];
    bool sagging = false;
    for (int side = 0; side < 2; ++side) {
      const int g = side == 0 ? con.geom1 : con.geom2;
      margin[side] = m->geom_margin[g];
      gap[side] = m->geom_gap[g];
      const int r = s.geom_rod[g];
      if (r < 0) continue;
      const RodBinding& rb = s.rods[r];
      const int k = s.geom_index[g];
      if (!rb.geom_sagging[k]) continue;
      sagging = true;
      margin[side] = rb.geom_margin0[k];
      gap[side] = rb.geom_gap0[k];
      const double sign = side == 0 ? -1.0 : 1.0;  // geom2 lies along +n
      // the axis point: back along n (exact where the contact point is the surfaces' midpoint, as
      // for planes), then onto the chord (where a convex pair's contact point lies elsewhere on n)
      const CapsuleAxis c(m, d, g);
      const Vec3 back = p + sign * (m->geom_size[3 * g] + 0.5 * dist) * n;
      const Vec3 measured = c.centre + c.along(back) * c.axis;
      const Vec3 centre = cosserat::rod_pose(rb.model, sd.rod[r], 0, c.abscissa(rb.decl.geoms[k], p)).u;
      con.dist += sign * n.dot(centre - measured);
    }
    if ((!sagging && !override_margin) || con.exclude > 1) {
      d->contact[kept++] = con;
      continue;
    }
    const int pair = geom_pair(s, con.geom1, con.geom2);  // an explicit <pair> sets its own margin and gap
    // (MuJoCo's margin is o_margin under <flag override>, widened by widen_contact_margins for every
    // contact: each is put back at the user's)
    const double user_margin = override_margin ? s.o_margin0
                               : pair >= 0     ? s.pair_margin0[pair]
                                               : std::max(margin[0], margin[1]);
    // found only through the widened margin, beyond the user's: no contact (an adhesion actuator
    // counts the contacts in a gap, MuJoCo's excluded ones)
    if (con.dist >= user_margin) continue;
    if (pair < 0 || override_margin)
      con.includemargin = user_margin - (pair >= 0 ? s.pair_gap0[pair] : std::max(gap[0], gap[1]));
    con.exclude = con.dist < con.includemargin ? 0 : 1;
    d->contact[kept++] = con;
  }
  d->ncon = kept;
}

// Whether a contact of this evaluation touches a rod capsule or a geom of a body moving with a rod
// (patch_contact_references's work).
bool rod_contacts(const Scene& s, const mjData* d) {
  for (int i = 0; i < d->ncon; ++i)
    for (const int g : {d->contact[i].geom1, d->contact[i].geom2})
      if (s.geom_rod[g] >= 0 || s.body_by_rod[s.m->geom_bodyid[g]]) return true;
  return false;
}

// The velocity product of a material point p (world) riding with the cross-section at X of rod r's
// section si: the centre line's classical acceleration at qacc = 0 plus the cross-section's angular
// one crossed with the offset to p and the offset's centripetal term (a contact takes the
// centre-line point itself, p on the centre line: contact_anchor). World axes: angular, then
// linear. After patch_bias.
// From the cross-section's motion pm (cosserat::point_motion_at_rest_acceleration).
Vec6 riding_point_velocity_product(const mjModel* m, const cosserat::PointMotion& pm, const Vec3& p) {
  const Mat3& R = pm.pose.R;
  const Vec3 w = pm.eta.head<3>(), v = pm.eta.tail<3>();
  Vec6 c;
  c.head<3>() = R * pm.acc.head<3>();
  // the base's acceleration carried gravity as an upward acceleration (rod_velocity): take it out
  const Vec3 offset = p - pm.pose.u;
  const Vec3 ww = R * w;
  c.tail<3>() = R * (pm.acc.tail<3>() + w.cross(v)) + c.head<3>().cross(offset) + ww.cross(ww.cross(offset));
  if (!(m->opt.disableflags & mjDSBL_GRAVITY)) c.tail<3>() += Vec3(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]);
  return c;
}

Vec6 riding_point_velocity_product(const Scene& s, const SceneData& sd, int r, int si, double X, const Vec3& p) {
  return riding_point_velocity_product(
      s.m, cosserat::point_motion_at_rest_acceleration(s.rods[r].model, sd.rod[r], 0, X, si), p);
}

// The cross-section a point fixed to body b rides with, when that is one of a section with strain
// dofs: b is that section's proxy (its end, X), or b hangs below the rod's last proxy (the rod's tip;
// the innermost rod for nested ones) and the last section has dofs. Points on rigid sections, and
// below them, keep MuJoCo's rows.
bool riding_frame(const Scene& s, int b, int& rod, int& section, double& X) {
  if (b <= 0 || s.riding_rod[b] < 0) return false;
  rod = s.riding_rod[b];
  section = s.riding_section[b];
  const Section& sec = s.rods[rod].model.sections[section];
  X = sec.X0 + sec.length;
  return sec.ndof > 0;
}

// Whether body b is moved by a rod's strain dofs: a rod's proxy or helper, or a body below a rod.
bool moved_by_rod(const Scene& s, int b) {
  for (const RodBinding& rb : s.rods)
    if (b > rb.base_body && b < rb.below_end) return true;
  return false;
}

// The classical acceleration of a point p (world) fixed to body b, and b's angular acceleration
// (world axes: angular, linear), from b's spatial acceleration A in MuJoCo's com-based layout (at
// the subtree_com of b's tree) and b's d->cvel: A's linear part carried to p plus b's spin crossed
// with p's velocity (mj_objectAcceleration's correction).
Vec6 point_acceleration(const mjModel* m, const mjData* d, int b, const Vec6& A, const Vec3& p) {
  const Vec3 com(d->subtree_com + 3 * m->body_rootid[b]);
  const Vec3 wb(d->cvel + 6 * b), vcom(d->cvel + 6 * b + 3);
  Vec6 c;
  c.head<3>() = A.head<3>();
  c.tail<3>() = A.tail<3>() + A.head<3>().cross(p - com) + wb.cross(vcom + wb.cross(p - com));
  return c;
}

// The velocity product of a point p (world) fixed to body b, where b rides with a soft rod
// (riding_frame; false otherwise), as riding_point_velocity_product's: a section's proxy or a body
// fixed below the rod's tip rides with that cross-section. A body below the tip that turns or
// slides on joints of its own (Scene::riding_dof; outside probe BG: the coupler of a four-bar
// hanging on a hinge below a soft crank had been given the tip's centripetal term over its 0.4 m
// anchor) has the tip's velocity product carried down its chain of joints: MuJoCo's com-based cacc
// recursion, the tip's spatial acceleration plus cdof_dot qvel of the joints below it, then the
// point's classical acceleration with b's own spin. After patch_bias.
bool riding_body_velocity_product(const Scene& s, const SceneData& sd, int b, const Vec3& p, Vec6& c) {
  int r = -1, si = -1;
  double X = 0.0;
  if (!riding_frame(s, b, r, si, X)) return false;
  if (s.riding_dof[b] < 0) {
    c = riding_point_velocity_product(s, sd, r, si, X, p);
    return true;
  }
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  const cosserat::PointMotion pm = cosserat::point_motion_at_rest_acceleration(s.rods[r].model, sd.rod[r], 0, X, si);
  const Mat3& R = pm.pose.R;
  const Vec3 w = R * pm.eta.head<3>(), v = R * pm.eta.tail<3>();  // the tip's spin, its origin's velocity
  const Vec3 alpha = R * pm.acc.head<3>();
  const Vec3 a0 = R * (pm.acc.tail<3>() + pm.eta.head<3>().cross(pm.eta.tail<3>()));  // its origin's acceleration
  const int proxy = s.rods[r].proxy_body.back();
  const Vec3 com(d->subtree_com + 3 * m->body_rootid[proxy]);
  Vec6 A;  // the tip's spatial acceleration at the tree's subtree_com, MuJoCo's layout (angular, linear)
  A.head<3>() = alpha;
  A.tail<3>() = a0 - w.cross(v) + alpha.cross(com - pm.pose.u);
  for (int j = s.riding_dof[b]; j >= 0 && m->dof_bodyid[j] > proxy; j = m->dof_parentid[j])
    A += Eigen::Map<const Vec6>(d->cdof_dot + 6 * j) * d->qvel[j];
  c = point_acceleration(m, d, b, A, p);
  // the tip's acceleration carried gravity as an upward acceleration (rod_velocity): take it out
  if (!(m->opt.disableflags & mjDSBL_GRAVITY)) c.tail<3>() += Vec3(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]);
  return true;
}

// MuJoCo's <exclude> signatures, sorted (geoms_may_touch).
std::vector<int> sorted_exclusions(const mjModel* m) {
  std::vector<int> excluded(m->exclude_signature, m->exclude_signature + m->nexclude);
  std::sort(excluded.begin(), excluded.end());
  return excluded;
}

// MuJoCo's filters of a geom pair (mj_collision): the bodies' weld groups differ and are not parent
// and child (unless that filter is off), no <exclude> names the bodies, contype meets conaffinity.
bool geoms_may_touch(const mjModel* m, const std::vector<int>& excluded, int g1, int g2) {
  const int b1 = m->geom_bodyid[g1], b2 = m->geom_bodyid[g2];
  const int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
  if (w1 == w2) return false;
  const int p1 = m->body_weldid[m->body_parentid[w1]], p2 = m->body_weldid[m->body_parentid[w2]];
  if (!(m->opt.disableflags & mjDSBL_FILTERPARENT) && w1 && w2 && (w1 == p2 || w2 == p1)) return false;
  const int signature = ((std::min(b1, b2) + 1) << 16) + std::max(b1, b2) + 1;
  if (std::binary_search(excluded.begin(), excluded.end(), signature)) return false;
  return (m->geom_contype[g1] & m->geom_conaffinity[g2]) || (m->geom_contype[g2] & m->geom_conaffinity[g1]);
}

// Distance between the segments [a0, a1] and [b0, b1] (clamped closest points).
double segment_distance(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  const Vec3 u = a1 - a0, v = b1 - b0, w = a0 - b0;
  const double a = u.dot(u), b = u.dot(v), c = v.dot(v), d = u.dot(w), e = v.dot(w);
  const double den = a * c - b * b;
  double sc = den > 1e-14 * a * c ? std::clamp((b * e - c * d) / den, 0.0, 1.0) : 0.0;
  double tc = c > 0 ? std::clamp((b * sc + e) / c, 0.0, 1.0) : 0.0;
  sc = a > 0 ? std::clamp((b * tc - d) / a, 0.0, 1.0) : 0.0;  // back-projection after clamping t
  return (w + sc * u - tc * v).norm();
}

// Whether the scene can ever have constraint rows: contacts, equality constraints, joint or
// tendon limits, friction loss.
bool may_constrain(const Scene& s) { return s.m->neq > 0 || scene_may_have_events(s.m, s.may_collide); }

// MuJoCo 2.2.2's Newton constraint solver with sparse Jacobians stops the program ("Rank-defficient
// Hessian in HessianDirect") where a pivot of M + J'DJ falls below mjMINVAL (1e-15); with dense
// ones it raises such a pivot to mjMINVAL and goes on, as its factorisation of M does. Strain
// coordinates have their units (1/m): in SI a thin, short section's twist inertia lies there
// (outside probe Z: 1.3e-16 kg m^4 for a 6 mm section of a 1 mm wire on a floor, a crash at the
// first contact). Where a strain pivot of M at qpos0 is below kSmallPivot (a margin for other
// configurations; J'DJ, positive semi-definite, only raises the pivots, the Schur complements),
// a Newton scene that would run sparse by MuJoCo's rule (jacobian="auto") gets dense Jacobians,
// with a warning; one that asks for sparse ones keeps them, with a warning that it may stop.
constexpr double kSmallPivot = 100 * mjMINVAL;

void avoid_sparse_newton_on_small_pivots(Scene& s, SceneData& sd) {
  mjModel* m = s.m;
  if (m->opt.solver != mjSOL_NEWTON || !mj_isSparse(m) || !may_constrain(s)) return;
  mju_copy(sd.d->qpos, m->qpos0, m->nq);
  fwd_inertia(s, sd, true);
  std::vector<mjtNum> LD(m->nM), diag_inv(m->nv);
  factor_ldl(m, sd.d, sd.d->qM, LD.data(), diag_inv.data(), s.dof_strain.data());
  int small = -1;
  for (int i = 0; i < m->nv; ++i)
    if (s.dof_strain[i] && LD[m->dof_Madr[i]] < kSmallPivot && (small < 0 || LD[m->dof_Madr[i]] < LD[m->dof_Madr[small]]))
      small = i;
  if (small < 0) return;
  const bool asked = m->opt.jacobian == mjJAC_SPARSE;
  if (!asked) m->opt.jacobian = mjJAC_DENSE;
  const RodBinding* rod = nullptr;
  for (const RodBinding& rb : s.rods)
    if (small >= rb.dof0 && small < rb.dof0 + rb.model.nv) rod = &rb;
  char pivot[32];
  std::snprintf(pivot, sizeof pivot, "%.2g", LD[m->dof_Madr[small]]);
  const char* joint = mj_id2name(m, mjOBJ_JOINT, m->dof_jntid[small]);
  s.load_warnings.push_back(rod->decl.file + ":" + std::to_string(rod->decl.line) + ": <cosserat name=\"" +
                            rod->decl.name + "\">: the inertia of strain coordinate '" + (joint ? joint : "?") +
                            "' is " + pivot + " (SI), near MuJoCo's numerical floor of 1e-15, where MuJoCo 2.2.2's "
                            "sparse Newton constraint solver stops (\"Rank-defficient Hessian\"): " +
                            (asked ? "the model asks for sparse Jacobians and keeps them; jacobian=\"auto\" or \"dense\" "
                                     "avoids the stop"
                                   : "the scene runs with dense Jacobians (jacobian=\"dense\"") +
                            "; solver=\"CG\" also avoids it, and longer sections or smaller units, e.g. mm and g, "
                            "raise the inertia" + (asked ? "" : ")"));
}

// One soft PCS section with one capsule and two Gauss points of mass: its contacts act at the
// section's two ends, which a mode of the section moves without moving either mass point (held by
// the cross-sections' rotary inertia alone). Outside probe AX: a 1 m rod of one such section lying
// on a floor was held at its ends by forces of 0.4 N against its 3 N weight, sank 46 mm and was
// thrown up with 100 times its energy. Three Gauss points, the Lobatto rule or a second capsule (a
// contact at the middle) hold it. Said of a capsule that can collide by the compiled model (its
// contype and conaffinity from the rod, its class or a default alike: outside probe BQ).
void warn_one_capsule_sections(Scene& s) {
  const mjModel* m = s.m;
  for (const RodBinding& rb : s.rods) {
    if (rb.model.sections.size() != 1 || rb.geom_id.size() != 1) continue;
    const cosserat::Section& sec = rb.model.sections[0];
    int mass_nodes = 0;
    for (int k = sec.first_node; k <= sec.end_node; ++k) mass_nodes += rb.model.nodes[k].dX > 0 ? 1 : 0;
    const int g = rb.geom_id[0];
    if (sec.ndof > 0 && sec.order == 0 && sec.end_weight == 0.0 && mass_nodes < 3 &&
        (m->geom_contype[g] || m->geom_conaffinity[g]))
      s.load_warnings.push_back(rb.decl.file + ":" + std::to_string(rb.decl.line) +
                                ": <cosserat>: one section with capsules=\"1\" touches only at the section's two "
                                "ends, which its two Gauss points of mass let move without moving any mass: lying on "
                                "a floor such a rod sinks through it; use capsules=\"2\", quadrature=\"3\" or "
                                "\"lobatto\", or more sections");
  }
}

// A GVS section of order 2 or more bends between its capsules' ends, where MuJoCo finds a floor's
// contacts: with fewer than order + 2 capsules a section lying on a floor sags into it between
// them (outside probe CA: one section of order 6 on 2 capsules, 8.3 mm (0.83 r) deep, `equilibrium`
// converged and the touch reading the weight; order 2: 3.1 mm). A default of order + 2 capsules
// (this session's first answer) overflowed MuJoCo's default contact buffers on long rods and left
// explicit <pair>s naming g0 and g1 covering part of each section (outside probe CC): warned
// instead, once per rod, where its capsules can collide.
void warn_gvs_capsules(Scene& s) {
  const mjModel* m = s.m;
  if (!s.may_collide) return;
  for (const RodBinding& rb : s.rods) {
    const auto& secs = rb.model.sections;
    std::string which;
    int order = 0, capsules = 0;
    for (size_t i = 0; i < secs.size(); ++i) {
      if (secs[i].order < 2 || secs[i].ndof == 0) continue;
      int n = 0;
      bool collides = false;
      for (size_t g = 0; g < rb.decl.geoms.size(); ++g)
        if (rb.decl.geoms[g].section == static_cast<int>(i)) {
          ++n;
          const int id = rb.geom_id[g];
          collides = collides || m->geom_contype[id] || m->geom_conaffinity[id];
        }
      if (!collides || n >= secs[i].order + 2) continue;
      which += (which.empty() ? "" : ", ") + std::to_string(i);
      order = std::max(order, secs[i].order), capsules = n;
    }
    if (which.empty()) continue;
    s.load_warnings.push_back(rb.decl.file + ":" + std::to_string(rb.decl.line) + ": <cosserat>: GVS section(s) " + which +
                              " of order up to " + std::to_string(order) + " with " + std::to_string(capsules) +
                              " capsules: a section of order 2 or more bends between its capsules' ends, where a floor's "
                              "contacts are found, and lying on one it sags into it between them (one section of order 6 "
                              "on 2 capsules: 0.83 of its radius deep); capsules=\"" + std::to_string(order + 2) +
                              "\" (order + 2) keeps it within a tenth of a millimetre of its radius (more contacts: "
                              "<size nconmax> may need raising)");
  }
}

// A rod's element in its file, for load warnings: FILE:LINE: <cosserat name="NAME">
std::string rod_element(const RodBinding& rb) {
  return rb.decl.file + ":" + std::to_string(rb.decl.line) + ": <cosserat name=\"" + rb.decl.name + "\">";
}

// Torsional and rolling friction (condim 4, 6) on soft rods' contacts under the pyramidal cone: the
// linearised steps hold an elliptic cone's friction rows with their matrix, not the pyramid's edges
// (outside probe BO: held, those braked and blew up rolling rods), and a soft rod's end twisted by
// 16% of mu_t N turned 4.7 rad on the floor under the default step (outside probe BM).
void warn_pyramidal_torsion(Scene& s) {
  const mjModel* m = s.m;
  if (m->opt.cone != mjCONE_PYRAMIDAL) return;
  const RodBinding* rod = nullptr;
  bool torsion = false;
  for (int g = 0; g < m->ngeom; ++g) {
    torsion = torsion || (m->geom_condim[g] >= 4 && (m->geom_contype[g] || m->geom_conaffinity[g]));
    // (a rod of rigid sections only keeps MuJoCo's rows, which hold it)
    if (!rod && s.geom_rod[g] >= 0 && (m->geom_contype[g] || m->geom_conaffinity[g]) && s.rods[s.geom_rod[g]].model.nv > 0)
      rod = &s.rods[s.geom_rod[g]];
  }
  for (int p = 0; p < m->npair && !torsion; ++p) torsion = m->pair_dim[p] >= 4;
  if (!rod || !torsion) return;
  s.load_warnings.push_back(rod_element(*rod) + ": contacts of condim 4 or 6 (torsional, rolling friction) with the "
                            "pyramidal cone: the default linearised step does not hold a soft rod's twist by them (a "
                            "rod's end twisted by 16% of its torsional friction limit turned 4.7 rad on a floor); "
                            "<option cone=\"elliptic\"> holds it under every integrator, the Newton schemes "
                            "(--newton 10, trapezoidal, genalpha, midpoint) with either cone");
}

// Frictionless contacts written as friction 0 with condim 3 or more under the pyramidal cone: the
// pyramid's edges J_n +- 0 J_t all equal the normal row, a degenerate set MuJoCo's solver stops on
// unconverged (outside probe CE: a soft gripper's touch sensors read up to 8.7e4 N on a 20 g box
// at rest, and the motion differed from condim 1's and the elliptic cone's, which agree). A pair
// contact's friction and condim are the larger of its geoms' (or a <pair>'s own).
void warn_frictionless_pyramid(Scene& s) {
  const mjModel* m = s.m;
  if (m->opt.cone != mjCONE_PYRAMIDAL || !s.may_collide) return;
  auto collidable = [&](int g) { return m->geom_contype[g] || m->geom_conaffinity[g]; };
  const RodBinding* rod = nullptr;
  for (int g = 0; g < m->ngeom && !rod; ++g) {
    if (s.geom_rod[g] < 0 || !collidable(g) || m->geom_friction[3 * g] != 0.0) continue;
    for (int g2 = 0; g2 < m->ngeom && !rod; ++g2) {
      // (a rod's own capsules: only with selfcollide, rarely frictionless)
      if (s.geom_rod[g2] == s.geom_rod[g] || m->geom_friction[3 * g2] != 0.0 ||
          std::max(m->geom_condim[g], m->geom_condim[g2]) < 3)
        continue;
      if ((m->geom_contype[g] & m->geom_conaffinity[g2]) || (m->geom_contype[g2] & m->geom_conaffinity[g]))
        rod = &s.rods[s.geom_rod[g]];
    }
  }
  for (int p = 0; p < m->npair && !rod; ++p)
    if (m->pair_friction[5 * p] == 0.0 && m->pair_dim[p] >= 3) {
      const int g = s.geom_rod[m->pair_geom1[p]] >= 0 ? m->pair_geom1[p] : m->pair_geom2[p];
      if (s.geom_rod[g] >= 0) rod = &s.rods[s.geom_rod[g]];
    }
  if (!rod) return;
  s.load_warnings.push_back(rod_element(*rod) + ": contacts with friction 0 and condim 3 or more under the pyramidal "
                            "cone: the pyramid's edges all equal the normal row, a degenerate set on which MuJoCo's "
                            "solver stops unconverged (contact forces and touch sensors off by orders of magnitude, the "
                            "motion changed); for frictionless contacts write condim=\"1\" (or <option "
                            "cone=\"elliptic\">)");
}

// A load warning for two rods whose capsules overlap in the model's reference configuration where
// MuJoCo would collide them: rods mounted at one point of one body (or of the world) overlap at
// their bases, which the proxies' exclusions (parent body, tip bodies) do not cover, and push each
// other apart from the first step. (Outside probe U: two branches from one hub.) `sd`: positions
// evaluated at qpos0 (recompute_qpos0_constants leaves them so).
void warn_overlapping_rods(Scene& s, const SceneData& sd) {
  const mjModel* m = s.m;
  if (!s.may_collide) return;
  const std::vector<int> excluded = sorted_exclusions(m);
  auto ends = [&](int g, Vec3& p0, Vec3& p1) {
    const Vec3 c(sd.d->geom_xpos[3 * g], sd.d->geom_xpos[3 * g + 1], sd.d->geom_xpos[3 * g + 2]);
    const Vec3 z(sd.d->geom_xmat[9 * g + 2], sd.d->geom_xmat[9 * g + 5], sd.d->geom_xmat[9 * g + 8]);
    p0 = c - m->geom_size[3 * g + 1] * z;
    p1 = c + m->geom_size[3 * g + 1] * z;
  };
  for (size_t r1 = 0; r1 < s.rods.size(); ++r1)
    for (size_t r2 = r1; r2 < s.rods.size(); ++r2) {  // r2 = r1: a selfcollide rod's own sections
      std::vector<std::string> pairs;
      for (const int g1 : s.rods[r1].geom_id)
        for (const int g2 : s.rods[r2].geom_id) {
          if ((r1 == r2 && g2 <= g1) || !geoms_may_touch(m, excluded, g1, g2)) continue;
          Vec3 a0, a1, b0, b1;
          ends(g1, a0, a1);
          ends(g2, b0, b1);
          const double depth = m->geom_size[3 * g1] + m->geom_size[3 * g2] - segment_distance(a0, a1, b0, b1);
          if (depth > 1e-9 * (m->geom_size[3 * g1] + m->geom_size[3 * g2]))
            pairs.push_back(std::string("<exclude body1=\"") + mj_id2name(m, mjOBJ_BODY, m->geom_bodyid[g1]) +
                            "\" body2=\"" + mj_id2name(m, mjOBJ_BODY, m->geom_bodyid[g2]) + "\"/>");
        }
      if (pairs.empty()) continue;
      std::sort(pairs.begin(), pairs.end());
      pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
      const RodDecl& a = s.rods[r1].decl;
      const RodDecl& b = s.rods[r2].decl;
      std::string list;
      for (size_t k = 0; k < pairs.size() && k < 6; ++k) list += (k ? " " : "") + pairs[k];
      if (pairs.size() > 6) list += " ... (" + std::to_string(pairs.size()) + " pairs)";
      const std::string where = b.file + ":" + std::to_string(b.line) + ": <cosserat name=\"" + b.name + "\">: ";
      if (r1 == r2)
        s.load_warnings.push_back(where + "with selfcollide=\"true\" its own capsules overlap in the model's initial " +
                                  "configuration, where they collide: the contacts push its sections apart from the " +
                                  "first step (sections shorter than the rod's diameter overlap their neighbours' " +
                                  "neighbours). Use fewer sections, or exclude the pairs in <contact>: " + list);
      else
        s.load_warnings.push_back(where + "its capsules overlap those of rod '" + a.name + "' (" + a.file + ":" +
                                  std::to_string(a.line) + ") in the model's initial configuration, where they " +
                                  "collide: the contacts push the rods apart from the first step. If they are " +
                                  "mounted together, exclude the pairs in <contact>: " + list);
    }
}

// Load-time tables of widen_contact_margins: the explicit pairs with a sagging capsule and their own
// margins and gaps, and whether two sagging capsules of different bodies can meet.
void setup_sagging_contacts(Scene& s) {
  const mjModel* m = s.m;
  std::vector<char> sagging(m->ngeom, 0);
  for (const int g : s.sagging_geoms) sagging[g] = 1;
  s.o_margin0 = m->opt.o_margin;
  s.pair_margin0.assign(m->pair_margin, m->pair_margin + m->npair);
  s.pair_gap0.assign(m->pair_gap, m->pair_gap + m->npair);
  for (int p = 0; p < m->npair; ++p) {
    const int g1 = m->pair_geom1[p], g2 = m->pair_geom2[p];
    if (sagging[g1] || sagging[g2]) s.sagging_pairs.push_back(p);
    if (sagging[g1] && sagging[g2]) s.sagging_capsules_meet = true;
  }
  const std::vector<int> excluded = sorted_exclusions(m);
  const auto may_touch = [&](int g1, int g2) { return geoms_may_touch(m, excluded, g1, g2); };
  const std::vector<int>& g = s.sagging_geoms;
  for (size_t i = 0; i < g.size() && !s.sagging_capsules_meet; ++i)
    for (size_t j = i + 1; j < g.size() && !s.sagging_capsules_meet; ++j) s.sagging_capsules_meet = may_touch(g[i], g[j]);
}

// Load-time table of riding_frame: the rod and section each body rides with.
void setup_riding_frames(Scene& s) {
  s.riding_rod.assign(s.m->nbody, -1);
  s.riding_section.assign(s.m->nbody, -1);
  s.riding_dof.assign(s.m->nbody, -1);
  for (size_t r = 0; r < s.rods.size(); ++r) {  // outer rods first: a later match is an inner rod
    const RodBinding& rb = s.rods[r];
    for (size_t k = 0; k < rb.proxy_body.size(); ++k) {
      s.riding_rod[rb.proxy_body[k]] = static_cast<int>(r);
      s.riding_section[rb.proxy_body[k]] = static_cast<int>(k);
    }
    for (int b = rb.below_begin; b < rb.below_end; ++b) {
      s.riding_rod[b] = static_cast<int>(r);
      s.riding_section[b] = static_cast<int>(rb.proxy_body.size()) - 1;
      const int j = first_ancestor_dof(s.m, b);  // a joint between the tip's proxy and b
      s.riding_dof[b] = j >= 0 && s.m->dof_bodyid[j] > rb.proxy_body.back() ? j : -1;
    }
  }
}

// The motion of a material point x (world) at qacc = 0, gravity out: its velocity v and velocity
// product a, its frame's spin w and angular velocity product alpha (world axes), where the coupling
// knows them exactly; `riding`: x rides with a soft rod.
struct MaterialMotion {
  Vec3 x = Vec3::Zero(), v = Vec3::Zero(), a = Vec3::Zero(), w = Vec3::Zero(), alpha = Vec3::Zero();
  Vec3 axis = Vec3::UnitX();  // a line anchor's direction (contact_anchor), turning with w
  bool riding = false;
};

// The point x riding with the cross-section whose motion is pm (x null: its centre-line point).
MaterialMotion riding_material_motion(const mjModel* m, const cosserat::PointMotion& pm, const Vec3* x) {
  const Mat3& R = pm.pose.R;
  MaterialMotion k;
  k.x = x ? *x : pm.pose.u;
  const Vec6 c = riding_point_velocity_product(m, pm, k.x);
  k.a = c.tail<3>();
  k.alpha = c.head<3>();
  k.w = R * pm.eta.head<3>();
  k.v = R * (pm.eta.tail<3>() + pm.eta.head<3>().cross(R.transpose() * (k.x - pm.pose.u)));
  k.axis = R.col(0);  // the centre line's tangent
  k.riding = true;
  return k;
}

// The point of rod r's soft section si on the cross-section at X, at x (the centre-line point when
// x is null). False on a section without strain dofs.
bool section_point_motion(const Scene& s, const SceneData& sd, int r, int si, double X, const Vec3* x,
                          MaterialMotion& k) {
  if (s.rods[r].model.sections[si].ndof == 0) return false;
  k = riding_material_motion(s.m, cosserat::point_motion_at_rest_acceleration(s.rods[r].model, sd.rod[r], 0, X, si), x);
  return true;
}

// The point x fixed to body b: the world's (at rest), a body riding with a soft rod
// (riding_body_velocity_product; its velocity from the rod's cross-section, or from MuJoCo's cvel
// for a body on joints of its own below the tip, which cdof_dot_read keeps computed), a body no rod
// moves (MuJoCo's cvel and the sum of cdof_dot qvel). False for the rest (rigid sections of soft
// rods and the bodies below them, whose d->cdof_dot the step may leave unpatched).
bool body_point_motion(const Scene& s, const SceneData& sd, int b, const Vec3& x, MaterialMotion& k) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  k = MaterialMotion{};
  k.x = x;
  if (b == 0) return true;
  auto from_cvel = [&] {
    const Vec3 com(d->subtree_com + 3 * m->body_rootid[b]);
    k.w = Vec3(d->cvel + 6 * b);
    k.v = Vec3(d->cvel + 6 * b + 3) + k.w.cross(x - com);
  };
  if (s.riding_rod[b] >= 0) {
    if (s.riding_dof[b] < 0) {  // fixed to the cross-section it rides with
      int r = -1, si = -1;
      double X = 0.0;
      return riding_frame(s, b, r, si, X) && section_point_motion(s, sd, r, si, X, &x, k);
    }
    Vec6 c;
    if (!riding_body_velocity_product(s, sd, b, x, c)) return false;
    k.a = c.tail<3>();
    k.alpha = c.head<3>();
    k.riding = true;
    from_cvel();
    return true;
  }
  if (moved_by_rod(s, b)) return false;
  from_cvel();
  const Vec6 c = point_acceleration(m, d, b, velocity_product_acceleration(m, d, b), x);
  k.a = c.tail<3>();
  k.alpha = c.head<3>();
  return true;
}

// A site's material point (site_motion's cases: a rod site on a soft section, body_point_motion).
bool site_motion(const Scene& s, const SceneData& sd, int site, const Vec3& p, MaterialMotion& k) {
  if (const int r = s.site_rod[site]; r >= 0)
    return section_point_motion(s, sd, r, s.site_section[site], s.rods[r].decl.sites[s.site_index[site]].X, &p, k);
  return body_point_motion(s, sd, s.m->site_bodyid[site], p, k);
}

// The point of a geom that a contact at p is anchored to, for the row's velocity product, and its
// kind: a sphere's centre (a point, whose distance to the other geom the contact keeps), the point
// of a capsule's segment nearest p, or of a cylinder's axis when the normal n is across it (a line,
// `axis`, along which the contact may slide), p itself on a plane, a box or a cylinder's cap (a
// face's material point), and p on other shapes (ellipsoids, meshes, height fields: curved
// surfaces whose contact point is no material point; outside probe BJ: taken as a face, an
// ellipsoid rolling on a soft rod was braked from 1 m/s to 0.17 m/s in 0.4 s).
enum class Anchor { Face, Point, Line, Other };
Vec3 contact_anchor(const mjModel* m, const mjData* d, int g, const Vec3& p, const Vec3& n, Anchor& kind, Vec3& axis) {
  const Vec3 c(d->geom_xpos + 3 * g);
  axis = Vec3(d->geom_xmat[9 * g + 2], d->geom_xmat[9 * g + 5], d->geom_xmat[9 * g + 8]);
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE: kind = Anchor::Point; return c;
    case mjGEOM_CAPSULE: kind = Anchor::Line; break;
    case mjGEOM_CYLINDER: kind = std::abs(n.dot(axis)) < 0.5 ? Anchor::Line : Anchor::Face; break;
    case mjGEOM_PLANE: case mjGEOM_BOX: kind = Anchor::Face; return p;
    default: kind = Anchor::Other; return p;
  }
  if (kind == Anchor::Face) return p;
  const double h = m->geom_size[3 * g + 1];
  return c + std::clamp((p - c).dot(axis), -h, h) * axis;
}

// The second derivative at qacc = 0 of the distance from a point anchor P to the straight line
// through a line anchor L along L.axis (turning with L's spin): |q|'' with q = Pperp (xP - xL),
// Pperp = 1 - a a^T, the line's material anchor sliding freely along it. `fallback` where the
// point lies on the line.
double point_line_distance_acceleration(const MaterialMotion& L, const MaterialMotion& P, double fallback) {
  const Vec3& a = L.axis;
  const Vec3 ad = L.w.cross(a), add = L.alpha.cross(a) + L.w.cross(L.w.cross(a));
  const Vec3 dx = P.x - L.x, dv = P.v - L.v, da = P.a - L.a;
  auto perp = [&a](const Vec3& y) { return Vec3(y - a * a.dot(y)); };
  const Vec3 q = perp(dx);
  const double l = q.norm();
  if (l <= 0) return fallback;
  const Vec3 u = q / l;
  const Vec3 qd = perp(dv) - ad * a.dot(dx) - a * ad.dot(dx);
  const Vec3 qdd = perp(da) - 2.0 * (ad * a.dot(dv) + a * ad.dot(dv)) -
                   (add * a.dot(dx) + 2.0 * ad * ad.dot(dx) + a * add.dot(dx));
  return u.dot(qdd) + (qd.squaredNorm() - u.dot(qd) * u.dot(qd)) / l;
}

// The same for the distance between two straight lines, s . (x2 - x1) with s their common normal
// (a1 x a2, normalised): for lines crossing at 17 degrees or more; nearer parallel, the second
// line's anchor is taken as a point (the lines' slide along each other then moves it along the
// first line, which the distance ignores).
double line_line_distance_acceleration(const MaterialMotion& L1, const MaterialMotion& L2, double fallback) {
  const Vec3 c = L1.axis.cross(L2.axis);
  const double k = c.norm();
  if (k < 0.3) return point_line_distance_acceleration(L1, L2, fallback);
  const Vec3 a1d = L1.w.cross(L1.axis), a2d = L2.w.cross(L2.axis);
  const Vec3 a1dd = L1.alpha.cross(L1.axis) + L1.w.cross(a1d), a2dd = L2.alpha.cross(L2.axis) + L2.w.cross(a2d);
  const Vec3 cd = a1d.cross(L2.axis) + L1.axis.cross(a2d);
  const Vec3 cdd = a1dd.cross(L2.axis) + 2.0 * a1d.cross(a2d) + L1.axis.cross(a2dd);
  const Vec3 sh = c / k;
  const double kd = sh.dot(cd);
  const Vec3 shd = (cd - sh * kd) / k;
  const Vec3 shdd = (cdd - shd * kd - sh * (shd.dot(cd) + sh.dot(cdd))) / k - (cd - sh * kd) * kd / (k * k);
  const Vec3 dx = L2.x - L1.x, dv = L2.v - L1.v, da = L2.a - L1.a;
  const double sign = sh.dot(dx) >= 0 ? 1.0 : -1.0;
  return sign * (shdd.dot(dx) + 2.0 * shd.dot(dv) + sh.dot(da));
}

// Patch point 5b: MuJoCo's contact rows constrain J qacc and leave the velocity product dJ/dt qvel
// to the reference acceleration's feedback (aref = -b J qvel - k r). For a point on a rigid body
// that term is the centripetal acceleration of its offset, which a round geom's contact does not
// feel; on a soft section it carries the strain coordinates' own velocity products, which need
// not be small: a bent rod rolling about its centre line keeps that line still while J qacc
// reads hundreds of m/s^2, and its contacts, seeing the rod leave, let it sink through the floor.
// So a contact on a section with strain dofs, or on a geom of a body riding with a soft rod,
// constrains the second derivative of its gap: efc_aref -= the rows' velocity product, from both
// sides' anchors (contact_anchor: the centre-line point under the contact, a sphere's centre, a
// face's material point at the contact), their relative acceleration at qacc = 0 carried to the
// contact by their angular ones, and on the normal row the turning of the gap's direction. A side
// whose motion is not known here (a rigid section of a soft rod, a body below one) is taken at rest,
// MuJoCo's rule; contacts with no soft side stay MuJoCo's (bit for bit what welded bodies give).
// After patch_bias, whose rnea leaves the rods' nodes' velocity-product accelerations (with
// gravity, which the base's carries) in Data::acc.
void patch_contact_references(const Scene& s, SceneData& sd) {
  mjData* d = sd.d;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& con = d->contact[i];
    if (con.efc_address < 0) continue;
    const Vec3 p(con.pos[0], con.pos[1], con.pos[2]);
    Eigen::Map<const Mat3r> frame(con.frame);  // rows: the normal (geom1 to geom2), the tangents
    const Vec3 n = frame.row(0).transpose();
    MaterialMotion side[2];
    bool known[2] = {false, false};
    Anchor kind[2] = {Anchor::Face, Anchor::Face};
    for (int k = 0; k < 2; ++k) {
      const int g = k == 0 ? con.geom1 : con.geom2;
      if (const int r = s.geom_rod[g]; r >= 0) {  // a rod capsule: the centre-line point under the contact
        known[k] = section_point_motion(s, sd, r, s.rods[r].decl.geoms[s.geom_index[g]].section,
                                        capsule_abscissa(s, sd, g, p), nullptr, side[k]);
        kind[k] = Anchor::Line;
      } else {
        Vec3 axis;
        const Vec3 x = contact_anchor(s.m, d, g, p, n, kind[k], axis);
        known[k] = body_point_motion(s, sd, s.m->geom_bodyid[g], x, side[k]);
        side[k].axis = axis;
        // a curved surface's contact point is no material point: MuJoCo's rule for a rigid one
        if (kind[k] == Anchor::Other && !side[k].riding) known[k] = false;
      }
      if (!known[k]) side[k] = MaterialMotion{}, side[k].x = p;  // MuJoCo's rule for that side
    }
    if (!side[0].riding && !side[1].riding) continue;
    // the relative velocity product (geom2 - geom1), world axes: angular; and linear, of the
    // material points at the contact (each side's anchor, carried to p by its angular acceleration)
    Vec6 c;
    c.head<3>() = side[1].alpha - side[0].alpha;
    c.tail<3>() = side[1].a + side[1].alpha.cross(p - side[1].x) - side[0].a - side[0].alpha.cross(p - side[0].x);
    // the normal row: the second derivative of the gap at qacc = 0, n . da plus the turning of the
    // gap's direction. Two spheres keep the distance of their centres, whose direction u turns by
    // (|dv|^2 - (u . dv)^2) / l; a sphere, or a line anchor (a rod or capsule along a face), on a
    // face keeps its anchor's distance from the face, whose normal turns with the face's body f:
    // 2 (w_f x n) . dv + (alpha_f x n + w_f x (w_f x n)) . dx (none on a face at rest: a floor's rows
    // as before). A line anchor against a point or a line keeps the distance between the straight
    // lines along which the anchors slide (point_line_ and line_line_distance_acceleration: the
    // rods' slide along each other no turning of the gap; outside probe BJ: their relative
    // acceleration alone told a sphere pressing on the side of a rod turning with it to accelerate
    // by omega^2 d). Curved shapes other than spheres keep MuJoCo's rule. Until the forty-sixth
    // session it was the soft side's term alone (outside probe BI: a rod on a turning table pressing
    // on a wall of the table sank 12.6 mm where the rigid rod sank 0.3 mm, MuJoCo's rows leaving out
    // both sides' centripetal terms, which cancel; a stiff rod's end passed 283 mm through the wall),
    // and a rope sliding over a fixed drum was told to keep its centre line from turning with the
    // drum's surface.
    double normal = n.dot(c.tail<3>());
    if (known[0] && known[1] && kind[0] != Anchor::Other && kind[1] != Anchor::Other) {
      const Vec3 dx = side[1].x - side[0].x, dv = side[1].v - side[0].v;
      const bool face0 = kind[0] == Anchor::Face, face1 = kind[1] == Anchor::Face;
      if (kind[0] == Anchor::Point && kind[1] == Anchor::Point) {
        const double l = dx.norm();
        if (l > 0) {
          const Vec3 u = dx / l;
          normal += (dv.squaredNorm() - u.dot(dv) * u.dot(dv)) / l;
        }
      } else if (face0 != face1) {
        const MaterialMotion& f = face0 ? side[0] : side[1];  // the face's body
        normal += 2 * f.w.cross(n).dot(dv) + (f.alpha.cross(n) + f.w.cross(f.w.cross(n))).dot(dx);
      } else if (kind[0] == Anchor::Line && kind[1] == Anchor::Line) {
        normal = line_line_distance_acceleration(side[0], side[1], normal);
      } else if (kind[0] == Anchor::Line && kind[1] == Anchor::Point) {
        normal = point_line_distance_acceleration(side[0], side[1], normal);
      } else if (kind[0] == Anchor::Point && kind[1] == Anchor::Line) {
        normal = point_line_distance_acceleration(side[1], side[0], normal);
      }
    }
    // contact-frame components: normal, tangents, then rotations about normal, t1, t2
    Eigen::Matrix<double, 6, 1> cf;
    cf.head<3>() = frame * c.tail<3>();
    cf(0) = normal;
    cf.tail<3>() = frame * c.head<3>();
    const int row0 = con.efc_address;
    if (d->efc_type[row0] == mjCNSTR_CONTACT_PYRAMIDAL) {
      for (int j = 1; j < con.dim; ++j) {
        d->efc_aref[row0 + 2 * (j - 1)] -= cf(0) + con.friction[j - 1] * cf(j);
        d->efc_aref[row0 + 2 * (j - 1) + 1] -= cf(0) - con.friction[j - 1] * cf(j);
      }
    } else {  // frictionless or elliptic: one row per contact-frame direction
      for (int j = 0; j < con.dim; ++j) d->efc_aref[row0 + j] -= cf(j);
    }
  }
}

// Patch point 5c: the same for equality constraints on a body riding with a soft rod (a proxy of a
// section with strain dofs, the section's end frame, or a body below a rod whose last section has
// dofs, riding with its tip; riding_frame): connect rows (anchor points) and weld rows (anchor
// points, and the rotation rows torquescale * 0.5 vec(neg(q1) (w0 - w1) q0 relpose), MuJoCo
// 2.2.2's, applied to the angular velocity products) constrain the acceleration of the anchor
// points riding with the cross-sections, their centripetal terms included (a material anchor's
// second derivative; probe M: left out, 54 m/s^2 of a shaft spun at 60 rad/s with its anchor 2 cm
// off the centre line doubled the violation). A bent shaft turning about its centre line, its tip held by a connect, drifted
// 3.4 mm off at 2 Hz (about 4x per doubling of the speed). Such a row gets the velocity product
// of its other body's anchor too (MuJoCo's cacc: sum of cdof_dot qvel, and the point's spin term),
// the row's whole dJ/dt qvel: with one side's alone, a four-bar whose coupler hangs on a hinge below a
// soft crank and meets a rigid rocker was told to accelerate by the coupler's centripetal term, which
// the rocker's left out balanced in MuJoCo's rows (outside probe BG: the loop drifted 15 mm where
// MuJoCo's own held it to 0.6). After patch_bias.
void patch_equality_references(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (int row = 0; row < d->nefc;) {
    if (d->efc_type[row] != mjCNSTR_EQUALITY) {
      ++row;
      continue;
    }
    const int e = d->efc_id[row], type = m->eq_type[e];
    const int size = type == mjEQ_CONNECT ? 3 : type == mjEQ_WELD ? 6 : 1;
    if (type == mjEQ_CONNECT || type == mjEQ_WELD) {
      const mjtNum* data = m->eq_data + mjNEQDATA * e;
      const int body[2] = {m->eq_obj1id[e], m->eq_obj2id[e]};
      Vec6 c = Vec6::Zero();  // body 0 minus body 1 (MuJoCo's sign for equality rows): angular, linear
      Vec6 cb[2] = {Vec6::Zero(), Vec6::Zero()};
      bool riding[2] = {false, false};
      Vec3 pw[2];
      for (int j = 0; j < 2; ++j) {
        if (body[j] <= 0) continue;  // the world: no motion
        // the anchor point, as mj_instantiateEquality places it
        const mjtNum* anchor = type == mjEQ_CONNECT ? data + 3 * j : data + 3 * (1 - j);
        mju_rotVecMat(pw[j].data(), anchor, d->xmat + 9 * body[j]);
        pw[j] += Vec3(d->xpos + 3 * body[j]);
        if (s.riding_rod[body[j]] >= 0) riding[j] = riding_body_velocity_product(s, sd, body[j], pw[j], cb[j]);
      }
      const bool any = riding[0] || riding[1];
      if (any) {
        for (int j = 0; j < 2; ++j)  // the other body's too: the row's whole velocity product
          if (body[j] > 0 && !riding[j])
            cb[j] = point_acceleration(m, d, body[j], velocity_product_acceleration(m, d, body[j]), pw[j]);
        c = cb[0] - cb[1];
      }
      if (any) {
        for (int k = 0; k < 3; ++k) d->efc_aref[row + k] -= c(3 + k);
        if (type == mjEQ_WELD) {
          mjtNum quat[4], quat1[4], quat2[4], quat3[4];
          mju_mulQuat(quat, d->xquat + 4 * body[0], data + 6);  // q0 relpose
          mju_negQuat(quat1, d->xquat + 4 * body[1]);           // neg(q1)
          const mjtNum axis[3] = {c(0), c(1), c(2)};
          mju_mulQuatAxis(quat2, quat1, axis);
          mju_mulQuat(quat3, quat2, quat);
          for (int k = 0; k < 3; ++k) d->efc_aref[row + 3 + k] -= data[10] * 0.5 * quat3[1 + k];
        }
      }
    }
    row += size;
  }
}

// The site path points of tendon t as mj_tendon wrote them: visit(site, p, grad) with p the point
// and grad = dL/dp. mj_tendon writes one path point per site (-1) and per pulley (-2) of the
// tendon, in the order of its wrap objects (a wrapped geom's tangent points carry the geom's id):
// walk both along.
template <class Visit>
void tendon_site_points(const mjModel* m, const mjData* d, int t, Visit&& visit) {
  const int adr = d->ten_wrapadr[t], num = d->ten_wrapnum[t];
  double divisor = 1.0;
  int w = m->tendon_adr[t];
  const int wrap_end = m->tendon_adr[t] + m->tendon_num[t];
  for (int k = 0; k < num; ++k) {
    const int obj = d->wrap_obj[adr + k];
    if (obj != -1 && obj != -2) continue;
    while (w < wrap_end && m->wrap_type[w] != mjWRAP_SITE && m->wrap_type[w] != mjWRAP_PULLEY) ++w;
    if (w == wrap_end) break;
    const int wrap = w++;
    if (obj == -2) {
      divisor = m->wrap_prm[wrap];
      continue;
    }
    const mjtNum* pk = d->wrap_xpos + 3 * (adr + k);
    Vec3 grad = Vec3::Zero();
    const Vec3 p(pk[0], pk[1], pk[2]);
    if (k > 0 && d->wrap_obj[adr + k - 1] != -2) {
      const mjtNum* q = d->wrap_xpos + 3 * (adr + k - 1);
      const Vec3 u = p - Vec3(q[0], q[1], q[2]);
      if (u.norm() > 0) grad += u.normalized();
    }
    if (k + 1 < num && d->wrap_obj[adr + k + 1] != -2) {
      const mjtNum* q = d->wrap_xpos + 3 * (adr + k + 1);
      const Vec3 u = Vec3(q[0], q[1], q[2]) - p;
      if (u.norm() > 0) grad -= u.normalized();
    }
    visit(m->wrap_objid[wrap], p, Vec3(grad / divisor));
  }
}

}  // namespace

// Whether every tendon of m is a spatial tendon through sites and pulleys only (no wrapping
// geoms, no fixed tendon): tendons_by_wrenches computes those.
bool tendons_of_sites_only(const mjModel* m) {
  for (int t = 0; t < m->ntendon; ++t)
    for (int k = m->tendon_adr[t]; k < m->tendon_adr[t] + m->tendon_num[t]; ++k)
      if (m->wrap_type[k] != mjWRAP_SITE && m->wrap_type[k] != mjWRAP_PULLEY) return false;
  return true;
}

namespace {

// mj_tendon for tendons_of_sites_only models: the same lengths (the same operations), path points
// (ten_wrapadr, ten_wrapnum, wrap_obj, wrap_xpos) and Jacobian layout (dense rows, or compressed
// rows on the union of the segments' bodies' dof chains, as mj_jacDifPair's merged chains make
// it), with the Jacobian summed as a transposed product instead of mj_tendon's two mj_jac calls
// per segment (each O(nv) wide: on the octopus arm's three cables through 8 sites, 11% of a step):
// a segment from p0 on body b0 to p1 on b1 with unit direction u pulls with u / divisor at p1 and
// -u / divisor at p0; each body's wrench (force, and moment about its tree's subtree_com, the
// point MuJoCo's cdof are taken at) is summed up the tree, and dL/dq_j = cdof_j . (moment, force)
// of the subtree of dof j's body. Equal to mj_tendon's to rounding (test
// Cable.TendonsOfSitesTakeMuJoCosLengthsAndJacobians); as mj_tendon, segments between sites of one body
// add nothing.
void tendons_by_wrenches(const mjModel* m, mjData* d, SceneData& sd) {
  const int nv = m->nv, nbody = m->nbody;
  const bool sparse = mj_isSparse(m);
  mjtNum* W = sd.ten_wrench.data();
  char* chain = sd.ten_chain.data();
  int wrapcount = 0;
  if (sparse) std::fill(d->ten_J_rownnz, d->ten_J_rownnz + m->ntendon, 0);
  for (int i = 0; i < m->ntendon; ++i) {
    const int adr = m->tendon_adr[i], num = m->tendon_num[i];
    d->ten_wrapadr[i] = wrapcount;
    d->ten_wrapnum[i] = 0;
    d->ten_length[i] = 0;
    std::fill(W, W + 6 * nbody, 0.0);
    std::fill(chain, chain + nbody, 0);
    mjtNum divisor = 1;
    for (int j = 0; j < num - 1;) {
      const int type0 = m->wrap_type[adr + j], type1 = m->wrap_type[adr + j + 1];
      if (type0 == mjWRAP_PULLEY || type1 == mjWRAP_PULLEY) {
        if (type0 == mjWRAP_PULLEY) {
          divisor = m->wrap_prm[adr + j];
          mju_zero3(d->wrap_xpos + 3 * wrapcount);
          d->wrap_obj[wrapcount++] = -2;
          d->ten_wrapnum[i]++;
        }
        ++j;
        continue;
      }
      const int id0 = m->wrap_objid[adr + j], id1 = m->wrap_objid[adr + j + 1];
      const mjtNum* p0 = d->site_xpos + 3 * id0;
      const mjtNum* p1 = d->site_xpos + 3 * id1;
      d->ten_length[i] += mju_dist3(p0, p1) / divisor;
      const int b0 = m->site_bodyid[id0], b1 = m->site_bodyid[id1];
      if (b0 != b1) {
        mjtNum u[3];
        mju_sub3(u, p1, p0);
        mju_normalize3(u);
        mju_scl3(u, u, 1 / divisor);
        for (const auto& [b, p, sign] : {std::tuple{b1, p1, 1.0}, std::tuple{b0, p0, -1.0}}) {
          const mjtNum* c = d->subtree_com + 3 * m->body_rootid[b];
          const Vec3 r(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
          const Vec3 f = sign * Vec3(u[0], u[1], u[2]);
          Eigen::Map<Vec3>(W + 6 * b) += r.cross(f);
          Eigen::Map<Vec3>(W + 6 * b + 3) += f;
          for (int a = b; a > 0 && !chain[a]; a = m->body_parentid[a]) chain[a] = 1;
        }
      }
      mju_copy3(d->wrap_xpos + 3 * wrapcount, p0);
      d->wrap_obj[wrapcount++] = -1;
      d->ten_wrapnum[i]++;
      ++j;
      if (j == num - 1 || m->wrap_type[adr + j + 1] == mjWRAP_PULLEY) {  // the last site before a pulley or the end
        mju_copy3(d->wrap_xpos + 3 * wrapcount, p1);
        d->wrap_obj[wrapcount++] = -1;
        d->ten_wrapnum[i]++;
      }
    }
    for (int b = nbody - 1; b > 0; --b)  // subtree sums (a parent's index is below its child's)
      if (const int p = m->body_parentid[b]; p > 0)
        for (int k = 0; k < 6; ++k) W[6 * p + k] += W[6 * b + k];
    const auto moment = [&](int dof) {
      const mjtNum* cd = d->cdof + 6 * dof;
      const mjtNum* w = W + 6 * m->dof_bodyid[dof];
      return cd[0] * w[0] + cd[1] * w[1] + cd[2] * w[2] + cd[3] * w[3] + cd[4] * w[4] + cd[5] * w[5];
    };
    if (!sparse) {
      for (int dof = 0; dof < nv; ++dof) d->ten_J[i * nv + dof] = moment(dof);
      continue;
    }
    const int row = d->ten_J_rowadr[i] = i > 0 ? d->ten_J_rowadr[i - 1] + d->ten_J_rownnz[i - 1] : 0;
    int nnz = 0;
    for (int dof = 0; dof < nv; ++dof)
      if (chain[m->dof_bodyid[dof]]) {
        d->ten_J_colind[row + nnz] = dof;
        d->ten_J[row + nnz++] = moment(dof);
      }
    d->ten_J_rownnz[i] = nnz;
  }
}

}  // namespace

// MuJoCo's tendon stage on a scene: tendons_by_wrenches where the scene has rods and its tendons
// are all spatial through sites and pulleys, else mj_tendon (rod-free scenes keep mj_step's bits).
void scene_tendons(const Scene& s, SceneData& sd) {
  if (!s.m->ntendon) return;
  if (!s.rods.empty() && tendons_of_sites_only(s.m))
    tendons_by_wrenches(s.m, sd.d, sd);
  else
    mj_tendon(s.m, sd.d);
}

namespace {

// Spatial tendons through rod sites: dL/dq gets the true site Jacobians. For a site at path point
// k, dL/dp_k = (u_in - u_out) / divisor (unit vectors of the segments into and out of it, which
// start or end at a wrapping geom's tangent point where the cable wraps one: the wrapped length is
// stationary in the tangent points; divisor: that of the last pulley before it, as mj_tendon counts
// the branch's length).
// Where MuJoCo keeps ten_J compressed (rows packed one after the other, ascending columns), the
// rows are unpacked into sd.ten_J_rows, corrected there and packed back on the union of MuJoCo's
// pattern and the corrected columns (a site's section dofs are in its body's chain, so the union
// is MuJoCo's pattern; the union keeps that an assumption nothing rests on). ten_J has room for
// ntendon x nv values.
void patch_tendons(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const int nv = m->nv;
  const bool sparse = mj_isSparse(m);
  mjtNum* J = sparse ? sd.ten_J_rows.data() : d->ten_J;
  char* mark = sd.ten_J_mark.data();
  if (sparse) {
    mju_zero(J, m->ntendon * nv);
    std::fill(sd.ten_J_mark.begin(), sd.ten_J_mark.end(), 0);
    for (int t = 0; t < m->ntendon; ++t)
      for (int k = d->ten_J_rowadr[t]; k < d->ten_J_rowadr[t] + d->ten_J_rownnz[t]; ++k) {
        J[t * nv + d->ten_J_colind[k]] = d->ten_J[k];
        mark[t * nv + d->ten_J_colind[k]] = 1;
      }
  }
  thread_local SectionCols dJ;  // scratch: no heap memory
  for (int t = 0; t < m->ntendon; ++t)
    tendon_site_points(m, d, t, [&](int site, const Vec3& p, const Vec3& grad) {
      if (s.site_rod[site] < 0) return;
      const int col0 = site_correction(s, sd, site, p, dJ);
      for (int c = 0; c < dJ.cols(); ++c) {
        J[t * nv + col0 + c] += grad.dot(dJ.col(c).head<3>());
        mark[t * nv + col0 + c] = 1;
      }
    });
  if (!sparse) return;
  int adr = 0;
  for (int t = 0; t < m->ntendon; ++t) {
    d->ten_J_rowadr[t] = adr;
    for (int c = 0; c < nv; ++c)
      if (mark[t * nv + c]) {
        d->ten_J_colind[adr] = c;
        d->ten_J[adr++] = J[t * nv + c];
      }
    d->ten_J_rownnz[t] = adr - d->ten_J_rowadr[t];
  }
}

// The velocity product of tendon t's length (d^2 L / dt^2 at qacc = 0), and whether some site of its
// path rides with a soft rod (else MuJoCo's rows stay as they are: `riding` false). For a spatial
// tendon whose every path point has a known motion (site_motion, body_point_motion) it is exact: over each
// segment, u . (a1 - a0) + (|v1 - v0|^2 - (u . (v1 - v0))^2) / l, divided by the pulleys' divisor
// (the turning of the segment's direction included). Until the forty-sixth session it was the
// riding sites' dL/dp . a alone, the rigid sites' accelerations and the turning left out: a
// segment from a site on a spinning hub to a rod site turning with it (a constant length) was told
// to accelerate by the rod site's centripetal term (as outside probe BG found for equality rows).
// A wrapped geom's tangent points count as material points of the geom's body (exact while the
// tendon does not slide on it; outside probe BI: a limit through a geom on a turning hub gave way
// 11.9 mm under the old rule), the arc between them as turning with it. A tendon through a site on
// a rigid section of a soft rod keeps the old rule. After patch_bias.
struct TendonProduct {
  double c = 0.0;
  bool riding = false;
};
// The riding sites' share of tendon t's velocity product, dL/dp . a (the rule for tendons whose
// path runs through a site of a rigid section of a soft rod, or a geom on one: their motion is not
// known exactly here).
TendonProduct tendon_sites_velocity_product(const Scene& s, const SceneData& sd, int t) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  TendonProduct out;
  tendon_site_points(m, d, t, [&](int site, const Vec3& p, const Vec3& grad) {
    MaterialMotion k;
    if (!site_motion(s, sd, site, p, k) || !k.riding) return;
    out.c += grad.dot(k.a);
    out.riding = true;
  });
  return out;
}

TendonProduct tendon_velocity_product(const Scene& s, const SceneData& sd, int t) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  TendonProduct out;
  bool exact = m->tendon_num[t] > 0 && m->wrap_type[m->tendon_adr[t]] != mjWRAP_JOINT;  // (a fixed tendon: none)
  if (exact) {
    const int adr = d->ten_wrapadr[t], num = d->ten_wrapnum[t];
    const int wrap_end = m->tendon_adr[t] + m->tendon_num[t];
    double divisor = 1.0;
    int w = m->tendon_adr[t];
    MaterialMotion prev, cur;
    for (int k = 0; k < num && exact; ++k) {
      const int obj = d->wrap_obj[adr + k];
      const Vec3 p(d->wrap_xpos + 3 * (adr + k));
      if (obj >= 0) {  // a wrapped geom's tangent point, as a material point of the geom's body
        exact = body_point_motion(s, sd, m->geom_bodyid[obj], p, cur);
      } else {  // a site (-1) or a pulley (-2): the next such wrap object
        while (w < wrap_end && m->wrap_type[w] != mjWRAP_SITE && m->wrap_type[w] != mjWRAP_PULLEY) ++w;
        if (w == wrap_end) return tendon_sites_velocity_product(s, sd, t);
        const int wrap = w++;
        if (obj == -2) {
          divisor = m->wrap_prm[wrap];
          continue;
        }
        exact = site_motion(s, sd, m->wrap_objid[wrap], p, cur);
      }
      out.riding = out.riding || cur.riding;
      // the straight segment from the point before (none after a pulley; between a geom's two
      // tangent points the path follows the geom's surface, turning with it)
      const int before = k > 0 ? d->wrap_obj[adr + k - 1] : -2;
      if (exact && before != -2 && !(obj >= 0 && before == obj)) {
        const Vec3 dp = p - prev.x, dv = cur.v - prev.v;
        const double l = dp.norm();
        if (l > 0) {
          const Vec3 u = dp / l;
          out.c += (u.dot(cur.a - prev.a) + (dv.squaredNorm() - u.dot(dv) * u.dot(dv)) / l) / divisor;
        }
      }
      prev = cur;
    }
    if (exact) return out;
  }
  return tendon_sites_velocity_product(s, sd, t);
}

// Patch point 5d: tendon limits and tendon equalities through sites on soft rods get their
// tendons' velocity products (tendon_velocity_product) in their reference accelerations, as the
// contact and equality rows do. A limit row is -side dL/dq (mj_instantiateLimit): the side from
// the row's distance; an equality row couples tendon 1 to a polynomial of tendon 2, L1 - f(L2)
// (row dL1 - f' dL2, velocity product c1 - f' c2 - f'' (dL2/dt)^2). After patch_bias.
void patch_tendon_references(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (int row = 0; row < d->nefc; ++row) {
    const int type = d->efc_type[row], id = d->efc_id[row];
    if (type == mjCNSTR_LIMIT_TENDON) {
      const TendonProduct tp = tendon_velocity_product(s, sd, id);
      if (!tp.riding) continue;
      const double L = d->ten_length[id];
      const double lower = L - m->tendon_range[2 * id], upper = m->tendon_range[2 * id + 1] - L;
      const double side = std::abs(d->efc_pos[row] - lower) <= std::abs(d->efc_pos[row] - upper) ? -1.0 : 1.0;
      d->efc_aref[row] -= -side * tp.c;
    } else if (type == mjCNSTR_EQUALITY && m->eq_type[id] == mjEQ_TENDON) {
      const int t1 = m->eq_obj1id[id], t2 = m->eq_obj2id[id];
      const TendonProduct tp1 = tendon_velocity_product(s, sd, t1);
      double c = tp1.c;
      bool riding = tp1.riding;
      if (t2 >= 0) {
        const mjtNum* poly = m->eq_data + mjNEQDATA * id;
        const double dif = d->ten_length[t2] - m->tendon_length0[t2];
        const double deriv = poly[1] + 2 * poly[2] * dif + 3 * poly[3] * dif * dif + 4 * poly[4] * dif * dif * dif;
        const double curv = 2 * poly[2] + 6 * poly[3] * dif + 12 * poly[4] * dif * dif;
        const TendonProduct tp2 = tendon_velocity_product(s, sd, t2);
        c -= deriv * tp2.c + curv * d->ten_velocity[t2] * d->ten_velocity[t2];
        riding = riding || tp2.riding;
      }
      if (riding) d->efc_aref[row] -= c;
    }
  }
}

// Base-frame columns of the ancestor dofs (sd.scratch[r].anc, fixed): Ad_G^-1 cdof_j.
void base_columns(const Scene& s, SceneData& sd, int r) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  SceneData::RodScratch& sc = sd.scratch[r];
  const SE3 G = com_frame(sd.rod[r].base_pose, d->subtree_com + 3 * m->body_rootid[s.rods[r].base_body]);
  for (size_t t = 0; t < sc.anc.size(); ++t) {
    Vec6 cd;
    for (int e = 0; e < 6; ++e) cd(e) = d->cdof[6 * sc.anc[t] + e];
    sc.C.col(t) = Ad_inv_apply(G, cd);
  }
}

// Patch point 3: the rod's inertia in qM (sparse: qM[dof_Madr[i] + k] = M(i, k-th ancestor)).
void patch_qM(const Scene& s, SceneData& sd, int r) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  cosserat::Data& rd = sd.rod[r];
  cosserat::crba(rb.model, rd);
  base_columns(s, sd, r);
  const SceneData::RodScratch& sc = sd.scratch[r];
  const int n = rb.model.nv, na = static_cast<int>(sc.anc.size());
  for (int i = 0; i < n; ++i) {
    const int adr = m->dof_Madr[rb.dof0 + i];
    for (int j = 0; j <= i; ++j) d->qM[adr + (i - j)] += rd.M(i, j);
    for (int t = 0; t < na; ++t) d->qM[adr + i + 1 + t] += rd.F_base.col(i).dot(sc.C.col(t));
  }
  for (int t = 0; t < na; ++t) {
    const Vec6 IcC = rd.Ic_base * sc.C.col(t);
    for (int u = t; u < na; ++u) d->qM[m->dof_Madr[sc.anc[t]] + (u - t)] += sc.C.col(u).dot(IcC);
  }
}

// Rod velocities for this step: strain rates from qvel, and the base's twist and bias
// acceleration (MuJoCo's cvel and sum cdof_dot qvel - gravity, to the base frame). Must run after
// mj_comVel and after the patches of every rod above this one (rods are ordered outer first).
void rod_velocity(const Scene& s, SceneData& sd, int r) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  cosserat::Data& rd = sd.rod[r];
  for (int k = 0; k < rb.model.nv; ++k) rd.v(k) = d->qvel[rb.dof0 + k];
  const SE3 G = com_frame(rd.base_pose, d->subtree_com + 3 * m->body_rootid[rb.base_body]);
  Vec6 cvel, cacc = velocity_product_acceleration(m, d, rb.base_body);
  for (int e = 0; e < 6; ++e) cvel(e) = d->cvel[6 * rb.base_body + e];
  if (!(m->opt.disableflags & mjDSBL_GRAVITY))
    cacc.tail<3>() -= Vec3(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]);
  rd.base_twist = Ad_inv_apply(G, cvel);
  rd.base_accel = Ad_inv_apply(G, cacc);
  cosserat::fwd_velocity(rb.model, rd, rb.cdof_dot_read);  // dS/dt only where cdof_dot is read
  if (rb.payload != (rd.attached_node >= 0)) hang_payload(m, d, rb, rd);  // decided again since the kinematics
  if (rb.payload) {  // the payload's cvel (MuJoCo's pass skips it): the rigid twist of its node
    const Vec6 c = Ad(com_frame(rd.g[rb.payload_node], d->subtree_com + 3 * m->body_rootid[rb.base_body])) *
                   rd.eta[rb.payload_node];
    for (int b = rb.below_begin; b < rb.below_end; ++b)
      for (int e = 0; e < 6; ++e) d->cvel[6 * b + e] = c(e);
  }
}

// Patch point 6: rod Coriolis, centrifugal and gravity forces, the reaction on the ancestors,
// and the rod's elastic and Kelvin-Voigt forces (explicit here; see the integrators).
void patch_bias(const Scene& s, SceneData& sd, int r) {
  mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  cosserat::Data& rd = sd.rod[r];
  const int n = rb.model.nv;
  rd.rhs.setZero();
  cosserat::rnea(rb.model, rd, rd.rhs, false, true, rd.qfrc_bias);  // gravity is in base_accel
  for (int k = 0; k < n; ++k) d->qfrc_bias[rb.dof0 + k] += rd.qfrc_bias(k);
  base_columns(s, sd, r);
  const SceneData::RodScratch& sc = sd.scratch[r];
  for (size_t t = 0; t < sc.anc.size(); ++t) d->qfrc_bias[sc.anc[t]] += sc.C.col(t).dot(rd.f_base);
  cosserat::passive(rb.model, rd);
  for (int k = 0; k < n; ++k) d->qfrc_passive[rb.dof0 + k] += rd.qfrc_passive(k);
}

}  // namespace

// ------------------------------------------------------------------------------- public API --

Scene::~Scene() {
  if (m) mj_deleteModel(m);
}

SceneData::SceneData(const Scene& s) : owner(&s) {
  d = mj_makeData(s.m);
  step_start_warmstart.assign(s.m->nv, 0);
  for (const auto& r : s.rods) rod.emplace_back(r.model);
  const int nv = s.m->nv, nq = s.m->nq, na = s.m->na;
  tmp_nv.assign(nv, 0);
  qacc_tmp.assign(nv, 0);
  for (auto* v : {&spring_V0, &spring_V1, &spring_P, &spring_w0, &spring_w1}) v->assign(s.m->njnt + s.m->ntendon, 0.0);
  geom_sag.assign(s.m->ngeom, 0.0);
  step_start.size(s.m);
  rk_q0.assign(nq, 0);
  rk_v0.assign(nv, 0);
  rk_a0.assign(na, 0);
  rk_kq.assign(4 * nv, 0);
  rk_kv.assign(4 * nv, 0);
  rk_ka.assign(4 * na, 0);
  rk_dx.assign(nv, 0);
  ros_M0.assign(s.m->nM, 0);
  for (auto* v : {&ros_sq, &ros_sv, &ros_rhs}) v->assign(nv, 0);
  ros_ja.assign(s.m->na, 0);
  A_LD.assign(s.m->nM, 0);
  A_LDiagInv.assign(nv, 0);
  joint_K.assign(nv, 0);
  K_rows.assign(static_cast<size_t>(s.m->ntendon + s.m->nu) * nv, 0);
  K_row_coef.assign(s.m->ntendon + s.m->nu, 0);
  {  // the elements' Woodbury rows, and kLoopContactRows for contact rows across branches
    const size_t r = woodbury_rows_of_elements(s.m) + (s.may_collide && !s.rods.empty() ? kLoopContactRows : 0);
    W_rows.assign(r * nv, 0);
    W_Z.assign(r * nv, 0);
    W_coef.assign(r, 0);
    W_S.assign(r * r, 0);
    W_t.assign(r, 0);
  }
  tree_nz.assign(nv, 0);
  {  // room for the frozen constraint rows of most scenes (more grows the vectors)
    const size_t rows = static_cast<size_t>(s.m->njmax);
    frozen_D.reserve(rows);
    frozen_c.reserve(rows);
    frozen_kI.reserve(rows);
    frozen_begin.reserve(rows + 1);
    frozen_across.reserve(rows);
    frozen_val.reserve(rows * std::min(nv, 64));
    frozen_dof.reserve(rows * std::min(nv, 64));
    frozen_row.assign(nv, 0.0);
  }
  if (s.m->ntendon && !s.rods.empty()) {  // (patch_tendons)
    ten_J_rows.assign(static_cast<size_t>(s.m->ntendon) * nv, 0);
    ten_J_mark.assign(static_cast<size_t>(s.m->ntendon) * nv, 0);
    ten_wrench.assign(static_cast<size_t>(s.m->nbody) * 6, 0.0);
    ten_chain.assign(s.m->nbody, 0);
  }
  newton.size(s.m);
  for (auto* v : {&newton.f0, &newton.A0, &newton.A, &newton.r, &newton.y, &newton.delta, &newton.v_end})
    v->assign(nv, 0);
  newton.q_end.assign(nq, 0);
  // constraint_pattern's largest: the contacts' geom pairs and two entries per constraint row
  for (auto* p : {&newton.pattern0, &newton.pattern}) p->reserve(1 + 2 * static_cast<size_t>(s.m->nconmax + s.m->njmax));
  newton.x_prev.assign(nv, 0);
  newton.F_prev.assign(nv, 0);
  newton.dX.assign(static_cast<size_t>(nv) * kMaxNewtonMemory, 0);
  newton.dF.assign(static_cast<size_t>(nv) * kMaxNewtonMemory, 0);
  adapt.size(s.m);
  for (auto* v : {&adapt.a_prev, &adapt.v_end}) v->assign(nv, 0);
  adapt.q_end.assign(nq, 0);
  fluid_qD.assign(s.fluid.active ? s.m->nM : 0, 0);
  fluid_f.assign(s.fluid.active ? nv : 0, 0);
  fluid_cols.setZero(6, s.fluid.max_chain);
  scratch.resize(s.rods.size());
  for (size_t r = 0; r < s.rods.size(); ++r) {
    RodScratch& sc = scratch[r];
    for (int j = first_ancestor_dof(s.m, s.rods[r].base_body); j >= 0; j = s.m->dof_parentid[j]) sc.anc.push_back(j);
    sc.C.resize(6, static_cast<int>(sc.anc.size()));
    rod[r].crba_base = !sc.anc.empty();  // patch_qM's coupling to the dofs above the base, if any
    sc.Kv.resize(s.rods[r].model.nv);
    sc.tau.resize(s.rods[r].model.nv);
    const RodBinding& rb = s.rods[r];
    sc.site_center.assign(rb.site_id.size(), SE3());
    sc.site_J.assign(rb.site_id.size(), Mat6X());
    sc.site_g_start.assign(rb.site_id.size(), SE3());
    for (size_t k = 0; k < rb.site_id.size(); ++k)
      if (rb.site_point[k] == static_cast<int>(k))
        sc.site_J[k].resize(6, rb.model.sections[s.site_section[rb.site_id[k]]].ndof);
    for (const Section& sec : rb.model.sections) {
      sc.section_J.emplace_back(6, sec.ndof);
      sc.section_Jdot.emplace_back(6, sec.ndof);
    }
  }
}

SceneData::~SceneData() {
  if (d) mj_deleteData(d);
}

namespace {
// Whether the model has a sensor MuJoCo evaluates at `stage` or a later one (whatever the sensor
// flags say now).
bool has_sensor_from(const mjModel* m, mjtStage stage) {
  for (int i = 0; i < m->nsensor; ++i)
    if (m->sensor_needstage[i] >= stage) return true;
  return false;
}

// Sensors MuJoCo evaluates at the acceleration stage (they read qacc or cacc), if sensors are on.
bool has_acceleration_sensors(const mjModel* m) {
  return !(m->opt.disableflags & mjDSBL_SENSOR) && has_sensor_from(m, mjSTAGE_ACC);
}

// Whether the last forward's M qacc is qfrc_smooth, exactly: no constraint rows (with acceleration
// sensors forward solves for qacc all the same). The implicit steps then take the forces, not
// M qacc: with a nearly singular M (a high-order GVS rod) M (M^-1 f) is f only to cond(M) times
// the round-off, which had kept a Newton iteration from converging once a sensor was added.
bool smooth_only(const SceneData& sd) { return sd.forces_only || sd.d->nefc == 0; }

void refresh_velocity_skips(const Scene& s);
}  // namespace

// MuJoCo 2.2.2's mj_fwdAcceleration without its solve for qacc_smooth: qfrc_smooth = passive -
// bias + applied + actuator forces and the bodies' xfrc_applied (mj_xfrcAccumulate, not exported,
// applies them at the bodies' centres of mass with mj_applyFT).
void smooth_forces(const mjModel* m, mjData* d) {
  const int nv = m->nv;
  mju_sub(d->qfrc_smooth, d->qfrc_passive, d->qfrc_bias, nv);
  mju_addTo(d->qfrc_smooth, d->qfrc_applied, nv);
  mju_addTo(d->qfrc_smooth, d->qfrc_actuator, nv);
  for (int b = 1; b < m->nbody; ++b)
    if (!mju_isZero(d->xfrc_applied + 6 * b, 6))
      mj_applyFT(m, d, d->xfrc_applied + 6 * b, d->xfrc_applied + 6 * b + 3, d->xipos + 3 * b, b, d->qfrc_smooth);
}

// Before the collisions: the margins and gaps of sagging capsules (RodBinding::geom_sagging) widened
// by their chords' sags (SceneData::geom_sag), so that MuJoCo finds the contacts their centre lines
// make. MuJoCo takes the larger of two geoms' margins: where two sagging capsules can meet, each
// also carries the step's largest sag (the larger of the two margins then covers both sags); an
// explicit pair's margin, which MuJoCo reads instead, gets its two geoms' sags.
void widen_contact_margins(const Scene& s, const SceneData& sd) {
  mjModel* m = s.m;
  double widest = 0.0;  // the largest sag of the step
  for (const int g : s.sagging_geoms) widest = std::max(widest, sd.geom_sag[g]);
  const double largest = s.sagging_capsules_meet ? widest : 0.0;
  for (const int g : s.sagging_geoms) {
    const RodBinding& rb = s.rods[s.geom_rod[g]];
    const int k = s.geom_index[g];
    m->geom_margin[g] = rb.geom_margin0[k] + sd.geom_sag[g] + largest;
    m->geom_gap[g] = rb.geom_gap0[k] + sd.geom_sag[g] + largest;
  }
  for (const int p : s.sagging_pairs) {
    const double sag = sd.geom_sag[m->pair_geom1[p]] + sd.geom_sag[m->pair_geom2[p]];
    m->pair_margin[p] = s.pair_margin0[p] + sag;
    m->pair_gap[p] = s.pair_gap0[p] + sag;
  }
  // under <flag override="enable"/> MuJoCo takes o_margin for every contact's margin: widened by
  // the largest sag, patch_contact_distances puts every contact back at o_margin (outside probe BM:
  // a soft rod with o_margin 5 mm rested at no margin)
  if (m->opt.enableflags & mjENBL_OVERRIDE) m->opt.o_margin = s.o_margin0 + widest + largest;
}

void fwd_inertia(const Scene& s, SceneData& sd, bool mass) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  refresh_velocity_skips(s);  // (before the payloads are hung on their rods and left out of crb)
  kinematics_except(m, d, s.body_by_rod.data());
  for (size_t r = 0; r < s.rods.size(); ++r) patch_rod_kinematics(s, sd, static_cast<int>(r));
  mj_comPos(m, d);
  for (size_t r = 0; r < s.rods.size(); ++r) patch_cdof(s, sd, static_cast<int>(r));
  if (!mass) {  // the ancestors' base-frame columns patch_qM leaves for the fluid's damping matrix
    for (size_t r = 0; r < s.rods.size(); ++r) base_columns(s, sd, static_cast<int>(r));
    return;
  }
  crb_skipping_massless(m, d, s.payload_body.data());
  for (size_t r = 0; r < s.rods.size(); ++r) patch_qM(s, sd, static_cast<int>(r));
}

namespace {

// d->qLD, d->qLDiagInv and d->qLDiagSqrtInv from d->qM, as mj_factorM computes them, but for the
// rods' strain dofs, whose pivots are not raised to mjMINVAL (1e-15): in SI units a thin, short
// section's twist inertia lies below it (outside probe Z: 1.3e-16 kg m^4 for a 6 mm section of
// a 1 mm wire), and the raised pivot made M^-1 wrong there, in the constraint solver's unconstrained
// accelerations and its inverse weights.
void factor_mass(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  if (s.rods.empty()) {
    mj_factorM(m, d);
    return;
  }
  factor_ldl(m, d, d->qM, d->qLD, d->qLDiagInv, s.dof_strain.data());
  for (int i = 0; i < m->nv; ++i) d->qLDiagSqrtInv[i] = std::sqrt(d->qLDiagInv[i]);
}

}  // namespace

// m->opt.timestep set to h for a scope, the previous value back however the scope ends.
struct TimestepScope {
  mjModel* m;
  double previous;
  TimestepScope(mjModel* model, double h) : m(model), previous(model->opt.timestep) { m->opt.timestep = h; }
  ~TimestepScope() { m->opt.timestep = previous; }
  TimestepScope(const TimestepScope&) = delete;
  TimestepScope& operator=(const TimestepScope&) = delete;
};

void fwd_position(const Scene& s, SceneData& sd, Need need) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const bool static_forces = need == Need::StaticForces || need == Need::SmoothStaticForces;
  fwd_inertia(s, sd, !static_forces);
  mj_camlight(m, d);
  if (!s.com_cameras.empty() || !s.com_lights.empty()) patch_com_tracking(s, sd);
  scene_tendons(s, sd);
  if (m->ntendon && !s.rods.empty()) patch_tendons(s, sd);
  fluid_damping(s, sd);  // fluid hook: damping matrix (scene_fluid.hpp); no-op without the fluid
  // (MuJoCo factorises M before the collisions; nothing up to the constraint projection reads
  // the factor, so it waits until the constraint rows tell whether it is needed)
  if (s.may_collide && need != Need::SmoothStaticForces) {
    if (!s.sagging_geoms.empty()) widen_contact_margins(s, sd);
    mj_collision(m, d);
  }
  else
    d->ncon = 0;  // what mj_collision finds when no geom pair passes its filters
  if (d->ncon && !s.rods.empty()) patch_contact_distances(s, sd);
  mj_makeConstraint(m, d);
  if (d->ncon && !s.rods.empty()) patch_contacts(s, sd);
  mj_transmission(m, d);
  if (!s.rod_site_actuators.empty()) patch_site_transmissions(s, sd);
  sd.forces_only = static_forces ||
                   (need == Need::Forces && d->nefc == 0 && (sd.step_sensors_done || !has_acceleration_sensors(m)));
  if (sd.forces_only) return;
  factor_mass(s, sd);
  mj_projectConstraint(m, d);
}


const mjtNum* tendon_jacobian_row(const Scene& s, const SceneData& sd, int t) {
  if (!mj_isSparse(s.m)) return sd.d->ten_J + static_cast<size_t>(t) * s.m->nv;
  return s.rods.empty() ? nullptr : sd.ten_J_rows.data() + static_cast<size_t>(t) * s.m->nv;
}


void fwd_velocity(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  if (m->ntendon) tendon_velocities(m, d);
  if (m->nu) mju_mulMatVec(d->actuator_velocity, d->actuator_moment, d->qvel, m->nu, m->nv);
  refresh_velocity_skips(s);
  com_velocity_except(m, d, s.velocity_skip.data());
  for (size_t r = 0; r < s.rods.size(); ++r) {
    rod_velocity(s, sd, static_cast<int>(r));
    if (s.rods[r].cdof_dot_read) patch_cdof_dot(s, sd, static_cast<int>(r));
  }
  mj_passive(m, d);
  mj_referenceConstraint(m, d);
  rne_except(m, d, 0, d->qfrc_bias, s.velocity_skip.data());
  for (size_t r = 0; r < s.rods.size(); ++r) patch_bias(s, sd, static_cast<int>(r));
  if (d->ncon && !s.rods.empty() && rod_contacts(s, d)) patch_contact_references(s, sd);
  if (d->ne && !s.rods.empty()) patch_equality_references(s, sd);
  if (m->ntendon && d->nefc && !s.rods.empty()) patch_tendon_references(s, sd);
  fluid_forces(s, sd);  // fluid hook: qfrc_passive -= D qvel; no-op without the fluid
}

// Lowers `c` to the smallest axial stretch of the extensible rods' current evaluation (sd.rod),
// recorded at `time`; `in_step` marks a record of a step's own evaluations (Compression::diverged_step).
void lower_compression(const Scene& s, const SceneData& sd, SceneData::Compression& c, double time, bool in_step) {
  for (size_t r = 0; r < s.rods.size(); ++r) {
    if (!s.rods[r].extensible) continue;
    int section = -1;
    const double stretch = cosserat::min_axial_stretch(s.rods[r].model, sd.rod[r], &section);
    if (stretch < c.stretch) c = {stretch, time, static_cast<int>(r), section, in_step};
  }
}

// SceneData is made for one Scene: another's sizes and buffers differ.
static void check_owner(const Scene& s, const SceneData& sd) {
  if (sd.owner != &s)
    throw std::invalid_argument("a SceneData steps with the Scene it was made from (SceneData(scene)), not another");
}

SceneUse::SceneUse(const Scene& s) : s_(s) {
  const std::thread::id me = std::this_thread::get_id();
  std::thread::id free;
  if (s.user.compare_exchange_strong(free, me)) {
    taken_ = true;
    return;
  }
  if (free != me)
    throw std::logic_error(
        "two threads step or evaluate one Scene at once: a step writes the rod capsules into the Scene's mjModel, "
        "so each thread needs a Scene of its own (load_scene in each); the SceneData of one Scene can be stepped "
        "in turn on one thread");
}

SceneUse::~SceneUse() {
  if (taken_) s_.user.store(std::thread::id());
}

void forward(const Scene& s, SceneData& sd, Need need) {
  check_owner(s, sd);
  const SceneUse use(s);
  const mjModel* m = s.m;
  mjData* d = sd.d;
  // the constraint model of the step a substep belongs to (SceneData::constraint_timestep)
  const TimestepScope constraint_step(s.m, sd.constraint_timestep > 0 ? sd.constraint_timestep : s.m->opt.timestep);
  const bool sensors = !sd.step_sensors_done;  // (SceneData::step_sensors_done)
  fwd_position(s, sd, need);
  if (sd.in_step) lower_compression(s, sd, sd.step_compression, 0.0, true);  // SceneData::step_compression
  if (sensors) {
    mj_sensorPos(m, d);
    patch_sensors(s, sd, mjSTAGE_POS);
  }
  fwd_velocity(s, sd);
  if (sensors) {
    mj_sensorVel(m, d);
    patch_sensors(s, sd, mjSTAGE_VEL);
  }
  if (sd.in_step) sd.step_sensors_done = true;
  if (m->opt.enableflags & mjENBL_ENERGY) {  // <flag energy="enable"/>: MuJoCo's d->energy, rods included
    const SceneEnergy e = energy(s, sd);
    d->energy[0] = e.gravity + e.elastic;
    d->energy[1] = e.kinetic;
  }
  if (mjcb_control) {  // MuJoCo 2.2.2's mj_forwardSkip calls it here, at every evaluation
    try {
      mjcb_control(m, d);
    } catch (...) {  // the application's own exception: step() passes it on (newton_step_split)
      sd.callback_threw = true;
      throw;
    }
  }
  mj_fwdActuation(m, d);
  if (sd.forces_only) {  // no constraints, no acceleration sensors: the forces are all the step needs
    smooth_forces(m, d);
    mju_zero(d->qfrc_constraint, m->nv);
    d->solver_iter = 0;
    return;
  }
  mj_fwdAcceleration(m, d);
  mj_fwdConstraint(m, d);
  if (sensors) {
    mj_sensorAcc(m, d);
    patch_sensors(s, sd, mjSTAGE_ACC);
  }
}

// --------------------------------------------------------------------------- load / reset --

void recompute_qpos0_constants(Scene& s) {
  SceneData sd(s);
  recompute_qpos0_constants(s, sd);
}

void recompute_qpos0_constants(Scene& s, SceneData& sd) {
  mjModel* m = s.m;
  mju_copy(sd.d->qpos, m->qpos0, m->nq);
  fwd_position(s, sd);
  // camera and light offsets for tracking modes (as mj_setConst computes them, which it did with
  // the proxies' temporary masses): from the static placement at qpos0, relative to the body and
  // to its subtree's centre of mass (MuJoCo's, which counts rigid bodies only; with the rods for
  // Scene::com_cameras and com_lights, which the step places from that centre of mass)
  for (int i = 0; i < m->ncam; ++i) {
    const int b = m->cam_bodyid[i];
    mjtNum xpos[3], xmat[9], qmat[9];
    mju_rotVecMat(xpos, m->cam_pos + 3 * i, sd.d->xmat + 9 * b);
    mju_addTo3(xpos, sd.d->xpos + 3 * b);
    mju_quat2Mat(qmat, m->cam_quat + 4 * i);
    mju_mulMatMat(xmat, sd.d->xmat + 9 * b, qmat, 3, 3, 3);
    mju_sub3(m->cam_pos0 + 3 * i, xpos, sd.d->xpos + 3 * b);
    mju_sub3(m->cam_poscom0 + 3 * i, xpos, sd.d->subtree_com + 3 * b);
    mju_copy(m->cam_mat0 + 9 * i, xmat, 9);
  }
  for (int i : s.com_cameras) {
    if (m->cam_mode[i] != mjCAMLIGHT_TRACKCOM) continue;
    const Vec3 c = subtree_com_with_rods(s, sd, m->cam_bodyid[i]);
    for (int e = 0; e < 3; ++e) m->cam_poscom0[3 * i + e] += sd.d->subtree_com[3 * m->cam_bodyid[i] + e] - c(e);
  }
  for (int i = 0; i < m->nlight; ++i) {
    const int b = m->light_bodyid[i];
    mjtNum xpos[3];
    mju_rotVecMat(xpos, m->light_pos + 3 * i, sd.d->xmat + 9 * b);
    mju_addTo3(xpos, sd.d->xpos + 3 * b);
    mju_sub3(m->light_pos0 + 3 * i, xpos, sd.d->xpos + 3 * b);
    mju_sub3(m->light_poscom0 + 3 * i, xpos, sd.d->subtree_com + 3 * b);
    mju_rotVecMat(m->light_dir0 + 3 * i, m->light_dir + 3 * i, sd.d->xmat + 9 * b);
  }
  for (int i : s.com_lights) {
    if (m->light_mode[i] != mjCAMLIGHT_TRACKCOM) continue;
    const Vec3 c = subtree_com_with_rods(s, sd, m->light_bodyid[i]);
    for (int e = 0; e < 3; ++e) m->light_poscom0[3 * i + e] += sd.d->subtree_com[3 * m->light_bodyid[i] + e] - c(e);
  }
  // These constants are scales (of constraint softness, of a muscle's force): they take the rods'
  // continuum inertia, integrated by kConstantsQuadrature Gauss points per section, not the mass
  // rule of the dynamics. With its 2 points per PCS section a free section has a mode that moves
  // neither mass point (held only by the cross-sections' rotary inertia): its end's inverse weight
  // was 70x a rod's, and MuJoCo's contact regulariser, which grows with it, let a one-section rod
  // sink 8 radii into a floor.
  // (MuJoCo's sparse LDL of qM and solves with it, as mj_setConst: a dense inverse was O(nv^3))
  const int nv = m->nv;
  for (size_t r = 0; r < s.rods.size(); ++r) {
    int points = kConstantsQuadrature;
    for (const Section& sec : s.rods[r].model.sections) points = std::max(points, sec.order + 6);
    add_rod_inertia_sparse(s, sd, static_cast<int>(r), points, 1.0, sd.d->qM);
    add_rod_inertia_sparse(s, sd, static_cast<int>(r), 0, -1.0, sd.d->qM);
  }
  factor_mass(s, sd);
  std::vector<mjtNum> e(nv, 0.0), x(nv);
  auto Minv_diag = [&](int a) {  // (M^-1)(a, a)
    e[a] = 1.0;
    mj_solveM(m, sd.d, x.data(), e.data(), 1);
    e[a] = 0.0;
    return x[a];
  };
  for (int j = 0; j < m->njnt; ++j) {
    const int a = m->jnt_dofadr[j];
    switch (m->jnt_type[j]) {
      case mjJNT_FREE: {
        const double t = (Minv_diag(a) + Minv_diag(a + 1) + Minv_diag(a + 2)) / 3.0;
        const double r = (Minv_diag(a + 3) + Minv_diag(a + 4) + Minv_diag(a + 5)) / 3.0;
        for (int k = 0; k < 3; ++k) m->dof_invweight0[a + k] = t, m->dof_invweight0[a + 3 + k] = r;
        break;
      }
      case mjJNT_BALL: {
        const double r = (Minv_diag(a) + Minv_diag(a + 1) + Minv_diag(a + 2)) / 3.0;
        for (int k = 0; k < 3; ++k) m->dof_invweight0[a + k] = r;
        break;
      }
      default: m->dof_invweight0[a] = Minv_diag(a);
    }
  }
  // a proxy's "centre of mass" is its section's (MuJoCo uses xipos; the proxy's own is empty)
  std::vector<int> proxy_rod(m->nbody, -1), proxy_sec(m->nbody, -1);
  for (size_t r = 0; r < s.rods.size(); ++r)
    for (size_t i = 0; i < s.rods[r].proxy_body.size(); ++i) {
      proxy_rod[s.rods[r].proxy_body[i]] = static_cast<int>(r);
      proxy_sec[s.rods[r].proxy_body[i]] = static_cast<int>(i);
    }
  std::vector<mjtNum> jp(3 * nv), jr(3 * nv), jx(3 * nv), jc(3 * nv), jrc(3 * nv);
  // the trace of J M^-1 J^T / 3, translation rows and rotation rows of jp and jr (3 solves each)
  auto inverse_weights = [&](double tr[2]) {
    for (int part = 0; part < 2; ++part) {
      const mjtNum* J = part == 0 ? jp.data() : jr.data();
      mj_solveM(m, sd.d, jx.data(), J, 3);
      tr[part] = mju_dot(J, jx.data(), 3 * nv) / 3.0;
    }
  };
  for (int b = 1; b < m->nbody; ++b) {
    double tr[2] = {0.0, 0.0};
    if (proxy_rod[b] >= 0) {
      const int r = proxy_rod[b], si = proxy_sec[b];
      const cosserat::Model& rm = s.rods[r].model;
      const cosserat::Data& rd = sd.rod[r];
      const Section& sec = rm.sections[si];
      const cosserat::Rod& rod = rm.rods[sec.rod];
      // the section's own mass points, visit(mass, node): its nodes' lumped cross-sections, the end
      // points of a Gauss-Lobatto section (shared with the neighbours) with this section's weight only
      auto mass_points = [&](auto&& visit) {
        auto point_mass = [&](double w, double X) {
          return w * sec.length * section_inertia_density(sec.material, rod.radius(X))(3);
        };
        for (int i = sec.first_node; i <= sec.end_node; ++i) {
          const double mi = i == sec.end_node && sec.end_weight > 0 ? point_mass(sec.end_weight, rm.nodes[i].X)
                                                                     : rm.nodes[i].inertia(3, 3);
          if (mi > 0) visit(mi, i);
        }
        if (sec.end_weight > 0) visit(point_mass(sec.end_weight, sec.X0), sec.start_node);
      };
      double mass = 0.0;
      if (sec.ndof == 0) {  // a rigid section: MuJoCo's rule at its centre of mass, as for its native equivalent
        Vec3 com = Vec3::Zero();
        mass_points([&](double mi, int node) {
          mass += mi;
          com += mi * rd.g[node].u;
        });
        com /= mass;
        mj_jac(m, sd.d, jp.data(), jr.data(), com.data(), b);
        inverse_weights(tr);
      } else {
        // a soft section is not rigid: MuJoCo's rule (mj_jacBodyCom) at its centre of mass, whose
        // Jacobian is the mass-weighted mean of its mass points' (each riding with its cross-section:
        // point_correction). Its centre of mass as if rigid with the proxy (the section end), used
        // first, is far off on a long section: outside probe Z's clamped one-section GVS rod got 9x
        // its tip's inverse weight, and MuJoCo's contact regulariser, which grows with it, let the
        // rod sink 5.7 radii into a floor. The mass-weighted mean of the points' own inverse weights,
        // used next, is larger than the centre's (the quadratic form is convex) and grew with the
        // sections' count: a 16-section kl rod resting on two cylinders sank 2.45 mm into them, 2.6
        // times its MuJoCo-native chain's 0.94 mm, and a prop under a stiff cantilever carried 29%
        // less than a rigid prop (outside probe AT). Now 1.41 mm (ikl, inextensible like the chain:
        // 0.99 mm; kl's stretch makes its centre of mass more mobile along the rod).
        std::fill(jc.begin(), jc.end(), 0.0);
        std::fill(jrc.begin(), jrc.end(), 0.0);
        mass_points([&](double mi, int node) {
          cross_section_jacobian_world(s, sd, r, si, rm.nodes[node].X, rd.g[node].u, jp.data(), jr.data());
          mju_addToScl(jc.data(), jp.data(), mi, 3 * nv);
          mju_addToScl(jrc.data(), jr.data(), mi, 3 * nv);
          mass += mi;
        });
        mju_scl(jp.data(), jc.data(), 1.0 / mass, 3 * nv);
        mju_scl(jr.data(), jrc.data(), 1.0 / mass, 3 * nv);
        inverse_weights(tr);
      }
    } else {
      mj_jacBodyCom(m, sd.d, jp.data(), jr.data(), b);
      inverse_weights(tr);
    }
    m->body_invweight0[2 * b] = tr[0];
    m->body_invweight0[2 * b + 1] = tr[1];
  }
  for (int t = 0; t < m->ntendon; ++t) {
    const mjtNum* Jt = tendon_jacobian_row(s, sd, t);
    mj_solveM(m, sd.d, x.data(), Jt, 1);
    m->tendon_invweight0[t] = mju_dot(Jt, x.data(), nv);
  }
  // actuator_acc0 = |M^-1 moment| at qpos0: a muscle without a force (force="-1") pulls with
  // F0 = scale / acc0 (mju_muscleGain, at run time)
  for (int i = 0; i < m->nu; ++i) {
    mj_solveM(m, sd.d, x.data(), sd.d->actuator_moment + i * nv, 1);
    m->actuator_acc0[i] = mju_norm(x.data(), nv);
  }
  // the mean diagonal inertia at qpos0 (setStat's): the constraint solvers scale their tolerances
  // by it, and the proxies' placeholder unit masses and armatures had made it about 1
  if (nv > 0) {
    double trace = 0.0;
    for (int i = 0; i < nv; ++i) trace += sd.d->qM[m->dof_Madr[i]];
    m->stat.meaninertia = trace / nv;
  }
}

namespace {
// Whether a body with mass or another rod's base lies below the rod's proxies (its subtree:
// [base_body + 1, below_end)), or a body below it with a joint of its own (the constraint rows'
// velocity products on it read the d->cvel and d->cdof_dot of its chain: riding_body_velocity_product):
// they read its cdof_dot (RodBinding::cdof_dot_read).
bool mass_or_rod_below(const Scene& s, const RodBinding& rb) {
  const mjModel* m = s.m;
  for (int b = rb.base_body + 1; b < rb.below_end; ++b)
    if (m->body_mass[b] > 0 || m->body_inertia[3 * b] > 0 || m->body_inertia[3 * b + 1] > 0 ||
        m->body_inertia[3 * b + 2] > 0 || (b >= rb.below_begin && m->body_dofnum[b] > 0))
      return true;
  for (const RodBinding& other : s.rods)
    if (other.base_body > rb.base_body && other.base_body < rb.below_end) return true;
  return false;
}

// Whether the bodies below rod rb can be its rigid payload (RodBinding::payload): none has a dof, and
// no rod hangs below it.
bool rigid_payload(const Scene& s, const RodBinding& rb) {
  for (int b = rb.below_begin; b < rb.below_end; ++b)
    if (s.m->body_dofnum[b] > 0) return false;
  for (const RodBinding& other : s.rods)
    if (other.base_body > rb.base_body && other.base_body < rb.below_end) return false;
  return true;
}

// Whether a connect or weld names one of rod rb's bodies or a body below it: the velocity product of
// its rows (patch_equality_references) reads the d->cvel and d->cdof_dot of that body's chain.
bool equality_on_rod(const mjModel* m, const RodBinding& rb) {
  for (int e = 0; e < m->neq; ++e)
    if (m->eq_type[e] == mjEQ_CONNECT || m->eq_type[e] == mjEQ_WELD)
      for (int b : {m->eq_obj1id[e], m->eq_obj2id[e]})
        if (b > rb.base_body && b < rb.below_end) return true;
  return false;
}

// RodBinding::cdof_dot_read and payload, and Scene::velocity_skip and payload_body, from the
// model's sensors, bodies and body masses.
void decide_velocity_skips(const Scene& s) {
  // acceleration sensors read every cdof_dot (mj_rnePostConstraint; whatever the sensor flags say now)
  const bool acceleration_sensors = has_sensor_from(s.m, mjSTAGE_ACC);
  const bool velocity_sensors = has_sensor_from(s.m, mjSTAGE_VEL);
  s.payload_body.assign(s.m->nbody, 0);
  for (const RodBinding& rb : s.rods) {
    rb.massless_below = !mass_or_rod_below(s, rb);
    const bool equality = equality_on_rod(s.m, rb);
    rb.payload = !velocity_sensors && !equality && !rb.massless_below && rigid_payload(s, rb);
    rb.cdof_dot_read = acceleration_sensors || equality || !(rb.massless_below || rb.payload);
    if (rb.payload)
      for (int b = rb.below_begin; b < rb.below_end; ++b) s.payload_body[b] = 1;
  }
  s.velocity_skip.assign(s.m->nbody, 0);
  if (!has_sensor_from(s.m, mjSTAGE_VEL))  // sensors of velocities or accelerations read cvel, cdof_dot
    for (const RodBinding& rb : s.rods)
      if (!rb.cdof_dot_read)
        for (int b = rb.base_body + 1; b < rb.below_end; ++b) s.velocity_skip[b] = 1;
}

// The skips decided at load stand while the bodies below the rods that skip them stay massless; a
// mass given to one since (from C, between steps) is found here, at the cost of a look at those
// bodies' masses, and the skips are decided again: its weight and inertia then count as if the
// model had given it.
void refresh_velocity_skips(const Scene& s) {
  for (const RodBinding& rb : s.rods)
    if (rb.massless_below && mass_or_rod_below(s, rb)) {
      decide_velocity_skips(s);
      return;
    }
}
}  // namespace

// Whether mj_collision (MuJoCo 2.2.2) can ever report a contact in model m, whatever its contact
// flags (they may change between steps; mj_collision reads them itself): an explicit <pair>, or
// two geoms on bodies of different weld groups (same weld group: never tested) whose masks pass
// (contype1 & conaffinity2) || (contype2 & conaffinity1), on a body pair that no <exclude> names.
// Conservative: the masks are united per body, and MuJoCo's parent-child filter is not applied
// (a pair it drops still counts).
bool scene_may_collide(const mjModel* m) {
  if (m->npair > 0) return true;
  // per body, the union of its geoms' masks (a body pair whose unions pass may hold a geom pair
  // that passes: conservative, and linear in the geoms)
  std::vector<int> contype(m->nbody, 0), conaffinity(m->nbody, 0), active;
  for (int g = 0; g < m->ngeom; ++g) {
    contype[m->geom_bodyid[g]] |= m->geom_contype[g];
    conaffinity[m->geom_bodyid[g]] |= m->geom_conaffinity[g];
  }
  for (int b = 0; b < m->nbody; ++b)
    if (contype[b] || conaffinity[b]) active.push_back(b);
  // exclude_signature: (body1 + 1) << 16 + body2 + 1
  const std::unordered_set<int> excluded(m->exclude_signature, m->exclude_signature + m->nexclude);
  for (size_t i = 0; i < active.size(); ++i)
    for (size_t j = i + 1; j < active.size(); ++j) {
      const int b1 = active[i], b2 = active[j];
      if (!((contype[b1] & conaffinity[b2]) || (contype[b2] & conaffinity[b1]))) continue;
      if (m->body_weldid[b1] == m->body_weldid[b2]) continue;
      if (!excluded.count(((b1 + 1) << 16) + b2 + 1) && !excluded.count(((b2 + 1) << 16) + b1 + 1)) return true;
    }
  return false;
}

bool scene_may_have_events(const mjModel* m, bool may_collide) {
  if (may_collide) return true;
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_limited[j]) return true;
  for (int t = 0; t < m->ntendon; ++t)
    if (m->tendon_limited[t] || m->tendon_frictionloss[t] > 0) return true;
  for (int i = 0; i < m->nv; ++i)
    if (m->dof_frictionloss[i] > 0) return true;
  return false;
}

namespace {

// Keyframes with a non-finite value (MuJoCo 2.2.2 reads "nan" with only a warning): the run from
// such a key would report a NaN time or diverge without saying where the NaN came from.
void check_keyframes(const Preprocessed& pre, const mjModel* m) {
  for (int k = 0; k < m->nkey; ++k) {
    const struct {
      const char* name;
      const mjtNum* v;
      int n;
    } fields[] = {{"time", m->key_time + k, 1},           {"qpos", m->key_qpos + k * m->nq, m->nq},
                  {"qvel", m->key_qvel + k * m->nv, m->nv}, {"act", m->key_act + k * m->na, m->na},
                  {"ctrl", m->key_ctrl + k * m->nu, m->nu}, {"mpos", m->key_mpos + 3 * k * m->nmocap, 3 * m->nmocap},
                  {"mquat", m->key_mquat + 4 * k * m->nmocap, 4 * m->nmocap}};
    for (const auto& f : fields)
      if (!std::all_of(f.v, f.v + f.n, [](mjtNum x) { return std::isfinite(x); })) {
        const SourceLine where = k < static_cast<int>(pre.key_origin.size()) ? pre.key_origin[k] : SourceLine{pre.path, 0};
        throw LoadError(where.file, where.line, "<key>: attribute '" + std::string(f.name) + "' holds a value that is not a finite number");
      }
  }
}

// A muscle acting on a rod whose lengthrange MuJoCo's compiler computed itself (by simulating the
// compiled model, in which the rods are massless placeholders without elasticity): not the rod's
// range, refused at the actuator's line.
void check_muscle_lengthranges(const Preprocessed& pre, const Scene& s) {
  const mjModel* m = s.m;
  std::unique_ptr<SceneData> sd;
  for (int i = 0; i < m->nu; ++i) {
    const bool muscle = m->actuator_gaintype[i] == mjGAIN_MUSCLE || m->actuator_biastype[i] == mjBIAS_MUSCLE;
    if (!muscle || i >= static_cast<int>(pre.actuator_lengthrange_given.size()) || pre.actuator_lengthrange_given[i])
      continue;
    if (!sd) {  // the moments at qpos0
      sd = std::make_unique<SceneData>(s);
      mju_copy(sd->d->qpos, m->qpos0, m->nq);
      fwd_position(s, *sd);
    }
    for (const RodBinding& rb : s.rods)
      for (int k = 0; k < rb.model.nv; ++k)
        if (sd->d->actuator_moment[i * m->nv + rb.dof0 + k] != 0) {
          const SourceLine& where = pre.actuator_origin[i];
          throw LoadError(where.file, where.line,
                          "<" + std::string(m->actuator_gaintype[i] == mjGAIN_MUSCLE ? "muscle" : "general") +
                              ">: a muscle acting on rod '" + rb.decl.name +
                              "' needs an explicit lengthrange (MuJoCo computes one by simulating the compiled "
                              "model, in which the rods are massless placeholders)");
        }
  }
}

std::unique_ptr<Scene> compile(const Preprocessed& pre) {
  auto s = std::make_unique<Scene>();
  s->path = pre.path;
  s->load_warnings = pre.warnings;
  s->m = compile_xml(pre);
  check_keyframes(pre, s->m);
  for (const auto& decl : pre.rods) s->rods.push_back(bind_rod(s->m, decl));
  std::sort(s->rods.begin(), s->rods.end(),
            [](const RodBinding& a, const RodBinding& b) { return a.base_body < b.base_body; });
  strip_proxies(s->m, s->rods);
  s->geom_rod.assign(s->m->ngeom, -1);
  s->geom_index.assign(s->m->ngeom, -1);
  s->site_rod.assign(s->m->nsite, -1);
  s->site_index.assign(s->m->nsite, -1);
  s->site_section.assign(s->m->nsite, -1);
  s->dof_strain.assign(s->m->nv, 0);
  for (const RodBinding& rb : s->rods) std::fill_n(s->dof_strain.begin() + rb.dof0, rb.model.nv, 1);
  for (size_t r = 0; r < s->rods.size(); ++r)
    for (size_t k = 0; k < s->rods[r].site_id.size(); ++k) {
      // the section whose proxy (or helper: none carry sites) holds the site. A site on the rod's
      // base body ("<rod>/base") is not one of them: it rides rigidly with that body, which MuJoCo
      // moves itself, so no patch corrects it (the rod still places it: RodBinding::site_fixed)
      const int body = s->m->site_bodyid[s->rods[r].site_id[k]];
      const auto& pb = s->rods[r].proxy_body;
      const auto it = std::find(pb.begin(), pb.end(), body);
      if (it == pb.end()) continue;
      s->site_rod[s->rods[r].site_id[k]] = static_cast<int>(r);
      s->site_index[s->rods[r].site_id[k]] = static_cast<int>(k);
      s->site_section[s->rods[r].site_id[k]] = static_cast<int>(it - pb.begin());
    }
  // sites on a spatial tendon's path, and the first of them at each abscissa and section
  // (RodBinding::site_point)
  std::vector<char> on_tendon(s->m->nsite, 0);
  for (int w = 0; w < s->m->nwrap; ++w)
    if (s->m->wrap_type[w] == mjWRAP_SITE) on_tendon[s->m->wrap_objid[w]] = 1;
  for (auto& rb : s->rods) {
    rb.site_point.assign(rb.site_id.size(), -1);
    for (size_t k = 0; k < rb.site_id.size(); ++k) {
      if (!on_tendon[rb.site_id[k]] || rb.site_fixed[k].fixed) continue;
      rb.site_point[k] = static_cast<int>(k);
      for (size_t j = 0; j < k; ++j)
        if (rb.site_point[j] == static_cast<int>(j) && rb.decl.sites[j].X == rb.decl.sites[k].X &&
            s->site_section[rb.site_id[j]] == s->site_section[rb.site_id[k]]) {
          rb.site_point[k] = static_cast<int>(j);
          break;
        }
    }
  }
  for (size_t r = 0; r < s->rods.size(); ++r)
    for (size_t k = 0; k < s->rods[r].geom_id.size(); ++k) {
      s->geom_rod[s->rods[r].geom_id[k]] = static_cast<int>(r);
      s->geom_index[s->rods[r].geom_id[k]] = static_cast<int>(k);
    }
  s->may_collide = scene_may_collide(s->m);
  s->may_have_events = scene_may_have_events(s->m, s->may_collide);
  // explicit pairs, once: which geoms they name, and the table patch_contact_distances searches
  std::vector<char> in_pair(s->m->ngeom, 0);
  for (int k = 0; k < s->m->npair; ++k) {
    const long long g1 = s->m->pair_geom1[k], g2 = s->m->pair_geom2[k], n = s->m->ngeom;
    in_pair[g1] = in_pair[g2] = 1;
    s->pair_by_geoms.emplace_back(g1 * n + g2, k);
    if (g1 != g2) s->pair_by_geoms.emplace_back(g2 * n + g1, k);
  }
  std::sort(s->pair_by_geoms.begin(), s->pair_by_geoms.end());  // a geom pair's first <pair> first, as the search found it
  for (RodBinding& rb : s->rods) {
    const size_t n = rb.geom_id.size();
    rb.geom_sagging.assign(n, 0);
    rb.geom_margin0.assign(n, 0.0);
    rb.geom_gap0.assign(n, 0.0);
    for (size_t k = 0; k < n; ++k) {
      const int id = rb.geom_id[k];
      rb.geom_margin0[k] = s->m->geom_margin[id];
      rb.geom_gap0[k] = s->m->geom_gap[id];
      rb.geom_sagging[k] = s->may_collide && !rb.geom_fixed[k].fixed &&
                           (s->m->geom_contype[id] != 0 || s->m->geom_conaffinity[id] != 0 || in_pair[id]);
      if (rb.geom_sagging[k]) s->sagging_geoms.push_back(id);
    }
  }
  setup_sagging_contacts(*s);
  s->body_by_rod.assign(s->m->nbody, 0);
  for (const RodBinding& rb : s->rods)
    for (int b = rb.base_body + 1; b < rb.below_end; ++b) s->body_by_rod[b] = 1;
  setup_riding_frames(*s);
  decide_velocity_skips(*s);
  setup_site_readers(pre, *s);  // sensors, transmissions, tracking that read rods (scene_sites.hpp)
  setup_fluid(*s);  // fluid hook: may switch MuJoCo's own fluid off (scene_fluid.hpp)
  if (!s->rods.empty()) {
    SceneData at_qpos0(*s);
    recompute_qpos0_constants(*s, at_qpos0);
    warn_overlapping_rods(*s, at_qpos0);  // (before anything else moves the rod capsules' sizes)
    warn_pyramidal_torsion(*s);
    warn_frictionless_pyramid(*s);
    warn_one_capsule_sections(*s);
    warn_gvs_capsules(*s);
    avoid_sparse_newton_on_small_pivots(*s, at_qpos0);
    check_muscle_lengthranges(pre, *s);
  }
  s->integrator = s->rods.empty() ? Integrator::Euler : Integrator::Implicit;
  if (s->m->opt.integrator == mjINT_RK4) s->integrator = Integrator::RK4;
  if (s->m->opt.integrator == mjINT_IMPLICIT) s->integrator = Integrator::Implicit;
  // <custom><text name="cosserat:integrator" data="NAME"/> (a known name: the preprocessor checked)
  if (const int t = mj_name2id(s->m, mjOBJ_TEXT, "cosserat:integrator"); t >= 0)
    if (const auto in = integrator_from_name(s->m->text_data + s->m->text_adr[t])) s->integrator = *in;
  // <custom><numeric name="cosserat:step_tol" data="TOL"/> (one positive number: checked)
  if (const int n = mj_name2id(s->m, mjOBJ_NUMERIC, "cosserat:step_tol"); n >= 0)
    s->step_tol = s->m->numeric_data[s->m->numeric_adr[n]];
  return s;
}

}  // namespace

std::unique_ptr<Scene> load_scene(const std::string& path) { return compile(preprocess_file(path)); }

bool implicit_is_mujocos(const Scene& s) { return s.rods.empty() && !s.fluid.active; }

bool has_joint_damping(const mjModel* m) {
  for (int i = 0; i < m->nv; ++i)
    if (m->dof_damping[i] > 0) return true;
  for (int t = 0; t < m->ntendon; ++t)
    if (m->tendon_damping[t] > 0) return true;
  return false;
}

std::unique_ptr<Scene> load_scene_string(const std::string& xml, const std::string& path) {
  return compile(preprocess_string(xml, path));
}

std::string collapse_warning(const Scene& s, const SceneData& sd) {
  const SceneData::Compression& c = sd.compression;
  if (!(c.stretch <= kCollapsedStretch)) return {};
  char b[640];
  std::snprintf(b, sizeof b,
                c.diverged_step ? "section %d of rod '%s' was compressed to %.3g of its length within the step from t = "
                                  "%.6g s that diverged: the linear constitutive law does not resist a section's "
                                  "collapse (if smaller steps crush it too, the load is more than the rod bears: %s)"
                                : "section %d of rod '%s' was compressed to %.3g of its length (t = %.6g s): the linear "
                                  "constitutive law does not resist a section's collapse, and the motion from there on "
                                  "is not physical (%s)",
                c.section, s.rods[c.rod].decl.name.c_str(), c.stretch, c.time, "a stiffer or damped rod, or a smaller load");
  return b;
}

int full_buffer_count(const mjData* d) { return d->warning[mjWARN_CONTACTFULL].number + d->warning[mjWARN_CNSTRFULL].number; }

std::string raise_buffers_advice(const mjModel* m) {
  return "raise <size nconmax=\"...\" njmax=\"...\"> (now " + std::to_string(m->nconmax) + " and " + std::to_string(m->njmax) +
         "; a capsule on a plane makes 1-2 contacts of 1-6 constraint rows each)";
}

std::string divergence_hint(const Scene& s, const SceneData& sd, Integrator in, Vocabulary words) {
  const bool cli = words == Vocabulary::CommandLine;
  const std::string smaller_step = cli ? "a smaller --timestep" : "a smaller time step (m->opt.timestep)";
  const std::string implicit = cli ? "--integrator implicit" : "Integrator::Implicit";
  const std::string collapse = collapse_warning(s, sd);
  // an explicit step that is too large crushes sections on its way to blowing up: the step is the
  // cause there (outside probe Y: rk4 on a stiff rod at 0.2 ms was told to stiffen the rod)
  const bool explicit_step = in == Integrator::Euler || in == Integrator::RK4 || in == Integrator::Rosenbrock;
  if (!collapse.empty() && !explicit_step && !sd.compression.diverged_step) return "after a rod section collapsed: " + collapse;
  std::string hint;
  if (in == Integrator::Euler || in == Integrator::RK4)
    hint = "try " + smaller_step + ", or " + implicit +
           ": explicit integrators need steps below the stiffest mode's period";
  else if (in == Integrator::Rosenbrock)
    hint = "try " + smaller_step + ", or " + implicit +
           ": the rosenbrock step treats gravity, Coriolis and geometric stiffness explicitly";
  else if (s.newton_for(in) == 0)
    // backward Euler with the matrix taken at each step's first iterate: 3-5 times faster where the
    // corrections fail with the start's (outside probe AP's soft helical spring and whipping rod);
    // not offered for the trapezoidal rule, whose split steps can keep its energy bounded
    hint = std::string("try ") +
           (in == Integrator::Implicit ? (cli ? "--newton 10 --newton-refresh" : "Scene::newton_iterations = 10 with Scene::newton_refresh")
                                       : (cli ? "--newton 10" : "Scene::newton_iterations = 10")) +
           " (gravity, Coriolis and geometric stiffness are explicit in the linearised step) or " + smaller_step;
  else
    hint = "try " + smaller_step + ", or more " + (cli ? "--newton corrections" : "Newton corrections (Scene::newton_iterations)");
  if (!collapse.empty())
    hint += std::string("; a rod section also collapsed on the way") +
            (explicit_step ? ", as under any unstable explicit step" : "") + ": " + collapse;
  // MuJoCo 2.2.2's sparse Newton solver stops at a pivot below 1e-15 (the loader moves scenes whose
  // rods' inertias lie there at qpos0 to dense Jacobians, with a warning; a blowing-up state gets
  // there too)
  if (sd.warning.find("Rank-defficient Hessian") != std::string::npos)
    hint = "MuJoCo's sparse Newton constraint solver stops where a pivot of the inertia falls below 1e-15 (a thin, "
           "short rod section in SI units, or a state already blowing up): <option jacobian=\"dense\"/> or "
           "solver=\"CG\" does not stop there; else " + hint;
  // contacts or constraint rows dropped for want of room come first: bodies then pass through each other
  const mjData* d = sd.d;
  const mjModel* m = s.m;
  // (unless they first filled in the last steps before the divergence, under 20 and the last 5% of
  // the run, as a blowing-up state makes contacts everywhere: outside probe CB's pile of rods gained energy for 0.35 s with its
  // buffers a quarter full, filled them in its last steps, and was told to raise nconmax first)
  const int full = full_buffer_count(d);
  const std::string raise = raise_buffers_advice(m);
  // (not yet recorded: they filled inside the diverging step; outside probe CE's gripper under rk4
  // blew up in its first step and was told to raise nconmax first)
  const double full_at = std::isnan(sd.buffers_full_at) ? d->time : sd.buffers_full_at;
  const double steps_before = (d->time - full_at) / m->opt.timestep;
  if (full > 0 && steps_before < 20 && d->time - full_at <= 0.05 * (d->time - sd.run_start))
    hint += "; MuJoCo's contact buffers also filled (" + std::to_string(full) + " times), first " +
            std::to_string(std::max(0L, std::lround(steps_before))) +
            " steps before the divergence, likely as the state blew up; if contacts were dropped before that, " + raise;
  else if (full > 0)
    hint = "MuJoCo's contact buffers were full " + std::to_string(full) + " times and contacts were dropped: " + raise +
           "; else " + hint;
  return hint;
}

void reset(const Scene& s, SceneData& sd) {
  mj_resetData(s.m, sd.d);
  sd.status = Status::Ok;
  sd.warning.clear();
  sd.compression = {};
  sd.last_step_end = -std::numeric_limits<double>::infinity();
  sd.buffers_full_at = std::numeric_limits<double>::quiet_NaN();
  sd.run_start = std::numeric_limits<double>::quiet_NaN();
  sd.adapt.valid = false;
  sd.adapt.level = 0;
}

// ------------------------------------------------------------------------------ integrators --

namespace {

// Advance qvel, qpos, act and time with the accelerations in d->qacc exactly as MuJoCo's Euler
// does, without its implicit joint damping (already folded into qacc by the caller).
void advance_with_qacc(const Scene& s, SceneData& sd) {
  mjModel* m = s.m;
  std::vector<mjtNum>& damping = sd.tmp_nv;
  mju_copy(damping.data(), m->dof_damping, m->nv);
  mju_zero(m->dof_damping, m->nv);
  mj_Euler(m, sd.d);
  mju_copy(m->dof_damping, damping.data(), m->nv);
}

// Derivatives of an actuator's scalar force (MuJoCo 2.2.2: force = gain * input + bias with gain
// and bias affine in length and velocity) with respect to its length and its velocity.
struct ForceDerivatives {
  double length = 0.0, velocity = 0.0;
};
ForceDerivatives actuator_force_derivatives(const mjModel* m, const mjData* d, int a) {
  ForceDerivatives df;
  if (m->actuator_gaintype[a] == mjGAIN_AFFINE) {
    const double input = m->actuator_dyntype[a] == mjDYN_NONE ? d->ctrl[a] : d->act[a - (m->nu - m->na)];
    df.length += m->actuator_gainprm[mjNGAIN * a + 1] * input;
    df.velocity += m->actuator_gainprm[mjNGAIN * a + 2] * input;
  }
  if (m->actuator_biastype[a] == mjBIAS_AFFINE) {
    df.length += m->actuator_biasprm[mjNBIAS * a + 1];
    df.velocity += m->actuator_biasprm[mjNBIAS * a + 2];
  }
  return df;
}

// The nonzero dofs of a row u (nv values) whose deepest nonzero dof is `last` and whose nonzeros
// number `count`: into nz, deepest first, each an ancestor (dof_parentid) of the one before, and
// their number; -1 where two of them lie on different branches of the tree (qM's pattern cannot
// hold their product).
int branch_dofs(const mjModel* m, const mjtNum* u, int last, int count, std::vector<int>& nz) {
  int n = 0;
  for (int k = last; k >= 0; k = m->dof_parentid[k])
    if (u[k] != 0.0) nz[n++] = k;
  return n == count ? n : -1;
}

// A += c v v' in qM's tree pattern for a row with values val(a) at the dofs nz[0..n) of one branch,
// deepest first (branch_dofs): qM's row of a dof holds the dof and its ancestors in chain order.
template <class Val>
void add_outer_on_branch(const mjModel* m, mjtNum* A, const int* nz, int n, double c, Val&& val) {
  for (int a = 0; a < n; ++a) {
    int adr = m->dof_Madr[nz[a]], b = a;
    for (int k = nz[a]; k >= 0 && b < n; k = m->dof_parentid[k], ++adr)
      if (k == nz[b]) A[adr] += c * val(a) * val(b++);
  }
}

// A += c u u' for u of size nv (a tendon's or an actuator's row), in qM's tree pattern; nothing
// and false where two of u's dofs are on different branches (the pattern cannot hold the term).
bool add_outer_in_tree(const mjModel* m, mjtNum* A, const mjtNum* u, double c, std::vector<int>& nz) {
  int last = -1, count = 0;
  for (int i = 0; i < m->nv; ++i)
    if (u[i] != 0.0) last = i, ++count;
  const int n = branch_dofs(m, u, last, count, nz);
  if (n < 0) return false;
  add_outer_on_branch(m, A, nz.data(), n, c, [&](int a) { return u[nz[a]]; });
  return true;
}

// Which active rows (in MuJoCo's quadratic state, on rods) factor_implicit freezes with its matrix
// (add_constraint_terms): none; every row (the Newton schemes); the equality rows; or the equality
// rows and the friction rows of elliptic cones, and should a friction row tie two branches of the
// tree, the equality rows alone (the linearised steps).
enum class FrozenRows { None, All, Equalities, EqualitiesAndEllipticFriction };

// Whether efc row i is a friction row of an elliptic cone (a contact's rows after its normal one).
bool elliptic_friction_row(const mjData* d, int i) {
  return d->efc_type[i] == mjCNSTR_CONTACT_ELLIPTIC && i > 0 && d->efc_type[i - 1] == mjCNSTR_CONTACT_ELLIPTIC &&
         d->efc_id[i - 1] == d->efc_id[i];
}

// Whether the Woodbury rows have room for one more (sd.W_*, grown where a scene's contacts need
// more than SceneData made room for, up to nv rows more than its tendons, actuators and equalities).
bool room_for_woodbury_row(const mjModel* m, SceneData& sd) {
  const size_t have = sd.W_coef.size(), nv = static_cast<size_t>(m->nv);
  if (static_cast<size_t>(sd.W_nrows) < have) return true;
  const size_t cap = woodbury_rows_of_elements(m) + nv;
  if (have >= cap) return false;
  const size_t r = std::min(cap, std::max<size_t>(2 * have, kLoopContactRows));
  sd.W_rows.resize(r * nv, 0.0);
  sd.W_Z.resize(r * nv, 0.0);
  sd.W_coef.resize(r, 0.0);
  sd.W_S.resize(r * r, 0.0);
  sd.W_t.resize(r, 0.0);
  return true;
}

// The Newton schemes' terms of the constraint rows. A row in MuJoCo's quadratic state (equality
// rows, active limits, pyramidal contact rows) pulls with -D (J a + B J v + K I r): it adds D J'J to
// the mass the iteration sees, B D J'J to its damping and K I D J'J to its stiffness, so
//   A += D (1 + hD B + hK K I) J'J   (in qM's tree pattern),
// and the residual is weighted with M + sum D J'J (add_constraint_mass). The rows are those of the
// matrix's evaluation, kept with it (SceneData::frozen_*), so that the correction sees the same
// terms as the matrix while contacts come and go between iterates (taken from each iterate's rows
// instead, the corrections grew on impacts and split more steps). Taken: the rows acting on a rod's
// strain dofs (rows on rigid bodies alone keep the previous iteration; with them the shipped
// octopus arm's object on its table took twice the corrections). Elliptic cones' rows (their
// state is the cone's) stay out. A row that ties two branches of the tree, which qM's pattern
// cannot hold, is a Woodbury row (sd.W_rows): an equality closing a loop of rods (two rods
// clamped to two walls and welded tip to tip, a parallel robot's platform; the linearised steps
// too: explicit, such rows had pumped energy into every loop at any step, outside probe BY: a
// tapped loop from 1e-4 J to 0.09 J in 5 s, a damped parallel robot released from rest to
// 10.8 J, all without a warning), and under the Newton schemes any row but an elliptic cone's, a
// rod pressing a free object (without it, a stiffly welded loop took twice the corrections, and a box on a free wire
// split 91 of 20 steps: none now). Should the Woodbury rows be full (room_for_woodbury_row), the
// terms would be partial: none are taken. Without these terms a wire of short sections lying on
// a floor split every step (outside probe AA: 300 corrections and 15 splits per 1 ms step under
// trapezoidal, midpoint and genalpha; now 27 and 1).
void add_constraint_terms(const mjModel* m, const char* strain, SceneData& sd, mjtNum* A, double hD, double hK,
                          FrozenRows which) {
  const bool equalities_only = which == FrozenRows::Equalities;
  const mjData* d = sd.d;
  const int nv = m->nv;
  const bool sparse = mj_isSparse(m);
  std::vector<int>& nz = sd.tree_nz;
  mjtNum* row = sd.frozen_row.data();
  const int w0 = sd.W_nrows;  // the Woodbury rows of tendons and actuators (add_row_terms)
  sd.frozen_D.clear();
  sd.frozen_c.clear();
  sd.frozen_kI.clear();
  sd.frozen_val.clear();
  sd.frozen_dof.clear();
  sd.frozen_across.clear();
  sd.frozen_begin.assign(1, 0);
  for (int i = 0; i < d->nefc; ++i) {
    if (d->efc_state[i] != mjCNSTRSTATE_QUADRATIC || !(d->efc_D[i] > 0)) continue;
    if (equalities_only && d->efc_type[i] != mjCNSTR_EQUALITY) continue;
    // the linearised steps hold the friction rows of elliptic cones, not the normal rows nor the
    // pyramid's (outside probe BO: held, those damped a soft rod's bounce from 62 to 14 mm and
    // braked, even blew up, a rod rolling on a pyramidal cone), nor the limits (held, they settled
    // outside probe BU's stiff rod hanging from a taut tendon limit, which bounces on it for ever,
    // but took a rod hitting its strain limits in motion 48 mm off its course, against 5 mm: probe BW)
    if (which == FrozenRows::EqualitiesAndEllipticFriction && d->efc_type[i] != mjCNSTR_EQUALITY &&
        !elliptic_friction_row(d, i))
      continue;
    const mjtNum* u = sparse ? row : d->efc_J + static_cast<size_t>(i) * nv;
    int last = -1, count = 0;
    if (sparse) {
      for (int k = d->efc_J_rowadr[i]; k < d->efc_J_rowadr[i] + d->efc_J_rownnz[i]; ++k)
        if (d->efc_J[k] != 0.0) {
          row[d->efc_J_colind[k]] = d->efc_J[k];
          last = std::max(last, d->efc_J_colind[k]);
          ++count;
        }
    } else {
      for (int k = 0; k < nv; ++k)
        if (u[k] != 0.0) last = k, ++count;
    }
    int n = branch_dofs(m, u, last, count, nz);
    bool across = n < 0;
    // a row closing a loop: a Woodbury row (the linearised steps: equality rows only)
    // (an elliptic cone's rows, which leave its quadratic zone for the cone's as the iterate moves,
    // stay out: held across two branches, they made the shipped octopus arm's object under
    // `implicit --newton 10` take 50.8 corrections a step where it took 32.9, re-check probe CG)
    const bool woodbury = across &&
                          (d->efc_type[i] == mjCNSTR_EQUALITY ||
                           (which == FrozenRows::All && d->efc_type[i] != mjCNSTR_CONTACT_ELLIPTIC)) &&
                          room_for_woodbury_row(m, sd);
    if (woodbury) {
      n = 0;
      for (int k = 0; k <= last; ++k)
        if (u[k] != 0.0) nz[n++] = k;
      across = false;
    }
    bool on_rod = false;  // (rows on rigid bodies only keep MuJoCo's treatment)
    for (int a = 0; a < n && !on_rod; ++a) on_rod = strain[nz[a]];
    if (!across && on_rod) {
      const mjtNum* kbip = d->efc_KBIP + 4 * i;
      sd.frozen_D.push_back(d->efc_D[i]);
      sd.frozen_c.push_back(d->efc_D[i] * (1.0 + hD * kbip[1] + hK * kbip[0] * kbip[2]));
      sd.frozen_kI.push_back(d->efc_D[i] * kbip[0] * kbip[2]);
      sd.frozen_across.push_back(woodbury);
      for (int a = 0; a < n; ++a) {
        sd.frozen_dof.push_back(nz[a]);
        sd.frozen_val.push_back(u[nz[a]]);
      }
      sd.frozen_begin.push_back(static_cast<int>(sd.frozen_dof.size()));
      if (woodbury) {
        std::copy(u, u + nv, sd.W_rows.begin() + static_cast<size_t>(sd.W_nrows) * nv);
        sd.W_coef[sd.W_nrows++] = sd.frozen_c.back();
      }
    }
    if (sparse)
      for (int k = d->efc_J_rowadr[i]; k < d->efc_J_rowadr[i] + d->efc_J_rownnz[i]; ++k) row[d->efc_J_colind[k]] = 0.0;
    if (across) {  // a row across two branches: the terms would be partial, none are taken
      sd.frozen_D.clear();
      sd.W_nrows = w0;
      if (which == FrozenRows::EqualitiesAndEllipticFriction)
        add_constraint_terms(m, strain, sd, A, hD, hK, FrozenRows::Equalities);
      return;
    }
  }
  for (size_t r = 0; r < sd.frozen_D.size(); ++r) {
    if (sd.frozen_across[r]) continue;  // (a Woodbury row)
    const int b0 = sd.frozen_begin[r];
    add_outer_on_branch(m, A, sd.frozen_dof.data() + b0, sd.frozen_begin[r + 1] - b0, sd.frozen_c[r],
                        [&](int a) { return sd.frozen_val[b0 + a]; });
  }
}

// The frozen rows held by the Woodbury rows, removed (factor_woodbury dropped its correction).
void drop_woodbury_rows(SceneData& sd) {
  size_t kept = 0, at = 0;
  for (size_t r = 0; r < sd.frozen_D.size(); ++r) {
    const int b0 = sd.frozen_begin[r], b1 = sd.frozen_begin[r + 1];
    if (sd.frozen_across[r]) continue;
    sd.frozen_D[kept] = sd.frozen_D[r], sd.frozen_c[kept] = sd.frozen_c[r], sd.frozen_kI[kept] = sd.frozen_kI[r];
    sd.frozen_across[kept] = 0;
    for (int k = b0; k < b1; ++k) sd.frozen_dof[at + (k - b0)] = sd.frozen_dof[k], sd.frozen_val[at + (k - b0)] = sd.frozen_val[k];
    sd.frozen_begin[kept] = static_cast<int>(at);
    at += b1 - b0;
    ++kept;
  }
  sd.frozen_D.resize(kept), sd.frozen_c.resize(kept), sd.frozen_kI.resize(kept), sd.frozen_across.resize(kept);
  sd.frozen_begin.resize(kept + 1);
  sd.frozen_begin[kept] = static_cast<int>(at);
  sd.frozen_dof.resize(at), sd.frozen_val.resize(at);
}

// y += scale sum coef[r] J_r'(J_r x) over the rows add_constraint_terms froze with the matrix
// (coef: one of its per-row arrays, frozen_D or frozen_kI).
void add_frozen_rows(const SceneData& sd, const std::vector<mjtNum>& coef, const mjtNum* x, mjtNum* y,
                     double scale = 1.0) {
  for (size_t r = 0; r < sd.frozen_D.size(); ++r) {
    double jx = 0.0;
    for (int k = sd.frozen_begin[r]; k < sd.frozen_begin[r + 1]; ++k) jx += sd.frozen_val[k] * x[sd.frozen_dof[k]];
    jx *= scale * coef[r];
    for (int k = sd.frozen_begin[r]; k < sd.frozen_begin[r + 1]; ++k) y[sd.frozen_dof[k]] += sd.frozen_val[k] * jx;
  }
}

// y += sum D J'(J x) over the rows add_constraint_terms froze with the matrix.
void add_constraint_mass(const SceneData& sd, const mjtNum* x, mjtNum* y) { add_frozen_rows(sd, sd.frozen_D, x, y); }

// A += (hD d + hK k) u u' for a row u of size nv (a tendon's Jacobian, an actuator's moment) with
// damping d >= 0 and stiffness k >= 0: in qM's tree pattern where u's dofs lie on one branch, else
// as one row of the low-rank correction solve_implicit applies (sd.W_rows); u is also kept with k
// for subtract_stiffness (sd.K_rows).
void add_row_terms(SceneData& sd, const mjModel* m, mjtNum* A, const mjtNum* u, double d, double k, double hD,
                   double hK) {
  const int nv = m->nv;
  const double c = hD * d + hK * k;
  if (c > 0 && !add_outer_in_tree(m, A, u, c, sd.tree_nz)) {
    std::copy(u, u + nv, sd.W_rows.begin() + static_cast<size_t>(sd.W_nrows) * nv);
    sd.W_coef[sd.W_nrows++] = c;
  }
  if (k > 0) {
    std::copy(u, u + nv, sd.K_rows.begin() + static_cast<size_t>(sd.K_nrows) * nv);
    sd.K_row_coef[sd.K_nrows++] = k;
  }
}

// After A_tree's factorisation: Z = A_tree^-1 U and the Cholesky factor (lower, in place) of
// S = C^-1 + U' Z, symmetric positive definite (C > 0, A_tree positive definite). Should a pivot
// not be positive (round-off on a term far below A's scale) the correction is dropped: those
// terms are then explicit, as before they were taken at all.
void factor_woodbury(const mjModel* m, SceneData& sd) {
  const int nv = m->nv, r = sd.W_nrows;
  if (r == 0) return;
  for (int i = 0; i < r; ++i)
    solve_ldl(m, sd.A_LD.data(), sd.A_LDiagInv.data(), sd.W_Z.data() + i * nv, sd.W_rows.data() + i * nv);
  mjtNum* S = sd.W_S.data();
  for (int i = 0; i < r; ++i)
    for (int j = 0; j <= i; ++j)
      S[i * r + j] = mju_dot(sd.W_rows.data() + i * nv, sd.W_Z.data() + j * nv, nv) + (i == j ? 1.0 / sd.W_coef[i] : 0.0);
  for (int j = 0; j < r; ++j) {  // S = L L' (L in the lower triangle)
    double pivot = S[j * r + j];
    for (int k = 0; k < j; ++k) pivot -= S[j * r + k] * S[j * r + k];
    if (!(pivot > 0)) {
      sd.W_nrows = 0;
      return;
    }
    S[j * r + j] = std::sqrt(pivot);
    for (int i = j + 1; i < r; ++i) {
      double v = S[i * r + j];
      for (int k = 0; k < j; ++k) v -= S[i * r + k] * S[j * r + k];
      S[i * r + j] = v / S[j * r + j];
    }
  }
}

// The implicit step's matrix
//   A = M + cD h D + cK h^2 K,
// D = joint damping + rods' Kelvin-Voigt damping + tendon damping J' d J + actuators' -d force/d
// velocity moment moment' + fluid damping D_f, K = the rods' stiffness + the springs of hinge and
// slide joints (and k I for those of ball and free joints) + actuators' -gear^2 d force/d length
// (position servos) on hinges and slides + tendon springs
// k J' J + actuators' -d force/d length moment moment' on tendons (rods = false: joint damping +
// D_f, K = 0: MuJoCo's Euler with the fluid added to its implicit damping). The tendon and
// actuator terms count only when `rods` (velocity servos such as a flagellar motor are stiff
// dampers, position servos and elastic cables stiff springs); a tendon's or actuator's term whose
// dofs lie on different branches of the tree (which qM's pattern cannot couple) is kept out of
// the tree factor and added by a low-rank (Woodbury) correction (sd.W_rows, solve_implicit).
// Explicit stay negative springs and dampers (a negative joint stiffness, positive feedback of an actuator: in
// A they would make it indefinite, and its factorisation fails at steps of h^2 |K| ~ M), a
// stretched spatial tendon's geometric stiffness k (L - L0) d2L/dq2 (indefinite too), and position
// gains on other transmissions than hinge and slide joints and tendons. Ball and free joints'
// springs enter as k I on their dofs (the rotational part's derivative at the rest orientation).
// (MuJoCo's own implicit integrator, which a rod-free scene runs, takes the
// velocity terms whatever their pattern, and no position terms.) K's diagonal outside the rods
// is kept in sd.joint_K, its outer products in sd.K_rows (subtract_stiffness). Assembled in MuJoCo's sparse qM (K
// and D live inside each section's dof chain, D_f in the kinematic tree's pattern), after
// forward: assembled in sd.A_LD from qM and factorised there as MuJoCo factorises qM
// (factor_ldl), with 1/diag(D) in sd.A_LDiagInv; mjData is not touched.
void factor_implicit(const Scene& s, SceneData& sd, bool rods, double cD, double cK,
                     FrozenRows frozen = FrozenRows::None) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const double h = m->opt.timestep, hD = cD * h, hK = cK * h * h;
  const int nv = m->nv;
  mjtNum* A = sd.A_LD.data();
  std::copy(d->qM, d->qM + m->nM, A);
  for (int i = 0; i < nv; ++i) A[m->dof_Madr[i]] += hD * m->dof_damping[i];
  std::fill(sd.joint_K.begin(), sd.joint_K.end(), 0.0);
  sd.K_nrows = 0;
  sd.W_nrows = 0;
  if (rods && !(m->opt.disableflags & mjDSBL_PASSIVE))  // mj_passive's joint springs
    for (int j = 0; j < m->njnt; ++j) {
      if (!(m->jnt_stiffness[j] > 0)) continue;
      // a ball's (and a free joint's rotational) spring pulls by k times the rotation vector from
      // its rest orientation, whose derivative is the identity there (exact for rotations about a
      // fixed axis); a free joint's translational spring is k times the displacement
      const int n = m->jnt_type[j] == mjJNT_FREE ? 6 : m->jnt_type[j] == mjJNT_BALL ? 3 : 1;
      for (int k = 0; k < n; ++k) sd.joint_K[m->jnt_dofadr[j] + k] += m->jnt_stiffness[j];
    }
  if (rods && !(m->opt.disableflags & mjDSBL_ACTUATION))
    for (int a = 0; a < m->nu; ++a) {
      const int tt = m->actuator_trntype[a];
      // a saturated force does not change with length or velocity
      if (m->actuator_forcelimited[a] && (d->actuator_force[a] <= m->actuator_forcerange[2 * a] ||
                                          d->actuator_force[a] >= m->actuator_forcerange[2 * a + 1]))
        continue;
      const ForceDerivatives df = actuator_force_derivatives(m, d, a);
      const int j = m->actuator_trnid[2 * a];
      if ((tt != mjTRN_JOINT && tt != mjTRN_JOINTINPARENT) ||
          (m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE)) {
        // other transmissions: velocity = moment' qvel (MuJoCo's actuator_velocity), and a
        // tendon's length is moment' q to first order (a site transmission has no length)
        const double damping = df.velocity < 0.0 ? -df.velocity : 0.0;
        const double stiffness = tt == mjTRN_TENDON && df.length < 0.0 ? -df.length : 0.0;
        add_row_terms(sd, m, A, d->actuator_moment + a * nv, damping, stiffness, hD, hK);
        continue;
      }
      const double g = m->actuator_gear[6 * a];
      const int dof = m->jnt_dofadr[j];
      if (df.velocity < 0.0) A[m->dof_Madr[dof]] -= hD * g * g * df.velocity;
      if (df.length < 0.0) sd.joint_K[dof] -= g * g * df.length;
    }
  if (rods && !(m->opt.disableflags & mjDSBL_PASSIVE))  // mj_passive's tendon damping and springs
    for (int t = 0; t < m->ntendon; ++t)
      add_row_terms(sd, m, A, tendon_jacobian_row(s, sd, t), std::max(0.0, m->tendon_damping[t]),
                    std::max(0.0, m->tendon_stiffness[t]), hD, hK);
  for (int i = 0; i < nv; ++i) A[m->dof_Madr[i]] += hK * sd.joint_K[i];
  if (rods)
    for (const auto& rb : s.rods)
      for (int i = 0; i < rb.model.nv; ++i)
        for (int j = 0; j <= i; ++j) {
          const double a = hD * rb.model.D(i, j) + hK * rb.model.K(i, j);
          if (a != 0.0) A[m->dof_Madr[rb.dof0 + i] + (i - j)] += a;
        }
  add_fluid_damping(s, sd, hD, A);  // fluid hook: + cD h D_f (no-op without the fluid)
  sd.frozen_D.clear();
  if (frozen != FrozenRows::None) add_constraint_terms(m, s.dof_strain.data(), sd, A, hD, hK, frozen);
  factor_ldl(m, d, A, A, sd.A_LDiagInv.data(), s.dof_strain.data());  // (factor_mass: the rods keep their pivots)
  factor_woodbury(m, sd);
  if (sd.W_nrows == 0 && std::find(sd.frozen_across.begin(), sd.frozen_across.end(), 1) != sd.frozen_across.end())
    drop_woodbury_rows(sd);  // (dropped with the correction: explicit, as before)
}

// x = A^-1 y with the factor of factor_implicit: x = A_tree^-1 y - Z S^-1 U' A_tree^-1 y with the
// terms across branches (Woodbury).
void solve_implicit(const Scene& s, SceneData& sd, mjtNum* x, const mjtNum* y) {
  solve_ldl(s.m, sd.A_LD.data(), sd.A_LDiagInv.data(), x, y);
  const int nv = s.m->nv, r = sd.W_nrows;
  if (r == 0) return;
  const mjtNum* L = sd.W_S.data();
  mjtNum* t = sd.W_t.data();
  for (int i = 0; i < r; ++i) {  // t = L^-1 U' x
    double v = mju_dot(sd.W_rows.data() + i * nv, x, nv);
    for (int k = 0; k < i; ++k) v -= L[i * r + k] * t[k];
    t[i] = v / L[i * r + i];
  }
  for (int i = r - 1; i >= 0; --i) {  // t = L'^-1 t
    double v = t[i];
    for (int k = i + 1; k < r; ++k) v -= L[k * r + i] * t[k];
    t[i] = v / L[i * r + i];
  }
  for (int i = 0; i < r; ++i) mju_addToScl(x, sd.W_Z.data() + i * nv, -t[i], nv);
}

// The state update q+ = q + h (v + h aq), v+ = v + h av, act+ = act + h act_dot, time + h, with aq
// in d->qacc on entry and av in `av` (nullptr: av = aq, MuJoCo's Euler update without its implicit
// damping, already in the accelerations). d->qacc and the constraint solver's warm start are av
// afterwards.
void advance(const Scene& s, SceneData& sd, const mjtNum* av) {
  mjData* d = sd.d;
  const int nv = s.m->nv;
  if (!av) {
    advance_with_qacc(s, sd);
    return;
  }
  std::vector<mjtNum>& v0 = sd.rk_v0;  // RK4's scratch, free here
  std::copy(d->qvel, d->qvel + nv, v0.begin());
  advance_with_qacc(s, sd);
  const double h = s.m->opt.timestep;
  for (int i = 0; i < nv; ++i) d->qvel[i] = v0[i] + h * av[i];
  std::copy(av, av + nv, d->qacc);
  std::copy(av, av + nv, d->qacc_warmstart);
}

// y -= c K x with the K of the last factor_implicit (the rods' stiffness, sd.joint_K and the rows
// of sd.K_rows; x and y of size nv, MuJoCo's dof order).
void subtract_stiffness(const Scene& s, SceneData& sd, double c, const mjtNum* x, mjtNum* y) {
  const int nv = s.m->nv;
  for (int i = 0; i < nv; ++i) y[i] -= c * sd.joint_K[i] * x[i];
  for (int r = 0; r < sd.K_nrows; ++r) {  // tendon springs and gains: k u (u' x)
    const mjtNum* u = sd.K_rows.data() + static_cast<size_t>(r) * nv;
    mju_addToScl(y, u, -c * sd.K_row_coef[r] * mju_dot(u, x, nv), nv);
  }
  for (size_t r = 0; r < s.rods.size(); ++r) {
    const RodBinding& rb = s.rods[r];
    VecX& Kx = sd.scratch[r].Kv;
    Kx.noalias() = rb.model.K * Eigen::Map<const VecX>(x + rb.dof0, rb.model.nv);
    for (int k = 0; k < rb.model.nv; ++k) y[rb.dof0 + k] -= c * Kx(k);
  }
}

// The activations of `filter` and `muscle` actuators by the theta rule
//   act+ = act0 + h ((1 - theta) act_dot0 + theta f(ctrl, act+))
// from the step's start (act0, act_dot0), instead of the Euler update advance() made: theta = 1 is
// backward Euler (L-stable), 1/2 the trapezoidal rule (second order). A filter's f = (ctrl - act) /
// tau is linear: solved in closed form. A muscle's (mju_muscleDynamics: the time constant depends
// on act and on the sign of ctrl - act) decreases strictly in act, so the equation has one root:
// found by bisection to round-off. The control is held over the step, clamped as MuJoCo's
// actuation clamps it, and the activation clamped to its range as mj_Euler clamps it.
// `integrator` dynamics (act' = ctrl) are exact under Euler's update already. User dynamics
// (mjcb_act_dyn, of unknown form: f(act) reads the activation from d->act, the rest of the state
// as the step left it) are solved by the secant method from Euler's update, to round-off; where it
// does not converge in 50 iterations (dynamics that are far from monotone), Euler's update stays.
// Actuator a's control as MuJoCo's actuation takes it: clamped to its range where it is limited.
double clamped_ctrl(const mjModel* m, const mjData* d, int a) {
  double ctrl = d->ctrl[a];
  if (m->actuator_ctrllimited[a] && !(m->opt.disableflags & mjDSBL_CLAMPCTRL))
    ctrl = mju_clip(ctrl, m->actuator_ctrlrange[2 * a], m->actuator_ctrlrange[2 * a + 1]);
  return ctrl;
}

void filter_activations(const Scene& s, SceneData& sd, const mjtNum* act0, const mjtNum* act_dot0, double theta) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const double h = m->opt.timestep;
  if (m->opt.disableflags & mjDSBL_ACTUATION) return;  // (MuJoCo's act_dot is not computed then)
  for (int a = m->nu - m->na; a < m->nu; ++a) {
    const int type = m->actuator_dyntype[a];
    if (type != mjDYN_FILTER && type != mjDYN_MUSCLE && !(type == mjDYN_USER && mjcb_act_dyn)) continue;
    const int j = a - (m->nu - m->na);
    const double ctrl = clamped_ctrl(m, d, a);
    const mjtNum* prm = m->actuator_dynprm + mjNDYN * a;
    const double rest = act0[j] + h * (1.0 - theta) * act_dot0[j];  // act+ = rest + h theta f(act+)
    double act;
    if (type == mjDYN_FILTER) {
      const double tau = std::max(mjMINVAL, prm[0]);
      act = (rest + h * theta * ctrl / tau) / (1.0 + h * theta / tau);
    } else if (type == mjDYN_USER) {
      const double euler = d->act[j];
      auto g = [&](double x) {
        d->act[j] = x;
        return x - rest - h * theta * mjcb_act_dyn(m, d, a);
      };
      // from Euler's update x0 and a fixed-point step x1 = x0 - g(x0) = rest + h theta f(x0)
      double x0 = euler, g0 = g(x0), x1 = x0 - g0;
      act = euler;
      for (int it = 0; it < 50 && std::isfinite(x1) && std::isfinite(g0); ++it) {
        const double g1 = g(x1);
        if (std::abs(g1) <= 1e-14 * (1.0 + std::abs(x1))) {
          act = x1;
          break;
        }
        if (g1 == g0) break;
        const double x2 = x1 - g1 * (x1 - x0) / (g1 - g0);
        x0 = x1, g0 = g1, x1 = x2;
      }
    } else {
      auto g = [&](double x) { return x - rest - h * theta * mju_muscleDynamics(ctrl, x, prm); };  // increasing
      double lo = std::min(rest, 0.0) - 1.0, hi = std::max(rest, 1.0) + 1.0;
      while (g(lo) > 0) lo -= 2.0 * (hi - lo);
      while (g(hi) < 0) hi += 2.0 * (hi - lo);
      for (int it = 0; it < 200 && hi - lo > 1e-16 * (1.0 + std::abs(lo)); ++it) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        (g(mid) < 0 ? lo : hi) = mid;
      }
      act = std::abs(g(lo)) <= std::abs(g(hi)) ? lo : hi;
    }
    if (m->actuator_actlimited[a]) act = mju_clip(act, m->actuator_actrange[2 * a], m->actuator_actrange[2 * a + 1]);
    d->act[j] = act;
  }
}

// One linearised implicit step (after forward, d->qacc MuJoCo's explicit accelerations with the
// constraint forces): with A = M + theta h D + theta^2 h^2 K,
//   A a = M qacc - theta h K v,   q+ = q + h (v + theta h a),  v+ = v + h a.
// theta = 1 (Implicit) is linearised backward Euler; theta = 1/2 (Trapezoidal) the trapezoidal rule
// on the same linearisation: no numerical damping of the linear modes.
// contacts: the elliptic cones' friction rows too (FrozenRows::EqualitiesAndEllipticFriction), as
// the linearised `implicit` and `trapezoidal --newton 0` steps take them (not the Newton schemes'
// event steps and first iterates, whose contacts change within the step: the pushed rod's stopping
// distance under `midpoint` went from within 0.3% of Coulomb's to 1-3% long with them)
void implicit_step(const Scene& s, SceneData& sd, bool rods = true, double theta = 1.0, bool contacts = false) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const int nv = m->nv;
  const double th = theta * m->opt.timestep;
  // rhs = M qacc - theta h K v (M qacc = qfrc_smooth when forward skipped the accelerations: there
  // are no constraint forces then)
  if (smooth_only(sd))
    mju_copy(sd.qacc_tmp.data(), d->qfrc_smooth, nv);
  else
    mj_mulM(m, d, sd.qacc_tmp.data(), d->qacc);
  // the active rows on rods in MuJoCo's quadratic state (equalities; with `contacts` also the
  // friction rows of elliptic cones), implicit as the Newton schemes' matrix takes them: their force
  // at the step's end, linearised, -D (J a + B J v+ + K I r+), less the start's, leaves
  // D J'(J a0) - theta h D K I J'(J v) on the right-hand side. Friction rows since the forty-seventh
  // session (outside probe BM: torsional friction at a soft rod's end, its force from MuJoCo's solve
  // against M alone, let the end turn 2 rad on the floor under 16% of mu_t N where the rod's native
  // twin turned 0.008 rad); where a row ties two branches of the tree (an arm pressing a free
  // object) the equality rows alone.
  const bool rows = rods && !smooth_only(sd) && (contacts ? d->nefc > 0 : d->ne > 0);
  factor_implicit(s, sd, rods, theta, theta * theta,
                  !rows      ? FrozenRows::None
                  : contacts ? FrozenRows::EqualitiesAndEllipticFriction
                             : FrozenRows::Equalities);
  if (rods) subtract_stiffness(s, sd, th, d->qvel, sd.qacc_tmp.data());
  if (rows) {
    add_constraint_mass(sd, d->qacc, sd.qacc_tmp.data());
    add_frozen_rows(sd, sd.frozen_kI, d->qvel, sd.qacc_tmp.data(), -th);
  }
  solve_implicit(s, sd, d->qacc, sd.qacc_tmp.data());
  const int na = m->na;
  if (rods && na) {  // the start's activations, for filter_activations (RK4's scratch is free here)
    std::copy(d->act, d->act + na, sd.rk_a0.begin());
    std::copy(d->act_dot, d->act_dot + na, sd.rk_ka.begin());
  }
  if (theta == 1.0) {
    advance(s, sd, nullptr);
  } else {
    std::vector<mjtNum>& a = sd.qacc_tmp;  // the solve's right-hand side, free now
    std::copy(d->qacc, d->qacc + nv, a.begin());
    mju_scl(d->qacc, a.data(), theta, nv);
    advance(s, sd, a.data());
  }
  if (rods && na) filter_activations(s, sd, sd.rk_a0.data(), sd.rk_ka.data(), theta);
}

// The one-step schemes the Newton iterations solve, on M qddot = f(q, v) with f the scene's forward
// dynamics (every force, constraints included). With A the end acceleration of the step (Arnold
// and Bruls' pseudo-acceleration for the generalized-alpha method), A0 that of the previous step:
//   q+ = q + h v + h^2 (cq0 A0 + cq1 A),  v+ = v + h (cv0 A0 + cv1 A),
//   (1 - am) A + am A0 = (1 - af) f(q+, v+) + af f(q, v).
struct Scheme {
  double cq0, cq1, cv0, cv1, am, af;
  bool carry;             // A0 is carried from the previous step (otherwise A0 = f(q, v))
  bool midpoint = false;  // f at the step's midpoint instead (midpoint_step)
};
Scheme backward_euler() { return {0, 1, 0, 1, 0, 0, false}; }
Scheme trapezoidal_rule() { return {0.25, 0.25, 0.5, 0.5, 0.5, 0.5, false}; }
// q+ = q + h v + h^2/2 A, v+ = v + h A: q+ = q + h (v + v+)/2 (midpoint_step)
// (cq1 = 1 alone does not tell: the generalized alpha with rho = 0 has it too.)
bool is_backward_euler(const Scheme& sc) {
  return sc.cq0 == 0.0 && sc.cq1 == 1.0 && sc.cv0 == 0.0 && sc.cv1 == 1.0 && sc.am == 0.0 && sc.af == 0.0;
}
Scheme midpoint_rule() { return {0, 0.5, 0, 1, 0, 0, false, true}; }
// Chung and Hulbert's parameters for the spectral radius rho at infinite frequency (rho = 1: the
// trapezoidal rule; rho < 1 damps the stiff modes, second order for every rho in [0, 1]).
Scheme generalized_alpha(double rho) {
  const double am = (2 * rho - 1) / (rho + 1), af = rho / (rho + 1);
  const double gamma = 0.5 - am + af, beta = 0.25 * (1 - am + af) * (1 - am + af);
  return {0.5 - beta, beta, 1 - gamma, gamma, am, af, true};
}

// A step's start state (qpos, qvel, act, act_dot, time) into st.q0, v0, act0, act_dot0, t0, and
// back; and its end state (qpos, qvel, time) into st.q_end, v_end, t_end, with the test whether
// the next step starts there (`St`: SceneData::NewtonScratch or SceneData::Adaptive).
void save_state(SceneData::SavedState& st, const mjModel* m, const mjData* d) {
  std::copy(d->qpos, d->qpos + m->nq, st.q0.begin());
  std::copy(d->qvel, d->qvel + m->nv, st.v0.begin());
  std::copy(d->act, d->act + m->na, st.act0.begin());
  std::copy(d->act_dot, d->act_dot + m->na, st.act_dot0.begin());
  st.t0 = d->time;
}
void restore_state(const SceneData::SavedState& st, mjData* d) {
  std::copy(st.q0.begin(), st.q0.end(), d->qpos);
  std::copy(st.v0.begin(), st.v0.end(), d->qvel);
  std::copy(st.act0.begin(), st.act0.end(), d->act);
  std::copy(st.act_dot0.begin(), st.act_dot0.end(), d->act_dot);
  d->time = st.t0;
}
template <class St>
void record_end(St& st, const mjData* d) {
  std::copy(d->qpos, d->qpos + st.q_end.size(), st.q_end.begin());
  std::copy(d->qvel, d->qvel + st.v_end.size(), st.v_end.begin());
  st.t_end = d->time;
}
// The state is the recorded end's to round-off (1e-12 relative per coordinate): MuJoCo's
// kinematics normalises the quaternions in qpos in place, so that a forward between two steps
// moves them by an ulp; an exact test had then dropped the generalized alpha's carried
// acceleration at such a step and changed the step by up to 2.4e-4 m at a contact's onset (outside
// probe T).
template <class St>
bool starts_at_end(const St& st, const mjData* d) {
  auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * (1.0 + std::abs(b)); };
  return st.t_end == d->time && std::equal(st.q_end.begin(), st.q_end.end(), d->qpos, near) &&
         std::equal(st.v_end.begin(), st.v_end.end(), d->qvel, near);
}

// Back to the start state newton_step saved.
void restore_start(SceneData& sd) { restore_state(sd.newton, sd.d); }

// Saves the start state for restore_start.
void save_start(SceneData& sd, const mjModel* m) {
  save_state(sd.newton, m, sd.d);
  sd.newton.saved = true;
}

// The state (q+, v+) of the scheme for the end acceleration w.A (from the saved start state).
void set_end_state(const Scene& s, SceneData& sd, const Scheme& sc) {
  mjData* d = sd.d;
  SceneData::NewtonScratch& w = sd.newton;
  const int nv = s.m->nv;
  restore_start(sd);
  for (int i = 0; i < nv; ++i) {
    d->qacc[i] = sc.cq0 * w.A0[i] + sc.cq1 * w.A[i];
    w.y[i] = sc.cv0 * w.A0[i] + sc.cv1 * w.A[i];
  }
  advance(s, sd, w.y.data());
  // filter activations: backward Euler's rule for backward Euler, the trapezoidal rule for the
  // second-order schemes
  if (s.m->na) filter_activations(s, sd, w.act0.data(), w.act_dot0.data(), is_backward_euler(sc) ? 1.0 : 0.5);
}

// Anderson acceleration (type II) of the fixed-point iteration x <- x + F(x), x = w.A and
// F = w.delta the plain correction at x: with the last differences dX, dF of iterates and
// corrections, gamma = argmin |F - dF gamma| and the step becomes F - (dX + dF) gamma (replacing
// w.delta). The history restarts when a correction grows (the extrapolation is then not trusted).
// k: the iteration (0: no history yet); `stored`: columns in use, updated.
void anderson_update(SceneData& sd, int nv, int memory, int k, int& stored) {
  SceneData::NewtonScratch& w = sd.newton;
  const mjtNum* x = w.A.data();
  mjtNum* F = w.delta.data();
  mjtNum* dX = w.dX.data();
  mjtNum* dF = w.dF.data();
  if (k == 0) {
    stored = 0;
  } else if (mju_dot(F, F, nv) > mju_dot(w.F_prev.data(), w.F_prev.data(), nv)) {
    stored = 0;
  } else {  // shift the ring (oldest column out) and append the newest differences
    const int keep = std::min(stored, memory - 1);
    if (stored > keep) {  // std::copy: the target range starts before the source (they overlap)
      std::copy(dX + (stored - keep) * nv, dX + stored * nv, dX);
      std::copy(dF + (stored - keep) * nv, dF + stored * nv, dF);
    }
    mju_sub(dX + keep * nv, x, w.x_prev.data(), nv);
    mju_sub(dF + keep * nv, F, w.F_prev.data(), nv);
    stored = keep + 1;
  }
  std::copy(x, x + nv, w.x_prev.begin());
  std::copy(F, F + nv, w.F_prev.begin());
  if (stored == 0) return;
  // normal equations (dF^T dF + eps I) gamma = dF^T F, at most kMaxNewtonMemory unknowns
  mjtNum G[kMaxNewtonMemory * kMaxNewtonMemory], b[kMaxNewtonMemory], gamma[kMaxNewtonMemory];
  double trace = 0.0;
  for (int r = 0; r < stored; ++r) {
    b[r] = mju_dot(dF + r * nv, F, nv);
    for (int c = 0; c <= r; ++c) G[r * stored + c] = G[c * stored + r] = mju_dot(dF + r * nv, dF + c * nv, nv);
    trace += G[r * stored + r];
  }
  if (!(trace > 0.0)) return;
  for (int r = 0; r < stored; ++r) G[r * stored + r] += 1e-12 * trace;
  // a numerically dependent history (a pivot not above 0): the plain correction
  if (mju_cholFactor(G, stored, std::numeric_limits<mjtNum>::min()) < stored) return;
  mju_cholSolve(gamma, G, b, stored);
  for (int r = 0; r < stored; ++r) {
    mju_addToScl(F, dX + r * nv, -gamma[r], nv);
    mju_addToScl(F, dF + r * nv, -gamma[r], nv);
  }
}

enum class Iterate { Continue, Converged, Stop };

// After the solve for the plain correction w.delta of iteration k: decides convergence on its
// size, h cv1 |delta| <= newton_tol (|v+| + h |a_v|) + 1e-12 (max norms over the dofs), applies
// the (Anderson-accelerated) correction to w.A and tells whether to go on. Stop: non-finite, or
// the corrections grew tenfold over the first (`first`; a single rise is tolerated: the
// corrections of a simplified Newton need not decrease monotonically).
Iterate apply_correction(const Scene& s, SceneData& sd, const Scheme& sc, int k, int& stored, double& first) {
  SceneData::NewtonScratch& w = sd.newton;
  const int nv = s.m->nv;
  const double h = s.m->opt.timestep;
  double dmax = 0.0, vmax = 0.0, amax = 0.0;
  for (int i = 0; i < nv; ++i) {
    dmax = std::max(dmax, std::abs(w.delta[i]));
    double av = sc.cv1 * (w.A[i] + w.delta[i]);
    if (sc.cv0 != 0.0) av += sc.cv0 * w.A0[i];
    amax = std::max(amax, std::abs(av));
    vmax = std::max(vmax, std::abs(w.v0[i] + h * av));
  }
  const double norm = h * sc.cv1 * dmax;
  const bool done = !std::isfinite(norm) || norm <= s.newton_tol * (vmax + h * amax) + 1e-12;
  const int memory = std::clamp(s.newton_memory, 0, kMaxNewtonMemory);
  if (memory > 0 && !done) anderson_update(sd, nv, memory, k, stored);
  for (int i = 0; i < nv; ++i) w.A[i] += w.delta[i];  // delta: the (accelerated) correction
  // (a stop is recorded for newton_step_split: NewtonScratch::stopped)
  const bool stop = !std::isfinite(norm) || (!done && k > 0 && norm > 10.0 * first);
  if (stop) {
    w.stopped = true;
    return Iterate::Stop;
  }
  if (done) return Iterate::Converged;
  if (k == 0) first = norm;
  return Iterate::Continue;
}

// The pattern of a state's non-smooth constraints, into p: its contacts (geom pairs) and the type
// and state of each constraint row but the equalities' (contacts, joint and tendon limits, friction
// loss: loaded or not, sticking or sliding; MuJoCo's efc_state, or under its PGS solver, which does
// not set it, whether the row carries a force). A pattern that changes within a step marks an
// event (an impact, a release, a switch between sticking and sliding) that the Newton schemes do
// not integrate: their iterations take the constraint forces at the end (or the midpoint) of the
// step, where such an event makes them a discontinuous function of the state. The trapezoidal rule,
// the generalized alpha and the midpoint rule, which leave stiff modes undamped, then pumped
// energy into soft rods in sliding or chattering contact without bound (outside probe AT: a
// one-section rod pushed along a floor with friction went from 1.4 J to 4.9e4 J and flew 20 m up;
// an undamped rod dropped tilted onto a frictionless floor, from 0.1 J to 20 J; a rod sliding down
// a slope accelerated 88% faster than Coulomb's friction lets it), and backward Euler's
// iterations split most such steps down to h/64. Such a step is taken as a linearised backward
// Euler step instead (event_step), whose constraint forces are the start's, as in MuJoCo's own
// step, and whose damping of the stiff modes ends the chatter. Contacts that persist without
// changing state (rolling, resting, sliding steadily) keep the scheme's end-of-step forces and its
// order (holding the start's forces in every step instead had made rolling first order, and broken
// equality constraints: outside probe AV). At an impact the event step is first order as
// `implicit` is: a contact arising within the step gets no force until the next one, and the
// energy the contact then gives back can exceed what it took (outside probe AW: a soft rod dropped
// across a clamped one, docs/bench/repro/rod_cross_impact.xml, gains 20% at 2 ms, 6% at 1 ms, where
// `implicit` gains 22% at 1 ms). Splitting a step with an event into pieces of h/8, backward Euler
// only on the piece with the event, removed that gain (1.000), but on a rod sliding with friction
// at 0.25 ms the pieces grew too short to damp the chatter, and it pumped again; h/2 halved the
// impact's gain; neither was kept. Nor was backward Euler with one Newton correction (it blew up at
// the impact).
void constraint_pattern(const mjModel* m, const mjData* d, std::vector<int>& p) {
  p.clear();
  p.push_back(d->ncon);
  for (int c = 0; c < d->ncon; ++c) {
    p.push_back(d->contact[c].geom1);
    p.push_back(d->contact[c].geom2);
  }
  const bool states = m->opt.solver != mjSOL_PGS;
  for (int r = 0; r < d->nefc; ++r)
    if (d->efc_type[r] != mjCNSTR_EQUALITY) {
      p.push_back(d->efc_type[r]);
      p.push_back(states ? d->efc_state[r] : d->efc_force[r] != 0.0);
    }
}

// Whether two constraint patterns hold the same contacts and rows, whatever the rows' states
// (midpoint_step's check at the end state).
bool same_rows(const std::vector<int>& a, const std::vector<int>& b) {
  if (a.size() != b.size() || a[0] != b[0]) return false;
  const size_t rows = 1 + 2 * static_cast<size_t>(a[0]);  // after the count and the geom pairs
  if (!std::equal(a.begin(), a.begin() + rows, b.begin())) return false;
  for (size_t i = rows; i < a.size(); i += 2)  // (type, state) per row
    if (a[i] != b[i]) return false;
  return true;
}

// Whether the Newton schemes factorise their matrix again at the first iterate (midpoint: at its
// first midpoint state): Scene::newton_refresh, and always under adaptive substeps, which control
// what the refreshed matrix's full steps would risk (Scene::step_tol).
bool refreshes_newton_matrix(const Scene& s) { return s.newton_refresh || s.step_tol > 0; }

// Whether the state's pattern differs from the step's start's (after a forward at an iterate).
bool constraint_event(const Scene& s, SceneData& sd) {
  SceneData::NewtonScratch& w = sd.newton;
  if (w.pattern0.size() == 1 && sd.d->ncon == 0 && sd.d->nefc == sd.d->ne) return false;  // none before or now
  constraint_pattern(s.m, sd.d, w.pattern);
  return w.pattern != w.pattern0;
}

// The step of an event (constraint_pattern), from the saved start state: linearised backward Euler.
void event_step(const Scene& s, SceneData& sd) {
  ++sd.newton_stats.events;
  restore_start(sd);
  sd.newton.carry_valid = false;
  forward(s, sd, Need::Forces);
  implicit_step(s, sd);
}

// One step of the scheme by simplified Newton iterations: the first iterate is the linearised
// step, each correction solves A_N delta = M r with the matrix
//   A_N = M + c (cv1 h D + cq1 h^2 K),  c = (1 - af) / (1 - am),
// M and the state-dependent parts of D (actuators, fluid) taken at the step's start (with
// Scene::newton_refresh, or with adaptive substeps: at the first iterate (q+, v+)),
// and the residual r = ((1 - af) f(q+, v+) + af f(q, v) - am A0) / (1 - am) - A. Returns whether the
// velocity correction h cv1 |delta| fell below newton_tol (|v+| + h |a_v|) (absolute 1e-12) before
// the iterations ran out or stopped contracting; either way the state is the last iterate's.
bool newton_step(const Scene& s, SceneData& sd, const Scheme& sc, int iterations) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const int nv = m->nv;
  SceneData::NewtonScratch& w = sd.newton;
  // backward Euler needs no acceleration at the start (only the other schemes' f(q, v) terms do)
  const bool be = is_backward_euler(sc);
  forward(s, sd, be ? Need::Forces : Need::Acceleration);
  // the carried A0 is valid if the state is the one the previous step ended with
  const bool carried = sc.carry && w.carry_valid && starts_at_end(w, d);
  save_start(sd, m);
  if (sd.forces_only)  // backward Euler without constraints: f(q, v) is not needed (af = am = 0)
    std::fill(w.f0.begin(), w.f0.end(), 0.0);
  else
    std::copy(d->qacc, d->qacc + nv, w.f0.begin());
  if (!carried) std::copy(w.f0.begin(), w.f0.end(), w.A0.begin());
  constraint_pattern(m, d, w.pattern0);
  // first iterate: the linearised step (backward Euler, or the trapezoidal rule whose average
  // acceleration a gives A = 2 a - f(q, v))
  implicit_step(s, sd, true, be ? 1.0 : 0.5);
  for (int i = 0; i < nv; ++i) w.A[i] = be ? d->qacc[i] : 2.0 * d->qacc[i] - w.f0[i];
  const double c = (1.0 - sc.af) / (1.0 - sc.am);
  const bool refresh = refreshes_newton_matrix(s);
  // the start state's constraint rows (d->efc_*: the first iterate ran no forward) enter the
  // iteration matrix (add_constraint_terms), of which the linearised step's holds the equalities only
  const bool constrained = !smooth_only(sd) && d->nefc > 0;
  if (!refresh && (constrained || (!be && (c * sc.cv1 != 0.5 || c * sc.cq1 != 0.25))))
    factor_implicit(s, sd, true, c * sc.cv1, c * sc.cq1, FrozenRows::All);  // the start state's, the scheme's coefficients
  if (!be) set_end_state(s, sd, sc);
  bool converged = false;
  double first = 0.0;  // size of the first correction
  int stored = 0;      // Anderson history columns in use
  for (int k = 0; k < iterations; ++k) {
    forward(s, sd, Need::Forces);  // at (q+, v+)
    // the iteration matrix at the first iterate's state (Scene::newton_refresh; the rods' D and K
    // are constant)
    if (k == 0 && refresh) factor_implicit(s, sd, true, be ? 1.0 : c * sc.cv1, be ? 1.0 : c * sc.cq1, FrozenRows::All);
    ++sd.newton_stats.iterations;
    // y = M r, M at (q+, v+), r = c f(q+, v+) + z; when forward skipped the accelerations (no
    // constraints), M f(q+, v+) = qfrc_smooth: y = M z + c qfrc_smooth
    for (int i = 0; i < nv; ++i) {
      w.r[i] = (sc.af * w.f0[i] - sc.am * w.A0[i]) / (1.0 - sc.am) - w.A[i];
      if (!smooth_only(sd)) w.r[i] += c * d->qacc[i];
    }
    mj_mulM(m, d, w.y.data(), w.r.data());
    if (smooth_only(sd)) mju_addToScl(w.y.data(), d->qfrc_smooth, c, nv);
    // (M + J'DJ) r with the rows the matrix holds (add_constraint_terms; where this iterate has no
    // constraint rows, f's part of r is not at hand: M r, the matrix stiffer than the iterate's)
    if (!smooth_only(sd)) add_constraint_mass(sd, w.r.data(), w.y.data());
    solve_implicit(s, sd, w.delta.data(), w.y.data());
    const Iterate it = apply_correction(s, sd, sc, k, stored, first);
    set_end_state(s, sd, sc);
    if (it == Iterate::Converged) converged = true;
    if (it != Iterate::Continue) break;
  }
  // the pattern of the last iterate's forward (the first iterates' can differ on the way)
  if (iterations > 0 && constraint_event(s, sd)) {
    event_step(s, sd);
    record_end(w, d);
    return true;
  }
  w.carry_valid = sc.carry;
  std::copy(w.A.begin(), w.A.end(), w.A0.begin());
  record_end(w, d);
  return converged;
}

// The kinetic and gravitational parts of energy() (after fwd_inertia).
void kinetic_and_gravity(const Scene& s, SceneData& sd, SceneEnergy& e) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  mj_mulM(m, d, sd.tmp_nv.data(), d->qvel);  // qM includes the rods' inertia
  e.kinetic = 0.5 * mju_dot(sd.tmp_nv.data(), d->qvel, m->nv);
  // gravity as the dynamics sees it now (MuJoCo's option, unless disabled)
  const Vec3 g = (m->opt.disableflags & mjDSBL_GRAVITY) ? Vec3::Zero()
                                                         : Vec3(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]);
  e.gravity = 0.0;
  for (int b = 1; b < m->nbody; ++b)
    e.gravity -= m->body_mass[b] * g.dot(Vec3(d->xipos[3 * b], d->xipos[3 * b + 1], d->xipos[3 * b + 2]));
  for (size_t r = 0; r < s.rods.size(); ++r) {
    double mass = 0.0;
    const Vec3 com = cosserat::center_of_mass(s.rods[r].model, sd.rod[r], &mass);
    e.gravity -= mass * g.dot(com);
  }
}

// MuJoCo's springs as mj_passive applies them and mj_energyPos counts them (none under
// mjDSBL_PASSIVE), split by whether their energy is quadratic in the coordinates: hinge and slide
// joints and a free joint's displacement (quadratic_spring_energy) against the rotations of ball and
// free joints (the rotation vector from the rest orientation, mj_passive's mju_subQuat) and tendons
// (nonlinear_springs' energy, after mj_tendon; its power: v . (their forces), after fwd_velocity,
// v = qvel and ten_velocity as d holds them).
double quadratic_spring_energy(const mjModel* m, const mjData* d) {
  if (m->opt.disableflags & mjDSBL_PASSIVE) return 0.0;
  double e = 0.0;
  for (int j = 0; j < m->njnt; ++j) {
    const double k = m->jnt_stiffness[j];
    if (!(k > 0) || m->jnt_type[j] == mjJNT_BALL) continue;
    const int a = m->jnt_qposadr[j];
    if (m->jnt_type[j] == mjJNT_FREE) {
      mjtNum dif[3];
      mju_sub3(dif, d->qpos + a, m->qpos_spring + a);
      e += 0.5 * k * mju_dot3(dif, dif);
    } else {
      const double dq = d->qpos[a] - m->qpos_spring[a];
      e += 0.5 * k * dq * dq;
    }
  }
  return e;
}

// The rotation vector of ball or free joint j's spring (mj_passive's); returns the scalar part of
// that rotation (the rest quaternion's dot product with the joint's), whose sign flips where the
// rotation passes pi.
double spring_rotation(const mjModel* m, const mjData* d, int j, mjtNum dif[3]) {
  const int a = m->jnt_qposadr[j] + (m->jnt_type[j] == mjJNT_FREE ? 3 : 0);
  mjtNum quat[4];
  mju_copy4(quat, d->qpos + a);
  mju_normalize4(quat);
  mju_subQuat(dif, quat, m->qpos_spring + a);
  return mju_dot(quat, m->qpos_spring + a, 4);
}

bool rotational_spring(const mjModel* m, int j) {
  return m->jnt_stiffness[j] > 0 && (m->jnt_type[j] == mjJNT_BALL || m->jnt_type[j] == mjJNT_FREE);
}

bool has_nonlinear_springs(const mjModel* m) {
  if (m->opt.disableflags & mjDSBL_PASSIVE) return false;
  for (int j = 0; j < m->njnt; ++j)
    if (rotational_spring(m, j)) return true;
  for (int t = 0; t < m->ntendon; ++t)
    if (m->tendon_stiffness[t] > 0) return true;
  return false;
}

// Each of those springs' energy and power (v . its force), into energy[k] and power[k], and for
// ball and free joints the scalar part of the rotation from the rest orientation into w[k] (its
// sign flips where the rotation passes pi); any may be null; k a joint's index or njnt plus a
// tendon's (0 for the rest). Returns the total energy.
double nonlinear_springs(const mjModel* m, const mjData* d, double* energy, double* power, double* w = nullptr) {
  const int n = m->njnt + m->ntendon;
  if (energy) std::fill(energy, energy + n, 0.0);
  if (power) std::fill(power, power + n, 0.0);
  if (w) std::fill(w, w + n, 0.0);
  if (m->opt.disableflags & mjDSBL_PASSIVE) return 0.0;
  double total = 0.0;
  for (int j = 0; j < m->njnt; ++j)
    if (rotational_spring(m, j)) {
      mjtNum dif[3];
      const double scalar = spring_rotation(m, d, j, dif);
      const double k = m->jnt_stiffness[j], e = 0.5 * k * mju_dot3(dif, dif);
      total += e;
      if (energy) energy[j] = e;
      if (power) power[j] = -k * mju_dot3(dif, d->qvel + m->jnt_dofadr[j] + (m->jnt_type[j] == mjJNT_FREE ? 3 : 0));
      if (w) w[j] = scalar;
    }
  for (int t = 0; t < m->ntendon; ++t)
    if (m->tendon_stiffness[t] > 0) {
      const double k = m->tendon_stiffness[t], dl = d->ten_length[t] - m->tendon_lengthspring[t], e = 0.5 * k * dl * dl;
      total += e;
      if (energy) energy[m->njnt + t] = e;
      if (power) power[m->njnt + t] = -k * dl * d->ten_velocity[t];
    }
  return total;
}

// The energy-conserving implicit midpoint rule. With v_m = (v + v+)/2 and the midpoint state
//   q_m = q + h/2 v_m (MuJoCo's position integration: quaternions along their geodesic), t + h/2,
//   q+ = q + h v_m,  v+ = v + h A,  M(q_m) A = F(q_m, v_m) + mu M(q_m) v_m,
// F every force of the scene at the midpoint (constraint forces included: MuJoCo's forward there).
// Without mu this is the implicit midpoint rule, second order, whose energy error is O(h^3) per
// step and not bounded on stiff nonlinear problems (Simo and Tarnow 1992: the midpoint and the
// trapezoidal rules blow up in nonlinear elastodynamics, as the trapezoidal rule does in
// docs/bench/RESULTS.md's long run). The scalar mu (O(h^2)) restores the energy balance exactly,
//   E(q+, v+) - E(q, v) = h v_m . (the non-conservative forces at the midpoint),
// E = kinetic + gravity + the rods' elastic energy + MuJoCo's springs (joints and tendons): a
// discrete gradient in Gonzalez's sense, corrected along v_m. The rods' elastic forces and the
// springs of hinge and slide joints (and a free joint's displacement) are linear in the
// coordinates, so their midpoint values are exact discrete gradients; the others, V_s (tendon
// springs, the rotations of ball and free joints: quadratic_spring_energy's note), are balanced
// like gravity, and the momentum equation leaves
//   h mu v_m' M v_m = h v_m' (M A + qfrc_bias - f_s) - [T + V_gravity + V_s](q+, v+)
//                     + [T + V_gravity + V_s](q, v),
// M, qfrc_bias (Coriolis and gravity, rods included) and f_s (the forces of V_s' springs) at the
// midpoint. Each iteration evaluates the forces at the midpoint (one forward) and T + V_gravity +
// V_s at the end (poses, mass matrix, tendon lengths), takes mu from the current iterate and
// corrects A with M + h/2 D + h^2/4 K (the linearisation of M(q_m) (A - f(q_m, v_m)), the
// trapezoidal rule's matrix). Undamped, the energy is constant to the Newton tolerance; with
// damping it can only decrease. (Outside probe AQ: with V_s left to the midpoint forces, a rod and a
// ball joint tied by tendon springs drifted 7e-5 of its energy in 0.5 s at 1 ms.)
// A step whose correction would change the velocity by more than a quarter (|h mu| > 1/4: a step
// too large for the motion, typically with the kinetic energy near zero while stiff modes are not
// resolved) is not converged: it is split. On the undamped cantilever of the stress runs at 5 ms,
// 2% of the steps are.
bool midpoint_step(const Scene& s, SceneData& sd, int iterations) {
  constexpr double kMaxCorrection = 0.25;
  mjModel* m = s.m;  // the midpoint state is a step of h/2: opt.timestep changes meanwhile
  mjData* d = sd.d;
  const int nv = m->nv;
  const double h = m->opt.timestep;
  SceneData::NewtonScratch& w = sd.newton;
  const Scheme sc = midpoint_rule();
  forward(s, sd, Need::Forces);
  // kinetic, gravity and the springs whose energy is not quadratic (the rest of the elastic energy
  // is balanced exactly)
  SceneEnergy e0, e1;
  kinetic_and_gravity(s, sd, e0);
  const bool springs = has_nonlinear_springs(m);
  const int nsp = m->njnt + m->ntendon;
  double* V0 = sd.spring_V0.data();
  double* V1 = sd.spring_V1.data();
  double* Ps = sd.spring_P.data();
  double* W0 = sd.spring_w0.data();
  double* W1 = sd.spring_w1.data();
  const double V0_all = springs ? nonlinear_springs(m, d, V0, nullptr, W0) : 0.0;
  save_start(sd, m);
  constraint_pattern(m, d, w.pattern0);
  // first iterate: the linearised trapezoidal step, whose average acceleration (d->qacc) is A
  implicit_step(s, sd, true, 0.5);
  std::copy(d->qacc, d->qacc + nv, w.A.begin());
  // the start state's constraint rows in the iteration matrix (add_constraint_terms)
  const bool constrained = !smooth_only(sd) && d->nefc > 0;
  if (constrained) factor_implicit(s, sd, true, 0.5, 0.25, FrozenRows::All);
  mjtNum* Mv = w.A0.data();  // M(q_m) v_m (A0 and f0 are not used by this scheme)
  mjtNum* vm = w.f0.data();  // v_m
  bool converged = false;
  double first = 0.0;  // size of the first correction
  int stored = 0;      // Anderson history columns in use
  for (int k = 0; k < iterations; ++k) {
    restore_start(sd);  // the midpoint state: half a step with A
    std::copy(w.A.begin(), w.A.end(), d->qacc);
    {
      const TimestepScope half(m, 0.5 * h);
      advance(s, sd, w.A.data());
    }
    forward(s, sd, Need::Forces);
    // Scene::newton_refresh (and adaptive substeps, as the other schemes) where no constraint row
    // acts at the start or at the first midpoint: the matrix at that midpoint state (with
    // constraint rows, refreshed, it had needed more corrections and splits on the octopus arm's
    // contacts). (Adaptive substeps had not refreshed it here, as they do for the other schemes:
    // the rod-cross impact repro at 2 ms with --step-tol 1e-2 took 45607 corrections and 4481
    // substeps, 2128 rejected; refreshed, 10367, 1527 and 304.)
    if (k == 0 && refreshes_newton_matrix(s) && !constrained && smooth_only(sd)) factor_implicit(s, sd, true, 0.5, 0.25);
    ++sd.newton_stats.iterations;
    std::copy(d->qvel, d->qvel + nv, vm);
    mj_mulM(m, d, Mv, vm);
    mj_mulM(m, d, w.y.data(), w.A.data());  // M A
    const double S = mju_dot(vm, Mv, nv);
    double P = mju_dot(vm, w.y.data(), nv) + mju_dot(vm, d->qfrc_bias, nv);
    if (springs) nonlinear_springs(m, d, nullptr, Ps);
    // r = M (f(q_m, v_m) - A); M f = qfrc_smooth when forward skipped the accelerations
    if (smooth_only(sd)) {
      mju_sub(w.r.data(), d->qfrc_smooth, w.y.data(), nv);
    } else {
      mj_mulM(m, d, w.r.data(), d->qacc);
      mju_subFrom(w.r.data(), w.y.data(), nv);
    }
    // (M + J'DJ) (f - A) with the constraint rows the matrix holds (add_constraint_terms; M (f - A)
    // where this iterate has none, as in newton_step)
    if (!sd.frozen_D.empty() && !smooth_only(sd)) {
      mju_sub(w.delta.data(), d->qacc, w.A.data(), nv);
      add_constraint_mass(sd, w.delta.data(), w.r.data());
    }
    set_end_state(s, sd, sc);
    fwd_inertia(s, sd);
    kinetic_and_gravity(s, sd, e1);
    // the springs whose energy is balanced: their energy at both ends less their power at the
    // midpoint (their work is in E's change), but a ball's or free joint's spring whose rotation
    // from rest passes pi in the step (the scalar part of that rotation changes sign), where
    // mj_passive's force flips: it is left to its midpoint force for the step, as the damping is
    // (outside probe AR: balanced through pi, a spinning free body's spring left 78 steps
    // unconverged and the energy jumped). (Where MuJoCo's wrapping makes a tendon's length jump,
    // as where a site enters the wrapped geom, the balance turns the jump of its spring's energy
    // into a change of the speeds, within the correction's limit.)
    double Vs0 = 0.0, Vs1 = 0.0, V1_all = 0.0;
    if (springs) {
      scene_tendons(s, sd);  // the lengths (the kinematics patched for rod sites)
      V1_all = nonlinear_springs(m, d, V1, nullptr, W1);
      for (int k = 0; k < nsp; ++k) {
        if (W0[k] * W1[k] < 0) continue;
        Vs0 += V0[k], Vs1 += V1[k];
        P -= Ps[k];
      }
    }
    // the energy defect the correction removes, unless it is within what the tolerance allows
    // anyway (the kinetic energy to newton_tol, the energies to round-off): a rod at rest has
    // S ~ 0 and a defect of round-off, whose quotient means nothing
    const double defect = h * P - (e1.kinetic + e1.gravity + Vs1 - (e0.kinetic + e0.gravity + Vs0));
    const double allowed = s.newton_tol * (e0.kinetic + e1.kinetic) +
                           64 * DBL_EPSILON *
                               (e0.kinetic + std::abs(e0.gravity) + e1.kinetic + std::abs(e1.gravity) + V0_all + V1_all);
    double mu = std::abs(defect) > allowed && S > 0.0 ? defect / (h * S) : 0.0;
    const bool clamped = !(std::abs(h * mu) <= kMaxCorrection);
    if (clamped) mu = std::isfinite(mu) ? std::copysign(kMaxCorrection / h, mu) : 0.0;
    mju_addToScl(w.r.data(), Mv, mu, nv);
    solve_implicit(s, sd, w.delta.data(), w.r.data());
    const Iterate it = apply_correction(s, sd, sc, k, stored, first);
    if (it == Iterate::Converged) converged = !clamped;
    if (it != Iterate::Continue) break;
  }
  // an event: the pattern changed by the last midpoint state, or the end state's constraint rows
  // (its contacts and the rows present, whatever their state) are not the start's. A contact
  // arising or parting in the step's second half is not seen at the midpoint, and that step had
  // gone without its force, or with it throughout: a rod pushed along a floor hopped up to 2 cm
  // and slid 0.5-8% past Coulomb's distance at 2 ms with --step-tol 1e-2, scattering with the
  // push's last digits (0.7% long at 62.5 us); now 0.6802 m for each push at 2 ms, 0.6816-0.6819
  // at 0.25 ms and 0.6801 at 62.5 us (Coulomb: 0.6796), as the trapezoidal rule. (At fixed 2 ms,
  // where the rod's first bending mode is not resolved, 0.7152, where it had read 0.6811: the
  // extra event steps, linearised, gain energy on the whipping rod; README, Known limitations.)
  // A change of the rows' states alone (sticking and sliding, a pyramid's edges) is left to the
  // next step's midpoint: counted as an event at the end too, it turned most steps of a rod
  // sliding across another into backward Euler steps with the start's forces, and the impact of
  // docs/bench/repro/rod_cross_impact.xml gained 15% at 2 ms with --step-tol 1e-2 (now 0.6%). The
  // end state's forward is taken only where such rows can arise (Scene::may_have_events). (Leaving
  // out the ends of corrections that ran away, which the step's split then takes, let the pushed
  // rod slide 0.7% long at 2 ms with --step-tol 1e-2; taking every runaway as an event made the
  // impact repro gain 23-29%, as implicit does.)
  bool event = constraint_event(s, sd);
  set_end_state(s, sd, sc);
  if (!event && s.may_have_events) {
    // MuJoCo's warnings raised there are not the run's (the end of corrections that ran away had
    // filled the contact buffer 4641 times in the impact repro's 500 steps at 1 ms, and the run
    // then advised a larger nconmax): counted as raised already (MuJoCo prints a warning the first
    // time only), and restored after. An end state that is kept raises its own at the next step's
    // start.
    mjWarningStat saved[mjNWARNING];
    std::copy(d->warning, d->warning + mjNWARNING, saved);
    for (mjWarningStat& x : d->warning) x.number = std::max(x.number, 1);
    forward(s, sd, Need::Forces);
    constraint_pattern(m, d, w.pattern);
    event = !same_rows(w.pattern0, w.pattern);
    std::copy(saved, saved + mjNWARNING, d->warning);
  }
  if (event) {
    event_step(s, sd);
    return true;
  }
  w.carry_valid = false;
  return converged;
}

// One step of `method` (implicit, trapezoidal, genalpha or midpoint) at m->opt.timestep, without
// splitting: whether its Newton iteration converged (true for the linearised steps and for one
// correction per step, which are kept by choice).
bool single_step(const Scene& s, SceneData& sd, Integrator method) {
  const int n = s.newton_for(method);
  switch (method) {
    case Integrator::Implicit:
      if (n > 0) return newton_step(s, sd, backward_euler(), n) || n == 1;
      if (implicit_is_mujocos(s)) {  // MuJoCo's own implicit integrator (mj_step's)
        forward(s, sd);
        mj_implicit(s.m, sd.d);
        return true;
      }
      forward(s, sd, Need::Forces);
      implicit_step(s, sd, true, 1.0, true);
      return true;
    case Integrator::Trapezoidal:
      if (n > 0) return newton_step(s, sd, trapezoidal_rule(), n) || n == 1;
      forward(s, sd, Need::Forces);
      implicit_step(s, sd, true, 0.5, true);
      return true;
    case Integrator::GeneralizedAlpha: return newton_step(s, sd, generalized_alpha(s.rho_inf), std::max(1, n)) || n <= 1;
    case Integrator::Midpoint: return midpoint_step(s, sd, std::max(1, n)) || n <= 1;
    default: return false;
  }
}

// single_step, with a step whose Newton iterations do not converge redone as two half steps (down
// to h / 2^kMaxSplit; below that counted as unconverged, and taken as a linearised backward Euler
// step where the corrections stopped). One
// correction per step (--newton 1) is a linearly implicit step of the scheme, by choice: it is
// kept without a convergence test (splitting would chase a tolerance one correction cannot meet,
// down to h/64 on every step).
// A MuJoCo error raised inside an iterate (through a throwing mju_user_error handler, as the
// command line installs; MuJoCo's own handler exits) counts as a failed correction, as a
// non-finite iterate does: the step is split (outside probe AA: a wild iterate of a violent
// cable-driven scene stopped MuJoCo 2.2.2's sparse Newton solver, "Rank-defficient Hessian",
// and ended the run at its first step, where dense Jacobians had split it and run on). An error
// at the step's start state, or in the finest half steps, is passed on.
bool state_finite(const mjModel* m, const mjData* d);

// The substeps of a step (split or adaptive) evaluate the constraints as the whole step does
// (SceneData::constraint_timestep): its step h from the outermost scope on, restored at its end.
// (Outside probe AW's heavy tip on a hard floor, solref 0.002 at 5 ms: its substeps had seen
// contacts 25 times stiffer than its whole steps, MuJoCo's refsafe raising the time constant to
// 2h; split, it hovered 5 um deep with an event in most steps, where whole steps rest 109 um deep.)
struct KeepConstraintStep {
  SceneData& sd;
  double c;
  KeepConstraintStep(SceneData& x, double h) : sd(x), c(x.constraint_timestep) {
    if (!(c > 0)) sd.constraint_timestep = h;
  }
  ~KeepConstraintStep() { sd.constraint_timestep = c; }
};

void newton_step_split(const Scene& s, SceneData& sd, Integrator method, int depth = 0) {
  constexpr int kMaxSplit = 6;
  sd.newton.saved = false;
  sd.newton.stopped = false;
  const KeepConstraintStep keep_constraints(sd, s.m->opt.timestep);
  bool converged = false;
  try {
    converged = single_step(s, sd, method);
  } catch (const std::exception&) {
    // (an exception of the control callback is the application's, not a failed correction: outside
    // probe BE's was swallowed, the step split and returned Ok)
    if (depth == kMaxSplit || !sd.newton.saved || sd.callback_threw) throw;
    sd.d->pstack = 0;  // the unwound MuJoCo frames did not release their stack allocations
  }
  if (converged) return;
  if (depth == kMaxSplit) {
    // where the corrections stopped (non-finite, or grown tenfold) the finest step is taken as a
    // linearised backward Euler step instead of their last iterate, which they may have left
    // anywhere (outside probe AP: a soft leg buckling under a weight with its foot on a floor
    // diverged under genalpha and trapezoidal at 1 ms after 184 and 601 such steps kept as they
    // were). An iterate whose corrections ran out still contracting is kept: taking the linearised
    // step there too made heavy tips gain energy in bench_stress (its explicit gravity and Coriolis)
    ++sd.newton_stats.unconverged;
    if (sd.newton.stopped || !state_finite(s.m, sd.d)) {
      ++sd.newton_stats.linearised;
      restore_start(sd);
      sd.newton.carry_valid = false;
      forward(s, sd, Need::Forces);
      implicit_step(s, sd);
    }
    return;
  }
  restore_start(sd);
  sd.newton.carry_valid = false;  // the half steps start from A0 = f(q, v)
  ++sd.newton_stats.splits;
  const TimestepScope half(s.m, 0.5 * s.m->opt.timestep);  // h again however the half steps end
  newton_step_split(s, sd, method, depth + 1);
  newton_step_split(s, sd, method, depth + 1);
}

// A step of m->opt.timestep h as adaptive substeps h / 2^k (Scene::step_tol). Levels only refine
// where the substeps are aligned, so the substeps tile the step exactly: positions are counted in
// units of h / 2^kMaxLevel.
void adaptive_step(const Scene& s, SceneData& sd, Integrator method) {
  constexpr int kMaxLevel = kMaxSubstepLevel;
  constexpr int kUnits = 1 << kMaxLevel;
  mjModel* m = s.m;
  mjData* d = sd.d;
  const int nv = m->nv;
  const double H = m->opt.timestep, t_start = d->time;
  SceneData::Adaptive& a = sd.adapt;
  // the previous substep's acceleration and level count only if this step starts where it ended: a
  // state reset or set between steps (an RL episode's mj_resetData) starts from whole steps, as a
  // new SceneData does (outside probe AB: the level carried over a reset, and the replayed episode
  // ended 1.2 cm away from the first)
  bool history = a.valid && starts_at_end(a, d);
  int level = history ? std::clamp(a.level, 0, kMaxLevel) : 0;
  const KeepConstraintStep keep_constraints(sd, H);
  int done = 0;  // units of H / kUnits
  ++sd.adapt_stats.steps;
  while (done < kUnits) {
    while (done % (kUnits >> level) != 0) ++level;  // (not reached: levels coarsen only when aligned)
    const double h = H / (1 << level);
    save_state(a, m, d);
    const long events = sd.newton_stats.events;
    const bool converged = [&] {
      const TimestepScope substep(m, h);
      return single_step(s, sd, method);
    }();
    // a substep of at most H/2 taken as a contact event's step (event_step) is kept whatever its
    // acceleration did, and the next substep is not compared with it: across a switch of a
    // contact's state the acceleration jumps at any substep, and halving only places the switch
    // more finely while the event steps' damping, first order in the substep, fades (outside probe
    // AW's one-section rod pushed along a floor with friction 0.3 at 2 ms and --step-tol 1e-2 was
    // halved to 2 us at most events, 8e3-5e4 substeps for 1 s, and slid 1.7%, 2.8% and 19% past
    // Coulomb's distance under trapezoidal, genalpha and midpoint; now 1.3e3-4.7e3 substeps, within
    // 0.5%). Whole steps with an event are still halved once: an impact's energy stays within 1.5%
    // (docs/bench/repro/rod_cross_impact.xml at 2 ms; never kept, 3.5% under trapezoidal).
    const bool event = sd.newton_stats.events != events && level >= 1;
    // the change of the mean acceleration against the velocity scale, in the kinetic-energy norm
    // |x|_M = sqrt(x' M x) (M of the substep's last forward evaluation; NaN rejects)
    double err = 0.0;
    if (history && !event) {
      SceneData::NewtonScratch& w = sd.newton;  // r, y, delta: free between steps
      for (int i = 0; i < nv; ++i) {
        w.r[i] = (d->qvel[i] - a.v0[i]) / h;  // abar
        w.y[i] = w.r[i] - a.a_prev[i];
      }
      mj_mulM(m, d, w.delta.data(), w.y.data());
      const double change = std::sqrt(std::max(0.0, mju_dot(w.y.data(), w.delta.data(), nv)));
      mj_mulM(m, d, w.delta.data(), w.r.data());
      const double accel = std::sqrt(std::max(0.0, mju_dot(w.r.data(), w.delta.data(), nv)));
      mj_mulM(m, d, w.delta.data(), d->qvel);
      const double vel = std::sqrt(std::max(0.0, mju_dot(d->qvel, w.delta.data(), nv)));
      err = h * change / (vel + h * accel + 1e-300);
      if (!std::isfinite(err)) err = std::numeric_limits<double>::infinity();
    }
    const bool ok = converged && err <= s.step_tol;
    if (!ok && level < kMaxLevel) {  // redo as two halves
      restore_state(a, d);
      sd.newton.carry_valid = false;
      ++level;
      ++sd.adapt_stats.rejected;
      continue;
    }
    if (!ok) ++sd.adapt_stats.kept_at_min;
    for (int i = 0; i < nv; ++i) a.a_prev[i] = (d->qvel[i] - a.v0[i]) / h;
    history = !event;
    ++sd.adapt_stats.substeps;
    sd.adapt_stats.finest = std::max(sd.adapt_stats.finest, level);
    done += kUnits >> level;
    // coarsen where the change is well within the tolerance (it grows about fourfold with a doubled
    // substep) and the next substep of twice the size stays aligned
    if (ok && err < s.step_tol / 8 && level > 0 && done % (kUnits >> (level - 1)) == 0) --level;
  }
  d->time = t_start + H;
  a.level = level;
  a.valid = true;
  record_end(a, d);
}

// Activations of actuators with actlimited clipped to their actrange, as MuJoCo 2.2.2's mj_step
// leaves them after each step whatever its integrator (outside probe BR: rk4 and rosenbrock had
// let an integrator's activation reach 0.5 of its limit 0.1, a filter's 0.993 of 0.3).
void clamp_activations(const mjModel* m, mjData* d) {
  for (int a = m->nu - m->na; a < m->nu; ++a) {  // (MuJoCo 2.2: the stateful actuators come last)
    if (!m->actuator_actlimited[a]) continue;
    const int j = a - (m->nu - m->na);
    d->act[j] = mju_clip(d->act[j], m->actuator_actrange[2 * a], m->actuator_actrange[2 * a + 1]);
  }
}

// Classic RK4 on (qpos, qvel, act) with our forward at every stage (MuJoCo's mj_RungeKutta calls
// mj_forward and would lose the rod patches). Positions are integrated with mj_integratePos.
void rk4_step(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const int nv = m->nv, nq = m->nq, na = m->na;
  const double h = m->opt.timestep;
  static constexpr double A[3] = {0.5, 0.5, 1.0}, B[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
  std::vector<mjtNum>&q0 = sd.rk_q0, &v0 = sd.rk_v0, &a0 = sd.rk_a0;
  std::vector<mjtNum>&kq = sd.rk_kq, &kv = sd.rk_kv, &ka = sd.rk_ka, &dx = sd.rk_dx;
  std::copy(d->qpos, d->qpos + nq, q0.begin());
  std::copy(d->qvel, d->qvel + nv, v0.begin());
  std::copy(d->act, d->act + na, a0.begin());
  const double t0 = d->time;
  for (int st = 0; st < 4; ++st) {
    if (st > 0) {
      const double c = A[st - 1] * h;
      mju_copy(d->qpos, q0.data(), nq);
      mj_integratePos(m, d->qpos, kq.data() + (st - 1) * nv, c);
      for (int i = 0; i < nv; ++i) d->qvel[i] = v0[i] + c * kv[(st - 1) * nv + i];
      for (int i = 0; i < na; ++i) d->act[i] = a0[i] + c * ka[(st - 1) * na + i];
      d->time = t0 + c;
    }
    forward(s, sd);
    mju_copy(kq.data() + st * nv, d->qvel, nv);
    mju_copy(kv.data() + st * nv, d->qacc, nv);
    if (na) mju_copy(ka.data() + st * na, d->act_dot, na);
  }
  mju_copy(d->qpos, q0.data(), nq);
  for (int i = 0; i < nv; ++i) {
    dx[i] = 0.0;
    double acc = 0.0;
    for (int st = 0; st < 4; ++st) dx[i] += B[st] * kq[st * nv + i], acc += B[st] * kv[st * nv + i];
    d->qvel[i] = v0[i] + h * acc;
    d->qacc[i] = acc;
  }
  mj_integratePos(m, d->qpos, dx.data(), h);
  for (int i = 0; i < na; ++i) {
    double acc = 0.0;
    for (int st = 0; st < 4; ++st) acc += B[st] * ka[st * na + i];
    d->act[i] = a0[i] + h * acc;
  }
  clamp_activations(m, d);
  d->time = t0 + h;
}

// d act_dot / d act of activation j at the current state, for Rosenbrock's W (any W keeps the
// method's order): a filter's -1/tau, a muscle's by central differences of mju_muscleDynamics
// (its time constant changes with act), 0 for integrators and user dynamics (left explicit).
double activation_jacobian(const mjModel* m, const mjData* d, int j) {
  if (m->opt.disableflags & mjDSBL_ACTUATION) return 0.0;
  const int a = m->nu - m->na + j, type = m->actuator_dyntype[a];
  const mjtNum* prm = m->actuator_dynprm + mjNDYN * a;
  if (type == mjDYN_FILTER) return -1.0 / std::max(mjMINVAL, prm[0]);
  if (type != mjDYN_MUSCLE) return 0.0;
  const double ctrl = clamped_ctrl(m, d, a);
  const double x = d->act[j], e = 1e-7;
  return std::min(0.0, (mju_muscleDynamics(ctrl, x + e, prm) - mju_muscleDynamics(ctrl, x - e, prm)) / (2 * e));
}

// One step of the Rosenbrock-W method ROS34PW2 (cosserat::ros34pw2, integrators.hpp) on
// y = (q, v, act) with F = (v, qacc, act_dot) (our forward, constraints included) and
// W = [0 I 0; -M0^-1 K  -M0^-1 D  0; 0 0 Ja]: M0 the mass matrix at the step's start, K and D the
// implicit step's stiffness and damping (factor_implicit: the rods', the joints' springs and
// damping, tendon springs and damping, the position and velocity gains of servos, the fluid's
// damping), Ja the activations' own decay (activation_jacobian: filters and muscles; before, their
// dynamics were explicit, and a filter of tau = h / 2.5 diverged where rk4 holds it: outside
// probe CF). What W leaves out (gravity, Coriolis, geometric stiffness, a stretched cable's turning,
// tendon forces set by controls, contacts, the activations' forces) is integrated as by an explicit
// method: there an undamped oscillation of
// frequency w gains energy by a factor 1 + O((h w)^4) per step (outside probe S), and the step
// limit is about RK4's. Eliminating u_q, each stage solves the implicit step's matrix A = M0 + gamma h D +
// gamma^2 h^2 K (factorised once per step):
//   A u_v = h gamma (M0 r_v - h gamma K r_q),   u_q = h gamma (r_q + u_v),
//   u_act = h gamma r_act / (1 - h gamma Ja),
// with r the stage's right-hand side F(Y_i) + sum_j C_ij / h u_j. Positions are integrated with
// mj_integratePos (as rk4_step does: on free and ball joints the quaternions then lose the third order).
void rosenbrock_step(const Scene& s, SceneData& sd) {
  namespace R = ros34pw2;
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const int nv = m->nv, nq = m->nq, na = m->na;
  const double h = m->opt.timestep, hg = h * R::gamma;
  std::vector<mjtNum>&q0 = sd.rk_q0, &v0 = sd.rk_v0, &a0 = sd.rk_a0;
  std::vector<mjtNum>&uq = sd.rk_kq, &uv = sd.rk_kv, &ua = sd.rk_ka, &dx = sd.rk_dx;
  std::vector<mjtNum>&sq = sd.ros_sq, &sv = sd.ros_sv, &rhs = sd.ros_rhs;
  std::copy(d->qpos, d->qpos + nq, q0.begin());
  std::copy(d->qvel, d->qvel + nv, v0.begin());
  std::copy(d->act, d->act + na, a0.begin());
  const double t0 = d->time;
  for (int st = 0; st < R::kStages; ++st) {
    if (st > 0) {  // Y_st = y + sum_j a_stj u_j
      std::fill(dx.begin(), dx.end(), 0.0);
      mju_copy(d->qvel, v0.data(), nv);
      mju_copy(d->act, a0.data(), na);
      for (int j = 0; j < st; ++j) {
        mju_addToScl(dx.data(), uq.data() + j * nv, R::a[st][j], nv);
        mju_addToScl(d->qvel, uv.data() + j * nv, R::a[st][j], nv);
        if (na) mju_addToScl(d->act, ua.data() + j * na, R::a[st][j], na);
      }
      mju_copy(d->qpos, q0.data(), nq);
      mj_integratePos(m, d->qpos, dx.data(), 1.0);
      d->time = t0 + R::c[st] * h;
    }
    forward(s, sd);
    if (st == 0) {
      std::copy(d->qM, d->qM + m->nM, sd.ros_M0.begin());
      factor_implicit(s, sd, true, R::gamma, R::gamma * R::gamma);
      for (int j = 0; j < na; ++j) sd.ros_ja[j] = activation_jacobian(m, d, j);
    }
    // r_q = v + sum_j C_stj / h u_q,j (in sq), r_v = qacc + sum_j C_stj / h u_v,j (in sv)
    mju_copy(sq.data(), d->qvel, nv);
    mju_copy(sv.data(), d->qacc, nv);
    mjtNum* ua_st = na ? ua.data() + st * na : nullptr;
    if (na) mju_copy(ua_st, d->act_dot, na);
    for (int j = 0; j < st; ++j) {
      const double cj = R::C[st][j] / h;
      mju_addToScl(sq.data(), uq.data() + j * nv, cj, nv);
      mju_addToScl(sv.data(), uv.data() + j * nv, cj, nv);
      if (na) mju_addToScl(ua_st, ua.data() + j * na, cj, na);
    }
    // rhs = h gamma (M0 r_v - h gamma K r_q)
    mul_tree(m, sd.ros_M0.data(), rhs.data(), sv.data());
    subtract_stiffness(s, sd, hg, sq.data(), rhs.data());
    mju_scl(rhs.data(), rhs.data(), hg, nv);
    mjtNum* uv_st = uv.data() + st * nv;
    mjtNum* uq_st = uq.data() + st * nv;
    solve_implicit(s, sd, uv_st, rhs.data());
    for (int i = 0; i < nv; ++i) uq_st[i] = hg * (sq[i] + uv_st[i]);
    for (int j = 0; j < na; ++j) ua_st[j] *= hg / (1.0 - hg * sd.ros_ja[j]);
  }
  std::fill(dx.begin(), dx.end(), 0.0);
  mju_copy(d->qvel, v0.data(), nv);
  mju_copy(d->act, a0.data(), na);
  for (int st = 0; st < R::kStages; ++st) {
    mju_addToScl(dx.data(), uq.data() + st * nv, R::b[st], nv);
    mju_addToScl(d->qvel, uv.data() + st * nv, R::b[st], nv);
    if (na) mju_addToScl(d->act, ua.data() + st * na, R::b[st], na);
  }
  mju_copy(d->qpos, q0.data(), nq);
  mj_integratePos(m, d->qpos, dx.data(), 1.0);
  clamp_activations(m, d);
  for (int i = 0; i < nv; ++i) d->qacc[i] = (d->qvel[i] - v0[i]) / h;
  mju_copy(d->qacc_warmstart, d->qacc, nv);
  d->time = t0 + h;
}

bool state_finite(const mjModel* m, const mjData* d) {
  for (int i = 0; i < m->nq; ++i)
    if (!std::isfinite(d->qpos[i])) return false;
  for (int i = 0; i < m->nv; ++i)
    if (!std::isfinite(d->qvel[i]) || std::abs(d->qvel[i]) > 1e10) return false;
  return true;
}

}  // namespace

Status step(const Scene& s, SceneData& sd) { return step(s, sd, s.integrator); }

namespace {
// The state step() started from, with its constraint solver's warm start.
void back_to_step_start(SceneData& sd) {
  restore_state(sd.step_start, sd.d);
  std::copy(sd.step_start_warmstart.begin(), sd.step_start_warmstart.end(), sd.d->qacc_warmstart);
}
}  // namespace

void abandon_step(SceneData& sd, const std::string& reason) {
  back_to_step_start(sd);
  sd.d->pstack = 0;  // the unwound MuJoCo frames did not release their stack allocations
  sd.status = Status::Diverged;
  sd.warning = reason + " (in the step from t = " + std::to_string(sd.d->time) + " s)";
}

Status step(const Scene& s, SceneData& sd, Integrator method) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  struct InStep {  // SceneData::step_sensors_done, reset however the step ends
    SceneData& sd;
    explicit InStep(SceneData& x) : sd(x) { sd.in_step = true, sd.step_sensors_done = false; }
    ~InStep() { sd.in_step = false, sd.step_sensors_done = false; }
  } in_step(sd);
  check_owner(s, sd);
  const SceneUse use(s);
  save_state(sd.step_start, m, d);
  std::copy(d->qacc_warmstart, d->qacc_warmstart + m->nv, sd.step_start_warmstart.begin());
  sd.step_compression = {};
  const double t = d->time;
  // a step from an earlier time than the last step's end starts a new run (MuJoCo's mj_resetData
  // or a state set back between steps): the records of the last one (compression, divergence) are
  // dropped, as reset() drops them (outside probe AB: an episode's collapse warning outlived it)
  if (t < sd.last_step_end) {
    sd.compression = {};
    sd.status = Status::Ok;
    sd.warning.clear();
    sd.buffers_full_at = std::numeric_limits<double>::quiet_NaN();
    sd.run_start = std::numeric_limits<double>::quiet_NaN();
  }
  if (std::isnan(sd.run_start)) sd.run_start = t;
  sd.callback_threw = false;
  try {
    switch (method) {
      case Integrator::Euler:
        if (s.fluid.active) {
          forward(s, sd, Need::Forces);
          implicit_step(s, sd, false);  // fluid hook: MuJoCo's Euler plus the fluid's implicit damping
        } else {
          forward(s, sd);
          mj_Euler(m, d);
        }
        break;
      case Integrator::RK4: rk4_step(s, sd); break;
      case Integrator::Rosenbrock: rosenbrock_step(s, sd); break;
      default:  // implicit, trapezoidal, genalpha, midpoint (single_step)
        if (s.step_tol > 0) adaptive_step(s, sd, method);
        else newton_step_split(s, sd, method);
        break;
    }
  } catch (...) {
    // an exception leaving the step (the control callback's, a MuJoCo error through a throwing
    // handler) leaves the step's start state, not a stage's or an iterate's (outside probe BE: rk4
    // left time and velocities at its failed stage)
    back_to_step_start(sd);
    throw;
  }
  if (std::isnan(sd.buffers_full_at) && full_buffer_count(d) > 0)
    sd.buffers_full_at = t;
  if (!state_finite(m, d)) {
    back_to_step_start(sd);
    if (sd.step_compression.stretch <= kCollapsedStretch && !(sd.compression.stretch <= kCollapsedStretch)) {
      sd.compression = sd.step_compression;
      sd.compression.time = t;
    }
    sd.status = Status::Diverged;
    sd.warning = "the state became non-finite at t = " + std::to_string(t) + " s";
    return sd.status;
  }
  // the smallest axial stretch at the step's end (the rods' data hold its last evaluation), kept
  // from the step with the first inverted section on (what follows an inversion is not physical)
  if (sd.compression.stretch > 0) lower_compression(s, sd, sd.compression, t, false);
  sd.status = Status::Ok;
  sd.last_step_end = d->time;
  return sd.status;
}

// ------------------------------------------------------------------------------- outputs --

SceneEnergy energy(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  SceneEnergy e;
  kinetic_and_gravity(s, sd, e);
  for (size_t r = 0; r < s.rods.size(); ++r) e.elastic += cosserat::energy(s.rods[r].model, sd.rod[r]).elastic;
  // MuJoCo's springs, as mj_energyPos counts them (outside probe W: ball and free joint springs
  // had been left out)
  e.elastic += quadratic_spring_energy(s.m, d) + nonlinear_springs(m, d, nullptr, nullptr);
  // (only where everything that moves hangs from free joints, whose trees keep their momentum
  // without contacts: a clamped rod's centre of mass swings with the rest of its motion)
  double mass = 0.0;
  bool free = true;
  auto floats = [m](int b) {
    const int root = m->body_rootid[b];
    return m->body_jntnum[root] > 0 && m->jnt_type[m->body_jntadr[root]] == mjJNT_FREE;
  };
  for (int b = 1; b < m->nbody && free; ++b) {
    if (m->body_weldid[b] == 0) continue;  // (welded to the world: does not move)
    free = floats(b);
    mass += m->body_mass[b];
  }
  for (size_t r = 0; r < s.rods.size() && free; ++r) {
    free = floats(s.rods[r].base_body);
    double rod_mass = 0.0;
    cosserat::center_of_mass(s.rods[r].model, sd.rod[r], &rod_mass);
    mass += rod_mass;
  }
  if (free && mass > 0) e.translational = 0.5 * momentum(s, sd).tail<3>().squaredNorm() / mass;
  return e;
}

Vec6 momentum(const Scene& s, const SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  Vec6 h = Vec6::Zero();
  for (int b = 1; b < m->nbody; ++b) {
    const double mass = m->body_mass[b];
    if (mass <= 0) continue;
    mjtNum vel[6];  // [w; v] of the body's inertial frame, world axes
    mj_objectVelocity(m, d, mjOBJ_BODY, b, vel, 0);
    const Vec3 w(vel[0], vel[1], vel[2]), v(vel[3], vel[4], vel[5]);
    const Vec3 x(d->xipos[3 * b], d->xipos[3 * b + 1], d->xipos[3 * b + 2]);
    const Mat3 R = Eigen::Map<const Mat3r>(d->ximat + 9 * b);
    const Vec3 I(m->body_inertia[3 * b], m->body_inertia[3 * b + 1], m->body_inertia[3 * b + 2]);
    const Vec3 p = mass * v;
    h.head<3>() += R * I.asDiagonal() * R.transpose() * w + x.cross(p);
    h.tail<3>() += p;
  }
  for (size_t r = 0; r < s.rods.size(); ++r) h += cosserat::momentum(s.rods[r].model, sd.rod[r]);
  return h;
}

int rod_index(const Scene& s, const std::string& name) {
  for (size_t r = 0; r < s.rods.size(); ++r)
    if (s.rods[r].decl.name == name) return static_cast<int>(r);
  return -1;
}

bool generated_body(const Scene& s, int b) {
  return std::any_of(s.rods.begin(), s.rods.end(), [b](const RodBinding& r) { return b >= r.base_body && b < r.below_begin; });
}

namespace {
// (outside probe BE: rod_index's -1 for a misspelt name, passed on, read freed memory and crashed)
void check_rod(const Scene& s, const SceneData& sd, int r) {
  check_owner(s, sd);
  if (r < 0 || r >= static_cast<int>(s.rods.size()))
    throw std::out_of_range("rod index " + std::to_string(r) + ": the scene has " + std::to_string(s.rods.size()) +
                            " rods (rod_index gives -1 for a name it does not know)");
}
}  // namespace

SE3 rod_frame(const Scene& s, const SceneData& sd, int r, double X) {
  check_rod(s, sd, r);
  return rod_pose(s.rods[r].model, sd.rod[r], 0, X);
}

Vec6 rod_frame_velocity(const Scene& s, const SceneData& sd, int r, double X) {
  check_rod(s, sd, r);
  const cosserat::Model& model = s.rods[r].model;
  const cosserat::Data& rd = sd.rod[r];
  SE3 pose;
  const Vec6 eta = rod_twist(model, rd, 0, X, &pose);  // in the cross-section's frame
  Vec6 w;
  w.head<3>() = pose.R * eta.head<3>();
  w.tail<3>() = pose.R * eta.tail<3>();
  return w;
}

Vec6 rod_strain(const Scene& s, const SceneData& sd, int r, double X) {
  check_rod(s, sd, r);
  return cosserat::rod_strain(s.rods[r].model, sd.rod[r], 0, X);
}

std::vector<Vec3> rod_centerline(const Scene& s, const SceneData& sd, int r, int n) {
  check_rod(s, sd, r);
  std::vector<Vec3> pts;
  const double L = s.rods[r].model.rods[0].length;
  for (int i = 0; i < n; ++i) pts.push_back(rod_pose(s.rods[r].model, sd.rod[r], 0, L * i / std::max(n - 1, 1)).u);
  return pts;
}

}  // namespace cosserat::mj
