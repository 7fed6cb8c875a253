#include "mesh/boundary.hpp"

#include <algorithm>
#include <array>
#include <cstdint>

namespace ebh {

std::vector<TetFace> sorted_tet_faces(const std::vector<Tet>& tets) {
  std::vector<TetFace> faces;
  faces.reserve(tets.size() * 4);
  for (std::size_t t = 0; t < tets.size(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> v = {tets[t][kTetFaces[f][0]], tets[t][kTetFaces[f][1]], tets[t][kTetFaces[f][2]]};
      std::sort(v.begin(), v.end());
      faces.push_back({static_cast<std::uint64_t>(static_cast<std::uint32_t>(v[0])) << 32 | static_cast<std::uint32_t>(v[1]),
                       static_cast<std::uint32_t>(v[2]), static_cast<int>(4 * t + f)});
    }
  std::sort(faces.begin(), faces.end());
  return faces;
}

std::vector<std::uint8_t> face_multiplicity(const std::vector<TetFace>& sorted) {
  std::vector<std::uint8_t> mult(sorted.size(), 0);
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i;
    while (j < sorted.size() && sorted[j].same_face(sorted[i])) ++j;
    const auto m = static_cast<std::uint8_t>(std::min<std::size_t>(j - i, 255));
    for (std::size_t k = i; k < j; ++k) mult[static_cast<std::size_t>(sorted[k].tet_face)] = m;
    i = j;
  }
  return mult;
}

FaceCounts count_faces(const std::vector<Tet>& tets) { return count_faces(face_multiplicity(sorted_tet_faces(tets))); }

FaceCounts count_faces(const std::vector<std::uint8_t>& mult) {
  FaceCounts c;
  long long shared2 = 0, shared3 = 0;
  for (auto m : mult) {
    if (m == 1) ++c.boundary;
    else if (m == 2) ++shared2;
    else ++shared3;
  }
  c.interior = shared2 / 2;
  c.nonmanifold = shared3;  // counts tet faces, not distinct faces: any non-zero value is the defect
  return c;
}

SurfaceMesh extract_boundary(const TetMesh& mesh, std::vector<int>* surface_to_volume,
                             const std::vector<std::uint8_t>* multiplicity) {
  const std::vector<std::uint8_t> own = multiplicity ? std::vector<std::uint8_t>{} : face_multiplicity(sorted_tet_faces(mesh.tets));
  const std::vector<std::uint8_t>& mult = multiplicity ? *multiplicity : own;
  SurfaceMesh surface;
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& tet = mesh.tets[t];
    const bool negative = signed_volume(mesh.vertices[tet[0]], mesh.vertices[tet[1]], mesh.vertices[tet[2]],
                                        mesh.vertices[tet[3]]) < 0.0;
    for (int f = 0; f < 4; ++f) {
      if (mult[4 * t + f] != 1) continue;
      Tri tri = {tet[kTetFaces[f][0]], tet[kTetFaces[f][1]], tet[kTetFaces[f][2]]};
      if (negative) std::swap(tri[1], tri[2]);
      for (int v : tri) remap[v] = 0;
      surface.triangles.push_back(tri);
    }
  }
  std::vector<int> to_volume;
  for (std::size_t v = 0; v < remap.size(); ++v)
    if (remap[v] == 0) {
      remap[v] = static_cast<int>(to_volume.size());
      to_volume.push_back(static_cast<int>(v));
    }
  surface.vertices.reserve(to_volume.size());
  for (int v : to_volume) surface.vertices.push_back(mesh.vertices[v]);
  for (Tri& tri : surface.triangles)
    for (int& v : tri) v = remap[v];
  if (surface_to_volume) *surface_to_volume = std::move(to_volume);
  return surface;
}

SurfaceEdges surface_edges(const std::vector<Tri>& triangles) {
  struct Use {
    int a, b, face;
  };
  std::vector<Use> uses;
  uses.reserve(3 * triangles.size());
  for (int f = 0; f < static_cast<int>(triangles.size()); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = triangles[f][k], b = triangles[f][(k + 1) % 3];
      uses.push_back({std::min(a, b), std::max(a, b), f});
    }
  std::sort(uses.begin(), uses.end(), [](const Use& x, const Use& y) { return x.a != y.a ? x.a < y.a : x.b < y.b; });
  SurfaceEdges out;
  std::vector<std::uint8_t> shared(triangles.size(), 0);
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i;
    while (j < uses.size() && uses[j].a == uses[i].a && uses[j].b == uses[i].b) ++j;
    if (j - i == 1) {
      ++out.open;
      out.open_edges.push_back({uses[i].a, uses[i].b});
    }
    if (j - i > 2) ++out.nonmanifold;
    if (j - i > 1)
      for (std::size_t k = i; k < j; ++k) shared[uses[k].face] = 1;
    i = j;
  }
  out.loose_faces = std::count(shared.begin(), shared.end(), std::uint8_t{0});
  return out;
}

}  // namespace ebh
