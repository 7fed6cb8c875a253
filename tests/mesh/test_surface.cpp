// OBJ reader and boundary extraction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>

#include "mesh/boundary.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/surface.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

using test::data;
using test::expect_input_error;
using test::replace;
using test::write_temp;

/// Volume enclosed by a closed surface (divergence theorem): positive when it faces outward.
double enclosed_volume(const SurfaceMesh& s) {
  double v = 0;
  for (const Tri& t : s.triangles) v += dot(s.vertices[t[0]], cross(s.vertices[t[1]], s.vertices[t[2]])) / 6.0;
  return v;
}

/// Closed, consistently oriented 2-manifold: each directed edge once, and its reverse once.
void expect_closed_oriented(const SurfaceMesh& s) {
  std::multiset<std::pair<int, int>> directed;
  for (const Tri& t : s.triangles)
    for (int k = 0; k < 3; ++k) directed.insert({t[k], t[(k + 1) % 3]});
  for (const auto& e : directed) {
    EXPECT_EQ(directed.count(e), 1u) << "edge " << e.first << "-" << e.second << " repeated";
    EXPECT_EQ(directed.count({e.second, e.first}), 1u) << "edge " << e.first << "-" << e.second << " is a border";
  }
}

// Every triangle's normal points away from the centre of the convex body.
void expect_outward(const SurfaceMesh& s, const Vec3d& centre) {
  for (const Tri& t : s.triangles) {
    const Vec3d n = cross(s.vertices[t[1]] - s.vertices[t[0]], s.vertices[t[2]] - s.vertices[t[0]]);
    const Vec3d c = (s.vertices[t[0]] + s.vertices[t[1]] + s.vertices[t[2]]) / 3.0;
    EXPECT_GT(dot(n, c - centre), 0.0);
  }
}

/// The unit cube split into 6 tets around its diagonal 0-7 (corner c = x + 2y + 4z).
TetMesh kuhn_cube() {
  TetMesh m;
  for (int c = 0; c < 8; ++c) m.vertices.push_back({double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)});
  m.tets = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7}, {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  for (Tet& t : m.tets)
    if (signed_volume(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], m.vertices[t[3]]) < 0) std::swap(t[1], t[2]);
  return m;
}

TEST(ReadObj, EveryFaceForm) {
  const SurfaceMesh s = read_obj(data("mesh/cube.obj"));
  ASSERT_EQ(s.vertices.size(), 8u);
  ASSERT_EQ(s.triangles.size(), 12u);  // 6 quads, fan-triangulated
  EXPECT_EQ(s.vertices[7], Vec3d(10, 10, 10));
  // the first quad "1 3 4 2" fans into (0 2 3) and (0 3 1)
  EXPECT_EQ(s.triangles[0], (Tri{0, 2, 3}));
  EXPECT_EQ(s.triangles[1], (Tri{0, 3, 1}));
  // the fifth face uses negative indices: "-8 -4 -2 -6" -> 0 4 6 2
  EXPECT_EQ(s.triangles[8], (Tri{0, 4, 6}));
  expect_closed_oriented(s);
  // each term is divided by 6 and rounded: a few ulps of 1000
  EXPECT_NEAR(enclosed_volume(s), 1000.0, 1e-9);
}

TEST(ReadObj, ForwardReference) {
  const SurfaceMesh s = read_obj(write_temp("fwd.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"));
  EXPECT_EQ(s.triangles.size(), 1u);
}

/// The cube's triangles as an STL: ASCII (its facets' normals as a writer gives them, unused) or
/// binary, with an 80-byte header of `header`.
std::string cube_stl(bool binary, const std::string& header = "ebh test") {
  const SurfaceMesh cube = read_obj(data("mesh/cube.obj"));
  std::string out;
  if (!binary) {
    out = "solid cube\n";
    for (const Tri& t : cube.triangles) {
      out += "  facet normal 0 0 1\n    outer loop\n";
      for (int v : t) {
        const Vec3d& p = cube.vertices[v];
        out += "      vertex " + std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + "\n";
      }
      out += "    endloop\n  endfacet\n";
    }
    return out + "endsolid cube\n";
  }
  out = header;
  out.resize(80, ' ');
  const auto count = static_cast<std::uint32_t>(cube.triangles.size());
  out.append(reinterpret_cast<const char*>(&count), 4);
  for (const Tri& t : cube.triangles) {
    float f[12] = {0, 0, 1};
    for (int k = 0; k < 3; ++k) {
      const Vec3d& p = cube.vertices[t[k]];
      f[3 + 3 * k] = static_cast<float>(p.x), f[4 + 3 * k] = static_cast<float>(p.y), f[5 + 3 * k] = static_cast<float>(p.z);
    }
    out.append(reinterpret_cast<const char*>(f), sizeof f);
    out.append(2, '\0');  // the attribute
  }
  return out;
}

// An STL repeats each corner in every facet: read, the cube's 8 corners are 8 vertices again and
// its 12 facets the OBJ's triangles, in order and with their corners' order; a binary STL whose header starts with "solid" (some
// writers do) is read as binary, by its size.
TEST(ReadStl, AsciiAndBinaryAreTheObjsCube) {
  const SurfaceMesh obj = read_obj(data("mesh/cube.obj"));
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"ascii.stl", cube_stl(false)}, {"binary.stl", cube_stl(true)}, {"solid_header.STL", cube_stl(true, "solid cube")}}) {
    SCOPED_TRACE(name);
    const SurfaceMesh s = read_surface(write_temp(name, text));
    EXPECT_EQ(s.vertices.size(), 8u);  // numbered in order of first appearance, not the OBJ's
    ASSERT_EQ(s.triangles.size(), obj.triangles.size());
    for (std::size_t f = 0; f < s.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(s.vertices[s.triangles[f][k]], obj.vertices[obj.triangles[f][k]]) << f;
  }
}

struct BadStl : ::testing::Test {
  void expect(const std::string& text, int line, const std::string& needle) {
    const auto p = write_temp("bad.stl", text);
    expect_input_error([&] { read_stl(p); }, p, line, needle);
  }
  /// Without a line: the binary form's errors name the file alone.
  void expect(const std::string& text, const std::string& needle) {
    const auto p = write_temp("bad.stl", text);
    try {
      read_stl(p);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(p.string() + ": ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  }
};
TEST_F(BadStl, BinaryCutShort) {
  const std::string full = cube_stl(true);
  expect(full.substr(0, full.size() - 7), "nor a binary one (677 bytes, where its count of 12 facets needs 684): cut short");
}
TEST_F(BadStl, BinaryCutShortWithASolidHeader) {
  const std::string full = cube_stl(true, "solid cube");
  expect(full.substr(0, full.size() - 7), "starts with 'solid' but holds NUL bytes: a binary STL whose size (677 bytes)");
}
TEST_F(BadStl, BinaryNotFinite) {
  std::string s = cube_stl(true);
  const float nan = std::nanf("");
  s.replace(84 + 50 * 3 + 12, 4, reinterpret_cast<const char*>(&nan), 4);
  expect(s, "facet 3 (a binary STL's) has a corner that is not a finite number");
}
TEST_F(BadStl, AsciiKeyword) {
  expect(replace(cube_stl(false), "    outer loop\n", "    outer lop\n"), 3, "expected 'loop' after 'outer', got 'lop'");
}
TEST_F(BadStl, AsciiTwoVertices) {
  const std::string text = cube_stl(false);
  const auto third = text.find("      vertex", text.find("      vertex", text.find("      vertex") + 1) + 1);
  expect(text.substr(0, third) + text.substr(text.find('\n', third) + 1), 6, "expected 'vertex' (a facet has 3), got 'endloop'");
}
TEST_F(BadStl, AsciiNoEndsolid) {
  const std::string text = cube_stl(false);
  expect(text.substr(0, text.find("endsolid")), 1, "the file ends inside the solid begun here (no 'endsolid')");
}
TEST_F(BadStl, NotAnStl) { expect("ply\nformat ascii 1.0\n", "not an STL"); }
TEST_F(BadStl, NoFacets) { expect("solid empty\nendsolid empty\n", "no facets"); }

struct BadObj : ::testing::Test {
  void expect(const std::string& text, int line, const std::string& needle) {
    const auto p = write_temp("bad.obj", text);
    expect_input_error([&] { read_obj(p); }, p, line, needle);
  }
};
const std::string kTri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

TEST_F(BadObj, TwoCorners) { expect(kTri + "f 1 2\n", 4, "a face needs at least 3 vertices, got 2"); }
TEST_F(BadObj, IndexOutOfRange) { expect(kTri + "# c\nf 1 2 9\n", 5, "vertex index 9 is out of range (the file has 3 vertices)"); }
TEST_F(BadObj, RepeatedVertex) { expect(kTri + "f 1 1 2\n", 4, "the face names vertex 1 twice (a degenerate face)"); }
TEST_F(BadObj, RepeatedVertexByRelativeIndex) { expect(kTri + "f 1 2 3 -2\n", 4, "the face names vertex 2 twice"); }
TEST_F(BadObj, IndexBeyondEveryCount) {
  expect(kTri + "f 1 2 99999999999999999999/1\n", 4, "vertex index 99999999999999999999 is out of range");
  expect(kTri + "f 1 2 -99999999999999999999\n", 4, "relative vertex index -99999999999999999999 reaches before the first vertex");
}
TEST_F(BadObj, IndexZero) { expect(kTri + "f 0 1 2\n", 4, "vertex index 0 is invalid"); }
TEST_F(BadObj, RelativeBeforeFirst) { expect(kTri + "f 1 2 -4\n", 4, "relative vertex index -4 reaches before the first vertex"); }
TEST_F(BadObj, Garbage) { expect(kTri + "f 1 2 3x\n", 4, "expected a face corner like 3, 3/1, 3/1/2 or 3//2, got '3x'"); }
TEST_F(BadObj, TooManySlashes) { expect(kTri + "f 1 2 3/1/1/1\n", 4, "got '3/1/1/1'"); }
TEST_F(BadObj, NanCoordinate) { expect("v 0 nan 0\n", 1, "y coordinate 'nan' is not a finite number"); }
TEST_F(BadObj, MissingCoordinate) { expect("v 0 0\r\n", 1, "expected z coordinate, found the end of the line"); }
TEST_F(BadObj, NoFaces) { expect(kTri, 4, "no faces"); }

// ---- merging coincident vertices (a triangle soup) ----------------------------------------------
TEST(MergeCoincident, TriangleSoupSharesEdges) {
  // the unit square's two triangles, each with its own corners; 0 and -0 are one position
  SurfaceMesh s{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-0.0, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {3, 4, 5}}};
  const MergedVertices m = merge_coincident_surface_vertices(s);
  EXPECT_EQ(m.vertices, 2);
  EXPECT_EQ(m.faces, 0);
  EXPECT_EQ(s.vertices, (std::vector<Vec3d>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
  EXPECT_FALSE(std::signbit(s.vertices[0].x));  // the first of a position stays, to the bit
  EXPECT_EQ(s.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}}));
}
TEST(MergeCoincident, FacesLeftWithARepeatedVertexAreRemoved) {
  SurfaceMesh s{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}}, {{0, 1, 2}, {0, 1, 3}, {3, 2, 0}}};
  const MergedVertices m = merge_coincident_surface_vertices(s);
  EXPECT_EQ(m.vertices, 1);
  EXPECT_EQ(m.faces, 1);
  EXPECT_EQ(s.vertices.size(), 3u);
  EXPECT_EQ(s.triangles, (std::vector<Tri>{{0, 1, 2}, {1, 2, 0}}));
}
// A seam exported twice, its copies a round-off apart (1e-9 here): one vertex within the reach,
// the first kept; an exact copy of a merged vertex follows it; vertices farther apart than the
// reach (a real gap of 1e-3) stay two, whatever cell of the reach's grid they fall in.
TEST(MergeCoincident, ASeamARoundOffApartIsWeldedWithinTheReach) {
  const double e = 1e-9;
  SurfaceMesh s{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {e, 0, 0}, {1, 1 + e, 0}, {0, 1, 0}, {e, 0, 0}, {0, 1e-3, 0}},
                {{0, 1, 2}, {3, 4, 5}, {6, 4, 7}}};
  const MergedVertices none = [s]() mutable { return merge_coincident_surface_vertices(s); }();
  EXPECT_EQ(none.vertices, 1);  // exactly, the two copies at (e, 0, 0) alone
  EXPECT_EQ(none.near, 0);
  const MergedVertices m = merge_coincident_surface_vertices(s, 1e-6);
  EXPECT_EQ(m.vertices, 3);  // (e, 0, 0) twice into 0, (1, 1 + e, 0) into 2
  EXPECT_EQ(m.near, 2);
  EXPECT_EQ(m.faces, 0);
  EXPECT_EQ(s.vertices, (std::vector<Vec3d>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 1e-3, 0}}));
  EXPECT_EQ(s.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}, {0, 2, 4}}));
  // Across a cell boundary of the reach's grid: -1e-7 and +1e-7 lie in neighbouring cells.
  SurfaceMesh across{{{-1e-7, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1e-7, 0, 0}, {1, 1, 0}}, {{0, 1, 2}, {3, 4, 1}}};
  EXPECT_EQ(merge_coincident_surface_vertices(across, 1e-6).near, 1);
  EXPECT_EQ(across.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 3, 1}}));
}
// Two squares side by side, the right one's left border a copy of the left one's right border
// `gap` away: each border's edge lies along the other. A hole's rim (the squares joined) has none,
// nor has a closed surface.
TEST(UnweldedSeam, TwoBordersAlongEachOther) {
  const auto squares = [](double gap) {
    return SurfaceMesh{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {1 + gap, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1 + gap, 1, 0}},
                       {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}}};
  };
  const UnweldedSeam seam = unwelded_seam(squares(0.01));
  EXPECT_EQ(seam.edges, 2);
  EXPECT_NEAR(seam.gap, 0.01, 1e-15);  // (1 + 0.01) - 1 in doubles
  EXPECT_EQ(unwelded_seam(squares(0.5)).edges, 0);  // half an edge apart: two patches, no seam
  SurfaceMesh joined = squares(0);
  merge_coincident_surface_vertices(joined);
  EXPECT_EQ(unwelded_seam(joined).edges, 0);
  EXPECT_EQ(unwelded_seam(read_obj(data("mesh/cube.obj"))).edges, 0);
}
// Two patches side by side: the left one's edge from (1, 0) to (1, 2) runs past the right one's
// vertex at (1, 1), a T-junction; off the line by 1% of the edge it is an opening, not one; with the
// long edge split at it, the patches are joined and none is left.
TEST(TJunctions, AVertexInsideAnotherFacesEdge) {
  SurfaceMesh s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 2, 0}, {0, 2, 0}, {1, 1, 0}, {2, 0, 0}, {2, 2, 0}};
  s.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 5, 4}, {5, 6, 4}, {4, 6, 2}};
  EXPECT_EQ(t_junctions(s), 1);
  SurfaceMesh off = s;
  off.vertices[4].x += 0.02;
  EXPECT_EQ(t_junctions(off), 0);
  SurfaceMesh joined = s;
  joined.triangles = {{0, 1, 4}, {0, 4, 2}, {0, 2, 3}, {1, 5, 4}, {5, 6, 4}, {4, 6, 2}};
  EXPECT_EQ(t_junctions(joined), 0);
}

TEST(MergeCoincident, NoCoincidentVerticesLeavesTheSurfaceAlone) {
  SurfaceMesh s = read_obj(data("mesh/cube.obj"));
  const SurfaceMesh before = s;
  const MergedVertices m = merge_coincident_surface_vertices(s);
  EXPECT_EQ(m.vertices, 0);
  EXPECT_EQ(s.vertices, before.vertices);
  EXPECT_EQ(s.triangles, before.triangles);
}

// A flat face that fills a T-junction closes the surface: it stays (removing it would open three
// edges). Flat faces laid along an edge of a closed surface open it: they go.
TEST(FlatFaces, OnlyThoseThatDoNotCloseTheSurfaceAreRemoved) {
  // a tetrahedron A B C D whose face A B C is split at M, the middle of A B, with the flat A B M
  // filling the junction against face A B D
  const Vec3d A{0, 0, 0}, B{1, 0, 0}, C{0, 1, 0}, D{0, 0, 1}, M{0.5, 0, 0};
  SurfaceMesh t{{A, B, C, D, M}, {{0, 2, 4}, {4, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 4, 1}}};
  ASSERT_EQ(surface_edges(t.triangles).open, 0);
  const std::vector<Tri> before = t.triangles;
  EXPECT_EQ(remove_flat_surface_faces(t), 0);
  EXPECT_EQ(t.triangles, before);
  // the tetrahedron whole, with two flat faces on its edge A B: removed, and it is closed again
  SurfaceMesh e{{A, B, C, D, M, Vec3d{0.25, 0, 0}}, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 4, 1}, {0, 5, 4}}};
  ASSERT_GT(surface_edges(e.triangles).open, 0);
  EXPECT_EQ(remove_flat_surface_faces(e), 2);
  EXPECT_EQ(e.triangles.size(), 4u);
  EXPECT_EQ(surface_edges(e.triangles).open, 0);
}

// ---- OBJ lines: continuation, comments, polygons, not text -----------------------------------
TEST(ReadObj, ContinuedLineAndTrailingComments) {
  const SurfaceMesh s = read_obj(write_temp("cont.obj", "v 0 0 0\nv 1 0 \\\n 0\r\nv 0 1 0 # the third\nf 1 2 \\\r\n3 # one face\n"
                                                          "v 0 0 1\nf 1 2 4 #\n"));
  EXPECT_EQ(s.vertices, (std::vector<Vec3d>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
  EXPECT_EQ(s.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 1, 3}}));
}
TEST(ReadObj, ConvexPolygonsAreFanTriangulated) {
  // a hexagon, and a trapezoid of its first 4 corners
  const SurfaceMesh s = read_obj(write_temp("convex.obj", "v 2 0 0\nv 1 1.7 0\nv -1 1.7 0\nv -2 0 0\nv -1 -1.7 0\nv 1 -1.7 0\n"
                                                            "f 1 2 3 4 5 6\nf 1 2 3 4\n"));
  EXPECT_EQ(s.triangles.size(), 6u);
  EXPECT_EQ(s.triangles[3], (Tri{0, 4, 5}));
}
TEST_F(BadObj, ContinuedLineErrorNamesItsFirstLine) {
  expect(kTri + "f 1 \\\n2 x\nf 1 2 3\nf 1 2 9\n", 4, "got 'x'");
  expect(kTri + "f 1 \\\n2 3\nf 1 2 3\nf 1 2 9\n", 7, "vertex index 9 is out of range");
}
TEST_F(BadObj, ConcaveQuad) {
  // an arrowhead: corner 4 (vertex 4) points inward; the fan from vertex 1 would cover the notch
  expect("v 0 0 0\nv 2 1 0\nv 0 2 0\nv 1 1 0\n# an arrowhead\nf 1 2 3 4\n", 6,
         "a concave face of 4 vertices (it turns back at vertex 4): ebh splits a face into triangles around its first vertex");
}
TEST_F(BadObj, ConcavePolygonAfterForwardReferences) {
  expect("f 1 2 3 4 5\nv 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\n", 1, "a concave face of 5 vertices (it turns back at vertex 4)");
}
TEST_F(BadObj, Gzip) { expect(std::string("\x1f\x8b\x08\x08", 4) + "plain.obj", 1, "a gzip-compressed file, not a text OBJ"); }
TEST_F(BadObj, NulBytes) { expect(kTri + std::string("f 1 2 3\n\0\0\x01", 11), 5, "a NUL byte: a binary file, not a text OBJ"); }

TEST(Boundary, FiveTetCube) {
  const TetMesh m = read_msh(data("mesh/cube22.msh"));
  std::vector<int> to_volume;
  const SurfaceMesh s = extract_boundary(m, &to_volume);
  EXPECT_EQ(s.vertices.size(), 8u);
  EXPECT_EQ(s.triangles.size(), 12u);
  EXPECT_EQ(count_interior_faces(m.tets), 4);  // (4 * 5 - 12) / 2
  ASSERT_EQ(to_volume.size(), 8u);
  EXPECT_TRUE(std::is_sorted(to_volume.begin(), to_volume.end()));
  for (std::size_t i = 0; i < to_volume.size(); ++i) EXPECT_EQ(s.vertices[i], m.vertices[to_volume[i]]);
  expect_closed_oriented(s);
  expect_outward(s, {5, 5, 5});
  EXPECT_NEAR(enclosed_volume(s), 1000.0, 1e-9);  // each term divided by 6 and rounded: a few ulps
}

// The cube's 12 boundary triangles with 5 of them turned (an OBJ wound at random): the 5 are
// turned back, the surface is closed and outward again; a consistent surface is left as it is;
// two separate pieces each keep their own majority.
TEST(OrientConsistently, TurnsTheMinorityOfEachPiece) {
  const SurfaceMesh cube = extract_boundary(read_msh(data("mesh/cube22.msh")));
  SurfaceMesh mixed = cube;
  for (int f : {0, 3, 4, 8, 11}) std::swap(mixed.triangles[f][1], mixed.triangles[f][2]);
  EXPECT_EQ(orient_consistently(mixed.triangles), 5u);
  EXPECT_EQ(mixed.triangles, cube.triangles);
  expect_closed_oriented(mixed);
  EXPECT_EQ(orient_consistently(mixed.triangles), 0u);
  // a second cube beside it, wound inward (all 12 turned): its own majority is kept
  SurfaceMesh two = cube;
  const int nv = static_cast<int>(cube.vertices.size());
  for (const Vec3d& p : cube.vertices) two.vertices.push_back(p + Vec3d{20, 0, 0});
  for (Tri t : cube.triangles) two.triangles.push_back({t[0] + nv, t[2] + nv, t[1] + nv});
  const std::vector<Tri> inward = two.triangles;
  std::swap(two.triangles[13][1], two.triangles[13][2]);  // one of the second's wound outward
  EXPECT_EQ(orient_consistently(two.triangles), 1u);
  EXPECT_EQ(two.triangles, inward);
}

TEST(Boundary, SixTetCubeAnyOrientation) {
  TetMesh m = kuhn_cube();
  const FaceCounts c = count_faces(m.tets);
  EXPECT_EQ(c.boundary, 12);
  EXPECT_EQ(c.interior, 6);
  EXPECT_EQ(c.nonmanifold, 0);
  const SurfaceMesh s = extract_boundary(m);
  expect_closed_oriented(s);
  expect_outward(s, {0.5, 0.5, 0.5});
  // negatively oriented tets still give an outward surface
  for (Tet& t : m.tets) std::swap(t[1], t[2]);
  const SurfaceMesh flipped = extract_boundary(m);
  expect_closed_oriented(flipped);
  expect_outward(flipped, {0.5, 0.5, 0.5});
}

TEST(Boundary, CompactsUnusedVertices) {
  TetMesh m = kuhn_cube();
  m.vertices.insert(m.vertices.begin(), Vec3d{9, 9, 9});  // vertex 0 is used by no tet
  for (Tet& t : m.tets)
    for (int& v : t) ++v;
  std::vector<int> to_volume;
  const SurfaceMesh s = extract_boundary(m, &to_volume);
  EXPECT_EQ(s.vertices.size(), 8u);
  EXPECT_EQ(to_volume.front(), 1);
}

// How a surface closes up: a tet's four faces close; three leave a rim of three open edges; two
// faces apart share nothing; three faces on one edge make it non-manifold.
TEST(SurfaceEdges, OpenNonManifoldAndLooseFaces) {
  const std::vector<Tri> tet = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  SurfaceEdges e = surface_edges(tet);
  EXPECT_EQ(e.open, 0);
  EXPECT_EQ(e.nonmanifold, 0);
  EXPECT_EQ(e.loose_faces, 0);
  e = surface_edges({tet[0], tet[1], tet[2]});
  EXPECT_EQ(e.open, 3);
  EXPECT_EQ(e.loose_faces, 0);
  e = surface_edges({{0, 1, 2}, {3, 4, 5}});
  EXPECT_EQ(e.open, 6);
  EXPECT_EQ(e.loose_faces, 2);
  e = surface_edges({{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  EXPECT_EQ(e.nonmanifold, 1);
  EXPECT_EQ(e.open, 6);
}

}  // namespace
}  // namespace ebh
