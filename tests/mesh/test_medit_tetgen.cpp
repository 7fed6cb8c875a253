// Medit (.mesh) and TetGen (.node/.ele/.face) readers for the physical mesh: the committed cube
// reads as its Gmsh twin, groups keep subdomains and surfaces apart, and every malformed case is
// refused with FILE:LINE.
#include <gtest/gtest.h>

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

TEST(ReadMedit, TetsTrianglesAndTheirReferences) {
  const TetMesh m = read_medit(data("mesh/cube.mesh"));
  test::expect_test_cube(m);
  EXPECT_EQ(m.tet_group, (std::vector<int>{1, 1, 2, 2, 2}));  // unnamed: group:1, group:2
  ASSERT_EQ(m.triangles.size(), 4u);
  EXPECT_EQ(m.triangles[0], (Tri{0, 2, 1}));
  // The triangles' references 3 and 1 are surface_1 and surface_3, on tags after the tets' 2: the
  // top's reference 1 does not join the subdomain 1.
  EXPECT_EQ(m.triangle_group, (std::vector<int>{4, 4, 3, 3}));
  EXPECT_EQ(m.group_names, (std::map<int, std::string>{{3, "surface_1"}, {4, "surface_3"}}));
  EXPECT_EQ(m.group_file_tags, (std::map<int, int>{{3, 1}, {4, 3}}));  // their numbers in the file
  EXPECT_EQ(m.file_node_ids.front(), 1);
  EXPECT_EQ(m.file_tet_ids.back(), 5);
}

TEST(ReadMedit, ReadTetMeshTakesItByItsExtension) {
  const TetMesh m = read_tet_mesh(write_temp("CUBE.MESH", slurp(data("mesh/cube.mesh"))));
  EXPECT_EQ(m.tets, test::kTestCubeTets);
}

TEST(ReadMedit, MalformedFilesAreRefusedWithTheirLine) {
  const std::string good = slurp(data("mesh/cube.mesh"));
  std::string binary = "\x01\x00\x00\x00\x02\x00\x00\x00";
  binary.append(16, '\0');
  const std::vector<test::BadFile> cases = {
      {"binary.meshb", binary, 1, "a binary .meshb is not read, write the mesh as ASCII .mesh"},
      {"gmsh.mesh", "$MeshFormat\n2.2 0 8\n", 1, "not a Medit mesh"},
      {"plane.mesh", replace(good, "Dimension\n3", "Dimension\n2"), 5, "Dimension 2: a plane mesh holds no tetrahedra"},
      {"hex.mesh", replace(good, "End", "Hexahedra\n1\n1 2 4 3 5 6 8 7 0\nEnd"), 30,
       "the volume holds 1 hexahedra besides its 5 tetrahedra: the physical mesh is 4-node tets only"},
      {"p2.mesh", replace(good, "End", "TetrahedraP2 1\n1 2 3 5 1 2 3 5 1 2 0\nEnd"), 30,
       "the volume holds 1 10-node tetrahedra besides its 5 tetrahedra"},
      {"unknown.mesh", replace(good, "Edges 1", "Crease 1"), 17, "unknown keyword 'Crease'"},
      {"range.mesh", replace(good, "1 2 3 5 1", "1 2 3 9 1"), 32, "a vertex number 9 is out of range [1, 8] (Tetrahedra record 1)"},
      {"zero.mesh", replace(good, "1 2 3 5 1", "0 2 3 5 1"), 32, "a vertex number 0 is out of range [1, 8]"},
      {"negative.mesh", replace(good, "1 2 3 5 1", "1 2 3 5 -1"), 32, "a reference (group tag, >= 0) -1 is out of range"},
      {"nan.mesh", replace(good, "10 10 10 0", "10 nan 10 0"), 16, "a coordinate 'nan' is not a finite number (Vertices record 8)"},
      {"count.mesh", replace(good, "Vertices\n8", "Vertices\n80000"), 8, "80000 records do not fit in the rest of the file"},
      {"short.mesh", replace(good, "2 3 5 8 2\nEnd", "2 3 5"), 37, "Tetrahedra: the file ends in record 5"},
      {"no_end.mesh", replace(good, "End\n", ""), 37, "the file ends without End (cut short?)"},
      {"twice.mesh", replace(good, "End", "Vertices 0\nEnd"), 37, "a second Vertices section"},
      {"triangles_twice.mesh", replace(good, "Tetrahedra\n5", "Triangles\n0\nTetrahedra\n5"), 30, "a second Triangles section"},
      {"triangles_only.mesh", good.substr(0, good.find("Tetrahedra")) + "End\n", 30, "no Tetrahedra"},
  };
  test::expect_each_refused(cases, [](const auto& p) { read_tet_mesh(p); });
}

TEST(ReadTetgen, NodeEleAndFaceFilesFromOne) {
  const TetMesh a = read_tetgen(data("mesh/cube.1.node"));
  const TetMesh b = read_tetgen(data("mesh/cube.1.ele"));
  test::expect_test_cube(a);
  test::expect_same_elements(a, b);
  EXPECT_EQ(a.tet_group, (std::vector<int>{1, 1, 2, 2, 2}));  // the region attributes
  EXPECT_EQ(a.triangle_group, (std::vector<int>{4, 4, 3, 3}));  // the faces' markers 3 and 1
  EXPECT_EQ(a.group_names, (std::map<int, std::string>{{3, "surface_1"}, {4, "surface_3"}}));
  EXPECT_EQ(a.group_file_tags, (std::map<int, int>{{3, 1}, {4, 3}}));  // the markers in the .face
  EXPECT_EQ(a.file_node_ids.front(), 1);
  EXPECT_EQ(a.file_tet_ids, (std::vector<long long>{1, 2, 3, 4, 5}));
}

TEST(ReadTetgen, NumberedFromZeroWithoutAttributesOrFaces) {
  const TetMesh m = read_tet_mesh(data("mesh/cube0.ele"));
  test::expect_test_cube(m);
  EXPECT_EQ(m.tet_group, std::vector<int>(5, 0));
  EXPECT_TRUE(m.triangles.empty());
  EXPECT_EQ(m.file_node_ids.front(), 0);
}

TEST(ReadTetgen, MalformedFilesAreRefusedWithTheirLine) {
  const std::string node = slurp(data("mesh/cube0.node")), ele = slurp(data("mesh/cube0.ele"));
  const std::string node1 = slurp(data("mesh/cube.1.node")), ele1 = slurp(data("mesh/cube.1.ele")),
                    face1 = slurp(data("mesh/cube.1.face"));
  struct Case {
    std::string name, node, ele, face;  // face "": no .face
    const char* bad;                    // the file the error names: "node", "ele" or "face"
    int line;
    std::string needle;
  };
  const std::vector<Case> cases = {
      {"plane", replace(node, "8 3 0 0", "8 2 0 0"), ele, "", "node", 1, "dimension 2: a plane mesh holds no tetrahedra"},
      {"values", replace(node, "3 10 10 0", "3 10 10"), ele, "", "node", 5, "a point (number, x, y, z, 0 attributes, 0 marker): 3 values, expected 4"},
      {"order", replace(node, "3 10 10 0", "4 10 10 0"), ele, "", "node", 5, "point 4 where 3 comes next"},
      {"base", replace(node, "0 0 0 0", "2 0 0 0"), ele, "", "node", 2, "the first point's number 2 is out of range [0, 1]"},
      {"nan", replace(node, "7 10 10 10", "7 10 inf 10"), ele, "", "node", 9, "a coordinate 'inf' is not a finite number"},
      {"count", replace(node, "8 3 0 0", "800000 3 0 0"), ele, "", "node", 1, "800000 points do not fit"},
      {"short", node.substr(0, node.find("7 10 10 10")), ele, "", "node", 9, "the file ends before point 8 of 8 (cut short?)"},
      {"second_order", node, replace(ele, "5 4 0", "5 10 0"), "", "ele", 1, "10 nodes per tetrahedron: the physical mesh is 4-node tets only"},
      {"range", node, replace(ele, "0 0 1 2 4", "0 0 1 2 8"), "", "ele", 2, "a node number 8 is out of range [0, 7] (the .node's numbers)"},
      {"no_tets", node, "0 4 0\n", "", "ele", 1, "0 tetrahedra"},
      {"region", node1, replace(ele1, "1  2  3  5    1", "1  2  3  5    -1"), "", "ele", 3, "the region attribute -1 is not a group tag"},
      {"fraction", node1, replace(ele1, "1  2  3  5    1", "1  2  3  5    1.5"), "", "ele", 3, "the region attribute 1.5 is not a group tag"},
      {"face_range", node1, ele1, replace(face1, "1  3  2  3", "1  3  9  3"), "face", 3, "a node number 9 is out of range [1, 8]"},
      {"face_values", node1, ele1, replace(face1, "1  3  2  3  -1  1", "1  3"), "face", 3, "a face (number, 3 nodes, 1 marker): 3 values, expected 5 to 7"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const auto n = write_temp(c.name + ".node", c.node);
    const auto e = write_temp(c.name + ".ele", c.ele);
    if (!c.face.empty()) write_temp(c.name + ".face", c.face);
    const std::string bad = c.bad;
    const auto named = bad == "node" ? n : bad == "ele" ? e : std::filesystem::path(n).replace_extension(".face");
    expect_input_error([&] { read_tet_mesh(e); }, named, c.line, c.needle);
  }
}

TEST(ReadTetgen, AMissingFileBesideIsNamed) {
  const auto n = write_temp("lonely.node", slurp(data("mesh/cube0.node")));
  try {
    read_tet_mesh(n);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lonely.node: no lonely.ele beside it"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ebh
