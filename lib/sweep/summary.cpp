#include "sweep/summary.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <optional>

#include "core/error.hpp"
#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "metrics/force_metrics.hpp"
#include "metrics/signal.hpp"
#include "sweep/runner.hpp"

namespace ebh {
namespace fs = std::filesystem;
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string cell(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "" : (v > 0 ? "inf" : "-inf");
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

/// The metric columns: `ebh metrics --json`'s numbers (its settings, `options.*`, left out).
std::vector<std::pair<std::string, double>> metric_values(const ForceMetrics& m) {
  std::vector<std::pair<std::string, double>> out;
  for (auto& [k, v] : to_json(m, false).numbers())
    if (k.rfind("options.", 0) != 0) out.emplace_back(std::move(k), v);
  return out;
}

const std::vector<std::string> kRunColumns = {"id", "status", "scene", "recording", "backend", "repetition", "reference",
                                              "baseline", "overrides"};
const std::vector<std::string> kResultColumns = {"wall_s", "virtual_s", "real_time_factor", "force_error_rms_N",
                                                 "force_error_max_N", "force_error_p999_N", "compared_ticks",
                                                 "active_vertices_mean", "awake_vertices_mean"};

}  // namespace

std::string report_cell_problem(const std::string& column, const std::string& cell) {
  const bool wall = column == "wall_s";
  if (!wall && std::find(kReportMeasureColumns.begin(), kReportMeasureColumns.end(), column) == kReportMeasureColumns.end())
    return "";
  if (!wall && cell.empty()) return "";
  double v = 0;
  const auto [p, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), v);
  const bool number = !cell.empty() && ec == std::errc() && p == cell.data() + cell.size() && std::isfinite(v);
  if (wall) return number && v > 0 ? "" : "a finite number > 0 (the run's wall time)";
  return number && v >= 0 ? "" : "a finite number >= 0 or nothing";
}

ForceError force_error(const ReplayTrace& run, const ReplayTrace& reference) {
  ForceError e;
  if (run.ticks() == 0 || reference.ticks() == 0) return {kNaN, kNaN, kNaN, 0};
  constexpr double eps = 1e-9;  // s: tick times computed the same way agree to far below this
  std::vector<double> d;
  d.reserve(reference.ticks());
  std::size_t i = 0;  // the run's tick at or before t
  for (std::size_t j = 0; j < reference.ticks(); ++j) {
    const double t = reference.t[j];
    if (t < run.t.front() - eps || t > run.t.back() + eps) continue;
    while (i + 1 < run.ticks() && run.t[i + 1] <= t + eps) ++i;
    d.push_back(norm(run.force[i] - reference.force[j]));
  }
  if (d.empty()) return {kNaN, kNaN, kNaN, 0};
  double sq = 0;
  for (double x : d) {
    sq += x * x;
    e.max = std::max(e.max, x);
    if (std::isnan(x)) e.max = x;
  }
  e.rms = std::sqrt(sq / static_cast<double>(d.size()));
  e.p999 = percentile(d, 99.9);
  e.ticks = d.size();
  return e;
}

std::size_t CsvTable::column(const std::string& name, const std::string& file) const {
  const auto it = std::find(header.begin(), header.end(), name);
  if (it == header.end()) throw InputError(file + ": no column '" + name + "'");
  return static_cast<std::size_t>(it - header.begin());
}

std::string CsvTable::to_csv() const {
  std::string out;
  auto line = [&out](const std::vector<std::string>& fields) {
    for (std::size_t i = 0; i < fields.size(); ++i) {
      if (i) out += ',';
      const std::string& f = fields[i];
      if (f.find_first_of(",\"\r\n") == std::string::npos) {
        out += f;
        continue;
      }
      out += '"';
      for (char c : f) out += c == '"' ? std::string("\"\"") : std::string(1, c);
      out += '"';
    }
    out += '\n';
  };
  line(header);
  for (const auto& r : rows) line(r);
  return out;
}

CsvTable parse_csv(const std::string& text, const std::string& file) {
  std::vector<std::vector<std::string>> records;
  std::vector<std::size_t> lines;  // each record's first line
  std::vector<bool> cr_ended;      // each record ended by a CR with no LF after it
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false, any = false;
  std::size_t line = 1, record_line = 1, line_start = 0;
  // "FILE:LINE:COLUMN: field N" of the byte at i (columns in bytes from 1, as editors count ASCII).
  auto at = [&](std::size_t i) {
    return file + ":" + std::to_string(line) + ":" + std::to_string(i - line_start + 1) + ": field " +
           std::to_string(fields.size() + 1);
  };
  auto end_record = [&](bool cr) {
    fields.push_back(std::move(field));
    records.push_back(std::move(fields));
    lines.push_back(record_line);
    cr_ended.push_back(cr);
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        // The closing quote ends the field: a comma, a line end or the file's end follows (RFC 4180).
        if (i + 1 < text.size() && text[i + 1] != ',' && text[i + 1] != '\n' && text[i + 1] != '\r')
          throw InputError(at(i) + ": a quote inside a quoted field must be doubled (\"\")");
        quoted = false;
      } else {
        if (c == '\n') {
          ++line;
          line_start = i + 1;
        }
        field += c;
      }
      continue;
    }
    if (c == '"') {
      if (!field.empty())
        throw InputError(at(i) + ": a quote in a field that does not begin with one (quote the field and double the quote)");
      quoted = any = true;
    } else if (c == ',') {
      fields.push_back(std::move(field));
      field.clear();
      any = true;
    } else if (c == '\n' || c == '\r') {
      const bool lone_cr = c == '\r' && !(i + 1 < text.size() && text[i + 1] == '\n');
      if (!lone_cr && c == '\r') ++i;
      if (any || !field.empty()) end_record(lone_cr);
      field.clear();
      fields.clear();
      any = false;
      record_line = ++line;
      line_start = i + 1;
    } else {
      field += c;
      any = true;
    }
  }
  if (quoted) throw InputError(file + ":" + std::to_string(record_line) + ": a quoted field is not closed");
  if (any || !field.empty()) end_record(false);
  if (records.empty()) throw InputError(file + ": empty (expected a header line)");
  CsvTable t;
  t.header = std::move(records[0]);
  for (std::size_t r = 1; r < records.size(); ++r) {
    if (records[r].size() != t.header.size()) {
      // A CR alone ends a line (old Mac files): one inside an unquoted field splits its record.
      const bool cr = cr_ended[r] || cr_ended[r - 1];
      throw InputError(file + ":" + std::to_string(lines[r]) + ": " + std::to_string(records[r].size()) +
                       " fields, the header has " + std::to_string(t.header.size()) +
                       (cr ? " (a carriage return with no line feed after it ends a line here: one inside a field must "
                             "be quoted)"
                           : ""));
    }
    t.rows.push_back(std::move(records[r]));
  }
  return t;
}

namespace {

enum class ColumnKind { Text, Integer, Real };

/// A cell as a number (an empty cell: NaN); false when it is not one.
bool cell_number(const std::string& s, double& v) {
  if (s.empty()) {
    v = kNaN;
    return true;
  }
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size();
}

ColumnKind column_kind(const CsvTable& t, std::size_t c) {
  static const std::vector<std::string> text = {"id", "status", "scene", "recording", "backend", "baseline", "overrides",
                                                "error"};
  const std::string& name = t.header[c];
  if (std::find(text.begin(), text.end(), name) != text.end()) return ColumnKind::Text;
  if (name == "repetition" || name == "reference") return ColumnKind::Integer;
  if (name.rfind("set.", 0) == 0) {  // a scene key's values: numbers, or text (a method, a list)
    double v = 0;
    for (const auto& row : t.rows)
      if (!cell_number(row[c], v)) return ColumnKind::Text;
  }
  return ColumnKind::Real;
}

/// A run's output as the summary takes it. A replay whose numbers go wrong stops with an error and
/// writes no output (README: exit 4), so an output holding a NaN or an inf sample (as
/// compute_metrics counts them, in any dataset it reads: nonfinite_samples) is a failed run: one
/// rule for NaN and inf, where NaN gave an ok run with empty force errors and inf a failed one.
/// Throws InputError "OUT: non-finite samples (/haptic/force: 1): ..." (and load_replay's errors).
ReplayTrace read_run_output(const fs::path& out) {
  ReplayTrace trace = load_replay(out.string());
  if (const NonfiniteSamples bad = nonfinite_samples(trace); bad.count > 0) {
    std::string samples;
    for (const std::string& d : bad.datasets) samples += (samples.empty() ? "" : ", ") + d;
    throw InputError(out.string() + ": non-finite samples (" + samples +
                     "): the run's numbers went wrong; no force error or metric is taken from it");
  }
  return trace;
}

/// The error column of a pending row whose output the sweep runs again (redo_reason).
std::string redo_error(RunState state) {
  return std::string("to run again: ") + (state == RunState::Stale ? "its output was " : "a run ") + redo_reason(state);
}

}  // namespace

void write_summary_h5(const CsvTable& t, const std::string& path) {
  h5::AtomicFile out(path);
  h5::File& f = out.file();
  std::string columns;
  for (std::size_t c = 0; c < t.header.size(); ++c) {
    const std::string& name = t.header[c];
    columns += (c ? "\n" : "") + name;
    const std::size_t n = t.rows.size();
    switch (column_kind(t, c)) {
      case ColumnKind::Text: {
        std::vector<std::string> v(n);
        for (std::size_t r = 0; r < n; ++r) v[r] = t.rows[r][c];
        f.write_strings(name, v);
        break;
      }
      case ColumnKind::Integer:
      case ColumnKind::Real: {
        const bool integer = column_kind(t, c) == ColumnKind::Integer;
        std::vector<double> v(n);
        for (std::size_t r = 0; r < n; ++r)
          if (!cell_number(t.rows[r][c], v[r]) || (integer && !(v[r] == std::floor(v[r]))))
            throw InputError(path + ": row " + std::to_string(r + 1) + ", column '" + name + "': expected " +
                             (integer ? "a whole number" : "a number") + ", got '" + t.rows[r][c] + "'");
        if (integer) {
          std::vector<std::int64_t> w(v.begin(), v.end());
          f.write<std::int64_t>(name, w, {n});
        } else {
          f.write<double>(name, v, {n});
        }
        break;
      }
    }
  }
  f.set_attr("columns", columns);
  out.commit();
}

SweepSummary summarize_sweep(const SweepPlan& plan, const std::vector<SweepRun>& runs, const fs::path& dir) {
  SweepSummary s;
  CsvTable& t = s.table;
  // One column per scene key any run overrides, in the order they first appear.
  std::vector<std::string> keys;
  for (const SweepRun& r : runs)
    for (const auto& [k, v] : r.overrides)
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
  const std::vector<std::pair<std::string, double>> metric_names = metric_values(ForceMetrics{});
  t.header = kRunColumns;
  for (const std::string& k : keys) t.header.push_back("set." + k);
  t.header.insert(t.header.end(), kResultColumns.begin(), kResultColumns.end());
  for (const auto& [k, v] : metric_names) t.header.push_back(k);
  t.header.push_back("error");

  // Where each run stands (run_state, as the sweep decides what to run): an output the sweep
  // would run again (made from input files edited since, even during the sweep, against the
  // digests the plan read; another run's output under its name; one that does not open) is no
  // result: its row is pending, saying why, and no run is compared with such a reference.
  InputDigests digests(&plan);
  std::map<std::string, RunState> states;
  for (const SweepRun& r : runs) states[r.id] = run_state(dir, plan, r, digests);
  // Each reference read once: its trace, or why there is none (its own row says more).
  struct Reference {
    std::optional<ReplayTrace> trace;
    std::string missing;  ///< the error column of a run compared with it, when there is no trace
  };
  std::map<std::string, Reference> references;  // by id
  auto reference_of = [&](const SweepRun& r) -> const Reference& {
    auto it = references.find(r.reference_id);
    if (it == references.end()) {
      Reference ref;
      const std::string run = "no reference: its run " + r.reference_id;
      const auto at = std::find_if(runs.begin(), runs.end(), [&](const SweepRun& x) { return x.id == r.reference_id; });
      const RunState state = states[r.reference_id];
      if (at != runs.end() && state == RunState::Done) {
        try {
          ref.trace = read_run_output(run_output(dir, *at));
        } catch (const InputError& e) {
          ref.missing = run + " failed: " + e.what();
        }
      } else if (const std::string why = redo_reason(state); !why.empty()) {
        ref.missing = run + ", to run again: " + why;
      } else if (const std::string failure = at != runs.end() ? read_run_failure(dir, *at) : ""; !failure.empty()) {
        ref.missing = run + " failed: " + failure;
      } else {
        ref.missing = run + " has no output";
      }
      it = references.emplace(r.reference_id, std::move(ref)).first;
    }
    return it->second;
  };

  for (const SweepRun& r : runs) {
    std::vector<std::string> row = {r.id, "pending", plan.scenes[r.scene].name, r.recording.stem().string(), r.backend,
                                    std::to_string(r.repetition), r.reference ? "1" : "0",
                                    r.baseline ? plan.baseline_name : "", r.overrides_text()};
    for (const std::string& k : keys) {
      const auto it = r.overrides.find(k);
      row.push_back(it == r.overrides.end() ? "" : it->second);
    }
    std::vector<std::string> results(kResultColumns.size() + metric_names.size(), "");
    std::string error;
    const fs::path out = run_output(dir, r);
    const RunState state = states[r.id];
    if (const std::string why = redo_reason(state); !why.empty()) {
      error = redo_error(state);
      ++s.pending;
      ++s.redo;
    } else if (state == RunState::Done) {
      try {
        const ReplayTrace trace = read_run_output(out);
        const ForceMetrics metrics = compute_metrics(trace);
        double wall = kNaN, virt = kNaN;
        {
          const h5::File f = h5::File::open_read(out.string());
          wall = f.attr_double("wall_s");
          virt = f.attr_double("virtual_s");
        }
        results[0] = cell(wall);
        results[1] = cell(virt);
        results[2] = cell(wall > 0 ? virt / wall : kNaN);
        if (const Reference& ref = reference_of(r); ref.trace) {
          const ForceError e = force_error(trace, *ref.trace);
          results[3] = cell(e.rms);
          results[4] = cell(e.max);
          results[5] = cell(e.p999);
          results[6] = std::to_string(e.ticks);
          if (e.ticks == 0) error = "no tick in common with the reference " + r.reference_id;
        } else {
          error = ref.missing;
        }
        // The regions' sizes: solver.active_region's per tick, solver.physical_region's per step (empty: off).
        auto mean = [](const std::vector<double>& a) {
          return a.empty() ? kNaN : std::accumulate(a.begin(), a.end(), 0.0) / static_cast<double>(a.size());
        };
        results[7] = cell(mean(trace.active));
        results[8] = cell(mean(trace.physical_awake));
        // By name: a run's metrics fill the columns a default ForceMetrics names, none beyond.
        for (const auto& [k, v] : metric_values(metrics)) {
          const auto at = std::find_if(metric_names.begin(), metric_names.end(), [&k](const auto& n) { return n.first == k; });
          if (at != metric_names.end())
            results[kResultColumns.size() + static_cast<std::size_t>(at - metric_names.begin())] = cell(v);
        }
        // A value the report would refuse (a real-time factor of inf from a wall time of 1e-320 s):
        // the run failed, saying which, rather than a summary its own report cannot read.
        for (std::size_t c = 0; c < results.size(); ++c) {
          const std::string& name = c < kResultColumns.size() ? kResultColumns[c] : metric_names[c - kResultColumns.size()].first;
          if (const std::string refused = report_cell_problem(name, results[c]); !refused.empty())
            throw InputError(out.string() + ": column '" + name + "' would be '" + results[c] +
                             "' where `ebh sweep report` takes " + refused);
        }
        row[1] = "ok";
        ++s.ok;
      } catch (const InputError& e) {
        row[1] = "failed";
        error = e.what();
        ++s.failed;
      }
    } else if (std::string failure = read_run_failure(dir, r); !failure.empty()) {
      row[1] = "failed";
      error = failure;
      ++s.failed;
    } else {
      ++s.pending;
    }
    row.insert(row.end(), results.begin(), results.end());
    row.push_back(error);
    t.rows.push_back(std::move(row));
  }
  return s;
}

std::vector<OutdatedRow> outdated_ok_rows(const SweepPlan& plan, const std::vector<SweepRun>& runs, const CsvTable& summary,
                                          const fs::path& dir) {
  std::vector<OutdatedRow> out;
  const auto id = std::find(summary.header.begin(), summary.header.end(), "id");
  const auto status = std::find(summary.header.begin(), summary.header.end(), "status");
  if (id == summary.header.end() || status == summary.header.end()) return out;
  const auto c_id = static_cast<std::size_t>(id - summary.header.begin());
  const auto c_status = static_cast<std::size_t>(status - summary.header.begin());
  std::map<std::string, const SweepRun*> by_id;
  for (const SweepRun& r : runs) by_id.emplace(r.id, &r);
  InputDigests digests(&plan);
  for (std::size_t row = 0; row < summary.rows.size(); ++row) {
    const std::vector<std::string>& cells = summary.rows[row];
    if (cells.size() <= std::max(c_id, c_status) || cells[c_status] != "ok") continue;
    const auto run = by_id.find(cells[c_id]);
    if (run == by_id.end()) continue;  // no run of this plan: the report takes the row as it is
    const RunState state = run_state(dir, plan, *run->second, digests);
    if (state == RunState::Done) continue;
    const std::string why = state == RunState::Missing
                                ? "to run again: its output " + run_output(dir, *run->second).string() +
                                      " is not there (deleted since the summary was written)"
                                : redo_error(state);
    out.push_back({row, run->second, why});
  }
  return out;
}

}  // namespace ebh
