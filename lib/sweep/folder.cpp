#include "sweep/folder.hpp"

#include <cstdio>
#include <regex>
#include <set>
#include <string>

#include "core/error.hpp"

namespace ebh {
namespace fs = std::filesystem;
namespace {

/// The sub-folders of DIR whose every file is a run's (or a Slurm task's).
const char* const kRunFolders[] = {"runs", "batches", "slurm"};

}  // namespace

fs::path sweep_plan_copy(const fs::path& dir) { return dir / "plan.yaml"; }
fs::path sweep_summary_csv(const fs::path& dir) { return dir / "summary.csv"; }
fs::path sweep_summary_h5(const fs::path& dir) { return dir / "summary.h5"; }

fs::path sweep_slurm_script(const fs::path& dir) { return dir / "sweep.sbatch"; }
fs::path sweep_lock_file(const fs::path& dir) { return dir / ".lock"; }

FileLock lock_sweep_folder(const fs::path& dir) {
  const std::string path = sweep_lock_file(dir).string();
  FileLock lock = FileLock::take(path, true, false);
  if (lock.status() == FileLock::Status::Busy) {
    const long pid = FileLock::holder_pid(path);
    throw InputError(dir.string() + ": another ebh sweep" + (pid > 0 ? " (pid " + std::to_string(pid) + ")" : std::string()) +
                     " is running in this folder");
  }
  if (lock.status() == FileLock::Status::Unsupported)
    std::fprintf(stderr, "ebh: warning: %s: cannot lock the folder (%s): nothing keeps a second sweep out of it while this one runs\n",
                 path.c_str(), lock.error().c_str());
  return lock;
}

std::vector<RoleFile> plan_input_files(const SweepPlan& plan) {
  std::vector<RoleFile> files = {{plan.file.string(), "the plan"}};
  std::set<std::string> named;
  for (const SweepScene& s : plan.scenes) {
    if (named.insert(s.scene_file.string()).second) files.push_back({s.scene_file.string(), "the scene file"});
    for (const fs::path& r : s.recordings)
      if (named.insert(r.string()).second) files.push_back({r.string(), "the recording"});
  }
  for (const auto& [path, sha] : plan.sha256)
    if (!named.count(path)) files.push_back({path, "a scene's input file"});
  return files;
}

std::vector<RoleFile> sweep_folder_files(const fs::path& dir) {
  std::vector<RoleFile> files = {{sweep_plan_copy(dir).string(), "the sweep's plan"},
                                 {sweep_summary_csv(dir).string(), "the sweep's summary"},
                                 {sweep_summary_h5(dir).string(), "the sweep's summary"},
                                 {sweep_slurm_script(dir).string(), "the sweep's Slurm script"},
                                 {sweep_lock_file(dir).string(), "the sweep's lock"}};
  for (const char* sub : kRunFolders) {
    std::error_code ec;
    for (fs::directory_iterator it(dir / sub, ec), end; !ec && it != end; it.increment(ec))
      files.push_back({it->path().string(), std::string("the sweep's file")});
  }
  return files;
}

void check_output_beside_sweep(const RoleFile& output, const fs::path& dir, std::vector<RoleFile> inputs) {
  if (output.path.empty()) return;
  std::vector<RoleFile> own = sweep_folder_files(dir);
  inputs.insert(inputs.end(), own.begin(), own.end());
  check_outputs({output}, inputs);
  const fs::path parent = fs::path(output.path).parent_path();
  for (const char* sub : kRunFolders)
    if (same_file(parent.empty() ? "." : parent.string(), (dir / sub).string()))
      throw InputError(output.path + ": the output would go into the sweep's folder " + (dir / sub).string() +
                       ", which holds its runs' files only; choose another output file");
}

void check_sweep_outputs(const SweepPlan& plan, const fs::path& dir, bool writes_plan) {
  std::vector<RoleFile> outputs = {{sweep_summary_csv(dir).string(), "summary"},
                                   {sweep_summary_h5(dir).string(), "summary"},
                                   {sweep_slurm_script(dir).string(), "Slurm script"},
                                   {sweep_lock_file(dir).string(), "lock"}};
  if (writes_plan) outputs.push_back({sweep_plan_copy(dir).string(), "plan"});
  for (const RoleFile& in : plan_input_files(plan)) {
    for (const RoleFile& out : outputs)
      if (same_file(out.path, in.path))
        throw InputError(out.path + ": the output would replace " + in.role + " " + in.path +
                         ", an input of this command; give the sweep another folder (-o NEW_DIR)");
    const fs::path parent = fs::path(in.path).parent_path();
    for (const char* sub : kRunFolders)
      if (same_file(parent.string(), (dir / sub).string()))
        throw InputError(in.path + ": " + in.role + " is in the sweep's folder " + (dir / sub).string() +
                         ", where it writes its runs' files; give the sweep another folder (-o NEW_DIR)");
  }
}

void check_sweep_folder(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec) || fs::exists(sweep_plan_copy(dir), ec)) return;
  auto refuse = [&](const std::string& what) {
    throw InputError(dir.string() + ": not an ebh sweep folder (no plan.yaml) but holds " + what +
                     ": name a new or empty folder");
  };
  for (const fs::path& own : {sweep_summary_csv(dir), sweep_summary_h5(dir), sweep_slurm_script(dir)})
    if (fs::exists(own, ec)) refuse(own.filename().string());
  // A run's file: ID.h5, ID.log, ID.failed (16 hex digits), or the temporary of one.
  static const std::regex run_file(R"(\.?[0-9a-f]{16}\.(h5|log|failed)(\..*\.ebh-partial)?)");
  // Another sweep's runs/ (or batches/, slurm/) given as the folder: its runs' files are in it.
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (std::regex_match(it->path().filename().string(), run_file))
      refuse(it->path().filename().string() + ", a sweep run's file (is it another sweep's runs folder?)");
  if (fs::exists(dir / "runs", ec) && !fs::is_directory(dir / "runs", ec)) refuse("runs");
  for (fs::directory_iterator it(dir / "runs", ec), end; !ec && it != end; it.increment(ec))
    if (!std::regex_match(it->path().filename().string(), run_file))
      refuse("runs/" + it->path().filename().string() + ", not a run's file");
}

}  // namespace ebh
