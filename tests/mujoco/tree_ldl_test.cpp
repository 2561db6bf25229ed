// The implicit step's tree factorisation (plugin/mujoco/tree_ldl.hpp) against MuJoCo's own
// mj_factorM / mj_solveM on the mass matrices of the shipped models, and against the matrix itself.
#include "tree_ldl.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "scene.hpp"

using namespace cosserat::mj;

namespace {

const std::string kModels = std::string(COSSERAT_SOURCE_DIR) + "/models/";

// A free sphere and a hinged arm next to a rod: a forest with simple dofs (MuJoCo's
// dof_simplenum), which both factorisations skip.
const char* kForest = R"(<mujoco>
  <worldbody>
    <body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.05" mass="0.3"/></body>
    <body name="arm" pos="0.3 0 0.5"><joint type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/>
      <body pos="0.2 0 0"><joint type="ball"/><geom type="sphere" size="0.03" pos="0.05 0 0" mass="0.1"/></body>
    </body>
    <cosserat name="rod" pos="0 0.5 1" length="0.3" sections="4" strain="kl" radius="0.01" density="1000" young="1e6"/>
  </worldbody>
</mujoco>)";

double max_rel_diff(const mjtNum* a, const mjtNum* b, int n) {
  double scale = 0.0, diff = 0.0;
  for (int i = 0; i < n; ++i) scale = std::max(scale, std::abs(b[i])), diff = std::max(diff, std::abs(a[i] - b[i]));
  return diff / scale;
}

TEST(TreeLdl, EqualsMujocosFactorisationAndSolves) {
  bool simple_seen = false;
  for (const std::string& src : {kModels + "lophotrichous.xml", kModels + "hybrid_arm.xml", kModels + "octopus_arm.xml",
                                 kModels + "flagellate.xml", std::string("forest")}) {
    SCOPED_TRACE(src);
    auto s = src == "forest" ? load_scene_string(kForest, "/tmp/cosserat_tree_ldl_test.xml") : load_scene(src);
    SceneData sd(*s);
    const mjModel* m = s->m;
    mjData* d = sd.d;
    const int nv = m->nv;
    for (int i = 0; i < nv; ++i) d->qvel[i] = 0.1 * std::sin(0.7 * i);
    for (int i = 0; i < m->nq; ++i) d->qpos[i] += 0.05 * std::cos(1.3 * i);
    mj_normalizeQuat(m, d->qpos);
    forward(*s, sd);  // qM, and MuJoCo's factor of it in qLD
    for (int i = 0; i < nv; ++i) simple_seen = simple_seen || m->dof_simplenum[i] > 0;

    std::vector<mjtNum> LD(m->nM), dinv(nv);
    factor_ldl(m, d, d->qM, LD.data(), dinv.data());
    EXPECT_LE(max_rel_diff(LD.data(), d->qLD, m->nM), 1e-13);
    EXPECT_LE(max_rel_diff(dinv.data(), d->qLDiagInv, nv), 1e-13);

    std::vector<mjtNum> y(nv), x(nv), x_mj(nv), Mx(nv);
    for (int i = 0; i < nv; ++i) y[i] = std::cos(2.1 * i + 0.3);
    solve_ldl(m, LD.data(), dinv.data(), x.data(), y.data());
    mj_solveM(m, d, x_mj.data(), y.data(), 1);
    EXPECT_LE(max_rel_diff(x.data(), x_mj.data(), nv), 1e-12);
    // and it solves M x = y (independently of MuJoCo's factor). The rods' M is ill-conditioned
    // (stiff axial and light bending coordinates), so the test is the normwise backward error
    // |M x - y| / (|M| |x|) (max norms) of a stable factorisation, not |M x - y| / |y|.
    mj_mulM(m, d, Mx.data(), x.data());
    std::vector<mjtNum> full(nv * nv);
    mj_fullM(m, full.data(), d->qM);
    double normM = 0.0, normx = 0.0, res = 0.0;
    for (int i = 0; i < nv; ++i) {
      double row = 0.0;
      for (int j = 0; j < nv; ++j) row += std::abs(full[i * nv + j]);
      normM = std::max(normM, row);
      normx = std::max(normx, std::abs(x[i]));
      res = std::max(res, std::abs(Mx[i] - y[i]));
    }
    EXPECT_LE(res / (normM * normx), 1e-14);
    // in place
    std::vector<mjtNum> z = y;
    solve_ldl(m, LD.data(), dinv.data(), z.data(), z.data());
    EXPECT_LE(max_rel_diff(z.data(), x.data(), nv), 1e-15);
  }
  EXPECT_TRUE(simple_seen) << "no scene exercises the simple-dof branch";
}

}  // namespace
