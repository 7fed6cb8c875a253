// `ebh validate NAME|all [--json]`, `ebh validate --list`: runs the library's validation cases
// (lib/validate) and exits 1 if any did not pass.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "core/error.hpp"
#include "replay_common.hpp"
#include "schedule/replay_inputs.hpp"
#include "validate/validation.hpp"

namespace {

struct Options {
  std::string name;
  bool json = false;
  bool list = false;
  ebh::ValidationOptions validation;
};

/// --recording: each one a recording that reads, and a chosen validation that replays it, checked
/// before any validation runs (an unknown name would otherwise surface after the others ran, and
/// a validation with no recordings would ignore it).
void check_recordings(const std::vector<std::string>& recordings, const std::vector<const ebh::Validation*>& chosen) {
  using namespace ebh;
  if (recordings.empty()) return;
  for (const std::string& r : recordings) {
    try {
      (void)read_replay_recording(r);
    } catch (const InputError& e) {
      throw InputError(std::string("--recording: ") + e.what());
    }
  }
  if (std::none_of(chosen.begin(), chosen.end(), [](const Validation* v) { return v->replays_recordings; })) {
    std::string takers;
    for (const Validation& v : validations())
      if (v.replays_recordings) takers += (takers.empty() ? "" : " and ") + v.name;
    throw InputError("--recording " + recordings.front() + ": the " + chosen.front()->name +
                     " validation replays no recording (--recording is for " + takers + ")");
  }
}

void run(const Options& o) {
  using namespace ebh;
  if (o.list) {
    for (const Validation& v : validations()) std::printf("%-14s %s\n", v.name.c_str(), v.description.c_str());
    return;
  }
  if (o.name.empty()) throw InputError("validate: name a validation, 'all', or use --list");
  cli::check_backend(o.validation.backend);
  std::vector<const Validation*> chosen;
  if (o.name == "all") {
    for (const Validation& v : validations()) chosen.push_back(&v);
  } else if (const Validation* v = find_validation(o.name)) {
    chosen.push_back(v);
  } else {
    throw InputError("validate: no validation named '" + o.name + "' (see ebh validate --list)");
  }
  check_recordings(o.validation.recordings, chosen);
  bool all_passed = true;
  Json results = Json::array();
  for (const Validation* v : chosen) {
    const ValidationResult r = v->run(o.validation);
    all_passed = all_passed && r.passed;
    if (o.json) {
      results.push(r.to_json());
    } else {
      std::printf("%-14s error %.3e  tolerance %.3e  %s\n", r.name.c_str(), r.error, r.tolerance,
                  r.passed ? "passed" : "FAILED");
    }
  }
  if (o.json) std::printf("%s\n", results.dump(2).c_str());
  if (!all_passed) throw ebh::cli::ExitRequest{1};
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand("validate", "Run validation cases with analytic or reference answers");
  cmd->add_option("name", opts->name, "validation name, or 'all'");
  cmd->add_flag("--json", opts->json, "print results as JSON (an array of {name, error, tolerance, passed, data})");
  cmd->add_flag("--list", opts->list, "list the validations");
  cmd->add_flag("--full", opts->validation.full, "the long form of the stress matrices (stability: every recording, mesh, solver; coupling: every recording whole; contact: every speed and surface)");
  cmd->add_option("--backend", opts->validation.backend, "cpu or cuda: where the iterative solvers run (stability, coupling)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  cmd->add_option("--recording", opts->validation.recordings, "replay only these recordings (stability, coupling; repeat the option)");
  cmd->callback([opts] { run(*opts); });
}

}  // namespace

EBH_COMMAND(setup);
