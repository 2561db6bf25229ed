// Small models shared by the core tests.
#pragma once

#include <cmath>

#include "model.hpp"

namespace cosserat::testing {

// A silicone-like rod of length L and radius r, clamped at the base along the world x axis.
inline RodSpec rod_spec(const char* basis_name, int sections, int order, double L = 0.5, double r = 0.01) {
  RodSpec s;
  s.name = "rod";
  s.length = L;
  s.radius_base = r;
  s.sections = sections;
  s.section.dofs = *strain_mask_from_name(basis_name);
  s.section.order = order;
  s.section.material.density = 1100.0;
  s.section.material.young = 1e6;
  s.section.material.poisson = 0.45;
  return s;
}

// The same rod clamped at `place` in the world (first) and hanging there from a free joint, a
// floating base (second): the base-coupling tests compare the two.
struct FixedAndFloating {
  Model fixed, floating;
};
inline FixedAndFloating fixed_and_floating(const RodSpec& spec, const SE3& place) {
  FixedAndFloating out;
  out.fixed.add_rod(-1, place, spec);
  out.fixed.finalize();
  const int fj = out.floating.add_joint(-1, SE3::Identity(), JointType::Free);
  out.floating.add_rod(fj, place, spec);
  out.floating.finalize();
  return out;
}

// A soft-rigid tree: revolute joint -> rigid link -> rod (GVS order 1, 2 sections) -> rigid tip
// body -> helical-rest rod (PCS) on a spherical joint, plus a second branch rod at the base.
inline Model hybrid_tree(bool with_cable = true) {
  Model m;
  const int j0 = m.add_joint(-1, SE3::Identity(), JointType::Revolute, Vec3(0, 1, 0.3));
  m.add_body(j0, 0.2, Vec3(0.05, 0.01, 0), Vec3(1e-4, 2e-4, 3e-4).asDiagonal());
  SE3 p;
  p.u = Vec3(0.1, 0, 0);
  RodSpec a = rod_spec("sr", 2, 1, 0.3, 0.01);
  a.name = "a";
  a.radius_tip = 0.006;
  a.section.rest_strain << 0.1, -0.3, 0.5, 1.0, 0.02, 0.0;
  a.section.material.viscosity = 0.1;
  const int ra = m.add_rod(j0, p, a);
  const int tip = m.rods[ra].tip_node;
  m.add_body(tip, 0.05, Vec3(0.01, 0, 0.005), Vec3(2e-5, 1e-5, 1e-5).asDiagonal());
  const int j1 = m.add_joint(tip, SE3::Identity(), JointType::Spherical);
  RodSpec b = rod_spec("kl", 3, 0, 0.2, 0.004);
  b.name = "b";
  b.section.rest_strain << 5.0, 0.0, 10.0, 1.0, 0.0, 0.0;  // helical
  m.add_rod(j1, SE3::Identity(), b);
  RodSpec c = rod_spec("icc", 2, 2, 0.15, 0.005);
  c.name = "c";
  SE3 pc;
  pc.R = exp_so3(Vec3(0, 0, 1.0));
  m.add_rod(-1, pc, c);
  if (with_cable) {
    Cable cab;
    cab.rod = ra;
    cab.d_begin = Vec3(0, 0.006, 0.002);
    cab.d_end = Vec3(0, 0.004, 0.0);
    m.add_cable(cab, "cable");
  }
  m.add_dof_actuator(0, "motor");
  m.finalize();
  return m;
}

}  // namespace cosserat::testing
