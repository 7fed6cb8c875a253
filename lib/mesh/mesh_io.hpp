#pragma once
// Mesh file readers: Gmsh MSH (ASCII 2.2 and 4.1) or VTK legacy for the physical mesh, Wavefront OBJ or STL for
// a virtual-mesh surface. Positions stay in file units; the scene scales them (docs/FORMATS.md, "Length units and the mesh transform").
//
// Both readers hold the file in memory and parse it in one pass without regular expressions.
// Untrusted counts never drive an allocation beyond what the file's size can hold. Every error is
// an InputError whose what() is one line: "FILE:LINE: what (element id N)" (the element or node id
// is named when one is known).
#include <filesystem>
#include <string>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// Reads a Gmsh ASCII mesh, version 2.x (2.2) or 4.1, dispatching on $MeshFormat.
///
/// Kept: 4-node tetrahedra (type 4) and 3-node triangles (type 2), each with its physical groups
/// (2.x: the element's first tag, where Gmsh writes an element once per group: such copies, the
/// same type and nodes, are merged into the first with all their groups; 4.1: the physical tags of
/// its entity in $Entities; tag 0 when there is none), and $PhysicalNames of dimension 2 and 3. Points, lines, quads and other
/// surface elements are skipped; any other volume element (hexahedra, prisms, pyramids, 10-node
/// tets, ...) is refused, naming each kind's count. Node ids may be sparse and unordered;
/// vertices keep the file's node order and `file_node_ids` maps back. A partitioned 4.1 file
/// (gmsh -part N) reads as the whole mesh: its elements' groups come from $PartitionedEntities,
/// and the triangles between partitions are skipped. A 2.x file's $ParametricNodes (gmsh
/// -parametric) is read as its $Nodes. Other sections are skipped.
/// If a surface and a volume group share a tag but not a name, the surface group gets a fresh
/// tag (> every surface and volume tag in the file) so that `group_names` stays one name per tag;
/// an unnamed one is then named by its number in the file (a scene's pin names it so).
///
/// Throws InputError for binary files, unsupported versions, malformed or truncated sections,
/// references to unknown nodes, duplicate node ids, volume elements other than 4-node tets, and a
/// file with no tetrahedra.
TetMesh read_msh(const std::filesystem::path& file);

/// Reads a VTK legacy file (`# vtk DataFile Version 2.0` .. 5.1, ASCII or BINARY) holding a
/// DATASET UNSTRUCTURED_GRID: its POINTS and its cells of type 10 (4-node tets), as written by
/// VTK, ParaView, 3D Slicer, TetGen (-k) or meshio. Cells of a lower dimension are skipped; any
/// other volume cell (hexahedra, wedges, 10-node tets, ...) is refused naming each kind's count.
/// Groups: the first integer cell array of one component (SCALARS, or in a FIELD) named
/// gmsh:physical, CellEntityIds, medit:ref, MaterialIds, material, region(s), label(s), subdomain
/// or domain (in any case) gives each tet its tag, unnamed (a pin names it by its number); the
/// other attributes are read past, and one of a kind without a group after it (LOOKUP_TABLE,
/// COLOR_SCALARS, TEXTURE_COORDINATES) ends the reading. A leading FIELD block and METADATA after
/// an array are skipped. Vertices keep the file's point order (file_node_ids 0..n-1). Throws
/// InputError "FILE:LINE: what" for another dataset, a count the rest of the file cannot hold,
/// non-finite coordinates, point indices out of range, cells whose point counts disagree with
/// their type or with the list's size, a group array of another length than the cells or with a
/// value that is no tag (< 0), and a file with no tets.
TetMesh read_vtk(const std::filesystem::path& file);

/// The physical mesh of `file`: read_vtk for a .vtk file (in any case), read_msh otherwise.
TetMesh read_tet_mesh(const std::filesystem::path& file);

/// The Gmsh ASCII 2.2 text of `mesh` with positions multiplied by `scale` (metres -> file units),
/// its triangles and tets with their physical group tags and $PhysicalNames: read_msh reads it
/// back to the same vertices (to the last bit: %.17g), elements and groups.
std::string msh22_text(const TetMesh& mesh, double scale = 1.0);

/// Reads the `v` and `f` lines of a Wavefront OBJ file; every other line is ignored, a line that
/// ends in `\` goes on on the next, and `#` starts a comment (after a face's corners too).
/// Faces may be written `f a b c`, `a/t`, `a/t/n` or `a//n`, with 1-based or negative
/// (relative to the vertices read so far) indices; polygons are fan-triangulated
/// (a b c d -> a b c, a c d), which is right for convex ones. Throws InputError for a file that is
/// not text (gzip-compressed, NUL bytes), bad numbers, non-finite coordinates, indices that are 0
/// or out of range, faces with fewer than 3 vertices, concave polygons (in their plane, seen along
/// their Newell normal), and a file with no faces.
SurfaceMesh read_obj(const std::filesystem::path& file);

/// Reads an STL surface, binary (when the file's size is what its facet count says, whatever its
/// header holds) or ASCII (`solid` ... `facet normal` / `outer loop` / 3 `vertex` / `endloop` /
/// `endfacet` ... `endsolid`, several solids in turn). An STL repeats each corner in every facet
/// that has it: corners at exactly the same position are one vertex, numbered in order of first
/// appearance; the facets keep their corners' order, the normals are not read. Throws InputError
/// for a file that is neither (a binary STL cut short names its size and the size its count needs),
/// non-finite corners, a malformed line (ASCII: its number), and a file with no facets.
SurfaceMesh read_stl(const std::filesystem::path& file);

/// read_stl for a `.stl` file (in any case), read_obj otherwise: a virtual-mesh surface.
SurfaceMesh read_surface(const std::filesystem::path& file);

/// The Wavefront OBJ text of `surface` (`v x y z` at %.17g, `f a b c` 1-based): read_obj reads it
/// back to the same vertices, to the last bit, and triangles.
std::string obj_text(const SurfaceMesh& surface);

}  // namespace ebh
