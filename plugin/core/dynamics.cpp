#include "dynamics.hpp"

#include <cmath>

#include "kinematics.hpp"

namespace cosserat {

namespace {
// Children of node p (p = -1: the base) as a range in m.children.
struct ChildRange {
  const int *b, *e;
  const int* begin() const { return b; }
  const int* end() const { return e; }
};
ChildRange children_of(const Model& m, int p) {
  return {m.children.data() + m.children_begin[p + 1], m.children.data() + m.children_begin[p + 2]};
}

// M U with U = u~ (row by row: (M U)_i = (m_i x u)^T, m_i the i-th row of M).
inline Mat3 mul_skew(const Mat3& M, const Vec3& u) {
  Mat3 r;
  for (int i = 0; i < 3; ++i) r.row(i) = Vec3(M.row(i).transpose()).cross(u).transpose();
  return r;
}
// U M with U = u~ (column by column).
inline Mat3 skew_mul(const Vec3& u, const Mat3& M) {
  Mat3 r;
  for (int j = 0; j < 3; ++j) r.col(j) = u.cross(M.col(j));
  return r;
}

// out += X^T A X with X = Ad_inv(g) = [[R^T, 0], [-R^T U, R^T]] = diag(R^T, R^T) [[I, 0], [-U, I]]
// (U = u~), for a general (not necessarily symmetric) A = [[A11, A12], [A21, A22]]. With the
// rotated blocks A'_ij = R A_ij R^T:
//   X^T A X = [[A11' + U A21' - T12 U, T12], [A21' - A22' U, A22']],  T12 = A12' + U A22'.
void add_congruence_Ad_inv(const SE3& g, const Mat6& A, Mat6& out) {
  const Mat3& R = g.R;
  const Vec3& u = g.u;
  const Mat3 Rt = R.transpose();
  const Mat3 A11 = R * (A.topLeftCorner<3, 3>() * Rt);
  const Mat3 A12 = R * (A.topRightCorner<3, 3>() * Rt);
  const Mat3 A21 = R * (A.bottomLeftCorner<3, 3>() * Rt);
  const Mat3 A22 = R * (A.bottomRightCorner<3, 3>() * Rt);
  const Mat3 T12 = A12 + skew_mul(u, A22);
  out.topLeftCorner<3, 3>() += A11 + skew_mul(u, A21) - mul_skew(T12, u);
  out.topRightCorner<3, 3>() += T12;
  out.bottomLeftCorner<3, 3>() += A21 - mul_skew(A22, u);
  out.bottomRightCorner<3, 3>() += A22;
}

// The same for a rigid-body spatial inertia A = [[I_o, h~], [-h~, m 1]] (h = m c, I_o about the
// frame origin): X^T A X is the inertia in the parent frame, [[I_o', h'~], [-h'~, m 1]] with
// h' = R h + m u and I_o' = R I_o R^T + (2 (Rh).u + m u.u) 1 - ((Rh) u^T + u (Rh)^T + m u u^T)
// (the parallel-axis shift from the origin to u, without dividing by m). About a quarter of the
// general congruence's arithmetic.
void add_congruence_rigid(const SE3& g, const Mat6& A, Mat6& out) {
  const Mat3& R = g.R;
  const Vec3& u = g.u;
  const double m = A(3, 3);
  const Vec3 hp = R * unskew(A.topRightCorner<3, 3>());
  // (the symmetric block made dense first: a product with a selfadjointView takes Eigen's general
  // GEMM kernel, a hundred times the cost of the fixed-size 3 x 3 product)
  const Mat3 I = A.topLeftCorner<3, 3>().selfadjointView<Eigen::Upper>();
  const Mat3 RI = R * I * R.transpose();
  const Mat3 shift = (2.0 * hp.dot(u) + m * u.squaredNorm()) * Mat3::Identity() -
                     (hp * u.transpose() + u * hp.transpose() + m * u * u.transpose());
  const Mat3 H = skew(hp + m * u);
  out.topLeftCorner<3, 3>() += RI + shift;
  out.topRightCorner<3, 3>() += H;
  out.bottomLeftCorner<3, 3>() -= H;
  out.bottomRightCorner<3, 3>().diagonal().array() += m;
}

// Each column of the 6 x n force subspace F (column-major, 6 doubles per column) to the parent
// frame of g: F <- Ad*_g F (in place). (Raw columns and fixed-size maps: the walk below runs
// these O(sections^2) times per evaluation, and Eigen's dynamic blocks cost more than the
// arithmetic at 3-6 columns.)
inline void coAd_cols(const SE3& g, double* F, int n) {
  for (int c = 0; c < n; ++c) {
    Eigen::Map<Vec6> f(F + 6 * c);
    const Vec3 nn = g.R * f.tail<3>();
    f.head<3>() = g.R * f.head<3>() + g.u.cross(nn);
    f.tail<3>() = nn;
  }
}

// The cross term of an ancestor b (motion subspace S_b: nb columns, dofs from rb) and a force
// subspace F (nf columns, dofs from cf) in b's frame: M(rb.., cf..) += S_b^T F and
// M(cf.., rb..) += F^T S_b.
inline void add_cross(const double* Sb, int nb, const double* F, int nf, MatX& M, int rb, int cf) {
  for (int c = 0; c < nf; ++c) {
    const Eigen::Map<const Vec6> f(F + 6 * c);
    for (int r = 0; r < nb; ++r) {
      const double x = Eigen::Map<const Vec6>(Sb + 6 * r).dot(f);
      M(rb + r, cf + c) += x;
      M(cf + c, rb + r) += x;
    }
  }
}

// The node after i in i's dof group, or -1. A group is a run of consecutive nodes sharing one
// dof block, each the parent of the next (the steps of one rod section; Node::group_first).
inline int group_next(const Model& m, int i) {
  const int j = i + 1;
  if (j >= static_cast<int>(m.nodes.size())) return -1;
  const Node &a = m.nodes[i], &b = m.nodes[j];
  return a.ndof > 0 && b.parent == i && b.dof0 == a.dof0 && b.ndof == a.ndof ? j : -1;
}

// Data::Ic_off_kind: what a group node carries besides the rest of its group
enum : signed char { kOffZero, kOffDiagonal, kOffFull };
}  // namespace

// The composite-rigid-body recursion for any symmetric per-node 6x6 matrix (inertia for crba,
// fluid resistance for fluid_damping): out_M = sum_i J_i^T A_i J_i, with the base coupling.
void composite(const Model& m, Data& d, NodeMatrix which, MatX& out_M, Mat6& out_base, Mat6X& out_F_base) {
  const int nn = static_cast<int>(m.nodes.size());
  const bool inertia = which == NodeMatrix::Inertia;
  Mat6 Node::*field = inertia ? &Node::inertia : &Node::drag;
  // a fixed subtree's composite is constant (Model::update_fixed_composites)
  Mat6 Node::*fixed = inertia ? &Node::inertia_sub : &Node::drag_sub;
  // inertias are rigid-body spatial inertias (Model::finalize checks): the cheaper congruence
  auto congruence = inertia ? add_congruence_rigid : add_congruence_Ad_inv;
  // composite matrix in each node frame: Ic_i = A_i + sum_c Ad*_{g_ic} Ic_c Ad^-1_{g_ic}
  // (the nodes inside a fixed subtree are not visited: their Ic is left as it was). The children
  // outside the node's group are summed first: that partial sum, Ic_off_i, is what node i adds to
  // its group's block of M beyond the rest of the group (below).
  for (int i = nn - 1; i >= 0; --i) {
    const Node& n = m.nodes[i];
    const bool attached = inertia && i == d.attached_node;  // (Data::attached_inertia)
    if (n.fixed_subtree) {
      if (!inside_fixed_subtree(m, n)) d.Ic[i] = n.*fixed;
      if (attached) d.Ic[i] += d.attached_inertia;
      continue;
    }
    const int next = group_next(m, i);
    Mat6 I = n.*field;
    if (attached) I += d.attached_inertia;
    bool own = !attached;  // I is the node's own matrix
    for (int c : children_of(m, i))
      if (c != next) {
        congruence(d.g_rel[c], d.Ic[c], I);
        own = false;
      }
    if (n.ndof > 0) {
      // a rod's mass point (diagonal in its frame) or a massless step: the cheap products below
      // (inertia: the shape update_fixed_composites cached; drag, which callers may edit without
      // refreshing the model, is looked at each time)
      signed char kind = kOffFull;
      if (own && inertia)
        kind = n.inertia_shape == Node::Shape::Zero       ? kOffZero
               : n.inertia_shape == Node::Shape::Diagonal ? kOffDiagonal
                                                          : kOffFull;
      else if (own && is_diagonal(I))
        kind = I.diagonal().isZero(0.0) ? kOffZero : kOffDiagonal;
      d.Ic_off_kind[i] = kind;
      if (kind == kOffFull && next >= 0) d.Ic_off[i] = I;
    }
    if (next >= 0) congruence(d.g_rel[next], d.Ic[next], I);
    d.Ic[i] = I;
  }
  const bool with_base = !inertia || d.crba_base;  // (Data::crba_base)
  out_base.setZero();
  if (with_base)
    for (int c : children_of(m, -1)) congruence(d.g_rel[c], d.Ic[c], out_base);
  out_M.setZero();
  out_F_base.setZero();
  // M = sum_i J_i^T A_i J_i over the nodes, a group of nodes a0..ak at a time (a node that does
  // not continue a run is a group of one). With Jg_a the group Jacobian (Data::Jg) and T_a =
  // Ic_off_a Jg_a (Ic_off_ak = Ic_ak):
  //   the group's own block: sum_a Jg_a^T T_a;
  //   its force subspace in the frame the group hangs from: F = sum_a Ad*_{g_grp_a} T_a;
  //   the cross terms with an ancestor b: Jg_b^T F, F moved to b's group frame, and so on up.
  // (A rod section's mass points are diagonal and its Gauss-rule end frame massless: only the
  // last node of a section takes a full 6 x 6 product.)
  for (int a0 = 0; a0 < nn;) {
    const Node& na = m.nodes[a0];
    if (na.ndof == 0) {
      ++a0;
      continue;
    }
    const int nd = na.ndof, q0 = na.dof0;
    double* F = d.Fs.data();  // 6 x nd, column-major
    double* T = d.Ts.data();
    std::fill(F, F + 6 * nd, 0.0);
    // F is for the cross terms with the ancestor groups and for out_F_base: without either, skipped
    bool need_F = with_base;
    for (int b = na.parent; b >= 0 && !need_F; b = m.nodes[m.nodes[b].group_first].parent) need_F = m.nodes[b].ndof > 0;
    int a = a0;
    for (;; ++a) {
      const signed char kind = d.Ic_off_kind[a];
      const int next = group_next(m, a);
      if (kind != kOffZero) {
        const double* J = d.Jg[a].data();
        if (kind == kOffDiagonal) {
          const Vec6 w = (m.nodes[a].*field).diagonal();
          for (int c = 0; c < nd; ++c)
            Eigen::Map<Vec6>(T + 6 * c) = w.cwiseProduct(Eigen::Map<const Vec6>(J + 6 * c));
        } else {
          const Mat6& A = next >= 0 ? d.Ic_off[a] : d.Ic[a];
          for (int c = 0; c < nd; ++c) Eigen::Map<Vec6>(T + 6 * c).noalias() = A * Eigen::Map<const Vec6>(J + 6 * c);
        }
        for (int c = 0; c < nd; ++c) {  // (a symmetric block: its upper triangle, mirrored)
          const Eigen::Map<const Vec6> t(T + 6 * c);
          for (int r = 0; r < c; ++r) {
            const double x = Eigen::Map<const Vec6>(J + 6 * r).dot(t);
            out_M(q0 + r, q0 + c) += x;
            out_M(q0 + c, q0 + r) += x;
          }
          out_M(q0 + c, q0 + c) += Eigen::Map<const Vec6>(J + 6 * c).dot(t);
        }
        if (need_F) {
          coAd_cols(d.g_grp[a], T, nd);
          for (int k = 0; k < 6 * nd; ++k) F[k] += T[k];
        }
      }
      if (next < 0) break;
    }
    if (!need_F) {
      a0 = a + 1;
      continue;
    }
    // the walk above the group, one ancestor group at a time: for an ancestor b, the cross terms
    // of b's group up to b are Jg_b^T F (F in b's frame), and F moves on by g_grp_b to the frame
    // that group hangs from
    for (int b = na.parent; b >= 0;) {
      const Node& nb = m.nodes[b];
      if (nb.ndof > 0) add_cross(d.Jg[b].data(), nb.ndof, F, nd, out_M, nb.dof0, q0);
      coAd_cols(d.g_grp[b], F, nd);
      b = m.nodes[nb.group_first].parent;
    }
    if (with_base) out_F_base.middleCols(q0, nd) += d.Fs.leftCols(nd);
    a0 = a + 1;
  }
}

void crba(const Model& m, Data& d) { composite(m, d, NodeMatrix::Inertia, d.M, d.Ic_base, d.F_base); }

void rnea(const Model& m, Data& d, const Eigen::Ref<const VecX>& qacc, bool gravity, bool external,
          Eigen::Ref<VecX> tau, bool every_node) {
  const int nn = static_cast<int>(m.nodes.size());
  // the base accelerates by base_accel; gravity enters as an upward base acceleration
  Vec6 a0 = d.base_accel;
  if (gravity) a0.tail<3>() -= d.base_pose.R.transpose() * m.gravity;
  const bool with_qacc = !qacc.isZero(0.0);  // (the bias forces: qacc = 0)
  for (int i = 0; i < nn; ++i) {
    const Node& n = m.nodes[i];
    Vec6 f = Vec6::Zero();
    const bool lumped = n.fixed_subtree && !every_node;  // a fixed subtree moving as one body
    if (lumped && inside_fixed_subtree(m, n)) {
      // inside a fixed subtree: its root carries the subtree's inertia; only loads remain here
    } else {
      Vec6 a = Ad_inv_apply(d.g_rel[i], n.parent < 0 ? a0 : d.acc[n.parent]) + d.cbias[i];
      if (n.ndof > 0 && with_qacc) a += mul_cols(d.S[i], qacc.data() + n.dof0);
      d.acc[i] = a;
      // Newton-Euler in the body frame: f = M acc + ad*_eta M eta - f_ext (for the root of a fixed
      // subtree, with the subtree's composite inertia: its parts move rigidly with it)
      const Mat6& I = lumped ? n.inertia_sub : n.inertia;
      // (a massless node, e.g. a Gauss-rule section's end frame, carries no inertial force: a
      // spatial inertia is positive semi-definite, so a zero diagonal means a zero matrix; a rod's
      // mass point has a diagonal inertia: bit for bit the products below)
      if (i != d.attached_node && !lumped && n.inertia_shape == Node::Shape::Diagonal) {
        const Vec6 w = I.diagonal();
        f = w.cwiseProduct(a) + coad_apply(d.eta[i], Vec6(w.cwiseProduct(d.eta[i])));
      } else if (i == d.attached_node || !I.diagonal().isZero(0.0)) {
        Vec6 h = I * d.eta[i];
        f = I * a;
        if (i == d.attached_node) {  // (Data::attached_inertia)
          h.noalias() += d.attached_inertia * d.eta[i];
          f.noalias() += d.attached_inertia * a;
        }
        f += coad_apply(d.eta[i], h);
      }
    }
    if (external && !(d.f_ext_body[i].isZero(0.0) && d.f_ext_world[i].isZero(0.0))) {
      const Mat3 Rt = d.g[i].R.transpose();
      f -= d.f_ext_body[i];
      f.head<3>() -= Rt * d.f_ext_world[i].head<3>();
      f.tail<3>() -= Rt * d.f_ext_world[i].tail<3>();
    }
    d.F[i] = f;
  }
  tau.setZero();
  d.f_base.setZero();
  for (int i = nn - 1; i >= 0; --i) {
    const Node& n = m.nodes[i];
    for (int k = 0; k < n.ndof; ++k) tau(n.dof0 + k) += d.S[i].col(k).dot(d.F[i]);
    if (n.fixed_subtree && !every_node && d.F[i].isZero(0.0)) continue;  // nothing to transmit (no load inside)
    (n.parent >= 0 ? d.F[n.parent] : d.f_base) += coAd_apply(d.g_rel[i], d.F[i]);
  }
}

void passive(const Model& m, Data& d) {
  d.tmp = d.q - m.q_ref;
  d.qfrc_passive.noalias() = -m.K * d.tmp;
  d.qfrc_passive.noalias() -= m.D * d.v;
}

namespace {
// Generalised force of cable c per unit tension, -dl/dq, accumulated into out with factor s;
// returns the cable length. The cable's local tangent in the cross-section frame is
// p + k x d + d' (the material derivative of the point at offset d): t = that / |that|.
// dl = int t . (dp + dk x d) dX = int [d x t; t]^T Phi dq dX.
double cable_integral(const Model& m, const Data& d, int c, double s, Eigen::Ref<VecX>* out) {
  const Cable& cab = m.cables[c];
  const Vec3 dd = (cab.d_end - cab.d_begin) / (cab.X_end - cab.X_begin);  // d'(X)
  double len = 0.0;
  double P[32];
  for (const Cable::Point& pt : cab.points) {
    const Section& sec = m.sections[pt.section];
    const int nb = sec.order + 1;
    legendre01(sec.order, (pt.X - sec.X0) / sec.length, P);
    const Vec6 xi = sec.basis_apply(P, d.q.data() + sec.dof0) + sec.rest_strain;  // strain at X
    const Vec3 dX = cab.d_begin + (pt.X - cab.X_begin) * dd;
    const Vec3 tv = xi.tail<3>() + xi.head<3>().cross(dX) + dd;
    const double tn = tv.norm();
    len += pt.w * tn;
    if (out && tn > 0) {
      const Vec3 t = tv / tn;
      Vec6 Fa;  // DESIGN.md section 5: F_a = [d~ t; t] per unit tension
      Fa.head<3>() = dX.cross(t);
      Fa.tail<3>() = t;
      for (int col = 0; col < sec.B.cols(); ++col) {
        const double bf = sec.B.col(col).dot(Fa);
        for (int k = 0; k < nb; ++k) (*out)(sec.dof0 + col * nb + k) += s * pt.w * bf * P[k];
      }
    }
  }
  return len;
}
}  // namespace

void add_distributed_force(const Model& m, Data& d, int rod, const Vec3& f) {
  const Rod& r = m.rods[rod];
  for (int i = r.first_node; i <= r.tip_node; ++i) d.f_ext_world[i].tail<3>() += m.nodes[i].dX * f;
}

void add_rod_point_wrench(const Model& m, const Data& d, int rod, double X, const Vec3& moment,
                          const Vec3& force, VecX& tau) {
  MatX J;
  rod_jacobian(m, d, rod, X, J);
  const Mat3 Rt = rod_pose(m, d, rod, X).R.transpose();
  Vec6 F;
  F.head<3>() = Rt * moment;
  F.tail<3>() = Rt * force;
  tau.noalias() += J.transpose() * F;
}

double cable_length(const Model& m, const Data& d, int c, VecX* grad) {
  if (!grad) return cable_integral(m, d, c, 0.0, nullptr);
  grad->setZero(m.nv);
  Eigen::Ref<VecX> g(*grad);
  return cable_integral(m, d, c, 1.0, &g);
}

void actuation(const Model& m, Data& d) {
  d.qfrc_actuator.setZero();
  Eigen::Ref<VecX> out(d.qfrc_actuator);
  for (int k = 0; k < m.nu(); ++k) {
    const Actuator& act = m.actuators[k];
    if (act.kind == Actuator::DofForce) {
      d.qfrc_actuator(act.index) += d.ctrl(k);
    } else if (d.ctrl(k) != 0.0) {
      cable_integral(m, d, act.index, -d.ctrl(k), &out);  // tau = -T dl/dq
    }
  }
}

void smooth_forces(const Model& m, Data& d) {
  fwd_position(m, d);
  fwd_velocity(m, d);
  crba(m, d);
  d.rhs.setZero();
  rnea(m, d, d.rhs, true, true, d.qfrc_bias);
  passive(m, d);
  actuation(m, d);
}

void forward(const Model& m, Data& d) {
  smooth_forces(m, d);
  d.rhs = d.qfrc_passive + d.qfrc_actuator - d.qfrc_bias;
  d.ldlt.compute(d.M);
  d.qacc = d.ldlt.solve(d.rhs);
}

Energy energy(const Model& m, const Data& d) {
  Energy e;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    const Mat6& I = m.nodes[i].inertia;
    e.kinetic += 0.5 * d.eta[i].dot(I * d.eta[i]);
    const double mass = I(3, 3);
    if (mass > 0) {
      const Vec3 c = unskew(I.topRightCorner<3, 3>()) / mass;  // I_tr = m c~
      e.gravity -= mass * m.gravity.dot(d.g[i].act(c));
    }
  }
  // coefficient-wise product: no temporaries (the scene's energy-conserving step calls this)
  e.elastic = 0.5 * (d.q - m.q_ref).dot(m.K.lazyProduct(d.q - m.q_ref));
  return e;
}

Vec6 node_momentum(const Model& m, const Data& d, int k) { return coAd_apply(d.g[k], m.nodes[k].inertia * d.eta[k]); }

double node_mass(const Model& m, const Data& d, int k, Vec3* com) {
  const Mat6& I = m.nodes[k].inertia;
  const double mass = I(3, 3);
  if (com && mass > 0) *com = d.g[k].act(unskew(I.topRightCorner<3, 3>()) / mass);
  return mass;
}

Vec6 momentum(const Model& m, const Data& d) {
  Vec6 h = Vec6::Zero();
  for (int i = 0; i < static_cast<int>(m.nodes.size()); ++i) h += node_momentum(m, d, i);
  return h;
}

Vec3 center_of_mass(const Model& m, const Data& d, double* total) {
  double mt = 0.0;
  Vec3 c = Vec3::Zero();
  for (int i = 0; i < static_cast<int>(m.nodes.size()); ++i) {
    Vec3 ci;
    const double mass = node_mass(m, d, i, &ci);
    if (mass <= 0) continue;
    mt += mass;
    c += mass * ci;
  }
  if (total) *total = mt;
  return mt > 0 ? Vec3(c / mt) : c;
}

}  // namespace cosserat
