// The whole haptic tick on a CUDA device (haptic_cuda.hpp; docs/CUDA.md "Device haptic tick").
//
// A run of ticks is one cooperative launch of ticks_kernel, every block resident. A tick is
// virtual_iterations steps; step s, per virtual vertex j (vertex_step, one thread each):
//   begin (first)   q_start, prediction s (Alg. 2 l. 6), E_svc target p from the blended physical
//                   result (l. 1), the grasp event of the tick (§5.2, eq. [10])
//   contact         E_con [3] target of j against the virtual tool held fixed (l. 10): the grasp
//                   target of a held vertex, else the closest point of the deepest collider
//   iteration       one Jacobi step of E_k + E_svc + E_con + E_s (l. 11-16)
//   end (last)      velocity (l. 23), depth of j in the physical tool (the penetration metric)
//   reach           whether the virtual tool's next Newton call can reach j (virtual_tool.cpp's bound)
// then, after the step, the virtual tool's Newton call (l. 18-19) on the reachable and held
// vertices: block 0 (tool_block, virtual_tool_tail) in double, with fixed-order block sums, the
// 6x6 PSD clamp (a Cholesky test, else a one-warp Jacobi eigen-decomposition), an Armijo line
// search, and (last step) the tick's outputs into a host-mapped ring (l. 26-27).
//
// The other blocks (vertex_blocks) run the vertices, a chunk of kBlock per block, and hand off to
// block 0 through two counters. A step is pipelined: it runs beside the Newton call before it,
// at the pose before that call. Only a vertex the call can reach can touch the tool at its new
// pose, so those (and the held ones) are deferred: their Jacobi sums go to block 0, which adds
// their contact at the new pose (finish_deferred) and filters the next candidates from a
// superset the other blocks flag (pipelined_lists). A run's first step and a grasp event's step
// are unpipelined: released after the call, with every vertex's contact in place.
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "energy/edge_spring.hpp"
#include "energy/quadratic.hpp"
#include "schedule/haptic_cuda.hpp"
#include "solver/cuda_util.cuh"
#include "solver/device_cuda.hpp"
#include "solver/virtual_jacobi.hpp"
#include "solver/virtual_mesh_device.cuh"
#include "tool/collider.hpp"
#include "tool/contact.hpp"
#include "tool/newton.hpp"
#include "tool/newton_warp.cuh"
#include "tool/tool_terms.hpp"

namespace ebh {
namespace {

constexpr int kBlock = 128;
constexpr int kWarps = kBlock / 32;
constexpr int kTailOffsets = 512;  // chunks whose list offsets the tail keeps in shared memory
constexpr int kCache = kBlock;      // candidates and held vertices the tail keeps in shared memory
constexpr int kReleaseThread = kBlock - 32;  // block 0's thread that releases the vertex blocks
constexpr int kPhysicalPoseThread = 64;      // block 0's first thread that poses the physical tool
constexpr int kEdgeChunk = 8;       // incident edges loaded at once (a surface vertex has ~6)
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
  float seg_L[kMaxColliders];  // the segment's farthest point from the tool origin (pipelined reach)
  double k_con = 0, k_vcs = 0, k_vct = 0, stab_t = 0, stab_r = 0;
  double max_step = 0, max_rot = 0;
  int newton = 1;
  double force_limit = 0, torque_limit = 0;
  double soft_margin = 1, eta = 1;
  float reach_T = 0, reach_th = 0;  // candidates: translation and rotation one call can reach
};

/// The virtual tool's state on the device (one instance).
struct ToolStateDev {
  Vec3d position;
  Quatd orientation;
  Vec3d anchor_position;
  Quatd anchor_orientation;
};

/// Stage times of the device tick (DeviceHapticSetup::profile_stages), summed over steps in
/// DeviceTickProfile's order: block 0's in SM cycles, the other blocks' in global-timer ns.
struct ProfileDev {
  unsigned long long sum[DeviceTickProfile::kStages];
  unsigned long long steps, unpipelined, updated, candidates, clamps, sweeps, definite;
  unsigned long long tail_cycles, tail_ns;  // block 0's SM cycles and time (its clock rate)
  unsigned long long release_ns[2];         // the release of step s (slot s & 1)
  unsigned long long vertices_max[2];       // step s's slowest block (slot s & 1)
};

__device__ __forceinline__ unsigned long long global_ns() {
  unsigned long long t;
  asm volatile("mov.u64 %0, %%globaltimer;" : "=l"(t));
  return t;
}

/// Block 0's stage marks, kept by its thread 0 in registers (SM cycles) for the whole run and
/// written to the ProfileDev once at its end, so that profiling adds no memory round trips.
struct TailMarks {
  bool on = false;
  unsigned long long start_ns = 0, start_clock = 0, last = 0;
  unsigned long long cycles[DeviceTickProfile::kStages] = {};
  int clamps = 0, sweeps = 0, definite = 0, candidates = 0, updated = 0, unpipelined = 0;
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
  __device__ void end(ProfileDev* p, int steps) {
    if (!on) return;
    for (int k = DeviceTickProfile::Wait; k <= DeviceTickProfile::Output; ++k) p->sum[k] += cycles[k];
    p->tail_cycles += clock64() - start_clock;
    p->tail_ns += global_ns() - start_ns;
    p->clamps += clamps;
    p->sweeps += sweeps;
    p->definite += definite;
    p->candidates += candidates;
    p->updated += updated;
    p->unpipelined += unpipelined;
    p->steps += steps;
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

/// The grid's hand-off counters (ticks_kernel): arrivals of the vertex blocks, and the last epoch
/// block 0 released; both count from the object's first run.
struct SyncDev {
  unsigned long long arrive, release;
};

/// The hand-offs between the ticks and the physical steps of a launch across physical periods
/// (run_ticks_with_steps), each counter on its own line, away from the ticks' counters (SyncDev):
/// `snapped`, the vertex blocks' q snapshots so far (each block counts one per period after the
/// first); `done`, the physical steps whose x is in the ring.
struct StepsDev {
  unsigned long long snapped;
  unsigned long long pad_[15];
  unsigned long long done;
};

/// The virtual tool's pose that block 0 publishes with a step's release (MeshDev::slots); each
/// vertex block poses the colliders from it (pose_colliders: the same bits as block 0's).
struct SlotPose {
  Vec3d P;
  Quatd Q;
};

/// A vertex a pipelined step left to block 0 (vertex_step<true>), at its place in its chunk's
/// list 1: what block 0 needs besides its contact, in one record.
struct alignas(16) DeferredVertex {
  Vec3f q;        // the iterate
  Vec3f r;        // the Jacobi sums without the contact
  Vec3f q_start;  // the tick's start (the velocity on its last step)
  float D;        // the diagonal without the contact; 0: pinned
  int j;
  int slot;       // -2: not held; held: its entry in TailShared::held_q, or -1
};

struct MeshDev {
  int m = 0, chunks = 0, ring = 1;  // chunks of kBlock vertices (a block of the grid runs several when needed)
  int iterations = 1;               // virtual iterations per tick
  bool pipeline = true;             // DeviceHapticSetup::pipeline
  float k_s = 0, k_svc = 0, h = 0, inv_h = 0, inv_h2 = 0;
  Vec3f gravity;
  cuda::VirtualModelView model;
  const Vec3f* x_prev = nullptr;  // the physical result before the visible one (the launch's first tick's)
  const Vec3f* x_vis = nullptr;   // the visible physical result
  // A launch across physical periods (run_ticks_with_steps; period 0: a launch within one period):
  // period k (ticks k period ..) blends x_prev = step k - 2's x and x_vis = step k - 1's, found in
  // xring[ring_slot(k)] (the physical result at tick 0 for k < 0). The first step of a tick
  // that starts period k > 0 copies q into snap_q, step k's input.
  int period = 0;
  const Vec3f* xring[4] = {};  // ring_slot(k): step k's entry
  Vec3f* snap_q = nullptr;
  StepsDev* steps = nullptr;
  Vec3f* q0 = nullptr;            // the virtual mesh at the tick's end; q1, q2: the iterates between
  Vec3f* q1 = nullptr;
  Vec3f* q2 = nullptr;
  Vec3f* v = nullptr;             // velocities: the last tick's (iteration 0 reads them), this tick's
  Vec3f* v_scratch = nullptr;     // one virtual iteration per tick: the velocities, copied to v
  SyncDev* sync = nullptr;
  const int4* edge_ell = nullptr;  // edge_ell(): edge item u of vertex j at u m + j
  // 2: the virtual tool's pose for step s's vertices (slot s & 1), published by block 0 with the
  // step's release: the pose the step's contacts use, or (a pipelined step, which runs beside the
  // Newton call that moves the tool) the pose before that call.
  SlotPose* slots = nullptr;
  Vec3f* q_start = nullptr;
  Vec3f* s = nullptr;
  Vec3f* p = nullptr;
  std::uint8_t* held = nullptr;
  Vec3d* grasp_local = nullptr;
  // Per chunk, two lists of its vertices in vertex order: (unpipelined steps) the reachable and the
  // held ones; (pipelined) those that may be reachable after the call and those deferred to block 0.
  Vec3f* block_cand = nullptr;      // chunks * kBlock: list 0 (the vertex's new iterate)
  int* block_held = nullptr;        // chunks * kBlock: list 1 (unpipelined steps)
  DeferredVertex* block_deferred = nullptr;  // chunks * kBlock: list 1 (pipelined steps)
  int* block_counts = nullptr;      // chunks * 4: list 0, list 1, contacts, penetration (float bits)
  int* block_offsets = nullptr;     // 2 (chunks + 1)
  Vec3d* cand_q = nullptr;          // m
  int* held_list = nullptr;         // m
  int* held_slot = nullptr;         // m: a held vertex's entry in TailShared::held_q, or -1
  ToolStateDev* state = nullptr;
  const DeviceTickInput* inputs = nullptr;
  const Collider<double>* grasp_boxes = nullptr;
  DeviceTickOutput* out = nullptr;  // host-mapped ring of `ring` rows
  ProfileDev* profile = nullptr;    // stage timestamps, or null
};

/// The entry of MeshDev::xring (and of CudaHapticTicks' ring) that holds step k's x: k % 3, or 3,
/// the physical result at tick 0, for k < 0. Period k blends ring_slot(k - 2) and ring_slot(k - 1).
__host__ __device__ __forceinline__ int ring_slot(long long k) { return k >= 0 ? static_cast<int>(k % 3) : 3; }

// The narrow phase and the posing of a collider are __noinline__: one copy each in the kernel,
// which the Newton call, its line search, block 0's vertices and the vertex blocks share. Inlined
// at every call site, block 0 ran ~140 KB of distinct code per run and its warps stalled on
// instruction fetch (Nsight Compute: no_inst, 21% of block 0's stall samples outside barriers);
// shared, the ticks run ~4% faster (docs/CUDA.md).

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

/// Block sum of the first kCount of v[kSums] over kBlock threads in a fixed order, the result in
/// out[0..kCount) (shared); and the block max of the non-negative m, into *max_out by thread 0 (the
/// deepest contact: one more value beside the sums, no barriers of its own). In each warp, many
/// values by a transposed butterfly: at the step of offset o a lane keeps one half of its values
/// and sends the other to lane ^ o, so lane L ends with value L's warp sum after 31 shuffles (a tree
/// per value would take 5 per value); then the warps in order.
template <int kCount>
__device__ void block_sum(const double* v, double m, double (*scratch)[kSums + 1], double* out, double* max_out) {
  static_assert(kCount >= 1 && kCount <= kSums);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  for (int o = 16; o > 0; o >>= 1) m = fmax(m, __shfl_xor_sync(~0u, m, o));
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
  if (lane == 31) scratch[warp][kSums] = m;
  __syncthreads();
  if (threadIdx.x < kCount) {
    double acc = 0;
    for (int w = 0; w < kWarps; ++w) acc += scratch[w][threadIdx.x];
    out[threadIdx.x] = acc;
  }
  if (threadIdx.x == 0) {
    double r = 0;
    for (int w = 0; w < kWarps; ++w) r = fmax(r, scratch[w][kSums]);
    *max_out = r;
  }
  __syncthreads();
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
  double sums[kWarps][kSums + 1];
  double total[kSums];
  float clamp_scratch[42];
  double dx[6], g[6];
  int warp_contacts[kWarps];
  unsigned warp_pen[kWarps];   // float bits of a non-negative depth
  int offsets[2 * (kTailOffsets + 1)];
  double E, slope, depth;
  int flag, nc, nh;
  int contacts;                // the step's vertices in contact (the tick's output on its last step)
  unsigned pen_bits;           // the step's deepest physical-tool penetration (float bits)
  int posed_current;           // whether the posed tool is at (P, Q) after the Newton call
  // The first kCache entries of the Newton call's lists (the rest in d.cand_q, d.held_list): read
  // by every evaluation and trial of the call, so kept here, entry i by thread i.
  Vec3d cand[kCache];          // a candidate's q
  Vec3d held_local[kCache], held_q[kCache];  // a held vertex's grasp point (tool frame) and q (its
                                             // slot: MeshDev::held_slot; the q of pipelined steps: finish_deferred)
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
/// Returns E (contact + grasp) and (thread 0) the deepest contact's depth in `depth`.
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
    const Vec3d qc = i < kCache ? sh.cand[i] : d.cand_q[i];
    const unsigned near = near_colliders(t, pt, static_cast<Vec3f>(qc), kFloatSlack);
    if (!near) continue;  // certainly outside
    if (kDerivs) {
      SurfaceQuery<double> sq;
      if (deepest_query(t, pt, qc, near, sq) < 0) continue;
      const double phi = -sq.sd;
      deepest = fmax(deepest, phi);
      acc[0] += contact_terms(t.k_con, phi, 1.0, sq.normal, qc - P, sq.hess, true, g, H);
    } else {  // E only: the deepest collider's signed distance
      const double phi = penetration(t, pt, qc, near);
      deepest = fmax(deepest, phi);
      acc[0] += 0.5 * t.k_con * phi * phi;
    }
  }
  for (int i = threadIdx.x; i < sh.nh; i += kBlock) {
    const bool cached = i < kCache;
    const int j = cached ? 0 : d.held_list[i];
    const GraspOffset<double> o = grasp_offset(pt.frame.R, P, cached ? sh.held_local[i] : d.grasp_local[j],
                                               cached ? sh.held_q[i] : static_cast<Vec3d>(q[j]));
    acc[0] += grasp_energy_term(t.k_con, o);
    if (kDerivs) grasp_derivative_terms<GraspRotation::Fused>(t.k_con, o, g, H);
  }
  if (kDerivs) {
    for (int k = 0; k < 6; ++k) acc[1 + k] = g[k];
    for (int a = 0; a < 6; ++a)
      for (int b = a; b < 6; ++b) acc[7 + cuda::upper(a, b)] = H[6 * a + b];
  }
  if (sh.nc + sh.nh == 0) {  // nothing near the tool: the sums are zero (skips the reduction)
    for (int k = threadIdx.x; k < kSums; k += kBlock) sh.total[k] = 0;
    depth = 0;
    __syncthreads();
    return 0;
  }
  block_sum<kDerivs ? kSums : 1>(acc, deepest, sh.sums, sh.total, &depth);  // depth: thread 0's
  return sh.total[0];
}

__device__ void tick_outputs(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in, long long tick,
                             TailShared& sh, int taken, int rejected);

/// Block 0: the virtual tool's Newton step (virtual_tool.cpp: update_virtual_tool) on the
/// candidates (d.cand_q, sh.nc) and the held vertices (d.held_list, sh.nh) of q, from the pose
/// (sh.P, sh.Q) at which `pt` is posed; then (`last`: the last step of tick `tick`) the tick's
/// outputs (a runtime flag, not a template: one copy of this code, which block 0's instruction
/// cache keeps from one step to the next). Leaves sh.posed_current: whether `pt` is still posed at
/// the result.
__device__ __forceinline__ void virtual_tool_tail(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in,
                                                  long long tick, const Vec3f* q, bool last, Posed& pt,
                                                  TailShared& sh, TailMarks& marks) {
  if (marks.on) marks.candidates += sh.nc;
  bool posed_current = true;  // thread 0: a trial poses pt, an accepted one is the result
  // Newton's method on E_tool (virtual_tool.cpp), q held fixed.
  const Vec3d Ph = in.position;
  const Quatd Qh = in.orientation;
  // sh.P, sh.Q and the anchor: the tool's state as the block read it at its start.
  const bool stabilised = t.stab_t > 0 || t.stab_r > 0;
  // E_tvc [2] (+ the stabilisation) and its gradient at (P, Q). The last thread computes it beside
  // the contact sums (it depends on the pose only), so it adds nothing to the chain.
  constexpr int kCouplingThread = kBlock - 1;
  auto coupling = [&](Vec3d P, Quatd Q, double* g) {
    double e = coupling_terms<CouplingAngle::OfComponents>(P, Q, Ph, Qh, t.k_vcs, t.k_vct, g);
    if (stabilised) {
      double gs[6];
      e += coupling_terms<CouplingAngle::OfComponents>(P, Q, sh.anchor_P, sh.anchor_Q, t.stab_t, t.stab_r, gs);
      for (int k = 0; k < 6; ++k) g[k] += gs[k];
    }
    return e;
  };
  // E_tool, its gradient (sh.E, sh.g), the contact Hessian (sh.total) and the deepest contact at
  // (sh.P, sh.Q): energy_at with derivatives.
  // `pt` is always the tool posed at (sh.P, sh.Q) here: the step's posed tool when the call
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
      const double h = lane < 21 ? sh.total[7 + lane] : 0.0;
      int hi = 0, hj = 0;
      cuda::upper_entry(lane < 21 ? lane : 0, hi, hj);
      const double diag = lane < 21 && hi == hj ? (hi < 3 ? t.k_vcs + t.stab_t : t.k_vct + t.stab_r) : 0.0;
      int sweeps = 0;
      bool factored = false;
      const double u = cuda::warp_clamped_factor(h, diag, lane, sh.clamp_scratch, factored, &sweeps);
      marks.mark(DeviceTickProfile::Clamp);
      if (marks.on && sweeps >= 0) { ++marks.clamps; marks.sweeps += sweeps; }
      if (marks.on && sweeps < 0) ++marks.definite;
      const double gk = lane < 6 ? sh.g[lane] : 0.0;
      double dx = 0;
      const bool ok = cuda::warp_cholesky_solve_factored(u, factored, -gk, lane, dx);
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
          const bool roundoff = newton_step_roundoff(nt * scale, nr * scale, sh.P);
          if (newton_decrease_visible(gdx, sh.E) && !roundoff) sh.flag = 1;
        }
      }
    }
    __syncthreads();
    marks.mark(DeviceTickProfile::Solve);
    if (sh.flag == 0) break;
    // Armijo line search: halve until E_tool does not increase enough.
    double alpha = 1.0;
    bool accepted = false;
    for (int hv = 0; hv < kNewtonMaxHalvings; ++hv, alpha *= 0.5) {
      // The trial pose, computed by each thread that uses it (same bits): the colliders' threads
      // pose it, the coupling thread evaluates E_tvc there, thread 0 keeps it.
      if (threadIdx.x < t.count || threadIdx.x == kCouplingThread) {
        const Vec3d P = sh.P + Vec3d{alpha * sh.dx[0], alpha * sh.dx[1], alpha * sh.dx[2]};
        const Quatd Q = trial_orientation_series(Vec3d{alpha * sh.dx[3], alpha * sh.dx[4], alpha * sh.dx[5]}, sh.Q);
        if (threadIdx.x < t.count) pose_collider(t, P, Q, in.jaw_cos, in.jaw_sin, threadIdx.x, pt);
        if (threadIdx.x == 0) { sh.trial_P = P; sh.trial_Q = Q; posed_current = false; }
        if (threadIdx.x == kCouplingThread) sh.coupling_E = coupling(P, Q, sh.coupling_g);
      }
      __syncthreads();
      double trial_depth = 0;
      const double Ec = tool_contact_sums<false>(d, t, q, pt, sh, trial_depth);  // synchronises the block
      if (threadIdx.x == 0) {
        const double Et = sh.coupling_E + Ec;
        sh.flag = armijo_accepts(Et, sh.E, alpha, sh.slope);
        if (sh.flag) {
          sh.P = sh.trial_P;
          sh.Q = sh.trial_Q;
          sh.E = Et;
          sh.depth = trial_depth;
          posed_current = true;
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
  if (threadIdx.x == 0) {
    ToolStateDev& st = *d.state;
    st.position = sh.P;
    st.orientation = sh.Q;
    sh.posed_current = posed_current;
    if (last) tick_outputs(d, t, in, tick, sh, taken, rejected);
  }
  __syncthreads();
  marks.mark(DeviceTickProfile::Output);
}

/// Algorithm 2 lines 26-27 (thread 0 of block 0, a tick's last step): the force and torque for the
/// device (tool_output), the metrics, into the ring; the next tick's anchor.
__device__ void tick_outputs(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in, long long tick,
                             TailShared& sh, int taken, int rejected) {
  ToolStateDev& st = *d.state;
  const Vec3d Ph = in.position;
  const Quatd Qh = in.orientation;
  DeviceTickOutput o;
  const CouplingOutput<double> c = coupling_output(sh.P, sh.Q, Ph, Qh, t.k_vcs, t.k_vct, t.force_limit, t.torque_limit);
  o.force = c.force;
  o.torque = c.torque;
  o.force_clamped = c.force_clamped;
  o.torque_clamped = c.torque_clamped;
  o.position = sh.P;
  o.orientation = sh.Q;
  o.penetration = sh.depth;
  o.penetration_physical = __uint_as_float(sh.pen_bits);
  o.contacts = sh.contacts;
  o.grasped = sh.nh;
  o.newton_steps = taken;
  o.newton_rejected = rejected;
  d.out[tick % d.ring] = o;
  st.anchor_position = sh.anchor_P = sh.P;  // read_device of the next tick: the anchor is the pose at its start
  st.anchor_orientation = sh.anchor_Q = sh.Q;
}

/// The E_svc target of virtual vertex j: its paired point on x_prev + alpha (x_vis - x_prev).
__device__ Vec3f blended_paired_point(const MeshDev& d, const Vec3f* x_prev, const Vec3f* x_vis, int j, float alpha) {
  if (alpha >= 1.f) return paired_point(x_vis, d.model.pair_vertex + 4 * j, d.model.pair_weight + 4 * j, d.model.pair_count[j]);
  Vec3f xb[4];
  const int idx[4] = {0, 1, 2, 3};
  const int count = d.model.pair_count[j];
  for (int k = 0; k < count; ++k) {
    const int a = d.model.pair_vertex[4 * j + k];
    xb[k] = lerp(x_prev[a], x_vis[a], alpha);
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

/// A device-scope release reduction (a vertex block's arrival): orders the block's writes before
/// the add without the full fence of __threadfence (fence.sc) that preceded a relaxed atomicAdd.
__device__ __forceinline__ void add_release(unsigned long long* p, unsigned long long v) {
  asm volatile("red.release.gpu.global.add.u64 [%0], %1;" ::"l"(p), "l"(v) : "memory");
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

/// What one vertex's step reports for its chunk's lists.
struct VertexFlags {
  bool list0 = false, list1 = false, contact = false;
  float pen = 0.f;  // depth in the physical tool (last step)
  Vec3f q{};        // the new iterate
};


/// The E_con [3] target of a held vertex with grasp point `local` (tool frame) against the tool
/// posed in `posed`: k_con times it into kt, k_con into ck.
__device__ void grasp_target(const ToolConst& t, const Posed& posed, Vec3d local, Vec3f& kt, float& ck) {
  kt = static_cast<Vec3f>(t.k_con * apply(posed.frame, local));
  ck = static_cast<float>(t.k_con);
}

/// E_con [3] target of vertex j at iterate q (Alg. 2 line 10) against the tool posed in `posed`:
/// the grasp target of a held vertex, else the closest point of the deepest collider; k_con times
/// it into kt, k_con into ck. Returns whether j is in contact.
__device__ bool contact_target(const MeshDev& d, const ToolConst& t, const Posed& posed, int j, Vec3f q, bool held,
                               Vec3f& kt, float& ck) {
  if (held) {
    grasp_target(t, posed, d.grasp_local[j], kt, ck);
    return true;
  }
  if (const unsigned near = near_colliders(t, posed, q, kFloatSlack)) {
    SurfaceQuery<double> sq;
    if (deepest_query(t, posed, static_cast<Vec3d>(q), near, sq) >= 0) {
      kt = static_cast<Vec3f>(t.k_con * sq.point);
      ck = static_cast<float>(t.k_con);
      return true;
    }
  }
  return false;
}

/// The end of vertex j's step at its new iterate qn: qout, and (last) the velocity (Alg. 2 line 23)
/// and the depth of j in the physical tool.
__device__ void vertex_end(const MeshDev& d, const ToolConst& t, const Posed& physical, bool last, int j, bool held,
                           Vec3f qn, Vec3f q_start, Vec3f* qout, Vec3f* v_out, VertexFlags& f) {
  qout[j] = qn;
  f.q = qn;
  if (last) {
    v_out[j] = d.inv_h * (qn - q_start);
    const unsigned near = held ? 0u : near_colliders(t, physical, qn, kFloatSlack);
    if (near) f.pen = static_cast<float>(penetration(t, physical, static_cast<Vec3d>(qn), near));
  }
}

/// Step s of virtual vertex j (one thread): begin (first), contact, one Jacobi step
/// q + (r + kt - ck q) / (D + ck), with r and D the sums without the contact; end (last).
///   kAhead = false (an unpipelined step): the contact of j against the virtual tool posed in
///     `posed`; list0: j is reachable from `posed` (a candidate of the Newton call after the
///     step); list1: j is held.
///   kAhead = true (the other blocks in a pipelined step, which runs beside the Newton call that
///     moves the tool away from `posed`): a held vertex, and one the call can reach, can touch the
///     tool at its new pose, so its step is left to block 0 (list1: deferred) with r and D kept for
///     it (r_part, d_part; 0: pinned); the others take no contact term; list0: j may be reachable
///     after the call.
template <bool kAhead>
__device__ VertexFlags vertex_step(const MeshDev& d, const ToolConst& t, const Posed& posed, const Posed& physical,
                                   const DeviceTickInput& in, bool first, bool last, int j,
                                   const Vec3f* __restrict__ qin, Vec3f* __restrict__ qout,
                                   Vec3f* __restrict__ v_out, DeferredVertex& deferred_out, bool p_ready) {
  VertexFlags f;
  const bool pinned = d.model.pinned[j];
  const Vec3f q_in = qin[j];
  // The loads that depend on j alone, issued before any branch: in the branches below, each waited
  // for the one before it (pinned, then the degree, then the edge items, then their ends); vertex
  // blocks 4.3 -> 4.0 us per step (H100).
  const int degree = d.model.edge_offsets[j + 1] - d.model.edge_offsets[j];
  const float mass = d.model.mass[j], stiff = d.model.stiff_diag[j];
  int4 it0[kEdgeChunk];  // the first chunk of edge items: every row of edge_ell has one
#pragma unroll
  for (int u = 0; u < kEdgeChunk; ++u) it0[u] = __ldg(&d.edge_ell[u * d.m + j]);
  Vec3f s, p;
  if (first) {  // Alg. 2 lines 1 and 6; §5.2 grasp at the jaws' closing, release at the opening
    d.q_start[j] = q_in;
    s = pinned ? q_in : predict_position(q_in, d.v[j], d.gravity, d.h);
    if (p_ready) {  // blended by this block ahead (vertex_blocks)
      p = d.p[j];
    } else {
      p = blended_paired_point(d, d.x_prev, d.x_vis, j, static_cast<float>(in.alpha));
      d.p[j] = p;
    }
    d.s[j] = s;
    if (!kAhead && in.grasp < 0) {
      d.held[j] = 0;
    } else if (!kAhead && in.grasp > 0) {
      const Collider<double>& hb = d.grasp_boxes[in.grasp - 1];
      const Vec3d ls = apply_inverse(posed.frame, static_cast<Vec3d>(s));
      const double sd = signed_distance_local(hb, ls);
      const bool grasp = grasp_reaches(sd, t.soft_margin);
      if (grasp) d.grasp_local[j] = grasp_point(hb, ls, sd, t.soft_margin, t.eta).local;  // eq. [10]
      d.held[j] = grasp;
    }
  } else {
    s = d.s[j];
    p = d.p[j];
  }
  const Vec3f q = first ? s : q_in;  // this iteration's iterate
  const bool held = d.held[j];
  Vec3f kt{};
  float ck = 0.f;
  if (!kAhead) f.contact = contact_target(d, t, posed, j, q, held, kt, ck);
  // One Jacobi iteration (virtual_mesh.cpp: virtual_iteration).
  Vec3f r{};
  float D = 0.f;
  if (!pinned) {
    const float mh = mass * d.inv_h2;
    r = inertia_coupling_residual(mh, s, q, p, d.k_svc);  // virtual_jacobi.hpp
    auto at = [&](int a) {  // q of vertex a in this iteration (iteration 0: its prediction)
      const Vec3f x = qin[a];
      if (!first || d.model.pinned[a]) return x;
      return predict_position(x, d.v[a], d.gravity, d.h);
    };
    // The incident edges (edge_ell) in chunks of kEdgeChunk, every load of a chunk issued before
    // its math (one thread per vertex: the loads' latency, not the arithmetic, bounds this loop).
    for (int kb = 0; kb < degree; kb += kEdgeChunk) {
      int4 it[kEdgeChunk];
      Vec3f xa[kEdgeChunk], xb[kEdgeChunk], rest[kEdgeChunk];
#pragma unroll
      for (int u = 0; u < kEdgeChunk; ++u) it[u] = kb == 0 ? it0[u] : __ldg(&d.edge_ell[(kb + u) * d.m + j]);
#pragma unroll
      for (int u = 0; u < kEdgeChunk; ++u)
        if (kb + u < degree) {
          xa[u] = at(it[u].x);
          xb[u] = at(it[u].y);
          rest[u] = d.model.rest_edge[it[u].z];
        }
#pragma unroll
      for (int u = 0; u < kEdgeChunk; ++u)
        if (kb + u < degree) add_edge_residual(r, edge_spring_gradient(xa[u], xb[u], rest[u], d.k_s), it[u].w != 0);
    }
    D = mh + stiff;
  }
  // -dE_con/dq [3]: kt - ck q. One reciprocal, not three divisions: an IEEE division takes its
  // slow path for some operands (a zero numerator), and a warp took it ~0.7 times per step
  // (Nsight Compute). finish_deferred uses the same expression.
  const Vec3f qn = pinned ? q : jacobi_update_with_contact(q, r, kt, ck, pinned ? 1.f : D + ck);
  if (kAhead) {
    bool deferred = held, superset = false;
    if (!held) {
      const Vec3f step = qn - q;
      const float s2 = dot(step, step);
      ahead_reach(t, posed, q, s2 > 0.f ? s2 * rsqrtf(s2) * 1.000001f : 0.f, deferred, superset);
    }
    if (deferred) {
      deferred_out.q = q;
      deferred_out.r = r;
      deferred_out.q_start = first || !last ? q_in : d.q_start[j];
      deferred_out.D = D;
      deferred_out.j = j;
      deferred_out.slot = held ? d.held_slot[j] : -2;
      f.list1 = true;
      return f;
    }
    f.list0 = superset;
  } else {
    f.list0 = !held && reachable(t, posed, qn);
    f.list1 = held;
  }
  vertex_end(d, t, physical, last, j, held, qn, first ? q_in : (last ? d.q_start[j] : Vec3f{}), qout, v_out, f);
  return f;
}

/// Block 0's part of vertex j in a pipelined step (vertex_step<true> deferred it): the contact
/// against the tool posed in `pt`, then the step from the other block's r and D.
__device__ VertexFlags finish_deferred(const MeshDev& d, const ToolConst& t, const Posed& pt, const Posed& physical,
                                       bool last, const DeferredVertex& v, Vec3f* qout, Vec3f* v_out, TailShared& sh) {
  VertexFlags f;
  const bool held = v.slot != -2;
  Vec3f kt{};
  float ck = 0.f;
  if (held) {  // its grasp point cached when it has a slot
    grasp_target(t, pt, v.slot >= 0 ? sh.held_local[v.slot] : d.grasp_local[v.j], kt, ck);
    f.contact = true;
  } else {
    f.contact = contact_target(d, t, pt, v.j, v.q, false, kt, ck);
  }
  const Vec3f qn = v.D == 0.f ? v.q : jacobi_update_with_contact(v.q, v.r, kt, ck, v.D == 0.f ? 1.f : v.D + ck);
  vertex_end(d, t, physical, last, v.j, held, qn, v.q_start, qout, v_out, f);
  f.list0 = !held && reachable(t, pt, qn);
  if (v.slot >= 0) sh.held_q[v.slot] = static_cast<Vec3d>(qn);  // the Newton call's cached q
  return f;
}

/// One step of chunk c (kBlock vertices, one per thread; vertex_step), then the chunk's two lists
/// in vertex order, its contact count and deepest penetration (block_counts[4 c ..]).
template <bool kAhead>
__device__ void vertex_chunk(const MeshDev& d, const ToolConst& t, bool first, bool last, bool p_ready, int c,
                             const Vec3f* __restrict__ qin, Vec3f* __restrict__ qout, Vec3f* __restrict__ v_out,
                             BlockShared& sm, unsigned long long* stamp) {
  const int j = c * kBlock + threadIdx.x;
  VertexFlags f;
  DeferredVertex deferred;
  if (j < d.m)
    f = vertex_step<kAhead>(d, t, sm.posed(), sm.physical(), sm.in(), first, last, j, qin, qout, v_out, deferred, p_ready);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  const unsigned below = (1u << lane) - 1u;
  const unsigned b0 = __ballot_sync(~0u, f.list0), b1 = __ballot_sync(~0u, f.list1), bc = __ballot_sync(~0u, f.contact);
  unsigned pen_bits = __float_as_uint(f.pen);  // pen >= 0: the bits order as the values
  for (int o = 16; o > 0; o >>= 1) pen_bits = max(pen_bits, __shfl_xor_sync(~0u, pen_bits, o));
  if (lane == 0) {
    sm.warp_counts[warp][0] = __popc(b0);
    sm.warp_counts[warp][1] = __popc(b1);
    sm.warp_counts[warp][2] = __popc(bc);
    sm.warp_pen[warp] = pen_bits;
  }
  __syncthreads();
  if (d.profile && threadIdx.x == 0) stamp[2] += global_ns() - stamp[4];
  int o0 = 0, o1 = 0;
  for (int w = 0; w < warp; ++w) { o0 += sm.warp_counts[w][0]; o1 += sm.warp_counts[w][1]; }
  if (f.list0) d.block_cand[c * kBlock + o0 + __popc(b0 & below)] = f.q;
  if (f.list1) {
    if (kAhead) d.block_deferred[c * kBlock + o1 + __popc(b1 & below)] = deferred;
    else d.block_held[c * kBlock + o1 + __popc(b1 & below)] = j;
  }
  if (threadIdx.x == 0) {
    int c0 = 0, c1 = 0, cc = 0;
    unsigned pm = 0;
    for (int w = 0; w < kWarps; ++w) {
      c0 += sm.warp_counts[w][0]; c1 += sm.warp_counts[w][1]; cc += sm.warp_counts[w][2];
      pm = max(pm, sm.warp_pen[w]);
    }
    int* bcnt = d.block_counts + 4 * c;
    bcnt[0] = c0; bcnt[1] = c1; bcnt[2] = cc; bcnt[3] = static_cast<int>(pm);
  }
  __syncthreads();  // warp_counts are reused by the next chunk
}

/// Block 0: the offsets of each chunk's two lists (exclusive scans of the chunk counts, chunked
/// over threads; in shared memory up to kTailOffsets chunks), their totals (n0, n1), and the
/// chunks' contact count and deepest penetration (sh.contacts, sh.pen_bits). Returns the offsets:
/// list 0's at [0, chunks], list 1's at [chunks + 1, 2 chunks + 1].
__device__ int* chunk_offsets(const MeshDev& d, TailShared& sh, int& n0, int& n1) {
  const int per = (d.chunks + kBlock - 1) / kBlock, b0 = threadIdx.x * per, b1 = min(b0 + per, d.chunks);
  int s0 = 0, s1 = 0, cc = 0;
  unsigned pm = 0;
  for (int b = b0; b < b1; ++b) {
    s0 += d.block_counts[4 * b];
    s1 += d.block_counts[4 * b + 1];
    cc += d.block_counts[4 * b + 2];
    pm = max(pm, static_cast<unsigned>(d.block_counts[4 * b + 3]));
  }
  for (int o = 16; o > 0; o >>= 1) {
    cc += __shfl_xor_sync(~0u, cc, o);
    pm = max(pm, __shfl_xor_sync(~0u, pm, o));
  }
  if ((threadIdx.x & 31) == 0) { sh.warp_contacts[threadIdx.x >> 5] = cc; sh.warp_pen[threadIdx.x >> 5] = pm; }
  int o0 = 0, o1 = 0;
  block_exclusive_scan(s0, s1, o0, o1, n0, n1);  // synchronises the block
  int* const off = d.chunks < kTailOffsets ? sh.offsets : d.block_offsets;
  for (int b = b0; b < b1; ++b) {
    off[b] = o0;
    off[d.chunks + 1 + b] = o1;
    o0 += d.block_counts[4 * b];
    o1 += d.block_counts[4 * b + 1];
  }
  if (threadIdx.x == 0) {
    off[d.chunks] = n0;
    off[2 * d.chunks + 1] = n1;
    int contacts = 0;
    unsigned pen = 0;
    for (int w = 0; w < kWarps; ++w) {
      contacts += sh.warp_contacts[w];
      pen = max(pen, sh.warp_pen[w]);
    }
    sh.contacts = contacts;
    sh.pen_bits = pen;
  }
  __syncthreads();
  return off;
}

/// Entry i of the chunks' list with offsets `off` (chunk_offsets): in the chunk b with
/// off[b] <= i < off[b + 1].
template <class T>
__device__ const T& list_item(const MeshDev& d, const int* off, const T* list, int i) {
  int lo = 0, hi = d.chunks - 1;
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;
    if (off[mid] <= i) lo = mid; else hi = mid - 1;
  }
  return list[lo * kBlock + (i - off[lo])];
}

/// Candidate i's q (TailShared::cand, then d.cand_q).
__device__ void put_candidate(const MeshDev& d, TailShared& sh, int i, Vec3f q) {
  if (i < kCache) sh.cand[i] = static_cast<Vec3d>(q); else d.cand_q[i] = static_cast<Vec3d>(q);
}

/// Block 0 after an unpipelined step of q: the candidates (their q in d.cand_q) and the held
/// vertices (d.held_list) in vertex order.
__device__ void unpipelined_lists(const MeshDev& d, const Vec3f* q, TailShared& sh) {
  int n0 = 0, n1 = 0;
  const int* off = chunk_offsets(d, sh, n0, n1);
  for (int i = threadIdx.x; i < n0; i += kBlock) put_candidate(d, sh, i, list_item(d, off, d.block_cand, i));
  for (int i = threadIdx.x; i < n1; i += kBlock) {  // the first kCache in shared memory (held_slot: their entry)
    const int j = list_item(d, off + d.chunks + 1, d.block_held, i);
    d.held_slot[j] = i < kCache ? i : -1;
    if (i < kCache) {
      sh.held_local[i] = d.grasp_local[j];
      sh.held_q[i] = static_cast<Vec3d>(q[j]);
    } else {
      d.held_list[i] = j;
    }
  }
  if (threadIdx.x == 0) { sh.nc = n0; sh.nh = n1; }
  __syncthreads();
}


/// Block 0 after the other blocks' part of a pipelined step (qin -> qout, beside the Newton call
/// that moved the tool to `pt`): the deferred vertices (held, or reachable by that call) finished
/// with their contact at `pt` (finish_deferred); then the candidates: those of the deferred
/// vertices, then those of the other blocks' superset list, tested at `pt` (the same test as an
/// unpipelined step's, so the same set, in this fixed order). The contact count and
/// deepest penetration add block 0's vertices to the chunks'.
__device__ void pipelined_lists(const MeshDev& d, const ToolConst& t, const Posed& pt, const Posed& physical,
                                bool last, Vec3f* qout, Vec3f* v_out, TailShared& sh, TailMarks& marks) {
  int nb = 0, nu = 0;
  const int* off = chunk_offsets(d, sh, nb, nu);
  int base = 0, contacts = 0;
  unsigned pen = 0;
  // Round r: deferred vertex r + i and superset entry r + i on thread i; the round's candidates
  // in that order (deferred, then superset), one scan for both.
  for (int r = 0; r < max(nu, nb); r += kBlock) {
    const int i = r + threadIdx.x;
    VertexFlags f;
    if (i < nu) f = finish_deferred(d, t, pt, physical, last, list_item(d, off + d.chunks + 1, d.block_deferred, i), qout, v_out, sh);
    bool fb = false;
    Vec3f xb{};
    if (i < nb) {
      xb = list_item(d, off, d.block_cand, i);
      fb = reachable(t, pt, xb);
    }
    contacts += f.contact;
    pen = max(pen, __float_as_uint(f.pen));
    int eu = 0, eb = 0, nu_r = 0, nb_r = 0;
    block_exclusive_scan(f.list0 ? 1 : 0, fb ? 1 : 0, eu, eb, nu_r, nb_r);
    if (f.list0) put_candidate(d, sh, base + eu, f.q);
    if (fb) put_candidate(d, sh, base + nu_r + eb, xb);
    base += nu_r + nb_r;
  }
  if (marks.on) marks.updated += nu;
  for (int o = 16; o > 0; o >>= 1) {
    contacts += __shfl_xor_sync(~0u, contacts, o);
    pen = max(pen, __shfl_xor_sync(~0u, pen, o));
  }
  if ((threadIdx.x & 31) == 0) {
    atomicAdd(&sh.contacts, contacts);  // integers: the same result in any order
    atomicMax(&sh.pen_bits, pen);
  }
  if (threadIdx.x == 0) sh.nc = base;
  __syncthreads();
  marks.mark(DeviceTickProfile::Update);
}

/// Whether two ticks' inputs open the jaws alike.
__device__ bool same_jaws(const DeviceTickInput& a, const DeviceTickInput& b) {
  return a.jaw_cos == b.jaw_cos && a.jaw_sin == b.jaw_sin;
}

/// The steps of one run: step s is iteration s % K of tick tick0 + s / K.
struct Schedule {
  int K;
  long long tick0;
  unsigned long long epoch0;  // the hand-off epochs before the run
  bool pipeline;
  const DeviceTickInput* inputs;
  Vec3f *q0, *q1, *q2, *v, *v_scratch;
  __device__ Schedule(const MeshDev& d, long long tick0_, unsigned long long epoch0_)
      : K(d.iterations), tick0(tick0_), epoch0(epoch0_), pipeline(d.pipeline), inputs(d.inputs), q0(d.q0), q1(d.q1),
        q2(d.q2), v(d.v), v_scratch(d.v_scratch) {}
  __device__ bool first(int s) const { return s % K == 0; }
  __device__ bool last(int s) const { return s % K == K - 1; }
  __device__ long long tick(int s) const { return tick0 + s / K; }
  __device__ const DeviceTickInput& input(int s) const { return inputs[tick(s)]; }
  /// The epoch of step s's vertices (K = 1: the next one is its copy phase).
  __device__ unsigned long long epoch(int s) const { return epoch0 + (K == 1 ? 2ull * s + 1 : s + 1ull); }
  /// Whether step s waits for the Newton call before it (an unpipelined step): the run's first
  /// step; every step with K = 1 (its iteration both reads and writes the velocities); a tick's
  /// first step with a grasp event (which changes the held vertices).
  __device__ bool unpipelined(int s) const {
    if (s == 0 || !pipeline || K == 1) return true;
    return first(s) && input(s).grasp != 0;
  }
  /// Iteration i reads in(s) and writes out(s): q0 -> q1 -> q2 -> q1 ... -> q0 (the last). K = 1:
  /// q0 -> q1 and the velocities to v_scratch, copied back in the copy phase.
  __device__ const Vec3f* in(int s) const {
    const int i = s % K;
    return i == 0 ? q0 : (i % 2 == 1 ? q1 : q2);
  }
  __device__ Vec3f* out(int s) const {
    const int i = s % K;
    return (i == K - 1 && K > 1) ? q0 : (i % 2 == 0 ? q1 : q2);
  }
  __device__ Vec3f* v_out() const { return K == 1 ? v_scratch : v; }
};

/// The blocks other than block 0: each step, once released, the step's vertices of their chunks
/// (chunk c = blockIdx.x - 1, + gridDim.x - 1, ...) at the pose of the step's slot, then arrive.
__device__ void vertex_blocks(const MeshDev& d, const ToolConst& t, const Schedule& S, int steps, BlockShared& sm) {
  const int blocks = gridDim.x - 1;
  bool p_ready = false;  // the step's E_svc targets blended ahead
  for (int s = 0; s < steps; ++s) {
    const unsigned long long e = S.epoch(s);
    const bool first = S.first(s), last = S.last(s), ahead = !S.unpipelined(s);
    {  // what does not depend on the virtual tool, before the release
      const DeviceTickInput& gin = S.input(s);
      if (threadIdx.x == 0) sm.in() = gin;
      if (last) pose_colliders(t, gin.position, gin.orientation, gin, sm.physical());
    }
    if (threadIdx.x == 0)
      while (load_acquire(&d.sync->release) < e) {}
    __syncthreads();
    unsigned long long stamp[5] = {};  // profiling: start, setup, vertices, lists (sums over chunks), chunk start
    if (d.profile && threadIdx.x == 0) stamp[0] = global_ns();
    if (threadIdx.x < t.count) {
      const SlotPose slot = d.slots[s & 1];
      pose_collider(t, slot.P, slot.Q, sm.in().jaw_cos, sm.in().jaw_sin, threadIdx.x, sm.posed());
    }
    __syncthreads();
    if (d.profile && threadIdx.x == 0) stamp[1] = global_ns();
    for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
      if (d.profile && threadIdx.x == 0) stamp[4] = global_ns();
      if (ahead) vertex_chunk<true>(d, t, first, last, p_ready, c, S.in(s), S.out(s), S.v_out(), sm, stamp);
      else vertex_chunk<false>(d, t, first, last, p_ready, c, S.in(s), S.out(s), S.v_out(), sm, stamp);
      if (d.profile && threadIdx.x == 0) stamp[3] += global_ns() - stamp[4];
    }
    if (d.profile && threadIdx.x == 0) {
      const unsigned long long vertices = stamp[2], lists = stamp[3] - stamp[2];
      atomicAdd(&d.profile->sum[DeviceTickProfile::BlockLag], stamp[0] - d.profile->release_ns[s & 1]);
      atomicAdd(&d.profile->sum[DeviceTickProfile::BlockSetup], stamp[1] - stamp[0]);
      atomicAdd(&d.profile->sum[DeviceTickProfile::BlockVertices], vertices);
      atomicAdd(&d.profile->sum[DeviceTickProfile::BlockLists], lists);
      atomicMax(&d.profile->vertices_max[s & 1], vertices);
    }
    __syncthreads();
    if (threadIdx.x == 0) {
      add_release(&d.sync->arrive, 1ull);
    }
    // A tick that starts a physical period k > 0 (a launch across periods): its start q, this
    // block's part of it, is step k's input (run_ticks_with_steps; step 0 starts from the initial mesh).
    if (d.period > 0 && first && S.tick(s) > 0 && S.tick(s) % d.period == 0) {
      const Vec3f* q = S.in(s);
      for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
        const int j = c * kBlock + threadIdx.x;
        if (j < d.m) d.snap_q[j] = q[j];
      }
      __syncthreads();
      if (threadIdx.x == 0) add_release(&d.steps->snapped, 1ull);
    }
    // While block 0 finishes a tick, the next tick's E_svc targets of this block's vertices: only
    // this block reads them (block 0 gets the deferred vertices' sums). The physical results they
    // blend are the launch's first period's, or (a launch across periods) the next tick's
    // period's, waited for when that tick starts the period.
    p_ready = last && s + 1 < steps;
    if (p_ready) {
      const float alpha = static_cast<float>(S.input(s + 1).alpha);
      const Vec3f *x_prev = d.x_prev, *x_vis = d.x_vis;
      if (d.period > 0) {
        const long long next = S.tick(s) + 1, k = next / d.period;
        if (next % d.period == 0) {
          if (threadIdx.x == 0)
            while (load_acquire(&d.steps->done) < static_cast<unsigned long long>(k)) {}
          __syncthreads();
        }
        x_vis = d.xring[ring_slot(k - 1)];
        x_prev = d.xring[ring_slot(k - 2)];
      }
      for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
        const int j = c * kBlock + threadIdx.x;
        if (j < d.m) d.p[j] = blended_paired_point(d, x_prev, x_vis, j, alpha);
      }
    }
    if (S.K == 1) {  // the copy phase: v_scratch -> v, q1 -> q0 for the chunks, once every block's step is done
      if (threadIdx.x == 0)
        while (load_acquire(&d.sync->release) < e + 1) {}
      __syncthreads();
      for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
        const int j = c * kBlock + threadIdx.x;
        if (j < d.m) {
          d.q0[j] = S.out(s)[j];
          d.v[j] = d.v_scratch[j];
        }
      }
      __syncthreads();
      if (threadIdx.x == 0) {
        add_release(&d.sync->arrive, 1ull);
      }
    }
  }
}

/// Block 0: the virtual tool. Each step, once the step's lists are made, it runs the Newton call
/// (virtual_tool_tail). An unpipelined step's vertices wait for the call before them: block 0
/// publishes the new pose, releases the step, waits for every block and gathers the lists. A
/// pipelined step runs beside that call: block 0 releases it with the pose before the call, runs
/// the call, then steps the vertices the other blocks left to it at the new pose and filters the
/// candidates (pipelined_lists). Block 0 stays on its multiprocessor for the whole run, so the
/// tool's code stays in that one instruction cache.
__device__ void tool_block(const MeshDev& d, const ToolConst& t, const Schedule& S, int steps, BlockShared& sm) {
  TailShared& sh = sm.tail();
  Posed& pt = sm.posed();
  const unsigned long long others = gridDim.x - 1;
  TailMarks marks;
  marks.begin(d.profile);
  if (threadIdx.x == 0) {
    sh.P = d.state->position;
    sh.Q = d.state->orientation;
    sh.anchor_P = d.state->anchor_position;
    sh.anchor_Q = d.state->anchor_orientation;
  }
  __syncthreads();
  // Releases epoch e; s >= 0: with the pose (sh.P, sh.Q) in step s's slot, from which each vertex
  // block poses the tool itself. By one thread of the last warp, with no barrier: the fence of its
  // release (its stores' round trip to L2) stalls no other warp, and the Newton call that follows
  // starts on the first warps (the candidates). What block 0 wrote before its last barrier is
  // visible with the release (the barrier orders it before the fence). Measured on the H100
  // against copying the posed tool (1.1 KB) by the whole block, a barrier and thread 0's release:
  // 65.5 against 67.0 us per tick; the same release by thread 0: 66.4.
  auto release = [&](unsigned long long e, int s) {
    if (threadIdx.x == kReleaseThread) {
      if (s >= 0) d.slots[s & 1] = SlotPose{sh.P, sh.Q};
      if (d.profile && s >= 0) d.profile->release_ns[s & 1] = global_ns();
      store_release(&d.sync->release, e);
    }
  };
  // Every vertex block's arrival at epoch e: step s's (s >= 0) or a copy phase's (s < 0).
  auto wait_arrivals = [&](unsigned long long e, int s) {
    __syncthreads();
    if (threadIdx.x == 0)
      while (load_acquire(&d.sync->arrive) < e * others) {}
    if (d.profile && threadIdx.x == 0 && s >= 0) {  // the step's slowest block
      d.profile->sum[DeviceTickProfile::BlockVerticesMax] += d.profile->vertices_max[s & 1];
      d.profile->vertices_max[s & 1] = 0;
    }
    __syncthreads();
    marks.mark(DeviceTickProfile::Wait);
  };
  // Step s unpipelined: the tool posed for it, the step released, every block waited for, its
  // lists gathered.
  auto unpipelined_step = [&](int s) {
    const DeviceTickInput& gin = S.input(s);
    if (threadIdx.x == 0) sm.in() = gin;
    pose_colliders(t, sh.P, sh.Q, gin, pt);
    __syncthreads();
    release(S.epoch(s), s);
    marks.mark(DeviceTickProfile::Lists);
    wait_arrivals(S.epoch(s), s);
    unpipelined_lists(d, S.out(s), sh);
    if (S.K == 1) release(S.epoch(s) + 1, -1);  // the copy phase (the Newton call reads neither q0 nor v)
    if (marks.on) ++marks.unpipelined;
    marks.mark(DeviceTickProfile::Lists);
  };
  unpipelined_step(0);
  for (int s = 0; s < steps; ++s) {
    // Here the lists of step s are made and pt is posed at (sh.P, sh.Q), the pose before its call,
    // with the jaws of sm.in(), step s's input.
    const bool next = s + 1 < steps, ahead = next && !S.unpipelined(s + 1);
    if (ahead) {
      const DeviceTickInput& gin = S.input(s + 1);
      // For block 0's vertices, by warp 2, which the evaluation that follows mostly leaves idle (by
      // threads 0-2 it delayed the candidates' terms; 63.0 against 64.1 us per tick with the
      // reciprocal below, H100).
      if (S.last(s + 1)) pose_colliders(t, gin.position, gin.orientation, gin, sm.physical(), kPhysicalPoseThread);
      release(S.epoch(s + 1), s + 1);
    }
    marks.mark(DeviceTickProfile::Lists);
    virtual_tool_tail(d, t, sm.in(), S.tick(s), S.out(s), S.last(s), pt, sh, marks);
    if (!next) break;
    if (S.K == 1) wait_arrivals(S.epoch(s) + 1, -1);  // the copies, before step s + 1 reads q0 and v
    if (ahead) {
      // pt at the call's result with step s + 1's jaws; sm.in() step s + 1's input.
      const bool new_tick = S.first(s + 1);
      const DeviceTickInput& gin = S.input(s + 1);
      const bool repose = !sh.posed_current || (new_tick && !same_jaws(gin, sm.in()));
      __syncthreads();
      if (repose) pose_colliders(t, sh.P, sh.Q, gin, pt);
      if (new_tick && threadIdx.x == 0) sm.in() = gin;
      __syncthreads();
      marks.mark(DeviceTickProfile::Lists);
      wait_arrivals(S.epoch(s + 1), s + 1);
      pipelined_lists(d, t, pt, sm.physical(), S.last(s + 1), S.out(s + 1), S.v_out(), sh, marks);
    } else {
      unpipelined_step(s + 1);
    }
  }
  marks.end(d.profile, steps);
}

/// One run of `count` ticks from tick `tick0` as one cooperative launch (every block resident;
/// block 0 the virtual tool, the others the virtual mesh; hand-off epochs numbered across runs
/// from `epoch0`).
__global__ void __launch_bounds__(kBlock)
    ticks_kernel(MeshDev d, ToolConst t, int count, long long tick0, unsigned long long epoch0) {
  __shared__ BlockShared sm;
  const Schedule S(d, tick0, epoch0);
  if (blockIdx.x == 0) tool_block(d, t, S, count * d.iterations, sm);
  else vertex_blocks(d, t, S, count * d.iterations, sm);
}

/// The physical step's stream before step k > 0 of a launch across periods: waits until every
/// vertex block has copied its part of the step's q (`target` = k times the vertex blocks).
/// It polls with relaxed loads, then fences once: an acquire load invalidates its multiprocessor's
/// L1, which a tick block sharing that multiprocessor depends on.
__global__ void wait_for_snapshots(const StepsDev* s, unsigned long long target) {
  if (threadIdx.x == 0) {
    for (;;) {
      unsigned long long v;
      asm volatile("ld.relaxed.gpu.global.u64 %0, [%1];" : "=l"(v) : "l"(&s->snapped) : "memory");
      if (v >= target) break;
      __nanosleep(1000);
    }
    __threadfence();
  }
}

/// Step k's x into the ring. A kernel of ours rather than cudaMemcpyAsync so that every kernel
/// between two steps on the physical stream is one that run_ticks_with_steps first launches while
/// nothing waits (whether the driver runs a device-to-device copy as a kernel was not checked).
__global__ void copy_positions(const Vec3f* from, Vec3f* to, int n) {
  for (int a = blockIdx.x * blockDim.x + threadIdx.x; a < n; a += gridDim.x * blockDim.x) to[a] = from[a];
}

/// The physical step's stream after step k's x is in the ring: publishes it to the ticks (k1 = k + 1).
__global__ void publish_step(StepsDev* s, unsigned long long k1) {
  if (threadIdx.x == 0) store_release(&s->done, k1);
}

Vec3f to_float(const Vec3d& v) { return static_cast<Vec3f>(v); }

/// `count` float32 positions (host memory) into `to`, in double.
void to_double(const Vec3f* from, int count, std::vector<Vec3d>& to) {
  to.resize(count);
  for (int a = 0; a < count; ++a) to[a] = static_cast<Vec3d>(from[a]);
}

/// The virtual mesh's incidence lists (VirtualModelArrays::edge_items: VirtualModel::edge_entries,
/// in their order) for the device tick, column-major: entry u of vertex j at u m + j, so that a
/// warp's 32 vertices load their u-th edges in one coalesced 512-byte line and without waiting for
/// the offsets; rows padded to a multiple of kEdgeChunk.
std::vector<int4> edge_ell(const VirtualModel& M) {
  const int m = M.num_vertices;
  int width = 0;
  for (int j = 0; j < m; ++j) width = std::max(width, M.edge_offsets[j + 1] - M.edge_offsets[j]);
  width = std::max(kEdgeChunk, (width + kEdgeChunk - 1) / kEdgeChunk * kEdgeChunk);
  std::vector<int4> ell(std::size_t(width) * m, make_int4(0, 0, 0, 0));
  for (int j = 0; j < m; ++j)
    for (int k = M.edge_offsets[j]; k < M.edge_offsets[j + 1]; ++k)
      ell[std::size_t(k - M.edge_offsets[j]) * m + j] = cuda::edge_item(M, k);
  return ell;
}

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
  int grid = 2;                           // ticks_kernel's blocks (all resident): block 0 and the vertices' blocks
  long long ticks = 0, enqueued = 0;
  unsigned long long epoch = 0;           // virtual iterations (and K = 1 copies) enqueued so far
  cudaStream_t stream = nullptr;
  cudaEvent_t q_ready = nullptr, step_done = nullptr;
  std::vector<cudaEvent_t> done;  // per run_ticks handle
  std::vector<std::pair<long long, int>> runs;  // per handle: first tick, count
  int next_handle = 0;
  bool step_in_flight = false;
  // Launches across physical periods (run_ticks_with_steps); not mixed with start_physical_step.
  enum class Steps { Unused, PerPeriod, InLaunch } steps_mode = Steps::Unused;
  int period = 0;                          // DeviceHapticSetup::ticks_per_step
  int step_slots = 64;                     // physical steps in flight at most
  int carveout_beside_steps = -1;          // ticks_kernel's carve-out in that mode (-1: L1-first as in the others)
  long long steps_enqueued = 0, steps_finished = 0;
  cuda::DeviceArray<StepsDev> steps_sync;
  cuda::DeviceArray<Vec3f> xring[3];       // step k's x in xring[ring_slot(k)]
  cuda::PinnedArray<Vec3f> x_slots;        // step k's x for finish_step, at (k % step_slots) n
  std::vector<cudaEvent_t> step_ready;     // per slot: the step's x copied and published
  cuda::VirtualModelArrays model;
  cuda::DeviceArray<std::uint8_t> held;
  cuda::DeviceArray<Vec3f> block_cand;
  cuda::DeviceArray<int> block_held, block_counts, block_offsets, held_list, held_slot;
  cuda::DeviceArray<SyncDev> sync;
  cuda::DeviceArray<int4> edge_ell;
  cuda::DeviceArray<SlotPose> slots;
  cuda::DeviceArray<Vec3f> x_prev, x_vis, v, v_scratch, q_start, s, p, q[3];
  cuda::DeviceArray<DeferredVertex> block_deferred;
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
    for (cudaEvent_t e : step_ready) cudaEventDestroy(e);
    if (q_ready) cudaEventDestroy(q_ready);
    if (step_done) cudaEventDestroy(step_done);
    if (ring) cudaFreeHost(ring);
    if (stream) cudaStreamDestroy(stream);
  }

  /// The physical step's q: the virtual mesh after the last enqueued tick (q[0]), copied on the
  /// ticks' stream; the physical stream `pst` waits for the copy.
  void hand_q_to_physical(cudaStream_t pst) {
    if (m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(physical->device_q(), q[0].get(), m * sizeof(Vec3f), cudaMemcpyDeviceToDevice, stream));
    EBH_CUDA_CHECK(cudaEventRecord(q_ready, stream));
    EBH_CUDA_CHECK(cudaStreamWaitEvent(pst, q_ready, 0));
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
  I.period = S.ticks_per_step;
  if (I.period < 0) throw std::invalid_argument("CudaHapticTicks: ticks_per_step must not be negative");
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
  up(I.edge_ell, edge_ell(M));
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
  I.block_deferred.allocate(std::size_t(chunks) * kBlock);
  I.block_counts.allocate(4 * std::size_t(chunks));
  I.block_offsets.allocate(2 * (std::size_t(chunks) + 1));
  I.held_list.allocate(m);
  I.held_slot.allocate(m);
  up(I.sync, std::vector<SyncDev>(1, SyncDev{0, 0}));
  I.slots.allocate(2);
  if (S.max_blocks < 0 || S.max_blocks == 1)
    throw std::invalid_argument("CudaHapticTicks: max_blocks must be 0 (no cap) or at least 2");
  {  // every block of ticks_kernel resident (its hand-offs spin): at most the device's co-resident blocks
    int device = 0, coop = 0, sms = 0, per_sm = 0;
    EBH_CUDA_CHECK(cudaGetDevice(&device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
    // As much L1 as the kernel's shared memory leaves: L1 serves a large share of its loads (H100,
    // with the physical steps beside: 71.9 us per tick against 72.3 with the driver's default
    // carve-out, 88.5 with the whole shared memory carved out; docs/CUDA.md).
    EBH_CUDA_CHECK(cudaFuncSetAttribute(ticks_kernel, cudaFuncAttributePreferredSharedMemoryCarveout,
                                        cudaSharedmemCarveoutMaxL1));
    // With the physical steps inside the launches (run_ticks_with_steps), enough shared memory on
    // each tick block's multiprocessor for one block of the step beside it; with the L1-first
    // carve-out the step's blocks fit only on the multiprocessors the ticks leave free (32 of 132
    // on the H100: 524 us per step beside the ticks instead of 233; docs/CUDA.md).
    cudaFuncAttributes fa{};
    EBH_CUDA_CHECK(cudaFuncGetAttributes(&fa, ticks_kernel));
    int reserved = 0, max_shared = 0, major = 0, minor = 0;
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&reserved, cudaDevAttrReservedSharedMemoryPerBlock, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&max_shared, cudaDevAttrMaxSharedMemoryPerMultiprocessor, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&minor, cudaDevAttrComputeCapabilityMinor, device));
    const std::size_t need = fa.sharedSizeBytes + physical.block_shared_bytes() + 2 * std::size_t(reserved);
    I.carveout_beside_steps = shared_carveout_percent(need, std::size_t(max_shared), shared_memory_configs_kb(major, minor));
    EBH_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, ticks_kernel, kBlock, 0));
    if (!coop || per_sm * sms < 2)
      throw std::runtime_error("CudaHapticTicks: the device cannot run the cooperative tick kernel");
    I.grid = std::min(chunks + 1, per_sm * sms);  // block 0 runs no chunks
    if (S.max_blocks > 0) I.grid = std::min(I.grid, S.max_blocks);
  }
  ToolStateDev s0{};
  s0.position = s0.anchor_position = S.pose0.position;
  s0.orientation = s0.anchor_orientation = S.pose0.orientation;
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
  d.edge_ell = I.edge_ell.get();
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
  d.pipeline = S.pipeline;
  d.slots = I.slots.get();
  d.q0 = I.q[0].get();
  d.q1 = I.q[1].get();
  d.q2 = I.q[2].get();
  d.v = I.v.get();
  d.v_scratch = I.v_scratch.get();
  d.block_deferred = I.block_deferred.get();
  d.sync = I.sync.get();
  d.cand_q = I.cand_q.get();
  d.held_list = I.held_list.get();
  d.held_slot = I.held_slot.get();
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
    // The segment's farthest point from the tool origin (a jaw's frame turns about that origin).
    const double L = std::max(norm(static_cast<Vec3d>(t.seg_a[c])), norm(static_cast<Vec3d>(t.seg_b[c])));
    t.seg_L[c] = static_cast<float>(L * (1 + 1e-6) + 1e-7);
  }
  t.k_con = S.k.k_con;
  t.k_vcs = S.k.k_vcs;
  t.k_vct = S.k.k_vct;
  t.stab_t = T.spec.stabilization_translation;
  t.stab_r = T.spec.stabilization_rotation;
  const NewtonLimits lim = newton_limits(T.spec);
  t.max_step = lim.max_step;
  t.max_rot = lim.max_rot;
  t.newton = lim.iterations;
  t.force_limit = T.spec.force_limit;
  t.torque_limit = T.torque_limit;
  t.soft_margin = T.spec.forceps.soft_margin;
  t.eta = T.spec.forceps.eta;
  t.reach_T = static_cast<float>(lim.reach_translation);
  t.reach_th = static_cast<float>(lim.reach_rotation);
  EBH_CUDA_CHECK(cudaStreamSynchronize(st));
}

CudaHapticTicks::~CudaHapticTicks() = default;

int CudaHapticTicks::capacity() const { return impl_->ring_size; }

void CudaHapticTicks::start_physical_step() {
  Impl& I = *impl_;
  if (I.steps_mode == Impl::Steps::InLaunch)
    throw std::logic_error("CudaHapticTicks::start_physical_step: the physical steps run in the launches (run_ticks_with_steps)");
  I.steps_mode = Impl::Steps::PerPeriod;
  auto* pst = static_cast<cudaStream_t>(I.physical->stream_handle());
  I.hand_q_to_physical(pst);
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
  to_double(I.x_host.get(), I.n, x);
  return r;
}

int CudaHapticTicks::run_ticks(int count) {
  Impl& I = *impl_;
  if (I.steps_mode == Impl::Steps::InLaunch)
    throw std::logic_error("CudaHapticTicks::run_ticks: the physical steps run in the launches (run_ticks_with_steps)");
  return launch_ticks(count);
}

int CudaHapticTicks::run_ticks_with_steps(int count) {
  Impl& I = *impl_;
  if (I.steps_mode == Impl::Steps::PerPeriod || (I.steps_mode == Impl::Steps::Unused && I.enqueued > 0))
    throw std::logic_error("CudaHapticTicks::run_ticks_with_steps: not after run_ticks or start_physical_step");
  if (I.period <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: setup.ticks_per_step is 0");
  if (count <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: count must be positive");
  // Checked before any step is enqueued: a step whose ticks never run would wait forever.
  if (count > I.ring_size) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: more ticks than the output ring holds");
  if (I.enqueued + count > I.ticks) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: past the last tick's input");
  const long long N = I.period, a = I.enqueued, b = a + count;
  const long long k0 = (a + N - 1) / N, k1 = (b + N - 1) / N;  // the steps of the periods starting in [a, b)
  if (k1 - I.steps_finished > I.step_slots)
    throw std::logic_error("CudaHapticTicks::run_ticks_with_steps: more physical steps in flight than step_capacity(); "
                           "finish_step the oldest first");
  cudaStream_t pst = static_cast<cudaStream_t>(I.physical->stream_handle());
  const bool first_use = I.steps_mode == Impl::Steps::Unused;
  if (first_use) {  // the ring, the slots, the counters, the carve-out
    I.steps_mode = Impl::Steps::InLaunch;
    // The kernel's attribute (process-wide): a later CudaHapticTicks sets L1-first again.
    if (I.carveout_beside_steps >= 0)
      EBH_CUDA_CHECK(cudaFuncSetAttribute(ticks_kernel, cudaFuncAttributePreferredSharedMemoryCarveout,
                                          I.carveout_beside_steps));
    I.physical->set_device_step_slots(I.step_slots);
    I.physical->prepare_device_step();
    for (auto& x : I.xring) x.allocate(std::max(I.n, 1));
    I.x_slots.allocate(std::size_t(I.step_slots) * std::max(I.n, 1));
    I.steps_sync.allocate(1);
    EBH_CUDA_CHECK(cudaMemsetAsync(I.steps_sync.get(), 0, sizeof(StepsDev), I.stream));
    I.step_ready.resize(I.step_slots);
    for (cudaEvent_t& e : I.step_ready) EBH_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming));
    MeshDev& d = I.dev;
    d.period = I.period;
    for (int k = 0; k < 3; ++k) d.xring[k] = I.xring[k].get();
    d.xring[ring_slot(-1)] = I.x_prev.get();  // the physical result at tick 0 (never overwritten in this mode)
    d.snap_q = I.physical->device_q();
    d.steps = I.steps_sync.get();
    EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));  // the counters zeroed before the physical stream polls them
  }
  // The launch's first tick blends its period's physical results: that of step ka - 1 waited for
  // (before this call's steps take slots: a slot's event is re-recorded by a later step).
  MeshDev& d = I.dev;
  const long long ka = a / N;
  if (ka >= 1) EBH_CUDA_CHECK(cudaStreamWaitEvent(I.stream, I.step_ready[(ka - 1) % I.step_slots], 0));
  d.x_vis = d.xring[ring_slot(ka - 1)];
  d.x_prev = d.xring[ring_slot(ka - 2)];
  const unsigned long long vertex_blocks = static_cast<unsigned long long>(I.grid - 1);
  // Step k: its q (k = 0: the initial mesh, copied on the ticks' stream before they run; k > 0:
  // the ticks' snapshot, waited for), the step, its x into the ring and the host slot, published.
  auto enqueue_step = [&](long long k) {
    const int slot = static_cast<int>(k % I.step_slots);
    if (k == 0) {
      I.hand_q_to_physical(pst);
    } else {
      wait_for_snapshots<<<1, 32, 0, pst>>>(I.steps_sync.get(), static_cast<unsigned long long>(k) * vertex_blocks);
      EBH_CUDA_LAUNCH_CHECK(pst, "wait_for_snapshots");
    }
    I.physical->launch_device_step(slot);
    if (I.n > 0) {
      Vec3f* x = I.xring[ring_slot(k)].get();
      copy_positions<<<cuda::blocks_for(I.n, 256), 256, 0, pst>>>(I.physical->device_x(), x, I.n);
      EBH_CUDA_LAUNCH_CHECK(pst, "copy_positions");
      EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_slots.get() + std::size_t(slot) * I.n, x, I.n * sizeof(Vec3f),
                                     cudaMemcpyDeviceToHost, pst));
    }
    publish_step<<<1, 32, 0, pst>>>(I.steps_sync.get(), static_cast<unsigned long long>(k + 1));
    EBH_CUDA_LAUNCH_CHECK(pst, "publish_step");
    EBH_CUDA_CHECK(cudaEventRecord(I.step_ready[slot], pst));
  };
  I.steps_enqueued = k1;
  if (first_use) {
    // With lazy module loading (the CUDA 12 default) a kernel's first launch may wait for the
    // device's running kernels; here those can be waiting for it (the ticks for a step's x, the
    // physical stream for the ticks' q), a deadlock. So every kernel of the hand-off is first
    // launched while none of them waits: wait_for_snapshots with nothing to wait for, step 0
    // (which waits for no ticks), the ticks (which wait for step 0 only, at tick N - 1), and
    // only then the steps that wait for the ticks.
    wait_for_snapshots<<<1, 32, 0, pst>>>(I.steps_sync.get(), 0ull);
    EBH_CUDA_LAUNCH_CHECK(pst, "wait_for_snapshots");
    enqueue_step(0);
    const int handle = launch_ticks(count);
    for (long long k = 1; k < k1; ++k) enqueue_step(k);
    return handle;
  }
  for (long long k = k0; k < k1; ++k) enqueue_step(k);
  return launch_ticks(count);
}

int CudaHapticTicks::steps_in_flight() const { return static_cast<int>(impl_->steps_enqueued - impl_->steps_finished); }

int CudaHapticTicks::step_capacity() const { return impl_->step_slots; }

PhysicalStepReport CudaHapticTicks::finish_step(std::vector<Vec3d>& x) {
  Impl& I = *impl_;
  if (I.steps_finished >= I.steps_enqueued) throw std::logic_error("CudaHapticTicks::finish_step: no step in flight");
  const int slot = static_cast<int>(I.steps_finished % I.step_slots);
  ++I.steps_finished;
  const PhysicalStepReport r = I.physical->device_step_report(slot);
  EBH_CUDA_CHECK(cudaEventSynchronize(I.step_ready[slot]));
  to_double(I.x_slots.get() + std::size_t(slot) * I.n, I.n, x);
  return r;
}

int CudaHapticTicks::launch_ticks(int count) {
  Impl& I = *impl_;
  if (count <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks: count must be positive");
  if (count > I.ring_size) throw std::invalid_argument("CudaHapticTicks::run_ticks: more ticks than the output ring holds");
  if (I.enqueued + count > I.ticks) throw std::invalid_argument("CudaHapticTicks::run_ticks: past the last tick's input");
  {
    int n = count;
    long long tick0 = I.enqueued;
    unsigned long long e = I.epoch;
    void* args[] = {&I.dev, &I.tool, &n, &tick0, &e};
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
  if (!p.steps || !p.tail_ns) return r;
  const double steps = static_cast<double>(p.steps);
  r.tail_clock_ghz = static_cast<double>(p.tail_cycles) / static_cast<double>(p.tail_ns);
  r.clamp_sweeps = p.clamps ? static_cast<double>(p.sweeps) / static_cast<double>(p.clamps) : 0.0;
  r.definite = p.clamps + p.definite ? static_cast<double>(p.definite) / static_cast<double>(p.clamps + p.definite) : 0.0;
  r.candidates = static_cast<double>(p.candidates) / steps;
  r.unpipelined = static_cast<double>(p.unpipelined) / steps;
  r.updated = p.steps > p.unpipelined ? static_cast<double>(p.updated) / static_cast<double>(p.steps - p.unpipelined) : 0.0;
  for (int k = 0; k < DeviceTickProfile::kStages; ++k) {
    const bool cycles = k <= DeviceTickProfile::Output;  // block 0's, in its cycles
    const bool per_block = k >= DeviceTickProfile::BlockLag && k <= DeviceTickProfile::BlockLists;  // summed over blocks
    const double ns = static_cast<double>(p.sum[k]) / (cycles ? r.tail_clock_ghz : 1.0);
    r.mean_us[k] = 1e-3 * ns / (steps * (per_block ? I.grid - 1 : 1));
  }
  return r;
}

void CudaHapticTicks::snapshot(std::vector<Vec3d>& q, std::vector<Vec3d>& x_visible) {
  Impl& I = *impl_;
  std::vector<Vec3f> qf(I.m), xf(I.n);
  if (I.m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(qf.data(), I.q[0].get(), I.m * sizeof(Vec3f), cudaMemcpyDeviceToHost, I.stream));
  const Vec3f* x_vis = I.x_vis.get();
  if (I.steps_mode == Impl::Steps::InLaunch && I.enqueued > 0) {  // the last enqueued tick's period's
    x_vis = I.dev.xring[ring_slot((I.enqueued - 1) / I.period - 1)];
  }
  if (I.n > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(xf.data(), x_vis, I.n * sizeof(Vec3f), cudaMemcpyDeviceToHost, I.stream));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));
  to_double(qf.data(), I.m, q);
  to_double(xf.data(), I.n, x_visible);
}

}  // namespace ebh
