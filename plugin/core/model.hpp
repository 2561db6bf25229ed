// The compiled model of a soft-rigid tree, and the data that holds its state and scratch memory.
//
// Everything is a tree of nodes (frames). Node i sits in its parent's frame at
//     g_{parent,i} = offset_i * exp(Omega_i(q)),
// where Omega_i is one 4th-order Magnus (Zanna) step (DESIGN.md section 4) over a length h:
//     Omega = h/2 (xi_a + xi_b) + (sqrt(3)/12) h^2 ad_{xi_a} xi_b,   xi_{a,b} = Phi_{a,b} q_i + xibar_{a,b},
// with xi_a, xi_b the strain at the two Gauss points of the step and q_i the node's dof block;
// a GVS step takes the first term as the exact integral of the strain over the step,
// h (Phi_m q_i + xibar), Phi_m the basis's mean over it (Node::Phi_m): the two-point rule integrates
// Legendre polynomials up to degree 3 only, and from order 4 on left a fixed fraction of the
// section's highest modes in every step (outside probe CA: a spurious P_4 strain under a pure end
// moment, 3.8e-4 L off the circle with one section, and a floor near 1e-6 L that more sections did
// not lower). The step stays of 4th order (the commutator's error) and is exact for strains of one
// direction, as the rotation of a planar rod.
//  - a rigid joint is one node with h = 1, Phi_a = Phi_b = B (joint basis), xibar = 0;
//  - a PCS section has constant strain, Phi_a = Phi_b = B: the commutator vanishes and the step is
//    the exact exponential of DESIGN.md section 4;
//  - a GVS section uses Phi(X) = B (x) Legendre(X): the commutator term is kept.
// Each rod section is split at the points of its mass quadrature plus its end; the inertia of the
// rod is lumped at those points (weight x cross-section inertia density), so mass matrix, bias,
// energy and momentum are all exact for this discrete model. The points: order + 2 Gauss points
// by default; for PCS sections optionally the 3-point Gauss-Lobatto rule (SectionSpec::lobatto:
// X0, mid, end, weights 1/6, 2/3, 1/6 of the length), whose end points are frames the
// neighbouring sections share (the first section's start is Rod::base_node), so that a section
// has two nodes with equal steps (one exponential).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "lie.hpp"
#include "strain.hpp"

namespace cosserat {

using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;

// Spatial inertia at a frame's origin, angular first: [[I_o, m c~], [-m c~, m I]].
Mat6 spatial_inertia(double mass, const Vec3& com, const Mat3& inertia_at_com);

// Material and shape of one stretch of rod. Circular cross-section, linear taper of the radius;
// a tube where `hollow` > 0.
struct RodMaterial {
  double density = 1000.0;  // rho [kg/m^3]
  double young = 1e6;       // E [Pa]
  double poisson = 0.5;     // nu; G = E / (2 (1 + nu)) unless `shear` is given
  double viscosity = 0.0;   // Kelvin-Voigt mu [Pa s]: Upsilon = mu diag(Jx, 3Iy, 3Iz, 3A, A, A)
  // G [Pa] given on its own (> 0), for torsion and shear; 0: from poisson. (Last: the brace
  // initialisations {density, young, poisson, viscosity} keep their meaning; placed before
  // viscosity, it took the demo arm's viscosity for G = 2 Pa, and its equilibrium sagged 364 m.)
  double shear = 0.0;
  // A tube: its inner radius over its outer one, 0 <= hollow < 1 (0: a solid rod). The section's
  // area and second moments are the annulus's; the outer radius sets the contacts and the fluid.
  double hollow = 0.0;
  double shear_modulus() const { return shear > 0 ? shear : young / (2.0 * (1.0 + poisson)); }
};

// Area A and second moment of area I (about a diameter; the polar one is 2 I) of the cross-section
// of outer radius r: a disc, or the annulus of a tube (RodMaterial::hollow).
void section_area_moments(const RodMaterial& m, double r, double& A, double& I);

// The largest GVS order of a section, and so the most dofs a section can have (6 strains, each a
// Legendre series of order + 1 terms): fixed-capacity scratch for per-section Jacobians.
constexpr int kMaxSectionOrder = 20;
constexpr int kMaxSectionDofs = 6 * (kMaxSectionOrder + 1);

// A section of a rod (DESIGN.md section 7: nested <section> overrides).
struct SectionSpec {
  double length = 0.0;  // [m]; 0: the rod's length divided evenly
  StrainMask dofs{true, true, true, true, true, true};
  int order = 0;  // 0: piecewise constant strain (PCS); > 0: GVS Legendre order, <= kMaxSectionOrder
  Vec6 rest_strain = (Vec6() << 0, 0, 0, 1, 0, 0).finished();
  RodMaterial material;
  int quadrature = 0;  // Gauss points of the mass quadrature; 0: order + 2 (gauss_points())
  // PCS only: the 3-point Gauss-Lobatto mass rule instead (section ends and middle, weights 1/6,
  // 2/3, 1/6; the ends shared with the neighbouring sections): as exact as 2 Gauss points
  // (cubics), with two nodes and one exponential per section instead of three and two. Its end
  // points sit where a section bent through whole turns has a singular tangent operator: there
  // the section's inertia in some strain directions is underestimated (stiff, spurious modes).
  bool lobatto = false;
  int gauss_points() const { return quadrature > 0 ? quadrature : order + 2; }  // (without lobatto)
  int substeps = 1;    // Magnus steps between consecutive quadrature points (GVS kinematic accuracy
                       // improves as substeps^-4; intermediate nodes carry no inertia)
};

struct RodSpec {
  std::string name;
  double length = 1.0;
  double radius_base = 0.01, radius_tip = -1.0;  // tip < 0: same as base
  int sections = 1;
  SectionSpec section;                // applied to every section ...
  std::vector<SectionSpec> overrides; // ... unless given one by one (then `sections` is ignored)
};

// Whether a 6 x 6 matrix is diagonal, exactly (a rod's lumped inertia and drag are, in its node
// frames).
inline bool is_diagonal(const Mat6& A) {
  for (int c = 0; c < 6; ++c)
    for (int r = 0; r < 6; ++r)
      if (r != c && A(r, c) != 0.0) return false;
  return true;
}

struct Node {
  int parent = -1;        // -1: the base frame
  SE3 offset;             // fixed placement in the parent frame, applied before the motion
  int dof0 = 0, ndof = 0; // dof block of Omega (ndof = 0: a fixed segment)
  double h = 1.0;         // length of the Magnus step
  Mat6X Phi_a, Phi_b;     // 6 x ndof strain basis at the two Gauss points of the step
  Mat6X Phi_m;            // its mean over the step (GVS steps, commutator: the twist's linear term)
  Vec6 xibar_a = Vec6::Zero(), xibar_b = Vec6::Zero();
  bool commutator = false;  // Phi_a != Phi_b or xibar_a != xibar_b
  Mat6 inertia = Mat6::Zero();  // lumped spatial inertia in the node frame
  Mat6 drag = Mat6::Zero();     // lumped fluid resistance in the node frame: wrench -drag * eta on
                                // the node in a fluid at rest (fluid.hpp; zero without a fluid)
  // A node without dofs whose descendants have none either moves rigidly with its parent: the
  // composites of inertia and drag over its subtree are constant in its frame. finalize() computes
  // them (Model::update_fixed_composites: call it again after editing inertia or drag), and crba,
  // fluid_damping and rnea use them instead of visiting the subtree.
  bool fixed_subtree = false;
  Mat6 inertia_sub = Mat6::Zero(), drag_sub = Mat6::Zero();  // those composites, in this frame
  // Whether `inertia` is zero (a massless step), diagonal (a rod's mass point) or neither; set with
  // the composites (update_fixed_composites). rnea takes the cheaper products where it can.
  enum class Shape : signed char { Zero, Diagonal, Full } inertia_shape = Shape::Full;
  // First node of this node's group: a run of nodes sharing one dof block, each the parent of the
  // next (the steps of one rod section). A node without dofs, or one that does not continue its
  // parent's block, starts its own group. Set by finalize().
  int group_first = -1;
  // An earlier node of the same PCS section whose step is this one's (same length to 1e-14, same
  // offset): fwd_position and fwd_velocity copy its step (Omega, g_rel, S, Sdot) instead of
  // recomputing the exponential and its tangents. -1: none. Set by finalize().
  int same_step = -1;
  // Whether fwd_position also keeps the pose at the middle of this node's step, at abscissa X_mid
  // (Data::g_mid; Model::keep_midpoint_pose): a PCS step is then E E with E = exp(Omega / 2), the
  // midpoint's pose coming with it (a collision capsule's end in the middle of a Gauss-rule section).
  bool keep_mid = false;
  double X_mid = 0.0;
  // A PCS step whose strain basis selects components (Section::B_row): G = h B, and S = dexp(-Omega) G
  // is h times the selected columns of dexp(-Omega) (fwd_position takes them). Set by finalize().
  bool selects = false;
  signed char select_row[6] = {-1, -1, -1, -1, -1, -1};  // per dof, the strain component it is
  // A GVS step whose basis columns have one nonzero each, in the same row at both Gauss points (a
  // Legendre polynomial times a selected strain component: Section::B_row): per dof, that row and
  // the column's value at each point. step_twist and fwd_velocity take them instead of the dense
  // 6 x ndof products with Phi_a and Phi_b (the same sums without the zeros). Set by finalize().
  bool sparse_basis = false;
  std::vector<signed char> basis_row;
  VecX basis_a, basis_b, basis_m;
  double dX = 0.0;        // rod length this node stands for in quadratures (0 for non-rod nodes)
  bool free_joint = false;  // a 6-dof free joint (floating base): no static equilibrium
  int rod = -1, section = -1;
  double X = 0.0;         // material abscissa along its rod
  // ndof = 0 (rigid section steps, fixed frames): the constant step, set by finalize()
  Vec6 fixed_Omega = Vec6::Zero();
  SE3 fixed_rel;          // offset * exp(fixed_Omega)
};

struct Section {
  int rod = -1;
  double X0 = 0.0, length = 0.0;
  int dof0 = 0, ndof = 0, order = 0;
  Mat6X B;                 // 6 x nfree selection of free components
  // per column of B, the row it selects (a single 1); -1 where the column is not such a selection
  // (basis_apply then takes the column as it is). Set with B by Model::add_rod.
  int B_row[6] = {-1, -1, -1, -1, -1, -1};
  Vec6 rest_strain;
  RodMaterial material;
  int start_node = -1;     // node at X0 (the rod's attachment frame for the first section)
  int first_node = 0, end_node = 0;  // nodes inside the section: first_node..end_node (end at X0+L)
  // Gauss-Lobatto mass quadrature (SectionSpec::lobatto): the weight, as a fraction of the length, of each
  // end point (1/6), whose mass sits on start_node and end_node (nodes shared with the neighbours,
  // which add their own); 0: Gauss points, all inside the section
  double end_weight = 0.0;
  // Strain basis Phi(X) = B (x) [P_0 .. P_order]((X - X0)/length): dof index = c*(order+1)+k.
  void basis(double X, Mat6X& Phi) const;
  // Its mean over [Xa, Xb] (the basis at Xa when Xb == Xa).
  void basis_mean(double Xa, double Xb, Mat6X& Phi) const;
  // The basis from Legendre weights P = [P_0 .. P_order] (basis, basis_mean).
  void basis_from(const double* P, Mat6X& Phi) const;
  // Phi(X) x for the section's dof block x (strains, or strain rates), given the Legendre weights
  // P = [P_0 .. P_order]((X - X0)/length) (legendre01): no matrix is formed.
  Vec6 basis_apply(const double* P, const double* x) const;
  // Whether the axial strain p_x is a dof of this section (it can stretch and collapse): set with B
  // by Model::add_rod (min_axial_stretch reads it at every evaluation).
  bool axial = false;
  bool axial_free() const { return axial; }
};

struct Rod {
  std::string name;
  double length = 0.0, radius_base = 0.0, radius_tip = 0.0;
  int parent = -1;      // node the rod hangs from (-1: base)
  SE3 placement;        // X = 0 frame in the parent frame
  int first_section = 0, nsections = 0;
  int tip_node = -1;
  // The rod's nodes are first_node..tip_node (contiguous, X increasing). base_node: a fixed node at
  // X = 0 carrying the mass point the first section's Gauss-Lobatto rule puts there (-1: none);
  // it is first_node then, and the first section's start_node.
  int first_node = -1, base_node = -1;
  double radius(double X) const { return radius_base + (radius_tip - radius_base) * X / length; }
};

// Cross-section constants at a radius: stiffness Sigma, inertia density, damping (DESIGN.md s.3).
Vec6 section_stiffness(const RodMaterial& m, double r);
Vec6 section_inertia_density(const RodMaterial& m, double r);
Vec6 section_damping(const RodMaterial& m, double r);

// A cable (tendon) routed inside a rod at a cross-section offset d(X) (y, z components used),
// linear from d_begin at X_begin to d_end at X_end. Its tension pulls the rod's sections together:
// generalised force tau = -T dl/dq with l the cable length (DESIGN.md section 5's F_a).
struct Cable {
  int rod = 0;
  Vec3 d_begin = Vec3::Zero(), d_end = Vec3::Zero();
  double X_begin = 0.0, X_end = -1.0;  // X_end < 0: the rod's tip
  // Quadrature of the cable's integrals, filled by Model::add_cable: Gauss points of each section
  // piece the cable spans (order + 3 points: exact for PCS where the integrand is constant).
  struct Point {
    double X, w;
    int section;
  };
  std::vector<Point> points;
};

// An input u: a cable tension [N] or a generalised force on one dof [N or N m].
struct Actuator {
  enum Kind { CableTension, DofForce } kind = DofForce;
  int index = 0;  // cable index or dof index
  std::string name;
};

struct Model {
  std::vector<Node> nodes;
  std::vector<Section> sections;
  std::vector<Rod> rods;
  std::vector<Cable> cables;
  std::vector<Actuator> actuators;
  int nv = 0;  // number of generalised coordinates (q and v have the same size)
  Vec3 gravity = Vec3(0, 0, -9.81);  // world frame
  MatX K, D;        // constant stiffness and damping matrices (nv x nv)
  VecX q_ref;       // q where the elastic force vanishes (zero for rods: q is the strain change)
  std::vector<int> children_begin, children;  // CSR children lists, built by finalize()
  int max_ndof = 0;
  bool finalized = false;

  // --- building (before finalize) ---
  // Rigid joint at `placement` in `parent` (node, or -1 for the base). Returns its node.
  int add_joint(int parent, const SE3& placement, JointType type, const Vec3& axis = Vec3::UnitZ(),
                double pitch = 0.0, double stiffness = 0.0, double damping = 0.0);
  // A fixed frame (no dof) at `placement` in `parent`. Returns its node.
  int add_frame(int parent, const SE3& placement);
  // Add rigid-body inertia (mass, centre of mass and inertia about it, in the node frame; on a
  // finalized model it refreshes the composites itself).
  void add_body(int node, double mass, const Vec3& com, const Mat3& inertia_at_com);
  // A rod hanging at `placement` in `parent`. Returns the rod index; its tip is rods[r].tip_node.
  int add_rod(int parent, const SE3& placement, const RodSpec& spec);
  int add_cable(const Cable& c, const std::string& name = "");  // also adds its actuator
  int add_dof_actuator(int dof, const std::string& name = "");
  // Computes K, D, the child lists and the fixed-subtree composites. Throws std::invalid_argument
  // on inconsistent input.
  void finalize();
  // Node::inertia_sub and Node::drag_sub from the nodes' inertia and drag (finalize and
  // set_rod_drag call it; call it yourself after editing them on a finalized model).
  void update_fixed_composites();

  // --- queries ---
  int nu() const { return static_cast<int>(actuators.size()); }
  int rod_index(const std::string& name) const;  // -1 if absent
  // Node whose step contains abscissa X of rod r (the first node with node.X >= X).
  int rod_node_at(int rod, double X) const;
  // If abscissa X of rod `rod` is the middle of a PCS step with dofs (to 1e-13 of the rod's
  // length), has fwd_position keep its pose in Data::g_mid (Node::keep_mid, X_mid = X), which
  // rod_pose(rod, X) then returns, and returns the node; -1 otherwise (nothing changes). After
  // finalize().
  int keep_midpoint_pose(int rod, double X);

 private:
  std::vector<double> joint_stiffness_, joint_damping_;
  std::vector<int> joint_dof_;
};

// A node below the root of a fixed subtree (Node::fixed_subtree): it moves rigidly with that root,
// whose cached composites stand for it (crba and rnea lump the subtree there).
inline bool inside_fixed_subtree(const Model& m, const Node& n) {
  return n.fixed_subtree && n.parent >= 0 && m.nodes[n.parent].fixed_subtree;
}

enum class Status { Ok, Diverged };

// Eigen::LDLT whose status is defined from construction. Eigen 3.4's constructors leave m_info
// uninitialised, so copying or moving a Data before its first factorisation (a scene's vector of
// rods growing, a state saved for a finite difference) read it: undefined behaviour, which UBSan
// reports as "load of value 4, which is not a valid value for type 'ComputationInfo'".
struct Factor : Eigen::LDLT<MatX> {
  Factor() { m_info = Eigen::Success; }
  explicit Factor(Eigen::Index n) : Eigen::LDLT<MatX>(n) { m_info = Eigen::Success; }
};

// State, outputs and all scratch memory, sized once by the constructor (no allocation when
// stepping: see tests/core/step_alloc_test.cpp).
struct Data {
  explicit Data(const Model& m);

  // state and inputs
  double time = 0.0;
  VecX q, v;      // generalised coordinates and velocities (nv)
  VecX ctrl;      // actuator inputs (nu)
  SE3 base_pose;  // pose of the base frame in the world
  Vec6 base_twist = Vec6::Zero(), base_accel = Vec6::Zero();  // in the base frame
  std::vector<Vec6> f_ext_body;   // per node: external wrench [m; f] in the node frame
  std::vector<Vec6> f_ext_world;  // per node: [moment; force] in world axes, applied at the node origin
  // A rigid-body spatial inertia [[I_o, h~], [-h~, m 1]] (about node attached_node's origin, in its
  // frame) that moves rigidly with that node: a load the caller hangs on the tree for crba and rnea
  // only (the MuJoCo coupling's payload below a rod's tip, whose inertia and weight are then the
  // core's rather than MuJoCo's). It is not part of the model: centre of mass, momentum, energy and
  // the model's own statics leave it out. -1: none.
  int attached_node = -1;
  Mat6 attached_inertia = Mat6::Zero();
  // Whether crba fills the base coupling Ic_base and F_base. The MuJoCo coupling sets it false
  // for a rod whose base body cannot move (no dofs above it), where nothing reads them: they are
  // then left zero, and crba skips the base-frame force subspace of the dof groups that have no
  // ancestor with dofs (a one-section rod's whole walk of its mass points to its base).
  bool crba_base = true;

  // outputs
  VecX qacc;          // generalised accelerations (nv)
  VecX qfrc_bias;     // Coriolis, centrifugal, gravity and external loads: M qacc + bias = passive + actuation
  VecX qfrc_passive;  // -K (q - q_ref) - D v
  VecX qfrc_actuator; // from ctrl
  MatX M;             // mass matrix (nv x nv)
  Status status = Status::Ok;

  // kinematics per node
  std::vector<SE3> g;      // world pose
  std::vector<SE3> g_rel;  // pose in the parent frame
  std::vector<SE3> g_mid;  // world pose at the middle of the step, where Node::keep_mid
  std::vector<Vec6> Omega, Omega_dot;
  std::vector<Mat6X> G;    // dOmega/dq_i (6 x ndof)
  std::vector<Mat6X> S;    // motion subspace dexp(-Omega) G (6 x ndof)
  std::vector<Mat6> Dm;    // dexp(-Omega) of the steps with a commutator (GVS; fwd_position, for fwd_velocity)
  std::vector<Mat6X> Sdot; // its time derivative (6 x ndof; fwd_velocity): cbias = ad_eta S v + Sdot v
  std::vector<Vec6> Sdot_v; // Sdot v (fwd_velocity, also when the matrix Sdot is not computed)
  // Group Jacobians (Node::group_first): Jg_i = twist of node i per unit velocity of its own dof
  // block relative to the frame its group hangs from, in node i's frame (fwd_position: Jg_i =
  // Ad^-1_{g_rel,i} Jg_parent + S_i within a group); its time derivative Jgdot (group_jacobian_dot);
  // g_grp_i = pose of node i in that frame. At a section end, Jg is section_jacobian's J.
  std::vector<Mat6X> Jg, Jgdot;
  std::vector<SE3> g_grp;
  std::vector<Vec6> eta;   // body twist
  std::vector<Vec6> cbias; // velocity-product acceleration of the step: ad_eta S v + dS/dt v
  std::vector<Vec6> acc;   // body acceleration (scratch of rnea)
  std::vector<Vec6> F;     // subtree wrench (scratch of rnea)
  std::vector<Mat6> Ic;    // composite inertia (scratch of crba)
  // (scratch of composite) a node's own matrix plus the composites of its children outside its
  // dof group, where that is neither zero nor the node's own diagonal matrix (Ic_off_kind)
  std::vector<Mat6> Ic_off;
  std::vector<signed char> Ic_off_kind;
  // what the tree transmits to its base (for coupling to a moving parent body):
  Mat6 Ic_base = Mat6::Zero();   // composite inertia of everything, base frame (crba)
  Mat6X F_base;                  // 6 x nv: base-frame wrench per unit qacc (crba): M_base,q
  Vec6 f_base = Vec6::Zero();    // base-frame wrench the base supplies to the tree (rnea)
  // fluid damping (fluid_damping in fluid.hpp: composite of Node::drag, like crba's outputs):
  // the generalised drag of the tree with base twist eta_b is -(D_fluid v + DF_base^T eta_b),
  // and the base receives the wrench -(DF_base v + Dc_base eta_b).
  MatX D_fluid;                  // nv x nv
  Mat6 Dc_base = Mat6::Zero();   // 6 x 6
  Mat6X DF_base;                 // 6 x nv

  // scratch
  Mat6X Fs, Ts;            // 6 x max_ndof
  VecX tmp, rhs;
  MatX A;                  // system matrix of the implicit integrator
  Factor ldlt;
  VecX q0, v0, kq[4], kv[4];  // RK4 and Rosenbrock stages
  MatX M0;                    // Rosenbrock: the mass matrix at the step's start
  Factor ldlt_w;              // Rosenbrock: the step's matrix (forward() factorises M in ldlt)
};

}  // namespace cosserat
