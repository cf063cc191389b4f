#pragma once
/// \file apply.hpp
/// Applying part masks to observations: s̄ = (1 − m) ⊙ s, and the policy input [s̄ ; m].
///
/// `parts` gives the body part of every observation element (humanoid/observation.hpp's
/// `observation_parts`); element j is zeroed iff its part is masked. Batches are columns:
/// observations (dim × batch), one PartMask per column.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>

#include <array>
#include <span>
#include <string>
#include <vector>

namespace maskadapt {

/// Element indices of each part, precomputed once from a per-element part list.
struct PartElements {
  Index dim = 0;                                           ///< number of elements
  std::array<std::vector<Index>, kNumParts> of_part;       ///< element indices of part p

  PartElements() = default;
  explicit PartElements(const std::vector<BodyPart>& parts) : dim(static_cast<Index>(parts.size())) {
    for (Index j = 0; j < dim; ++j) of_part[static_cast<std::size_t>(parts[static_cast<std::size_t>(j)])].push_back(j);
  }
};

/// Number of rows of the policy input: observation rows + 5 mask bits.
inline Index policy_input_dim(Index obs_dim) { return obs_dim + kNumParts; }

/// The keep vector 1 − m (dim): 0 on elements of masked parts, 1 elsewhere.
template <class T = float>
VectorX<T> keep_vector(const PartElements& pe, PartMask m) {
  VectorX<T> k = VectorX<T>::Ones(pe.dim);
  for (int p = 0; p < kNumParts; ++p)
    if (m.has(static_cast<BodyPart>(p)))
      for (Index j : pe.of_part[static_cast<std::size_t>(p)]) k[j] = T(0);
  return k;
}

/// In place: column b of `obs` (dim × batch) becomes (1 − m_b) ⊙ obs_b.
template <class Derived>
void apply_masks(const PartElements& pe, std::span<const PartMask> masks, Eigen::MatrixBase<Derived>& obs) {
  require(obs.rows() == pe.dim, "observations have " + std::to_string(obs.rows()) + " rows, the part list " +
                                    std::to_string(pe.dim), {{}, {}, "observation"});
  require(static_cast<Index>(masks.size()) == obs.cols(),
          std::to_string(masks.size()) + " masks for " + std::to_string(obs.cols()) + " columns", {{}, {}, "masks"});
  for (Index b = 0; b < obs.cols(); ++b) {
    const PartMask m = masks[static_cast<std::size_t>(b)];
    for (int p = 0; p < kNumParts; ++p)
      if (m.has(static_cast<BodyPart>(p)))
        for (Index j : pe.of_part[static_cast<std::size_t>(p)]) obs(j, b) = 0;
  }
}
template <class Derived>
void apply_masks(const PartElements& pe, std::span<const PartMask> masks, Eigen::MatrixBase<Derived>&& obs) {
  apply_masks(pe, masks, obs);
}

/// Policy input for a batch: out (dim + 5 × batch) = [(1 − m_b) ⊙ obs_b ; bits(m_b)], mask bits
/// in part order (trunk, left_arm, right_arm, left_leg, right_leg) as 0/1.
template <class T>
void build_policy_input(const PartElements& pe, const Eigen::Ref<const MatrixX<T>>& obs,
                        std::span<const PartMask> masks, Eigen::Ref<MatrixX<T>> out) {
  require(out.rows() == policy_input_dim(pe.dim) && out.cols() == obs.cols(),
          "policy input is " + std::to_string(out.rows()) + "x" + std::to_string(out.cols()) + ", expected " +
              std::to_string(policy_input_dim(pe.dim)) + "x" + std::to_string(obs.cols()),
          {{}, {}, "policy_input"});
  require(obs.rows() == pe.dim, "observations have " + std::to_string(obs.rows()) + " rows, the part list " +
                                    std::to_string(pe.dim), {{}, {}, "observation"});
  out.topRows(pe.dim) = obs;
  apply_masks(pe, masks, out.topRows(pe.dim));
  for (Index b = 0; b < obs.cols(); ++b) {
    const auto bits = masks[static_cast<std::size_t>(b)].template as_array<T>();
    for (int p = 0; p < kNumParts; ++p) out(pe.dim + p, b) = bits[static_cast<std::size_t>(p)];
  }
}

/// Convenience: returns the policy input as a new matrix.
template <class T>
MatrixX<T> policy_input(const PartElements& pe, const Eigen::Ref<const MatrixX<T>>& obs, std::span<const PartMask> masks) {
  MatrixX<T> out(policy_input_dim(pe.dim), obs.cols());
  build_policy_input<T>(pe, obs, masks, out);
  return out;
}

}  // namespace maskadapt
