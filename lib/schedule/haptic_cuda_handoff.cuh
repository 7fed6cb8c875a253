#pragma once
// The device haptic tick's hand-offs (part of haptic_cuda.cu's translation unit): the counters
// block 0 and the vertex blocks release and acquire, the schedule of a run's steps, the chunks'
// candidate and held lists that block 0 gathers in a fixed order, and the kernels on the physical
// step's stream that exchange q and x with the ticks of a launch across periods.
#include "mesh/boundary.hpp"
#include "schedule/haptic_cuda_layout.cuh"

namespace ebh {
namespace {

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
/// the add without the full fence (fence.sc) of __threadfence and a relaxed atomicAdd.
__device__ __forceinline__ void add_release(unsigned long long* p, unsigned long long v) {
  asm volatile("red.release.gpu.global.add.u64 [%0], %1;" ::"l"(p), "l"(v) : "memory");
}

/// The steps of one run: step s is iteration s % K of tick tick0 + s / K.
struct Schedule {
  int K;
  int first_call;  // iterations first_call .. K - 1 of a tick are followed by a Newton call
  long long tick0;
  unsigned long long epoch0;  // the hand-off epochs before the run
  bool pipeline;
  const DeviceTickInput* inputs;
  Vec3f *q0, *q1, *q2, *v, *v_scratch;
  __device__ Schedule(const MeshDev& d, long long tick0_, unsigned long long epoch0_)
      : K(d.iterations), first_call(d.first_call), tick0(tick0_), epoch0(epoch0_), pipeline(d.pipeline), inputs(d.inputs), q0(d.q0), q1(d.q1),
        q2(d.q2), v(d.v), v_scratch(d.v_scratch) {}
  __device__ bool first(int s) const { return s % K == 0; }
  __device__ bool last(int s) const { return s % K == K - 1; }
  __device__ long long tick(int s) const { return tick0 + s / K; }
  __device__ const DeviceTickInput& input(int s) const { return inputs[tick(s)]; }
  /// Whether the virtual tool's Newton call follows step s (a tick's last step always has one).
  __device__ bool called(int s) const { return s % K >= first_call; }
  /// The epoch of step s's vertices: the steps enqueued through it (every run's).
  __device__ unsigned long long epoch(int s) const { return epoch0 + s + 1ull; }
  /// Whether step s waits for the Newton call before it (an unpipelined step): the run's first
  /// step; a step with no Newton call before it (nothing moves the tool beside it, so no vertex is
  /// deferred); a tick's first step with a grasp event (which changes the held vertices). Block 0
  /// also runs a step unpipelined when the call before it has more candidates than
  /// MeshDev::pipeline_limit, and tells the vertex blocks in the step's slot (SlotPose::ahead).
  __device__ bool unpipelined(int s) const {
    if (s == 0 || !pipeline || !called(s - 1)) return true;
    return first(s) && input(s).grasp != 0;
  }
  /// K = 1, tick(s) odd: a tick of one iteration both reads and writes its iterate and velocity,
  /// so the two buffers of each take turns tick by tick (q0 -> q1 on even ticks, q1 -> q0 on odd
  /// ones; v -> v_scratch, v_scratch -> v), by the absolute tick, across runs (state_buffer).
  __device__ bool odd(int s) const { return K == 1 && (tick(s) & 1) != 0; }
  /// Iteration i reads in(s) and writes out(s): q0 -> q1 -> q2 -> q1 ... -> q0 (the last); K = 1
  /// as odd() says.
  __device__ const Vec3f* in(int s) const {
    const int i = s % K;
    if (K == 1) return odd(s) ? q1 : q0;
    return i == 0 ? q0 : (i % 2 == 1 ? q1 : q2);
  }
  __device__ Vec3f* out(int s) const {
    const int i = s % K;
    if (K == 1) return odd(s) ? q0 : q1;
    return i == K - 1 ? q0 : (i % 2 == 0 ? q1 : q2);
  }
  /// The buffer a tick's first step neither reads nor writes and its second step writes (q2; K >= 3,
  /// a tick with middle steps; else none): a sleeping chunk's first step writes it too, so that
  /// its vertices, which stand still for the tick, need no middle step (vertex_blocks).
  __device__ Vec3f* spare() const { return K >= 3 ? q2 : nullptr; }
  /// The velocities a tick's first step reads (its start x + h v) and its last step writes.
  __device__ const Vec3f* v_in(int s) const { return odd(s) ? v_scratch : v; }
  __device__ Vec3f* v_out(int s) const { return K == 1 && !odd(s) ? v_scratch : v; }
};

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

/// Block 0: the n1 held vertices of an unpipelined step of q in vertex order (off: chunk_offsets'),
/// the first kCache with their grasp point and q in shared memory (held_slot: their entry), the
/// rest in d.held_list.
__device__ void gather_held(const MeshDev& d, const int* off, int n1, const Vec3f* q, TailShared& sh) {
  for (int i = threadIdx.x; i < n1; i += kBlock) {
    const int j = list_item(d, off + d.chunks + 1, d.block_held, i);
    d.held_slot[j] = i < kCache ? i : -1;
    if (i < kCache) {
      sh.held_local[i] = d.grasp_local[j];
      sh.held_q[i] = static_cast<Vec3d>(q[j]);
    } else {
      d.held_list[i] = j;
    }
  }
}

/// Block 0 after an unpipelined step of q: the candidates (their q in d.cand_q) and the held
/// vertices (gather_held) in vertex order.
__device__ void unpipelined_lists(const MeshDev& d, const Vec3f* q, TailShared& sh) {
  int n0 = 0, n1 = 0;
  const int* off = chunk_offsets(d, sh, n0, n1);
  for (int i = threadIdx.x; i < n0; i += kBlock) put_candidate(d, sh, i, list_item(d, off, d.block_cand, i));
  gather_held(d, off, n1, q, sh);
  if (threadIdx.x == 0) { sh.nc = n0; sh.nh = n1; }
  __syncthreads();
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
/// nothing waits (a device-to-device copy may run as a kernel of the driver's).
__global__ void copy_positions(const Vec3f* from, Vec3f* to, int n) {
  for (int a = blockIdx.x * blockDim.x + threadIdx.x; a < n; a += gridDim.x * blockDim.x) to[a] = from[a];
}

/// Step k's inverted or flat tets (inverted_or_flat, against their signs at rest) at its x in the
/// ring, added to `sum`: the host's test on the same coordinates (float32 widened to double, as
/// finish_step's x), so the count is the one the host would make (docs/CUDA.md).
__global__ void count_inverted(const Vec3f* x, const int4* tets, const signed char* sign, int count, unsigned* sum) {
  unsigned c = 0;
  for (int a = blockIdx.x * blockDim.x + threadIdx.x; a < count; a += gridDim.x * blockDim.x) {
    const int4 t = tets[a];
    c += inverted_or_flat(static_cast<Vec3d>(x[t.x]), static_cast<Vec3d>(x[t.y]), static_cast<Vec3d>(x[t.z]),
                          static_cast<Vec3d>(x[t.w]), sign[a]);
  }
  for (int o = 16; o > 0; o >>= 1) c += __shfl_down_sync(0xffffffffu, c, o);
  if ((threadIdx.x & 31) == 0 && c > 0) atomicAdd(sum, c);
}

/// The physical step's stream after step k's x is in the ring: publishes it to the ticks (k1 = k + 1).
/// With the tets counted (sum not null): the count into the step's host slot, `sum` zeroed for the next.
__global__ void publish_step(StepsDev* s, unsigned long long k1, unsigned* sum, int* slot) {
  if (threadIdx.x == 0) {
    if (sum) {
      *slot = static_cast<int>(*sum);
      *sum = 0;
    }
    store_release(&s->done, k1);
  }
}

}  // namespace
}  // namespace ebh
