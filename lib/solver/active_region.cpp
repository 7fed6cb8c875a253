// The virtual mesh's active region (solver/active_region.hpp, docs/MODEL.md "The active region").
#include "solver/active_region.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>

#include "energy/edge_spring.hpp"
#include "energy/quadratic.hpp"
#include "solver/local_kernels.hpp"
#include "solver/shared_loops.hpp"
#include "solver/virtual_jacobi.hpp"

namespace ebh {
namespace {

constexpr std::uint8_t kSeed = 1;  // ActiveRegion::mark: a seed of this tick
constexpr std::uint8_t kMoving = 2;  // ActiveRegion::mark: its displacement changed by more than tol / kCalmTicks
constexpr std::uint8_t kNearHot = 4;  // ActiveRegion::mark: within kSpreadRings edges of a hot (moving, displaced by more than tol) vertex
constexpr std::uint8_t kChecked = 8;  // ActiveRegion::mark: in this tick's strain check (add_strained)

/// Vertex j's E_svc target at blend a: p_j(a), the blend of p_from and p_to.
inline Vec3d coupling_point(const ActiveRegion& r, int j, double a) {
  return a >= 1.0 ? r.p_to[j] : lerp(r.p_from[j], r.p_to[j], a);
}
/// Where inactive (non-pinned) vertex j stands at blend a: its E_svc target, lowered by its own
/// weight's stretch of the coupling spring, m_j g / k_svc, plus the offset it left the region with
/// (ActiveRegion::offset holds both).
inline Vec3d follow_target(const ActiveRegion& r, int j, double a) {
  return coupling_point(r, j, a) + r.offset[j];
}

/// Inactive vertex j to where it stands at blend a, its q marked touched when that changed it.
inline void follow(ActiveRegion& r, VirtualState& state, int j, double a) {
  const Vec3d q = follow_target(r, j, a);
  if (std::memcmp(&q, &state.q[j], sizeof(Vec3d)) == 0) return;
  state.q[j] = q;
  r.touched[j] = r.tick;
}

/// Makes j active (not pinned ones: they never move); true when it was not.
bool activate(const VirtualModel& model, ActiveRegion& r, int j) {
  if (r.active[j] || model.pinned[j]) return false;
  r.active[j] = 1;
  r.calm[j] = 0;
  r.displacement[j] = Vec3d{};  // it joins from where it stands
  r.added.push_back(j);
  return true;
}

/// The active vertex and edge lists after `added` and `removed` (the flags already set), updated
/// in place and kept in index order, so that the passes over them walk memory forward: the removed
/// leave, the added (and their new edges) are sorted and merged in through the scratch lists. The
/// order changes no result (every vertex and edge is computed on its own).
void update_lists(const VirtualModel& model, ActiveRegion& r) {
  for (const int j : r.removed)
    for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k) --r.edge_ends[model.edge_entries[k] >> 1];
  if (!r.removed.empty()) {
    std::erase_if(r.vertices, [&](int j) { return !r.active[j]; });
    std::erase_if(r.edges, [&](int e) { return r.edge_ends[e] == 0; });
  }
  if (r.added.empty()) return;
  const std::size_t vertices = r.vertices.size(), edges = r.edges.size();
  for (const int j : r.added) {
    r.vertices.push_back(j);
    for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k)
      if (r.edge_ends[model.edge_entries[k] >> 1]++ == 0) r.edges.push_back(model.edge_entries[k] >> 1);
  }
  // Within the capacities make_active_region reserved: no allocation.
  auto merge_in = [](std::vector<int>& list, std::size_t old, std::vector<int>& scratch) {
    std::sort(list.begin() + static_cast<std::ptrdiff_t>(old), list.end());
    scratch.resize(list.size());
    std::merge(list.begin(), list.begin() + static_cast<std::ptrdiff_t>(old), list.begin() + static_cast<std::ptrdiff_t>(old),
               list.end(), scratch.begin());
    list.swap(scratch);
  };
  merge_in(r.vertices, vertices, r.vertex_scratch);
  merge_in(r.edges, edges, r.edge_scratch);
}

/// A vertex that was inactive starts the tick with its target's velocity; `place`: also from where
/// its target stood before this tick (a vertex the inactive pass already moved on).
void join(const ActiveRegion& r, VirtualState& state, int j, double v_scale, bool place) {
  const Vec3d before = follow_target(r, j, r.blend_before);
  if (place) state.q[j] = before;
  state.v[j] = v_scale * (follow_target(r, j, r.blend) - before);
}

/// The seeds of this tick join the region (marked, for retire_and_spread) from where they stand.
/// Clears r.added and r.removed.
void add_seeds(const VirtualModel& model, ActiveRegion& r, VirtualState& state, std::span<const int> seeds,
               double v_scale) {
  r.added.clear();
  r.removed.clear();
  for (const int j : seeds) {
    assert(j >= 0 && j < model.num_vertices);
    r.mark[j] |= kSeed;
    if (activate(model, r, j)) join(r, state, j, v_scale, false);
  }
}

/// Whether slice vertex j's strain check would give what it gave when it last ran: neither j's q
/// nor a neighbour's changed since (ActiveRegion::touched) and its coupling point has the same bits
/// (the check reads nothing else that changes).
bool check_unchanged(const VirtualModel& model, const ActiveRegion& r, int j, const Vec3d& point) {
  const std::int64_t c = r.checked_at[j];
  if (c == 0 || r.touched[j] >= c || std::memcmp(&point, &r.checked_point[j], sizeof(Vec3d)) != 0) return false;
  for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k)
    if (r.touched[r.neighbours[k]] >= c) return false;
  return true;
}

/// The inactive vertices of slice `slice` (of r.check_ticks; the whole mesh when 1) that their
/// edges and E_svc spring pull off where they stand join (active_region.hpp): a vertex that was
/// never active stands on its target, where the E_s [4] forces of its edges need not balance (a
/// surface strained against its rest shape, as gravity strains a settled organ's), and one that
/// left the region where it settled, which its neighbours may have moved since; the static Jacobi
/// step's move, |sum of its E_s and E_svc [5] forces and weight| / (k_s degree + k_svc), above the
/// tolerance makes it join from where it stands, as a seed does. The edges' E_s gradients go into
/// ws.edge_grad in the SIMD blocks of the iterations: every edge for the whole mesh (most edges
/// have an inactive end), a slice's listed edges of the vertices it checks (r.check_edges; a slice
/// skips the vertices whose check cannot have changed, check_unchanged); the tick's iterations
/// overwrite the active ones before they read them. Reads q; appends to r.added.
void add_strained(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& r, VirtualState& state,
                  double v_scale, int slice) {
  const int m = model.num_vertices, E = static_cast<int>(model.edges.size());
  const std::vector<Vec3d>& q = state.q;
  const EdgeKernelData edges{E, model.edges.data(), model.rest_edge.data(), model.rest_len.data(), model.k_s};
  const bool whole = r.check_ticks <= 1;
  const int j0 = whole ? 0 : r.check_vertex[slice], j1 = whole ? m : r.check_vertex[slice + 1];
  const int* ids = whole ? nullptr : r.check_edges.data() + r.check_edge_offsets[slice];
  int count = whole ? E : r.check_edge_offsets[slice + 1] - r.check_edge_offsets[slice];
  // A slice: the vertices to check (flagged kChecked), and the slice's edges with such an end, in
  // the slice list's order (each edge's gradient has the same bits in any list: local_kernels.hpp).
  r.check_list.clear();
  if (!whole) {
    for (int j = j0; j < j1; ++j) {
      if (r.active[j] || model.pinned[j]) continue;
      const Vec3d point = coupling_point(r, j, r.blend);
      if (r.skip_unchanged && check_unchanged(model, r, j, point)) {
        ++r.strain_skipped;
        continue;
      }
      r.check_list.push_back(j);
      r.checked_at[j] = r.tick;
      r.checked_point[j] = point;
      r.mark[j] |= kChecked;
    }
    r.check_edge_list.clear();
    for (int i = 0; i < count; ++i) {
      const auto& e = model.edges[ids[i]];
      if ((r.mark[e[0]] | r.mark[e[1]]) & kChecked) r.check_edge_list.push_back(ids[i]);
    }
    ids = r.check_edge_list.data();
    count = static_cast<int>(r.check_edge_list.size());
    for (const int j : r.check_list) r.mark[j] &= static_cast<std::uint8_t>(~kChecked);
  }
#pragma omp parallel if (!ws.shared && virtual_team(model, j1 - j0))
  for_chunks(ws.shared, edge_blocks(count), kEdgeBlockChunk, [&](int b0, int b1) {
    if (whole) edge_spring_gradient_blocks(edges, q.data(), ws.edge_grad.data(), b0, b1);
    else edge_spring_gradient_groups(edges, ids, count, q.data(), ws.edge_grad.data(), b0, b1);
  });
  const std::size_t before = r.added.size();
  const int n_checked = whole ? j1 - j0 : static_cast<int>(r.check_list.size());
  for (int i = 0; i < n_checked; ++i) {
    const int j = whole ? j0 + i : r.check_list[i];
    if (r.active[j] || model.pinned[j]) continue;
    Vec3d f = model.k_svc * (coupling_point(r, j, r.blend) - q[j]) + model.mass[j] * model.gravity;
    for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k) {
      const int entry = model.edge_entries[k];
      add_edge_residual(f, ws.edge_grad[entry >> 1], (entry & 1) != 0);  // the force on this end
    }
    if (pulled_off(f, model.stiff_diag[j], r.tolerance)) activate(model, r, j);
  }
  for (std::size_t i = before; i < r.added.size(); ++i) join(r, state, r.added[i], v_scale, false);
  r.strained += static_cast<std::int64_t>(r.added.size() - before);
}

/// The rest of who is active this tick (active_region.hpp), over the region before the seeds
/// joined: the vertices within kSpreadRings edges of a hot vertex join; a vertex that has stayed
/// calm for kCalmTicks leaves and stands where it is (its displacement joins its offset). Three
/// passes: the displacements (marking the moving and hot vertices, listing the hot), the rings
/// around the hot vertices (joining, marked as near a hot vertex), then each vertex's stay or
/// leave from its own marks alone. Reads the last tick's q of the active vertices; appends to
/// r.added and r.removed; clears the marks.
void retire_and_spread(const VirtualModel& model, ActiveRegion& r, VirtualState& state, std::span<const int> seeds,
                       double v_scale) {
  const std::size_t seeded = r.added.size();
  const std::vector<Vec3d>& q = state.q;
  r.hot.clear();
  for (const int j : r.vertices) {
    const Vec3d d = q[j] - follow_target(r, j, r.blend);
    const RegionMotion motion = region_motion(d, r.displacement[j], r.tolerance);
    if (motion.moving) r.mark[j] |= kMoving;
    if (motion.hot) r.hot.push_back(j);
    r.displacement[j] = d;
  }
  // The rings: a hot vertex is near itself, so it is marked before them and a ring does not
  // spread from it again (its neighbours are the first ring's already); a marked vertex is active.
  for (const int j : r.hot) r.mark[j] |= kNearHot;
  r.frontier.assign(r.hot.begin(), r.hot.end());
  for (int ring = 0; ring < kSpreadRings && !r.frontier.empty(); ++ring) {
    r.next.clear();
    for (const int j : r.frontier)
      for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k) {
        const int o = r.neighbours[k];
        if (r.mark[o] & kNearHot) continue;  // reached already
        activate(model, r, o);
        if (!r.active[o]) continue;  // pinned
        r.mark[o] |= kNearHot;  // every marked vertex is listed (not a pinned one)
        r.next.push_back(o);
      }
    r.frontier.swap(r.next);
  }
  for (const int j : r.vertices) {
    if (r.mark[j] & (kSeed | kMoving | kNearHot)) {
      r.calm[j] = 0;
    } else if (++r.calm[j] >= kCalmTicks) {
      r.active[j] = 0;
      r.removed.push_back(j);
    }
    r.mark[j] = 0;
  }
  for (const int j : seeds) r.mark[j] = 0;
  for (const int j : r.added) r.mark[j] = 0;  // the vertices near hot ones that joined
  for (std::size_t i = seeded; i < r.added.size(); ++i) join(r, state, r.added[i], v_scale, true);
  for (const int j : r.removed) r.offset[j] += r.displacement[j];  // q stays: it stands where it settled
}

}  // namespace

ActiveRegion make_active_region(const VirtualModel& model, double tolerance, int check_ticks) {
  assert(tolerance > 0);
  ActiveRegion r;
  const std::size_t m = model.num_vertices, E = model.edges.size();
  r.tolerance = tolerance;
  r.check_ticks = std::max(check_ticks, 1);
  if (r.check_ticks > 1) {  // slice s: vertices [check_vertex[s], check_vertex[s + 1]) and their edges
    const int T = r.check_ticks;
    r.check_vertex.resize(T + 1);
    for (int s = 0; s <= T; ++s) r.check_vertex[s] = static_cast<int>(static_cast<std::int64_t>(m) * s / T);
    r.check_edge_offsets.assign(T + 1, 0);
    for (int s = 0; s < T; ++s) {
      std::vector<int> ids;
      for (int j = r.check_vertex[s]; j < r.check_vertex[s + 1]; ++j)
        for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k) ids.push_back(model.edge_entries[k] >> 1);
      std::sort(ids.begin(), ids.end());
      ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
      r.check_edges.insert(r.check_edges.end(), ids.begin(), ids.end());
      r.check_edge_offsets[s + 1] = static_cast<int>(r.check_edges.size());
    }
  }
  r.neighbours.resize(model.edge_entries.size());
  for (std::size_t k = 0; k < model.edge_entries.size(); ++k) {
    const int entry = model.edge_entries[k];  // 2 e + end: the other end is edges[e][1 - end]
    r.neighbours[k] = model.edges[entry >> 1][1 - (entry & 1)];
  }
  r.active.assign(m, 0);
  r.calm.assign(m, 0);
  r.offset.resize(m);
  for (std::size_t j = 0; j < m; ++j) r.offset[j] = rest_offset(model.mass[j], model.k_svc, model.gravity);
  r.displacement.assign(m, Vec3d{});
  r.mark.assign(m, 0);
  r.edge_ends.assign(E, 0);
  r.vertices.reserve(m);
  r.vertex_scratch.reserve(m);
  r.edge_scratch.reserve(E);
  r.added.reserve(m);
  r.removed.reserve(m);
  r.hot.reserve(m);
  r.frontier.reserve(m);
  r.next.reserve(m);
  r.edges.reserve(E);
  r.p_from.assign(m, Vec3d{});
  r.p_to.assign(m, Vec3d{});
  r.moving_targets.reserve(m);
  r.left.reserve(m);
  r.in_left.assign(m, 0);
  r.touched.assign(m, 0);
  r.checked_at.assign(m, 0);
  r.checked_point.assign(m, Vec3d{});
  r.check_list.reserve(m);
  r.check_edge_list.reserve(E);
  return r;
}

void virtual_begin_tick_active(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& r, VirtualState& state,
                               const PhysicalTargets& targets, double h, std::span<const int> seeds) {
  ws.h = h;
  ++r.tick;
  const int m = model.num_vertices;
  const double v_scale = tick_velocity_scale(h, model.damping);  // the velocity carried on (damped)
  const bool team = virtual_team(model, m);

  // Alg. 2 line 1: the E_svc targets, paired once per version of the physical positions. The
  // targets before this tick are p_from (blend 0) after a new version, the last tick's otherwise.
  const double a = std::min(targets.blend, 1.0);
  const bool fresh = targets.version != r.targets_version;
  if (fresh) {
    const bool first = r.targets_version == INT64_MIN;
    const bool from_paired = targets.from_version == r.targets_version;  // x_from was the last x_to
    r.targets_version = targets.version;
    r.p_from.swap(r.p_to);  // without interpolation: the last targets, where the vertices stood
    if (!first && a < 1.0 && !from_paired) paired_points(model, targets.x_from, r.p_from);
    double spread2 = 0;  // max |p_to - p_from|, in the pairing's pass
#pragma omp parallel for schedule(static) reduction(max : spread2) if (team)
    for (int j = 0; j < m; ++j) {
      r.p_to[j] = paired_point(targets.x_to.data(), model.pair_vertex[j].data(), model.pair_weight[j].data(),
                               model.pair_count[j]);
      if (!first) spread2 = std::max(spread2, squared_norm(r.p_to[j] - r.p_from[j]));
    }
    if (first) r.p_from = r.p_to;
    r.target_spread = std::sqrt(spread2);
    r.moving_targets.clear();
    for (int j = 0; j < m; ++j)
      if (std::memcmp(&r.p_to[j], &r.p_from[j], sizeof(Vec3d)) != 0) r.moving_targets.push_back(j);
    r.blend_before = first ? a : 0.0;
  } else {
    r.blend_before = r.blend;
  }
  r.blend = a;

  add_seeds(model, r, state, seeds, v_scale);
  // The inactive vertices move with their targets (only q: active_region.hpp). On a new physical
  // result every one does (the targets' pair changed); between results only those whose target
  // moves, and those that left the region since (a vertex whose p_from and p_to are the same bits
  // stands where that pass, or the last one since it left, put it, whatever the blend).
  r.inactive_moved = std::fabs(a - r.blend_before) * r.target_spread;
  if (a != r.blend_before) {
    const int count = fresh ? m : static_cast<int>(r.moving_targets.size());
    const int* list = fresh ? nullptr : r.moving_targets.data();
#pragma omp parallel if (!ws.shared && virtual_team(model, count))
    for_chunks(ws.shared, count, kVertexChunk, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) {
        const int j = list ? list[i] : i;
        if (!r.active[j] && !model.pinned[j]) follow(r, state, j, a);
      }
    });
    for (const int j : r.left) {
      if (!fresh && !r.active[j]) follow(r, state, j, a);
      r.in_left[j] = 0;
    }
    r.left.clear();
  }
  if (r.check_ticks <= 1) {
    if (fresh) add_strained(model, ws, r, state, v_scale, 0);  // once per physical result
  } else {  // a slice a tick, every vertex once in check_ticks ticks
    add_strained(model, ws, r, state, v_scale, static_cast<int>(r.checked_ticks++ % r.check_ticks));
  }
  retire_and_spread(model, r, state, seeds, v_scale);
  for (const int j : r.removed)
    if (!r.in_left[j]) {
      r.in_left[j] = 1;
      r.left.push_back(j);
    }
  if (!r.added.empty() || !r.removed.empty()) update_lists(model, r);

  // Alg. 2 line 6 on the active vertices, as virtual_begin_tick.
  const int na = static_cast<int>(r.vertices.size());
#pragma omp parallel if (!ws.shared && virtual_team(model, na))
  for_chunks(ws.shared, na, kVertexChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const int j = r.vertices[i];
      ws.p[j] = coupling_point(r, j, a);
      ws.q_start[j] = state.q[j];
      ws.s[j] = predict_position(state.q[j], state.v[j], model.gravity, h);
      state.q[j] = iteration_start(state.q[j], state.v[j], h);
    }
  });
}

void virtual_iteration_active(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& r, VirtualState& state,
                              std::span<const ContactTarget> contacts) {
  // A contact on an inactive vertex activates it, its prediction where it stands (q = p).
  r.added.clear();
  r.removed.clear();
  for (const ContactTarget& c : contacts) {
    const int j = c.vertex;
    if (!activate(model, r, j)) continue;
    ws.p[j] = coupling_point(r, j, r.blend);
    ws.q_start[j] = follow_target(r, j, r.blend_before);  // where it stood: v at the end is consistent
    ws.s[j] = state.q[j];
  }
  if (!r.added.empty()) {
    r.activated_by_contact += static_cast<std::int64_t>(r.added.size());
    update_lists(model, r);
  }
  // E_con [3] sums, local step on the active edges, Jacobi global step on the active vertices
  // (virtual_iteration's arithmetic); inactive vertices enter as fixed E_s neighbours.
  for (const ContactTarget& c : contacts) {
    ws.contact_kt[c.vertex] += c.stiffness * c.target;
    ws.contact_k[c.vertex] += c.stiffness;
  }
  const int na = static_cast<int>(r.vertices.size());
  const double inv_h2 = 1.0 / (ws.h * ws.h);
  const EdgeKernelData edges{static_cast<int>(model.edges.size()), model.edges.data(), model.rest_edge.data(),
                             model.rest_len.data(), model.k_s};
  const Vec3d* q = state.q.data();
  Vec3d* q_next = ws.q_next.data();
  const int ne = static_cast<int>(r.edges.size());
#pragma omp parallel if (!ws.shared && virtual_team(model, na))
  {
    for_chunks(ws.shared, edge_blocks(ne), kEdgeBlockChunk, [&](int b0, int b1) {
      edge_spring_gradient_groups(edges, r.edges.data(), ne, q, ws.edge_grad.data(), b0, b1);
    });
    for_chunks(ws.shared, na, kVertexChunk, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) {
        const int j = r.vertices[i];
        q_next[j] = virtual_vertex_update(model, ws, q, j, inv_h2);
      }
    });
    for_chunks(ws.shared, na, 4 * kVertexChunk, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) state.q[r.vertices[i]] = q_next[r.vertices[i]];
    });
  }
  for (const ContactTarget& c : contacts) {
    ws.contact_kt[c.vertex] = Vec3d{};
    ws.contact_k[c.vertex] = 0.0;
  }
}

double virtual_end_tick_active(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& r, VirtualState& state) {
  const double v_scale = tick_velocity_scale(ws.h, model.damping);
  const int na = static_cast<int>(r.vertices.size());
  double moved2 = 0;
#pragma omp parallel for schedule(static) reduction(max : moved2) if (virtual_team(model, na))
  for (int i = 0; i < na; ++i) {
    const int j = r.vertices[i];
    r.touched[j] = r.tick;  // iterated: the strain check of its neighbours runs again
    state.v[j] = v_scale * (state.q[j] - ws.q_start[j]);  // Alg. 2 line 23, damped
    moved2 = std::max(moved2, squared_norm(state.q[j] - ws.q_start[j]));
  }
  return std::sqrt(moved2) + r.inactive_moved;  // a vertex that joined this tick may have done both
}

}  // namespace ebh
