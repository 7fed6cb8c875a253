// The physical-mesh step (Algorithm 1) on a CUDA device, float32 (physical_mesh_cuda.hpp).
//
// Kernels of one step, all captured once into a CUDA graph:
//   copy q in     the #m virtual positions E_svc holds fixed (pinned host -> device)
//   predict       per vertex: x_start = x, s = x + h v + h^2 g (pinned: s = x), x = x_prev = s
//   K times:
//     local       per tet: F, R = extract_rotation(F, R_last) (Mueller 2016, warm-started),
//                 the corner forces w_t (R - F) g_c written to their slots of the vertex -> (tet,
//                 corner) CSR list; per virtual vertex: k_svc (q_j - p_j) w_jk written to the
//                 slots of the coupling CSR list                                      Alg. 1 l. 6-8
//     vertex      per vertex (8 threads): r = m/h^2 (s - x) + the sum of its CSR slots (contiguous,
//                 fixed order), then the Jacobi or Chebyshev update                   Alg. 1 l. 9
// Kernels are launched with programmatic dependent launch where the driver takes it in a graph
// (each waits for its predecessor with cudaGridDependencySynchronize before touching memory, so
// only the launch latency overlaps); otherwise as plain graph nodes.
//   finish        v = (1 - damping)(x - x_start) / h                                 Alg. 1 l. 11
//   reduce        ||r_0||^2 and ||r_{K-1}||^2 in a fixed order (one block)
//   copy x out    device -> pinned host
// The per-element math is the CPU reference's: the same EBH_HD templates instantiated on float.
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "energy/arap.hpp"
#include "energy/quadratic.hpp"
#include "energy/rotation.hpp"
#include "io/error.hpp"
#include "solver/cuda_util.cuh"
#include "solver/physical_mesh_cuda.hpp"

namespace ebh {
namespace {

constexpr int kBlock = 128;         // threads per block of the per-element kernels
constexpr int kLanes = 8;           // threads per vertex in the gather (a power of two <= 32)
constexpr int kReduceThreads = 512; // the one block of the residual reduction

/// The device's view of the model and state: plain pointers, passed to every kernel by value.
struct PhysicalDevice {
  int n = 0, T = 0, m = 0;
  float h = 0, k_svc = 0, velocity_scale = 0;  // velocity_scale = (1 - damping) / h
  Vec3f gravity;
  const int* tets = nullptr;            // 4T corner vertices
  const Vec3f* shape_grad = nullptr;    // 4T g_c
  const float* tet_weight = nullptr;    // T  w_t = 2 k_vol V_t
  const int* pair_vertex = nullptr;     // 4m
  const float* pair_weight = nullptr;   // 4m
  const int* pair_count = nullptr;      // m
  const int* tet_offsets = nullptr;     // n+1 CSR vertex -> incidence entries
  const int* corner_slot = nullptr;     // 4T slot of (t, c) in the vertex CSR list
  const int* cpl_slot = nullptr;        // 4m slot of (j, k) in the coupling CSR list
  const int* cpl_offsets = nullptr;     // n+1 CSR vertex -> coupling entries
  const float* mass_h2 = nullptr;       // n  m_a / h^2
  const float* step_scale = nullptr;    // n  gamma / A(a, a)
  const std::uint8_t* pinned = nullptr; // n
  const Vec3f* q = nullptr;             // m  virtual positions (input of the step)
  Vec3f* x = nullptr;                   // n
  Vec3f* v = nullptr;                   // n
  Vec3f* s = nullptr;                   // n  prediction
  Vec3f* x_start = nullptr;             // n
  Vec3f* x_prev = nullptr;              // n  previous iterate (Chebyshev)
  Quatf* rotation = nullptr;            // T  warm start of the local step
  Vec3f* corner_force = nullptr;        // 4T w_t (R_t - F_t) g_c, in CSR order: -dE_vol/dx_c
  Vec3f* cpl_force = nullptr;           // #coupling entries, w_jk k_svc (q_j - p_j): -dE_svc/dx
  float* rsq_first = nullptr;           // n  |r_a|^2 at iteration 0
  float* rsq_last = nullptr;            // n  |r_a|^2 at iteration K-1
  double* residual_sq = nullptr;        // 2  sums of the two
};

/// Start of every kernel: wait until the preceding kernel's writes are visible (a no-op without
/// programmatic dependent launch), then let the next kernel's launch begin.
__device__ __forceinline__ void kernel_prologue() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  cudaGridDependencySynchronize();
  cudaTriggerProgrammaticLaunchCompletion();
#endif
}

__device__ __forceinline__ void predict_vertex(const PhysicalDevice& d, int a) {
  const Vec3f xa = d.x[a];
  const Vec3f sa = d.pinned[a] ? xa : predict_position(xa, d.v[a], d.gravity, d.h);
  d.x_start[a] = xa;
  d.s[a] = sa;
  d.x[a] = sa;
  d.x_prev[a] = sa;
}

__global__ void predict_kernel(PhysicalDevice d) {
  kernel_prologue();
  const int a = blockIdx.x * blockDim.x + threadIdx.x;
  if (a < d.n) predict_vertex(d, a);
}

/// Alg. 1 lines 6-8: threads [0, T) take a tet each, threads [T, T + m) a virtual vertex each.
__device__ __forceinline__ void local_item(const PhysicalDevice& d, int i, int rotation_iterations) {
  if (i < d.T) {
    Vec3f x[4], g[4];
    int idx[4];
    for (int c = 0; c < 4; ++c) idx[c] = d.tets[4 * i + c];
    for (int c = 0; c < 4; ++c) { x[c] = d.x[idx[c]]; g[c] = d.shape_grad[4 * i + c]; }
    // F = sum_c x_c g_c^T with positions taken relative to corner 0 (sum_c g_c = 0, so F is the
    // same; in float32 it avoids cancelling |x| |g| ~ scene size / edge length).
    const Vec3f x0 = x[0];
    for (int c = 0; c < 4; ++c) x[c] = x[c] - x0;
    const Mat3f F = deformation_gradient(x, g);
    const Quatf R = extract_rotation(F, d.rotation[i], rotation_iterations, 1e-9f);
    d.rotation[i] = R;
    const Mat3f proj = d.tet_weight[i] * (to_matrix(R) - F);
    for (int c = 0; c < 4; ++c) d.corner_force[d.corner_slot[4 * i + c]] = proj * g[c];  // -dE_vol/dx_c [7]
  } else if (i < d.T + d.m) {
    const int j = i - d.T;
    const int count = d.pair_count[j];
    const Vec3f p = paired_point(d.x, d.pair_vertex + 4 * j, d.pair_weight + 4 * j, count);
    const Vec3f f = coupling_gradient_virtual(p, d.q[j], d.k_svc);  // k_svc (q - p)
    for (int k = 0; k < count; ++k) d.cpl_force[d.cpl_slot[4 * j + k]] = d.pair_weight[4 * j + k] * f;  // -dE_svc/dx [5]
  }
}

__global__ void local_kernel(PhysicalDevice d, int rotation_iterations) {
  kernel_prologue();
  local_item(d, blockIdx.x * blockDim.x + threadIdx.x, rotation_iterations);
}

__device__ __forceinline__ float lane_sum(float v) {
  // Butterfly over the kLanes threads of one vertex: every lane ends with the same bits (float
  // addition is commutative), in an order fixed by the lane pattern alone.
  for (int off = kLanes / 2; off > 0; off /= 2) v += __shfl_xor_sync(0xffffffffu, v, off, kLanes);
  return v;
}

/// r = -grad E_soft gathered per vertex, then the global step (Alg. 1 line 9):
///   jacobi     x <- x + gamma D^-1 r
///   chebyshev  x_{k+1} = omega (gamma D^-1 r + x_k - x_{k-1}) + x_{k-1}   (Wang 2015, eq. 12)
/// rsq_a / rsq_b (or null): where to store |r_a|^2 for the residual report.
/// Called by whole warps (its shuffles take every lane); gid beyond n * kLanes does nothing.
template <bool kChebyshev>
__device__ __forceinline__ void vertex_update(const PhysicalDevice& d, int gid, float omega, float* rsq_a, float* rsq_b) {
  const int a = gid / kLanes, lane = gid % kLanes;
  const bool valid = a < d.n;  // no early return: every lane takes part in the shuffles
  Vec3f r{};
  if (valid) {
    for (int k = d.tet_offsets[a] + lane; k < d.tet_offsets[a + 1]; k += kLanes) r += d.corner_force[k];  // [7]
    for (int k = d.cpl_offsets[a] + lane; k < d.cpl_offsets[a + 1]; k += kLanes) r += d.cpl_force[k];     // [5]
  }
  r = Vec3f{lane_sum(r.x), lane_sum(r.y), lane_sum(r.z)};
  if (!valid || lane != 0) return;
  const Vec3f xk = d.x[a];
  if (d.pinned[a]) r = Vec3f{};
  else r += d.mass_h2[a] * (d.s[a] - xk);                                   // -dE_k/dx [6]
  if (rsq_a) rsq_a[a] = squared_norm(r);
  if (rsq_b) rsq_b[a] = squared_norm(r);
  if constexpr (kChebyshev) {
    const Vec3f xp = d.x_prev[a];
    d.x[a] = omega * (d.step_scale[a] * r + xk - xp) + xp;
    d.x_prev[a] = xk;
  } else {
    d.x[a] = xk + d.step_scale[a] * r;
  }
}

template <bool kChebyshev>
__global__ void vertex_kernel(PhysicalDevice d, float omega, float* rsq_a, float* rsq_b) {
  kernel_prologue();
  vertex_update<kChebyshev>(d, blockIdx.x * blockDim.x + threadIdx.x, omega, rsq_a, rsq_b);
}

__device__ __forceinline__ void finish_vertex(const PhysicalDevice& d, int a) {
  d.v[a] = d.velocity_scale * (d.x[a] - d.x_start[a]);
}

__global__ void finish_kernel(PhysicalDevice d) {
  kernel_prologue();
  const int a = blockIdx.x * blockDim.x + threadIdx.x;
  if (a < d.n) finish_vertex(d, a);
}

/// ||r_0||^2 and ||r_{K-1}||^2 in double, each thread a fixed strided slice, then a fixed tree.
/// One block of kReduceThreads threads reduces (see residual_kernel).
__device__ __forceinline__ void residual_block(const PhysicalDevice& d) {
  __shared__ double sum[2][kReduceThreads];
  const int t = threadIdx.x;
  double a = 0, b = 0;
  for (int i = t; i < d.n; i += kReduceThreads) { a += d.rsq_first[i]; b += d.rsq_last[i]; }
  sum[0][t] = a;
  sum[1][t] = b;
  __syncthreads();
  for (int w = kReduceThreads / 2; w > 0; w /= 2) {
    if (t < w) { sum[0][t] += sum[0][t + w]; sum[1][t] += sum[1][t + w]; }
    __syncthreads();
  }
  if (t == 0) { d.residual_sq[0] = sum[0][0]; d.residual_sq[1] = sum[1][0]; }
}

__global__ void residual_kernel(PhysicalDevice d) {
  kernel_prologue();
  residual_block(d);
}

/// The whole step in one cooperative launch: the stages of the graph above as grid-stride loops
/// separated by grid-wide barriers (two per iteration), with the same per-element code, so x
/// comes out bitwise equal to the graph's. Blocks of kReduceThreads threads so block 0 can finish
/// with the residual reduction. omega: the K Chebyshev weights (float, computed in double on the
/// host as for the graph).
template <bool kChebyshev>
__global__ void __launch_bounds__(kReduceThreads) persistent_step_kernel(PhysicalDevice d, const float* omega, int K,
                                                                          int rotation_iterations) {
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  const int tid = blockIdx.x * blockDim.x + threadIdx.x, stride = gridDim.x * blockDim.x;
  for (int a = tid; a < d.n; a += stride) predict_vertex(d, a);
  grid.sync();
  // Whole warps iterate together in the gather (stride and the padded bound are multiples of 32).
  const int lanes_total = ((d.n * kLanes + 31) / 32) * 32;
  for (int k = 0; k < K; ++k) {
    for (int i = tid; i < d.T + d.m; i += stride) local_item(d, i, rotation_iterations);
    grid.sync();
    float* ra = k == 0 ? d.rsq_first : nullptr;
    float* rb = k == K - 1 ? d.rsq_last : nullptr;
    for (int g = tid; g < lanes_total; g += stride) vertex_update<kChebyshev>(d, g, omega[k], ra, rb);
    grid.sync();
  }
  for (int a = tid; a < d.n; a += stride) finish_vertex(d, a);
  if (K > 0 && blockIdx.x == 0) residual_block(d);
}

Vec3f to_float(const Vec3d& v) { return static_cast<Vec3f>(v); }

/// Launches kernel<<<grid, block, 0, stream>>>(args...), with programmatic dependent launch when
/// `programmatic` (the kernels' prologue makes that safe).
template <class... Params, class... Args>
void launch(bool programmatic, void (*kernel)(Params...), int grid, int block, cudaStream_t stream, const char* name,
            Args... args) {
  cudaLaunchConfig_t cfg{};
  cfg.gridDim = dim3(grid);
  cfg.blockDim = dim3(block);
  cfg.dynamicSmemBytes = 0;
  cfg.stream = stream;
  cudaLaunchAttribute attr[1];
  attr[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attr[0].val.programmaticStreamSerializationAllowed = 1;
  cfg.attrs = programmatic ? attr : nullptr;
  cfg.numAttrs = programmatic ? 1 : 0;
  EBH_CUDA_CHECK(cudaLaunchKernelEx(&cfg, kernel, args...));
  EBH_CUDA_LAUNCH_CHECK(stream, name);
}
Quatf to_float(const Quatd& q) { return {float(q.w), float(q.x), float(q.y), float(q.z)}; }

}  // namespace

struct CudaPhysicalSolver::Impl {
  PhysicalStepParams params;
  int n = 0, T = 0, m = 0;
  cuda::Stream stream;
  // Model.
  cuda::DeviceArray<int> tets, pair_vertex, pair_count, tet_offsets, corner_slot, cpl_offsets, cpl_slot;
  cuda::DeviceArray<Vec3f> shape_grad;
  cuda::DeviceArray<float> tet_weight, pair_weight, mass_h2, step_scale;
  cuda::DeviceArray<std::uint8_t> pinned;
  // State and scratch.
  cuda::DeviceArray<Vec3f> q, x, v, s, x_start, x_prev, corner_force, cpl_force;
  cuda::DeviceArray<Quatf> rotation;
  cuda::DeviceArray<float> rsq_first, rsq_last;
  cuda::DeviceArray<double> residual_sq;
  // Host side of the per-step copies.
  cuda::PinnedArray<Vec3f> q_host, x_host;
  cuda::PinnedArray<double> residual_host;
  PhysicalDevice dev;
  cudaGraph_t graph = nullptr;
  cudaGraphExec_t exec = nullptr;
  cudaEvent_t start = nullptr, stop = nullptr;  // around the graph launch
  double device_s = 0;

  Impl() {
    EBH_CUDA_CHECK(cudaEventCreate(&start));
    EBH_CUDA_CHECK(cudaEventCreate(&stop));
  }
  ~Impl() {
    if (exec) cudaGraphExecDestroy(exec);
    if (graph) cudaGraphDestroy(graph);
    if (start) cudaEventDestroy(start);
    if (stop) cudaEventDestroy(stop);
  }

  bool programmatic = false;  // the graph uses programmatic dependent launch
  // The cooperative single-kernel step (persistent_step_kernel), where the device supports it.
  bool cooperative_supported = false, persistent = false;
  int persistent_blocks = 0;
  cuda::DeviceArray<float> omega;  // K Chebyshev weights for the persistent kernel
  void prepare_persistent();
  void launch_persistent();

  void upload_model(const PhysicalModel& M);
  void capture(bool with_programmatic_launch);
};

void CudaPhysicalSolver::Impl::upload_model(const PhysicalModel& M) {
  n = M.num_vertices;
  T = M.num_tets;
  m = M.num_virtual;
  cudaStream_t st = stream.get();
  auto up = [st](auto& arr, const auto& host) {
    arr.allocate(host.size());
    arr.upload(host.data(), st);
  };
  std::vector<int> tets_h(4 * size_t(T));
  std::vector<Vec3f> grad_h(4 * size_t(T));
  std::vector<float> weight_h(T);
  for (int t = 0; t < T; ++t) {
    for (int c = 0; c < 4; ++c) {
      tets_h[4 * t + c] = M.tets[t][c];
      grad_h[4 * t + c] = to_float(M.shape_grad[4 * t + c]);
    }
    weight_h[t] = float(M.tet_weight[t]);
  }
  up(tets, tets_h);
  up(shape_grad, grad_h);
  up(tet_weight, weight_h);

  std::vector<int> pv(4 * size_t(m), -1);
  std::vector<float> pw(4 * size_t(m), 0.f);
  for (int j = 0; j < m; ++j)
    for (int k = 0; k < 4; ++k) { pv[4 * j + k] = M.pair_vertex[j][k]; pw[4 * j + k] = float(M.pair_weight[j][k]); }
  up(pair_vertex, pv);
  up(pair_weight, pw);
  up(pair_count, M.pair_count);

  // Slots: where the local step writes each corner force and coupling force, so that the vertex
  // kernel reads its CSR range contiguously, in the CPU reference's order.
  std::vector<int> cs(M.tet_entries.size());
  for (size_t k = 0; k < M.tet_entries.size(); ++k) cs[M.tet_entries[k]] = static_cast<int>(k);
  up(tet_offsets, M.tet_offsets);
  up(corner_slot, cs);
  std::vector<int> ps(4 * size_t(m), -1);
  for (int a = 0; a < n; ++a)
    for (int k = M.cpl_offsets[a]; k < M.cpl_offsets[a + 1]; ++k) {
      const int j = M.cpl_virtual[k];
      int i = 0;
      while (i < M.pair_count[j] && (M.pair_vertex[j][i] != a || ps[4 * j + i] >= 0)) ++i;
      if (i == M.pair_count[j]) throw std::logic_error("CudaPhysicalSolver: coupling list does not match the pairing");
      ps[4 * j + i] = k;
    }
  up(cpl_offsets, M.cpl_offsets);
  up(cpl_slot, ps);

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

  for (auto* arr : {&x, &v, &s, &x_start, &x_prev}) arr->allocate(n);
  q.allocate(m);
  cpl_force.allocate(M.cpl_virtual.size());
  corner_force.allocate(4 * size_t(T));
  rotation.allocate(T);
  rsq_first.allocate(n);
  rsq_last.allocate(n);
  residual_sq.allocate(2);
  q_host.allocate(m);
  x_host.allocate(n);
  residual_host.allocate(2);

  dev.n = n;
  dev.T = T;
  dev.m = m;
  dev.h = float(M.h);
  dev.k_svc = float(M.k_svc);
  dev.velocity_scale = float((1.0 - M.damping) / M.h);
  dev.gravity = to_float(M.gravity);
  dev.tets = tets.get();
  dev.shape_grad = shape_grad.get();
  dev.tet_weight = tet_weight.get();
  dev.pair_vertex = pair_vertex.get();
  dev.pair_weight = pair_weight.get();
  dev.pair_count = pair_count.get();
  dev.tet_offsets = tet_offsets.get();
  dev.corner_slot = corner_slot.get();
  dev.cpl_offsets = cpl_offsets.get();
  dev.cpl_slot = cpl_slot.get();
  dev.mass_h2 = mass_h2.get();
  dev.step_scale = step_scale.get();
  dev.pinned = pinned.get();
  dev.q = q.get();
  dev.x = x.get();
  dev.v = v.get();
  dev.s = s.get();
  dev.x_start = x_start.get();
  dev.x_prev = x_prev.get();
  dev.rotation = rotation.get();
  dev.corner_force = corner_force.get();
  dev.cpl_force = cpl_force.get();
  dev.rsq_first = rsq_first.get();
  dev.rsq_last = rsq_last.get();
  dev.residual_sq = residual_sq.get();
}

void CudaPhysicalSolver::Impl::capture(bool pdl) {
  cudaStream_t st = stream.get();
  const int K = params.iterations;
  EBH_CUDA_CHECK(cudaStreamBeginCapture(st, cudaStreamCaptureModeThreadLocal));
  try {
    if (m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(q.get(), q_host.get(), m * sizeof(Vec3f), cudaMemcpyHostToDevice, st));
    // The first kernel after a copy node takes no programmatic edge.
    if (n > 0) launch(false, predict_kernel, cuda::blocks_for(n, kBlock), kBlock, st, "predict_kernel", dev);
    // The Chebyshev weights of the CPU reference, in double, one per iteration (Wang 2015).
    const double rho2 = params.chebyshev_rho * params.chebyshev_rho;
    double omega = 1;
    const bool chebyshev = params.method == SolverSpec::Method::Chebyshev;
    for (int k = 0; k < K; ++k) {
      if (T + m > 0)
        launch(pdl && n > 0, local_kernel, cuda::blocks_for(T + m, kBlock), kBlock, st, "local_kernel", dev,
               params.rotation_iterations);
      const int j = k - params.chebyshev_delay;
      omega = j < 0 ? 1.0 : (j == 0 ? 2.0 / (2.0 - rho2) : 4.0 / (4.0 - rho2 * omega));
      float* ra = k == 0 ? dev.rsq_first : nullptr;
      float* rb = k == K - 1 ? dev.rsq_last : nullptr;
      if (n > 0) {
        const int grid = cuda::blocks_for(static_cast<long long>(n) * kLanes, kBlock);
        if (chebyshev) launch(pdl, vertex_kernel<true>, grid, kBlock, st, "vertex_kernel", dev, float(omega), ra, rb);
        else launch(pdl, vertex_kernel<false>, grid, kBlock, st, "vertex_kernel", dev, 1.0f, ra, rb);
      }
    }
    if (n > 0) {
      launch(pdl, finish_kernel, cuda::blocks_for(n, kBlock), kBlock, st, "finish_kernel", dev);
      if (K > 0) {
        launch(pdl, residual_kernel, 1, kReduceThreads, st, "residual_kernel", dev);
        EBH_CUDA_CHECK(cudaMemcpyAsync(residual_host.get(), residual_sq.get(), 2 * sizeof(double),
                                       cudaMemcpyDeviceToHost, st));
      }
      EBH_CUDA_CHECK(cudaMemcpyAsync(x_host.get(), x.get(), n * sizeof(Vec3f), cudaMemcpyDeviceToHost, st));
    }
  } catch (...) {
    cudaGraph_t broken = nullptr;
    cudaStreamEndCapture(st, &broken);  // leave capture mode whatever failed
    if (broken) cudaGraphDestroy(broken);
    throw;
  }
  EBH_CUDA_CHECK(cudaStreamEndCapture(st, &graph));
  EBH_CUDA_CHECK(cudaGraphInstantiate(&exec, graph, 0));
  programmatic = pdl;
}

void CudaPhysicalSolver::Impl::prepare_persistent() {
  int device = 0, coop = 0, sms = 0;
  EBH_CUDA_CHECK(cudaGetDevice(&device));
  EBH_CUDA_CHECK(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, device));
  EBH_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  const bool chebyshev = params.method == SolverSpec::Method::Chebyshev;
  int per_sm = 0;
  EBH_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
      &per_sm, chebyshev ? persistent_step_kernel<true> : persistent_step_kernel<false>, kReduceThreads, 0));
  cooperative_supported = coop != 0 && per_sm > 0 && n > 0;
  if (!cooperative_supported) return;
  // Enough blocks for the widest stage, at most what can be resident at once (a grid barrier needs
  // every block resident).
  const long long widest = std::max<long long>({static_cast<long long>(T) + m, static_cast<long long>(n) * kLanes, n});
  persistent_blocks = static_cast<int>(std::min<long long>(static_cast<long long>(sms) * per_sm,
                                                           (widest + kReduceThreads - 1) / kReduceThreads));
  persistent_blocks = std::max(persistent_blocks, 1);
  // The Chebyshev weights exactly as the graph computes them (double, then float per launch).
  const int K = params.iterations;
  std::vector<float> w(std::max(K, 1), 1.0f);
  const double rho2 = params.chebyshev_rho * params.chebyshev_rho;
  double om = 1;
  for (int k = 0; k < K; ++k) {
    const int j = k - params.chebyshev_delay;
    om = j < 0 ? 1.0 : (j == 0 ? 2.0 / (2.0 - rho2) : 4.0 / (4.0 - rho2 * om));
    w[k] = chebyshev ? float(om) : 1.0f;
  }
  omega.allocate(w.size());
  omega.upload(w.data(), stream.get());
}

void CudaPhysicalSolver::Impl::launch_persistent() {
  cudaStream_t st = stream.get();
  if (m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(q.get(), q_host.get(), m * sizeof(Vec3f), cudaMemcpyHostToDevice, st));
  const float* w = omega.get();
  int K = params.iterations, rot = params.rotation_iterations;
  void* args[] = {&dev, &w, &K, &rot};
  const bool chebyshev = params.method == SolverSpec::Method::Chebyshev;
  EBH_CUDA_CHECK(cudaLaunchCooperativeKernel(
      chebyshev ? reinterpret_cast<void*>(persistent_step_kernel<true>) : reinterpret_cast<void*>(persistent_step_kernel<false>),
      dim3(persistent_blocks), dim3(kReduceThreads), args, 0, st));
  EBH_CUDA_LAUNCH_CHECK(st, "persistent_step_kernel");
  if (K > 0)
    EBH_CUDA_CHECK(cudaMemcpyAsync(residual_host.get(), residual_sq.get(), 2 * sizeof(double), cudaMemcpyDeviceToHost, st));
  EBH_CUDA_CHECK(cudaMemcpyAsync(x_host.get(), x.get(), n * sizeof(Vec3f), cudaMemcpyDeviceToHost, st));
}

CudaPhysicalSolver::CudaPhysicalSolver(const PhysicalModel& model, const PhysicalStepParams& params)
    : impl_(std::make_unique<Impl>()) {
  if (params.method == SolverSpec::Method::Direct)
    throw InputError("--backend cuda: the direct method runs on the CPU only (use jacobi or chebyshev)");
  if (params.iterations < 0) throw InputError("physical iterations must not be negative");
  impl_->params = params;
  impl_->upload_model(model);
  upload_state(make_physical_state(model));
  // The cooperative single-kernel step only on request (EBH_CUDA_PERSISTENT=1): on the H100 it took
  // 468 us against the graph's 350 us for cholecystectomy (docs/CUDA.md), so the graph stays the
  // default; both give bitwise the same x.
  impl_->prepare_persistent();
  const char* persistent_env = std::getenv("EBH_CUDA_PERSISTENT");
  impl_->persistent = impl_->cooperative_supported && persistent_env && std::string(persistent_env) == "1";
  // Programmatic dependent launch in the graph where the driver takes it (EBH_CUDA_PDL=0 turns it
  // off, for comparison); plain kernel nodes otherwise.
  const char* env = std::getenv("EBH_CUDA_PDL");
  const bool want_pdl = !(env && std::string(env) == "0");
  if (want_pdl) {
    try {
      impl_->capture(true);
      return;
    } catch (const std::runtime_error&) {
      cudaGetLastError();  // clear the failed launch's error and fall back
      if (impl_->exec) { cudaGraphExecDestroy(impl_->exec); impl_->exec = nullptr; }
      if (impl_->graph) { cudaGraphDestroy(impl_->graph); impl_->graph = nullptr; }
    }
  }
  impl_->capture(false);
}

CudaPhysicalSolver::~CudaPhysicalSolver() = default;

const PhysicalStepParams& CudaPhysicalSolver::params() const { return impl_->params; }

double CudaPhysicalSolver::last_device_seconds() const { return impl_->device_s; }

bool CudaPhysicalSolver::programmatic_launch() const { return impl_->programmatic; }

bool CudaPhysicalSolver::persistent_kernel() const { return impl_->persistent; }

void CudaPhysicalSolver::set_persistent_kernel(bool on) { impl_->persistent = on && impl_->cooperative_supported; }

void CudaPhysicalSolver::upload_state(const PhysicalState& state) {
  Impl& I = *impl_;
  if (state.x.size() != size_t(I.n) || state.v.size() != size_t(I.n) || state.rotation.size() != size_t(I.T))
    throw std::invalid_argument("CudaPhysicalSolver::upload_state: state sizes do not match the model");
  std::vector<Vec3f> x(I.n), v(I.n);
  std::vector<Quatf> r(I.T);
  for (int a = 0; a < I.n; ++a) { x[a] = to_float(state.x[a]); v[a] = to_float(state.v[a]); }
  for (int t = 0; t < I.T; ++t) r[t] = to_float(state.rotation[t]);
  I.x.upload(x.data(), I.stream.get());
  I.v.upload(v.data(), I.stream.get());
  I.rotation.upload(r.data(), I.stream.get());
}

void CudaPhysicalSolver::download_state(PhysicalState& state) const {
  const Impl& I = *impl_;
  std::vector<Vec3f> x(I.n), v(I.n);
  std::vector<Quatf> r(I.T);
  I.x.download(x.data(), I.stream.get());
  I.v.download(v.data(), I.stream.get());
  I.rotation.download(r.data(), I.stream.get());
  state.x.resize(I.n);
  state.v.resize(I.n);
  state.rotation.resize(I.T);
  for (int a = 0; a < I.n; ++a) { state.x[a] = static_cast<Vec3d>(x[a]); state.v[a] = static_cast<Vec3d>(v[a]); }
  for (int t = 0; t < I.T; ++t) state.rotation[t] = Quatd{r[t].w, r[t].x, r[t].y, r[t].z};
}

PhysicalStepReport CudaPhysicalSolver::step(PhysicalState& state, std::span<const Vec3d> virtual_q) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  Impl& I = *impl_;
  if (I.m > 0 && virtual_q.size() != size_t(I.m))
    throw std::invalid_argument("CudaPhysicalSolver::step: virtual_q has the wrong size");
  for (int j = 0; j < I.m; ++j) I.q_host[j] = to_float(virtual_q[j]);
  EBH_CUDA_CHECK(cudaEventRecord(I.start, I.stream.get()));
  if (I.persistent)
    I.launch_persistent();
  else
    EBH_CUDA_CHECK(cudaGraphLaunch(I.exec, I.stream.get()));
  EBH_CUDA_CHECK(cudaEventRecord(I.stop, I.stream.get()));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream.get()));
  float ms = 0;
  EBH_CUDA_CHECK(cudaEventElapsedTime(&ms, I.start, I.stop));
  I.device_s = 1e-3 * ms;
  state.x.resize(I.n);
  for (int a = 0; a < I.n; ++a) state.x[a] = static_cast<Vec3d>(I.x_host[a]);
  PhysicalStepReport report;
  report.iterations = I.params.iterations;
  if (I.params.iterations > 0 && I.n > 0) {
    const double r0 = std::sqrt(I.residual_host[0]), rk = std::sqrt(I.residual_host[1]);
    report.residual = r0 > 0 ? rk / r0 : 0.0;
  }
  report.time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return report;
}

}  // namespace ebh
