#pragma once
// A sweep's summary (DIR/summary.csv; docs/FORMATS.md, "Sweep summary"): one row per run of the
// plan with its overrides, status, wall time, real-time factor, its force error against the
// reference replay of the same scene and recording, and every value of `ebh metrics` (computed
// here, in-process, from the run's output).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "metrics/replay_trace.hpp"
#include "sweep/plan.hpp"

namespace ebh {

/// How far a run's force is from the reference's: e_j = |F(t_j) - F_ref(t_j)| at each reference
/// tick t_j inside the run's span, F(t) the run's force held from its last tick at or before t
/// (what a device displays between ticks; the same tick times give the tick-by-tick difference).
struct ForceError {
  double rms = 0;        ///< sqrt(mean e_j^2), N
  double max = 0;        ///< max e_j, N
  double p999 = 0;       ///< 99.9th percentile of e_j, N (metrics/signal.hpp percentile)
  std::size_t ticks = 0; ///< reference ticks compared
};

/// NaN errors (and ticks 0) when the two runs do not overlap in time.
ForceError force_error(const ReplayTrace& run, const ReplayTrace& reference);

/// A table of text cells, read from or written to CSV (RFC 4180: fields with a comma, a quote or
/// a line break are quoted, quotes doubled).
struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  /// The index of a column; throws InputError "FILE: no column 'NAME'" when missing.
  std::size_t column(const std::string& name, const std::string& file) const;
  std::string to_csv() const;
};

/// Parses CSV text (RFC 4180; a line ends at LF, CRLF or a lone CR); every row must have the
/// header's number of fields. Throws InputError "FILE:LINE: ..." otherwise, and
/// "FILE:LINE:COLUMN: field N: ..." for a quote that is not where RFC 4180 allows one: a quoted
/// field's closing quote followed by anything but a comma or a line end (an undoubled quote inside
/// it), or a quote inside a field that does not begin with one.
CsvTable parse_csv(const std::string& text, const std::string& file);

struct SweepSummary {
  CsvTable table;
  std::size_t ok = 0, failed = 0, pending = 0;
  std::size_t redo = 0;  ///< of the pending: runs with an output the sweep runs again (redo_reason)
};

/// The summary as HDF5 (DIR/summary.h5; docs/FORMATS.md, "summary.h5"): the same rows and
/// columns, one 1-D dataset per column in the root group, named as the column: text columns (id,
/// status, scene, recording, backend, baseline, overrides, error, and a set.KEY column with a value
/// that is not a number) as variable-length UTF-8 strings; repetition and reference as int64; every other
/// column as float64 (an empty cell: NaN). The root attribute `columns` lists the names in the
/// CSV's order, one per line. Written atomically; InputError (naming `path`, the row and the
/// column) when a numeric column holds text.
void write_summary_h5(const CsvTable& summary, const std::string& path);

/// The columns of a run's measures that `ebh sweep report` reads from an ok row (build_report), in
/// the order it checks them: each empty (not measured: no reference, no region) or a finite number
/// >= 0, as a replay gives them.
inline const std::vector<std::string> kReportMeasureColumns = {
    "real_time_factor", "force_error_rms_N", "force_error_max_N", "force_error_p999_N", "timing.physical_residual_max",
    "haptic_hz", "whole.max_force_rate_N_per_s", "active_vertices_mean", "awake_vertices_mean", "contact_fraction"};

/// "" when an ok row's `cell` of `column` is what the report takes, else what it takes there: wall_s
/// "a finite number > 0 (the run's wall time)", a column of kReportMeasureColumns "a finite number
/// >= 0 or nothing". Any other column takes anything ("").
std::string report_cell_problem(const std::string& column, const std::string& cell);

/// The summary of every run of the plan as it stands in `dir`: status ok (an output the sweep takes
/// as done: run_state), failed (a DIR/runs/ID.failed, or an output that does not read) or pending
/// (neither, or an output the sweep would run again: its error says why, redo_reason). An output
/// holding a non-finite sample (NaN or inf, in any dataset the metrics read: a replay whose numbers
/// go wrong stops and writes none) is failed, its error naming the datasets; so is one that gives a
/// measure the report would refuse (report_cell_problem), its error naming the column: the summary
/// is never one its own report refuses. A run whose reference has no usable output is ok with empty
/// force errors, its error saying why (the reference failed, not run yet, to run again). The input
/// files are checked against the digests the plan read (SweepPlan::sha256): a file edited while
/// the sweep ran leaves the runs made from it pending. Reads each output once and each reference once.
SweepSummary summarize_sweep(const SweepPlan& plan, const std::vector<SweepRun>& runs, const std::filesystem::path& dir);

/// A row of a summary as read that says ok for a run whose output the sweep no longer takes as done.
struct OutdatedRow {
  std::size_t row = 0;            ///< index into CsvTable::rows
  const SweepRun* run = nullptr;  ///< its run, of `runs`
  /// Why, as the error column of a pending row says it: "to run again: its output DIR/runs/ID.h5
  /// is not there (deleted since the summary was written)", "to run again: a run whose output does
  /// not open", ...
  std::string why;
};

/// The rows of `summary` (a sweep's summary.csv as read) that say ok for a run of `runs` whose
/// output in `dir` the sweep would not take as done now (run_state: deleted, cut short, replaced
/// by another run's replay or made from input files edited since the summary was written): a
/// resumed sweep runs each again, so the summary no longer holds its result. Rows are matched by
/// their `id` column; a summary without one (an older ebh) gives none.
std::vector<OutdatedRow> outdated_ok_rows(const SweepPlan& plan, const std::vector<SweepRun>& runs, const CsvTable& summary,
                                          const std::filesystem::path& dir);

}  // namespace ebh
