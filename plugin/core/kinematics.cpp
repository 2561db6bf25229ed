// Forward kinematics of the node tree (model.hpp). Velocity of a step (DESIGN.md section 4):
//   eta_i = Ad^-1_{g_rel} eta_parent + psi_i,  psi_i = dexp(-Omega) Omega_dot = S_i v_i,
// and its time derivative at qacc = 0:
//   cbias_i = ad_{eta_i} psi_i + dexp(-Omega) Omega_ddot|_{qacc=0} + ddexp(-Omega, -Omega_dot) Omega_dot.
#include "kinematics.hpp"

#include <algorithm>
#include <limits>

namespace cosserat {

namespace {

// dS/dt v of a Magnus step (S = dexp(-Om) G): ddexp(-Om, -Om_dot) Om_dot, and for a step with the
// commutator (c = kZanna h^2, c = 0 without) dexp(-Om) 2c ad_{xa_dot} xb_dot, xa_dot and xb_dot
// the strain rates at its Gauss points (vectors: the matrix dS/dt is not needed for this).
// Dm: dexp(-Om) where the caller has it (fwd_position keeps it for the steps with the
// commutator: Data::Dm), else null.
Vec6 step_Sdot_v(const Vec6& Om, const Vec6& Om_dot, double c, const Vec6& xa_dot, const Vec6& xb_dot,
                 const Mat6* Dm = nullptr) {
  Vec6 sv = ddexp_apply_self(-Om, Om_dot);
  if (c != 0.0) {
    const Vec6 y = 2.0 * c * ad_apply(xa_dot, xb_dot);
    if (Dm) sv.noalias() += *Dm * y;
    else sv += dexp_apply(-Om, y);
  }
  return sv;
}

constexpr double kZanna = 0.14433756729740643;  // sqrt(3) / 12
}

Vec6 step_twist(const Node& n, const Eigen::Ref<const VecX>& qi, Mat6X* G) {
  if (n.selects) {  // (PCS, the basis selecting components: bit for bit the general case below)
    Vec6 xi = n.xibar_a;
    for (int k = 0; k < n.ndof; ++k) xi(n.select_row[k]) += qi(k);
    if (G) {
      G->setZero();
      for (int k = 0; k < n.ndof; ++k) (*G)(n.select_row[k], k) = n.h;
    }
    return n.h * xi;
  }
  Vec6 xa = n.xibar_a, xb = n.xibar_b;
  const double c = kZanna * n.h * n.h;
  if (n.sparse_basis) {  // (GVS with a selecting basis: the products below without their zeros)
    Vec6 xm = n.xibar_a;  // the mean strain over the step
    for (int k = 0; k < n.ndof; ++k) {
      const int r = n.basis_row[k];
      xa(r) += n.basis_a(k) * qi(k), xb(r) += n.basis_b(k) * qi(k), xm(r) += n.basis_m(k) * qi(k);
    }
    if (G) {
      // G = h Phi_m + c (ad_{xa} Phi_b - ad_{xb} Phi_a): column k is column r of ad_y,
      // y = c (b_k xa - a_k xb) (ad is linear in its argument), r the dof's strain component
      for (int k = 0; k < n.ndof; ++k) {
        const int r = n.basis_row[k];
        G->col(k) = ad_column((c * n.basis_b(k)) * xa - (c * n.basis_a(k)) * xb, r);
        (*G)(r, k) += n.h * n.basis_m(k);
      }
    }
    return n.h * xm + c * ad_apply(xa, xb);
  }
  Vec6 Om;
  if (n.commutator) {  // GVS: the exact integral of the strain (model.hpp)
    Om = n.xibar_a;
    if (n.ndof > 0) {
      xa.noalias() += n.Phi_a * qi;
      xb.noalias() += n.Phi_b * qi;
      Om.noalias() += n.Phi_m * qi;
    }
    Om = n.h * Om + c * ad_apply(xa, xb);
  } else {
    if (n.ndof > 0) {
      xa.noalias() += n.Phi_a * qi;
      xb.noalias() += n.Phi_b * qi;
    }
    Om = 0.5 * n.h * (xa + xb);
  }
  if (G && n.ndof > 0) {
    if (n.commutator) G->noalias() = n.h * n.Phi_m;
    else G->noalias() = (0.5 * n.h) * (n.Phi_a + n.Phi_b);
    if (n.commutator) {
      // d/dq ad_{xa} xb = ad_{xa} Phi_b - ad_{xb} Phi_a
      G->noalias() += c * (ad(xa) * n.Phi_b);
      G->noalias() -= c * (ad(xb) * n.Phi_a);
    }
  }
  return Om;
}

void fwd_position(const Model& m, Data& d) {
  const int nn = static_cast<int>(m.nodes.size());
  for (int i = 0; i < nn; ++i) {
    const Node& n = m.nodes[i];
    if (n.ndof == 0) {  // constant (Model::finalize)
      d.Omega[i] = n.fixed_Omega;
      d.g_rel[i] = n.fixed_rel;
    } else if (n.same_step >= 0) {  // the same step as an earlier node of its PCS section
      d.Omega[i] = d.Omega[n.same_step];
      d.g_rel[i] = d.g_rel[n.same_step];
      d.G[i] = d.G[n.same_step];
      d.S[i] = d.S[n.same_step];
    } else {
      d.Omega[i] = step_twist(n, d.q.segment(n.dof0, n.ndof), &d.G[i]);
      if (n.keep_mid) {  // (a PCS step: the pose at its middle is offset exp(Omega / 2))
        const SE3 E = exp_se3(Vec6(0.5 * d.Omega[i]));
        const SE3 to_mid = n.offset * E;
        d.g_mid[i] = (n.parent < 0 ? d.base_pose : d.g[n.parent]) * to_mid;
        d.g_rel[i] = to_mid * E;
      } else {
        d.g_rel[i] = n.offset * exp_se3(d.Omega[i]);
      }
      if (n.selects) {  // (bit for bit the product below: one nonzero h per column of G)
        const Mat6 D = dexp(-d.Omega[i]);
        for (int k = 0; k < n.ndof; ++k) d.S[i].col(k) = n.h * D.col(n.select_row[k]);
      } else if (n.commutator) {
        d.Dm[i] = dexp(-d.Omega[i]);
        d.S[i].noalias() = d.Dm[i] * d.G[i];
      } else {
        d.S[i].noalias() = dexp(-d.Omega[i]) * d.G[i];
      }
    }
    d.g[i] = (n.parent < 0 ? d.base_pose : d.g[n.parent]) * d.g_rel[i];
    if (n.group_first != i) {  // continues its parent's group
      // Jg_i = Ad^-1_{g_rel} Jg_p + S_i, as two 3 x 3 block products over the columns:
      // Ad^-1 (w, v) = (R^T w, R^T (v - u x w))
      const Mat6X& Jp = d.Jg[n.parent];
      Mat6X& J = d.Jg[i];
      const Mat3 Rt = d.g_rel[i].R.transpose();
      J.topRows<3>().noalias() = Rt * Jp.topRows<3>();
      J.bottomRows<3>().noalias() = Rt * Jp.bottomRows<3>();
      J.bottomRows<3>().noalias() -= (Rt * skew(d.g_rel[i].u)) * Jp.topRows<3>();
      J += d.S[i];
      d.g_grp[i] = d.g_grp[n.parent] * d.g_rel[i];
    } else {
      d.Jg[i] = d.S[i];
      d.g_grp[i] = d.g_rel[i];
    }
  }
}

void group_jacobian_dot(const Model& m, Data& d) {
  const int nn = static_cast<int>(m.nodes.size());
  for (int i = 0; i < nn; ++i) {
    const Node& n = m.nodes[i];
    if (n.ndof == 0) continue;
    if (n.group_first == i) {
      d.Jgdot[i] = d.Sdot[i];
      continue;
    }
    // d/dt (Ad^-1 Jg_p) = Ad^-1 Jgdot_p - ad_psi Ad^-1 Jg_p, psi = S v the step's own twist, and
    // Ad^-1 Jg_p = Jg_i - S_i (fwd_position)
    const Vec6 psi = mul_cols(d.S[i], d.v.data() + n.dof0);
    const Mat6X& Jdp = d.Jgdot[n.parent];
    for (int k = 0; k < n.ndof; ++k)
      d.Jgdot[i].col(k) = Ad_inv_apply(d.g_rel[i], Jdp.col(k)) - ad_apply(psi, d.Jg[i].col(k) - d.S[i].col(k)) +
                          d.Sdot[i].col(k);
  }
}

void fwd_velocity(const Model& m, Data& d, bool with_Sdot) {
  const int nn = static_cast<int>(m.nodes.size());
  for (int i = 0; i < nn; ++i) {
    const Node& n = m.nodes[i];
    const Vec6& eta_p = n.parent < 0 ? d.base_twist : d.eta[n.parent];
    Vec6 eta = Ad_inv_apply(d.g_rel[i], eta_p);
    Vec6 cb = Vec6::Zero();
    if (n.ndof > 0) {
      const auto vi = d.v.segment(n.dof0, n.ndof);
      const Vec6 psi = mul_cols(d.S[i], vi.data());
      eta += psi;
      // dS/dt = ddexp(-Omega, -Omega_dot) G + dexp(-Omega) dG/dt, and dG/dt is the commutator's
      // c (ad_{xa_dot} Phi_b - ad_{xb_dot} Phi_a): so dS/dt v = ddexp Omega_dot + dexp 2c ad_{xa_dot} xb_dot
      // (computed as vectors; the matrix dS/dt only when asked for)
      if (n.same_step >= 0) {  // PCS: the same step, the same dofs, the same rates
        d.Omega_dot[i] = d.Omega_dot[n.same_step];
        d.Sdot_v[i] = d.Sdot_v[n.same_step];
        if (with_Sdot) d.Sdot[i] = d.Sdot[n.same_step];
      } else {
        d.Omega_dot[i] = mul_cols(d.G[i], vi.data());
        const Vec6 mOm = -d.Omega[i];
        Vec6 xad = Vec6::Zero(), xbd = Vec6::Zero();
        if (n.sparse_basis) {
          for (int k = 0; k < n.ndof; ++k)
            xad(n.basis_row[k]) += n.basis_a(k) * vi(k), xbd(n.basis_row[k]) += n.basis_b(k) * vi(k);
        } else if (n.commutator) {
          xad.noalias() = n.Phi_a * vi;
          xbd.noalias() = n.Phi_b * vi;
        }
        const double c = n.commutator ? kZanna * n.h * n.h : 0.0;
        d.Sdot_v[i] = step_Sdot_v(d.Omega[i], d.Omega_dot[i], c, xad, xbd, &d.Dm[i]);
        if (with_Sdot) {
          d.Sdot[i].noalias() = ddexp(mOm, -d.Omega_dot[i]) * d.G[i];
          if (n.commutator) {
            const Mat6& Dm = d.Dm[i];
            for (int k = 0; k < n.ndof; ++k)
              d.Sdot[i].col(k).noalias() += Dm * (c * (ad_apply(xad, n.Phi_b.col(k)) - ad_apply(xbd, n.Phi_a.col(k))));
          }
        }
      }
      cb = d.Sdot_v[i] + ad_apply(eta, psi);
    } else {
      d.Omega_dot[i].setZero();
    }
    d.eta[i] = eta;
    d.cbias[i] = cb;
  }
}

void node_jacobian(const Model& m, const Data& d, int node, MatX& J) {
  J.setZero(6, m.nv);
  // J_i = sum over ancestors a (incl. i) of Ad^-1_{g_{a,i}} S_a, accumulated walking up.
  Mat6 X = Mat6::Identity();  // Ad^-1 of the pose of `node` in the frame of the current ancestor
  for (int a = node; a >= 0; a = m.nodes[a].parent) {
    const Node& n = m.nodes[a];
    if (n.ndof > 0) J.middleCols(n.dof0, n.ndof).noalias() += X * d.S[a];
    X = X * Ad_inv(d.g_rel[a]);
  }
}

Vec6 node_jdot_v(const Model& m, const Data& d, int node) {
  // acc_i = Ad^-1 acc_parent + cbias_i, from a fixed base: sum cbias transported down.
  Vec6 a = Vec6::Zero();
  std::vector<int> path;
  for (int k = node; k >= 0; k = m.nodes[k].parent) path.push_back(k);
  for (auto it = path.rbegin(); it != path.rend(); ++it) a = Ad_inv_apply(d.g_rel[*it], a) + d.cbias[*it];
  return a;
}

namespace {
constexpr double kGauss = 0.28867513459481287;  // sqrt(3) / 6: Gauss points at 1/2 -+ this

// The step of a rod section from abscissa Xp over a length h, described without a Node (no heap
// memory): the Legendre weights of its two Gauss points. The strain basis is
// Phi(X) = B (x) [P_0 .. P_order]((X - X0)/length), dof index c*(order+1)+k (model.hpp).
struct StepPoints {
  double h = 0.0;
  bool commutator = false;
  double Pa[32], Pb[32], Pm[32];  // Pm: the mean over the step (the twist's linear term, model.hpp)
};

void step_points(const Section& sec, double Xp, double h, bool commutator, StepPoints& sp) {
  sp.h = h;
  sp.commutator = commutator;
  legendre01(sec.order, (Xp + h * (0.5 - kGauss) - sec.X0) / sec.length, sp.Pa);
  legendre01(sec.order, (Xp + h * (0.5 + kGauss) - sec.X0) / sec.length, sp.Pb);
  if (commutator) legendre01_mean(sec.order, (Xp - sec.X0) / sec.length, (Xp + h - sec.X0) / sec.length, sp.Pm);
  else std::copy(sp.Pa, sp.Pa + sec.order + 1, sp.Pm);  // (PCS: P_0 = 1 everywhere)
}

// The Magnus twist of the step (model.hpp) and, if G is given, G = dOmega/dq (6 x ndof). xa, xb:
// the strains at the Gauss points (outputs).
Vec6 step_twist_at(const Section& sec, const StepPoints& sp, const double* q, Mat6X* G, Vec6& xa, Vec6& xb) {
  xa = sec.basis_apply(sp.Pa, q) + sec.rest_strain;
  xb = sec.basis_apply(sp.Pb, q) + sec.rest_strain;
  const double c = kZanna * sp.h * sp.h;
  Vec6 Om = sp.commutator ? Vec6(sp.h * (sec.basis_apply(sp.Pm, q) + sec.rest_strain) + c * ad_apply(xa, xb))
                          : Vec6(0.5 * sp.h * (xa + xb));
  if (G) {  // G's first ndof columns (a larger G keeps its memory: scratch reused across sections)
    const int nb = sec.order + 1;
    if (G->cols() < sec.ndof) G->resize(6, sec.ndof);
    for (int cc = 0; cc < sec.B.cols(); ++cc) {
      const Vec6 Bc = sec.B.col(cc);
      const Vec6 adaB = ad_apply(xa, Bc), adbB = ad_apply(xb, Bc);
      for (int k = 0; k < nb; ++k) {
        // d/dq ad_{xa} xb = ad_{xa} Phi_b - ad_{xb} Phi_a
        auto col = G->col(cc * nb + k);
        col = (sp.commutator ? sp.h * sp.Pm[k] : 0.5 * sp.h * (sp.Pa[k] + sp.Pb[k])) * Bc;
        if (sp.commutator) col += c * (sp.Pb[k] * adaB - sp.Pa[k] * adbB);
      }
    }
  }
  return Om;
}

// The partial step of the node containing X: from the node's parent frame (abscissa Xp) to X.
struct PartialStep {
  int node = -1, parent = -1;
  SE3 offset;
  double Xp = 0.0;
  bool full = false;  // X is the node itself: the step is the node's own (Data holds it)
  bool empty = false;  // X is the parent frame: a step of length 0 (Om = 0; xa, xb, sp unset unless G was asked for)
  bool mid = false;    // X is the node's kept midpoint (Node::keep_mid: Data::g_mid; Om, xa, xb, sp unset unless G was asked for)
  StepPoints sp;
  Vec6 Om, xa, xb;
};

// When X is the node itself (ps.full) its step is in Data already: Om, xa, xb and G are computed
// then only if `when_full`.
// The node of the partial step to X (rod_pose's unless `section` is given) and where X falls in
// it: ps.node, parent, offset, Xp, full, empty, mid; returns X clamped to the rod.
double locate_step(const Model& m, int r, double X, int section, PartialStep& ps) {
  const Rod& rod = m.rods[r];
  X = std::clamp(X, 0.0, rod.length);
  int i = m.rod_node_at(r, X);
  if (section >= 0) {  // the first node of that section at or beyond X
    const Section& sec = m.sections[section];
    i = sec.end_node;
    for (int k = sec.first_node; k <= sec.end_node; ++k)
      if (m.nodes[k].X >= X) {
        i = k;
        break;
      }
  }
  const Node& n = m.nodes[i];
  ps.node = i;
  ps.parent = n.parent;
  ps.offset = n.offset;
  ps.Xp = n.X - n.h;  // abscissa of the parent frame
  ps.full = X == n.X;
  ps.empty = X == ps.Xp;
  ps.mid = n.keep_mid && X == n.X_mid;
  return X;
}

void partial_step(const Model& m, const Data& d, int r, double X, int section, Mat6X* G, PartialStep& ps,
                  bool when_full) {
  X = locate_step(m, r, X, section, ps);
  if (ps.full && !when_full) return;
  if (ps.mid && !G) return;
  const Node& n = m.nodes[ps.node];
  const Section& sec = m.sections[n.section];
  if (ps.empty && !G) {  // X is the parent frame: no motion (a rod's start, a capsule's first end)
    ps.Om.setZero();
    return;
  }
  step_points(sec, ps.Xp, X - ps.Xp, n.commutator, ps.sp);
  ps.Om = step_twist_at(sec, ps.sp, d.q.data() + n.dof0, G, ps.xa, ps.xb);
}
}  // namespace

int kept_pose_node(const Model& m, int r, double X, bool& mid) {
  PartialStep ps;
  locate_step(m, r, X, -1, ps);
  mid = ps.mid && !ps.full;
  return ps.full || ps.mid ? ps.node : -1;
}

SE3 rod_pose(const Model& m, const Data& d, int r, double X) {
  PartialStep ps;
  partial_step(m, d, r, X, -1, nullptr, ps, false);
  if (ps.full) return d.g[ps.node];
  if (ps.mid) return d.g_mid[ps.node];
  const SE3& gp = ps.parent < 0 ? d.base_pose : d.g[ps.parent];
  if (ps.empty) return gp * ps.offset;
  return gp * ps.offset * exp_se3(ps.Om);
}

void rod_jacobian(const Model& m, const Data& d, int r, double X, MatX& J) {
  PartialStep ps;
  Mat6X G;
  partial_step(m, d, r, X, -1, &G, ps, true);
  if (ps.parent >= 0) {
    node_jacobian(m, d, ps.parent, J);
    const Mat6 Ai = Ad_inv(ps.offset * exp_se3(ps.Om));
    J = Ai * J;
  } else {
    J.setZero(6, m.nv);
  }
  const Node& n = m.nodes[ps.node];
  if (n.ndof > 0) J.middleCols(n.dof0, n.ndof) += dexp(-ps.Om) * G.leftCols(n.ndof);
}

namespace {
// Scratch of the point Jacobians below, kept between calls per thread (only their first ndof
// columns are used: they grow when a section with more dofs comes along). Sized for a model's
// largest section when a Data is made (reserve_kinematics_scratch), so that the first contact or
// site read of a step does not allocate, nor register their destructors, in that thread.
struct KinematicsScratch {
  Mat6X S, Sdot, AJ;           // section_jacobian_from
  Mat6X G_jac, G_motion, G_pose;  // partial_step's G of section_jacobian, point_motion_at_rest_acceleration,
                                  // rod_pose_and_jacobian (which may call section_jacobian: distinct)
};
thread_local KinematicsScratch tl_scratch;
}  // namespace

void reserve_kinematics_scratch(int ndof) {
  KinematicsScratch& k = tl_scratch;
  for (Mat6X* x : {&k.S, &k.Sdot, &k.AJ, &k.G_jac, &k.G_motion, &k.G_pose})
    if (x->cols() < ndof) x->resize(6, ndof);
}

namespace {
// section_jacobian from its partial step ps and G = dOmega/dq (partial_step's), with E = exp(ps.Om)
// when the caller has it (nullptr: computed here; unused when ps.full).
int section_jacobian_from(const Model& m, const Data& d, const PartialStep& ps, const Mat6X& G, Mat6X& J,
                          Mat6X* Jdot, SE3* gX, const SE3* E) {
  Mat6X &S = tl_scratch.S, &Sdot = tl_scratch.Sdot, &AJ = tl_scratch.AJ;
  const int si = m.nodes[ps.node].section;
  const Section& sec = m.sections[si];
  const int nd = sec.ndof;
  J.setZero(6, nd);
  if (Jdot) Jdot->setZero(6, nd);
  SE3 g;
  const double* v = d.v.data() + sec.dof0;
  // One Magnus step of the section: J <- Ad^-1 J + S, Jdot <- Ad^-1 Jdot - ad_psi Ad^-1 J + Sdot,
  // with S = dexp(-Om) G and Sdot = ddexp(-Om, -Om_dot) G + dexp(-Om) d/dt(G) (the commutator).
  auto advance = [&](const SE3& grel, const Mat6X& Ss, const Mat6X& Sd) {
    if (nd == 0) {
      g = g * grel;
      return;
    }
    const bool dot = Jdot != nullptr;
    if (dot && AJ.cols() < nd) AJ.resize(6, nd);
    for (int k = 0; k < nd; ++k) {
      const Vec6 a = Ad_inv_apply(grel, J.col(k));
      if (dot) AJ.col(k) = a;
      J.col(k) = a + Ss.col(k);
    }
    g = g * grel;
    if (!dot) return;
    Vec6 psi = Vec6::Zero();
    for (int k = 0; k < nd; ++k) psi += Ss.col(k) * v[k];
    for (int k = 0; k < nd; ++k)
      Jdot->col(k) = Ad_inv_apply(grel, Jdot->col(k)) - ad_apply(psi, AJ.col(k)) + Sd.col(k);
  };
  // whole steps: the node's own pose, S and dS/dt from fwd_position and fwd_velocity; without
  // Jdot the group Jacobian of the last whole step holds them all already (a section's nodes are
  // one group, Data::Jg)
  const int last = ps.full ? ps.node + 1 : ps.node;
  if (!Jdot && nd > 0 && last > sec.first_node) {
    J = d.Jg[last - 1];
    g = d.g_grp[last - 1];
  } else {
    for (int i = sec.first_node; i < last; ++i) advance(d.g_rel[i], d.S[i], d.Sdot[i]);
  }
  if (!ps.full) {  // the last, partial step
    const Mat6 Dm = dexp(-ps.Om);
    if (S.cols() < nd) S.resize(6, nd);
    S.leftCols(nd).noalias() = Dm * G.leftCols(nd);
    if (Jdot && nd > 0) {
      Vec6 Omd = Vec6::Zero();
      for (int k = 0; k < nd; ++k) Omd += G.col(k) * v[k];
      if (Sdot.cols() < nd) Sdot.resize(6, nd);
      Sdot.leftCols(nd).noalias() = ddexp(-ps.Om, -Omd) * G.leftCols(nd);
      if (ps.sp.commutator) {  // dG/dt: c (ad_{xa_dot} Phi_b - ad_{xb_dot} Phi_a), column by column
        const StepPoints& sp = ps.sp;
        const double c = kZanna * sp.h * sp.h;
        const Vec6 xad = sec.basis_apply(sp.Pa, v), xbd = sec.basis_apply(sp.Pb, v);
        const int nb = sec.order + 1;
        for (int cc = 0; cc < sec.B.cols(); ++cc) {
          const Vec6 Bc = sec.B.col(cc);
          const Vec6 adaB = ad_apply(xad, Bc), adbB = ad_apply(xbd, Bc);
          for (int k = 0; k < nb; ++k) Sdot.col(cc * nb + k).noalias() += Dm * (c * (sp.Pb[k] * adaB - sp.Pa[k] * adbB));
        }
      }
    }
    advance(ps.offset * (E ? *E : exp_se3(ps.Om)), S, Sdot);
  }
  if (gX) *gX = g;
  return si;
}
}  // namespace

int section_jacobian(const Model& m, const Data& d, int r, double X, Mat6X& J, Mat6X* Jdot, SE3* gX,
                     int section) {
  Mat6X& G = tl_scratch.G_jac;
  PartialStep ps;
  partial_step(m, d, r, X, section, &G, ps, false);
  return section_jacobian_from(m, d, ps, G, J, Jdot, gX, nullptr);
}

// point_motion_at_rest_acceleration, and with `acc` false its pose and twist only (acc left zero:
// Data::acc is not read, so fwd_velocity alone suffices).
static PointMotion point_motion(const Model& m, const Data& d, int r, double X, int section, bool acc) {
  Mat6X& G = tl_scratch.G_motion;
  PartialStep ps;
  partial_step(m, d, r, X, section, &G, ps, false);
  if (ps.full) return {d.g[ps.node], d.eta[ps.node], acc ? d.acc[ps.node] : Vec6::Zero()};
  const Section& sec = m.sections[m.nodes[ps.node].section];
  const SE3 grel = ps.offset * exp_se3(ps.Om);
  PointMotion pm;
  pm.pose = ps.mid ? d.g_mid[ps.node] : (ps.parent < 0 ? d.base_pose : d.g[ps.parent]) * grel;  // (rod_pose's)
  pm.eta = Ad_inv_apply(grel, ps.parent < 0 ? d.base_twist : d.eta[ps.parent]);
  pm.acc = acc ? Ad_inv_apply(grel, ps.parent < 0 ? d.base_accel : d.acc[ps.parent]) : Vec6::Zero();
  if (sec.ndof > 0) {  // the partial step's own motion, as fwd_velocity's for a whole step
    const double* v = d.v.data() + sec.dof0;
    Vec6 Omd = Vec6::Zero();
    for (int k = 0; k < sec.ndof; ++k) Omd += G.col(k) * v[k];
    const Vec6 psi = dexp_apply(-ps.Om, Omd);
    pm.eta += psi;
    if (acc) {
      const bool comm = ps.sp.commutator;
      const Vec6 sv = step_Sdot_v(ps.Om, Omd, comm ? kZanna * ps.sp.h * ps.sp.h : 0.0,
                                  comm ? sec.basis_apply(ps.sp.Pa, v) : Vec6::Zero(),
                                  comm ? sec.basis_apply(ps.sp.Pb, v) : Vec6::Zero());
      pm.acc += sv + ad_apply(pm.eta, psi);
    }
  }
  return pm;
}

PointMotion point_motion_at_rest_acceleration(const Model& m, const Data& d, int r, double X, int section) {
  return point_motion(m, d, r, X, section, true);
}

Vec6 rod_twist(const Model& m, const Data& d, int r, double X, SE3* pose) {
  const PointMotion pm = point_motion(m, d, r, X, -1, false);
  if (pose) *pose = pm.pose;
  return pm.eta;
}

SE3 rod_pose_and_jacobian(const Model& m, const Data& d, int r, double X, int section, Mat6X& J, SE3* g_start_X) {
  Mat6X& G = tl_scratch.G_pose;
  PartialStep ps;
  partial_step(m, d, r, X, -1, &G, ps, false);  // rod_pose's node (the section's, unless X is a boundary)
  if (section >= 0 && m.nodes[ps.node].section != section) {
    section_jacobian(m, d, r, X, J, nullptr, g_start_X, section);
    return rod_pose(m, d, r, X);
  }
  if (ps.full) {
    section_jacobian_from(m, d, ps, G, J, nullptr, g_start_X, nullptr);
    return d.g[ps.node];
  }
  const SE3 E = exp_se3(ps.Om);
  section_jacobian_from(m, d, ps, G, J, nullptr, g_start_X, &E);
  if (ps.mid) return d.g_mid[ps.node];  // (rod_pose's, to the bit)
  const SE3& gp = ps.parent < 0 ? d.base_pose : d.g[ps.parent];
  return gp * ps.offset * E;
}

Vec6 rod_strain(const Model& m, const Data& d, int r, double X) {
  const Rod& rod = m.rods[r];
  X = std::clamp(X, 0.0, rod.length);
  const Node& n = m.nodes[m.rod_node_at(r, X)];
  const Section& sec = m.sections[n.section];
  double P[32];
  legendre01(sec.order, (X - sec.X0) / sec.length, P);
  return sec.basis_apply(P, d.q.data() + sec.dof0) + sec.rest_strain;
}

double min_axial_stretch(const Model& m, const Data& d, int* section) {
  double smin = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    const Node& n = m.nodes[i];
    if (n.ndof == 0 || n.section < 0 || n.h <= 0 || !m.sections[n.section].axial_free()) continue;
    const double s = d.Omega[i](3) / n.h;
    if (s < smin) {
      smin = s;
      if (section) *section = n.section;
    }
  }
  return smin;
}

}  // namespace cosserat
