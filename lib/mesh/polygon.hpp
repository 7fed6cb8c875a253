#pragma once
// Polygons of the surface readers (OBJ, PLY, VTK polydata): split into triangles around their first
// corner, which is right for convex polygons only, so a concave one is found and refused; and VTK's
// triangle strips.
// Internal to lib/mesh (the readers).
#include <cstddef>
#include <string>
#include <vector>

#include "math/vec.hpp"
#include "mesh/tet_mesh.hpp"

namespace ebh::detail {

/// The first corner (an index into `corners`) where a polygon turns against the others, seen
/// along its Newell normal; -1 for a convex one (or one with no area, whose fan is as flat).
inline int concave_corner(const std::vector<long long>& corners, const std::vector<Vec3d>& v) {
  const std::size_t n = corners.size();
  auto at = [&](std::size_t k) { return v[static_cast<std::size_t>(corners[k % n])]; };
  Vec3d normal{};
  for (std::size_t k = 0; k < n; ++k) normal += cross(at(k), at(k + 1));
  const double length = norm(normal);
  if (!(length > 0)) return -1;
  normal = normal / length;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3d a = at(k) - at(k + n - 1), b = at(k + 1) - at(k);
    // a relative tolerance: a straight corner's round-off may turn either way
    if (dot(cross(a, b), normal) < -1e-9 * norm(a) * norm(b)) return static_cast<int>(k);
  }
  return -1;
}

/// A polygon's triangles around its first corner (a b c d -> a b c, a c d), appended to `out`.
inline void append_fan(const std::vector<long long>& corners, std::vector<Tri>& out) {
  for (std::size_t k = 1; k + 1 < corners.size(); ++k)
    out.push_back({static_cast<int>(corners[0]), static_cast<int>(corners[k]), static_cast<int>(corners[k + 1])});
}

/// A triangle strip's triangles as VTK orders them (every second one turned: a b c d -> a b c,
/// c b d), appended to `out`.
inline void append_strip(const std::vector<long long>& corners, std::vector<Tri>& out) {
  for (std::size_t k = 0; k + 2 < corners.size(); ++k) {
    const int a = static_cast<int>(corners[k]), b = static_cast<int>(corners[k + 1]), d = static_cast<int>(corners[k + 2]);
    out.push_back(k % 2 == 0 ? Tri{a, b, d} : Tri{b, a, d});
  }
}

/// The message for a concave polygon of `n` corners turning back at vertex `vertex` (as the file
/// numbers it).
inline std::string concave_message(std::size_t n, long long vertex) {
  return "a concave face of " + std::to_string(n) + " vertices (it turns back at vertex " + std::to_string(vertex) +
         "): ebh splits a face into triangles around its first vertex, right for convex faces only; triangulate the "
         "mesh before exporting it";
}

}  // namespace ebh::detail
