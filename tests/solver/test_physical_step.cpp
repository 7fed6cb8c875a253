// The physical mesh's step on structured boxes: pinned vertices, the direct solve against a
// dense one, monotone energy under the exact global step, convergence of jacobi/chebyshev to the
// direct answer, bitwise determinism across thread counts.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <numeric>
#include <random>

#include "box_sim.hpp"
#include "solver/local_kernels.hpp"

namespace ebh {
namespace {

using namespace ebh::test;

TEST(PhysicalStep, PinnedVerticesNeverMove) {
  for (Method method : {Method::Jacobi, Method::Chebyshev, Method::Direct}) {
    Sim sim(box_scene(3, 3, 6));
    sim.perturb();
    PhysicalStepParams params;
    params.method = method;
    for (int step = 0; step < 5; ++step) physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);
    for (int a : sim.scene.pinned) {
      EXPECT_EQ(sim.ps.x[a], sim.pm.rest[a]);
      EXPECT_EQ(sim.ps.v[a], Vec3d{});
    }
    EXPECT_GT(max_diff(sim.ps.x, sim.pm.rest), 1e-5);  // and the rest did move (16 iterations of 5 steps)
  }
}

TEST(PhysicalStep, DirectGlobalSolveMatchesDenseSolve) {
  Sim sim(box_scene(2, 2, 3));
  sim.perturb();
  const PhysicalState start = sim.ps;
  PhysicalStepParams params;
  params.method = Method::Direct;
  params.iterations = 1;
  params.rotation_iterations = 500;  // R converged to the SVD polar (the dense reference uses SVD)
  physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);

  // Dense A over free vertices, assembled independently from the energies' definitions.
  const PhysicalModel& pm = sim.pm;
  const int nf = pm.num_free;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(nf, nf);
  for (int a = 0; a < pm.num_vertices; ++a)
    if (!pm.pinned[a]) A(pm.free_index[a], pm.free_index[a]) += pm.mass[a] / (pm.h * pm.h);
  for (int t = 0; t < pm.num_tets; ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const int fa = pm.free_index[pm.tets[t][i]], fb = pm.free_index[pm.tets[t][j]];
        if (fa >= 0 && fb >= 0) A(fa, fb) += pm.tet_weight[t] * dot(pm.shape_grad[4 * t + i], pm.shape_grad[4 * t + j]);
      }
  for (int j = 0; j < pm.num_virtual; ++j)
    for (int i = 0; i < pm.pair_count[j]; ++i)
      for (int k = 0; k < pm.pair_count[j]; ++k) {
        const int fa = pm.free_index[pm.pair_vertex[j][i]], fb = pm.free_index[pm.pair_vertex[j][k]];
        if (fa >= 0 && fb >= 0) A(fa, fb) += pm.k_svc * pm.pair_weight[j][i] * pm.pair_weight[j][k];
      }
  // r = -grad E_soft at the iterations' start x_0 = x + h v: -grad(E_vol + E_svc) at x_0 plus the
  // inertia term M/h^2 (s - x_0) = M g, with s = x_0 + h^2 g the prediction.
  std::vector<Vec3d> x0(pm.num_vertices), f(pm.num_vertices);
  for (int a = 0; a < pm.num_vertices; ++a) x0[a] = pm.pinned[a] ? start.x[a] : start.x[a] + pm.h * start.v[a];
  physical_elastic_forces(pm, x0, f);
  for (int a = 0; a < pm.num_vertices; ++a)
    if (!pm.pinned[a]) f[a] += pm.mass[a] * pm.gravity;
  for (int j = 0; j < pm.num_virtual; ++j) {
    Vec3d p{};
    for (int i = 0; i < pm.pair_count[j]; ++i) p += pm.pair_weight[j][i] * x0[pm.pair_vertex[j][i]];
    for (int i = 0; i < pm.pair_count[j]; ++i) f[pm.pair_vertex[j][i]] += pm.k_svc * pm.pair_weight[j][i] * (sim.vm.rest[j] - p);
  }
  Eigen::MatrixXd r(nf, 3);
  for (int i = 0; i < nf; ++i) r.row(i) << f[pm.free_vertices[i]].x, f[pm.free_vertices[i]].y, f[pm.free_vertices[i]].z;
  const Eigen::MatrixXd dx = A.ldlt().solve(r);
  double err = 0, size = 0;
  for (int i = 0; i < nf; ++i) {
    const Vec3d expect = x0[pm.free_vertices[i]] + Vec3d{dx(i, 0), dx(i, 1), dx(i, 2)};
    err = std::max(err, norm(sim.ps.x[pm.free_vertices[i]] - expect));
    size = std::max(size, std::sqrt(dx.row(i).squaredNorm()));
  }
  // Sparse LDLT vs dense LDLT of the same SPD matrix (condition ~1e3): agreement to ~1e-12 of the step.
  EXPECT_LT(err, 1e-9 * size);
}

TEST(PhysicalStep, EnergyNeverIncreasesUnderTheExactGlobalStep) {
  Sim sim(box_scene(3, 3, 6));
  sim.perturb();
  for (int a = 0; a < sim.pm.num_vertices; ++a) sim.ps.v[a] = 10.0 * sim.ps.v[a];  // large deformation
  const PhysicalState start = sim.ps;
  PhysicalStepParams params;
  params.method = Method::Direct;
  params.rotation_iterations = 500;  // the exact local step
  double previous = std::numeric_limits<double>::infinity();
  for (int k = 1; k <= 10; ++k) {
    sim.ps = start;
    params.iterations = k;
    physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);
    const double E = physical_energy(sim.pm, sim.ps.x, sim.pw.s, sim.q()).total();
    // Local-global is monotone: each local and each exact global step minimises E over its
    // variables. Slack: round-off of E's sum over ~1000 terms.
    EXPECT_LE(E, previous * (1 + 1e-12)) << "iterations " << k;
    previous = E;
  }
}

TEST(PhysicalStep, JacobiAndChebyshevConvergeToTheDirectResult) {
  Sim sim(box_scene(2, 2, 4));
  sim.perturb();
  const PhysicalState start = sim.ps;
  PhysicalStepParams params;
  params.method = Method::Direct;
  params.iterations = 100;
  physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);
  const std::vector<Vec3d> x_star = sim.ps.x;
  const double travel = max_diff(x_star, start.x);
  for (Method method : {Method::Jacobi, Method::Chebyshev}) {
    sim.ps = start;
    params.method = method;
    params.iterations = 1500;
    const PhysicalStepReport rep = physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);
    // Both are fixed-point iterations of the same stationarity condition; 1500 iterations take
    // their linear convergence to round-off on this 96-tet block. The reference itself stops after
    // 100 direct iterations with rotations converged to 1e-9 rad: agreement to 1e-7 of the travel.
    EXPECT_LT(max_diff(sim.ps.x, x_star), 1e-7 * travel) << "method " << int(method);
    EXPECT_LT(rep.residual_reduction, 1e-6);
  }
}

// A step asked to stop (a run that ended or was interrupted while it ran) stops at its next poll,
// with report.cancelled; one never asked runs to the bits of a step without the question.
TEST(PhysicalStep, ACancelledStepStopsAtItsNextPoll) {
  for (Method method : {Method::Jacobi, Method::Chebyshev, Method::Direct}) {
    Sim sim(box_scene(1, 1, 2));
    sim.perturb();
    const PhysicalState start = sim.ps;
    PhysicalStepParams params;
    params.method = method;
    params.iterations = 3 * kCancelPollIterations;
    int asked = 0;
    const PhysicalStepReport stopped = physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params, nullptr, nullptr,
                                                     nullptr, [&asked] { return ++asked == 2; });
    EXPECT_TRUE(stopped.cancelled);
    EXPECT_EQ(stopped.iterations, 2 * kCancelPollIterations) << int(method);  // asked at 64, stopped at 128
    sim.ps = start;
    const PhysicalStepReport ran = physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params, nullptr, nullptr, nullptr,
                                                 [] { return false; });
    const std::vector<Vec3d> x = sim.ps.x;
    sim.ps = start;
    physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);
    EXPECT_FALSE(ran.cancelled);
    EXPECT_EQ(ran.iterations, 3 * kCancelPollIterations);
    EXPECT_EQ(max_diff(x, sim.ps.x), 0.0);
  }
}

TEST(Determinism, PhysicalStepIsBitwiseEqualWithOneAndTwoThreads) {
  for (Method method : {Method::Jacobi, Method::Chebyshev, Method::Direct}) {
    expect_bitwise_equal_across_threads([&] {
      Sim sim(box_scene(4, 4, 8, 1));
      sim.perturb();
      PhysicalStepParams params;
      params.method = method;
      for (int step = 0; step < 3; ++step) physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params);
      std::vector<Vec3d> out = sim.ps.x;
      out.insert(out.end(), sim.ps.v.begin(), sim.ps.v.end());
      return out;
    });
  }
}

// The step run on one thread with its loops shared with a helping thread (SharedLoops, as the async
// replay's waiting haptic thread helps) gives the bits of the OpenMP step on one thread (and so on
// two: the test above).
TEST(Determinism, PhysicalStepWithAHelperIsBitwiseThatOfTheOpenMpStep) {
  for (Method method : {Method::Jacobi, Method::Chebyshev, Method::Direct}) {
    SCOPED_TRACE(static_cast<int>(method));
    expect_bitwise_equal_with_a_helper([&](SharedLoops* shared) {
      Sim sim(box_scene(6, 6, 12, 1));  // 2160 tets: 9 chunks of SIMD blocks a local step
      sim.perturb();
      PhysicalStepParams params;
      params.method = method;
      params.tolerance = method == Method::Direct ? 0 : 1e-6;  // the stopping rule's decisions too
      params.max_iterations = 40;
      for (int step = 0; step < 3; ++step) physical_step(sim.pm, sim.pw, sim.ps, sim.q(), params, nullptr, shared);
      std::vector<Vec3d> out = sim.ps.x;
      out.insert(out.end(), sim.ps.v.begin(), sim.ps.v.end());
      return out;
    });
  }
}

// The CPU step's local order (PhysicalModel::tet_slot, vertex_order, local) changes where the step reads
// and writes, not what it computes: on a block whose vertices and tets are numbered at random (as
// a mesher's output can be), the step gives the bits of the file's order for every method, with
// E_det, and with several rotation updates per local step; the rotations agree tet by tet.
TEST(Determinism, LocalOrderGivesTheBitsOfTheFileOrder) {
  Scene scene = box_scene(5, 5, 9, 1);
  std::mt19937 rng(11);
  const int n = static_cast<int>(scene.physical.vertices.size());
  std::vector<int> renumber(n);
  std::iota(renumber.begin(), renumber.end(), 0);
  std::shuffle(renumber.begin(), renumber.end(), rng);
  std::vector<Vec3d> vertices(n);
  for (int a = 0; a < n; ++a) vertices[renumber[a]] = scene.physical.vertices[a];
  scene.physical.vertices = vertices;
  for (Tet& t : scene.physical.tets)
    for (int& a : t) a = renumber[a];
  for (int& a : scene.pinned) a = renumber[a];
  std::shuffle(scene.physical.tets.begin(), scene.physical.tets.end(), rng);
  const VirtualModel vm = build_virtual_model(scene);
  for (const double k_det : {0.0, 3 * scene.spec.stiffness.k_vol})
    for (const Method method : {Method::Jacobi, Method::Chebyshev, Method::Direct})
      for (const int rotation_iterations : {1, 3}) {
        SCOPED_TRACE(::testing::Message() << "k_det " << k_det << " method " << static_cast<int>(method)
                                          << " rotation updates " << rotation_iterations);
        scene.spec.stiffness.k_det = k_det;
        PhysicalModelOptions options;
        options.local_order = false;
        const PhysicalModel file = build_physical_model(scene, &vm, options);
        options.local_order = true;
        const PhysicalModel local = build_physical_model(scene, &vm, options);
        ASSERT_NE(file.num_tets % kTetLanes, 0);  // a partial SIMD block, which keeps its tets
        int moved = 0;
        for (int t = 0; t < local.num_tets; ++t) {
          moved += local.tet_slot[t] != t;
          if (t >= local.num_tets - local.num_tets % kTetLanes) { EXPECT_EQ(local.tet_slot[t], t); }
        }
        EXPECT_GT(moved, local.num_tets / 2);
        int renumbered = 0;  // the step's own vertex numbering
        for (int i = 0; i < n; ++i) renumbered += local.vertex_order[i] != i;
        EXPECT_GT(renumbered, n / 2);
        PhysicalStepParams params;
        params.method = method;
        params.rotation_iterations = rotation_iterations;
        params.tolerance = method == Method::Direct ? 0 : 1e-6;
        params.max_iterations = 30;
        std::vector<PhysicalState> out;
        for (const PhysicalModel* pm : {&file, &local}) {
          PhysicalState ps = make_physical_state(*pm);
          for (int a = 0; a < pm->num_vertices; ++a)
            if (!pm->pinned[a]) ps.v[a] = Vec3d{2.0, -1.0, -0.5} * (pm->rest[a].z / 0.024);
          PhysicalWorkspace pw = make_physical_workspace(*pm);
          for (int step = 0; step < 3; ++step) physical_step(*pm, pw, ps, vm.rest, params);
          out.push_back(ps);
        }
        EXPECT_EQ(std::memcmp(out[0].x.data(), out[1].x.data(), n * sizeof(Vec3d)), 0);
        EXPECT_EQ(std::memcmp(out[0].v.data(), out[1].v.data(), n * sizeof(Vec3d)), 0);
        int rotations_differ = 0;
        for (int t = 0; t < local.num_tets; ++t)
          rotations_differ += std::memcmp(&out[0].rotation[t], &out[1].rotation[local.tet_slot[t]], sizeof(Quatd)) != 0;
        EXPECT_EQ(rotations_differ, 0);
      }
}

// E_det (stiffness.k_det, energy/volume.hpp): a box with every boundary vertex held on the affine
// field x = F X, F = diag(1, 1, 1 - e), relaxes to that field (any homogeneous energy's
// equilibrium; linear tets hold it exactly), and the top face then carries the confined
// compression stress 2 (k_vol + k_det) e (P = 2 k_vol (F - R) + 2 k_det (J - 1) cof F with R = I,
// J = 1 - e, cof F = diag(1 - e, 1 - e, 1): exact at finite strain). Every method gets there,
// the iterative ones stably with k_det = 10 k_vol (nu = 0.48).
TEST(PhysicalStep, VolumeStiffnessGivesTheConfinedCompressionStress) {
  const double W = 0.012, L = 0.024, e = 0.05, k_vol = 3000, k_det = 30000;
  for (Method method : {Method::Direct, Method::Jacobi, Method::Chebyshev}) {
    SCOPED_TRACE(static_cast<int>(method));
    Scene scene;
    scene.spec.file = "box (in code)";
    scene.spec.gravity = Vec3d{};
    scene.spec.stiffness.k_vol = k_vol;
    scene.spec.stiffness.k_det = k_det;
    scene.physical = make_box_tets({0, 0, 0}, {W, W, L}, 3, 3, 6);
    std::vector<int> top;
    for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i) {
      const Vec3d& X = scene.physical.vertices[i];
      const auto at = [](double a, double b) { return std::abs(a - b) < 1e-9; };
      if (at(X.x, 0) || at(X.x, W) || at(X.y, 0) || at(X.y, W) || at(X.z, 0) || at(X.z, L)) scene.pinned.push_back(i);
      if (at(X.z, L)) top.push_back(i);
    }
    PhysicalModelOptions options;
    options.h = 1e3;  // static: M / h^2 ~ 1e-9 of the stiffness
    const PhysicalModel pm = build_physical_model(scene, nullptr, options);
    PhysicalState ps = make_physical_state(pm);
    for (int a : scene.pinned) ps.x[a].z *= 1 - e;
    PhysicalWorkspace pw = make_physical_workspace(pm);
    PhysicalStepParams params;
    params.method = method;
    params.iterations = 400;
    params.rotation_iterations = 4;
    for (int step = 0; step < 5; ++step) {
      physical_step(pm, pw, ps, {}, params);
      ps.v.assign(pm.num_vertices, Vec3d{});  // quasi-static: each step from rest
    }
    // Tolerances: 5 static steps of 400 iterations leave the residual at ~1e-11 mesh weights (round-off),
    // so the positions sit on the affine field to ~1e-12 m of a 24 mm box and the stress to ~1e-10
    // relative; 1e-9 m and 1e-6 leave room for other compilers' rounding, far below what a wrong
    // weight or force (a few % of e L = 1.2 mm) would give.
    for (int a = 0; a < pm.num_vertices; ++a) {
      const Vec3d affine{pm.rest[a].x, pm.rest[a].y, pm.rest[a].z * (1 - e)};
      EXPECT_LT(norm(ps.x[a] - affine), 1e-9) << a;
    }
    std::vector<Vec3d> f(pm.num_vertices);
    physical_elastic_forces(pm, ps.x, f);
    double reaction = 0;
    for (int a : top) reaction += f[a].z;
    EXPECT_NEAR(reaction, 2 * (k_vol + k_det) * e * W * W, 1e-6 * 2 * (k_vol + k_det) * e * W * W);
  }
}

}  // namespace
}  // namespace ebh
