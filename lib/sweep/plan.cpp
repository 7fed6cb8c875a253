#include "sweep/plan.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>
#include <string_view>
#include <system_error>

#include "core/error.hpp"
#include "core/yaml_error.hpp"
#include "io/h5.hpp"
#include "io/paths.hpp"
#include "io/recording.hpp"
#include "io/sha256.hpp"
#include "scene/scene.hpp"

namespace ebh {
namespace fs = std::filesystem;
namespace {

std::string scene_inputs_sha256(const fs::path& scene_file, std::map<std::string, std::string>& digests);

/// A number's text in its shortest form (shortest_number: "1e3" -> "1000", "0.50" -> "0.5", "+5e2"
/// -> "500", "-0" -> "0": YAML reads a leading + as the number's sign, and -0 is the value 0); other
/// text as it is.
std::string shortest_if_number(const std::string& text) {
  const char* begin = text.data();
  const char* const last = text.data() + text.size();
  if (text.size() > 1 && text[0] == '+' && text[1] != '-' && text[1] != '+') ++begin;  // from_chars takes no '+'
  double v = 0;
  const auto [end, ec] = std::from_chars(begin, last, v);
  if (ec != std::errc() || end != last || !std::isfinite(v)) return text;
  return shortest_number(v == 0 ? 0.0 : v);
}

/// `text` as a `--set` value that reads back as that text (yaml_override_value): as it is where it
/// does (a number, a word, "a #b"), which keeps the values of a plan, its runs' ids and its
/// summary's columns as they were; else double-quoted.
std::string set_value_text(const std::string& text) {
  try {
    const YAML::Node n = yaml_override_value(text);
    if (n.IsScalar() && n.Scalar() == text) return text;
  } catch (const YAML::Exception&) {
  }
  YAML::Emitter e;
  e << YAML::DoubleQuoted << text;
  return e.c_str();
}

/// Reads the plan's YAML tree; every message names the file, the line and the dotted key.
class PlanReader {
 public:
  explicit PlanReader(fs::path file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& what) const {
    throw InputError(yaml_key_error(file_.string(), n, key, what));
  }

  /// The entries of a map, checked (yaml_map_entries: text keys among `allowed`, any key when it is
  /// empty, each once).
  std::vector<std::pair<std::string, YAML::Node>> entries(const YAML::Node& n, const std::string& key,
                                                          const std::vector<std::string>& allowed) const {
    return yaml_map_entries(n, key, allowed, [&](const YAML::Node& at, const std::string& k, const std::string& what) {
      fail(at, k, what);
    });
  }

  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar() || n.Scalar().empty()) fail(n, key, "expected text, got " + yaml_shown(n));
    return n.Scalar();
  }

  double number(const YAML::Node& n, const std::string& key, double lo, bool lo_open) const {
    char expected[64];
    std::snprintf(expected, sizeof expected, "a number %s %g", lo_open ? ">" : ">=", lo);
    double v = 0;
    if (n.IsScalar()) {
      const std::string& s = n.Scalar();
      const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
      if (ec == std::errc() && p == s.data() + s.size() && !s.empty() && std::isfinite(v) && (lo_open ? v > lo : v >= lo))
        return v;
    }
    fail(n, key, std::string("expected ") + expected + ", got " + yaml_shown(n));
  }

  int integer(const YAML::Node& n, const std::string& key, int lo, int hi) const {
    long long v = 0;
    if (n.IsScalar()) {
      const std::string& s = n.Scalar();
      const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
      if (ec == std::errc() && p == s.data() + s.size() && !s.empty() && v >= lo && v <= hi) return static_cast<int>(v);
    }
    fail(n, key, "expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + yaml_shown(n));
  }

  /// A non-empty list (its items, in order).
  std::vector<YAML::Node> list(const YAML::Node& n, const std::string& key, const std::string& of) const {
    if (!n.IsSequence() || n.size() == 0) fail(n, key, "expected a non-empty list of " + of + ", got " + yaml_shown(n));
    std::vector<YAML::Node> out;
    for (const YAML::Node& x : n) out.push_back(x);
    return out;
  }

  /// A scene key's value as `--set` takes it: a scalar's text, a list in flow style; numbers in
  /// their shortest form, so that one value is one configuration however it is written (1e3 and
  /// 1000, 0.50 and 0.5: the same replay, which would otherwise run twice, or not be taken for
  /// the reference or the baseline it is). A text that `--set` would read as something else (a
  /// quoted '[1, 2]', 'x: y', '~') is passed on quoted (set_value_text).
  std::string value(const YAML::Node& n, const std::string& key) const {
    if (n.IsScalar()) return set_value_text(shortest_if_number(n.Scalar()));
    if (n.IsSequence()) {
      YAML::Node items(YAML::NodeType::Sequence);
      for (const YAML::Node& x : n) items.push_back(x.IsScalar() ? YAML::Node(shortest_if_number(x.Scalar())) : x);
      YAML::Emitter e;
      e << YAML::Flow << items;
      return e.c_str();
    }
    fail(n, key, "expected a value (a number, text or a list), got " + yaml_shown(n));
  }

  /// A map of overrides {dotted.key: value}; the node of each value in `where` (for messages).
  Overrides overrides(const YAML::Node& n, const std::string& key, std::map<std::string, YAML::Node>* where) const {
    if (n.IsNull()) return {};  // `reference:` with nothing after it: the scene as it is
    Overrides out;
    for (const auto& [k, v] : entries(n, key, {})) {
      out[k] = value(v, key + "." + k);
      if (where) (*where)[k] = v;
    }
    return out;
  }

  /// A scene or recording as written: a name, or a path taken relative to the plan's folder.
  fs::path resolve(const YAML::Node& n, const std::string& key, const std::string& folder, const std::string& extension,
                   const std::string& what) const {
    try {
      return fs::absolute(resolve_data_path(data_reference_from(text(n, key), file_.parent_path()), folder, extension,
                                            what))
          .lexically_normal();
    } catch (const InputError& e) {
      fail(n, key, e.what());
    }
  }

  const fs::path& file() const { return file_; }

 private:
  fs::path file_;
};

std::vector<std::string> as_set_arguments(const Overrides& o) {
  std::vector<std::string> out;
  for (const auto& [k, v] : o) out.push_back(k + "=" + v);
  return out;
}

Overrides merged(const Overrides& first, const Overrides& then) {
  Overrides out = first;
  for (const auto& [k, v] : then) out[k] = v;
  return out;
}

/// The recordings whose `scene` attribute names the scene (`recordings: all`): by its name, or as
/// a path to its file (resolve_recording_scene: `ebh import --scene FILE` writes one), or the
/// scene it was refined or degraded from (as a replay takes them: NAME_l1's are NAME's).
std::vector<fs::path> recordings_of(const std::string& scene, const fs::path& scene_file) {
  // The recordings/ folders of the data roots, and the scene file's own folder (own data kept
  // together: scene, mesh and the recordings imported for it).
  std::vector<fs::path> candidates = data_files("recordings", ".h5");
  std::vector<fs::path> beside;
  std::error_code ec;
  for (fs::directory_iterator it(scene_file.parent_path(), ec), end; !ec && it != end; it.increment(ec))
    if (it->path().extension() == ".h5" && fs::is_regular_file(it->path(), ec)) beside.push_back(it->path());
  std::sort(beside.begin(), beside.end());
  candidates.insert(candidates.end(), beside.begin(), beside.end());
  std::vector<fs::path> out;
  for (const fs::path& p : candidates) {
    const fs::path path = fs::absolute(p).lexically_normal();
    if (std::any_of(out.begin(), out.end(), [&](const fs::path& q) { return fs::equivalent(q, path, ec); })) continue;
    try {
      const h5::File f = h5::File::open_read(path.string());
      if (!f.has("trajectory")) continue;  // a replay output or another file, not a recording
      const std::string attribute = f.attr_string("scene");
      if (attribute == scene || derived_scene_name(scene, attribute) ||
          fs::equivalent(resolve_recording_scene(attribute, path.string()), scene_file, ec))
        out.push_back(path);
    } catch (const InputError&) {
      // not a recording (or one without a scene, or naming none): not one of this scene's
    }
  }
  return out;
}

/// Where a configuration's own overrides are in the plan: for each scene key, the plan's key that
/// gave it ("grid.solver.virtual_iterations", for messages) and its value's node (its line).
using OverrideNodes = std::map<std::string, std::pair<std::string, YAML::Node>>;

OverrideNodes override_nodes(const std::map<std::string, YAML::Node>& where, const std::string& prefix) {
  OverrideNodes out;
  for (const auto& [k, node] : where) out[k] = {prefix + k, node};
  return out;
}

/// Throws when a configuration does not load on the scene: `set`, then its own overrides `own`, all
/// together, as its replays take them (the check `ebh replay --set` makes; keys that are only valid
/// together, such as time.haptic_hz 999.9 with time.physical_hz 99.99, pass). The error names the
/// plan's key of the override the scene refused: the configuration's own (`own_nodes`), or `set`'s
/// (`set_nodes`) where `set` alone is refused too; else the configuration (`key` at `where`), as
/// the combination is what fails. Returns the haptic tick (s) the scene has under them
/// (1 / time.haptic_hz, as its world has it).
double check_on_scene(const PlanReader& r, const SweepScene& s, const Overrides& set, const OverrideNodes& set_nodes,
                      const Overrides& own, const OverrideNodes& own_nodes, const YAML::Node& where, const std::string& key) {
  auto load = [&s](const Overrides& o) { return load_scene_spec(s.scene_file, as_set_arguments(o)).haptic_hz; };
  auto set_alone_refused = [&] {
    try {
      (void)load(set);
      return false;
    } catch (const InputError&) {
      return true;
    }
  };
  try {
    return 1.0 / load(merged(set, own));
  } catch (const OverrideError& e) {
    // The override the scene refused (as_set_arguments gives each as "KEY=VALUE").
    const std::string problem = "on scene " + s.name + ": " + e.key_message();
    const std::string k = e.override_text().substr(0, e.override_text().find('='));
    if (const auto at = own_nodes.find(k); at != own_nodes.end()) r.fail(at->second.second, at->second.first, problem);
    if (const auto at = set_nodes.find(k); at != set_nodes.end() && set_alone_refused())
      r.fail(at->second.second, at->second.first, problem);
    r.fail(where, key, problem);
  } catch (const InputError& e) {
    r.fail(where, key, "on scene " + s.name + ": " + e.what());
  }
}

}  // namespace

SweepPlan read_sweep_plan(const fs::path& file) {
  check_input_file(file.string());
  PlanReader r(file);
  YAML::Node root;
  try {
    root = only_yaml_document(YAML::LoadAllFromFile(file.string()), file.string(), "a sweep plan");
  } catch (const YAML::ParserException& e) {
    throw InputError(yaml_parse_error(file.string(), e));
  } catch (const YAML::Exception& e) {
    throw InputError(file.string() + ": cannot read the plan: " + e.msg);
  }
  if (!root.IsDefined() || root.IsNull()) throw InputError(file.string() + ": empty plan (it needs at least `scenes`)");
  yaml_refuse_tags_in(file.string(), root);
  SweepPlan plan;
  plan.file = file;
  std::map<std::string, YAML::Node> top;
  for (auto& [k, v] : r.entries(root, "", {"scenes", "grid", "runs", "baseline", "set", "backends", "reference_backend",
                                          "repetitions", "mode", "start", "duration"}))
    top[k] = v;
  if (!top.count("scenes")) throw InputError(file.string() + ": key 'scenes': missing (required)");

  // Plain settings first: the scenes' checks below use them.
  if (top.count("backends")) {
    plan.backends.clear();
    for (const YAML::Node& b : r.list(top["backends"], "backends", "backends (cpu, cuda)")) {
      const std::string name = r.text(b, "backends");
      if (name != "cpu" && name != "cuda") r.fail(b, "backends", "expected cpu or cuda, got " + yaml_shown(b));
      if (std::find(plan.backends.begin(), plan.backends.end(), name) != plan.backends.end())
        r.fail(b, "backends", "'" + name + "' given twice");
      plan.backends.push_back(name);
    }
  }
  if (top.count("reference_backend")) {
    plan.reference_backend = r.text(top["reference_backend"], "reference_backend");
    if (plan.reference_backend != "cpu" && plan.reference_backend != "cuda")
      r.fail(top["reference_backend"], "reference_backend", "expected cpu or cuda, got " + yaml_shown(top["reference_backend"]));
  }
  if (top.count("repetitions")) plan.repetitions = r.integer(top["repetitions"], "repetitions", 1, 1000);
  if (top.count("mode")) {
    plan.mode = r.text(top["mode"], "mode");
    if (plan.mode != "async" && plan.mode != "lockstep")
      r.fail(top["mode"], "mode", "expected async or lockstep (realtime replays are not repeatable), got " + yaml_shown(top["mode"]));
  }
  if (top.count("start")) plan.start = r.number(top["start"], "start", 0, false);
  if (top.count("duration")) plan.duration = r.number(top["duration"], "duration", 0, true);

  std::map<std::string, YAML::Node> set_where;
  if (top.count("set")) plan.set = r.overrides(top["set"], "set", &set_where);

  // Configurations: a grid's combinations (the last key varying fastest) or a list.
  struct Configuration {
    Overrides overrides;
    YAML::Node node;     ///< what gave it (messages): a list entry, a grid combination's last value
    OverrideNodes keys;  ///< where each of its overrides is in the plan
  };
  std::vector<Configuration> configurations;
  if (top.count("grid") && top.count("runs"))
    r.fail(top["runs"], "runs", "give `grid` or `runs`, not both (a list of override sets can hold any grid)");
  if (top.count("grid")) {
    configurations.push_back({{}, top["grid"], {}});
    for (const auto& [key, values] : r.entries(top["grid"], "grid", {})) {
      const std::vector<YAML::Node> items = r.list(values, "grid." + key, "values");
      std::vector<Configuration> next;
      for (const Configuration& config : configurations)
        for (const YAML::Node& v : items) {
          Configuration c = config;
          c.overrides[key] = r.value(v, "grid." + key);
          c.node = v;
          c.keys[key] = {"grid." + key, v};
          next.push_back(std::move(c));
        }
      if (next.size() > kMaxSweepRuns) r.fail(values, "grid", "more than " + std::to_string(kMaxSweepRuns) + " combinations");
      configurations = std::move(next);
    }
  } else if (top.count("runs")) {
    std::size_t i = 0;
    for (const YAML::Node& entry : r.list(top["runs"], "runs", "override sets ({key: value, ...})")) {
      const std::string key = "runs[" + std::to_string(i++) + "]";
      std::map<std::string, YAML::Node> where;
      const Overrides o = entry.IsMap() && entry.size() == 0 ? Overrides{} : r.overrides(entry, key, &where);
      configurations.push_back({o, entry, override_nodes(where, "runs.")});
    }
  } else {
    configurations.push_back({{}, root, {}});  // the scenes as they are
  }
  // A `set` key that every configuration overrides (a grid's key always is) never reaches a run:
  // only the references would replay it, which is seldom what a plan means by "every replay".
  if (top.count("grid") || top.count("runs"))
    for (const auto& [k, v] : plan.set) {
      // (a plan's values are numbers, text or lists: no map sets part of another key)
      if (std::all_of(configurations.begin(), configurations.end(), [&k](const auto& c) { return c.overrides.count(k) > 0; }))
        r.fail(set_where[k], "set." + k,
               std::string("every configuration of `") + (top.count("grid") ? "grid" : "runs") + "` gives " + k +
                   " its own value, so this one reaches no run (only the references that keep it): `set` holds "
                   "what every replay shares; give " + k + " in one place");
    }
  std::set<Overrides> seen;
  for (const Configuration& c : configurations)
    if (seen.insert(c.overrides).second) plan.configurations.push_back(c.overrides);
  // The baseline: a named configuration, one more run unless a grid combination or list entry is it.
  std::map<std::string, YAML::Node> baseline_where;
  YAML::Node baseline_node;
  if (top.count("baseline")) {
    std::map<std::string, YAML::Node> b;
    for (auto& [k, v] : r.entries(top["baseline"], "baseline", {"name", "set"})) b[k] = v;
    if (!b.count("set")) r.fail(top["baseline"], "baseline.set", "missing (required: the baseline's overrides, {} for the scene as it is)");
    if (b.count("name")) plan.baseline_name = r.text(b["name"], "baseline.name");
    baseline_node = b["set"];
    plan.baseline = baseline_node.IsMap() && baseline_node.size() == 0 ? Overrides{}
                                                                        : r.overrides(baseline_node, "baseline.set", &baseline_where);
    if (seen.insert(*plan.baseline).second) plan.configurations.push_back(*plan.baseline);
  }

  // The run count (expand_plan's, from the counts alone) before any scene is loaded or any
  // configuration checked on it: a grid of 1e5 values took minutes and hundreds of MB to refuse.
  // Per recording: each distinct replay configuration on each backend, each repetition, and the
  // reference unless it is one of them.
  std::set<Overrides> effective_configurations;
  for (const Overrides& c : plan.configurations) effective_configurations.insert(merged(plan.set, c));
  const std::size_t per_backend = effective_configurations.size() * plan.backends.size();
  const std::size_t per_recording = per_backend * static_cast<std::size_t>(plan.repetitions);
  const bool by_repetitions = per_backend <= kMaxSweepRuns && per_recording > kMaxSweepRuns;
  const char* const size_key = by_repetitions ? "repetitions" : top.count("grid") ? "grid" : top.count("runs") ? "runs" : "scenes";
  auto check_run_count = [&](std::size_t runs, std::size_t recordings) {
    if (runs <= kMaxSweepRuns) return;
    r.fail(top[size_key], size_key,
           "the plan makes " + std::to_string(runs) + " runs or more (" + std::to_string(effective_configurations.size()) +
               " configurations x " + std::to_string(plan.backends.size()) + " backends x " +
               std::to_string(plan.repetitions) + " repetitions x " + std::to_string(recordings) +
               " recordings, and their references); at most " + std::to_string(kMaxSweepRuns) + ": split it into plans");
  };
  check_run_count(per_recording, 1);
  std::size_t run_count = 0, recording_count = 0;

  std::size_t index = 0;
  for (const YAML::Node& n : r.list(top["scenes"], "scenes", "scenes ({scene: NAME, recordings: [...], reference: {...}})")) {
    const std::string key = "scenes[" + std::to_string(index++) + "]";
    std::map<std::string, YAML::Node> e;
    for (auto& [k, v] : r.entries(n, key, {"scene", "recordings", "reference"})) e[k] = v;
    for (const char* required : {"scene", "recordings", "reference"})
      if (!e.count(required)) r.fail(n, key + "." + required, "missing (required)");
    SweepScene s;
    s.scene = r.text(e["scene"], key + ".scene");
    s.scene_file = r.resolve(e["scene"], key + ".scene", "scenarios", ".yaml", "scene");
    s.name = s.scene_file.stem().string();
    const YAML::Node& recs = e["recordings"];
    if (recs.IsScalar() && recs.Scalar() == "all") {
      s.recordings = recordings_of(s.name, s.scene_file);
      if (s.recordings.empty())
        r.fail(recs, key + ".recordings",
               "no recording names the scene '" + s.name + "' (their `scene` attribute) in recordings/ of the data "
               "folders ($EBH_DATA_DIR, the working directory, the source tree) or beside the scene file in " +
               s.scene_file.parent_path().string() + "; list the recordings by path");
    } else {
      for (const YAML::Node& rec : r.list(recs, key + ".recordings", "recordings (names or paths), or all")) {
        const std::string entry = key + ".recordings[" + std::to_string(s.recordings.size()) + "]";
        const fs::path p = r.resolve(rec, entry, "recordings", ".h5", "recording");
        if (std::find(s.recordings.begin(), s.recordings.end(), p) != s.recordings.end())
          r.fail(rec, entry, p.string() + " given twice");
        s.recordings.push_back(p);
      }
    }
    // Each recording's own entry (its line and index) for what is wrong with the file itself;
    // `all` names the key.
    auto recording_at = [&](std::size_t i) { return recs.IsSequence() ? recs[i] : recs; };
    auto recording_key = [&](std::size_t i) {
      return key + ".recordings" + (recs.IsSequence() ? "[" + std::to_string(i) + "]" : std::string());
    };
    // A copy is the same recording: its runs would be the same replays, kept once, one row for both.
    for (std::size_t i = 0; i < s.recordings.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (sha256_file_cached(plan.sha256, s.recordings[i].string()) ==
            sha256_file_cached(plan.sha256, s.recordings[j].string()))
          r.fail(recording_at(i), recording_key(i),
                 s.recordings[i].string() + " has the same bytes as " + s.recordings[j].string() +
                     ": the same recording; list it once");
    // Each recording read as a run reads it: its window's samples kept, every one checked. A file
    // that is no recording is its entry's fault. (Its window is checked below, with the scene's rates.)
    for (std::size_t i = 0; i < s.recordings.size(); ++i) {
      const fs::path& p = s.recordings[i];
      double length = 0;
      try {
        length = read_recording(p.string(), RecordingWindow{plan.start, plan.duration}).duration();
      } catch (const InputError& error) {
        r.fail(recording_at(i), recording_key(i), error.what());
      }
      plan.recording_length[p.string()] = length;
    }
    std::map<std::string, YAML::Node> ref_where;
    s.reference = r.overrides(e["reference"], key + ".reference", &ref_where);
    const bool reference_is_a_run =
        std::find(plan.backends.begin(), plan.backends.end(), plan.reference_backend) != plan.backends.end() &&
        effective_configurations.count(merged(plan.set, s.reference));
    run_count += s.recordings.size() * (per_recording + (reference_is_a_run ? 0 : 1));
    recording_count += s.recordings.size();
    check_run_count(run_count, recording_count);
    for (const SweepScene& other : plan.scenes)
      if (other.scene_file == s.scene_file) r.fail(e["scene"], key + ".scene", s.scene_file.string() + " given twice");
    // A copy (the scene file and its meshes the same bytes) is the same scene: its runs would be
    // the same replays, kept once, and its rows and its reference's errors lost.
    s.inputs_sha256 = scene_inputs_sha256(s.scene_file, plan.sha256);
    for (const SweepScene& other : plan.scenes)
      if (other.inputs_sha256 == s.inputs_sha256)
        r.fail(e["scene"], key + ".scene",
               s.scene_file.string() + " and its meshes have the same bytes as " + other.scene_file.string() +
                   ": the same scene; list it once (with its recordings together)");

    // Each configuration with `set`, all its keys together, as its replays take them; the longest
    // haptic tick of the scene's replays (a plan may sweep time.haptic_hz).
    const OverrideNodes set_nodes = override_nodes(set_where, "set.");
    double h_haptic = check_on_scene(r, s, plan.set, set_nodes, s.reference, override_nodes(ref_where, key + ".reference."),
                                     e["reference"], key + ".reference");
    if (plan.baseline)
      h_haptic = std::max(h_haptic, check_on_scene(r, s, plan.set, set_nodes, *plan.baseline,
                                                   override_nodes(baseline_where, "baseline.set."), baseline_node, "baseline.set"));
    for (const Configuration& c : configurations)
      h_haptic = std::max(h_haptic, check_on_scene(r, s, plan.set, set_nodes, c.overrides, c.keys, c.node,
                                                   top.count("grid") ? "grid" : top.count("runs") ? "runs" : "set"));
    // The window inside every recording and of one tick at least (as ebh replay --start --duration
    // checks it), before any run: each run would fail on it. A window outside a recording is the
    // start's fault; one under a tick the duration's, or the start's where the recording's end cuts it.
    for (const fs::path& p : s.recordings)
      try {
        (void)replay_window(plan.start, plan.duration > 0 ? std::optional<double>(plan.duration) : std::nullopt,
                            plan.recording_length[p.string()], h_haptic, p.string() + " (" + key + ".recordings)", "start",
                            "duration");
      } catch (const InputError& error) {
        const bool duration = std::string_view(error.what()).starts_with("duration");
        r.fail(duration ? top["duration"] : top.count("start") ? top["start"] : recs, duration ? "duration" : "start",
               error.what());
      }
    plan.scenes.push_back(std::move(s));
  }
  for (SweepScene& sc : plan.scenes)  // each file read once, for every run's id (the listed ones are)
    for (const fs::path& f : sc.recordings) sha256_file_cached(plan.sha256, f.string());
  (void)expand_plan(plan);  // the size limit, before any work
  return plan;
}

std::string resolved_plan_yaml(const SweepPlan& plan) {
  YAML::Emitter y;
  auto overrides = [&y](const Overrides& o) {
    y << YAML::BeginMap;
    for (const auto& [k, v] : o) {
      y << YAML::Key << k << YAML::Value;
      // The value as the plan gave it: a flow list stays a list, a scalar stays its text (quoted
      // where YAML needs it), which the plan's reader turns back into the same value.
      const YAML::Node n = yaml_override_value(v);
      if (n.IsSequence()) y << YAML::Flow << n;
      else y << n.Scalar();
    }
    y << YAML::EndMap;
  };
  y << YAML::BeginMap;
  y << YAML::Key << "scenes" << YAML::Value << YAML::BeginSeq;
  for (const SweepScene& s : plan.scenes) {
    y << YAML::BeginMap << YAML::Key << "scene" << YAML::Value << s.scene_file.string();
    y << YAML::Key << "recordings" << YAML::Value << YAML::BeginSeq;
    for (const fs::path& p : s.recordings) y << p.string();
    y << YAML::EndSeq << YAML::Key << "reference" << YAML::Value;
    overrides(s.reference);
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
  y << YAML::Key << "runs" << YAML::Value << YAML::BeginSeq;
  for (const Overrides& c : plan.configurations) overrides(c);
  y << YAML::EndSeq;
  if (plan.baseline) {
    y << YAML::Key << "baseline" << YAML::Value << YAML::BeginMap << YAML::Key << "name" << YAML::Value << plan.baseline_name;
    y << YAML::Key << "set" << YAML::Value;
    overrides(*plan.baseline);
    y << YAML::EndMap;
  }
  if (!plan.set.empty()) {
    y << YAML::Key << "set" << YAML::Value;
    overrides(plan.set);
  }
  y << YAML::Key << "backends" << YAML::Value << YAML::Flow << plan.backends;
  y << YAML::Key << "reference_backend" << YAML::Value << plan.reference_backend;
  y << YAML::Key << "repetitions" << YAML::Value << plan.repetitions;
  y << YAML::Key << "mode" << YAML::Value << plan.mode;
  y << YAML::Key << "start" << YAML::Value << shortest_number(plan.start);
  if (plan.duration > 0) y << YAML::Key << "duration" << YAML::Value << shortest_number(plan.duration);
  y << YAML::EndMap;
  return "# ebh sweep: the plan as run (paths absolute, defaults written; docs/FORMATS.md, \"Sweep plan\")\n" +
         std::string(y.c_str()) + "\n";
}

std::string shortest_number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string SweepRun::overrides_text() const {
  std::string s;
  for (const auto& [k, v] : overrides) s += (s.empty() ? "" : " ") + k + "=" + v;
  return s.empty() ? "-" : s;
}

std::vector<std::string> SweepRun::set_arguments() const { return as_set_arguments(effective); }

namespace {

/// SweepScene::inputs_sha256 of a scene file: its input files' digests (taken from `digests`, by
/// path, and added to it when not there).
std::string scene_inputs_sha256(const fs::path& scene_file, std::map<std::string, std::string>& digests) {
  std::string key;
  for (const SceneInputFile& f : scene_input_files(load_scene_spec(scene_file)))
    key += f.key + " " + sha256_file_cached(digests, f.path.string()) + "\n";
  return sha256_hex(key);
}

/// What a run id hashes after the two files: the replay's window, configuration and backend.
std::string run_key_tail(const SweepPlan& plan, const Overrides& effective, const std::string& backend, int repetition) {
  std::string key = "\nmode " + plan.mode + "\nstart " + shortest_number(plan.start) + "\nduration " +
                    shortest_number(plan.duration) + "\nbackend " + backend + "\nrepetition " + std::to_string(repetition) + "\n";
  for (const auto& [k, v] : effective) key += "set " + k + "=" + v + "\n";
  return key;
}

}  // namespace

std::string run_id(const SweepPlan& plan, const std::string& scene_inputs_sha256, const std::string& recording_sha256,
                   const Overrides& effective, const std::string& backend, int repetition) {
  return sha256_hex("ebh sweep run\nscene inputs sha256 " + scene_inputs_sha256 + "\nrecording sha256 " + recording_sha256 +
                    run_key_tail(plan, effective, backend, repetition))
      .substr(0, 16);
}

std::string legacy_run_id(const SweepPlan& plan, const fs::path& scene_file, const fs::path& recording,
                          const Overrides& effective, const std::string& backend, int repetition) {
  return sha256_hex("ebh sweep run\nscene " + scene_file.string() + "\nrecording " + recording.string() +
                    run_key_tail(plan, effective, backend, repetition))
      .substr(0, 16);
}

std::vector<SweepRun> expand_plan(const SweepPlan& plan) {
  std::vector<SweepRun> runs;
  std::set<std::string> ids;
  // Run r of scene si: its ids, from the files' digests read with the plan (read_sweep_plan).
  auto name = [&](SweepRun& r, std::size_t si) {
    const fs::path& scene = plan.scenes[si].scene_file;
    r.id = run_id(plan, plan.scenes[si].inputs_sha256, plan.sha256.at(r.recording.string()), r.effective, r.backend,
                  r.repetition);
    r.legacy_id = legacy_run_id(plan, scene, r.recording, r.effective, r.backend, r.repetition);
  };
  auto add = [&](SweepRun r) {
    if (ids.insert(r.id).second) runs.push_back(std::move(r));
    if (runs.size() > kMaxSweepRuns)
      throw InputError(plan.file.string() + ": the plan makes more than " + std::to_string(kMaxSweepRuns) + " runs");
  };
  for (std::size_t si = 0; si < plan.scenes.size(); ++si)
    for (const fs::path& rec : plan.scenes[si].recordings) {
      SweepRun r;
      r.scene = si;
      r.recording = rec;
      r.overrides = plan.scenes[si].reference;
      r.effective = merged(plan.set, r.overrides);
      r.backend = plan.reference_backend;
      r.reference = true;
      // The baseline's run on this backend when the baseline is the reference configuration.
      r.baseline = plan.baseline && *plan.baseline == r.overrides &&
                   std::find(plan.backends.begin(), plan.backends.end(), r.backend) != plan.backends.end();
      name(r, si);
      r.reference_id = r.id;
      add(std::move(r));
    }
  const std::size_t references = runs.size();
  for (std::size_t si = 0; si < plan.scenes.size(); ++si)
    for (const fs::path& rec : plan.scenes[si].recordings) {
      const auto ref = std::find_if(runs.begin(), runs.begin() + static_cast<long>(references),
                                    [&](const SweepRun& x) { return x.scene == si && x.recording == rec; });
      const std::string ref_id = ref->id;
      for (const Overrides& config : plan.configurations)
        for (const std::string& backend : plan.backends)
          for (int rep = 0; rep < plan.repetitions; ++rep) {
            SweepRun r;
            r.scene = si;
            r.recording = rec;
            r.overrides = config;
            r.effective = merged(plan.set, config);
            r.backend = backend;
            r.repetition = rep;
            r.reference_id = ref_id;
            r.baseline = plan.baseline && *plan.baseline == config;
            name(r, si);
            add(std::move(r));  // the reference's own configuration on its backend is the reference run
          }
    }
  return runs;
}

}  // namespace ebh
