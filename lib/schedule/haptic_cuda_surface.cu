// The device haptic tick with surface contact (surface_ticks_kernel; haptic_cuda_surface.cuh has
// the per-vertex and per-triangle parts; docs/CUDA.md, "Surface contact"): the vertex blocks' and
// block 0's loops over a run's steps, and the kernel. A translation unit of its own beside
// haptic_cuda.cu (which launches it), built from the same parts, so that the vertex-contact
// kernel there compiles as it did without it.
//
// Every step is unpipelined (CudaHapticTicks sets MeshDev::pipeline off): a sample's contact needs
// its triangle's three corners, which a pipelined step's vertex blocks do not have at the Newton
// call's new pose. A step is
//   contacts   when a Newton call followed the step before: the call's contact list's
//              triangles, a warp each over the vertex blocks, their samples against the tool
//              posed for the step and their targets summed per corner (listed_triangle_sums); then
//              the blocks wait for each other (SurfaceDev::summed)
//   vertices   per vertex (vertex_step<false, true>): begin, the E_con targets of its triangles'
//              samples inside the tool (their sums from the list, or its own tests without one),
//              the Jacobi step, end; then an arrival (MeshDev::sync)
//   triangles  once every vertex block's iterate is written (the blocks wait for each other's
//              arrivals): per triangle, whether the next Newton call or the contact list needs it
//              and (last step) whether it may reach into the physical tool (triangle_step), then
//              the listed triangles' samples tested over a warp's lanes (listed_sample_masks)
//              and the deep ones' deepest samples, a warp's in one sequence (deepest_in_warp); then
//              an arrival (SurfaceDev::arrive)
//   tool       block 0: the held vertices and the listed triangles in a fixed order, their listed
//              samples (from the tests' bits; a large triangle's tested here) one per thread into
//              the Newton call's candidates and the next step's contact list (surface_lists,
//              list_samples), the Newton call on the candidates (virtual_tool_tail<true>).
#include <cuda_runtime.h>

#include "schedule/haptic_cuda_handoff.cuh"
#include "schedule/haptic_cuda_layout.cuh"
#include "schedule/haptic_cuda_profile.cuh"
#include "schedule/haptic_cuda_surface.cuh"
#include "schedule/haptic_cuda_tool.cuh"
#include "schedule/haptic_cuda_vertices.cuh"

namespace ebh {
namespace {

/// The contact list step s's vertices read (surface_contact_target's `listed`): that of the step
/// before when a Newton call followed it (list_samples; on a launch's first step, the last step of
/// the launch before), 0 (none: every sample near the tool is tested) on a replay's first step, on a grasp event's (which changes the held
/// vertices, whose triangles the list leaves out), and without lists (SurfaceDev::lists).
__device__ unsigned long long contact_list_of(const SurfaceDev& sd, const Schedule& S, int s) {
  if (!sd.lists || (S.first(s) && S.input(s).grasp != 0)) return 0;
  // A launch's first step follows the last step of the launch before (epochs run on across
  // launches, Schedule::epoch), if there was one.
  if (s == 0) return S.epoch0;
  return S.called(s - 1) ? S.epoch(s - 1) : 0;
}

/// One unpipelined step of chunk c with surface contact (vertex_chunk's lists: list 1 the held
/// vertices; block_counts[4 c + 2] the E_con targets' count; no candidates or depth here).
__device__ void surface_vertex_chunk(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, bool first,
                                     bool last, bool p_ready, unsigned long long listed, int c,
                                     const Vec3f* __restrict__ qin, const Vec3f* v_in,
                                     Vec3f* __restrict__ qout, Vec3f* __restrict__ v_out, BlockShared& sm,
                                     BlockClock& clock) {
  const int j = c * kBlock + threadIdx.x;
  VertexFlags f;
  DeferredVertex unused;
  if (j < d.m)
    f = vertex_step<false, true>(d, t, sm.posed(), sm.physical(), sm.in(), first, last, j, qin, v_in, qout, v_out, unused,
                                 p_ready, &sd, listed);
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

/// Triangle chunk c after a step (triangle_step per thread): its listed triangles in triangle
/// order (sd.list; kContactOnly on those the Newton call cannot reach), their samples' flags
/// (listed_sample_masks) and their count and deepest physical-tool depth (sd.counts[2 c ..]).
__device__ void triangle_chunk(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, bool called, bool last,
                               int c, const Vec3f* q, const Vec3f* v, BlockShared& sm) {
  const int f = c * kBlock + threadIdx.x;
  bool candidate = false, listed = false, deep = false;
  if (f < sd.F) triangle_step(d, sd, t, sm.posed(), sm.physical(), called, last, f, q, v, candidate, listed, deep);
  listed_sample_masks(d, sd, t, sm.posed(), q, v, last, f, listed, candidate);
  const float pen = deepest_in_warp(sd, t, sm.physical(), q, f, deep);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  const unsigned below = (1u << lane) - 1u;
  const unsigned b0 = __ballot_sync(~0u, listed);
  if (lane == 0) {
    sm.warp_counts[warp][0] = __popc(b0);
    sm.warp_pen[warp] = __float_as_uint(pen);  // pen >= 0: the bits order as the values
  }
  __syncthreads();
  int o0 = 0;
  for (int w = 0; w < warp; ++w) o0 += sm.warp_counts[w][0];
  if (listed) sd.list[c * kBlock + o0 + __popc(b0 & below)] = candidate ? f : (f | kContactOnly);
  if (threadIdx.x == 0) {
    int c0 = 0;
    unsigned pm = 0;
    for (int w = 0; w < kWarps; ++w) { c0 += sm.warp_counts[w][0]; pm = max(pm, sm.warp_pen[w]); }
    sd.counts[2 * c] = c0;
    sd.counts[2 * c + 1] = static_cast<int>(pm);
  }
  __syncthreads();
}

/// Listed triangle i of the contact list (contact_list_of) before a step's vertices, by one warp:
/// its listed samples against the tool posed for the step at the step's iterates qin (their
/// starts x + h v on a tick's first step), over the lanes, then its corners' sums of their targets
/// (sum of w k_con b_c (q_c + y_proj - y) and of w k_con b_c) and their count, reduced over the
/// lanes in a fixed order (sd.tri_sum, tri_map's w). A triangle whose rows changed since the list
/// (stretched by the start's h v) gets tri_map's z = 0: its vertices then sum its samples themselves.
__device__ void listed_triangle_sums(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& posed,
                                     const Vec3f* qin, const Vec3f* v_in, bool first, int i) {
  const int lane = threadIdx.x & 31;
  const int f = sd.listed[i].f;
  const int4 tri = sd.tri[f], m = sd.tri_map[f];
  const Vec3d x[3] = {static_cast<Vec3d>(iterate_of(d, qin, v_in, first, tri.x)),
                      static_cast<Vec3d>(iterate_of(d, qin, v_in, first, tri.y)),
                      static_cast<Vec3d>(iterate_of(d, qin, v_in, first, tri.z))};
  const int n = surface_sample_level(tri.w, sd.spacing, x[0], x[1], x[2]);
  if (n != m.z) {
    if (lane == 0) sd.tri_map[f].z = 0;
    return;
  }
  const double kw = t.k_con * surface_sample_weight(sd.stiffness_factor, sd.spacing, n, x[0], x[1], x[2]);
  double sum[3][4] = {};  // per corner: the targets' sum (xyz), the stiffnesses' (w)
  int count = 0;
  for (int k = m.x + lane; k < m.y; k += 32) {
    double b[3];
    sample_barycentric(n, sd.contact[k].y, b[0], b[1], b[2]);
    Vec3d to;
    if (!sample_contact(t, posed, surface_sample_point(b[0], b[1], b[2], x[0], x[1], x[2]), to)) continue;
    for (int c = 0; c < 3; ++c) {
      const double kb = kw * b[c];
      const Vec3d target = kb * (x[c] + to);
      sum[c][0] += target.x;
      sum[c][1] += target.y;
      sum[c][2] += target.z;
      sum[c][3] += kb;
    }
    ++count;
  }
  for (int o = 16; o > 0; o >>= 1) {
    for (int c = 0; c < 3; ++c)
      for (int u = 0; u < 4; ++u) sum[c][u] += __shfl_xor_sync(~0u, sum[c][u], o);
    count += __shfl_xor_sync(~0u, count, o);
  }
  if (lane == 0) {
    for (int c = 0; c < 3; ++c) sd.tri_sum[3 * f + c] = SampleSum{sum[c][0], sum[c][1], sum[c][2], sum[c][3]};
    sd.tri_map[f].w = count;
  }
}

/// The vertex blocks with surface contact (vertex_blocks' loop, every step unpipelined): each step,
/// once released, the vertices of their chunks at the pose of the step's slot; once every block's
/// vertices are done, the triangles of their chunks at the new iterates (when a Newton call or
/// the tick's end follows); then the E_svc targets ahead and the q snapshots of a launch across
/// periods, as vertex_blocks does.
__device__ void surface_vertex_blocks(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Schedule& S,
                                      int steps, BlockShared& sm) {
  const int blocks = gridDim.x - 1;
  bool p_ready = false;  // the step's E_svc targets blended ahead
  for (int s = 0; s < steps; ++s) {
    const unsigned long long e = S.epoch(s);
    const bool first = S.first(s), last = S.last(s), called = S.called(s);
    const unsigned long long listed = contact_list_of(sd, S, s);
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
    // The contact list's triangles, a warp each over every vertex block, then a wait for all.
    // (An empty list has no sums to wait for; every block reads the same count.)
    const int nt = listed ? *sd.listed_count : 0;
    if (nt > 0) {
      const int warps = blocks * kWarps;
      for (int i = (blockIdx.x - 1) * kWarps + (threadIdx.x >> 5); i < nt; i += warps)
        listed_triangle_sums(d, sd, t, sm.posed(), S.in(s), S.v_in(s), first, i);
      __syncthreads();
    }
    if (threadIdx.x == 0) {
      add_release(sd.summed, 1ull);
      if (nt > 0)
        while (load_acquire(sd.summed) < S.epoch(s) * static_cast<unsigned long long>(blocks)) {}
    }
    __syncthreads();
    clock.posed();
    for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
      clock.chunk_begin();
      surface_vertex_chunk(d, sd, t, first, last, p_ready, listed, c, S.in(s), S.v_in(s), S.out(s), S.v_out(s), sm, clock);
      clock.chunk_end();
    }
    __syncthreads();
    clock.chunks_arrived();
    if (threadIdx.x == 0) add_release(&d.sync->arrive, 1ull);
    if (called || last) {  // the triangles, at every vertex's new iterate
      if (threadIdx.x == 0)
        while (load_acquire(&d.sync->arrive) < e * static_cast<unsigned long long>(blocks)) {}
      __syncthreads();
      clock.triangles_begin();
      for (int c = blockIdx.x - 1; c < sd.chunks; c += blocks) triangle_chunk(d, sd, t, called, last, c, S.out(s), S.v_out(s), sm);
      __syncthreads();
      clock.triangles_end();
    }
    clock.report(d.profile, s);  // before the arrival block 0 reads the step's slowest blocks at
    if (threadIdx.x == 0) add_release(sd.arrive, 1ull);
    p_ready = step_handoffs(d, S, s, steps);
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

/// The position of the (j + 1)-th set bit of `bits` (it has more than j).
__device__ int nth_set_bit(unsigned long long bits, int j) {
  const unsigned lo = static_cast<unsigned>(bits), hi = static_cast<unsigned>(bits >> 32);
  const int below = __popc(lo);
  return j < below ? static_cast<int>(__fns(lo, 0, j + 1)) : 32 + static_cast<int>(__fns(hi, 0, j - below + 1));
}

/// Block 0, a Newton call following the step with epoch `epoch`: the samples of the chunks' nt
/// listed triangles at q, in triangle order, each triangle's in for_each_sample's, a thread per
/// sample (of a triangle the triangle pass tested, per sample of its list: its flags from
/// SurfaceDev::tri_masks; of a larger one, per sample: sample_flags):
///   the Newton call's candidates: those of its candidate triangles (not kContactOnly) that it can
///     reach (reachable); their points in TailShared::cand and d.cand_q, their weights in sd.cand_w;
///   the next step's contact list: those it can reach at q or, after a tick's last step, anywhere
///     within their triangle's start_shift (v: the velocities after the step); in sd.contact,
///     each triangle's range and rows in sd.tri_map, stamped with `epoch` in sd.tri_stamp.
/// At most sd.capacity of each (past it sd.overflow is set). Returns the candidates' count.
__device__ int list_samples(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& pt,
                            const Vec3f* q, const Vec3f* v, bool last, unsigned long long epoch, int nt,
                            TailShared& sh) {
  // The listed triangles: rows, weight, shift, and the samples before each (a scan of n^2).
  int total = 0;
  for (int r = 0; r < nt; r += kBlock) {
    const int i = r + threadIdx.x;
    int count = 0;
    ListedTriangle lt{};
    if (i < nt) {
      const int entry = candidate_triangle(sd, i);
      lt.f = entry & ~kContactOnly;
      lt.newton = (entry & kContactOnly) == 0;
      const int4 tri = sd.tri[lt.f];
      lt.a = q[tri.x];
      lt.b = q[tri.y];
      lt.c = q[tri.z];
      const Vec3d a = static_cast<Vec3d>(lt.a), b = static_cast<Vec3d>(lt.b), c = static_cast<Vec3d>(lt.c);
      lt.n = surface_sample_level(tri.w, sd.spacing, a, b, c);
      lt.w = surface_sample_weight(sd.stiffness_factor, sd.spacing, lt.n, a, b, c);
      lt.shift = last ? start_shift(d, tri, q, v) : 0.f;
      // A triangle the triangle pass tested: the samples of its list (a superset of its
      // candidates); a larger one: every sample, tested below.
      if (lt.n * lt.n <= sd.masked_samples) {
        lt.masks = sd.tri_masks[lt.f];
        count = __popcll(lt.masks.y);
      } else {
        count = lt.n * lt.n;
      }
      sd.tri_map[lt.f] = make_int4(0, 0, lt.n, 0);
      sd.tri_stamp[lt.f] = epoch;
      sd.vertex_stamp[tri.x] = sd.vertex_stamp[tri.y] = sd.vertex_stamp[tri.z] = epoch;
    }
    int e = 0, unused = 0, sum = 0, unused_total = 0;
    block_exclusive_scan(count, 0, e, unused, sum, unused_total);
    if (i < nt) {
      lt.base = total + e;
      sd.listed[i] = lt;
      for (int g = lt.base, end = min(lt.base + count, sd.capacity); g < end; ++g) sd.sample_listed[g] = i;
    }
    total += sum;
  }
  if (total > sd.capacity) {  // as a list past its capacity
    if (threadIdx.x == 0) *sd.overflow = 1;
    total = sd.capacity;
  }
  __syncthreads();
  // The samples, kBlock at a time: test, scan, write. The tests are float with slack, so the
  // point is float here (its round-off, ~1e-7 m on tool-sized coordinates, far inside the slack),
  // and double for the candidates only. (Several consecutive samples per thread and round, one
  // scan for more of them, were slower: block 0's four warps are bound by each sample's latency,
  // not by the scans.)
  int nc = 0, nl = 0;
  for (int r = 0; r < total; r += kBlock) {
    const int g = r + threadIdx.x;
    bool cand = false, listed = false;
    int f = 0, k = 0, n = 0;
    double w = 0;
    Vec3f ca, cb, cc;
    if (g < total) {
      const ListedTriangle lt = sd.listed[sd.sample_listed[g]];
      f = lt.f;
      k = g - lt.base;
      n = lt.n;
      w = lt.w;
      ca = lt.a;
      cb = lt.b;
      cc = lt.c;
      if (n * n <= sd.masked_samples) {  // the k-th sample of its list
        k = nth_set_bit(lt.masks.y, k);
        cand = (lt.masks.x >> k) & 1ull;
        listed = true;
      } else {
        sample_flags(t, pt, n, k, ca, cb, cc, lt.newton, lt.shift, cand, listed);
      }
    }
    int ec = 0, el = 0, tc = 0, tl = 0;
    block_exclusive_scan(cand, listed, ec, el, tc, tl);
    if (cand && nc + ec < sd.capacity) {
      const int at = nc + ec;
      double b0, b1, b2;
      sample_barycentric(n, k, b0, b1, b2);
      const Vec3d y = surface_sample_point(b0, b1, b2, static_cast<Vec3d>(ca), static_cast<Vec3d>(cb),
                                           static_cast<Vec3d>(cc));
      if (at < kCache) sh.cand[at] = y; else d.cand_q[at] = y;
      sd.cand_w[at] = w;
    }
    if (listed && nl + el < sd.capacity) sd.contact[nl + el] = make_int2(f, k);
    nc += tc;
    nl += tl;
  }
  __syncthreads();
  // Each listed triangle's range of the contact list.
  const int n = min(nl, sd.capacity);
  for (int i = threadIdx.x; i < n; i += kBlock) {
    const int f = sd.contact[i].x;
    if (i == 0 || sd.contact[i - 1].x != f) sd.tri_map[f].x = i;
    if (i + 1 == n || sd.contact[i + 1].x != f) sd.tri_map[f].y = i + 1;
  }
  if (threadIdx.x == 0) {
    if (nc > sd.capacity || nl > sd.capacity) *sd.overflow = 1;
    *sd.listed_count = nt;
  }
  return nc;
}

/// Block 0 after the step with epoch `epoch` of q with surface contact: the held vertices
/// (unpipelined_lists), the step's target count and deepest physical-tool depth (its triangles' on
/// the last step), and (called) the Newton call's candidates and the next step's contact list
/// (list_samples; v: the velocities after the step).
__device__ void surface_lists(const MeshDev& d, const SurfaceDev& sd, const ToolConst& t, const Posed& pt,
                              const Vec3f* q, const Vec3f* v, bool called, bool last, unsigned long long epoch,
                              TailShared& sh, TailMarks& marks) {
  int n0 = 0, n1 = 0;
  const int* off = chunk_offsets(d, sh, n0, n1);  // the held vertices' offsets; sh.contacts
  gather_held(d, off, n1, q, sh);
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
  marks.mark(DeviceTickProfile::Lists);
  const int base = called ? list_samples(d, sd, t, pt, q, v, last, epoch, nt, sh) : 0;
  marks.mark(DeviceTickProfile::Samples);
  if (threadIdx.x == 0) {
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
  load_tool_state(d, sh);
  auto release = [&](unsigned long long e, int s) {  // tool_block's
    if (threadIdx.x == kReleaseThread) {
      d.slots[s & 1] = SlotPose{sh.P, sh.Q};
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
    if (contact_list_of(sd, S, s)) marks.count_listed();
    release(S.epoch(s), s);
    marks.mark(DeviceTickProfile::Lists);
    wait_for(sd.arrive, S.epoch(s) * others, s);  // steps done through s, per vertex block
    surface_lists(d, sd, t, pt, S.out(s), S.v_out(s), S.called(s), S.last(s), S.epoch(s), sh, marks);
    marks.count_unpipelined();
    marks.mark(DeviceTickProfile::Lists);
    if (S.called(s))
      virtual_tool_tail<true>(d, t, sm.in(), S.tick(s), S.out(s), S.last(s), pt, sh, marks, sd.cand_w);
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
