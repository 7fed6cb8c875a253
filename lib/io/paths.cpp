#include "io/paths.hpp"

#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <filesystem>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "io/atomic.hpp"

namespace ebh {
namespace fs = std::filesystem;

bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  struct stat sa {}, sb {};
  if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0)
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  // One is missing, or a link to nothing: the file it would create, at the end of its links (a
  // link to nothing and the name it leads to are one file once it is written).
  const fs::path la = link_end(a).value_or(a), lb = link_end(b).value_or(b);
  std::error_code ea, eb;
  const fs::path ca = fs::weakly_canonical(fs::absolute(la, ea), ea), cb = fs::weakly_canonical(fs::absolute(lb, eb), eb);
  if (ea || eb) return la.lexically_normal() == lb.lexically_normal();
  return ca == cb;
}

std::string companion_output(const std::string& output, const std::string& extension) {
  return fs::path(output_target(output)).replace_extension(extension).string();
}

namespace {

// The output can be created where it is asked for (AtomicOutput finds the same later; this says it
// before the work).
void check_output_location(const std::string& path) {
  // A line break in a name would split every line that names the file (its warnings, the
  // summary, a sweep's report): no one means one (InputError escapes it in this message).
  if (has_control_character(path))
    throw InputError(path + ": the output's name holds a control character (a line break, a tab?): name it otherwise");
  // The shell's "standard output": no command writes its file there (a file named '-' is ./-).
  if (path == "-") throw InputError("-: an output is a file (standard output is not one here): name a file, ./- for one named -");
  check_name_length(path);
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path + ": cannot write the output: " + os_reason(EISDIR));
  check_replaceable(path);
  // Before any estimate of its size: a folder that cannot be written is the reason, not its space.
  check_can_create(path);
}

/// " (a link to TARGET)" where `path` is a symbolic link, else empty: said where two outputs are
/// one file through a link.
std::string link_note(const std::string& path) {
  std::error_code ec;
  if (!fs::is_symlink(fs::symlink_status(path, ec))) return "";
  const fs::path to = fs::read_symlink(path, ec);
  return ec ? std::string() : " (a link to " + to.string() + ")";
}

}  // namespace

void check_outputs(const std::vector<RoleFile>& outputs, const std::vector<RoleFile>& inputs) {
  // Compared where each is written (output_target: a link's target, also one yet to be made), so
  // that a link to nothing that names another output is that output.
  std::vector<std::string> targets(outputs.size());
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const RoleFile& out = outputs[i];
    if (out.path.empty()) continue;
    check_output_location(out.path);
    targets[i] = output_target(out.path);
    for (const RoleFile& in : inputs)
      if (same_file(targets[i], in.path))
        throw InputError(out.path + ": the output would replace " + in.role + " " + in.path +
                         ", an input of this command; choose another output file");
    for (std::size_t j = 0; j < i; ++j)
      if (same_file(targets[i], targets[j])) {
        // Named apart where they differ ("a.yaml (a link to a.msh)"): the name said is the second's.
        const bool apart = fs::path(outputs[j].path).lexically_normal() != fs::path(out.path).lexically_normal();
        throw InputError(out.path + link_note(out.path) + ": is both " + outputs[j].role +
                         (apart ? " " + outputs[j].path + link_note(outputs[j].path) : std::string()) + " and " +
                         out.role + "; choose another output file");
      }
  }
}

void check_input_file(const std::string& path) {
  if (path.empty()) throw InputError("an input file name is empty");
  if (is_partial_output(path) && !is_own_temporary(path)) throw InputError(partial_input_message(path));
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    throw InputError(path + ": cannot open: " + os_reason(err));
  }
  if (S_ISDIR(st.st_mode)) throw InputError(path + ": is a folder, not a file");
  // A pipe or a device: its open waits for a writer (a named pipe hangs) and a second read finds
  // nothing (the readers check a file before they read it).
  if (!S_ISREG(st.st_mode)) {
    const std::string kind = S_ISFIFO(st.st_mode) ? "a pipe" : "a device or a socket";
    throw InputError(path + ": is " + kind + ", not a file: save what it gives to a file and name that");
  }
  if (::access(path.c_str(), R_OK) != 0) {
    const int err = errno;
    throw InputError(path + ": cannot open: " + os_reason(err));
  }
}

std::optional<std::uint64_t> free_bytes_for(const std::string& output) {
  std::string target;  // the file written: beside the file a link names
  try {
    target = output_target(output);
  } catch (const InputError&) {
    return std::nullopt;
  }
  std::filesystem::path folder = std::filesystem::path(target).parent_path();
  if (folder.empty()) folder = ".";
  struct statvfs fs {};
  if (::statvfs(folder.c_str(), &fs) != 0) return std::nullopt;
  // No blocks at all: a file system that does not count them (ramfs), or holds no files (/proc).
  if (fs.f_blocks == 0) return std::nullopt;
  return static_cast<std::uint64_t>(fs.f_bavail) * static_cast<std::uint64_t>(fs.f_frsize);
}

std::filesystem::path temporary_directory() {
  const char* env = std::getenv("TMPDIR");
  const std::filesystem::path dir = env && *env ? env : "/tmp";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    throw InputError(std::string(env && *env ? "TMPDIR '" + dir.string() + "'" : "/tmp (TMPDIR is not set)") +
                     ": no such folder (the folder for temporary files; set TMPDIR to one, or unset it for /tmp)");
  return dir;
}

TemporaryFolder::TemporaryFolder(const std::string& prefix, const std::string& what) {
  std::string t = (temporary_directory() / (prefix + "XXXXXX")).string();
  if (!::mkdtemp(t.data())) {
    const int err = errno;
    throw InputError(t + ": cannot create " + what + ": " + os_reason(err));
  }
  path_ = t;
  slots_.push_back(remove_on_interrupt(t));
}

std::filesystem::path TemporaryFolder::file(const std::string& name) {
  std::filesystem::path f = path_ / name;
  if (std::find(names_.begin(), names_.end(), name) == names_.end()) {
    names_.push_back(name);
    slots_.push_back(remove_on_interrupt(f.string()));
  }
  return f;
}

TemporaryFolder::~TemporaryFolder() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
  for (int slot : slots_) keep_on_interrupt(slot);
}

}  // namespace ebh
