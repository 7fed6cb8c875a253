#pragma once
// Uniform refinement of a tet mesh (`ebh scene refine`, `ebh bench sizes`): every tet is split
// into 8 at its edge midpoints (Bey 1995, "Tetrahedral grid refinement"; the "red" refinement).
//
//   corners   (v0, m01, m02, m03), (m01, v1, m12, m13), (m02, m12, v2, m23), (m03, m13, m23, v3):
//             each the parent scaled by 1/2 about one of its vertices, so similar to it.
//   octahedron  the inner 6 midpoints, cut into 4 tets around one of its three diagonals
//             (m01-m23, m02-m13, m03-m12): the shortest one, ties broken by the smaller vertex
//             indices. The corners are similar to the parent; the inner four are not, and the
//             shortest diagonal is the choice that keeps them closest to it (the longest one can
//             make them needles). On the four committed meshes, two levels deep, every inner child's
//             mean ratio is at least 0.76 of its parent's (tests/mesh/test_refine.cpp holds 0.7).
// A child of a positively oriented tet is positively oriented (the corner order above and the
// diagonals' cycles are chosen for it).
//
// Listed triangles (tagged boundary or interface triangles) are split into 4 with the same
// midpoints; one whose edges are not all edges of the tets (a file may list a face with the other
// diagonal) is kept as it is, so its group keeps the same vertices. Groups: each child takes its parent's physical group tag, so a group's vertex set
// after refinement is the old set plus the midpoints of the edges of its elements: the midpoint of
// an edge of a group's triangle or tet belongs to the group; one of an edge that merely joins two
// of its vertices (an edge through the body between two boundary vertices) does not. A group's
// surface therefore stays the same surface, refined.
#include <cstdint>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// One level of refinement (see above).
///
/// Inputs:
///   mesh  #V vertices, #T tets (indices in range), #F listed triangles with group tags
/// Outputs:
///   returns  #V + #E vertices: the old ones with their indices, then one per unique edge of the
///            tets, ordered by (smaller index, larger index) of the edge's ends;
///            8 #T tets (tet t's children at 8t .. 8t + 7, the corners first) with t's groups;
///            4 triangles for each listed one on the tets (consecutive, in the listed order) with its
///            groups, the others as they were; the same group names.
///            file_node_ids are 1 .. #V'; file_tet_ids are left empty (the file writer numbers them).
/// Deterministic: the result depends on the input alone, bit for bit.
TetMesh refine_tet_mesh(const TetMesh& mesh);

/// Counts of a mesh after refinement, from the counts before (exact for a conforming mesh:
/// V' = V + E, E' = 2E + 3F + T, F' = 4F + 8T, T' = 8T, with F every distinct face, boundary and
/// interior, and E every distinct edge).
struct RefinedCounts {
  std::int64_t vertices = 0, edges = 0, faces = 0, tets = 0;
  std::int64_t triangles = 0;          ///< listed triangles (those on the tets x 4 a level, the rest kept)
  std::int64_t boundary_faces = 0;     ///< faces of one tet
  double tets_estimate = 0, vertices_estimate = 0;  ///< the same counts as doubles, for messages past INT64_MAX
};

/// The counts of `mesh` itself (levels = 0) or after `levels` refinements, computed without
/// refining (a few sorts of the level-0 mesh). Saturates at INT64_MAX rather than overflowing.
RefinedCounts refined_counts(const TetMesh& mesh, int levels);

}  // namespace ebh
