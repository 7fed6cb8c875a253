#pragma once
// The device haptic tick's tool side (part of haptic_cuda.cu's translation unit): block 0 runs the
// virtual tool's Newton call on the vertices a step can reach (fixed-order block sums of E_tool,
// its gradient and the contact Hessian; the warp's 6x6 clamp and solve; the Armijo line search),
// the tick's outputs, block 0's share of a pipelined step, and its loop over a run's steps.
#include "schedule/haptic_cuda_handoff.cuh"
#include "schedule/haptic_cuda_posed.cuh"
#include "schedule/haptic_cuda_vertices.cuh"
#include "tool/newton.hpp"
#include "tool/newton_warp.cuh"
#include "tool/tool_terms.hpp"

namespace ebh {
namespace {

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

/// E_con [3] of the reachable vertices plus the grasp part (tool_energy.cpp) at the posed tool `pt`,
/// summed over the block. kDerivs: also the gradient and the upper Hessian (into sh.total).
/// Returns E (contact + grasp) and (thread 0) the deepest contact's depth in `depth`.
/// kSurface: the candidates are surface samples, candidate i with stiffness cand_w[i] k_con.
template <bool kDerivs, bool kSurface = false>
__device__ double tool_contact_sums(const MeshDev& d, const ToolConst& t, const Vec3f* q, const Posed& pt,
                                    TailShared& sh, double& depth, const double* cand_w = nullptr) {
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
    // The contact's stiffness: k_con, or a surface sample's w k_con (surface_contact.hpp).
    if (kDerivs) {
      SurfaceQuery<double> sq;
      if (deepest_query(t, pt, qc, near, sq) < 0) continue;
      const double phi = -sq.sd;
      deepest = fmax(deepest, phi);
      if constexpr (kSurface) acc[0] += contact_terms(t.k_con * cand_w[i], phi, 1.0, sq.normal, qc - P, sq.hess, true, g, H);
      else acc[0] += contact_terms(t.k_con, phi, 1.0, sq.normal, qc - P, sq.hess, true, g, H);
    } else {  // E only: the deepest collider's signed distance
      const double phi = penetration(t, pt, qc, near);
      deepest = fmax(deepest, phi);
      if constexpr (kSurface) acc[0] += 0.5 * (t.k_con * cand_w[i]) * phi * phi;
      else acc[0] += 0.5 * t.k_con * phi * phi;
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
/// the result. kSurface: the candidates are surface samples with weights cand_w (tool_contact_sums).
template <bool kSurface = false>
__device__ __forceinline__ void virtual_tool_tail(const MeshDev& d, const ToolConst& t, const DeviceTickInput& in,
                                                  long long tick, const Vec3f* q, bool last, Posed& pt,
                                                  TailShared& sh, TailMarks& marks, const double* cand_w = nullptr) {
  marks.count_candidates(sh.nc);
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
    const double Econ = tool_contact_sums<true, kSurface>(d, t, q, pt, sh, depth, cand_w);  // synchronises the block
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
      marks.count_clamp(sweeps);
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
      const double Ec = tool_contact_sums<false, kSurface>(d, t, q, pt, sh, trial_depth, cand_w);  // synchronises the block
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
  // The chunks awake this tick added to their entry at its first step, before the arrivals block 0 waited for.
  if (d.region_tick_active) o.active = static_cast<std::int32_t>(atomicExch(&d.region_tick_active[tick & 1], 0u));
  d.out[tick % d.ring] = o;
  st.anchor_position = sh.anchor_P = sh.P;  // read_device of the next tick: the anchor is the pose at its start
  st.anchor_orientation = sh.anchor_Q = sh.Q;
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
  marks.count_updated(nu);
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

/// Block 0 at a run's start: the virtual tool's pose and anchor, as the run before left them, into
/// shared memory (tool_block, surface_tool_block).
__device__ void load_tool_state(const MeshDev& d, TailShared& sh) {
  if (threadIdx.x == 0) {
    sh.P = d.state->position;
    sh.Q = d.state->orientation;
    sh.anchor_P = d.state->anchor_position;
    sh.anchor_Q = d.state->anchor_orientation;
  }
  __syncthreads();
}

/// Block 0: the virtual tool. Each step, once the step's lists are made, it runs the Newton call
/// (virtual_tool_tail) when one follows the step (Schedule::called; a step without it is followed
/// by an unpipelined step). An unpipelined step's vertices wait for the call before them: block 0
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
  load_tool_state(d, sh);
  // Releases step s (epoch e) with the pose (sh.P, sh.Q) in its slot, from which each vertex
  // block poses the tool itself. By one thread of the last warp, with no barrier: the fence of its
  // release (its stores' round trip to L2) stalls no other warp, and the Newton call that follows
  // starts on the first warps (the candidates). What block 0 wrote before its last barrier is
  // visible with the release (the barrier orders it before the fence). Publishing the pose (not
  // the posed tool) and releasing from the last warp keeps the release off the Newton call's path.
  auto release = [&](unsigned long long e, int s, bool ahead) {
    if (threadIdx.x == kReleaseThread) {
      d.slots[s & 1] = SlotPose{sh.P, sh.Q, ahead ? 1 : 0};
      profile_release(d.profile, s);
      store_release(&d.sync->release, e);
    }
  };
  // Every vertex block's arrival at step s (epoch e).
  auto wait_arrivals = [&](unsigned long long e, int s) {
    __syncthreads();
    if (threadIdx.x == 0)
      while (load_acquire(&d.sync->arrive) < e * others) {}
    profile_arrivals(d.profile, s);
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
    release(S.epoch(s), s, false);
    marks.mark(DeviceTickProfile::Lists);
    wait_arrivals(S.epoch(s), s);
    unpipelined_lists(d, S.out(s), sh);
    marks.count_unpipelined();
    marks.mark(DeviceTickProfile::Lists);
  };
  unpipelined_step(0);
  for (int s = 0; s < steps; ++s) {
    // Here the lists of step s are made and pt is posed at (sh.P, sh.Q), the pose before its call,
    // with the jaws of sm.in(), step s's input.
    // Step s + 1 runs beside the call unless the schedule says otherwise or the call reaches many
    // vertices: block 0 would finish each of them after the call (about as many as step s's
    // candidates, besides the held ones, whose grasp targets cost little), longer than the vertex
    // blocks take for a whole step.
    const bool next = s + 1 < steps, ahead = next && !S.unpipelined(s + 1) && sh.nc <= d.pipeline_limit;
    if (ahead) {
      const DeviceTickInput& gin = S.input(s + 1);
      // For block 0's vertices, by warp 2, which the evaluation that follows mostly leaves idle
      // (threads 0-2 would delay the candidates' terms).
      if (S.last(s + 1)) pose_colliders(t, gin.position, gin.orientation, gin, sm.physical(), kPhysicalPoseThread);
      release(S.epoch(s + 1), s + 1, true);
    }
    marks.mark(DeviceTickProfile::Lists);
    if (S.called(s)) virtual_tool_tail(d, t, sm.in(), S.tick(s), S.out(s), S.last(s), pt, sh, marks);
    if (!next) break;
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
      pipelined_lists(d, t, pt, sm.physical(), S.last(s + 1), S.out(s + 1), S.v_out(s + 1), sh, marks);
    } else {
      unpipelined_step(s + 1);
    }
  }
  marks.end(d.profile, steps);
}

}  // namespace
}  // namespace ebh
