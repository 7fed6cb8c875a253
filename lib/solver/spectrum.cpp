#include "solver/spectrum.hpp"

#include "math/splitmix.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace ebh {

double SpectrumEstimate::jacobi_rate(double gamma) const {
  return std::max(std::abs(1 - gamma * lambda_max), std::abs(1 - gamma * lambda_min));
}

SpectrumEstimate estimate_spectrum(const Eigen::SparseMatrix<double>& A, const std::vector<double>& D, int steps,
                                   Eigen::MatrixXd* basis) {
  const Eigen::Index n = A.rows();
  if (A.cols() != n || Eigen::Index(D.size()) != n) throw std::invalid_argument("estimate_spectrum: sizes differ");
  SpectrumEstimate est;
  if (n == 0) return est;
  Eigen::VectorXd s(n);  // D^-1/2
  for (Eigen::Index i = 0; i < n; ++i) s[i] = 1.0 / std::sqrt(D[i]);
  const int k_max = static_cast<int>(std::min<Eigen::Index>(steps, n));

  // Start: a fixed pseudo-random vector, so every mode is present.
  Eigen::MatrixXd own;
  Eigen::MatrixXd& V = basis ? *basis : own;
  V.resize(n, k_max + 1);  // every column is written before it is read
  SplitMix64 rng{0x243f6a8885a308d3ull};
  for (Eigen::Index i = 0; i < n; ++i) V(i, 0) = rng.uniform() - 0.5;
  V.col(0).normalize();
  std::vector<double> alpha, beta;
  Eigen::VectorXd w(n);
  int k = 0;
  for (; k < k_max; ++k) {
    w = s.cwiseProduct(A * s.cwiseProduct(V.col(k)));  // S v, S = D^-1/2 A D^-1/2
    const double a = V.col(k).dot(w);
    alpha.push_back(a);
    for (int pass = 0; pass < 2; ++pass)  // full reorthogonalisation, twice is enough
      for (int j = 0; j <= k; ++j) w -= V.col(j).dot(w) * V.col(j);
    const double b = w.norm();
    if (k + 1 == k_max || !(b > 1e-12 * std::abs(a))) { ++k; break; }
    beta.push_back(b);
    V.col(k + 1) = w / b;
  }
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(k, k);
  for (int i = 0; i < k; ++i) {
    T(i, i) = alpha[i];
    if (i + 1 < k) T(i, i + 1) = T(i + 1, i) = beta[i];
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(T, Eigen::EigenvaluesOnly);
  est.lambda_min = eig.eigenvalues()(0);
  est.lambda_max = eig.eigenvalues()(k - 1);
  est.iterations = k;
  return est;
}

}  // namespace ebh
