// ebh: energy-based haptic rendering toolkit — the command line.
#include <fcntl.h>
#include <pthread.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <new>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>
#include <vector>

#include "command.hpp"
#include "core/error.hpp"
#include "ebh/version.hpp"
#include "io/atomic.hpp"
#include "options.hpp"

namespace ebh::cli {
std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> registry;
  return registry;
}
}  // namespace ebh::cli

namespace {

/// Why OMP_NUM_THREADS (`value`, set) cannot run this process's OpenMP threads; "" when it can.
/// OpenMP's syntax: a positive whole number per nesting level, comma-separated ("4" or "4,2"),
/// blanks around each allowed. libgomp ignores any other value, after a warning of its own at
/// load time, and runs on with a default the user did not choose. Each level must also stay within
/// max(4096, 8 x the cores): libgomp starts every thread of a team in each parallel region and
/// waits for all of them at its barriers, so the time of each region grows with the count (on 2
/// cores, 0.01 s of the tube replay took 6 s with 4096 threads and 13.5 s with 8192; 30000 ran on
/// for hours, 40000 failed to create its threads, 100000 crashed inside libgomp). 4096 still runs
/// (slowly, and the replay warns of threads beyond the cores); 8 x the cores keeps large machines
/// free to oversubscribe as much as a small one.
std::string omp_threads_problem(std::string_view value, unsigned cores) {
  const unsigned long long cap = std::max<unsigned long long>(4096, 8ull * cores);
  std::string_view rest = value;
  while (true) {
    const std::size_t comma = rest.find(',');
    std::string_view level = rest.substr(0, comma);
    while (!level.empty() && std::isspace(static_cast<unsigned char>(level.front()))) level.remove_prefix(1);
    while (!level.empty() && std::isspace(static_cast<unsigned char>(level.back()))) level.remove_suffix(1);
    if (!level.empty() && level.front() == '+') level.remove_prefix(1);
    unsigned long long n = 0;
    const auto [end, ec] = std::from_chars(level.data(), level.data() + level.size(), n);
    const bool digits = !level.empty() && end == level.data() + level.size() &&
                        std::all_of(level.begin(), level.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (!digits || (ec != std::errc() && ec != std::errc::result_out_of_range) || (ec == std::errc() && n == 0))
      return "not a number of threads (expected a whole number from 1, or one per nesting level as 4,2; unset it "
             "for one a core)";
    if (ec == std::errc::result_out_of_range || n > cap)
      return "far more threads than this machine runs at once" +
             (cores > 0 ? " (" + std::to_string(cores) + " cores)" : std::string()) + ": at most " + std::to_string(cap) +
             " are accepted, beyond which OpenMP takes hours to start and stop them, or fails" +
             (cores > 0 ? "; set it to at most " + std::to_string(cores) + ", one a core" : std::string());
    if (comma == std::string_view::npos) return "";
    rest.remove_prefix(comma + 1);
  }
}

/// The first argument left over after parsing that starts with '-' (an option no command takes),
/// said as an unknown option: CLI11 says "replay is required" of `ebh metrics --x.h5` (its check of
/// required arguments comes before that of extra ones) and "The following argument was not
/// expected" of `ebh metrics a.h5 --x.h5`. A file of that name is hinted at, with the two ways to
/// name it. "" when no such argument is left.
std::string unknown_option(const CLI::App& app) {
  for (const std::string& arg : app.remaining(true)) {
    if (arg.size() < 2 || arg[0] != '-' || arg == "--") continue;
    std::string command;  // the command given, "bench sizes" (its own --help lists its options)
    for (const CLI::App* a = &app; !a->get_subcommands().empty();) {
      a = a->get_subcommands().front();
      command += (command.empty() ? "" : " ") + a->get_name();
    }
    const std::string shown = ebh::escape_unprintable(arg);
    std::string why = "unknown option '" + shown + "'";
    std::error_code ec;
    if (std::filesystem::exists(arg, ec))
      why += " (a file of that name exists: write ./" + shown + ", or -- " + shown +
             ": after --, no argument is an option)";
    else if (!command.empty())
      why += " (ebh " + command + " --help lists its options)";
    return why;
  }
  return "";
}

/// Parses and runs the command; returns the exit status (1 bad input, 3 internal error).
int run(CLI::App& app, int argc, char** argv) {
  // A first word that names no command (a typo) is said as such: CLI11 would say that a
  // subcommand is required.
  if (argc > 1 && argv[1][0] != '-') {
    std::vector<std::string> commands;
    bool known = false;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      known = known || sub->check_name(argv[1]);
      commands.push_back(sub->get_name());
    }
    std::sort(commands.begin(), commands.end());
    std::string names;
    for (const std::string& c : commands) names += (names.empty() ? "" : ", ") + c;
    if (!known) {
      std::fprintf(stderr, "ebh: error: '%s' is not an ebh command (commands: %s; ebh --help)\n",
                   ebh::escape_unprintable(argv[1]).c_str(), names.c_str());
      return 1;
    }
  }
  // "-o=out.h5": CLI11, as getopt, gives a short option the text after it, '=' included, and the
  // output was a file named "=out.h5". Refused, naming both ways to write it.
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg.size() > 2 && arg[0] == '-' && std::isalpha(static_cast<unsigned char>(arg[1])) && arg[2] == '=') {
      const std::string opt(arg.substr(0, 2)), value(arg.substr(3));
      std::fprintf(stderr, "ebh: error: '%s': a short option takes its value after a space (%s %s), not after '='\n",
                   ebh::escape_unprintable(std::string(arg)).c_str(), opt.c_str(),
                   ebh::escape_unprintable(value).c_str());
      return 1;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    if (dynamic_cast<const CLI::RequiredError*>(&e) || dynamic_cast<const CLI::ExtrasError*>(&e))
      if (const std::string why = unknown_option(app); !why.empty()) {
        std::fprintf(stderr, "ebh: error: %s\n", why.c_str());
        return 1;
      }
    // A bad command line is bad input like any other: one line, exit status 1.
    std::fprintf(stderr, "ebh: error: %s\n", ebh::escape_unprintable(e.what()).c_str());
    return 1;
  } catch (const ebh::cli::ExitRequest& e) {
    return e.code;
  } catch (const ebh::InputError& e) {
    std::fprintf(stderr, "ebh: error: %s\n", e.what());
    return 1;
  } catch (const ebh::NumericalError& e) {
    std::fprintf(stderr, "ebh: error: %s\n", e.what());
    return 4;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "ebh: error: out of memory\n");
    return 1;
  } catch (const std::system_error& e) {
    // A thread that could not start (std::thread's EAGAIN): a limit on processes or memory that a
    // scheduler or a shell set, not a fault of ebh's.
    if (e.code() == std::errc::resource_unavailable_try_again) {
      std::fprintf(stderr, "ebh: error: cannot start a thread: %s (a limit on processes or memory: ulimit -u, "
                   "ulimit -v, the job's limits; or fewer threads: OMP_NUM_THREADS)\n", e.code().message().c_str());
      return 1;
    }
    std::fprintf(stderr, "ebh: internal error: %s\n", ebh::escape_unprintable(e.what()).c_str());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ebh: internal error: %s\n", ebh::escape_unprintable(e.what()).c_str());
    return 3;
  }
  return 0;
}

/// The least stack a command runs on: yaml-cpp parses a nesting by recursion, and under a small
/// limit (`ulimit -s 64`, 64 KiB) a scene file nested 500 deep ended the process by SIGSEGV before
/// yaml-cpp's own depth limit could be said; with the usual 8 MiB it is said.
constexpr std::size_t kCommandStackBytes = std::size_t{8} << 20;

/// Runs `body` and returns its status: on this thread when the process's stack limit is at least
/// kCommandStackBytes (or none), else on a thread with that stack (on this one where no such
/// thread can be started).
int run_with_stack(const std::function<int()>& body) {
  if (rlimit stack{}; getrlimit(RLIMIT_STACK, &stack) != 0 || stack.rlim_cur == RLIM_INFINITY ||
                      stack.rlim_cur >= kCommandStackBytes)
    return body();
  struct Call {
    const std::function<int()>* body;
    int status = 0;
  } call{&body};
  pthread_attr_t attr;
  if (pthread_attr_init(&attr) != 0) return body();
  pthread_t thread;
  const bool started = pthread_attr_setstacksize(&attr, kCommandStackBytes) == 0 &&
                       pthread_create(
                           &thread, &attr,
                           [](void* p) -> void* {
                             auto* c = static_cast<Call*>(p);
                             c->status = (*c->body)();
                             return nullptr;
                           },
                           &call) == 0;
  pthread_attr_destroy(&attr);
  if (!started) return body();
  pthread_join(thread, nullptr);
  return call.status;
}

}  // namespace

int main(int argc, char** argv) {
  // A standard stream the process started without (`ebh ... >&-`) is opened on /dev/null, as Unix
  // programs do: else the next file opened (an output's temporary, a log being read) would get its
  // number, and what is printed would go into that file.
  for (int fd = STDIN_FILENO; fd <= STDERR_FILENO; ++fd)
    if (fcntl(fd, F_GETFD) < 0 && errno == EBADF && open("/dev/null", fd == STDIN_FILENO ? O_RDONLY : O_WRONLY) != fd)
      return 1;  // nowhere to say why
  // The CUDA driver puts the process's streams on CUDA_DEVICE_MAX_CONNECTIONS hardware queues (8
  // unless set), in turn. Replays side by side (ebh replay --batch: a tick stream and a physical
  // stream each) then share queues, and a queue holds one replay's launch behind another's kernel
  // that spins until its own ticks run: 8 replays at once ran at 8.9x real time in total with 8
  // queues and at 14.7x with 32 (docs/CUDA.md, "Many replays on one GPU"). Set before the first
  // CUDA call; a value the user set is kept.
  setenv("CUDA_DEVICE_MAX_CONNECTIONS", "32", 0);
  // Before any OpenMP parallel region, whatever the command: a thread count OpenMP ignored, or one
  // it cannot start (omp_threads_problem), is refused rather than run with.
  if (const char* threads = std::getenv("OMP_NUM_THREADS"))
    if (const std::string why = omp_threads_problem(threads, std::thread::hardware_concurrency()); !why.empty()) {
      std::fprintf(stderr, "ebh: error: OMP_NUM_THREADS '%s': %s\n", ebh::escape_unprintable(threads).c_str(), why.c_str());
      return 1;
    }
  // A signal before the command polls for one (loading a large log or mesh; validate, table1)
  // ends the process with a line and 128 + signal rather than without a word.
  ebh::install_early_interrupt_handlers();
  // A file-size limit (ulimit -f) would end the process by SIGXFSZ without a word, its temporary
  // output left behind: ignored, the write fails with EFBIG and goes the way of a full disk (one
  // line, the temporary removed, exit 1). Commands the sweep starts inherit it.
  std::signal(SIGXFSZ, SIG_IGN);
  // A reader that goes away (`ebh bench sizes --plot p.png | head -3`) would end the process by
  // SIGPIPE at the next line printed, before the files it was asked for are written: ignored, the
  // print fails with EPIPE and the command goes on to its outputs; the end below says what was lost.
  std::signal(SIGPIPE, SIG_IGN);
  // A processor-time limit whose soft and hard values are one (`ulimit -t N` sets both) ends the
  // process by SIGKILL, which no handler sees, its temporary output left behind. With the soft
  // limit 2 s lower, SIGXCPU stops the run first (as SIGTERM does) and, a second later, a second
  // SIGXCPU ends it with its temporaries removed: within the same N seconds.
  if (rlimit cpu{}; getrlimit(RLIMIT_CPU, &cpu) == 0 && cpu.rlim_cur != RLIM_INFINITY && cpu.rlim_cur == cpu.rlim_max &&
                    cpu.rlim_max > 2) {
    cpu.rlim_cur = cpu.rlim_max - 2;
    setrlimit(RLIMIT_CPU, &cpu);
  }
  CLI::App app{"ebh: energy-based haptic rendering for surgical simulation (batch replay, validation, benchmarks)"};
  app.set_version_flag("--version", std::string("ebh ") + ebh::kVersion);
  app.require_subcommand(1);
  for (auto setup : ebh::cli::command_registry()) setup(app);
  ebh::cli::refuse_empty_values(app);
  int status = run_with_stack([&] { return run(app, argc, argv); });
  // A command stopped by SIGINT, SIGTERM or SIGHUP says so and ends with 128 + signal (130, 143,
  // 129), as a second signal would, so a script tells an interrupt from bad input (1).
  if (status != 0 && ebh::interrupt_signal() > 0) status = 128 + ebh::interrupt_signal();
  // What a command prints (a table, JSON) is an output too: a write that failed (a full disk under
  // a redirection) is an error, not a truncated file and exit status 0.
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    const int err = errno;
    const std::size_t written = ebh::outputs_committed();
    // A pipe's reader that has read what it wanted (`| head`) is no error of the user's: the status
    // a shell gives a process ended by SIGPIPE, without a word (the files are written by now).
    if (err == EPIPE) return status == 0 ? 128 + SIGPIPE : status;
    std::fprintf(stderr, "ebh: error: standard output: %s%s\n", err ? std::strerror(err) : "write error",
                 written == 0 ? ""
                 : written == 1 ? " (the output file was written; what the command printed is lost)"
                                : " (the output files were written; what the command printed is lost)");
    return status == 0 ? 1 : status;
  }
  return status;
}
