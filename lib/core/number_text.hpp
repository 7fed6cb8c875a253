#pragma once
// The one way a message shows a number the user gave or a check computed: "%g" (1e-30 stays
// 1e-30, where std::to_string prints 0.000000; 3.3 stays 3.3).
#include <cstdio>
#include <string>

namespace ebh {

inline std::string shown_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace ebh
