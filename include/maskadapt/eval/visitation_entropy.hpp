#pragma once
/// \file visitation_entropy.hpp
/// Normalised entropy of reference-frame visitation (H_norm), the diversity metric of the
/// mask-invariant / part-adaptive humanoid control paper.
///
/// Given n reference frames r_1..r_n and m generated frames g_1..g_m (feature columns), each
/// generated frame adds counts to the reference frames it resembles, in one of two ways:
///
///   - VisitCounting::all_within (the paper's wording): every pair with ‖g_j − r_i‖ ≤ threshold
///     adds one count to reference frame i, c_i = #{ j : ‖g_j − r_i‖₂ ≤ threshold };
///   - VisitCounting::nearest: each generated frame adds one count to its nearest reference frame,
///     if that one is within the threshold, c_i = #{ j : i = argmin_k ‖g_j − r_k‖ ≤ threshold }
///     (ties in the computed distances: the lowest index; distances come from a GEMM, so
///     reference frames that are exact copies may differ in the last bit between BLAS kernels).
///
///   p_i = c_i / Σ_k c_k,   H_norm = −Σ_i p_i log p_i / log n        (0 · log 0 = 0).
///
/// Why two: on a data set of many similar frames (16,255 frames of walking) `all_within` scores a
/// policy frozen in one pose 0.89 at a 0.5 m threshold, since thousands of walking frames lie
/// within 0.5 m of any one of them, and it only separates a frozen pose from a replay of the data
/// at thresholds (≤ 0.05 m) that no simulated frame reaches; `nearest` scores the frozen pose 0
/// at any threshold, and the threshold only decides which frames count as like the data at all
/// (docs/evaluation.md, eval/threshold_probes.hpp).
///
/// H_norm = 1 when the generated motion visits every reference frame equally often and 0 when it
/// only ever visits one. Conventions for the degenerate cases (documented, tested):
///   - n = 1: H_norm = 0 (a single frame offers no diversity; log n = 0 would divide by zero);
///   - no generated frame within the threshold of any reference frame (Σ c = 0): H_norm = 0.
///
/// Cost: distances come from one GEMM per block of generated frames,
/// ‖g − r‖² = ‖g‖² + ‖r‖² − 2 gᵀr, so 5,000 reference × 10,000 generated frames of ~70 features is
/// a few GFLOP of BLAS work and O(n · block) memory. The GEMM form has a rounding error of about
/// ε·(‖g‖² + ‖r‖²) in the squared distance, negligible against any sensible threshold.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

namespace maskadapt::eval {

/// How generated frames count as visits (see the file comment).
enum class VisitCounting { all_within, nearest };

/// "all_within" or "nearest"; throws naming `field` otherwise.
inline VisitCounting visit_counting_from_string(const std::string& s, const std::string& field = "counting") {
  if (s == "all_within") return VisitCounting::all_within;
  if (s == "nearest") return VisitCounting::nearest;
  throw Error("unknown visit counting '" + s + "' (expected nearest or all_within)", {{}, std::nullopt, field});
}

inline const char* to_string(VisitCounting c) { return c == VisitCounting::nearest ? "nearest" : "all_within"; }

/// Result of visitation_entropy(): H_norm plus the raw counts it came from.
struct VisitationEntropy {
  double h_norm = 0.0;                 ///< normalised entropy in [0, 1]
  double entropy = 0.0;                ///< unnormalised −Σ p log p (nats)
  std::vector<std::int64_t> counts;    ///< (num_reference) c_i
  std::int64_t total_count = 0;        ///< Σ c_i
  std::int64_t matched_generated = 0;  ///< generated frames within threshold of ≥ 1 reference frame
  std::int64_t visited_reference = 0;  ///< reference frames with c_i > 0
};

/// H_norm from visit counts (p_i = c_i / Σ c). Throws on negative counts.
/// Conventions: n = 1 → 0; Σ c = 0 → 0.
inline double normalized_entropy(const std::vector<std::int64_t>& counts, double* entropy_out = nullptr) {
  std::int64_t total = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    require(counts[i] >= 0, "visit counts must be non-negative", {{}, {}, "counts"});
    total += counts[i];
  }
  double h = 0.0;
  if (total > 0) {
    const double inv = 1.0 / static_cast<double>(total);
    for (std::int64_t c : counts)
      if (c > 0) {
        const double p = static_cast<double>(c) * inv;
        h -= p * std::log(p);
      }
  }
  if (entropy_out) *entropy_out = h;
  if (counts.size() <= 1 || total == 0) return 0.0;
  return std::clamp(h / std::log(static_cast<double>(counts.size())), 0.0, 1.0);
}

/// Visit counts and H_norm of `generated` against `reference`.
///
/// \param reference  (feature_dim × n) reference-frame features (e.g. joint features of the clips)
/// \param generated  (feature_dim × m) features of the generated (simulated) frames
/// \param threshold  distance threshold in feature units (Euclidean); must be ≥ 0 and finite
/// \param counting   which reference frames a generated frame visits (file comment)
/// \param block      generated frames per GEMM block (memory n × block scalars)
/// Throws maskadapt::Error on mismatched dimensions, empty reference or non-finite features.
template <class DerivedR, class DerivedG>
VisitationEntropy visitation_entropy(const Eigen::MatrixBase<DerivedR>& reference,
                                     const Eigen::MatrixBase<DerivedG>& generated, double threshold,
                                     VisitCounting counting = VisitCounting::all_within, Index block = 512) {
  using Scalar = typename DerivedR::Scalar;
  static_assert(std::is_same_v<Scalar, typename DerivedG::Scalar>,
                "reference and generated features must have the same scalar type");
  require(reference.cols() >= 1, "need at least one reference frame", {{}, {}, "reference"});
  require(reference.rows() == generated.rows(),
          "feature dimension mismatch: reference has " + std::to_string(reference.rows()) +
              " rows, generated has " + std::to_string(generated.rows()),
          {{}, {}, "generated"});
  require(std::isfinite(threshold) && threshold >= 0.0, "threshold must be finite and >= 0",
          {{}, {}, "threshold"});
  require(block >= 1, "block must be >= 1", {{}, {}, "block"});
  require_finite(reference, "reference");
  require_finite(generated, "generated");

  const Index n = reference.cols(), m = generated.cols();
  const MatrixX<Scalar> R = reference;  // (d × n), contiguous for the GEMM
  const RowVectorX<Scalar> r_sq = R.colwise().squaredNorm();  // (1 × n)
  const Scalar thr_sq = static_cast<Scalar>(threshold * threshold);

  VisitationEntropy out;
  out.counts.assign(static_cast<std::size_t>(n), 0);
  MatrixX<Scalar> dots;  // (block × n) gᵀr
  std::vector<unsigned char> matched;  // (block) generated frame j hit some reference frame
  std::vector<Scalar> best;            // (block) nearest mode: max_i 2 g_jᵀ r_i − ‖r_i‖²
  std::vector<Index> best_i;           // (block) nearest mode: its i
  for (Index start = 0; start < m; start += block) {
    const Index b = std::min(block, m - start);
    const MatrixX<Scalar> G = generated.middleCols(start, b);  // (d × b)
    const VectorX<Scalar> g_sq = G.colwise().squaredNorm().transpose();  // (b)
    dots.noalias() = G.transpose() * R;  // (b × n)
    if (counting == VisitCounting::nearest) {
      // nearest i maximises 2 g_jᵀ r_i − ‖r_i‖² (= ‖g_j‖² − d²(j, i)); the first maximum wins ties
      best.assign(static_cast<std::size_t>(b), -std::numeric_limits<Scalar>::infinity());
      best_i.assign(static_cast<std::size_t>(b), 0);
      for (Index i = 0; i < n; ++i) {
        const Scalar* col = dots.col(i).data();
        for (Index j = 0; j < b; ++j) {
          const Scalar v = Scalar(2) * col[j] - r_sq[i];
          if (v > best[static_cast<std::size_t>(j)]) {
            best[static_cast<std::size_t>(j)] = v;
            best_i[static_cast<std::size_t>(j)] = i;
          }
        }
      }
      for (Index j = 0; j < b; ++j)
        if (g_sq[j] - best[static_cast<std::size_t>(j)] <= thr_sq) {
          ++out.counts[static_cast<std::size_t>(best_i[static_cast<std::size_t>(j)])];
          ++out.matched_generated;
        }
      continue;
    }
    // d²(j, i) = ‖g_j‖² + ‖r_i‖² − 2 g_jᵀ r_i ≤ thr²  ⇔  2 g_jᵀ r_i ≥ ‖g_j‖² + ‖r_i‖² − thr².
    matched.assign(static_cast<std::size_t>(b), 0);
    for (Index i = 0; i < n; ++i) {
      const Scalar ri = r_sq[i] - thr_sq;
      const Scalar* col = dots.col(i).data();
      std::int64_t c = 0;
      for (Index j = 0; j < b; ++j) {
        const bool hit = g_sq[j] + ri - Scalar(2) * col[j] <= Scalar(0);
        c += hit;
        matched[static_cast<std::size_t>(j)] |= static_cast<unsigned char>(hit);
      }
      out.counts[static_cast<std::size_t>(i)] += c;
    }
    for (unsigned char hit : matched) out.matched_generated += hit;
  }
  for (std::int64_t c : out.counts) {
    out.total_count += c;
    out.visited_reference += (c > 0);
  }
  out.h_norm = normalized_entropy(out.counts, &out.entropy);
  return out;
}

/// The rows `rows` of `features` (e.g. only the adapted parts' elements), as a new matrix.
/// \param features (feature_dim × frames); \return (rows.size() × frames)
template <class Derived>
MatrixX<typename Derived::Scalar> select_rows(const Eigen::MatrixBase<Derived>& features,
                                              const std::vector<Index>& rows) {
  MatrixX<typename Derived::Scalar> out(static_cast<Index>(rows.size()), features.cols());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    require(rows[k] >= 0 && rows[k] < features.rows(),
            "row index " + std::to_string(rows[k]) + " out of range [0, " + std::to_string(features.rows()) + ")",
            {{}, {}, "rows"});
    out.row(static_cast<Index>(k)) = features.row(rows[k]);
  }
  return out;
}

}  // namespace maskadapt::eval
