// The whole haptic tick on a CUDA device (haptic_cuda.hpp; docs/CUDA.md "Device haptic tick").
//
// A run of ticks is one cooperative launch of ticks_kernel, every block resident. A tick is
// virtual_iterations iterations; iteration i, per virtual vertex j (one thread each):
//   begin (i = 0)   q_start, prediction s (Alg. 2 l. 6), E_svc target p from the blended physical
//                   result (l. 1), the grasp event of the tick (§5.2, eq. [10])
//   contact         E_con [3] target of j against the virtual tool held fixed (l. 10): the grasp
//                   target of a held vertex, else the closest point of the deepest collider
//   iteration       one Jacobi step of E_k + E_svc + E_con + E_s (l. 11-16) into q_{i+1}
//   end (last i)    velocity (l. 23), depth of j in the physical tool (the penetration metric)
//   reach           whether the virtual tool's Newton step can reach j (virtual_tool.cpp's bound)
// then per chunk of vertices: the reachable and the held vertices in vertex order, the contact
// count, the deepest physical-tool penetration. Every block arrives at a counter; block 0, the
// tail block, waits for all, runs the virtual tool (l. 18-19) and releases the next iteration:
// Newton's method on E_tool over the reachable vertices in double, with fixed-order block sums,
// the 6x6 PSD clamp by a one-warp Jacobi eigen-decomposition, an Armijo line search, and (last i)
// the tick's outputs into a host-mapped ring (l. 26-27).
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "energy/edge_spring.hpp"
#include "energy/quadratic.hpp"
#include "schedule/haptic_cuda.hpp"
#include "schedule/newton_warp.cuh"
#include "solver/cuda_util.cuh"
#include "solver/virtual_mesh_device.cuh"
#include "tool/collider.hpp"
#include "tool/contact.hpp"
#include "tool/tool_energy.hpp"

namespace ebh {
namespace {

constexpr int kBlock = 128;
constexpr int kWarps = kBlock / 32;
constexpr int kTailOffsets = 512;  // chunks whose list offsets the tail keeps in shared memory
constexpr int kEdgeChunk = 8;       // incident edges loaded at once (a surface vertex has ~6)
constexpr int kMaxHalvings = 12;    // virtual_tool.cpp
constexpr double kArmijo = 1e-4;    // virtual_tool.cpp
constexpr double kConverged = 1e-13;
constexpr double kStepFloor = 1e-14;
constexpr int kSums = 28;           // E, gradient (6), upper Hessian (21)
// A float32 signed distance above this (m) is certainly positive in double: the exact double tests
// run only below it (float's error on tool-sized coordinates is ~1e-7 m).
constexpr float kFloatSlack = 1e-5f;

/// The tool's constants (kernel parameter).
struct ToolConst {
  int count = 0;
  Collider<double> shape[kMaxColliders];
  // Early-outs: a segment (a, b, collider frame) and radius whose capsule contains collider c, so
  // the distance to that capsule is a lower bound of the collider's signed distance.
  Vec3f seg_a[kMaxColliders], seg_b[kMaxColliders];
  float seg_r[kMaxColliders];
  double jaw_angle = 0;  // rad at jaw = 1
  double k_con = 0, k_vcs = 0, k_vct = 0, stab_t = 0, stab_r = 0;
  double max_step = 0, max_rot = 0;
  int newton = 1;
  double force_limit = 0, torque_limit = 0;
  double soft_margin = 1, eta = 1;
  double reach_T = 0, reach_th = 0;  // candidates: translation and rotation one call can reach
};

/// The virtual tool's state on the device (one instance).
struct ToolStateDev {
  Vec3d position;
  Quatd orientation;
  Vec3d anchor_position;
  Quatd anchor_orientation;
  long long tick;
};

/// Stage timestamps of the device tick (DeviceHapticSetup::profile_stages; global timer, ns): sums
/// over launches of each stage's duration, in DeviceTickProfile's order.
struct ProfileDev {
  unsigned long long sum[DeviceTickProfile::kStages];  // ns; the tail's stages in SM cycles
  unsigned long long launches;
  unsigned long long start;        // this launch: block 0 past the grid dependency
  unsigned long long prev_end;     // the last launch's tail end
  unsigned long long block_start;  // this launch: sum over blocks of (start - prev_end)
  unsigned long long tail_cycles, tail_ns;  // the tails' SM cycles and time (their clock rate)
  unsigned long long vertices_max;  // this launch: the slowest block's vertex stage
  unsigned long long clamps, sweeps, candidates;  // PSD clamps, their Jacobi sweeps; reachable vertices
};

__device__ __forceinline__ unsigned long long global_ns() {
  unsigned long long t;
  asm volatile("mov.u64 %0, %%globaltimer;" : "=l"(t));
  return t;
}

/// The tail's stage marks, kept by its thread 0 in registers (SM cycles) and written to the
/// ProfileDev once at its end, so that profiling adds no memory round trips between the stages.
struct TailMarks {
  bool on = false;
  unsigned long long start_ns = 0, start_clock = 0, last = 0;
  unsigned long long cycles[DeviceTickProfile::kStages] = {};
  int clamps = 0, sweeps = 0, candidates = 0;
  __device__ void begin(const ProfileDev* p) {
    on = p && threadIdx.x == 0;
    if (!on) return;
    start_ns = global_ns();
    start_clock = last = clock64();
  }
  /// Closes stage k at now (thread 0 only).
  __device__ void mark(int k) {
    if (!on || threadIdx.x != 0) return;
    const unsigned long long t = clock64();
    cycles[k] += t - last;
    last = t;
  }
  __device__ void end(ProfileDev* p, int blocks) {
    if (!on) return;
    const unsigned long long now = global_ns();
    for (int k = DeviceTickProfile::Gather; k <= DeviceTickProfile::Output; ++k) p->sum[k] += cycles[k];
    p->tail_cycles += clock64() - start_clock;
    p->clamps += clamps;
    p->sweeps += sweeps;
    p->candidates += candidates;
    p->tail_ns += now - start_ns;
    if (p->prev_end) {
      p->sum[DeviceTickProfile::Launch] += p->start - p->prev_end;
      const long long lag = static_cast<long long>(p->block_start / blocks) - static_cast<long long>(p->start - p->prev_end);
      p->sum[DeviceTickProfile::BlockLag] += static_cast<unsigned long long>(lag);
    }
    p->sum[DeviceTickProfile::Mesh] += start_ns - p->start;
    p->sum[DeviceTickProfile::BlockVerticesMax] += p->vertices_max;
    p->vertices_max = 0;
    p->block_start = 0;
    p->prev_end = now;
    ++p->launches;
  }
};

/// Colliders posed for one tool pose and jaw value.
struct Posed {
  Rigid<double> world[kMaxColliders];
  Rigid<double> frame;  // tool frame -> world
  Vec3f seg_a[kMaxColliders], seg_u[kMaxColliders];  // bounding segments in the world: start, unit axis
  float seg_len[kMaxColliders], seg_r[kMaxColliders];
  Vec3f origin_f;       // frame.t, rounded
};

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

/// The grid's hand-off counters (ticks_kernel): arrivals of the blocks other than the tail block,
/// and the last epoch the tail block released; both count from the object's first run.
struct SyncDev {
  unsigned long long arrive, release;
};

struct MeshDev {
  int m = 0, chunks = 0, ring = 1;  // chunks of kBlock vertices (a block of the grid runs several when needed)
  int iterations = 1;               // virtual iterations per tick
  float k_s = 0, k_svc = 0, h = 0, inv_h = 0, inv_h2 = 0;
  Vec3f gravity;
  cuda::VirtualModelView model;
  const Vec3f* x_prev = nullptr;  // the physical result before the visible one
  const Vec3f* x_vis = nullptr;   // the visible physical result
  Vec3f* q0 = nullptr;            // the virtual mesh at the tick's end; q1, q2: the iterates between
  Vec3f* q1 = nullptr;
  Vec3f* q2 = nullptr;
  Vec3f* v = nullptr;             // velocities: the last tick's (iteration 0 reads them), this tick's
  Vec3f* v_scratch = nullptr;     // one virtual iteration per tick: the velocities, copied to v
  SyncDev* sync = nullptr;
  Vec3f* q_start = nullptr;
  Vec3f* s = nullptr;
  Vec3f* p = nullptr;
  std::uint8_t* held = nullptr;
  Vec3d* grasp_local = nullptr;
  int* block_cand = nullptr;        // chunks * kBlock
  int* block_held = nullptr;        // chunks * kBlock
  int* block_counts = nullptr;      // chunks * 4: reachable, held, contacts, penetration (float bits)
  int* block_offsets = nullptr;     // 2 (chunks + 1)
  Vec3d* cand_q = nullptr;          // m
  int* held_list = nullptr;         // m
  ToolStateDev* state = nullptr;
  const DeviceTickInput* inputs = nullptr;
  const Collider<double>* grasp_boxes = nullptr;
  DeviceTickOutput* out = nullptr;  // host-mapped ring of `ring` rows
  ProfileDev* profile = nullptr;    // stage timestamps, or null
};

/// Collider c of pose_tool (tool_model.cpp) on the device; (jc, js): cos and sin of the jaws'
/// opening angle (DeviceTickInput). Threads 0 .. count-1 each pose one collider.
__device__ void pose_collider(const ToolConst& t, Vec3d P, Quatd Q, double jc, double js, int c, Posed& out) {
  Rigid<double> frame;
  frame.R = to_matrix(Q);
  frame.t = P;
  const ColliderFrame f = t.shape[c].frame;
  if (f == ColliderFrame::Tool) {
    out.world[c] = frame;
  } else {
    Rigid<double> local;  // rotation about the tool's y axis, +angle for the upper jaw
    const double s = f == ColliderFrame::UpperJaw ? js : -js;
    local.R(0, 0) = jc; local.R(0, 2) = s; local.R(2, 0) = -s; local.R(2, 2) = jc;
    out.world[c] = compose(frame, local);
  }
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

/// The whole posed tool, by the block's first threads (callers synchronise after it).
__device__ void pose_colliders(const ToolConst& t, Vec3d P, Quatd Q, const DeviceTickInput& in, Posed& out) {
  if (threadIdx.x < t.count) pose_collider(t, P, Q, in.jaw_cos, in.jaw_sin, threadIdx.x, out);
}

/// E_tvc [2] (tool_energy.cpp: coupling_energy) with its gradient.
__device__ double coupling_energy_dev(Vec3d P, Quatd Q, Vec3d Ph, Quatd Qh, double k_vcs, double k_vct, double* g) {
  const Vec3d dP = P - Ph;
  const Vec3d v = rotvec_from_quat(normalized(Q * conjugate(Qh)));
  g[0] = k_vcs * dP.x; g[1] = k_vcs * dP.y; g[2] = k_vcs * dP.z;
  g[3] = k_vct * v.x; g[4] = k_vct * v.y; g[5] = k_vct * v.z;
  return 0.5 * k_vcs * squared_norm(dP) + 0.5 * k_vct * squared_norm(v);
}

/// Block sum of the first kCount of v[kSums] over kBlock threads in a fixed order; the result lands
/// in out[0..kCount) (shared). In each warp, many values by a transposed butterfly: at the step of
/// offset o a lane keeps one half of its values and sends the other to lane ^ o, so lane L ends with
/// value L's warp sum after 31 shuffles (a tree per value would take 5 per value); then the warps in order.
template <int kCount>
__device__ void block_sum(const double* v, double (*scratch)[kSums], double* out) {
  static_assert(kCount == 1 || (kCount > 1 && kCount <= 32));
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  if constexpr (kCount == 1) {
    double x = v[0];
    for (int o = 16; o > 0; o >>= 1) x += __shfl_down_sync(~0u, x, o);
    if (lane == 0) scratch[warp][0] = x;
  } else {
    double x[32];
#pragma unroll
    for (int k = 0; k < 32; ++k) x[k] = k < kCount ? v[k] : 0.0;
#pragma unroll
    for (int o = 16; o > 0; o >>= 1) {
      const bool high = (lane & o) != 0;  // keeps values [o, 2o) of its current 2o, sends [0, o)
#pragma unroll
      for (int k = 0; k < o; ++k) {
        const double send = high ? x[k] : x[k + o];
        const double keep = high ? x[k + o] : x[k];
        x[k] = keep + __shfl_xor_sync(~0u, send, o);
      }
    }
    if (lane < kCount) scratch[warp][lane] = x[0];
  }
  __syncthreads();
  if (threadIdx.x < kCount) {
    double acc = 0;
    for (int w = 0; w < kWarps; ++w) acc += scratch[w][threadIdx.x];
    out[threadIdx.x] = acc;
  }
  __syncthreads();
}

/// Block max of a non-negative double.
__device__ double block_max(double x, double* scratch) {
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  for (int o = 16; o > 0; o >>= 1) x = fmax(x, __shfl_down_sync(~0u, x, o));
  if (lane == 0) scratch[warp] = x;
  __syncthreads();
  double r = 0;
  for (int w = 0; w < kWarps; ++w) r = fmax(r, scratch[w]);
  __syncthreads();
  return r;
}

/// Exclusive block scans of two counts (warp shuffles, then the warps in order); totals in ta, tb.
__device__ void block_exclusive_scan(int a, int b, int& ea, int& eb, int& ta, int& tb) {
  __shared__ int wa[kWarps], wb[kWarps];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  int ia = a, ib = b;
  for (int o = 1; o < 32; o <<= 1) {
    const int xa = __shfl_up_sync(~0u, ia, o), xb = __shfl_up_sync(~0u, ib, o);
    if (lane >= o) { ia += xa; ib += xb; }
  }
  if (lane == 31) { wa[warp] = ia; wb[warp] = ib; }
  __syncthreads();
  int pa = 0, pb = 0, sa = 0, sb = 0;
  for (int w = 0; w < kWarps; ++w) {
    if (w < warp) { pa += wa[w]; pb += wb[w]; }
    sa += wa[w];
    sb += wb[w];
  }
  ea = pa + ia - a;
  eb = pb + ib - b;
  ta = sa;
  tb = sb;
  __syncthreads();
}

struct TailShared {
  double sums[kWarps][kSums];
  double total[kSums];
  float clamp_scratch[42];
  double dx[6], g[6];
  double wmax[kWarps];
  int warp_contacts[kWarps];
  unsigned warp_pen[kWarps];   // float bits of a non-negative depth
  int offsets[2 * (kTailOffsets + 1)];
  double E, slope, depth;
  int flag, nc, nh;
  Vec3d P;
  Quatd Q;
  Vec3d trial_P;
  Quatd trial_Q;
  Vec3d anchor_P;  // the tool's pose at the tick's start (stabilisation)
  Quatd anchor_Q;
  double coupling_E, coupling_g[6];
};

/// E_con [3] of the reachable vertices plus the grasp part (tool_energy.cpp) at the posed tool `pt`,
/// summed over the block. kDerivs: also the gradient and the upper Hessian (into sh.total).
/// Returns E (contact + grasp) and the deepest contact's depth in `depth`.
template <bool kDerivs>
__device__ double tool_contact_sums(const MeshDev& d, const ToolConst& t, const Vec3f* q, const Posed& pt,
                                    TailShared& sh, double& depth) {
  double acc[kSums];
  for (int k = 0; k < kSums; ++k) acc[k] = 0;
  double H[36];
  double g[6];
  if (kDerivs) {
    for (int k = 0; k < 36; ++k) H[k] = 0;
    for (int k = 0; k < 6; ++k) g[k] = 0;
  }
  double deepest = 0;
  const Vec3d P = pt.frame.t;
  for (int i = threadIdx.x; i < sh.nc; i += kBlock) {
    const Vec3d qc = d.cand_q[i];
    const unsigned near = near_colliders(t, pt, static_cast<Vec3f>(qc), kFloatSlack);
    if (!near) continue;  // certainly outside
    if (kDerivs) {
      SurfaceQuery<double> sq;
      if (deepest_collider(t.shape, pt.world, t.count, qc, sq, near) < 0) continue;
      const double phi = -sq.sd;
      deepest = fmax(deepest, phi);
      acc[0] += contact_terms(t.k_con, phi, 1.0, sq.normal, qc - P, sq.hess, true, g, H);
    } else {  // E only: the deepest collider's signed distance (deepest_collider's first pass)
      double sd = 0;
      for (int c = 0; c < t.count; ++c)
        if ((near >> c) & 1u) sd = fmin(sd, signed_distance_local(t.shape[c], apply_inverse(pt.world[c], qc)));
      const double phi = -sd;
      deepest = fmax(deepest, phi);
      acc[0] += 0.5 * t.k_con * phi * phi;
    }
  }
  for (int i = threadIdx.x; i < sh.nh; i += kBlock) {
    const int j = d.held_list[i];
    const Vec3d s = pt.frame.R * d.grasp_local[j];
    const Vec3d r = static_cast<Vec3d>(q[j]) - P - s;
    acc[0] += 0.5 * t.k_con * squared_norm(r);
    if (kDerivs) {
      const Vec3d sr = cross(s, r);
      g[0] -= t.k_con * r.x; g[1] -= t.k_con * r.y; g[2] -= t.k_con * r.z;
      g[3] -= t.k_con * sr.x; g[4] -= t.k_con * sr.y; g[5] -= t.k_con * sr.z;
      const Mat3d Sk = skew(s);
      const Mat3d SS = Sk * Sk;
      const Mat3d Eww = dot(r, s) * Mat3d::identity() - 0.5 * (outer(r, s) + outer(s, r));
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          H[6 * a + b] += t.k_con * (a == b ? 1.0 : 0.0);
          H[6 * a + b + 3] -= t.k_con * Sk(a, b);
          H[6 * (a + 3) + b] += t.k_con * Sk(a, b);
          H[6 * (a + 3) + b + 3] += t.k_con * (Eww(a, b) - SS(a, b));
        }
    }
  }
  if (kDerivs) {
    for (int k = 0; k < 6; ++k) acc[1 + k] = g[k];
    for (int a = 0; a < 6; ++a)
      for (int b = a; b < 6; ++b) acc[7 + cuda::upper(a, b)] = H[6 * a + b];
  }
  depth = block_max(deepest, sh.wmax);
  if (sh.nc + sh.nh == 0) {  // nothing near the tool: the sums are zero (skips the reduction)
    for (int k = threadIdx.x; k < kSums; k += kBlock) sh.total[k] = 0;
    __syncthreads();
    return 0;
  }
  block_sum<kDerivs ? kSums : 1>(acc, sh.sums, sh.total);
  return sh.total[0];
}

__device__ void tick_outputs(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in, const TailShared& sh,
                             int taken, int rejected);

/// The last block: the reachable and held vertices in vertex order, then the virtual tool's Newton
/// step (virtual_tool.cpp: update_virtual_tool), then (`last`: the tick's last iteration) the tick's
/// outputs (a runtime flag, not a template: one copy of this code, which the tail block's
/// instruction cache keeps from one iteration to the next).
__device__ void virtual_tool_tail(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in,
                                      const Vec3f* q, bool last, Posed& pt, TailShared& sh) {
  TailMarks marks;
  marks.begin(d.profile);
  // Offsets of each block's lists (exclusive scans of the block counts, chunked over threads), in
  // shared memory up to kTailOffsets chunks; with `last` also the tick's contact count and deepest
  // physical-tool penetration (per warp, summed by tick_outputs).
  {
    const int per = (d.chunks + kBlock - 1) / kBlock, b0 = threadIdx.x * per, b1 = min(b0 + per, d.chunks);
    int sc = 0, shd = 0, cc = 0;
    unsigned pm = 0;
    for (int b = b0; b < b1; ++b) {
      sc += d.block_counts[4 * b];
      shd += d.block_counts[4 * b + 1];
      if (last) {
        cc += d.block_counts[4 * b + 2];
        pm = max(pm, static_cast<unsigned>(d.block_counts[4 * b + 3]));
      }
    }
    if (last) {
      for (int o = 16; o > 0; o >>= 1) {
        cc += __shfl_xor_sync(~0u, cc, o);
        pm = max(pm, __shfl_xor_sync(~0u, pm, o));
      }
      if ((threadIdx.x & 31) == 0) { sh.warp_contacts[threadIdx.x >> 5] = cc; sh.warp_pen[threadIdx.x >> 5] = pm; }
    }
    int oc = 0, oh = 0;
    block_exclusive_scan(sc, shd, oc, oh, sh.nc, sh.nh);
    int* const off = d.chunks < kTailOffsets ? sh.offsets : d.block_offsets;  // 2 (chunks + 1)
    for (int b = b0; b < b1; ++b) {
      off[b] = oc;
      off[d.chunks + 1 + b] = oh;
      oc += d.block_counts[4 * b];
      oh += d.block_counts[4 * b + 1];
    }
    if (threadIdx.x == 0) { off[d.chunks] = sh.nc; off[2 * d.chunks + 1] = sh.nh; }
    __syncthreads();
    // Gather: entry i of a list lies in the block b with offset[b] <= i < offset[b + 1].
    auto entry = [&](int i, const int* o, const int* block_list) {
      int lo = 0, hi = d.chunks - 1;
      while (lo < hi) {
        const int mid = (lo + hi + 1) / 2;
        if (o[mid] <= i) lo = mid; else hi = mid - 1;
      }
      return block_list[lo * kBlock + (i - o[lo])];
    };
    for (int i = threadIdx.x; i < sh.nc; i += kBlock) d.cand_q[i] = static_cast<Vec3d>(q[entry(i, off, d.block_cand)]);
    for (int i = threadIdx.x; i < sh.nh; i += kBlock) d.held_list[i] = entry(i, off + d.chunks + 1, d.block_held);
    __syncthreads();
  }
  marks.mark(DeviceTickProfile::Gather);
  if (marks.on) marks.candidates = sh.nc;

  // Newton's method on E_tool (virtual_tool.cpp), q held fixed.
  const Vec3d Ph = in.position;
  const Quatd Qh = in.orientation;
  // sh.P, sh.Q and the anchor: the tool's state as the block read it at its start.
  const bool stabilised = t.stab_t > 0 || t.stab_r > 0;
  // E_tvc [2] (+ the stabilisation) and its gradient at (P, Q). The last thread computes it beside
  // the contact sums (it depends on the pose only), so it adds nothing to the chain.
  constexpr int kCouplingThread = kBlock - 1;
  auto coupling = [&](Vec3d P, Quatd Q, double* g) {
    double e = coupling_energy_dev(P, Q, Ph, Qh, t.k_vcs, t.k_vct, g);
    if (stabilised) {
      double gs[6];
      e += coupling_energy_dev(P, Q, sh.anchor_P, sh.anchor_Q, t.stab_t, t.stab_r, gs);
      for (int k = 0; k < 6; ++k) g[k] += gs[k];
    }
    return e;
  };
  // E_tool, its gradient (sh.E, sh.g), the contact Hessian (sh.total) and the deepest contact at
  // (sh.P, sh.Q): energy_at with derivatives.
  // `pt` is always the tool posed at (sh.P, sh.Q) here: the launch's posed tool when the tail
  // starts, the accepted trial's after a line search (a rejected one ends the call).
  auto evaluate_with_derivatives = [&] {
    if (threadIdx.x == kCouplingThread) sh.coupling_E = coupling(sh.P, sh.Q, sh.coupling_g);
    double depth = 0;
    const double Econ = tool_contact_sums<true>(d, t, q, pt, sh, depth);  // synchronises the block
    if (threadIdx.x == 0) {
      sh.E = sh.coupling_E + Econ;
      for (int k = 0; k < 6; ++k) sh.g[k] = sh.coupling_g[k] + sh.total[1 + k];
      sh.depth = depth;
    }
    __syncthreads();
    marks.mark(DeviceTickProfile::Evaluate);
  };
  evaluate_with_derivatives();
  int taken = 0, rejected = 0;
  for (int it = 0; it < t.newton; ++it) {
    // One warp: H_step = PSD(H_con + H_grasp) + k_vcs I (+) k_vct I (+ stabilisation), then
    // dx = -H_step^-1 g (eq. (9)) by Cholesky, scaled to the step limits.
    if (threadIdx.x < 32) {
      const int lane = threadIdx.x;
      double h = lane < 21 ? sh.total[7 + lane] : 0.0;
      int sweeps = 0;
      h = cuda::warp_psd_clamp(h, lane, sh.clamp_scratch, &sweeps);
      marks.mark(DeviceTickProfile::Clamp);
      if (marks.on) { ++marks.clamps; marks.sweeps += sweeps; }
      int hi = 0, hj = 0;
      cuda::upper_entry(lane < 21 ? lane : 0, hi, hj);
      if (lane < 21 && hi == hj) h += hi < 3 ? t.k_vcs + t.stab_t : t.k_vct + t.stab_r;
      const double gk = lane < 6 ? sh.g[lane] : 0.0;
      double dx = 0;
      const bool ok = cuda::warp_cholesky_solve(h, -gk, lane, dx);
      // Step limits, slope, round-off test (lanes 0-5 hold dx; the sums reach every lane).
      double t2 = lane < 3 ? dx * dx : 0.0, r2 = lane >= 3 && lane < 6 ? dx * dx : 0.0;
      for (int o = 4; o > 0; o >>= 1) {
        t2 += __shfl_xor_sync(~0u, t2, o);
        r2 += __shfl_xor_sync(~0u, r2, o);
      }
      // Reciprocal square roots, no division (a zero part's limit is then ~1e150, never binding).
      const double it2 = rsqrt(fmax(t2, 1e-300)), ir2 = rsqrt(fmax(r2, 1e-300));
      const double nt = t2 * it2, nr = r2 * ir2;
      const double scale = fmin(1.0, fmin(t.max_step * it2, t.max_rot * ir2));
      double gdx = lane < 6 ? gk * (dx * scale) : 0.0;
      for (int o = 4; o > 0; o >>= 1) gdx += __shfl_xor_sync(~0u, gdx, o);
      if (lane < 6) sh.dx[lane] = dx * scale;
      if (lane == 0) {
        sh.flag = 0;  // 0: stop (converged or failed), 1: line search
        if (!ok) {
          ++rejected;
        } else {
          sh.slope = gdx;
          const double floor_t = kStepFloor * (norm(sh.P) + 1e-3);  // virtual_tool.cpp: round-off steps
          const bool roundoff = nt * scale <= floor_t && nr * scale <= kStepFloor;
          if (gdx < -kConverged * fmax(sh.E, 1e-300) && !roundoff) sh.flag = 1;
        }
      }
    }
    __syncthreads();
    marks.mark(DeviceTickProfile::Solve);
    if (sh.flag == 0) break;
    // Armijo line search: halve until E_tool does not increase enough.
    double alpha = 1.0;
    bool accepted = false;
    for (int hv = 0; hv < kMaxHalvings; ++hv, alpha *= 0.5) {
      // The trial pose, computed by each thread that uses it (same bits): the colliders' threads
      // pose it, the coupling thread evaluates E_tvc there, thread 0 keeps it.
      if (threadIdx.x < t.count || threadIdx.x == kCouplingThread) {
        const Vec3d P = sh.P + Vec3d{alpha * sh.dx[0], alpha * sh.dx[1], alpha * sh.dx[2]};
        const Quatd Q = normalized(quat_from_rotvec(Vec3d{alpha * sh.dx[3], alpha * sh.dx[4], alpha * sh.dx[5]}) * sh.Q);
        if (threadIdx.x < t.count) pose_collider(t, P, Q, in.jaw_cos, in.jaw_sin, threadIdx.x, pt);
        if (threadIdx.x == 0) { sh.trial_P = P; sh.trial_Q = Q; }
        if (threadIdx.x == kCouplingThread) sh.coupling_E = coupling(P, Q, sh.coupling_g);
      }
      __syncthreads();
      double trial_depth = 0;
      const double Ec = tool_contact_sums<false>(d, t, q, pt, sh, trial_depth);  // synchronises the block
      if (threadIdx.x == 0) {
        const double Et = sh.coupling_E + Ec;
        sh.flag = Et <= sh.E + kArmijo * alpha * sh.slope;
        if (sh.flag) {
          sh.P = sh.trial_P;
          sh.Q = sh.trial_Q;
          sh.E = Et;
          sh.depth = trial_depth;
        }
      }
      __syncthreads();
      if (sh.flag) { accepted = true; break; }
    }
    marks.mark(DeviceTickProfile::LineSearch);
    if (!accepted) { ++rejected; break; }
    ++taken;
    if (it + 1 < t.newton) evaluate_with_derivatives();  // for the next Newton step
  }
  if (threadIdx.x != 0) return;
  ToolStateDev& st = *d.state;
  st.position = sh.P;
  st.orientation = sh.Q;
  if (last) tick_outputs(d, t, in, sh, taken, rejected);
  marks.mark(DeviceTickProfile::Output);
  marks.end(d.profile, gridDim.x);
}

/// Algorithm 2 lines 26-27 (thread 0 of the tail, last launch): the force and torque for the
/// device (tool_output), the metrics, into the ring; the next tick's anchor.
__device__ void tick_outputs(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in, const TailShared& sh,
                             int taken, int rejected) {
  ToolStateDev& st = *d.state;
  const Vec3d Ph = in.position;
  const Quatd Qh = in.orientation;
  DeviceTickOutput o;
  double g[6];
  coupling_energy_dev(sh.P, sh.Q, Ph, Qh, t.k_vcs, t.k_vct, g);
  o.force = Vec3d{g[0], g[1], g[2]};
  o.torque = Vec3d{g[3], g[4], g[5]};
  const double f = norm(o.force), tq = norm(o.torque);
  if (t.force_limit > 0 && f > t.force_limit) { o.force = (t.force_limit / f) * o.force; o.force_clamped = 1; }
  if (t.torque_limit > 0 && tq > t.torque_limit) { o.torque = (t.torque_limit / tq) * o.torque; o.torque_clamped = 1; }
  o.position = sh.P;
  o.orientation = sh.Q;
  o.penetration = sh.depth;
  unsigned pen = 0;
  int contacts = 0;
  for (int w = 0; w < kWarps; ++w) {
    contacts += sh.warp_contacts[w];
    pen = max(pen, sh.warp_pen[w]);
  }
  o.penetration_physical = __uint_as_float(pen);
  o.contacts = contacts;
  o.grasped = sh.nh;
  o.newton_steps = taken;
  o.newton_rejected = rejected;
  d.out[st.tick % d.ring] = o;
  st.anchor_position = sh.P;  // read_device of the next tick: the anchor is the pose at its start
  st.anchor_orientation = sh.Q;
  ++st.tick;
}

/// The E_svc target of virtual vertex j: its paired point on x_prev + alpha (x_vis - x_prev).
__device__ Vec3f blended_paired_point(const MeshDev& d, int j, float alpha) {
  if (alpha >= 1.f) return paired_point(d.x_vis, d.model.pair_vertex + 4 * j, d.model.pair_weight + 4 * j, d.model.pair_count[j]);
  Vec3f xb[4];
  const int idx[4] = {0, 1, 2, 3};
  const int count = d.model.pair_count[j];
  for (int k = 0; k < count; ++k) {
    const int a = d.model.pair_vertex[4 * j + k];
    xb[k] = d.x_prev[a] + alpha * (d.x_vis[a] - d.x_prev[a]);
  }
  return paired_point(xb, idx, d.model.pair_weight + 4 * j, count);
}

/// Device-scope acquire load and release store of the grid's hand-off counters (SyncDev).
__device__ __forceinline__ unsigned long long load_acquire(const unsigned long long* p) {
  unsigned long long v;
  asm volatile("ld.acquire.gpu.global.u64 %0, [%1];" : "=l"(v) : "l"(p) : "memory");
  return v;
}
__device__ __forceinline__ void store_release(unsigned long long* p, unsigned long long v) {
  asm volatile("st.release.gpu.global.u64 [%0], %1;" ::"l"(p), "l"(v) : "memory");
}

/// The shared memory of a block of ticks_kernel.
struct BlockShared {
  alignas(16) unsigned char posed_raw[sizeof(Posed)], physical_raw[sizeof(Posed)], input_raw[sizeof(DeviceTickInput)],
      tail_raw[sizeof(TailShared)];
  int warp_counts[kWarps][3];
  unsigned warp_pen[kWarps];
  __device__ Posed& posed() { return *reinterpret_cast<Posed*>(posed_raw); }
  __device__ Posed& physical() { return *reinterpret_cast<Posed*>(physical_raw); }
  __device__ DeviceTickInput& in() { return *reinterpret_cast<DeviceTickInput*>(input_raw); }
  __device__ TailShared& tail() { return *reinterpret_cast<TailShared*>(tail_raw); }
};

/// One iteration's work on chunk c (kBlock vertices, one per thread): begin (first), contact, the
/// Jacobi step, end (last), reach; then the chunk's reachable and held vertices in vertex order,
/// its contact count and deepest penetration (block_counts[4 c ..]).
__device__ void vertex_chunk(const MeshDev& d, const ToolConst& t, bool first, bool last, int c,
                             const Vec3f* __restrict__ qin, Vec3f* __restrict__ qout, Vec3f* __restrict__ v_out,
                             BlockShared& sm, unsigned long long* stamp) {
  const Posed& posed = sm.posed();
  const DeviceTickInput& in = sm.in();
  const int j = c * kBlock + threadIdx.x;
  bool reach = false, held = false, contact = false;
  float pen = 0.f;
  if (j < d.m) {
    const bool pinned = d.model.pinned[j];
    Vec3f q = qin[j], s, p;
    if (first) {  // Alg. 2 lines 1 and 6; §5.2 grasp at the jaws' closing, release at the opening
      d.q_start[j] = q;
      s = pinned ? q : predict_position(q, d.v[j], d.gravity, d.h);
      p = blended_paired_point(d, j, static_cast<float>(in.alpha));
      d.s[j] = s;
      d.p[j] = p;
      q = s;
      if (in.grasp < 0) {
        d.held[j] = 0;
      } else if (in.grasp > 0) {
        const Collider<double>& hb = d.grasp_boxes[in.grasp - 1];
        const Vec3d ls = apply_inverse(posed.frame, static_cast<Vec3d>(s));
        const double sd = signed_distance_local(hb, ls);
        const bool grasp = sd <= t.soft_margin;
        if (grasp) {
          const double w = 1.0 / (1.0 + t.eta * exp(sd / t.soft_margin));  // eq. [10]
          const Vec3d lf{0.0, fmin(fmax(ls.y, hb.a.y - hb.half.y), hb.a.y + hb.half.y),
                         fmin(fmax(ls.z, hb.a.z - hb.half.z), hb.a.z + hb.half.z)};
          d.grasp_local[j] = w * lf + (1.0 - w) * ls;
        }
        d.held[j] = grasp;
      }
    } else {
      s = d.s[j];
      p = d.p[j];
    }
    held = d.held[j];
    // E_con [3] target of this vertex (Alg. 2 line 10).
    Vec3f kt{};
    float ck = 0.f;
    if (held) {
      kt = static_cast<Vec3f>(t.k_con * apply(posed.frame, d.grasp_local[j]));
      ck = static_cast<float>(t.k_con);
      contact = true;
    } else if (const unsigned near = near_colliders(t, posed, q, kFloatSlack)) {
      SurfaceQuery<double> sq;
      if (deepest_collider(t.shape, posed.world, t.count, static_cast<Vec3d>(q), sq, near) >= 0) {
        kt = static_cast<Vec3f>(t.k_con * sq.point);
        ck = static_cast<float>(t.k_con);
        contact = true;
      }
    }
    // One Jacobi iteration (virtual_mesh.cpp: virtual_iteration).
    Vec3f qn = q;
    if (!pinned) {
      const float mh = d.model.mass[j] * d.inv_h2;
      Vec3f r = mh * (s - q)                                   // -dE_k/dq   [6]
                - coupling_gradient_virtual(p, q, d.k_svc)     // -dE_svc/dq [5]
                + kt - ck * q;                                 // -dE_con/dq [3]
      auto at = [&](int a) {  // q of vertex a in this iteration (iteration 0: its prediction)
        const Vec3f x = qin[a];
        if (!first || d.model.pinned[a]) return x;
        return predict_position(x, d.v[a], d.gravity, d.h);
      };
      // The incident edges in chunks of kEdgeChunk, every load of a chunk issued before its math
      // (one thread per vertex: the loads' latency, not the arithmetic, bounds this loop).
      const int k0 = d.model.edge_offsets[j], k1 = d.model.edge_offsets[j + 1];
      for (int kb = k0; kb < k1; kb += kEdgeChunk) {
        int4 it[kEdgeChunk];
        Vec3f xa[kEdgeChunk], xb[kEdgeChunk], rest[kEdgeChunk];
#pragma unroll
        for (int u = 0; u < kEdgeChunk; ++u)
          if (kb + u < k1) it[u] = d.model.edge_items[kb + u];
#pragma unroll
        for (int u = 0; u < kEdgeChunk; ++u)
          if (kb + u < k1) {
            xa[u] = at(it[u].x);
            xb[u] = at(it[u].y);
            rest[u] = d.model.rest_edge[it[u].z];
          }
#pragma unroll
        for (int u = 0; u < kEdgeChunk; ++u)
          if (kb + u < k1) {
            const Vec3f g = edge_spring_gradient(xa[u], xb[u], rest[u], d.k_s);  // [4]
            r += it[u].w ? g : -g;
          }
      }
      qn = q + r / (mh + d.model.stiff_diag[j] + ck);
    }
    qout[j] = qn;
    if (last) {
      v_out[j] = d.inv_h * (qn - d.q_start[j]);  // Alg. 2 line 23
      const unsigned near = held ? 0u : near_colliders(t, sm.physical(), qn, kFloatSlack);
      if (near) {  // depth in the physical tool
        const Vec3d qd = static_cast<Vec3d>(qn);
        double deepest = 0;
        for (int k = 0; k < t.count; ++k)
          if ((near >> k) & 1u)
            deepest = fmax(deepest, -signed_distance_local(t.shape[k], apply_inverse(sm.physical().world[k], qd)));
        pen = static_cast<float>(deepest);
      }
    }
    // Can the virtual tool's next Newton call reach j? (virtual_tool.cpp's per-vertex bound, 1 nm slack)
    // In float32 with kFloatSlack: a superset of the double test's vertices (the exact contact
    // tests on them decide), so no result depends on the rounding.
    if (!held) {
      const float T = static_cast<float>(t.reach_T), th = static_cast<float>(t.reach_th);
      const Vec3f o = qn - posed.origin_f;
      const float d2 = dot(o, o), dist = d2 > 0.f ? d2 * rsqrtf(d2) * 1.000001f : 0.f;
      const float bound = (T + th * (dist + T)) / (1.f - th) + kFloatSlack;
      reach = maybe_within(t, posed, qn, bound);
    }
  }
  // The chunk's reachable and held vertices in vertex order, contact count, deepest penetration.
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  const unsigned below = (1u << lane) - 1u;
  const unsigned br = __ballot_sync(~0u, reach), bh = __ballot_sync(~0u, held), bc = __ballot_sync(~0u, contact);
  unsigned pen_bits = __float_as_uint(pen);  // pen >= 0: the bits order as the values
  for (int o = 16; o > 0; o >>= 1) pen_bits = max(pen_bits, __shfl_xor_sync(~0u, pen_bits, o));
  if (lane == 0) {
    sm.warp_counts[warp][0] = __popc(br);
    sm.warp_counts[warp][1] = __popc(bh);
    sm.warp_counts[warp][2] = __popc(bc);
    sm.warp_pen[warp] = pen_bits;
  }
  __syncthreads();
  if (d.profile && threadIdx.x == 0) stamp[2] += global_ns() - stamp[4];
  int orr = 0, oh = 0;
  for (int w = 0; w < warp; ++w) { orr += sm.warp_counts[w][0]; oh += sm.warp_counts[w][1]; }
  if (reach) d.block_cand[c * kBlock + orr + __popc(br & below)] = j;
  if (held) d.block_held[c * kBlock + oh + __popc(bh & below)] = j;
  if (threadIdx.x == 0) {
    int cr = 0, chd = 0, cc = 0;
    unsigned pm = 0;
    for (int w = 0; w < kWarps; ++w) {
      cr += sm.warp_counts[w][0]; chd += sm.warp_counts[w][1]; cc += sm.warp_counts[w][2];
      pm = max(pm, sm.warp_pen[w]);
    }
    int* bcnt = d.block_counts + 4 * c;
    bcnt[0] = cr; bcnt[1] = chd; bcnt[2] = cc; bcnt[3] = static_cast<int>(pm);
  }
  __syncthreads();  // warp_counts are reused by the next chunk
}

/// One run of `count` ticks as one cooperative launch (every block resident; DeviceTickInput rows
/// from the tool state's tick on). Per virtual iteration ("epoch", numbered across runs from
/// `epoch`): every block poses the virtual tool and runs its chunks of vertices (chunk c = block
/// c, c + gridDim.x, ...), then arrives; block 0, the tail block, waits for every arrival, runs the
/// virtual tool (virtual_tool_tail) and releases the next epoch. Block 0 stays on its multiprocessor
/// for the whole run, so the tail's code stays in that one instruction cache, and an iteration
/// costs a hand-off through two counters instead of a kernel boundary.
__global__ void __launch_bounds__(kBlock) ticks_kernel(MeshDev d, ToolConst t, int count, unsigned long long epoch) {
  __shared__ BlockShared sm;
  const int K = d.iterations;
  const bool tail_block = blockIdx.x == 0;
  const unsigned long long others = gridDim.x - 1;
  // The other blocks arrive at `arrive`, block 0 releases at `release`; each counts epochs.
  auto arrive = [&] {
    __syncthreads();
    if (threadIdx.x == 0) {
      __threadfence();
      atomicAdd(&d.sync->arrive, 1ull);
    }
  };
  auto wait_release = [&](unsigned long long e) {
    if (threadIdx.x == 0)
      while (load_acquire(&d.sync->release) < e) {}
    __syncthreads();
  };
  auto wait_arrivals = [&](unsigned long long e) {
    __syncthreads();
    if (threadIdx.x == 0)
      while (load_acquire(&d.sync->arrive) < e * others) {}
    __syncthreads();
  };
  auto release = [&](unsigned long long e) {
    __syncthreads();
    if (threadIdx.x == 0) store_release(&d.sync->release, e);
  };
  for (int k = 0; k < count; ++k)
    for (int i = 0; i < K; ++i) {
      const bool first = i == 0, last = i == K - 1;
      // Iteration i reads a and writes b: q0 -> q1 -> q2 -> q1 ... -> q0 (the last). K = 1: q0 -> q1
      // and the velocities to v_scratch, copied back after the tail (v is the iteration's input).
      const Vec3f* a = first ? d.q0 : (i % 2 == 1 ? d.q1 : d.q2);
      Vec3f* b = (last && K > 1) ? d.q0 : (i % 2 == 0 ? d.q1 : d.q2);
      Vec3f* vo = K == 1 ? d.v_scratch : d.v;
      unsigned long long stamp[5] = {};  // profiling: start, setup, vertices, lists (sums over chunks), chunk start
      if (d.profile && threadIdx.x == 0) {
        stamp[0] = global_ns();
        if (tail_block) d.profile->start = stamp[0];
        if (d.profile->prev_end) atomicAdd(&d.profile->block_start, stamp[0] - d.profile->prev_end);
      }
      {
        const DeviceTickInput& gin = d.inputs[d.state->tick];
        if (threadIdx.x == 0) {
          sm.in() = gin;
          TailShared& tail = sm.tail();
          tail.P = d.state->position;  // for the virtual tool, if this block runs it
          tail.Q = d.state->orientation;
          tail.anchor_P = d.state->anchor_position;
          tail.anchor_Q = d.state->anchor_orientation;
        }
        pose_colliders(t, d.state->position, d.state->orientation, gin, sm.posed());
        if (last) pose_colliders(t, gin.position, gin.orientation, gin, sm.physical());
      }
      __syncthreads();
      if (d.profile && threadIdx.x == 0) stamp[1] = global_ns();
      for (int c = blockIdx.x; c < d.chunks; c += gridDim.x) {
        if (d.profile && threadIdx.x == 0) stamp[4] = global_ns();
        vertex_chunk(d, t, first, last, c, a, b, vo, sm, stamp);
        if (d.profile && threadIdx.x == 0) stamp[3] += global_ns() - stamp[4];
      }
      if (d.profile && threadIdx.x == 0) {
        const unsigned long long vertices = stamp[2], lists = stamp[3] - stamp[2];
        atomicAdd(&d.profile->sum[DeviceTickProfile::BlockSetup], stamp[1] - stamp[0]);
        atomicAdd(&d.profile->sum[DeviceTickProfile::BlockVertices], vertices);
        atomicAdd(&d.profile->sum[DeviceTickProfile::BlockLists], lists);
        atomicMax(&d.profile->vertices_max, vertices);
      }
      ++epoch;
      if (tail_block) {
        wait_arrivals(epoch);
        __threadfence();
        virtual_tool_tail(d, t, sm.in(), b, last, sm.posed(), sm.tail());
        release(epoch);
      } else {
        arrive();
        wait_release(epoch);
      }
      if (K == 1) {  // v_scratch -> v, q1 -> q0, each block its own chunks, then every block waits for all
        for (int c = blockIdx.x; c < d.chunks; c += gridDim.x) {
          const int j = c * kBlock + threadIdx.x;
          if (j < d.m) {
            d.q0[j] = b[j];
            d.v[j] = vo[j];
          }
        }
        ++epoch;
        if (tail_block) {
          wait_arrivals(epoch);
          release(epoch);
        } else {
          arrive();
          wait_release(epoch);
        }
      }
    }
}

Vec3f to_float(const Vec3d& v) { return static_cast<Vec3f>(v); }

/// A segment and radius whose capsule contains collider c (ToolConst's early-outs), rounded outward.
void bounding_segment(const Collider<double>& c, Vec3f& a, Vec3f& b, float& r) {
  double radius = c.radius;
  Vec3d A = c.a, B = c.b;
  if (c.shape == Shape::Sphere) {
    B = A;
  } else if (c.shape == Shape::Box) {  // along the longest half extent, through the centre
    const Vec3d h = c.half;
    const int k = h.x >= h.y && h.x >= h.z ? 0 : (h.y >= h.z ? 1 : 2);
    Vec3d axis{};
    double rest2 = 0;
    if (k == 0) { axis.x = h.x; rest2 = h.y * h.y + h.z * h.z; }
    if (k == 1) { axis.y = h.y; rest2 = h.x * h.x + h.z * h.z; }
    if (k == 2) { axis.z = h.z; rest2 = h.x * h.x + h.y * h.y; }
    A = c.a - axis;
    B = c.a + axis;
    radius = std::sqrt(rest2);
  }
  a = to_float(A);
  b = to_float(B);
  r = static_cast<float>(radius * (1 + 1e-6) + 1e-7);
}

}  // namespace

bool device_haptic_supported(const ToolModel& tool) {
  return tool.projection == Projection::ClosestPoint && tool.colliders.size() <= static_cast<std::size_t>(kMaxColliders);
}

struct CudaHapticTicks::Impl {
  CudaPhysicalSolver* physical = nullptr;
  int m = 0, n = 0, iterations = 1;
  int grid = 1;                           // ticks_kernel's blocks (all resident)
  long long ticks = 0, enqueued = 0;
  unsigned long long epoch = 0;           // virtual iterations (and K = 1 copies) enqueued so far
  cudaStream_t stream = nullptr;
  cudaEvent_t q_ready = nullptr, step_done = nullptr;
  std::vector<cudaEvent_t> done;  // per run_ticks handle
  std::vector<std::pair<long long, int>> runs;  // per handle: first tick, count
  int next_handle = 0;
  bool step_in_flight = false;
  cuda::VirtualModelArrays model;
  cuda::DeviceArray<std::uint8_t> held;
  cuda::DeviceArray<int> block_cand, block_held, block_counts, block_offsets, held_list;
  cuda::DeviceArray<SyncDev> sync;
  cuda::DeviceArray<Vec3f> x_prev, x_vis, v, v_scratch, q_start, s, p, q[3];
  cuda::DeviceArray<Vec3d> grasp_local, cand_q;
  cuda::DeviceArray<ToolStateDev> state;
  cuda::DeviceArray<DeviceTickInput> inputs;
  cuda::DeviceArray<Collider<double>> grasp_boxes;
  cuda::DeviceArray<ProfileDev> profile;
  cuda::PinnedArray<Vec3f> x_host;   // the physical step's x, copied out beside the ticks
  DeviceTickOutput* ring = nullptr;  // cudaHostAlloc, mapped
  int ring_size = 0;
  MeshDev dev;
  ToolConst tool;

  ~Impl() {
    for (cudaEvent_t e : done) cudaEventDestroy(e);
    if (q_ready) cudaEventDestroy(q_ready);
    if (step_done) cudaEventDestroy(step_done);
    if (ring) cudaFreeHost(ring);
    if (stream) cudaStreamDestroy(stream);
  }
};

CudaHapticTicks::CudaHapticTicks(const DeviceHapticSetup& S, std::span<const DeviceTickInput> in,
                                 CudaPhysicalSolver& physical)
    : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  if (!S.mesh || !S.tool) throw std::invalid_argument("CudaHapticTicks: no model");
  if (!device_haptic_supported(*S.tool))
    throw std::invalid_argument("CudaHapticTicks: the device tick supports the closest-point projection only");
  const VirtualModel& M = *S.mesh;
  I.physical = &physical;
  I.m = M.num_vertices;
  I.n = static_cast<int>(S.x0.size());
  I.iterations = std::max(1, S.virtual_iterations);
  I.ticks = static_cast<long long>(in.size());
  if (S.q0.size() != static_cast<std::size_t>(I.m)) throw std::invalid_argument("CudaHapticTicks: q0 has the wrong size");
  int lo = 0, hi = 0;
  EBH_CUDA_CHECK(cudaDeviceGetStreamPriorityRange(&lo, &hi));
  EBH_CUDA_CHECK(cudaStreamCreateWithPriority(&I.stream, cudaStreamNonBlocking, hi));  // the haptic side first
  EBH_CUDA_CHECK(cudaEventCreateWithFlags(&I.q_ready, cudaEventDisableTiming));
  EBH_CUDA_CHECK(cudaEventCreateWithFlags(&I.step_done, cudaEventDisableTiming));
  I.done.resize(8);
  for (cudaEvent_t& e : I.done) EBH_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming));
  I.runs.resize(I.done.size());
  cudaStream_t st = I.stream;
  auto up = [st](auto& arr, const auto& host) {
    arr.allocate(host.size());
    arr.upload(host.data(), st);
  };
  const int m = I.m;
  I.model.upload(M, st);
  std::vector<Vec3f> x0(I.n), q0(m), zero(m);
  for (int a = 0; a < I.n; ++a) x0[a] = to_float(S.x0[a]);
  for (int j = 0; j < m; ++j) q0[j] = to_float(S.q0[j]);
  I.x_host.allocate(I.n);
  up(I.x_prev, x0);
  up(I.x_vis, x0);
  up(I.v, zero);
  up(I.q[0], q0);
  for (auto* a : {&I.v_scratch, &I.q_start, &I.s, &I.p, &I.q[1], &I.q[2]}) a->allocate(m);
  up(I.held, std::vector<std::uint8_t>(m, 0));
  I.grasp_local.allocate(m);
  I.cand_q.allocate(m);
  const int chunks = std::max(1, cuda::blocks_for(m, kBlock));
  I.block_cand.allocate(std::size_t(chunks) * kBlock);
  I.block_held.allocate(std::size_t(chunks) * kBlock);
  I.block_counts.allocate(4 * std::size_t(chunks));
  I.block_offsets.allocate(2 * (std::size_t(chunks) + 1));
  I.held_list.allocate(m);
  up(I.sync, std::vector<SyncDev>(1, SyncDev{0, 0}));
  {  // every block of ticks_kernel resident (its hand-offs spin): at most the device's co-resident blocks
    int device = 0, coop = 0, sms = 0, per_sm = 0;
    EBH_CUDA_CHECK(cudaGetDevice(&device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
    EBH_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, ticks_kernel, kBlock, 0));
    if (!coop || per_sm < 1)
      throw std::runtime_error("CudaHapticTicks: the device cannot run the cooperative tick kernel");
    I.grid = std::max(1, std::min(chunks, per_sm * sms));
  }
  ToolStateDev s0{};
  s0.position = s0.anchor_position = S.pose0.position;
  s0.orientation = s0.anchor_orientation = S.pose0.orientation;
  s0.tick = 0;
  up(I.state, std::vector<ToolStateDev>(1, s0));
  up(I.inputs, std::vector<DeviceTickInput>(in.begin(), in.end()));
  std::vector<Collider<double>> boxes = S.grasp_boxes;
  if (boxes.empty()) boxes.emplace_back();
  up(I.grasp_boxes, boxes);
  I.ring_size = 4096;
  EBH_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&I.ring), I.ring_size * sizeof(DeviceTickOutput), cudaHostAllocMapped));
  DeviceTickOutput* ring_dev = nullptr;
  EBH_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&ring_dev), I.ring, 0));

  MeshDev& d = I.dev;
  d.m = m;
  d.chunks = chunks;
  d.ring = I.ring_size;
  d.k_s = float(M.k_s);
  d.k_svc = float(M.k_svc);
  d.h = float(S.h);
  d.inv_h = float(1.0 / S.h);
  d.inv_h2 = float(1.0 / (S.h * S.h));
  d.gravity = to_float(M.gravity);
  d.model = I.model.view();
  d.x_prev = I.x_prev.get();
  d.x_vis = I.x_vis.get();
  d.q_start = I.q_start.get();
  d.s = I.s.get();
  d.p = I.p.get();
  d.held = I.held.get();
  d.grasp_local = I.grasp_local.get();
  d.block_cand = I.block_cand.get();
  d.block_held = I.block_held.get();
  d.block_counts = I.block_counts.get();
  d.block_offsets = I.block_offsets.get();
  d.iterations = I.iterations;
  d.q0 = I.q[0].get();
  d.q1 = I.q[1].get();
  d.q2 = I.q[2].get();
  d.v = I.v.get();
  d.v_scratch = I.v_scratch.get();
  d.sync = I.sync.get();
  d.cand_q = I.cand_q.get();
  d.held_list = I.held_list.get();
  d.state = I.state.get();
  d.inputs = I.inputs.get();
  d.grasp_boxes = I.grasp_boxes.get();
  d.out = ring_dev;
  if (S.profile_stages) {
    up(I.profile, std::vector<ProfileDev>(1, ProfileDev{}));
    d.profile = I.profile.get();
  }

  const ToolModel& T = *S.tool;
  ToolConst& t = I.tool;
  t.count = static_cast<int>(T.colliders.size());
  for (int c = 0; c < t.count; ++c) {
    const Collider<double>& a = T.colliders[c];
    t.shape[c] = a;
    bounding_segment(a, t.seg_a[c], t.seg_b[c], t.seg_r[c]);
  }
  t.jaw_angle = T.has_jaws ? T.spec.forceps.jaw_max_angle_deg * std::numbers::pi / 180.0 : 0.0;
  t.k_con = S.k.k_con;
  t.k_vcs = S.k.k_vcs;
  t.k_vct = S.k.k_vct;
  t.stab_t = T.spec.stabilization_translation;
  t.stab_r = T.spec.stabilization_rotation;
  t.max_step = T.spec.max_step;
  t.max_rot = T.spec.max_step_rotation_deg * std::numbers::pi / 180.0;
  t.newton = std::max(1, T.spec.newton_iterations);
  t.force_limit = T.spec.force_limit;
  t.torque_limit = T.torque_limit;
  t.soft_margin = T.spec.forceps.soft_margin;
  t.eta = T.spec.forceps.eta;
  t.reach_T = t.newton * t.max_step;
  t.reach_th = std::min(t.newton * t.max_rot, 0.5);
  EBH_CUDA_CHECK(cudaStreamSynchronize(st));
}

CudaHapticTicks::~CudaHapticTicks() = default;

int CudaHapticTicks::capacity() const { return impl_->ring_size; }

void CudaHapticTicks::start_physical_step() {
  Impl& I = *impl_;
  auto* pst = static_cast<cudaStream_t>(I.physical->stream_handle());
  if (I.m > 0)
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.physical->device_q(), I.q[0].get(), I.m * sizeof(Vec3f), cudaMemcpyDeviceToDevice, I.stream));
  EBH_CUDA_CHECK(cudaEventRecord(I.q_ready, I.stream));
  EBH_CUDA_CHECK(cudaStreamWaitEvent(pst, I.q_ready, 0));
  I.physical->launch_device_step();
  EBH_CUDA_CHECK(cudaEventRecord(I.step_done, pst));
  if (I.n > 0)  // for the observer's on_step (the copy engine, not the haptic ticks, waits for it)
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_host.get(), I.physical->device_x(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToHost, pst));
  I.step_in_flight = true;
}

void CudaHapticTicks::deliver_physical_step() {
  Impl& I = *impl_;
  if (!I.step_in_flight) throw std::logic_error("CudaHapticTicks::deliver_physical_step: no step was started");
  EBH_CUDA_CHECK(cudaStreamWaitEvent(I.stream, I.step_done, 0));
  if (I.n > 0) {
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_prev.get(), I.x_vis.get(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToDevice, I.stream));
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_vis.get(), I.physical->device_x(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToDevice, I.stream));
  }
}

PhysicalStepReport CudaHapticTicks::finish_physical_step(std::vector<Vec3d>& x) {
  Impl& I = *impl_;
  I.step_in_flight = false;
  const PhysicalStepReport r = I.physical->device_step_report();
  EBH_CUDA_CHECK(cudaStreamSynchronize(static_cast<cudaStream_t>(I.physical->stream_handle())));
  x.resize(I.n);
  for (int a = 0; a < I.n; ++a) x[a] = static_cast<Vec3d>(I.x_host[a]);
  return r;
}

int CudaHapticTicks::run_ticks(int count) {
  Impl& I = *impl_;
  if (count <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks: count must be positive");
  if (count > I.ring_size) throw std::invalid_argument("CudaHapticTicks::run_ticks: more ticks than the output ring holds");
  if (I.enqueued + count > I.ticks) throw std::invalid_argument("CudaHapticTicks::run_ticks: past the last tick's input");
  {
    int n = count;
    unsigned long long e = I.epoch;
    void* args[] = {&I.dev, &I.tool, &n, &e};
    EBH_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<void*>(ticks_kernel), dim3(I.grid), dim3(kBlock), args, 0, I.stream));
    EBH_CUDA_LAUNCH_CHECK(I.stream, "ticks_kernel");
    I.epoch += static_cast<unsigned long long>(count) * (I.iterations + (I.iterations == 1 ? 1 : 0));
  }
  const int handle = I.next_handle;
  I.next_handle = (I.next_handle + 1) % static_cast<int>(I.done.size());
  EBH_CUDA_CHECK(cudaEventRecord(I.done[handle], I.stream));
  I.runs[handle] = {I.enqueued, count};
  I.enqueued += count;
  return handle;
}

void CudaHapticTicks::collect(int handle, std::span<DeviceTickOutput> out) {
  Impl& I = *impl_;
  const auto [first, count] = I.runs.at(handle);
  if (out.size() != static_cast<std::size_t>(count)) throw std::invalid_argument("CudaHapticTicks::collect: wrong size");
  EBH_CUDA_CHECK(cudaEventSynchronize(I.done[handle]));
  for (int k = 0; k < count; ++k) out[k] = I.ring[(first + k) % I.ring_size];
}

DeviceTickProfile CudaHapticTicks::profile() {
  Impl& I = *impl_;
  DeviceTickProfile r;
  if (!I.dev.profile) return r;
  ProfileDev p{};
  EBH_CUDA_CHECK(cudaMemcpyAsync(&p, I.dev.profile, sizeof(p), cudaMemcpyDeviceToHost, I.stream));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));
  r.launches = static_cast<long long>(p.launches);
  if (!p.launches || !p.tail_ns) return r;
  r.tail_clock_ghz = static_cast<double>(p.tail_cycles) / static_cast<double>(p.tail_ns);
  r.clamp_sweeps = p.clamps ? static_cast<double>(p.sweeps) / static_cast<double>(p.clamps) : 0.0;
  r.candidates = static_cast<double>(p.candidates) / static_cast<double>(p.launches);
  for (int k = 0; k < DeviceTickProfile::kStages; ++k) {
    const bool per_block = k >= DeviceTickProfile::BlockSetup && k <= DeviceTickProfile::BlockLists;  // summed over the blocks
    const bool cycles = k >= DeviceTickProfile::Gather && k <= DeviceTickProfile::Output;
    const double ns = static_cast<double>(static_cast<long long>(p.sum[k])) / (cycles ? r.tail_clock_ghz : 1.0);
    r.mean_us[k] = 1e-3 * ns / (static_cast<double>(p.launches) * (per_block ? I.grid : 1));
  }
  return r;
}

void CudaHapticTicks::snapshot(std::vector<Vec3d>& q, std::vector<Vec3d>& x_visible) {
  Impl& I = *impl_;
  std::vector<Vec3f> qf(I.m), xf(I.n);
  if (I.m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(qf.data(), I.q[0].get(), I.m * sizeof(Vec3f), cudaMemcpyDeviceToHost, I.stream));
  if (I.n > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(xf.data(), I.x_vis.get(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToHost, I.stream));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));
  q.resize(I.m);
  x_visible.resize(I.n);
  for (int j = 0; j < I.m; ++j) q[j] = static_cast<Vec3d>(qf[j]);
  for (int a = 0; a < I.n; ++a) x_visible[a] = static_cast<Vec3d>(xf[a]);
}

}  // namespace ebh
