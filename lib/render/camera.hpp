#pragma once
// Cameras for `ebh render`: the scene file's camera, or a preset framing a bounding box, and the
// pinhole projection the renderer uses (so a test can say where a world point lands in the image).
//
// Conventions: a right-handed world; the camera looks from `eye` at `target`, `up` is projected to
// the image's up direction; fov_deg is the vertical field of view. Pixel coordinates are (column,
// row) with row 0 at the top of the image and pixel (c, r) covering [c, c+1) x [r, r+1).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "math/vec.hpp"
#include "scene/scene.hpp"

namespace ebh {

struct Bounds {
  Vec3d min{}, max{};
  Vec3d centre() const { return 0.5 * (min + max); }
  double radius() const { return 0.5 * norm(max - min); }  ///< half the diagonal
};

/// Bounds of the finite points (a zero box at the origin when there are none).
Bounds bounds_of(const std::vector<Vec3f>& points);

struct ViewCamera {
  Vec3d eye{0, -1, 0}, target{}, up{0, 0, 1};
  double fov_deg = 40.0;  ///< vertical
  double z_near = 0.01, z_far = 10.0;
};

/// The preset names --camera accepts besides "scene".
inline const std::array<const char*, 4> kCameraPresets = {"top", "front", "side", "iso"};

/// A preset looking at `b` so that its bounding sphere fits an image of aspect width/height:
///   top   from +z (image up = +y)        front from -y (image up = +z)
///   side  from +x (image up = +z)        iso   from (-1, -1, 1) (image up = +z)
/// Throws InputError for an unknown name.
ViewCamera preset_camera(const std::string& name, const Bounds& b, double aspect, double fov_deg = 40.0);

/// The scene file's camera with near/far planes chosen for `b`.
ViewCamera scene_camera(const Camera& c, const Bounds& b);

/// Column-major 4x4 matrices (OpenGL's layout): world -> eye, eye -> clip.
std::array<double, 16> view_matrix(const ViewCamera& c);
std::array<double, 16> projection_matrix(const ViewCamera& c, double aspect);

/// Where world point p lands in a width x height image: (column, row, depth in [0, 1]); empty
/// when p is behind the camera or outside the near/far range.
std::optional<std::array<double, 3>> project(const ViewCamera& c, int width, int height, Vec3d p);

}  // namespace ebh
