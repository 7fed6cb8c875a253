// The Jacobi-type methods' stopping rule (solver.physical_tolerance, physical_max_iterations):
// a step that already meets the tolerance after K iterations is the fixed-K step to the bit; one
// that does not goes on until it does or reaches the cap; the decision is the same for any thread
// count.
#include <gtest/gtest.h>

#include <cstring>

#include "box_sim.hpp"

namespace ebh {
namespace {

using test::Method;

/// A swaying start: velocities growing with height (m/s at the top).
void sway(test::Sim& sim, double top_speed, double height) {
  for (int a = 0; a < sim.pm.num_vertices; ++a)
    if (!sim.pm.pinned[a]) sim.ps.v[a] = Vec3d{top_speed, -0.5 * top_speed, -0.25 * top_speed} * (sim.pm.rest[a].z / height);
}

PhysicalStepParams chebyshev(int K, double tolerance, int max_iterations) {
  PhysicalStepParams p;
  p.method = Method::Chebyshev;
  p.iterations = K;
  p.tolerance = tolerance;
  p.max_iterations = max_iterations;
  return p;
}

TEST(StoppingRule, ContinuesOnlyPastKAndBelowTheCapWhileAboveTheTolerance) {
  // continue_iterating(k, residual, K, tolerance, max, state): after iteration k, run k + 1?
  auto rule = [](int k, double residual, int K, double tolerance, int max) {
    StoppingState state;
    return continue_iterating(k, residual, K, tolerance, max, state);
  };
  EXPECT_TRUE(rule(0, 0.0, 16, 0.01, 64));     // below K: always
  EXPECT_TRUE(rule(14, 0.0, 16, 0.0, 0));
  EXPECT_FALSE(rule(15, 1e9, 16, 0.0, 64));    // tolerance 0: exactly K
  EXPECT_FALSE(rule(15, 0.01, 16, 0.01, 64));  // at the tolerance: done
  EXPECT_TRUE(rule(15, 0.011, 16, 0.01, 64));
  EXPECT_FALSE(rule(63, 1e9, 16, 0.01, 64));   // the cap
}

TEST(StoppingRule, StopsWhenTheResidualStalls) {
  // A residual that keeps falling by 5% or more goes on; one that stops doing so for
  // kStallIterations iterations (the float32 floor, say) stops, above the tolerance.
  StoppingState state;
  double r = 1.0;
  int k = 15;
  for (; k < 15 + 20; ++k, r *= 0.9) EXPECT_TRUE(continue_iterating(k, r, 16, 1e-6, 1000, state)) << k;
  const int stalled_from = state.best_k;
  const double best = state.best;
  bool more = true;
  for (; more; ++k) more = continue_iterating(k, best * (1 + 0.01 * (k % 2)), 16, 1e-6, 1000, state);
  EXPECT_EQ(k - 1 - stalled_from, kStallIterations);
  // A growing residual (Chebyshev's first iterations past K) counts against the best before it.
  StoppingState growing;
  for (int j = 15; j < 15 + kStallIterations; ++j) EXPECT_TRUE(continue_iterating(j, 1.0 + j, 16, 1e-6, 1000, growing));
  EXPECT_FALSE(continue_iterating(15 + kStallIterations, 100.0, 16, 1e-6, 1000, growing));
}

TEST(StoppingRule, AdaptiveOnlyForJacobiTypeMethodsWithRoomPastK) {
  EXPECT_TRUE(chebyshev(16, 0.01, 64).adaptive());
  EXPECT_FALSE(chebyshev(16, 0.0, 64).adaptive());
  EXPECT_FALSE(chebyshev(16, 0.01, 16).adaptive());
  EXPECT_FALSE(chebyshev(0, 0.01, 64).adaptive());
  PhysicalStepParams direct = chebyshev(16, 0.01, 64);
  direct.method = Method::Direct;
  EXPECT_FALSE(direct.adaptive());
  // The scene's keys: the cap is raised to K when below it.
  SolverSpec spec;
  spec.physical_iterations = 100;
  spec.physical_max_iterations = 64;
  const test::Sim sim(test::box_scene(2, 2, 2));
  EXPECT_EQ(physical_params(spec, sim.pm).max_iterations, 100);
}

TEST(StoppingRule, AStepThatMeetsTheToleranceAtKIsTheFixedStepToTheBit) {
  // The box at rest but swaying gently: 16 Chebyshev iterations leave far less than 10 mesh
  // weights unbalanced, so the rule stops at K and nothing changes, not even the report.
  test::Sim fixed(test::box_scene(3, 3, 6)), adaptive(test::box_scene(3, 3, 6));
  sway(fixed, 0.01, 0.024);
  sway(adaptive, 0.01, 0.024);
  const PhysicalStepReport rf = physical_step(fixed.pm, fixed.pw, fixed.ps, fixed.q(), chebyshev(16, 0, 0));
  const PhysicalStepReport ra = physical_step(adaptive.pm, adaptive.pw, adaptive.ps, adaptive.q(), chebyshev(16, 10.0, 64));
  ASSERT_LT(rf.residual, 10.0);
  EXPECT_EQ(ra.iterations, 16);
  EXPECT_EQ(std::memcmp(fixed.ps.x.data(), adaptive.ps.x.data(), fixed.ps.x.size() * sizeof(Vec3d)), 0);
  EXPECT_EQ(std::memcmp(fixed.ps.v.data(), adaptive.ps.v.data(), fixed.ps.v.size() * sizeof(Vec3d)), 0);
  EXPECT_EQ(rf.residual, ra.residual);
  EXPECT_EQ(rf.residual_reduction, ra.residual_reduction);
}

TEST(StoppingRule, SliversIterateUntilTheToleranceAndGetCloserToTheDirectSolve) {
  const Scene scene = test::degraded_block(0.02);
  test::Sim direct(scene), fixed(scene), adaptive(scene);
  for (test::Sim* s : {&direct, &fixed, &adaptive}) sway(*s, 0.2, 0.048);
  PhysicalStepParams exact;
  exact.method = Method::Direct;
  exact.iterations = 200;
  physical_step(direct.pm, direct.pw, direct.ps, direct.q(), exact);

  const PhysicalStepReport rf = physical_step(fixed.pm, fixed.pw, fixed.ps, fixed.q(), chebyshev(16, 0, 0));
  constexpr double kTolerance = 1e-3;  // mesh weights
  const PhysicalStepReport ra =
      physical_step(adaptive.pm, adaptive.pw, adaptive.ps, adaptive.q(), chebyshev(16, kTolerance, 2000));
  ASSERT_GT(rf.residual, kTolerance);  // the sliver block's slow modes: 16 iterations are not enough
  EXPECT_GT(ra.iterations, 16) << ra.iterations;
  EXPECT_LT(ra.iterations, 2000);
  EXPECT_LE(ra.residual, kTolerance);
  const double e_fixed = test::max_diff(fixed.ps.x, direct.ps.x), e_adaptive = test::max_diff(adaptive.ps.x, direct.ps.x);
  EXPECT_LT(e_adaptive, 0.5 * e_fixed) << "fixed " << e_fixed << " m, adaptive " << e_adaptive << " m";
  EXPECT_TRUE(physical_state_problem(adaptive.pm, adaptive.ps.x, ra).empty());
}

// The device's float32 leaves a residual where nothing moves: ~1/h^2 as the mesh is refined (a
// position's round-off over an edge h, against a vertex weight ~h^3), far more where slivers are.
TEST(StoppingRule, Float32FloorGrowsWithRefinementAndSlivers) {
  auto floor_of = [](int n) {  // off the origin: a lattice at 0 rounds to float uniformly (F = I exactly)
    Scene scene = test::box_scene(n, n, 2 * n);
    scene.spec.stiffness.k_vol = 5000;
    for (Vec3d& v : scene.physical.vertices) v += Vec3d{0.0137, -0.0211, 0.0953};
    return float32_residual_floor(test::Sim(scene).pm);
  };
  const double coarse = floor_of(4), fine = floor_of(8);  // h halved: 4.7x
  EXPECT_GT(coarse, 0);
  EXPECT_TRUE(std::isfinite(fine));
  EXPECT_GT(fine / coarse, 2.5);
  EXPECT_LT(fine / coarse, 6.5);
  const double clean = float32_residual_floor(test::Sim(test::degraded_block(1)).pm);
  const double slivers = float32_residual_floor(test::Sim(test::degraded_block(0.01)).pm);
  EXPECT_GT(slivers, 10 * clean);
}

// Float32 keeps 24 bits of a coordinate: the same mesh 10 m from the origin rounds ~500 times
// coarser than at 20 mm, its floor rises above the tolerance, and the placement warning names the
// translation that brings it back (in mesh.unit); at the origin nothing is said.
TEST(StoppingRule, Float32FloorOfAMeshFarFromTheOriginIsWarned) {
  Scene scene = test::box_scene(4, 4, 8);
  scene.spec.stiffness.k_vol = 5000;
  scene.spec.unit = 0.001;
  scene.spec.unit_name = "mm";
  for (Vec3d& v : scene.physical.vertices) v += Vec3d{0.0137, -0.0211, 0.0953};
  const test::Sim near(scene);
  const double floor_near = float32_residual_floor(near.pm);
  EXPECT_LT(floor_near, scene.spec.solver.physical_tolerance);
  EXPECT_EQ(float32_placement_warning(scene.spec, near.pm, floor_near), "");
  for (Vec3d& v : scene.physical.vertices) v += Vec3d{10, 0, 0};
  const test::Sim far(scene);
  const double floor_far = float32_residual_floor(far.pm);
  EXPECT_GT(floor_far, 4 * scene.spec.solver.physical_tolerance);
  // at its centre the mesh rounds as near the origin (within the centre's own round-off)
  const BoundingBox box = bounding_box(far.pm.rest);
  EXPECT_LT(float32_residual_floor(far.pm, 0.5 * (box.lo + box.hi)), scene.spec.solver.physical_tolerance);
  const std::string w = float32_placement_warning(scene.spec, far.pm, floor_far);
  EXPECT_NE(w.find("the physical mesh's centre lies 10 m from the world's origin"), std::string::npos) << w;
  // in mesh.unit, the key's own unit (not the scene's `unit`), to 0.1 mm
  EXPECT_NE(w.find("move the mesh to the origin (mesh.transform.translate: [-10.0197, 0.0151, -0.1073], in m)"),
            std::string::npos) << w;
  SceneSpec in_mm = scene.spec;
  in_mm.mesh_unit = 0.001;
  in_mm.mesh_unit_name = "mm";
  const std::string mm = float32_placement_warning(in_mm, far.pm, floor_far);
  EXPECT_NE(mm.find("(mesh.transform.translate: [-10019.7, 15.1, -107.3], in mm)"), std::string::npos) << mm;
  EXPECT_EQ(w.find('\n'), std::string::npos);
}

// Double keeps 53 bits: a mesh about 1e6 times its size from the origin (kDoubleRoundOffShare) has
// its positions rounded coarsely enough to be named first where the CPU steps stall, with the
// translation that brings it back; 10 m away (340 times its size) it is not.
TEST(StoppingRule, DoubleRoundOffOfAMeshFarFromTheOriginIsNamed) {
  Scene scene = test::box_scene(4, 4, 8);  // 29 mm across
  for (Vec3d& v : scene.physical.vertices) v += Vec3d{10, 0, 0};
  EXPECT_EQ(double_round_off_cause(scene.spec, test::Sim(scene).pm), "");
  for (Vec3d& v : scene.physical.vertices) v += Vec3d{1e6, 0, 0};
  const std::string w = double_round_off_cause(scene.spec, test::Sim(scene).pm);
  EXPECT_NE(w.find("the physical mesh's centre lies 1e+06 m from the world's origin, 3.4e+07 times its size, where "
                   "double's round-off of its positions (1.1e-10 m) can leave what they stall at: move the mesh near the "
                   "origin (mesh.transform.translate: [-1000010.006, -0.006, -0.012], in m)"),
            std::string::npos) << w;
}

TEST(StoppingRule, StopsAtTheCap) {
  test::Sim sim(test::degraded_block(0.02));
  sway(sim, 0.2, 0.048);
  const PhysicalStepReport r = physical_step(sim.pm, sim.pw, sim.ps, sim.q(), chebyshev(16, 1e-12, 24));
  EXPECT_EQ(r.iterations, 24);
  EXPECT_GT(r.residual, 1e-12);
}

TEST(Determinism, AdaptiveStepIsBitwiseEqualWithOneAndTwoThreads) {
  const Scene scene = test::degraded_block(0.02);
  int iterations[2] = {0, 0}, run = 0;
  test::expect_bitwise_equal_across_threads([&] {
    test::Sim sim(scene);
    sway(sim, 0.2, 0.048);
    iterations[run++] = physical_step(sim.pm, sim.pw, sim.ps, sim.q(), chebyshev(16, 0.1, 2000)).iterations;
    return sim.ps.x;
  });
  EXPECT_EQ(iterations[0], iterations[1]);
  EXPECT_GT(iterations[0], 16);
}

}  // namespace
}  // namespace ebh
