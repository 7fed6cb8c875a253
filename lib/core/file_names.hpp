#pragma once
// A file name's extension as the commands compare it: lower-cased, so that a file a Windows tool
// or a camera-style export named `ORGAN.STL`, `LOG.CSV` or `scene.YAML` is told apart by its kind
// as its lower-case twin is.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

namespace ebh {

/// The extension of `file` with its dot, lower-cased (ASCII): ".stl" for "a/B.STL", "" for none.
inline std::string lower_extension(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

/// Whether `file` names a YAML file (.yaml or .yml, in any case).
inline bool has_yaml_extension(const std::filesystem::path& file) {
  const std::string ext = lower_extension(file);
  return ext == ".yaml" || ext == ".yml";
}

}  // namespace ebh
