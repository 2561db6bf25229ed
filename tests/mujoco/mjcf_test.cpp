// MJCF pre-processor (plugin/mujoco/mjcf.hpp): bad input gives LoadError with file:line, good
// scenes compile in MuJoCo 2.2.2 with the contract's names, dof counts and frames.
#include "mjcf.hpp"
#include "scene.hpp"
#include "support/text_file.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

#include "model.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const std::string kData = std::string(COSSERAT_SOURCE_DIR) + "/tests/mujoco/data/";
// Name of in-memory test scenes: anchors their includes in the data directory.
const std::string kInline = kData + "inline.xml";

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
namespace fs = std::filesystem;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// Loads MJCF text through a VFS file named `name`; MuJoCo resolves relative asset paths against
// the directory of `name` (see the VfsAssets test). Null on error, with the message in `error`.
ModelPtr load_xml(const std::string& xml, const std::string& name, std::string* error = nullptr) {
  auto vfs = std::make_unique<mjVFS>();  // ~2 MB: keep it off the stack
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(xml.size())) != 0) return nullptr;
  const int i = mj_findFileVFS(vfs.get(), name.c_str());
  std::memcpy(vfs->filedata[i], xml.data(), xml.size());
  char err[1024] = "";
  ModelPtr m(mj_loadXML(name.c_str(), vfs.get(), err, sizeof err));
  mj_deleteVFS(vfs.get());
  if (error) *error = err;
  return m;
}

// Compiles a pre-processed scene, failing the test (with MuJoCo's message) if it does not load.
ModelPtr compile(const Preprocessed& p) {
  std::string err;
  ModelPtr m = load_xml(p.xml, p.path, &err);
  EXPECT_TRUE(m) << "mj_loadXML: " << err << "\n" << p.xml;
  return m;
}

int id(const mjModel* m, mjtObj type, const std::string& name) { return mj_name2id(m, type, name.c_str()); }

// Number of strain coordinates the core solver gives a rod.
int core_dofs(const RodSpec& spec) {
  Model model;
  model.add_rod(-1, SE3::Identity(), spec);
  return model.nv;
}

std::string in_world(const std::string& body) {
  return "<mujoco>\n<worldbody>\n" + body + "\n</worldbody>\n</mujoco>\n";
}

// ------------------------------------------------------------------------------------------------
// Bad input: one row per kind of mistake.

struct BadCase {
  const char* kind;
  std::string xml;
  int line;
  std::string message;                // substring of LoadError::message
  std::string file = "inline.xml";    // suffix of LoadError::file
};

std::string repeat(const std::string& text, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += text;
  return out;
}

std::vector<BadCase> bad_cases() {
  const std::string rod = R"(<cosserat name="a" length="1")";  // + attributes + "/>"
  return {
      {"unknown attribute", in_world(rod + R"( colour="red"/>)"), 3, "unknown attribute 'colour'"},
      {"unknown child element", in_world(rod + ">\n<geom size=\"1\"/>\n</cosserat>"), 4, "unknown child element <geom>"},
      {"pos with 2 numbers", in_world(rod + R"( pos="0 1"/>)"), 3, "'pos' needs 3 numbers, got 2"},
      {"reststrain with 5 numbers", in_world(rod + R"( reststrain="0 0 0 1 0"/>)"), 3, "'reststrain' needs 6"},
      // a zero rest stretch had reached MuJoCo as zero-length capsules, a negative one loaded
      {"zero rest stretch", in_world(rod + R"( reststrain="0 0 0 0 0 0"/>)"), 3, "rest axial stretch px (its 4th number) of 0: it must be above 0.1"},
      {"inverted rest stretch", in_world(rod + R"( reststrain="0 0 0 -1 0 0"/>)"), 3, "of -1: it must be above 0.1"},
      {"collapsed rest stretch of a section", in_world(rod + ">\n<section length=\"1\" reststrain=\"0 1 0 0.05 0 0\"/>\n</cosserat>"), 4, "of 0.05: it must be above 0.1"},
      {"non-numeric value", in_world(R"(<cosserat name="a" length="abc"/>)"), 3, "'length' holds 'abc', which is not a number"},
      {"non-numeric in a list", in_world(rod + R"( radius="0.1 x"/>)"), 3, "'radius' holds 'x', which is not a number"},
      {"hexadecimal number", in_world(R"(<cosserat name="a" length="0x10"/>)"), 3, "'length' holds '0x10', which is not a number"},
      {"zero length", in_world(R"(<cosserat name="a" length="0"/>)"), 3, "'length' must be positive"},
      {"negative length", in_world(R"(<cosserat name="a" length="-2"/>)"), 3, "'length' must be positive"},
      {"negative radius", in_world(rod + R"( radius="0.01 -0.002"/>)"), 3, "'radius' must be positive"},
      {"zero sections", in_world(rod + R"( sections="0"/>)"), 3, "'sections' must be >= 1"},
      {"fractional sections", in_world(rod + R"( sections="2.5"/>)"), 3, "'sections' must be an integer"},
      {"huge sections", in_world(rod + R"( sections="1000000000"/>)"), 3, "'sections' is too large: 1000000000"},
      {"section of no length", in_world(rod + R"( sections="3">)" "\n<section length=\"0.5\"/>\n<section length=\"1e-300\"/>\n<section/>\n</cosserat>"),
       5, "section 1 is 1e-300 long, less than 1e-06 of the rod length 1"},
      {"unknown strain name", in_world(rod + R"( strain="wobbly"/>)"), 3, "unknown strain name 'wobbly'"},
      {"both strain and dofs", in_world(rod + R"( strain="kl" dofs="1 1 1 1 0 0"/>)"), 3, "'strain' and 'dofs'"},
      {"dofs not 0/1", in_world(rod + R"( dofs="1 1 2 0 0 0"/>)"), 3, "'dofs' must hold six 0/1"},
      {"dofs with 5 values", in_world(rod + R"( dofs="1 1 1 0 0"/>)"), 3, "'dofs' needs 6"},
      {"negative order", in_world(rod + R"( order="-1"/>)"), 3, "'order' must be >= 0"},
      {"poisson too large", in_world(rod + R"( poisson="0.7"/>)"), 3, "'poisson' must be in (-1, 0.5]"},
      {"poisson -1", in_world(rod + R"( poisson="-1"/>)"), 3, "'poisson'"},
      {"poisson too large names shear", in_world(rod + R"( poisson="0.7"/>)"), 3, "set 'shear' (G in Pa) instead"},
      {"poisson and shear", in_world(rod + R"( poisson="0.3" shear="1e5"/>)"), 3, "'shear' and 'poisson' both given"},
      {"zero shear", in_world(rod + R"( shear="0"/>)"), 3, "'shear' must be positive (G in Pa)"},
      {"section poisson and shear", in_world(rod + ">\n<section poisson=\"0.3\" shear=\"1e5\"/>\n</cosserat>"), 4, "'shear' and 'poisson' both given"},
      {"negative viscosity", in_world(rod + R"( viscosity="-1"/>)"), 3, "'viscosity' must be >= 0"},
      {"zero density", in_world(rod + R"( density="0"/>)"), 3, "'density' must be positive"},
      {"zero quadrature", in_world(rod + R"( quadrature="0"/>)"), 3, "'quadrature' must be >= 1"},
      {"bad quadrature", in_world(rod + R"( quadrature="simpson"/>)"), 3,
       "'quadrature' must be a number of Gauss points, 'gauss' (order + 2 of them, the default) or 'lobatto', got "
       "'simpson'"},
      {"lobatto on GVS", in_world(rod + R"( order="2" quadrature="lobatto"/>)"), 3, "'quadrature' 'lobatto' (the Gauss-Lobatto"},
      {"lobatto, a turn per section", in_world(rod + R"( quadrature="lobatto" reststrain="0 0 6.3 1 0 0"/>)"), 3,
       "section 0 bends through 1.00 turns at rest: quadrature=\"lobatto\" is for sections bending less than half"},
      {"lobatto, a curled section", in_world(rod + " sections=\"2\" quadrature=\"lobatto\">\n<section/>\n"
                                                   "<section reststrain=\"0 7 0 1 0 0\"/>\n</cosserat>"), 5,
       "section 1 bends through 0.56 turns"},
      {"lobatto rod, GVS section", in_world(rod + " quadrature=\"lobatto\">\n<section order=\"1\"/>\n</cosserat>"), 4,
       "'order' must be 0 under quadrature=\"lobatto\""},
      {"zero capsules", in_world(rod + R"( capsules="0"/>)"), 3, "'capsules' must be >= 1"},
      {"too many capsules", in_world(rod + R"( capsules="1000000"/>)"), 3, "'capsules' must be <= 100 per section"},
      {"too many Gauss points", in_world(rod + R"( quadrature="1000000"/>)"), 3, "'quadrature' must be <= 64 Gauss points"},
      // fewer Gauss points than Legendre modes: a singular mass matrix (outside probe CA)
      {"too few Gauss points for the order", in_world(rod + R"( order="3" quadrature="2"/>)"), 3,
       "'quadrature' gives 2 Gauss points to a section of order 3: the mass quadrature needs at least order + 1 (4)"},
      {"an order above a rod's Gauss points", in_world(rod + " quadrature=\"2\">\n<section order=\"2\"/>\n</cosserat>"), 4,
       "'order' gives 2 Gauss points to a section of order 2"},
      // refused before the rewrite (which would first build O(sections^2) collision exclusions)
      {"sections beyond the parser's depth", in_world(rod + R"( sections="1000000"/>)"), 3,
       "'sections' is 1000000, but each section nests one body and MuJoCo 2.2.2's XML parser stops at 99"},
      {"section children beyond the parser's depth", in_world(rod + ">\n" + repeat("<section/>", 198) + "\n</cosserat>"), 3,
       "the rod has 198 <section> children, but each section nests one body"},
      {"bad selfcollide", in_world(rod + R"( selfcollide="yes"/>)"), 3, "'selfcollide' must be 'true' or 'false'"},
      {"bad rgba count", in_world(rod + R"( rgba="1 0 0"/>)"), 3, "'rgba' needs 4"},
      {"two orientations", in_world(rod + R"( quat="1 0 0 0" euler="0 0 1"/>)"), 3, "'euler' conflicts"},
      {"quat with 3 numbers", in_world(rod + R"( quat="1 0 0"/>)"), 3, "'quat' needs 4"},
      {"site without at", in_world(rod + ">\n<site name=\"s\"/>\n</cosserat>"), 4, "missing attribute 'at'"},
      {"site without name", in_world(rod + ">\n<site at=\"0.5\"/>\n</cosserat>"), 4, "missing attribute 'name'"},
      {"site at beyond the tip", in_world(rod + ">\n<site name=\"s\" at=\"1.5\"/>\n</cosserat>"), 4, "'at' must be in [0, 1]"},
      {"site at negative", in_world(rod + ">\n<site name=\"s\" at=\"-0.1\"/>\n</cosserat>"), 4, "'at' must be in"},
      {"site pos with 4 numbers", in_world(rod + ">\n<site name=\"s\" at=\"0.5\" pos=\"0 0 0 0\"/>\n</cosserat>"), 4, "'pos' needs 2 to 3"},
      {"site unknown attribute", in_world(rod + ">\n\n<site name=\"s\" at=\"0.5\" colour=\"red\"/>\n</cosserat>"), 5, "unknown attribute 'colour'"},
      // an orientation on a rod site says why it is refused (outside probe AD)
      {"site orientation", in_world(rod + ">\n\n<site name=\"s\" at=\"0.5\" euler=\"0 0 90\"/>\n</cosserat>"), 5, "attribute 'euler' is not accepted on a rod site: its frame is the rod's cross-section frame"},
      {"site zaxis", in_world(rod + ">\n<site name=\"s\" at=\"0.5\" zaxis=\"0 0 1\"/>\n</cosserat>"), 4, "attribute 'zaxis' is not accepted on a rod site"},
      {"section lengths exceed", in_world(rod + ">\n<section length=\"0.6\"/>\n<section length=\"0.6\"/>\n</cosserat>"), 3, "section lengths add up to 1.2"},
      {"section lengths fall short", in_world(rod + ">\n<section length=\"0.3\"/>\n<section length=\"0.3\"/>\n</cosserat>"), 3, "section lengths add up to 0.6"},
      {"section lengths leave nothing", in_world(rod + ">\n<section length=\"1\"/>\n<section/>\n</cosserat>"), 3, "leaving nothing"},
      {"sections disagree with <section>", in_world(R"(<cosserat name="a" length="1" sections="3">)" "\n<section/>\n<section/>\n</cosserat>"), 3, "'sections' is 3 but there are 2"},
      {"section negative length", in_world(rod + ">\n<section/>\n<section length=\"-0.5\"/>\n</cosserat>"), 5, "'length' must be positive"},
      {"section unknown strain", in_world(rod + ">\n<section strain=\"floppy\"/>\n</cosserat>"), 4, "unknown strain name 'floppy'"},
      {"section unknown attribute", in_world(rod + ">\n<section radius=\"0.1\"/>\n</cosserat>"), 4, "unknown attribute 'radius'"},
      {"section with a child", in_world(rod + ">\n<section>\n<site name=\"s\" at=\"0\"/>\n</section>\n</cosserat>"), 5, "unknown child element <site>"},
      {"missing include file", "<mujoco>\n\n<include file=\"missing.xml\"/>\n</mujoco>\n", 3, "missing.xml"},
      {"include without file", "<mujoco>\n<include/>\n</mujoco>\n", 2, "missing attribute 'file'"},
      {"error inside an included file", "<mujoco>\n<worldbody>\n<include file=\"bad_inner.xml\"/>\n</worldbody>\n</mujoco>\n", 4, "unknown attribute 'stiffness'", "bad_inner.xml"},
      {"malformed included file", "<mujoco>\n<include file=\"malformed_inner.xml\"/>\n</mujoco>\n", 3, "XML_ERROR_MISMATCHED_ELEMENT", "malformed_inner.xml"},
      {"include cycle", "<mujoco>\n<include file=\"cycle_a.xml\"/>\n</mujoco>\n", 2, "include cycle", "cycle_b.xml"},
      {"malformed XML", "<mujoco>\n<worldbody>\n<cosserat name=\"a\" length=\"1\">\n</worldbody>\n</mujoco>\n", 3, "XML_ERROR_MISMATCHED_ELEMENT"},
      {"unterminated attribute", "<mujoco>\n<worldbody>\n<cosserat name=\"a length=\"1\"/>\n</worldbody>\n</mujoco>\n", 3, "XML_ERROR"},
      // tinyxml2's errors in words first (outside probe AD: a repeated attribute read only
      // "Error=XML_ERROR_PARSING_ATTRIBUTE ErrorID=7 ...")
      {"repeated attribute", "<mujoco>\n<worldbody>\n<cosserat name=\"a\" length=\"1\" length=\"2\"/>\n</worldbody>\n</mujoco>\n", 3, "malformed XML: an attribute could not be read (given twice in one element"},
      {"empty document", "", 0, "XML_ERROR_EMPTY_DOCUMENT"},
      {"root is not <mujoco>", "<mujoko>\n</mujoko>\n", 1, "root element must be <mujoco>"},
      {"duplicate rod name", in_world(rod + "/>\n" + rod + "/>"), 4, "duplicate rod name 'a'"},
      {"missing name", in_world(R"(<cosserat length="1"/>)"), 3, "missing attribute 'name'"},
      {"empty name", in_world(R"(<cosserat name="" length="1"/>)"), 3, "'name' must not be empty"},
      {"missing length", in_world(R"(<cosserat name="a"/>)"), 3, "missing attribute 'length'"},
      {"cosserat inside an unnamed body", in_world("<body pos=\"0 0 1\">\n" + rod + "/>\n</body>"), 4, "must be inside a named <body> or <worldbody>"},
      {"cosserat outside the worldbody", "<mujoco>\n" + rod + "/>\n</mujoco>\n", 2, "must be inside a named <body> or <worldbody>"},
      {"cosserat inside a cosserat", in_world(rod + ">\n<cosserat name=\"b\" length=\"1\"/>\n</cosserat>"), 4, "unknown child element <cosserat>"},
      {"site name used by another rod", in_world(rod + ">\n<site name=\"s\" at=\"0\"/>\n</cosserat>\n<cosserat name=\"b\" length=\"1\">\n<site name=\"s\" at=\"0\"/>\n</cosserat>"), 7, "site name 's' is already used"},
      {"site name of a generated site", in_world(rod + ">\n<site name=\"a/tip\" at=\"1\"/>\n</cosserat>"), 4, "site name 'a/tip' is already used"},
      {"site name used in the worldbody", in_world("<site name=\"s\"/>\n" + rod + ">\n<site name=\"s\" at=\"0\"/>\n</cosserat>"), 5, "site name 's' is already used"},
      {"unknown default class", in_world(rod + R"( class="nosuch"/>)"), 3, "'class' names no <default class=...>: 'nosuch'"},
      {"site with an unknown class", in_world(rod + ">\n<site name=\"s\" at=\"0\" class=\"nosuch\"/>\n</cosserat>"), 4, "'class' names no"},
      {"too many sections for MuJoCo's XML depth", in_world("<body name=\"b\">\n" + rod + R"( sections="120"/>)" "\n</body>"), 4, "use at most about 94 sections"},
      // sections of 20 dofs nest 4 bodies each (3 helpers and the proxy): 23 fit whatever the request
      {"too many GVS sections for MuJoCo's XML depth", in_world(rod + R"( sections="24" order="4" strain="kl"/>)"), 3, "use at most about 23 sections"},
      {"far too many GVS sections for MuJoCo's XML depth", in_world(rod + R"( sections="32" order="4" strain="kl"/>)"), 3, "use at most about 23 sections"},
      {"generated body name taken", in_world("<body name=\"a/s0\"/>\n" + rod + "/>"), 4, "generated body name 'a/s0'"},
      {"step_tol not positive", "<mujoco>\n<custom>\n<numeric name=\"cosserat:step_tol\" data=\"0\"/>\n</custom>\n</mujoco>\n",
       3, "'data' of 'cosserat:step_tol' must be one positive number, got '0'"},
      {"step_tol with two numbers", "<mujoco>\n<custom>\n<numeric name=\"cosserat:step_tol\" data=\"1 2\"/>\n</custom>\n</mujoco>\n",
       3, "'data' needs 1 number, got 2"},
      {"unknown integrator", "<mujoco>\n<custom>\n<text name=\"cosserat:integrator\" data=\"leapfrog\"/>\n</custom>\n</mujoco>\n",
       3, "must name an integrator (euler, implicit, trapezoidal, genalpha, midpoint, rk4, rosenbrock), got 'leapfrog'"},
      // <option> values MuJoCo accepts but no simulation can use (found by fuzzing: a zero or NaN
      // time step ran 0 steps and exited 0, compare hung; NaN gravity failed without a line)
      {"zero time step", "<mujoco>\n<option timestep=\"0\"/>\n</mujoco>\n", 2, "'timestep' must be a positive number of seconds"},
      {"NaN time step", "<mujoco>\n<option timestep=\"nan\"/>\n</mujoco>\n", 2, "'timestep' holds 'nan', which is not a number"},
      {"NaN gravity", "<mujoco>\n<option gravity=\"nan 0 0\"/>\n</mujoco>\n", 2, "'gravity' holds 'nan'"},
      {"infinite wind", "<mujoco>\n<option wind=\"0 inf 0\"/>\n</mujoco>\n", 2, "'wind' holds 'inf'"},
      {"negative viscosity", "<mujoco>\n<option viscosity=\"-5\"/>\n</mujoco>\n", 2, "'viscosity' must not be negative"},
      {"content after the root", "<mujoco>\n</mujoco>\n<cosserat name=\"x\" length=\"-1\"/>\n", 3,
       "<cosserat> after the root element <mujoco>"},
      // (fuzzing, session 39: tinyxml2 stops at a NUL, and what followed it loaded unread)
      {"NUL byte after the root", std::string("<mujoco>\n</mujoco>\n") + '\0' + "<cosserat name=\"x\" length=\"-1\"/>\n", 3,
       "a NUL byte"},
      {"NUL byte inside", std::string("<mujoco>\n<worldbody>\n") + '\0' + "</worldbody>\n</mujoco>\n", 3, "a NUL byte"},
      {"include of a device", "<mujoco>\n<include file=\"/dev/zero\"/>\n</mujoco>\n", 2, "'/dev/zero': it is not a regular file"},
      // (fuzzing, session 39: MuJoCo took minutes and 2.4 GB to load nuser_site="100000000", and
      // more than 2 minutes and 2.6 GB for nkey="10000000"; the rod's base and tip sites count)
      // strainrange (fortieth session): pairs lo <= 0 <= hi of the six strain components, on PCS dofs
      {"strainrange of the wrong count", in_world(rod + R"( strainrange="-5 5"/>)"), 3, "'strainrange'"},
      {"strainrange with lo above hi", in_world(rod + R"( strainrange="0 0 0 0 5 -5 0 0 0 0 0 0"/>)"), 3,
       "pair 3 (kz) is 5 -5: it needs lo < hi"},
      {"strainrange excluding the rest shape", in_world(rod + R"( strainrange="0 0 0 0 1 5 0 0 0 0 0 0"/>)"), 3,
       "the values are deviations from 'reststrain'"},
      {"strainrange on a strain the section lacks", in_world(rod + R"( strain="kl" strainrange="0 0 0 0 0 0 0 0 -0.1 0.1 0 0"/>)"), 3,
       "limits py (pair 5), which is not among this section's strain dofs"},
      {"strainrange on a GVS rod", in_world(rod + R"( order="2" strainrange="0 0 0 0 -5 5 0 0 0 0 0 0"/>)"), 3,
       "is for PCS sections (order 0)"},
      {"a GVS section inheriting a strainrange", in_world(rod + " strainrange=\"0 0 0 0 -5 5 0 0 0 0 0 0\">\n<section order=\"2\"/>\n</cosserat>"), 4,
       "makes this a GVS section, which the rod's strainrange cannot limit"},
      {"solreflimit without a strainrange", in_world(rod + R"( solreflimit="0.01 1"/>)"), 3,
       "'solreflimit' is given, but no strain is limited"},
      // a body partway along a rod: the messages say how (outside probe CE)
      {"a body inside a section", in_world(rod + ">\n<section>\n<body/>\n</section>\n</cosserat>"), 5,
       "a <body> inside a <section> is not supported. For a body partway along a rod, split the rod there"},
      {"a rod body with 'at'", in_world(rod + ">\n<body at=\"0.1\"/>\n</cosserat>"), 4,
       "attribute 'at' is not accepted on a <body>: a body inside <cosserat> is carried at the rod's tip. For a body "
       "partway along a rod, split the rod there"},
      {"user data beyond a gigabyte", "<mujoco>\n<size nuser_site=\"100000000\"/>\n<worldbody>\n" + rod + "/>\n</worldbody>\n</mujoco>\n", 2,
       "'nuser_site' is 100000000: MuJoCo would allocate 1.6 GB of user data for the model's 2 sites"},
      {"keyframes beyond a gigabyte", "<mujoco>\n<size nkey=\"999999999\"/>\n</mujoco>\n", 2,
       "'nkey' is 999999999: MuJoCo would allocate at least 8 GB for that many keyframes"},
      // (fuzzing, second round: sections allocated before the depth check exhausted memory; sizes
      // that overflow the inertia gave an internal error without a line)
      {"a billion sections", in_world(rod + R"( sections="999999999"/>)"), 3, "'sections' is 999999999, but each section nests one body"},
      // (outside probe BB, forty-fifth session: sections of many dofs nest one body per 6, counted
      // only after their O(depth^2) generation: 60 sections of order 20 took 2.8 GB to be refused)
      {"GVS sections nesting a thousand bodies", in_world(rod + R"( sections="60" order="20" strain="sr"/>)"), 3,
       "'sections' is 60, nesting 1260 bodies (one per 6 strain dofs of a section"},
      {"radius beyond 1e6 m", in_world(rod + R"( radius="1e100"/>)"), 3, "'radius' must be at most 1e6 m"},
      {"length beyond 1e6 m", in_world(R"(<cosserat name="a" length="1e150"/>)"), 3, "'length' must be at most 1e6 m"},
      // (outside probe N, twentieth session: a rod without mass or stiffness loaded and ran without a word)
      {"a radius whose section inertia underflows", in_world(rod + R"( radius="1e-300"/>)"), 3,
       "'radius' is too small: the section's second moment of area pi r^4/4 underflows"},
      {"a denormal Young's modulus", in_world(rod + R"( young="5e-324"/>)"), 3,
       "'young' is too small: the section's bending stiffness young pi r^4/4 underflows"},
      {"a section's density whose inertia underflows", in_world(rod + ">\n<section density=\"1e-300\"/>\n</cosserat>"), 4,
       "<section>: attribute 'density' is too small"},
      // (outside probes, fourteenth session: a gear or cutoff of inf or nan ran NaN from the first
      // step with MuJoCo's line-less warning; settotalmass scaled the rods' placeholder bodies too)
      {"infinite gear", "<mujoco>\n<worldbody>\n<body>\n<joint name=\"j\"/>\n<geom size=\"0.1\"/>\n</body>\n</worldbody>\n"
                        "<actuator>\n<motor joint=\"j\" gear=\"inf 0 0 0 0 0\"/>\n</actuator>\n</mujoco>\n",
       9, "<motor>: attribute 'gear' has a number that is not finite: 'inf 0 0 0 0 0'"},
      {"NaN cutoff", "<mujoco>\n<worldbody>\n<site name=\"s\"/>\n</worldbody>\n<sensor>\n<framepos objtype=\"site\" "
                     "objname=\"s\" cutoff=\"nan\"/>\n</sensor>\n</mujoco>\n",
       6, "'cutoff' has a number that is not finite"},
      {"a size beyond the double range", in_world("<geom size=\"1e309\"/>"), 3, "'size' has a number that is not finite"},
      // (outside probe P, twenty-first session: the generated bodies were read as global, a tip body landed 1 m off)
      {"global coordinates with a rod", "<mujoco>\n<compiler coordinate=\"global\"/>\n<worldbody>\n" + rod + "/>\n</worldbody>\n</mujoco>\n",
       2, "'coordinate' must be 'local' in models with <cosserat> rods"},
      {"settotalmass with a rod", "<mujoco>\n<compiler settotalmass=\"1\"/>\n<worldbody>\n" + rod + "/>\n</worldbody>\n</mujoco>\n",
       2, "'settotalmass' is not supported in models with <cosserat> rods"},
      // (outside probe M, nineteenth session: constraints and sensors on a helper body loaded and
      // moved with part of the section only)
      {"a connect on a helper body", "<mujoco>\n<worldbody>\n" + rod + R"( strain="sr" order="1"/>)" +
                                         "\n</worldbody>\n<equality>\n<connect body1=\"a/s0/h0\" anchor=\"0 0 0\"/>\n</equality>\n</mujoco>\n",
       6, "name the section's proxy 'a/s0'"},
      {"a framelinvel of a helper body", "<mujoco>\n<worldbody>\n" + rod + R"( strain="sr" order="1"/>)" +
                                              "\n</worldbody>\n<sensor>\n<framelinvel objtype=\"xbody\" objname=\"a/s0/h0\"/>\n</sensor>\n</mujoco>\n",
       6, "'a/s0/h0' is a body generated to hold the first 6 dofs"},
  };
}

TEST(MjcfErrors, TableOfBadInput) {
  const auto cases = bad_cases();
  ASSERT_GE(cases.size(), 20u);
  for (const BadCase& c : cases) {
    SCOPED_TRACE(std::string(c.kind) + "\n" + c.xml);
    try {
      preprocess_string(c.xml, kInline);
      ADD_FAILURE() << "no LoadError for: " << c.kind;
    } catch (const LoadError& e) {
      EXPECT_EQ(e.line, c.line) << e.what();
      EXPECT_NE(e.message.find(c.message), std::string::npos) << e.what();
      EXPECT_TRUE(e.file.ends_with(c.file)) << e.what();
      const std::string prefix = e.file + (e.line > 0 ? ":" + std::to_string(e.line) : std::string()) + ": ";
      EXPECT_EQ(std::string(e.what()).rfind(prefix, 0), 0u) << e.what();
    }
  }
}

// Values that load but are likely mistakes: warned about with their file and line (a unit slip, a
// rod thicker than it is long); real materials load without a word.
TEST(MjcfErrors, ImplausibleValuesAreWarnedAbout) {
  const std::string rod = R"(<cosserat name="a" length="0.3")";
  const std::string rod4 = rod + R"( sections="4")";
  const struct {
    std::string xml;
    std::string warning;  // "" for none
  } cases[] = {
      // a soft PCS rod without `sections`: one constant-strain section (outside probe BL: a soft
      // cantilever drooped 29% short of its converged tip drop, quietly)
      {in_world(rod + "/>"), "inline.xml:3: <cosserat>: sections not given: one PCS section, whose strain is constant"},
      {in_world(rod + R"( order="2"/>)"), ""},
      // a rod site's pos along the centre line (outside probe BL): rigid with its cross-section
      {in_world(rod4 + "><site name=\"s\" at=\"0.1\" pos=\"0.05 0.008 0\"/></cosserat>"),
       "inline.xml:3: <site>: pos has 0.05 along the centre line: the site rides rigidly with the cross-section at at=\"0.1\", not with the material point that far along the rod (which the rod's bending moves); give at=\"0.15\" and pos=\"0.008 0\" for that point"},
      {in_world(rod4 + "><site name=\"s\" at=\"0.3\" pos=\"0.05 0.008 0\"/></cosserat>"), ""},  // beyond the tip
      {in_world(rod4 + "><site name=\"s\" at=\"0.1\" pos=\"0.008 0\"/></cosserat>"), ""},
      {in_world(rod + R"( strain="rigid"/>)"), ""},
      {in_world(rod + R"( strain="icc"/>)"), ""},  // one arc: the constant-curvature model chosen
      // a rest curvature tighter than the rod is thick (outside probe BL: degrees for radians per metre)
      {in_world(rod + R"( sections="8" radius="0.012" reststrain="0 0 90 1 0 0"/>)"),
       "inline.xml:3: <cosserat>: reststrain bends the rod with curvature 90 1/m, a radius 0.0111111 m below the rod's radius 0.012 m"},
      {in_world(rod + R"( sections="8" radius="0.01" reststrain="0 0 90 1 0 0"/>)"), ""},
      // a coil in one section (outside probe CD: a 5-turn helix in one section, its frequencies
      // 23-49% off); a turn and a half per section of twist alone, or 0.9 turn of bending, are not
      {in_world(rod + R"( sections="2" radius="0.001" reststrain="0 0 60 1 0 0"/>)"),
       "inline.xml:3: <cosserat>: 2 sections (the first: 0) coil through up to 1.43 turns at rest"},
      {in_world(rod + R"( sections="2" radius="0.001" reststrain="60 0 0 1 0 0"/>)"), ""},
      {in_world(rod + R"( sections="2" radius="0.001" reststrain="0 0 37.7 1 0 0"/>)"), ""},
      {in_world(rod + R"( strain="spring"/>)"), ""},
      {in_world(rod4 + R"( radius="0.005" young="1e6" density="1000"/>)"), ""},
      {in_world(rod4 + R"( radius="0.005" young="1e12" density="22000"/>)"), ""},
      {in_world(rod4 + R"( radius="1e-8" young="1e10" density="1300"/>)"), ""},  // a bacterial flagellum
      {in_world(rod4 + R"( radius="0.15"/>)"), ""},  // as thick as long: the limit
      {in_world(rod4 + R"( radius="2"/>)"), "inline.xml:3: <cosserat>: the rod is thicker than it is long (diameter 4 m, length 0.3 m)"},
      {in_world(rod4 + R"( radius="0.01 0.2"/>)"), "inline.xml:3: <cosserat>: the rod is thicker than it is long (diameter 0.4 m"},
      {in_world(rod4 + R"( radius="1e-12"/>)"), "inline.xml:3: <cosserat>: radius 1e-12 m is below molecular sizes"},
      {in_world(rod4 + R"( young="0.5"/>)"), "inline.xml:3: <cosserat>: young 0.5 Pa is outside the moduli of real materials"},
      {in_world(rod4 + R"( young="2e14"/>)"), "inline.xml:3: <cosserat>: young 2e+14 Pa is outside the moduli"},
      // a slip to MPa or g/cm^3 (outside probe BL: silicone's 1 MPa and 1.1 g/cm^3 had loaded quietly)
      {in_world(rod4 + R"( young="1"/>)"), "inline.xml:3: <cosserat>: young 1 Pa is softer than all but the softest gels (silicones and rubbers 1e5 to 1e8 Pa): check the units (Pa; 1 MPa is 1e+06 Pa)"},
      {in_world(rod4 + R"( young="100"/>)"), ""},
      {in_world(rod4 + R"( density="1.1"/>)"), "inline.xml:3: <cosserat>: density 1.1 kg/m^3 is lighter than any solid but aerogels and the lightest foams (water 1000, silicone about 1100): check the units (kg/m^3; 1.1 g/cm^3 is 1100 kg/m^3)"},
      {in_world(rod4 + R"( density="50"/>)"), ""},
      {in_world(rod4 + R"( density="0.001"/>)"), "inline.xml:3: <cosserat>: density 0.001 kg/m^3 is outside the densities of real solids"},
      {in_world(rod + ">\n<section/>\n<section density=\"1e6\"/>\n</cosserat>"),
       "inline.xml:5: <section>: density 1e+06 kg/m^3 is outside the densities of real solids"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.xml);
    const Preprocessed p = preprocess_string(c.xml, kInline);
    if (c.warning.empty()) {
      EXPECT_TRUE(p.warnings.empty()) << p.warnings.front();
    } else {
      ASSERT_EQ(p.warnings.size(), 1u);
      EXPECT_EQ(p.warnings[0].rfind(kData + c.warning, 0), 0u) << p.warnings[0];
    }
  }
  // the scene keeps them for the tools that load it
  const auto scene = load_scene_string(in_world(rod4 + R"( young="0.5"/>)"), kInline);
  ASSERT_EQ(scene->load_warnings.size(), 1u);
  EXPECT_NE(scene->load_warnings[0].find("young 0.5 Pa"), std::string::npos);

  // said of the compiled model: whether the capsules collide by the rod's contype and conaffinity,
  // its class's or a default's alike (outside probe BQ: two zeros from a class had been warned about)
  const struct {
    std::string xml;
    std::string warning;  // "" for none
  } compiled[] = {
      // one soft PCS section touching at its two ends only, which its 2 Gauss points of mass let
      // move without moving any mass (outside probe AX: lying on a floor it sank through it)
      {in_world(rod + R"( sections="1" capsules="1"/>)"),
       "inline.xml:3: <cosserat>: one section with capsules=\"1\" touches only at the section's two ends"},
      {in_world(rod + R"( sections="1" capsules="2"/>)"), ""},
      {in_world(rod + R"( sections="2" capsules="1"/>)"), ""},
      {in_world(rod + R"( sections="1" capsules="1" quadrature="3"/>)"), ""},
      {in_world(rod + R"( sections="1" capsules="1" quadrature="lobatto"/>)"), ""},
      {in_world(rod + R"( sections="1" capsules="1" strain="rigid"/>)"), ""},
      {in_world(rod + R"( sections="1" capsules="1" contype="0" conaffinity="0"/>)"), ""},
      {"<mujoco>\n<default><default class=\"nc\"><geom contype=\"0\" conaffinity=\"0\"/></default></default>\n<worldbody>\n" +
           rod + R"( sections="1" capsules="1" class="nc"/>)" + "\n</worldbody>\n</mujoco>\n",
       ""},
      {"<mujoco>\n<default><geom contype=\"0\" conaffinity=\"0\"/></default>\n<worldbody>\n" + rod +
           R"( sections="1" capsules="1"/>)" + "\n</worldbody>\n</mujoco>\n",
       ""},
      {"<mujoco>\n<default><geom contype=\"0\" conaffinity=\"0\"/></default>\n<worldbody>\n" + rod +
           R"( sections="1" capsules="1" conaffinity="1"/>)" + "\n</worldbody>\n</mujoco>\n",
       "inline.xml:4: <cosserat>: one section with capsules=\"1\" touches only at the section's two ends"},
  };
  for (const auto& c : compiled) {
    SCOPED_TRACE(c.xml);
    const auto sc = load_scene_string(c.xml, kInline);
    if (c.warning.empty()) {
      EXPECT_TRUE(sc->load_warnings.empty()) << sc->load_warnings.front();
    } else {
      ASSERT_EQ(sc->load_warnings.size(), 1u);
      EXPECT_EQ(sc->load_warnings[0].rfind(kData + c.warning, 0), 0u) << sc->load_warnings[0];
    }
  }
}

// <compiler discardvisual="true"> drops the capsules of a rod that cannot collide: said at the rod's
// line (outside probe P: "internal: generated element 'arm/s0/g0' missing"); a colliding rod keeps them.
TEST(MjcfErrors, DiscardVisualWithARodThatCannotCollideIsExplained) {
  const std::string head = "<mujoco>\n<compiler discardvisual=\"true\"/>\n<worldbody>\n<cosserat name=\"arm\" length=\"0.3\"";
  try {
    load_scene_string(head + " contype=\"0\" conaffinity=\"0\"/>\n</worldbody>\n</mujoco>\n", kInline);
    ADD_FAILURE() << "no LoadError";
  } catch (const LoadError& e) {
    EXPECT_EQ(e.line, 4) << e.what();
    EXPECT_NE(e.message.find("discardvisual=\"true\"> discards the capsules of a rod that cannot collide"),
              std::string::npos) << e.what();
  }
  const auto scene = load_scene_string(head + "/>\n</worldbody>\n</mujoco>\n", kInline);
  EXPECT_EQ(scene->rods[0].geom_id.size(), 2u);  // one section (the default) of 2 capsules
}

TEST(MjcfErrors, ModelThatIsNotARegularFile) {
  for (const std::string& path : {std::string("/dev/zero"), kData}) {
    try {
      preprocess_file(path);
      ADD_FAILURE() << "no LoadError for " << path;
    } catch (const LoadError& e) {
      EXPECT_EQ(e.file, path);
      EXPECT_NE(e.message.find(path == kData ? "is a directory" : "is not a regular file"), std::string::npos) << e.what();
    }
  }
}

TEST(MjcfErrors, MissingTopLevelFile) {
  try {
    preprocess_file(kData + "does_not_exist.xml");
    ADD_FAILURE() << "no LoadError";
  } catch (const LoadError& e) {
    EXPECT_TRUE(e.file.ends_with("does_not_exist.xml"));
    EXPECT_NE(e.message.find("cannot open"), std::string::npos);
  }
}

// Never crash: every prefix and many random mutations of a good scene either pre-process or give
// a LoadError (nothing else escapes).
TEST(MjcfErrors, TruncatedAndMutatedInputOnlyGivesLoadErrors) {
  const std::string good = in_world(R"(<body name="b" pos="0 0 1">
<cosserat name="a" length="1" sections="2" radius="0.02 0.01" strain="sr" order="1">
<site name="s" at="0.25" pos="0 0.01"/>
<section length="0.4" dofs="1 1 1 1 0 0"/>
<section young="2e6"/>
<body name="tip"><geom size="0.01"/></body>
</cosserat>
</body>)");
  ASSERT_NO_THROW(preprocess_string(good, kInline));
  auto survives = [](const std::string& xml) {
    try {
      preprocess_string(xml, kInline);
    } catch (const LoadError& e) {
      EXPECT_GE(e.line, 0);
      EXPECT_FALSE(e.message.empty());
    }
  };
  for (std::size_t n = 0; n < good.size(); ++n) survives(good.substr(0, n));
  std::mt19937 rng(7);
  const std::string alphabet = "<>/=\" -.0123456789eaxz";
  for (int k = 0; k < 3000; ++k) {
    std::string xml = good;
    for (int m = 0; m < 3; ++m) xml[rng() % xml.size()] = alphabet[rng() % alphabet.size()];
    survives(xml);
  }
}

// ------------------------------------------------------------------------------------------------
// Good scenes

TEST(MjcfScenes, OneRodNamesCountsAndSites) {
  const std::string xml = R"(<mujoco>
  <worldbody>
    <cosserat name="arm" pos="0 0 1" length="0.6" sections="3" radius="0.02 0.01">
      <site name="mid" at="0.3" pos="0.01 0.02"/>
      <site name="edge" at="0.2"/>
      <site name="start" at="0"/>
      <site name="end" at="0.6" pos="0.001 0 0"/>
    </cosserat>
    <body name="ball" pos="1 0 1"><freejoint/><geom size="0.05"/></body>
  </worldbody>
</mujoco>
)";
  const Preprocessed p = preprocess_string(xml, kInline);
  ASSERT_EQ(p.rods.size(), 1u);
  const RodDecl& rod = p.rods[0];

  // declaration
  EXPECT_EQ(rod.name, "arm");
  EXPECT_EQ(rod.parent_body, "world");
  EXPECT_EQ(rod.file, kInline);
  EXPECT_EQ(rod.line, 3);
  EXPECT_EQ(rod.spec.sections, 3);
  ASSERT_EQ(rod.spec.overrides.size(), 3u);
  for (const auto& s : rod.spec.overrides) EXPECT_NEAR(s.length, 0.2, 1e-15);
  EXPECT_DOUBLE_EQ(rod.spec.radius_base, 0.02);
  EXPECT_DOUBLE_EQ(rod.spec.radius_tip, 0.01);
  EXPECT_EQ(rod.proxies, (std::vector<std::string>{"arm/s0", "arm/s1", "arm/s2"}));
  EXPECT_EQ(rod.joints.size(), 12u);
  EXPECT_EQ(static_cast<int>(rod.joints.size()), core_dofs(rod.spec));
  EXPECT_EQ(rod.joints[0], "arm/s0/kx");
  EXPECT_EQ(rod.joints[3], "arm/s0/px");
  EXPECT_EQ(rod.joints[11], "arm/s2/px");
  ASSERT_EQ(rod.geoms.size(), 6u);
  EXPECT_EQ(rod.geoms[3].name, "arm/s1/g1");
  EXPECT_EQ(rod.geoms[3].section, 1);
  EXPECT_NEAR(rod.geoms[3].X_begin, 0.3, 1e-15);
  EXPECT_NEAR(rod.geoms[3].X_end, 0.4, 1e-15);
  ASSERT_EQ(rod.sites.size(), 6u);
  EXPECT_EQ(rod.sites.front().name, "arm/base");
  EXPECT_EQ(rod.sites.back().name, "arm/tip");
  EXPECT_DOUBLE_EQ(rod.sites.back().X, 0.6);

  // compiled model: counts and names
  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->nq, 12 + 7);
  EXPECT_EQ(m->nv, 12 + 6);
  for (const auto& b : {"arm/base", "arm/s0", "arm/s1", "arm/s2"}) EXPECT_GE(id(m.get(), mjOBJ_BODY, b), 0) << b;
  for (const auto& j : rod.joints) EXPECT_GE(id(m.get(), mjOBJ_JOINT, j), 0) << j;
  for (const auto& g : rod.geoms) EXPECT_GE(id(m.get(), mjOBJ_GEOM, g.name), 0) << g.name;
  for (const auto& s : rod.sites) EXPECT_GE(id(m.get(), mjOBJ_SITE, s.name), 0) << s.name;
  for (int j = 0; j < 12; ++j) {
    EXPECT_EQ(m->jnt_type[j], mjJNT_SLIDE);
    EXPECT_EQ(m->jnt_limited[j], 0);
    EXPECT_EQ(m->jnt_stiffness[j], 0.0);
    EXPECT_EQ(m->dof_damping[j], 0.0);
  }
  // exclusions: 3 proxy pairs, 3 proxy-base pairs; none against the world (a floor must collide)
  EXPECT_EQ(m->nexclude, 3 + 3);

  // sites in the right proxies (a boundary belongs to the earlier section), poses in the proxy frame
  auto site_body = [&](const char* s) { return m->site_bodyid[id(m.get(), mjOBJ_SITE, s)]; };
  const int s0 = id(m.get(), mjOBJ_BODY, "arm/s0"), s1 = id(m.get(), mjOBJ_BODY, "arm/s1"),
            s2 = id(m.get(), mjOBJ_BODY, "arm/s2");
  EXPECT_EQ(site_body("arm/base"), id(m.get(), mjOBJ_BODY, "arm/base"));
  EXPECT_EQ(site_body("start"), s0);
  EXPECT_EQ(site_body("edge"), s0);
  EXPECT_EQ(site_body("mid"), s1);
  EXPECT_EQ(site_body("end"), s2);
  EXPECT_EQ(site_body("arm/tip"), s2);
  const mjtNum* mid_pos = m->site_pos + 3 * id(m.get(), mjOBJ_SITE, "mid");
  EXPECT_NEAR(mid_pos[0], -0.1, 1e-12);
  EXPECT_NEAR(mid_pos[1], 0.01, 1e-12);
  EXPECT_NEAR(mid_pos[2], 0.02, 1e-12);

  // capsules: radius of the taper at their middle, centred on their X range
  const int g = id(m.get(), mjOBJ_GEOM, "arm/s0/g0");
  EXPECT_EQ(m->geom_type[g], mjGEOM_CAPSULE);
  EXPECT_NEAR(m->geom_size[3 * g], 0.02 - 0.01 * 0.05 / 0.6, 1e-12);
  EXPECT_NEAR(m->geom_size[3 * g + 1], 0.05, 1e-12);  // half length
  EXPECT_NEAR(m->geom_pos[3 * g], 0.05 - 0.2, 1e-12);

  // straight rest shape at qpos0
  DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  auto xpos = [&](const char* s) { return d->site_xpos + 3 * id(m.get(), mjOBJ_SITE, s); };
  EXPECT_NEAR(xpos("arm/tip")[0], 0.6, 1e-12);
  EXPECT_NEAR(xpos("arm/tip")[2], 1.0, 1e-12);
  EXPECT_NEAR(xpos("mid")[0], 0.3, 1e-12);
  EXPECT_NEAR(xpos("mid")[1], 0.01, 1e-12);
  EXPECT_NEAR(xpos("mid")[2], 1.02, 1e-12);
  EXPECT_NEAR(xpos("end")[0], 0.601, 1e-12);
}

TEST(MjcfScenes, RodOnTheTipOfAnotherRod) {
  const std::string xml = R"(<mujoco>
  <worldbody>
    <body name="mount" pos="0 0 1">
      <cosserat name="arm" length="0.5" sections="2" strain="kl">
        <body name="hand" pos="0.05 0 0">
          <joint name="wrist" type="hinge" axis="0 0 1"/>
          <geom size="0.02"/>
          <cosserat name="finger" pos="0.02 0 0" length="0.2" sections="2" strain="sr" order="1">
            <site name="fingertip_probe" at="0.2"/>
          </cosserat>
        </body>
      </cosserat>
    </body>
  </worldbody>
</mujoco>
)";
  const Preprocessed p = preprocess_string(xml, kInline);
  ASSERT_EQ(p.rods.size(), 2u);
  EXPECT_EQ(p.rods[0].parent_body, "mount");
  EXPECT_EQ(p.rods[1].parent_body, "hand");
  EXPECT_EQ(p.rods[1].joints.size(), 24u);  // 6 components x 2 Legendre terms x 2 sections
  EXPECT_EQ(p.rods[1].joints[0], "finger/s0/kx0");
  EXPECT_EQ(p.rods[1].joints[1], "finger/s0/kx1");
  EXPECT_EQ(p.rods[1].joints[11], "finger/s0/pz1");

  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  int rod_dofs = 0;
  for (const auto& r : p.rods) rod_dofs += core_dofs(r.spec);
  EXPECT_EQ(rod_dofs, 8 + 24);
  EXPECT_EQ(m->nv, rod_dofs + 1);
  EXPECT_EQ(m->nq, rod_dofs + 1);
  // 12 dofs per section: MuJoCo 2.2.2 takes at most 6 per body, so a helper body carries the
  // first 6 joints of each section just above its proxy
  const int helper = id(m.get(), mjOBJ_BODY, "finger/s0/h0");
  ASSERT_GE(helper, 0);
  EXPECT_EQ(m->jnt_bodyid[id(m.get(), mjOBJ_JOINT, "finger/s0/ky1")], helper);
  EXPECT_EQ(m->jnt_bodyid[id(m.get(), mjOBJ_JOINT, "finger/s0/px0")], id(m.get(), mjOBJ_BODY, "finger/s0"));
  EXPECT_EQ(m->body_parentid[id(m.get(), mjOBJ_BODY, "finger/s0")], helper);
  EXPECT_EQ(m->body_parentid[id(m.get(), mjOBJ_BODY, "finger/s1/h0")], id(m.get(), mjOBJ_BODY, "finger/s0"));
  // (the coupling zeroes helper and proxy masses after compiling: tests/mujoco/scene_test.cpp)
  for (std::size_t j = 0; j < p.rods[1].joints.size(); ++j)  // MuJoCo's dof order is the core's
    EXPECT_EQ(m->jnt_dofadr[id(m.get(), mjOBJ_JOINT, p.rods[1].joints[j])],
              m->jnt_dofadr[id(m.get(), mjOBJ_JOINT, p.rods[1].joints[0])] + static_cast<int>(j));
  const int hand = id(m.get(), mjOBJ_BODY, "hand");
  EXPECT_EQ(m->body_parentid[hand], id(m.get(), mjOBJ_BODY, "arm/s1"));
  EXPECT_EQ(m->body_parentid[id(m.get(), mjOBJ_BODY, "finger/base")], hand);
  EXPECT_EQ(m->site_bodyid[id(m.get(), mjOBJ_SITE, "fingertip_probe")], id(m.get(), mjOBJ_BODY, "finger/s1"));

  DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  EXPECT_NEAR(d->xpos[3 * hand], 0.55, 1e-12);  // tip frame + the body's own pos
  EXPECT_NEAR(d->site_xpos[3 * id(m.get(), mjOBJ_SITE, "finger/tip")], 0.77, 1e-12);
}

// quadrature="lobatto" (PCS: the 3-point Gauss-Lobatto mass rule) is inherited by the sections
// and replaced by a Gauss point count, or by "gauss" (the default rule, order + 2 points).
TEST(MjcfScenes, LobattoMassRule) {
  const std::string xml = in_world(R"(<cosserat name="arm" length="1" quadrature="lobatto">
  <section/>
  <section quadrature="3"/>
  <section quadrature="gauss"/>
</cosserat>)");
  const Preprocessed p = preprocess_string(xml, kInline);
  const auto& s = p.rods.at(0).spec.overrides;
  ASSERT_EQ(s.size(), 3u);
  EXPECT_TRUE(p.rods.at(0).spec.section.lobatto);
  EXPECT_TRUE(s[0].lobatto);
  EXPECT_EQ(s[0].quadrature, 0);
  EXPECT_FALSE(s[1].lobatto);
  EXPECT_EQ(s[1].quadrature, 3);
  EXPECT_FALSE(s[2].lobatto);
  EXPECT_EQ(s[2].quadrature, 0);
}

TEST(MjcfScenes, SectionOverrides) {
  const std::string xml = in_world(R"(<cosserat name="arm" length="1" strain="kl" density="500">
  <section length="0.5" strain="pcc" order="2"/>
  <section dofs="1 0 0 0 0 1" young="2e6"/>
  <section reststrain="0 0 1 1 0 0" quadrature="5"/>
</cosserat>)");
  const Preprocessed p = preprocess_string(xml, kInline);
  const RodDecl& rod = p.rods.at(0);
  const auto& s = rod.spec.overrides;
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(rod.spec.sections, 3);
  EXPECT_DOUBLE_EQ(s[0].length, 0.5);
  EXPECT_DOUBLE_EQ(s[1].length, 0.25);
  EXPECT_DOUBLE_EQ(s[2].length, 0.25);
  EXPECT_EQ(s[0].order, 2);
  EXPECT_EQ(s[1].order, 0);
  EXPECT_EQ(s[1].dofs, (StrainMask{true, false, false, false, false, true}));
  EXPECT_EQ(s[2].dofs, (StrainMask{true, true, true, true, false, false}));
  for (const auto& ss : s) EXPECT_EQ(ss.material.density, 500.0);
  EXPECT_EQ(s[0].material.young, 1e6);
  EXPECT_EQ(s[1].material.young, 2e6);
  EXPECT_EQ(s[2].rest_strain(2), 1.0);
  EXPECT_EQ(s[2].quadrature, 5);
  EXPECT_EQ(rod.joints, (std::vector<std::string>{"arm/s0/kz0", "arm/s0/kz1", "arm/s0/kz2", "arm/s0/px0",
                                                  "arm/s0/px1", "arm/s0/px2", "arm/s1/kx", "arm/s1/pz",
                                                  "arm/s2/kx", "arm/s2/ky", "arm/s2/kz", "arm/s2/px"}));
  EXPECT_EQ(static_cast<int>(rod.joints.size()), core_dofs(rod.spec));

  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->nv, 12);
  // the proxy of section 1 sits at X = 0.75, one of section 0 at X = 0.5
  DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  EXPECT_NEAR(d->xpos[3 * id(m.get(), mjOBJ_BODY, "arm/s0")], 0.5, 1e-12);
  EXPECT_NEAR(d->xpos[3 * id(m.get(), mjOBJ_BODY, "arm/s1")], 0.75, 1e-12);
}

TEST(MjcfScenes, RigidSectionHasNoJoints) {
  const Preprocessed p = preprocess_string(in_world(R"(<cosserat name="a" length="1" sections="2" strain="rigid"/>)"), kInline);
  EXPECT_TRUE(p.rods.at(0).joints.empty());
  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->nv, 0);
}

// The deepest chain MuJoCo's XML parser takes (the bad-input table has one section more than this
// is refused with a LoadError instead of MuJoCo's parse error).
TEST(MjcfScenes, DeepestChainMuJoCoAccepts) {
  const Preprocessed p = preprocess_string(
      in_world("<body name=\"b\">\n<cosserat name=\"a\" length=\"1\" sections=\"94\" capsules=\"1\"/>\n</body>"), kInline);
  EXPECT_TRUE(compile(p));
  EXPECT_THROW(preprocess_string(
                   in_world("<body name=\"b\">\n<cosserat name=\"a\" length=\"1\" sections=\"95\" capsules=\"1\"/>\n</body>"),
                   kInline),
               LoadError);
  // GVS sections of 20 dofs nest 4 bodies each: the table's hint, 23, is the limit
  EXPECT_TRUE(compile(preprocess_string(
      in_world("<cosserat name=\"a\" length=\"1\" sections=\"23\" order=\"4\" strain=\"kl\" capsules=\"1\"/>"), kInline)));
  EXPECT_THROW(preprocess_string(
                   in_world("<cosserat name=\"a\" length=\"1\" sections=\"24\" order=\"4\" strain=\"kl\" capsules=\"1\"/>"), kInline),
               LoadError);
}

TEST(MjcfScenes, IncludesAndDefaultClasses) {
  const Preprocessed p = preprocess_file(kData + "scene_include.xml");
  EXPECT_EQ(p.xml.find("<include"), std::string::npos);
  EXPECT_EQ(p.xml.find("<cosserat"), std::string::npos);
  ASSERT_EQ(p.rods.size(), 1u);
  const RodDecl& rod = p.rods[0];
  EXPECT_TRUE(rod.file.ends_with("parts/arm.xml")) << rod.file;
  EXPECT_EQ(rod.line, 3);
  EXPECT_EQ(rod.parent_body, "mount");

  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  // the class of the rod's capsules comes from the included <default>
  const int g = id(m.get(), mjOBJ_GEOM, "arm/s1/g0");
  ASSERT_GE(g, 0);
  EXPECT_FLOAT_EQ(m->geom_rgba[4 * g + 2], 0.3f);
  EXPECT_EQ(m->geom_contype[g], 0);
  // the tip weight, included from parts/tipweight.xml inside the <cosserat>
  const int w = id(m.get(), mjOBJ_BODY, "weight");
  ASSERT_GE(w, 0);
  EXPECT_EQ(m->body_parentid[w], id(m.get(), mjOBJ_BODY, "arm/s1"));
  EXPECT_NEAR(m->body_mass[w], 0.05, 1e-12);
  EXPECT_EQ(m->nv, 8);
}

// Nested includes are read relative to the main model's directory, as MuJoCo 2.2.2 reads them
// (outside probe P: they were read relative to the including file, and a file of the same name
// there loaded instead). MuJoCo's own reading is checked on the same files without the rod.
TEST(MjcfScenes, NestedIncludesAreRelativeToTheMainModelsDirectory) {
  const fs::path dir = fs::temp_directory_path() / ("cosserat_nested_include_" + std::to_string(getpid()));
  fs::create_directories(dir / "sub");
  auto write = [&](const fs::path& f, const std::string& text) { std::ofstream(dir / f) << text; };
  write("tip.xml", "<mujoco><body name=\"from_main_dir\"><geom size=\"0.01\"/></body></mujoco>");
  write("sub/tip.xml", "<mujoco><body name=\"from_sub_dir\"><geom size=\"0.01\"/></body></mujoco>");
  write("sub/arm.xml", "<mujoco><cosserat name=\"arm\" length=\"0.3\"><include file=\"tip.xml\"/></cosserat></mujoco>");
  write("sub/native.xml", "<mujoco><body name=\"b\"><geom size=\"0.01\"/><include file=\"tip.xml\"/></body></mujoco>");
  write("main.xml", "<mujoco><worldbody><include file=\"sub/arm.xml\"/></worldbody></mujoco>");
  write("native.xml", "<mujoco><worldbody><include file=\"sub/native.xml\"/></worldbody></mujoco>");
  char error[512] = "";
  ModelPtr native(mj_loadXML((dir / "native.xml").c_str(), nullptr, error, sizeof error));
  ASSERT_TRUE(native) << error;
  EXPECT_GE(id(native.get(), mjOBJ_BODY, "from_main_dir"), 0);  // MuJoCo's reading
  EXPECT_LT(id(native.get(), mjOBJ_BODY, "from_sub_dir"), 0);
  ModelPtr m = compile(preprocess_file((dir / "main.xml").string()));
  ASSERT_TRUE(m);
  EXPECT_GE(id(m.get(), mjOBJ_BODY, "from_main_dir"), 0);
  EXPECT_LT(id(m.get(), mjOBJ_BODY, "from_sub_dir"), 0);
  fs::remove_all(dir);
}

// euler with <compiler angle="degree">: the base frame is rotated by MuJoCo's own rules.
TEST(MjcfScenes, OrientationUsesCompilerAngleUnits) {
  for (const std::string compiler : {R"(<compiler angle="degree"/>)", R"(<compiler angle="radian"/>)"}) {
    const std::string angle = compiler.find("degree") != std::string::npos ? "90" : "1.5707963267948966";
    const std::string xml = "<mujoco>\n" + compiler + "\n<worldbody>\n<cosserat name=\"arm\" pos=\"0 0 1\" euler=\"0 0 " +
                            angle + "\" length=\"0.5\" sections=\"2\"/>\n</worldbody>\n</mujoco>\n";
    const Preprocessed p = preprocess_string(xml, kInline);
    ModelPtr m = compile(p);
    ASSERT_TRUE(m);
    DataPtr d(mj_makeData(m.get()));
    mj_kinematics(m.get(), d.get());
    const mjtNum* R = d->xmat + 9 * id(m.get(), mjOBJ_BODY, "arm/base");
    const double expected[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};  // rotation of 90 degrees about z
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(R[k], expected[k], 1e-9) << compiler << " k=" << k;
    const mjtNum* tip = d->site_xpos + 3 * id(m.get(), mjOBJ_SITE, "arm/tip");
    EXPECT_NEAR(tip[0], 0.0, 1e-9);
    EXPECT_NEAR(tip[1], 0.5, 1e-9);
    EXPECT_NEAR(tip[2], 1.0, 1e-9);
  }
}

// selfcollide keeps only the exclusions against the parent (none here: the world); they merge into an existing
// <contact>; tendons, actuators and sensors referring to generated names pass through.
TEST(MjcfScenes, SelfCollideContactMergeAndPassThrough) {
  const std::string xml = R"(<mujoco>
  <worldbody>
    <body name="ball" pos="0 0 0.5"><freejoint/><geom name="ball" size="0.05"/></body>
    <cosserat name="arm" pos="0 0 1" length="0.5" sections="4" selfcollide="true" condim="1"
              friction="0.5" contype="2" conaffinity="3" group="2"/>
  </worldbody>
  <contact>
    <exclude body1="ball" body2="world"/>
  </contact>
  <tendon>
    <spatial name="cable"><site site="arm/base"/><site site="arm/tip"/></spatial>
  </tendon>
  <actuator>
    <motor name="bend" joint="arm/s0/kz"/>
    <motor name="pull" tendon="cable"/>
  </actuator>
  <sensor>
    <framepos name="tip" objtype="site" objname="arm/tip"/>
  </sensor>
</mujoco>
)";
  const Preprocessed p = preprocess_string(xml, kInline);
  std::size_t contacts = 0;
  for (std::size_t at = 0; (at = p.xml.find("<contact", at)) != std::string::npos; ++at) ++contacts;
  EXPECT_EQ(contacts, 1u);
  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->nexclude, 1);  // the user's own
  EXPECT_EQ(m->nu, 2);
  EXPECT_EQ(m->ntendon, 1);
  EXPECT_EQ(m->nsensor, 1);
  const int g = id(m.get(), mjOBJ_GEOM, "arm/s3/g1");
  EXPECT_EQ(m->geom_condim[g], 1);
  EXPECT_EQ(m->geom_contype[g], 2);
  EXPECT_EQ(m->geom_conaffinity[g], 3);
  EXPECT_EQ(m->geom_group[g], 2);
  EXPECT_DOUBLE_EQ(m->geom_friction[3 * g], 0.5);
}

TEST(MjcfScenes, ShippedCantileverLoads) {
  const Preprocessed p = preprocess_file(std::string(COSSERAT_SOURCE_DIR) + "/models/cantilever.xml");
  ASSERT_EQ(p.rods.size(), 1u);
  EXPECT_EQ(p.rods[0].parent_body, "world");
  ModelPtr m = compile(p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->nv, core_dofs(p.rods[0].spec));
  const int w = id(m.get(), mjOBJ_BODY, "weight");
  ASSERT_GE(w, 0);
  EXPECT_EQ(m->body_parentid[w], id(m.get(), mjOBJ_BODY, "beam/s7"));
}

// A VFS-loaded model resolves relative asset paths against the directory of the name it is
// loaded under (MuJoCo looks in the VFS by base name first, then on disk): loading under the
// original file's path makes meshdir-relative meshes work.
TEST(MjcfScenes, VfsAssetsResolveAgainstTheLoadName) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("mjcf_test_" + std::to_string(::getpid()));
  fs::create_directories(dir / "meshes");
  {
    // a binary STL tetrahedron
    std::ofstream stl(dir / "meshes" / "mjcf_test_tet.stl", std::ios::binary);
    const float v[4][3] = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, {0, 0, 0.1f}};
    const int f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    const char header[80] = {};
    stl.write(header, 80);
    const unsigned n = 4;
    stl.write(reinterpret_cast<const char*>(&n), 4);
    for (const auto& t : f) {
      const float normal[3] = {0, 0, 0};
      stl.write(reinterpret_cast<const char*>(normal), 12);
      for (int k : t) stl.write(reinterpret_cast<const char*>(v[k]), 12);
      const char attr[2] = {};
      stl.write(attr, 2);
    }
    std::ofstream scene(dir / "scene.xml");
    scene << R"(<mujoco><compiler meshdir="meshes"/><asset><mesh name="tet" file="mjcf_test_tet.stl"/></asset>
<worldbody><body name="b"><cosserat name="arm" length="0.3"><body name="w"><geom type="mesh" mesh="tet"/></body></cosserat></body></worldbody></mujoco>)";
  }
  const Preprocessed p = preprocess_file((dir / "scene.xml").string());
  std::string err;
  EXPECT_TRUE(load_xml(p.xml, p.path, &err)) << err;  // under the original path: found
  EXPECT_FALSE(load_xml(p.xml, "scene.xml", &err));   // under a bare name: relative to the cwd
  EXPECT_NE(err.find("mjcf_test_tet.stl"), std::string::npos) << err;
  fs::remove_all(dir);
}

}  // namespace

// Two rods mounted at one point of one body overlap at their bases, where MuJoCo collides them
// (the proxies are excluded only against the parent body and the tip bodies): a load warning at
// the second rod's line names the pairs to exclude (outside probe U: two branches from a hub pushed
// each other apart, and `equilibrium` fell back to relaxation). With those exclusions, or with the
// rods apart, nothing is said.
TEST(MjcfErrors, RodsOverlappingAtTheStartAreWarnedAbout) {
  auto xml = [](const char* pos_v, const char* contact) {
    return std::string("<mujoco>\n<worldbody>\n<body name=\"hub\" pos=\"0 0 1\">\n"
                       "<geom type=\"sphere\" size=\"0.02\" contype=\"0\" conaffinity=\"0\"/>\n"
                       "<cosserat name=\"u\" euler=\"0 -45 0\" length=\"0.4\" sections=\"8\" radius=\"0.01\"/>\n"
                       "<cosserat name=\"v\" pos=\"") +
           pos_v + "\" euler=\"0 0 60\" length=\"0.4\" sections=\"8\" radius=\"0.01\"/>\n</body>\n</worldbody>\n" +
           contact + "</mujoco>";
  };
  const auto together = load_scene_string(xml("0 0 0", ""), kInline);
  ASSERT_EQ(together->load_warnings.size(), 1u);
  const std::string& w = together->load_warnings[0];
  EXPECT_EQ(w.rfind(kData + std::string("inline.xml:6: <cosserat name=\"v\">: its capsules overlap those of rod 'u'"), 0), 0u) << w;
  EXPECT_NE(w.find(R"(<exclude body1="u/s0" body2="v/s0"/>)"), std::string::npos) << w;
  const auto excluded = load_scene_string(xml("0 0 0", "<contact><exclude body1=\"u/s0\" body2=\"v/s0\"/></contact>\n"), kInline);
  EXPECT_TRUE(excluded->load_warnings.empty()) << excluded->load_warnings.front();
  const auto apart = load_scene_string(xml("0 0.05 0", ""), kInline);
  EXPECT_TRUE(apart->load_warnings.empty()) << apart->load_warnings.front();
  // a selfcollide rod whose sections are shorter than its diameter overlaps itself (outside probe
  // W: 58 contacts at rest stretched it 7.7%); without selfcollide its sections never collide
  for (const bool self : {true, false}) {
    const auto rod = load_scene_string(std::string("<mujoco>\n<worldbody>\n<cosserat name=\"u\" length=\"0.2\" sections=\"8\" "
                                                   "radius=\"0.03\"") + (self ? " selfcollide=\"true\"" : "") +
                                           "/>\n</worldbody>\n</mujoco>",
                                       kInline);
    if (!self) {
      EXPECT_TRUE(rod->load_warnings.empty()) << rod->load_warnings.front();
      continue;
    }
    ASSERT_EQ(rod->load_warnings.size(), 1u);
    EXPECT_NE(rod->load_warnings[0].find("inline.xml:3: <cosserat name=\"u\">: with selfcollide=\"true\" its own capsules overlap"),
              std::string::npos) << rod->load_warnings[0];
    EXPECT_NE(rod->load_warnings[0].find(R"(<exclude body1="u/s0" body2="u/s2"/>)"), std::string::npos);
  }
}

// A <key>'s arrays with spaces around the numbers load as the numbers (MuJoCo 2.2.2 counts a
// trailing space as one more number: "invalid qpos size, expected length 11" for 11 numbers,
// outside probe X).
TEST(MjcfErrors, KeyframeArraysWithSurroundingSpacesLoad) {
  const auto s = load_scene_string(R"(<mujoco><worldbody><body name="b" pos="0 0 1"><freejoint/>
      <geom type="sphere" size="0.1"/></body>
      <cosserat name="r" pos="1 0 0" length="0.1" contype="0" conaffinity="0"/></worldbody>
    <keyframe><key name="k" qpos=" 0 0 2 1 0 0 0 0 0 0 0 "/></keyframe></mujoco>)",
                                   kInline);
  ASSERT_EQ(s->m->nkey, 1);
  EXPECT_EQ(s->m->nq, 11);
  EXPECT_EQ(s->m->key_qpos[2], 2.0);
}

// <size> user data and keyframes below the loader's gigabyte load and reach MuJoCo (the refused
// sizes: TableOfBadInput); the bound counts the model's elements, rods' generated ones included:
// 2 million numbers on each of 3 sites (48 MB) load, where nuser_site="100000000" on
// the rod's two sites (1.6 GB) is refused.
TEST(MjcfErrors, SizesWithinTheLoadersBudgetLoad) {
  const auto s = load_scene_string(R"(<mujoco><size nuser_site="2000000" nkey="1000" nuser_body="3"/><worldbody>
      <site name="a"/><cosserat name="r" length="0.1" sections="2" contype="0" conaffinity="0"/></worldbody></mujoco>)",
                                   kInline);
  EXPECT_EQ(s->m->nuser_site, 2000000);
  EXPECT_EQ(s->m->nsite, 3);
  EXPECT_EQ(s->m->nkey, 1000);
  EXPECT_EQ(s->m->nuser_body, 3);
}

// strainrange puts MuJoCo joint limits on a PCS section's strain joints (the rod's range on each
// section, a <section>'s own over it; solreflimit and solimplimit with them), and a strain pushed
// past its limit stops there: a clamped rod of two kl sections (E = 1e7 Pa, r = 1 cm, heavily damped
// to rest), its first section bent by a motor on its kz that alone bends it to 5.09 1/m, limited
// to 5 1/m, rests as an arc of curvature 5 over 0.25 m with the unloaded second section straight
// along its end tangent: the tip at (sin t / k + 0.25 cos t, (1 - cos t) / k + 0.25 sin t), t = 0.25 k,
// to MuJoCo's soft-limit penetration (5.0006 1/m measured), and a jointlimitfrc sensor reads the
// generalized force the limit carries, what the section's linear stiffness leaves of the motor's
// u: u (1 - k / k_free); a one-sided range "0 20" stops a negative moment at the rest shape.
TEST(MjcfScenes, StrainRangeLimitsTheStrain) {
  const std::string xml = R"(<mujoco><option timestep="0.001" gravity="0 0 0"/><worldbody>
    <cosserat name="rod" length="0.5" strain="kl" radius="0.01" density="1000" young="1e7" poisson="0.5" viscosity="1e6"
              strainrange="0 0 0 0 -5 5 0 0 0 0 0 0" solreflimit="0.01 1">
      <section/><section strainrange="-2 2 0 0 0 0 0 0 0 0 0 0"/>
    </cosserat></worldbody><actuator><motor name="m" joint="rod/s0/kz"/></actuator>
    <sensor><jointlimitfrc joint="rod/s0/kz"/></sensor></mujoco>)";
  auto s = load_scene_string(xml, kInline);
  const mjModel* m = s->m;
  for (const char* name : {"rod/s0/kx", "rod/s0/ky", "rod/s0/kz", "rod/s1/kx", "rod/s1/ky", "rod/s1/kz"}) {
    SCOPED_TRACE(name);
    const int j = mj_name2id(m, mjOBJ_JOINT, name);
    ASSERT_GE(j, 0);
    const bool limited = std::string(name) == "rod/s0/kz" || std::string(name) == "rod/s1/kx";
    EXPECT_EQ(m->jnt_limited[j], limited ? 1 : 0);
    if (!limited) continue;
    EXPECT_EQ(m->jnt_range[2 * j + 1], std::string(name) == "rod/s0/kz" ? 5.0 : 2.0);
    EXPECT_EQ(m->jnt_range[2 * j], -m->jnt_range[2 * j + 1]);
    EXPECT_EQ(m->jnt_solref[mjNREF * j], 0.01);
  }
  EXPECT_TRUE(s->may_have_events);  // (the midpoint rule's end-state check: limits can arise)
  double limit_force = 0.0;  // the jointlimitfrc sensor at the last rest
  auto rest = [&](const std::string& model, double u, int kz) {
    auto sc = load_scene_string(model, kInline);
    SceneData sd(*sc);
    sd.d->ctrl[0] = u;
    for (int k = 0; k < 3000; ++k) EXPECT_EQ(step(*sc, sd), Status::Ok);
    forward(*sc, sd);
    limit_force = sd.d->sensordata[0];
    return std::make_pair(sd.d->qpos[kz], Vec3(sd.d->site_xpos[3], sd.d->site_xpos[4], sd.d->site_xpos[5]));
  };
  const int kz = m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "rod/s0/kz")];
  using cosserat::testing::replace_all;
  const std::string unlimited = replace_all(replace_all(xml, R"(strainrange="0 0 0 0 -5 5 0 0 0 0 0 0")", ""),
                                            R"(<jointlimitfrc joint="rod/s0/kz"/>)", R"(<jointpos joint="rod/s0/kz"/>)");
  const auto [free_kz, free_tip] = rest(unlimited, 0.1, kz);
  EXPECT_GT(free_kz, 5.05);  // past the limit without it
  const auto [k, tip] = rest(xml, 0.1, kz);
  EXPECT_NEAR(k, 5.0, 1e-3);
  // the limit carries what the section's linear stiffness does not: u (1 - k / free_kz)
  EXPECT_NEAR(limit_force, 0.1 * (1 - k / free_kz), 1e-6) << limit_force;
  const double t = 0.25 * 5.0;
  EXPECT_NEAR(tip.x(), std::sin(t) / 5.0 + 0.25 * std::cos(t), 1e-4);
  EXPECT_NEAR(tip.y(), (1 - std::cos(t)) / 5.0 + 0.25 * std::sin(t), 1e-4);
  // one-sided: kz >= 0 (the rest shape at the limit); a negative moment leaves it straight
  const auto [k1, tip1] = rest(replace_all(xml, "0 0 0 0 -5 5 0 0 0 0 0 0", "0 0 0 0 0 20 0 0 0 0 0 0"), -0.1, kz);
  // (the soft limit carries the whole moment here, which alone bends it to about -5 1/m: 6.1e-3 1/m deep)
  EXPECT_NEAR(k1, 0.0, 1e-2);
  EXPECT_NEAR(tip1.y(), 0.0, 1e-3);
}
