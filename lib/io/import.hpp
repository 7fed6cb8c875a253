#pragma once
// Importing device logs into recordings (`ebh import`, docs/FORMATS.md).
//
// openhaptics: one sample a line, whitespace- or comma-separated: the 16 numbers of the
//   column-major 4x4 device transform (as hdGetDoublev(HD_CURRENT_TRANSFORM) returns it:
//   translation in elements 12-14), the jaw opening (1 open, 0 closed), then zero or more button
//   states (ints, button i nonzero -> bit i). '#' starts a comment; blank lines are skipped.
//   Times are i / rate_hz.
// csv: a header naming the columns (any order): t, x, y, z, qw, qx, qy, qz, jaw, buttons;
//   x, y, z and the quaternion are required, t optional (else i / rate_hz), jaw defaults to 1,
//   buttons to 0.
// Positions are scaled by the unit (openhaptics default mm, csv default m), then the optional
// world transform is applied: p_world = R p + t, q_world = q_R q.
#include <optional>
#include <string>

#include "io/recording.hpp"

namespace ebh {

enum class LogFormat { openhaptics, csv };

struct ImportOptions {
  std::optional<LogFormat> format;  ///< nullopt: .csv -> csv, anything else -> openhaptics
  double rate_hz = 1000;            ///< sample rate when the log has no t column
  std::optional<double> unit;       ///< metres per log length unit; nullopt: the format's default
  Vec3d transform_translation;      ///< m (already scaled)
  Quatd transform_rotation;         ///< log frame -> world
  std::string scene;
  std::string tool = "hook";
};

/// Reads a log; errors name the file and line ("log.txt:17: ...").
Recording import_log(const std::string& path, const ImportOptions& opt);

/// Parses "--unit m|cm|mm" (metres per unit); throws InputError naming the option.
double parse_length_unit(const std::string& name);
/// Parses "--transform tx,ty,tz,rx,ry,rz" (translation in the given unit, rotation vector in
/// degrees) into opt.transform_*.
void parse_transform(const std::string& text, double unit_m, ImportOptions& opt);

/// Max Frobenius distance between a logged rotation block and its nearest rotation: encoder
/// noise and 6-digit logs stay far below it; a scaled or sheared matrix does not.
inline constexpr double kRotationTolerance = 0.02;

}  // namespace ebh
