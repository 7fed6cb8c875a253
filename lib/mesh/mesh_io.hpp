#pragma once
// Mesh file readers: Gmsh MSH (ASCII 2.2 and 4.1), VTK legacy or XML, Medit or TetGen for the physical mesh; Wavefront OBJ,
// STL, PLY or VTK polydata for a virtual-mesh surface. Positions stay in file units; the scene scales them (docs/FORMATS.md, "Length units and the mesh transform").
//
// Both readers hold the file in memory and parse it in one pass without regular expressions.
// Untrusted counts never drive an allocation beyond what the file's size can hold. Every error is
// an InputError whose what() is one line: "FILE:LINE: what (element id N)" (the element or node id
// is named when one is known).
#include <filesystem>
#include <string>
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// Reads a Gmsh ASCII mesh, version 2.x (2.2) or 4.1, dispatching on $MeshFormat.
///
/// Kept: 4-node tetrahedra (type 4) and 3-node triangles (type 2), each with its physical groups
/// (2.x: the element's first tag, where Gmsh writes an element once per group: such copies, the
/// same type and nodes, are merged into the first with all their groups; 4.1: the physical tags of
/// its entity in $Entities; tag 0 when there is none), and $PhysicalNames of dimension 2 and 3 (a
/// name as Gmsh reads it: between double quotes, without escapes, a backslash kept). Points, lines, quads and other
/// surface elements are skipped (their nodes checked as a tet's); any other volume element
/// (hexahedra, prisms, pyramids, 10-node tets, ... of every type and order Gmsh defines) is
/// refused, naming each kind's count. Node ids may be sparse and unordered;
/// vertices keep the file's node order and `file_node_ids` maps back. A partitioned 4.1 file
/// (gmsh -part N) reads as the whole mesh: its elements' groups come from $PartitionedEntities,
/// and the triangles between partitions are skipped. A 2.x file's $ParametricNodes (gmsh
/// -parametric) is read as its $Nodes. Other sections are skipped.
/// If a surface and a volume group share a tag but not a name, the surface group gets a fresh
/// tag (> every surface and volume tag in the file) so that `group_names` stays one name per tag;
/// an unnamed one is then named by its number in the file (a scene's pin names it so), and
/// `group_file_tags` maps the fresh tag back to that number.
///
/// Throws InputError for binary files, unsupported versions, malformed or truncated sections, a
/// physical name with text after its closing quote (an inner quote: `"a \"b\""`, which Gmsh cuts at
/// `"a \"`),
/// references to unknown nodes (by any element), duplicate node ids, an element type Gmsh does not
/// define, a 4.1 element block whose entity dimension is not its element type's, volume elements
/// other than 4-node tets, and a file with no tetrahedra.
TetMesh read_msh(const std::filesystem::path& file);

/// Reads a VTK legacy file (`# vtk DataFile Version 2.0` .. 5.1, ASCII or BINARY) holding a
/// DATASET UNSTRUCTURED_GRID: its POINTS and its cells of type 10 (4-node tets), as written by
/// VTK, ParaView, 3D Slicer, TetGen (-k) or meshio. Cells of a lower dimension are skipped; any
/// other volume cell (hexahedra, wedges, 10-node tets, ...) is refused naming each kind's count.
/// Groups: the first cell array of one component (SCALARS, or in a FIELD; integers, or floats
/// holding whole numbers, as ParaView's filters and ITK write labels) named
/// gmsh:physical, CellEntityIds, medit:ref, MaterialIds, material, region(s), label(s), subdomain
/// or domain (in any case) gives each tet its tag, unnamed (a pin names it by its number); the
/// other attributes are read past, and one of a kind without a group after it (LOOKUP_TABLE,
/// COLOR_SCALARS, TEXTURE_COORDINATES) ends the reading. A leading FIELD block and METADATA after
/// an array are skipped. Vertices keep the file's point order (file_node_ids 0..n-1). Lines are
/// numbered as a text editor numbers them: the line feeds among a binary block's bytes count. Throws
/// InputError "FILE:LINE: what" for another dataset, a second POINTS section, a count the rest of
/// the file cannot hold, non-finite coordinates, point indices out of range, cells whose point
/// counts disagree with their type or with the list's size, a group array of another length than
/// the cells or with a value that is no tag (< 0, a fraction, a NaN or above INT32_MAX), a tet's or
/// a skipped cell's alike, naming the cell (and its kind: "cell 2 (a vertex, type 1)"), and a file
/// with no tets.
TetMesh read_vtk(const std::filesystem::path& file);

/// Reads a VTK XML unstructured grid (`.vtu`, as VTK, ParaView, 3D Slicer and meshio write it): its
/// Points and its cells of type 10 (4-node tets), over one or more Pieces (joined, in order). Arrays
/// in any of the formats: ascii, binary (base64 inline) or appended (raw or base64), uncompressed
/// or zlib-compressed (vtkZLibDataCompressor), little- or big-endian, UInt32 or UInt64 headers.
/// Cells of a lower dimension are skipped, other volume cells refused naming each kind's count.
/// Groups as read_vtk: the first cell array of one component (integers, or floats holding whole
/// numbers) named gmsh:physical, CellEntityIds, medit:ref, MaterialIds, material, region(s),
/// label(s), subdomain or domain.
/// Throws InputError "FILE:LINE: what" (the line of the element concerned) for other file types
/// (a parallel .pvtu, image data, ...), lz4 or lzma compression, malformed XML, arrays whose sizes
/// disagree with their headers or counts (a count, NumberOfPoints or NumberOfCells, is checked
/// against what its array's text or bytes can hold before it sizes anything: the error names the
/// <Piece>'s line and the count), damaged compressed blocks, non-finite coordinates, point
/// indices out of range, a cell's group value that is no tag (as read_vtk), and a file with no tets.
/// A cell or a point is named by its number in the file (the pieces' counted in turn, as VTK and
/// ParaView number them) and, in a file of several pieces, by its number in its <Piece> too:
/// "cell 7 (cell 1 of the <Piece> at line 30)".
TetMesh read_vtu(const std::filesystem::path& file);

/// Reads a Medit ASCII mesh (`.mesh`, MeshVersionFormatted 1 to 3, Dimension 3), as MMG, CGAL's
/// Mesh_3, TetGen (-g), SOFA and meshio write it: its Vertices, Tetrahedra and Triangles (1-based
/// vertex numbers, a reference after each). Keywords in any case, values over any lines, `#`
/// comments. A tet's reference is its group (unnamed: a pin names it by number, `group:2`); a
/// triangle's reference N > 0 its group named `surface_N` (on a tag after every tet's, so a surface
/// and a subdomain of the same number stay apart; `group_file_tags` maps it back to N). Edges, corners, ridges, required entities,
/// normals, tangents and quadrilaterals are read past; hexahedra, prisms, pyramids and
/// second-order tets are refused naming each kind's count. Throws InputError "FILE:LINE: what" for
/// a binary .meshb (not text), a 2-D mesh, an unknown keyword (its record size is unknown), a
/// count the rest of the file cannot hold, non-finite coordinates, vertex numbers out of range,
/// negative references, a section given twice, a file without End (cut short) and one with no
/// tetrahedra.
TetMesh read_medit(const std::filesystem::path& file);

/// Reads a TetGen mesh from its `.node` or its `.ele` file (either; the other beside it, with the
/// same name): the nodes, the 4-node tets, and the boundary faces of a `.face` beside them where
/// there is one. Records one per line, `#` comments, numbers from 0 or 1 (set by the first node,
/// consecutive in each file). The first region attribute (`tetgen -A`) is a tet's group (unnamed,
/// a whole number >= 0); a face's boundary marker N > 0 its group named `surface_N`, as read_medit
/// (`group_file_tags` maps its tag back to N).
/// Node attributes and markers are read past. Throws InputError "FILE:LINE: what" for a missing
/// .node or .ele, 2-D or second-order (-o2) meshes, records out of order or with the wrong number
/// of values, node numbers out of range, non-finite coordinates, attributes that are no group tag,
/// and counts the rest of the file cannot hold.
TetMesh read_tetgen(const std::filesystem::path& file);

/// The files besides `file` that read_tet_mesh reads for the mesh (a TetGen mesh's other .node or
/// .ele, and its .face where there is one; none for the other formats): the mesh's provenance.
std::vector<std::filesystem::path> tet_mesh_companions(const std::filesystem::path& file);

/// The physical mesh of `file`, by its extension (in any case): read_msh for .msh, read_vtk for
/// .vtk, read_medit for .mesh, read_tetgen for .node and .ele, read_vtu for .vtu (and .pvtu, .vtp,
/// which it refuses by their type). Throws InputError "FILE: ..." for a surface's extension (.stl,
/// .obj, .ply, .off: a surface holds no tetrahedra) and for any other, naming the ones read.
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

/// Reads a PLY surface (ASCII, binary_little_endian or binary_big_endian; what 3D Slicer, MeshLab,
/// Blender and Open3D write): the x, y, z of its `vertex` element and the `vertex_indices` (or
/// `vertex_index`) lists of its `face` element, 0-based; other properties and elements are read
/// past; polygons split around their first corner (convex ones only, as read_obj). Throws
/// InputError "FILE:LINE: what" (binary data: the line where it starts, with the element and its
/// number) for a malformed header (an `element vertex` or `element face` given twice among it),
/// unknown types, a missing x/y/z or face list, counts the rest of the file cannot hold,
/// non-finite coordinates, indices out of range, faces of fewer than 3 vertices or naming one
/// twice, concave faces, and a file with no faces.
SurfaceMesh read_ply(const std::filesystem::path& file);

/// Reads a VTK legacy POLYDATA surface (`.vtk`, ASCII or BINARY, 2.0 to 5.1, as 3D Slicer's Models
/// and VTK write it): its POINTS, POLYGONS (split around their first corner, convex ones only) and
/// TRIANGLE_STRIPS; VERTICES and LINES are read past, the attributes not read. Throws InputError
/// "FILE:LINE: what" as read_vtk, and for an UNSTRUCTURED_GRID (named as a physical mesh).
SurfaceMesh read_vtk_surface(const std::filesystem::path& file);

/// Reads a VTK XML PolyData surface (`.vtp`, ParaView, 3D Slicer, VTK): its Points, Polys and
/// Strips over its pieces, in any of read_vtu's array formats; Verts and Lines are not read.
SurfaceMesh read_vtp(const std::filesystem::path& file);

/// A virtual-mesh surface by its extension (in any case): read_stl for .stl, read_ply for .ply,
/// read_vtk_surface for .vtk, read_vtp for .vtp, read_obj otherwise. Every triangle's indices are
/// checked to lie in [0, #V) before it returns (InputError "FILE: triangle N: ...").
SurfaceMesh read_surface(const std::filesystem::path& file);

/// The Wavefront OBJ text of `surface` (`v x y z` at %.17g, `f a b c` 1-based): read_obj reads it
/// back to the same vertices, to the last bit, and triangles.
std::string obj_text(const SurfaceMesh& surface);

}  // namespace ebh
