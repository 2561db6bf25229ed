// Stages of MuJoCo 2.2.2's smooth pipeline (engine_core_smooth.c), operation for operation, for the
// parts of a scene that the rods do not own: the step calls these instead of MuJoCo's own stages
// so that it does not compute what a rod's patch overwrites or what is zero on its massless
// proxies (DESIGN.md section 6). Compiled without fused multiply-adds (CMakeLists.txt): every
// number they produce is bit-for-bit the packaged MuJoCo's (Scene.StagedPipelineReproducesMjStep
// BitForBit; runs of the shipped models are compared field by field against the full stages).
#pragma once

#include <mujoco/mujoco.h>

namespace cosserat::mj {

// mj_kinematics for one body whose parent's pose is final (free, ball, hinge and slide joints,
// mocap bodies), after the quaternions in qpos and mocap_quat were normalised in place: its frame,
// joint anchors and axes, and inertial frame. Its geoms and sites are not placed.
void body_kinematics(const mjModel* m, mjData* d, int body);

// mj_kinematics for one geom or site whose body's pose is final: its frame from the body's.
void geom_kinematics(const mjModel* m, mjData* d, int geom);
void site_kinematics(const mjModel* m, mjData* d, int site);

// mj_kinematics for the bodies b with !skip[b] (skip: nbody flags, or nullptr for none), their
// geoms and sites, the world, and the in-place normalisation of qpos's and mocap_quat's
// quaternions. A skipped body, its geoms and sites are left as they are (the caller places them).
void kinematics_except(const mjModel* m, mjData* d, const char* skip);

// mj_crb (composite inertias and qM), without the pass over the ancestors of a dof whose body's
// composite inertia is zero (a rod's massless proxies with nothing below them): those entries of
// qM are the dof's armature and zeros, as MuJoCo's products with a zero vector leave them.
// leave_out (nbody flags, or nullptr): bodies whose inertia is counted elsewhere (a rod's payload,
// Scene::payload_body): their cinert is taken as zero.
void crb_skipping_massless(const mjModel* m, mjData* d, const char* leave_out = nullptr);

// mj_fwdVelocity's tendon velocities, d->ten_velocity = ten_J qvel, in either layout of ten_J:
// mju_mulMatVec on dense rows, a compressed row's entries summed in order (mju_dotSparse as
// packaged, without AVX; a fused multiply-add had changed their last bits: outside probe AA).
void tendon_velocities(const mjModel* m, mjData* d);

// mj_comVel (cvel, and cdof_dot = cvel x cdof) for the bodies b with !skip[b] (skip: nbody flags,
// or nullptr for none); a skipped body's cvel and cdof_dot are left as they are. `skip` must hold
// whole subtrees: a body below a skipped one is skipped too.
void com_velocity_except(const mjModel* m, mjData* d, const char* skip);

// mj_rne into result (nv) with the bodies b with skip[b] taken as massless with a massless subtree:
// their bias force is zero, and so is `result` at their dofs, without computing them (MuJoCo's
// products with their zero inertias give zeros, whose sign may differ). Skipped bodies' cvel and
// cdof_dot are not read. `skip` must hold whole subtrees of massless bodies.
void rne_except(const mjModel* m, mjData* d, int flg_acc, mjtNum* result, const char* skip);

}  // namespace cosserat::mj
