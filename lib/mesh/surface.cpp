// Surface helpers of the virtual mesh.
#include "mesh/surface.hpp"

#include <algorithm>
#include <cmath>
#include <map>

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

}  // namespace ebh
