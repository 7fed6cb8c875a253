// Embedding points in a tet mesh: inside a tet its barycentric weights, outside the closest point of
// the boundary; the closest point on a triangle against a dense sampling of it.
#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace ebh
