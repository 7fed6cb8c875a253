// `convergence`: one physical step of the cholecystectomy scene after a velocity perturbation,
// solved by jacobi and chebyshev for K local-global iterations; the relative error
//     e(K) = ||x_K - x*|| / ||x_0 - x*||      (x_0 = the prediction s, where every method starts)
// against K and wall time, x* = the direct method run for 200 local-global iterations (the
// converged step). Every method runs the same full local-global loop: this compares what a step
// delivers, local-step error included.
// Each method runs exactly K iterations (the scene's stopping rule off). Passed when chebyshev's
// error is below jacobi's at every K >= 4 (equal iterations) and, at the paper's K (16), at most
// half of jacobi's. (A Jacobi-type method cannot reach 1e-2 in 16 iterations on a 44k-tet mesh
// whose stiffness outweighs M/h^2 ~70x; the direct method does.)
#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "mesh/box_mesh.hpp"
#include "scene/scene.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/virtual_mesh.hpp"
#include "validate/validation.hpp"

namespace ebh {
namespace {

double distance(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += squared_norm(a[i] - b[i]);
  return std::sqrt(s);
}

ValidationResult run_convergence() {
  Scene scene;
  std::string source;
  try {
    scene = load_scene(resolve_scene_path("cholecystectomy"));
    source = "scenarios/cholecystectomy.yaml";
  } catch (const InputError& e) {
    // Fallback until the scene exists: a 14 x 14 x 28 cell box (32928 tets), bottom pinned.
    scene = Scene{};
    scene.spec.file = "box (generated in code)";
    scene.physical = make_box_tets({0, 0, 0}, {0.07, 0.07, 0.14}, 14, 14, 28);
    for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i)
      if (scene.physical.vertices[i].z == 0.0) scene.pinned.push_back(i);
    source = std::string("generated box (cholecystectomy scene not loadable: ") + e.what() + ")";
  }
  const VirtualModel vm = build_virtual_model(scene);
  PhysicalModelOptions options;
  options.h = 1.0 / scene.spec.physical_hz;
  const PhysicalModel model = build_physical_model(scene, &vm, options);
  PhysicalWorkspace ws = make_physical_workspace(model);

  // Perturbation: a smooth downward velocity bump of 0.5 m/s centred on the top of the bounding
  // box (radius a quarter of its diagonal), plus gravity. The virtual mesh rests.
  Vec3d lo = model.rest[0], hi = model.rest[0];
  for (const Vec3d& x : model.rest) { lo = cwise_min(lo, x); hi = cwise_max(hi, x); }
  const Vec3d centre{(lo.x + hi.x) / 2, (lo.y + hi.y) / 2, hi.z};
  const double radius = 0.25 * norm(hi - lo);
  PhysicalState start = make_physical_state(model);
  for (int a = 0; a < model.num_vertices; ++a)
    if (!model.pinned[a])
      start.v[a] = Vec3d{0, 0, -0.5} * std::exp(-squared_norm(model.rest[a] - centre) / (radius * radius));

  PhysicalStepParams params = physical_params(scene.spec.solver, model);
  constexpr int default_k = 16;  // the paper's physical iterations
  // Exactly K iterations: the scene's stopping rule would go on past K to its tolerance, and every
  // K would return the same step.
  params.tolerance = 0;
  params.max_iterations = 0;
  params.method = SolverSpec::Method::Direct;
  params.iterations = 200;
  PhysicalState state = start;
  physical_step(model, ws, state, vm.rest, params);
  const std::vector<Vec3d> x_star = state.x;
  const double initial = distance(ws.s, x_star);

  const std::vector<int> ks = {1, 2, 4, 8, 16, 32, 64};
  Json curves = Json::object();
  bool faster_everywhere = true;
  double cheb_at_default = 1, jacobi_at_default = 1;
  std::vector<double> jacobi_err, cheb_err;  // at each K
  for (SolverSpec::Method method : {SolverSpec::Method::Jacobi, SolverSpec::Method::Chebyshev, SolverSpec::Method::Direct}) {
    Json err = Json::array(), time = Json::array(), residual = Json::array();
    for (size_t i = 0; i < ks.size(); ++i) {
      state = start;
      params.method = method;
      params.iterations = ks[i];
      const PhysicalStepReport rep = physical_step(model, ws, state, vm.rest, params);
      const double e = distance(state.x, x_star) / initial;
      err.push(e);
      time.push(rep.time_s);
      residual.push(rep.residual_reduction);
      if (method == SolverSpec::Method::Jacobi) jacobi_err.push_back(e);
      if (method == SolverSpec::Method::Chebyshev) cheb_err.push_back(e);
      if (method == SolverSpec::Method::Chebyshev && ks[i] >= 4 && !(e < jacobi_err[i])) faster_everywhere = false;
      if (ks[i] == default_k && method == SolverSpec::Method::Chebyshev) cheb_at_default = e;
      if (ks[i] == default_k && method == SolverSpec::Method::Jacobi) jacobi_at_default = e;
    }
    Json c = Json::object();
    c.set("relative_error", err);
    c.set("time_s", time);
    c.set("residual_reduction", residual);
    curves.set(method == SolverSpec::Method::Jacobi ? "jacobi" : method == SolverSpec::Method::Chebyshev ? "chebyshev" : "direct", c);
  }

  // A curve that does not fall with K measures nothing (a stopping rule that ran past K returned
  // the same step at every K): the iterative methods' errors at 64 iterations are under half of
  // theirs at 4 (ks: 1, 2, 4, ..., 64).
  const bool curves_fall = jacobi_err.back() < 0.5 * jacobi_err[2] && cheb_err.back() < 0.5 * cheb_err[2];
  ValidationResult r;
  r.name = "convergence";
  r.error = cheb_at_default;
  r.tolerance = 0.5 * jacobi_at_default;
  r.passed = faster_everywhere && curves_fall && r.error <= r.tolerance;
  r.data = Json::object();
  r.data.set("source", source);
  r.data.set("vertices", model.num_vertices);
  r.data.set("tets", model.num_tets);
  r.data.set("virtual_vertices", vm.num_vertices);
  r.data.set("h_s", model.h);
  r.data.set("chebyshev_rho", params.chebyshev_rho);
  r.data.set("relaxation", params.relaxation);
  r.data.set("reference", "direct, 200 local-global iterations");
  r.data.set("criterion", "each method runs exactly K iterations; their errors at K = 64 under half of those at K = 4; "
                          "chebyshev error < jacobi error at every K >= 4, and "
                          "chebyshev error at the paper's K (16) <= tolerance = 0.5 * jacobi error there");
  r.data.set("default_iterations", default_k);
  r.data.set("jacobi_error_at_default", jacobi_at_default);
  r.data.set("chebyshev_beats_jacobi", faster_everywhere);
  r.data.set("errors_fall_with_iterations", curves_fall);
  r.data.set("iterations", Json::array_of(ks));
  r.data.set("curves", curves);
  return r;
}

}  // namespace

Validation convergence_validation() {
  return {"convergence",
          "one physical step of cholecystectomy: jacobi/chebyshev error vs iterations and time, against the direct solve",
          [](const ValidationOptions&) { return run_convergence(); }};
}

}  // namespace ebh
