// The physical mesh with tets of several stiffnesses (stiffness.regions, Scene::tet_k_vol): the
// elastic forces are the energy's gradient with each tet's own k_vol (and E_det's in proportion),
// and a column of two layers under compression gives the series springs' reaction exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "box_sim.hpp"
#include "energy/finite_difference.hpp"

namespace ebh {
namespace {

using test::Method;

TEST(StiffnessRegions, ElasticForcesAreMinusTheEnergysGradientWithEachTetsStiffness) {
  Scene scene = test::box_scene(2, 2, 3);
  scene.spec.stiffness.k_vol = 3000;
  scene.spec.stiffness.k_det = 9000;  // kept at 3 k_vol in every tet: E_det is 27000 Pa in the stiff ones
  scene.tet_k_vol.assign(scene.physical.tets.size(), 3000);
  for (std::size_t t = 0; t < scene.tet_k_vol.size(); t += 3) scene.tet_k_vol[t] = 30000;
  PhysicalModelOptions options;
  options.h = 0.01;
  const PhysicalModel pm = build_physical_model(scene, nullptr, options);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> d(-0.001, 0.001);  // up to 1 mm on 4-6 mm tets
  std::vector<Vec3d> x = pm.rest;
  for (Vec3d& p : x) p += Vec3d{d(rng), d(rng), d(rng)};
  std::vector<Vec3d> f(pm.num_vertices);
  physical_elastic_forces(pm, x, f);
  std::vector<double> flat(3 * x.size());
  for (std::size_t a = 0; a < x.size(); ++a) std::tie(flat[3 * a], flat[3 * a + 1], flat[3 * a + 2]) = std::tuple(x[a].x, x[a].y, x[a].z);
  const auto energy = [&](const std::vector<double>& v) {
    std::vector<Vec3d> y(x.size());
    for (std::size_t a = 0; a < y.size(); ++a) y[a] = Vec3d{v[3 * a], v[3 * a + 1], v[3 * a + 2]};
    return physical_energy(pm, y, {}, {}).volume;
  };
  const std::vector<double> g = fd_gradient(energy, flat, 1e-7);
  double worst = 0, scale = 0;
  for (std::size_t a = 0; a < x.size(); ++a)
    for (int k = 0; k < 3; ++k) {
      const double fk = k == 0 ? f[a].x : k == 1 ? f[a].y : f[a].z;
      worst = std::max(worst, std::abs(fk + g[3 * a + static_cast<std::size_t>(k)]));
      scale = std::max(scale, std::abs(fk));
    }
  // Central differences with a 1e-7 m step on energies of ~1e-4 J: truncation ~1e-10 of the force,
  // round-off ~1e-16 / 1e-7 = 1e-9 relative; a tet with the scene's k_vol in place of its own would
  // be off by 90% of its share.
  EXPECT_LT(worst, 1e-6 * scale);
  // And the weights: w_t = 2 k_vol_t V_t.
  for (int t = 0; t < pm.num_tets; ++t) EXPECT_EQ(pm.tet_weight[t], 2 * scene.tet_k_vol[t] * pm.volume[t]);
}

TEST(StiffnessRegions, TwoLayersUnderCompressionAreSpringsInSeries) {
  // A column of a soft bottom half (k_vol 3000) and a stiff top half (12000), top and bottom faces
  // pinned, the top pushed down by delta. ARAP is linear elasticity with E = 2 k_vol and nu = 0
  // (docs/MODEL.md; the `column` validation): no lateral strain, a uniform stress along the column,
  // the strain of each layer in proportion to its compliance, linear in z within each layer, which
  // linear tets with the interface on a layer of vertices reproduce exactly. The reaction is
  // A delta / (L1 / E1 + L2 / E2).
  const double W = 0.010, L = 0.040, strain = 0.01, k1 = 3000, k2 = 12000;
  Scene scene;
  scene.spec.file = "two layers (in code)";
  scene.spec.gravity = Vec3d{};
  scene.spec.stiffness.k_vol = k1;
  scene.physical = make_box_tets({0, 0, 0}, {W, W, L}, 4, 4, 16);
  std::vector<int> top;
  for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i) {
    const double z = scene.physical.vertices[i].z;
    if (z == 0.0 || z == L) scene.pinned.push_back(i);
    if (z == L) top.push_back(i);
  }
  scene.tet_k_vol.resize(scene.physical.tets.size());
  for (std::size_t t = 0; t < scene.physical.tets.size(); ++t) {
    const Tet& e = scene.physical.tets[t];
    const double zc = 0.25 * (scene.physical.vertices[e[0]].z + scene.physical.vertices[e[1]].z +
                              scene.physical.vertices[e[2]].z + scene.physical.vertices[e[3]].z);
    scene.tet_k_vol[t] = zc < L / 2 ? k1 : k2;
  }
  PhysicalModelOptions options;
  options.h = 1e3;  // static: M / h^2 ~ 1e-9 of the stiffness
  const PhysicalModel pm = build_physical_model(scene, nullptr, options);
  PhysicalState ps = make_physical_state(pm);
  for (int i : top) ps.x[i].z -= strain * L;
  PhysicalWorkspace pw = make_physical_workspace(pm);
  PhysicalStepParams params;
  params.method = Method::Direct;
  params.iterations = 40;
  params.rotation_iterations = 20;
  physical_step(pm, pw, ps, {}, params);
  std::vector<Vec3d> f(pm.num_vertices);
  physical_elastic_forces(pm, ps.x, f);
  double reaction = 0;
  for (int i : top) reaction += f[i].z;
  const double A = W * W, delta = strain * L;
  const double expected = A * delta / ((L / 2) / (2 * k1) + (L / 2) / (2 * k2));
  // 1% strain: the finite-strain stress of the uniaxial field is exact (F = diag(1, 1, 1 - e), R = I),
  // so what is left is the local-global loop's stopping point; 1e-4 leaves it room while a layer at
  // the other's stiffness would be 60% off (and the uniform soft column 37.5%).
  EXPECT_NEAR(reaction, expected, 1e-4 * expected);
  // The interface sits where the compliances put it: the soft half takes 4/5 of delta.
  for (int a = 0; a < pm.num_vertices; ++a)
    if (std::abs(pm.rest[a].z - L / 2) < 1e-12) {
      EXPECT_NEAR(L / 2 - ps.x[a].z, 0.8 * delta, 1e-4 * delta) << a;
    }
}

TEST(StiffnessRegions, ARegionOverTheWholeMeshIsTheUniformStiffness) {
  Scene a = test::box_scene(2, 2, 3), b = a;
  a.spec.stiffness.k_vol = 6000;
  b.spec.stiffness.k_vol = 3000;
  b.tet_k_vol.assign(b.physical.tets.size(), 6000);
  PhysicalModelOptions options;
  options.h = 0.01;
  EXPECT_EQ(build_physical_model(a, nullptr, options).tet_weight, build_physical_model(b, nullptr, options).tet_weight);
}

}  // namespace
}  // namespace ebh
