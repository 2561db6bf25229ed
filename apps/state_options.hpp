// The initial state of the commands that simulate or solve (run, compare, equilibrium, linearize,
// render, snapshot): --key and --ctrl, and the step count of a duration.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "control_schedule.hpp"
#include "scene.hpp"

namespace cosserat::cli {

// Keyframe `key` (name or index; empty: none) and then the controls `ctrl` (nu numbers separated by
// commas; empty: none) into d. Controls of magnitude 1e10 or more are refused: MuJoCo 2.2.2 sets
// such a control to 0 with only a warning (mjMAXVAL), so the run would silently ignore it. A
// control outside a limited actuator's ctrlrange, given or from the keyframe, is kept (MuJoCo
// clamps it unless the model disables clampctrl) with a warning.
inline void apply_key_and_ctrl(const mjModel* m, mjData* d, const std::string& key, const std::string& ctrl) {
  if (!key.empty()) {
    int id = mj_name2id(m, mjOBJ_KEY, key.c_str());
    if (id < 0 && key.find_first_not_of("0123456789") == std::string::npos) id = parse_int("--key", key, 0);
    if (id < 0 || id >= m->nkey) fail("--key: no keyframe '" + key + "' (the model has " + std::to_string(m->nkey) + ")");
    mj_resetDataKeyframe(m, d, id);
  }
  if (!ctrl.empty()) {
    std::vector<double> u;
    std::istringstream in(ctrl);
    for (std::string v; std::getline(in, v, ',');) {
      u.push_back(parse_number("--ctrl", v));
      if (!(std::abs(u.back()) < mjMAXVAL)) fail("--ctrl: '" + v + "' is not below 1e10 in magnitude (MuJoCo ignores such controls)");
    }
    if (static_cast<int>(u.size()) != m->nu)
      fail("--ctrl: " + std::to_string(u.size()) + " values for " + std::to_string(m->nu) + " actuators");
    std::copy(u.begin(), u.end(), d->ctrl);
  }
  // MuJoCo clamps a limited control, unless <flag clampctrl="disable"/>: say so, of the keyframe's
  // controls too (outside probe BM: the warning had claimed a clamp the flag turned off, and a
  // keyframe's control out of range went without one)
  if (m->opt.disableflags & mjDSBL_CLAMPCTRL || (key.empty() && ctrl.empty())) return;
  for (int i = 0; i < m->nu; ++i) {
    const double lo = m->actuator_ctrlrange[2 * i], hi = m->actuator_ctrlrange[2 * i + 1], u = d->ctrl[i];
    if (!m->actuator_ctrllimited[i] || (u >= lo && u <= hi)) continue;
    const char* name = mj_id2name(m, mjOBJ_ACTUATOR, i);
    char label[128];
    if (name) std::snprintf(label, sizeof label, "'%s'", name);
    else std::snprintf(label, sizeof label, "%d", i);
    char b[512];
    std::snprintf(b, sizeof b, "%s: %g for actuator %s is outside its ctrlrange [%g, %g]: MuJoCo clamps it to %g",
                  ctrl.empty() ? ("keyframe '" + key + "'").c_str() : "--ctrl", u, label, lo, hi, std::clamp(u, lo, hi));
    warn_once(b);
  }
}

// The state a report carries ("state" in run's and equilibrium's JSON): time, qpos, qvel, act, ctrl.
inline nlohmann::ordered_json state_json(const mjModel* m, const mjData* d) {
  return {{"time", d->time},
          {"qpos", std::vector<double>(d->qpos, d->qpos + m->nq)},
          {"qvel", std::vector<double>(d->qvel, d->qvel + m->nv)},
          {"act", std::vector<double>(d->act, d->act + m->na)},
          {"ctrl", std::vector<double>(d->ctrl, d->ctrl + m->nu)}};
}

// --state F: the "state" of a report F (state_json) into d, refused where F is no such report or
// its sizes are not the model's. (Outside probes CJ and CL: an interrupted run could not be
// continued, and an equilibrium or a run's end state could not be started from without writing a
// keyframe by hand.)
inline void apply_state_file(const mjModel* m, mjData* d, const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("--state: cannot read " + path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    fail("--state: " + path + " is not JSON (" + e.what() + ")");
  }
  if (!j.is_object() || !j.contains("state") || !j["state"].is_object())
    fail("--state: " + path + " has no \"state\" (the JSON of run --json or equilibrium --json has one)");
  const nlohmann::json& st = j["state"];
  auto take = [&](const char* name, int size, mjtNum* into) {
    if (!st.contains(name) || !st[name].is_array()) fail("--state: " + path + ": \"state\" has no array \"" + name + "\"");
    const auto& a = st[name];
    if (static_cast<int>(a.size()) != size)
      fail("--state: " + path + ": " + name + " has " + std::to_string(a.size()) + " values where the model has " +
           std::to_string(size) + " (a report of another model?)");
    for (int i = 0; i < size; ++i) {
      if (!a[i].is_number() || !std::isfinite(a[i].get<double>()))
        fail("--state: " + path + ": " + name + "[" + std::to_string(i) + "] is not a finite number");
      into[i] = a[i].get<double>();
    }
  };
  mj_resetData(m, d);
  take("qpos", m->nq, d->qpos);
  take("qvel", m->nv, d->qvel);
  take("act", m->na, d->act);
  take("ctrl", m->nu, d->ctrl);
  if (!st.contains("time") || !st["time"].is_number() || !std::isfinite(st["time"].get<double>()))
    fail("--state: " + path + ": \"state\" has no finite \"time\"");
  d->time = st["time"].get<double>();
}

// The initial state and the controls: a keyframe (qpos, qvel, act, ctrl) and/or explicit controls.
struct StateOptions {
  std::string key, ctrl, ctrl_file, state_file;

  // schedule: the command takes --ctrl-file too (the ones that simulate a run: run, render, snapshot)
  void add_to(CommandLine& c, bool schedule = false) {
    c.options.push_back(text_option("--key", "K", "start from keyframe K (name or index): qpos, qvel, act, ctrl", key));
    c.options.push_back(text_option(
        "--state", "F",
        "start from the \"state\" (time, qpos, qvel, act, ctrl) of a JSON report F that run --json or equilibrium "
        "--json wrote for this model: continue a run where it ended or was interrupted, or run from an equilibrium",
        state_file));
    c.options.push_back(text_option("--ctrl", "U", "actuator controls: nu numbers separated by commas (applied after --key)", ctrl));
    if (schedule)
      c.options.push_back(text_option(
          "--ctrl-file", "F",
          "controls that change over the run: a CSV file, its header time,<actuator>,... and rows of numbers (# lines "
          "skipped); at every evaluation each named actuator's control is interpolated linearly in the simulated time "
          "between the rows (before the first and after the last: theirs); two rows at one time make a step change "
          "there (the second row's values from that time on, at an evaluation exactly then too: rk4's and "
          "rosenbrock's last stage of the step ending there); actuators without a column keep --key's and --ctrl's",
          ctrl_file));
  }

  void apply(const mj::Scene& s, mj::SceneData& sd) const {
    if (!state_file.empty()) {
      if (!key.empty()) fail("--state and --key both set the initial state: give one");
      apply_state_file(s.m, sd.d, state_file);
    }
    apply_key_and_ctrl(s.m, sd.d, key, ctrl);
    if (!ctrl_file.empty()) install_schedule_file(ctrl_file, s.m, sd.d);
  }
};

// The number of steps of h in `duration` (to the nearest). Refused, naming `what` (the options
// that set it), when a positive duration gives no step, or when it gives more than 1e12 steps
// (a run that would not end, and beyond what a step counter holds).
inline long step_count(double duration, double h, const std::string& what) {
  const double n = duration / h;
  char buf[160];
  if (!(n <= 1e12)) {
    std::snprintf(buf, sizeof buf, "%s: %g s in steps of %g s is %.3g steps, more than 1e12", what.c_str(), duration, h, n);
    fail(buf);
  }
  const long k = std::lround(n);
  if (k < 1 && duration > 0) {
    std::snprintf(buf, sizeof buf, "%s: %g s is less than half a step of %g s: no step would be taken", what.c_str(), duration, h);
    fail(buf);
  }
  return k;
}

}  // namespace cosserat::cli
