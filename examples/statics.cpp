// Static equilibrium and small vibrations of a scene, against the beam formulas.
//
//   build/examples/statics
//
// models/cantilever.xml: a rod of EI = 0.785 N m^2, 0.5 m long, clamped at one end, with a 0.05 kg
// weight at the other. mj::equilibrium solves for the rest shape under gravity (Newton's method
// with load continuation), mj::linearize gives the vibration modes about it. The program prints
// the rod tip's drop against the small-deflection estimate w L^4/8EI + P L^3/3EI + P e L^2/2EI (the
// rod's own weight w per length, the weight P hung e = 20 mm beyond the tip; the exact elastica
// drops a little less, the deflection being 11% of L) and the first frequency against Rayleigh's
// estimate.
#include <cmath>
#include <cstdio>

#include "scene.hpp"
#include "scene_statics.hpp"

using namespace cosserat;

// The shipped models' directory: examples/CMakeLists.txt defines it; a copy built elsewhere reads
// them from ./models (or define COSSERAT_MODELS_DIR="/path/to/models" when compiling).
#ifndef COSSERAT_MODELS_DIR
#define COSSERAT_MODELS_DIR "models"
#endif

int main() {
  auto scene = mj::load_scene(COSSERAT_MODELS_DIR "/cantilever.xml");
  mj::SceneData data(*scene);

  const mj::SceneStaticsResult eq = mj::equilibrium(*scene, data);
  if (!eq.converged) {
    std::fprintf(stderr, "no equilibrium: %s\n", eq.message.c_str());
    return 1;
  }
  const double E = 1e8, r = 0.01, L = 0.5, rho = 1000, g = 9.81, tip_mass = 0.05, e = 0.02;
  const double drop = 1.0 - mj::rod_frame(*scene, data, 0, L).u.z();  // clamped at z = 1 m
  const double EI = E * M_PI * std::pow(r, 4) / 4, w = rho * M_PI * r * r * g, P = tip_mass * g;
  const double linear = w * std::pow(L, 4) / (8 * EI) + P * std::pow(L, 3) / (3 * EI) + P * e * L * L / (2 * EI);
  std::printf("equilibrium (%s, %d iterations): rod tip %.2f mm below the clamp; small-deflection theory %.2f mm\n",
              eq.method.c_str(), eq.iterations, 1e3 * drop, 1e3 * linear);

  const mj::SceneLinearization lin = mj::linearize(*scene, data);
  // Rayleigh: the tip mass plus 0.24 of the rod's mass on the tip's stiffness 3EI/L^3
  const double rod_mass = rho * M_PI * r * r * L;
  const double rayleigh = std::sqrt(3 * EI / std::pow(L, 3) / (tip_mass + 0.2357 * rod_mass)) / (2 * M_PI);
  std::printf("first two frequencies %.3f Hz and %.3f Hz (the bending pair); Rayleigh's estimate %.3f Hz\n",
              lin.frequencies_hz(0), lin.frequencies_hz(1), rayleigh);
  return 0;
}
