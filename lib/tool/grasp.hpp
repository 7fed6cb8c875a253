#pragma once
// Grasping (§5.2, eq. [10]). When the jaw value drops below grasp_threshold the virtual vertices
// inside the jaws' hard box (grasp_hard_box) or within soft_margin of it are grasped, once. Each
// keeps a target fixed in the virtual tool's frame,
//     l_g = w(d) l_f + (1 - w(d)) l_s,     w(d) = 1 / (1 + eta e^d)            [10]
// l_s: the vertex's position in the virtual tool frame at the grasp; l_f: l_s flattened onto the
// jaw projection plane (the tool's x = 0 plane where closed jaws meet) and clamped to the box's
// y-z extent; d: the vertex's signed distance to the hard box divided by soft_margin
// (dimensionless, in [-min half extent / soft_margin, 1]: negative inside, so vertices between
// the jaws are flattened most; e.g. -1.25 .. 1 for the default forceps). Every tick the target q_g = P_g + R_g l_g moves rigidly with the virtual
// tool, goes to the virtual mesh as a ContactTarget (stiffness k_con) and acts back on the virtual
// tool through the same E_con [3] (grasp_energy in tool_energy.hpp). Opening the jaws to the
// release threshold (tool.forceps.release_threshold, by default the grasp threshold) releases
// every vertex. The weight and target are tool_terms.hpp's (grasp_point), shared
// with the device tick.
#include <cstdint>
#include <span>
#include <vector>

#include "energy/contact_target.hpp"
#include "tool/broadphase.hpp"
#include "tool/tool_model.hpp"
#include "tool/tool_terms.hpp"

namespace ebh {

struct GraspState {
  bool closed = false;             ///< jaw below threshold at the last update (grasp done once per closing)
  std::vector<int> vertices;       ///< #G grasped virtual-mesh vertices
  std::vector<Vec3d> local_target; ///< #G l_g, virtual tool frame (metres)
  std::vector<double> weight;      ///< #G w(d) of eq. [10]
  std::vector<std::uint8_t> held;  ///< #m 1 for grasped vertices (they get no pressing contact)
};

/// Sizes the state for m virtual vertices (capacity m, so grasping never allocates later).
void init_grasp(GraspState& g, std::size_t m);

/// Whether the jaws are closed at the jaw value `jaw`, having been `was_closed` (a tool with jaws;
/// ForcepsSpec::closed_at).
inline bool jaws_closed(const ToolModel& tool, double jaw, bool was_closed) {
  return tool.spec.forceps.closed_at(jaw, was_closed);
}

/// Opens or closes the grasp for this tick's jaw value.
///   q  #m virtual-mesh positions; pose: the virtual tool's pose
/// Returns +1 when it grasped (even zero vertices), -1 when it released, 0 otherwise.
int update_grasp(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
                 VertexGrid& grid, GraspState& g);

/// Appends one ContactTarget {vertex, P + R l_g, k_con} per grasped vertex.
void grasp_targets(const GraspState& g, const ToolPose& pose, double k_con, std::vector<ContactTarget>& out);

}  // namespace ebh
