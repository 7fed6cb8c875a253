// Uniform 1 -> 8 refinement of a tet mesh (mesh/refine.hpp).
#include "mesh/refine.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

namespace ebh {
namespace {

using Edge = std::pair<int, int>;  // (smaller, larger) vertex index

Edge edge(int a, int b) { return a < b ? Edge{a, b} : Edge{b, a}; }

/// The distinct edges of the tets, sorted.
std::vector<Edge> unique_edges(const TetMesh& mesh) {
  std::vector<Edge> edges;
  edges.reserve(6 * mesh.tets.size());
  for (const Tet& t : mesh.tets)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) edges.push_back(edge(t[i], t[j]));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

/// Whether each edge of the triangle is an edge of the tets (`edges`, sorted): then it is split.
bool splits(const Tri& f, const std::vector<Edge>& edges) {
  for (int i = 0; i < 3; ++i)
    if (!std::binary_search(edges.begin(), edges.end(), edge(f[i], f[(i + 1) % 3]))) return false;
  return true;
}

/// The number of distinct faces (sorted vertex triples) of the tets, and of those used once.
std::pair<std::int64_t, std::int64_t> face_counts(const std::vector<Tet>& tets) {
  std::vector<std::array<int, 3>> faces;
  faces.reserve(4 * tets.size());
  for (const Tet& t : tets)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f{};
      int k = 0;
      for (int i = 0; i < 4; ++i)
        if (i != skip) f[k++] = t[i];
      std::sort(f.begin(), f.end());
      faces.push_back(f);
    }
  std::sort(faces.begin(), faces.end());
  std::int64_t distinct = 0, once = 0;
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j] == faces[i]) ++j;
    ++distinct;
    if (j - i == 1) ++once;
    i = j;
  }
  return {distinct, once};
}

std::int64_t saturating(double v) {
  return v >= static_cast<double>(std::numeric_limits<std::int64_t>::max()) ? std::numeric_limits<std::int64_t>::max()
                                                                               : static_cast<std::int64_t>(v);
}

}  // namespace

TetMesh refine_tet_mesh(const TetMesh& mesh) {
  const std::vector<Edge> edges = unique_edges(mesh);
  const int n = static_cast<int>(mesh.vertices.size());
  auto mid = [&](int a, int b) {
    const auto it = std::lower_bound(edges.begin(), edges.end(), edge(a, b));
    return n + static_cast<int>(it - edges.begin());
  };

  TetMesh out;
  out.group_names = mesh.group_names;
  out.vertices.reserve(mesh.vertices.size() + edges.size());
  out.vertices = mesh.vertices;
  for (const auto& [a, b] : edges) out.vertices.push_back(0.5 * (mesh.vertices[a] + mesh.vertices[b]));
  out.file_node_ids.resize(out.vertices.size());
  for (std::size_t v = 0; v < out.vertices.size(); ++v) out.file_node_ids[v] = static_cast<long long>(v) + 1;

  for (const auto& [t, tag] : mesh.tet_more_groups)
    for (int c = 0; c < 8; ++c) out.tet_more_groups.push_back({8 * t + c, tag});
  std::sort(out.tet_more_groups.begin(), out.tet_more_groups.end());
  out.tets.reserve(8 * mesh.tets.size());
  out.tet_group.reserve(8 * mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const auto [v0, v1, v2, v3] = mesh.tets[t];
    const int m01 = mid(v0, v1), m02 = mid(v0, v2), m03 = mid(v0, v3);
    const int m12 = mid(v1, v2), m13 = mid(v1, v3), m23 = mid(v2, v3);
    // The corners: the parent scaled by 1/2 about each vertex (the same orientation).
    out.tets.push_back({v0, m01, m02, m03});
    out.tets.push_back({m01, v1, m12, m13});
    out.tets.push_back({m02, m12, v2, m23});
    out.tets.push_back({m03, m13, m23, v3});
    // The octahedron around its shortest diagonal (a, b); c is the cycle of the other four
    // midpoints in the order that makes (a, b, c[i], c[i+1]) positive for a positive parent.
    auto length2 = [&](int a, int b) { return squared_norm(out.vertices[a] - out.vertices[b]); };
    struct Diagonal {
      int a, b;
      std::array<int, 4> c;
    };
    const Diagonal diagonals[3] = {{m01, m23, {m02, m03, m13, m12}},
                                   {m02, m13, {m01, m12, m23, m03}},
                                   {m03, m12, {m01, m02, m23, m13}}};
    int best = 0;
    for (int d = 1; d < 3; ++d) {
      const double ld = length2(diagonals[d].a, diagonals[d].b), lb = length2(diagonals[best].a, diagonals[best].b);
      // Ties by the smaller vertex index of each diagonal, then the larger: the same choice on any
      // machine and for any order of the parent's corners.
      const auto key = [](const Diagonal& g) { return edge(g.a, g.b); };
      if (ld < lb || (ld == lb && key(diagonals[d]) < key(diagonals[best]))) best = d;
    }
    const Diagonal& g = diagonals[best];
    for (int i = 0; i < 4; ++i) out.tets.push_back({g.a, g.b, g.c[i], g.c[(i + 1) % 4]});
    const int group = t < mesh.tet_group.size() ? mesh.tet_group[t] : 0;
    out.tet_group.insert(out.tet_group.end(), 8, group);
  }

  out.triangles.reserve(4 * mesh.triangles.size());
  out.triangle_group.reserve(4 * mesh.triangles.size());
  auto more = mesh.triangle_more_groups.begin();
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const int group = f < mesh.triangle_group.size() ? mesh.triangle_group[f] : 0;
    const bool split = splits(mesh.triangles[f], edges);
    for (; more != mesh.triangle_more_groups.end() && more->first == static_cast<int>(f); ++more)
      for (int c = 0; c < (split ? 4 : 1); ++c) out.triangle_more_groups.push_back({static_cast<int>(out.triangles.size()) + c, more->second});
    if (!split) {  // not on the tets: kept as it is (mesh/refine.hpp)
      out.triangles.push_back(mesh.triangles[f]);
      out.triangle_group.push_back(group);
      continue;
    }
    const auto [a, b, c] = mesh.triangles[f];
    const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    // As refine_surface (mesh/surface.hpp) splits a virtual triangle: each child keeps the orientation.
    out.triangles.push_back({a, ab, ca});
    out.triangles.push_back({ab, b, bc});
    out.triangles.push_back({ca, bc, c});
    out.triangles.push_back({ab, bc, ca});
    out.triangle_group.insert(out.triangle_group.end(), 4, group);
  }
  std::sort(out.triangle_more_groups.begin(), out.triangle_more_groups.end());
  return out;
}

RefinedCounts refined_counts(const TetMesh& mesh, int levels) {
  const auto [faces, boundary] = face_counts(mesh.tets);
  const std::vector<Edge> edges = unique_edges(mesh);
  std::int64_t split = 0;
  for (const Tri& f : mesh.triangles) split += splits(f, edges) ? 1 : 0;
  // Doubles: the counts grow by 8 a level and must saturate, not wrap, for a large `levels`.
  double V = static_cast<double>(mesh.vertices.size()), E = static_cast<double>(edges.size());
  double F = static_cast<double>(faces), T = static_cast<double>(mesh.tets.size());
  double B = static_cast<double>(boundary), L = static_cast<double>(split);
  for (int l = 0; l < levels; ++l) {
    const double V1 = V + E, E1 = 2 * E + 3 * F + T, F1 = 4 * F + 8 * T;
    V = V1;
    E = E1;
    F = F1;
    T *= 8;
    B *= 4;
    L *= 4;
    if (std::isinf(T) && std::isinf(V)) break;  // past what a double holds; a huge `levels` ends here
  }
  RefinedCounts c;
  c.vertices = saturating(V);
  c.edges = saturating(E);
  c.faces = saturating(F);
  c.tets = saturating(T);
  c.tets_estimate = T;
  c.vertices_estimate = V;
  c.boundary_faces = saturating(B);
  c.triangles = saturating(L + static_cast<double>(static_cast<std::int64_t>(mesh.triangles.size()) - split));
  return c;
}

}  // namespace ebh
