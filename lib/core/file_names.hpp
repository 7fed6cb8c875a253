#pragma once
// File names as the commands take and make them. A file name's extension as the commands compare
// it: lower-cased, so that a file a Windows tool or a camera-style export named `ORGAN.STL`,
// `LOG.CSV` or `scene.YAML` is told apart by its kind as its lower-case twin is. And a name taken
// from a file's contents (a scene's `name`) checked before it becomes a file's name in a folder.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

#include "core/error.hpp"

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

/// "" when `name` can start the name of a file in a folder as it is, else why not: it holds a '/'
/// (a folder above, or an absolute path: the file would land outside the folder), starts with a '.'
/// ('..', or a hidden file), or holds a control character (a line break splits every line that
/// names the file). For names read from a file: a scene's `name` makes `ebh scene degrade`'s
/// DIR/NAME_qQ.yaml.
inline std::string file_name_problem(std::string_view name) {
  if (name.empty()) return "is empty";
  if (name.find('/') != std::string_view::npos) return "holds a '/' (a path, not a file's name)";
  if (name.front() == '.') return "starts with a '.' (a folder above, or a hidden file)";
  if (has_control_character(name))
    return "holds a control character (a line break, a tab?)";
  return "";
}

/// The name at the end of `path`'s links, followed as the system follows them (a relative link
/// from the folder it is in) whether that file exists or not, and not made canonical: `path` itself
/// where it is no link, "DIR/store/run.h5" for a link DIR/run.h5 -> store/run.h5. nullopt for a
/// loop of links, a chain longer than the system follows (40) or a link that cannot be read.
/// Never throws (output_target says why).
inline std::optional<std::string> link_end(const std::string& path) {
  namespace fs = std::filesystem;
  fs::path end(path);
  std::error_code ec;
  // By hand, as the system does: a relative link from its own folder, at most 40 links.
  for (int links = 0; fs::is_symlink(end, ec); ++links) {
    const fs::path to = fs::read_symlink(end, ec);
    if (ec || links == 40) return std::nullopt;
    end = to.is_absolute() ? to : end.parent_path() / to;
  }
  return end.string();
}

}  // namespace ebh
