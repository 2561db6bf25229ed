// Forward kinematics of the node tree (model.hpp). Velocity of a step (DESIGN.md section 4):
//   eta_i = Ad^-1_{g_rel} eta_parent + psi_i,  psi_i = dexp(-Omega) Omega_dot = S_i v_i,
// and its time derivative at qacc = 0:
//   cbias_i = ad_{eta_i} psi_i + dexp(-Omega) Omega_ddot|_{qacc=0} + ddexp(-Omega, -Omega_dot) Omega_dot.
#include "kinematics.hpp"

namespace cosserat {

namespace {
constexpr double kZanna = 0.14433756729740643;  // sqrt(3) / 12
}

Vec6 step_twist(const Node& n, const Eigen::Ref<const VecX>& qi, Mat6X* G) {
  Vec6 xa = n.xibar_a, xb = n.xibar_b;
  if (n.ndof > 0) {
    xa.noalias() += n.Phi_a * qi;
    xb.noalias() += n.Phi_b * qi;
  }
  Vec6 Om = 0.5 * n.h * (xa + xb);
  const double c = kZanna * n.h * n.h;
  if (n.commutator) Om += c * ad_apply(xa, xb);
  if (G && n.ndof > 0) {
    G->noalias() = (0.5 * n.h) * (n.Phi_a + n.Phi_b);
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
    d.Omega[i] = step_twist(n, d.q.segment(n.dof0, n.ndof), &d.G[i]);
    d.g_rel[i] = n.offset * exp_se3(d.Omega[i]);
    d.g[i] = (n.parent < 0 ? d.base_pose : d.g[n.parent]) * d.g_rel[i];
    if (n.ndof > 0) d.S[i].noalias() = dexp(-d.Omega[i]) * d.G[i];
  }
}

void fwd_velocity(const Model& m, Data& d) {
  const int nn = static_cast<int>(m.nodes.size());
  for (int i = 0; i < nn; ++i) {
    const Node& n = m.nodes[i];
    const Vec6& eta_p = n.parent < 0 ? d.base_twist : d.eta[n.parent];
    Vec6 eta = Ad_inv_apply(d.g_rel[i], eta_p);
    Vec6 cb = Vec6::Zero();
    if (n.ndof > 0) {
      const auto vi = d.v.segment(n.dof0, n.ndof);
      const Vec6 Omd = d.G[i] * vi;
      const Vec6 psi = d.S[i] * vi;
      d.Omega_dot[i] = Omd;
      eta += psi;
      // second time derivative of Omega at qacc = 0: the commutator is bilinear in q
      cb = ddexp(-d.Omega[i], -Omd) * Omd;
      if (n.commutator) {
        const Vec6 xad = n.Phi_a * vi, xbd = n.Phi_b * vi;
        cb += dexp(-d.Omega[i]) * (2.0 * kZanna * n.h * n.h * ad_apply(xad, xbd));
      }
      cb += ad_apply(eta, psi);
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
// The partial step of the node containing X: node index and the Magnus twist from its parent
// frame to X (and its dOmega/dq block).
struct PartialStep {
  int node, parent;
  SE3 offset;
  Vec6 Om;
  Mat6X G;
};

PartialStep partial_step(const Model& m, const Data& d, int r, double X, int section = -1) {
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
  const Section& sec = m.sections[n.section];
  const double Xp = n.X - n.h;  // abscissa of the parent frame
  Node part = n;
  part.h = X - Xp;
  if (n.commutator) {
    sec.basis(Xp + part.h * (0.5 - 0.28867513459481287), part.Phi_a);
    sec.basis(Xp + part.h * (0.5 + 0.28867513459481287), part.Phi_b);
  }
  PartialStep ps{i, n.parent, n.offset, Vec6::Zero(), Mat6X(6, n.ndof)};
  ps.Om = step_twist(part, d.q.segment(n.dof0, n.ndof), &ps.G);
  return ps;
}
}  // namespace

SE3 rod_pose(const Model& m, const Data& d, int r, double X) {
  const PartialStep ps = partial_step(m, d, r, X);
  const SE3& gp = ps.parent < 0 ? d.base_pose : d.g[ps.parent];
  return gp * ps.offset * exp_se3(ps.Om);
}

void rod_jacobian(const Model& m, const Data& d, int r, double X, MatX& J) {
  const PartialStep ps = partial_step(m, d, r, X);
  if (ps.parent >= 0) {
    node_jacobian(m, d, ps.parent, J);
    const Mat6 Ai = Ad_inv(ps.offset * exp_se3(ps.Om));
    J = Ai * J;
  } else {
    J.setZero(6, m.nv);
  }
  const Node& n = m.nodes[ps.node];
  if (n.ndof > 0) J.middleCols(n.dof0, n.ndof) += dexp(-ps.Om) * ps.G;
}

int section_jacobian(const Model& m, const Data& d, int r, double X, Mat6X& J, Mat6X* Jdot, SE3* gX,
                     int section) {
  const PartialStep ps = partial_step(m, d, r, X, section);
  const int si = m.nodes[ps.node].section;
  const Section& sec = m.sections[si];
  J.setZero(6, sec.ndof);
  if (Jdot) Jdot->setZero(6, sec.ndof);
  SE3 g;
  Mat6X Sdot(6, sec.ndof), AJ(6, sec.ndof);
  // one Magnus step of the section: J <- Ad^-1 J + S, Jdot <- Ad^-1 Jdot - ad_psi Ad^-1 J + Sdot
  auto advance = [&](const Node& n, const SE3& grel, const Vec6& Om, const Mat6X& G) {
    const Mat6 Ai = Ad_inv(grel);
    const Mat6 Dm = dexp(-Om);
    AJ.noalias() = Ai * J;
    J = AJ;
    J.noalias() += Dm * G;
    g = g * grel;
    if (!Jdot || sec.ndof == 0) return;
    const auto vi = d.v.segment(n.dof0, n.ndof);
    const Vec6 Omd = G * vi;
    const Vec6 psi = Dm * Omd;
    Sdot.noalias() = ddexp(-Om, -Omd) * G;
    if (n.commutator) {
      const double c = kZanna * n.h * n.h;
      const Vec6 xad = n.Phi_a * vi, xbd = n.Phi_b * vi;
      Sdot.noalias() += Dm * (c * (ad(xad) * n.Phi_b - ad(xbd) * n.Phi_a));
    }
    *Jdot = Ai * (*Jdot) - ad(psi) * AJ + Sdot;
  };
  for (int i = sec.first_node; i < ps.node; ++i) advance(m.nodes[i], d.g_rel[i], d.Omega[i], d.G[i]);
  // the last (possibly partial) step; Phi of the partial step for its commutator
  Node part = m.nodes[ps.node];
  if (part.commutator) {
    const double Xp = part.X - part.h, h = std::clamp(X, 0.0, m.rods[r].length) - Xp;
    part.h = h;
    sec.basis(Xp + h * (0.5 - 0.28867513459481287), part.Phi_a);
    sec.basis(Xp + h * (0.5 + 0.28867513459481287), part.Phi_b);
  }
  advance(part, ps.offset * exp_se3(ps.Om), ps.Om, ps.G);
  if (gX) *gX = g;
  return si;
}

Vec6 rod_strain(const Model& m, const Data& d, int r, double X) {
  const Rod& rod = m.rods[r];
  X = std::clamp(X, 0.0, rod.length);
  const Node& n = m.nodes[m.rod_node_at(r, X)];
  const Section& sec = m.sections[n.section];
  Mat6X Phi;
  sec.basis(X, Phi);
  return Phi * d.q.segment(sec.dof0, sec.ndof) + sec.rest_strain;
}

}  // namespace cosserat
