#include "sweep/folder.hpp"

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
                                 {(dir / "sweep.sbatch").string(), "the sweep's Slurm script"}};
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

}  // namespace ebh
