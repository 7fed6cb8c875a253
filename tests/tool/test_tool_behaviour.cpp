// Behaviour of the tools: pressing, free motion, grasping, broad phase, force clamp, and the
// two projections in the gap scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <set>
#include <tuple>

#include "contact_points.hpp"
#include "core/error.hpp"
#include "tool/contact.hpp"
#include "tool/grasp.hpp"
#include "tool/newton.hpp"
#include "tool/tool_model.hpp"
#include "tool/virtual_tool.hpp"

using namespace ebh;

namespace {
const Quatd kPointingDown{0, 1, 0, 0};  // pi about x: tool +z -> world -z

std::vector<Vec3d> flat_patch(double half, double spacing) {
  std::vector<Vec3d> q;
  const int n = static_cast<int>(std::lround(half / spacing));
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j) q.push_back({i * spacing, j * spacing, 0.0});
  return q;
}
}  // namespace

TEST(VirtualTool, PressingAFlatPatchFeelsTheNormalForceAndStaysOutside) {
  ToolSpec spec;
  spec.kind = ToolSpec::Kind::Forceps;
  const ToolModel tool = build_tool(spec);
  const Stiffness k;
  const std::vector<Vec3d> q = flat_patch(0.015, 0.0005);  // fixed vertices on z = 0
  const double L = spec.forceps.jaw_length, depth = 0.005;
  const ToolPose physical{{0, 0, L - depth}, kPointingDown};  // closed jaws' tips 5 mm deep
  VertexGrid grid;
  VirtualToolState st;
  init_virtual_tool(st, q.size(), {{0, 0, L + 0.001}, kPointingDown});
  for (int tick = 0; tick < 300; ++tick) update_virtual_tool(tool, k, physical, 0.0, q, {}, grid, st);
  const ToolOutput out = tool_output(tool, k, physical, st);
  // Contacts pushing the tool up: those nearer the jaw tips' face than the jaws' sides.
  int pushing_up = 0;
  Vec3d contact_force{};
  for (const ContactPoint& c : st.contacts) {
    pushing_up += c.normal.z < -0.9;
    contact_force -= k.k_con * c.phi * c.normal;  // -dE_con/dP_g, the tissue's push on the tool
  }
  ASSERT_GE(pushing_up, 20);
  // Along the patch normal: the contact is symmetric about the tool axis, so the x/y force and
  // the torque vanish up to round-off of sums of ~50 terms.
  EXPECT_GT(out.force.z, 0.5);
  EXPECT_LT(std::hypot(out.force.x, out.force.y), 1e-9 * out.force.z);
  EXPECT_LT(norm(out.torque), 1e-9);
  // Quasi-static equilibrium: the coupling force balances the contact forces.
  EXPECT_LT(norm(out.force - contact_force), 1e-6 * out.force.z);  // Newton converged to 1e-6
  // The virtual tool stays outside: >= 20 contacts share F <= k_vcs * 5 mm = 1.5 N, so none is
  // deeper than 1.5 / (400 * 20) m = 0.19 mm. The physical tool's closest-point depth saturates
  // at the jaws' half thickness (1 mm): the deepest vertex is nearer a side face than the tip face.
  const double pen = penetration_depth(tool, st.pose, 0.0, q, grid);
  EXPECT_LT(pen, 1.5 / (k.k_con * 20));
  EXPECT_NEAR(penetration_depth(tool, physical, 0.0, q, grid), spec.forceps.jaw_thickness / 2, 1e-12);
  EXPECT_FALSE(out.force_clamped);
}

TEST(VirtualTool, InFreeSpaceFollowsThePhysicalToolExactly) {
  ToolSpec spec;
  const ToolModel tool = build_tool(spec);
  const Stiffness k;
  const std::vector<Vec3d> q = flat_patch(0.02, 0.002);  // far below the tool
  ToolPose physical{{0, 0, 0.1}, kPointingDown};
  VertexGrid grid;
  VirtualToolState st;
  init_virtual_tool(st, q.size(), physical);
  for (int tick = 0; tick < 100; ++tick) {
    // 0.3 mm and 0.8 degrees per tick: inside one Newton step's limits (0.5 mm, 2 degrees).
    physical.position += Vec3d{0.0003 * std::cos(0.1 * tick), 0.0003 * std::sin(0.1 * tick), 0.0};
    physical.orientation = normalized(quat_from_rotvec(Vec3d{0.014, 0.0, 0.0}) * physical.orientation);
    update_virtual_tool(tool, k, physical, 1.0, q, {}, grid, st);
    const ToolOutput out = tool_output(tool, k, physical, st);
    // One Newton step solves the quadratic coupling exactly: the error is round-off.
    ASSERT_LT(norm(st.pose.position - physical.position), 1e-15);
    ASSERT_LT(norm(rotvec_from_quat(st.pose.orientation * conjugate(physical.orientation))), 1e-12);
    ASSERT_LT(norm(out.force), 1e-12);
    ASSERT_TRUE(st.contacts.empty());
  }
}

TEST(VirtualTool, EnergyNeverIncreasesOverNewtonSteps) {
  ToolSpec spec;
  const ToolModel tool = build_tool(spec);
  const Stiffness k;
  const std::vector<Vec3d> q = flat_patch(0.02, 0.0005);
  // The hook's bent tip pressed 4 mm into the patch, tilted: asymmetric contacts, torques.
  const ToolPose physical{{0.001, 0.0, 0.002}, normalized(quat_from_rotvec(Vec3d{0.3, 0.2, 0}) * kPointingDown)};
  VertexGrid grid;
  VirtualToolState st;
  init_virtual_tool(st, q.size(), {{0.001, 0.0, 0.012}, kPointingDown});
  double previous = tool_energy(tool, k, physical, 1.0, q, {}, grid, st);
  for (int tick = 0; tick < 100; ++tick) {
    update_virtual_tool(tool, k, physical, 1.0, q, {}, grid, st);
    const double e = tool_energy(tool, k, physical, 1.0, q, {}, grid, st);
    ASSERT_LE(e, previous * (1 + 1e-12));  // Armijo backtracking: monotone up to round-off
    previous = e;
  }
  EXPECT_GT(st.contacts.size(), 0u);
}

TEST(VirtualTool, AMeshIterationAfterANewtonCallTakesItsContacts) {
  // Right after update_virtual_tool, virtual_mesh_targets takes the call's contacts at its final
  // pose instead of searching the grid: they must be what the search finds (the same vertices,
  // targets and stiffnesses; a grasped vertex left out), with either projection, while the
  // tilted hook sinks into a patch over Newton calls of several line-searched steps.
  for (const Projection projection : {Projection::ClosestPoint, Projection::InverseNormal}) {
    ToolSpec spec;
    spec.newton_iterations = 3;
    const ToolModel tool = build_tool(spec, projection);
    const Stiffness k;
    const std::vector<Vec3d> q = flat_patch(0.02, 0.0005);
    const std::vector<Vec3d> normals(q.size(), Vec3d{0, 0, 1});
    const ToolPose physical{{0.001, 0.0, 0.002}, normalized(quat_from_rotvec(Vec3d{0.3, 0.2, 0}) * kPointingDown)};
    VertexGrid grid;
    VirtualToolState st;
    init_virtual_tool(st, q.size(), {{0.001, 0.0, 0.006}, kPointingDown});
    std::size_t most = 0;
    for (int tick = 0; tick < 40; ++tick) {
      // A grasp is taken at a tick's start, before the calls: a vertex in contact held from then on.
      if (tick == 20 && !st.contacts.empty()) st.grasp.held[st.contacts.front().vertex] = 1;
      update_virtual_tool(tool, k, physical, 1.0, q, normals, grid, st);
      ASSERT_TRUE(st.call_fresh);
      std::vector<ContactTarget> reused, searched;
      virtual_mesh_targets(tool, k, 1.0, q, normals, grid, st, reused);
      ASSERT_FALSE(st.call_fresh) << "the iteration that follows moves q";
      virtual_mesh_targets(tool, k, 1.0, q, normals, grid, st, searched);
      auto sorted = [](const std::vector<ContactTarget>& list) {
        std::vector<std::tuple<int, double, double, double, double>> out;
        for (const ContactTarget& t : list) out.emplace_back(t.vertex, t.target.x, t.target.y, t.target.z, t.stiffness);
        std::sort(out.begin(), out.end());
        return out;
      };
      ASSERT_EQ(sorted(reused), sorted(searched)) << "tick " << tick;
      most = std::max(most, reused.size());
    }
    EXPECT_GT(most, 10u) << "the hook presses the patch";
  }
}

TEST(Grasp, GraspedVerticesFollowTheJawsAndAreFreedOnRelease) {
  ToolSpec spec;
  spec.kind = ToolSpec::Kind::Forceps;
  const ToolModel tool = build_tool(spec);
  const Stiffness k;
  // A block of tissue between the open jaws (tool frame = world here).
  std::vector<Vec3d> q;
  for (int i = -3; i <= 3; ++i)
    for (int j = -4; j <= 4; ++j)
      for (int l = 0; l <= 10; ++l) q.push_back({0.0005 * i, 0.0005 * j, 0.005 + 0.001 * l});
  q.push_back({0.0, 0.0, 0.04});  // one vertex far beyond the jaw tips: never grasped
  VertexGrid grid;
  VirtualToolState st;
  ToolPose pose{{0, 0, 0}, Quatd{}};
  init_virtual_tool(st, q.size(), pose);
  EXPECT_EQ(update_grasp(tool, st.pose, 1.0, q, grid, st.grasp), 0);  // open: nothing
  EXPECT_EQ(update_grasp(tool, st.pose, 0.1, q, grid, st.grasp), +1);  // closing edge
  EXPECT_EQ(st.grasp.vertices.size(), q.size() - 1);
  EXPECT_EQ(st.grasp.held.back(), 0);
  EXPECT_EQ(update_grasp(tool, st.pose, 0.05, q, grid, st.grasp), 0);  // once per closing
  const Collider<double> hard = grasp_hard_box(tool, 0.1);
  const double dmin = -std::min({hard.half.x, hard.half.y, hard.half.z}) / spec.forceps.soft_margin;
  for (double w : st.grasp.weight) {  // d in [dmin, 1] (grasp.hpp)
    EXPECT_GE(w, grasp_weight(1.0, spec.forceps.eta));
    EXPECT_LE(w, grasp_weight(dmin, spec.forceps.eta));
  }
  // Targets move rigidly with the virtual tool.
  const ToolPose moved{{0.003, -0.002, 0.01}, quat_from_rotvec(Vec3d{0.2, -0.3, 0.1})};
  st.pose = moved;
  std::vector<ContactTarget> targets;
  virtual_mesh_targets(tool, k, 0.05, q, {}, grid, st, targets);
  ASSERT_EQ(targets.size(), st.grasp.vertices.size());  // grasped vertices get no pressing contact
  for (std::size_t j = 0; j < targets.size(); ++j)
    EXPECT_LT(norm(targets[j].target - apply(to_rigid(moved), st.grasp.local_target[j])), 1e-15);
  // The tool feels the pull through E_con: tissue fixed, physical tool lifted 5 mm.
  st.pose = pose;
  const ToolPose lifted{{0, 0, -0.005}, Quatd{}};  // tool +z points to the tissue: -z is "up"
  for (int tick = 0; tick < 100; ++tick) update_virtual_tool(tool, k, lifted, 0.05, q, {}, grid, st);
  const ToolOutput out = tool_output(tool, k, lifted, st);
  EXPECT_GT(out.force.z, 0.0);  // pulled back towards the tissue (+z)
  EXPECT_GT(st.pose.position.z, lifted.position.z);
  // Release.
  EXPECT_EQ(update_grasp(tool, st.pose, 0.5, q, grid, st.grasp), -1);
  EXPECT_TRUE(st.grasp.vertices.empty());
  EXPECT_EQ(std::accumulate(st.grasp.held.begin(), st.grasp.held.end(), 0), 0);
}

// The release threshold: closed jaws let go at it, not at the grasp threshold, so a jaw signal that
// wanders between the two holds on; by default the two are one (the paper's single threshold).
TEST(Grasp, ClosedJawsLetGoAtTheReleaseThreshold) {
  ToolSpec spec;
  spec.kind = ToolSpec::Kind::Forceps;
  spec.forceps.release_threshold = 0.3;
  const std::vector<Vec3d> q{{0, 0, 0.01}};  // one vertex between the jaws
  VertexGrid grid;
  GraspState g;
  const ToolPose pose{{0, 0, 0}, Quatd{}};
  const ToolModel tool = build_tool(spec);
  EXPECT_EQ(update_grasp(tool, pose, 0.25, q, grid, g), 0);   // open: closes below 0.2 only
  EXPECT_EQ(update_grasp(tool, pose, 0.15, q, grid, g), +1);
  EXPECT_EQ(update_grasp(tool, pose, 0.25, q, grid, g), 0);   // noise above 0.2: still held
  EXPECT_EQ(update_grasp(tool, pose, 0.299, q, grid, g), 0);
  EXPECT_EQ(g.vertices.size(), 1u);
  EXPECT_EQ(update_grasp(tool, pose, 0.3, q, grid, g), -1);   // at the release threshold: let go
  spec.forceps.release_threshold.reset();
  const ToolModel paper = build_tool(spec);
  GraspState h;
  EXPECT_EQ(update_grasp(paper, pose, 0.15, q, grid, h), +1);
  EXPECT_EQ(update_grasp(paper, pose, 0.25, q, grid, h), -1);  // one threshold
}

/// n points uniform in a 6 cm cube about the origin (the broad-phase tests' virtual mesh).
std::vector<Vec3d> random_cloud(unsigned seed, std::size_t n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.03, 0.03);
  std::vector<Vec3d> q(n);
  for (Vec3d& x : q) x = {u(rng), u(rng), u(rng)};
  return q;
}

/// A pose in the middle of random_cloud's cube, turned at random.
ToolPose random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.015, 0.015);
  const Vec3d p{u(rng), u(rng), u(rng)};
  return {p, test::random_rotation(rng)};
}

/// The default tool of `kind`.
ToolModel tool_of(ToolSpec::Kind kind) {
  ToolSpec spec;
  spec.kind = kind;
  return build_tool(spec);
}

TEST(BroadPhase, GivesTheSameContactsAsBruteForce) {
  std::mt19937 rng(11);
  const std::vector<Vec3d> q = random_cloud(11, 20000);
  for (auto kind : {ToolSpec::Kind::Hook, ToolSpec::Kind::Forceps}) {
    const ToolModel tool = tool_of(kind);
    VertexGrid grid;
    grid.rebuild(q, 0.002);
    for (int t = 0; t < 30; ++t) {
      const ToolPose pose = random_pose(rng);
      std::vector<ContactTarget> fast;
      detect_contacts(tool, pose, 0.7, q, {}, grid, 400.0, fast);
      std::vector<int> all(q.size());
      std::iota(all.begin(), all.end(), 0);
      std::vector<ContactPoint> brute;
      narrow_phase(pose_tool(tool, pose, 0.7), tool.projection, all, q, {}, {}, brute);
      std::set<int> a, b;
      for (auto& c : fast) a.insert(c.vertex);
      for (auto& c : brute) b.insert(c.vertex);
      ASSERT_EQ(a, b);
      ASSERT_GT(b.size(), 0u);
    }
  }
}

TEST(BroadPhase, APassWalksEachCellOnceAndVisitsWhatTheOverlappingBoxesVisit) {
  // The hook's shaft is covered by overlapping boxes (cover_collider); within one pass a cell is
  // tested and its vertices visited once, in the order the boxes first reach them.
  const std::vector<Vec3d> q = random_cloud(13, 20000);
  const ToolModel tool = build_tool(ToolSpec{});
  VertexGrid grid;
  grid.rebuild(q, 0.002);
  const PosedTool posed = pose_tool(tool, {{0.0, 0.0, 0.01}, kPointingDown}, 1.0);
  int overlapping = 0;
  for (int c = 0; c < posed.count; ++c) {
    const Collider<double>& shape = posed.shape[c];
    const Rigid<double>& w = posed.world[c];
    int tests = 0;
    auto keep = [&](Vec3d centre, double slack) {
      ++tests;
      return signed_distance_local(shape, apply_inverse(w, centre)) <= slack;
    };
    std::vector<int> all, once;
    cover_collider(shape, w, grid.cell_size(), [&](Vec3d lo, Vec3d hi) {
      grid.query(lo, hi, 0.001, q, keep, [&](int i) { all.push_back(i); });
    });
    const int tests_all = tests;
    tests = 0;
    const std::uint32_t pass = grid.next_pass();
    cover_collider(shape, w, grid.cell_size(), [&](Vec3d lo, Vec3d hi) {
      grid.query(lo, hi, 0.001, q, keep, [&](int i) { once.push_back(i); }, pass);
    });
    std::vector<int> first;  // `all` without its repeats, in first-visit order
    std::set<int> seen;
    for (const int i : all)
      if (seen.insert(i).second) first.push_back(i);
    EXPECT_EQ(once, first) << "collider " << c;
    EXPECT_LE(tests, tests_all);
    if (all.size() > first.size()) {
      ++overlapping;
      EXPECT_LT(tests, tests_all) << "collider " << c;
    }
  }
  EXPECT_GT(overlapping, 0);  // the shaft's boxes overlap
}

TEST(BroadPhase, ABoxColliderIsCoveredByItsWorldBoundsNotByItsBoundingCube) {
  // A jaw-like box (thin, long; sharp and rounded), turned at random: the one cover box is the
  // world-aligned bounds of its eight corners (each face through a corner, so every point of the
  // box is inside it), a fraction of the cube around its bounding sphere.
  std::mt19937 rng(23);
  for (const double rounding : {0.0, 0.0005}) {
    Collider<double> jaw;
    jaw.shape = Shape::Box;
    jaw.a = {0.001, -0.002, 0.015};
    jaw.half = {0.0015, 0.0025, 0.01};
    jaw.radius = rounding;
    for (int t = 0; t < 50; ++t) {
      const Rigid<double> w{to_matrix(test::random_rotation(rng)), {0.01, 0.02, -0.03}};
      std::vector<std::pair<Vec3d, Vec3d>> boxes;
      cover_collider(jaw, w, 0.001, [&](Vec3d lo, Vec3d hi) { boxes.push_back({lo, hi}); });
      ASSERT_EQ(boxes.size(), 1u);
      const auto [lo, hi] = boxes[0];
      Vec3d clo{1e300, 1e300, 1e300}, chi{-1e300, -1e300, -1e300};
      for (int k = 0; k < 8; ++k) {
        const Vec3d corner = apply(w, jaw.a + Vec3d{(k & 1) ? jaw.half.x : -jaw.half.x,
                                                    (k & 2) ? jaw.half.y : -jaw.half.y,
                                                    (k & 4) ? jaw.half.z : -jaw.half.z});
        clo = cwise_min(clo, corner);
        chi = cwise_max(chi, corner);
      }
      // Coordinates of ~3 cm, whose ulp is 3.5e-18 m: the two ways of computing the bounds agree
      // to a few ulps (1e-15 m allows ~300, still a millionth of a grid cell), and the cover holds
      // the corners to about one (1e-17 m).
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(lo[k], clo[k], 1e-15) << t;
        EXPECT_NEAR(hi[k], chi[k], 1e-15) << t;
        EXPECT_LE(lo[k], clo[k] + 1e-17) << t;
        EXPECT_GE(hi[k], chi[k] - 1e-17) << t;
      }
      // For these half extents the bounds take at most ~0.44 of the bounding cube's volume (the
      // largest over 2e5 random rotations); the cube itself (1.0) fails.
      const double cube = std::pow(2 * bounding_radius(jaw), 3);
      EXPECT_LT((hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z), 0.75 * cube) << t;
    }
  }
}

TEST(BroadPhase, ANewtonCallsCandidatesAreTheVerticesWithinItsReachInTheGatherOrder) {
  // gather_reachable: the vertices some collider comes within newton_reach_bound of (against
  // every vertex, brute force), listed in gather_candidates' order; the hook and the forceps,
  // posed at random, with and without rotation reach.
  std::mt19937 rng(17);
  const std::vector<Vec3d> q = random_cloud(17, 20000);
  int listed = 0;
  for (auto kind : {ToolSpec::Kind::Hook, ToolSpec::Kind::Forceps}) {
    const ToolModel tool = tool_of(kind);
    VertexGrid grid;
    grid.rebuild(q, 0.002);
    for (int t = 0; t < 20; ++t) {
      const PosedTool posed = pose_tool(tool, random_pose(rng), 0.7);
      const double T = t % 2 ? 0.0005 : 0.002, th = (t / 2) % 3 == 0 ? 0.0 : 0.004 * ((t / 2) % 3);
      auto within = [&](int i) {
        for (int c = 0; c < posed.count; ++c)
          if (signed_distance_local(posed.shape[c], apply_inverse(posed.world[c], q[i])) <=
              newton_reach_bound(T, th, norm(q[i] - posed.origin)))
            return true;
        return false;
      };
      std::vector<int> gathered, expected, reachable;
      gather_candidates(posed, q, grid, T, th, gathered);
      for (const int i : gathered)
        if (within(i)) expected.push_back(i);
      gather_reachable(posed, q, grid, T, th, reachable);
      ASSERT_EQ(reachable, expected) << "pose " << t;
      std::vector<int> brute;
      for (int i = 0; i < static_cast<int>(q.size()); ++i)
        if (within(i)) brute.push_back(i);
      std::vector<int> sorted = reachable;
      std::sort(sorted.begin(), sorted.end());
      ASSERT_EQ(sorted, brute) << "pose " << t;
      listed += static_cast<int>(reachable.size());
    }
  }
  EXPECT_GT(listed, 100);
}

TEST(BroadPhase, ViolatedDisplacementBoundFallsBackToARebuild) {
  std::vector<Vec3d> q = random_cloud(12, 5000);
  const ToolModel tool = build_tool(ToolSpec{});
  VertexGrid grid;
  grid.rebuild(q, 0.001);
  for (Vec3d& x : q) x += Vec3d{0.004, 0.0, 0.0};  // every vertex moved 4 mm > 1 mm margin
  const int before = grid.rebuilds();
  const ToolPose pose{{0.0, 0.0, 0.0}, kPointingDown};
  std::vector<ContactTarget> fast;
  detect_contacts(tool, pose, 1.0, q, {}, grid, 400.0, fast);
  EXPECT_EQ(grid.rebuilds(), before + 1);
  std::vector<int> all(q.size());
  std::iota(all.begin(), all.end(), 0);
  std::vector<ContactPoint> brute;
  narrow_phase(pose_tool(tool, pose, 1.0), tool.projection, all, q, {}, {}, brute);
  EXPECT_EQ(fast.size(), brute.size());
  // Reported motion beyond the margin makes the grid stale before any query.
  grid.note_motion(0.0011);
  EXPECT_TRUE(grid.stale(q.size()));
}

TEST(ToolOutput, ForceAndTorqueClampAreFlagged) {
  ToolSpec spec;
  spec.torque_limit = 0.05;
  const ToolModel tool = build_tool(spec);
  const Stiffness k;  // k_vcs 300 N/m, k_vct 0.3 N m/rad
  VirtualToolState st;
  init_virtual_tool(st, 0, {{0, 0, 0.02}, quat_from_rotvec(Vec3d{0, 0, 0.3})});
  const ToolOutput big = tool_output(tool, k, {{0, 0, 0}, Quatd{}}, st);  // 6 N, 0.09 N m
  EXPECT_TRUE(big.force_clamped);
  EXPECT_NEAR(norm(big.force), 3.3, 1e-12);
  EXPECT_NEAR(big.force.z, 3.3, 1e-12);
  EXPECT_TRUE(big.torque_clamped);
  EXPECT_NEAR(norm(big.torque), 0.05, 1e-12);
  st.pose = {{0, 0, 0.005}, quat_from_rotvec(Vec3d{0, 0, 0.1})};  // 1.5 N, 0.03 N m
  const ToolOutput small = tool_output(tool, k, {{0, 0, 0}, Quatd{}}, st);
  EXPECT_FALSE(small.force_clamped);
  EXPECT_FALSE(small.torque_clamped);
  EXPECT_NEAR(small.force.z, 1.5, 1e-12);
  EXPECT_NEAR(small.torque.z, 0.03, 1e-12);
}

// The gap scene (docs/TOOLS.md): a 3 mm gap between two blocks, the 5 mm hook shaft lying across
// it, sunk 0.5 mm below the block tops and slid sideways. E_con of the fixed vertices along the
// slide is continuous with the closest-point projection; with the inverse-normal projection a
// top vertex entering through the shaft's flank is sent down through the whole shaft: E_con jumps.
TEST(Projection, ClosestPointIsContinuousInTheGapWhereInverseNormalJumps) {
  const double gap = 0.003, s = 0.0005;
  std::vector<Vec3d> q, nrm;
  for (double y = -0.010; y <= -0.002 + 1e-9; y += s) {
    for (int i = 0; i <= 24; ++i) {  // block tops, normal +z
      const double x = gap / 2 + i * s;
      for (double sx : {-1.0, 1.0}) { q.push_back({sx * x, y, 0.0}); nrm.push_back({0, 0, 1}); }
    }
    for (int i = 1; i <= 20; ++i)  // walls, normals into the gap
      for (double sx : {-1.0, 1.0}) { q.push_back({sx * gap / 2, y, -i * s}); nrm.push_back({-sx, 0, 0}); }
  }
  ToolSpec spec;
  const Quatd along_y = quat_from_rotvec(Vec3d{-std::acos(-1.0) / 2, 0, 0});  // tool +z -> world +y
  double jump[2] = {0, 0}, emax[2] = {0, 0};
  for (int mode = 0; mode < 2; ++mode) {
    const ToolModel tool = build_tool(spec, mode == 0 ? Projection::ClosestPoint : Projection::InverseNormal);
    std::vector<int> all(q.size());
    std::iota(all.begin(), all.end(), 0);
    std::vector<ContactPoint> cps;
    double prev = -1;
    for (int step = 0; step <= 400; ++step) {  // slide x from -1 mm to +1 mm by 5 um
      const ToolPose pose{{-0.001 + 5e-6 * step, 0, -0.0005}, along_y};
      narrow_phase(pose_tool(tool, pose, 1.0), tool.projection, all, q, nrm, {}, cps);
      const double e = contact_energy(cps, pose.position, 400.0, nullptr, nullptr);
      if (prev >= 0) jump[mode] = std::max(jump[mode], std::abs(e - prev));
      emax[mode] = std::max(emax[mode], e);
      prev = e;
    }
  }
  RecordProperty("closest_point_max_jump_rel", std::to_string(jump[0] / emax[0]));
  RecordProperty("inverse_normal_max_jump_rel", std::to_string(jump[1] / emax[1]));
  std::printf("gap slide: max |dE|/E_max per 5 um: closest point %.3g, inverse normal %.3g\n",
              jump[0] / emax[0], jump[1] / emax[1]);
  // A continuous E changes by at most |dE/dx| * 5 um: a few percent of E over this slide.
  EXPECT_LT(jump[0] / emax[0], 0.05);
  EXPECT_GT(jump[1] / emax[1], 3 * jump[0] / emax[0]);
}

// A spec built in code meets build_tool's own checks: a tiny value is shown as given, not as 0.000000.
TEST(ToolModel, RefusalShowsTinyValuesAsGiven) {
  ToolSpec t;
  t.max_step = -1e-30;
  try {
    (void)build_tool(t);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "tool: key 'tool.max_step': must be positive, got -1e-30");
  }
}
