#pragma once
// Morton (Z-order) codes of rest positions: an order of vertices and tets in which neighbours in
// space are mostly neighbours in memory. The CPU step's local order (PhysicalModel::tet_slot,
// vertex_order) and the CUDA step's patches both come from here.
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <span>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

/// The cube that Morton codes quantise: the points' bounding box's low corner and its largest side.
struct MortonBox {
  Vec3d lo;
  double extent = 0;
};

inline MortonBox morton_box(std::span<const Vec3d> points) {
  if (points.empty()) return {};
  Vec3d lo = points[0], hi = points[0];
  for (const Vec3d& p : points) { lo = cwise_min(lo, p); hi = cwise_max(hi, p); }
  return {lo, std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z})};
}

/// Morton code of p in the box: 10 bits per axis, interleaved (x lowest).
inline std::uint32_t morton_code(const Vec3d& p, const MortonBox& box) {
  auto spread = [](std::uint32_t v) {
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
  };
  auto cell = [&](double c, double l) {  // 0 .. 1023; 0 for a non-finite coordinate
    const double u = box.extent > 0 ? (c - l) / box.extent * 1023.0 : 0.0;
    return u >= 1023.0 ? 1023u : (u > 0 ? static_cast<std::uint32_t>(u) : 0u);
  };
  return spread(cell(p.x, box.lo.x)) | (spread(cell(p.y, box.lo.y)) << 1) | (spread(cell(p.z, box.lo.z)) << 2);
}

/// The indices of `points` sorted by Morton code in `box` (stable: ties keep index order).
inline std::vector<int> morton_order(std::span<const Vec3d> points, const MortonBox& box) {
  std::vector<std::uint32_t> code(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) code[i] = morton_code(points[i], box);
  std::vector<int> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return code[a] < code[b]; });
  return order;
}

}  // namespace ebh
