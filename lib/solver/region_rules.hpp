#pragma once
// The active region's per-vertex rules (docs/MODEL.md, "The active region"), host/device: the CPU
// region (solver/active_region.cpp, per vertex, double) and the device tick's region
// (schedule/haptic_cuda_vertices.cuh, per chunk of vertices, float32) call these.
//
// A vertex out of the region stands at its E_svc point p plus an offset: its own weight's stretch
// of the coupling spring, m g / k_svc, at first, plus the displacement it left the region with.
// Its displacement d = q - (p + offset) is measured from there, so that a vertex that settled off
// its target is not displaced.
#include "math/hd.hpp"
#include "math/vec.hpp"

namespace ebh {

/// Ticks a vertex (the CPU) or a chunk (the device) must stay calm before it leaves the region: 2
/// physical periods at the default rates, so that one the tool keeps nudging does not flicker in
/// and out. A vertex is moving when its displacement changes by more than tol / kCalmTicks in a
/// tick: one that crept at that rate through its calm ticks moved at most tol.
inline constexpr int kCalmTicks = 20;

/// Where a vertex that was never in the region stands from its E_svc point: its weight's stretch
/// of the coupling spring, (m / k_svc) g (its static equilibrium against E_svc alone).
template <class T>
EBH_HD Vec3<T> rest_offset(T mass, T k_svc, Vec3<T> gravity) {
  return (mass / k_svc) * gravity;
}

/// A vertex's motion over a tick at tolerance tol from its displacement d now and d_before a tick
/// before: moving, d changed by more than tol / kCalmTicks; hot, moving and displaced by more
/// than tol (a hot vertex spreads the region to its neighbours).
struct RegionMotion {
  bool moving = false, hot = false;
};
template <class T>
EBH_HD RegionMotion region_motion(Vec3<T> d, Vec3<T> d_before, T tol) {
  const T step = tol / kCalmTicks;
  RegionMotion r;
  r.moving = squared_norm(d - d_before) > step * step;
  r.hot = r.moving && squared_norm(d) > tol * tol;
  return r;
}

/// The strain check of a vertex out of the region: whether `force`, the sum of its edges' E_s [4]
/// forces, its E_svc [5] spring's and its weight where it stands, moves it by more than tol in a
/// static Jacobi step, |force| / stiff > tol, with stiff = k_s degree + k_svc.
template <class T>
EBH_HD bool pulled_off(Vec3<T> force, T stiff, T tol) {
  return squared_norm(force) > tol * tol * stiff * stiff;
}

}  // namespace ebh
