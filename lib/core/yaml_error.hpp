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
#include <yaml-cpp/node/node.h>

#include <string>
#include <vector>

#include "core/error.hpp"

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

/// The one document of YAML text read with YAML::LoadAll (a null node when there is none). A
/// second one (after '---'), which a reader of the first would leave unread without a word, is an
/// InputError "WHERE:LINE: a second YAML document (after '---'): WHAT holds one".
inline YAML::Node only_yaml_document(const std::vector<YAML::Node>& documents, const std::string& where,
                                     const std::string& what) {
  for (std::size_t i = 1; i < documents.size(); ++i)
    if (documents[i].IsDefined() && !documents[i].IsNull())
      throw InputError(where + ":" + std::to_string(documents[i].Mark().line + 1) +
                       ": a second YAML document (after '---'): " + what + " holds one");
  return documents.empty() ? YAML::Node() : documents.front();
}

}  // namespace ebh
