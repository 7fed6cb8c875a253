// Embedding points in a tet mesh (tet_locator.hpp).
#include "mesh/tet_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "mesh/boundary.hpp"

namespace ebh {

TetLocator::TetLocator(const TetMesh& mesh) : mesh_(mesh) {
  lo_ = hi_ = mesh.vertices.empty() ? Vec3d{} : mesh.vertices[0];
  for (const Vec3d& v : mesh.vertices) { lo_ = cwise_min(lo_, v); hi_ = cwise_max(hi_, v); }
  const double cells_wanted = std::max<double>(1.0, double(mesh.tets.size()) / 4.0);
  const Vec3d ext = hi_ - lo_;
  const double vol = std::max(ext.x, 1e-12) * std::max(ext.y, 1e-12) * std::max(ext.z, 1e-12);
  cell_ = std::cbrt(vol / cells_wanted);
  for (int i = 0; i < 3; ++i) dims_[i] = std::clamp(int(ext[i] / cell_) + 1, 1, 512);
  cells_.resize(size_t(dims_[0]) * dims_[1] * dims_[2]);
  inv_.resize(mesh.tets.size());
  for (int t = 0; t < static_cast<int>(mesh.tets.size()); ++t) {
    const auto& T = mesh.tets[t];
    Vec3d a = mesh.vertices[T[0]], b = a;
    for (int c = 1; c < 4; ++c) { a = cwise_min(a, mesh.vertices[T[c]]); b = cwise_max(b, mesh.vertices[T[c]]); }
    const auto ia = cell_of(a), ib = cell_of(b);
    for (int x = ia[0]; x <= ib[0]; ++x)
      for (int y = ia[1]; y <= ib[1]; ++y)
        for (int z = ia[2]; z <= ib[2]; ++z) cells_[index(x, y, z)].push_back(t);
    const Vec3d& X0 = mesh.vertices[T[0]];
    inv_[t] = inverse(Mat3d::from_cols(mesh.vertices[T[1]] - X0, mesh.vertices[T[2]] - X0, mesh.vertices[T[3]] - X0));
  }
  // The boundary: faces that one tet alone has (sorted corner triples, counted).
  std::map<std::array<int, 3>, std::pair<int, int>> faces;  // sorted vertices -> (tet, face), tet -1 when shared
  for (int t = 0; t < static_cast<int>(mesh.tets.size()); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> key{mesh.tets[t][kTetFaces[f][0]], mesh.tets[t][kTetFaces[f][1]], mesh.tets[t][kTetFaces[f][2]]};
      std::sort(key.begin(), key.end());
      auto [it, first] = faces.try_emplace(key, t, f);
      if (!first) it->second.first = -1;
    }
  for (const auto& [key, tf] : faces)
    if (tf.first >= 0)
      boundary_.push_back({tf.first, {kTetFaces[tf.second][0], kTetFaces[tf.second][1], kTetFaces[tf.second][2]}});
}

int TetLocator::best_tet(const Vec3d& p, double& score) const {
  int best = -1;
  score = -std::numeric_limits<double>::infinity();
  const auto c = cell_of(p);
  for (int t : cells_[index(c[0], c[1], c[2])]) {
    const auto l = bary(t, p);
    const double s = std::min(std::min(l[0], l[1]), std::min(l[2], l[3]));
    if (s > score) { score = s; best = t; }
  }
  return best;
}

bool TetLocator::inside(const Vec3d& p) const {
  double score = 0;
  return best_tet(p, score) >= 0 && score >= -1e-9;
}

TetEmbedding TetLocator::locate(const Vec3d& p, double& error_out) const {
  double score = 0;
  int best = best_tet(p, score);
  std::array<double, 4> l{};
  if (best >= 0 && score >= -1e-9) {
    l = bary(best, p);  // inside (or on) a tet: its weights, round-off's negatives clamped below
  } else if (!boundary_.empty()) {
    // Outside every tet: the closest point of the boundary (a tet's weights clamped, the old rule,
    // paired a point 3 mm off with one 7.9 mm away, the E_svc target dragging it sideways).
    double nearest = std::numeric_limits<double>::infinity();
    for (const BoundaryFace& f : boundary_) {
      const auto& T = mesh_.tets[f.tet];
      const Vec3d& a = mesh_.vertices[T[f.corner[0]]];
      const Vec3d& b = mesh_.vertices[T[f.corner[1]]];
      const Vec3d& c = mesh_.vertices[T[f.corner[2]]];
      const auto w = closest_on_triangle(p, a, b, c);
      const double d2 = squared_norm(w[0] * a + w[1] * b + w[2] * c - p);
      if (d2 < nearest) {
        nearest = d2;
        best = f.tet;
        l = {0, 0, 0, 0};
        for (int k = 0; k < 3; ++k) l[f.corner[k]] = w[k];
      }
    }
  }
  TetEmbedding pair;
  if (best < 0) return pair;
  double sum = 0;
  for (double& w : l) { w = std::max(w, 0.0); sum += w; }
  Vec3d q{};
  for (int k = 0; k < 4; ++k) {
    if (l[k] / sum < 1e-12) continue;
    pair.vertex[pair.count] = mesh_.tets[best][k];
    pair.weight[pair.count] = l[k] / sum;
    q += pair.weight[pair.count] * mesh_.vertices[mesh_.tets[best][k]];
    ++pair.count;
  }
  error_out = norm(q - p);
  return pair;
}

std::array<double, 3> closest_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};  // vertex a
  const Vec3d bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};  // vertex b
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {  // edge ab
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec3d cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};  // vertex c
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {  // edge ac
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {  // edge bc
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) return {1, 0, 0};  // a degenerate face: its first corner
  const double v = vb / denom, w = vc / denom;
  return {1 - v - w, v, w};
}

std::array<double, 4> TetLocator::bary(int t, const Vec3d& p) const {
  const Vec3d l = inv_[t] * (p - mesh_.vertices[mesh_.tets[t][0]]);
  return {1.0 - l.x - l.y - l.z, l.x, l.y, l.z};
}

std::array<int, 3> TetLocator::cell_of(const Vec3d& p) const {
  std::array<int, 3> c;
  for (int i = 0; i < 3; ++i) c[i] = std::clamp(int((p[i] - lo_[i]) / cell_), 0, dims_[i] - 1);
  return c;
}

std::size_t TetLocator::index(int x, int y, int z) const { return (std::size_t(z) * dims_[1] + y) * dims_[0] + x; }

}  // namespace ebh
