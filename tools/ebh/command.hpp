#pragma once
// Each `ebh` command lives in its own file (cmd_NAME.cpp) and registers itself with
// EBH_COMMAND(setup), where setup(CLI::App& root) adds a subcommand whose callback does the work.
// A callback reports bad input by throwing InputError; main prints "ebh: error: ..." and exits 1.
#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace ebh::cli {

using CommandSetup = void (*)(CLI::App& root);

std::vector<CommandSetup>& command_registry();

/// Thrown by a command to end with a given exit code after printing its own message
/// (e.g. a validation that ran but did not pass exits kCheckFailedStatus).
struct ExitRequest {
  int code;
};

/// The exit status of a check that ran and did not pass (`ebh gate`, `ebh validate`): not 1, bad
/// input, so that a CI job tells a regression from a typo (3 internal error, 4 numerical, 128 +
/// signal interrupted).
inline constexpr int kCheckFailedStatus = 2;

struct CommandRegistrar {
  explicit CommandRegistrar(CommandSetup setup) { command_registry().push_back(setup); }
};

}  // namespace ebh::cli

#define EBH_CONCAT_INNER(a, b) a##b
#define EBH_CONCAT(a, b) EBH_CONCAT_INNER(a, b)
#define EBH_COMMAND(setup) \
  static const ::ebh::cli::CommandRegistrar EBH_CONCAT(ebh_command_registrar_, __LINE__){setup}
