// The physical-mesh step (Algorithm 1) on a CUDA device, float32 (physical_mesh_cuda.hpp).
//
// One kernel per local-global iteration, all captured once into a CUDA graph:
//   copy q in     the #m virtual positions E_svc holds fixed (pinned host -> device)
//   K times:
//     iteration   one block per patch of vertices (below):
//                   stage    the patch's vertices and their neighbours' x_k into shared memory
//                   local    per tet touching the patch: F, R = extract_rotation(F, R_last)
//                            (Mueller 2016, warm-started) and the four corner forces
//                            w_t (R - F) g_c into shared memory                    Alg. 1 l. 6-8
//                   global   per patch vertex (kLanes threads): r = m/h^2 (s - x) + its corner
//                            forces + the E_svc pulls of its coupled virtual vertices, then
//                            the Jacobi or Chebyshev update into x_{k+1}            Alg. 1 l. 9
//                 Iteration 0 also makes the prediction s = x + h v + h^2 g (l. 1) and the
//                 start x_0 = x + h v (docs/MODEL.md, "The iterations' start") on the fly; the
//                 last one also the velocities (l. 11) and, in the last block to finish, the
//                 residual sums (into host-mapped memory: no copy node).
//   copy x out    device -> pinned host
// With the stopping rule (PhysicalStepParams::adaptive, docs/MODEL.md) iterations 0 .. K-2 are as
// above but none writes the state; then a while node whose body is one loop_iteration_kernel
// (iteration k from a device counter; its last block sums the residual and decides with
// continue_iterating, setting the node's condition), then loop_finish_kernel moves the last
// iterate, its velocities and rotations into the state.
// The device-resident graph (launch_device_step: the replay's device haptic tick) is the same
// without the two copies: q and x stay in device memory.
// With the awake region (CudaPhysicalOptions::region, solver.physical_region) the iterations are
// framed by region_decide_kernel, which picks the patches that iterate (the CPU's rules at the
// grain of patches) and holds the others, and region_seen_kernel; a sleeping patch's block leaves
// each iteration at once. A region holding every patch gives the whole mesh's bits.
// Patches: the vertices in Morton order of their rest positions, cut into runs sized so that
// about two blocks per multiprocessor hold them all (at most 128 vertices, 64 beside the device
// tick: CudaPhysicalOptions; halved while a block's shared memory does not fit); a patch's tets
// are all tets with a corner in it. Each block first copies its patch's model data (tets, shape
// gradients, pairings) into shared memory, before waiting for the previous iteration. A tet on a
// patch border is computed by each patch it touches (about 2x the arithmetic of one thread per
// tet), which buys one kernel per iteration instead of two and keeps the corner forces in shared
// memory: the step is bound by kernel latency and memory traffic, not arithmetic (docs/CUDA.md).
// The patch owning a tet's corner 0 stores its rotation; every patch computes the same bits from
// the same inputs.
// Kernels are launched with programmatic dependent launch where the driver takes it in a graph
// (each waits for its predecessor with cudaGridDependencySynchronize before touching memory, so
// only the launch latency overlaps); otherwise, or with CudaPhysicalOptions::programmatic_launch
// off, as plain graph nodes.
//
// Iterates: the state x is read by iteration 0 and written by iteration K-1; iterations in between
// rotate over three scratch buffers (x_{k-1}, x_k, x_{k+1}), so no kernel reads what another block
// of it writes. Rotations are double-buffered: iteration k reads rot[k % 2], writes rot[(k+1) % 2].
// The per-element math is the CPU reference's: the same EBH_HD templates instantiated on float,
// and each vertex sums its terms in the CPU model's incidence order.
#include <cuda_runtime.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/error.hpp"
#include "energy/arap.hpp"
#include "energy/volume.hpp"
#include "energy/quadratic.hpp"
#include "energy/rotation.hpp"
#include "mesh/morton.hpp"
#include "solver/cuda_util.cuh"
#include "solver/physical_region.hpp"
#include "solver/physical_mesh_cuda.hpp"

// The stopping rule's while node needs conditional graph nodes with stream capture as CUDA 13
// declares them; older toolkits build the backend without it (CudaPhysicalSolver refuses the rule).
#if CUDART_VERSION >= 13000
#define EBH_GRAPH_LOOPS 1
#else
#define EBH_GRAPH_LOOPS 0
#endif

namespace ebh {
namespace {

#if EBH_GRAPH_LOOPS
using LoopHandle = cudaGraphConditionalHandle;
#else
using LoopHandle = unsigned long long;
#endif

constexpr int kBlock = 512;                    // threads per block (one patch)
// Threads per vertex in the global stage (the kernels' kLanes): kMaxLanes while a patch has at
// most kBlock / kMaxLanes vertices (every mesh up to ~17k vertices on an H100), kMinLanes for
// the larger patches of larger meshes: fewer tets on patch borders, computed twice (a 128-vertex
// patch's step took 0.85x the time of a 64-vertex one's at 352k and 1.08M tets, h100).
constexpr int kMaxLanes = 8, kMinLanes = 4;
constexpr int kMaxPatch = kBlock / kMinLanes;  // most vertices in a patch
constexpr int kPrefetchTets = 4;            // incidence entries per lane loaded before the barriers
constexpr int kPrefetchPulls = 2;           // coupling entries per lane loaded before the barriers

/// The device's view of the model and state: plain pointers, passed to every kernel by value.
struct PhysicalDevice {
  int n = 0, T = 0, m = 0;
  float h = 0, k_svc = 0, velocity_scale = 0;  // velocity_scale = (1 - damping) / h
  float det_ratio = 0;                  // kappa = k_det / k_vol: E_det's force too where > 0 (energy/volume.hpp)
  Vec3f gravity;
  // Patches (host-built, see build_patches): per patch p, its vertex slots
  // [slot_offsets[p], slot_offsets[p+1]) (its own vertices first, then neighbours) and its tets
  // [tet_offsets_p[p], tet_offsets_p[p+1]).
  const int* slot_offsets = nullptr;    // P+1
  const int* slot_vertex = nullptr;     // global vertex of each slot
  const int* own_count = nullptr;       // P  vertices the patch updates (its first slots)
  const int* ptet_offsets = nullptr;    // P+1
  const int* ptet = nullptr;            // tet index; bit 31 set when this patch stores its rotation
  const ushort4* ptet_corner = nullptr; // the tet's corners as slots of the patch
  const Vec3f* ptet_grad = nullptr;     // 4 per patch tet: g_c
  const float* ptet_weight = nullptr;   // w_t = 2 k_vol V_t
  const int* pcpl_offsets = nullptr;    // P+1 the patch's coupled virtual vertices
  const int2* pcpl = nullptr;           // (virtual vertex j, its pair count)
  const ushort4* pcpl_corner = nullptr; // j's paired physical vertices as slots of the patch
  int max_slots = 0, max_tets = 0, max_pulls = 0;  // shared memory sizing
  // Per vertex, in the CPU model's incidence order.
  const int* tet_offsets = nullptr;     // n+1 CSR vertex -> incident (tet, corner)
  const unsigned short* force_slot = nullptr;  // 4 e + c of each entry: e its patch tet
  const int* cpl_offsets = nullptr;     // n+1 CSR vertex -> coupled virtual vertices
  const unsigned short* pull_slot = nullptr;  // the patch item of each entry's virtual vertex
  const float* cpl_weight = nullptr;    // w_jk of this physical vertex in j's pairing
  const int* pair_vertex = nullptr;     // 4m
  const float* pair_weight = nullptr;   // 4m
  const int* pair_count = nullptr;      // m
  const float* mass_h2 = nullptr;       // n  m_a / h^2
  const float* step_scale = nullptr;    // n  gamma / A(a, a)
  const std::uint8_t* pinned = nullptr; // n
  const Vec3f* q = nullptr;             // m  virtual positions (input of the step)
  Vec3f* x = nullptr;                   // n  state: read by iteration 0, written by the last
  Vec3f* v = nullptr;                   // n
  Vec3f* s = nullptr;                   // n  prediction (= x_0)
  Vec3f* x_start = nullptr;             // n
  Quatf* rotation = nullptr;            // 2T warm starts: [0, T) the state, [T, 2T) scratch
  float* rsq_first = nullptr;           // n  |r_a|^2 at iteration 0
  float* rsq_last = nullptr;            // n  |r_a|^2 at iteration K-1
  double* residual_sq = nullptr;        // kReportValues (host-mapped: the host reads them after the step)
  unsigned int* blocks_done = nullptr;  // 1  the last-block counter
  // The stopping rule past K iterations (adaptive graphs only: PhysicalStepParams::adaptive).
  int* next_iteration = nullptr;        // 1  the loop's next iteration k; the loop's finish resets it
  StoppingState* stopping = nullptr;    // 1  the rule's best residual so far; the loop's finish resets it
  const float* omega = nullptr;         // max_iterations  the Chebyshev weights (iteration_weights)
  double weight_norm = 0;               // ||M g0||, the residual's scale
  double tolerance = 0;                 // the stopping rule's tolerance (mesh weights), 0: none
  int iterations = 0, max_iterations = 0;  // K and the cap
  // Sleeping (CudaPhysicalOptions::sleep; sleep_gate_kernel).
  float sleep_sq = 0;                   // the sleep length squared (m^2); 0: every step runs
  int* sleep_flags = nullptr;           // 2  [0] a vertex moved (this step's test), [1] a step has run
  Vec3f* ran_with = nullptr;            // m  the virtual positions the last step that ran took
  // The awake region (CudaPhysicalOptions::region; region_decide_kernel, region_seen_kernel).
  std::uint8_t* patch_awake = nullptr;  // P  this step's patches that iterate (null: the region is off)
  float region_sq = 0;                  // the tolerance squared (m^2)
  const int* halo_offsets = nullptr;    // P+1
  const int* halo = nullptr;            // per patch: its halo (PatchHalos, physical_region.hpp)
  const int* cpl_virtual = nullptr;     // per coupling entry (cpl_offsets): its virtual vertex j
  const int* patch_of = nullptr;        // n  the patch a vertex belongs to
  const int* patch_free = nullptr;      // P  its free vertices
  Vec3f* seen = nullptr;                // m  the virtual mesh as every vertex it pairs with last saw it
  int* region_flags = nullptr;          // 2  [0] the next step iterates every patch, [1] this step's awake free vertices
};

/// One iteration's buffers (the rotation described at the top of the file).
struct Sweep {
  const Vec3f* cur = nullptr;   // x_k (iterations k >= 1)
  const Vec3f* prev = nullptr;  // x_{k-1} (Chebyshev)
  Vec3f* next = nullptr;        // x_{k+1}
  const Quatf* rot_in = nullptr;
  Quatf* rot_out = nullptr;
  float omega = 1;              // Chebyshev weight of this iteration (Wang 2015), 1 for Jacobi
  float* rsq = nullptr;         // where |r_a|^2 goes, or null
};

/// Start of every kernel: wait until the preceding kernel's writes are visible (a no-op without
/// programmatic dependent launch), then let the next kernel's launch begin.
__device__ __forceinline__ void kernel_prologue() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  cudaGridDependencySynchronize();
  cudaTriggerProgrammaticLaunchCompletion();
#endif
}

/// Alg. 1 line 1: s = x + h v + h^2 g (pinned: s = x).
__device__ __forceinline__ Vec3f predicted(const PhysicalDevice& d, int b) {
  const Vec3f xb = d.x[b];
  return d.pinned[b] ? xb : predict_position(xb, d.v[b], d.gravity, d.h);
}

/// x_0 = x + h v (pinned: x), the iterations' start (docs/MODEL.md).
__device__ __forceinline__ Vec3f started(const PhysicalDevice& d, int b) {
  const Vec3f xb = d.x[b];
  return d.pinned[b] ? xb : iteration_start(xb, d.v[b], d.h);
}

/// x_k of vertex b: the start in iteration 0, the current iterate after it.
template <bool kFirst>
__device__ __forceinline__ Vec3f iterate(const PhysicalDevice& d, const Sweep& w, int b) {
  if constexpr (kFirst) return started(d, b);
  else return w.cur[b];
}

/// A patch tet's model data (loaded before the iteration's dependency wait: it never changes).
struct TetItem {
  int tagged;  // tet index, bit 31 set when this patch stores its rotation
  ushort4 corner;
  Vec3f g[4];
  float weight;
};

__device__ __forceinline__ TetItem load_tet(const PhysicalDevice& d, int e) {
  TetItem it;
  it.tagged = d.ptet[e];
  it.corner = d.ptet_corner[e];
  for (int i = 0; i < 4; ++i) it.g[i] = d.ptet_grad[4 * e + i];
  it.weight = d.ptet_weight[e];
  return it;
}

/// Alg. 1 lines 6-8 for one tet: F, R (warm-started from r_last) and the four corner forces
/// w_t (R - F) g_c = -dE_vol/dx_c [7], from the patch's staged positions; with det_ratio > 0 also
/// -dE_det/dx_c (elastic_force_matrix, energy/volume.hpp).
__device__ __forceinline__ Quatf tet_forces(const TetItem& it, Quatf r_last, const Sweep& w, const Vec3f* pos,
                                            Vec3f* force, int rotation_iterations, float det_ratio) {
  Vec3f x[4];
  x[0] = pos[it.corner.x];
  x[1] = pos[it.corner.y];
  x[2] = pos[it.corner.z];
  x[3] = pos[it.corner.w];
  // F = sum_c x_c g_c^T with positions taken relative to corner 0 (sum_c g_c = 0, so F is the
  // same; in float32 it avoids cancelling |x| |g| ~ scene size / edge length).
  const Vec3f x0 = x[0];
  for (int i = 0; i < 4; ++i) x[i] = x[i] - x0;
  const Mat3f F = deformation_gradient(x, it.g);
  const Quatf R = extract_rotation(F, r_last, rotation_iterations, 1e-9f);
  if (it.tagged < 0) w.rot_out[it.tagged & 0x7fffffff] = R;
  const Mat3f proj = elastic_force_matrix(F, to_matrix(R), it.weight, det_ratio);
  for (int i = 0; i < 4; ++i) force[i] = proj * it.g[i];
  return R;
}

/// A coupled virtual vertex j of the patch: k_svc (q_j - p_j), p_j = sum_i w_ji x_i [5].
struct PullItem {
  int count;
  ushort4 corner;
  float weight[4];
  Vec3f q;
};

__device__ __forceinline__ PullItem load_pull(const PhysicalDevice& d, int c) {
  PullItem it;
  const int2 jc = d.pcpl[c];
  it.count = jc.y;
  it.corner = d.pcpl_corner[c];
  for (int i = 0; i < 4; ++i) it.weight[i] = d.pair_weight[4 * jc.x + i];
  it.q = d.q[jc.x];  // written by the step's first copy, before any iteration kernel
  return it;
}

__device__ __forceinline__ Vec3f pull_force(const PullItem& it, const Vec3f* pos, float k_svc) {
  const unsigned short c[4] = {it.corner.x, it.corner.y, it.corner.z, it.corner.w};
  Vec3f p{};
  for (int i = 0; i < it.count; ++i) p += it.weight[i] * pos[c[i]];
  return coupling_gradient_virtual(p, it.q, k_svc);
}

/// Butterfly over the kLanes threads of one vertex: every lane ends with the same bits (float
/// addition is commutative), in an order fixed by the lane pattern alone.
template <int kLanes>
__device__ __forceinline__ float lane_sum(float v) {
  for (int off = kLanes / 2; off > 0; off /= 2) v += __shfl_xor_sync(0xffffffffu, v, off, kLanes);
  return v;
}

/// ||r_0||^2 and ||r_k||^2 (|r_a|^2 in `rsq_last`) in double by one block: each thread a fixed
/// strided slice, then a fixed tree (the same order whichever block runs it). Thread 0 stores them
/// and returns ||r_k||^2.
__device__ __forceinline__ double residual_block(const PhysicalDevice& d, const float* rsq_last) {
  __shared__ double sum[2][kBlock];
  const int t = threadIdx.x;
  double a = 0, b = 0;
  for (int i = t; i < d.n; i += kBlock) { a += __ldcg(d.rsq_first + i); b += __ldcg(rsq_last + i); }
  sum[0][t] = a;
  sum[1][t] = b;
  __syncthreads();
  for (int w = kBlock / 2; w > 0; w /= 2) {
    if (t < w) { sum[0][t] += sum[0][t + w]; sum[1][t] += sum[1][t + w]; }
    __syncthreads();
  }
  if (t == 0) { d.residual_sq[0] = sum[0][0]; d.residual_sq[1] = sum[1][0]; }
  return sum[1][0];
}

/// Blocks count themselves out; true in the last one to finish (an integer atomic only picks
/// which block it is), which then resets the counter. Every thread fences its own writes first.
__device__ __forceinline__ bool last_block(const PhysicalDevice& d) {
  __shared__ bool last;
  __threadfence();
  __syncthreads();
  if (threadIdx.x == 0) last = atomicAdd(d.blocks_done, 1u) == gridDim.x - 1;
  __syncthreads();
  if (!last) return false;
  __threadfence();
  if (threadIdx.x == 0) *d.blocks_done = 0;
  return true;
}

/// The last block sums the residuals (the sums' order is fixed).
__device__ __forceinline__ void last_block_reduces(const PhysicalDevice& d) {
  if (last_block(d)) residual_block(d, d.rsq_last);
}

/// What a thread of a patch's block needs that never changes: loaded once per kernel, before
/// the wait for the previous iteration (the model is constant; q is copied before any iteration).
struct PatchThread {
  int s0 = 0, slots = 0, e0 = 0, tets = 0, c0 = 0, pulls = 0;
  int my_slot = -1;             // vertex staged by this thread (slot tid), or -1
  // Global stage: vertex i = tid / kLanes of the patch, lane = tid % kLanes.
  int i = 0, lane = 0, a = 0;
  bool valid = false, pinned = false;
  float mass_h2 = 0, step_scale = 0;
  int t_begin = 0, t_end = 0, c_begin = 0, c_end = 0;
  unsigned short fs[kPrefetchTets] = {}, ps[kPrefetchPulls] = {};
  float pw[kPrefetchPulls] = {};
};

template <int kLanes>
__device__ __forceinline__ void load_patch_thread(const PhysicalDevice& d, int patch, int tid, PatchThread& P) {
  P.s0 = d.slot_offsets[patch];
  P.slots = d.slot_offsets[patch + 1] - P.s0;
  P.e0 = d.ptet_offsets[patch];
  P.tets = d.ptet_offsets[patch + 1] - P.e0;
  P.c0 = d.pcpl_offsets[patch];
  P.pulls = d.pcpl_offsets[patch + 1] - P.c0;
  P.my_slot = tid < P.slots ? d.slot_vertex[P.s0 + tid] : -1;
  P.i = tid / kLanes;
  P.lane = tid % kLanes;
  P.valid = P.i < d.own_count[patch];
  if (!P.valid) return;
  const int a = P.a = d.slot_vertex[P.s0 + P.i];
  P.pinned = d.pinned[a];
  P.mass_h2 = d.mass_h2[a];
  P.step_scale = d.step_scale[a];
  P.t_begin = d.tet_offsets[a] + P.lane;
  P.t_end = d.tet_offsets[a + 1];
  P.c_begin = d.cpl_offsets[a] + P.lane;
  P.c_end = d.cpl_offsets[a + 1];
  for (int j = 0; j < kPrefetchTets; ++j) {
    const int k = P.t_begin + j * kLanes;
    P.fs[j] = k < P.t_end ? d.force_slot[k] : 0;
  }
  for (int j = 0; j < kPrefetchPulls; ++j) {
    const int k = P.c_begin + j * kLanes;
    P.ps[j] = k < P.c_end ? d.pull_slot[k] : 0;
    P.pw[j] = k < P.c_end ? d.cpl_weight[k] : 0.f;
  }
}

/// The dynamic shared memory of a patch's block: its tet and pull items (model data, copied in
/// once per kernel), then x_k of its slots, the corner forces and the coupling pulls.
struct PatchShared {
  TetItem* tet;
  PullItem* pl;
  Vec3f* pos;
  Vec3f* force;
  Vec3f* pull;
};

__device__ __forceinline__ PatchShared patch_shared(const PhysicalDevice& d) {
  extern __shared__ float4 shared[];
  PatchShared S;
  S.tet = reinterpret_cast<TetItem*>(shared);
  S.pl = reinterpret_cast<PullItem*>(S.tet + d.max_tets);
  S.pos = reinterpret_cast<Vec3f*>(S.pl + d.max_pulls);
  S.force = S.pos + d.max_slots;
  S.pull = S.force + 4 * d.max_tets;
  return S;
}

/// Copies the patch's tet and pull items into shared memory (read after the next barrier).
__device__ __forceinline__ void cache_patch_items(const PhysicalDevice& d, const PatchThread& P, const PatchShared& S,
                                                  int tid) {
  for (int k = tid; k < P.tets; k += kBlock) S.tet[k] = load_tet(d, P.e0 + k);
  for (int k = tid; k < P.pulls; k += kBlock) S.pl[k] = load_pull(d, P.c0 + k);
}

/// One local-global iteration of one patch (Alg. 1 lines 6-9):
///   r = m/h^2 (s - x) + sum of the corner forces [7] + sum of the coupling pulls [5]
///   jacobi     x <- x + gamma D^-1 r
///   chebyshev  x_{k+1} = omega (gamma D^-1 r + x_k - x_{k-1}) + x_{k-1}   (Wang 2015, eq. 12)
/// kFirst: x_0 = x_{-1} = x + h v and s = x + h v + h^2 g, computed here; s and x_start are
/// stored for later iterations.
/// kLast: x_K goes to the state x, with v = (1 - damping)(x_K - x_start) / h (Alg. 1 line 11).
/// r_last: the warm start of the thread's own tet (item tid), replaced by its new rotation; every
/// other read of the last rotations goes to w.rot_in. Only shared memory is read between the
/// two barriers.
template <int kLanes, bool kChebyshev, bool kFirst, bool kLast>
__device__ __forceinline__ void patch_iteration(const PhysicalDevice& d, const Sweep& w, const PatchThread& P,
                                                Quatf& r_last, int tid, int rotation_iterations) {
  const PatchShared S = patch_shared(d);
  Vec3f* pos = S.pos;
  Vec3f* force = S.force;
  Vec3f* pull = S.pull;
  const int a = P.a;
  Vec3f sa{}, xp{}, x_before{};
  if (P.valid && P.lane == 0) {
    if constexpr (kFirst) x_before = d.x[a];
    else {
      sa = d.s[a];
      if constexpr (kChebyshev) xp = w.prev[a];
      if constexpr (kLast) x_before = d.x_start[a];
    }
  }
  // Stage.
  if (P.my_slot >= 0) pos[tid] = iterate<kFirst>(d, w, P.my_slot);
  for (int k = tid + kBlock; k < P.slots; k += kBlock) pos[k] = iterate<kFirst>(d, w, d.slot_vertex[P.s0 + k]);
  __syncthreads();
  // Local: the patch's tets and coupled virtual vertices, one item a thread.
  for (int k = tid; k < P.tets + P.pulls; k += kBlock) {
    if (k < P.tets) {
      const TetItem& it = S.tet[k];
      const Quatf R = tet_forces(it, k == tid ? r_last : w.rot_in[it.tagged & 0x7fffffff], w, pos, force + 4 * k,
                                 rotation_iterations, d.det_ratio);
      if (k == tid) r_last = R;
    } else {
      pull[k - P.tets] = pull_force(S.pl[k - P.tets], pos, d.k_svc);
    }
  }
  __syncthreads();
  // Global: kLanes threads per patch vertex sum its entries in the CPU model's order.
  Vec3f r{};
  if (P.valid) {
    for (int j = 0; j < kPrefetchTets; ++j)
      if (P.t_begin + j * kLanes < P.t_end) r += force[P.fs[j]];                              // [7]
    for (int k = P.t_begin + kPrefetchTets * kLanes; k < P.t_end; k += kLanes) r += force[d.force_slot[k]];
    for (int j = 0; j < kPrefetchPulls; ++j)
      if (P.c_begin + j * kLanes < P.c_end) r += P.pw[j] * pull[P.ps[j]];                    // [5]
    for (int k = P.c_begin + kPrefetchPulls * kLanes; k < P.c_end; k += kLanes) r += d.cpl_weight[k] * pull[d.pull_slot[k]];
  }
  r = Vec3f{lane_sum<kLanes>(r.x), lane_sum<kLanes>(r.y), lane_sum<kLanes>(r.z)};
  if (P.valid && P.lane == 0) {
    const Vec3f xk = pos[P.i];
    if constexpr (kFirst) {
      sa = predicted(d, a);
      xp = xk;
      d.s[a] = sa;
      d.x_start[a] = x_before;
    }
    if (P.pinned) r = Vec3f{};
    else r += P.mass_h2 * (sa - xk);  // -dE_k/dx [6]
    if (w.rsq) w.rsq[a] = squared_norm(r);
    Vec3f xn;
    if constexpr (kChebyshev) xn = w.omega * (P.step_scale * r + xk - xp) + xp;
    else xn = xk + P.step_scale * r;
    w.next[a] = xn;
    if constexpr (kLast) d.v[a] = d.velocity_scale * (xn - x_before);
  }
}

/// Whether this block's patch sleeps in this step (the awake region: region_decide_kernel). Read
/// before the dependency wait: the decision's kernel completes before the step's first iteration
/// starts (a plain graph edge), and every later iteration starts after that one.
__device__ __forceinline__ bool patch_asleep(const PhysicalDevice& d) { return d.patch_awake && !d.patch_awake[blockIdx.x]; }

/// A sleeping patch's share of an iteration, after the dependency wait (region_decide_kernel has
/// written its v = 0, its x into the iterate buffers and its zero residuals): in the first, its
/// x_start = x, where the next decision measures its motion from (the decision cannot write it:
/// other blocks read x_start there).
__device__ __forceinline__ void sleeping_patch(const PhysicalDevice& d, bool first) {
  if (!first) return;
  const int s0 = d.slot_offsets[blockIdx.x], own = d.own_count[blockIdx.x];
  for (int i = threadIdx.x; i < own; i += blockDim.x) {
    const int a = d.slot_vertex[s0 + i];
    d.x_start[a] = d.x[a];
  }
}

/// One iteration as one kernel of the graph.
template <int kLanes, bool kChebyshev, bool kFirst, bool kLast>
__global__ void __launch_bounds__(kBlock, 2) iteration_kernel(PhysicalDevice d, Sweep w, int rotation_iterations) {
  if (patch_asleep(d)) {
    kernel_prologue();
    sleeping_patch(d, kFirst);
    if constexpr (kLast) last_block_reduces(d);
    return;
  }
  PatchThread P;
  load_patch_thread<kLanes>(d, blockIdx.x, threadIdx.x, P);
  cache_patch_items(d, P, patch_shared(d), threadIdx.x);
  kernel_prologue();  // the previous iteration's x_k and rotations are visible from here on
  Quatf r_last{};
  if (threadIdx.x < P.tets) r_last = w.rot_in[d.ptet[P.e0 + threadIdx.x] & 0x7fffffff];
  patch_iteration<kLanes, kChebyshev, kFirst, kLast>(d, w, P, r_last, threadIdx.x, rotation_iterations);
  if constexpr (kLast) last_block_reduces(d);
}

/// A method's iteration kernels for `lanes` threads per patch vertex: the first, the middle and the
/// last iteration's.
using IterationKernel = void (*)(PhysicalDevice, Sweep, int);
template <bool kChebyshev, int kLanes>
std::array<IterationKernel, 3> iteration_kernels_of() {
  return {iteration_kernel<kLanes, kChebyshev, true, false>, iteration_kernel<kLanes, kChebyshev, false, false>,
          iteration_kernel<kLanes, kChebyshev, false, true>};
}
template <bool kChebyshev>
std::array<IterationKernel, 3> iteration_kernels(int lanes) {
  return lanes == kMinLanes ? iteration_kernels_of<kChebyshev, kMinLanes>() : iteration_kernels_of<kChebyshev, kMaxLanes>();
}

/// K = 0: the step is the iterations' start alone (as on the CPU).
__global__ void predict_only_kernel(PhysicalDevice d) {
  kernel_prologue();
  const int a = blockIdx.x * blockDim.x + threadIdx.x;
  if (a >= d.n) return;
  const Vec3f xa = d.x[a];
  const Vec3f sa = started(d, a);
  d.x[a] = sa;
  d.v[a] = d.velocity_scale * (sa - xa);
}

/// K = 1: x_1 (in `from`) becomes the state of vertex a, with its velocity (Alg. 1 line 11).
__device__ __forceinline__ void finish_vertex(const PhysicalDevice& d, const Vec3f* from, int a) {
  const Vec3f xa = from[a];
  d.v[a] = d.velocity_scale * (xa - d.x_start[a]);
  d.x[a] = xa;
}

/// K = 1 in the graph: finish_vertex for every vertex; the last block sums the residual.
__global__ void __launch_bounds__(kBlock) finish_kernel(PhysicalDevice d, const Vec3f* from) {
  kernel_prologue();
  const int a = blockIdx.x * blockDim.x + threadIdx.x;
  if (a < d.n) finish_vertex(d, from, a);
  last_block_reduces(d);
}

/// Whether the step sleeps (docs/MODEL.md, "Sleeping"; the CPU's rule, run_physical_step): a step
/// ran before and met the stopping rule's tolerance (when there is one), it moved no vertex by more
/// than the sleep length (|v| h), and no virtual vertex has moved by more than it since. Every
/// thread tests a physical and a virtual vertex and the blocks or their findings into an integer
/// (the same in any order); the last block decides, sets the step's conditional node (0: the
/// iterations are skipped, the state held) and then, asleep, zeroes the velocities and reports 0
/// iterations (r_0 = r_K: a reduction of 1), awake, keeps q for the next test.
__global__ void __launch_bounds__(kBlock) sleep_gate_kernel(PhysicalDevice d, LoopHandle awake) {
  kernel_prologue();
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const float h2 = d.h * d.h;
  bool moved = false;
  if (i < d.n) moved = squared_norm(d.v[i]) * h2 > d.sleep_sq;
  if (i < d.m) moved = moved || squared_norm(d.q[i] - d.ran_with[i]) > d.sleep_sq;
  if (__syncthreads_or(moved) && threadIdx.x == 0) atomicOr(d.sleep_flags, 1);
  if (!last_block(d)) return;
  __shared__ bool asleep;
  if (threadIdx.x == 0) {
    const double scale = d.weight_norm > 0 ? d.weight_norm : 1.0;
    asleep = d.sleep_flags[1] != 0 && d.sleep_flags[0] == 0 &&
             (d.tolerance <= 0 || sqrt(d.residual_sq[1]) / scale <= d.tolerance);
    d.sleep_flags[0] = 0;
    d.sleep_flags[1] = 1;
    if (asleep) {
      d.residual_sq[0] = d.residual_sq[1];
      d.residual_sq[2] = 0;
    } else {
      d.residual_sq[2] = d.iterations;  // the stopping rule's loop writes its own count
    }
#if EBH_GRAPH_LOOPS
    cudaGraphSetConditional(awake, asleep ? 0u : 1u);
#else
    (void)awake;
#endif
  }
  __syncthreads();
  if (asleep) {
    for (int a = threadIdx.x; a < d.n; a += blockDim.x) d.v[a] = Vec3f{};
  } else {
    for (int j = threadIdx.x; j < d.m; j += blockDim.x) d.ran_with[j] = d.q[j];
  }
}

/// The K sweeps' buffers: iteration 0 reads the state x (and v) to predict, iteration K-1 >= 1
/// writes x and v, and the iterates in between rotate over scratch[0..2] (x_{-1} = x_0 = s).
/// With K = 1 the one iteration writes scratch[0] and finish_kernel moves it to the state.
struct SweepPlan {
  Vec3f* scratch[3] = {nullptr, nullptr, nullptr};
  const Vec3f* s = nullptr;
  Vec3f* x = nullptr;
  Quatf* rot = nullptr;  // 2T
  int T = 0, K = 0;
  __host__ __device__ Vec3f* written(int k) const { return (k == K - 1 && K >= 2) ? x : scratch[k % 3]; }
  __host__ __device__ const Vec3f* read(int k) const { return k < 0 ? s : written(k); }
  __host__ __device__ Sweep sweep(int k, float omega, float* rsq) const {
    Sweep w;
    w.cur = k >= 1 ? read(k - 1) : nullptr;
    w.prev = k >= 1 ? read(k - 2) : nullptr;
    w.next = written(k);
    w.rot_in = rot + (k % 2) * static_cast<long long>(T);
    w.rot_out = rot + ((k + 1) % 2) * static_cast<long long>(T);
    w.omega = omega;
    w.rsq = rsq;
    return w;
  }
};

/// The awake region's decision before a step (CudaPhysicalOptions::region): the CPU's rules
/// (choose_awake, physical_region.hpp) at the grain of patches (patch_halos). Patch p iterates when
/// a vertex of its halo moved by more than the tolerance in the step before (|x - x_start|, hot) or
/// pairs with a virtual vertex that moved by more than it since every vertex that one pairs with
/// last saw it (seeded), or when the step iterates every patch (the first after upload_state). A
/// sleeping patch is held: its vertices' v = 0 (so the iterations' start x + h v is x, for its
/// awake neighbours too), their x in every iterate buffer the others read, 0 in the residual sums.
/// Each block decides for its own patch from the step before's state and writes its own vertices
/// only; x_start, which all read here, is written by the first iteration (sleeping_patch).
__global__ void __launch_bounds__(kBlock) region_decide_kernel(PhysicalDevice d, SweepPlan plan) {
  kernel_prologue();
  const int p = blockIdx.x;
  bool moved = d.region_flags[0] != 0;
  for (int k = d.halo_offsets[p] + threadIdx.x; k < d.halo_offsets[p + 1] && !moved; k += blockDim.x) {
    const int a = d.halo[k];
    moved = squared_norm(d.x[a] - d.x_start[a]) > d.region_sq;  // hot
    for (int c = d.cpl_offsets[a]; c < d.cpl_offsets[a + 1] && !moved; ++c) {
      const int j = d.cpl_virtual[c];
      moved = squared_norm(d.q[j] - d.seen[j]) > d.region_sq;  // seeded
    }
  }
  const bool awake = __syncthreads_or(moved);
  if (threadIdx.x == 0) {
    d.patch_awake[p] = awake ? 1 : 0;
    if (awake) atomicAdd(d.region_flags + 1, d.patch_free[p]);  // an integer sum: the same in any order
  }
  if (awake) return;
  const int s0 = d.slot_offsets[p], own = d.own_count[p];
  for (int i = threadIdx.x; i < own; i += blockDim.x) {
    const int a = d.slot_vertex[s0 + i];
    const Vec3f xa = d.x[a];
    d.v[a] = Vec3f{};
    for (Vec3f* buffer : plan.scratch) buffer[a] = xa;
    d.rsq_first[a] = 0;
    d.rsq_last[a] = 0;
  }
}

/// After a step with the awake region (saw_virtual_mesh's rule): the virtual vertices every vertex
/// of which iterated (pinned ones count) have now been seen where they are. The last block reports
/// the awake free vertices and ends a whole step.
__global__ void __launch_bounds__(kBlock) region_seen_kernel(PhysicalDevice d) {
  kernel_prologue();
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j < d.m) {
    bool every = true;
    if (d.region_flags[0] == 0)
      for (int c = 0; c < d.pair_count[j]; ++c) {
        const int a = d.pair_vertex[4 * j + c];
        every = every && (d.pinned[a] || d.patch_awake[d.patch_of[a]]);
      }
    if (every) d.seen[j] = d.q[j];
  }
  if (last_block(d) && threadIdx.x == 0) {
    d.residual_sq[3] = d.region_flags[1];
    d.region_flags[0] = 0;
    d.region_flags[1] = 0;
  }
}

/// The loop's decision after iteration k (the last block): the residual sums, the iterations run,
/// and whether the loop runs iteration k + 1 (continue_iterating, as the CPU step decides).
__device__ __forceinline__ void last_block_decides(const PhysicalDevice& d, int k, const float* rsq,
                                                   LoopHandle loop) {
  if (!last_block(d)) return;
  const double rk2 = residual_block(d, rsq);
  if (threadIdx.x != 0) return;
  const double scale = d.weight_norm > 0 ? d.weight_norm : 1.0;
  const bool more = continue_iterating(k, sqrt(rk2) / scale, d.iterations, d.tolerance, d.max_iterations, *d.stopping);
  d.residual_sq[2] = k + 1;
  *d.next_iteration = k + 1;
#if EBH_GRAPH_LOOPS
  cudaGraphSetConditional(loop, more ? 1u : 0u);
#else
  (void)loop;
  (void)more;
#endif
}

/// The iterations from K - 1 on, as the body of the graph's while loop (PhysicalStepParams::
/// adaptive): iteration k = *next_iteration, buffers from `plan` (no iteration writes the state:
/// loop_finish_kernel does), its weight from d.omega; the last block decides whether k + 1 runs.
template <int kLanes, bool kChebyshev>
__global__ void __launch_bounds__(kBlock, 2)
    loop_iteration_kernel(PhysicalDevice d, SweepPlan plan, int rotation_iterations, LoopHandle loop) {
  if (patch_asleep(d)) {
    kernel_prologue();
    const int k = *d.next_iteration;
    sleeping_patch(d, k == 0);
    last_block_decides(d, k, k == 0 ? d.rsq_first : d.rsq_last, loop);
    return;
  }
  PatchThread P;
  load_patch_thread<kLanes>(d, blockIdx.x, threadIdx.x, P);
  cache_patch_items(d, P, patch_shared(d), threadIdx.x);
  kernel_prologue();
  const int k = *d.next_iteration;  // written by the previous kernel's last block
  float* rsq = k == 0 ? d.rsq_first : d.rsq_last;
  const Sweep w = plan.sweep(k, d.omega[k], rsq);
  Quatf r_last{};
  if (threadIdx.x < P.tets) r_last = w.rot_in[d.ptet[P.e0 + threadIdx.x] & 0x7fffffff];
  if (k == 0) patch_iteration<kLanes, kChebyshev, true, false>(d, w, P, r_last, threadIdx.x, rotation_iterations);
  else patch_iteration<kLanes, kChebyshev, false, false>(d, w, P, r_last, threadIdx.x, rotation_iterations);
  last_block_decides(d, k, rsq, loop);
}

/// After the loop: the last iterate x_count becomes the state with its velocities (Alg. 1 line
/// 11), the last rotations move into the state half when count is odd, and the last block resets
/// the loop's counter for the next step (every block has read it by then).
__global__ void __launch_bounds__(kBlock) loop_finish_kernel(PhysicalDevice d, SweepPlan plan) {
  kernel_prologue();
  const int count = *d.next_iteration;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < d.n) finish_vertex(d, plan.read(count - 1), i);
  if (count % 2 == 1 && i < d.T) d.rotation[i] = d.rotation[d.T + i];
  if (last_block(d) && threadIdx.x == 0) {
    *d.next_iteration = d.iterations - 1;
    *d.stopping = StoppingState{};
  }
}

/// The patches of the iteration kernel, host side.
struct Patches {
  std::vector<int> slot_offsets{0}, slot_vertex, own_count, ptet_offsets{0}, ptet, pcpl_offsets{0};
  std::vector<ushort4> ptet_corner, pcpl_corner;
  std::vector<int2> pcpl;
  std::vector<Vec3f> ptet_grad;
  std::vector<float> ptet_weight;
  std::vector<unsigned short> force_slot, pull_slot;  // per CPU incidence / coupling entry
  int max_slots = 0, max_tets = 0, max_pulls = 0;
  int too_many = 0;  // the tets of a patch past the 16-bit slots (0: none): the patches must be smaller
};

/// Cuts the vertices, in Morton order of their rest positions, into runs of `size` (<= kMaxPatch).
Patches build_patches(const PhysicalModel& M, int size) {
  const int n = M.num_vertices;
  Patches P;
  if (n == 0) return P;
  const std::vector<int> order = morton_order(M.rest, morton_box(M.rest));
  std::vector<int> patch_of(n);
  for (int i = 0; i < n; ++i) patch_of[order[i]] = i / size;
  P.force_slot.assign(M.tet_entries.size(), 0);
  P.pull_slot.assign(M.cpl_virtual.size(), 0);
  const int patches = (n + size - 1) / size;
  std::unordered_map<int, int> slot_of, tet_item, pull_item;
  auto u16 = [](int v) { return static_cast<unsigned short>(v); };
  for (int p = 0; p < patches; ++p) {
    slot_of.clear();
    tet_item.clear();
    pull_item.clear();
    const int begin = p * size, end = std::min(n, begin + size);
    auto slot = [&](int a) {
      auto [it, inserted] = slot_of.try_emplace(a, static_cast<int>(slot_of.size()));
      if (inserted) P.slot_vertex.push_back(a);
      return it->second;
    };
    for (int i = begin; i < end; ++i) slot(order[i]);
    P.own_count.push_back(end - begin);
    // The patch's tets and coupled virtual vertices, each in ascending order.
    std::vector<int> tets, pulls;
    for (int i = begin; i < end; ++i) {
      const int a = order[i];
      for (int k = M.tet_offsets[a]; k < M.tet_offsets[a + 1]; ++k) tets.push_back(M.tet_entries[k] >> 2);
      for (int k = M.cpl_offsets[a]; k < M.cpl_offsets[a + 1]; ++k) pulls.push_back(M.cpl_virtual[k]);
    }
    for (auto* list : {&tets, &pulls}) {
      std::sort(list->begin(), list->end());
      list->erase(std::unique(list->begin(), list->end()), list->end());
    }
    for (const int t : tets) {
      tet_item[t] = static_cast<int>(tet_item.size());
      const auto& c = M.tets[t];
      const bool owner = patch_of[c[0]] == p;
      P.ptet.push_back(owner ? static_cast<int>(static_cast<unsigned>(t) | 0x80000000u) : t);
      P.ptet_corner.push_back(ushort4{u16(slot(c[0])), u16(slot(c[1])), u16(slot(c[2])), u16(slot(c[3]))});
      for (int i = 0; i < 4; ++i) P.ptet_grad.push_back(static_cast<Vec3f>(M.shape_grad[4 * t + i]));
      P.ptet_weight.push_back(float(M.tet_weight[t]));
    }
    for (const int j : pulls) {
      pull_item[j] = static_cast<int>(pull_item.size());
      const int count = M.pair_count[j];
      int c[4] = {0, 0, 0, 0};
      for (int i = 0; i < count; ++i) c[i] = slot(M.pair_vertex[j][i]);
      P.pcpl.push_back(int2{j, count});
      P.pcpl_corner.push_back(ushort4{u16(c[0]), u16(c[1]), u16(c[2]), u16(c[3])});
    }
    for (int i = begin; i < end; ++i) {
      const int a = order[i];
      for (int k = M.tet_offsets[a]; k < M.tet_offsets[a + 1]; ++k)
        P.force_slot[k] = u16(4 * tet_item.at(M.tet_entries[k] >> 2) + (M.tet_entries[k] & 3));
      for (int k = M.cpl_offsets[a]; k < M.cpl_offsets[a + 1]; ++k) P.pull_slot[k] = u16(pull_item.at(M.cpl_virtual[k]));
    }
    const int slots = static_cast<int>(slot_of.size()), count = static_cast<int>(tets.size());
    if (slots > 65535 || 4 * count > 65535 || pulls.size() > 65535) P.too_many = std::max(P.too_many, count);
    P.slot_offsets.push_back(static_cast<int>(P.slot_vertex.size()));
    P.ptet_offsets.push_back(static_cast<int>(P.ptet.size()));
    P.pcpl_offsets.push_back(static_cast<int>(P.pcpl.size()));
    P.max_slots = std::max(P.max_slots, slots);
    P.max_tets = std::max(P.max_tets, count);
    P.max_pulls = std::max(P.max_pulls, static_cast<int>(pulls.size()));
  }
  return P;
}

Vec3f to_float(const Vec3d& v) { return static_cast<Vec3f>(v); }
Quatf to_float(const Quatd& q) { return {float(q.w), float(q.x), float(q.y), float(q.z)}; }

/// The doubles a step reports through mapped host memory: ||r_0||^2, ||r_K||^2, iterations run,
/// and the free vertices the awake region iterated (CudaPhysicalOptions::region).
constexpr int kReportValues = 4;

/// A step's report values (mapped host memory) into its slot (launch_device_step(slot)).
__global__ void copy_residual_kernel(const double* from, double* to) {
  if (threadIdx.x < kReportValues) to[threadIdx.x] = from[threadIdx.x];
}

}  // namespace

struct CudaPhysicalSolver::Impl {
  PhysicalStepParams params;
  int n = 0, T = 0, m = 0, patches = 0;
  int patch_vertices = 0;  // vertices per patch (the last patch may have fewer)
  int lanes = kMaxLanes;   // threads per patch vertex in the global stage (the kernels' kLanes)
  double weight_norm = 0;  // PhysicalModel::weight_norm: the residual's scale
  std::vector<int> tet_slot;  // PhysicalModel::tet_slot: PhysicalState::rotation's order on the host
  std::size_t shared_bytes = 0;
  cuda::Stream stream;
  // Model.
  cuda::DeviceArray<int> slot_offsets, slot_vertex, own_count, ptet_offsets, ptet, pcpl_offsets;
  cuda::DeviceArray<ushort4> ptet_corner, pcpl_corner;
  cuda::DeviceArray<int2> pcpl;
  cuda::DeviceArray<Vec3f> ptet_grad;
  cuda::DeviceArray<float> ptet_weight;
  cuda::DeviceArray<unsigned short> force_slot, pull_slot;
  cuda::DeviceArray<int> pair_vertex, pair_count, tet_offsets, cpl_offsets;
  cuda::DeviceArray<float> pair_weight, cpl_weight, mass_h2, step_scale;
  cuda::DeviceArray<std::uint8_t> pinned;
  // State and scratch.
  cuda::DeviceArray<Vec3f> q, x, v, s, x_start, scratch0, scratch1, scratch2;
  cuda::DeviceArray<Quatf> rotation;  // 2T
  cuda::DeviceArray<float> rsq_first, rsq_last;
  cuda::DeviceArray<unsigned int> blocks_done;
  // The stopping rule's loop (params.adaptive()): its counter, the weights of every iteration it
  // may run, and the stream its body is captured on.
  cuda::DeviceArray<int> next_iteration;
  cuda::DeviceArray<StoppingState> stopping;
  cuda::DeviceArray<float> omega;
  cuda::Stream body_stream;
  // Sleeping (sleep > 0): the gate's flags, the q of the last step that ran, and the stream the
  // conditional node's body (the step's iterations) is captured on.
  double sleep = 0;
  cuda::DeviceArray<int> sleep_flags;
  cuda::DeviceArray<Vec3f> ran_with;
  cuda::Stream awake_stream;
  // The awake region (region > 0: CudaPhysicalOptions::region): the patches' halos, the decision,
  // what the virtual mesh was last seen as, and its flags (region_decide_kernel).
  double region = 0;
  cuda::DeviceArray<int> halo_offsets, halo, cpl_virtual, patch_of, patch_free, region_flags;
  cuda::DeviceArray<std::uint8_t> patch_awake;
  cuda::DeviceArray<Vec3f> seen;
  // Host side of the per-step copies.
  cuda::PinnedArray<Vec3f> q_host, x_host;
  // The residual sums, written by the kernels straight into mapped host memory (no copy node).
  double* residual_host = nullptr;
  PhysicalDevice dev;
  SweepPlan plan;
  std::vector<float> omega_host;  // the K Chebyshev weights (1 for Jacobi)
  cudaGraph_t graph = nullptr;
  cudaGraphExec_t exec = nullptr;
  // The device-resident step (no copies of q and x; made on first use by launch_device_step).
  cudaGraph_t graph_device = nullptr;
  cudaGraphExec_t exec_device = nullptr;
  cudaEvent_t start = nullptr, stop = nullptr;  // around the graph launch
  // Per slot (set_device_step_slots): the events around its step and its residual sums (mapped).
  std::vector<cudaEvent_t> slot_start, slot_stop, slot_done;  // slot_done: after the residual copy
  double* slot_residual = nullptr;
  double* slot_residual_dev = nullptr;
  double device_s = 0;
  bool programmatic = false;  // the graph uses programmatic dependent launch
  void copy_q_in(cudaStream_t st);
  void copy_results_out(cudaStream_t st);

  Impl() {
    EBH_CUDA_CHECK(cudaEventCreate(&start));
    EBH_CUDA_CHECK(cudaEventCreate(&stop));
  }
  ~Impl() {
    if (exec) cudaGraphExecDestroy(exec);
    if (graph) cudaGraphDestroy(graph);
    if (exec_device) cudaGraphExecDestroy(exec_device);
    if (residual_host) cudaFreeHost(residual_host);
    free_slots();
    if (graph_device) cudaGraphDestroy(graph_device);
    if (start) cudaEventDestroy(start);
    if (stop) cudaEventDestroy(stop);
  }

  void free_slots() {
    for (cudaEvent_t e : slot_start) cudaEventDestroy(e);
    for (cudaEvent_t e : slot_stop) cudaEventDestroy(e);
    for (cudaEvent_t e : slot_done) cudaEventDestroy(e);
    slot_start.clear();
    slot_stop.clear();
    slot_done.clear();
    if (slot_residual) cudaFreeHost(slot_residual);
    slot_residual = slot_residual_dev = nullptr;
  }
  void upload_model(const PhysicalModel& M, int asked_patch, bool beside_ticks);
  /// Captures the step graph: with the copies of q in and x out (copies = true: exec), or reading q
  /// from and leaving x in device memory (exec_device).
  void capture(bool with_programmatic_launch, bool copies);
  template <bool kChebyshev>
  void capture_iterations(bool pdl, cudaStream_t st);
  void capture_step(bool pdl, cudaStream_t st);
  void capture_sleeping_step(bool pdl, cudaStream_t st);
  template <bool kChebyshev>
  void capture_loop(cudaStream_t st);
  PhysicalStepReport report() const { return report(residual_host); }  ///< the last step's (host copy)
  /// Iterations and the residual ratio from a step's report values (kReportValues).
  PhysicalStepReport report(const double* sums) const;
};

/// The weights of the CPU reference (chebyshev_weight, in double), rounded once: K of them, or
/// max_iterations when the step may run past K.
std::vector<float> iteration_weights(const PhysicalStepParams& params) {
  const int count = params.adaptive() ? params.max_iterations : params.iterations;
  std::vector<float> w(std::max(count, 1), 1.0f);
  double omega = 1;
  for (int k = 0; k < count; ++k) w[k] = float(omega = chebyshev_weight(params, k, omega));
  return w;
}

namespace {
/// Raises `kernel`'s limit of dynamic shared memory to at least `bytes`. The limit is the
/// kernel's, process-wide, and solvers of other meshes (replay_batch makes them on several
/// threads) may need more: it only grows, under a lock, so that no solver lowers it below
/// what another's captured launches use.
void allow_dynamic_shared(const void* kernel, std::size_t bytes) {
  static std::mutex lock;
  static std::unordered_map<const void*, std::size_t> most;
  const std::lock_guard<std::mutex> guard(lock);
  std::size_t& m = most[kernel];
  if (bytes <= m) return;
  EBH_CUDA_CHECK(cudaFuncSetAttribute(kernel, cudaFuncAttributeMaxDynamicSharedMemorySize, static_cast<int>(bytes)));
  m = bytes;
}

/// The most static shared memory of `kernels`.
std::size_t static_shared_of(std::span<const void* const> kernels) {
  std::size_t bytes = 0;
  for (const void* k : kernels) {
    cudaFuncAttributes a{};
    EBH_CUDA_CHECK(cudaFuncGetAttributes(&a, k));
    bytes = std::max(bytes, a.sharedSizeBytes);
  }
  return bytes;
}

/// A method's iteration kernels for `lanes` threads per vertex, as plain pointers.
template <bool kChebyshev>
std::vector<const void*> iteration_kernel_pointers(int lanes) {
  std::vector<const void*> out;
  for (const IterationKernel k : iteration_kernels<kChebyshev>(lanes)) out.push_back(reinterpret_cast<const void*>(k));
  return out;
}

/// The static shared memory of the kernels that take a patch's dynamic shared memory (both methods).
std::size_t static_shared_bytes() {
  std::vector<const void*> kernels;
  for (const int lanes : {kMinLanes, kMaxLanes})
    for (const auto& of : {iteration_kernel_pointers<true>(lanes), iteration_kernel_pointers<false>(lanes)})
      kernels.insert(kernels.end(), of.begin(), of.end());
#if EBH_GRAPH_LOOPS
  kernels.push_back(reinterpret_cast<const void*>(loop_iteration_kernel<kMinLanes, true>));
  kernels.push_back(reinterpret_cast<const void*>(loop_iteration_kernel<kMinLanes, false>));
  kernels.push_back(reinterpret_cast<const void*>(loop_iteration_kernel<kMaxLanes, true>));
  kernels.push_back(reinterpret_cast<const void*>(loop_iteration_kernel<kMaxLanes, false>));
#endif
  return static_shared_of(kernels);
}

/// A patch block's dynamic shared memory (patch_shared).
std::size_t patch_shared_bytes(const Patches& P) {
  return static_cast<std::size_t>(P.max_tets) * sizeof(TetItem) + static_cast<std::size_t>(P.max_pulls) * sizeof(PullItem) +
         (static_cast<std::size_t>(P.max_slots) + 4 * static_cast<std::size_t>(P.max_tets) + P.max_pulls) * sizeof(Vec3f);
}
}  // namespace

void CudaPhysicalSolver::Impl::upload_model(const PhysicalModel& M, int asked_patch, bool beside_ticks) {
  n = M.num_vertices;
  T = M.num_tets;
  m = M.num_virtual;
  cudaStream_t st = stream.get();
  auto up = [st](auto& arr, const auto& host) {
    arr.allocate(host.size());
    arr.upload(host.data(), st);
  };
  // Patches: about two blocks per multiprocessor, so that one wave holds them all, at most
  // kMaxPatch vertices; halved while a patch's block does not fit the device's shared memory (a
  // dense mesh: vertices of high valence).
  int device = 0, sms = 1, optin = 0;
  EBH_CUDA_CHECK(cudaGetDevice(&device));
  EBH_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  EBH_CUDA_CHECK(cudaDeviceGetAttribute(&optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, device));
  const std::size_t room = static_cast<std::size_t>(optin) - std::min<std::size_t>(optin, static_shared_bytes());
  const int most = beside_ticks ? kBlock / kMaxLanes : kMaxPatch;
  int size = std::clamp(asked_patch > 0 ? asked_patch : (n + 2 * sms - 1) / std::max(1, 2 * sms), 8, most);
  Patches P = build_patches(M, size);
  while ((P.too_many > 0 || patch_shared_bytes(P) > room) && size > 8) {
    size = std::max(8, size / 2);
    P = build_patches(M, size);
  }
  if (P.too_many > 0 || patch_shared_bytes(P) > room)
    throw InputError("--backend cuda: the physical mesh is too dense for the device: a patch of " + std::to_string(size) +
                     " vertices touches " + std::to_string(std::max(P.too_many, P.max_tets)) + " tets and needs " +
                     std::to_string(patch_shared_bytes(P) / 1024) + " KiB of shared memory, more than the " +
                     std::to_string(room / 1024) + " KiB a block has (or the 16-bit slots hold); use --backend cpu");
  patches = static_cast<int>(P.own_count.size());
  patch_vertices = size;
  lanes = size <= kBlock / kMaxLanes ? kMaxLanes : kMinLanes;
  up(slot_offsets, P.slot_offsets);
  up(slot_vertex, P.slot_vertex);
  up(own_count, P.own_count);
  up(ptet_offsets, P.ptet_offsets);
  up(ptet, P.ptet);
  up(ptet_corner, P.ptet_corner);
  up(ptet_grad, P.ptet_grad);
  up(ptet_weight, P.ptet_weight);
  up(force_slot, P.force_slot);
  up(pcpl_offsets, P.pcpl_offsets);
  up(pcpl, P.pcpl);
  up(pcpl_corner, P.pcpl_corner);
  up(pull_slot, P.pull_slot);
  shared_bytes = patch_shared_bytes(P);

  std::vector<int> pv(4 * size_t(m), -1);
  std::vector<float> pw(4 * size_t(m), 0.f);
  for (int j = 0; j < m; ++j)
    for (int k = 0; k < 4; ++k) { pv[4 * j + k] = M.pair_vertex[j][k]; pw[4 * j + k] = float(M.pair_weight[j][k]); }
  up(pair_vertex, pv);
  up(pair_weight, pw);
  up(pair_count, M.pair_count);
  up(tet_offsets, M.tet_offsets);
  up(cpl_offsets, M.cpl_offsets);
  std::vector<float> cw(M.cpl_weight.size());
  for (size_t k = 0; k < cw.size(); ++k) cw[k] = float(M.cpl_weight[k]);
  up(cpl_weight, cw);

  // Per-vertex constants in double, rounded once: m/h^2 and gamma / A(a, a).
  std::vector<float> mh(n), sc(n);
  const double gamma = params.relaxation;
  for (int a = 0; a < n; ++a) {
    mh[a] = float(M.mass[a] / (M.h * M.h));
    sc[a] = float(gamma / M.diag[a]);
  }
  up(mass_h2, mh);
  up(step_scale, sc);
  up(pinned, M.pinned);

  for (auto* arr : {&x, &v, &s, &x_start, &scratch0, &scratch1, &scratch2}) arr->allocate(n);
  q.allocate(m);
  rotation.allocate(2 * size_t(T));
  rsq_first.allocate(n);
  rsq_last.allocate(n);
  blocks_done.allocate(1);
  EBH_CUDA_CHECK(cudaMemsetAsync(blocks_done.get(), 0, sizeof(unsigned int), st));
  q_host.allocate(m);
  x_host.allocate(n);
  EBH_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&residual_host), kReportValues * sizeof(double), cudaHostAllocMapped));
  std::fill(residual_host, residual_host + kReportValues, 0.0);
  EBH_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&dev.residual_sq), residual_host, 0));

  dev.n = n;
  dev.T = T;
  dev.m = m;
  dev.h = float(M.h);
  dev.k_svc = float(M.k_svc);
  dev.velocity_scale = float((1.0 - M.damping) / M.h);
  dev.det_ratio = float(M.det_ratio);
  dev.gravity = to_float(M.gravity);
  dev.slot_offsets = slot_offsets.get();
  dev.slot_vertex = slot_vertex.get();
  dev.own_count = own_count.get();
  dev.ptet_offsets = ptet_offsets.get();
  dev.ptet = ptet.get();
  dev.ptet_corner = ptet_corner.get();
  dev.ptet_grad = ptet_grad.get();
  dev.ptet_weight = ptet_weight.get();
  dev.pcpl_offsets = pcpl_offsets.get();
  dev.pcpl = pcpl.get();
  dev.pcpl_corner = pcpl_corner.get();
  dev.pull_slot = pull_slot.get();
  dev.max_slots = P.max_slots;
  dev.max_tets = P.max_tets;
  dev.max_pulls = P.max_pulls;
  dev.tet_offsets = tet_offsets.get();
  dev.force_slot = force_slot.get();
  dev.cpl_offsets = cpl_offsets.get();
  dev.cpl_weight = cpl_weight.get();
  dev.pair_vertex = pair_vertex.get();
  dev.pair_weight = pair_weight.get();
  dev.pair_count = pair_count.get();
  dev.mass_h2 = mass_h2.get();
  dev.step_scale = step_scale.get();
  dev.pinned = pinned.get();
  dev.q = q.get();
  dev.x = x.get();
  dev.v = v.get();
  dev.s = s.get();
  dev.x_start = x_start.get();
  dev.rotation = rotation.get();
  dev.rsq_first = rsq_first.get();
  dev.rsq_last = rsq_last.get();
  dev.blocks_done = blocks_done.get();

  plan.scratch[0] = scratch0.get();
  plan.scratch[1] = scratch1.get();
  plan.scratch[2] = scratch2.get();
  plan.s = s.get();
  plan.x = x.get();
  plan.rot = rotation.get();
  plan.T = T;
  plan.K = params.iterations;
  omega_host = iteration_weights(params);
  if (params.adaptive()) {
    const int start = params.iterations - 1;  // the loop's first iteration
    next_iteration.allocate(1);
    next_iteration.upload(&start, st);
    const StoppingState fresh{};
    stopping.allocate(1);
    stopping.upload(&fresh, st);
    dev.stopping = stopping.get();
    omega.allocate(omega_host.size());
    omega.upload(omega_host.data(), st);
    dev.next_iteration = next_iteration.get();
    dev.omega = omega.get();
    dev.max_iterations = params.max_iterations;
  }
  dev.weight_norm = weight_norm;
  dev.tolerance = params.tolerance;
  dev.iterations = params.iterations;
  if (region > 0) {
    // Each patch's own vertices, its free count and its halo (patch_halos), by model vertex.
    std::vector<int> offsets{0}, members, of(n, 0), free(patches, 0);
    for (int p = 0; p < patches; ++p) {
      for (int i = 0; i < P.own_count[p]; ++i) {
        const int a = P.slot_vertex[P.slot_offsets[p] + i];
        members.push_back(a);
        of[a] = p;
        free[p] += M.pinned[a] ? 0 : 1;
      }
      offsets.push_back(static_cast<int>(members.size()));
    }
    const PatchHalos H = patch_halos(M, offsets, members);
    up(halo_offsets, H.offsets);
    up(halo, H.vertices);
    up(cpl_virtual, M.cpl_virtual);
    up(patch_of, of);
    up(patch_free, free);
    patch_awake.allocate(patches);
    seen.allocate(std::max(m, 1));
    region_flags.allocate(2);
    dev.region_sq = static_cast<float>(region * region);
    dev.halo_offsets = halo_offsets.get();
    dev.halo = halo.get();
    dev.cpl_virtual = cpl_virtual.get();
    dev.patch_of = patch_of.get();
    dev.patch_free = patch_free.get();
    dev.patch_awake = patch_awake.get();
    dev.seen = seen.get();
    dev.region_flags = region_flags.get();
  }
  if (sleep > 0) {
    sleep_flags.allocate(2);
    EBH_CUDA_CHECK(cudaMemsetAsync(sleep_flags.get(), 0, 2 * sizeof(int), st));
    ran_with.allocate(std::max(m, 1));
    dev.sleep_sq = static_cast<float>(sleep * sleep);
    dev.sleep_flags = sleep_flags.get();
    dev.ran_with = ran_with.get();
  }
}

template <bool kChebyshev>
void CudaPhysicalSolver::Impl::capture_iterations(bool pdl, cudaStream_t st) {
  const int K = params.iterations, rot = params.rotation_iterations;
  const auto [first, middle, last] = iteration_kernels<kChebyshev>(lanes);
  for (auto* kernel : {first, middle, last}) allow_dynamic_shared(reinterpret_cast<const void*>(kernel), shared_bytes);
  if (params.adaptive()) {
    // Iterations 0 .. K-2 as below but none writes the state (plan K = 0), then the loop.
    SweepPlan open = plan;
    open.K = 0;
    for (int k = 0; k + 1 < K; ++k)
      cuda::launch(pdl && k > 0, k == 0 ? first : middle, patches, kBlock, shared_bytes, st, "iteration_kernel", dev,
                   open.sweep(k, omega_host[k], k == 0 ? dev.rsq_first : nullptr), rot);
    capture_loop<kChebyshev>(st);
    return;
  }
  for (int k = 0; k < K; ++k) {
    float* rsq = k == 0 ? dev.rsq_first : (k == K - 1 ? dev.rsq_last : nullptr);
    const Sweep w = plan.sweep(k, omega_host[k], rsq);
    const bool edge = pdl && k > 0;  // the first kernel after a copy node takes no programmatic edge
    auto* kernel = k == 0 ? first : (k == K - 1 ? last : middle);
    cuda::launch(edge, kernel, patches, kBlock, shared_bytes, st, "iteration_kernel", dev, w, rot);
  }
  if (K == 1) {
    PhysicalDevice once = dev;
    once.rsq_last = once.rsq_first;  // one iteration: the residual ratio is 1
    cuda::launch(pdl, finish_kernel, cuda::blocks_for(n, kBlock), kBlock, 0, st, "finish_kernel", once,
           static_cast<const Vec3f*>(plan.scratch[0]));
  }
}

#if EBH_GRAPH_LOOPS
namespace {
/// A handle for a conditional node of the graph being captured on st (its value 1 at each launch
/// unless a kernel sets it).
cudaGraphConditionalHandle conditional_handle(cudaStream_t st) {
  cudaStreamCaptureStatus status{};
  cudaGraph_t graph_now = nullptr;
  EBH_CUDA_CHECK(cudaStreamGetCaptureInfo(st, &status, nullptr, &graph_now, nullptr, nullptr, nullptr));
  cudaGraphConditionalHandle handle{};
  EBH_CUDA_CHECK(cudaGraphConditionalHandleCreate(&handle, graph_now, 1, cudaGraphCondAssignDefault));
  return handle;
}

/// Adds a conditional node of `type` on `handle` after what st has captured, and captures its body
/// on body_stream: capture_body(body_stream).
template <class F>
void capture_conditional(cudaStream_t st, cudaStream_t body_stream, cudaGraphConditionalHandle handle,
                         cudaGraphConditionalNodeType type, F&& capture_body) {
  cudaStreamCaptureStatus status{};
  cudaGraph_t graph_now = nullptr;
  const cudaGraphNode_t* deps = nullptr;
  const cudaGraphEdgeData* edges = nullptr;
  std::size_t count = 0;
  EBH_CUDA_CHECK(cudaStreamGetCaptureInfo(st, &status, nullptr, &graph_now, &deps, &edges, &count));
  cudaGraphNodeParams node_params{};
  node_params.type = cudaGraphNodeTypeConditional;
  node_params.conditional.handle = handle;
  node_params.conditional.type = type;
  node_params.conditional.size = 1;
  cudaGraphNode_t node = nullptr;
  EBH_CUDA_CHECK(cudaGraphAddNode(&node, graph_now, deps, edges, count, &node_params));
  EBH_CUDA_CHECK(cudaStreamUpdateCaptureDependencies(st, &node, nullptr, 1, cudaStreamSetCaptureDependencies));
  cudaGraph_t body = node_params.conditional.phGraph_out[0];
  EBH_CUDA_CHECK(cudaStreamBeginCaptureToGraph(body_stream, body, nullptr, nullptr, 0, cudaStreamCaptureModeThreadLocal));
  try {
    capture_body(body_stream);
  } catch (...) {
    cudaGraph_t ended = nullptr;
    cudaStreamEndCapture(body_stream, &ended);
    throw;
  }
  EBH_CUDA_CHECK(cudaStreamEndCapture(body_stream, &body));
}
}  // namespace
#endif

/// The stopping rule's part of the graph (params.adaptive()): a while node whose body is one
/// loop_iteration_kernel (iteration K - 1 first: the node's condition starts at 1), then
/// loop_finish_kernel. The node is added to the graph being captured on `st`, its body captured
/// on body_stream.
template <bool kChebyshev>
void CudaPhysicalSolver::Impl::capture_loop(cudaStream_t st) {
#if !EBH_GRAPH_LOOPS
  (void)st;
  throw InputError("--backend cuda: solver.physical_tolerance needs the CUDA backend built with CUDA 13 or newer "
                   "(graph while nodes); set solver.physical_tolerance=0");
#else
  auto* body_kernel = lanes == kMinLanes ? loop_iteration_kernel<kMinLanes, kChebyshev> : loop_iteration_kernel<kMaxLanes, kChebyshev>;
  allow_dynamic_shared(reinterpret_cast<const void*>(body_kernel), shared_bytes);
  const cudaGraphConditionalHandle handle = conditional_handle(st);
  SweepPlan open = plan;
  open.K = 0;  // no iteration writes the state
  capture_conditional(st, body_stream.get(), handle, cudaGraphCondTypeWhile, [&](cudaStream_t bs) {
    cuda::launch(false, body_kernel, patches, kBlock, shared_bytes, bs, "loop_iteration_kernel", dev, open,
                 params.rotation_iterations, handle);
  });
  cuda::launch(false, loop_finish_kernel, cuda::blocks_for(std::max(n, T), kBlock), kBlock, 0, st, "loop_finish_kernel",
               dev, open);
#endif
}

void CudaPhysicalSolver::Impl::capture(bool pdl, bool copies) {
  cudaStream_t st = stream.get();
  const int K = params.iterations;
  EBH_CUDA_CHECK(cudaStreamBeginCapture(st, cudaStreamCaptureModeThreadLocal));
  try {
    if (copies) copy_q_in(st);
    if (n > 0 && K == 0)
      cuda::launch(false, predict_only_kernel, cuda::blocks_for(n, kBlock), kBlock, 0, st, "predict_only_kernel", dev);
    if (n > 0 && K > 0) {
      if (sleep > 0) capture_sleeping_step(pdl, st);
      else capture_step(pdl, st);
    }
    if (copies) {
      copy_results_out(st);
    }
  } catch (...) {
    cudaGraph_t broken = nullptr;
    cudaStreamEndCapture(st, &broken);  // leave capture mode whatever failed
    if (broken) cudaGraphDestroy(broken);
    throw;
  }
  cudaGraph_t& g = copies ? graph : graph_device;
  cudaGraphExec_t& e = copies ? exec : exec_device;
  EBH_CUDA_CHECK(cudaStreamEndCapture(st, &g));
  EBH_CUDA_CHECK(cudaGraphInstantiate(&e, g, 0));
  programmatic = pdl;
}

/// The K iterations (and, K odd, the last rotations into the state half), captured on st.
void CudaPhysicalSolver::Impl::capture_step(bool pdl, cudaStream_t st) {
  const int K = params.iterations;
  if (region > 0)  // the awake region: which patches iterate (a plain edge to the first iteration: patch_asleep)
    cuda::launch(false, region_decide_kernel, patches, kBlock, 0, st, "region_decide_kernel", dev, plan);
  if (params.method == SolverSpec::Method::Chebyshev) capture_iterations<true>(pdl, st);
  else capture_iterations<false>(pdl, st);
  if (K % 2 == 1 && T > 0 && !params.adaptive())  // the last rotations are in the scratch half
    EBH_CUDA_CHECK(cudaMemcpyAsync(rotation.get(), rotation.get() + T, T * sizeof(Quatf), cudaMemcpyDeviceToDevice, st));
  if (region > 0)
    cuda::launch(false, region_seen_kernel, cuda::blocks_for(std::max(m, 1), kBlock), kBlock, 0, st, "region_seen_kernel",
                 dev);
}

/// With sleep > 0: sleep_gate_kernel, then the step (capture_step) as the body of a conditional
/// node that the gate sets, captured on awake_stream.
void CudaPhysicalSolver::Impl::capture_sleeping_step(bool pdl, cudaStream_t st) {
#if !EBH_GRAPH_LOOPS
  (void)pdl;
  (void)st;
  throw InputError("--backend cuda: solver.sleep needs the CUDA backend built with CUDA 13 or newer "
                   "(graph conditional nodes); set solver.sleep=0");
#else
  const cudaGraphConditionalHandle handle = conditional_handle(st);
  cuda::launch(false, sleep_gate_kernel, cuda::blocks_for(std::max(n, m), kBlock), kBlock, 0, st, "sleep_gate_kernel",
               dev, handle);
  capture_conditional(st, awake_stream.get(), handle, cudaGraphCondTypeIf,
                      [&](cudaStream_t as) { capture_step(pdl, as); });
#endif
}

/// The step's input: q, rounded to float on the host, into the device.
void CudaPhysicalSolver::Impl::copy_q_in(cudaStream_t st) {
  if (m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(q.get(), q_host.get(), m * sizeof(Vec3f), cudaMemcpyHostToDevice, st));
}

/// The step's output x (the residual sums reach the host without a copy: residual_host).
void CudaPhysicalSolver::Impl::copy_results_out(cudaStream_t st) {
  if (n == 0) return;
  EBH_CUDA_CHECK(cudaMemcpyAsync(x_host.get(), x.get(), n * sizeof(Vec3f), cudaMemcpyDeviceToHost, st));
}

CudaPhysicalSolver::CudaPhysicalSolver(const PhysicalModel& model, const PhysicalStepParams& params,
                                       const CudaPhysicalOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (params.method == SolverSpec::Method::Direct)
    throw InputError("--backend cuda: the direct method runs on the CPU only (use jacobi or chebyshev)");
  if (params.iterations < 0) throw InputError("physical iterations must not be negative");
  if (params.adaptive() && !EBH_GRAPH_LOOPS)
    throw InputError("--backend cuda: solver.physical_tolerance needs the CUDA backend built with CUDA 13 or newer "
                     "(graph while nodes); set solver.physical_tolerance=0");
  if (!(options.sleep >= 0)) throw InputError("solver.sleep must not be negative");
  if (!(options.region >= 0)) throw InputError("solver.physical_region must not be negative");
  impl_->params = params;
  impl_->weight_norm = model.weight_norm;
  impl_->tet_slot = model.tet_slot;
  impl_->sleep = options.sleep;
  impl_->region = params.iterations > 0 ? options.region : 0;  // K = 0 only predicts
  impl_->upload_model(model, options.patch_vertices, options.beside_ticks);
  upload_state(make_physical_state(model));
  // Programmatic dependent launch in the graph where the driver takes it; plain kernel nodes
  // otherwise.
  if (options.programmatic_launch) {
    try {
      impl_->capture(true, true);
      return;
    } catch (const std::runtime_error&) {
      cudaGetLastError();  // clear the failed launch's error and fall back
      if (impl_->exec) { cudaGraphExecDestroy(impl_->exec); impl_->exec = nullptr; }
      if (impl_->graph) { cudaGraphDestroy(impl_->graph); impl_->graph = nullptr; }
    }
  }
  impl_->capture(false, true);
}

CudaPhysicalSolver::~CudaPhysicalSolver() = default;

const PhysicalStepParams& CudaPhysicalSolver::params() const { return impl_->params; }

double CudaPhysicalSolver::last_device_seconds() const { return impl_->device_s; }

double CudaPhysicalSolver::tet_evaluations_per_tet() const {
  return impl_->T > 0 ? static_cast<double>(impl_->ptet.size()) / impl_->T : 1.0;
}

bool CudaPhysicalSolver::programmatic_launch() const { return impl_->programmatic; }

std::size_t CudaPhysicalSolver::block_shared_bytes() const {
  const bool chebyshev = impl_->params.method == SolverSpec::Method::Chebyshev;
  return impl_->shared_bytes + static_shared_of(chebyshev ? iteration_kernel_pointers<true>(impl_->lanes)
                                                          : iteration_kernel_pointers<false>(impl_->lanes));
}

int CudaPhysicalSolver::patch_vertices() const { return impl_->patch_vertices; }

bool CudaPhysicalSolver::can_sleep() { return EBH_GRAPH_LOOPS != 0; }

int CudaPhysicalSolver::patch_lanes() const { return impl_->lanes;
}

void CudaPhysicalSolver::upload_state(const PhysicalState& state) {
  Impl& I = *impl_;
  if (state.x.size() != size_t(I.n) || state.v.size() != size_t(I.n) || state.rotation.size() != size_t(I.T))
    throw std::invalid_argument("CudaPhysicalSolver::upload_state: state sizes do not match the model");
  std::vector<Vec3f> x(I.n), v(I.n);
  std::vector<Quatf> r(I.T);
  for (int a = 0; a < I.n; ++a) { x[a] = to_float(state.x[a]); v[a] = to_float(state.v[a]); }
  for (int t = 0; t < I.T; ++t) r[t] = to_float(state.rotation[I.tet_slot[t]]);  // by tet on the device
  I.x.upload(x.data(), I.stream.get());
  I.v.upload(v.data(), I.stream.get());
  if (I.sleep > 0)  // a new state: the next step runs
    EBH_CUDA_CHECK(cudaMemsetAsync(I.sleep_flags.get(), 0, 2 * sizeof(int), I.stream.get()));
  if (I.region > 0) {  // a new state: the next step iterates every patch
    const int whole[2] = {1, 0};
    I.region_flags.upload(whole, I.stream.get());
  }
  if (I.T > 0) {  // the state half of the two rotation buffers
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.rotation.get(), r.data(), I.T * sizeof(Quatf), cudaMemcpyHostToDevice, I.stream.get()));
    EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream.get()));
  }
}

void CudaPhysicalSolver::download_state(PhysicalState& state) const {
  const Impl& I = *impl_;
  std::vector<Vec3f> x(I.n), v(I.n);
  std::vector<Quatf> r(I.T);
  I.x.download(x.data(), I.stream.get());
  I.v.download(v.data(), I.stream.get());
  if (I.T > 0) {
    EBH_CUDA_CHECK(cudaMemcpyAsync(r.data(), I.rotation.get(), I.T * sizeof(Quatf), cudaMemcpyDeviceToHost, I.stream.get()));
    EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream.get()));
  }
  state.x.resize(I.n);
  state.v.resize(I.n);
  state.rotation.resize(I.T);
  for (int a = 0; a < I.n; ++a) { state.x[a] = static_cast<Vec3d>(x[a]); state.v[a] = static_cast<Vec3d>(v[a]); }
  for (int t = 0; t < I.T; ++t) state.rotation[I.tet_slot[t]] = Quatd{r[t].w, r[t].x, r[t].y, r[t].z};
}

PhysicalStepReport CudaPhysicalSolver::step(PhysicalState& state, std::span<const Vec3d> virtual_q) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  Impl& I = *impl_;
  if (I.m > 0 && virtual_q.size() != size_t(I.m))
    throw std::invalid_argument("CudaPhysicalSolver::step: virtual_q has the wrong size");
  for (int j = 0; j < I.m; ++j) I.q_host[j] = to_float(virtual_q[j]);
  EBH_CUDA_CHECK(cudaEventRecord(I.start, I.stream.get()));
  EBH_CUDA_CHECK(cudaGraphLaunch(I.exec, I.stream.get()));
  EBH_CUDA_CHECK(cudaEventRecord(I.stop, I.stream.get()));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream.get()));
  float ms = 0;
  EBH_CUDA_CHECK(cudaEventElapsedTime(&ms, I.start, I.stop));
  I.device_s = 1e-3 * ms;
  state.x.resize(I.n);
  for (int a = 0; a < I.n; ++a) state.x[a] = static_cast<Vec3d>(I.x_host[a]);
  PhysicalStepReport report = I.report();
  report.time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return report;
}

PhysicalStepReport CudaPhysicalSolver::Impl::report(const double* sums) const {
  PhysicalStepReport r;
  r.iterations = params.adaptive() || sleep > 0 ? static_cast<int>(sums[2]) : params.iterations;
  r.slept = sleep > 0 && params.iterations > 0 && n > 0 && sums[2] == 0;
  if (params.iterations > 0 && n > 0) {
    set_residuals(r, std::sqrt(sums[0]), std::sqrt(sums[1]), weight_norm);
  }
  if (region > 0 && !r.slept) {
    r.awake = static_cast<int>(sums[3]);
    if (r.awake == 0) {  // no patch iterated: the state held at rest, as the CPU's skipped step
      r.slept = true;
      r.iterations = 0;
      r.residual_reduction = 1;
    }
  } else if (region > 0) {
    r.awake = 0;
  }
  return r;
}

Vec3f* CudaPhysicalSolver::device_q() { return impl_->q.get(); }

const Vec3f* CudaPhysicalSolver::device_x() const { return impl_->x.get(); }

void* CudaPhysicalSolver::stream_handle() const { return impl_->stream.get(); }

void CudaPhysicalSolver::launch_device_step() { launch_device_step(-1); }

PhysicalStepReport CudaPhysicalSolver::device_step_report() { return device_step_report(-1); }

void CudaPhysicalSolver::prepare_device_step() {
  Impl& I = *impl_;
  if (!I.exec_device) {
    const bool pdl = I.programmatic;  // as the copying graph (capture() resets the flag: restored below)
    try {
      I.capture(pdl, false);
    } catch (const std::runtime_error&) {
      if (!pdl) throw;
      cudaGetLastError();
      if (I.exec_device) { cudaGraphExecDestroy(I.exec_device); I.exec_device = nullptr; }
      if (I.graph_device) { cudaGraphDestroy(I.graph_device); I.graph_device = nullptr; }
      I.capture(false, false);
    }
    I.programmatic = pdl;
  }
}

void CudaPhysicalSolver::set_device_step_slots(int slots) {
  Impl& I = *impl_;
  if (slots < 1) throw std::invalid_argument("CudaPhysicalSolver::set_device_step_slots: slots must be positive");
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream.get()));
  I.free_slots();
  I.slot_start.resize(slots);
  I.slot_stop.resize(slots);
  I.slot_done.resize(slots);
  for (int k = 0; k < slots; ++k) {
    EBH_CUDA_CHECK(cudaEventCreate(&I.slot_start[k]));
    EBH_CUDA_CHECK(cudaEventCreate(&I.slot_stop[k]));
    EBH_CUDA_CHECK(cudaEventCreateWithFlags(&I.slot_done[k], cudaEventDisableTiming));
  }
  EBH_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&I.slot_residual), kReportValues * slots * sizeof(double),
                               cudaHostAllocMapped));
  std::fill(I.slot_residual, I.slot_residual + kReportValues * slots, 0.0);
  EBH_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&I.slot_residual_dev), I.slot_residual, 0));
}

void CudaPhysicalSolver::launch_device_step(int slot) {
  Impl& I = *impl_;
  if (slot >= static_cast<int>(I.slot_start.size()))
    throw std::invalid_argument("CudaPhysicalSolver::launch_device_step: no slot " + std::to_string(slot) +
                                " (set_device_step_slots)");
  prepare_device_step();
  cudaStream_t st = I.stream.get();
  EBH_CUDA_CHECK(cudaEventRecord(slot < 0 ? I.start : I.slot_start[slot], st));
  EBH_CUDA_CHECK(cudaGraphLaunch(I.exec_device, st));
  EBH_CUDA_CHECK(cudaEventRecord(slot < 0 ? I.stop : I.slot_stop[slot], st));
  if (slot >= 0) {
    copy_residual_kernel<<<1, 32, 0, st>>>(I.dev.residual_sq, I.slot_residual_dev + kReportValues * slot);
    EBH_CUDA_LAUNCH_CHECK(st, "copy_residual_kernel");
    EBH_CUDA_CHECK(cudaEventRecord(I.slot_done[slot], st));
  }
}

PhysicalStepReport CudaPhysicalSolver::device_step_report(int slot) {
  Impl& I = *impl_;
  if (slot >= static_cast<int>(I.slot_start.size()))
    throw std::invalid_argument("CudaPhysicalSolver::device_step_report: no slot " + std::to_string(slot));
  cudaEvent_t start = slot < 0 ? I.start : I.slot_start[slot], stop = slot < 0 ? I.stop : I.slot_stop[slot];
  EBH_CUDA_CHECK(cudaEventSynchronize(slot < 0 ? stop : I.slot_done[slot]));  // a slot: its residual copied
  float ms = 0;
  EBH_CUDA_CHECK(cudaEventElapsedTime(&ms, start, stop));
  I.device_s = 1e-3 * ms;
  PhysicalStepReport r = I.report(slot < 0 ? I.residual_host : I.slot_residual + kReportValues * slot);
  r.time_s = I.device_s;
  return r;
}

}  // namespace ebh
