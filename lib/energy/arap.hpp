#pragma once
// E_vol [7]: as-rigid-as-possible volumetric energy of one tetrahedron,
//     E_vol = k_vol * V_t * ||F - R||_F^2,   F = Ds Dm^-1,   R = rotation of the polar F = R S,
// (the paper's energy density k_vol ||F - R||^2 integrated over the rest volume V_t).
// Ds = [x1 - x0, x2 - x0, x3 - x0] (current), Dm = [X1 - X0, X2 - X0, X3 - X0] (rest).
//
// Writing F = sum_c x_c g_c^T with the shape gradients g_c (g_1..g_3 the rows of Dm^-1,
// g_0 = -(g_1 + g_2 + g_3)), the energy is quadratic in x at fixed R, and since R minimises
// ||F - R|| over rotations its derivative drops out (envelope theorem):
//     dE/dx_c = 2 k_vol V_t (F - R) g_c.
// Projective Dynamics [4.2] uses exactly this split: the local step projects F onto R, the
// global step minimises (w_t / 2) ||sum_c x_c g_c^T - R||^2 with the weight w_t = 2 k_vol V_t.
// docs/MODEL.md: k_vol is the shear modulus mu of the linearised model (lambda = 0, E = 2 k_vol).
#include "math/vec.hpp"

namespace ebh {

/// Corner 0's shape gradient from the other three's (they sum to zero): what tet_shape_gradients
/// stores, so that a kernel that keeps only g_1..g_3 recomputes the same bits.
template <class T>
EBH_HD Vec3<T> first_shape_gradient(const Vec3<T>& g1, const Vec3<T>& g2, const Vec3<T>& g3) {
  return -(g1 + g2 + g3);
}

/// Shape gradients of a tet from Dm^-1 (3x3): g[0..3] with F = sum_c x_c g_c^T.
template <class T>
EBH_HD void tet_shape_gradients(const Mat3<T>& Dm_inv, Vec3<T> g[4]) {
  g[1] = Dm_inv.row(0);
  g[2] = Dm_inv.row(1);
  g[3] = Dm_inv.row(2);
  g[0] = first_shape_gradient(g[1], g[2], g[3]);
}

/// F = sum_c x_c g_c^T for corner positions x[4] and shape gradients g[4].
template <class T>
EBH_HD Mat3<T> deformation_gradient(const Vec3<T> x[4], const Vec3<T> g[4]) {
  Mat3<T> F = outer(x[0], g[0]);
  for (int c = 1; c < 4; ++c) F = F + outer(x[c], g[c]);
  return F;
}

/// E_vol [7] of one tet: k_vol * volume * ||F - R||_F^2. R must be the polar rotation of F.
template <class T>
EBH_HD T arap_energy(const Mat3<T>& F, const Mat3<T>& R, T k_vol, T volume) {
  return k_vol * volume * frobenius_sq(F - R);
}

/// dE_vol/dx_c for the four corners, written to grad[4]: 2 k_vol V (F - R) g_c.
template <class T>
EBH_HD void arap_gradient(const Mat3<T>& F, const Mat3<T>& R, const Vec3<T> g[4], T k_vol, T volume,
                          Vec3<T> grad[4]) {
  const Mat3<T> P = (T(2) * k_vol * volume) * (F - R);
  for (int c = 0; c < 4; ++c) grad[c] = P * g[c];
}

/// Projective Dynamics weight of a tet in the global matrix: w_t = 2 k_vol V_t, so that
/// E_vol = (w_t / 2) ||F - R||^2 and the tet adds w_t g_a . g_b to A(a, b).
template <class T>
EBH_HD T arap_weight(T k_vol, T volume) {
  return T(2) * k_vol * volume;
}

}  // namespace ebh
