// MJCF pre-processing (DESIGN.md sections 6-7): <include> expansion with file:line tracking, and
// the rewrite of every <cosserat> into proxy bodies, slide joints, capsules and sites, following
// the naming contract of mjcf.hpp.
//
// Pipeline (Preprocessor::run):
//   1. parse the text (tinyxml2), remember the file and line of every element (Origin);
//   2. expand <include file=...> recursively, relative to the main model's directory (as MuJoCo
//      does, nested includes too), cloning the included elements together with their origins;
//   3. collect the names of the user's bodies, joints, geoms and sites (collision checks);
//   4. walk the tree and replace each <cosserat> by its "<rod>/base" body (read_rod checks and
//      collects everything first, build_rod then generates the MuJoCo elements);
//   5. add the <contact><exclude> pairs, check the nesting depth, and print the document.
//
// Two MuJoCo 2.2.2 limits shape the output beyond mjcf.hpp's contract:
//   - a body takes at most 6 dofs: a section with more strain coordinates (e.g. GVS order 1 with
//     kl) puts its first joints on helper bodies "<rod>/s<i>/h<k>" chained just above the proxy, at
//     the same frame, with a negligible mass (see add_section_bodies);
//   - its XML parser (tinyxml2) refuses elements nested 100 deep, and each section nests one body:
//     a rod too long for that is a LoadError at the rod (see check_depth).
#include "mjcf.hpp"

#include "integrators.hpp"
#include "kinematics.hpp"

#include <tinyxml2.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>

namespace cosserat::mj {

LoadError::LoadError(const std::string& file_, int line_, const std::string& msg)
    : std::runtime_error(file_ + (line_ > 0 ? ":" + std::to_string(line_) : std::string()) + ": " + msg),
      file(file_),
      line(line_),
      message(msg) {}

namespace {

namespace fs = std::filesystem;
using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;
using tinyxml2::XMLNode;

using Attributes = std::vector<std::pair<std::string, std::string>>;  // name, verbatim value

// ------------------------------------------------------------------------------------------------
// Small utilities

// Where an element comes from (after include expansion).
struct Origin {
  std::string file;
  int line = 0;
};

// Shortest decimal text that reads back to the same double.
std::string fmt(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// %g: a value the message suggests (0.15, not 0.15000000000000002)
std::string fmt_g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// MuJoCo 2.2's default solimp of joint limits (dmin dmax width midpoint power)
constexpr const char* kDefaultSolimp = "0.9 0.95 0.001 0.5 2";

std::string fmt3(double x, double y, double z) { return fmt(x) + " " + fmt(y) + " " + fmt(z); }

bool is(const XMLElement* e, std::string_view name) { return e && name == e->Name(); }

std::vector<std::string> split_whitespace(std::string_view s) {
  std::vector<std::string> out;
  std::istringstream in{std::string(s)};
  for (std::string tok; in >> tok;) out.push_back(tok);
  return out;
}

// The text of a regular file (not a directory, device or pipe: /dev/zero would never end) of at
// most kMaxFileBytes; nullopt otherwise, with the reason in `why`.
constexpr std::uintmax_t kMaxFileBytes = 256u << 20;
std::optional<std::string> read_text_file(const std::string& path, std::string* why = nullptr) {
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (!ec && fs::exists(st) && !fs::is_regular_file(st)) {
    if (why) *why = fs::is_directory(st) ? "it is a directory" : "it is not a regular file";
    return std::nullopt;
  }
  if (const auto size = fs::file_size(path, ec); !ec && size > kMaxFileBytes) {
    if (why) *why = "it is larger than 256 MB";
    return std::nullopt;
  }
  if (why) why->clear();
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Canonical form of a path for include-cycle detection (the file need not exist).
std::string canonical_key(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? fs::path(path).lexically_normal().string() : p.string();
}

// ------------------------------------------------------------------------------------------------
// Reader: typed, checked access to the attributes of one element. Every error is a LoadError
// naming the element's file and line, the element and the attribute.

using OriginMap = std::unordered_map<const XMLElement*, Origin>;

class Reader {
 public:
  // `origins` locates child elements in messages about them.
  Reader(const XMLElement* e, Origin origin, const OriginMap& origins)
      : e_(e), origin_(std::move(origin)), origins_(origins) {}

  const XMLElement* element() const { return e_; }
  const Origin& origin() const { return origin_; }

  [[noreturn]] void fail(const std::string& msg) const {
    throw LoadError(origin_.file, origin_.line, "<" + std::string(e_->Name()) + ">: " + msg);
  }
  [[noreturn]] void fail_attr(const char* attr, const std::string& msg) const {
    fail("attribute '" + std::string(attr) + "' " + msg);
  }
  void check(bool ok, const char* attr, const std::string& msg) const {
    if (!ok) fail_attr(attr, msg);
  }

  // Any attribute outside `allowed` is an error.
  void allow_attributes(std::initializer_list<std::string_view> allowed) const {
    for (auto* a = e_->FirstAttribute(); a; a = a->Next())
      if (std::find(allowed.begin(), allowed.end(), a->Name()) == allowed.end())
        fail("unknown attribute '" + std::string(a->Name()) + "'");
  }
  // Any child element outside `allowed` is an error, reported at the child's line.
  void allow_children(std::initializer_list<std::string_view> allowed) const {
    for (auto* c = e_->FirstChildElement(); c; c = c->NextSiblingElement()) {
      if (std::find(allowed.begin(), allowed.end(), c->Name()) != allowed.end()) continue;
      const auto it = origins_.find(c);
      const Origin& o = it == origins_.end() ? origin_ : it->second;
      throw LoadError(o.file, o.line, "<" + std::string(e_->Name()) + ">: unknown child element <" +
                                          std::string(c->Name()) + ">");
    }
  }

  bool has(const char* attr) const { return e_->Attribute(attr) != nullptr; }

  std::string text(const char* attr, const std::string& fallback = "") const {
    const char* v = e_->Attribute(attr);
    return v ? v : fallback;
  }
  std::string required_text(const char* attr) const {
    const char* v = e_->Attribute(attr);
    if (!v) fail("missing attribute '" + std::string(attr) + "'");
    if (!*v) fail_attr(attr, "must not be empty");
    return v;
  }

  // The one number parser: between min_n and max_n whitespace-separated finite numbers, or
  // nullopt when the attribute is absent.
  std::optional<std::vector<double>> numbers(const char* attr, int min_n, int max_n) const {
    const char* v = e_->Attribute(attr);
    if (!v) return std::nullopt;
    std::vector<double> out;
    for (const std::string& tok : split_whitespace(v)) {
      char* end = nullptr;
      const double x = std::strtod(tok.c_str(), &end);
      // (strtod also reads hexadecimal: "0x10" had been taken as 16)
      if (end != tok.c_str() + tok.size() || !std::isfinite(x) || tok.find_first_of("xX") != std::string::npos)
        fail_attr(attr, "holds '" + tok + "', which is not a number");
      out.push_back(x);
    }
    const int n = static_cast<int>(out.size());
    if (n < min_n || n > max_n) {
      const std::string want = min_n == max_n ? std::to_string(min_n)
                                              : std::to_string(min_n) + " to " + std::to_string(max_n);
      fail_attr(attr, "needs " + want + (max_n == 1 ? " number" : " numbers") + ", got " +
                          std::to_string(n) + " ('" + v + "')");
    }
    return out;
  }
  double number(const char* attr, double fallback) const {
    const auto v = numbers(attr, 1, 1);
    return v ? (*v)[0] : fallback;
  }
  double required_number(const char* attr) const {
    if (!has(attr)) fail("missing attribute '" + std::string(attr) + "'");
    return number(attr, 0.0);
  }
  // An integer >= min_value.
  int integer(const char* attr, int fallback, int min_value) const {
    if (!has(attr)) return fallback;
    const double x = number(attr, 0.0);
    check(x == std::floor(x), attr, "must be an integer, got '" + text(attr) + "'");
    check(std::abs(x) < 1e9, attr, "is too large: " + text(attr) + " (at most 999999999)");
    check(x >= min_value, attr, "must be >= " + std::to_string(min_value) + ", got " + text(attr));
    return static_cast<int>(x);
  }
  bool boolean(const char* attr, bool fallback) const {
    if (!has(attr)) return fallback;
    const std::string v = text(attr);
    if (v == "true") return true;
    if (v == "false") return false;
    fail_attr(attr, "must be 'true' or 'false', got '" + v + "'");
  }
  // Copies attribute `attr` verbatim into `out` if present, after checking it holds between
  // min_n and max_n numbers (max_n = 0: any text).
  void pass_through(const char* attr, int min_n, int max_n, Attributes& out) const {
    if (!has(attr)) return;
    if (max_n > 0) numbers(attr, min_n, max_n);
    out.emplace_back(attr, text(attr));
  }

 private:
  const XMLElement* e_;
  Origin origin_;
  const OriginMap& origins_;
};

// ------------------------------------------------------------------------------------------------
// What a <cosserat> says, checked, before any MuJoCo element is generated.

constexpr const char* kComponents[6] = {"kx", "ky", "kz", "px", "py", "pz"};

struct RodSite {
  const XMLElement* element = nullptr;
  RodSiteDecl decl;
  int section = 0;
  Attributes attrs;  // size, rgba, type, group, class (verbatim)
};

struct RodInput {
  RodDecl decl;                     // name, file, line, spec, parent_body (generated lists later)
  Attributes frame;                 // pos and orientation of "<rod>/base", verbatim
  Attributes geom;                  // attributes of every capsule, verbatim
  int capsules = 2;                 // per section
  bool selfcollide = false;
  std::vector<double> section_end;  // X at the end of each section
  std::vector<RodSite> sites;       // user sites
  std::vector<XMLElement*> bodies;  // <body> children, moved under the last proxy
  std::vector<std::string> helpers; // generated helper bodies (sections with more than 6 dofs)
  // the rod's solreflimit / solimplimit for its strain limits (RodDecl::strain_range), verbatim
  Attributes limit;
};

// strain="name" or dofs="m m m m m m" (exclusive); `fallback` when neither is given.
StrainMask read_strain_mask(const Reader& r, const StrainMask& fallback) {
  if (r.has("strain") && r.has("dofs")) r.fail("attributes 'strain' and 'dofs' are exclusive");
  if (r.has("strain")) {
    const auto m = strain_mask_from_name(r.text("strain"));
    r.check(m.has_value(), "strain",
            "unknown strain name '" + r.text("strain") + "' (known: rigid spring pcc icc cc ikl kl sr)");
    return *m;
  }
  if (const auto d = r.numbers("dofs", 6, 6)) {
    StrainMask m{};
    for (int i = 0; i < 6; ++i) {
      r.check((*d)[i] == 0.0 || (*d)[i] == 1.0, "dofs",
              "must hold six 0/1 values, got '" + r.text("dofs") + "'");
      m[i] = (*d)[i] == 1.0;
    }
    return m;
  }
  return fallback;
}

// strainrange="lo hi" x 6 (kx ky kz px py pz) on <cosserat> or <section>: limits of the strain
// coordinates (deviations from the rest strain, as qpos: 1/m and dimensionless), each pair 0 0
// for none, lo <= 0 <= hi otherwise (the rest shape within them); MuJoCo joint limits on the
// section's strain joints. `sec` is the element's resolved section: a pair on a component that is
// not among its dofs, or on a GVS section (whose coordinates are Legendre coefficients, not
// strains), is refused here; `fallback` when the attribute is absent.
std::array<double, 12> read_strain_range(const Reader& r, const SectionSpec& sec, const std::array<double, 12>& fallback) {
  const auto v = r.numbers("strainrange", 12, 12);
  if (!v) return fallback;
  std::array<double, 12> range{};
  for (int c = 0; c < 6; ++c) {
    const double lo = (*v)[2 * c], hi = (*v)[2 * c + 1];
    range[2 * c] = lo, range[2 * c + 1] = hi;
    if (lo == 0.0 && hi == 0.0) continue;
    const std::string name = kComponents[c];
    r.check(lo < hi && lo <= 0.0 && hi >= 0.0, "strainrange",
            "pair " + std::to_string(c + 1) + " (" + name + ") is " + fmt(lo) + " " + fmt(hi) +
                ": it needs lo < hi with the rest strain within, lo <= 0 <= hi (the values are deviations from "
                "'reststrain'), or 0 0 for no limit");
    r.check(sec.dofs[c], "strainrange",
            "limits " + name + " (pair " + std::to_string(c + 1) + "), which is not among this section's strain dofs");
    r.check(sec.order == 0, "strainrange",
            "is for PCS sections (order 0): a GVS section's coordinates are Legendre coefficients, whose limits "
            "would not bound the strain along it");
  }
  return range;
}

// Upper bounds of counts that would otherwise only exhaust memory: Gauss points per section (the
// mass quadrature of order 20 GVS needs 22) and collision capsules per section.
constexpr int kMaxQuadrature = 64;
constexpr int kMaxCapsules = 100;

// Strain and material attributes shared by <cosserat> and <section>: each overrides `base`.
SectionSpec read_section_spec(const Reader& r, SectionSpec s) {
  s.dofs = read_strain_mask(r, s.dofs);
  s.order = r.integer("order", s.order, 0);
  r.check(s.order <= 20, "order", "must be <= 20");
  if (const auto v = r.numbers("reststrain", 6, 6)) {
    s.rest_strain = Eigen::Map<const Vec6>(v->data());
    // (a stretch of 0 had reached MuJoCo as capsules of zero length, a negative one loaded silently)
    r.check(s.rest_strain(3) > kCollapsedStretch, "reststrain",
            "has a rest axial stretch px (its 4th number) of " + fmt(s.rest_strain(3)) +
                ": it must be above " + fmt(kCollapsedStretch) +
                " (1 for a rod as long as its 'length'; at or below it a section has collapsed)");
  }
  s.material.density = r.number("density", s.material.density);
  r.check(s.material.density > 0, "density", "must be positive");
  s.material.young = r.number("young", s.material.young);
  r.check(s.material.young > 0, "young", "must be positive");
  // the shear modulus from Poisson's ratio, or given on its own (`shear`, for a torsional and shear
  // stiffness that no isotropic ratio gives: PyElastica's helical-buckling rod has GJ/EI = 0.587,
  // where 0.5 <= nu makes it at least 2/3); a section's own `poisson` overrides an inherited `shear`
  r.check(!(r.has("poisson") && r.has("shear")), "shear",
          "and 'poisson' both given: the shear modulus is G = E / (2 (1 + poisson)) or 'shear', not both");
  if (r.has("poisson")) s.material.shear = 0.0;
  s.material.poisson = r.number("poisson", s.material.poisson);
  r.check(s.material.poisson > -1.0 && s.material.poisson <= 0.5, "poisson",
          "must be in (-1, 0.5]; for a shear modulus that no such ratio gives, set 'shear' (G in Pa) instead");
  s.material.shear = r.number("shear", s.material.shear);
  r.check(!r.has("shear") || s.material.shear > 0, "shear", "must be positive (G in Pa)");
  s.material.viscosity = r.number("viscosity", s.material.viscosity);
  r.check(s.material.viscosity >= 0, "viscosity", "must be >= 0");
  // a tube (outside probe BZ: a nitinol manipulator's tube could not be described)
  s.material.hollow = r.number("hollow", s.material.hollow);
  r.check(s.material.hollow >= 0 && s.material.hollow <= 0.99, "hollow",
          "is the inner radius over the outer one: it must be in [0, 0.99] (0: a solid rod), got " + r.text("hollow"));
  if (r.text("quadrature") == "lobatto") {
    s.lobatto = true;
    s.quadrature = 0;
  } else if (r.text("quadrature") == "gauss") {  // the default rule, named: order + 2 Gauss points
    s.lobatto = false;
    s.quadrature = 0;
  } else if (r.has("quadrature")) {
    const std::string v = r.text("quadrature");
    r.check(v.find_first_not_of("0123456789+-.eE \t") == std::string::npos, "quadrature",
            "must be a number of Gauss points, 'gauss' (order + 2 of them, the default) or 'lobatto', got '" + v + "'");
    s.quadrature = r.integer("quadrature", s.quadrature, 1);
    r.check(s.quadrature <= kMaxQuadrature, "quadrature",
            "must be <= " + std::to_string(kMaxQuadrature) + " Gauss points (exact for polynomials of degree " +
                std::to_string(2 * kMaxQuadrature - 1) + "), got " + r.text("quadrature"));
    s.lobatto = false;
  }
  if (s.lobatto && s.order > 0) {  // on this element's quadrature, or inherited by a GVS section
    if (r.has("quadrature"))
      r.fail_attr("quadrature",
                  "'lobatto' (the Gauss-Lobatto mass rule) is for PCS sections (order 0); give a GVS section a Gauss point count");
    r.fail_attr("order", "must be 0 under quadrature=\"lobatto\" (the Gauss-Lobatto mass rule is for PCS sections); give "
                         "this section a Gauss point count");
  }
  // fewer Gauss points than Legendre modes: the mass quadrature sees no inertia in some strain
  // modes, a singular mass matrix (outside probe CA: MuJoCo's "Inertia matrix is too close to
  // singular" 13870 times in a run, modes at 6.5e8 Hz, all without a load message)
  if (s.quadrature > 0 && s.quadrature < s.order + 1 && mask_count(s.dofs) > 0)
    r.fail_attr(r.has("quadrature") ? "quadrature" : "order",
                "gives " + std::to_string(s.quadrature) + " Gauss points to a section of order " + std::to_string(s.order) +
                    ": the mass quadrature needs at least order + 1 (" + std::to_string(s.order + 1) +
                    ") points, or the mass matrix is singular in the higher strain modes (the default is order + 2)");
  return s;
}

// "file:line: <element>: ", the start of a warning about the element of `r`.
std::string where(const Reader& r) {
  return r.origin().file + ":" + std::to_string(r.origin().line) + ": <" + r.element()->Name() + ">: ";
}

// Values that load but describe no real rod. Refused: a section whose inertia or bending stiffness
// underflows the doubles (radius="1e-300", young="5e-324": a rod with no mass or no stiffness that
// ran without a word). Warned about (Preprocessed::warnings): moduli and densities outside those of
// real materials in SI units (a unit slip, e.g. MPa or g/cm^3). Each element is checked for the
// attributes it gives (a <section> inherits the checked values of its rod); read_rod also warns
// about radii below molecular sizes and rods thicker than they are long.
// A rest curvature whose radius 1/kappa is below the rod's radius folds the inner side of the rod
// onto itself (outside probe BL: a rest strain written in degrees, kappa = 90 1/m, loaded quietly).
void check_rest_curvature(const Reader& r, const SectionSpec& s, double r_max, std::vector<std::string>& warnings) {
  if (!r.has("reststrain")) return;
  const double kappa = std::hypot(s.rest_strain(1), s.rest_strain(2));
  if (kappa * r_max >= 1.0)
    warnings.push_back(where(r) + "reststrain bends the rod with curvature " + fmt_g(kappa) + " 1/m, a radius " +
                       fmt_g(1.0 / kappa) + " m below the rod's radius " + fmt_g(r_max) +
                       " m: its inner side folds onto itself; check the units (1/m, radians per metre)");
}

void check_section_scales(const Reader& r, const SectionSpec& s, double r_min, std::vector<std::string>& warnings) {
  const double I = M_PI * r_min * r_min * r_min * r_min / 4.0;  // second moment of area, thinnest end
  constexpr double kTiny = std::numeric_limits<double>::min();   // the smallest normal double
  if (I < kTiny)
    r.fail_attr("radius", "is too small: the section's second moment of area pi r^4/4 underflows (radius " +
                              fmt(r_min) + " m)");
  const bool rod = std::string_view(r.element()->Name()) == "cosserat";
  if (rod || r.has("density")) {
    r.check(s.material.density * I >= kTiny, "density",
            "is too small: the section's rotational inertia density pi r^4/4 underflows (density " +
                fmt(s.material.density) + " kg/m^3)");
    if (s.material.density < 1e-1 || s.material.density > 1e5)
      warnings.push_back(where(r) + "density " + fmt(s.material.density) +
                         " kg/m^3 is outside the densities of real solids (about 1 for aerogels to 2.3e4 for "
                         "osmium): check the units (kg/m^3)");
    else if (s.material.density < 50)  // (outside probe BL: silicone's 1.1 g/cm^3 loaded without a word)
      warnings.push_back(where(r) + "density " + fmt(s.material.density) +
                         " kg/m^3 is lighter than any solid but aerogels and the lightest foams (water 1000, "
                         "silicone about 1100): check the units (kg/m^3; " + fmt(s.material.density) +
                         " g/cm^3 is " + fmt(1e3 * s.material.density) + " kg/m^3)");
  }
  if (rod || r.has("young")) {
    r.check(s.material.young * I >= kTiny, "young",
            "is too small: the section's bending stiffness young pi r^4/4 underflows (young " +
                fmt(s.material.young) + " Pa)");
    if (s.material.young < 1.0 || s.material.young > 1e13)
      warnings.push_back(where(r) + "young " + fmt(s.material.young) +
                         " Pa is outside the moduli of real materials (about 10 Pa for the softest gels to 1.2e12 Pa "
                         "for diamond): check the units (Pa)");
    else if (s.material.young < 100)  // (outside probe BL: a silicone's 1 MPa as young="1" loaded quietly)
      warnings.push_back(where(r) + "young " + fmt(s.material.young) +
                         " Pa is softer than all but the softest gels (silicones and rubbers 1e5 to 1e8 Pa): check "
                         "the units (Pa; " + fmt(s.material.young) + " MPa is " + fmt(1e6 * s.material.young) + " Pa)");
  }
  if (r.has("shear")) {
    r.check(s.material.shear * I >= kTiny, "shear",
            "is too small: the section's torsional stiffness shear pi r^4/2 underflows (shear " +
                fmt(s.material.shear) + " Pa)");
    if (s.material.shear < 1.0 || s.material.shear > 1e13)
      warnings.push_back(where(r) + "shear " + fmt(s.material.shear) +
                         " Pa is outside the moduli of real materials: check the units (Pa)");
  }
}

// ------------------------------------------------------------------------------------------------
// Preprocessor: owns the parsed documents and the origin of every element.

class Preprocessor {
 public:
  Preprocessed run(const std::string& text, const std::string& path);

 private:
  // parsing and includes
  XMLDocument& parse(const std::string& text, const std::string& file);
  void record_origins(const XMLElement* e, const std::string& file);
  void expand_includes(XMLElement* parent, XMLDocument& doc, std::vector<std::string>& stack);
  void splice_include(XMLElement* include, XMLDocument& doc, std::vector<std::string>& stack);
  XMLNode* clone(const XMLNode* src, XMLDocument& doc);

  // names
  void collect_names(const XMLElement* e);
  void claim(const std::string& kind, const std::string& name, const Reader& r, bool user);
  void check_class(const Reader& r) const;

  // rods
  void rewrite(XMLElement* parent);
  XMLElement* replace_rod(XMLElement* parent, XMLElement* cosserat);
  RodInput read_rod(XMLElement* cosserat, const std::string& parent_body);
  void read_sections(const Reader& r, RodInput& rod);
  void read_sites(const Reader& r, RodInput& rod);
  XMLElement* build_rod(XMLDocument& doc, RodInput& rod);
  void add_excludes(const RodInput& rod);
  void map_lines(const XMLElement* root, Preprocessed& out) const;
  void emit_excludes(XMLDocument& doc, XMLElement* root);
  void check_depth(const XMLElement* root) const;
  void check_helper_references(const XMLElement* e) const;
  void check_custom_fields(const XMLElement* root) const;
  void check_options(const XMLElement* root) const;
  void check_size(const XMLElement* root) const;
  void check_finite(const XMLElement* e) const;
  void check_compiler(const XMLElement* root) const;

  Reader reader(const XMLElement* e) const { return Reader(e, origin(e), origins_); }
  const Origin& origin(const XMLElement* e) const;

  std::vector<std::unique_ptr<XMLDocument>> docs_;  // main document first; kept alive
  OriginMap origins_;
  std::set<std::pair<std::string, std::string>> names_;  // (kind, name) of MuJoCo objects
  std::set<std::string> classes_{"main"};                 // <default class=...> names
  std::map<std::string, Origin> rod_names_;
  std::set<std::string> declared_rods_;  // names of the <cosserat> elements (collect_names)
  std::vector<RodDecl> rods_;
  std::vector<std::string> warnings_;  // Preprocessed::warnings
  fs::path main_dir_;                   // the main model's directory: includes are relative to it
  // the generated helper bodies (sections with more than 6 dofs), each with its section's proxy
  std::map<std::string, std::string> helper_proxy_;
  std::vector<std::pair<std::string, std::string>> excludes_;
};

const Origin& Preprocessor::origin(const XMLElement* e) const {
  static const Origin unknown{"<generated>", 0};
  const auto it = origins_.find(e);
  return it == origins_.end() ? unknown : it->second;
}

// --- parsing and includes -----------------------------------------------------------------------

namespace {
// tinyxml2's parse error in words, with its own text after them (outside probe AD: a repeated
// attribute read "Error=XML_ERROR_PARSING_ATTRIBUTE ErrorID=7 (0x7) Line number=1: XMLElement
// name=cosserat").
std::string xml_error_message(const XMLDocument& doc) {
  const char* what = nullptr;
  switch (doc.ErrorID()) {
    case tinyxml2::XML_ERROR_PARSING_ATTRIBUTE:
      what = "malformed XML: an attribute could not be read (given twice in one element, a value "
             "without quotes, or a stray character)";
      break;
    case tinyxml2::XML_ERROR_MISMATCHED_ELEMENT:
      what = "malformed XML: a closing tag does not match the element it closes";
      break;
    case tinyxml2::XML_ERROR_PARSING_ELEMENT:
      what = "malformed XML: an element could not be read (an unclosed tag, or an element left open "
             "at the end of the file)";
      break;
    case tinyxml2::XML_ERROR_EMPTY_DOCUMENT: what = "the file holds no XML element"; break;
    default: what = "malformed XML";
  }
  return std::string(what) + " [" + doc.ErrorStr() + "]";
}
}  // namespace

// Parses `text` (named `file` in messages) into a new document; records element origins.
XMLDocument& Preprocessor::parse(const std::string& text, const std::string& file) {
  // XML holds no NUL character, and tinyxml2 stops reading at one: what follows it would be
  // ignored without a word (outside fuzzing: a valid model, a NUL, then a bad rod loaded)
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw LoadError(file, 1 + static_cast<int>(std::count(text.begin(), text.begin() + nul, '\n')),
                    "a NUL byte: XML holds none (binary data, or a file saved in UTF-16?)");
  auto doc = std::make_unique<XMLDocument>();
  if (doc->Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS)
    throw LoadError(file, doc->ErrorLineNum(), xml_error_message(*doc));
  if (!doc->RootElement()) throw LoadError(file, 1, "no root element");
  record_origins(doc->RootElement(), file);
  docs_.push_back(std::move(doc));
  return *docs_.back();
}

void Preprocessor::record_origins(const XMLElement* e, const std::string& file) {
  for (; e; e = e->NextSiblingElement()) {
    origins_[e] = Origin{file, e->GetLineNum()};
    record_origins(e->FirstChildElement(), file);
  }
}

// Deep copy of `src` into `doc`, carrying the origins of its elements along.
XMLNode* Preprocessor::clone(const XMLNode* src, XMLDocument& doc) {
  XMLNode* copy = src->ShallowClone(&doc);
  if (const XMLElement* e = src->ToElement()) origins_[copy->ToElement()] = origin(e);
  for (const XMLNode* c = src->FirstChild(); c; c = c->NextSibling()) copy->InsertEndChild(clone(c, doc));
  return copy;
}

// Replaces every <include> below `parent` (recursively). `stack` holds the canonical paths of the
// files being expanded (cycle detection).
void Preprocessor::expand_includes(XMLElement* parent, XMLDocument& doc, std::vector<std::string>& stack) {
  XMLElement* c = parent->FirstChildElement();
  while (c) {
    XMLElement* next = c->NextSiblingElement();  // spliced content is already expanded
    if (is(c, "include"))
      splice_include(c, doc, stack);
    else
      expand_includes(c, doc, stack);
    c = next;
  }
}

// Replaces one <include file=...> by the children of the included file's root element.
void Preprocessor::splice_include(XMLElement* include, XMLDocument& doc, std::vector<std::string>& stack) {
  const Reader r = reader(include);
  r.allow_attributes({"file"});
  r.allow_children({});
  const std::string name = r.required_text("file");
  // MuJoCo 2.2.2 reads every include, nested ones too, relative to the main model's directory
  // (outside probe P: relative to the including file, a nested include loaded another file)
  const std::string path = (main_dir_ / name).lexically_normal().string();
  const std::string key = canonical_key(path);

  // cycles and missing files are errors at the <include>
  if (std::find(stack.begin(), stack.end(), key) != stack.end()) {
    std::string chain;
    for (const auto& s : stack) chain += fs::path(s).filename().string() + " -> ";
    r.fail("include cycle: " + chain + fs::path(key).filename().string());
  }
  std::string why;
  const auto text = read_text_file(path, &why);
  if (!text) r.fail("cannot open include file '" + path + "'" + (why.empty() ? "" : ": " + why));

  // parse and expand the included file in its own document, then clone its content here
  XMLDocument& inc = parse(*text, path);
  if (inc.RootElement()->NextSiblingElement())
    throw LoadError(path, origin(inc.RootElement()->NextSiblingElement()).line,
                    "an included file must have a single top-level element");
  stack.push_back(key);
  expand_includes(inc.RootElement(), inc, stack);
  stack.pop_back();
  XMLNode* after = include;
  for (const XMLNode* c = inc.RootElement()->FirstChild(); c; c = c->NextSibling())
    after = include->Parent()->InsertAfterChild(after, clone(c, doc));
  include->Parent()->DeleteChild(include);
}

// --- names --------------------------------------------------------------------------------------

constexpr std::string_view kNamedKinds[] = {"body", "joint", "geom", "site"};

// Records the default class names, and the names of the user's bodies, joints, geoms and sites
// (except the sites of a <cosserat>, which are claimed with their rod).
void Preprocessor::collect_names(const XMLElement* e) {
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (is(c, "default") && c->Attribute("class")) classes_.insert(c->Attribute("class"));
    if (is(c, "site") && is(e, "cosserat")) continue;
    if (is(c, "cosserat") && c->Attribute("name")) declared_rods_.insert(c->Attribute("name"));
    const std::string kind = is(c, "freejoint") ? "joint" : c->Name();
    if (c->Attribute("name") &&
        std::find(std::begin(kNamedKinds), std::end(kNamedKinds), kind) != std::end(kNamedKinds))
      names_.emplace(kind, c->Attribute("name"));
    collect_names(c);
  }
}

// Reserves a name of a MuJoCo object; a repeated name is an error at `r`'s element.
void Preprocessor::claim(const std::string& kind, const std::string& name, const Reader& r, bool user) {
  if (names_.emplace(kind, name).second) return;
  if (user) r.fail(kind + " name '" + name + "' is already used");
  r.fail("generated " + kind + " name '" + name + "' is already used");
}

// The class attribute of a generated geom or site must name a default class.
void Preprocessor::check_class(const Reader& r) const {
  if (r.has("class") && !classes_.count(r.text("class")))
    r.fail_attr("class", "names no <default class=...>: '" + r.text("class") + "'");
}

// --- rods: reading ------------------------------------------------------------------------------

// Checks everything a <cosserat> says and collects it; no MuJoCo element is generated here.
// How to put a body partway along a rod (outside probe CE: the workaround gives the same motion).
constexpr const char* kMidRodBody =
    "For a body partway along a rod, split the rod there: the first part's <cosserat> carries a <body> at its "
    "tip, which holds the body's geoms, joints or sites and a second <cosserat> for the rest of the rod";

RodInput Preprocessor::read_rod(XMLElement* cosserat, const std::string& parent_body) {
  const Reader r = reader(cosserat);
  r.allow_attributes({"name", "pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "length",
                      "sections", "strain", "dofs", "order", "reststrain", "radius", "density",
                      "young", "poisson", "shear", "viscosity", "hollow", "quadrature", "capsules", "selfcollide", "drag", "wavelength",
                      "strainrange", "solreflimit", "solimplimit",
                      "contype", "conaffinity", "condim", "friction", "solref", "solimp", "margin",
                      "gap", "rgba", "group", "material", "class"});
  r.allow_children({"site", "body", "section"});

  RodInput rod;
  RodDecl& d = rod.decl;
  d.name = r.required_text("name");
  d.file = r.origin().file;
  d.line = r.origin().line;
  d.parent_body = parent_body;

  // base frame: pos and at most one orientation, copied verbatim
  r.pass_through("pos", 3, 3, rod.frame);
  int orientations = 0;
  for (auto [attr, n] : {std::pair{"quat", 4}, {"euler", 3}, {"axisangle", 4}, {"xyaxes", 6}, {"zaxis", 3}}) {
    if (!r.has(attr)) continue;
    if (++orientations > 1)
      r.fail_attr(attr, "conflicts with another orientation attribute (use at most one of quat, euler, "
                        "axisangle, xyaxes, zaxis)");
    r.pass_through(attr, n, n, rod.frame);
  }

  // shape
  RodSpec& spec = d.spec;
  spec.name = d.name;
  spec.length = r.required_number("length");
  // sizes beyond 1e6 m overflow the section's inertia (radius 1e100: an internal error without a line)
  constexpr double kMaxSize = 1e6;
  r.check(spec.length > 0, "length", "must be positive, got " + r.text("length"));
  r.check(spec.length <= kMaxSize, "length", "must be at most 1e6 m, got " + r.text("length"));
  if (const auto rad = r.numbers("radius", 1, 2)) {
    for (double x : *rad) r.check(x > 0, "radius", "must be positive, got '" + r.text("radius") + "'");
    for (double x : *rad) r.check(x <= kMaxSize, "radius", "must be at most 1e6 m, got '" + r.text("radius") + "'");
    spec.radius_base = rad->front();
    spec.radius_tip = rad->back();
  } else {
    spec.radius_tip = spec.radius_base;
  }

  // strain, material and sections
  SectionSpec defaults;
  defaults.dofs = *strain_mask_from_name("kl");
  spec.section = read_section_spec(r, defaults);
  spec.section.length = 0.0;
  const double r_min = std::min(spec.radius_base, spec.radius_tip);
  check_section_scales(r, spec.section, r_min, warnings_);
  check_rest_curvature(r, spec.section, std::max(spec.radius_base, spec.radius_tip), warnings_);
  if (r_min < 1e-9)
    warnings_.push_back(where(r) + "radius " + fmt(r_min) +
                        " m is below molecular sizes (a bacterial flagellum's filament is about 1e-8 m): check the "
                        "units (m)");
  if (2.0 * std::max(spec.radius_base, spec.radius_tip) > spec.length)
    warnings_.push_back(where(r) + "the rod is thicker than it is long (diameter " +
                        fmt(2.0 * std::max(spec.radius_base, spec.radius_tip)) + " m, length " + fmt(spec.length) +
                        " m): the rod theory describes slender bodies, its results for this one are not physical");
  read_sections(r, rod);

  // fluid (plugin/mujoco/fluid.hpp)
  if (const auto v = r.numbers("drag", 1, 3)) {
    if (v->size() == 1)
      r.check((*v)[0] == 0.0, "drag", "needs 'c_t c_n [c_rot]', or '0' for no fluid force, got '" + r.text("drag") + "'");
    else
      for (double x : *v) r.check(x > 0, "drag", "coefficients must be positive, got '" + r.text("drag") + "'");
    d.drag = *v;
  }
  d.wavelength = r.number("wavelength", 0.0);
  r.check(!r.has("wavelength") || d.wavelength > 0, "wavelength", "must be positive, got " + r.text("wavelength"));
  r.check(!(r.has("wavelength") && r.has("drag")), "wavelength", "conflicts with 'drag' (give one of them)");

  // capsules and collision options
  // (a GVS section with fewer than order + 2 is warned about once compiled: warn_gvs_capsules)
  rod.capsules = r.integer("capsules", 2, 1);
  r.check(rod.capsules <= kMaxCapsules, "capsules",
          "must be <= " + std::to_string(kMaxCapsules) + " per section, got " + r.text("capsules"));
  rod.selfcollide = r.boolean("selfcollide", false);
  // the strain limits' softness, for every limited strain joint (MuJoCo's joint solreflimit and
  // solimplimit; its defaults otherwise)
  for (auto [attr, lo, hi] : {std::tuple{"solreflimit", 2, 2}, {"solimplimit", 3, 5}}) {
    r.check(!r.has(attr) || r.has("strainrange") || std::any_of(rod.decl.strain_range.begin(), rod.decl.strain_range.end(),
                                                                 [](const auto& a) { return a != std::array<double, 12>{}; }),
            attr, "is given, but no strain is limited (strainrange)");
    r.pass_through(attr, lo, hi, rod.limit);
  }
  // a solimplimit of 3 or 4 numbers: MuJoCo takes the rest from the joint's class, so the rest of
  // MuJoCo's default (kDefaultSolimp) is written out here, never a <default><joint>'s
  for (auto& [name, value] : rod.limit)
    if (name == "solimplimit") {
      std::istringstream given(value), fallback(kDefaultSolimp);
      std::string word;
      while (given >> word) fallback >> word;  // (skips as many of the default's numbers as were given)
      while (fallback >> word) value += " " + word;
    }
  for (auto [attr, lo, hi] : {std::tuple{"contype", 1, 1}, {"conaffinity", 1, 1}, {"condim", 1, 1},
                              {"friction", 1, 3}, {"solref", 2, 2}, {"solimp", 3, 5}, {"margin", 1, 1},
                              {"gap", 1, 1}, {"rgba", 4, 4}, {"group", 1, 1}, {"material", 0, 0},
                              {"class", 0, 0}})
    r.pass_through(attr, lo, hi, rod.geom);
  check_class(r);

  // children: sites, bodies (sections were read above)
  read_sites(r, rod);
  for (XMLElement* c = cosserat->FirstChildElement("body"); c; c = c->NextSiblingElement("body")) {
    // (outside probe CE: MuJoCo's "unrecognized attribute: 'at'" did not say what to do)
    if (c->Attribute("at"))
      reader(c).fail_attr("at", std::string("is not accepted on a <body>: a body inside <cosserat> is carried at the "
                                            "rod's tip. ") + kMidRodBody);
    rod.bodies.push_back(c);
  }
  return rod;
}

// The shortest section, relative to its rod's length.
constexpr double kMinSectionFraction = 1e-6;

// Fills spec.overrides (one fully resolved SectionSpec per section) and rod.section_end, from
// `sections` or the <section> children.
void Preprocessor::read_sections(const Reader& r, RodInput& rod) {
  RodSpec& spec = rod.decl.spec;
  const int n_attr = r.integer("sections", 0, 1);

  // one SectionSpec per section: the rod's values, overridden by each <section>
  std::vector<SectionSpec>& secs = spec.overrides;
  std::vector<bool> sized;
  std::vector<const XMLElement*> elements;  // each section's <section> (none: the rod's attributes)
  const std::array<double, 12> rod_range = read_strain_range(r, spec.section, {});
  for (const XMLElement* c = r.element()->FirstChildElement("section"); c;
       c = c->NextSiblingElement("section")) {
    elements.push_back(c);
    const Reader s = reader(c);
    s.allow_attributes({"length", "strain", "dofs", "order", "reststrain", "density", "young", "poisson", "shear",
                        "viscosity", "hollow", "quadrature", "strainrange"});
    if (const XMLElement* b = c->FirstChildElement("body"))
      reader(b).fail(std::string("a <body> inside a <section> is not supported. ") + kMidRodBody);
    s.allow_children({});
    SectionSpec ss = read_section_spec(s, spec.section);
    // the rod's strain range reaches the components this section has; its own is checked against it
    std::array<double, 12> inherited = rod_range;
    for (int k = 0; k < 6; ++k)
      if (!ss.dofs[k]) inherited[2 * k] = inherited[2 * k + 1] = 0.0;
    const std::array<double, 12> range = read_strain_range(s, ss, inherited);
    s.check(s.has("strainrange") || ss.order == 0 || range == std::array<double, 12>{}, "order",
            "makes this a GVS section, which the rod's strainrange cannot limit (its coordinates are Legendre "
            "coefficients): give the section strainrange=\"0 0 0 0 0 0 0 0 0 0 0 0\" or order 0");
    rod.decl.strain_range.push_back(range);
    check_section_scales(s, ss, std::min(spec.radius_base, spec.radius_tip), warnings_);
    check_rest_curvature(s, ss, std::max(spec.radius_base, spec.radius_tip), warnings_);
    ss.length = s.number("length", 0.0);
    s.check(!s.has("length") || ss.length > 0, "length", "must be positive, got " + s.text("length"));
    secs.push_back(ss);
    sized.push_back(s.has("length"));
  }
  // each section nests one body: a rod of twice the parser's depth limit is refused here, before
  // allocating its sections (sections="999999999" exhausted memory) and generating their
  // O(sections^2) collision exclusions (check_depth, after the rewrite, gives the exact limit of
  // the rods that come closer)
  // (a section of more than 6 dofs nests one body per 6: outside probe BB's 60 sections of order
  // 20 and 126 dofs, 1260 bodies deep, took 2.8 GB and 6 s to be refused at check_depth, 95 of them
  // more than 8 GB)
  constexpr int kDepthLimit = TINYXML2_MAX_ELEMENT_DEPTH - 1;
  const int requested = secs.empty() ? std::max(n_attr, 1) : static_cast<int>(secs.size());
  auto bodies_of = [](const SectionSpec& sec) {
    int dofs = 0;
    for (int c = 0; c < 6; ++c) dofs += sec.dofs[c] ? sec.order + 1 : 0;
    return std::max(1, (dofs + 5) / 6);
  };
  long long depth = 0;
  if (secs.empty())
    depth = static_cast<long long>(requested) * bodies_of(spec.section);
  else
    for (const SectionSpec& sec : secs) depth += bodies_of(sec);
  if (secs.empty()) {
    if (depth < 2 * kDepthLimit) {
      secs.assign(requested, spec.section);
      rod.decl.strain_range.assign(requested, rod_range);
    }
    sized.assign(secs.size(), false);
  } else if (n_attr > 0 && n_attr != static_cast<int>(secs.size())) {
    r.fail_attr("sections", "is " + std::to_string(n_attr) + " but there are " + std::to_string(secs.size()) +
                                " <section> children");
  }
  spec.sections = requested;
  // (outside probe BL: a newcomer's soft cantilever without `sections` drooped 29% short of the
  // converged tip drop under its weight, without a word)
  // (not on the constant-curvature sets and the spring, whose one section is the model the user
  // chose: outside probe BO; the sets pcc, icc and cc, by name or by their dofs masks: outside
  // probe BQ)
  const auto& dofs = spec.section.dofs;
  const bool bends = dofs[0] || dofs[1] || dofs[2];
  constexpr const char* kArcSets[] = {"pcc", "icc", "cc"};
  const bool arc_model = std::any_of(std::begin(kArcSets), std::end(kArcSets),
                                     [&](const char* set) { return strain_mask_from_name(set) == dofs; });
  if (elements.empty() && !r.has("sections") && bends && !arc_model && spec.section.order == 0)
    warnings_.push_back(where(r) + "sections not given: one PCS section, whose strain is constant along the rod (it "
                                   "bends into a circular arc only); give sections=\"N\" (a soft cantilever under its "
                                   "weight: 4 sections within 5% of the converged tip drop, 16 within 0.3%) or order=\"N\"");
  if (depth >= 2 * kDepthLimit) {
    const int per = static_cast<int>((depth + requested - 1) / requested);  // bodies per section, at most
    const std::string why =
        per == 1 ? ", but each section nests one body and MuJoCo 2.2.2's XML parser stops at " +
                       std::to_string(kDepthLimit) + " nested elements: use at most about " +
                       std::to_string(kDepthLimit - 4) + " sections (fewer inside nested bodies)"
                 : ", nesting " + std::to_string(depth) +
                       " bodies (one per 6 strain dofs of a section: a section of order n has n + 1 per strain "
                       "component), but MuJoCo 2.2.2's XML parser stops at " +
                       std::to_string(kDepthLimit) + " nested elements: use fewer sections or a lower order";
    if (elements.empty()) r.fail_attr("sections", "is " + std::to_string(spec.sections) + why);
    r.fail("the rod has " + std::to_string(spec.sections) + " <section> children" + why);
  }

  // lengths: the given ones, the rest shared evenly; they must add up to the rod length
  double given = 0.0;
  int unsized = 0;
  for (std::size_t i = 0; i < secs.size(); ++i) {
    if (sized[i])
      given += secs[i].length;
    else
      ++unsized;
  }
  const double L = spec.length, tol = 1e-9 * L;
  // (12 digits: the tolerance shows, the sum's rounding does not; outside probe BB read
  // "add up to 0.30000000000000004")
  auto digits12 = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.12g", v);
    return std::string(b);
  };
  if (unsized == 0 && std::abs(given - L) > tol)
    r.fail("section lengths add up to " + digits12(given) + ", not the rod length " + digits12(L));
  if (unsized > 0 && given >= L - tol)
    r.fail("section lengths add up to " + digits12(given) + ", leaving nothing of the rod length " + digits12(L) +
           " for the sections without a length");
  double X = 0.0;
  std::size_t coils = 0, first_coil = 0;  // sections coiling through more than a turn at rest
  double most_turns = 0.0;
  for (std::size_t i = 0; i < secs.size(); ++i) {
    if (!sized[i]) secs[i].length = (L - given) / unsized;
    // a section shorter than a millionth of the rod: no physics to resolve there, and its end
    // abscissa is lost in the rounding of its start's (probe N: 1e-300 gave an internal error)
    if (secs[i].length < kMinSectionFraction * L) {
      const std::string msg = "section " + std::to_string(i) + " is " + fmt(secs[i].length) +
                              " long, less than " + fmt(kMinSectionFraction) + " of the rod length " + fmt(L);
      if (i < elements.size()) reader(elements[i]).fail(msg);
      r.fail(msg);
    }
    X += secs[i].length;
    rod.section_end.push_back(i + 1 == secs.size() ? L : X);
    // the Gauss-Lobatto mass rule's end points: singular tangent operator at whole turns
    const double turn = secs[i].rest_strain.head<3>().norm() * secs[i].length;
    if (secs[i].lobatto && turn >= M_PI) {
      char turns[32];
      std::snprintf(turns, sizeof turns, "%.2f", turn / (2 * M_PI));
      const std::string msg = "section " + std::to_string(i) + " bends through " + turns +
                              " turns at rest: quadrature=\"lobatto\" is for sections bending less than half a turn "
                              "(its mass points at the section ends sit near a whole turn, where the tangent operator "
                              "is singular); use more sections or Gauss points (quadrature=\"2\")";
      if (i < elements.size()) reader(elements[i]).fail(msg);
      r.fail(msg);
    }
    // a coil in one section: its rest shape is exact, its motion one strain over the whole coil
    // (outside probe CD: one section holding a 5-turn helix, its first frequencies 23-49% off those
    // of 40 sections, loaded without a word)
    if (const double bend = std::hypot(secs[i].rest_strain(1), secs[i].rest_strain(2)) * secs[i].length; bend > 2 * M_PI) {
      if (coils == 0) first_coil = i;
      ++coils;
      most_turns = std::max(most_turns, bend / (2 * M_PI));
    }
  }
  if (coils > 0) {
    char turns[32];
    std::snprintf(turns, sizeof turns, "%.3g", most_turns);
    warnings_.push_back(where(first_coil < elements.size() ? reader(elements[first_coil]) : r) +
                        (coils == 1 ? "section " + std::to_string(first_coil) + " coils"
                                    : std::to_string(coils) + " sections (the first: " + std::to_string(first_coil) +
                                          ") coil") +
                        " through " + (coils == 1 ? "" : "up to ") + turns +
                        " turns at rest: the rest shape is exact, but a section deforms with one strain (or one "
                        "strain polynomial) over its whole coil, and frequencies and deflections can be far off (one "
                        "section holding a 5-turn helix: first frequencies 23-49% off); give a coil several sections "
                        "per turn (a convergence study in sections tells how many)");
  }
}

// User <site name=... at=X pos=...> children: abscissa, offset, section, pass-through attributes.
void Preprocessor::read_sites(const Reader& r, RodInput& rod) {
  const double L = rod.decl.spec.length;
  for (const XMLElement* c = r.element()->FirstChildElement("site"); c; c = c->NextSiblingElement("site")) {
    const Reader s = reader(c);
    // orientation attributes are refused with the reason (outside probe AD: a bare "unknown
    // attribute 'euler'" left the user guessing)
    for (const char* a : {"quat", "euler", "axisangle", "xyaxes", "zaxis", "fromto"})
      if (s.has(a))
        s.fail_attr(a, "is not accepted on a rod site: its frame is the rod's cross-section frame at `at` "
                       "(x along the centre line), offset by `pos` in it; put an oriented site on a <body> at "
                       "the rod's tip or on a rigid body instead");
    s.allow_attributes({"name", "at", "pos", "size", "rgba", "type", "group", "class"});
    s.allow_children({});
    RodSite site;
    site.element = c;
    site.decl.name = s.required_text("name");
    site.decl.X = s.required_number("at");
    s.check(site.decl.X >= 0 && site.decl.X <= L, "at",
            "must be in [0, " + fmt(L) + "] (the rod length), got " + s.text("at"));
    if (const auto p = s.numbers("pos", 2, 3))
      site.decl.pos = p->size() == 2 ? Vec3(0, (*p)[0], (*p)[1]) : Vec3((*p)[0], (*p)[1], (*p)[2]);
    // (outside probe BL: pos="0.05 0.008 0" at 0.1 loaded quietly, the site 5 cm ahead of its
    // cross-section, rigidly, where a user had meant the material point at 0.15)
    // (beyond the rod's ends a rigid offset is all there is)
    if (const double along = site.decl.X + site.decl.pos.x(); site.decl.pos.x() != 0.0 && along >= 0 && along <= L)
      warnings_.push_back(where(s) + "pos has " + fmt(site.decl.pos.x()) +
                          " along the centre line: the site rides rigidly with the cross-section at at=\"" +
                          fmt(site.decl.X) + "\", not with the material point that far along the rod (which the "
                          "rod's bending moves); give at=\"" + fmt_g(along) +
                          "\" and pos=\"" + fmt(site.decl.pos.y()) + " " + fmt(site.decl.pos.z()) + "\" for that point");
    // the section containing X; on a boundary, the earlier one
    while (site.section + 1 < static_cast<int>(rod.section_end.size()) &&
           site.decl.X > rod.section_end[site.section] + 1e-9 * L)
      ++site.section;
    s.pass_through("size", 1, 3, site.attrs);
    s.pass_through("rgba", 4, 4, site.attrs);
    s.pass_through("type", 0, 0, site.attrs);
    s.pass_through("group", 1, 1, site.attrs);
    s.pass_through("class", 0, 0, site.attrs);
    check_class(s);
    rod.sites.push_back(std::move(site));
  }
}

// --- rods: generating ---------------------------------------------------------------------------

// A new element with `attrs`, then the verbatim `extra` ones.
XMLElement* new_element(XMLDocument& doc, const char* tag, const Attributes& attrs,
                        const Attributes& extra = {}) {
  XMLElement* e = doc.NewElement(tag);
  for (const auto& [k, v] : attrs) e->SetAttribute(k.c_str(), v.c_str());
  for (const auto& [k, v] : extra) e->SetAttribute(k.c_str(), v.c_str());
  return e;
}

// "pos" and "quat" attributes of a pose (shortest round-trip decimals: MuJoCo's compiler reads the
// same doubles back, up to its quaternion normalisation).
Attributes pose_attributes(const SE3& g) {
  const Eigen::Quaterniond q(g.R);
  return {{"pos", fmt3(g.u.x(), g.u.y(), g.u.z())}, {"quat", fmt(q.w()) + " " + fmt3(q.x(), q.y(), q.z())}};
}

XMLElement* new_slide_joint(XMLDocument& doc, const std::string& name, const Attributes& limit) {
  return new_element(doc, "joint",
                     {{"name", name}, {"type", "slide"}, {"pos", "0 0 0"}, {"axis", "1 0 0"},
                      {"limited", "false"}, {"stiffness", "0"}, {"damping", "0"}, {"armature", "1"},
                      {"frictionloss", "0"}, {"ref", "0"}, {"springref", "0"},
                      // nor a <default>'s range and margin (outside probe P: a program setting
                      // jnt_limited from C inherited a class's range)
                      {"range", "0 0"}, {"margin", "0"},
                      // MuJoCo's compiler sets stiffness and damping from a positive springdamper
                      // (a user <default>'s), overriding the two above
                      {"springdamper", "0 0"},
                      // the strain limits' softness is the rod's or MuJoCo's default, never a
                      // <default><joint>'s (outside probe BQ: a main default's solreflimit moved a
                      // limited rod's resting tip by 0.12 m); `limit` replaces these
                      {"solreflimit", "0.02 1"}, {"solimplimit", kDefaultSolimp}},
                     limit);  // strainrange: limited, range, and the rod's solreflimit / solimplimit
}

// The bodies of one section under `parent`: normally just the proxy `prefix`, at pose `offset` in it,
// with all the section's slide joints and the explicit inertia the compiler requires of moving
// bodies (the coupling zeroes it). MuJoCo 2.2.2 refuses more than 6 dofs in a body, so a section
// with more joints gets a chain of helper bodies "<prefix>/h<k>" at the same frame above the proxy
// (6 joints each, in dof order, the proxy keeping the rest). Proxies and helpers get a unit mass
// and the slide joints a unit armature so that MuJoCo's compiler accepts them (the coupling
// zeroes both: all rod inertia comes from the solver); helper names are appended to `helpers`.
// Returns the proxy.
XMLElement* add_section_bodies(XMLDocument& doc, XMLElement* parent, const std::string& prefix, const SE3& offset,
                               const std::vector<std::string>& joints, const std::vector<Attributes>& limits,
                               std::vector<std::string>& helpers) {
  constexpr std::size_t kMaxDofs = 6;
  const std::size_t nbodies = joints.empty() ? 1 : (joints.size() + kMaxDofs - 1) / kMaxDofs;
  XMLElement* body = nullptr;
  for (std::size_t b = 0; b < nbodies; ++b) {
    const bool proxy = b + 1 == nbodies;
    const std::string name = proxy ? prefix : prefix + "/h" + std::to_string(b);
    body = new_element(doc, "body", {{"name", name}}, b == 0 ? pose_attributes(offset) : Attributes{});
    body->InsertEndChild(new_element(doc, "inertial",
                                     {{"pos", "0 0 0"},
                                      {"mass", "1"},
                                      {"diaginertia", "1 1 1"}}));
    for (std::size_t j = b * kMaxDofs; j < std::min(joints.size(), (b + 1) * kMaxDofs); ++j)
      body->InsertEndChild(new_slide_joint(doc, joints[j], limits[j]));
    if (!proxy) helpers.push_back(name);
    parent->InsertEndChild(body);
    parent = body;
  }
  return body;
}

// Generates "<rod>/base" with its proxy chain, joints, capsules and sites, moves the <body>
// children under the last proxy, and fills the generated lists of rod.decl.
XMLElement* Preprocessor::build_rod(XMLDocument& doc, RodInput& rod) {
  RodDecl& d = rod.decl;
  const RodSpec& spec = d.spec;
  const std::string& n = d.name;

  // base body and site
  XMLElement* base = new_element(doc, "body", {{"name", n + "/base"}}, rod.frame);
  base->InsertEndChild(new_element(doc, "site", {{"name", n + "/base"}, {"pos", "0 0 0"}}));
  d.sites.push_back(RodSiteDecl{n + "/base", 0.0, Vec3::Zero()});

  // MuJoCo's compiled model at qpos0 (strain coordinates zero) is the rod's rest shape: proxies,
  // capsules and sites are placed where the rod puts them at rest, so that what MuJoCo computes
  // there itself (equality constraints' relative poses, tendon rest lengths, tendon and actuator
  // lengths at qpos0, the model's extent) is the rod's
  cosserat::Model rest_model;
  rest_model.add_rod(-1, SE3::Identity(), spec);
  rest_model.finalize();
  cosserat::Data rest(rest_model);
  cosserat::fwd_position(rest_model, rest);
  auto rest_pose = [&](double X) { return cosserat::rod_pose(rest_model, rest, 0, X); };
  SE3 start = SE3::Identity();  // the section's start frame (the base, or the previous proxy)

  XMLElement* parent = base;
  double X0 = 0.0;
  for (int i = 0; i < spec.sections; ++i) {
    const SectionSpec& sec = spec.overrides[i];
    const double Xe = rod.section_end[i];
    const std::string prefix = n + "/s" + std::to_string(i);

    // slide joint names in core dof order (component-major, then Legendre degree), and the limits
    // of a PCS section's (strainrange)
    std::vector<std::string> joints;
    std::vector<Attributes> limits;
    for (int c = 0; c < 6; ++c)
      for (int k = 0; sec.dofs[c] && k <= sec.order; ++k) {
        joints.push_back(prefix + "/" + kComponents[c] + (sec.order == 0 ? "" : std::to_string(k)));
        const double lo = rod.decl.strain_range[i][2 * c], hi = rod.decl.strain_range[i][2 * c + 1];
        limits.emplace_back();
        if (lo == 0.0 && hi == 0.0) continue;
        limits.back() = {{"limited", "true"}, {"range", fmt(lo) + " " + fmt(hi)}};
        limits.back().insert(limits.back().end(), rod.limit.begin(), rod.limit.end());
      }
    d.joints.insert(d.joints.end(), joints.begin(), joints.end());

    // the proxy at the section end (after helpers if the section has more than 6 dofs)
    const SE3 end = rest_pose(Xe), to_end = end.inverse();
    XMLElement* proxy = add_section_bodies(doc, parent, prefix, start.inverse() * end, joints, limits, rod.helpers);
    d.proxies.push_back(prefix);

    // capsules along the chords of the rest shape, radius of the taper at their middle
    for (int j = 0; j < rod.capsules; ++j) {
      const double a = X0 + (Xe - X0) * j / rod.capsules;
      const double b = j + 1 == rod.capsules ? Xe : X0 + (Xe - X0) * (j + 1) / rod.capsules;
      const double radius =
          spec.radius_base + (spec.radius_tip - spec.radius_base) * 0.5 * (a + b) / spec.length;
      const std::string gn = prefix + "/g" + std::to_string(j);
      const Vec3 pa = to_end.act(rest_pose(a).u), pb = to_end.act(rest_pose(b).u);
      proxy->InsertEndChild(new_element(doc, "geom",
                                        {{"name", gn}, {"type", "capsule"},
                                         {"fromto", fmt3(pa.x(), pa.y(), pa.z()) + " " + fmt3(pb.x(), pb.y(), pb.z())},
                                         {"size", fmt(radius)}},
                                        rod.geom));
      d.geoms.push_back(RodGeomDecl{gn, i, a, b});
    }

    // user sites of this section: their cross-section frame at rest, in the proxy frame
    for (const RodSite& s : rod.sites) {
      if (s.section != i) continue;
      SE3 g = rest_pose(s.decl.X);
      g.u += g.R * s.decl.pos;
      Attributes attrs = pose_attributes(to_end * g);
      attrs.insert(attrs.begin(), {"name", s.decl.name});
      XMLElement* site = new_element(doc, "site", attrs, s.attrs);
      origins_[site] = origin(s.element);  // MuJoCo's errors on it point at the user's <site>
      proxy->InsertEndChild(site);
      d.sites.push_back(s.decl);
    }

    parent = proxy;
    start = end;
    X0 = Xe;
  }

  // tip site and the rigid bodies hanging at the tip
  parent->InsertEndChild(new_element(doc, "site", {{"name", n + "/tip"}, {"pos", "0 0 0"}}));
  d.sites.push_back(RodSiteDecl{n + "/tip", spec.length, Vec3::Zero()});
  for (XMLElement* b : rod.bodies) parent->InsertEndChild(b);  // moves it (origins kept)
  return base;
}

// Collision exclusions of one rod. The rod always overlaps what it is mounted on and what hangs at
// its tip, so every proxy is excluded against the parent body (unless that is the world, whose
// geoms, e.g. a floor, must stay in contact) and against named <body> children at the tip. Unless
// selfcollide="true", the proxies are also excluded pairwise and with the rod's base.
void Preprocessor::add_excludes(const RodInput& rod) {
  const auto& p = rod.decl.proxies;
  for (const auto& proxy : p) {
    if (rod.decl.parent_body != "world") excludes_.emplace_back(rod.decl.parent_body, proxy);
    for (const XMLElement* b : rod.bodies)
      if (const char* name = b->Attribute("name"); name && *name) excludes_.emplace_back(name, proxy);
  }
  if (rod.selfcollide) return;
  for (std::size_t i = 0; i < p.size(); ++i) {
    excludes_.emplace_back(rod.decl.name + "/base", p[i]);
    for (std::size_t j = i + 1; j < p.size(); ++j) excludes_.emplace_back(p[i], p[j]);
  }
}

// Checks the place of one <cosserat>, reads it, claims its names, and replaces it by the
// generated "<rod>/base" body (returned, so that the walk continues inside it).
XMLElement* Preprocessor::replace_rod(XMLElement* parent, XMLElement* cosserat) {
  const Reader r = reader(cosserat);
  if (!is(parent, "worldbody") && !is(parent, "body"))
    r.fail("a <cosserat> must be inside a named <body> or <worldbody> (found inside <" +
           std::string(parent->Name()) + ">)");
  if (is(parent, "body") && (!parent->Attribute("name") || !*parent->Attribute("name")))
    r.fail("a <cosserat> must be inside a named <body> or <worldbody>");
  RodInput rod = read_rod(cosserat, is(parent, "worldbody") ? "world" : parent->Attribute("name"));

  // names: the rod's, then every generated or user object name
  const std::string& name = rod.decl.name;
  if (const auto it = rod_names_.find(name); it != rod_names_.end())
    r.fail("duplicate rod name '" + name + "' (first declared at " + it->second.file + ":" +
           std::to_string(it->second.line) + ")");
  rod_names_[name] = r.origin();
  XMLDocument& doc = *cosserat->GetDocument();
  XMLElement* base = build_rod(doc, rod);
  claim("body", name + "/base", r, false);
  for (const auto& p : rod.decl.proxies) claim("body", p, r, false);
  for (const auto& h : rod.helpers) {
    claim("body", h, r, false);
    helper_proxy_[h] = h.substr(0, h.rfind('/'));  // "<rod>/s<i>/h<k>" -> "<rod>/s<i>"
  }
  for (const auto& j : rod.decl.joints) claim("joint", j, r, false);
  for (const auto& g : rod.decl.geoms) claim("geom", g.name, r, false);
  claim("site", name + "/base", r, false);
  claim("site", name + "/tip", r, false);
  for (const RodSite& s : rod.sites) claim("site", s.decl.name, reader(s.element), true);

  // splice the generated subtree in place of the <cosserat>: its generated elements take the
  // <cosserat>'s origin (MuJoCo's errors on a capsule point at the rod's line, not its parent's),
  // and the origins of the elements deleted with it are forgotten (a new element may reuse one's
  // memory)
  const Origin rod_origin = origin(cosserat);
  const auto adopt = [&](auto&& self, XMLElement* e) -> void {
    origins_.try_emplace(e, rod_origin);
    for (XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) self(self, c);
  };
  adopt(adopt, base);
  const auto forget = [&](auto&& self, const XMLElement* e) -> void {
    origins_.erase(e);
    for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) self(self, c);
  };
  parent->InsertAfterChild(cosserat, base);
  forget(forget, cosserat);
  parent->DeleteChild(cosserat);
  add_excludes(rod);
  rods_.push_back(std::move(rod.decl));
  return base;
}

// Walks the tree and replaces every <cosserat> (rods inside bodies moved to a rod tip included).
void Preprocessor::rewrite(XMLElement* parent) {
  for (XMLElement* c = parent->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (is(c, "cosserat")) c = replace_rod(parent, c);
    rewrite(c);
  }
}

// Appends the exclusion pairs to the first top-level <contact>, or to a new one.
void Preprocessor::emit_excludes(XMLDocument& doc, XMLElement* root) {
  if (excludes_.empty()) return;
  XMLElement* contact = root->FirstChildElement("contact");
  if (!contact) contact = root->InsertEndChild(doc.NewElement("contact"))->ToElement();
  for (const auto& [b1, b2] : excludes_)
    contact->InsertEndChild(new_element(doc, "exclude", {{"body1", b1}, {"body2", b2}}));
}

// The deepest element below `e` (at `depth`) and its depth.
std::pair<const XMLElement*, int> deepest(const XMLElement* e, int depth) {
  std::pair<const XMLElement*, int> best{e, depth};
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    const auto d = deepest(c, depth + 1);
    if (d.second > best.second) best = d;
  }
  return best;
}

// MuJoCo 2.2.2 parses our output with tinyxml2, which refuses elements nested
// TINYXML2_MAX_ELEMENT_DEPTH (100) deep, and every section adds one level: report a chain that is
// too deep at the innermost rod it runs through, rather than as MuJoCo's parse error.
void Preprocessor::check_depth(const XMLElement* root) const {
  const auto [e, depth] = deepest(root, 1);
  const int limit = TINYXML2_MAX_ELEMENT_DEPTH - 1;
  if (depth <= limit) return;
  for (const XMLNode* a = e; a; a = a->Parent()) {
    const XMLElement* b = a->ToElement();
    if (!is(b, "body") || !b->Attribute("name")) continue;
    for (const RodDecl& rod : rods_) {
      const auto& p = rod.proxies;
      if (std::find(p.begin(), p.end(), b->Attribute("name")) == p.end()) continue;
      // the rod's chain: one proxy per section and its helpers; the rest of the depth is the scene's
      int levels = rod.spec.sections;
      for (const auto& [helper, proxy] : helper_proxy_) levels += std::find(p.begin(), p.end(), proxy) != p.end();
      const double per_section = static_cast<double>(levels) / rod.spec.sections;
      const int fits = static_cast<int>(std::floor((levels - (depth - limit)) / per_section));
      throw LoadError(rod.file, rod.line,
                      "rod '" + rod.name + "': the generated bodies nest " + std::to_string(depth) +
                          " elements deep, MuJoCo 2.2.2's XML parser stops at " + std::to_string(limit) +
                          " (each section is one nested body; a section with more than 6 dofs, more): "
                          "use at most about " +
                          std::to_string(std::max(1, fits)) + " sections here");
    }
  }
  throw LoadError(origin(e).file, origin(e).line, "elements nested too deep for MuJoCo's XML parser");
}

// References to the helper bodies "<rod>/s<i>/h<k>" (equality constraints, sensors, actuators,
// cameras and lights): a helper sits at its section's end frame but carries only the section's
// first dofs, so MuJoCo's Jacobian there misses the rest (probe M: a connect's velocity rows off by
// 2-40%, a framelinvel reading another velocity than the proxy's at the same frame). Refused at the
// element, naming the proxy (the same frame, the whole motion).
void Preprocessor::check_helper_references(const XMLElement* e) const {
  if (helper_proxy_.empty()) return;
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (!is(c, "exclude")) {  // an exclusion naming a helper changes nothing
      for (const char* attr : {"body", "body1", "body2", "target", "objname", "refname"}) {
        const char* v = c->Attribute(attr);
        if (!v) continue;
        const std::string a(attr);
        if (a == "objname" || a == "refname") {  // a body only when the matching type says so
          const char* type = c->Attribute(a == "objname" ? "objtype" : "reftype");
          if (!type || (std::string_view(type) != "body" && std::string_view(type) != "xbody")) continue;
        }
        const auto h = helper_proxy_.find(v);
        if (h == helper_proxy_.end()) continue;
        reader(c).fail("'" + h->first + "' is a body generated to hold the first 6 dofs of a section with more; it "
                       "sits at the section's end but moves with only those dofs: name the section's proxy '" +
                       h->second + "' (the same frame, the whole motion)");
      }
    }
    check_helper_references(c);
  }
}

Preprocessed Preprocessor::run(const std::string& text, const std::string& path) {
  const std::string file = path.empty() ? "<string>" : path;
  main_dir_ = fs::path(file).parent_path();
  XMLDocument& doc = parse(text, file);
  XMLElement* root = doc.RootElement();
  if (!is(root, "mujoco")) reader(root).fail("the root element must be <mujoco>");
  if (const XMLElement* extra = root->NextSiblingElement())
    throw LoadError(file, extra->GetLineNum(), "<" + std::string(extra->Name()) + "> after the root element <mujoco>: a model has one top-level element");

  std::vector<std::string> stack{canonical_key(file)};
  expand_includes(root, doc, stack);
  // MuJoCo 2.2.2 counts a trailing space in a <key>'s arrays as one more number ("invalid qpos
  // size, expected length N" for N numbers: outside probe X), where its other attributes allow it
  for (XMLElement* kf = root->FirstChildElement("keyframe"); kf; kf = kf->NextSiblingElement("keyframe"))
    for (XMLElement* k = kf->FirstChildElement("key"); k; k = k->NextSiblingElement("key"))
      for (const char* name : {"qpos", "qvel", "act", "ctrl", "mpos", "mquat"})
        if (const char* v = k->Attribute(name)) {
          std::string t(v);
          const size_t b = t.find_first_not_of(" \t\r\n"), e = t.find_last_not_of(" \t\r\n");
          k->SetAttribute(name, b == std::string::npos ? "" : t.substr(b, e - b + 1).c_str());
        }
  collect_names(root);
  check_custom_fields(root);
  check_options(root);
  rewrite(root);
  check_size(root);  // after rewrite: the rods' generated bodies, joints, geoms and sites count
  check_helper_references(root);
  check_finite(root);  // after the checks with messages of their own (options, rods)
  check_compiler(root);
  emit_excludes(doc, root);
  check_depth(root);

  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  Preprocessed out{printer.CStr(), path, std::move(rods_), {}, {}, {}, {}, {}, {}, {}, {}};
  out.warnings = std::move(warnings_);
  map_lines(root, out);
  for (const XMLElement* kf = root->FirstChildElement("keyframe"); kf; kf = kf->NextSiblingElement("keyframe"))
    for (const XMLElement* k = kf->FirstChildElement("key"); k; k = k->NextSiblingElement("key"))
      out.key_origin.push_back(SourceLine{origin(k).file, origin(k).line});
  for (const XMLElement* se = root->FirstChildElement("sensor"); se; se = se->NextSiblingElement("sensor"))
    for (const XMLElement* k = se->FirstChildElement(); k; k = k->NextSiblingElement()) {
      out.sensor_origin.push_back(SourceLine{origin(k).file, origin(k).line});
      out.sensor_objname.push_back(k->Attribute("objname") ? k->Attribute("objname") : "");
    }
  // a lengthrange in any <default> may reach any actuator through its class (not resolved here)
  bool default_lengthrange = false;
  std::vector<const XMLElement*> defaults;
  for (const XMLElement* d = root->FirstChildElement("default"); d; d = d->NextSiblingElement("default"))
    defaults.push_back(d);
  while (!defaults.empty() && !default_lengthrange) {
    const XMLElement* d = defaults.back();
    defaults.pop_back();
    for (const XMLElement* c = d->FirstChildElement(); c; c = c->NextSiblingElement()) {
      if (is(c, "default")) defaults.push_back(c);
      else if (c->Attribute("lengthrange")) default_lengthrange = true;
    }
  }
  for (const XMLElement* ac = root->FirstChildElement("actuator"); ac; ac = ac->NextSiblingElement("actuator"))
    for (const XMLElement* k = ac->FirstChildElement(); k; k = k->NextSiblingElement()) {
      out.actuator_origin.push_back(SourceLine{origin(k).file, origin(k).line});
      out.actuator_lengthrange_given.push_back(default_lengthrange || k->Attribute("lengthrange"));
      const char* dyn = k->Attribute("dyntype");
      out.actuator_stateful.push_back(is(k, "muscle") || is(k, "cylinder") || (dyn && std::string_view(dyn) != "none"));
    }
  return out;
}

// The plugin's <custom> fields, checked here where their file and line are known: the fluid's
// (plugin/mujoco/scene_fluid.hpp) <text name="cosserat:fluid" data="gray-hancock|lighthill|mujoco">
// and <numeric name="cosserat:drag:NAME" data="c_t c_n [c_rot]" or "0">, NAME a geom or a body;
// the scene's integrator <text name="cosserat:integrator" data="euler|implicit|..."> and adaptive
// substeps <numeric name="cosserat:step_tol" data="TOL">.
void Preprocessor::check_custom_fields(const XMLElement* root) const {
  for (const XMLElement* custom = root->FirstChildElement("custom"); custom;
       custom = custom->NextSiblingElement("custom"))
    for (const XMLElement* c = custom->FirstChildElement(); c; c = c->NextSiblingElement()) {
      const std::string name = c->Attribute("name") ? c->Attribute("name") : "";
      if (name.rfind("cosserat:", 0) != 0) continue;
      const Reader r = reader(c);
      if (is(c, "text") && name == "cosserat:integrator") {
        const std::string v = r.text("data");
        r.check(integrator_from_name(v).has_value(), "data",
                "of '" + name + "' must name an integrator (" + kIntegratorNames + "), got '" + v + "'");
      } else if (is(c, "numeric") && name == "cosserat:step_tol") {
        const auto v = r.numbers("data", 1, 1);
        r.check(v.has_value() && (*v)[0] > 0, "data", "of '" + name + "' must be one positive number, got '" + r.text("data") + "'");
      } else if (is(c, "text") && name == "cosserat:fluid") {
        const std::string v = r.text("data");
        r.check(v == "gray-hancock" || v == "lighthill" || v == "mujoco", "data",
                "of '" + name + "' must be 'gray-hancock', 'lighthill' or 'mujoco', got '" + v + "'");
      } else if (is(c, "numeric") && name.rfind("cosserat:drag:", 0) == 0) {
        const std::string target = name.substr(14);
        const bool user = names_.count({"geom", target}) || names_.count({"body", target});
        for (const std::string& rod : declared_rods_)  // a rod, or a body or geom it generates
          r.check(user || (target != rod && target.rfind(rod + "/", 0) != 0), "name",
                  "'" + name + "' names rod '" + rod + "' or a part of it: a rod's fluid force is set by the drag "
                  "attribute of its <cosserat> element");
        r.check(user, "name", "'" + name + "' names no geom or body '" + target + "'");
        const auto v = r.numbers("data", 1, 3);
        r.check(v.has_value(), "data", "is missing");
        if (v->size() == 1)
          r.check((*v)[0] == 0.0, "data", "needs 'c_t c_n [c_rot]', or '0' for no fluid force, got '" + r.text("data") + "'");
        else
          for (double x : *v) r.check(x > 0, "data", "coefficients must be positive, got '" + r.text("data") + "'");
        r.check(!r.has("size") || r.integer("size", 0, 1) == static_cast<int>(v->size()), "size", "differs from the number of values in 'data'");
      } else {
        r.fail_attr("name", "'" + name + "': unknown cosserat field (known: <text name=\"cosserat:integrator\">, "
                            "<numeric name=\"cosserat:step_tol\">, <text name=\"cosserat:fluid\">, "
                            "<numeric name=\"cosserat:drag:NAME\">)");
      }
    }
}

// <option> values MuJoCo 2.2.2 accepts although no simulation can use them: a time step that is not
// a positive number, non-finite gravity, wind or magnetic field, a negative or non-finite medium
// density or viscosity (a negative viscosity silently switched the plugin's fluid off).
void Preprocessor::check_options(const XMLElement* root) const {
  for (const XMLElement* o = root->FirstChildElement("option"); o; o = o->NextSiblingElement("option")) {
    const Reader r = reader(o);
    if (const auto h = r.numbers("timestep", 1, 1))
      r.check((*h)[0] > 0, "timestep", "must be a positive number of seconds, got '" + r.text("timestep") + "'");
    for (const char* a : {"gravity", "wind", "magnetic"}) r.numbers(a, 3, 3);
    for (const char* a : {"density", "viscosity"})
      if (const auto v = r.numbers(a, 1, 1)) r.check((*v)[0] >= 0, a, "must not be negative, got '" + r.text(a) + "'");
  }
}

// <size> values that make MuJoCo 2.2.2 allocate (and copy, element by element) more than
// kSizeBudget for user data and keyframes: it accepts any, and nuser_site="100000000" took minutes
// and 2.4 GB to load, nkey="10000000" more than 2 minutes and 2.6 GB before it was stopped
// (fuzzing, session 39). The estimate is a lower bound (each joint counted as one position and one
// velocity), so no model that fits is refused. nconmax, njmax and nstack are left to MuJoCo, which
// allocates them when it makes mjData and says so when it cannot.
void Preprocessor::check_size(const XMLElement* root) const {
  constexpr double kSizeBudget = 1 << 30;  // bytes
  std::map<std::string, double> count{{"body", 1}};  // the world body
  std::function<void(const XMLElement*)> walk = [&](const XMLElement* e) {
    for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      const std::string tag = c->Name();
      if (tag == "freejoint") ++count["joint"];
      else if (tag == "body" || tag == "joint" || tag == "geom" || tag == "site" || tag == "camera") ++count[tag];
      walk(c);
    }
  };
  for (const XMLElement* w = root->FirstChildElement("worldbody"); w; w = w->NextSiblingElement("worldbody")) walk(w);
  auto children = [&](const char* section) {
    double n = 0;
    for (const XMLElement* x = root->FirstChildElement(section); x; x = x->NextSiblingElement(section))
      for (const XMLElement* c = x->FirstChildElement(); c; c = c->NextSiblingElement()) ++n;
    return n;
  };
  count["tendon"] = children("tendon");
  count["actuator"] = children("actuator");
  count["sensor"] = children("sensor");
  const struct {
    const char* attr;
    const char* kind;   // count's key
    const char* what;   // for the message
  } users[] = {{"nuser_body", "body", "bodies"},        {"nuser_jnt", "joint", "joints"},
               {"nuser_geom", "geom", "geoms"},         {"nuser_site", "site", "sites"},
               {"nuser_cam", "camera", "cameras"},      {"nuser_tendon", "tendon", "tendons"},
               {"nuser_actuator", "actuator", "actuators"}, {"nuser_sensor", "sensor", "sensors"}};
  auto gigabytes = [](double bytes) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g GB", bytes / 1e9);
    return std::string(b);
  };
  for (const XMLElement* z = root->FirstChildElement("size"); z; z = z->NextSiblingElement("size")) {
    const Reader r = reader(z);
    for (const auto& u : users) {
      const double n = r.integer(u.attr, -1, -1);
      const double bytes = 8.0 * std::max(0.0, n) * count[u.kind];
      r.check(bytes <= kSizeBudget, u.attr,
              "is " + r.text(u.attr) + ": MuJoCo would allocate " + gigabytes(bytes) + " of user data for the model's " +
                  fmt(count[u.kind]) + " " + u.what + " (" + r.text(u.attr) + " numbers each; more than the " +
                  gigabytes(kSizeBudget) + " this loader allows)");
    }
    const double nkey = r.integer("nkey", 0, 0);
    const double per_key = 8.0 * (1 + 2 * count["joint"] + count["actuator"]);
    r.check(nkey * per_key <= kSizeBudget, "nkey",
            "is " + r.text("nkey") + ": MuJoCo would allocate at least " + gigabytes(nkey * per_key) +
                " for that many keyframes (more than the " + gigabytes(kSizeBudget) + " this loader allows)");
  }
}

// Numbers that are not finite (nan, inf, or a decimal beyond the double range such as 1e309) in any
// attribute: MuJoCo 2.2.2 reads them, warns "XML contains a 'NaN'" without a line or nothing at
// all, and a gear or cutoff of inf ran NaN from the first step. An attribute is numeric here when
// every token of it reads as a number; the attributes that name things are skipped (a body may be
// called "inf").
void Preprocessor::check_finite(const XMLElement* e) const {
  static const std::set<std::string_view> names = {
      "name", "class", "childclass", "model", "file", "prefix", "content_type", "joint", "joint1", "joint2",
      "jointinparent", "tendon", "tendon1", "tendon2", "site", "refsite", "cranksite", "slidersite", "sidesite",
      "body", "body1", "body2", "geom", "geom1", "geom2", "objname", "refname", "target", "mesh", "material",
      "texture", "hfield", "actuator", "data", "plugin", "instance", "type", "objtype", "reftype"};
  for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
    if (names.count(a->Name()) && !(is(e, "numeric") && std::string_view(a->Name()) == "data")) continue;
    std::istringstream in(a->Value());
    std::string tok;
    bool numeric = true, finite = true;
    while (numeric && in >> tok) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      numeric = end && *end == '\0' && end != tok.c_str();
      finite = finite && (!numeric || std::isfinite(v));
    }
    if (numeric && !finite)
      reader(e).fail_attr(a->Name(), "has a number that is not finite: '" + std::string(a->Value()) + "'");
  }
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) check_finite(c);
}

// <compiler settotalmass> scales every body's mass to a total, the rods' placeholder proxies (unit
// masses, zeroed after compiling) included: the rigid bodies came out lighter than asked for.
void Preprocessor::check_compiler(const XMLElement* root) const {
  if (rods_.empty()) return;
  for (const XMLElement* c = root->FirstChildElement("compiler"); c; c = c->NextSiblingElement("compiler")) {
    const Reader r = reader(c);
    if (const auto v = r.numbers("settotalmass", 1, 1))
      r.check((*v)[0] <= 0, "settotalmass",
              "is not supported in models with <cosserat> rods (their mass comes from density and size; MuJoCo would "
              "scale the rigid bodies with the rods' placeholder bodies counted): give the rigid bodies' masses");
    // the generated section bodies are placed in local coordinates: under coordinate="global"
    // MuJoCo read them, and the bodies at a rod's tip, as global (outside probe P: a tip body 1 m off)
    r.check(r.text("coordinate") != "global", "coordinate",
            "must be 'local' in models with <cosserat> rods: their generated bodies are placed in local coordinates, "
            "which MuJoCo would read as global; write the model in local coordinates (MuJoCo's default; later "
            "versions removed 'global')");
  }
}

// Maps each line of the printed MJCF to the origin of the element that starts there: re-parse the
// printed text and walk both trees together (generated elements inherit their parent's origin).
void Preprocessor::map_lines(const XMLElement* root, Preprocessed& out) const {
  XMLDocument printed;
  printed.Parse(out.xml.c_str());
  const int nlines = static_cast<int>(std::count(out.xml.begin(), out.xml.end(), '\n')) + 2;
  out.line_origin.assign(nlines, SourceLine{});
  const auto walk = [&](auto&& self, const XMLElement* a, const XMLElement* b, const Origin& parent) -> void {
    for (; a && b; a = a->NextSiblingElement(), b = b->NextSiblingElement()) {
      const auto it = origins_.find(a);
      const Origin& o = it == origins_.end() ? parent : it->second;
      if (b->GetLineNum() > 0 && b->GetLineNum() < nlines) out.line_origin[b->GetLineNum()] = {o.file, o.line};
      self(self, a->FirstChildElement(), b->FirstChildElement(), o);
    }
  };
  walk(walk, root, printed.RootElement(), origin(root));
  for (int i = 1; i < nlines; ++i)
    if (out.line_origin[i].line == 0) out.line_origin[i] = out.line_origin[i - 1];
}

}  // namespace

SourceLine Preprocessed::origin_of_line(int line) const {
  if (line >= 1 && line < static_cast<int>(line_origin.size()) && line_origin[line].line > 0) return line_origin[line];
  return SourceLine{path, 0};
}

Preprocessed preprocess_file(const std::string& path) {
  std::string why;
  const auto text = read_text_file(path, &why);
  if (!text) throw LoadError(path, 0, "cannot open the model file" + (why.empty() ? "" : ": " + why));
  return Preprocessor().run(*text, path);
}

Preprocessed preprocess_string(const std::string& xml, const std::string& path) {
  return Preprocessor().run(xml, path);
}

}  // namespace cosserat::mj
