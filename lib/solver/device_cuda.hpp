#pragma once
// The CUDA device as the rest of ebh sees it (no CUDA types: this header compiles without nvcc;
// its functions exist when the build has the CUDA backend, EBH_HAVE_CUDA).
#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace ebh {

/// True when a CUDA device can be used; otherwise false and `why` (if given) says why in a few
/// words ("no CUDA device", or the driver's error).
bool cuda_device_available(std::string* why = nullptr);

/// The CUDA devices this process sees (those CUDA_VISIBLE_DEVICES leaves; 0 without any).
int cuda_device_count();

/// "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)" for device 0; throws std::runtime_error without one.
std::string cuda_device_description();

/// Device 0's memory as cudaMemGetInfo reports it (bytes; the context is created first): what a
/// run takes on the device is the drop in `free` while it runs (`ebh bench sizes`).
struct CudaMemory {
  std::size_t free = 0, total = 0;
};
CudaMemory cuda_memory_info();

/// The shared-memory capacities (KB) a multiprocessor of compute capability major.minor can be
/// configured to (CUDA C++ Programming Guide, the compute capabilities' "Shared Memory"
/// sections); empty when not known here.
std::vector<int> shared_memory_configs_kb(int major, int minor);

/// The carve-out (cudaFuncAttributePreferredSharedMemoryCarveout, percent) that configures a
/// multiprocessor with at least `need` bytes of shared memory and as much L1 as that leaves: the
/// percent of the smallest configuration that holds `need`, rounded up. The driver takes the
/// largest configuration at or below percent * max_bytes / 100 (measured on an H100: 57% gives
/// 100 KB, 58% gives 132 KB). -1 when no configuration holds `need`.
int shared_carveout_percent(std::size_t need, std::size_t max_bytes, std::span<const int> configs_kb);

}  // namespace ebh
