#pragma once
// The virtual mesh's active region (solver.active_region, docs/MODEL.md "The active region"):
// a tick iterates only the virtual vertices near the tool; every other vertex follows its E_svc [5]
// target exactly, q_j = p_j, with the velocity of that motion, and acts as a fixed E_s [4]
// neighbour of the active vertices beside it.
//
// Who is active (decided at the start of each tick, from the last tick's q and this tick's p):
//   - the seeds the caller passes (the schedule: vertices the virtual tool may reach this tick,
//     grasped vertices, the corners of surface-contact triangles near the tool);
//   - every vertex within kSpreadRings edges (over the virtual mesh's edges) of a hot active
//     vertex (below: moving, and displaced from where it would stand inactive by more than
//     `tolerance`): the region grows where the tool's push spreads, and a vertex that moves by
//     more than the tolerance is never held by a neighbour fixed on its target;
//   - any vertex a contact target names during the tick (activated at once, counted: the seeds
//     should have held it);
//   - every inactive vertex that its edges and its E_svc spring pull off where it stands: the
//     static Jacobi step's move, |sum of its E_s and E_svc forces and its weight| / (k_s degree +
//     k_svc), above tol (a surface strained against its rest shape, which no seed reaches: the far
//     field); checked on the tick a new physical result arrives, or (check_ticks = N > 1, targets
//     that move every tick) a slice of the vertices a tick, each vertex once in N ticks. A slice
//     vertex whose check cannot have changed since it last ran (neither its q nor a neighbour's
//     changed since: ActiveRegion::touched; its coupling point the same bits) is not checked
//     again: the same outcome, without its edges' work.
// Displacements are measured from where the vertex stands when inactive (below), so a vertex that
// settled off its E_svc point (a strained surface) is not displaced. A vertex is *moving* when its
// displacement changed by more than tol / kCalmTicks since the last tick, *hot* when it is moving
// and displaced by more than tol.
// Hysteresis: an active vertex leaves only when it is not a seed, not moving, and not near (within
// kSpreadRings edges of) a hot vertex for kCalmTicks ticks in a row; it then stays where it
// stands: its offset from its E_svc point is kept (no jump). Pinned vertices are never active.
//
// An inactive vertex stands at its E_svc point p_j lowered by its own weight's stretch of the
// coupling spring, m_j g / k_svc (its static equilibrium against E_svc: 0 without gravity), plus
// the offset it left the region with (0 for a vertex never active): it moves with p_j. Its
// velocity is that of its target: it is not stored while the vertex is inactive (only q is
// written, and only on ticks where the targets move), and is set when the vertex joins: it starts
// from where it stood with v = (target now - target before) / h.
//
// The arithmetic on an active vertex or edge is the full solve's (virtual_mesh.cpp), so a region
// that holds every vertex gives the full solve's bits; results do not depend on the order of the
// active lists or on the OpenMP thread count (every per-vertex loop gathers).
//
// A tick:
//     virtual_begin_tick_active(model, ws, region, state, physical_x, version, h, seeds);
//     for i < iterations:  virtual_iteration_active(model, ws, region, state, contacts); ...
//     moved = virtual_end_tick_active(model, ws, region, state);
#include <cstdint>
#include <span>
#include <vector>

#include "energy/contact_target.hpp"
#include "solver/region_rules.hpp"
#include "solver/virtual_mesh.hpp"

namespace ebh {

/// Rings of neighbours around a hot vertex that join the region with it. With one, a hot vertex's
/// neighbours join but theirs stand fixed on their targets: the tissue next to the push is clamped
/// one edge away, stiffer than the full solve's, and on the gap's stick-slip recordings it held the
/// hook through slips the full solve lets happen (gap_insert 0.038 / 0.38 N RMS / 99.9th
/// percentile against the whole mesh at 0.001 mm; 0.0099 / 0.089 N with two rings, for 1-15% more
/// active vertices and up to ~10% more tick; docs/PERFORMANCE.md, "CPU: the active region"). The
/// physical region spreads as far (kRegionRings).
inline constexpr int kSpreadRings = 2;

// kCalmTicks, the displacement rules and the strain check: solver/region_rules.hpp.

/// The physical positions this tick's E_svc targets come from: x_to, or a blend from x_from
/// (time.interpolate_physical), p = (1 - blend) p(x_from) + blend p(x_to), each paired once per
/// version (the blend of the paired points, not of the physical positions: the same targets to
/// round-off, without an O(n) pass a tick). blend >= 1: p(x_to) exactly.
struct PhysicalTargets {
  std::span<const Vec3d> x_from, x_to;  ///< #n physical positions
  double blend = 1;                     ///< weight of x_to, in (0, 1]
  std::int64_t version = 0;             ///< changes whenever x_to (and with it x_from) does
  /// x_from's version when it was x_to (INT64_MIN: unknown): the region then reuses its pairing
  std::int64_t from_version = INT64_MIN;
};

/// The active region's state (sized by make_active_region; a tick never allocates).
struct ActiveRegion {
  double tolerance = 0;                   ///< m, displacement |q - p| that spreads the region
  /// The strain check's spread: 1, every inactive vertex on the tick a new physical result arrives;
  /// N > 1, a slice of the vertices (in index order) every tick, each vertex once in N ticks (for
  /// targets that move every tick: time.interpolate_physical, N its ticks per physical period)
  int check_ticks = 1;
  std::int64_t checked_ticks = 0;         ///< ticks that ran a slice of the strain check
  /// A slice's vertices whose check cannot have changed are not checked again (off: each is; the
  /// same results, for tests)
  bool skip_unchanged = true;
  std::int64_t tick = 0;                  ///< ticks begun (the first is 1)
  /// #m the last tick a vertex's q may have changed (iterated while active; moved to another
  /// place by following its target): the strain check's skip
  std::vector<std::int64_t> touched;
  std::vector<std::int64_t> checked_at;   ///< #m the tick the strain check last ran on it (0: never)
  std::vector<Vec3d> checked_point;       ///< #m the coupling point that check used
  std::vector<int> check_list, check_edge_list;  ///< scratch: a slice's vertices and edges checked this tick
  std::vector<int> check_vertex;          ///< #N+1 slice s: the vertices [check_vertex[s], check_vertex[s + 1])
  std::vector<int> check_edges, check_edge_offsets;  ///< slice s's edges (an end in it), in index order: CSR, #N+1 offsets
  /// #(2 E) the other end of each incidence entry, in VirtualModel::edge_entries' order (the
  /// rings' walk reads it, not the edge behind the entry)
  std::vector<int> neighbours;
  std::vector<std::uint8_t> active;       ///< #m 1 when iterated this tick
  std::vector<std::uint16_t> calm;        ///< #m consecutive calm ticks of an active vertex
  /// #m where an inactive vertex stands, from its E_svc point: its weight's stretch plus the
  /// displacement it left the region with
  std::vector<Vec3d> offset;
  std::vector<Vec3d> displacement;        ///< #m an active vertex's displacement at the last tick
  std::vector<int> vertices;              ///< the active vertices, in index order
  std::vector<int> edges;                 ///< the edges with an active end, in index order
  std::vector<std::uint8_t> edge_ends;    ///< #E active ends of each edge (0, 1, 2)
  // Scratch.
  std::vector<std::uint8_t> mark;         ///< #m per-tick flags (seed, moving, near a hot vertex), zero between uses
  std::vector<int> added, removed;        ///< vertices entering and leaving this tick
  std::vector<int> hot;                   ///< this tick's hot active vertices (moving, displaced by more than tol)
  std::vector<int> frontier, next;        ///< the spread's rings around the hot vertices
  std::vector<int> vertex_scratch, edge_scratch;  ///< update_lists' merges
  std::vector<Vec3d> p_from, p_to;        ///< #m E_svc targets of PhysicalTargets::x_from and x_to
  /// the vertices whose p_to differs from p_from (bitwise), in index order: the only inactive ones
  /// the blend moves (the physical mesh's awake region holds the rest of it still)
  std::vector<int> moving_targets;
  /// the vertices that left the region since the last pass over every inactive vertex (once each,
  /// flagged in in_left): they keep their q, which p + offset gives back only to round-off until
  /// the next pass over the inactive vertices writes it
  std::vector<int> left;
  std::vector<std::uint8_t> in_left;      ///< #m
  std::int64_t targets_version = INT64_MIN;  ///< PhysicalTargets::version of p_from and p_to
  double blend = 1;                       ///< this tick's PhysicalTargets::blend
  double blend_before = 1;                ///< the blend the inactive vertices stood at before this tick
  double target_spread = 0;               ///< m, max_j |p_to - p_from|
  double inactive_moved = 0;              ///< m, bound on the move of an inactive vertex this tick
  // Counters over the replay.
  std::int64_t activated_by_contact = 0;  ///< vertices a contact target activated mid-tick
  std::int64_t strained = 0;              ///< vertices their edges' pull activated (add_strained)
  std::int64_t strain_skipped = 0;        ///< slice vertices not checked again, their check unchanged
};

/// A region for `model` with the given tolerance (m, > 0), empty: the first tick fills it; its
/// strain check spread over check_ticks ticks (ActiveRegion::check_ticks).
ActiveRegion make_active_region(const VirtualModel& model, double tolerance, int check_ticks = 1);

/// Alg. 2 lines 1 and 6 on the active region: the E_svc targets p from `targets` (paired, O(m)
/// gathers, only when its version changes; blended, an O(m) pass, when the blend does), the
/// region from `seeds` (vertex indices, any order, repeats allowed) and the displacements; the
/// active vertices are predicted as virtual_begin_tick does, the inactive ones moved to their
/// targets.
void virtual_begin_tick_active(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& region,
                               VirtualState& state, const PhysicalTargets& targets, double h,
                               std::span<const int> seeds);

/// virtual_iteration on the active vertices; a contact target on an inactive vertex first
/// activates it (its prediction is then where it stands).
void virtual_iteration_active(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& region,
                              VirtualState& state, std::span<const ContactTarget> contacts);

/// Alg. 2 line 23 on the active vertices. Returns the largest move of any vertex this tick (m),
/// for the broad phase's drift bound.
double virtual_end_tick_active(const VirtualModel& model, VirtualWorkspace& ws, ActiveRegion& region,
                               VirtualState& state);

}  // namespace ebh
