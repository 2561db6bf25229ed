#include "tube_mesh.hpp"

#include <GL/gl.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cosserat::render {

TubeMeshes::TubeMeshes(const mjrContext& con, int slices) : con_(con), slices_(std::max(slices, 8)) {
  for (int k = 0; k <= slices_; ++k) {
    cos_.push_back(std::cos(2 * M_PI * k / slices_));
    sin_.push_back(std::sin(2 * M_PI * k / slices_));
  }
}

TubeMeshes::~TubeMeshes() {
  for (unsigned l : lists_) glDeleteLists(l, 1);
}

unsigned TubeMeshes::list(size_t i) {
  while (lists_.size() <= i) {
    const GLuint l = glGenLists(1);
    if (l == 0 || static_cast<long>(l) < con_.baseMesh) throw std::runtime_error("OpenGL could not make a display list");
    lists_.push_back(l);
  }
  return lists_[i];
}

void TubeMeshes::add(const std::vector<Tube>& tubes, mjvScene* scn) {
  for (size_t i = 0; i < tubes.size() && scn->ngeom < scn->maxgeom; ++i) {
    const Tube& tube = tubes[i];
    if (tube.rings.size() < 2) continue;
    // vertices relative to the centre of the tube's bounding box, which is the geom's position
    Vec3 lo = tube.rings[0].centre, hi = lo;
    double rmax = 0;
    for (const TubeRing& ring : tube.rings) {
      lo = lo.cwiseMin(ring.centre), hi = hi.cwiseMax(ring.centre);
      rmax = std::max(rmax, ring.radius);
    }
    const Vec3 centre = 0.5 * (lo + hi);

    const unsigned l = list(i);
    glNewList(l, GL_COMPILE);
    for (size_t j = 0; j + 1 < tube.rings.size(); ++j) {
      glBegin(GL_TRIANGLE_STRIP);
      for (int k = 0; k <= slices_; ++k)
        for (const TubeRing* ring : {&tube.rings[j + 1], &tube.rings[j]}) {  // counter-clockwise seen from outside
          const Vec3 radial = cos_[k] * ring->u + sin_[k] * ring->v;
          const double c = std::sqrt(std::max(0.0, 1 - ring->tilt * ring->tilt));
          const Vec3 n = c * radial + ring->tilt * ring->t, p = ring->centre + ring->radius * radial - centre;
          if (tube.ring_colors) glColor4fv(ring->rgba);
          glNormal3d(n.x(), n.y(), n.z());
          glVertex3d(p.x(), p.y(), p.z());
        }
      glEnd();
    }
    glEndList();

    mjvGeom& g = scn->geoms[scn->ngeom];
    g = tube.look;
    g.type = mjGEOM_MESH;
    g.dataid = static_cast<int>(l) - con_.baseMesh;
    g.objtype = mjOBJ_UNKNOWN;
    g.objid = -1;
    g.texid = -1;  // tubes are not textured
    g.texcoord = 0;
    g.segid = scn->ngeom;
    g.label[0] = '\0';
    for (int k = 0; k < 3; ++k) g.pos[k] = static_cast<float>(centre[k]), g.size[k] = static_cast<float>(rmax);
    for (int k = 0; k < 9; ++k) g.mat[k] = k % 4 == 0 ? 1.0f : 0.0f;
    g.modelrbound = static_cast<float>(0.5 * (hi - lo).norm() + rmax);
    ++scn->ngeom;
  }
}

}  // namespace cosserat::render
