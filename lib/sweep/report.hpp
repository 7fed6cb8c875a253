#pragma once
// `ebh sweep report`: run time against force error from a sweep's summary. Runs of one
// configuration (its repetitions) are one point (medians); the points of each scene, recording
// and backend are compared with each other, and the Pareto front is the configurations that no
// other one beats on both wall time and force RMS error against the reference (the reference
// itself is the yardstick, not a candidate). A configuration with fewer haptic ticks per second
// than the floor (a haptic device's loop rate, scene/scene.hpp kDeviceHapticHz) is listed but is no candidate
// either: not on the front, not against the baseline.
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "scene/scene.hpp"
#include "sweep/summary.hpp"

namespace ebh {

/// Which points are on the Pareto front when both coordinates are to be small: point i is on it
/// unless some j has x_j <= x_i and y_j <= y_i with one of them strictly smaller. Points with a
/// NaN coordinate are never on it (and dominate nothing).
std::vector<bool> pareto_front(const std::vector<std::pair<double, double>>& points);

/// One configuration of one scene, recording and backend: its runs' medians.
struct ReportPoint {
  std::string overrides;
  bool reference = false;
  std::size_t runs = 0;
  double wall_s = 0, real_time_factor = 0;
  double error_rms = 0, error_max = 0, error_p999 = 0;  ///< N, against the reference
  double residual_max = 0;                             ///< max physical residual (NaN when absent)
  double max_force_rate = 0;                           ///< N/s, the rendered force's largest rate (NaN when absent)
  double haptic_hz = 0;                                ///< haptic ticks per second (NaN when absent)
  double active_mean = 0, awake_mean = 0;              ///< the regions' sizes (active_vertices_mean, awake_vertices_mean; NaN when off or absent)
  double contact_fraction = 0;                         ///< ticks in contact over ticks (NaN when absent)
  bool below_rate = false;                             ///< haptic_hz below the report's floor: no candidate
  bool front = false;
  std::string baseline;                                ///< the plan's baseline name when this is it, else ""
};


/// An RMS force error at most this (N) is round-off: the configuration renders the reference's
/// forces (a device resolves about a millinewton), so it is the reference in effect, no candidate.
inline constexpr double kSameForceN = 1e-9;

struct ReportGroup {
  std::string scene, recording, backend;
  double min_haptic_hz = 0;              ///< the floor the points were held to (0: none)
  std::string reference;                 ///< "OVERRIDES (BACKEND)" of the reference ("" when not in the summary)
  std::vector<ReportPoint> points;       ///< by wall time
  std::vector<std::string> failed;       ///< "ID OVERRIDES: error", one per failed run
  std::size_t pending = 0;
  /// "ID OVERRIDES: why", one per pending run whose output the sweep runs again (its error column)
  std::vector<std::string> redo;
  std::string baseline;  ///< the plan's baseline name when a run of the group (ok or not) is the baseline's, else ""
  /// Why a group with a baseline has no comparison with it (baseline_goal gives none): "none of its
  /// runs is ok (1 failed, 0 not run yet)", "its runs have no force error: ERROR" (their error
  /// column: the reference failed, say); "" when it has one or the group has no baseline.
  std::string no_baseline_goal;
};

/// A group's configurations against its baseline B (the plan's `baseline`): the fastest one whose
/// RMS error is at most B's, and the most accurate one whose wall time is at most B's (B itself
/// when no other does better; the reference and the points below the haptic rate floor are never
/// candidates). The goal of a faster method:
/// speedup >= 2 at equal or lower error, or error_ratio >= 2 at equal or lower time.
struct BaselineGoal {
  std::size_t baseline = 0, fastest = 0, most_accurate = 0;  ///< indices into ReportGroup::points
  double speedup = 1;      ///< B's wall time over the fastest's
  double error_ratio = 1;  ///< B's RMS error over the most accurate's
  bool faster() const { return speedup >= 2; }             ///< the goal met by speed
  bool more_accurate() const { return error_ratio >= 2; }  ///< the goal met by accuracy
  bool met() const { return faster() || more_accurate(); }
};
/// Nothing when the group has no finished baseline run (or its wall time or error is NaN).
std::optional<BaselineGoal> baseline_goal(const ReportGroup& group);

/// Throws InputError "--min-haptic-hz nan: expected a finite number >= 0 ..." unless `hz` is one.
void check_min_haptic_hz(double hz);

/// Groups the summary's rows (columns: status, scene, recording, backend, reference, overrides,
/// wall_s, real_time_factor, force_error_rms_N, force_error_max_N, force_error_p999_N; optional:
/// id, error, baseline, timing.physical_residual_max, haptic_hz). Configurations below
/// `min_haptic_hz` haptic ticks per second are no candidates (0: every one is). Throws InputError
/// "FILE: no runs ..." for a summary without rows (a plan has one run at least: its reference), and
/// naming `file`, the row and the column for a missing column, a column named twice, a reference
/// other than 0 or 1, and in an ok row a wall time that is not a finite number > 0 or a measure
/// (real-time factor, force errors, residual, haptic rate, ...) that is neither empty nor a finite
/// number >= 0.
std::vector<ReportGroup> build_report(const CsvTable& summary, const std::string& file, double min_haptic_hz = 0);

/// A candidate against the baseline whose max physical residual is more than this many times the
/// baseline's is named as less converged beside the comparison (report_markdown). Configurations
/// that keep the stopping rule stop at the same residual tolerance; the one this names was 16x
/// (cholecystectomy_press with 6 fixed physical iterations, two from diverging).
inline constexpr double kLooserSolve = 5;

/// The Markdown report: per group a table by wall time, the front and the baseline marked, and the
/// comparison with the baseline (baseline_goal) when there is one, saying where the fastest or the
/// most accurate leaves its physical mesh less converged than the baseline (kLooserSolve), and
/// that no configuration is faster (or more accurate) where the baseline is itself the fastest
/// (the most accurate), not "1x"; a group whose baseline gives no comparison says why
/// (ReportGroup::no_baseline_goal), and the closing 2x-goal section counts such groups as not
/// compared: no baseline of the plan goes unmentioned. Text from the summary (names, overrides,
/// errors) shows as written: what Markdown or HTML would take for syntax (<b>, [x](y), *, |, `) is
/// escaped, a plain name left as it is.
std::string report_markdown(const std::vector<ReportGroup>& groups);

/// A PNG plot (log-log): force RMS error against wall time, one colour per group, the front of
/// each joined by a line, the reference as a ring on the bottom edge, the baseline ringed. Written
/// atomically.
void write_report_plot(const std::vector<ReportGroup>& groups, const std::string& path);

}  // namespace ebh
