#pragma once
// E_s [4]: a virtual-mesh edge keeps its rest length,
//     E_s = (k_s / 2) ||q1 - q2 - R (q1^0 - q2^0)||^2,
// with R the rotation taking the rest edge direction onto the current one, so that
// R (q1^0 - q2^0) = L0 d / |d| (d = q1 - q2, L0 = |q1^0 - q2^0|): a spring of rest length L0.
// As with E_vol, R minimises the energy over rotations, so dE_s/dq1 = k_s (d - L0 d/|d|).
#include "math/vec.hpp"

namespace ebh {

/// Local step of E_s: the projected edge vector R (q1^0 - q2^0) for the current edge d = q1 - q2.
///   rest_edge: q1^0 - q2^0, rest_len: |rest_edge| (precomputed by the solvers).
///   For a collapsed edge (|d| = 0) R = I: the rest edge itself. Written as a select, so a SIMD
///   loop over edges runs it per lane.
/// True when the edge d has collapsed (|d| <= 1e-12 rest_len): edge_target returns the rest edge.
template <class T>
EBH_HD bool edge_collapsed(Vec3<T> d, T rest_len) {
  return norm(d) <= rest_len * T(1e-12);
}
template <class T>
EBH_HD Vec3<T> edge_target(Vec3<T> d, Vec3<T> rest_edge, T rest_len) {
  const T len = norm(d);
  const T s = rest_len / len;
  const bool collapsed = len <= rest_len * T(1e-12);  // edge_collapsed
  return {collapsed ? rest_edge.x : s * d.x, collapsed ? rest_edge.y : s * d.y, collapsed ? rest_edge.z : s * d.z};
}
template <class T>
EBH_HD Vec3<T> edge_target(Vec3<T> d, Vec3<T> rest_edge) {
  return edge_target(d, rest_edge, norm(rest_edge));
}

/// E_s [4] of one edge.
template <class T>
EBH_HD T edge_spring_energy(Vec3<T> q1, Vec3<T> q2, Vec3<T> rest_edge, T k_s) {
  const Vec3<T> d = q1 - q2;
  return T(0.5) * k_s * squared_norm(d - edge_target(d, rest_edge));
}

/// dE_s/dq1 = k_s (d - R e0); dE_s/dq2 is its negative. rest_len: |rest_edge|.
template <class T>
EBH_HD Vec3<T> edge_spring_gradient(Vec3<T> q1, Vec3<T> q2, Vec3<T> rest_edge, T rest_len, T k_s) {
  const Vec3<T> d = q1 - q2;
  return k_s * (d - edge_target(d, rest_edge, rest_len));
}
template <class T>
EBH_HD Vec3<T> edge_spring_gradient(Vec3<T> q1, Vec3<T> q2, Vec3<T> rest_edge, T k_s) {
  return edge_spring_gradient(q1, q2, rest_edge, norm(rest_edge), k_s);
}

}  // namespace ebh
