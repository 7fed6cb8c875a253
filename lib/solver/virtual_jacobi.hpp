#pragma once
// One virtual vertex's Jacobi step on E_k [6] + E_svc [5] + E_con [3] + E_s [4] (Algorithm 2 lines
// 11-16), host/device: the CPU iteration (virtual_mesh.cpp, double), the CUDA iteration
// (virtual_mesh.cu, float32) and the device tick (schedule/haptic_cuda.cu, float32) gather and
// call these:
//     q_j <- q_j + r_j / D_j,   r = -grad E (the residual),   D = m/h^2 + k_s deg + k_svc + sum k_con,
// with the residual's parts
//     -dE_k/dq   = m/h^2 (s - q)                      (s: the prediction)
//     -dE_svc/dq = -k_svc (q - p)                     (p: the paired physical point)
//     -dE_con/dq = kt - ck q                          (kt = sum k_con target, ck = sum k_con; 0 without contact)
//     -dE_s/dq   = +-g per incident edge              (g: the edge's spring gradient, + at its second end)
//
// The contact term enters in two places, so two updates: the CPU and CUDA iterations add it to the
// residual before the edges and divide (jacobi_update); the device tick adds it after the edges
// and multiplies by a reciprocal (jacobi_update_with_contact), because it knows the contact only
// once the edges are summed (a pipelined step's contact waits for the virtual tool's Newton call).
// The two round differently (not bitwise equal); each backend keeps its own.
#include "energy/quadratic.hpp"
#include "math/hd.hpp"
#include "math/vec.hpp"

namespace ebh {

/// -dE_k/dq - dE_svc/dq of vertex q with mh = m/h^2, prediction s and paired point p.
template <class T>
EBH_HD Vec3<T> inertia_coupling_residual(T mh, Vec3<T> s, Vec3<T> q, Vec3<T> p, T k_svc) {
  return mh * (s - q) - coupling_gradient_virtual(p, q, k_svc);  // [6], [5]
}

/// r - dE_con/dq: the contact sums kt = sum k target, ck = sum k added to the residual r.
template <class T>
EBH_HD Vec3<T> add_contact_residual(Vec3<T> r, Vec3<T> kt, T ck, Vec3<T> q) {
  return r + kt - ck * q;  // [3]
}

/// r - dE_s/dq of one incident edge with spring gradient g; second: q is the edge's second end.
template <class T>
EBH_HD void add_edge_residual(Vec3<T>& r, Vec3<T> g, bool second) {
  r += second ? g : -g;  // [4]
}

/// The Jacobi update q + r / D, the contact already in r and D.
template <class T>
EBH_HD Vec3<T> jacobi_update(Vec3<T> q, Vec3<T> r, T D) {
  return q + r / D;
}

/// The Jacobi update with the contact (kt, ck) added after the edges: q + (r + kt - ck q) / D_all,
/// by one reciprocal; D_all = D + ck (the caller passes 1 for a pinned vertex, whose result it
/// discards, so that no division by zero is taken).
template <class T>
EBH_HD Vec3<T> jacobi_update_with_contact(Vec3<T> q, Vec3<T> r, Vec3<T> kt, T ck, T D_all) {
  return q + (r + (kt - ck * q)) * (T(1) / D_all);
}

}  // namespace ebh
