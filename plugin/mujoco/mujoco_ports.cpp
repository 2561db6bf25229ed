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

void crb_skipping_massless(const mjModel* m, mjData* d) {
  mjtNum* crb = d->crb;
  mju_copy(crb, d->cinert, 10 * m->nbody);
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
    for (int j = i; j >= 0; j = m->dof_parentid[j]) d->qM[Madr_ij++] += mju_dot(d->cdof + 6 * j, tmp, 6);
  }
}

}  // namespace cosserat::mj
