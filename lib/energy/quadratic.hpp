#pragma once
// The point-to-target energies of the model, all (k/2) ||a - b||^2 shaped (paper §3.2), with their
// gradients. Each is a stateless function of plain values; the solvers gather, call and scatter.
#include "math/vec.hpp"

namespace ebh {

/// (k/2) ||a - b||^2: the common shape of E_k, E_svc, E_con.
template <class T>
EBH_HD T spring_energy(Vec3<T> a, Vec3<T> b, T k) {
  return T(0.5) * k * squared_norm(a - b);
}
/// d/da of (k/2) ||a - b||^2 = k (a - b)  (d/db is its negative).
template <class T>
EBH_HD Vec3<T> spring_gradient(Vec3<T> a, Vec3<T> b, T k) {
  return k * (a - b);
}

/// Prediction of Algorithm 1 line 1 / Algorithm 2 line 6: s = x + h v + h^2 g
/// (Newton's first law plus gravity g, the only external force; pinned vertices use s = x).
template <class T>
EBH_HD Vec3<T> predict_position(Vec3<T> x, Vec3<T> v, Vec3<T> g, T h) {
  return x + h * v + (h * h) * g;
}

/// Algorithm 2 line 23, v = (q - q_start) / h, with the virtual mesh's velocity damping: the
/// velocity carried into the next tick's prediction is v / (1 + alpha h), alpha the damping rate
/// (solver.virtual_damping, 1/s; docs/MODEL.md, "Damping of the virtual mesh"). Returns the
/// factor 1 / (h (1 + alpha h)) that multiplies q - q_start; alpha = 0 gives 1 / h exactly.
template <class T>
EBH_HD T tick_velocity_scale(T h, T alpha) {
  return T(1) / (h * (T(1) + alpha * h));
}

/// The first iterate x_0 = x + h v of a physical step and of a haptic tick's virtual-mesh
/// iterations: the prediction without the external forces (docs/MODEL.md, "The iterations'
/// start"). Started from s (Alg. 1 line 2, Alg. 2 line 6), K Jacobi-type iterations have their
/// fixed point off the equilibrium by about (I - T^K)^-1 T^K h^2 g (T the iteration matrix): a
/// mesh at rest keeps an unbalanced force; from x + h v, a mesh at rest in equilibrium stays
/// exactly there.
template <class T>
EBH_HD Vec3<T> iteration_start(Vec3<T> x, Vec3<T> v, T h) {
  return x + h * v;
}

/// E_k [6] of one vertex: 1/(2 h^2) m ||x - s||^2 (mass m, step h, prediction s).
template <class T>
EBH_HD T inertia_energy(Vec3<T> x, Vec3<T> s, T mass, T h) {
  return spring_energy(x, s, mass / (h * h));
}
/// dE_k/dx = m / h^2 (x - s).
template <class T>
EBH_HD Vec3<T> inertia_gradient(Vec3<T> x, Vec3<T> s, T mass, T h) {
  return spring_gradient(x, s, mass / (h * h));
}

/// The physical point p = sum_i w_i x_i that virtual vertex q is paired with in E_svc [5].
///   x: physical positions, idx[count]/w[count]: paired physical vertices and weights (sum 1).
template <class T>
EBH_HD Vec3<T> paired_point(const Vec3<T>* x, const int* idx, const T* w, int count) {
  Vec3<T> p{};
  for (int i = 0; i < count; ++i) p += w[i] * x[idx[i]];
  return p;
}

/// E_svc [5]: (k_svc/2) ||p - q||^2 between the physical point p and the virtual vertex q.
template <class T>
EBH_HD T coupling_energy(Vec3<T> p, Vec3<T> q, T k_svc) {
  return spring_energy(p, q, k_svc);
}
/// dE_svc/dq = k_svc (q - p)  (on the virtual mesh p is held fixed).
template <class T>
EBH_HD Vec3<T> coupling_gradient_virtual(Vec3<T> p, Vec3<T> q, T k_svc) {
  return spring_gradient(q, p, k_svc);
}
/// dE_svc/dx_i = k_svc w_i (p - q)  (on the physical mesh q is held fixed).
template <class T>
EBH_HD Vec3<T> coupling_gradient_physical(Vec3<T> p, Vec3<T> q, T k_svc, T w_i) {
  return spring_gradient(p, q, k_svc * w_i);
}

/// E_con [3] on the virtual mesh (tool held fixed): (k/2) ||q - target||^2, target = q_proj.
template <class T>
EBH_HD T contact_energy(Vec3<T> q, Vec3<T> target, T k) {
  return spring_energy(q, target, k);
}
/// dE_con/dq = k (q - target).
template <class T>
EBH_HD Vec3<T> contact_gradient(Vec3<T> q, Vec3<T> target, T k) {
  return spring_gradient(q, target, k);
}

}  // namespace ebh
