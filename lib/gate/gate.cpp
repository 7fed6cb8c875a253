#include "gate/gate.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <string_view>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "core/yaml_error.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "metrics/force_metrics.hpp"
#include "metrics/replay_trace.hpp"
#include "scene/scene.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/replay_output.hpp"

namespace ebh {
namespace {

/// Reads the baselines' YAML tree; every message names the file, the line and the dotted key
/// (yaml_key_error).
struct BaselinesReader {
  std::string file;

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& what) const {
    throw InputError(yaml_key_error(file, n, key, what));
  }

  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "expected a number, got " + yaml_shown(n));
    try {
      return n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, "expected a number, got " + yaml_shown(n));
    }
  }

  /// A band or a baseline metric: a finite number >= 0.
  double nonnegative(const YAML::Node& n, const std::string& key) const {
    const double v = number(n, key);
    if (!(std::isfinite(v) && v >= 0)) fail(n, key, "expected a finite number >= 0, got " + yaml_shown(n));
    return v;
  }

  bool boolean(const YAML::Node& n, const std::string& key) const {
    if (n.IsScalar() && (n.Scalar() == "true" || n.Scalar() == "false")) return n.Scalar() == "true";
    fail(n, key, "expected true or false, got " + yaml_shown(n));
  }

  /// Checks the keys of map `n` (yaml_map_entries: text keys among `known`, each once; a misspelt
  /// metric would otherwise go unchecked).
  void only_keys(const YAML::Node& n, const std::string& key, std::initializer_list<std::string_view> known) const {
    yaml_map_entries(n, key, known, [&](const YAML::Node& at, const std::string& k, const std::string& what) {
      fail(at, k, what);
    });
  }

  /// A string of UTF-8 text. A YAML file is UTF-8, and a case's name, scene and recording go back
  /// into it (--update) and into --json as they are: a byte of another encoding (Latin-1 from an
  /// old editor) is refused here, as a scene file's is.
  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "expected a string, got " + yaml_shown(n));
    const std::string& s = n.Scalar();
    if (const std::string byte = first_invalid_utf8_byte(s); !byte.empty())
      fail(n, key, "'" + s + "' holds byte " + byte + ", which is not UTF-8 text: save the file as UTF-8");
    return s;
  }
};

/// Each case's text in the baselines file (`lines`: the file's, each with its line end): from the
/// line of its '-' to the line before the next case's (the last case's: before the next top-level
/// key, or the end of the file), less the blank and comment lines that end it (a rewrite drops
/// those, as --update says). Empty where the cases are no block list whose every case starts on a
/// line of its own (`cases: [{...}, {...}]`): those are written anew.
std::vector<std::string> case_texts(const std::vector<std::string>& lines, const YAML::Node& root,
                                    const YAML::Node& cases) {
  if (cases.Style() == YAML::EmitterStyle::Flow) return {};
  std::vector<std::size_t> first;  // each case's first line, and the line after the last case's
  for (const YAML::Node& c : cases) {
    const int mark = c.Mark().line;
    if (mark < 0) return {};
    const auto line = static_cast<std::size_t>(mark);
    if (line >= lines.size() || (!first.empty() && line <= first.back())) return {};
    const std::size_t dash = lines[line].find_first_not_of(' ');
    if (dash == std::string::npos || lines[line].compare(dash, 2, "- ") != 0) return {};
    first.push_back(line);
  }
  std::size_t end = lines.size();
  for (auto it = root.begin(); it != root.end(); ++it) {
    const int mark = it->first.Mark().line;
    if (mark > static_cast<int>(first.back())) end = std::min(end, static_cast<std::size_t>(mark));
  }
  first.push_back(end);
  std::vector<std::string> out;
  for (std::size_t i = 0; i + 1 < first.size(); ++i) {
    std::size_t last = first[i + 1];
    while (last > first[i] + 1) {
      const std::string& text = lines[last - 1];
      const std::size_t at = text.find_first_not_of(" \t\r\n");
      if (at != std::string::npos && text[at] != '#') break;
      --last;
    }
    std::string text;
    for (std::size_t l = first[i]; l < last; ++l) text += lines[l];
    out.push_back(std::move(text));
  }
  return out;
}

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

}  // namespace

FileLock lock_gate_baselines(const std::string& path) {
  FileLock lock = FileLock::take(path, false, false);
  if (lock.status() == FileLock::Status::Busy) {
    std::fprintf(stderr, "ebh gate: %s: another ebh gate --update is writing it; waiting\n", path.c_str());
    std::fflush(stderr);
    lock = FileLock::take(path, false, true);
  }
  if (lock.status() == FileLock::Status::Unsupported)
    std::fprintf(stderr, "ebh: warning: %s: cannot lock the baselines (%s): a second ebh gate --update at once would lose one update\n",
                 path.c_str(), lock.error().c_str());
  return lock;
}

std::size_t remove_stale_gate_temporaries(const std::filesystem::path& tmp) {
  namespace fs = std::filesystem;
  std::size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(tmp, ec), end; !ec && it != end; it.increment(ec)) {
    // ebh_gate_PID_XXXXXX (a case's folder), and an older ebh's ebh_gate_PID_CASE.h5 and its
    // temporary .ebh_gate_PID_CASE.h5.HOST.PID2.ebh-partial
    const std::string name = it->path().filename().string();
    const std::string tag = "ebh_gate_";
    const std::size_t at = name.rfind(tag, 1);
    if (at == std::string::npos || (at == 1 && name[0] != '.')) continue;
    const std::size_t digits = at + tag.size();
    std::size_t stop = digits;
    while (stop < name.size() && std::isdigit(static_cast<unsigned char>(name[stop]))) ++stop;
    if (stop == digits || stop >= name.size() || name[stop] != '_') continue;
    const long pid = std::strtol(name.c_str() + digits, nullptr, 10);
    if (pid <= 0 || pid == static_cast<long>(::getpid()) || process_running(pid)) continue;
    struct stat st {};
    if (::lstat(it->path().c_str(), &st) != 0 || st.st_uid != ::geteuid()) continue;
    const bool folder = S_ISDIR(st.st_mode) && at == 0;
    const bool file = S_ISREG(st.st_mode) && (is_partial_output(name) || (name.size() > 3 && name.compare(name.size() - 3, 3, ".h5") == 0));
    if (!folder && !file) continue;  // a link, or a name of another kind: not the gate's
    std::error_code rm;
    if (folder ? fs::remove_all(it->path(), rm) > 0 : fs::remove(it->path(), rm)) ++removed;
  }
  return removed;
}

GateBaselines read_gate_baselines(const std::string& path) {
  check_input_file(path);
  YAML::Node root;
  try {
    root = only_yaml_document(YAML::LoadAllFromFile(path), path, "a gate baseline file");
  } catch (const YAML::BadFile&) {
    throw InputError(path + ": cannot read the gate baselines");
  } catch (const YAML::Exception& e) {
    throw InputError(yaml_parse_error(path, e));
  }
  GateBaselines b;
  std::vector<std::string> lines;  // the file's, each with its line end: the cases' text (case_texts)
  {
    // The comment lines: those before the first data line are the header; a comment on a data
    // line's end is not counted (a rewrite keeps it on a case it did not measure, drops it on one
    // it did; rare in these files).
    std::ifstream in(path);
    bool in_header = true;
    for (std::string line; std::getline(in, line);) {
      lines.push_back(line + "\n");
      const std::size_t first = line.find_first_not_of(" \t\r");
      const bool comment = first != std::string::npos && line[first] == '#';
      if (in_header && (comment || first == std::string::npos)) b.header += line + "\n";
      else if (comment) ++b.body_comments;
      else in_header = false;
    }
    // Blank lines after the last header comment belong to the layout, not the header.
    while (b.header.size() >= 2 && b.header[b.header.size() - 2] == '\n') b.header.pop_back();
    if (b.header.find('#') == std::string::npos) b.header.clear();
  }
  const BaselinesReader r{path};
  // A tag (`duration: !ms 300`) would be dropped without a word: refused, as every YAML reader does.
  yaml_refuse_tags_in(r.file, root);
  r.only_keys(root, "", {"generated_by", "bands", "cases"});
  if (root["generated_by"]) b.generated_by = r.text(root["generated_by"], "generated_by");
  if (const YAML::Node bands = root["bands"]) {
    r.only_keys(bands, "bands",
                {"relative", "abs_force_step", "abs_force_rate", "abs_peak_force", "abs_power", "abs_penetration",
                 "abs_boundary_ratio"});
    // A band left out keeps its default (GateBands).
    const auto band = [&](const char* key, double& value) {
      if (bands[key]) value = r.nonnegative(bands[key], std::string("bands.") + key);
    };
    band("relative", b.bands.relative);
    band("abs_force_step", b.bands.abs_force_step);
    band("abs_force_rate", b.bands.abs_force_rate);
    band("abs_peak_force", b.bands.abs_peak_force);
    band("abs_power", b.bands.abs_power);
    band("abs_penetration", b.bands.abs_penetration);
    band("abs_boundary_ratio", b.bands.abs_boundary_ratio);
    // Bands so wide that no regression can fail them: the gate would check only finiteness.
    if (b.bands.relative > 1)
      r.fail(bands["relative"], "bands.relative",
             bands["relative"].Scalar() + " lets a metric more than double and pass (at most 1; the bands absorb "
             "machines' floating-point differences, well under 0.1)");
    // The absolute bands well under what a haptic device renders (3.3 N for a Touch): with a
    // relative band of 1 on top, a band of a device's whole force (10 N, 1e4 N/s) passed a tissue a
    // hundred times stiffer, or one buzzing at the force limit. At most a third of a Touch's force on
    // the peak, a tenth of a newton a tick on the roughness (the baselines' 0.006-0.03 N; a buzz felt
    // at a few hundredths), a newton a tick on the rate, 2 mm of penetration (the baselines' 0.4-1.2
    // mm); the defaults are 2 mN, 5 N/s, 0.1 N and 0.2 mm.
    struct Ceiling {
      const char* key;
      double value, most;
      const char* what;
    };
    for (const Ceiling& c : {Ceiling{"abs_force_step", b.bands.abs_force_step, 0.1, "N a tick: a strong buzz"},
                             Ceiling{"abs_force_rate", b.bands.abs_force_rate, 1e3, "N/s: a newton within a 1 kHz tick"},
                             Ceiling{"abs_peak_force", b.bands.abs_peak_force, 1, "N: a third of a Touch's force"},
                             Ceiling{"abs_penetration", b.bands.abs_penetration, 0.002, "m: 2 mm, beyond the baselines' 1.2 mm"},
                             // power_above_30hz is a fraction of the force's power; the committed
                             // baselines sit at 2e-4 .. 0.07, a buzz users feel at a tenth and more
                             Ceiling{"abs_power", b.bands.abs_power, 0.1, "of the force's power above 30 Hz"},
                             // a ratio of 1 hides the physical frames; 2 more is a ripple at the physical rate
                             Ceiling{"abs_boundary_ratio", b.bands.abs_boundary_ratio, 1, "over the baseline's ratio"}})
      if (c.value > c.most)
        r.fail(bands[c.key], std::string("bands.") + c.key,
               bands[c.key].Scalar() + " passes every run (at most " + shown_number(c.most) + " " + c.what + ")");
  }
  const YAML::Node cases = root["cases"];
  if (!cases) r.fail(root, "cases", "missing: the file lists its cases under it");
  if (!cases.IsSequence()) r.fail(cases, "cases", "expected a list, got " + yaml_shown(cases));
  if (cases.size() == 0) r.fail(cases, "cases", "expected at least one case (a gate of none checks nothing)");
  const std::vector<std::string> texts = case_texts(lines, root, cases);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const YAML::Node c = cases[i];
    const std::string k = "cases[" + std::to_string(i) + "].";
    r.only_keys(c, k.substr(0, k.size() - 1),
                {"name", "scene", "recording", "start", "duration", "rms_force_step", "max_force_rate", "peak_force",
                 "power_above_30hz", "penetration_max", "boundary_step_ratio", "force_collapse"});
    for (const char* key : {"name", "scene", "recording", "start", "duration"})
      if (!c[key]) r.fail(c, k + key, "missing (a case gives name, scene, recording, start and duration)");
    GateCase g;
    g.name = r.text(c["name"], k + "name");
    // The name is what --case selects and what the verdict's lines start with.
    if (g.name.empty() || has_control_character(g.name))
      r.fail(c["name"], k + "name", "expected a name of printable characters, got '" + g.name + "'");
    for (const GateCase& other : b.cases)
      if (other.name == g.name) r.fail(c["name"], k + "name", "'" + g.name + "' names two cases");
    g.scene = r.text(c["scene"], k + "scene");
    g.recording = r.text(c["recording"], k + "recording");
    // A path relative to the baselines file, as in a sweep plan: the file works from any folder.
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    g.scene_file = data_reference_from(g.scene, folder);
    g.recording_file = data_reference_from(g.recording, folder);
    g.start = r.number(c["start"], k + "start");
    g.duration = r.number(c["duration"], k + "duration");
    // Said here, before any case runs; one tick of the case's scene is checked with the scene
    // (check_gate_case), and the start against the recording (replay_window).
    if (!(std::isfinite(g.duration) && g.duration > 0))
      r.fail(c["duration"], k + "duration",
             "expected a finite number of seconds > 0 (at least one haptic tick), got " + yaml_shown(c["duration"]));
    g.where = yaml_key_error(path, c, "", k.substr(0, k.size() - 1) + " (" + g.name + ")");
    if (!texts.empty()) g.text = texts[i];
    // A metric absent has no baseline yet; one given is a finite number >= 0 (a NaN baseline
    // would pass every comparison). The power above 30 Hz alone may be .nan: a window too short
    // for its spectrum has none, and the gate then compares none.
    auto metric = [&](const char* key) {
      return c[key] ? r.nonnegative(c[key], k + key) : std::numeric_limits<double>::quiet_NaN();
    };
    g.rms_force_step = metric("rms_force_step");
    g.max_force_rate = metric("max_force_rate");
    g.peak_force = metric("peak_force");
    g.power_above_30hz = c["power_above_30hz"] && std::isnan(r.number(c["power_above_30hz"], k + "power_above_30hz"))
                             ? std::numeric_limits<double>::quiet_NaN()
                             : metric("power_above_30hz");
    g.penetration_max = metric("penetration_max");
    // NaN where the window's steps are all 0 (a free tool): none to compare, as for the power.
    g.boundary_step_ratio =
        c["boundary_step_ratio"] && std::isnan(r.number(c["boundary_step_ratio"], k + "boundary_step_ratio"))
            ? std::numeric_limits<double>::quiet_NaN()
            : metric("boundary_step_ratio");
    if (c["force_collapse"]) g.force_collapse = r.boolean(c["force_collapse"], k + "force_collapse");
    b.cases.push_back(g);
  }
  return b;
}

namespace {

/// A case as write_gate_baselines writes one from its values: a YAML flow map, on one line. Its
/// numbers, as the bands', are the shortest text that reads back as the same double (shortest_text:
/// 0.3, not yaml-cpp's 17 digits 0.29999999999999999).
std::string case_yaml(const GateCase& c) {
  YAML::Emitter y;
  y << YAML::Flow << YAML::BeginMap;
  y << YAML::Key << "name" << YAML::Value << c.name;
  y << YAML::Key << "scene" << YAML::Value << c.scene;
  y << YAML::Key << "recording" << YAML::Value << c.recording;
  y << YAML::Key << "start" << YAML::Value << shortest_text(c.start);
  y << YAML::Key << "duration" << YAML::Value << shortest_text(c.duration);
  // A metric without a value (NaN: no baseline yet, or none in the window, as the power above
  // 30 Hz of a window too short for a spectrum) is left out: the reader takes it as NaN, and a
  // case that had no such key gets none.
  auto metric = [&y](const char* key, double value) {
    if (!std::isnan(value)) y << YAML::Key << key << YAML::Value << shortest_text(value);
  };
  metric("rms_force_step", c.rms_force_step);
  metric("max_force_rate", c.max_force_rate);
  metric("peak_force", c.peak_force);
  metric("power_above_30hz", c.power_above_30hz);
  metric("penetration_max", c.penetration_max);
  metric("boundary_step_ratio", c.boundary_step_ratio);
  if (c.force_collapse) y << YAML::Key << "force_collapse" << YAML::Value << *c.force_collapse;
  y << YAML::EndMap;
  return y.c_str();
}

}  // namespace

void write_gate_baselines(const std::string& path, const GateBaselines& b) {
  YAML::Emitter y;
  y << YAML::BeginMap;
  y << YAML::Key << "generated_by" << YAML::Value << b.generated_by;
  y << YAML::Key << "bands" << YAML::Value << YAML::Flow << YAML::BeginMap;
  y << YAML::Key << "relative" << YAML::Value << shortest_text(b.bands.relative);
  y << YAML::Key << "abs_force_step" << YAML::Value << shortest_text(b.bands.abs_force_step);
  y << YAML::Key << "abs_force_rate" << YAML::Value << shortest_text(b.bands.abs_force_rate);
  y << YAML::Key << "abs_peak_force" << YAML::Value << shortest_text(b.bands.abs_peak_force);
  y << YAML::Key << "abs_power" << YAML::Value << shortest_text(b.bands.abs_power);
  y << YAML::Key << "abs_penetration" << YAML::Value << shortest_text(b.bands.abs_penetration);
  y << YAML::Key << "abs_boundary_ratio" << YAML::Value << shortest_text(b.bands.abs_boundary_ratio);
  y << YAML::EndMap;
  y << YAML::EndMap;
  const std::string header = !b.header.empty() ? b.header
                                                : "# Force-smoothness gate baselines (ebh gate). Regenerate with\n"
                                                  "# `ebh gate --baselines FILE --update`; do not edit the metrics by hand.\n";
  // A case with its text is written as it (GateCase::text); one written from its values is
  // indented as those (the entries of a YAML list share their indentation).
  std::string indent = "  ";
  for (const GateCase& c : b.cases)
    if (!c.text.empty()) {
      indent = c.text.substr(0, c.text.find('-'));
      break;
    }
  const auto file_text = [&](bool keep_texts) {
    std::string text = header + y.c_str() + "\ncases:\n";
    for (const GateCase& c : b.cases) text += keep_texts && !c.text.empty() ? c.text : indent + "- " + case_yaml(c) + "\n";
    return text;
  };
  std::string text = file_text(true);
  // A kept text that named an anchor of a part written anew (`*a` of a case measured again) no
  // longer reads: then every case is written from its values.
  try {
    (void)YAML::Load(text);
  } catch (const YAML::Exception&) {
    text = file_text(false);
  }
  write_file_atomically(path, text);
}

void check_gate_case(const GateCase& c, const std::vector<std::string>& overrides) {
  double haptic_hz = 0;
  RecordingFile rec;
  try {
    (void)replay_input_files(c.scene_file, c.recording_file, overrides);
    haptic_hz = load_scene_spec(resolve_scene_path(c.scene_file), overrides).haptic_hz;
    rec = read_replay_recording(c.recording_file, RecordingWindow{c.start, c.duration});  // as run_gate_case reads it
  } catch (const InputError& e) {
    throw InputError(c.where + ": " + e.what());
  }
  // The window as run_gate_case takes it, at the rate its world gets (1 / haptic_hz).
  (void)replay_window(c.start, c.duration, rec.recording.duration(), 1.0 / haptic_hz, rec.path, c.where + ": start",
                      c.where + ": duration");
}

GateResult run_gate_case(const GateCase& c, const std::vector<std::string>& overrides) {
  const std::string key = c.where.empty() ? "case '" + c.name + "'" : c.where;
  const LoadedReplay in = [&] {
    try {
      return load_replay_inputs(c.scene_file, c.recording_file, overrides, std::nullopt, std::nullopt, false,
                                Backend::Cpu, {}, RecordingWindow{c.start, c.duration});
    } catch (const InputError& e) {
      throw InputError(key + ": " + e.what());
    }
  }();
  const double dur = replay_window(c.start, c.duration, in.recording.duration(), in.world->h_haptic, in.recording_path,
                                   key + ": start", key + ": duration");
  ReplayOptions opt;
  opt.mode = Mode::Async;
  opt.start = c.start;
  opt.duration = c.duration;
  TemporaryFolder folder("ebh_gate_" + std::to_string(::getpid()) + "_", "the gate's temporary folder");
  const auto tmp = folder.file("replay.h5");
  ForceMetrics m;
  GateResult r;
  r.measured = c;
  r.measured.text.clear();  // its metrics are this run's, not the file's
  r.warnings = in.warnings;
  // A case whose window starts in a press measures the tissue at rest around the tool, not the press.
  if (std::string w = window_start_warning(in, c.start, "start"); !w.empty()) r.warnings.push_back(std::move(w));
  if (dur < c.duration)
    r.warnings.push_back(in.recording_path + ": the recording ends " + shown_number(dur) + " s after the start; " +
                         "measuring those, not the duration's " + shown_number(c.duration) + " s");
  try {
    ReplayMetadata meta;
    meta.recording = in.recording_path;
    meta.start = opt.start;
    meta.duration = opt.duration;
    meta.overrides = overrides;
    meta.threads = split_threads(opt.mode, opt.haptic_threads);
    check_replay_size(*in.world, dur, 0, in.recording_path, tmp.string());
    ReplayWriter writer(tmp.string(), *in.world, meta, tick_count(*in.world, dur), false);
    const ReplaySummary s = replay(*in.world, in.recording, opt, writer);
    // Stopped by a signal: the case, not the gate's temporary replay file, is what the user knows.
    if (s.stopped) throw InputError(c.where + ": interrupted; the gate stopped here, its baselines as they were");
    writer.commit(s);
    m = compute_metrics(load_replay(tmp.string()));
  } catch (const NumericalError& e) {  // the health checks stopped it: a failed case, not a failed gate run
    r.passed = false;
    r.stopped = true;
    r.failures.push_back(c.name + ": the replay stopped: " + e.what());
    return r;
  }
  r.measured.rms_force_step = m.whole.rms_force_step;
  r.measured.max_force_rate = m.whole.max_force_rate;
  r.measured.peak_force = m.whole.peak_force;
  r.measured.power_above_30hz = m.whole.power_above_30hz;
  r.measured.penetration_max = m.whole.penetration_max;
  r.measured.boundary_step_ratio = m.whole.boundary_step_ratio;
  r.measured.force_collapse = m.collapse.has_value();
  r.contact_warning = m.contact_warning;
  if (m.collapse)
    r.warnings.push_back(collapse_warning(*m.collapse, in.world->scene.spec.contact == ContactModel::Vertices, c.start));
  if (!m.finite) {
    r.passed = false;
    r.failures.push_back(c.name + ": non-finite values in the replay (" + std::to_string(m.nonfinite_count) +
                         " samples)");
  }
  return r;
}

void judge_gate_case(const GateCase& b, const GateBands& bands, GateResult& r) {
  if (r.stopped) return;  // no metrics to judge
  const GateCase& m = r.measured;
  auto fail = [&](const std::string& what) {
    r.passed = false;
    r.failures.push_back(b.name + ": " + what);
  };
  // A case with no baseline at all compares nothing: it must not read as a pass.
  if (std::isnan(b.rms_force_step) && std::isnan(b.max_force_rate) && std::isnan(b.peak_force) &&
      std::isnan(b.penetration_max) && std::isnan(b.power_above_30hz) && std::isnan(b.boundary_step_ratio) &&
      !b.force_collapse)
    return fail("no baseline metric to compare against (rms_force_step, max_force_rate, peak_force, "
                "penetration_max, power_above_30hz, boundary_step_ratio, force_collapse: `ebh gate --update` "
                "writes them)");
  for (const auto& [name, base] : {std::pair<const char*, double>{"rms_force_step", b.rms_force_step},
                                   {"max_force_rate", b.max_force_rate}, {"peak_force", b.peak_force},
                                   {"penetration_max", b.penetration_max}, {"power_above_30hz", b.power_above_30hz},
                                   {"boundary_step_ratio", b.boundary_step_ratio}})
    if (std::isnan(base)) r.unchecked.emplace_back(name);
  if (!b.force_collapse) r.unchecked.emplace_back("force_collapse");
  auto upper = [&](const char* metric, double got, double base, double abs) {
    const std::string name = gate_metric_label(metric);  // "rms_force_step [N]"
    if (!std::isfinite(got)) return fail(name + " is not finite");
    if (std::isnan(base)) return;  // no baseline for it yet
    const double limit = base * (1 + bands.relative) + abs;
    if (got > limit) fail(name + " " + fmt(got) + " above the band (baseline " + fmt(base) + ", limit " + fmt(limit) + ")");
  };
  upper("rms_force_step", m.rms_force_step, b.rms_force_step, bands.abs_force_step);
  upper("max_force_rate", m.max_force_rate, b.max_force_rate, bands.abs_force_rate);
  upper("penetration_max", m.penetration_max, b.penetration_max, bands.abs_penetration);
  // The spectral fraction (NaN for a window too short to analyse) and the frame-boundary ratio
  // (NaN where the force never changes): compared when both have one; a ratio of +inf (steps
  // only at frame boundaries) fails against a finite baseline.
  if (std::isfinite(b.power_above_30hz) && !std::isnan(m.power_above_30hz))
    upper("power_above_30hz", m.power_above_30hz, b.power_above_30hz, bands.abs_power);
  if (std::isfinite(b.boundary_step_ratio) && !std::isnan(m.boundary_step_ratio))
    upper("boundary_step_ratio", m.boundary_step_ratio, b.boundary_step_ratio, bands.abs_boundary_ratio);
  if (b.force_collapse == false && m.force_collapse == true)
    fail("force_collapse: the force collapsed in contact, which the baseline's did not (the warning below)");
  if (!std::isfinite(m.peak_force)) {
    fail("peak_force is not finite");
  } else if (std::isfinite(b.peak_force)) {
    // A factor either way: up to (1 + relative) times the baseline, down to 1 / (1 + relative) of it
    // (a band of +-relative let a force of half the baseline pass at relative 0.5).
    const double high = b.peak_force * (1 + bands.relative) + bands.abs_peak_force,
                 low = b.peak_force / (1 + bands.relative) - bands.abs_peak_force;
    if (m.peak_force > high || m.peak_force < low)
      fail(gate_metric_label("peak_force") + " " + fmt(m.peak_force) + " outside the band around " + fmt(b.peak_force) + " (" + fmt(low) +
           " .. " + fmt(high) + ")");
  }
}

namespace {

/// The gate's metrics: the baselines file's key, the JSON report's (with its unit, as `ebh metrics
/// --json`), and the unit the text output gives in brackets ("" for a ratio or a flag).
struct GateMetricName {
  const char* name;
  const char* json_key;
  const char* unit;
};
constexpr GateMetricName kGateMetricNames[] = {
    {"rms_force_step", "rms_force_step_N", "N"},   {"max_force_rate", "max_force_rate_N_per_s", "N/s"},
    {"peak_force", "peak_force_N", "N"},           {"power_above_30hz", "power_above_30hz", ""},
    {"penetration_max", "penetration_max_m", "m"}, {"boundary_step_ratio", "boundary_step_ratio", ""},
    {"force_collapse", "force_collapse", ""}};

const GateMetricName* find_gate_metric(const std::string& name) {
  for (const GateMetricName& m : kGateMetricNames)
    if (name == m.name) return &m;
  return nullptr;
}

/// A case's metrics under keys that carry their unit (as `ebh metrics --json`); a metric it has no
/// value for (NaN, an absent flag) is null.
Json gate_metrics_json(const GateCase& c) {
  Json j = Json::object();
  j.set(gate_metric_key("rms_force_step"), c.rms_force_step);
  j.set(gate_metric_key("max_force_rate"), c.max_force_rate);
  j.set(gate_metric_key("peak_force"), c.peak_force);
  j.set(gate_metric_key("power_above_30hz"), c.power_above_30hz);
  j.set(gate_metric_key("penetration_max"), c.penetration_max);
  j.set(gate_metric_key("boundary_step_ratio"), c.boundary_step_ratio);
  j.set(gate_metric_key("force_collapse"), c.force_collapse ? Json(*c.force_collapse) : Json());
  return j;
}

}  // namespace

std::string gate_metric_key(const std::string& name) {
  const GateMetricName* m = find_gate_metric(name);
  return m ? m->json_key : name;
}

std::string gate_metric_label(const std::string& name) {
  const GateMetricName* m = find_gate_metric(name);
  return m && *m->unit ? name + " [" + m->unit + "]" : name;
}

Json to_json(const GateResult& r, const GateCase& baseline) {
  Json j = Json::object();
  j.set("name", r.measured.name);
  j.set("passed", r.passed);
  j.set("stopped", r.stopped);
  j.set("measured", gate_metrics_json(r.measured));
  j.set("baseline", gate_metrics_json(baseline));
  j.set("failures", Json::array_of(r.failures));
  j.set("warnings", Json::array_of(r.warnings));
  // Under the keys "measured" and "baseline" give them, unit and all.
  std::vector<std::string> unchecked;
  for (const std::string& name : r.unchecked) unchecked.push_back(gate_metric_key(name));
  j.set("unchecked", Json::array_of(unchecked));
  return j;
}

}  // namespace ebh
