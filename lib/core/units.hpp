#pragma once
// The length units ebh's files and options accept (SI inside: docs/FORMATS.md).
#include <optional>
#include <string>

namespace ebh {

/// Metres per unit for "m", "cm", "mm"; nullopt for anything else.
inline std::optional<double> length_unit_metres(const std::string& name) {
  if (name == "m") return 1.0;
  if (name == "cm") return 0.01;
  if (name == "mm") return 0.001;
  return std::nullopt;
}

}  // namespace ebh
