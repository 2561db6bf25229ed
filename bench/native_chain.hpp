// The MuJoCo-native equivalent of a scene with <cosserat> rods: what a MuJoCo user would build
// without us. Every <cosserat> becomes a chain of N capsule bodies of length ds = L/N, each with the
// mass and rotational inertia of its stretch of rod (explicit <inertial>, taper radius at the
// segment's middle), joined by joints at the body origins (the first one at the rod's base):
//   hinge mode: one hinge per free curvature component (x: torsion GJ/ds, y and z: bending EI/ds)
//               and one slide per free stretch/shear component (x: EA/ds, y and z: GA/ds);
//   ball mode:  one ball joint with the isotropic stiffness EI/ds (MuJoCo's ball joints take a
//               single stiffness: torsion is then (1 + nu) too stiff) plus the slides.
// Damping matches the rod's Kelvin-Voigt law (DESIGN.md section 3): mu J/ds (torsion), 3 mu I/ds
// (bending), 3 mu A/ds (stretch), mu A/ds (shear). The rest strains place body i+1 in body i at
// the rest pose of X_{i+1} in X_i's frame, composed across section boundaries (so the chain starts
// in the rod's rest shape, springs at rest).
//
// Names: the fixed "<rod>/base" body (pos/orientation of the <cosserat>), bodies "<rod>/b<i>",
// joints "<rod>/b<i>/<kx|ky|kz|px|py|pz|ball>", capsules "<rod>/b<i>/g", sites "<rod>/base",
// "<rod>/tip" and every user <site> (on the body holding its abscissa), the rod's <body> children
// under a fixed "<rod>/tipframe" body at X = L. Named sites and bodies are thus shared with the
// rod scene (the comparison of positions is by name).
//
// Collisions: the capsules take the rod's collision attributes; unless selfcollide="true", the
// chain's bodies are excluded pairwise (neighbours are MuJoCo's parent-filtered), as the rod's
// sections are, and against the rod's parent body and tip bodies like the rod's proxies.
// Fluid: when the project's plugin owns the rod scene's fluid (plugin/mujoco/scene_fluid.hpp), every
// chain body gets a <numeric name="cosserat:drag:<rod>/b<i>"> with the rod's resistive-force
// coefficients at its radius, so that the chain, loaded through the plugin (mj::load_scene), feels
// the same fluid on its capsules' segments; plain MuJoCo ignores these numerics.
// Keyframes lose qpos/qvel (their size changes); anything naming rod proxies or strain joints
// ("<rod>/s<i>...") is an error.
#pragma once

#include <stdexcept>
#include <string>

namespace cosserat::bench {

struct NativeChainOptions {
  int segments = 8;            // bodies per rod (N)
  bool ball = false;           // ball joints instead of hinges
  // Spring of the first joint (at the clamp) as a multiple of EI/ds. 1 is the textbook chain of
  // the issue (stiffness EI/ds everywhere); 2 lumps only the half segment next to the clamp.
  double base_spring_factor = 1.0;
  // Armature of every hinge (and ball joint) as a multiple of its segment's rotational inertia
  // about its centre, rho A ds^3 / 12: MuJoCo's way to a larger stable step (it adds inertia of
  // the order of the chain's own discretisation error, second order in ds); 0: none.
  double armature_factor = 0.0;
};

// MJCF text of the native equivalent of `xml` (a scene with <cosserat> elements; `path` names it
// in messages and anchors relative paths). Throws std::runtime_error on what it cannot convert.
std::string native_chain_xml(const std::string& xml, const std::string& path, const NativeChainOptions& opt);

}  // namespace cosserat::bench
