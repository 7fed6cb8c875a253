#pragma once
// Surface contact in the device haptic tick (part of haptic_cuda.cu's translation unit; scene key
// `contact: surface`, tool/surface_contact.hpp; docs/CUDA.md, "Surface contact"): E_con [3] on
// the sample points of the virtual mesh's triangles instead of its vertices. The samples' math is
// the CPU's (tool/surface_samples.hpp); here it is gathered per vertex (the virtual mesh's
// Jacobi step), per triangle (the Newton call's candidates and the contact list, the penetration
// metric) and per listed sample (haptic_cuda_surface.cu: list_samples, listed_triangle_sums).
#include "energy/quadratic.hpp"
#include "schedule/haptic_cuda_layout.cuh"
#include "schedule/haptic_cuda_posed.cuh"
#include "tool/surface_samples.hpp"
#include "tool/tool_terms.hpp"

namespace ebh {
namespace {

/// Vertex a's position in this step's iteration as vertex_step's edges read it: its iterate, or on
/// a tick's first step its start x + h v (iteration_start).
__device__ Vec3f iterate_of(const MeshDev& d, const Vec3f* qin, const Vec3f* v_in, bool first, int a) {
  const Vec3f x = qin[a];
  if (!first || d.model.pinned[a]) return x;
  return iteration_start(x, v_in[a], d.h);
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

/// Whether sample point y lies inside a collider posed in `posed`; then `to` = y_proj - y, towards
/// the deepest collider's closest point (E_con [3] on a sample, surface_contact.hpp).
__device__ bool sample_contact(const ToolConst& t, const Posed& posed, Vec3d y, Vec3d& to) {
  const unsigned near = near_colliders(t, posed, static_cast<Vec3f>(y), kFloatSlack);
  if (!near) return false;
  SurfaceQuery<double> sq;
  if (deepest_query(t, posed, y, near, sq) < 0) return false;
  to = sq.point - y;
  return true;
}

/// E_con [3] of vertex j with surface contact against the tool posed in `posed` (Alg. 2 line 10,
/// surface_contact.hpp): each sample y of j's triangles inside a collider pulls j towards
/// q_j + (y_proj - y) with stiffness w k_con b_j (y_proj: the deepest collider's closest point).
/// The triangles in SurfaceContactModel::tri_entries' order; k times the targets summed into kt,
/// the stiffnesses into ck (in double, then rounded). A triangle with a held corner carries no
/// samples (the CPU's `excluded`). Returns the targets' count.
///   listed = 0: each triangle near the tool sums its samples inside here, in for_each_sample's
///     order;
///   listed = the epoch of the step before (contact_list_of): a triangle off that step's contact
///     list has no sample inside the tool (a vertex with none on it, SurfaceDev::vertex_stamp, has
///     no target); one on it has its sums per corner from the step's start
///     (listed_triangle_sums), but for one whose rows changed since (tri_map's z = 0), summed here.
__device__ int surface_contact_target(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& posed,
                                      const DeviceTickInput& in, bool first, int j, Vec3f q, const Vec3f* qin,
                                      const Vec3f* v_in, unsigned long long listed, Vec3f& kt, float& ck) {
  Vec3d kt_sum{};
  double ck_sum = 0;
  int count = 0;
  if (listed && sd.vertex_stamp[j] != listed) {  // none of j's triangles is on the list
    kt = Vec3f{};
    ck = 0.f;
    return 0;
  }
  const Vec3d qj = static_cast<Vec3d>(q);
  for (int e = sd.tri_offsets[j]; e < sd.tri_offsets[j + 1]; ++e) {
    const int fi = sd.tri_entries[e];
    const int4 tri = sd.tri[fi];
    if (listed) {
      if (sd.tri_stamp[fi] != listed) continue;
      const int4 m = sd.tri_map[fi];
      if (m.z > 0) {
        const SampleSum sum = sd.tri_sum[3 * fi + (tri.x == j ? 0 : (tri.y == j ? 1 : 2))];
        kt_sum += Vec3d{sum.x, sum.y, sum.z};
        ck_sum += sum.w;
        count += m.w;
        continue;
      }
    }
    const int v[3] = {tri.x, tri.y, tri.z};
    Vec3f x[3];
    bool held = false;
    int cj = 0;
    for (int k = 0; k < 3; ++k) {
      if (v[k] == j) {
        x[k] = q;
        cj = k;
      } else {
        x[k] = iterate_of(d, qin, v_in, first, v[k]);
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
      Vec3d to;
      if (!sample_contact(t, posed, y, to)) return;
      const double kb = kw * (cj == 0 ? b0 : (cj == 1 ? b1 : b2));
      kt_sum += kb * (qj + to);
      ck_sum += kb;
      ++count;
    });
  }
  kt = static_cast<Vec3f>(kt_sum);
  ck = static_cast<float>(ck_sum);
  return count;
}

/// How far a corner of triangle `tri` moves to the next tick's first iterate (x + h v, from its q
/// and v after a tick's last step), rounded up: the next tick's first step reads its samples
/// there.
__device__ float start_shift(const MeshDev& d, int4 tri, const Vec3f* q, const Vec3f* v) {
  float most = 0.f;
  const int c[3] = {tri.x, tri.y, tri.z};
  for (int k = 0; k < 3; ++k) {
    if (d.model.pinned[c[k]]) continue;
    const Vec3f x = q[c[k]], dx = iteration_start(x, v[c[k]], d.h) - x;
    const float d2 = dot(dx, dx);
    most = fmaxf(most, d2 > 0.f ? d2 * rsqrtf(d2) : 0.f);
  }
  return most > 0.f ? most * 1.000001f + kFloatSlack : 0.f;
}

/// reachable() for every point within `shift` of x: whether the Newton call from the pose of `p`
/// can reach a point that moves up to `shift` from x (shift = 0: reachable(x)).
__device__ bool reachable_within(const ToolConst& t, const Posed& p, Vec3f x, float shift) {
  return maybe_within(t, p, x, reach_bound(t, origin_distance(p, x) + shift) + shift);
}

/// Sample k of a listed triangle of n rows with corners ca, cb, cc (float: the tests have slack),
/// against the tool posed in `pt`: whether the Newton call can reach it (`newton`: the triangle is
/// the call's candidate, triangle_step) and whether the contact list holds it (the call can reach
/// it here or, within `shift`, at the next tick's first iterates).
__device__ void sample_flags(const ToolConst& t, const Posed& pt, int n, int k, Vec3f ca, Vec3f cb, Vec3f cc,
                             bool newton, float shift, bool& cand, bool& listed) {
  float b0, b1, b2;
  sample_barycentric(n, k, b0, b1, b2);
  const Vec3f yf = b0 * ca + b1 * cb + b2 * cc;
  cand = newton && reachable(t, pt, yf);
  listed = cand || reachable_within(t, pt, yf, shift);
}

/// A warp's samples in one sequence, each lane's `count` after the lanes below it: the inclusive
/// scan of count over the lanes (lane l's samples are [end - count, end)).
__device__ int warp_sequence_end(int count) {
  const int lane = threadIdx.x & 31;
  int end = count;
  for (int o = 1; o < 32; o <<= 1) {
    const int y = __shfl_up_sync(~0u, end, o);
    if (lane >= o) end += y;
  }
  return end;
}

/// The lane whose samples hold sample g of the warp's sequence (warp_sequence_end): the first lane
/// whose end passes g (every lane calls it; g past the sequence gives some lane).
__device__ int warp_sequence_owner(int end, int g) {
  int lo = 0, hi = 31;
  for (int step = 0; step < 5; ++step) {
    const int mid = (lo + hi) / 2;
    if (__shfl_sync(~0u, end, mid) <= g) lo = mid + 1; else hi = mid;
  }
  return lo;
}

/// The sample flags (sample_flags) of the warp's listed triangles (f, `listed` and `newton`: each
/// lane's triangle and its triangle_step) after a step with a Newton call, at their corners' new
/// iterates q, into SurfaceDev::tri_masks. The warp's samples in one sequence, triangle after
/// triangle, 32 at a time over the lanes; each lane gathers its own triangle's bits from the
/// ballots. Triangles of more than sd.masked_samples samples are left to block 0 (list_samples).
__device__ void listed_sample_masks(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& pt,
                                    const Vec3f* q, const Vec3f* v, bool last, int f, bool listed, bool newton) {
  const int lane = threadIdx.x & 31;
  int n = 0, count = 0;
  Vec3f ca{}, cb{}, cc{};
  float shift = 0.f;
  if (listed) {
    const int4 tri = sd.tri[f];
    ca = q[tri.x];
    cb = q[tri.y];
    cc = q[tri.z];
    n = surface_sample_level(tri.w, sd.spacing, static_cast<Vec3d>(ca), static_cast<Vec3d>(cb), static_cast<Vec3d>(cc));
    if (n * n <= sd.masked_samples) {
      count = n * n;
      shift = last ? start_shift(d, tri, q, v) : 0.f;
    }
  }
  const int end = warp_sequence_end(count);  // this lane's samples are [end - count, end) of the sequence
  const int total = __shfl_sync(~0u, end, 31), begin = end - count;
  unsigned long long cand_bits = 0, list_bits = 0;
  for (int base = 0; base < total; base += 32) {
    const int g = base + lane;
    const int lo = warp_sequence_owner(end, g);
    const int k = g - __shfl_sync(~0u, begin, lo), on = __shfl_sync(~0u, n, lo);
    const Vec3f oa{__shfl_sync(~0u, ca.x, lo), __shfl_sync(~0u, ca.y, lo), __shfl_sync(~0u, ca.z, lo)};
    const Vec3f ob{__shfl_sync(~0u, cb.x, lo), __shfl_sync(~0u, cb.y, lo), __shfl_sync(~0u, cb.z, lo)};
    const Vec3f oc{__shfl_sync(~0u, cc.x, lo), __shfl_sync(~0u, cc.y, lo), __shfl_sync(~0u, cc.z, lo)};
    const float oshift = __shfl_sync(~0u, shift, lo);
    const bool onewton = __shfl_sync(~0u, newton ? 1 : 0, lo) != 0;
    bool cand = false, in_list = false;
    if (g < total) sample_flags(t, pt, on, k, oa, ob, oc, onewton, oshift, cand, in_list);
    const unsigned cw = __ballot_sync(~0u, cand), lw = __ballot_sync(~0u, in_list);
    const int from = max(begin, base), to = min(end, base + 32);  // this lane's samples in the round
    if (from < to) {
      const unsigned long long keep = (1ull << (to - from)) - 1ull;
      cand_bits |= ((static_cast<unsigned long long>(cw) >> (from - base)) & keep) << (from - begin);
      list_bits |= ((static_cast<unsigned long long>(lw) >> (from - base)) & keep) << (from - begin);
    }
  }
  if (count > 0) sd.tri_masks[f] = make_ulonglong2(cand_bits, list_bits);
}

/// Triangle f after a step, at its corners' new iterates q (every vertex block's step done):
///   candidate (called: a Newton call follows): whether that call can reach one of its samples, a
///     superset of the CPU's triangle test (candidate_triangles: the bounding sphere against
///     newton_reach_bound, float with slack);
///   listed (called): candidate, or (last) whether the call can reach one of its samples at the
///     next tick's first iterates (each within start_shift of its sample here; v: the velocities
///     after the step), for the next step's contact list;
///   deep (last): whether one of its samples may lie in the physical tool (triangle_chunk then
///     measures them: their depth is surface_penetration_depth's).
/// A triangle with a held corner carries no samples.
__device__ void triangle_step(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& posed,
                              const Posed& physical, bool called, bool last, int f, const Vec3f* q, const Vec3f* v,
                              bool& candidate, bool& listed, bool& deep) {
  const int4 tri = sd.tri[f];
  if (d.held[tri.x] || d.held[tri.y] || d.held[tri.z]) return;
  const Vec3d a = static_cast<Vec3d>(q[tri.x]), b = static_cast<Vec3d>(q[tri.y]), c = static_cast<Vec3d>(q[tri.z]);
  Vec3d mid;
  const double R = triangle_bounding_sphere(a, b, c, mid);
  const Vec3f mf = static_cast<Vec3f>(mid);
  const float Rf = static_cast<float>(R) * 1.000001f;
  if (called) {
    const float r = origin_distance(posed, mf);
    candidate = maybe_within(t, posed, mf, reach_bound(t, r) + Rf * sd.inv_reach);
    listed = candidate;
    if (last && !listed) {
      const float shift = start_shift(d, tri, q, v);
      listed = shift > 0.f && maybe_within(t, posed, mf, reach_bound(t, r + shift) + (Rf + shift) * sd.inv_reach);
    }
  }
  deep = last && maybe_within(t, physical, mf, Rf + kFloatSlack);
}

/// The depth of the deepest sample in the physical tool of the warp's triangles with `deep` set
/// (triangle_step; f: each lane's triangle): their samples in one sequence over the lanes
/// (warp_sequence_end), 32 at a time; every lane gets the warp's value (a maximum: the order
/// changes no bit).
__device__ float deepest_in_warp(const SurfaceDev& sd, const ToolConst& t, const Posed& physical, const Vec3f* q,
                                 int f, bool deep) {
  const int lane = threadIdx.x & 31;
  int n = 0;
  if (deep) {
    const int4 tri = sd.tri[f];
    n = surface_sample_level(tri.w, sd.spacing, static_cast<Vec3d>(q[tri.x]), static_cast<Vec3d>(q[tri.y]),
                             static_cast<Vec3d>(q[tri.z]));
  }
  const int end = warp_sequence_end(n * n);
  const int total = __shfl_sync(~0u, end, 31), begin = end - n * n;
  double deepest = 0;
  for (int base = 0; base < total; base += 32) {
    const int g = base + lane;
    const int lo = warp_sequence_owner(end, g);
    const int k = g - __shfl_sync(~0u, begin, lo), on = __shfl_sync(~0u, n, lo), of = __shfl_sync(~0u, f, lo);
    if (g >= total) continue;
    const int4 tri = sd.tri[of];
    const Vec3d a = static_cast<Vec3d>(q[tri.x]), b = static_cast<Vec3d>(q[tri.y]), c = static_cast<Vec3d>(q[tri.z]);
    double b0, b1, b2;
    sample_barycentric(on, k, b0, b1, b2);
    const Vec3d y = surface_sample_point(b0, b1, b2, a, b, c);
    const unsigned near = near_colliders(t, physical, static_cast<Vec3f>(y), kFloatSlack);
    if (near) deepest = fmax(deepest, penetration(t, physical, y, near));
  }
  for (int o = 16; o > 0; o >>= 1) deepest = fmax(deepest, __shfl_xor_sync(~0u, deepest, o));
  return static_cast<float>(deepest);
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
