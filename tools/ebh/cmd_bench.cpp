// `ebh bench sizes`: the cost of a replay against the physical mesh's size (bench/size_bench.hpp):
// a text table (JSON with --json) and a log-log plot of each cost against the tet count with the
// slope of its least-squares line.
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "bench/size_bench.hpp"
#include "command.hpp"
#include "core/error.hpp"
#include "io/json.hpp"
#include "io/paths.hpp"
#include "options.hpp"
#include "render/plot.hpp"
#include "render/text.hpp"
#include "replay_common.hpp"
#include "scene/scene.hpp"
#include "scene/scene_refine.hpp"
#include "schedule/replay_output.hpp"
#include "table1_columns.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif

namespace ebh::cli {
namespace {

struct SizesArgs {
  std::string scene = "tube", recording, levels = "0-2", backend = "cpu", mode = "async", plot;
  std::optional<double> start;
  double seconds = 1.0;
  std::int64_t max_tets = kMaxRefinedTets;
  std::vector<std::string> overrides;
  bool keep_virtual = false;
  bool json = false;
};

/// "A-B" or "N" -> (first, last); an InputError naming --levels otherwise.
/// Digits only (no sign, blank or exponent; one past int's range fails rather than wrapping).
std::pair<int, int> parse_levels(const std::string& text) {
  const auto level = [](std::string_view digits, int& out) {
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string_view::npos) return false;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), out);
    return ec == std::errc() && end == digits.data() + digits.size();
  };
  const std::string_view t = text;
  const std::size_t dash = t.find('-');
  int a = -1, b = -1;
  const bool ok = dash == std::string_view::npos ? level(t, a) && level(t, b)
                                                 : level(t.substr(0, dash), a) && level(t.substr(dash + 1), b);
  if (!ok || b < a)
    throw InputError("--levels: expected FIRST-LAST (e.g. 0-3) or one level, levels >= 0, got '" + escape_unprintable(text) + "'");
  return {a, b};
}

std::string megabytes(std::int64_t bytes) {
  if (bytes < 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f", static_cast<double>(bytes) / 1e6);
  return buf;
}

std::string slope_text(double s) {
  if (std::isnan(s)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", s);
  return buf;
}

/// The slope of each cost (size_costs order) over the sizes.
std::vector<double> slopes(const std::vector<SizeResult>& sizes) {
  std::vector<double> tets, out;
  for (const SizeResult& r : sizes) tets.push_back(static_cast<double>(r.tets));
  for (const SizeCost& c : size_costs()) {
    std::vector<double> y;
    for (const SizeResult& r : sizes) y.push_back(c.value(r));
    out.push_back(log_log_slope(tets, y));
  }
  return out;
}

/// Each cost relative to its value at the smallest size, against tets, log-log: the slopes read
/// off one chart whatever the costs' units. Markers at the measured sizes, the fitted line through
/// them, the slope in the legend.
void write_sizes_plot(const std::vector<SizeResult>& sizes, const std::vector<double>& fitted, const std::string& title,
                      const std::string& path) {
  std::vector<double> xs, ys;
  for (const SizeResult& r : sizes) xs.push_back(static_cast<double>(r.tets));
  const std::vector<SizeCost>& costs = size_costs();
  std::vector<std::vector<double>> relative(costs.size());
  for (std::size_t c = 0; c < costs.size(); ++c) {
    const double base = costs[c].value(sizes.front());
    for (const SizeResult& r : sizes) {
      const double v = costs[c].value(r) / base;
      relative[c].push_back(v);
      if (std::isfinite(v) && v > 0) ys.push_back(v);
    }
  }
  constexpr int kScale = 2;
  Image img(1100, 680, kPlotWhite);
  const LogLogFrame f = draw_log_log_frame(img, LogAxis(xs), LogAxis(ys), 110, 330, 90, 80, "physical mesh tets",
                                           "cost relative to the smallest mesh", kScale);
  int legend_y = f.y1;
  for (std::size_t c = 0; c < costs.size(); ++c) {
    if (std::isnan(fitted[c])) continue;  // a cost this run does not have (device memory on the CPU)
    const Rgb colour = kPlotPalette[c % kPlotPaletteSize];
    // The fitted line log y = a + b log x through the points' mean, drawn over the measured range.
    double mx = 0, my = 0;
    int n = 0;
    for (std::size_t i = 0; i < sizes.size(); ++i)
      if (std::isfinite(relative[c][i]) && relative[c][i] > 0) {
        mx += std::log(xs[i]);
        my += std::log(relative[c][i]);
        ++n;
      }
    mx /= n;
    my /= n;
    auto line_at = [&](double x) { return std::exp(my + fitted[c] * (std::log(x) - mx)); };
    draw_line(img, f.px(xs.front()), f.py(line_at(xs.front())), f.px(xs.back()), f.py(line_at(xs.back())), colour, 2);
    for (std::size_t i = 0; i < sizes.size(); ++i)
      if (std::isfinite(relative[c][i]) && relative[c][i] > 0) draw_marker(img, f.px(xs[i]), f.py(relative[c][i]), colour, true);
    draw_marker(img, f.x1 + 30, legend_y + 7, colour, true);
    draw_text(img, f.x1 + 45, legend_y, costs[c].label, kPlotBlack, kScale);
    draw_text(img, f.x1 + 45, legend_y + 20, "slope " + slope_text(fitted[c]), kPlotBlack, kScale);
    legend_y += 50;
  }
  draw_text(img, f.x0, 15, title.substr(0, 80), kPlotBlack, kScale);
  write_png(path, img, {{"Title", "ebh bench sizes: " + title}});
}

/// What makes a size's costs other than a replay's at work: the inputs' warnings, a window in
/// which the tool never touched the tissue (the tick's costs are free motion's), and skipped
/// physical steps (left out of the step's costs).
void warn_size(const SizeResult& r) {
  for (const std::string& w : r.warnings) std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(w).c_str());
  if (r.contact_ticks == 0)
    std::fprintf(stderr,
                 "ebh: warning: level %d: the tool never touched the tissue in this window: the costs are free "
                 "motion's, not rendering's (choose --start and --seconds where it works)\n",
                 r.level);
  if (r.skipped_steps > 0)
    std::fprintf(stderr,
                 "ebh: warning: level %d: %lld of %lld physical steps were skipped (the mesh at rest: solver.sleep or "
                 "solver.physical_region); the step's costs are the %lld that ran\n",
                 r.level, static_cast<long long>(r.skipped_steps), static_cast<long long>(r.steps),
                 static_cast<long long>(r.steps - r.skipped_steps));
}

void print_size_line(const SizeResult& r) {
  warn_size(r);
  std::printf("%5d %10lld %9lld %8lld %9.3f %9.3f %9.4f %9.4f %9.3f %8s %9s\n", r.level, static_cast<long long>(r.tets),
              static_cast<long long>(r.vertices), static_cast<long long>(r.virtual_vertices), 1e3 * r.physical_step.median,
              1e3 * r.physical_step.p99, 1e3 * r.haptic_tick.median, 1e3 * r.haptic_tick.p99, r.real_time_factor,
              megabytes(r.host_peak_bytes).c_str(), megabytes(r.device_peak_bytes).c_str());
  std::fflush(stdout);
}

void run_sizes(const SizesArgs& a) {
  check_backend(a.backend);
  SizeBenchOptions o;
  o.scene = a.scene;
  std::tie(o.first_level, o.last_level) = parse_levels(a.levels);
  // A scene that is missing is said first, not that it has no default window.
  const std::filesystem::path scene_file = resolve_scene_path(a.scene);
  // A Table 1 scene given as its file (scenarios/tube.yaml) has the window of its name.
  Table1Window window = table1_window(a.scene.c_str());
  if (!window.recording) {
    const std::string stem = scene_file.stem().string();
    try {
      if (same_file(resolve_scene_path(stem).string(), scene_file.string())) window = table1_window(stem.c_str());
    } catch (const InputError&) {
      // no scene of that name: no default window
    }
  }
  if (!a.recording.empty()) {
    o.recording = a.recording;
  } else if (window.recording) {
    o.recording = window.recording;
  } else {
    // What is missing is the recording: a --start given is a time into it, and names none.
    throw InputError("--recording: missing, and scene '" + a.scene +
                     "' has no default recording (the Table 1 scenes have one: tube, gap, cholecystectomy, gynaecology "
                     "and their _forceps/_hook variants); give --recording" +
                     (a.start ? " (--start " + format_number(*a.start) + " is a time into it)"
                              : " and --start, where in it the tool meets the tissue (0 when left out)"));
  }
  o.start = a.start.value_or(a.recording.empty() && window.recording ? window.start : 0.0);
  o.seconds = a.seconds;
  o.mode = parse_mode(a.mode);
  o.backend = a.backend == "cuda" ? Backend::Cuda : Backend::Cpu;
  o.max_tets = a.max_tets;
  check_set_once(a.overrides);
  o.overrides = a.overrides;
  o.keep_virtual = a.keep_virtual;
  // A bad option, override or size: one line, before the heading.
  const SizeBenchWindow window_checked = check_size_bench(o);
  // A window past the recording's end measures what is left of it: said, and reported as measured.
  if (window_checked.seconds < o.seconds) {
    std::fprintf(stderr, "ebh: warning: %s: the recording ends %s s after --start; measuring those, not --seconds' %s s\n",
                 window_checked.recording.c_str(), format_number(window_checked.seconds).c_str(),
                 format_number(o.seconds).c_str());
    o.seconds = window_checked.seconds;
  }
  if (!a.plot.empty()) check_outputs({{a.plot, "the plot"}}, replay_input_files(o.scene, o.recording, o.overrides));
  std::string device = cpu_description();
#if EBH_HAVE_CUDA
  if (o.backend == Backend::Cuda) device = cuda_device_description() + " + " + device;
#endif
  char title[256];
  std::snprintf(title, sizeof title, "%s + %s from %g s, %g s, %s, %s", o.scene.c_str(), o.recording.c_str(), o.start,
                o.seconds, a.mode.c_str(), a.backend.c_str());
  std::string heading = title;
  for (const std::string& k : o.overrides) heading += ", " + k;
  if (o.keep_virtual) heading += ", virtual mesh kept";
  if (!a.json) {
    std::printf("ebh bench sizes: %s\n%s\n", heading.c_str(), device.c_str());
    std::printf("%5s %10s %9s %8s %9s %9s %9s %9s %9s %8s %9s\n", "level", "tets", "vertices", "virtual", "step ms",
                "step p99", "tick ms", "tick p99", "real time", "host MB", "device MB");
  }
  const std::vector<SizeResult> sizes = run_size_bench(o, a.json ? nullptr : print_size_line);
  const std::vector<double> fitted = slopes(sizes);
  const std::vector<SizeCost>& costs = size_costs();
  if (a.json) {
    Json j = Json::object();
    j.set("scene", o.scene);
    j.set("recording", o.recording);
    j.set("start_s", o.start);
    j.set("seconds", o.seconds);
    j.set("mode", a.mode);
    j.set("backend", a.backend);
    Json set = Json::array();
    for (const std::string& k : o.overrides) set.push(Json(k));
    j.set("overrides", std::move(set));
    j.set("keep_virtual", o.keep_virtual);
    j.set("device", device);
    Json rows = Json::array();
    for (const SizeResult& r : sizes) {
      Json e = Json::object();
      e.set("level", r.level);
      e.set("tets", static_cast<long long>(r.tets));
      e.set("vertices", static_cast<long long>(r.vertices));
      e.set("virtual_vertices", static_cast<long long>(r.virtual_vertices));
      auto stat = [](const TimeStats& s) {
        Json t = Json::object();
        t.set("median", s.median);
        t.set("p99", s.p99);
        return t;
      };
      e.set("physical_step_s", stat(r.physical_step));
      e.set("haptic_tick_s", stat(r.haptic_tick));
      e.set("ticks", static_cast<long long>(r.ticks));
      e.set("steps", static_cast<long long>(r.steps));
      e.set("skipped_steps", static_cast<long long>(r.skipped_steps));
      e.set("wall_s", r.wall_s);
      e.set("virtual_s", r.virtual_s);
      e.set("real_time_factor", r.real_time_factor);
      e.set("load_s", r.load_s);
      e.set("host_peak_bytes", static_cast<long long>(r.host_peak_bytes));
      e.set("host_peak_since_start", !r.host_peak_reset);
      e.set("device_peak_bytes", r.device_peak_bytes >= 0 ? Json(static_cast<long long>(r.device_peak_bytes)) : Json());
      e.set("contact_ticks", static_cast<long long>(r.contact_ticks));
      rows.push(std::move(e));
      warn_size(r);
    }
    j.set("sizes", std::move(rows));
    Json s = Json::object();
    for (std::size_t c = 0; c < costs.size(); ++c) s.set(costs[c].key, std::isnan(fitted[c]) ? Json() : Json(fitted[c]));
    j.set("slopes", std::move(s));
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::string line;
    for (std::size_t c = 0; c < costs.size(); ++c)
      if (!std::isnan(fitted[c]) || (sizes.size() < 2 && c + 1 < costs.size()))
        line += std::string(line.empty() ? "" : ", ") + costs[c].label + " " + slope_text(fitted[c]);
    std::printf("slope against tets (log-log least squares; 1 = linear): %s\n", line.c_str());
    for (const SizeResult& r : sizes)
      if (!r.host_peak_reset) {
        std::printf("host MB is the process's peak so far (this system refused to reset it between sizes)\n");
        break;
      }
  }
  if (!a.plot.empty()) {
    write_sizes_plot(sizes, fitted, heading, a.plot);
    if (!a.json) std::printf("%s: the costs against tets\n", a.plot.c_str());
  }
}

void setup(CLI::App& root) {
  CLI::App* bench = root.add_subcommand("bench", "Benchmarks of the whole replay");
  bench->require_subcommand(1);
  auto args = std::make_shared<SizesArgs>();
  CLI::App* c = bench->add_subcommand(
      "sizes", "Physical step, haptic tick, real-time factor and memory as the physical mesh is refined (8x the tets a level)");
  c->add_option("--scene", args->scene, "scene name or path (default tube)");
  c->add_option("--levels", args->levels, "refinement levels FIRST-LAST or one level (default 0-2; 0 is the scene as it is)");
  c->add_option("--recording", args->recording,
                "recording to replay (default: the scene's Table 1 recording, e.g. tube_insert for tube)");
  c->add_option("--start", args->start, "seconds into the recording (default: the Table 1 window's start, else 0)")
      ->check(finite_number(0, kNoUpperLimit));
  c->add_option("--seconds", args->seconds, "seconds of the recording replayed at each size (default 1)")
      ->check(finite_number(0, 3600, true, "s"));
  c->add_option("--mode", args->mode, "async (default) or lockstep");
  c->add_option("--backend", args->backend, "cpu (default) or cuda");
  c->add_option("--max-tets", args->max_tets,
                "refuse sizes above this many tets (default " + std::to_string(kMaxRefinedTets) + ")")
      ->check(ebh::cli::whole_number(1, std::numeric_limits<std::int64_t>::max()));
  c->add_option("--plot", args->plot, "also draw the costs against tets, log-log, into this PNG file");
  c->add_option("--set", args->overrides,
                "Override a scene key at every size: --set solver.active_region=0.001 (repeatable)");
  c->add_flag("--keep-virtual", args->keep_virtual,
              "refine only the physical mesh; the virtual mesh keeps the scene's resolution (as scene refine --keep-virtual)");
  c->add_flag("--json", args->json, "JSON output");
  c->callback([args] { run_sizes(*args); });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
