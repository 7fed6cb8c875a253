#pragma once
// The length units ebh's files and options accept (SI inside: docs/FORMATS.md).
#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "core/error.hpp"

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

/// Why a dataset's `unit` attribute `given` is not the SI unit `si` that `ebh replay` writes ("" when
/// it is, or starts with it as "m, 1 (...)" or "m (...)" does; no attribute is "" too): a file
/// rewritten by other code in mm would otherwise be read 1000 times too large. One rule for every
/// reader of replay outputs (metrics, render).
inline std::string si_unit_problem(const std::string& given, std::string_view si) {
  const std::string u(si);
  if (given.empty() || given == u || given.rfind(u + ",", 0) == 0 || given.rfind(u + " (", 0) == 0) return "";
  return "has unit '" + clipped(given) + "'; expected '" + u + "' (SI, docs/FORMATS.md)";
}

}  // namespace ebh
