// Embedding points in a tet mesh (tet_locator.hpp).
#include "mesh/tet_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
}

TetEmbedding TetLocator::locate(const Vec3d& p, double& error_out) const {
  int best = -1;
  double best_score = -std::numeric_limits<double>::infinity();
  auto consider = [&](int t) {
    const auto l = bary(t, p);
    const double score = std::min(std::min(l[0], l[1]), std::min(l[2], l[3]));
    if (score > best_score) { best_score = score; best = t; }
  };
  const auto c = cell_of(p);
  for (int t : cells_[index(c[0], c[1], c[2])]) consider(t);
  if (best_score < -1e-9)  // outside every tet near p: search all
    for (int t = 0; t < static_cast<int>(mesh_.tets.size()); ++t) consider(t);
  TetEmbedding pair;
  if (best < 0) return pair;
  auto l = bary(best, p);
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
