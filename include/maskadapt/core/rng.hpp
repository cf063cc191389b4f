#pragma once
/// \file rng.hpp
/// Seeded, reproducible random streams.
///
/// `Rng` is xoshiro256++ seeded through SplitMix64. Every stochastic function in maskadapt takes
/// an explicit `Rng&`. Env i draws from `Rng::stream(seed, i)`, so results never depend on the
/// number of threads. Normal and uniform variates are computed here (not by <random>'s
/// distributions, whose algorithms differ between standard libraries), so a seed gives the same
/// numbers on every platform.
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace maskadapt {

class Rng {
 public:
  using result_type = std::uint64_t;

  explicit Rng(std::uint64_t seed = 0x5eed) { reseed(seed); }

  /// Independent stream `stream_id` of a run seeded with `seed` (e.g. one per env).
  static Rng stream(std::uint64_t seed, std::uint64_t stream_id) {
    std::uint64_t s = seed;
    const std::uint64_t a = splitmix64(s);
    std::uint64_t t = stream_id ^ 0x9E3779B97F4A7C15ULL;
    const std::uint64_t b = splitmix64(t);
    return Rng(a ^ (b * 0xD1B54A32D192ED03ULL) ^ (stream_id << 1));
  }

  void reseed(std::uint64_t seed) {
    std::uint64_t x = seed;
    for (auto& w : s_) w = splitmix64(x);
    has_spare_normal_ = false;
  }

  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return std::numeric_limits<result_type>::max(); }

  /// Next raw 64-bit value (xoshiro256++).
  result_type operator()() {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>((*this)() >> 11) * 0x1.0p-53; }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n), n > 0 (Lemire's nearly-divisionless method).
  std::uint64_t uniform_int(std::uint64_t n) {
    __uint128_t m = static_cast<__uint128_t>((*this)()) * n;
    auto low = static_cast<std::uint64_t>(m);
    if (low < n) {
      const std::uint64_t threshold = -n % n;
      while (low < threshold) {
        m = static_cast<__uint128_t>((*this)()) * n;
        low = static_cast<std::uint64_t>(m);
      }
    }
    return static_cast<std::uint64_t>(m >> 64);
  }
  /// True with probability p.
  bool bernoulli(double p) { return uniform() < p; }
  /// Standard normal (Marsaglia polar method; caches the second variate).
  double normal() {
    if (has_spare_normal_) {
      has_spare_normal_ = false;
      return spare_normal_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_normal_ = v * f;
    has_spare_normal_ = true;
    return u * f;
  }
  double normal(double mean, double stddev) { return mean + stddev * normal(); }

  /// Full state, for checkpoints (resume must continue bit-exactly).
  struct State {
    std::array<std::uint64_t, 4> s;
    double spare_normal;
    bool has_spare_normal;
  };
  State state() const { return {s_, spare_normal_, has_spare_normal_}; }
  void set_state(const State& st) {
    s_ = st.s;
    spare_normal_ = st.spare_normal;
    has_spare_normal_ = st.has_spare_normal;
  }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static std::uint64_t splitmix64(std::uint64_t& x) {
    std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }

  std::array<std::uint64_t, 4> s_{};
  double spare_normal_ = 0.0;
  bool has_spare_normal_ = false;
};

/// Index i drawn with probability weights[i] / Σ weights (one uniform draw of `rng`; the last
/// index when rounding leaves u past every weight). Weights must be finite, ≥ 0, not all 0.
inline std::size_t draw_weighted(const std::vector<double>& weights, Rng& rng) {
  double total = 0;
  for (double w : weights) total += w;
  double u = rng.uniform() * total;
  for (std::size_t i = 0; i + 1 < weights.size(); ++i) {
    if (u < weights[i]) return i;
    u -= weights[i];
  }
  return weights.empty() ? 0 : weights.size() - 1;
}

}  // namespace maskadapt
