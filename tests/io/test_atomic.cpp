// Atomic outputs (lib/io/atomic.hpp) when writing goes wrong: a write that fails (a full disk, a
// file-size limit) is reported with the OS reason and leaves a previous file byte-identical and no
// temporary behind; temporaries are hidden, named so they are recognised, and removed once their
// writer is gone; SIGHUP stops a run like SIGTERM; a process stuck past the interrupt's grace ends
// on one signal.
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "io/paths.hpp"
#include "io/recording.hpp"
#include "io_test_util.hpp"

using namespace ebh;
namespace fs = std::filesystem;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void spill(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

/// A recording of n samples (about 70 bytes each before compression; the tremor-free straight line
/// compresses, so n is large where a test needs many bytes on the disk).
Recording line_recording(std::size_t n) {
  Recording r;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 1e-3 * static_cast<double>(i);
    r.t.push_back(t);
    // Not compressible to nothing: a pseudo-random wobble.
    const double w = 1e-6 * static_cast<double>((i * 2654435761u) % 1000);
    r.position.push_back({0.01 * t + w, w, -w});
    r.orientation.push_back({1, 0, 0, 0});
    r.jaw.push_back(1);
    r.buttons.push_back(static_cast<std::uint8_t>(i % 3));
  }
  r.scene = "tube";
  r.tool = "hook";
  return r;
}

/// Runs `body` in a child process and returns what it returned (through a pipe): the child may
/// change process-wide settings (resource limits, mount namespace) without touching the tests.
std::string in_child(const std::function<std::string()>& body) {
  int fds[2];
  if (pipe(fds) != 0) return "pipe failed";
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    std::string out;
    try {
      out = body();
    } catch (const std::exception& e) {
      out = std::string("exception: ") + e.what();
    }
    const char* p = out.data();
    std::size_t left = out.size();
    while (left > 0) {
      const ssize_t n = write(fds[1], p, left);
      if (n <= 0) break;
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    _exit(0);
  }
  close(fds[1]);
  std::string out;
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) out.append(buf, static_cast<std::size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status)) out += " [the child died with signal " + std::to_string(WTERMSIG(status)) + "]";
  return out;
}

/// What a failed write reports: the InputError's message, whether the previous file is
/// byte-identical and the folder's entries afterwards ("message|same|entries").
std::string failed_write_report(const std::string& dir, const std::function<void(const std::string&)>& write) {
  const std::string path = dir + "/out.h5";
  const std::string previous = "a previous result the user keeps\n";
  spill(path, previous);
  std::string message = "no error";
  try {
    write(path);
  } catch (const InputError& e) {
    message = e.what();
  }
  std::string entries;
  for (const auto& e : fs::directory_iterator(dir)) entries += e.path().filename().string() + " ";
  return message + "|" + (slurp(path) == previous ? "same" : "changed") + "|" + entries;
}

void expect_clean_failure(const std::string& report, const std::string& reason) {
  const auto bar = report.find('|');
  ASSERT_NE(bar, std::string::npos) << report;
  const std::string message = report.substr(0, bar);
  EXPECT_NE(message.find("out.h5: "), std::string::npos) << message;
  EXPECT_NE(message.find(reason), std::string::npos) << message;
  EXPECT_EQ(message.find("ebh-partial"), std::string::npos) << "the message names the temporary: " << message;
  EXPECT_EQ(report.substr(bar), "|same|out.h5 ") << "previous file changed or a temporary left behind: " << report;
}

/// The writes of every atomic writer: an HDF5 recording (write_recording) and a plain file.
const std::vector<std::pair<const char*, std::function<void(const std::string&)>>> kWriters = {
    {"recording", [](const std::string& p) { write_recording(p, line_recording(20000)); }},
    {"text", [](const std::string& p) { write_file_atomically(p, std::string(300000, 'x')); }},
};

}  // namespace

TEST(Atomic, TemporaryIsHiddenBesideTheOutputAndMarkedPartial) {
  const std::string tmp = partial_path_for("some/dir/run.h5");
  EXPECT_EQ(fs::path(tmp).parent_path(), fs::path("some/dir"));
  const std::string name = fs::path(tmp).filename().string();
  EXPECT_EQ(name.rfind(".run.h5.", 0), 0u) << name;
  EXPECT_NE(name.find("." + std::to_string(getpid()) + ".ebh-partial"), std::string::npos) << name;
  EXPECT_TRUE(is_partial_output(tmp));
  EXPECT_FALSE(is_partial_output("some/dir/run.h5"));
}

// A link planted at the temporary's predictable name is replaced, not written through: its target
// keeps its bytes and the output is a regular file.
TEST(Atomic, ALinkAtTheTemporarysNameIsNotFollowed) {
  test::ScratchDir tmp;
  const std::string out = (tmp.dir / "o.txt").string(), victim = (tmp.dir / "victim").string();
  { std::ofstream(victim) << "precious"; }
  fs::create_symlink(victim, partial_path_for(out));
  write_file_atomically(out, "new");
  EXPECT_EQ(slurp(victim), "precious");
  EXPECT_EQ(slurp(out), "new");
  EXPECT_FALSE(fs::is_symlink(out));
  EXPECT_FALSE(fs::exists(fs::symlink_status(partial_path_for(out))));
}

// An output named by a link to a file (a baselines file kept elsewhere) replaces the file the link
// names, the link kept; its temporary is beside that file.
TEST(Atomic, AnOutputThatIsALinkWritesTheFileItNames) {
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "real");
  const std::string target = (tmp.dir / "real" / "base.yaml").string(), link = (tmp.dir / "link.yaml").string();
  { std::ofstream(target) << "old"; }
  fs::create_symlink(target, link);
  write_file_atomically(link, "new");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(slurp(target), "new");
  EXPECT_EQ(slurp(link), "new");
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.dir / "real"), fs::directory_iterator{}), 1);
}

// An output named by a link to nothing yet (a results folder of links into a data store) creates
// the file at the end of its links, its temporary beside that file, and the links stay (the link
// was replaced by a regular file, its target never made).
TEST(Atomic, AnOutputThatIsALinkToNothingCreatesTheFileItNames) {
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "store");
  const std::string link = tmp / "run.h5", chain = tmp / "chain.h5";
  fs::create_symlink("store/run.h5", link);  // relative: to the link's folder
  fs::create_symlink("run.h5", chain);
  write_file_atomically(chain, "new");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_TRUE(fs::is_symlink(chain));
  EXPECT_EQ(slurp(tmp / "store/run.h5"), "new");
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.dir / "store"), fs::directory_iterator{}), 1);
  EXPECT_EQ(tmp.entries(), 3u);  // store, run.h5, chain.h5: no temporary left
}

// A link whose target's folder is missing, or a loop of links, is refused naming the link and its
// target (not replaced by a file, nor followed forever); the links stay and nothing is made.
TEST(Atomic, ALinkToAMissingFolderOrALoopOfLinksIsRefused) {
  test::ScratchDir tmp;
  fs::create_symlink("nowhere/run.h5", tmp / "dangling.h5");
  fs::create_symlink("b.h5", tmp / "a.h5");
  fs::create_symlink("a.h5", tmp / "b.h5");
  EXPECT_INPUT_ERROR(write_file_atomically(tmp / "dangling.h5", "x"),
                     "dangling.h5: cannot create the output: a link to nowhere/run.h5, whose folder ",
                     "nowhere does not exist: make that folder or remove the link");
  EXPECT_INPUT_ERROR(write_file_atomically(tmp / "a.h5", "x"),
                     "a.h5: cannot create the output: a link to b.h5, whose links go round in a loop");
  for (const char* name : {"dangling.h5", "a.h5", "b.h5"}) EXPECT_TRUE(fs::is_symlink(tmp / name)) << name;
  EXPECT_EQ(tmp.entries(), 3u);
}

// A file replaced keeps its permissions (0640 stays 0640, not the umask's 0644); one its user may not
// write is refused, not replaced behind its mode (as root may write it, only checked as another).
TEST(Atomic, AReplacedFileKeepsItsMode) {
  test::ScratchDir tmp;
  const std::string path = (tmp.dir / "out.h5").string();
  { std::ofstream(path) << "old"; }
  ASSERT_EQ(::chmod(path.c_str(), 0640), 0);
  write_file_atomically(path, "new");
  EXPECT_EQ(slurp(path), "new");
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
}
TEST(Atomic, AWriteProtectedFileIsRefused) {
  if (::geteuid() == 0) GTEST_SKIP() << "root may write a write-protected file";
  test::ScratchDir tmp;
  const std::string path = (tmp.dir / "out.h5").string();
  { std::ofstream(path) << "new"; }
  ASSERT_EQ(::chmod(path.c_str(), 0444), 0);
  EXPECT_INPUT_ERROR(write_file_atomically(path, "newer"), "out.h5: is write-protected (mode 0444): make it writable");
  EXPECT_EQ(slurp(path), "new");
}

// The folders an output made are removed with it when it is not committed (a failed run leaves
// no empty folder tree); a folder that holds something else stays.
TEST(Atomic, AnOutputNotCommittedRemovesTheFoldersItMade) {
  test::ScratchDir tmp;
  { AtomicOutput out((tmp.dir / "new/sub/o.h5").string()); }
  EXPECT_FALSE(fs::exists(tmp.dir / "new"));
  fs::create_directories(tmp.dir / "kept");
  { std::ofstream(tmp.dir / "kept/mine.txt") << "mine"; }
  { AtomicOutput out((tmp.dir / "kept/sub/o.h5").string()); }
  EXPECT_FALSE(fs::exists(tmp.dir / "kept/sub"));
  EXPECT_TRUE(fs::exists(tmp.dir / "kept/mine.txt"));
  write_file_atomically((tmp.dir / "made/o.txt").string(), "x");  // committed: the folder stays
  EXPECT_TRUE(fs::exists(tmp.dir / "made/o.txt"));
}

// Files that belong together (a mesh and the scene naming it): an interrupt before the renames
// leaves both previous files; without one both are replaced.
TEST(Atomic, FilesThatBelongTogetherAreReplacedTogether) {
  test::ScratchDir tmp;
  const std::string a = (tmp.dir / "a.msh").string(), b = (tmp.dir / "a.yaml").string();
  write_files_atomically({{a, "old mesh"}, {b, "old scene"}});
  set_interrupted(true);
  EXPECT_THROW(write_files_atomically({{a, "new mesh"}, {b, "new scene"}}), InputError);
  set_interrupted(false);
  EXPECT_EQ(slurp(a), "old mesh");
  EXPECT_EQ(slurp(b), "old scene");
  EXPECT_FALSE(fs::exists(partial_path_for(a)));
  EXPECT_FALSE(fs::exists(partial_path_for(b)));
  write_files_atomically({{a, "new mesh"}, {b, "new scene"}});
  EXPECT_EQ(slurp(a), "new mesh");
  EXPECT_EQ(slurp(b), "new scene");
}

TEST(Atomic, WriteFailureKeepsThePreviousFileAndSaysWhy) {
  // A file-size limit makes write() fail with EFBIG once a file would grow past it (SIGXFSZ
  // ignored), in any file system and without privileges: the same path as a full disk.
  test::ScratchDir tmp;
  for (const auto& [kind, write] : kWriters) {
    SCOPED_TRACE(kind);
    const std::string report = in_child([&, dir = tmp.dir.string()] {
      std::signal(SIGXFSZ, SIG_IGN);
      const rlimit small{64 * 1024, 64 * 1024};
      if (setrlimit(RLIMIT_FSIZE, &small) != 0) return std::string("setrlimit failed");
      return failed_write_report(dir, write);
    });
    expect_clean_failure(report, "File too large");
  }
}

TEST(Atomic, FullDiskKeepsThePreviousFileAndSaysWhy) {
  // A real full disk: a 64 KiB tmpfs, mounted in a private mount namespace of a child process (it
  // disappears with the child). Needs root and CAP_SYS_ADMIN; the file-size test above covers
  // the same code where that is not allowed.
  test::ScratchDir tmp;
  const std::string dir = tmp / "small";
  fs::create_directories(dir);
  for (const auto& [kind, write] : kWriters) {
    SCOPED_TRACE(kind);
    const std::string report = in_child([&] {
      if (unshare(CLONE_NEWNS) != 0) return std::string("SKIP unshare: ") + std::strerror(errno);
      if (mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0)
        return std::string("SKIP private mounts: ") + std::strerror(errno);
      if (mount("tmpfs", dir.c_str(), "tmpfs", 0, "size=64k") != 0) return std::string("SKIP mount: ") + std::strerror(errno);
      return failed_write_report(dir, write);
    });
    if (report.rfind("SKIP", 0) == 0) GTEST_SKIP() << "cannot mount a small tmpfs here (" << report.substr(5)
                                                   << "); WriteFailureKeepsThePreviousFileAndSaysWhy covers write failures";
    expect_clean_failure(report, "No space left on device");
  }
}

TEST(Atomic, OutputInAFileNotAFolderNamesTheOutputAndTheReason) {
  test::ScratchDir tmp;
  spill(tmp / "afile", "x");
  EXPECT_INPUT_ERROR(h5::AtomicFile(tmp / "afile/out.h5"), "afile/out.h5: ", "Not a directory");
  try {
    h5::AtomicFile out(tmp / "afile/out.h5");
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("ebh-partial"), std::string::npos) << e.what();
  }
  EXPECT_INPUT_ERROR(write_file_atomically(tmp / "afile/out.txt", "x"), "afile/out.txt: ", "Not a directory");
  fs::create_directories(tmp / "folder");
  EXPECT_INPUT_ERROR(h5::AtomicFile(tmp / "folder"), "folder: ", "Is a directory");
}

/// An output named like a device or a pipe is refused before anything is written: renaming the
/// finished file over it would replace it (as root, `-o /dev/null` replaced /dev/null).
TEST(Atomic, ADeviceOrAPipeAsTheOutputIsRefusedAndLeftAsItWas) {
  const fs::path dir = fs::temp_directory_path() / ("ebh_special_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path fifo = dir / "pipe.h5", null_link = dir / "null.h5";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  fs::create_symlink("/dev/null", null_link);
  for (const auto& [path, kind] : {std::pair{fifo, "a named pipe"}, std::pair{null_link, "a character device"}}) {
    try {
      AtomicOutput out(path.string());
      ADD_FAILURE() << path << " was accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path.string() + ": " + kind + ", not a regular file"), std::string::npos) << what;
    }
  }
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(fifo)));
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(null_link)));
  EXPECT_TRUE(fs::is_character_file(fs::status("/dev/null")));
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 2u) << "no temporary left beside them";
  fs::remove_all(dir);
}

/// An output name of up to 255 bytes, the most a file name holds, gets a temporary: its name keeps
/// the output's start and a hash of the whole, within the same 255 bytes.
TEST(Atomic, TheLongestFileNameIsWritten) {
  const fs::path dir = fs::temp_directory_path() / ("ebh_long_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const std::size_t length : {200u, 243u, 255u}) {
    const std::string name = std::string(length - 3, 'a') + ".h5";
    const std::string path = (dir / name).string();
    {
      AtomicOutput out(path);
      EXPECT_LE(fs::path(out.temp_path()).filename().string().size(), 255u);
      EXPECT_TRUE(is_partial_output(out.temp_path()));
      spill(out.temp_path(), "data " + std::to_string(length));
      out.commit();
    }
    EXPECT_EQ(slurp(path), "data " + std::to_string(length));
  }
  // two long names that share their first 200 bytes have different temporaries
  const std::string a = (dir / (std::string(250, 'b') + "1")).string(), b = (dir / (std::string(250, 'b') + "2")).string();
  AtomicOutput oa(a), ob(b);
  EXPECT_NE(oa.temp_path(), ob.temp_path());
  fs::remove_all(dir);
}

TEST(Atomic, StaleTemporariesOfGoneWritersAreRemoved) {
  test::ScratchDir tmp;
  const std::string out = tmp / "run.h5";
  // A PID that no longer runs: a child that has exited and been reaped.
  const pid_t gone = fork();
  if (gone == 0) _exit(0);
  waitpid(gone, nullptr, 0);
  const std::string mine = partial_path_for(out);
  // .run.h5.HOST.PID.ebh-partial -> HOST
  std::string who = fs::path(mine).filename().string().substr(std::string(".run.h5.").size());
  who.resize(who.size() - kPartialSuffix.size());
  const std::string host_name = who.substr(0, who.rfind('.'));
  auto name = [&](const std::string& h, long pid) { return tmp / (".run.h5." + h + "." + std::to_string(pid) + ".ebh-partial"); };
  spill(name(host_name, gone), "stale");                       // killed: removed
  spill(name(host_name, static_cast<long>(getppid())), "live");  // still running: kept
  spill(name("another-host", gone), "other");                  // another machine's: kept
  spill(tmp / ".other.h5." + host_name + "." + std::to_string(gone) + ".ebh-partial", "x");  // another output: kept
  EXPECT_EQ(remove_stale_partials(out), 1u);
  EXPECT_FALSE(fs::exists(name(host_name, gone)));
  EXPECT_TRUE(fs::exists(name(host_name, static_cast<long>(getppid()))));
  EXPECT_TRUE(fs::exists(name("another-host", gone)));
  EXPECT_EQ(tmp.entries(), 3u);
  // Every new output of that path cleans up the same way.
  spill(name(host_name, gone), "stale again");
  { AtomicOutput o(out); }
  EXPECT_FALSE(fs::exists(name(host_name, gone)));
}

TEST(Atomic, HangupStopsARunLikeAnInterrupt) {
  install_interrupt_handlers();
  set_interrupted(false);
  std::raise(SIGHUP);  // the handler only sets the flag
  EXPECT_TRUE(interrupted());
  set_interrupted(false);
}

/// The signals whose default action would end the process leaving its temporaries stop a run as
/// SIGTERM does; SIGALRM sent by a process too (not the grace's own timer).
TEST(Atomic, SignalsThatWouldEndTheProcessStopARun) {
  install_interrupt_handlers();
  for (const int sig : {SIGUSR1, SIGUSR2, SIGALRM, SIGXCPU, SIGVTALRM, SIGPROF}) {
    set_interrupted(false);
    std::raise(sig);  // the handler only sets the flag
    EXPECT_TRUE(interrupted()) << strsignal(sig);
    EXPECT_EQ(interrupt_signal(), sig);
  }
  set_interrupted(false);
}

/// `timeout` sends its signal to the command and then to its process group: the same signal twice
/// at once is one interrupt, not a second one that ends the process.
TEST(Atomic, TheSameSignalTwiceAtOnceIsOneInterrupt) {
  install_interrupt_handlers();
  set_interrupted(false);
  std::raise(SIGTERM);
  std::raise(SIGTERM);  // a second interrupt would have ended the test
  EXPECT_TRUE(interrupted());
  set_interrupted(false);
}

namespace {

/// Forks a child that installs the interrupt handlers with a grace of `grace` s, opens an
/// AtomicOutput at `out` and then runs `body` (its exit status, once the output is closed); the
/// parent sends it SIGTERM once it is ready and returns its wait status and the seconds it took to
/// end (or kills it after 10 s: status -1).
std::pair<int, double> interrupt_child(const std::string& out, unsigned grace, int (*body)()) {
  int ready[2];
  if (pipe(ready) != 0) return {-1, 0};
  const pid_t pid = fork();
  if (pid == 0) {
    close(ready[0]);
    install_interrupt_handlers();
    set_interrupted(false);
    set_interrupt_grace(grace);
    int code = 0;
    {
      AtomicOutput o(out);
      (void)!write(ready[1], "r", 1);
      code = body();
    }
    _exit(code);
  }
  close(ready[1]);
  char c = 0;
  (void)!read(ready[0], &c, 1);
  close(ready[0]);
  const auto t0 = std::chrono::steady_clock::now();
  kill(pid, SIGTERM);
  int status = 0;
  for (int i = 0; i < 1000; ++i) {
    if (waitpid(pid, &status, WNOHANG) == pid)
      return {status, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()};
    usleep(10000);
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return {-1, 10};
}

}  // namespace

/// A process stuck where it does not poll interrupted() (as a replay waiting on a hung device)
/// still ends on one SIGTERM: when the grace runs out, as on a second signal (its temporaries
/// removed, exit status 128 + SIGTERM). One that stops within the grace ends as it chooses.
TEST(Atomic, AStuckProcessEndsWhenTheInterruptsGraceRunsOut) {
  const fs::path dir = fs::temp_directory_path() / ("ebh_grace_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string out = (dir / "out.h5").string();
  const auto [stuck, stuck_s] = interrupt_child(out, 1, []() -> int {
    for (;;) pause();  // never polls the flag
  });
  ASSERT_NE(stuck, -1) << "the stuck child did not end within 10 s of one SIGTERM";
  ASSERT_TRUE(WIFEXITED(stuck));
  EXPECT_EQ(WEXITSTATUS(stuck), 128 + SIGTERM);
  EXPECT_GE(stuck_s, 0.9);
  EXPECT_TRUE(fs::is_empty(dir)) << "the temporary is removed, no output written";
  const auto [polite, polite_s] = interrupt_child(out, 5, [] {
    while (!interrupted()) usleep(1000);
    return 3;
  });
  ASSERT_TRUE(WIFEXITED(polite));
  EXPECT_EQ(WEXITSTATUS(polite), 3);
  EXPECT_LT(polite_s, 4.0);
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

/// A TemporaryFolder of a process that ends at the grace runs no destructor: the folder and the
/// files named through it go with the temporaries (bench sizes left a 2 GB refined mesh in /tmp
/// when a large level's load, which does not poll the flag, outlasted the grace).
TEST(Atomic, ATemporaryFolderGoesWhenTheGraceRunsOut) {
  const fs::path dir = fs::temp_directory_path() / ("ebh_grace_folder_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const char* before = std::getenv("TMPDIR");
  const std::string kept = before ? before : "";
  setenv("TMPDIR", dir.c_str(), 1);  // the child's folder in dir
  const auto [status, seconds] = interrupt_child((dir / "out.h5").string(), 1, []() -> int {
    TemporaryFolder folder("ebh-sizes-test-", "the test's folder");
    std::ofstream(folder.file("level1.msh")) << "a refined mesh";
    std::ofstream(folder.file("level1.yaml")) << "its scene";
    for (;;) pause();  // never polls the flag, as a large mesh's load
  });
  if (before) setenv("TMPDIR", kept.c_str(), 1);
  else unsetenv("TMPDIR");
  ASSERT_NE(status, -1) << "the child did not end within 10 s of one SIGTERM";
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  EXPECT_GE(seconds, 0.9);
  std::vector<std::string> left;
  for (const auto& e : fs::recursive_directory_iterator(dir)) left.push_back(e.path().string());
  EXPECT_TRUE(left.empty()) << ::testing::PrintToString(left);
  fs::remove_all(dir);
}
