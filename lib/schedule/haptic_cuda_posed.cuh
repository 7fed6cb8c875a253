#pragma once
// The device haptic tick's posed tool (part of haptic_cuda.cu's translation unit): posing the
// colliders for a pose and jaw opening, the float32 early-outs and reach tests against their
// bounding capsules, and the exact double queries (contact.hpp's narrow phase).
#include "schedule/haptic_cuda_layout.cuh"
#include "tool/collider.hpp"
#include "tool/contact.hpp"
#include "tool/newton.hpp"

namespace ebh {
namespace {

/// Whether x may lie within `margin` of posed collider c: float32, no division or square root (the
/// distance to its bounding capsule, a lower bound of the signed distance, against margin + radius,
/// squared). An early-out for the exact double tests: false means certainly farther than margin
/// less float round-off (~1e-7 m on tool-sized coordinates; callers add kFloatSlack).
__device__ bool capsule_within(const Posed& p, int c, Vec3f x, float margin) {
  const Vec3f v = x - p.seg_a[c];
  const float s = fminf(fmaxf(dot(v, p.seg_u[c]), 0.f), p.seg_len[c]);
  const Vec3f d = v - s * p.seg_u[c];
  const float reach = fmaxf(p.seg_r[c] + margin, 0.f);
  return dot(d, d) <= reach * reach;
}

/// Whether x may lie within `margin` of any posed collider (capsule_within).
__device__ bool maybe_within(const ToolConst& t, const Posed& p, Vec3f x, float margin) {
  for (int c = 0; c < t.count; ++c)
    if (capsule_within(p, c, x, margin)) return true;
  return false;
}

/// maybe_within per collider: bit c set when x may lie within `margin` of posed collider c (a clear
/// bit: certainly farther, so the exact double tests skip that collider).
__device__ unsigned near_colliders(const ToolConst& t, const Posed& p, Vec3f x, float margin) {
  unsigned mask = 0;
  for (int c = 0; c < t.count; ++c)
    if (capsule_within(p, c, x, margin)) mask |= 1u << c;
  return mask;
}

/// The candidate bound (newton.hpp: newton_reach_bound) for a point at distance r from the tool
/// origin, plus float slack: one Newton call moves no collider point nearer to the point than its
/// distance less this bound.
__device__ float reach_bound(const ToolConst& t, float r) {
  return newton_reach_bound(t.reach_T, t.reach_th, r) + kFloatSlack;
}

/// |x - tool origin|, rounded up.
__device__ float origin_distance(const Posed& p, Vec3f x) {
  const Vec3f o = x - p.origin_f;
  const float d2 = dot(o, o);
  return d2 > 0.f ? d2 * rsqrtf(d2) * 1.000001f : 0.f;
}

/// Whether the virtual tool's next Newton call, from the pose of `p`, can reach x (virtual_tool.cpp's
/// per-vertex bound): in float32 with kFloatSlack, a superset of the double test's vertices (the
/// exact contact tests on them decide), so no result depends on the rounding.
__device__ bool reachable(const ToolConst& t, const Posed& p, Vec3f x) {
  return maybe_within(t, p, x, reach_bound(t, origin_distance(p, x)));
}

/// The reach tests of a pipelined step's vertex (vertex_step<true>) at its iterate q, in one pass
/// over the colliders posed at the pose before the Newton call that runs beside the step; its step
/// moves it to qn, |qn - q| <= delta.
///   defer: reachable(q), whether the call can bring the tool into contact with q;
///   superset: a superset of reachable(qn) at every pose one call away (within reach_T and
///     reach_th): such a pose's origin lies within reach_T, so qn's distance to it within
///     |q - origin| + delta + reach_T; a point of collider c's segment moves by at most
///     reach_T + reach_th seg_L[c]; and qn lies within delta of q.
__device__ void ahead_reach(const ToolConst& t, const Posed& p, Vec3f q, float delta, bool& defer, bool& superset) {
  const float r = origin_distance(p, q);
  const float b = reach_bound(t, r);
  const float b2 = reach_bound(t, r + delta + t.reach_T) + t.reach_T + delta + 2.f * kFloatSlack;
  defer = superset = false;
  for (int c = 0; c < t.count; ++c) {  // capsule_within at two margins
    const Vec3f v = q - p.seg_a[c];
    const float s = fminf(fmaxf(dot(v, p.seg_u[c]), 0.f), p.seg_len[c]);
    const Vec3f d = v - s * p.seg_u[c];
    const float d2 = dot(d, d);
    const float r1 = fmaxf(p.seg_r[c] + b, 0.f), r2 = p.seg_r[c] + b2 + t.reach_th * t.seg_L[c];
    defer = defer || d2 <= r1 * r1;
    superset = superset || d2 <= r2 * r2;
  }
}

// The narrow phase and the posing of a collider are __noinline__: one copy each in the kernel,
// which the Newton call, its line search, block 0's vertices and the vertex blocks share, so that
// block 0's code stays small enough for its instruction cache (inlined at every call site, its
// warps stall on instruction fetch).

/// Signed distance of q (world) to collider c posed at w.
__device__ __noinline__ double collider_sd(const Collider<double>& c, const Rigid<double>& w, Vec3d q) {
  return signed_distance_local(c, apply_inverse(w, q));
}

/// deepest_collider (contact.hpp) of q against the colliders posed in p, those of `near` only.
__device__ __noinline__ int deepest_query(const ToolConst& t, const Posed& p, Vec3d q, unsigned near,
                                          SurfaceQuery<double>& sq) {
  return deepest_collider(t.shape, p.world, t.count, q, sq, near);
}

/// The depth of q in the colliders of `near` posed in p, 0 outside them (deepest_collider's first
/// pass: the signed distances alone).
__device__ double penetration(const ToolConst& t, const Posed& p, Vec3d q, unsigned near) {
  double sd = 0;
  for (int c = 0; c < t.count; ++c)
    if ((near >> c) & 1u) sd = fmin(sd, collider_sd(t.shape[c], p.world[c], q));
  return -sd;
}

/// Collider c of pose_tool (tool_model.cpp) on the device; (jc, js): cos and sin of the jaws'
/// opening angle (DeviceTickInput). Threads 0 .. count-1 each pose one collider.
__device__ __noinline__ void pose_collider(const ToolConst& t, Vec3d P, Quatd Q, double jc, double js, int c,
                                           Posed& out) {
  Rigid<double> frame;
  frame.R = to_matrix(Q);
  frame.t = P;
  out.world[c] = collider_world(frame, t.shape[c].frame, jc, js);
  const Vec3d A = apply(out.world[c], static_cast<Vec3d>(t.seg_a[c]));
  const Vec3d B = apply(out.world[c], static_cast<Vec3d>(t.seg_b[c]));
  const double len = norm(B - A);
  out.seg_a[c] = static_cast<Vec3f>(A);
  out.seg_u[c] = len > 0 ? static_cast<Vec3f>((1.0 / len) * (B - A)) : Vec3f{};
  out.seg_len[c] = static_cast<float>(len);
  out.seg_r[c] = t.seg_r[c];
  if (c == 0) {
    out.frame = frame;
    out.origin_f = static_cast<Vec3f>(P);
  }
}

/// The whole posed tool, by threads first .. first + count - 1 (callers synchronise after it).
__device__ void pose_colliders(const ToolConst& t, Vec3d P, Quatd Q, const DeviceTickInput& in, Posed& out,
                               int first = 0) {
  const int c = static_cast<int>(threadIdx.x) - first;
  if (c >= 0 && c < t.count) pose_collider(t, P, Q, in.jaw_cos, in.jaw_sin, c, out);
}

}  // namespace
}  // namespace ebh
