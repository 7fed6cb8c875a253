// VTK legacy reader for the physical mesh: ASCII, binary and 5.1 forms give the same tets, and
// every malformed case is refused with FILE:LINE.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <utility>

#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

using test::data;
using test::expect_input_error;
using test::replace;
using test::slurp;
using test::write_temp;

// The cube of make_test_meshes.py: corner c = x + 2y + 4z at (10 x, 10 y, 10 z), five tets.
TEST(ReadVtk, AsciiWithAFieldBlockAndCellsOfLowerDimensions) {
  const TetMesh m = read_vtk(data("mesh/cube_ascii.vtk"));
  ASSERT_EQ(m.vertices.size(), 8u);
  EXPECT_EQ(m.vertices[5], Vec3d(10, 0, 10));
  ASSERT_EQ(m.tets.size(), 5u);  // the vertex, the line and the triangle among them are skipped
  EXPECT_EQ(m.tets[0], (Tet{0, 1, 2, 4}));
  EXPECT_EQ(m.file_tet_ids, (std::vector<long long>{0, 1, 5, 6, 7}));  // their cell numbers
  EXPECT_TRUE(m.triangles.empty());
  EXPECT_EQ(m.tet_group, (std::vector<int>{1, 1, 2, 2, 2}));  // the cell array "region"
  EXPECT_TRUE(m.group_names.empty());                          // unnamed: pins name them by number
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal()) << r.fatal_message(m);
  EXPECT_EQ(r.boundary_faces, 12);  // the cube's six faces, two triangles each
}

TEST(ReadVtk, BinaryAnd51FormsGiveTheSameTets) {
  const TetMesh ascii = read_vtk(data("mesh/cube_ascii.vtk"));
  for (const char* name : {"mesh/cube_binary.vtk", "mesh/cube51.vtk"}) {
    const TetMesh m = read_vtk(data(name));
    EXPECT_EQ(m.tets, ascii.tets) << name;
    ASSERT_EQ(m.vertices.size(), ascii.vertices.size()) << name;
    for (std::size_t i = 0; i < m.vertices.size(); ++i) EXPECT_EQ(m.vertices[i], ascii.vertices[i]) << name << " " << i;
  }
  // The binary file's regions are gmsh:physical in a FIELD of its cell data; 5.1's file has none.
  EXPECT_EQ(read_vtk(data("mesh/cube_binary.vtk")).tet_group, ascii.tet_group);
  EXPECT_EQ(read_vtk(data("mesh/cube51.vtk")).tet_group, std::vector<int>(5, 0));
}

TEST(ReadVtk, GroupsThatAreNotTagsAreRefused) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtk"));
  const auto p = write_temp("negative.vtk", replace(ascii, "LOOKUP_TABLE default\n1\n1\n0", "LOOKUP_TABLE default\n1\n-1\n0"));
  expect_input_error([&] { read_vtk(p); }, p, 47, "cell 1: region -1 is not a group tag (a whole number from 0 to 2147483647)");
  // A cell array of another name (an id per cell) is not taken as groups.
  EXPECT_EQ(read_vtk(write_temp("ids.vtk", replace(ascii, "SCALARS region", "SCALARS vtkOriginalCellIds"))).tet_group,
            std::vector<int>(5, 0));
}

/// `v`'s bytes, big-endian: a legacy binary file's float.
std::string big_endian(float v) {
  const auto u = std::bit_cast<std::uint32_t>(v);
  std::string out;
  for (int k = 3; k >= 0; --k) out += static_cast<char>((u >> (8 * k)) & 0xff);
  return out;
}

/// cube_binary.vtk with its gmsh:physical FIELD array (5 ints) as the floats `groups`.
std::string binary_with_float_groups(const std::vector<float>& groups) {
  const std::string bin = slurp(data("mesh/cube_binary.vtk"));
  const std::string ints = "gmsh:physical 1 5 int\n";
  const auto at = bin.find(ints);
  EXPECT_NE(at, std::string::npos);
  std::string floats = "gmsh:physical 1 5 float\n";
  for (float g : groups) floats += big_endian(g);
  return bin.substr(0, at) + floats + bin.substr(at + ints.size() + 5 * 4);
}

// ParaView's filters, ITK and 3D Slicer write labels as floats: a float group array of whole
// numbers gives the groups an integer one does, in SCALARS or a FIELD, ASCII or binary.
TEST(ReadVtk, AFloatGroupArrayOfWholeNumbersGivesTheGroups) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtk"));
  const std::vector<int> groups = read_vtk(data("mesh/cube_ascii.vtk")).tet_group;  // {1, 1, 2, 2, 2}
  for (const std::string type : {"float", "double"}) {
    SCOPED_TRACE(type);
    const std::string text = replace(replace(ascii, "SCALARS region int", "SCALARS region " + type), "LOOKUP_TABLE default\n1\n1\n",
                                     "LOOKUP_TABLE default\n1.0\n1e0\n");
    EXPECT_EQ(read_vtk(write_temp("float.vtk", text)).tet_group, groups);
  }
  const std::string field = ascii.substr(0, ascii.find("SCALARS region")) + "FIELD FieldData 1\nMaterialIds 1 8 double\n1 1 0 0 0 2 2 2\n";
  EXPECT_EQ(read_vtk(write_temp("field.vtk", field)).tet_group, groups);
  EXPECT_EQ(read_vtk(write_temp("binary.vtk", binary_with_float_groups({1, 1, 2, 2, 2}))).tet_group, groups);
  // the largest tag, and 0 on a cell that is no tet (cell 2, a vertex)
  const std::string edge = replace(replace(ascii, "SCALARS region int", "SCALARS region double"), "LOOKUP_TABLE default\n1\n1\n0\n",
                                   "LOOKUP_TABLE default\n2147483647\n1\n0\n");
  EXPECT_EQ(read_vtk(write_temp("edge.vtk", edge)).tet_group, (std::vector<int>{2147483647, 1, 2, 2, 2}));
}

// A tet's float label that is no tag (a fraction, a NaN, out of range) is refused naming the file,
// the array's line, the cell, the array and the value.
TEST(ReadVtk, AFloatGroupValueThatIsNoTagIsRefusedWithItsCell) {
  const std::string doubles = replace(slurp(data("mesh/cube_ascii.vtk")), "SCALARS region int", "SCALARS region double");
  for (const auto& [value, shown] : {std::pair{"1.5", "1.5"}, std::pair{"nan", "nan"}, std::pair{"-1", "-1"},
                                     std::pair{"2147483648", "2147483648"}, std::pair{"3e9", "3e+09"}}) {
    SCOPED_TRACE(value);
    const auto p = write_temp("bad.vtk", replace(doubles, "LOOKUP_TABLE default\n1\n1\n", std::string("LOOKUP_TABLE default\n1\n") + value + "\n"));
    expect_input_error([&] { read_vtk(p); }, p, 47, std::string("cell 1: region ") + shown + " is not a group tag (a whole number from 0 to 2147483647)");
  }
  const std::string ascii = slurp(data("mesh/cube_ascii.vtk"));
  const auto field = write_temp("field.vtk", ascii.substr(0, ascii.find("SCALARS region")) + "FIELD FieldData 1\nMaterialIds 1 8 float\n1 1 0 0 0 2.25 2 2\n");
  expect_input_error([&] { read_vtk(field); }, field, 48, "cell 5: MaterialIds 2.25 is not a group tag");
  const auto bin = write_temp("binary.vtk", binary_with_float_groups({1, 1, 2, std::nanf(""), 2}));
  // (line 20: the line feeds among the binary blocks' bytes count, CELL_TYPES' five 10s)
  expect_input_error([&] { read_vtk(bin); }, bin, 20, "cell 3: gmsh:physical nan is not a group tag");
}

// A value in the group array on a cell that is no tet (a vertex, a line, a triangle: read past) is
// checked as a tet's is: a NaN, a fraction or a value out of range there is refused, naming the
// cell and its kind, at the array's line.
TEST(ReadVtk, AGroupValueOnACellThatIsNoTetIsCheckedAsATetsIs) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtk"));  // cells 2, 3, 4: a vertex, a line, a triangle
  const std::string doubles = replace(ascii, "SCALARS region int", "SCALARS region double");
  const std::string values = "LOOKUP_TABLE default\n1\n1\n0\n0\n0\n";
  test::expect_each_refused(
      {
          {"vertex.vtk", replace(doubles, values, "LOOKUP_TABLE default\n1\n1\nnan\n0\n0\n"), 47,
           "cell 2 (a vertex, type 1): region nan is not a group tag (a whole number from 0 to 2147483647)"},
          {"line.vtk", replace(doubles, values, "LOOKUP_TABLE default\n1\n1\n0\n0.5\n0\n"), 47,
           "cell 3 (a line, type 3): region 0.5 is not a group tag"},
          {"triangle.vtk", replace(doubles, values, "LOOKUP_TABLE default\n1\n1\n0\n0\n3e9\n"), 47,
           "cell 4 (a triangle, type 5): region 3e+09 is not a group tag"},
          {"int.vtk", replace(ascii, values, "LOOKUP_TABLE default\n1\n1\n0\n0\n-1\n"), 47,
           "cell 4 (a triangle, type 5): region -1 is not a group tag"},
          {"field.vtk", ascii.substr(0, ascii.find("SCALARS region")) + "FIELD FieldData 1\nMaterialIds 1 8 float\n1 1 inf 0 0 2 2 2\n", 48,
           "cell 2 (a vertex, type 1): MaterialIds inf is not a group tag"},
      },
      [](const auto& p) { read_vtk(p); });
  // the first cell whose value is no tag, in the file's order, a tet or not
  const auto p = write_temp("both.vtk", replace(doubles, values, "LOOKUP_TABLE default\n1\n1\n0\n-2\n0\n2.5\n"));
  expect_input_error([&] { read_vtk(p); }, p, 47, "cell 3 (a line, type 3): region -2 is not a group tag");
}

/// The line of the first `key` in `bytes` as a text editor and `grep -an` number it: one after the
/// line feeds before it, those among binary data's bytes too.
int line_of(const std::string& bytes, const std::string& key) {
  const auto at = bytes.find(key);
  EXPECT_NE(at, std::string::npos) << key;
  return 1 + static_cast<int>(std::count(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// After binary data, a message names the line that an editor shows: the binary blocks' bytes that
// are line feeds (a cell type 10, an int 10) count as line ends, as they do there.
TEST(ReadVtk, LinesAfterBinaryDataAreNumberedAsAnEditorNumbersThem) {
  const std::string bin = slurp(data("mesh/cube_binary.vtk"));
  // CELL_TYPES 5 is on line 9, its five 10s (00 00 00 0a) on line 10 .. 15: CELL_DATA is on line 16
  ASSERT_EQ(line_of(bin, "CELL_TYPES"), 9);
  ASSERT_EQ(line_of(bin, "CELL_DATA"), 16);
  const std::string typo = replace(bin, "CELL_DATA 5\n", "CELL_DATUM 5\n");
  const auto p = write_temp("keyword.vtk", typo);
  expect_input_error([&] { read_vtk(p); }, p, line_of(typo, "CELL_DATUM"), "unexpected 'CELL_DATUM'");
  // the FIELD's group array, after a binary array of doubles: the line of its name
  const std::string ints = replace(bin, "gmsh:physical 1 5 int", "gmsh:physical 1 4 int");
  const auto q = write_temp("count.vtk", ints);
  expect_input_error([&] { read_vtk(q); }, q, line_of(ints, "gmsh:physical"), "gmsh:physical: 4 values for the 5 cells");
}

TEST(ReadVtk, ReadTetMeshTakesVtkByItsExtensionInAnyCase) {
  const std::string text = slurp(data("mesh/cube_ascii.vtk"));
  EXPECT_EQ(read_tet_mesh(write_temp("CUBE.VTK", text)).tets.size(), 5u);
  EXPECT_EQ(read_tet_mesh(data("mesh/cube22.msh")).tets.size(), 5u);
}

// A surface given as the physical mesh is named as one (as a VTK POLYDATA is), and a file of an
// extension read_tet_mesh does not know is refused naming those it does, not read as a Gmsh file.
TEST(ReadTetMesh, ASurfaceOrAnUnknownExtensionSaysWhatThePhysicalMeshIs) {
  const std::string read = "a .msh (Gmsh), .vtk or .vtu (VTK), .mesh (Medit) or .node/.ele (TetGen) file";
  auto message = [](const std::filesystem::path& p) {
    try {
      read_tet_mesh(p);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string surface = " file holds no tetrahedra (a surface: it can be the virtual mesh): the physical mesh is a "
                              "volume of tets: mesh the surface first (gmsh -3, tetgen) to " + read;
  for (const auto& [name, kind] : {std::pair{"mesh/cube_ascii.stl", "an STL"}, std::pair{"mesh/cube.obj", "a Wavefront OBJ"},
                                   std::pair{"mesh/cube.ply", "a PLY"}}) {
    SCOPED_TRACE(name);
    EXPECT_EQ(message(data(name)), data(name).string() + ": " + kind + surface);
  }
  const auto off = write_temp("CUBE.OFF", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(message(off), off.string() + ": an OFF file holds no tetrahedra (a surface): the physical mesh is a volume of "
                                         "tets: mesh the surface first (gmsh -3, tetgen) to " + read);
  const auto vtp = data("mesh/cube_poly.vtp");
  expect_input_error([&] { read_tet_mesh(vtp); }, vtp, 2, "a VTKFile of type 'PolyData' holds no tetrahedra (a surface: it can "
                                                          "be the virtual mesh): the physical mesh is an UnstructuredGrid of tets");
  const std::string msh = slurp(data("mesh/cube22.msh"));
  const auto txt = write_temp("cube.txt", msh);
  EXPECT_EQ(message(txt), txt.string() + ": extension '.txt' names no format read: a physical mesh is " + read);
  const auto bare = write_temp("cube", msh);
  EXPECT_EQ(message(bare), bare.string() + ": no extension to tell its format: a physical mesh is " + read);
  // what keeps a file from being read at all is said first
  const auto missing = bare.parent_path() / "missing.stl";
  EXPECT_EQ(message(missing), missing.string() + ": cannot open file: No such file or directory");
  const auto partial = write_temp("cube.msh.host.1.ebh-partial", msh);
  EXPECT_NE(message(partial).find("an unfinished output of ebh"), std::string::npos) << message(partial);
}

TEST(ReadVtk, OtherVolumeCellsAreRefusedByKind) {
  const auto p = data("mesh/cube_hex.vtk");
  expect_input_error([&] { read_vtk(p); }, p, 14,  // the CELLS line
                     "the volume holds 1 hexahedra besides its 1 tetrahedra: the physical mesh is 4-node tets only");
}

TEST(ReadVtk, MalformedFilesAreRefusedWithTheirLine) {
  const std::string good = slurp(data("mesh/cube51.vtk"));
  const std::string ascii = slurp(data("mesh/cube_ascii.vtk"));
  const std::vector<test::BadFile> cases = {
      {"not_vtk.vtk", "$MeshFormat\n2.2 0 8\n", 1, "not a VTK legacy file"},
      {"polydata.vtk", replace(good, "DATASET UNSTRUCTURED_GRID", "DATASET POLYDATA"), 4,
       "a DATASET POLYDATA holds no tetrahedra (a surface: it can be the virtual mesh)"},
      {"mode.vtk", replace(good, "ASCII", "TEXT"), 3, "expected ASCII or BINARY, got 'TEXT'"},
      {"nan.vtk", replace(good, "10 10 10", "10 nan 10"), 13, "'nan' is not a finite number"},
      {"index.vtk", replace(good, "6 7 4 2", "6 7 4 9"), 17, "cell 3: point index 9 is out of range [0, 8)"},
      {"offsets.vtk", replace(good, "0 4 8 12 16 20", "0 4 8 12 16 21"), 17, "cell 4: OFFSETS 16..21 is not a range"},
      {"points.vtk", replace(replace(ascii, "4 3 2 1 7", "3 3 2 1"), "CELLS 8 34", "CELLS 8 33"), 19, "cell 1 (a tetrahedron, type 10) has 3 points, expected 4"},
      {"short.vtk", good.substr(0, good.find("CONNECTIVITY")), 20, "the file ends before its CONNECTIVITY array"},
      {"count.vtk", replace(good, "POINTS 8 float", "POINTS 8000000 float"), 5, "values do not fit in the rest of the file"},
      {"types.vtk", replace(good, "CELL_TYPES 5\n10\n", "CELL_TYPES 4\n"), 17, "CELLS lists 5 cells, CELL_TYPES 4"},
      {"no_tets.vtk", ascii.substr(0, ascii.find("CELLS")) + "CELLS 1 2\n1 0\nCELL_TYPES 1\n1\n", 19,
       "no tetrahedra (cell type 10) among the 1 cells"},
      {"keyword.vtk", replace(good, "CELL_TYPES", "CELL_TYPOS"), 22, "unexpected 'CELL_TYPOS'"},
      {"points_twice.vtk", replace(good, "CELLS 6 20", "POINTS 1 float\n0 0 0\nCELLS 6 20"), 17,
       "a second POINTS section (the first at line 5)"},
  };
  test::expect_each_refused(cases, [](const auto& p) { read_vtk(p); });
}

TEST(ReadVtk, ABinaryFileCutShortSaysSo) {
  const std::string bin = slurp(data("mesh/cube_binary.vtk"));
  const auto p = write_temp("cut.vtk", bin.substr(0, bin.find("CELLS") + 30));
  expect_input_error([&] { read_vtk(p); }, p, 7, "CELLS: 25 values do not fit in the rest of the file");
}

}  // namespace
}  // namespace ebh
