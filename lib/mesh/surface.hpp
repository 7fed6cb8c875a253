#pragma once
// Surface helpers of the virtual mesh: 1 -> 4 refinement (the boundary comes from
// mesh/boundary.hpp's extract_boundary).
#include <array>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// Splits each triangle into 4 at its edge midpoints. Old vertices keep their indices; new ones
/// follow in order of first appearance. parent (#V_out): {i, i} for an old vertex, {a, b} (a < b)
/// for the midpoint of edge a-b.
SurfaceMesh refine_surface(const SurfaceMesh& surface, std::vector<std::array<int, 2>>& parent);

}  // namespace ebh
