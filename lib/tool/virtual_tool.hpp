#pragma once
// The virtual tool (§4.1, Appendix A, Algorithm 2 lines 17-19 and 24-27): Newton's method on
// E_tool(X_g) = E_tvc [2] + E_con [3] (+ the grasp part of E_con, eq. [10]) over the 6 DOF of
// tool_energy.hpp, the virtual-mesh positions q held fixed and the contacts recomputed at every
// Newton iterate. The output force and torque come from the coupling:
// F = dE_tvc/dP_g = k_vcs (P_g - P_h), T = dE_tvc/dw_g = k_vct rotvec(R_g R_h^T), clamped.
//
// Newton step: H_step dx = -grad with
//   H_step = k_vcs I (+) k_vct I  +  PSD(H_con + H_grasp)
// PSD(.) clamps the negative eigenvalues of the exact contact Hessian to zero (a 6x6
// eigen-decomposition); the coupling block k_vct I bounds the exact coupling Hessian from above
// (its eigenvalues are 1 and (theta/2) cot(theta/2) <= 1 times k_vct), so H_step is positive
// definite, the step is a descent direction, and with no contact one step lands exactly on the
// physical tool. The step is scaled to |dP| <= max_step and |w| <= max_step_rotation_deg, then
// halved until E_tool does not increase (Armijo); a step that fails 12 halvings is not taken.
#include <cstdint>
#include <span>
#include <vector>

#include "energy/contact_target.hpp"
#include "scene/scene.hpp"
#include "tool/broadphase.hpp"
#include "tool/contact.hpp"
#include "tool/grasp.hpp"
#include "tool/surface_contact.hpp"
#include "tool/tool_energy.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

enum class NewtonHessian {
  ClampedExact,  ///< H_step above (default)
  GaussNewton,   ///< contacts contribute k J J^T only
};

/// Mutable state of one virtual tool.
struct VirtualToolState {
  ToolPose pose;                        ///< X_g
  ToolPose anchor;                      ///< X_g at the start of the tick (ToolSpec stabilization)
  GraspState grasp;
  NewtonHessian hessian = NewtonHessian::ClampedExact;
  // Scratch, sized once (init_virtual_tool) and reused every tick.
  std::vector<int> candidates;          ///< vertices near the tool for this call's iterations
  std::vector<ContactPoint> contacts;   ///< contacts at the current Newton iterate
  std::vector<ContactPoint> trial;      ///< contacts at a trial iterate
  std::vector<SurfaceSample> samples;   ///< surface contact: the samples near the tool for this call
  /// The last Newton call ran at the current q, so what it found at its final pose is what the
  /// next virtual_mesh_targets would search for: vertex contact takes `contacts` (the narrow phase
  /// at the final pose over the call's candidates, which hold every vertex any pose the call can
  /// reach touches), surface contact `samples` (every sample that pose touches), instead of
  /// searching the grid again. Whoever moves q clears it (virtual_mesh_targets does, for the
  /// iteration that follows it; the tick's start, which moves q to its prediction, too).
  bool call_fresh = false;
  SurfaceScratch surface_scratch;       ///< surface contact's query scratch
  // Diagnostics of the last update_virtual_tool call.
  double energy = 0.0;                  ///< E_tool at the final pose
  int steps_taken = 0;
  int steps_rejected = 0;               ///< steps that found no energy decrease
};

/// Prepares the state for m virtual vertices, the virtual tool starting at `pose`.
void init_virtual_tool(VirtualToolState& st, std::size_t m, const ToolPose& pose);

/// Algorithm 2 lines 18-19: spec.newton_iterations Newton steps on E_tool at fixed q.
///   physical  X_h, the physical tool's pose this tick; jaw in [0, 1]
///   q         #m virtual-mesh positions (held fixed); normals: #m unit vertex normals (only
///             read by Projection::InverseNormal; may be empty otherwise)
///   grid      the broad phase over q (see broadphase.hpp for its invariant)
void update_virtual_tool(const ToolModel& tool, const Stiffness& k, const ToolPose& physical, double jaw,
                         std::span<const Vec3d> q, std::span<const Vec3d> normals, VertexGrid& grid,
                         VirtualToolState& st);

/// E_tool at the state's pose with contacts detected at that pose (for tests and diagnostics).
double tool_energy(const ToolModel& tool, const Stiffness& k, const ToolPose& physical, double jaw,
                   std::span<const Vec3d> q, std::span<const Vec3d> normals, VertexGrid& grid,
                   VirtualToolState& st);

/// Algorithm 2 line 10 for one tool: pressing contacts (grasped vertices excluded) and grasp
/// targets of the virtual tool at its current pose, appended to `out` for the virtual mesh.
void virtual_mesh_targets(const ToolModel& tool, const Stiffness& k, double jaw, std::span<const Vec3d> q,
                          std::span<const Vec3d> normals, VertexGrid& grid, VirtualToolState& st,
                          std::vector<ContactTarget>& out);

struct ToolOutput {
  Vec3d force{};                ///< N, dE_tvc/dP_g, after the clamp
  Vec3d torque{};               ///< N m, dE_tvc/dw_g, after the clamp
  bool force_clamped = false;   ///< |F| exceeded spec.force_limit and was scaled down to it
  bool torque_clamped = false;  ///< |T| exceeded tool.torque_limit (when > 0)
};

/// Algorithm 2 lines 26-27: the force and torque for the device.
ToolOutput tool_output(const ToolModel& tool, const Stiffness& k, const ToolPose& physical,
                       const VirtualToolState& st);

}  // namespace ebh
