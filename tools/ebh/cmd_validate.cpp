// `ebh validate NAME|all [--json]`, `ebh validate --list`: runs the library's validation cases
// (lib/validate) and exits 1 if any did not pass.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "core/error.hpp"
#include "replay_common.hpp"
#include "scene/scene.hpp"
#include "schedule/replay_inputs.hpp"
#include "validate/validation.hpp"

namespace {

struct Options {
  std::string name;
  bool json = false;
  bool list = false;
  ebh::ValidationOptions validation;
};

/// The validations that take an option ("coupling and stability"; "contact, coupling and stability").
std::string takers(bool ebh::Validation::*takes) {
  std::vector<std::string> names;
  for (const ebh::Validation& v : ebh::validations())
    if (v.*takes) names.push_back(v.name);
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i)
    out += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
  return out;
}

bool any_takes(const std::vector<const ebh::Validation*>& chosen, bool ebh::Validation::*takes) {
  return std::any_of(chosen.begin(), chosen.end(), [takes](const ebh::Validation* v) { return v->*takes; });
}

/// --recording: each one a recording that reads, and a chosen validation that replays it, checked
/// before any validation runs (an unknown name would otherwise surface after the others ran, and
/// a validation with no recordings would ignore it). --full: a chosen validation with a long form
/// (another would run its one form and pass as if the long one had). --backend cuda: a chosen
/// validation that places its solvers (another would run on the CPU without a word).
void check_options(const ebh::ValidationOptions& o, const std::vector<const ebh::Validation*>& chosen) {
  using namespace ebh;
  for (const std::string& r : o.recordings) {
    try {
      (void)read_replay_recording(r);
    } catch (const InputError& e) {
      throw InputError(std::string("--recording: ") + e.what());
    }
  }
  if (!o.recordings.empty() && !any_takes(chosen, &Validation::replays_recordings))
    throw InputError("--recording " + o.recordings.front() + ": the " + chosen.front()->name +
                     " validation replays no recording (--recording is for " + takers(&Validation::replays_recordings) +
                     ")");
  // --set: by the stress matrices only (the analytic cases build their own scenes), each override
  // checked on a committed scene before any case runs, as --recording is.
  check_overrides_once(o.overrides);
  if (!o.overrides.empty()) {
    if (!any_takes(chosen, &Validation::replays_recordings))
      throw InputError("--set " + o.overrides.front() + ": the " + chosen.front()->name +
                       " validation builds its own scenes (--set is for " + takers(&Validation::replays_recordings) + ")");
    (void)load_scene_spec(resolve_scene_path("tube"), o.overrides);
    for (const Validation* v : chosen) {
      std::string varied;
      for (const std::string& k : v->varied_keys) varied += (varied.empty() ? "" : " and ") + k;
      for (const std::string& s : overrides_of_keys(o.overrides, v->varied_keys))
        std::fprintf(stderr, "ebh: warning: --set %s: the %s validation varies %s itself: its values are used there\n",
                     s.c_str(), v->name.c_str(), varied.c_str());
    }
  }
  if (o.full && !any_takes(chosen, &Validation::has_full_form))
    throw InputError("--full: the " + chosen.front()->name + " validation has no full form (--full is for " +
                     takers(&Validation::has_full_form) + ")");
  if (o.backend == "cuda" && !any_takes(chosen, &Validation::places_solvers))
    throw InputError("--backend " + o.backend + ": the " + chosen.front()->name +
                     " validation runs on the CPU only (--backend is for " + takers(&Validation::places_solvers) + ")");
}

void run(const Options& o) {
  using namespace ebh;
  if (o.list) {
    Json list = Json::array();
    for (const Validation& v : validations()) {
      if (!o.json) std::printf("%-14s %s\n", v.name.c_str(), v.description.c_str());
      Json entry = Json::object();
      entry.set("name", v.name);
      entry.set("description", v.description);
      list.push(std::move(entry));
    }
    if (o.json) std::printf("%s\n", list.dump(2).c_str());
    return;
  }
  if (o.name.empty()) throw InputError("validate: name a validation, 'all', or use --list");
  std::vector<const Validation*> chosen;
  if (o.name == "all") {
    for (const Validation& v : validations()) chosen.push_back(&v);
  } else if (const Validation* v = find_validation(o.name)) {
    chosen.push_back(v);
  } else {
    throw InputError("validate: no validation named '" + o.name + "' (see ebh validate --list)");
  }
  check_options(o.validation, chosen);
  cli::check_backend(o.validation.backend);
  bool all_passed = true;
  Json results = Json::array();
  for (const Validation* v : chosen) {
    const ValidationResult r = v->run(o.validation);
    all_passed = all_passed && r.passed;
    if (o.json) {
      results.push(r.to_json());
    } else if (!r.summary.empty()) {
      std::printf("%-14s %s  %s\n", r.name.c_str(), r.summary.c_str(), r.passed ? "passed" : "FAILED");
    } else {
      std::printf("%-14s error %.3e  tolerance %.3e  %s\n", r.name.c_str(), r.error, r.tolerance,
                  r.passed ? "passed" : "FAILED");
    }
  }
  if (o.json) std::printf("%s\n", results.dump(2).c_str());
  if (!all_passed) throw ebh::cli::ExitRequest{ebh::cli::kCheckFailedStatus};
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand("validate", "Run validation cases with analytic or reference answers");
  cmd->add_option("name", opts->name, "validation name, or 'all'");
  cmd->add_flag("--json", opts->json, "print results as JSON (an array of {name, error, tolerance, passed, data})");
  cmd->add_flag("--list", opts->list, "list the validations");
  cmd->add_flag("--full", opts->validation.full, "the long form of the stress matrices (stability: every recording, mesh, solver; coupling: every recording whole; contact: every speed and surface); refused by the other cases");
  cmd->add_option("--backend", opts->validation.backend, "cpu or cuda: where the iterative solvers run (stability, coupling)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  cmd->add_option("--recording", opts->validation.recordings, "replay only these recordings (stability, coupling; repeat the option)");
  cmd->add_option("--set", opts->validation.overrides,
                  "override a scene key in every scene the stress matrix replays: --set stiffness.k_svc=20 (stability, "
                  "coupling; repeatable; the key the matrix varies keeps the matrix's values)");
  cmd->callback([opts] { run(*opts); });
}

}  // namespace

EBH_COMMAND(setup);
