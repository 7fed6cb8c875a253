// The CPU solvers' hot loops (see local_kernels.hpp): blocks of SIMD lanes, fixed per element.
#include "solver/local_kernels.hpp"

#include <algorithm>

#include "energy/arap.hpp"
#include "energy/edge_spring.hpp"
#include "energy/rotation.hpp"
#include "energy/volume.hpp"

namespace ebh {
namespace {

/// The shape gradients of lane l: g_1..g_3 from the structure of arrays, g_0 recomputed
/// (first_shape_gradient: the bits tet_shape_gradients stored).
inline void lane_shape_gradients(const double* __restrict g, int T, int l, Vec3d gc[4]) {
  for (int c = 1; c < 4; ++c)
    gc[c] = Vec3d{g[(3 * c - 3) * T + l], g[(3 * c - 2) * T + l], g[(3 * c - 1) * T + l]};
  gc[0] = first_shape_gradient(gc[1], gc[2], gc[3]);
}

/// Alg. 1 lines 6-8 for the tets [t0, t0 + count), count <= kTetLanes (Full: equal):
/// R_t = Mueller update(s) of the warm start (energy/rotation.hpp), then the corner forces
/// w_t (R_t - F_t) g_c (= -dE_vol/dx_c) into force[4 t + c]. The lanes' data go through small
/// structure-of-arrays buffers: scalar gathers in, branch-free loops over the lanes that the
/// compiler vectorises (the energy functions inlined per lane), scalar stores out. Det: E_det's
/// force added (tets.det_ratio > 0); a template argument rather than elastic_force_matrix's own
/// test of kappa, which would put a branch inside the vectorised loop.
template <bool Full, bool Det>
void tet_block_general(const TetKernelData& tets, const Vec3d* __restrict x, Quatd* __restrict rotation,
               Vec3d* __restrict force, int t0, int count, int rotation_iterations, double tol) {
  constexpr int W = kTetLanes;
  const int L = Full ? W : count;
  const int T = tets.num_tets;
  const int* __restrict corner = tets.corner;
  const double* __restrict g = tets.shape_grad + t0;  // g[(3 c - 3 + i) T + l], c = 1..3
  const double* __restrict w = tets.weight + t0;
  double X[12][W], F[9][W], q[4][W], f[12][W];
  int active[W];
  for (int l = 0; l < L; ++l) {  // gather
    for (int c = 0; c < 4; ++c) {
      const Vec3d& xc = x[corner[c * T + t0 + l]];
      X[3 * c][l] = xc.x; X[3 * c + 1][l] = xc.y; X[3 * c + 2][l] = xc.z;
    }
    const Quatd& qt = rotation[t0 + l];
    q[0][l] = qt.w; q[1][l] = qt.x; q[2][l] = qt.y; q[3][l] = qt.z;
  }
#pragma GCC ivdep
  for (int l = 0; l < L; ++l) {  // F = sum_c x_c g_c^T
    Vec3d xc[4], gc[4];
    for (int c = 0; c < 4; ++c) xc[c] = Vec3d{X[3 * c][l], X[3 * c + 1][l], X[3 * c + 2][l]};
    lane_shape_gradients(g, T, l, gc);
    const Mat3d Ft = deformation_gradient(xc, gc);
    for (int i = 0; i < 9; ++i) F[i][l] = Ft.m[i / 3][i % 3];
    active[l] = 1;
  }
  for (int it = 0; it < rotation_iterations; ++it) {
    int any = 0;
#pragma GCC ivdep
    for (int l = 0; l < L; ++l) {  // extract_rotation's loop, one update per pass
      Mat3d Ft;
      for (int i = 0; i < 9; ++i) Ft.m[i / 3][i % 3] = F[i][l];
      const Quatd qt{q[0][l], q[1][l], q[2][l], q[3][l]};
      double omega_norm;
      const Quatd next = mueller_update(Ft, qt, omega_norm);
      const int go = active[l] & int(!(omega_norm < tol));  // extract_rotation's stop test
      q[0][l] = go ? next.w : qt.w; q[1][l] = go ? next.x : qt.x;
      q[2][l] = go ? next.y : qt.y; q[3][l] = go ? next.z : qt.z;
      active[l] = go;
      any |= go;
    }
    if (!any) break;
  }
#pragma GCC ivdep
  for (int l = 0; l < L; ++l) {  // w_t (R_t - F_t) g_c
    Mat3d Ft;
    for (int i = 0; i < 9; ++i) Ft.m[i / 3][i % 3] = F[i][l];
    const Mat3d R = rotation_matrix(Quatd{q[0][l], q[1][l], q[2][l], q[3][l]});
    Mat3d P;
    if constexpr (Det) P = elastic_force_matrix(Ft, R, w[l], tets.det_ratio);
    else P = w[l] * (R - Ft);
    Vec3d gc[4];
    lane_shape_gradients(g, T, l, gc);
    for (int c = 0; c < 4; ++c) {
      const Vec3d fc = P * gc[c];
      f[3 * c][l] = fc.x; f[3 * c + 1][l] = fc.y; f[3 * c + 2][l] = fc.z;
    }
  }
  for (int l = 0; l < L; ++l) {  // out, in (tet, corner) order
    rotation[t0 + l] = Quatd{q[0][l], q[1][l], q[2][l], q[3][l]};
    for (int c = 0; c < 4; ++c) force[4 * (t0 + l) + c] = Vec3d{f[3 * c][l], f[3 * c + 1][l], f[3 * c + 2][l]};
  }
}

/// tet_block for one rotation update per local step (the default): one fused loop over the lanes,
/// positions gathered straight from x, no intermediate buffers but the forces' (same operations,
/// same order as tet_block_general).
template <bool Full, bool Det>
void tet_block_single_update(const TetKernelData& tets, const double* __restrict x, Quatd* __restrict rotation,
                             Vec3d* __restrict force, int t0, int count, double tol) {
  constexpr int W = kTetLanes;
  const int L = Full ? W : count;
  const int T = tets.num_tets;
  const int* __restrict corner = tets.corner + t0;      // corner[c T + l]
  const double* __restrict g = tets.shape_grad + t0;    // g[(3 c - 3 + i) T + l], c = 1..3
  const double* __restrict w = tets.weight + t0;
  double* __restrict qd = &rotation[t0].w;              // 4 per tet
  double f[12][W];
#pragma GCC ivdep
  for (int l = 0; l < L; ++l) {
    Vec3d xc[4], gc[4];
    for (int c = 0; c < 4; ++c) {
      const int v = 3 * corner[c * T + l];
      xc[c] = Vec3d{x[v], x[v + 1], x[v + 2]};
    }
    lane_shape_gradients(g, T, l, gc);
    const Mat3d F = deformation_gradient(xc, gc);
    const Quatd q0{qd[4 * l], qd[4 * l + 1], qd[4 * l + 2], qd[4 * l + 3]};
    double omega_norm;
    const Quatd next = mueller_update(F, q0, omega_norm);
    const bool go = !(omega_norm < tol);  // extract_rotation's stop test
    const Quatd q{go ? next.w : q0.w, go ? next.x : q0.x, go ? next.y : q0.y, go ? next.z : q0.z};
    qd[4 * l] = q.w; qd[4 * l + 1] = q.x; qd[4 * l + 2] = q.y; qd[4 * l + 3] = q.z;
    Mat3d P;
    if constexpr (Det) P = elastic_force_matrix(F, rotation_matrix(q), w[l], tets.det_ratio);
    else P = w[l] * (rotation_matrix(q) - F);  // w_t (R_t - F_t)
    for (int c = 0; c < 4; ++c) {
      const Vec3d fc = P * gc[c];
      f[3 * c][l] = fc.x; f[3 * c + 1][l] = fc.y; f[3 * c + 2][l] = fc.z;
    }
  }
  for (int l = 0; l < L; ++l)  // out, in (tet, corner) order
    for (int c = 0; c < 4; ++c) force[4 * (t0 + l) + c] = Vec3d{f[3 * c][l], f[3 * c + 1][l], f[3 * c + 2][l]};
}

/// E_s [4] gradients g = dE_s/dq_a = k_s (d - R e0) of the edges [e0, e0 + count),
/// count <= kEdgeLanes (Full: equal), into g_out[e]. One branch-free loop over the lanes with
/// the positions gathered straight from q (SIMD gathers under EBH_NATIVE); it reads the rest
/// edge vectors only for a collapsed edge (|d| ~ 0, where R e0 = e0), recomputed after the loop
/// (that edge alone: the others keep the loop's bits, which do not depend on the block, so that
/// edge_spring_gradients_listed gives every edge the same bits whatever its neighbours).
template <bool Full>
void edge_block(const EdgeKernelData& data, const double* __restrict q, Vec3d* __restrict g_out, int e0, int count) {
  constexpr int W = kEdgeLanes;
  const int L = Full ? W : count;
  const int* __restrict ab = data.edges[0].data() + 2 * e0;  // (a, b) pairs
  const double* __restrict rest_len = data.rest_len + e0;
  double* __restrict out = &g_out[e0].x;
  int collapsed = 0;
#pragma GCC ivdep
  for (int l = 0; l < L; ++l) {
    const int a = 3 * ab[2 * l], b = 3 * ab[2 * l + 1];
    const Vec3d qa{q[a], q[a + 1], q[a + 2]}, qb{q[b], q[b + 1], q[b + 2]};
    const Vec3d g = edge_spring_gradient(qa, qb, Vec3d{}, rest_len[l], data.k_s);  // exact unless collapsed
    out[3 * l] = g.x; out[3 * l + 1] = g.y; out[3 * l + 2] = g.z;
    collapsed |= int(edge_collapsed(qa - qb, rest_len[l]));
  }
  if (collapsed)
    for (int l = 0; l < L; ++l) {
      const int a = ab[2 * l], b = ab[2 * l + 1];
      const Vec3d* qv = reinterpret_cast<const Vec3d*>(q);
      if (edge_collapsed(qv[a] - qv[b], rest_len[l]))
        g_out[e0 + l] = edge_spring_gradient(qv[a], qv[b], data.rest_edge[e0 + l], rest_len[l], data.k_s);
    }
}

}  // namespace

void local_step_tet_blocks(const TetKernelData& tets, const Vec3d* x, Quatd* rotation, Vec3d* force,
                           int rotation_iterations, double tol, int b0, int b1) {
  constexpr int W = kTetLanes;
  const int T = tets.num_tets;
  for (int b = b0; b < b1; ++b) {
    const bool full = W * (b + 1) <= T;
    const int count = full ? W : T - W * b;
    if (tets.det_ratio > 0) {
      if (rotation_iterations == 1) {
        if (full) tet_block_single_update<true, true>(tets, &x[0].x, rotation, force, W * b, W, tol);
        else tet_block_single_update<false, true>(tets, &x[0].x, rotation, force, W * b, count, tol);
      } else {
        if (full) tet_block_general<true, true>(tets, x, rotation, force, W * b, W, rotation_iterations, tol);
        else tet_block_general<false, true>(tets, x, rotation, force, W * b, count, rotation_iterations, tol);
      }
    } else if (rotation_iterations == 1) {
      if (full) tet_block_single_update<true, false>(tets, &x[0].x, rotation, force, W * b, W, tol);
      else tet_block_single_update<false, false>(tets, &x[0].x, rotation, force, W * b, count, tol);
    } else {
      if (full) tet_block_general<true, false>(tets, x, rotation, force, W * b, W, rotation_iterations, tol);
      else tet_block_general<false, false>(tets, x, rotation, force, W * b, count, rotation_iterations, tol);
    }
  }
}

void local_step_tets(const TetKernelData& tets, const Vec3d* x, Quatd* rotation, Vec3d* force,
                     int rotation_iterations, double tol) {
  const int blocks = tet_blocks(tets.num_tets);
#pragma omp for schedule(static) nowait
  for (int b = 0; b < blocks; ++b) local_step_tet_blocks(tets, x, rotation, force, rotation_iterations, tol, b, b + 1);
}

void edge_spring_gradient_blocks(const EdgeKernelData& edges, const Vec3d* q, Vec3d* g, int b0, int b1) {
  constexpr int W = kEdgeLanes;
  const int E = edges.num_edges;
  for (int b = b0; b < b1; ++b) {
    if (W * (b + 1) <= E)
      edge_block<true>(edges, &q[0].x, g, W * b, W);
    else
      edge_block<false>(edges, &q[0].x, g, W * b, E - W * b);
  }
}

void edge_spring_gradients(const EdgeKernelData& edges, const Vec3d* q, Vec3d* g) {
  const int blocks = edge_blocks(edges.num_edges);
#pragma omp for schedule(static)
  for (int b = 0; b < blocks; ++b) edge_spring_gradient_blocks(edges, q, g, b, b + 1);
}

void edge_spring_gradient_groups(const EdgeKernelData& edges, const int* ids, int count, const Vec3d* q, Vec3d* g,
                                 int b0, int b1) {
  // Per edge what edge_block computes: the gradient without the rest edge, or with it for a
  // collapsed edge (as edge_block recomputes it). A group of kEdgeLanes listed edges that are consecutive edges (the active region's list is in
  // index order, so most are) is edge_block's block itself.
  constexpr int W = kEdgeLanes;
  for (int b = b0; b < b1; ++b) {
    const int i0 = W * b, n = std::min(W, count - i0);
    bool run = n == W;
    for (int l = 1; run && l < W; ++l) run = ids[i0 + l] == ids[i0] + l;
    if (run) {
      edge_block<true>(edges, &q[0].x, g, ids[i0], W);
      continue;
    }
    for (int i = i0; i < i0 + n; ++i) {
      const int e = ids[i];
      const Vec3d qa = q[edges.edges[e][0]], qb = q[edges.edges[e][1]];
      const double L0 = edges.rest_len[e];
      g[e] = edge_collapsed(qa - qb, L0) ? edge_spring_gradient(qa, qb, edges.rest_edge[e], L0, edges.k_s)
                                         : edge_spring_gradient(qa, qb, Vec3d{}, L0, edges.k_s);
    }
  }
}

void edge_spring_gradients_listed(const EdgeKernelData& edges, const int* ids, int count, const Vec3d* q, Vec3d* g) {
  const int groups = edge_blocks(count);
#pragma omp for schedule(static)
  for (int b = 0; b < groups; ++b) edge_spring_gradient_groups(edges, ids, count, q, g, b, b + 1);
}

}  // namespace ebh
