// Shared helpers of the benchmark programs: timing, machine description, JSON output, MJCF text
// edits, and one interface over "our coupled scene" and "a plain MuJoCo model" so that every
// benchmark runs both the same way.
#pragma once

#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "integrators.hpp"
#include "scene.hpp"

namespace cosserat::bench {

using json = nlohmann::json;

// ------------------------------------------------------------------------------------ timing --

inline double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v);

// Runs f() until `min_time` seconds have been spent and at least `min_reps` times (at most
// `max_reps`); returns the median time of one call.
double time_median(const std::function<void()>& f, int min_reps = 5, double min_time = 0.05, int max_reps = 100000);

// ------------------------------------------------------------------------- machine and output --

// CPU model, cores, compiler, MuJoCo and Eigen versions, date.
json machine_info();
// Writes `j` (pretty) to `path`, creating the directory. Prints the path.
void write_json(const std::string& path, const json& j);
std::string read_file(const std::string& path);
bool file_exists(const std::string& path);

// ------------------------------------------------------------------------------ MJCF edits --

// Sets attribute `attr` of every <cosserat> (or only the one named `rod`) to `value`.
std::string set_rod_attr(const std::string& xml, const std::string& attr, const std::string& value,
                         const std::string& rod = "");
// Every rod with k times as many sections: each <section> child becomes k copies (a given length
// divided by k), or the `sections` attribute is multiplied by k. k = -m <= -2 coarsens instead:
// every run of m identical <section> children without a length (same attributes, no children)
// becomes one, so the run shares the rod's free length in pieces m times as long (exact where they
// have the same rest strain); or `sections` is divided by m. Throws std::invalid_argument where a
// run or `sections` is not a multiple of m.
std::string refine_sections(const std::string& xml, int k);
// Sets <option attr="value"> (creating <option> if needed).
std::string set_option(const std::string& xml, const std::string& attr, const std::string& value);
// Removes every element (anywhere) whose tag is `tag` and whose name attribute is `name`.
std::string remove_named(const std::string& xml, const std::string& tag, const std::string& name);
// Removes every element with tag `tag` (anywhere).
std::string remove_all(const std::string& xml, const std::string& tag);
// Sets attribute `attr` of the element with tag `tag` named `name`.
std::string set_named_attr(const std::string& xml, const std::string& tag, const std::string& name,
                           const std::string& attr, const std::string& value);

// A plain MuJoCo model from MJCF text (no <cosserat>); throws std::runtime_error with MuJoCo's
// message.
mjModel* load_mujoco_string(const std::string& xml, const std::string& path);

// --------------------------------------------------------------------------- simulations --

// Trapezoidal (the scene's default: fully implicit, Newton), TrapezoidalLinear (--newton 0: one
// linearised solve), GeneralizedAlpha (rho_inf 0.8), ImplicitNewton (backward Euler, --newton 10),
// Midpoint (the energy-conserving implicit midpoint rule): ours only.
enum class Method { Euler, Implicit, RK4, Trapezoidal, TrapezoidalLinear, GeneralizedAlpha, ImplicitNewton, Midpoint, Rosenbrock };
const char* method_name(Method m);

// One simulation, ours (Scene + SceneData, our integrators) or MuJoCo's (mjModel + mjData, mj_step
// with MuJoCo's own integrators: Euler, RK4, implicit-in-velocity).
class Sim {
 public:
  virtual ~Sim() = default;
  virtual const mjModel* m() const = 0;
  virtual mjData* d() = 0;
  // one step of size h; false when the state became non-finite (or MuJoCo reset it)
  virtual bool step() = 0;
  // positions of the current state (site_xpos, xpos): the position stage, run outside the timing
  virtual void positions() = 0;
  // back to the model's initial state (qpos0, zero velocities, time 0; ctrl and xfrc_applied zero)
  virtual void reset() = 0;
  // total mechanical energy of the current state (kinetic + gravity + elastic) and its kinetic
  // part, after positions()
  virtual double energy(double* kinetic = nullptr) = 0;
  double time() { return d()->time; }
  Vec3 site(int id) { return Vec3(d()->site_xpos[3 * id], d()->site_xpos[3 * id + 1], d()->site_xpos[3 * id + 2]); }
  Vec3 body(int id) { return Vec3(d()->xpos[3 * id], d()->xpos[3 * id + 1], d()->xpos[3 * id + 2]); }
  int site_id(const std::string& name) const { return mj_name2id(m(), mjOBJ_SITE, name.c_str()); }
  int body_id(const std::string& name) const { return mj_name2id(m(), mjOBJ_BODY, name.c_str()); }
};

// Ours: `xml` with <cosserat> elements, stepped with `method` at time step h.
std::unique_ptr<Sim> make_rod_sim(const std::string& xml, const std::string& path, Method method, double h);
// MuJoCo's: a plain model (e.g. from native_chain_xml), MuJoCo's integrator for `method`.
std::unique_ptr<Sim> make_mujoco_sim(const std::string& xml, const std::string& path, Method method, double h);

// Access to the coupled scene behind a rod Sim (nullptr for a MuJoCo Sim).
// Solver options every rod simulation made by make_rod_sim takes (after the method's own
// newton_iterations): the stress sweep's --step-tol and --newton-refresh.
struct RodSimOptions {
  double step_tol = 0.0;        // mj::Scene::step_tol
  bool newton_refresh = false;  // mj::Scene::newton_refresh
};
RodSimOptions& rod_sim_options();
const mj::Scene* rod_scene(Sim& s);
mj::SceneData* rod_scene_data(Sim& s);

// Runs `sim` to time T, calling control(t, m, d) before every step and recording, every `every`
// seconds (a multiple of the step), the world positions of `sites` (after positions()). Only the
// steps are timed. Returns false on divergence.
struct Trajectory {
  std::vector<double> t;
  std::vector<std::vector<Vec3>> p;  // [sample][site]
  std::vector<double> energy;        // per sample, if requested: total
  std::vector<double> kinetic;       // and kinetic
  double wall = 0.0;                 // seconds spent in step()
  long steps = 0;
  bool diverged = false;
};
using Control = std::function<void(double t, const mjModel* m, mjData* d)>;
Trajectory run(Sim& sim, double T, double h, double every, const std::vector<int>& sites, const Control& control = {},
               bool record_energy = false, const std::vector<int>& bodies = {});

}  // namespace cosserat::bench
