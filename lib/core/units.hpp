#pragma once
// The length units ebh's files and options accept (SI inside: docs/FORMATS.md).
#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace ebh {

/// The length units by name: metres, centimetres, millimetres and inches (motion trackers such as
/// Polhemus's report inches by default; CAD exports often are).
inline constexpr std::array<std::string_view, 4> kLengthUnitNames = {"m", "cm", "mm", "in"};
/// "m, cm, mm, in", for messages and help.
inline constexpr const char* kLengthUnitList = "m, cm, mm, in";
inline constexpr double kMetresPerInch = 0.0254;

/// Metres per unit for a name of kLengthUnitNames; nullopt for anything else.
inline std::optional<double> length_unit_metres(std::string_view name) {
  if (name == "m") return 1.0;
  if (name == "cm") return 0.01;
  if (name == "mm") return 0.001;
  if (name == "in") return kMetresPerInch;
  return std::nullopt;
}

}  // namespace ebh
