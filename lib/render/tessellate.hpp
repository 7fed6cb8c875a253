#pragma once
// Triangle meshes for drawing: the tool's colliders (collider.hpp) tessellated at a pose, and
// smooth per-vertex normals of the virtual mesh.
#include <array>
#include <vector>

#include "math/vec.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

/// A triangle soup: vertex 3i, 3i+1, 3i+2 make triangle i, counter-clockwise seen from outside;
/// `normal` holds the outward unit normal at each vertex.
struct TriangleSoup {
  std::vector<Vec3f> position;
  std::vector<Vec3f> normal;
  std::size_t triangles() const { return position.size() / 3; }
};

/// Appends collider c, placed by `world` (collider frame -> world), to `out`. `segments` is the
/// number of facets around a round axis (hemispheres and spheres use segments/4 rings per
/// quarter turn).
void tessellate(const Collider<double>& c, const Rigid<double>& world, int segments, TriangleSoup& out);

/// Every collider of a posed tool.
TriangleSoup tessellate(const PosedTool& tool, int segments = 32);

/// Area-weighted per-vertex normals of a triangle mesh (#V unit vectors; a vertex of no
/// non-degenerate triangle gets +z).
void vertex_normals(const std::vector<Vec3f>& positions, const std::vector<std::array<int, 3>>& triangles,
                    std::vector<Vec3f>& normals);

}  // namespace ebh
