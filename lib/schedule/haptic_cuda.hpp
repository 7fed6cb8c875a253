#pragma once
// The whole haptic tick on a CUDA device (Algorithm 2 with --backend cuda in the virtual-time
// modes): virtual mesh, vertex-tool collision, grasp and the virtual tool's Newton step, with the
// physical step (CudaPhysicalSolver's device-resident step) exchanging q and x on the device. The
// host only enqueues: a replay is known in advance (the recording), so the device runs ahead and
// the host collects each tick's outputs later. docs/CUDA.md, "Device haptic tick", gives the design;
// docs/PERFORMANCE.md the measured numbers.
//
// A run of ticks is one cooperative kernel; a tick is virtual_iterations steps. Step i is one
// virtual-mesh iteration over all vertices (step 0 also makes the tick's prediction, E_svc targets
// and grasp) with the contact of each vertex against the virtual tool; then block 0 runs the
// virtual tool's Newton step (virtual_tool.hpp) on the vertices that the step can reach, in
// double (after the tick's last newton_calls steps only, when fewer than all). The steps are pipelined: the other blocks run step i + 1 beside the Newton call of
// step i and leave block 0 the vertices that call can reach, whose contacts need its result.
// Sums are fixed-order block reductions; the only atomics are the integer hand-off counters, so
// replays are bitwise reproducible.
//
// Departures from the CPU tick, by round-off only: q and the virtual mesh's update are float32;
// the 6x6 PSD clamp of the contact Hessian is a Jacobi eigen-decomposition in float32 (the CPU uses
// Eigen's in double) unless a Cholesky factorisation shows the matrix positive definite; contact
// and grasp sums run in a fixed order of their own (the CPU's in broad-phase order).
// With surface contact (ToolModel::surface, scene `contact: surface`) the run is another kernel
// (schedule/haptic_cuda_surface.cu): the samples of the virtual mesh's triangles instead of its
// vertices, every step unpipelined.
// Not supported here (the scheduler keeps the host tool, HapticSide::cuda, for them): the
// inverse-normal projection and the realtime mode.
//
// No CUDA types here (pimpl); the class exists when the build has the CUDA backend.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "mesh/tet_mesh.hpp"
#include "solver/physical_mesh_cuda.hpp"
#include "solver/virtual_mesh.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

/// What the host knows of tick n before it runs: the device sample, the E_svc target blend and
/// the grasp event (all functions of the recording and the schedule).
struct DeviceTickInput {
  Vec3d position{};      ///< X_h
  Quatd orientation{};
  double jaw = 1;
  double jaw_cos = 1, jaw_sin = 0;  ///< of the jaws' opening angle clamp(jaw, 0, 1) * jaw_max_angle
  /// physical targets = x_prev + alpha (x_visible - x_prev); 1 = the visible result
  /// (time.interpolate_physical, simulation.cpp: physical_targets).
  double alpha = 1;
  /// 0: none; -1: release; k > 0: grasp with hard box k - 1 of DeviceHapticSetup::grasp_boxes.
  int grasp = 0;
};

/// What tick n produced (HapticSide's outputs).
struct DeviceTickOutput {
  Vec3d force{}, torque{};
  Vec3d position{};      ///< X_g
  Quatd orientation{};
  double penetration = 0, penetration_physical = 0;
  std::int32_t contacts = 0, grasped = 0;
  std::int32_t force_clamped = 0, torque_clamped = 0;
  std::int32_t newton_steps = 0, newton_rejected = 0;
  /// Free virtual vertices of the chunks awake this tick (DeviceHapticSetup::active_region; -1 off)
  std::int32_t active = -1;
};

/// Where a device tick's time goes (DeviceHapticSetup::profile_stages): the mean of each stage
/// per iteration ("step": one virtual-mesh iteration and the virtual tool's Newton call after it,
/// when tool.newton_calls puts one there).
/// Block 0's stages, in SM cycles converted by its clock, add up to its whole time; the other
/// blocks' stages are means over blocks from the device's global timer (steps of about 1 us).
struct DeviceTickProfile {
  enum Stage {
    Wait,        ///< block 0 waiting for the other blocks' vertices after the Newton call
    Update,      ///< block 0's own vertices (held and deferred) at the new pose (pipelined steps)
    Lists,       ///< the candidate and held lists, filtered and in a fixed order; the hand-offs
    Samples,     ///< surface contact: the listed triangles' samples tested and listed (list_samples)
    Evaluate,    ///< E_tool, its gradient and the contact Hessian (every evaluation)
    Clamp,       ///< the 6x6 PSD clamp
    Solve,       ///< the Cholesky solve and the step's checks
    LineSearch,  ///< the Armijo trials
    Output,      ///< the tool's state, the tick's outputs on its last step
    // The other blocks, means over blocks: a block's start after its release, its setup (inputs,
    // posed tool; surface contact: the contact list's sums and the wait for every block's), its
    // vertices (contact, Jacobi step, reach), its lists; surface contact: its wait for every
    // block's vertices before the triangles, its triangles (the triangle pass).
    BlockLag, BlockSetup, BlockVertices, BlockLists, BlockTriangleWait, BlockTriangles,
    BlockVerticesMax,   ///< the slowest block's vertices
    BlockTrianglesMax,  ///< surface contact: the slowest block's triangles
    kStages
  };
  static constexpr const char* kNames[kStages] = {"wait", "update", "lists", "samples", "evaluate", "clamp", "solve",
                                                  "line_search", "output", "block_lag", "block_setup",
                                                  "block_vertices", "block_lists", "block_triangle_wait",
                                                  "block_triangles", "block_vertices_max", "block_triangles_max"};
  double mean_us[kStages] = {};
  double tail_clock_ghz = 0;  ///< block 0's SM clock (cycles over time)
  double clamp_sweeps = 0;    ///< Jacobi sweeps per PSD clamp that ran them (tool/newton_warp.cuh)
  double definite = 0;        ///< the share of clamps whose matrix was positive definite (no Jacobi)
  double candidates = 0;      ///< vertices the Newton call can reach, per step
  double updated = 0;         ///< vertices block 0 updates itself, per pipelined step
  double unpipelined = 0;     ///< the share of steps that ran unpipelined
  double listed = 0;          ///< surface contact: the share of steps whose vertices read a contact list
};

struct DeviceHapticSetup {
  const VirtualModel* mesh = nullptr;
  const ToolModel* tool = nullptr;
  Stiffness k;
  double h = 1e-3;                       ///< s, haptic tick
  int virtual_iterations = 4;
  /// Newton calls of the virtual tool per tick, after the tick's last newton_calls steps
  /// (tool.newton_calls); 0: after every step. A step with no call after it leaves the next step
  /// unpipelined (nothing moves the tool beside it).
  int newton_calls = 0;
  std::span<const Vec3d> q0;             ///< #m the virtual mesh at tick 0 (at rest)
  std::span<const Vec3d> x0;             ///< #n the physical result visible at tick 0
  ToolPose pose0;                        ///< the virtual tool at tick 0
  std::vector<Collider<double>> grasp_boxes;  ///< hard boxes of the grasp events (tool frame)
  bool profile_stages = false;           ///< time the stages (profile()); off: no timer reads
  /// Run the next step's vertices beside the virtual tool (docs/CUDA.md, "Pipelined steps"); off:
  /// every step waits for the tool (the same results up to the order of the contact sums).
  bool pipeline = true;
  /// A step after a Newton call of more candidates than this runs unpipelined: block 0 would
  /// finish about that many vertices itself after the call, which takes longer than the vertex
  /// blocks' whole step (docs/CUDA.md, "Pipelined steps"). 0: a step after a call with
  /// candidates unpipelined; -1: every step, as with `pipeline` off.
  int pipeline_limit = 256;
  /// Surface contact: a step after a Newton call tests only the samples of the call's contact list
  /// (docs/CUDA.md, "Surface contact"); off: every sample of the triangles near the tool (the same
  /// contacts, the sums in another order; for comparisons).
  bool contact_lists = true;
  /// Surface contact: the triangle pass tests the samples of the listed triangles of up to 64
  /// samples for block 0 (docs/CUDA.md, "Surface contact"); off: block 0 tests each of them itself,
  /// as it does a larger triangle's (the same candidates; for comparisons).
  bool sample_bits = true;
  int max_blocks = 0;                    ///< cap on the kernel's blocks (tests: blocks running several chunks); 0: none
  /// Tick blocks that may share a multiprocessor (replays sharing the device, replay_batch:
  /// DeviceTickCapacity::blocks_per_sm_shared); the carve-out beside the physical steps leaves
  /// shared memory for that many and one block of the step. 1: a replay alone.
  int blocks_per_sm = 1;
  int ticks_per_step = 0;                ///< N, ticks per physical step (run_ticks_with_steps); 0: not used
  /// m, solver.active_region: the tick iterates only the chunks of the virtual mesh near the tool
  /// (docs/CUDA.md, "The active region"); 0: every vertex every tick. Vertex contact only.
  double active_region = 0;
  /// The active region's strain check: a sleeping chunk's vertices once in this many ticks (the
  /// chunks staggered over them; the scheduler passes the ticks of a physical period)
  int region_check_ticks = 1;
  /// The physical mesh at rest and its tets: the steps inside the launches (run_ticks_with_steps)
  /// count their inverted or flat tets on the device (finish_step's PhysicalStepReport::inverted),
  /// so that the host does not go over every tet after every step. Empty: not counted (-1).
  std::span<const Vec3d> physical_rest;
  std::span<const Tet> physical_tets;
};

/// How many blocks of the device tick's kernel for this tool's contact the device holds at once
/// (a launch's blocks must all be resident: they hand off through spinning counters).
struct DeviceTickCapacity {
  int multiprocessors = 0;
  /// A replay alone: with the L1-first carve-out (the most L1 for its loads), usually 1.
  int blocks_per_sm = 1;
  /// Replays sharing the device (replay_batch; DeviceHapticSetup::blocks_per_sm): as many as the
  /// registers and the shared-memory-first carve-out allow, less one block's room for the
  /// physical step's blocks, which run beside the spinning tick blocks.
  int blocks_per_sm_shared = 1;
  int registers = 0;            ///< per thread
  std::size_t shared_bytes = 0;  ///< static shared memory per block
  /// Multiprocessors left without tick blocks, for the physical steps that run beside the ticks
  /// (a quarter). The tick blocks spin on hand-off counters that the steps release: with a tick
  /// block on every multiprocessor the device stalled (the tube refined once, 208 chunks, one
  /// replay) or never finished (two replays of 66 blocks each on an H100).
  int multiprocessors_for_steps() const { return (multiprocessors + 3) / 4; }
  /// The same for replays sharing the device (a sixteenth, at least one): there the ticks, not the
  /// steps, bound the batch (its tick blocks run several chunks each), and each tick block's
  /// multiprocessor keeps room for a block of the steps (the carve-out beside the steps), so the
  /// free ones only guarantee the steps a place. On an H100, 32 replays of cholecystectomy_grasp 8
  /// at once: 25.8x real time in total with a quarter free, 28.6x with a sixteenth (9 of 132).
  int multiprocessors_for_shared_steps() const { return (multiprocessors + 15) / 16; }
  /// The most tick blocks of a replay alone.
  int alone_blocks() const { return (multiprocessors - multiprocessors_for_steps()) * blocks_per_sm; }
  /// The tick blocks of a replay alone whose virtual mesh has `chunks` chunks: block 0 and one
  /// block per chunk where that leaves at least a fifth of the multiprocessors to the steps, else
  /// alone_blocks(). A step waits for its slowest vertex block, so a block with a second chunk
  /// makes every step wait for it: cholecystectomy's 99 chunks on 98 vertex blocks (a quarter of
  /// 132 multiprocessors free) ran 13.9x real time, on 99 vertex blocks 14.6x (h200), bitwise the same.
  int alone_grid(int chunks) const {
    const int one_each = chunks + 1, fifth = (multiprocessors + 4) / 5;
    return one_each <= (multiprocessors - fifth) * blocks_per_sm ? one_each : std::min(one_each, alone_blocks());
  }
  /// The most tick blocks of all the replays that share the device.
  int shared_blocks() const { return (multiprocessors - multiprocessors_for_shared_steps()) * blocks_per_sm_shared; }
};
DeviceTickCapacity device_tick_capacity(const ToolModel& tool);

/// Whether the device tick can run this tool (the closest-point projection, at most kMaxColliders).
bool device_haptic_supported(const ToolModel& tool);

class CudaHapticTicks {
 public:
  /// Uploads the model and the inputs of every tick; the physical solver's device step is used
  /// for the coupling (its q and x stay on the device).
  CudaHapticTicks(const DeviceHapticSetup& setup, std::span<const DeviceTickInput> inputs,
                  CudaPhysicalSolver& physical);
  ~CudaHapticTicks();
  CudaHapticTicks(const CudaHapticTicks&) = delete;
  CudaHapticTicks& operator=(const CudaHapticTicks&) = delete;

  /// Enqueues: q at this point -> the physical step's q; the physical step on its stream.
  void start_physical_step();
  /// Enqueues: the ticks wait for the physical step; x_prev <- x_visible <- its x.
  void deliver_physical_step();
  /// Waits for the last started physical step; its report (time_s: device time) and its x (#n).
  PhysicalStepReport finish_physical_step(std::vector<Vec3d>& x);

  /// Enqueues the next `count` ticks; returns a handle for collect().
  int run_ticks(int count);

  /// One launch across physical periods (async replays; docs/CUDA.md, "Launches across physical
  /// periods"): enqueues the next `count` ticks as one launch and, on the physical step's stream,
  /// the physical step of every period (setup.ticks_per_step ticks) that starts among them. The
  /// ticks hand each step its q and take its x on the device, through counters instead of a
  /// launch per period: step k starts from q before tick k N, and ticks (k + 1) N .. blend its x
  /// with step k - 1's, as start_physical_step and deliver_physical_step do one period at a time
  /// (the same bits). Not mixed with run_ticks or start_physical_step on one object. Returns a
  /// handle for collect().
  int run_ticks_with_steps(int count);
  /// Physical steps enqueued by run_ticks_with_steps and not yet finished.
  int steps_in_flight() const;
  /// Physical steps run_ticks_with_steps may have in flight before the oldest must be finished.
  int step_capacity() const;
  /// Waits for the oldest unfinished step of run_ticks_with_steps (steps finish in order): its
  /// report (time_s: device time) and its x (#n).
  PhysicalStepReport finish_step(std::vector<Vec3d>& x);
  /// Waits for the ticks of run_ticks' handle and copies their outputs to `out` (count entries).
  void collect(int handle, std::span<DeviceTickOutput> out);
  /// Ticks run_ticks() may have in flight before they must be collected.
  int capacity() const;

  /// Waits for everything enqueued; the stage times so far (zeros unless setup.profile_stages).
  DeviceTickProfile profile();

  /// Waits for everything enqueued; with the active region, the share of the virtual mesh's
  /// chunks that were awake over the ticks so far (1 without it).
  double awake_share();

  /// Waits for everything enqueued; the virtual mesh (#m) and the visible physical result (#n).
  void snapshot(std::vector<Vec3d>& q, std::vector<Vec3d>& x_visible);

 private:
  int launch_ticks(int count);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ebh
