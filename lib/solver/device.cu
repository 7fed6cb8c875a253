// Device discovery for the CUDA backend.
#include <cuda_runtime.h>

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

std::string cuda_device_description() {
  std::string why;
  if (!cuda_device_available(&why)) throw std::runtime_error(why);
  cudaDeviceProp p{};
  EBH_CUDA_CHECK(cudaGetDeviceProperties(&p, 0));
  return std::string(p.name) + " (sm_" + std::to_string(p.major) + std::to_string(p.minor) + ", " +
         std::to_string(p.multiProcessorCount) + " SMs)";
}

}  // namespace ebh
