#pragma once
// `ebh bench sizes`: what a replay costs as the physical mesh grows. The scene is refined uniformly
// (scene/scene_refine.hpp: 8x the tets a level, written to a temporary folder and loaded as any
// scene file) and a window of a recording is replayed at each size through the scheduler
// (schedule/scheduler.hpp), as `ebh replay` would; each size reports the physical step and the
// haptic tick (median, 99th percentile), the replay's real-time factor, and the peak host and
// device memory; each cost gets the slope of its least-squares line against the tet count in
// log-log (1: linear in the mesh size).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "schedule/scheduler.hpp"

namespace ebh {

struct SizeBenchOptions {
  std::string scene;       ///< name or path
  std::string recording;   ///< name or path
  double start = 0;        ///< s into the recording
  double seconds = 1;      ///< s of the recording replayed at each size
  int first_level = 0, last_level = 2;
  Mode mode = Mode::Async;  ///< a virtual-time mode (async or lockstep)
  Backend backend = Backend::Cpu;
  std::int64_t max_tets = 0;  ///< refuse sizes above this (0: scene_refine.hpp's kMaxRefinedTets)
  /// "dotted.key=value" scene overrides (the command line's --set), applied to every size's scene
  /// as it is loaded (the refinement refines the scene file's own meshes).
  std::vector<std::string> overrides;
  /// Refine only the physical mesh; the virtual mesh keeps the scene's resolution (refine_scene's
  /// keep_virtual).
  bool keep_virtual = false;
};

/// Median and 99th percentile of a per-tick or per-step time (s).
struct TimeStats {
  double median = 0, p99 = 0;
};

struct SizeResult {
  int level = 0;
  std::int64_t tets = 0, vertices = 0;  ///< the physical mesh
  std::int64_t virtual_vertices = 0;    ///< the virtual mesh (after virtual_refine)
  TimeStats physical_step, haptic_tick;  ///< physical_step: over the steps that ran (not skipped)
  std::int64_t ticks = 0, steps = 0;
  std::int64_t skipped_steps = 0;  ///< steps skipped, the state held (solver.sleep, solver.physical_region)
  double wall_s = 0, virtual_s = 0;
  double real_time_factor = 0;          ///< virtual_s / wall_s
  double load_s = 0;                    ///< loading the scene and building the world (settling included)
  /// Peak resident memory of the process while the size loaded and replayed (bytes): /proc's
  /// VmHWM after resetting it (clear_refs) before the size; where that reset is refused, the
  /// process's peak so far (getrusage), and host_peak_reset is false.
  std::int64_t host_peak_bytes = 0;
  bool host_peak_reset = true;
  /// --backend cuda: the largest drop of the device's free memory during the run from before the
  /// size loaded (cudaMemGetInfo on the first tick and every 100th); -1 on the CPU backend.
  std::int64_t device_peak_bytes = -1;
  std::int64_t contact_ticks = 0;        ///< ticks with a contact: 0 is free motion, not rendering
  /// What `ebh replay` warns of these inputs (a recording made for another scene, a unit off; one
  /// line each), for the first size measured only (the refined scenes repeat them).
  std::vector<std::string> warnings;
};

/// The slope b of log(cost) = a + b log(tets), least squares over the sizes with a positive cost;
/// NaN with fewer than two such sizes or a single distinct tet count.
double log_log_slope(const std::vector<double>& tets, const std::vector<double>& cost);

/// The costs of SizeResult that get a slope, in this order, with their names in the table, JSON
/// and plot: physical step median, haptic tick median, replay wall time per virtual second, peak
/// host memory, peak device memory.
struct SizeCost {
  const char* key;    ///< JSON key of the slope
  const char* label;  ///< words for the table and plot legend
  double (*value)(const SizeResult&);
};
const std::vector<SizeCost>& size_costs();

/// The window check_size_bench found: the recording's file and the seconds each size replays
/// (options.seconds, or fewer where the recording ends sooner, as `ebh replay` cuts its window).
struct SizeBenchWindow {
  std::string recording;
  double seconds = 0;
};

/// The checks run_size_bench makes before any work (an InputError naming the option, the key or
/// the file): levels, mode, seconds, the scene with its overrides, the recording, the window, the
/// largest size.
SizeBenchWindow check_size_bench(const SizeBenchOptions& o);

/// Runs the sizes first_level .. last_level in turn (the level-0 scene as it is). `progress`, when
/// set, is told each size's line as it completes. Throws InputError before any work for a bad
/// level range, a size above the limit, a mode other than async or lockstep, or a bad scene or
/// recording (as `ebh replay` would).
std::vector<SizeResult> run_size_bench(const SizeBenchOptions& options,
                                       void (*progress)(const SizeResult&) = nullptr);

}  // namespace ebh
