#pragma once
// Rigid transforms of device poses (docs/FORMATS.md): a device log uses its own world frame (the
// device's workspace) and its own tool frame (a Geomagic Touch's stylus +z points back toward the
// handle, and the logged point is the gimbal, a few cm behind the tip). Two transforms map a
// logged pose (p, q) to ebh's:
//   world transform (t_w, q_w), on the left:  applied in the world frame (the workspace -> the scene)
//   tool transform  (t_T, q_T), on the right: applied in the tool's own frame (the stylus -> ebh's tool)
//   p' = R(q_w) (p + R(q) t_T) + t_w,   q' = q_w q q_T
// The tool transform alone is p' = p + q t_T, q' = q q_T; the world transform alone is
// p' = R p + t, q' = q_R q. Used by `ebh import` (--transform, --tool-transform) and replay
// (the same options, and a recording's world_transform / tool_transform attributes). The options'
// text is parsed by parse_rigid_transform (io/import.hpp).
#include <optional>
#include <string>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

/// x -> R(rotation) x + translation.
struct RigidTransform {
  Vec3d translation;  ///< m
  Quatd rotation;     ///< unit quaternion (w, x, y, z)
};

/// The longest translation a transform may have, m: a scene is at most 2 m across and a device's
/// workspace smaller, so 100 m is no placement of one at the other but a unit or typing mistake (and
/// near 1e308 the poses' coordinates overflow: "the tool lies inf m outside the scene").
inline constexpr double kMaxTranslationM = 100;

/// "" for a translation (m) a transform may have, else why not ("the translation is 1e+308 m long;
/// give one of at most 100 m (a scene is at most 2 m across)"), for the caller to put after its
/// option or attribute.
std::string translation_problem(Vec3d translation_m);

/// The transforms applied to a trajectory's poses; an empty one is the identity.
struct PoseTransforms {
  std::optional<RigidTransform> world;  ///< on the left, in the world frame
  std::optional<RigidTransform> tool;   ///< on the right, in the tool's own frame
  bool empty() const { return !world && !tool; }
};

/// Applies `tr` to every pose (p[i], q[i]) in place (formula above). Orientations are unit
/// quaternions; the result is one too.
void apply_pose_transforms(const PoseTransforms& tr, std::vector<Vec3d>& position, std::vector<Quatd>& orientation);

/// Turns poses logged in a left-handed frame into the right-handed frame whose `axis` (0 x, 1 y,
/// 2 z) runs the other way: that coordinate of every position negated, and every orientation
/// mirrored alike (R -> M R M, M the reflection: a quaternion's other two vector components
/// negated), which keeps it a rotation. No rigid transform can do it (its determinant is -1).
void mirror_poses(int axis, std::vector<Vec3d>& position, std::vector<Quatd>& orientation);
/// The axis a --mirror names ("x", "y", "z"): 0, 1, 2; throws InputError otherwise.
int parse_mirror_axis(const std::string& text);

/// One line: "translation (0, 0, -0.04) m, rotation vector (180, 0, 0) deg".
std::string describe(const RigidTransform& t);

/// A transform as stored in a file's attribute: 7 numbers, translation in metres then the unit
/// quaternion (tx, ty, tz, qw, qx, qy, qz) — the layout of a replay's poses.
std::vector<double> to_attribute(const RigidTransform& t);
/// The reverse; throws InputError "WHERE: attribute NAME: ..." for a wrong length, a non-finite
/// number or a quaternion whose norm is off by more than 1e-3 (smaller errors are normalised).
RigidTransform from_attribute(const std::vector<double>& v, const std::string& where, const std::string& name);

}  // namespace ebh
