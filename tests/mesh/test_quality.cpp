// Mesh validator: each defect is caught, orientation is fixed or rejected, quality is right.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mesh/boundary.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

TetMesh cube() { return read_msh(test::data("mesh/cube22.msh")); }

TEST(MeanRatio, RegularAndFlat) {
  const double s = 1.0 / std::sqrt(2.0);
  const Vec3d a{1, 0, -s}, b{-1, 0, -s}, c{0, 1, s}, d{0, -1, s};  // regular, edge 2
  const double q = signed_volume(a, b, c, d) > 0 ? tet_mean_ratio(a, b, c, d) : tet_mean_ratio(a, c, b, d);
  EXPECT_NEAR(q, 1.0, 1e-12);  // rounding in cbrt and the sums only
  EXPECT_EQ(tet_mean_ratio({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}), 0.0);  // flat
  EXPECT_EQ(tet_mean_ratio({0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}), 0.0);  // inverted
  // the corner tet of a unit cube: V = 1/6, sum of squared edges = 3 + 3 * 2 = 9
  EXPECT_NEAR(tet_mean_ratio({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}), 12.0 * std::cbrt(0.25) / 9.0, 1e-15);
}

/// A deformed mesh's inverted tets are counted against each tet's orientation at rest, whichever
/// sign that is: a vertex pushed through the opposite face inverts every tet it belongs to; a
/// flattened tet counts too; moving the whole mesh rigidly (a rotation) inverts none.
TEST(InvertedTets, CountedAgainstTheRestOrientation) {
  const TetMesh m = cube();
  const std::vector<Tet>& tets = m.tets;
  std::vector<Vec3d> x = m.vertices;
  const std::vector<signed char> sign = rest_signs(x, tets);
  EXPECT_EQ(count_inverted_tets(x, tets, sign), 0);
  std::vector<signed char> flipped(sign);
  for (signed char& s : flipped) s = static_cast<signed char>(-s);
  EXPECT_EQ(count_inverted_tets(x, tets, flipped), static_cast<int>(tets.size()));  // every one, the other way round
  std::vector<Vec3d> turned(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) turned[i] = {-x[i].y, x[i].x, x[i].z};  // 90 degrees about z
  EXPECT_EQ(count_inverted_tets(turned, tets, sign), 0);
  // Tet 0's first corner through the plane of the other three: tet 0 inverts (and maybe its neighbours).
  const Tet& t0 = tets[0];
  const Vec3d centroid = (x[t0[1]] + x[t0[2]] + x[t0[3]]) / 3.0;
  std::vector<Vec3d> pushed = x;
  pushed[t0[0]] = centroid + (centroid - x[t0[0]]);
  const int inverted = count_inverted_tets(pushed, tets, sign);
  EXPECT_GE(inverted, 1);
  EXPECT_LT(signed_volume(pushed[t0[0]], pushed[t0[1]], pushed[t0[2]], pushed[t0[3]]) * sign[0], 0.0);
  pushed[t0[0]] = centroid;  // flat
  EXPECT_GE(count_inverted_tets(pushed, tets, sign), 1);
  EXPECT_TRUE(inverted_or_flat(pushed[t0[0]], pushed[t0[1]], pushed[t0[2]], pushed[t0[3]], sign[0]));
  EXPECT_FALSE(inverted_or_flat(x[t0[0]], x[t0[1]], x[t0[2]], x[t0[3]], sign[0]));
}

/// Counts made elsewhere (a backend's, PhysicalStepReport::inverted) and counts of its own keep
/// one running most, whichever came first.
TEST(InvertedTets, RecordedCountsKeepTheMost) {
  const TetMesh m = cube();
  InvertedTets counted;
  EXPECT_EQ(counted.record(3), 3);
  EXPECT_EQ(counted.record(1), 1);
  EXPECT_EQ(counted.most, 3);
  EXPECT_EQ(counted.count(m.vertices, m.tets, m.vertices), 0);  // at rest
  EXPECT_EQ(counted.most, 3);
  EXPECT_EQ(counted.record(7), 7);
  EXPECT_EQ(counted.most, 7);
}

TEST(Validate, CleanCube) {
  const TetMesh m = cube();
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal()) << r.fatal_message(m);
  EXPECT_TRUE(r.warnings().empty());
  EXPECT_EQ(r.boundary_faces, 12);
  EXPECT_EQ(r.interior_faces, 4);
  // four corner tets (q = 12 cbrt(1/4) / 9 = 0.840) and one regular central tet (q = 1)
  const double corner = 12.0 * std::cbrt(0.25) / 9.0;
  EXPECT_NEAR(r.quality_worst, corner, 1e-12);  // rounding only
  EXPECT_NEAR(r.quality_mean, (4 * corner + 1) / 5, 1e-12);
}

// Two boxes of tets touching at one corner, then along one edge: pieces that share vertices but no
// face (a hinge the coupling alone holds). One box of several pieces sharing faces has none.
TEST(Validate, PiecesJoinedAtAVertexOrAnEdge) {
  const TetMesh box = make_box_tets({0, 0, 0}, {1, 1, 1}, 2, 2, 2);
  EXPECT_EQ(validate_mesh(box).jointed_pieces, 0);
  EXPECT_EQ(validate_mesh(box).first_joint_vertex, -1);
  const auto joined = [&box](const Vec3d& offset) {
    TetMesh m = box;
    const int n = static_cast<int>(box.vertices.size());
    for (const Vec3d& v : box.vertices) m.vertices.push_back(v + offset);
    for (Tet t : box.tets) {
      for (int& v : t) v += n;
      m.tets.push_back(t);
    }
    // the copy's vertices at the position of the box's: the box's own
    for (Tet& t : m.tets)
      for (int& v : t)
        for (int w = 0; w < n && v >= n; ++w)
          if (m.vertices[v] == m.vertices[w]) v = w;
    return m;
  };
  const MeshReport corner = validate_mesh(joined({1, 1, 1}));
  EXPECT_EQ(corner.jointed_pieces, 1);
  EXPECT_EQ(corner.joint_vertices, 1);
  EXPECT_EQ(corner.first_joint_vertex, 26);  // (1, 1, 1), the box's last vertex
  EXPECT_EQ(corner.joint_piece_tets, 48);
  const std::vector<std::string> w = corner.warnings();  // (and the copy's unused vertex at the corner)
  EXPECT_EQ(std::count_if(w.begin(), w.end(), [](const std::string& line) {
              return line.rfind("1 piece of the mesh touches the rest at vertices or edges only, sharing no face (1 vertex "
                                "shared; the first: vertex 26, where the smaller piece has 48 tets)", 0) == 0;
            }),
            1) << ::testing::PrintToString(w);
  const MeshReport edge = validate_mesh(joined({1, 1, 0}));
  EXPECT_EQ(edge.jointed_pieces, 1);
  EXPECT_EQ(edge.joint_vertices, 3);  // the edge x = y = 1 of the box, at its three grid points
  const MeshReport face = validate_mesh(joined({1, 0, 0}));
  EXPECT_EQ(face.jointed_pieces, 0);  // sharing the face x = 1: one piece
}

TEST(Validate, DegenerateTet) {
  TetMesh m = cube();
  m.vertices.push_back({5, 5, 0});  // coplanar with the bottom face
  m.tets.push_back({1, 4, 3, 8});   // three bottom corners and the new vertex: flat
  m.file_tet_ids.push_back(77);
  const MeshReport r = validate_mesh(m);
  EXPECT_EQ(r.degenerate_tets, std::vector<int>{5});
  EXPECT_TRUE(r.fatal());
  EXPECT_NE(r.fatal_message(m).find("degenerate (flat) tet, the first: tet 5 (element id 77)"), std::string::npos)
      << r.fatal_message(m);
  EXPECT_EQ(r.quality_worst, 0.0);
  EXPECT_EQ(r.worst_tet, 5);
}

TEST(Validate, InvertedTetIsMixedOrientation) {
  TetMesh m = cube();
  std::swap(m.tets[2][1], m.tets[2][2]);
  const MeshReport r = validate_mesh(m);
  EXPECT_EQ(r.inverted_tets, std::vector<int>{2});
  EXPECT_NE(r.fatal_message(m).find("1 inverted tet, the first: tet 2 (element id 22)"), std::string::npos);
  const Orientation o = orient_tets(m);
  EXPECT_EQ(o.kind, Orientation::Kind::Mixed);
  EXPECT_EQ(o.witness, 2);
  EXPECT_EQ(o.positive, 4);
  EXPECT_EQ(o.negative, 1);
  // only its vertex order differed: flipped, the mesh is whole
  EXPECT_FALSE(validate_mesh(m).fatal()) << validate_mesh(m).fatal_message(m);
  EXPECT_EQ(orientation_warning(o, m),
            "1 of 5 tets were negatively oriented (their vertex order differs from the others'), the first: tet 2 "
            "(element id 22); flipped them one by one");
  EXPECT_EQ(orient_tets(m).kind, Orientation::Kind::Positive);
}

/// A corner pushed through the opposite face turns its tet inside out among its neighbours:
/// flipping it makes its volume positive but leaves it on the centre tet's side of their shared
/// face, so the tangle is refused, not hidden.
TEST(Validate, FlippingDoesNotHideATangle) {
  TetMesh m = cube();
  ASSERT_EQ(m.file_node_ids[1], 7);  // the corner (0, 0, 0) of tet 0 (7 1000 3 250)
  m.vertices[1] = {5, 5, 5};         // beyond the face x + y + z = 10
  const Orientation o = orient_tets(m);
  EXPECT_EQ(o.kind, Orientation::Kind::Mixed);
  EXPECT_EQ(o.witness, 0);
  const MeshReport r = validate_mesh(m);
  ASSERT_TRUE(r.fatal());
  ASSERT_EQ(r.overlapping_tets.size(), 1u);
  EXPECT_EQ(r.overlapping_tets[0], (std::array<int, 2>{0, 4}));
}

TEST(Validate, AllNegativeIsFlipped) {
  TetMesh m = cube();
  for (Tet& t : m.tets) std::swap(t[0], t[3]);
  EXPECT_EQ(validate_mesh(m).inverted_tets.size(), 5u);
  const Orientation o = orient_tets(m);
  EXPECT_EQ(o.kind, Orientation::Kind::Flipped);
  EXPECT_FALSE(validate_mesh(m).fatal());
  EXPECT_EQ(orient_tets(m).kind, Orientation::Kind::Positive);
}

TEST(Validate, DuplicateElementIdsAreWarned) {
  TetMesh m = cube();
  EXPECT_EQ(validate_mesh(m).duplicate_tet_ids, 0);
  m.file_tet_ids[3] = m.file_tet_ids[1];  // element ids 21 twice
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal());
  EXPECT_EQ(r.duplicate_tet_ids, 1);
  ASSERT_EQ(r.warnings().size(), 1u);
  EXPECT_EQ(r.warnings()[0], "1 tet with an element id another tet has too, the first: element id 21 (a file's element "
                             "ids are unique: two files joined? the ids messages name are ambiguous)");
}

TEST(Validate, UnreferencedAndDuplicateVertices) {
  TetMesh m = cube();
  m.vertices.push_back(m.vertices[3]);  // vertex 8 duplicates vertex 3 and is used by no tet
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal());
  EXPECT_EQ(r.unreferenced_vertices, std::vector<int>{8});
  ASSERT_EQ(r.duplicate_vertices.size(), 1u);
  EXPECT_EQ(r.duplicate_vertices[0], (std::pair<int, int>{8, 3}));
  EXPECT_EQ(r.warnings().size(), 2u);
  EXPECT_EQ(remove_unreferenced_vertices(m), 1);
  EXPECT_EQ(m.vertices.size(), 8u);
  EXPECT_TRUE(validate_mesh(m).warnings().empty());
  // Counts in words: "1 vertex", "2 vertices".
  m.vertices.push_back({5, 5, 5});
  EXPECT_EQ(validate_mesh(m).warnings().at(0).rfind("1 vertex used by no tet", 0), 0u) << validate_mesh(m).warnings()[0];
  m.vertices.push_back({6, 6, 6});
  EXPECT_EQ(validate_mesh(m).warnings().at(0).rfind("2 vertices used by no tet", 0), 0u) << validate_mesh(m).warnings()[0];
}

// A near-flat tet (one corner 1e-4 of an edge above the opposite face) is warned, with the worst
// and its element id; the cube's own tets are not.
TEST(Validate, NearFlatTetsAreWarned) {
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 1e-4}};
  m.tets = {{0, 1, 2, 3}};
  m.file_tet_ids = {57};
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal());
  EXPECT_EQ(r.poor_tets, 1);
  ASSERT_EQ(r.warnings().size(), 1u);
  EXPECT_NE(r.warnings()[0].find("1 tet of mean ratio below 0.01, the worst"), std::string::npos) << r.warnings()[0];
  EXPECT_NE(r.warnings()[0].find("(tet 0 (element id 57))"), std::string::npos) << r.warnings()[0];
  EXPECT_EQ(validate_mesh(cube()).poor_tets, 0);
}

TEST(Validate, NonManifoldBoundaryEdge) {
  // two tets sharing only the edge 0-1
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}, {0, 0, -1}};
  m.tets = {{0, 1, 2, 3}, {0, 1, 4, 5}};
  for (Tet& t : m.tets)
    if (signed_volume(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], m.vertices[t[3]]) < 0) std::swap(t[1], t[2]);
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal());
  ASSERT_EQ(r.nonmanifold_edges.size(), 1u);
  EXPECT_EQ(r.nonmanifold_edges[0], (std::array<int, 2>{0, 1}));
}

TEST(Validate, NonFiniteCoordinate) {
  TetMesh m = cube();
  m.vertices[6].y = std::numeric_limits<double>::quiet_NaN();
  const MeshReport r = validate_mesh(m);
  EXPECT_EQ(r.nonfinite_vertices, std::vector<int>{6});
  EXPECT_NE(r.fatal_message(m).find("vertex 6 (node id 9)"), std::string::npos) << r.fatal_message(m);
  EXPECT_TRUE(std::isfinite(r.quality_mean));
}

TEST(Validate, IndexOutOfRangeAndRepeated) {
  TetMesh m = cube();
  m.tets.push_back({0, 1, 2, 99});
  m.tets.push_back({0, 1, 1, 2});
  const MeshReport r = validate_mesh(m);
  EXPECT_EQ(r.bad_index_tets, (std::vector<int>{5, 6}));
  EXPECT_NE(r.fatal_message(m).find("tet 5 uses vertices 0 1 2 99 of 8"), std::string::npos) << r.fatal_message(m);
}

TEST(Validate, FaceSharedByThreeTets) {
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {0.2, 0.2, 2}};
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}};
  const MeshReport r = validate_mesh(m);
  EXPECT_EQ(r.nonmanifold_faces, 3);
  EXPECT_TRUE(r.fatal());
}

TEST(Validate, ATetInsideAnotherSharingAFaceOverlapsIt) {
  // Tet 1 lies inside tet 0 and shares its bottom face: every face is shared by at most two tets
  // and every volume is positive, but the mesh counts that space (and its mass) twice.
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.2, 0.2, 0.2}, {0.2, 0.2, -0.5}};
  m.tets = {{0, 1, 2, 3}, {0, 1, 2, 4}};
  MeshReport r = validate_mesh(m);
  ASSERT_EQ(r.overlapping_tets.size(), 1u);
  EXPECT_EQ(r.overlapping_tets[0], (std::array<int, 2>{0, 1}));
  EXPECT_TRUE(r.fatal());
  EXPECT_NE(r.fatal_message(m).find("1 pair of tets on the same side of the face they share (one overlaps the other"),
            std::string::npos) << r.fatal_message(m);
  // The same face with the second tet below it: a valid mesh of two tets.
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 5}};
  r = validate_mesh(m);
  EXPECT_TRUE(r.overlapping_tets.empty());
  EXPECT_FALSE(r.fatal());
  // Both tets of negative volume (a mirrored file): still on opposite sides.
  for (Tet& t : m.tets) std::swap(t[0], t[3]);
  EXPECT_TRUE(validate_mesh(m).overlapping_tets.empty());
}

// A part of the volume listed twice (a second entity repeating the first's tets with their
// vertices in another order): refused naming both elements, not as faces shared three times.
TEST(Validate, ATetRepeatingAnothersVerticesIsNamed) {
  TetMesh m = cube();
  const std::size_t n = m.tets.size();
  for (std::size_t t = 0; t < 2; ++t) {
    const Tet& a = m.tets[t];
    m.tets.push_back({a[1], a[0], a[3], a[2]});  // an even permutation: the same orientation
    m.tet_group.push_back(0);
    m.file_tet_ids.push_back(900 + static_cast<long long>(t));
  }
  const MeshReport r = validate_mesh(m);
  ASSERT_EQ(r.repeated_tets.size(), 2u);
  EXPECT_EQ(r.repeated_tets[0], (std::array<int, 2>{static_cast<int>(n), 0}));
  EXPECT_TRUE(r.fatal());
  EXPECT_EQ(r.fatal_message(m).rfind("2 tets with the four vertices of another (in any order), the first: tet " +
                                         std::to_string(n) + " (element id 900) repeats tet 0 (element id " +
                                         std::to_string(m.file_tet_ids[0]) + ")",
                                     0),
            0u)
      << r.fatal_message(m);
  EXPECT_TRUE(validate_mesh(cube()).repeated_tets.empty());
}

// Two parts that share no node: side by side, or touching along a seam (an unmerged copy of the
// shared face), they are a mesh; one inside the other (a label meshed apart and appended) or half
// into it counts that space twice and is refused, naming a tet of each.
TEST(Validate, APartInsideAnotherIsRefused) {
  const TetMesh one = cube();
  const Vec3d lo = [&] {
    Vec3d l = one.vertices[0];
    for (const Vec3d& v : one.vertices) l = cwise_min(l, v);
    return l;
  }();
  const Vec3d hi = [&] {
    Vec3d h = one.vertices[0];
    for (const Vec3d& v : one.vertices) h = cwise_max(h, v);
    return h;
  }();
  const Vec3d size = hi - lo;
  auto two = [&](double scale, Vec3d shift) {
    TetMesh m = one;
    const int nv = static_cast<int>(one.vertices.size());
    for (const Vec3d& v : one.vertices) m.vertices.push_back(lo + scale * (v - lo) + shift);
    for (std::size_t t = 0; t < one.tets.size(); ++t) {
      const Tet& a = one.tets[t];
      m.tets.push_back({a[0] + nv, a[1] + nv, a[2] + nv, a[3] + nv});
      m.tet_group.push_back(0);
      m.file_tet_ids.push_back(500 + static_cast<long long>(t));
    }
    for (int v = 0; v < nv; ++v) m.file_node_ids.push_back(700 + v);
    return m;
  };
  EXPECT_FALSE(validate_mesh(two(1, {2 * size.x, 0, 0})).fatal());           // apart
  EXPECT_FALSE(validate_mesh(two(1, {size.x, 0, 0})).fatal());               // touching along a face
  const TetMesh inside = two(0.3, 0.35 * size);
  const MeshReport r = validate_mesh(inside);
  ASSERT_TRUE(r.fatal());
  EXPECT_EQ(r.part_inside_part[0], static_cast<int>(one.tets.size()));
  EXPECT_EQ(r.fatal_message(inside).rfind("two parts of the mesh overlap without sharing nodes: tet " +
                                              std::to_string(one.tets.size()) + " (element id 500) reaches inside tet ",
                                          0),
            0u)
      << r.fatal_message(inside);
  EXPECT_TRUE(validate_mesh(two(1, {0.5 * size.x, 0, 0})).fatal());  // half into it
  // A tenth into it (two organs segmented apart overlapping by a voxel): no tet centre inside, a
  // vertex: warned, naming a tet of each; touching along a face, shifted along it, the seam's
  // vertices lie on the other's face: nothing.
  const TetMesh thin = two(1, {0.9 * size.x, 0.3 * size.y, 0.3 * size.z});
  const MeshReport t = validate_mesh(thin);
  EXPECT_FALSE(t.fatal()) << t.fatal_message(thin);
  EXPECT_GE(t.parts_overlap[0], static_cast<int>(one.tets.size()));
  EXPECT_LT(t.parts_overlap[1], static_cast<int>(one.tets.size()));
  ASSERT_EQ(t.warnings().size(), 1u);
  EXPECT_EQ(t.warnings()[0].rfind("two parts of the mesh overlap slightly without sharing nodes: tet ", 0), 0u)
      << t.warnings()[0];
  const MeshReport seam = validate_mesh(two(1, {size.x, 0.3 * size.y, 0.3 * size.z}));
  EXPECT_FALSE(seam.fatal());
  EXPECT_EQ(seam.parts_overlap[0], -1);
  for (const std::string& w : validate_mesh(inside).warnings())  // refused: not warned as well
    EXPECT_EQ(w.find("overlap slightly"), std::string::npos) << w;
  // Among many parts, in the last of ten cubes side by side (every part is a container).
  TetMesh many = one;
  auto append = [&](double scale, Vec3d shift) {
    const int nv = static_cast<int>(many.vertices.size());
    for (const Vec3d& v : one.vertices) many.vertices.push_back(lo + scale * (v - lo) + shift);
    for (const Tet& a : one.tets) many.tets.push_back({a[0] + nv, a[1] + nv, a[2] + nv, a[3] + nv});
  };
  for (int k = 1; k < 10; ++k) append(1, {2.0 * k * size.x, 0, 0});
  EXPECT_FALSE(validate_mesh(many).fatal());
  append(0.3, Vec3d{18 * size.x, 0, 0} + 0.35 * size);
  EXPECT_GE(validate_mesh(many).part_inside_part[0], 10 * static_cast<int>(one.tets.size()));
}

TEST(Validate, EmptyMesh) {
  const MeshReport r = validate_mesh(TetMesh{});
  EXPECT_TRUE(r.fatal());
  EXPECT_EQ(r.fatal_message(TetMesh{}), "no tets");
}

}  // namespace
}  // namespace ebh
