// See native_chain.hpp. The rods are read by the project's own MJCF pre-processor (so the chain
// sees exactly the lengths, tapers, materials and sites the rod scene sees); the <cosserat>
// elements of the user's document are then replaced in place.
#include "native_chain.hpp"

#include <tinyxml2.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <regex>
#include <vector>

#include "lie.hpp"
#include "fluid.hpp"
#include "mjcf.hpp"
#include "scene.hpp"

namespace cosserat::bench {

namespace {

using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;
constexpr double kPi = 3.14159265358979323846;

std::string fmt(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}
std::string fmt3(const Vec3& v) { return fmt(v.x()) + " " + fmt(v.y()) + " " + fmt(v.z()); }

XMLElement* add(XMLDocument& doc, XMLElement* parent, const char* tag,
                const std::vector<std::pair<std::string, std::string>>& attrs) {
  XMLElement* e = doc.NewElement(tag);
  for (const auto& [k, v] : attrs) e->SetAttribute(k.c_str(), v.c_str());
  parent->InsertEndChild(e);
  return e;
}

// The section containing abscissa X (on a boundary, the later one): its index, and its data.
int section_index_at(const RodSpec& spec, double X) {
  if (spec.overrides.empty())  // equal sections
    return std::min(static_cast<int>((X + 1e-12 * spec.length) / spec.length * spec.sections), spec.sections - 1);
  double X0 = 0.0;
  for (std::size_t i = 0; i < spec.overrides.size(); ++i) {
    X0 += spec.overrides[i].length;
    if (X < X0 - 1e-12 * spec.length || i + 1 == spec.overrides.size()) return static_cast<int>(i);
  }
  return 0;
}
const SectionSpec& section_at(const RodSpec& spec, double X) {
  return spec.overrides.empty() ? spec.section : spec.overrides[section_index_at(spec, X)];
}

// The rest pose of abscissa b in the frame of abscissa a <= b: the sections' rest strains composed
// across their boundaries (a chain link straddling the flagellate's hook-helix boundary took one
// section's strain for all of it, outside probe Q: its helix was 2 mm off, at any N).
SE3 rest_between(const RodSpec& spec, double a, double b) {
  if (spec.overrides.empty()) return exp_se3(b - a, spec.section.rest_strain);
  SE3 g;
  double X0 = 0.0;
  for (std::size_t i = 0; i < spec.overrides.size(); ++i) {
    const double X1 = i + 1 == spec.overrides.size() ? spec.length : X0 + spec.overrides[i].length;
    const double lo = std::max(a, X0), hi = std::min(b, X1);
    if (hi > lo) g = g * exp_se3(hi - lo, spec.overrides[i].rest_strain);
    X0 = X1;
  }
  return g;
}

double radius_at(const RodSpec& spec, double X) {
  const double tip = spec.radius_tip < 0 ? spec.radius_base : spec.radius_tip;
  return spec.radius_base + (tip - spec.radius_base) * X / spec.length;
}

std::string quat_text(const Mat3& R) {
  const Eigen::Vector4d q = quat_from_matrix(R);
  return fmt(q(0)) + " " + fmt(q(1)) + " " + fmt(q(2)) + " " + fmt(q(3));
}

void fail(const std::string& path, const std::string& msg) { throw std::runtime_error(path + ": native chain: " + msg); }

// Every attribute value anywhere in the document naming a rod proxy or strain joint.
void check_no_proxy_refs(const XMLElement* e, const std::vector<std::string>& rods, const std::string& path) {
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::string(c->Name()) == "cosserat") continue;
    for (auto* a = c->FirstAttribute(); a; a = a->Next()) {
      const std::string v = a->Value();
      for (const auto& r : rods) {
        const std::regex proxy("(^|\\s)" + std::regex_replace(r, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                               "/s[0-9]+");
        if (std::regex_search(v, proxy))
          fail(path, "<" + std::string(c->Name()) + " " + a->Name() + "=\"" + v +
                         "\"> names a rod proxy or strain joint, which the native chain does not have");
      }
    }
    check_no_proxy_refs(c, rods, path);
  }
}

// How the rod scene's fluid acts on a rod (when the plugin owns the scene's fluid).
struct RodDrag {
  double viscosity = 0;
  RftModel model = RftModel::GrayHancock;
  RodFluidInfo info;
  bool enabled = false;
};

struct Converter {
  XMLDocument& doc;
  const std::map<std::string, const mj::RodDecl*>& decls;
  const std::map<std::string, RodDrag>& drag;
  const NativeChainOptions& opt;
  std::string path;
  std::vector<std::pair<std::string, std::string>> excludes;
  std::vector<std::pair<std::string, std::string>> numerics;  // cosserat:drag:<body> -> data
  bool radian = false;  // <compiler angle="radian"> (MuJoCo reads hinge ranges in degrees otherwise)

  void replace(XMLElement* parent, XMLElement* cos) {
    const char* nm = cos->Attribute("name");
    if (!nm || !decls.count(nm)) fail(path, "unnamed or unknown <cosserat>");
    const mj::RodDecl& d = *decls.at(nm);
    const RodSpec& spec = d.spec;
    const std::string n = d.name;
    const int N = opt.segments;
    if (N < 1) fail(path, "segments must be >= 1");
    const double L = spec.length, ds = L / N;

    // fixed base body with the rod's placement
    XMLElement* base = doc.NewElement("body");
    base->SetAttribute("name", (n + "/base").c_str());
    for (const char* a : {"pos", "quat", "euler", "axisangle", "xyaxes", "zaxis"})
      if (const char* v = cos->Attribute(a)) base->SetAttribute(a, v);
    parent->InsertAfterChild(cos, base);
    add(doc, base, "site", {{"name", n + "/base"}, {"pos", "0 0 0"}});

    // collision attributes of every capsule, as the rod's (MuJoCo's defaults apply otherwise)
    std::vector<std::pair<std::string, std::string>> geom_attrs;
    for (const char* a : {"contype", "conaffinity", "condim", "friction", "solref", "solimp", "margin", "gap", "rgba",
                          "group", "material", "class"})
      if (const char* v = cos->Attribute(a)) geom_attrs.emplace_back(a, v);
    const bool selfcollide = cos->BoolAttribute("selfcollide", false);
    // like the rod's sections: no collisions within the chain (neighbours: MuJoCo's parent filter)
    if (!selfcollide)
      for (int i = 0; i < N; ++i)
        for (int k = i + 2; k < N; ++k) excludes.emplace_back(n + "/b" + std::to_string(i), n + "/b" + std::to_string(k));
    const RodDrag* rd = drag.count(n) ? &drag.at(n) : nullptr;

    static const char* comp[6] = {"kx", "ky", "kz", "px", "py", "pz"};
    // strainrange (the loader resolved and checked it per section: RodDecl::strain_range): the
    // limits of the section a joint sits in become that joint's limits, a strain range times ds (a
    // hinge's angle, a slide's displacement), with the rod's solreflimit and solimplimit; rotational
    // limits on ball joints (a cone, not a box) have no such equivalent and are refused
    for (const auto& range : d.strain_range)
      if (opt.ball && (range[0] || range[1] || range[2] || range[3] || range[4] || range[5]))
        fail(path, "rod '" + n + "': strainrange on rotations cannot be carried by ball joints (a cone, not a box): "
                   "use hinges");
    std::vector<std::pair<std::string, std::string>> limit_attrs;
    for (const char* a : {"solreflimit", "solimplimit"})
      if (const char* v = cos->Attribute(a)) limit_attrs.emplace_back(a, v);
    XMLElement* body = base;
    std::vector<XMLElement*> bodies;
    for (int k = 0; k < N; ++k) {
      const double Xk = k * ds, Xm = (k + 0.5) * ds;
      const int ij = section_index_at(spec, Xk);
      const SectionSpec& sj = section_at(spec, Xk);  // joint: at X_k
      static const std::array<double, 12> kUnlimited{};
      const std::array<double, 12>& range = ij < static_cast<int>(d.strain_range.size()) ? d.strain_range[ij] : kUnlimited;
      const SectionSpec& sm = section_at(spec, Xm);  // body: its middle
      SE3 place;                                     // body k in body k-1 (rest shape)
      if (k > 0) place = rest_between(spec, Xk - ds, Xk);
      XMLElement* b = add(doc, body, "body", {{"name", n + "/b" + std::to_string(k)}, {"pos", fmt3(place.u)}});
      if (!place.R.isIdentity(1e-15)) b->SetAttribute("quat", quat_text(place.R).c_str());
      bodies.push_back(b);

      // joints at the body origin: springs of the rod around X_k
      {
        double A, I;
        cosserat::section_area_moments(sj.material, radius_at(spec, Xk), A, I);
        const double J = 2 * I;
        const double E = sj.material.young, G = sj.material.shear_modulus(), mu = sj.material.viscosity;
        // the clamp factor on bending only: the chain's torsion and stretch are exact with 1/ds
        // (outside probe Q: doubling them too made the clamp's torsion too stiff to first order)
        const double f = k == 0 ? opt.base_spring_factor : 1.0;
        const double fb[6] = {1.0, f, f, 1.0, 1.0, 1.0};
        const double kstiff[6] = {G * J / ds, E * I / ds, E * I / ds, E * A / ds, G * A / ds, G * A / ds};
        // armature on the hinges (a MuJoCo user's way to a larger stable step): a multiple of the
        // segment's rotational inertia about its centre, rho A ds^3 / 12
        const double armature = opt.armature_factor * sj.material.density * A * ds * ds * ds / 12;
        const double kdamp[6] = {mu * J / ds, 3 * mu * I / ds, 3 * mu * I / ds, 3 * mu * A / ds, mu * A / ds, mu * A / ds};
        const std::string jp = n + "/b" + std::to_string(k) + "/";
        const bool any_rot = sj.dofs[0] || sj.dofs[1] || sj.dofs[2];
        if (opt.ball && any_rot) {
          add(doc, b, "joint",
              {{"name", jp + "ball"}, {"type", "ball"}, {"pos", "0 0 0"}, {"stiffness", fmt(f * kstiff[1])},
               {"damping", fmt(f * kdamp[1])}, {"armature", fmt(armature)}, {"limited", "false"}});
        }
        for (int c = 0; c < 6; ++c) {
          if (!sj.dofs[c] || (opt.ball && c < 3)) continue;
          Vec3 axis = Vec3::Zero();
          axis(c % 3) = 1;
          XMLElement* joint = add(doc, b, "joint",
              {{"name", jp + comp[c]}, {"type", c < 3 ? "hinge" : "slide"}, {"pos", "0 0 0"}, {"axis", fmt3(axis)},
               {"stiffness", fmt(fb[c] * kstiff[c])}, {"damping", fmt(fb[c] * kdamp[c])},
               {"armature", fmt(c < 3 ? armature : 0.0)},
               {"limited", "false"}, {"springref", "0"}});
          if (range[2 * c] != 0.0 || range[2 * c + 1] != 0.0) {
            joint->SetAttribute("limited", "true");
            const double unit = c < 3 && !radian ? 180.0 / kPi : 1.0;  // a hinge's angle in the model's unit
            joint->SetAttribute("range",
                                (fmt(range[2 * c] * ds * unit) + " " + fmt(range[2 * c + 1] * ds * unit)).c_str());
            for (const auto& [a, v] : limit_attrs) joint->SetAttribute(a.c_str(), v.c_str());
          }
        }
      }
      // inertia of the segment [X_k, X_k + ds] (taper radius at its middle), capsule along its chord
      {
        const double r = radius_at(spec, Xm);
        double A, I;
        cosserat::section_area_moments(sm.material, r, A, I);
        const double J = 2 * I;
        const double rho = sm.material.density, mass = rho * A * ds;
        const SE3 half = rest_between(spec, Xk, Xm), end = rest_between(spec, Xk, Xk + ds);
        add(doc, b, "inertial",
            {{"pos", fmt3(half.u)},
             {"mass", fmt(mass)},
             {"diaginertia", fmt(rho * J * ds) + " " + fmt(rho * I * ds + mass * ds * ds / 12) + " " +
                                 fmt(rho * I * ds + mass * ds * ds / 12)}});
        auto attrs = geom_attrs;
        attrs.insert(attrs.begin(), {{"name", n + "/b" + std::to_string(k) + "/g"},
                                     {"type", "capsule"},
                                     {"fromto", "0 0 0 " + fmt3(end.u)},
                                     {"size", fmt(r)},
                                     {"mass", "0"}});
        add(doc, b, "geom", attrs);
        // the rod's resistive force theory on the capsule's segment (the plugin's fluid)
        if (rd && rd->enabled) {
          RftCoefficients c = rd->info.base;
          if (rd->model == RftModel::GrayHancock && rd->info.wavelength > 0) {
            const RftCoefficients g = gray_hancock(rd->viscosity, r, rd->info.wavelength);
            if (valid(g)) c = g;
          }
          numerics.emplace_back("cosserat:drag:" + n + "/b" + std::to_string(k),
                                fmt(c.ct) + " " + fmt(c.cn) + " " + fmt(c.crot));
        }
      }
      body = b;
    }

    // tip frame, tip site, and the rigid bodies hanging at the tip
    const SE3 tip_place = rest_between(spec, L - ds, L);
    XMLElement* tip = add(doc, body, "body", {{"name", n + "/tipframe"}, {"pos", fmt3(tip_place.u)}});
    if (!tip_place.R.isIdentity(1e-15)) tip->SetAttribute("quat", quat_text(tip_place.R).c_str());
    add(doc, tip, "site", {{"name", n + "/tip"}, {"pos", "0 0 0"}});

    // user sites: on the body holding their abscissa
    for (XMLElement* c = cos->FirstChildElement("site"); c; c = c->NextSiblingElement("site")) {
      const std::string sn = c->Attribute("name");
      const mj::RodSiteDecl* sd = nullptr;
      for (const auto& s : d.sites)
        if (s.name == sn) sd = &s;
      if (!sd) fail(path, "site '" + sn + "' not found among the rod's sites");
      const int k = std::min(N - 1, static_cast<int>(std::floor(sd->X / ds + 1e-9)));
      const SE3 g = rest_between(spec, k * ds, sd->X);
      XMLElement* s = add(doc, bodies[k], "site", {{"name", sn}, {"pos", fmt3(g.act(sd->pos))}});
      for (auto* a = c->FirstAttribute(); a; a = a->Next()) {
        const std::string an = a->Name();
        if (an != "name" && an != "at" && an != "pos") s->SetAttribute(a->Name(), a->Value());
      }
    }
    // <body> children: moved under the tip frame; excluded against the chain like the proxies
    std::vector<XMLElement*> kids;
    for (XMLElement* c = cos->FirstChildElement("body"); c; c = c->NextSiblingElement("body")) kids.push_back(c);
    for (XMLElement* c : kids) {
      tip->InsertEndChild(c);
      if (const char* cn = c->Attribute("name"))
        for (int k = 0; k < N; ++k) excludes.emplace_back(cn, n + "/b" + std::to_string(k));
    }
    if (d.parent_body != "world")
      for (int k = 0; k < N; ++k) excludes.emplace_back(d.parent_body, n + "/b" + std::to_string(k));
    parent->DeleteChild(cos);
    // continue inside the moved rigid bodies (they may carry rods too)
    for (XMLElement* c : kids) walk(c);
  }

  void walk(XMLElement* e) {
    for (XMLElement* c = e->FirstChildElement(); c;) {
      XMLElement* next = c->NextSiblingElement();
      if (std::string(c->Name()) == "cosserat")
        replace(e, c);
      else
        walk(c);
      c = next;
    }
  }
};

}  // namespace

std::string native_chain_xml(const std::string& xml, const std::string& path, const NativeChainOptions& opt) {
  const mj::Preprocessed pre = mj::preprocess_string(xml, path);  // validates and reads the rods
  std::map<std::string, const mj::RodDecl*> decls;
  std::vector<std::string> names;
  for (const auto& r : pre.rods) decls[r.name] = &r, names.push_back(r.name);
  // the fluid the rod scene applies to each rod, if the plugin owns it
  std::map<std::string, RodDrag> drag;
  {
    const auto scene = mj::load_scene_string(xml, path);
    if (scene->fluid.active)
      for (size_t r = 0; r < scene->rods.size(); ++r) {
        RodDrag d;
        d.viscosity = scene->fluid.viscosity;
        d.model = scene->fluid.model;
        d.info = scene->fluid.rods[r];
        d.enabled = scene->fluid.rod_enabled[r];
        drag[scene->rods[r].decl.name] = d;
      }
  }

  XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) fail(path, "XML parse error");
  XMLElement* root = doc.RootElement();
  if (!root || std::string(root->Name()) != "mujoco") fail(path, "the root element is not <mujoco>");
  if (root->FirstChildElement("include")) fail(path, "<include> is not supported");
  check_no_proxy_refs(root, names, path);

  Converter conv{doc, decls, drag, opt, path, {}, {}};
  for (const XMLElement* c = root->FirstChildElement("compiler"); c; c = c->NextSiblingElement("compiler"))
    if (const char* a = c->Attribute("angle")) conv.radian = std::string(a) == "radian";
  conv.walk(root);

  if (!conv.excludes.empty()) {
    XMLElement* contact = root->FirstChildElement("contact");
    if (!contact) contact = add(doc, root, "contact", {});
    for (const auto& [a, b] : conv.excludes) add(doc, contact, "exclude", {{"body1", a}, {"body2", b}});
  }
  if (!conv.numerics.empty()) {
    XMLElement* custom = root->FirstChildElement("custom");
    if (!custom) custom = add(doc, root, "custom", {});
    for (const auto& [name, data] : conv.numerics) add(doc, custom, "numeric", {{"name", name}, {"data", data}});
  }
  // keyframes: qpos/qvel no longer fit
  for (XMLElement* k = root->FirstChildElement("keyframe"); k; k = k->NextSiblingElement("keyframe"))
    for (XMLElement* key = k->FirstChildElement("key"); key; key = key->NextSiblingElement("key"))
      for (const char* a : {"qpos", "qvel", "mpos", "mquat"}) key->DeleteAttribute(a);

  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace cosserat::bench
