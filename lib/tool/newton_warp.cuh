#pragma once
// The virtual tool's 6x6 linear algebra on one warp (the device Newton step,
// schedule/haptic_cuda.cu; its CPU twin is virtual_tool.cpp's energy_at and update_virtual_tool).
// A symmetric 6x6 matrix lives in registers, lane e < 21 holding upper entry e in row order
// (upper(i, j), i <= j); every lane of the warp calls these functions together (shuffles, no
// shared memory but the clamp's scratch).
//
//   warp_psd_clamp      V max(Lambda, 0) V^T: the 6x6 PSD clamp, by cyclic Jacobi in float32
//                       (H itself when a Cholesky factorisation shows it positive definite)
//   warp_cholesky_solve x = H^-1 b for a symmetric positive definite H, in double
//   warp_clamped_factor the Newton step's PSD(H) + diag factored, the definiteness test of H and
//                       the factorisation of H + diag interleaved (warp_cholesky_solve_factored)
//
// Shuffle chains instead of one thread's loops: the Newton step is a latency chain on one SM,
// and a 6x6 by one thread pays every division, square root and shared-memory load in turn.
#include <cuda_runtime.h>

namespace ebh::cuda {

/// Upper-triangle index of (i, j), i <= j, in row order (0 .. 20).
__device__ __forceinline__ int upper(int i, int j) { return i * 6 - i * (i - 1) / 2 + (j - i); }
/// upper() of (min, max): the entry (i, j) of a symmetric matrix.
__device__ __forceinline__ int sym(int i, int j) { return i <= j ? upper(i, j) : upper(j, i); }
/// (i, j), i <= j, of upper entry e (e < 21).
__device__ __forceinline__ void upper_entry(int e, int& i, int& j) {
  i = 0;
  while (i < 5 && upper(i + 1, i + 1) <= e) ++i;
  j = i + (e - upper(i, i));
}

/// Jacobi round-robin pairing of 6 indices: partner of i in round r (5 rounds cover the 15 pairs).
__device__ __forceinline__ int jacobi_partner(int r, int i) {
  // Rows: {1,0,5,4,3,2} {2,3,0,1,5,4} {3,5,4,0,2,1} {4,2,1,5,0,3} {5,4,3,2,1,0}, 3 bits per entry.
  constexpr unsigned long long kTable[5] = {
      (1ull << 0) | (0ull << 3) | (5ull << 6) | (4ull << 9) | (3ull << 12) | (2ull << 15),
      (2ull << 0) | (3ull << 3) | (0ull << 6) | (1ull << 9) | (5ull << 12) | (4ull << 15),
      (3ull << 0) | (5ull << 3) | (4ull << 6) | (0ull << 9) | (2ull << 12) | (1ull << 15),
      (4ull << 0) | (2ull << 3) | (1ull << 6) | (5ull << 9) | (0ull << 12) | (3ull << 15),
      (5ull << 0) | (4ull << 3) | (3ull << 6) | (2ull << 9) | (1ull << 12) | (0ull << 15)};
  return static_cast<int>((kTable[r] >> (3 * i)) & 7u);
}

/// The clamp's Jacobi stops when every off-diagonal is below 2^-21 (~4 float round-offs) of the
/// largest diagonal entry, checked before each sweep, or after kMaxJacobiSweeps. Random 6x6
/// matrices with eigenvalues of both signs from 1e-2 to 1e4 need 4-5 sweeps (mean 3.9); a fixed 4
/// left some of them 3e-4 of their norm away from the clamp (tests/cuda: CudaNewton).
inline constexpr int kMaxJacobiSweeps = 8;
inline constexpr float kJacobiTolerance = 0x1p-21f;

/// Cholesky factorisations H = U^T U in double of N symmetric matrices at once (their chains
/// interleave), upper entry e of matrix m on lane e < 21 in u[m] ((i, j): that entry's row and
/// column): returns in u[m] (lane e) U's upper entry e, its diagonal holding 1 / U(c, c); ok[m] (on
/// every lane) whether every pivot was positive.
template <int N>
__device__ inline void warp_cholesky_factors(double (&u)[N], int lane, int i, int j, bool (&ok)[N]) {
#pragma unroll
  for (int m = 0; m < N; ++m) {
    if (lane >= 21) u[m] = 0.0;
    ok[m] = true;
  }
#pragma unroll
  for (int c = 0; c < 6; ++c) {
#pragma unroll
    for (int m = 0; m < N; ++m) {
      const double d = __shfl_sync(~0u, u[m], upper(c, c));
      ok[m] = ok[m] && d > 0.0;
      const double inv = rsqrt(fmax(d, 1e-300));  // no division; a non-positive pivot fails
      if (i == c) u[m] = j == c ? inv : u[m] * inv;  // row c of U
    }
#pragma unroll
    for (int m = 0; m < N; ++m) {
      const double uci = __shfl_sync(~0u, u[m], upper(c, max(i, c))), ucj = __shfl_sync(~0u, u[m], upper(c, max(j, c)));
      if (i > c) u[m] -= uci * ucj;  // the trailing block: H(i, j) - U(c, i) U(c, j)
    }
  }
}

/// warp_cholesky_factors of one matrix.
__device__ inline double warp_cholesky_factor(double h, int lane, int i, int j, bool& ok) {
  double u[1] = {h};
  bool oks[1];
  warp_cholesky_factors(u, lane, i, j, oks);
  ok = oks[0];
  return u[0];
}

/// The cyclic Jacobi part of warp_psd_clamp (h neither zero nor positive definite); (i, j): lane's
/// upper entry.
__device__ inline double warp_jacobi_clamp(double h, int lane, int i, int j, float* scratch, int* sweeps);

/// The PSD clamp of virtual_tool.cpp's H_step: returns (lane e < 21) upper entry e of
/// V max(Lambda, 0) V^T for the symmetric matrix whose upper entry e lane e holds in `h`, by a cyclic
/// Jacobi eigen-decomposition in float32 (round r rotates the three disjoint pairs of
/// jacobi_partner at once: A' = J^T A J, V' = V J; Numerical Recipes' rotation; sweeps until
/// kJacobiTolerance), the product in double. A zero matrix is returned as is, and so is one whose
/// Cholesky factorisation in double succeeds: positive definite, its own clamp (the factorisation
/// is backward stable, so H is within double round-off of a positive definite matrix, far below
/// the float32 Jacobi's error). `scratch`: 42 floats of shared memory for this warp; `sweeps`
/// (optional): the sweeps the Jacobi took, -1 when H was positive definite.
__device__ inline double warp_psd_clamp(double h, int lane, float* scratch, int* sweeps = nullptr) {
  if (sweeps) *sweeps = 0;
  if (__ballot_sync(~0u, lane < 21 && h != 0.0) == 0u) return h;  // no contact Hessian
  int i = 0, j = 0;
  upper_entry(lane < 21 ? lane : 0, i, j);
  bool pd = false;
  warp_cholesky_factor(h, lane, i, j, pd);
  if (pd) {
    if (sweeps) *sweeps = -1;
    return lane < 21 ? h : 0.0;
  }
  return warp_jacobi_clamp(h, lane, i, j, scratch, sweeps);
}

/// The Newton step's matrix PSD(h) + diag factored (warp_cholesky_factors' layout), h as
/// warp_psd_clamp's and diag the added diagonal (lane e < 21: zero off the diagonal). The test of
/// h and the factorisation of h + diag run as one interleaved pair, so a positive definite h (its
/// own clamp) costs one factorisation's latency; otherwise the Jacobi clamp, then the
/// factorisation. The same bits as warp_psd_clamp, + diag, warp_cholesky_factor. `ok`: every
/// pivot positive; `sweeps` as warp_psd_clamp's.
__device__ inline double warp_clamped_factor(double h, double diag, int lane, float* scratch, bool& ok,
                                             int* sweeps = nullptr) {
  if (sweeps) *sweeps = 0;
  int i = 0, j = 0;
  upper_entry(lane < 21 ? lane : 0, i, j);
  const bool zero = __ballot_sync(~0u, lane < 21 && h != 0.0) == 0u;  // no contact Hessian: as is
  double u[2] = {h, h + diag};
  bool pd[2];
  warp_cholesky_factors(u, lane, i, j, pd);
  if (zero || pd[0]) {
    if (sweeps && !zero) *sweeps = -1;
    ok = pd[1];
    return u[1];
  }
  return warp_cholesky_factor(warp_jacobi_clamp(h, lane, i, j, scratch, sweeps) + diag, lane, i, j, ok);
}

__device__ inline double warp_jacobi_clamp(double h, int lane, int i, int j, float* scratch, int* sweeps) {
  float a = static_cast<float>(h);
  // V, row-major 6x6: lane l owns entries l and l + 32 (the second for lanes 0-3 only).
  const int e1 = min(lane + 32, 35);
  const int v0i = lane / 6, v0j = lane % 6, v1i = e1 / 6, v1j = e1 % 6;
  float v0 = v0i == v0j ? 1.f : 0.f, v1 = v1i == v1j ? 1.f : 0.f;
  const int k = lane < 6 ? lane : 0;  // index whose rotation lane k computes
  // The shuffle sources of each round, packed 5 bits each (all < 32) with 3 flags, computed once:
  // the sweeps then spend their instructions on the rotations, not on index arithmetic.
  unsigned long long src[5];
#pragma unroll
  for (int r = 0; r < 5; ++r) {
    const int pk = jacobi_partner(r, k), p = min(k, pk), q = max(k, pk);
    const int pi = jacobi_partner(r, i), pj = jacobi_partner(r, j);
    const int f0 = 6 * v0i + jacobi_partner(r, v0j), f1 = 6 * v1i + jacobi_partner(r, v1j);
    src[r] = static_cast<unsigned long long>(upper(p, p)) | static_cast<unsigned long long>(upper(q, q)) << 5 |
             static_cast<unsigned long long>(upper(p, q)) << 10 | static_cast<unsigned long long>(sym(i, pj)) << 15 |
             static_cast<unsigned long long>(sym(pi, j)) << 20 | static_cast<unsigned long long>(sym(pi, pj)) << 25 |
             static_cast<unsigned long long>(f0 & 31) << 30 | static_cast<unsigned long long>(f1 & 31) << 35 |
             static_cast<unsigned long long>(f0 >= 32) << 40 | static_cast<unsigned long long>(f1 >= 32) << 41 |
             static_cast<unsigned long long>(k < pk) << 42;
  }
  auto field = [](unsigned long long x, int at) { return static_cast<int>((x >> at) & 31u); };
  const bool diagonal_entry = lane < 21 && i == j, off_entry = lane < 21 && i != j;
  for (int sweep = 0; sweep < kMaxJacobiSweeps; ++sweep) {
    float off = off_entry ? fabsf(a) : 0.f, diag = diagonal_entry ? fabsf(a) : 0.f;
    for (int o = 16; o > 0; o >>= 1) {
      off = fmaxf(off, __shfl_xor_sync(~0u, off, o));
      diag = fmaxf(diag, __shfl_xor_sync(~0u, diag, o));
    }
    if (off <= kJacobiTolerance * diag) break;  // the same on every lane
    if (sweeps) ++*sweeps;
#pragma unroll
    for (int r = 0; r < 5; ++r) {
      const unsigned long long x = src[r];
      // The rotation of the pair (p, q) holding k (both of its lanes compute it, in the same order).
      const float app = __shfl_sync(~0u, a, field(x, 0)), aqq = __shfl_sync(~0u, a, field(x, 5));
      const float apq = __shfl_sync(~0u, a, field(x, 10));
      // A's neighbours of this round (independent of the rotation: issued before its math).
      const float a_ipj = __shfl_sync(~0u, a, field(x, 15)), a_pij = __shfl_sync(~0u, a, field(x, 20));
      const float a_pipj = __shfl_sync(~0u, a, field(x, 25));
      const float x00 = __shfl_sync(~0u, v0, field(x, 30)), x01 = __shfl_sync(~0u, v1, field(x, 30));
      const float x10 = __shfl_sync(~0u, v0, field(x, 35)), x11 = __shfl_sync(~0u, v1, field(x, 35));
      // Fast reciprocals (no IEEE division: its slow path, taken for zero or tiny operands, cost
      // more than the rest of the sweep); a pair already diagonal to float round-off is skipped.
      float c = 1.f, s = 0.f;
      const float g = fabsf(apq);
      if (g > 1e-30f && g > 1e-9f * (fabsf(app) + fabsf(aqq))) {
        const float th = __fdividef(aqq - app, 2.f * apq);
        const float at = fabsf(th);
        const float u = fmaf(th, th, 1.f);  // >= 1: sqrt(u) = u rsqrt(u)
        const float t = at > 1e18f ? __fdividef(0.5f, th) : copysignf(__fdividef(1.f, at + u * rsqrtf(u)), th);
        c = rsqrtf(fmaf(t, t, 1.f));
        s = t * c;
      }
      const float sk = (x >> 42) & 1u ? -s : s;  // J(p, q) = s, J(q, p) = -s: the coefficient of k's partner
      // A'(i, j) = c_i c_j A(i, j) + c_i s_j A(i, pj) + s_i c_j A(pi, j) + s_i s_j A(pi, pj)
      const float ci = __shfl_sync(~0u, c, i), si = __shfl_sync(~0u, sk, i);
      const float cj = __shfl_sync(~0u, c, j), sj = __shfl_sync(~0u, sk, j);
      // V'(x, y) = c_y V(x, y) + s_y V(x, py)
      const float c0 = __shfl_sync(~0u, c, v0j), s0 = __shfl_sync(~0u, sk, v0j);
      const float c1 = __shfl_sync(~0u, c, v1j), s1 = __shfl_sync(~0u, sk, v1j);
      a = ci * cj * a + ci * sj * a_ipj + si * cj * a_pij + si * sj * a_pipj;
      v0 = c0 * v0 + s0 * ((x >> 40) & 1u ? x01 : x00);
      v1 = c1 * v1 + s1 * ((x >> 41) & 1u ? x11 : x10);
    }
  }
  // V max(Lambda, 0) V^T in double, from V and the clamped eigenvalues in scratch.
  float* V = scratch;       // 36
  float* lambda = scratch + 36;  // 6
  V[lane] = v0;
  if (lane < 4) V[32 + lane] = v1;
  const float diag = __shfl_sync(~0u, a, upper(k, k));
  if (lane < 6) lambda[lane] = fmaxf(diag, 0.f);
  __syncwarp();
  double acc = 0;
#pragma unroll
  for (int m = 0; m < 6; ++m)
    acc += static_cast<double>(V[6 * i + m]) * static_cast<double>(lambda[m]) * static_cast<double>(V[6 * j + m]);
  __syncwarp();
  return lane < 21 ? acc : 0.0;
}

/// Solves U^T U x = b for U from warp_cholesky_factors (its diagonal holding 1 / U(c, c); lane
/// k < 6: b_k in `b`): x_k on lane k < 6. `ok`: the factorisation's; returns false (on every lane)
/// when it is false or x is not finite.
__device__ inline bool warp_cholesky_solve_factored(double u, bool ok, double b, int lane, double& x) {
  // Lane k < 6: column k of U (= row k), U(m, k) for m < k and U(k, m) for m > k; its inverse diagonal.
  const int k = lane < 6 ? lane : 5;
  double col[6];
#pragma unroll
  for (int m = 0; m < 6; ++m) col[m] = __shfl_sync(~0u, u, sym(m, k));
  const double inv_kk = __shfl_sync(~0u, u, upper(k, k));
  // U^T y = b (forward), then U x = y (backward); lane k holds b_k, then y_k, then x_k.
  double r = b;
#pragma unroll
  for (int m = 0; m < 6; ++m) {
    const double ym = __shfl_sync(~0u, r * inv_kk, m);
    if (k > m) r -= col[m] * ym;
  }
  r *= inv_kk;
#pragma unroll
  for (int m = 5; m >= 0; --m) {
    const double xm = __shfl_sync(~0u, r * inv_kk, m);
    if (k < m) r -= col[m] * xm;
  }
  x = r * inv_kk;
  ok = ok && (lane >= 6 || isfinite(x));
  return __all_sync(~0u, ok);
}

/// Solves H x = b for the symmetric positive definite H (lane e < 21: upper entry e in `h`;
/// lane k < 6: b_k in `b`) by a Cholesky factorisation H = U^T U in double: x_k on lane k < 6.
/// Returns false (on every lane) when a pivot is not positive or x is not finite.
__device__ inline bool warp_cholesky_solve(double h, double b, int lane, double& x) {
  int i = 0, j = 0;
  upper_entry(lane < 21 ? lane : 0, i, j);
  bool ok = true;
  const double u = warp_cholesky_factor(h, lane, i, j, ok);
  return warp_cholesky_solve_factored(u, ok, b, lane, x);
}

}  // namespace ebh::cuda
