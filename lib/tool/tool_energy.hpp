#pragma once
// The virtual tool's energy E_tool = E_tvc [2] + E_con [3] (§4.1, Appendix A) with its exact
// gradient and Hessian.
//
// Parameterisation of every derivative here (and of the Newton step): x = (dP, w) in R^6,
//     pose(x) = (P_g + dP, quat_from_rotvec(w) * Q_g),
// a world-frame translation of the rotation centre and a world-frame incremental rotation vector
// applied to the orientation. The appendix's printed formulas (A.4-A.16) have sign slips; the code
// below is derived from the energies and checked against finite differences (tests/tool).
#include <span>

#include <Eigen/Dense>

#include "math/vec.hpp"
#include "tool/contact.hpp"
#include "tool/grasp.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

/// pose(x) above.
ToolPose perturb(const ToolPose& pose, const Vec6& x);

/// E_tvc [2] = k_vcs/2 |P_g - P_h|^2 + k_vct/2 theta^2, theta = |v|, v = rotvec(R_g R_h^T).
///   gradient:  (k_vcs (P_g - P_h), k_vct v)
///   Hessian:   k_vcs I (+) k_vct [a a^T + (theta/2) cot(theta/2) (I - a a^T)], a = v / theta
///              (the exact Hessian of half the squared geodesic distance on SO(3)).
/// grad/hess may be null.
double coupling_energy(const ToolPose& g, const ToolPose& h, double k_vcs, double k_vct, Vec6* grad, Mat6* hess);

/// Per-contact E_con [3] terms, host/device. For one contact with phi = |q - q_proj| and lever
/// r = lever - P_g:  E = k/2 phi^2,  J = d phi / dx = gain (n, r x n),  grad = k phi J,
///   Hessian = k (J J^T + phi d2phi),  for the closest-point projection (phi = -sd(q) in the
///   collider that moves with the tool; Hf = -hess_sd; B = [I, -[r]x]):
///     d2phi = B^T Hf B + [[0, -[n]x], [[n]x, (n.r) I - (n r^T + r n^T)/2]]
///   and d2phi = 0 (Gauss-Newton) when !exact (the inverse-normal projection).
///   g: 6 values (added to); H: 6x6 row-major (added to); returns the energy.
template <class T>
EBH_HD T contact_terms(T k, T phi, T gain, Vec3<T> n, Vec3<T> r, const Mat3<T>& hess_sd, bool exact, T* g, T* H) {
  const Vec3<T> rn = cross(r, n);
  const T J[6] = {gain * n.x, gain * n.y, gain * n.z, gain * rn.x, gain * rn.y, gain * rn.z};
  for (int i = 0; i < 6; ++i) g[i] += k * phi * J[i];
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) H[6 * i + j] += k * J[i] * J[j];
  if (exact) {
    // B^T Hf B with B = [I, -[r]x]: blocks Hf, -Hf [r]x, [r]x Hf, -[r]x Hf [r]x ([r]x^T = -[r]x).
    const Mat3<T> Hf = T(-1) * hess_sd;
    const Mat3<T> S = skew(r), Sn = skew(n);
    const Mat3<T> A = Hf, Bm = T(-1) * (Hf * S), C = S * Hf, D = T(-1) * (S * Hf * S);
    const T nr = dot(n, r);
    const Mat3<T> Eww = nr * Mat3<T>::identity() - T(0.5) * (outer(n, r) + outer(r, n));
    const T c = k * phi;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        H[6 * i + j] += c * A(i, j);
        H[6 * i + j + 3] += c * (Bm(i, j) - Sn(i, j));
        H[6 * (i + 3) + j] += c * (C(i, j) + Sn(i, j));
        H[6 * (i + 3) + j + 3] += c * (D(i, j) + Eww(i, j));
      }
  }
  return T(0.5) * k * phi * phi;
}

/// E_con [3] of contacts computed at pose P (rotation centre P_g), tissue q held fixed.
/// grad/hess may be null; they are overwritten.
double contact_energy(std::span<const ContactPoint> contacts, const Vec3d& P, double k_con, Vec6* grad, Mat6* hess);

/// Grasp part of E_con [3]: sum k/2 |q_i - (P_g + R_g l_i)|^2 over grasped vertices, with
/// s = R_g l_i, e = q_i - P_g - s:  grad = -k (e, s x e),
///   Hessian = k ([[I, -[s]x], [[s]x, -[s]x^2]] + [[0, 0], [0, (e.s) I - (e s^T + s e^T)/2]]).
/// q: #m virtual positions. grad/hess may be null; they are overwritten.
double grasp_energy(const GraspState& grasp, std::span<const Vec3d> q, const ToolPose& pose, double k_con,
                    Vec6* grad, Mat6* hess);

}  // namespace ebh
