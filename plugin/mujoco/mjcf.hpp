// MJCF pre-processing: turns <cosserat> elements into MuJoCo proxy bodies (DESIGN.md sections 6-7)
// and collects the rod declarations the coupling builds its rod models from.
//
// Contract (names of generated MuJoCo objects; the coupling and users rely on them):
//   body  "<rod>/base"       fixed frame at X = 0, with the element's pos and orientation
//                            attributes copied verbatim (MuJoCo resolves quat/euler/axisangle/
//                            xyaxes/zaxis with the model's <compiler angle/eulerseq>)
//   body  "<rod>/s<i>"       proxy of section i (0-based), a chain under "<rod>/base"; its frame
//                            is the end of section i (the coupling overwrites its pose)
//   joint "<rod>/s<i>/<c>"   slide joint per strain coordinate of section i, c = kx ky kz px py pz
//                            for PCS, or "<comp><k>" (e.g. kz0 kz1 kz2) for Legendre order k (GVS),
//                            in the core's dof order (Section::basis: component-major)
//   geom  "<rod>/s<i>/g<j>"  capsule j of section i (collision and visual), covering
//                            [X0 + j L_i / n, X0 + (j+1) L_i / n] with n capsules per section
//   site  "<rod>/base", "<rod>/tip" automatic; user <site name=... at=X pos=...> keep their name
//   <body> children of <cosserat> hang under the last proxy (at the tip frame).
// Collision exclusions (<contact><exclude>): every proxy against the rod's parent body (unless it is
// the world) and against named <body> children at the tip; and, unless selfcollide="true", the
// proxies of a rod pairwise and with its base.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "model.hpp"

namespace cosserat::mj {

// A rod section compressed to this fraction of its length or less (SceneData::compression) has
// collapsed: the linear constitutive law does not resist it, and the motion from there on is not
// physical. A rest shape must be longer (the loader refuses a rest stretch at or below it).
constexpr double kCollapsedStretch = 0.1;

// A load error that knows where it comes from: what() is "file:line: message" ("file: message"
// where the line is 0: an error of the whole model).
class LoadError : public std::runtime_error {
 public:
  LoadError(const std::string& file, int line, const std::string& msg);
  std::string file;
  int line;
  std::string message;
};

struct RodSiteDecl {
  std::string name;
  double X = 0.0;               // material abscissa
  Vec3 pos = Vec3::Zero();      // offset in the cross-section frame
};

struct RodGeomDecl {
  std::string name;             // "<rod>/s<i>/g<j>"
  int section = 0;
  double X_begin = 0.0, X_end = 0.0;
};

struct RodDecl {
  std::string name;
  std::string file;
  int line = 0;
  RodSpec spec;                       // core description (length, radii, sections, material)
  std::string parent_body;            // MuJoCo body the rod hangs from ("world" for worldbody)
  std::vector<RodSiteDecl> sites;     // user sites plus "<rod>/base" and "<rod>/tip"
  std::vector<RodGeomDecl> geoms;     // capsules, in section order
  std::vector<std::string> joints;    // slide joint names in core dof order (nv of the rod)
  std::vector<std::string> proxies;   // proxy body names, one per section
  // fluid (fluid.hpp): drag="c_t c_n [c_rot]" overrides the resistive-force coefficients
  // (drag="0": no fluid force on this rod); wavelength="lambda" the wave they are computed from
  std::vector<double> drag;
  double wavelength = 0.0;
  // strainrange, resolved per section (a <section>'s own, else the rod's; checked): lo, hi of each
  // of kx ky kz px py pz, deviations from the rest strain; 0 0 where not limited. Empty before
  // the sections are read.
  std::vector<std::array<double, 12>> strain_range;
};

// Where a line of the generated MJCF comes from in the user's files.
struct SourceLine {
  std::string file;
  int line = 0;
};

struct Preprocessed {
  std::string xml;                    // MJCF for mj_loadXML, <include>s expanded
  std::string path;                   // the original file (for relative asset paths)
  std::vector<RodDecl> rods;
  std::vector<SourceLine> line_origin;  // per line of `xml` (1-based): the element's origin
                                        // (generated elements: their <cosserat>'s)
  // MuJoCo's compiler names lines of `xml` ("line = N"): the user's file:line for line N.
  SourceLine origin_of_line(int line) const;
  // the <key> elements of <keyframe>, in order (MuJoCo's keyframe errors name the key's index,
  // "key N: ...", and no line)
  std::vector<SourceLine> key_origin;
  // the children of the <sensor> elements, in order (MuJoCo's sensor ids)
  std::vector<SourceLine> sensor_origin;
  // the children of the <actuator> elements, in order (MuJoCo's actuator ids), and whether each
  // has an activation state (muscle, cylinder, or a dyntype other than none)
  std::vector<SourceLine> actuator_origin;
  std::vector<char> actuator_stateful;
  // per actuator: it or a <default> of the model may give its lengthrange (else MuJoCo's compiler
  // computes a muscle's by simulating the compiled model)
  std::vector<char> actuator_lengthrange_given;
  // what loads but is likely a mistake ("file:line: <element>: ..."): a rod thicker than it is long,
  // moduli and densities outside those of real materials in SI units
  std::vector<std::string> warnings;
  // per sensor (MuJoCo's ids): its objname, "" without (MuJoCo's "unrecognized name of
  // sensorized object" names the sensor, not the object)
  std::vector<std::string> sensor_objname;
};

// Reads `path`, expands <include file=...> recursively (relative to the main model's directory, as
// MuJoCo 2.2.2 reads them, nested includes too), and rewrites every <cosserat>. Throws LoadError on bad input (file:line: what is wrong).
Preprocessed preprocess_file(const std::string& path);
// Same for MJCF text; `path` names it in messages and anchors relative includes.
Preprocessed preprocess_string(const std::string& xml, const std::string& path);

}  // namespace cosserat::mj
