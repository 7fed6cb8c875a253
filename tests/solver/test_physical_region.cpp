// The physical mesh's awake region (solver/physical_region.hpp): who wakes (the hot vertices, the
// vertices under a virtual vertex that moved, two rings around them), that sleeping vertices are
// held at rest, that a creeping virtual vertex wakes its vertices once its motion adds up past the
// tolerance, that the result approaches the whole mesh's as the tolerance falls (and is its bits
// when every vertex wakes), and that the step's bits do not depend on the threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "box_sim.hpp"
#include "solver/local_kernels.hpp"
#include "solver/physical_region.hpp"

using namespace ebh;
using namespace ebh::test;

namespace {

Scene weightless(Scene s) {
  s.spec.gravity = Vec3d{};
  return s;
}

/// A box at rest (no gravity) with its awake region; `step` runs one physical step as the replay
/// does (choose_awake, physical_step, saw_virtual_mesh), the first with every vertex.
struct RegionSim {
  Sim sim;
  PhysicalRegion region;
  std::vector<Vec3d> q;  // the virtual mesh the steps are given
  PhysicalStepParams params;
  int steps = 0;
  RegionSim(double tolerance, int nx = 6, int ny = 6, int nz = 12)
      : sim(weightless(box_scene(nx, ny, nz, 1))), region(make_physical_region(sim.pm, tolerance)), q(sim.vm.rest) {
    params.iterations = 8;
  }
  /// Returns the awake count (0: the step is skipped, the state held at rest, as the replay does).
  int step(SharedLoops* shared = nullptr) {
    const int awake = choose_awake(sim.pm, sim.pw, q, steps == 0, region);
    ++steps;
    if (awake == 0) {
      for (Vec3d& v : sim.ps.v) v = Vec3d{};
      return 0;
    }
    physical_step(sim.pm, sim.pw, sim.ps, q, params, nullptr, shared, &region);
    saw_virtual_mesh(sim.pm, q, region);
    return awake;
  }
};

/// The virtual vertex on the top face nearest its centre.
int top_virtual_vertex(const Sim& s) {
  int best = 0;
  double best_d = 1e30;
  for (int j = 0; j < static_cast<int>(s.vm.rest.size()); ++j) {
    const Vec3d r = s.vm.rest[j];
    const double d = std::abs(r.z - 0.024) * 1e3 + norm(Vec3d{r.x - 0.006, r.y - 0.006, 0});
    if (d < best_d) { best_d = d; best = j; }
  }
  return best;
}

/// The physical vertices (local indices) within `rings` tet edges of the vertices virtual vertex j
/// pairs with, free ones only: by brute force over the tets.
std::set<int> expected_awake(const Sim& s, int j, int rings) {
  const PhysicalModel& m = s.pm;
  std::set<int> in;
  for (int c = 0; c < m.pair_count[j]; ++c) in.insert(m.local.pair_vertex[j][c]);
  for (int r = 0; r < rings; ++r) {
    std::set<int> grown = in;
    for (const Tet& t : m.tets) {
      bool touches = false;
      for (int a = 0; a < 4; ++a) touches = touches || in.count(m.vertex_local[t[a]]) > 0;
      if (touches)
        for (int a = 0; a < 4; ++a) grown.insert(m.vertex_local[t[a]]);
    }
    in = grown;
  }
  std::set<int> free;
  for (const int i : in)
    if (!m.local.pinned[i]) free.insert(i);
  return free;
}

}  // namespace

// At rest nothing wakes (the step is skipped); a virtual vertex moved by more than the tolerance
// wakes the physical vertices it pairs with and two rings of their neighbours, exactly; the step's
// lists hold the tet blocks and virtual vertices those touch; one moved by less wakes nothing.
TEST(PhysicalRegion, AVirtualVertexMovedPastTheToleranceWakesItsVerticesAndTwoRings) {
  const double d = 1e-6;
  RegionSim r(d);
  EXPECT_EQ(r.step(), r.sim.pm.num_free) << "the first step iterates every vertex";
  EXPECT_EQ(r.step(), 0) << "a box at rest without gravity: nothing moves";
  const int j = top_virtual_vertex(r.sim);
  r.q[j] = r.q[j] + Vec3d{0, 0, 0.5 * d};
  EXPECT_EQ(r.step(), 0) << "moved by less than the tolerance";
  r.q[j] = r.sim.vm.rest[j] + Vec3d{0, 0, 3 * d};
  const int awake = choose_awake(r.sim.pm, r.sim.pw, r.q, false, r.region);
  const std::set<int> expected = expected_awake(r.sim, j, kRegionRings);
  EXPECT_EQ(awake, static_cast<int>(expected.size()));
  EXPECT_EQ(std::set<int>(r.region.vertices.begin(), r.region.vertices.end()), expected);
  EXPECT_TRUE(std::is_sorted(r.region.vertices.begin(), r.region.vertices.end()));
  EXPECT_LT(awake, r.sim.pm.num_free / 4) << "a region, not the mesh";
  // Every tet with an awake corner is in a listed block; every virtual vertex an awake vertex pairs with is listed.
  const PhysicalModel& m = r.sim.pm;
  for (int t = 0; t < m.num_tets; ++t) {
    bool touches = false;
    for (int a = 0; a < 4; ++a) touches = touches || expected.count(m.vertex_local[m.tets[t][a]]) > 0;
    if (touches) {
      EXPECT_TRUE(std::binary_search(r.region.tet_blocks.begin(), r.region.tet_blocks.end(), m.tet_slot[t] / kTetLanes))
          << "tet " << t;
    }
  }
  for (const int i : expected)
    for (int k = m.local.cpl_offsets[i]; k < m.local.cpl_offsets[i + 1]; ++k)
      EXPECT_TRUE(std::binary_search(r.region.virtuals.begin(), r.region.virtuals.end(), m.local.cpl_virtual[k]));
}

// A step with a region moves only its awake vertices: every other vertex keeps its position to the
// bit and ends at rest (v = 0), although it had a velocity before (it is held, not coasting).
TEST(PhysicalRegion, SleepingVerticesAreHeldAtRest) {
  RegionSim r(1e-6);
  r.step();
  r.sim.perturb();  // every free vertex has a velocity now
  const int j = top_virtual_vertex(r.sim);
  r.q[j] = r.q[j] + Vec3d{0, 0, 1e-3};
  // Decide the region from a step without motion (so only the pull seeds it), then step with it.
  const std::vector<Vec3d> before = r.sim.ps.x;
  const int awake = choose_awake(r.sim.pm, r.sim.pw, r.q, false, r.region);
  ASSERT_GT(awake, 0);
  ASSERT_LT(awake, r.sim.pm.num_free);
  physical_step(r.sim.pm, r.sim.pw, r.sim.ps, r.q, r.params, nullptr, nullptr, &r.region);
  int held = 0, moved = 0;
  for (int i = 0; i < r.sim.pm.num_vertices; ++i) {
    const int a = r.sim.pm.vertex_order[i];
    if (r.region.awake[i]) {
      moved += norm(r.sim.ps.x[a] - before[a]) > 0;
      continue;
    }
    ++held;
    EXPECT_EQ(std::memcmp(&r.sim.ps.x[a], &before[a], sizeof(Vec3d)), 0) << "vertex " << a;
    EXPECT_EQ(norm(r.sim.ps.v[a]), 0.0) << "vertex " << a;
  }
  EXPECT_GT(held, 0);
  EXPECT_EQ(moved, awake) << "every awake vertex moves";
}

// A virtual vertex that creeps by 0.6 of the tolerance a step wakes its vertices on the second step:
// its motion is measured from where they last saw it, so it adds up while they sleep.
TEST(PhysicalRegion, ACreepingVirtualVertexWakesItsVerticesOnceItsMotionAddsUp) {
  const double d = 1e-6;
  RegionSim r(d);
  r.step();
  const int j = top_virtual_vertex(r.sim);
  r.q[j] = r.q[j] + Vec3d{0.6 * d, 0, 0};
  EXPECT_EQ(r.step(), 0);
  r.q[j] = r.q[j] + Vec3d{0.6 * d, 0, 0};
  EXPECT_GT(r.step(), 0) << "1.2 tolerances from where its vertices last saw it";
}

// The region's result approaches the whole mesh's as the tolerance falls (a top patch of the virtual
// mesh pulled up and sideways over 30 steps); under gravity, where every free vertex moves in every
// step, a tolerance below every motion wakes every vertex and gives the whole mesh's bits.
TEST(PhysicalRegion, TheResultApproachesTheWholeMeshAsTheToleranceFalls) {
  auto run = [](double tolerance, bool weight, double* awake_mean) {
    RegionSim r(tolerance > 0 ? tolerance : 1.0);
    if (weight) {
      Scene heavy = box_scene(6, 6, 12, 1);
      r.sim = Sim(heavy);
      r.region = make_physical_region(r.sim.pm, tolerance > 0 ? tolerance : 1.0);
    }
    const int j0 = top_virtual_vertex(r.sim);
    std::vector<int> patch;
    for (int j = 0; j < static_cast<int>(r.q.size()); ++j)
      if (norm(r.sim.vm.rest[j] - r.sim.vm.rest[j0]) < 0.003) patch.push_back(j);
    double awake = 0;
    for (int s = 0; s < 30; ++s) {
      const double a = std::min(1.0, s / 10.0);
      for (const int j : patch) r.q[j] = r.sim.vm.rest[j] + Vec3d{0.5e-3 * a, 0, 1e-3 * a};
      if (tolerance > 0) {
        awake += r.step();
      } else {
        physical_step(r.sim.pm, r.sim.pw, r.sim.ps, r.q, r.params);
        awake += r.sim.pm.num_free;
      }
    }
    if (awake_mean) *awake_mean = awake / 30 / r.sim.pm.num_free;
    return r.sim.ps.x;
  };
  const std::vector<Vec3d> whole = run(0, false, nullptr);
  double coarse_awake = 0, fine_awake = 0, tiny_awake = 0;
  const double coarse = max_diff(run(1e-6, false, &coarse_awake), whole);
  const double fine = max_diff(run(1e-8, false, &fine_awake), whole);
  EXPECT_LT(fine, coarse);
  // Within a few tolerances of the whole mesh (1.2 and 0.5 tolerances when written), against a pull of 1.1 mm.
  EXPECT_LT(coarse, 3 * 1e-6);
  EXPECT_LT(fine, 3 * 1e-8);
  EXPECT_LT(coarse_awake, 0.9) << "the coarse region must leave vertices asleep";
  EXPECT_LT(coarse_awake, fine_awake);
  const std::vector<Vec3d> heavy = run(0, true, nullptr);
  const std::vector<Vec3d> tiny = run(1e-30, true, &tiny_awake);
  EXPECT_EQ(tiny_awake, 1.0);
  EXPECT_EQ(std::memcmp(tiny.data(), heavy.data(), heavy.size() * sizeof(Vec3d)), 0);
}

// The region at the grain of patches (patch_halos, the CUDA step's rule): a patch's halo holds a hot
// or seeded vertex exactly when choose_awake wakes one of the patch's free vertices. Patches cut
// from a shuffled vertex order (scattered, and some holding only pinned vertices), hot vertices
// and moved virtual vertices drawn at random, the pinned bottom face among them.
TEST(PhysicalRegion, APatchHaloHoldsAMovedVertexExactlyWhenOneOfThePatchsVerticesWakes) {
  const double d = 1e-6;
  RegionSim r(d, 4, 4, 8);
  r.step();  // every virtual vertex seen where it rests
  const PhysicalModel& m = r.sim.pm;
  const int n = m.num_vertices;
  std::mt19937 rng(3);
  std::vector<int> members(n);
  std::iota(members.begin(), members.end(), 0);
  std::shuffle(members.begin(), members.end(), rng);
  // The pinned vertices first: the first patches hold only pinned ones, one holds both kinds.
  std::stable_partition(members.begin(), members.end(), [&](int a) { return m.pinned[a] != 0; });
  std::vector<int> offsets{0};
  for (int k = 9; k < n; k += 7) offsets.push_back(k);
  offsets.push_back(n);
  const PatchHalos halos = patch_halos(m, offsets, members);
  ASSERT_EQ(halos.offsets.size(), offsets.size());
  int compared = 0, woken = 0, slept = 0;
  for (int trial = 0; trial < 40; ++trial) {
    // The step before moved a few vertices (hot); the virtual mesh moved at a few places (seeds).
    std::vector<std::uint8_t> moved(n, 0);
    for (int i = 0; i < n; ++i) r.sim.pw.x[i] = r.sim.pw.x_start[i] = m.rest[m.vertex_order[i]];
    for (int k = 0; k < trial % 3; ++k) {
      const int a = std::uniform_int_distribution<int>(0, n - 1)(rng);
      if (!m.pinned[a]) r.sim.pw.x[m.vertex_local[a]] += Vec3d{2 * d, 0, 0};
    }
    std::vector<Vec3d> q = r.q;
    std::vector<std::uint8_t> virtual_moved(q.size(), 0);
    for (int k = 0; k < (trial / 3) % 3; ++k) {
      const int j = std::uniform_int_distribution<int>(0, static_cast<int>(q.size()) - 1)(rng);
      q[j] += Vec3d{0, 2 * d, 0};
      virtual_moved[j] = 1;
    }
    for (int a = 0; a < n; ++a) {
      moved[a] = squared_norm(r.sim.pw.x[m.vertex_local[a]] - r.sim.pw.x_start[m.vertex_local[a]]) > d * d;
      for (int k = m.cpl_offsets[a]; k < m.cpl_offsets[a + 1]; ++k) moved[a] |= virtual_moved[m.cpl_virtual[k]];
    }
    choose_awake(m, r.sim.pw, q, false, r.region);
    for (int p = 0; p + 1 < static_cast<int>(offsets.size()); ++p) {
      bool cpu = false, halo = false;
      for (int k = offsets[p]; k < offsets[p + 1]; ++k) cpu = cpu || r.region.awake[m.vertex_local[members[k]]];
      for (int k = halos.offsets[p]; k < halos.offsets[p + 1]; ++k) {
        const int a = halos.vertices[k];
        EXPECT_FALSE(m.pinned[a]) << "a pinned vertex never wakes: not in a halo";
        halo = halo || moved[a];
      }
      EXPECT_EQ(halo, cpu) << "trial " << trial << ", patch " << p;
      ++compared;
      (cpu ? woken : slept) += 1;
    }
  }
  EXPECT_EQ(halos.offsets[1], 0) << "the pinned patch's halo is empty";
  EXPECT_GT(woken, 20);
  EXPECT_GT(slept, 20);
  std::printf("[ patch halos ] %d patch decisions, %d awake, %d asleep\n", compared, woken, slept);
}

// The region's steps give the same bits on one and two threads and with a helping thread.
TEST(Determinism, PhysicalRegionStepIsBitwiseEqualAcrossThreadsAndWithAHelper) {
  auto run = [](SharedLoops* shared) {
    RegionSim r(1e-7);
    r.params.tolerance = 1e-6;  // the stopping rule's decisions on the region's residual too
    r.params.max_iterations = 40;
    const int j0 = top_virtual_vertex(r.sim);
    for (int s = 0; s < 6; ++s) {
      for (int j = 0; j < static_cast<int>(r.q.size()); ++j)
        if (norm(r.sim.vm.rest[j] - r.sim.vm.rest[j0]) < 0.004) r.q[j] = r.sim.vm.rest[j] + Vec3d{0, 0, 2e-4 * s};
      r.step(shared);
    }
    std::vector<Vec3d> out = r.sim.ps.x;
    out.insert(out.end(), r.sim.ps.v.begin(), r.sim.ps.v.end());
    return out;
  };
  expect_bitwise_equal_across_threads([&] { return run(nullptr); });
  expect_bitwise_equal_with_a_helper(run);
}
