// `ebh bench sizes` (bench/size_bench.hpp).
#include "bench/size_bench.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "core/error.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "mesh/mesh_io.hpp"
#include "metrics/signal.hpp"
#include "scene/scene.hpp"
#include "scene/scene_refine.hpp"
#include "schedule/replay_inputs.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif

namespace ebh {
namespace {

namespace fs = std::filesystem;

/// Resets the kernel's peak resident size of this process to its current size (Linux: writing 5 to
/// /proc/self/clear_refs); false where that is refused.
bool reset_host_peak() {
  std::ofstream f("/proc/self/clear_refs");
  if (!f) return false;
  f << "5";
  f.flush();
  return static_cast<bool>(f);
}

/// The process's peak resident size (bytes): VmHWM, else getrusage's ru_maxrss.
std::int64_t host_peak() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return 1024 * std::stoll(line.substr(6));  // "VmHWM:   1234 kB"
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1024 * static_cast<std::int64_t>(u.ru_maxrss);  // kilobytes on Linux
}

/// Collects the tick and step times and samples the device's free memory.
class SizeObserver : public ReplayObserver {
 public:
  std::vector<double> tick_s, step_s;  ///< step_s: the steps that ran
  std::int64_t contact_ticks = 0, skipped_steps = 0;
  std::size_t device_free_min = std::numeric_limits<std::size_t>::max();
  explicit SizeObserver(bool device) : device_(device) {}
  void on_tick(const World&, const HapticSide& h, double) override {
    tick_s.push_back(h.timing.total);
    contact_ticks += h.contact_count > 0;
    if (h.tick % 100 == 1) sample_device();  // h.tick is the next tick: 1 after the first
  }
  void on_step(const World&, const PhysicalSide& p, double) override {
    // A skipped step (solver.sleep, an empty awake region) costs nothing and is no step's cost: its
    // 0 s made the median 0 where most steps slept.
    if (p.slept) ++skipped_steps;
    else step_s.push_back(p.report.time_s);
    sample_device();
  }
  /// An interrupt (io/atomic.hpp's handlers, installed when the first refined scene is written)
  /// ends the size; run_size_bench then stops and removes its temporary folder.
  bool should_stop() override { return interrupted(); }

 private:
  void sample_device() {
#if EBH_HAVE_CUDA
    if (device_) device_free_min = std::min(device_free_min, cuda_memory_info().free);
#endif
  }
  bool device_;
};

TimeStats stats(std::vector<double> v) {
  if (v.empty()) return {NAN, NAN};
  TimeStats s;
  s.median = percentile(v, 50.0);
  s.p99 = percentile(std::move(v), 99.0);
  return s;
}


SizeResult measure(const SizeBenchOptions& o, const std::string& scene, int level) {
  SizeResult r;
  r.level = level;
  r.host_peak_reset = reset_host_peak();
#if EBH_HAVE_CUDA
  const bool device = o.backend == Backend::Cuda;
  const std::size_t free_before = device ? cuda_memory_info().free : 0;
#else
  const bool device = false;
#endif
  const auto t0 = std::chrono::steady_clock::now();
  const LoadedReplay in = load_replay_inputs(scene, o.recording, o.overrides, std::nullopt, std::nullopt, false, o.backend,
                                            {}, RecordingWindow{o.start, o.seconds});
  r.load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const World& w = *in.world;
  r.tets = static_cast<std::int64_t>(w.scene.physical.tets.size());
  r.vertices = static_cast<std::int64_t>(w.scene.physical.vertices.size());
  r.virtual_vertices = static_cast<std::int64_t>(w.initial_virtual.size());
  replay_window(o.start, o.seconds, in.recording.duration(), w.h_haptic, in.recording_path, "--start", "--seconds");
  ReplayOptions ro;
  ro.mode = o.mode;
  ro.start = o.start;
  ro.duration = o.seconds;
  SizeObserver obs(device);
  obs.tick_s.reserve(static_cast<std::size_t>(o.seconds / w.h_haptic) + 2);
  const ReplaySummary s = replay(w, in.recording, ro, obs);
  if (s.stopped) throw InputError("interrupted at level " + std::to_string(level) + "; no results");
  r.physical_step = stats(std::move(obs.step_s));
  r.haptic_tick = stats(std::move(obs.tick_s));
  r.ticks = s.ticks;
  r.steps = s.steps;
  r.skipped_steps = obs.skipped_steps;
  r.contact_ticks = obs.contact_ticks;
  if (level == o.first_level) r.warnings = in.warnings;
  r.wall_s = s.wall_s;
  r.virtual_s = s.virtual_s;
  r.real_time_factor = s.wall_s > 0 ? s.virtual_s / s.wall_s : 0;
  r.host_peak_bytes = host_peak();
#if EBH_HAVE_CUDA
  if (device && obs.device_free_min <= free_before)
    r.device_peak_bytes = static_cast<std::int64_t>(free_before - obs.device_free_min);
  else if (device)
    r.device_peak_bytes = 0;
#endif
  return r;
}

}  // namespace

double log_log_slope(const std::vector<double>& tets, const std::vector<double>& cost) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (std::size_t i = 0; i < tets.size() && i < cost.size(); ++i) {
    if (!(tets[i] > 0 && cost[i] > 0 && std::isfinite(cost[i]))) continue;
    const double x = std::log(tets[i]), y = std::log(cost[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    ++n;
  }
  const double d = n * sxx - sx * sx;
  if (n < 2 || !(d > 1e-12 * n * sxx)) return NAN;
  return (n * sxy - sx * sy) / d;
}

const std::vector<SizeCost>& size_costs() {
  static const std::vector<SizeCost> costs = {
      {"physical_step_median", "physical step", [](const SizeResult& r) { return r.physical_step.median; }},
      {"haptic_tick_median", "haptic tick", [](const SizeResult& r) { return r.haptic_tick.median; }},
      {"wall_per_virtual_second", "wall per virtual s",
       [](const SizeResult& r) { return r.virtual_s > 0 ? r.wall_s / r.virtual_s : NAN; }},
      {"host_peak_bytes", "host memory", [](const SizeResult& r) { return static_cast<double>(r.host_peak_bytes); }},
      {"device_peak_bytes", "device memory",
       [](const SizeResult& r) { return r.device_peak_bytes >= 0 ? static_cast<double>(r.device_peak_bytes) : NAN; }},
  };
  return costs;
}

SizeBenchWindow check_size_bench(const SizeBenchOptions& o) {
  if (o.first_level < 0 || o.last_level < o.first_level)
    throw InputError("--levels: expected FIRST-LAST with 0 <= FIRST <= LAST, got " + std::to_string(o.first_level) + "-" +
                     std::to_string(o.last_level));
  if (o.mode == Mode::Realtime)
    throw InputError("--mode: expected async or lockstep (a size's costs are measured in virtual time), got realtime");
  if (!(o.seconds > 0)) throw InputError("--seconds: expected a number > 0");
  if (o.last_level > 0) (void)temporary_directory();  // where the refined scenes go: there
  const std::int64_t max_tets = o.max_tets > 0 ? o.max_tets : kMaxRefinedTets;
  const fs::path scene_file = resolve_scene_path(o.scene);
  // Each size is the scene's own meshes refined: an override of a mesh file would replace the
  // refined one at every size (one mesh measured at every level, a null slope) and, relative, is
  // looked for beside the refined scenes' temporary folder.
  for (const std::string& text : o.overrides)
    for (const std::string& key : override_keys(text))
      if (key == "mesh.physical" || key == "mesh.virtual" || key == "mesh")
        throw OverrideError(text, "key '" + key + "': bench sizes refines the scene's own meshes, which this would " +
                                      "replace at every size; give a scene that names this mesh (--scene)");
  (void)replay_input_files(o.scene, o.recording, o.overrides);
  const RecordingFile rec = read_replay_recording(o.recording, RecordingWindow{o.start, o.seconds});  // as a replay checks it
  const SceneSpec spec = load_scene_spec(scene_file, o.overrides);  // a bad override too
  // At the scene's haptic rate (time.haptic_hz, under --set), as each size's world has it.
  const SizeBenchWindow window{rec.path, replay_window(o.start, o.seconds, rec.recording.duration(), 1.0 / spec.haptic_hz,
                                                       rec.path, "--start", "--seconds")};
  TetMesh mesh = read_tet_mesh(spec.physical_mesh);
  std::vector<std::string> said_at_load;  // each size's replay loads its scene and says them
  clean_physical_mesh(mesh, spec, said_at_load);  // as refine_scene refines it
  const RefinedCounts c = refined_counts(mesh, o.last_level);
  if (!refined_within(c, max_tets))
    throw InputError("--levels: level " + std::to_string(o.last_level) + " of " + scene_file.string() + " makes " +
                     (c.tets_estimate < 1e15 ? std::to_string(c.tets) : [&] {
                       char buf[32];
                       std::snprintf(buf, sizeof buf, "%.3g", c.tets_estimate);
                       return std::isfinite(c.tets_estimate) ? std::string(buf) : std::string("over 1e308");
                     }()) +
                     " tets, " +
                     (max_tets < kMaxMeshElements && c.tets_estimate > static_cast<double>(max_tets)
                          ? "over the limit of " + std::to_string(max_tets) +
                                " (--max-tets raises it; `ebh scene refine` says the memory it takes)"
                          : "over the " + std::to_string(kMaxMeshElements) +
                                " tets or vertices a mesh can index (its indices are 32-bit)"));
  // Each level is refined, written and replayed here: the largest must fit this machine's memory.
  const RefineMemory m = refine_memory(c);
  const bool replay_more = m.replay_bytes >= m.write_bytes;
  if (const auto beyond = beyond_machine_memory(replay_more ? m.replay_bytes : m.write_bytes, replay_more ? "replay" : "write"))
    throw InputError("--levels: level " + std::to_string(o.last_level) + " of " + scene_file.string() + " makes " +
                     std::to_string(c.tets) + " tets: " + *beyond);
  return window;
}

std::vector<SizeResult> run_size_bench(const SizeBenchOptions& o, void (*progress)(const SizeResult&)) {
  // Before any work: the scene, the overrides and the recording are good and every size is within the limit.
  (void)check_size_bench(o);
  const std::int64_t max_tets = o.max_tets > 0 ? o.max_tets : kMaxRefinedTets;
  const fs::path scene_file = resolve_scene_path(o.scene);
  install_interrupt_handlers();
  // The refined scenes' folder, before any work (check_size_bench has said a TMPDIR that is no
  // folder); level 0 alone, the scene as it is, needs none.
  std::optional<TemporaryFolder> folder;
  if (o.last_level > 0)
    folder.emplace("ebh-sizes-" + std::to_string(::getpid()) + "-", "the folder for the refined scenes");
  // The first device replay of a process loads the kernels and reserves their local memory (170 MB
  // on an H100 for the tube): a short replay of the scene first keeps that out of the first size.
  if (o.backend == Backend::Cuda) {
    SizeBenchOptions warm = o;
    warm.seconds = std::min(o.seconds, 0.05);
    (void)measure(warm, scene_file.string(), 0);
  }
  std::vector<SizeResult> out;
  for (int level = o.first_level; level <= o.last_level; ++level) {
    std::string scene = scene_file.string();
    std::vector<std::string> written;
    if (level > 0) {
      const fs::path refined_file = folder->path() / ("level" + std::to_string(level) + ".yaml");
      const RefinedScene r = refine_scene(scene_file, level, refined_file, max_tets, o.scene, o.keep_virtual);
      // Registered with the folder: a run that ends at an interrupt's grace (a large level's load
      // does not poll it) leaves none of them behind.
      std::vector<std::pair<std::string, std::string_view>> files = {
          {folder->file(r.mesh_file.filename().string()).string(), r.mesh_text}};
      if (!r.virtual_file.empty())
        files.push_back({folder->file(r.virtual_file.filename().string()).string(), r.virtual_text});
      files.push_back({folder->file(r.scene_file.filename().string()).string(), r.scene_yaml});
      write_files_atomically(files);
      for (const auto& f : files) written.push_back(f.first);
      scene = refined_file.string();
    }
    out.push_back(measure(o, scene, level));
    std::error_code ec;
    for (const std::string& f : written) fs::remove(f, ec);  // a large mesh need not wait for the next
    if (progress) progress(out.back());
  }
  return out;
}

}  // namespace ebh
