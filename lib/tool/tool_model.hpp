#pragma once
// A surgical tool as a composition of colliders (collider.hpp), built from a ToolSpec.
//
// Tool frame (fixed for everyone): origin = rotation centre = the distal end of the shaft (where
// the hook bends or the jaws hinge); the shaft occupies local z in [-shaft_length, 0]; local +z
// points from the handle to the tip. A pose is (position of the origin in world metres, unit
// quaternion (w, x, y, z) rotating tool-frame vectors into the world).
//
//   hook:    shaft cylinder + straight capsule (0,0,0)->(0,0,tip_length) + bent tip capsule
//            (0,0,tip_length)->(tip_length,0,tip_length), both of radius tip_radius
//   forceps: shaft cylinder + two jaw boxes. Jaw j in {upper, lower} hinges at the origin, its
//            hinge frame rotated about the tool's y axis by +-jaw * jaw_max_angle (upper towards
//            +x); in its hinge frame the box spans z in [0, jaw_length], y in +-jaw_width/2 and
//            x in [0, jaw_thickness] (upper) or [-jaw_thickness, 0] (lower): closed jaws meet on
//            the tool's x = 0 plane, the grasp projection plane (§5.2, Fig. 3).
#include <array>
#include <memory>
#include <vector>

#include "math/vec.hpp"
#include "scene/scene.hpp"
#include "tool/collider.hpp"

namespace ebh {

struct SurfaceContactModel;  // surface_contact.hpp

struct ToolPose {
  Vec3d position{};    ///< rotation centre, world metres
  Quatd orientation{}; ///< tool frame -> world
};

/// Where q_proj of a vertex inside a collider comes from (docs/TOOLS.md says why the default).
enum class Projection {
  ClosestPoint,   ///< closest point on the deepest collider's surface
  InverseNormal,  ///< the paper's option (§5.1): along minus the virtual-mesh vertex normal
};

/// Immutable tool model.
struct ToolModel {
  ToolSpec spec;
  Projection projection = Projection::ClosestPoint;
  std::vector<Collider<double>> colliders;  ///< #C primitives, each in the frame it names
  std::vector<double> reach;                ///< #C bound on |x| over the collider's points x (tool
                                            ///<    frame, any jaw value): how far from the rotation
                                            ///<    centre a rotation moves it
  bool has_jaws = false;
  /// Contact against the virtual mesh's triangles (scene `contact: surface`; surface_contact.hpp),
  /// or null: the paper's contact of the virtual mesh's vertices.
  std::shared_ptr<const SurfaceContactModel> surface;
};

/// Builds the colliders of spec.kind. Throws InputError on non-positive dimensions.
ToolModel build_tool(const ToolSpec& spec, Projection projection = Projection::ClosestPoint);

/// The jaws' opening angle at jaw value `jaw` in [0, 1] (0 closed, 1 open), clamp(jaw, 0, 1)
/// jaw_max_angle, as its cosine and sine (cos 0, sin 0 for a tool without jaws).
struct JawOpening {
  double cos = 1, sin = 0;
};
JawOpening jaw_opening(const ToolModel& tool, double jaw);

/// Frames of ColliderFrame {Tool, UpperJaw, LowerJaw} relative to the tool frame at jaw value
/// `jaw` in [0, 1] (0 closed, 1 open).
std::array<Rigid<double>, 3> collider_frames(const ToolModel& tool, double jaw);

/// The pose as a rigid transform tool frame -> world.
inline Rigid<double> to_rigid(const ToolPose& pose) { return {to_matrix(pose.orientation), pose.position}; }

/// At most this many colliders per tool (fixed scratch arrays, also on a device).
inline constexpr int kMaxColliders = 8;

/// Colliders with their world transforms for one pose and jaw value.
struct PosedTool {
  int count = 0;
  std::array<Collider<double>, kMaxColliders> shape;
  std::array<Rigid<double>, kMaxColliders> world;   ///< collider frame -> world
  std::array<double, kMaxColliders> reach{};
  Vec3d origin{};  ///< the rotation centre, world
};
PosedTool pose_tool(const ToolModel& tool, const ToolPose& pose, double jaw);

/// The grasp's hard box (§5.2): the tool-frame AABB of both jaw boxes at jaw value `jaw`, as a
/// Box collider in the tool frame. Only for tools with jaws.
Collider<double> grasp_hard_box(const ToolModel& tool, double jaw);

}  // namespace ebh
