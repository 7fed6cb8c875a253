// Surface helpers of the virtual mesh.
#include "mesh/surface.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace ebh {

SurfaceMesh refine_surface(const SurfaceMesh& surface, std::vector<std::array<int, 2>>& parent) {
  SurfaceMesh out;
  out.vertices = surface.vertices;
  parent.clear();
  for (int i = 0; i < static_cast<int>(surface.vertices.size()); ++i) parent.push_back({i, i});
  std::map<std::array<int, 2>, int> midpoint;
  auto mid = [&](int a, int b) {
    std::array<int, 2> key{std::min(a, b), std::max(a, b)};
    auto [it, inserted] = midpoint.try_emplace(key, static_cast<int>(out.vertices.size()));
    if (inserted) {
      out.vertices.push_back(0.5 * (surface.vertices[a] + surface.vertices[b]));
      parent.push_back(key);
    }
    return it->second;
  };
  for (const Tri& t : surface.triangles) {
    const int ab = mid(t[0], t[1]), bc = mid(t[1], t[2]), ca = mid(t[2], t[0]);
    out.triangles.push_back({t[0], ab, ca});
    out.triangles.push_back({ab, t[1], bc});
    out.triangles.push_back({ca, bc, t[2]});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

double median_circumradius(std::span<const Vec3d> positions, std::span<const Tri> triangles) {
  if (triangles.empty()) return 0;
  std::vector<double> r;
  r.reserve(triangles.size());
  for (const Tri& t : triangles) {
    const Vec3d a = positions[t[0]], b = positions[t[1]], c = positions[t[2]];
    const double twice_area = norm(cross(b - a, c - a));
    r.push_back(twice_area > 0 ? norm(b - c) * norm(c - a) * norm(a - b) / (2 * twice_area) : INFINITY);
  }
  const auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
  std::nth_element(r.begin(), mid, r.end());
  return *mid;
}

namespace {

/// The open edges (those one face uses), lowest vertex first, in order.
std::vector<std::array<int, 2>> open_edges(const std::vector<Tri>& triangles) {
  std::map<std::array<int, 2>, int> uses;
  for (const Tri& t : triangles)
    for (int k = 0; k < 3; ++k) ++uses[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  std::vector<std::array<int, 2>> open;
  for (const auto& [e, n] : uses)
    if (n == 1) open.push_back(e);
  return open;
}

/// The cell of p in a grid of `cell`-sized cubes.
std::array<long long, 3> grid_cell(const Vec3d& p, double cell) {
  return {static_cast<long long>(std::floor(p.x / cell)), static_cast<long long>(std::floor(p.y / cell)),
          static_cast<long long>(std::floor(p.z / cell))};
}

}  // namespace

UnweldedSeam unwelded_seam(const SurfaceMesh& surface) {
  const std::vector<std::array<int, 2>> open = open_edges(surface.triangles);
  std::vector<double> lengths;
  for (const auto& e : open) lengths.push_back(norm(surface.vertices[e[1]] - surface.vertices[e[0]]));
  UnweldedSeam seam;
  if (open.size() < 2) return seam;
  // Their midpoints in cells of the longest open edge's size: a partner's midpoint lies within a
  // quarter of it, in the same cell or a neighbour.
  const double cell = *std::max_element(lengths.begin(), lengths.end());
  if (!(cell > 0)) return seam;
  const auto key = [cell](const Vec3d& p) { return grid_cell(p, cell); };
  const auto mid = [&](std::size_t i) { return 0.5 * (surface.vertices[open[i][0]] + surface.vertices[open[i][1]]); };
  std::map<std::array<long long, 3>, std::vector<std::size_t>> cells;
  for (std::size_t i = 0; i < open.size(); ++i) cells[key(mid(i))].push_back(i);
  for (std::size_t i = 0; i < open.size(); ++i) {
    const Vec3d &a = surface.vertices[open[i][0]], &b = surface.vertices[open[i][1]];
    const std::array<long long, 3> c = key(mid(i));
    double best = INFINITY;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz)
          if (const auto it = cells.find({c[0] + dx, c[1] + dy, c[2] + dz}); it != cells.end())
            for (const std::size_t j : it->second) {
              if (j == i || open[j][0] == open[i][0] || open[j][0] == open[i][1] || open[j][1] == open[i][0] ||
                  open[j][1] == open[i][1])
                continue;
              const Vec3d &p = surface.vertices[open[j][0]], &q = surface.vertices[open[j][1]];
              const double gap = 0.5 * std::min(norm(a - p) + norm(b - q), norm(a - q) + norm(b - p));
              if (gap < 0.25 * std::min(lengths[i], lengths[j])) best = std::min(best, gap);
            }
    if (best < INFINITY) {
      ++seam.edges;
      seam.gap = std::max(seam.gap, best);
    }
  }
  return seam;
}

long long t_junctions(const SurfaceMesh& surface) {
  const std::vector<std::array<int, 2>> open = open_edges(surface.triangles);
  if (open.size() < 3) return 0;  // a T-junction's edges: the long one and the two along it
  double cell = 0;
  std::vector<int> ends;  // the open edges' vertices
  for (const auto& e : open) {
    cell = std::max(cell, norm(surface.vertices[e[1]] - surface.vertices[e[0]]));
    ends.insert(ends.end(), e.begin(), e.end());
  }
  if (!(cell > 0)) return 0;
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
  std::map<std::array<long long, 3>, std::vector<int>> cells;
  for (const int v : ends) cells[grid_cell(surface.vertices[v], cell)].push_back(v);
  std::vector<char> on_edge(surface.vertices.size(), 0);
  for (const auto& [a, b] : open) {
    const Vec3d &pa = surface.vertices[a], &pb = surface.vertices[b];
    const Vec3d d = pb - pa;
    const double l2 = dot(d, d);
    if (!(l2 > 0)) continue;
    // Every point of the edge lies within half an edge (<= half a cell) of its midpoint's cell.
    const std::array<long long, 3> c = grid_cell(0.5 * (pa + pb), cell);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz)
          if (const auto it = cells.find({c[0] + dx, c[1] + dy, c[2] + dz}); it != cells.end())
            for (const int m : it->second) {
              if (m == a || m == b || on_edge[m]) continue;
              const double t = dot(surface.vertices[m] - pa, d) / l2;
              if (t <= 0 || t >= 1) continue;
              if (squared_norm(surface.vertices[m] - (pa + t * d)) <= kTJunctionReach * kTJunctionReach * l2) on_edge[m] = 1;
            }
  }
  return std::count(on_edge.begin(), on_edge.end(), 1);
}

std::size_t orient_consistently(std::vector<Tri>& triangles) {
  // Each undirected edge's uses: (triangle, +1 if it runs low -> high there, -1 otherwise).
  std::map<std::array<int, 2>, std::vector<std::pair<int, int>>> uses;
  for (std::size_t f = 0; f < triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = triangles[f][k], b = triangles[f][(k + 1) % 3];
      uses[{std::min(a, b), std::max(a, b)}].push_back({static_cast<int>(f), a < b ? 1 : -1});
    }
  std::vector<std::vector<std::pair<int, bool>>> next(triangles.size());  // (neighbour, wound alike)
  for (const auto& [edge, on] : uses)
    if (on.size() == 2) {
      const bool alike = on[0].second == on[1].second;  // both traverse it the same way: one is turned
      next[on[0].first].push_back({on[1].first, alike});
      next[on[1].first].push_back({on[0].first, alike});
    }
  // Per piece, in triangle order: turn[f] relative to the piece's first, then the minority turned.
  std::vector<signed char> turn(triangles.size(), -1);
  std::size_t turned = 0;
  std::vector<int> piece, stack;
  for (std::size_t s = 0; s < triangles.size(); ++s) {
    if (turn[s] >= 0) continue;
    piece.clear();
    turn[s] = 0;
    stack.assign(1, static_cast<int>(s));
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      piece.push_back(f);
      for (const auto& [g, alike] : next[f])
        if (turn[g] < 0) {
          turn[g] = static_cast<signed char>(turn[f] ^ (alike ? 1 : 0));
          stack.push_back(g);
        }
    }
    const std::size_t against = static_cast<std::size_t>(std::count_if(piece.begin(), piece.end(), [&](int f) { return turn[f] == 1; }));
    const signed char flip = 2 * against > piece.size() ? 0 : 1;  // turn the minority (ties: those against the first)
    for (const int f : piece)
      if (turn[f] == flip) {
        std::swap(triangles[f][1], triangles[f][2]);
        ++turned;
      }
  }
  return turned;
}

}  // namespace ebh
