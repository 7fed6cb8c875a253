#include "io/pose_transform.hpp"

#include <cfloat>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "core/error.hpp"
#include "io/recording.hpp"

namespace ebh {

void mirror_poses(int axis, std::vector<Vec3d>& position, std::vector<Quatd>& orientation) {
  for (Vec3d& p : position) {
    double& c = axis == 0 ? p.x : axis == 1 ? p.y : p.z;
    c = -c;
  }
  // M R M for the reflection M across the plane normal to `axis`: a rotation about `axis` stays
  // itself, one about another axis turns the other way.
  for (Quatd& q : orientation) {
    if (axis != 0) q.x = -q.x;
    if (axis != 1) q.y = -q.y;
    if (axis != 2) q.z = -q.z;
  }
}

int parse_mirror_axis(const std::string& text) {
  if (text == "x") return 0;
  if (text == "y") return 1;
  if (text == "z") return 2;
  throw InputError("--mirror: expected the axis that runs the other way, x, y or z, got '" + text + "'");
}

void apply_pose_transforms(const PoseTransforms& tr, std::vector<Vec3d>& position, std::vector<Quatd>& orientation) {
  for (std::size_t i = 0; i < position.size(); ++i) {
    Vec3d p = position[i];
    Quatd q = orientation[i];
    if (tr.tool) {  // in the tool's own frame: the offset turns with the tool
      p = p + rotate(q, tr.tool->translation);
      q = q * tr.tool->rotation;
    }
    if (tr.world) {
      p = rotate(tr.world->rotation, p) + tr.world->translation;
      q = tr.world->rotation * q;
    }
    position[i] = p;
    orientation[i] = q;
  }
}

std::string translation_problem(Vec3d t) {
  const double length = std::hypot(t.x, t.y, t.z);  // overflows only beyond the largest double
  if (length <= kMaxTranslationM) return "";
  char buf[128];
  std::snprintf(buf, sizeof buf, "the translation is %s%.4g m long; give one of at most %g m (a scene is at most 2 m across)",
                std::isfinite(length) ? "" : "over ", std::isfinite(length) ? length : DBL_MAX, kMaxTranslationM);
  return buf;
}

std::string describe(const RigidTransform& t) {
  const Vec3d r = rotvec_from_quat(t.rotation) * (180.0 / std::numbers::pi);
  char buf[160];
  std::snprintf(buf, sizeof buf, "translation (%.6g, %.6g, %.6g) m, rotation vector (%.6g, %.6g, %.6g) deg",
                t.translation.x, t.translation.y, t.translation.z, r.x, r.y, r.z);
  return buf;
}

std::vector<double> to_attribute(const RigidTransform& t) {
  return {t.translation.x, t.translation.y, t.translation.z, t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z};
}

RigidTransform from_attribute(const std::vector<double>& v, const std::string& where, const std::string& name) {
  const std::string at = where + ": attribute " + name + ": ";
  if (v.size() != 7)
    throw InputError(at + std::to_string(v.size()) +
                     " numbers, expected 7 (tx, ty, tz in metres, then the unit quaternion qw, qx, qy, qz)");
  for (std::size_t i = 0; i < 7; ++i)
    if (!std::isfinite(v[i])) throw InputError(at + "value " + std::to_string(i) + " is NaN or Inf");
  Quatd q{v[3], v[4], v[5], v[6]};
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  if (std::abs(n - 1.0) > kQuatNormTolerance) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", n);
    throw InputError(at + "quaternion norm " + buf + " is not 1 (is it (w, x, y, z)?)");
  }
  if (const std::string why = translation_problem({v[0], v[1], v[2]}); !why.empty()) throw InputError(at + why);
  return RigidTransform{{v[0], v[1], v[2]}, Quatd{q.w / n, q.x / n, q.y / n, q.z / n}};
}

}  // namespace ebh
