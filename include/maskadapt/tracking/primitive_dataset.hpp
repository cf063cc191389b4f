#pragma once
/// \file primitive_dataset.hpp
/// Training windows for the generator: every labelled clip is cut into overlapping primitives of
/// H + F frames; each window is canonicalised to its first frame and encoded with
/// `encode_frames` (frame_features.hpp). Frame j of a window occupies rows [j·D, (j+1)·D) of the
/// flattened column (frames stacked in time order).
///
/// The same memory read as windows × frames × features: `history_tensor(d)` is the
/// (N × H × D) xtensor view of `d.history` (and `future_tensor(d)` the (N × F × D) view of
/// `d.future`), no copy: history_tensor(d)(n, j, i) == d.history(j·D + i, n). The networks take
/// the flattened columns (Eigen, BLAS); the dataset is written window by window through the views.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/tensor.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/tracking/frame_features.hpp>
#include <maskadapt/tracking/generator.hpp>

#include <concepts>
#include <string>
#include <type_traits>
#include <vector>

namespace maskadapt::tracking {

/// From frame `start_frame` on (until the next segment), `texts` describe the motion.
struct TextSegment {
  Index start_frame = 0;
  std::vector<std::string> texts;
};

/// A world-frame clip at 30 Hz with its text descriptions (any one of them describes it).
/// `segments` (optional, start frames increasing, the first at 0) label parts of the clip
/// differently, e.g. a walk whose arms start waving at frame 60 (tracking/arm_data.hpp); a
/// window then takes the texts of the segment holding its first *future* frame, so windows whose
/// history shows the old behaviour and whose future the new one teach the transition.
struct LabelledTrajectory {
  std::string name;
  std::vector<std::string> texts;
  Trajectory motion;  ///< body_pos may be empty: it is recomputed by FK
  std::vector<TextSegment> segments;
};

struct PrimitiveDataset {
  Index history_frames = 0, future_frames = 0, frame_dim = 0;
  MatrixXf history;  ///< (H·D × N) raw features of the history frames
  MatrixXf future;   ///< (F·D × N) raw features of the future frames
  std::vector<int> clip;  ///< (N) index of the source clip of each window
  std::vector<std::vector<std::string>> clip_texts;  ///< (num clips) texts of each clip
  std::vector<std::string> clip_names;               ///< (num clips)
  std::vector<int> label;                            ///< (N) index into label_texts: the window's texts
  std::vector<std::vector<std::string>> label_texts; ///< (num label sets) clip texts, or a segment's texts
  /// (N) 1 where the window's first future frame lies less than H + F frames after the start of a
  /// clip's second or later segment (the window shows a switch of behaviour, or its first
  /// moments), else 0.
  std::vector<char> transition;

  Index size() const { return history.cols(); }
};

/// (N × H × D) view of `d.history` (no copy; writable unless `d` is const): window n, history
/// frame j, feature i.
template <class Dataset>
  requires std::same_as<std::remove_const_t<Dataset>, PrimitiveDataset>
inline auto history_tensor(Dataset& d) {
  return tensor_view(d.history, std::array{std::size_t(d.size()), std::size_t(d.history_frames), std::size_t(d.frame_dim)},
                     "history");
}
/// (N × F × D) view of `d.future` (no copy; writable unless `d` is const): window n, future frame
/// j, feature i.
template <class Dataset>
  requires std::same_as<std::remove_const_t<Dataset>, PrimitiveDataset>
inline auto future_tensor(Dataset& d) {
  return tensor_view(d.future, std::array{std::size_t(d.size()), std::size_t(d.future_frames), std::size_t(d.frame_dim)},
                     "future");
}

/// Cuts every clip into windows of H + F frames with the given stride (frames). Clips shorter
/// than H + F frames are skipped; throws if no window at all results.
inline PrimitiveDataset make_primitive_dataset(const Skeleton& skel, const std::vector<LabelledTrajectory>& clips,
                                               Index H, Index F, Index stride = 2) {
  require(H >= 1 && F >= 1 && stride >= 1, "window sizes and stride must be ≥ 1", {{}, {}, "window"});
  PrimitiveDataset d;
  d.history_frames = H;
  d.future_frames = F;
  d.frame_dim = frame_feature_dim(skel);
  const Index D = d.frame_dim, W = H + F;
  // windows per clip, known before any is encoded: the dataset is allocated once and every
  // window is written straight into its slot
  Index N = 0;
  for (const auto& clip : clips)
    if (clip.motion.num_frames() >= W) N += (clip.motion.num_frames() - W) / stride + 1;
  d.history.resize(H * D, N);
  d.future.resize(F * D, N);
  auto hist = history_tensor(d);  // (N × H × D)
  auto fut = future_tensor(d);    // (N × F × D)
  std::size_t n = 0;
  for (std::size_t c = 0; c < clips.size(); ++c) {
    const auto& clip = clips[c];
    d.clip_texts.push_back(clip.texts);
    d.clip_names.push_back(clip.name);
    // label sets of this clip: its texts, or one per segment
    const int first_label = static_cast<int>(d.label_texts.size());
    if (clip.segments.empty()) {
      d.label_texts.push_back(clip.texts);
    } else {
      for (std::size_t k = 0; k < clip.segments.size(); ++k) {
        const auto& sg = clip.segments[k];
        require(k == 0 ? sg.start_frame == 0 : sg.start_frame > clip.segments[k - 1].start_frame,
                "clip '" + clip.name + "': segments must start at frame 0 and increase", {{}, {}, "segments"});
        d.label_texts.push_back(sg.texts);
      }
    }
    if (clip.motion.num_frames() < W) continue;
    require(clip.motion.q.rows() == skel.num_dofs(), "clip '" + clip.name + "' does not match the skeleton", {{}, {}, "q"});
    Trajectory world = clip.motion;
    compute_body_positions(skel, world);
    for (Index s = 0; s + W <= world.num_frames(); s += stride, ++n) {
      const auto [local, frame] = canonicalize(world.slice(s, W), 0);
      const MatrixXf w = encode_frames<float>(skel, local);  // (D × W)
      const auto frames = tensor_view(w, std::array{std::size_t(W), std::size_t(D)});  // (W × D)
      xt::noalias(xt::view(hist, n)) = xt::view(frames, xt::range(0, H));  // no temporary: w is not d
      xt::noalias(xt::view(fut, n)) = xt::view(frames, xt::range(H, W));
      d.clip.push_back(static_cast<int>(c));
      int seg = 0;
      for (std::size_t k = 0; k < clip.segments.size(); ++k)
        if (clip.segments[k].start_frame <= s + H) seg = static_cast<int>(k);
      d.label.push_back(first_label + seg);
      d.transition.push_back(seg > 0 && s + H - clip.segments[static_cast<std::size_t>(seg)].start_frame < W ? 1 : 0);
    }
  }
  require(N > 0, "no clip is long enough for one window of " + std::to_string(W) + " frames", {{}, {}, "clips"});
  return d;
}

/// B window indices drawn uniformly with replacement.
inline std::vector<Index> sample_indices(Index n, Index B, Rng& rng) {
  std::vector<Index> idx(static_cast<std::size_t>(B));
  for (auto& i : idx) i = static_cast<Index>(rng.uniform_int(static_cast<std::uint64_t>(n)));
  return idx;
}

/// Columns `idx` of x.
inline MatrixXf gather_columns(const Eigen::Ref<const MatrixXf>& x, const std::vector<Index>& idx) {
  MatrixXf out(x.rows(), static_cast<Index>(idx.size()));
  for (std::size_t j = 0; j < idx.size(); ++j) out.col(static_cast<Index>(j)) = x.col(idx[j]);
  return out;
}

}  // namespace maskadapt::tracking
