// MuJoCo's features that read a rod's sites or mass, made to read the rod's material
// (scene_sites.hpp).
#include "scene_sites.hpp"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "dynamics.hpp"
#include "kinematics.hpp"
#include "strain.hpp"

namespace cosserat::mj {

namespace {

using Mat3r = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;  // MuJoCo's xmat layout

// A rod site whose material point MuJoCo does not move correctly (rigidly with its section's proxy:
// right only on rigid sections, whose sites RodBinding::site_fixed holds).
bool moving_rod_site(const Scene& s, int type, int id) {
  return type == mjOBJ_SITE && id >= 0 && s.site_rod[id] >= 0 &&
         !s.rods[s.site_rod[id]].site_fixed[s.site_index[id]].fixed;
}

// MuJoCo's cutoff of a sensor's data (engine_sensor.c's apply_cutoff), for the sensors the step
// evaluates again: real values are clipped to [-cutoff, cutoff], positive ones (touch,
// rangefinder) to cutoff.
void apply_cutoff(const mjModel* m, int sensor, mjtNum* out) {
  const mjtNum cut = m->sensor_cutoff[sensor];
  if (cut <= 0) return;
  for (int e = 0; e < m->sensor_dim[sensor]; ++e) {
    if (m->sensor_datatype[sensor] == mjDATATYPE_REAL) out[e] = std::clamp(out[e], -cut, cut);
    else if (m->sensor_datatype[sensor] == mjDATATYPE_POSITIVE) out[e] = std::min(out[e], cut);
  }
}

// MuJoCo 2.2's sensor noise (<flag sensornoise="enable"/>, a sensor's `noise`: a standard
// deviation), added again to the data the step evaluates again, as engine_sensor.c's add_noise
// adds it: Gaussian noise on real values, on positive ones where they are
// positive (kept at or above 0), on an axis (then normalised), and a random rotation of a
// quaternion by a Gaussian angle about a random axis. (Outside probe AN: these sensors had come
// out noise-free beside MuJoCo's noisy ones.)
void apply_noise(const mjModel* m, int sensor, mjtNum* out) {
  const mjtNum noise = m->sensor_noise[sensor];
  if (!(m->opt.enableflags & mjENBL_SENSORNOISE) || noise <= 0) return;
  const int dim = m->sensor_dim[sensor];
  switch (m->sensor_datatype[sensor]) {
    case mjDATATYPE_REAL:
      for (int e = 0; e < dim; ++e) out[e] += noise * mju_standardNormal(nullptr);
      break;
    case mjDATATYPE_POSITIVE:
      for (int e = 0; e < dim; ++e)
        if (out[e] > 0) out[e] = std::max(0.0, out[e] + noise * mju_standardNormal(nullptr));
      break;
    case mjDATATYPE_AXIS:
      for (int e = 0; e < 3; ++e) out[e] += noise * mju_standardNormal(nullptr);
      mju_normalize3(out);
      break;
    case mjDATATYPE_QUATERNION: {
      mjtNum axis[3], q[4], res[4];
      for (int e = 0; e < 3; ++e) axis[e] = mju_standardNormal(nullptr);
      mju_normalize3(axis);
      mju_axisAngle2Quat(q, axis, noise * mju_standardNormal(nullptr));
      mju_mulQuat(res, out, q);
      mju_normalize4(res);
      mju_copy4(out, res);
      break;
    }
    default:
      break;
  }
}

// What MuJoCo 2.2 does to a sensor's data after computing it: the noise, then the cutoff (outside
// probe AO: the other order had let noisy readings past their cutoff).
void finish_sensor(const mjModel* m, int sensor, mjtNum* out) {
  apply_noise(m, sensor, out);
  apply_cutoff(m, sensor, out);
}

// A rod site as above, or any rod capsule (rigid sections' too): MuJoCo orients them from their
// proxy's quaternion and their compiled frame (a capsule's from its fromto, which points its z
// axis the other way than the rod's chord frame), the rod places them (site_xmat, geom_xmat).
bool rod_placed_frame(const Scene& s, int type, int id) {
  if (type == mjOBJ_GEOM && id >= 0) return s.geom_rod[id] >= 0;
  return moving_rod_site(s, type, id);
}

// The world orientation of a frame sensor's object (MuJoCo's object types of frame sensors) as a
// quaternion of its frame matrix, which the rod sets for its sites and capsules. Of the two
// quaternions of a rotation, the one nearer the carrying body's (xquat, continuous in time as
// MuJoCo's own composition body * local is): it changes sign only where the object turns more than
// half a turn from its body, not wherever mju_mat2Quat's choice of sign does (a rod site's framequat
// jumped to its negative on a tumbling body, outside probe P).
void frame_quat(const mjModel* m, const mjData* d, int type, int id, mjtNum q[4]) {
  const mjtNum* mat = type == mjOBJ_XBODY    ? d->xmat + 9 * id
                      : type == mjOBJ_BODY   ? d->ximat + 9 * id
                      : type == mjOBJ_GEOM   ? d->geom_xmat + 9 * id
                      : type == mjOBJ_SITE   ? d->site_xmat + 9 * id
                      : type == mjOBJ_CAMERA ? d->cam_xmat + 9 * id
                                             : nullptr;
  if (!mat) {
    q[0] = 1, q[1] = q[2] = q[3] = 0;
    return;
  }
  mju_mat2Quat(q, mat);
  const int body = type == mjOBJ_GEOM ? m->geom_bodyid[id]
                   : type == mjOBJ_SITE ? m->site_bodyid[id]
                   : type == mjOBJ_CAMERA ? m->cam_bodyid[id]
                                          : id;
  if (mju_dot(q, d->xquat + 4 * body, 4) < 0) mju_scl(q, q, -1, 4);
}

// Scene::rod_quat_sensors: the object's orientation, relative to the reference frame's if it has
// one (MuJoCo's neg(ref) * obj), from the frames' matrices.
void patch_quat_sensors(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (int i : s.rod_quat_sensors) {
    mjtNum obj[4], ref[4];
    frame_quat(m, d, m->sensor_objtype[i], m->sensor_objid[i], obj);
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    if (m->sensor_refid[i] < 0) {
      mju_copy4(out, obj);
    } else {
      frame_quat(m, d, m->sensor_reftype[i], m->sensor_refid[i], ref);
      mju_negQuat(ref, ref);
      mju_mulQuat(out, ref, obj);
    }
    finish_sensor(m, i, out);
  }
}

// Whether body b is one of rod r's proxies or helpers (the bodies carrying its capsules).
bool rod_body(const Scene& s, int r, int b) {
  return b > s.rods[r].base_body && b <= s.rods[r].proxy_body.back();
}

// Scene::rod_touch_sensors: MuJoCo's touch sensor (the normal forces of active contacts whose
// force points into the site's zone) with the whole rod as the site's body.
void patch_touch_sensors(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (const auto& [i, r] : s.rod_touch_sensors) {
    const int site = m->sensor_objid[i];
    // the rod's capsules, and the site's own body's geoms as MuJoCo counts them (the base site's
    // body: outside probe AO, a hub's contacts had been lost)
    const int own = m->body_weldid[m->site_bodyid[site]];
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    out[0] = 0;
    for (int j = 0; j < d->ncon; ++j) {
      const mjContact& con = d->contact[j];
      const int b1 = m->geom_bodyid[con.geom1], b2 = m->geom_bodyid[con.geom2];
      const bool on1 = rod_body(s, r, b1) || m->body_weldid[b1] == own, on2 = rod_body(s, r, b2) || m->body_weldid[b2] == own;
      if (con.efc_address < 0 || (!on1 && !on2)) continue;
      mjtNum force[6], ray[3];
      mj_contactForce(m, d, j, force);
      if (force[0] <= 0) continue;
      mju_scl3(ray, con.frame, force[0]);
      mju_normalize3(ray);
      if (!on1) mju_scl3(ray, ray, -1);  // the rod is the contact's second body
      if (mju_rayGeom(d->site_xpos + 3 * site, d->site_xmat + 9 * site, m->site_size + 3 * site, con.pos, ray,
                      m->site_type[site]) >= 0)
        out[0] += force[0];
    }
    finish_sensor(m, i, out);
  }
}

// Scene::rod_rangefinders: MuJoCo's rangefinder (mj_ray along the site's z axis, the site's body
// excluded), continued through the capsules of the site's rod that contain the site.
void patch_rangefinders(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (const auto& [i, r] : s.rod_rangefinders) {
    const int site = m->sensor_objid[i];
    const mjtNum* p0 = d->site_xpos + 3 * site;
    const mjtNum dir[3] = {d->site_xmat[9 * site + 2], d->site_xmat[9 * site + 5], d->site_xmat[9 * site + 8]};
    mjtNum p[3] = {p0[0], p0[1], p0[2]}, travelled = 0, dist = -1;
    for (size_t pass = 0; pass <= s.rods[r].geom_id.size(); ++pass) {
      int g = -1;
      dist = mj_ray(m, d, p, dir, nullptr, 1, m->site_bodyid[site], &g);
      if (dist < 0 || g < 0 || s.geom_rod[g] != r) break;
      // a capsule of the rod: the site's own if the site lies in it (then go on from where the ray
      // leaves it), else an obstacle like any other
      const mjtNum* a = d->geom_xpos + 3 * g;
      const Vec3 axis(d->geom_xmat[9 * g + 2], d->geom_xmat[9 * g + 5], d->geom_xmat[9 * g + 8]);
      const Vec3 rel = Vec3(p0[0], p0[1], p0[2]) - Vec3(a[0], a[1], a[2]);
      const double half = m->geom_size[3 * g + 1];
      const double along = std::clamp(rel.dot(axis), -half, half);
      if ((rel - along * axis).norm() > m->geom_size[3 * g]) break;
      const double step = dist + 1e-9 * (1.0 + dist);
      for (int e = 0; e < 3; ++e) p[e] += step * dir[e];
      travelled += step;
      dist = -1;
    }
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    out[0] = dist < 0 ? -1 : travelled + dist;
    finish_sensor(m, i, out);
  }
}

// The part of rod r that body b's subtree holds, as mass nodes of the rod's model: all of it where
// the rod's base body is in the subtree; where b is the proxy of section i, or one of its helpers
// (the proxies stand at the sections' ends, the rod beyond them hanging below), the nodes beyond
// section i's end and, with the Gauss-Lobatto rule, the next section's share of the node at that
// end, which both sections' stretches share; none otherwise. (Outside probe BP: subtree sensors on
// a section's proxy had counted no rod at all, reading a rod section moving at 1.6 m/s at rest.)
struct RodPart {
  int first = -1;          // first node counted whole; -1: none of the rod
  int shared = -1;         // a node counted in part
  double fraction = 0.0;   // of the shared node's mass
};
RodPart rod_part_in_subtree(const Scene& s, int r, int b) {
  const RodBinding& rb = s.rods[r];
  if (is_descendant(s.m, rb.base_body, b)) return {0, -1, 0.0};
  for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
    const auto& helpers = rb.helper_body[i];
    if (rb.proxy_body[i] != b && std::find(helpers.begin(), helpers.end(), b) == helpers.end()) continue;
    const cosserat::Model& m = rb.model;
    const cosserat::Section& sec = m.sections[i];
    RodPart part{sec.end_node + 1, -1, 0.0};
    if (i + 1 < m.sections.size()) {
      const cosserat::Section& next = m.sections[i + 1];
      const double here = sec.end_weight * sec.length * sec.material.density;
      const double beyond = next.end_weight * next.length * next.material.density;
      if (beyond > 0) part.shared = sec.end_node, part.fraction = beyond / (here + beyond);
    }
    return part;
  }
  return {};
}

// Body b's subtree with the rods hanging in it (their mass lives in the solver): its mass, centre of
// mass and, with `velocities`, the linear velocity of that centre and the angular momentum about
// it, from MuJoCo's rigid-body subtree quantities and the rods' nodes in it (rod_part_in_subtree).
struct Subtree {
  double mass = 0.0;
  Vec3 com, linvel, angmom;
};
Subtree subtree_with_rods(const Scene& s, const SceneData& sd, int b, bool velocities) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  const double M0 = m->body_subtreemass[b];
  const Vec3 c0(d->subtree_com[3 * b], d->subtree_com[3 * b + 1], d->subtree_com[3 * b + 2]);
  Subtree st;
  st.mass = M0;
  Vec3 mc = M0 * c0;
  Vec3 P = Vec3::Zero(), L_origin = Vec3::Zero();  // the rods' momentum, and angular momentum about the origin
  for (size_t r = 0; r < s.rods.size(); ++r) {
    const RodPart part = rod_part_in_subtree(s, static_cast<int>(r), b);
    if (part.first < 0) continue;
    const cosserat::Model& rm = s.rods[r].model;
    const cosserat::Data& rd = sd.rod[r];
    auto add = [&](int k, double w) {  // node k, a fraction w of it
      Vec3 com;
      const double mass = w * cosserat::node_mass(rm, rd, k, &com);
      if (mass <= 0) return;
      st.mass += mass;
      mc += mass * com;
      if (velocities) {
        const Vec6 h = w * cosserat::node_momentum(rm, rd, k);
        P += h.tail<3>();
        L_origin += h.head<3>();
      }
    };
    if (part.shared >= 0) add(part.shared, part.fraction);
    for (int k = part.first; k < static_cast<int>(rm.nodes.size()); ++k) add(k, 1.0);
  }
  st.com = st.mass > 0 ? Vec3(mc / st.mass) : c0;
  if (!velocities) return st;
  const Vec3 v0(d->subtree_linvel[3 * b], d->subtree_linvel[3 * b + 1], d->subtree_linvel[3 * b + 2]);
  const Vec3 P0 = M0 * v0;
  st.linvel = st.mass > 0 ? Vec3((P0 + P) / st.mass) : v0;
  st.angmom = Vec3(d->subtree_angmom[3 * b], d->subtree_angmom[3 * b + 1], d->subtree_angmom[3 * b + 2]) +
              (c0 - st.com).cross(P0) + L_origin - st.com.cross(P);
  return st;
}

// World-frame velocity of an object's frame in MuJoCo's layout (angular, linear): mj_objectVelocity,
// plus, for a rod site, the difference between its material point's velocity and MuJoCo's.
void object_velocity(const Scene& s, const SceneData& sd, int type, int id, mjtNum xvel[6]) {
  mj_objectVelocity(s.m, sd.d, type, id, xvel, 0);
  if (!moving_rod_site(s, type, id)) return;
  thread_local SectionCols dJ;  // scratch: no heap memory
  const mjtNum* p = sd.d->site_xpos + 3 * id;
  const int col0 = site_correction(s, sd, id, Vec3(p[0], p[1], p[2]), dJ);
  for (int c = 0; c < dJ.cols(); ++c) {
    const double qd = sd.d->qvel[col0 + c];
    for (int e = 0; e < 3; ++e) {
      xvel[e] += dJ(3 + e, c) * qd;  // dJ: linear rows, then angular
      xvel[3 + e] += dJ(e, c) * qd;
    }
  }
}

// An object's frame as MuJoCo's sensors read it (engine_sensor.c's get_xpos_xmat: a body's
// inertial frame, an xbody's own).
void object_frame(const mjData* d, int type, int id, const mjtNum** pos, const mjtNum** mat) {
  switch (type) {
    case mjOBJ_XBODY: *pos = d->xpos + 3 * id, *mat = d->xmat + 9 * id; break;
    case mjOBJ_BODY: *pos = d->xipos + 3 * id, *mat = d->ximat + 9 * id; break;
    case mjOBJ_GEOM: *pos = d->geom_xpos + 3 * id, *mat = d->geom_xmat + 9 * id; break;
    case mjOBJ_CAMERA: *pos = d->cam_xpos + 3 * id, *mat = d->cam_xmat + 9 * id; break;
    default: *pos = d->site_xpos + 3 * id, *mat = d->site_xmat + 9 * id; break;
  }
}

// Scene::rod_velocity_sensors again, as mj_sensorVel computes them (velocimeter and gyro in the
// site's frame; framelinvel and frameangvel in the world or relative to a reference frame), with
// the rod sites' material velocities, then MuJoCo's cutoff of real-valued data.
void patch_velocity_sensors(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (int i : s.rod_velocity_sensors) {
    const int type = m->sensor_type[i], objtype = m->sensor_objtype[i], objid = m->sensor_objid[i];
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    mjtNum xvel[6];
    object_velocity(s, sd, objtype, objid, xvel);
    if (type == mjSENS_VELOCIMETER || type == mjSENS_GYRO) {
      mju_mulMatTVec(out, d->site_xmat + 9 * objid, type == mjSENS_GYRO ? xvel : xvel + 3, 3, 3);
    } else {
      if (const int refid = m->sensor_refid[i]; refid >= 0) {
        const int reftype = m->sensor_reftype[i];
        const mjtNum *pos, *mat, *pos_ref, *mat_ref;
        object_frame(d, objtype, objid, &pos, &mat);
        object_frame(d, reftype, refid, &pos_ref, &mat_ref);
        mjtNum xvel_ref[6], rel[6], rvec[3], cross[3];
        object_velocity(s, sd, reftype, refid, xvel_ref);
        mju_sub(rel, xvel, xvel_ref, 6);
        mju_sub3(rvec, pos, pos_ref);  // the rotating reference frame's share of the linear velocity
        mju_cross(cross, rvec, xvel_ref);
        mju_addTo3(rel + 3, cross);
        mju_mulMatTVec(xvel, mat_ref, rel, 3, 3);
        mju_mulMatTVec(xvel + 3, mat_ref, rel + 3, 3, 3);
      }
      mju_copy3(out, type == mjSENS_FRAMELINVEL ? xvel + 3 : xvel);
    }
    finish_sensor(m, i, out);
  }
}

// The motion of the cross-section of rod r at X in its section si: its world pose, and its twist and
// acceleration in its own frame, the acceleration counting gravity as MuJoCo's cacc does (the world
// accelerates by -g). From the section's start frame (the rod's base body or the previous section's
// proxy, whose cvel and cacc MuJoCo computes exactly: the patched cdof and cdof_dot) and the
// section's own motion: the twist at X is eta_X = Ad^-1_G eta_s + psi, psi = J qvel (section_jacobian's
// J, G the pose of X in the start frame), and its rate Ad^-1_G eta_s' + J qacc + Jdot qvel
// - ad_psi Ad^-1_G eta_s.
struct CrossSectionMotion {
  SE3 pose;
  Vec6 eta, acc;
};
CrossSectionMotion cross_section_motion(const Scene& s, const SceneData& sd, int r, int si, double X) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  const RodBinding& rb = s.rods[r];
  const cosserat::Data& rd = sd.rod[r];
  Mat6X& J = sd.scratch[r].section_J[si];
  Mat6X& Jdot = sd.scratch[r].section_Jdot[si];
  SE3 G;
  section_jacobian(rb.model, rd, 0, X, J, &Jdot, &G, si);
  const int start = si == 0 ? rb.base_body : rb.proxy_body[si - 1];
  const SE3 gs = anchor_pose(rd, rb.model.sections[si].start_node);
  const SE3 C = com_frame(gs, d->subtree_com + 3 * m->body_rootid[start]);
  const Vec6 eta_s = Ad_inv_apply(G, Ad_inv_apply(C, Eigen::Map<const Vec6>(d->cvel + 6 * start)));
  const Vec6 acc_s = Ad_inv_apply(G, Ad_inv_apply(C, Eigen::Map<const Vec6>(d->cacc + 6 * start)));
  const int dof0 = rb.dof0 + rb.model.sections[si].dof0;
  Vec6 psi = Vec6::Zero(), acc = acc_s;
  for (int k = 0; k < J.cols(); ++k) {
    psi += J.col(k) * d->qvel[dof0 + k];
    acc += J.col(k) * d->qacc[dof0 + k] + Jdot.col(k) * d->qvel[dof0 + k];
  }
  acc -= ad_apply(psi, eta_s);
  return {gs * G, eta_s + psi, acc};
}

// World-frame acceleration of a rod site's material point in MuJoCo's layout (angular, linear), its
// linear part counting gravity as MuJoCo's cacc does: its cross-section's (cross_section_motion) at
// the site's offset.
void rod_site_acceleration(const Scene& s, const SceneData& sd, int site, mjtNum out[6]) {
  const int r = s.site_rod[site];
  const RodSiteDecl& sdl = s.rods[r].decl.sites[s.site_index[site]];
  const CrossSectionMotion cs = cross_section_motion(s, sd, r, s.site_section[site], sdl.X);
  // the point at the site's offset in the cross-section frame, rotated to the world
  const Vec3 w = cs.eta.head<3>(), v = cs.eta.tail<3>(), wd = cs.acc.head<3>();
  const Vec3 a = cs.acc.tail<3>() + wd.cross(sdl.pos) + w.cross(v + w.cross(sdl.pos));
  const Vec3 wd_world = cs.pose.R * wd, a_world = cs.pose.R * a;
  for (int e = 0; e < 3; ++e) {
    out[e] = wd_world(e);
    out[3 + e] = a_world(e);
  }
}

// Scene::rod_acceleration_sensors again, as mj_sensorAcc computes them (accelerometer in the site's
// frame, framelinacc and frameangacc in the world), with the material point's acceleration, then
// MuJoCo's cutoff.
void patch_acceleration_sensors(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (int i : s.rod_acceleration_sensors) {
    const int type = m->sensor_type[i], site = m->sensor_objid[i];
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    mjtNum acc[6];
    rod_site_acceleration(s, sd, site, acc);
    if (type == mjSENS_ACCELEROMETER)
      mju_mulMatTVec(out, d->site_xmat + 9 * site, acc + 3, 3, 3);
    else
      mju_copy3(out, type == mjSENS_FRAMELINACC ? acc + 3 : acc);
    finish_sensor(m, i, out);
  }
}

// MuJoCo's cfrc_int (mj_rnePostConstraint: the wrench each body's parent supplies to its subtree,
// com-based) counts rigid bodies only; a rod's proxies are massless. Each rod adds the wrench that
// moves it (its inverse dynamics at the step's qacc, its base accelerating by MuJoCo's cacc, which
// counts gravity as an upward acceleration of the world) to its base body and every ancestor, and
// the part of the rod from a section's end on to that section's proxy and helpers. Leaves the
// rod's node wrenches (cosserat::Data::F) for the force sensors on rod sites.
void patch_cfrc_int(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  auto add = [d](int body, const Vec6& W) {
    for (int e = 0; e < 6; ++e) d->cfrc_int[6 * body + e] += W(e);
  };
  for (size_t r = 0; r < s.rods.size(); ++r) {
    const RodBinding& rb = s.rods[r];
    cosserat::Data& rd = sd.rod[r];
    const mjtNum* c = d->subtree_com + 3 * m->body_rootid[rb.base_body];
    const SE3 G = com_frame(rd.base_pose, c);
    const Vec6 bias_accel = rd.base_accel;  // the bias pass's (qacc = 0): restored below
    rd.base_accel = Ad_inv_apply(G, Eigen::Map<const Vec6>(d->cacc + 6 * rb.base_body));
    cosserat::rnea(rb.model, rd, Eigen::Map<const VecX>(d->qacc + rb.dof0, rb.model.nv), false, false,
                   sd.scratch[r].tau, true);  // every node: the wrenches across rigid sections too
    rd.base_accel = bias_accel;
    const Vec6 W = coAd_apply(G, rd.f_base);
    for (int b = rb.base_body; b > 0; b = m->body_parentid[b]) add(b, W);
    for (size_t i = 0; i < rb.proxy_body.size(); ++i) {
      const int k = rb.model.sections[i].end_node;
      const Vec6 Wi = coAd_apply(com_frame(rd.g[k], c), rd.F[k]);
      add(rb.proxy_body[i], Wi);
      for (int h : rb.helper_body[i]) add(h, Wi);
    }
  }
}

// The wrench rod r carries across the cross-section of rod site `site` (at X in section si), less
// the wrench it carries across the section's end (the node wrench cosserat::Data::F of its end
// node: the nodes' own inverse dynamics, at MuJoCo's accelerations, and everything beyond),
// com-based about c. That is the part of the section beyond X: its inertial wrench (gravity
// counted as the world's acceleration) integrated over [X, X1] by the section's own mass rule laid
// on that stretch (its Gauss points, or Gauss-Lobatto's ends and middle), at each point's own motion
// (cross_section_motion). (The rods' fluid drag acts through their joints, as MuJoCo's own fluid
// forces do through qfrc_passive: cfrc_int counts neither.) With the Gauss-Lobatto rule the end node is
// shared with the next section: the part of its inertial wrench that stands for this section's
// stretch is taken out of F first. At X = X0 the rule is the section's own (the same points and
// weights): a site at a section's start reads the node wrenches as the rod's base does.
// (Outside probe BQ: splitting each node's whole wrench in proportion to its stretch beyond X read
// a rigid rod swinging on a hinge 3.2x, 28%, 3.5% off at its base with 1, 2, 4 sections; outside probe AN: counting the nodes at or beyond
// X in full had read -3.8% to +7% off on a hanging rod; outside probe AO: moments with the forces
// left at the nodes, -46% and the wrong sign just inside a Gauss-Lobatto tip.)
Vec6 rod_wrench_beyond_section_end(const Scene& s, const SceneData& sd, int site, const mjtNum* c) {
  const int r = s.site_rod[site], si = s.site_section[site];
  const cosserat::Model& m = s.rods[r].model;
  const cosserat::Section& sec = m.sections[si];
  const cosserat::Rod& rod = m.rods[0];
  const double X = s.rods[r].decl.sites[s.site_index[site]].X, X1 = sec.X0 + sec.length;
  // the inertial wrench of rod length w at the cross-section at x, com-based about c
  auto inertial = [&](double x, double w) {
    const CrossSectionMotion cs = cross_section_motion(s, sd, r, si, x);
    const Vec6 I = w * cosserat::section_inertia_density(sec.material, rod.radius(x));
    const Vec6 f = I.cwiseProduct(cs.acc) + coad_apply(cs.eta, Vec6(I.cwiseProduct(cs.eta)));
    return coAd_apply(com_frame(cs.pose, c), f);
  };
  Vec6 sum = Vec6::Zero();
  const double len = X1 - X;
  if (sec.end_weight > 0.0) {  // Gauss-Lobatto: 0, 1/2, 1 on [X, X1]; this section's share of the end node out
    sum -= inertial(X1, sec.end_weight * sec.length);
    if (len > 0) {
      sum += inertial(X, sec.end_weight * len) + inertial(X1, sec.end_weight * len);
      sum += inertial(0.5 * (X + X1), (1.0 - 2.0 * sec.end_weight) * len);
    }
  } else if (len > 0) {  // the section's Gauss points on [X, X1]
    int nq = 0;
    for (int k = sec.first_node; k <= sec.end_node; ++k) nq += m.nodes[k].dX > 0 ? 1 : 0;
    thread_local std::vector<double> gx, gw;
    cosserat::gauss_legendre01(nq, gx, gw);
    for (int j = 0; j < nq; ++j) sum += inertial(X + gx[j] * len, gw[j] * len);
  }
  return sum;
}

// The com-based wrench (torque about c, force; world axes) contact j exerts on `body`, as MuJoCo's
// mj_rnePostConstraint adds it to cfrc_ext: the contact force on geom2's body, its opposite on
// geom1's.
Vec6 contact_wrench_on(const mjModel* m, mjData* d, int j, int body, const mjtNum* c) {
  const mjContact& con = d->contact[j];
  mjtNum local[6], world[6], out[6];
  mj_contactForce(m, d, j, local);
  mju_rotVecMatT(world + 3, local, con.frame);  // force
  mju_rotVecMatT(world, local + 3, con.frame);  // torque
  mju_transformSpatial(out, world, 1, c, con.pos, nullptr);
  const Vec6 W = Eigen::Map<const Vec6>(out);
  return m->geom_bodyid[con.geom1] == body ? Vec6(-W) : W;
}

// Scene::force_sensors again, as mj_sensorAcc computes them (cfrc_int of the site's body, to the
// site's frame), from the patched cfrc_int. A site on a rod section reads the wrench transmitted
// into the rod from its abscissa on (rod_wrench_beyond_section_end) instead of from the section's end, plus
// what MuJoCo's bodies below add (tip bodies; contacts on the capsules of the site's section
// at or beyond the site's abscissa, and on the sections beyond). (Outside probe AN: the contacts
// on the site's own section before it had counted too, 8-24% of the weight of a rod on a floor.)
void patch_force_sensors(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  patch_cfrc_int(s, sd);
  for (int i : s.force_sensors) {
    const int site = m->sensor_objid[i], body = m->site_bodyid[site];
    const mjtNum* c = d->subtree_com + 3 * m->body_rootid[body];
    Vec6 cf = Eigen::Map<const Vec6>(d->cfrc_int + 6 * body);
    if (const int r = s.site_rod[site]; r >= 0 && body != s.rods[r].base_body) {
      const double X = s.rods[r].decl.sites[s.site_index[site]].X;
      cf += rod_wrench_beyond_section_end(s, sd, site, c);
      // cfrc_int holds minus the external wrenches on the proxy: add back those of the contacts on
      // the section's capsules before X
      for (int j = 0; j < d->ncon; ++j) {
        const mjContact& con = d->contact[j];
        if (con.efc_address < 0) continue;
        for (const int g : {con.geom1, con.geom2})
          if (m->geom_bodyid[g] == body && s.geom_rod[g] == r &&
              capsule_abscissa(s, sd, g, Eigen::Map<const Vec3>(con.pos)) < X)
            cf += contact_wrench_on(m, d, j, body, c);
      }
    }
    mjtNum tmp[6];
    mju_transformSpatial(tmp, cf.data(), 1, d->site_xpos + 3 * site, c, d->site_xmat + 9 * site);
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    mju_copy3(out, m->sensor_type[i] == mjSENS_FORCE ? tmp + 3 : tmp);
    finish_sensor(m, i, out);
  }
}

// Scene::subtree_sensors of the stage just computed (mjSTAGE_POS: subtreecom; mjSTAGE_VEL:
// subtreelinvel, subtreeangmom) again, with the rods, then MuJoCo's cutoff.
void patch_subtree_sensors(const Scene& s, SceneData& sd, int stage) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  for (int i : s.subtree_sensors) {
    if (m->sensor_needstage[i] != stage) continue;
    const int type = m->sensor_type[i];
    const Subtree st = subtree_with_rods(s, sd, m->sensor_objid[i], stage == mjSTAGE_VEL);
    const Vec3& v = type == mjSENS_SUBTREECOM ? st.com : type == mjSENS_SUBTREELINVEL ? st.linvel : st.angmom;
    mjtNum* out = d->sensordata + m->sensor_adr[i];
    for (int e = 0; e < 3; ++e) out[e] = v(e);
    finish_sensor(m, i, out);
  }
}

// Frame sensors of velocity or acceleration whose object or reference frame is a rod capsule: a
// capsule spans a chord of the rod (its frame is no material frame) and MuJoCo would move it
// rigidly with its proxy; refused, pointing at a site instead. After geom_rod is set.
void check_sensors(const Preprocessed& pre, const Scene& s) {
  const mjModel* m = s.m;
  for (int i = 0; i < m->nsensor; ++i) {
    const int t = m->sensor_type[i];
    if (t != mjSENS_FRAMELINVEL && t != mjSENS_FRAMEANGVEL && t != mjSENS_FRAMELINACC && t != mjSENS_FRAMEANGACC)
      continue;
    for (const auto& [type, id] : {std::pair{m->sensor_objtype[i], m->sensor_objid[i]},
                                   std::pair{m->sensor_reftype[i], m->sensor_refid[i]}})
      if (type == mjOBJ_GEOM && id >= 0 && s.geom_rod[id] >= 0) {
        const SourceLine where =
            i < static_cast<int>(pre.sensor_origin.size()) ? pre.sensor_origin[i] : SourceLine{pre.path, 0};
        throw LoadError(where.file, where.line,
                        "<sensor>: the motion of rod capsule '" + std::string(mj_id2name(m, mjOBJ_GEOM, id)) +
                            "' is not a material frame's (a capsule spans a chord of the rod): put a <site> on "
                            "the rod at the abscissa to measure and name it instead");
      }
  }
}

}  // namespace

void setup_site_readers(const Preprocessed& pre, Scene& s) {
  const mjModel* m = s.m;
  check_sensors(pre, s);
  auto rods_below = [&](int body) {  // a rod, or part of one, hangs in body's subtree
    for (size_t r = 0; body >= 0 && r < s.rods.size(); ++r)
      if (rod_part_in_subtree(s, static_cast<int>(r), body).first >= 0) return true;
    return false;
  };
  for (int i = 0; i < m->nsensor; ++i) {
    const int t = m->sensor_type[i];
    if ((t == mjSENS_VELOCIMETER || t == mjSENS_GYRO || t == mjSENS_FRAMELINVEL || t == mjSENS_FRAMEANGVEL) &&
        (moving_rod_site(s, m->sensor_objtype[i], m->sensor_objid[i]) ||
         moving_rod_site(s, m->sensor_reftype[i], m->sensor_refid[i])))
      s.rod_velocity_sensors.push_back(i);
    if ((t == mjSENS_ACCELEROMETER || t == mjSENS_FRAMELINACC || t == mjSENS_FRAMEANGACC) &&
        moving_rod_site(s, m->sensor_objtype[i], m->sensor_objid[i]))
      s.rod_acceleration_sensors.push_back(i);
    if (t == mjSENS_TOUCH || t == mjSENS_RANGEFINDER)  // on a rod's proxies, or its base site
      for (size_t r = 0; r < s.rods.size(); ++r) {
        const auto& ids = s.rods[r].site_id;
        if (std::find(ids.begin(), ids.end(), m->sensor_objid[i]) != ids.end())
          (t == mjSENS_TOUCH ? s.rod_touch_sensors : s.rod_rangefinders).emplace_back(i, static_cast<int>(r));
      }
    if (t == mjSENS_FRAMEQUAT && (rod_placed_frame(s, m->sensor_objtype[i], m->sensor_objid[i]) ||
                                  rod_placed_frame(s, m->sensor_reftype[i], m->sensor_refid[i])))
      s.rod_quat_sensors.push_back(i);
    if ((t == mjSENS_FORCE || t == mjSENS_TORQUE) && !s.rods.empty()) s.force_sensors.push_back(i);
    if ((t == mjSENS_SUBTREECOM || t == mjSENS_SUBTREELINVEL || t == mjSENS_SUBTREEANGMOM) &&
        rods_below(m->sensor_objid[i]))
      s.subtree_sensors.push_back(i);
  }
  for (int i = 0; i < m->ncam; ++i)
    if ((m->cam_mode[i] == mjCAMLIGHT_TRACKCOM && rods_below(m->cam_bodyid[i])) ||
        (m->cam_mode[i] == mjCAMLIGHT_TARGETBODYCOM && rods_below(m->cam_targetbodyid[i])))
      s.com_cameras.push_back(i);
  for (int i = 0; i < m->nlight; ++i)
    if ((m->light_mode[i] == mjCAMLIGHT_TRACKCOM && rods_below(m->light_bodyid[i])) ||
        (m->light_mode[i] == mjCAMLIGHT_TARGETBODYCOM && rods_below(m->light_targetbodyid[i])))
      s.com_lights.push_back(i);
  for (int i = 0; i < m->nu; ++i) {
    const int t = m->actuator_trntype[i];
    // site (and its refsite) or slider-crank (crank and slider sites) through rod sites; adhesion
    // (body transmission) wherever rods can touch something
    // (and site transmissions with a refsite where either site is on a rod, rigid sections too:
    // their rotational length from the sites' frames, whichever the sections' strain)
    const int a = m->actuator_trnid[2 * i], b = m->actuator_trnid[2 * i + 1];
    const bool on_rod_refsite = t == mjTRN_SITE && b >= 0 && (s.site_rod[a] >= 0 || s.site_rod[b] >= 0);
    if (((t == mjTRN_SITE || t == mjTRN_SLIDERCRANK) &&
         (moving_rod_site(s, mjOBJ_SITE, a) || moving_rod_site(s, mjOBJ_SITE, b) || on_rod_refsite)) ||
        (t == mjTRN_BODY && !s.rods.empty()))
      s.rod_site_actuators.push_back(i);
  }
}

Vec3 subtree_com_with_rods(const Scene& s, const SceneData& sd, int b) {
  return subtree_with_rods(s, sd, b, false).com;
}

void patch_sensors(const Scene& s, SceneData& sd, int stage) {
  if (s.m->opt.disableflags & mjDSBL_SENSOR) return;
  if (!s.subtree_sensors.empty() && stage != mjSTAGE_ACC) patch_subtree_sensors(s, sd, stage);
  if (stage == mjSTAGE_POS && !s.rod_quat_sensors.empty()) patch_quat_sensors(s, sd);
  if (stage == mjSTAGE_POS && !s.rod_rangefinders.empty()) patch_rangefinders(s, sd);
  if (stage == mjSTAGE_ACC && !s.rod_touch_sensors.empty()) patch_touch_sensors(s, sd);
  if (stage == mjSTAGE_VEL && !s.rod_velocity_sensors.empty()) patch_velocity_sensors(s, sd);
  if (stage == mjSTAGE_ACC && !s.rod_acceleration_sensors.empty()) patch_acceleration_sensors(s, sd);
  if (stage == mjSTAGE_ACC && !s.force_sensors.empty()) patch_force_sensors(s, sd);
}

// Cameras and lights that follow or look at a subtree's centre of mass (Scene::com_cameras,
// com_lights: trackcom, targetbodycom) with rods in that subtree, placed as mj_camlight places
// them but from the centre of mass with the rods (subtree_with_rods; their offsets cam_poscom0 and
// light_poscom0 are set from it at load, recompute_qpos0_constants).
void patch_com_tracking(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  auto com = [&](int body, mjtNum out[3]) {  // the subtree's centre of mass with its rods
    const Vec3 c = subtree_with_rods(s, sd, body, false).com;
    for (int e = 0; e < 3; ++e) out[e] = c(e);
  };
  mjtNum c[3];
  for (int i : s.com_cameras) {
    const bool track = m->cam_mode[i] == mjCAMLIGHT_TRACKCOM;
    com(track ? m->cam_bodyid[i] : m->cam_targetbodyid[i], c);
    if (track) {
      mju_add3(d->cam_xpos + 3 * i, c, m->cam_poscom0 + 3 * i);
      continue;
    }
    // targetbodycom: the camera's z axis away from the target, x orthogonal to it and to world z
    mjtNum matT[9];
    mju_sub3(matT + 6, d->cam_xpos + 3 * i, c);
    mju_normalize3(matT + 6);
    matT[3] = 0;
    matT[4] = 0;
    matT[5] = 1;
    mju_cross(matT, matT + 3, matT + 6);
    mju_normalize3(matT);
    mju_cross(matT + 3, matT + 6, matT);
    mju_normalize3(matT + 3);
    mju_transpose(d->cam_xmat + 9 * i, matT, 3, 3);
  }
  for (int i : s.com_lights) {
    const bool track = m->light_mode[i] == mjCAMLIGHT_TRACKCOM;
    com(track ? m->light_bodyid[i] : m->light_targetbodyid[i], c);
    if (track) {
      mju_add3(d->light_xpos + 3 * i, c, m->light_poscom0 + 3 * i);
    } else {  // targetbodycom: pointing at it
      mju_sub3(d->light_xdir + 3 * i, c, d->light_xpos + 3 * i);
      mju_normalize3(d->light_xdir + 3 * i);
    }
  }
}

// An adhesion actuator's moment arm (mj_transmission's body transmission: minus the mean over the
// body's contacts of the normal Jacobian n . (J2 - J1)) where a contact in the gap (exclude 1: no
// constraint row, so MuJoCo takes the Jacobian of the proxies as rigid bodies) touches a rod
// capsule. The active contacts read the contact rows, corrected in scene.cpp already.
void patch_adhesion(const Scene& s, SceneData& sd, int i) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  thread_local SectionCols dJ;  // scratch: no heap memory
  const int body = m->actuator_trnid[2 * i];
  int counted = 0;
  for (int k = 0; k < d->ncon; ++k) {
    const mjContact& con = d->contact[k];
    if ((m->geom_bodyid[con.geom1] == body || m->geom_bodyid[con.geom2] == body) && con.exclude <= 1) ++counted;
  }
  if (!counted) return;
  for (int k = 0; k < d->ncon; ++k) {
    const mjContact& con = d->contact[k];
    if ((m->geom_bodyid[con.geom1] != body && m->geom_bodyid[con.geom2] != body) || con.exclude != 1) continue;
    const Vec3 n(con.frame[0], con.frame[1], con.frame[2]);
    for (int side = 0; side < 2; ++side) {
      const int g = side == 0 ? con.geom1 : con.geom2;
      if (s.geom_rod[g] < 0) continue;
      const int col0 = capsule_correction(s, sd, g, Vec3(con.pos[0], con.pos[1], con.pos[2]), dJ);
      const double sign = (side == 0 ? 1.0 : -1.0) / counted;  // -(J2 - J1) / counted
      for (int c = 0; c < dJ.cols(); ++c) d->actuator_moment[i * m->nv + col0 + c] += sign * n.dot(dJ.col(c).head<3>());
    }
  }
}

// Actuator moment arms through rod sites (Scene::rod_site_actuators), MuJoCo's mj_transmission with
// the true site Jacobians: moment += gear^T (the actuator's wrench or length gradient) times the
// sites' point_correction (the section's dofs only).
//   site:         moment = J^T [R gear_force; R gear_torque] at the site (J: translation, rotation);
//                 with a refsite, (J - J_ref)^T [..] with R the reference's frame
//                 (mj_transmission: the reference frame's own rotation is not differentiated)
//   slider-crank: length = a.v - sqrt((a.v)^2 + r^2 - v.v), v = crank - slider, a the slider's z
//                 axis; dlength = dldv . (dp_crank - dp_slider) + dlda . (w_slider x a)
void patch_site_transmissions(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  thread_local SectionCols dJ;  // scratch: no heap memory
  auto add = [&](int i, int site, const Vec3& f_lin, const Vec3& f_rot) {  // moment += f . dJ
    if (!moving_rod_site(s, mjOBJ_SITE, site)) return;
    const mjtNum* p = d->site_xpos + 3 * site;
    const int col0 = site_correction(s, sd, site, Vec3(p[0], p[1], p[2]), dJ);
    for (int c = 0; c < dJ.cols(); ++c)
      d->actuator_moment[i * m->nv + col0 + c] += f_lin.dot(dJ.col(c).head<3>()) + f_rot.dot(dJ.col(c).tail<3>());
  };
  for (int i : s.rod_site_actuators) {
    if (m->actuator_trntype[i] == mjTRN_BODY) {
      patch_adhesion(s, sd, i);
      continue;
    }
    const mjtNum* gear = m->actuator_gear + 6 * i;
    const int id = m->actuator_trnid[2 * i];
    if (m->actuator_trntype[i] == mjTRN_SITE) {
      // the gear in the site's frame, or with a reference site (refsite) in the reference's frame,
      // acting on the site's motion relative to the reference's
      const int ref = m->actuator_trnid[2 * i + 1];
      Eigen::Map<const Mat3r> R(d->site_xmat + 9 * (ref >= 0 ? ref : id));
      const Vec3 f = R * Vec3(gear[0], gear[1], gear[2]), t = R * Vec3(gear[3], gear[4], gear[5]);
      add(i, id, f, t);
      if (ref >= 0) add(i, ref, -f, -t);
      if (ref >= 0 && (gear[3] != 0 || gear[4] != 0 || gear[5] != 0)) {
        // the rotational length: mj_transmission takes the sites' quaternions from their parent
        // bodies (site_quat * xquat: for a rod site the proxy's, rigid), here from both sites'
        // frames (the site's rotation relative to the reference's, axis-angle in its frame)
        mjtNum q[2][4], q_mj[2][4], v[3], v_mj[3];
        for (int k = 0; k < 2; ++k) {
          const int site = k == 0 ? id : ref;
          mju_mulQuat(q_mj[k], m->site_quat + 4 * site, d->xquat + 4 * m->site_bodyid[site]);
          mju_mat2Quat(q[k], d->site_xmat + 9 * site);
        }
        mju_subQuat(v, q[0], q[1]);
        mju_subQuat(v_mj, q_mj[0], q_mj[1]);
        for (int e = 0; e < 3; ++e) d->actuator_length[i] += (v[e] - v_mj[e]) * gear[3 + e];
      }
      continue;
    }
    // slider-crank: trnid = (crank site, slider site)
    const int slider = m->actuator_trnid[2 * i + 1];
    const Vec3 a(d->site_xmat[9 * slider + 2], d->site_xmat[9 * slider + 5], d->site_xmat[9 * slider + 8]);
    const Vec3 v = Vec3(d->site_xpos[3 * id], d->site_xpos[3 * id + 1], d->site_xpos[3 * id + 2]) -
                   Vec3(d->site_xpos[3 * slider], d->site_xpos[3 * slider + 1], d->site_xpos[3 * slider + 2]);
    const double r = m->actuator_cranklength[i], av = a.dot(v);
    double det = av * av + r * r - v.dot(v);
    Vec3 dlda, dldv;
    if (det <= 0) {  // degenerate: MuJoCo's length is a.v
      dlda = v;
      dldv = a;
    } else {
      det = std::sqrt(det);
      const double factor = 1 - av / det;
      dlda = factor * v;
      dldv = factor * a + v / det;
    }
    add(i, id, gear[0] * dldv, Vec3::Zero());
    // d a / dq = w x a: dlda . (w x a) = (a x dlda) . w
    add(i, slider, -gear[0] * dldv, gear[0] * a.cross(dlda));
  }
}

}  // namespace cosserat::mj
