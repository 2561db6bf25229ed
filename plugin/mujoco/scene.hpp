// A MuJoCo 2.2.2 scene with Cosserat rods, stepped as one system (DESIGN.md section 6).
//
// Scene is the compiled model (MuJoCo model plus one core rod model per <cosserat>); SceneData
// holds the state (mjData plus one core Data per rod). The API mirrors MuJoCo's:
//   auto scene = load_scene("arm.xml");        // throws LoadError("file:line: ...")
//   SceneData data(*scene);
//   while (...) step(*scene, data);             // or forward(*scene, data)
// Strain coordinates live in MuJoCo's qpos/qvel (one slide joint per strain coordinate, see
// mjcf.hpp for the names), so actuators, sensors, equality constraints and the constraint solver
// see one system.
#pragma once

#include <atomic>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <mujoco/mujoco.h>

#include "integrators.hpp"
#include "mjcf.hpp"
#include "model.hpp"
#include "scene_fluid.hpp"

namespace cosserat::mj {

// One rod inside the MuJoCo model.
struct RodBinding {
  RodDecl decl;
  cosserat::Model model;          // the rod alone; its base frame is the "<rod>/base" body
  int base_body = -1;             // MuJoCo body id of "<rod>/base"
  std::vector<int> proxy_body;    // per section
  std::vector<std::vector<int>> helper_body;  // per section: bodies above the proxy holding dofs
                                              // beyond MuJoCo's 6 per body (same frame as proxy)
  int dof0 = 0, qpos0 = 0;        // the rod's contiguous block in qvel / qpos (nv = model.nv)
  int below_begin = 0, below_end = 0;  // MuJoCo bodies hanging below the last proxy: [begin, end)
  std::vector<int> geom_id;       // capsules (decl.geoms order)
  std::vector<int> site_id;       // sites (decl.sites order)
  // geoms and sites on the proxies and helpers that are not the rod's own (none in models the
  // pre-processor writes; kept general): placed from their body's pose as MuJoCo places them
  std::vector<int> other_geom_id, other_site_id;
  // Capsules and sites on rigid sections sit at a constant pose relative to the frame their
  // section starts at (node `anchor`, -1: the rod's base): kept here, not recomputed each step.
  struct Fixed {
    bool fixed = false;
    int anchor = -1;
    SE3 rel;            // pose in the anchor frame
    double half = 0.0;  // capsules: half-length of the chord
  };
  std::vector<Fixed> geom_fixed;  // per capsule
  // per capsule: where the kinematics keep the pose of its end (X_end) already, a node's frame
  // (cosserat::Data::g) or a kept step midpoint (Data::g_mid, Model::keep_midpoint_pose); node -1:
  // neither (rod_pose's partial step). Set at load.
  struct PoseSource {
    int node = -1;
    bool mid = false;
  };
  std::vector<PoseSource> geom_end;
  // per capsule on a section with strain dofs that can collide (its contype or conaffinity, or an
  // explicit <pair>; set at load): the user's margin and gap. MuJoCo detects contacts on the
  // capsule, a chord of the centre line; each step widens its margin and gap by the chord's sag
  // (widen_contact_margins, scene.cpp), so that contacts are found around the centre line, and the
  // coupling then measures their distance on the centre line and applies the user's margin and gap
  // to it (patch_contact_distances).
  std::vector<char> geom_sagging;
  std::vector<double> geom_margin0, geom_gap0;
  std::vector<Fixed> site_fixed;  // per site
  // per site (set at load): -1 unless the site is a spatial tendon's path point off a rigid
  // section. Its centre-line pose and section Jacobian come from one partial step per evaluation
  // (cosserat::rod_pose_and_jacobian; the kinematics keep them in SceneData::RodScratch for the
  // tendon patch), shared by the path points at the same abscissa and section (a cable-driven
  // arm's cables pass each spacer disk at one abscissa): site_point[k] is the first such site,
  // whose scratch entries hold them (k itself for the first).
  std::vector<int> site_point;
  bool extensible = false;        // a section with a free axial strain (SceneData::compression)
  // Whether anything reads the cdof_dot of the rod's dofs (patch point 4; set at load): a body with
  // mass or a joint below the rod (mj_rne accelerates it with them), another rod hanging below it
  // (its base acceleration), a sensor of the acceleration stage, or a connect or weld on a body of
  // the rod or below it (its rows' velocity product: patch_equality_references). Otherwise the step does not patch
  // d->cdof_dot of the rod's dofs: mj_rne would multiply them by the massless proxies' zero
  // inertias only (and Scene::velocity_skip may skip the rod's bodies in those passes altogether).
  // A mass given at run time to a body below the rod that had none sets it again at the next
  // evaluation (refresh_velocity_skips; mutable for that).
  mutable bool cdof_dot_read = true;
  // whether the bodies below the rod were massless (and no rod hung below it) when cdof_dot_read
  // was last decided: the ones refresh_velocity_skips watches
  mutable bool massless_below = false;
  // Whether the bodies below the rod (RodBinding::below_begin..below_end) are a rigid payload whose
  // inertia and weight the rod's solver carries (set with cdof_dot_read): they have mass but no
  // dofs, no rod hangs below, no sensor reads velocities or accelerations, and no connect or weld
  // names a body of the rod or below it. Their composite
  // inertia, taken each evaluation from MuJoCo's body masses, inertias and poses, is hung on the
  // rod's node payload_node (cosserat::Data::attached_inertia), and MuJoCo's composite-inertia and
  // bias passes leave them out (Scene::payload_body, velocity_skip): a tip weight then costs a 6 x 6
  // inertia more in the rod's recursions instead of MuJoCo's O(nv^2) composite walk over the
  // proxies and the rod's cdof_dot. Their d->cvel is set from the rod's tip twist.
  mutable bool payload = false;
  // the tip node, or the root of the fixed subtree (a rigid last section) holding it (set at load)
  int payload_node = -1;
};

// Rod capsules' geom_size and geom_rbound follow the state (their chords): a Scene steps one
// SceneData at a time (use one Scene per thread).
struct Scene {
  Scene() = default;
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;
  ~Scene();

  mjModel* m = nullptr;
  // the thread stepping, evaluating or solving the statics of this scene now (SceneUse): two
  // threads at once would write into one mjModel, and each read the other's; the second is refused
  // with std::logic_error (outside probe AB: it had given wrong results without an error)
  mutable std::atomic<std::thread::id> user{};
  std::vector<RodBinding> rods;   // ordered by base body id: outer rods before rods hanging on them
  std::vector<int> geom_rod;      // per MuJoCo geom: rod index or -1
  std::vector<int> geom_index;    // per MuJoCo geom: index into that rod's geoms
  // per MuJoCo site on a rod's proxies: rod index, else -1 (also the sites on a rod's base body,
  // "<rod>/base": rigid with that body, MuJoCo moves them right)
  std::vector<int> site_rod;
  std::vector<int> site_index;    // per MuJoCo site: index into that rod's sites
  std::vector<int> site_section;  // per MuJoCo site: section (proxy) of the rod carrying it
  // per MuJoCo dof: 1 for a rod's strain dofs, whose pivots factor_mass keeps below mjMINVAL
  std::vector<char> dof_strain;
  // per MuJoCo body: 1 for the bodies a rod places (its proxies and helpers, and the bodies below
  // it), which the step's kinematics leaves to the rod's patch instead of computing them twice
  std::vector<char> body_by_rod;
  // per MuJoCo body: the rod and section whose cross-section it rides with (riding_frame): a
  // section's proxy, or a body below a rod's last proxy (the innermost rod for nested rods); -1 for
  // the rest. Set at load.
  std::vector<int> riding_rod, riding_section;
  // per MuJoCo body below a rod: the last dof between the rod's last proxy and it (its own or its
  // nearest ancestor's, as first_ancestor_dof), where it turns or slides on joints of its own
  // relative to the rod's tip; -1 for a body fixed to the tip, and for the rest. Set at load.
  std::vector<int> riding_dof;
  // explicit <pair> of each geom pair that has one (key geom1 * ngeom + geom2, both orders; sorted
  // by key for a binary search): patch_contact_distances reads the pair's margin
  std::vector<std::pair<long long, int>> pair_by_geoms;
  // the capsules of RodBinding::geom_sagging (MuJoCo geom ids), the explicit pairs with one of them
  // and those pairs' own margins and gaps (set at load)
  std::vector<int> sagging_geoms, sagging_pairs;
  std::vector<double> pair_margin0, pair_gap0;
  double o_margin0 = 0.0;  // <option o_margin> as loaded (MuJoCo's margin of every contact under <flag override>)
  // whether two sagging capsules of different bodies can meet (their filters, or a pair): MuJoCo
  // takes the larger of two geoms' margins, so each capsule's then carries the largest sag of the
  // step besides its own (widen_contact_margins)
  bool sagging_capsules_meet = false;
  // per MuJoCo body: 1 for the bodies of rods whose cdof_dot nothing reads (RodBinding::
  // cdof_dot_read: massless, with a massless subtree), when no sensor reads velocities or
  // accelerations: the step's com-velocity and bias passes (com_velocity_except, rne_except) skip
  // them, leaving their d->cvel and d->cdof_dot uncomputed. Set again by the evaluation that finds
  // a mass given to a body below such a rod since (refresh_velocity_skips: a payload's mass
  // randomised at run time; outside probe AB found its weight left out when this was set at load only).
  mutable std::vector<char> velocity_skip;
  // per MuJoCo body: 1 for the bodies of a rod's payload (RodBinding::payload), whose inertia the
  // rod's recursions carry: MuJoCo's composite-inertia pass (crb_skipping_massless) leaves them out
  mutable std::vector<char> payload_body;
  // velocity sensors (velocimeter, gyro, framelinvel, frameangvel) whose object or reference frame
  // is a rod site off a rigid section (set at load): MuJoCo moves such a site rigidly with its
  // section's proxy, so the step evaluates them again with the site's material velocity
  std::vector<int> rod_velocity_sensors;
  // likewise the acceleration sensors (accelerometer, framelinacc, frameangacc) of such sites
  std::vector<int> rod_acceleration_sensors;
  // framequat sensors whose object or reference frame is such a site or a rod capsule: MuJoCo takes
  // their orientation from the parent body's quaternion (the section end's), the step from the
  // frame the rod gives them (site_xmat, geom_xmat)
  std::vector<int> rod_quat_sensors;
  // touch sensors on a rod's sites: the rod is one body to them (MuJoCo counts the contacts of the
  // site's proxy only, one section's capsules); rangefinders on a rod's sites: their ray leaves
  // the rod's capsules it starts in (MuJoCo excludes the proxy's own, and a site at a section's
  // end, or the rod's base site, starts inside the next section's capsule): (sensor, rod)
  // (the rod's base site too: outside probe AN, it had read 0, MuJoCo counting its base body's
  // contacts, which has no geoms)
  std::vector<std::pair<int, int>> rod_touch_sensors;
  std::vector<std::pair<int, int>> rod_rangefinders;
  // force and torque sensors, when the model has rods: MuJoCo's cfrc_int counts rigid bodies only
  // (the rods' mass lives in their solver), so the step adds each rod's inverse dynamics to it and
  // evaluates these sensors again
  std::vector<int> force_sensors;
  // subtreecom, subtreelinvel and subtreeangmom sensors of bodies with a rod in their subtree:
  // MuJoCo's subtree quantities count rigid bodies only, the step adds the rods to these sensors
  // (MuJoCo's own d->subtree_* arrays keep the rigid bodies: they are its com-based reference)
  std::vector<int> subtree_sensors;
  // actuators with a site (refsite) or slider-crank transmission through a rod site off a rigid
  // section, and with an adhesion (body) transmission when the scene has rods (set at load):
  // MuJoCo's moment arms move such a site or touching capsule point rigidly with its section's
  // proxy, the step corrects them to the material point's Jacobian
  std::vector<int> rod_site_actuators;
  // cameras and lights following (trackcom) or looking at (targetbodycom) the centre of mass of a
  // subtree with rods: placed from the centre of mass with the rods (MuJoCo's counts rigid bodies)
  std::vector<int> com_cameras, com_lights;
  std::string path;
  // the loader's warnings about values that load but are likely mistakes (Preprocessed::warnings:
  // "file:line: <element>: ..."); the command-line tool prints them on stderr at load
  std::vector<std::string> load_warnings;
  // false when no two geoms of the model can ever touch (scene_may_collide, at load): the step then
  // skips MuJoCo's collision detection, whose broad phase otherwise costs a tenth of a step on a
  // rod in free space. The collision filters (geom contype/conaffinity, <pair>, <exclude>; the
  // disabling flags stay live) are read at load: a program that edits them afterwards must set
  // this again (mj::scene_may_collide), and may_have_events.
  bool may_collide = true;
  // false when the model can have no constraint rows but equalities (scene_may_have_events, at
  // load; a program that edits limits, friction loss or the collision filters sets it again with
  // may_collide): the midpoint rule then skips the forward at each step's end state that looks
  // for a contact or limit arising or parting in the step's second half (midpoint_step).
  bool may_have_events = true;
  // step()'s integrator: the model's <custom><text name="cosserat:integrator" data="NAME"/> if it
  // has one, else RK4 for <option integrator="RK4">, Implicit for <option integrator="implicit">,
  // Implicit with rods, Euler without
  Integrator integrator = Integrator::Implicit;
  // Newton iterations of the implicit and trapezoidal steps. With N > 0 the step is the fully
  // implicit theta method (backward Euler, or the trapezoidal rule, with every force at the end of
  // the step), solved by up to N simplified-Newton corrections to the relative velocity tolerance
  // newton_tol; a step that does not converge is redone as two half steps (down to h/64). 1: one
  // correction after the linearised solve, without a convergence test or splitting. 0: one
  // linearised solve (stiffness and damping implicit, the rest explicit). -1 (default): 10 for
  // the trapezoidal rule (linearised, it is only a W-method whose undamped stiff modes slowly
  // blow up under the explicit nonlinear terms), 0 for implicit (linearised backward Euler damps
  // them), 10 for the generalized-alpha method and the midpoint rule, which have no linearised form
  // here (0 counts as 1 for them). See step().
  int newton_iterations = -1;
  double newton_tol = 1e-6;
  // Anderson acceleration of the Newton corrections: the last `newton_memory` (at most 4)
  // corrections and their changes extrapolate the next iterate (a multisecant update of the frozen
  // matrix, which misses the configuration dependence of the mass matrix and the geometric
  // stiffness). 0: plain simplified Newton.
  int newton_memory = 3;
  // true: the iteration matrix of newton_step (trapezoidal, genalpha, implicit with corrections)
  // is factorised again at the first iterate (q+, v+), whose M and velocity derivatives (actuators,
  // fluid) are the residual's, instead of kept from the step's start. On the undamped cantilever at
  // 5 ms that is a third fewer plain corrections (a fifth with Anderson acceleration), on the soft
  // string a third fewer and a tenth of the split steps. Not the default: where the start matrix's
  // iteration fails and splits the step (heavy tip masses at 2-10 ms: up to 550 corrections per step),
  // the refreshed one converges at the full step, where the trapezoidal rule and the generalized
  // alpha method gain energy (bench_stress: a tip of 10x the rod's mass stable at 1 ms instead of
  // 10 ms). The midpoint rule (which keeps its energy however it converges) takes it at its first
  // midpoint state, where no constraint row acts there or at the start (outside probe AP's rod
  // released bent and twisted, 1 ms: 838 split steps in 500 without, none with, a seventh of the
  // wall time); with constraint rows it keeps its start matrix. Adaptive substeps (step_tol > 0)
  // refresh it whatever this says: they control the step instead of the Newton failures.
  bool newton_refresh = false;
  // > 0: adaptive substeps (implicit, trapezoidal, genalpha, midpoint; see step()). Each step of
  // m->opt.timestep h is taken as substeps of h / 2^k (k <= kMaxSubstepLevel), refined where the
  // substep's mean acceleration abar = (v+ - v) / h_s changed from the previous substep's by more
  // than
  //   h_s |abar - abar_prev|_M <= step_tol (|v+|_M + h_s |abar|_M),   |x|_M = sqrt(x' M x)
  // (the kinetic-energy norm, which weighs dofs of any unit by their inertia: a substep that
  // under-resolves how the motion changes) or where the Newton iteration failed, and coarsened
  // again where the change fell below step_tol / 8; k carries over to the next step (the first
  // substep after construction, reset() or a state set between steps has no previous substep to
  // compare with: only its Newton convergence is checked). A substep of
  // h / 2^kMaxSubstepLevel is kept even above the tolerance (counted in adapt_stats.kept_at_min).
  // 0 (default): fixed steps (the Newton schemes split a step only when their iteration fails).
  // A model sets it with <custom><numeric name="cosserat:step_tol" data="TOL"/>.
  double step_tol = 0.0;
  double rho_inf = 0.8;  // generalized alpha: spectral radius at infinite frequency, in [0, 1]
  int newton_for(Integrator method) const {
    if (method == Integrator::Euler || method == Integrator::RK4 || method == Integrator::Rosenbrock) return 0;
    if (newton_iterations >= 0) return newton_iterations;
    return method == Integrator::Trapezoidal || method == Integrator::GeneralizedAlpha || method == Integrator::Midpoint
               ? 10
               : 0;
  }
  SceneFluid fluid;               // low-Reynolds fluid (scene_fluid.hpp); inactive without viscosity
};

// Scene::step_tol: the finest adaptive substep is h / 2^kMaxSubstepLevel.
constexpr int kMaxSubstepLevel = 10;
// Whether `method` takes adaptive substeps under Scene::step_tol (euler, rk4 and rosenbrock keep fixed steps).
inline bool takes_substeps(Integrator method) {
  return method != Integrator::Euler && method != Integrator::RK4 && method != Integrator::Rosenbrock;
}

// A Scene and its SceneData can be neither copied nor moved (they hold MuJoCo's model and data and
// point into each other): keep them where they are made, or in std::unique_ptr (load_scene returns
// one; std::make_unique<SceneData>(scene) for a vector of states). A SceneData steps with the Scene
// it was made from only (step and forward throw std::invalid_argument otherwise), and must not
// outlive it. Read its state after forward(): a fresh SceneData's mjData holds zeros until then.
struct SceneData {
  explicit SceneData(const Scene& s);
  SceneData(const SceneData&) = delete;
  SceneData& operator=(const SceneData&) = delete;
  ~SceneData();

  mjData* d = nullptr;
  std::vector<cosserat::Data> rod;  // per rod
  Status status = Status::Ok;
  std::string warning;              // last divergence message (remedies: divergence_hint)
  // The end time of the last step that succeeded (-inf: none since construction or reset()): a
  // step from an earlier time starts a new run, dropping the last one's compression and divergence
  // records as reset() does.
  double last_step_end = -std::numeric_limits<double>::infinity();
  // The start time of the step in which MuJoCo's contact or constraint buffers first filled in
  // this run (divergence_hint: whether that came before the state blew up); NaN: not yet.
  double buffers_full_at = std::numeric_limits<double>::quiet_NaN();
  double run_start = std::numeric_limits<double>::quiet_NaN();  // the first step's start time in this run
  // The smallest axial stretch p_x of any extensible rod section seen by the steps since
  // construction, reset() or a step back in time (cosserat::min_axial_stretch of each step's last
  // forward evaluation), with the step's start time, the rod and its section (local index); kept
  // from the first inversion (stretch <= 0) on. A section compressed towards zero length is outside what the
  // linear constitutive law describes.
  // A step that diverges leaves no state to measure: the smallest stretch of its forward evaluations
  // (stages, iterates, substeps) is recorded then, with `diverged_step` set, where it is a collapse
  // and none was recorded before (a section crushed by a load no step resists and one crushed by
  // an iteration diverging look the same there: collapse_warning and divergence_hint say both).
  struct Compression {
    double stretch = std::numeric_limits<double>::infinity();
    double time = 0.0;
    int rod = -1, section = -1;
    bool diverged_step = false;
  } compression;
  Compression step_compression;  // the current step's forward evaluations so far (inside step())
  // the last forward skipped M's factorisation and the accelerations (Need::Forces without
  // constraints, Need::StaticForces): d->qfrc_smooth holds the forces, d->qacc, d->qacc_smooth
  // and d->qLD are stale (and after Need::StaticForces d->qM too)
  bool forces_only = false;
  // in_step: inside step(). step_sensors_done: the start state's sensors are in d->sensordata, and the step's further forward
  // evaluations (stages, iterates, substeps) skip the sensors, as mj_step's RK4 stages do
  // (mj_forwardSkip with skipsensor): after a step, sensordata holds the start state's values,
  // MuJoCo's convention, whatever the integrator.
  bool in_step = false, step_sensors_done = false;
  // per MuJoCo geom: the chord's sag bound of a sagging capsule at the last kinematics (else 0)
  std::vector<double> geom_sag;
  // scratch (sized once)
  std::vector<mjtNum> tmp_nv, qacc_tmp;
  // the midpoint rule's springs whose energy is not quadratic: energy at the step's start and end,
  // power at the midpoint, one entry per joint then per tendon (midpoint_step)
  std::vector<double> spring_V0, spring_V1, spring_P, spring_w0, spring_w1;
  // A copy of the state (qpos, qvel, act, act_dot, time), sized by the constructor.
  struct SavedState {
    std::vector<mjtNum> q0, v0, act0, act_dot0;
    double t0 = 0.0;
    void size(const mjModel* m) {
      q0.assign(m->nq, 0);
      v0.assign(m->nv, 0);
      act0.assign(m->na, 0);
      act_dot0.assign(m->na, 0);
    }
  };
  SavedState step_start;  // the state step() started from (restored when the step diverges)
  // and its constraint solver's warm start, restored with it when the step diverges (outside probe
  // BE: left at the diverged step's 1e17-1e75)
  std::vector<mjtNum> step_start_warmstart;
  // the Scene this SceneData was made for: step() and forward() refuse another (outside probe BE:
  // a SceneData of one model stepped with another's Scene wrote past a heap buffer)
  const Scene* owner = nullptr;
  // set when mjcb_control threw inside the current step(): the exception is the application's and
  // leaves the step (with the step's start state), rather than counting as a failed correction
  bool callback_threw = false;
  // the 4 stages of RK4 and of the Rosenbrock-W method: kq, kv, ka hold one row of nv (na) per stage
  std::vector<mjtNum> rk_q0, rk_v0, rk_a0, rk_kq, rk_kv, rk_ka, rk_dx;
  std::vector<mjtNum> ros_M0, ros_sq, ros_sv, ros_rhs, ros_ja;  // Rosenbrock-W: M at the step's start, sums
  struct RodScratch {
    std::vector<int> anc;  // MuJoCo dofs above the rod's base, nearest first
    Mat6X C;               // their base-frame columns (6 x anc.size())
    VecX Kv;
    VecX tau;  // scratch of the rod's inverse dynamics for cfrc_int (nv)
    // per site k with RodBinding::site_point[k] == k: the centre-line pose at its abscissa, the
    // section Jacobian there and the pose relative to the section start (cosserat::section_jacobian's
    // J and g_start_X), from this evaluation's kinematics
    std::vector<SE3> site_center;
    std::vector<Mat6X> site_J;
    std::vector<SE3> site_g_start;
    // per section: a section Jacobian and its rate at some abscissa (6 x the section's ndof: sized
    // here, so that points on sections of different sizes reallocate nothing), scratch of the
    // contact, tendon, sensor and actuator patches
    mutable std::vector<Mat6X> section_J, section_Jdot;
  };
  std::vector<RodScratch> scratch;  // per rod
  // the implicit step's factor (A = M + theta h D + theta^2 h^2 K, MuJoCo's qLD layout), and the
  // diagonal of K outside the rods it was assembled with (hinge and slide joints' springs and
  // position gains of actuators on them; zero elsewhere)
  std::vector<mjtNum> A_LD, A_LDiagInv, joint_K;
  // K's outer-product terms outside the rods that A was assembled with: tendon springs k J' J and
  // position gains of actuators on tendons (-dF/dlength) moment moment', each a copy of its row
  // (nv) at the factorisation with its coefficient (K_nrows of at most ntendon + nu)
  std::vector<mjtNum> K_rows, K_row_coef;
  int K_nrows = 0;
  // A's terms c u u' whose dofs lie on two branches of the tree (a tendon tying two arms), which
  // qM's pattern cannot hold: A = A_tree + U C U', solved by the Woodbury identity with
  // Z = A_tree^-1 U and the Cholesky factor of S = C^-1 + U' Z (W_nrows rows of nv: a tendon's or
  // actuator's damping and spring in one row, and the held constraint rows that tie two branches,
  // grown on demand for contacts up to nv more rows; solve_implicit)
  std::vector<mjtNum> W_rows, W_coef, W_Z, W_S, W_t;
  int W_nrows = 0;
  std::vector<int> tree_nz;  // scratch of add_outer_in_tree (nv)
  // The constraint rows the Newton schemes' iteration matrix holds (add_constraint_terms: rows in
  // MuJoCo's quadratic state at the matrix's evaluation, on one branch of the tree), frozen with
  // it: row r has D = frozen_D[r], its coefficient in the matrix frozen_c[r] (D (1 + h B + h^2 K I))
  // and the entries frozen_val at dofs frozen_dof, from frozen_begin[r] to frozen_begin[r + 1]
  // (deepest dof first). frozen_row: scratch (nv). frozen_across[r]: the row ties two branches
  // (an equality row closing a loop; under the Newton schemes also a contact row, a rod pressing a
  // free object): its term is one of the Woodbury rows W_rows, its dofs in increasing order.
  std::vector<mjtNum> frozen_D, frozen_c, frozen_val, frozen_row;
  std::vector<mjtNum> frozen_kI;  // D K I of each row (the linearised step's right-hand side)
  std::vector<int> frozen_begin, frozen_dof;
  std::vector<char> frozen_across;
  // The tendon Jacobian in rows of nv (ntendon x nv) of a scene with rods where MuJoCo keeps ten_J
  // compressed (sparse Jacobians: jacobian="sparse", or "auto" from nv = 60 on), as patch_tendons leaves it: the
  // coupling's dense reads go through tendon_jacobian_row(). ten_J_mark: scratch, the pattern.
  std::vector<mjtNum> ten_J_rows;
  std::vector<char> ten_J_mark;
  // scratch of tendons_by_wrenches (scene.cpp): a wrench per body (nbody x 6) and the bodies on
  // the chains a tendon's pattern spans (nbody)
  std::vector<mjtNum> ten_wrench;
  std::vector<char> ten_chain;
  struct NewtonScratch : SavedState {  // the step's start state, and:
    std::vector<mjtNum> f0, A0, A, r, y, delta;
    // generalized alpha: the end acceleration A0 carries over to the next step if it starts from
    // the state this one ended with
    bool carry_valid = false;
    bool saved = false;  // the start state is saved (newton_step_split resets it before each step)
    bool stopped = false;  // the step's corrections stopped, non-finite or grown tenfold (Iterate::Stop)
    std::vector<mjtNum> q_end, v_end;
    double t_end = 0.0;
    // Anderson acceleration: the previous iterate and correction, and the last differences of
    // iterates and corrections (columns of nv, ring buffers of Scene::newton_memory columns)
    std::vector<mjtNum> x_prev, F_prev, dX, dF;
    // the start state's non-smooth constraint pattern, and an iterate's (constraint_pattern)
    std::vector<int> pattern0, pattern;
  } newton;
  // Scene::step_tol > 0: the adaptive substeps' state. The substep's start (restored when it is
  // rejected), the last accepted substep's mean acceleration and the state it ended in (the
  // history is used only if the next step starts there), and the level k of substeps h / 2^k.
  struct Adaptive : SavedState {  // the substep's start state, and:
    std::vector<mjtNum> a_prev, q_end, v_end;
    double t_end = 0.0;
    bool valid = false;
    int level = 0;
  } adapt;
  struct AdaptiveStats {  // totals since construction (Scene::step_tol > 0)
    long steps = 0;       // steps of m->opt.timestep
    long substeps = 0;    // accepted substeps
    long rejected = 0;    // substeps redone as two halves (error or Newton failure)
    long kept_at_min = 0; // substeps of h / 2^kMaxSubstepLevel kept above the tolerance or unconverged
    int finest = 0;       // the largest level k used
  } adapt_stats;
  // The step whose MuJoCo constraint model the split and adaptive substeps of a step keep (forward
  // evaluates the constraint rows with m->opt.timestep set to it): MuJoCo's refsafe raises every
  // solref time constant to at least twice the step, so that a substep would otherwise see harder
  // contacts, limits and equalities than the step it is part of. 0: m->opt.timestep.
  double constraint_timestep = 0.0;
  struct NewtonStats {  // totals since construction (Scene::newton_iterations > 0)
    long iterations = 0;   // corrections (each one forward evaluation)
    long splits = 0;       // steps redone as two half steps
    long unconverged = 0;  // steps of h/64 kept without convergence
    long linearised = 0;   // ... of them taken as linearised backward Euler steps (corrections that stopped)
    long events = 0;       // steps taken as linearised backward Euler steps because a contact, limit or
                           // friction loss changed state within them (constraint_pattern)
  } newton_stats;
  // fluid (scene_fluid.hpp): damping in qM's sparse layout (nM), its force, body columns
  std::vector<mjtNum> fluid_qD, fluid_f;
  Mat6X fluid_cols;
};

// Scene::user for the scope of a step, an evaluation, or a statics solve (which change the
// mjModel for their whole run: gravity scaled, dampers off): taken by the first call on a thread,
// kept through its nested calls, released at its end; a call from another thread meanwhile throws
// std::logic_error.
class SceneUse {
 public:
  explicit SceneUse(const Scene& s);
  ~SceneUse();
  SceneUse(const SceneUse&) = delete;
  SceneUse& operator=(const SceneUse&) = delete;

 private:
  const Scene& s_;
  bool taken_ = false;
};

// The warning for such a collapse (rod, section, stretch, time), or "" when none happened.
std::string collapse_warning(const Scene& s, const SceneData& sd);

// What to try after step() returned Diverged under `method` (SceneData::warning says what
// happened): the integrator's remedy, led by a section collapse, MuJoCo's full contact buffers or
// its sparse solver's small pivots where those came first. `Vocabulary` names the remedies as a
// program sets them (m->opt.timestep, Integrator::Implicit, Scene::newton_iterations) or as the
// command line's options (--timestep, --integrator implicit, --newton).
enum class Vocabulary { Cpp, CommandLine };
// How many times MuJoCo's contact or constraint buffers were full (its warning counters since the
// last reset), and the advice for it: raise <size nconmax njmax>, naming their values.
int full_buffer_count(const mjData* d);
std::string raise_buffers_advice(const mjModel* m);
std::string divergence_hint(const Scene& s, const SceneData& sd, Integrator method,
                            Vocabulary words = Vocabulary::Cpp);

// Whether any two geoms of m can ever touch (Scene::may_collide).
bool scene_may_collide(const mjModel* m);
// Whether m can ever have constraint rows other than equalities (contacts where may_collide, joint
// or tendon limits, friction loss): the rows whose changes within a step are events for the
// Newton schemes (Scene::may_have_events).
bool scene_may_have_events(const mjModel* m, bool may_collide);

// Loads an MJCF file with <cosserat> elements (or the text `xml`, read as if it were the file
// `path`: relative asset paths and messages use it). Throws LoadError on bad input.
// Fluid: the plugin takes over a scene's fluid at load (m->opt.viscosity then reads 0, and the
// rods' drag is set from the load's viscosity): to change the viscosity, load the model again;
// setting m->opt.viscosity afterwards turns MuJoCo's own fluid on for the rigid bodies beside
// the plugin's (outside probe BE).
std::unique_ptr<Scene> load_scene(const std::string& path);
std::unique_ptr<Scene> load_scene_string(const std::string& xml, const std::string& path);

// What a forward evaluation must leave in mjData.
//   Acceleration: everything MuJoCo's mj_forward computes, d->qacc = M^-1 (forces) included.
//   Forces: the implicit steps need the forces only (their right-hand side is M qacc = qfrc_smooth
//     + qfrc_constraint). When the scene then has no constraint rows (nefc = 0) and no sensor of the
//     acceleration stage, the factorisation of M and the solves for qacc_smooth and qacc are
//     skipped: d->qLD, d->qacc_smooth and d->qacc are not computed (SceneData::forces_only).
//     With constraints the constraint solver needs M's factor and nothing is skipped.
//   StaticForces: the static solver's finite differences need qfrc_smooth at rest only, after
//     fwd_position, fwd_velocity, mj_fwdActuation and smooth_forces: the mass matrix (d->qM, d->crb,
//     the rods' M) is not assembled either, constraints or not (SceneData::forces_only).
//   SmoothStaticForces: StaticForces without collision detection (d->ncon = 0): qfrc_smooth does not
//     depend on the contacts, and the smooth static problem ignores them (its tangent stiffness
//     takes 2 nv of these evaluations; a 384-dof tree with 60 contact rows spent most of its
//     equilibrium in mj_collision and the contact rows).
enum class Need { Acceleration, Forces, StaticForces, SmoothStaticForces };

// Whether Integrator::Implicit (without Newton corrections) steps `s` with MuJoCo's own mj_implicit,
// bit for bit mj_step's (a scene without rods and without the plugin's fluid: Coriolis implicit,
// joint springs and servos' position gains explicit), rather than the rods' linearised backward
// Euler (implicit_step: stiffness implicit, Coriolis explicit).
bool implicit_is_mujocos(const Scene& s);

// Whether some joint or tendon of m has a damper (dof_damping, tendon_damping > 0), whatever
// <flag passive> says.
bool has_joint_damping(const mjModel* m);

// Row t of the tendon Jacobian dL_t/dq (nv values, the rod-site corrections included) after
// forward(), in either of MuJoCo's layouts of d->ten_J (dense rows, or compressed where its
// Jacobians are sparse). Null for a scene without rods in the compressed layout: nothing there
// reads dense rows, and the step does not unpack them (d->ten_J is MuJoCo's own).
const mjtNum* tendon_jacobian_row(const Scene& s, const SceneData& sd, int t);

// The step's tendon stage, before the rod-site corrections: MuJoCo's mj_tendon outputs (lengths,
// path points, d->ten_J in MuJoCo's layout for the proxies' rigid Jacobians). In a scene with rods
// whose tendons are all spatial through sites and pulleys (tendons_of_sites_only) they are summed
// as wrenches up the tree, equal to mj_tendon's to rounding and cheaper; elsewhere mj_tendon.
void scene_tendons(const Scene& s, SceneData& sd);
bool tendons_of_sites_only(const mjModel* m);

// Staged MuJoCo pipeline with the rod patches: position, velocity, actuation, acceleration,
// constraint solve. With Need::Acceleration it leaves d->qacc as MuJoCo's forward would. MuJoCo's
// control callback (mjcb_control) is called before the actuation, as mj_forward calls it. Like
// mj_forward it rewrites the constraint solver's warm start (and the rod capsules' sizes follow
// the state): a forward between steps (to log) can change the next steps of a scene with contacts
// by the solver's tolerance, which chaotic contact motion then amplifies (outside probe BE).
// Velocities of rod points: MuJoCo's mj_objectVelocity on a rod site reads its section's proxy
// body, whose d->cvel the step leaves uncomputed where nothing reads it (zero); rod_frame_velocity,
// or a velocimeter or framelinvel/frameangvel sensor on the site, gives the material point's.
void forward(const Scene& s, SceneData& sd, Need need = Need::Acceleration);
// One time step with s.integrator (or `method`). Returns Diverged (and restores the state) when
// the state goes non-finite. Euler and Implicit treat the fluid's damping implicitly (as joint
// damping); with the plugin's fluid inactive, Euler is MuJoCo's mj_Euler. Implicit also treats
// the rods' stiffness and damping and the velocity dependence of actuators on hinge and slide
// joints implicitly (linearised backward Euler); on a scene without rods and with the plugin's
// fluid inactive, Implicit without Newton corrections is MuJoCo's own implicit integrator
// (mj_implicit: joint damping and the velocity derivatives of the passive, actuator and bias
// forces implicit), as mj_step runs it.
// Every forward evaluation of a step calls mjcb_control (and mjcb_passive), at the evaluation's
// time: RK4 and Rosenbrock at their stage times, the Newton schemes at each iterate. An exception
// leaving the step (one the control callback throws, a MuJoCo error through a throwing
// mju_user_error handler that splitting the step did not avoid) leaves the step's start state. After a step,
// d->sensordata holds the sensors of the step's start state (mj_step's convention; the further
// evaluations skip the sensors); qacc, the contacts and the constraint rows are those of the
// step's last evaluation. Call forward() for the end state's.
Status step(const Scene& s, SceneData& sd);
Status step(const Scene& s, SceneData& sd, Integrator method);
// qpos = qpos0, qvel = 0, time = 0, and MuJoCo's mj_resetData.
void reset(const Scene& s, SceneData& sd);
// For an application whose mju_user_error handler throws: after a MuJoCo error raised (and
// unwound) inside step, the state goes back to the step's start, MuJoCo's stack is released, and
// the step counts as diverged (SceneData::status, warning: `reason` and the step's time).
void abandon_step(SceneData& sd, const std::string& reason);

// Energies of the whole scene (after forward): rods (core) plus MuJoCo's rigid bodies.
struct SceneEnergy {
  double kinetic = 0, gravity = 0, elastic = 0;
  // the part of `kinetic` that moves the centre of mass, |P|^2 / 2M (Koenig; P the scene's
  // momentum, M the mass of its bodies and rods), where everything that moves hangs from free
  // joints (0 otherwise): in a scene moving as a whole, energy no exchange within it touches
  double translational = 0;
  double total() const { return kinetic + gravity + elastic; }
};
SceneEnergy energy(const Scene& s, SceneData& sd);

// Total spatial momentum of the scene [angular about the world origin; linear], world axes, after
// forward: MuJoCo's rigid bodies plus the rods (the core's, with their bases' motion).
Vec6 momentum(const Scene& s, const SceneData& sd);

// Rod shapes, after forward (rod: index in Scene::rods; rod_index finds it by name, -1 if none;
// an index out of range throws std::out_of_range; X is clamped to [0, L], the base's or the tip's
// frame beyond them):
int rod_index(const Scene& s, const std::string& name);
// Whether body b is one the loader generated for a rod (its base or a section's proxy) rather than
// one of the model's own bodies.
bool generated_body(const Scene& s, int b);
// sampled centreline: n points from base to tip (world frame)
std::vector<Vec3> rod_centerline(const Scene& s, const SceneData& sd, int rod, int n);
// world pose of the cross-section at abscissa X (x axis: the tangent)
SE3 rod_frame(const Scene& s, const SceneData& sd, int rod, double X);
// velocity of that cross-section, world axes, in mj_objectVelocity's layout (flg_local = 0):
// [angular velocity; linear velocity of the frame's origin on the centre line]. After forward
// (the velocities of the state forward evaluated). mj_objectVelocity on a rod's proxy body or site
// reads MuJoCo's d->cvel, which the step leaves uncomputed there; this is the material point's.
Vec6 rod_frame_velocity(const Scene& s, const SceneData& sd, int rod, double X);
// strain xi(X) = [kx ky kz px py pz] in the cross-section frame
Vec6 rod_strain(const Scene& s, const SceneData& sd, int rod, double X);

// Model constants mj_setConst computed without the rods' inertia (body/dof/tendon invweight0, the
// scale of constraint softness; actuator_acc0, a muscle's default force scale; stat.meaninertia,
// the constraint solvers' scale; camera and light offsets for tracking), recomputed from the
// patched state at qpos0. A proxy's body_invweight0 is taken at its section's centre of mass, as
// MuJoCo takes it at a body's. (What MuJoCo computes from positions alone at qpos0 is right as it
// is: the compiled model at qpos0 is the rods' rest shape.)
// These take the rods' inertia integrated by max(kConstantsQuadrature, order + 6) Gauss points per
// section (rod_inertia), not the dynamics' mass rule, whose few points leave nearly massless modes
// that inflated a short rod's inverse weights (and so its contacts' softness) many times over.
void recompute_qpos0_constants(Scene& s);
// The same with the caller's SceneData, left with the positions evaluated at qpos0.
void recompute_qpos0_constants(Scene& s, SceneData& sd);
constexpr int kConstantsQuadrature = 8;

// The kinetic-energy metric (nv x nv, MuJoCo's dofs) of rod r's cross-sections after fwd_position:
// their inertia summed over the rod's mass points (points = 0: the dynamics' mass rule, what qM
// holds of the rod), or integrated by a `points`-point Gauss rule on each section.
Eigen::MatrixXd rod_inertia(const Scene& s, SceneData& sd, int r, int points);

// Lower-level stages (exposed for tests and for the static solver).
void fwd_position(const Scene& s, SceneData& sd, Need need = Need::Acceleration);
// The part of fwd_position that energy() needs: poses (rods patched), cdof and (with `mass`) the
// mass matrix.
void fwd_inertia(const Scene& s, SceneData& sd, bool mass = true);
void fwd_velocity(const Scene& s, SceneData& sd);
// MuJoCo's mj_fwdAcceleration without its solve for qacc_smooth: d->qfrc_smooth only (no factor
// of M needed; what the implicit steps and the static solver take when no constraint acts).
void smooth_forces(const mjModel* m, mjData* d);

}  // namespace cosserat::mj
