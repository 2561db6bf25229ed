// MuJoCo's features that read a rod's sites or mass, made to read the rod's material.
//
// MuJoCo sees a rod as a chain of massless proxy bodies, one at the end of each section, and a rod
// site as rigid with its section's proxy. What reads positions is right as MuJoCo computes it (the
// coupling places the sites, plugin/mujoco/scene.cpp); what reads a site's motion, the mass in a
// subtree or the wrench a body carries is evaluated again after MuJoCo's stage, from the rods' own
// kinematics and dynamics:
//   - framequat of rod sites and capsules (also as the reference frame): their own frames (MuJoCo
//     takes the proxy's quaternion);
//   - touch on a rod site: the whole rod's contacts in the zone (MuJoCo: the site's section's);
//     rangefinder on a rod site: the ray leaves the rod's capsules it starts in (MuJoCo excludes
//     the site's proxy only, and a site at a section's end starts in the next section's capsule);
//   - velocimeter, gyro, framelinvel and frameangvel (also with a reftype frame) of rod sites, and
//     accelerometer, framelinacc and frameangacc: the material point's motion;
//   - force and torque: MuJoCo's cfrc_int gets each rod's inverse dynamics (a sensor above a soft
//     arm reads its weight and inertia; on a rod site, the wrench across that cross-section);
//   - subtreecom, subtreelinvel and subtreeangmom of bodies with rods below, and trackcom and
//     targetbodycom cameras and lights: the centre of mass and momentum with the rods;
//   - site (with or without refsite) and slider-crank transmissions: the sites' material Jacobians,
//     and with a refsite the rotational length from both sites' frames;
//     adhesion (body) transmissions: the rod capsules' material points in contacts in the gap
//     (the active contacts read the contact rows, which scene.cpp corrects).
// Velocity and acceleration frame sensors of rod capsules (a chord, no material frame) are load
// errors. Tendons through rod sites and contacts on rod capsules are patched in scene.cpp.
#pragma once

#include <mujoco/mujoco.h>

#include <Eigen/Core>

#include "mjcf.hpp"
#include "model.hpp"
#include "scene.hpp"

namespace cosserat::mj {

// At load, after the rods are bound (Scene::site_rod, geom_rod, ...): the lists of Scene that the
// patches below walk (rod_velocity_sensors, rod_acceleration_sensors, force_sensors,
// subtree_sensors, rod_site_actuators, com_cameras, com_lights). Throws LoadError at the sensor's
// file and line for a velocity or acceleration frame sensor of a rod capsule.
void setup_site_readers(const Preprocessed& pre, Scene& s);

// In fwd_position: after mj_camlight, and after mj_transmission.
void patch_com_tracking(const Scene& s, SceneData& sd);
void patch_site_transmissions(const Scene& s, SceneData& sd);
// In forward: after mj_sensorPos, mj_sensorVel and mj_sensorAcc (stage mjSTAGE_POS, VEL, ACC).
void patch_sensors(const Scene& s, SceneData& sd, int stage);

// The centre of mass of body b's subtree with the rods in it (after the position stage).
Vec3 subtree_com_with_rods(const Scene& s, const SceneData& sd, int b);

// ---- shared with scene.cpp, which defines them ----

// 6 x (a section's dofs) with fixed capacity: scratch that points on sections of different sizes
// share without touching the heap.
using SectionCols = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, cosserat::kMaxSectionDofs>;
// For the material point of rod site `site` at world position p: the Jacobian columns of its
// section's dofs minus MuJoCo's (the point rigid with the proxy), rows translation then rotation,
// world axes; returns the section's first MuJoCo dof (dJ.cols() dofs). Needs fwd_position.
int site_correction(const Scene& s, const SceneData& sd, int site, const Vec3& p, SectionCols& dJ);
// The same for a point p (world) touching rod capsule `geom`: the material point of the section at
// p's projection on the capsule's axis (the contact rows' correction).
int capsule_correction(const Scene& s, const SceneData& sd, int geom, const Vec3& p, SectionCols& dJ);
// The material abscissa of a point p touching rod capsule `geom`: p projected on the capsule's axis.
double capsule_abscissa(const Scene& s, const SceneData& sd, int geom, const Vec3& p);
// Body b is `ancestor` or below it (every body is below the world).
bool is_descendant(const mjModel* m, int b, int ancestor);
// The frame a rod section starts at: node `anchor`, or the rod's base for -1.
const SE3& anchor_pose(const cosserat::Data& d, int anchor);
// Spatial transform MuJoCo's com-based vectors live in, for a frame g: G = (R, p - c).
SE3 com_frame(const SE3& g, const mjtNum* c);

}  // namespace cosserat::mj
