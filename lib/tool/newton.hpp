#pragma once
// The virtual tool's Newton call (virtual_tool.hpp gives the method), the parts both backends
// share: the step limits and what one call can reach, the line search's constants and tests, and
// the trial pose. The CPU (virtual_tool.cpp) and the device tick (schedule/haptic_cuda.cu) run
// the same iteration on them, each with its own 6x6 algebra (Eigen in double; newton_warp.cuh).
#include <algorithm>
#include <numbers>

#include "math/hd.hpp"
#include "math/vec.hpp"
#include "scene/scene.hpp"

namespace ebh {

/// The Armijo line search halves a step at most this many times; a step that fails them all is
/// not taken (the call ends, counted as rejected).
inline constexpr int kNewtonMaxHalvings = 12;
/// Armijo's sufficient-decrease factor.
inline constexpr double kArmijo = 1e-4;
/// A step whose predicted decrease is below this fraction of E_tool is below round-off of E: no
/// halving could show it, so the call has converged.
inline constexpr double kNewtonConverged = 1e-13;
/// A step shorter than this (times |P_g| + 1 mm, in metres; and in radians) moves the pose by
/// round-off only: it counts as converged rather than as 12 halvings ending in a rejected step.
inline constexpr double kNewtonStepFloor = 1e-14;

/// The step limits of one Newton call and what they let it reach (ToolSpec).
struct NewtonLimits {
  int iterations = 1;      ///< Newton steps per call (spec.newton_iterations, at least 1)
  double max_step = 0;     ///< m, |dP| of one step
  double max_rot = 0;      ///< rad, |w| of one step
  double reach_translation = 0;  ///< m, iterations * max_step
  double reach_rotation = 0;     ///< rad, iterations * max_rot, at most 0.5 (the bound below needs < 1)
};
inline NewtonLimits newton_limits(const ToolSpec& spec) {
  NewtonLimits l;
  l.iterations = std::max(1, spec.newton_iterations);
  l.max_step = spec.max_step;
  l.max_rot = spec.max_step_rotation_deg * std::numbers::pi / 180.0;
  l.reach_translation = l.iterations * l.max_step;
  l.reach_rotation = std::min(l.iterations * l.max_rot, 0.5);
  return l;
}

/// What `calls` Newton calls in a row can reach from the pose before them (the active region's
/// seeds on the CPU, its chunks' wake on the device): calls times one call's translation and
/// rotation, the rotation at most 0.5 as above.
struct NewtonReach {
  double translation = 0, rotation = 0;
};
inline NewtonReach newton_reach_of_calls(const NewtonLimits& l, int calls) {
  return {calls * l.reach_translation, std::min(calls * l.reach_rotation, 0.5)};
}

/// How close (a signed distance) a collider point can come to a point at distance r from the tool
/// origin within one Newton call that translates by at most T and turns by at most th (rad): a
/// vertex farther from every collider than this is no candidate of the call.
template <class T>
EBH_HD T newton_reach_bound(T translation, T rotation, T r) {
  return (translation + rotation * (r + translation)) / (T(1) - rotation);
}

/// Whether a Newton step with slope g.dx still predicts a decrease that E (= E_tool) can show.
template <class T>
EBH_HD bool newton_decrease_visible(T slope, T E) {
  return slope < -T(kNewtonConverged) * fmax(E, T(1e-300));
}

/// Whether a step of length step_t (m) and step_r (rad) from position P moves the pose by
/// round-off only (kNewtonStepFloor).
template <class T>
EBH_HD bool newton_step_roundoff(T step_t, T step_r, Vec3<T> P) {
  return step_t <= T(kNewtonStepFloor) * (norm(P) + T(1e-3)) && step_r <= T(kNewtonStepFloor);
}

/// Armijo's test of the trial at alpha times the step: E_trial <= E + kArmijo alpha slope.
template <class T>
EBH_HD bool armijo_accepts(T E_trial, T E, T alpha, T slope) {
  return E_trial <= E + T(kArmijo) * alpha * slope;
}

/// The trial orientation normalized(quat_from_rotvec(w) * Q) of the step w, as the CPU computes
/// it (quat_from_rotvec's trigonometry, normalized by a division).
template <class T>
EBH_HD Quat<T> trial_orientation(Vec3<T> w, Quat<T> Q) {
  return normalized(quat_from_rotvec(w) * Q);
}

#if defined(__CUDACC__)
/// trial_orientation as the device tick computes it, for its latency: a Newton step turns the tool
/// by at most max_rot (0.5 deg in the scenes), so below 0.01 rad the half angle's cosine and
/// sin(x) / x come from their Taylor series (x = |w| / 2 < 0.005: truncation below 1e-24, far under
/// double round-off), with no range reduction, square root or division; larger turns take the
/// trigonometry; the product is normalized by a reciprocal square root. Equal to
/// trial_orientation up to round-off (not bitwise).
__device__ inline Quatd trial_orientation_series(Vec3d w, Quatd Q) {
  const double a2 = dot(w, w);
  Quatd r;
  if (a2 < 1e-4) {
    const double x2 = 0.25 * a2;
    const double c = 1.0 + x2 * (-1.0 / 2 + x2 * (1.0 / 24 + x2 * (-1.0 / 720 + x2 * (1.0 / 40320))));
    const double s = 0.5 * (1.0 + x2 * (-1.0 / 6 + x2 * (1.0 / 120 + x2 * (-1.0 / 5040))));  // sin(x) / (2x)
    r = Quatd{c, s * w.x, s * w.y, s * w.z};
  } else {
    r = quat_from_rotvec(w);
  }
  const Quatd q = r * Q;
  const double inv = rsqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return Quatd{q.w * inv, q.x * inv, q.y * inv, q.z * inv};
}
#endif

}  // namespace ebh
