#pragma once
// The sample points of surface contact (surface_contact.hpp; docs/MODEL.md, "Contact against the
// surface"), host/device: one definition of a triangle's sample rows, its samples' E_con weight and
// their barycentric coordinates, which the CPU (surface_contact.cpp) and the device tick
// (schedule/haptic_cuda_surface.cuh) both call. A triangle's corners come in as plain positions
// (a, b, c), so each backend gathers them from its own arrays.
//
// A triangle carries the centroids of the n x n sub-triangles of its regular subdivision, n from
// its longest edge and the samples' spacing (the tool's thinnest part); a sample y = b0 a + b1 b +
// b2 c inside a collider is one contact of the paper's E_con [3] with stiffness w k_con,
//     w = stiffness_factor (area / n^2) / (sqrt(3)/4 spacing^2).
// (The rounded boxes of surface contact are Collider::radius on a box: collider.hpp, already
// host/device.)
#include "math/hd.hpp"
#include "math/vec.hpp"

namespace ebh {

/// Most sample rows per triangle (n <= kMaxSampleLevel: at most 4096 samples per triangle): a
/// triangle up to 64 sample spacings long (64 mm for a 1 mm tip) keeps the no-tunnelling bound.
inline constexpr int kMaxSampleLevel = 64;

/// ceil(length / spacing) as a row count: clamped to [1, kMaxSampleLevel].
EBH_HD int clamp_sample_level(double n) {
  return n < 1 ? 1 : (n > kMaxSampleLevel ? kMaxSampleLevel : static_cast<int>(n));
}

/// The longest edge of the triangle (a, b, c).
EBH_HD double triangle_longest_edge(Vec3d a, Vec3d b, Vec3d c) {
  return EBH_SQRT(fmax(fmax(squared_norm(b - a), squared_norm(c - b)), squared_norm(a - c)));
}

/// The sample rows n of a triangle with corners (a, b, c) now and `rest_level` rows at rest:
/// ceil(longest edge / spacing) at rest or now, whichever is more (at most kMaxSampleLevel), so the
/// samples stay within sqrt(3)/3 spacing of every point of a stretched triangle.
EBH_HD int surface_sample_level(int rest_level, double spacing, Vec3d a, Vec3d b, Vec3d c) {
  const int stretched = clamp_sample_level(ceil(triangle_longest_edge(a, b, c) / spacing));
  return rest_level > stretched ? rest_level : stretched;
}

/// The E_con weight of each of the n^2 samples of the triangle (a, b, c): its share of the
/// surface in units of an equilateral triangle of edge `spacing`, times `stiffness_factor`.
EBH_HD double surface_sample_weight(double stiffness_factor, double spacing, int n, Vec3d a, Vec3d b, Vec3d c) {
  const double area = 0.5 * norm(cross(b - a, c - a));
  const double reference = 0.25 * EBH_SQRT(3.0) * spacing * spacing;
  return stiffness_factor * area / (static_cast<double>(n) * n * reference);
}

/// Calls f(b0, b1, b2) for the n^2 sample points of a triangle, in a fixed order: the centroids of
/// the regular subdivision's "up" sub-triangles, corners (i, j), (i+1, j), (i, j+1) in units of 1/n
/// along the edges from corner 0 to corners 1 and 2, each followed by the "down" one (i+1, j),
/// (i, j+1), (i+1, j+1) where there is one.
#if defined(__CUDACC__)
#pragma nv_exec_check_disable
#endif
template <class F>
EBH_HD void for_each_sample(int n, F&& f) {
  const double inv = 1.0 / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; i + j < n; ++j) {
      const double b1 = (i + 1.0 / 3.0) * inv, b2 = (j + 1.0 / 3.0) * inv;
      f(1.0 - b1 - b2, b1, b2);
      if (i + j + 1 < n) {
        const double c1 = (i + 2.0 / 3.0) * inv, c2 = (j + 2.0 / 3.0) * inv;
        f(1.0 - c1 - c2, c1, c2);
      }
    }
}

/// The k-th sample (0 <= k < n^2) of for_each_sample(n)'s order: its barycentric coordinates, in
/// double bitwise as for_each_sample gives them (float: for float tests with slack). Row i of the
/// order holds 2 (n - i) - 1 samples, i (2n - i) before it; within the row, sample r is the "up"
/// one of column r / 2 (r even) or the "down" one.
template <class T>
EBH_HD void sample_barycentric(int n, int k, T& b0, T& b1, T& b2) {
  int i = static_cast<int>(n - EBH_SQRT(static_cast<T>(n) * n - k));  // the row, up to rounding
  if (i < 0) i = 0;
  if (i > n - 1) i = n - 1;
  while (i > 0 && i * (2 * n - i) > k) --i;
  while (i + 1 < n && (i + 1) * (2 * n - i - 1) <= k) ++i;
  const int r = k - i * (2 * n - i), j = r / 2;
  const T inv = T(1) / n;
  if (r % 2 == 0) {
    b1 = (i + T(1) / T(3)) * inv;
    b2 = (j + T(1) / T(3)) * inv;
  } else {
    b1 = (i + T(2) / T(3)) * inv;
    b2 = (j + T(2) / T(3)) * inv;
  }
  b0 = T(1) - b1 - b2;
}

/// The sample point b0 a + b1 b + b2 c.
EBH_HD Vec3d surface_sample_point(double b0, double b1, double b2, Vec3d a, Vec3d b, Vec3d c) {
  return b0 * a + b1 * b + b2 * c;
}

/// The triangle's bounding sphere about its centroid: the centroid, and (returned) the radius.
EBH_HD double triangle_bounding_sphere(Vec3d a, Vec3d b, Vec3d c, Vec3d& mid) {
  mid = (a + b + c) / 3.0;
  return EBH_SQRT(fmax(fmax(squared_norm(a - mid), squared_norm(b - mid)), squared_norm(c - mid)));
}

}  // namespace ebh
