#pragma once
// Surface contact in the device haptic tick (part of haptic_cuda.cu's translation unit; scene key
// `contact: surface`, tool/surface_contact.hpp; docs/CUDA.md, "Surface contact"): E_con [3] on
// the sample points of the virtual mesh's triangles instead of its vertices. The samples' math is
// the CPU's (tool/surface_samples.hpp); here it is gathered per vertex (the virtual mesh's
// Jacobi step) and per triangle (the Newton call's candidates, the penetration metric).
#include "energy/quadratic.hpp"
#include "schedule/haptic_cuda_layout.cuh"
#include "schedule/haptic_cuda_posed.cuh"
#include "tool/surface_samples.hpp"
#include "tool/tool_terms.hpp"

namespace ebh {
namespace {

/// Vertex a's position in this step's iteration as vertex_step's edges read it: its iterate, or on
/// a tick's first step its prediction (Alg. 2 line 6).
__device__ Vec3f iterate_of(const MeshDev& d, const Vec3f* qin, bool first, int a) {
  const Vec3f x = qin[a];
  if (!first || d.model.pinned[a]) return x;
  return predict_position(x, d.v[a], d.gravity, d.h);
}

/// Whether vertex a (at its iterate s_a) is held in this step, as its own thread decides it in
/// vertex_step: on a grasp event's first step that thread writes d.held[a] beside this read, so the
/// decision is recomputed here (the same expression).
__device__ bool held_in_step(const MeshDev& d, const ToolConst& t, const Posed& posed, const DeviceTickInput& in,
                             bool first, int a, Vec3f s_a) {
  if (first && in.grasp < 0) return false;
  if (first && in.grasp > 0) {
    const Collider<double>& hb = d.grasp_boxes[in.grasp - 1];
    return grasp_reaches(signed_distance_local(hb, apply_inverse(posed.frame, static_cast<Vec3d>(s_a))), t.soft_margin);
  }
  return d.held[a] != 0;
}

/// E_con [3] of vertex j with surface contact against the tool posed in `posed` (Alg. 2 line 10,
/// surface_contact.hpp): each sample y of j's triangles inside a collider pulls j towards
/// q_j + (y_proj - y) with stiffness w k_con b_j (y_proj: the deepest collider's closest point).
/// The triangles in SurfaceContactModel::tri_entries' order, each one's samples in
/// for_each_sample's; k times the targets summed into kt, the stiffnesses into ck (in double, then
/// rounded). A triangle with a held corner carries no samples (the CPU's `excluded`). Returns the
/// targets' count.
__device__ int surface_contact_target(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& posed,
                                      const DeviceTickInput& in, bool first, int j, Vec3f q, const Vec3f* qin,
                                      Vec3f& kt, float& ck) {
  Vec3d kt_sum{};
  double ck_sum = 0;
  int count = 0;
  const Vec3d qj = static_cast<Vec3d>(q);
  for (int e = sd.tri_offsets[j]; e < sd.tri_offsets[j + 1]; ++e) {
    const int4 tri = sd.tri[sd.tri_entries[e]];
    const int v[3] = {tri.x, tri.y, tri.z};
    Vec3f x[3];
    bool held = false;
    int cj = 0;
    for (int k = 0; k < 3; ++k) {
      if (v[k] == j) {
        x[k] = q;
        cj = k;
      } else {
        x[k] = iterate_of(d, qin, first, v[k]);
        held = held || held_in_step(d, t, posed, in, first, v[k], x[k]);
      }
    }
    if (held) continue;
    const Vec3d a = static_cast<Vec3d>(x[0]), b = static_cast<Vec3d>(x[1]), c = static_cast<Vec3d>(x[2]);
    Vec3d mid;
    const double R = triangle_bounding_sphere(a, b, c, mid);
    // Every sample lies within R of the centroid (float early-out; the double queries decide).
    if (!maybe_within(t, posed, static_cast<Vec3f>(mid), static_cast<float>(R) + kFloatSlack)) continue;
    const int n = surface_sample_level(tri.w, sd.spacing, a, b, c);
    const double kw = t.k_con * surface_sample_weight(sd.stiffness_factor, sd.spacing, n, a, b, c);
    for_each_sample(n, [&](double b0, double b1, double b2) {
      const Vec3d y = surface_sample_point(b0, b1, b2, a, b, c);
      const unsigned near = near_colliders(t, posed, static_cast<Vec3f>(y), kFloatSlack);
      if (!near) return;
      SurfaceQuery<double> sq;
      if (deepest_query(t, posed, y, near, sq) < 0) return;
      const double kb = kw * (cj == 0 ? b0 : (cj == 1 ? b1 : b2));
      kt_sum += kb * (qj + (sq.point - y));
      ck_sum += kb;
      ++count;
    });
  }
  kt = static_cast<Vec3f>(kt_sum);
  ck = static_cast<float>(ck_sum);
  return count;
}

/// Triangle f after a step, at its corners' new iterates q (every vertex block's step done):
///   candidate (called: a Newton call follows): whether that call can reach one of its samples, a
///     superset of the CPU's triangle test (candidate_triangles: the bounding sphere against
///     newton_reach_bound, float with slack);
///   pen (last): the depth of its deepest sample in the physical tool (surface_penetration_depth).
/// A triangle with a held corner carries no samples.
__device__ void triangle_step(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& posed,
                              const Posed& physical, bool called, bool last, int f, const Vec3f* q, bool& candidate,
                              float& pen) {
  const int4 tri = sd.tri[f];
  if (d.held[tri.x] || d.held[tri.y] || d.held[tri.z]) return;
  const Vec3d a = static_cast<Vec3d>(q[tri.x]), b = static_cast<Vec3d>(q[tri.y]), c = static_cast<Vec3d>(q[tri.z]);
  Vec3d mid;
  const double R = triangle_bounding_sphere(a, b, c, mid);
  const Vec3f mf = static_cast<Vec3f>(mid);
  const float Rf = static_cast<float>(R) * 1.000001f;
  if (called) candidate = maybe_within(t, posed, mf, reach_bound(t, origin_distance(posed, mf)) + Rf * sd.inv_reach);
  if (last && maybe_within(t, physical, mf, Rf + kFloatSlack)) {
    double deepest = 0;
    for_each_sample(surface_sample_level(tri.w, sd.spacing, a, b, c), [&](double b0, double b1, double b2) {
      const Vec3d y = surface_sample_point(b0, b1, b2, a, b, c);
      const unsigned near = near_colliders(t, physical, static_cast<Vec3f>(y), kFloatSlack);
      if (near) deepest = fmax(deepest, penetration(t, physical, y, near));
    });
    pen = static_cast<float>(deepest);
  }
}

/// Calls f(y, w) for the samples of candidate triangle `tri` (at q) that the Newton call from the
/// tool posed in `pt` can reach (reachable: float with slack, a superset of gather_samples' bound
/// for a point), in for_each_sample's order; returns their count.
template <class F>
__device__ int reachable_samples(const SurfaceDev& sd, const ToolConst& t, const Posed& pt, int4 tri, const Vec3f* q,
                                 F&& f) {
  const Vec3d a = static_cast<Vec3d>(q[tri.x]), b = static_cast<Vec3d>(q[tri.y]), c = static_cast<Vec3d>(q[tri.z]);
  const int n = surface_sample_level(tri.w, sd.spacing, a, b, c);
  const double w = surface_sample_weight(sd.stiffness_factor, sd.spacing, n, a, b, c);
  int count = 0;
  for_each_sample(n, [&](double b0, double b1, double b2) {
    const Vec3d y = surface_sample_point(b0, b1, b2, a, b, c);
    if (reachable(t, pt, static_cast<Vec3f>(y))) {
      f(count, y, w);
      ++count;
    }
  });
  return count;
}

}  // namespace
}  // namespace ebh

namespace ebh {
/// The device tick's kernel with surface contact (haptic_cuda_surface.cu), for CudaHapticTicks'
/// cooperative launch with the arguments (MeshDev, ToolConst, SurfaceDev, int count, long long
/// tick0, unsigned long long epoch0). A translation unit of its own: sharing one with ticks_kernel
/// changes how nvcc compiles the vertex-contact kernel (its posed tool's shared memory is then no
/// longer a constant of the narrow phase's calls).
const void* surface_ticks_kernel_entry();
}  // namespace ebh
