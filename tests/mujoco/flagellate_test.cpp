// Swimming flagellates (models/flagellate*.xml, lophotrichous.xml): the shipped models load and
// swim; physics checks at low Reynolds number (speed proportional to the motor frequency for the
// rigid flagellum, reversal, no thrust from a straight flagellum); and the rigid flagellum of our
// solver against the same flagellum built natively in MuJoCo from capsules, whose deviation
// shrinks as N^-2 with the number N of capsules.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "fluid.hpp"
#include "scene.hpp"
#include "support/text_file.hpp"

using namespace cosserat;
using namespace cosserat::mj;

namespace {

const std::string kModels = std::string(COSSERAT_SOURCE_DIR) + "/models/";

using cosserat::testing::read_text;

std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// Replaces the one occurrence of `a` in s by `b` (fails the test if absent).
std::string replace(std::string s, const std::string& a, const std::string& b) {
  const size_t p = s.find(a);
  EXPECT_NE(p, std::string::npos) << a;
  if (p != std::string::npos) s.replace(p, a.size(), b);
  return s;
}

Vec3 body_pos(const Scene& s, const SceneData& sd, const char* name) {
  const int b = mj_name2id(s.m, mjOBJ_BODY, name);
  return Vec3(sd.d->xpos[3 * b], sd.d->xpos[3 * b + 1], sd.d->xpos[3 * b + 2]);
}

// Head-first swimming velocity along the head's initial axis (the nose is at -x of the head),
// averaged over `periods` motor periods after one period of transient.
double forward_speed(const Scene& s, double f, double periods = 2) {
  SceneData sd(s);
  for (int a = 0; a < s.m->nu; ++a) sd.d->ctrl[a] = f;
  const double h = s.m->opt.timestep, T = 1.0 / std::abs(f);
  const long n0 = std::lround(T / h), n1 = std::lround((1 + periods) * T / h);
  Vec3 p0 = Vec3::Zero();
  for (long k = 0; k <= n1; ++k) {
    if (k == n0) {
      forward(s, sd);
      p0 = body_pos(s, sd, "head");
    }
    if (k < n1) EXPECT_EQ(step(s, sd), Status::Ok);
  }
  forward(s, sd);
  return -(body_pos(s, sd, "head") - p0).x() / ((n1 - n0) * h);
}

TEST(Flagellate, ShippedModelsLoadAndSwim) {
  for (const char* name : {"flagellate.xml", "flagellate_rigid.xml", "flagellate_native.xml", "lophotrichous.xml"}) {
    SCOPED_TRACE(name);
    auto s = load_scene(kModels + name);
    EXPECT_TRUE(s->fluid.active);
    EXPECT_EQ(s->m->opt.viscosity, 0.0);
    EXPECT_EQ(s->fluid.viscosity, 5.0);
    SceneData sd(*s);
    mj_resetDataKeyframe(s->m, sd.d, mj_name2id(s->m, mjOBJ_KEY, "swim"));
    for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(*s, sd), Status::Ok);  // one motor turn
    forward(*s, sd);
    EXPECT_LT(body_pos(*s, sd, "head").x(), -1e-3);  // head first, along -x
  }
}

// The generated native twin (tools/flagellate_native.py) follows the rod's centreline and uses the
// rod's resistive-force coefficients.
TEST(Flagellate, NativeTwinMatchesTheRigidRod) {
  auto rigid = load_scene(kModels + "flagellate_rigid.xml");
  auto native = load_scene(kModels + "flagellate_native.xml");
  SceneData sr(*rigid), sn(*native);
  forward(*rigid, sr);
  forward(*native, sn);
  const Model& rod = rigid->rods[0].model;
  const Node& node = rod.nodes[rod.sections[1].first_node];
  const int id = mj_name2id(native->m, mjOBJ_NUMERIC, "cosserat:drag:flagellum");
  ASSERT_GE(id, 0);
  const mjtNum* c = native->m->numeric_data + native->m->numeric_adr[id];
  EXPECT_NEAR(c[0], node.drag(3, 3) / node.dX, 1e-8 * c[0]);
  EXPECT_NEAR(c[1], node.drag(4, 4) / node.dX, 1e-8 * c[1]);
  EXPECT_NEAR(c[2], node.drag(0, 0) / node.dX, 1e-8 * c[2]);
  // capsule j of the helix spans [X_j, X_j+1] of the rod
  const double Lh = rod.rods[0].length - 0.01;
  const mjModel* m = native->m;
  int checked = 0;
  for (int g = 0; g < m->ngeom; ++g) {
    const char* gn = mj_id2name(m, mjOBJ_GEOM, g);
    if (!gn || std::string(gn).rfind("flagellum/c", 0) != 0) continue;
    const int j = std::atoi(gn + 11);
    const double Xa = j == 0 ? 0.0 : 0.01 + Lh * (j - 1) / 64, Xb = j == 0 ? 0.01 : 0.01 + Lh * j / 64;
    const Vec3 centre(sn.d->geom_xpos[3 * g], sn.d->geom_xpos[3 * g + 1], sn.d->geom_xpos[3 * g + 2]);
    const Vec3 axis(sn.d->geom_xmat[9 * g + 2], sn.d->geom_xmat[9 * g + 5], sn.d->geom_xmat[9 * g + 8]);
    const double half = m->geom_size[3 * g + 1];
    const Vec3 a = rod_frame(*rigid, sr, 0, Xa).u, b = rod_frame(*rigid, sr, 0, Xb).u;
    EXPECT_LT((centre - 0.5 * (a + b)).norm(), 1e-9) << gn;
    // the capsule's ends are a and b (MuJoCo's frame may point either way along fromto)
    EXPECT_LT(std::min((centre + half * axis - b).norm(), (centre - half * axis - b).norm()), 1e-9) << gn;
    ++checked;
  }
  EXPECT_EQ(checked, 65);
}

// At low Reynolds number a rigid swimmer's speed is proportional to the motor frequency (Stokes
// flow is linear and instantaneous; only the small inertia of head and flagellum departs from it).
TEST(Flagellate, RigidSpeedIsProportionalToFrequency) {
  auto s = load_scene(kModels + "flagellate_rigid.xml");
  const double per_turn = forward_speed(*s, 1.0);
  EXPECT_GT(per_turn, 2e-3);  // about 3 mm per turn
  for (double f : {0.5, 2.0}) {
    const double v = forward_speed(*s, f);
    EXPECT_NEAR(v / f, per_turn, 2e-3 * per_turn) << "f = " << f;
  }
}

// The soft flagellum given ABS's stiffness (hook and helix, E = 2.3 GPa) swims like the rigid
// sections of flagellate_rigid.xml: the soft path (strain dofs, implicit stiffness, the fluid on
// moving sections) against the rigid one.
TEST(Flagellate, StiffSoftFlagellumMatchesTheRigidOne) {
  const std::string soft = read_text(kModels + "flagellate.xml");
  const std::string stiff = replace(soft, "young=\"1e6\"", "young=\"2.3e9\"");
  const double v_stiff = forward_speed(*load_scene_string(stiff, kModels + "x.xml"), 1.0, 1);
  const double v_rigid = forward_speed(*load_scene(kModels + "flagellate_rigid.xml"), 1.0, 1);
  std::printf("1 Hz: rigid sections %.6g m/s, soft sections with E = 2.3 GPa %.6g m/s\n", v_rigid, v_stiff);
  EXPECT_NEAR(v_stiff, v_rigid, 2e-3 * v_rigid);
}

// Reversing the motor reverses the swimming direction: exactly (to the inertia effects) for the
// rigid flagellum, in sign for the soft one (a soft helix deforms differently pushed and pulled).
TEST(Flagellate, ReversingTheMotorReversesSwimming) {
  auto rigid = load_scene(kModels + "flagellate_rigid.xml");
  const double a = forward_speed(*rigid, 1.0), b = forward_speed(*rigid, -1.0);
  EXPECT_GT(a, 0.0);
  EXPECT_NEAR(b, -a, 5e-3 * a);
  auto soft = load_scene(kModels + "flagellate.xml");
  const double c = forward_speed(*soft, 2.0, 1), d = forward_speed(*soft, -2.0, 1);
  EXPECT_GT(c, 0.5 * 2 * a);
  EXPECT_LT(d, -0.5 * 2 * a);
}

// A straight flagellum produces no net thrust. (1) rigid, tilted 30 degrees off the motor axis in
// a plane through the axis, the head on a rail along the axis (a slide joint: the thrust is what
// moves it): the swimmer is mirror-symmetric about that plane, so by mirror symmetry and the
// linearity of Stokes flow in the motor rate the axial velocity is odd in the motor angle and
// averages to zero over a turn, while the helix of flagellate_rigid.xml on the same rail swims.
// (A free swimmer with such a rod wobbles and may drift along a helical path: achiral rotating
// bodies are not barred from that; thrust is the clean statement.) (2) soft, along the motor axis,
// free: it spins about its own axis, stays straight and does not swim.
TEST(Flagellate, StraightFlagellumGivesNoThrust) {
  const std::string rigid = replace(read_text(kModels + "flagellate_rigid.xml"), "<freejoint name=\"head\"/>",
                                    "<joint name=\"rail\" type=\"slide\" axis=\"1 0 0\"/>");
  const double helix = forward_speed(*load_scene_string(rigid, kModels + "x.xml"), 1.0);
  EXPECT_GT(helix, 1e-3);
  const size_t a = rigid.find("<geom name=\"crank\""), b = rigid.find("</cosserat>") + 11;
  ASSERT_NE(a, std::string::npos);
  const double c30 = std::cos(M_PI / 6), s30 = std::sin(M_PI / 6);
  const std::string straight =
      rigid.substr(0, a) +
      "<geom name=\"crank\" type=\"capsule\" fromto=\"0.008 0 0 0.008 0 0.008\" size=\"0.0025\" density=\"1100\"/>\n"
      "<cosserat name=\"flagellum\" pos=\"0.008 0 0.008\" xyaxes=\"" + fmt(c30) + " 0 " + fmt(s30) +
      " 0 1 0\" length=\"0.12\" sections=\"4\" strain=\"rigid\" quadrature=\"4\" radius=\"0.0025\" density=\"1050\"/>" +
      rigid.substr(b);
  const double v = forward_speed(*load_scene_string(straight, kModels + "x.xml"), 1.0);
  std::printf("on the rail at 1 Hz: helix %.4g m/s, straight tilted rod %.3g m/s\n", helix, v);
  EXPECT_LT(std::abs(v), 1e-3 * helix) << "straight " << v << " helix " << helix;

  const std::string free = read_text(kModels + "flagellate_rigid.xml");
  const size_t fa = free.find("<geom name=\"crank\""), fb = free.find("</cosserat>") + 11;
  const std::string soft =
      free.substr(0, fa) +
      "<cosserat name=\"flagellum\" pos=\"0.008 0 0\" length=\"0.12\" sections=\"4\" strain=\"kl\" radius=\"0.0025\" "
      "density=\"1080\" young=\"1e6\" poisson=\"0.49\" viscosity=\"5\"/>" +
      free.substr(fb);
  auto s = load_scene_string(soft, kModels + "x.xml");
  const double w = forward_speed(*s, 1.0, 1);
  std::printf("free, straight soft rod on the axis: %.3g m/s\n", w);
  EXPECT_LT(std::abs(w), 1e-6 * helix);
}

// Our rigid flagellum against MuJoCo's own: the flagellum as N capsules welded into one body along
// the rod's centreline (as tools/flagellate_native.py builds it), same motor, same fluid model.
// The head trajectories deviate by the capsule chain's discretisation error, O(N^-2).
TEST(Flagellate, NativeCapsuleChainConvergesToTheRod) {
  const std::string rigid_xml = read_text(kModels + "flagellate_rigid.xml");
  auto rigid = load_scene_string(rigid_xml, kModels + "x.xml");
  SceneData sr(*rigid);
  forward(*rigid, sr);
  const Model& rod = rigid->rods[0].model;
  const double L = rod.rods[0].length, hook = 0.01, a = 0.0025, lin_mass = 1050 * M_PI * a * a;
  const Node& node = rod.nodes[rod.sections[1].first_node];
  const SE3 base = rod_frame(*rigid, sr, 0, 0.0);
  auto local = [&](double X) { return base.inverse().act(rod_frame(*rigid, sr, 0, X).u); };
  const size_t open = rigid_xml.find("<cosserat"), close = rigid_xml.find("</cosserat>") + 11;
  const size_t pos_at = rigid_xml.find("pos=", open), frame_end = rigid_xml.find("length=", open);
  const std::string frame = rigid_xml.substr(pos_at, frame_end - pos_at);  // pos and xyaxes
  auto native_xml = [&](int N) {
    std::string body = "<body name=\"flagellum\" " + frame + ">\n";
    std::vector<double> X = {0.0, hook};
    for (int j = 1; j <= N; ++j) X.push_back(hook + (L - hook) * j / N);
    for (size_t j = 0; j + 1 < X.size(); ++j) {
      const Vec3 p = local(X[j]), q = local(X[j + 1]);
      body += "<geom type=\"capsule\" size=\"" + fmt(a) + "\" mass=\"" + fmt(lin_mass * (X[j + 1] - X[j])) +
              "\" fromto=\"" + fmt(p.x()) + " " + fmt(p.y()) + " " + fmt(p.z()) + " " + fmt(q.x()) + " " + fmt(q.y()) +
              " " + fmt(q.z()) + "\"/>\n";
    }
    body += "</body>\n";
    std::string x = rigid_xml.substr(0, open) + body + rigid_xml.substr(close);
    const std::string drag = fmt(node.drag(3, 3) / node.dX) + " " + fmt(node.drag(4, 4) / node.dX) + " " +
                             fmt(node.drag(0, 0) / node.dX);
    return replace(x, "<actuator>", "<custom><numeric name=\"cosserat:drag:flagellum\" data=\"" + drag + "\"/></custom>\n<actuator>");
  };
  // head trajectories over 2 s at 1 Hz, sampled every step
  auto trajectory = [](const Scene& s) {
    SceneData sd(s);
    sd.d->ctrl[0] = 1.0;
    std::vector<Vec3> p;
    for (int k = 0; k < 2000; ++k) {
      EXPECT_EQ(step(s, sd), Status::Ok);
      p.push_back(Vec3(sd.d->qpos[0], sd.d->qpos[1], sd.d->qpos[2]));
    }
    return p;
  };
  const std::vector<Vec3> ref = trajectory(*rigid);
  EXPECT_GT((ref.back() - ref.front()).norm(), 4e-3);  // swam about 6 mm
  std::vector<double> dev;
  for (int N : {16, 32, 64}) {
    auto native = load_scene_string(native_xml(N), kModels + "x.xml");
    ASSERT_TRUE(native->rods.empty());
    ASSERT_TRUE(native->fluid.active);
    const std::vector<Vec3> p = trajectory(*native);
    double d = 0;
    for (size_t k = 0; k < p.size(); ++k) d = std::max(d, (p[k] - ref[k]).norm());
    dev.push_back(d);
    std::printf("N = %d capsules: max head deviation %.3g m\n", N, d);
  }
  EXPECT_NEAR(dev[0] / dev[1], 4.0, 0.4);
  EXPECT_NEAR(dev[1] / dev[2], 4.0, 0.4);
  EXPECT_LT(dev[2], 1e-4);
}

}  // namespace
