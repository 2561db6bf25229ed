// Swimming measurements of flagellate models (README, "Swimming flagellates"): for each model and
// motor frequency, the swimming speed of the head, the wobble of the head, its counter-rotation
// and the torque the motor needs.
//
//   ./build/flagellate_sweep [--models A.xml,B.xml] [--frequencies 0.25,0.5,1,2,3,4] [--transient 1]
//                            [--periods 3] [--timestep h] [--csv F]
//
// Every actuator gets ctrl = f (the models' motors take the frequency in Hz). After `transient`
// turns of the (first) motor, over `periods` turns, per turn: the head's rotation P and
// displacement d in its own frame. In steady swimming the head moves on a helix whose axis is the
// axis n of P (fixed in the head frame), so
//   speed        |d . n| / (time per turn): the long-run swimming speed of the body "head"
//   forward      the same, signed: > 0 nose first (head first; the nose is at -x of the head)
//   per turn     |d . n|: distance per motor turn (constant for a rigid swimmer at low Re)
//   wobble       RMS angle between the head's long (x) axis and the swimming axis n (the head
//                nods at the motor frequency about a mean tilt)
//   path radius  radius of the head's helical path
//   roll         mean angular velocity of the head about its own axis [Hz] (counter-rotation)
//   torque       mean motor torque (qfrc_actuator on the motor's hinge), per motor
//   motor        mean motor frequency reached (the velocity servo lags the command slightly)
// Pure C++ over the coupling library; no plotting (scripts/plot_flagellate.py draws the CSV).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string t; std::getline(in, t, ',');)
    if (!t.empty()) out.push_back(t);
  return out;
}

struct Result {
  double speed = 0, forward = 0, per_turn = 0, wobble_deg = 0, lateral = 0, roll_hz = 0, torque = 0, motor_hz = 0;
  double wall = 0;
  bool ok = true;
};

Vec3 vec(const mjtNum* p) { return Vec3(p[0], p[1], p[2]); }

// Axis (unit) and angle of a rotation matrix.
void axis_angle(const Mat3& P, Vec3& axis, double& angle) {
  const Eigen::AngleAxisd aa(P);
  axis = aa.axis();
  angle = aa.angle();
}

Result measure(const std::string& path, double f, double transient, double periods, double h) {
  auto s = load_scene(path);
  if (h > 0) s->m->opt.timestep = h;
  const mjModel* m = s->m;
  SceneData sd(*s);
  const int head = mj_name2id(m, mjOBJ_BODY, "head");
  if (head < 0) throw std::runtime_error(path + ": no body named 'head'");
  for (int a = 0; a < m->nu; ++a) sd.d->ctrl[a] = f;
  std::vector<int> motor_dof, motor_qpos;
  for (int a = 0; a < m->nu; ++a)
    if (m->actuator_trntype[a] == mjTRN_JOINT) {
      motor_dof.push_back(m->jnt_dofadr[m->actuator_trnid[2 * a]]);
      motor_qpos.push_back(m->jnt_qposadr[m->actuator_trnid[2 * a]]);
    }
  if (motor_dof.empty()) throw std::runtime_error(path + ": no joint actuator (motor)");
  // periods of the (first) motor's angle, not of the clock: the servo lags the command a little
  const int npts = static_cast<int>(std::lround(periods));
  std::vector<Vec3> pos;      // head position at the period boundaries
  std::vector<Mat3> rot;      // head orientation there
  std::vector<double> time;
  std::vector<std::pair<int, Vec3>> axes;  // head axis (world) at every step, with its turn
  double roll = 0, torque = 0, motor = 0;
  long samples = 0;
  Result r;
  const auto wall0 = std::chrono::steady_clock::now();
  const double theta0 = sd.d->qpos[motor_qpos[0]];
  double prev_turns = 0, prev_t = 0;
  Vec3 prev_p = Vec3::Zero();
  Eigen::Quaterniond prev_q = Eigen::Quaterniond::Identity();
  const long max_steps = std::lround(10 * (transient + periods + 1) / std::abs(f) / m->opt.timestep);
  for (long k = 0; k <= max_steps; ++k) {
    forward(*s, sd);  // current positions and forces
    const double turns = std::abs(sd.d->qpos[motor_qpos[0]] - theta0) / (2 * M_PI);
    const Vec3 p = vec(sd.d->xpos + 3 * head);
    const Eigen::Quaterniond q(sd.d->xquat[4 * head], sd.d->xquat[4 * head + 1], sd.d->xquat[4 * head + 2],
                               sd.d->xquat[4 * head + 3]);
    // a period boundary between the previous step and this one: interpolate
    const double next = transient + static_cast<double>(pos.size());
    if (k > 0 && prev_turns < next && turns >= next) {
      const double w = (next - prev_turns) / (turns - prev_turns);
      pos.push_back((1 - w) * prev_p + w * p);
      rot.push_back(prev_q.slerp(w, q).toRotationMatrix());
      time.push_back((1 - w) * prev_t + w * sd.d->time);
      if (static_cast<int>(pos.size()) > npts) break;
    }
    if (!pos.empty()) {
      mjtNum vel[6];
      mj_objectVelocity(m, sd.d, mjOBJ_BODY, head, vel, 0);
      const Vec3 ax(sd.d->xmat[9 * head], sd.d->xmat[9 * head + 3], sd.d->xmat[9 * head + 6]);
      roll += Vec3(vel[0], vel[1], vel[2]).dot(ax);
      axes.emplace_back(static_cast<int>(pos.size()) - 1, ax);
      for (size_t j = 0; j < motor_dof.size(); ++j)
        torque += sd.d->qfrc_actuator[motor_dof[j]] / motor_dof.size(), motor += sd.d->qvel[motor_dof[j]] / motor_dof.size();
      ++samples;
    }
    prev_turns = turns, prev_t = sd.d->time, prev_p = p, prev_q = q;
    if (step(*s, sd) != Status::Ok) {
      r.ok = false;
      return r;
    }
  }
  if (static_cast<int>(pos.size()) <= npts) throw std::runtime_error(path + ": the motor did not turn");
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  // per motor turn: the head's rotation P and displacement d in its own frame. The head moves on
  // a helix about the axis n of P (fixed in the head frame): the long-run swimming velocity is
  // (d . n) n per turn, and the head's long axis stays at a fixed angle (the wobble) from n.
  double fwd = 0, wob = 0, radius = 0, T = 0;
  std::vector<Vec3> n_world(npts);
  for (int k = 0; k < npts; ++k) {
    const Mat3 P = rot[k].transpose() * rot[k + 1];
    const Vec3 d = rot[k].transpose() * (pos[k + 1] - pos[k]);
    Vec3 n;
    double phi;
    axis_angle(P, n, phi);
    if (phi < 1e-9) n = -Vec3::UnitX();  // no net rotation: along the head's axis
    if (n.x() > 0) n = -n;               // towards the nose (-x of the head)
    const double dn = d.dot(n);
    fwd += dn;
    n_world[k] = rot[k] * n;
    radius += phi > 1e-9 ? (d - dn * n).norm() / (2 * std::sin(phi / 2)) : 0.0;
    T += time[k + 1] - time[k];
  }
  r.forward = fwd / T;
  r.speed = std::abs(r.forward);
  r.per_turn = std::abs(fwd) / npts;
  // wobble: RMS angle between the head's long axis and the swimming axis, over every step
  for (const auto& [k, ax] : axes) {
    if (k >= npts) continue;
    const double a = std::acos(std::clamp(-ax.dot(n_world[k]), -1.0, 1.0));
    wob += a * a;
  }
  r.wobble_deg = std::sqrt(wob / axes.size()) * 180.0 / M_PI;
  r.lateral = radius / npts;
  r.roll_hz = roll / samples / (2 * M_PI);
  r.torque = torque / samples;
  r.motor_hz = motor / samples / (2 * M_PI);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> models = {"models/flagellate_rigid.xml", "models/flagellate.xml"};
  std::vector<double> freqs = {0.25, 0.5, 1, 2, 3, 4};
  double transient = 1, periods = 3, h = 0;
  std::string csv;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    if (a == "--models") models = split(next());
    else if (a == "--frequencies") {
      freqs.clear();
      for (const auto& t : split(next())) freqs.push_back(std::atof(t.c_str()));
    } else if (a == "--transient") transient = std::atof(next().c_str());
    else if (a == "--periods") periods = std::atof(next().c_str());
    else if (a == "--timestep") h = std::atof(next().c_str());
    else if (a == "--csv") csv = next();
    else {
      std::printf(
          "usage: flagellate_sweep [--models A.xml,B.xml] [--frequencies 0.25,0.5,1,2,3,4] [--transient 1] [--periods 3]\n"
          "                        [--timestep h] [--csv F]\n");
      return a == "--help" || a == "-h" ? 0 : 1;
    }
  }
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "model,frequency_hz,speed_m_s,forward_m_s,per_turn_m,wobble_deg,path_radius_m,head_roll_hz,motor_torque_n_m,motor_hz,wall_s\n";
  }
  std::printf("| model | f [Hz] | speed [mm/s] | forward [mm/s] | per turn [mm] | head wobble [deg] | path radius [mm] | head roll [Hz] | motor torque [mN m] | motor [Hz] |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  int status = 0;
  for (const auto& path : models)
    for (double f : freqs) {
      Result r;
      try {
        r = measure(path, f, transient, periods, h);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
      }
      const std::string name = path.substr(path.find_last_of('/') + 1);
      if (!r.ok) {
        std::printf("| %s | %g | diverged | | | | | | | |\n", name.c_str(), f);
        status = 1;
        continue;
      }
      std::printf("| %s | %g | %.4f | %.4f | %.4f | %.2f | %.3f | %.4f | %.4f | %.4f |\n", name.c_str(), f, 1e3 * r.speed, 1e3 * r.forward,
                  1e3 * r.per_turn, r.wobble_deg, 1e3 * r.lateral, r.roll_hz, 1e3 * r.torque, r.motor_hz);
      std::fflush(stdout);
      if (out)
        out << name << "," << f << "," << r.speed << "," << r.forward << "," << r.per_turn << "," << r.wobble_deg << "," << r.lateral << ","
            << r.roll_hz << "," << r.torque << "," << r.motor_hz << "," << r.wall << "\n";
    }
  return status;
}
