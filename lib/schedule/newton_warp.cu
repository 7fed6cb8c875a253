// Host entry points to newton_warp.cuh (newton_warp.hpp): one warp per call.
#include "schedule/newton_warp.hpp"

#include <vector>

#include "schedule/newton_warp.cuh"
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

Vec6 device_cholesky_solve(const Mat6& H, const Vec6& b, bool& ok) {
  cuda::DeviceArray<double> in, rhs, x;
  cuda::DeviceArray<int> good;
  const std::vector<double> u = upper_of(H);
  const std::vector<double> bv(b.data(), b.data() + 6);
  in.allocate(21);
  rhs.allocate(6);
  x.allocate(6);
  good.allocate(1);
  in.upload(u.data(), nullptr);
  rhs.upload(bv.data(), nullptr);
  cholesky_kernel<<<1, 32>>>(in.get(), rhs.get(), x.get(), good.get());
  EBH_CUDA_LAUNCH_CHECK(nullptr, "cholesky_kernel");
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

}  // namespace ebh
