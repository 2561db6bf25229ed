// Static equilibrium and linearisation of a coupled scene (the MuJoCo counterpart of the core's
// statics.hpp and linearize.hpp).
//
// Equilibrium solves, at rest (qvel = 0), for qpos such that the smooth generalised force vanishes:
//     f(q) = qfrc_passive + qfrc_actuator + qfrc_applied + J^T xfrc_applied - qfrc_bias = 0,
// i.e. MuJoCo's qfrc_smooth, with the rods' elastic forces in qfrc_passive and their gravity in
// qfrc_bias. Newton's method with a central finite-difference tangent stiffness in the tangent
// space of qpos (ball joints are perturbed with mj_integratePos), a backtracking line search, and
// load continuation on a factor lambda that scales gravity, controls and applied forces together.
// A free body held by no weld, connect or force that grows with its displacement has no static
// equilibrium under gravity but on a support; without gravity it floats, in equilibrium anywhere
// under no net load, and is kept where it starts (a net load on it is refused, named).
//
// The smooth residual ignores constraint forces. When contacts, limits or equality constraints
// carry load at the smooth solution (or the smooth solve fails while constraint rows exist), the
// solver falls back to dynamic relaxation: the scene's own dynamics from the initial state with
// kinetic damping (velocities are zeroed at every peak of kinetic energy) until the full residual
// |M qacc| at rest (smooth plus constraint forces) is small. The result says which method
// produced it.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "linearize.hpp"
#include "scene.hpp"

namespace cosserat::mj {

struct SceneStaticsOptions {
  int max_iterations = 50;       // Newton iterations per load step
  double tolerance = 1e-10;      // on |f| relative to the force scales (see SceneStaticsResult::residual)
  int max_load_halvings = 12;    // continuation: smallest load increment 2^-12
  bool relaxation = true;        // fall back to dynamic relaxation when constraints carry load
  double relaxation_tolerance = 1e-6;  // the relaxation's (looser) target on the full residual
  double relaxation_time = 30.0;       // [s] of simulated time before the relaxation gives up
  // follow the stable branch: a load step is accepted only if its equilibrium is stable (no
  // negative eigenvalue of Kt x = omega^2 M x); otherwise the increment is halved, and if the
  // continuation stalls, the relaxation (which only settles in stable states) takes over
  bool stable = true;
  // called now and then with where the solve is (Newton's load step, the relaxation's time): a
  // long solve's progress line (the cosserat tool's `equilibrium` and `linearize`)
  std::function<void(const std::string&)> progress;
};

struct SceneStaticsResult {
  bool converged = false;
  std::string method = "newton";  // "newton" or "dynamic relaxation"
  int iterations = 0;     // Newton iterations in total (relaxation: time steps)
  int load_steps = 0;     // continuation steps taken (1: solved directly)
  // |f| / scale at the end, or the largest over the scene's trees (the world's children with what
  // hangs from them) of |f| on the tree's dofs over the tree's own scale if larger (relaxation:
  // |M qacc| / scale)
  double residual = 0.0;
  double scale = 0.0;     // force scale: max(|qfrc_passive|, |loads|, |qfrc_constraint|)
  int constraint_rows = 0;  // active constraint rows (contacts, limits, equalities) at the end
  double omega2_min = 0.0;  // Newton with opt.stable: smallest eigenvalue of Kt x = omega^2 M x [1/s^2]
  // where the loads turn with the structure (Kt not symmetric) and the equilibrium found flutters:
  // the growth rate [1/s] and frequency [Hz] of its fastest-growing oscillation (0: none)
  double flutter_rate = 0.0, flutter_hz = 0.0;
  int unstable_steps_refused = 0;  // load steps refused because their equilibrium was unstable
  // MuJoCo's contact buffers (<size nconmax njmax>) full at the equilibrium found: it is the one
  // without the contacts beyond them (the message says so)
  bool buffers_full = false;
  std::string message;
};

// The load continuation scales s.m->opt.gravity while solving (restored on return): do not share
// the Scene with another thread during these calls.
//
// Solves for sd.d->qpos in place; qvel = 0 and the stages are evaluated at the result (positions
// in xpos/site_xpos are current). Actuators with filter or muscle dynamics are put at their steady
// state act = ctrl. On failure qpos holds the last converged load step (Newton; the start when it
// made none), also after a dynamic relaxation that failed, and the message says so.
SceneStaticsResult equilibrium(const Scene& s, SceneData& sd, const SceneStaticsOptions& opt = {});

// The smooth generalised force f(q) at rest under load factor lambda (gravity, ctrl, qfrc_applied
// and xfrc_applied scaled by lambda, restored afterwards). Returns the force scale.
double static_force(const Scene& s, SceneData& sd, double lambda, Eigen::VectorXd& f);

// Tangent stiffness Kt = -df/dq (nv x nv, tangent space) by central differences at lambda.
void tangent_stiffness(const Scene& s, SceneData& sd, double lambda, Eigen::MatrixXd& Kt);

struct SceneLinearizeOptions {
  // Hold the equality constraints that act (welds, connects, joint and tendon couplings) rigid:
  // the linearisation is then in coordinates y of the motions they leave free, dq = basis y, with
  // the stiffness of the loads they carry (a weld's end moment on a twisted rod, a connect's end
  // load on a column), the frequencies those of a clamped or pinned end. False: they are left out
  // (the frequencies without them).
  bool rigid_equalities = true;
  // Hold every contact rigid as a pin (all its rows: its point held to the other geom, with its
  // friction), and the limits that act, with the equalities: the frequencies of a rod resting on
  // its supports, as long as they hold it (a contact that would lift off is held all the same).
  // False (the default): contacts and limits are left out (the frequencies without them).
  bool rigid_contacts = false;
  // called now and then with where the linearisation is (the stiffness's finite-difference columns,
  // the eigenproblem): a long one's progress line (the cosserat tool's `linearize`)
  std::function<void(const std::string&)> progress;
};

// Linearisation at the current qpos (call equilibrium() first), qvel = 0 and the current ctrl.
// It sets d->qvel to zero (the linearisation is at rest) and leaves the stages evaluated there: to
// continue a run afterwards, save qvel before and restore it (outside probe BE):
//   M dqacc + D dqvel + Kt dq = Bu dctrl,   x = [dq; dqvel],   x_dot = A x + B dctrl.
// M is the patched mass matrix (rods included), D the rods' Kelvin-Voigt damping plus joint and
// tendon damping, Kt the tangent stiffness. With a control callback (mjcb_control, called at every
// force evaluation), D and Kt hold its dependence on the state (the closed loop), and Bu =
// d qfrc_actuator / d ctrl at its controls: the input matrix of a perturbation added to them.
// Actuators with activation dynamics (filters, integrators, muscles: MuJoCo's act) add their
// activations to the state, x = [dq; dqvel; dact] (L.Fa, L.Ga, ... in linearize.hpp): A and B are
// then (2 nv + na) square and (2 nv + na) x nu, with the dynamics of act and a control callback's
// dependence on the state through them; M, D, Kt and Bu keep the activations at their steady state.
// Constraint forces: equality constraints, contacts and limits as opt says (with rows held rigid,
// every matrix is in the coordinates y, dq = L.basis y, and L.constraint_rows counts the rows).
// Throws std::runtime_error where a contact held rigid comes and goes under the finite
// differences' perturbations (one at the edge of its margin).
using SceneLinearization = cosserat::Linearization;  // the core's: A, B, M, D, Kt, Bu, frequencies
SceneLinearization linearize(const Scene& s, SceneData& sd, const SceneLinearizeOptions& opt = {});

// The equality constraints that are open at the current state (after forward()): a row's
// violation (MuJoCo's efc_pos: for a weld's position rows, its anchor's offset, which includes the
// rotation times the distance from the world origin) beyond 1e-3 of the model's extent, or 1e-3 rad
// for a weld's rotation and a joint equality on hinges or balls. MuJoCo's constraints are soft (solref, solimp, and the inverse
// weights of what they join: a light rod's weld can open by centimetres under load); linearize
// holds them rigid where they are. One line per constraint, naming it and the gap. With
// `displacement` (per body, nbody: how far it and its sites moved from where the analysis started),
// also a connect's or weld's gap beyond 5e-3 of the largest displacement in the kinematic trees it
// joins: what a gap does to a result scales with the deformation, not the scene (outside probe BY:
// a parallel robot's welds opened 0.5 mm under a load that moved its platform 53 mm, which put the
// platform 4.5% off and its rotation 6x off without a word; a rod pushed 1 cm short by a weld
// ended 8 mm short).
std::vector<std::string> open_equalities(const Scene& s, const SceneData& sd,
                                         const std::vector<double>& displacement = {});

// The shape of mode k of L (from linearize at the current qpos; k in the order of L.omega2): the
// direction dq = basis x_k in the tangent space of qpos, and the displacements it gives every
// rod's centreline (`points` samples from base to tip), every site and every body (by id; the
// world body's is 0), by central differences of the poses. Scaled so that the largest
// displacement of the rods' centrelines and the named sites and bodies is 1 (dimensionless: the
// shape, not an amplitude), its largest component positive; where the mode moves none of them (a
// rod's pure twist), so that dq's largest entry is 1 (displaces false).
struct ModeShape {
  double omega2 = 0.0, frequency_hz = 0.0;
  bool displaces = false;
  Eigen::VectorXd dq;
  std::vector<std::vector<Vec3>> rods;
  std::vector<Vec3> sites, bodies;
};
// (k outside 0 .. L.modes.cols() - 1 throws std::invalid_argument)
ModeShape mode_shape(const Scene& s, SceneData& sd, const SceneLinearization& L, int k, int points = 17);

}  // namespace cosserat::mj
