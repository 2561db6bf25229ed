// The initial state of the commands that simulate or solve (run, compare, equilibrium, linearize,
// render, snapshot): --key and --ctrl, and the step count of a duration.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

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

// The initial state and the controls: a keyframe (qpos, qvel, act, ctrl) and/or explicit controls.
struct StateOptions {
  std::string key, ctrl, ctrl_file;

  // schedule: the command takes --ctrl-file too (the ones that simulate a run: run, render, snapshot)
  void add_to(CommandLine& c, bool schedule = false) {
    c.options.push_back(text_option("--key", "K", "start from keyframe K (name or index): qpos, qvel, act, ctrl", key));
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
