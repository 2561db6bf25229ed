// Rods drawn as smooth tubes around the solver's centreline, at any physics resolution: rings of
// the exact (tapered) radius at samples dense where the centreline bends, closed by round ends,
// coloured as the rod's capsules in the MJCF or by strain or stress. They replace the rod's
// collision capsules in the abstract scene (tube_mesh.hpp turns them into geoms).
#pragma once

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "scene.hpp"

namespace cosserat::render {

enum class RodColoring {
  Model,   // the rgba (and material, but for a texture: the tubes have no texture coordinates) of the rod's capsules
  Strain,  // surface strain magnitude (dimensionless), see rod_strain_magnitude
  Stress,  // surface stress magnitude [Pa], see rod_stress_magnitude
};
// "model", "strain", "stress"; throws std::invalid_argument otherwise.
RodColoring parse_rod_coloring(const std::string& name);

struct RodVisualOptions {
  int segments = 0;  // rings per rod, evenly spaced (plus one); 0: adaptive, see rod_samples
  RodColoring coloring = RodColoring::Model;
  double color_max = 0.0;  // value shown at the top of the colour map; 0: the largest in the picture
};

constexpr int kMaxRodSegments = 512;

// Abscissae X_0 = 0 < ... < X_n = L of rod r's rings in the current state. Evenly spaced when
// o.segments > 0; else adaptive, from the solver's strain: the centreline turns by at most
// 0.05 rad between rings, with 16 to kMaxRodSegments intervals.
std::vector<double> rod_samples(const mj::Scene& s, const mj::SceneData& sd, int r, const RodVisualOptions& o);

// Largest strain at the surface of rod r's cross-section at X, from the strain change
// dxi = xi(X) - xi*(X): sqrt(e^2 + g^2) with the axial strain e = |dp_x| + r |(dk_y, dk_z)| and
// the shear g = |(dp_y, dp_z)| + r |dk_x|.
double rod_strain_magnitude(const mj::Scene& s, const mj::SceneData& sd, int r, double X);
// The matching von Mises stress sqrt((E e)^2 + 3 (G g)^2) [Pa] of the section's material.
double rod_stress_magnitude(const mj::Scene& s, const mj::SceneData& sd, int r, double X);

// The colour map for RodColoring other than Model: t in [0, 1] to rgb (viridis).
void colormap(double t, float rgb[3]);

// A circle of the tube's surface: centre, unit tangent t and unit axes u, v spanning its plane.
// Its surface normals are cos(a) (cos q u + sin q v) + sin(a) t with sin(a) = tilt (a cone's
// slope, or a round end's latitude).
struct TubeRing {
  Vec3 centre, t, u, v;
  double radius = 0, tilt = 0;
  float rgba[4] = {1, 1, 1, 1};
};

// A run of tube along one rod, drawn with the look (colour, specular, shininess, emission) of a rod
// capsule; not its material's texture (Renderer warns).
struct Tube {
  int rod = -1;
  std::vector<TubeRing> rings;  // base to tip, round ends included
  mjvGeom look{};               // the capsule's abstract geom (from mjv_updateScene)
  bool ring_colors = false;     // rings carry their own colours (else the look's rgba)
};

// After mjv_updateScene: removes the rods' collision capsules (and their automatic base and tip
// sites) from `scn` and returns the tubes replacing them, one per run of capsules `scn` showed
// (capsules the options hide leave gaps).
std::vector<Tube> rod_tubes(const mj::Scene& s, const mj::SceneData& sd, const RodVisualOptions& o, mjvScene* scn);
// Largest number of tubes rod_tubes can return for the scene.
int max_rod_tubes(const mj::Scene& s);

}  // namespace cosserat::render
