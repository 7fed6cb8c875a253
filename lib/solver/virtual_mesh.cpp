// The virtual mesh: construction, pairing with the physical mesh, and the haptic-rate
// local-global iterations (the soft part of Algorithm 2).
#include "solver/virtual_mesh.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <unordered_map>

#include "core/error.hpp"
#include "energy/edge_spring.hpp"
#include "energy/quadratic.hpp"
#include "mesh/boundary.hpp"
#include "mesh/csr.hpp"
#include "mesh/lumped_masses.hpp"
#include "mesh/morton.hpp"
#include "mesh/surface.hpp"
#include "mesh/tet_locator.hpp"
#include "scene/scene.hpp"
#include "solver/local_kernels.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/shared_loops.hpp"
#include "solver/virtual_jacobi.hpp"

namespace ebh {

namespace {

/// The virtual mesh numbered in Morton order of its vertices, its triangles by their first vertex
/// in that order: neighbours on the surface sit near each other in memory, so the passes over an
/// active region (or the mesh) walk it forward. A boundary's own numbering follows the physical
/// mesh's file, which may scatter neighbours across the whole index range, and refinement appends
/// the midpoints. A user's virtual mesh (an OBJ file) used unrefined keeps the file's order.
/// `parent` is renumbered with the vertices.
void renumber_local(SurfaceMesh& surface, std::vector<std::array<int, 2>>& parent) {
  const std::vector<int> order = morton_order(surface.vertices, morton_box(surface.vertices));
  std::vector<int> local(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) local[order[i]] = static_cast<int>(i);
  SurfaceMesh out;
  std::vector<std::array<int, 2>> out_parent(order.size());
  out.vertices.reserve(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    out.vertices.push_back(surface.vertices[order[i]]);
    out_parent[i] = {local[parent[order[i]][0]], local[parent[order[i]][1]]};
  }
  out.triangles.reserve(surface.triangles.size());
  for (const Tri& t : surface.triangles) out.triangles.push_back({local[t[0]], local[t[1]], local[t[2]]});
  std::stable_sort(out.triangles.begin(), out.triangles.end(), [](const Tri& a, const Tri& b) {
    return std::min({a[0], a[1], a[2]}) < std::min({b[0], b[1], b[2]});
  });
  surface = std::move(out);
  parent = std::move(out_parent);
}

/// The physical mesh's boundary vertices farther than `reach` from the virtual mesh's surface (its
/// triangles at rest): how many, of how many, and one of them.
struct Uncovered {
  std::size_t count = 0, of = 0;
  double reach = 0;
  Vec3d at;
};
Uncovered uncovered_boundary(const TetMesh& physical, const VirtualModel& vm, double reach) {
  Uncovered u;
  u.reach = reach;
  if (!(reach > 0) || vm.triangles.empty()) return u;
  // The triangles binned by their bounding boxes in cells of edge `reach`: one within `reach` of a
  // point overlaps the point's cell or one of the 26 around it.
  const Vec3d lo = bounding_box(vm.rest).lo;
  auto cell = [&](const Vec3d& p) {
    auto c = [&](double x, double o) { return static_cast<std::int64_t>(std::clamp(std::floor((x - o) / reach), -1e6, 1e6)); };
    return std::array<std::int64_t, 3>{c(p.x, lo.x), c(p.y, lo.y), c(p.z, lo.z)};
  };
  auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) { return (i * 2000003 + j) * 2000003 + k; };
  std::unordered_map<std::int64_t, std::vector<int>> cells;
  for (int t = 0; t < static_cast<int>(vm.triangles.size()); ++t) {
    const auto& tri = vm.triangles[t];
    const BoundingBox box = bounding_box({vm.rest[tri[0]], vm.rest[tri[1]], vm.rest[tri[2]]});
    const auto a = cell(box.lo), b = cell(box.hi);
    for (std::int64_t i = a[0]; i <= b[0]; ++i)
      for (std::int64_t j = a[1]; j <= b[1]; ++j)
        for (std::int64_t k = a[2]; k <= b[2]; ++k) cells[key(i, j, k)].push_back(t);
  }
  for (const Vec3d& p : extract_boundary(physical).vertices) {
    ++u.of;
    const auto c = cell(p);
    bool near = false;
    for (std::int64_t i = c[0] - 1; i <= c[0] + 1 && !near; ++i)
      for (std::int64_t j = c[1] - 1; j <= c[1] + 1 && !near; ++j)
        for (std::int64_t k = c[2] - 1; k <= c[2] + 1 && !near; ++k)
          if (auto it = cells.find(key(i, j, k)); it != cells.end())
            for (int t : it->second) {
              const auto& tri = vm.triangles[t];
              const Vec3d &ta = vm.rest[tri[0]], &tb = vm.rest[tri[1]], &tc = vm.rest[tri[2]];
              const std::array<double, 3> w = closest_on_triangle(p, ta, tb, tc);
              if (norm(w[0] * ta + w[1] * tb + w[2] * tc - p) <= reach) {
                near = true;
                break;
              }
            }
    if (!near && u.count++ == 0) u.at = p;
  }
  return u;
}

}  // namespace

void check_virtual_mesh_placement(const Scene& scene, const VirtualModel& vm, std::vector<std::string>& warnings) {
  if (!scene.spec.virtual_mesh) return;
  const std::string where = scene.spec.virtual_mesh->string() + ": mesh.virtual: the virtual mesh ";
  const char* frame = "is it in mesh.unit and the physical mesh's frame (mesh.transform places both)?";
  const BoundingBox physical = bounding_box(scene.physical.vertices);
  const double diagonal = physical.diagonal();
  char buf[320];
  if (vm.pairing_worst >= 0 && vm.pairing_max_error > 0.01 * diagonal) {
    // Where, not which: the model's vertex numbers are not the file's (refined, renumbered).
    const Vec3d at = vm.rest[vm.pairing_worst];
    if (!(vm.pairing_max_error <= kVirtualFarOff * diagonal)) {
      std::snprintf(buf, sizeof buf, "%.3g m off the physical mesh (the virtual vertex at %.4g, %.4g, %.4g m), more "
                    "than %g times its diagonal (%.3g m)", vm.pairing_max_error, at.x, at.y, at.z, kVirtualFarOff, diagonal);
      throw InputError(where + "lies up to " + buf + ": it is not a surface of this mesh; " + frame);
    }
    std::snprintf(buf, sizeof buf, "%.3g mm off the physical mesh (the virtual vertex at %.4g, %.4g, %.4g mm; 1%% of "
                  "its diagonal is %.3g mm)", vm.pairing_max_error * 1e3, at.x * 1e3, at.y * 1e3, at.z * 1e3,
                  0.01 * diagonal * 1e3);
    warnings.push_back(where + "lies up to " + buf + ": its E_svc targets pull it onto the physical mesh; " + frame);
  }
  // An open surface (a hole, a cut patch, a soup of unwelded faces) lets the tool through unfelt.
  const SurfaceEdges edges = surface_edges(scene.virtual_surface.triangles);
  if (edges.open > 0) {
    std::string soup;
    if (edges.loose_faces > 0)
      soup = "; " + std::to_string(edges.loose_faces) + " of its " + std::to_string(scene.virtual_surface.triangles.size()) +
             " faces share no edge with another: corners that differ by round-off, never welded";
    // Two borders along each other: a seam never welded (its copies farther apart than a weld).
    const UnweldedSeam seam = unwelded_seam(scene.virtual_surface);
    std::string seam_text;
    if (seam.edges > 0) {
      std::snprintf(buf, sizeof buf, "; %lld of the open edges lie along another, up to %.3g mm apart: a seam never "
                    "welded, whose vertices a mesh tool merges by distance", seam.edges, seam.gap * 1e3);
      seam_text = buf;
    }
    // T-junctions: closed in space, not in its connectivity.
    std::string junction_text;
    if (const long long junctions = t_junctions(scene.virtual_surface); junctions > 0)
      junction_text = "; " + std::to_string(junctions) + (junctions == 1 ? " vertex lies" : " vertices lie") +
                      " inside another face's edge (T-junctions: no gap there, but no edge joins the faces on either "
                      "side: split the long edges at those vertices)";
    // Where: a hole is found by the box its rim lies in (several holes: the box of them all).
    Vec3d lo = scene.virtual_surface.vertices[edges.open_edges.front()[0]], hi = lo;
    for (const auto& e : edges.open_edges)
      for (const int v : e) {
        lo = cwise_min(lo, scene.virtual_surface.vertices[v]);
        hi = cwise_max(hi, scene.virtual_surface.vertices[v]);
      }
    std::snprintf(buf, sizeof buf, " (the open edges lie within (%.4g, %.4g, %.4g) .. (%.4g, %.4g, %.4g) mm)",
                  lo.x * 1e3, lo.y * 1e3, lo.z * 1e3, hi.x * 1e3, hi.y * 1e3, hi.z * 1e3);
    warnings.push_back(where + "is not closed: " + std::to_string(edges.open) +
                       " of its edges belong to one face only (a hole, a cut patch" + soup + seam_text + junction_text +
                       "): a tool that passes through an opening feels nothing there" + buf);
  }
  if (edges.nonmanifold > 0)
    warnings.push_back(where + "has " + std::to_string(edges.nonmanifold) +
                       (edges.nonmanifold == 1 ? " edge" : " edges") +
                       " of three faces or more (a wall inside the surface, or two organs sharing a face): the tool "
                       "meets such a wall as surface too");
  const BoundingBox box = bounding_box(vm.rest);
  const double span = box.diagonal();
  // A closed virtual mesh over part of the physical mesh only (a segmentation's surface of one
  // lobe): a tool pressed into the rest meets no virtual vertex and renders next to nothing
  // there. Said where over 1% of the physical boundary's vertices lie farther from the virtual
  // mesh's surface than 5% of the diagonal (a smoothed surface's rounded corners lie within it).
  if (const Uncovered u = uncovered_boundary(scene.physical, vm, kUncoveredReach * diagonal);
      u.count > 0 && u.count * 100 > u.of) {
    std::snprintf(buf, sizeof buf, "covers part of the physical mesh only: %zu of its %zu boundary vertices (%.0f%%) "
                  "lie more than %.3g mm from its surface (one at %.4g, %.4g, %.4g mm)",
                  u.count, u.of, 100.0 * static_cast<double>(u.count) / static_cast<double>(u.of), u.reach * 1e3,
                  u.at.x * 1e3, u.at.y * 1e3, u.at.z * 1e3);
    // Much smaller than the physical mesh, and its box ten times larger the physical mesh's: the
    // same organ in another unit (cm beside mm), not a surface of one part of it.
    std::string unit;
    if (span > 0 && span * 5 < diagonal && span * 20 >= diagonal && norm(10.0 * box.lo - physical.lo) <= 0.25 * diagonal &&
        norm(10.0 * box.hi - physical.hi) <= 0.25 * diagonal) {
      char size[200];
      std::snprintf(size, sizeof size, "; it spans 1/%.3g of the physical mesh's diagonal: is it in another unit than "
                    "mesh.unit (an OBJ in cm beside a mesh in mm is 1/10 of its size)?", diagonal / span);
      unit = size;
    }
    warnings.push_back(where + buf + ": a tool pressed in there passes through the physical mesh unfelt" + unit);
  }
  // A surface of the physical mesh is no larger than it: one twice its size is in another unit
  // (an OBJ in mm read as cm is 10 times it), and E_svc would drag the physical mesh out to it
  // (310 tets inverted in the first second).
  if (span > 2 * diagonal) {
    std::snprintf(buf, sizeof buf, "spans %.3g mm, %.3g times the physical mesh's diagonal (%.3g mm)", span * 1e3,
                  span / diagonal, diagonal * 1e3);
    throw InputError(where + buf + ": it is not a surface of this mesh; " + frame);
  }
  if (span < diagonal / 20) {
    std::snprintf(buf, sizeof buf, "spans %.3g mm, 1/%.0f of the physical mesh's diagonal (%.3g mm)", span * 1e3,
                  span > 0 ? diagonal / span : INFINITY, diagonal * 1e3);
    warnings.push_back(where + buf + ": is it in mesh.unit (a mesh in m read as mm is 1/1000 of its size)? (A patch "
                                     "of the surface may be this small.)");
  }
}

VirtualModel build_virtual_model(const Scene& scene) {
  const TetMesh& phys = scene.physical;
  const std::string where = scene.spec.file.string();
  if (phys.tets.empty()) throw InputError(where + ": the physical mesh has no tets to pair the virtual mesh with");
  SurfaceMesh surface = scene.virtual_surface.triangles.empty() ? extract_boundary(phys) : scene.virtual_surface;
  std::vector<std::array<int, 2>> parent;
  if (scene.spec.virtual_refine > 0) {
    surface = refine_surface(surface, parent);
  } else {
    for (int i = 0; i < static_cast<int>(surface.vertices.size()); ++i) parent.push_back({i, i});
  }
  if (!scene.spec.virtual_mesh || scene.spec.virtual_refine > 0) renumber_local(surface, parent);

  VirtualModel M;
  const int m = static_cast<int>(surface.vertices.size());
  M.num_vertices = m;
  M.k_s = scene.spec.stiffness.k_s;
  M.k_svc = scene.spec.stiffness.k_svc;
  M.damping = scene.spec.solver.virtual_damping;
  M.gravity = scene.spec.gravity;
  M.rest = surface.vertices;
  M.triangles = surface.triangles;

  // Edges, unique, sorted.
  std::vector<std::array<int, 2>> edges;
  for (const Tri& t : M.triangles)
    for (int k = 0; k < 3; ++k) edges.push_back({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  M.edges = std::move(edges);
  for (const auto& e : M.edges) M.rest_edge.push_back(M.rest[e[0]] - M.rest[e[1]]);
  const int E = static_cast<int>(M.edges.size());
  build_csr(m, 2 * E, [&](int i, auto add) { add(M.edges[i >> 1][i & 1]); }, M.edge_offsets, M.edge_entries);
  for (const Vec3d& e0 : M.rest_edge) M.rest_len.push_back(norm(e0));
  build_csr(m, static_cast<int>(M.triangles.size()), [&](int f, auto add) { for (int v : M.triangles[f]) add(v); },
            M.tri_offsets, M.tri_entries);

  // Pairing: a vertex at a physical vertex takes it with weight 1; the midpoint of two such
  // vertices takes both with 1/2; any other vertex is embedded in its containing tet.
  std::map<std::tuple<double, double, double>, int> at_vertex;
  for (int i = 0; i < static_cast<int>(phys.vertices.size()); ++i)
    at_vertex.emplace(std::make_tuple(phys.vertices[i].x, phys.vertices[i].y, phys.vertices[i].z), i);
  auto exact = [&](const Vec3d& p) {
    auto it = at_vertex.find(std::make_tuple(p.x, p.y, p.z));
    return it == at_vertex.end() ? -1 : it->second;
  };
  std::unique_ptr<TetLocator> locator;
  M.pair_vertex.assign(m, {-1, -1, -1, -1});
  M.pair_weight.assign(m, {0, 0, 0, 0});
  M.pair_count.assign(m, 0);
  for (int j = 0; j < m; ++j) {
    TetEmbedding pair;
    const auto [a, b] = parent[j];
    const int ia = exact(surface.vertices[a]), ib = exact(surface.vertices[b]);
    if (a == b && ia >= 0) {
      pair.vertex[0] = ia; pair.weight[0] = 1.0; pair.count = 1;
    } else if (a != b && ia >= 0 && ib >= 0) {
      pair.vertex[0] = ia; pair.vertex[1] = ib; pair.weight[0] = pair.weight[1] = 0.5; pair.count = 2;
    } else {
      if (!locator) locator = std::make_unique<TetLocator>(phys);
      double err = 0;
      pair = locator->locate(M.rest[j], err);
      if (pair.count == 0) throw InputError(where + ": virtual vertex " + std::to_string(j) + " cannot be paired");
    }
    M.pair_vertex[j] = pair.vertex;
    M.pair_weight[j] = pair.weight;
    M.pair_count[j] = pair.count;
    const Vec3d p = paired_point(phys.vertices.data(), pair.vertex.data(), pair.weight.data(), pair.count);
    if (const double e = norm(p - M.rest[j]); e > M.pairing_max_error) {
      M.pairing_max_error = e;
      M.pairing_worst = j;
    }
  }

  // Mass: each physical vertex lends its lumped mass to the virtual vertices paired with it, in
  // proportion to their weights: m_j = sum_k w_jk m_i / c_i, c_i = sum_j w_ji. The virtual mesh
  // thus carries the mass of the physical vertices it is tied to (docs/MODEL.md).
  const std::vector<double> phys_mass = lumped_masses(phys, scene.spec.density);
  std::vector<double> share(phys.vertices.size(), 0.0);
  for (int j = 0; j < m; ++j)
    for (int k = 0; k < M.pair_count[j]; ++k) share[M.pair_vertex[j][k]] += M.pair_weight[j][k];
  M.mass.assign(m, 0.0);
  for (int j = 0; j < m; ++j)
    for (int k = 0; k < M.pair_count[j]; ++k) {
      const int i = M.pair_vertex[j][k];
      M.mass[j] += M.pair_weight[j][k] * phys_mass[i] / share[i];
    }

  // Pinned: every paired physical vertex is pinned.
  std::vector<std::uint8_t> phys_pinned(phys.vertices.size(), 0);
  for (int p : scene.pinned)
    if (p >= 0 && p < static_cast<int>(phys_pinned.size())) phys_pinned[p] = 1;
  M.pinned.assign(m, 1);
  for (int j = 0; j < m; ++j)
    for (int k = 0; k < M.pair_count[j]; ++k)
      if (!phys_pinned[M.pair_vertex[j][k]]) M.pinned[j] = 0;

  M.stiff_diag.resize(m);
  for (int j = 0; j < m; ++j) M.stiff_diag[j] = M.k_s * (M.edge_offsets[j + 1] - M.edge_offsets[j]) + M.k_svc;
  return M;
}

bool virtual_team(const VirtualModel& model, int count) {
  return count >= model.parallel_min_vertices && omp_get_max_threads() > 1;
}

VirtualState make_virtual_state(const VirtualModel& model) {
  return VirtualState{model.rest, std::vector<Vec3d>(model.num_vertices)};
}

VirtualWorkspace make_virtual_workspace(const VirtualModel& model) {
  VirtualWorkspace ws;
  const size_t m = model.num_vertices;
  ws.q_start.assign(m, Vec3d{});
  ws.s.assign(m, Vec3d{});
  ws.p.assign(m, Vec3d{});
  ws.q_next.assign(m, Vec3d{});
  ws.contact_kt.assign(m, Vec3d{});
  ws.contact_k.assign(m, 0.0);
  ws.edge_grad.assign(model.edges.size(), Vec3d{});
  return ws;
}

void paired_points(const VirtualModel& model, std::span<const Vec3d> x, std::span<Vec3d> p) {
  const int m = model.num_vertices;
#pragma omp parallel for schedule(static)
  for (int j = 0; j < m; ++j)
    p[j] = paired_point(x.data(), model.pair_vertex[j].data(), model.pair_weight[j].data(), model.pair_count[j]);
}

void virtual_begin_tick(const VirtualModel& model, VirtualWorkspace& ws, VirtualState& state,
                        std::span<const Vec3d> physical_x, double h) {
  ws.h = h;
  const int m = model.num_vertices;
#pragma omp parallel if (!ws.shared && virtual_team(model, m))
  for_chunks(ws.shared, m, kVertexChunk, [&](int begin, int end) {
    for (int j = begin; j < end; ++j) {
      ws.p[j] = paired_point(physical_x.data(), model.pair_vertex[j].data(), model.pair_weight[j].data(),
                             model.pair_count[j]);                        // Alg. 2 line 1: E_svc targets
      ws.q_start[j] = state.q[j];                                         // Alg. 2 line 6: prediction, start
      ws.s[j] = model.pinned[j] ? state.q[j] : predict_position(state.q[j], state.v[j], model.gravity, h);
      state.q[j] = model.pinned[j] ? state.q[j] : iteration_start(state.q[j], state.v[j], h);
    }
  });
}

namespace {

/// The local step of E_s for every edge (work-shared or ws.shared; ends with a barrier).
void edge_pass(const VirtualModel& model, VirtualWorkspace& ws, const Vec3d* q) {
  const EdgeKernelData edges{static_cast<int>(model.edges.size()), model.edges.data(), model.rest_edge.data(),
                             model.rest_len.data(), model.k_s};
  for_chunks(ws.shared, edge_blocks(edges.num_edges), kEdgeBlockChunk,
             [&](int b0, int b1) { edge_spring_gradient_blocks(edges, q, ws.edge_grad.data(), b0, b1); });
}

/// The gather and Jacobi global step per vertex (virtual_jacobi.hpp; work-shared or ws.shared;
/// ends with a barrier).
void vertex_pass(const VirtualModel& model, VirtualWorkspace& ws, const Vec3d* __restrict q, Vec3d* __restrict q_next) {
  const double inv_h2 = 1.0 / (ws.h * ws.h);
  for_chunks(ws.shared, model.num_vertices, kVertexChunk, [&](int begin, int end) {
    for (int j = begin; j < end; ++j) q_next[j] = model.pinned[j] ? q[j] : virtual_vertex_update(model, ws, q, j, inv_h2);
  });
}

}  // namespace

void virtual_iteration(const VirtualModel& model, VirtualWorkspace& ws, VirtualState& state,
                       std::span<const ContactTarget> contacts) {
  // E_con [3] constraints: summed per vertex in the given order (serial: few, and deterministic).
  for (const ContactTarget& c : contacts) {
    ws.contact_kt[c.vertex] += c.stiffness * c.target;
    ws.contact_k[c.vertex] += c.stiffness;
  }
  // Local step (edge targets R e0; E_svc and E_con targets are fixed) and Jacobi global step.
#pragma omp parallel if (!ws.shared && virtual_team(model, model.num_vertices))
  {
    edge_pass(model, ws, state.q.data());
    vertex_pass(model, ws, state.q.data(), ws.q_next.data());
  }
  std::swap(state.q, ws.q_next);
  for (const ContactTarget& c : contacts) {
    ws.contact_kt[c.vertex] = Vec3d{};
    ws.contact_k[c.vertex] = 0.0;
  }
}

void virtual_end_tick(const VirtualModel& model, VirtualWorkspace& ws, VirtualState& state) {
  const int m = model.num_vertices;
  const double v_scale = tick_velocity_scale(ws.h, model.damping);
#pragma omp parallel if (!ws.shared && virtual_team(model, m))
  for_chunks(ws.shared, m, kVertexChunk, [&](int begin, int end) {
    for (int j = begin; j < end; ++j) state.v[j] = v_scale * (state.q[j] - ws.q_start[j]);  // Alg. 2 line 23, damped
  });
}

void compute_vertex_normals(const VirtualModel& model, std::span<const Vec3d> q, std::span<Vec3d> normals) {
  const int m = model.num_vertices;
#pragma omp parallel for schedule(static)
  for (int j = 0; j < m; ++j) {
    Vec3d n{};
    for (int k = model.tri_offsets[j]; k < model.tri_offsets[j + 1]; ++k) {
      const Tri& t = model.triangles[model.tri_entries[k]];
      n += cross(q[t[1]] - q[t[0]], q[t[2]] - q[t[0]]);  // twice the area times the unit normal
    }
    normals[j] = normalized(n);
  }
}

VirtualEnergy virtual_energy(const VirtualModel& model, std::span<const Vec3d> q, std::span<const Vec3d> s,
                             std::span<const Vec3d> p, std::span<const ContactTarget> contacts, double h) {
  VirtualEnergy E;
  for (size_t e = 0; e < model.edges.size(); ++e)
    E.edges += edge_spring_energy(q[model.edges[e][0]], q[model.edges[e][1]], model.rest_edge[e], model.k_s);
  for (int j = 0; j < model.num_vertices; ++j) {
    if (!p.empty()) E.coupling += coupling_energy(p[j], q[j], model.k_svc);
    if (!s.empty()) E.inertia += inertia_energy(q[j], s[j], model.mass[j], h);
  }
  for (const ContactTarget& c : contacts) E.contact += contact_energy(q[c.vertex], c.target, c.stiffness);
  return E;
}

}  // namespace ebh
