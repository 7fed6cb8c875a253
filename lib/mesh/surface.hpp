#pragma once
// Surface helpers of the virtual mesh: 1 -> 4 refinement (the boundary comes from
// mesh/boundary.hpp's extract_boundary).
#include <array>
#include <span>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// Splits each triangle into 4 at its edge midpoints. Old vertices keep their indices; new ones
/// follow in order of first appearance. parent (#V_out): {i, i} for an old vertex, {a, b} (a < b)
/// for the midpoint of edge a-b.
SurfaceMesh refine_surface(const SurfaceMesh& surface, std::vector<std::array<int, 2>>& parent);

/// The median of the triangles' circumradii (0 for none; a degenerate triangle's is infinite): a
/// ball narrower than a triangle's circumradius fits between its corners.
double median_circumradius(std::span<const Vec3d> positions, std::span<const Tri> triangles);

}  // namespace ebh
