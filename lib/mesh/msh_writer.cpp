// Gmsh ASCII 2.2 text of a tet mesh (mesh_io.hpp: msh22_text).
#include <algorithm>
#include <climits>
#include <cstdio>
#include <set>
#include <string>

#include "mesh/mesh_io.hpp"

namespace ebh {

std::string msh22_text(const TetMesh& mesh, double scale) {
  std::string out;
  char line[256];
  out += "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
  // An element in several groups is written once per group, as Gmsh writes it (read_msh merges
  // the copies back into one element with all its groups).
  auto groups_of = [](std::size_t i, const std::vector<int>& first, const std::vector<std::pair<int, int>>& more) {
    std::vector<int> g{i < first.size() ? first[i] : 0};
    auto it = std::lower_bound(more.begin(), more.end(), std::pair<int, int>{static_cast<int>(i), INT_MIN});
    for (; it != more.end() && it->first == static_cast<int>(i); ++it) g.push_back(it->second);
    return g;
  };
  std::set<std::pair<int, int>> named;  // (dimension, tag)
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int g : groups_of(i, mesh.triangle_group, mesh.triangle_more_groups))
      if (mesh.group_names.count(g)) named.insert({2, g});
  for (std::size_t i = 0; i < mesh.tets.size(); ++i)
    for (int g : groups_of(i, mesh.tet_group, mesh.tet_more_groups))
      if (mesh.group_names.count(g)) named.insert({3, g});
  if (!named.empty()) {
    out += "$PhysicalNames\n" + std::to_string(named.size()) + "\n";
    for (const auto& [dim, tag] : named) out += std::to_string(dim) + " " + std::to_string(tag) + " \"" + mesh.group_names.at(tag) + "\"\n";
    out += "$EndPhysicalNames\n";
  }
  out += "$Nodes\n" + std::to_string(mesh.vertices.size()) + "\n";
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3d p = mesh.vertices[v] * scale;
    std::snprintf(line, sizeof line, "%zu %.17g %.17g %.17g\n", v + 1, p.x, p.y, p.z);
    out += line;
  }
  const std::size_t elements =
      mesh.triangles.size() + mesh.tets.size() + mesh.triangle_more_groups.size() + mesh.tet_more_groups.size();
  out += "$EndNodes\n$Elements\n" + std::to_string(elements) + "\n";
  std::size_t id = 1;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Tri& t = mesh.triangles[i];
    for (int g : groups_of(i, mesh.triangle_group, mesh.triangle_more_groups)) {
      std::snprintf(line, sizeof line, "%zu 2 2 %d %d %d %d %d\n", id++, g, g, t[0] + 1, t[1] + 1, t[2] + 1);
      out += line;
    }
  }
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    const Tet& t = mesh.tets[i];
    for (int g : groups_of(i, mesh.tet_group, mesh.tet_more_groups)) {
      std::snprintf(line, sizeof line, "%zu 4 2 %d %d %d %d %d %d\n", id++, g, g, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1);
      out += line;
    }
  }
  out += "$EndElements\n";
  return out;
}

}  // namespace ebh
