#include "tool/surface_contact.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace ebh {


SurfaceContactModel build_surface_contact(std::span<const std::array<int, 3>> triangles, std::span<const Vec3d> rest,
                                          double spacing) {
  const int vertices = static_cast<int>(rest.size());
  if (!(spacing > 0)) throw std::invalid_argument("build_surface_contact: the sample spacing must be positive");
  SurfaceContactModel s;
  s.spacing = spacing;
  s.triangles.assign(triangles.begin(), triangles.end());
  s.rest_level.resize(s.triangles.size());
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const auto& v = s.triangles[t];
    s.rest_level[t] = static_cast<std::uint8_t>(
        clamp_sample_level(std::ceil(triangle_longest_edge(rest[v[0]], rest[v[1]], rest[v[2]]) / spacing)));
  }
  std::vector<int> count(vertices + 1, 0);
  for (const auto& v : s.triangles)
    for (const int i : v) ++count[i + 1];
  s.tri_offsets.assign(vertices + 1, 0);
  for (int j = 0; j < vertices; ++j) s.tri_offsets[j + 1] = s.tri_offsets[j] + count[j + 1];
  s.tri_entries.resize(s.tri_offsets[vertices]);
  std::vector<int> fill(s.tri_offsets.begin(), s.tri_offsets.end() - 1);
  for (std::size_t t = 0; t < s.triangles.size(); ++t)
    for (const int i : s.triangles[t]) s.tri_entries[fill[i]++] = static_cast<int>(t);
  return s;
}

double thinnest_part(const ToolModel& tool) {
  double r = INFINITY;
  for (const Collider<double>& c : tool.colliders) {
    if (c.shape == Shape::Box)
      r = std::min({r, c.half.x, c.half.y, c.half.z});
    else
      r = std::min(r, c.radius);
  }
  return r;
}


void round_box_edges(ToolModel& tool) {
  for (Collider<double>& c : tool.colliders)
    if (c.shape == Shape::Box) c.radius = std::min({c.half.x, c.half.y, c.half.z});
}

void attach_surface_contact(ToolModel& tool, std::span<const std::array<int, 3>> triangles,
                            std::span<const Vec3d> rest, double k_con) {
  round_box_edges(tool);
  SurfaceContactModel s = build_surface_contact(triangles, rest, thinnest_part(tool));
  s.stiffness_factor = surface_stiffness_factor(k_con, tool.spec.force_limit, s.spacing);
  tool.surface = std::make_shared<const SurfaceContactModel>(std::move(s));
}

int sample_level(const SurfaceContactModel& s, int t, std::span<const Vec3d> q) {
  const auto& v = s.triangles[t];
  return surface_sample_level(s.rest_level[t], s.spacing, q[v[0]], q[v[1]], q[v[2]]);
}

double sample_weight(const SurfaceContactModel& s, int t, int n, std::span<const Vec3d> q) {
  const auto& v = s.triangles[t];
  return surface_sample_weight(s.stiffness_factor, s.spacing, n, q[v[0]], q[v[1]], q[v[2]]);
}

double surface_stiffness_factor(double k_con, double force_limit, double spacing) {
  if (!(force_limit > 0) || !(spacing > 0) || !(k_con > 0)) return 1.0;
  return std::max(1.0, force_limit / (1.5 * spacing) / k_con);
}

void triangle_samples(const SurfaceContactModel& s, int t, std::span<const Vec3d> q, std::vector<SurfaceSample>& out) {
  const int n = sample_level(s, t, q);
  const double w = sample_weight(s, t, n, q);
  for_each_sample(n, [&](double b0, double b1, double b2) { out.push_back({t, {b0, b1, b2}, w}); });
}

namespace {

/// The triangle grid's cells [i0, i1] (per axis, clamped to the grid) that the box [a, b] covers.
void cell_range(const SurfaceScratch& sc, Vec3d a, Vec3d b, int* i0, int* i1) {
  for (int k = 0; k < 3; ++k) {
    i0[k] = std::clamp(static_cast<int>(std::floor((a[k] - sc.origin[k]) / sc.cell)), 0, sc.dims[k] - 1);
    i1[k] = std::clamp(static_cast<int>(std::floor((b[k] - sc.origin[k]) / sc.cell)), 0, sc.dims[k] - 1);
  }
}

std::size_t cell_id(const SurfaceScratch& sc, int x, int y, int z) {
  return (static_cast<std::size_t>(x) * sc.dims[1] + y) * sc.dims[2] + z;
}

/// Calls take(t) once for each triangle binned in the cells the box [a, b] covers that the query
/// `stamp` (sc.current) has not taken yet; a cell an earlier box of the query walked is skipped.
template <class Take>
void for_each_new_triangle(SurfaceScratch& sc, Vec3d a, Vec3d b, std::uint32_t stamp, Take&& take) {
  int i0[3], i1[3];
  cell_range(sc, a, b, i0, i1);
  for (int x = i0[0]; x <= i1[0]; ++x)
    for (int y = i0[1]; y <= i1[1]; ++y)
      for (int z = i0[2]; z <= i1[2]; ++z) {
        const std::size_t cell = cell_id(sc, x, y, z);
        if (sc.cell_stamp[cell] == stamp) continue;  // an earlier box of this query walked it
        sc.cell_stamp[cell] = stamp;
        for (int e = sc.cell_start[cell]; e < sc.cell_start[cell + 1]; ++e) {
          const int t = sc.cell_entries[e];
          if (sc.stamp[t] == stamp) continue;
          sc.stamp[t] = stamp;
          take(t);
        }
      }
}

/// (Re)bins the triangles by their bounding boxes at q when the vertex grid was rebuilt since the
/// last time (the vertex grid keeps every vertex within its margin of where it was built, so
/// within two margins of q here: queries grow by that).
void refresh_triangle_grid(const SurfaceContactModel& s, std::span<const Vec3d> q, VertexGrid& grid,
                           SurfaceScratch& sc) {
  if (grid.stale(q.size())) grid.rebuild(q, grid.margin());
  if (sc.grid_rebuild == grid.rebuilds() && sc.stamp.size() == s.triangles.size()) return;
  sc.grid_rebuild = grid.rebuilds();
  const std::size_t F = s.triangles.size();
  sc.stamp.assign(F, 0);
  sc.current = 0;
  sc.grow = 2.0 * grid.margin();
  Vec3d lo{INFINITY, INFINITY, INFINITY}, hi = -lo;
  double mean_edge = 0;
  for (const auto& v : s.triangles) {
    for (const int i : v) { lo = cwise_min(lo, q[i]); hi = cwise_max(hi, q[i]); }
    mean_edge += norm(q[v[1]] - q[v[0]]);
  }
  mean_edge = F ? mean_edge / F : 1.0;
  sc.origin = lo;
  sc.upper = hi;
  // Cells of two mean edges, but at most kTriangleGridCellsPerTriangle a triangle: a small dense
  // patch (a locally refined region of 0.5 million tiny triangles) makes the mean edge tiny, and
  // the whole surface's grid 1024^3 cells (8.6 GB, its cells walked by every query wherever the
  // tool is). The cells then grow until the grid holds no more.
  const double most_cells = std::max(kTriangleGridMinCells, kTriangleGridCellsPerTriangle * static_cast<double>(F));
  sc.cell = std::max(2.0 * mean_edge, 1e-6);
  for (;;) {
    double cells = 1;
    for (int k = 0; k < 3; ++k) {
      sc.dims[k] = F ? std::max(1, std::min(1024, static_cast<int>((hi[k] - lo[k]) / sc.cell) + 1)) : 1;
      cells *= sc.dims[k];
    }
    if (cells <= most_cells) break;
    sc.cell *= std::max(1.01, std::cbrt(cells / most_cells));
  }
  const std::size_t cells = static_cast<std::size_t>(sc.dims[0]) * sc.dims[1] * sc.dims[2];
  sc.cell_start.assign(cells + 1, 0);
  sc.cell_stamp.assign(cells, 0);  // with sc.current back at 0
  // Two passes (count, then fill) over the cells each triangle's box covers, the first keeping
  // each triangle's cell range for the second.
  sc.ranges.resize(F);
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      for (std::size_t c = 0; c < cells; ++c) sc.cell_start[c + 1] += sc.cell_start[c];
      sc.cell_entries.resize(sc.cell_start[cells]);
      sc.fill.assign(sc.cell_start.begin(), sc.cell_start.end() - 1);
    }
    for (std::size_t t = 0; t < F; ++t) {
      int* i0 = sc.ranges[t].data();
      int* i1 = i0 + 3;
      if (pass == 0) {
        const auto& v = s.triangles[t];
        cell_range(sc, cwise_min(cwise_min(q[v[0]], q[v[1]]), q[v[2]]),
                   cwise_max(cwise_max(q[v[0]], q[v[1]]), q[v[2]]), i0, i1);
      }
      for (int x = i0[0]; x <= i1[0]; ++x)
        for (int y = i0[1]; y <= i1[1]; ++y)
          for (int z = i0[2]; z <= i1[2]; ++z) {
            const std::size_t c = cell_id(sc, x, y, z);
            if (pass == 0) ++sc.cell_start[c + 1];
            else sc.cell_entries[sc.fill[c]++] = static_cast<int>(t);
          }
    }
  }
}

/// The triangles a collider of `tool` may reach after moving by up to `translation` and `rotation`,
/// each once, in a fixed order (colliders, their covering boxes, cells, the cells' triangles), with
/// those of an `excluded` vertex left out.
void candidate_triangles(const SurfaceContactModel& s, const PosedTool& tool, std::span<const Vec3d> q,
                         VertexGrid& grid, double translation, double rotation, std::span<const std::uint8_t> excluded,
                         SurfaceScratch& sc, std::vector<int>& triangles) {
  refresh_triangle_grid(s, q, grid, sc);
  triangles.clear();
  const std::uint32_t stamp = ++sc.current;
  const double T = translation, th = std::min(rotation, 0.5);
  for (int c = 0; c < tool.count; ++c) {
    const Collider<double>& shape = tool.shape[c];
    const Rigid<double>& w = tool.world[c];
    const double grow = sc.grow + (T + th * (tool.reach[c] + T)) / (1.0 - th);
    cover_collider(shape, w, sc.cell, [&](Vec3d lo, Vec3d hi) {
      const Vec3d g{grow, grow, grow}, a = lo - g, b = hi + g;
      for (int k = 0; k < 3; ++k)  // a box wholly outside the binned triangles holds none (the last
        if (b[k] < sc.origin[k] || a[k] > sc.upper[k]) return;  // cell also holds those past 1024 cells)
      for_each_new_triangle(sc, a, b, stamp, [&](int t) {
        const auto& v = s.triangles[t];
        if (!excluded.empty() && (excluded[v[0]] || excluded[v[1]] || excluded[v[2]])) return;
        // The triangle's bounding sphere against gather_candidates' bound (s = its radius).
        Vec3d mid;
        const double R = triangle_bounding_sphere(q[v[0]], q[v[1]], q[v[2]], mid);
        const double bound = (R + T + th * (norm(mid - tool.origin) + T)) / (1.0 - th);
        for (int k = 0; k < tool.count; ++k)
          if (signed_distance_local(tool.shape[k], apply_inverse(tool.world[k], mid)) <= bound) {
            triangles.push_back(t);
            break;
          }
      });
    });
  }
}

/// The vertex whose probe (the cube of kCrowdProbeSpacings spacings around it) the bounding boxes
/// of the most samples meet: what a tool there tests at every query. Binned at rest.
struct Crowding {
  double samples = 0;
  std::size_t vertex = 0;
  int triangles = 0;
};
Crowding most_crowded_vertex(const SurfaceContactModel& s, std::span<const Vec3d> rest) {
  VertexGrid grid;
  grid.rebuild(rest, s.spacing);
  SurfaceScratch sc;
  refresh_triangle_grid(s, rest, grid, sc);
  const std::size_t F = s.triangles.size();
  std::vector<Vec3d> box_lo(F), box_hi(F);
  for (std::size_t t = 0; t < F; ++t) {
    const auto& v = s.triangles[t];
    box_lo[t] = cwise_min(cwise_min(rest[v[0]], rest[v[1]]), rest[v[2]]);
    box_hi[t] = cwise_max(cwise_max(rest[v[0]], rest[v[1]]), rest[v[2]]);
  }
  const Vec3d reach = Vec3d{1, 1, 1} * (kCrowdProbeSpacings * s.spacing);
  Crowding most;
  for (std::size_t a = 0; a < rest.size(); ++a) {
    const Vec3d lo = rest[a] - reach, hi = rest[a] + reach;
    Crowding here{0, a, 0};
    for_each_new_triangle(sc, lo, hi, ++sc.current, [&](int t) {
      if (box_hi[t].x < lo.x || box_lo[t].x > hi.x || box_hi[t].y < lo.y || box_lo[t].y > hi.y || box_hi[t].z < lo.z ||
          box_lo[t].z > hi.z)
        return;
      const double n = s.rest_level[t];
      here.samples += n * n;
      ++here.triangles;
    });
    if (here.samples > most.samples) most = here;
  }
  return most;
}

}  // namespace

std::vector<std::string> surface_contact_warnings(const SurfaceContactModel& s, std::span<const Vec3d> rest) {
  std::vector<std::string> out;
  int too_long = 0, slow = 0, slivers = 0;
  double longest = 0, samples = 0, sliver_samples = 0, sliver_need = 0;
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const auto& v = s.triangles[t];
    const double edge = triangle_longest_edge(rest[v[0]], rest[v[1]], rest[v[2]]);
    longest = std::max(longest, edge);
    if (edge > kMaxSampleLevel * s.spacing) ++too_long;
    else if (s.rest_level[t] > kSlowSampleLevel) ++slow;
    const double n2 = static_cast<double>(s.rest_level[t]) * s.rest_level[t];
    samples += n2;
    const double need = norm(cross(rest[v[1]] - rest[v[0]], rest[v[2]] - rest[v[0]])) / (s.spacing * s.spacing);
    if (n2 > kSliverOversampling * std::max(need, 1.0)) {
      ++slivers;
      sliver_samples += n2;
      sliver_need += need;
    }
  }
  char line[560];
  if (sliver_samples > kManySliverSamples && samples <= kManySurfaceSamples) {
    std::snprintf(line, sizeof line,
                  "surface contact: %d long, thin triangles of the virtual mesh carry %.3g sample points, %.3g times "
                  "what their area needs (a triangle's n^2 samples follow its longest edge; the spacing, the tool's "
                  "thinnest part, %.4g mm): a tick near them tests them all, so ticks there are slow; remesh the "
                  "virtual mesh with triangles of even shape",
                  slivers, sliver_samples, sliver_samples / std::max(sliver_need, 1.0), s.spacing * 1e3);
    out.emplace_back(line);
  }
  if (slow > 0) {
    std::snprintf(line, sizeof line,
                  "surface contact: %d %s of the virtual mesh %s longer than %d sample spacings (the longest %.4g mm; "
                  "the spacing, the tool's thinnest part, %.4g mm): each carries n^2 samples (n its longest edge over "
                  "the spacing), which a tick near it tests, so ticks in contact there are slow; mesh.virtual_refine "
                  "or a finer mesh splits them",
                  slow, slow == 1 ? "triangle" : "triangles", slow == 1 ? "is" : "are", kSlowSampleLevel, longest * 1e3,
                  s.spacing * 1e3);
    out.emplace_back(line);
  }
  if (too_long > 0) {
    std::snprintf(line, sizeof line,
                  "surface contact: %d %s of the virtual mesh %s longer than %d sample spacings (the longest "
                  "%.4g mm; the spacing, the tool's thinnest part, %.4g mm): a collider can pass between their samples "
                  "unfelt, and each carries 4096 samples, which a tick near it tests; refine the virtual mesh "
                  "(mesh.virtual_refine) or remesh it finer",
                  too_long, too_long == 1 ? "triangle" : "triangles", too_long == 1 ? "is" : "are", kMaxSampleLevel,
                  longest * 1e3, s.spacing * 1e3);
    out.emplace_back(line);
  }
  // Crowding: the samples a tool near one point tests at every query, those of the triangles whose
  // bounding boxes meet the cube of kCrowdProbeSpacings spacings around a vertex: a fan of long
  // triangles meeting at one vertex crowds it although no triangle is long or thin enough for the
  // warnings above (said only where none above or below names the cause already).
  if (out.empty() && slow == 0 && too_long == 0 && samples <= kManySurfaceSamples && !s.triangles.empty()) {
    if (const Crowding c = most_crowded_vertex(s, rest); c.samples > kCrowdedSamples) {
      const Vec3d& at = rest[c.vertex];
      std::snprintf(line, sizeof line,
                    "surface contact: %d triangles of the virtual mesh reach within %.3g mm of its vertex %zu (at "
                    "(%.4g, %.4g, %.4g) mm) and carry %.3g sample points (a triangle n^2, n its longest edge over the "
                    "spacing, %.4g mm), which a tool there tests at every query: ticks there are slow (long "
                    "triangles meeting there, or a great many small ones); remesh the virtual mesh with triangles "
                    "of even size and spacing, or split long ones (mesh.virtual_refine)",
                    c.triangles, kCrowdProbeSpacings * s.spacing * 1e3, c.vertex, at.x * 1e3, at.y * 1e3, at.z * 1e3,
                    c.samples, s.spacing * 1e3);
      out.emplace_back(line);
    }
  }
  if (samples > kManySurfaceSamples) {
    std::snprintf(line, sizeof line,
                  "surface contact: the virtual mesh's triangles carry %.3g sample points (a triangle n^2, n its longest "
                  "edge over the spacing, %.4g mm): a tick in contact with long, thin triangles is slow; remesh the "
                  "virtual mesh with triangles of even size",
                  samples, s.spacing * 1e3);
    out.emplace_back(line);
  }
  return out;
}

void gather_samples(const SurfaceContactModel& s, const PosedTool& tool, std::span<const Vec3d> q, VertexGrid& grid,
                    double translation, double rotation, std::span<const std::uint8_t> excluded,
                    SurfaceScratch& scratch, std::vector<SurfaceSample>& out) {
  candidate_triangles(s, tool, q, grid, translation, rotation, excluded, scratch, scratch.triangles);
  out.clear();
  const double T = translation, th = std::min(rotation, 0.5);
  for (const int t : scratch.triangles) {
    scratch.samples.clear();
    triangle_samples(s, t, q, scratch.samples);
    for (const SurfaceSample& p : scratch.samples) {
      // gather_candidates' bound for a point (s = 0): keep the samples some collider can reach.
      const Vec3d y = sample_point(s, p, q);
      const double bound = (T + th * (norm(y - tool.origin) + T)) / (1.0 - th);
      for (int c = 0; c < tool.count; ++c)
        if (signed_distance_local(tool.shape[c], apply_inverse(tool.world[c], y)) <= bound) {
          out.push_back(p);
          break;
        }
    }
  }
}

void sample_narrow_phase(const SurfaceContactModel& s, const PosedTool& tool, std::span<const SurfaceSample> samples,
                         std::span<const Vec3d> q, std::vector<ContactPoint>& out) {
  out.clear();
  ContactPoint cp;
  for (std::size_t k = 0; k < samples.size(); ++k)
    if (vertex_contact(tool, Projection::ClosestPoint, static_cast<int>(k), sample_point(s, samples[k], q), Vec3d{},
                       cp)) {
      cp.weight = samples[k].weight;
      out.push_back(cp);
    }
}

void surface_contact_targets(const SurfaceContactModel& s, const ToolModel& tool, const ToolPose& pose, double jaw,
                             std::span<const Vec3d> q, VertexGrid& grid, double k_con,
                             std::span<const std::uint8_t> excluded, SurfaceScratch& scratch,
                             std::vector<ContactTarget>& out) {
  const PosedTool posed = pose_tool(tool, pose, jaw);
  gather_samples(s, posed, q, grid, 0.0, 0.0, excluded, scratch, scratch.kept);
  sample_targets(s, posed, scratch.kept, q, k_con, scratch, out);
}

void sample_targets(const SurfaceContactModel& s, const PosedTool& posed, std::span<const SurfaceSample> samples,
                    std::span<const Vec3d> q, double k_con, SurfaceScratch& scratch, std::vector<ContactTarget>& out) {
  sample_narrow_phase(s, posed, samples, q, scratch.contacts);
  for (const ContactPoint& c : scratch.contacts) {
    const SurfaceSample& p = samples[c.vertex];
    const Vec3d shift = c.target - c.lever;  // y_proj - y
    const auto& v = s.triangles[p.triangle];
    for (int k = 0; k < 3; ++k)
      if (p.b[k] > 0) out.push_back({v[k], q[v[k]] + shift, k_con * p.weight * p.b[k]});
  }
}

double surface_penetration_depth(const SurfaceContactModel& s, const ToolModel& tool, const ToolPose& pose, double jaw,
                                 std::span<const Vec3d> q, VertexGrid& grid, std::span<const std::uint8_t> excluded,
                                 SurfaceScratch& scratch) {
  const PosedTool posed = pose_tool(tool, pose, jaw);
  gather_samples(s, posed, q, grid, 0.0, 0.0, excluded, scratch, scratch.kept);
  double deepest = 0.0;
  for (const SurfaceSample& p : scratch.kept) {
    const Vec3d y = sample_point(s, p, q);
    for (int c = 0; c < posed.count; ++c)
      deepest = std::max(deepest, -signed_distance_local(posed.shape[c], apply_inverse(posed.world[c], y)));
  }
  return deepest;
}

}  // namespace ebh
