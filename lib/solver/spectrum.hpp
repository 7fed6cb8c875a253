#pragma once
// The spectrum of the Jacobi-type global step: the eigenvalues of D^-1 A (A the physical mesh's
// global matrix over free vertices, D a positive diagonal), which decide whether and how fast
// x <- x + gamma D^-1 r converges: the relaxed Jacobi error shrinks by
//     rho_J = max |1 - gamma lambda|  over lambda in [lambda_min, lambda_max]
// per iteration and grows without bound once gamma lambda_max > 2.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace ebh {

struct SpectrumEstimate {
  double lambda_min = 0;  ///< smallest eigenvalue of D^-1 A (Lanczos: an upper bound of it)
  double lambda_max = 0;  ///< largest eigenvalue of D^-1 A (Lanczos: a lower bound of it)
  int iterations = 0;     ///< Lanczos steps taken
  /// The relaxed Jacobi iteration's spectral radius max(|1 - gamma lambda_max|, |1 - gamma lambda_min|).
  double jacobi_rate(double gamma) const;
};

/// Lanczos on the symmetric D^-1/2 A D^-1/2 with full reorthogonalisation, from a fixed start
/// vector (the same result on every run), at most `steps` steps (fewer when the Krylov space is
/// exhausted). The extreme Ritz values converge from inside: lambda_max is accurate to ~1e-3
/// relative after 40 steps on the committed meshes (tests/solver/test_spectrum.cpp checks it
/// against a dense eigensolve); callers that need a bound add a margin. `basis`: where the Lanczos
/// vectors go (n x steps + 1), for a caller that estimates again on the same matrix to keep
/// (choose_diagonal's bisection runs eight: a 2.8 million-tet mesh's basis is 160 MB, whose fresh
/// pages the kernel cleared each time); its contents are not read.
SpectrumEstimate estimate_spectrum(const Eigen::SparseMatrix<double>& A, const std::vector<double>& D, int steps = 40,
                                   Eigen::MatrixXd* basis = nullptr);

}  // namespace ebh
