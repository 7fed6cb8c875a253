#include "sweep/runner.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include "io/atomic.hpp"
#include "core/error.hpp"
#include "io/h5.hpp"
#include "io/recording.hpp"
#include "io/sha256.hpp"
#include "scene/scene.hpp"

extern char** environ;

namespace ebh {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

/// A child in flight: its replays (one, or those of its `ebh replay --batch` file, in the file's
/// line order), its process, the read end of its stdout+stderr pipe and what it printed.
struct Child {
  std::vector<const SweepRun*> runs;
  pid_t pid = -1;
  int fd = -1;
  std::string text;
  Clock::time_point t0;
  int gpu = -1;  ///< its entry of RunnerOptions::gpus (-1: none, a CPU child or no --gpus)
  /// Each run's output as the child started (a stale one, run again): its time, or none.
  std::vector<std::optional<fs::file_time_type>> before;
};

/// The time of `file`'s last write, none where it is not there.
std::optional<fs::file_time_type> written_at(const fs::path& file) {
  std::error_code ec;
  const fs::file_time_type t = fs::last_write_time(file, ec);
  if (ec) return std::nullopt;
  return t;
}

/// The child's environment: ours with OMP_NUM_THREADS replaced, and CUDA_VISIBLE_DEVICES too when
/// `gpu` is not empty.
std::vector<std::string> child_environment(int threads, const std::string& gpu = {}) {
  std::vector<std::string> env;
  for (char** e = environ; e && *e; ++e)
    if (std::strncmp(*e, "OMP_NUM_THREADS=", 16) != 0 && (gpu.empty() || std::strncmp(*e, "CUDA_VISIBLE_DEVICES=", 21) != 0))
      env.emplace_back(*e);
  env.push_back("OMP_NUM_THREADS=" + std::to_string(threads));
  if (!gpu.empty()) env.push_back("CUDA_VISIBLE_DEVICES=" + gpu);
  return env;
}

std::vector<std::string> replay_arguments(const SweepPlan& plan, const SweepRun& run, const fs::path& dir,
                                          const std::string& executable) {
  std::vector<std::string> a = {executable, "replay", plan.scenes[run.scene].scene_file.string(), run.recording.string(),
                                "-o", run_output(dir, run).string(), "--backend", run.backend, "--mode", plan.mode,
                                "--quiet"};
  if (plan.start > 0) a.insert(a.end(), {"--start", shortest_number(plan.start)});
  if (plan.duration > 0) a.insert(a.end(), {"--duration", shortest_number(plan.duration)});
  for (const std::string& s : run.set_arguments()) a.insert(a.end(), {"--set", s});
  return a;
}

/// One argument on a line of a --batch file (CLI11 splits the line as a shell would): quoted
/// when it holds a blank or a quote.
std::string batch_word(const std::string& a) {
  if (!a.empty() && a.find_first_of(" \t\"'\\") == std::string::npos) return a;
  std::string q = "\"";
  for (const char ch : a) {
    if (ch == '"' || ch == '\\') q += '\\';
    q += ch;
  }
  return q + "\"";
}

/// The --batch file of `runs` (RunnerOptions::batch): line k + 1 is run k, the arguments its own
/// `ebh replay` would get (batch_error_line finds its error by that line number).
std::string batch_file_text(const SweepPlan& plan, const std::vector<const SweepRun*>& runs, const fs::path& dir) {
  std::string text;
  for (const SweepRun* r : runs) {
    const std::vector<std::string> a = replay_arguments(plan, *r, dir, "");
    for (std::size_t i = 2; i < a.size(); ++i) {
      if (i > 2) text += ' ';
      text += batch_word(a[i]);
    }
    text += "\n";
  }
  return text;
}

std::vector<char*> pointers(std::vector<std::string>& v) {
  std::vector<char*> p;
  for (std::string& s : v) p.push_back(s.data());
  p.push_back(nullptr);
  return p;
}

int wait_for(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

/// The child's side of start_process, between fork and exec: only async-signal-safe calls. Its
/// stdout and stderr go to `out`; with `die_with_parent` it gets SIGTERM when this process ends,
/// however it ends (SIGKILL included: no replay goes on writing into the sweep's folder as an
/// orphan). An exec that fails writes its errno to `err_fd`.
[[noreturn]] void exec_child(char* const* argv, char* const* envp, int out, int err_fd, bool die_with_parent, pid_t parent) {
  // This process's handlers (io/atomic.hpp) would swallow a SIGTERM before the exec; a signal this
  // process ignores (a `nohup`'d sweep's SIGHUP) stays ignored in the child, as exec keeps it.
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGUSR2, SIGALRM, SIGXCPU, SIGVTALRM, SIGPROF}) {
    struct sigaction now {};
    if (sigaction(sig, nullptr, &now) == 0 && now.sa_handler == SIG_IGN) continue;
    signal(sig, SIG_DFL);
  }
  signal(SIGPIPE, SIG_DFL);  // ebh ignores it for itself (tools/ebh/main.cpp); the child starts with the default
  if (die_with_parent) {
    if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0) _exit(127);
    if (getppid() != parent) _exit(128 + SIGTERM);  // the parent ended before the line above
  }
  if (dup2(out, STDOUT_FILENO) < 0 || dup2(out, STDERR_FILENO) < 0) {
    const int err = errno;
    (void)!write(err_fd, &err, sizeof err);
    _exit(127);
  }
  if (std::strchr(argv[0], '/')) execve(argv[0], argv, envp);
  else execvpe(argv[0], argv, envp);
  const int err = errno;
  (void)!write(err_fd, &err, sizeof err);
  _exit(127);
}

/// Starts argv (argv[0] a path, or a name looked up on PATH) with its stdout and stderr on a pipe;
/// returns its pid and the pipe's read end. With `die_with_parent` the child ends (SIGTERM) when
/// this process does (exec_child). Throws InputError naming `what` when it cannot start.
std::pair<pid_t, int> start_process(std::vector<std::string> args, std::vector<std::string>* env, const std::string& what,
                                    bool die_with_parent = false) {
  int fds[2], errs[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw InputError(what + ": cannot start " + args[0] + ": " + os_reason(errno));
  if (pipe2(errs, O_CLOEXEC) != 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw InputError(what + ": cannot start " + args[0] + ": " + os_reason(err));
  }
  std::vector<char*> argv = pointers(args);
  std::vector<char*> envp = env ? pointers(*env) : std::vector<char*>{};
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid == 0) exec_child(argv.data(), env ? envp.data() : environ, fds[1], errs[1], die_with_parent, parent);
  const int fork_err = errno;
  ::close(fds[1]);
  ::close(errs[1]);
  int err = pid < 0 ? fork_err : 0;
  if (pid > 0) {  // the exec's errno, or nothing once it succeeded (the pipe closes on exec)
    ssize_t got;
    while ((got = ::read(errs[0], &err, sizeof err)) < 0 && errno == EINTR) {
    }
    if (got != static_cast<ssize_t>(sizeof err)) err = 0;
    else wait_for(pid);
  }
  ::close(errs[0]);
  if (err != 0) {
    ::close(fds[0]);
    throw InputError(what + ": cannot start " + args[0] + ": " + os_reason(err));
  }
  return {pid, fds[0]};
}

/// Reads what the child printed (appending to `text`); false at the end of its output.
bool read_some(int fd, std::string& text) {
  char buf[65536];
  const ssize_t got = ::read(fd, buf, sizeof buf);
  if (got > 0) text.append(buf, static_cast<std::size_t>(got));
  return got > 0 || (got < 0 && errno == EINTR);
}

/// The replay's error line: its last "ebh: error: WHAT" line's WHAT ("internal error: WHAT" for
/// an internal error), else its last line, else how it ended.
std::string error_line(const std::string& text, int status) {
  std::string last, last_error;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const auto cr = line.find_last_of('\r');  // a progress bar's leftovers
    if (cr != std::string::npos) line = line.substr(cr + 1);
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    last = line;
    if (line.rfind("ebh: error: ", 0) == 0) last_error = line.substr(12);
    else if (line.rfind("ebh: internal error: ", 0) == 0) last_error = line.substr(5);
  }
  if (!last_error.empty()) return last_error;
  std::string how = WIFSIGNALED(status) ? "the replay was killed by signal " + std::to_string(WTERMSIG(status))
                                        : "the replay exited with status " + std::to_string(WEXITSTATUS(status));
  return last.empty() ? how : how + " (" + last + ")";
}

/// The error of replay `line` (1-based) of a --batch child: its "ebh: error: FILE:LINE: WHAT"
/// line's WHAT, else the child's own error (one that stopped every replay: no GPU, a bad file).
std::string batch_error_line(const std::string& text, int status, const fs::path& file, std::size_t line) {
  const std::string tag = "ebh: error: " + file.string() + ":" + std::to_string(line) + ": ";
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (l.rfind(tag, 0) == 0) return l.substr(tag.size());
  return error_line(text, status);
}

void remove_file(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

}  // namespace

CommandResult run_command(const std::vector<std::string>& argv) {
  const auto [pid, fd] = start_process(argv, nullptr, argv.at(0));
  CommandResult r;
  while (read_some(fd, r.output)) {
  }
  ::close(fd);
  const int status = wait_for(pid);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

void add_warning_kinds(const std::string& text, const std::vector<std::string>& outputs, const fs::path& log,
                       std::vector<WarningKind>& kinds) {
  static const std::string prefix = "ebh: warning: ";
  std::size_t at = 0;
  while (at < text.size()) {
    std::size_t end = text.find('\n', at);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(at, end - at);
    at = end + 1;
    if (line.rfind(prefix, 0) != 0) continue;
    const std::string said = line.substr(prefix.size());
    std::string key = said;
    for (const std::string& o : outputs)
      if (!o.empty())
        for (std::size_t p = key.find(o); p != std::string::npos; p = key.find(o, p + 3)) key.replace(p, o.size(), "RUN");
    std::string kind;  // each run of digits (and decimal points between them) as one '#'
    for (const char ch : key) {
      const bool number = std::isdigit(static_cast<unsigned char>(ch)) != 0 || (ch == '.' && !kind.empty() && kind.back() == '#');
      if (!number) kind += ch;
      else if (kind.empty() || kind.back() != '#') kind += '#';
    }
    auto same = std::find_if(kinds.begin(), kinds.end(), [&](const WarningKind& k) { return k.kind == kind; });
    if (same == kinds.end()) kinds.push_back({kind, said, log, 1});
    else ++same->count;
  }
}

fs::path run_output(const fs::path& dir, const SweepRun& run) { return dir / "runs" / (run.id + ".h5"); }
fs::path run_log(const fs::path& dir, const SweepRun& run) { return dir / "runs" / (run.id + ".log"); }
fs::path run_failure(const fs::path& dir, const SweepRun& run) { return dir / "runs" / (run.id + ".failed"); }
fs::path batch_file(const fs::path& dir, const SweepRun& first) { return dir / "batches" / (first.id + ".txt"); }

InputDigests::InputDigests(const SweepPlan* plan) {
  if (plan) files_ = plan->sha256;
}

const std::string& InputDigests::file(const fs::path& path) { return sha256_file_cached(files_, path.string()); }

const InputDigests::RunInputs& InputDigests::run_inputs(const SweepPlan& plan, const SweepRun& run) {
  const fs::path& scene = plan.scenes[run.scene].scene_file;
  const std::vector<std::string> set = run.set_arguments();
  std::string key = scene.string() + '\n' + run.recording.string();
  for (const std::string& s : set) key += '\n' + s;
  auto it = runs_.find(key);
  if (it == runs_.end()) {
    // A scene that no longer loads throws here (InputError), as it did before the rates were
    // read: the plan loaded each scene with each run's overrides when it was read (plan.cpp).
    const SceneSpec spec = load_scene_spec(scene, set);
    RunInputs in;
    for (const SceneInputFile& file : scene_input_files(spec)) in.files.emplace_back(file.key, file.path);
    in.files.emplace_back("recording", run.recording);
    in.haptic_hz = spec.haptic_hz;
    in.physical_hz = spec.physical_hz;
    it = runs_.emplace(key, std::move(in)).first;
  }
  return it->second;
}

const std::vector<std::pair<std::string, fs::path>>& InputDigests::run_files(const SweepPlan& plan, const SweepRun& run) {
  return run_inputs(plan, run).files;
}

std::pair<double, double> InputDigests::run_rates(const SweepPlan& plan, const SweepRun& run) {
  const RunInputs& in = run_inputs(plan, run);
  return {in.haptic_hz, in.physical_hz};
}

namespace {
/// Whether `f` is a replay with the run's window, mode, backend and overrides, as its attributes
/// say (`ebh replay` writes them: docs/FORMATS.md), made as the sweep makes it (replay_arguments):
/// no pose transform and the rates of the run's scene under its overrides (`rates`: haptic,
/// physical Hz). Not one replayed by hand or copied under the run's name, nor an HDF5 file of
/// another program. The window's length is the one a replay of the recording gives (a duration
/// past its end is cut to it).
bool is_replay_of(const h5::File& f, const SweepPlan& plan, const SweepRun& run, std::pair<double, double> rates) {
  // haptic_hz and physical_hz are required: every `ebh replay` output has held them (they came
  // before the attributes above), and the summary cannot read a replay without them
  // (read_replay_trace); transform_option and tool_transform_option came after overrides_list, so
  // a replay older than them, which could not be given a transform, counts as made without one.
  for (const char* a : {"mode", "backend", "start", "duration", "overrides_list", "haptic_hz", "physical_hz"})
    if (!f.has_attr(a)) return false;
  for (const char* a : {"transform_option", "tool_transform_option"})
    if (f.has_attr(a) && !f.attr_string(a).empty()) return false;
  // The rates as written are the loaded scene's own doubles (replay_output.cpp): equal bit for bit.
  if (f.attr_double("haptic_hz") != rates.first || f.attr_double("physical_hz") != rates.second) return false;
  std::string overrides;
  for (const std::string& s : run.set_arguments()) {
    if (!overrides.empty()) overrides += '\n';
    overrides += s;
  }
  if (f.attr_string("mode") != plan.mode || f.attr_string("backend") != run.backend ||
      f.attr_string("overrides_list") != overrides || f.attr_double("start") != plan.start)
    return false;
  if (plan.duration == 0) return f.attr_double("duration") == 0;  // a replay of the rest of the recording records 0
  const auto length = plan.recording_length.find(run.recording.string());
  if (length == plan.recording_length.end()) return true;  // a plan made without the lengths: not checked
  // (read_sweep_plan checked the window with every run's haptic tick: this one does not throw)
  return f.attr_double("duration") == replay_window(plan.start, plan.duration, length->second, 1.0 / rates.first,
                                                    run.recording.string(), "start", "duration");
}
}  // namespace

RunState run_state(const fs::path& dir, const SweepPlan& plan, const SweepRun& run, InputDigests& digests) {
  const fs::path out = run_output(dir, run);
  std::error_code ec;
  if (!fs::exists(out, ec)) return RunState::Missing;
  const auto& files = digests.run_files(plan, run);
  std::vector<std::string> recorded(files.size());  // the SHA-256 the output holds for each ("": none)
  try {
    const h5::File f = h5::File::open_read(out.string());
    if (!is_replay_of(f, plan, run, digests.run_rates(plan, run))) return RunState::Other;
    for (std::size_t k = 0; k < files.size(); ++k)
      if (f.has_attr(files[k].first + "_sha256")) recorded[k] = f.attr_string(files[k].first + "_sha256");
  } catch (const InputError&) {
    // An HDF5 file that does not open (cut short by a copy or a full disk) or an empty one runs
    // again; a file of another kind is another program's, left alone as done.
    char head[8] = {};
    std::ifstream in(out, std::ios::binary);
    in.read(head, sizeof head);
    const bool empty = in.gcount() == 0;
    return empty || std::memcmp(head, "\x89HDF\r\n\x1a\n", 8) == 0 ? RunState::Unreadable : RunState::Done;
  }
  for (std::size_t k = 0; k < files.size(); ++k)
    if (!recorded[k].empty() && recorded[k] != digests.file(files[k].second)) return RunState::Stale;
  return RunState::Done;
}

const char* redo_reason(RunState state) {
  switch (state) {
    case RunState::Stale: return "made from input files edited or replaced since";
    case RunState::Unreadable: return "whose output does not open";
    case RunState::Other: return "whose output is not the run's replay (another window, mode, backend, overrides, pose transform or "
                                 "rate, or no replay)";
    case RunState::Missing:
    case RunState::Done: break;
  }
  return "";
}

std::size_t adopt_legacy_outputs(const fs::path& dir, const std::vector<SweepRun>& runs) {
  std::size_t taken = 0;
  std::error_code ec;
  if (!fs::is_directory(dir / "runs", ec)) return 0;
  for (const SweepRun& r : runs) {
    if (r.legacy_id.empty() || r.legacy_id == r.id) continue;
    SweepRun legacy = r;
    legacy.id = r.legacy_id;
    const std::pair<fs::path, fs::path> files[] = {{run_output(dir, legacy), run_output(dir, r)},
                                                   {run_log(dir, legacy), run_log(dir, r)},
                                                   {run_failure(dir, legacy), run_failure(dir, r)}};
    if (fs::exists(run_output(dir, r), ec) || fs::exists(run_failure(dir, r), ec)) continue;
    for (const auto& [from, to] : files) {
      if (!fs::exists(from, ec)) continue;
      fs::rename(from, to, ec);
      if (ec) throw InputError(from.string() + ": cannot rename it to " + to.filename().string() + ": " + ec.message());
      if (from == files[0].first) ++taken;
    }
  }
  return taken;
}

std::string read_run_failure(const fs::path& dir, const SweepRun& run) {
  std::ifstream in(run_failure(dir, run));
  std::string line;
  if (!in || !std::getline(in, line)) return "";
  return line;
}

int available_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  int n = 0;
  if (sched_getaffinity(0, sizeof set, &set) == 0) n = CPU_COUNT(&set);
  if (n <= 0) n = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  // A Slurm task's share where the cluster does not bind tasks to cores (TaskPlugin=task/none).
  if (const char* s = std::getenv("SLURM_CPUS_PER_TASK"); s && *s) {
    char* end = nullptr;
    const long c = std::strtol(s, &end, 10);
    if (*end == '\0' && c > 0) n = std::min(n, static_cast<int>(c));
  }
  return n;
}

std::vector<std::string> gpu_entries(const std::vector<int>& indices, int count, const char* visible) {
  std::vector<std::string> listed;  // this process's CUDA_VISIBLE_DEVICES, entry by entry
  if (visible) {
    std::stringstream in(visible);
    for (std::string e; std::getline(in, e, ',');) listed.push_back(e);
  }
  std::vector<std::string> out;
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const int i = indices[k];
    if (i < 0 || i >= count)
      throw InputError("--gpus " + std::to_string(i) + ": " +
                       (count == 0 ? std::string("this process sees no CUDA device")
                                   : "this process sees " + std::to_string(count) + " CUDA device" + (count > 1 ? "s" : "") +
                                         ", numbered 0-" + std::to_string(count - 1)) +
                       (visible ? std::string(" (CUDA_VISIBLE_DEVICES=") + visible + ")" : std::string()));
    if (std::find(indices.begin(), indices.begin() + static_cast<std::ptrdiff_t>(k), i) != indices.begin() + static_cast<std::ptrdiff_t>(k))
      throw InputError("--gpus: device " + std::to_string(i) + " is listed twice");
    out.push_back(visible && static_cast<std::size_t>(i) < listed.size() ? listed[static_cast<std::size_t>(i)] : std::to_string(i));
  }
  return out;
}

std::vector<SweepRun> task_slice(const std::vector<SweepRun>& runs, int task, int tasks) {
  std::vector<SweepRun> out;
  for (std::size_t i = 0; i < runs.size(); ++i)
    if (static_cast<int>(i % static_cast<std::size_t>(tasks)) == task) out.push_back(runs[i]);
  return out;
}

RunnerReport execute_runs(const SweepPlan& plan, const std::vector<SweepRun>& runs, const fs::path& dir,
                          const RunnerOptions& options, const RunnerCallback& progress,
                          const std::vector<RunState>* states) {
  install_interrupt_handlers();
  RunnerReport report;
  RunnerProgress p;
  p.total = runs.size();
  std::vector<const SweepRun*> pending;
  InputDigests digests(&plan);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const SweepRun& r = runs[i];
    const RunState state = states ? (*states)[i] : run_state(dir, plan, r, digests);
    report.stale += state == RunState::Stale ? 1 : 0;
    report.unreadable += state == RunState::Unreadable ? 1 : 0;
    if (state == RunState::Done) {
      ++report.skipped;
      ++p.skipped;
      ++p.done;
      if (progress) {
        const RunOutcome o{&r, RunOutcome::Status::Skipped, 0, {}};
        progress(p, &o);
      }
    } else {
      pending.push_back(&r);
    }
  }
  {
    std::error_code ec;
    fs::create_directories(dir / "runs", ec);
    if (ec) throw InputError((dir / "runs").string() + ": cannot create the folder: " + ec.message());
  }
  std::vector<std::string> env = child_environment(options.threads);
  std::vector<std::vector<std::string>> gpu_env;  // per entry of options.gpus
  for (const std::string& g : options.gpus) gpu_env.push_back(child_environment(options.threads, g));
  std::vector<int> on_gpu(options.gpus.size(), 0);  // CUDA children running on each
  std::vector<Child> active;
  std::size_t next = 0;
  bool forwarded = false, killed = false;
  Clock::time_point forwarded_at{};
  set_interrupt_grace(0);  // this process waits for its replays, which have their own grace

  auto finish = [&](Child& c) {
    const int status = wait_for(c.pid);
    // A child killed by a signal (SIGKILL, the OOM killer) could not remove the temporaries of
    // its outputs (io/atomic.hpp): they go now, not when the run is redone.
    for (const SweepRun* run : c.runs) remove_file(partial_path_for(run_output(dir, *run).string(), c.pid));
    const double seconds = std::chrono::duration<double>(Clock::now() - c.t0).count();
    for (std::size_t k = 0; k < c.runs.size(); ++k) {
      const SweepRun& run = *c.runs[k];
      RunOutcome o{&run, RunOutcome::Status::Done, seconds, {}};
      // An output written by this child (complete or not there at all: io/atomic.hpp), not a
      // stale one it was to replace.
      const std::optional<fs::file_time_type> now = written_at(run_output(dir, run));
      const bool written = now && (!c.before[k] || *now != *c.before[k]);
      // A batch child exits non-zero when any of its replays failed; each replay's output says
      // whether it ran. So does that of a child the interrupt reached after it wrote it: done.
      const bool ok = written && (c.runs.size() > 1 || interrupted() || (WIFEXITED(status) && WEXITSTATUS(status) == 0));
      if (ok) {
        ++report.ran;
        remove_file(run_failure(dir, run));
        // After an interrupt no file is written (io/atomic.hpp); the log is only what it printed.
        if (!c.text.empty() && !interrupted()) write_file_atomically(run_log(dir, run).string(), c.text);
        else if (c.text.empty()) remove_file(run_log(dir, run));
        // Once per child: a batch child's text holds each of its replays' lines once.
        if (k == 0) {
          std::vector<std::string> outputs;
          for (const SweepRun* r : c.runs) outputs.push_back(run_output(dir, *r).string());
          add_warning_kinds(c.text, outputs, run_log(dir, run), report.warnings);
        }
      } else if (interrupted()) {
        o.status = RunOutcome::Status::Interrupted;  // stopped by the interrupt: not run, not failed
        ++report.interrupted;
      } else {
        o.status = RunOutcome::Status::Failed;
        o.error = c.runs.size() > 1 ? batch_error_line(c.text, status, batch_file(dir, *c.runs.front()), k + 1)
                                    : error_line(c.text, status);
        ++report.failed;
        ++p.failed;
        write_file_atomically(run_failure(dir, run).string(), o.error + "\n" + c.text);
        report.failures.push_back(o);
      }
      if (o.status != RunOutcome::Status::Interrupted) ++p.done;
      --p.running;
      if (progress) progress(p, &o);
    }
    if (c.runs.size() > 1 && !interrupted()) remove_file(batch_file(dir, *c.runs.front()));
    if (c.gpu >= 0) --on_gpu[static_cast<std::size_t>(c.gpu)];
  };

  while (true) {
    if (interrupted() && !forwarded) {
      for (const Child& c : active) kill(c.pid, SIGTERM);
      forwarded = true;
      forwarded_at = Clock::now();
    }
    if (forwarded && !killed &&
        std::chrono::duration<double>(Clock::now() - forwarded_at).count() > options.stop_grace_s) {
      for (const Child& c : active) kill(c.pid, SIGKILL);  // stuck past its own grace
      killed = true;
    }
    while (!interrupted() && active.size() < static_cast<std::size_t>(std::max(1, options.jobs)) && next < pending.size()) {
      // CUDA runs of an async plan go options.batch to a child (`ebh replay --batch`), the others one each.
      std::vector<const SweepRun*> take{pending[next++]};
      const bool batched = options.batch > 1 && take.front()->backend == "cuda" && plan.mode == "async";
      while (batched && take.size() < static_cast<std::size_t>(options.batch) && next < pending.size() &&
             pending[next]->backend == "cuda")
        take.push_back(pending[next++]);
      std::vector<std::string> argv;
      if (take.size() > 1) {
        const fs::path file = batch_file(dir, *take.front());
        write_file_atomically(file.string(), batch_file_text(plan, take, dir));
        argv = {options.executable, "replay", "--batch", file.string(), "--quiet"};
        if (options.at_once > 0) argv.insert(argv.end(), {"--at-once", std::to_string(options.at_once)});
      } else {
        argv = replay_arguments(plan, *take.front(), dir, options.executable);
      }
      // A CUDA child goes to the GPU with the fewest CUDA children running (the first of those).
      int gpu = -1;
      if (take.front()->backend == "cuda" && !on_gpu.empty())
        gpu = static_cast<int>(std::min_element(on_gpu.begin(), on_gpu.end()) - on_gpu.begin());
      std::vector<std::optional<fs::file_time_type>> before;  // taken before the child can write
      for (const SweepRun* r : take) before.push_back(written_at(run_output(dir, *r)));
      const auto [pid, fd] = start_process(argv, gpu >= 0 ? &gpu_env[static_cast<std::size_t>(gpu)] : &env, dir.string(), true);
      if (gpu >= 0) ++on_gpu[static_cast<std::size_t>(gpu)];
      active.push_back(Child{take, pid, fd, {}, Clock::now(), gpu, std::move(before)});
      p.running += take.size();
      if (progress) progress(p, nullptr);
    }
    if (active.empty()) break;
    std::vector<pollfd> fds;
    for (const Child& c : active) fds.push_back(pollfd{c.fd, POLLIN, 0});
    const int n = poll(fds.data(), fds.size(), 100);
    if (n < 0 && errno != EINTR) throw InputError(dir.string() + ": waiting for the replays: " + os_reason(errno));
    for (std::size_t i = fds.size(); n > 0 && i-- > 0;) {
      if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      if (read_some(active[i].fd, active[i].text)) continue;
      ::close(active[i].fd);  // end of its output: it has exited (or is about to)
      finish(active[i]);
      active.erase(active.begin() + static_cast<long>(i));
    }
  }
  report.stopped = interrupted() && (next < pending.size() || report.interrupted > 0);
  return report;
}

}  // namespace ebh
