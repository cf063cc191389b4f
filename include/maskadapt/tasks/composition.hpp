#pragma once
/// \file composition.hpp
/// Dynamic motion composition (stage 2a): the data side.
///
///  - `EpisodeMasks`: which body parts the residual adapts, per env — drawn per episode
///    (uniformly) from a configurable set (e.g. lower_body, arms, left_arm, upper_body) and, with
///    `switch_rate` > 0, switched mid-episode (a Poisson process: probability switch_rate·dt per
///    control step), so the policy learns transitions.
///  - `BlendedMotionSet`: the mask-conditioned discriminator's REAL samples. For every mask m of
///    the set it holds the part-wise blends blend_parts(A_i, B_j, m) (motion/blend.hpp): the base
///    set M on unmasked parts, the new set M_new on the masked parts. A real sample is a
///    5-frame window of such a blend together with the bits of its m; a "negative expert" sample
///    is the same kind of window paired with a mask m' ≠ m (labelled fake), so D must read m.
///  - `window_rows`: rows of a 5-frame discriminator window that belong to some parts (used by
///    the per-part-group discriminators of the CML-style baseline and by the tracking task's
///    imitation discriminator on the non-designated parts).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/blend.hpp>
#include <maskadapt/motion/library.hpp>

#include <memory>
#include <string>
#include <vector>

namespace maskadapt::tasks {

/// Parses "lower_body;arms;left_arm" or a list of names into masks (each entry may itself be a
/// comma list: "trunk,left_arm"). Throws naming `field` on unknown names or the empty mask.
inline std::vector<PartMask> parse_mask_set(const std::vector<std::string>& names, const std::string& field = "masks") {
  std::vector<PartMask> out;
  for (const auto& n : names) {
    const PartMask m = PartMask::parse(n, field);
    require(!m.empty(), "a training mask must adapt at least one part ('" + n + "')", {{}, {}, field});
    out.push_back(m);
  }
  require(!out.empty(), "the mask set is empty", {{}, {}, field});
  return out;
}

/// Rows of a window of `frames` stacked observations whose element belongs to a part in `parts`.
inline std::vector<Index> window_rows(const std::vector<BodyPart>& obs_parts, PartMask parts, Index frames = kAmpWindowFrames) {
  std::vector<Index> rows;
  const auto d = static_cast<Index>(obs_parts.size());
  for (Index f = 0; f < frames; ++f)
    for (Index j = 0; j < d; ++j)
      if (parts.has(obs_parts[static_cast<std::size_t>(j)])) rows.push_back(f * d + j);
  return rows;
}

/// out (rows.size() × B) = x(rows, :).
inline void select_rows(const Eigen::Ref<const MatrixXf>& x, const std::vector<Index>& rows, MatrixXf& out) {
  out.resize(static_cast<Index>(rows.size()), x.cols());
  for (Index j = 0; j < x.cols(); ++j)
    for (std::size_t r = 0; r < rows.size(); ++r) out(static_cast<Index>(r), j) = x(rows[r], j);
}

/// The 5 mask bits of each column (5 × B).
inline MatrixXf mask_bits(const std::vector<PartMask>& masks) {
  MatrixXf c(kNumParts, static_cast<Index>(masks.size()));
  for (std::size_t j = 0; j < masks.size(); ++j) {
    const auto a = masks[j].as_array<float>();
    for (int p = 0; p < kNumParts; ++p) c(p, static_cast<Index>(j)) = a[static_cast<std::size_t>(p)];
  }
  return c;
}

/// Per-env adapted-part masks: per episode from a set, optionally switched mid-episode.
class EpisodeMasks {
 public:
  EpisodeMasks() = default;
  /// `switch_rate`: expected mid-episode switches per second (0: one mask per episode). Env e
  /// draws from the stream of env first_env + e (a distributed run's rank offset).
  EpisodeMasks(std::vector<PartMask> set, Index num_envs, double switch_rate, double control_dt, std::uint64_t seed,
               Index first_env = 0)
      : set_(std::move(set)), switch_p_(std::clamp(switch_rate * control_dt, 0.0, 1.0)),
        masks_(static_cast<std::size_t>(num_envs), PartMask::none()) {
    require(!set_.empty(), "the mask set is empty", {{}, {}, "masks"});
    require(std::isfinite(switch_rate) && switch_rate >= 0, "switch rate must be ≥ 0", {{}, {}, "switch_rate"});
    for (Index e = 0; e < num_envs; ++e) {
      rngs_.push_back(Rng::stream(seed, 0x3A5C0000ULL + static_cast<std::uint64_t>(first_env + e)));
      new_episode(e);
    }
  }
  const std::vector<PartMask>& set() const { return set_; }
  const std::vector<PartMask>& masks() const { return masks_; }
  /// A fresh mask for env e (call when its episode starts).
  void new_episode(Index e) { masks_[static_cast<std::size_t>(e)] = draw(e); }
  /// After a step of an env that goes on: maybe switch to another mask of the set.
  void maybe_switch(Index e) {
    if (switch_p_ <= 0 || set_.size() < 2) return;
    auto& r = rngs_[static_cast<std::size_t>(e)];
    if (!r.bernoulli(switch_p_)) return;
    const PartMask old = masks_[static_cast<std::size_t>(e)];
    PartMask m = old;
    while (m == old) m = draw(e);
    masks_[static_cast<std::size_t>(e)] = m;
  }
  /// Overrides env e's mask (play / evaluation schedules).
  void set(Index e, PartMask m) { masks_[static_cast<std::size_t>(e)] = m; }
  std::vector<Rng>& rngs() { return rngs_; }
  const std::vector<Rng>& rngs() const { return rngs_; }

 private:
  PartMask draw(Index e) {
    auto& r = rngs_[static_cast<std::size_t>(e)];
    return set_[static_cast<std::size_t>(r.uniform_int(set_.size()))];
  }
  std::vector<PartMask> set_;
  double switch_p_ = 0;
  std::vector<PartMask> masks_;
  std::vector<Rng> rngs_;
};

/// Part-wise blends of a base set A and a new set B for every mask of a set (see file comment).
class BlendedMotionSet {
 public:
  BlendedMotionSet(const MotionLibrary& base, const MotionLibrary& added, std::vector<PartMask> masks)
      : masks_(std::move(masks)) {
    require(base.num_clips() > 0 && added.num_clips() > 0, "blending needs base and new motion clips",
            {{}, {}, "new_motion"});
    require(!masks_.empty(), "the mask set is empty", {{}, {}, "masks"});
    for (PartMask m : masks_) {
      auto lib = std::make_shared<MotionLibrary>(base.skeleton());
      for (int i = 0; i < base.num_clips(); ++i)
        for (int j = 0; j < added.num_clips(); ++j)
          lib->add(blend_parts(base.clip(i), added.clip(j), m, base.skeleton()), base.weight(i) * added.weight(j));
      libs_.push_back(std::move(lib));
    }
  }
  const std::vector<PartMask>& masks() const { return masks_; }
  /// Blends for mask k of the set.
  const MotionLibrary& library(std::size_t k) const { return *libs_.at(k); }
  Index window_dim() const { return libs_.front()->amp_window_dim(); }

  /// B real samples: windows (window_dim × B), their mask bits (5 × B); masks drawn uniformly
  /// from the set. `masks_out` (optional) receives the masks. The masks and times are drawn in
  /// order from `rng`; the windows are then computed on `pool` when one is given — the same
  /// numbers for any pool size (as MotionLibrary::sample_amp_windows).
  void sample_real(Rng& rng, Index B, MatrixXf& windows, MatrixXf& cond, std::vector<PartMask>* masks_out = nullptr,
                   ThreadPool* pool = nullptr) const {
    windows.resize(window_dim(), B);
    std::vector<PartMask> ms(static_cast<std::size_t>(B));
    std::vector<std::size_t> lib_of(static_cast<std::size_t>(B));
    std::vector<ClipTime> times(static_cast<std::size_t>(B));
    for (std::size_t b = 0; b < static_cast<std::size_t>(B); ++b) {
      const auto k = static_cast<std::size_t>(rng.uniform_int(masks_.size()));
      ms[b] = masks_[k];
      lib_of[b] = k;
      times[b] = libs_[k]->sample(rng, true, (kAmpWindowFrames - 1) * kAmpFrameDt);
    }
    auto window = [&](std::size_t b) { libs_[lib_of[b]]->amp_window(times[b].clip, times[b].time, windows.col(static_cast<Index>(b))); };
    for_each_index(pool, times.size(), window);
    cond = mask_bits(ms);
    if (masks_out) *masks_out = std::move(ms);
  }

  /// B negative-expert samples: real blend windows with a mask m' ≠ their m (another mask of the
  /// set, or a uniformly drawn other non-empty mask when the set has one entry).
  void sample_negative(Rng& rng, Index B, MatrixXf& windows, MatrixXf& cond, ThreadPool* pool = nullptr) const {
    std::vector<PartMask> ms;
    sample_real(rng, B, windows, cond, &ms, pool);
    for (auto& m : ms) {
      PartMask o = m;
      while (o == m) {
        if (masks_.size() >= 2) o = masks_[static_cast<std::size_t>(rng.uniform_int(masks_.size()))];
        else o = PartMask{static_cast<std::uint8_t>(1 + rng.uniform_int((1u << kNumParts) - 1))};
      }
      m = o;
    }
    cond = mask_bits(ms);
  }

 private:
  std::vector<PartMask> masks_;
  std::vector<std::shared_ptr<MotionLibrary>> libs_;
};

}  // namespace maskadapt::tasks
