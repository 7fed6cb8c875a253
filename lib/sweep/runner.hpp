#pragma once
// Running a sweep's replays: each run is an `ebh replay` child process of the same binary
// (isolated: a run that crashes or runs out of memory takes no other with it), N at a time, with
// OMP_NUM_THREADS set so that workers x threads = the cores this process may use.
//
// The folder of a sweep (DIR):
//   DIR/plan.yaml        the plan as run (resolved_plan_yaml)
//   DIR/runs/ID.h5       a finished run's replay output (written atomically by `ebh replay`)
//   DIR/runs/ID.log      what its replay printed (warnings), when it printed anything
//   DIR/runs/ID.failed   a failed run: its error line, then everything its replay printed
//   DIR/batches/ID.txt   the --batch file of a child running several CUDA runs (RunnerOptions::batch),
//                        removed when it ends
//   DIR/summary.csv      one row per run (sweep/summary.hpp); DIR/summary.h5 the same as HDF5
// A run whose output exists is done and never run again, unless the output was made from other
// input files (run_state: a mesh an override names edited or replaced since; an edited scene
// file, mesh it names or recording gives the run another id, so it is run again under that); a
// failed one is tried again by the next sweep of the folder. An interrupted sweep (SIGINT, SIGTERM, SIGHUP) passes the signal on to the
// replays in flight, which stop and write nothing, and starts no other: rerunning it runs exactly
// the runs that have no output. A replay still running RunnerOptions::stop_grace_s later is killed.
// The sweep's own process has no interrupt grace (io/atomic.hpp): it waits for its replays.
// The replays end with the sweep however it ends: a sweep killed with SIGKILL, which can pass
// nothing on, takes them along (each gets SIGTERM as its parent dies: PR_SET_PDEATHSIG), so none
// goes on writing into runs/ as an orphan. A replay killed by a signal cannot remove its output's
// temporary (io/atomic.hpp); the sweep removes it when it sees the child die.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "io/atomic.hpp"
#include "sweep/plan.hpp"

namespace ebh {

std::filesystem::path run_output(const std::filesystem::path& dir, const SweepRun& run);
std::filesystem::path run_log(const std::filesystem::path& dir, const SweepRun& run);
std::filesystem::path run_failure(const std::filesystem::path& dir, const SweepRun& run);

/// The SHA-256 of input files, and the files a run's scene reads under its overrides and the rates
/// it runs at, each found once (a sweep of many runs hashes each mesh once and loads each scene
/// once per set of overrides).
class InputDigests {
 public:
  /// With the digests the plan read (SweepPlan::sha256), which are then not read again.
  explicit InputDigests(const SweepPlan* plan = nullptr);
  const std::string& file(const std::filesystem::path& path);
  /// The run's scene's input files (scene_input_files) and its recording, by the keys a replay
  /// output records them under.
  const std::vector<std::pair<std::string, std::filesystem::path>>& run_files(const SweepPlan& plan, const SweepRun& run);
  /// The haptic tick and physical step rates (Hz) the run's scene gives under its overrides
  /// (time.haptic_hz, time.physical_hz): those of its replay, which the sweep gives no rate option.
  std::pair<double, double> run_rates(const SweepPlan& plan, const SweepRun& run);

 private:
  /// What a run's scene gives under its overrides, loaded once per (scene, recording, overrides).
  struct RunInputs {
    std::vector<std::pair<std::string, std::filesystem::path>> files;
    double haptic_hz = 0, physical_hz = 0;
  };
  const RunInputs& run_inputs(const SweepPlan& plan, const SweepRun& run);

  std::map<std::string, std::string> files_;
  std::map<std::string, RunInputs> runs_;
};

/// Where a run stands in DIR: no output yet; an output made from the run's input files as they are
/// now; or one made from others (a file whose SHA-256 differs from the one the output recorded:
/// edited or replaced since it ran), which a sweep runs again; or an HDF5 file that does not open
/// (cut short by a copy or a full disk) or an empty one, run again too; or an HDF5 file that is
/// not the run's replay (Other: a replay of another window, mode, backend or overrides, or one made
/// with a pose transform or other rates than the scene's (--transform, --tool-transform, --haptic-hz,
/// --physical-hz, which a sweep never gives), copied or replayed by hand under the run's name, or
/// no replay at all), run again. An output without the
/// digests counts as done; a file of another kind (not HDF5) is another program's, left alone as done.
enum class RunState { Missing, Done, Stale, Unreadable, Other };
RunState run_state(const std::filesystem::path& dir, const SweepPlan& plan, const SweepRun& run, InputDigests& digests);
/// Why a sweep runs a run with an output again (Stale, Unreadable, Other): "made from input files
/// edited or replaced since", ...; "" for Missing and Done. The sweep's count of them and the
/// summary's rows (summarize_sweep) say the same.
const char* redo_reason(RunState state);

/// A folder made before the run ids came from the files' contents names a run's files after its
/// legacy id (SweepRun::legacy_id): each run without files under its id takes those (output, log,
/// failure, renamed), which run_state then checks as any other. Returns how many outputs it took.
std::size_t adopt_legacy_outputs(const std::filesystem::path& dir, const std::vector<SweepRun>& runs);

/// The error line of a failed run (the first line of DIR/runs/ID.failed), or "" when it has none.
std::string read_run_failure(const std::filesystem::path& dir, const SweepRun& run);

/// The cores this process may run on: its CPU affinity (what taskset or a Slurm allocation that
/// binds tasks gives), at most SLURM_CPUS_PER_TASK when that is set.
int available_cores();

/// The CUDA_VISIBLE_DEVICES entries that make a child see device i (i in `indices`, numbered as
/// this process sees its `count` devices): the i-th entry of `visible` (this process's own
/// CUDA_VISIBLE_DEVICES, an index or UUID each) when that is set, else i itself. Throws
/// InputError "--gpus ..." for an index outside 0..count-1 or one given twice.
std::vector<std::string> gpu_entries(const std::vector<int>& indices, int count, const char* visible);

/// The runs that task `task` of `tasks` takes: run i when i % tasks == task (a Slurm array task's
/// slice; every run in exactly one task, references spread over the tasks).
std::vector<SweepRun> task_slice(const std::vector<SweepRun>& runs, int task, int tasks);

/// A finished command: its exit status (128 + signal when killed) and what it printed (stdout
/// and stderr together).
struct CommandResult {
  int status = 0;
  std::string output;
};
/// Runs argv (argv[0] looked up on PATH) to its end. Throws InputError "ARGV0: cannot start ARGV0:
/// reason" when it cannot start (not installed).
CommandResult run_command(const std::vector<std::string>& argv);

struct RunnerOptions {
  std::string executable;  ///< the ebh binary the replays run with
  int jobs = 1;            ///< children at a time
  int threads = 1;         ///< OMP_NUM_THREADS of each child
  /// CUDA runs of an async plan per child: up to this many go to one `ebh replay --batch` child
  /// (DIR/batches/ID.txt, the first run's id; docs/CUDA.md "Many replays on one GPU"); 1: a child
  /// per run.
  int batch = 1;
  int at_once = 0;         ///< the batch children's --at-once (0: theirs)
  /// The GPUs the CUDA children run on, as CUDA_VISIBLE_DEVICES entries (gpu_entries): each CUDA
  /// child gets one, the one with the fewest CUDA children running (the first of those), so
  /// `jobs` children spread over them; empty: the children inherit this process's devices.
  std::vector<std::string> gpus;
  /// After an interrupt, seconds the replays in flight have to stop before they are killed
  /// (SIGKILL; a replay ends by itself kInterruptGraceSeconds after the SIGTERM passed on to it,
  /// io/atomic.hpp, unless it is stuck past even that).
  double stop_grace_s = 2.0 * kInterruptGraceSeconds;
};

/// What happened to one run.
struct RunOutcome {
  enum class Status { Done, Skipped, Failed, Interrupted };
  const SweepRun* run = nullptr;
  Status status = Status::Done;
  double seconds = 0;     ///< wall time of the child process (load included)
  std::string error;      ///< Failed: the replay's error line
};

/// Progress: called when a run starts (outcome null) and when one ends, with the counts so far.
struct RunnerProgress {
  std::size_t total = 0, done = 0, skipped = 0, failed = 0, running = 0;
};
using RunnerCallback = std::function<void(const RunnerProgress&, const RunOutcome* finished)>;

/// Warnings of the runs that ran, the same but for their numbers and the run's output (the first
/// line of the kind as the replay printed it, and its log): a sweep's replays print into their
/// logs (DIR/runs/ID.log), which a sweep of a hundred runs leaves unread.
struct WarningKind {
  std::string kind;           ///< the line without "ebh: warning: ", the runs' outputs and its numbers
  std::string example;        ///< the first such line, without "ebh: warning: "
  std::filesystem::path log;  ///< the log it is in
  std::size_t count = 0;      ///< such lines over the runs that ran
};

/// The kinds of the warning lines ("ebh: warning: ...") in `text`, a child's output (`outputs`:
/// its runs' output paths), added to `kinds` (in the order first seen): a line's kind is its text
/// with those paths and every number left out.
void add_warning_kinds(const std::string& text, const std::vector<std::string>& outputs, const std::filesystem::path& log,
                       std::vector<WarningKind>& kinds);

struct RunnerReport {
  std::size_t ran = 0, skipped = 0, failed = 0, interrupted = 0;  ///< run counts
  std::size_t stale = 0;                ///< outputs made from other input files, run again (RunState::Stale)
  std::size_t unreadable = 0;           ///< outputs that do not open, run again (RunState::Unreadable)
  bool stopped = false;                 ///< an interrupt stopped the sweep
  std::vector<RunOutcome> failures;     ///< in the order they ended
  std::vector<WarningKind> warnings;    ///< of the runs that ran (add_warning_kinds)
};

/// Runs every run of `runs` that has no output in `dir`, or a stale one (`ebh replay` with the plan's mode, window
/// and the run's backend and overrides), options.jobs at a time. A replay that fails is written
/// down (DIR/runs/ID.failed) and the others go on. `states`: the caller's run_state of each run,
/// in the order of `runs` (so that no output is opened and no file hashed twice); null: its own.
RunnerReport execute_runs(const SweepPlan& plan, const std::vector<SweepRun>& runs, const std::filesystem::path& dir,
                          const RunnerOptions& options, const RunnerCallback& progress = {},
                          const std::vector<RunState>* states = nullptr);

}  // namespace ebh
