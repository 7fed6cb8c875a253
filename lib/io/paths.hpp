#pragma once
// The files a command reads and writes, checked before any work so that no option can hurt a
// user's data: an output never replaces one of the command's inputs (or another of its outputs),
// and an input is a readable file, never a folder or an unfinished output (*.ebh-partial).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace ebh {

/// A file with what it is to the command, for messages: {"rec.h5", "the recording"}.
struct RoleFile {
  std::string path;
  std::string role;
};

/// Whether a and b name the same file: the same device and inode when both exist (so hard links
/// and symbolic links to it count), otherwise the same canonical path.
bool same_file(const std::string& a, const std::string& b);

/// Throws InputError "OUT: the output would replace ROLE IN, an input of this command; choose another
/// output file" when an output is the same file as an input, and "OUT: is both ROLE1 and ROLE2" when
/// two outputs are; "OUT: cannot create the output: Not a directory" (or another OS reason) when it
/// cannot be created there. Empty paths are skipped. Commands call it before any work.
void check_outputs(const std::vector<RoleFile>& outputs, const std::vector<RoleFile>& inputs);

/// Throws InputError "PATH: why" unless `path` names a file that can be read: it must exist ("cannot
/// open: No such file or directory"), not be a folder, a pipe or a device and not be an unfinished
/// output.
void check_input_file(const std::string& path);

/// Bytes an unprivileged process may still write on the file system that holds `output` (its
/// folder: the output and its temporary go there); nullopt when that cannot be told.
std::optional<std::uint64_t> free_bytes_for(const std::string& output);

}  // namespace ebh
