#pragma once
// The name every unfinished output of ebh carries, which no command reads as an input: the
// writers (io/atomic.hpp) and every reader of inputs (io/paths.hpp's check_input_file, the scene
// and mesh readers) share it.
#include <string>
#include <string_view>

namespace ebh {

/// The suffix of every temporary output file.
inline constexpr std::string_view kPartialSuffix = ".ebh-partial";

/// Whether `path`'s file name ends with kPartialSuffix (an unfinished output, never an input).
inline bool is_partial_output(std::string_view path) {
  return path.size() >= kPartialSuffix.size() && path.substr(path.size() - kPartialSuffix.size()) == kPartialSuffix;
}

/// The refusal of such an input: "PATH: an unfinished output of ebh (...), not an input".
inline std::string partial_input_message(const std::string& path) {
  return path + ": an unfinished output of ebh (a run that was killed or is still writing), not an input";
}

}  // namespace ebh
