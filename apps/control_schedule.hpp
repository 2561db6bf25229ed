// --ctrl-file: actuator controls that change over a run (run, render, snapshot), read from a CSV
// file and set at every evaluation of the dynamics through MuJoCo's control callback, as a program
// of one's own would (outside probe BL: grasping and then lifting needed a C++ program, the
// command line holding --ctrl constant).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli.hpp"
#include "scene.hpp"

namespace cosserat::cli {

// Knots (time, controls of some actuators): between two knots the controls are interpolated
// linearly in d->time, before the first and after the last they are the first's and the last's.
// Two knots at one time make a step change: the first's value up to it, the second's from it on
// (upper_bound picks the second at that time). Actuators without a column keep their controls
// (--key, --ctrl).
struct ControlSchedule {
  std::vector<int> actuators;          // the columns' actuator ids
  std::vector<double> times;           // increasing, at most two knots at one time
  std::vector<std::vector<double>> u;  // per knot, per column

  void apply(mjData* d) const {
    if (times.empty()) return;
    const double t = d->time;
    const size_t hi = std::upper_bound(times.begin(), times.end(), t) - times.begin();
    const size_t a = hi == 0 ? 0 : hi - 1, b = std::min(hi, times.size() - 1);
    const double w = a == b ? 0.0 : (t - times[a]) / (times[b] - times[a]);
    for (size_t c = 0; c < actuators.size(); ++c) d->ctrl[actuators[c]] = (1.0 - w) * u[a][c] + w * u[b][c];
  }
};

// Splits a CSV line at commas (no quoting: names and numbers only), trimming spaces.
inline std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  for (std::string f; std::getline(in, f, ',');) {
    const size_t b = f.find_first_not_of(" \t\r"), e = f.find_last_not_of(" \t\r");
    out.push_back(b == std::string::npos ? std::string() : f.substr(b, e - b + 1));
  }
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

// Reads F: a header "time,<actuator name>,..." (#k for the k-th actuator where it has no name) and
// rows of numbers, lines starting with '#' and blank lines skipped. Every mistake is a failure naming the file and line.
inline ControlSchedule read_control_schedule(const std::string& path, const mjModel* m) {
  std::ifstream f(path);
  if (!f) fail("--ctrl-file: cannot read " + path);
  ControlSchedule s;
  std::string line;
  int lineno = 0;
  bool header = false;
  auto line_of = [&] { return "--ctrl-file: " + path + ":" + std::to_string(lineno); };
  auto where = [&] { return line_of() + ": "; };
  while (std::getline(f, line)) {
    ++lineno;
    if (lineno == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 byte order mark
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::vector<std::string> fields = csv_fields(line);
    if (!header) {
      if (fields.empty() || fields[0] != "time")
        fail(where() + "the first line names the columns: time,<actuator>,... (got '" + line + "')");
      if (fields.size() < 2) fail(where() + "no actuator column after 'time'");
      for (size_t c = 1; c < fields.size(); ++c) {
        int id = mj_name2id(m, mjOBJ_ACTUATOR, fields[c].c_str());
        // an unnamed actuator by its index, as the error below lists it (outside probe BO)
        if (id < 0 && fields[c].size() > 1 && fields[c][0] == '#' &&
            fields[c].find_first_not_of("0123456789", 1) == std::string::npos) {
          const int k = std::atoi(fields[c].c_str() + 1);
          if (k < m->nu && !mj_id2name(m, mjOBJ_ACTUATOR, k)) id = k;
        }
        if (id < 0) {
          std::string names;
          for (int a = 0; a < m->nu; ++a) {
            const char* n = mj_id2name(m, mjOBJ_ACTUATOR, a);
            if (!names.empty()) names += ", ";
            if (n) names += n;
            else names.append("#").append(std::to_string(a));
          }
          fail(where() + "no actuator '" + fields[c] + "' in the model (actuators: " + (names.empty() ? "none" : names) +
               ")");
        }
        if (std::find(s.actuators.begin(), s.actuators.end(), id) != s.actuators.end())
          fail(where() + "actuator '" + fields[c] + "' has two columns");
        s.actuators.push_back(id);
      }
      header = true;
      continue;
    }
    if (fields.size() != s.actuators.size() + 1)
      fail(where() + std::to_string(fields.size()) + " values, the header has " + std::to_string(s.actuators.size() + 1));
    std::vector<double> row;
    for (const auto& x : fields) {
      const double v = parse_number(line_of(), x);
      if (!(std::abs(v) < mjMAXVAL)) fail(where() + "'" + x + "' is not below 1e10 in magnitude (MuJoCo ignores such controls)");
      row.push_back(v);
    }
    // two rows at one time: a step change there (the second row's from that time on); not three
    const size_t n = s.times.size();
    const bool jump = n > 0 && row[0] == s.times.back() && !(n > 1 && s.times[n - 2] == s.times.back());
    if (n > 0 && !(row[0] > s.times.back()) && !jump)
      fail(where() + "time " + format_g(row[0]) + " does not follow " + format_g(s.times.back()) +
           ": times must increase (two rows at one time make a step change there)");
    s.times.push_back(row[0]);
    s.u.emplace_back(row.begin() + 1, row.end());
  }
  if (!header) fail("--ctrl-file: " + path + ": empty (the first line names the columns: time,<actuator>,...)");
  if (s.times.empty()) fail("--ctrl-file: " + path + ": no rows after the header");
  // MuJoCo clamps a limited control unless the model disables it: say so, once per actuator
  if (!(m->opt.disableflags & mjDSBL_CLAMPCTRL))
    for (size_t c = 0; c < s.actuators.size(); ++c) {
      const int a = s.actuators[c];
      if (!m->actuator_ctrllimited[a]) continue;
      const double lo = m->actuator_ctrlrange[2 * a], hi = m->actuator_ctrlrange[2 * a + 1];
      for (size_t k = 0; k < s.times.size(); ++k)
        if (s.u[k][c] < lo || s.u[k][c] > hi) {
          const char* name = mj_id2name(m, mjOBJ_ACTUATOR, a);
          std::string label = name ? name : "#";
          if (!name) label.append(std::to_string(a));
          warn_once("--ctrl-file: " + format_g(s.u[k][c]) + " at t = " + format_g(s.times[k]) + " for actuator '" + label +
                    "' is outside its ctrlrange [" + format_g(lo) + ", " + format_g(hi) + "]: MuJoCo clamps it");
          break;
        }
    }
  return s;
}

// The schedule MuJoCo's control callback applies (one per process: the commands that take
// --ctrl-file run one simulation).
inline const ControlSchedule*& active_schedule() {
  static const ControlSchedule* s = nullptr;
  return s;
}

inline void apply_active_schedule(const mjModel*, mjData* d) {
  if (active_schedule()) active_schedule()->apply(d);
}

// Reads the schedule of `path` and sets its controls now and at every later evaluation
// (mjcb_control).
inline void install_schedule_file(const std::string& path, const mjModel* m, mjData* d) {
  static ControlSchedule schedule;
  schedule = read_control_schedule(path, m);
  active_schedule() = &schedule;
  mjcb_control = apply_active_schedule;
  schedule.apply(d);
}

}  // namespace cosserat::cli
