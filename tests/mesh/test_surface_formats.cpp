// Virtual-mesh surfaces from PLY and VTK polydata (.vtk POLYDATA, .vtp): every form of the cube
// reads to the OBJ cube's vertices and triangles, and malformed files are refused with FILE:LINE.
#include <gtest/gtest.h>

#include "mesh/mesh_io.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

using test::data;
using test::expect_input_error;
using test::replace;
using test::slurp;
using test::write_temp;

void expect_same_surface(const SurfaceMesh& a, const SurfaceMesh& b) {
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (std::size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices[i], b.vertices[i]) << "vertex " << i;
  EXPECT_EQ(a.triangles, b.triangles);
}

TEST(ReadPly, AsciiAndBothBinaryOrdersGiveTheObjCube) {
  const SurfaceMesh obj = read_obj(data("mesh/cube.obj"));  // six quads, split as every reader splits them
  for (const char* name : {"mesh/cube.ply", "mesh/cube_le.ply", "mesh/cube_be.ply"}) {
    SCOPED_TRACE(name);
    expect_same_surface(read_surface(data(name)), obj);
  }
}

TEST(ReadPly, MalformedFilesAreRefusedWithTheirLine) {
  const std::string ascii = slurp(data("mesh/cube.ply"));
  const std::string le = slurp(data("mesh/cube_le.ply"));
  const std::vector<test::BadFile> cases = {
      {"not_ply.ply", "solid cube\n", 1, "not a PLY file"},
      {"format.ply", replace(ascii, "format ascii 1.0", "format utf8 1.0"), 2, "unknown format 'utf8'"},
      {"type.ply", replace(ascii, "property float x", "property real x"), 5, "unknown property type 'real'"},
      {"no_end.ply", ascii.substr(0, ascii.find("end_header")), 16, "the header ends without end_header"},
      {"no_x.ply", replace(ascii, "property float x", "property float u"), 4, "element vertex has no x, y and z properties"},
      {"no_list.ply", replace(ascii, "vertex_indices", "corners"), 14, "element face has no list property vertex_indices"},
      {"range.ply", replace(ascii, "4 0 2 3 1", "4 0 2 3 9"), 25, "face 0: vertex index 9 is out of range [0, 8)"},
      {"twice.ply", replace(ascii, "4 0 2 3 1", "4 0 2 3 0"), 25, "face 0: vertex 0 twice (a degenerate face)"},
      {"two.ply", replace(ascii, "4 0 2 3 1", "2 0 2"), 25, "face 0: 2 vertices, a face needs 3 at least"},
      {"concave.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n10 0 0\n2 2 0\n0 10 0\n4 0 1 2 3\n",
       14, "face 0: a concave face of 4 vertices (it turns back at vertex 2)"},
      {"nan.ply", replace(ascii, "10 10 10 0 0 1", "10 nan 10 0 0 1"), 24, "a number 'nan' is not a finite number"},
      {"short.ply", ascii.substr(0, ascii.find("4 1 3 7 5")), 30, "the file ends inside an element (cut short?)"},
      {"count.ply", replace(ascii, "element vertex 8", "element vertex 80000"), 4, "80000 vertices do not fit"},
      {"binary_short.ply", le.substr(0, le.size() - 20), 14, "the binary data ends inside an element (cut short?)"},
      {"binary_range.ply", replace(le, "element vertex 8", "element vertex 7"), 14, "binary data, face 0: 0 vertices, a face needs 3 at least"},
      // Once each: a second vertex element after the faces would leave their indices past its count.
      {"vertex_twice.ply",
       replace(ascii, "end_header", "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header") +
           "0 0 0\n1 0 0\n0 1 0\n",
       16, "a second 'element vertex' (the first at line 4)"},
      {"face_twice.ply", replace(ascii, "end_header", "element face 1\nproperty list uchar int vertex_indices\nend_header") + "3 0 1 2\n",
       16, "a second 'element face' (the first at line 14)"},
  };
  test::expect_each_refused(cases, [](const auto& p) { read_surface(p); });
}

TEST(ReadVtkSurface, PolygonsAndAStripGiveTheCube) {
  // five quads as polygons, the +x face as the strip 1 3 5 7: triangles 1 3 5 and 5 3 7
  const SurfaceMesh obj = read_obj(data("mesh/cube.obj"));
  SurfaceMesh expected = obj;
  expected.triangles.resize(10);
  expected.triangles.push_back({1, 3, 5});
  expected.triangles.push_back({5, 3, 7});
  // ASCII legacy (ours), XML with zlib (ours), and VTK 9.1's own: legacy 5.1 binary, XML appended
  for (const char* name : {"mesh/cube_poly.vtk", "mesh/cube_poly.vtp", "mesh/cube_poly_vtk9.vtk", "mesh/cube_poly_vtk9.vtp"}) {
    SCOPED_TRACE(name);
    expect_same_surface(read_surface(data(name)), expected);
  }
}

TEST(ReadVtkSurface, AGridIsNamedAsAPhysicalMeshAndAPolydataAsAVirtualOne) {
  const auto grid = data("mesh/cube_ascii.vtk");
  expect_input_error([&] { read_vtk_surface(grid); }, grid, 4, "a DATASET UNSTRUCTURED_GRID is no surface: the virtual mesh is "
                                                               "a POLYDATA of polygons (this file can be the physical mesh)");
  const auto vtu = data("mesh/cube_ascii.vtu");
  expect_input_error([&] { read_vtp(vtu); }, vtu, 3, "a VTKFile of type 'UnstructuredGrid' is no surface");
  const auto poly = data("mesh/cube_poly.vtp");
  expect_input_error([&] { read_vtu(poly); }, poly, 2, "a VTKFile of type 'PolyData' holds no tetrahedra");
}

TEST(ReadVtkSurface, MalformedFilesAreRefusedWithTheirLine) {
  const std::string legacy = slurp(data("mesh/cube_poly.vtk"));
  const std::vector<test::BadFile> cases = {
      {"range.vtk", replace(legacy, "4 0 2 3 1", "4 0 2 3 8"), 18, "POLYGONS cell 0: point index 8 is out of range [0, 8)"},
      {"concave.vtk", replace(replace(legacy, "0 10 0\n10 10 0", "0 10 0\n2 2 0"), "4 0 2 3 1", "4 0 1 3 2"), 18,
       "POLYGONS cell 0: a concave face of 4 vertices (it turns back at vertex 3)"},
      {"strip.vtk", replace(legacy, "4 1 3 5 7", "2 1 3 5 7"), 24, "TRIANGLE_STRIPS: its size says 5 entries, its cells use 3"},
      {"empty.vtk", legacy.substr(0, legacy.find("VERTICES")), 14, "no POLYGONS or TRIANGLE_STRIPS"},
      // a shorter POINTS after the polygons were checked against the first would leave them past its end
      {"points_twice.vtk", replace(legacy, "POINT_DATA 8", "POINTS 3 float\n0 0 0\n1 0 0\n0 1 0\nPOINT_DATA 8"), 26,
       "a second POINTS section (the first at line 5)"},
  };
  test::expect_each_refused(cases, [](const auto& p) { read_surface(p); });
}

}  // namespace
}  // namespace ebh
