// Every soft-tissue energy's analytic gradient against central finite differences (double
// precision), on random, nearly flat and inverted inputs; zero energy and gradient at rest and
// under rigid motion; rotation extraction against the SVD reference.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "energy/arap.hpp"
#include "energy/volume.hpp"
#include "energy/edge_spring.hpp"
#include "energy/finite_difference.hpp"
#include "energy/polar_svd.hpp"
#include "energy/quadratic.hpp"
#include "energy/rotation.hpp"

namespace ebh {
namespace {

// Central differences with eps = 1e-6 on O(1) inputs: truncation O(eps^2 f''') ~ 1e-12, roundoff
// ~ 1e-16 |f| / eps ~ 1e-10. A relative tolerance of 1e-6 leaves a wide margin for both.
constexpr double kFdEps = 1e-6;
constexpr double kFdTol = 1e-6;

Vec3d random_vec(std::mt19937& rng, double scale = 1.0) {
  std::uniform_real_distribution<double> u(-1, 1);
  return {scale * u(rng), scale * u(rng), scale * u(rng)};
}
Mat3d random_rotation(std::mt19937& rng) { return to_matrix(quat_from_rotvec(random_vec(rng, 3.0))); }

void expect_gradient_near(const std::vector<double>& analytic, const std::vector<double>& fd) {
  double scale = 1e-12;
  for (double g : fd) scale = std::max(scale, std::abs(g));
  for (size_t i = 0; i < fd.size(); ++i) EXPECT_NEAR(analytic[i], fd[i], kFdTol * scale) << "component " << i;
}

std::vector<double> pack(const Vec3d* v, int n) {
  std::vector<double> out;
  for (int i = 0; i < n; ++i) { out.push_back(v[i].x); out.push_back(v[i].y); out.push_back(v[i].z); }
  return out;
}

// ---- rotation extraction -----------------------------------------------------------------------

TEST(Rotation, MuellerMatchesSvdOnRandomInvertedAndFlatMatrices) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 200; ++trial) {
    Mat3d F;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) F.m[r][c] = std::uniform_real_distribution<double>(-1, 1)(rng);
    if (trial % 3 == 1) F = F * Mat3d::from_cols({1, 0, 0}, {0, 1, 0}, {0, 0, 1e-9});  // nearly flat
    const Mat3d R_svd = polar_rotation_svd(F);
    const Mat3d R = to_matrix(extract_rotation(F, Quatd{}, 20000, 1e-15));
    EXPECT_NEAR(determinant(R), 1.0, 1e-12);  // proper rotation always (unit quaternion)
    // Both maximise tr(R^T F); compare the objective, which is well conditioned even where the
    // maximiser is not (nearly equal signed singular values): 1e-10 relative to |F|.
    double tr_svd = 0, tr = 0;
    for (int i = 0; i < 3; ++i) { tr_svd += dot(R_svd.col(i), F.col(i)); tr += dot(R.col(i), F.col(i)); }
    EXPECT_NEAR(tr, tr_svd, 1e-10 * std::sqrt(frobenius_sq(F))) << "trial " << trial;
  }
}

TEST(Rotation, WarmStartConvergesInAFewUpdates) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 100; ++trial) {
    const Mat3d R0 = random_rotation(rng);
    const Quatd q0 = extract_rotation(R0, Quatd{}, 200, 1e-15);
    // A small deformation step away from R0 (a physical step's change): 3 warm-started updates.
    Mat3d S = Mat3d::identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) S.m[r][c] += 0.05 * std::uniform_real_distribution<double>(-1, 1)(rng);
    const Mat3d F = to_matrix(quat_from_rotvec(random_vec(rng, 0.05))) * R0 * S;
    const Mat3d R = to_matrix(extract_rotation(F, q0, 3, 0.0));
    // The update contracts the error linearly (a scaled gradient ascent on tr(R^T F)); on
    // well-conditioned F (singular values within 15% of 1) three updates shrink it at least 5x.
    const double before = std::sqrt(frobenius_sq(R0 - polar_rotation_svd(F)));
    EXPECT_LT(std::sqrt(frobenius_sq(R - polar_rotation_svd(F))), 0.2 * before) << "trial " << trial;
  }
}

TEST(Rotation, RotationMatrixIsToMatrixWithoutTheZeroTerms) {
  // rotation_matrix performs to_matrix's operations minus the products by the unit vectors'
  // zeros and ones: the same values to round-off (FMA contraction may differ by an ulp or two).
  std::mt19937 rng(4);
  for (int trial = 0; trial < 1000; ++trial) {
    const Quatd q = quat_from_rotvec(random_vec(rng, 3.0));
    const Mat3d A = rotation_matrix(q), B = to_matrix(q);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(A.m[r][c], B.m[r][c], 1e-15) << "trial " << trial;
  }
}

TEST(Rotation, ZeroMatrixKeepsTheWarmStart) {
  const Quatd q0 = normalized(Quatd{0.9, 0.1, -0.3, 0.2});
  const Quatd q = extract_rotation(Mat3d{}, q0, 5, 1e-12);
  EXPECT_EQ(q.w, q0.w);
  EXPECT_EQ(q.x, q0.x);
}

// ---- E_vol [7] ---------------------------------------------------------------------------------

struct TetCase {
  Vec3d X[4];  // rest
  Vec3d x[4];  // current
};

double arap_energy_of(const Vec3d g[4], const std::vector<double>& xs, double k, double V) {
  Vec3d x[4];
  for (int c = 0; c < 4; ++c) x[c] = {xs[3 * c], xs[3 * c + 1], xs[3 * c + 2]};
  const Mat3d F = deformation_gradient(x, g);
  return arap_energy(F, polar_rotation_svd(F), k, V);
}

void check_arap_gradient(const TetCase& tc) {
  const Mat3d Dm = Mat3d::from_cols(tc.X[1] - tc.X[0], tc.X[2] - tc.X[0], tc.X[3] - tc.X[0]);
  Vec3d g[4];
  tet_shape_gradients(inverse(Dm), g);
  const double V = std::abs(determinant(Dm)) / 6, k = 3000.0;
  const Mat3d F = deformation_gradient(tc.x, g);
  Vec3d grad[4];
  arap_gradient(F, polar_rotation_svd(F), g, k, V, grad);
  const auto fd = fd_gradient([&](const std::vector<double>& xs) { return arap_energy_of(g, xs, k, V); },
                              pack(tc.x, 4), kFdEps);
  expect_gradient_near(pack(grad, 4), fd);
}

TEST(ArapEnergy, GradientMatchesFiniteDifferencesOnRandomFlatAndInvertedTets) {
  std::mt19937 rng(3);
  const TetCase regular{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {}};
  for (int trial = 0; trial < 60; ++trial) {
    TetCase tc = regular;
    for (int c = 0; c < 4; ++c) tc.X[c] += random_vec(rng, 0.2);
    for (int c = 0; c < 4; ++c) tc.x[c] = tc.X[c] + random_vec(rng, 0.3);
    if (trial % 3 == 1) {  // nearly flat: all four corners within 1e-4 of the plane z = 0.3
      for (int c = 0; c < 4; ++c) tc.x[c].z = 0.3 + 1e-4 * c;
    } else if (trial % 3 == 2) {  // inverted: corner 3 pushed through the opposite face
      tc.x[3] = tc.X[3] - Vec3d{0, 0, 1.6};
    }
    SCOPED_TRACE(trial);
    check_arap_gradient(tc);
  }
}

TEST(ArapEnergy, ZeroAtRestAndUnderRigidMotion) {
  std::mt19937 rng(4);
  const Vec3d X[4] = {{0, 0, 0}, {1, 0.1, 0}, {0.2, 1, 0}, {0.1, 0.3, 1}};
  Vec3d g[4];
  tet_shape_gradients(inverse(Mat3d::from_cols(X[1] - X[0], X[2] - X[0], X[3] - X[0])), g);
  for (int trial = 0; trial < 20; ++trial) {
    const Mat3d Q = trial == 0 ? Mat3d::identity() : random_rotation(rng);
    const Vec3d t = trial == 0 ? Vec3d{} : random_vec(rng, 5);
    Vec3d x[4];
    for (int c = 0; c < 4; ++c) x[c] = Q * X[c] + t;
    const Mat3d F = deformation_gradient(x, g);
    const Mat3d R = to_matrix(extract_rotation(F, Quatd{}, 100, 1e-15));
    Vec3d grad[4];
    arap_gradient(F, R, g, 3000.0, 1.0, grad);
    // Round-off of F from positions of size |t| ~ 5: 1e-14 relative.
    EXPECT_NEAR(arap_energy(F, R, 3000.0, 1.0), 0.0, 1e-20 + 3000.0 * 1e-24);
    for (int c = 0; c < 4; ++c) EXPECT_LT(norm(grad[c]), 3000.0 * 1e-12);
  }
}

// ---- E_det (energy/volume.hpp) -----------------------------------------------------------------

TEST(VolumeEnergy, CofactorIsTheDeterminantsDerivative) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    Mat3d A;
    for (int i = 0; i < 9; ++i) A.m[i / 3][i % 3] = random_vec(rng, 1.0)[i % 3];
    const Mat3d C = cofactor(A);
    // Central differences of the cubic det with step 1e-6 on entries of size ~1: truncation ~1e-12,
    // round-off ~1e-16 / 1e-6 = 1e-10; 1e-8 is above both.
    for (int i = 0; i < 9; ++i) {
      Mat3d Ap = A, Am = A;
      Ap.m[i / 3][i % 3] += 1e-6;
      Am.m[i / 3][i % 3] -= 1e-6;
      EXPECT_NEAR(C.m[i / 3][i % 3], (determinant(Ap) - determinant(Am)) / 2e-6, 1e-8);
    }
    if (std::abs(determinant(A)) > 1e-3) {  // cof A = det A A^-T; A^-1 of det >= 1e-3 amplifies round-off ~1e3 x
      for (int i = 0; i < 9; ++i)
        EXPECT_NEAR(C.m[i / 3][i % 3], determinant(A) * transpose(inverse(A)).m[i / 3][i % 3], 1e-9);
    }
  }
}

TEST(VolumeEnergy, GradientMatchesFiniteDifferencesOnRandomFlatAndInvertedTets) {
  std::mt19937 rng(6);
  const TetCase regular{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {}};
  const double k = 6000.0;
  for (int trial = 0; trial < 60; ++trial) {
    TetCase tc = regular;
    for (int c = 0; c < 4; ++c) tc.X[c] += random_vec(rng, 0.2);
    for (int c = 0; c < 4; ++c) tc.x[c] = tc.X[c] + random_vec(rng, 0.3);
    if (trial % 3 == 1) {
      for (int c = 0; c < 4; ++c) tc.x[c].z = 0.3 + 1e-4 * c;
    } else if (trial % 3 == 2) {
      tc.x[3] = tc.X[3] - Vec3d{0, 0, 1.6};
    }
    SCOPED_TRACE(trial);
    const Mat3d Dm = Mat3d::from_cols(tc.X[1] - tc.X[0], tc.X[2] - tc.X[0], tc.X[3] - tc.X[0]);
    Vec3d g[4];
    tet_shape_gradients(inverse(Dm), g);
    const double V = std::abs(determinant(Dm)) / 6;
    Vec3d grad[4];
    volume_gradient(deformation_gradient(tc.x, g), g, k, V, grad);
    const auto energy = [&](const std::vector<double>& xs) {
      Vec3d x[4];
      for (int c = 0; c < 4; ++c) x[c] = {xs[3 * c], xs[3 * c + 1], xs[3 * c + 2]};
      return volume_energy(deformation_gradient(x, g), k, V);
    };
    expect_gradient_near(pack(grad, 4), fd_gradient(energy, pack(tc.x, 4), kFdEps));
  }
}

TEST(VolumeEnergy, ForceMatrixIsMinusBothGradients) {
  // elastic_force_matrix(F, R, w = 2 k_vol V, kappa = k_det / k_vol) g_c = -(dE_vol + dE_det)/dx_c.
  std::mt19937 rng(7);
  const Vec3d X[4] = {{0, 0, 0}, {1, 0.1, 0}, {0.2, 1, 0}, {0.1, 0.3, 1}};
  Vec3d g[4];
  tet_shape_gradients(inverse(Mat3d::from_cols(X[1] - X[0], X[2] - X[0], X[3] - X[0])), g);
  const double k_vol = 3000.0, k_det = 7000.0, V = 0.2;
  for (int trial = 0; trial < 20; ++trial) {
    Vec3d x[4];
    for (int c = 0; c < 4; ++c) x[c] = X[c] + random_vec(rng, 0.4);
    const Mat3d F = deformation_gradient(x, g), R = polar_rotation_svd(F);
    const Mat3d P = elastic_force_matrix(F, R, arap_weight(k_vol, V), k_det / k_vol);
    Vec3d ga[4], gd[4];
    arap_gradient(F, R, g, k_vol, V, ga);
    volume_gradient(F, g, k_det, V, gd);
    // The same products in another order: round-off, ~1e-15 of the terms; 1e-9 relative leaves room.
    for (int c = 0; c < 4; ++c) EXPECT_LT(norm(P * g[c] + ga[c] + gd[c]), 1e-9 * (1 + norm(ga[c]) + norm(gd[c])));
  }
}

TEST(VolumeEnergy, ZeroUnderRigidMotionAndGrowsWithoutBoundThroughInversion) {
  std::mt19937 rng(8);
  for (int trial = 0; trial < 10; ++trial) {
    const Mat3d Q = random_rotation(rng);
    EXPECT_NEAR(volume_energy(Q, 1000.0, 1.0), 0.0, 1e-20);
  }
  // F = diag(1, 1, s): E_det = k V (s - 1)^2, while E_vol of a flat or mirrored tet stays finite.
  double previous = -1;
  for (double s = 1.0; s >= -2.0; s -= 0.25) {
    const Mat3d F = Mat3d::from_cols({1, 0, 0}, {0, 1, 0}, {0, 0, s});
    const double e = volume_energy(F, 1000.0, 1.0);
    EXPECT_NEAR(e, 1000.0 * (s - 1) * (s - 1), 1e-9);
    EXPECT_GT(e, previous);
    previous = e;
  }
}

// ---- E_s [4] -----------------------------------------------------------------------------------

TEST(EdgeSpring, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 50; ++trial) {
    const Vec3d e0 = random_vec(rng) + Vec3d{1.5, 0, 0};
    Vec3d q[2] = {random_vec(rng), random_vec(rng)};
    if (trial % 5 == 0) q[1] = q[0] + Vec3d{1e-3, 0, 0};  // a nearly collapsed edge
    const double k = 20.0;
    auto f = [&](const std::vector<double>& v) {
      return edge_spring_energy(Vec3d{v[0], v[1], v[2]}, Vec3d{v[3], v[4], v[5]}, e0, k);
    };
    const Vec3d g = edge_spring_gradient(q[0], q[1], e0, k);
    const Vec3d grads[2] = {g, -g};
    SCOPED_TRACE(trial);
    expect_gradient_near(pack(grads, 2), fd_gradient(f, pack(q, 2), kFdEps));
  }
}

TEST(EdgeSpring, ZeroAtRestAndUnderRigidMotion) {
  std::mt19937 rng(6);
  const Vec3d q1{0.3, 0.2, 0.1}, q2{-0.4, 0.5, 0.9};
  for (int trial = 0; trial < 20; ++trial) {
    const Mat3d Q = trial == 0 ? Mat3d::identity() : random_rotation(rng);
    const Vec3d t = trial == 0 ? Vec3d{} : random_vec(rng, 5);
    const Vec3d a = Q * q1 + t, b = Q * q2 + t;
    EXPECT_NEAR(edge_spring_energy(a, b, q1 - q2, 20.0), 0.0, 1e-24);  // round-off of |q| ~ 5
    EXPECT_LT(norm(edge_spring_gradient(a, b, q1 - q2, 20.0)), 20.0 * 1e-13);
  }
}

// ---- E_k [6], E_svc [5], E_con [3] --------------------------------------------------------------

TEST(QuadraticEnergies, InertiaCouplingContactGradientsMatchFiniteDifferences) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3d s = random_vec(rng), target = random_vec(rng), q = random_vec(rng);
    const double m = 0.01, h = 0.01, k = 50.0;
    // E_k
    auto fk = [&](const std::vector<double>& v) { return inertia_energy(Vec3d{v[0], v[1], v[2]}, s, m, h); };
    const Vec3d gk = inertia_gradient(q, s, m, h);
    expect_gradient_near(pack(&gk, 1), fd_gradient(fk, pack(&q, 1), kFdEps));
    // E_con
    auto fc = [&](const std::vector<double>& v) { return contact_energy(Vec3d{v[0], v[1], v[2]}, target, k); };
    const Vec3d gc = contact_gradient(q, target, k);
    expect_gradient_near(pack(&gc, 1), fd_gradient(fc, pack(&q, 1), kFdEps));
    // E_svc on both meshes: wrt q (p fixed) and wrt the paired physical vertices (q fixed).
    Vec3d x[3] = {random_vec(rng), random_vec(rng), random_vec(rng)};
    const int idx[3] = {0, 1, 2};
    const double w[3] = {0.2, 0.5, 0.3};
    const Vec3d p = paired_point(x, idx, w, 3);
    auto fq = [&](const std::vector<double>& v) { return coupling_energy(p, Vec3d{v[0], v[1], v[2]}, k); };
    const Vec3d gq = coupling_gradient_virtual(p, q, k);
    expect_gradient_near(pack(&gq, 1), fd_gradient(fq, pack(&q, 1), kFdEps));
    auto fx = [&](const std::vector<double>& v) {
      const Vec3d xs[3] = {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}};
      return coupling_energy(paired_point(xs, idx, w, 3), q, k);
    };
    Vec3d gx[3];
    for (int i = 0; i < 3; ++i) gx[i] = coupling_gradient_physical(p, q, k, w[i]);
    expect_gradient_near(pack(gx, 3), fd_gradient(fx, pack(x, 3), kFdEps));
  }
}

TEST(QuadraticEnergies, PredictionIsNewtonsFirstLawWithGravity) {
  const Vec3d s = predict_position(Vec3d{1, 2, 3}, Vec3d{0.5, 0, -1}, Vec3d{0, 0, -10}, 0.1);
  EXPECT_DOUBLE_EQ(s.x, 1.05);
  EXPECT_DOUBLE_EQ(s.y, 2.0);
  EXPECT_DOUBLE_EQ(s.z, 3.0 - 0.1 - 0.1);
}

}  // namespace
}  // namespace ebh
