// Kinematics of the node tree: poses, twists, Jacobians, and poses/Jacobians at any material
// abscissa of a rod.
#pragma once

#include "model.hpp"

namespace cosserat {

// From d.q: Omega, g_rel, g (world), G = dOmega/dq, the motion subspaces S = dexp(-Omega) G and
// the group Jacobians Jg with the poses g_grp (Data).
void fwd_position(const Model& m, Data& d);
// From d.v (after fwd_position): Omega_dot, body twists eta and the velocity-product
// accelerations cbias (so that acc_i = Ad^-1 acc_parent + cbias_i + S_i qacc_i). with_Sdot false
// leaves the matrices d.Sdot as they were (cbias is the same): for callers that read neither Sdot,
// group_jacobian_dot's Jgdot nor section_jacobian's Jdot.
void fwd_velocity(const Model& m, Data& d, bool with_Sdot = true);
// d.Jgdot, the time derivative of the group Jacobians. After fwd_velocity.
void group_jacobian_dot(const Model& m, Data& d);

// Body Jacobian of node i (6 x nv): eta_i = J v (with a fixed base). After fwd_position.
void node_jacobian(const Model& m, const Data& d, int node, MatX& J);
// J-dot v of node i: its body acceleration at qacc = 0 with a fixed base. After fwd_velocity.
Vec6 node_jdot_v(const Model& m, const Data& d, int node);

// Sizes this thread's scratch of the point Jacobians (section_jacobian, rod_pose_and_jacobian,
// point_motion_at_rest_acceleration) for sections of up to `ndof` dofs. Data's constructor calls
// it for its model; a thread that steps a Data made in another one allocates once, at its first
// such call.
void reserve_kinematics_scratch(int ndof);

// World pose of the cross-section of rod r at abscissa X in [0, L]. After fwd_position.
// Exact for PCS; one 4th-order Magnus step from the previous node for GVS.
SE3 rod_pose(const Model& m, const Data& d, int rod, double X);
// Where the kinematics keep rod_pose(m, d, rod, X) already, whatever the state: the node whose
// Data::g it is (mid = false), or whose kept midpoint Data::g_mid it is (mid = true); -1 where
// rod_pose takes a partial step.
int kept_pose_node(const Model& m, int rod, double X, bool& mid);
// Body Jacobian (6 x nv) of the cross-section at X. After fwd_position.
void rod_jacobian(const Model& m, const Data& d, int rod, double X, MatX& J);
// Twist of the cross-section at X relative to the start frame of the section containing X, per
// unit velocity of that section's own dofs: J (6 x ndof of the section, in the frame at X), and
// its time derivative Jdot (if given; after fwd_velocity). The pose of the frame at X relative to
// the section start goes to g_start_X if given. Returns the section index. At a section end this
// is what a MuJoCo proxy's strain dofs contribute (cdof, cdof_dot: DESIGN.md section 6).
// `section` (a global section index) picks the section explicitly when X lies on a boundary
// between two sections (a point fixed to the later one); by default the earlier one is used.
int section_jacobian(const Model& m, const Data& d, int rod, double X, Mat6X& J, Mat6X* Jdot = nullptr,
                     SE3* g_start_X = nullptr, int section = -1);
// rod_pose(m, d, rod, X), returned, and section_jacobian(m, d, rod, X, J, nullptr, g_start_X,
// section) in one pass: one partial step and one exponential where the two would take two of each
// (both results bit for bit theirs). For a point that needs both every evaluation (a tendon's path
// point on the rod: its position, then its Jacobian).
SE3 rod_pose_and_jacobian(const Model& m, const Data& d, int rod, double X, int section, Mat6X& J,
                          SE3* g_start_X);

// The cross-section at X in motion at qacc = 0: its world pose, its twist eta and its
// velocity-product acceleration acc (body frame at X): the parent node's Data::acc (or, before the
// first node, Data::base_accel) carried along, plus dS/dt v + ad_eta psi of the partial step to X
// (psi = S v its own twist). After fwd_velocity and an rnea with qacc = 0, whose Data::acc it reads
// (the nodes of a section with dofs and their parents are never lumped away: rnea fills them).
// `section` as section_jacobian's. O(one Magnus step).
struct PointMotion {
  SE3 pose;
  Vec6 eta, acc;
};
PointMotion point_motion_at_rest_acceleration(const Model& m, const Data& d, int rod, double X, int section = -1);
// Twist [angular; linear] of the cross-section of rod r at X (the material frame rod_pose gives),
// in that frame: the base's twist carried along the rod plus the strain rates' share. After
// fwd_velocity. X as rod_pose's (clamped to [0, L]; on a boundary, the earlier section's point,
// the same frame). With `pose`, the cross-section's pose too (rod_pose's, from the same partial step).
Vec6 rod_twist(const Model& m, const Data& d, int rod, double X, SE3* pose = nullptr);

// Strain xi(X) = Phi(X) q + xi* of rod r.
Vec6 rod_strain(const Model& m, const Data& d, int rod, double X);

// The smallest axial stretch p_x (deformed over rest length of the centreline) over the Magnus
// steps of rod sections whose axial strain is free, from the last fwd_position: Omega_x / h of
// each step (exact for PCS, the step's mean for GVS). +inf when no section can stretch. Its
// section (global index) goes to `section` if given. A linear constitutive law does not resist a
// section's collapse: p_x -> 0 and below is an inverted, massless section, not a physical state.
double min_axial_stretch(const Model& m, const Data& d, int* section = nullptr);

// The Magnus step of a node evaluated for an arbitrary q block (used by the functions above):
// Omega, and optionally G = dOmega/dq_block.
Vec6 step_twist(const Node& n, const Eigen::Ref<const VecX>& qi, Mat6X* G);

}  // namespace cosserat
