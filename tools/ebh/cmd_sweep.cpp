// ebh sweep PLAN.yaml -o DIR: many replays from a plan, locally (N at a time) or as a Slurm job
// array, resumable; DIR/summary.csv and DIR/summary.h5 hold one row per run. ebh sweep report DIR:
// run time against force error, the Pareto front, a plot. lib/sweep has the pieces; docs/FORMATS.md the files.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <exception>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include "command.hpp"
#include "io/atomic.hpp"
#include "core/error.hpp"
#include "io/paths.hpp"
#include "options.hpp"
#include "replay_common.hpp"
#include "sweep/folder.hpp"
#include "sweep/plan.hpp"
#include "sweep/report.hpp"
#include "sweep/runner.hpp"
#include "sweep/summary.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif

namespace ebh::cli {
namespace {
namespace fs = std::filesystem;

struct SweepArgs {
  std::string plan, out, backend, slurm_args;
  std::string gpus = "all";
  int jobs = 1, batch = 1;
  std::optional<int> at_once;
  std::optional<int> task, tasks;
  bool slurm = false, collect = false;
};

struct ReportArgs {
  std::string dir, plot;
  double min_haptic_hz = kDeviceHapticHz;
};


std::string executable() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw InputError("cannot find the ebh binary to run the replays with (/proc/self/exe: " + ec.message() + ")");
  return p.string();
}

/// The runs with an output that a sweep runs again, by why (RunState).
struct RedoCounts {
  std::size_t stale = 0, unreadable = 0, other = 0;
};

/// Where each run of `runs` stands in DIR (run_state), counting the outputs it runs again.
std::vector<RunState> run_states(const SweepPlan& plan, const fs::path& dir, const std::vector<SweepRun>& runs,
                                 RedoCounts& redo) {
  InputDigests digests(&plan);
  std::vector<RunState> states;
  for (const SweepRun& r : runs) {
    states.push_back(run_state(dir, plan, r, digests));
    redo.stale += states.back() == RunState::Stale ? 1 : 0;
    redo.unreadable += states.back() == RunState::Unreadable ? 1 : 0;
    redo.other += states.back() == RunState::Other ? 1 : 0;
  }
  return states;
}

/// The first line's note of the runs with an output that run again (", N made from input files
/// edited or replaced since (run again)", ...), or "".
std::string stale_note(const RedoCounts& redo) {
  auto note = [](std::size_t n, RunState why) {
    return n ? ", " + std::to_string(n) + " " + redo_reason(why) + " (run again)" : std::string();
  };
  return note(redo.stale, RunState::Stale) + note(redo.unreadable, RunState::Unreadable) + note(redo.other, RunState::Other);
}

/// "tube + tube_insert, cpu, solver.virtual_iterations=2 (ID)": a run in messages, one printable
/// line (an override's text may hold a line break or an escape sequence: escape_unprintable).
std::string describe(const SweepPlan& plan, const SweepRun& r) {
  return ebh::escape_unprintable(plan.scenes[r.scene].name + " + " + r.recording.stem().string() + ", " + r.backend +
                                 (r.repetition ? " #" + std::to_string(r.repetition) : "") + ", " +
                                 (r.reference ? "reference " : "") + r.overrides_text() + " (" + r.id + ")");
}

/// The text of `file`, or nullopt when it cannot be read.
std::optional<std::string> file_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Throws InputError when DIR/plan.yaml is another plan's: a sweep's folder holds one plan's runs,
/// and a second plan would replace its plan.yaml and its summary while the first one's outputs
/// stay. The same plan (a resume) is the same resolved plan (resolved_plan_yaml: the same scenes,
/// recordings, configurations and settings, whatever the file's layout, comments or folder),
/// compared with the folder's plan.yaml as written and, when that text differs (an older ebh wrote
/// it), as read again.
void check_same_plan(const SweepPlan& plan, const std::string& given, const fs::path& dir) {
  const fs::path kept = sweep_plan_copy(dir);
  std::error_code ec;
  if (!fs::exists(kept, ec) || same_file(given, kept.string())) return;
  const std::string resolved = resolved_plan_yaml(plan);
  if (file_text(kept) == resolved) return;
  try {
    if (resolved_plan_yaml(read_sweep_plan(kept)) == resolved) return;
  } catch (const InputError& e) {
    // A plan that no longer reads (cut short, emptied, edited by hand, its files moved): its own
    // error is the cause, not another plan.
    throw InputError(std::string(e.what()) + " (the plan of the sweep's folder " + dir.string() + ", which " + given +
                     " is compared with; repair it, or give " + given + " a new folder: -o NEW_DIR)");
  }
  throw InputError(kept.string() + ": another plan's folder: its scenes, recordings, configurations or settings are not " +
                   given + "'s; give " + given + " a new folder (-o NEW_DIR; copying " + (dir / "runs").string() +
                   "/ there reuses the runs the two plans share)");
}

/// " (N of them with an output to run again: their errors say why)", or "".
std::string redo_note(const SweepSummary& s) {
  return s.redo ? " (" + std::to_string(s.redo) + " of them with an output to run again: their errors say why)" : std::string();
}

/// DIR/summary.csv and DIR/summary.h5, each written atomically: the HDF5 file first, as it checks
/// every numeric cell (InputError naming the row and column) before it replaces anything, so a table
/// that fails leaves both previous files as they were.
void write_summary_files(const fs::path& dir, const CsvTable& table) {
  write_summary_h5(table, sweep_summary_h5(dir).string());
  write_file_atomically(sweep_summary_csv(dir).string(), table.to_csv());
}

/// Writes DIR/summary.csv (and .h5) from what DIR holds; prints its counts.
SweepSummary write_summary(const SweepPlan& plan, const std::vector<SweepRun>& runs, const fs::path& dir) {
  SweepSummary s = summarize_sweep(plan, runs, dir);
  write_summary_files(dir, s.table);
  std::printf("%s: %zu runs: %zu ok, %zu failed, %zu not run%s\n", sweep_summary_csv(dir).c_str(), runs.size(), s.ok, s.failed,
              s.pending, redo_note(s).c_str());
  return s;
}

/// "'text'" for a POSIX shell.
std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::vector<std::string> split_words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

/// The outputs a folder made by an older ebh holds under the runs' legacy ids, renamed to their
/// ids (adopt_legacy_outputs), with a line saying so.
void adopt_legacy(const fs::path& dir, const std::vector<SweepRun>& runs) {
  if (const std::size_t n = adopt_legacy_outputs(dir, runs))
    std::fprintf(stderr, "ebh sweep: %s: %zu outputs named after their scene's and recording's paths (an older ebh) renamed to "
                 "the ids of their files' contents\n", dir.c_str(), n);
}

/// --gpus: "all" (every CUDA device this process sees) or device numbers separated by commas.
std::vector<int> gpu_indices(const std::string& text, int count) {
  std::vector<int> out;
  if (text == "all") {
    for (int i = 0; i < count; ++i) out.push_back(i);
    return out;
  }
  const InputError bad("--gpus '" + text + "': expected all or device numbers separated by commas (e.g. 0,1)");
  if (text.empty() || text.back() == ',') throw bad;
  std::stringstream in(text);
  for (std::string e; std::getline(in, e, ',');) {
    std::size_t used = 0;
    int i = -1;
    try {
      i = std::stoi(e, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (e.empty() || used != e.size() || i < 0) throw bad;
    out.push_back(i);
  }
  return out;
}

/// The CUDA_VISIBLE_DEVICES entries the plan's CUDA children spread over (RunnerOptions::gpus):
/// none (they inherit this process's devices) when no CUDA run is left or `all` finds one device.
std::vector<std::string> sweep_gpus(const std::string& text, bool cuda_runs) {
  if (!cuda_runs) return {};
  int count = 0;
#if EBH_HAVE_CUDA
  count = cuda_device_count();
#endif
  const std::vector<int> indices = gpu_indices(text, count);
  if (text == "all" && count <= 1) return {};
  return gpu_entries(indices, count, std::getenv("CUDA_VISIBLE_DEVICES"));
}

/// What the start of a sweep writes into its folder (the folder and its missing parents, its lock,
/// plan.yaml, sweep.sbatch, slurm/), undone when an exception leaves its scope before keep(): a sweep that fails
/// before its runs start or its job array is submitted (sbatch missing or refusing, a backend this
/// build lacks) leaves the folder as it found it. A file that was there gets its content back; a
/// folder that was there stays, and one it made goes only when empty.
class FolderChanges {
 public:
  explicit FolderChanges(const fs::path& dir) : dir_(dir) {
    std::error_code ec;
    for (fs::path p = fs::absolute(dir, ec).lexically_normal(); !ec && p.has_relative_path() && !fs::exists(p, ec);
         p = p.parent_path())
      made_folders_.push_back(p);  // deepest first
  }
  FolderChanges(const FolderChanges&) = delete;
  FolderChanges& operator=(const FolderChanges&) = delete;
  ~FolderChanges() {
    if (!kept_ && std::uncaught_exceptions() > exceptions_) undo();
  }

  /// Before (re)writing `file`: remembers what it held, or that it was not there.
  void writing(const fs::path& file) {
    std::error_code ec;
    files_.emplace_back(file, fs::is_regular_file(file, ec) ? file_text(file) : std::nullopt);
  }
  /// Before creating the folder `folder` (a no-op for one that is there).
  void making(const fs::path& folder) {
    std::error_code ec;
    if (!fs::exists(folder, ec)) made_folders_.insert(made_folders_.begin(), folder);
  }
  void keep() { kept_ = true; }
  /// Makes the folder (when missing) and takes its lock (lock_sweep_folder) until this object
  /// ends: the lock file goes before the folders it made, after the files it wrote are undone.
  void lock() {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) throw InputError(dir_.string() + ": cannot create the folder: " + ec.message());
    lock_ = lock_sweep_folder(dir_);
  }

 private:
  void undo() noexcept {
    for (auto it = files_.rbegin(); it != files_.rend(); ++it) {
      std::error_code ec;
      try {
        if (it->second) write_file_atomically(it->first.string(), *it->second);
        else fs::remove(it->first, ec);
      } catch (const std::exception&) {
        // best effort: the error that led here is the one to report
      }
    }
    lock_ = FileLock();
    for (const fs::path& f : made_folders_) {
      std::error_code ec;
      fs::remove(f, ec);  // only when empty
    }
  }

  std::vector<std::pair<fs::path, std::optional<std::string>>> files_;
  fs::path dir_;
  std::vector<fs::path> made_folders_;  // deepest first
  FileLock lock_;  // the folder's, from lock() on
  bool kept_ = false;
  int exceptions_ = std::uncaught_exceptions();
};

/// --slurm: one array task per slice of the runs, each `ebh sweep DIR/plan.yaml -o DIR --task I --tasks T`.
void submit_slurm(const SweepArgs& a, const SweepPlan& plan, const std::vector<SweepRun>& runs, const fs::path& dir,
                  FolderChanges& changes) {
  RedoCounts redo;
  const std::vector<RunState> states = run_states(plan, dir, runs, redo);
  const auto todo = static_cast<std::size_t>(std::count_if(states.begin(), states.end(), [](RunState s) { return s != RunState::Done; }));
  if (todo == 0) {
    std::printf("%s: all %zu runs are done; nothing to submit (ebh sweep report %s)\n", dir.c_str(), runs.size(), dir.c_str());
    return;
  }
  // A task per run at most: more would be tasks with no run, each still queued and started.
  const int tasks = static_cast<int>(std::min<std::size_t>(a.tasks ? static_cast<std::size_t>(*a.tasks) : 1000, runs.size()));
  if (a.tasks && *a.tasks > tasks)
    std::fprintf(stderr, "ebh sweep: --tasks %d: the plan has %zu runs here; submitting %d tasks, one per run\n", *a.tasks,
                 runs.size(), tasks);
  const fs::path abs_dir = fs::absolute(dir).lexically_normal();
  std::string command = "exec " + shell_quote(executable()) + " sweep " + shell_quote(sweep_plan_copy(abs_dir).string()) + " -o " +
                        shell_quote(abs_dir.string()) + " --task \"$SLURM_ARRAY_TASK_ID\" --tasks " +
                        std::to_string(tasks) + " --jobs " + std::to_string(a.jobs);
  if (!a.backend.empty()) command += " --backend " + a.backend;
  if (a.batch > 1) command += " --batch " + std::to_string(a.batch);
  if (a.at_once) command += " --at-once " + std::to_string(*a.at_once);
  if (a.gpus != "all") command += " --gpus " + shell_quote(a.gpus);  // else each task's own devices
  const fs::path script = sweep_slurm_script(abs_dir);
  changes.writing(script);
  write_file_atomically(script.string(),
                        "#!/bin/sh\n# ebh sweep --slurm: array task I of " + std::to_string(tasks) +
                            " runs the plan's runs i with i % " + std::to_string(tasks) + " == I that have no output yet\n" +
                            command + "\n");
  std::error_code ec;
  changes.making(abs_dir / "slurm");
  fs::create_directories(abs_dir / "slurm", ec);
  if (ec) throw InputError((abs_dir / "slurm").string() + ": cannot create the folder: " + ec.message());
  std::vector<std::string> argv = {"sbatch", "--parsable", "--array=0-" + std::to_string(tasks - 1), "--job-name=ebh-sweep",
                                   "--output=" + (abs_dir / "slurm" / "%A_%a.out").string()};
  for (const std::string& w : split_words(a.slurm_args)) argv.push_back(w);
  argv.push_back(script.string());
  CommandResult r;
  try {
    r = run_command(argv);
  } catch (const InputError& e) {
    throw InputError(std::string("--slurm: ") + e.what() + " (is Slurm's sbatch on PATH?)");
  }
  std::string out = r.output;
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  if (r.status != 0) {
    const auto nl = out.find_last_of('\n');
    throw InputError("--slurm: sbatch failed (status " + std::to_string(r.status) + "): " +
                     (nl == std::string::npos ? out : out.substr(nl + 1)));
  }
  changes.keep();
  const std::string job = out.substr(out.find_last_of('\n') == std::string::npos ? 0 : out.find_last_of('\n') + 1);
  std::printf("%s: submitted Slurm job array %s: %d tasks for %zu runs (%zu to do%s); when it has finished: ebh sweep report %s\n",
              dir.c_str(), job.substr(0, job.find(';')).c_str(), tasks, runs.size(), todo, stale_note(redo).c_str(), dir.c_str());
}

/// The progress line: on a terminal one line rewritten in place, otherwise a line per finished run.
class ProgressPrinter {
 public:
  ProgressPrinter(const SweepPlan& plan) : plan_(plan), tty_(isatty(STDERR_FILENO)) {}
  void operator()(const RunnerProgress& p, const RunOutcome* o) {
    if (o && o->status == RunOutcome::Status::Skipped) return;
    const std::size_t width = 24, done = p.total ? width * p.done / p.total : width;
    if (tty_) {
      std::fprintf(stderr, "\r[%.*s%*s] %zu/%zu runs, %zu running, %zu failed ", static_cast<int>(done),
                   "########################", static_cast<int>(width - done), "", p.done, p.total, p.running, p.failed);
      if (o && o->status == RunOutcome::Status::Failed)
        std::fprintf(stderr, "\r%*s\rfailed: %s: %s\n", 100, "", describe(plan_, *o->run).c_str(), o->error.c_str());
    } else if (o) {
      const char* what = o->status == RunOutcome::Status::Done ? "done" : o->status == RunOutcome::Status::Failed ? "failed" : "stopped";
      std::fprintf(stderr, "[%zu/%zu] %s in %.1f s: %s%s%s\n", p.done, p.total, what, o->seconds,
                   describe(plan_, *o->run).c_str(), o->error.empty() ? "" : ": ", o->error.c_str());
    }
    std::fflush(stderr);
  }
  void finish() {
    if (tty_) std::fprintf(stderr, "\r%*s\r", 100, "");
  }

 private:
  const SweepPlan& plan_;
  bool tty_;
};

void run_sweep(const SweepArgs& a) {
  if (a.tasks && !a.task && !a.slurm) throw InputError("--tasks needs --slurm (the job array's tasks)");
  if (a.task.has_value() != a.tasks.has_value() && !(a.slurm && a.tasks && !a.task))
    throw InputError("--task and --tasks go together (a Slurm array task's slice)");
  if (a.task && (*a.task < 0 || *a.task >= *a.tasks))
    throw InputError("--task " + std::to_string(*a.task) + ": expected 0 .. " + std::to_string(*a.tasks - 1));
  if (a.slurm && (a.task || a.collect)) throw InputError("--slurm submits the whole plan: not with --task or --collect");
  if (!a.backend.empty() && a.backend != "cpu" && a.backend != "cuda")
    throw InputError("--backend: expected cpu or cuda, got '" + a.backend + "'");
  (void)gpu_indices(a.gpus, 0);  // its form, before any work (the devices once the runs are known)
  const SweepPlan plan = read_sweep_plan(a.plan);
  const std::vector<SweepRun> all = expand_plan(plan);
  const fs::path dir = a.out;
  if (std::error_code ec; fs::exists(dir, ec) && !fs::is_directory(dir, ec)) throw InputError("-o " + a.out + ": not a folder");
  if (!a.backend.empty() && std::find(plan.backends.begin(), plan.backends.end(), a.backend) == plan.backends.end())
    throw InputError("--backend " + a.backend + ": not one of the plan's backends (" + plan.file.string() + ", key 'backends')");
  // Before any work: no file the plan reads is one the sweep writes.
  check_sweep_outputs(plan, dir, !a.task && !same_file(a.plan, sweep_plan_copy(dir).string()));
  // The folder is this process's until it ends (a Slurm array's tasks each write runs of their
  // own): what it holds is checked under the lock, so no second sweep slips in between.
  FolderChanges changes(dir);
  if (!a.task) changes.lock();
  // A folder that is not a sweep's keeps what it holds; one of another plan too.
  check_sweep_folder(dir);
  check_same_plan(plan, a.plan, dir);
  // --backend B: the plan's runs on B and the references they are compared with.
  std::vector<SweepRun> runs;
  for (const SweepRun& r : all)
    if (a.backend.empty() || r.backend == a.backend || r.reference) runs.push_back(r);
  if (a.task) {
    runs = task_slice(runs, *a.task, *a.tasks);
  } else if (!same_file(a.plan, sweep_plan_copy(dir).string())) {
    changes.writing(sweep_plan_copy(dir));
    write_file_atomically(sweep_plan_copy(dir).string(), resolved_plan_yaml(plan));
  }
  if (!a.task) adopt_legacy(dir, all);

  if (a.collect) {
    changes.keep();
    const SweepSummary s = write_summary(plan, all, dir);
    if (s.failed) throw ExitRequest{1};
    return;
  }
  if (a.slurm) return submit_slurm(a, plan, runs, dir, changes);

  std::size_t todo = 0;
  RedoCounts redo;
  bool cuda_runs = false;
  const std::vector<RunState> states = run_states(plan, dir, runs, redo);
  for (std::size_t i = 0; i < runs.size(); ++i)
    if (states[i] != RunState::Done) {
      const SweepRun& r = runs[i];
      ++todo;
      cuda_runs = cuda_runs || r.backend == "cuda";
      try {
        check_backend(r.backend);
      } catch (const InputError& e) {
        throw InputError(std::string(e.what()) + " (the plan's runs on " + r.backend + "; --backend cpu runs the others)");
      }
    }
  RunnerOptions opt;
  opt.executable = executable();
  opt.jobs = a.jobs;
  opt.threads = std::max(1, available_cores() / a.jobs);
  opt.batch = a.batch;
  opt.at_once = a.at_once.value_or(0);
  opt.gpus = sweep_gpus(a.gpus, cuda_runs);
  std::string on_gpus;
  for (const std::string& g : opt.gpus) on_gpus += (on_gpus.empty() ? "" : ",") + g;
  if (!on_gpus.empty())
    on_gpus = "; CUDA children on GPUs " + on_gpus +
              (a.jobs < static_cast<int>(opt.gpus.size()) ? " (--jobs " + std::to_string(opt.gpus.size()) + " uses them all at once)" : "");
  std::fprintf(stderr, "ebh sweep: %zu runs, %zu already done%s; %d at a time, %d threads each%s%s\n", runs.size(),
               runs.size() - todo, stale_note(redo).c_str(), std::min<int>(a.jobs, static_cast<int>(std::max<std::size_t>(todo, 1))), opt.threads,
               a.batch > 1 ? (" (CUDA runs of async plans: up to " + std::to_string(a.batch) + " to a child)").c_str() : "",
               on_gpus.c_str());
  changes.keep();
  ProgressPrinter printer(plan);
  const RunnerReport rep = execute_runs(plan, runs, dir, opt, std::ref(printer), &states);
  printer.finish();
  if (rep.stopped) {
    std::fprintf(stderr, "ebh: error: %s: interrupted: %zu runs done, %zu not (%zu stopped in flight); rerun the same command to go on\n",
                 dir.c_str(), rep.ran + rep.skipped, runs.size() - rep.ran - rep.skipped - rep.failed, rep.interrupted);
    throw ExitRequest{1};
  }
  // What the runs' replays warned of, which their logs hold: each kind once, with how often.
  constexpr std::size_t kShownKinds = 8;
  for (std::size_t i = 0; i < rep.warnings.size() && i < kShownKinds; ++i) {
    const WarningKind& w = rep.warnings[i];
    std::fprintf(stderr, "ebh: warning: the runs' replays warned %zu time%s (the first in %s): %s\n", w.count,
                 w.count == 1 ? "" : "s", w.log.c_str(), escape_unprintable(w.example).c_str());
  }
  if (rep.warnings.size() > kShownKinds)
    std::fprintf(stderr, "ebh: warning: and %zu other kinds of warning, in %s\n", rep.warnings.size() - kShownKinds,
                 (dir / "runs").c_str());
  SweepSummary summary;
  if (!a.task) summary = write_summary(plan, all, dir);
  const std::size_t failed_rows = summary.failed;
  if (rep.failed) {
    const RunOutcome& f = rep.failures.front();
    std::fprintf(stderr, "ebh: error: %zu of %zu runs failed (the first: %s: %s)%s\n", rep.failed, runs.size(),
                 describe(plan, *f.run).c_str(), f.error.c_str(),
                 a.task ? "" : ("; every error is in " + sweep_summary_csv(dir).string()).c_str());
    throw ExitRequest{1};
  }
  // Runs counted as done whose outputs the summary could not read (another program's file under
  // a run's name): the sweep did not give every result.
  if (failed_rows) {
    std::fprintf(stderr, "ebh: error: %zu of %zu runs have no result in %s (their errors are there)\n", failed_rows,
                 all.size(), sweep_summary_csv(dir).c_str());
    throw ExitRequest{1};
  }
  // Outputs the summary does not take (an input file edited while the sweep ran: its replays were
  // of the edited file, the reference of the old one): no result to compare.
  if (summary.redo) {
    std::fprintf(stderr, "ebh: error: %zu of %zu runs have an output to run again in %s (their errors say why); rerun the "
                 "same command\n", summary.redo, all.size(), sweep_summary_csv(dir).c_str());
    throw ExitRequest{1};
  }
}

/// The newest modification time among the sweep's run files and plan, and the files the plan reads.
fs::file_time_type newest_input(const fs::path& dir, const std::optional<SweepPlan>& plan) {
  std::error_code ec;
  fs::file_time_type newest = fs::last_write_time(sweep_plan_copy(dir), ec);
  if (plan)
    for (const RoleFile& f : plan_input_files(*plan)) {
      std::error_code e2;
      newest = std::max(newest, fs::last_write_time(f.path, e2));
    }
  for (fs::directory_iterator it(dir / "runs", ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code e2;
    newest = std::max(newest, fs::last_write_time(it->path(), e2));
  }
  return newest;
}

/// Throws InputError when a summary not collected again lacks rows of runs of the plan whose
/// output or failure is in DIR/runs (rows deleted by hand): the report would drop them unsaid.
/// A summary without ids (an older ebh) is not checked, nor runs with no file (a folder moved to
/// where the plan's input files differ gives other ids).
void check_summary_has_runs(const SweepPlan& plan, const CsvTable& summary, const fs::path& dir) {
  const auto id_column = std::find(summary.header.begin(), summary.header.end(), "id");
  if (id_column == summary.header.end()) return;
  const auto c = static_cast<std::size_t>(id_column - summary.header.begin());
  std::set<std::string> ids;
  for (const auto& row : summary.rows) ids.insert(row[c]);
  std::size_t lacking = 0;
  const SweepRun* first = nullptr;
  const std::vector<SweepRun> runs = expand_plan(plan);
  for (const SweepRun& r : runs) {
    std::error_code ec;
    if (ids.count(r.id) || !(fs::exists(run_output(dir, r), ec) || fs::exists(run_failure(dir, r), ec))) continue;
    ++lacking;
    if (!first) first = &r;
  }
  if (lacking)
    throw InputError(sweep_summary_csv(dir).string() + ": lacks " + std::to_string(lacking) + " of the plan's runs (the first: " +
                     describe(plan, *first) + ", whose output is in " + (dir / "runs").string() +
                     "); rebuild it: ebh sweep " + sweep_plan_copy(dir).string() + " -o " + dir.string() + " --collect");
}

void run_report(const ReportArgs& a) {
  check_min_haptic_hz(a.min_haptic_hz);  // NaN passes CLI::Range
  const fs::path dir = a.dir;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(a.dir + ": not a folder (expected a sweep's folder, ebh sweep -o DIR)");
  const bool has_plan = fs::exists(sweep_plan_copy(dir), ec), has_summary = fs::exists(sweep_summary_csv(dir), ec);
  if (!has_plan && !has_summary)
    throw InputError(a.dir + ": neither summary.csv nor plan.yaml: not a sweep's folder");
  // The plan, to collect or for the plot's check: the plot replaces none of the folder's files nor
  // a file the plan reads, collected or not (with a fresh summary it overwrote a plan's recording
  // with a PNG); a folder moved without its plan's inputs has none to check.
  std::optional<SweepPlan> plan;
  std::string plan_error;
  if (has_plan) {
    try {
      plan = read_sweep_plan(sweep_plan_copy(dir));
    } catch (const InputError& e) {
      if (!has_summary) throw;
      plan_error = e.what();
    }
  }
  // Collect: the summary again when runs ended after it was written (a Slurm array's tasks), or
  // when a file the plan reads was edited since (its runs' outputs are then not current). A folder
  // copied to another machine may have its files' times reordered and its plan's input files
  // missing: then the summary it has is reported, saying so.
  bool collect = has_plan && (!has_summary || fs::last_write_time(sweep_summary_csv(dir), ec) <= newest_input(dir, plan));
  const std::string file = sweep_summary_csv(dir).string();
  std::vector<RoleFile> inputs;
  if (plan) inputs = plan_input_files(*plan);
  check_output_beside_sweep({a.plot, "the plot (--plot)"}, dir, inputs);
  // Runs the summary lists as ok whose outputs the sweep no longer takes as done (deleted, cut
  // short, replaced since): no file is newer than the summary, yet it is out of date.
  // The plan's runs and the summary as read, each once: reused below where nothing is collected.
  std::optional<std::vector<SweepRun>> plan_runs;
  std::optional<CsvTable> read;
  std::vector<OutdatedRow> outdated;
  if (plan && !collect) {
    check_input_file(file);  // a named pipe's read would wait for a writer
    try {
      plan_runs = expand_plan(*plan);
      read = parse_csv(file_text(file).value_or(""), file);
      outdated = outdated_ok_rows(*plan, *plan_runs, *read, dir);
    } catch (const InputError&) {
      // a plan whose runs do not expand, or a summary that does not read: said below, as before
    }
    if (!outdated.empty()) {
      collect = true;
      const std::string more = outdated.size() > 1 ? " (and " + std::to_string(outdated.size() - 1) + " more such runs)" : "";
      std::fprintf(stderr, "%s: out of date: it lists %s as ok, but %s%s\n", file.c_str(),
                   describe(*plan, *outdated.front().run).c_str(), escape_unprintable(outdated.front().why).c_str(),
                   more.c_str());
    }
  }
  std::string collect_error = collect ? plan_error : std::string();
  if (plan && collect) {
    try {
      if (!plan_runs) plan_runs = expand_plan(*plan);
      const std::vector<SweepRun>& runs = *plan_runs;  // `outdated` points into them
      adopt_legacy(dir, runs);
      const SweepSummary s = summarize_sweep(*plan, runs, dir);
      write_summary_files(dir, s.table);
      std::fprintf(stderr, "%s: collected %zu runs: %zu ok, %zu failed, %zu not run%s\n", sweep_summary_csv(dir).c_str(),
                   s.table.rows.size(), s.ok, s.failed, s.pending, redo_note(s).c_str());
    } catch (const InputError& e) {
      if (!has_summary) throw;
      collect_error = e.what();
    }
  }
  if (!collect_error.empty()) {
    const std::size_t n = outdated.size();
    const std::string except =
        n == 0   ? ""
        : n == 1 ? ", except 1 run it lists as ok: not run yet (its output is to run again)"
                 : ", except " + std::to_string(n) + " runs it lists as ok: not run yet (their outputs are to run again)";
    std::fprintf(stderr, "ebh: warning: %s: cannot collect the runs again (%s); reporting summary.csv as it is%s\n",
                 a.dir.c_str(), collect_error.c_str(), except.c_str());
  }
  check_input_file(file);
  CsvTable summary = read && !collect ? std::move(*read) : parse_csv(file_text(file).value_or(""), file);
  if (plan && !collect) check_summary_has_runs(*plan, summary, dir);
  // Not collected again: the rows of outputs gone since are no results (their error says why).
  if (!collect_error.empty() && !outdated.empty()) {
    const std::size_t c_status = summary.column("status", file), c_id = summary.column("id", file);
    const auto c_error = std::find(summary.header.begin(), summary.header.end(), "error");
    for (const OutdatedRow& o : outdated) {
      if (o.row >= summary.rows.size() || summary.rows[o.row][c_id] != o.run->id) continue;  // rewritten meanwhile
      summary.rows[o.row][c_status] = "pending";
      if (c_error != summary.header.end())
        summary.rows[o.row][static_cast<std::size_t>(c_error - summary.header.begin())] = o.why;
    }
  }
  const std::vector<ReportGroup> groups = build_report(summary, file, a.min_haptic_hz);
  std::fputs(report_markdown(groups).c_str(), stdout);
  if (!a.plot.empty()) {
    write_report_plot(groups, a.plot);
    std::fprintf(stderr, "%s: run time against force error\n", a.plot.c_str());
  }
}

void setup(CLI::App& root) {
  auto args = std::make_shared<SweepArgs>();
  CLI::App* c = root.add_subcommand("sweep", "Many replays from a plan (locally or on Slurm), resumable; DIR/summary.csv");
  c->add_option("plan", args->plan, "Sweep plan (YAML, docs/FORMATS.md)");
  c->add_option("-o,--output", args->out, "The sweep's folder (runs/, plan.yaml, summary.csv)");
  c->add_option("--jobs", args->jobs, "Replays at a time (default 1: timings undisturbed); threads split so jobs x threads = cores")
      ->check(ebh::cli::whole_number(1, 1024));
  c->add_option("--gpus", args->gpus,
                "CUDA devices the CUDA runs spread over, one per child (all, the default, or numbers as this process "
                "sees them: 0,1); with --jobs N, N children at a time");
  c->add_option("--backend", args->backend, "Run only the plan's runs on cpu or cuda (and the CPU references)");
  CLI::Option* batch_option =
      c->add_option("--batch", args->batch,
                    "CUDA runs per child: up to B go to one `ebh replay --batch` on the GPU (async plans; default 1)")
          ->check(ebh::cli::whole_number(1, 1024));
  c->add_option("--at-once", args->at_once, "With --batch: the children's --at-once (replays side by side)")
      ->check(ebh::cli::whole_number(1, 1024))
      ->needs(batch_option);
  c->add_flag("--collect", args->collect, "Only rebuild DIR/summary.csv and summary.h5 from the runs' outputs");
  CLI::Option* slurm_option =
      c->add_flag("--slurm", args->slurm, "Submit the plan as a Slurm job array (sbatch --array) instead of running it here");
  c->add_option("--slurm-args", args->slurm_args, "More sbatch options, e.g. \"--partition=gpu --gres=gpu:1 -c 4\"")
      ->needs(slurm_option);
  c->add_option("--tasks", args->tasks, "Array tasks with --slurm (default: one per run, at most 1000; at most one per run)")
      ->check(ebh::cli::whole_number(1, 100000));
  c->add_option("--task", args->task, "")->group("");  // a Slurm array task's slice (with --tasks)
  auto report = std::make_shared<ReportArgs>();
  CLI::App* r = c->add_subcommand("report", "Run time against force error: Markdown table, Pareto front, --plot PNG");
  r->add_option("dir", report->dir, "The sweep's folder")->required();
  r->add_option("--plot", report->plot, "Also draw force RMS error against wall time into this PNG");
  r->add_option("--min-haptic-hz", report->min_haptic_hz,
                "Configurations with fewer haptic ticks per second are listed but no candidates: not on the front, "
                "not against the baseline (default 1000, the virtual tool's rate; 0: every one)")
      ->check(CLI::Range(0.0, 1e6));
  r->callback([report] { run_report(*report); });
  c->callback([args, c] {
    if (c->got_subcommand("report")) return;
    if (args->plan.empty()) throw InputError("sweep: expected a plan (ebh sweep PLAN.yaml -o DIR) or `ebh sweep report DIR`");
    if (args->out.empty()) throw InputError("sweep: -o DIR is required (the sweep's folder)");
    run_sweep(*args);
  });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
