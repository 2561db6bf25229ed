// The ports of MuJoCo 2.2.2's smooth stages (plugin/mujoco/mujoco_ports.hpp) against MuJoCo's own
// mj_kinematics, mj_crb, mj_comVel and mj_rne, bit for bit, on the shipped models and on a scene
// with every joint type and a mocap body.
#include "mujoco_ports.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "scene.hpp"

using namespace cosserat::mj;

namespace {

const std::string kModels = std::string(COSSERAT_SOURCE_DIR) + "/models/";

// free, ball, hinge and slide joints, a mocap body, and a rod with a body below it
const char* kJoints = R"(<mujoco>
  <worldbody>
    <body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.05" mass="0.3"/></body>
    <body name="arm" pos="0.3 0 0.5"><joint type="hinge" axis="0 1 0" pos="0.01 0 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/><site name="s" pos="0.1 0 0"/>
      <body pos="0.2 0 0"><joint type="ball" pos="0 0.01 0"/><geom type="sphere" size="0.03" pos="0.05 0 0" mass="0.1"/>
        <body pos="0.1 0 0"><joint type="slide" axis="1 0 0"/><geom type="box" size="0.01 0.02 0.03" mass="0.05"/></body>
      </body>
    </body>
    <body name="hand" mocap="true" pos="0.5 0 0.8" quat="0.9 0.1 0.2 0"><geom type="sphere" size="0.02"/></body>
    <cosserat name="rod" pos="0 0.5 1" length="0.3" sections="4" strain="kl" radius="0.01" density="1000" young="1e6">
      <body name="tip" pos="0.02 0 0"><joint type="hinge" axis="0 0 1"/><geom type="sphere" size="0.02" mass="0.04"/></body>
    </cosserat>
  </worldbody>
</mujoco>)";

// A state away from qpos0: every coordinate moved, quaternions (qpos and mocap) not normalised.
void disturb(const Scene& s, SceneData& sd) {
  for (int i = 0; i < s.m->nq; ++i) sd.d->qpos[i] += 0.05 * std::sin(1.3 * i + 0.4);
  for (int i = 0; i < s.m->nv; ++i) sd.d->qvel[i] = 0.2 * std::cos(0.7 * i);
  for (int i = 0; i < 4 * s.m->nmocap; ++i) sd.d->mocap_quat[i] *= 1.1;
}

// A copy of d, deleted with the handle.
using DataCopy = std::unique_ptr<mjData, void (*)(mjData*)>;
DataCopy copy_of(const mjModel* m, const mjData* d) {
  mjData* c = mj_makeData(m);
  mj_copyData(c, m, d);
  return DataCopy(c, mj_deleteData);
}

template <class T>
bool same(const T* a, const T* b, int n) {
  return std::memcmp(a, b, sizeof(T) * n) == 0;
}

std::vector<std::string> sources() {
  std::vector<std::string> v = {kJoints};
  for (const char* f : {"cantilever", "flagellate", "lophotrichous", "hybrid_arm", "octopus_arm"})
    v.push_back(kModels + f + ".xml");
  return v;
}

std::unique_ptr<Scene> load(const std::string& src) {
  return src.front() == '<' ? load_scene_string(src, "/tmp/cosserat_ports_test.xml") : load_scene(src);
}

// Without a skip list, kinematics_except is mj_kinematics: poses of bodies, joints, inertial frames,
// geoms and sites, and the normalised quaternions it writes back.
TEST(MujocoPorts, KinematicsIsMujocos) {
  for (const std::string& src : sources()) {
    auto s = load(src);
    SceneData sd(*s);
    disturb(*s, sd);
    const mjModel* m = s->m;
    const DataCopy ref = copy_of(m, sd.d);
    mj_kinematics(m, ref.get());
    kinematics_except(m, sd.d, nullptr);
    const mjData* d = sd.d;
    const std::string what = src.substr(0, 60);
    EXPECT_TRUE(same(ref->qpos, d->qpos, m->nq)) << what;
    EXPECT_TRUE(same(ref->mocap_quat, d->mocap_quat, 4 * m->nmocap)) << what;
    EXPECT_TRUE(same(ref->xpos, d->xpos, 3 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->xquat, d->xquat, 4 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->xmat, d->xmat, 9 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->xipos, d->xipos, 3 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->ximat, d->ximat, 9 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->xanchor, d->xanchor, 3 * m->njnt)) << what;
    EXPECT_TRUE(same(ref->xaxis, d->xaxis, 3 * m->njnt)) << what;
    EXPECT_TRUE(same(ref->geom_xpos, d->geom_xpos, 3 * m->ngeom)) << what;
    EXPECT_TRUE(same(ref->geom_xmat, d->geom_xmat, 9 * m->ngeom)) << what;
    EXPECT_TRUE(same(ref->site_xpos, d->site_xpos, 3 * m->nsite)) << what;
    EXPECT_TRUE(same(ref->site_xmat, d->site_xmat, 9 * m->nsite)) << what;
  }
}

// crb_skipping_massless is mj_crb on the coupled scene's own cinert and cdof (rods patched in):
// the same composite inertias and qM, although it skips the ancestors of the rods' massless dofs
// (counted: the test covers both kinds of rod, with and without a body below).
TEST(MujocoPorts, CompositeInertiaIsMujocos) {
  int zero_dofs = 0, rod_dofs = 0;
  for (const std::string& src : sources()) {
    auto s = load(src);
    SceneData sd(*s);
    disturb(*s, sd);
    forward(*s, sd);
    const mjModel* m = s->m;
    const DataCopy ref = copy_of(m, sd.d);
    mj_crb(m, ref.get());
    crb_skipping_massless(m, sd.d);
    const std::string what = src.substr(0, 60);
    EXPECT_TRUE(same(ref->crb, sd.d->crb, 10 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->qM, sd.d->qM, m->nM)) << what;
    for (const RodBinding& rb : s->rods)
      for (int k = 0; k < rb.model.nv; ++k, ++rod_dofs) {
        const mjtNum* c = sd.d->crb + 10 * m->dof_bodyid[rb.dof0 + k];
        zero_dofs += std::all_of(c, c + 10, [](mjtNum x) { return x == 0.0; });
      }
  }
  EXPECT_GT(zero_dofs, 0);          // the skip happened
  EXPECT_LT(zero_dofs, rod_dofs);   // and rods with bodies below took the full pass
}

// Without a skip list, com_velocity_except and rne_except are mj_comVel and mj_rne bit for bit.
// With the scene's (Scene::velocity_skip: the bodies of rods with nothing massive below them, or
// with a rigid payload whose inertia the rod's solver carries, RodBinding::payload), the bodies
// they compute keep MuJoCo's cvel and cdof_dot bit for bit, and the bias forces equal MuJoCo's on
// the same data with the payloads' inertias left out (a skipped body's zero may differ in sign
// from MuJoCo's product with its zero inertia).
TEST(MujocoPorts, VelocityAndBiasAreMujocos) {
  int skipped = 0, kept_rod_bodies = 0, payloads = 0;
  for (const std::string& src : sources()) {
    auto s = load(src);
    SceneData sd(*s);
    disturb(*s, sd);
    forward(*s, sd);
    const mjModel* m = s->m;
    const std::string what = src.substr(0, 60);
    const DataCopy ref = copy_of(m, sd.d);
    mj_comVel(m, ref.get());
    mj_rne(m, ref.get(), 0, ref->qfrc_bias);
    const DataCopy all = copy_of(m, sd.d);
    com_velocity_except(m, all.get(), nullptr);
    rne_except(m, all.get(), 0, all->qfrc_bias, nullptr);
    EXPECT_TRUE(same(ref->cvel, all->cvel, 6 * m->nbody)) << what;
    EXPECT_TRUE(same(ref->cdof_dot, all->cdof_dot, 6 * m->nv)) << what;
    EXPECT_TRUE(same(ref->qfrc_bias, all->qfrc_bias, m->nv)) << what;
    ASSERT_EQ(s->velocity_skip.size(), static_cast<size_t>(m->nbody));
    ASSERT_EQ(s->payload_body.size(), static_cast<size_t>(m->nbody));
    for (int b = 1; b < m->nbody; ++b)  // the rods carry their payloads' inertia
      if (s->payload_body[b]) {
        ++payloads;
        mju_zero(ref->cinert + 10 * b, 10);
      }
    mj_rne(m, ref.get(), 0, ref->qfrc_bias);
    const DataCopy part = copy_of(m, sd.d);
    com_velocity_except(m, part.get(), s->velocity_skip.data());
    rne_except(m, part.get(), 0, part->qfrc_bias, s->velocity_skip.data());
    for (int b = 1; b < m->nbody; ++b) {
      if (s->velocity_skip[b]) {
        ++skipped;
        if (!s->payload_body[b]) EXPECT_EQ(m->body_mass[b], 0.0) << what << ": skipped body " << b << " has mass";
        continue;
      }
      kept_rod_bodies += s->body_by_rod[b];
      EXPECT_TRUE(same(ref->cvel + 6 * b, part->cvel + 6 * b, 6)) << what << ", body " << b;
      const int n = m->body_dofnum[b], a = m->body_dofadr[b];
      EXPECT_TRUE(same(ref->cdof_dot + 6 * a, part->cdof_dot + 6 * a, 6 * n)) << what << ", body " << b;
    }
    for (int i = 0; i < m->nv; ++i) EXPECT_EQ(ref->qfrc_bias[i], part->qfrc_bias[i]) << what << ", dof " << i;
  }
  EXPECT_GT(skipped, 0);          // the skip happened
  EXPECT_GT(kept_rod_bodies, 0);  // and rods with massive bodies below kept their passes
  EXPECT_GT(payloads, 0);         // and some rods carried their payloads
}

}  // namespace
