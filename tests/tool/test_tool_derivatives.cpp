// Finite-difference checks of the virtual tool's energy E_tool = E_tvc [2] + E_con [3] (+ grasp):
// the analytic gradient against central differences of the ENERGY (contacts re-detected at every
// perturbed pose), and the exact Hessian against central differences of the analytic gradient.
#include <gtest/gtest.h>

#include <numeric>
#include <random>

#include "contact_points.hpp"
#include "tool/contact.hpp"
#include "tool/tool_energy.hpp"
#include "tool/tool_model.hpp"

using namespace ebh;

namespace {

struct Case {
  ToolModel tool;
  double jaw = 0.6;
  ToolPose pose, physical;
  std::vector<Vec3d> q, normals;
  Stiffness k;
};

// E_tool at pose(x) with contacts detected by brute force over every vertex.
double energy(const Case& c, const Vec6& x, Vec6* g, Mat6* H) {
  const ToolPose p = perturb(c.pose, x);
  const PosedTool posed = pose_tool(c.tool, p, c.jaw);
  std::vector<int> all(c.q.size());
  std::iota(all.begin(), all.end(), 0);
  std::vector<ContactPoint> contacts;
  narrow_phase(posed, c.tool.projection, all, c.q, c.normals, {}, contacts);
  return test::coupling_and_contact_energy(p, c.physical, c.k, contacts, g, H);
}

// Vertices where the energy is smooth (contact_points.hpp).
void add_inside_vertices(Case& c, std::mt19937& rng, int count, double min_depth) {
  for (const Vec3d& x : test::inside_points(pose_tool(c.tool, c.pose, c.jaw), rng, count, min_depth)) c.q.push_back(x);
}

void expect_gradient_matches(const Case& c, double rel_tol) {
  Vec6 g;
  energy(c, Vec6::Zero(), &g, nullptr);
  // eps = 1e-7 m / rad: truncation O(eps^2 E''') stays below 1e-6 relative for curvature radii
  // down to 1e-5 m, round-off O(1e-16 E / eps) is negligible.
  const double eps = 1e-7;
  Vec6 fd;
  for (int i = 0; i < 6; ++i) {
    Vec6 x = Vec6::Zero();
    x[i] = eps;
    const double ep = energy(c, x, nullptr, nullptr);
    x[i] = -eps;
    fd[i] = (ep - energy(c, x, nullptr, nullptr)) / (2 * eps);
  }
  EXPECT_LE((fd - g).norm(), rel_tol * g.norm() + 1e-12) << "analytic " << g.transpose() << "\nfd       " << fd.transpose();
}

void expect_hessian_matches(const Case& c, double rel_tol) {
  Mat6 H;
  Vec6 g;
  energy(c, Vec6::Zero(), &g, &H);
  const double eps = 1e-7;  // as above, on the gradient
  Mat6 fd;
  for (int j = 0; j < 6; ++j) {
    Vec6 x = Vec6::Zero(), gp, gm;
    x[j] = eps;
    energy(c, x, &gp, nullptr);
    gp = test::pulled_back(x, gp);
    x[j] = -eps;
    energy(c, x, &gm, nullptr);
    gm = test::pulled_back(x, gm);
    fd.col(j) = (gp - gm) / (2 * eps);
  }
  EXPECT_LE((fd - H).norm(), rel_tol * H.norm()) << "analytic\n" << H << "\nfd\n" << fd;
  EXPECT_LE((H - H.transpose()).norm(), 1e-12 * H.norm());  // symmetric up to round-off
}

Case make_case(ToolSpec::Kind kind, std::mt19937& rng) {
  ToolSpec spec;
  spec.kind = kind;
  Case c;
  c.tool = build_tool(spec);
  c.pose = {{0.01, -0.02, 0.03}, test::random_rotation(rng)};
  std::normal_distribution<double> n(0, 1);
  c.physical = {c.pose.position + 0.003 * Vec3d{n(rng), n(rng), n(rng)},
                normalized(quat_from_rotvec(0.4 * Vec3d{n(rng), n(rng), n(rng)}) * c.pose.orientation)};
  return c;
}

}  // namespace

TEST(ToolEnergy, CouplingGradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(1);
  for (int t = 0; t < 20; ++t) {
    Case c = make_case(ToolSpec::Kind::Hook, rng);  // no vertices: E_tvc alone
    // Relative 1e-6: central differences with eps 1e-7 on angles up to ~2 rad.
    expect_gradient_matches(c, 1e-6);
    expect_hessian_matches(c, 1e-6);
  }
}

TEST(ToolEnergy, ContactGradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(2);
  for (auto kind : {ToolSpec::Kind::Hook, ToolSpec::Kind::Forceps}) {
    for (int t = 0; t < 10; ++t) {
      Case c = make_case(kind, rng);
      add_inside_vertices(c, rng, 12, 5e-5);
      ASSERT_GE(c.q.size(), 6u);
      // Relative 1e-5: curvature radii down to ~1e-4 m give O(eps^2 / rho^2) = 1e-6 truncation.
      expect_gradient_matches(c, 1e-5);
      expect_hessian_matches(c, 1e-5);
    }
  }
}

TEST(ToolEnergy, ContactFarFromTheRotationCentre) {
  std::mt19937 rng(3);
  Case c = make_case(ToolSpec::Kind::Hook, rng);
  const PosedTool posed = pose_tool(c.tool, c.pose, c.jaw);
  // Vertices inside the shaft 0.25 m up from the rotation centre: lever arms 250x the tip's.
  for (double a : {0.0, 1.0, 2.0, 3.0}) {
    const Vec3d local{0.0015 * std::cos(a), 0.0015 * std::sin(a), -0.25 + 0.001 * a};
    c.q.push_back(apply(posed.world[0], local));
  }
  expect_gradient_matches(c, 1e-6);
  expect_hessian_matches(c, 1e-6);
}

TEST(ToolEnergy, NearlyDegenerateNormals) {
  std::mt19937 rng(4);
  {  // vertices 1e-5 m (1% of the radius) from a capsule's axis: curvature 1/rho = 1e5 /m
    Case c = make_case(ToolSpec::Kind::Hook, rng);
    const PosedTool posed = pose_tool(c.tool, c.pose, c.jaw);
    c.q.push_back(apply(posed.world[2], Vec3d{0.003, 1e-5, 0.006}));
    c.q.push_back(apply(posed.world[1], Vec3d{-7e-6, 7e-6, 0.003}));
    expect_gradient_matches(c, 1e-5);  // truncation eps^2/rho^2 = 1e-4 relative on the curvature term,
    expect_hessian_matches(c, 1e-3);   // which is a fraction of the total
  }
  {  // vertices near a jaw box's edge: nearest face 1e-5 m, next face 4e-5 m away
    Case c = make_case(ToolSpec::Kind::Forceps, rng);
    const PosedTool posed = pose_tool(c.tool, c.pose, c.jaw);
    const Collider<double>& box = posed.shape[1];
    c.q.push_back(apply(posed.world[1], box.a + box.half - Vec3d{1e-5, 4e-5, 0.004}));
    c.q.push_back(apply(posed.world[2], posed.shape[2].a + Vec3d{0, -posed.shape[2].half.y + 1e-5,
                                                                 posed.shape[2].half.z - 4e-5}));
    // The FD step 1e-7 (rotations move these points by <= 3e-9 m) never crosses the medial plane.
    expect_gradient_matches(c, 1e-6);
    expect_hessian_matches(c, 1e-6);
  }
}

TEST(ToolEnergy, InverseNormalGradientMatchesFiniteDifferences) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  int checked = 0;
  for (int t = 0; t < 10; ++t) {
    Case c = make_case(ToolSpec::Kind::Hook, rng);
    ToolSpec spec = c.tool.spec;
    c.tool = build_tool(spec, Projection::InverseNormal);
    add_inside_vertices(c, rng, 8, 5e-5);
    const PosedTool posed = pose_tool(c.tool, c.pose, c.jaw);
    // Random normals whose ray leaves the collider well away from grazing (cos > 0.3) and far
    // from the exit surface's edges, where the paper's projection jumps.
    std::vector<Vec3d> q;
    for (const Vec3d& x : c.q) {
      for (int a = 0; a < 50; ++a) {
        const Vec3d nv = normalized(Vec3d{n(rng), n(rng), n(rng)});
        ContactPoint cp;
        if (!vertex_contact(posed, Projection::InverseNormal, 0, x, nv, cp)) break;
        if (1.0 / cp.gain < 0.3) continue;
        ContactPoint shifted;
        bool smooth = true;
        for (int k = 0; k < 3 && smooth; ++k) {
          Vec3d d{};
          d[k] = 1e-5;
          smooth = vertex_contact(posed, Projection::InverseNormal, 0, x + d, nv, shifted) &&
                   norm(shifted.normal - cp.normal) < 1e-2;
        }
        if (!smooth) continue;
        q.push_back(x);
        c.normals.push_back(nv);
        break;
      }
    }
    c.q = q;
    if (c.q.empty()) continue;
    checked += static_cast<int>(c.q.size());
    // 1e-5 relative: the exit distance comes from 60 bisection halvings (exact to round-off).
    expect_gradient_matches(c, 1e-5);
  }
  EXPECT_GE(checked, 20);
}

TEST(ToolEnergy, GraspGradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(6);
  std::normal_distribution<double> n(0, 1);
  GraspState g;
  std::vector<Vec3d> q;
  for (int i = 0; i < 10; ++i) {
    q.push_back(0.01 * Vec3d{n(rng), n(rng), n(rng)});
    g.vertices.push_back(i);
    g.local_target.push_back(0.01 * Vec3d{n(rng), n(rng), n(rng)});
  }
  const ToolPose pose{{0.002, 0.001, -0.003}, test::random_rotation(rng)};
  auto E = [&](const Vec6& x, Vec6* gr, Mat6* H) { return grasp_energy(g, q, perturb(pose, x), 400.0, gr, H); };
  Vec6 gr;
  Mat6 H;
  E(Vec6::Zero(), &gr, &H);
  const double eps = 1e-7;  // smooth quadratic-in-position energy: truncation ~1e-14
  Vec6 fd;
  Mat6 fdH;
  for (int i = 0; i < 6; ++i) {
    Vec6 x = Vec6::Zero(), gp, gm;
    x[i] = eps;
    const double ep = E(x, &gp, nullptr);
    gp = test::pulled_back(x, gp);
    x[i] = -eps;
    fd[i] = (ep - E(x, &gm, nullptr)) / (2 * eps);
    gm = test::pulled_back(x, gm);
    fdH.col(i) = (gp - gm) / (2 * eps);
  }
  EXPECT_LE((fd - gr).norm(), 1e-6 * gr.norm());
  EXPECT_LE((fdH - H).norm(), 1e-6 * H.norm());
}
