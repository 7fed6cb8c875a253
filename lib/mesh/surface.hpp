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

/// Open edges (of one face) that lie along another open edge sharing no corner with it, each of
/// its corners near one of the other's (their mean distance under a quarter of the shorter edge):
/// a seam exported as two borders, never welded, that a tool slips through. `edges` counts them,
/// `gap` is the largest such mean distance (positions' unit).
struct UnweldedSeam {
  long long edges = 0;
  double gap = 0;
};
UnweldedSeam unwelded_seam(const SurfaceMesh& surface);

/// Vertices of open edges that lie inside another open edge (within kTJunctionReach of its length,
/// off its ends): T-junctions, where a face's edge runs past a vertex of the faces beside it. The
/// surface is closed there in space but its faces are not joined, so its sides can part.
inline constexpr double kTJunctionReach = 1e-3;  // an OBJ's printed digits leave ~1e-5 of an edge
long long t_junctions(const SurfaceMesh& surface);

/// Turns triangles wound against their neighbours (an edge that two triangles traverse the same
/// way) so that each piece of the surface is wound one way: per piece joined by edges of two
/// triangles, the winding most of its triangles have is kept (a consistent surface is unchanged).
/// Edges of one or of three and more triangles do not join. Returns the number turned.
std::size_t orient_consistently(std::vector<Tri>& triangles);

}  // namespace ebh
