#pragma once
// Central finite differences, kept in the library (STYLE.md, MuJoCo): tests check every
// analytic gradient of lib/energy against them.
#include <functional>
#include <vector>

namespace ebh {

/// Central-difference gradient of f at x: (f(x + eps e_i) - f(x - eps e_i)) / (2 eps).
///   x: #D parameters; f: R^D -> R. Returns #D. Error O(eps^2 f''') + O(roundoff / eps).
inline std::vector<double> fd_gradient(const std::function<double(const std::vector<double>&)>& f,
                                       std::vector<double> x, double eps) {
  std::vector<double> g(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    const double xi = x[i];
    x[i] = xi + eps;
    const double fp = f(x);
    x[i] = xi - eps;
    const double fm = f(x);
    x[i] = xi;
    g[i] = (fp - fm) / (2 * eps);
  }
  return g;
}

}  // namespace ebh
