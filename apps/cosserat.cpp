// The `cosserat` command-line tool (DESIGN.md section 8): check, run, equilibrium, linearize and
// compare MJCF scenes with Cosserat rods, plus the core-only `demo`.
//
// Every command declares its options in one table (CommandLine) that parses them strictly and
// prints its --help. Failures throw Failure; main prints a one-line reason on stderr and exits
// with status 1 (LoadError as "file:line: message").
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "adaptive_option.hpp"
#include "newton_options.hpp"
#include "dynamics.hpp"
#include "integrators.hpp"
#include "kinematics.hpp"
#include "linearize.hpp"
#include "cli.hpp"
#include "progress.hpp"
#include "render_commands.hpp"
#include "scene.hpp"
#include "scene_statics.hpp"
#include "state_options.hpp"
#include "statics.hpp"

namespace {

using namespace cosserat::cli;
namespace mj = cosserat::mj;
using cosserat::Integrator;
using cosserat::Vec3;
using json = nlohmann::ordered_json;

// MuJoCo's warnings go to the run's report instead of the console and MUJOCO_LOG.TXT; its errors
// are thrown: inside a step they end the run as a divergence (its outputs cover the run up to the
// last good step), elsewhere the program with a one-line reason.
// `compare` points g_warning_sink at the messages of the simulation it is stepping (MuJoCo's
// callback is global), so that each warning is reported for the model that raised it.
std::vector<std::string> g_mujoco_warnings;
std::vector<std::string>* g_warning_sink = &g_mujoco_warnings;
void on_mujoco_warning(const char* msg) {
  std::vector<std::string>& w = *g_warning_sink;
  if (std::find(w.begin(), w.end(), msg) == w.end()) w.emplace_back(msg);
}
// Sends MuJoCo's warnings to `sink` for its lifetime.
struct WarningSink {
  std::vector<std::string>* saved;
  explicit WarningSink(std::vector<std::string>& sink) : saved(g_warning_sink) { g_warning_sink = &sink; }
  ~WarningSink() { g_warning_sink = saved; }
  WarningSink(const WarningSink&) = delete;
  WarningSink& operator=(const WarningSink&) = delete;
};
struct MujocoError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
void on_mujoco_error(const char* msg) { throw MujocoError(std::string("MuJoCo error: ") + msg); }

Integrator parse_integrator(const std::string& flag, const std::string& text) {
  const auto in = cosserat::integrator_from_name(text);
  if (!in) fail(flag + ": unknown integrator '" + text + "' (" + cosserat::kIntegratorNames + ")");
  return *in;
}

Option integrator_option(std::optional<Integrator>& target) {
  return {"--integrator", "NAME", "euler | implicit | trapezoidal | genalpha | midpoint | rk4 | rosenbrock (default: implicit with "
          "rods, euler without; midpoint: the energy-conserving implicit midpoint rule, for long undamped runs; "
          "rosenbrock: third order, linearly implicit, 4 evaluations per step, for accuracy at large steps where the stiffness of rods, joints and tendons dominates; cable tensions set by controls, contacts and gravity are explicit in it)",
          [&target](const std::string& v) { target = parse_integrator("--integrator", v); }};
}

// ------------------------------------------------------------------------------------ output --

// Opens `path` for writing (its directory was created by check_writable, before the command ran).
std::ofstream open_output(const std::string& path) {
  std::ofstream f(path);
  if (!f) fail("cannot write " + path);
  return f;
}

// The command line after the program's name (dispatch): each JSON report starts with it, so that
// reports of runs with other options can be told apart (outside probe BL).
std::vector<std::string>& command_line() {
  static std::vector<std::string> args;
  return args;
}

// A report's warnings: `w` and those said on stderr as they arose (warn_once: a clamped --ctrl), an
// empty list where there are none (the same keys in every report).
json report_warnings(std::vector<std::string> w) {
  const std::vector<std::string>& said = said_warnings();
  w.insert(w.end(), said.begin(), said.end());
  return w;
}

// Whether efc row i is a joint or tendon limit.
bool limit_row(const mjData* d, int i) {
  return d->efc_type[i] == mjCNSTR_LIMIT_JOINT || d->efc_type[i] == mjCNSTR_LIMIT_TENDON;
}

// Writes j to path ('-': stdout), after a "command" entry with the command line. A write that
// fails, also at the final flush (a full disk: a small report sits in the stream's buffer until
// then), is a failure naming the path and the reason.
void write_json(const std::string& path, const json& report) {
  json j = {{"command", command_line()}};
  j.update(report);
  if (path == "-") {
    std::cout << j.dump(2) << "\n";
    if (!std::cout.flush()) fail("--json: cannot write stdout");
    return;
  }
  // a regular file is written whole under another name and renamed over it: a program killed while
  // writing leaves no half report (outside probe CL); a pipe or device is written in place
  std::error_code ec;
  const bool in_place = std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec);
  const std::string written = in_place ? path : path + ".part";
  std::ofstream f = open_output(written);
  // (the reason from the write that failed: a report larger than the stream's buffer fails while
  // written, a smaller one at the close)
  errno = 0;
  f << j.dump(2) << "\n";
  int reason = f ? 0 : errno;
  if (f) {
    errno = 0;
    f.close();
    reason = errno;
  }
  if (f && !in_place) {
    std::filesystem::rename(written, path, ec);
    if (ec) f.setstate(std::ios::failbit), reason = ec.value();
  }
  if (!f && !in_place) std::filesystem::remove(written, ec);
  // (the option named: outside probe BB)
  if (!f) fail("--json: cannot write " + path + (reason ? " (" + std::string(std::strerror(reason)) + ")" : ""));
}

// ---------------------------------------------------------------------------- scene outputs --

// The named sites (rod sites included) and named bodies (not world, not the bodies generated for
// rods, whose poses the rod sites report) whose positions the commands write.
struct Named {
  std::string name;
  int id;
};
struct Outputs {
  std::vector<Named> sites, bodies;
};

// A sensor's values in the outputs (--sensors): MuJoCo's sensordata[adr .. adr + dim), under the
// sensor's name (an unnamed one: sensor<i>); CSV columns NAME for one value, NAME.0, NAME.1, ... else.
struct SensorOutput {
  std::string name;
  int adr = 0, dim = 0;
};

std::vector<SensorOutput> sensor_outputs(const mjModel* m) {
  std::vector<SensorOutput> v;
  auto named = [m](const std::string& n) { return mj_name2id(m, mjOBJ_SENSOR, n.c_str()) >= 0; };
  for (int i = 0; i < m->nsensor; ++i) {
    const char* n = mj_id2name(m, mjOBJ_SENSOR, i);
    std::string name = n && *n ? std::string(n) : "sensor" + std::to_string(i);
    // (outside probe AN: an unnamed sensor 0 beside one named "sensor0" had shared its columns)
    if (!(n && *n))
      for (int k = 1; named(name); ++k) name = "sensor" + std::to_string(i) + "_" + std::to_string(k);
    v.push_back({name, m->sensor_adr[i], m->sensor_dim[i]});
  }
  return v;
}

// The warning --sensors gives where the model switches its sensors off (their columns read 0).
std::string disabled_sensors_warning(const mjModel* m) {
  return m->nsensor > 0 && (m->opt.disableflags & mjDSBL_SENSOR)
             ? "--sensors: the model disables its sensors (<flag sensor=\"disable\"/>): their values read 0"
             : "";
}

// A CSV header field: quoted (RFC 4180) where the name holds a comma, a quote or a line break.
std::string csv_field(const std::string& name) {
  if (name.find_first_of(",\"\n\r") == std::string::npos) return name;
  std::string q = "\"";
  for (const char ch : name) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return q + "\"";
}

void add_sensors(json& j, const std::vector<SensorOutput>& sensors, const mjData* d) {
  j["sensors"] = json::object();
  for (const auto& s : sensors) j["sensors"][s.name] = std::vector<double>(d->sensordata + s.adr, d->sensordata + s.adr + s.dim);
}

void print_sensors(const std::vector<SensorOutput>& sensors, const mjData* d) {
  for (const auto& s : sensors) {
    std::printf("  %-6s %-24s", "sensor", s.name.c_str());
    for (int k = 0; k < s.dim; ++k) std::printf(" %12.6g", d->sensordata[s.adr + k]);
    std::printf("\n");
  }
}

// The --sensors flag's help (run, equilibrium).
constexpr const char* kSensorsHelp =
    "also report the model's sensors (MuJoCo's sensordata, rod sites included: tendon and actuator lengths, "
    "forces, touch, frame poses, ...) at each sample: CSV columns NAME (or NAME.0, NAME.1, ... for several values; "
    "an unnamed sensor is sensor<i>, with a suffix _k where a named sensor has that name; names with commas or quotes are quoted) after the positions, and \"sensors\": {NAME: [values]} in the JSON and the "
    "summary (the final state)";

Outputs named_outputs(const mj::Scene& s) {
  const mjModel* m = s.m;
  Outputs o;
  for (int i = 0; i < m->nsite; ++i)
    if (const char* n = mj_id2name(m, mjOBJ_SITE, i); n && *n) o.sites.push_back({n, i});
  for (int b = 1; b < m->nbody; ++b)
    if (const char* n = mj_id2name(m, mjOBJ_BODY, b); n && *n && !mj::generated_body(s, b)) o.bodies.push_back({n, b});
  return o;
}

Vec3 site_position(const mj::SceneData& sd, int id) { return Eigen::Map<const Vec3>(sd.d->site_xpos + 3 * id); }
Vec3 body_position(const mj::SceneData& sd, int id) { return Eigen::Map<const Vec3>(sd.d->xpos + 3 * id); }

json vec_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

void add_positions(json& j, const Outputs& o, const mj::SceneData& sd) {
  j["sites"] = json::object();
  for (const auto& n : o.sites) j["sites"][n.name] = vec_json(site_position(sd, n.id));
  j["bodies"] = json::object();
  for (const auto& n : o.bodies) j["bodies"][n.name] = vec_json(body_position(sd, n.id));
}

void print_positions(const Outputs& o, const mj::SceneData& sd) {
  // six decimals of a metre, more for a scene of micrometres (outside probe BZ: a flagellum's
  // positions read 0.000008), six significant digits of its largest coordinate
  double big = 0.0;
  for (const auto& n : o.sites) big = std::max(big, site_position(sd, n.id).cwiseAbs().maxCoeff());
  for (const auto& n : o.bodies) big = std::max(big, body_position(sd, n.id).cwiseAbs().maxCoeff());
  const int decimals = big > 0 && std::isfinite(big) ? std::clamp(5 - static_cast<int>(std::floor(std::log10(big))), 6, 15) : 6;
  auto line = [decimals](const std::string& kind, const std::string& name, const Vec3& p) {
    std::printf("  %-6s %-24s %*.*f %*.*f %*.*f\n", kind.c_str(), name.c_str(), decimals + 6, decimals, p.x(), decimals + 6,
                decimals, p.y(), decimals + 6, decimals, p.z());
  };
  for (const auto& n : o.sites) line("site", n.name, site_position(sd, n.id));
  for (const auto& n : o.bodies) line("body", n.name, body_position(sd, n.id));
}

// Warnings MuJoCo counted in mjData (too many contacts, bad numbers, ...), plus its messages.
std::vector<std::string> collect_warnings(const mj::Scene& sc, const mj::SceneData& sd,
                                          const std::vector<std::string>& messages = g_mujoco_warnings) {
  const mjData* d = sd.d;
  std::vector<std::string> w;
  if (const std::string c = mj::collapse_warning(sc, sd); !c.empty()) w.push_back(c);
  for (int i = 0; i < mjNWARNING; ++i)
    if (d->warning[i].number > 0)
      w.push_back(std::string(mju_warningText(i, d->warning[i].lastinfo)) + " (" + std::to_string(d->warning[i].number) +
                  " times)");
  w.insert(w.end(), messages.begin(), messages.end());
  w.insert(w.end(), sc.load_warnings.begin(), sc.load_warnings.end());
  for (const auto& f : sc.fluid.warnings) w.push_back("fluid: " + f);
  return w;
}

// Prints warnings but those the load printed already (`loaded`), which the JSON keeps (outside
// probe BB: a load warning was printed twice in one run).
void print_warnings(std::FILE* to, const std::vector<std::string>& warnings, const std::vector<std::string>& loaded) {
  for (const auto& w : warnings)
    if (std::find(loaded.begin(), loaded.end(), w) == loaded.end()) std::fprintf(to, "warning: %s\n", w.c_str());
}

// ------------------------------------------------------------------------------- simulation --

struct SimOptions {
  double duration = 1.0;
  std::optional<double> timestep;
  std::optional<Integrator> integrator;
  NewtonOptions newton;  // --newton*, --rho
  std::optional<double> step_tol;

  void add_to(CommandLine& c) {
    c.options.push_back(positive_option("--duration", "T", "simulated time [s] (default 1)", duration));
    c.options.push_back(optional_positive_option("--timestep", "h", "time step [s] (default: the model's <option timestep>)", timestep));
    c.options.push_back(integrator_option(integrator));
    newton.add_newton_to(c);
    c.options.push_back(optional_positive_option(
        "--step-tol", "TOL",
        "implicit, trapezoidal, genalpha, midpoint: adaptive substeps. Each step is taken as substeps of h/2^k "
        "(k <= 10, carried from step to step), halved where the mean acceleration changed from the previous "
        "substep's by more than TOL of the velocity scale (h_s |abar - abar_prev| <= TOL (|v| + h_s |abar|) in "
        "the kinetic-energy norm) or the Newton iteration failed, doubled where the change fell below TOL/8; a "
        "substep of at most h/2 taken as a contact event's step is kept unchecked (default: the model's <custom><numeric name=\"cosserat:step_tol\">, else off: fixed steps; 1e-2 keeps the energy of a whipping heavy-tipped rod to 0.1%, 1e-3 is "
        "about 10 times more accurate)",
        step_tol));
    newton.add_rho_to(c);
  }
};

// A MuJoCo error raised outside a step (`doing`: what the command was doing), reported against the file.
mj::LoadError error_while(const std::string& path, const MujocoError& e, const char* doing) {
  return mj::LoadError(path, 0, std::string(e.what()) + ", raised while " + doing);
}

// A MuJoCo error raised while a model is evaluated at its initial state (at load: its constants at
// qpos0; in check: its first forward).
mj::LoadError error_at_initial_state(const std::string& path, const MujocoError& e) {
  return error_while(path, e, "evaluating the model at its initial state");
}

// mj::load_scene, with error_at_initial_state's report; prints the loader's warnings
// (mj::Scene::load_warnings) on stderr.
std::unique_ptr<mj::Scene> load(const std::string& path) {
  try {
    auto s = mj::load_scene(path);
    for (const auto& w : s->load_warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    return s;
  } catch (const MujocoError& e) {
    throw error_at_initial_state(path, e);
  }
}

// A loaded scene stepping with the command's time step and integrator.
class Simulation {
 public:
  Simulation(const std::string& path, const SimOptions& o, const StateOptions& state) : scene_(load(path)) {
    if (o.timestep) scene_->m->opt.timestep = *o.timestep;
    integrator_ = o.integrator.value_or(scene_->integrator);
    o.newton.apply(*scene_, integrator_);
    apply_step_tol(*scene_, integrator_, o.step_tol);
    data_ = std::make_unique<mj::SceneData>(*scene_);
    state.apply(*scene_, *data_);
    steps_ = step_count(o.duration, timestep(), "--duration");
    outputs_ = named_outputs(*scene_);
  }

  const mj::Scene& scene() const { return *scene_; }
  mj::SceneData& data() { return *data_; }
  const Outputs& outputs() const { return outputs_; }
  Integrator integrator() const { return integrator_; }
  double timestep() const { return scene_->m->opt.timestep; }
  double time() const { return data_->d->time; }
  long steps() const { return steps_; }

  bool step() {
    try {
      return mj::step(*scene_, *data_, integrator_) == cosserat::Status::Ok;
    } catch (const MujocoError& e) {
      mj::abandon_step(*data_, e.what());
      return false;
    }
  }
  // Evaluates the pipeline at the current state: positions and energy are current afterwards.
  // False after a MuJoCo error (positions are then the position stage's; the run counts as
  // diverged, with the error as its reason unless a divergence gave one already). The observation
  // leaves the run as it was: the kinematics normalises quaternions in qpos in place (not exactly
  // idempotent), and the evaluation overwrites the constraint solver's warm start; both are put
  // back, so a sampled run is bit for bit an unsampled one (they had differed in the last bits).
  bool observe() {
    mjData* d = data_->d;
    const mjModel* m = scene_->m;
    kept_qpos_.assign(d->qpos, d->qpos + m->nq);
    kept_warmstart_.assign(d->qacc_warmstart, d->qacc_warmstart + m->nv);
    try {
      mj::forward(*scene_, *data_);
      std::copy(kept_qpos_.begin(), kept_qpos_.end(), d->qpos);
      std::copy(kept_warmstart_.begin(), kept_warmstart_.end(), d->qacc_warmstart);
      return true;
    } catch (const MujocoError& e) {
      data_->d->pstack = 0;  // the unwound MuJoCo frames did not release their stack allocations
      if (data_->status != cosserat::Status::Diverged) {
        data_->status = cosserat::Status::Diverged;
        data_->warning = std::string(e.what()) + " (at t = " + std::to_string(time()) + " s)";
      }
      return false;
    }
  }
  mj::SceneEnergy energy() { return mj::energy(*scene_, *data_); }

 private:
  std::unique_ptr<mj::Scene> scene_;
  std::unique_ptr<mj::SceneData> data_;
  Integrator integrator_ = Integrator::Implicit;
  std::vector<mjtNum> kept_qpos_, kept_warmstart_;  // what observe() puts back
  long steps_ = 0;
  Outputs outputs_;
};

// Per geom, whether it is a capsule of a rod section with stretch or shear strain (px, py or pz)
// and `in` leaves that section's vibration undamped: the explicit steps (euler, rk4, rosenbrock,
// whose contacts are explicit) and the linearised trapezoidal rule, and the section's viscosity is
// below 100 Pa s. Empty where no geom is.
std::vector<char> undamped_stretching_capsules(const mj::Scene& sc, Integrator in) {
  const bool undamped = in == Integrator::Euler || in == Integrator::RK4 || in == Integrator::Rosenbrock ||
                        (in == Integrator::Trapezoidal && sc.newton_for(in) == 0);
  std::vector<char> out;
  if (!undamped) return out;
  for (int g = 0; g < sc.m->ngeom; ++g) {
    const int r = sc.geom_rod[g];
    if (r < 0) continue;
    const cosserat::Section& sec = sc.rods[r].model.sections[sc.rods[r].decl.geoms[sc.geom_index[g]].section];
    // (a viscosity of 100 Pa s brought the kl rod within 1.3% of Coulomb's)
    if (sec.B.bottomRows<3>().isZero(0.0) || sec.material.viscosity >= 100.0) continue;
    out.resize(sc.m->ngeom, 0);
    out[g] = 1;
  }
  return out;
}

// Outside probe BS: a soft rod sliding down a slope steeper than its friction angle, with sections
// that stretch (kl) or shear (sr) and no viscosity, accelerated 7-18% (kl) and up to 90% (sr) faster
// than Coulomb's g (sin a - mu cos a) under euler, rk4 and rosenbrock, at every step down to 5 us,
// and slid below the friction angle: its undamped axial and shear vibration, driven by the contacts,
// takes friction away (8% of the contacts pushed it downhill). MuJoCo's own Euler on the native
// chain of slide joints does the same, less (2.38-2.48 against 2.356 m/s^2); backward Euler, the
// default, damps the vibration and gives Coulomb's to 1e-4, as do inextensible strain sets and a
// viscosity of about 100 Pa s.
std::string friction_on_stretching_rods_warning(Integrator in) {
  return std::string("friction on rod sections that stretch or shear (strain px, py, pz) under --integrator ") +
         cosserat::integrator_name(in) + (in == Integrator::Trapezoidal ? " --newton 0" : "") +
         ": this step leaves their axial and shear vibration undamped, and the contacts drive it until it takes "
         "friction away (an undamped kl rod slid down a slope 7-18% faster than Coulomb's friction allows, an sr rod "
         "up to 90%, at any step size); the default --integrator implicit damps it and gives Coulomb's friction, as do "
         "inextensible strain sets (ikl, icc) or a rod viscosity of about 100 Pa s";
}

// Relative energy drift: the largest |E - E0| over the energy the run exchanges between its forms
// (exchanged(): the largest kinetic plus elastic energy seen without the motion of the whole
// scene's centre of mass, plus the range of that motion's energy and the gravitational one). E0 is
// no scale: it is zero for a rod released straight at the origin, and the gravitational energy's
// datum moves it (outside probe BL: the same cantilever clamped at z = 0, 0.5 m and 100 m read
// drifts of 0.19, 2.5e-5 and 1.2e-7 over the larger of |E0| and that energy, while backward Euler
// took a third of its vibration's energy in each case). |E0| only where nothing moved.
class EnergyTracker {
 public:
  void add(const mj::SceneEnergy& e) {
    const double total = e.total();
    if (n_++ == 0) initial_ = total, gravity_min_ = gravity_max_ = e.gravity;
    if (n_ == 1) stored0_ = e.kinetic + e.elastic;
    final_ = total;
    final_kinetic_ = e.kinetic;
    max_dev_ = std::max(max_dev_, std::abs(total - initial_));
    max_gain_ = std::max(max_gain_, total - initial_);
    max_loss_ = std::max(max_loss_, initial_ - total);
    max_internal_ = std::max(max_internal_, e.kinetic - e.translational + e.elastic);
    const double outer = e.translational + e.gravity;
    if (n_ == 1) outer_min_ = outer_max_ = outer;
    outer_min_ = std::min(outer_min_, outer);
    outer_max_ = std::max(outer_max_, outer);
    gravity_min_ = std::min(gravity_min_, e.gravity);
    gravity_max_ = std::max(gravity_max_, e.gravity);
  }
  double initial() const { return initial_; }
  double final() const { return final_; }
  // the kinetic energy at the last sample: whether the run came to rest (outside probe BL)
  double final_kinetic() const { return final_kinetic_; }
  // the energy the run exchanged between its forms (kinetic, elastic, gravitational): the largest
  // kinetic and elastic energy seen, the kinetic less the centre of mass's motion, plus the range of
  // that motion's energy and the gravitational one together. Neither a datum, nor a uniform
  // velocity, nor a free fall moves it: a free scene's centre of mass keeps the sum of the two
  // (outside probe BP: a free scene boosted by 3.7 m/s read a drift of 8.5e-3 without a warning
  // where at rest its integrator's 63% loss was warned about; outside probe BT: the same scene
  // falling read 2.4e-4, the scale 300 J of its fall). A clamped rod's swing moves it with the rest.
  double exchanged() const { return max_internal_ + (outer_max_ - outer_min_); }
  double max_rel_drift() const {
    const double ref = exchanged() > 0 ? exchanged() : std::abs(initial_);
    return ref > 0 ? max_dev_ / ref : 0.0;
  }
  // The largest gain of energy, over the energy the run started with (stored, or the range of the
  // gravitational energy it went through): not over what it stored later, which a run that blows
  // up inflates (outside probe AF's bent rod under the trapezoidal rule: 3.5 J to 1229 J read as a
  // drift of 0.998), nor over the total, whose gravitational part depends on the datum (outside
  // probe AG: the same rod clamped 100 m up hid a gain of 30 J in 311 J).
  double max_rel_gain() const {
    const double ref = stored0_ + (gravity_max_ - gravity_min_);
    return ref > 0 ? max_gain_ / ref : 0.0;
  }
  double max_gain() const { return max_gain_; }
  // the largest loss of energy, over the energy the run exchanged
  double max_rel_loss() const { return exchanged() > 0 ? max_loss_ / exchanged() : 0.0; }
  double max_loss() const { return max_loss_; }

 private:
  long n_ = 0;
  double initial_ = 0, final_ = 0, final_kinetic_ = 0, max_dev_ = 0, max_gain_ = 0, max_loss_ = 0, max_internal_ = 0, stored0_ = 0,
         outer_min_ = 0, outer_max_ = 0, gravity_min_ = 0, gravity_max_ = 0;
};

// A body as messages name it: its name, "world", or "#id" where it has none.
std::string body_name(const mjModel* m, int b) {
  if (b == 0) return "world";
  const char* n = mj_id2name(m, mjOBJ_BODY, b);
  return n && *n ? std::string(n) : "#" + std::to_string(b);
}

// The fastest motion `run` saw, against what one step can resolve: a body turning more than half
// a turn in a step (whose direction of turning a sampled motion cannot tell) or moving more than
// the scene's extent (past anything it could touch). A run that blows up shows it before its state
// becomes non-finite (outside fuzzing: the hybrid arm under rk4 at its 1 ms step went from 3 J to
// 7.5e11 J in 0.02 s, with exit 0 and only a section's collapse to say so).
class MotionTracker {
 public:
  void add(const mjModel* m, const mjData* d) {
    const double h = m->opt.timestep, extent = m->stat.extent;
    for (int b = 1; b < m->nbody; ++b) {
      mjtNum v[6];
      mj_objectVelocity(m, d, mjOBJ_BODY, b, v, 0);
      const double turn = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) * h;
      const double move = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]) * h;
      const double r = std::max(turn / M_PI, extent > 0 ? move / extent : 0.0);
      if (r > worst_) {
        worst_ = r;
        body_ = b;
        turn_ = turn;
        move_ = move;
        time_ = d->time;
      }
    }
  }
  // the warning, where a step's motion exceeded what it resolves
  std::string warning(const mjModel* m, const EnergyTracker& energy) const {
    if (!(worst_ > 1.0)) return {};
    char b[640];
    std::snprintf(b, sizeof b,
                  "body '%s' turned %.3g rad and moved %.3g m (%.3g times the scene's extent) within one step of %g s "
                  "at t = %.6g s: steps this large do not resolve the motion, and a run blowing up looks like this (its "
                  "energy went from %.4g J to %.4g J); try a smaller --timestep or --integrator implicit",
                  body_name(m, body_).c_str(), turn_, move_, move_ / m->stat.extent,
                  m->opt.timestep, time_, energy.initial(), energy.final());
    return b;
  }

 private:
  double worst_ = 0, turn_ = 0, move_ = 0, time_ = 0;
  int body_ = 0;
};

// What in the scene moves energy in or out of the mechanical energy `run` tracks (damping, actuators
// that pushed during the run, fluid forces, contacts made during the run, equality constraints):
// with any of them the drift above measures that exchange, not the integrator (a swimmer driven
// from rest reads 1.00).
std::vector<std::string> energy_exchanges(const mj::Scene& sc, bool touched, bool limited, bool actuated) {
  const mjModel* m = sc.m;
  std::vector<std::string> out;
  bool rod_damping = false;
  for (const auto& rb : sc.rods)
    for (const auto& sec : rb.model.sections) rod_damping = rod_damping || sec.material.viscosity > 0;
  if (rod_damping) out.push_back("rod damping");
  // (MuJoCo's dampers and fluid are off under <flag passive="disable"/>, and its actuators under
  // actuation="disable"; the rods' own damping and fluid stay on)
  const bool passive = !(m->opt.disableflags & mjDSBL_PASSIVE);
  if (passive && mj::has_joint_damping(m)) out.push_back("joint or tendon damping");
  // (outside probe CH: a model whose load motors stayed at 0 had its energy loss under the default
  // step unwarned, "not conserved here: actuators")
  if (actuated) out.push_back("actuators");
  if (sc.fluid.active || (passive && (m->opt.density > 0 || m->opt.viscosity > 0))) out.push_back("fluid");
  if (touched) out.push_back("contacts");
  // friction loss and limits take energy too (outside probe BV: a pendulum with friction loss and
  // one stopped by a joint limit had been warned about as numerical damping)
  const bool rows = !(m->opt.disableflags & mjDSBL_CONSTRAINT);
  bool frictionloss = false;
  for (int i = 0; i < m->nv; ++i) frictionloss = frictionloss || m->dof_frictionloss[i] > 0;
  for (int i = 0; i < m->ntendon; ++i) frictionloss = frictionloss || m->tendon_frictionloss[i] > 0;
  if (rows && frictionloss && !(m->opt.disableflags & mjDSBL_FRICTIONLOSS)) out.push_back("friction loss");
  if (rows && limited) out.push_back("limits");
  // (outside probe BI: listed under <flag equality="disable"/> and constraint="disable" too)
  bool active_equality = false;
  for (int e = 0; e < m->neq; ++e) active_equality = active_equality || m->eq_active[e];
  if (active_equality && !(m->opt.disableflags & (mjDSBL_EQUALITY | mjDSBL_CONSTRAINT))) out.push_back("equality constraints");
  return out;
}

// --------------------------------------------------------------------------------- commands --

// One rod's resistive-force coefficients at its base, and where they came from (the law, lambda and
// Lighthill's Lambda along the filament).
void print_rod_fluid(const std::string& rod, bool enabled, const cosserat::RodFluidInfo& f) {
  using Law = cosserat::RodFluidInfo::Law;
  if (!enabled) {
    std::printf("fluid: rod '%s': no fluid force (drag=\"0\")\n", rod.c_str());
    return;
  }
  std::string from;
  if (f.law == Law::Explicit) from = "explicit drag";
  else {
    const std::string lambda = (f.default_wavelength ? (f.helical ? "the helix's pitch " : "L/2 ") : "wavelength ") +
                               format_g(f.wavelength) + " m";
    from = f.law == Law::Lighthill ? "Lighthill, Lambda " + format_g(f.along_filament) + " m along the filament (lambda = " +
                                         lambda + ")"
                                   : "Gray & Hancock, lambda = " + lambda;
  }
  std::printf("fluid: rod '%s': %s; at its base c_t %g, c_n %g N s/m^2, c_rot %g N s\n", rod.c_str(), from.c_str(),
              f.base.ct, f.base.cn, f.base.crot);
}

int cmd_check(int argc, char** argv) {
  CommandLine cl{"check", "load and compile a model; print a summary (rods, sections, strain dofs, sizes)",
                 {"MODEL.xml"}, {}, ""};
  const auto pos = cl.parse(argc, argv);
  if (!pos) return 0;
  const auto s = load((*pos)[0]);
  const mjModel* m = s->m;
  mj::SceneData sd(*s);
  try {
    mj::forward(*s, sd);
  } catch (const MujocoError& e) {
    throw error_at_initial_state((*pos)[0], e);
  }
  std::printf("model: %s (%s)\n", m->names, (*pos)[0].c_str());
  std::printf("rods: %zu\n", s->rods.size());
  for (const auto& r : s->rods) {
    int limited = 0;  // strainrange
    for (int k = 0; k < r.model.nv; ++k) limited += m->jnt_limited[m->dof_jntid[r.dof0 + k]] ? 1 : 0;
    std::printf("  %s: %zu sections, %d strain dofs, length %g m", r.decl.name.c_str(), r.proxy_body.size(), r.model.nv,
                r.model.rods[0].length);
    if (limited) std::printf(", %d strain dofs limited (strainrange)", limited);
    std::printf("\n");
  }
  std::printf("nq: %d  nv: %d  nbody: %d  ngeom: %d  nsite: %d  nu: %d\n", m->nq, m->nv, m->nbody, m->ngeom, m->nsite,
              m->nu);
  std::printf("timestep: %g s  integrator: %s", m->opt.timestep, integrator_name(s->integrator));
  if (s->step_tol > 0 && mj::takes_substeps(s->integrator))
    std::printf("  adaptive substeps: step_tol %g", s->step_tol);
  else if (s->step_tol > 0)
    std::printf("  (the model's step_tol %g does not apply: %s takes fixed steps)", s->step_tol,
                integrator_name(s->integrator));
  std::printf("\n");
  if (!s->may_collide)
    std::printf("contacts: none possible (no two geoms pass the contype/conaffinity filters, no <pair>): "
                "collision detection skipped\n");
  if (s->fluid.active)
    std::printf("fluid: resistive-force theory (%s), viscosity %g Pa s; rigid bodies: %zu, rods: %d\n",
                s->fluid.model == cosserat::RftModel::Lighthill ? "Lighthill" : "Gray & Hancock", s->fluid.viscosity,
                s->fluid.bodies.size(),
                static_cast<int>(std::count(s->fluid.rod_enabled.begin(), s->fluid.rod_enabled.end(), true)));
  if (s->fluid.active)
    for (size_t r = 0; r < s->rods.size(); ++r) print_rod_fluid(s->rods[r].decl.name, s->fluid.rod_enabled[r], s->fluid.rods[r]);
  for (const auto& n : s->fluid.notes) std::printf("fluid: %s\n", n.c_str());
  for (const auto& w : s->fluid.warnings) std::printf("warning: fluid: %s\n", w.c_str());
  for (int i = 0; i < m->nv; ++i)
    if (!std::isfinite(sd.d->qacc[i])) fail("the model's accelerations at qpos0 are not finite");
  return 0;
}

// What to try when a run diverges, for the integrator it used.
std::string divergence_hint(Simulation& s) {
  return mj::divergence_hint(s.scene(), s.data(), s.integrator(), mj::Vocabulary::CommandLine);
}

const std::string kCloseIt =
    "a stiffer solref (its time constant down to twice the step, e.g. solref=\"0.002 1\" at 1 ms) or a "
    "solimp nearer 1 (e.g. solimp=\"0.99 0.999 0.001\") closes it, and where it joins bodies, heavier ones";

// The bodies' and then the sites' positions as d holds them (after an evaluation of the scene).
std::vector<mjtNum> body_and_site_positions(const mjModel* m, const mjData* d) {
  std::vector<mjtNum> x(d->xpos, d->xpos + 3 * m->nbody);
  x.insert(x.end(), d->site_xpos, d->site_xpos + 3 * m->nsite);
  return x;
}

// The bodies' and sites' positions (the rods' proxies at their section ends, their sites where the
// rods put them: the scene's poses, not mj_kinematics', which takes the strain joints for slides).
std::vector<mjtNum> scene_positions(const mj::Scene& sc, mj::SceneData& sd) {
  mj::fwd_inertia(sc, sd, false);
  return body_and_site_positions(sc.m, sd.d);
}

// Per body, the largest displacement of it and its sites between two scene_positions.
std::vector<double> displacement_from(const mjModel* m, const std::vector<mjtNum>& start, const std::vector<mjtNum>& x) {
  std::vector<double> out(m->nbody, 0.0);
  for (size_t i = 0; i + 2 < x.size(); i += 3) {
    const int k = static_cast<int>(i / 3);
    const int b = k < m->nbody ? k : m->site_bodyid[k - m->nbody];
    out[b] = std::max(out[b], std::hypot(x[i] - start[i], x[i + 1] - start[i + 1], x[i + 2] - start[i + 2]));
  }
  return out;
}

// SIGINT (Ctrl-C), SIGTERM (a batch system's time limit, `timeout`) and SIGHUP during `run`: the run
// stops at the end of its step, writes its CSV and JSON up to there (the JSON's "interrupted"),
// says so and exits with 128 + the signal; a third one ends it at once (GNU timeout delivers its
// signal twice, to the program and to its process group). (Outside probe CL: a signal killed the
// program outright, with no JSON, nothing said and the CSV cut mid-row, the last value parsing
// 1e5 too large.)
volatile std::sig_atomic_t g_stop_signal = 0, g_stop_count = 0;
extern "C" void note_stop_signal(int sig) {
  g_stop_signal = sig;
  if (++g_stop_count >= 3) {
    signal(sig, SIG_DFL);
    raise(sig);
  }
}
class StopOnSignals {
 public:
  StopOnSignals() {
    struct sigaction a {};
    a.sa_handler = note_stop_signal;
    sigemptyset(&a.sa_mask);
    a.sa_flags = 0;
    for (int i = 0; i < 3; ++i) {
      sigaction(kSignals[i], &a, &old_[i]);
      // a signal the caller ignores stays ignored (nohup; a shell script's background job and SIGINT)
      if (old_[i].sa_handler == SIG_IGN) sigaction(kSignals[i], &old_[i], nullptr);
    }
  }
  ~StopOnSignals() {
    for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &old_[i], nullptr);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;
  static const char* name(int sig) { return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "SIGHUP"; }

 private:
  static constexpr int kSignals[3] = {SIGINT, SIGTERM, SIGHUP};
  struct sigaction old_[3];
};

int cmd_run(int argc, char** argv) {
  SimOptions sim;
  StateOptions state;
  std::string csv, json_path;
  int every = 0;  // 0: the default, set once the run's length is known
  CommandLine cl{"run", "simulate a model from its initial state", {"MODEL.xml"}, {}, ""};
  sim.add_to(cl);
  state.add_to(cl, true);
  cl.options.push_back(text_option("--csv", "F", "write time,energy,<name>.x,<name>.y,<name>.z,... (sites, then bodies; '-': stdout)", csv));
  cl.options.push_back(int_option("--every", "N",
                                  "CSV rows and energy samples every N steps (steps 0, N, 2N, ... and the last; default: "
                                  "1 with --csv, otherwise about 1000 samples per run). Each sample costs about one "
                                  "step (a forward evaluation and the energy)",
                                  every, 1));
  cl.options.push_back(text_option("--json", "F", "write a JSON report ('-': stdout)", json_path));
  bool with_sensors = false;
  cl.options.push_back(flag_option("--sensors", kSensorsHelp, with_sensors));
  cl.details = "Exit status 1 when the simulation diverges (the outputs cover the run up to there).\n";
  const auto pos = cl.parse(argc, argv);
  if (!pos) return 0;
  if (csv == "-" && json_path == "-") fail("--csv - and --json - both ask for stdout: give one of them a file");
  // (outside probe BV: the JSON had overwritten the CSV, quietly)
  // (weakly_canonical: the same file however spelt, before it exists; outside probe BW: "./x" and "x")
  auto same_file = [](const std::string& a, const std::string& b) {
    std::error_code ea, eb;
    const auto ca = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea),
               cb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
    return a == b || (!ea && !eb && ca == cb);
  };
  if (!csv.empty() && !json_path.empty() && (csv == "-" ? json_path == "/dev/stdout" : json_path == "-" ? csv == "/dev/stdout"
                                                                                                      : same_file(csv, json_path)))
    fail("--csv and --json name the same file (" + csv + "): give them different files");
  check_writable("--csv", csv);
  check_writable("--json", json_path);

  Simulation s(pos->front(), sim, state);
  if (every == 0) every = csv.empty() ? static_cast<int>(std::max(1L, s.steps() / 1000)) : 1;
  // an earlier run's JSON goes now, as its CSV does when opened: a report on disk is this run's
  // (outside probe CL: a re-run killed partway left the old JSON, "steps": 1000, beside the new
  // CSV, and a batch script taking "the JSON exists" for "done" skipped the job)
  if (!json_path.empty() && json_path != "-" && std::filesystem::is_regular_file(json_path)) {
    std::error_code ec;
    std::filesystem::remove(json_path, ec);
  }
  const Outputs& out = s.outputs();
  const std::vector<SensorOutput> sensors = with_sensors ? sensor_outputs(s.scene().m) : std::vector<SensorOutput>{};
  std::ofstream file;
  std::ostream* csv_out = nullptr;  // stdout or the file
  if (csv == "-") {
    csv_out = &std::cout;
  } else if (!csv.empty()) {
    file = open_output(csv);
    csv_out = &file;
  }
  std::vector<std::string> header = {"time", "energy"};
  for (const auto* names : {&out.sites, &out.bodies})
    for (const auto& n : *names)
      for (const char* axis : {".x", ".y", ".z"}) header.push_back(n.name + axis);
  for (const auto& c : sensors)
    for (int k = 0; k < c.dim; ++k) header.push_back(c.name + (c.dim > 1 ? "." + std::to_string(k) : std::string()));
  if (csv_out) {
    std::ostream& f = *csv_out;
    for (size_t i = 0; i < header.size(); ++i) f << (i ? "," : "") << csv_field(header[i]);
    f << "\n";
    f.precision(10);
  }
  // the CSV's rows are flushed every 64 (a killed run loses at most those), and a write that fails
  // (a full disk) stops the run there, with the reason (outside probe CL: a CSV on a full disk ran
  // the whole 300 000 steps to fail at the end, saying only "cannot write")
  int rows_unflushed = 0, csv_errno = 0;
  bool csv_failed = false;
  auto write_row = [&](double e) {
    if (!csv_out || csv_failed) return;
    std::ostream& f = *csv_out;
    errno = 0;
    f << s.time() << "," << e;
    for (const auto& n : out.sites) {
      const Vec3 p = site_position(s.data(), n.id);
      f << "," << p.x() << "," << p.y() << "," << p.z();
    }
    for (const auto& n : out.bodies) {
      const Vec3 p = body_position(s.data(), n.id);
      f << "," << p.x() << "," << p.y() << "," << p.z();
    }
    for (const auto& c : sensors)
      for (int k = 0; k < c.dim; ++k) f << "," << s.data().d->sensordata[c.adr + k];
    f << "\n";
    if (f && ++rows_unflushed >= 64) {
      rows_unflushed = 0;
      f.flush();
    }
    if (!f) {
      csv_failed = true;
      csv_errno = errno;
    }
  };

  EnergyTracker energy;
  MotionTracker motion;
  const double start_time = s.time();
  Progress progress("run", s.steps(), "step");
  const auto t0 = std::chrono::steady_clock::now();
  s.observe();
  energy.add(s.energy());
  write_row(energy.final());
  const std::vector<mjtNum> start_positions = scene_positions(s.scene(), s.data());
  // per body, the largest displacement of it and its sites from the start at the samples (the
  // scene's poses after each observation): the open-equality warning's measure of the motion
  // (re-check CK: from the end state alone, a pendulum back at its start after two periods had a
  // 2e-7 m gap of a stiff connect warned about as 2.6% of it)
  std::vector<double> moved_max(s.scene().m->nbody, 0.0);
  auto track_moved = [&](const std::vector<mjtNum>& x) {
    const std::vector<double> now = displacement_from(s.scene().m, start_positions, x);
    for (size_t b = 0; b < now.size(); ++b) moved_max[b] = std::max(moved_max[b], now[b]);
  };
  // how deep the start puts bodies into each other: what MuJoCo's soft contacts give back from
  // there is energy energy() does not count
  // (the pair's geoms kept: outside probe BB, the warning named the pair at the same index of the
  // end's contacts)
  double start_depth = 0.0;
  int deepest_geom1 = -1, deepest_geom2 = -1;
  for (int c = 0; c < s.data().d->ncon; ++c)
    if (-s.data().d->contact[c].dist > start_depth) {
      start_depth = -s.data().d->contact[c].dist;
      deepest_geom1 = s.data().d->contact[c].geom1;
      deepest_geom2 = s.data().d->contact[c].geom2;
    }
  // the energy the start stores in joints and tendons pushed past their limits, which their soft
  // rows give back and energy() does not count: 1/2 k r^2 per row, k = K I / R its stiffness at rest
  // (MuJoCo's reference stiffness, impedance and regulariser), r the violation (outside probe BW: a
  // tendon limit violated at the start had its gain blamed on the integrator; probe BX: judged by
  // the violation's size instead, a bead 2 mm past a slide limit hid a pendulum's real gain), and
  // in equality constraints open at the start, which store it as limits do
  double start_row_energy = 0.0;
  for (int i = 0; i < s.data().d->nefc; ++i) {
    const mjData* d0 = s.data().d;
    const bool violated = limit_row(d0, i) ? d0->efc_pos[i] < 0 : d0->efc_type[i] == mjCNSTR_EQUALITY;
    if (!violated || !(d0->efc_R[i] > 0))
      continue;
    const double k = d0->efc_KBIP[4 * i] * d0->efc_KBIP[4 * i + 2] / d0->efc_R[i];
    start_row_energy += 0.5 * k * d0->efc_pos[i] * d0->efc_pos[i];
  }
  long k = 0;
  bool diverged = false, touched = false, limited = false, actuated = false;
  long last_row = 0;  // the step of the CSV's last row
  // friction on the capsules of rod sections that stretch or shear, under a step that leaves their
  // vibration undamped (friction_on_stretching_rods_warning)
  const std::vector<char> stretching = undamped_stretching_capsules(s.scene(), s.integrator());
  bool rubbed = false;
  const StopOnSignals stop_on_signals;
  while (k < s.steps() && !g_stop_signal && !csv_failed) {
    if (!s.step()) {
      diverged = true;
      break;
    }
    ++k;
    touched = touched || s.data().d->ncon > 0;
    for (int i = 0; i < s.data().d->nefc && !limited; ++i) limited = limit_row(s.data().d, i);
    if (!(s.scene().m->opt.disableflags & mjDSBL_ACTUATION))
      for (int i = 0; i < s.scene().m->nu && !actuated; ++i) actuated = s.data().d->actuator_force[i] != 0;
    if (!stretching.empty() && !rubbed)
      for (int c = 0; c < s.data().d->ncon && !rubbed; ++c) {
        const mjContact& con = s.data().d->contact[c];
        // (with friction above MuJoCo's floor mjMINMU: outside probe BT, a frictionless slope had been warned about)
        rubbed = con.dim >= 3 && con.friction[0] > 10 * mjMINMU && con.exclude == 0 && (stretching[con.geom1] || stretching[con.geom2]);
      }
    if (k % every == 0 || k == s.steps()) {
      if (!s.observe()) {
        diverged = true;
        break;
      }
      energy.add(s.energy());
      motion.add(s.scene().m, s.data().d);
      write_row(energy.final());
      last_row = k;
      if (s.scene().m->neq > 0) track_moved(body_and_site_positions(s.scene().m, s.data().d));
    }
    progress.update(k, s.time());
  }
  if (diverged) {  // the state was restored to the last good step: the CSV's last row (outside probe BV)
    s.observe();
    energy.add(s.energy());
    if (last_row != k) write_row(energy.final());
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const int interrupted = g_stop_signal;
  if (csv_out && !csv_failed) {
    errno = 0;
    if (!csv_out->flush()) csv_failed = true, csv_errno = errno;
  }
  // (reported after the JSON, which a healthy disk still takes)
  const std::string csv_failure =
      csv_failed ? "--csv: cannot write " + (csv == "-" ? std::string("stdout") : csv) +
                       (csv_errno ? " (" + std::string(std::strerror(csv_errno)) + ")" : std::string()) +
                       ", at t = " + format_g(s.time()) + " s: the run stopped there"
                 : std::string();

  std::vector<std::string> warnings = collect_warnings(s.scene(), s.data());
  if (s.scene().newton_for(s.integrator()) > 0 && k > 0) {
    // steps whose Newton corrections failed were split: the run took smaller steps than asked
    const auto& ns = s.data().newton_stats;
    char b[512];
    if (ns.splits > k / 10) {
      std::snprintf(b, sizeof b,
                    "the Newton corrections failed to converge %ld times in %ld steps, each time splitting a step into "
                    "halves (down to h/64): the run's steps were smaller, and its cost higher, than --timestep says",
                    ns.splits, k);
      std::string w = b;
      // the iteration matrix taken again at each step's first iterate often converges at the full
      // step where the start's fails (README: --newton-refresh)
      if (!s.scene().newton_refresh && !(s.scene().step_tol > 0))
        w += std::string("; --newton-refresh (the iteration matrix taken again at each step's first iterate") +
             (s.integrator() == Integrator::Midpoint ? ", the midpoint rule's at its first midpoint state where no contact, "
                                                       "limit or equality acts"
                                                     : "") +
             ") often converges at the full step" +
             (s.integrator() == Integrator::Trapezoidal || s.integrator() == Integrator::GeneralizedAlpha
                  ? " (check the energy then: split steps can keep this scheme's energy bounded)"
                  : "");
      // more than a split per step with contact events: a rod sliding over a round body, whose
      // contact forces at the step's end the corrections do not find (README: a rope over a drum)
      if (ns.events > 0 && ns.splits > k && s.integrator() != Integrator::Implicit)
        w += "; with contacts changing state in " + std::to_string(ns.events) +
             " steps, --integrator implicit (contact forces from each step's start, as MuJoCo takes them) is "
             "often the robust choice (README, Known limitations: a rope over a drum)";
      // MuJoCo's noslip post-process rewrites the friction forces after its solver, a step the
      // corrections cannot follow (outside probe CE's grasp under trapezoidal: 93 corrections and
      // 4.6 splits a step with noslip_iterations 20, 5.9 and 0.03 without)
      if (s.scene().m->opt.noslip_iterations > 0)
        w += "; <option noslip_iterations> (MuJoCo's post-process of the friction forces) is a step the Newton "
             "corrections cannot follow: --integrator implicit takes it as MuJoCo does";
      warnings.push_back(w);
    }
    // most steps contact events, taken as linearised backward Euler steps: the scheme asked for was
    // hardly used (outside probe BS: a crawling rod's friction rows change state every step; under
    // trapezoidal and genalpha its 5000 steps gave implicit's numbers at 8-13 times its cost)
    // (counted in the pieces the steps were taken in: adaptive substeps, or split halves; outside
    // probe BT: "1111 of the 400 steps")
    const auto& as = s.data().adapt_stats;
    const bool substeps = s.scene().step_tol > 0 && as.substeps > 0;
    const long pieces = substeps ? as.substeps : k + ns.splits;
    if (s.integrator() != Integrator::Implicit && ns.events > pieces / 2) {
      std::snprintf(b, sizeof b,
                    "%ld of the %ld %s were contact events (a contact, limit or friction changing state), each "
                    "taken as a linearised backward Euler step: --integrator %s was used in the rest only; "
                    "--integrator implicit gives nearly the same run at a fraction of the cost",
                    ns.events, pieces, substeps ? "substeps" : "steps", cosserat::integrator_name(s.integrator()));
      warnings.push_back(b);
    }
    if (ns.unconverged > 0) {
      std::snprintf(b, sizeof b,
                    "%ld steps of h/64 did not converge: %ld kept as the corrections left them, %ld (whose corrections "
                    "stopped) taken as linearised backward Euler steps",
                    ns.unconverged, ns.unconverged - ns.linearised, ns.linearised);
      warnings.push_back(b);
    }
  }
  const auto& as = s.data().adapt_stats;
  const bool adaptive = s.scene().step_tol > 0 && as.steps > 0;
  if (adaptive && as.kept_at_min > 0) {
    char b[256];
    std::snprintf(b, sizeof b,
                  "%ld substeps of h/%d were kept above --step-tol or without converging: the run is less accurate "
                  "than asked; a smaller --timestep resolves it",
                  as.kept_at_min, 1 << mj::kMaxSubstepLevel);
    warnings.push_back(b);
  }
  if (rubbed && !diverged) warnings.push_back(friction_on_stretching_rods_warning(s.integrator()));
  // an equality constraint open at the end, judged as equilibrium judges one (outside probe CH: a weld
  // of solref 0.002 held a twisted rod's end 4.6 mm from where servos put it, 15% of the slack they
  // prescribed, without a word)
  if (!diverged && s.scene().m->neq > 0) {
    track_moved(scene_positions(s.scene(), s.data()));  // (the end state, sampled or not: an interrupted run)
    for (const std::string& o : mj::open_equalities(s.scene(), s.data(), moved_max))
      warnings.push_back(o + " at the end of the run: MuJoCo's constraints are soft (solref, solimp and the inertia of "
                             "what it joins), and the run moved with it open; " + kCloseIt);
  }
  if (diverged) warnings.insert(warnings.begin(), "diverged: " + s.data().warning);
  if (const std::string w = motion.warning(s.scene().m, energy); !w.empty() && !diverged) warnings.push_back(w);
  // bodies that start deep in each other (outside fuzzing: a 100 m leg through a floor went from
  // -1.8e4 J to 2.2e7 J in 0.02 s without a word)
  if (const mjModel* m = s.scene().m; deepest_geom1 >= 0 && start_depth > 1e-2 * m->stat.extent) {
    char b[512];
    std::snprintf(b, sizeof b,
                  "the run started with bodies '%s' and '%s' %.3g m into each other (%.3g of the scene's extent): "
                  "MuJoCo's soft contacts push them apart with energy the run's figures do not count",
                  body_name(m, m->geom_bodyid[deepest_geom1]).c_str(), body_name(m, m->geom_bodyid[deepest_geom2]).c_str(), start_depth, start_depth / m->stat.extent);
    warnings.push_back(b);
  }
  const std::vector<std::string> exchanges = energy_exchanges(s.scene(), touched, limited, actuated);
  // a closed scene whose energy grew: the integrator supplied it
  if (exchanges.empty() && !diverged && energy.max_rel_gain() > 0.1) {
    const Integrator in = s.integrator();
    const std::string remedy =
        in == Integrator::Trapezoidal || in == Integrator::GeneralizedAlpha
            ? "the trapezoidal rule and the generalized-alpha method are not energy-stable on nonlinear rods (Simo and "
              "Tarnow): --integrator midpoint keeps the energy"
        : in == Integrator::Midpoint ? "try a tighter --newton-tol"
        // (outside probe BK: a free rod spinning at 20 rad/s doubled its energy in 6 s at 1 ms, and with
        // --newton 10, fully implicit backward Euler, lost 12% instead, its precession 27% slow)
        : s.scene().newton_for(in) == 0 && in == Integrator::Implicit
            ? "the linearised step leaves gravity, Coriolis and gyroscopic forces explicit: --integrator midpoint keeps "
              "the energy, --newton 10 (fully implicit backward Euler) takes it away instead"
                                                                      : "try a smaller --timestep, or --integrator midpoint";
    char b[512];
    std::snprintf(b, sizeof b,
                  "the energy grew by %.3g J, %.3g times what the run started with, in a scene where nothing supplies "
                  "it (no damping, actuators, fluid, contacts or constraints): the integrator did (%s)",
                  energy.max_gain(), energy.max_rel_gain(), remedy.c_str());
    warnings.push_back(b);
  }
  // a closed scene that lost energy: the integrator's numerical damping took it (outside probe BL:
  // an undamped steel cantilever whose 79 Hz fundamental takes 13 steps of the default 1 ms, under
  // the default backward Euler, lost its vibration by a factor 4.4 a period, without a word)
  // (a loss above a millionth of the scene's weight times its size, the longest rod or MuJoCo's
  // mean body size, not the extent, which counts the distance from the origin: a steel rod hanging
  // at rest lost 4.7e-8 J of a barely moving axial vibration, a third of what it moved, outside
  // probe BO)
  const mjModel* mm = s.scene().m;
  double weight = 0.0, size = mm->stat.meansize;
  for (int b = 1; b < mm->nbody; ++b) weight += mm->body_mass[b];
  for (size_t r = 0; r < s.scene().rods.size(); ++r) {
    double rod_mass = 0.0;
    cosserat::center_of_mass(s.scene().rods[r].model, s.data().rod[r], &rod_mass);
    weight += rod_mass;
    size = std::max(size, s.scene().rods[r].decl.spec.length);
  }
  weight *= mju_norm3(mm->opt.gravity);
  if (exchanges.empty() && !diverged && energy.max_rel_loss() > 0.1 && energy.max_loss() > 1e-6 * weight * size) {
    const Integrator in = s.integrator();
    const std::string why =
        in == Integrator::Implicit ? "backward Euler damps what it does not resolve: a vibration of N steps a period keeps "
                                     "about exp(-4 pi^2 / N) of its energy a period"
        : in == Integrator::GeneralizedAlpha ? "the generalized-alpha method damps motions of few steps a period (--rho 1: none)"
                                             : "the integrator took it";
    char b[640];
    std::snprintf(b, sizeof b,
                  "the energy fell by %.3g J, %.3g of the energy the run moved between its forms, in a scene where nothing "
                  "takes it away (no damping, actuators, fluid, contacts or constraints): %s; --integrator midpoint keeps "
                  "the energy, a smaller --timestep loses less",
                  energy.max_loss(), energy.max_rel_loss(), why.c_str());
    warnings.push_back(b);
  }
  // a scene whose exchanges only take energy away (contacts, dampers) that gained more than it
  // started with (outside probe AT: a soft rod sliding on a floor under the trapezoidal rule went
  // from 1.4 J to 4.9e4 J and flew 20 m up, and an undamped one resting after a tilted drop from
  // 0.1 J to 20 J, with no word but the Newton splits). Not where the start puts bodies deeper
  // into each other than 1e-3 of the scene's size: what the contacts give back from there is energy
  // energy() does not count (the repro pile's rods start 0.25 m into the floor: 0.08 J to 0.66 J).
  const bool dissipative =
      !exchanges.empty() && start_depth <= 1e-3 * s.scene().m->stat.extent &&
      std::all_of(exchanges.begin(), exchanges.end(), [](const std::string& x) {
        return x == "contacts" || x == "rod damping" || x == "joint or tendon damping" || x == "friction loss" ||
               x == "limits" || x == "equality constraints";
      });
  // (a gain of the energy the run started with where contacts act, whose soft rows give back what a
  // start inside them stores; a tenth where only dampers, friction loss and limits act: outside
  // probe BW, a pendulum carrying a stiff rod gained 39% at a hinge limit without a word once
  // limits were listed here; equality constraints, soft springs and dampers on a fixed relation,
  // since the forty-ninth session: outside probes BY and BZ, a parallel robot of two rods welded to
  // a platform went from rest to 10.8 J, and a steel cable held at its far end by a stiff connect
  // gained 1700 J, both without a word)
  const bool touching = std::find(exchanges.begin(), exchanges.end(), "contacts") != exchanges.end();
  if (dissipative && !diverged && energy.max_rel_gain() > (touching ? 1.0 : 0.1) &&
      energy.max_gain() > 2.0 * start_row_energy) {
    const Integrator in = s.integrator();
    const bool newton_scheme = in == Integrator::Trapezoidal || in == Integrator::Midpoint || in == Integrator::GeneralizedAlpha;
    std::string list;
    for (const auto& x : exchanges) list += (list.empty() ? "" : ", ") + x;
    // (dropped contacts let bodies into each other, whose soft rows then push them out: outside
    // probe CC's long rod on a floor gained 0.4 J with full buffers and was told the integrator did)
    const int full = mj::full_buffer_count(s.data().d);
    const std::string why =
        full > 0 ? "MuJoCo's contact buffers were full " + std::to_string(full) +
                       " times: contacts were dropped, and bodies that sank in were pushed out; " +
                       mj::raise_buffers_advice(s.scene().m)
                 : std::string("the integrator supplied it (") +
                       (newton_scheme ? "try a smaller --timestep, or --integrator implicit" : "try a smaller --timestep") + ")";
    char b[768];
    std::snprintf(b, sizeof b,
                  "the energy grew by %.3g J, %.3g times what the run started with, though what exchanges energy here "
                  "(%s) only takes it away: %s",
                  energy.max_gain(), energy.max_rel_gain(), list.c_str(), why.c_str());
    warnings.push_back(b);
  }
  if (with_sensors)
    if (const std::string w = disabled_sensors_warning(s.scene().m); !w.empty()) warnings.push_back(w);
  if (csv_out && with_sensors) {  // a sensor's column named like another column (outside probe AO)
    std::map<std::string, int> count;  // (sorted: the warning lists the names in order)
    for (const auto& h : header) ++count[h];
    const size_t first_sensor_column = 2 + 3 * (out.sites.size() + out.bodies.size());
    std::set<std::string> repeated;
    for (size_t i = first_sensor_column; i < header.size(); ++i)
      if (count[header[i]] > 1) repeated.insert(header[i]);
    std::string list;
    for (const auto& r : repeated) list += (list.empty() ? "" : ", ") + r;
    if (!list.empty()) warnings.push_back("--sensors: the CSV has more than one column named " + list);
  }
  if (csv_out)  // the CSV header's contract is <name>.x,...: a site and a body of one name repeat it
    for (const auto& site : out.sites)
      for (const auto& body : out.bodies)
        if (site.name == body.name)
          warnings.push_back("a site and a body are both named '" + site.name + "': the CSV has two sets of columns " +
                             site.name + ".x,.y,.z, the site's first");
  if (!json_path.empty()) {
    json j;
    j["model"] = pos->front();
    j["integrator"] = integrator_name(s.integrator());
    j["timestep"] = s.timestep();
    j["steps"] = k;
    j["sim_time"] = s.time();       // the simulated time at the end (MuJoCo's d->time, the CSV's)
    j["start_time"] = start_time;   // at the start: a keyframe's time, else 0
    j["wall_time"] = wall;
    j["energy"] = {{"initial", energy.initial()}, {"final", energy.final()}, {"final_kinetic", energy.final_kinetic()},
                   {"max_rel_drift", energy.max_rel_drift()}, {"exchanged_by", exchanges}};
    add_positions(j, out, s.data());
    if (with_sensors) add_sensors(j, sensors, s.data().d);
    j["state"] = state_json(s.scene().m, s.data().d);  // (where it ended: --state continues from it)
    j["diverged"] = diverged;
    if (diverged) j["reason"] = s.data().warning;  // also the first warning
    // stopped by a signal or a CSV that could not be written: the report covers the run up to there
    j["interrupted"] = interrupted ? json(StopOnSignals::name(interrupted)) : csv_failed ? json("csv write failed") : json(nullptr);
    j["warnings"] = report_warnings(warnings);
    if (adaptive)
      j["adaptive"] = {{"step_tol", s.scene().step_tol}, {"substeps", as.substeps}, {"rejected", as.rejected},
                       {"kept_at_min", as.kept_at_min}, {"finest_step", s.timestep() / (1 << as.finest)}};
    if (s.scene().newton_for(s.integrator()) > 0) {
      const auto& ns = s.data().newton_stats;
      j["newton"] = {{"iterations", ns.iterations}, {"splits", ns.splits}, {"unconverged", ns.unconverged}, {"linearised", ns.linearised},
                     {"events", ns.events}};
    }
    write_json(json_path, j);
  }
  if (json_path != "-" && csv != "-") {  // stdout carries the JSON or the CSV alone
    std::string exchanged;  // the drift is the integrator's only in a closed scene
    for (const auto& e : exchanges) exchanged += (exchanged.empty() ? "; not conserved here: " : ", ") + e;
    // (the time simulated, and from where where a keyframe starts the clock: outside probe BV, a
    // key at t = 1 had a 0.5 s run read "simulated 1.5 s")
    const std::string from = start_time != 0.0 ? " (t = " + format_g(start_time) + " to " + format_g(s.time()) + " s)" : "";
    std::printf("simulated %.6g s%s in %ld steps (%s, h = %g s) in %.3f s wall; energy %.6g -> %.6g J (max drift %.2e%s), "
                "kinetic at the end %.3g J\n",
                s.time() - start_time, from.c_str(), k, integrator_name(s.integrator()), s.timestep(), wall, energy.initial(),
                energy.final(), energy.max_rel_drift(), exchanged.c_str(), energy.final_kinetic());
    if (s.scene().newton_for(s.integrator()) > 0) {
      const auto& ns = s.data().newton_stats;
      std::printf("newton: %.2f corrections per step, %ld steps split, %ld unconverged", k > 0 ? double(ns.iterations) / double(k) : 0.0,
                  ns.splits, ns.unconverged);
      // steps where a contact, limit or friction loss changed state (README, Known limitations)
      if (ns.events > 0) std::printf(", %ld contact events taken as backward Euler steps", ns.events);
      std::printf("\n");
    }
    if (adaptive)
      std::printf("adaptive: %.2f substeps per step (finest h/%d), %ld rejected, %ld kept at h/%d above the tolerance\n",
                  double(as.substeps) / double(as.steps), 1 << as.finest, as.rejected, as.kept_at_min,
                  1 << mj::kMaxSubstepLevel);
    print_positions(out, s.data());
    print_sensors(sensors, s.data().d);
    print_warnings(stdout, warnings, s.scene().load_warnings);
  } else {  // (outside probe AL: with --csv - the warnings had gone nowhere)
    print_warnings(stderr, warnings, s.scene().load_warnings);
  }
  if (!csv_failure.empty()) fail(csv_failure);
  if (interrupted) {
    std::fprintf(stderr, "run: interrupted by %s at t = %s s after %ld of %ld steps; the outputs cover the run up to there\n",
                 StopOnSignals::name(interrupted), format_g(s.time()).c_str(), k, s.steps());
    return 128 + interrupted;
  }
  if (diverged) fail("simulation diverged: " + s.data().warning + " (" + divergence_hint(s) + ")");
  return 0;
}

// Loads a model and solves its static equilibrium; shared by `equilibrium` and `linearize`.
// What closes an equality constraint left open under load (outside probe BU: solref="0.002 1" had
// been suggested where it was already set, and heavier bodies for strain joints, which have none).
struct Equilibrium {
  std::unique_ptr<mj::Scene> scene;
  std::unique_ptr<mj::SceneData> data;
  mj::SceneStaticsResult result;
  std::vector<mjtNum> start_xpos;  // bodies' and sites' positions at the start (displacement())

  // stable = false: any equilibrium, stable or not (SceneStaticsOptions::stable); search = false:
  // no search, the start state as it is (its residual force measured: linearize --at-start)
  Equilibrium(const std::string& path, const StateOptions& state, double relaxation_time = 30.0, bool stable = true,
              bool search = true)
      : scene(load(path)), data(std::make_unique<mj::SceneData>(*scene)) {
    state.apply(*scene, *data);
    start_xpos = positions();
    if (!search) {
      Eigen::VectorXd f;
      mju_zero(data->d->qvel, scene->m->nv);
      const double scale = mj::static_force(*scene, *data, 1.0, f);
      result.converged = true;
      result.method = "none (the start state)";
      result.residual = scale > 0 ? f.norm() / scale : f.norm();
      mj::forward(*scene, *data);
      return;
    }
    Progress progress("equilibrium", 1);
    mj::SceneStaticsOptions opt;
    opt.relaxation_time = relaxation_time;
    opt.stable = stable;
    opt.progress = [&progress](const std::string& where) { progress.note(where); };
    try {
      result = mj::equilibrium(*scene, *data, opt);
    } catch (const MujocoError& e) {
      throw error_while(path, e, "computing the static equilibrium");
    }
  }
  std::vector<mjtNum> positions() const { return scene_positions(*scene, *data); }
  // per body, the largest displacement of it and its sites from the start (after forward at the
  // result)
  std::vector<double> displacement() const { return displacement_from(scene->m, start_xpos, positions()); }
  json report() const {
    json j = {{"converged", result.converged}, {"iterations", result.iterations}, {"residual", result.residual},
              {"method", result.method},       {"load_steps", result.load_steps}, {"message", result.message}};
    if (result.method == "newton" && result.converged) j["omega2_min"] = result.omega2_min;
    // (as linearize's: outside probe BW, equilibrium named the flutter in its message only)
    if (result.flutter_rate > 0) j["flutter"] = {{"growth_rate", result.flutter_rate}, {"frequency_hz", result.flutter_hz}};
    return j;
  }
  void print() const {
    const bool plain = result.message.empty() || result.message == "converged";
    std::printf("equilibrium: %s by %s after %d iterations (residual %.2e)%s%s\n",
                result.converged ? "converged" : "NOT converged", result.method.c_str(), result.iterations, result.residual,
                plain ? "" : ": ", plain ? "" : result.message.c_str());
  }
};

int cmd_equilibrium(int argc, char** argv) {
  std::string json_path;
  StateOptions state;
  CommandLine cl{"equilibrium", "static equilibrium under gravity, actuator controls and applied loads", {"MODEL.xml"}, {},
                 "Newton's method with load continuation along the stable branch (a load step whose\n"
                 "equilibrium is unstable is refused and split; \"omega2_min\" in the report is the smallest\n"
                 "eigenvalue of K x = omega^2 M x there); scenes whose contacts, limits or equality constraints\n"
                 "carry load, or where the stable branch cannot be followed, are settled by dynamic relaxation\n"
                 "(the report's \"method\"); past a buckling load the relaxation starts from the unstable\n"
                 "equilibrium moved along its unstable mode, and settles on the buckled shape. Where constraint\n"
                 "rows carry load, stability is judged with them held rigid (contacts as pins).\n"
                 "Exit status 1 when no equilibrium is found.\n"};
  cl.options.push_back(text_option("--json", "F", "write {converged, iterations, residual, sites, bodies, ...} ('-': stdout)", json_path));
  double relaxation_time = 30.0;
  cl.options.push_back(positive_option("--relaxation-time", "T",
                                       "simulated time [s] the dynamic relaxation may take before it gives up (default 30)",
                                       relaxation_time));
  bool with_sensors = false;
  cl.options.push_back(flag_option("--sensors",
                                   "also report the model's sensors (MuJoCo's sensordata, rod sites included) at the "
                                   "result, at rest: \"sensors\": {NAME: [values]} in the JSON and the summary",
                                   with_sensors));
  state.add_to(cl);
  const auto pos = cl.parse(argc, argv);
  if (!pos) return 0;
  check_writable("--json", json_path);
  const Equilibrium eq(pos->front(), state, relaxation_time);
  const Outputs out = named_outputs(*eq.scene);
  std::vector<SensorOutput> sensors;
  if (with_sensors) {
    sensors = sensor_outputs(eq.scene->m);
    if (const std::string w = disabled_sensors_warning(eq.scene->m); !w.empty()) std::fprintf(stderr, "warning: %s\n", w.c_str());
  }
  // a forward evaluation at the result (at rest, positions unchanged) computes the sensors and the
  // constraints' violations
  if (with_sensors || eq.result.converged) {
    mjData* d = eq.data->d;
    const std::vector<mjtNum> q(d->qpos, d->qpos + eq.scene->m->nq);
    try {
      mj::forward(*eq.scene, *eq.data);
    } catch (const MujocoError& e) {
      throw error_while(pos->front(), e, "evaluating the sensors and constraints at the equilibrium");
    }
    std::copy(q.begin(), q.end(), d->qpos);
  }
  // an equality constraint MuJoCo's soft rows let open under the load it carries: the equilibrium is
  // that of the soft constraint (outside probe AS: a rod twisted between two welds of E = 1e11 Pa
  // opened its weld by 0.37 rad, and held less twist than the scene asked)
  std::vector<std::string> warnings;
  if (eq.result.buffers_full)
    warnings.push_back("MuJoCo's contact buffers are full at the equilibrium: it is the one without the contacts beyond "
                       "them; " + mj::raise_buffers_advice(eq.scene->m));
  if (eq.result.converged)
    for (const std::string& o : mj::open_equalities(*eq.scene, *eq.data, eq.displacement()))
      warnings.push_back(o + " at the equilibrium: MuJoCo's constraints are soft (solref, solimp and the inertia of "
                             "what it joins), and this is the equilibrium with it open; " + kCloseIt);
  for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  if (!json_path.empty()) {
    json j = eq.report();
    j["warnings"] = report_warnings(warnings);
    add_positions(j, out, *eq.data);
    if (with_sensors) add_sensors(j, sensors, eq.data->d);
    // (at rest where it converged; where not, the positions reported: --state starts from either)
    j["state"] = state_json(eq.scene->m, eq.data->d);
    write_json(json_path, j);
  }
  if (json_path != "-") {
    eq.print();
    print_positions(out, *eq.data);
    print_sensors(sensors, eq.data->d);
  }
  if (!eq.result.converged)
    fail((eq.result.omega2_min < 0 || eq.result.flutter_rate > 0 ? "no stable equilibrium: " : "no static equilibrium: ") + eq.result.message);
  return 0;
}

json matrix_json(const Eigen::MatrixXd& A) {
  json rows = json::array();
  for (int i = 0; i < A.rows(); ++i) {
    json r = json::array();
    for (int k = 0; k < A.cols(); ++k) r.push_back(A(i, k));
    rows.push_back(r);
  }
  return rows;
}

int cmd_linearize(int argc, char** argv) {
  std::string json_path;
  bool matrices = false;
  StateOptions state;
  CommandLine cl{"linearize", "linearise at the static equilibrium: natural frequencies and modal damping", {"MODEL.xml"}, {},
                 "Second-order form M ddq + D dq' + K dq = Bu du about the equilibrium (tangent space of qpos).\n"
                 "Equality constraints (weld, connect, joint, tendon) are held rigid: the form is then in the\n"
                 "coordinates y of the motions they leave free, dq = basis y, and K includes the stiffness of\n"
                 "the loads they carry. Contacts and limits are left out (a warning says when they carry load).\n"};
  cl.options.push_back(text_option("--json", "F", "write {frequencies_hz: [ascending; undamped, sqrt(omega2) / 2 pi: a mode of damping ratio z rings at sqrt(1 - z^2) of it], damping_ratios, omega2, unstable_modes, nv, coordinates, equality_rows, equilibrium, warnings, ...} ('-': stdout)", json_path));
  cl.options.push_back(flag_option("--matrices", "include M, D, K and Bu in the JSON (and the basis of the coordinates), and the state-space A and B of x = [dq; dq'] (with actuators that have activation dynamics, filters, integrators, muscles: x = [dq; dq'; dact], and \"activations\": Fa, Bd, Ga, Gu of M ddq + D dq' + K dq = Fa dact + Bd du, dact' = Ga dact + Gu du; M, D, K and Bu keep the activations at their steady state, Bu the static gain)", matrices));
  mj::SceneLinearizeOptions lopt;
  bool without_equalities = false;
  double relaxation_time = 30.0;
  cl.options.push_back(positive_option("--relaxation-time", "T",
                                       "simulated time [s] the equilibrium's dynamic relaxation may take (default 30)",
                                       relaxation_time));
  int modes = 0;
  cl.options.push_back(int_option("--modes", "N",
                                  "add the first N mode shapes to the JSON: dq, and the displacements of every rod's "
                                  "centreline (17 points), named site and body, scaled to a largest displacement of 1",
                                  modes, 0));
  cl.options.push_back(flag_option("--without-equalities",
                                   "leave the equality constraints out (default: held rigid, a weld a clamped end)",
                                   without_equalities));
  bool contacts_as_pins = false;
  cl.options.push_back(flag_option("--contacts-as-pins",
                                   "hold every contact rigid as a pin (with its friction), and the limits that act: the "
                                   "frequencies of a rod resting on its supports (default: contacts and limits left out)",
                                   contacts_as_pins));
  bool at_start = false;
  cl.options.push_back(flag_option(
      "--at-start",
      "linearise at the start state (the model's, or --key's) at rest, without searching for an equilibrium: an "
      "unstable one (an inverted pendulum, a column past buckling) for a controller's model; warned where the start "
      "is not an equilibrium (A is then the dynamics' Jacobian there at rest, the mass matrix's turning times the "
      "unbalanced forces' acceleration included, except with equality constraints held rigid)",
      at_start));
  state.add_to(cl);
  const auto pos = cl.parse(argc, argv);
  if (!pos) return 0;
  check_writable("--json", json_path);
  if (modes > 0 && json_path.empty()) fail("--modes: the mode shapes go into the JSON: give --json F too");
  lopt.rigid_equalities = !without_equalities;
  lopt.rigid_contacts = contacts_as_pins;
  if (contacts_as_pins && without_equalities)
    fail("--contacts-as-pins holds the equality constraints rigid too: it cannot go with --without-equalities");
  std::unique_ptr<Equilibrium> found = std::make_unique<Equilibrium>(pos->front(), state, relaxation_time, true, !at_start);
  // no stable equilibrium, where the search found unstable ones (a column past its flutter load):
  // linearised at an equilibrium found without the stability test, whose instability the modes
  // then show (outside probe BT: Beck's column past its flutter load read "no static equilibrium")
  std::string unstable_note;
  if (!found->result.converged && (found->result.omega2_min < 0 || found->result.flutter_rate > 0)) {
    auto any = std::make_unique<Equilibrium>(pos->front(), state, relaxation_time, false);
    if (any->result.converged) {
      unstable_note = "no stable equilibrium: linearised at an unstable one, found without the stability test";
      found = std::move(any);
    }
  }
  const Equilibrium& eq = *found;
  if (!eq.result.converged) fail("no static equilibrium to linearise about: " + eq.result.message);
  const mj::SceneLinearization lin = [&] {
    Progress progress("linearize", 1);  // (cleared before the output)
    mj::SceneLinearizeOptions with_progress = lopt;
    with_progress.progress = [&progress](const std::string& where) { progress.note(where); };
    try {
      return mj::linearize(*eq.scene, *eq.data, with_progress);
    } catch (const MujocoError& e) {
      throw error_while(pos->front(), e, "linearising at the equilibrium");
    } catch (const std::runtime_error& e) {
      fail(pos->front() + ": " + e.what());
    }
  }();
  const mjModel* m = eq.scene->m;
  // --at-start: how far the start is from an equilibrium, as the largest move of a body or site
  // under one Newton step from it (Kt dq = f, in the coordinates the linearisation holds free):
  // the residual force alone would flag a stiff rod's axial strain of 1e-12 under its weight
  std::string not_at_rest;
  if (at_start && lin.M.rows() > 0) {
    mjData* d = eq.data->d;
    const std::vector<mjtNum> q0(d->qpos, d->qpos + m->nq);
    Eigen::VectorXd f;
    const double scale = mj::static_force(*eq.scene, *eq.data, 1.0, f);
    const Eigen::VectorXd fy = lin.basis.size() ? Eigen::VectorXd(lin.basis.transpose() * f) : f;
    const Eigen::VectorXd dy = lin.Kt.completeOrthogonalDecomposition().solve(fy);
    // the force no stiffness balances (a torque on a free hinge: the step above moves nothing
    // there, re-check probe CG), relative to the forces' scale
    const double unbalanced = (fy - lin.Kt * dy).norm() / (scale > 0 ? scale : 1.0);
    const Eigen::VectorXd dq = lin.basis.size() ? Eigen::VectorXd(lin.basis * dy) : dy;
    const std::vector<mjtNum> x0 = eq.positions();
    mj_integratePos(m, d->qpos, dq.data(), 1.0);
    const std::vector<mjtNum> x1 = eq.positions();
    std::copy(q0.begin(), q0.end(), d->qpos);
    mju_zero(d->qvel, m->nv);
    mj::forward(*eq.scene, *eq.data);
    // activations that keep changing (an integrator under a control): not at rest either
    double act_rate = 0.0;
    for (int k = 0; k < m->na; ++k)
      if (m->actuator_dyntype[m->nu - m->na + k] == mjDYN_INTEGRATOR) act_rate = std::max(act_rate, std::abs(d->act_dot[k]));
    double move = 0.0;
    for (size_t i = 0; i + 2 < x0.size(); i += 3)
      move = std::max(move, std::hypot(x1[i] - x0[i], x1[i + 1] - x0[i + 1], x1[i + 2] - x0[i + 2]));
    if (!(move <= 1e-6 * std::max(m->stat.extent, 1e-3)) || !(unbalanced <= 1e-6) || act_rate > 0) {
      char buf[900];
      std::snprintf(buf, sizeof buf,
                    "the start state is not an equilibrium (the equilibrium nearest it, by one Newton step, moves a "
                    "body or site %.3g m; residual force %.3g of the forces' scale, %.3g along motions without "
                    "stiffness%s): %s",
                    move, found->result.residual, unbalanced,
                    act_rate > 0 ? "; an integrator actuator's activation changes under its control" : "",
                    lin.constraint_rows > 0
                        ? "with equality constraints held rigid the linearisation holds the forces' derivatives there, "
                          "at rest, but not the term of the constrained motion the unbalanced forces drive: A is exact "
                          "only at an equilibrium"
                        : "A is the dynamics' Jacobian there, at rest (the mass matrix's turning with the motion the "
                          "unbalanced forces drive included), and the modes and frequencies are the stiffness's, of no "
                          "motion about a rest");
      not_at_rest = buf;
    }
  }
  // equality constraints are held rigid (unless --without-equalities); the constraints that are
  // left out and carry load at the equilibrium (a floor, a limit) make the frequencies those of
  // the system without them
  std::string constraint_warning, constraint_note;
  const int left_out = eq.result.constraint_rows - lin.constraint_rows;
  if (left_out > 0)
    constraint_warning = std::to_string(left_out) + " constraint rows (" +
                         (lin.constraint_rows > 0 || !without_equalities ? "contacts, limits"
                                                                         : "contacts, limits, equality constraints") +
                         ") act at the equilibrium (found by " + eq.result.method +
                         "); the linearisation leaves them out: these are the frequencies without them";
  if (lin.constraint_rows > 0)
    constraint_note = std::to_string(lin.constraint_rows) +
                      (contacts_as_pins ? " constraint rows (equalities, contacts as pins, limits) held rigid: "
                                        : " equality constraint rows held rigid: ") +
                      std::to_string(lin.M.rows()) + " coordinates of the " + std::to_string(m->nv) +
                      " degrees of freedom remain free";
  // a rigid hold of a constraint MuJoCo's soft rows left open (outside probe AH: a weld open by 0.1
  // under load gave a first frequency 35% off the closed weld's)
  std::vector<std::string> open_warnings;
  if (lin.constraint_rows > 0)
    for (const std::string& o : mj::open_equalities(*eq.scene, *eq.data, eq.displacement()))
      open_warnings.push_back(o + " at the equilibrium (MuJoCo's constraints are soft: solref, solimp and the inertia "
                                  "of what it joins); the linearisation holds it rigid there, open: " + kCloseIt);
  // the modes with omega^2 < 0 (listed first), and a growing oscillation where the loads turn with
  // the structure (outside probe BR: a follower-loaded rod's flutter had been read stable)
  const int divergent = lin.diverging_modes;
  char flutter_buf[400] = "";
  if (lin.flutter_rate > 0)
    std::snprintf(flutter_buf, sizeof flutter_buf,
                  "flutter: an oscillation of %.4g Hz grows at %.4g 1/s (e-folding time %.4g s): non-conservative "
                  "loads (follower loads that turn with the structure, site actuators without a refsite, end moments "
                  "of fixed direction in 3-D) feed it faster than the damping takes it; the equilibrium is unstable",
                  lin.flutter_hz, lin.flutter_rate, 1.0 / lin.flutter_rate);
  std::string flutter_text = flutter_buf;
  // without any damping every discretised mode can flutter, and the fastest growth is that of the
  // highest modes the sections resolve (outside probe CD: a rod under a fixed-direction end moment
  // read 0.78, 1.40, 2.06 1/s at 8, 16, 32 sections against 0.08 1/s for its resolved modes,
  // which a light viscosity shows to 1e-3)
  if (lin.flutter_rate > 0 && !not_at_rest.empty()) {
    // (re-check probe CG: a free rod falling under gravity was told of non-conservative loads)
    std::snprintf(flutter_buf, sizeof flutter_buf,
                  "an oscillation of %.4g Hz grows at %.4g 1/s in the linearisation, which is at a start that is not "
                  "an equilibrium (above): its growth may be no property of the scene",
                  lin.flutter_hz, lin.flutter_rate);
    flutter_text = flutter_buf;
  } else if (lin.flutter_rate > 0 && left_out > 0) {
    // (re-check CK: a hub and rod lying on a floor, the contacts left out, read flutter "fed by
    // non-conservative loads" where there are none: the smooth forces it keeps are out of balance
    // there, their stiffness unsymmetric; with the contacts held as pins it reads none)
    std::snprintf(flutter_buf, sizeof flutter_buf,
                  "an oscillation of %.4g Hz grows at %.4g 1/s in the linearisation, which leaves out %d constraint "
                  "rows that carry load here: the forces it keeps are out of balance, and the growth may be no "
                  "property of the scene (--contacts-as-pins holds them)",
                  lin.flutter_hz, lin.flutter_rate, left_out);
    flutter_text = flutter_buf;
  } else if (lin.flutter_rate > 0 && lin.D.size() > 0 && lin.D.cwiseAbs().maxCoeff() == 0.0)
    flutter_text += " (undamped: this growth may be that of the highest modes the sections resolve, which grows with "
                    "them; a light `viscosity` on the rods leaves the resolved modes' growth)";
  if (!json_path.empty()) {
    json j;
    j["frequencies_hz"] = std::vector<double>(lin.frequencies_hz.data(), lin.frequencies_hz.data() + lin.frequencies_hz.size());
    json zeta = json::array();
    for (int i = 0; i < lin.damping_ratios.size(); ++i)  // NaN (rigid-body modes) becomes null
      zeta.push_back(std::isfinite(lin.damping_ratios(i)) ? json(lin.damping_ratios(i)) : json(nullptr));
    j["damping_ratios"] = zeta;
    j["omega2"] = std::vector<double>(lin.omega2.data(), lin.omega2.data() + lin.omega2.size());
    j["unstable_modes"] = lin.unstable_modes;
    j["nv"] = m->nv;
    j["coordinates"] = lin.M.rows();  // nv less the equality constraints' rows held rigid
    j["equality_rows"] = lin.constraint_rows;
    j["nu"] = m->nu;
    j["equilibrium"] = eq.report();
    json warnings = json::array();
    if (!not_at_rest.empty()) warnings.push_back(not_at_rest);
    if (!constraint_warning.empty()) warnings.push_back(constraint_warning);
    for (const auto& w : open_warnings) warnings.push_back(w);
    if (!unstable_note.empty()) warnings.push_back(unstable_note);
    if (divergent > 0)
      warnings.push_back(std::to_string(divergent) + " unstable mode(s) (omega2 < 0): the equilibrium is unstable");
    if (lin.flutter_rate > 0) {
      warnings.push_back(flutter_text);
      j["flutter"] = {{"growth_rate", lin.flutter_rate}, {"frequency_hz", lin.flutter_hz}};
    }
    j["warnings"] = report_warnings(warnings);
    if (modes > 0) {
      const Outputs named = named_outputs(*eq.scene);
      json list = json::array();
      for (int k = 0; k < std::min<int>(modes, static_cast<int>(lin.omega2.size())); ++k) {
        const mj::ModeShape shape = mj::mode_shape(*eq.scene, *eq.data, lin, k);
        json mode = {{"mode", k + 1}, {"frequency_hz", shape.frequency_hz}, {"omega2", shape.omega2},
                     {"dq", std::vector<double>(shape.dq.data(), shape.dq.data() + shape.dq.size())}};
        if (k < lin.damping_ratios.size() && std::isfinite(lin.damping_ratios(k))) mode["damping_ratio"] = lin.damping_ratios(k);
        mode["rods"] = json::object();
        for (size_t r = 0; r < eq.scene->rods.size(); ++r) {
          json points = json::array();
          for (const Vec3& v : shape.rods[r]) points.push_back(vec_json(v));
          mode["rods"][eq.scene->rods[r].decl.name] = points;
        }
        mode["sites"] = json::object();
        for (const auto& n : named.sites) mode["sites"][n.name] = vec_json(shape.sites[n.id]);
        mode["bodies"] = json::object();
        for (const auto& n : named.bodies) mode["bodies"][n.name] = vec_json(shape.bodies[n.id]);
        list.push_back(mode);
      }
      j["modes"] = list;
    }
    if (matrices) {
      j["M"] = matrix_json(lin.M);
      j["D"] = matrix_json(lin.D);
      j["K"] = matrix_json(lin.Kt);
      j["Bu"] = matrix_json(lin.Bu);
      if (lin.Fa.cols() > 0) {  // actuator activations as states (x = [dq; dv; dact])
        j["activations"] = {{"Fa", matrix_json(lin.Fa)}, {"Bd", matrix_json(lin.Bd)}, {"Ga", matrix_json(lin.Ga)},
                            {"Gu", matrix_json(lin.Gu)}};
        if (lin.Gq.size()) j["activations"]["Gq"] = matrix_json(lin.Gq), j["activations"]["Gv"] = matrix_json(lin.Gv);
      }
      j["A"] = matrix_json(lin.A);
      j["B"] = matrix_json(lin.B);
      if (lin.constraint_rows > 0) j["basis"] = matrix_json(lin.basis);  // dq = basis y
    }
    write_json(json_path, j);
  }
  if (json_path != "-") {
    eq.print();
    if (!constraint_note.empty()) std::printf("%s\n", constraint_note.c_str());
    if (!constraint_warning.empty()) std::printf("warning: %s\n", constraint_warning.c_str());
    if (!not_at_rest.empty()) std::printf("warning: %s\n", not_at_rest.c_str());
    for (const auto& w : open_warnings) std::printf("warning: %s\n", w.c_str());
    if (!unstable_note.empty()) std::printf("warning: %s\n", unstable_note.c_str());
    if (divergent > 0)
      std::printf("warning: %d unstable mode(s) (omega^2 < 0, listed first): the equilibrium is unstable\n", divergent);
    if (lin.flutter_rate > 0) std::printf("warning: %s\n", flutter_text.c_str());
    std::printf("natural frequencies [Hz], undamped (damping ratio):\n");
    for (int i = 0; i < lin.frequencies_hz.size(); ++i) {
      // the modes are in ascending omega^2: the unstable ones come first, growing as exp(t / tau)
      if (i < divergent && lin.omega2(i) < 0) {
        std::printf("  %3d  unstable: omega^2 = %.6g 1/s^2, e-folding time %.4g s\n", i + 1, lin.omega2(i),
                    1.0 / std::sqrt(-lin.omega2(i)));
        continue;
      }
      std::printf("  %3d  %12.6g", i + 1, lin.frequencies_hz(i));
      if (i < lin.damping_ratios.size())
        std::isfinite(lin.damping_ratios(i)) ? std::printf("  (%.4g)", lin.damping_ratios(i))
                                             : std::printf("  (neutral mode)");
      std::printf("\n");
    }
  }
  return 0;
}

// Position samples of one simulation at requested times, linearly interpolated between steps.
class Sampler {
 public:
  // (the comma expression keeps the sink set while the model loads: a temporary lives to the end
  // of its member initializer)
  Sampler(const std::string& path, const SimOptions& o, const StateOptions& state)
      : sim((WarningSink(messages), path), o, state) {
    WarningSink sink(messages);
    sim.observe();
    t0_ = prev_t_ = cur_t_ = sim.time();
    prev_ = cur_ = positions();
  }
  std::vector<std::string> messages;  // MuJoCo's warnings raised by this simulation
  Simulation sim;
  bool diverged = false;

  // Positions (sites then bodies, as in outputs()) at time t after the start (a keyframe may start
  // the simulation at another time than 0), t >= the previous request.
  std::vector<Vec3> at(double t_since_start) {
    const double t = t0_ + t_since_start;
    const double tol = 1e-9 * sim.timestep();
    WarningSink sink(messages);
    while (!diverged && cur_t_ < t - tol) {
      if (!sim.step() || !sim.observe()) {
        diverged = true;
        break;
      }
      prev_ = cur_;
      prev_t_ = cur_t_;
      cur_ = positions();
      cur_t_ = sim.time();
    }
    if (diverged || cur_t_ - prev_t_ <= tol) return cur_;
    const double w = std::clamp((t - prev_t_) / (cur_t_ - prev_t_), 0.0, 1.0);
    std::vector<Vec3> p(cur_.size());
    for (size_t i = 0; i < p.size(); ++i) p[i] = (1 - w) * prev_[i] + w * cur_[i];
    return p;
  }

 private:
  std::vector<Vec3> positions() {
    std::vector<Vec3> p;
    for (const auto& n : sim.outputs().sites) p.push_back(site_position(sim.data(), n.id));
    for (const auto& n : sim.outputs().bodies) p.push_back(body_position(sim.data(), n.id));
    return p;
  }
  double t0_ = 0, prev_t_ = 0, cur_t_ = 0;
  std::vector<Vec3> prev_, cur_;
};

// Bodies of a model with a free joint (swimmers): their index among outputs().bodies.
std::vector<int> free_bodies(const Simulation& s) {
  std::vector<int> idx;
  const mjModel* m = s.scene().m;
  const auto& bodies = s.outputs().bodies;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const int b = bodies[i].id;
    if (m->body_jntnum[b] > 0 && m->jnt_type[m->body_jntadr[b]] == mjJNT_FREE) idx.push_back(static_cast<int>(i));
  }
  return idx;
}

int cmd_compare(int argc, char** argv) {
  SimOptions sim;
  StateOptions state;
  std::string json_path;
  CommandLine cl{"compare", "simulate two models side by side and compare their same-named sites and bodies",
                 {"A.xml", "B.xml"}, {}, ""};
  sim.add_to(cl);
  state.add_to(cl);
  cl.options.push_back(text_option("--json", "F", "write {sites, bodies: {name: {max, rms}}, swimming_speed, ...} ('-': stdout)", json_path));
  cl.details =
      "Positions are sampled about every max(h_A, h_B), in equal parts of the duration (JSON\n"
      "sample_interval; linear interpolation between steps: a model whose step does not divide the\n"
      "duration is simulated one step past it); deviations are\n"
      "|p_A - p_B|. The swimming speed of a free body is |mean velocity of its position| over the\n"
      "second half of the run. Both models step with one integrator: --integrator, else implicit when\n"
      "either has rods (euler when neither has). Exit status 1 when either simulation diverges; the\n"
      "deviations are then those of the samples both reached (JSON: samples, compared_until,\n"
      "diverged_models: \"A\", \"B\" or both).\n";
  const auto pos = cl.parse(argc, argv);
  if (!pos) return 0;
  check_writable("--json", json_path);
  // a keyframe or controls that one of the two models cannot take: say which
  auto sampler = [&](int k) {
    try {
      return std::make_unique<Sampler>((*pos)[k], sim, state);
    } catch (const Failure& f) {
      fail(std::string(k == 0 ? "A" : "B") + " (" + (*pos)[k] + "): " + f.what());
    }
  };
  std::unique_ptr<Sampler> sampler_a = sampler(0), sampler_b = sampler(1);
  // one integrator for both: without --integrator, the default of the model with rods (implicit)
  // when only one has them (each model's own default would make a motor spin up one step apart,
  // a phase offset that outlasts the run)
  if (!sim.integrator && sampler_a->sim.integrator() != sampler_b->sim.integrator()) {
    sim.integrator = Integrator::Implicit;
    sampler_a = sampler(0), sampler_b = sampler(1);
  }
  Sampler &a = *sampler_a, &b = *sampler_b;

  // name pairs: index in A's and B's output lists, sites then bodies
  struct Pair {
    std::string name;
    bool site;
    int ia, ib;
    double max = 0, sum2 = 0;
  };
  std::vector<Pair> pairs;
  std::vector<std::string> unmatched;
  auto match = [&](const std::vector<Named>& na, const std::vector<Named>& nb, int offa, int offb, bool site) {
    for (size_t i = 0; i < na.size(); ++i) {
      const auto j = std::find_if(nb.begin(), nb.end(), [&](const Named& n) { return n.name == na[i].name; });
      if (j == nb.end()) unmatched.push_back(na[i].name);
      else pairs.push_back({na[i].name, site, offa + static_cast<int>(i), offb + static_cast<int>(j - nb.begin())});
    }
    for (const auto& n : nb)
      if (std::none_of(na.begin(), na.end(), [&](const Named& x) { return x.name == n.name; })) unmatched.push_back(n.name);
  };
  const Outputs &oa = a.sim.outputs(), &ob = b.sim.outputs();
  match(oa.sites, ob.sites, 0, 0, true);
  match(oa.bodies, ob.bodies, static_cast<int>(oa.sites.size()), static_cast<int>(ob.sites.size()), false);

  const double dt = std::max(a.sim.timestep(), b.sim.timestep());
  const long n = step_count(sim.duration, dt, "--duration");
  const long half = n / 2;
  const std::vector<int> fa = free_bodies(a.sim), fb = free_bodies(b.sim);
  std::vector<std::string> warnings;
  const mj::Scene &sa = a.sim.scene(), &sb = b.sim.scene();
  if (a.sim.integrator() == Integrator::Implicit && sa.newton_for(Integrator::Implicit) == 0 &&
      mj::implicit_is_mujocos(sa) != mj::implicit_is_mujocos(sb)) {
    const char* ours = mj::implicit_is_mujocos(sa) ? "B" : "A";
    const char* theirs = mj::implicit_is_mujocos(sa) ? "A" : "B";
    warnings.push_back(std::string("'implicit' steps the two models by two methods: ") + ours +
                       " (rods or the fluid) by the linearised backward Euler of the rods (stiffness implicit, Coriolis "
                       "explicit), " + theirs + " by MuJoCo's own implicit (Coriolis implicit, springs explicit); the "
                       "deviations include their difference, first order in the step: compare with --integrator euler, "
                       "rk4 or a second-order scheme");
  }
  if (pairs.empty()) {
    const std::string none = (*pos)[0] + " and " + (*pos)[1] + " share no named site or body";
    if (fa.empty() && fb.empty()) fail(none + " and have no free body to give a swimming speed: nothing to compare");
    warnings.push_back(none + ": only the free bodies' swimming speeds are compared");
  }
  std::vector<Vec3> half_a, half_b, pa, pb;
  Progress progress("compare", n);
  long samples = 0;  // compared: up to the last time both simulations reached
  double until = 0.0;
  for (long k = 0; k <= n; ++k) {
    const double t = k * sim.duration / n;
    pa = a.at(t);
    pb = b.at(t);
    if (a.diverged || b.diverged) break;
    ++samples;
    until = t;
    for (auto& p : pairs) {
      const double d = (pa[p.ia] - pb[p.ib]).norm();
      p.max = std::max(p.max, d);
      p.sum2 += d * d;
    }
    if (k == half) half_a = pa, half_b = pb;
    progress.update(k, t);
  }
  const bool diverged = a.diverged || b.diverged;
  // both can diverge by one sample: name both (the message had named A alone)
  const char* which = a.diverged && b.diverged ? "A and B" : a.diverged ? "A" : "B";
  const double span = sim.duration * (n - half) / n;
  auto speeds = [&](const Sampler& s, const std::vector<int>& fr, const std::vector<Vec3>& p0, const std::vector<Vec3>& p1) {
    json j = json::object();
    const int off = static_cast<int>(s.sim.outputs().sites.size());
    for (int i : fr)
      j[s.sim.outputs().bodies[i].name] = diverged ? json(nullptr) : json((p1[off + i] - p0[off + i]).norm() / span);
    return j;
  };
  json j;
  j["models"] = {(*pos)[0], (*pos)[1]};
  j["duration"] = sim.duration;
  j["integrator"] = integrator_name(a.sim.integrator());
  j["timestep"] = {a.sim.timestep(), b.sim.timestep()};
  j["samples"] = samples;
  j["sample_interval"] = sim.duration / n;
  if (diverged) {
    j["compared_until"] = until;
    j["diverged_models"] = json::array();
    if (a.diverged) j["diverged_models"].push_back("A");
    if (b.diverged) j["diverged_models"].push_back("B");
  }
  j["sites"] = json::object();
  j["bodies"] = json::object();
  for (const auto& p : pairs) j[p.site ? "sites" : "bodies"][p.name] = {{"max", p.max}, {"rms", std::sqrt(p.sum2 / samples)}};
  j["swimming_speed"] = {{"a", speeds(a, fa, half_a, pa)}, {"b", speeds(b, fb, half_b, pb)}};
  j["unmatched"] = unmatched;
  j["diverged"] = diverged;
  for (const auto& w : collect_warnings(a.sim.scene(), a.sim.data(), a.messages)) warnings.push_back("A: " + w);
  for (const auto& w : collect_warnings(b.sim.scene(), b.sim.data(), b.messages)) warnings.push_back("B: " + w);
  j["warnings"] = warnings;
  if (!json_path.empty()) write_json(json_path, j);
  if (json_path != "-") {
    std::printf("integrator: %s (both models), time steps %g s (A) and %g s (B)\n", integrator_name(a.sim.integrator()),
                a.sim.timestep(), b.sim.timestep());
    if (diverged)
      std::printf("compared up to t = %g s (%ld of %ld samples), where %s diverged\n", until, samples, n + 1, which);
    std::printf("%-8s %-28s %14s %14s\n", "kind", "name", "max dev [m]", "rms dev [m]");
    for (const auto& p : pairs)
      std::printf("%-8s %-28s %14.6g %14.6g\n", p.site ? "site" : "body", p.name.c_str(), p.max, std::sqrt(p.sum2 / samples));
    for (const char* k : {"a", "b"})
      for (const auto& [name, v] : j["swimming_speed"][k].items())
        std::printf("swimming speed (%s) %s: %s m/s\n", k, name.c_str(), v.dump().c_str());
  }
  std::vector<std::string> loaded;  // the load warnings of A and B, printed at their loads
  for (const auto& l : a.sim.scene().load_warnings) loaded.push_back("A: " + l);
  for (const auto& l : b.sim.scene().load_warnings) loaded.push_back("B: " + l);
  print_warnings(json_path == "-" ? stderr : stdout, warnings, loaded);
  if (diverged) {
    std::string why;
    if (a.diverged) why = "A: " + a.sim.data().warning;
    if (b.diverged) why += (why.empty() ? "B: " : "; B: ") + b.sim.data().warning;
    fail(std::string("simulation of ") + which + " diverged (" + why + ")");
  }
  return 0;
}

// ------------------------------------------------------------------------- core-only demo --

struct DemoOptions {
  double duration = 2.0, timestep = 1e-3, tension = 1.5;
  int sections = 6, order = 0;
  std::optional<Integrator> integrator;
  std::string out = "out/demo";
};

cosserat::Model demo_model(const DemoOptions& o) {
  using namespace cosserat;
  Model m;
  RodSpec s;
  s.name = "arm";
  s.length = 0.4;
  s.radius_base = 0.012;
  s.radius_tip = 0.005;
  s.sections = o.sections;
  s.section.dofs = *strain_mask_from_name("sr");
  s.section.order = o.order;
  s.section.material = RodMaterial{1080.0, 5e5, 0.45, 2.0};  // silicone: density, E, nu, mu
  const int rod = m.add_rod(-1, SE3::Identity(), s);
  m.add_body(m.rods[rod].tip_node, 0.01, Vec3::Zero(), 1e-7 * Mat3::Identity());  // 10 g tip mass
  Cable c;  // a cable 8 mm above the centreline at the base, 3 mm at the tip
  c.rod = rod;
  c.d_begin = Vec3(0, 0, 0.008);
  c.d_end = Vec3(0, 0, 0.003);
  m.add_cable(c, "cable");
  m.finalize();
  return m;
}

// A tapered soft arm clamped horizontally, released under gravity, lifted by a cable whose
// tension ramps up; prints the static equilibrium, natural frequencies and the motion.
int cmd_demo(int argc, char** argv) {
  using namespace cosserat;
  DemoOptions o;
  CommandLine cl{"demo", "core-only simulation of a tapered soft arm lifted by a cable (no MuJoCo)", {}, {},
                 "Writes DIR/demo.csv with time,energy,tip.x,tip.y,tip.z,tension and prints a summary.\n"};
  cl.options = {positive_option("--duration", "T", "simulated time [s] (default 2)", o.duration),
                positive_option("--timestep", "h", "time step [s] (default 0.001)", o.timestep),
                {"--integrator", "NAME", "euler | implicit | trapezoidal | rk4 | rosenbrock (default: implicit)",
                 [&o](const std::string& v) { o.integrator = parse_integrator("--integrator", v); }},
                int_option("--sections", "N", "rod sections (default 6)", o.sections, 1),
                int_option("--order", "P", "GVS strain order per section (default 0: PCS)", o.order, 0),
                {"--tension", "T", "final cable tension [N], >= 0: a cable pulls (default 1.5)",
                 [&o](const std::string& v) {
                   o.tension = parse_number("--tension", v);
                   if (o.tension < 0) fail("--tension: a cable only pulls: give a tension >= 0, got " + v);
                 }},
                text_option("--out", "DIR", "output directory (default out/demo)", o.out)};
  if (!cl.parse(argc, argv)) return 0;
  const Integrator integrator = o.integrator.value_or(Integrator::Implicit);
  if (integrator == Integrator::GeneralizedAlpha || integrator == Integrator::Midpoint)
    fail(std::string("--integrator ") + integrator_name(integrator) + ": MuJoCo scenes only (the demo runs the core solver)");
  // (outside probe BB: 400 sections ran 129 s before a word, 1000 looked like a hang; and a bad
  // --out failed at the end, after the statics and the run)
  constexpr int kDemoDofs = 600;
  const long long dofs = static_cast<long long>(o.sections) * 6 * (o.order + 1);  // (strain "sr")
  if (dofs > kDemoDofs)
    fail("--sections " + std::to_string(o.sections) + " --order " + std::to_string(o.order) + ": the demo's rod would have " +
         std::to_string(dofs) + " dofs; it takes at most " +
         std::to_string(kDemoDofs) + " (its dense statics grow as the cube of them: 600 take 2 s, 1200 15 s)");
  const std::string csv = o.out + "/demo.csv";
  check_writable("--out", csv);

  const Model m = demo_model(o);
  Data d(m);
  const int tip = m.rods[0].tip_node;
  std::printf("demo: tapered silicone arm, L = 0.4 m, %d sections, order %d, %d dofs\n", o.sections, o.order, m.nv);

  // static equilibrium under gravity alone, and the natural frequencies there
  Data ds(m);
  const StaticsResult st = cosserat::equilibrium(m, ds);
  cosserat::fwd_position(m, ds);
  std::printf("equilibrium under gravity: %s after %d Newton iterations (residual %.1e), tip at (%.4f, %.4f, %.4f) m\n",
              st.converged ? "converged" : "NOT converged", st.iterations, st.residual, ds.g[tip].u.x(),
              ds.g[tip].u.y(), ds.g[tip].u.z());
  const Linearization lin = cosserat::linearize(m, ds);
  std::printf("natural frequencies there [Hz]: %.3f %.3f %.3f %.3f\n", lin.frequencies_hz(0), lin.frequencies_hz(1),
              lin.frequencies_hz(2), lin.frequencies_hz(3));

  std::ofstream f = open_output(csv);
  f << "time,energy,tip.x,tip.y,tip.z,tension\n";
  const long steps = step_count(o.duration, o.timestep, "--duration");
  Progress progress("demo", steps);
  const auto t0 = std::chrono::steady_clock::now();
  for (long k = 0; k <= steps; ++k) {
    // tension: zero for the first half, then a smooth ramp to its final value
    const double s = std::clamp((d.time - 0.5 * o.duration) / (0.25 * o.duration), 0.0, 1.0);
    d.ctrl(0) = o.tension * s * s * (3 - 2 * s);
    if (k > 0 && cosserat::step(m, d, o.timestep, integrator) != Status::Ok)
      fail("simulation diverged at t = " + std::to_string(d.time) + " s (try a smaller --timestep)");
    cosserat::fwd_position(m, d);
    cosserat::fwd_velocity(m, d);
    const Vec3 p = d.g[tip].u;
    f << d.time << "," << cosserat::energy(m, d).total() << "," << p.x() << "," << p.y() << "," << p.z() << ","
      << d.ctrl(0) << "\n";
    progress.update(k, d.time);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Vec3 p = d.g[tip].u;
  std::printf("simulated %.2f s in %ld steps (%s, h = %g s) in %.2f s wall: tip at (%.4f, %.4f, %.4f) m, cable %.2f N\n",
              o.duration, steps, integrator_name(integrator), o.timestep, wall, p.x(), p.y(), p.z(), d.ctrl(0));
  std::printf("wrote %s\n", csv.c_str());
  return 0;
}

// ------------------------------------------------------------------------- rendering (render/) --

// The render commands take argv from the command name on (see render_commands.hpp).
int cmd_render(int argc, char** argv) { return render_command(argc + 1, argv - 1); }
int cmd_snapshot(int argc, char** argv) { return snapshot_command(argc + 1, argv - 1); }

// ------------------------------------------------------------------------------------- main --

struct Command {
  const char* name;
  const char* summary;
  int (*run)(int argc, char** argv);
};

const Command kCommands[] = {
    {"check", "load and compile a model, print a summary", cmd_check},
    {"run", "simulate; CSV and JSON outputs", cmd_run},
    {"equilibrium", "static equilibrium (gravity, controls, loads)", cmd_equilibrium},
    {"linearize", "natural frequencies at the equilibrium", cmd_linearize},
    {"compare", "two models side by side: deviations and swimming speeds", cmd_compare},
    {"render", "headless frames (and a video) of a simulation", cmd_render},
    {"snapshot", "one headless picture at a given time", cmd_snapshot},
    {"demo", "core-only soft-arm demo (no MuJoCo)", cmd_demo},
};

std::string usage() {
  std::string u = "usage: cosserat COMMAND [ARGS] [OPTIONS]   ('cosserat COMMAND --help' for details)\ncommands:\n";
  for (const auto& c : kCommands) u += "  " + std::string(c.name) + std::string(14 - std::string(c.name).size(), ' ') + c.summary + "\n";
  return u;
}

int dispatch(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << usage();
    return 1;
  }
  const std::string cmd = argv[1];
  command_line().assign(argv + 1, argv + argc);
  if (cmd == "help" && argc > 2) {  // `cosserat help run` is `cosserat run --help`
    for (const auto& c : kCommands)
      if (argv[2] == std::string(c.name)) {
        char help[] = "--help";
        char* args[] = {argv[2], help, nullptr};
        return c.run(1, args + 1);
      }
    fail("help: unknown command '" + std::string(argv[2]) + "' (see 'cosserat --help')");
  }
  if (cmd == "--help" || cmd == "-h" || cmd == "help") {
    std::cout << usage();
    return 0;
  }
  if (cmd == "--version" || cmd == "version") {
    std::printf("cosserat %s (MuJoCo %d.%d.%d)\n", COSSERAT_VERSION, mj_version() / 100, mj_version() / 10 % 10,
                mj_version() % 10);
    return 0;
  }
  for (const auto& c : kCommands)
    if (cmd == c.name) return c.run(argc - 2, argv + 2);
  fail("unknown command '" + cmd + "' (see 'cosserat --help')");
}

}  // namespace

// The reason for stderr on one line (MuJoCo's compiler messages span several).
std::string one_line(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  for (size_t p = s.find('\n'); p != std::string::npos; p = s.find('\n', p)) s.replace(p, 1, "; ");
  return s;
}

int main(int argc, char** argv) {
  mju_user_warning = on_mujoco_warning;
  mju_user_error = on_mujoco_error;
  try {
    const int status = dispatch(argc, argv);
    // what the command printed may still sit in stdout's buffers: a failed final write (a full
    // disk, a closed pipe) is a failed command, not a silent loss
    std::cout.flush();
    if (std::fflush(stdout) != 0 || std::ferror(stdout) || !std::cout) fail("cannot write stdout");
    if (status != 0) remove_empty_created_directories();
    return status;
  } catch (const mj::LoadError& e) {
    std::cerr << one_line(e.what()) << "\n";
  } catch (const std::exception& e) {  // Failure and anything unexpected
    std::cerr << "cosserat: " << one_line(e.what()) << "\n";
  }
  remove_empty_created_directories();
  return 1;
}
