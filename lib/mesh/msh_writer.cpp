// Gmsh ASCII 2.2 text of a tet mesh (mesh_io.hpp: msh22_text).
#include <cstdio>
#include <set>
#include <string>

#include "mesh/mesh_io.hpp"

namespace ebh {

std::string msh22_text(const TetMesh& mesh, double scale) {
  std::string out;
  char line[256];
  out += "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
  std::set<std::pair<int, int>> named;  // (dimension, tag)
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (i < mesh.triangle_group.size() && mesh.group_names.count(mesh.triangle_group[i]))
      named.insert({2, mesh.triangle_group[i]});
  for (int g : mesh.tet_group)
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
  out += "$EndNodes\n$Elements\n" + std::to_string(mesh.triangles.size() + mesh.tets.size()) + "\n";
  std::size_t id = 1;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const int g = i < mesh.triangle_group.size() ? mesh.triangle_group[i] : 0;
    const Tri& t = mesh.triangles[i];
    std::snprintf(line, sizeof line, "%zu 2 2 %d %d %d %d %d\n", id++, g, g, t[0] + 1, t[1] + 1, t[2] + 1);
    out += line;
  }
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    const int g = i < mesh.tet_group.size() ? mesh.tet_group[i] : 0;
    const Tet& t = mesh.tets[i];
    std::snprintf(line, sizeof line, "%zu 4 2 %d %d %d %d %d %d\n", id++, g, g, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1);
    out += line;
  }
  out += "$EndElements\n";
  return out;
}

}  // namespace ebh
