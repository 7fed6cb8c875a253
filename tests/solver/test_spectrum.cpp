// The bounded diagonal on meshes with bad tets: Lanczos' estimate of the spectrum of D^-1 A
// against a dense eigensolve, the bound lambda_max(D^-1 A) <= 2.1 that the bounded diagonal keeps,
// the paper's diagonal diverging where it does not, and the step converging to the direct solve.
#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/Dense>

#include "box_sim.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/degrade.hpp"
#include "scene/scene.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/spectrum.hpp"
#include "solver/virtual_mesh.hpp"

namespace ebh {
namespace {

PhysicalModel model_of(const Scene& scene, const VirtualModel& vm, SolverSpec::Diagonal diagonal) {
  PhysicalModelOptions o;
  o.diagonal = diagonal;
  return build_physical_model(scene, &vm, o);
}

/// The eigenvalues of D^-1 A, densely.
Eigen::VectorXd dense_spectrum(const PhysicalModel& m) {
  const Eigen::MatrixXd A = Eigen::MatrixXd(assemble_global_matrix(m));
  Eigen::VectorXd s(m.num_free);
  for (int i = 0; i < m.num_free; ++i) s[i] = 1.0 / std::sqrt(m.diag[m.free_vertices[i]]);
  const Eigen::MatrixXd S = s.asDiagonal() * A * s.asDiagonal();
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues();
}

TEST(Spectrum, LanczosFindsTheLargestEigenvalueOfADenseSolve) {
  for (double q : {1.0, 0.02}) {
    const Scene scene = test::degraded_block(q);
    const VirtualModel vm = build_virtual_model(scene);
    const PhysicalModel m = model_of(scene, vm, SolverSpec::Diagonal::Plain);
    const Eigen::VectorXd ev = dense_spectrum(m);
    // Ritz values lie inside the spectrum; 40 steps get the top one to 1e-3 on these meshes.
    EXPECT_LE(m.spectrum.lambda_max, ev[ev.size() - 1] * (1 + 1e-12)) << "quality " << q;
    EXPECT_NEAR(m.spectrum.lambda_max, ev[ev.size() - 1], 1e-3 * ev[ev.size() - 1]) << "quality " << q;
    EXPECT_GE(m.spectrum.lambda_min, ev[0] * (1 - 1e-12)) << "quality " << q;
  }
}

TEST(Spectrum, BoundedDiagonalIsThePlainOneOnAGoodMeshAndBoundsABadOne) {
  const Scene good = test::degraded_block(1.0);
  const VirtualModel vg = build_virtual_model(good);
  const PhysicalModel plain = model_of(good, vg, SolverSpec::Diagonal::Plain);
  const PhysicalModel bounded = model_of(good, vg, SolverSpec::Diagonal::Bounded);
  EXPECT_EQ(bounded.diag_theta, 0.0);
  EXPECT_EQ(bounded.diag, plain.diag);  // the paper's diagonal to the bit

  const Scene bad = test::degraded_block(0.02);
  const VirtualModel vb = build_virtual_model(bad);
  const PhysicalModel bad_plain = model_of(bad, vb, SolverSpec::Diagonal::Plain);
  const PhysicalModel bad_bounded = model_of(bad, vb, SolverSpec::Diagonal::Bounded);
  const Eigen::VectorXd ev_plain = dense_spectrum(bad_plain), ev_bounded = dense_spectrum(bad_bounded);
  // gamma = 0.9: the plain diagonal leaves gamma lambda_max > 2 (divergent), the bounded one <= 1.89.
  EXPECT_GT(0.9 * ev_plain[ev_plain.size() - 1], 2.0);
  EXPECT_LE(ev_bounded[ev_bounded.size() - 1], 2.1);
  EXPECT_GT(bad_bounded.diag_theta, 0.0);
  EXPECT_LE(bad_bounded.diag_theta, 0.5);
  EXPECT_GT(bad_bounded.diag_bounded_rows, 0);
}

TEST(Spectrum, L1RowSumsBoundTheMatrix) {
  // D_l1 - A is positive semidefinite: its smallest eigenvalue is >= 0 (round-off aside).
  const Scene bad = test::degraded_block(0.02);
  const VirtualModel vb = build_virtual_model(bad);
  const PhysicalModel m = model_of(bad, vb, SolverSpec::Diagonal::Plain);
  const Eigen::SparseMatrix<double> A = assemble_global_matrix(m);
  const std::vector<double> l1 = l1_row_sums(A);
  Eigen::MatrixXd B = -Eigen::MatrixXd(A);
  for (int i = 0; i < m.num_free; ++i) B(i, i) += l1[i];
  const double lo = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(B, Eigen::EigenvaluesOnly).eigenvalues()[0];
  EXPECT_GE(lo, -1e-9 * Eigen::Map<const Eigen::VectorXd>(l1.data(), l1.size()).maxCoeff());
}

TEST(Spectrum, BoundedChebyshevConvergesWhereThePlainOneDiverges) {
  const Scene bad = test::degraded_block(0.02);
  const VirtualModel vm = build_virtual_model(bad);
  PhysicalModelOptions o;
  o.diagonal = SolverSpec::Diagonal::Bounded;
  const PhysicalModel bounded = build_physical_model(bad, &vm, o);
  o.diagonal = SolverSpec::Diagonal::Plain;
  const PhysicalModel plain = build_physical_model(bad, &vm, o);
  PhysicalState start = make_physical_state(plain);
  for (int a = 0; a < plain.num_vertices; ++a)
    if (!plain.pinned[a]) start.v[a] = Vec3d{0.5, 0.0, -0.3} * (plain.rest[a].z / 0.048);
  PhysicalWorkspace ws = make_physical_workspace(plain);
  PhysicalStepParams p;
  p.method = SolverSpec::Method::Direct;
  p.iterations = 200;
  PhysicalState ref = start;
  physical_step(plain, ws, ref, vm.rest, p);  // the converged step
  double initial = 0;  // every method starts from the prediction x + h v
  for (int a = 0; a < plain.num_vertices; ++a)
    initial = std::max(initial, norm(start.x[a] + plain.h * start.v[a] - ref.x[a]));

  for (SolverSpec::Method method : {SolverSpec::Method::Jacobi, SolverSpec::Method::Chebyshev}) {
    p.method = method;
    p.iterations = 200;
    PhysicalState s = start;
    const PhysicalStepReport rb = physical_step(bounded, ws, s, vm.rest, p);
    double err = 0;
    for (int a = 0; a < plain.num_vertices; ++a) err = std::max(err, norm(s.x[a] - ref.x[a]));
    // The block's slow modes leave both far from round-off after 200 iterations (measured: 0.15
    // of the initial error for relaxed Jacobi, 0.05 for Chebyshev); what matters is that they
    // shrink where the plain diagonal blows up.
    EXPECT_LT(err, (method == SolverSpec::Method::Jacobi ? 0.5 : 0.1) * initial) << "method " << int(method);
    EXPECT_TRUE(physical_state_problem(bounded, s.x, rb).empty());

    s = start;
    p.iterations = 60;
    const PhysicalStepReport rp = physical_step(plain, ws, s, vm.rest, p);
    const std::string problem = physical_state_problem(plain, s.x, rp);
    EXPECT_NE(problem.find("the physical mesh "), std::string::npos) << "method " << int(method);
    EXPECT_NE(problem.find("its worst tet"), std::string::npos) << problem;
  }
}

TEST(Spectrum, ResidualIsZeroAtRest) {
  const Scene good = test::degraded_block(1.0);
  const VirtualModel vm = build_virtual_model(good);
  const PhysicalModel m = model_of(good, vm, SolverSpec::Diagonal::Bounded);
  PhysicalWorkspace ws = make_physical_workspace(m);
  PhysicalModel weightless = m;
  weightless.gravity = Vec3d{};
  PhysicalState s = make_physical_state(m);
  PhysicalStepParams p;
  const PhysicalStepReport r = physical_step(weightless, ws, s, vm.rest, p);
  EXPECT_LT(r.residual, 1e-10);  // nothing moves: r_K is the elastic force at rest, round-off
  s.v.assign(s.v.size(), Vec3d{0, 0, -0.1});
  const PhysicalStepReport moving = physical_step(weightless, ws, s, vm.rest, p);
  EXPECT_GT(moving.residual, 0.0);
  EXPECT_GT(moving.residual_reduction, 0.0);
  EXPECT_LT(moving.residual_reduction, 1.0);
}

TEST(Spectrum, AutoChebyshevRhoIsTheRelaxedJacobiRate) {
  // chebyshev_rho: auto takes rho = max |1 - gamma lambda| over the estimate; a number stays as it is.
  for (double q : {1.0, 0.02}) {
    const Scene scene = test::degraded_block(q);
    const VirtualModel vm = build_virtual_model(scene);
    const PhysicalModel m = model_of(scene, vm, SolverSpec::Diagonal::Bounded);
    SolverSpec spec;
    spec.chebyshev_rho = 0.9;
    EXPECT_EQ(physical_params(spec, m).chebyshev_rho, 0.9);
    spec.chebyshev_rho_auto = true;
    const double rho = physical_params(spec, m).chebyshev_rho;
    EXPECT_EQ(rho, std::clamp(m.spectrum.jacobi_rate(0.9), 0.5, 0.9999)) << "quality " << q;
    EXPECT_GT(rho, 0.5);
    EXPECT_LT(rho, 1.0);
  }
}

}  // namespace
}  // namespace ebh
