#include "render/camera.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/error.hpp"

namespace ebh {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// Near/far planes that hold the sphere (c, r) seen from eye with room for the tool in front of
/// it: far reaches 4 radii past the centre, near is 4 radii before it but never closer than 5% of
/// the distance (a 24-bit depth buffer keeps ~1e-5 of the range: ample at these ratios).
void fit_depth_range(ViewCamera& v, Vec3d c, double r) {
  const double d = norm(c - v.eye);
  const double rr = std::max(r, 1e-6);
  v.z_far = d + 4.0 * rr;
  v.z_near = std::max(0.05 * d, d - 4.0 * rr);
  if (!(v.z_near > 0)) v.z_near = 1e-4;
  if (!(v.z_far > v.z_near)) v.z_far = 2.0 * v.z_near + 4.0 * rr;
}

}  // namespace

Bounds bounds_of(const std::vector<Vec3f>& points) {
  Bounds b;
  bool any = false;
  for (const Vec3f& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const Vec3d q{p.x, p.y, p.z};
    b.min = any ? cwise_min(b.min, q) : q;
    b.max = any ? cwise_max(b.max, q) : q;
    any = true;
  }
  return b;
}

ViewCamera preset_camera(const std::string& name, const Bounds& b, double aspect, double fov_deg) {
  Vec3d dir, up{0, 0, 1};  // from the target to the eye
  if (name == "top") {
    dir = {0, 0, 1};
    up = {0, 1, 0};
  } else if (name == "front") {
    dir = {0, -1, 0};
  } else if (name == "side") {
    dir = {1, 0, 0};
  } else if (name == "iso") {
    dir = normalized(Vec3d{-1, -1, 1});
  } else {
    throw InputError("--camera: expected scene, top, front, side or iso, got '" + name + "'");
  }
  ViewCamera v;
  v.fov_deg = fov_deg;
  v.target = b.centre();
  v.up = up;
  // The distance: the smallest at which the box's eight corners project within the central 90%
  // of the image (bisection; projections shrink towards the centre as the eye backs away), never
  // more than the distance at which the bounding sphere fits.
  const double half_v = 0.5 * fov_deg * kDeg;
  const double half_h = std::atan(std::tan(half_v) * aspect);
  const double r = std::max(b.radius(), 1e-4);
  double lo = 0.0, hi = 1.1 * r / std::sin(std::min(half_v, half_h));
  auto fits = [&](double d) {
    ViewCamera t = v;
    t.eye = v.target + d * dir;
    fit_depth_range(t, v.target, r);
    const int W = 1000, H = std::max(1, static_cast<int>(std::lround(1000 / aspect)));
    for (int k = 0; k < 8; ++k) {
      const Vec3d c{(k & 1) ? b.max.x : b.min.x, (k & 2) ? b.max.y : b.min.y, (k & 4) ? b.max.z : b.min.z};
      if (dot(c - t.eye, v.target - t.eye) <= t.z_near * d) return false;  // at or behind the near plane
      const auto p = project(t, W, H, c);
      if (!p || (*p)[0] < 0.05 * W || (*p)[0] > 0.95 * W || (*p)[1] < 0.05 * H || (*p)[1] > 0.95 * H) return false;
    }
    return true;
  };
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (fits(mid) ? hi : lo) = mid;
  }
  v.eye = v.target + std::max(hi, 2.0 * r) * dir;
  fit_depth_range(v, v.target, r);
  return v;
}

ViewCamera scene_camera(const Camera& c, const Bounds& b) {
  ViewCamera v;
  v.eye = c.eye;
  v.target = c.target;
  v.up = c.up;
  v.fov_deg = c.fov_deg;
  fit_depth_range(v, b.centre(), b.radius());
  return v;
}

std::array<double, 16> view_matrix(const ViewCamera& c) {
  const Vec3d f = normalized(c.target - c.eye);
  // An `up` along the view direction leaves the image's roll undefined: the fallback up (world z,
  // or y for a view along z) is taken when the sine of their angle is under 1e-9. Round-off alone
  // (an up given parallel in decimal, [0, 76, -45.7] for eye - target = (0, -76, 45.7) mm) leaves
  // a sine of ~1e-16 times |eye| / |eye - target|, under 1e-12 for any scene camera, whose cross
  // product points anywhere (an upside-down image); 1e-9 rad is no tilt anyone means.
  const Vec3d side = cross(f, c.up);
  Vec3d s = normalized(side);
  if (!(norm(side) > 1e-9 * norm(c.up)))
    s = normalized(cross(f, std::abs(f.z) < 0.9 ? Vec3d{0, 0, 1} : Vec3d{0, 1, 0}));
  const Vec3d u = cross(s, f);
  // Rows s, u, -f; translation -R eye (gluLookAt).
  return {s.x, u.x, -f.x, 0, s.y, u.y, -f.y, 0, s.z, u.z, -f.z, 0,
          -dot(s, c.eye), -dot(u, c.eye), dot(f, c.eye), 1};
}

std::array<double, 16> projection_matrix(const ViewCamera& c, double aspect) {
  const double t = 1.0 / std::tan(0.5 * c.fov_deg * kDeg);
  const double n = c.z_near, fa = c.z_far;
  std::array<double, 16> m{};
  m[0] = t / aspect;
  m[5] = t;
  m[10] = (fa + n) / (n - fa);
  m[11] = -1.0;
  m[14] = 2.0 * fa * n / (n - fa);
  return m;
}

std::optional<std::array<double, 3>> project(const ViewCamera& c, int width, int height, Vec3d p) {
  const auto V = view_matrix(c);
  const auto P = projection_matrix(c, static_cast<double>(width) / height);
  const double in[4] = {p.x, p.y, p.z, 1.0};
  double e[4], clip[4];
  for (int r = 0; r < 4; ++r) e[r] = V[r] * in[0] + V[4 + r] * in[1] + V[8 + r] * in[2] + V[12 + r] * in[3];
  for (int r = 0; r < 4; ++r) clip[r] = P[r] * e[0] + P[4 + r] * e[1] + P[8 + r] * e[2] + P[12 + r] * e[3];
  if (!(clip[3] > 0)) return std::nullopt;
  const double x = clip[0] / clip[3], y = clip[1] / clip[3], z = clip[2] / clip[3];
  if (z < -1.0 || z > 1.0) return std::nullopt;
  return std::array<double, 3>{0.5 * (x + 1.0) * width, 0.5 * (1.0 - y) * height, 0.5 * (z + 1.0)};
}

}  // namespace ebh
