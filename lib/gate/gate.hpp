#pragma once
// The force-smoothness regression gate: short replays of the committed recordings on
// the CPU, their force-quality metrics (lib/metrics) compared with committed baselines. A force
// roughness beyond the stated band, or any non-finite value, fails.
//
// Baselines file (YAML, tests/gate/baselines.yaml), written by `ebh gate --update`:
//   generated_by: "ebh gate --update (ebh 0.1.0, ...)"
//   bands: {relative: 0.5, ...}                # see GateBands
//   cases:
//     - {name: tube_insert, scene: tube, recording: tube_insert, start: 2.8, duration: 2.0,
//        rms_force_step: ..., max_force_rate: ..., peak_force: ..., power_above_30hz: ...,
//        penetration_max: ..., boundary_step_ratio: ..., force_collapse: false}
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "io/json.hpp"
#include "io/lock.hpp"
#include "metrics/force_metrics.hpp"

namespace ebh {

/// The tolerated deviation from a baseline. A metric m with baseline b passes when
///   m <= b * (1 + relative) + absolute   (roughness, rate, penetration, the power above 30 Hz,
///                                        the frame-boundary ratio: only increases fail)
///   b / (1 + relative) - absolute <= m <= b * (1 + relative) + absolute   (peak force: a change by
///                                        the same factor either way is a behaviour change)
/// Why these sizes: replays are bitwise reproducible for one binary, so the bands only absorb
/// compiler and library differences between machines (floating-point contraction, libm), which
/// move these metrics by well under 10%; a real regression (fewer iterations, a broken
/// coupling) moves roughness by integer factors. A force that collapses while the tool stays in
/// contact (metrics/force_metrics.hpp, ForceCollapse) fails a case whose baseline has none.
struct GateBands {
  double relative = 0.5;
  double abs_force_step = 2e-3;    ///< N   (per-tick force change of a quiet contact)
  double abs_force_rate = 5.0;     ///< N/s
  double abs_peak_force = 0.1;     ///< N
  double abs_power = 5e-3;         ///< fraction of force power above 30 Hz (baselines 2e-4 .. 0.07)
  double abs_penetration = 2e-4;   ///< m
  double abs_boundary_ratio = 0.1; ///< frame-boundary step ratio (baselines 0.9 .. 1.25; a felt 100 Hz ripple: >> 1)
};

struct GateCase {
  std::string name, scene, recording;  ///< as the baselines file gives them (and --update writes them)
  /// scene and recording as they are read: a relative path joined to the baselines file's folder
  /// (data_reference_from), a name as it is
  std::string scene_file, recording_file;
  double start = 0, duration = 2.0;  ///< s: the window of the recording replayed (replay_window checks it)
  std::string where;  ///< "FILE:LINE: cases[i] (NAME)", naming the case in messages (read_gate_baselines sets it)
  /// The case's lines in the baselines file, as read_gate_baselines found them ("" where they share
  /// a line with another case's): write_gate_baselines writes a case that has them as they are, so
  /// that --update of one case leaves the others byte for byte; a case measured anew has none.
  std::string text;
  // Baseline metrics (NaN when not yet recorded).
  double rms_force_step = 0, max_force_rate = 0, peak_force = 0, power_above_30hz = 0, penetration_max = 0;
  double boundary_step_ratio = 0;  ///< metrics' frame-boundary ratio (NaN in a baseline: none to compare)
  /// whether the force collapsed in the window (metrics' ForceCollapse); absent in a baseline: not compared
  std::optional<bool> force_collapse;
};

struct GateBaselines {
  std::string generated_by;
  /// The file's leading comment lines, each with its line end ("" when it starts with data): kept
  /// by write_gate_baselines, so a lab's own file keeps its own header through --update
  std::string header;
  /// Comment lines after the header, which a rewrite of the YAML cannot keep (--update warns)
  std::size_t body_comments = 0;
  GateBands bands;
  std::vector<GateCase> cases;
};

struct GateResult {
  GateCase measured;   ///< the case with the metrics of this run
  bool passed = true;
  bool stopped = false;  ///< the replay's health checks stopped it (failures says where): no metrics
  std::vector<std::string> failures;  ///< one line each
  /// The metrics the baselines give no value for, so not compared (a hand-edited or older file): a
  /// pass checked the rest only. Named as the baselines file names them (rms_force_step).
  std::vector<std::string> unchecked;
  /// the replay's contact_warning (metrics/force_metrics.hpp): the window where the tool never or
  /// barely touched the tissue, whose metrics describe a free tool ("" when it touched)
  std::string contact_warning;
  /// What a replay of the case says besides (the recording's checks, a window cut at the
  /// recording's end, a collapse of the force): one line each, printed under the case
  std::vector<std::string> warnings;
};

/// The exclusive lock `ebh gate --update` holds on the baselines file from reading it to writing
/// it (io/lock.hpp: a flock on the file itself, taken again on the file under its name once a
/// writer renamed a new one over it), so two updates at once both land. When another process holds
/// it, says so on stderr ("ebh gate: FILE: another ebh gate --update is writing it; waiting") and
/// waits. On a file system that takes no locks it warns and holds none.
FileLock lock_gate_baselines(const std::string& path);

/// Removes the temporary folders of gate runs that are gone (TMP/ebh_gate_PID_XXXXXX, made by
/// run_gate_case, and the files an older ebh left there under fixed names): only this user's,
/// only where PID no longer runs; a link or another user's file is left alone. Returns how many
/// it removed.
std::size_t remove_stale_gate_temporaries(const std::filesystem::path& tmp);

/// Reads a baselines file; throws InputError "FILE:LINE: key 'KEY': WHAT" (yaml_key_error).
GateBaselines read_gate_baselines(const std::string& path);
/// Writes a baselines file atomically, under b.header (else a header saying how to regenerate it):
/// a case with its text (GateCase::text) as that text, another from its values, a metric without
/// a value (NaN) left out, as the reader takes it.
void write_gate_baselines(const std::string& path, const GateBaselines& b);

/// What a gate checks of a case before any case runs (a missing scene or a start past the end of
/// the last case failed the gate after the others had run, minutes on CI): its scene, meshes and
/// recording are there and the overrides apply (replay_input_files), the recording reads, and its
/// window is one a replay takes (replay_window against the recording, at the scene's haptic rate:
/// a start before the recording's end, at least one haptic tick, as a shorter window replays a
/// single tick: no force step, metrics of nothing). Throws InputError naming the case (GateCase::where).
void check_gate_case(const GateCase& c, const std::vector<std::string>& overrides);

/// Replays one case (async mode, CPU, scene overrides applied) and computes its metrics (its
/// `measured` without the case's text: its values are new). Its replay output goes into a folder
/// of its own under the temporary directory (mkdtemp: TMP/ebh_gate_PID_XXXXXX, readable by this
/// user only), removed with it when the case ends.
GateResult run_gate_case(const GateCase& c, const std::vector<std::string>& overrides);
/// Compares a run with its baseline under the bands; fills passed/failures.
void judge_gate_case(const GateCase& baseline, const GateBands& bands, GateResult& r);

/// A metric as the baselines file names it (GateResult::unchecked: "rms_force_step") under its
/// key in the JSON report, with its unit as `ebh metrics --json` gives it ("rms_force_step_N"),
/// and as the text output names it ("rms_force_step [N]"; a ratio or a flag as it is).
std::string gate_metric_key(const std::string& name);
std::string gate_metric_label(const std::string& name);

/// The JSON report of a case: whether it passed, its metrics measured and its baseline's (keys
/// with their unit, gate_metric_key; null where there is no value), the failures, warnings and the
/// unchecked metrics (under the same keys).
Json to_json(const GateResult& r, const GateCase& baseline);

}  // namespace ebh
