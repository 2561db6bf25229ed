// A controller written for MuJoCo, unchanged: mjcb_control drives a scene with a soft elbow.
//
//   build/examples/controller [OUT.csv]     (default: controller.csv in the working directory)
//
// models/hybrid_arm.xml: rigid links on hinge position servos with a soft elbow (a Cosserat rod)
// between them. The callback swings the shoulder's target sinusoidally; mj::step calls it at every
// evaluation of the dynamics, at that evaluation's time, as mj_step does. The program writes the
// gripper site's height and the elbow's mid-point curvature to a CSV file, and prints how far the
// gripper lags its rigid-arm position (the soft elbow's sag and ringing).
#include <cmath>
#include <cstdio>
#include <fstream>

#include "scene.hpp"

using namespace cosserat;

// The shipped models' directory: examples/CMakeLists.txt defines it; a copy built elsewhere reads
// them from ./models (or define COSSERAT_MODELS_DIR="/path/to/models" when compiling).
#ifndef COSSERAT_MODELS_DIR
#define COSSERAT_MODELS_DIR "models"
#endif

namespace {
int shoulder = -1;  // actuator id, found after loading

// MuJoCo's control callback: a 0.5 Hz, 0.4 rad swing of the shoulder's position target.
void swing(const mjModel*, mjData* d) { d->ctrl[shoulder] = 0.4 * std::sin(2 * M_PI * 0.5 * d->time); }
}  // namespace

int main(int argc, char** argv) {
  const char* out = argc > 1 ? argv[1] : "controller.csv";
  auto scene = mj::load_scene(COSSERAT_MODELS_DIR "/hybrid_arm.xml");  // throws mj::LoadError
  mj::SceneData data(*scene);
  const mjModel* m = scene->m;
  mjData* d = data.d;
  shoulder = mj_name2id(m, mjOBJ_ACTUATOR, "shoulder");
  const int grip = mj_name2id(m, mjOBJ_SITE, "grip");
  const int shoulder_joint = mj_name2id(m, mjOBJ_JOINT, "shoulder");
  if (shoulder < 0 || grip < 0 || shoulder_joint < 0) {
    std::fprintf(stderr, "hybrid_arm.xml lacks the shoulder actuator or the grip site\n");
    return 1;
  }
  mjcb_control = swing;

  std::ofstream csv(out);
  csv << "t,shoulder_angle,grip_z,elbow_curvature\n";
  // a rigid elbow would put the grip at this height for a shoulder angle a (the upper link, the
  // elbow's 0.12 m and the forearm to the grip site, 0.17 + 0.05 m, in one straight line)
  const double base_z = 0.1, arm = 0.2 + 0.12 + 0.22;
  double max_lag = 0.0;
  const long steps = std::lround(4.0 / m->opt.timestep);  // two periods
  for (long k = 0; k < steps; ++k) {
    if (mj::step(*scene, data) == Status::Diverged) {
      std::fprintf(stderr, "diverged: %s (%s)\n", data.warning.c_str(),
                   mj::divergence_hint(*scene, data, scene->integrator).c_str());
      return 1;
    }
    if (k % 10 == 0) {
      mj::fwd_position(*scene, data);  // the end state's poses (a step leaves its start's sensors)
      const double a = d->qpos[m->jnt_qposadr[shoulder_joint]];
      const double z = d->site_xpos[3 * grip + 2];
      const Vec6 xi = mj::rod_strain(*scene, data, 0, 0.06);  // [kx ky kz px py pz] at mid-elbow
      csv << d->time << ',' << a << ',' << z << ',' << xi.head<3>().norm() << '\n';
      max_lag = std::max(max_lag, std::abs(base_z + arm * std::cos(a) - z));
    }
  }
  mjcb_control = nullptr;
  std::printf("shoulder swung 2 periods; the gripper deviated up to %.1f mm from a rigid arm's height; %s written\n",
              1e3 * max_lag, out);
  return 0;
}
