// The physical and virtual mesh solvers on structured boxes: pinned vertices, pairing, the
// direct solve against a dense one, monotone energy under the exact global step, convergence of
// jacobi/chebyshev to the direct answer, bitwise determinism across thread counts.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Dense>
#include <cstring>
#include <random>

#include "energy/arap.hpp"
#include "energy/edge_spring.hpp"
#include "energy/rotation.hpp"
#include "mesh/boundary.hpp"
#include "scene/scene.hpp"
#include "solver/box_mesh.hpp"
#include "solver/local_kernels.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/surface.hpp"
#include "solver/virtual_mesh.hpp"

namespace ebh {
namespace {

using Method = SolverSpec::Method;

/// A 12 x 12 x 24 mm block of tets, bottom face pinned, with virtual mesh = boundary (refine r).
Scene box_scene(int nx, int ny, int nz, int refine = 0) {
  Scene scene;
  scene.spec.file = "box (in code)";
  scene.spec.virtual_refine = refine;
  scene.physical = make_box_tets({0, 0, 0}, {0.012, 0.012, 0.024}, nx, ny, nz);
  for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i)
    if (scene.physical.vertices[i].z == 0.0) scene.pinned.push_back(i);
  return scene;
}

struct Sim {
  Scene scene;
  VirtualModel vm;
  PhysicalModel pm;
  PhysicalState ps;
  PhysicalWorkspace pw;
  explicit Sim(Scene s, bool coupled = true) : scene(std::move(s)) {
    vm = build_virtual_model(scene);
    pm = build_physical_model(scene, coupled ? &vm : nullptr, {});
    ps = make_physical_state(pm);
    pw = make_physical_workspace(pm);
  }
  /// A sideways and downward velocity field growing with height: a swaying block.
  void perturb() {
    for (int a = 0; a < pm.num_vertices; ++a)
      if (!pm.pinned[a]) ps.v[a] = Vec3d{2.0, -1.0, -0.5} * (pm.rest[a].z / 0.024);
  }
  std::span<const Vec3d> q() const { return pm.num_virtual ? std::span<const Vec3d>(vm.rest) : std::span<const Vec3d>(); }
};

double max_diff(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, norm(a[i] - b[i]));
  return d;
}

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

// ---- the SIMD kernels against the energy functions they vectorise ------------------------------

TEST(LocalKernels, TetBlocksMatchTheScalarEnergyFunctions) {
  // 3 x 3 x 5 cells = 270 tets: 33 full blocks of 8 lanes and a tail of 6.
  Sim sim(box_scene(3, 3, 5));
  const PhysicalModel& pm = sim.pm;
  ASSERT_NE(pm.num_tets % 8, 0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3d> x = pm.rest;
  for (Vec3d& p : x) p += Vec3d{0.002 * u(rng), 0.002 * u(rng), 0.002 * u(rng)};  // up to 1/2 cell: some tets may invert
  std::vector<Quatd> warm(pm.num_tets);
  for (Quatd& q : warm) q = quat_from_rotvec(Vec3d{0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng)});
  const TetKernelData tets{pm.num_tets, pm.corner_soa.data(), pm.shape_grad_soa.data(), pm.tet_weight.data()};
  for (int iterations : {1, 4, 50}) {  // the fused single-update path and the general one
    std::vector<Quatd> rot = warm;
    std::vector<Vec3d> force(4 * pm.num_tets);
    local_step_tets(tets, x.data(), rot.data(), force.data(), iterations, 1e-9);
    for (int t = 0; t < pm.num_tets; ++t) {
      const Vec3d xc[4] = {x[pm.tets[t][0]], x[pm.tets[t][1]], x[pm.tets[t][2]], x[pm.tets[t][3]]};
      const Mat3d F = deformation_gradient(xc, &pm.shape_grad[4 * t]);
      const Quatd q = extract_rotation(F, warm[t], iterations, 1e-9);
      // The same operations per lane; FMA contraction (EBH_NATIVE) may differ by ulps, which the
      // rotation update's normalisation and division amplify little: 1e-12 relative.
      EXPECT_NEAR(rot[t].w, q.w, 1e-12); EXPECT_NEAR(rot[t].x, q.x, 1e-12);
      EXPECT_NEAR(rot[t].y, q.y, 1e-12); EXPECT_NEAR(rot[t].z, q.z, 1e-12);
      const Mat3d P = pm.tet_weight[t] * (to_matrix(q) - F);
      for (int c = 0; c < 4; ++c) {
        const Vec3d f = P * pm.shape_grad[4 * t + c];
        const double scale = 1e-12 * (1.0 + norm(f));
        EXPECT_NEAR(force[4 * t + c].x, f.x, scale) << "tet " << t << " corner " << c << " iterations " << iterations;
        EXPECT_NEAR(force[4 * t + c].y, f.y, scale);
        EXPECT_NEAR(force[4 * t + c].z, f.z, scale);
      }
    }
  }
}

TEST(LocalKernels, EdgeBlocksMatchTheScalarEnergyFunctionIncludingCollapsedEdges) {
  Sim sim(box_scene(3, 3, 6, 1));
  const VirtualModel& vm = sim.vm;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3d> q = vm.rest;
  for (Vec3d& p : q) p += Vec3d{0.001 * u(rng), 0.001 * u(rng), 0.001 * u(rng)};
  q[vm.edges[5][1]] = q[vm.edges[5][0]];  // a collapsed edge: R e0 = e0
  const EdgeKernelData edges{static_cast<int>(vm.edges.size()), vm.edges.data(), vm.rest_edge.data(),
                             vm.rest_len.data(), vm.k_s};
  std::vector<Vec3d> g(vm.edges.size());
  edge_spring_gradients(edges, q.data(), g.data());
  for (size_t e = 0; e < vm.edges.size(); ++e) {
    const Vec3d expect = edge_spring_gradient(q[vm.edges[e][0]], q[vm.edges[e][1]], vm.rest_edge[e], vm.k_s);
    EXPECT_LT(norm(g[e] - expect), 1e-12 * (1.0 + norm(expect))) << "edge " << e;  // ulps (FMA)
  }
  EXPECT_LT(norm(g[5] + vm.k_s * vm.rest_edge[5]), 1e-15);  // collapsed: k_s (0 - e0)
}

template <class Run>
void expect_bitwise_equal_across_threads(Run run) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const std::vector<Vec3d> one = run();
  omp_set_num_threads(2);
  const std::vector<Vec3d> two = run();
  omp_set_num_threads(saved);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(Vec3d)), 0);
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

/// Five virtual-mesh ticks (4 iterations each) of a box under contact; parallel_min_vertices = 0
/// puts even this small mesh on the OpenMP team instead of the calling thread.
std::vector<Vec3d> five_virtual_ticks(int parallel_min_vertices) {
  Sim sim(box_scene(4, 4, 8, 1));
  if (parallel_min_vertices >= 0) sim.vm.parallel_min_vertices = parallel_min_vertices;
  VirtualState vs = make_virtual_state(sim.vm);
  VirtualWorkspace vw = make_virtual_workspace(sim.vm);
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

}  // namespace
}  // namespace ebh
