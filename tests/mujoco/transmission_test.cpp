// Actuator transmissions through rod sites: MuJoCo computes a site's moment arm as if the site were
// rigid with its section's proxy (placed at the section's end); the coupling corrects it to the
// material point's Jacobian. Checked against central differences of the sites' motion, and the
// equality constraints on rod bodies (exact as MuJoCo computes them: proxies are material frames).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "scene.hpp"
#include "support/bent_motion.hpp"
#include "support/text_file.hpp"
#include "support/material_point.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

using cosserat::testing::replace_all;

using Mat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

// A hinged hub with a bent, moving rod; sites inside sections (m, s) and on the hub (h).
std::string arm(const std::string& sites_on_hub, const std::string& actuators) {
  return R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>)" +
         sites_on_hub + R"(
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01">
        <site name="m" at="0.15" pos="0 0.006 0.002"/><site name="s" at="0.25" pos="0.001 -0.004 0.003"/>
      </cosserat></body></worldbody><actuator>)" +
         actuators + "</actuator></mujoco>";
}

// The scene along cosserat::testing::BentMotion.
struct Motion {
  std::unique_ptr<Scene> s;
  std::unique_ptr<SceneData> sd;
  std::unique_ptr<cosserat::testing::BentMotion> motion;
  explicit Motion(const std::string& xml) : s(load_scene_string(xml, "/tmp/cosserat_transmission_test.xml")) {
    sd = std::make_unique<SceneData>(*s);
    EXPECT_EQ(s->m->nq, s->m->nv);
    motion = std::make_unique<cosserat::testing::BentMotion>(s->m);
  }
  const mjData* at(double t) {
    motion->at(*s, *sd, t);
    return sd->d;
  }
  double moment_times_v(int actuator) const {
    double mv = 0.0;
    for (int i = 0; i < s->m->nv; ++i) mv += sd->d->actuator_moment[actuator * s->m->nv + i] * motion->v[i];
    return mv;
  }
};

// A site transmission applies the force R gear[0:3] and torque R gear[3:6] at the site (R its
// frame): its moment arm times v is their virtual power at the site's velocity and spin. With a
// reference site (refsite), R is the reference's frame and the motion the site's relative to the
// reference's (mj_transmission's formula). Sites on the rod (m, s), on the hub (h) and the rod's
// generated base site (arm/base, on the rod's base body: MuJoCo's own moment arm, uncorrected).
TEST(Transmission, SiteActuatorOnARodSiteHasTheMaterialPointsMomentArm) {
  const std::string gear = "\" gear=\"0.3 -0.5 1 0.02 0.01 -0.03\"/>";
  Motion mo(arm(R"(<site name="h" pos="0.01 0.02 0.03" euler="10 20 30"/>)",
                "<motor site=\"m" + gear + "<motor site=\"m\" refsite=\"s" + gear + "<motor site=\"h\" refsite=\"m" + gear +
                    "<motor site=\"arm/base" + gear + "<motor site=\"m\" refsite=\"arm/base" + gear));
  const double eps = 1e-6;
  struct Motion3 {
    Vec3 vel, w;
    Mat3 R;
  };
  auto motion_of = [&](const char* name) {  // velocity and spin from central differences, frame
    const int id = mj_name2id(mo.s->m, mjOBJ_SITE, name);
    auto pose = [&](double t) {
      const mjData* d = mo.at(t);
      return std::make_pair(Vec3(d->site_xpos + 3 * id), Mat3(Eigen::Map<const Mat3>(d->site_xmat + 9 * id)));
    };
    const auto [pp, Rp] = pose(eps);
    const auto [pm, Rm] = pose(-eps);
    const auto [p0, R0] = pose(0.0);
    const Mat3 W = ((Rp - Rm) / (2 * eps)) * R0.transpose();
    return Motion3{(pp - pm) / (2 * eps), cosserat::testing::spin_of(W), R0};
  };
  const Motion3 m = motion_of("m"), sr = motion_of("s"), h = motion_of("h"), b = motion_of("arm/base");
  mo.at(0.0);
  auto power = [](const Motion3& site, const Motion3* ref) {
    const Mat3& R = ref ? ref->R : site.R;
    const Vec3 f = R * Vec3(0.3, -0.5, 1), tau = R * Vec3(0.02, 0.01, -0.03);
    return f.dot(site.vel - (ref ? ref->vel : Vec3::Zero())) + tau.dot(site.w - (ref ? ref->w : Vec3::Zero()));
  };
  const double expected[5] = {power(m, nullptr), power(m, &sr), power(h, &m), power(b, nullptr), power(m, &b)};
  for (int a = 0; a < 5; ++a) {
    EXPECT_GT(std::abs(expected[a]), 1e-2) << a;
    EXPECT_NEAR(mo.moment_times_v(a), expected[a], 1e-7 * std::abs(expected[a])) << a;
  }
  // with a reference site the length is the site's position in the reference's frame and its
  // rotation relative to it (axis-angle in the reference's frame), dotted with the gear: m against
  // s (both inside sections), h (on the hub) against m
  const mjData* d = mo.sd->d;
  auto length = [&](const char* site, const char* ref) {
    const int a = mj_name2id(mo.s->m, mjOBJ_SITE, site), r = mj_name2id(mo.s->m, mjOBJ_SITE, ref);
    const Mat3 Ra = Eigen::Map<const Mat3>(d->site_xmat + 9 * a), Rr = Eigen::Map<const Mat3>(d->site_xmat + 9 * r);
    const Eigen::AngleAxisd rel(Eigen::Matrix3d(Rr.transpose() * Ra));
    const Vec3 pos = Rr.transpose() * (Vec3(d->site_xpos + 3 * a) - Vec3(d->site_xpos + 3 * r));
    return Vec3(0.3, -0.5, 1).dot(pos) + Vec3(0.02, 0.01, -0.03).dot(rel.angle() * rel.axis());
  };
  EXPECT_NEAR(d->actuator_length[1], length("m", "s"), 1e-12);
  EXPECT_NEAR(d->actuator_length[2], length("h", "m"), 1e-12);
  // the same on a rigid rod (its sites rigid with their proxies): the length from the frames too,
  // so that a rod's strain does not change what the actuator measures
  Motion rigid(replace_all(arm(R"(<site name="h" pos="0.01 0.02 0.03" euler="10 20 30"/>)",
                               "<motor site=\"m\" refsite=\"s" + gear + "<motor site=\"h\" refsite=\"m" + gear),
                           "strain=\"kl\"", "strain=\"rigid\""));
  d = rigid.at(0.0);
  EXPECT_NEAR(d->actuator_length[0], length("m", "s"), 1e-12);
  EXPECT_NEAR(d->actuator_length[1], length("h", "m"), 1e-12);
}

// MuJoCo's compiler derives actuator_acc0 = |M^-1 moment| at qpos0 from its placeholder proxies
// (unit masses and armatures); with the rod's inertia (its continuum inertia, as for the inverse
// weights: Scene.InverseWeightsTakeTheRodsContinuumInertia) it is what mj_setConst would compute,
// and a muscle without a force pulls with F0 = scale / acc0 (mju_muscleGain); the mean diagonal
// inertia (the constraint solvers' scale) is the rod's too.
TEST(Transmission, ActuatorAccelerationsAndMuscleScalesAtQpos0CountTheRodsInertia) {
  Motion mo(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01">
        <site name="m" at="0.15" pos="0 0.006 0.002"/><site name="s" at="0.25" pos="0.001 -0.004 0.003"/>
      </cosserat></body></worldbody>
    <tendon><spatial name="cable"><site site="m"/><site site="s"/></spatial></tendon>
    <actuator><motor joint="arm/s1/kz"/><motor site="m" gear="0 0 1 0 0 0"/>
      <muscle tendon="cable" lengthrange="0.09 0.11" scale="300"/><muscle tendon="cable" lengthrange="0.09 0.11" force="5"/>
    </actuator>
  </mujoco>)");
  const mjModel* m = mo.s->m;
  const mjData* d = mo.sd->d;
  mju_copy(mo.sd->d->qpos, m->qpos0, m->nq);
  mju_zero(mo.sd->d->qvel, m->nv);
  forward(*mo.s, *mo.sd);
  const int nv = m->nv;
  Eigen::MatrixXd M(nv, nv);
  mj_fullM(m, M.data(), d->qM);
  M += rod_inertia(*mo.s, *mo.sd, 0, kConstantsQuadrature) - rod_inertia(*mo.s, *mo.sd, 0, 0);
  const Eigen::LDLT<Eigen::MatrixXd> Mc(M);
  auto acc0_of = [&](int i) { return Mc.solve(Eigen::Map<const Eigen::VectorXd>(d->actuator_moment + i * nv, nv)).norm(); };
  for (int i = 0; i < m->nu; ++i) {
    const double acc0 = acc0_of(i);
    EXPECT_GT(acc0, 1.0) << i;  // the rod is light: far above the placeholder model's value
    EXPECT_NEAR(m->actuator_acc0[i], acc0, 1e-9 * acc0) << i;
  }
  // the muscles at full activation, at the cable's length: the default one with F0 = scale / acc0
  // (acc0 from the mass matrix above), the other with its own force
  mo.sd->d->act[0] = mo.sd->d->act[1] = 1.0;
  forward(*mo.s, *mo.sd);
  for (int i : {2, 3}) {
    const double acc0 = acc0_of(i);
    const mjtNum* g = m->actuator_gainprm + mjNGAIN * i;
    const mjtNum* lr = m->actuator_lengthrange + 2 * i;
    const double F0 = i == 2 ? 300.0 / acc0 : 5.0;
    mjtNum prm[mjNGAIN];
    mju_copy(prm, g, mjNGAIN);
    prm[2] = F0;  // mju_muscleGain and mju_muscleBias with the force given
    const double want = mju_muscleGain(d->actuator_length[i], d->actuator_velocity[i], lr, acc0, prm) +
                        mju_muscleBias(d->actuator_length[i], lr, acc0, prm);
    EXPECT_GT(std::abs(want), 1e-3) << i;
    EXPECT_NEAR(d->actuator_force[i], want, 1e-9 * std::abs(want)) << i;
  }
  EXPECT_NEAR(m->stat.meaninertia, M.trace() / nv, 1e-15);
  EXPECT_LT(m->stat.meaninertia, 0.01);  // the placeholder model's was about 1
}

// A slider-crank's moment arm is the derivative of its length: crank and slider sites on the rod,
// a crank on the rod with the slider on the hub, and the rod's base site as crank and as slider.
TEST(Transmission, SliderCrankThroughRodSitesHasItsLengthsDerivative) {
  Motion mo(arm(R"(<site name="h" pos="0.01 0.02 0.03" euler="10 20 30"/>)",
                R"(<motor cranksite="m" slidersite="s" cranklength="0.2" gear="2.5"/>
                   <motor cranksite="s" slidersite="h" cranklength="0.3" gear="1.5"/>
                   <motor cranksite="arm/base" slidersite="s" cranklength="0.2" gear="1"/>
                   <motor cranksite="m" slidersite="arm/base" cranklength="0.2" gear="1"/>)"));
  const int n = mo.s->m->nu;
  ASSERT_EQ(n, 4);
  const double eps = 1e-6;
  std::vector<double> lp, lm;
  const mjData* d = mo.at(eps);
  lp.assign(d->actuator_length, d->actuator_length + n);
  d = mo.at(-eps);
  lm.assign(d->actuator_length, d->actuator_length + n);
  mo.at(0.0);
  for (int a = 0; a < n; ++a) {
    const double rate = (lp[a] - lm[a]) / (2 * eps);
    EXPECT_GT(std::abs(rate), 1e-3) << a;
    EXPECT_NEAR(mo.moment_times_v(a), rate, 1e-6 * std::abs(rate)) << a;
  }
}

// Equality constraints on rod bodies (a connect at an offset anchor on a section's proxy, a weld of
// the rod's tip body): every constraint row of efc_J is the derivative of its residual efc_pos.
TEST(Transmission, EqualityConstraintsOnRodBodiesHaveTheirResidualsDerivative) {
  Motion mo(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
        <body name="tipb"/>
      </cosserat></body></worldbody>
    <equality><connect body1="arm/s1" body2="world" anchor="0.01 0.02 0"/><weld body1="tipb" body2="world"/></equality>
  </mujoco>)");
  const double eps = 1e-6;
  const mjData* d = mo.at(eps);
  const std::vector<double> rp(d->efc_pos, d->efc_pos + d->nefc);
  d = mo.at(-eps);
  const std::vector<double> rm(d->efc_pos, d->efc_pos + d->nefc);
  d = mo.at(0.0);
  const int nv = mo.s->m->nv;
  ASSERT_EQ(d->nefc, 9);  // connect: 3 rows, weld: 6
  ASSERT_FALSE(mj_isSparse(mo.s->m));
  for (int r = 0; r < d->nefc; ++r) {
    double Jv = 0.0;
    for (int i = 0; i < nv; ++i) Jv += d->efc_J[r * nv + i] * mo.motion->v[i];
    const double rate = (rp[r] - rm[r]) / (2 * eps);
    EXPECT_GT(std::abs(rate), 1e-3) << r;
    EXPECT_NEAR(Jv, rate, 1e-7 * std::abs(rate)) << "row " << r;
  }
}

// The reference accelerations of equality rows on the proxies of sections with strain dofs
// (patch_equality_references): MuJoCo's aref minus the rows' velocity product, the acceleration
// at qacc = 0 of the anchor point riding with the cross-section (its offset's centripetal term
// included) and, for a weld's rotation rows, torquescale 0.5 vec(neg(q1) alpha q0 relpose) of the
// cross-section's angular acceleration. Against second differences of the proxies' frames along
// q0 + t v; MuJoCo's anchor layout and rotation rows checked first against efc_pos and efc_vel.
TEST(Transmission, EqualityRowsOnSoftSectionsReferenceTheAnchorsAcceleration) {
  Motion mo(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0"/>
    </body></worldbody>
    <equality><connect body1="arm/s1" body2="world" anchor="0.01 0.02 0"/>
      <weld body1="arm/s2" body2="world" anchor="0.005 -0.01 0.003" torquescale="2"/></equality>
  </mujoco>)");
  const mjModel* m = mo.s->m;
  const int b1 = mj_name2id(m, mjOBJ_BODY, "arm/s1"), b2 = mj_name2id(m, mjOBJ_BODY, "arm/s2");
  const double e = 1e-4;
  struct Frame {
    Vec3 x;
    Mat3 R;
  };
  auto frame = [&](int b, double t) {
    const mjData* d = mo.at(t);
    return Frame{Vec3(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]), Eigen::Map<const Mat3>(d->xmat + 9 * b)};
  };
  // a body's spin at t and the acceleration (qacc = 0) of the point at `offset` in its frame (the
  // offset's centripetal term included: a material anchor's); and its angular acceleration
  auto motion_of = [&](int b, const Vec3& offset, Vec3& a, Vec3& alpha, Vec3& w) {
    auto spin = [&](double t) {
      const Frame fp = frame(b, t + e), fm = frame(b, t - e), f0 = frame(b, t);
      return cosserat::testing::spin_of(Mat3((fp.R - fm.R) / (2 * e) * f0.R.transpose()));
    };
    const Frame fp = frame(b, e), f0 = frame(b, 0.0), fm = frame(b, -e);
    w = spin(0.0);
    alpha = (spin(e) - spin(-e)) / (2 * e);
    const Vec3 r = f0.R * offset;
    a = (fp.x + fp.R * offset - 2.0 * (f0.x + r) + fm.x + fm.R * offset) / (e * e);
  };
  const mjtNum* cdata = m->eq_data;              // connect: anchor on body1 at data[0:3]
  const mjtNum* wdata = m->eq_data + mjNEQDATA;  // weld: body1's anchor at data[3:6], relpose quat at data[6:10]
  Vec3 a1, al1, w1, a2, al2, w2;
  motion_of(b1, Vec3(cdata[0], cdata[1], cdata[2]), a1, al1, w1);
  motion_of(b2, Vec3(wdata[3], wdata[4], wdata[5]), a2, al2, w2);
  const Frame f2 = frame(b2, 0.0);
  const mjData* d = mo.at(0.0);
  ASSERT_EQ(d->nefc, 9);  // connect: 3 rows, weld: 6
  const std::vector<mjtNum> aref(d->efc_aref, d->efc_aref + d->nefc);
  mj_referenceConstraint(m, mo.sd->d);  // MuJoCo's own reference accelerations
  // MuJoCo's weld: the anchor in efc_pos, the rotation rows in efc_vel (the layout the patch reads)
  const Vec3 p2 = f2.x + f2.R * Vec3(wdata[3], wdata[4], wdata[5]), p_world(wdata[0], wdata[1], wdata[2]);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(d->efc_pos[3 + k], p2(k) - p_world(k), 1e-12);
  auto rotation_rows = [&](const Vec3& w) {
    mjtNum q[4], q1[4], q2[4], q3[4];
    mju_mulQuat(q, d->xquat + 4 * b2, wdata + 6);
    mju_negQuat(q1, d->xquat);  // body 2: the world
    const mjtNum axis[3] = {w(0), w(1), w(2)};
    mju_mulQuatAxis(q2, q1, axis);
    mju_mulQuat(q3, q2, q);
    return Vec3(wdata[10] * 0.5 * q3[1], wdata[10] * 0.5 * q3[2], wdata[10] * 0.5 * q3[3]);
  };
  const Vec3 vel_rows = rotation_rows(w2);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(d->efc_vel[6 + k], vel_rows(k), 1e-7 * (1 + vel_rows.norm()));
  // the patch: aref - MuJoCo's = minus the velocity product (the world has none)
  const Vec3 rot = rotation_rows(al2);
  double largest = 0.0;
  for (int k = 0; k < 3; ++k) {
    largest = std::max({largest, std::abs(a1(k)), std::abs(a2(k))});
    EXPECT_NEAR(aref[k] - d->efc_aref[k], -a1(k), 1e-6 * (1 + a1.norm())) << "connect row " << k;
    EXPECT_NEAR(aref[3 + k] - d->efc_aref[3 + k], -a2(k), 1e-6 * (1 + a2.norm())) << "weld row " << k;
    EXPECT_NEAR(aref[6 + k] - d->efc_aref[6 + k], -rot(k), 1e-6 * (1 + rot.norm())) << "weld rotation row " << k;
  }
  EXPECT_GT(largest, 0.1);  // m/s^2: not a vacuous check
}

// Nested rods (probe M): a body below a rigid rod B that hangs below a soft rod A rides with B's
// rigid tip, so its equality rows keep MuJoCo's reference (as the rows on B's proxy do); with B
// soft, it rides with B's tip, not A's: its correction is the anchor's velocity product from B.
TEST(Transmission, BodiesBelowNestedRodsRideWithTheInnermostRod) {
  for (const char* strain : {"rigid", "kl"}) {
    SCOPED_TRACE(strain);
    Motion mo(std::string(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
      <body name="hub" pos="0 0 0.5"><joint name="sh" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
        <cosserat name="A" length="0.3" sections="1" strain="kl" radius="0.01" contype="0" conaffinity="0">
          <body name="Atip"><geom type="sphere" size="0.003" mass="0.001" contype="0" conaffinity="0"/>
            <cosserat name="B" length="0.1" sections="1" strain=")") + strain + R"(" radius="0.005" contype="0" conaffinity="0">
              <body name="Btip"><geom type="sphere" size="0.01" mass="0.01" contype="0" conaffinity="0"/></body>
            </cosserat></body>
        </cosserat></body></worldbody>
      <equality><connect body1="B/s0" anchor="0 0 0"/><connect body1="Btip" anchor="0 0.01 0"/></equality>
    </mujoco>)");
    const mjModel* m = mo.s->m;
    const int b = mj_name2id(m, mjOBJ_BODY, "Btip");
    const double e = 1e-4;
    auto anchor_at = [&](double t) {
      const mjData* d = mo.at(t);
      return Vec3(Eigen::Map<const Vec3>(d->xpos + 3 * b) + Eigen::Map<const Mat3>(d->xmat + 9 * b) * Vec3(0, 0.01, 0));
    };
    const Vec3 a = (anchor_at(e) - 2.0 * anchor_at(0.0) + anchor_at(-e)) / (e * e);  // the anchor's, at qacc = 0
    const mjData* d = mo.at(0.0);
    ASSERT_EQ(d->nefc, 6);
    const std::vector<mjtNum> aref(d->efc_aref, d->efc_aref + d->nefc);
    mj_referenceConstraint(m, mo.sd->d);
    for (int k = 0; k < 3; ++k) {
      const double tip = aref[3 + k] - d->efc_aref[3 + k];  // the Btip row's correction
      if (std::string(strain) == "rigid") {
        EXPECT_EQ(aref[k], d->efc_aref[k]) << "B/s0 row " << k;
        EXPECT_EQ(tip, 0.0) << "Btip row " << k;
      } else {
        EXPECT_NEAR(tip, -a(k), 1e-6 * (1 + a.norm())) << "Btip row " << k;
      }
    }
    if (std::string(strain) != "rigid") EXPECT_GT(a.norm(), 0.1);
  }
}

// Bodies hanging below a soft rod's tip on joints of their own (a hinge; a slide and a hinge below
// it), constrained to a rigid body on a hinge of its own: their equality rows (a connect, a weld)
// get the whole velocity product of the row, both anchors' accelerations at qacc = 0, the tip's
// carried down their joints, and a tendon equality through a site on them its length's (outside
// probe BG: a four-bar's loop drifted 15 mm where MuJoCo's held it to 0.6, with the tip's
// centripetal term over the coupler's 0.4 m offset on one side and nothing on the other). Against
// second differences of the frames along q0 + t v.
TEST(Transmission, RowsOnBodiesJointedBelowASoftRodReferenceTheirOwnAcceleration) {
  Motion mo(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
      <site name="h" pos="0.01 0.02 0"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
        <body name="cp" pos="0.01 0 0"><joint name="jc" type="hinge" axis="0.2 1 0.1"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.005" mass="0.02" contype="0" conaffinity="0"/>
          <body name="cq" pos="0.2 0 0"><joint name="sq" type="slide" axis="1 0 0"/><joint name="hq" type="hinge" axis="0 0 1"/>
            <geom type="sphere" size="0.01" mass="0.01" contype="0" conaffinity="0"/><site name="q" pos="0.03 0.01 0"/></body>
        </body>
      </cosserat></body>
    <body name="R" pos="0.3 0.1 0.8"><joint name="jr" type="hinge" axis="1 0.2 0.3"/>
      <geom type="box" size="0.05 0.02 0.01" pos="0.04 0 0" contype="0" conaffinity="0"/></body></worldbody>
    <tendon><spatial name="t"><site site="h"/><site site="q"/></spatial></tendon>
    <equality><connect body1="cq" body2="R" anchor="0.02 0.01 -0.01"/>
      <weld body1="cp" body2="R" anchor="0.1 0.005 0" torquescale="2"/><tendon tendon1="t"/></equality>
  </mujoco>)");
  const mjModel* m = mo.s->m;
  const int bp = mj_name2id(m, mjOBJ_BODY, "cp"), bq = mj_name2id(m, mjOBJ_BODY, "cq"), br = mj_name2id(m, mjOBJ_BODY, "R");
  const double e = 1e-4;
  auto point = [&](int b, const Vec3& offset, double t) {
    const mjData* d = mo.at(t);
    return Vec3(Eigen::Map<const Vec3>(d->xpos + 3 * b) + Eigen::Map<const Mat3>(d->xmat + 9 * b) * offset);
  };
  auto accel = [&](int b, const Vec3& offset) {
    return Vec3((point(b, offset, e) - 2.0 * point(b, offset, 0.0) + point(b, offset, -e)) / (e * e));
  };
  auto spin = [&](int b, double t) {
    const Mat3 Rp = Eigen::Map<const Mat3>(mo.at(t + e)->xmat + 9 * b), Rm = Eigen::Map<const Mat3>(mo.at(t - e)->xmat + 9 * b);
    const Mat3 R0 = Eigen::Map<const Mat3>(mo.at(t)->xmat + 9 * b);
    return cosserat::testing::spin_of(Mat3((Rp - Rm) / (2 * e) * R0.transpose()));
  };
  // connect: body1's anchor at data[0:3], body2's at data[3:6]; weld: body1's anchor at data[3:6],
  // body2's at data[0:3], relpose quat at data[6:10]
  const mjtNum* cdata = m->eq_data;
  const mjtNum* wdata = m->eq_data + mjNEQDATA;
  const Vec3 a_connect = accel(bq, Vec3(cdata[0], cdata[1], cdata[2])) - accel(br, Vec3(cdata[3], cdata[4], cdata[5]));
  const Vec3 a_weld = accel(bp, Vec3(wdata[3], wdata[4], wdata[5])) - accel(br, Vec3(wdata[0], wdata[1], wdata[2]));
  const Vec3 alpha = (spin(bp, e) - spin(bp, -e) - spin(br, e) + spin(br, -e)) / (2 * e);
  auto length_second = [&](double h) {  // the tendon h -> q: its length's second derivative
    return (mo.at(h)->ten_length[0] - 2.0 * mo.at(0.0)->ten_length[0] + mo.at(-h)->ten_length[0]) / (h * h);
  };
  const double c_tendon = (4 * length_second(5e-4) - length_second(1e-3)) / 3;  // (Richardson)
  const mjData* d = mo.at(0.0);
  ASSERT_EQ(d->nefc, 10);  // connect: 3 rows, weld: 6, tendon: 1
  mjtNum q[4], q1[4], q2[4], q3[4];  // the weld's rotation rows of alpha (MuJoCo 2.2.2's)
  mju_mulQuat(q, d->xquat + 4 * bp, wdata + 6);
  mju_negQuat(q1, d->xquat + 4 * br);
  const mjtNum axis[3] = {alpha(0), alpha(1), alpha(2)};
  mju_mulQuatAxis(q2, q1, axis);
  mju_mulQuat(q3, q2, q);
  const Vec3 rot(wdata[10] * 0.5 * q3[1], wdata[10] * 0.5 * q3[2], wdata[10] * 0.5 * q3[3]);
  const std::vector<mjtNum> aref(d->efc_aref, d->efc_aref + d->nefc);
  mj_referenceConstraint(m, mo.sd->d);  // MuJoCo's own reference accelerations
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(aref[k] - d->efc_aref[k], -a_connect(k), 1e-6 * (1 + a_connect.norm())) << "connect row " << k;
    EXPECT_NEAR(aref[3 + k] - d->efc_aref[3 + k], -a_weld(k), 1e-6 * (1 + a_weld.norm())) << "weld row " << k;
    EXPECT_NEAR(aref[6 + k] - d->efc_aref[6 + k], -rot(k), 1e-6 * (1 + rot.norm())) << "weld rotation row " << k;
  }
  EXPECT_NEAR(d->efc_aref[9] - aref[9], c_tendon, 1e-6 * (1 + std::abs(c_tendon))) << "tendon row";
  EXPECT_GT(a_connect.norm(), 0.1);  // m/s^2: not vacuous
  EXPECT_GT(a_weld.norm(), 0.1);
  EXPECT_GT(rot.norm(), 0.1);
  EXPECT_GT(std::abs(c_tendon), 0.1);
}

// The four-bar of that finding: a motor turns a crank (a rod) whose coupler hangs on a hinge below
// its tip and is connected to a rigid rocker. A stiff soft crank (E = 1e9, 1e11) moves as the rigid
// one (strain="rigid", MuJoCo's own rows bit for bit) and holds the loop as well: over 1.2 s the
// crank angle agrees to 0.01 rad and the loop's gap stays under 1 mm (0.56 mm rigid, MuJoCo's
// soft constraint; 15 mm before the fix).
TEST(Transmission, AFourBarWithAStiffSoftCrankMovesAsTheRigidOne) {
  auto run = [](const std::string& strain, double young) {
    const std::string xml = R"(<mujoco><option timestep="0.0005"/><worldbody>
      <body name="A" pos="0 0 0.5"><joint name="ja" axis="0 1 0" damping="0.01"/>
        <inertial pos="0 0 0" mass="0.01" diaginertia="1e-5 1e-5 1e-5"/>
        <cosserat name="arm" axisangle="0 1 0 -90" length="0.3" sections="4" strain=")" + strain +
                            R"(" radius="0.008" density="1000" young=")" + std::to_string(young) +
                            R"(" contype="0" conaffinity="0">
          <body name="cp" axisangle="0 1 0 90"><joint name="jc" axis="0 1 0"/>
            <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.008" mass="0.05" contype="0" conaffinity="0"/>
            <site name="ce" pos="0.4 0 0"/></body></cosserat></body>
      <body name="B" pos="0.4 0 0.5"><joint name="jb" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.008" mass="0.05" contype="0" conaffinity="0"/></body></worldbody>
      <equality><connect body1="cp" body2="B" anchor="0.4 0 0"/></equality>
      <actuator><motor name="m" joint="ja"/></actuator></mujoco>)";
    auto s = load_scene_string(xml, "/tmp/cosserat_transmission_test.xml");
    SceneData sd(*s);
    const mjModel* m = s->m;
    mjData* d = sd.d;
    d->ctrl[0] = 0.05;
    const int ce = mj_name2id(m, mjOBJ_SITE, "ce"), qa = m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "ja")],
              qb = m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "jb")];
    double gap = 0.0;
    for (int k = 0; k < 2400; ++k) {
      EXPECT_EQ(step(*s, sd), Status::Ok);
      forward(*s, sd);
      const Vec3 top(0.4 + 0.3 * std::sin(d->qpos[qb]), 0.0, 0.5 + 0.3 * std::cos(d->qpos[qb]));
      gap = std::max(gap, (Vec3(d->site_xpos + 3 * ce) - top).norm());
    }
    return std::make_pair(d->qpos[qa], gap);
  };
  const auto [angle_rigid, gap_rigid] = run("rigid", 1e9);
  EXPECT_GT(std::abs(angle_rigid), 4.0);  // the crank turned most of a turn
  for (double young : {1e9, 1e11}) {
    SCOPED_TRACE(young);
    const auto [angle, gap] = run("kl", young);
    EXPECT_NEAR(angle, angle_rigid, 0.01);
    EXPECT_LT(gap, 1e-3);
    EXPECT_LT(gap_rigid, 1e-3);
  }
}

// Tendon limits and tendon equalities through rod sites (patch_tendon_references): MuJoCo's aref
// minus the rows' velocity product, the tendon length's second derivative at qacc = 0 (the rod
// sites', the rigid hub site's accelerations and the segments' turning; before the forty-sixth
// session the rod sites' dL/dp . a alone), against second differences of ten_length along q0 + t v;
// an equality with a quadratic polynomial of a second tendon takes f'' (dL2/dt)^2 as well.
TEST(Transmission, TendonRowsThroughRodSitesReferenceTheSitesAcceleration) {
  Motion mo(R"(<mujoco><option gravity="0 0 -9.81"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/><geom type="sphere" size="0.02"/>
      <site name="h" pos="0.01 0.02 0"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="0" conaffinity="0">
        <site name="m" at="0.15" pos="0 0.006 0.002"/><site name="s" at="0.25" pos="0.001 -0.004 0.003"/>
      </cosserat></body>
    <body name="R" pos="0.3 0.1 0.8"><joint name="jr" type="hinge" axis="1 0.2 0.3"/>
      <geom type="box" size="0.05 0.02 0.01" pos="0.04 0 0" contype="0" conaffinity="0"/><site name="w" pos="0.05 0.01 0"/></body>
    </worldbody>
    <tendon><spatial name="lim" limited="true" range="0 0.01"><site site="h"/><site site="m"/><site site="s"/></spatial>
      <spatial name="eq"><site site="m"/><site site="s"/></spatial>
      <spatial name="eq2"><site site="w"/><site site="s"/><pulley divisor="2"/><site site="w"/><site site="h"/></spatial></tendon>
    <equality><tendon tendon1="eq"/><tendon tendon1="eq2" tendon2="eq" polycoef="0 0.5 3 0 0"/></equality>
  </mujoco>)");
  const mjModel* m = mo.s->m;
  // 30x the bent motion's speeds: at its own the strain rates change the segments' lengths by
  // 1e-5 m/s^2, where the hub's turning accelerates the sites by 0.1 m/s^2 without changing them
  // (which the one-sided rule took for the tendons', and a check of it against the sites'
  // accelerations passed)
  for (double& vi : mo.motion->v) vi *= 30;
  auto length_at = [&](int t, double tt) { return mo.at(tt)->ten_length[t]; };
  auto second_at = [&](int t, double e) {
    return (length_at(t, e) - 2.0 * length_at(t, 0.0) + length_at(t, -e)) / (e * e);
  };
  auto second = [&](int t) { return (4 * second_at(t, 5e-4) - second_at(t, 1e-3)) / 3; };  // (Richardson)
  const int t_lim = mj_name2id(m, mjOBJ_TENDON, "lim"), t_eq = mj_name2id(m, mjOBJ_TENDON, "eq"),
            t_eq2 = mj_name2id(m, mjOBJ_TENDON, "eq2");
  const double c_lim = second(t_lim), c_eq = second(t_eq), c_eq2 = second(t_eq2);
  const mjData* d = mo.at(0.0);
  // eq2 - f(eq), f(x) = 0.5 x + 3 x^2 with x = L_eq - L_eq0: its row's velocity product
  const double x = d->ten_length[t_eq] - m->tendon_length0[t_eq];
  const double c_poly = c_eq2 - (0.5 + 6 * x) * c_eq - 6 * d->ten_velocity[t_eq] * d->ten_velocity[t_eq];
  int lim_row = -1, eq_row = -1, poly_row = -1;
  for (int r = 0; r < d->nefc; ++r) {
    if (d->efc_type[r] == mjCNSTR_LIMIT_TENDON) lim_row = r;
    if (d->efc_type[r] == mjCNSTR_EQUALITY) (d->efc_id[r] == 0 ? eq_row : poly_row) = r;
  }
  ASSERT_GE(lim_row, 0);  // the upper limit: the row is -dL/dq
  ASSERT_GE(eq_row, 0);
  ASSERT_GE(poly_row, 0);
  const std::vector<mjtNum> aref(d->efc_aref, d->efc_aref + d->nefc);
  mj_referenceConstraint(m, mo.sd->d);
  EXPECT_NEAR(d->efc_aref[lim_row] - aref[lim_row], -c_lim, 1e-6 * (1 + std::abs(c_lim)));
  EXPECT_NEAR(d->efc_aref[eq_row] - aref[eq_row], c_eq, 1e-6 * (1 + std::abs(c_eq)));
  EXPECT_NEAR(d->efc_aref[poly_row] - aref[poly_row], c_poly, 1e-6 * (1 + std::abs(c_poly)));
  EXPECT_GT(std::abs(c_lim), 1e-3);  // m/s^2: not vacuous
  EXPECT_GT(std::abs(c_eq), 1e-3);
  EXPECT_GT(std::abs(c_poly), 1e-3);
}

// A cable from a turning table over a cylinder on the table to a stiff soft rod's tip riding with
// the table, held by its limit (outside probe BI: under the rod sites' share alone the limit gave
// way 11.9 mm, the cylinder's and the table site's centripetal terms left out; the tangent points
// now move with the cylinder): it stretches past its limit as far as with a rigid rod, give or take
// the soft rod's inverse weight (0.58 and 0.73 mm).
TEST(Transmission, ATendonLimitOverAGeomOnATurningTableHoldsAsWithARigidRod) {
  auto overshoot = [](const char* strain) {
    auto s = load_scene_string(std::string(R"(<mujoco><option timestep="0.0005" gravity="0 0 0"/><worldbody>
      <body name="tt" pos="0 0 0.1"><joint name="spin" axis="0 0 1"/><inertial pos="0 0 0" mass="10" diaginertia="1 1 1"/>
        <site name="h0" pos="0 0.02 0"/><site name="side" pos="0.15 0.03 0"/>
        <geom name="cyl" type="cylinder" pos="0.15 0 0" size="0.015 0.02" contype="0" conaffinity="0" mass="0.001"/>
        <body name="car"><joint name="sl" type="slide" axis="1 0 0"/><inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/>
          <cosserat name="arm" length="0.3" sections="4" strain=")") + strain + R"(" radius="0.008" density="1000" young="1e11" contype="0" conaffinity="0">
            <body name="ball"><geom type="sphere" size="0.02" mass="0.2" contype="0" conaffinity="0"/></body>
          </cosserat></body></body></worldbody>
      <tendon><spatial name="cab" limited="true" range="0 0.285"><site site="h0"/><geom geom="cyl" sidesite="side"/><site site="arm/tip"/></spatial></tendon>
      <actuator><velocity name="v" joint="spin" kv="20"/></actuator></mujoco>)", "/tmp/cosserat_transmission_test.xml");
    SceneData sd(*s);
    sd.d->ctrl[0] = 10;
    for (int k = 0; k < 3000; ++k) EXPECT_EQ(step(*s, sd), Status::Ok);
    forward(*s, sd);
    EXPECT_NEAR(sd.d->qvel[0], 10.0, 1e-3);
    return sd.d->ten_length[0] - 0.285;
  };
  const double rigid = overshoot("rigid"), soft = overshoot("kl");
  EXPECT_GT(rigid, 1e-4);
  EXPECT_LT(soft, 1.5 * rigid);
}

// An adhesion actuator (MuJoCo's body transmission) on a ball near rod capsules, inside their
// margin and, for some, beyond their gap: MuJoCo counts a gap contact without a constraint row and
// takes its normal Jacobian n . (J2 - J1) directly; with the rod's touching material point (as the
// contact rows take it) the moment arm times v is minus the mean normal velocity of the contacts.
TEST(Transmission, AdhesionThroughGapContactsWithARodHasTheMaterialPointsMomentArm) {
  // the ball 2 cm off the middle capsule of the bent rod (placed from a first load at that state)
  auto xml = [](const Vec3& ball) {
    char pos[96];
    std::snprintf(pos, sizeof pos, "%.17g %.17g %.17g", ball(0), ball(1), ball(2));
    return std::string(R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="hub" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0.3 1"/>
      <geom type="sphere" size="0.02" contype="0" conaffinity="0"/>
      <cosserat name="arm" length="0.3" sections="3" strain="kl" radius="0.01" contype="1" conaffinity="1"
                margin="0.05" gap="0.04"/></body>
    <body name="ball" pos=")") + pos + R"(">
      <geom name="ball" type="sphere" size="0.02" margin="0.05" gap="0.04"/></body>
    </worldbody><actuator><adhesion body="ball" ctrlrange="0 1"/></actuator></mujoco>)";
  };
  Vec3 ball;
  {
    Motion first(xml(Vec3(0, 0, 3)));
    const mjData* d = first.at(0.0);
    const int g = mj_name2id(first.s->m, mjOBJ_GEOM, "arm/s1/g0");
    const Vec3 c(d->geom_xpos + 3 * g), ax(d->geom_xmat[9 * g + 2], d->geom_xmat[9 * g + 5], d->geom_xmat[9 * g + 8]);
    const Vec3 normal = ax.cross(Vec3(0, 0, 1)).normalized();
    ball = c + (0.01 + 0.02 + 0.02) * normal;  // 2 cm apart: in the 5 cm margin, beyond margin - gap
  }
  Motion mo(xml(ball));
  // MuJoCo's moment: minus the mean over the ball's contacts of n . (v2 - v1), the contact points'
  // velocities along the normal (the rod's side: its touching material point, by central
  // differences along qvel; the ball is fixed)
  const mjData* d = mo.at(0.0);
  ASSERT_GE(d->ncon, 1);
  const double eps = 1e-6;
  std::vector<mjtNum> qp(mo.motion->q0), qm(mo.motion->q0);
  for (size_t k = 0; k < qp.size(); ++k) {
    qp[k] += eps * mo.motion->v[k];
    qm[k] -= eps * mo.motion->v[k];
  }
  int gap = 0;
  double rate = 0.0;
  for (int k = 0; k < d->ncon; ++k) {
    const mjContact& con = d->contact[k];
    gap += con.exclude == 1;
    const bool rod_first = mo.s->geom_rod[con.geom1] >= 0;
    const cosserat::testing::MaterialPoint mp =
        cosserat::testing::contact_point(*mo.s, *mo.sd, con, rod_first ? con.geom1 : con.geom2);
    const Vec3 v = (cosserat::testing::material_pose(*mo.s, qp, mp).u - cosserat::testing::material_pose(*mo.s, qm, mp).u) /
                   (2 * eps);
    rate += (rod_first ? -1.0 : 1.0) * Vec3(con.frame[0], con.frame[1], con.frame[2]).dot(v) / d->ncon;
  }
  EXPECT_GE(gap, 1);  // at least one contact in the gap: no constraint row
  EXPECT_GT(std::abs(rate), 1e-2);
  EXPECT_NEAR(mo.moment_times_v(0), -rate, 1e-6 * std::abs(rate));
}

}  // namespace
