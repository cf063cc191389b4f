#pragma once
/// \file reward_discriminators.hpp
/// The discriminator objectives of a stage-2 run (train/residual_trainer.hpp): one
/// rl::Discriminator per `DiscriminatorSource`, each seeing some rows of the 5-frame window
/// (all, or one part group's) and optionally the 5 mask bits (D(·|m), the mask-conditioned
/// discriminator of ours). Each gives one reward row −log(max(1 − D_k, 1e−4)). With
/// `rl.disc.window_frames` F < 5 every member sees only the rows of the window's last F frames
/// (F = 2: the paper's D(s, s′|m)).
///
/// Discriminator steps (`update`): per member, disc.epochs · n / B steps of B samples: real
/// samples from its source (part-wise blends for ours), fake = fresh agent windows with their
/// masks mixed with the replay buffer, and, for conditioned members with a negative sampler, a
/// `negative_fraction` of the fake batch replaced by real blends paired with a mismatched mask
/// (so D must read m).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/rl/replay_buffer.hpp>
#include <maskadapt/tasks/composition.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/distributed.hpp>
#include <maskadapt/train/progress.hpp>
#include <maskadapt/train/residual_config.hpp>

#include <functional>
#include <string>
#include <vector>

namespace maskadapt::train {

/// One reward source backed by a discriminator.
struct DiscriminatorSource {
  std::string name;
  double weight = 1.0;
  std::vector<Index> rows;   ///< rows of the 5-frame window it sees (empty: all)
  bool conditioned = false;  ///< D(·|m): the 5 mask bits as conditioning input
  /// B real samples: full windows (window_dim × B) and mask bits (5 × B; ignored if unconditioned).
  std::function<void(Rng&, Index, MatrixXf&, MatrixXf&)> real;
  /// Optional negative-expert samples (same layout), labelled fake.
  std::function<void(Rng&, Index, MatrixXf&, MatrixXf&)> negative;
};

class RewardDiscriminators {
 public:
  RewardDiscriminators() = default;
  /// One member per source, initialised from `init` in source order; `window_dim` rows of a full
  /// 5-frame window; sizes and losses from `rl.net.disc_hidden` and `rl.disc`.
  RewardDiscriminators(std::vector<DiscriminatorSource> sources, Index window_dim, const BaseTrainConfig& rl,
                       nn::Activation activation, double negative_fraction, Rng& init)
      : sources_(std::move(sources)), disc_(rl.disc), negative_fraction_(negative_fraction) {
    keep_last_frames(rl.disc.window_frames, window_dim);
    for (const auto& src : sources_) {
      require(static_cast<bool>(src.real), "discriminator '" + src.name + "' has no real sampler", {{}, {}, "setup"});
      rl::DiscriminatorConfig dc = discriminator_config(rl, src.rows.empty() ? window_dim : static_cast<Index>(src.rows.size()));
      dc.cond_dim = src.conditioned ? kNumParts : 0;
      dc.activation = activation;
      // stage 2 has never clipped its discriminators' gradient norm (the Table 2 runs): keep it so
      dc.max_grad_norm = rl::DiscriminatorConfig{}.max_grad_norm;
      set_.add(src.name, rl::Discriminator<float>(dc, init), src.weight);
      replays_.emplace_back(dc.feature_dim + dc.cond_dim, rl.disc.replay_size);
    }
  }

  Index size() const { return static_cast<Index>(sources_.size()); }
  const std::vector<DiscriminatorSource>& sources() const { return sources_; }
  const rl::DiscriminatorSet<float>& set() const { return set_; }

  /// Rows [0, size()) of `rewards` (objectives × n) for the windows (window_dim × n) and their
  /// masks; st.disc_reward = the weighted sum of the rows' means, and with `log_each` one
  /// st.extra["reward_<name>"] per member.
  void rewards(const Eigen::Ref<const MatrixXf>& windows, const std::vector<PartMask>& masks, MatrixXf& rewards,
               bool log_each, IterationStats& st) const {
    MatrixXf feat, cond;
    double w = 0;
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      member_inputs(k, windows, masks, feat, cond);
      const auto row = static_cast<Index>(k);
      rewards.row(row) = set_.members[k].reward(feat, cond);
      const double mean = rewards.row(row).cast<double>().mean();
      if (log_each) st.extra["reward_" + sources_[k].name] = mean;
      w += sources_[k].weight * mean;
    }
    st.disc_reward = w;
  }

  /// Discriminator steps on the agent windows (window_dim × n) of an iteration (see file comment).
  /// Distributed (`ranks`): the windows and masks of all ranks are gathered (one process's column
  /// order), so every rank draws the same batches from the replicated `rng` and keeps the same
  /// replay buffers; each rank back-propagates its slice of each batch and the gradients are
  /// summed over ranks (rl::Discriminator::update_on_ranks).
  void update(const MatrixXf& windows_here, const std::vector<PartMask>& masks_here, Rng& rng, IterationStats& st,
              const RankLayout& ranks = {}) {
    if (ranks.distributed()) {
      gather_step_major(*ranks.comm, windows_here, ranks.envs_here, all_windows_, "discriminator windows");
      gather_step_major(*ranks.comm, masks_here, ranks.envs_here, all_masks_);
    }
    const MatrixXf& agent_windows = ranks.distributed() ? all_windows_ : windows_here;
    const std::vector<PartMask>& agent_masks = ranks.distributed() ? all_masks_ : masks_here;
    const Index n = agent_windows.cols(), B = disc_.batch_size, half = B / 2;
    const Index steps = std::max<Index>(1, disc_.epochs * n / B);
    double sum_real = 0, sum_fake = 0, sum_loss = 0, sum_gp = 0;
    int count = 0;
    MatrixXf real_w, real_c, real_f, agent_w, feat, cond, fake, neg_w, neg_c, neg_f, stacked;
    std::vector<PartMask> ms(static_cast<std::size_t>(B - half));
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      const auto& src = sources_[k];
      auto& d = set_.members[k];
      const Index F = d.config().feature_dim, C = d.config().cond_dim;
      const Index n_neg = (src.conditioned && src.negative) ? static_cast<Index>(negative_fraction_ * static_cast<double>(B)) : 0;
      for (Index s = 0; s < steps; ++s) {
        src.real(rng, B, real_w, real_c);
        if (src.rows.empty()) real_f = real_w;
        else tasks::select_rows(real_w, src.rows, real_f);
        agent_w.resize(agent_windows.rows(), B - half);  // fresh agent windows with their masks
        for (Index j = 0; j < B - half; ++j) {
          const auto c = static_cast<Index>(rng.uniform_int(static_cast<std::uint64_t>(n)));
          agent_w.col(j) = agent_windows.col(c);
          ms[static_cast<std::size_t>(j)] = agent_masks[static_cast<std::size_t>(c)];
        }
        member_inputs(k, agent_w, ms, feat, cond);
        stacked.resize(F + C, B - half);
        stacked.topRows(F) = feat;
        if (C > 0) stacked.bottomRows(C) = cond;
        rl::mix_with_replay<float>(stacked, replays_[k], half, rng, fake);
        if (n_neg > 0) {
          src.negative(rng, n_neg, neg_w, neg_c);
          if (src.rows.empty()) neg_f = neg_w;
          else tasks::select_rows(neg_w, src.rows, neg_f);
          const Index keep = std::max<Index>(1, fake.cols() - n_neg);
          fake.conservativeResize(F + C, keep + n_neg);
          fake.block(0, keep, F, n_neg) = neg_f;
          fake.block(F, keep, C, n_neg) = neg_c;
        }
        if (s == 0) {
          d.update_normalizer(real_f);
          d.update_normalizer(feat);
        }
        const MatrixXf real_cond = src.conditioned ? MatrixXf(real_c) : MatrixXf(0, B);
        const MatrixXf fake_cond = C > 0 ? MatrixXf(fake.bottomRows(C)) : MatrixXf(0, fake.cols());
        const auto ds = ranks.distributed() ? d.update_on_ranks(real_f, real_cond, fake.topRows(F), fake_cond, *ranks.comm)
                                            : d.update(real_f, real_cond, fake.topRows(F), fake_cond);
        if (ds.skipped) ++st.skipped_updates;
        sum_real += ds.real_mean;
        sum_fake += ds.fake_mean;
        sum_loss += ds.loss;
        sum_gp += ds.grad_penalty;
        ++count;
      }
    }
    if (count > 0) {
      st.disc_real = sum_real / count;
      st.disc_fake = sum_fake / count;
      st.disc_loss = sum_loss / count;
      st.disc_grad_penalty = sum_gp / count;
    }
  }

  /// Networks and normalisers: disc/<k>/params, disc/<k>/norm/…
  void save(Checkpoint& c) const {
    for (std::size_t k = 0; k < set_.members.size(); ++k) {
      const std::string p = "disc/" + std::to_string(k);
      c.put(p + "/params", set_.members[k].net().params());
      save_normalizer(set_.members[k].normalizer(), p + "/norm", c);
    }
  }
  void load(const Checkpoint& c) {
    for (std::size_t k = 0; k < set_.members.size(); ++k) {
      const std::string p = "disc/" + std::to_string(k);
      c.copy_to<float>(p + "/params", set_.members[k].net().params());
      load_normalizer(c, p + "/norm", set_.members[k].normalizer());
    }
  }
  /// Optimiser moments, step counts and replay buffers: state/disc/<k>/…
  void save_state(Checkpoint& c) const {
    auto& self = const_cast<RewardDiscriminators&>(*this);  // block accessors are non-const only; nothing changes
    for (std::size_t k = 0; k < set_.members.size(); ++k) {
      auto& d = self.set_.members[k];
      const std::string p = "state/disc/" + std::to_string(k);
      c.put(p + "/block", d.net().block().storage());
      c.put_int(p + "/steps", d.optimizer().step_count());
      const auto& r = replays_[k];
      c.put(p + "/replay", r.storage());
      c.put_int(p + "/replay_size", r.size());
      c.put_int(p + "/replay_head", r.head());
    }
  }
  void load_state(const Checkpoint& c) {
    for (std::size_t k = 0; k < set_.members.size(); ++k) {
      auto& d = set_.members[k];
      const std::string p = "state/disc/" + std::to_string(k);
      c.copy_to<float>(p + "/block", d.net().block().storage());
      d.optimizer().set_step_count(c.get_int(p + "/steps"));
      auto& r = replays_[k];
      r.restore(c.get_matrix<float>(p + "/replay", r.storage().rows(), r.storage().cols()), c.get_int(p + "/replay_size"),
                c.get_int(p + "/replay_head"));
    }
  }

 private:
  /// With F = window_frames < 5, each source's rows become those of the last F frames (a source
  /// that saw the whole window: rows [(5 − F)·d, 5·d)); sources keep their order.
  void keep_last_frames(int frames, Index window_dim) {
    require(frames >= 1 && frames <= kAmpWindowFrames && window_dim % kAmpWindowFrames == 0,
            "window_frames must be 1 to 5 of a 5-frame window", {{}, {}, "disc.window_frames"});
    if (frames == kAmpWindowFrames) return;
    const Index first = (kAmpWindowFrames - frames) * (window_dim / kAmpWindowFrames);
    for (auto& src : sources_) {
      if (src.rows.empty())
        for (Index r = first; r < window_dim; ++r) src.rows.push_back(r);
      else
        std::erase_if(src.rows, [first](Index r) { return r < first; });
      require(!src.rows.empty(), "discriminator '" + src.name + "' sees no row of the last frames", {{}, {}, "disc.window_frames"});
    }
  }

  /// Member k's input: its rows of the windows, and the mask bits if it is conditioned.
  void member_inputs(std::size_t k, const Eigen::Ref<const MatrixXf>& windows, const std::vector<PartMask>& masks,
                     MatrixXf& feat, MatrixXf& cond) const {
    const auto& src = sources_[k];
    if (src.rows.empty()) feat = windows;
    else tasks::select_rows(windows, src.rows, feat);
    if (src.conditioned) cond = tasks::mask_bits(masks);
    else cond.resize(0, windows.cols());
  }

  std::vector<DiscriminatorSource> sources_;
  DiscConfig disc_;
  double negative_fraction_ = 0.25;
  rl::DiscriminatorSet<float> set_;
  std::vector<rl::ReplayBuffer<float>> replays_;
  MatrixXf all_windows_;              ///< distributed: every rank's agent windows (window_dim × N_all·H)
  std::vector<PartMask> all_masks_;   ///< and their masks
};

}  // namespace maskadapt::train
