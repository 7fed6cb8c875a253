#include "io/synth.hpp"
#include "math/splitmix.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <numbers>
#include <string_view>
#include <utility>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "core/yaml_error.hpp"
#include "io/paths.hpp"
#include "math/rotvec_input.hpp"

namespace ebh {
namespace {

// ---- plan file ----

struct PlanReader {
  std::string file;

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& what) const {
    throw InputError(yaml_key_error(file, n, key, what));
  }

  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "expected a number");
    try {
      double v = n.as<double>();
      if (!std::isfinite(v)) fail(n, key, "not a finite number");
      return v;
    } catch (const YAML::Exception&) {
      fail(n, key, "expected a number, got '" + n.Scalar() + "'");
    }
  }

  std::string string(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "expected a string");
    // A recording's attributes are C strings: the text would end there ("tu\0be" stored as "tu").
    if (n.Scalar().find('\0') != std::string::npos) fail(n, key, "contains a NUL byte (\\0)");
    return n.Scalar();
  }

  std::vector<double> numbers(const YAML::Node& n, const std::string& key, std::size_t count) const {
    if (!n.IsSequence() || n.size() != count) fail(n, key, "expected a list of " + std::to_string(count) + " numbers");
    std::vector<double> v;
    for (std::size_t i = 0; i < count; ++i) v.push_back(number(n[i], key + "[" + std::to_string(i) + "]"));
    return v;
  }

  /// Checks the map's keys (yaml_map_entries: text keys among `allowed`, each once).
  void only_keys(const YAML::Node& n, const std::string& key, std::initializer_list<std::string_view> allowed) const {
    yaml_map_entries(n, key, allowed, [&](const YAML::Node& at, const std::string& k, const std::string& what) {
      fail(at, k, what);
    });
  }
};

constexpr double kQuantumMinMm = 1e-6, kQuantumMaxMm = 10;  // quantum_mm: 1 nm .. 1 cm
constexpr double kTremorMaxMm = 10;                         // tremor.amplitude_mm
constexpr double kPositionMaxMm = 1e5;                      // a waypoint's coordinates: 100 m

// Whole numbers as such ("10000000 samples"), others as %g ("1e+15").
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, std::fabs(v) < 1e15 && v == std::floor(v) ? "%.0f" : "%g", v);
  return buf;
}

}  // namespace

SynthPlan read_plan(const std::string& path, std::optional<double> rate_hz) {
  check_input_file(path);
  PlanReader r{path};
  YAML::Node root;
  try {
    root = only_yaml_document(YAML::LoadAllFromFile(path), path, "a synthesis plan");
  } catch (const YAML::BadFile&) {
    throw InputError(path + ": cannot open the plan file");
  } catch (const YAML::ParserException& e) {
    throw InputError(yaml_parse_error(path, e));
  }
  if (!root.IsMap()) throw InputError(path + ": the plan must be a YAML mapping (scene, tool, waypoints, ...)");
  yaml_refuse_tags_in(path, root);
  r.only_keys(root, "", {"scene", "tool", "description", "rate_hz", "tremor", "quantum_mm", "waypoints"});

  SynthPlan plan;
  plan.file = path;
  for (const char* k : {"scene", "waypoints"})
    if (!root[k]) throw InputError(path + ": missing key '" + k + "'");
  plan.scene = r.string(root["scene"], "scene");
  if (plan.scene.find_first_not_of(" \t") == std::string::npos)
    r.fail(root["scene"], "scene", "expected a scene's name or path, got nothing (a recording names its scene)");
  if (has_control_character(plan.scene))
    r.fail(root["scene"], "scene", "'" + escape_unprintable(plan.scene) + "' holds a control character (a line break?): "
                                   "no scene's name or path does");
  // A scene is a YAML file: a recording or a mesh named here would be stored as the scene.
  if (const std::filesystem::path sp(plan.scene); sp.has_extension() && !has_yaml_extension(sp))
    r.fail(root["scene"], "scene", "'" + plan.scene + "' is no scene file (a scene is YAML, .yaml): name the scene the "
                                   "recording is for, its name or its .yaml");
  if (root["scene"].Mark().line >= 0) plan.scene_line = root["scene"].Mark().line + 1;
  if (root["tool"]) {
    plan.tool = r.string(root["tool"], "tool");
    if (root["tool"].Mark().line >= 0) plan.tool_line = root["tool"].Mark().line + 1;
    if (plan.tool != "hook" && plan.tool != "forceps") r.fail(root["tool"], "tool", "expected hook or forceps");
  }
  if (root["description"]) plan.description = r.string(root["description"], "description");
  if (root["rate_hz"]) {
    plan.rate_hz = r.number(root["rate_hz"], "rate_hz");
    if (!(plan.rate_hz > 0 && plan.rate_hz <= kMaxSampleRateHz))
      r.fail(root["rate_hz"], "rate_hz", "expected a number in (0, " + num(kMaxSampleRateHz) + "] Hz");
  }
  if (root["quantum_mm"]) {
    // A device's position resolution is ~0.01-0.1 mm: a coarser grid flattens the path, and one
    // below a nanometre overflows the rounding (position / quantum).
    const double q = r.number(root["quantum_mm"], "quantum_mm");
    if (!(q == 0 || (q >= kQuantumMinMm && q <= kQuantumMaxMm)))
      r.fail(root["quantum_mm"], "quantum_mm",
             "expected 0 (none) or " + num(kQuantumMinMm) + " .. " + num(kQuantumMaxMm) +
                 " mm (a device's resolution is ~0.01-0.1 mm), got " + num(q));
    plan.quantum = q * 1e-3;
  }
  if (const YAML::Node tr = root["tremor"]) {
    if (!tr.IsMap()) r.fail(tr, "tremor", "expected a mapping {amplitude_mm, band_hz, components}");
    r.only_keys(tr, "tremor", {"amplitude_mm", "band_hz", "components"});
    if (tr["amplitude_mm"]) {
      const double a = r.number(tr["amplitude_mm"], "tremor.amplitude_mm");
      if (!(a >= 0 && a <= kTremorMaxMm))
        r.fail(tr["amplitude_mm"], "tremor.amplitude_mm",
               "expected 0 .. " + num(kTremorMaxMm) + " mm (a hand's tremor is ~0.01-1 mm), got " + num(a));
      plan.tremor_amplitude = a * 1e-3;
    }
    if (tr["band_hz"]) {
      auto b = r.numbers(tr["band_hz"], "tremor.band_hz", 2);
      if (!(b[0] > 0 && b[1] >= b[0])) r.fail(tr["band_hz"], "tremor.band_hz", "expected [low, high] with 0 < low <= high");
      plan.tremor_band_lo = b[0];
      plan.tremor_band_hi = b[1];
    }
    if (tr["components"]) {
      double c = r.number(tr["components"], "tremor.components");
      if (c < 1 || c > 16 || c != std::floor(c)) r.fail(tr["components"], "tremor.components", "expected an integer in 1..16");
      plan.tremor_components = static_cast<int>(c);
    }
  }

  const YAML::Node wps = root["waypoints"];
  if (!wps.IsSequence() || wps.size() < 2) r.fail(wps, "waypoints", "expected a list of at least 2 waypoints");
  for (std::size_t i = 0; i < wps.size(); ++i) {
    const YAML::Node w = wps[i];
    const std::string key = "waypoints[" + std::to_string(i) + "]";
    if (!w.IsMap()) r.fail(w, key, "expected a mapping {t, position_mm, rotvec_deg, jaw, buttons}");
    r.only_keys(w, key, {"t", "position_mm", "rotvec_deg", "jaw", "buttons"});
    PlanWaypoint p;
    if (!w["t"]) r.fail(w, key, "missing 't'");
    p.t = r.number(w["t"], key + ".t");
    if (i == 0 && p.t < 0) r.fail(w["t"], key + ".t", "must be >= 0");
    if (i > 0 && !(p.t > plan.waypoints.back().t)) r.fail(w["t"], key + ".t", "times must be strictly increasing");
    // position_mm, rotvec_deg, jaw and buttons carry over from the previous waypoint when omitted.
    if (w["position_mm"]) {
      auto v = r.numbers(w["position_mm"], key + ".position_mm", 3);
      for (const double c : v)
        if (!(std::fabs(c) <= kPositionMaxMm))
          r.fail(w["position_mm"], key + ".position_mm",
                 "coordinate " + num(c) + " mm is beyond " + num(kPositionMaxMm) + " mm (100 m; a scene is at most 2 m across)");
      p.position = Vec3d{v[0], v[1], v[2]} * 1e-3;
    } else if (i == 0) {
      r.fail(w, key, "the first waypoint needs position_mm");
    } else {
      p.position = plan.waypoints.back().position;
    }
    if (w["rotvec_deg"]) {
      auto v = r.numbers(w["rotvec_deg"], key + ".rotvec_deg", 3);
      const Vec3d rotvec{v[0], v[1], v[2]};
      if (const std::string why = rotvec_deg_problem(rotvec); !why.empty()) r.fail(w["rotvec_deg"], key + ".rotvec_deg", why);
      p.orientation = quat_from_rotvec(rotvec * (std::numbers::pi / 180.0));
    } else if (i == 0) {
      r.fail(w, key, "the first waypoint needs rotvec_deg");
    } else {
      p.orientation = plan.waypoints.back().orientation;
    }
    if (w["jaw"]) {
      p.jaw = r.number(w["jaw"], key + ".jaw");
      if (p.jaw < 0 || p.jaw > 1) r.fail(w["jaw"], key + ".jaw", "must be in [0, 1] (0 closed, 1 open)");
    } else {
      p.jaw = i == 0 ? 1.0 : plan.waypoints.back().jaw;
    }
    if (w["buttons"]) {
      double b = r.number(w["buttons"], key + ".buttons");
      if (b < 0 || b > 255 || b != std::floor(b)) r.fail(w["buttons"], key + ".buttons", "expected a bitmask 0..255");
      p.buttons = static_cast<std::uint8_t>(b);
    } else {
      p.buttons = i == 0 ? 0 : plan.waypoints.back().buttons;
    }
    plan.waypoints.push_back(p);
  }
  // The rate is final here (--rate replaces the plan's): samples slower than twice the tremor's
  // highest frequency alias it. Blamed on what set the rate, else on the plan's band or rate.
  if (rate_hz) plan.rate_hz = *rate_hz;
  if (plan.tremor_amplitude > 0 && plan.tremor_band_hi > plan.rate_hz / 2) {
    const std::string what = num(plan.rate_hz) + " Hz samples cannot carry the tremor's band up to " +
                             num(plan.tremor_band_hi) +
                             " Hz (more than half the rate); raise the rate, lower tremor.band_hz, or set "
                             "tremor.amplitude_mm: 0";
    if (rate_hz) throw InputError("--rate " + num(*rate_hz) + ": " + what);
    if (const YAML::Node tr = root["tremor"]; tr && tr["band_hz"]) r.fail(tr["band_hz"], "tremor.band_hz", what);
    r.fail(root["rate_hz"], "rate_hz", what);
  }
  return plan;
}

std::vector<std::string> plan_rate_warnings(const SynthPlan& plan) {
  constexpr double kPeakOverMean = 15.0 / 8.0;  // ds/dtau of minimum_jerk at tau = 1/2
  const auto& w = plan.waypoints;
  auto distance = [&w](std::size_t i) { return norm(w[i].position - w[i - 1].position); };
  auto angle = [&w](std::size_t i) { return norm(rotvec_from_quat(conjugate(w[i - 1].orientation) * w[i].orientation)); };
  auto fastest = [&w](auto change, double limit) {  // {the segment's end (0: none over), its peak rate}
    std::pair<std::size_t, double> f{0, limit};
    for (std::size_t i = 1; i < w.size(); ++i)
      if (const double r = kPeakOverMean * change(i) / (w[i].t - w[i - 1].t); r > f.second) f = {i, r};
    return f;
  };
  std::vector<std::string> out;
  char line[400];
  if (const auto [i, rate] = fastest(distance, kToolSpeedMax); i > 0) {
    std::snprintf(line, sizeof line,
                  "%s: waypoints[%zu] -> waypoints[%zu] (t = %g .. %g s) move the tool %.4g mm at up to %.3g m/s (a hand "
                  "moves it at under 1 m/s): t is in seconds, position_mm in millimetres",
                  plan.file.c_str(), i - 1, i, w[i - 1].t, w[i].t, distance(i) * 1e3, rate);
    out.emplace_back(line);
  }
  if (const auto [i, rate] = fastest(angle, kToolTurnRateMax); i > 0) {
    std::snprintf(line, sizeof line,
                  "%s: waypoints[%zu] -> waypoints[%zu] (t = %g .. %g s) turn the tool %.4g degrees at up to %.3g rad/s (a "
                  "hand turns it at a few): t is in seconds, rotvec_deg in degrees",
                  plan.file.c_str(), i - 1, i, w[i - 1].t, w[i].t, angle(i) * 180 / std::numbers::pi, rate);
    out.emplace_back(line);
  }
  return out;
}

double minimum_jerk(double tau) {
  tau = std::clamp(tau, 0.0, 1.0);
  double t3 = tau * tau * tau;
  return t3 * (10.0 + tau * (-15.0 + 6.0 * tau));
}

DeviceSample plan_pose(const SynthPlan& plan, double t) {
  const auto& w = plan.waypoints;
  DeviceSample d;
  d.t = t;
  auto at = [&](const PlanWaypoint& p) {
    d.position = p.position;
    d.orientation = p.orientation;
    d.jaw = p.jaw;
    d.buttons = p.buttons;
    return d;
  };
  if (w.empty()) return d;
  if (t <= w.front().t) return at(w.front());
  if (t >= w.back().t) return at(w.back());
  auto it = std::upper_bound(w.begin(), w.end(), t, [](double x, const PlanWaypoint& p) { return x < p.t; });
  const PlanWaypoint& b = *it;
  const PlanWaypoint& a = *(it - 1);
  double s = minimum_jerk((t - a.t) / (b.t - a.t));
  d.position = a.position + s * (b.position - a.position);
  d.orientation = slerp(a.orientation, b.orientation, s);
  d.jaw = a.jaw + s * (b.jaw - a.jaw);
  d.buttons = a.buttons;
  return d;
}

Tremor::Tremor(const SynthPlan& plan, std::uint64_t seed) {
  SplitMix64 rng{seed};
  const int k = plan.tremor_components;
  const double amp = plan.tremor_amplitude / std::sqrt(static_cast<double>(k));
  for (auto& axis : axes_)
    for (int i = 0; i < k; ++i) {
      double f = plan.tremor_band_lo + (plan.tremor_band_hi - plan.tremor_band_lo) * rng.uniform();
      double phase = 2.0 * std::numbers::pi * rng.uniform();
      axis.push_back({amp, 2.0 * std::numbers::pi * f, phase});
    }
}

Vec3d Tremor::operator()(double t) const {
  Vec3d v;
  for (int a = 0; a < 3; ++a)
    for (const auto& c : axes_[a]) v[a] += c.amplitude * std::sin(c.omega * t + c.phase);
  return v;
}

Recording synthesize(const SynthPlan& plan, std::uint64_t seed) {
  if (plan.waypoints.empty()) throw InputError("synthesize: the plan has no waypoints");
  Tremor tremor(plan, seed);
  Recording rec;
  rec.rate_hz = plan.rate_hz;
  rec.source = "synthetic";
  rec.scene = plan.scene;
  rec.tool = plan.tool;
  rec.description = plan.description;
  // 1e-9 guards t_last * rate landing a hair below an integer (10 s * 1000 Hz).
  const double t_last = plan.waypoints.back().t;
  const double count = std::floor(t_last * plan.rate_hz + 1e-9) + 1;
  const std::string where = plan.file.empty() ? std::string("synth") : plan.file;
  if (!(count <= kMaxRecordingSamples))
    throw InputError(where + ": the last waypoint at t = " + num(t_last) + " s sampled at " + num(plan.rate_hz) +
                     " Hz makes " + num(count) + " samples; the limit is " + num(kMaxRecordingSamples) +
                     " samples (a shorter plan or a lower rate)");
  if (count < 2)
    throw InputError(where + ": the waypoints span " + num(t_last) + " s, less than one sample interval at " +
                     num(plan.rate_hz) + " Hz; a recording needs at least two samples");
  const auto n = static_cast<std::size_t>(count);
  rec.t.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    double t = static_cast<double>(i) / plan.rate_hz;
    DeviceSample d = plan_pose(plan, t);
    Vec3d p = d.position + tremor(t);
    if (plan.quantum > 0)
      for (int a = 0; a < 3; ++a) p[a] = std::round(p[a] / plan.quantum) * plan.quantum;
    rec.t.push_back(t);
    rec.position.push_back(p);
    rec.orientation.push_back(d.orientation);
    rec.jaw.push_back(d.jaw);
    rec.buttons.push_back(d.buttons);
  }
  return rec;
}

}  // namespace ebh
