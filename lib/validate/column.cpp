// `column`: a pinned ARAP column compressed by 1 %, solved to static equilibrium with the exact
// global step; the reaction force at the top against the analytic E A delta / L with E = 2 k_vol.
//
// Why it is exact: ARAP's energy density k_vol ||F - R||^2 linearises to linear elasticity with
// mu = k_vol and lambda = 0 (nu = 0, E = 2 k_vol, docs/MODEL.md). With nu = 0 a uniaxially
// compressed bar does not bulge, so clamping the top and bottom faces laterally changes nothing,
// the displacement is linear in z and linear tets reproduce it exactly; for F = diag(1, 1, 1 - e)
// (R = I) even the finite-strain stress is exactly 2 k_vol e. The remaining error is the
// local-global loop's stopping point.
#include <cmath>

#include "mesh/box_mesh.hpp"
#include "scene/scene.hpp"
#include "solver/physical_mesh.hpp"
#include "validate/validation.hpp"

namespace ebh {
namespace {

ValidationResult run_column() {
  const double W = 0.010, L = 0.040, strain = 0.01, k_vol = 3000.0;
  const int nx = 5, ny = 5, nz = 20;
  Scene scene;
  scene.spec.file = "column (generated in code)";
  scene.spec.stiffness.k_vol = k_vol;
  scene.spec.gravity = Vec3d{};
  scene.physical = make_box_tets({0, 0, 0}, {W, W, L}, nx, ny, nz);
  std::vector<int> top;
  for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i) {
    const double z = scene.physical.vertices[i].z;
    if (z == 0.0 || z == L) scene.pinned.push_back(i);
    if (z == L) top.push_back(i);
  }
  // Static equilibrium: a step of h = 1e3 s leaves M / h^2 ~ 1e-9 of the stiffness, from rest.
  PhysicalModelOptions options;
  options.h = 1e3;
  const PhysicalModel model = build_physical_model(scene, nullptr, options);
  PhysicalState state = make_physical_state(model);
  for (int i : top) state.x[i].z -= strain * L;  // the imposed compression delta = strain L
  PhysicalWorkspace ws = make_physical_workspace(model);
  PhysicalStepParams params;
  params.method = SolverSpec::Method::Direct;
  params.iterations = 30;
  params.rotation_iterations = 20;
  const PhysicalStepReport report = physical_step(model, ws, state, {}, params);

  std::vector<Vec3d> forces(model.num_vertices);
  physical_elastic_forces(model, state.x, forces);
  double reaction = 0;  // the column pushes the top face up: the sum of the elastic forces there
  for (int i : top) reaction += forces[i].z;
  const double E = 2.0 * k_vol, A = W * W;
  const double expected = E * A * strain;
  ValidationResult r;
  r.name = "column";
  r.error = std::abs(reaction - expected) / expected;
  r.tolerance = 0.05;
  r.passed = r.error <= r.tolerance;
  r.data = Json::object();
  r.data.set("size_m", Json::array_of(std::vector<double>{W, W, L}));
  r.data.set("cells", Json::array_of(std::vector<int>{nx, ny, nz}));
  r.data.set("tets", model.num_tets);
  r.data.set("k_vol_Pa", k_vol);
  r.data.set("youngs_modulus_Pa", E);
  r.data.set("strain", strain);
  r.data.set("reaction_N", reaction);
  r.data.set("expected_N", expected);
  r.data.set("local_global_iterations", report.iterations);
  r.data.set("final_relative_residual", report.residual_reduction);
  return r;
}

}  // namespace

Validation column_validation() {
  return {"column", "pinned ARAP column, 1% compression: top reaction force vs E A delta / L with E = 2 k_vol",
          [](const ValidationOptions&) { return run_column(); }};
}

}  // namespace ebh
