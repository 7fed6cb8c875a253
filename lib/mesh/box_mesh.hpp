#pragma once
// A structured box of tets, for validations, tests and benchmarks that need a mesh without files.
#include "mesh/tet_mesh.hpp"

namespace ebh {

/// The box [lo, hi] split into nx * ny * nz cells of 6 tets each (Kuhn subdivision along each
/// cell's lo-hi diagonal, conforming across cells), positively oriented. Vertex (i, j, k), with
/// 0 <= i <= nx etc., has index i + (nx + 1) (j + (ny + 1) k).
TetMesh make_box_tets(Vec3d lo, Vec3d hi, int nx, int ny, int nz);

}  // namespace ebh
