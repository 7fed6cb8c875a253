#pragma once
// The one check of a rotation vector an input gives in degrees (mesh.transform's rotvec_deg, a
// synthesis waypoint's, --transform's): every rotation has one of at most 180 degrees, and far
// beyond a turn the vector's length overflows or its sine keeps nothing of the angle.
#include <cstdio>
#include <string>

#include "math/vec.hpp"

namespace ebh {

inline constexpr double kMaxRotvecDeg = 360;

/// "" for a rotation vector (degrees) an input may give, else why not ("the rotation vector's
/// angle is inf degrees; give one of at most 360"), for the caller to put after its key.
inline std::string rotvec_deg_problem(Vec3d rotvec_deg) {
  const double angle = norm(rotvec_deg);
  if (angle <= kMaxRotvecDeg) return "";
  char buf[96];
  std::snprintf(buf, sizeof buf, "the rotation vector's angle is %.4g degrees; give one of at most 360", angle);
  return buf;
}

}  // namespace ebh
