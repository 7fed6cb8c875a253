#pragma once
// The one way a message shows a number the user gave or a check computed: "%g" (1e-30 stays
// 1e-30, where std::to_string prints 0.000000; 3.3 stays 3.3).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace ebh {

inline std::string shown_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// v to `decimals` places, without trailing zeros ("-1000.03", "0.44", "0"): a length to copy into
/// a file or an option, at a resolution that matters (0.1 mm) however large it is, where %g's
/// significant digits would drop it (1000.02 m as 1e+03).
inline std::string fixed_text(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s == "-0" ? "0" : s;
}

/// The shortest text that reads back as v ("100", "0.1", "1e+300"): a value that must survive the
/// message exactly (a window's start, a rate).
inline std::string shortest_text(double v) {
  char buf[32];
  if (std::fabs(v) < 1e15 && v == std::floor(v)) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return buf;
  }
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

}  // namespace ebh
