#pragma once
// Checks a tet mesh before it becomes a physical mesh: what is fatal (the solver cannot run on
// it) and what deserves a warning, plus element quality.
#include <array>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// Mean ratio shape quality of a tet, in [0, 1]: 12 (3 |V|)^(2/3) / sum of squared edge lengths.
/// 1 for the regular tet, 0 for a flat one (Liu & Joe 1994). Inverted tets count as 0.
double tet_mean_ratio(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);

/// Relative volume below which a tet is degenerate: signed volume <= kDegenerateVolume * l^3,
/// with l the tet's longest edge. The regular tet has V / l^3 = 0.118; 1e-12 flags only tets
/// that are flat to about the precision of the coordinates.
inline constexpr double kDegenerateVolume = 1e-12;

/// What validate_mesh found. Element and vertex indices are 0-based positions in the TetMesh.
struct MeshReport {
  int num_vertices = 0;
  int num_tets = 0;
  // fatal
  std::vector<int> bad_index_tets;      ///< tets with a vertex index outside [0, #V) or repeated
  std::vector<int> nonfinite_vertices;  ///< vertices with a NaN or infinite coordinate
  std::vector<int> degenerate_tets;     ///< |signed volume| <= kDegenerateVolume l^3
  std::vector<int> inverted_tets;       ///< signed volume < -kDegenerateVolume l^3
  long long nonmanifold_faces = 0;      ///< tet faces shared by three or more tets
  /// (later, earlier) tets with the same four vertices in any order: a part of the volume listed
  /// twice (two entities, or a label meshed apart and concatenated), its mass counted twice
  std::vector<std::array<int, 2>> repeated_tets;
  /// pairs of tets sharing a face on the same side of it: one overlaps the other (a tet inside
  /// another shares a face with it and counted its volume and mass twice)
  std::vector<std::array<int, 2>> overlapping_tets;
  /// A tet of one part (tets connected through shared vertices) whose centre lies inside a tet of
  /// another part, as (tet, tet); {-1, -1}: none. Two volumes overlap without sharing nodes (a
  /// label meshed apart from its organ and appended): their space and mass counted twice, the
  /// inner one's surface a virtual surface inside the tissue.
  std::array<int, 2> part_inside_part{-1, -1};
  // warnings
  std::vector<int> unreferenced_vertices;             ///< used by no tet
  std::vector<std::pair<int, int>> duplicate_vertices;  ///< (later, earlier) at the same position
  std::vector<std::array<int, 2>> nonmanifold_edges;  ///< boundary edges in != 2 boundary faces
  /// Parts that overlap less: no tet centre inside the other, a tet's vertex strictly inside a tet of
  /// another part (tet, tet), and how messages name them; {-1, -1}: none (or part_inside_part).
  std::array<int, 2> parts_overlap{-1, -1};
  std::string parts_overlap_names;
  /// Pieces of the mesh (tets joined through shared faces) that touch another piece at vertices or
  /// edges only: `jointed_pieces` pieces beyond one per connected part, `joint_vertices` vertices
  /// shared by pieces, the first of them `first_joint_vertex` (-1: none) and the smallest piece
  /// there, in tets. Such a piece turns about its joint, held only by the coupling (two labels of a
  /// segmentation touching at a corner voxel).
  long long jointed_pieces = 0, joint_vertices = 0, joint_piece_tets = 0;
  int first_joint_vertex = -1;
  std::string joint_name;  ///< how messages name first_joint_vertex ("node 7" or "vertex 6")
  long long poor_tets = 0;  ///< tets of mean ratio below kPoorTetQuality (near flat: the solver stalls on them)
  /// tets whose file element id another tet has too (file_tet_ids), and the first such id: the
  /// ids messages name would name more than one element
  long long duplicate_tet_ids = 0;
  long long first_duplicate_tet_id = 0;
  /// How messages name them: "vertex 364" or with the file's ids "node 200365" / "element id 57"
  /// (the mesh's file_node_ids and file_tet_ids, when it has them).
  std::string duplicate_names, worst_tet_name;
  // counts and quality (over tets with valid indices)
  long long boundary_faces = 0;
  long long interior_faces = 0;
  double quality_worst = 0.0;  ///< smallest mean ratio (see tet_mean_ratio)
  double quality_mean = 0.0;   ///< average mean ratio
  int worst_tet = -1;          ///< the tet with the smallest mean ratio

  /// True if the mesh cannot be simulated.
  bool fatal() const {
    return !bad_index_tets.empty() || !nonfinite_vertices.empty() || !degenerate_tets.empty() ||
           !inverted_tets.empty() || !repeated_tets.empty() || nonmanifold_faces > 0 || !overlapping_tets.empty() ||
           part_inside_part[0] >= 0 || num_tets == 0;
  }
  /// One line describing the first fatal problem, e.g. "2 inverted tets, the first: tet 12
  /// (element id 57), signed volume -3e-09", empty if none. `mesh` is the mesh this report is
  /// about; its file_tet_ids (if present) give the element ids.
  std::string fatal_message(const TetMesh& mesh) const;
  /// One line per kind of non-fatal problem, naming the first few culprits.
  std::vector<std::string> warnings() const;
};

/// A tet of mean ratio below this is near flat: the physical solver's iterations stall on such
/// tets (the own-data organ with slivers of 0.005: steps stalled at 55 times the tolerance) and a
/// mesh squashed to 1e-4 stopped the replay; the committed meshes' worst is 0.39, the degraded
/// stress meshes' 0.02-0.04.
inline constexpr double kPoorTetQuality = 0.01;

/// The connected parts of a tet mesh (tets sharing a vertex): each vertex's part, named by the
/// part's lowest vertex index (a vertex no tet uses is a part of its own). Tets' indices must be
/// in range.
std::vector<int> mesh_parts(const TetMesh& mesh);

/// Validates a tet mesh: indices in range, finite coordinates, degenerate and inverted tets,
/// non-manifold faces and boundary edges, unreferenced and duplicate vertices (same position up
/// to 1e-12 of the bounding box diagonal, found with a spatial hash), element quality.
MeshReport validate_mesh(const TetMesh& mesh);

/// How many of `tets` are inverted or flat at positions x: signed volume of the opposite sign to
/// (or zero against) `rest_sign`, each tet's sign at rest (+1 or -1; rest_signs computes them).
int count_inverted_tets(std::span<const Vec3d> x, std::span<const Tet> tets, std::span<const signed char> rest_sign);
std::vector<signed char> rest_signs(std::span<const Vec3d> rest, std::span<const Tet> tets);

/// The inverted or flat tets of a deforming mesh, one count per state (after each physical step),
/// against its orientation at rest (taken at the first count), and the most counted.
struct InvertedTets {
  std::vector<signed char> rest_sign;
  int most = 0;
  /// The count at positions x of the mesh (rest, tets); keeps the most.
  int count(std::span<const Vec3d> rest, std::span<const Tet> tets, std::span<const Vec3d> x) {
    if (rest_sign.empty()) rest_sign = rest_signs(rest, tets);
    return record(count_inverted_tets(x, tets, rest_sign));
  }
  /// A count made elsewhere (the device's, PhysicalStepReport::inverted); keeps the most.
  int record(int n) {
    most = n > most ? n : most;
    return n;
  }
};

/// How orient_tets found the tets.
struct Orientation {
  enum class Kind { Positive, Flipped, Mixed };
  Kind kind = Kind::Positive;
  int positive = 0;   ///< tets with positive signed volume (before any flip)
  int negative = 0;   ///< tets with negative signed volume (before any flip)
  int witness = -1;   ///< Mixed: the first tet of negative volume (flipped)
};

/// Makes every tet positively oriented by swapping the vertices 1 and 2 of each tet of negative
/// volume: all of them (some generators write them that way: Flipped) or some (Mixed: a vertex
/// order that differs from tet to tet, as converters and hand-made files leave it). Geometry
/// decides, not the file's order, so a fold or a tangle is not hidden: a tet turned inside out
/// among its neighbours sees a shared face from their side once flipped, which validate_mesh
/// refuses (overlapping tets). Degenerate tets (|V| tiny) count for neither sign.
/// Tets with out-of-range indices are ignored (validate_mesh reports them).
Orientation orient_tets(TetMesh& mesh);

/// What orient_tets did, for a load warning ("" when every tet was positive).
std::string orientation_warning(const Orientation& o, const TetMesh& mesh);

/// Removes vertices no tet uses, renumbering tets and triangles (triangles that use a removed
/// vertex are dropped). Returns how many vertices were removed.
int remove_unreferenced_vertices(TetMesh& mesh);

/// Removes the vertices of a surface that no triangle uses (a virtual mesh's OBJ with stray
/// points), renumbering the triangles. Returns how many were removed.
int remove_unused_surface_vertices(SurfaceMesh& mesh);

/// What merge_coincident_surface_vertices did: vertices merged into another (`near` of them at
/// another position, within the tolerance), faces removed.
struct MergedVertices {
  int vertices = 0;
  int near = 0;
  int faces = 0;
};

/// Merges the vertices of a surface at exactly the same position (equal coordinates; 0 and -0
/// alike), or within `within` of it, into the first of them, as a triangle soup (an STL converted
/// to OBJ) or a seam exported twice (its copies a round-off apart) needs so that its faces share
/// edges. A vertex merges into the lowest-numbered earlier vertex within reach that is itself kept
/// (no chains). The vertices keep their order, the first of each position in its place; the
/// triangles are renumbered, and those left with a repeated vertex (zero area) are removed. A
/// surface with no two vertices that close is left untouched.
MergedVertices merge_coincident_surface_vertices(SurfaceMesh& mesh, double within = 0);

/// The weld tolerance of a virtual mesh's vertices, a share of its bounding box's diagonal: a seam's
/// copies that an exporter wrote a round-off apart (float32: 1e-7 of the coordinates; six
/// decimals of metres: 1e-6 m on a 0.1 m organ) are one vertex; no two distinct vertices of a
/// surface fine enough to render lie this close (1 um on a 100 mm organ).
inline constexpr double kSurfaceWeldTolerance = 1e-5;

/// "vertex V (node id N)": a vertex of the mesh in a message, with the node id it had in the file
/// (what a mesh tool shows) when the mesh has them.
std::string vertex_name(const TetMesh& mesh, int v);

/// Removes the triangles of a surface whose three vertices another triangle before it already
/// has (in any order or orientation): a face given twice would count twice in surface contact.
/// Returns how many were removed.
int remove_repeated_surface_faces(SurfaceMesh& mesh);

/// Removes the triangles of a surface with no area: corners on one line (twice the area at most
/// 1e-12 of the longest edge squared: round-off of a line). They cover nothing, and their edges,
/// each one face's, read as a hole. Where removing them would open the surface (they fill
/// T-junctions, closing it), none is removed. Returns how many were removed.
int remove_flat_surface_faces(SurfaceMesh& mesh);

}  // namespace ebh
