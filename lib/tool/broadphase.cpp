#include "tool/broadphase.hpp"

#include <algorithm>
#include <cmath>

namespace ebh {

void VertexGrid::rebuild(std::span<const Vec3d> q_ref, double margin) {
  const std::size_t m = q_ref.size();
  q_ref_.assign(q_ref.begin(), q_ref.end());
  margin_ = margin;
  moved_ = 0.0;
  violated_ = false;
  ++rebuilds_;
  if (stamps_.size() != m) { stamps_.assign(m, 0); stamp_ = 0; slots_.assign(m, 0); }
  Vec3d lo{0, 0, 0}, hi{0, 0, 0};
  if (m > 0) { lo = hi = q_ref[0]; }
  for (const Vec3d& p : q_ref) { lo = cwise_min(lo, p); hi = cwise_max(hi, p); }
  const Vec3d ext = hi - lo;
  // Cell size: at least half the margin, and about one vertex per cell for a volume-filling
  // cloud; at most 128 cells per axis.
  const double vol = std::max(ext.x, 1e-9) * std::max(ext.y, 1e-9) * std::max(ext.z, 1e-9);
  double cell = std::max({0.5 * margin, std::cbrt(vol / std::max<std::size_t>(m, 1)), 1e-6});
  cell = std::max({cell, ext.x / 128.0, ext.y / 128.0, ext.z / 128.0});
  cell_ = cell;
  origin_ = lo;
  for (int k = 0; k < 3; ++k) dims_[k] = std::max(1, static_cast<int>(std::floor(ext[k] / cell)) + 1);
  const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  cell_start_.assign(cells + 1, 0);
  if (cell_pass_.size() < cells) cell_pass_.resize(cells, 0);  // entries kept: all below the next pass
  vertex_cell_.resize(m);
  for (std::size_t i = 0; i < m; ++i) {
    int c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = std::min(dims_[k] - 1, static_cast<int>((q_ref[i][k] - origin_[k]) / cell));
    vertex_cell_[i] = (c[2] * dims_[1] + c[1]) * dims_[0] + c[0];
    ++cell_start_[vertex_cell_[i] + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) cell_start_[c + 1] += cell_start_[c];
  cell_vertex_.resize(m);
  std::vector<int>& fill = vertex_cell_;  // reuse: counting sort, then vertex_cell_ is scratch
  std::vector<int> cursor(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < m; ++i) cell_vertex_[cursor[fill[i]]++] = static_cast<int>(i);
}

double VertexGrid::max_displacement(std::span<const Vec3d> q) const {
  double d2 = 0.0;
  const std::size_t m = std::min(q.size(), q_ref_.size());
  for (std::size_t i = 0; i < m; ++i) d2 = std::max(d2, squared_norm(q[i] - q_ref_[i]));
  return std::sqrt(d2);
}

}  // namespace ebh
