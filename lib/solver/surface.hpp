#pragma once
// Surface helpers of the virtual mesh: the physical mesh's boundary and 1 -> 4 refinement.
#include <array>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// The boundary of a tet mesh: faces used by exactly one tet, oriented outwards (counter-clockwise
/// seen from outside), with vertices compacted in increasing physical-vertex order.
///   source_vertex (out, optional): #V_surface physical-vertex index of each surface vertex.
SurfaceMesh tet_boundary(const TetMesh& mesh, std::vector<int>* source_vertex = nullptr);

/// Splits each triangle into 4 at its edge midpoints. Old vertices keep their indices; new ones
/// follow in order of first appearance. parent (#V_out): {i, i} for an old vertex, {a, b} (a < b)
/// for the midpoint of edge a-b.
SurfaceMesh refine_surface(const SurfaceMesh& surface, std::vector<std::array<int, 2>>& parent);

}  // namespace ebh
