#pragma once
/// \file progress.hpp
/// Per-iteration statistics of a trainer, the JSONL log (one JSON object per iteration) and the
/// one-line progress display on the terminal.
#include <maskadapt/core/error.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace maskadapt::train {

/// Wall-clock stopwatch (seconds).
class Stopwatch {
 public:
  Stopwatch() : start_(clock::now()) {}
  void restart() { start_ = clock::now(); }
  double seconds() const { return std::chrono::duration<double>(clock::now() - start_).count(); }

 private:
  using clock = std::chrono::steady_clock;
  clock::time_point start_;
};

/// Everything logged for one iteration. Times are wall-clock seconds of this iteration, split
/// into simulation (physics stepping), inference (policy/value/discriminator forward passes and
/// features during collection) and update (GAE, PPO, MI and discriminator steps); time_disc is
/// the discriminators' part of the update (their reward pass on the rollout and their steps).
struct IterationStats {
  long long iteration = 0;        ///< 1-based index of the iteration just finished
  long long samples = 0;          ///< total env steps collected so far (all envs)
  double samples_per_s = 0;       ///< env steps per wall second of this iteration
  double episode_length = 0;      ///< mean length (s) of episodes that ended in this iteration (NaN if none)
  double episodes = 0;            ///< episodes that ended in this iteration
  double fall_rate = 0;           ///< fraction of ended episodes that ended by a fall
  double disc_reward = 0;         ///< mean discriminator reward per step
  double disc_real = 0;           ///< mean D(real) (probability) during discriminator updates
  double disc_fake = 0;           ///< mean D(agent)
  double disc_loss = 0;
  double disc_grad_penalty = 0;
  double mi_kl = 0;               ///< mean KL(π(·|s,m⁰) ‖ π(·|s̄,m)) over PPO minibatches
  double policy_loss = 0;
  double value_loss = 0;
  double entropy = 0;
  double approx_kl = 0;
  double clip_frac = 0;
  double grad_norm = 0;
  double actor_lr = 0;            ///< the actor's learning rate at the end of the iteration (moves when adaptive)
  double mask_fraction = 0;       ///< fraction of collected steps with a non-empty mask
  double time_sim = 0;
  double time_inference = 0;
  double time_update = 0;
  double time_disc = 0;           ///< part of time_update: discriminator rewards + updates
  double time_ppo = 0;            ///< part of time_update: GAE and PPO (with stage 1's MI term)
  double time_disc_reward = 0;    ///< part of time_disc: the reward pass on the rollout (stage 2: with the tracking terms)
  double time_disc_real_windows = 0;  ///< part of time_disc: drawing the real windows (stage 1; 0 in stage 2)
  double time_total = 0;
  long long skipped_updates = 0;  ///< non-finite update steps skipped in this iteration
  long long sim_resets = 0;       ///< envs reset by the simulator because physics went non-finite
  double elapsed_s = 0;           ///< wall time since the run (or resume) started
  double eta_s = NAN;             ///< estimated time left (NaN when unknown)
  /// Task-specific columns (e.g. stage 2's "tracking_reward"), written to the log as extra keys.
  std::map<std::string, double> extra;
};

/// Sums of the PPO minibatch figures over an update; `write` stores their means in the stats.
struct PpoMinibatchMeans {
  double policy_loss = 0, value_loss = 0, approx_kl = 0, clip_frac = 0, mi_kl = 0, grad_norm = 0;
  int count = 0;
  void add(double pl, double vl, double kl, double cf, double mi, double gn) {
    policy_loss += pl;
    value_loss += vl;
    approx_kl += kl;
    clip_frac += cf;
    mi_kl += mi;
    grad_norm += gn;
    ++count;
  }
  void write(IterationStats& st) const {
    const double n = count > 0 ? count : 1;
    st.policy_loss = policy_loss / n;
    st.value_loss = value_loss / n;
    st.approx_kl = approx_kl / n;
    st.clip_frac = clip_frac / n;
    st.mi_kl = mi_kl / n;
    st.grad_norm = grad_norm / n;
  }
};

/// Fills the counters, throughput and episode columns of `st` at the end of an iteration that
/// collected `batch` samples in `seconds`; `es` is the task's tasks::EpisodeStats of the iteration.
/// mask_fraction is the fraction of steps with a non-empty mask.
template <class EpisodeStatsT>
void finish_iteration_stats(IterationStats& st, long long iteration, long long samples, long long batch,
                            double seconds, const EpisodeStatsT& es) {
  st.iteration = iteration;
  st.samples = samples;
  st.time_total = seconds;
  st.samples_per_s = static_cast<double>(batch) / std::max(1e-9, seconds);
  st.episode_length = es.mean_length();
  st.episodes = static_cast<double>(es.episodes);
  st.fall_rate = es.fall_rate();
  st.mask_fraction = es.steps > 0 ? static_cast<double>(es.masked_steps) / static_cast<double>(es.steps) : 0.0;
  st.sim_resets = es.sim_resets;
}

inline nlohmann::json to_json(const IterationStats& s) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json j = {{"iteration", s.iteration},
          {"samples", s.samples},
          {"samples_per_s", num(s.samples_per_s)},
          {"episode_length", num(s.episode_length)},
          {"episodes", num(s.episodes)},
          {"fall_rate", num(s.fall_rate)},
          {"disc_reward", num(s.disc_reward)},
          {"disc_real", num(s.disc_real)},
          {"disc_fake", num(s.disc_fake)},
          {"disc_loss", num(s.disc_loss)},
          {"disc_grad_penalty", num(s.disc_grad_penalty)},
          {"mi_kl", num(s.mi_kl)},
          {"policy_loss", num(s.policy_loss)},
          {"value_loss", num(s.value_loss)},
          {"entropy", num(s.entropy)},
          {"approx_kl", num(s.approx_kl)},
          {"clip_frac", num(s.clip_frac)},
          {"grad_norm", num(s.grad_norm)},
          {"actor_lr", num(s.actor_lr)},
          {"mask_fraction", num(s.mask_fraction)},
          {"time_sim", num(s.time_sim)},
          {"time_inference", num(s.time_inference)},
          {"time_update", num(s.time_update)},
          {"time_disc", num(s.time_disc)},
          {"time_ppo", num(s.time_ppo)},
          {"time_disc_reward", num(s.time_disc_reward)},
          {"time_disc_real_windows", num(s.time_disc_real_windows)},
          {"time_total", num(s.time_total)},
          {"skipped_updates", s.skipped_updates},
          {"sim_resets", s.sim_resets},
          {"elapsed_s", num(s.elapsed_s)},
          {"eta_s", num(s.eta_s)}};
  for (const auto& [k, v] : s.extra) j[k] = num(v);
  return j;
}

/// Makes the log at `path` end at `iteration` before a resumed run appends to it: a run killed
/// after its last checkpoint (SIGKILL, a session ending) logged iterations that the resumed run
/// repeats, which would otherwise appear twice. Keeps every line whose "iteration" is ≤
/// `iteration` (and lines without one), drops the others and an unfinished last line (a crash in
/// mid-write), and rewrites the file atomically (temporary file, then rename). A missing file is
/// left missing; a file that cannot be read or written throws naming it.
inline void drop_log_lines_after(const std::string& path, long long iteration) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) return;
  std::ifstream in(path);
  if (!in) throw Error("cannot read log file", {path, std::nullopt, {}});
  std::vector<std::string> kept;
  std::string line;
  bool dropped = false;
  while (std::getline(in, line)) {
    const bool last = in.peek() == std::char_traits<char>::eof();
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded()) {
      if (last) { dropped = true; continue; }  // an unfinished last line
      kept.push_back(line);
      continue;
    }
    if (j.is_object() && j.contains("iteration") && j["iteration"].is_number() && j["iteration"].get<long long>() > iteration) {
      dropped = true;
      continue;
    }
    kept.push_back(line);
  }
  if (!dropped) return;
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    for (const auto& l : kept) out << l << '\n';
    out.flush();
    if (!out) throw Error("failed writing log file", {tmp, std::nullopt, {}});
  }
  fs::rename(tmp, path);
}

/// Appends one JSON object per line; flushed after every line so a crash loses nothing.
class JsonlLog {
 public:
  JsonlLog() = default;
  /// Opens `path` for appending (a resumed run continues the same log) or truncates it.
  explicit JsonlLog(const std::string& path, bool append = false)
      : path_(path), out_(path, append ? std::ios::app : std::ios::trunc) {
    if (!out_) throw Error("cannot open log file for writing", {path, std::nullopt, {}});
  }
  bool is_open() const { return out_.is_open(); }
  void write(const nlohmann::json& j) {
    if (!out_.is_open()) return;
    out_ << j.dump() << '\n';
    out_.flush();
    if (!out_) throw Error("failed writing log file", {path_, std::nullopt, {}});
  }

 private:
  std::string path_;
  std::ofstream out_;
};

/// "1h02m", "3m05s", "12s", "--" for unknown.
inline std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--";
  const long long s = static_cast<long long>(std::llround(seconds));
  char buf[32];
  if (s >= 3600) std::snprintf(buf, sizeof buf, "%lldh%02lldm", s / 3600, (s % 3600) / 60);
  else if (s >= 60) std::snprintf(buf, sizeof buf, "%lldm%02llds", s / 60, s % 60);
  else std::snprintf(buf, sizeof buf, "%llds", s);
  return buf;
}

/// The terminal progress line, e.g.
/// `it   120/500 | 3,140 sps | ep 6.21 s | r_D 0.412 | KL_MI 0.0312 | sim 41% inf 22% upd 37% (disc 12%) | ETA 21m10s`
/// (the disc share is of the whole iteration, and is part of the upd share)
inline std::string format_progress(const IterationStats& s, long long total_iterations) {
  const double t = s.time_sim + s.time_inference + s.time_update;
  auto pct = [&](double x) { return t > 0 ? 100.0 * x / t : 0.0; };
  char ep[32];
  if (std::isfinite(s.episode_length)) std::snprintf(ep, sizeof ep, "%5.2f s", s.episode_length);
  else std::snprintf(ep, sizeof ep, "  -- s");
  char total[32] = "";
  if (total_iterations > 0) std::snprintf(total, sizeof total, "/%lld", total_iterations);
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "it %6lld%s | %6.0f sps | ep %s | r_D %.3f | KL_MI %.4f | sim %2.0f%% inf %2.0f%% upd %2.0f%% (disc %2.0f%%) | ETA %s%s",
                s.iteration, total, s.samples_per_s, ep, s.disc_reward, s.mi_kl, pct(s.time_sim),
                pct(s.time_inference), pct(s.time_update), pct(s.time_disc), format_duration(s.eta_s).c_str(),
                s.skipped_updates > 0 ? " | SKIPPED non-finite updates" : "");
  return buf;
}

}  // namespace maskadapt::train
