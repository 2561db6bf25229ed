// Stability stress tests of the coupled scene (bench/README.md). Every case is a small MJCF scene
// stepped with each of our integrators; a run passes when
//   - the state stays finite (no divergence reported by step()),
//   - an undamped run does not gain energy: the mean total energy over the last quarter of the
//     run exceeds the mean over the first quarter by at most 5% of the energy scale (the largest
//     kinetic energy seen, or the energy of the initial deformation), and never exceeds the
//     initial energy by more than 50% of that scale,
//   - a resting state (static equilibrium found by mj::equilibrium) does not drift: the tip moves
//     by less than 1e-6 L.
// Sweeps:
//   material   Young's modulus 1e3 .. 1e11 Pa x slenderness L/r 10, 100, 1000 (a kl cantilever
//              released under gravity): the largest stable step of each integrator on the grid
//              1e-5 .. 1e-2 s (searched downwards: the first step that passes), then a resting-state
//              run at that step;
//   turns      one PCS section bent and twisted through 0 .. 5 full turns (and nearly straight:
//              theta = 1e-12 .. 1e-3), released without gravity: energy conservation with RK4;
//   long       1e5 steps (quick: 5e3) of the cantilever with each integrator;
//   soft       a string too soft for its own weight (E = 1e3 Pa, L/r = 1000), 3 s at 2 ms;
//   tipmass    tip masses 1 .. 1000 x the rod's mass: largest stable step of each integrator;
//   contact    a 1 kg sphere dropped on a clamped rod (stiff contact), and a rod resting on the
//              floor (drift).
// Usage: stress [--quick] [--out DIR] [--only PART]... (PART: material, turns, long, soft, tipmass,
// contact; repeatable; default all) [--rod-attr NAME=VALUE]... [--step-tol TOL] [--newton-refresh].
// Writes DIR/stress.json.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "cli.hpp"
#include "common.hpp"

#include "scene_statics.hpp"

using namespace cosserat;
using namespace cosserat::bench;

namespace {

constexpr double kPi = 3.14159265358979323846;

// --rod-attr NAME=VALUE: set on every rod of every scene the sweep loads (e.g. quadrature=lobatto)
std::vector<std::pair<std::string, std::string>> g_rod_attrs;
std::string with_rod_attrs(std::string xml) {
  for (const auto& [name, value] : g_rod_attrs) xml = set_rod_attr(xml, name, value);
  return xml;
}

struct Case {
  double E = 1e7, L = 0.5, r = 0.005, rho = 1000, viscosity = 0;
  std::string strain = "kl";
  int sections = 4;
  double tip_mass = 0;  // kg, sphere at the tip
  bool gravity = true;
  bool floor = false;
  std::string extra_body;  // extra MJCF inside <worldbody>
  std::string rod_extra;   // extra attributes of the <cosserat>
  std::string options;     // extra attributes of <option>
};

std::string scene_xml(const Case& c) {
  char buf[4096];
  std::string tip;
  if (c.tip_mass > 0) {
    char t[256];
    std::snprintf(t, sizeof t, R"(<body name="tipmass" pos="%g 0 0"><geom type="sphere" size="%g" mass="%g" contype="0" conaffinity="0"/></body>)",
                  2 * c.r, 2 * c.r, c.tip_mass);
    tip = t;
  }
  std::snprintf(buf, sizeof buf, R"(<mujoco model="stress">
  <option timestep="0.001" gravity="0 0 %g" %s/>
  <worldbody>
    %s
    %s
    <cosserat name="rod" pos="0 0 1" length="%g" sections="%d" strain="%s" radius="%g" density="%g"
              young="%g" poisson="0.5" viscosity="%g" %s>%s</cosserat>
  </worldbody>
</mujoco>)",
                c.gravity ? -9.81 : 0.0, c.options.c_str(), c.floor ? R"(<geom name="floor" type="plane" size="2 2 0.1"/>)" : "",
                c.extra_body.c_str(), c.L, c.sections, c.strain.c_str(),
                c.r, c.rho, c.E, c.viscosity, c.rod_extra.c_str(), tip.c_str());
  return buf;
}

struct Result {
  bool pass = false;
  std::string reason;
  double energy_growth = NAN, energy_scale = NAN, drift = NAN;
  double lambda_min = NAN, lambda_max = NAN;  // resting runs: spectrum of Kt x = lambda M x
  bool unstable_equilibrium = false;
  long steps = 0;
  double wall = 0;
  // Newton corrections per step and split steps (integrators with corrections; -1: none): a
  // scheme whose iteration keeps failing sub-steps the run, and that cost belongs with its step
  double newton_per_step = -1;
  long newton_splits = -1;
  // adaptive runs (--step-tol): accepted substeps per step, and substeps kept at h/64 above the
  // tolerance (-1: fixed steps)
  double substeps_per_step = -1;
  long kept_at_min = -1;
};

// Newton statistics of a finished run into r (runs that made corrections only), and the adaptive
// substeps' (--step-tol).
void newton_stats(Sim& sim, Result& r) {
  const mj::SceneData* sd = rod_scene_data(sim);
  if (sd && sd->adapt_stats.steps > 0) {
    r.substeps_per_step = static_cast<double>(sd->adapt_stats.substeps) / static_cast<double>(sd->adapt_stats.steps);
    r.kept_at_min = sd->adapt_stats.kept_at_min;
  }
  if (!sd || r.steps <= 0 || sd->newton_stats.iterations == 0) return;
  r.newton_per_step = static_cast<double>(sd->newton_stats.iterations) / static_cast<double>(r.steps);
  r.newton_splits = sd->newton_stats.splits;
}

// Runs `steps` steps from the scene's initial state (after `init`), checking finiteness and energy.
Result energy_run(const std::string& xml, Method method, double h, long steps,
                  const std::function<void(Sim&)>& init = {}) {
  Result r;
  std::unique_ptr<Sim> sim;
  try {
    sim = make_rod_sim(with_rod_attrs(xml), "stress.xml", method, h);
  } catch (const std::exception& e) {
    r.reason = std::string("load: ") + e.what();
    return r;
  }
  if (init) init(*sim);
  const long stride = std::max(1L, steps / 200);
  const Trajectory tr = run(*sim, steps * h, h, stride * h, {sim->site_id("rod/tip")}, {}, true);
  r.steps = tr.steps;
  r.wall = tr.wall;
  newton_stats(*sim, r);
  if (tr.diverged) {
    r.reason = "diverged at step " + std::to_string(tr.steps);
    return r;
  }
  const std::vector<double>& E = tr.energy;
  for (double e : E)
    if (!std::isfinite(e)) {
      r.reason = "non-finite energy";
      return r;
    }
  // energy scale: the largest kinetic energy of the run (the energy that is exchanged)
  double scale = 0.0;
  for (double k : tr.kinetic) scale = std::max(scale, k);
  const size_t n = E.size(), q = std::max<size_t>(1, n / 4);
  double first = 0, last = 0, emax = -1e300;
  for (size_t k = 0; k < q; ++k) first += E[k] / q;
  for (size_t k = n - q; k < n; ++k) last += E[k] / q;
  for (double e : E) emax = std::max(emax, e);
  r.energy_scale = scale;
  r.pass = true;
  if (scale <= 0) return r;  // nothing moves
  r.energy_growth = (last - first) / scale;
  const double jump = (emax - E[0]) / scale;
  if (r.energy_growth > 0.05) {
    r.pass = false;
    r.reason = "energy grows by " + std::to_string(r.energy_growth) + " of the largest kinetic energy";
  } else if (jump > 0.5) {
    r.pass = false;
    r.reason = "energy rises above its start by " + std::to_string(jump) + " of the largest kinetic energy";
  }
  return r;
}

// Resting state: equilibrium under gravity, then `steps` steps; drift of the tip relative to L.
Result rest_run(const std::string& xml, double L, Method method, double h, long steps) {
  Result r;
  std::unique_ptr<Sim> sim;
  try {
    sim = make_rod_sim(with_rod_attrs(xml), "stress.xml", method, h);
  } catch (const std::exception& e) {
    r.reason = std::string("load: ") + e.what();
    return r;
  }
  const mj::Scene* s = rod_scene(*sim);
  mj::SceneData* sd = rod_scene_data(*sim);
  const mj::SceneStaticsResult eq = mj::equilibrium(*s, *sd);
  if (!eq.converged) {
    r.reason = "no equilibrium: " + eq.message;
    return r;
  }
  // is the equilibrium stable? smallest eigenvalue of Kt x = lambda M x (tangent stiffness)
  {
    const mj::SceneLinearization lin = mj::linearize(*s, *sd);
    const Eigen::MatrixXd Ks = 0.5 * (lin.Kt + lin.Kt.transpose());
    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> es(Ks, lin.M, Eigen::EigenvaluesOnly);
    r.lambda_min = es.eigenvalues()(0);
    r.lambda_max = es.eigenvalues()(es.eigenvalues().size() - 1);
    mju_zero(sd->d->qvel, s->m->nv);
  }
  sim->positions();
  const int tip = sim->site_id("rod/tip");
  const Vec3 p0 = sim->site(tip);
  const Trajectory tr = run(*sim, steps * h, h, steps * h, {tip});
  r.steps = tr.steps;
  r.wall = tr.wall;
  if (tr.diverged) {
    r.reason = "diverged at step " + std::to_string(tr.steps);
    return r;
  }
  r.drift = (tr.p.back()[0] - p0).norm() / L;
  r.pass = r.drift < 1e-6;
  if (!r.pass) {
    r.reason = "resting state drifts by " + std::to_string(r.drift) + " L";
    if (r.lambda_min < -1e-9 * std::abs(r.lambda_max)) {
      // the equilibrium Newton found is physically unstable: drifting away is right
      r.unstable_equilibrium = true;
      char b[160];
      std::snprintf(b, sizeof b, " (the equilibrium is unstable: omega^2_min = %.3g 1/s^2)", r.lambda_min);
      r.reason += b;
    }
  }
  return r;
}

json result_json(const Result& r) {
  json j;
  j["pass"] = r.pass;
  if (!r.reason.empty()) j["reason"] = r.reason;
  if (std::isfinite(r.energy_growth)) j["energy_growth"] = r.energy_growth;
  if (std::isfinite(r.energy_scale)) j["energy_scale_J"] = r.energy_scale;
  if (std::isfinite(r.drift)) j["drift_over_L"] = r.drift;
  if (std::isfinite(r.lambda_min)) j["equilibrium_omega2_min"] = r.lambda_min;
  if (r.unstable_equilibrium) j["unstable_equilibrium"] = true;
  j["steps"] = r.steps;
  j["wall_s"] = r.wall;
  if (r.newton_per_step >= 0) {
    j["newton_corrections_per_step"] = r.newton_per_step;
    j["newton_splits"] = r.newton_splits;
  }
  if (r.substeps_per_step >= 0) {
    j["substeps_per_step"] = r.substeps_per_step;
    j["substeps_kept_at_min"] = r.kept_at_min;
  }
  return j;
}

const Method kMethods[] = {Method::Euler,       Method::Implicit,         Method::ImplicitNewton, Method::Trapezoidal,
                           Method::TrapezoidalLinear, Method::GeneralizedAlpha, Method::Midpoint, Method::RK4,
                           Method::Rosenbrock};

}  // namespace

int run_stress(int argc, char** argv) {
  bool quick = false;
  std::string out = "docs/bench";
  std::vector<std::string> only;  // parts to run (empty: all)
  const std::vector<std::string> parts = {"material", "turns", "long", "soft", "tipmass", "contact"};
  cli::CommandLine cl{"bench_stress",
                      "stability stress tests of every integrator (bench/README.md); writes DIR/stress.json",
                      {},
                      {cli::flag_option("--quick", "small grids and short runs (the CI smoke run)", quick),
                       cli::text_option("--out", "DIR", "output directory (default docs/bench)", out),
                       {"--rod-attr", "NAME=VALUE",
                        "set this attribute on every rod of every scene (repeatable), e.g. quadrature=lobatto",
                        [&](const std::string& v) {
                          const size_t eq = v.find('=');
                          if (eq == std::string::npos || eq == 0 || eq + 1 == v.size())
                            cli::fail("--rod-attr: expected NAME=VALUE, got '" + v + "'");
                          g_rod_attrs.emplace_back(v.substr(0, eq), v.substr(eq + 1));
                        }},
                       cli::positive_option("--step-tol", "TOL",
                                            "run every integrator but euler, rk4 and rosenbrock with adaptive substeps to this "
                                            "tolerance (mj::Scene::step_tol; default: fixed steps)",
                                            rod_sim_options().step_tol),
                       cli::flag_option("--newton-refresh", "refactorise the Newton matrix at the first iterate "
                                                            "(mj::Scene::newton_refresh)",
                                        rod_sim_options().newton_refresh),
                       {"--only", "PART",
                        "run only this part (repeatable): material, turns, long, soft, tipmass or contact (default: all)",
                        [&](const std::string& v) {
                          if (std::find(parts.begin(), parts.end(), v) == parts.end())
                            cli::fail("--only: unknown part '" + v +
                                      "' (material, turns, long, soft, tipmass, contact)");
                          only.push_back(v);
                        }}}};
  cl.program.clear();
  if (!cl.parse(argc - 1, argv + 1)) return 0;
  const auto wanted = [&](const char* part) {
    return only.empty() || std::find(only.begin(), only.end(), part) != only.end();
  };
  mju_user_warning = [](const char*) {};
  json report;
  report["machine"] = machine_info();
  report["quick"] = quick;
  for (const auto& [name, value] : g_rod_attrs) report["rod_attributes"][name] = value;
  if (rod_sim_options().step_tol > 0) report["step_tol"] = rod_sim_options().step_tol;
  if (rod_sim_options().newton_refresh) report["newton_refresh"] = true;
  int failures = 0;
  std::vector<std::string> failure_list;
  auto note = [&](const std::string& what, const Result& r) {
    std::printf("  %-62s %s%s\n", what.c_str(), r.pass ? "pass" : "FAIL",
                r.reason.empty() ? "" : ("  (" + r.reason + ")").c_str());
    std::fflush(stdout);
    if (!r.pass) ++failures, failure_list.push_back(what + ": " + r.reason);
  };

  const std::vector<double> steps_grid =
      quick ? std::vector<double>{1e-2, 1e-3, 1e-4}
            : std::vector<double>{1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6, 1e-6};
  const long nsteps = quick ? 150 : 1000;
  // failing long and soft-string runs look for a passing step down to the issue's smallest, 1e-5 s
  const double kSmallestStep = 1e-5;
  const auto passes_below = [&](double hp) {
    char b[96];
    if (hp > 0)
      std::snprintf(b, sizeof b, "; passes at h = %g", hp);
    else
      std::snprintf(b, sizeof b, "; no passing step down to %g", std::max(kSmallestStep, steps_grid.back()));
    return std::string(b);
  };
  // The largest step of the grid (searched downwards) at which steps(h) steps pass the energy
  // check (steps(h) <= 0: h is skipped), or 0 if none; every trial is appended to `tried`.
  auto largest_stable = [&](const std::string& xml, Method m, const std::function<long(double)>& steps, json& tried) {
    for (double h : steps_grid) {
      if (steps(h) <= 0) continue;  // not a candidate
      const Result r = energy_run(xml, m, h, steps(h));
      json t = result_json(r);
      t["h"] = h;
      tried.push_back(t);
      if (r.pass) return h;
    }
    return 0.0;
  };
  const auto fixed_steps = [&](double) { return nsteps; };
  // A run that failed at step h: the largest smaller step of the grid, down to kSmallestStep, at
  // which steps(h') steps pass (0: none); its trials go to row["runs_below"].
  auto largest_below = [&](const std::string& xml, Method m, double h, const std::function<long(double)>& steps,
                           json& row) {
    json tried = json::array();
    const double hp = largest_stable(
        xml, m, [&](double hh) { return hh < h && hh >= kSmallestStep ? steps(hh) : 0L; }, tried);
    row["runs_below"] = tried;
    return hp;
  };

  if (wanted("material")) {
    // ---- material x slenderness x integrator: largest stable step, then a resting run at it
    std::printf("== material: Young's modulus x slenderness, largest stable step per integrator (%ld steps)\n", nsteps);
    const std::vector<double> moduli = quick ? std::vector<double>{1e3, 1e7, 1e11}
                                             : std::vector<double>{1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11};
    const std::vector<double> slender = quick ? std::vector<double>{10, 1000} : std::vector<double>{10, 100, 1000};
    json mat = json::array();
    for (double E : moduli)
      for (double sl : slender) {
        Case c;
        c.E = E;
        c.r = c.L / sl;
        const std::string xml = scene_xml(c);
        for (Method m : kMethods) {
          json row;
          row["young"] = E;
          row["slenderness"] = sl;
          row["method"] = method_name(m);
          json tried = json::array();
          const double hmax = largest_stable(xml, m, fixed_steps, tried);
          row["runs"] = tried;
          row["largest_stable_step"] = hmax > 0 ? json(hmax) : json(nullptr);
          char what[128];
          std::snprintf(what, sizeof what, "E=%.0e L/r=%-4g %-8s largest stable h = %s", E, sl, method_name(m),
                        hmax > 0 ? std::to_string(hmax).substr(0, 7).c_str() : "none");
          if (hmax > 0) {
            const long nrest = quick ? 100 : 1000;
            Result rest = rest_run(xml, c.L, m, hmax, nrest);
            row["rest"] = result_json(rest);
            if (!rest.pass && rest.unstable_equilibrium) {
              rest.pass = true;  // drifting away from an unstable equilibrium is physics
              rest.reason = "n/a: " + rest.reason;
            } else if (!rest.pass && rest.reason.rfind("no equilibrium", 0) != 0) {
              // the same simulated time at a 10x smaller step: is it the step?
              const Result small = rest_run(xml, c.L, m, hmax / 10, 10 * nrest);
              row["rest_at_tenth_step"] = result_json(small);
              rest.reason += small.pass ? "; passes at h/10 (same time)" : "; also at h/10: " + small.reason;
            }
            note(std::string(what) + ", resting", rest);
          } else {
            Result none;
            none.reason = "no stable step down to " + std::to_string(steps_grid.back());
            note(what, none);
          }
          mat.push_back(row);
        }
      }
    report["material"] = mat;
  }
  if (wanted("turns")) {
    // ---- several full turns, and nearly straight sections (no gravity, undamped, RK4)
    std::printf("== turns: one section bent and twisted through several turns / nearly straight (rk4)\n");
    json turns = json::array();
    const std::vector<double> angles =
        quick ? std::vector<double>{1e-12, 1e-6, 2 * kPi, 5 * 2 * kPi}
              : std::vector<double>{0.0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3, 1.0, kPi, 2 * kPi, 3 * 2 * kPi, 5 * 2 * kPi};
    for (double theta : angles) {
      Case c;
      c.E = 1e6;
      c.sections = 1;
      c.strain = "sr";
      c.gravity = false;
      const std::string xml = scene_xml(c);
      for (Method m : {Method::RK4, Method::Implicit}) {
        const double h = 1e-4;
        auto init = [&](Sim& s) {
          const mjModel* mm = s.m();
          // bend (ky) and twist (kx) so that |k| L = theta, plus a little stretch and shear
          const double k = theta / c.L;
          auto set = [&](const char* j, double v) {
            const int id = mj_name2id(mm, mjOBJ_JOINT, j);
            s.d()->qpos[mm->jnt_qposadr[id]] = v;
          };
          set("rod/s0/ky", 0.8 * k);
          set("rod/s0/kx", 0.6 * k);
          set("rod/s0/px", 1e-3);
          set("rod/s0/py", 1e-4);
        };
        const Result r = energy_run(xml, m, h, quick ? 200 : 2000, init);
        json row = result_json(r);
        row["theta"] = theta;
        row["method"] = method_name(m);
        row["h"] = h;
        turns.push_back(row);
        char what[128];
        std::snprintf(what, sizeof what, "theta = %-10.3g (%.2f turns) %s h=%g", theta, theta / (2 * kPi),
                      method_name(m), h);
        note(what, r);
      }
    }
    report["turns"] = turns;
  }
  if (wanted("long")) {
    // ---- long runs
    const long nlong = quick ? 5000 : 100000;
    std::printf(
        "== long: %ld steps of the cantilever (E = 1e7, L/r = 100) one grid step below the largest step stable over "
        "%ld steps\n",
        nlong, nsteps);
    json lng = json::array();
    for (Method m : kMethods) {
      Case c;
      // one notch of the grid below the largest step stable over 1000 steps (as in the material
      // sweep; a run at the very edge of stability is not what anyone would choose), then nlong
      // steps at it
      json tried = json::array();
      const double edge = largest_stable(scene_xml(c), m, fixed_steps, tried);
      if (edge == 0) continue;
      const auto k = std::find(steps_grid.begin(), steps_grid.end(), edge) - steps_grid.begin();
      const double h = k + 1 < static_cast<long>(steps_grid.size()) ? steps_grid[k + 1] : edge;
      Result r = energy_run(scene_xml(c), m, h, nlong);
      json row = result_json(r);
      row["method"] = method_name(m);
      row["h"] = h;
      if (!r.pass) {
        // the case fails at this step: the largest smaller step of the issue's range at which the
        // same number of steps passes (the failure stays a failure; this says what step it needs)
        const double hp = largest_below(scene_xml(c), m, h, [&](double) { return nlong; }, row);
        row["largest_passing_step"] = hp > 0 ? json(hp) : json(nullptr);
        r.reason += passes_below(hp);
      }
      lng.push_back(row);
      note(std::string("long run ") + method_name(m) + " h=" + std::to_string(h).substr(0, 6), r);
    }
    report["long"] = lng;
  }
  if (wanted("soft")) {
    // ---- a string too soft for its own weight (docs/bench/repro/soft_string_collapse.xml): it
    // stretches 6-8x and compresses sections towards zero length. Every integrator at h = 2 ms for
    // 3 s (quick: 1 s); the explicit ones (euler, rk4) that fail there get their largest stable step
    // below it instead (explicit methods are not expected to take stiff steps).
    const double soft_T = quick ? 1.0 : 3.0;
    std::printf("== soft string: E = 1e3 Pa, L/r = 1000, %g s at h = 2 ms\n", soft_T);
    json soft = json::array();
    const std::string soft_xml = read_file(COSSERAT_SOURCE_DIR "/docs/bench/repro/soft_string_collapse.xml");
    for (Method m : kMethods) {
      const double h = 2e-3;
      Result r = energy_run(soft_xml, m, h, std::lround(soft_T / h));
      json row = result_json(r);
      row["method"] = method_name(m);
      row["h"] = h;
      if (!r.pass) {
        // the largest smaller step at which the same 3 s pass. An explicit method (euler, rk4) is
        // not expected to take stiff steps: it passes when it has one. An implicit one stays failed
        // at 2 ms, with the step it needs noted.
        const double hmax = largest_below(soft_xml, m, h, [&](double hh) { return std::lround(soft_T / hh); }, row);
        row["largest_stable_step"] = hmax > 0 ? json(hmax) : json(nullptr);
        if (m == Method::Euler || m == Method::RK4) {
          r.pass = hmax > 0;
          r.reason = "explicit, unstable at 2 ms (" + r.reason + "); largest stable step " +
                     (hmax > 0 ? std::to_string(hmax).substr(0, 7) : std::string("none"));
        } else {
          r.reason += passes_below(hmax);
        }
      }
      soft.push_back(row);
      note(std::string("soft string ") + method_name(m) + " h=0.002", r);
    }
    report["soft_string"] = soft;
  }
  if (wanted("tipmass")) {
    // ---- heavy tip masses
    std::printf("== tipmass: tip mass x rod mass, largest stable step per integrator\n");
    json tm = json::array();
    for (double ratio : quick ? std::vector<double>{1, 1000} : std::vector<double>{1, 10, 100, 1000}) {
      Case c;
      const double rod_mass = c.rho * kPi * c.r * c.r * c.L;
      c.tip_mass = ratio * rod_mass;
      const std::string xml = scene_xml(c);
      for (Method m : kMethods) {
        json tried = json::array();
        const double hmax = largest_stable(xml, m, fixed_steps, tried);
        json row;
        row["tip_mass_ratio"] = ratio;
        row["method"] = method_name(m);
        row["runs"] = tried;
        row["largest_stable_step"] = hmax > 0 ? json(hmax) : json(nullptr);
        Result r;
        r.pass = hmax > 0;
        if (!r.pass) r.reason = "no stable step";
        char what[128];
        std::snprintf(what, sizeof what, "tip mass %4g x rod %-8s largest stable h = %s", ratio, method_name(m),
                      hmax > 0 ? std::to_string(hmax).substr(0, 7).c_str() : "none");
        note(what, r);
        tm.push_back(row);
      }
    }
    report["tipmass"] = tm;
  }
  if (wanted("contact")) {
    // ---- hard contact
    std::printf("== contact: a 1 kg sphere dropped on a clamped rod; a rod resting on the floor\n");
    json ct = json::array();
    for (Method m : kMethods) {
      Case c;
      c.E = 1e7;
      c.sections = 8;
      c.rod_extra = R"(solref="0.002 1")";
      const std::string free_xml = scene_xml(c);
      c.extra_body =
          R"(<body name="ball" pos="0.3 0 1.04"><freejoint/><geom type="sphere" size="0.03" mass="1" solref="0.002 1"/></body>)";
      const std::string ball_xml = scene_xml(c);
      json tried_free = json::array(), tried_ball = json::array();
      const double T = quick ? 0.15 : 0.4;  // the ball hits the rod at about 0.03 s
      const auto over_T = [T](double h) { return std::max(50L, static_cast<long>(T / h)); };
      const double h_free = largest_stable(free_xml, m, over_T, tried_free);
      const double h_ball = largest_stable(ball_xml, m, over_T, tried_ball);
      Result r;
      r.pass = h_ball > 0 && h_ball >= h_free;
      if (!r.pass)
        r.reason =
            "contact lowers the largest stable step from " + std::to_string(h_free) + " to " + std::to_string(h_ball);
      json row;
      row["case"] = "1 kg sphere dropped from 5 mm above a clamped rod (E = 1e7, 8 kl sections, solref 0.002)";
      row["method"] = method_name(m);
      row["largest_stable_step_without_contact"] = h_free > 0 ? json(h_free) : json(nullptr);
      row["largest_stable_step_with_contact"] = h_ball > 0 ? json(h_ball) : json(nullptr);
      row["runs_without_contact"] = tried_free;
      row["runs_with_contact"] = tried_ball;
      row["pass"] = r.pass;
      ct.push_back(row);
      char what[160];
      std::snprintf(what, sizeof what, "sphere on rod %-8s largest stable h: %g with contact, %g without",
                    method_name(m), h_ball, h_free);
      note(what, r);
    }
    for (Method m : kMethods) {
      Case c;
      c.E = 1e6;
      c.sections = 4;
      c.viscosity = 0;
      c.rod_extra = R"(pos="0 0 0.005" )";
      std::string xml = scene_xml(c);
      // lying on the floor: the rod's base is not clamped above the floor but rides on a free body
      xml = R"(<mujoco model="rest_on_floor">
  <option timestep="0.001" gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="hub" pos="0 0 0.006"><freejoint/><geom type="sphere" size="0.006" mass="0.01"/>
      <cosserat name="rod" length="0.5" sections="4" strain="kl" radius="0.005" density="1000" young="1e6" poisson="0.5" viscosity="5"/>
    </body>
  </worldbody>
</mujoco>)";
      // settle, then measure the drift over further steps
      Result r;
      try {
        auto sim = make_rod_sim(with_rod_attrs(xml), "rest_on_floor.xml", m, 1e-3);
        const int tip = sim->site_id("rod/tip");
        const Trajectory settle = run(*sim, 2.0, 1e-3, 2.0, {tip});
        if (settle.diverged) {
          r.reason = "diverged while settling";
        } else {
          const Vec3 p0 = settle.p.back()[0];
          const Trajectory tr = run(*sim, quick ? 0.5 : 5.0, 1e-3, 0.5, {tip});
          r.steps = settle.steps + tr.steps;
          r.wall = settle.wall + tr.wall;
          if (tr.diverged) {
            r.reason = "diverged";
          } else {
            r.drift = (tr.p.back()[0] - p0).norm() / 0.5;
            r.pass = r.drift < 1e-4;
            if (!r.pass) r.reason = "creeps by " + std::to_string(r.drift) + " L";
          }
        }
      } catch (const std::exception& e) {
        r.reason = e.what();
      }
      json row = result_json(r);
      row["case"] = "rod resting on the floor (free hub), drift after settling";
      row["method"] = method_name(m);
      row["h"] = 1e-3;
      ct.push_back(row);
      note(std::string("rod resting on the floor, drift after 2 s, ") + method_name(m), r);
    }
    report["contact"] = ct;
  }

  report["failures"] = failures;
  report["failure_list"] = failure_list;
  std::printf("\n%d failing case(s)\n", failures);
  for (const auto& f : failure_list) std::printf("  %s\n", f.c_str());
  write_json(out + "/stress.json", report);
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run_stress(argc, argv);
  } catch (const cosserat::cli::Failure& f) {
    return cosserat::cli::report("bench_stress", f);
  }
}
