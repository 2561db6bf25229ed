#include "camera.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace cosserat::render {

namespace {

constexpr double kDeg = M_PI / 180.0;

// Names of the model's objects of one type, for error messages.
std::string known_names(const mjModel* m, mjtObj type, int n) {
  std::string list;
  for (int i = 0; i < n; ++i)
    if (const char* name = mj_id2name(m, type, i); name && *name) list += (list.empty() ? "" : ", ") + std::string(name);
  return list.empty() ? "none" : list;
}

// Half extents in world axes of a geom's bounding box.
Vec3 geom_half_extent(const mjModel* m, const mjData* d, int g) {
  const mjtNum* size = m->geom_size + 3 * g;
  Vec3 local;
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE: local.setConstant(size[0]); break;
    case mjGEOM_CAPSULE: local = Vec3(size[0], size[0], size[1] + size[0]); break;
    case mjGEOM_CYLINDER: local = Vec3(size[0], size[0], size[1]); break;
    case mjGEOM_BOX:
    case mjGEOM_ELLIPSOID: local = Vec3(size[0], size[1], size[2]); break;
    default: return Vec3::Constant(m->geom_rbound[g]);  // meshes
  }
  const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> R(d->geom_xmat + 9 * g);
  return R.cwiseAbs() * local;
}

}  // namespace

Extent scene_extent(const mj::Scene& s, const mj::SceneData& sd, const mjvOption& opt) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  Extent e;
  for (int i = 1; i < m->nbody; ++i) e.add(Eigen::Map<const Vec3>(d->xpos + 3 * i));
  for (size_t r = 0; r < s.rods.size(); ++r) {
    const Rod& rod = s.rods[r].model.rods[0];
    const int n = 33;
    const auto pts = mj::rod_centerline(s, sd, static_cast<int>(r), n);
    for (int i = 0; i < n; ++i) e.add(pts[i], rod.radius(rod.length * i / (n - 1)));
  }
  // geoms of finite size; the world's only when not larger than the rest (a clamp, not a table)
  for (int pass = 0; pass < 2; ++pass) {
    Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (size_t i = 0; i < e.centres.size(); ++i) {
      lo = lo.cwiseMin(e.centres[i] - Vec3::Constant(e.radii[i]));
      hi = hi.cwiseMax(e.centres[i] + Vec3::Constant(e.radii[i]));
    }
    const double size = e.empty() ? 1e300 : (hi - lo).norm();
    for (int g = 0; g < m->ngeom; ++g) {
      const int type = m->geom_type[g];
      const int group = std::clamp(m->geom_group[g], 0, mjNGROUP - 1);
      if (type == mjGEOM_PLANE || type == mjGEOM_HFIELD || !opt.geomgroup[group] || m->geom_rgba[4 * g + 3] == 0) continue;
      if (s.geom_rod[g] >= 0 || (m->geom_bodyid[g] == 0) != (pass == 1)) continue;  // rods: the centreline covers them
      const Vec3 c = Eigen::Map<const Vec3>(d->geom_xpos + 3 * g), h = geom_half_extent(m, d, g);
      if (pass == 1 && 2 * h.norm() > size) continue;
      for (int k = 0; k < 8; ++k) e.add(c + Vec3(k & 1 ? h.x() : -h.x(), k & 2 ? h.y() : -h.y(), k & 4 ? h.z() : -h.z()));
    }
  }
  return e;
}

void frame_extent(const mjModel* m, const Extent& e, double aspect, double azimuth, double elevation, double margin,
                  mjvCamera* cam, double depth[2]) {
  mjv_defaultCamera(cam);
  if (depth) depth[0] = depth[1] = 0;
  cam->type = mjCAMERA_FREE;
  cam->azimuth = azimuth;
  cam->elevation = elevation;
  if (e.empty()) {  // nothing finite: MuJoCo's own view of the model statistics
    for (int k = 0; k < 3; ++k) cam->lookat[k] = m->stat.center[k];
    cam->distance = 1.5 * m->stat.extent;
    return;
  }
  // camera axes as mjv_updateCamera builds them for a free camera
  const double ca = std::cos(azimuth * kDeg), sa = std::sin(azimuth * kDeg);
  const double ce = std::cos(elevation * kDeg), se = std::sin(elevation * kDeg);
  const Vec3 fwd(ce * ca, ce * sa, se), up(-se * ca, -se * sa, ce), right = fwd.cross(up);
  const double fill = std::clamp(1.0 - 2.0 * margin, 0.05, 1.0);
  const double ty = std::tan(0.5 * m->vis.global.fovy * kDeg) * fill, tx = ty * aspect;

  Vec3 lookat = Vec3::Zero();
  for (const Vec3& c : e.centres) lookat += c;
  lookat /= static_cast<double>(e.centres.size());
  double distance = 0.0;
  // fit the distance to the spheres, then re-centre their projection; a few rounds converge
  for (int round = 0; round < 6; ++round) {
    distance = 0.0;
    for (size_t i = 0; i < e.centres.size(); ++i) {
      const Vec3 v = e.centres[i] - lookat;
      const double r = e.radii[i];
      const double need = std::max((std::abs(v.dot(right)) + r) / tx, (std::abs(v.dot(up)) + r) / ty) - v.dot(fwd) + r;
      distance = std::max(distance, need);
    }
    const Vec3 eye = lookat - distance * fwd;
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (size_t i = 0; i < e.centres.size(); ++i) {
      const Vec3 v = e.centres[i] - eye;
      const double z = std::max(v.dot(fwd), 1e-9), r = e.radii[i];
      x0 = std::min(x0, (v.dot(right) - r) / z), x1 = std::max(x1, (v.dot(right) + r) / z);
      y0 = std::min(y0, (v.dot(up) - r) / z), y1 = std::max(y1, (v.dot(up) + r) / z);
    }
    lookat += distance * (0.5 * (x0 + x1) * right + 0.5 * (y0 + y1) * up);
  }
  distance = std::max(distance, 1e-6);
  for (int k = 0; k < 3; ++k) cam->lookat[k] = lookat[k];
  cam->distance = distance;
  if (depth) {
    const Vec3 eye = lookat - distance * fwd;
    depth[0] = 1e300, depth[1] = 0;
    for (size_t i = 0; i < e.centres.size(); ++i) {
      const double z = (e.centres[i] - eye).dot(fwd);
      depth[0] = std::min(depth[0], z - e.radii[i]), depth[1] = std::max(depth[1], z + e.radii[i]);
    }
    depth[0] = std::max(depth[0], 0.0);
  }
}

void widen_clipping(double lo, double hi, mjvScene* scn) {
  if (!(hi > 0)) return;
  for (mjvGLCamera& c : scn->camera) {
    const double near = c.frustum_near, far = c.frustum_far;
    // the near plane no closer than 1e-6 of the far one: the depth buffer's resolution
    double new_near = std::min(near, std::max(0.5 * lo, 1e-6 * std::max(far, 2 * hi)));
    const double new_far = std::max(far, 2 * hi);
    new_near = std::max(new_near, 1e-12);  // mjr_render refuses a near plane below mjMINVAL (1e-15)
    if (new_near != near && near > 0) {  // the frustum's sides are given at the near plane
      const double s = new_near / near;
      c.frustum_bottom = static_cast<float>(c.frustum_bottom * s);
      c.frustum_top = static_cast<float>(c.frustum_top * s);
      c.frustum_center = static_cast<float>(c.frustum_center * s);
      c.frustum_near = static_cast<float>(new_near);
    }
    c.frustum_far = static_cast<float>(new_far);
  }
}

CameraRig::CameraRig(const mj::Scene& s, const CameraOptions& o) : options_(o) {
  const mjModel* m = s.m;
  if (!o.name.empty()) {
    camera_id_ = mj_name2id(m, mjOBJ_CAMERA, o.name.c_str());
    if (camera_id_ < 0)
      throw std::invalid_argument("no camera '" + o.name + "' in the model (cameras: " + known_names(m, mjOBJ_CAMERA, m->ncam) + ")");
    if (!o.track.empty()) throw std::invalid_argument("a model camera cannot track a body: drop --camera to track");
  }
  if (!o.track.empty()) {
    body_id_ = mj_name2id(m, mjOBJ_BODY, o.track.c_str());
    if (body_id_ < 0)
      throw std::invalid_argument("no body '" + o.track + "' in the model (bodies: " + known_names(m, mjOBJ_BODY, m->nbody) + ")");
  }
}

void CameraRig::update(const mj::Scene& s, const mj::SceneData& sd, const mjvOption& opt, double aspect, mjvCamera* cam) {
  if (camera_id_ >= 0) {
    mjv_defaultCamera(cam);
    cam->type = mjCAMERA_FIXED;
    cam->fixedcamid = camera_id_;
    return;
  }
  const Vec3 body = body_id_ >= 0 ? Vec3(Eigen::Map<const Vec3>(sd.d->xpos + 3 * body_id_)) : Vec3::Zero();
  if (!framed_) frame(s.m, scene_extent(s, sd, opt), aspect, body);
  *cam = free_;
  if (body_id_ >= 0)
    for (int k = 0; k < 3; ++k) cam->lookat[k] = body[k] + offset_[k];
}

void CameraRig::frame(const mjModel* m, const Extent& e, double aspect, const Vec3& body) {
  if (camera_id_ >= 0) return;
  frame_extent(m, e, aspect, options_.azimuth, options_.elevation, options_.margin, &free_, depth_);
  offset_ = Eigen::Map<const Vec3>(free_.lookat) - body;
  framed_ = true;
}

void CameraRig::clip(mjvScene* scn) const {
  if (camera_id_ < 0 && framed_) widen_clipping(depth_[0], depth_[1], scn);
}

}  // namespace cosserat::render
