#pragma once
// Embedding points in a tet mesh: which tet holds a point and its barycentric weights there (the
// virtual mesh's E_svc pairing, solver/virtual_mesh.cpp).
#include <array>
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
/// (exact), or, for a point outside every tet, in the tet it is least outside of with the negative
/// weights clamped (approximate; the error is reported). A uniform grid of tet bounding boxes
/// keeps the search local. Holds a reference to `mesh`, which must outlive it.
class TetLocator {
 public:
  explicit TetLocator(const TetMesh& mesh);

  /// The embedding of point p (count 0 for a mesh without tets); error_out: |sum w X - p|.
  TetEmbedding locate(const Vec3d& p, double& error_out) const;

 private:
  std::array<double, 4> bary(int t, const Vec3d& p) const;
  std::array<int, 3> cell_of(const Vec3d& p) const;
  std::size_t index(int x, int y, int z) const;

  const TetMesh& mesh_;
  Vec3d lo_, hi_;
  double cell_ = 1;
  int dims_[3] = {1, 1, 1};
  std::vector<std::vector<int>> cells_;
  std::vector<Mat3d> inv_;
};

}  // namespace ebh
