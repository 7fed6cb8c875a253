#pragma once
// Host entry points to the device Newton step's 6x6 linear algebra (newton_warp.cuh), for tests:
// each launches one warp on the current device and waits. No CUDA types here.
#include "tool/tool_energy.hpp"

namespace ebh {

/// V max(Lambda, 0) V^T of the symmetric H (its upper triangle is read), as the device tick's
/// warp_psd_clamp computes it (float32 Jacobi, the product in double).
Mat6 device_psd_clamp(const Mat6& H);

/// H^-1 b for a symmetric positive definite H (upper triangle read) by warp_cholesky_solve;
/// `ok` false when it reports a non-positive pivot or a non-finite result.
Vec6 device_cholesky_solve(const Mat6& H, const Vec6& b, bool& ok);

/// (PSD(H) + diag(d))^-1 b as the device tick's Newton step solves it (warp_clamped_factor, then
/// warp_cholesky_solve_factored); `ok` as device_cholesky_solve's.
Vec6 device_clamped_solve(const Mat6& H, const Vec6& d, const Vec6& b, bool& ok);

}  // namespace ebh
