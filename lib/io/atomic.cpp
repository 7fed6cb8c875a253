#include "io/atomic.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>

#include "core/error.hpp"
#include "core/file_names.hpp"

namespace ebh {
namespace fs = std::filesystem;
namespace {

/// What a file that is not a regular one is, for a message ("a character device").
std::string file_kind(fs::file_type type) {
  switch (type) {
    case fs::file_type::character: return "a character device";
    case fs::file_type::block: return "a block device";
    case fs::file_type::fifo: return "a named pipe";
    case fs::file_type::socket: return "a socket";
    default: return "a special file";
  }
}

// The signal handler may only touch lock-free atomics and call async-signal-safe functions
// (unlink, _exit), so temporary names live in a fixed table of plain buffers.
constexpr int kSlots = 32;
constexpr std::size_t kPathMax = 4096;
char g_paths[kSlots][kPathMax];
std::atomic<int> g_used[kSlots];  // 0 free, 1 being written, 2 holds a path
volatile std::sig_atomic_t g_interrupted = 0;
volatile std::sig_atomic_t g_first_signal = 0;
std::atomic<unsigned> g_grace{kInterruptGraceSeconds};
std::atomic<bool> g_installed{false};
std::atomic<long> g_child{0};  // killed before a sudden end (set_child_to_kill)
std::atomic<bool> g_alarm_stops{true};  // false: SIGALRM was ignored at the start; only the grace's counts
std::atomic<std::size_t> g_committed{0};
std::atomic<long long> g_first_ns{0};  // when the first interrupt came (CLOCK_MONOTONIC)
static_assert(std::atomic<unsigned>::is_always_lock_free && std::atomic<int>::is_always_lock_free &&
              std::atomic<long>::is_always_lock_free && std::atomic<bool>::is_always_lock_free &&
              std::atomic<long long>::is_always_lock_free);

/// The signals that stop a run. SIGINT (Ctrl-C), SIGTERM (kill, `timeout`) and SIGHUP (the terminal
/// closed), and those whose default action would end the process without a word and leave its
/// temporaries: SIGUSR1, SIGUSR2, SIGALRM (`timeout -s ALRM`), SIGXCPU (the soft limit of
/// `ulimit -t`), SIGVTALRM and SIGPROF. SIGQUIT keeps its core dump; SIGXFSZ is ignored instead
/// (tools/ebh/main.cpp: the write fails with EFBIG, reported as a full disk is).
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGUSR2, SIGALRM, SIGXCPU, SIGVTALRM, SIGPROF};

/// The signal's name, for the early handler's line (a string literal: async-signal-safe).
const char* signal_name(int sig) {
  switch (sig) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    case SIGUSR1: return "SIGUSR1";
    case SIGUSR2: return "SIGUSR2";
    case SIGALRM: return "SIGALRM";
    case SIGXCPU: return "SIGXCPU";
    case SIGVTALRM: return "SIGVTALRM";
    case SIGPROF: return "SIGPROF";
    default: return "a signal";
  }
}

/// Unlinks every registered path, then removes those that are folders (emptied by the unlinks
/// before: a temporary folder and the files registered in it).
void remove_temporaries() {
  for (int i = 0; i < kSlots; ++i)
    if (g_used[i].load() == 2) unlink(g_paths[i]);
  for (int i = 0; i < kSlots; ++i)
    if (g_used[i].load() == 2) rmdir(g_paths[i]);
}

/// Ends the process now (async-signal-safe): the recorded child killed first, then the temporaries
/// removed.
[[noreturn]] void end_now(int status) {
  if (const long child = g_child.load(); child > 0) kill(static_cast<pid_t>(child), SIGKILL);
  remove_temporaries();
  _exit(status);
}

/// CLOCK_MONOTONIC in nanoseconds (clock_gettime is async-signal-safe).
long long now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

extern "C" void on_signal(int sig) {
  const long long now = now_ns();
  if (g_interrupted) {
    // The same signal again within 0.1 s is the same interrupt: `timeout` sends its signal to the
    // command and then to the command's process group, and the two may arrive one after the other.
    // A person's second Ctrl-C comes later.
    if (sig == g_first_signal && now - g_first_ns.load() < 100000000LL) return;
    static const char kMessage[] = "ebh: interrupted again: stopping now; unfinished outputs removed\n";
    (void)!write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
    end_now(128 + sig);
  }
  g_first_ns.store(now);
  g_interrupted = 1;
  g_first_signal = sig;
  const unsigned grace = g_grace.load();
  if (grace > 0) alarm(grace);
}

/// Before a command polls for interrupts: end now, saying so (async-signal-safe calls only).
extern "C" void on_early_signal(int sig) {
  char line[96];
  std::size_t n = 0;
  for (const char* part : {"ebh: interrupted by ", signal_name(sig), "; no output file written\n"})
    for (; *part && n < sizeof line; ++part) line[n++] = *part;
  (void)!write(STDERR_FILENO, line, n);
  end_now(128 + sig);
}

/// The first interrupt's grace ran out: end as on a second signal.
void grace_over() {
  static const char kMessage[] = "ebh: still running after the interrupt's grace: stopping now\n";
  (void)!write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
  end_now(128 + (g_first_signal ? g_first_signal : SIGTERM));
}

/// SIGALRM: the grace's timer (alarm(), sent by the kernel), or one sent by a process (`timeout -s
/// ALRM`, kill: si_code SI_USER, SI_QUEUE or SI_TKILL, all <= 0), which stops the run as SIGTERM
/// does, unless the process started with SIGALRM ignored.
extern "C" void on_alarm(int sig, siginfo_t* info, void*) {
  if (info != nullptr && info->si_code <= 0) {
    if (g_alarm_stops.load()) on_signal(sig);
  } else if (g_interrupted) {
    grace_over();
  }
}

// The files being read (CrashNamesInput), for the crash handler: plain buffers, as the
// temporaries' table; `order` tells the innermost.
constexpr int kReadSlots = 8;
char g_reading[kReadSlots][kPathMax];
std::atomic<long> g_reading_order[kReadSlots];  // 0 free, -1 being written, > 0 holds a path
std::atomic<long> g_reading_next{1};

/// SIGSEGV, SIGBUS or SIGABRT (the C library's abort on a heap HDF5 corrupted: "free(): invalid
/// pointer"; SA_RESETHAND: the default action is back). Reading a file: one line naming it,
/// then end_now(1). Else the temporaries are removed and the fault, run again on return, ends the
/// process as it would have.
extern "C" void on_crash(int sig) {
  int innermost = -1;
  long best = 0;
  for (int i = 0; i < kReadSlots; ++i)
    if (const long order = g_reading_order[i].load(); order > best) {
      best = order;
      innermost = i;
    }
  if (innermost < 0) {
    remove_temporaries();
    return;
  }
  for (const char* part : {"ebh: error: ", static_cast<const char*>(g_reading[innermost]), ": the process crashed (",
                           sig == SIGBUS ? "SIGBUS" : sig == SIGABRT ? "SIGABRT" : "SIGSEGV",
                           ") while reading it: the file is damaged where the HDF5 library trusts it (or ebh has a bug: "
                           "report it with the file); unfinished outputs removed\n"})
    (void)!write(STDERR_FILENO, part, std::strlen(part));
  end_now(1);
}

int register_temp(const std::string& path) {
  if (path.size() >= kPathMax) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (g_used[i].compare_exchange_strong(expected, 1)) {
      std::memcpy(g_paths[i], path.c_str(), path.size() + 1);
      g_used[i].store(2);
      return i;
    }
  }
  return -1;  // table full: the file is still removed by the destructor, just not by a 2nd signal
}

void unregister_temp(int slot) {
  if (slot >= 0) g_used[slot].store(0);
}

std::string host_name() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0 || buf[0] == '\0') return "localhost";
  std::string h = buf;
  for (char& c : h)
    if (c == '/') c = '_';
  return h;
}

// "DIR/.NAME." — what every temporary of DIR/NAME starts with.
/// ".NAME.", the start of NAME's temporaries ".NAME.HOST.PID.ebh-partial". A file name holds at
/// most 255 bytes, so a NAME too long to leave room for the rest keeps its start and a hash of
/// the whole name (FNV-1a): a legal output name always has a temporary.
std::string partial_prefix(const fs::path& final_path) {
  std::string name = final_path.filename().string();
  constexpr std::size_t kNameMax = 255, kPidDigits = 10;
  const std::size_t room = kNameMax - (3 + host_name().size() + kPidDigits + kPartialSuffix.size());
  if (name.size() > room) {
    std::uint64_t h = 1469598103934665603ull;
    for (const unsigned char c : name) h = (h ^ c) * 1099511628211ull;
    char hash[18];
    std::snprintf(hash, sizeof hash, "~%016llx", static_cast<unsigned long long>(h));
    name = name.substr(0, room - 17) + hash;
  }
  return "." + name + ".";
}


/// The nearest of `path`'s folders that exists (a file where a folder should be counts: creating
/// in it fails with "Not a directory"), "." for a relative path none of whose folders does: where
/// a file for `path` can be created now, its missing folders not yet made.
fs::path nearest_existing_folder(const fs::path& path) {
  fs::path dir = path.parent_path();
  std::error_code ec;
  while (!dir.empty() && !fs::exists(dir, ec) && dir.parent_path() != dir) dir = dir.parent_path();
  if (dir.empty() || !fs::exists(dir, ec)) dir = ".";
  return dir;
}

/// Creates `temp` new and empty, or returns -1 with errno. O_EXCL, which does not follow a link: a
/// link planted at a temporary's predictable name would have the output written through it to the
/// link's target. What is there (such a link, or this PID's temporary from an earlier process) is
/// removed first.
int create_new_file(const std::string& temp) {
  int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
  if (fd < 0 && errno == EEXIST && ::unlink(temp.c_str()) == 0)
    fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
  return fd;
}

/// Why no file could be created in `folder`: the OS reason, and where the folder's file system has
/// no blocks at all, that it holds no files (/proc says "No such file or directory", /sys
/// "Permission denied", even to root).
std::string creation_failure(const fs::path& folder, int err) {
  struct statvfs st {};
  const bool holds_no_files = ::statvfs(folder.c_str(), &st) == 0 && st.f_blocks == 0;
  return os_reason(err) + (holds_no_files ? " (" + folder.string() +
                                            " is on a virtual file system, which holds no files: choose another folder)"
                                          : std::string());
}

// Best effort: the rename is on the disk once its directory is synced (some file systems refuse).
void sync_directory(const fs::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  (void)fsync(fd);
  ::close(fd);
}

}  // namespace

CrashNamesInput::CrashNamesInput(const std::string& path) {
  static const bool installed = [] {
    struct sigaction sa {};
    sa.sa_handler = on_crash;
    sa.sa_flags = SA_RESETHAND;
    sigemptyset(&sa.sa_mask);
    for (const int sig : {SIGSEGV, SIGBUS, SIGABRT}) sigaction(sig, &sa, nullptr);
    return true;
  }();
  (void)installed;
  const std::string shown = escape_unprintable(path);  // as an InputError shows it
  if (shown.size() >= kPathMax) return;
  for (int i = 0; i < kReadSlots; ++i) {
    long expected = 0;
    if (g_reading_order[i].compare_exchange_strong(expected, -1)) {
      std::memcpy(g_reading[i], shown.c_str(), shown.size() + 1);
      g_reading_order[i].store(g_reading_next.fetch_add(1));
      slot_ = i;
      return;
    }
  }
}

CrashNamesInput::~CrashNamesInput() {
  if (slot_ >= 0) g_reading_order[slot_].store(0);
}

int remove_on_interrupt(const std::string& path) { return register_temp(path); }
bool is_own_temporary(const std::string& path) {
  for (int i = 0; i < kSlots; ++i)
    if (g_used[i].load() == 2 && path == g_paths[i]) return true;
  return false;
}
void keep_on_interrupt(int slot) { unregister_temp(slot); }


std::string partial_path_for(const std::string& final_path) { return partial_path_for(final_path, static_cast<long>(getpid())); }

std::string partial_path_for(const std::string& final_path, long pid) {
  const fs::path p(final_path);
  return (p.parent_path() / (partial_prefix(p) + host_name() + "." + std::to_string(pid) + std::string(kPartialSuffix))).string();
}

std::size_t remove_stale_partials(const std::string& final_path) {
  const fs::path p(final_path);
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  const std::string prefix = partial_prefix(p), host = host_name();
  std::error_code ec;
  std::size_t removed = 0;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= prefix.size() + kPartialSuffix.size() || n.compare(0, prefix.size(), prefix) != 0 ||
        !is_partial_output(n))
      continue;
    // The rest is HOST.PID
    const std::string who = n.substr(prefix.size(), n.size() - prefix.size() - kPartialSuffix.size());
    const auto dot = who.rfind('.');
    if (dot == std::string::npos || who.substr(0, dot) != host) continue;
    char* end_pid = nullptr;
    const long pid = std::strtol(who.c_str() + dot + 1, &end_pid, 10);
    if (*end_pid != '\0' || pid <= 0 || pid == static_cast<long>(getpid()) || process_running(pid)) continue;
    std::error_code rm;
    if (fs::remove_all(it->path(), rm) > 0 && !rm) ++removed;  // a folder too (a render's frames)
  }
  return removed;
}

std::string os_reason(int err) { return std::strerror(err); }

void check_replaceable(const std::string& path) {
  // The output is written beside its name and renamed over it: that would replace a device, a
  // pipe or a socket (as root, `-o /dev/null` would turn /dev/null into a file), so only a
  // regular file (or a link to one) is replaced.
  std::error_code ec;
  if (const fs::file_status st = fs::status(path, ec); !ec && fs::exists(st) && !fs::is_regular_file(st) &&
                                                       !fs::is_directory(st))
    throw InputError(path + ": " + file_kind(st.type()) +
                     ", not a regular file: an output is written beside its name and renamed over it, which "
                     "would replace it; name a regular file");
  // A file the user may not write (chmod a-w, kept from being overwritten) is not replaced behind
  // its mode by the rename, as `>` or cp would not (root may, as with them).
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(path.c_str(), W_OK) != 0 && errno == EACCES) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw InputError(path + ": is write-protected (mode " + mode + "): make it writable (chmod u+w) or remove it to "
                     "replace it, or choose another output file");
  }
}

void check_name_length(const std::string& path) {
  // The name created: a link's own name exists already; the one at the end of its links is made
  // (a loop is output_target's to say).
  const std::optional<std::string> end = link_end(path);
  const fs::path p(end ? *end : path);
  const fs::path dir = nearest_existing_folder(p);
  long name_max = ::pathconf(dir.c_str(), _PC_NAME_MAX);
  if (name_max <= 0) name_max = NAME_MAX;
  const std::string where = p == fs::path(path) ? "" : " at the end of its link, " + p.string();
  for (const fs::path& part : p)
    if (const std::size_t n = part.native().size(); n > static_cast<std::size_t>(name_max))
      throw InputError(path + ": cannot create the output: " + os_reason(ENAMETOOLONG) + " (a name of " +
                       std::to_string(n) + " bytes" + where + "; this file system allows " + std::to_string(name_max) + ")");
}

std::string output_target(const std::string& final_path) {
  fs::path target(final_path);
  std::error_code ec;
  if (!fs::is_symlink(target, ec)) return final_path;
  // A link to a file: that file (check_replaceable and AtomicOutput refuse what is not one).
  if (struct stat st {}; ::stat(final_path.c_str(), &st) == 0) {
    const fs::path file = fs::canonical(target, ec);
    return ec ? final_path : file.string();
  }
  const int err = errno;
  const std::string link_to = final_path + ": cannot create the output: a link to " + fs::read_symlink(target, ec).string();
  if (err == ELOOP) throw InputError(link_to + ", whose links go round in a loop (or chain too deep): " + os_reason(err));
  if (err != ENOENT) throw InputError(link_to + ": " + os_reason(err));
  // A link to nothing (yet): the file at the end of its links is created, as a link to a file is
  // written (a loop made meanwhile stops at the system's limit of 40).
  const std::optional<std::string> end = link_end(final_path);
  if (!end) throw InputError(link_to + ": " + os_reason(ELOOP));
  target = *end;
  const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(folder, ec))
    throw InputError(link_to + ", whose folder " + folder.string() +
                     (fs::exists(folder, ec) ? " is not a folder" : " does not exist") +
                     ": make that folder or remove the link");
  return target.string();
}

void check_can_create(const std::string& final_path) {
  const std::string target = output_target(final_path);
  const fs::path folder = nearest_existing_folder(target);
  const std::string probe = partial_path_for((folder / fs::path(target).filename()).string());
  const int slot = register_temp(probe);
  const int fd = create_new_file(probe);
  const int err = errno;
  if (fd >= 0) {
    ::close(fd);
    ::unlink(probe.c_str());
  }
  unregister_temp(slot);
  if (fd < 0) throw InputError(final_path + ": cannot create the output: " + creation_failure(folder, err));
}

bool process_running(long pid) { return pid > 0 && (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH); }

/// Whether the stop signal `sig` gets ebh's handler: SIGINT and SIGTERM always (a shell starts a
/// background job with SIGINT ignored); the others unless the process started with them ignored
/// (`nohup ebh ...`: the user asked for the command to outlive its terminal; the same for a signal
/// a parent chose to ignore). Seen before any handler of ebh's is installed, or with the early one.
static bool stops_on(int sig) {
  if (sig == SIGINT || sig == SIGTERM) return true;
  struct sigaction now {};
  return !(sigaction(sig, nullptr, &now) == 0 && !(now.sa_flags & SA_SIGINFO) && now.sa_handler == SIG_IGN);
}

/// The stop signals (kStopSignals) to `handler`, SIGALRM to on_alarm unless `early`.
static void handle_interrupts_with(void (*handler)(int), bool early) {
  struct sigaction sa {};
  sa.sa_handler = handler;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  for (const int sig : kStopSignals) {
    const bool stops = stops_on(sig);
    if (sig == SIGALRM && !early) {  // the grace's timer needs it, whatever the start left
      g_alarm_stops.store(stops);
      struct sigaction alarm_sa {};
      alarm_sa.sa_sigaction = on_alarm;
      sigemptyset(&alarm_sa.sa_mask);
      alarm_sa.sa_flags = SA_SIGINFO;
      sigaction(SIGALRM, &alarm_sa, nullptr);
    } else if (stops) {
      sigaction(sig, &sa, nullptr);
    }
  }
}

void install_interrupt_handlers() {
  if (g_installed.exchange(true)) return;
  // SIGHUP, the terminal closed: stop like SIGTERM, leave no temporary.
  handle_interrupts_with(on_signal, false);
}

void install_early_interrupt_handlers() {
  if (!g_installed.load()) handle_interrupts_with(on_early_signal, true);
}

void set_child_to_kill(long pid) { g_child.store(pid > 0 ? pid : 0); }
std::size_t outputs_committed() { return g_committed.load(); }

bool interrupted() { return g_interrupted != 0; }
int interrupt_signal() { return g_interrupted ? static_cast<int>(g_first_signal) : 0; }
void set_interrupted(bool value) {
  if (!value) alarm(0);
  g_interrupted = value ? 1 : 0;
  g_first_signal = 0;
}

void set_interrupt_grace(unsigned seconds) { g_grace.store(seconds); }
unsigned interrupt_grace() { return g_grace.load(); }

AtomicOutput::AtomicOutput(std::string final_path) : final_(std::move(final_path)) {
  if (final_.empty()) throw InputError("output file name is empty");
  const fs::path p(final_);
  if (p.filename().empty() || p.filename() == "." || p.filename() == "..")
    throw InputError(final_ + ": expected a file name, not a folder");
  if (is_partial_output(final_))
    throw InputError(final_ + ": names ending in " + std::string(kPartialSuffix) + " are kept for unfinished outputs");
  check_name_length(final_);
  std::error_code ec;
  if (fs::is_directory(p, ec)) fail("cannot write the output", EISDIR);
  check_replaceable(final_);
  // A link (to a baselines file kept elsewhere, `gate --update`; to a file yet to be made) is
  // written through: the file it names is replaced or created and the link stays (renamed over,
  // the link became a copy and its target kept the old content). Messages name the output as given.
  target_ = output_target(final_);
  // The output's folder is made when missing (`-o out/run.h5` on a fresh checkout).
  const fs::path parent = p.parent_path();
  if (!parent.empty() && !fs::exists(parent, ec)) {
    for (fs::path f = parent; !f.empty() && !fs::exists(f, ec); f = f.parent_path()) {
      made_folders_.push_back(f.string());
      if (f == f.parent_path()) break;
    }
    fs::create_directories(parent, ec);
    if (ec) throw InputError(final_ + ": cannot create the folder " + parent.string() + ": " + ec.message());
  }
  remove_stale_partials(target_);
  install_interrupt_handlers();
  temp_ = partial_path_for(target_);
  slot_ = register_temp(temp_);
  // Created here, so that a folder that is not one, a read-only folder or a full disk is reported
  // with the final name and the reason before any work.
  const int fd = create_new_file(temp_);
  if (fd < 0) {
    const int err = errno;
    unregister_temp(slot_);
    slot_ = -1;
    throw InputError(final_ + ": cannot create the output: " + creation_failure(fs::path(temp_).parent_path(), err));
  }
  // A file replaced keeps its permissions (a 0640 output stays 0640, not the umask's 0644).
  if (struct stat old {}; ::stat(target_.c_str(), &old) == 0 && S_ISREG(old.st_mode))
    (void)::fchmod(fd, old.st_mode & 07777);
  ::close(fd);
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    discard();
    for (const std::string& f : made_folders_) {  // deepest first; stops at one that is not empty
      std::error_code ec;
      if (!fs::remove(f, ec)) break;
    }
  }
  unregister_temp(slot_);
}

void AtomicOutput::discard() {
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicOutput::fail(const std::string& what, int err) const {
  throw InputError(final_ + ": " + what + (err ? ": " + os_reason(err) : std::string()));
}

void AtomicOutput::commit() {
  if (committed_) return;
  stop_if_interrupted();
  sync();
  rename_into_place();
}

void AtomicOutput::stop_if_interrupted() {
  if (committed_ || !interrupted()) return;
  discard();
  throw InputError(final_ + ": interrupted; nothing written");
}

void AtomicOutput::sync() {
  if (committed_) return;
  // The data must be on the disk before the name points at it: a write error the OS reports
  // only now (a full disk, an I/O error) keeps the previous file.
  const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    discard();
    fail("the temporary file " + temp_ + " is gone", err);
  }
  if (fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    discard();
    fail("cannot write the output", err);
  }
  ::close(fd);
}

void AtomicOutput::rename_into_place() {
  if (committed_) return;
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) {
    const int err = errno;
    discard();
    fail("cannot rename the finished output into place", err);
  }
  committed_ = true;
  g_committed.fetch_add(1);
  unregister_temp(slot_);
  slot_ = -1;
  sync_directory(fs::path(target_).parent_path());
}

namespace {

/// Writes `bytes` into the output's temporary file; every write checked.
void write_temporary(const AtomicOutput& out, std::string_view bytes) {
  const int fd = ::open(out.temp_path().c_str(), O_WRONLY | O_TRUNC | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    out.fail("cannot write the output", err);
  }
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      out.fail("cannot write the output", err);
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  if (::close(fd) != 0) {
    const int err = errno;
    out.fail("cannot write the output", err);
  }
}

}  // namespace

void write_file_atomically(const std::string& path, std::string_view bytes) {
  AtomicOutput out(path);
  write_temporary(out, bytes);
  out.commit();
}

void write_files_atomically(const std::vector<std::pair<std::string, std::string_view>>& files) {
  std::vector<std::unique_ptr<AtomicOutput>> outs;
  for (const auto& [path, bytes] : files) {
    outs.push_back(std::make_unique<AtomicOutput>(path));
    write_temporary(*outs.back(), bytes);
  }
  if (interrupted()) throw InputError(outs.front()->final_path() + ": interrupted; nothing written");
  for (auto& out : outs) out->sync();
  std::string replaced;
  for (auto& out : outs) {
    try {
      out->rename_into_place();
    } catch (const InputError& e) {
      if (replaced.empty()) throw;
      throw InputError(std::string(e.what()) + " (already replaced: " + replaced + ")");
    }
    replaced += (replaced.empty() ? "" : ", ") + out->final_path();
  }
}

}  // namespace ebh
