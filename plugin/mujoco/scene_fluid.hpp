// Low-Reynolds fluid forces in a MuJoCo scene with Cosserat rods (the MuJoCo side of
// plugin/core/fluid.hpp).
//
// Who owns the fluid. MuJoCo 2.2's own fluid model (inertia box or ellipsoid, mj_passive, from
// <option density viscosity>) is built for moderate Reynolds numbers and skips the massless rod
// proxies. This plugin OWNS the fluid forces of a scene when <option viscosity> > 0 and the scene
// has a rod, or marks geoms with a "cosserat:drag:NAME" numeric, or has a "cosserat:fluid" text.
// Then MuJoCo's own fluid is switched off (m->opt.viscosity and m->opt.density are zeroed after
// being read into SceneFluid), so no geom feels both models. A scene without viscosity has no
// fluid at all; a rod-free scene without those markers keeps MuJoCo's own model untouched.
//
// What the fluid does (fluid at rest, Stokes regime: forces linear in the velocities):
//  - rods: resistive force theory per quadrature node (core fluid.hpp), coefficients from the
//    rod's radius and helix pitch (Gray & Hancock, or Lighthill with the text below), or the
//    <cosserat drag="c_t c_n [c_rot]"> / wavelength="lambda" overrides; drag="0": none;
//  - spheres: Stokes, 6 pi mu a U and 8 pi mu a^3 Omega; ellipsoids: exact Stokes resistance
//    (Oberbeck / Jeffery); boxes: the ellipsoid with the same semi-axes (a rough stand-in);
//  - capsules and cylinders: RFT along their axis over their full length L (capsules: cylinder
//    plus caps), coefficients of a straight filament (Gray & Hancock with lambda = L/2, i.e.
//    ln(L/a)); stubby ones (L < 10 a) are taken as the spheroid of semi-axes
//    (a, a, L/2). A capsule or cylinder with explicit coefficients is a piece of a longer filament
//    (e.g. a native capsule chain): RFT over its segment 2 * halfheight only, since chained
//    capsules overlap their neighbours' caps;
//  - meshes, planes, height fields: no fluid force (SceneFluid::warnings).
// MJCF (MuJoCo's own <custom> elements, so the file still loads in plain MuJoCo):
//   <custom>
//     <text name="cosserat:fluid" data="gray-hancock"/>      (or "lighthill", or "mujoco": leave
//                                                             the fluid to MuJoCo, rods feel none)
//     <numeric name="cosserat:drag:NAME" data="c_t c_n [c_rot]"/>   NAME a geom, or a body (all
//                                                             its capsules and cylinders); "0":
//                                                             no fluid force on that geom/body
//   </custom>
// Drag is assembled as a damping matrix D in MuJoCo's sparse qM layout: the force -D qvel goes to
// qfrc_passive, and the integrators treat D implicitly (M + h D ...), as MuJoCo's Euler does with
// joint damping: light flagella in a viscous fluid are far too stiff for explicit drag.
#pragma once

#include <string>
#include <vector>

#include "fluid.hpp"
#include "lie.hpp"

namespace cosserat::mj {

struct Scene;
struct SceneData;

// A rigid MuJoCo body in the fluid: its geoms' resistances summed in its frame.
struct FluidBody {
  int body = -1;
  Mat6 C = Mat6::Zero();     // body frame (origin and axes of xpos/xmat), angular first
  std::vector<int> chain;    // its dofs, nearest first (MuJoCo's dof_parentid chain)
};

struct SceneFluid {
  bool active = false;                 // this plugin owns the scene's fluid forces
  double viscosity = 0.0, density = 0.0;  // <option> values as loaded (zeroed in mjModel if active)
  RftModel model = RftModel::GrayHancock;
  std::vector<FluidBody> bodies;
  std::vector<RodFluidInfo> rods;      // per Scene::rods (when active)
  std::vector<bool> rod_enabled;       // per Scene::rods
  int max_chain = 0;
  std::vector<std::string> notes;      // decisions worth reporting (fallback shapes)
  std::vector<std::string> warnings;   // what the scene asks for and does not get (ignored options and
                                       // coefficients, geoms without fluid force)
};

// At load, after the rods are bound: decides who owns the fluid, sets the rods' node drag and the
// bodies' resistances, and switches MuJoCo's own fluid off when this plugin owns it. Throws
// LoadError on bad input.
void setup_fluid(Scene& s);
// The fluid damping D in MuJoCo's sparse qM layout (sd.fluid_qD). In fwd_position, after the
// rods' qM patches (uses their ancestor columns) and with the patched cdof.
void fluid_damping(const Scene& s, SceneData& sd);
// qfrc_passive -= D qvel. In fwd_velocity, after mj_passive.
void fluid_forces(const Scene& s, SceneData& sd);
// A += h D, A a matrix in qM's sparse layout (the implicit solves' matrix).
void add_fluid_damping(const Scene& s, const SceneData& sd, double h, double* A);

}  // namespace cosserat::mj
