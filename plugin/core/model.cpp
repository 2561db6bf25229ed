// Building the node tree of a soft-rigid model (see model.hpp for the structure).
#include "model.hpp"

#include "kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cosserat {

namespace {
constexpr double kSqrt3 = 1.7320508075688772;

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}
}  // namespace

Mat6 spatial_inertia(double m, const Vec3& c, const Mat3& Ic) {
  const Mat3 C = skew(c);
  Mat6 I;
  I << Ic - m * C * C, m * C, -m * C, m * Mat3::Identity();
  return I;
}

void section_area_moments(const RodMaterial& m, double r, double& A, double& I) {
  const double k2 = m.hollow * m.hollow;
  A = M_PI * r * r * (1.0 - k2);
  I = M_PI * r * r * r * r / 4.0 * (1.0 - k2 * k2);
}

Vec6 section_stiffness(const RodMaterial& mat, double r) {
  double A, I;
  section_area_moments(mat, r, A, I);
  const double J = 2.0 * I;
  const double G = mat.shear_modulus();
  Vec6 s;
  s << G * J, mat.young * I, mat.young * I, mat.young * A, G * A, G * A;
  return s;
}

Vec6 section_inertia_density(const RodMaterial& mat, double r) {
  double A, I;
  section_area_moments(mat, r, A, I);
  const double J = 2.0 * I;
  return mat.density * (Vec6() << J, I, I, A, A, A).finished();
}

Vec6 section_damping(const RodMaterial& mat, double r) {
  double A, I;
  section_area_moments(mat, r, A, I);
  const double J = 2.0 * I;
  return mat.viscosity * (Vec6() << J, 3 * I, 3 * I, 3 * A, A, A).finished();
}

void Section::basis_from(const double* P, Mat6X& Phi) const {
  const int nb = order + 1;
  Phi.setZero(6, ndof);
  for (int c = 0; c < B.cols(); ++c)
    for (int k = 0; k < nb; ++k) Phi.col(c * nb + k) = B.col(c) * P[k];
}

void Section::basis(double X, Mat6X& Phi) const {
  double P[32];
  legendre01(order, (X - X0) / length, P);
  basis_from(P, Phi);
}

void Section::basis_mean(double Xa, double Xb, Mat6X& Phi) const {
  double P[32];
  legendre01_mean(order, (Xa - X0) / length, (Xb - X0) / length, P);
  basis_from(P, Phi);
}

Vec6 Section::basis_apply(const double* P, const double* x) const {
  const int nb = order + 1;
  Vec6 out = Vec6::Zero();
  for (int c = 0; c < B.cols(); ++c) {
    double coef = 0.0;
    for (int k = 0; k < nb; ++k) coef += x[c * nb + k] * P[k];
    // a selecting column adds coef to its row and (+-)0 to the others, which leaves them +0: the
    // same sums without the dynamic column's arithmetic
    if (B_row[c] >= 0)
      out(B_row[c]) += coef;
    else
      out += B.col(c) * coef;
  }
  return out;
}

int Model::add_joint(int parent, const SE3& placement, JointType type, const Vec3& axis, double pitch,
                     double stiffness, double damping) {
  require(!finalized, "add_joint after finalize");
  require(parent >= -1 && parent < static_cast<int>(nodes.size()), "add_joint: bad parent node");
  require(axis.norm() > 0, "add_joint: zero axis");
  Node n;
  n.parent = parent;
  n.offset = placement;
  n.dof0 = nv;
  n.ndof = joint_dofs(type);
  n.h = 1.0;
  n.Phi_a = n.Phi_b = joint_basis(type, axis, pitch);
  n.free_joint = type == JointType::Free;
  for (int k = 0; k < n.ndof; ++k) {
    joint_dof_.push_back(nv + k);
    joint_stiffness_.push_back(stiffness);
    joint_damping_.push_back(damping);
  }
  nv += n.ndof;
  nodes.push_back(n);
  return static_cast<int>(nodes.size()) - 1;
}

int Model::add_frame(int parent, const SE3& placement) {
  require(!finalized, "add_frame after finalize");
  require(parent >= -1 && parent < static_cast<int>(nodes.size()), "add_frame: bad parent node");
  Node n;
  n.parent = parent;
  n.offset = placement;
  n.dof0 = nv;
  n.ndof = 0;
  n.Phi_a = n.Phi_b = Mat6X(6, 0);
  nodes.push_back(n);
  return static_cast<int>(nodes.size()) - 1;
}

void Model::add_body(int node, double mass, const Vec3& com, const Mat3& inertia_at_com) {
  require(node >= 0 && node < static_cast<int>(nodes.size()), "add_body: bad node");
  require(mass >= 0, "add_body: negative mass");
  nodes[node].inertia += spatial_inertia(mass, com, inertia_at_com);
  if (finalized) update_fixed_composites();  // (the composites and Node::inertia_shape)
}

int Model::add_rod(int parent, const SE3& placement, const RodSpec& spec) {
  require(!finalized, "add_rod after finalize");
  require(parent >= -1 && parent < static_cast<int>(nodes.size()), "add_rod: bad parent node");
  require(spec.length > 0, "rod '" + spec.name + "': length must be positive");
  require(spec.radius_base > 0, "rod '" + spec.name + "': radius must be positive");
  require(spec.sections >= 1, "rod '" + spec.name + "': sections must be >= 1");
  Rod rod;
  rod.name = spec.name;
  rod.length = spec.length;
  rod.radius_base = spec.radius_base;
  rod.radius_tip = spec.radius_tip > 0 ? spec.radius_tip : spec.radius_base;
  rod.parent = parent;
  rod.placement = placement;
  rod.first_section = static_cast<int>(sections.size());
  const int rod_id = static_cast<int>(rods.size());

  std::vector<SectionSpec> specs = spec.overrides;
  if (specs.empty()) specs.assign(spec.sections, spec.section);
  double given = 0.0;
  int unsized = 0;
  for (const auto& s : specs) {
    require(s.length >= 0, "rod '" + spec.name + "': negative section length");
    given += s.length;
    unsized += s.length == 0.0;
  }
  require(unsized > 0 ? given < spec.length : std::abs(given - spec.length) < 1e-9 * spec.length,
          "rod '" + spec.name + "': section lengths do not add up to the rod length");
  const double fill = unsized > 0 ? (spec.length - given) / unsized : 0.0;

  int prev = parent;
  double X0 = 0.0;
  std::vector<double> gx, gw;
  for (const auto& ss : specs) {
    require(ss.order >= 0 && ss.order <= kMaxSectionOrder,
            "rod '" + spec.name + "': order must be in [0, " + std::to_string(kMaxSectionOrder) + "]");
    require(ss.material.density > 0 && ss.material.young > 0,
            "rod '" + spec.name + "': density and Young's modulus must be positive");
    require(ss.material.poisson > -1.0 && ss.material.poisson <= 0.5,
            "rod '" + spec.name + "': Poisson ratio must be in (-1, 0.5]");
    require(ss.material.shear >= 0, "rod '" + spec.name + "': negative shear modulus");
    require(ss.material.viscosity >= 0, "rod '" + spec.name + "': negative viscosity");
    Section sec;
    sec.rod = rod_id;
    sec.X0 = X0;
    sec.length = ss.length > 0 ? ss.length : fill;
    sec.order = ss.order;
    sec.B = basis_from_mask(ss.dofs);
    for (int c = 0; c < sec.B.cols(); ++c) {
      int row = -1, nonzeros = 0;
      for (int i = 0; i < 6; ++i)
        if (sec.B(i, c) != 0.0) {
          ++nonzeros;
          row = i;
        }
      sec.B_row[c] = nonzeros == 1 && sec.B(row, c) == 1.0 ? row : -1;
    }
    sec.ndof = static_cast<int>(sec.B.cols()) * (ss.order + 1);
    sec.axial = sec.ndof > 0 && !sec.B.row(3).isZero();
    sec.dof0 = nv;
    sec.rest_strain = ss.rest_strain;
    sec.material = ss.material;
    nv += sec.ndof;

    // mass quadrature: Gauss points, or for PCS optionally the 3-point Gauss-Lobatto rule (0, 1/2,
    // 1; weights 1/6, 2/3, 1/6), as exact (cubics) with one node per section less: its end points
    // are the frames at the section's ends, which the neighbouring sections share
    require(!ss.lobatto || (ss.order == 0 && ss.quadrature == 0),
            "rod '" + spec.name + "': the Gauss-Lobatto mass rule is for PCS sections (order 0), without a Gauss point count");
    require(ss.quadrature == 0 || ss.quadrature > ss.order || sec.ndof == 0,
            "rod '" + spec.name + "': " + std::to_string(ss.quadrature) + " Gauss points for a section of order " +
                std::to_string(ss.order) + ": the mass matrix needs at least order + 1");
    const bool lobatto = ss.lobatto;
    const int nq = lobatto ? 1 : ss.gauss_points();
    if (lobatto) gx = {0.5}, gw = {2.0 / 3.0};
    else gauss_legendre01(nq, gx, gw);
    const double w_end = lobatto ? 1.0 / 6.0 : 0.0;  // weight of each end point
    sec.end_weight = w_end;
    if (lobatto) {  // the start point: the previous section's end frame, or a fixed one at the base
      if (prev == parent) {
        Node n;
        n.parent = parent;
        n.offset = placement;
        n.h = 0.0;
        n.rod = rod_id;
        n.section = static_cast<int>(sections.size());
        n.X = X0;
        nodes.push_back(n);
        prev = static_cast<int>(nodes.size()) - 1;
        rod.base_node = prev;
      }
      nodes[prev].dX += w_end * sec.length;
      nodes[prev].inertia += (w_end * sec.length * section_inertia_density(ss.material, rod.radius(X0))).asDiagonal();
    }
    sec.start_node = prev;
    sec.first_node = static_cast<int>(nodes.size());
    require(ss.substeps >= 1, "rod '" + spec.name + "': substeps must be >= 1");
    double Xprev = X0;
    for (int j = 0; j <= nq; ++j) {
      const double Xq = j < nq ? X0 + gx[j] * sec.length : X0 + sec.length;
      const double Xstart = Xprev;
      // a GVS interval is split into `substeps` Magnus steps; PCS steps are exact already
      const int nsub = sec.order > 0 ? ss.substeps : 1;
      for (int k = 1; k <= nsub; ++k) {
        const double X = k == nsub ? Xq : Xstart + (Xq - Xstart) * k / nsub;
        Node n;
        n.parent = prev;
        n.offset = (prev == parent) ? placement : SE3::Identity();
        n.dof0 = sec.dof0;
        n.ndof = sec.ndof;
        n.h = X - Xprev;
        sec.basis(Xprev + n.h * (0.5 - kSqrt3 / 6.0), n.Phi_a);
        sec.basis(Xprev + n.h * (0.5 + kSqrt3 / 6.0), n.Phi_b);
        n.xibar_a = n.xibar_b = sec.rest_strain;
        n.commutator = sec.order > 0;
        if (n.commutator) sec.basis_mean(Xprev, X, n.Phi_m);
        if (k == nsub && (j < nq || w_end > 0.0)) {
          n.dX = (j < nq ? gw[j] : w_end) * sec.length;
          n.inertia = (n.dX * section_inertia_density(ss.material, rod.radius(X))).asDiagonal();
        }
        n.rod = rod_id;
        n.section = static_cast<int>(sections.size());
        n.X = X;
        nodes.push_back(n);
        prev = static_cast<int>(nodes.size()) - 1;
        Xprev = X;
      }
    }
    sec.end_node = prev;
    sections.push_back(sec);
    X0 += sec.length;
  }
  rod.nsections = static_cast<int>(specs.size());
  rod.tip_node = prev;
  rod.first_node = rod.base_node >= 0 ? rod.base_node : sections[rod.first_section].first_node;
  rods.push_back(rod);
  return rod_id;
}

int Model::add_cable(const Cable& c, const std::string& name) {
  require(c.rod >= 0 && c.rod < static_cast<int>(rods.size()), "add_cable: bad rod");
  Cable cc = c;
  if (cc.X_end < 0) cc.X_end = rods[c.rod].length;
  require(cc.X_begin >= 0 && cc.X_begin < cc.X_end && cc.X_end <= rods[c.rod].length * (1 + 1e-12),
          "add_cable: need 0 <= X_begin < X_end <= rod length");
  const Rod& rod = rods[c.rod];
  std::vector<double> gx, gw;
  for (int si = rod.first_section; si < rod.first_section + rod.nsections; ++si) {
    const Section& sec = sections[si];
    const double a = std::max(sec.X0, cc.X_begin), b = std::min(sec.X0 + sec.length, cc.X_end);
    if (b <= a) continue;
    gauss_legendre01(sec.order + 3, gx, gw);
    for (size_t j = 0; j < gx.size(); ++j) cc.points.push_back({a + gx[j] * (b - a), gw[j] * (b - a), si});
  }
  cables.push_back(cc);
  actuators.push_back({Actuator::CableTension, static_cast<int>(cables.size()) - 1, name});
  return static_cast<int>(actuators.size()) - 1;
}

int Model::add_dof_actuator(int dof, const std::string& name) {
  require(dof >= 0 && dof < nv, "add_dof_actuator: bad dof");
  actuators.push_back({Actuator::DofForce, dof, name});
  return static_cast<int>(actuators.size()) - 1;
}

void Model::finalize() {
  require(!finalized, "finalize called twice");
  for (Node& n : nodes)  // steps without dofs are constant: computed once
    if (n.ndof == 0) {
      n.fixed_Omega = step_twist(n, VecX(), nullptr);
      n.fixed_rel = n.offset * exp_se3(n.fixed_Omega);
    }
  K = MatX::Zero(nv, nv);
  D = MatX::Zero(nv, nv);
  q_ref = VecX::Zero(nv);
  for (size_t k = 0; k < joint_dof_.size(); ++k) {
    K(joint_dof_[k], joint_dof_[k]) += joint_stiffness_[k];
    D(joint_dof_[k], joint_dof_[k]) += joint_damping_[k];
  }
  // K = int Phi^T Sigma Phi dX, D = int Phi^T Upsilon Phi dX (DESIGN.md section 5). The integrand
  // is a polynomial of degree 2 order + 4 (r^4 under a linear taper): order + 3 points are exact.
  std::vector<double> gx, gw;
  Mat6X Phi;
  for (const auto& sec : sections) {
    if (sec.ndof == 0) continue;
    gauss_legendre01(sec.order + 4, gx, gw);
    const Rod& rod = rods[sec.rod];
    for (size_t j = 0; j < gx.size(); ++j) {
      const double X = sec.X0 + gx[j] * sec.length, w = gw[j] * sec.length;
      sec.basis(X, Phi);
      const double r = rod.radius(X);
      K.block(sec.dof0, sec.dof0, sec.ndof, sec.ndof) +=
          w * Phi.transpose() * section_stiffness(sec.material, r).asDiagonal() * Phi;
      D.block(sec.dof0, sec.dof0, sec.ndof, sec.ndof) +=
          w * Phi.transpose() * section_damping(sec.material, r).asDiagonal() * Phi;
    }
  }
  const int nn = static_cast<int>(nodes.size());
  children_begin.assign(nn + 2, 0);  // entry p+1 lists the children of node p (p = -1: base)
  for (const auto& n : nodes) children_begin[n.parent + 2]++;
  for (int i = 1; i < nn + 2; ++i) children_begin[i] += children_begin[i - 1];
  children.assign(nn, 0);
  std::vector<int> fill(children_begin.begin(), children_begin.end() - 1);
  for (int i = 0; i < nn; ++i) children[fill[nodes[i].parent + 1]++] = i;
  max_ndof = 0;
  for (const auto& n : nodes) max_ndof = std::max(max_ndof, n.ndof);
  // fixed subtrees (children come after their parents: add_* appends them so) and groups
  for (int i = 0; i < nn; ++i) {
    Node& n = nodes[i];
    require(n.parent < i, "internal: a node precedes its parent");
    const bool continues = n.ndof > 0 && n.parent >= 0 && nodes[n.parent].ndof == n.ndof &&
                           nodes[n.parent].dof0 == n.dof0;
    n.group_first = continues ? nodes[n.parent].group_first : i;
    n.selects = false;
    if (n.ndof > 0 && !n.commutator && n.section >= 0 && sections[n.section].order == 0) {
      const Section& sec = sections[n.section];
      n.selects = n.Phi_a == sec.B && n.Phi_b == sec.B && n.xibar_a == n.xibar_b;
      for (int c = 0; c < n.ndof; ++c) n.selects = n.selects && sec.B_row[c] >= 0;
      if (n.selects)
        for (int c = 0; c < n.ndof; ++c) n.select_row[c] = static_cast<signed char>(sec.B_row[c]);
    }
    n.sparse_basis = false;
    if (n.ndof > 0 && n.commutator && n.section >= 0 && n.Phi_a.cols() == n.ndof && n.Phi_b.cols() == n.ndof &&
        n.Phi_m.cols() == n.ndof) {
      const Section& sec = sections[n.section];
      const int nb = sec.order + 1;
      n.basis_row.assign(n.ndof, -1);
      n.basis_a = VecX::Zero(n.ndof), n.basis_b = VecX::Zero(n.ndof), n.basis_m = VecX::Zero(n.ndof);
      n.sparse_basis = n.ndof == sec.ndof;
      for (int k = 0; k < n.ndof && n.sparse_basis; ++k) {
        const int r = sec.B_row[k / nb];
        if (r < 0) {
          n.sparse_basis = false;
          break;
        }
        Vec6 ea = Vec6::Zero(), eb = Vec6::Zero(), em = Vec6::Zero();
        ea(r) = n.Phi_a(r, k), eb(r) = n.Phi_b(r, k), em(r) = n.Phi_m(r, k);
        n.sparse_basis = n.Phi_a.col(k) == ea && n.Phi_b.col(k) == eb && n.Phi_m.col(k) == em;
        n.basis_row[k] = static_cast<signed char>(r), n.basis_a(k) = ea(r), n.basis_b(k) = eb(r), n.basis_m(k) = em(r);
      }
    }
    n.same_step = -1;
    if (n.ndof > 0 && !n.commutator && n.section >= 0)  // PCS: the step is a function of h alone
      for (int j = sections[n.section].first_node; j < i && n.same_step < 0; ++j) {
        const Node& o = nodes[j];
        if (o.ndof == n.ndof && o.dof0 == n.dof0 && !o.commutator && std::abs(o.h - n.h) <= 1e-14 * n.h &&
            o.offset.R == n.offset.R && o.offset.u == n.offset.u && o.Phi_a == n.Phi_a && o.Phi_b == n.Phi_b &&
            o.xibar_a == n.xibar_a && o.xibar_b == n.xibar_b)
          n.same_step = j;
      }
  }
  for (int i = nn - 1; i >= 0; --i) {
    bool fixed = nodes[i].ndof == 0;
    for (int k = children_begin[i + 1]; k < children_begin[i + 2] && fixed; ++k) fixed = nodes[children[k]].fixed_subtree;
    nodes[i].fixed_subtree = fixed;
  }
  for (const Node& n : nodes) {  // crba's congruence relies on the rigid-body form
    const Mat6& I = n.inertia;
    const double scale = 1e-12 * (1.0 + I.norm());
    const Mat3 H = I.topRightCorner<3, 3>();
    require((I.bottomRightCorner<3, 3>() - I(3, 3) * Mat3::Identity()).norm() <= scale &&
                (H + H.transpose()).norm() <= scale && (I.bottomLeftCorner<3, 3>() + H).norm() <= scale &&
                (I.topLeftCorner<3, 3>() - I.topLeftCorner<3, 3>().transpose()).norm() <= scale,
            "internal: a node inertia is not a rigid-body spatial inertia");
  }
  for (const Rod& rod : rods) {  // rod_node_at bisects: a rod's nodes are contiguous, X increasing
    const int a = sections[rod.first_section].first_node, b = sections[rod.first_section + rod.nsections - 1].end_node;
    for (int i = a + 1; i <= b; ++i)
      require(nodes[i].rod == nodes[a].rod && nodes[i].X > nodes[i - 1].X, "internal: rod nodes out of order");
  }
  finalized = true;
  update_fixed_composites();
}

void Model::update_fixed_composites() {
  const int nn = static_cast<int>(nodes.size());
  for (Node& n : nodes) {
    const Mat6& I = n.inertia;
    n.inertia_shape = !is_diagonal(I)              ? Node::Shape::Full
                      : I.diagonal().isZero(0.0) ? Node::Shape::Zero
                                                 : Node::Shape::Diagonal;
  }
  for (int i = nn - 1; i >= 0; --i) {
    Node& n = nodes[i];
    if (!n.fixed_subtree) continue;
    n.inertia_sub = n.inertia;
    n.drag_sub = n.drag;
    for (int k = children_begin[i + 1]; k < children_begin[i + 2]; ++k) {
      const Node& c = nodes[children[k]];
      const Mat6 X = Ad_inv(c.fixed_rel);  // node twist -> child twist
      n.inertia_sub.noalias() += X.transpose() * c.inertia_sub * X;
      n.drag_sub.noalias() += X.transpose() * c.drag_sub * X;
    }
  }
}

int Model::rod_index(const std::string& name) const {
  for (size_t r = 0; r < rods.size(); ++r)
    if (rods[r].name == name) return static_cast<int>(r);
  return -1;
}

int Model::rod_node_at(int r, double X) const {
  // a rod's nodes are contiguous with increasing X (add_rod appends them in order): bisection
  const Rod& rod = rods[r];
  int lo = sections[rod.first_section].first_node, hi = sections[rod.first_section + rod.nsections - 1].end_node;
  if (nodes[hi].X < X) return hi;
  while (lo < hi) {  // the first node in [lo, hi] with X_node >= X
    const int mid = lo + (hi - lo) / 2;
    if (nodes[mid].X >= X) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

int Model::keep_midpoint_pose(int r, double X) {
  require(finalized, "keep_midpoint_pose: call finalize() first");
  require(r >= 0 && r < static_cast<int>(rods.size()), "keep_midpoint_pose: bad rod");
  const int i = rod_node_at(r, X);
  Node& n = nodes[i];
  if (n.ndof == 0 || n.commutator || n.same_step >= 0 || n.rod != r) return -1;
  if (std::abs(X - (n.X - 0.5 * n.h)) > 1e-13 * rods[r].length) return -1;
  n.keep_mid = true;
  n.X_mid = X;
  return i;
}

Data::Data(const Model& m) {
  if (!m.finalized) throw std::invalid_argument("Data(model): model not finalized");
  int max_ndof = 0;
  for (const Section& sec : m.sections) max_ndof = std::max(max_ndof, sec.ndof);
  reserve_kinematics_scratch(max_ndof);  // the point Jacobians' scratch: no allocation in a step
  const int n = m.nv, nn = static_cast<int>(m.nodes.size());
  q = VecX::Zero(n);
  v = VecX::Zero(n);
  ctrl = VecX::Zero(m.nu());
  f_ext_body.assign(nn, Vec6::Zero());
  f_ext_world.assign(nn, Vec6::Zero());
  qacc = qfrc_bias = qfrc_passive = qfrc_actuator = VecX::Zero(n);
  M = MatX::Zero(n, n);
  g.assign(nn, SE3());
  g_rel.assign(nn, SE3());
  g_mid.assign(nn, SE3());
  Omega.assign(nn, Vec6::Zero());
  Omega_dot.assign(nn, Vec6::Zero());
  Sdot_v.assign(nn, Vec6::Zero());
  G.resize(nn);
  S.resize(nn);
  Dm.assign(nn, Mat6::Identity());
  Sdot.resize(nn);
  Jg.resize(nn);
  Jgdot.resize(nn);
  for (int i = 0; i < nn; ++i) {
    G[i] = Mat6X::Zero(6, m.nodes[i].ndof);
    S[i] = Mat6X::Zero(6, m.nodes[i].ndof);
    Sdot[i] = Mat6X::Zero(6, m.nodes[i].ndof);
    Jg[i] = Mat6X::Zero(6, m.nodes[i].ndof);
    Jgdot[i] = Mat6X::Zero(6, m.nodes[i].ndof);
  }
  g_grp.assign(nn, SE3());
  eta.assign(nn, Vec6::Zero());
  cbias.assign(nn, Vec6::Zero());
  acc.assign(nn, Vec6::Zero());
  F.assign(nn, Vec6::Zero());
  Ic.assign(nn, Mat6::Zero());
  Ic_off.assign(nn, Mat6::Zero());
  Ic_off_kind.assign(nn, 0);
  Fs = Ts = Mat6X::Zero(6, m.max_ndof);
  F_base = Mat6X::Zero(6, n);
  D_fluid = MatX::Zero(n, n);
  DF_base = Mat6X::Zero(6, n);
  tmp = rhs = VecX::Zero(n);
  A = MatX::Zero(n, n);
  ldlt = Factor(n);  // buffers allocated here: steps then allocate nothing
  q0 = v0 = VecX::Zero(n);
  for (int k = 0; k < 4; ++k) kq[k] = kv[k] = VecX::Zero(n);
  M0 = MatX::Zero(n, n);
  ldlt_w = Factor(n);
}

}  // namespace cosserat
