#pragma once
// Finite-difference helpers shared by the nn tests (double precision).
#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Core>

namespace maskadapt::nn::test {

/// Central differences of a scalar function of the entries of `x` (perturbed in place and restored).
template <class Mat>
Mat central_diff(Mat& x, const std::function<double()>& f, double h = 1e-6) {
  Mat g(x.rows(), x.cols());
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double old = x.data()[i];
    x.data()[i] = old + h;
    const double fp = f();
    x.data()[i] = old - h;
    const double fm = f();
    x.data()[i] = old;
    g.data()[i] = (fp - fm) / (2 * h);
  }
  return g;
}

/// ‖a − n‖∞ / max(‖n‖∞, 1e-3): the norm-wise relative error used by every gradient check.
template <class A, class B>
double rel_error(const A& analytic, const B& numeric) {
  const double diff = (analytic - numeric).cwiseAbs().maxCoeff();
  return diff / std::max(numeric.cwiseAbs().maxCoeff(), 1e-3);
}

}  // namespace maskadapt::nn::test
