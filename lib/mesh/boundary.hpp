#pragma once
// The surface of a tetrahedral mesh: the faces that belong to exactly one tet.
#include <cstdint>
#include <array>
#include <vector>

#include "math/hd.hpp"
#include "mesh/tet_mesh.hpp"

namespace ebh {

/// Signed volume of the tet (a, b, c, d): det(b - a, c - a, d - a) / 6, positive when d lies on
/// the side of triangle (a, b, c) that its counter-clockwise normal points to.
EBH_HD double signed_volume(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return dot(cross(b - a, c - a), d - a) / 6.0;
}

/// Whether tet (a, b, c, d) is inverted or flat: its signed volume of the opposite sign to (or zero
/// against) `rest_sign`, its sign at rest (+1 or -1; rest_signs). The host's count_inverted_tets
/// and the device's count of the physical steps inside the tick launches (docs/CUDA.md).
EBH_HD bool inverted_or_flat(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d, signed char rest_sign) {
  return signed_volume(a, b, c, d) * rest_sign <= 0;
}

/// The four faces of tet (a, b, c, d), each oriented counter-clockwise seen from outside when the
/// tet has positive signed volume: face f is opposite vertex f.
inline constexpr int kTetFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// A face of a tet as its sorted vertex triple (a < b < c packed as hi = a << 32 | b, lo = c) and
/// the tet face it came from (4 t + f, f of kTetFaces).
struct TetFace {
  std::uint64_t hi = 0;
  std::uint32_t lo = 0;
  int tet_face = 0;
  bool same_face(const TetFace& o) const { return hi == o.hi && lo == o.lo; }
  bool operator<(const TetFace& o) const {
    return hi != o.hi ? hi < o.hi : lo != o.lo ? lo < o.lo : tet_face < o.tet_face;
  }
};

/// Every face of every tet (4 #T), sorted by their vertex triples and, within one triple, by tet
/// face: the tets that share a face stand side by side. Integer keys, not arrays compared
/// element-wise: the mesh checks of a load sort these faces more than once (a 350k-tet mesh holds
/// 1.4 million).
std::vector<TetFace> sorted_tet_faces(const std::vector<Tet>& tets);

/// multiplicity[4 t + f]: how many tets use face f of tet t, from their sorted_tet_faces.
std::vector<std::uint8_t> face_multiplicity(const std::vector<TetFace>& sorted);

/// Extracts the boundary surface of a tet mesh.
///
/// Inputs:
///   mesh  #V vertices and #T tets (indices in range; any orientation: faces of a tet with
///         negative signed volume are flipped so the result still faces outward)
/// Outputs:
///   returns  #B vertices, #F triangles: the faces used by exactly one tet, counter-clockwise
///            seen from outside, in tet order, over a compacted vertex numbering (ascending in
///            the tet mesh's numbering)
///   surface_to_volume  if not null, #B: the tet-mesh vertex of each surface vertex
/// Faces shared by three or more tets (a non-manifold volume) are not boundary faces.
///   multiplicity  if not null, face_multiplicity of mesh.tets (computed here otherwise)
SurfaceMesh extract_boundary(const TetMesh& mesh, std::vector<int>* surface_to_volume = nullptr,
                             const std::vector<std::uint8_t>* multiplicity = nullptr);

/// Counts face multiplicities: faces used by exactly one tet (boundary), exactly two
/// (interior) and more than two (non-manifold, an error in a valid mesh). For a manifold mesh
/// interior = (4 #T - boundary) / 2: the paper's Table 1 "triangle" count.
struct FaceCounts {
  long long boundary = 0;
  long long interior = 0;
  long long nonmanifold = 0;
};
FaceCounts count_faces(const std::vector<Tet>& tets);
/// The same from the tets' face_multiplicity.
FaceCounts count_faces(const std::vector<std::uint8_t>& multiplicity);

/// How a triangle surface closes up: edges of one face only (a hole's rim, a cut patch's border),
/// edges of three or more faces, and faces none of whose edges another face shares (a triangle
/// soup, corners never welded). A closed manifold surface has none of them.
struct SurfaceEdges {
  long long open = 0;
  std::vector<std::array<int, 2>> open_edges;  ///< #open, each (lower vertex, higher vertex), in that order
  long long nonmanifold = 0;
  long long loose_faces = 0;
};
SurfaceEdges surface_edges(const std::vector<Tri>& triangles);

/// Number of faces shared by two tets (see FaceCounts).
inline long long count_interior_faces(const std::vector<Tet>& tets) { return count_faces(tets).interior; }

}  // namespace ebh
