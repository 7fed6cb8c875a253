#pragma once
// The CPU solvers' hot loops: the physical mesh's per-tet local step (E_vol [7]) and the virtual
// mesh's per-edge local step (E_s [4]). They live in their own translation unit, which includes no
// Eigen, so that EBH_NATIVE can build it with -march=native (wider SIMD) without changing Eigen's
// ABI between the solver and its callers. The arguments are plain arrays (as for a CUDA kernel).
//
// Both functions are OpenMP work-sharing loops (`omp for`) over fixed blocks of lanes: call them
// from inside a parallel region (or outside one: they then run serially). A block's lanes run
// through the energy functions of lib/energy in branch-free loops the compiler vectorises (tets:
// through small structure-of-arrays buffers). A tet or edge takes the same code path whatever
// the thread count, so results are bitwise reproducible.
#include <array>

#include "math/vec.hpp"

namespace ebh {

/// The physical mesh's tets, structure of arrays. T = #tets.
struct TetKernelData {
  int num_tets = 0;                  ///< T
  const int* corner = nullptr;       ///< #4T vertex of corner c of tet t at [c T + t]
  const double* shape_grad = nullptr;///< #9T component i of g_c, c = 1..3, of tet t at [(3 c - 3 + i) T + t] (g_0 = first_shape_gradient)
  const double* weight = nullptr;    ///< #T w_t = 2 k_vol V_t
  double det_ratio = 0;              ///< kappa = k_det / k_vol: E_det's force too where > 0 (energy/volume.hpp)
};

/// Alg. 1 lines 6-8 per tet: F_t = sum_c x_c g_c^T; R_t by up to rotation_iterations Mueller
/// updates of rotation[t] (stopping below tol radians, as extract_rotation); then
/// force[4 t + c] = w_t (R_t - F_t) g_c (= -dE_vol/dx_c), with det_ratio > 0 E_det's force added
/// (elastic_force_matrix). `omp for nowait`.
///   x: #n positions; rotation: #T warm starts, updated; force: #4T.
void local_step_tets(const TetKernelData& tets, const Vec3d* x, Quatd* rotation, Vec3d* force,
                     int rotation_iterations, double tol);
/// The SIMD blocks of local_step_tets: kTetLanes tets each (8 doubles, one AVX-512 register or
/// two AVX2 ones), tet_blocks(T) of them.
constexpr int kTetLanes = 8;
constexpr int tet_blocks(int num_tets) { return (num_tets + kTetLanes - 1) / kTetLanes; }
/// local_step_tets over blocks [b0, b1) only, on the calling thread (no OpenMP): each block writes
/// only its own tets' rotations and forces.
void local_step_tet_blocks(const TetKernelData& tets, const Vec3d* x, Quatd* rotation, Vec3d* force,
                           int rotation_iterations, double tol, int b0, int b1);

/// The virtual mesh's edges. E = #edges.
struct EdgeKernelData {
  int num_edges = 0;                       ///< E
  const std::array<int, 2>* edges = nullptr;  ///< #E (a, b)
  const Vec3d* rest_edge = nullptr;        ///< #E q_a^0 - q_b^0
  const double* rest_len = nullptr;        ///< #E |q_a^0 - q_b^0|
  double k_s = 0;                          ///< N/m
};

/// E_s [4] per edge: g[e] = dE_s/dq_a = k_s (d - R e0), d = q_a - q_b (dE_s/dq_b = -g[e]).
/// `omp for` (ends with a barrier). q: #m positions; g: #E.
void edge_spring_gradients(const EdgeKernelData& edges, const Vec3d* q, Vec3d* g);

/// The same for the listed edges only (the active region, solver/active_region.hpp): g[ids[i]]
/// for i < count, each edge's bits those edge_spring_gradients gives it. `omp for` (ends with a
/// barrier). ids: #count distinct edge indices, fastest in index order (runs of consecutive edges
/// go through the blocks of edge_spring_gradients).
void edge_spring_gradients_listed(const EdgeKernelData& edges, const int* ids, int count, const Vec3d* q, Vec3d* g);

/// The blocks of edge_spring_gradients (kEdgeLanes edges each, edge_blocks(E) of them) and the
/// groups of edge_spring_gradients_listed (kEdgeLanes listed edges each, edge_blocks(count)):
/// blocks or groups [b0, b1) only, on the calling thread (no OpenMP), each writing only its own
/// edges' gradients.
constexpr int kEdgeLanes = 8;
constexpr int edge_blocks(int count) { return (count + kEdgeLanes - 1) / kEdgeLanes; }
void edge_spring_gradient_blocks(const EdgeKernelData& edges, const Vec3d* q, Vec3d* g, int b0, int b1);
void edge_spring_gradient_groups(const EdgeKernelData& edges, const int* ids, int count, const Vec3d* q, Vec3d* g,
                                 int b0, int b1);

}  // namespace ebh
