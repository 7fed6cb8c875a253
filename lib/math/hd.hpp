#pragma once
// EBH_HD marks inline math that compiles for both the host and CUDA devices, so one
// definition of each energy serves the CPU and the CUDA backend (docs/CUDA.md, "One definition of the math").
#if defined(__CUDACC__)
#define EBH_HD __host__ __device__ __forceinline__
#else
#define EBH_HD inline
#endif

#if defined(__CUDA_ARCH__)
#define EBH_SQRT(x) sqrt(x)
#else
#include <algorithm>
#include <cmath>
#define EBH_SQRT(x) std::sqrt(x)
#endif

namespace ebh {

/// v clamped to [lo, hi] (lo <= hi): std::clamp on the host, fmin(fmax()) on a device. The two
/// agree but for a NaN v and the sign of a zero bound.
template <class T>
EBH_HD T clamp_between(T v, T lo, T hi) {
#if defined(__CUDA_ARCH__)
  return fmin(fmax(v, lo), hi);
#else
  return std::clamp(v, lo, hi);
#endif
}

}  // namespace ebh
