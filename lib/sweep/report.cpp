#include "sweep/report.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>
#include <tuple>

#include "core/error.hpp"

namespace ebh {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double median(std::vector<double> v) {
  std::erase_if(v, [](double x) { return std::isnan(x); });
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string fmt(double v, const char* f = "%.4g") {
  if (std::isnan(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

bool ascii_alnum(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }

/// Text of the summary (a scene's, recording's or baseline's name, overrides, an error) in the
/// report as written, not as Markdown or HTML: each character a viewer could take for syntax is
/// backslash-escaped (CommonMark escapes any ASCII punctuation so): a tag, comment or autolink
/// (<), an entity (&), a link or image ("](", the only bracket that makes one: a line of the
/// report never begins with a name, so no link definition can), emphasis and strikethrough (*, ~,
/// and _ but between two letters or digits, where it opens and closes nothing: tube_insert), a
/// code span (`), math ($), a backslash itself, and the bar that ends a table's cell. Plain names
/// (tube_insert, solver.virtual_iterations=2, gravity=[0, 0, -9.81]) stay as they are. Then
/// unprintable bytes as \xNN (escape_unprintable): a line break would end a heading or a row.
std::string md(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    const bool syntax =
        std::string_view("\\`*~$|<>&").find(c) != std::string_view::npos ||
        (c == ']' && i + 1 < s.size() && s[i + 1] == '(') ||
        (c == '_' && !(i > 0 && i + 1 < s.size() && ascii_alnum(s[i - 1]) && ascii_alnum(s[i + 1])));
    if (syntax) out += '\\';
    out += c;
  }
  return escape_unprintable(out);
}

}  // namespace

std::vector<bool> pareto_front(const std::vector<std::pair<double, double>>& points) {
  std::vector<bool> front(points.size(), false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto [xi, yi] = points[i];
    if (std::isnan(xi) || std::isnan(yi)) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < points.size() && !dominated; ++j) {
      const auto [xj, yj] = points[j];
      dominated = j != i && xj <= xi && yj <= yi && (xj < xi || yj < yi);
    }
    front[i] = !dominated;
  }
  return front;
}

void check_min_haptic_hz(double hz) {
  if (!(hz >= 0 && std::isfinite(hz)))
    throw InputError("--min-haptic-hz " + shortest_number(hz) + ": expected a finite number >= 0 (haptic ticks per second)");
}

std::vector<ReportGroup> build_report(const CsvTable& t, const std::string& file, double min_haptic_hz) {
  check_min_haptic_hz(min_haptic_hz);
  if (t.rows.empty()) throw InputError(file + ": no runs (a header line and no rows; a sweep's summary has a row per run)");
  // A column named twice: which one holds the run's value is anyone's guess.
  for (std::size_t c = 0; c < t.header.size(); ++c)
    for (std::size_t d = 0; d < c; ++d)
      if (t.header[c] == t.header[d])
        throw InputError(file + ": line 1, column '" + t.header[c] + "': given twice (fields " + std::to_string(d + 1) +
                         " and " + std::to_string(c + 1) + ")");
  const std::size_t c_status = t.column("status", file), c_scene = t.column("scene", file),
                    c_rec = t.column("recording", file), c_backend = t.column("backend", file),
                    c_ref = t.column("reference", file), c_over = t.column("overrides", file),
                    c_wall = t.column("wall_s", file), c_rtf = t.column("real_time_factor", file),
                    c_rms = t.column("force_error_rms_N", file), c_max = t.column("force_error_max_N", file),
                    c_p999 = t.column("force_error_p999_N", file);
  auto optional_column = [&t](const char* name) -> std::optional<std::size_t> {
    const auto it = std::find(t.header.begin(), t.header.end(), name);
    if (it == t.header.end()) return std::nullopt;
    return static_cast<std::size_t>(it - t.header.begin());
  };
  const auto c_id = optional_column("id"), c_error = optional_column("error"), c_baseline = optional_column("baseline"),
             c_residual = optional_column("timing.physical_residual_max"), c_hz = optional_column("haptic_hz"),
             c_rate = optional_column("whole.max_force_rate_N_per_s"), c_active = optional_column("active_vertices_mean"),
             c_awake = optional_column("awake_vertices_mean"), c_contact = optional_column("contact_fraction");
  auto number = [&](std::size_t row, std::size_t col) {
    const std::string& s = t.rows[row][col];
    if (s.empty()) return kNaN;
    double v = 0;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size())
      throw InputError(file + ": row " + std::to_string(row + 2) + ", column '" + t.header[col] + "': expected a number, got '" +
                       s + "'");
    return v;
  };

  std::vector<std::size_t> checked = {c_wall};  // an ok row's wall time, then its measures present
  for (const std::string& name : kReportMeasureColumns)
    if (const auto c = optional_column(name.c_str())) checked.push_back(*c);

  using Key = std::tuple<std::string, std::string, std::string>;  // scene, recording, backend
  std::vector<Key> order;
  std::map<Key, ReportGroup> groups;
  std::map<std::pair<std::string, std::string>, std::string> references;  // (scene, recording) -> overrides
  std::map<Key, std::map<std::string, std::vector<std::size_t>>> rows_of;  // group -> overrides -> ok rows
  std::map<Key, std::vector<std::string>> config_order;
  std::map<Key, std::pair<std::string, std::size_t>> baseline_names;  // group -> its baseline's name and first row
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const auto& row = t.rows[r];
    const Key key{row[c_scene], row[c_rec], row[c_backend]};
    if (!groups.count(key)) {
      order.push_back(key);
      groups[key] = ReportGroup{row[c_scene], row[c_rec], row[c_backend], min_haptic_hz, "", {}, {}, 0, {}, "", ""};
    }
    ReportGroup& g = groups[key];
    if (row[c_ref] != "0" && row[c_ref] != "1")
      throw InputError(file + ": row " + std::to_string(r + 2) + ", column 'reference': expected 0 or 1, got '" + row[c_ref] + "'");
    if (row[c_ref] == "1") {
      // One reference per scene and recording (its repetitions alike): a summary edited by hand
      // could hold two, and the errors would be against either.
      const std::string ref = row[c_over] + " (" + row[c_backend] + ")";
      const auto [it, added] = references.emplace(std::pair{row[c_scene], row[c_rec]}, ref);
      if (!added && it->second != ref)
        throw InputError(file + ": row " + std::to_string(r + 2) + ", column 'reference': a second reference for " +
                         row[c_scene] + " + " + row[c_rec] + " (" + ref + "; the first: " + it->second + ")");
    }
    // One baseline per group (a plan names one): a summary edited by hand could hold two, and the
    // goal would be against either.
    if (c_baseline && !row[*c_baseline].empty()) {
      const auto [it, added] = baseline_names.emplace(key, std::pair{row[*c_baseline], r});
      if (!added && it->second.first != row[*c_baseline])
        throw InputError(file + ": row " + std::to_string(r + 2) + ", column 'baseline': a second baseline '" +
                         row[*c_baseline] + "' for " + row[c_scene] + " + " + row[c_rec] + " on " + row[c_backend] +
                         " (the first: '" + it->second.first + "', row " + std::to_string(it->second.second + 2) + ")");
    }
    const std::string& status = row[c_status];
    if (status == "ok") {
      // The run's wall time, and its measures: empty (not measured: no reference, no region), else
      // what a replay can give, a finite number >= 0 (a negative or infinite error would lead or
      // leave the front). The summary's writer holds its rows to the same (report_cell_problem).
      for (const std::size_t c : checked) {
        (void)number(r, c);  // text: "expected a number"
        if (const std::string why = report_cell_problem(t.header[c], row[c]); !why.empty())
          throw InputError(file + ": row " + std::to_string(r + 2) + ", column '" + t.header[c] + "': expected " + why +
                           ", got '" + row[c] + "'");
      }
      auto& configs = rows_of[key];
      if (!configs.count(row[c_over])) config_order[key].push_back(row[c_over]);
      configs[row[c_over]].push_back(r);
    } else if (status == "failed") {
      g.failed.push_back((c_id ? row[*c_id] + " " : "") + row[c_over] + ": " + (c_error ? row[*c_error] : "failed"));
    } else if (status == "pending") {
      ++g.pending;
      if (c_error && !row[*c_error].empty())  // an output the sweep runs again (summarize_sweep)
        g.redo.push_back((c_id ? row[*c_id] + " " : "") + row[c_over] + ": " + row[*c_error]);
    } else {
      throw InputError(file + ": row " + std::to_string(r + 2) + ", column 'status': expected ok, failed or pending, got '" +
                       status + "'");
    }
  }

  std::vector<ReportGroup> out;
  for (const Key& key : order) {
    ReportGroup g = std::move(groups[key]);
    const auto ref = references.find({g.scene, g.recording});
    if (ref != references.end()) g.reference = ref->second;
    for (const std::string& overrides : config_order[key]) {
      const std::vector<std::size_t>& rows = rows_of[key][overrides];
      auto med = [&](std::optional<std::size_t> col) {
        if (!col) return kNaN;
        std::vector<double> v;
        for (std::size_t r : rows) v.push_back(number(r, *col));
        return median(v);
      };
      ReportPoint p;
      p.overrides = overrides;
      p.reference = std::any_of(rows.begin(), rows.end(), [&](std::size_t r) { return t.rows[r][c_ref] == "1"; });
      if (c_baseline)
        for (std::size_t r : rows)
          if (!t.rows[r][*c_baseline].empty()) p.baseline = t.rows[r][*c_baseline];
      p.runs = rows.size();
      p.wall_s = med(c_wall);
      p.real_time_factor = med(c_rtf);
      p.error_rms = med(c_rms);
      p.error_max = med(c_max);
      p.error_p999 = med(c_p999);
      p.residual_max = med(c_residual);
      p.max_force_rate = med(c_rate);
      p.haptic_hz = med(c_hz);
      p.active_mean = med(c_active);
      p.awake_mean = med(c_awake);
      p.contact_fraction = med(c_contact);
      p.below_rate = p.haptic_hz < min_haptic_hz;  // false for NaN (not in the summary)
      g.points.push_back(p);
    }
    std::vector<std::pair<double, double>> xy;
    for (const ReportPoint& p : g.points) xy.emplace_back(p.reference || p.below_rate ? kNaN : p.wall_s, p.error_rms);
    const std::vector<bool> front = pareto_front(xy);
    for (std::size_t i = 0; i < g.points.size(); ++i) g.points[i].front = front[i];
    std::stable_sort(g.points.begin(), g.points.end(), [](const ReportPoint& a, const ReportPoint& b) {
      return a.wall_s < b.wall_s || (std::isnan(b.wall_s) && !std::isnan(a.wall_s));
    });
    if (const auto named = baseline_names.find(key); named != baseline_names.end()) g.baseline = named->second.first;
    // A baseline that gives no comparison is said, with why: none of its runs ok, or their force
    // errors empty (their error column says why: the reference failed, say).
    if (!g.baseline.empty() && !baseline_goal(g)) {
      const auto b = std::find_if(g.points.begin(), g.points.end(), [](const ReportPoint& p) { return !p.baseline.empty(); });
      if (b == g.points.end()) {
        std::size_t failed = 0, pending = 0;
        for (const auto& row : t.rows)
          if (Key{row[c_scene], row[c_rec], row[c_backend]} == key && !row[*c_baseline].empty()) {
            failed += row[c_status] == "failed";
            pending += row[c_status] == "pending";
          }
        g.no_baseline_goal = "none of its runs is ok (" + std::to_string(failed) + " failed, " + std::to_string(pending) +
                             " not run yet)";
      } else {
        std::string why;
        for (const std::size_t r : rows_of[key][b->overrides])
          if (c_error && !t.rows[r][*c_error].empty()) {
            why = t.rows[r][*c_error];
            break;
          }
        g.no_baseline_goal = std::string(std::isnan(b->error_rms) ? "its runs have no force error" : "its runs have no wall time") +
                             (why.empty() ? "" : ": " + why);
      }
    }
    out.push_back(std::move(g));
  }
  return out;
}

std::optional<BaselineGoal> baseline_goal(const ReportGroup& g) {
  const auto& P = g.points;
  const auto b = std::find_if(P.begin(), P.end(), [](const ReportPoint& p) { return !p.baseline.empty(); });
  if (b == P.end() || std::isnan(b->wall_s) || std::isnan(b->error_rms)) return std::nullopt;
  BaselineGoal goal;
  goal.baseline = goal.fastest = goal.most_accurate = static_cast<std::size_t>(b - P.begin());
  for (std::size_t i = 0; i < P.size(); ++i) {
    const ReportPoint& p = P[i];
    // A configuration with no error beyond round-off renders the reference's forces: it is the
    // reference in effect (an override that changes nothing, a k_con below surface contact's
    // floor: 4e-15 N), not 1e12 times more accurate, and its time is the reference's give or take noise.
    const bool same_as_reference = p.error_rms <= kSameForceN && b->error_rms > kSameForceN;
    if ((p.reference || p.below_rate || same_as_reference) && p.baseline.empty()) continue;
    if (p.error_rms <= b->error_rms && p.wall_s < P[goal.fastest].wall_s) goal.fastest = i;
    if (p.wall_s <= b->wall_s && p.error_rms < P[goal.most_accurate].error_rms) goal.most_accurate = i;
  }
  goal.speedup = b->wall_s / P[goal.fastest].wall_s;
  // Both exact (a window where the tool never touches: every force 0) is no gain: 1x, not 0/0 taken
  // for an infinite one that met the goal.
  const double best = P[goal.most_accurate].error_rms;
  goal.error_ratio = best > 0 ? b->error_rms / best : b->error_rms > 0 ? std::numeric_limits<double>::infinity() : 1.0;
  return goal;
}

namespace {

/// Whether a candidate's physical solve the baseline's leaves far behind: its max physical
/// residual over kLooserSolve times the baseline's. Its speed may then come from an unconverged
/// physical mesh (fewer fixed iterations) rather than from a better method.
bool less_converged(const ReportPoint& p, const ReportPoint& b) {
  return b.residual_max > 0 && p.residual_max > kLooserSolve * b.residual_max;
}

/// What the comparison says beside a less converged candidate ("" for another).
std::string looser_solve(const ReportPoint& p, const ReportPoint& b) {
  if (!less_converged(p, b)) return "";
  return " (its physical solve is less converged: max residual " + fmt(p.residual_max) + " mesh weights, " +
         fmt(p.residual_max / b.residual_max, "%.2g") + "x the baseline's)";
}

}  // namespace

std::string report_markdown(const std::vector<ReportGroup>& groups) {
  std::ostringstream o;
  o << "# Run time against force error\n\n"
       "Force error: |F - F_ref| per reference tick against the reference replay of the same scene and recording. Front: the configurations that no other one beats on both wall time and RMS error. Max force rate: the rendered force's largest change per second (`ebh metrics`), which a configuration that follows the device faster raises.\n";
  if (!groups.empty() && groups.front().min_haptic_hz > 0)
    o << "\nConfigurations below " << fmt(groups.front().min_haptic_hz, "%g")
      << " haptic ticks per second (marked `< Hz`) are listed but are neither on the front nor candidates against the "
         "baseline.\n";
  for (const ReportGroup& g : groups) {
    o << "\n## " << md(g.scene) << " + " << md(g.recording) << ", " << md(g.backend) << "\n\n";
    o << "Reference: " << (g.reference.empty() ? "not in the summary" : md(g.reference)) << "\n\n";
    // A window in which no configuration's tool touched the tissue: every force is 0, and so is
    // every error; the comparison says nothing about the configurations.
    if (!g.points.empty() && std::all_of(g.points.begin(), g.points.end(), [](const ReportPoint& p) {
          return p.contact_fraction == 0;
        }))
      o << "**The tool never touched the tissue in this window** (contact_fraction 0 in every run): the errors "
           "below compare free motion; choose a window with contact (the plan's start and duration).\n\n";
    // The regions' sizes where a run of the group has one (solver.active_region, solver.physical_region).
    const bool regions = std::any_of(g.points.begin(), g.points.end(), [](const ReportPoint& p) {
      return !std::isnan(p.active_mean) || !std::isnan(p.awake_mean);
    });
    o << "| front | overrides | runs | wall (s) | real time | force error RMS (N) | max (N) | p99.9 (N) | max force rate "
         "(N/s) | max physical residual |"
      << (regions ? " vertices iterated (virtual / physical) |" : "") << "\n|---|---|---|---|---|---|---|---|---|---|"
      << (regions ? "---|" : "") << "\n";
    for (const ReportPoint& p : g.points) {
      o << "| " << (p.front ? "*" : p.reference ? "reference" : p.below_rate ? "< Hz" : "")
        << (p.baseline.empty() ? "" : " ") << md(p.baseline)  // (" " + md(): GCC 12 warns -Wrestrict there)
        << " | " << md(p.overrides) << " | " << p.runs << " | "
        << fmt(p.wall_s) << " | " << fmt(p.real_time_factor, "%.3gx") << " | " << fmt(p.error_rms) << " | "
        << fmt(p.error_max) << " | " << fmt(p.error_p999) << " | " << fmt(p.max_force_rate) << " | " << fmt(p.residual_max)
        << " |";
      if (regions) o << " " << fmt(p.active_mean, "%.0f") << " / " << fmt(p.awake_mean, "%.0f") << " |";
      o << "\n";
    }
    if (g.points.empty()) o << "| | (no finished run) | | | | | | | | |\n";
    if (const auto goal = baseline_goal(g)) {
      const ReportPoint &b = g.points[goal->baseline], &f = g.points[goal->fastest], &a = g.points[goal->most_accurate];
      // The baseline is no candidate against itself: where nothing beats it, that is said, not "1x".
      o << "\nAgainst the baseline " << md(b.baseline) << " (" << md(b.overrides) << ": " << fmt(b.wall_s) << " s, RMS error "
        << fmt(b.error_rms) << " N): ";
      if (goal->fastest == goal->baseline)
        o << "no configuration is faster at an RMS error <= " << fmt(b.error_rms) << " N";
      else
        o << "the fastest at an RMS error <= " << fmt(b.error_rms) << " N is " << md(f.overrides) << ", " << fmt(f.wall_s)
          << " s, **" << fmt(goal->speedup, "%.3g") << "x faster**" << looser_solve(f, b);
      if (goal->most_accurate == goal->baseline)
        o << "; no configuration is more accurate at a wall time <= " << fmt(b.wall_s) << " s";
      else
        o << "; the most accurate at a wall time <= " << fmt(b.wall_s) << " s is " << md(a.overrides) << ", "
          << fmt(a.error_rms) << " N, **" << fmt(goal->error_ratio, "%.3g") << "x lower error**" << looser_solve(a, b);
      o << ". 2x goal: " << (goal->met() ? "met" : "not met") << ".\n";
    } else if (!g.no_baseline_goal.empty()) {
      o << "\nAgainst the baseline " << md(g.baseline) << ": no comparison: " << md(g.no_baseline_goal) << ".\n";
    }
    for (const std::string& f : g.failed) o << "\nfailed: " << md(f) << "\n";
    if (g.pending) o << "\n" << g.pending << " run" << (g.pending == 1 ? "" : "s") << " not run yet\n";
    for (const std::string& f : g.redo) o << "\nnot run yet: " << md(f) << "\n";
  }
  // Per backend, on how many scene and recording pairs a configuration meets the 2x goal.
  std::map<std::string, std::pair<int, int>> goals;  // backend -> (met, compared)
  std::map<std::string, std::string> met_on, not_compared;
  for (const ReportGroup& g : groups) {
    if (!g.no_baseline_goal.empty()) {
      goals[g.backend];  // listed, with none compared
      not_compared[g.backend] += (not_compared[g.backend].empty() ? "" : ", ") + g.recording;
    }
    if (const auto goal = baseline_goal(g)) {
      auto& [met, compared] = goals[g.backend];
      ++compared;
      if (goal->met()) {
        ++met;
        const ReportPoint& b = g.points[goal->baseline];
        const bool loose = (!goal->faster() || less_converged(g.points[goal->fastest], b)) &&
                           (!goal->more_accurate() || less_converged(g.points[goal->most_accurate], b));
        met_on[g.backend] += (met_on[g.backend].empty() ? "" : ", ") + g.recording + (loose ? " [less converged]" : "");
      }
    }
  }
  if (!goals.empty()) {
    o << "\n## The 2x goal\n\n";
    for (const auto& [backend, n] : goals)
      o << "- " << md(backend) << ": met on " << n.first << " of " << n.second << " scene and recording pairs"
        << (met_on[backend].empty() ? "" : " (" + md(met_on[backend]) + ")")
        << (not_compared[backend].empty() ? ""
                                          : "; not compared on " + md(not_compared[backend]) +
                                                ", whose baseline gives no comparison (see its section)")
        << "\n";
  }
  return o.str();
}

}  // namespace ebh
