#pragma once
// The virtual tool's energy terms, one per function, host/device (EBH_HD): E_tvc [2] and the output
// force and torque, E_con [3] of one contact, the grasp part of E_con (eq. [10]) of one grasped
// vertex, and the grasp's weight and target. Plain values in, values out: the CPU (tool_energy.cpp,
// virtual_tool.cpp, grasp.cpp) and the device tick (schedule/haptic_cuda.cu) gather, call and sum.
//
// Parameterisation of every derivative (tool_energy.hpp): x = (dP, w) in R^6,
//     pose(x) = (P_g + dP, quat_from_rotvec(w) * Q_g).
// Gradients are 6 values, Hessians 6x6 row-major; both are added to.
//
// Two terms are rounded differently on the two backends (the same value up to the last bits).
// Each backend keeps its own rounding, named below, so that both stay bitwise reproducible
// against their earlier results:
//   CouplingAngle    how E_tvc squares theta = |v|
//   GraspRotation    how the grasp Hessian's rotation block adds its two parts
#include <limits>

#include "math/hd.hpp"
#include "math/vec.hpp"
#include "tool/collider.hpp"

namespace ebh {

// ---- E_tvc [2] = k_vcs/2 |P_g - P_h|^2 + k_vct/2 theta^2, theta = |v|, v = rotvec(R_g R_h^T) ----

/// The coupling's offsets: dP = P_g - P_h and v = rotvec(R_g R_h^T) (world frame).
template <class T>
struct CouplingOffset {
  Vec3<T> dP;
  Vec3<T> v;
};
template <class T>
EBH_HD CouplingOffset<T> coupling_offset(Vec3<T> Pg, Quat<T> Qg, Vec3<T> Ph, Quat<T> Qh) {
  return {Pg - Ph, rotvec_from_quat(normalized(Qg * conjugate(Qh)))};
}

/// dE_tvc/dx = (k_vcs dP, k_vct v), into g[6] (overwritten): the force and torque on the device.
template <class T>
EBH_HD void coupling_gradient(const CouplingOffset<T>& o, T k_vcs, T k_vct, T* g) {
  g[0] = k_vcs * o.dP.x; g[1] = k_vcs * o.dP.y; g[2] = k_vcs * o.dP.z;
  g[3] = k_vct * o.v.x; g[4] = k_vct * o.v.y; g[5] = k_vct * o.v.z;
}

/// How E_tvc's k_vct/2 theta^2 is rounded: the CPU squares theta = |v| (OfNorm); the device tick
/// sums v's squared components, without the square root (OfComponents). The Armijo test compares
/// these energies, so each backend's line search keeps its own.
enum class CouplingAngle { OfNorm, OfComponents };

template <CouplingAngle kAngle, class T>
EBH_HD T coupling_energy_value(const CouplingOffset<T>& o, T k_vcs, T k_vct) {
  if constexpr (kAngle == CouplingAngle::OfNorm) {
    const T theta = norm(o.v);
    return T(0.5) * k_vcs * squared_norm(o.dP) + T(0.5) * k_vct * theta * theta;
  } else {
    return T(0.5) * k_vcs * squared_norm(o.dP) + T(0.5) * k_vct * squared_norm(o.v);
  }
}

/// E_tvc at (Pg, Qg) against (Ph, Qh), its gradient into g[6].
template <CouplingAngle kAngle, class T>
EBH_HD T coupling_terms(Vec3<T> Pg, Quat<T> Qg, Vec3<T> Ph, Quat<T> Qh, T k_vcs, T k_vct, T* g) {
  const CouplingOffset<T> o = coupling_offset(Pg, Qg, Ph, Qh);
  coupling_gradient(o, k_vcs, k_vct, g);
  return coupling_energy_value<kAngle>(o, k_vcs, k_vct);
}

/// Scales v down to length `limit` when it is longer (limit > 0: the device's force or torque
/// limit); returns whether it did. A v whose squared length overflows (a coupling force from a lag
/// beyond ~1e154 m in double, ~6e16 m in float) keeps its direction: it is first divided by its
/// largest component, so the clamp gives `limit`, not 0.
template <class T>
EBH_HD bool clamp_length(Vec3<T>& v, T limit) {
  const T n = norm(v);
  if (!(limit > T(0) && n > limit)) return false;
  if (n <= std::numeric_limits<T>::max()) {
    v = (limit / n) * v;
  } else {
    const T largest = T(fmax(fmax(fabs(v.x), fabs(v.y)), fabs(v.z)));  // exact in T
    const Vec3<T> u = (T(1) / largest) * v;
    v = (limit / norm(u)) * u;
  }
  return true;
}

/// Algorithm 2 lines 26-27: F = dE_tvc/dP_g, T = dE_tvc/dw_g at the virtual tool's final pose,
/// each clamped to its limit (0: none).
template <class T>
struct CouplingOutput {
  Vec3<T> force{}, torque{};
  bool force_clamped = false, torque_clamped = false;
};
template <class T>
EBH_HD CouplingOutput<T> coupling_output(Vec3<T> Pg, Quat<T> Qg, Vec3<T> Ph, Quat<T> Qh, T k_vcs, T k_vct,
                                         T force_limit, T torque_limit) {
  T g[6];
  coupling_gradient(coupling_offset(Pg, Qg, Ph, Qh), k_vcs, k_vct, g);
  CouplingOutput<T> o;
  o.force = Vec3<T>{g[0], g[1], g[2]};
  o.torque = Vec3<T>{g[3], g[4], g[5]};
  o.force_clamped = clamp_length(o.force, force_limit);
  o.torque_clamped = clamp_length(o.torque, torque_limit);
  return o;
}

// ---- E_con [3] of one contact -------------------------------------------------------------------

/// One contact with phi = |q - q_proj| and lever r = lever - P_g:  E = k/2 phi^2,
/// J = d phi / dx = gain (n, r x n),  grad = k phi J,  Hessian = k (J J^T + phi d2phi),  for the
/// closest-point projection (phi = -sd(q) in the collider that moves with the tool; Hf = -hess_sd;
/// B = [I, -[r]x]):
///     d2phi = B^T Hf B + [[0, -[n]x], [[n]x, (n.r) I - (n r^T + r n^T)/2]]
/// and d2phi = 0 (Gauss-Newton) when !exact (the inverse-normal projection).
/// g: 6 values (added to); H: 6x6 row-major (added to); returns the energy.
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

// ---- The grasp part of E_con [3], eq. [10] ---------------------------------------------------------

/// w(d) = 1 / (1 + eta e^d), eq. [10]; d dimensionless (signed distance / soft margin).
template <class T>
EBH_HD T grasp_weight(T d, T eta) {
  return T(1) / (T(1) + eta * exp(d));
}

/// Whether a vertex at signed distance sd from the grasp's hard box is grasped (§5.2).
template <class T>
EBH_HD bool grasp_reaches(T sd, T soft_margin) {
  return sd <= soft_margin;
}

/// A grasped vertex's target in the virtual tool frame, l_g = w l_f + (1 - w) l_s (eq. [10]), and w.
template <class T>
struct GraspPoint {
  Vec3<T> local;
  T weight;
};
/// l_s: the vertex in the tool frame at the grasp, sd its signed distance to the hard box hb (tool
/// frame); l_f: l_s flattened onto the jaw plane x = 0 and clamped to the box's y-z extent.
template <class T>
EBH_HD GraspPoint<T> grasp_point(const Collider<T>& hb, Vec3<T> ls, T sd, T soft_margin, T eta) {
  const T w = grasp_weight(sd / soft_margin, eta);
  const Vec3<T> lf{T(0), clamp_between(ls.y, hb.a.y - hb.half.y, hb.a.y + hb.half.y),
                   clamp_between(ls.z, hb.a.z - hb.half.z, hb.a.z + hb.half.z)};
  return {w * lf + (T(1) - w) * ls, w};
}

/// One grasped vertex q with target l (tool frame) at the tool pose (R_g, P_g): s = R_g l and
/// e = q - P_g - s, so that E = k/2 |e|^2.
template <class T>
struct GraspOffset {
  Vec3<T> s, e;
};
template <class T>
EBH_HD GraspOffset<T> grasp_offset(const Mat3<T>& Rg, Vec3<T> Pg, Vec3<T> l, Vec3<T> q) {
  const Vec3<T> s = Rg * l;
  return {s, q - Pg - s};
}

/// k/2 |e|^2 of one grasped vertex.
template <class T>
EBH_HD T grasp_energy_term(T k, const GraspOffset<T>& o) {
  return T(0.5) * k * squared_norm(o.e);
}

/// How the grasp Hessian's rotation block adds its two parts -k [s]x^2 and k Eww: the CPU in two
/// steps, H - (k [s]x) [s]x, then + k Eww (Split); the device tick in one, H + k (Eww - [s]x [s]x)
/// (Fused).
enum class GraspRotation { Split, Fused };

/// The derivatives of one grasped vertex's k/2 |e|^2:
///   grad = -k (e, s x e),
///   Hessian = k ([[I, -[s]x], [[s]x, -[s]x^2]] + [[0, 0], [0, Eww]]),  Eww = (e.s) I - (e s^T + s e^T)/2,
/// added to g (6) and H (6x6 row-major).
template <GraspRotation kRotation, class T>
EBH_HD void grasp_derivative_terms(T k, const GraspOffset<T>& o, T* g, T* H) {
  const Vec3<T> s = o.s, r = o.e;
  const Vec3<T> sr = cross(s, r);
  g[0] -= k * r.x; g[1] -= k * r.y; g[2] -= k * r.z;
  g[3] -= k * sr.x; g[4] -= k * sr.y; g[5] -= k * sr.z;
  const Mat3<T> S = skew(s);
  const Mat3<T> Eww = dot(r, s) * Mat3<T>::identity() - T(0.5) * (outer(r, s) + outer(s, r));
  if constexpr (kRotation == GraspRotation::Fused) {
    const Mat3<T> SS = S * S;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        H[6 * a + b] += k * (a == b ? T(1) : T(0));
        H[6 * a + b + 3] -= k * S(a, b);
        H[6 * (a + 3) + b] += k * S(a, b);
        H[6 * (a + 3) + b + 3] += k * (Eww(a, b) - SS(a, b));
      }
  } else {
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        H[6 * a + b] += k * (a == b ? T(1) : T(0));
        H[6 * a + b + 3] -= k * S(a, b);
        H[6 * (a + 3) + b] += k * S(a, b);
        H[6 * (a + 3) + b + 3] -= k * S(a, 0) * S(0, b) + k * S(a, 1) * S(1, b) + k * S(a, 2) * S(2, b);
        H[6 * (a + 3) + b + 3] += k * Eww(a, b);
      }
  }
}

}  // namespace ebh
