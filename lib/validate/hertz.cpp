// `hertz`: a rigid sphere pressed quasi-statically into a pinned block; the contact force against
// Hertz's F = 4/3 E* sqrt(R) delta^1.5 at indentations up to R/10.
//
// The material: ARAP with energy density k_vol ||F - R||^2 is linear elasticity with mu = k_vol,
// lambda = 0 (docs/MODEL.md), so nu = 0, E = 2 k_vol and E* = E / (1 - nu^2) = 2 k_vol. With E_det
// (k_det (J - 1)^2, energy/volume.hpp) lambda = 2 k_det: the case runs a second block at k_det =
// 3 k_vol, nu = 3/7, E = mu (3 lambda + 2 mu) / (lambda + mu) = 20/7 k_vol, E* = 4.2 k_vol.
//
// The contact: the block's boundary is the virtual mesh (no refinement: each virtual vertex is
// paired with the physical vertex it sits on), the sphere is the tool's Sphere collider held
// fixed, and a virtual vertex inside it gets the target q_proj = its closest point on the sphere
// (E_con [3], §5.1). Here the virtual mesh is solved to its static limit in closed form: with the
// contact stiffness large against the coupling, a vertex in contact sits at q_proj and the
// coupling E_svc [5] (stiffness k_svc, acting on the physical mesh) carries the contact force
// k_svc (q_proj - p) into the tissue, a penalty of stiffness k_svc. Outer iterations recompute the
// contact set and targets from the physical surface until the contact force settles; each runs
// a static physical step (h = 1e3 s: inertia ~ 1e-9 of the stiffness) with the exact global solve.
//
// Errors we accept, and why the tolerance is 15% (goal 10%): the block is finite (60 x 60 x 30 mm
// against a contact radius a = sqrt(R delta) <= 3.2 mm: finite size and the pinned bottom stiffen
// it by a few %), linear tets 0.75 mm across under the sphere are stiffer than the continuum and
// sample the contact pressure at a few dozen nodes, and Hertz itself is a small-strain theory
// (delta/R = 0.1 is its usual limit). The penalty: k_svc = 10 N/m per node against a tissue node
// stiffness of about E h = 4.5 N/m lets the tissue stay up to ~12% of delta above the sphere
// (reported as tissue_indentation_m); a stiffer penalty converges more slowly in the outer loop
// (every non-contact surface node is also held to where it was by k_svc, a drag that the loop
// relaxes by a factor of about k_svc / (k_svc + E h) per iteration).
#include <algorithm>
#include <chrono>
#include <cmath>

#include "mesh/box_mesh.hpp"
#include "scene/scene.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/virtual_mesh.hpp"
#include "tool/collider.hpp"
#include "validate/validation.hpp"

namespace ebh {
namespace {

/// Node coordinates along one axis from `lo` to `hi`: uniform cells of size `fine` within
/// `fine_half` of `centre`, growing by `growth` per cell outside it. Sorted, ends included.
std::vector<double> graded_axis(double lo, double hi, double centre, double fine, double fine_half, double growth) {
  std::vector<double> up{centre}, down;
  double h = fine, x = centre;
  while (x < hi - 1e-12) {
    x = std::min(hi, x + h);
    if (hi - x < 0.3 * h) x = hi;  // no sliver cell at the end
    up.push_back(x);
    if (x - centre >= fine_half - 1e-12) h *= growth;
  }
  h = fine;
  x = centre;
  while (x > lo + 1e-12) {
    x = std::max(lo, x - h);
    if (x - lo < 0.3 * h) x = lo;
    down.push_back(x);
    if (centre - x >= fine_half - 1e-12) h *= growth;
  }
  std::reverse(down.begin(), down.end());
  down.insert(down.end(), up.begin(), up.end());
  return down;
}

/// A block [-W, W]^2 x [-H, 0], graded fine under the origin, bottom pinned.
Scene make_block(double W, double H, double fine, double fine_half, double k_vol, double k_svc) {
  const std::vector<double> xs = graded_axis(-W, W, 0.0, fine, fine_half, 1.35);
  // z: fine just below the top face, growing downwards.
  std::vector<double> zs = graded_axis(-H, H, 0.0, fine, fine_half, 1.35);
  zs.erase(std::remove_if(zs.begin(), zs.end(), [](double z) { return z > 0; }), zs.end());
  const int nx = static_cast<int>(xs.size()) - 1, nz = static_cast<int>(zs.size()) - 1;
  Scene scene;
  scene.spec.name = "hertz";
  scene.spec.file = "hertz block (generated in code)";
  scene.spec.stiffness.k_vol = k_vol;
  scene.spec.stiffness.k_svc = k_svc;
  scene.spec.gravity = Vec3d{};
  // Kuhn-split unit cells, then each axis mapped monotonically onto the graded coordinates:
  // every cell stays a box, so its six tets stay positively oriented and conforming.
  scene.physical = make_box_tets({0, 0, 0}, {1, 1, 1}, nx, nx, nz);
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= nx; ++j)
      for (int i = 0; i <= nx; ++i) {
        const int v = i + (nx + 1) * (j + (nx + 1) * k);
        scene.physical.vertices[v] = {xs[i], xs[j], zs[k]};
        if (k == 0) scene.pinned.push_back(v);
      }
  return scene;
}

constexpr double kSphereRadius = 0.010;  // m
constexpr double kVol = 3000.0;          // Pa, k_vol: E = 6 kPa (nu = 0), soft tissue
constexpr double kSvc = 10.0;            // N/m per surface node: the contact penalty (see the top of the file)

/// One material's indentation curve: k_det = 0 (E_vol alone, nu = 0) or with E_det.
struct HertzCurve {
  Json data = Json::object();
  double worst = 0;  // the largest relative error of the curve
};

HertzCurve hertz_curve(double k_det) {
  const double R = kSphereRadius, k_vol = kVol, k_svc = kSvc;
  // Linearised: mu = k_vol, lambda = 2 k_det (energy/volume.hpp); E* = E / (1 - nu^2).
  const double mu = k_vol, lambda = 2.0 * k_det, nu = lambda / (2.0 * (lambda + mu));
  const double E_star = mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu) / (1.0 - nu * nu);
  Scene scene = make_block(0.030, 0.030, 0.00075, 0.0035, k_vol, k_svc);
  scene.spec.stiffness.k_det = k_det;
  const VirtualModel vm = build_virtual_model(scene);
  PhysicalModelOptions options;
  options.h = 1e3;
  const PhysicalModel model = build_physical_model(scene, &vm, options);
  PhysicalState state = make_physical_state(model);
  PhysicalWorkspace ws = make_physical_workspace(model);
  PhysicalStepParams params;
  params.method = SolverSpec::Method::Direct;
  params.iterations = 4;
  params.rotation_iterations = 4;

  Collider<double> sphere;
  sphere.shape = Shape::Sphere;
  sphere.radius = R;
  const int m = vm.num_vertices;
  std::vector<Vec3d> p(m), q(m);

  Json curve = Json::array();
  double worst = 0;
  const std::vector<double> fractions = {0.25, 0.5, 0.75, 1.0};  // delta / (R / 10)
  int outer_total = 0;
  constexpr int kMaxOuter = 120;
  for (double frac : fractions) {
    const double delta = frac * R / 10.0;
    sphere.a = Vec3d{0, 0, R - delta};  // the sphere's lowest point is delta below the top face
    double force = 0, previous = -1;
    int contacts = 0, outer = 0;
    for (; outer < kMaxOuter; ++outer) {
      paired_points(vm, state.x, p);
      force = 0;
      contacts = 0;
      for (int j = 0; j < m; ++j) {
        const SurfaceQuery<double> s = query_local(sphere, p[j]);
        q[j] = s.sd < 0 ? s.point : p[j];  // E_con [3]: inside -> the closest sphere point
        if (s.sd < 0) {
          ++contacts;
          force += k_svc * (p[j].z - q[j].z);  // the tissue pushes the sphere up
        }
      }
      if (previous >= 0 && std::abs(force - previous) <= 1e-4 * std::abs(force)) break;
      previous = force;
      physical_step(model, ws, state, q, params);
    }
    outer_total += outer;
    // The surface point on the axis: how deep the tissue itself is indented (the penalty lets it
    // stay a little above the sphere).
    double delta_tissue = 0;
    for (int j = 0; j < m; ++j)
      if (std::abs(vm.rest[j].x) < 1e-9 && std::abs(vm.rest[j].y) < 1e-9 && std::abs(vm.rest[j].z) < 1e-9) delta_tissue = -p[j].z;
    const double hertz = 4.0 / 3.0 * E_star * std::sqrt(R) * std::pow(delta, 1.5);
    const double err = std::abs(force - hertz) / hertz;
    worst = std::max(worst, err);
    Json point = Json::object();
    point.set("indentation_m", delta);
    point.set("force_N", force);
    point.set("hertz_N", hertz);
    point.set("relative_error", err);
    point.set("contact_nodes", contacts);
    point.set("outer_iterations", outer);
    point.set("tissue_indentation_m", delta_tissue);
    point.set("contact_radius_m", std::sqrt(R * delta));
    curve.push(point);
  }
  HertzCurve c;
  c.worst = worst;
  c.data.set("k_vol_Pa", k_vol);
  c.data.set("k_det_Pa", k_det);
  c.data.set("poisson_ratio", nu);
  c.data.set("effective_modulus_Pa", E_star);
  c.data.set("relative_error", worst);
  c.data.set("tets", model.num_tets);
  c.data.set("surface_nodes", m);
  c.data.set("outer_iterations", outer_total);
  c.data.set("curve", curve);
  return c;
}

ValidationResult run_hertz() {
  const auto t_start = std::chrono::steady_clock::now();
  ValidationResult r;
  r.name = "hertz";
  r.data = Json::object();
  r.data.set("sphere_radius_m", kSphereRadius);
  r.data.set("k_svc_N_per_m", kSvc);
  r.data.set("block_m", Json::array_of(std::vector<double>{0.060, 0.060, 0.030}));
  // E_vol alone (nu = 0), then with E_det at k_det = 3 k_vol (nu = 3/7 = 0.43, near-incompressible
  // soft tissue's range): E* = 2 k_vol and 4.2 k_vol.
  Json materials = Json::array();
  r.error = 0;
  for (const double k_det : {0.0, 3.0 * kVol}) {
    HertzCurve c = hertz_curve(k_det);
    r.error = std::max(r.error, c.worst);
    materials.push(std::move(c.data));
  }
  r.data.set("materials", materials);
  r.tolerance = 0.15;
  r.passed = r.error <= r.tolerance;
  r.data.set("wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
  return r;
}

}  // namespace

Validation hertz_validation() {
  return {"hertz",
          "rigid sphere pressed into a pinned block: force vs indentation against Hertz, E* = 2 k_vol (nu = 0) and "
          "with E_det (nu = 0.43)",
          [](const ValidationOptions&) { return run_hertz(); }};
}

}  // namespace ebh
