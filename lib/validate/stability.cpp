// `stability`: the stress matrix of the physical solver on meshes users bring. Each case replays a
// window of a committed recording (async, the scene's rates) on
//   mesh       the scene's own, or with interior vertices moved until the worst tet has a mean
//              ratio of 0.05, 0.02 or 0.01 (mesh/degrade.hpp: caps, slivers, needles)
//   stiffness  k_vol times 0.01, 1 or 100
//   method     jacobi, chebyshev (both with the scene's diagonal, bounded by default) or direct
//   motion     the recording, the same sped up until the tool's peak speed is 1 m/s, or a
//              teleport: halfway through, the device jumps 10 mm towards the mesh's centre
// and counts what went wrong: non-finite states and blow-ups (the replay's health checks,
// schedule/simulation.hpp: check_physical_step), the cases the recovery rescued (steps redone with
// the direct solve, CPU backend) and the deepest penetration of the virtual tool.
// It also compares the force of each iterative case with the direct solve's on the same mesh,
// stiffness and motion (RMS over the window; -1 where either stopped).
// Passed when no case is non-finite or blows up. The short form (the default, ~1 minute on two
// cores) takes tube_insert and gap_insert, the 0.02 mesh, chebyshev; --full every committed
// recording and every value above (long: about an hour on two cores); --recording NAME (repeated)
// replaces the list of recordings.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "mesh/degrade.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"
#include "validate/validation.hpp"

namespace ebh {
namespace {

constexpr double kWindow = 0.3;        // s of each recording replayed
constexpr double kTeleport = 0.01;     // m
constexpr double kFastSpeed = 1.0;     // m/s

/// Records the force per tick, the deepest penetration and the steps the recovery redid.
struct Trace : ReplayObserver {
  std::vector<Vec3d> force;
  double penetration = 0;
  int recovered = 0;
  long contact_ticks = 0;
  void on_tick(const World&, const HapticSide& h, double) override {
    force.push_back(h.output.force);
    penetration = std::max(penetration, h.penetration);
    contact_ticks += h.contact_count > 0;
  }
  void on_step(const World&, const PhysicalSide& p, double) override { recovered += p.recovered ? 1 : 0; }
};

/// The window of `rec` a case replays: kWindow s from 40% of the recording (where the committed
/// recordings are in contact), sped up or with a teleport.
Recording window(const Recording& rec, const std::string& motion, const Vec3d& centre) {
  Recording r = rec;
  const double t0 = rec.start_time() + 0.4 * rec.duration();
  double speed = 0;  // the peak device speed inside the window at the recorded pace
  for (std::size_t i = 1; i < rec.t.size(); ++i)
    if (rec.t[i] >= t0 && rec.t[i] <= t0 + kWindow && rec.t[i] > rec.t[i - 1])
      speed = std::max(speed, norm(rec.position[i] - rec.position[i - 1]) / (rec.t[i] - rec.t[i - 1]));
  const double factor = motion == "fast" && speed > 0 ? std::max(1.0, kFastSpeed / speed) : 1.0;
  for (std::size_t i = 0; i < r.t.size(); ++i) {
    r.t[i] = t0 + (rec.t[i] - t0) / factor;
    if (motion == "teleport" && rec.t[i] >= t0 + 0.5 * kWindow)
      r.position[i] += kTeleport * normalized(centre - rec.position[i]);
  }
  // Keep the samples from t0 on (the replay starts at the recording's first sample).
  std::size_t a = 0;
  while (a + 2 < r.t.size() && r.t[a + 1] <= t0) ++a;
  auto cut = [&](auto& v) { v.erase(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(a)); };
  cut(r.t); cut(r.position); cut(r.orientation); cut(r.jaw); cut(r.buttons);
  return r;
}

struct Outcome {
  bool nonfinite = false, blowup = false;
  int recovered = 0;  ///< physical steps redone with the direct solve (CPU backend)
  std::string error;
  double penetration = 0;
  long contact_ticks = 0;
  std::vector<Vec3d> force;
};

/// The scene of `rec` with the case's mesh, stiffness and method.
Scene case_scene(const Recording& rec, double quality, double stiffness, const std::string& method,
                 const std::vector<std::string>& overrides, Vec3d* centre) {
  const std::vector<std::string> all = with_matrix_values(overrides, {"solver.method=" + method});
  Scene scene = load_scene(resolve_scene_path(rec.scene), all);
  scene.spec.stiffness.k_vol *= stiffness;
  if (quality < 1) {
    DegradeOptions d;
    d.target_quality = quality;
    degrade_physical_mesh(scene, d);
  }
  *centre = Vec3d{};
  for (const Vec3d& v : scene.physical.vertices) *centre += v / static_cast<double>(scene.physical.vertices.size());
  return scene;
}

/// Replays every motion on one world (its building, settling included, is most of a case's cost).
std::vector<Outcome> run_motions(const Recording& rec, double quality, double stiffness, const std::string& method,
                                 const std::vector<std::string>& motions, const std::vector<std::string>& overrides,
                                 Backend backend) {
  std::vector<Outcome> out(motions.size());
  Vec3d centre;
  Scene scene = case_scene(rec, quality, stiffness, method, overrides, &centre);
  const double hz_h = scene.spec.haptic_hz, hz_p = scene.spec.physical_hz;
  std::shared_ptr<const World> world;
  std::string build_error;
  try {
    world = build_world(std::move(scene), hz_h, hz_p, method == "direct" ? Backend::Cpu : backend);
  } catch (const NumericalError& e) {  // settling under gravity blew up
    build_error = e.what();
  }
  for (std::size_t i = 0; i < motions.size(); ++i) {
    Outcome& o = out[i];
    Trace trace;
    try {
      if (!world) throw NumericalError(build_error);
      ReplayOptions opt;
      opt.duration = kWindow;
      replay(*world, window(rec, motions[i], centre), opt, trace);
    } catch (const NumericalError& e) {
      o.error = e.what();
      (o.error.find("not finite") != std::string::npos ? o.nonfinite : o.blowup) = true;
    }
    o.penetration = trace.penetration;
    o.contact_ticks = trace.contact_ticks;
    o.recovered = trace.recovered;
    o.force = std::move(trace.force);
  }
  return out;
}

double force_rms(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  const std::size_t n = std::min(a.size(), b.size());
  double s = 0;
  for (std::size_t i = 0; i < n; ++i) s += squared_norm(a[i] - b[i]);
  return n ? std::sqrt(s / static_cast<double>(n)) : 0.0;
}

ValidationResult run_stability(const ValidationOptions& options) {
  std::vector<std::string> recordings = {"tube_insert", "gap_insert"};
  std::vector<double> qualities = {0.02}, stiffnesses = {0.01, 1, 100};
  std::vector<std::string> methods = {"chebyshev"}, motions = {"recorded", "fast", "teleport"};
  if (options.full) {
    recordings = {"tube_insert", "tube_grasp", "gap_insert", "gap_grasp", "cholecystectomy_press",
                  "cholecystectomy_grasp", "gynaecology_press", "gynaecology_grasp"};
    qualities = {1, 0.05, 0.02, 0.01};
    methods = {"jacobi", "chebyshev"};
  }
  if (!options.recordings.empty()) recordings = options.recordings;
  const Backend backend = options.backend == "cuda" ? Backend::Cuda : Backend::Cpu;
  ValidationResult r;
  r.name = "stability";
  int cases = 0, nonfinite = 0, blowups = 0, recovered_cases = 0;
  double max_penetration = 0, max_rms = 0;
  Json rows = Json::array();
  for (const std::string& name : recordings) {
    const std::string path = resolve_recording_path(name);
    Recording rec = read_recording(path);
    rec.scene = resolve_recording_scene(rec.scene, path).string();  // a scene file beside the recording
    apply_stored_transforms(rec, path);
    // The cases replay kWindow s from 40% of the recording, in contact there (the committed ones
    // are): a recording given that is shorter, or whose tool touches nothing there, checks nothing
    // of contact.
    const double t0 = rec.start_time() + 0.4 * rec.duration();
    char span[160];
    std::snprintf(span, sizeof span, "the matrix replays %g s from 40%% of each recording (t = %.6g .. %.6g s)", kWindow, t0,
                  t0 + kWindow);
    if (rec.start_time() + rec.duration() < t0 + kWindow)
      throw InputError("--recording " + name + ": " + path + " is " + shown_number(rec.duration()) + " s long, and " + span +
                       ": give a longer recording");
    bool touched = false;
    for (double q : qualities)
      for (double k : stiffnesses) {
        // The direct solve on the same mesh, stiffness and motions: the force reference.
        const std::vector<Outcome> direct = run_motions(rec, q, k, "direct", motions, options.overrides, backend);
        touched = touched || std::any_of(direct.begin(), direct.end(), [](const Outcome& o) { return o.contact_ticks > 0; });
        if (!touched && !options.recordings.empty())
          throw InputError("--recording " + name + ": " + path + ": the tool touches no tissue where " + span +
                           ", so its cases check nothing of contact: give a recording in contact there");
        for (const std::string& method : methods) {
          const std::vector<Outcome> outcomes = run_motions(rec, q, k, method, motions, options.overrides, backend);
          for (std::size_t i = 0; i < motions.size(); ++i) {
            const Outcome& o = outcomes[i];
            ++cases;
            nonfinite += o.nonfinite;
            blowups += o.blowup;
            recovered_cases += o.recovered > 0;
            max_penetration = std::max(max_penetration, o.penetration);
            const double rms = o.error.empty() && direct[i].error.empty() ? force_rms(o.force, direct[i].force) : -1.0;
            max_rms = std::max(max_rms, rms);
            Json row = Json::object();
            row.set("recording", name);
            row.set("quality", q);
            row.set("k_vol_factor", k);
            row.set("method", method);
            row.set("motion", motions[i]);
            row.set("ticks", static_cast<long long>(o.force.size()));
            row.set("nonfinite", o.nonfinite);
            row.set("blowup", o.blowup);
            row.set("recovered_steps", o.recovered);
            row.set("error", o.error);
            row.set("max_penetration_m", o.penetration);
            row.set("force_rms_vs_direct_N", rms);
            rows.push(std::move(row));
          }
        }
      }
  }
  r.error = nonfinite + blowups;
  r.tolerance = 0;
  r.passed = nonfinite == 0 && blowups == 0;
  r.summary = std::to_string(nonfinite + blowups) + " of " + std::to_string(cases) +
              " cases non-finite or blown up (" + std::to_string(recovered_cases) + " recovered by the health checks)";
  r.data = Json::object();
  r.data.set("form", options.full ? "full" : "short");
  r.data.set("backend", options.backend);
  r.data.set("overrides", Json::array_of(options.overrides));
  r.data.set("window_s", kWindow);
  r.data.set("cases", cases);
  r.data.set("nonfinite", nonfinite);
  r.data.set("blowups", blowups);
  r.data.set("recovered_cases", recovered_cases);
  r.data.set("max_penetration_m", max_penetration);
  r.data.set("max_force_rms_vs_direct_N", max_rms);
  r.data.set("criterion", "no case non-finite or blown up (the replay's health checks)");
  r.data.set("cases_detail", rows);
  return r;
}

}  // namespace

Validation stability_validation() {
  return {"stability",
          "replays on sliver meshes x stiffness x solver x tool speed: counts non-finite states and blow-ups",
          run_stability, /*replays_recordings=*/true, /*has_full_form=*/true, /*places_solvers=*/true,
          /*varied_keys=*/{"solver.method"}};
}

}  // namespace ebh
