#pragma once
// The files a command reads and writes, checked before any work so that no option can hurt a
// user's data: an output never replaces one of the command's inputs (or another of its outputs),
// and an input is a readable file, never a folder or an unfinished output (*.ebh-partial).
#include <cstdint>
#include <filesystem>
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
/// and symbolic links to it count), otherwise the same canonical path of the names at the end of
/// their links (io/atomic.hpp link_end: a link to nothing is the file it would create).
bool same_file(const std::string& a, const std::string& b);

/// The file written beside the output `output` with its extension replaced (".msh" beside a scene
/// OUT.yaml): named after the file the output really is and beside it (output_target: where
/// `output` is a link, its target), so that the output names it by its file name, relative to its
/// own folder. Throws as output_target does.
std::string companion_output(const std::string& output, const std::string& extension);

/// Throws InputError "OUT: the output would replace ROLE IN, an input of this command; choose another
/// output file" when an output is the same file as an input, and "OUT: is both ROLE1 and ROLE2" when
/// two outputs are (compared where each is written, output_target: a link to nothing that names
/// another output is that output; "OUT (a link to X): is both ROLE1 OUT1 and ROLE2" where the
/// names differ); "OUT: cannot create the output: Not a directory" (or another OS reason) when it
/// cannot be created there (io/atomic.hpp check_can_create: tried, so a read-only folder or /proc is
/// said as such). Empty paths are skipped. Commands call it before any work.
void check_outputs(const std::vector<RoleFile>& outputs, const std::vector<RoleFile>& inputs);

/// Throws InputError "PATH: why" unless `path` names a file that can be read: it must exist ("cannot
/// open: No such file or directory"), not be a folder, a pipe or a device and not be an unfinished
/// output.
void check_input_file(const std::string& path);

/// Bytes an unprivileged process may still write on the file system that holds `output` (its
/// folder, or that of the file a link there names: the output and its temporary go there); nullopt
/// when that cannot be told (a file system with no blocks: ramfs, /proc).
std::optional<std::uint64_t> free_bytes_for(const std::string& output);

/// The folder for temporary files: $TMPDIR, or /tmp where it is unset or empty (as POSIX tools take
/// it). Throws InputError "TMPDIR 'X': no such folder (...)" when it names none: an exit status 1
/// and one line, not filesystem's "temp_directory_path" error as an internal one.
std::filesystem::path temporary_directory();

/// A folder of its own under temporary_directory(), made with mkdtemp (PREFIX plus six characters,
/// this user's only), removed with what it holds when it goes. `what` names it in the error:
/// "/tmp/ebh_gate_1_XXXXXX: cannot create the gate's temporary folder: Permission denied".
/// A process that ends at an interrupt's grace or second signal (io/atomic.hpp) runs no
/// destructor: the folder and the files named through file() are removed then too.
class TemporaryFolder {
 public:
  TemporaryFolder(const std::string& prefix, const std::string& what);
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  ~TemporaryFolder();
  const std::filesystem::path& path() const { return path_; }
  /// path() / name, registered for removal at a sudden end (a few at a time: the table is small).
  std::filesystem::path file(const std::string& name);

 private:
  std::filesystem::path path_;
  std::vector<int> slots_;  ///< remove_on_interrupt's, the folder's first
  std::vector<std::string> names_;  ///< file()'s
};

}  // namespace ebh
