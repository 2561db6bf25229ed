// Generalised dynamics (DESIGN.md section 5):
//   M(q) qacc + bias(q, v) = qfrc_passive + qfrc_actuator,
// bias = Coriolis/centrifugal + gravity - external loads (recursive Newton-Euler),
// qfrc_passive = -K (q - q_ref) - D v, qfrc_actuator from cable tensions and dof forces.
#pragma once

#include "model.hpp"

namespace cosserat {

// Mass matrix by the composite-rigid-body algorithm into d.M. After fwd_position.
// Also fills the coupling to a moving base: d.Ic_base (composite inertia of the whole tree in the
// base frame) and d.F_base (6 x nv, base-frame wrench per unit qacc), so that for a base with
// body-frame acceleration a_b the full mass matrix is [[Ic_base, F_base], [F_base^T, M]].
void crba(const Model& m, Data& d);
// The same recursion for the nodes' inertia (crba) or fluid resistance Node::drag (fluid.hpp):
// out_M = sum_i J_i^T A_i J_i over the nodes (A_i = Node::inertia or Node::drag, node frame, angular
// first), with the base coupling out_base (6 x 6) and out_F_base (6 x nv) as for Ic_base and
// F_base. Uses d.Ic, d.Ic_off, d.Fs and d.Ts as scratch. Fixed subtrees take their cached composite (Node::inertia_sub,
// Node::drag_sub). The matrices are symmetric: out_M is filled as a symmetric matrix from its
// upper blocks.
enum class NodeMatrix { Inertia, Drag };
void composite(const Model& m, Data& d, NodeMatrix which, MatX& out_M, Mat6& out_base, Mat6X& out_F_base);
// Recursive Newton-Euler: tau = M qacc + C v + gravity - external loads. After fwd_velocity.
// `gravity` and `external` switch those contributions on; the base moves as d.base_twist/accel.
// d.f_base receives the base-frame wrench the base must supply to the tree (its inverse dynamics),
// d.F[i] the wrench node i's parent supplies to node i's subtree (node frame). A fixed subtree
// (Node::fixed_subtree) moves as one body with its root's composite inertia, so its inner nodes'
// F hold their loads only; `every_node` computes every node's own motion and wrench instead (the
// same tau and f_base; for the internal wrenches across a rigid part).
void rnea(const Model& m, Data& d, const Eigen::Ref<const VecX>& qacc, bool gravity, bool external,
          Eigen::Ref<VecX> tau, bool every_node = false);
// -K (q - q_ref) - D v into d.qfrc_passive.
void passive(const Model& m, Data& d);
// Generalised force of the actuators for d.ctrl into d.qfrc_actuator. After fwd_position.
void actuation(const Model& m, Data& d);
// Kinematics, mass matrix and every generalised force (bias, passive, actuator) for d.q, d.v.
void smooth_forces(const Model& m, Data& d);
// smooth_forces and the accelerations d.qacc (explicit forward dynamics).
void forward(const Model& m, Data& d);

// External loads on rods (they add to d.f_ext_world; clear it yourself between uses):
// a force per unit length in world axes over the whole rod, lumped at the mass quadrature nodes
// with their length weights (the same rule that integrates the rod's own weight).
void add_distributed_force(const Model& m, Data& d, int rod, const Vec3& force_per_length);
// Generalised force J(X)^T [R^T m; R^T f] of a world-axes wrench applied at abscissa X, added to
// tau. After fwd_position.
void add_rod_point_wrench(const Model& m, const Data& d, int rod, double X, const Vec3& moment,
                          const Vec3& force, VecX& tau);

// Length of a cable and its gradient dl/dq (the cable's generalised force is -T dl/dq).
double cable_length(const Model& m, const Data& d, int cable, VecX* grad = nullptr);

struct Energy {
  double kinetic = 0, gravity = 0, elastic = 0;
  double total() const { return kinetic + gravity + elastic; }
};
// After fwd_velocity (kinetic energy from node twists; gravity relative to the world origin).
Energy energy(const Model& m, const Data& d);
// Total spatial momentum [angular about the world origin; linear] in world axes. After fwd_velocity.
Vec6 momentum(const Model& m, const Data& d);
// Node k's share of the two: its spatial momentum (as momentum's), and its mass, with the world
// position of its centre of mass in `com` where it has mass.
Vec6 node_momentum(const Model& m, const Data& d, int k);
double node_mass(const Model& m, const Data& d, int k, Vec3* com = nullptr);
// World position of the centre of mass of everything, and the total mass.
Vec3 center_of_mass(const Model& m, const Data& d, double* total_mass = nullptr);

}  // namespace cosserat
