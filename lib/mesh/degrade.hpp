#pragma once
// Bad tets on purpose: the stability stress cases (`ebh validate stability`) take a committed
// scene's mesh and move some of its interior vertices until the worst tet has a chosen mean-ratio
// quality, as a segmentation pipeline's mesh would have. The boundary (and so the virtual mesh
// and the pinned regions' surface) does not move, and no tet inverts.
//
// Each chosen tet gets one of three shapes by moving one of its interior corners v:
//   cap     v towards the foot of its perpendicular on the opposite face (inside the triangle)
//   sliver  v towards the opposite face's plane where the foot falls outside the triangle
//   needle  v towards the nearest other corner (a short edge; its tets become needles and wedges)
// The move is the largest along that line for which every tet around v keeps a mean ratio of at
// least the target (bisection), so the mesh's worst quality reaches the target and goes no lower.
#include <cstdint>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

struct DegradeOptions {
  double target_quality = 0.05;  ///< mean ratio the degraded tets reach (0 < target < 1)
  int tets = 24;                 ///< how many tets to degrade, spread over the mesh
  std::uint64_t seed = 1;        ///< which tets (the same seed gives the same mesh on any machine)
};

struct DegradeReport {
  int caps = 0, slivers = 0, needles = 0;  ///< degraded tets by shape
  double worst_quality = 1;                ///< the mesh's worst mean ratio afterwards
  int worst_tet = -1;
  std::vector<int> moved_vertices;         ///< in the order they moved
};

/// Moves interior vertices of `mesh` (not on its boundary, not flagged in `fixed`: #V or empty)
/// as described above. Deterministic in (mesh, options).
DegradeReport degrade_mesh_quality(TetMesh& mesh, const std::vector<std::uint8_t>& fixed,
                                   const DegradeOptions& options);

}  // namespace ebh
