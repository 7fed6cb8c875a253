#pragma once
// The virtual mesh's haptic-rate iterations (virtual_mesh.hpp: virtual_begin_tick,
// virtual_iteration, virtual_end_tick) on a CUDA device, float32, with the CPU reference's
// EBH_HD energy math (energy/edge_spring.hpp, quadratic.hpp).
//
// The virtual tool's Newton step and the vertex-tool collision stay on the CPU here (paper §4.2),
// so every iteration hands q back to the host: one tick costs 2 + virtual_iterations synchronised
// round trips. `--backend cuda` uses it where the whole tick cannot run on the device
// (schedule/haptic_cuda.hpp: the realtime mode, the inverse-normal projection,
// ReplayOptions::device_tick off); docs/PERFORMANCE.md gives the measured costs.
//
// No CUDA types here (pimpl); the class exists when the build has the CUDA backend.
#include <cstdint>
#include <memory>
#include <span>

#include "solver/virtual_mesh.hpp"

namespace ebh {

class CudaVirtualSolver {
 public:
  /// Uploads the model; the state starts at rest (make_virtual_state).
  explicit CudaVirtualSolver(const VirtualModel& model);
  ~CudaVirtualSolver();
  CudaVirtualSolver(const CudaVirtualSolver&) = delete;
  CudaVirtualSolver& operator=(const CudaVirtualSolver&) = delete;

  void upload_state(const VirtualState& state);     ///< q, v (rounded to float32)
  void download_state(VirtualState& state) const;   ///< q, v

  /// virtual_begin_tick: E_svc targets from physical_x (#n; uploaded only when physical_version
  /// differs from the last call's), prediction, q <- s. Writes the new q to q_out (#m).
  void begin_tick(std::span<const Vec3d> physical_x, std::int64_t physical_version, double h,
                  std::span<Vec3d> q_out);
  /// virtual_iteration with this iteration's contacts (summed per vertex in the given order on
  /// the host). Writes the new q to q_out (#m).
  void iteration(std::span<const ContactTarget> contacts, std::span<Vec3d> q_out);
  /// virtual_end_tick: v = (q - q_start) / h on the device.
  void end_tick();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ebh
