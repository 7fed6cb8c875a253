#pragma once
// The CUDA device as the rest of ebh sees it (no CUDA types: this header compiles without nvcc;
// its functions exist when the build has the CUDA backend, EBH_HAVE_CUDA).
#include <string>

namespace ebh {

/// True when a CUDA device can be used; otherwise false and `why` (if given) says why in a few
/// words ("no CUDA device", or the driver's error).
bool cuda_device_available(std::string* why = nullptr);

/// "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)" for device 0; throws std::runtime_error without one.
std::string cuda_device_description();

}  // namespace ebh
