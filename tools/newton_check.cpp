// How well the simplified Newton matrix of the trapezoidal rule fits a run (README: `run`'s warning
// on split steps; docs/bench/repro/heavy_tip.xml). The model runs with `trapezoidal` at the given
// step; at each requested time the tool takes finite-difference Jacobians of the smooth forces
// (d->qfrc_smooth) in q and v and prints the spectral radius of A_N^-1 (A_true - A_N), with
//   A_N    = M + h^2/4 K                     (the matrix the corrections use: the rods' K),
//   A_true = M + h/2 (-dF/dv) + h^2/4 (-d(F - M(q) a)/dq),  a the acceleration at the state,
// and the parts from q and from v. Above 1 the simplified iteration cannot contract; its failures
// then split the steps (the "corr./step" marks of the stress tables). --no-mass-term leaves the
// change of M times a out of the q part.
//
// Usage: newton_check MODEL.xml [--timestep h] [--times t1,t2,...] [--key K] [--ctrl U]
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "../apps/cli.hpp"
#include "../apps/state_options.hpp"
#include "scene.hpp"

using namespace cosserat;
namespace cli = cosserat::cli;

namespace {

double spectral_radius(const Eigen::MatrixXd& A) {
  const Eigen::VectorXcd ev = A.eigenvalues();
  double r = 0.0;
  for (int i = 0; i < ev.size(); ++i) r = std::max(r, std::abs(ev(i)));
  return r;
}

int run(int argc, char** argv) {
  std::optional<double> timestep;
  std::string times = "0.5,1,1.5";
  cli::CommandLine cl{"newton_check",
                      "spectral radius of the trapezoidal rule's Newton matrix error along a run (tools/newton_check.cpp)",
                      {"MODEL.xml"},
                      {cli::optional_positive_option("--timestep", "h", "time step [s] (default: the model's)", timestep),
                       cli::text_option("--times", "T1,T2,...", "simulated times to check, increasing (default 0.5,1,1.5)",
                                        times)}};
  bool no_mass_term = false;
  cl.options.push_back(cli::flag_option(
      "--no-mass-term", "leave out the change of the mass matrix times the acceleration in the q part", no_mass_term));
  cli::StateOptions state;
  state.add_to(cl);
  cl.program.clear();
  const auto pos = cl.parse(argc - 1, argv + 1);
  if (!pos) return 0;
  std::vector<double> at;
  {
    std::istringstream in(times);
    for (std::string v; std::getline(in, v, ',');) at.push_back(cli::parse_number("--times", v));
    if (at.empty() || !std::is_sorted(at.begin(), at.end())) cli::fail("--times: give increasing times");
  }
  std::unique_ptr<mj::Scene> s;
  try {
    s = mj::load_scene(pos->front());
  } catch (const std::exception& e) {
    cli::fail(e.what());
  }
  if (timestep) s->m->opt.timestep = *timestep;
  const double h = s->m->opt.timestep;
  mj::SceneData sd(*s);
  mjData* d = sd.d;
  state.apply(*s, sd);
  const int nv = s->m->nv, nq = s->m->nq;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(nv, nv);
  for (const auto& rb : s->rods)
    K.block(rb.dof0, rb.dof0, rb.model.nv, rb.model.nv) = rb.model.K;
  std::printf("%s: trapezoidal, h = %g s, nv = %d\n", pos->front().c_str(), h, nv);
  std::printf("%8s %10s %12s %12s %12s %12s\n", "t [s]", "splits", "max |v|", "radius", "from q", "from v");
  for (double t : at) {
    while (d->time < t - 0.5 * h)
      if (mj::step(*s, sd, Integrator::Trapezoidal) != Status::Ok) cli::fail("diverged at t = " + std::to_string(d->time));
    const std::vector<double> q0(d->qpos, d->qpos + nq), v0(d->qvel, d->qvel + nv);
    // the acceleration a at this state: the residual's q-derivative is d(F - M(q) a)/dq, the
    // change of the mass matrix times a included (large where light parts carry heavy bodies)
    mj::forward(*s, sd, mj::Need::Acceleration);
    const std::vector<double> a(d->qacc, d->qacc + nv);
    std::vector<double> Ma(nv);
    // F, minus M(q) a with `mass` (M does not depend on v: the v part never takes it)
    auto forces = [&](Eigen::VectorXd& f, bool mass) {
      mj::forward(*s, sd, mj::Need::Forces);
      f = Eigen::Map<const Eigen::VectorXd>(d->qfrc_smooth, nv);
      if (mass) {
        mj_mulM(s->m, d, Ma.data(), a.data());
        f -= Eigen::Map<const Eigen::VectorXd>(Ma.data(), nv);
      }
    };
    Eigen::VectorXd fp, fm;
    forces(fp, false);  // (for M at the state)
    std::vector<double> Mfull(static_cast<size_t>(nv) * nv);
    mj_fullM(s->m, Mfull.data(), d->qM);
    const Eigen::MatrixXd M = Eigen::Map<Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(Mfull.data(), nv, nv);
    Eigen::MatrixXd Kq(nv, nv), Dv(nv, nv);
    const double e = 1e-7;
    std::vector<double> dq(nv);
    for (int j = 0; j < nv; ++j) {
      for (double sign : {1.0, -1.0}) {
        std::fill(dq.begin(), dq.end(), 0.0);
        dq[j] = sign * e;
        std::copy(q0.begin(), q0.end(), d->qpos);
        mj_integratePos(s->m, d->qpos, dq.data(), 1.0);
        forces(sign > 0 ? fp : fm, !no_mass_term);
      }
      Kq.col(j) = -(fp - fm) / (2 * e);
      std::copy(q0.begin(), q0.end(), d->qpos);
      for (double sign : {1.0, -1.0}) {
        std::copy(v0.begin(), v0.end(), d->qvel);
        d->qvel[j] += sign * e;
        forces(sign > 0 ? fp : fm, false);
      }
      Dv.col(j) = -(fp - fm) / (2 * e);
      std::copy(v0.begin(), v0.end(), d->qvel);
    }
    forward(*s, sd, mj::Need::Forces);  // back to the run's state
    const Eigen::MatrixXd AN = M + 0.25 * h * h * K;
    const Eigen::LDLT<Eigen::MatrixXd> f(AN);
    const Eigen::MatrixXd Eq = f.solve(0.25 * h * h * (Kq - K)), Ev = f.solve(0.5 * h * Dv);
    const double vmax = Eigen::Map<const Eigen::VectorXd>(v0.data(), nv).cwiseAbs().maxCoeff();
    std::printf("%8.3f %10ld %12.3g %12.3g %12.3g %12.3g\n", d->time, sd.newton_stats.splits, vmax,
                spectral_radius(Eq + Ev), spectral_radius(Eq), spectral_radius(Ev));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const cli::Failure& f) {
    return cli::report("newton_check", f);
  }
}
