// The material point of a rod that touches at a contact: the abscissa (the contact point projected
// on the capsule's axis, as the coupling defines it) and the offset in the cross-section frame; and
// its world pose at another configuration (for central differences of its motion).
#pragma once

#include <algorithm>
#include <vector>

#include "kinematics.hpp"
#include "scene.hpp"

namespace cosserat::testing {

struct MaterialPoint {
  int rod;
  double X;
  Vec3 offset;
};

inline MaterialPoint contact_point(const mj::Scene& s, const mj::SceneData& sd, const mjContact& con, int g) {
  const int r = s.geom_rod[g];
  const mj::RodGeomDecl& gd = s.rods[r].decl.geoms[s.geom_index[g]];
  const Vec3 p(con.pos[0], con.pos[1], con.pos[2]);
  const Vec3 gc(sd.d->geom_xpos[3 * g], sd.d->geom_xpos[3 * g + 1], sd.d->geom_xpos[3 * g + 2]);
  const Vec3 ax(sd.d->geom_xmat[9 * g + 2], sd.d->geom_xmat[9 * g + 5], sd.d->geom_xmat[9 * g + 8]);
  const double t = std::clamp(0.5 + (p - gc).dot(ax) / (2.0 * s.m->geom_size[3 * g + 1]), 0.0, 1.0);
  const double X = gd.X_begin + t * (gd.X_end - gd.X_begin);
  const SE3 gX = rod_pose(s.rods[r].model, sd.rod[r], 0, X);
  return {r, X, gX.R.transpose() * (p - gX.u)};
}

// World pose of that material point's frame at configuration qpos.
inline SE3 material_pose(const mj::Scene& s, const std::vector<mjtNum>& qpos, const MaterialPoint& mp) {
  mj::SceneData sd(s);
  mju_copy(sd.d->qpos, qpos.data(), s.m->nq);
  mj::fwd_position(s, sd);
  SE3 g = rod_pose(s.rods[mp.rod].model, sd.rod[mp.rod], 0, mp.X);
  g.u += g.R * mp.offset;
  return g;
}

}  // namespace cosserat::testing
