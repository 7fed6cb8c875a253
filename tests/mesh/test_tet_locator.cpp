// Embedding points in a tet mesh: inside a tet its barycentric weights, outside the closest point of
// the boundary; the closest point on a triangle against a dense sampling of it.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "mesh/boundary.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/tet_locator.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

TetMesh cube() { return read_msh(test::data("mesh/cube22.msh")); }  // 0..10 on every axis, 5 tets

Vec3d embedded(const TetMesh& m, const TetEmbedding& e) {
  Vec3d q{};
  for (int k = 0; k < e.count; ++k) q += e.weight[k] * m.vertices[e.vertex[k]];
  return q;
}

TEST(ClosestOnTriangle, MatchesADenseSampling) {
  const Vec3d a{0, 0, 0}, b{4, 0, 0}, c{1, 3, 0};
  for (const Vec3d& p : {Vec3d{1, 1, 2}, Vec3d{-2, -1, 1}, Vec3d{6, -1, -1}, Vec3d{3, 3, 0.5}, Vec3d{0.5, 2, -3},
                         Vec3d{2, -5, 0}, Vec3d{1, 4, 1}}) {
    const auto w = closest_on_triangle(p, a, b, c);
    EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-15);  // 1 - v - w: one rounding
    for (double x : w) EXPECT_GE(x, 0.0);
    const double d = norm(w[0] * a + w[1] * b + w[2] * c - p);
    double best = INFINITY;  // every point of a 400 x 400 grid of the triangle
    for (int i = 0; i <= 400; ++i)
      for (int j = 0; i + j <= 400; ++j) {
        const double u = i / 400.0, v = j / 400.0;
        best = std::min(best, norm((1 - u - v) * a + u * b + v * c - p));
      }
    EXPECT_LE(d, best + 1e-12) << p.x << " " << p.y << " " << p.z;  // never farther than a sample (round-off)
    EXPECT_GT(d, best - 0.02) << p.x << " " << p.y << " " << p.z;  // the grid's spacing
  }
}

// Inside: the point itself. Outside: the closest point of the cube's surface (a point 3 above the
// top face pairs with the point right under it, one beyond an edge or a corner with the edge's or
// the corner's point), at the distance to it.
TEST(TetLocator, InsideExactOutsideTheClosestBoundaryPoint) {
  const TetMesh m = cube();
  const TetLocator locator(m);
  double error = -1;
  const Vec3d in{2, 3, 4};
  // round-off of weights times coordinates of 10 (a few ulps of 10: ~1e-15)
  EXPECT_LT(norm(embedded(m, locator.locate(in, error)) - in), 1e-14);
  EXPECT_LT(error, 1e-14);
  EXPECT_TRUE(locator.inside(in));
  EXPECT_TRUE(locator.inside({10, 10, 10}));  // a corner: on the mesh
  const struct {
    Vec3d p, closest;
  } outside[] = {{{3, 4, 13}, {3, 4, 10}}, {{-2, 5, 5}, {0, 5, 5}}, {{12, 5, 13}, {10, 5, 10}}, {{-1, -1, -1}, {0, 0, 0}}};
  for (const auto& o : outside) {
    const TetEmbedding e = locator.locate(o.p, error);
    // the same round-off, through the projection's divisions (distances up to ~3.5)
    EXPECT_LT(norm(embedded(m, e) - o.closest), 1e-12) << o.p.x << " " << o.p.y << " " << o.p.z;
    EXPECT_NEAR(error, norm(o.closest - o.p), 1e-12);
    EXPECT_FALSE(locator.inside(o.p));
  }
}

// The tree of boundary faces finds the face a search of every face finds, to the bit: the nearest,
// the first (in extract_boundary's order) of equally near ones (a point over a box's edge or corner
// is equally near two or three faces' shared points), for points near and far, on every side.
TEST(TetLocator, TheFaceTreeFindsWhatASearchOfEveryFaceFinds) {
  const TetMesh m = make_box_tets({0, 0, 0}, {0.04, 0.03, 0.02}, 8, 6, 4);
  const TetLocator locator(m);
  std::vector<int> to_volume;
  std::vector<Tri> faces;
  for (Tri t : extract_boundary(m, &to_volume).triangles) {
    for (int& k : t) k = to_volume[k];
    faces.push_back(t);
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.05, 0.09);
  std::vector<Vec3d> points{{-0.01, -0.01, -0.01}, {0.05, 0.015, 0.01}, {0.02, 0.015, 0.03}, {0.045, 0.035, 0.025}};
  for (int i = 0; i < 400; ++i) points.push_back({u(rng), u(rng) * 0.75, u(rng) * 0.5});
  for (int i = 0; i < 40; ++i) points.push_back({u(rng) * 1e3, u(rng) * 1e3, u(rng)});  // far away
  int checked = 0;
  for (const Vec3d& p : points) {
    if (locator.inside(p)) continue;
    double nearest = std::numeric_limits<double>::infinity();
    std::size_t best = 0;
    std::array<double, 3> wb{};
    for (std::size_t f = 0; f < faces.size(); ++f) {
      const Vec3d &a = m.vertices[faces[f][0]], &b = m.vertices[faces[f][1]], &c = m.vertices[faces[f][2]];
      const auto w = closest_on_triangle(p, a, b, c);
      if (const double d2 = squared_norm(w[0] * a + w[1] * b + w[2] * c - p); d2 < nearest) {
        nearest = d2;
        best = f;
        wb = w;
      }
    }
    double error = 0;
    const TetEmbedding e = locator.locate(p, error);
    int k = 0;
    const double sum = wb[0] + wb[1] + wb[2];
    for (int c = 0; c < 3; ++c) {
      if (wb[c] / sum < 1e-12) continue;  // locate leaves such weights out
      ASSERT_LT(k, e.count);
      EXPECT_EQ(e.vertex[k], faces[best][c]) << p.x << " " << p.y << " " << p.z;
      EXPECT_EQ(e.weight[k], wb[c] / sum);
      ++k;
    }
    EXPECT_EQ(k, e.count);
    EXPECT_TRUE(std::isfinite(error));
    ++checked;
  }
  EXPECT_GT(checked, 300);
}

}  // namespace
}  // namespace ebh
