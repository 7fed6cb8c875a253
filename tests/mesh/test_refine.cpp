// Uniform 1 -> 8 refinement (mesh/refine.hpp) on the reference tet, a box and a committed scene's mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mesh/boundary.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/lumped_masses.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/refine.hpp"

namespace ebh {
namespace {

/// The bound on a child's mean ratio relative to its parent's (mesh/refine.hpp).
constexpr double kQualityFraction = 0.7;

double tet_volume(const TetMesh& m, const Tet& t) {
  return signed_volume(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], m.vertices[t[3]]);
}

double mean_ratio(const TetMesh& m, const Tet& t) {
  return tet_mean_ratio(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], m.vertices[t[3]]);
}

TetMesh committed(const std::string& name) {
  TetMesh m = read_msh(std::filesystem::path(EBH_SOURCE_DIR) / "scenarios" / (name + ".msh"));
  remove_unreferenced_vertices(m);
  orient_tets(m);
  return m;
}

/// Each child positive with 1/8 of its parent's volume (to round-off); worst_fraction: the smallest
/// ratio of a child's mean ratio to its parent's.
void expect_children_of_parents(const TetMesh& parent, const TetMesh& child, double* worst_fraction) {
  ASSERT_EQ(child.tets.size(), 8 * parent.tets.size());
  *worst_fraction = 1;
  for (std::size_t t = 0; t < parent.tets.size(); ++t) {
    const double v = tet_volume(parent, parent.tets[t]);
    const double q = mean_ratio(parent, parent.tets[t]);
    double sum = 0;
    for (std::size_t c = 8 * t; c < 8 * t + 8; ++c) {
      const double vc = tet_volume(child, child.tets[c]);
      ASSERT_GT(vc, 0) << "child " << c << " of tet " << t;
      // Exact arithmetic gives v / 8; the midpoints and the determinant round at ~1e-16 of the
      // tet's size cubed, far below 1e-9 of its volume for any tet validate_mesh accepts.
      EXPECT_NEAR(vc, v / 8, 1e-9 * v) << "child " << c << " of tet " << t;
      sum += vc;
      *worst_fraction = std::min(*worst_fraction, mean_ratio(child, child.tets[c]) / q);
    }
    EXPECT_NEAR(sum, v, 1e-12 * v) << "tet " << t;
  }
}

TEST(Refine, ReferenceTetEveryDiagonalIsPositive) {
  // Stretch the reference tet along each axis in turn so that each of the three diagonals is the
  // shortest once; every child must stay positive.
  for (int axis = 0; axis < 3; ++axis) {
    TetMesh m;
    m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (Vec3d& p : m.vertices) (axis == 0 ? p.x : axis == 1 ? p.y : p.z) *= 3.0;
    m.tets = {{0, 1, 2, 3}};
    m.tet_group = {0};
    const TetMesh r = refine_tet_mesh(m);
    ASSERT_EQ(r.vertices.size(), 10u);
    double fraction = 0;
    expect_children_of_parents(m, r, &fraction);
  }
}

TEST(Refine, ShortestDiagonalTiesGoToTheSmallerIndices) {
  // The regular-ish unit cube corner tet ties two diagonals; the refinement must not depend on
  // the order of the parent's corners beyond the vertex indices: refining twice gives the same bits.
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}};
  const TetMesh a = refine_tet_mesh(m), b = refine_tet_mesh(m);
  EXPECT_EQ(a.tets, b.tets);
  // Diagonals m01-m23, m02-m13, m03-m12 all have length^2 0.75 here: the first by index, m01-m23
  // (vertices 4 and 9), is the one chosen.
  for (int c = 4; c < 8; ++c) {
    EXPECT_EQ(a.tets[c][0], 4);
    EXPECT_EQ(a.tets[c][1], 9);
  }
}

TEST(Refine, CommittedMeshKeepsVolumeMassOrientationAndQuality) {
  const TetMesh m = committed("tube");
  const TetMesh r = refine_tet_mesh(m);
  double fraction = 0;
  expect_children_of_parents(m, r, &fraction);
  // The corners keep their parent's ratio; the octahedron's tets around the shortest diagonal
  // reach 0.78 of it on this mesh (0.76 to 0.79 on the four committed meshes over two levels): 0.7
  // leaves room for compiler differences in the last bits of the ratio, not for a worse rule.
  EXPECT_GE(fraction, kQualityFraction);
  const MeshReport before = validate_mesh(m), after = validate_mesh(r);
  EXPECT_FALSE(after.fatal());
  EXPECT_GE(after.quality_worst, kQualityFraction * before.quality_worst);
  EXPECT_EQ(after.boundary_faces, 4 * before.boundary_faces);
  // Masses stay physical: density * volume, the same total.
  double m0 = 0, m1 = 0;
  for (double x : lumped_masses(m, 1000)) m0 += x;
  for (double x : lumped_masses(r, 1000)) m1 += x;
  EXPECT_NEAR(m1, m0, 1e-12 * m0);
  // The boundary is the old boundary split into 4: the same enclosed volume, 4x the triangles.
  EXPECT_EQ(extract_boundary(r).triangles.size(), 4 * extract_boundary(m).triangles.size());
}

TEST(Refine, CountsMatchTheRefinedMesh) {
  const TetMesh m = committed("tube");
  const TetMesh r1 = refine_tet_mesh(m), r2 = refine_tet_mesh(r1);
  for (const auto& [level, mesh] : {std::pair<int, const TetMesh*>{1, &r1}, {2, &r2}}) {
    const RefinedCounts c = refined_counts(m, level), direct = refined_counts(*mesh, 0);
    EXPECT_EQ(c.vertices, static_cast<std::int64_t>(mesh->vertices.size())) << "level " << level;
    EXPECT_EQ(c.tets, static_cast<std::int64_t>(mesh->tets.size()));
    EXPECT_EQ(c.triangles, static_cast<std::int64_t>(mesh->triangles.size()));
    EXPECT_EQ(c.edges, direct.edges);
    EXPECT_EQ(c.faces, direct.faces);
    EXPECT_EQ(c.boundary_faces, direct.boundary_faces);
  }
  EXPECT_EQ(refined_counts(m, 40).tets, std::numeric_limits<std::int64_t>::max());
}

TEST(Refine, EveryGroupOfAnElementGoesToItsChildren) {
  const TetMesh m = read_msh(std::filesystem::path(EBH_TEST_DATA_DIR) / "mesh" / "cube41_two_groups.msh");  // each tet also in 4, 2 triangles also in 6
  const TetMesh r = refine_tet_mesh(m);
  std::vector<std::pair<int, int>> tets, triangles;
  for (int c = 0; c < 40; ++c) tets.push_back({c, 4});
  for (int c = 0; c < 8; ++c) triangles.push_back({c, 6});
  EXPECT_EQ(r.tet_more_groups, tets);
  EXPECT_EQ(r.triangle_more_groups, triangles);
}

TEST(Refine, GroupsCarryOverAsRefinedSurfaces) {
  const TetMesh m = committed("tube");
  const TetMesh r = refine_tet_mesh(m);
  EXPECT_EQ(r.group_names, m.group_names);
  ASSERT_EQ(r.triangles.size(), 4 * m.triangles.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f)
    for (std::size_t c = 4 * f; c < 4 * f + 4; ++c) ASSERT_EQ(r.triangle_group[c], m.triangle_group[f]);
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    for (std::size_t c = 8 * t; c < 8 * t + 8; ++c) ASSERT_EQ(r.tet_group[c], m.tet_group[t]);
  // Each child triangle is made of its parent's corners and the midpoints of its edges, so a
  // group's vertices afterwards are its old ones and the midpoints of its triangles' edges.
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    const auto [a, b, c] = m.triangles[f];
    const Tri& corner_a = r.triangles[4 * f];
    const Tri& middle = r.triangles[4 * f + 3];
    ASSERT_EQ(corner_a[0], a);
    EXPECT_EQ(r.triangles[4 * f + 1][1], b);
    EXPECT_EQ(r.triangles[4 * f + 2][2], c);
    EXPECT_EQ(r.vertices[middle[0]], 0.5 * (m.vertices[a] + m.vertices[b])) << "triangle " << f;
    EXPECT_EQ(r.vertices[middle[1]], 0.5 * (m.vertices[b] + m.vertices[c])) << "triangle " << f;
    EXPECT_EQ(r.vertices[middle[2]], 0.5 * (m.vertices[c] + m.vertices[a])) << "triangle " << f;
  }
  // Old vertices keep their indices and bits.
  for (std::size_t v = 0; v < m.vertices.size(); ++v) ASSERT_EQ(r.vertices[v], m.vertices[v]);
}

TEST(Refine, TriangleOffTheTetsIsKept) {
  // cube22.msh lists its top face with the other diagonal than its tets': those two triangles are
  // not on the tets and stay as they are; the bottom's two are split.
  const TetMesh m = read_msh(std::filesystem::path(EBH_TEST_DATA_DIR) / "mesh" / "cube22.msh");
  ASSERT_EQ(m.triangles.size(), 4u);
  const TetMesh r = refine_tet_mesh(m);
  ASSERT_EQ(r.triangles.size(), 2 * 4 + 2u);
  EXPECT_EQ(refined_counts(m, 1).triangles, 10);
  EXPECT_EQ(refined_counts(m, 2).triangles, 2 * 16 + 2);
  EXPECT_EQ(r.triangles[8], m.triangles[2]);
  EXPECT_EQ(r.triangles[9], m.triangles[3]);
  EXPECT_EQ(static_cast<std::int64_t>(r.vertices.size()), refined_counts(m, 1).vertices);
}

TEST(Refine, BitForBitDeterministicAndWrittenIdentically) {
  const TetMesh m = committed("tube");
  EXPECT_EQ(msh22_text(refine_tet_mesh(m)), msh22_text(refine_tet_mesh(m)));
}

TEST(Refine, BoxMeshTwoLevels) {
  const TetMesh box = make_box_tets({0, 0, 0}, {0.02, 0.01, 0.01}, 4, 2, 2);
  const TetMesh r1 = refine_tet_mesh(box), r2 = refine_tet_mesh(r1);
  double f1 = 0, f2 = 0;
  expect_children_of_parents(box, r1, &f1);
  expect_children_of_parents(r1, r2, &f2);
  EXPECT_GE(f1, kQualityFraction);
  EXPECT_GE(f2, kQualityFraction);
  EXPECT_EQ(r2.tets.size(), 64 * box.tets.size());
}

}  // namespace
}  // namespace ebh
