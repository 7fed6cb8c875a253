// Host entry points to newton_warp.cuh (newton_warp.hpp): one warp per call.
#include "tool/newton_warp.hpp"

#include <vector>

#include "tool/newton_warp.cuh"
#include "solver/cuda_util.cuh"

namespace ebh {
namespace {

__global__ void psd_clamp_kernel(const double* upper_in, double* upper_out) {
  __shared__ float scratch[42];
  const int lane = threadIdx.x;
  const double h = cuda::warp_psd_clamp(lane < 21 ? upper_in[lane] : 0.0, lane, scratch);
  if (lane < 21) upper_out[lane] = h;
}

__global__ void cholesky_kernel(const double* upper_in, const double* b, double* x, int* ok) {
  const int lane = threadIdx.x;
  double xk = 0;
  const bool good = cuda::warp_cholesky_solve(lane < 21 ? upper_in[lane] : 0.0, lane < 6 ? b[lane] : 0.0, lane, xk);
  if (lane < 6) x[lane] = xk;
  if (lane == 0) *ok = good;
}

__global__ void clamped_solve_kernel(const double* upper_in, const double* diag, const double* b, double* x, int* ok) {
  __shared__ float scratch[42];
  const int lane = threadIdx.x;
  int i = 0, j = 0;
  cuda::upper_entry(lane < 21 ? lane : 0, i, j);
  bool factored = false;
  const double u = cuda::warp_clamped_factor(lane < 21 ? upper_in[lane] : 0.0, lane < 21 && i == j ? diag[i] : 0.0,
                                             lane, scratch, factored);
  double xk = 0;
  const bool good = cuda::warp_cholesky_solve_factored(u, factored, lane < 6 ? b[lane] : 0.0, lane, xk);
  if (lane < 6) x[lane] = xk;
  if (lane == 0) *ok = good;
}

std::vector<double> upper_of(const Mat6& H) {
  std::vector<double> u;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) u.push_back(H(i, j));
  return u;
}

}  // namespace

Mat6 device_psd_clamp(const Mat6& H) {
  cuda::DeviceArray<double> in, out;
  const std::vector<double> u = upper_of(H);
  in.allocate(21);
  out.allocate(21);
  in.upload(u.data(), nullptr);
  psd_clamp_kernel<<<1, 32>>>(in.get(), out.get());
  EBH_CUDA_LAUNCH_CHECK(nullptr, "psd_clamp_kernel");
  std::vector<double> r(21);
  out.download(r.data(), nullptr);
  EBH_CUDA_CHECK(cudaDeviceSynchronize());
  Mat6 M;
  for (int i = 0, e = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j, ++e) M(i, j) = M(j, i) = r[e];
  return M;
}

namespace {

/// One warp of `solve` (cholesky_kernel or clamped_solve_kernel) on H's upper triangle, the
/// diagonal d and b: x, and whether the solve reported success.
template <class Launch>
Vec6 run_solve(const Mat6& H, const Vec6& d, const Vec6& b, bool& ok, Launch solve) {
  cuda::DeviceArray<double> in, dg, rhs, x;
  cuda::DeviceArray<int> good;
  const std::vector<double> u = upper_of(H);
  const std::vector<double> dv(d.data(), d.data() + 6), bv(b.data(), b.data() + 6);
  in.allocate(21);
  dg.allocate(6);
  rhs.allocate(6);
  x.allocate(6);
  good.allocate(1);
  in.upload(u.data(), nullptr);
  dg.upload(dv.data(), nullptr);
  rhs.upload(bv.data(), nullptr);
  solve(in.get(), dg.get(), rhs.get(), x.get(), good.get());
  std::vector<double> xv(6);
  int g = 0;
  x.download(xv.data(), nullptr);
  good.download(&g, nullptr);
  EBH_CUDA_CHECK(cudaDeviceSynchronize());
  ok = g != 0;
  Vec6 r;
  for (int k = 0; k < 6; ++k) r[k] = xv[k];
  return r;
}

}  // namespace

Vec6 device_cholesky_solve(const Mat6& H, const Vec6& b, bool& ok) {
  return run_solve(H, Vec6::Zero(), b, ok, [](const double* in, const double*, const double* rhs, double* x, int* good) {
    cholesky_kernel<<<1, 32>>>(in, rhs, x, good);
    EBH_CUDA_LAUNCH_CHECK(nullptr, "cholesky_kernel");
  });
}

Vec6 device_clamped_solve(const Mat6& H, const Vec6& d, const Vec6& b, bool& ok) {
  return run_solve(H, d, b, ok, [](const double* in, const double* dg, const double* rhs, double* x, int* good) {
    clamped_solve_kernel<<<1, 32>>>(in, dg, rhs, x, good);
    EBH_CUDA_LAUNCH_CHECK(nullptr, "clamped_solve_kernel");
  });
}

}  // namespace ebh
