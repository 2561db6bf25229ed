// MuJoCo's sensors on rod sites. A site inside a section rides on the deforming centre line, not
// rigidly on the section's proxy body (placed at the section's end) as MuJoCo assumes: the velocity
// and acceleration sensors that read it must give the material point's own motion, checked here
// against central differences of the sites' positions and orientations, and of their velocities.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "dynamics.hpp"
#include "scene.hpp"
#include "scene_statics.hpp"
#include "support/bent_motion.hpp"
#include "support/text_file.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

using cosserat::testing::replace_all;

using Mat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

Vec3 site_pos(const mjData* d, int id) {
  return Vec3(d->site_xpos[3 * id], d->site_xpos[3 * id + 1], d->site_xpos[3 * id + 2]);
}
Mat3 site_mat(const mjData* d, int id) { return Eigen::Map<const Mat3>(d->site_xmat + 9 * id); }

// Sites: m inside section 1 (off the centre line), e at section 1's end, r inside section 2 (a
// reference frame), h on the rigid hub, and the rod's generated base site arm/base (on its base
// body, rigid with the hub, off the hinge's axis); the rod and the hub move (hinge and strain velocities).
const char* kXml = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
  <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
    <site name="h" pos="0.01 0.02 0.03" euler="10 20 30"/>
    <cosserat name="arm" pos="0.02 0 0" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
      <site name="m" at="0.15" pos="0 0.006 0.002"/><site name="e" at="0.2" pos="0 0.006 0.002"/>
      <site name="r" at="0.27" pos="0.001 -0.004 0.003"/>
    </cosserat></body></worldbody>
  <sensor>
    <framelinvel name="m_lin" objtype="site" objname="m"/>
    <frameangvel name="m_ang" objtype="site" objname="m"/>
    <velocimeter name="m_vel" site="m"/>
    <gyro name="m_gyro" site="m"/>
    <framelinvel name="m_lin_r" objtype="site" objname="m" reftype="site" refname="r"/>
    <frameangvel name="m_ang_r" objtype="site" objname="m" reftype="site" refname="r"/>
    <framelinvel name="h_lin_r" objtype="site" objname="h" reftype="site" refname="r"/>
    <frameangvel name="h_ang_r" objtype="site" objname="h" reftype="site" refname="r"/>
    <framelinvel name="e_lin" objtype="site" objname="e"/>
    <velocimeter name="m_vel_cut" site="m" cutoff="0.05"/>
    <velocimeter name="b_vel" site="arm/base"/>
    <gyro name="b_gyro" site="arm/base"/>
    <framelinvel name="m_lin_b" objtype="site" objname="m" reftype="site" refname="arm/base"/>
  </sensor>
</mujoco>)";

// check(scene, data, motion) on the model with PCS sections (as written) and with GVS sections of
// order 2, along cosserat::testing::BentMotion.
void on_pcs_and_gvs(const std::string& xml,
                    const std::function<void(const Scene&, SceneData&, const cosserat::testing::BentMotion&)>& check) {
  for (bool gvs : {false, true}) {
    SCOPED_TRACE(gvs ? "GVS order 2" : "PCS");
    const size_t at = xml.find("strain=\"kl\"");
    auto s = load_scene_string(gvs ? xml.substr(0, at) + "order=\"2\" " + xml.substr(at) : xml,
                               "/tmp/cosserat_sensor_test.xml");
    SceneData sd(*s);
    ASSERT_EQ(s->m->nq, s->m->nv);
    check(*s, sd, cosserat::testing::BentMotion(s->m));
  }
}

TEST(Sensors, VelocitySensorsOnRodSitesReadTheMaterialPointsVelocity) {
  on_pcs_and_gvs(kXml, [](const Scene& scene, SceneData& sd, const cosserat::testing::BentMotion& motion) {
    const Scene* s = &scene;
    const mjModel* m = s->m;
    mjData* d = sd.d;
    const int id_m = mj_name2id(m, mjOBJ_SITE, "m"), id_e = mj_name2id(m, mjOBJ_SITE, "e"),
              id_r = mj_name2id(m, mjOBJ_SITE, "r"), id_h = mj_name2id(m, mjOBJ_SITE, "h"),
              id_b = mj_name2id(m, mjOBJ_SITE, "arm/base");
    struct Frames {
      std::vector<Vec3> p;
      std::vector<Mat3> R;
    };
    auto at = [&](double t) {
      motion.at(*s, sd, t);
      Frames f;
      for (int id : {id_m, id_e, id_r, id_h, id_b}) {
        f.p.push_back(site_pos(d, id));
        f.R.push_back(site_mat(d, id));
      }
      return f;
    };
    const double eps = 1e-6;
    const Frames fp = at(eps), fm = at(-eps), f0 = at(0.0);
    std::vector<Vec3> vel,
        ang;  // world-frame velocities of m, e, r, h, arm/base from the differences
    for (int k = 0; k < 5; ++k) {
      vel.push_back((fp.p[k] - fm.p[k]) / (2 * eps));
      ang.push_back(cosserat::testing::spin_of(((fp.R[k] - fm.R[k]) / (2 * eps)) * f0.R[k].transpose()));
    }
    const Mat3 Rr = f0.R[2];
    // relative to a reference site (r: 2, arm/base: 4): d/dt R_ref^T (p - p_ref), and R_r^T (w - w_r)
    auto rel_lin = [&](int k, int ref = 2) {
      return Vec3((fp.R[ref].transpose() * (fp.p[k] - fp.p[ref]) - fm.R[ref].transpose() * (fm.p[k] - fm.p[ref])) /
                  (2 * eps));
    };
    const std::vector<std::pair<const char*, Vec3>> expected = {
        {"m_lin", vel[0]},
        {"m_ang", ang[0]},
        {"m_vel", f0.R[0].transpose() * vel[0]},
        {"m_gyro", f0.R[0].transpose() * ang[0]},
        {"m_lin_r", rel_lin(0)},
        {"m_ang_r", Rr.transpose() * (ang[0] - ang[2])},
        {"h_lin_r", rel_lin(3)},
        {"h_ang_r", Rr.transpose() * (ang[3] - ang[2])},
        {"e_lin", vel[1]},
        {"b_vel", f0.R[4].transpose() * vel[4]},
        {"b_gyro", f0.R[4].transpose() * ang[4]},
        {"m_lin_b", rel_lin(0, 4)},
    };
    for (const auto& [name, want] : expected) {
      const int adr = m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, name)];
      const Vec3 got(d->sensordata[adr], d->sensordata[adr + 1], d->sensordata[adr + 2]);
      EXPECT_GT(want.norm(), 1e-3) << name;
      EXPECT_LT((got - want).norm(), 1e-7 * want.norm())
          << name << ": " << got.transpose() << " against " << want.transpose();
    }
    // a cutoff clamps the material point's velocity (not MuJoCo's rigid guess)
    const Vec3 want = f0.R[0].transpose() * vel[0];
    const int adr = m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, "m_vel_cut")];
    for (int e = 0; e < 3; ++e) EXPECT_NEAR(d->sensordata[adr + e], std::clamp(want(e), -0.05, 0.05), 1e-7) << e;
  });
}

// rod_frame_velocity: the world-frame twist of a cross-section, at its base, inside and at the
// ends of sections and at its tip, is the rate of change of rod_frame (central differences), the
// hub's rotation and the strain rates both moving it; X beyond [0, L] reads the tip's.
TEST(Sensors, RodFrameVelocityIsTheRateOfChangeOfRodFrame) {
  on_pcs_and_gvs(kXml, [](const Scene& s, SceneData& sd, const cosserat::testing::BentMotion& motion) {
    const int r = rod_index(s, "arm");
    const double eps = 1e-6;
    for (double X : {0.0, 0.04, 0.1, 0.15, 0.2, 0.27, 0.3}) {
      SCOPED_TRACE(X);
      motion.at(s, sd, eps);
      const SE3 gp = rod_frame(s, sd, r, X);
      motion.at(s, sd, -eps);
      const SE3 gm = rod_frame(s, sd, r, X);
      motion.at(s, sd, 0.0);
      const SE3 g0 = rod_frame(s, sd, r, X);
      const Vec6 got = rod_frame_velocity(s, sd, r, X);
      const Vec3 w = cosserat::testing::spin_of(((gp.R - gm.R) / (2 * eps)) * g0.R.transpose());
      const Vec3 v = (gp.u - gm.u) / (2 * eps);
      EXPECT_GT(w.norm(), 1e-2);
      EXPECT_GT(v.norm(), X > 0 ? 1e-2 : 1e-3);
      EXPECT_LT((got.head<3>() - w).norm(), 1e-7 * w.norm()) << got.head<3>().transpose() << " against " << w.transpose();
      EXPECT_LT((got.tail<3>() - v).norm(), 1e-7 * v.norm()) << got.tail<3>().transpose() << " against " << v.transpose();
    }
    motion.at(s, sd, 0.0);
    EXPECT_EQ(rod_frame_velocity(s, sd, r, 0.5), rod_frame_velocity(s, sd, r, 0.3));
    EXPECT_THROW(rod_frame_velocity(s, sd, 1, 0.1), std::out_of_range);
  });
}

// framequat of rod sites and capsules (alone and relative to a rod site, to a hub site, and the
// hub site relative to a rod site) reads the frame the rod gives them, not their proxy's.
TEST(Sensors, FrameQuaternionsOfRodSitesAndCapsulesReadTheirOwnFrames) {
  const std::string xml = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
      <site name="h" pos="0.01 0.02 0.03" euler="10 20 30"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
        <site name="m" at="0.15" pos="0 0.006 0.002"/><site name="r" at="0.27" pos="0.001 -0.004 0.003"/>
      </cosserat></body></worldbody>
    <sensor>
      <framequat name="q_m" objtype="site" objname="m"/>
      <framequat name="q_m_r" objtype="site" objname="m" reftype="site" refname="r"/>
      <framequat name="q_m_h" objtype="site" objname="m" reftype="site" refname="h"/>
      <framequat name="q_h_m" objtype="site" objname="h" reftype="site" refname="m"/>
      <framequat name="q_g" objtype="geom" objname="arm/s1/g0"/>
    </sensor>
  </mujoco>)";
  on_pcs_and_gvs(xml, [](const Scene& scene, SceneData& sd, const cosserat::testing::BentMotion& motion) {
    const mjModel* m = scene.m;
    const mjData* d = sd.d;
    motion.at(scene, sd, 0.0);
    auto site = [&](const char* n) { return site_mat(d, mj_name2id(m, mjOBJ_SITE, n)); };
    const int g = mj_name2id(m, mjOBJ_GEOM, "arm/s1/g0");
    const Mat3 Rm = site("m"), Rr = site("r"), Rh = site("h"), Rg = Eigen::Map<const Mat3>(d->geom_xmat + 9 * g);
    const std::vector<std::pair<const char*, Mat3>> expected = {
        {"q_m", Rm}, {"q_m_r", Rr.transpose() * Rm}, {"q_m_h", Rh.transpose() * Rm}, {"q_h_m", Rm.transpose() * Rh},
        {"q_g", Rg}};
    for (const auto& [name, want] : expected) {
      const mjtNum* q = d->sensordata + m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, name)];
      const Eigen::Quaterniond got(q[0], q[1], q[2], q[3]);
      EXPECT_NEAR(got.norm(), 1.0, 1e-12) << name;
      EXPECT_LT((got.toRotationMatrix() - want).norm(), 1e-12) << name;
    }
    // the frames moved off their proxies: a proxy's rotation would be off by far more
    const int proxy = m->site_bodyid[mj_name2id(m, mjOBJ_SITE, "m")];
    EXPECT_GT((Eigen::Map<const Mat3>(d->xmat + 9 * proxy) - Rm).norm(), 1e-2);
  });
  // a rigid rod's capsules too (MuJoCo's frame of a capsule compiled from its fromto points its z
  // axis the other way: half a turn off, an outside probe found), and its sites
  auto s = load_scene_string(replace_all(xml, "strain=\"kl\"", "strain=\"rigid\""), "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  sd.d->qpos[0] = 0.7;
  forward(*s, sd);
  const mjModel* m = s->m;
  const int g = mj_name2id(m, mjOBJ_GEOM, "arm/s1/g0");
  const std::vector<std::pair<const char*, Mat3>> expected = {
      {"q_g", Eigen::Map<const Mat3>(sd.d->geom_xmat + 9 * g)},
      {"q_m", site_mat(sd.d, mj_name2id(m, mjOBJ_SITE, "m"))}};
  for (const auto& [name, want] : expected) {
    const mjtNum* q = sd.d->sensordata + m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, name)];
    EXPECT_LT((Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix() - want).norm(), 1e-12) << "rigid " << name;
  }
}

// Frame quaternions are continuous in time, as MuJoCo's own composition body * local is: a rod on a
// tumbling free body (outside probe P: a rod site's framequat jumped to its negative twice in 1000
// steps, where the native site's never did, because mju_mat2Quat picks a sign of its own). Over
// 1000 steps no sensor's quaternion, and no proxy's xquat, turns by more than a small angle per step
// (|q(t) . q(t - h)| near 1 and positive), and each still reads its frame.
TEST(Sensors, FrameQuaternionsAreContinuousInTime) {
  auto s = load_scene_string(R"(<mujoco><option gravity="0 0 0"/><compiler angle="degree"/><worldbody>
    <body name="hub" pos="0 0 1" euler="30 10 45"><freejoint/><inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
      <cosserat name="arm" pos="0.02 0.03 0.04" xyaxes="1 1 0 -1 1 0.5" length="0.4" strain="sr" young="1e9"
                sections="2" radius="0.01" contype="0" conaffinity="0">
        <site name="c1" at="0.15" pos="0 0.006 0"/>
        <body name="gripper" pos="0.02 0.01 0" euler="10 20 30"><geom type="box" size=".01 .02 .01" mass="0.02"/>
          <site name="gs" pos="0.01 0.02 0.03"/></body>
      </cosserat></body></worldbody>
    <sensor>
      <framequat name="site" objtype="site" objname="c1"/>
      <framequat name="site_ref" objtype="site" objname="c1" reftype="site" refname="gs"/>
      <framequat name="capsule" objtype="geom" objname="arm/s1/g1"/>
      <framequat name="proxy" objtype="xbody" objname="arm/s1"/>
    </sensor>
  </mujoco>)", "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  const mjModel* m = s->m;
  mjData* d = sd.d;
  const double w[6] = {0.1, -0.2, 0.3, 2, -3, 5};  // free joint velocity: tumbling at 6 rad/s
  for (int k = 0; k < 6; ++k) d->qvel[k] = w[k];
  const int proxy = mj_name2id(m, mjOBJ_BODY, "arm/s1");
  std::vector<Eigen::Vector4d> prev;
  double turns = 0.0;  // how far the hub turned
  for (int k = 0; k <= 1000; ++k) {
    forward(*s, sd);
    std::vector<Eigen::Vector4d> now;
    for (int i = 0; i < m->nsensor; ++i) now.push_back(Eigen::Map<const Eigen::Vector4d>(d->sensordata + m->sensor_adr[i]));
    now.push_back(Eigen::Map<const Eigen::Vector4d>(d->xquat + 4 * proxy));
    if (!prev.empty())
      for (size_t i = 0; i < now.size(); ++i) ASSERT_GT(now[i].dot(prev[i]), 0.99) << "quaternion " << i << " at step " << k;
    prev = now;
    // the site's quaternion still reads its frame
    const Eigen::Quaterniond q(now[0](0), now[0](1), now[0](2), now[0](3));
    ASSERT_LT((q.toRotationMatrix() - site_mat(d, mj_name2id(m, mjOBJ_SITE, "c1"))).norm(), 1e-12);
    turns += 6.2 * m->opt.timestep / (2 * M_PI);
    ASSERT_EQ(step(*s, sd), cosserat::Status::Ok);
  }
  EXPECT_GT(turns, 1.0);  // the frames turned through every sign of mju_mat2Quat's choice
}

// A touch sensor on a rod site counts the whole rod's contacts in its zone (the rod is one body to
// it; MuJoCo would count the site's section's only): a rod resting on the floor on its capsules
// alone (its base body has no geom) carries its weight and its base's, and a zone over the whole
// rod reads that weight; two zones splitting it between its contacts (x < 0.175 and beyond, each
// over two sections) read it in parts that sum to it.
TEST(Sensors, TouchOnARodSiteCountsTheWholeRodsContacts) {
  auto s = load_scene_string(R"(<mujoco><option gravity="0 0 -9.81" timestep="0.001"/><worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="hub" pos="0 0 0.012"><freejoint/><inertial pos="0 0 0" mass="0.02" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" young="1e6" viscosity="5">
        <site name="all" at="0.15" type="box" size="0.3 0.3 0.05"/>
        <site name="z1" at="0.0375" type="box" size="0.1375 0.3 0.05"/><site name="z2" at="0.2875" type="box" size="0.1125 0.3 0.05"/>
      </cosserat></body></worldbody>
    <sensor><touch name="all" site="all"/><touch name="z1" site="z1"/><touch name="z2" site="z2"/></sensor></mujoco>)",
                             "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  for (int k = 0; k < 3000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
  forward(*s, sd);
  const mjModel* m = s->m;
  double rod_mass = 0.0;
  cosserat::center_of_mass(s->rods[0].model, sd.rod[0], &rod_mass);
  const double weight = 9.81 * (rod_mass + 0.02);  // the rod and its base body
  auto touch = [&](const char* n) { return sd.d->sensordata[m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, n)]]; };
  EXPECT_GT(sd.d->ncon, 1);
  EXPECT_NEAR(touch("all"), weight, 1e-6 * weight);
  EXPECT_NEAR(touch("z1") + touch("z2"), weight, 1e-6 * weight);
  EXPECT_GT(touch("z1"), 0.2 * weight);
  EXPECT_GT(touch("z2"), 0.2 * weight);
}

// Touch on the rod's generated base site counts the rod's contacts in its zone like a user site
// at the same abscissa (outside probe AN: it read 0, MuJoCo counting the contacts of the base
// body, which has no geoms). A thin rod (r = 3 mm) on a floor: the default 5 mm site spheres at its
// ends hold its end contacts.
TEST(Sensors, TouchOnTheRodsBaseSiteCountsItsContacts) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="hub" pos="0 0 0.00299"><freejoint/><inertial pos="0 0 0" mass="0.001" diaginertia="1e-8 1e-8 1e-8"/>
      <cosserat name="rod" length="0.3" sections="3" strain="kl" radius="0.003" density="1000" young="1e7"
                poisson="0.5" viscosity="200"><site name="at0" at="0"/><site name="atL" at="0.3"/></cosserat>
    </body></worldbody>
    <sensor><touch name="base" site="rod/base"/><touch name="at0" site="at0"/><touch name="tip" site="rod/tip"/>
      <touch name="atL" site="atL"/></sensor></mujoco>)",
                             "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
  forward(*s, sd);
  const mjModel* m = s->m;
  auto touch = [&](const char* n) { return sd.d->sensordata[m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, n)]]; };
  EXPECT_GT(touch("at0"), 1e-3);
  EXPECT_EQ(touch("base"), touch("at0"));
  EXPECT_GT(touch("atL"), 1e-3);
  EXPECT_EQ(touch("tip"), touch("atL"));

  // ... and the contacts of the body it rides with, as MuJoCo's own touch counts them (outside probe
  // AO): a hub sphere on the floor, the rod's end lifted, read by the base site and a hub site alike
  auto h = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="hub" pos="0 0 0.004"><freejoint/><geom name="hubg" type="sphere" size="0.004" mass="0.01"/><site name="hubs"/>
      <cosserat name="rod" length="0.3" sections="3" strain="kl" radius="0.003" density="1000" young="1e7" poisson="0.5"
                viscosity="200"/></body></worldbody>
    <contact><exclude body1="hub" body2="rod/s0"/></contact>
    <sensor><touch name="base" site="rod/base"/><touch name="hub" site="hubs"/></sensor></mujoco>)",
                             "/tmp/cosserat_sensor_test.xml");
  SceneData hd(*h);
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(*h, hd), Status::Ok);
  forward(*h, hd);
  EXPECT_GT(hd.d->sensordata[1], 1e-3);
  EXPECT_EQ(hd.d->sensordata[0], hd.d->sensordata[1]);
}

// A rangefinder on a rod site sees past the rod's own capsules it starts in (at a section's end the
// site lies inside the next section's capsule, another body to MuJoCo): a rod 0.5 m above the floor
// with its sites' z axes pointing down reads 0.5 from sites inside sections, at their ends and at
// the base; another rod's capsules below are obstacles as any geom (0.25 m below, radius 0.01).
TEST(Sensors, RangefinderOnARodSiteSeesPastTheRodsOwnCapsules) {
  auto s = load_scene_string(R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <cosserat name="arm" pos="0 0 0.5" euler="180 0 0" length="0.4" sections="4" strain="kl" radius="0.01">
      <site name="in" at="0.05"/><site name="end" at="0.1"/><site name="end2" at="0.2"/><site name="at0" at="0"/>
      <site name="over" at="0.35"/>
    </cosserat>
    <cosserat name="bar" pos="0.35 -0.1 0.25" euler="0 0 90" length="0.2" sections="2" strain="kl" radius="0.01"/>
    </worldbody>
    <sensor><rangefinder name="in" site="in"/><rangefinder name="end" site="end"/><rangefinder name="end2" site="end2"/>
      <rangefinder name="at0" site="at0"/><rangefinder name="base" site="arm/base"/><rangefinder name="over" site="over"/>
    </sensor></mujoco>)",
                             "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  forward(*s, sd);
  const mjModel* m = s->m;
  for (const char* n : {"in", "end", "end2", "at0", "base"})
    EXPECT_NEAR(sd.d->sensordata[m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, n)]], 0.5, 1e-6) << n;
  EXPECT_NEAR(sd.d->sensordata[m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, "over")]], 0.24, 1e-6);
}

// Acceleration sensors on rod sites (a in section 0, m in section 1, e at section 1's end): the
// material point's acceleration, from central differences of its (checked) velocity sensors along
// the motion (q, v) -> (q + t v, v + t qacc). MuJoCo's linear accelerations count gravity as an
// upward acceleration (cacc of the world is -g).
TEST(Sensors, AccelerationSensorsOnRodSitesReadTheMaterialPointsAcceleration) {
  const char* xml = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
  <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
    <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
      <site name="m" at="0.15" pos="0 0.006 0.002"/><site name="a" at="0.04" pos="0.001 -0.003 0.002"/>
      <site name="e" at="0.2" pos="0 0.006 0.002"/>
    </cosserat></body></worldbody>
  <sensor>
    <framelinvel name="m_lin" objtype="site" objname="m"/><frameangvel name="m_ang" objtype="site" objname="m"/>
    <framelinvel name="a_lin" objtype="site" objname="a"/><frameangvel name="a_ang" objtype="site" objname="a"/>
    <framelinvel name="e_lin" objtype="site" objname="e"/><frameangvel name="e_ang" objtype="site" objname="e"/>
    <framelinacc name="m_linacc" objtype="site" objname="m"/><frameangacc name="m_angacc" objtype="site" objname="m"/>
    <accelerometer name="m_acc" site="m"/>
    <framelinacc name="a_linacc" objtype="site" objname="a"/><frameangacc name="a_angacc" objtype="site" objname="a"/>
    <framelinacc name="e_linacc" objtype="site" objname="e"/><frameangacc name="e_angacc" objtype="site" objname="e"/>
    <accelerometer name="m_acc_cut" site="m" cutoff="2"/>
  </sensor>
</mujoco>)";
  on_pcs_and_gvs(xml, [](const Scene& scene, SceneData& sd, const cosserat::testing::BentMotion& motion) {
    const Scene* s = &scene;
    const mjModel* m = s->m;
    mjData* d = sd.d;
    auto set = [&](double t, const std::vector<double>& a) { motion.at(*s, sd, t, &a); };
    auto sensor = [&](const char* name) {
      const int adr = m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, name)];
      return Vec3(d->sensordata[adr], d->sensordata[adr + 1], d->sensordata[adr + 2]);
    };
    set(0.0, std::vector<double>(m->nv, 0.0));
    const std::vector<double> a0(d->qacc, d->qacc + m->nv);
    const double eps = 1e-6;
    std::map<std::string, Vec3> plus, minus;
    const char* vel[] = {"m_lin", "m_ang", "a_lin", "a_ang", "e_lin", "e_ang"};
    set(eps, a0);
    for (const char* n : vel) plus[n] = sensor(n);
    set(-eps, a0);
    for (const char* n : vel) minus[n] = sensor(n);
    set(0.0, a0);
    auto rate = [&](const char* n) { return Vec3((plus[n] - minus[n]) / (2 * eps)); };
    const Vec3 up(0, 0, 9.81);
    const int id_m = mj_name2id(m, mjOBJ_SITE, "m");
    const Mat3 Rm = site_mat(d, id_m);
    const std::vector<std::pair<const char*, Vec3>> expected = {
        {"m_linacc", rate("m_lin") + up}, {"m_angacc", rate("m_ang")}, {"m_acc", Rm.transpose() * (rate("m_lin") + up)},
        {"a_linacc", rate("a_lin") + up}, {"a_angacc", rate("a_ang")}, {"e_linacc", rate("e_lin") + up},
        {"e_angacc", rate("e_ang")},
    };
    for (const auto& [name, want] : expected) {
      const Vec3 got = sensor(name);
      EXPECT_GT(want.norm(), 1e-2) << name;
      EXPECT_LT((got - want).norm(), 1e-6 * want.norm())
          << name << ": " << got.transpose() << " against " << want.transpose();
    }
    const Vec3 want = Rm.transpose() * (rate("m_lin") + up), got = sensor("m_acc_cut");
    for (int e = 0; e < 3; ++e) EXPECT_NEAR(got(e), std::clamp(want(e), -2.0, 2.0), 1e-6) << e;
  });
}

// Force and torque sensors count the rods' mass (MuJoCo's cfrc_int counts rigid bodies only; the
// rods' proxies are massless). A rod of rigid sections on a hinged hub against the native body with
// its inertia: the sensors at the hub and at the rod's base agree at a moving state.
TEST(Sensors, ForceAndTorqueSensorsAboveARigidRodMatchTheNativeBody) {
  const double m = 1000.0 * M_PI * 0.01 * 0.01 * 0.3;
  const double ixx = 0.5 * m * 1e-4, iyy = 0.25 * m * 1e-4 + m * 0.09 / 12.0;
  const std::string head = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="j" type="hinge" axis="0.3 1 0"/>
      <inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/><site name="ft" pos="0.01 0 0.005" euler="0 30 0"/>)";
  const std::string tail = R"(</body></worldbody>
    <sensor><force site="ft"/><torque site="ft"/><force site="rb"/><torque site="rb"/></sensor></mujoco>)";
  const std::string rod =
      R"(<cosserat name="rod" pos="0.02 0 0" length="0.3" sections="3" strain="rigid" radius="0.01" density="1000">
      </cosserat><site name="rb" pos="0.02 0 0"/>)";
  char native[512];
  std::snprintf(
      native, sizeof native,
      R"(<body name="rod" pos="0.02 0 0"><inertial pos="0.15 0 0" mass="%.17g" diaginertia="%.17g %.17g %.17g"/></body>
      <site name="rb" pos="0.02 0 0"/>)",
      m, ixx, iyy, iyy);
  auto sr = load_scene_string(head + rod + tail, "/tmp/cosserat_sensor_test.xml");
  auto sn = load_scene_string(head + native + tail, "/tmp/cosserat_sensor_test.xml");
  SceneData dr(*sr), dn(*sn);
  for (SceneData* sd : {&dr, &dn}) {
    sd->d->qpos[0] = 0.7;
    sd->d->qvel[0] = 2.0;
  }
  forward(*sr, dr);
  forward(*sn, dn);
  ASSERT_EQ(sr->m->nsensordata, 12);
  double scale = 0.0;
  for (int i = 0; i < 12; ++i) scale = std::max(scale, std::abs(dn.d->sensordata[i]));
  EXPECT_GT(scale, 0.3);  // the rod's weight and swing: about 1 N
  for (int i = 0; i < 12; ++i) EXPECT_NEAR(dr.d->sensordata[i], dn.d->sensordata[i], 1e-9 * scale) << i;
}

// A rod hanging at rest (a soft one at static equilibrium, a rigid one) with a tip weight: a force
// sensor reads the weight of everything beyond it, a torque sensor its moment about the site (the
// rod's weight along its centre line, the tip body at its centre of mass), at the hub, at the rod's
// base, at a section boundary and inside a section.
TEST(Sensors, ForceAndTorqueSensorsOnAHangingRodReadTheWeightBeyondThem) {
  for (const std::string strain : {"kl", "rigid"}) {
    SCOPED_TRACE(strain);
    std::string xml = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
  <body name="hub" pos="0 0 1"><geom type="sphere" size="0.02" mass="0.2" contype="0" conaffinity="0"/>
    <site name="hub_s" pos="0.005 0 0"/>
    <cosserat name="arm" pos="0.02 0 0" length="0.3" sections="3" strain="kl" radius="0.01" density="1000" young="2e6"
              contype="0" conaffinity="0">
      <site name="x0" at="0"/><site name="x10" at="0.1" pos="0 0.003 0.004"/><site name="x15" at="0.15"/>
      <body name="weight"><geom type="sphere" pos="0.01 0 0" size="0.01" mass="0.03" contype="0" conaffinity="0"/></body>
    </cosserat></body></worldbody>
  <sensor><force site="hub_s"/><torque site="hub_s"/><force site="x0"/><torque site="x0"/>
    <force site="x10"/><torque site="x10"/><force site="x15"/><torque site="x15"/></sensor>
</mujoco>)";
    xml.replace(xml.find("strain=\"kl\""), 11, "strain=\"" + strain + "\"");
    auto s = load_scene_string(xml, "/tmp/cosserat_sensor_test.xml");
    const mjModel* m = s->m;
    SceneData sd(*s);
    if (m->nv > 0) ASSERT_TRUE(equilibrium(*s, sd).converged);
    forward(*s, sd);
    const mjData* d = sd.d;
    const RodBinding& rb = s->rods[0];
    const cosserat::Data& rd = sd.rod[0];
    const Vec3 up(0, 0, 9.81);
    const int weight = mj_name2id(m, mjOBJ_BODY, "weight");
    const Vec3 weight_com(d->xipos[3 * weight], d->xipos[3 * weight + 1], d->xipos[3 * weight + 2]);
    // (name, abscissa from which the rod counts; -1: all of it, and the hub's own mass too)
    const std::vector<std::pair<const char*, double>> sites = {{"hub_s", -1}, {"x0", 0.0}, {"x10", 0.1}, {"x15", 0.15}};
    int adr = 0;
    for (const auto& [name, X] : sites) {
      const int id = mj_name2id(m, mjOBJ_SITE, name);
      const Vec3 p = site_pos(d, id);
      Vec3 f = m->body_mass[weight] * up, tau = (weight_com - p).cross(m->body_mass[weight] * up);
      for (size_t k = 0; k < rb.model.nodes.size(); ++k) {
        const cosserat::Node& n = rb.model.nodes[k];
        if (n.X >= X) f += n.inertia(3, 3) * up;
      }
      // the moment of the rod's weight beyond X, integrated along its centre line (midpoint rule,
      // 3000 points): the continuum's, which the sensor reads between nodes too
      const double rhoA = 1000 * M_PI * 1e-4, X0 = std::max(X, 0.0), ds = (0.3 - X0) / 3000;
      for (int q = 0; q < 3000; ++q)
        tau += (rod_frame(*s, sd, 0, X0 + (q + 0.5) * ds).u - p).cross(rhoA * ds * up);
      if (X < 0) f += 0.2 * up;  // the hub's sphere, centred at the hub's origin
      if (X < 0) tau += (Vec3(0, 0, 1) - p).cross(0.2 * up);
      const Mat3 R = site_mat(d, id);
      const Vec3 f_got(d->sensordata + adr), tau_got(d->sensordata + adr + 3);
      adr += 6;
      EXPECT_LT((f_got - R.transpose() * f).norm(), 1e-6 * f.norm()) << name << ": " << f_got.transpose();
      // (the bent soft rod: the mass rule's two Gauss points per 0.1 m section against the continuum's
      // moment, 7e-6 of the hub's moment; the straight rigid rod: exact)
      const double tol = strain == "rigid" ? 1e-6 : 2e-5;
      EXPECT_LT((tau_got - R.transpose() * tau).norm(), tol * f.norm() * 0.3) << name << ": " << tau_got.transpose();
    }
  }
}

// Between mass nodes a force sensor reads the continuum's resultant (outside probe AN: counting the
// nodes at or beyond the site in full had read -3.8% to +7% off on a hanging rod): each node stands
// for the stretch its length weight lays end to end from the base, and the node whose stretch the
// site cuts counts in part (rod_wrench_beyond). A rod hanging at rest with a tip weight reads
// rho A g (L - X) + m g at any X, with the Gauss rule, Gauss-Lobatto's and GVS's; and a rod lying on
// a floor reads its weight beyond the site less the contacts beyond it (touch zones around every
// capsule end, where its contacts are), not those on the site's section before it (which had
// counted: 8-24% of the rod's weight).
TEST(Sensors, ForceSensorsBetweenMassNodesReadTheContinuumsResultant) {
  const double L = 0.5, rhoAg = 1000 * M_PI * 0.01 * 0.01 * 9.81;
  const std::vector<double> at = {0.03, 0.1, 0.17, 0.26, 0.31, 0.374, 0.44};
  std::string sites, sensors;
  for (size_t i = 0; i < at.size(); ++i) {
    sites += "<site name=\"f" + std::to_string(i) + "\" at=\"" + std::to_string(at[i]) + "\"/>";
    sensors += "<force site=\"f" + std::to_string(i) + "\"/>";
  }
  for (const char* rule : {"", "quadrature=\"lobatto\"", "order=\"2\""}) {
    SCOPED_TRACE(rule);
    auto s = load_scene_string(std::string(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
      <cosserat name="rod" pos="0 0 1" euler="0 90 0" length="0.5" sections="4" strain="kl" radius="0.01" density="1000"
                young="1e8" contype="0" conaffinity="0" )") + rule + ">" + sites + R"(
        <body name="w" pos="0.02 0 0"><geom type="sphere" size="0.02" mass="0.05" contype="0" conaffinity="0"/></body>
      </cosserat></worldbody><sensor>)" + sensors + "</sensor></mujoco>",
                               "/tmp/cosserat_sensor_test.xml");
    SceneData sd(*s);
    ASSERT_TRUE(equilibrium(*s, sd).converged);
    forward(*s, sd);
    for (size_t i = 0; i < at.size(); ++i) {
      const double expected = rhoAg * (L - at[i]) + 0.05 * 9.81;
      const Vec3 f(sd.d->sensordata + 3 * i);
      EXPECT_NEAR(f.norm(), expected, 1e-6 * expected) << "X = " << at[i];
    }
  }

  std::string zones, touches;
  for (int k = 0; k <= 8; ++k) {
    zones += "<site name=\"z" + std::to_string(k) + "\" at=\"" + std::to_string(k * L / 8) + "\" type=\"sphere\" size=\"0.02\"/>";
    touches += "<touch site=\"z" + std::to_string(k) + "\"/>";
  }
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/><worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="hub" pos="0 0 0.0099"><freejoint/><inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="rod" length="0.5" sections="4" strain="kl" radius="0.01" density="1000" young="1e6" viscosity="200">)" +
                                 zones + sites + "</cosserat></body></worldbody><sensor>" + touches + sensors +
                                 "</sensor></mujoco>",
                             "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  for (int k = 0; k < 2000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
  forward(*s, sd);
  const double* touch = sd.d->sensordata;
  double total = 0.0;
  for (int k = 0; k <= 8; ++k) total += touch[k];
  const double weight = rhoAg * L + 0.01 * 9.81;
  ASSERT_NEAR(total, weight, 1e-4 * weight);  // the zones hold every contact
  for (size_t i = 0; i < at.size(); ++i) {
    double beyond = 0.0;
    for (int k = 0; k <= 8; ++k)
      if (k * L / 8 > at[i]) beyond += touch[k];
    const Vec3 f(sd.d->sensordata + 9 + 3 * i);
    EXPECT_NEAR(f.z(), rhoAg * (L - at[i]) - beyond, 1e-3 * weight) << "X = " << at[i];
  }
}

// A rod accelerating through a site inside a section: the site reads the wrench of the motion of
// the part beyond it, not the node wrenches split in proportion to stretch (outside probe BQ: a rigid
// rod swinging on a hinge read 3.2x, 28%, 3.5% off at a site at its base with 1, 2, 4 sections, and
// 55% off in a force component at 0.1 m with 1 section). A rigid rod of length L on a hinge about y at
// its base, horizontal and turning at omega with angular acceleration alpha (the model's, read
// back): the part beyond X carries f = int_X^L lambda (a(s) - g) ds, a(s) = (-omega^2 s, 0, -alpha s),
// and the moment about the cut int_X^L (s - X) x_hat x lambda (a - g) ds plus the cross-sections'
// rotary inertia rho I (L - X) alpha, whatever the sections and the mass rule (both exact for this
// quadratic integrand). And on a soft rod bent and in motion, a site at a section's start reads
// what the rod's base site reads.
TEST(Sensors, ForceSensorsInsideASectionReadTheWrenchOfTheMotionBeyondThem) {
  const double L = 0.4, r = 0.01, rho = 1000, lambda = rho * M_PI * r * r, rhoI = rho * M_PI * r * r * r * r / 4;
  const double omega = 3.0, g = 9.81;
  const std::vector<double> at = {0.0, 0.07, 0.1, 0.2, 0.31};
  for (const char* variant : {"sections=\"1\"", "sections=\"2\"", "sections=\"3\"", "sections=\"3\" quadrature=\"lobatto\"",
                              "sections=\"2\" quadrature=\"3\""}) {
    SCOPED_TRACE(variant);
    std::string sites, sensors;
    for (size_t i = 0; i < at.size(); ++i) {
      sites += "<site name=\"s" + std::to_string(i) + "\" at=\"" + std::to_string(at[i]) + "\"/>";
      sensors += "<force site=\"s" + std::to_string(i) + "\"/><torque site=\"s" + std::to_string(i) + "\"/>";
    }
    auto s = load_scene_string(std::string(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
      <body name="hub" pos="0 0 1"><joint name="sh" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
        <cosserat name="r" length="0.4" strain="rigid" radius="0.01" density="1000" contype="0" conaffinity="0" )") +
                                   variant + ">" + sites + "</cosserat></body></worldbody><sensor>" + sensors +
                                   "</sensor></mujoco>",
                               "/tmp/cosserat_sensor_test.xml");
    SceneData sd(*s);
    ASSERT_EQ(s->m->nv, 1);
    sd.d->qvel[0] = omega;
    forward(*s, sd);
    const double alpha = sd.d->qacc[0];
    ASSERT_GT(std::abs(alpha), 10.0);  // the rod's weight turns it: about 36 rad/s^2
    for (size_t i = 0; i < at.size(); ++i) {
      const double X = at[i];
      // int_X^L s^k ds
      auto I = [&](int k) { return (std::pow(L, k + 1) - std::pow(X, k + 1)) / (k + 1); };
      const Vec3 f(lambda * -omega * omega * I(1), 0.0, lambda * (-alpha * I(1) + g * (L - X)));
      // (s - X) x_hat x (a - g) = (s - X) (0, -(a - g)_z, (a - g)_y)
      const Vec3 tau(0.0, -lambda * (-alpha * (I(2) - X * I(1)) + g * (I(1) - X * (L - X))) + rhoI * (L - X) * alpha, 0.0);
      const int id = mj_name2id(s->m, mjOBJ_SITE, ("s" + std::to_string(i)).c_str());
      const Mat3 R = site_mat(sd.d, id);
      const Vec3 f_got(sd.d->sensordata + 6 * i), tau_got(sd.d->sensordata + 6 * i + 3);
      EXPECT_LT((f_got - R.transpose() * f).norm(), 1e-9 * lambda * L * g) << "X = " << X << ": " << f_got.transpose();
      EXPECT_LT((tau_got - R.transpose() * tau).norm(), 1e-9 * lambda * L * L * g) << "X = " << X << ": " << tau_got.transpose();
    }
  }

  // a soft rod, bent and moving (cosserat::testing::BentMotion): a site at a section's start (at 0
  // and at 0.1) against the rod's base site and against a site a hair beyond the section start
  on_pcs_and_gvs(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
  <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
    <cosserat name="arm" pos="0.02 0 0" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
      <site name="a0" at="0"/><site name="a1" at="0.1"/><site name="a1p" at="0.1000000001"/>
    </cosserat></body></worldbody>
  <sensor><force site="arm/base"/><torque site="arm/base"/><force site="a0"/><torque site="a0"/>
    <force site="a1"/><torque site="a1"/><force site="a1p"/><torque site="a1p"/></sensor>
</mujoco>)",
                 [](const Scene& s, SceneData& sd, const cosserat::testing::BentMotion& motion) {
                   motion.at(s, sd, 0.0);
                   const double* v = sd.d->sensordata;
                   double scale = 0.0;
                   for (int e = 0; e < 24; ++e) scale = std::max(scale, std::abs(v[e]));
                   ASSERT_GT(scale, 0.1);
                   for (int e = 0; e < 6; ++e) EXPECT_NEAR(v[6 + e], v[e], 1e-12 * scale) << e;
                   for (int e = 0; e < 6; ++e) EXPECT_NEAR(v[18 + e], v[12 + e], 1e-6 * scale) << e;
                 });
}

// Sensor noise (<flag sensornoise="enable"/>) on the sensors the step evaluates again for rods: the
// noisy twin of a clean sensor differs from it by Gaussian noise of the given deviation (outside
// probe AN: the noise had been dropped from them, and from every force sensor of a scene with rods);
// a noisy quaternion stays a unit quaternion.
TEST(Sensors, NoiseIsAddedToTheSensorsTheRodsEvaluateAgain) {
  auto s = load_scene_string(R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"><flag sensornoise="enable"/></option>
    <worldbody><cosserat name="rod" pos="0 0 1" length="0.3" sections="3" strain="kl" radius="0.01" young="1e6"
      viscosity="50" contype="0" conaffinity="0"><site name="s" at="0.2"/></cosserat></worldbody>
    <sensor><velocimeter site="s"/><velocimeter site="s" noise="0.1"/><force site="s"/><force site="s" noise="0.1"/>
      <framequat objtype="site" objname="s"/><framequat objtype="site" objname="s" noise="0.1"/>
      <velocimeter site="s" noise="0.1" cutoff="0.05"/></sensor></mujoco>)",
                             "/tmp/cosserat_sensor_test.xml");
  SceneData sd(*s);
  const mjModel* m = s->m;
  double sum2[3] = {0, 0, 0};  // velocimeter, force, quaternion angle
  const int n = 400;
  for (int k = 0; k < n; ++k) {
    ASSERT_EQ(step(*s, sd), Status::Ok);
    const double* v = sd.d->sensordata;
    for (int e = 0; e < 3; ++e) {
      sum2[0] += std::pow(v[3 + e] - v[e], 2) / 3;
      sum2[1] += std::pow(v[9 + e] - v[6 + e], 2) / 3;
    }
    for (int e = 0; e < 3; ++e) EXPECT_LE(std::abs(v[20 + e]), 0.05);  // the noise, then the cutoff (as MuJoCo)
    const Eigen::Quaterniond q0(v[12], v[13], v[14], v[15]), q1(v[16], v[17], v[18], v[19]);
    EXPECT_NEAR(q1.norm(), 1.0, 1e-12);
    sum2[2] += std::pow(q0.angularDistance(q1), 2);
  }
  EXPECT_EQ(m->sensor_noise[1], 0.1);
  for (int c = 0; c < 2; ++c) {  // deviation 0.1 per value, from 1200 samples: within 10%
    const double sd_got = std::sqrt(sum2[c] / n);
    EXPECT_GT(sd_got, 0.09) << c;
    EXPECT_LT(sd_got, 0.11) << c;
  }
  // a rotation by a Gaussian angle of deviation 0.1: RMS angle 0.1 (400 samples)
  EXPECT_GT(std::sqrt(sum2[2] / n), 0.085);
  EXPECT_LT(std::sqrt(sum2[2] / n), 0.115);
}

// A free hub (the scene's head, its body left open) and a weight for a rod's tip.
const char* kFreeHub = R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><freejoint/><inertial pos="0.01 0 0" mass="0.05" diaginertia="1e-5 2e-5 3e-5"/>)";
const char* kTipWeight = R"(<body name="weight"><geom type="sphere" pos="0.01 0 0" size="0.01" mass="0.03"/></body>)";

// The sensors of a scene with a rigid rod against those of its native twin, a free hub moving and
// turned (its first 7 qpos, 6 qvel), to 1e-9.
void expect_sensors_as_native(const std::string& rod_xml, const std::string& native_xml, int nsensordata) {
  auto sr = load_scene_string(rod_xml, "/tmp/cosserat_sensor_test.xml");
  auto sn = load_scene_string(native_xml, "/tmp/cosserat_sensor_test.xml");
  SceneData dr(*sr), dn(*sn);
  const double qvel[6] = {0.1, -0.2, 0.3, 1.0, 2.0, -0.5};
  for (SceneData* sd : {&dr, &dn}) {
    sd->d->qpos[3] = std::cos(0.3);
    sd->d->qpos[5] = std::sin(0.3);
    for (int i = 0; i < 6; ++i) sd->d->qvel[i] = qvel[i];
  }
  forward(*sr, dr);
  forward(*sn, dn);
  ASSERT_EQ(sr->m->nsensordata, nsensordata);
  for (int i = 0; i < nsensordata; ++i) {
    const double ref = dn.d->sensordata[i];
    EXPECT_NEAR(dr.d->sensordata[i], ref, 1e-9 * std::max(1.0, std::abs(ref))) << i;
  }
}

// Subtree sensors count the rods' mass: a rigid rod (with a weight at its tip) on a free hub against
// the native body with its inertia, at a moving state, for the hub's and the world's subtrees.
TEST(Sensors, SubtreeSensorsCountTheRodLikeTheNativeBody) {
  const double m = 1000.0 * M_PI * 0.01 * 0.01 * 0.3;
  const double ixx = 0.5 * m * 1e-4, iyy = 0.25 * m * 1e-4 + m * 0.09 / 12.0;
  const std::string head = kFreeHub, tip = kTipWeight;
  const std::string tail = R"(</body></worldbody><sensor>
    <subtreecom body="hub"/><subtreelinvel body="hub"/><subtreeangmom body="hub"/>
    <subtreecom body="world"/><subtreelinvel body="world"/><subtreeangmom body="world"/>
    <subtreeangmom body="weight"/></sensor></mujoco>)";
  const std::string rod =
      R"(<cosserat name="rod" pos="0.02 0 0" length="0.3" sections="3" strain="rigid" radius="0.01" density="1000">)" +
      tip + "</cosserat>";
  char native[512];
  std::snprintf(
      native, sizeof native,
      R"(<body name="rod" pos="0.02 0 0"><inertial pos="0.15 0 0" mass="%.17g" diaginertia="%.17g %.17g %.17g"/>
      <body name="tipframe" pos="0.3 0 0">%s</body></body>)",
      m, ixx, iyy, iyy, tip.c_str());
  expect_sensors_as_native(head + rod + tail, head + native + tail, 21);
}

// Subtree sensors on a section's proxy count the rod beyond the section's end (the proxies stand at
// the sections' ends, the rest of the rod hanging below them), as a native chain of one body per
// section counts its later bodies: with the Gauss rule and with Gauss-Lobatto's, whose node at a
// section's end is shared by both sections (outside probe BP: they had counted no rod at all).
TEST(Sensors, SubtreeSensorsOnASectionCountTheRodBeyondIt) {
  const double m = 1000.0 * M_PI * 0.01 * 0.01 * 0.1;  // a section's
  const double ixx = 0.5 * m * 1e-4, iyy = 0.25 * m * 1e-4 + m * 0.01 / 12.0;
  const std::string head = kFreeHub, tip = kTipWeight;
  const std::string tail = R"(</body></worldbody><sensor>
    <subtreecom body="S0"/><subtreelinvel body="S0"/><subtreeangmom body="S0"/>
    <subtreecom body="S1"/><subtreelinvel body="S1"/><subtreeangmom body="S1"/>
    <subtreecom body="S2"/><subtreelinvel body="S2"/><subtreeangmom body="S2"/></sensor></mujoco>)";
  char section[256];
  std::snprintf(section, sizeof section, R"(<inertial pos="0.05 0 0" mass="%.17g" diaginertia="%.17g %.17g %.17g"/>)", m,
                ixx, iyy, iyy);
  const std::string native = std::string(R"(<body name="rod" pos="0.02 0 0">)") + section + R"(<body name="p1" pos="0.1 0 0">)" +
                             section + R"(<body name="p2" pos="0.1 0 0">)" + section + R"(<body name="p3" pos="0.1 0 0">)" +
                             tip + "</body></body></body></body>";
  for (const char* rule : {"", R"( quadrature="lobatto")"}) {
    SCOPED_TRACE(rule);
    const std::string rod = std::string(R"(<cosserat name="rod" pos="0.02 0 0" length="0.3" sections="3" strain="rigid" )") +
                            R"(radius="0.01" density="1000")" + rule + ">" + tip + "</cosserat>";
    expect_sensors_as_native(
        replace_all(replace_all(replace_all(head + rod + tail, "S0", "rod/s0"), "S1", "rod/s1"), "S2", "rod/s2"),
        replace_all(replace_all(replace_all(head + native + tail, "S0", "p1"), "S1", "p2"), "S2", "p3"), 27);
  }
}

}  // namespace
