#pragma once
// The device haptic tick's vertex side (part of haptic_cuda.cu's translation unit): one thread
// per virtual vertex and step (vertex_step: begin, contact, Jacobi iteration, end, reach), the
// steps a pipelined step leaves to block 0 (finish_deferred), the active region's sleeping
// chunks (chunk_awake, sleeping_vertex, settle_chunk), a chunk's lists, and the vertex blocks'
// loop over a run's steps.
#include "energy/edge_spring.hpp"
#include "energy/quadratic.hpp"
#include "schedule/haptic_cuda_handoff.cuh"
#include "schedule/haptic_cuda_posed.cuh"
#include "schedule/haptic_cuda_surface.cuh"
#include "solver/region_rules.hpp"
#include "solver/virtual_jacobi.hpp"
#include "tool/tool_terms.hpp"

namespace ebh {
namespace {

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

/// Vertex j's E_svc target for this tick (its first step): blended ahead by its block (p_ready,
/// vertex_blocks) or now, into d.p.
__device__ Vec3f tick_target(const MeshDev& d, const DeviceTickInput& in, int j, bool p_ready) {
  if (p_ready) return d.p[j];
  const Vec3f p = blended_paired_point(d, d.x_prev, d.x_vis, j, static_cast<float>(in.alpha));
  d.p[j] = p;
  return p;
}

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
/// kDepth = false (surface contact): no depth here, the triangles' samples give it (triangle_step).
template <bool kDepth = true>
__device__ void vertex_end(const MeshDev& d, const ToolConst& t, const Posed& physical, bool last, int j, bool held,
                           Vec3f qn, Vec3f q_start, Vec3f* qout, Vec3f* v_out, VertexFlags& f) {
  qout[j] = qn;
  f.q = qn;
  if (last) {
    v_out[j] = d.v_scale * (qn - q_start);  // Alg. 2 line 23, damped (tick_velocity_scale)
    if constexpr (!kDepth) return;
    const unsigned near = held ? 0u : near_colliders(t, physical, qn, kFloatSlack);
    if (near) f.pen = static_cast<float>(penetration(t, physical, static_cast<Vec3d>(qn), near));
  }
}

/// -dE_s/dq [4] of vertex j's `degree` incident edges (edge_ell, in their order) added to r, an
/// edge's ends at at(a); it0: the first kEdgeChunk edge items, loaded. In chunks of kEdgeChunk,
/// every load of a chunk issued before its math (one thread per vertex: the loads' latency, not
/// the arithmetic, bounds this loop).
template <class At>
__device__ void add_edge_residuals(const MeshDev& d, int j, int degree, const int4 (&it0)[kEdgeChunk], At at, Vec3f& r) {
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
///   v_in, v_out: the velocities a tick's first step reads and its last step writes (Schedule); the
///     same array at more than one iteration a tick, so v_in is not __restrict__.
///   kSurface (surface contact, unpipelined steps only): the contact is that of the samples of j's
///     triangles (surface_contact_target, with `surface` and its contact list `listed`); list0 stays empty (the candidates are
///     triangles: triangle_step), f.targets counts the targets, and the depth is the triangles'.
template <bool kAhead, bool kSurface = false>
__device__ VertexFlags vertex_step(const MeshDev& d, const ToolConst& t, const Posed& posed, const Posed& physical,
                                   const DeviceTickInput& in, bool first, bool last, int j,
                                   const Vec3f* __restrict__ qin, const Vec3f* v_in, Vec3f* __restrict__ qout,
                                   Vec3f* __restrict__ v_out, DeferredVertex& deferred_out, bool p_ready,
                                   const SurfaceDev* surface = nullptr, unsigned long long listed = 0) {
  static_assert(!(kAhead && kSurface), "surface contact runs unpipelined steps");
  VertexFlags f;
  const bool pinned = d.model.pinned[j];
  const Vec3f q_in = qin[j];
  // The loads that depend on j alone, issued before any branch: in the branches below, each would
  // wait for the one before it (pinned, then the degree, then the edge items, then their ends).
  const int degree = d.model.edge_offsets[j + 1] - d.model.edge_offsets[j];
  const float mass = d.model.mass[j], stiff = d.model.stiff_diag[j];
  int4 it0[kEdgeChunk];  // the first chunk of edge items: every row of edge_ell has one
#pragma unroll
  for (int u = 0; u < kEdgeChunk; ++u) it0[u] = __ldg(&d.edge_ell[u * d.m + j]);
  Vec3f s, p, q0 = q_in;  // q0: the tick's first iterate, x + h v (iteration_start)
  if (first) {  // Alg. 2 lines 1 and 6; §5.2 grasp at the jaws' closing, release at the opening
    d.q_start[j] = q_in;
    s = pinned ? q_in : predict_position(q_in, v_in[j], d.gravity, d.h);
    q0 = pinned ? q_in : iteration_start(q_in, v_in[j], d.h);
    p = tick_target(d, in, j, p_ready);
    d.s[j] = s;
    if (!kAhead && in.grasp < 0) {
      d.held[j] = 0;
    } else if (!kAhead && in.grasp > 0) {
      const Collider<double>& hb = d.grasp_boxes[in.grasp - 1];
      const Vec3d ls = apply_inverse(posed.frame, static_cast<Vec3d>(q0));
      const double sd = signed_distance_local(hb, ls);
      const bool grasp = grasp_reaches(sd, t.soft_margin);
      if (grasp) d.grasp_local[j] = grasp_point(hb, ls, sd, t.soft_margin, t.eta).local;  // eq. [10]
      d.held[j] = grasp;
    }
  } else {
    s = d.s[j];
    p = d.p[j];
  }
  const Vec3f q = first ? q0 : q_in;  // this iteration's iterate
  const bool held = d.held[j];
  Vec3f kt{};
  float ck = 0.f;
  if constexpr (kSurface) {
    if (held) {
      grasp_target(t, posed, d.grasp_local[j], kt, ck);
      f.targets = 1;
    } else {
      f.targets = surface_contact_target(d, *surface, t, posed, in, first, j, q, qin, v_in, listed, kt, ck);
    }
    f.contact = f.targets > 0;
  } else if (!kAhead) {
    f.contact = contact_target(d, t, posed, j, q, held, kt, ck);
  }
  // One Jacobi iteration (virtual_mesh.cpp: virtual_iteration).
  Vec3f r{};
  float D = 0.f;
  if (!pinned) {
    const float mh = mass * d.inv_h2;
    r = inertia_coupling_residual(mh, s, q, p, d.k_svc);  // virtual_jacobi.hpp
    auto at = [&](int a) {  // q of vertex a in this iteration (iteration 0: its start, x + h v)
      const Vec3f x = qin[a];
      if (!first || d.model.pinned[a]) return x;
      return iteration_start(x, v_in[a], d.h);
    };
    add_edge_residuals(d, j, degree, it0, at, r);
    D = mh + stiff;
  }
  // -dE_con/dq [3]: kt - ck q, by one reciprocal rather than three divisions (an IEEE division
  // takes a slow path for some operands, a zero numerator among them); finish_deferred uses the
  // same expression.
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
  } else if (kSurface) {
    f.list1 = held;
  } else {
    f.list0 = !held && reachable(t, posed, qn);
    f.list1 = held;
  }
  vertex_end<!kSurface>(d, t, physical, last, j, held, qn, first ? q_in : (last ? d.q_start[j] : Vec3f{}), qout, v_out, f);
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

// The active region (MeshDev::region_tol > 0; docs/CUDA.md, "The active region"): a chunk of
// kBlock vertices is awake or asleep for a whole tick, decided at its first step (chunk_awake);
// a sleeping chunk's vertices follow their E_svc targets (sleeping_vertex); an awake chunk falls
// asleep after kCalmTicks calm ticks in a row (settle_chunk). The rules per vertex are the CPU
// region's (solver/region_rules.hpp); the region's unit is the chunk.

/// The strain check of vertex j of a sleeping chunk where it stood at the last tick's end (qin,
/// its coupling point qin - offset): the sum of its edges' E_s [4] forces, its E_svc [5]
/// spring's and its weight moves it by more than the tolerance in a static Jacobi step.
__device__ bool strained(const MeshDev& d, int j, const Vec3f* __restrict__ qin) {
  Vec3f f = d.model.mass[j] * d.gravity - d.k_svc * d.region_offset[j];
  int4 it0[kEdgeChunk];
#pragma unroll
  for (int u = 0; u < kEdgeChunk; ++u) it0[u] = __ldg(&d.edge_ell[u * d.m + j]);
  add_edge_residuals(d, j, d.model.edge_offsets[j + 1] - d.model.edge_offsets[j], it0, [&](int a) { return qin[a]; }, f);
  return pulled_off(f, d.model.stiff_diag[j], d.region_tol);
}

/// Whether chunk c runs its vertices this tick (at its first step, tick `tick`; every thread of
/// the block calls it, thread i for vertex j): it was awake, a hot neighbour of one of its
/// vertices at the tick before or a grasp event wakes it, or one of its vertices is held, may be reached by the tick's Newton
/// calls (from the pose of `posed`, at the place it will stand) or, on the chunk's strain-check
/// tick, is pulled off by its edges. The tick's E_svc targets of its vertices are blended here.
__device__ bool chunk_awake(const MeshDev& d, const ToolConst& t, const Posed& posed, const DeviceTickInput& in,
                            long long tick, int c, int j, const Vec3f* __restrict__ qin, bool p_ready) {
  ChunkRegion& cr = d.chunk_region[c];
  const bool was = cr.awake != 0;
  bool need = false;
  if (j < d.m) {
    const Vec3f p = tick_target(d, in, j, p_ready);
    if (!was) {  // a pinned vertex too: it takes no step, but the tool pushes against it
      const bool pinned = d.model.pinned[j];
      const Vec3f q = pinned ? qin[j] : p + d.region_offset[j];
      need = d.held[j] != 0 ||
             maybe_within(t, posed, q, newton_reach_bound(d.region_reach_T, d.region_reach_th, origin_distance(posed, q)) + kFloatSlack);
      if (!need && !pinned && (tick + c) % d.region_check == 0) need = strained(d, j, qin);
    }
  }
  // Every thread read cr.awake before the barrier; thread 0 writes only awake and calm.
  const bool awake = __syncthreads_or(need) || was || in.grasp > 0 || cr.wake[tick & 1] >= tick;
  if (threadIdx.x == 0) {
    if (!was && awake) {
      cr.awake = 1;
      cr.calm = 0;
    }
    if (awake) {
      atomicAdd(d.region_awake, 1ull);
      atomicAdd(&d.region_tick_active[tick & 1], static_cast<unsigned>(d.chunk_free[c]));
    }
  }
  return awake;
}

/// Step s of vertex j of a sleeping chunk: it follows its E_svc target, standing at p + offset
/// for the whole tick (its velocity, on the last step, that of the move; vertex_end). The first
/// step writes that place into `spare` as well (Schedule::spare, when not null): every buffer the
/// tick's middle steps read then holds it, and the chunk skips them (vertex_blocks).
__device__ VertexFlags sleeping_vertex(const MeshDev& d, const ToolConst& t, const Posed& physical, bool first, bool last,
                                       int j, const Vec3f* __restrict__ qin, Vec3f* __restrict__ qout,
                                       Vec3f* __restrict__ v_out, Vec3f* __restrict__ spare) {
  VertexFlags f;
  const Vec3f q_in = qin[j];
  Vec3f q = q_in;
  if (first) {
    d.q_start[j] = q_in;
    if (!d.model.pinned[j]) q = d.p[j] + d.region_offset[j];
    if (spare) spare[j] = q;
  }
  vertex_end(d, t, physical, last, j, false, q, first ? q_in : (last ? d.q_start[j] : Vec3f{}), qout, v_out, f);
  return f;
}

/// The end of an awake chunk's tick (its last step, every thread of the block; f: vertex j's
/// step): each vertex's displacement from where it would stand asleep, and whether it is calm (not
/// held, in contact, deferred or reachable, and not moving: region_rules.hpp) or hot. A hot vertex
/// wakes the chunks of its neighbours for the next tick; after kCalmTicks calm ticks the chunk sleeps,
/// each vertex keeping its displacement in its offset (it stays where it settled).
template <bool kAhead>
__device__ void settle_chunk(const MeshDev& d, long long tick, int c, int j, const VertexFlags& f) {
  bool calm = true, hot = false;
  Vec3f disp{};
  if (j < d.m) {
    // Held, deferred (kAhead: its q is block 0's), or near the tool (a pinned vertex too)
    if (f.list1 || f.list0 || f.contact) calm = false;
    if (!d.model.pinned[j] && !(kAhead && f.list1)) {
      disp = f.q - (d.p[j] + d.region_offset[j]);
      const RegionMotion motion = region_motion(disp, d.region_disp[j], d.region_tol);
      calm = calm && !motion.moving;
      hot = motion.hot;
    }
  }
  if (hot) {  // the chunks of its neighbours wake at the next tick
    const int degree = d.model.edge_offsets[j + 1] - d.model.edge_offsets[j];
    for (int k = 0; k < degree; ++k) {
      const int4 it = __ldg(&d.edge_ell[k * d.m + j]);
      const int other = (it.x == j ? it.y : it.x) / kBlock;
      if (other != c) atomicMax(&d.chunk_region[other].wake[(tick + 1) & 1], tick + 1);
    }
  }
  ChunkRegion& cr = d.chunk_region[c];
  const bool still = !__syncthreads_or(!calm);  // after chunk_awake's writes (one iteration a tick)
  const int before = cr.calm;
  __syncthreads();  // every thread read cr.calm
  const int calm_ticks = still ? before + 1 : 0;
  const bool sleep = calm_ticks >= kCalmTicks;
  if (j < d.m && !d.model.pinned[j] && !(kAhead && f.list1)) {
    if (sleep) {
      d.region_offset[j] = d.region_offset[j] + disp;
      d.region_disp[j] = Vec3f{};
    } else {
      d.region_disp[j] = disp;
    }
  }
  if (threadIdx.x == 0) {
    cr.calm = sleep ? 0 : calm_ticks;
    if (sleep) cr.awake = 0;
  }
}

/// One step of chunk c (kBlock vertices, one per thread; vertex_step), then the chunk's two lists
/// in vertex order, its contact count and deepest penetration (block_counts[4 c ..]).
/// With the active region (d.region_tol > 0), a sleeping chunk's vertices follow their targets
/// instead (chunk_awake, sleeping_vertex, settle_chunk). Returns whether the chunk is awake.
template <bool kAhead>
__device__ bool vertex_chunk(const MeshDev& d, const ToolConst& t, long long tick, bool first, bool last, bool p_ready,
                             int c, const Vec3f* __restrict__ qin, const Vec3f* v_in, Vec3f* __restrict__ qout,
                             Vec3f* __restrict__ v_out, Vec3f* __restrict__ spare, BlockShared& sm, BlockClock& clock) {
  const int j = c * kBlock + threadIdx.x;
  VertexFlags f;
  DeferredVertex deferred;
  const bool region = d.region_tol > 0.f;
  bool awake = true;
  if (region) {
    if (first) {
      awake = chunk_awake(d, t, sm.posed(), sm.in(), tick, c, j, qin, p_ready);
      p_ready = true;  // chunk_awake blended the targets
    } else {
      awake = d.chunk_region[c].awake != 0;
    }
  }
  if (j < d.m) {
    if (awake)
      f = vertex_step<kAhead>(d, t, sm.posed(), sm.physical(), sm.in(), first, last, j, qin, v_in, qout, v_out, deferred, p_ready);
    else
      f = sleeping_vertex(d, t, sm.physical(), first, last, j, qin, qout, v_out, spare);
  }
  if (region && last && awake) settle_chunk<kAhead>(d, tick, c, j, f);
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
  clock.chunk_vertices_done();
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
  return awake;
}

/// A vertex block's work after it arrived at step s, with or without surface contact (vertex_blocks,
/// surface_vertex_blocks). A tick that starts a physical period k > 0 (a launch across periods):
/// its start q, this block's part of it, is step k's input (run_ticks_with_steps; step 0 starts
/// from the initial mesh). A tick's last step but the run's: while block 0 finishes the tick, the
/// next tick's E_svc targets of this block's vertices, which only this block reads (block 0 gets
/// the deferred vertices' sums); the physical results they blend are the launch's first
/// period's, or (a launch across periods) the next tick's period's, waited for when that tick
/// starts the period. Returns whether it blended them (the next step's p_ready).
__device__ bool step_handoffs(const MeshDev& d, const Schedule& S, int s, int steps) {
  const int blocks = gridDim.x - 1;
  if (d.period > 0 && S.first(s) && S.tick(s) > 0 && S.tick(s) % d.period == 0) {
    const Vec3f* q = S.in(s);
    for (int c = blockIdx.x - 1; c < d.chunks; c += blocks) {
      const int j = c * kBlock + threadIdx.x;
      if (j < d.m) d.snap_q[j] = q[j];
    }
    __syncthreads();
    if (threadIdx.x == 0) add_release(&d.steps->snapped, 1ull);
  }
  if (!S.last(s) || s + 1 >= steps) return false;
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
  return true;
}

/// The blocks other than block 0: each step, once released, the step's vertices of their chunks
/// (chunk c = blockIdx.x - 1, + gridDim.x - 1, ...) at the pose of the step's slot, then arrive.
__device__ void vertex_blocks(const MeshDev& d, const ToolConst& t, const Schedule& S, int steps, BlockShared& sm) {
  const int blocks = gridDim.x - 1;
  bool p_ready = false;  // the step's E_svc targets blended ahead
  unsigned asleep = 0;   // bit i: the block's i-th chunk sleeps this tick (decided at its first step)
  for (int s = 0; s < steps; ++s) {
    const unsigned long long e = S.epoch(s);
    const bool first = S.first(s), last = S.last(s);
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
    const bool ahead = d.slots[s & 1].ahead != 0;  // block 0's choice (tool_block)
    if (threadIdx.x < t.count) {
      const SlotPose slot = d.slots[s & 1];
      pose_collider(t, slot.P, slot.Q, sm.in().jaw_cos, sm.in().jaw_sin, threadIdx.x, sm.posed());
    }
    __syncthreads();
    clock.posed();
    // A sleeping chunk's middle steps (neither a tick's first nor its last) are skipped: its
    // vertices stand still for the tick, the first step wrote their place into both buffers the
    // middle steps alternate between (sleeping_vertex), and its counts stay that step's zeros.
    // Which of the block's chunks sleep: `asleep`'s bits for its first 32, their own flag beyond.
    Vec3f* spare = first ? S.spare() : nullptr;
    int i = 0;
    for (int c = blockIdx.x - 1; c < d.chunks; c += blocks, ++i) {
      if (!first && !last && (i < 32 ? (asleep >> i) & 1u : d.region_tol > 0.f && !d.chunk_region[c].awake)) continue;
      clock.chunk_begin();
      const bool awake =
          ahead ? vertex_chunk<true>(d, t, S.tick(s), first, last, p_ready, c, S.in(s), S.v_in(s), S.out(s), S.v_out(s), spare, sm, clock)
                : vertex_chunk<false>(d, t, S.tick(s), first, last, p_ready, c, S.in(s), S.v_in(s), S.out(s), S.v_out(s), spare, sm, clock);
      if (first && i < 32) asleep = awake ? asleep & ~(1u << i) : asleep | (1u << i);
      clock.chunk_end();
    }
    clock.report(d.profile, s);
    __syncthreads();
    if (threadIdx.x == 0) {
      add_release(&d.sync->arrive, 1ull);
    }
    p_ready = step_handoffs(d, S, s, steps);
  }
}

}  // namespace
}  // namespace ebh
