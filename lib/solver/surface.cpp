// Surface helpers of the virtual mesh.
#include "solver/surface.hpp"

#include <algorithm>
#include <map>

namespace ebh {

SurfaceMesh tet_boundary(const TetMesh& mesh, std::vector<int>* source_vertex) {
  // Each face keyed by its sorted vertices; count uses, keep the oriented copy and the opposite vertex.
  struct Face { Tri tri; int opposite; int count; };
  std::map<std::array<int, 3>, Face> faces;
  static constexpr int kFace[4][4] = {{1, 2, 3, 0}, {0, 3, 2, 1}, {0, 1, 3, 2}, {0, 2, 1, 3}};
  for (const Tet& t : mesh.tets)
    for (const auto& f : kFace) {
      Tri tri{t[f[0]], t[f[1]], t[f[2]]};
      std::array<int, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto [it, inserted] = faces.try_emplace(key, Face{tri, t[f[3]], 0});
      ++it->second.count;
    }
  std::vector<int> remap(mesh.vertices.size(), -1);
  std::vector<Tri> tris;
  for (const auto& [key, face] : faces) {
    if (face.count != 1) continue;
    Tri tri = face.tri;
    const Vec3d& a = mesh.vertices[tri[0]];
    const Vec3d n = cross(mesh.vertices[tri[1]] - a, mesh.vertices[tri[2]] - a);
    if (dot(n, mesh.vertices[face.opposite] - a) > 0) std::swap(tri[1], tri[2]);  // make it face away
    for (int v : tri) remap[v] = 0;
    tris.push_back(tri);
  }
  SurfaceMesh out;
  std::vector<int> src;
  for (size_t v = 0; v < remap.size(); ++v)
    if (remap[v] == 0) { remap[v] = static_cast<int>(src.size()); src.push_back(static_cast<int>(v)); }
  for (int v : src) out.vertices.push_back(mesh.vertices[v]);
  for (Tri t : tris) out.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
  if (source_vertex) *source_vertex = std::move(src);
  return out;
}

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

}  // namespace ebh
