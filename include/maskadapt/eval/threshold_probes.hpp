#pragma once
/// \file threshold_probes.hpp
/// Choosing the distance threshold of H_norm (visitation_entropy.hpp) on the reference data
/// itself. H_norm only ranks policies if the threshold separates broad coverage from collapse, so
/// it is checked against three kinematic probes whose answer is known:
///
///   - **replay**: windows of the clips played back as recorded (random clip and start frame, as
///     reference-state initialisation draws them; a window that reaches its clip's end continues
///     from a new random start, like a reset). A policy that imitates the data perfectly.
///     H_norm should be near 1;
///   - **frozen**: one frame repeated (a policy that stands in one pose). H_norm should be near 0;
///   - **one clip**: all frames of one clip, once (a policy collapsed onto one motion pattern).
///     H_norm should be well below replay.
///
/// A threshold that is too large lets every generated frame visit almost every reference frame
/// (frozen → 1: the metric cannot see collapse); one that is too small lets a frame visit only
/// itself (then every probe's score depends on how many frames it has). The probes are averaged
/// over `probes` random frames / clips. Everything here works on feature columns: the caller
/// provides the reference features clip by clip (e.g. train/eval_base.hpp's
/// reference_visitation_features, root-relative body positions in the heading frame, metres).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/eval/visitation_entropy.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace maskadapt::eval {

struct ThresholdProbeOptions {
  Index windows = 32;          ///< replay windows (eval-base: one per env)
  Index window_frames = 300;   ///< frames per replay window (eval-base: --frames)
  Index probes = 8;            ///< frozen frames and single clips averaged
  VisitCounting counting = VisitCounting::nearest;
  std::uint64_t seed = 1;
};

/// H_norm of the three probes at one threshold (frozen and one-clip: mean over the probes, with
/// their largest value beside it).
struct ThresholdProbe {
  double threshold = 0;        ///< feature units (m for visitation features)
  double replay = 0;           ///< H_norm of the replay windows
  double replay_matched = 0;   ///< fraction of the replay's frames with a reference frame within the threshold (1 by construction)
  double frozen = 0, frozen_max = 0;
  double one_clip = 0, one_clip_max = 0;
};

/// \param reference     (d × n) feature columns of every reference frame, clips back to back
/// \param clip_frames   frames of each clip in that order (Σ = n, each ≥ 1)
/// \param thresholds    distances to probe (each finite and ≥ 0)
/// Throws naming the argument on inconsistent sizes.
inline std::vector<ThresholdProbe> probe_thresholds(const Eigen::Ref<const MatrixXf>& reference,
                                                    const std::vector<Index>& clip_frames,
                                                    const std::vector<double>& thresholds,
                                                    const ThresholdProbeOptions& opt = {}) {
  require(!clip_frames.empty(), "need at least one clip", {{}, {}, "clip_frames"});
  for (Index f : clip_frames) require(f >= 1, "every clip needs at least one frame", {{}, {}, "clip_frames"});
  const Index n = std::accumulate(clip_frames.begin(), clip_frames.end(), Index{0});
  require(n == reference.cols(),
          "clip frames add up to " + std::to_string(n) + ", reference has " + std::to_string(reference.cols()) + " columns",
          {{}, {}, "clip_frames"});
  require(opt.windows >= 1 && opt.window_frames >= 1 && opt.probes >= 1, "windows, window_frames and probes must be >= 1",
          {{}, {}, "options"});
  std::vector<Index> first(clip_frames.size());  // column of each clip's first frame
  std::exclusive_scan(clip_frames.begin(), clip_frames.end(), first.begin(), Index{0});
  Rng rng = Rng::stream(opt.seed, 0x7E5E0ULL);
  // A reference frame drawn uniformly over all frames, as (clip, frame in clip).
  auto draw_frame = [&](std::size_t& clip, Index& t) {
    const Index col = static_cast<Index>(rng.uniform_int(static_cast<std::uint64_t>(n)));
    clip = static_cast<std::size_t>(std::upper_bound(first.begin(), first.end(), col) - first.begin() - 1);
    t = col - first[clip];
  };

  MatrixXf replay(reference.rows(), opt.windows * opt.window_frames);  // (d × windows·window_frames)
  for (Index w = 0; w < opt.windows; ++w) {
    std::size_t clip = 0;
    Index t = 0;
    draw_frame(clip, t);
    for (Index f = 0; f < opt.window_frames; ++f) {
      if (t >= clip_frames[clip]) draw_frame(clip, t);  // the clip ended: a new reference start
      replay.col(w * opt.window_frames + f) = reference.col(first[clip] + t);
      ++t;
    }
  }
  std::vector<Index> frozen_cols, clips;
  for (Index k = 0; k < opt.probes; ++k) {
    std::size_t clip = 0;
    Index t = 0;
    draw_frame(clip, t);
    frozen_cols.push_back(first[clip] + t);
    clips.push_back(static_cast<Index>(rng.uniform_int(clip_frames.size())));
  }

  std::vector<ThresholdProbe> out;
  for (double thr : thresholds) {
    require(std::isfinite(thr) && thr >= 0, "thresholds must be finite and >= 0", {{}, {}, "thresholds"});
    ThresholdProbe p;
    p.threshold = thr;
    const VisitationEntropy r = visitation_entropy(reference, replay, thr, opt.counting);
    p.replay = r.h_norm;
    p.replay_matched = static_cast<double>(r.matched_generated) / static_cast<double>(replay.cols());
    for (Index k = 0; k < opt.probes; ++k) {
      // a pose held for any number of frames has the visit distribution of one frame
      const double hf = visitation_entropy(reference, reference.col(frozen_cols[static_cast<std::size_t>(k)]), thr, opt.counting).h_norm;
      const auto c = static_cast<std::size_t>(clips[static_cast<std::size_t>(k)]);
      const double hc = visitation_entropy(reference, reference.middleCols(first[c], clip_frames[c]), thr, opt.counting).h_norm;
      p.frozen += hf / static_cast<double>(opt.probes);
      p.frozen_max = std::max(p.frozen_max, hf);
      p.one_clip += hc / static_cast<double>(opt.probes);
      p.one_clip_max = std::max(p.one_clip_max, hc);
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace maskadapt::eval
