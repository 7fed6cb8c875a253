#pragma once
// Reference rotation extraction by singular value decomposition (host only): the closed-form
// answer that rotation.hpp's iterative update is tested and benchmarked against.
//   F = U S V^T;  R = U diag(1, 1, det(U V^T)) V^T
// flips the direction of the smallest singular value when det(U V^T) < 0, which makes R the
// proper rotation maximising tr(R^T F) for inverted and flat F too (the "rotation-variant SVD").
#include <Eigen/Dense>

#include "math/vec.hpp"

namespace ebh {

/// R of F = R S with det R = +1, by Eigen's JacobiSVD. F: any 3x3 matrix.
inline Mat3d polar_rotation_svd(const Mat3d& F) {
  Eigen::Matrix3d A;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) A(r, c) = F.m[r][c];
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);  // singular values sorted: col 2 is the smallest
  const Eigen::Matrix3d R = U * V.transpose();
  Mat3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.m[r][c] = R(r, c);
  return out;
}

}  // namespace ebh
