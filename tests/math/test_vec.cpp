#include <gtest/gtest.h>

#include <random>

#include "math/vec.hpp"

using namespace ebh;

TEST(Quat, RotvecRoundTripIsExact) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int i = 0; i < 200; ++i) {
    Vec3d w{u(rng), u(rng), u(rng)};
    if (norm(w) >= 3.1) continue;  // keep the angle below pi so the rotation vector is unique
    Vec3d back = rotvec_from_quat(quat_from_rotvec(w));
    EXPECT_NEAR(norm(back - w), 0.0, 1e-12);  // double round-off of sin/atan2
  }
}

TEST(Quat, RotationMatchesMatrixAndPreservesLength) {
  Quatd q = quat_from_rotvec(Vec3d{0.3, -0.2, 0.9});
  Mat3d R = to_matrix(q);
  Vec3d v{1.0, 2.0, -0.5};
  EXPECT_NEAR(norm(R * v - rotate(q, v)), 0.0, 1e-14);
  EXPECT_NEAR(norm(rotate(q, v)), norm(v), 1e-14);
  EXPECT_NEAR(determinant(R), 1.0, 1e-14);
}

TEST(Mat3, InverseAndSkew) {
  Mat3d A = Mat3d::from_cols({2, 0.1, 0}, {0.3, 1.5, 0.2}, {0, -0.4, 3});
  Mat3d I = A * inverse(A);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(I(r, c), r == c ? 1.0 : 0.0, 1e-14);
  Vec3d a{1, 2, 3}, b{-2, 0.5, 4};
  EXPECT_NEAR(norm(skew(a) * b - cross(a, b)), 0.0, 1e-14);
}
