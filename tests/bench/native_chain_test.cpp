// The MuJoCo-native chain the benchmarks compare against (bench/native_chain.hpp): its rest shape is
// the rod's, across section boundaries; its springs and armature are what the header says.
#include "native_chain.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <memory>
#include <string>

#include "common.hpp"
#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::bench;

namespace {

const std::string kModels = COSSERAT_SOURCE_DIR "/models/";
constexpr double kPi = 3.14159265358979323846;

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};

Vec3 site_pos(const mjModel* m, const mjData* d, const char* name) {
  const int i = mj_name2id(m, mjOBJ_SITE, name);
  EXPECT_GE(i, 0) << name;
  return i < 0 ? Vec3::Zero() : Vec3(d->site_xpos[3 * i], d->site_xpos[3 * i + 1], d->site_xpos[3 * i + 2]);
}

// The flagellate's rod is a straight hook followed by helical sections: a chain link straddling the
// hook's end took one section's strain for all of it (outside probe Q: the helix 2 mm off at every
// N). At rest the chain's sites sit where the rod's do, for chain lengths whose links straddle the
// boundary (16, 24, 48) and one whose do not.
TEST(NativeChain, RestShapeComposesTheSectionsAcrossTheirBoundaries) {
  const std::string path = kModels + "flagellate_rigid.xml";
  const std::string xml = read_file(path);
  auto rod = mj::load_scene(path);
  mj::SceneData sd(*rod);
  mj::forward(*rod, sd);
  for (int N : {16, 24, 48, 64}) {
    NativeChainOptions o;
    o.segments = N;
    std::unique_ptr<mjModel, ModelDeleter> m(load_mujoco_string(native_chain_xml(xml, path, o), path));
    std::unique_ptr<mjData, DataDeleter> d(mj_makeData(m.get()));
    mj_kinematics(m.get(), d.get());
    for (const char* site : {"hook_end", "flagellum/tip"})
      EXPECT_LT((site_pos(m.get(), d.get(), site) - site_pos(rod->m, sd.d, site)).norm(), 1e-12)
          << "N = " << N << ", " << site;
  }
}

// Springs and armature of a cantilever's chain: EI/ds for bending, GJ/ds for torsion; the clamp
// factor on the first joint's bending only (doubling its torsion made it too stiff to first order,
// outside probe Q); armature a rho A ds^3 / 12 on every hinge.
TEST(NativeChain, SpringsAndArmature) {
  const double L = 0.5, r = 0.005, E = 1e8, nu = 0.5, rho = 1000.0;
  const std::string xml = R"(<mujoco><worldbody>
    <cosserat name="rod" length="0.5" sections="4" strain="ikl" radius="0.005" density="1000" young="1e8" poisson="0.5"/>
  </worldbody></mujoco>)";
  const int N = 8;
  const double ds = L / N, A = kPi * r * r, I = kPi * r * r * r * r / 4, G = E / (2 * (1 + nu));
  NativeChainOptions o;
  o.segments = N;
  o.base_spring_factor = 2.0;
  o.armature_factor = 10.0;
  std::unique_ptr<mjModel, ModelDeleter> m(load_mujoco_string(native_chain_xml(xml, "/tmp/chain.xml", o), "/tmp/chain.xml"));
  ASSERT_EQ(m->nv, 3 * N);  // ikl: three hinges per joint
  for (int k = 0; k < N; ++k) {
    const std::string j = "rod/b" + std::to_string(k) + "/";
    const int kx = mj_name2id(m.get(), mjOBJ_JOINT, (j + "kx").c_str()), ky = mj_name2id(m.get(), mjOBJ_JOINT, (j + "ky").c_str());
    ASSERT_GE(kx, 0);
    ASSERT_GE(ky, 0);
    const double f = k == 0 ? 2.0 : 1.0;
    EXPECT_NEAR(m->jnt_stiffness[kx], G * 2 * I / ds, 1e-9 * G * I / ds) << k;
    EXPECT_NEAR(m->jnt_stiffness[ky], f * E * I / ds, 1e-9 * E * I / ds) << k;
    EXPECT_NEAR(m->dof_armature[m->jnt_dofadr[ky]], 10.0 * rho * A * ds * ds * ds / 12, 1e-15) << k;
  }
}

// A rod's strainrange becomes the chain's joint limits: a strain range times ds, a hinge's angle in
// the model's angle unit (MuJoCo reads degrees unless <compiler angle="radian">), a slide's
// displacement, with the rod's solreflimit; a <section>'s own range and rotational limits on ball
// joints have no equivalent and are refused.
TEST(NativeChain, StrainRangeBecomesJointLimits) {
  const std::string rod = R"(<cosserat name="rod" length="0.5" sections="2" strain="kl" radius="0.005"
      strainrange="0 0 -1 2 0 0 -0.1 0.2 0 0 0 0" solreflimit="0.004 1")";
  const int N = 10;
  const double ds = 0.5 / N;
  NativeChainOptions o;
  o.segments = N;
  for (const bool radian : {false, true}) {
    SCOPED_TRACE(radian ? "radian" : "degree");
    const std::string xml = std::string("<mujoco>") + (radian ? R"(<compiler angle="radian"/>)" : "") +
                            "<worldbody>" + rod + "/></worldbody></mujoco>";
    std::unique_ptr<mjModel, ModelDeleter> m(load_mujoco_string(native_chain_xml(xml, "/tmp/chain.xml", o), "/tmp/chain.xml"));
    for (int k = 0; k < N; ++k) {
      const std::string j = "rod/b" + std::to_string(k) + "/";
      const int kx = mj_name2id(m.get(), mjOBJ_JOINT, (j + "kx").c_str()), ky = mj_name2id(m.get(), mjOBJ_JOINT, (j + "ky").c_str()),
                px = mj_name2id(m.get(), mjOBJ_JOINT, (j + "px").c_str());
      ASSERT_GE(kx, 0);
      ASSERT_GE(ky, 0);
      ASSERT_GE(px, 0);
      EXPECT_EQ(m->jnt_limited[kx], 0);
      ASSERT_EQ(m->jnt_limited[ky], 1);
      EXPECT_NEAR(m->jnt_range[2 * ky], -1.0 * ds, 1e-12);  // radians in the compiled model either way
      EXPECT_NEAR(m->jnt_range[2 * ky + 1], 2.0 * ds, 1e-12);
      ASSERT_EQ(m->jnt_limited[px], 1);
      EXPECT_NEAR(m->jnt_range[2 * px], -0.1 * ds, 1e-15);
      EXPECT_NEAR(m->jnt_range[2 * px + 1], 0.2 * ds, 1e-15);
      EXPECT_EQ(m->jnt_solref[mjNREF * ky], 0.004);
    }
  }
  // a <section>'s own range: the joints in that section take it, the others the rod's
  const std::string own = "<mujoco><worldbody>" + rod + ">\n<section strainrange=\"0 0 0 0 -3 1 0 0 0 0 0 0\"/><section/></cosserat></worldbody></mujoco>";
  {
    std::unique_ptr<mjModel, ModelDeleter> m(load_mujoco_string(native_chain_xml(own, "/tmp/chain.xml", o), "/tmp/chain.xml"));
    for (int k = 0; k < N; ++k) {
      SCOPED_TRACE(k);
      const std::string j = "rod/b" + std::to_string(k) + "/";
      const int kz = mj_name2id(m.get(), mjOBJ_JOINT, (j + "kz").c_str()), ky = mj_name2id(m.get(), mjOBJ_JOINT, (j + "ky").c_str()),
                px = mj_name2id(m.get(), mjOBJ_JOINT, (j + "px").c_str());
      ASSERT_GE(kz, 0);
      ASSERT_GE(ky, 0);
      ASSERT_GE(px, 0);
      const bool first = k < N / 2;  // joints at X_k = k ds: the first five in the first section
      EXPECT_EQ(m->jnt_limited[kz], first ? 1 : 0);
      EXPECT_EQ(m->jnt_limited[ky], first ? 0 : 1);
      EXPECT_EQ(m->jnt_limited[px], first ? 0 : 1);
      if (first) {
        EXPECT_NEAR(m->jnt_range[2 * kz], -3.0 * ds, 1e-12);
        EXPECT_NEAR(m->jnt_range[2 * kz + 1], 1.0 * ds, 1e-12);
        EXPECT_EQ(m->jnt_solref[mjNREF * kz], 0.004);
      } else {
        EXPECT_NEAR(m->jnt_range[2 * ky + 1], 2.0 * ds, 1e-12);
      }
    }
  }
  o.ball = true;
  EXPECT_THROW(native_chain_xml("<mujoco><worldbody>" + rod + "/></worldbody></mujoco>", "/tmp/chain.xml", o),
               std::runtime_error);
}

}  // namespace
