#pragma once
// Shared by the tool tests: random rotations, and for the contact tests' finite-difference checks,
// points inside a posed tool where E_con is smooth and the pull-back of a pose gradient through the
// rotation's parameterisation.
#include <cmath>
#include <random>
#include <vector>

#include "tool/contact.hpp"
#include "tool/tool_energy.hpp"
#include "tool/tool_model.hpp"

namespace ebh::test {

/// A rotation drawn uniformly (a normalized 4D Gaussian).
inline Quatd random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return normalized(Quatd{n(rng), n(rng), n(rng), n(rng)});
}

/// Up to `count` world points strictly inside exactly one collider of `posed`, at depth >=
/// min_depth (and, in a rounded box, < max_rounded_depth of its radius: its rounded region, away from
/// the core's medial plane), whose nearest feature does not change within 1e-5 m, so that the
/// energy is smooth in a neighbourhood larger than the finite-difference steps.
inline std::vector<Vec3d> inside_points(const PosedTool& posed, std::mt19937& rng, int count, double min_depth,
                                        double max_rounded_depth = 0.9) {
  std::vector<Vec3d> out;
  std::uniform_real_distribution<double> u(-1, 1);
  for (int tries = 0; static_cast<int>(out.size()) < count && tries < 200000; ++tries) {
    const int ci = std::uniform_int_distribution<int>(0, posed.count - 1)(rng);
    const Collider<double>& s = posed.shape[ci];
    Vec3d local = centre(s) + bounding_radius(s) * Vec3d{u(rng), u(rng), u(rng)};
    if (s.shape == Shape::Cylinder) local.z = -0.02 * (0.5 + 0.5 * u(rng));  // near the distal end, not 0.3 m up the shaft
    const SurfaceQuery<double> l = query_local(s, local);
    if (-l.sd < min_depth) continue;
    if (s.shape == Shape::Box && s.radius > 0 && -l.sd > max_rounded_depth * s.radius) continue;
    const Vec3d x = apply(posed.world[ci], local);
    int inside = 0;
    for (int j = 0; j < posed.count; ++j) inside += signed_distance_local(posed.shape[j], apply_inverse(posed.world[j], x)) < 0;
    if (inside != 1) continue;
    bool stable = true;
    for (int k = 0; k < 3 && stable; ++k) {
      Vec3d d{};
      d[k] = 1e-5;
      stable = norm(query_local(s, local + d).normal - l.normal) < 0.5 && norm(query_local(s, local - d).normal - l.normal) < 0.5;
    }
    if (stable) out.push_back(x);
  }
  return out;
}

/// E_tvc [2] + E_con [3] of `contacts` at pose p against the physical pose, with gradient and
/// Hessian (either may be null): the virtual tool's energy the finite-difference tests check.
inline double coupling_and_contact_energy(const ToolPose& p, const ToolPose& physical, const Stiffness& k,
                                          const std::vector<ContactPoint>& contacts, Vec6* g, Mat6* H) {
  Vec6 g1, g2;
  Mat6 H1, H2;
  double e = coupling_energy(p, physical, k.k_vcs, k.k_vct, g ? &g1 : nullptr, H ? &H1 : nullptr);
  e += contact_energy(contacts, p.position, k.k_con, g ? &g2 : nullptr, H ? &H2 : nullptr);
  if (g) *g = g1 + g2;
  if (H) *H = H1 + H2;
  return e;
}

/// The analytic gradient at pose(x) is taken in the parameterisation centred at pose(x); the
/// derivative of f(x) = E(pose(x)) is its pull-back through the left Jacobian of SO(3):
/// exp(x + d) = exp(J_l(x) d) exp(x), J_l(x) = I + [x]/2 + O(|x|^2), so
/// grad f(x) = (g_P, J_l(x)^T g_w) = (g_P, g_w - x_w x g_w / 2) up to O(eps^2), the order of the
/// central difference itself.
inline Vec6 pulled_back(const Vec6& x, const Vec6& g) {
  const Vec3d w{x[3], x[4], x[5]}, gw{g[3], g[4], g[5]};
  const Vec3d r = gw - 0.5 * cross(w, gw);
  Vec6 out = g;
  out[3] = r.x; out[4] = r.y; out[5] = r.z;
  return out;
}

}  // namespace ebh::test
