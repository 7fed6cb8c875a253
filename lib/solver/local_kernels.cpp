// The CPU solvers' hot loops (see local_kernels.hpp): blocks of SIMD lanes, fixed per element.
#include "solver/local_kernels.hpp"

#include "energy/arap.hpp"
#include "energy/edge_spring.hpp"
#include "energy/rotation.hpp"

namespace ebh {
namespace {

// Lanes per block: 8 doubles, one AVX-512 register or two AVX2 ones.
constexpr int kTetLanes = 8;   ///< tets per block
constexpr int kEdgeLanes = 8;  ///< edges per block

/// Alg. 1 lines 6-8 for the tets [t0, t0 + count), count <= kTetLanes (Full: equal):
/// R_t = Mueller update(s) of the warm start (energy/rotation.hpp), then the corner forces
/// w_t (R_t - F_t) g_c (= -dE_vol/dx_c) into their gather slots. The lanes' data go through small
/// structure-of-arrays buffers: scalar gathers in, branch-free loops over the lanes that the
/// compiler vectorises (the energy functions inlined per lane), scalar scatters out.
template <bool Full>
void tet_block(const TetKernelData& tets, const Vec3d* __restrict x, Quatd* __restrict rotation,
               Vec3d* __restrict force, int t0, int count, int rotation_iterations, double tol) {
  constexpr int W = kTetLanes;
  const int L = Full ? W : count;
  const int T = tets.num_tets;
  const int* __restrict corner = tets.corner;
  const double* __restrict g = tets.shape_grad + t0;  // g[(3 c + i) T + l]
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
    for (int c = 0; c < 4; ++c) {
      xc[c] = Vec3d{X[3 * c][l], X[3 * c + 1][l], X[3 * c + 2][l]};
      gc[c] = Vec3d{g[(3 * c) * T + l], g[(3 * c + 1) * T + l], g[(3 * c + 2) * T + l]};
    }
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
    const Mat3d P = w[l] * (rotation_matrix(Quatd{q[0][l], q[1][l], q[2][l], q[3][l]}) - Ft);
    for (int c = 0; c < 4; ++c) {
      const Vec3d fc = P * Vec3d{g[(3 * c) * T + l], g[(3 * c + 1) * T + l], g[(3 * c + 2) * T + l]};
      f[3 * c][l] = fc.x; f[3 * c + 1][l] = fc.y; f[3 * c + 2][l] = fc.z;
    }
  }
  const int* __restrict slot = tets.slot;
  for (int l = 0; l < L; ++l) {  // scatter
    rotation[t0 + l] = Quatd{q[0][l], q[1][l], q[2][l], q[3][l]};
    for (int c = 0; c < 4; ++c) force[slot[c * T + t0 + l]] = Vec3d{f[3 * c][l], f[3 * c + 1][l], f[3 * c + 2][l]};
  }
}

/// E_s [4] gradients of the edges [e0, e0 + count), count <= kEdgeLanes (Full: equal):
/// g = dE_s/dq_a = k_s (d - R e0); the end a receives -g, the end b +g, in their gather slots.
/// Scalar gathers into small structure-of-arrays buffers, a branch-free loop over the lanes that
/// the compiler vectorises, scalar scatters out.
template <bool Full>
void edge_block(const EdgeKernelData& data, const Vec3d* __restrict q, Vec3d* __restrict force, int e0, int count) {
  constexpr int W = kEdgeLanes;
  const int L = Full ? W : count;
  const std::array<int, 2>* __restrict edges = data.edges + e0;
  const Vec3d* __restrict rest_edge = data.rest_edge + e0;
  const double* __restrict rest_len = data.rest_len + e0;
  double qa[3][W], qb[3][W], e[3][W], f[3][W];
  for (int l = 0; l < L; ++l) {
    const Vec3d& a = q[edges[l][0]];
    const Vec3d& b = q[edges[l][1]];
    qa[0][l] = a.x; qa[1][l] = a.y; qa[2][l] = a.z;
    qb[0][l] = b.x; qb[1][l] = b.y; qb[2][l] = b.z;
    e[0][l] = rest_edge[l].x; e[1][l] = rest_edge[l].y; e[2][l] = rest_edge[l].z;
  }
#pragma GCC ivdep
  for (int l = 0; l < L; ++l) {
    const Vec3d g = edge_spring_gradient(Vec3d{qa[0][l], qa[1][l], qa[2][l]}, Vec3d{qb[0][l], qb[1][l], qb[2][l]},
                                         Vec3d{e[0][l], e[1][l], e[2][l]}, rest_len[l], data.k_s);
    f[0][l] = g.x; f[1][l] = g.y; f[2][l] = g.z;
  }
  const int* __restrict slot = data.slot + 2 * e0;
  for (int l = 0; l < L; ++l) {
    const Vec3d g{f[0][l], f[1][l], f[2][l]};
    force[slot[2 * l]] = -g;
    force[slot[2 * l + 1]] = g;
  }
}

}  // namespace

void local_step_tets(const TetKernelData& tets, const Vec3d* x, Quatd* rotation, Vec3d* force,
                     int rotation_iterations, double tol) {
  constexpr int W = kTetLanes;
  const int T = tets.num_tets;
  const int blocks = (T + W - 1) / W;
#pragma omp for schedule(static) nowait
  for (int b = 0; b < blocks; ++b) {
    if (W * (b + 1) <= T)
      tet_block<true>(tets, x, rotation, force, W * b, W, rotation_iterations, tol);
    else
      tet_block<false>(tets, x, rotation, force, W * b, T - W * b, rotation_iterations, tol);
  }
}

void edge_spring_forces(const EdgeKernelData& edges, const Vec3d* q, Vec3d* force) {
  constexpr int W = kEdgeLanes;
  const int E = edges.num_edges;
  const int blocks = (E + W - 1) / W;
#pragma omp for schedule(static)
  for (int b = 0; b < blocks; ++b) {
    if (W * (b + 1) <= E)
      edge_block<true>(edges, q, force, W * b, W);
    else
      edge_block<false>(edges, q, force, W * b, E - W * b);
  }
}

}  // namespace ebh
