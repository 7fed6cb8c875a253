// Device discovery for the CUDA backend.
#include <cuda_runtime.h>

#include <algorithm>

#include "solver/cuda_util.cuh"
#include "solver/device_cuda.hpp"

namespace ebh {

bool cuda_device_available(std::string* why) {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e == cudaErrorNoDevice || (e == cudaSuccess && count == 0)) {
    cudaGetLastError();  // clear the sticky-free error state
    if (why) *why = "no CUDA device";
    return false;
  }
  if (e != cudaSuccess) {
    cudaGetLastError();
    if (why) *why = std::string("no CUDA device (") + cudaGetErrorName(e) + ": " + cudaGetErrorString(e) + ")";
    return false;
  }
  return true;
}

int cuda_device_count() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return count;
}

std::string cuda_device_description() {
  std::string why;
  if (!cuda_device_available(&why)) throw std::runtime_error(why);
  cudaDeviceProp p{};
  EBH_CUDA_CHECK(cudaGetDeviceProperties(&p, 0));
  return std::string(p.name) + " (sm_" + std::to_string(p.major) + std::to_string(p.minor) + ", " +
         std::to_string(p.multiProcessorCount) + " SMs)";
}

CudaMemory cuda_memory_info() {
  CudaMemory m;
  EBH_CUDA_CHECK(cudaMemGetInfo(&m.free, &m.total));
  return m;
}

std::vector<int> shared_memory_configs_kb(int major, int minor) {
  if (major == 9 && minor == 0) return {0, 8, 16, 32, 64, 100, 132, 164, 196, 228};  // H100, H200
  if (major == 8 && minor == 0) return {0, 8, 16, 32, 64, 100, 132, 164};            // A100
  if (major == 8 && (minor == 6 || minor == 9)) return {0, 8, 16, 32, 64, 100};
  return {};
}

int shared_carveout_percent(std::size_t need, std::size_t max_bytes, std::span<const int> configs_kb) {
  if (max_bytes == 0) return -1;
  std::vector<int> sorted(configs_kb.begin(), configs_kb.end());
  std::sort(sorted.begin(), sorted.end());
  for (const int kb : sorted) {
    const std::size_t bytes = std::size_t(kb) * 1024;
    if (bytes < need || bytes > max_bytes) continue;
    return static_cast<int>((100 * bytes + max_bytes - 1) / max_bytes);
  }
  return -1;
}

}  // namespace ebh
