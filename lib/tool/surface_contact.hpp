#pragma once
// Contact against the virtual mesh's surface, not only its vertices (scene key `contact: surface`;
// docs/MODEL.md, "Contact against the surface").
//
// The paper's E_con [3] acts on virtual vertices inside the tool, so a collider thinner than the
// vertex spacing slips between vertices unfelt and the contact set changes vertex by vertex as a
// tool slides. Here E_con acts on points of the surface's triangles instead: each triangle carries
// a grid of sample points, the centroids of its n x n sub-triangles at barycentric coordinates b
// (n from the triangle's current longest edge and the tool's thinnest part, so that a collider
// cannot pass between the samples even where the surface is stretched). A sample y = sum b_i q_i
// inside a collider is one contact of the paper's form,
//     E = w k_con/2 |y - y_proj|^2,   w = (area of the triangle / n^2) / (sqrt(3)/4 spacing^2) <= 1,
// with y_proj the closest point on the collider's surface (contact.hpp, vertex_contact). The weight
// w is the sample's share of the surface in units of an equilateral triangle of edge `spacing`:
// the contact's stiffness per unit area, k_con / (sqrt(3)/4 spacing^2), does not depend on how
// finely the virtual mesh is triangulated, and a tool part of radius r >= spacing pressed in by
// its radius meets at least ~pi r^2 / (sqrt(3)/4 spacing^2) ~ 7 samples' worth of k_con.
//   - The virtual tool (Newton on E_tool, q fixed) sees each sample as a vertex contact at y with
//     stiffness w k_con: the same exact gradient and Hessian (tool_terms.hpp, contact_terms).
//   - The virtual mesh (Jacobi, tool fixed) gets the sample's pull on each corner i as the target
//     q_i + (y_proj - y) with stiffness w k_con b_i: its gradient at the current q is that of E
//     (b_i w k_con (y - y_proj)), and each corner's diagonal stays w k_con b_i > 0, so the Jacobi
//     iteration keeps the form (and the convergence) of the paper's vertex contact. With
//     b = (1, 0, 0) it is the paper's vertex contact.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "energy/contact_target.hpp"
#include "tool/broadphase.hpp"
#include "tool/contact.hpp"
#include "tool/surface_samples.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

/// The surface's triangles and what the sampling needs (immutable; built once per scene).
struct SurfaceContactModel {
  std::vector<std::array<int, 3>> triangles;  ///< #F vertex indices
  std::vector<std::uint8_t> rest_level;       ///< #F ceil(longest rest edge / spacing), in [1, kMaxSampleLevel]
  std::vector<int> tri_offsets;               ///< #m+1: incident triangles of vertex j are
  std::vector<int> tri_entries;               ///<   tri_entries[tri_offsets[j] .. tri_offsets[j+1])
  double spacing = 0;                         ///< m, the samples' spacing: the tool's thinnest part
  double stiffness_factor = 1;                ///< >= 1, multiplies every sample's weight (surface_stiffness_factor)
};

/// rest: #m rest positions; spacing: the samples' spacing, thinnest_part(tool) in a scene.
SurfaceContactModel build_surface_contact(std::span<const std::array<int, 3>> triangles, std::span<const Vec3d> rest,
                                          double spacing);

/// What a replay should be told about the samples of `s` at rest positions `rest` (one line each,
/// no file named): triangles longer than kMaxSampleLevel spacings, whose samples a collider can
/// pass between; and a total of samples so large (long, thin triangles: n^2 each) that every tick
/// in contact is slow.
std::vector<std::string> surface_contact_warnings(const SurfaceContactModel& s, std::span<const Vec3d> rest);

/// Samples beyond which surface_contact_warnings says a tick in contact will be slow (the committed
/// scenes' virtual meshes carry 0.05-0.23 million with their tools' 1 mm spacing).
inline constexpr double kManySurfaceSamples = 4e6;
/// Samples along a triangle's longest edge beyond which it says so of the triangle: over a thousand
/// samples each (the committed scenes' 2-3; an own coarse mesh's 53 mm triangles with a 1 mm tool:
/// 53, ticks in contact 2.6 ms against 0.05 ms with vertex contact).
inline constexpr int kSlowSampleLevel = 32;
/// Long, thin triangles: n^2 samples (n the longest edge over the spacing) on an area that needs
/// 2 area / spacing^2 of them (an even triangle carries 1.2-2 times that). Over kSliverOversampling
/// times, and over kManySliverSamples samples in such triangles, surface_contact_warnings says the
/// ticks near them will be slow (600 slivers of 30 x 0.1 mm, 0.58 million samples with a 1 mm tool:
/// a replay at 0.005x real time, 1.25x on an even 1.25 mm mesh of the same block).
inline constexpr double kSliverOversampling = 16;
inline constexpr double kManySliverSamples = 1e5;
/// Samples of the triangles reaching within kCrowdProbeSpacings spacings of one vertex (the
/// bounding boxes that meet the cube around it: what a tool there tests at every query) beyond
/// which surface_contact_warnings says ticks there will be slow (the committed scenes: at most a
/// few hundred; 64 triangles of 25 mm meeting at one vertex: 40000, a replay at 0.09x real time).
inline constexpr double kCrowdedSamples = 1e4;
inline constexpr double kCrowdProbeSpacings = 5;

/// The radius of the tool's thinnest part: the smallest radius of a sphere, capsule or cylinder
/// and the smallest half extent of a box (m).
double thinnest_part(const ToolModel& tool);

/// The factor that raises surface contact's k_con to its floor F_limit / (1.5 r): a sphere of
/// radius r pressed in by r/2 displaces a cap of volume 0.654 r^3, so with the stiffness per area
/// k / (sqrt(3)/4 r^2) it meets the force 1.51 k r; at the floor that is the force limit, so the
/// device's limit cannot push the tool's thinnest part (r = spacing) more than half its radius into the
/// surface, and never through it. 1 when k_con is already above the floor or there is no limit.
double surface_stiffness_factor(double k_con, double force_limit, double spacing);

/// Rounds every box collider of `tool` by its smallest half extent (Collider::radius). A sharp
/// box's closest-point projection jumps between faces at its edges: a jaw sliding over the surface
/// drags it along and lets it go. Rounded by its half thickness the jaw's projection is continuous
/// to that depth, which the stiffness floor keeps the contact within.
void round_box_edges(ToolModel& tool);

/// Switches `tool` to surface contact on the virtual mesh (triangles, #m rest positions): rounds
/// its boxes, builds the samples' model with spacing thinnest_part(tool) and the stiffness floor
/// for k_con and the tool's force limit, and sets tool.surface.
void attach_surface_contact(ToolModel& tool, std::span<const std::array<int, 3>> triangles,
                            std::span<const Vec3d> rest, double k_con);

/// One sample point of a triangle: y = b0 q_a + b1 q_b + b2 q_c, E_con weight w.
struct SurfaceSample {
  int triangle = -1;
  std::array<double, 3> b{};
  double weight = 0;
};

/// The sample rows n of triangle t at positions q (surface_sample_level, surface_samples.hpp):
/// ceil(longest edge / spacing) at rest or now,
/// whichever is more (at most kMaxSampleLevel). n stays at its rest value, and the samples move
/// with the surface, unless the triangle is stretched past it; every point of the triangle is
/// then within sqrt(3)/3 spacing ~ 0.58 spacing of a sample, so a tool part of radius >= spacing
/// cannot pass between them. (Sparser samples on stretched triangles let the hook's tip dip
/// between them: in `ebh validate contact`, pushing at 50 mm/s, rows for 2x the spacing gave a
/// 1.2 N fall of the force, rows for the spacing 0.17 N.)
int sample_level(const SurfaceContactModel& s, int t, std::span<const Vec3d> q);

/// The E_con weight of each of triangle t's n^2 samples at positions q (surface_sample_weight; see
/// the header comment).
double sample_weight(const SurfaceContactModel& s, int t, int n, std::span<const Vec3d> q);

/// Appends the n^2 samples of triangle t at positions q (n = sample_level; sub-triangle
/// centroids in for_each_sample's order).
void triangle_samples(const SurfaceContactModel& s, int t, std::span<const Vec3d> q, std::vector<SurfaceSample>& out);

/// The sample's point at positions q.
inline Vec3d sample_point(const SurfaceContactModel& s, const SurfaceSample& p, std::span<const Vec3d> q) {
  const std::array<int, 3>& t = s.triangles[p.triangle];
  return surface_sample_point(p.b[0], p.b[1], p.b[2], q[t[0]], q[t[1]], q[t[2]]);
}

/// The triangle grid of the surface queries holds at most this many cells a triangle (and at
/// least kTriangleGridMinCells): its memory and the cells a query walks follow the surface's
/// triangles, not its smallest ones.
inline constexpr double kTriangleGridCellsPerTriangle = 8;
inline constexpr double kTriangleGridMinCells = 4096;

/// Scratch of the surface queries (reused; sized on first use).
struct SurfaceScratch {
  std::vector<int> triangles;           ///< candidate triangles
  std::vector<std::uint32_t> stamp;     ///< #F: triangle already taken in this query
  std::uint32_t current = 0;
  // A uniform grid of the triangles' bounding boxes, binned when the vertex grid's rebuild
  // number `grid_rebuild` was first seen; queries grow by `grow` (two of its margins).
  int grid_rebuild = -1;
  double cell = 1, grow = 0;
  Vec3d origin{}, upper{};  ///< the binned triangles' bounding box
  int dims[3] = {1, 1, 1};
  std::vector<int> cell_start, cell_entries, fill;
  std::vector<std::array<int, 6>> ranges;  ///< #F the binning's cell range per triangle (first, last per axis)
  /// #cells: the query (`current`) that last walked each cell; a later box of the same query skips
  /// it (its triangles are taken already)
  std::vector<std::uint32_t> cell_stamp;
  std::vector<SurfaceSample> samples;   ///< one triangle's samples
  std::vector<SurfaceSample> kept;      ///< the samples near the tool (targets, penetration)
  std::vector<ContactPoint> contacts;   ///< their contacts
};

/// Samples that a collider of `tool` may reach after moving by up to `translation` and `rotation`
/// (gather_candidates' bound, applied to the sample point); clears and fills `out`. Triangles with
/// a vertex in `excluded` (#m flags, e.g. grasped vertices; may be empty) carry no samples.
void gather_samples(const SurfaceContactModel& s, const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid,
                    double translation, double rotation, std::span<const std::uint8_t> excluded,
                    SurfaceScratch& scratch, std::vector<SurfaceSample>& out);

/// Contacts of the given samples against the posed tool (closest-point projection); clears and fills
/// `out`. Each ContactPoint's `vertex` is the sample's index in `samples`, its weight the sample's.
void sample_narrow_phase(const SurfaceContactModel& s, const PosedTool& tool, std::span<const SurfaceSample> samples,
                         std::span<const Vec3d> q, std::vector<ContactPoint>& out);

/// Algorithm 2 line 10 with surface contact: the targets of every sample inside the tool at
/// `pose`, per corner (see the header comment), appended to `out`.
void surface_contact_targets(const SurfaceContactModel& s, const ToolModel& tool, const ToolPose& pose, double jaw,
                             std::span<const Vec3d> q, VertexGrid& grid, double k_con,
                             std::span<const std::uint8_t> excluded, SurfaceScratch& scratch,
                             std::vector<ContactTarget>& out);

/// The targets of those of `samples` inside the posed tool (surface_contact_targets without the
/// search: for samples already known to hold every contact, e.g. a Newton call's at the same q).
void sample_targets(const SurfaceContactModel& s, const PosedTool& posed, std::span<const SurfaceSample> samples,
                    std::span<const Vec3d> q, double k_con, SurfaceScratch& scratch, std::vector<ContactTarget>& out);

/// Depth (m, >= 0) of the deepest surface sample inside the tool at `pose`.
double surface_penetration_depth(const SurfaceContactModel& s, const ToolModel& tool, const ToolPose& pose, double jaw,
                                 std::span<const Vec3d> q, VertexGrid& grid, std::span<const std::uint8_t> excluded,
                                 SurfaceScratch& scratch);

}  // namespace ebh
