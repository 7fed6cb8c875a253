#pragma once
// Embedding points in a tet mesh: which tet holds a point and its barycentric weights there (the
// virtual mesh's E_svc pairing, solver/virtual_mesh.cpp).
#include <array>
#include <mutex>
#include <vector>

#include "math/vec.hpp"
#include "mesh/tet_mesh.hpp"

namespace ebh {

/// A point as a weighted sum of up to four mesh vertices: sum_k weight[k] x[vertex[k]], k < count
/// (weights positive, summing to 1; vertices with a weight below 1e-12 of the sum are left out).
struct TetEmbedding {
  std::array<int, 4> vertex{-1, -1, -1, -1};
  std::array<double, 4> weight{};
  int count = 0;
};

/// Embeds points in a tet mesh's tets: barycentric weights in the tet that contains the point
/// (exact), or, for a point outside every tet, those of the closest point of the mesh's boundary
/// (extract_boundary's faces, found on the first such point; the distance is reported). A uniform
/// grid of tet bounding boxes keeps the search for the containing tet local, a tree of the
/// boundary faces' boxes the search for the closest face (the face a search of every face finds:
/// the nearest, the first of equally near ones). Holds a reference to `mesh`, which must outlive it.
class TetLocator {
 public:
  explicit TetLocator(const TetMesh& mesh);

  /// The embedding of point p (count 0 for a mesh without tets); error_out: |sum w X - p|, the
  /// distance to the mesh (round-off inside it).
  TetEmbedding locate(const Vec3d& p, double& error_out) const;

  /// Whether p lies in (or on, within round-off) a tet of the mesh.
  bool inside(const Vec3d& p) const;

 private:
  /// The tet near p that p is least outside of (the smallest barycentric weight, largest), or -1.
  int best_tet(const Vec3d& p, double& score) const;
  std::array<double, 4> bary(int t, const Vec3d& p) const;
  std::array<int, 3> cell_of(const Vec3d& p) const;
  std::size_t index(int x, int y, int z) const;

  const TetMesh& mesh_;
  Vec3d lo_, hi_;
  double cell_ = 1;
  int dims_[3] = {1, 1, 1};
  std::vector<std::vector<int>> cells_;
  std::vector<Mat3d> inv_;
  /// A node of the boundary faces' tree: its faces' box, and its children (inner) or its faces
  /// [first, first + count) of face_order_ (leaf).
  struct FaceNode {
    Vec3d lo, hi;
    int left = -1, right = -1, first = 0, count = 0;
  };
  void build_face_tree() const;
  /// The closest boundary face to p and its closest point's weights.
  int closest_face(const Vec3d& p, std::array<double, 3>& weights) const;

  mutable std::once_flag boundary_once_;
  mutable std::vector<Tri> boundary_;  ///< the boundary faces in the mesh's vertex numbering
  mutable std::vector<int> face_order_;
  mutable std::vector<FaceNode> face_tree_;
};

/// The closest point of triangle (a, b, c) to p as barycentric weights (w_a, w_b, w_c), each in
/// [0, 1], summing to 1 (Ericson, Real-Time Collision Detection, 5.1.5).
std::array<double, 3> closest_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c);

}  // namespace ebh
