#pragma once
// The physical-mesh step (Algorithm 1) on a CUDA device, float32: the same function as
// physical_step (physical_mesh.hpp) for the jacobi and chebyshev methods, computed with the same
// EBH_HD energy headers (energy/arap.hpp, rotation.hpp, quadratic.hpp). The direct method stays
// on the CPU. docs/CUDA.md describes the layout, the kernels, the graph and the tolerances.
//
// The solver keeps the whole state (x, v, warm-start rotations) on the device. One step copies
// the #m virtual positions in and the #n positions out; the K local-global iterations between
// them are one CUDA graph launch with no host synchronisation inside. Results are bitwise
// identical from run to run (no atomics: every kernel writes its own slots, per-vertex sums gather
// over the CSR incidence lists in a fixed order, the residual norm is a fixed-order reduction).
//
// No CUDA types here (pimpl): this header compiles without nvcc; the class exists when the build
// has the CUDA backend (EBH_HAVE_CUDA).
#include <cstddef>
#include <memory>
#include <span>

#include "solver/physical_mesh.hpp"

namespace ebh {

/// How the step's graph is built (the results are bitwise the same either way).
struct CudaPhysicalOptions {
  /// Chain the iteration kernels by programmatic dependent launch where the driver takes it in a
  /// graph (docs/CUDA.md); false: plain kernel nodes (for comparisons).
  bool programmatic_launch = true;
  /// Vertices per patch (the iteration kernel's block; docs/CUDA.md, "Physical step"), clamped to
  /// [8, 128]; 0: about two blocks per multiprocessor. Either way halved while a patch's block does
  /// not fit the device's shared memory. Results depend on it only by round-off (tests: the larger
  /// patches' path on a small mesh).
  int patch_vertices = 0;
  /// The step runs beside the device tick's blocks (an async device replay's steps inside its
  /// launches): patches of at most 64 vertices, so that two of the step's blocks fit beside a tick
  /// block on a multiprocessor (with one, the step of a 352k-tet mesh took 2.9x as long).
  bool beside_ticks = false;
  /// solver.sleep (m; docs/MODEL.md, "Sleeping"): a step whose inputs have not moved by more than
  /// this is skipped on the device (a conditional graph node: CUDA 13 builds; others refuse it),
  /// the state held; the report says so (PhysicalStepReport::slept). 0: every step runs.
  double sleep = 0;
  /// solver.physical_region (m; docs/MODEL.md, "The physical mesh's awake region"): the CPU's
  /// rules at the grain of the step's patches: a patch iterates when one of its free vertices is
  /// awake by them, the others are held at rest; the report gives the free vertices of the patches
  /// that iterated (PhysicalStepReport::awake) and a step in which none did as slept. 0: off.
  double region = 0;
};

class CudaPhysicalSolver {
 public:
  /// Uploads the model and captures the step graph for `params`. The state starts at rest
  /// (make_physical_state). Throws InputError for the direct method, std::runtime_error (with the
  /// CUDA error, file and line) when the device cannot be used.
  CudaPhysicalSolver(const PhysicalModel& model, const PhysicalStepParams& params,
                     const CudaPhysicalOptions& options = {});
  ~CudaPhysicalSolver();
  CudaPhysicalSolver(const CudaPhysicalSolver&) = delete;
  CudaPhysicalSolver& operator=(const CudaPhysicalSolver&) = delete;

  /// Replaces the device state by `state` (x, v, rotation; rounded to float32).
  void upload_state(const PhysicalState& state);
  /// Copies the device state (x, v, rotation) into `state`.
  void download_state(PhysicalState& state) const;

  /// One physical step on the device state, coupled to virtual_q (#m, empty when m = 0). Writes the
  /// new positions to state.x (#n); state.v and state.rotation are left as they were (they live on
  /// the device: download_state reads them). local_s and global_s are not split on the device
  /// (0); time_s is the wall clock of the whole step, copies included.
  PhysicalStepReport step(PhysicalState& state, std::span<const Vec3d> virtual_q);

  /// The device-resident step, for callers that keep q and x on the device (the replay's device
  /// haptic tick, schedule/haptic_cuda.hpp): q is read from device_q() (#m float32 xyz, device
  /// memory) and x left in device_x() (#n); launch_device_step() enqueues the step on
  /// stream_handle() (a cudaStream_t) and returns at once; device_step_report() waits for it and
  /// reports its residual and its device time (time_s). Same kernels and bits as step().
  Vec3f* device_q();
  const Vec3f* device_x() const;
  void* stream_handle() const;
  void launch_device_step();
  PhysicalStepReport device_step_report();
  /// Several device-resident steps in flight (the replay's launches across physical periods,
  /// CudaHapticTicks::run_ticks_with_steps): launch_device_step(slot) times its step with the
  /// slot's own events and keeps a copy of its residual sums there, so that a later step does not
  /// overwrite them; device_step_report(slot) waits for that step. Slots 0 .. slots - 1.
  void set_device_step_slots(int slots);
  /// Captures the device-resident step's graph now (launch_device_step does it on first use), for
  /// callers that want it done before they enqueue work of their own on stream_handle().
  void prepare_device_step();
  void launch_device_step(int slot);
  PhysicalStepReport device_step_report(int slot);

  const PhysicalStepParams& params() const;
  /// Device time of the last step's graph (copies of q and x included), seconds, from CUDA events:
  /// time_s minus this is the host's share (conversions, launch, synchronisation).
  double last_device_seconds() const;
  /// Local-step evaluations per tet and iteration (>= 1): a tet on a patch border is computed by
  /// each patch it touches (docs/CUDA.md).
  double tet_evaluations_per_tet() const;
  /// Shared memory (bytes, dynamic and static) one block of the step's iteration kernels takes:
  /// for callers that want a block of theirs and one of the step's to share a multiprocessor
  /// (CudaHapticTicks: the physical steps inside the launches).
  std::size_t block_shared_bytes() const;
  /// Vertices per patch, and threads per patch vertex in the global stage (8 up to 64 vertices,
  /// else 4).
  int patch_vertices() const;
  int patch_lanes() const;
  /// Whether this build can sleep (CudaPhysicalOptions::sleep: graph conditional nodes).
  static bool can_sleep();
  /// Whether the step graph chains its kernels by programmatic dependent launch (docs/CUDA.md).
  bool programmatic_launch() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ebh
