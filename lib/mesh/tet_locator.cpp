// Embedding points in a tet mesh (tet_locator.hpp).
#include "mesh/tet_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

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
  // The weights l of the vertices v: inside (or on) a tet its barycentric ones, round-off's
  // negatives clamped below; outside every tet those of the closest point of the boundary (the
  // nearest tet's clamped weights, the old rule, paired a point 3 mm off with one 7.9 mm away, its
  // E_svc target dragging it sideways).
  std::array<int, 4> v{-1, -1, -1, -1};
  std::array<double, 4> l{};
  double score = 0;
  if (const int t = best_tet(p, score); t >= 0 && score >= -1e-9) {
    v = mesh_.tets[t];
    l = bary(t, p);
  } else {
    std::call_once(boundary_once_, [this] { build_face_tree(); });
    std::array<double, 3> w{};
    if (const int f = closest_face(p, w); f >= 0) {
      v = {boundary_[f][0], boundary_[f][1], boundary_[f][2], -1};
      l = {w[0], w[1], w[2], 0};
    }
  }
  TetEmbedding pair;
  if (v[0] < 0) return pair;
  double sum = 0;
  for (double& w : l) { w = std::max(w, 0.0); sum += w; }
  Vec3d q{};
  for (int k = 0; k < 4; ++k) {
    if (v[k] < 0 || l[k] / sum < 1e-12) continue;
    pair.vertex[pair.count] = v[k];
    pair.weight[pair.count] = l[k] / sum;
    q += pair.weight[pair.count] * mesh_.vertices[v[k]];
    ++pair.count;
  }
  error_out = norm(q - p);
  return pair;
}

void TetLocator::build_face_tree() const {
  std::vector<int> to_volume;
  for (Tri tri : extract_boundary(mesh_, &to_volume).triangles) {
    for (int& k : tri) k = to_volume[k];
    boundary_.push_back(tri);
  }
  const int n = static_cast<int>(boundary_.size());
  if (n == 0) return;
  std::vector<Vec3d> centre(n), lo(n), hi(n);
  for (int f = 0; f < n; ++f) {
    const Vec3d &a = mesh_.vertices[boundary_[f][0]], &b = mesh_.vertices[boundary_[f][1]],
                &c = mesh_.vertices[boundary_[f][2]];
    lo[f] = cwise_min(a, cwise_min(b, c));
    hi[f] = cwise_max(a, cwise_max(b, c));
    centre[f] = 0.5 * (lo[f] + hi[f]);
  }
  face_order_.resize(n);
  for (int f = 0; f < n; ++f) face_order_[f] = f;
  // Median splits along the widest extent of the faces' centres, leaves of up to 4 faces.
  struct Range { int node, first, count; };
  face_tree_.push_back({});
  std::vector<Range> todo{{0, 0, n}};
  while (!todo.empty()) {
    const Range r = todo.back();
    todo.pop_back();
    const auto begin = face_order_.begin() + r.first, end = begin + r.count;
    Vec3d blo = lo[*begin], bhi = hi[*begin], clo = centre[*begin], chi = clo;
    for (auto it = begin; it != end; ++it) {
      blo = cwise_min(blo, lo[*it]);
      bhi = cwise_max(bhi, hi[*it]);
      clo = cwise_min(clo, centre[*it]);
      chi = cwise_max(chi, centre[*it]);
    }
    face_tree_[r.node].lo = blo;
    face_tree_[r.node].hi = bhi;
    if (r.count <= 4) {
      face_tree_[r.node].first = r.first;
      face_tree_[r.node].count = r.count;
      continue;
    }
    const Vec3d ext = chi - clo;
    const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
    const int half = r.count / 2;
    std::nth_element(begin, begin + half, end, [&](int a, int b) {
      return centre[a][axis] < centre[b][axis] || (centre[a][axis] == centre[b][axis] && a < b);
    });
    const int left = static_cast<int>(face_tree_.size());
    face_tree_.push_back({});
    face_tree_.push_back({});
    face_tree_[r.node].left = left;
    face_tree_[r.node].right = left + 1;
    todo.push_back({left, r.first, half});
    todo.push_back({left + 1, r.first + half, r.count - half});
  }
}

int TetLocator::closest_face(const Vec3d& p, std::array<double, 3>& weights) const {
  if (face_tree_.empty()) return -1;
  // Depth first, the nearer child first; a node is skipped only when its box is farther than the
  // nearest face found, so an equally near face of a lower number is still found.
  auto box_d2 = [&p](const FaceNode& n) { return squared_norm(cwise_max(n.lo - p, cwise_max(p - n.hi, Vec3d{}))); };
  double nearest = std::numeric_limits<double>::infinity();
  int best = -1;
  std::vector<int> stack{0};
  while (!stack.empty()) {
    const FaceNode& n = face_tree_[stack.back()];
    stack.pop_back();
    if (box_d2(n) > nearest) continue;
    if (n.left < 0) {
      for (int k = n.first; k < n.first + n.count; ++k) {
        const int f = face_order_[k];
        const Vec3d &a = mesh_.vertices[boundary_[f][0]], &b = mesh_.vertices[boundary_[f][1]],
                    &c = mesh_.vertices[boundary_[f][2]];
        const auto w = closest_on_triangle(p, a, b, c);
        const double d2 = squared_norm(w[0] * a + w[1] * b + w[2] * c - p);
        if (d2 < nearest || (d2 == nearest && f < best)) {
          nearest = d2;
          best = f;
          weights = w;
        }
      }
      continue;
    }
    const bool left_first = box_d2(face_tree_[n.left]) <= box_d2(face_tree_[n.right]);
    stack.push_back(left_first ? n.right : n.left);
    stack.push_back(left_first ? n.left : n.right);
  }
  return best;
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
