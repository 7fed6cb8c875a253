#include "tool/contact.hpp"

#include <algorithm>
#include <cmath>

#include "tool/newton.hpp"

namespace ebh {
namespace {
// Below this cosine between the exit normal and the ray the inverse-normal projection is
// grazing; the gain 1/cos is capped there (the paper's method is ill-posed at grazing rays).
constexpr double kMinExitCosine = 0.1;

/// The cells that may hold a vertex a Newton call from `tool` (translating by at most T, turning
/// by at most th < 1 rad) can reach, per collider (gather_candidates' per-cell test): calls
/// visit(c, i) for the vertices of collider c's cells, one pass per collider.
template <class Visit>
void walk_reach(const PosedTool& tool, std::span<const Vec3d> q, const VertexGrid& grid, double T, double th,
                Visit&& visit) {
  for (int c = 0; c < tool.count; ++c) {
    const Collider<double>& shape = tool.shape[c];
    const Rigid<double>& w = tool.world[c];
    const double extra = (T + th * (tool.reach[c] + T)) / (1.0 - th);
    auto keep = [&](Vec3d cc, double s_with_extra) {
      const double s = s_with_extra - extra;  // half diagonal + margin
      const double bound = (s + T + th * (norm(cc - tool.origin) + T)) / (1.0 - th);
      return signed_distance_local(shape, apply_inverse(w, cc)) <= bound;
    };
    auto visit_c = [&](int i) { visit(c, i); };
    const std::uint32_t pass = grid.next_pass();
    cover_collider(shape, w, grid.cell_size(),
                   [&](Vec3d lo, Vec3d hi) { grid.query(lo, hi, extra, q, keep, visit_c, pass); });
  }
}

/// The cells that may hold a vertex inside a collider of `tool`, per collider: calls visit(c, i) for
/// the vertices of collider c's cells, one pass per collider.
template <class Visit>
void walk_inside(const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid, Visit&& visit) {
  for (int c = 0; c < tool.count; ++c) {
    const Collider<double>& shape = tool.shape[c];
    const Rigid<double>& w = tool.world[c];
    auto keep = [&](Vec3d cell_centre, double slack) {
      return signed_distance_local(shape, apply_inverse(w, cell_centre)) <= slack;
    };
    auto visit_c = [&](int i) { visit(c, i); };
    const std::uint32_t pass = grid.next_pass();
    cover_collider(shape, w, grid.cell_size(),
                   [&](Vec3d lo, Vec3d hi) { grid.query(lo, hi, 0.0, q, keep, visit_c, pass); });
  }
}

}  // namespace

bool vertex_contact(const PosedTool& tool, Projection projection, int vertex, Vec3d q, Vec3d n_v, ContactPoint& out) {
  SurfaceQuery<double> s;
  const int c = deepest_collider(tool.shape.data(), tool.world.data(), tool.count, q, s);
  if (c < 0) return false;
  out.vertex = vertex;
  out.depth = -s.sd;
  if (projection == Projection::InverseNormal && squared_norm(n_v) > 0.25) {
    const Vec3d d = -normalized(n_v);
    const Rigid<double>& w = tool.world[c];
    const Vec3d p = apply_inverse(w, q), dl = transpose(w.R) * d;
    const double t = exit_distance_local(tool.shape[c], p, dl);
    const SurfaceQuery<double> e = query_local(tool.shape[c], p + t * dl);
    out.phi = t;
    out.target = q + t * d;
    out.normal = w.R * e.normal;
    out.lever = out.target;
    out.gain = 1.0 / std::max(dot(out.normal, d), kMinExitCosine);
    out.hess_sd = Mat3d{};
    out.exact = false;
  } else {
    out.phi = -s.sd;
    out.target = s.point;
    out.normal = s.normal;
    out.lever = q;
    out.gain = 1.0;
    out.hess_sd = s.hess;
    out.exact = true;
  }
  return true;
}

void gather_candidates(const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid, double translation,
                       double rotation, std::vector<int>& out) {
  if (grid.stale(q.size())) grid.rebuild(q, grid.margin());
  const std::size_t start = out.size();
  for (int attempt = 0; attempt < 2; ++attempt) {
    const std::uint32_t stamp = grid.next_stamp();
    auto& stamps = grid.stamps();
    walk_reach(tool, q, grid, translation, std::min(rotation, 0.5), [&](int, int i) {
      if (stamps[i] == stamp) return;
      stamps[i] = stamp;
      out.push_back(i);
    });
    if (!grid.violated()) return;
    out.resize(start);  // fallback: the invariant broke, rebuild from the current positions
    grid.rebuild(q, grid.margin());
  }
}

void gather_reachable(const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid, double translation,
                      double rotation, std::vector<int>& out) {
  if (grid.stale(q.size())) grid.rebuild(q, grid.margin());
  const std::size_t start = out.size();
  const double T = translation, th = std::min(rotation, 0.5);
  for (int attempt = 0; attempt < 2; ++attempt) {
    const std::uint32_t stamp = grid.next_stamp();
    auto& stamps = grid.stamps();
    auto& slots = grid.slots();
    // A vertex's first visit lists it, as ~i until a collider is within its bound; out[slots[i]].
    walk_reach(tool, q, grid, T, th, [&](int c, int i) {
      if (stamps[i] != stamp) {
        stamps[i] = stamp;
        slots[i] = static_cast<int>(out.size());
        out.push_back(~i);
      }
      int& entry = out[static_cast<std::size_t>(slots[i])];
      if (entry < 0 && signed_distance_local(tool.shape[c], apply_inverse(tool.world[c], q[i])) <=
                           newton_reach_bound(T, th, norm(q[i] - tool.origin)))
        entry = i;
    });
    if (!grid.violated()) {
      out.erase(std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(start), out.end(), [](int e) { return e < 0; }),
                out.end());
      return;
    }
    out.resize(start);  // fallback: the invariant broke, rebuild from the current positions
    grid.rebuild(q, grid.margin());
  }
}

void narrow_phase(const PosedTool& tool, Projection projection, std::span<const int> candidates,
                  std::span<const Vec3d> q, std::span<const Vec3d> normals, std::span<const std::uint8_t> excluded,
                  std::vector<ContactPoint>& out) {
  out.clear();
  ContactPoint cp;
  for (const int i : candidates) {
    if (!excluded.empty() && excluded[i]) continue;
    const Vec3d n = normals.empty() ? Vec3d{} : normals[i];
    if (vertex_contact(tool, projection, i, q[i], n, cp)) out.push_back(cp);
  }
}

void detect_contacts(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
                     std::span<const Vec3d> normals, VertexGrid& broadphase, double k_con,
                     std::vector<ContactTarget>& out, std::span<const std::uint8_t> excluded) {
  const PosedTool posed = pose_tool(tool, pose, jaw);
  if (broadphase.stale(q.size())) broadphase.rebuild(q, broadphase.margin());
  for (int attempt = 0; attempt < 2; ++attempt) {
    const std::size_t start = out.size();
    const std::uint32_t stamp = broadphase.next_stamp();
    auto& stamps = broadphase.stamps();
    ContactPoint cp;
    walk_inside(posed, q, broadphase, [&](int, int i) {
      if (stamps[i] == stamp) return;
      stamps[i] = stamp;
      if (!excluded.empty() && excluded[i]) return;
      const Vec3d n = normals.empty() ? Vec3d{} : normals[i];
      if (vertex_contact(posed, tool.projection, i, q[i], n, cp)) out.push_back({i, cp.target, k_con});
    });
    if (!broadphase.violated()) return;
    out.resize(start);
    broadphase.rebuild(q, broadphase.margin());
  }
}

double penetration_depth(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
                         VertexGrid& broadphase, std::span<const std::uint8_t> excluded) {
  const PosedTool posed = pose_tool(tool, pose, jaw);
  if (broadphase.stale(q.size())) broadphase.rebuild(q, broadphase.margin());
  double deepest = 0.0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    deepest = 0.0;
    walk_inside(posed, q, broadphase, [&](int c, int i) {
      if (!excluded.empty() && excluded[i]) return;
      deepest = std::max(deepest, -signed_distance_local(posed.shape[c], apply_inverse(posed.world[c], q[i])));
    });
    if (!broadphase.violated()) break;
    broadphase.rebuild(q, broadphase.margin());
  }
  return deepest;
}

}  // namespace ebh
