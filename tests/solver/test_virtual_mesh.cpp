// The virtual mesh on structured boxes: its pairing with the physical mesh, rest and convergence
// under contact, bitwise determinism across thread counts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <tuple>
#include <numeric>
#include <string>

#include "mesh/boundary.hpp"
#include "solver/active_region.hpp"

#include "box_sim.hpp"

namespace ebh {
namespace {

using namespace ebh::test;

TEST(Pairing, ExactAtRestWithAndWithoutRefinement) {
  for (int refine : {0, 1}) {
    Sim sim(box_scene(3, 3, 6, refine));
    EXPECT_EQ(sim.vm.pairing_max_error, 0.0) << "refine " << refine;  // weights 1 or 1/2 of exact binary fractions
    std::vector<Vec3d> p(sim.vm.num_vertices);
    paired_points(sim.vm, sim.pm.rest, p);
    EXPECT_LT(max_diff(p, sim.vm.rest), 1e-18);
    if (refine) {
      EXPECT_GT(sim.vm.num_vertices, static_cast<int>(extract_boundary(sim.scene.physical).vertices.size()));
    }
  }
}

TEST(Pairing, InteriorSurfaceIsEmbeddedInTets) {
  Scene scene = box_scene(3, 3, 6);
  // A virtual surface shrunk towards the centre: every vertex lies strictly inside a tet.
  scene.virtual_surface = extract_boundary(scene.physical);
  for (Vec3d& v : scene.virtual_surface.vertices) v = Vec3d{0.006, 0.006, 0.012} + 0.9 * (v - Vec3d{0.006, 0.006, 0.012});
  const VirtualModel vm = build_virtual_model(scene);
  EXPECT_LT(vm.pairing_max_error, 1e-17);  // barycentric reproduction, round-off of 1e-2 m coordinates
  for (int j = 0; j < vm.num_vertices; ++j) EXPECT_GE(vm.pair_count[j], 1);
}

/// Median over the edges of |a - b|: how far apart an edge's ends lie in memory.
int median_edge_span(const std::vector<std::array<int, 2>>& edges) {
  std::vector<int> span;
  for (const auto& e : edges) span.push_back(std::abs(e[0] - e[1]));
  std::nth_element(span.begin(), span.begin() + static_cast<std::ptrdiff_t>(span.size() / 2), span.end());
  return span[span.size() / 2];
}

TEST(Numbering, TheVirtualMeshIsNumberedAlongSpaceButAUsersUnrefinedMeshKeepsItsOrder) {
  // The box's physical vertices in a scrambled order (as a mesher may number them): the boundary
  // inherits it, the virtual model renumbers it in Morton order, and pairs exactly as before.
  Scene scene = box_scene(8, 8, 16, 0);
  const int n = static_cast<int>(scene.physical.vertices.size());
  std::vector<int> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  for (int i = n - 1; i > 0; --i) std::swap(perm[i], perm[(i * 7919 + 13) % (i + 1)]);  // a fixed shuffle
  std::vector<Vec3d> scrambled(n);
  for (int a = 0; a < n; ++a) scrambled[perm[a]] = scene.physical.vertices[a];
  scene.physical.vertices = scrambled;
  for (Tet& t : scene.physical.tets)
    for (int& v : t) v = perm[v];
  scene.pinned.clear();
  scene.virtual_surface = extract_boundary(scene.physical);
  std::vector<std::array<int, 2>> boundary_edges;
  for (const Tri& t : scene.virtual_surface.triangles)
    for (int k = 0; k < 3; ++k) boundary_edges.push_back({t[k], t[(k + 1) % 3]});
  const VirtualModel vm = build_virtual_model(scene);
  ASSERT_EQ(vm.num_vertices, static_cast<int>(scene.virtual_surface.vertices.size()));
  // Scrambled, an edge's ends lie a good part of the index range apart; in Morton order a few
  // rows of the box's surface grid (its side has 9-17 vertices) at most.
  EXPECT_GT(median_edge_span(boundary_edges), vm.num_vertices / 8);
  EXPECT_LT(median_edge_span(vm.edges), 40);
  EXPECT_EQ(vm.pairing_max_error, 0.0);
  std::vector<Vec3d> a = vm.rest, b = scene.virtual_surface.vertices;  // the same points, renumbered
  auto less = [](const Vec3d& u, const Vec3d& v) { return std::tie(u.x, u.y, u.z) < std::tie(v.x, v.y, v.z); };
  std::sort(a.begin(), a.end(), less);
  std::sort(b.begin(), b.end(), less);
  EXPECT_EQ(a, b);
  EXPECT_EQ(vm.triangles.size(), scene.virtual_surface.triangles.size());
  // A user's virtual mesh used unrefined keeps the file's numbering; refined, it is renumbered too.
  scene.spec.virtual_mesh = "user.obj";
  const VirtualModel user = build_virtual_model(scene);
  EXPECT_EQ(user.rest, scene.virtual_surface.vertices);
  EXPECT_EQ(user.triangles, scene.virtual_surface.triangles);
  scene.spec.virtual_refine = 1;
  EXPECT_LT(median_edge_span(build_virtual_model(scene).edges), 40);
}

/// Five virtual-mesh ticks (4 iterations each) of a box under contact; parallel_min_vertices = 0
/// puts even this small mesh on the OpenMP team instead of the calling thread.
/// shared: the passes' loops shared with a helping thread (VirtualWorkspace::shared); cells: the
/// box's cells across (and twice that along).
std::vector<Vec3d> five_virtual_ticks(int parallel_min_vertices, SharedLoops* shared = nullptr, int cells = 4) {
  Sim sim(box_scene(cells, cells, 2 * cells, 1));
  if (parallel_min_vertices >= 0) sim.vm.parallel_min_vertices = parallel_min_vertices;
  VirtualState vs = make_virtual_state(sim.vm);
  VirtualWorkspace vw = make_virtual_workspace(sim.vm);
  vw.shared = shared;
  std::vector<ContactTarget> contacts;
  for (int j = 0; j < sim.vm.num_vertices; ++j)
    if (sim.vm.rest[j].z > 0.0239) contacts.push_back({j, sim.vm.rest[j] - Vec3d{0, 0, 0.002}, 400.0});
  for (int tick = 0; tick < 5; ++tick) {
    virtual_begin_tick(sim.vm, vw, vs, sim.pm.rest, 0.001);
    for (int i = 0; i < 4; ++i) virtual_iteration(sim.vm, vw, vs, contacts);
    virtual_end_tick(sim.vm, vw, vs);
  }
  return vs.q;
}

TEST(Determinism, VirtualTickIsBitwiseEqualWithOneAndTwoThreads) {
  expect_bitwise_equal_across_threads([&] { return five_virtual_ticks(-1); });
}

TEST(Determinism, VirtualTickOnTheThreadTeamIsBitwiseEqualWithOneAndTwoThreads) {
  // Paper-sized virtual meshes iterate on the calling thread; the thread team must give the same
  // bits with one and two threads.
  expect_bitwise_equal_across_threads([&] { return five_virtual_ticks(0); });
}

TEST(Determinism, VirtualTickWithAHelperIsBitwiseThatOfOneThread) {
  // The async replay's physical thread helps with the tick's passes while it waits (two cores).
  // A box of 10 cells across: its passes have several chunks each.
  expect_bitwise_equal_with_a_helper([&](SharedLoops* shared) { return five_virtual_ticks(-1, shared, 10); });
}

/// The contacts of five_virtual_ticks: the top face pressed 2 mm down.
std::vector<ContactTarget> top_face_pressed(const Sim& sim) {
  std::vector<ContactTarget> contacts;
  for (int j = 0; j < sim.vm.num_vertices; ++j)
    if (sim.vm.rest[j].z > 0.0239) contacts.push_back({j, sim.vm.rest[j] - Vec3d{0, 0, 0.002}, 400.0});
  return contacts;
}

/// The box of five_virtual_ticks with an active region of the given tolerance (m); ticks(n, seeds,
/// contacts) runs n virtual-mesh ticks of 4 iterations.
/// gravity: the box scene's (as five_virtual_ticks), else none.
struct ActiveRun {
  Sim sim;
  VirtualState vs = make_virtual_state(sim.vm);
  VirtualWorkspace vw = make_virtual_workspace(sim.vm);
  ActiveRegion region;
  ActiveRun(double tolerance, bool gravity, int cells = 4, int check_ticks = 1)
      : sim(without_gravity(box_scene(cells, cells, 2 * cells, 1), !gravity)),
        region(make_active_region(sim.vm, tolerance, check_ticks)) {}
  static Scene without_gravity(Scene s, bool off) {
    if (off) s.spec.gravity = Vec3d{};
    return s;
  }
  void ticks(int n, std::span<const int> seeds, std::span<const ContactTarget> contacts) {
    for (int tick = 0; tick < n; ++tick) {
      virtual_begin_tick_active(sim.vm, vw, region, vs, {sim.pm.rest, sim.pm.rest, 1.0, 0}, 0.001, seeds);
      for (int i = 0; i < 4; ++i) virtual_iteration_active(sim.vm, vw, region, vs, contacts);
      virtual_end_tick_active(sim.vm, vw, region, vs);
    }
  }
};

/// The region's lists are what its flags say, in index order (update_lists' merges): every
/// active vertex once, every edge with an active end once.
void expect_lists_match_flags(const ActiveRegion& r, const VirtualModel& vm) {
  std::vector<int> vertices, edges;
  for (int j = 0; j < vm.num_vertices; ++j)
    if (r.active[j]) vertices.push_back(j);
  for (int e = 0; e < static_cast<int>(vm.edges.size()); ++e)
    if (r.active[vm.edges[e][0]] || r.active[vm.edges[e][1]]) edges.push_back(e);
  EXPECT_EQ(r.vertices, vertices);
  EXPECT_EQ(r.edges, edges);
}

TEST(ActiveRegion, HoldingEveryVertexIsTheFullSolveBitwise) {
  // Every vertex a seed: the region's arithmetic must be the full solve's, to the bit (q and v).
  ActiveRun run(1e-6, true);
  std::vector<int> all(run.sim.vm.num_vertices);
  std::iota(all.begin(), all.end(), 0);
  const std::vector<ContactTarget> contacts = top_face_pressed(run.sim);
  run.ticks(5, all, contacts);
  const std::vector<Vec3d> full = five_virtual_ticks(-1);
  ASSERT_EQ(run.vs.q.size(), full.size());
  EXPECT_EQ(std::memcmp(run.vs.q.data(), full.data(), full.size() * sizeof(Vec3d)), 0);
  EXPECT_EQ(run.region.activated_by_contact, 0);
}

TEST(ActiveRegion, InactiveVerticesStandWhereTheySettledAndTheRegionFollowsTheDisplacement) {
  ActiveRun run(1e-5, false);  // 0.01 mm
  const std::vector<ContactTarget> contacts = top_face_pressed(run.sim);
  std::vector<int> seeds;
  for (const ContactTarget& c : contacts) seeds.push_back(c.vertex);
  run.ticks(5, seeds, contacts);
  const VirtualModel& vm = run.sim.vm;
  const int m = vm.num_vertices;
  int active = 0;
  for (int j = 0; j < m; ++j) {
    if (run.region.active[j]) { ++active; continue; }
    EXPECT_EQ(run.vs.q[j], vm.rest[j]) << j;  // never active: the target, exactly (no gravity; the physical mesh at rest)
  }
  // The press spreads: more than the seeds, fewer than every vertex (the bottom rows stay calm).
  EXPECT_GT(active, static_cast<int>(seeds.size()));
  EXPECT_LT(active, m);
  expect_lists_match_flags(run.region, vm);
  // Every active vertex displaced by more than the tolerance has only active (or pinned) vertices
  // within kSpreadRings edges: none of its neighbours is held by a vertex fixed on its target.
  auto neighbours = [&](int j) {
    std::vector<int> out;
    for (int k = vm.edge_offsets[j]; k < vm.edge_offsets[j + 1]; ++k) {
      const auto& e = vm.edges[vm.edge_entries[k] >> 1];
      out.push_back(e[0] == j ? e[1] : e[0]);
    }
    return out;
  };
  static_assert(kSpreadRings == 2);
  int displaced = 0;
  for (const int j : run.region.vertices) {
    if (norm(run.vs.q[j] - vm.rest[j]) <= run.region.tolerance) continue;
    ++displaced;
    for (const int o : neighbours(j)) {
      EXPECT_TRUE(run.region.active[o] || vm.pinned[o]) << j << " -> " << o;
      if (vm.pinned[o]) continue;
      for (const int p : neighbours(o)) EXPECT_TRUE(run.region.active[p] || vm.pinned[p]) << j << " -> " << o << " -> " << p;
    }
  }
  EXPECT_GT(displaced, 0);
  // Released (no contact, no seed), the region empties once every vertex has been calm for
  // kCalmTicks, and every vertex is back on its target: it left where it settled, and settled
  // there (its offset is round-off, far below the tolerance), and it stays there.
  const std::size_t pressed = run.region.vertices.size();
  run.ticks(25, {}, {});
  EXPECT_LT(run.region.vertices.size(), pressed);  // the calm ones have left, merged lists and all
  expect_lists_match_flags(run.region, vm);
  run.ticks(375, {}, {});
  EXPECT_TRUE(run.region.vertices.empty());
  double off = 0;
  for (int j = 0; j < m; ++j) {
    off = std::max(off, norm(run.vs.q[j] - vm.rest[j]));
    EXPECT_EQ(run.vs.q[j], vm.rest[j] + run.region.offset[j]) << j;
  }
  EXPECT_LT(off, 1e-6 * run.region.tolerance);
}

/// Coupling targets that stretch the virtual mesh against its rest shape (the physical mesh scaled
/// by 1.02 about its centre; no contact, no seeds): the edges pull every vertex off its target, and
/// no seed would bring one in. The strain check (add_strained) lets them in on the tick of the new
/// physical result, and the region settles where the full solve does; the full solve's vertices
/// stand far more than the tolerance off their targets, so a region of seeds alone would not.
/// Settled, the vertices leave the region where they stand (their offsets from their targets
/// kept), and the region empties: a strained surface costs the tick nothing once it is at rest.
/// The same with the check spread over 4 ticks (a slice of the vertices a tick, as for
/// interpolated targets), which must let in what the whole check does.
TEST(ActiveRegion, AStrainedSurfaceJoinsWithoutSeedsAndLeavesOnceSettled) {
  for (const int check_ticks : {1, 4}) {
    SCOPED_TRACE("check_ticks " + std::to_string(check_ticks));
    ActiveRun run(1e-6, false, 4, check_ticks);
    const Sim& sim = run.sim;
    Vec3d centre{};
    for (const Vec3d& x : sim.pm.rest) centre += x / static_cast<double>(sim.pm.rest.size());
    std::vector<Vec3d> stretched(sim.pm.rest);
    for (Vec3d& x : stretched) x = centre + 1.02 * (x - centre);
    VirtualState full = make_virtual_state(sim.vm);
    VirtualWorkspace fw = make_virtual_workspace(sim.vm);
    for (int tick = 0; tick < 300; ++tick) {  // tick 0 at rest, then the stretched result arrives
      const std::vector<Vec3d>& x = tick == 0 ? sim.pm.rest : stretched;
      virtual_begin_tick(sim.vm, fw, full, x, 0.001);
      for (int i = 0; i < 4; ++i) virtual_iteration(sim.vm, fw, full, {});
      virtual_end_tick(sim.vm, fw, full);
      virtual_begin_tick_active(sim.vm, run.vw, run.region, run.vs, {x, x, 1.0, tick == 0 ? 0 : 1}, 0.001, {});
      for (int i = 0; i < 4; ++i) virtual_iteration_active(sim.vm, run.vw, run.region, run.vs, {});
      virtual_end_tick_active(sim.vm, run.vw, run.region, run.vs);
    }
    std::vector<Vec3d> targets(sim.vm.num_vertices);
    paired_points(sim.vm, stretched, targets);
    EXPECT_GT(max_diff(full.q, targets), 20 * run.region.tolerance);
    EXPECT_GT(run.region.strained, 0);
    EXPECT_LT(max_diff(run.vs.q, full.q), run.region.tolerance) << "strained " << run.region.strained << " of "
                                                               << sim.vm.num_vertices;
    EXPECT_TRUE(run.region.vertices.empty()) << run.region.vertices.size() << " of " << sim.vm.num_vertices;
    if (check_ticks > 1) {  // the slices cover every vertex once, their edge lists every edge of each
      const ActiveRegion& r = run.region;
      ASSERT_EQ(r.check_vertex.size(), 5u);
      EXPECT_EQ(r.check_vertex.front(), 0);
      EXPECT_EQ(r.check_vertex.back(), sim.vm.num_vertices);
      for (int sl = 0; sl < check_ticks; ++sl)
        for (int j = r.check_vertex[sl]; j < r.check_vertex[sl + 1]; ++j)
          for (int k = sim.vm.edge_offsets[j]; k < sim.vm.edge_offsets[j + 1]; ++k)
            EXPECT_TRUE(std::binary_search(r.check_edges.begin() + r.check_edge_offsets[sl],
                                           r.check_edges.begin() + r.check_edge_offsets[sl + 1],
                                           sim.vm.edge_entries[k] >> 1));
    }
  }
}

/// Interpolated targets (time.interpolate_physical): each new physical result's blend starts from
/// the pairing of the result before it, which the region reuses when the targets say x_from was
/// that result (PhysicalTargets::from_version). Three results that stretch and shift the mesh, four
/// ticks of blend each, a press on the top face: the same bits as pairing x_from again every time.
TEST(ActiveRegion, AnInterpolatedBlendReusesThePairingOfTheResultBefore) {
  ActiveRun reuse(1e-5, true), repair(1e-5, true);
  const Sim& sim = reuse.sim;
  std::vector<std::vector<Vec3d>> results{sim.pm.rest};
  for (int k = 1; k <= 3; ++k) {
    std::vector<Vec3d> x(sim.pm.rest);
    for (Vec3d& p : x) p = p * (1.0 + 0.004 * k) + Vec3d{0.0003 * k, 0, -0.0002 * k};
    results.push_back(std::move(x));
  }
  const std::vector<ContactTarget> contacts = top_face_pressed(sim);
  std::vector<int> seeds;
  for (const ContactTarget& c : contacts) seeds.push_back(c.vertex);
  for (int k = 1; k <= 3; ++k)
    for (int tick = 1; tick <= 4; ++tick) {
      const double blend = tick / 4.0;
      for (ActiveRun* run : {&reuse, &repair}) {
        const PhysicalTargets targets{results[k - 1], results[k], blend, k, run == &reuse ? k - 1 : INT64_MIN};
        virtual_begin_tick_active(sim.vm, run->vw, run->region, run->vs, targets, 0.001, seeds);
        for (int i = 0; i < 4; ++i) virtual_iteration_active(sim.vm, run->vw, run->region, run->vs, contacts);
        virtual_end_tick_active(sim.vm, run->vw, run->region, run->vs);
      }
    }
  ASSERT_FALSE(reuse.region.vertices.empty());
  EXPECT_LT(reuse.region.vertices.size(), static_cast<std::size_t>(sim.vm.num_vertices));  // some follow their targets
  EXPECT_EQ(std::memcmp(reuse.vs.q.data(), repair.vs.q.data(), reuse.vs.q.size() * sizeof(Vec3d)), 0);
  EXPECT_EQ(std::memcmp(reuse.vs.v.data(), repair.vs.v.data(), reuse.vs.v.size() * sizeof(Vec3d)), 0);
  EXPECT_EQ(reuse.region.vertices, repair.region.vertices);
}

/// Between physical results the blend moves only the inactive vertices whose targets move
/// (ActiveRegion::moving_targets: here those on the box's lower half, the physical mesh's upper
/// half held to the bit, as its awake region holds resting vertices) and those that left the
/// region since the last pass (ActiveRegion::left). After every tick's start each other inactive
/// vertex stands exactly where a pass over every inactive vertex puts it: its target at the tick's
/// blend plus its offset. The press brings vertices in, the release lets them leave between
/// results.
TEST(ActiveRegion, BetweenResultsTheBlendMovesOnlyMovingTargetsAndVerticesThatLeft) {
  ActiveRun run(1e-5, true);
  const VirtualModel& vm = run.sim.vm;
  const int m = vm.num_vertices;
  const ActiveRegion& r = run.region;
  std::vector<std::vector<Vec3d>> results{run.sim.pm.rest};
  for (int k = 1; k <= 12; ++k) {
    std::vector<Vec3d> x(run.sim.pm.rest);
    for (Vec3d& p : x)  // a bulge of the lower half; the upper half, the one pressed, holds still
      if (p.z < 0.012) p = p + (p.z * (0.012 - p.z) / (0.006 * 0.006)) * Vec3d{0.00002 * k, 0, -0.00001 * k};
    results.push_back(std::move(x));
  }
  const std::vector<ContactTarget> pressed = top_face_pressed(run.sim);
  std::vector<int> pressed_seeds;
  for (const ContactTarget& c : pressed) pressed_seeds.push_back(c.vertex);
  std::size_t most_left = 0, moving = 0;
  int checked = 0, off = 0;
  for (int k = 1; k <= 12; ++k)
    for (int tick = 1; tick <= 4; ++tick) {
      const bool press = k <= 3;
      const PhysicalTargets targets{results[k - 1], results[k], tick / 4.0, k, k - 1};
      virtual_begin_tick_active(vm, run.vw, run.region, run.vs, targets, 0.001,
                                press ? std::span<const int>(pressed_seeds) : std::span<const int>());
      if (k >= 2) {  // from the first pass over every inactive vertex (the first result has none)
        moving = std::max(moving, r.moving_targets.size());
        most_left = std::max(most_left, r.left.size());
        for (int j = 0; j < m; ++j) {
          if (r.active[j] || vm.pinned[j] || r.in_left[j]) continue;
          const Vec3d want = (r.blend >= 1.0 ? r.p_to[j] : lerp(r.p_from[j], r.p_to[j], r.blend)) + r.offset[j];
          ++checked;
          off += std::memcmp(&run.vs.q[j], &want, sizeof(Vec3d)) != 0;
        }
      }
      for (int i = 0; i < 4; ++i)
        virtual_iteration_active(vm, run.vw, run.region, run.vs, press ? std::span<const ContactTarget>(pressed)
                                                                        : std::span<const ContactTarget>());
      virtual_end_tick_active(vm, run.vw, run.region, run.vs);
    }
  EXPECT_EQ(off, 0) << "of " << checked << " inactive vertices checked";
  EXPECT_GT(moving, 0u);
  EXPECT_LT(moving, static_cast<std::size_t>(m) / 2 + m / 4);  // the upper half's targets hold still
  EXPECT_GT(most_left, 0u);                                    // vertices left between results
}

/// The strain check spread over 4 ticks skips a slice vertex whose check cannot have changed
/// (ActiveRegion::skip_unchanged: no new result since, neither it nor a neighbour moving or written
/// since): every skipped vertex's inputs (its q, its neighbours' q, its coupling point) have the
/// bits they had when its check last ran, and the replay has the bits of checking every one. The
/// lower half bulges and stretches from result to result (its strain lets vertices in), the upper
/// half holds still; a press on the top face brings vertices in, then its release lets them leave.
TEST(ActiveRegion, TheStrainCheckSkipsOnlyVerticesWhoseCheckCannotHaveChanged) {
  ActiveRun skip(1e-6, true, 4, 4), every(1e-6, true, 4, 4);
  every.region.skip_unchanged = false;
  const VirtualModel& vm = skip.sim.vm;
  std::vector<std::vector<Vec3d>> results{skip.sim.pm.rest};
  for (int k = 1; k <= 8; ++k) {
    std::vector<Vec3d> x(skip.sim.pm.rest);
    for (Vec3d& p : x)
      if (p.z < 0.012)
        p = p + (p.z * (0.012 - p.z) / (0.006 * 0.006)) * Vec3d{0.00002 * k, 0.000015 * (k % 3), -0.00001 * k};
    results.push_back(std::move(x));
  }
  const std::vector<ContactTarget> pressed = top_face_pressed(skip.sim);
  std::vector<int> seeds;
  for (const ContactTarget& c : pressed) seeds.push_back(c.vertex);
  int ticks_differ = 0, skipped = 0, inputs_changed = 0;
  const ActiveRegion& r = skip.region;
  std::vector<std::vector<Vec3d>> q_at, point_at;  // per tick, after its start: q and the coupling points
  for (int k = 1; k <= 8; ++k)
    for (int tick = 1; tick <= 12; ++tick) {  // each result held for 8 ticks after its blend
      const bool press = k <= 3;
      const PhysicalTargets targets{results[k - 1], results[k], std::min(tick / 4.0, 1.0), k, k - 1};
      for (ActiveRun* run : {&skip, &every}) {
        virtual_begin_tick_active(vm, run->vw, run->region, run->vs, targets, 0.001,
                                  press ? std::span<const int>(seeds) : std::span<const int>());
        if (run == &skip) {
          q_at.push_back(skip.vs.q);
          std::vector<Vec3d> points(vm.num_vertices);
          for (int j = 0; j < vm.num_vertices; ++j)
            points[j] = r.blend >= 1.0 ? r.p_to[j] : lerp(r.p_from[j], r.p_to[j], r.blend);
          point_at.push_back(std::move(points));
          const int slice = static_cast<int>((r.checked_ticks - 1) % r.check_ticks), now = static_cast<int>(r.tick);
          for (int j = r.check_vertex[slice]; j < r.check_vertex[slice + 1]; ++j) {
            const std::int64_t c = r.checked_at[j];
            const bool left_now = std::find(r.removed.begin(), r.removed.end(), j) != r.removed.end();
            if (c == 0 || c == now || r.active[j] || vm.pinned[j] || left_now) continue;  // left: active at the check
            ++skipped;  // its inputs now against those when its check ran (after that tick's start)
            bool same = std::memcmp(&q_at[now - 1][j], &q_at[c - 1][j], sizeof(Vec3d)) == 0 &&
                        std::memcmp(&point_at[now - 1][j], &point_at[c - 1][j], sizeof(Vec3d)) == 0;
            for (int e = vm.edge_offsets[j]; e < vm.edge_offsets[j + 1]; ++e) {
              const int o = r.neighbours[e];
              same = same && std::memcmp(&q_at[now - 1][o], &q_at[c - 1][o], sizeof(Vec3d)) == 0;
            }
            inputs_changed += same ? 0 : 1;
          }
        }
        for (int i = 0; i < 4; ++i)
          virtual_iteration_active(vm, run->vw, run->region, run->vs,
                                   press ? std::span<const ContactTarget>(pressed) : std::span<const ContactTarget>());
        virtual_end_tick_active(vm, run->vw, run->region, run->vs);
      }
      ticks_differ += std::memcmp(skip.vs.q.data(), every.vs.q.data(), skip.vs.q.size() * sizeof(Vec3d)) != 0 ||
                      std::memcmp(skip.vs.v.data(), every.vs.v.data(), skip.vs.v.size() * sizeof(Vec3d)) != 0 ||
                      skip.region.vertices != every.region.vertices;
    }
  EXPECT_EQ(inputs_changed, 0) << "of " << skipped << " skipped";
  // (A vertex the rings brought in after its check was skipped is active now, not counted here.)
  EXPECT_GT(skipped, 0);
  EXPECT_LE(skipped, skip.region.strain_skipped);
  EXPECT_EQ(ticks_differ, 0);
  EXPECT_EQ(skip.region.strained, every.region.strained);
  EXPECT_GT(every.region.strained, 0) << "the stretch must let vertices in through the check";
  EXPECT_GT(skip.region.strain_skipped, 0);
  EXPECT_EQ(every.region.strain_skipped, 0);
}

TEST(ActiveRegion, AContactOnAnInactiveVertexActivatesIt) {
  ActiveRun run(1e-5, false);
  const std::vector<ContactTarget> contacts = top_face_pressed(run.sim);
  run.ticks(1, {}, contacts);  // no seeds: the contacts themselves must bring their vertices in
  EXPECT_EQ(run.region.activated_by_contact, static_cast<std::int64_t>(contacts.size()));
  for (const ContactTarget& c : contacts) EXPECT_LT(run.vs.q[c.vertex].z, run.sim.vm.rest[c.vertex].z);
}

TEST(Determinism, ActiveRegionIsBitwiseEqualWithOneAndTwoThreads) {
  for (const int team : {-1, 0}) {  // the calling thread, and the thread team even for this mesh
    expect_bitwise_equal_across_threads([&] {
      ActiveRun run(1e-5, false);
      if (team >= 0) run.sim.vm.parallel_min_vertices = team;
      const std::vector<ContactTarget> contacts = top_face_pressed(run.sim);
      std::vector<int> seeds;
      for (const ContactTarget& c : contacts) seeds.push_back(c.vertex);
      run.ticks(5, seeds, contacts);
      run.ticks(30, {}, {});
      return run.vs.q;
    });
  }
}

TEST(Determinism, ActiveRegionWithAHelperIsBitwiseThatOfOneThread) {
  // A box of 10 cells across, every vertex a seed for 5 ticks: the region's passes have several
  // chunks each; then it shrinks.
  expect_bitwise_equal_with_a_helper([&](SharedLoops* shared) {
    ActiveRun run(1e-5, false, 10);
    run.vw.shared = shared;
    const std::vector<ContactTarget> contacts = top_face_pressed(run.sim);
    std::vector<int> seeds(run.sim.vm.num_vertices);
    std::iota(seeds.begin(), seeds.end(), 0);
    run.ticks(5, seeds, contacts);
    run.ticks(30, {}, {});
    return run.vs.q;
  });
}

TEST(VirtualMesh, RestsAtRestAndConvergesUnderContact) {
  Scene scene = box_scene(3, 3, 6, 1);
  scene.spec.gravity = Vec3d{};
  Sim sim(scene);
  VirtualState vs = make_virtual_state(sim.vm);
  VirtualWorkspace vw = make_virtual_workspace(sim.vm);
  virtual_begin_tick(sim.vm, vw, vs, sim.pm.rest, 0.001);
  virtual_iteration(sim.vm, vw, vs, {});
  EXPECT_LT(max_diff(vs.q, sim.vm.rest), 1e-18);  // at rest every force is zero up to round-off

  // Press the top face down by 2 mm: the iteration reaches the minimiser of E_soft (gradient 0).
  std::vector<ContactTarget> contacts;
  for (int j = 0; j < sim.vm.num_vertices; ++j)
    if (sim.vm.rest[j].z > 0.0239) contacts.push_back({j, sim.vm.rest[j] - Vec3d{0, 0, 0.002}, 400.0});
  for (int i = 0; i < 3000; ++i) virtual_iteration(sim.vm, vw, vs, contacts);
  const double E = virtual_energy(sim.vm, vs.q, vw.s, vw.p, contacts, 0.001).total();
  // Perturb each coordinate of a few contact vertices by +-1 um: the energy never drops (minimum).
  for (int c = 0; c < 5; ++c)
    for (int axis = 0; axis < 3; ++axis)
      for (double sgn : {-1.0, 1.0}) {
        std::vector<Vec3d> q = vs.q;
        q[contacts[c].vertex][axis] += sgn * 1e-6;
        EXPECT_GE(virtual_energy(sim.vm, q, vw.s, vw.p, contacts, 0.001).total(), E * (1 - 1e-12));
      }
  EXPECT_LT(vs.q[contacts[0].vertex].z, sim.vm.rest[contacts[0].vertex].z - 1e-4);  // it did move
  std::vector<Vec3d> normals(sim.vm.num_vertices);
  compute_vertex_normals(sim.vm, sim.vm.rest, normals);
  for (int j = 0; j < sim.vm.num_vertices; ++j) {
    const Vec3d& r = sim.vm.rest[j];
    if (r.z > 0.0239 && r.x > 1e-4 && r.x < 0.0119 && r.y > 1e-4 && r.y < 0.0119) {
      EXPECT_NEAR(normals[j].z, 1.0, 1e-12);
    }
  }
}

/// Under gravity a virtual mesh at rest in its static equilibrium (E_s and E_svc holding its
/// weight, the physical points fixed) is a fixed point of ticks of a few iterations: they start
/// from q + h v (iteration_start), not from the prediction s, whose h^2 g offset a few Jacobi
/// iterations never remove (docs/MODEL.md, "The iterations' start"; started from s, the gap
/// scene's blocks sank for the whole recording).
TEST(VirtualMesh, AMeshAtRestUnderGravityStaysThere) {
  Scene scene = box_scene(3, 3, 6, 1);
  scene.spec.gravity = Vec3d{0, 0, -9.81};
  Sim sim(scene);
  VirtualState vs = make_virtual_state(sim.vm);
  VirtualWorkspace vw = make_virtual_workspace(sim.vm);
  auto tick = [&](int iterations) {
    virtual_begin_tick(sim.vm, vw, vs, sim.pm.rest, 0.001);
    for (int i = 0; i < iterations; ++i) virtual_iteration(sim.vm, vw, vs, {});
    virtual_end_tick(sim.vm, vw, vs);
  };
  for (int n = 0; n < 300; ++n) tick(100);  // converged ticks until nothing moves: the equilibrium
  const std::vector<Vec3d> rest = vs.q;
  double sag = 0;
  for (int j = 0; j < sim.vm.num_vertices; ++j) sag = std::max(sag, sim.vm.rest[j].z - rest[j].z);
  EXPECT_GT(sag, 1e-6);  // it hangs on its springs (1.6 um)
  tick(100);
  ASSERT_LT(max_diff(vs.q, rest), 1e-15);  // converged: a tick moves it by round-off of 1e-2 m coordinates
  for (int n = 0; n < 100; ++n) tick(4);
  // round-off of 100 ticks; started from s the box moves by 3.1e-6 m in them
  EXPECT_LT(max_diff(vs.q, rest), 1e-14) << "of a sag of " << sag << " m";
}

}  // namespace
}  // namespace ebh
