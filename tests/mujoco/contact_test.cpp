// Rod contacts through MuJoCo's constraint solver (plugin/mujoco/scene.cpp: patch_contacts,
// patch_contact_references): contact rows against finite-difference velocities of the material
// contact points, their reference accelerations against second differences, dense against sparse
// Jacobians, and resting/friction physics against Newton and Coulomb.
#include "scene.hpp"
#include "scene_statics.hpp"
#include "support/text_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "kinematics.hpp"
#include "support/material_point.hpp"

using namespace cosserat;
using namespace cosserat::mj;
using cosserat::testing::contact_point;
using cosserat::testing::material_pose;
using cosserat::testing::MaterialPoint;

namespace {

const char* kPath = "/tmp/cosserat_contact_test.xml";

using cosserat::testing::full_precision;
using cosserat::testing::replace_all;

// A soft rod on a free body, near a plane.
const char* kScene = R"(<mujoco>
  <option timestep="0.0005" gravity="0 0 -9.81" cone="CONE" jacobian="JAC" solver="SOLVER"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1" friction="MU 0.005 0.0001" condim="CONDIM"/>
    <body name="hub" pos="0 0 HEIGHT"><freejoint/>
      <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="rod" pos="0.0 0 0" length="0.3" sections="4" strain="kl" radius="0.01" density="1000"
                young="YOUNG" viscosity="VISC" condim="CONDIM" friction="MU 0.005 0.0001" capsules="3"/>
    </body>
  </worldbody>
</mujoco>)";

std::string scene(const char* cone, const char* jac, int condim, double height, double visc = 5.0,
                  double mu = 0.5, const char* solver = "Newton", double young = 2e5) {
  std::string x = kScene;
  x = replace_all(x, "YOUNG", std::to_string(young));
  x = replace_all(x, "CONE", cone);
  x = replace_all(x, "JAC", jac);
  x = replace_all(x, "SOLVER", solver);
  x = replace_all(x, "CONDIM", std::to_string(condim));
  x = replace_all(x, "HEIGHT", std::to_string(height));
  x = replace_all(x, "VISC", std::to_string(visc));
  return replace_all(x, "MU", std::to_string(mu));
}

// A bent, tilted rod pressed into the floor (the scene at height 0.005), moving with speed scale
// `speed`, after forward: the state of the row checks below.
void bend_and_move(const Scene& s, SceneData& sd, double speed) {
  for (int k = 0; k < s.rods[0].model.nv; ++k) sd.d->qpos[s.rods[0].qpos0 + k] = 0.15 * std::sin(1.0 + 2.3 * k);
  for (int k = 0; k < s.m->nv; ++k) sd.d->qvel[k] = speed * std::cos(0.7 + 1.9 * k);
  forward(s, sd);
}

// efc_vel = efc_J qvel (MuJoCo's own product, dense or sparse) against the relative velocity of
// the touching material point, by central differences along qvel.
void check_contact_rows(const char* cone, const char* jac, int condim) {
  SCOPED_TRACE(std::string(cone) + " " + jac + " condim " + std::to_string(condim));
  auto s = load_scene_string(scene(cone, jac, condim, 0.005), kPath);
  SceneData sd(*s);
  const mjModel* m = s->m;
  bend_and_move(*s, sd, 0.3);
  ASSERT_GT(sd.d->ncon, 0);
  const double e = 1e-6;
  std::vector<mjtNum> qp(sd.d->qpos, sd.d->qpos + m->nq), qm = qp;
  mj_integratePos(m, qp.data(), sd.d->qvel, e);
  mj_integratePos(m, qm.data(), sd.d->qvel, -e);
  int checked = 0;
  for (int i = 0; i < sd.d->ncon; ++i) {
    const mjContact& con = sd.d->contact[i];
    if (con.efc_address < 0) continue;
    const bool rod_is_2 = s->geom_rod[con.geom2] >= 0;
    const int g = rod_is_2 ? con.geom2 : con.geom1;
    ASSERT_GE(s->geom_rod[g], 0);
    const MaterialPoint mp = contact_point(*s, sd, con, g);
    const SE3 gp = material_pose(*s, qp, mp), gm = material_pose(*s, qm, mp);
    Vec3 v = (gp.u - gm.u) / (2 * e);
    Vec3 w = unskew(gp.R * gm.R.transpose()) / (2 * e);  // world angular velocity
    if (!rod_is_2) v = -v, w = -w;  // relative velocity: body2 - body1 (the floor is at rest)
    Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(con.frame);
    Eigen::Matrix<double, 6, 1> rel;
    rel << frame * v, frame * w;  // normal, t1, t2, spin, roll1, roll2
    const double* ev = sd.d->efc_vel + con.efc_address;
    // central differences: O(e^2) truncation, eps/e round-off: sqrt-eps level on m/s values
    const double tol = 1e-7;
    if (std::string(cone) == "pyramidal" && con.dim > 1) {
      for (int j = 1; j < con.dim; ++j) {
        EXPECT_NEAR(ev[2 * (j - 1)], rel(0) + con.friction[j - 1] * rel(j), tol) << "contact " << i << " edge " << j;
        EXPECT_NEAR(ev[2 * (j - 1) + 1], rel(0) - con.friction[j - 1] * rel(j), tol) << "contact " << i << " edge " << j;
      }
    } else {
      for (int j = 0; j < con.dim; ++j) EXPECT_NEAR(ev[j], rel(j), tol) << "contact " << i << " row " << j;
    }
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(Contact, RowsGiveMaterialPointVelocities) {
  for (const char* jac : {"dense", "sparse"})
    for (const char* cone : {"elliptic", "pyramidal"})
      for (int condim : {1, 3, 4, 6}) check_contact_rows(cone, jac, condim);
}

// The rows' reference acceleration on a soft section (patch_contact_references): MuJoCo's aref
// minus the velocity product of the point riding with the cross-section, i.e. the acceleration at
// qacc = 0 of the centre-line point under the contact plus the cross-section's angular acceleration
// crossed with the offset to the contact (its centripetal term left out). Against second
// differences of the centre-line point and of the cross-section's rotation along q + t qvel.
void check_contact_references(const char* cone) {
  SCOPED_TRACE(cone);
  auto s = load_scene_string(scene(cone, "dense", 3, 0.005), kPath);
  SceneData sd(*s);
  const mjModel* m = s->m;
  bend_and_move(*s, sd, 3.0);
  ASSERT_GT(sd.d->ncon, 0);
  const std::vector<mjtNum> aref(sd.d->efc_aref, sd.d->efc_aref + sd.d->nefc);
  mj_referenceConstraint(m, sd.d);  // MuJoCo's own reference accelerations, from the same rows
  const double e = 1e-4;
  std::vector<mjtNum> q0(sd.d->qpos, sd.d->qpos + m->nq), qp = q0, qm = q0;
  mj_integratePos(m, qp.data(), sd.d->qvel, e);
  mj_integratePos(m, qm.data(), sd.d->qvel, -e);
  // the touching points first: material_pose runs other configurations through the model, whose
  // capsule sizes (geom_size, which contact_point reads) follow the state
  std::vector<MaterialPoint> centres;
  std::vector<Vec3> offsets;  // world: centre line to contact
  for (int i = 0; i < sd.d->ncon; ++i) {
    const mjContact& con = sd.d->contact[i];
    const int g = s->geom_rod[con.geom2] >= 0 ? con.geom2 : con.geom1;
    ASSERT_GE(s->geom_rod[g], 0);
    MaterialPoint c = contact_point(*s, sd, con, g);
    offsets.push_back(rod_pose(s->rods[0].model, sd.rod[0], 0, c.X).R * c.offset);
    c.offset.setZero();
    centres.push_back(c);
  }
  double largest = 0.0;
  for (int i = 0; i < sd.d->ncon; ++i) {
    const mjContact& con = sd.d->contact[i];
    const bool rod_is_2 = s->geom_rod[con.geom2] >= 0;
    const MaterialPoint& centre = centres[i];
    const Vec3& r = offsets[i];
    const SE3 g0 = material_pose(*s, q0, centre), gp = material_pose(*s, qp, centre), gm = material_pose(*s, qm, centre);
    const Vec3 a_centre = (gp.u - 2.0 * g0.u + gm.u) / (e * e);
    const Vec3 w_after = unskew(gp.R * g0.R.transpose()) / e, w_before = unskew(g0.R * gm.R.transpose()) / e;
    const Vec3 alpha = (w_after - w_before) / e;
    Vec3 c = a_centre + alpha.cross(r);
    if (!rod_is_2) c = -c;  // relative: body2 - body1 (the floor is at rest)
    Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(con.frame);
    const Vec3 cf = frame * c;  // normal, t1, t2
    largest = std::max(largest, std::abs(cf(0)));
    const int a = con.efc_address;
    const double tol = 1e-6 * (1.0 + c.norm());  // second differences: O(e^2) and eps/e^2
    if (std::string(cone) == "pyramidal") {
      for (int j = 1; j < 3; ++j) {
        EXPECT_NEAR(sd.d->efc_aref[a + 2 * (j - 1)] - aref[a + 2 * (j - 1)], cf(0) + con.friction[j - 1] * cf(j), tol)
            << "contact " << i << " edge " << j;
        EXPECT_NEAR(sd.d->efc_aref[a + 2 * (j - 1) + 1] - aref[a + 2 * (j - 1) + 1], cf(0) - con.friction[j - 1] * cf(j), tol)
            << "contact " << i << " edge " << j;
      }
    } else {
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(sd.d->efc_aref[a + j] - aref[a + j], cf(j), tol) << "contact " << i << " row " << j;
    }
  }
  EXPECT_GT(largest, 1.0);  // m/s^2: the term is not negligible at these rates
}

TEST(Contact, SoftSectionRowsReferenceTheCrossSectionsAcceleration) {
  check_contact_references("pyramidal");
  check_contact_references("elliptic");
}

// A geom on a body below a soft rod (a ball at the tip) rides with the rod's tip cross-section: its
// contacts' reference accelerations get the velocity product of the ball's centre, a material point
// riding with the tip, and its angular acceleration crossed with the offset to the contact (the
// offset's centripetal term left out: a round geom keeps its centre's distance to the floor),
// against second differences of the tip body's frame along q + t qvel (the point's acceleration
// there, less the centripetal term of its offset from the ball's centre; until the forty-sixth
// session the offset was taken from the tip's centre line).
TEST(Contact, GeomsBelowASoftRodReferenceTheTipsAcceleration) {
  auto s = load_scene_string(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="hub" pos="0 0 0.1" euler="0 30 0"><freejoint/>
      <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="rod" length="0.2" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
        <body name="tipb" pos="0.01 0.005 0"><geom name="ball" type="sphere" size="0.02"/></body>
      </cosserat></body></worldbody></mujoco>)", kPath);
  SceneData sd(*s);
  const mjModel* m = s->m;
  const int b = mj_name2id(m, mjOBJ_BODY, "tipb");
  for (int k = 0; k < s->rods[0].model.nv; ++k) sd.d->qpos[s->rods[0].qpos0 + k] = 0.3 * std::sin(1.0 + 2.3 * k);
  for (int k = 0; k < m->nv; ++k) sd.d->qvel[k] = 3.0 * std::cos(0.7 + 1.9 * k);
  forward(*s, sd);
  ASSERT_GT(sd.d->ncon, 0);
  const mjContact con = sd.d->contact[0];
  ASSERT_EQ(m->geom_bodyid[con.geom2], b);
  const std::vector<mjtNum> aref(sd.d->efc_aref, sd.d->efc_aref + sd.d->nefc);
  mj_referenceConstraint(m, sd.d);
  const std::vector<mjtNum> q0(sd.d->qpos, sd.d->qpos + m->nq);
  const std::vector<mjtNum> v(sd.d->qvel, sd.d->qvel + m->nv);
  const Vec3 p(con.pos[0], con.pos[1], con.pos[2]);
  // the tip body's frame at q0 (+) t v, and the rod's tip centre at q0
  const double e = 1e-4;
  auto frame_at = [&](double t, Vec3& x, Mat3& R) {
    SceneData sdt(*s);
    std::vector<mjtNum> q = q0;
    mj_integratePos(m, q.data(), v.data(), t);
    mju_copy(sdt.d->qpos, q.data(), m->nq);
    fwd_position(*s, sdt);
    x = Vec3(sdt.d->xpos[3 * b], sdt.d->xpos[3 * b + 1], sdt.d->xpos[3 * b + 2]);
    R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(sdt.d->xmat + 9 * b);
  };
  Vec3 x[5];
  Mat3 R[5];
  for (int k = 0; k < 5; ++k) frame_at((k - 2) * e, x[k], R[k]);
  // (a Vec3, not Eigen's expression, which would refer to unskew's temporary after the return)
  auto spin = [&](int k) -> Vec3 { return unskew(R[k + 1] * R[k - 1].transpose()) / (2 * e); };
  const Vec3 w = spin(2);
  const Vec3 offset = R[2].transpose() * (p - x[2]);  // the contact point in the body's frame
  const Vec3 a_point = (x[3] + R[3] * offset - 2.0 * p + x[1] + R[1] * offset) / (e * e);
  const Vec3 c = a_point - w.cross(w.cross(p - x[2]));  // the offset from the ball's centre (the body's origin)
  Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(con.frame);
  const Vec3 cf = frame * c;
  const int a = con.efc_address;
  for (int j = 1; j < 3; ++j) {
    EXPECT_NEAR(sd.d->efc_aref[a + 2 * (j - 1)] - aref[a + 2 * (j - 1)], cf(0) + con.friction[j - 1] * cf(j), 1e-6 * (1 + c.norm()));
    EXPECT_NEAR(sd.d->efc_aref[a + 2 * (j - 1) + 1] - aref[a + 2 * (j - 1) + 1], cf(0) - con.friction[j - 1] * cf(j), 1e-6 * (1 + c.norm()));
  }
  EXPECT_GT(std::abs(cf(0)), 0.05);  // m/s^2: five orders above the tolerance
}

// A ball on a soft rod's tip, carried by a turning table, pressing on a wall of the table (outside
// probe BI): the contact row's reference takes the gap's second derivative at qacc = 0, both sides'
// accelerations and the turning of the wall's normal (the ball's centre keeps its distance from
// the wall's face), against second differences of MuJoCo's contact distance along q + t qvel; and
// the ball settles as deep as with the rod's last section rigid (MuJoCo's rows; the rest of the
// depth beyond the rigid rod's is the soft rod's inverse weight), where the soft side's term alone
// had sunk it 12.6 mm.
std::string turntable(const char* last_section) {
  return std::string(R"(<mujoco><option timestep="0.0005" gravity="0 0 0"><flag filterparent="disable"/></option><worldbody>
    <body name="tt" pos="0 0 0.1"><joint name="spin" axis="0 0 1"/><inertial pos="0 0 0" mass="10" diaginertia="1 1 1"/>
      <geom name="wall" type="box" pos="0.4 0 0" size="0.05 0.1 0.1" mass="0.1"/>
      <body name="car"><joint name="sl" type="slide" axis="1 0 0"/><inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/>
        <cosserat name="arm" length="0.3" strain="kl" radius="0.008" density="1000" young="1e11" contype="0" conaffinity="0">
          <section/><section/><section/><section strain=")") + last_section + R"("/>
          <body name="ball"><geom name="bg" type="sphere" size="0.05" mass="0.2"/></body>
        </cosserat></body></body></worldbody>
    <actuator><velocity name="v" joint="spin" kv="20"/></actuator></mujoco>)";
}

TEST(Contact, ABallOnASoftRodPressingOnATurningWallReferencesTheGapsAcceleration) {
  auto s = load_scene_string(turntable("kl"), kPath);
  SceneData sd(*s);
  const mjModel* m = s->m;
  for (int k = 0; k < s->rods[0].model.nv; ++k) sd.d->qpos[s->rods[0].qpos0 + k] = 0.02 * std::sin(1.0 + 2.3 * k);
  sd.d->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "sl")]] = 0.002;  // 2 mm into the wall
  for (int k = 0; k < m->nv; ++k) sd.d->qvel[k] = std::cos(0.7 + 1.9 * k);
  sd.d->qvel[m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "spin")]] = 10.0;
  forward(*s, sd);
  ASSERT_EQ(sd.d->ncon, 1);
  const mjContact con = sd.d->contact[0];
  const std::vector<mjtNum> aref(sd.d->efc_aref, sd.d->efc_aref + sd.d->nefc);
  mj_referenceConstraint(m, sd.d);
  const std::vector<mjtNum> q0(sd.d->qpos, sd.d->qpos + m->nq), v(sd.d->qvel, sd.d->qvel + m->nv);
  const int ball = mj_name2id(m, mjOBJ_BODY, "ball");
  Vec3 centre[3];
  auto dist_at = [&](double t) {
    SceneData sdt(*s);
    mju_copy(sdt.d->qpos, q0.data(), m->nq);
    mj_integratePos(m, sdt.d->qpos, v.data(), t);
    mju_copy(sdt.d->qvel, v.data(), m->nv);
    forward(*s, sdt);
    EXPECT_EQ(sdt.d->ncon, 1);
    centre[t > 0 ? 2 : t < 0 ? 0 : 1] = Vec3(sdt.d->xpos + 3 * ball);
    return sdt.d->ncon ? sdt.d->contact[0].dist : 0.0;
  };
  auto second = [&](double e) { return (dist_at(e) - 2.0 * dist_at(0.0) + dist_at(-e)) / (e * e); };
  const double gap = (4 * second(5e-5) - second(1e-4)) / 3;  // (Richardson)
  // the ball's own acceleration along the normal, the soft side's term alone: the table's turning
  const Vec3 n(con.frame[0], con.frame[1], con.frame[2]);
  const double ball_alone = n.dot(centre[2] - 2.0 * centre[1] + centre[0]) / (1e-4 * 1e-4);
  // the normal row (pyramidal: each edge row holds it plus friction times a tangent's)
  const int a = con.efc_address;
  const double normal = 0.5 * ((aref[a] - sd.d->efc_aref[a]) + (aref[a + 1] - sd.d->efc_aref[a + 1]));
  EXPECT_NEAR(-normal, gap, 1e-5 * (1 + std::abs(gap)));
  EXPECT_GT(std::abs(ball_alone), 100 * std::abs(gap));  // (about 30 m/s^2, against 3e-3)
  // settled against the wall at 10 rad/s: as deep as with a rigid last section
  auto depth = [&](const char* last) {
    auto t = load_scene_string(turntable(last), kPath);
    SceneData st(*t);
    st.d->ctrl[0] = 10;
    for (int k = 0; k < 3000; ++k) EXPECT_EQ(step(*t, st), Status::Ok);
    return st.d->qpos[t->m->jnt_qposadr[mj_name2id(t->m, mjOBJ_JOINT, "sl")]];
  };
  const double soft = depth("kl"), control = depth("rigid");
  EXPECT_GT(control, 5e-4);
  EXPECT_NEAR(soft, control, 0.1 * control);
}

// The normal rows of contacts with a soft rod's side, against Richardson second differences of
// MuJoCo's contact distances along q + t qvel (outside probe BJ): a sphere on a slide of a turning
// table pressing on the side of a stiff rod lying on the table (point on a line, turning together:
// the relative acceleration of the anchors, omega^2 d along the normal, is cancelled by the turning
// of the line; it had been taken alone), and an ellipsoid spinning on two soft rails (a curved
// surface whose contact point is no material point: MuJoCo's rule, nothing from the ellipsoid; it
// had been taken as a face's material point, its centripetal term braking a rolling ellipsoid).
TEST(Contact, RowsOnARodsSideReferenceTheGapsAcceleration) {
  struct Case {
    const char* name;
    std::string xml;
    std::vector<double> qvel;  // (empty: the table's motor only)
    double largest_wrong;      // what a term left out or taken wrongly would add, m/s^2
  };
  const std::vector<Case> cases = {
      {"sphere on a turning rod", R"(<mujoco><option gravity="0 0 0" cone="elliptic"><flag filterparent="disable"/></option><worldbody>
        <body name="tt" pos="0 0 0.1"><joint name="spin" axis="0 0 1"/><inertial pos="0 0 0" mass="10" diaginertia="1 1 1"/>
          <cosserat name="arm" length="0.4" sections="4" strain="kl" radius="0.008" density="1000" young="1e11"/>
          <body name="bb" pos="0.25 0.057 0"><joint name="ys" type="slide" axis="0 1 0"/>
            <geom name="ball" type="sphere" size="0.05" mass="0.2"/></body></body></worldbody></mujoco>)",
       {}, 5.0},
      {"ellipsoid spinning on rails", R"(<mujoco><option cone="elliptic"/><worldbody>
        <body name="w" pos="-0.1 0 0.0475" euler="90 0 0"><freejoint/>
          <geom name="e" condim="1" type="ellipsoid" size="0.05 0.05 0.03" mass="0.3"/></body>
        <cosserat name="r1" pos="-0.2 0.025 0.0101" length="0.6" sections="6" strain="kl" radius="0.01" young="1e9" condim="1"/>
        <cosserat name="r2" pos="-0.2 -0.025 0.0101" length="0.6" sections="6" strain="kl" radius="0.01" young="1e9" condim="1"/>
        </worldbody></mujoco>)",
       {0, 0, 0, 0, 0, -20}, 10.0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    auto s = load_scene_string(c.xml, kPath);
    SceneData sd(*s);
    const mjModel* m = s->m;
    if (c.qvel.empty()) sd.d->qvel[0] = 10.0;  // the table turning at 10 rad/s
    for (size_t k = 0; k < c.qvel.size(); ++k) sd.d->qvel[k] = c.qvel[k];
    forward(*s, sd);
    ASSERT_GT(sd.d->ncon, 0);
    const std::vector<mjtNum> ours(sd.d->efc_aref, sd.d->efc_aref + sd.d->nefc);
    std::vector<mjContact> contacts(sd.d->contact, sd.d->contact + sd.d->ncon);
    mj_referenceConstraint(m, sd.d);
    const std::vector<mjtNum> mujocos(sd.d->efc_aref, sd.d->efc_aref + sd.d->nefc);
    const std::vector<mjtNum> q0(sd.d->qpos, sd.d->qpos + m->nq), v(sd.d->qvel, sd.d->qvel + m->nv);
    auto dists_at = [&](double t) {  // the same geom pairs' distances
      SceneData sdt(*s);
      mju_copy(sdt.d->qpos, q0.data(), m->nq);
      mj_integratePos(m, sdt.d->qpos, v.data(), t);
      mju_copy(sdt.d->qvel, v.data(), m->nv);
      forward(*s, sdt);
      std::vector<double> out;
      for (const mjContact& con : contacts) {
        double dist = std::nan("");
        for (int i = 0; i < sdt.d->ncon; ++i)
          if (sdt.d->contact[i].geom1 == con.geom1 && sdt.d->contact[i].geom2 == con.geom2) dist = sdt.d->contact[i].dist;
        out.push_back(dist);
      }
      return out;
    };
    auto second = [&](double e) {
      const auto p = dists_at(e), z = dists_at(0.0), n = dists_at(-e);
      std::vector<double> out;
      for (size_t i = 0; i < p.size(); ++i) out.push_back((p[i] - 2 * z[i] + n[i]) / (e * e));
      return out;
    };
    const auto fine = second(5e-5), coarse = second(1e-4);
    int checked = 0;
    for (size_t i = 0; i < contacts.size(); ++i) {
      const mjContact& con = contacts[i];
      // a contact's distance is smooth where it stays on one capsule, away from the capsules' ends
      if (!std::isfinite(fine[i]) || !std::isfinite(coarse[i]) || std::abs(fine[i] - coarse[i]) > 1e-3) continue;
      const double gap = (4 * fine[i] - coarse[i]) / 3;  // (Richardson)
      const int a = con.efc_address;
      const double normal = mujocos[a] - ours[a];  // what the patch subtracts (elliptic: the normal row)
      EXPECT_NEAR(normal, gap, 1e-3 * c.largest_wrong) << "contact " << i;
      ++checked;
    }
    EXPECT_GT(checked, 0);
  }
}

// `steps` implicit steps from sd's state (each must stay finite: a failure otherwise), after_step(k)
// after step k; the start's energy and the largest one sampled every `every` steps.
struct EnergyRange {
  double start, largest;
};
template <class AfterStep>
EnergyRange run_implicit(const Scene& s, SceneData& sd, int steps, int every, AfterStep&& after_step) {
  forward(s, sd);
  EnergyRange E{energy(s, sd).total(), 0.0};
  E.largest = E.start;
  for (int k = 1; k <= steps; ++k) {
    if (step(s, sd, Integrator::Implicit) != Status::Ok) {
      ADD_FAILURE() << "diverged at t = " << sd.d->time;
      break;
    }
    after_step(k);
    if (k % every == 0) {
      forward(s, sd);
      E.largest = std::max(E.largest, energy(s, sd).total());
    }
  }
  return E;
}

// docs/bench/repro/rod_off_cylinder.xml: a soft rod draped across an upright cylinder's top rolls
// sideways off it (a rod across a disc's rim lowers its weight by moving sideways), turning about
// its bent centre line. Without the rows' velocity product its contacts read J qacc of hundreds of
// m/s^2 while the centre line stood still: the rod sank 5 cm into the floor and its energy went
// from 0.05 J to 25 J (non-finite with the implicit integrator at 3.08 s). Now it rolls off and
// comes to rest on the floor: the energy never exceeds the start's, and at rest the rod presses
// into the floor by less than 2 mm (its radius is 10 mm). The rod starts 1e-4 m off the
// cylinder's centre: centred, rounding alone set off the roll, whose time then depended on the
// compiler's flags (outside probe CI: built with -O2 it rolled 0.75 s later and was still
// landing, 10.5 mm into the floor, in the window where the test takes it at rest).
TEST(Contact, BentRodRollingOffACylinderComesToRestOnTheFloor) {
  auto s = load_scene_string(R"(<mujoco>
  <option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom type="cylinder" pos="0 0 0.05" size="0.05 0.05"/>
    <body name="hub" pos="0 1e-4 0.14"><freejoint/><inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="rod" pos="-0.25 0 0" length="0.5" sections="8" strain="kl" radius="0.01" density="1000" young="1e6" poisson="0.5" viscosity="500"/>
    </body>
  </worldbody>
</mujoco>)", kPath);
  SceneData sd(*s);
  double deepest_at_rest = 0.0;
  double landed = 0.0;  // when the rod's tip last moved faster than 1 cm/s
  const int tip_site = mj_name2id(s->m, mjOBJ_SITE, "rod/tip");
  std::vector<double> tip_before(3, 0.0);
  const EnergyRange E = run_implicit(*s, sd, 4000, 10, [&](int k) {
    if (k > 3500)
      for (int c = 0; c < sd.d->ncon; ++c) deepest_at_rest = std::min(deepest_at_rest, sd.d->contact[c].dist);
    if (k % 10 == 0) {
      forward(*s, sd);
      const double* x = sd.d->site_xpos + 3 * tip_site;
      if (std::hypot(x[0] - tip_before[0], x[1] - tip_before[1], x[2] - tip_before[2]) > 1e-2 * 10 * 0.001) landed = sd.d->time;
      tip_before.assign(x, x + 3);
    }
  });
  const int tip = mj_name2id(s->m, mjOBJ_SITE, "rod/tip");
  const double y_end = sd.d->site_xpos[3 * tip + 1];
  EXPECT_LE(E.largest, E.start);
  EXPECT_LT(landed, 3.4);  // at rest before the window the depth is taken in (landed at 2.91 s)
  EXPECT_GT(deepest_at_rest, -0.002);
  EXPECT_GT(std::abs(y_end), 0.05);  // it did roll off (the cylinder's radius is 0.05 m)
}

// Contact distances on soft sections are the centre line's (patch_contact_distances), not the
// chords': on a floor, the centre line's height at the contact's abscissa minus the radius (MuJoCo's
// capsule-plane contacts sit at the capsules' ends, on the centre line up to the projection); on a
// sphere under a bent section spanned by one capsule, the centre line's distance from the sphere
// (to second order in the normal's tilt), where the chord's is a centimetre off.
TEST(Contact, DistancesAreTheCentreLinesNotTheChords) {
  {
    auto s = load_scene_string(replace_all(scene("pyramidal", "dense", 3, 0.005), "capsules=\"3\"", "capsules=\"1\""), kPath);
    SceneData sd(*s);
    for (int k = 0; k < s->rods[0].model.nv; ++k) sd.d->qpos[s->rods[0].qpos0 + k] = 2.0 * std::sin(1.0 + 2.3 * k);
    forward(*s, sd);
    ASSERT_GT(sd.d->ncon, 0);
    for (int i = 0; i < sd.d->ncon; ++i) {
      const mjContact& con = sd.d->contact[i];
      ASSERT_EQ(con.geom1, 0);  // the floor, normal +z
      const Vec3 centre = rod_pose(s->rods[0].model, sd.rod[0], 0, contact_point(*s, sd, con, con.geom2).X).u;
      EXPECT_NEAR(con.dist, centre.z() - 0.01, 1e-12) << "contact " << i;
    }
  }
  auto s = load_scene_string(R"(<mujoco><worldbody>
    <geom name="ball" type="sphere" pos="0 0 0" size="0.05"/>
    <cosserat name="rod" pos="-0.1 0 0.058" length="0.2" sections="1" strain="kl" radius="0.01" capsules="1"/>
  </worldbody></mujoco>)", kPath);
  SceneData sd(*s);
  sd.d->qpos[s->rods[0].qpos0 + 1] = 2.0;  // curvature 2/m, bending down over the ball
  forward(*s, sd);
  ASSERT_EQ(sd.d->ncon, 1);
  const mjContact& con = sd.d->contact[0];
  const int g = con.geom2;
  ASSERT_GE(s->geom_rod[g], 0);
  const Vec3 centre = rod_pose(s->rods[0].model, sd.rod[0], 0, contact_point(*s, sd, con, g).X).u;
  const double along_centre = centre.norm() - 0.05 - 0.01;
  // the chord's distance: from the ball's centre to the capsule's segment
  const Vec3 gc(sd.d->geom_xpos[3 * g], sd.d->geom_xpos[3 * g + 1], sd.d->geom_xpos[3 * g + 2]);
  const Vec3 ax(sd.d->geom_xmat[9 * g + 2], sd.d->geom_xmat[9 * g + 5], sd.d->geom_xmat[9 * g + 8]);
  const double half = s->m->geom_size[3 * g + 1];
  const Vec3 nearest = gc + std::clamp(-gc.dot(ax), -half, half) * ax;
  const double along_chord = nearest.norm() - 0.05 - 0.01;
  EXPECT_NEAR(con.dist, along_centre, 1e-5);
  EXPECT_GT(std::abs(along_chord - along_centre), 5e-3);
}

// Contacts are found and switched on around the centre line, not the chord (the capsules' margin
// and gap widened by the chord's sag, RodBinding::geom_sagging): a bent one-capsule section over a
// ball, its chord clear of the ball by 9 mm while its centre line dips 9 mm into it, gets an active
// contact; bent the other way, its chord 9 mm into the ball while its centre line stays 10 mm
// clear, it gets none.
TEST(Contact, ContactsAreFoundAroundTheCentreLine) {
  for (const double curvature : {-5.0, 5.0}) {
    SCOPED_TRACE(curvature);
    const std::string pose = curvature < 0 ? "pos=\"-0.05 0 0.06\" euler=\"0 17 0\"" : "pos=\"-0.05 0 0.062\" euler=\"0 -17 0\"";
    auto s = load_scene_string("<mujoco><worldbody><geom name=\"ball\" type=\"sphere\" pos=\"0 0 0\" size=\"0.05\"/>"
                               "<cosserat name=\"rod\" " + pose + " length=\"0.2\" sections=\"1\" strain=\"kl\" "
                               "radius=\"0.01\" capsules=\"1\"/></worldbody></mujoco>", kPath);
    SceneData sd(*s);
    sd.d->qpos[s->rods[0].qpos0 + 1] = curvature;  // bending in the x-z plane
    forward(*s, sd);
    double centre = 1e9;  // the centre line's least distance from the ball, less the radius
    for (int k = 0; k <= 400; ++k) centre = std::min(centre, rod_pose(s->rods[0].model, sd.rod[0], 0, 0.2 * k / 400).u.norm() - 0.06);
    const int g = s->rods[0].geom_id[0];
    const Vec3 gc(sd.d->geom_xpos[3 * g], sd.d->geom_xpos[3 * g + 1], sd.d->geom_xpos[3 * g + 2]);
    const Vec3 ax(sd.d->geom_xmat[9 * g + 2], sd.d->geom_xmat[9 * g + 5], sd.d->geom_xmat[9 * g + 8]);
    const double half = s->m->geom_size[3 * g + 1];
    const double chord = (gc + std::clamp(-gc.dot(ax), -half, half) * ax).norm() - 0.06;
    if (curvature < 0) {
      EXPECT_GT(chord, 0.008);
      EXPECT_LT(centre, -0.008);
      ASSERT_EQ(sd.d->ncon, 1);
      EXPECT_EQ(sd.d->contact[0].exclude, 0);
      EXPECT_LT(sd.d->contact[0].dist, -0.005);  // first order at the chord's nearest point
      EXPECT_GT(sd.d->nefc, 0);
    } else {
      EXPECT_LT(chord, -0.008);
      EXPECT_GT(centre, 0.009);
      EXPECT_EQ(sd.d->nefc, 0);
    }
  }
}

// The same through an explicit <pair> (MuJoCo reads the pair's margin, not the geoms'): the
// ball's own filters off, the pair's margin and gap widened by the capsule's sag.
TEST(Contact, ExplicitPairsFindContactsAroundTheCentreLine) {
  for (const double curvature : {-5.0, 5.0}) {
    SCOPED_TRACE(curvature);
    const std::string pose = curvature < 0 ? "pos=\"-0.05 0 0.06\" euler=\"0 17 0\"" : "pos=\"-0.05 0 0.062\" euler=\"0 -17 0\"";
    auto s = load_scene_string("<mujoco><worldbody><geom name=\"ball\" type=\"sphere\" pos=\"0 0 0\" size=\"0.05\" "
                               "contype=\"0\" conaffinity=\"0\"/>"
                               "<cosserat name=\"rod\" " + pose + " length=\"0.2\" sections=\"1\" strain=\"kl\" "
                               "radius=\"0.01\" capsules=\"1\" contype=\"0\" conaffinity=\"0\"/></worldbody>"
                               "<contact><pair geom1=\"ball\" geom2=\"rod/s0/g0\" margin=\"0.001\"/></contact></mujoco>", kPath);
    SceneData sd(*s);
    sd.d->qpos[s->rods[0].qpos0 + 1] = curvature;
    forward(*s, sd);
    EXPECT_NEAR(s->m->pair_margin[0], 0.001 + 5.0 * 0.2 * 0.2 / 8.0, 1e-12);  // kappa l^2 / 8
    if (curvature < 0) {  // chord 9 mm clear, centre line 9 mm in
      ASSERT_EQ(sd.d->ncon, 1);
      EXPECT_EQ(sd.d->contact[0].exclude, 0);
      EXPECT_LT(sd.d->contact[0].dist, -0.005);
      EXPECT_NEAR(sd.d->contact[0].includemargin, 0.001, 1e-15);
      EXPECT_GT(sd.d->nefc, 0);
    } else {  // chord 9 mm in, centre line 9 mm clear
      EXPECT_EQ(sd.d->nefc, 0);
    }
  }
}

// Two soft rods crossing at right angles, their sections bending towards each other: each centre
// line bulges 24.5 mm beyond its chord, the chords' surfaces 40 mm apart, the centre lines' 9 mm
// into each other. MuJoCo takes the larger of two geoms' margins, so each capsule's is widened by
// twice its sag bound (the sum of both is needed).
TEST(Contact, SoftRodsBendingTowardsEachOtherFindTheirContact) {
  const double a = 0.5, c = 2 * std::sin(a) / 5.0;  // half the turning angle (5 /m over 0.2 m), the chord
  char xml[1024];
  std::snprintf(xml, sizeof xml, R"(<mujoco><compiler angle="radian"/><worldbody>
    <cosserat name="low" pos="0 0 0" euler="0 %.15f 0" length="0.2" sections="1" strain="kl" radius="0.01" capsules="1"/>
    <cosserat name="high" pos="%.15f %.15f 0.06" xyaxes="0 %.15f %.15f -1 0 0" length="0.2" sections="1" strain="kl"
              radius="0.01" capsules="1"/>
  </worldbody></mujoco>)", -a, c / 2, -c / 2, std::cos(a), -std::sin(a));
  auto s = load_scene_string(xml, kPath);
  SceneData sd(*s);
  sd.d->qpos[s->rods[0].qpos0 + 1] = 5.0;   // low: along x, turning down, bulging up
  sd.d->qpos[s->rods[1].qpos0 + 1] = -5.0;  // high: along y, turning up, bulging down
  forward(*s, sd);
  const Vec3 top = rod_pose(s->rods[0].model, sd.rod[0], 0, 0.1).u, bottom = rod_pose(s->rods[1].model, sd.rod[1], 0, 0.1).u;
  const double rise = (1 - std::cos(a)) / 5.0;
  ASSERT_LT((top - Vec3(c / 2, 0, rise)).norm(), 1e-9);
  ASSERT_LT((bottom - Vec3(c / 2, 0, 0.06 - rise)).norm(), 1e-9);
  ASSERT_LT((rod_pose(s->rods[1].model, sd.rod[1], 0, 0.2).u - Vec3(c / 2, c / 2, 0.06)).norm(), 1e-9);  // level chords
  ASSERT_EQ(sd.d->ncon, 1);
  EXPECT_EQ(sd.d->contact[0].exclude, 0);
  EXPECT_NEAR(sd.d->contact[0].dist, 0.06 - 2 * rise - 0.02, 1e-9);  // the centre lines' surfaces, 9 mm in
  EXPECT_GT(sd.d->nefc, 0);
}

// Probe L's F1: a soft GVS rod (3 sections of order 2, 2 capsules each) dropped onto a sphere
// through a stiff frictionless contact (solref 0.004, solimp 0.99 0.999). With distances measured
// on the chords and rows acting on the material points, the contact did positive work while the
// sections bent fast: +4.5% of the energy at 0.5 ms (+5.6% at 0.1 ms, +32% with one capsule per
// section). With the centre line's distance the energy only falls.
TEST(Contact, StiffContactOnACoarselyCapsuledBendingRodAddsNoEnergy) {
  auto s = load_scene_string(R"(<mujoco>
  <option timestep="0.0005" gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="ball" type="sphere" pos="0.35 0.02 0.05" size="0.05" condim="1" solref="0.004 1" solimp="0.99 0.999 0.001"/>
    <body name="hub" pos="0 0 0.15"><freejoint/><inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="a" length="0.5" sections="3" order="2" strain="kl" radius="0.01" density="1000" young="1e5"
                poisson="0.5" viscosity="5" condim="1" solref="0.004 1" solimp="0.99 0.999 0.001"/>
    </body>
  </worldbody>
</mujoco>)", kPath);
  SceneData sd(*s);
  int contacts = 0;
  const EnergyRange E = run_implicit(*s, sd, 800, 1, [&](int) { contacts = std::max(contacts, sd.d->ncon); });
  EXPECT_GT(contacts, 0);
  EXPECT_LE(E.largest, E.start * (1 + 1e-12));
}

// Capsules follow the solver's centre line: a stretched rod's capsules lengthen, a bent one's
// span their chords.
TEST(Contact, CapsulesFollowStretchAndBending) {
  auto s = load_scene_string(scene("elliptic", "sparse", 3, 0.5), kPath);
  SceneData sd(*s);
  const RodBinding& rb = s->rods[0];
  for (int sec = 0; sec < 4; ++sec) sd.d->qpos[rb.qpos0 + 4 * sec + 3] = 0.2;  // px: 20% stretch
  sd.d->qpos[rb.qpos0 + 2] = 3.0;                                           // kz of section 0: bend
  fwd_position(*s, sd);
  for (size_t k = 0; k < rb.geom_id.size(); ++k) {
    const RodGeomDecl& gd = rb.decl.geoms[k];
    const Vec3 a = rod_pose(rb.model, sd.rod[0], 0, gd.X_begin).u, b = rod_pose(rb.model, sd.rod[0], 0, gd.X_end).u;
    const int g = rb.geom_id[k];
    EXPECT_NEAR(2 * s->m->geom_size[3 * g + 1], (b - a).norm(), 1e-12);
    EXPECT_NEAR(s->m->geom_rbound[g], s->m->geom_size[3 * g + 1] + s->m->geom_size[3 * g], 1e-12);
    if (gd.section > 0) EXPECT_NEAR(2 * s->m->geom_size[3 * g + 1], 1.2 * (gd.X_end - gd.X_begin), 1e-9);  // straight, stretched
  }
}

// Dense and sparse Jacobians must give the same motion (all three solvers). Compared step by step
// from the same state (qpos, qvel, warm start): a trajectory comparison would measure how fast the
// constraint solver amplifies round-off (CG's iteration count switches at its tolerance, so a
// 1e-16 change of M can grow to 1e-4 over a few hundred steps), not whether the equations agree.
TEST(Contact, DenseAndSparseGiveIdenticalResults) {
  for (const char* solver : {"PGS", "CG", "Newton"}) {
    SCOPED_TRACE(solver);
    auto sd_ = load_scene_string(scene("elliptic", "dense", 3, 0.03, 5.0, 0.5, solver), kPath);
    auto ss_ = load_scene_string(scene("elliptic", "sparse", 3, 0.03, 5.0, 0.5, solver), kPath);
    SceneData a(*sd_), b(*ss_);
    const mjModel* m = sd_->m;
    double worst = 0.0, scale = 0.0;
    int ncon_max = 0;
    for (int k = 0; k < 600; ++k) {
      mju_copy(b.d->qpos, a.d->qpos, m->nq);
      mju_copy(b.d->qvel, a.d->qvel, m->nv);
      mju_copy(b.d->qacc_warmstart, a.d->qacc_warmstart, m->nv);
      b.d->time = a.d->time;
      forward(*sd_, a);
      forward(*ss_, b);
      ASSERT_EQ(a.d->ncon, b.d->ncon);
      ncon_max = std::max(ncon_max, a.d->ncon);
      for (int i = 0; i < m->nv; ++i) {
        worst = std::max(worst, std::abs(a.d->qacc[i] - b.d->qacc[i]));
        scale = std::max(scale, std::abs(a.d->qacc[i]));
      }
      ASSERT_EQ(step(*sd_, a), Status::Ok);
    }
    EXPECT_GT(std::abs(a.d->qpos[2] - 0.03), 0.01);  // it fell onto the floor
    EXPECT_GT(ncon_max, 0);
    // same equations, different sparse/dense summation order: round-off level
    EXPECT_LT(worst, 1e-9 * scale) << "scale " << scale;
  }
}

double total_mass(const Scene& s) {
  double mtot = 0.0;
  for (int b = 1; b < s.m->nbody; ++b) mtot += s.m->body_mass[b];
  for (const auto& r : s.rods)
    for (const auto& n : r.model.nodes) mtot += n.inertia(3, 3);
  return mtot;
}

// MuJoCo's <flag override="enable"/> gives every contact the margin o_margin (and o_solref,
// o_solimp): a soft rod dropped on a floor with o_margin 5 mm comes to rest as with margin 5 mm on
// its capsules and the floor, to the last bit, 5 mm higher than without (outside probe BM: the
// soft sections' contacts, re-measured from the centre line, had taken the geoms' margins, and
// the rod rested at no margin; the rows widened for the sag were not read under override).
TEST(Contact, OverriddenMarginsAreTheMarginsOfSoftSections) {
  const std::string rod = R"(<body name="b" pos="0 0 0.02"><freejoint/>
      <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
      <cosserat name="rod" length="0.4" sections="2" strain="kl" radius="0.01" density="1000" young="1e7" viscosity="50"
                MARGIN><site name="mid" at="0.2"/></cosserat></body>)";
  auto rest = [&](const std::string& option, const std::string& floor_margin, const std::string& rod_margin) {
    const std::string xml = "<mujoco><option timestep=\"0.001\" " + option + "<worldbody><geom name=\"floor\" type=\"plane\" size=\"2 2 .1\" " +
                            floor_margin + "/>" + replace_all(rod, "MARGIN", rod_margin) + "</worldbody></mujoco>";
    auto s = load_scene_string(xml, kPath);
    SceneData sd(*s);
    for (int k = 0; k < 2000; ++k) EXPECT_EQ(step(*s, sd), Status::Ok);
    const mjtNum* x = sd.d->site_xpos + 3 * mj_name2id(s->m, mjOBJ_SITE, "mid");
    return Vec3(x[0], x[1], x[2]);
  };
  const Vec3 overridden = rest(R"(o_margin="0.005"><flag override="enable"/></option>)", "", "");
  const Vec3 given = rest("/>", R"(margin="0.005")", R"(margin="0.005")");
  const Vec3 none = rest("/>", "", "");
  EXPECT_EQ(overridden, given);
  EXPECT_NEAR(overridden.z() - none.z(), 0.005, 2e-4);  // measured 0.01490 against 0.00990
}

TEST(Contact, RodDroppedOnPlaneRestsWithItsWeightOnTheFloor) {
  auto s = load_scene_string(scene("elliptic", "sparse", 3, 0.05, 20.0), kPath);
  SceneData sd(*s);
  for (int k = 0; k < 4000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);  // 2 s
  forward(*s, sd);
  double fn = 0.0, deepest = 0.0;
  for (int i = 0; i < sd.d->ncon; ++i) {
    mjtNum f[6];
    mj_contactForce(s->m, sd.d, i, f);
    fn += f[0];
    deepest = std::min(deepest, sd.d->contact[i].dist);
  }
  const double W = total_mass(*s) * 9.81;
  double vmax = 0.0;
  for (int i = 0; i < s->m->nv; ++i) vmax = std::max(vmax, std::abs(sd.d->qvel[i]));
  std::printf("at rest: sum of normal forces %.6f N, weight %.6f N, deepest penetration %.2e m, |qvel| %.1e\n", fn, W,
              -deepest, vmax);
  EXPECT_NEAR(fn, W, 0.01 * W);
  EXPECT_LT(vmax, 1e-3);
  // MuJoCo's soft contacts settle slightly inside the surface (solref/solimp); a native capsule
  // of the same weight per contact sinks by the same order: a millimetre bounds it here
  EXPECT_GT(deepest, -1e-3);
}

// Coulomb: a horizontal push below mu W does not slide the rod; above it the rod accelerates at
// (F - mu W) / m. The push acts along the straight rod's axis, through its centre of mass (a push
// across one end would also turn it, which starts at about 0.41 mu W). MuJoCo's friction is a
// soft constraint: below the limit bodies creep slowly (faster the more flexible they are, since
// the constraint softness scales with invweight0), so "sticking" is asserted as a creep speed far
// below the sliding speed.
TEST(Contact, FrictionObeysCoulombsLimit) {
  const double mu = 0.5, T = 0.2;
  double creep_speed = 0.0, creep = 0.0, slide_speed = 0.0;
  for (double ratio : {0.5, 2.0}) {
    SCOPED_TRACE(ratio);
    // a stiff rod (E = 1e8 Pa): a soft one also shortens under the push (EA/L ~ 200 N/m at 2e5 Pa)
    auto s = load_scene_string(scene("elliptic", "sparse", 3, 0.0105, 20.0, mu, "Newton", 1e8), kPath);
    SceneData sd(*s);
    for (int k = 0; k < 2000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);  // settle for 1 s
    const double mtot = total_mass(*s), W = mtot * 9.81, F = ratio * mu * W;
    const int hub = mj_name2id(s->m, mjOBJ_BODY, "hub");
    const double x0 = sd.d->qpos[0];
    sd.d->xfrc_applied[6 * hub + 0] = F;  // push along +x, the rod's axis
    for (int k = 0; k < static_cast<int>(T / s->m->opt.timestep); ++k) ASSERT_EQ(step(*s, sd), Status::Ok);
    const double dx = sd.d->qpos[0] - x0;
    if (ratio < 1) {
      creep = dx;
      creep_speed = std::abs(sd.d->qvel[0]);
    } else {
      const double expected = 0.5 * (F - mu * W) / mtot * T * T;
      slide_speed = std::abs(sd.d->qvel[0]);
      std::printf("sliding at 2 mu W: displacement %.5f m (Coulomb: %.5f m), speed %.3f m/s\n", dx, expected, slide_speed);
      // a native rigid chain slides 0.25% beyond Coulomb here (MuJoCo's soft friction)
      EXPECT_NEAR(dx, expected, 0.02 * expected);
    }
  }
  std::printf("at 0.5 mu W: creep %.2e m in %.1f s, speed %.1e m/s\n", creep, T, creep_speed);
  EXPECT_LT(creep_speed, 0.01 * slide_speed);
  EXPECT_LT(std::abs(creep), 0.01 * 0.5 * (mu * 9.81) * T * T);
}

// Exactness with contact: a rod of `rigid` sections on a free hub, dropped on a floor and pushed,
// against the native MuJoCo equivalent with the same mass distribution: one welded body per
// section carrying its capsules and its mass at its centre (so that MuJoCo's constraint softness,
// which depends on each body's invweight0 at its centre of mass, is the same).

// A soft rod dropped 9 cm onto a floor with an underdamped contact (solref 0.01 0.1) bounces as its
// rigid twin does under the default step, with either cone: peak 62 mm after the impact (rigid
// 62 mm). Outside probe BO: with the contacts' normal rows held in the linearised step's matrix
// (backward Euler over the contact's own spring) it had barely left the floor, 14 mm.
TEST(Contact, ASoftRodBouncesAsItsRigidTwinUnderTheDefaultStep) {
  const std::string xml = R"(<mujoco><option timestep="0.001" cone="CONE"/><worldbody>
    <geom name="floor" type="plane" size="5 5 .1" condim="3" friction="0.5 0.005 0.0001" solref="0.01 0.1"/>
    <body name="hub" pos="0 0 0.1"><freejoint/><inertial pos="0 0 0" mass="1e-3" diaginertia="1e-8 1e-8 1e-8"/>
      <cosserat name="rod" length="0.4" sections="4" strain="STRAIN" radius="0.01" density="1000" young="1e6"
                condim="3" friction="0.5 0.005 0.0001" solref="0.01 0.1"><site name="mid" at="0.2"/></cosserat>
    </body></worldbody></mujoco>)";
  auto peak = [&](const char* cone, const char* strain) {
    auto s = load_scene_string(replace_all(replace_all(xml, "CONE", cone), "STRAIN", strain), kPath);
    SceneData sd(*s);
    const int mid = mj_name2id(s->m, mjOBJ_SITE, "mid");
    double top = 0.0;
    for (int k = 0; k < 500; ++k) {
      EXPECT_EQ(step(*s, sd), Status::Ok);
      if (sd.d->time > 0.16) top = std::max(top, sd.d->site_xpos[3 * mid + 2]);
    }
    return top;
  };
  for (const char* cone : {"elliptic", "pyramidal"}) {
    SCOPED_TRACE(cone);
    const double rigid = peak(cone, "rigid"), soft = peak(cone, "kl");
    EXPECT_GT(rigid, 0.05);  // measured 0.062
    EXPECT_NEAR(soft, rigid, 0.1 * rigid);
  }
}

// Torsional friction (condim 4, elliptic cone) at the end of a soft rod standing on a floor holds a
// twist of 16% of mu_t N: a hub on a vertical slide and hinge, a motor twisting it with 0.05 N m against
// mu_t N = 0.2 x 0.163 kg x 9.81 = 0.32 N m. Outside probe BM: the linearised `implicit` step had
// taken the contact forces from MuJoCo's solve against M alone, outside its matrix, and the rod's
// end turned 2.05 rad on the floor (the end's light, stiff twist carried along by the twist
// spring's implicit response) where the native twin turns 0.008 rad in 3 s and the Newton schemes
// 0.027 rad; its elliptic cones' friction rows are now frozen with its matrix as the Newton
// schemes' rows are.
// Frictionless contacts written as friction 0 with condim 3 under the pyramidal cone are warned
// about at load (the pyramid degenerates: outside probe CE's gripper read touch forces up to
// 8.7e4 N on a 20 g box); condim 1, the elliptic cone, or friction on either geom are not.
TEST(Contact, FrictionZeroOnAPyramidIsWarnedAbout) {
  auto scene = [](const std::string& rod, const std::string& floor, const std::string& option) {
    return load_scene_string(R"(<mujoco><option )" + option + R"(/><worldbody><geom type="plane" size="1 1 0.1" )" + floor +
                                 R"(/><cosserat name="r" pos="0 0 0.01" length="0.5" sections="4" radius="0.01" )" + rod +
                                 R"(/></worldbody></mujoco>)",
                             kPath);
  };
  auto warned = [](const std::unique_ptr<Scene>& s) {
    for (const auto& w : s->load_warnings)
      if (w.find("friction 0 and condim 3 or more under the pyramidal cone") != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(warned(scene(R"(friction="0 0 0")", R"(friction="0 0 0")", "")));
  EXPECT_FALSE(warned(scene(R"(friction="0 0 0" condim="1")", R"(friction="0 0 0" condim="1")", "")));
  EXPECT_FALSE(warned(scene(R"(friction="0 0 0")", R"(friction="0 0 0")", R"(cone="elliptic")")));
  EXPECT_FALSE(warned(scene(R"(friction="0 0 0")", "", "")));  // the floor's friction 1 is the pair's
}

TEST(Contact, TorsionalFrictionAtASoftRodsEndHoldsUnderEveryIntegrator) {
  const std::string xml = R"(<mujoco>
  <option timestep="0.001" cone="CONE"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 .1" condim="4" friction="1 0.2 0.001"/>
    <body name="top" pos="0 0 0.20999">
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="spin" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="0.1" diaginertia="1e-2 1e-2 1e-2"/>
      <cosserat name="rod" euler="0 90 0" length="0.2" sections="2" strain="kl" radius="0.01" density="1000"
                young="1e8" viscosity="20" condim="4" friction="1 0.2 0.001"/>
    </body>
  </worldbody>
  <actuator><motor name="tq" joint="spin"/></actuator>
</mujoco>)";
  // the largest turn of the end's cross-section over 1.5 s: `newton` corrections (-1: the default)
  auto turn = [&](const char* cone, Integrator in, int newton) {
    auto s = load_scene_string(replace_all(xml, "CONE", cone), kPath);
    s->newton_iterations = newton;
    SceneData sd(*s);
    sd.d->ctrl[0] = 0.05;
    double yaw = 0.0;
    for (int k = 0; k < 1500; ++k) {
      EXPECT_EQ(step(*s, sd, in), Status::Ok);
      const SE3 tip = rod_frame(*s, sd, 0, 0.2);
      yaw = std::max(yaw, std::abs(std::atan2(tip.R(1, 1), tip.R(0, 1)) - M_PI / 2));
    }
    return yaw;
  };
  // backward Euler by Newton's iteration, every force at the step's end: 0.027 rad
  const double exact = turn("elliptic", Integrator::Implicit, 10);
  EXPECT_LT(exact, 0.05);
  const double be = turn("elliptic", Integrator::Implicit, -1), trap = turn("elliptic", Integrator::Trapezoidal, 0);
  EXPECT_NEAR(be, exact, 0.25 * exact);  // measured 0.0271 (2.05 rad before)
  EXPECT_NEAR(trap, exact, 0.25 * exact);
  // the pyramid's edges are not held (held, they braked rolling rods: outside probe BO): the
  // Newton schemes hold the twist (0.062 rad), the linearised step does not, and the load says so
  EXPECT_LT(turn("pyramidal", Integrator::Implicit, 10), 0.1);
  const auto pyramidal = load_scene_string(replace_all(xml, "CONE", "pyramidal"), kPath);
  ASSERT_EQ(pyramidal->load_warnings.size(), 1u);
  EXPECT_NE(pyramidal->load_warnings[0].find("contacts of condim 4 or 6 (torsional, rolling friction) with the pyramidal "
                                             "cone: the default linearised step does not hold"),
            std::string::npos)
      << pyramidal->load_warnings[0];
  EXPECT_TRUE(load_scene_string(replace_all(xml, "CONE", "elliptic"), kPath)->load_warnings.empty());
  EXPECT_TRUE(load_scene_string(replace_all(replace_all(xml, "CONE", "pyramidal"), "strain=\"kl\"", "strain=\"rigid\""), kPath)
                  ->load_warnings.empty());
}
std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

TEST(Contact, RigidRodWithContactBehavesLikeNativeBodies) {
  const double L = 0.3, r = 0.01, rho = 1000.0;
  const int N = 3, C = 3;
  const std::string head =
      "<mujoco><option timestep=\"0.0005\"/><worldbody>"
      "<geom type=\"plane\" size=\"1 1 0.1\" friction=\"0.5 0.005 0.0001\"/>"
      "<body name=\"hub\" pos=\"0 0 0.03\" euler=\"3 5 20\"><freejoint/>"
      "<inertial pos=\"0 0 0\" mass=\"0.01\" diaginertia=\"1e-6 1e-6 1e-6\"/>";
  const std::string rod = head + "<cosserat name=\"rod\" length=\"" + fmt(L) + "\" sections=\"" + std::to_string(N) +
                          "\" strain=\"rigid\" radius=\"" + fmt(r) + "\" density=\"" + fmt(rho) +
                          "\" friction=\"0.5 0.005 0.0001\" capsules=\"" + std::to_string(C) + "\"/></body></worldbody></mujoco>";
  const double ls = L / N, ms = rho * M_PI * r * r * ls;
  const double ixx = 0.5 * ms * r * r, iyy = 0.25 * ms * r * r + ms * ls * ls / 12;
  std::string native = head, close;
  for (int i = 0; i < N; ++i) {  // body i sits at the end of section i, like the proxy
    native += "<body pos=\"" + fmt(ls) + " 0 0\"><inertial pos=\"" + fmt(-ls / 2) + " 0 0\" mass=\"" + fmt(ms) +
              "\" diaginertia=\"" + fmt(ixx) + " " + fmt(iyy) + " " + fmt(iyy) + "\"/>";
    for (int j = 0; j < C; ++j)
      native += "<geom type=\"capsule\" fromto=\"" + fmt(-ls + j * ls / C) + " 0 0 " + fmt(-ls + (j + 1) * ls / C) +
                " 0 0\" size=\"" + fmt(r) + "\" friction=\"0.5 0.005 0.0001\" mass=\"0\"/>";
    close += "</body>";
  }
  native += close + "</body></worldbody></mujoco>";
  auto sr = load_scene_string(rod, kPath);
  auto sn = load_scene_string(native, kPath);
  SceneData a(*sr), b(*sn);
  ASSERT_EQ(sr->m->nq, sn->m->nq);
  double worst = 0.0;
  int contacts = 0;
  for (int k = 0; k < 2000; ++k) {
    if (k == 1000) a.d->xfrc_applied[6 + 1] = b.d->xfrc_applied[6 + 1] = 0.8;  // push the hub along y
    ASSERT_EQ(step(*sr, a, Integrator::Euler), Status::Ok);
    ASSERT_EQ(step(*sn, b, Integrator::Euler), Status::Ok);
    contacts = std::max(contacts, a.d->ncon);
    for (int i = 0; i < sr->m->nq; ++i) worst = std::max(worst, std::abs(a.d->qpos[i] - b.d->qpos[i]));
  }
  EXPECT_GT(contacts, 0);
  EXPECT_LT(worst, 1e-9);
}

// The inverse weight of a long soft section (which scales MuJoCo's contact regulariser) is its
// mass points' mean, each from the point's true Jacobian. Outside probe Z: a clamped one-section
// GVS wire (order 2, r = 1 mm) got the section's centre of mass as if rigid with its end: 9x the
// tip's true J M^-1 J', and the wire sank 5.7 radii into a floor. Reference: the true J M^-1 J' of
// each contact row (from efc_J and MuJoCo's factor) against the row's diagApprox (the regulariser's
// scale, 4 body_invweight0 on a pyramid's edges: (1 + mu^2) 2 with mu = 1); and the wire's rest.
TEST(Contact, LongSoftSectionsRestOnAFloorAsShortOnes) {
  const double r = 0.001;
  auto s = load_scene_string(R"(<mujoco><option timestep="0.0005"/><worldbody><geom type="plane" size="1 1 .1"/>
    <cosserat name="c" pos="0 0 0.0009" length="0.2" sections="1" strain="kl" order="2" radius="0.001"
      density="1000" young="1e9" poisson="0.3"/></worldbody></mujoco>)",
                             kPath);
  SceneData sd(*s);
  for (int k = 0; k < 2000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok) << k;
  forward(*s, sd);
  const mjModel* m = s->m;
  mjData* d = sd.d;
  ASSERT_FALSE(mj_isSparse(m));
  int tip_rows = 0;
  std::vector<mjtNum> x(m->nv);
  for (int i = 0; i < d->ncon; ++i) {
    const int row = d->contact[i].efc_address;
    if (d->contact[i].pos[0] < 0.15) continue;  // the contacts towards the free end
    mj_solveM(m, d, x.data(), d->efc_J + row * m->nv, 1);
    const double A = mju_dot(d->efc_J + row * m->nv, x.data(), m->nv);
    EXPECT_LT(d->efc_diagApprox[row], 3.0 * A) << i;  // was 35x
    EXPECT_GT(d->efc_diagApprox[row], A / 30.0) << i;
    ++tip_rows;
  }
  EXPECT_GT(tip_rows, 0);
  const double tip = d->site_xpos[3 * mj_name2id(m, mjOBJ_SITE, "c/tip") + 2];
  EXPECT_GT(tip, 0.5 * r);  // rests on the floor, its centre line less than half a radius deep (was -4.7 mm)
  EXPECT_LT(tip, r);
}

// A GVS section bends between its capsules' ends, where a floor's contacts are: with two capsules
// a free rod of one order-6 section lay on the three ends and sagged 8.3 mm (0.83 r) into the floor
// between them, the touch reading its weight (outside probe CA). The load warns and names the
// remedy, order + 2 capsules, with which it lies flat. (A default of order + 2 overflowed MuJoCo's
// default contact buffers on long rods and left <pair>s naming g0 and g1 covering part of each
// section: outside probe CC.)
TEST(Contact, AGvsSectionLiesFlatOnAFloorWithOrderPlusTwoCapsules) {
  const double r = 0.01;
  std::string sites;
  for (int k = 0; k <= 20; ++k) sites += "<site name=\"p" + std::to_string(k) + "\" at=\"" + std::to_string(0.025 * k) + "\"/>";
  const std::string xml = R"(<mujoco><worldbody><geom type="plane" size="1 1 .1"/>
    <body name="hold" pos="0 0 0.0105"><freejoint/><inertial pos="0 0 0" mass="0.001" diaginertia="1e-8 1e-8 1e-8"/>
    <cosserat name="c" length="0.5" sections="1" order="6" strain="kl" radius="0.01" density="1000" young="1e6"
      viscosity="20" CAPSULES>)" + sites + R"(</cosserat></body></worldbody></mujoco>)";
  auto plain = load_scene_string(cosserat::testing::replace_all(xml, "CAPSULES", ""), kPath);
  ASSERT_EQ(plain->load_warnings.size(), 1u);
  EXPECT_NE(plain->load_warnings[0].find("GVS section(s) 0 of order up to 6 with 2 capsules"), std::string::npos)
      << plain->load_warnings[0];
  EXPECT_NE(plain->load_warnings[0].find("capsules=\"8\" (order + 2)"), std::string::npos) << plain->load_warnings[0];
  auto s = load_scene_string(cosserat::testing::replace_all(xml, "CAPSULES", "capsules=\"8\""), kPath);
  EXPECT_TRUE(s->load_warnings.empty());
  const mjModel* m = s->m;
  SceneData sd(*s);
  for (int k = 0; k < 3000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok) << k;
  forward(*s, sd);
  for (int k = 0; k <= 20; ++k) {
    const double z = sd.d->site_xpos[3 * mj_name2id(m, mjOBJ_SITE, ("p" + std::to_string(k)).c_str()) + 2];
    EXPECT_GT(z, r - 5e-4) << "site " << k;  // r - 8.3 mm in the middle of each capsule pair with 2
    EXPECT_LT(z, r + 5e-4) << "site " << k;
  }
}

// Thin, short sections: a 6 mm section of a 1 mm wire has a twist inertia of 1.3e-16 kg m^4 in SI,
// below MuJoCo's mjMINVAL (1e-15). Outside probe Z: on a floor, MuJoCo 2.2.2's sparse Newton
// solver stopped the program at the first step ("Rank-defficient Hessian"), and mj_factorM's
// raised pivot had made M^-1 wrong on those dofs. The loader gives such scenes dense Jacobians
// (with a warning), the factor keeps the rods' pivots: M (M^-1 e) = e, and the wire rests where
// the CG solver, which never factorises the Hessian, puts it.
TEST(Contact, ThinShortSectionsRestOnAFloor) {
  const std::string xml = R"(<mujoco><size nconmax="400" njmax="3000"/><option SOLVER/><worldbody>
    <geom type="plane" size="1 1 .1"/>
    <cosserat name="c" pos="0 0 0.0009" length="0.2" sections="32" strain="kl" radius="0.001" density="1000"
      young="1e9" poisson="0.3"/></worldbody></mujoco>)";
  auto newton = load_scene_string(replace_all(xml, "SOLVER", ""), kPath);
  auto cg = load_scene_string(replace_all(xml, "SOLVER", "solver=\"CG\""), kPath);
  ASSERT_EQ(newton->load_warnings.size(), 1u);
  EXPECT_NE(newton->load_warnings[0].find("the inertia of strain coordinate 'c/s31/kx' is 1.3e-16"), std::string::npos)
      << newton->load_warnings[0];
  EXPECT_EQ(newton->m->opt.jacobian, mjJAC_DENSE);
  EXPECT_TRUE(cg->load_warnings.empty());  // CG never stops there: its Jacobians stay as they are
  EXPECT_TRUE(mj_isSparse(cg->m));
  SceneData a(*newton), b(*cg);
  for (int k = 0; k < 100; ++k) {
    ASSERT_EQ(step(*newton, a), Status::Ok) << k;
    ASSERT_EQ(step(*cg, b), Status::Ok) << k;
  }
  forward(*newton, a);
  const mjModel* m = newton->m;
  EXPECT_GT(a.d->ncon, 0);
  const int dof = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "c/s31/kx")];
  std::vector<mjtNum> e(m->nv, 0.0), x(m->nv), y(m->nv);
  e[dof] = 1.0;
  mj_solveM(m, a.d, x.data(), e.data(), 1);
  mj_mulM(m, a.d, y.data(), x.data());
  for (int i = 0; i < m->nv; ++i) EXPECT_NEAR(y[i], e[i], 1e-9) << i;
  const int tip = mj_name2id(m, mjOBJ_SITE, "c/tip");
  // (two solvers, each to its tolerance, on a wire still settling: 4e-9 m measured)
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.d->site_xpos[3 * tip + k], b.d->site_xpos[3 * tip + k], 1e-7) << k;
  EXPECT_GT(a.d->site_xpos[3 * tip + 2], 0.0);  // on the floor, less than a radius deep
  EXPECT_LT(a.d->site_xpos[3 * tip + 2], 0.001);
}

}  // namespace

// A soft section's inverse weight, which scales the softness of its contacts, is MuJoCo's rule at
// its centre of mass, with the true (flexible) Jacobian of that centre. A rod of 16 sections resting
// on two cylinders then sinks into them as deep as its MuJoCo-native chain of 16 capsules with the
// same freedoms: hinges about y and z (ikl; measured 0.99 against 0.94 mm), and a slide along the
// link for the stretch (kl; 1.41 against 1.42 mm: MuJoCo's rule averages the three translational
// directions, and the stretch makes the centre of mass mobile along the rod, in the chain as in the
// rod). With the mass-weighted mean of the mass points' own inverse weights, used before, the ikl
// rod sank 1.72 mm and the kl rod 2.45 mm (outside probe AT: the depth biased the reactions of
// statically indeterminate supports, a prop under a cantilever carrying 29% less than a rigid prop).
TEST(Contact, ARodOnTwoSupportsSinksAsDeepAsItsNativeChain) {
  const std::string supports = R"(<option timestep="0.0005"/><size nconmax="200" njmax="1200"/><worldbody>
    <geom type="cylinder" size="0.01 0.05" pos="0.02 0 -0.02" euler="90 0 0"/>
    <geom type="cylinder" size="0.01 0.05" pos="0.98 0 -0.02" euler="90 0 0"/>)";
  for (const bool stretch : {false, true}) {
    auto rod = load_scene_string("<mujoco>" + supports + R"(
    <body name="hub"><freejoint/><inertial pos="0 0 0" mass="1e-4" diaginertia="1e-9 1e-9 1e-9"/>
      <cosserat name="rod" length="1" sections="16" strain=")" + std::string(stretch ? "kl" : "ikl") +
                                     R"(" radius="0.01" density="1000" young="1e9"
                poisson="0.3" viscosity="50"><site name="A" at="0.02"/><site name="B" at="0.98"/></cosserat>
    </body></worldbody></mujoco>)",
                                 kPath);
    // the chain: 16 capsules of 62.5 mm and the rod's mass, hinges about y and z of stiffness
    // EI / ds, and for kl a slide along the link. Its stiffness does not enter the inverse weights
    // (M alone does); EA / ds, 5e6 N/m on a 20 g link, is beyond the relaxation's steps, and 5e3 N/m
    // lets the chain settle (at rest nothing loads it along its length)
    const double L = 0.0625, r = 0.01, mass = 1000 * M_PI * r * r * L, EI = 1e9 * M_PI * r * r * r * r / 4;
    const double Ia = 0.5 * mass * r * r, It = mass * (3 * r * r + L * L) / 12;
    std::string chain = "<mujoco>" + supports, close;
    for (int i = 0; i < 16; ++i) {
      chain += "<body name=\"b" + std::to_string(i) + "\" pos=\"" + (i == 0 ? "0" : full_precision(L)) + " 0 0\">";
      if (i == 0) {
        chain += "<freejoint/>";
      } else {
        for (const char* axis : {"0 1 0", "0 0 1"})
          chain += std::string("<joint type=\"hinge\" axis=\"") + axis + "\" stiffness=\"" + full_precision(EI / L) +
                   "\" damping=\"0.06\"/>";
        if (stretch)
          chain += "<joint type=\"slide\" axis=\"1 0 0\" stiffness=\"5000\" damping=\"1\"/>";
      }
      chain += "<inertial pos=\"" + full_precision(L / 2) + " 0 0\" mass=\"" + full_precision(mass) +
               "\" diaginertia=\"" + full_precision(Ia) + " " + full_precision(It) + " " + full_precision(It) + "\"/>";
      chain += "<geom type=\"capsule\" fromto=\"0 0 0 " + full_precision(L) + " 0 0\" size=\"0.01\" mass=\"0\"/>";
      if (i == 0) chain += "<site name=\"A\" pos=\"0.02 0 0\"/>";
      if (i == 15) chain += "<site name=\"B\" pos=\"" + full_precision(0.98 - 15 * L) + " 0 0\"/>";
      close += "</body>";
    }
    chain += close + "</worldbody><contact>";
    for (int i = 0; i + 1 < 16; ++i)
      chain += "<exclude body1=\"b" + std::to_string(i) + "\" body2=\"b" + std::to_string(i + 1) + "\"/>";
    chain += "</contact></mujoco>";
    auto native = load_scene_string(chain, kPath);
    double depth[2];
    for (int k = 0; k < 2; ++k) {
      const Scene& s = k == 0 ? *rod : *native;
      SceneData sd(s);
      const SceneStaticsResult res = equilibrium(s, sd);
      ASSERT_TRUE(res.converged) << res.message;
      forward(s, sd);
      const int a = mj_name2id(s.m, mjOBJ_SITE, "A"), b = mj_name2id(s.m, mjOBJ_SITE, "B");
      ASSERT_GE(std::min(a, b), 0);
      depth[k] = -0.5 * (sd.d->site_xpos[3 * a + 2] + sd.d->site_xpos[3 * b + 2]);
    }
    std::printf("%s: sunk into the supports: rod %.3f mm, native chain %.3f mm\n", stretch ? "kl" : "ikl",
                1e3 * depth[0], 1e3 * depth[1]);
    EXPECT_GT(depth[1], 5e-4);
    EXPECT_NEAR(depth[0], depth[1], 0.1 * depth[1]) << (stretch ? "kl" : "ikl");
  }
}
