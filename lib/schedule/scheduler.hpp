#pragma once
// Who runs when (docs/MODEL.md, "Between the two rates"). Tick n is at t_n = n h_h; the device sample of tick n is the
// recording interpolated at t_n. Physical step k starts at tick k N (N = h_p / h_h):
//   async     (default, the paper's system) it starts from the haptic side's snapshot at tick kN
//             and its result becomes visible at tick (k+1)N, as a concurrent solver thread would
//             deliver it. It does run on a second thread, overlapping the N ticks, but its
//             inputs and delivery tick are fixed, so the replay is bitwise reproducible.
//   lockstep  its result is visible at once (no latency): the reference for accuracy studies.
//   realtime  the two sides run on two threads paced by the wall clock, exchanging
//             double-buffered snapshots; it measures achievable rates and is not deterministic.
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "schedule/simulation.hpp"
#if EBH_HAVE_CUDA
#include "schedule/haptic_cuda.hpp"
#endif

namespace ebh {

enum class Mode { Async, Lockstep, Realtime };

/// Parses "async" | "lockstep" | "realtime"; throws InputError naming the option otherwise.
Mode parse_mode(const std::string& s);
const char* mode_name(Mode m);

struct ReplayOptions {
  Mode mode = Mode::Async;
  double start = 0;       ///< s into the recording where tick 0 is (a window of a long recording)
  double duration = 0;    ///< s of the recording to replay from `start`; <= 0: all the rest
  double frames_hz = 0;   ///< mesh snapshots per second; 0: none
  /// realtime only: false lets the physical side step as fast as it can (the paper's "Sim FPS"
  /// of Table 1) instead of once per h_p of wall time.
  bool pace_physical = true;
  /// --backend cuda, async and lockstep: the whole haptic tick on the device where the tool allows
  /// it (device_haptic_supported, schedule/haptic_cuda.hpp); false keeps the virtual tool on the
  /// host and only the virtual mesh's iterations on the device (for comparisons).
  bool device_tick = true;
  /// The device tick in async mode without mesh frames: the physical steps run inside launches of
  /// many periods (CudaHapticTicks::run_ticks_with_steps); false launches once per period with the
  /// steps between the launches (the same bits; for comparisons).
  bool steps_in_launches = true;
  /// The device tick's blocks at most (DeviceHapticSetup::max_blocks), which then may share a
  /// multiprocessor (DeviceTickCapacity::blocks_per_sm_shared); 0: one per chunk of the virtual
  /// mesh, as many as the device holds. replay_batch shares the device this way; the results do
  /// not depend on it (bitwise).
  int device_blocks = 0;
  /// --backend cpu, async and realtime: the OpenMP threads of the haptic side (its virtual-mesh
  /// passes, solver/virtual_mesh.hpp's virtual_team); the physical step gets the rest of
  /// omp_get_max_threads(). 0: half of them, rounded up (one each on two cores). Lockstep gives
  /// both sides every thread. The results do not depend on it (bitwise).
  int haptic_threads = 0;
};

/// OpenMP threads for each side of a CPU replay. In lockstep the sides take turns and each may use
/// every core; in async and realtime they run at once, so they split the cores (more threads than
/// cores would leave OpenMP's spinning barriers waiting on descheduled threads): the haptic side
/// takes `haptic_threads` of them (ReplayOptions; 0: half, rounded up: a period's ticks outweigh
/// its physical step on every committed scene) and the physical step the rest, one at least.
/// Results do not depend on these counts (bitwise, tests/solver, tests/schedule).
/// Async with a core for each side: a side with one thread shares its loops with the other side's
/// thread while that one would wait (solver/shared_loops.hpp; docs/MODEL.md, "Threads of a CPU
/// replay"): the physical step's (shared_physical_loops) and the virtual mesh's passes
/// (shared_virtual_loops). Both on two cores; neither with one OpenMP thread in all.
struct ThreadSplit {
  int haptic = 1, physical = 1;
  bool shared_physical_loops = false, shared_virtual_loops = false;
};
ThreadSplit split_threads(Mode mode, int haptic_threads);

/// What a replay reports as it goes (the HDF5 writer and the progress bar implement it).
class ReplayObserver {
 public:
  virtual ~ReplayObserver() = default;
  /// After tick n (virtual time t = n h_h).
  virtual void on_tick(const World&, const HapticSide&, double /*t*/) {}
  /// After physical step k finished (virtual time t at which it started).
  virtual void on_step(const World&, const PhysicalSide&, double /*t*/) {}
  /// A mesh snapshot at virtual time t (physical: the physical side's visible result).
  virtual void on_frame(const World&, const HapticSide&, double /*t*/) {}
  /// Polled once per tick, and during a CPU physical step (async: from its thread) every
  /// kCancelPollIterations iterations; returning true stops the replay (e.g. an interrupt) and
  /// the step in flight, whose result is then not reported.
  virtual bool should_stop() { return false; }
};

struct ReplaySummary {
  std::int64_t ticks = 0;
  std::int64_t steps = 0;
  double virtual_s = 0;   ///< replayed virtual time: replayed_seconds(ticks, h_haptic)
  double wall_s = 0;
  bool stopped = false;   ///< ended early by should_stop()
};

/// Virtual time `ticks` ticks replay: they sample the recording at 0, h, .., (ticks - 1) h, so
/// a window of D seconds (tick_count: D / h + 1 ticks) replays D seconds, not D + h.
inline double replayed_seconds(std::int64_t ticks, double h_haptic) {
  return ticks > 1 ? static_cast<double>(ticks - 1) * h_haptic : 0.0;
}

/// The most ticks one replay runs (docs/FORMATS.md, Limits): 10 million is 2.8 hours at 1 kHz; the
/// output writer holds ~258 bytes per tick in memory (2.6 GB at the limit).
inline constexpr double kMaxReplayTicks = 10e6;

/// Number of ticks a replay of `duration` seconds runs: ticks 0 .. floor(duration / h_h). Throws
/// InputError beyond kMaxReplayTicks (check_replay_size, replay_output.hpp, says it better first).
std::int64_t tick_count(const World& world, double duration);

#if EBH_HAVE_CUDA
/// What a device replay (--backend cuda, haptic_cuda.hpp) of ticks 0 .. ticks-1 starting at recording
/// time t0 needs: each tick's inputs (device sample, the E_svc blend for `mode`, grasp events) and
/// the setup of the device tick (the world's models and start state, the grasps' hard boxes).
struct DeviceReplayInputs {
  std::vector<DeviceTickInput> ticks;
  std::vector<DeviceSample> samples;  ///< each tick's device sample (what the observer reads)
  DeviceHapticSetup setup;  ///< refers to `world`'s data
};
DeviceReplayInputs device_replay_inputs(const World& world, const Recording& rec, double t0, std::int64_t ticks,
                                        Mode mode);
#endif

/// Replays `recording` through the two-rate solver.
ReplaySummary replay(const World& world, const Recording& recording, const ReplayOptions& options,
                     ReplayObserver& observer);

/// One replay of a batch (replay_batch).
struct BatchReplay {
  const World* world = nullptr;          ///< built with Backend::Cuda
  const Recording* recording = nullptr;
  ReplayOptions options;                 ///< async, device_tick, steps_in_launches, no frames
  ReplayObserver* observer = nullptr;
};

struct BatchOutcome {
  ReplaySummary summary;
  std::string error;  ///< empty: the replay ran to its end (or its observer stopped it)
};

/// Replays several device replays in one process on one GPU (docs/CUDA.md, "Many replays on one
/// GPU"): every replay is set up first, then `at_once` of them run side by side, the next starting
/// when one ends. Each has its own streams, tick kernel and physical steps; the device's resident
/// tick blocks are split between those that run at once (ReplayOptions::device_blocks), and the
/// calling thread feeds them in turn, one launch of ~100 ticks each. Each replay's outputs are
/// bitwise those of the same replay run alone. A replay that fails (its error in its outcome)
/// leaves the others running. Throws InputError naming the replay (its index) when one cannot run
/// this way, when at_once is more than the device holds, or without the CUDA backend.
/// The fastest measured, with 32 hardware queues (CUDA_DEVICE_MAX_CONNECTIONS, which `ebh` sets;
/// with the driver's 8 the replays' streams share queues and 2 at once is faster: docs/CUDA.md).
inline constexpr int kBatchAtOnce = 8;
std::vector<BatchOutcome> replay_batch(std::span<const BatchReplay> replays, int at_once = kBatchAtOnce);

/// The most replays replay_batch runs at once for this world (every replay's tick kernel needs at
/// least 2 resident blocks, and the physical steps a share of the device beside them); 0 without
/// the CUDA backend.
int max_batch_replays(const World& world);

}  // namespace ebh
