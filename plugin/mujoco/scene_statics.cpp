// Static equilibrium and linearisation of a coupled scene (see scene_statics.hpp). Mirrors the
// core's statics.cpp (Newton, backtracking, load continuation) and linearize.cpp, with the forces
// taken from the staged MuJoCo pipeline of scene.cpp.
#include "scene_statics.hpp"

#include <algorithm>
#include <complex>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "scene_sites.hpp"
#include "statics.hpp"

namespace cosserat::mj {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// Steady state of an actuator's activation under a constant control: filters and muscles settle
// at act = ctrl; integrators keep their activation. MuJoCo 2.2 puts stateful actuators last.
void settle_activations(const mjModel* m, mjData* d) {
  for (int i = m->nu - m->na; i < m->nu; ++i) {
    const int t = m->actuator_dyntype[i];
    if (t == mjDYN_FILTER || t == mjDYN_MUSCLE) d->act[i - (m->nu - m->na)] = d->ctrl[i];
  }
}

// A force scale that does not vanish at equilibrium (gravity's generalised force does, for a
// hanging pendulum): |g| sqrt(total mass * sum_j M_jj), the weight times a lever arm per dof, for
// gravity g. Needs the mass matrix of fwd_position.
double weight_force_scale(const Scene& s, const mjData* d, const double g[3]) {
  double mass = s.m->body_subtreemass[0], diag = 0.0;
  for (const auto& rb : s.rods)
    for (const auto& node : rb.model.nodes) mass += node.inertia(3, 3);
  for (int j = 0; j < s.m->nv; ++j) diag += d->qM[s.m->dof_Madr[j]];
  const bool gravity_on = !(s.m->opt.disableflags & mjDSBL_GRAVITY);
  return gravity_on ? mju_norm3(g) * std::sqrt(mass * diag) : 0.0;
}

// The scene's independent parts, for Newton's residual: per dof, the kinematic tree it belongs to
// (the world's child at its top, MuJoCo's body_rootid), numbered 0, 1, ... in dof order.
std::vector<int> dof_trees(const mjModel* m, int& count) {
  std::vector<int> tree(m->nv), number(m->nbody, -1);
  count = 0;
  for (int i = 0; i < m->nv; ++i) {
    int& t = number[m->body_rootid[m->dof_bodyid[i]]];
    if (t < 0) t = count++;
    tree[i] = t;
  }
  return tree;
}

// weight_force_scale per tree: |g| sqrt(m_T sum_{i in T} M_ii), m_T the mass of tree T's bodies and
// of the rods in it. Needs the mass matrix of fwd_position.
VectorXd tree_weight_scales(const Scene& s, const mjData* d, const double g[3], const std::vector<int>& tree, int count) {
  const mjModel* m = s.m;
  VectorXd mass = VectorXd::Zero(count), diag = VectorXd::Zero(count);
  std::vector<int> number(m->nbody, -1);
  for (int i = 0; i < m->nv; ++i) {
    number[m->body_rootid[m->dof_bodyid[i]]] = tree[i];
    diag(tree[i]) += d->qM[m->dof_Madr[i]];
  }
  for (int b = 1; b < m->nbody; ++b)
    if (number[m->body_rootid[b]] >= 0) mass(number[m->body_rootid[b]]) += m->body_mass[b];
  for (const auto& rb : s.rods) {
    const int t = number[m->body_rootid[rb.base_body]];
    if (t >= 0)
      for (const auto& node : rb.model.nodes) mass(t) += node.inertia(3, 3);
  }
  const bool gravity_on = !(m->opt.disableflags & mjDSBL_GRAVITY);
  return gravity_on ? VectorXd(mju_norm3(g) * (mass.cwiseProduct(diag)).cwiseMax(0.0).cwiseSqrt()) : VectorXd::Zero(count);
}

// The rods' own passive forces (their elastic forces at rest) in MuJoCo's dof order, zero
// elsewhere: the residual's scales take them apart from the rest of qfrc_passive, since where a
// spring (a tendon's, a joint's) holds a rod bent the two balance each other in qfrc_passive, whose
// norm then shrinks with the residual and cannot scale it (outside probe AG: a rod held by a
// tendon spring without gravity never converged, its residual 1 throughout).
VectorXd rods_passive(const Scene& s, const SceneData& sd) {
  VectorXd v = VectorXd::Zero(s.m->nv);
  for (size_t r = 0; r < s.rods.size(); ++r) v.segment(s.rods[r].dof0, s.rods[r].model.nv) = sd.rod[r].qfrc_passive;
  return v;
}

// Which constraint rows an analysis with constraints held rigid holds: the equality constraints'
// (welds, connects, joint and tendon couplings), or every row that can carry load at rest: the
// equalities, the limits that act, and every row of every contact (its point then held to the
// other geom with its friction, a pin; friction loss only resists motion). A contact at exactly
// zero distance carries no force, but holds all the same: outside probe AI's capsule lying on a
// floor at exactly its radius had one end's contact held and the other free, and pivoting about the
// held end into the floor read as unstable.
enum class Held { Equalities, Loaded };

bool is_contact(int type) {
  return type == mjCNSTR_CONTACT_FRICTIONLESS || type == mjCNSTR_CONTACT_PYRAMIDAL || type == mjCNSTR_CONTACT_ELLIPTIC;
}

// A row's identity across evaluations at nearby configurations, where indices can shift as
// contacts come and go: its type, its object (for a contact its two geoms and its rank among
// their contacts) and its place among that object's rows.
struct RowKey {
  int type = 0, object = 0, other = 0, rank = 0, row = 0;
  bool operator==(const RowKey&) const = default;
};

std::vector<RowKey> row_keys(const mjData* d) {
  std::vector<RowKey> keys(d->nefc);
  for (int i = 0; i < d->nefc; ++i) {
    RowKey k;
    k.type = d->efc_type[i];
    k.object = d->efc_id[i];
    if (is_contact(k.type)) {
      const mjContact& c = d->contact[d->efc_id[i]];
      k.object = c.geom1;
      k.other = c.geom2;
      for (int j = 0; j < d->efc_id[i]; ++j) k.rank += d->contact[j].geom1 == c.geom1 && d->contact[j].geom2 == c.geom2;
    }
    if (i > 0 && d->efc_type[i - 1] == d->efc_type[i] && d->efc_id[i - 1] == d->efc_id[i]) k.row = keys[i - 1].row + 1;
    keys[i] = k;
  }
  return keys;
}

// The rows `held` holds after an evaluation (their indices).
std::vector<int> held_rows(const mjData* d, Held held) {
  std::vector<int> rows;
  for (int i = 0; i < d->nefc; ++i) {
    const int t = d->efc_type[i];
    const bool hold = t == mjCNSTR_EQUALITY ||
                      (held == Held::Loaded && (is_contact(t) || ((t == mjCNSTR_LIMIT_JOINT || t == mjCNSTR_LIMIT_TENDON) &&
                                                                  d->efc_state[i] != mjCNSTRSTATE_SATISFIED)));
    if (hold) rows.push_back(i);
  }
  return rows;
}

// Rows `rows` of efc_J after an evaluation, dense (rows x nv), in either of MuJoCo's layouts.
MatrixXd constraint_jacobian(const mjModel* m, const mjData* d, const std::vector<int>& rows) {
  MatrixXd J = MatrixXd::Zero(static_cast<int>(rows.size()), m->nv);
  for (int r = 0; r < J.rows(); ++r) {
    const int i = rows[r];
    if (!mj_isSparse(m)) {
      for (int j = 0; j < m->nv; ++j) J(r, j) = d->efc_J[static_cast<size_t>(i) * m->nv + j];
    } else {
      for (int k = 0; k < d->efc_J_rownnz[i]; ++k)
        J(r, d->efc_J_colind[d->efc_J_rowadr[i] + k]) = d->efc_J[d->efc_J_rowadr[i] + k];
    }
  }
  return J;
}

// An orthonormal basis (columns) of the tangent directions dq that the rows of J leave free
// (J N = 0): the identity without rows.
MatrixXd free_directions(const MatrixXd& J) {
  const int n = static_cast<int>(J.cols());
  if (J.rows() == 0) return MatrixXd::Identity(n, n);
  Eigen::JacobiSVD<MatrixXd> svd(J, Eigen::ComputeFullV);
  const VectorXd& sigma = svd.singularValues();
  int rank = 0;
  while (rank < sigma.size() && sigma(rank) > 1e-9 * sigma(0)) ++rank;
  return svd.matrixV().rightCols(n - rank);
}

std::vector<int> floating_joints(const mjModel* m);

// The static problem of one scene: the loads as the user set them (scaled by the load factor at
// every evaluation and restored on destruction) and evaluations of the smooth force at rest.
class StaticProblem {
 public:
  // `progress`: told where the finite-difference columns are (the option of SceneStaticsOptions and
  // SceneLinearizeOptions)
  StaticProblem(const Scene& s, SceneData& sd, std::function<void(const std::string&)> progress = {})
      : progress_(std::move(progress)), s_(s), sd_(sd), m_(s.m), d_(sd.d),
        gravity_(m_->opt.gravity, m_->opt.gravity + 3),
        ctrl_(d_->ctrl, d_->ctrl + m_->nu),
        qfrc_applied_(d_->qfrc_applied, d_->qfrc_applied + m_->nv),
        xfrc_applied_(d_->xfrc_applied, d_->xfrc_applied + 6 * m_->nbody) {
    tree_ = dof_trees(m_, ntree_);
    for (int i = 0; i < m_->nv; ++i) {
      const int j = m_->dof_jntid[i], t = m_->jnt_type[j];
      if (t == mjJNT_HINGE || t == mjJNT_BALL || (t == mjJNT_FREE && i - m_->jnt_dofadr[j] >= 3)) turning_.push_back(i);
    }
    for (const int j : floating_joints(m_))
      for (int k = 0; k < 6; ++k) floating_.push_back(m_->jnt_dofadr[j] + k);
  }
  StaticProblem(const StaticProblem&) = delete;
  StaticProblem& operator=(const StaticProblem&) = delete;
  ~StaticProblem() { set_loads(1.0); }

  int nv() const { return m_->nv; }

  // Loads at factor lambda: gravity, controls, applied generalised forces and body wrenches.
  void set_loads(double lambda) {
    for (int k = 0; k < 3; ++k) m_->opt.gravity[k] = lambda * gravity_[k];
    for (int i = 0; i < m_->nu; ++i) d_->ctrl[i] = lambda * ctrl_[i];
    for (int i = 0; i < m_->nv; ++i) d_->qfrc_applied[i] = lambda * qfrc_applied_[i];
    for (int i = 0; i < 6 * m_->nbody; ++i) d_->xfrc_applied[i] = lambda * xfrc_applied_[i];
    settle_activations(m_, d_);
  }

  // The position and velocity stages at the current qpos and qvel, and the control callback's
  // controls there under load factor lambda: what a force evaluation starts from.
  void stages_and_controls(Need need, double lambda = 1.0) {
    fwd_position(s_, sd_, need);
    fwd_velocity(s_, sd_);
    control_callback(lambda);
  }

  // MuJoCo's control callback (mjcb_control), called where a step's evaluation calls it (after
  // the velocities), from the controls the statics started with: the controls it sets are scaled by
  // the load factor with the other loads (a feedback law is then the step's at the full loads, and
  // the tangent stiffness and damping include its dependence on the state). Outside probe AB: the
  // callback was ignored, and a rod bent by a motor whose control it set read straight.
  void control_callback(double lambda) {
    if (!mjcb_control) return;
    std::copy(ctrl_.begin(), ctrl_.end(), d_->ctrl);
    mjcb_control(m_, d_);
    for (int i = 0; i < m_->nu; ++i) d_->ctrl[i] *= lambda;
    settle_activations(m_, d_);
  }

  // f = qfrc_smooth at the current qpos, at rest, under load factor lambda. Returns the scale.
  // Without `mass` the mass matrix is left stale (Need::SmoothStaticForces, which skips the collisions too); M's factorisation, O(nv^3)
  // for one long rod (whose dofs all share one branch), is skipped whenever no constraint acts.
  // With `row_scale`, per generalised force f_i the sum of the magnitudes of the terms it is made
  // of (the rods' elastic forces, the other passive forces, gravity's and the other bias forces,
  // each actuator's, the applied forces and the body wrenches), whose rounding bounds f_i's.
  // With `tree_scale`, the same scale per tree of the scene (dof_trees): the norms over the tree's
  // dofs, its joints' and tendons' springs, its actuators' share, and its own weight
  // (tree_weight_scales).
  double force(double lambda, VectorXd& f, bool mass = true, VectorXd* row_scale = nullptr, VectorXd* tree_scale = nullptr) {
    set_loads(lambda);
    mju_zero(d_->qvel, m_->nv);
    stages_and_controls(mass ? Need::Forces : Need::SmoothStaticForces, lambda);
    mj_fwdActuation(m_, d_);
    if (sd_.forces_only)
      smooth_forces(m_, d_);  // qfrc_smooth = passive - bias + applied + actuator + J^T xfrc
    else
      mj_fwdAcceleration(m_, d_);  // the same, and qacc_smooth
    f = Eigen::Map<const VectorXd>(d_->qfrc_smooth, m_->nv);
    const Eigen::Map<const VectorXd> passive(d_->qfrc_passive, m_->nv);
    if (weight_scale_ < 0) {  // needs the mass matrix
      if (!mass) fwd_inertia(s_, sd_);
      weight_scale_ = weight_scale();
      tree_weights_ = tree_weight_scales(s_, d_, gravity_.data(), tree_, ntree_);
    }
    const VectorXd rods = rods_passive(s_, sd_);
    // each actuator's own generalised force |force_i| |moment_i| too, as the rounding it leaves
    // where actuators cancel each other in their sum: without it, three cables at 120 degrees on a
    // straight arm had left a scale of round-off, and Newton hundreds of iterations on a state that
    // was already the equilibrium (outside probe AM). Weighted by kCancelling, so that the
    // default tolerance (1e-10) accepts 100 times the rounding of their sum: at its full weight,
    // two antagonistic motors of 5e9 N on a pendulum's hinge let Newton stop 0.066 rad off (1e7 N:
    // 1e-4 rad), where the rounding of their sum is 2e-6 N m (1e-6 rad).
    constexpr double kCancelling = 1e12 * DBL_EPSILON;
    double actuators = 0.0;
    for (int i = 0; i < m_->nu; ++i)
      actuators = std::max(actuators, kCancelling * std::abs(d_->actuator_force[i]) *
                                          mju_norm(d_->actuator_moment + i * m_->nv, m_->nv));
    // the joints' and tendons' springs apart from the rest of qfrc_passive, where they can cancel
    // each other (outside probe AQ: a hinge's spring balancing a tendon's, without gravity, had
    // left the hinge's tree a scale of its own residual, and the scene's scale went to zero with the
    // residual where a slide's spring and a tendon's balance: pre-existing, no equilibrium found)
    VectorXd springs = VectorXd::Zero(ntree_);
    if (!(m_->opt.disableflags & mjDSBL_PASSIVE)) {
      for (int j = 0; j < m_->njnt; ++j) {
        const int type = m_->jnt_type[j];
        if (!(m_->jnt_stiffness[j] > 0) || (type != mjJNT_HINGE && type != mjJNT_SLIDE)) continue;
        const int a = m_->jnt_qposadr[j];
        const double fj = m_->jnt_stiffness[j] * (d_->qpos[a] - m_->qpos_spring[a]);
        springs(tree_[m_->jnt_dofadr[j]]) += fj * fj;
      }
      for (int t = 0; t < m_->ntendon; ++t) {
        if (!(m_->tendon_stiffness[t] > 0)) continue;
        const double ft = m_->tendon_stiffness[t] * (d_->ten_length[t] - m_->tendon_lengthspring[t]);
        if (mj_isSparse(m_)) {
          for (int k = 0; k < d_->ten_J_rownnz[t]; ++k) {
            const int adr = d_->ten_J_rowadr[t] + k;
            springs(tree_[d_->ten_J_colind[adr]]) += ft * ft * d_->ten_J[adr] * d_->ten_J[adr];
          }
        } else {
          for (int i = 0; i < m_->nv; ++i)
            springs(tree_[i]) += ft * ft * d_->ten_J[t * m_->nv + i] * d_->ten_J[t * m_->nv + i];
        }
      }
    }
    if (row_scale) {
      const int n = m_->nv;
      const Eigen::Map<const VectorXd> bias(d_->qfrc_bias, n), applied(d_->qfrc_applied, n), actuator(d_->qfrc_actuator, n);
      VectorXd& sc = *row_scale;
      sc = rods.cwiseAbs() + (passive - rods).cwiseAbs() + bias.cwiseAbs() + applied.cwiseAbs() +
           (f - passive + bias - applied - actuator).cwiseAbs();  // (the last: the body wrenches)
      for (int a = 0; a < m_->nu; ++a)
        sc += std::abs(d_->actuator_force[a]) * Eigen::Map<const VectorXd>(d_->actuator_moment + a * n, n).cwiseAbs();
    }
    if (tree_scale) {
      const int n = m_->nv;
      VectorXd r2 = VectorXd::Zero(ntree_), p2 = r2, o2 = r2, act = r2, m2(ntree_);
      for (int i = 0; i < n; ++i) {
        r2(tree_[i]) += rods(i) * rods(i);
        p2(tree_[i]) += (passive(i) - rods(i)) * (passive(i) - rods(i));
        o2(tree_[i]) += (f(i) - passive(i)) * (f(i) - passive(i));
      }
      for (int a = 0; a < m_->nu; ++a) {
        m2.setZero();
        for (int i = 0; i < n; ++i) m2(tree_[i]) += d_->actuator_moment[a * n + i] * d_->actuator_moment[a * n + i];
        act = act.cwiseMax(kCancelling * std::abs(d_->actuator_force[a]) * m2.cwiseSqrt());
      }
      VectorXd& ts = *tree_scale;
      ts.resize(ntree_);
      for (int t = 0; t < ntree_; ++t)
        ts(t) = std::max({std::sqrt(r2(t)), std::sqrt(p2(t)), std::sqrt(o2(t)), std::sqrt(springs(t)), act(t),
                          lambda * tree_weights_(t), 1e-300});
    }
    return std::max({rods.norm(), (passive - rods).norm(), (f - passive).norm(), std::sqrt(springs.sum()), actuators,
                     lambda * weight_scale_, 1e-300});
  }

  // Newton's residual (newton_residual) and its line search's measure of f: per tree of the scene,
  // |f| over its dofs relative to the tree's own force scale, so that a light part converges to
  // the tolerance of its own forces.
  double tree_residual(const VectorXd& f, const VectorXd& tree_scale) const {
    VectorXd f2 = VectorXd::Zero(ntree_);
    for (int i = 0; i < f.size(); ++i) f2(tree_[i]) += f(i) * f(i);
    return ntree_ ? (f2.cwiseSqrt().cwiseQuotient(tree_scale)).maxCoeff() : 0.0;  // (a scene without dofs: none)
  }
  // sum over the trees of (|f_T| / scale_T)^2, for scales fixed by the caller
  double tree_merit(const VectorXd& f, const VectorXd& tree_scale) const {
    double sum = 0.0;
    for (int i = 0; i < f.size(); ++i) sum += (f(i) / tree_scale(tree_[i])) * (f(i) / tree_scale(tree_[i]));
    return std::sqrt(sum);
  }

  // The total generalised force M qacc = qfrc_smooth + qfrc_constraint at the current qpos and
  // qvel under the full loads: a run's evaluation (contacts detected, MuJoCo's soft constraint
  // rows solved), with the constraint solver's tolerance tightened to round-off for the call.
  void total_force(VectorXd& F) {
    set_loads(1.0);
    stages_and_controls(Need::Acceleration);
    mj_fwdActuation(m_, d_);
    mj_fwdAcceleration(m_, d_);
    const mjtNum tolerance = m_->opt.tolerance;
    m_->opt.tolerance = 1e-15;
    mj_fwdConstraint(m_, d_);
    m_->opt.tolerance = tolerance;
    F = Eigen::Map<const VectorXd>(d_->qfrc_smooth, m_->nv) + Eigen::Map<const VectorXd>(d_->qfrc_constraint, m_->nv);
  }

  // Tangent stiffness -df/dq at lambda by central differences in the tangent space of qpos. With
  // `noise`, bounds of the differences' rounding entry by entry (Linearization::Kt_noise): the
  // rounding of force i, taken as kForceRounding of the sum of the magnitudes of the terms that
  // make it (force()'s row_scale), over the step 2 h_j. (Outside probe AM's antagonistic cables at 12 N on
  // a bent rod: its generalised forces, of terms of 0.013, scattered by 1e-16, 30 times the
  // double's epsilon of them. Per row, not one scale for the scene: outside probe AO's column past
  // its buckling load beside a heavy body on a spring had read stable with the body's forces
  // setting the noise of the column's rows.)
  void stiffness(double lambda, MatrixXd& Kt, MatrixXd* noise = nullptr) {
    constexpr double kForceRounding = 100.0 * std::numeric_limits<double>::epsilon();
    const int n = m_->nv;
    Kt.resize(n, n);
    if (noise) noise->resize(n, n);
    VectorXd fp(n), fm(n), sp(n), sm(n), e = VectorXd::Zero(n);
    const std::vector<mjtNum> q0 = qpos();
    for (int j = 0; j < n; ++j) {
      // (outside probe BB: a 1620-dof scene's columns took 35 s without a word)
      if (progress_ && j % 16 == 0)
        progress_((phase.empty() ? "" : phase + ": ") + "tangent stiffness by central differences, column " +
                  std::to_string(j + 1) + " of " + std::to_string(n));
      const double h = step_size(q0, j);
      e(j) = 1.0;
      move(q0, e, h);
      force(lambda, fp, false, noise ? &sp : nullptr);
      move(q0, e, -h);
      force(lambda, fm, false, noise ? &sm : nullptr);
      e(j) = 0.0;
      Kt.col(j) = -(fp - fm) / (2.0 * h);
      if (noise) noise->col(j) = kForceRounding / h * sp.cwiseMax(sm);
    }
    set_qpos(q0);
  }

  // The constraint rows `held` holds at the current qpos, at rest under the full loads: their
  // Jacobian J (dense, rows x nv) and the stiffness of the loads f they carry there,
  // Kc = -d(J(q)' f)/dq at fixed f by central differences (the turning of a weld's end moment or
  // a connect's end load with the geometry, a contact's point moving over its geoms: their
  // geometric stiffness). The rows' own soft response (solref, solimp) is left out: with the rows
  // held rigid, motions along J are none. Throws std::runtime_error when a held row is gone
  // at a perturbed configuration (a contact at the edge of its margin; one of the pair two parallel
  // capsules make, which is one at any tilt), the state restored.
  // Each column is also differenced at ten times the step, and Kc is the extrapolation that removes
  // an error inversely proportional to the step, (10 Kc(10h) - Kc(h)) / 9, with `noise` an entrywise
  // bound of what is left of it, a tenth of |Kc(h) - Kc(10h)|. MuJoCo 2.2's general
  // convex collider (MPR: pairs with a cylinder, box, ellipsoid or mesh but the analytic ones)
  // places a contact with a jump at a symmetric configuration (a capsule crossing a cylinder: 3e-8 m
  // along the cylinder and 1.4e-6 rad in the normal between 0 and any offset), an error of J / h in
  // the differences: outside probe AX's rigid rod lying across two cylinders read its rolling,
  // neutral, at omega^2 = -1.8 1/s^2 (0 on capsules), and equilibrium left it along that mode and
  // never settled. (A bound of twice |Kc(h) - Kc(10h)| alone, this session's first version, hid
  // real instabilities of the same symmetric configurations, outside probe AY: a capsule standing on
  // a cylinder's flat top at omega^2 = -14, an ellipsoid on its tip on a box at -39; and it left the
  // state moved by 10h where a lightly loaded contact opened at that step.) Where a held row is gone
  // at 10h the column keeps Kc(h).
  void held_loads(Held held, MatrixXd& J, MatrixXd& Kc, MatrixXd& noise) {
    constexpr double kCheckStep = 10.0, kJumpVariation = 0.1;
    const int n = m_->nv;
    VectorXd F(n);
    mju_zero(d_->qvel, n);
    total_force(F);
    const std::vector<int> rows = held_rows(d_, held);
    const std::vector<RowKey> all = row_keys(d_);
    std::vector<RowKey> keys;
    VectorXd f(rows.size());
    for (size_t r = 0; r < rows.size(); ++r) keys.push_back(all[rows[r]]), f(r) = d_->efc_force[rows[r]];
    J = constraint_jacobian(m_, d_, rows);
    Kc.setZero(n, n);
    noise.setZero(n, n);  // (also without rows: the callers add it to their noise of n x n)
    if (rows.empty()) return;
    VectorXd e = VectorXd::Zero(n);
    const std::vector<mjtNum> q0 = qpos();
    // J(q)' f at q0 + h e, or nothing where a held row is gone there
    auto load_at = [&](double h) -> std::optional<VectorXd> {
      move(q0, e, h);
      fwd_position(s_, sd_, Need::Acceleration);
      const std::vector<RowKey> now = row_keys(d_);
      std::vector<int> found;
      for (const RowKey& k : keys) {
        const auto it = std::find(now.begin(), now.end(), k);
        if (it == now.end()) return std::nullopt;
        found.push_back(static_cast<int>(it - now.begin()));
      }
      return VectorXd(constraint_jacobian(m_, d_, found).transpose() * f);
    };
    for (int j = 0; j < n; ++j) {
      const double h = step_size(q0, j);
      e(j) = 1.0;
      const std::optional<VectorXd> fp = load_at(h), fm = load_at(-h);
      if (!fp || !fm) {
        set_qpos(q0);
        total_force(F);  // (the caller's state as it was)
        throw std::runtime_error("a constraint row held rigid is gone under a perturbation");
      }
      Kc.col(j) = -(*fp - *fm) / (2.0 * h);
      const std::optional<VectorXd> gp = load_at(kCheckStep * h), gm = load_at(-kCheckStep * h);
      if (gp && gm) {
        const VectorXd wide = -(*gp - *gm) / (2.0 * kCheckStep * h);
        noise.col(j) = kJumpVariation * (Kc.col(j) - wide).cwiseAbs();
        Kc.col(j) = (kCheckStep * wide - Kc.col(j)) / (kCheckStep - 1.0);
      }
      e(j) = 0.0;
    }
    set_qpos(q0);
    total_force(F);  // the stages at q0 again
  }

  // Velocity derivative -df/dqvel at the current qpos (damping: rods' Kelvin-Voigt, joint and
  // tendon damping, velocity-dependent actuators and fluid forces; Coriolis terms vanish at rest).
  // d(M(q) a)/dq at fixed a by central differences in the tangent space of qpos (the mass matrix's
  // turning with the configuration, times an acceleration a), qpos restored (stages not evaluated).
  void mass_motion(const VectorXd& a, MatrixXd& dMa) {
    const int n = m_->nv;
    dMa.resize(n, n);
    VectorXd mp(n), mm(n), e = VectorXd::Zero(n);
    const std::vector<mjtNum> q0 = qpos();
    for (int j = 0; j < n; ++j) {
      const double h = step_size(q0, j);
      e(j) = 1.0;
      move(q0, e, h);
      fwd_inertia(s_, sd_);
      mj_mulM(m_, d_, mp.data(), a.data());
      move(q0, e, -h);
      fwd_inertia(s_, sd_);
      mj_mulM(m_, d_, mm.data(), a.data());
      e(j) = 0.0;
      dMa.col(j) = (mp - mm) / (2.0 * h);
    }
    set_qpos(q0);
  }

  void damping(MatrixXd& D) {
    const int n = m_->nv;
    const double h = 1e-6;
    D.resize(n, n);
    set_loads(1.0);
    mju_zero(d_->qvel, n);
    fwd_position(s_, sd_);
    auto force_at_velocity = [&](VectorXd& f) {
      fwd_velocity(s_, sd_);
      control_callback(1.0);
      mj_fwdActuation(m_, d_);
      mj_fwdAcceleration(m_, d_);
      f = Eigen::Map<const VectorXd>(d_->qfrc_smooth, n);
    };
    VectorXd fp(n), fm(n);
    for (int j = 0; j < n; ++j) {
      d_->qvel[j] = h;
      force_at_velocity(fp);
      d_->qvel[j] = -h;
      force_at_velocity(fm);
      d_->qvel[j] = 0.0;
      D.col(j) = -(fp - fm) / (2.0 * h);
    }
    fwd_velocity(s_, sd_);
  }

  // Actuation per unit control at the current state: Bu(:, k) = d qfrc_actuator / d ctrl_k
  // (actuation is affine in ctrl at fixed qpos, with activations at their steady state).
  MatrixXd actuation_matrix() {
    const int n = m_->nv, nu = m_->nu;
    MatrixXd Bu(n, nu);
    set_loads(1.0);
    mj_fwdActuation(m_, d_);
    const VectorXd base = Eigen::Map<const VectorXd>(d_->qfrc_actuator, n);
    for (int k = 0; k < nu; ++k) {
      d_->ctrl[k] += 1.0;
      settle_activations(m_, d_);
      mj_fwdActuation(m_, d_);
      Bu.col(k) = Eigen::Map<const VectorXd>(d_->qfrc_actuator, n) - base;
      d_->ctrl[k] -= 1.0;
    }
    set_loads(1.0);
    mj_fwdActuation(m_, d_);
    return Bu;
  }

  // Actuator activations (MuJoCo's act) as states of their own, at the current qpos, at rest, by
  // central differences (actuation is affine in act and ctrl but for muscles): Fa = d qfrc_actuator
  // / d act and Bd = d qfrc_actuator / d ctrl at fixed act, Ga = d act_dot / d act, Gu = d act_dot /
  // d ctrl; with a control callback also Cq, Cv = d ctrl / d qpos, d qvel (the callback's controls,
  // by differences of the position and velocity stages; empty without one). The activations start
  // from their steady state (act = ctrl for filters and muscles), as the second-order form has them.
  void activation_terms(MatrixXd& Fa, MatrixXd& Bd, MatrixXd& Ga, MatrixXd& Gu, MatrixXd& Cq, MatrixXd& Cv) {
    const int n = m_->nv, nu = m_->nu, na = m_->na;
    const double h = 1e-6;
    Fa.resize(n, na), Bd.resize(n, nu), Ga.resize(na, na), Gu.resize(na, nu);
    set_loads(1.0);
    mju_zero(d_->qvel, n);
    stages_and_controls(Need::SmoothStaticForces);
    auto column = [&](mjtNum* x, int k, MatrixXd& F, MatrixXd& G) {  // central differences in x[k]
      VectorXd fp(n), gp(na);
      for (const double sign : {1.0, -1.0}) {
        x[k] += sign * h;
        mj_fwdActuation(m_, d_);
        x[k] -= sign * h;
        const VectorXd f = Eigen::Map<const VectorXd>(d_->qfrc_actuator, n);
        const VectorXd g = Eigen::Map<const VectorXd>(d_->act_dot, na);
        if (sign > 0) fp = f, gp = g;
        else F.col(k) = (fp - f) / (2 * h), G.col(k) = (gp - g) / (2 * h);
      }
    };
    for (int k = 0; k < na; ++k) column(d_->act, k, Fa, Ga);
    for (int k = 0; k < nu; ++k) column(d_->ctrl, k, Bd, Gu);
    Cq.resize(0, 0), Cv.resize(0, 0);
    if (mjcb_control) {
      Cq.resize(nu, n), Cv.resize(nu, n);
      const std::vector<mjtNum> q0(d_->qpos, d_->qpos + m_->nq);
      std::vector<mjtNum> e(n, 0.0);
      auto ctrl_at = [&](VectorXd& c) {
        stages_and_controls(Need::SmoothStaticForces);
        c = Eigen::Map<const VectorXd>(d_->ctrl, nu);
      };
      VectorXd cp(nu), cm(nu);
      for (int j = 0; j < n; ++j) {
        e[j] = 1.0;
        for (const double sign : {1.0, -1.0}) {
          set_qpos(q0);
          mj_integratePos(m_, d_->qpos, e.data(), sign * h);
          ctrl_at(sign > 0 ? cp : cm);
        }
        e[j] = 0.0;
        set_qpos(q0);
        Cq.col(j) = (cp - cm) / (2 * h);
        d_->qvel[j] = h;
        ctrl_at(cp);
        d_->qvel[j] = -h;
        ctrl_at(cm);
        d_->qvel[j] = 0.0;
        Cv.col(j) = (cp - cm) / (2 * h);
      }
    }
    set_loads(1.0);
    stages_and_controls(Need::SmoothStaticForces);
    mj_fwdActuation(m_, d_);
  }

  // The dofs of the floating free joints (floating_joints): Newton keeps them where they are
  // (hold_floating) and the stability test leaves them out, their stiffness being round-off.
  const std::vector<int>& floating() const { return floating_; }
  // Kt and f with the floating dofs held: their rows and columns those of a unit spring at rest.
  void hold_floating(MatrixXd& Kt, VectorXd& f) const {
    for (const int i : floating_) {
      Kt.row(i).setZero();
      Kt.col(i).setZero();
      Kt(i, i) = 1.0;
      f(i) = 0.0;
    }
  }

  // dq scaled down so that no hinge, ball or free joint turns by more than 1 rad: where the stiffness
  // of a joint vanishes (a pendulum starting horizontal) Newton's step is unbounded (outside probe
  // BB: the Levenberg-Marquardt step took such a pendulum 1e6 rad, 160 000 turns, to an equilibrium
  // there, where the finite differences' step relative to the angle was 1 rad and linearize read
  // its frequency 8% low)
  void limit_turns(VectorXd& dq) const {
    constexpr double kMaxTurn = 1.0;
    double most = 0.0;
    for (const int i : turning_) most = std::max(most, std::abs(dq(i)));
    if (most > kMaxTurn) dq *= kMaxTurn / most;
  }

  std::vector<mjtNum> qpos() const { return std::vector<mjtNum>(d_->qpos, d_->qpos + m_->nq); }
  void set_qpos(const std::vector<mjtNum>& q) { std::copy(q.begin(), q.end(), d_->qpos); }
  // qpos = q0 (+) alpha dq, the tangent-space step (quaternions stay unit).
  void move(const std::vector<mjtNum>& q0, const VectorXd& dq, double alpha) {
    set_qpos(q0);
    mj_integratePos(m_, d_->qpos, dq.data(), alpha);
  }

 private:
  // The finite-difference step of dof j at q: 1e-6 relative to a slide's position, to a hinge's
  // angle from 1000 rad on (the rounding of sin and cos of a larger angle), else 1e-6.
  double step_size(const std::vector<mjtNum>& q, int j) const {
    const bool hinge = m_->jnt_type[m_->dof_jntid[j]] == mjJNT_HINGE;
    return 1e-6 * std::max(1.0, std::abs(scalar_coordinate(q, j)) * (hinge ? 1e-3 : 1.0));
  }

  // qpos value of dof j when its joint is a hinge or slide (0 for ball joints).
  double scalar_coordinate(const std::vector<mjtNum>& q, int j) const {
    const int jnt = m_->dof_jntid[j];
    const int t = m_->jnt_type[jnt];
    return t == mjJNT_HINGE || t == mjJNT_SLIDE ? q[m_->jnt_qposadr[jnt]] : 0.0;
  }

  double weight_scale() const { return weight_force_scale(s_, d_, gravity_.data()); }

  std::function<void(const std::string&)> progress_;

 public:
  // What the solve is doing, ahead of the stiffness's progress notes (outside probe CJ: 280 s of
  // "tangent stiffness by central differences, column k of 362" said nothing of the load step or
  // the iteration).
  std::string phase;

 private:
  const Scene& s_;
  SceneData& sd_;
  mjModel* m_;
  mjData* d_;
  std::vector<mjtNum> gravity_, ctrl_, qfrc_applied_, xfrc_applied_;  // the user's loads
  double weight_scale_ = -1.0;  // computed at the first evaluation
  std::vector<int> tree_;       // per dof, its tree (dof_trees)
  int ntree_ = 0;
  VectorXd tree_weights_;       // tree_weight_scales, with weight_scale_
  std::vector<int> floating_;   // floating(): the floating free joints' dofs
  std::vector<int> turning_;    // the dofs of hinges, balls and free joints' rotations (limit_turns)
};

// Candidate directions for Kt dq = f, tried in turn (k = 0, 1, ...) until one decreases |f|: the
// plain Newton step; the minimum-norm step (Kt is singular in directions with neither stiffness nor
// load, e.g. a ball joint's twist under gravity alone); then Levenberg-Marquardt steps
// (Kt + mu I) dq = f with growing mu, which turn towards f itself (needed where Kt vanishes, as for
// a horizontal pendulum).
constexpr int kDirections = 2 + 7;
VectorXd newton_direction(const MatrixXd& Kt, const VectorXd& f, int k) {
  if (k == 0) return Eigen::PartialPivLU<MatrixXd>(Kt).solve(f);
  if (k == 1) {
    Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod;
    cod.setThreshold(1e-9);
    return cod.compute(Kt).solve(f);
  }
  const double c = std::max({Kt.diagonal().cwiseAbs().maxCoeff(), f.norm(), 1e-12});
  const double mu = 1e-6 * c * std::pow(100.0, k - 2);  // 1e-6 c ... 1e6 c
  return (Kt + mu * MatrixXd::Identity(Kt.rows(), Kt.cols())).partialPivLu().solve(f);
}

// Newton's residual: |f| / scale, the scene's largest forces (force()'s return), or, if larger, the
// largest over the scene's trees (the world's children and what hangs from them) of |f| on the
// tree's dofs over the tree's own force scale. Per tree, a light part of a scene converges to the
// tolerance of its own forces: on |f| / scale alone a pendulum beside a 10 t body on a spring had
// stopped 6e-6 m off (its 1e-5 N m is 1e-10 of the spring's 1e5 N), and a buckled column beside a
// 100 t one 1e-5 of its length (outside probe AO). The line search measures f the same way (the
// heavy part's rounding had blocked the light part's progress on |f|), each tree on the larger of
// its scales at the iterate and at the trial.
//
// Newton with backtracking at a fixed load factor. Returns true on convergence. Where the line
// search cannot decrease the residual (a residual at round-off), the state counts as converged when
// |f| / scale is within 1e3 times the tolerance.
bool newton(StaticProblem& p, double lambda, const SceneStaticsOptions& opt, SceneStaticsResult& res) {
  const int n = p.nv();
  VectorXd f(n), ft(n), trees, trees_t;
  MatrixXd Kt;
  double scale = p.force(lambda, f, true, nullptr, &trees);
  // the scales do not fall below 1e-3 of what they were at the start: where every force vanishes
  // at the equilibrium (springs and a tendon all at rest, no gravity) they fall with the residual,
  // which then stayed at 1 (outside probe AQ, pre-existing: no equilibrium found)
  const double scale_start = 1e-3 * scale;
  const VectorXd trees_start = 1e-3 * trees;
  auto residual = [&] { return std::max(f.norm() / std::max(scale, scale_start), p.tree_residual(f, trees.cwiseMax(trees_start))); };
  const std::string phase = p.phase;
  for (int it = 0; it < opt.max_iterations; ++it) {
    res.residual = residual();
    res.scale = scale;
    if (res.residual <= opt.tolerance) return true;
    ++res.iterations;
    char at[96];
    std::snprintf(at, sizeof at, "iteration %d (residual %.3g)", it + 1, res.residual);
    p.phase = (phase.empty() ? "Newton" : phase) + ", " + at;
    p.stiffness(lambda, Kt);
    p.phase = phase;
    VectorXd fh = f;
    p.hold_floating(Kt, fh);
    const std::vector<mjtNum> q0 = p.qpos();
    const double f0 = f.norm();
    bool accepted = false;
    for (int k = 0; k < kDirections && !accepted; ++k) {
      VectorXd dq = newton_direction(Kt, fh, k);
      if (!dq.allFinite()) continue;
      p.limit_turns(dq);
      double alpha = 1.0;
      for (int ls = 0; ls < 30 && !accepted; ++ls, alpha *= 0.5) {
        p.move(q0, dq, alpha);
        const double st = p.force(lambda, ft, true, nullptr, &trees_t);
        // both states measured on the larger of their two scales per tree: a tree whose every
        // force vanishes at the iterate (a spring at rest, no gravity) and that a step loads through
        // a tendon from another tree has its scale from the trial (outside probe AQ: the iterate's
        // 1e-300 had made every step's measure infinite, and Newton failed where it had converged)
        const VectorXd both = trees.cwiseMax(trees_t);
        if (ft.allFinite() && p.tree_merit(ft, both) <= (1.0 - 1e-4 * alpha) * p.tree_merit(f, both)) {
          f = ft;
          trees = trees_t;
          scale = st;
          accepted = true;
        }
      }
    }
    if (!accepted) {
      p.set_qpos(q0);
      // a residual already at round-off level cannot decrease further
      return f0 / std::max(scale, scale_start) <= 1e3 * opt.tolerance;
    }
  }
  res.residual = residual();
  return res.residual <= opt.tolerance;
}

// Under gravity, the omega^2 of a fall too slow to act on: 1e-6 g / extent, an e-folding time of
// 1000 sqrt(extent / g) (0 without gravity).
double slowest_fall(const mjModel* m) {
  const bool gravity = !(m->opt.disableflags & mjDSBL_GRAVITY);
  return gravity ? 1e-6 * mju_norm3(m->opt.gravity) / std::max(m->stat.extent, 1e-6) : 0.0;
}

// One step of the scene's own integrator, where a MuJoCo error raised in it (the application's
// mju_user_error handler throws) ends it like a divergence, the step abandoned: outside probe AG's
// twisted rod between two welds broke MuJoCo's constraint solver ("Rank-defficient Hessian"),
// which had aborted the whole command.
Status step_or_abandon(const Scene& s, SceneData& sd) {
  try {
    return step(s, sd);
  } catch (const std::exception& e) {
    abandon_step(sd, e.what());
    return Status::Diverged;
  }
}

// The dynamics' verdict on the equilibrium at the current qpos (at rest, the full loads), for
// where the static one has none (stable_equilibrium: a held contact comes and goes under its
// perturbations, as two parallel capsules' pair of contacts becomes one at any tilt). The scene is
// released at rest from the state and, again, from the state moved by kTap along a fixed direction
// that mixes every dof, each run with its own integrator for up to 30 sqrt(extent / g); it is
// unstable where some body of the tapped run comes kFall times the scene's extent away from where
// the untapped run has it: a fall, which an unstable equilibrium's does until something stops it,
// not the bounded ringing a tap gives a stable one. Bodies' positions, not coordinates: a soft rod's
// twist, of little inertia, rings at 1e3 times the tap in its strain on a hard floor (the repro
// heavy tip). The difference, not the tapped motion alone: a state whose residual the contacts'
// static friction takes up creeps as MuJoCo's soft friction does, by 1e-2 in 0.1 s on the repro
// buckling leg, tapped or not. A fall of e-folding rate below about 0.3 sqrt(g / extent) is not seen,
// and the state is then taken as stable, as without the check. `mode` is the direction in which the
// runs part (tangent space of qpos), `omega2` -lambda^2 with lambda the rate at which they part over
// the last decade. The state is restored. Without gravity there is no time scale to take: no
// verdict (stable).
bool falls_when_tapped(const Scene& s, SceneData& sd, VectorXd& mode, double& omega2) {
  constexpr double kTap = 1e-6, kFall = 1e-2;
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const double g = (m->opt.disableflags & mjDSBL_GRAVITY) ? 0.0 : mju_norm3(m->opt.gravity);
  const int nv = m->nv, nq = m->nq, nx = 3 * m->nbody;
  if (!(g > 0) || nv == 0) return false;
  const double extent = std::max(m->stat.extent, 1e-3), h = m->opt.timestep;
  const long steps = static_cast<long>(std::ceil(30.0 * std::sqrt(extent / g) / h));
  const std::vector<mjtNum> q0(d->qpos, d->qpos + nq);
  const std::vector<mjtNum> act0(d->act, d->act + m->na);
  const double t0 = d->time, last_step_end = sd.last_step_end;
  const SceneData::Compression compression = sd.compression;
  auto restart = [&] {  // (the runs' records too)
    std::copy(q0.begin(), q0.end(), d->qpos);
    std::copy(act0.begin(), act0.end(), d->act);
    mju_zero(d->qvel, nv);
    d->time = t0;
    sd.status = Status::Ok;
    sd.warning.clear();
    sd.compression = compression;
    sd.last_step_end = last_step_end;
  };
  auto advance = [&] { return step_or_abandon(s, sd) == Status::Ok; };
  // the untapped motion, step by step: coordinates and the bodies' positions (those of the step's
  // start, as a step leaves them)
  std::vector<mjtNum> base_q, base_x;
  base_q.reserve(static_cast<size_t>(steps) * nq);
  base_x.reserve(static_cast<size_t>(steps) * nx);
  for (long k = 0; k < steps && advance(); ++k) {
    base_q.insert(base_q.end(), d->qpos, d->qpos + nq);
    base_x.insert(base_x.end(), d->xpos, d->xpos + nx);
  }
  const long recorded = static_cast<long>(base_x.size()) / nx;
  // the tapped one: every dof moved, by amounts of both signs and unequal sizes (no symmetry of
  // the scene kept)
  restart();
  VectorXd tap(nv);
  for (int i = 0; i < nv; ++i) tap(i) = kTap * (0.5 + 0.5 * std::abs(std::sin(1.0 + 2.0 * i))) * (i % 2 ? -1.0 : 1.0);
  mj_integratePos(m, d->qpos, tap.data(), 1.0);
  bool fell = false;
  long decade = -1;  // the step where the runs first parted by a tenth of the fall
  for (long k = 0; k < recorded && !fell && advance(); ++k) {
    double apart = 0.0;
    for (int i = 3; i < nx; i += 3)  // (body 0, the world, stays)
      apart = std::max(apart, mju_dist3(d->xpos + i, &base_x[static_cast<size_t>(k) * nx + i]));
    if (decade < 0 && apart >= 0.1 * kFall * extent) decade = k;
    fell = apart >= kFall * extent;
    if (fell) {
      mode.resize(nv);
      mj_differentiatePos(m, mode.data(), 1.0, &base_q[static_cast<size_t>(k) * nq], d->qpos);
      mode.normalize();
      const double rate = std::log(10.0) / (static_cast<double>(std::max<long>(k - decade, 1)) * h);
      omega2 = -rate * rate;
    }
  }
  restart();
  forward(s, sd);
  return fell;
}

// Stability of the equilibrium at the current qpos under load factor lambda: the smallest
// eigenvalue omega^2 of Ks x = omega^2 M x, Ks the symmetric part of the tangent stiffness (a
// negative one: the equilibrium is unstable, the rod would fall away from it). Returns true when
// no eigenvalue lies below the noise of the central differences (cosserat::unstable_mode: neutral
// directions, such as a free hinge without gravity, count as stable); `mode` (if given) is then
// the most unstable one's eigenvector, in the tangent space of qpos. (Until the twenty-seventh
// session the test was omega^2_min >= -1e-9 |omega^2|_max, which a rod's axial modes at 1e12 made
// blind: outside probe AF's column at twice its buckling load, omega^2_min = -6.2, passed.)
//
// With `constraints` (lambda = 1, an equilibrium where constraint rows carry load) the rows that
// can carry load are held rigid (Held::Loaded: equalities, limits that act, contacts as pins):
// the eigenproblem is N'K N y = omega^2 N'M N y on the directions dq = N y they leave free
// (free_directions), K the smooth stiffness plus that of the loads the rows carry
// (StaticProblem::held_loads: a twisted rod's end moment at a weld, a column's end load at a
// connect, a standing rod's weight on the floor). The rows' own soft stiffness (MuJoCo's solref and
// solimp, most often far stiffer than a rod) is left out: in K its entries would set the noise
// scale of unstable_mode far above a buckling mode's quotient. A contact held as a pin cannot
// lift off: an instability by lifting off is not seen. Where a held row is gone at a perturbed
// configuration (a contact at the edge of its margin; two parallel capsules' pair of contacts,
// which is one at any tilt) the verdict is the dynamics' (falls_when_tapped; until the thirty-eighth
// session there was none: outside probe AY's body of four capsules lying along the top of a capsule
// log, unstable at omega^2 = -107, was reported converged there). (Until the
// twenty-eighth session equilibria where constraint rows carried load were not checked: outside
// probe AG's rod twisted 11 times past Greenhill's load by a weld came back straight and
// "converged".)
bool stable_equilibrium(StaticProblem& p, const Scene& s, SceneData& sd, double lambda, double& omega2_min,
                        VectorXd* mode = nullptr, bool constraints = false, cosserat::GrowthModes* flutter = nullptr) {
  const int n = p.nv();
  omega2_min = 0.0;
  if (flutter) *flutter = {};
  if (n == 0) return true;
  MatrixXd Kt, J, Kc, noise, Kc_noise;
  const std::string phase = p.phase;
  p.phase = "stability check";
  p.stiffness(lambda, Kt, &noise);
  p.phase = phase;
  // loads that turn with the structure make the stiffness at a smooth equilibrium unsymmetric
  // (where constraint rows carry load the smooth forces are not in balance, and their stiffness is
  // unsymmetric whatever the loads: judged as before, from the symmetric part and the noise)
  const bool follower = !constraints && (Kt - Kt.transpose()).norm() > 2e-6 * Kt.norm();
  MatrixXd N = MatrixXd::Identity(n, n);
  if (constraints) {
    try {
      p.held_loads(Held::Loaded, J, Kc, Kc_noise);  // leaves the stages (and qM) at the equilibrium
    } catch (const std::runtime_error&) {
      VectorXd fall;
      if (!falls_when_tapped(s, sd, fall, omega2_min)) return true;
      if (mode) *mode = fall;
      return false;
    }
    Kt += Kc;
    noise += Kc_noise;
  } else {
    VectorXd f(n);
    p.force(lambda, f);  // the stages (and qM) at the equilibrium again
  }
  // the floating bodies' motions are neutral: held like the constraint rows
  if (constraints || !p.floating().empty()) {
    const int rows = constraints ? static_cast<int>(J.rows()) : 0;
    MatrixXd held = MatrixXd::Zero(rows + static_cast<int>(p.floating().size()), n);
    if (rows) held.topRows(rows) = J;
    for (size_t k = 0; k < p.floating().size(); ++k) held(rows + static_cast<int>(k), p.floating()[k]) = 1.0;
    N = free_directions(held);
  }
  if (N.cols() == 0) return true;  // nothing can move
  std::vector<mjtNum> full(static_cast<size_t>(n) * n);
  mj_fullM(s.m, full.data(), sd.d->qM);
  const MatrixXd M = N.transpose() *
                     Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(full.data(), n, n) *
                     N;
  const MatrixXd KN = N.transpose() * Kt * N;
  const MatrixXd KcN = constraints ? MatrixXd(N.transpose() * Kc * N) : MatrixXd();
  const MatrixXd Ks = 0.5 * (KN + KN.transpose());
  // under gravity, a fall slower than an e-folding time of 1000 sqrt(extent / g) is no instability
  // to act on: outside probe AI's capsule lying on a floor, held at one contact, had a neutral
  // direction at omega^2 = -1e-7 1/s^2, the noise of a stiffness that is all noise there (no
  // elastic forces, gravity's constant), and was reported unstable
  const double slowest = slowest_fall(s.m);
  const MatrixXd absN = N.cwiseAbs();
  if (follower) {
    // Loads that turn with the structure (follower loads: site actuators without a refsite): the
    // symmetric part of K decides nothing (outside probe BR: a rod bent into a half circle by a
    // follower end moment, stable in its own damped run, had a negative one and was refused), nor
    // do M^-1 K's eigenvalues alone: the damping decides (cosserat::growth_modes, the damped state
    // matrix's eigenvalues above the slowest fall: divergence where real, flutter where complex).
    MatrixXd D;
    p.damping(D);
    const cosserat::GrowthModes g =
        cosserat::growth_modes(cosserat::state_matrix(M.partialPivLu(), KN, N.transpose() * D * N), std::sqrt(slowest));
    omega2_min = g.divergence_omega2;
    if (!g.unstable()) return true;
    if (flutter && g.growing_pairs > 0) *flutter = g;
    if (mode) *mode = N * (g.diverging > 0 ? g.divergence_mode : g.flutter_mode);
    return false;
  }
  Eigen::GeneralizedSelfAdjointEigenSolver<MatrixXd> es(Ks, M);
  if (es.info() != Eigen::Success) return true;  // M not positive definite: no verdict
  const VectorXd& w = es.eigenvalues();
  omega2_min = w(0);
  for (int i = 0; i < w.size() && w(i) < -slowest; ++i)
    if (cosserat::unstable_mode_fd(es.eigenvectors().col(i), Ks, M,
                                   cosserat::noise_bound(absN * es.eigenvectors().col(i).cwiseAbs(), noise),
                                   constraints ? &KcN : nullptr)) {
      if (mode) *mode = N * es.eigenvectors().col(i);
      return false;
    }
  return true;
}

// An unstable equilibrium the solve came across: where, under which load factor, and the
// eigenvector of its most unstable mode (tangent space of qpos).
struct UnstableState {
  std::vector<mjtNum> qpos;
  double lambda = 0.0;
  VectorXd mode;
  cosserat::GrowthModes flutter;  // where it flutters (loads that turn with the scene)
  bool found() const { return !qpos.empty(); }
};

// q moved along the tangent-space direction `mode`, by `amount` in its largest coordinate
// (radians, strains, curvatures in 1/m, metres). 1e-3: a start that an unstable equilibrium's
// dynamics leave exponentially, at its rate sqrt(-omega^2).
std::vector<mjtNum> along_mode(const mjModel* m, std::vector<mjtNum> q, const VectorXd& mode, double amount = 1e-3) {
  const double big = mode.cwiseAbs().maxCoeff();
  if (big > 0) mj_integratePos(m, q.data(), mode.data(), amount / big);
  return q;
}

// Branch switching past a bifurcation: Newton under the full loads from the unstable equilibrium
// the continuation met, moved along its unstable mode by growing amounts (0.01, 0.1, 1 in the
// mode's largest coordinate), until it converges on a stable equilibrium (the buckled column, whose
// amplitude grows like the square root of the load's excess: 0.1% past the buckling load is too
// slow a fall for the dynamic relaxation's 30 s). On failure qpos and the result are as they were.
bool switch_branch(StaticProblem& p, const Scene& s, SceneData& sd, const SceneStaticsOptions& opt,
                   SceneStaticsResult& res, const UnstableState& unstable) {
  const std::vector<mjtNum> q_good = p.qpos();
  const SceneStaticsResult before = res;
  for (const double amount : {1e-2, 1e-1, 1.0}) {
    p.set_qpos(along_mode(s.m, unstable.qpos, unstable.mode, amount));
    p.phase = "Newton past the bifurcation, from the unstable equilibrium moved along its mode";
    double w2 = 0.0;
    if (newton(p, 1.0, opt, res) && stable_equilibrium(p, s, sd, 1.0, w2)) {
      ++res.load_steps;
      res.omega2_min = w2;
      res.message = "converged, past a bifurcation: from the unstable equilibrium at load factor " +
                    cosserat::load_factor_text(unstable.lambda) + " moved along its unstable mode";
      return true;
    }
  }
  const int iterations = res.iterations;
  res = before;
  res.iterations = iterations;
  p.set_qpos(q_good);
  return false;
}

// Newton with load continuation (statics.cpp's scheme). On failure qpos is the last good step.
// With opt.stable, a load step whose equilibrium is unstable is refused like a failed one (the
// increment is halved): small enough increments follow the stable branch from the start. The
// refused equilibrium under the largest load is kept in `unstable` (switch_branch and the
// relaxation start from it).
bool solve_smooth(StaticProblem& p, const Scene& s, SceneData& sd, const SceneStaticsOptions& opt,
                  SceneStaticsResult& res, UnstableState& unstable) {
  double lam = 0.0, dlam = 1.0;
  std::vector<mjtNum> q_good = p.qpos();
  int halvings = 0;
  while (lam < 1.0) {
    const double target = std::min(1.0, lam + dlam);
    p.phase = "Newton, load step " + std::to_string(res.load_steps + 1) + " to load factor " + cosserat::load_factor_text(target);
    if (opt.progress) opt.progress(p.phase + ", " + std::to_string(res.iterations) + " iterations so far");
    double w2 = 0.0;
    VectorXd mode;
    cosserat::GrowthModes flutter;
    bool converged = newton(p, target, opt, res), refused = false;
    if (converged && opt.stable && !stable_equilibrium(p, s, sd, target, w2, &mode, false, &flutter)) {
      refused = true;
      if (!unstable.found() || target >= unstable.lambda) unstable = {p.qpos(), target, mode, flutter};
    }
    if (converged && !refused) {
      lam = target;
      q_good = p.qpos();
      ++res.load_steps;
      res.omega2_min = w2;
      dlam *= 2.0;
    } else {
      if (refused) ++res.unstable_steps_refused;
      p.set_qpos(q_good);
      dlam *= 0.5;
      if (++halvings > opt.max_load_halvings) {
        res.message = "no convergence: load continuation stalled at load factor " + cosserat::load_factor_text(lam) +
                      (res.unstable_steps_refused ? " (beyond it the equilibria found are unstable)" : "");
        return false;
      }
    }
  }
  res.message = "converged";
  return true;
}

// Constraint rows that can carry load at rest (friction loss only resists motion: any smooth
// equilibrium is also an equilibrium with it).
int load_bearing_rows(const mjData* d) {
  int n = 0;
  for (int i = 0; i < d->nefc; ++i)
    if (d->efc_type[i] != mjCNSTR_FRICTION_DOF && d->efc_type[i] != mjCNSTR_FRICTION_TENDON) ++n;
  return n;
}

// The full residual at rest: |M qacc| = |qfrc_smooth + qfrc_constraint|, after forward().
// `loaded`: whether some constraint row carries more than its round-off: a force beyond what a
// violation of 1e-15 of the model's extent makes in that row (k imp / R, MuJoCo's soft row at
// rest). Where every force vanishes (an unloaded rod welded where it lies) the scale goes to zero
// with them, and a weld's round-off (2e-16 m, 8e-15 N) had counted as a load, with a residual of
// order 1 that no relaxation brings down (outside probe AH). The test is per row: a threshold from
// the stiffest row anywhere (a locked rotor's weld, R at MuJoCo's floor 1e-15: 5e3 N) hid a
// connect's real load elsewhere, and the smooth solution that tore it open 0.47 m was reported
// (outside probe AI).
struct FullResidual {
  VectorXd Ma;  // M qacc
  double force = 0.0, constraint = 0.0, scale = 1e-300;
  bool loaded = false;
};
FullResidual full_residual(const Scene& s, SceneData& sd) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  const int n = m->nv;
  const Eigen::Map<const VectorXd> passive(d->qfrc_passive, n), smooth(d->qfrc_smooth, n),
      constraint(d->qfrc_constraint, n);
  FullResidual r;
  r.Ma.resize(n);
  mj_mulM(m, d, r.Ma.data(), d->qacc);
  r.force = r.Ma.norm();
  r.constraint = constraint.norm();
  const VectorXd rods = rods_passive(s, sd);
  // the weight's scale: gravity's generalised force vanishes at a hanging equilibrium (outside
  // probe AG: a rigid double pendulum's relaxation stayed at residual 1)
  r.scale = std::max({rods.norm(), (passive - rods).norm(), (smooth - passive).norm(), r.constraint,
                      weight_force_scale(s, d, m->opt.gravity), 1e-300});
  const double roundoff = 1e-15 * std::max(m->stat.extent, 1e-3);
  for (int i = 0; i < d->nefc && !r.loaded; ++i) {
    if (d->efc_type[i] == mjCNSTR_FRICTION_DOF || d->efc_type[i] == mjCNSTR_FRICTION_TENDON) continue;
    const double stiffness = d->efc_R[i] > 0 ? d->efc_KBIP[4 * i] * d->efc_KBIP[4 * i + 2] / d->efc_R[i] : HUGE_VAL;
    r.loaded = std::abs(d->efc_force[i]) > roundoff * stiffness;
  }
  return r;
}

// Whether the straight path in configuration space from q0 to q1 runs into an obstacle: some
// contact deeper than any at q0 (by more than 1e-6 m) at one of the samples along it. The smooth
// solution ignores contacts, and the check at its end misses a support the rod passed through on
// the way (a thin plate under a cantilever's tip: an outside probe). Samples are spaced at most
// half the smallest size of the colliding geoms apart, by the largest geom displacement (16 to
// 2048 samples). Leaves qpos at q1; `where` gets the path fraction of the first deep contact.
bool path_runs_into_contact(const Scene& s, SceneData& sd, const std::vector<mjtNum>& q0,
                            const std::vector<mjtNum>& q1, double& where) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  if (!s.may_collide) return false;
  auto deepest = [&](const std::vector<mjtNum>& q, std::vector<mjtNum>* xpos) {
    mju_copy(d->qpos, q.data(), m->nq);
    fwd_position(s, sd, Need::StaticForces);
    if (xpos) xpos->assign(d->geom_xpos, d->geom_xpos + 3 * m->ngeom);
    double depth = 0.0;
    for (int i = 0; i < d->ncon; ++i) depth = std::min(depth, d->contact[i].dist);
    return depth;
  };
  std::vector<mjtNum> x0, x1;
  const double depth0 = deepest(q0, &x0), depth1 = deepest(q1, &x1);
  const double limit = std::min(0.0, depth0) - 1e-6;
  double moved = 0.0, smallest = HUGE_VAL;
  for (int g = 0; g < m->ngeom; ++g) {
    if (!m->geom_contype[g] && !m->geom_conaffinity[g]) continue;
    moved = std::max(moved, mju_dist3(x0.data() + 3 * g, x1.data() + 3 * g));
    if (m->geom_type[g] == mjGEOM_PLANE || m->geom_type[g] == mjGEOM_HFIELD) continue;
    const mjtNum* size = m->geom_size + 3 * g;
    const double least = m->geom_type[g] == mjGEOM_BOX || m->geom_type[g] == mjGEOM_ELLIPSOID
                             ? std::min({size[0], size[1], size[2]})
                         : m->geom_type[g] == mjGEOM_MESH ? m->geom_rbound[g]
                                                           : size[0];  // sphere, capsule, cylinder radius
    if (least > 0) smallest = std::min(smallest, least);
  }
  const int n = std::isfinite(smallest)
                    ? static_cast<int>(std::clamp(std::ceil(2.0 * moved / smallest), 16.0, 2048.0))
                    : 16;
  std::vector<mjtNum> dq(m->nv), q(m->nq);
  mj_differentiatePos(m, dq.data(), 1.0, q0.data(), q1.data());
  bool hit = false;
  for (int k = 1; k < n && !hit; ++k) {
    q = q0;
    mj_integratePos(m, q.data(), dq.data(), static_cast<double>(k) / n);
    if (deepest(q, nullptr) < limit) hit = true, where = static_cast<double>(k) / n;
  }
  if (!hit && depth1 < limit) hit = true, where = 1.0;
  mju_copy(d->qpos, q1.data(), m->nq);
  return hit;
}

double kinetic_energy(const Scene& s, SceneData& sd) {
  std::vector<mjtNum> Mv(s.m->nv);
  mj_mulM(s.m, sd.d, Mv.data(), sd.d->qvel);
  return 0.5 * mju_dot(Mv.data(), sd.d->qvel, s.m->nv);
}

// Whether the straight path in configuration space from q0 to q1 opens an equality constraint
// wider on the way than at either end: some equality row's violation at one of 17 samples along
// it (at the fractions k phi mod 1, which no whole number of turns lines up with) beyond both ends' by 1e-6 of
// the model's extent (or radians). The smooth solution ignores the constraints: outside probe AG's
// rod twisted 27 turns between a clamp and a weld untwists in it, through the weld, which sees
// whole turns as closed at both ends. Leaves qpos at q1; `where` gets the path fraction.
bool path_opens_equality(const Scene& s, SceneData& sd, const std::vector<mjtNum>& q0, const std::vector<mjtNum>& q1,
                         double& where) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  if (m->neq == 0) return false;
  auto violations = [&](const std::vector<mjtNum>& q) {
    mju_copy(d->qpos, q.data(), m->nq);
    fwd_position(s, sd, Need::SmoothStaticForces);
    std::vector<RowKey> keys = row_keys(d);
    std::vector<std::pair<RowKey, double>> v;
    for (int i = 0; i < d->nefc; ++i)
      if (d->efc_type[i] == mjCNSTR_EQUALITY) v.emplace_back(keys[i], std::abs(d->efc_pos[i]));
    return v;
  };
  const auto v0 = violations(q0), v1 = violations(q1);
  const double tol = 1e-6 * std::max(m->stat.extent, 1e-3);
  std::vector<mjtNum> dq(m->nv), q(m->nq);
  mj_differentiatePos(m, dq.data(), 1.0, q0.data(), q1.data());
  bool opens = false;
  for (int k = 1; k <= 17 && !opens; ++k) {
    // fractions k phi mod 1 (phi the golden ratio's 0.618...): irrational, so no whole number of
    // turns puts every sample on a whole turn (at k/18, 18 and 36 turns did: outside probe AI)
    const double t = std::fmod(k * 0.6180339887498949, 1.0);
    q = q0;
    mj_integratePos(m, q.data(), dq.data(), t);
    for (const auto& [key, v] : violations(q)) {
      double ends = 0.0;
      for (const auto* e : {&v0, &v1})
        for (const auto& [k2, w] : *e)
          if (k2 == key) ends = std::max(ends, w);
      if (v > ends + tol) {
        opens = true;
        where = t;
        break;
      }
    }
  }
  mju_copy(d->qpos, q1.data(), m->nq);
  return opens;
}

// Whether the contacts' static friction can take up what is left of the force at rest, r = M qacc
// (after forward(), qvel = 0): contact forces df in the contacts' own frames (normal and tangents,
// least squares) cancel r to `tolerance`, and every contact stays pressed and inside its friction
// cone with df added (the pyramid's L1 bound, the ellipse's). MuJoCo's soft friction cannot hold a
// tangential load at zero velocity: a fraction R / (A + R) of it leaks and the contact creeps
// (outside probe AI: 0.77 um/s for a stiff rod across two supports, 2.4 um/s for a box over a
// step's edge), so where friction carries load the relaxation's residual stayed near 1e-5 to 1e-4
// and no equilibrium was reported.
bool friction_takes_up(const mjModel* m, const mjData* d, const VectorXd& r, double tolerance) {
  if (d->ncon == 0) return false;
  struct Frame {
    int col = 0;  // its columns in G: normal, then tangents
    bool elliptic = false;
    double fn = 0.0;
    std::vector<double> ft, mu;
  };
  std::vector<Frame> frames;
  std::vector<VectorXd> cols;
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    if (con.efc_address < 0) continue;
    const int row0 = con.efc_address, t = d->efc_type[row0];
    auto row = [&](int k) { return VectorXd(constraint_jacobian(m, d, {row0 + k}).row(0).transpose()); };
    Frame f;
    f.col = static_cast<int>(cols.size());
    f.elliptic = t == mjCNSTR_CONTACT_ELLIPTIC;
    if (t == mjCNSTR_CONTACT_PYRAMIDAL) {
      cols.push_back(0.5 * (row(0) + row(1)));
      for (int k = 0; k < con.dim - 1; ++k) {
        const double mu = con.friction[k];
        cols.push_back((row(2 * k) - row(2 * k + 1)) / (2 * mu));
        f.mu.push_back(mu);
        f.ft.push_back(mu * (d->efc_force[row0 + 2 * k] - d->efc_force[row0 + 2 * k + 1]));
        f.fn += d->efc_force[row0 + 2 * k] + d->efc_force[row0 + 2 * k + 1];
      }
    } else {  // frictionless or elliptic: one row per contact-frame direction
      for (int k = 0; k < con.dim; ++k) cols.push_back(row(k));
      f.fn = d->efc_force[row0];
      for (int k = 1; k < con.dim; ++k) f.ft.push_back(d->efc_force[row0 + k]), f.mu.push_back(con.friction[k - 1]);
    }
    frames.push_back(f);
  }
  MatrixXd G(r.size(), static_cast<int>(cols.size()));
  for (int k = 0; k < G.cols(); ++k) G.col(k) = cols[k];
  const VectorXd df = -Eigen::CompleteOrthogonalDecomposition<MatrixXd>(G).solve(r);
  if (!((r + G * df).norm() <= tolerance)) return false;
  for (const Frame& f : frames) {
    const double fn = f.fn + df(f.col);
    if (fn < 0) return false;
    double l1 = 0.0, l2 = 0.0;
    for (size_t k = 0; k < f.ft.size(); ++k) {
      if (!(f.mu[k] > 0)) continue;
      const double q = (f.ft[k] + df(f.col + 1 + static_cast<int>(k))) / f.mu[k];
      l1 += std::abs(q);
      l2 += q * q;
    }
    if ((f.elliptic ? std::sqrt(l2) : l1) > fn) return false;
  }
  return true;
}

// Whether tendon t's path passes through body b's subtree (a site on it, or a geom it wraps).
bool tendon_touches(const mjModel* m, int t, int b) {
  for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
    const int type = m->wrap_type[w], id = m->wrap_objid[w];
    if (type == mjWRAP_SITE && is_descendant(m, m->site_bodyid[id], b)) return true;
    if ((type == mjWRAP_SPHERE || type == mjWRAP_CYLINDER) && is_descendant(m, m->geom_bodyid[id], b)) return true;
  }
  return false;
}

// Whether a force that grows with the displacement pulls free joint j's body (b) towards a place:
// the joint's own spring, a tendon through its subtree with a spring (or, under gravity, a length
// limit: a rope), a tendon equality on such a tendon, or an actuator with a length or position
// gain on the joint, on a site of the subtree or on such a tendon (a servo). (Outside probe AR: a
// box on a rope, on a tendon spring or on its free joint's spring was refused as free-floating.)
bool held_by_forces(const mjModel* m, int j, bool gravity) {
  const int b = m->jnt_bodyid[j];
  const bool passive = !(m->opt.disableflags & mjDSBL_PASSIVE);
  if (passive && m->jnt_stiffness[j] > 0) return true;
  for (int t = 0; t < m->ntendon; ++t)
    if (((passive && m->tendon_stiffness[t] > 0) || (gravity && m->tendon_limited[t])) && tendon_touches(m, t, b))
      return true;
  for (int e = 0; e < m->neq; ++e)
    if (m->eq_type[e] == mjEQ_TENDON &&
        (tendon_touches(m, m->eq_obj1id[e], b) || (m->eq_obj2id[e] >= 0 && tendon_touches(m, m->eq_obj2id[e], b))))
      return true;
  if (!(m->opt.disableflags & mjDSBL_ACTUATION))
    for (int a = 0; a < m->nu; ++a) {
      const bool servo = (m->actuator_gaintype[a] == mjGAIN_AFFINE && m->actuator_gainprm[mjNGAIN * a + 1] != 0) ||
                         (m->actuator_biastype[a] == mjBIAS_AFFINE && m->actuator_biasprm[mjNBIAS * a + 1] != 0);
      if (!servo) continue;
      const int type = m->actuator_trntype[a], id = m->actuator_trnid[2 * a];
      if (((type == mjTRN_JOINT || type == mjTRN_JOINTINPARENT) && id == j) ||
          (type == mjTRN_SITE && is_descendant(m, m->site_bodyid[id], b)) ||
          (type == mjTRN_TENDON && tendon_touches(m, id, b)))
        return true;
    }
  return false;
}

// Whether an actuator acts on body b's subtree: through a joint, site or body of it, or a tendon
// through it (a thruster's force turns with the body, so the subtree's net force can depend on its
// placement).
bool actuated(const mjModel* m, int b) {
  if (m->opt.disableflags & mjDSBL_ACTUATION) return false;
  for (int a = 0; a < m->nu; ++a) {
    const int type = m->actuator_trntype[a], id = m->actuator_trnid[2 * a];
    if (((type == mjTRN_JOINT || type == mjTRN_JOINTINPARENT) && is_descendant(m, m->jnt_bodyid[id], b)) ||
        ((type == mjTRN_SITE || type == mjTRN_SLIDERCRANK) && is_descendant(m, m->site_bodyid[id], b)) ||
        (type == mjTRN_BODY && is_descendant(m, id, b)) || (type == mjTRN_TENDON && tendon_touches(m, id, b)))
      return true;
  }
  return false;
}

// A free joint of `loose` (only a contact can hold it) that no actuator acts on and whose subtree
// carries a net force at the start under the full loads (its weight, applied forces): no placement
// changes that force (everything else on the subtree is internal to it, and contacts are what the
// smooth problem leaves out), so the smooth problem has no equilibrium. A message naming it, empty
// if none. Not where forces at rest can depend on the placement otherwise: MuJoCo's fluid in a
// wind (re-check CK: a plate held up by an updraft's drag when flat, which Newton had found, was
// sent to the relaxation and fell), or a passive callback of the user's. (Outside probe CE: a
// starfish of 646 dofs on a floor spent 80 of 110 s in the smooth search's continuation, halving
// its load step at load factor 0, before the relaxation that found its rest.)
std::string weight_on_contacts_alone(const mjModel* m, const std::vector<int>& loose, const VectorXd& f, double scale) {
  const bool passive = !(m->opt.disableflags & mjDSBL_PASSIVE);
  const bool wind = passive && (m->opt.density > 0 || m->opt.viscosity > 0) && mju_norm3(m->opt.wind) > 0;
  if (wind || (passive && mjcb_passive)) return {};
  for (int j : loose) {
    const int b = m->jnt_bodyid[j];
    if (actuated(m, b)) continue;
    const double net = f.segment<3>(m->jnt_dofadr[j]).norm();
    if (!(net > 1e-6 * scale)) continue;
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "'%s' (free joint) is held by nothing but contacts: nothing else balances the net force of %.4g N on it "
                  "and what hangs from it, so the smooth equilibrium search (contacts ignored) has none to find",
                  name ? name : "?", net);
    return buf;
  }
  return {};
}

// Whether an equality constraint holds free joint j's body (b): a weld or connect between its
// subtree and something outside it (a weld inside the subtree, to its own child, holds nothing:
// outside probe AI).
bool held_by_equality(const mjModel* m, int j) {
  const int b = m->jnt_bodyid[j];
  for (int e = 0; e < m->neq; ++e)
    if ((m->eq_type[e] == mjEQ_CONNECT || m->eq_type[e] == mjEQ_WELD) &&
        is_descendant(m, m->eq_obj1id[e], b) != is_descendant(m, m->eq_obj2id[e], b))
      return true;
  return false;
}

bool has_gravity(const mjModel* m) {
  return !(m->opt.disableflags & mjDSBL_GRAVITY) && mju_norm3(m->opt.gravity) > 0;
}

// The free joints that float: without gravity, held by no weld or connect (held_by_equality) and
// by no force that grows with their displacement (held_by_forces). Under no net load any placement
// of such a body is an equilibrium: equilibrium() checks that none acts and keeps it where it
// starts (outside probe BA: a rod on a free hub in zero gravity, whose free-free modes linearize
// gives, had been refused as free-floating).
std::vector<int> floating_joints(const mjModel* m) {
  std::vector<int> out;
  if (has_gravity(m)) return out;
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_type[j] == mjJNT_FREE && !held_by_equality(m, j) && !held_by_forces(m, j, false)) out.push_back(j);
  return out;
}

// Whether a contact of d touches the subtree of body b.
bool touches(const mjModel* m, const mjData* d, int b) {
  for (int c = 0; c < d->ncon; ++c)
    if (is_descendant(m, m->geom_bodyid[d->contact[c].geom1], b) ||
        is_descendant(m, m->geom_bodyid[d->contact[c].geom2], b))
      return true;
  return false;
}

// A free joint of `loose` (held by no weld, connect or force: only a contact can hold it) whose
// body has fallen from q_start, along gravity, by more than `depth` and touches nothing now: a
// message naming it, empty if none.
std::string fallen_free_body(const mjModel* m, const mjData* d, const std::vector<mjtNum>& q_start,
                             const std::vector<int>& loose, double depth, double elapsed) {
  const double g = mju_norm3(m->opt.gravity);
  for (int j : loose) {
    const int a = m->jnt_qposadr[j], b = m->jnt_bodyid[j];
    double fall = 0.0;
    for (int i = 0; i < 3; ++i) fall += (d->qpos[a + i] - q_start[a + i]) * m->opt.gravity[i] / g;
    if (!(fall > depth) || touches(m, d, b)) continue;
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "'%s' (free joint), held by no weld, connect, spring, rope or servo, has fallen %.3g m below its "
                  "start in %.3g s of relaxation and touches nothing: a free body has no static equilibrium without "
                  "a support",
                  name ? name : "?", fall, elapsed);
    return buf;
  }
  return {};
}

// The joint a dof belongs to, for a message: "hinge joint 'NAME'" (a rod's strain joints are named
// ROD/s<i>/<coordinate>), or the body of an unnamed joint, and the component of a free or ball
// joint's dof.
std::string dof_name(const mjModel* m, int dof) {
  const int j = m->dof_jntid[dof], b = m->jnt_bodyid[j], k = dof - m->jnt_dofadr[j];
  const char* jn = mj_id2name(m, mjOBJ_JOINT, j);
  const char* bn = mj_id2name(m, mjOBJ_BODY, b);
  const int type = m->jnt_type[j];
  const char* kind = type == mjJNT_FREE ? "free" : type == mjJNT_BALL ? "ball" : type == mjJNT_SLIDE ? "slide" : "hinge";
  std::string out = jn && *jn ? std::string(kind) + " joint '" + jn + "'"
                              : std::string(kind) + " joint of body '" + (bn && *bn ? bn : "#" + std::to_string(b)) + "'";
  static const char* axis[] = {"x", "y", "z"};
  if (type == mjJNT_FREE) out += k < 3 ? std::string(", translation along ") + axis[k] : std::string(", rotation about ") + axis[k - 3];
  if (type == mjJNT_BALL) out += std::string(", rotation about ") + axis[k];
  return out;
}

// What to do where the relaxation diverged: it runs the scene's own dynamics (its integrator and
// time step), so what lets a run through lets it through; an equality constraint open at the start
// pulls what it joins together within a few steps (outside probe CJ: a weld 0.3 m open at a
// keyframe broke MuJoCo's constraint solver in the relaxation's eleventh step, "Rank-defficient
// Hessian", and the message said nothing of the cause or the remedy). Leaves qpos at q_start.
// (Not the run's remedies, which name options of a step, not of equilibrium: re-check CK.)
std::string relaxation_divergence_hint(const Scene& s, SceneData& sd, const std::vector<mjtNum>& q_start) {
  char b[240];
  std::snprintf(b, sizeof b,
                " (the relaxation runs the scene's own dynamics, its integrator and <option timestep> of %g s: a "
                "smaller timestep in the model lets it through where the motion outran the step)",
                s.m->opt.timestep);
  std::string hint = b;
  std::copy(q_start.begin(), q_start.end(), sd.d->qpos);
  mju_zero(sd.d->qvel, s.m->nv);
  try {
    forward(s, sd);
    const std::vector<std::string> gaps = open_equalities(s, sd);
    if (!gaps.empty())
      hint += "; at the start " + gaps.front() +
              ", which pulls what it joins together within a few steps: start nearer to it closed (a keyframe)";
  } catch (const std::exception&) {
  }
  return hint;
}

// Dynamic relaxation with kinetic damping from qpos = q_start: the scene's own dynamics, with all
// velocities zeroed whenever the kinetic energy passes a peak; converged when |M qacc| at rest is
// below the tolerance. Contacts, limits and equality constraints take part exactly as in a run.
// It stops early where a free joint of `loose` (equilibrium()'s free bodies that only a contact can
// hold) falls more than ten times the scene's size while touching nothing (the larger of
// mjStatistic::extent and the diagonal of the box around the bodies and geoms at q_start: outside
// probe AR's keyframe put a box 30 m above its floor, beyond ten times the extent at qpos0), and
// names one still falling when it does not settle (outside probe AQ: a box beside a pendulum,
// which its geoms could touch, fell for the whole 30 s, and the message told only that the
// relaxation had not settled). `diverged` tells a step that diverged (or raised a MuJoCo error).
bool relax_once(const Scene& s, SceneData& sd, const std::vector<mjtNum>& q_start, const SceneStaticsOptions& opt,
                const std::vector<int>& loose, SceneStaticsResult& res, bool& diverged) {
  diverged = false;
  mjData* d = sd.d;
  const double t0 = d->time, h = s.m->opt.timestep;
  std::copy(q_start.begin(), q_start.end(), d->qpos);
  mju_zero(d->qvel, s.m->nv);
  double fall_limit = 10.0 * std::max(s.m->stat.extent, 1e-3);
  if (!loose.empty()) {
    fwd_inertia(s, sd, false);  // the poses at q_start
    Vec3 lo = Vec3::Constant(HUGE_VAL), hi = -lo;
    for (int b = 1; b < s.m->nbody; ++b) {
      const Vec3 x(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]);
      lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    }
    for (int g = 0; g < s.m->ngeom; ++g) {
      const Vec3 x(d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]);
      lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    }
    if (lo.allFinite() && hi.allFinite()) fall_limit = std::max(fall_limit, 10.0 * (hi - lo).norm());
  }
  settle_activations(s.m, d);
  res.method = "dynamic relaxation";
  res.iterations = 0;
  res.message.clear();
  const long max_steps = static_cast<long>(std::ceil(opt.relaxation_time / h));
  double ke_prev = 0.0, best = HUGE_VAL, best_time = 0.0;
  VectorXd last_Ma;  // the residual force M qacc at the last rest
  // The residual's scale does not fall below 1e-3 of the start's (as Newton's): where every force
  // vanishes at the equilibrium (no gravity, no load, a constraint open at the start and closed at
  // the end) it fell with the residual, which stayed near 1 (fifty-first session: a rod twisted by
  // a weld opened 0.6 rad at the start, neutral once closed, "did not settle", its |M qacc| at rest
  // 4e-12 N m where the start's forces were 0.1 N m).
  mju_zero(d->qvel, s.m->nv);
  forward(s, sd);
  const double scale_floor = 1e-3 * full_residual(s, sd).scale;
  // the velocities zeroed, the residual there (into res and last_Ma)
  auto at_rest = [&] {
    mju_zero(d->qvel, s.m->nv);
    forward(s, sd);
    FullResidual r = full_residual(s, sd);
    r.scale = std::max(r.scale, scale_floor);
    res.residual = r.force / r.scale;
    res.scale = r.scale;
    last_Ma = r.Ma;
    return r;
  };
  bool converged = false;
  for (long k = 0; k < max_steps && !converged; ++k) {
    const Status status = step_or_abandon(s, sd);
    if (status != Status::Ok) {
      diverged = true;
      res.message = "dynamic relaxation diverged: " + sd.warning + relaxation_divergence_hint(s, sd, q_start);
      break;
    }
    ++res.iterations;
    if (!loose.empty()) {
      if (std::string fallen = fallen_free_body(s.m, d, q_start, loose, fall_limit, (k + 1) * h); !fallen.empty()) {
        res.message = "dynamic relaxation stopped: " + fallen;
        break;
      }
    }
    if (opt.progress && (k & 255) == 0) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "dynamic relaxation, t = %.3g s of at most %g s", (k + 1) * h, opt.relaxation_time);
      opt.progress(buf);
    }
    const double ke = kinetic_energy(s, sd);
    if (ke < ke_prev || ke == 0.0) {  // past a peak (or at rest): stop, and test for equilibrium
      const FullResidual r = at_rest();
      converged = res.residual <= opt.relaxation_tolerance;
      // the residual's progress: the static friction is asked only once it has stopped falling (no
      // gain of 10% for 1 s of simulated time), lest a state still settling be taken; at any level
      // of the residual (outside probe AR: a box on a 20 degree slope with friction 1 crept at
      // 1.7 mm/s with a residual of 1e-2, above the 1e-3 the question had waited for, and the
      // relaxation ran its 30 s)
      const double t = (k + 1) * h;
      if (res.residual < 0.9 * best) best = res.residual, best_time = t;
      if (!converged && d->ncon > 0 && t - best_time > 1.0) {
        if (friction_takes_up(s.m, d, r.Ma, opt.relaxation_tolerance * r.scale)) {
          converged = true;
          char buf[200];
          std::snprintf(buf, sizeof buf, "residual %.3g taken up by the contacts' static friction (MuJoCo's soft friction creeps under load)", res.residual);
          res.message = buf;
        }
      }
      ke_prev = 0.0;
    } else {
      ke_prev = ke;
    }
  }
  d->time = t0;
  mju_zero(d->qvel, s.m->nv);
  if (!converged && res.message.empty()) {
    // no rest at all: the kinetic energy grew from the start to the end (a slow fall along an
    // unstable mode); the residual then is the last state's, at rest
    const bool never_rested = last_Ma.size() == 0 && res.iterations > 0;
    if (never_rested) at_rest();
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "dynamic relaxation did not settle within %g s of simulated time (%s %.3g, target %g; "
                  "SceneStaticsOptions::relaxation_time, the command line's --relaxation-time, allows more)",
                  opt.relaxation_time,
                  never_rested ? "its kinetic energy grew from start to end, still moving; the last state's residual at rest"
                               : "residual",
                  res.residual, opt.relaxation_tolerance);
    res.message = buf;
    // a loose free body below its start, touching nothing (any depth); else where the residual is
    // (the shipped octopus arm: the cylinder it drapes over rocks on the single point of MuJoCo's
    // cylinder-box contact, and the message had not said where the residual was)
    if (const std::string fallen = fallen_free_body(s.m, d, q_start, loose, 0.0, res.iterations * h); !fallen.empty()) {
      res.message += ": " + fallen;
    } else if (last_Ma.size() > 0 && last_Ma.allFinite()) {
      int worst = 0;
      last_Ma.cwiseAbs().maxCoeff(&worst);
      std::snprintf(buf, sizeof buf, "; the residual force |M qacc| at rest, %.3g, is largest (%.3g) on the ",
                    last_Ma.norm(), last_Ma(worst));
      res.message += buf + dof_name(s.m, worst);
    }
  }
  return converged;
}

// MuJoCo's convex collisions (libccd's MPR: a capsule on a cylinder, a box on a cylinder) to
// 1e-12 for the guard's life, and restored after. At MuJoCo's default of 1e-6 the contact points
// move by their tolerance between evaluations: the statics' finite differences, whose steps are of
// that size, read it as stiffness, and the relaxation's residual as force (outside probe AT: a rod
// resting on two cylinders was reported unstable, omega^2 = -3.8e5, after 27605 relaxation steps;
// at 1e-12 it settles in 419 and is stable).
class PreciseCollisions {
 public:
  explicit PreciseCollisions(mjModel* m) : m_(m), tolerance_(m->opt.mpr_tolerance), iterations_(m->opt.mpr_iterations) {
    m->opt.mpr_tolerance = std::min(m->opt.mpr_tolerance, 1e-12);
    m->opt.mpr_iterations = std::max(m->opt.mpr_iterations, 100);
  }
  ~PreciseCollisions() {
    m_->opt.mpr_tolerance = tolerance_;
    m_->opt.mpr_iterations = iterations_;
  }
  PreciseCollisions(const PreciseCollisions&) = delete;
  PreciseCollisions& operator=(const PreciseCollisions&) = delete;

 private:
  mjModel* m_;
  double tolerance_;
  int iterations_;
};

// MuJoCo's joint and tendon damping, zeroed for the guard's life and restored after (the scene's
// model is shared: no other thread may step it meanwhile).
class WithoutJointDamping {
 public:
  explicit WithoutJointDamping(mjModel* m)
      : m_(m), dof_(m->dof_damping, m->dof_damping + m->nv), tendon_(m->tendon_damping, m->tendon_damping + m->ntendon) {
    mju_zero(m->dof_damping, m->nv);
    if (m->ntendon > 0) mju_zero(m->tendon_damping, m->ntendon);
  }
  ~WithoutJointDamping() {
    std::copy(dof_.begin(), dof_.end(), m_->dof_damping);
    std::copy(tendon_.begin(), tendon_.end(), m_->tendon_damping);
  }
  WithoutJointDamping(const WithoutJointDamping&) = delete;
  WithoutJointDamping& operator=(const WithoutJointDamping&) = delete;

 private:
  mjModel* m_;
  std::vector<mjtNum> dof_, tendon_;
};

// The dynamic relaxation (relax_once), without MuJoCo's joint and tendon damping where the scene
// has some: a damper has no part in an equilibrium, and where it overdamps the slow motion the
// kinetic damping waits for, the relaxation crawls (outside probe AR: a box on a soft spring with
// damping 0.5, its sag 49 m, beside a box resting on a floor, had not settled after 30 s of
// simulated time; without the damper it settles in 7 s). A relaxation that diverges without them
// (MuJoCo's Euler treats them implicitly: they can stabilise a stiff spring at the model's step)
// runs again with them. The rods' Kelvin-Voigt viscosity stays: it damps their stiff modes, which
// would otherwise stop the motion at every peak (without it, the repro's buckling leg took 5182
// steps instead of 3145).
bool relax(const Scene& s, SceneData& sd, const std::vector<mjtNum>& q_start, const SceneStaticsOptions& opt,
           const std::vector<int>& loose, SceneStaticsResult& res) {
  bool diverged = false;
  if (has_joint_damping(s.m)) {
    bool converged = false;
    {
      WithoutJointDamping undamped(s.m);
      converged = relax_once(s, sd, q_start, opt, loose, res, diverged);
    }
    if (!diverged) return converged;
    sd.compression = {};
  }
  return relax_once(s, sd, q_start, opt, loose, res, diverged);
}

}  // namespace

double static_force(const Scene& s, SceneData& sd, double lambda, VectorXd& f) {
  const SceneUse use(s);
  StaticProblem p(s, sd);
  return p.force(lambda, f);
}

void tangent_stiffness(const Scene& s, SceneData& sd, double lambda, MatrixXd& Kt) {
  const SceneUse use(s);
  StaticProblem p(s, sd);
  p.stiffness(lambda, Kt);
}

namespace {

// The net load on the first floating body (floating_joints) that has one beyond the tolerance of
// the scene's forces, at rest at the current qpos: a message naming it (such a body accelerates
// for ever), empty if none.
std::string floating_body_pushed(const Scene& s, SceneData& sd, const std::vector<int>& floating, double tolerance,
                                 const char* when) {
  if (floating.empty()) return {};
  const mjModel* m = s.m;
  VectorXd f(m->nv);
  double scale = 0.0;
  {
    StaticProblem p(s, sd);
    scale = p.force(1.0, f);
  }
  std::string out;
  for (const int j : floating) {
    const double load = f.segment(m->jnt_dofadr[j], 6).norm();
    if (!(load > tolerance * scale)) continue;
    const char* name = mj_id2name(m, mjOBJ_BODY, m->jnt_bodyid[j]);
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "a free-floating body has no static equilibrium: '%s' (free joint), held by no weld, connect, "
                  "spring, rope or servo, floats without gravity, but a net load of %.3g (its free joint's "
                  "generalised force, N and N m) acts on it %s",
                  name ? name : "?", load, when);
    out = buf;
    break;
  }
  mju_zero(sd.d->qvel, m->nv);
  forward(s, sd);
  return out;
}

SceneStaticsResult equilibrium_of_held(const Scene& s, SceneData& sd, const SceneStaticsOptions& opt);

}  // namespace

SceneStaticsResult equilibrium(const Scene& s, SceneData& sd, const SceneStaticsOptions& opt) {
  const SceneUse use(s);  // (it changes the mjModel for its whole run: outside probe BW)
  const std::vector<int> floating = floating_joints(s.m);
  SceneStaticsResult res;
  res.message = floating_body_pushed(s, sd, floating, opt.tolerance, "at the start");
  if (!res.message.empty()) return res;
  res = equilibrium_of_held(s, sd, opt);
  if (res.converged) {
    // MuJoCo's contact buffers full at the result: the contacts beyond them are missing from it
    const int before = full_buffer_count(sd.d);
    forward(s, sd);
    if (full_buffer_count(sd.d) > before) {
      res.buffers_full = true;
      res.message += "; MuJoCo's contact buffers are full at this equilibrium: it is the one without the contacts "
                     "beyond them; " + raise_buffers_advice(s.m);
    }
  }
  if (!res.converged || floating.empty()) return res;
  if (std::string why = floating_body_pushed(s, sd, floating, opt.tolerance, "at the equilibrium found"); !why.empty()) {
    res.converged = false;
    res.message = why;
    return res;
  }
  for (const int j : floating) {
    const char* name = mj_id2name(s.m, mjOBJ_BODY, s.m->jnt_bodyid[j]);
    res.message += std::string("; '") + (name ? name : "?") +
                   "' (free joint) floats: without gravity and with no net load on it, any placement of it is an "
                   "equilibrium";
  }
  return res;
}

namespace {

// equilibrium() of a scene whose free bodies are held, fall onto a support, or float (the
// floating ones' net load checked by the caller)
SceneStaticsResult equilibrium_of_held(const Scene& s, SceneData& sd, const SceneStaticsOptions& opt) {
  const PreciseCollisions precise(s.m);
  const mjModel* m = s.m;
  mjData* d = sd.d;
  SceneStaticsResult res;
  // A free body has an equilibrium only where something holds it: an equality constraint on its
  // subtree, a force that grows with its displacement (held_by_forces), or, under gravity, a
  // contact (a box on a table); otherwise it falls for ever (a swimmer). (Outside probe AH: a box
  // hanging from a `connect` on its free joint was refused.) Without gravity such a body floats,
  // and is in equilibrium anywhere while no net load acts on it (floating_joints).
  const bool gravity = has_gravity(m);
  std::vector<int> loose;  // free joints only a contact can hold (relax watches them fall)
  for (int j = 0; j < m->njnt; ++j) {
    if (m->jnt_type[j] != mjJNT_FREE || !gravity) continue;
    const int b = m->jnt_bodyid[j];
    if (held_by_equality(m, j) || held_by_forces(m, j, gravity)) continue;
    bool held = false;
    for (int g = 0; g < m->ngeom && !held; ++g)
      held = s.may_collide && (m->geom_contype[g] || m->geom_conaffinity[g]) && is_descendant(m, m->geom_bodyid[g], b);
    if (held) {
      loose.push_back(j);
      continue;
    }
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    res.message = std::string("a free-floating body has no static equilibrium: '") + (name ? name : "?") +
                  "' (free joint) is held by no weld, connect, spring, rope or servo and touches nothing";
    mju_zero(d->qvel, m->nv);
    forward(s, sd);
    return res;
  }
  const std::vector<mjtNum> q_start(d->qpos, d->qpos + m->nq);
  UnstableState unstable;
  std::string on_contacts;  // why the smooth search cannot succeed, if it cannot
  {
    StaticProblem p(s, sd, opt.progress);
    if (!loose.empty()) {
      VectorXd f(m->nv);
      const double scale = p.force(1.0, f);
      on_contacts = weight_on_contacts_alone(m, loose, f, scale);
    }
    if (on_contacts.empty()) {
      res.converged = solve_smooth(p, s, sd, opt, res, unstable);
      if (!res.converged && unstable.found()) res.converged = switch_branch(p, s, sd, opt, res, unstable);
    }
  }
  // the smooth solution ignores constraint forces: check that none is needed there, and that the
  // way there does not pass through a support
  double where = 0.0;
  const std::vector<mjtNum> q_smooth(d->qpos, d->qpos + m->nq);
  const bool through = res.converged && path_runs_into_contact(s, sd, q_start, q_smooth, where);
  double where_open = 0.0;
  const bool opens = res.converged && !through && path_opens_equality(s, sd, q_start, q_smooth, where_open);
  mju_zero(d->qvel, m->nv);
  forward(s, sd);
  const FullResidual r = full_residual(s, sd);
  res.constraint_rows = load_bearing_rows(d);
  // (rows that carry load with no generalised force: outside probe BU's inextensible rod pushed 1 cm
  // short by a weld at its tip, straight, whose tip cannot move along the rod at first order, had
  // been reported a converged stable column, where it buckles)
  const double loaded_force = std::max(1e-8, 100 * opt.tolerance) * r.scale;
  bool axial = false;
  for (int i = 0; i < d->nefc && !axial; ++i)
    axial = d->efc_type[i] == mjCNSTR_EQUALITY && std::abs(d->efc_force[i]) > loaded_force;
  const bool constrained = res.constraint_rows > 0 && r.loaded && (r.constraint > loaded_force || axial);
  if (res.converged && !constrained && !through && !opens) return res;
  const std::string why =
      !on_contacts.empty() ? on_contacts
      : constrained ? std::to_string(res.constraint_rows) +
                        " constraint rows (contacts, limits, equalities) carry load at the smooth equilibrium, which "
                        "ignores them"
      : through ? "the way from the start to the smooth equilibrium, which ignores contacts, runs into a contact (at " +
                      std::to_string(static_cast<int>(std::lround(100 * where))) + "% of the way)"
      : opens ? "the way from the start to the smooth equilibrium, which ignores equality constraints, opens one (at " +
                    std::to_string(static_cast<int>(std::lround(100 * where_open))) + "% of the way)"
              // (outside probe CE: "Newton failed" read like an error for a starfish resting on a floor)
              : "the smooth equilibrium search (Newton, contacts ignored) found none (" + res.message + ")";
  res.converged = false;
  if (!opt.relaxation) {
    res.message = why;
    return res;
  }
  // Newton's last converged load step, reported if the relaxation fails; not where its way there
  // passed through a contact or an equality constraint (the start then)
  const std::vector<mjtNum> q_newton = through || opens ? q_start : std::vector<mjtNum>(d->qpos, d->qpos + m->nq);
  // The relaxation starts from the user's state; if that state is itself an unstable equilibrium
  // under the full loads (a straight column above its buckling load: the symmetric start's
  // dynamics leave it only as fast as round-off grows, a heavy column at 1.25 times its load not
  // within 30 s), from there moved a little along its unstable mode, to fall onto the stable branch
  // (the buckled column). A relaxation that settles on an unstable equilibrium all the same starts
  // again from it so moved. (For a while in the twenty-seventh session it started from the unstable
  // state Newton's continuation had met, wherever the user's start was: outside probe AG's rod
  // leaning on a hinge was sent from its upright state, by the sign of an eigenvector, onto a wall
  // on the other side instead of the floor on its own side, and a stretched soft rod diverged.)
  // Where constraint rows carry load at the start (a rod twisted between two welds, a rod standing
  // on its end), its stability is that with them held rigid (stable_equilibrium).
  std::vector<mjtNum> q_relax = q_start;
  std::string from;
  if (opt.stable) {
    std::copy(q_start.begin(), q_start.end(), d->qpos);
    mju_zero(d->qvel, m->nv);
    forward(s, sd);
    const bool rows = load_bearing_rows(d) > 0;
    StaticProblem p(s, sd, opt.progress);
    VectorXd f(m->nv), mode;
    double w2 = 0.0, residual = 0.0;
    if (rows) {
      const FullResidual r = full_residual(s, sd);
      residual = r.force / r.scale;
    } else {
      const double scale = p.force(1.0, f);
      residual = f.norm() / scale;
    }
    if (residual <= opt.relaxation_tolerance && !stable_equilibrium(p, s, sd, 1.0, w2, &mode, rows)) {
      q_relax = along_mode(m, q_start, mode);
      from = ", started from the initial state, an unstable equilibrium, moved along its unstable mode";
    }
  }
  for (int attempt = 0;; ++attempt) {
    sd.compression = {};
    const int full_before = full_buffer_count(d);
    res.converged = relax(s, sd, q_relax, opt, loose, res);
    const int dropped = full_buffer_count(d) - full_before;
    res.message = (res.message.empty() ? "" : res.message + "; ") + "relaxation used because " + why + from;
    // MuJoCo's contact buffers full on the way: the likely reason a relaxation did not settle (bodies
    // sinking through what should hold them). (Fifty-first session: a 2 m rod of 64 sections lying
    // on a floor, 128 capsules under MuJoCo's default nconmax of 100, ran the 30 s without settling
    // and without a word of the buffers.)
    if (!res.converged && dropped > 0) {
      res.message = "MuJoCo's contact buffers were full " + std::to_string(dropped) +
                    " times during the relaxation, which dropped contacts (bodies sink through what should hold them): " +
                    raise_buffers_advice(m) + ". How: " + res.message;
    }
    if (!res.converged) {
      // a relaxation that diverged or did not settle leaves a state of no meaning (probe O: inverted
      // sections after a blow-up): report the last equilibrium Newton found instead
      if (const std::string c = collapse_warning(s, sd); !c.empty()) res.message += "; during the relaxation " + c;
      std::copy(q_newton.begin(), q_newton.end(), d->qpos);
      res.message += q_newton == q_start ? "; the positions reported are the start's"
                                         : "; the positions reported are Newton's last converged load step";
      // the continuation stopped where the equilibria begin to flutter, which no relaxation settles
      // (outside probe BT: Beck's column past its flutter load, an exact straight equilibrium, read
      // "no static equilibrium")
      if (unstable.found() && unstable.flutter.rate > 0 && res.flutter_rate == 0.0) {
        res.flutter_rate = unstable.flutter.rate;
        res.flutter_hz = unstable.flutter.hz;
        char b[240];
        std::snprintf(b, sizeof b,
                      "the equilibria the load continuation found flutter (at load factor %s an oscillation of %.4g Hz "
                      "grows at %.4g 1/s, fed by non-conservative loads; more damping or less load holds it); ",
                      cosserat::load_factor_text(unstable.lambda).c_str(), unstable.flutter.hz, unstable.flutter.rate);
        res.message = b + res.message;
      }
    }
    forward(s, sd);
    res.constraint_rows = load_bearing_rows(d);
    // relaxation settles where the motion stops, which a symmetric start can do on an unstable
    // equilibrium (a straight column above its buckling load, a rod standing on its end): without
    // constraint rows carrying load its stability is the smooth one's, with them that of the rows
    // held rigid (stable_equilibrium)
    bool rows = res.constraint_rows > 0;
    // Newton from the state the relaxation settled in, where no constraint row carries load (the
    // smooth problem): the relaxation's tolerance is relative to the scene's largest forces, and a
    // light part beside a heavy one stops short (outside probe AO: a pendulum beside a 10 t body on
    // a spring settled 30 degrees from hanging). Kept where it converges without the way to it
    // running into a contact or opening an equality.
    if (res.converged && !rows && m->nv > 0) {
      const std::vector<mjtNum> q_relaxed(d->qpos, d->qpos + m->nq);
      StaticProblem pp(s, sd, opt.progress);
      pp.phase = "Newton from the state the relaxation settled in";
      SceneStaticsResult polished = res;
      polished.iterations = 0;
      double where = 0.0;
      bool keep = newton(pp, 1.0, opt, polished) && polished.residual < res.residual;
      if (keep) {
        const std::vector<mjtNum> q_polished(d->qpos, d->qpos + m->nq);
        keep = !path_runs_into_contact(s, sd, q_relaxed, q_polished, where) &&
               !path_opens_equality(s, sd, q_relaxed, q_polished, where);
        std::copy(q_polished.begin(), q_polished.end(), d->qpos);
      }
      if (keep) {
        res.residual = polished.residual;
        res.scale = polished.scale;
        res.message += "; then " + std::to_string(polished.iterations) + " Newton iterations from the state it settled in";
      } else {
        std::copy(q_relaxed.begin(), q_relaxed.end(), d->qpos);
      }
      mju_zero(d->qvel, m->nv);
      forward(s, sd);
      res.constraint_rows = load_bearing_rows(d);
      rows = res.constraint_rows > 0;
    }
    if (!res.converged || !opt.stable) return res;
    StaticProblem p(s, sd, opt.progress);
    double w2 = 0.0;
    VectorXd mode;
    cosserat::GrowthModes flutter;
    const bool stable = stable_equilibrium(p, s, sd, 1.0, w2, &mode, rows, &flutter);
    mju_zero(d->qvel, m->nv);
    forward(s, sd);
    if (stable) return res;
    if (attempt == 0) {
      q_relax = along_mode(m, std::vector<mjtNum>(d->qpos, d->qpos + m->nq), mode);
      from = ", started again from the unstable state the first relaxation settled in, moved along its unstable mode";
      continue;
    }
    res.converged = false;
    res.omega2_min = w2;
    res.flutter_rate = flutter.rate;
    res.flutter_hz = flutter.hz;
    // the verdict first, then how it was reached (outside probe BL: "NOT converged ... (residual
    // 1.50e-14)" led a 600-character line that came to the instability at its end)
    char w2_text[160];
    if (flutter.rate > 0)
      std::snprintf(w2_text, sizeof w2_text, "flutter: an oscillation of %.4g Hz grows at %.4g 1/s, fed by non-conservative loads", flutter.hz, flutter.rate);
    else
      std::snprintf(w2_text, sizeof w2_text, "omega^2_min = %.6g 1/s^2: the scene would fall away from it", w2);
    res.message = std::string("the search settled in an unstable equilibrium (") + w2_text +
                  ") and found no stable one; start from a perturbed state, e.g. a keyframe" +
                  (flutter.rate > 0 ? ", or damp the scene more" : "") + ". How: " + res.message;
    return res;
  }
}

}  // namespace

SceneLinearization linearize(const Scene& s, SceneData& sd, const SceneLinearizeOptions& opt) {
  const SceneUse use(s);
  const PreciseCollisions precise(s.m);
  const mjModel* m = s.m;
  const int n = m->nv, nu = m->nu;
  SceneLinearization L;
  if (n == 0) {  // nothing moves
    L.M = L.D = L.Kt = MatrixXd(0, 0);
    L.Bu = L.B = MatrixXd(0, nu);
    L.A = MatrixXd(0, 0);
    return L;
  }
  StaticProblem p(s, sd, opt.progress);
  p.stiffness(1.0, L.Kt, &L.Kt_noise);
  p.damping(L.D);  // leaves the stages evaluated at the current qpos, at rest
  L.M.resize(n, n);
  std::vector<mjtNum> full(static_cast<size_t>(n) * n);
  mj_fullM(m, full.data(), sd.d->qM);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) L.M(i, j) = full[static_cast<size_t>(i) * n + j];
  L.Bu = p.actuation_matrix();
  MatrixXd Cq, Cv;
  if (m->na > 0) {
    p.activation_terms(L.Fa, L.Bd, L.Ga, L.Gu, Cq, Cv);
    if (Cq.size()) {
      // a control law's dependence on the state reaches the filters' and muscles' forces through
      // their activations (S: d act_steady / d ctrl), not at once as the second-order form has it
      MatrixXd S = MatrixXd::Zero(m->na, nu);
      for (int k = 0; k < m->na; ++k) {
        const int a = nu - m->na + k, t = m->actuator_dyntype[a];
        if (t == mjDYN_FILTER || t == mjDYN_MUSCLE) S(k, a) = 1.0;
      }
      L.dKt = L.Fa * S * Cq;
      L.dD = L.Fa * S * Cv;
      L.Gq = L.Gu * Cq;
      L.Gv = L.Gu * Cv;
    }
  }

  if (opt.rigid_equalities || opt.rigid_contacts) {
    // the equality constraints that act (and with rigid_contacts the contacts and limits), held
    // rigid: coordinates y with dq = N y, J N = 0, and the stiffness of the loads they carry
    // (StaticProblem::held_loads); their own damping and their response to the controls act along
    // J only, which N' removes
    MatrixXd J, Kc, Kc_noise;
    try {
      p.held_loads(opt.rigid_contacts ? Held::Loaded : Held::Equalities, J, Kc, Kc_noise);
    } catch (const std::runtime_error&) {
      throw std::runtime_error(
          "linearize: a contact held rigid comes and goes under the finite differences' perturbations (1e-6): it "
          "is at the edge of its margin, or one of the pair of contacts two parallel capsules make, which is one at "
          "any tilt; leave the contacts out, or start from a state where it is closed");
    }
    if (J.rows() > 0) {
      const MatrixXd N = free_directions(J);
      L.Kt = N.transpose() * (L.Kt + Kc) * N;
      L.Kt_noise += Kc_noise;  // (in the coordinates of qpos's tangent space, as the basis maps them)
      L.Kt_held = N.transpose() * Kc * N;
      L.D = N.transpose() * L.D * N;
      L.M = N.transpose() * L.M * N;
      L.Bu = N.transpose() * L.Bu;
      if (m->na > 0) {
        L.Fa = N.transpose() * L.Fa;
        L.Bd = N.transpose() * L.Bd;
        if (L.dKt.size()) L.dKt = N.transpose() * L.dKt * N, L.dD = N.transpose() * L.dD * N;
        if (L.Gq.size()) L.Gq = L.Gq * N, L.Gv = L.Gv * N;
      }
      L.basis = N;
      L.constraint_rows = static_cast<int>(J.rows());
    }
    mju_zero(sd.d->qvel, n);
    forward(s, sd);
  }

  // At a state that is no equilibrium (linearize at a state of the user's, --at-start), the
  // acceleration qacc0 the unbalanced forces drive at rest also turns with the mass matrix:
  // d qacc / dq = -M^-1 (Kt + d(M(q) qacc0)/dq), the second term in A (dMa). Not where constraint
  // rows are held (the constrained motion's own curvature term is not in A: the command line warns).
  // (Fifty-first session: outside probe CF's A had lacked it, exact only at an equilibrium.)
  if (L.constraint_rows == 0) {
    mju_zero(sd.d->qvel, n);
    forward(s, sd);
    const VectorXd a0 = Eigen::Map<const VectorXd>(sd.d->qacc, n);
    VectorXd Ma(n);
    mj_mulM(m, sd.d, Ma.data(), a0.data());
    VectorXd f;
    const double scale = p.force(1.0, f);
    if (Ma.allFinite() && Ma.norm() > 1e-9 * scale) {
      p.mass_motion(a0, L.dMa);
      mju_zero(sd.d->qvel, n);
      forward(s, sd);
    }
  }

  // (linearize counts as equilibrium's check does: outside probe AS's box hung by a connect had its
  // neutral yaw at omega^2 = -1.3e-10 counted unstable, and scenes with their contacts left out
  // their bodies' free motions at -5e-8)
  L.neutral_omega2 = slowest_fall(m);
  if (opt.progress) opt.progress("modes: the eigenproblem of " + std::to_string(L.M.rows()) + " dofs");
  state_space(L);
  return L;
}

std::vector<std::string> open_equalities(const Scene& s, const SceneData& sd, const std::vector<double>& displacement) {
  const mjModel* m = s.m;
  const mjData* d = sd.d;
  const std::vector<RowKey> keys = row_keys(d);
  std::vector<double> gap(m->neq, 0.0);
  std::vector<char> angle(m->neq, 0);
  const double absolute = 1e-3 * std::max(m->stat.extent, 1e-3);
  // per constraint: the length its gap is measured against, and the displacement in the trees it
  // joins (a connect's or weld's: their rows are lengths; a joint equality's may be a curvature)
  std::vector<double> length(m->neq, absolute), moved(m->neq, 0.0);
  if (static_cast<int>(displacement.size()) == m->nbody)
    for (int e = 0; e < m->neq; ++e) {
      if (m->eq_type[e] != mjEQ_CONNECT && m->eq_type[e] != mjEQ_WELD) continue;
      const int r1 = m->body_rootid[m->eq_obj1id[e]], r2 = m->body_rootid[m->eq_obj2id[e]];
      for (int b = 1; b < m->nbody; ++b)
        if (m->body_rootid[b] == r1 || m->body_rootid[b] == r2) moved[e] = std::max(moved[e], displacement[b]);
      // (not below 1e-6 of the extent: re-check CK's box welded at rest, whose joined bodies moved
      // only by the weld's own give, was warned of a gap of 4e-9 m, "100%" of that)
      if (moved[e] > 0 && 5e-3 * moved[e] < absolute) length[e] = std::max(5e-3 * moved[e], 1e-3 * absolute);
    }
  for (int i = 0; i < d->nefc; ++i) {
    if (d->efc_type[i] != mjCNSTR_EQUALITY) continue;
    const int e = d->efc_id[i];
    const bool rotation = (m->eq_type[e] == mjEQ_WELD && keys[i].row >= 3) ||
                          (m->eq_type[e] == mjEQ_JOINT && m->jnt_type[m->eq_obj1id[e]] != mjJNT_SLIDE);
    // (a weld's rotation rows hold the sine of half the angle: the angle, to first order, is twice)
    const double v = (rotation && m->eq_type[e] == mjEQ_WELD ? 2.0 : 1.0) * std::abs(d->efc_pos[i]) / (rotation ? 1e-3 : length[e]);
    if (v > gap[e]) gap[e] = v, angle[e] = rotation;
  }
  std::vector<std::string> out;
  for (int e = 0; e < m->neq; ++e) {
    if (gap[e] <= 1.0) continue;
    const char* name = mj_id2name(m, mjOBJ_EQUALITY, e);
    const char* type = m->eq_type[e] == mjEQ_CONNECT ? "connect"
                       : m->eq_type[e] == mjEQ_WELD  ? "weld"
                       : m->eq_type[e] == mjEQ_JOINT ? "joint"
                       : m->eq_type[e] == mjEQ_TENDON ? "tendon"
                                                      : "distance";
    char buf[400];
    std::snprintf(buf, sizeof buf, "equality constraint %s%s%s (%s) is open by %.3g %s", name && *name ? "'" : "#",
                  name && *name ? name : std::to_string(e).c_str(), name && *name ? "'" : "", type,
                  gap[e] * (angle[e] ? 1e-3 : length[e]),
                  angle[e] ? "rad" : "(MuJoCo's measure of its violation: metres, or the strain's units on strain joints)");
    std::string line = buf;
    if (length[e] < absolute && !angle[e]) {
      std::snprintf(buf, sizeof buf, ", %.2g%% of the largest displacement from the start of what it joins (%.3g m)",
                    100.0 * gap[e] * length[e] / moved[e], moved[e]);
      line += buf;
    }
    out.push_back(line);
  }
  return out;
}

ModeShape mode_shape(const Scene& s, SceneData& sd, const SceneLinearization& L, int k, int points) {
  const mjModel* m = s.m;
  mjData* d = sd.d;
  if (k < 0 || k >= L.modes.cols()) throw std::invalid_argument("mode_shape: no mode " + std::to_string(k));
  ModeShape shape;
  shape.omega2 = L.omega2(k);
  shape.frequency_hz = L.frequencies_hz(k);
  shape.dq = L.basis.size() ? VectorXd(L.basis * L.modes.col(k)) : VectorXd(L.modes.col(k));
  const std::vector<mjtNum> q0(d->qpos, d->qpos + m->nq);
  const double big = shape.dq.cwiseAbs().maxCoeff();
  if (!(big > 0)) throw std::invalid_argument("mode_shape: mode " + std::to_string(k) + " is zero");
  const double eps = 1e-6 / big;
  struct Poses {
    std::vector<std::vector<Vec3>> rods;
    std::vector<Vec3> sites, bodies;
  };
  auto poses_at = [&](double a) {
    std::copy(q0.begin(), q0.end(), d->qpos);
    mj_integratePos(m, d->qpos, shape.dq.data(), a);
    mju_zero(d->qvel, m->nv);
    fwd_position(s, sd, Need::SmoothStaticForces);
    Poses p;
    for (size_t r = 0; r < s.rods.size(); ++r) p.rods.push_back(rod_centerline(s, sd, static_cast<int>(r), points));
    for (int i = 0; i < m->nsite; ++i) p.sites.push_back(Eigen::Map<const Vec3>(d->site_xpos + 3 * i));
    for (int b = 0; b < m->nbody; ++b) p.bodies.push_back(Eigen::Map<const Vec3>(d->xpos + 3 * b));
    return p;
  };
  const Poses plus = poses_at(eps), minus = poses_at(-eps);
  std::copy(q0.begin(), q0.end(), d->qpos);
  forward(s, sd);
  auto diff = [&](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    std::vector<Vec3> v(a.size());
    for (size_t i = 0; i < a.size(); ++i) v[i] = (a[i] - b[i]) / (2 * eps);
    return v;
  };
  for (size_t r = 0; r < plus.rods.size(); ++r) shape.rods.push_back(diff(plus.rods[r], minus.rods[r]));
  shape.sites = diff(plus.sites, minus.sites);
  shape.bodies = diff(plus.bodies, minus.bodies);
  // scale: the largest displacement to 1, its largest component positive (dq's largest entry where
  // nothing moves, e.g. a rod's pure twist). Of the rods' centrelines and the named sites and
  // bodies, what the command line's JSON lists (outside probe AI: an unnamed body at a rod's tip
  // set the scale, and the JSON's largest displacement was 0.49)
  Vec3 largest = Vec3::Zero();
  auto consider = [&](const Vec3& x) {
    if (x.norm() > largest.norm()) largest = x;
  };
  for (const auto& r : shape.rods)
    for (const Vec3& x : r) consider(x);
  for (int i = 0; i < m->nsite; ++i)
    if (const char* n = mj_id2name(m, mjOBJ_SITE, i); n && *n) consider(shape.sites[i]);
  for (int b = 1; b < m->nbody; ++b)
    if (const char* n = mj_id2name(m, mjOBJ_BODY, b); n && *n && !generated_body(s, b)) consider(shape.bodies[b]);
  int i = 0;
  double scale = 0.0;
  if (largest.norm() > 1e-9 * big) {
    largest.cwiseAbs().maxCoeff(&i);
    scale = (largest(i) < 0 ? -1.0 : 1.0) / largest.norm();
    shape.displaces = true;
  } else {
    shape.dq.cwiseAbs().maxCoeff(&i);
    scale = 1.0 / shape.dq(i);
  }
  shape.dq *= scale;
  for (auto* v : {&shape.sites, &shape.bodies})
    for (Vec3& x : *v) x *= scale;
  for (auto& r : shape.rods)
    for (Vec3& x : r) x *= scale;
  return shape;
}

}  // namespace cosserat::mj
