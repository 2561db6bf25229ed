// The inverse weights (body_invweight0) of a rod's sections or a chain's links, recomputed from
// J M^-1 J' at each body's centre of mass (Axx along the rod, Ayy, Azz; their mean is MuJoCo's
// translational weight), with the linear-strain or slide dofs locked too, then the contact rows at
// the equilibrium and the depth (forty-fourth session: why a kl rod sinks deeper than an ikl one,
// as deep as its native chain with slides; the figures are in the README's "Known limitations").
// Build against a build directory B of this repository (S: the source tree):
//   g++ -O2 -march=x86-64-v3 -std=c++17 -I S/plugin/mujoco -I S/plugin/core -I/usr/include/eigen3 \
//       probe.cpp B/plugin/mujoco/libcosserat_mujoco.a B/plugin/core/libcosserat_core.a -lmujoco -ltinyxml2 -o probe
// usage: probe rod_kl.xml   (or rod_ikl.xml, or a plain MuJoCo chain such as the one
//        tests/mujoco/contact_test.cpp builds in ARodOnTwoSupportsSinksAsDeepAsItsNativeChain)
//        probe MODEL override=FILE   (FILE: lines "body tran rot", weights put in before the equilibrium)
// It writes rule_invweight.txt in the working directory: the weights of the locked-strain rule, in
// override's format.
#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "scene.hpp"
#include "scene_statics.hpp"

using namespace cosserat;
using namespace cosserat::mj;
using Eigen::MatrixXd;
using Eigen::VectorXd;

static MatrixXd const_mass(Scene& s, SceneData& sd) {
  mjModel* m = s.m;
  const int nv = m->nv;
  mju_copy(sd.d->qpos, m->qpos0, m->nq);
  fwd_position(s, sd);
  MatrixXd M(nv, nv);
  std::vector<mjtNum> full(nv * nv);
  mj_fullM(m, full.data(), sd.d->qM);
  for (int i = 0; i < nv; ++i)
    for (int j = 0; j < nv; ++j) M(i, j) = full[i * nv + j];
  for (size_t r = 0; r < s.rods.size(); ++r) {
    int points = kConstantsQuadrature;
    for (const Section& sec : s.rods[r].model.sections) points = std::max(points, sec.order + 6);
    M += rod_inertia(s, sd, (int)r, points) - rod_inertia(s, sd, (int)r, 0);
  }
  return M;
}

struct Pose {
  Vec3 c;
  Mat3 R[64];
  double w[64];
  int n = 0;
};

// section si of rod r: mass-weighted com (world) and per-point world rotations
static void section_points(Scene& s, SceneData& sd, int r, int si, Vec3& com, std::vector<std::pair<double, SE3>>& pts) {
  const cosserat::Model& rm = s.rods[r].model;
  const cosserat::Data& rd = sd.rod[r];
  const Section& sec = rm.sections[si];
  const cosserat::Rod& rod = rm.rods[sec.rod];
  const int bb = s.rods[r].base_body;
  SE3 base;
  for (int a = 0; a < 3; ++a) {
    base.u(a) = sd.d->xpos[3 * bb + a];
    for (int b = 0; b < 3; ++b) base.R(a, b) = sd.d->xmat[9 * bb + 3 * a + b];
  }
  pts.clear();
  auto point_mass = [&](double w, double X) { return w * sec.length * section_inertia_density(sec.material, rod.radius(X))(3); };
  for (int i = sec.first_node; i <= sec.end_node; ++i) {
    const double mi = i == sec.end_node && sec.end_weight > 0 ? point_mass(sec.end_weight, rm.nodes[i].X) : rm.nodes[i].inertia(3, 3);
    if (mi > 0) pts.push_back({mi, rd.g[i]});
  }
  if (sec.end_weight > 0) pts.push_back({point_mass(sec.end_weight, sec.X0), rd.g[sec.start_node]});
  double mass = 0;
  com.setZero();
  for (auto& p : pts) mass += p.first, com += p.first * p.second.u;
  com /= mass;
}

// FD Jacobian (translation of com, mass-weighted angular velocity) of rod section at qpos0
static void section_jac(Scene& s, SceneData& sd, int r, int si, MatrixXd& Jp, MatrixXd& Jr) {
  mjModel* m = s.m;
  const int nv = m->nv;
  Jp = MatrixXd::Zero(3, nv);
  Jr = MatrixXd::Zero(3, nv);
  std::vector<mjtNum> q0(m->qpos0, m->qpos0 + m->nq), v(nv, 0.0);
  const double h = 1e-6;
  for (int i = 0; i < nv; ++i) {
    Vec3 c[2];
    std::vector<std::pair<double, SE3>> P[2];
    for (int sgn = 0; sgn < 2; ++sgn) {
      mju_copy(sd.d->qpos, q0.data(), m->nq);
      std::fill(v.begin(), v.end(), 0.0);
      v[i] = sgn ? h : -h;
      mj_integratePos(m, sd.d->qpos, v.data(), 1.0);
      fwd_position(s, sd);
      section_points(s, sd, r, si, c[sgn], P[sgn]);
    }
    Jp.col(i) = (c[1] - c[0]) / (2 * h);
    double mass = 0;
    Vec3 w = Vec3::Zero();
    for (size_t k = 0; k < P[0].size(); ++k) {
      Mat3 dR = P[1][k].second.R * P[0][k].second.R.transpose();
      Vec3 om(dR(2, 1) - dR(1, 2), dR(0, 2) - dR(2, 0), dR(1, 0) - dR(0, 1));
      om /= 2 * (2 * h);
      w += P[0][k].first * om;
      mass += P[0][k].first;
    }
    Jr.col(i) = w / mass;
  }
  mju_copy(sd.d->qpos, q0.data(), m->nq);
  fwd_position(s, sd);
}

static void print_invweights(Scene& s, SceneData& sd) {
  mjModel* m = s.m;
  const int nv = m->nv;
  MatrixXd M = const_mass(s, sd);
  MatrixXd Minv = M.inverse();
  // stretch dofs of the rods, and slide dofs of the model
  std::vector<int> lin;
  for (size_t r = 0; r < s.rods.size(); ++r)
    for (const Section& sec : s.rods[r].model.sections)
      for (int c = 0; c < 6; ++c)
        if (sec.B_row[c] >= 3)
          for (int k = 0; k <= sec.order; ++k) lin.push_back(s.rods[r].dof0 + sec.dof0 + c * (sec.order + 1) + k);
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_type[j] == mjJNT_SLIDE && !s.dof_strain[m->jnt_dofadr[j]]) lin.push_back(m->jnt_dofadr[j]);
  std::vector<int> keep;
  for (int i = 0; i < nv; ++i)
    if (std::find(lin.begin(), lin.end(), i) == lin.end()) keep.push_back(i);
  MatrixXd Mk(keep.size(), keep.size());
  for (size_t a = 0; a < keep.size(); ++a)
    for (size_t b = 0; b < keep.size(); ++b) Mk(a, b) = M(keep[a], keep[b]);
  MatrixXd Mkinv = Mk.inverse();
  std::printf("nv %d, linear-strain/slide dofs %zu\n", nv, lin.size());
  std::printf("%-12s %11s %11s | %11s %11s %11s %11s | %11s %11s | %11s %11s\n", "body", "model_tran", "model_rot", "Axx", "Ayy",
              "Azz", "tr/3", "rot tr/3", "lock tr/3", "lock Azz", "lock rot");
  std::FILE* rule = std::fopen("rule_invweight.txt", "w");
  std::map<int, std::pair<int, int>> proxy;
  (void)0;
  for (size_t r = 0; r < s.rods.size(); ++r)
    for (size_t i = 0; i < s.rods[r].proxy_body.size(); ++i) proxy[s.rods[r].proxy_body[i]] = {(int)r, (int)i};
  for (int b = 1; b < m->nbody; ++b) {
    MatrixXd Jp, Jr;
    if (proxy.count(b)) {
      section_jac(s, sd, proxy[b].first, proxy[b].second, Jp, Jr);
    } else {
      std::vector<mjtNum> jp(3 * nv), jr(3 * nv);
      mj_jacBodyCom(m, sd.d, jp.data(), jr.data(), b);
      Jp = Eigen::Map<Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(jp.data(), 3, nv);
      Jr = Eigen::Map<Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(jr.data(), 3, nv);
    }
    if (m->body_mass[b] == 0 && !proxy.count(b) && Jp.norm() == 0) continue;
    MatrixXd A = Jp * Minv * Jp.transpose(), B = Jr * Minv * Jr.transpose();
    MatrixXd Jpk(3, keep.size()), Jrk(3, keep.size());
    for (size_t a = 0; a < keep.size(); ++a) Jpk.col(a) = Jp.col(keep[a]), Jrk.col(a) = Jr.col(keep[a]);
    MatrixXd Ak = keep.empty() ? MatrixXd::Zero(3, 3) : MatrixXd(Jpk * Mkinv * Jpk.transpose()), Bk = Jrk * Mkinv * Jrk.transpose();
    const char* nm = mj_id2name(m, mjOBJ_BODY, b);
    if (false) {}
    std::printf("%-12s %11.5g %11.5g | %11.5g %11.5g %11.5g %11.5g | %11.5g %11.5g | %11.5g %11.5g\n", nm ? nm : "?",
                m->body_invweight0[2 * b], m->body_invweight0[2 * b + 1], A(0, 0), A(1, 1), A(2, 2), A.trace() / 3,
                B.trace() / 3, Ak.trace() / 3, Ak(2, 2), Bk.trace() / 3);
    double t = 0;  // proposed rule: per direction, locked unless locking leaves it immobile
    for (int k = 0; k < 3; ++k) t += (Ak(k, k) > 1e-6 * A(k, k) ? Ak(k, k) : A(k, k)) / 3;
    std::printf("    rule tran %.5g (Axx lock %.5g)\n", t, Ak(0, 0));
    std::fprintf(rule, "%d %.10g %.10g\n", b, t, m->body_invweight0[2 * b + 1]);
    std::fflush(rule);
  }
}

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  auto sp = load_scene(argv[1]);
  Scene& s = *sp;
  mjModel* m = s.m;
  std::string mode = argc > 2 ? argv[2] : "none";
  {
    SceneData sd(s);
    print_invweights(s, sd);
    std::fflush(nullptr);
  }
  if (mode.rfind("set=", 0) == 0) {  // set=tran,rot for all bodies with mass/proxy except the hub
    double t, r;
    std::sscanf(mode.c_str() + 4, "%lf,%lf", &t, &r);
    for (int b = 2; b < m->nbody; ++b)
      if (m->body_invweight0[2 * b] > 0) m->body_invweight0[2 * b] = t, m->body_invweight0[2 * b + 1] = r;
  }
  if (mode.rfind("scale=", 0) == 0) {
    double f = std::atof(mode.c_str() + 6);
    for (int b = 2; b < m->nbody; ++b) m->body_invweight0[2 * b] *= f;
  }
  if (mode.rfind("file=", 0) == 0) {  // lines: body tran rot
    std::ifstream in(mode.substr(5));
    int b;
    double t, r;
    while (in >> b >> t >> r) m->body_invweight0[2 * b] = t, m->body_invweight0[2 * b + 1] = r;
  }
  SceneData sd(s);
  const SceneStaticsResult res = equilibrium(s, sd);
  std::printf("equilibrium: %s residual %g iters %d\n", res.message.c_str(), res.residual, res.iterations);
  forward(s, sd);
  const int a = mj_name2id(m, mjOBJ_SITE, "A"), b = mj_name2id(m, mjOBJ_SITE, "B");
  const double depth = -0.5 * (sd.d->site_xpos[3 * a + 2] + sd.d->site_xpos[3 * b + 2]);
  std::printf("equilibrium %s (%s), depth A %.4f mm B %.4f mm mean %.4f mm\n", res.converged ? "ok" : "FAILED", res.method.c_str(),
              -1e3 * sd.d->site_xpos[3 * a + 2], -1e3 * sd.d->site_xpos[3 * b + 2], 1e3 * depth);
  std::printf("cone %d impratio %g\n", m->opt.cone, m->opt.impratio);
  mjData* d = sd.d;
  double total = 0;
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    if (con.efc_address < 0) continue;
    const int b1 = m->geom_bodyid[con.geom1], b2 = m->geom_bodyid[con.geom2];
    mjtNum f[6];
    mj_contactForce(m, d, c, f);
    total += f[0];
    const int i = con.efc_address;
    std::printf("con %d bodies %s/%s dist %.4f mm pos x %.4f dim %d solref %g %g solimp %g %g %g %g %g mu %g  fn %.4f N\n", c,
                mj_id2name(m, mjOBJ_BODY, b1) ? mj_id2name(m, mjOBJ_BODY, b1) : "world",
                mj_id2name(m, mjOBJ_BODY, b2) ? mj_id2name(m, mjOBJ_BODY, b2) : "world", 1e3 * con.dist, con.pos[0], con.dim,
                con.solref[0], con.solref[1], con.solimp[0], con.solimp[1], con.solimp[2], con.solimp[3], con.solimp[4], con.mu, f[0]);
    std::printf("    invw0 b1 %.5g/%.5g b2 %.5g/%.5g | row0 diagApprox %.5g R %.5g D %.5g K %.5g B %.5g I %.5g efc_pos %.4g mm\n",
                m->body_invweight0[2 * b1], m->body_invweight0[2 * b1 + 1], m->body_invweight0[2 * b2], m->body_invweight0[2 * b2 + 1],
                d->efc_diagApprox[i], d->efc_R[i], d->efc_D[i], d->efc_KBIP[4 * i], d->efc_KBIP[4 * i + 1], d->efc_KBIP[4 * i + 2],
                1e3 * d->efc_pos[i]);
  }
  double mass = 0;
  for (int bb = 0; bb < m->nbody; ++bb) mass += m->body_mass[bb];
  std::printf("total normal force %.5f N (ncon %d)\n", total, d->ncon);
  return 0;
}
