// The shared tool terms (tool/tool_terms.hpp, tool/newton.hpp, solver/virtual_jacobi.hpp) where
// the CPU and the device tick round differently: each pair of variants must agree to round-off,
// and each must match the plain formula it implements.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "contact_points.hpp"
#include "solver/virtual_jacobi.hpp"
#include "tool/newton.hpp"
#include "tool/tool_model.hpp"
#include "tool/tool_terms.hpp"

using namespace ebh;

namespace {

Vec3d random_vec(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

}  // namespace

// Both roundings of k_vct/2 theta^2 are theta^2 in double: they agree to a few ulps of E.
TEST(ToolTerms, CouplingAnglesAgreeToRoundOff) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 1000; ++trial) {
    const Vec3d Pg = random_vec(rng, 0.1), Ph = random_vec(rng, 0.1);
    const Quatd Qg = test::random_rotation(rng), Qh = test::random_rotation(rng);
    double g1[6], g2[6];
    const double e1 = coupling_terms<CouplingAngle::OfNorm>(Pg, Qg, Ph, Qh, 300.0, 0.05, g1);
    const double e2 = coupling_terms<CouplingAngle::OfComponents>(Pg, Qg, Ph, Qh, 300.0, 0.05, g2);
    EXPECT_NEAR(e1, e2, 1e-14 * e1);
    for (int k = 0; k < 6; ++k) EXPECT_EQ(g1[k], g2[k]);  // one gradient
    const CouplingOffset<double> o = coupling_offset(Pg, Qg, Ph, Qh);
    const double theta = norm(o.v);
    EXPECT_NEAR(e1, 150.0 * squared_norm(o.dP) + 0.025 * theta * theta, 1e-14 * e1);
  }
}

// The force clamp scales to the limit along the same direction and reports it; 0 is no limit.
TEST(ToolTerms, ClampLength) {
  Vec3d v{3, 4, 0};
  EXPECT_FALSE(clamp_length(v, 0.0));
  EXPECT_FALSE(clamp_length(v, 5.0));
  EXPECT_TRUE(clamp_length(v, 2.5));
  EXPECT_DOUBLE_EQ(norm(v), 2.5);
  EXPECT_DOUBLE_EQ(v.x / v.y, 0.75);
  const CouplingOutput<double> out =
      coupling_output(Vec3d{0.1, 0, 0}, Quatd{1, 0, 0, 0}, Vec3d{}, Quatd{1, 0, 0, 0}, 300.0, 0.05, 3.3, 0.0);
  EXPECT_TRUE(out.force_clamped);  // 30 N before the clamp
  EXPECT_DOUBLE_EQ(out.force.x, 3.3);
  EXPECT_FALSE(out.torque_clamped);
  // A length whose square overflows keeps its direction (it gave 0 N, "clamped").
  Vec3d far{3e200, -4e200, 0};
  EXPECT_TRUE(clamp_length(far, 2.5));
  EXPECT_DOUBLE_EQ(norm(far), 2.5);
  EXPECT_DOUBLE_EQ(far.x / far.y, -0.75);
  Vec3<float> far_f{3e30f, 4e30f, 0};
  EXPECT_TRUE(clamp_length(far_f, 2.5f));
  EXPECT_FLOAT_EQ(norm(far_f), 2.5f);
  const CouplingOutput<double> lag =
      coupling_output(Vec3d{1e160, 0, 0}, Quatd{1, 0, 0, 0}, Vec3d{}, Quatd{1, 0, 0, 0}, 300.0, 0.05, 3.3, 0.0);
  EXPECT_TRUE(lag.force_clamped);
  EXPECT_DOUBLE_EQ(lag.force.x, 3.3);
}

// The grasp Hessian's two roundings (CPU Split, device Fused) agree to round-off of its entries.
TEST(ToolTerms, GraspRotationOrdersAgreeToRoundOff) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 1000; ++trial) {
    const Mat3d R = to_matrix(test::random_rotation(rng));
    const GraspOffset<double> o = grasp_offset(R, random_vec(rng, 0.1), random_vec(rng, 0.01), random_vec(rng, 0.1));
    double g1[6] = {}, g2[6] = {}, H1[36] = {}, H2[36] = {};
    grasp_derivative_terms<GraspRotation::Split>(400.0, o, g1, H1);
    grasp_derivative_terms<GraspRotation::Fused>(400.0, o, g2, H2);
    double scale = 0;
    for (int k = 0; k < 36; ++k) scale = std::max(scale, std::fabs(H1[k]));
    for (int k = 0; k < 6; ++k) EXPECT_EQ(g1[k], g2[k]);
    for (int k = 0; k < 36; ++k) EXPECT_NEAR(H1[k], H2[k], 1e-14 * scale) << k;
    EXPECT_DOUBLE_EQ(grasp_energy_term(400.0, o), 200.0 * squared_norm(o.e));
  }
}

// eq. [10]: w(d) = 1 / (1 + eta e^d); the target is flattened onto x = 0 as w -> 1.
TEST(ToolTerms, GraspPoint) {
  Collider<double> hb;
  hb.shape = Shape::Box;
  hb.a = Vec3d{0, 0, 0.01};
  hb.half = Vec3d{0.001, 0.002, 0.01};
  const Vec3d ls{0.0005, 0.003, 0.005};  // y beyond the box: clamped to 0.002
  const GraspPoint<double> p = grasp_point(hb, ls, -0.5e-3, 1e-3, 0.1);
  EXPECT_DOUBLE_EQ(p.weight, 1.0 / (1.0 + 0.1 * std::exp(-0.5)));
  const Vec3d lf{0.0, 0.002, 0.005};
  // Coordinates of ~5 mm: 1e-18 m is about one ulp (8.7e-19) of them.
  EXPECT_NEAR(norm(p.local - (p.weight * lf + (1.0 - p.weight) * ls)), 0.0, 1e-18);
  EXPECT_TRUE(grasp_reaches(1e-3, 1e-3));
  EXPECT_FALSE(grasp_reaches(1.0001e-3, 1e-3));
}

// The line search's tests at their boundaries.
TEST(ToolTerms, NewtonTests) {
  EXPECT_TRUE(armijo_accepts(1.0, 1.0, 1.0, 0.0));
  EXPECT_FALSE(armijo_accepts(1.0, 1.0, 1.0, -1.0));
  EXPECT_TRUE(armijo_accepts(1.0 - 2e-4, 1.0, 1.0, -1.0));
  EXPECT_TRUE(newton_decrease_visible(-1e-12, 1.0));
  EXPECT_FALSE(newton_decrease_visible(-1e-14, 1.0));
  EXPECT_TRUE(newton_step_roundoff(1e-18, 1e-15, Vec3d{0.1, 0, 0}));
  EXPECT_FALSE(newton_step_roundoff(1e-12, 1e-15, Vec3d{0.1, 0, 0}));
  // The candidate bound: translation T alone reaches T; a rotation th reaches th (r + T) more, over 1 - th.
  EXPECT_DOUBLE_EQ(newton_reach_bound(0.002, 0.0, 0.05), 0.002);
  EXPECT_DOUBLE_EQ(newton_reach_bound(0.0, 0.1, 0.05), 0.005 / 0.9);
  ToolSpec spec;
  spec.newton_iterations = 3;
  spec.max_step = 1e-3;
  spec.max_step_rotation_deg = 20.0;
  const NewtonLimits l = newton_limits(spec);
  EXPECT_EQ(l.iterations, 3);
  EXPECT_DOUBLE_EQ(l.reach_translation, 3e-3);
  EXPECT_DOUBLE_EQ(l.reach_rotation, 0.5);  // 60 degrees, capped
}

// The jaws: the upper jaw turns +z towards +x, the lower towards -x, by the clamped angle.
TEST(ToolTerms, JawOpeningAndColliderWorld) {
  ToolSpec spec;
  spec.kind = ToolSpec::Kind::Forceps;
  const ToolModel tool = build_tool(spec);
  const JawOpening o = jaw_opening(tool, 2.0);  // clamped to 1
  const double a = spec.forceps.jaw_max_angle_deg * std::numbers::pi / 180.0;
  EXPECT_DOUBLE_EQ(o.cos, std::cos(a));
  EXPECT_DOUBLE_EQ(o.sin, std::sin(a));
  const Rigid<double> tool_frame{Mat3d::identity(), Vec3d{1, 2, 3}};
  const Vec3d up = apply(collider_world(tool_frame, ColliderFrame::UpperJaw, o.cos, o.sin), Vec3d{0, 0, 1});
  const Vec3d down = apply(collider_world(tool_frame, ColliderFrame::LowerJaw, o.cos, o.sin), Vec3d{0, 0, 1});
  // x = 1 + sin a: the subtraction leaves the ulp of 1 (2.2e-16) times a few operations.
  EXPECT_NEAR(up.x - 1, std::sin(a), 1e-15);
  EXPECT_NEAR(down.x - 1, -std::sin(a), 1e-15);
  const Vec3d same = apply(collider_world(tool_frame, ColliderFrame::Tool, o.cos, o.sin), Vec3d{0, 0, 1});
  EXPECT_EQ(same.z, 4.0);
  const ToolModel hook = build_tool(ToolSpec{});
  EXPECT_EQ(jaw_opening(hook, 0.3).sin, 0.0);
}

// The two Jacobi updates (contact before the edges and a division; after them and a reciprocal)
// agree to float round-off, and both solve the vertex's 1D quadratic exactly when nothing else moves.
TEST(VirtualJacobi, UpdatesAgree) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 1000; ++trial) {
    const Vec3f q = static_cast<Vec3f>(random_vec(rng, 0.1)), s = static_cast<Vec3f>(random_vec(rng, 0.1));
    const Vec3f p = static_cast<Vec3f>(random_vec(rng, 0.1)), g = static_cast<Vec3f>(random_vec(rng, 1.0));
    const Vec3f target = static_cast<Vec3f>(random_vec(rng, 0.1));
    const float mh = 50.f, k_svc = 50.f, stiff = 170.f, ck = 400.f;
    const Vec3f kt = ck * target;
    Vec3f r1 = add_contact_residual(inertia_coupling_residual(mh, s, q, p, k_svc), kt, ck, q);
    add_edge_residual(r1, g, true);
    const Vec3f a = jacobi_update(q, r1, mh + stiff + ck);
    Vec3f r2 = inertia_coupling_residual(mh, s, q, p, k_svc);
    add_edge_residual(r2, g, true);
    const Vec3f b = jacobi_update_with_contact(q, r2, kt, ck, mh + stiff + ck);
    // float32 in another order: positions of ~0.1 m carry ~1e-8 m per rounding (ulp 7.5e-9), and the
    // residual's terms (up to ~100 N/m x 0.2 m) divided by D ~ 600 N/m add a few more: 1e-6 m is
    // ~100 such roundings, far below any error of the update itself (~0.1 m).
    EXPECT_NEAR(norm(static_cast<Vec3d>(a - b)), 0.0, 1e-6);
    // Without edges (stiff = 0): the minimiser of E_k + E_svc + E_con.
    const Vec3f r0 = add_contact_residual(inertia_coupling_residual(mh, s, q, p, 0.f), kt, ck, q);
    const Vec3f x = jacobi_update(q, r0, mh + ck);
    const Vec3f expect = (1.f / (mh + ck)) * (mh * s + kt);
    EXPECT_NEAR(norm(static_cast<Vec3d>(x - expect)), 0.0, 1e-6);  // the same float32 round-off as above
  }
}
