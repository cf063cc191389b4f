#pragma once
/// \file dtw.hpp
/// Dynamic time warping (DTW) between two sequences of pose feature columns.
///
/// Used for the pose error of the non-tracked parts against the reference walk: the simulated
/// and the reference motion need not be in phase, so frames are aligned by the monotone warping
/// path of least total cost before the error is averaged.
///
///   cost(i, j) = ‖a_i − b_j‖₂                      (Euclidean, in feature units, e.g. metres)
///   D(0, 0)    = cost(0, 0)
///   D(i, j)    = cost(i, j) + min(D(i−1, j), D(i, j−1), D(i−1, j−1))
///
/// total_cost = D(n−1, m−1); the path runs from (0, 0) to (n−1, m−1) with steps (1,0), (0,1) or
/// (1,1); mean_cost = total_cost / path length (the average per-aligned-pair distance).
///
/// Optional Sakoe–Chiba band: only cells with |i − j| ≤ r′ are allowed, r′ = max(r, |n − m|) so
/// that the end cell is always reachable. Without a band (r < 0) the full n × m grid is used.
/// Memory and time are O(n · m) (O(n · band) time with a band); distances are computed in double.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::eval {

struct DtwResult {
  double total_cost = 0.0;                      ///< Σ cost along the optimal path
  double mean_cost = 0.0;                       ///< total_cost / path.size()
  std::vector<std::pair<Index, Index>> path;    ///< (i, j) pairs from (0, 0) to (n−1, m−1)
};

/// DTW between a (d × n) and b (d × m).
/// \param band Sakoe–Chiba radius in frames; negative = no band.
/// Throws maskadapt::Error for empty sequences, mismatched feature dimensions or non-finite values.
template <class DerivedA, class DerivedB>
DtwResult dtw(const Eigen::MatrixBase<DerivedA>& a, const Eigen::MatrixBase<DerivedB>& b, Index band = -1) {
  require(a.cols() >= 1, "first sequence is empty", {{}, {}, "a"});
  require(b.cols() >= 1, "second sequence is empty", {{}, {}, "b"});
  require(a.rows() == b.rows(),
          "feature dimension mismatch: " + std::to_string(a.rows()) + " vs " + std::to_string(b.rows()),
          {{}, {}, "b"});
  require_finite(a, "a");
  require_finite(b, "b");
  const Index n = a.cols(), m = b.cols();
  const MatrixXd A = a.template cast<double>(), B = b.template cast<double>();  // (d × n), (d × m)
  const Index r = band < 0 ? std::max(n, m) : std::max(band, std::abs(n - m));
  const double inf = std::numeric_limits<double>::infinity();

  MatrixXd D = MatrixXd::Constant(n, m, inf);  // accumulated cost (n × m)
  for (Index i = 0; i < n; ++i) {
    const Index j_lo = std::max<Index>(0, i - r), j_hi = std::min<Index>(m - 1, i + r);
    for (Index j = j_lo; j <= j_hi; ++j) {
      const double c = (A.col(i) - B.col(j)).norm();
      double best;
      if (i == 0 && j == 0) best = 0.0;
      else {
        best = inf;
        if (i > 0) best = std::min(best, D(i - 1, j));
        if (j > 0) best = std::min(best, D(i, j - 1));
        if (i > 0 && j > 0) best = std::min(best, D(i - 1, j - 1));
      }
      D(i, j) = c + best;
    }
  }

  DtwResult out;
  out.total_cost = D(n - 1, m - 1);
  // Backtrack; ties prefer the diagonal, then the step that keeps |i − j| small.
  Index i = n - 1, j = m - 1;
  out.path.emplace_back(i, j);
  while (i > 0 || j > 0) {
    if (i == 0) --j;
    else if (j == 0) --i;
    else {
      const double diag = D(i - 1, j - 1), up = D(i - 1, j), left = D(i, j - 1);
      if (diag <= up && diag <= left) { --i; --j; }
      else if (up <= left) --i;
      else --j;
    }
    out.path.emplace_back(i, j);
  }
  std::reverse(out.path.begin(), out.path.end());
  out.mean_cost = out.total_cost / static_cast<double>(out.path.size());
  return out;
}

}  // namespace maskadapt::eval
