#include "tool/tool_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "core/error.hpp"
#include "core/number_text.hpp"

namespace ebh {
namespace {

/// The scene reader refuses these first, naming the file; a spec built in code meets them here.
void require_positive(double v, const char* key) {
  if (!(v > 0.0) || !std::isfinite(v))
    throw InputError(std::string("tool: key 'tool.") + key + "': must be positive, got " + shown_number(v));
}

Collider<double> cylinder(Vec3d a, Vec3d b, double r) {
  Collider<double> c;
  c.shape = Shape::Cylinder; c.a = a; c.b = b; c.radius = r;
  return c;
}
Collider<double> capsule(Vec3d a, Vec3d b, double r) {
  Collider<double> c;
  c.shape = Shape::Capsule; c.a = a; c.b = b; c.radius = r;
  return c;
}
double reach_of_segment(Vec3d a, Vec3d b, double r) { return std::max(norm(a), norm(b)) + r; }

}  // namespace

ToolModel build_tool(const ToolSpec& spec, Projection projection) {
  require_positive(spec.shaft_radius, "shaft_radius");
  require_positive(spec.shaft_length, "shaft_length");
  require_positive(spec.max_step, "max_step");
  require_positive(spec.max_step_rotation_deg, "max_step_rotation_deg");
  ToolModel t;
  t.spec = spec;
  t.projection = projection;
  const Vec3d origin{0, 0, 0}, handle{0, 0, -spec.shaft_length};
  t.colliders.push_back(cylinder(handle, origin, spec.shaft_radius));
  t.reach.push_back(std::hypot(spec.shaft_length, spec.shaft_radius));
  if (spec.kind == ToolSpec::Kind::Hook) {
    require_positive(spec.hook.tip_length, "hook.tip_length");
    require_positive(spec.hook.tip_radius, "hook.tip_radius");
    const double L = spec.hook.tip_length, r = spec.hook.tip_radius;
    const Vec3d bend{0, 0, L}, tip{L, 0, L};
    t.colliders.push_back(capsule(origin, bend, r));
    t.reach.push_back(reach_of_segment(origin, bend, r));
    t.colliders.push_back(capsule(bend, tip, r));
    t.reach.push_back(reach_of_segment(bend, tip, r));
  } else {
    const ForcepsSpec& f = spec.forceps;
    require_positive(f.jaw_length, "forceps.jaw_length");
    require_positive(f.jaw_width, "forceps.jaw_width");
    require_positive(f.jaw_thickness, "forceps.jaw_thickness");
    require_positive(f.soft_margin, "forceps.soft_margin");
    require_positive(f.eta, "forceps.eta");
    if (!(f.jaw_max_angle_deg > 0.0 && f.jaw_max_angle_deg < kMaxJawAngleDeg))
      throw InputError("tool: key 'tool.forceps.jaw_max_angle_deg': must be in (0, 90), got " +
                       std::to_string(f.jaw_max_angle_deg));
    for (int side = 0; side < 2; ++side) {
      Collider<double> box;
      box.shape = Shape::Box;
      box.frame = side == 0 ? ColliderFrame::UpperJaw : ColliderFrame::LowerJaw;
      const double sx = side == 0 ? 1.0 : -1.0;
      box.a = Vec3d{sx * f.jaw_thickness / 2, 0, f.jaw_length / 2};
      box.half = Vec3d{f.jaw_thickness / 2, f.jaw_width / 2, f.jaw_length / 2};
      t.colliders.push_back(box);
      t.reach.push_back(norm(Vec3d{f.jaw_thickness, f.jaw_width / 2, f.jaw_length}));
    }
    t.has_jaws = true;
  }
  return t;
}

JawOpening jaw_opening(const ToolModel& tool, double jaw) {
  if (!tool.has_jaws) return {};
  const double a = std::clamp(jaw, 0.0, 1.0) * tool.spec.forceps.jaw_max_angle_deg * std::numbers::pi / 180.0;
  return {std::cos(a), std::sin(a)};
}

std::array<Rigid<double>, 3> collider_frames(const ToolModel& tool, double jaw) {
  std::array<Rigid<double>, 3> f{};
  if (!tool.has_jaws) return f;
  const JawOpening o = jaw_opening(tool, jaw);
  f[static_cast<int>(ColliderFrame::UpperJaw)].R = jaw_rotation(o.cos, o.sin);
  f[static_cast<int>(ColliderFrame::LowerJaw)].R = jaw_rotation(o.cos, -o.sin);
  return f;
}

PosedTool pose_tool(const ToolModel& tool, const ToolPose& pose, double jaw) {
  PosedTool p;
  const JawOpening o = jaw_opening(tool, jaw);
  const Rigid<double> world = to_rigid(pose);
  p.count = static_cast<int>(tool.colliders.size());
  p.origin = pose.position;
  for (int c = 0; c < p.count; ++c) {
    p.shape[c] = tool.colliders[c];
    p.world[c] = collider_world(world, tool.colliders[c].frame, o.cos, o.sin);
    p.reach[c] = tool.reach[c];
  }
  return p;
}

Collider<double> grasp_hard_box(const ToolModel& tool, double jaw) {
  const auto frames = collider_frames(tool, jaw);
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto& c : tool.colliders) {
    if (c.frame == ColliderFrame::Tool) continue;
    const Rigid<double>& f = frames[static_cast<int>(c.frame)];
    for (int k = 0; k < 8; ++k) {
      const Vec3d corner = c.a + Vec3d{(k & 1) ? c.half.x : -c.half.x, (k & 2) ? c.half.y : -c.half.y,
                                       (k & 4) ? c.half.z : -c.half.z};
      const Vec3d x = apply(f, corner);
      lo = cwise_min(lo, x);
      hi = cwise_max(hi, x);
    }
  }
  Collider<double> box;
  box.shape = Shape::Box;
  box.a = (lo + hi) / 2.0;
  box.half = (hi - lo) / 2.0;
  return box;
}

}  // namespace ebh
