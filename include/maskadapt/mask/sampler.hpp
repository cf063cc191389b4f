#pragma once
/// \file sampler.hpp
/// Where part masks come from: random (training), fixed, or scheduled over time (evaluation).
///
/// Random mode (the paper's default): with probability p (0.8) the mask is a non-empty subset of
/// at most K (3) parts, drawn uniformly among all such subsets (for 5 parts and K = 3: 25
/// subsets); otherwise the null mask. Every draw takes an explicit `Rng&`.
///
/// Schedules are lists of (time in seconds, mask): the mask of the last entry whose time is ≤ t
/// applies; before the first entry the null mask applies. Text form:
///   "0:lower_body,5:upper_body"   or   "0:left_leg,right_arm; 2.5:none"
/// Entries are separated by ',' or ';'; a token "T:names" starts an entry at time T and tokens
/// without a time extend the previous entry's mask (so "0:left_leg,right_arm" masks both).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/parts.hpp>

#include <cmath>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace maskadapt {

/// One entry of a mask schedule.
struct ScheduledMask {
  double time = 0.0;  ///< seconds from the episode start
  PartMask mask;
};

/// Parses a schedule (see file comment). Throws Error naming `field` on malformed text,
/// unknown part names, non-finite or decreasing times.
inline std::vector<ScheduledMask> parse_mask_schedule(std::string_view text, const std::string& field = "mask_schedule") {
  std::vector<ScheduledMask> out;
  std::string_view rest = text;
  while (!rest.empty()) {
    const std::size_t cut = rest.find_first_of(",;");
    std::string_view tok = rest.substr(0, cut);
    rest = cut == std::string_view::npos ? std::string_view{} : rest.substr(cut + 1);
    while (!tok.empty() && tok.front() == ' ') tok.remove_prefix(1);
    while (!tok.empty() && tok.back() == ' ') tok.remove_suffix(1);
    if (tok.empty()) continue;
    const std::size_t colon = tok.find(':');
    if (colon == std::string_view::npos) {
      require(!out.empty(), "schedule entry '" + std::string(tok) + "' has no time (expected 'T:parts')",
              {{}, {}, field});
      out.back().mask = out.back().mask | PartMask::parse(tok, field);
      continue;
    }
    const std::string time_text(tok.substr(0, colon));
    char* end = nullptr;
    const double t = std::strtod(time_text.c_str(), &end);
    require(!time_text.empty() && end == time_text.c_str() + time_text.size() && std::isfinite(t) && t >= 0,
            "bad time '" + time_text + "' in schedule entry '" + std::string(tok) + "' (expected seconds ≥ 0)",
            {{}, {}, field});
    if (!out.empty() && !(t > out.back().time))
      throw Error("schedule times must increase ('" + std::string(tok) + "' follows time " +
                      std::to_string(out.back().time) + ")",
                  {{}, {}, field});
    out.push_back({t, PartMask::parse(tok.substr(colon + 1), field)});
  }
  require(!out.empty(), "empty mask schedule", {{}, {}, field});
  return out;
}

class MaskSampler {
 public:
  enum class Mode { Random, Fixed, Scheduled };

  /// Random masks: probability `prob` of a non-empty subset of at most `max_parts` parts.
  static MaskSampler random(double prob = 0.8, int max_parts = 3) {
    require(std::isfinite(prob) && prob >= 0 && prob <= 1, "mask probability must be in [0, 1]", {{}, {}, "mask_prob"});
    require(max_parts >= 1 && max_parts <= kNumParts, "max masked parts must be in [1, 5]", {{}, {}, "max_masked_parts"});
    MaskSampler s;
    s.mode_ = Mode::Random;
    s.prob_ = prob;
    s.max_parts_ = max_parts;
    for (int bits = 1; bits < (1 << kNumParts); ++bits) {
      const PartMask m{static_cast<std::uint8_t>(bits)};
      if (m.count() <= max_parts) s.choices_.push_back(m);
    }
    return s;
  }
  /// Always `mask`.
  static MaskSampler fixed(PartMask mask) {
    MaskSampler s;
    s.mode_ = Mode::Fixed;
    s.schedule_ = {{0.0, mask}};
    return s;
  }
  /// Masks over time (entries sorted by strictly increasing time).
  static MaskSampler scheduled(std::vector<ScheduledMask> schedule) {
    require(!schedule.empty(), "empty mask schedule", {{}, {}, "mask_schedule"});
    for (std::size_t i = 1; i < schedule.size(); ++i)
      require(schedule[i].time > schedule[i - 1].time, "schedule times must increase", {{}, {}, "mask_schedule"});
    MaskSampler s;
    s.mode_ = Mode::Scheduled;
    s.schedule_ = std::move(schedule);
    return s;
  }
  static MaskSampler scheduled(std::string_view text) { return scheduled(parse_mask_schedule(text)); }

  Mode mode() const { return mode_; }
  double prob() const { return prob_; }
  int max_parts() const { return max_parts_; }
  /// The subsets random mode draws from (uniformly).
  const std::vector<PartMask>& choices() const { return choices_; }
  const std::vector<ScheduledMask>& schedule() const { return schedule_; }

  /// The mask at `time` seconds into an episode; random mode draws from `rng` (other modes
  /// never touch it).
  PartMask sample(Rng& rng, double time = 0.0) const {
    switch (mode_) {
      case Mode::Random:
        if (!rng.bernoulli(prob_)) return PartMask::none();
        return choices_[static_cast<std::size_t>(rng.uniform_int(choices_.size()))];
      case Mode::Fixed:
        return schedule_.front().mask;
      case Mode::Scheduled:
        break;
    }
    PartMask m = PartMask::none();
    for (const auto& e : schedule_) {
      if (e.time <= time) m = e.mask;
      else break;
    }
    return m;
  }

 private:
  MaskSampler() = default;
  Mode mode_ = Mode::Fixed;
  double prob_ = 0.0;
  int max_parts_ = 0;
  std::vector<PartMask> choices_;
  std::vector<ScheduledMask> schedule_;
};

}  // namespace maskadapt
