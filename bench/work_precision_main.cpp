// Work-precision study: run time against error for our rods (PCS over sections, GVS over order,
// each integrator over its time step) and for the MuJoCo-native chain a user would build without
// us (native_chain.hpp: N capsule bodies, hinge or ball joints, MuJoCo's integrators), on
//   cantilever  a cantilever released from straight under gravity (large deflection), tip and
//               mid-point trajectories over a few periods; reference: our solver at a far finer
//               discretisation and step, shown converged against a second fine solution;
//   circle      a rod rolled into a full circle by a ramped tip moment 2 pi EI / L (damped, held
//               until at rest); reference: the analytic circle at four points along the rod;
//   flagellate  rigid and soft flagellate swimming speed (models/flagellate_rigid.xml and
//               models/flagellate.xml; skipped with a message when absent); reference: our finest;
//   octopus     the octopus arm (models/octopus_arm.xml, without table, object and floor) curling
//               under the cable tensions of its "curl" keyframe; reference: our finest.
//
// Every contender family is a grid (space knob x time step). For each space knob the step is
// refined from the coarsest until the error stops improving (the time error is then below the
// space error), and a family stops growing when one run costs more than --cap seconds. The
// Pareto-optimal points of each family (no other point of the family both faster and more
// accurate) and every run under 10 ms are re-run until --reps timings exist: their wall times are
// medians (a run under 10 ms is timed warm, made again from the reset state: kWarmBelow). Errors are
// relative (divided by the rod length, or by the reference speed). The summary compares the Pareto
// front of all our families with that of all native families at equal error (log-log
// interpolation between front points).
//
// Usage: work_precision [--quick] [--problem NAME]... [--out DIR] [--reps N] [--cap S]
//                       [--models DIR] [--family TEXT]... [--cold]
// --family keeps only the contender families whose name contains TEXT (e.g. "midpoint", "native
// hinge"): for trying one contender; the README figures come from runs of all of them.
// Writes DIR/work_precision_<problem>.json (plots: bench/plot.py).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.hpp"
#include "common.hpp"
#include "native_chain.hpp"

using namespace cosserat;
using namespace cosserat::bench;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The native chain's lengths on every problem: steps of 1.5-2 (a grid of doublings left gaps that
// the equal-error interpolation bridged between discretisations: bench/equal_error_rules.py), from
// as few dofs as our coarsest rods (N = 2: 6 hinges; one ikl section has 3 dofs). Our space knobs
// are as dense (each problem's families).
const std::vector<int> kNativeChains = {2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64};

struct Options {
  bool quick = false;
  bool cold = false;  // --cold
  std::vector<std::string> problems;
  std::string out = "docs/bench";
  std::string models = COSSERAT_SOURCE_DIR "/models";
  std::string refs = COSSERAT_SOURCE_DIR "/docs/bench";  // cached reference trajectories
  int reps = 3;
  double cap = -1;  // seconds per run (default: quick 1.5, full 10)
  bool reference_only = false;
  std::vector<std::string> families;  // --family: name filters (empty: all)
  bool planar = false;                // --planar
};

// ------------------------------------------------------------------------------------ settings --

// %g of a factor, for labels.
std::string fmt_g(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// A space knob as labels print it: "4", or "1/4" for runs of 4 identical sections merged into one.
std::string space_text(int space) { return space < 0 ? "1/" + std::to_string(-space) : std::to_string(space); }

// One run: ours (sections, order, method, h) or the native chain (segments, ball, method, h).
struct Setting {
  bool native = false;
  // sections (ours) or segments (native); for problems with Problem::refine the refinement
  // factor k of the model's sections, -m where runs of m identical sections are merged into one
  int space = 1;
  int order = 0;  // GVS order (ours)
  bool ball = false;
  double base_spring = 1.0;  // native: clamp spring as a multiple of EI/ds
  double armature = 0.0;     // native: hinge armature as a multiple of rho A ds^3 / 12
  int quadrature = 0;        // ours: mass points per section (0: the model's)
  bool lobatto = false;      // ours: the Gauss-Lobatto mass rule (quadrature="lobatto")
  Method method = Method::Implicit;
  double h = 1e-3;
  std::string label() const {
    char b[128];
    if (native)
      std::snprintf(b, sizeof b, "native %s%s%s N=%d %s h=%g", ball ? "ball" : "hinge",
                    base_spring != 1.0 ? (" clamp x" + std::to_string(base_spring).substr(0, 3)).c_str() : "",
                    armature > 0 ? (" armature x" + fmt_g(armature)).c_str() : "", space, method_name(method), h);
    else
      std::snprintf(b, sizeof b, "%s %s sec%s%s %s h=%g", order ? "GVS" : "PCS",
                    space_text(space).c_str(),
                    order ? (" order " + std::to_string(order)).c_str() : "",
                    lobatto ? " lobatto" : quadrature ? (" q" + std::to_string(quadrature)).c_str() : "",
                    method_name(method), h);
    return b;
  }
};

Setting ours(int sections, int order, Method m, double h) {
  Setting s;
  s.space = sections;
  s.order = order;
  s.method = m;
  s.h = h;
  return s;
}

// A family: one curve of the plot. Its grid is spaces x steps (GVS: orders x steps).
struct Family {
  std::string name;
  bool native = false;
  bool ball = false;
  Method method;
  std::vector<int> spaces;  // sections or segments (PCS, native), or orders (GVS)
  int gvs_sections = 0;     // GVS: sections, or Setting::space's refinement (the knob is the order); 0: PCS
  std::vector<double> steps;
  double base_spring = 1.0;  // native: clamp spring factor (NativeChainOptions)
  double armature = 0.0;     // native: hinge armature factor (NativeChainOptions)
  int quadrature = 0;        // ours: mass points per section (0: the model's)
  bool lobatto = false;      // ours: the Gauss-Lobatto mass rule (quadrature="lobatto")
};

struct Problem {
  std::string name, description;
  std::string xml, path;
  double T = 1.0, every = 0.01;
  double scale = 1.0;                 // length (or speed) that makes errors relative
  std::vector<std::string> sites;     // tracked sites
  std::string swimmer;                // body whose mean speed is the output (flagellate)
  Control control;
  // final positions of `sites` (analytic) if any; else the reference run
  std::vector<Vec3> analytic_final;
  bool trajectory = true;  // error over the whole trajectory (else: final state or speed)
  bool refine = false;     // the space knob multiplies every rod's sections (refine_sections)
  bool native_via_plugin = false;  // the native chain runs through our loader (the plugin's fluid)
  Setting reference, reference_check;
  std::vector<Family> families;
  std::string reference_note;
  bool warm = true;  // time short runs warm (kWarmBelow; --cold: false)
};

// XML of `p` for setting s (ours: sections/order edited into every rod; native: the generated chain).
std::string scene_xml(const Problem& p, const Setting& s) {
  if (s.native) {
    NativeChainOptions o;
    o.segments = s.space;
    o.ball = s.ball;
    o.base_spring_factor = s.base_spring;
    o.armature_factor = s.armature;
    return native_chain_xml(p.xml, p.path, o);
  }
  std::string xml = p.refine ? refine_sections(p.xml, s.space) : set_rod_attr(p.xml, "sections", std::to_string(s.space));
  if (s.quadrature) xml = set_rod_attr(xml, "quadrature", std::to_string(s.quadrature));
  if (s.lobatto) xml = set_rod_attr(xml, "quadrature", "lobatto");
  return s.order ? set_rod_attr(xml, "order", std::to_string(s.order)) : xml;
}

struct Outcome {
  Trajectory tr;  // tr.wall: the timed run's (warm where cold_wall is set)
  int nv = 0;
  double speed = NAN;
  std::string error_message;
  double cold_wall = NAN;  // the first run's wall after the model's load, where the timed run was warm
};

// Runs that take less than this from a freshly loaded model are timed warm: run once, the state
// reset, run again (the same trajectory, checked bit for bit) and the second run timed. Our first
// step after a load costs about 3 us more than the next (cold caches; 1-2 steady steps of a small
// rod, 0.5 us for a small native chain's mj_step: the forty-fourth session), which a run of 2-8
// steps does not amortise but no use of a loaded model repeats.
constexpr double kWarmBelow = 0.01;  // [s]

Outcome simulate(const Problem& p, const Setting& s) {
  Outcome o;
  try {
    const std::string xml = scene_xml(p, s);
    std::unique_ptr<Sim> sim = s.native && !p.native_via_plugin ? make_mujoco_sim(xml, p.path, s.method, s.h)
                                                                : make_rod_sim(xml, p.path, s.method, s.h);
    // controls of the first keyframe (qpos is not portable between discretisations)
    auto controls = [&sim] {
      if (sim->m()->nkey > 0)
        for (int i = 0; i < sim->m()->nu; ++i) sim->d()->ctrl[i] = sim->m()->key_ctrl[i];
    };
    controls();
    o.nv = sim->m()->nv;
    std::vector<int> sites, bodies;
    for (const auto& n : p.sites) {
      const int id = sim->site_id(n);
      if (id < 0) throw std::runtime_error("no site '" + n + "'");
      sites.push_back(id);
    }
    if (!p.swimmer.empty()) bodies.push_back(sim->body_id(p.swimmer));
    o.tr = run(*sim, p.T, s.h, p.every, sites, p.control, false, bodies);
    if (p.warm && !o.tr.diverged && o.tr.wall < kWarmBelow) {
      sim->reset();
      controls();
      Trajectory again = run(*sim, p.T, s.h, p.every, sites, p.control, false, bodies);
      if (again.diverged || again.t != o.tr.t || again.p != o.tr.p)
        throw std::runtime_error("the run again from the reset state differs from the first run");
      o.cold_wall = o.tr.wall;
      o.tr.wall = again.wall;
    }
    if (!p.swimmer.empty() && !o.tr.diverged) {
      // mean speed over the second half of the run
      const size_t n = o.tr.p.size(), k = n / 2;
      const Vec3 d = o.tr.p[n - 1].back() - o.tr.p[k].back();
      o.speed = d.norm() / (o.tr.t[n - 1] - o.tr.t[k]);
    }
  } catch (const std::exception& e) {
    o.error_message = e.what();
    o.tr.diverged = true;
  }
  return o;
}

// Relative error of an outcome against the reference (trajectory RMS, final state or speed).
double error_of(const Problem& p, const Outcome& o, const Outcome& ref) {
  if (o.tr.diverged) return kInf;
  if (!p.swimmer.empty()) return std::abs(o.speed - ref.speed) / std::abs(ref.speed);
  if (!p.analytic_final.empty()) {
    double e = 0.0;
    for (size_t i = 0; i < p.sites.size(); ++i) e = std::max(e, (o.tr.p.back()[i] - p.analytic_final[i]).norm());
    return e / p.scale;
  }
  // samples matched by time: the reference has one every p.every; a run with steps longer than
  // that has one per step (at multiples of p.every when the grid's steps are)
  double sum = 0.0;
  size_t n = 0;
  for (size_t k = 0; k < o.tr.p.size(); ++k) {
    const size_t j = static_cast<size_t>(std::lround(o.tr.t[k] / p.every));
    if (j >= ref.tr.p.size() || std::abs(ref.tr.t[j] - o.tr.t[k]) > 1e-6 * p.every)
      throw std::runtime_error("sample at t = " + std::to_string(o.tr.t[k]) + " s has no reference sample");
    for (size_t i = 0; i < p.sites.size(); ++i) sum += (o.tr.p[k][i] - ref.tr.p[j][i]).squaredNorm(), ++n;
  }
  return std::sqrt(sum / n) / p.scale;
}

// ------------------------------------------------------------------------------------ problems --

// Cantilever: L = 0.5 m, r = 5 mm, E = 100 MPa, rho = 1000 (w L^3 / EI = 1.96), inextensible
// Kirchhoff (ikl), undamped, released straight and horizontal under gravity: it swings down to
// about 0.7 L below the clamp and back, first period about 0.6 s.
Problem cantilever(const Options& o) {
  Problem p;
  p.name = "cantilever";
  p.description =
      "cantilever released from straight under gravity: L = 0.5 m, r = 5 mm, E = 1e8 Pa, rho = 1000 kg/m^3 "
      "(w L^3/EI = 1.96), inextensible Kirchhoff rod (ikl), undamped; RMS over time of the tip and mid-point "
      "position error, relative to L";
  p.path = "wp_cantilever.xml";
  p.xml = R"(<mujoco model="wp_cantilever">
  <option timestep="0.001" gravity="0 0 -9.81"/>
  <worldbody>
    <cosserat name="rod" pos="0 0 1" length="0.5" sections="4" strain="ikl" radius="0.005" density="1000"
              young="1e8" poisson="0.5" viscosity="0" contype="0" conaffinity="0">
      <site name="mid" at="0.25"/>
    </cosserat>
  </worldbody>
</mujoco>)";
  p.T = o.quick ? 0.3 : 2.0;
  p.every = 0.01;
  p.scale = 0.5;
  p.sites = {"rod/tip", "mid"};
  // both sides start at the same large steps (runs that diverge are recorded as such)
  const std::vector<double> ours_h = {1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5};
  const std::vector<double> native_h = {1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4,
                                        2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6};
  const std::vector<int> ours_space = {1, 2, 3, 4, 6, 8, 12, 16};
  if (o.quick) {
    p.families.push_back({"PCS / implicit", false, false, Method::Implicit, {2, 4}, 0, {1e-3, 5e-4}});
    p.families.push_back({"GVS 2 sec / rk4", false, false, Method::RK4, {1, 2}, 2, {1e-3, 5e-4}});
    p.families.push_back({"GVS 2 sec / trapezoidal-lin", false, false, Method::TrapezoidalLinear, {1}, 2, {5e-3, 2e-3}});
    p.families.push_back({"GVS 2 sec / rosenbrock", false, false, Method::Rosenbrock, {1}, 2, {2e-2, 1e-2}});
    p.families.push_back({"native hinge / euler", true, false, Method::Euler, {4, 8}, 0, {1e-3, 5e-4}});
    p.families.push_back({"native hinge clamp 2EI/ds / euler", true, false, Method::Euler, {4, 8}, 0, {1e-3, 5e-4}, 2.0});
    p.families.push_back({"native hinge clamp 2EI/ds armature x10 / euler", true, false, Method::Euler, {4, 8}, 0,
                          {1e-3, 5e-4}, 2.0, 10.0});
  } else {
    for (Method m : {Method::Implicit, Method::TrapezoidalLinear, Method::RK4, Method::Euler, Method::Rosenbrock}) {
      p.families.push_back({std::string("PCS / ") + method_name(m), false, false, m, ours_space, 0, ours_h});
      p.families.push_back({std::string("GVS 2 sec / ") + method_name(m), false, false, m, {1, 2, 3, 4}, 2, ours_h});
      // one section of linear or higher-order strain: the gravity-loaded cantilever's curvature is
      // close to linear in s (session 23: 2.1e-3 at 2.7 ms, 8.7e-4 at 10 ms with trapezoidal-lin)
      p.families.push_back({std::string("GVS 1 sec / ") + method_name(m), false, false, m, {1, 2, 3, 4}, 1, ours_h});
    }
    // PCS with the 3-point Gauss-Lobatto mass rule (quadrature="lobatto"): as exact as the
    // default 2 Gauss points, with two nodes and one exponential per section instead of three and two
    for (Method m : {Method::Implicit, Method::TrapezoidalLinear, Method::Rosenbrock}) {
      Family f{std::string("PCS lobatto / ") + method_name(m), false, false, m, ours_space, 0, ours_h};
      f.lobatto = true;
      p.families.push_back(f);
    }
    // the fully implicit second-order schemes (Newton iterations): GVS only, and the
    // energy-conserving midpoint rule (the problem is undamped) with PCS too
    for (Method m : {Method::Trapezoidal, Method::GeneralizedAlpha, Method::Midpoint})
      p.families.push_back({std::string("GVS 2 sec / ") + method_name(m), false, false, m, {1, 2, 3, 4}, 2, ours_h});
    p.families.push_back({"PCS / midpoint", false, false, Method::Midpoint, ours_space, 0, ours_h});
    for (Method m : {Method::Euler, Method::RK4, Method::Implicit})
      p.families.push_back({std::string("native hinge / ") + method_name(m), true, false, m, kNativeChains, 0, native_h});
    p.families.push_back({"native ball / euler", true, true, Method::Euler, kNativeChains, 0, native_h});
    p.families.push_back({"native hinge clamp 2EI/ds / euler", true, false, Method::Euler, kNativeChains, 0, native_h, 2.0});
    // with armature on the hinges (a MuJoCo user's way to a larger stable step; outside probe Q:
    // it cut the native chain's time at 1e-2 from 17 ms to about 2 ms): a sweep of its factor
    for (double a : {3.0, 10.0, 30.0})
      p.families.push_back({"native hinge clamp 2EI/ds armature x" + fmt_g(a) + " / euler", true, false, Method::Euler,
                            kNativeChains, 0, native_h, 2.0, a});
  }
  p.reference = ours(3, 5, Method::RK4, 5e-5);
  p.reference_check = ours(2, 4, Method::RK4, 1e-4);
  return p;
}

// Circle: L = 0.5 m, r = 5 mm, E = 1 GPa (EI = 0.491 N m^2), no gravity, a tip moment about y ramped
// smoothly from 0 to 2 pi EI / L over 1 s and held for 1.5 s; Kelvin-Voigt viscosity giving the
// first bending mode critical damping (the transient then decays as exp(-17 t) or faster).
Problem circle(const Options& o) {
  Problem p;
  p.name = "circle";
  const double L = 0.5, r = 0.005, E = 1e9, rho = 1000.0;
  const double I = kPi * r * r * r * r / 4, A = kPi * r * r, EI = E * I;
  const double w1 = 3.516 * std::sqrt(EI / (rho * A * L * L * L * L));
  const double mu = 2.0 * E * 1.0 / (3.0 * w1);  // bending damping ratio 1 for the first mode
  const double M = 2 * kPi * EI / L, Tr = 1.0;
  p.description = "rod rolled into a full circle by a tip moment ramped to 2 pi EI/L: L = 0.5 m, r = 5 mm, "
                  "E = 1e9 Pa, no gravity, Kelvin-Voigt damping (first mode critically damped), ramp 1 s, "
                  "hold 1.5 s; max error of four points along the rod (L/4, L/2, 3L/4, tip) against the "
                  "analytic circle, relative to L";
  p.path = "wp_circle.xml";
  char xml[2048];
  std::snprintf(xml, sizeof xml, R"(<mujoco model="wp_circle">
  <option timestep="0.001" gravity="0 0 0"/>
  <worldbody>
    <cosserat name="rod" pos="0 0 0" length="%g" sections="4" strain="ikl" radius="%g" density="%g"
              young="%g" poisson="0.5" viscosity="%.17g" contype="0" conaffinity="0">
      <site name="q1" at="%g"/>
      <site name="q2" at="%g"/>
      <site name="q3" at="%g"/>
      <body name="load"/>
    </cosserat>
  </worldbody>
</mujoco>)",
                L, r, rho, E, mu, L / 4, L / 2, 3 * L / 4);
  p.xml = xml;
  p.T = 2.5;
  p.every = 0.05;
  p.scale = L;
  p.trajectory = false;
  p.sites = {"q1", "q2", "q3", "rod/tip"};
  // analytic circle: curvature k = M/EI about y, centre below the base
  const double k = M / EI;
  for (double X : {L / 4, L / 2, 3 * L / 4, L}) p.analytic_final.push_back(Vec3(std::sin(k * X) / k, 0, -(1 - std::cos(k * X)) / k));
  p.control = [M, Tr](double t, const mjModel* m, mjData* d) {
    // the id is cached, and checked by name: a model of the next run may be allocated at the
    // address of the last one, with another numbering (the chains' N differ)
    static thread_local int body = -1;
    const char* name = body >= 0 && body < m->nbody ? mj_id2name(m, mjOBJ_BODY, body) : nullptr;
    if (!name || std::strcmp(name, "load") != 0) body = mj_name2id(m, mjOBJ_BODY, "load");
    const double s = t >= Tr ? 1.0 : 0.5 * (1 - std::cos(kPi * t / Tr));
    d->xfrc_applied[6 * body + 4] = s * M;  // torque about world y: bends the tip towards -z
  };
  // both sides start at the same large steps, up to a quarter of the ramp
  const std::vector<double> ours_h = {1.25, 5e-1, 2.5e-1, 1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4};
  const std::vector<double> native_h = {1.25, 5e-1, 2.5e-1, 1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4,
                                        2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6};
  if (o.quick) {
    p.families.push_back({"PCS / implicit", false, false, Method::Implicit, {1, 2}, 0, {1e-2, 5e-3}});
    p.families.push_back({"native hinge / euler", true, false, Method::Euler, {4, 8}, 0, {1e-3, 5e-4}});
  } else {
    for (Method m : {Method::Implicit, Method::TrapezoidalLinear, Method::RK4, Method::Rosenbrock})
      p.families.push_back({std::string("PCS / ") + method_name(m), false, false, m, {1, 2, 3, 4, 6, 8}, 0, ours_h});
    p.families.push_back({"GVS 1 sec / implicit", false, false, Method::Implicit, {1, 2}, 1, ours_h});
    for (Method m : {Method::Euler, Method::Implicit, Method::RK4})
      p.families.push_back({std::string("native hinge / ") + method_name(m), true, false, m, kNativeChains, 0, native_h});
    p.families.push_back({"native hinge clamp 2EI/ds / euler", true, false, Method::Euler, kNativeChains, 0, native_h, 2.0});
    p.families.push_back({"native hinge clamp 2EI/ds armature x10 / euler", true, false, Method::Euler, kNativeChains, 0,
                          native_h, 2.0, 10.0});
  }
  return p;
}

// Flagellates: the shipped models as they are (their controls: keyframe "swim", 1 Hz), the space
// knob refining every section of every rod k times. The native chain (flagellum as N capsule
// bodies) runs through our loader so that it feels the same fluid (resistive force theory on its
// capsules, scene_fluid.hpp); for the rigid flagellate it is N welded capsules.
std::vector<Problem> flagellates(const Options& o) {
  std::vector<Problem> out;
  for (const char* f : {"flagellate_rigid", "flagellate"}) {
    const std::string path = o.models + "/" + f + ".xml";
    if (!file_exists(path)) {
      std::printf("[%s] skipped: %s does not exist yet\n", f, path.c_str());
      continue;
    }
    Problem p;
    p.name = f;
    p.path = path;
    p.xml = read_file(path);
    p.trajectory = false;
    p.refine = true;
    p.native_via_plugin = true;
    p.every = 0.01;
    p.T = o.quick ? 1.0 : 4.0;
    p.description = std::string("mean swimming speed of the head of ") + f + ".xml (keyframe swim: 1 Hz) over the "
                    "second half of " + std::to_string(p.T).substr(0, 3) + " s, relative to the reference speed; "
                    "space knob: every section refined k times (k = 1/m: runs of m identical sections merged into one)";
    std::unique_ptr<mj::Scene> s;
    try {
      s = mj::load_scene(path);
    } catch (const std::exception& e) {
      std::printf("[%s] skipped: %s\n", f, e.what());
      continue;
    }
    for (int j = 0; j < s->m->njnt; ++j)
      if (s->m->jnt_type[j] == mjJNT_FREE) {
        p.swimmer = mj_id2name(s->m, mjOBJ_BODY, s->m->jnt_bodyid[j]);
        break;
      }
    if (p.swimmer.empty() || s->rods.empty()) {
      std::printf("[%s] skipped: no free-swimming body or no rod\n", f);
      continue;
    }
    const double h0 = s->m->opt.timestep;
    p.sites = {s->rods[0].decl.name + "/tip"};
    // both sides start at 8 steps per run (512 times the model's 1 ms): at 64 ms, the grid's start
    // until the fourteenth session, our error was 6.7e-5 (rigid) and 4.6e-3 (soft), so the grid did
    // not reach the coarse end of our accuracy
    std::vector<double> hs;
    for (double k : {512.0, 256.0, 128.0, 64.0, 32.0, 16.0, 8.0, 4.0, 2.0, 1.0, 0.5, 0.25}) hs.push_back(h0 * k);
    // our space knob: the model's sections merged m to one where its runs of identical sections
    // allow (the helix's pieces share one rest strain: fewer, longer pieces are the same helix at
    // rest; coarsest first), then refined k times
    std::vector<int> spaces;
    for (int m = 32; m >= 2; --m) try {
        refine_sections(p.xml, -m);
        spaces.push_back(-m);
      } catch (const std::invalid_argument&) {
      }
    for (int k : {1, 2, 3, 4}) spaces.push_back(k);
    if (o.quick) {
      // (the coarsest merge too, so that CI's quick run builds one)
      p.families.push_back({"PCS / implicit", false, false, Method::Implicit,
                            spaces.front() < 0 ? std::vector<int>{spaces.front(), 1} : std::vector<int>{1}, 0,
                            {h0 * 2, h0}});
      p.families.push_back({"native / euler", true, false, Method::Euler, {16}, 0, {h0 * 2, h0}});
    } else {
      p.families.push_back({"PCS / implicit", false, false, Method::Implicit, spaces, 0, hs});
      p.families.push_back({"PCS / rk4", false, false, Method::RK4, spaces, 0, hs});
      p.families.push_back({"PCS / rosenbrock", false, false, Method::Rosenbrock, spaces, 0, hs});
      // GVS: the model's sections (or the helix merged) with strains of order 1-3 along each
      if (std::string(f) == "flagellate")
        for (int k : spaces)
          if (k <= 1)
            p.families.push_back({"GVS " + space_text(k) + " sec / implicit", false, false, Method::Implicit, {1, 2, 3}, k, hs});
      p.families.push_back({"native / euler", true, false, Method::Euler, kNativeChains, 0, hs});
      p.families.push_back({"native / rk4", true, false, Method::RK4, kNativeChains, 0, hs});
      // the native chain with our implicit step too (motor servo and fluid damping implicit), so
      // that the step-size limit of the explicit methods is not what the comparison measures
      p.families.push_back({"native / implicit", true, false, Method::Implicit, kNativeChains, 0, hs});
      // the soft flagellum's chain with armature on its hinges (the rigid propeller has none)
      if (std::string(f) == "flagellate")
        p.families.push_back({"native armature x10 / implicit", true, false, Method::Implicit, kNativeChains, 0, hs, 1.0, 10.0});
    }
    if (std::string(f) == "flagellate") {
      // the soft flagellum is stiff (axial modes) and light in a viscous fluid: explicit steps
      // (RK4, or Euler's explicit elasticity) need h < 1e-4; the implicit integrator is the one
      // that runs at the model's step, and the reference is a fine implicit run
      p.families.erase(std::remove_if(p.families.begin(), p.families.end(),
                                      [](const Family& fm) { return fm.method == Method::RK4; }),
                       p.families.end());
      // the native chain's Euler keeps its joint springs explicit: it starts at small steps. Its
      // `implicit` families (joint springs, damping, fluid drag and servo implicit: the scene's
      // implicit step) start where ours do (until the thirtieth session they started at h0 / 2
      // too, a limit of the explicit springs they no longer have: outside probe AJ)
      for (Family& fm : p.families)
        if (fm.native && fm.method == Method::Euler) fm.steps = {h0 / 2, h0 / 4, h0 / 8, h0 / 16};
      p.reference = ours(2, 0, Method::Implicit, h0 / 16);
      p.reference_check = ours(1, 0, Method::Implicit, h0 / 8);
    } else {
      p.reference = ours(4, 0, Method::RK4, h0 / 4);
      p.reference_check = ours(2, 0, Method::RK4, h0 / 2);
    }
    out.push_back(p);
  }
  return out;
}

// Octopus arm: models/octopus_arm.xml without table, object and floor, the mount raised to 0.5 m,
// controls of its "curl" keyframe (0, 0.4, 0.4) N from t = 0.
Problem octopus(const Options& o) {
  Problem p;
  p.name = "octopus";
  p.path = o.models + "/octopus_arm.xml";
  p.description = "octopus arm (models/octopus_arm.xml: tapered kl rod, 0.35 m, E = 1.5e5 Pa, viscosity 2 Pa s, "
                  "three cables through 8 sites) curling under the tensions of its 'curl' keyframe (0, 0.4, 0.4) N "
                  "ramped in over 0.5 s, in free space (table, object and floor removed, mount at 0.5 m), first 0.2 s; RMS over time of the tip and "
                  "dorsal4 (X = 0.2 m) position error, relative to L";
  std::string xml = read_file(p.path);
  for (const char* g : {"floor", "table"}) xml = remove_named(xml, "geom", g);
  xml = remove_named(xml, "body", "object");
  xml = set_named_attr(xml, "body", "mount", "pos", "0 0 0.5");
  p.xml = xml;
  // 0.2 s: the arm swings down and starts to curl (its tip travels 0.15 m). It is nearly undamped
  // and its trajectory soon becomes too sensitive for any reference: discretisations that agree to
  // about 1e-3 L at 0.2 s differ by 6e-3 L (RMS) over 0.3 s and by centimetres at 1 s.
  p.T = 0.2;
  p.every = 0.01;
  p.scale = 0.35;
  p.sites = {"arm/tip", "dorsal4"};
  // the tensions of the "curl" keyframe, ramped in smoothly over the first 0.5 s (a step in tension
  // would excite modes no discretisation resolves)
  p.control = [](double t, const mjModel* m, mjData* d) {
    const double Tr = 0.5, s = t >= Tr ? 1.0 : 0.5 * (1 - std::cos(kPi * t / Tr));
    for (int i = 0; i < m->nu; ++i) d->ctrl[i] = s * m->key_ctrl[i];
  };
  // both sides start at 4 steps per run (the fastest runs of either side stayed below 1e-1 at 10 ms)
  const std::vector<double> ours_h = {5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5};
  const std::vector<double> native_h = {5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6};
  if (o.quick) {
    p.families.push_back({"PCS / implicit", false, false, Method::Implicit, {2, 4}, 0, {1e-3, 5e-4}});
    p.families.push_back({"native hinge / euler", true, false, Method::Euler, {8}, 0, {1e-3, 5e-4}});
  } else {
    for (Method m : {Method::Implicit, Method::TrapezoidalLinear, Method::RK4, Method::Rosenbrock})
      p.families.push_back({std::string("PCS / ") + method_name(m), false, false, m, {1, 2, 3, 4, 6, 8, 12, 16, 24, 32}, 0, ours_h});
    for (Method m : {Method::Implicit, Method::TrapezoidalLinear, Method::RK4, Method::Rosenbrock})
      p.families.push_back({std::string("GVS 2 sec / ") + method_name(m), false, false, m, {1, 2, 3, 4}, 2, ours_h});
    for (Method m : {Method::Euler, Method::Implicit, Method::RK4})
      p.families.push_back({std::string("native hinge / ") + method_name(m), true, false, m, kNativeChains, 0, native_h});
    p.families.push_back({"native hinge clamp 2EI/ds / euler", true, false, Method::Euler, kNativeChains, 0, native_h, 2.0});
    for (double a : {3.0, 10.0})
      p.families.push_back({"native hinge clamp 2EI/ds armature x" + fmt_g(a) + " / euler", true, false, Method::Euler,
                            kNativeChains, 0, native_h, 2.0, a});
  }
  p.reference = ours(4, 3, Method::RK4, 5e-5);
  p.reference_check = ours(32, 0, Method::RK4, 1e-4);
  return p;
}

// ------------------------------------------------------------------------------------- driver --

// Identifies a reference run: the problem text, sampling, sites and the reference settings
// (FNV-1a, stable across runs).
// --planar: the cantilever and the circle bend about y only, so one bending strain per section
// (dofs="0 1 0 0 0 0") and one hinge per link of the native chain (the generator follows the rod's
// dofs) give the same motion; the native chain's cost falls far more than ours (outside probe BH).
// Its own problem name, JSON and cached reference (work_precision_NAME_planar.json).
Problem planar_if(const Options& o, Problem p) {
  if (!o.planar) return p;
  const std::string from = "strain=\"ikl\"";
  const size_t at = p.xml.find(from);
  if (at == std::string::npos) throw std::logic_error("--planar: no strain=\"ikl\" in " + p.name);
  p.xml.replace(at, from.size(), "dofs=\"0 1 0 0 0 0\"");
  p.name += "_planar";
  p.path.insert(p.path.size() - 4, "_planar");
  p.description += "; planar: one bending strain (ky) per section, one hinge per native link";
  return p;
}

std::string reference_key(const Problem& p) {
  std::string t = p.xml + "|" + std::to_string(p.every) + "|" + p.reference.label() + "|" + p.reference_check.label();
  for (const auto& n : p.sites) t += "|" + n;
  if (!p.swimmer.empty()) t += "|" + p.swimmer + "|" + std::to_string(p.T);
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : t) h = (h ^ c) * 1099511628211ull;
  char b[32];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(h));
  return b;
}

json setting_json(const Setting& s) {
  json j;
  j["label"] = s.label();
  j["native"] = s.native;
  j[s.native ? "segments" : "sections"] = s.space;
  if (!s.native) j["order"] = s.order;
  if (s.quadrature) j["quadrature"] = s.quadrature;
  if (s.lobatto) j["quadrature"] = "lobatto";
  if (s.native) j["joint"] = s.ball ? "ball" : "hinge";
  j["method"] = method_name(s.method);
  j["h"] = s.h;
  return j;
}

struct Point {
  Setting s;
  int nv = 0;
  double error = kInf;
  // the largest of its own error and those of the same discretisation at smaller steps (a coarse
  // step that beats its finer ones got lucky: errors cancelling at the samples); fronts and the
  // equal-error summary use it (credit_errors)
  double credited = kInf;
  std::vector<double> walls;
  std::vector<double> cold_walls;  // the runs' first runs after their loads, where walls are warm
  bool interleaved = false;  // walls from retime_fronts_interleaved
  bool diverged = false;
  std::string message;
  double wall() const { return median(walls); }
  // one more timing of the point's run (and its cold first run where it was timed warm)
  void add_timing(const Outcome& oc) {
    walls.push_back(oc.tr.wall);
    if (!std::isnan(oc.cold_wall)) cold_walls.push_back(oc.cold_wall);
  }
};

// Point::credited for the points of one family (same discretisation: same space knob and order).
void credit_errors(std::vector<Point>& pts) {
  for (Point& p : pts) {
    p.credited = p.error;
    if (!std::isfinite(p.error)) continue;
    for (const Point& q : pts)
      if (std::isfinite(q.error) && q.s.h < p.s.h && q.s.space == p.s.space && q.s.order == p.s.order)
        p.credited = std::max(p.credited, q.error);
  }
}

// Points of `pts` on the lower-left envelope (credited error against wall time).
std::vector<int> pareto(const std::vector<Point>& pts) {
  std::vector<int> idx;
  for (size_t i = 0; i < pts.size(); ++i) {
    if (!std::isfinite(pts[i].credited)) continue;
    bool dominated = false;
    for (size_t j = 0; j < pts.size() && !dominated; ++j)
      dominated = j != i && std::isfinite(pts[j].credited) && pts[j].wall() <= pts[i].wall() &&
                  pts[j].credited <= pts[i].credited &&
                  (pts[j].wall() < pts[i].wall() || pts[j].credited < pts[i].credited);
    if (!dominated) idx.push_back(static_cast<int>(i));
  }
  std::sort(idx.begin(), idx.end(), [&](int a, int b) { return pts[a].wall() < pts[b].wall(); });
  return idx;
}

// Least wall time to reach relative error e on the Pareto front (credited errors) of `pts` (all families of one
// side together), interpolating log(time) against log(error) between front points; inf when the
// front never gets that low, the fastest time when e is above all of it.
double time_to_error(const std::vector<const Point*>& pts, double e) {
  std::vector<std::pair<double, double>> all, fr;  // (wall, error)
  for (const Point* p : pts)
    if (std::isfinite(p->credited) && p->credited > 0) all.emplace_back(p->wall(), p->credited);
  std::sort(all.begin(), all.end());
  for (const auto& q : all)
    if (fr.empty() || q.second < fr.back().second) fr.push_back(q);
  if (fr.empty() || e < fr.back().second) return kInf;
  if (e >= fr.front().second) return fr.front().first;
  for (size_t k = 0; k + 1 < fr.size(); ++k) {
    const auto [t0, e0] = fr[k];
    const auto [t1, e1] = fr[k + 1];
    if (e <= e0 && e >= e1) {
      const double a = (std::log(e) - std::log(e0)) / (std::log(e1) - std::log(e0));
      return std::exp(std::log(t0) + a * (std::log(t1) - std::log(t0)));
    }
  }
  return kInf;
}

// The fronts' points timed again in interleaved rounds (each round runs every such point once,
// ours and the native chain's alternately), their medians replacing the timings taken when each
// family ran: the families run minutes apart, and this machine's speed drifts by up to 2x over
// minutes (the forty-second session: the same soft-flagellate run, 125 steps, timed 6.6 ms one
// day and 13 ms the next inside a full run, 8.1-9.0 ms with either day's build outside it), which
// moved the equal-error ratios with it. Points of either side's front (all its families together) under
// kMaxWall are re-timed; where that moves another point onto a front, it is re-timed in turn.
void retime_fronts_interleaved(const Problem& p, const Options& o, std::vector<std::vector<Point>>& all) {
  constexpr double kMaxWall = 2.0;  // [s]: at most reps x 2 s per point
  for (int pass = 0; pass < 3; ++pass) {
    std::vector<Point*> todo[2];  // ours, the native chain's
    for (int side = 0; side < 2; ++side) {
      std::vector<Point*> mine;
      std::vector<Point> copy;
      for (size_t f = 0; f < all.size(); ++f)
        if (p.families[f].native == (side == 1))
          for (Point& pt : all[f])
            if (!pt.diverged) mine.push_back(&pt), copy.push_back(pt);
      for (int i : pareto(copy))
        if (!mine[i]->interleaved && mine[i]->wall() < kMaxWall) todo[side].push_back(mine[i]);
    }
    std::vector<Point*> order;
    for (size_t k = 0; k < std::max(todo[0].size(), todo[1].size()); ++k)
      for (const auto& side : todo)
        if (k < side.size()) order.push_back(side[k]);
    if (order.empty()) return;
    std::printf("-- the fronts' %zu points under %.0f s timed again in %d interleaved rounds\n", order.size(), kMaxWall,
                o.reps);
    std::vector<Point> timed(order.size());  // (their timings of these rounds only)
    for (int r = 0; r < o.reps; ++r)
      for (size_t k = 0; k < order.size(); ++k) timed[k].add_timing(simulate(p, order[k]->s));
    for (size_t k = 0; k < order.size(); ++k) {
      std::printf("   %-44s wall %10.3e s (was %10.3e s)\n", order[k]->s.label().c_str(), timed[k].wall(),
                  order[k]->wall());
      order[k]->walls = timed[k].walls;
      order[k]->cold_walls = timed[k].cold_walls;
      order[k]->interleaved = true;
    }
    std::fflush(stdout);
  }
}

json run_problem(const Problem& p, const Options& o) {
  const double cap = o.cap > 0 ? o.cap : (o.quick ? 1.5 : 10.0);
  std::printf("\n=== %s: %s\n", p.name.c_str(), p.description.c_str());
  json out;
  out["problem"] = p.name;
  out["description"] = p.description;
  out["duration_s"] = p.T;
  out["sample_interval_s"] = p.every;
  out["quick"] = o.quick;
  out["warm_below_s"] = p.warm ? kWarmBelow : 0.0;  // runs under it timed warm (Outcome::cold_wall)
  out["machine"] = machine_info();

  // reference: cached in --refs when computed with the same problem and setting for at least T
  Outcome ref;
  if (p.analytic_final.empty()) {
    const std::string key = reference_key(p);
    const std::string cache = o.refs + "/reference_" + p.name +
                              (p.swimmer.empty() ? "" : "_T" + std::to_string(static_cast<int>(p.T))) + ".json";
    json cached;
    if (file_exists(cache)) {
      cached = json::parse(read_file(cache));
      const bool usable = cached.value("key", "") == key && cached.value("duration_s", 0.0) >= p.T - 1e-9 &&
                          (p.swimmer.empty() || std::abs(cached.value("duration_s", 0.0) - p.T) < 1e-9);
      if (!usable) cached = json();
    }
    if (!cached.is_null()) {
      std::printf("reference: %s (cached in %s, %.1f s of simulated time)\n", p.reference.label().c_str(),
                  cache.c_str(), cached["duration_s"].get<double>());
      const size_t n = cached["t"].size();
      for (size_t k = 0; k < n; ++k) {
        if (cached["t"][k].get<double>() > p.T + 1e-9) break;
        ref.tr.t.push_back(cached["t"][k]);
        std::vector<Vec3> pk;
        for (const auto& v : cached["p"][k]) pk.push_back(Vec3(v[0], v[1], v[2]));
        ref.tr.p.push_back(pk);
      }
      if (cached.contains("speed")) ref.speed = cached["speed"];
      ref.tr.wall = cached["wall_s"];
    } else {
      std::printf("reference: %s ...\n", p.reference.label().c_str());
      std::fflush(stdout);
      ref = simulate(p, p.reference);
      if (ref.tr.diverged) {
        std::printf("reference run failed: %s\n", ref.error_message.c_str());
        out["error"] = "reference run failed: " + ref.error_message;
        return out;
      }
      const Outcome chk = simulate(p, p.reference_check);
      cached["key"] = key;
      cached["problem"] = p.name;
      cached["duration_s"] = p.T;
      cached["setting"] = setting_json(p.reference);
      cached["wall_s"] = ref.tr.wall;
      cached["check_setting"] = setting_json(p.reference_check);
      cached["check_difference"] = error_of(p, chk, ref);
      cached["sites"] = p.sites;
      cached["t"] = ref.tr.t;
      json pp = json::array();
      for (const auto& pk : ref.tr.p) {
        json row = json::array();
        for (const Vec3& v : pk) row.push_back({v.x(), v.y(), v.z()});
        pp.push_back(row);
      }
      cached["p"] = pp;
      if (!p.swimmer.empty()) cached["speed"] = ref.speed;
      write_json(cache, cached);
    }
    const double e = cached["check_difference"];
    std::printf("reference %s: %.2f s wall; the second fine solution %s differs by %.3e (relative)\n",
                p.reference.label().c_str(), ref.tr.wall, p.reference_check.label().c_str(), e);
    out["reference"] = {{"kind", "own solver, fine"},
                        {"setting", setting_json(p.reference)},
                        {"wall_s", ref.tr.wall},
                        {"computed_for_duration_s", cached["duration_s"]},
                        {"check_setting", setting_json(p.reference_check)},
                        {"check_difference", e},
                        {"note", "errors below about check_difference are not resolved by the reference"}};
    if (!p.swimmer.empty()) out["reference"]["speed"] = ref.speed;
  } else {
    json pts = json::array();
    for (const Vec3& v : p.analytic_final) pts.push_back({v.x(), v.y(), v.z()});
    out["reference"] = {{"kind", "analytic"}, {"final_positions", pts}};
  }

  if (o.reference_only) return out;
  std::vector<std::vector<Point>> all;
  for (const Family& f : p.families) {
    std::printf("-- %s\n", f.name.c_str());
    std::vector<Point> pts;
    bool too_slow = false;
    for (int knob : f.spaces) {
      if (too_slow) break;
      double prev = kInf;
      bool any_ok = false;
      int n_ok = 0;    // runs that completed
      int growths = 0;  // consecutive refinements whose error grew
      for (double h : f.steps) {
        Setting s;
        s.native = f.native;
        s.ball = f.ball;
        s.base_spring = f.base_spring;
        s.armature = f.armature;
        s.quadrature = f.quadrature;
        s.lobatto = f.lobatto;
        s.method = f.method;
        s.h = h;
        if (f.gvs_sections != 0)
          s.space = f.gvs_sections, s.order = knob;
        else
          s.space = knob;
        // cost guard: skip runs predicted to take more than twice the cap, from the last run that
        // completed (cost ~ steps x size, size^2 for ours: the rod's mass matrix is dense)
        {
          const Point* last = nullptr;
          for (const Point& q : pts)
            if (!q.diverged) last = &q;
          if (last) {
            const auto size = [&](const Setting& x) {
              return (x.space < 0 ? 1.0 / -x.space : static_cast<double>(x.space)) * (x.order + 1);
            };
            const double predicted =
                last->wall() * (last->s.h / h) * std::pow(size(s) / size(last->s), f.native ? 1.0 : 2.0);
            if (predicted > 2 * cap) {
              std::printf("   %-44s skipped: predicted %.0f s > 2 x cap\n", s.label().c_str(), predicted);
              if (h == f.steps.front()) too_slow = true;
              break;
            }
          }
        }
        Point pt;
        pt.s = s;
        const Outcome oc = simulate(p, s);
        pt.diverged = oc.tr.diverged;
        pt.message = oc.error_message;
        pt.add_timing(oc);
        pt.error = error_of(p, oc, ref);
        pt.nv = oc.nv;
        std::printf("   %-44s nv %4d  error %10.3e  wall %9.4f s%s%s\n", s.label().c_str(), pt.nv, pt.error,
                    oc.tr.wall, pt.diverged ? "  DIVERGED" : "",
                    pt.message.empty() ? "" : ("  (" + pt.message + ")").c_str());
        std::fflush(stdout);
        pts.push_back(pt);
        if (!pt.message.empty()) {
          too_slow = true;  // a setting that cannot even be built: stop the family
          break;
        }
        if (pt.diverged) continue;
        any_ok = true;
        if (oc.tr.wall > cap) {
          too_slow = true;
          break;
        }
        // The walk stops only on runs that track the solution (error below kTracking): above it a
        // run beyond its stable step moves erratically without diverging (outside probe Q: the
        // circle's clamp chain N = 8 read 0.30, 0.48, 0.56 at 1.25, 0.5, 0.25 s and stopped, where
        // 0.1 s gives 8.3e-3).
        constexpr double kTracking = 0.25;
        const bool tracking = pt.error < kTracking && std::isfinite(prev) && prev < kTracking;
        // converged in time: the step no longer matters at this resolution
        if (tracking && std::abs(pt.error - prev) < 0.05 * prev) break;
        // the error grows as the step shrinks, twice in a row: the space error is reached (time
        // errors of a coarse step can cancel the space error by chance, once: the rigid
        // flagellate's implicit runs read 6.7e-5, 3.8e-4, 1.5e-4, 7.5e-5 at 64, 32, 16, 8 ms; and
        // not before the third completed run)
        growths = tracking && pt.error > prev * 1.05 && pt.error > 1e-12 ? growths + 1 : 0;
        if (++n_ok >= 3 && growths >= 2) break;
        prev = pt.error;
      }
      if (!any_ok && !f.native) continue;
    }
    // medians for every cheap run and for the Pareto points: a single timing of a run of tens of
    // microseconds is at the mercy of cold caches and the scheduler, and decided whether the run
    // was on the front at all (the rigid flagellate's 1-section run at 512 ms read 42 us in the
    // fourteenth session and 129 us once in the eighteenth, against 68 us for the median of 2 sections)
    credit_errors(pts);
    auto repeat = [&](Point& pt) {
      while (static_cast<int>(pt.walls.size()) < o.reps && pt.wall() < cap) {  // runs over the cap: once
        pt.add_timing(simulate(p, pt.s));
      }
    };
    constexpr double kCheap = 0.01;  // [s]: at most reps x 10 ms more per run
    for (Point& pt : pts)
      if (!pt.diverged && pt.wall() < kCheap) repeat(pt);
    for (int i : pareto(pts)) repeat(pts[i]);
    all.push_back(pts);
  }
  retime_fronts_interleaved(p, o, all);

  json fams = json::array();
  for (size_t fi = 0; fi < p.families.size(); ++fi) {
    const Family& f = p.families[fi];
    const std::vector<Point>& pts = all[fi];
    const std::vector<int> front = pareto(pts);
    json jf;
    jf["name"] = f.name;
    jf["native"] = f.native;
    jf["method"] = method_name(f.method);
    json jp = json::array();
    for (size_t i = 0; i < pts.size(); ++i) {
      const Point& pt = pts[i];
      json j = setting_json(pt.s);
      j["nv"] = pt.nv;
      j["error"] = std::isfinite(pt.error) ? json(pt.error) : json(nullptr);
      j["credited_error"] = std::isfinite(pt.credited) ? json(pt.credited) : json(nullptr);
      j["wall_s"] = pt.wall();
      j["wall_runs_s"] = pt.walls;
      if (!pt.cold_walls.empty()) j["wall_cold_runs_s"] = pt.cold_walls;
      if (pt.interleaved) j["interleaved"] = true;
      j["diverged"] = pt.diverged;
      if (!pt.message.empty()) j["message"] = pt.message;
      j["pareto"] = std::find(front.begin(), front.end(), static_cast<int>(i)) != front.end();
      jp.push_back(j);
    }
    jf["points"] = jp;
    fams.push_back(jf);
  }
  out["families"] = fams;

  // summary: ours against the native chain at equal error
  std::vector<const Point*> ours, native;
  for (size_t f = 0; f < p.families.size(); ++f)
    for (const Point& pt : all[f]) (p.families[f].native ? native : ours).push_back(&pt);
  double best_native = kInf, best_ours = kInf;
  for (const Point* q : native) best_native = std::min(best_native, q->error);
  for (const Point* q : ours) best_ours = std::min(best_ours, q->error);
  json summary;
  summary["best_error_ours"] = std::isfinite(best_ours) ? json(best_ours) : json(nullptr);
  summary["best_error_native"] = std::isfinite(best_native) ? json(best_native) : json(nullptr);
  json ratios = json::array();
  std::printf("\nsummary %s: least error ours %.3e, native %.3e (within the cap of %.1f s per run)\n", p.name.c_str(),
              best_ours, best_native, cap);
  std::printf("   %10s  %12s  %12s  %8s\n", "error <=", "ours [s]", "native [s]", "ratio");
  // errors below the reference's own resolution are left out (bench/report.py's rule)
  const double resolution = out["reference"].value("check_difference", 0.0);
  for (double e : {1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6}) {
    if (e < resolution) continue;
    const double to = time_to_error(ours, e), tn = time_to_error(native, e);
    if (!std::isfinite(to) && !std::isfinite(tn)) continue;
    json r;
    r["error"] = e;
    r["ours_s"] = std::isfinite(to) ? json(to) : json(nullptr);
    r["native_s"] = std::isfinite(tn) ? json(tn) : json(nullptr);
    r["speedup"] = std::isfinite(to) && std::isfinite(tn) ? json(tn / to) : json(nullptr);
    ratios.push_back(r);
    std::printf("   %10.0e  %12.5f  %12.5f  %8s\n", e, to, tn,
                std::isfinite(to) && std::isfinite(tn) ? std::to_string(tn / to).substr(0, 7).c_str() : "-");
  }
  summary["at_equal_error"] = ratios;
  out["summary"] = summary;
  return out;
}

}  // namespace

int run_work_precision(int argc, char** argv) {
  Options o;
  const std::vector<std::string> problems = {"cantilever", "circle", "flagellate", "octopus"};
  cli::CommandLine cl{
      "bench_work_precision",
      "run time against error, ours and the MuJoCo-native chains (bench/README.md); writes "
      "DIR/work_precision_<problem>.json",
      {},
      {cli::flag_option("--quick", "small grids (the CI smoke run)", o.quick),
       {"--problem", "NAME", "cantilever, circle, flagellate or octopus (repeatable; default: all)",
        [&](const std::string& v) {
          if (std::find(problems.begin(), problems.end(), v) == problems.end())
            cli::fail("--problem: unknown problem '" + v +
                      "' (cantilever, circle, flagellate, octopus)");
          o.problems.push_back(v);
        }},
       cli::text_option("--out", "DIR", "output directory (default docs/bench)", o.out),
       cli::int_option("--reps", "N", "timings per front point, their median is reported (default 3)", o.reps, 1),
       {"--cap", "S", "a family stops growing when one run takes longer than S seconds (default: quick 1.5, full 10)",
        [&](const std::string& v) { o.cap = cli::parse_positive("--cap", v); }},
       cli::text_option("--models", "DIR", "where the shipped models are (default models/)", o.models),
       cli::text_option("--refs", "DIR", "where the reference trajectories are cached (default docs/bench)", o.refs),
       cli::flag_option("--reference-only", "compute (or load) the references and stop", o.reference_only),
       cli::flag_option("--cold",
                        "time every run from a freshly loaded model (default: runs under 10 ms are timed warm, "
                        "run again from the reset state)",
                        o.cold),
       cli::flag_option("--planar",
                        "the cantilever and the circle with one bending dof per section and one hinge per native "
                        "link (their motion is planar: the same errors, both sides cheaper); writes "
                        "work_precision_<problem>_planar.json",
                        o.planar),
       {"--family", "TEXT",
        "only the contender families whose name contains TEXT (repeatable), e.g. midpoint or 'native hinge'",
        [&](const std::string& v) {
          if (v.empty()) cli::fail("--family: empty text");
          o.families.push_back(v);
        }}}};
  cl.program.clear();
  if (!cl.parse(argc - 1, argv + 1)) return 0;
  if (o.problems.empty()) o.problems = problems;
  mju_user_warning = [](const char*) {};  // divergence is detected and reported per run
  if (o.planar && std::any_of(o.problems.begin(), o.problems.end(),
                              [](const std::string& n) { return n != "cantilever" && n != "circle"; }))
    cli::fail("--planar applies to the cantilever and the circle only: give --problem cantilever and/or --problem circle");
  for (const std::string& name : o.problems) {
    std::vector<Problem> ps;
    if (name == "cantilever") ps.push_back(planar_if(o, cantilever(o)));
    else if (name == "circle") ps.push_back(planar_if(o, circle(o)));
    else if (name == "flagellate") ps = flagellates(o);
    else if (name == "octopus") ps.push_back(octopus(o));
    else cli::fail("unknown problem '" + name + "'");
    for (Problem& p : ps) {
      p.warm = !o.cold;
      if (!o.families.empty()) {  // --family: only the families whose name contains one of the texts
        auto unwanted = [&o](const Family& f) {
          return std::none_of(o.families.begin(), o.families.end(),
                              [&f](const std::string& t) { return f.name.find(t) != std::string::npos; });
        };
        p.families.erase(std::remove_if(p.families.begin(), p.families.end(), unwanted), p.families.end());
      }
      write_json(o.out + "/work_precision_" + p.name + ".json", run_problem(p, o));
    }
  }
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run_work_precision(argc, argv);
  } catch (const cosserat::cli::Failure& f) {
    return cosserat::cli::report("bench_work_precision", f);
  }
}
