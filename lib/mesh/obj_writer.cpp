// Wavefront OBJ text of a triangle surface (mesh_io.hpp: obj_text).
#include <cstdio>
#include <string>

#include "mesh/mesh_io.hpp"

namespace ebh {

std::string obj_text(const SurfaceMesh& surface) {
  std::string out;
  char line[128];
  for (const Vec3d& p : surface.vertices) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x, p.y, p.z);
    out += line;
  }
  for (const Tri& t : surface.triangles) {
    std::snprintf(line, sizeof line, "f %d %d %d\n", t[0] + 1, t[1] + 1, t[2] + 1);
    out += line;
  }
  return out;
}

}  // namespace ebh
