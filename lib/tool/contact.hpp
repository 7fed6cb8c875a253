#pragma once
// Vertex-tool collision (§5.1): which virtual-mesh vertices lie inside the (virtual or physical)
// tool's colliders, their projections q_proj (what E_con [3] pulls them towards) and the
// quantities the virtual tool's Newton step needs.
//
// One contact per vertex: the collider the vertex is deepest in (depth = -sd, the union's depth
// approximated by the largest primitive depth). q_proj is the closest point on that collider's
// surface (default) or the exit point of the ray from the vertex along minus its vertex normal
// (Projection::InverseNormal, the paper's option); docs/TOOLS.md compares them.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "energy/contact_target.hpp"
#include "tool/broadphase.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

/// One vertex inside the tool. phi = |q - q_proj| >= 0 and E_con [3] of it is k_con/2 phi^2.
struct ContactPoint {
  int vertex = -1;
  double depth = 0;  ///< -sd of the vertex in its collider (= phi for closest-point projection)
  double phi = 0;    ///< |q - q_proj|
  Vec3d target{};    ///< q_proj, world
  Vec3d normal{};    ///< outward collider normal at q_proj, world
  Vec3d lever{};     ///< the collider point that carries phi: q (closest point) or q_proj (inverse normal)
  double gain = 1;   ///< d phi / d(tool displacement along normal at lever): 1, or 1/(n . d) for a ray d
  Mat3d hess_sd{};   ///< world Hessian of the collider's sd at q (closest point only)
  bool exact = true; ///< false: phi's curvature is not modelled (inverse normal: Gauss-Newton only)
  double weight = 1; ///< the contact's stiffness is weight * k_con (1 for a vertex; surface_contact.hpp for a sample)
};

/// Per-vertex narrow phase, host/device: the deepest of n posed colliders containing q.
/// Returns the collider index or -1; `s` gets the world-frame query of that collider. `mask`: bit c
/// clear skips collider c (a caller that knows q is outside it; the device tick's float early-out).
template <class T>
EBH_HD int deepest_collider(const Collider<T>* shape, const Rigid<T>* world, int n, Vec3<T> q, SurfaceQuery<T>& s,
                            unsigned mask = ~0u) {
  // First pass: the signed distance alone; the full query only for the deepest collider.
  int best = -1;
  T best_sd = T(0);
  for (int c = 0; c < n; ++c) {
    if (!((mask >> c) & 1u)) continue;
    const T sd = signed_distance_local(shape[c], apply_inverse(world[c], q));
    if (sd < T(0) && (best < 0 || sd < best_sd)) {
      best = c;
      best_sd = sd;
    }
  }
  if (best >= 0) {
    const SurfaceQuery<T> l = query_local(shape[best], apply_inverse(world[best], q));
    s.sd = l.sd;
    s.point = apply(world[best], l.point);
    s.normal = world[best].R * l.normal;
    s.hess = world[best].R * l.hess * transpose(world[best].R);
  }
  return best;
}

/// Calls box(lo, hi) with world boxes that together cover collider `shape` posed by `w`, hugging
/// it: a long shaft (hundreds of mm) is cut into pieces a few grid cells long, and a box (a
/// forceps jaw, thin and long) is covered by its own world-aligned bounds rather than by the cube
/// around its bounding sphere, so a query costs the cells near the collider.
template <class Box>
void cover_collider(const Collider<double>& shape, const Rigid<double>& w, double cell, Box&& box) {
  if (shape.shape == Shape::Capsule || shape.shape == Shape::Cylinder) {
    const Vec3d A = apply(w, shape.a), B = apply(w, shape.b);
    const int pieces = std::max(1, static_cast<int>(std::ceil(norm(B - A) / (4.0 * cell))));
    const Vec3d r{shape.radius, shape.radius, shape.radius};
    for (int k = 0; k < pieces; ++k) {
      const Vec3d p0 = A + (static_cast<double>(k) / pieces) * (B - A);
      const Vec3d p1 = A + (static_cast<double>(k + 1) / pieces) * (B - A);
      box(cwise_min(p0, p1) - r, cwise_max(p0, p1) + r);
    }
  } else if (shape.shape == Shape::Box) {
    // The world extent of the box's half extents h along world axis k: sum_j |R_kj| h_j (its
    // rounded edges lie inside them).
    const Vec3d mid = apply(w, shape.a);
    Vec3d ext{};
    for (int k = 0; k < 3; ++k)
      ext[k] = std::fabs(w.R(k, 0)) * shape.half.x + std::fabs(w.R(k, 1)) * shape.half.y +
               std::fabs(w.R(k, 2)) * shape.half.z;
    box(mid - ext, mid + ext);
  } else {
    const Vec3d mid = apply(w, centre(shape));
    const double rb = bounding_radius(shape);
    const Vec3d ext{rb, rb, rb};
    box(mid - ext, mid + ext);
  }
}

/// Contact of vertex `vertex` at q (world) against a posed tool, with normal n_v (unit, may be
/// zero: then the closest point is used whatever the projection). Returns false when outside.
bool vertex_contact(const PosedTool& tool, Projection projection, int vertex, Vec3d q, Vec3d n_v, ContactPoint& out);

/// Candidate vertices for a posed tool that may move by up to `translation` (m) and
/// `rotation` (rad, about the rotation centre) before the candidates are used again. Appends
/// unique indices to `out`. A collider point y moves by at most T + theta (|y - P| + T)
/// (T = translation, theta = rotation, P = rotation centre), so a cell with centre c and
/// half-diagonal-plus-margin s can hold a future contact only if
///     sd(c) <= (s + T + theta (|c - P| + T)) / (1 - theta),
/// the per-cell test used (rotation < 1 rad). Rebuilds the grid first when stale (counted in grid.rebuilds()) and
/// again when the query finds the invariant violated.
void gather_candidates(const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid, double translation,
                       double rotation, std::vector<int>& out);

/// The candidates of a Newton call from `tool` that translates by at most `translation` and
/// turns by at most `rotation` (< 1 rad): the vertices i with, for some collider c,
///     sd_c(q_i) <= newton_reach_bound(translation, rotation, |q_i - P|)
/// (newton.hpp), appended to `out` in the order gather_candidates would first list them. Each
/// vertex is tested against the colliders whose cells brought it (a collider within the bound of
/// a vertex brings it: the per-cell test above holds for every point of the cell), once per
/// collider, until one is within it. Rebuilds the grid as gather_candidates does.
void gather_reachable(const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid, double translation,
                      double rotation, std::vector<int>& out);

/// Narrow phase over candidates; clears and fills `out`. excluded: #m flags (grasped vertices)
/// or empty.
void narrow_phase(const PosedTool& tool, Projection projection, std::span<const int> candidates,
                  std::span<const Vec3d> q, std::span<const Vec3d> normals, std::span<const std::uint8_t> excluded,
                  std::vector<ContactPoint>& out);

/// Algorithm 2 line 10: contact targets for the virtual mesh (E_con [3], tool held fixed).
///   tool     the model; pose, jaw: the (virtual) tool's pose and jaw value in [0, 1]
///   q        #m virtual-mesh positions; normals: #m unit vertex normals (may be empty for
///            Projection::ClosestPoint)
///   k_con    stiffness put on every target
///   out      appended: one ContactTarget per vertex inside the tool
///   excluded #m flags of vertices to skip (grasped ones), or empty
void detect_contacts(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
                     std::span<const Vec3d> normals, VertexGrid& broadphase, double k_con,
                     std::vector<ContactTarget>& out, std::span<const std::uint8_t> excluded = {});

/// Depth (m, >= 0) of the deepest vertex of q inside the tool's colliders at pose (docs/FORMATS.md, "Replay output":
/// the virtual tool's is the penetration metric; the physical tool's is large by design).
double penetration_depth(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
                         VertexGrid& broadphase, std::span<const std::uint8_t> excluded = {});

}  // namespace ebh
