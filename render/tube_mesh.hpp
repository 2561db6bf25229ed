// Rod tubes as geoms of MuJoCo's renderer: each tube is compiled into an OpenGL display list of
// smooth triangle strips (per-vertex normals, exact taper), and drawn through an mjvGeom of type
// mesh whose dataid points at that list. MuJoCo's renderer draws a mesh geom by calling the list
// con->baseMesh + dataid after applying its pose and material, so tubes get MuJoCo's lighting,
// shadows, reflections and transparency like any geom. Needs the GL context current.
#pragma once

#include <vector>

#include <mujoco/mujoco.h>

#include "rod_visual.hpp"

namespace cosserat::render {

class TubeMeshes {
 public:
  // `slices`: vertices around each ring.
  TubeMeshes(const mjrContext& con, int slices);
  ~TubeMeshes();
  TubeMeshes(const TubeMeshes&) = delete;
  TubeMeshes& operator=(const TubeMeshes&) = delete;

  // Compiles the tubes and appends one geom per tube to scn (as long as it has room).
  void add(const std::vector<Tube>& tubes, mjvScene* scn);

 private:
  unsigned list(size_t i);  // display list i, made on first use

  const mjrContext& con_;
  int slices_;
  std::vector<unsigned> lists_;
  std::vector<double> cos_, sin_;
};

}  // namespace cosserat::render
