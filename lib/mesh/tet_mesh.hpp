#pragma once
// Mesh containers shared by readers, the scene, the solvers and the renderer.
// Positions are in metres once a scene has loaded them (files may use cm or mm; the
// conversion happens once, at load: docs/FORMATS.md, "Length units and the mesh transform").
#include <array>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

using Tet = std::array<int, 4>;
using Tri = std::array<int, 3>;

/// A tetrahedral mesh as read from a file: the physical mesh's source.
struct TetMesh {
  std::vector<Vec3d> vertices;           ///< #V positions (file units until scaled)
  std::vector<Tet> tets;                 ///< #T vertex indices, 0-based
  std::vector<int> tet_group;            ///< #T physical group tag (0 when none)
  std::vector<Tri> triangles;            ///< #F boundary triangles listed in the file (may be empty)
  std::vector<int> triangle_group;       ///< #F physical group tag of each triangle
  std::map<int, std::string> group_names;  ///< physical group tag -> name (from $PhysicalNames)
  /// Physical group tag -> the number the mesh file gives that group, for the groups a reader tags
  /// otherwise: a Gmsh surface group moved off a volume group's number (read_msh), a Medit triangle
  /// reference or a TetGen boundary marker N (surface_N, on a tag after every tet's). A tag not
  /// listed is the file's own number. For what a user reads (`ebh scene info`), not for pins.
  std::map<int, int> group_file_tags;
  std::vector<long long> file_node_ids;  ///< #V the node id each vertex had in the file
  std::vector<long long> file_tet_ids;   ///< #T the element id each tet had in the file (may be empty)
  /// Elements in more than one physical group (Gmsh allows it): (tet index, tag) and (triangle
  /// index, tag) for each group after the first, which tet_group / triangle_group hold. Sorted,
  /// each pair once; empty for most meshes.
  std::vector<std::pair<int, int>> tet_more_groups;
  std::vector<std::pair<int, int>> triangle_more_groups;
  /// What a Gmsh file says that the groups above do not hold (read_msh), for the messages of a pin
  /// by group that finds nothing: the file's MSH major version (2 or 4; 0 for other sources), the
  /// names of its physical groups of points and curves (dimension 0 or 1), which pins do not take,
  /// and its triangles and tets in element blocks on entities that $Entities does not list (4.1,
  /// as meshio writes it), read without groups, with the line of the first such block.
  int msh_major = 0;
  std::map<std::string, int> point_curve_groups;
  long long elements_off_entities = 0, first_off_entities_line = 0;
};

/// The indices (ascending, each once) of the `count` elements whose groups, `first` and `more` as
/// TetMesh keeps them (tet_group and tet_more_groups, or the triangles'), include one of `tags`.
inline std::vector<int> elements_in_groups(const std::vector<int>& first, const std::vector<std::pair<int, int>>& more,
                                           std::size_t count, const std::set<int>& tags) {
  std::vector<char> in(count, 0);
  for (std::size_t i = 0; i < count && i < first.size(); ++i) in[i] = tags.count(first[i]) > 0;
  for (const auto& [i, tag] : more)
    if (i >= 0 && static_cast<std::size_t>(i) < count && tags.count(tag)) in[i] = 1;
  std::vector<int> out;
  for (std::size_t i = 0; i < count; ++i)
    if (in[i]) out.push_back(static_cast<int>(i));
  return out;
}

/// A triangle surface: the virtual mesh's source (OBJ) or a boundary extracted from tets.
struct SurfaceMesh {
  std::vector<Vec3d> vertices;  ///< #V positions
  std::vector<Tri> triangles;   ///< #F vertex indices, 0-based, counter-clockwise seen from outside
};

}  // namespace ebh
