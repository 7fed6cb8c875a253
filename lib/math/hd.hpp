#pragma once
// EBH_HD marks inline math that compiles for both the host and CUDA devices, so one
// definition of each energy serves the CPU and the CUDA backend (DESIGN.md §6).
#if defined(__CUDACC__)
#define EBH_HD __host__ __device__ __forceinline__
#else
#define EBH_HD inline
#endif

#if defined(__CUDA_ARCH__)
#define EBH_SQRT(x) sqrt(x)
#else
#include <cmath>
#define EBH_SQRT(x) std::sqrt(x)
#endif
