// ebh: energy-based haptic rendering toolkit — the command line.
#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <string>
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
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
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ebh: internal error: %s\n", ebh::escape_unprintable(e.what()).c_str());
    return 3;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // The CUDA driver puts the process's streams on CUDA_DEVICE_MAX_CONNECTIONS hardware queues (8
  // unless set), in turn. Replays side by side (ebh replay --batch: a tick stream and a physical
  // stream each) then share queues, and a queue holds one replay's launch behind another's kernel
  // that spins until its own ticks run: 8 replays at once ran at 8.9x real time in total with 8
  // queues and at 14.7x with 32 (docs/CUDA.md, "Many replays on one GPU"). Set before the first
  // CUDA call; a value the user set is kept.
  setenv("CUDA_DEVICE_MAX_CONNECTIONS", "32", 0);
  // A signal before the command polls for one (loading a large log or mesh; validate, table1)
  // ends the process with a line and 128 + signal rather than without a word.
  ebh::install_early_interrupt_handlers();
  // A file-size limit (ulimit -f) would end the process by SIGXFSZ without a word, its temporary
  // output left behind: ignored, the write fails with EFBIG and goes the way of a full disk (one
  // line, the temporary removed, exit 1). Commands the sweep starts inherit it.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"ebh: energy-based haptic rendering for surgical simulation (batch replay, validation, benchmarks)"};
  app.set_version_flag("--version", std::string("ebh ") + ebh::kVersion);
  app.require_subcommand(1);
  for (auto setup : ebh::cli::command_registry()) setup(app);
  ebh::cli::refuse_empty_values(app);
  int status = run(app, argc, argv);
  // A command stopped by SIGINT, SIGTERM or SIGHUP says so and ends with 128 + signal (130, 143,
  // 129), as a second signal would, so a script tells an interrupt from bad input (1).
  if (status != 0 && ebh::interrupt_signal() > 0) status = 128 + ebh::interrupt_signal();
  // What a command prints (a table, JSON) is an output too: a write that failed (a full disk under
  // a redirection) is an error, not a truncated file and exit status 0.
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    const int err = errno;
    std::fprintf(stderr, "ebh: error: standard output: %s\n", err ? std::strerror(err) : "write error");
    return status == 0 ? 1 : status;
  }
  return status;
}
