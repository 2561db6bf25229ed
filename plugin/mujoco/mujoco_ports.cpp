// Ports of MuJoCo 2.2.2's smooth stages (mujoco_ports.hpp), compiled with -ffp-contract=off.
#include "mujoco_ports.hpp"

#include <algorithm>

namespace cosserat::mj {

namespace {

// mju_mulInertVec (not exported in 2.2.2): res = I v for a com-based inertia i[10].
void mul_inert_vec(mjtNum res[6], const mjtNum i[10], const mjtNum v[6]) {
  res[0] = i[0] * v[0] + i[3] * v[1] + i[4] * v[2] - i[8] * v[4] + i[7] * v[5];
  res[1] = i[3] * v[0] + i[1] * v[1] + i[5] * v[2] + i[8] * v[3] - i[6] * v[5];
  res[2] = i[4] * v[0] + i[5] * v[1] + i[2] * v[2] - i[7] * v[3] + i[6] * v[4];
  res[3] = i[8] * v[1] - i[7] * v[2] + i[9] * v[3];
  res[4] = i[6] * v[2] - i[8] * v[0] + i[9] * v[4];
  res[5] = i[7] * v[0] - i[6] * v[1] + i[9] * v[5];
}

// engine_util_spatial.c's motion and force cross products and dof-vector product (not exported).
void cross_motion(mjtNum res[6], const mjtNum vel[6], const mjtNum v[6]) {
  res[0] = -vel[2] * v[1] + vel[1] * v[2];
  res[1] = vel[2] * v[0] - vel[0] * v[2];
  res[2] = -vel[1] * v[0] + vel[0] * v[1];
  res[3] = -vel[2] * v[4] + vel[1] * v[5];
  res[4] = vel[2] * v[3] - vel[0] * v[5];
  res[5] = -vel[1] * v[3] + vel[0] * v[4];
  res[3] += -vel[5] * v[1] + vel[4] * v[2];
  res[4] += vel[5] * v[0] - vel[3] * v[2];
  res[5] += -vel[4] * v[0] + vel[3] * v[1];
}

void cross_force(mjtNum res[6], const mjtNum vel[6], const mjtNum f[6]) {
  res[0] = -vel[2] * f[1] + vel[1] * f[2];
  res[1] = vel[2] * f[0] - vel[0] * f[2];
  res[2] = -vel[1] * f[0] + vel[0] * f[1];
  res[3] = -vel[2] * f[4] + vel[1] * f[5];
  res[4] = vel[2] * f[3] - vel[0] * f[5];
  res[5] = -vel[1] * f[3] + vel[0] * f[4];
  res[0] += -vel[5] * f[4] + vel[4] * f[5];
  res[1] += vel[5] * f[3] - vel[3] * f[5];
  res[2] += -vel[4] * f[3] + vel[3] * f[4];
}

// mju_dot(a, b, 6) inlined, in the packaged library's order of additions (four running sums over
// the first four entries, then the last two: its disassembly): bit for bit its result, without
// the call, which cost more than the arithmetic in crb_skipping_massless's ancestor walk (8% of a
// cantilever step's instructions). Tests MujocoPorts.CompositeInertiaIsMujocos and
// MujocoPorts.VelocityAndBiasAreMujocos (qM and qfrc_bias equal mj_crb's and mj_rne's bit for bit).
// The running sums start at +0 as there (a sum of -0 products is +0).
inline mjtNum dot6(const mjtNum* a, const mjtNum* b) {
  const mjtNum r0 = 0.0 + a[0] * b[0], r1 = 0.0 + a[1] * b[1], r2 = 0.0 + a[2] * b[2], r3 = 0.0 + a[3] * b[3];
  return ((r0 + r2) + (r1 + r3)) + (a[4] * b[4] + a[5] * b[5]);
}

void mul_dof_vec(mjtNum* res, const mjtNum* dof, const mjtNum* vec, int n) {
  if (n == 1)
    mju_scl(res, dof, vec[0], 6);
  else if (n <= 0)
    mju_zero(res, 6);
  else
    mju_mulMatTVec(res, dof, vec, n, 6);
}

}  // namespace

void body_kinematics(const mjModel* m, mjData* d, int i) {
  mjtNum pos[3], quat[4];
  const int jntadr = m->body_jntadr[i], jntnum = m->body_jntnum[i];
  if (jntnum == 1 && m->jnt_type[jntadr] == mjJNT_FREE) {
    const int qadr = m->jnt_qposadr[jntadr];
    mju_copy3(pos, d->qpos + qadr);
    mju_copy4(quat, d->qpos + qadr + 3);
    mju_copy3(d->xanchor + 3 * jntadr, pos);
    const mjtNum zaxis[3] = {0, 0, 1};
    mju_copy3(d->xaxis + 3 * jntadr, zaxis);
  } else {
    const int pid = m->body_parentid[i];
    // the body's offset from its parent: the model's, or a mocap body's from mjData
    const int mocap = m->body_mocapid[i];
    const mjtNum* bodypos = mocap >= 0 ? d->mocap_pos + 3 * mocap : m->body_pos + 3 * i;
    const mjtNum* bodyquat = mocap >= 0 ? d->mocap_quat + 4 * mocap : m->body_quat + 4 * i;
    mjtNum vec[3];
    mju_rotVecMat(vec, bodypos, d->xmat + 9 * pid);
    mju_add3(pos, d->xpos + 3 * pid, vec);
    mju_mulQuat(quat, d->xquat + 4 * pid, bodyquat);
    for (int j = 0; j < jntnum; ++j) {
      const int jid = jntadr + j, qadr = m->jnt_qposadr[jid], type = m->jnt_type[jid];
      mjtNum xanchor[3], xaxis[3];
      mju_rotVecQuat(xaxis, m->jnt_axis + 3 * jid, quat);
      mju_rotVecQuat(xanchor, m->jnt_pos + 3 * jid, quat);
      mju_addTo3(xanchor, pos);
      if (type == mjJNT_SLIDE) {
        mju_addToScl3(pos, xaxis, d->qpos[qadr] - m->qpos0[qadr]);
      } else if (type == mjJNT_BALL || type == mjJNT_HINGE) {
        mjtNum qloc[4], vec1[3];
        if (type == mjJNT_BALL)
          mju_copy4(qloc, d->qpos + qadr);
        else
          mju_axisAngle2Quat(qloc, m->jnt_axis + 3 * jid, d->qpos[qadr] - m->qpos0[qadr]);
        mju_mulQuat(quat, quat, qloc);  // (mju_mulQuat goes through a temporary)
        // off-centre rotation
        mju_sub3(vec, xanchor, pos);
        mju_rotVecQuat(vec1, m->jnt_pos + 3 * jid, quat);
        pos[0] += (vec[0] - vec1[0]);
        pos[1] += (vec[1] - vec1[1]);
        pos[2] += (vec[2] - vec1[2]);
      }
      mju_copy3(d->xanchor + 3 * jid, xanchor);
      mju_copy3(d->xaxis + 3 * jid, xaxis);
    }
  }
  mju_normalize4(quat);
  mju_copy4(d->xquat + 4 * i, quat);
  mju_copy3(d->xpos + 3 * i, pos);
  mju_quat2Mat(d->xmat + 9 * i, quat);
  mj_local2Global(d, d->xipos + 3 * i, d->ximat + 9 * i, m->body_ipos + 3 * i, m->body_iquat + 4 * i, i,
                  m->body_sameframe[i]);
}

void kinematics_except(const mjModel* m, mjData* d, const char* skip) {
  // as mj_kinematics does: the quaternions in qpos and mocap_quat normalised in place
  mj_normalizeQuat(m, d->qpos);
  for (int i = 0; i < m->nmocap; ++i) mju_normalize4(d->mocap_quat + 4 * i);
  mju_zero3(d->xpos);
  mju_unit4(d->xquat);
  mju_zero3(d->xipos);
  mju_zero(d->xmat, 9);
  mju_zero(d->ximat, 9);
  d->xmat[0] = d->xmat[4] = d->xmat[8] = 1;
  d->ximat[0] = d->ximat[4] = d->ximat[8] = 1;
  for (int b = 1; b < m->nbody; ++b)
    if (!(skip && skip[b])) body_kinematics(m, d, b);
  for (int g = 0; g < m->ngeom; ++g)
    if (!(skip && skip[m->geom_bodyid[g]])) geom_kinematics(m, d, g);
  for (int i = 0; i < m->nsite; ++i)
    if (!(skip && skip[m->site_bodyid[i]])) site_kinematics(m, d, i);
}

void geom_kinematics(const mjModel* m, mjData* d, int g) {
  mj_local2Global(d, d->geom_xpos + 3 * g, d->geom_xmat + 9 * g, m->geom_pos + 3 * g, m->geom_quat + 4 * g,
                  m->geom_bodyid[g], m->geom_sameframe[g]);
}

void site_kinematics(const mjModel* m, mjData* d, int i) {
  mj_local2Global(d, d->site_xpos + 3 * i, d->site_xmat + 9 * i, m->site_pos + 3 * i, m->site_quat + 4 * i,
                  m->site_bodyid[i], m->site_sameframe[i]);
}

void crb_skipping_massless(const mjModel* m, mjData* d, const char* leave_out) {
  mjtNum* crb = d->crb;
  mju_copy(crb, d->cinert, 10 * m->nbody);
  if (leave_out)
    for (int i = 1; i < m->nbody; ++i)
      if (leave_out[i]) mju_zero(crb + 10 * i, 10);
  for (int i = m->nbody - 1; i > 0; --i)
    if (m->body_parentid[i] > 0) mju_addTo(crb + 10 * m->body_parentid[i], crb + 10 * i, 10);
  mju_zero(d->qM, m->nM);
  for (int i = m->nv - 1; i >= 0; --i) {
    if (m->dof_simplenum[i]) {
      d->qM[m->dof_Madr[i]] = m->dof_M0[i];
      continue;
    }
    int Madr_ij = m->dof_Madr[i];
    d->qM[Madr_ij] = m->dof_armature[i];
    const mjtNum* crb_i = crb + 10 * m->dof_bodyid[i];
    if (std::all_of(crb_i, crb_i + 10, [](mjtNum x) { return x == 0.0; })) continue;
    mjtNum tmp[6];
    mul_inert_vec(tmp, crb_i, d->cdof + 6 * i);
    for (int j = i; j >= 0; j = m->dof_parentid[j]) d->qM[Madr_ij++] += dot6(d->cdof + 6 * j, tmp);
  }
}

void com_velocity_except(const mjModel* m, mjData* d, const char* skip) {
  mjtNum tmp[6], cvel[6], cdofdot[36];
  mju_zero(d->cvel, 6);
  for (int i = 1; i < m->nbody; ++i) {
    if (skip && skip[i]) continue;
    const int bda = m->body_dofadr[i];
    mju_copy(cvel, d->cvel + 6 * m->body_parentid[i], 6);
    for (int j = 0; j < m->body_dofnum[i]; ++j) {
      switch (m->jnt_type[m->dof_jntid[bda + j]]) {
        case mjJNT_FREE:
          mju_zero(cdofdot, 18);
          mul_dof_vec(tmp, d->cdof + 6 * bda, d->qvel + bda, 3);
          mju_addTo(cvel, tmp, 6);
          j += 3;
          [[fallthrough]];
        case mjJNT_BALL:
          for (int k = 0; k < 3; ++k) cross_motion(cdofdot + 6 * (j + k), cvel, d->cdof + 6 * (bda + j + k));
          mul_dof_vec(tmp, d->cdof + 6 * (bda + j), d->qvel + bda + j, 3);
          mju_addTo(cvel, tmp, 6);
          j += 2;
          break;
        default:
          cross_motion(cdofdot + 6 * j, cvel, d->cdof + 6 * (bda + j));
          mul_dof_vec(tmp, d->cdof + 6 * (bda + j), d->qvel + bda + j, 1);
          mju_addTo(cvel, tmp, 6);
      }
    }
    mju_copy(d->cvel + 6 * i, cvel, 6);
    mju_copy(d->cdof_dot + 6 * bda, cdofdot, 6 * m->body_dofnum[i]);
  }
}

void rne_except(const mjModel* m, mjData* d, int flg_acc, mjtNum* result, const char* skip) {
  mjtNum tmp[6], tmp1[6];
  const int mark = d->pstack;  // mjMARKSTACK
  mjtNum* cacc = mj_stackAlloc(d, m->nbody * 6);
  mjtNum* cfrc = mj_stackAlloc(d, m->nbody * 6);
  mju_zero(cacc, 6);
  if (!(m->opt.disableflags & mjDSBL_GRAVITY)) mju_scl3(cacc + 3, m->opt.gravity, -1);
  for (int i = 1; i < m->nbody; ++i) {
    if (skip && skip[i]) continue;  // massless, with a massless subtree: its cfrc is never read
    const int bda = m->body_dofadr[i];
    mul_dof_vec(tmp, d->cdof_dot + 6 * bda, d->qvel + bda, m->body_dofnum[i]);
    mju_add(cacc + 6 * i, cacc + 6 * m->body_parentid[i], tmp, 6);
    if (flg_acc) {
      mul_dof_vec(tmp, d->cdof + 6 * bda, d->qacc + bda, m->body_dofnum[i]);
      mju_addTo(cacc + 6 * i, tmp, 6);
    }
    mul_inert_vec(cfrc + 6 * i, d->cinert + 10 * i, cacc + 6 * i);
    mul_inert_vec(tmp, d->cinert + 10 * i, d->cvel + 6 * i);
    cross_force(tmp1, d->cvel + 6 * i, tmp);
    mju_addTo(cfrc + 6 * i, tmp1, 6);
  }
  mju_zero(cfrc, 6);
  for (int i = m->nbody - 1; i > 0; --i)
    if (m->body_parentid[i] && !(skip && skip[i])) mju_addTo(cfrc + 6 * m->body_parentid[i], cfrc + 6 * i, 6);
  for (int i = 0; i < m->nv; ++i)
    result[i] = skip && skip[m->dof_bodyid[i]] ? 0.0 : dot6(d->cdof + 6 * i, cfrc + 6 * m->dof_bodyid[i]);
  d->pstack = mark;  // mjFREESTACK
}

void tendon_velocities(const mjModel* m, mjData* d) {
  if (!mj_isSparse(m)) {
    mju_mulMatVec(d->ten_velocity, d->ten_J, d->qvel, m->ntendon, m->nv);
    return;
  }
  for (int t = 0; t < m->ntendon; ++t) {
    mjtNum v = 0.0;
    for (int k = d->ten_J_rowadr[t]; k < d->ten_J_rowadr[t] + d->ten_J_rownnz[t]; ++k)
      v += d->ten_J[k] * d->qvel[d->ten_J_colind[k]];
    d->ten_velocity[t] = v;
  }
}

}  // namespace cosserat::mj
