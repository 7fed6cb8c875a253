// Morton order (mesh/morton.hpp): the order the CPU step visits tets and vertices in and the CUDA
// step cuts its patches from.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "mesh/morton.hpp"

namespace ebh {
namespace {

TEST(Morton, PointsOfOneOctantComeTogetherAndTiesKeepTheirIndexOrder) {
  // Points scattered over the unit cube, numbered without regard to where they are.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3d> p(4000);
  for (Vec3d& x : p) x = Vec3d{u(rng), u(rng), u(rng)};
  p.push_back(p[10]);  // a duplicate: the same code as point 10, after it
  const MortonBox box = morton_box(p);
  const std::vector<int> order = morton_order(p, box);
  ASSERT_EQ(order.size(), p.size());
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < static_cast<int>(sorted.size()); ++i) ASSERT_EQ(sorted[i], i);  // a permutation
  // The octant (the codes' top three bits: cell 512 of 0 .. 1023 and up on each axis) never
  // decreases along the order: each octant's points are one run.
  const double split = 512.0 / 1023.0 * box.extent;
  auto octant = [&](const Vec3d& x) {
    const Vec3d d = x - box.lo;
    return (d.x >= split) + 2 * (d.y >= split) + 4 * (d.z >= split);
  };
  for (std::size_t i = 1; i < order.size(); ++i) ASSERT_LE(octant(p[order[i - 1]]), octant(p[order[i]]));
  // Neighbours in the order are neighbours in space: the mean step between consecutive points is
  // a small fraction of the mean step in index order (~0.66 of the cube's side).
  double by_order = 0, by_index = 0;
  for (std::size_t i = 1; i < order.size(); ++i) {
    by_order += norm(p[order[i]] - p[order[i - 1]]);
    by_index += norm(p[i] - p[i - 1]);
  }
  EXPECT_LT(by_order, 0.15 * by_index);
  const auto at10 = std::find(order.begin(), order.end(), 10), at_dup = std::find(order.begin(), order.end(), 4000);
  EXPECT_LT(at10, at_dup);
}

TEST(Morton, FlatAndNonFiniteInputsGiveAnOrderWithoutFailing) {
  // All points equal (a box of extent 0): every code is 0, the order is the index order.
  const std::vector<Vec3d> same(5, Vec3d{1, 2, 3});
  const std::vector<int> order = morton_order(same, morton_box(same));
  for (int i = 0; i < 5; ++i) EXPECT_EQ(order[i], i);
  // A non-finite coordinate quantises to cell 0 (validation refuses such meshes before they get here).
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const MortonBox box{Vec3d{0, 0, 0}, 1.0};
  EXPECT_EQ(morton_code(Vec3d{nan, nan, nan}, box), 0u);
  EXPECT_EQ(morton_code(Vec3d{1, 1, 1}, box), (1u << 30) - 1);  // every bit of 3 x 10
  EXPECT_EQ(morton_code(Vec3d{2, -1, 0.5}, box), morton_code(Vec3d{1, 0, 0.5}, box));  // clamped to the cube
}

}  // namespace
}  // namespace ebh
