#pragma once
// A sweep's folder (DIR, sweep/runner.hpp lists what it holds): the files that are the sweep's
// own, which no output of a command and no input of its plan may be.
#include <filesystem>
#include <vector>

#include "io/lock.hpp"
#include "io/paths.hpp"
#include "sweep/plan.hpp"

namespace ebh {

/// DIR/plan.yaml, DIR/summary.csv and DIR/summary.h5.
std::filesystem::path sweep_plan_copy(const std::filesystem::path& dir);
std::filesystem::path sweep_summary_csv(const std::filesystem::path& dir);
std::filesystem::path sweep_summary_h5(const std::filesystem::path& dir);

/// DIR/sweep.sbatch: the job script of a --slurm submission.
std::filesystem::path sweep_slurm_script(const std::filesystem::path& dir);

/// DIR/.lock: the lock a sweep holds on its folder (lock_sweep_folder).
std::filesystem::path sweep_lock_file(const std::filesystem::path& dir);

/// Takes the lock of a sweep's folder (DIR/.lock, an exclusive flock: io/lock.hpp; DIR must exist),
/// held while the result lives and never by two processes: a sweep run here, its --collect and a
/// --slurm submission hold it for their whole life (the tasks of a Slurm array, which each write
/// runs of their own, take none). Throws InputError "DIR: another ebh sweep (pid N) is running in
/// this folder" when another process holds it. On a file system that takes no locks it warns on
/// stderr and holds none.
FileLock lock_sweep_folder(const std::filesystem::path& dir);

/// The files the plan's replays read, each with its role for messages: the plan file, each scene
/// file, the other files the scenes name (meshes: SweepPlan::sha256) and each recording.
std::vector<RoleFile> plan_input_files(const SweepPlan& plan);

/// The files of DIR that are the sweep's, each with its role for messages ("the sweep's summary"):
/// plan.yaml, summary.csv, summary.h5, sweep.sbatch, .lock (whether there or not: a sweep or a report
/// writes them), and every file now in runs/, batches/ and slurm/.
std::vector<RoleFile> sweep_folder_files(const std::filesystem::path& dir);

/// Throws InputError "OUT: the output would replace ROLE IN, an input of this command; choose
/// another output file" (check_outputs) when `output` is one of the folder's files
/// (sweep_folder_files) or one of `inputs`, and "OUT: the output would go into the sweep's folder
/// DIR/runs, ..." when it names a file in runs/, batches/ or slurm/, which hold the runs' files
/// only (a run not done yet has no file there to compare with).
void check_output_beside_sweep(const RoleFile& output, const std::filesystem::path& dir, std::vector<RoleFile> inputs);

/// Throws InputError when a file the plan reads (plan_input_files) is one the sweep writes in DIR,
/// before any work: "DIR/summary.h5: the output would replace the recording DIR/summary.h5, an
/// input of this command; give the sweep another folder (-o NEW_DIR)", and the same for
/// summary.csv, sweep.sbatch, .lock, plan.yaml (`writes_plan`: unless the plan is that file) and any
/// file in runs/, batches/ or slurm/.
void check_sweep_outputs(const SweepPlan& plan, const std::filesystem::path& dir, bool writes_plan);

/// Throws InputError "DIR: not an ebh sweep folder (no plan.yaml) but holds summary.csv: name a new
/// or empty folder" when DIR has no plan.yaml but holds a file a sweep would write over or mix its
/// runs with (summary.csv, summary.h5, sweep.sbatch, or a file in runs/ that is not a run's). A
/// runs/ of run files only (copied from another sweep's folder to reuse them) is taken, as is a
/// folder holding other files (an empty slurm/ made for the array's logs).
void check_sweep_folder(const std::filesystem::path& dir);

}  // namespace ebh
