// The solvers' SIMD loops (solver/local_kernels.hpp) against the energy functions they vectorise.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "energy/arap.hpp"
#include "energy/edge_spring.hpp"
#include "energy/rotation.hpp"
#include "solver/local_kernels.hpp"

#include "box_sim.hpp"

namespace ebh {
namespace {

using namespace ebh::test;

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
  const TetKernelData tets{pm.num_tets, pm.corner_soa.data(), pm.shape_grad_soa.data(), pm.weight_soa.data()};
  for (int iterations : {1, 4, 50}) {  // the fused single-update path and the general one
    std::vector<Quatd> rot = warm;  // by slot
    std::vector<Vec3d> force(4 * pm.num_tets);
    std::vector<Vec3d> x_local(x.size());  // the kernel reads positions by local index
    for (size_t i = 0; i < x.size(); ++i) x_local[i] = x[pm.vertex_order[i]];
    local_step_tets(tets, x_local.data(), rot.data(), force.data(), iterations, 1e-9);
    for (int t = 0; t < pm.num_tets; ++t) {
      const int s = pm.tet_slot[t];
      const Vec3d xc[4] = {x[pm.tets[t][0]], x[pm.tets[t][1]], x[pm.tets[t][2]], x[pm.tets[t][3]]};
      const Mat3d F = deformation_gradient(xc, &pm.shape_grad[4 * t]);
      const Quatd q = extract_rotation(F, warm[s], iterations, 1e-9);
      // The same operations per lane; FMA contraction (EBH_NATIVE) may differ by ulps, which the
      // rotation update's normalisation and division amplify little: 1e-12 relative.
      EXPECT_NEAR(rot[s].w, q.w, 1e-12); EXPECT_NEAR(rot[s].x, q.x, 1e-12);
      EXPECT_NEAR(rot[s].y, q.y, 1e-12); EXPECT_NEAR(rot[s].z, q.z, 1e-12);
      const Mat3d P = pm.tet_weight[t] * (to_matrix(q) - F);
      for (int c = 0; c < 4; ++c) {
        const Vec3d f = P * pm.shape_grad[4 * t + c];
        const double scale = 1e-12 * (1.0 + norm(f));
        EXPECT_NEAR(force[4 * s + c].x, f.x, scale) << "tet " << t << " corner " << c << " iterations " << iterations;
        EXPECT_NEAR(force[4 * s + c].y, f.y, scale);
        EXPECT_NEAR(force[4 * s + c].z, f.z, scale);
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

TEST(LocalKernels, ListedEdgesGetTheBitsOfTheWholePass) {
  // edge_spring_gradients_listed (the active region) takes a group of 8 consecutive listed edges
  // through the whole pass's block and the others one at a time: every listed edge must get the
  // bits the whole pass gives it, for a sorted list of runs and gaps, one edge at a time, and an
  // unsorted one; the collapsed edge 5 inside a run and alone.
  Sim sim(box_scene(3, 3, 6, 1));
  const VirtualModel& vm = sim.vm;
  const int E = static_cast<int>(vm.edges.size());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3d> q = vm.rest;
  for (Vec3d& p : q) p += Vec3d{0.001 * u(rng), 0.001 * u(rng), 0.001 * u(rng)};
  q[vm.edges[5][1]] = q[vm.edges[5][0]];
  const EdgeKernelData edges{E, vm.edges.data(), vm.rest_edge.data(), vm.rest_len.data(), vm.k_s};
  std::vector<Vec3d> whole(vm.edges.size());
  edge_spring_gradients(edges, q.data(), whole.data());
  std::vector<int> runs, single = {5}, shuffled;
  for (int e = 0; e < E; ++e)
    if (e % 29 < 19 && e != 40) runs.push_back(e);  // runs of 19 (from 0: edge 5 inside one) and gaps
  for (int e = 0; e < E; e += 3) shuffled.push_back(e);
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  for (const std::vector<int>* ids : {&runs, &single, &shuffled}) {
    std::vector<Vec3d> g(vm.edges.size(), Vec3d{7, 7, 7});
    edge_spring_gradients_listed(edges, ids->data(), static_cast<int>(ids->size()), q.data(), g.data());
    for (const int e : *ids) EXPECT_EQ(std::memcmp(&g[e], &whole[e], sizeof(Vec3d)), 0) << "edge " << e << " of a list of " << ids->size();
    std::vector<char> listed(vm.edges.size(), 0);
    for (const int e : *ids) listed[e] = 1;
    for (int e = 0; e < E; ++e) {
      if (!listed[e]) {
        EXPECT_EQ(g[e], (Vec3d{7, 7, 7})) << "edge " << e << " is not listed";
      }
    }
  }
}

}  // namespace
}  // namespace ebh
