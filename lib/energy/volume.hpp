#pragma once
// E_det: resistance to volume change of one tetrahedron (not in the paper; scene key
// stiffness.k_det, default 0 = the paper's model; docs/MODEL.md, "Volume stiffness"),
//     E_det = k_det * V_t * (J - 1)^2,   J = det F,   F = Ds Dm^-1 (as E_vol [7], energy/arap.hpp).
// E_vol alone is linear elasticity with lambda = 0 (Poisson's ratio 0): a tet squeezed flat by a
// tool costs at most k_vol V_t, so deep under a tool the tissue gives way and tets invert. E_det
// adds lambda = 2 k_det to the linearised model (nu = k_det / (2 k_det + k_vol)); its cost grows
// without bound as J falls through 0, so an inverted tet is pushed back out.
//
// With the cofactor cof F = d det F / dF (math/vec.hpp) and F = sum_c x_c g_c^T:
//     dE_det/dx_c = 2 k_det V_t (J - 1) cof(F) g_c.
// Projective Dynamics has no projection for it that costs less than an SVD, so the local step
// adds its exact force to E_vol's, w_t [(R - F) + kappa (1 - J) cof F] g_c with w_t = 2 k_vol V_t
// and kappa = k_det / k_vol, and the global step's matrix takes the tet's weight as
// w_t (1 + 3 kappa), which bounds the term's Gauss-Newton Hessian (volume_matrix_factor).
#include "math/vec.hpp"

namespace ebh {

/// E_det of one tet: k_det * volume * (det F - 1)^2.
template <class T>
EBH_HD T volume_energy(const Mat3<T>& F, T k_det, T volume) {
  const T j1 = determinant(F) - T(1);
  return k_det * volume * j1 * j1;
}

/// dE_det/dx_c for the four corners, written to grad[4]: 2 k_det V (J - 1) cof(F) g_c.
template <class T>
EBH_HD void volume_gradient(const Mat3<T>& F, const Vec3<T> g[4], T k_det, T volume, Vec3<T> grad[4]) {
  const Mat3<T> P = (T(2) * k_det * volume * (determinant(F) - T(1))) * cofactor(F);
  for (int c = 0; c < 4; ++c) grad[c] = P * g[c];
}

/// The local step's force matrix of E_vol and E_det together: with it the corner forces are
/// P g_c = -(dE_vol/dx_c + dE_det/dx_c). w: E_vol's weight w_t = 2 k_vol V_t; kappa = k_det / k_vol.
/// kappa = 0 gives E_vol's w (R - F) by the paper's own operations (the same bits as without E_det).
template <class T>
EBH_HD Mat3<T> elastic_force_matrix(const Mat3<T>& F, const Mat3<T>& R, T w, T kappa) {
  if (!(kappa > T(0))) return w * (R - F);
  return w * ((R - F) + (kappa * (T(1) - determinant(F))) * cofactor(F));
}

/// The factor on a tet's weight w_t in the global matrix with E_det: 1 + 3 kappa. E_det's
/// Gauss-Newton Hessian at rest, 2 k_det V_t g_a g_b^T, is rank one over the tet's 12 coordinates
/// with norm 2 k_det V_t sum_c |g_c|^2; the isotropic w (g_a . g_b) I that the global matrix holds
/// has its largest eigenvalue no less than w sum_c |g_c|^2 / 3, so 3 kappa w_t bounds it.
template <class T>
EBH_HD T volume_matrix_factor(T kappa) {
  return T(1) + T(3) * kappa;
}

}  // namespace ebh
