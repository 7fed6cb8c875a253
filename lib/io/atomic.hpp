#pragma once
// Atomic output files (docs/FORMATS.md, "How outputs are written"): a file is written under a temporary name beside its final
// name, synced to the disk and renamed when complete, so a crash, an interrupt or a full disk
// never leaves a half-written file under the final name, and a previous file of that name stays
// as it was until the new one is complete.
//
// The temporary of DIR/NAME is DIR/.NAME.HOST.PID.ebh-partial: hidden, and with a suffix that no
// command accepts as input (check_input_file, io/paths.hpp). A process killed with SIGKILL cannot
// remove it; the next AtomicOutput of the same final path removes every such file whose writer
// (same host, PID no longer running) is gone.
//
// Interrupts: the first SIGINT/SIGTERM/SIGHUP (or SIGUSR1, SIGUSR2, SIGALRM, SIGXCPU, SIGVTALRM,
// SIGPROF, whose default action would end the process leaving its temporaries) only sets a flag
// that long loops poll with interrupted(); they stop, and the AtomicOutput's destructor removes
// the temporary file. A second signal (not the first one repeated within 0.1 s, as `timeout` sends
// it twice) removes every registered temporary file at once and ends the process, saying so (exit
// status 128+signal). So does the first signal's grace running out (interrupt_grace(), 10 s): a process
// stuck where it does not poll the flag (a wait on a hung device) still ends on one SIGTERM,
// saying so on stderr. The handlers are installed by the first AtomicOutput (or by
// install_interrupt_handlers()).
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/partial_output.hpp"

namespace ebh {

/// The temporary name this process uses for `final_path`: DIR/.NAME.HOST.PID.ebh-partial.
std::string partial_path_for(const std::string& final_path);
/// The temporary name process `pid` of this host uses for `final_path` (a child's, to remove
/// after it was killed).
std::string partial_path_for(const std::string& final_path, long pid);

/// Removes the temporaries of `final_path` (files, or folders such as a render's frames) left by
/// writers that are gone (this host, a PID that no longer runs); keeps those of running processes
/// and of other hosts. Returns how many it removed.
std::size_t remove_stale_partials(const std::string& final_path);

/// Registers `path` (a file, or a folder emptied of its registered files) for removal should the
/// process end at an interrupt's second signal or grace, as an unfinished output's temporary is;
/// returns a slot for keep_on_interrupt (-1: the table is full, and only the owner removes it).
int remove_on_interrupt(const std::string& path);
/// Unregisters a slot of remove_on_interrupt (the owner removed the path, or keeps it).
void keep_on_interrupt(int slot);
/// Whether `path` is (as written) the temporary of an output this process is writing: the one
/// input of kPartialSuffix's name a reader accepts (`ebh replay --render` renders the finished
/// replay output before it takes the previous one's place).
bool is_own_temporary(const std::string& path);

/// strerror(err): the operating system's reason ("No space left on device").
std::string os_reason(int err);

/// Throws InputError "PATH: cannot create the output: File name too long (...)" when a part of
/// the name that will be created is longer than the file system that would hold it allows
/// (pathconf's _PC_NAME_MAX of the nearest existing folder, else NAME_MAX): the rename into place
/// would fail only after all the work. That name is `path`'s, or where `path` is a link, the one at
/// the end of its links (core/file_names.hpp link_end): a short link may lead to a name too long, in a folder of
/// another file system.
void check_name_length(const std::string& path);

/// Throws InputError "PATH: a named pipe, not a regular file: ..." when `path` is a device, a
/// named pipe or a socket (or a link to one): an output is renamed over its name, which would
/// replace it. A missing name, a regular file or a link to one passes.
void check_replaceable(const std::string& path);

/// The file an output named `final_path` replaces or creates, its temporary beside it: `final_path`
/// itself, or, where `final_path` is a symbolic link, the file at the end of its links (the link
/// stays). A link to nothing names the file it would create, whose folder must exist. Throws
/// InputError "FINAL: cannot create the output: ..." naming the link and its target where that
/// folder is missing, and for a loop of links (or a chain longer than the system follows).
/// Every output's path is resolved here (AtomicOutput, check_can_create).
std::string output_target(const std::string& final_path);

/// Throws InputError "FINAL: cannot create the output: OS reason" unless this process can create
/// the output's temporary where it goes (beside output_target(final_path), or in the nearest
/// existing folder above it when the output's folder is still to be made): a read-only folder or
/// file system, one the user may not write, a file where a folder should be, /proc or /sys. Tries:
/// creates that file and removes it. Commands call it before any work (io/paths.hpp check_outputs).
void check_can_create(const std::string& final_path);

/// Whether process `pid` of this host may still run (kill(pid, 0) finds it, or may not signal it):
/// its temporaries are not stale.
bool process_running(long pid);

class AtomicOutput {
 public:
  /// Creates the (empty) temporary file, making the output's folder when it is missing, after
  /// removing stale temporaries of the same final path. Throws InputError naming the final path
  /// and the OS reason when the output cannot be created there ("Not a directory"). An output
  /// that is not committed removes the folders it made, where they stayed empty.
  explicit AtomicOutput(std::string final_path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::string& final_path() const { return final_; }
  const std::string& temp_path() const { return temp_; }
  bool committed() const { return committed_; }

  /// Syncs the temporary file to the disk and renames it to the final name. Throws InputError
  /// (removing the temporary; a previous file under the final name is left as it was) when the
  /// run was interrupted, the temporary is missing or the sync or the rename fails.
  void commit();
  /// The two halves of commit() without its interrupt check, for files that belong together
  /// (write_files_atomically: every one synced, then every one renamed, whatever signal arrives
  /// between the renames). Each throws as commit() does.
  void sync();
  void rename_into_place();
  /// commit()'s interrupt check: after an interrupt, removes the temporary and throws InputError
  /// "FINAL: interrupted; nothing written".
  void stop_if_interrupted();
  /// Removes the temporary file now (also done by the destructor when not committed).
  void discard();
  /// Throws InputError "FINAL: WHAT: OS reason" (err = an errno value; 0 leaves the reason out).
  [[noreturn]] void fail(const std::string& what, int err) const;

 private:
  std::string final_;
  std::string target_;  // the file renamed over: final_, or the file a link at final_ names
  std::string temp_;
  int slot_ = -1;  // index in the signal handler's table of temporary files
  bool committed_ = false;
  std::vector<std::string> made_folders_;  // made for the output, deepest first: removed (when empty) on failure
};

/// Writes `bytes` to `path` atomically (an AtomicOutput, every write checked, commit). Errors name
/// `path` and the OS reason.
void write_file_atomically(const std::string& path, std::string_view bytes);

/// Writes several files (path, bytes) that belong together: every one is written completely under
/// its temporary name and synced before any is renamed, so a failure while writing (a full disk,
/// an interrupt) leaves none of them, and previous files of those names stay as they were. Once
/// the first is renamed an interrupt no longer stops the rest; a rename that fails then (the old
/// file cannot be replaced) names the files already replaced.
void write_files_atomically(const std::vector<std::pair<std::string, std::string_view>>& files);

/// Installs the handlers of the signals that stop a run (idempotent): SIGINT, SIGTERM, SIGHUP,
/// SIGUSR1, SIGUSR2, SIGALRM, SIGXCPU, SIGVTALRM and SIGPROF. Those but SIGINT and SIGTERM stay
/// ignored where they were at the start (`nohup`); SIGALRM's handler also runs the grace, and
/// tells its timer from a SIGALRM another process sent.
void install_interrupt_handlers();
/// While an input file is read through a library that trusts its bytes (HDF5 copies a string
/// attribute by a length read from the file: a damaged global heap made `ebh metrics` end with a
/// bare "Segmentation fault"), a crash (SIGSEGV, SIGBUS, or SIGABRT from the C library finding its
/// heap corrupted) ends the process with one line, "ebh: error:
/// FILE: the process crashed (SIGSEGV) while reading it: ...", status 1 and its temporaries removed.
/// A crash while no file is read stays a crash (its core dump kept), its temporaries removed.
/// Scopes nest: the innermost file is named. h5::File::open_read holds one while the file is open.
class CrashNamesInput {
 public:
  explicit CrashNamesInput(const std::string& path);
  ~CrashNamesInput();
  CrashNamesInput(const CrashNamesInput&) = delete;
  CrashNamesInput& operator=(const CrashNamesInput&) = delete;

 private:
  int slot_ = -1;  ///< -1: the table was full (the crash is then a plain one)
};

/// Until a command installs those (it polls interrupted() from then on), a signal ends the process
/// at once with one line, "ebh: interrupted by SIGINT; no output file written" (the signal that
/// came), and status 128 + signal, removing any temporary: what a long load (a 10-million-line log, a large mesh) or
/// a command that never polls (validate, table1) gets. `ebh` calls it first thing (SIGHUP left
/// ignored where it was).
void install_early_interrupt_handlers();
/// True once one of those signals arrived (after install_interrupt_handlers()).
bool interrupted();
/// The first of those signals that arrived (0 when none did, or the flag was set by hand): a
/// command that stopped on it exits with status 128 + signal, as the shell's convention has it.
int interrupt_signal();
/// Sets or clears the flag, as a signal would (tests; a tool that handled the interrupt); clearing
/// it also cancels a running grace.
void set_interrupted(bool value);

/// Records the child process `pid` (0: none) that a sudden end (a second signal, the grace running
/// out) kills with SIGKILL before the process ends: a child being stopped (ffmpeg, given half a
/// second to end on SIGTERM) would otherwise outlive it, writing into a temporary being removed.
/// Record it as soon as the child started, and clear it before the child is reaped (its PID may
/// then be another process's).
void set_child_to_kill(long pid);

/// How many outputs this process renamed into place (a message after a later failure says they
/// were written).
std::size_t outputs_committed();

/// Seconds a process has after the first interrupt before it ends as on a second one.
inline constexpr unsigned kInterruptGraceSeconds = 10;
/// Sets the grace (0: none, the process runs until it stops by itself; for a process that waits
/// for children of its own, which have theirs). Takes effect at the next first interrupt.
void set_interrupt_grace(unsigned seconds);
unsigned interrupt_grace();

}  // namespace ebh
