#pragma once
// Rotation extraction for E_vol [7]: R = argmin_{R in SO(3)} ||F - R||_F = argmax tr(R^T F), the
// rotational part of the polar decomposition F = R S, kept a proper rotation (det R = +1) for
// inverted (det F < 0) and flat (det F = 0) tets alike.
//
// The default is the warm-started iterative update of Mueller, Bender, Chentanez and Macklin,
// "A Robust Method to Extract the Rotational Part of Deformations" (MIG 2016): starting from the
// previous step's rotation q, repeat
//     omega = sum_i r_i x f_i / (|sum_i r_i . f_i| + eps)      (r_i, f_i the columns of R, F)
//     q <- exp(omega) q       (here to first order, renormalised: no trigonometry)
// Each update is a rotation, so R never leaves SO(3). The error contracts linearly (a scaled
// gradient ascent on tr(R^T F)); warm-started from the last iteration's rotation, a few updates per
// local step keep R converged as the Projective Dynamics loop proceeds. It is branch-light and runs
// per tet in a CUDA thread unchanged.
// polar_svd.hpp holds the SVD reference (host only) that tests and the benchmark compare with.
#include "math/vec.hpp"

namespace ebh {

/// The rotation matrix of a unit quaternion: the same operations as to_matrix (rotate() of the
/// unit vectors, math/vec.hpp) with the products by the unit vectors' zeros and ones dropped, so
/// the same values (up to the sign of an exact zero) at about a third of the cost.
template <class T>
EBH_HD Mat3<T> rotation_matrix(Quat<T> q) {
  const T x2 = T(2) * q.x, y2 = T(2) * q.y, z2 = T(2) * q.z;
  Mat3<T> R;
  R.m[0][0] = T(1) - (q.y * y2 + q.z * z2);
  R.m[1][0] = q.w * z2 + q.x * y2;
  R.m[2][0] = q.x * z2 - q.w * y2;
  R.m[0][1] = q.y * x2 - q.w * z2;
  R.m[1][1] = T(1) - (q.z * z2 + q.x * x2);
  R.m[2][1] = q.w * x2 + q.y * z2;
  R.m[0][2] = q.w * y2 + q.z * x2;
  R.m[1][2] = q.z * y2 - q.w * x2;
  R.m[2][2] = T(1) - (q.x * x2 + q.y * y2);
  return R;
}

/// One Mueller 2016 update of the rotation q towards the rotational part of F:
///     omega = sum_i r_i x f_i / (|sum_i r_i . f_i| + 1e-9),   q <- normalise((1, omega/2) q).
/// Branch-free, so a SIMD loop over tets runs it per lane. omega_norm: |omega| (radians).
template <class T>
EBH_HD Quat<T> mueller_update(const Mat3<T>& F, Quat<T> q, T& omega_norm) {
  const Mat3<T> R = rotation_matrix(q);
  Vec3<T> num{};
  T den = T(0);
  for (int i = 0; i < 3; ++i) {
    num += cross(R.col(i), F.col(i));
    den += dot(R.col(i), F.col(i));
  }
  const Vec3<T> omega = num / ((den < T(0) ? -den : den) + T(1e-9));
  omega_norm = norm(omega);
  // exp(omega) to first order, renormalised: still an exact rotation (by angle 2 atan(|omega|/2)
  // instead of |omega|), with no trigonometry; the fixed point is unchanged.
  return normalized(Quat<T>{T(1), omega.x / 2, omega.y / 2, omega.z / 2} * q);
}

/// Rotational part of F by Mueller et al. 2016, warm-started.
///   F         3x3 deformation gradient (any determinant, zero included)
///   q         rotation to start from (e.g. the last step's), unit quaternion (w, x, y, z)
///   max_iter  most axis-angle updates (a few with a warm start; hundreds from identity)
///   tol       stop when the update angle |omega| (radians) falls below it
/// Returns the unit quaternion of R. For F = 0 it returns q unchanged.
template <class T>
EBH_HD Quat<T> extract_rotation(const Mat3<T>& F, Quat<T> q, int max_iter, T tol) {
  for (int it = 0; it < max_iter; ++it) {
    T omega_norm;
    const Quat<T> next = mueller_update(F, q, omega_norm);
    if (omega_norm < tol) break;
    q = next;
  }
  return q;
}

}  // namespace ebh
