// The device haptic tick with surface contact (surface_ticks_kernel; haptic_cuda_surface.cuh has
// the per-vertex and per-triangle parts; docs/CUDA.md, "Surface contact"): the vertex blocks' and
// block 0's loops over a run's steps, and the kernel. A translation unit of its own beside
// haptic_cuda.cu (which launches it), built from the same parts, so that the vertex-contact
// kernel there compiles as it did without it.
//
// Every step is unpipelined (CudaHapticTicks sets MeshDev::pipeline off): a sample's contact needs
// its triangle's three corners, which a pipelined step's vertex blocks do not have at the Newton
// call's new pose. A step is
//   vertices   per vertex (vertex_step<false, true>): begin, the E_con targets of its triangles'
//              samples inside the tool, the Jacobi step, end; then an arrival (MeshDev::sync)
//   triangles  once every vertex block's iterate is written (the blocks wait for each other's
//              arrivals): per triangle, whether the next Newton call can reach it and (last step)
//              its deepest sample in the physical tool (triangle_step); then an arrival
//              (SurfaceDev::arrive)
//   tool       block 0: the held vertices and the candidate triangles in a fixed order, their
//              reachable samples (surface_lists), the Newton call on them (virtual_tool_tail<true>).
#include <cuda_runtime.h>

#include "schedule/haptic_cuda_handoff.cuh"
#include "schedule/haptic_cuda_layout.cuh"
#include "schedule/haptic_cuda_profile.cuh"
#include "schedule/haptic_cuda_surface.cuh"
#include "schedule/haptic_cuda_tool.cuh"
#include "schedule/haptic_cuda_vertices.cuh"

namespace ebh {
namespace {

/// Steps done (all runs) after step s: the count SurfaceDev::arrive reaches per vertex block.
__device__ unsigned long long steps_through(const Schedule& S, int s) {
  return S.K == 1 ? (S.epoch(s) + 1) / 2 : S.epoch(s);
}

/// One unpipelined step of chunk c with surface contact (vertex_chunk's lists: list 1 the held
/// vertices; block_counts[4 c + 2] the E_con targets' count; no candidates or depth here).
__device__ void surface_vertex_chunk(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, bool first,
                                     bool last, bool p_ready, int c, const Vec3f* __restrict__ qin,
                                     Vec3f* __restrict__ qout, Vec3f* __restrict__ v_out, BlockShared& sm,
                                     BlockClock& clock) {
  const int j = c * kBlock + threadIdx.x;
  VertexFlags f;
  DeferredVertex unused;
  if (j < d.m)
    f = vertex_step<false, true>(d, t, sm.posed(), sm.physical(), sm.in(), first, last, j, qin, qout, v_out, unused,
                                 p_ready, &sd);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  const unsigned below = (1u << lane) - 1u;
  const unsigned b1 = __ballot_sync(~0u, f.list1);
  int targets = f.targets;
  for (int o = 16; o > 0; o >>= 1) targets += __shfl_xor_sync(~0u, targets, o);
  if (lane == 0) {
    sm.warp_counts[warp][1] = __popc(b1);
    sm.warp_counts[warp][2] = targets;
  }
  __syncthreads();
  clock.chunk_vertices_done();
  int o1 = 0;
  for (int w = 0; w < warp; ++w) o1 += sm.warp_counts[w][1];
  if (f.list1) d.block_held[c * kBlock + o1 + __popc(b1 & below)] = j;
  if (threadIdx.x == 0) {
    int c1 = 0, cc = 0;
    for (int w = 0; w < kWarps; ++w) { c1 += sm.warp_counts[w][1]; cc += sm.warp_counts[w][2]; }
    int* bcnt = d.block_counts + 4 * c;
    bcnt[0] = 0; bcnt[1] = c1; bcnt[2] = cc; bcnt[3] = 0;
  }
  __syncthreads();  // warp_counts are reused by the next chunk
}

/// Triangle chunk c after a step (triangle_step per thread): its candidate triangles in triangle
/// order (sd.list) and their count and deepest physical-tool depth (sd.counts[2 c ..]).
__device__ void triangle_chunk(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, bool called, bool last,
                               int c, const Vec3f* q, BlockShared& sm) {
  const int f = c * kBlock + threadIdx.x;
  bool candidate = false;
  float pen = 0.f;
  if (f < sd.F) triangle_step(d, sd, t, sm.posed(), sm.physical(), called, last, f, q, candidate, pen);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  const unsigned below = (1u << lane) - 1u;
  const unsigned b0 = __ballot_sync(~0u, candidate);
  unsigned pen_bits = __float_as_uint(pen);  // pen >= 0: the bits order as the values
  for (int o = 16; o > 0; o >>= 1) pen_bits = max(pen_bits, __shfl_xor_sync(~0u, pen_bits, o));
  if (lane == 0) {
    sm.warp_counts[warp][0] = __popc(b0);
    sm.warp_pen[warp] = pen_bits;
  }
  __syncthreads();
  int o0 = 0;
  for (int w = 0; w < warp; ++w) o0 += sm.warp_counts[w][0];
  if (candidate) sd.list[c * kBlock + o0 + __popc(b0 & below)] = f;
  if (threadIdx.x == 0) {
    int c0 = 0;
    unsigned pm = 0;
    for (int w = 0; w < kWarps; ++w) { c0 += sm.warp_counts[w][0]; pm = max(pm, sm.warp_pen[w]); }
    sd.counts[2 * c] = c0;
    sd.counts[2 * c + 1] = static_cast<int>(pm);
  }
  __syncthreads();
}

/// The vertex blocks with surface contact (vertex_blocks' loop, every step unpipelined): each step,
/// once released, the vertices of their chunks at the pose of the step's slot; once every block's
/// vertices are done, the triangles of their chunks at the new iterates (when a Newton call or
/// the tick's end follows); then the E_svc targets ahead, the q snapshots of a launch across
/// periods and (K = 1) the copy phase, as vertex_blocks does.
__device__ void surface_vertex_blocks(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Schedule& S,
                                      int steps, BlockShared& sm) {
  const int blocks = gridDim.x - 1;
  bool p_ready = false;  // the step's E_svc targets blended ahead
  for (int s = 0; s < steps; ++s) {
    const unsigned long long e = S.epoch(s);
    const bool first = S.first(s), last = S.last(s), called = S.called(s);
    {  // what does not depend on the virtual tool, before the release
      const DeviceTickInput& gin = S.input(s);
      if (threadIdx.x == 0) sm.in() = gin;
      if (last) pose_colliders(t, gin.position, gin.orientation, gin, sm.physical());
    }
    if (threadIdx.x == 0)
      while (load_acquire(&d.sync->release) < e) {}
    __syncthreads();
    BlockClock clock(d.profile);
    clock.released();
    if (threadIdx.x < t.count) {
      const SlotPose slot = d.slots[s & 1];
      pose_collider(t, slot.P, slot.Q, sm.in().jaw_cos, sm.in().jaw_sin, threadIdx.x, sm.posed());
    }
    __syncthreads();
    clock.posed();
    for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
      clock.chunk_begin();
      surface_vertex_chunk(d, sd, t, first, last, p_ready, c, S.in(s), S.out(s), S.v_out(), sm, clock);
      clock.chunk_end();
    }
    clock.report(d.profile, s);
    __syncthreads();
    if (threadIdx.x == 0) add_release(&d.sync->arrive, 1ull);
    if (called || last) {  // the triangles, at every vertex's new iterate
      if (threadIdx.x == 0)
        while (load_acquire(&d.sync->arrive) < e * static_cast<unsigned long long>(blocks)) {}
      __syncthreads();
      for (int c = blockIdx.x - 1; c < sd.chunks; c += blocks) triangle_chunk(d, sd, t, called, last, c, S.out(s), sm);
      __syncthreads();
    }
    if (threadIdx.x == 0) add_release(sd.arrive, 1ull);
    // As vertex_blocks: a tick that starts a physical period k > 0 hands its start q to step k.
    if (d.period > 0 && first && S.tick(s) > 0 && S.tick(s) % d.period == 0) {
      const Vec3f* q = S.in(s);
      for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
        const int j = c * kBlock + threadIdx.x;
        if (j < d.m) d.snap_q[j] = q[j];
      }
      __syncthreads();
      if (threadIdx.x == 0) add_release(&d.steps->snapped, 1ull);
    }
    // As vertex_blocks: the next tick's E_svc targets of this block's vertices.
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
    if (S.K == 1) {  // the copy phase, as vertex_blocks
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
      if (threadIdx.x == 0) add_release(&d.sync->arrive, 1ull);
    }
  }
}

/// Candidate triangle i of the chunks' lists (sd.offsets, block 0's scan).
__device__ int candidate_triangle(const SurfaceDev& sd, int i) {
  int lo = 0, hi = sd.chunks - 1;
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;
    if (sd.offsets[mid] <= i) lo = mid; else hi = mid - 1;
  }
  return sd.list[lo * kBlock + (i - sd.offsets[lo])];
}

/// Block 0 after a step of q with surface contact: the held vertices (unpipelined_lists), the
/// step's target count and deepest physical-tool depth (its triangles' on the last step), and
/// (called) the Newton call's candidates: the reachable samples of the candidate triangles in
/// triangle order, each triangle's in for_each_sample's (their points in TailShared::cand and
/// d.cand_q, their weights in sd.cand_w; at most sd.capacity, past it sd.overflow is set).
__device__ void surface_lists(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& pt,
                              const Vec3f* q, bool called, bool last, TailShared& sh) {
  int n0 = 0, n1 = 0;
  const int* off = chunk_offsets(d, sh, n0, n1);  // the held vertices' offsets; sh.contacts
  for (int i = threadIdx.x; i < n1; i += kBlock) {  // as unpipelined_lists
    const int j = list_item(d, off + d.chunks + 1, d.block_held, i);
    d.held_slot[j] = i < kCache ? i : -1;
    if (i < kCache) {
      sh.held_local[i] = d.grasp_local[j];
      sh.held_q[i] = static_cast<Vec3d>(q[j]);
    } else {
      d.held_list[i] = j;
    }
  }
  if (!(called || last)) {
    if (threadIdx.x == 0) { sh.nc = 0; sh.nh = n1; }
    __syncthreads();
    return;
  }
  // The triangle chunks' offsets (exclusive scan of their counts) and deepest depth.
  const int per = (sd.chunks + kBlock - 1) / kBlock, c0 = threadIdx.x * per, c1 = min(c0 + per, sd.chunks);
  int sum = 0;
  unsigned pen = 0;
  for (int c = c0; c < c1; ++c) {
    sum += sd.counts[2 * c];
    pen = max(pen, static_cast<unsigned>(sd.counts[2 * c + 1]));
  }
  for (int o = 16; o > 0; o >>= 1) pen = max(pen, __shfl_xor_sync(~0u, pen, o));
  if ((threadIdx.x & 31) == 0) atomicMax(&sh.pen_bits, pen);  // integers: the same in any order
  int o0 = 0, ob = 0, nt = 0, tb = 0;
  block_exclusive_scan(sum, 0, o0, ob, nt, tb);  // synchronises the block
  for (int c = c0; c < c1; ++c) {
    sd.offsets[c] = o0;
    o0 += sd.counts[2 * c];
  }
  if (threadIdx.x == 0) sd.offsets[sd.chunks] = nt;
  __syncthreads();
  // The candidate samples, a round of kBlock triangles at a time: count, scan, write.
  int base = 0;
  if (called) {
    for (int r = 0; r < nt; r += kBlock) {
      const int i = r + threadIdx.x;
      int4 tri{};
      int count = 0;
      if (i < nt) {
        tri = sd.tri[candidate_triangle(sd, i)];
        count = reachable_samples(sd, t, pt, tri, q, [](int, Vec3d, double) {});
      }
      int e = 0, eb = 0, total = 0, tb2 = 0;
      block_exclusive_scan(count, 0, e, eb, total, tb2);
      if (count > 0)
        reachable_samples(sd, t, pt, tri, q, [&](int k, Vec3d y, double w) {
          const int at = base + e + k;
          if (at >= sd.capacity) return;
          if (at < kCache) sh.cand[at] = y; else d.cand_q[at] = y;
          sd.cand_w[at] = w;
        });
      base += total;
    }
  }
  if (threadIdx.x == 0) {
    if (base > sd.capacity) *sd.overflow = 1;
    sh.nc = min(base, sd.capacity);
    sh.nh = n1;
  }
  __syncthreads();
}

/// Block 0 with surface contact (tool_block's unpipelined steps): per step, the tool posed and
/// its pose published, the step released, every vertex block's triangles waited for, the lists
/// (surface_lists), and the Newton call when one follows the step.
__device__ void surface_tool_block(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Schedule& S,
                                   int steps, BlockShared& sm) {
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
  auto release = [&](unsigned long long e, int s) {  // tool_block's
    if (threadIdx.x == kReleaseThread) {
      if (s >= 0) d.slots[s & 1] = SlotPose{sh.P, sh.Q};
      profile_release(d.profile, s);
      store_release(&d.sync->release, e);
    }
  };
  auto wait_for = [&](const unsigned long long* counter, unsigned long long target, int s) {
    __syncthreads();
    if (threadIdx.x == 0)
      while (load_acquire(counter) < target) {}
    profile_arrivals(d.profile, s);
    __syncthreads();
    marks.mark(DeviceTickProfile::Wait);
  };
  for (int s = 0; s < steps; ++s) {
    const DeviceTickInput& gin = S.input(s);
    if (threadIdx.x == 0) sm.in() = gin;
    pose_colliders(t, sh.P, sh.Q, gin, pt);
    __syncthreads();
    release(S.epoch(s), s);
    marks.mark(DeviceTickProfile::Lists);
    wait_for(sd.arrive, steps_through(S, s) * others, s);
    surface_lists(d, sd, t, pt, S.out(s), S.called(s), S.last(s), sh);
    if (S.K == 1) release(S.epoch(s) + 1, -1);  // the copy phase (the Newton call reads neither q0 nor v)
    marks.count_unpipelined();
    marks.mark(DeviceTickProfile::Lists);
    if (S.called(s))
      virtual_tool_tail<true>(d, t, sm.in(), S.tick(s), S.out(s), S.last(s), pt, sh, marks, sd.cand_w);
    if (s + 1 < steps && S.K == 1) wait_for(&d.sync->arrive, (S.epoch(s) + 1) * others, -1);  // the copies
  }
  marks.end(d.profile, steps);
}

/// ticks_kernel with surface contact: one run of `count` ticks from tick `tick0` as one cooperative
/// launch (block 0 the virtual tool, the others the virtual mesh and its triangles).
__global__ void __launch_bounds__(kBlock)
    surface_ticks_kernel(MeshDev d, ToolConst t, SurfaceDev sd, int count, long long tick0, unsigned long long epoch0) {
  __shared__ BlockShared sm;
  const Schedule S(d, tick0, epoch0);
  if (blockIdx.x == 0) surface_tool_block(d, sd, t, S, count * d.iterations, sm);
  else surface_vertex_blocks(d, sd, t, S, count * d.iterations, sm);
}

}  // namespace

const void* surface_ticks_kernel_entry() { return reinterpret_cast<const void*>(surface_ticks_kernel); }

}  // namespace ebh
