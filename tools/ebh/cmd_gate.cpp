// ebh gate: the force-smoothness regression gate (lib/gate/gate.hpp) for CI.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.hpp"
#include "core/error.hpp"
#include "ebh/version.hpp"
#include "gate/gate.hpp"
#include "io/paths.hpp"
#include "options.hpp"

namespace ebh::cli {
namespace {

/// v in printf format `f`, or "-" where the case has no value (NaN: the power above 30 Hz of a
/// window too short for a spectrum, the frame ratio of a force that never changed), as `ebh
/// metrics` prints it.
std::string shown(const char* f, double v) {
  if (std::isnan(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

struct GateArgs {
  std::string baselines = std::string(kSourceDir) + "/tests/gate/baselines.yaml";
  std::vector<std::string> overrides, only;
  bool update = false, json = false;
};

void run_gate(const GateArgs& a) {
  check_set_once(a.overrides);
  // Baselines measured under an override are what every later plain run is compared with: the
  // file kept only a note of it, and a plain gate passed a case whose baseline had twice its force.
  if (a.update && !a.overrides.empty())
    throw InputError("--update with --set " + a.overrides.front() + ": baselines measured under an override would be "
                     "the reference of every later run without it; update without --set (for a gate of another "
                     "scene, a baselines file of its own whose cases name that scene)");
  // What gate runs killed with SIGKILL left in the temporary directory (a TMPDIR that is no
  // folder is said here, before any case runs).
  remove_stale_gate_temporaries(temporary_directory());
  // --update: the baselines can be written where they are (said before any case runs), and no
  // other update writes them between this one's reading and writing.
  FileLock lock;
  if (a.update) {
    check_input_file(a.baselines);
    check_outputs({{a.baselines, "the baselines (--update)"}}, {});
    lock = lock_gate_baselines(a.baselines);
  }
  GateBaselines b = read_gate_baselines(a.baselines);
  // Baselines another version measured: its changes to the solver may move every metric (a
  // regression or not), which the bands do not absorb.
  const std::string this_version = std::string("ebh gate --update (ebh ") + kVersion + ")";
  if (!a.update && !b.generated_by.empty() && b.generated_by != this_version)
    std::fprintf(stderr,
                 "ebh: warning: %s: generated_by '%s', not this ebh %s: a change between the two versions moves the "
                 "metrics as a regression would (`ebh gate --update` measures them with this one)\n",
                 a.baselines.c_str(), escape_unprintable(b.generated_by).c_str(), kVersion);
  // Said before the cases run (minutes), while an interrupt still keeps the file as it is.
  if (a.update && b.body_comments > 0)
    std::fprintf(stderr, "ebh: warning: %s: its %zu comment line%s below the header will not be kept: --update writes "
                 "the file anew from its values and the lines of the cases it does not measure (notes kept through "
                 "updates belong in the header, the comment lines at its top)\n",
                 a.baselines.c_str(), b.body_comments, b.body_comments == 1 ? "" : "s");
  std::vector<std::string> known;
  for (const GateCase& c : b.cases) known.push_back(c.name);
  check_known_names("--case", "gate case", a.only, known);
  // Every case's inputs and window are good before the first case runs (check_gate_case).
  for (const GateCase& c : b.cases)
    if (a.only.empty() || std::find(a.only.begin(), a.only.end(), c.name) != a.only.end()) check_gate_case(c, a.overrides);
  Json report = Json::array();
  bool all_passed = true;
  for (GateCase& c : b.cases) {
    if (!a.only.empty() && std::find(a.only.begin(), a.only.end(), c.name) == a.only.end()) continue;
    GateResult r = run_gate_case(c, a.overrides);
    if (a.update) {
      if (r.stopped) throw NumericalError("gate --update: " + r.failures.front());  // nothing to measure
      // A baseline is a number: a window too short for a metric (a tick or two) gives none.
      for (const auto& [name, v] : {std::pair{"rms_force_step", r.measured.rms_force_step},
                                    {"max_force_rate", r.measured.max_force_rate},
                                    {"peak_force", r.measured.peak_force},
                                    {"penetration_max", r.measured.penetration_max}})
        if (!std::isfinite(v))
          throw InputError("not updating " + a.baselines + ": " + c.where + ": its window (start " +
                           cli::format_number(c.start) + " s, duration " + cli::format_number(c.duration) +
                           " s) gives no " + name + "; lengthen it");
      // A window where the tool is free measures round-off: a baseline that no regression moves.
      if (!r.contact_warning.empty())
        throw InputError("not updating " + a.baselines + ": " + c.where + ": in its window (start " +
                         cli::format_number(c.start) + " s, duration " + cli::format_number(c.duration) + " s) " +
                         r.contact_warning + ": a baseline of a free tool checks nothing; move the window");
      c = r.measured;
    } else {
      judge_gate_case(c, b.bands, r);
    }
    // Said once the case is taken (a refused update says only why).
    for (const std::string& w : r.warnings)
      std::fprintf(stderr, "ebh: warning: %s: %s\n", c.name.c_str(), escape_unprintable(w).c_str());
    all_passed = all_passed && r.passed;
    if (a.json) {
      report.push(to_json(r, c));  // after --update, c is the new baseline
    } else if (r.stopped) {
      std::printf("%-24s FAIL  stopped by the health checks\n", c.name.c_str());
      for (const auto& f : r.failures) std::printf("    %s\n", f.c_str());
    } else {
      std::printf("%-24s %s  rms dF %s N  max dF/dt %8s N/s  peak %s N  >30 Hz %s  pen %s mm  frame ratio %s\n",
                  c.name.c_str(), r.passed ? "ok  " : "FAIL", shown("%.3e", r.measured.rms_force_step).c_str(),
                  shown("%.2f", r.measured.max_force_rate).c_str(), shown("%.3f", r.measured.peak_force).c_str(),
                  shown("%.3f", r.measured.power_above_30hz).c_str(),
                  shown("%.3f", 1e3 * r.measured.penetration_max).c_str(),
                  shown("%.2f", r.measured.boundary_step_ratio).c_str());
      for (const auto& f : r.failures) std::printf("    %s\n", f.c_str());
      if (!r.unchecked.empty()) {  // all missing: a failure says so, and none is listed
        std::string names;
        for (const std::string& n : r.unchecked) {
          if (!names.empty()) names += ", ";
          names += gate_metric_label(n);  // with its unit, as the failures name it
        }
        std::printf("    %s: not compared, no baseline: %s (`ebh gate --update` writes them)\n", c.name.c_str(), names.c_str());
      }
    }
  }
  if (a.json) std::printf("%s\n", report.dump().c_str());
  if (a.update) {
    if (!all_passed) throw InputError("not updating " + a.baselines + ": a case produced non-finite values");
    b.generated_by = this_version;
    write_gate_baselines(a.baselines, b);
    std::fprintf(a.json ? stderr : stdout, "wrote %s\n", a.baselines.c_str());  // stdout holds the JSON alone
    return;
  }
  if (!a.json) {
    std::string under;  // a run under overrides measures another scene than the baselines'
    for (const std::string& o : a.overrides) under += (under.empty() ? " (under --set " : ", --set ") + o;
    if (!under.empty()) under += ": not the baselines' scenes)";
    std::printf("%s%s\n", all_passed ? "gate: passed" : "gate: FAILED", under.c_str());
  }
  if (!all_passed) throw ExitRequest{kCheckFailedStatus};
}

void setup(CLI::App& root) {
  auto args = std::make_shared<GateArgs>();
  CLI::App* c = root.add_subcommand("gate", "Force-smoothness regression gate: short replays vs committed baselines");
  c->add_option("--baselines", args->baselines,
                 "Baselines file (default: " + args->baselines + ", the source tree this ebh was built from)");
  c->add_option("--set", args->overrides, "Scene override applied to every case (to test the gate itself; not with --update)");
  c->add_option("--case", args->only, "Run only these cases (repeatable)");
  c->add_flag("--update", args->update, "Re-measure and rewrite the baselines");
  c->add_flag("--json", args->json, "JSON report");
  c->callback([args] { run_gate(*args); });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
