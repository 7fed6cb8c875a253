#pragma once
// The one message for YAML text that yaml-cpp refuses, for every reader of YAML input (scene
// files, sweep and synthesis plans, gate baselines, --set values). Header-only; its includers link
// yaml-cpp (lib/CMakeLists.txt: scene, io, gate, sweep).
//
// yaml-cpp parses nested lists and maps recursively and stops at a fixed depth (500 in 0.7) with
// DeepRecursion, a ParserException whose own message is "bad file": a file of 100000 `[` is such a
// stop, not a stack overflow, and is said as what it is.
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/exceptions.h>

#include <string>

namespace ebh {

/// What is wrong with YAML text that yaml-cpp refused: "nested too deeply (...)" at its depth
/// limit, else "YAML syntax error: MESSAGE".
inline std::string yaml_parse_problem(const YAML::Exception& e) {
  if (const auto* deep = dynamic_cast<const YAML::DeepRecursion*>(&e))
    return "nested too deeply (over " + std::to_string(deep->depth()) +
           " levels of lists and maps, yaml-cpp's limit; ebh's files nest a few)";
  return "YAML syntax error: " + e.msg;
}

/// "WHERE:LINE: " and yaml_parse_problem(e) ("WHERE: " when yaml-cpp gives no position).
inline std::string yaml_parse_error(const std::string& where, const YAML::Exception& e) {
  std::string out = where;
  if (!e.mark.is_null()) {
    out += ':';
    out += std::to_string(e.mark.line + 1);
  }
  out += ": ";
  out += yaml_parse_problem(e);
  return out;
}

}  // namespace ebh
