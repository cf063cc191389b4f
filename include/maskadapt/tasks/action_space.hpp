#pragma once
/// \file action_space.hpp
/// From policy actions to PD targets: target = offset + scale ⊙ a, per DoF (radians).
///
/// The identity (empty offset and scale) is a = PD target, where a = 0 is the all-zero pose — a
/// T-pose with straight legs for the reference humanoid. Normalised actions (the peers' recipe:
/// MimicKit, IsaacGymEnvs) centre a = 0 on a useful pose — the motion data's mean pose or the
/// middle of each joint's range — and scale a so that ±1 spans the joint's range, which puts the
/// policy's σ and output initialisation in the same units for every joint.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <cmath>
#include <string>

namespace maskadapt::tasks {

struct ActionSpace {
  VectorXf offset;  ///< (num_dofs) PD target of a = 0 (rad); empty ⇒ 0
  VectorXf scale;   ///< (num_dofs) rad per unit of a, > 0; empty ⇒ 1

  bool identity() const { return offset.size() == 0 && scale.size() == 0; }

  /// Throws naming the field unless each vector is empty or (num_dofs), finite, scale > 0.
  void validate(Index num_dofs, const std::string& field = "action_space") const {
    require(offset.size() == 0 || offset.size() == num_dofs,
            "offset must have " + std::to_string(num_dofs) + " entries, got " + std::to_string(offset.size()),
            {{}, {}, field + ".offset"});
    require(scale.size() == 0 || scale.size() == num_dofs,
            "scale must have " + std::to_string(num_dofs) + " entries, got " + std::to_string(scale.size()),
            {{}, {}, field + ".scale"});
    require(offset.allFinite(), "offset must be finite", {{}, {}, field + ".offset"});
    require(scale.allFinite() && (scale.array() > 0).all(), "scale must be finite and > 0", {{}, {}, field + ".scale"});
  }

  /// targets (num_dofs × N) = offset + scale ⊙ a, column by column; `targets` must be sized.
  template <class A, class Out>
  void to_targets(const A& a, Out&& targets) const {
    for (Index j = 0; j < a.cols(); ++j) {
      auto t = targets.col(j);
      if (scale.size()) t = a.col(j).cwiseProduct(scale);
      else t = a.col(j);
      if (offset.size()) t += offset;
    }
  }

  /// Adds to `grad` (num_dofs × B) ∂/∂a of the action-bound penalty
  ///   weight · Σ_ij (max(t_ij − bound, 0)² + min(t_ij + bound, 0)²),   t = offset + scale ⊙ a,
  /// i.e. weight · 2·excess(t) ⊙ scale: the bound is on the PD targets (rad) whatever the action
  /// units. `work` is scratch (sized here). (The base trainer's μ and stage 2's composite actions
  /// use it.)
  template <class A, class G>
  void add_bound_penalty_grad(const A& a, float bound, float weight, MatrixXf& work, G&& grad) const {
    work.resize(a.rows(), a.cols());
    to_targets(a, work);
    work = weight * ((work.array() - bound).max(0.0f) + (work.array() + bound).min(0.0f)) * 2.0f;
    if (scale.size()) work.array().colwise() *= scale.array();
    grad += work;
  }
};

}  // namespace maskadapt::tasks
