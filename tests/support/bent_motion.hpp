// A bent, moving state of a coupled scene for checks against central differences: qpos = q0 + t v,
// qvel = v + t a, with q0_i = 0.6 sin(1.7 i + 0.3) and v_i = cos(2.3 i + 0.5), for models whose
// qpos moves linearly with qvel (hinges, slides, rod strains: nq == nv).
#pragma once

#include <cmath>
#include <vector>

#include "scene.hpp"

namespace cosserat::testing {

struct BentMotion {
  std::vector<double> q0, v;
  explicit BentMotion(const mjModel* m) : q0(m->nq), v(m->nv) {
    for (int i = 0; i < m->nq; ++i) q0[i] = 0.6 * std::sin(1.7 * i + 0.3);
    for (int i = 0; i < m->nv; ++i) v[i] = std::cos(2.3 * i + 0.5);
  }
  // the state at t (qvel = v + t a when a is given, else v), evaluated by mj::forward
  void at(const mj::Scene& s, mj::SceneData& sd, double t, const std::vector<double>* a = nullptr) const {
    for (size_t i = 0; i < q0.size(); ++i) sd.d->qpos[i] = q0[i] + t * v[i];
    for (size_t i = 0; i < v.size(); ++i) sd.d->qvel[i] = v[i] + (a ? t * (*a)[i] : 0.0);
    mj::forward(s, sd);
  }
};

// The angular velocity whose skew matrix is the antisymmetric part of W = dR/dt R^T (a frame's
// spin from central differences of its orientation).
template <class M3>
inline Vec3 spin_of(const M3& W) {
  return 0.5 * Vec3(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1));
}

}  // namespace cosserat::testing
