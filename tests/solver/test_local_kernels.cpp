// The solvers' SIMD loops (solver/local_kernels.hpp) against the energy functions they vectorise.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace ebh
