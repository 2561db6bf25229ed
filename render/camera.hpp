// Cameras for headless pictures: a model camera by name, or a free camera that frames the whole
// scene (bodies, finite geoms and rod centrelines), optionally following a body.
#pragma once

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "scene.hpp"

namespace cosserat::render {

struct CameraOptions {
  std::string name;   // a model camera; empty: the free camera framing the scene
  std::string track;  // free camera only: follow this body (keeps the first frame's offset to it)
  double azimuth = 90.0, elevation = -20.0;  // free camera view direction [deg], MuJoCo's convention
  double margin = 0.08;                      // free camera: empty border, fraction of the picture
};

// What a picture should show, as spheres: bodies (not the world), rod centrelines (with their
// radius) and the corners of the bodies' geoms of finite size visible under `opt`, plus those of
// the world's geoms no larger than all that (a clamp or a mount, not a floor or a table: those
// are shown as far as they fit).
struct Extent {
  std::vector<Vec3> centres;
  std::vector<double> radii;
  bool empty() const { return centres.empty(); }
  void add(const Vec3& p, double r = 0.0) { centres.push_back(p), radii.push_back(r); }
  void add(const Extent& e) {
    centres.insert(centres.end(), e.centres.begin(), e.centres.end());
    radii.insert(radii.end(), e.radii.begin(), e.radii.end());
  }
};
Extent scene_extent(const mj::Scene& s, const mj::SceneData& sd, const mjvOption& opt);

// Free camera looking along (azimuth, elevation) at `e` so that it fills the picture of aspect
// width/height up to `margin` on each side (MuJoCo's perspective with vis.global.fovy). `depth`,
// when given, receives the nearest and farthest depth of `e` in front of that camera (0 0 when `e`
// is empty).
void frame_extent(const mjModel* m, const Extent& e, double aspect, double azimuth, double elevation, double margin,
                  mjvCamera* cam, double depth[2] = nullptr);

// Moves the near and far clipping planes of `scn`'s cameras (set by mjv_updateScene to MuJoCo's
// <visual><map znear zfar> times stat.extent) out so that the depths [lo, hi] in front of the camera
// are drawn: the near plane to lo / 2 where it was beyond that, the far plane to 2 hi where it was
// nearer; the field of view stays. A scene within MuJoCo's planes keeps them.
void widen_clipping(double lo, double hi, mjvScene* scn);

// Resolves CameraOptions against a scene and poses an mjvCamera for each picture.
class CameraRig {
 public:
  // Throws std::invalid_argument naming the unknown camera or body (and the known ones).
  CameraRig(const mj::Scene& s, const CameraOptions& o);
  // The camera for the current state: the free camera is framed at the first call (unless
  // frame() framed it) and then stays (or follows the tracked body), so a frame sequence has a
  // steady view.
  void update(const mj::Scene& s, const mj::SceneData& sd, const mjvOption& opt, double aspect, mjvCamera* cam);
  // Frames the free camera on `e` (e.g. the union of a whole run's extents) for the pictures to
  // come; for a tracked body, keeps the offset to its position `body`. No effect on a model camera.
  void frame(const mjModel* m, const Extent& e, double aspect, const Vec3& body = Vec3::Zero());
  bool free() const { return camera_id_ < 0; }
  // The free camera: widens `scn`'s clipping planes (after mjv_updateScene) to hold what it framed
  // (outside probe BF: a 5 cm rod framed 7 cm away lay before MuJoCo's near plane, 0.01 x the extent
  // of its 50 m floor, and a rod fallen 43 m beyond the far plane: blank pictures). No effect on a
  // model camera, whose planes are the model's.
  void clip(mjvScene* scn) const;

 private:
  CameraOptions options_;
  int camera_id_ = -1, body_id_ = -1;
  bool framed_ = false;
  mjvCamera free_{};
  Vec3 offset_ = Vec3::Zero();  // lookat minus the tracked body's position
  double depth_[2] = {0, 0};    // nearest and farthest depth of the framed extent
};

}  // namespace cosserat::render
