#pragma once
// The two-rate simulation (schedule/scheduler.hpp says who runs when): an immutable World (the scene's models), the haptic
// side (virtual mesh + virtual tool, ticking at h_h, Algorithm 2) and the physical side (physical
// mesh, stepping at h_p, Algorithm 1). The two sides exchange data only through snapshots:
//   HapticSnapshot   -> physical step: the virtual-mesh positions E_svc [5] holds fixed;
//   PhysicalSnapshot -> haptic tick:   the physical positions the E_svc targets are paired from.
// Who delivers which snapshot when is the scheduler's business (schedule/scheduler.hpp).
#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/recording.hpp"
#include "scene/scene.hpp"
#include "solver/active_region.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/physical_region.hpp"
#include "solver/virtual_mesh.hpp"
#include "tool/broadphase.hpp"
#include "tool/tool_model.hpp"
#include "tool/virtual_tool.hpp"
#if EBH_HAVE_CUDA
#include "solver/physical_mesh_cuda.hpp"
#include "solver/virtual_mesh_cuda.hpp"
#endif

namespace ebh {

/// Where the soft-body solvers run (docs/CUDA.md). The CPU backend is the reference.
enum class Backend { Cpu, Cuda };

/// Everything that does not change during a replay.
struct World {
  Backend backend = Backend::Cpu;
  Scene scene;
  VirtualModel virtual_mesh;
  PhysicalModel physical_mesh;
  ToolModel tool;
  PhysicalStepParams physical_params;
  /// --backend cuda: float32_residual_floor of the physical mesh (the device's steps stall at a few
  /// times it); 0 on the CPU backend.
  double float32_floor = 0;
  double h_haptic = 1e-3;   ///< s, haptic tick
  double h_physical = 1e-2; ///< s, physical step
  int ticks_per_step = 10;  ///< N = h_physical / h_haptic (an integer)
  double grid_margin = 0.002;  ///< m, broad-phase slack (tool/broadphase.hpp)
  /// The state both sides start from: the rest shape, or (stages.settle) the static equilibrium
  /// under gravity, at rest. initial_virtual: the virtual mesh on it (#m, the paired points).
  PhysicalState initial_physical;
  std::vector<Vec3d> initial_virtual;
  int settle_steps = 0;  ///< static steps the settling took (0: not settled)
  bool settle_capped = false;  ///< the settling stopped at its cap with the mesh still moving (warned)
};

/// Builds the world of a scene at the given rates. Throws InputError when the rates do not give a
/// whole number of ticks per physical step.
std::shared_ptr<const World> build_world(Scene scene, double haptic_hz, double physical_hz,
                                         Backend backend = Backend::Cpu);

/// Worlds built once and shared by replays whose scenes differ at most in the virtual tool's
/// stiffnesses (stiffness.k_con, k_vcs, k_vct): those act on the virtual tool alone, so the
/// meshes, the solvers' set-up, the settling and the warnings of such scenes are the same, and a
/// replay's world is the first one's (the same object when the stiffnesses agree too, else a copy
/// with the stiffnesses and the tool rebuilt). The start-up work of a batch (ebh replay --batch)
/// is then done once per scene. Thread-safe: a world is built once while the other threads that
/// need it wait.
class WorldCache {
 public:
  /// The world of `spec` (a parsed scene with its overrides) at the given rates.
  std::shared_ptr<const World> get(SceneSpec spec, double haptic_hz, double physical_hz, Backend backend);
  /// Worlds built (or tried) from their scenes so far; the other gets shared or derived them.
  int built() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_future<std::shared_ptr<const World>>> entries_;
  int built_ = 0;
};

/// The physical side's output as the haptic side sees it.
struct PhysicalSnapshot {
  std::vector<Vec3d> x;  ///< #n physical-mesh positions
  std::int64_t step = -1;  ///< the physical step that produced it (-1: rest state)
};

/// The haptic side's output as the physical step sees it.
struct HapticSnapshot {
  std::vector<Vec3d> q;  ///< #m virtual-mesh positions
};

/// Wall-clock seconds spent in each stage of the last haptic tick.
struct HapticTiming {
  double device = 0, physical_sync = 0, grasp = 0, virtual_mesh = 0, virtual_tool = 0, output = 0, total = 0;
};

/// The haptic side: virtual mesh, virtual tool, the device's latest sample, and what it emits.
struct HapticSide {
  VirtualState mesh;
  VirtualWorkspace workspace;
  /// solver.active_region > 0 (CPU backend): the virtual vertices the tick iterates; region_seeds
  /// and region_samples: this tick's seeds and the surface samples they come from (scratch).
  std::optional<ActiveRegion> region;
  std::vector<int> region_seeds;
  std::vector<SurfaceSample> region_samples;
  std::vector<Vec3d> normals;            ///< #m virtual-mesh vertex normals
  VirtualToolState tool;
  VertexGrid grid;                       ///< broad phase over the virtual mesh
  std::vector<ContactTarget> contacts;   ///< this iteration's E_con targets (capacity m)
  PhysicalSnapshot visible;              ///< the latest physical result this side may use
  std::vector<Vec3d> previous_x;         ///< #n the result before it (time.interpolate_physical)
  std::int64_t previous_step = INT64_MIN;  ///< previous_x's PhysicalSnapshot::step (none: INT64_MIN)
  std::vector<Vec3d> targets_x;          ///< #n this tick's blend of the two
  std::int64_t delivered_tick = 0;       ///< the tick at which `visible` arrived
  std::int64_t tick = 0;                 ///< the next tick to run
  // Outputs of the last tick.
  DeviceSample device;                   ///< X_h and jaw
  ToolOutput output;                     ///< force and torque for the device
  double penetration = 0;                ///< m, deepest virtual-mesh vertex inside the virtual tool
  double penetration_physical = 0;       ///< m, the same for the physical tool (large by design)
  int contact_count = 0;                 ///< E_con targets of the last iteration (grasp included)
  int grasped = 0;                       ///< virtual vertices held by the grasp
  int newton_calls = 0;                  ///< Newton calls of the virtual tool in the last tick
  /// Free virtual vertices the last tick iterated under solver.active_region (the CPU region's; on
  /// the CUDA device tick those of its awake chunks); -1: the whole mesh (the key off)
  int active_vertices = -1;
  HapticTiming timing;
#if EBH_HAVE_CUDA
  /// Backend::Cuda where the whole tick cannot run on the device (realtime mode, inverse-normal
  /// projection, ReplayOptions::device_tick off; else scheduler.cpp's replay_device): the virtual-mesh
  /// iterations run here; mesh.q is the host copy each iteration hands back for collision and the
  /// virtual tool (mesh.v stays on the device; docs/CUDA.md).
  std::unique_ptr<CudaVirtualSolver> cuda;
#endif
};

/// The physical side: physical mesh state and the scratch of its step.
struct PhysicalSide {
  PhysicalState mesh;
  PhysicalWorkspace workspace;
  std::int64_t step = 0;                 ///< the next step to run
  PhysicalStepReport report;             ///< of the last step
  /// The recovery (SolverSpec::recovery, CPU backend): the last step was redone with the direct
  /// global solve; the state the step started from; the factorisation, made on the first recovery.
  bool recovered = false;
  PhysicalState start;
  std::shared_ptr<const PhysicalDirectSolver> recovery_direct;
  double recovery_factorize_s = 0;       ///< s the factorisation took (in its step's time_s too)
  /// Sleeping (SolverSpec::sleep, CPU backend): the last step was skipped and the state held; the
  /// virtual mesh the last step that ran was given.
  bool slept = false;
  std::vector<Vec3d> ran_with;
  /// The awake region (SolverSpec::physical_region, CPU backend; null when off).
  std::unique_ptr<PhysicalRegion> region;
  /// The step runs beside the ticks (async, realtime), not between them (lockstep): a divergence's
  /// message names the two meshes driving each other only there.
  bool beside_ticks = true;
#if EBH_HAVE_CUDA
  /// Backend::Cuda: the step runs here and mesh.x is its copy of x (mesh.v and mesh.rotation stay
  /// on the device; docs/CUDA.md).
  std::unique_ptr<CudaPhysicalSolver> cuda;
#endif
};

/// Both sides at rest, the virtual tool starting at the physical tool's first pose.
HapticSide make_haptic_side(const World& world, const DeviceSample& first_sample);
/// beside_ticks: the CUDA step runs beside the device tick's blocks (CudaPhysicalOptions).
PhysicalSide make_physical_side(const World& world, bool beside_ticks = false);

/// The haptic side's snapshot for the physical step (copies q; allocation-free after the first).
/// Whether `residual` (mesh weights) is what the device's float32 alone leaves on this world's mesh:
/// within kFloat32StallFactor times its float32 floor (--backend cuda only; false on the CPU).
inline bool float32_round_off(const World& world, double residual) {
  return world.float32_floor > 0 && residual <= kFloat32StallFactor * world.float32_floor;
}

void take_haptic_snapshot(const HapticSide& haptic, HapticSnapshot& out);
/// The physical side's snapshot for the haptic side.
void take_physical_snapshot(const PhysicalSide& physical, PhysicalSnapshot& out);
/// Makes a physical result visible to the haptic side (the broad phase is rebuilt around it).
void deliver_physical_snapshot(const World& world, HapticSide& haptic, const PhysicalSnapshot& snapshot);

/// time.interpolate_physical: the weight of the visible physical result in the E_svc targets of
/// tick n, that result delivered at tick `delivered` (the previous result weighs 1 minus it):
/// (n - delivered + 1) / N, 1 from N - 1 ticks after the delivery on (N ticks per physical step).
double physical_blend(std::int64_t n, std::int64_t delivered, int N);

/// One haptic tick (Algorithm 2) with the device sample for this tick; its health check
/// (check_haptic_tick) is the caller's, which knows the recording.
void haptic_tick(const World& world, HapticSide& haptic, const DeviceSample& sample);

/// One physical step (Algorithm 1) coupled to the virtual-mesh positions of `snapshot`; on the
/// CPU backend, the recovery (SolverSpec::recovery: a step left unconverged or diverged by the
/// Jacobi-type iterations is redone from its start with the direct global solve); then
/// check_physical_step. `shared` (CPU backend): the step's loops shared with a helping thread
/// (physical_step); the same bits. `cancel` (CPU backend): asked during the step (physical_step);
/// when it stops there, physical.report.cancelled and the state is no result.
void run_physical_step(const World& world, PhysicalSide& physical, const HapticSnapshot& snapshot,
                       SharedLoops* shared = nullptr, const std::function<bool()>& cancel = {});

/// The health checks (STYLE.md's run-time tier): a non-finite or diverged physical state after
/// physical.step - 1 (physical_state_problem), a non-finite force or torque after a tick. Each
/// throws NumericalError: "SCENE: tick N, physical step K: what, the worst element"; a tick's
/// names the recording's samples that `sample` (what tick N read: rec at sample.t) came from, by
/// their index in the file and time, so that the row of the log can be found.
void check_physical_step(const World& world, const PhysicalSide& physical);
void check_haptic_tick(const World& world, std::int64_t tick, const ToolOutput& output, const Recording& rec,
                       const DeviceSample& sample);

}  // namespace ebh
