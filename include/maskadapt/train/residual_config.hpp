#pragma once
/// \file residual_config.hpp
/// Stage-2 run settings (ResidualTrainConfig and its JSON form) and the networks a residual run
/// starts from: the frozen base actor of a stage-1 checkpoint (FrozenBase), the scratch
/// method's zero base, and the residual policy stored in a train-residual checkpoint.
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/tasks/action_space.hpp>
#include <maskadapt/tracking/goals.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/config.hpp>

#include <nlohmann/json.hpp>

#include <array>
#include <cmath>

#include <string>
#include <vector>

namespace maskadapt::train {

/// Stage-2 settings; `rl` carries run / env / ppo / disc / net sections of the stage-1 format
/// (env.motions = the base motion set A; net.critic_hidden / disc_hidden size the new critic and
/// discriminators).
struct ResidualTrainConfig {
  BaseTrainConfig rl;
  std::string task = "composition";   ///< composition | tracking | location | heading | strike
  std::string method = "ours";        ///< ours | cml | scratch (no base: a zero base, every DoF residual) | adaptnet (goal tasks)
  std::vector<std::string> new_motions;            ///< M_new (composition)
  std::vector<std::string> masks = {"lower_body"}; ///< training mask set (cml / tracking: the first = fixed region)
  double switch_rate = 0.0;           ///< mid-episode mask switches per second (ours)
  double negative_fraction = 0.25;    ///< share of the fake batch that is negative-expert blends (ours)
  /// composition: share of episode resets drawn from the part-wise blends (B on the adapted parts,
  /// A on the rest) instead of from A; 0 = every reset from A (train/motion_sources.hpp)
  double blend_resets = 0.0;
  std::vector<double> objective_weights;  ///< empty: cml 0.5/0.5, tracking 0.5/0.5, ours 1
  /// Per-part credit (Stage2Learner's PartCredit): the objective weights that the residual's DoFs
  /// of a body part are credited with, one per objective as objective_weights; an empty entry =
  /// objective_weights. All empty (the default) = the paper's PPO: one advantage for every DoF.
  std::array<std::vector<double>, kNumParts> part_objective_weights{};
  std::vector<Index> residual_hidden = {256, 256};
  std::string gain = "scalar";        ///< fixed | scalar | per_dof
  double init_gain = 1.0;
  double residual_std = 0.0;          ///< σ_ψ of the residual (action units); 0 = the base's σ (adapt::ResidualConfig::init_std)
  /// σ_ψ per body part, over residual_std on that part's DoFs; 0 = residual_std (adapt::ResidualConfig::part_std)
  std::array<double, kNumParts> residual_part_std{};
  /// Exploration noise held for this many control steps (1 = fresh noise every step, the paper's
  /// PPO). With k > 1 each env draws the composite's deviation a − μ̂ once every k steps (and at
  /// every episode start) and adds that same deviation to the mean of the next k − 1 steps, so
  /// the exploration is a piecewise-constant offset rather than 30 Hz white noise (a steering
  /// change lasts long enough to turn the walker). Every step stays one PPO sample whose
  /// log-probability is taken under that step's Gaussian, as with state-dependent exploration
  /// (gSDE's sample frequency). Evaluation uses the mean and is unaffected.
  int noise_hold_steps = 1;
  /// σ_ψ decay: every residual DoF's σ falls geometrically from its initial value (residual_std /
  /// residual_part_std / the base's) to `residual_std_decay_factor` times it over the first
  /// `residual_std_decay_iterations` iterations, σ(it) = σ(0)·factor^min(1, it / iterations), set at
  /// the start of each iteration (so one iteration's rollout and update share one σ; a resumed run
  /// continues the schedule bit-exactly). 1 / 0 = a fixed σ, the paper's. Residual methods only
  /// (AdaptNet's σ is its own).
  double residual_std_decay_factor = 1.0;
  int residual_std_decay_iterations = 0;
  bool decays_std() const { return residual_std_decay_iterations > 0 && residual_std_decay_factor != 1.0; }
  /// location: weight w of the facing shaping term (tasks::LocationConfig::facing_weight; 0 = the
  /// paper's reward)
  double location_facing_weight = 0.0;
  /// location: weight p of the position shaping term (tasks::LocationConfig::position_weight; 0 =
  /// the paper's reward; location_facing_weight + p <= 1)
  double location_position_weight = 0.0;
  /// location, training only: targets drawn this far from the root (m; tasks::LocationConfig's
  /// min/max_distance; evaluation always draws the defaults, 1–5 m)
  double location_min_distance = 1.0, location_max_distance = 5.0;
  /// location, training only: end the episode once the target is this much farther than when
  /// drawn (m; tasks::LocationConfig::divergence_distance; 0 = never, the paper's)
  double location_divergence = 0.0;
  /// location, training only: the velocity term's target speed falls to 0 at the target,
  /// v*·min(1, d/ρ) (m; tasks::LocationConfig::arrive_distance; 0 = v* everywhere, the paper's)
  double location_arrive_distance = 0.0;
  /// location, training only: reward on reaching a target, which is then redrawn at once
  /// (tasks::LocationConfig::reach_bonus; 0 = none, the paper's)
  double location_reach_bonus = 0.0;
  /// strike: weight w of the approach shaping term (tasks::StrikeConfig::approach_weight; 0 = the
  /// paper's reward)
  double strike_approach_weight = 0.0;
  /// strike, training only: boxes placed this far from the root (m; tasks::StrikeConfig's
  /// min/max_distance; evaluation always places them 1–3 m away, the paper's)
  double strike_min_distance = 1.0, strike_max_distance = 3.0;
  /// strike, training only: a first contact by a body other than the hands ends the episode
  /// (tasks::StrikeConfig::end_on_foreign_contact; ASE's rule; false = the paper's)
  bool strike_end_on_foreign_contact = false;
  /// strike, training only: a new box this many control steps after the box tilted
  /// (tasks::StrikeConfig::next_box_steps; 0 = one box per episode, the paper's)
  int strike_next_box_steps = 0;
  // tracking
  std::string designated = "arms";    ///< parts that follow the generated trajectory
  std::vector<std::string> texts;     ///< prompts sampled for the goals; empty: the generator's arms pool (else the clips')
  // goal tasks
  std::string goal_parts;             ///< parts the residual also moves for the goal ("" none; adapt::ResidualConfig::goal_parts)
  Index goal_steps = 2;               ///< next target frames in the goal
  int sample_every = 20;              ///< refill the goal buffer every N iterations
  int goal_trajectories = 16;         ///< trajectories per refill
  double term_window_s = 1.0;         ///< windowed-average early termination window (s)
  double term_threshold = 0.05;       ///< … ends the goal episode when the mean tracking reward < this
  double tracking_reward_scale = 1.0; ///< k of the tracking reward exp(−k·Σ angle²) (1: the paper's)
  std::string generator;              ///< generator checkpoint (CLI)
  std::string base_checkpoint;        ///< stage-1 checkpoint (CLI; recorded for provenance)

  /// Whether any part has its own objective weights (per-part credit on).
  bool has_part_credit() const {
    for (const auto& w : part_objective_weights)
      if (!w.empty()) return true;
    return false;
  }

  void validate() const {
    rl.validate("residual config");
    require(task == "composition" || task == "tracking" || task == "location" || task == "heading" || task == "strike",
            "expected composition, tracking, location, heading or strike", {{}, {}, "task"});
    require(method == "ours" || method == "cml" || method == "scratch" || method == "adaptnet",
            "expected ours, cml, scratch or adaptnet", {{}, {}, "method"});
    require(method != "adaptnet" || task == "location" || task == "heading" || task == "strike",
            "adaptnet adapts the base to a goal task (location, heading or strike), not to " + task, {{}, {}, "method"});
    require(!masks.empty(), "need at least one mask", {{}, {}, "masks"});
    require(switch_rate >= 0, "must be ≥ 0", {{}, {}, "switch_rate"});
    require(std::isfinite(residual_std) && residual_std >= 0, "must be finite and ≥ 0 (0 = the base's σ)",
            {{}, {}, "residual_std"});
    for (std::size_t p = 0; p < residual_part_std.size(); ++p)
      require(std::isfinite(residual_part_std[p]) && residual_part_std[p] >= 0 && residual_part_std[p] <= 10,
              "must be finite and in [0, 10] (0 = residual_std)", {{}, {}, "residual_part_std." + std::string(kPartNames[p])});
    require(negative_fraction >= 0 && negative_fraction < 1, "must be in [0, 1)", {{}, {}, "negative_fraction"});
    require(std::isfinite(blend_resets) && blend_resets >= 0 && blend_resets <= 1, "must be in [0, 1]",
            {{}, {}, "blend_resets"});
    require(blend_resets == 0 || task == "composition", "resets from blends need the composition task, not " + task,
            {{}, {}, "blend_resets"});
    require(goal_steps >= 1 && sample_every >= 1 && goal_trajectories >= 1, "tracking counts must be ≥ 1", {{}, {}, "tracking"});
    require(term_window_s > 0, "must be > 0", {{}, {}, "term_window_s"});
    require(std::isfinite(tracking_reward_scale) && tracking_reward_scale > 0 && tracking_reward_scale <= 100,
            "must be in (0, 100]", {{}, {}, "tracking_reward_scale"});
    require(tracking_reward_scale == 1.0 || task == "tracking", "the tracking reward scale is the tracking task's, not " + task + "'s",
            {{}, {}, "tracking_reward_scale"});
    require(noise_hold_steps >= 1 && noise_hold_steps <= 100000, "must be in [1, 100000] control steps",
            {{}, {}, "noise_hold_steps"});
    require(std::isfinite(residual_std_decay_factor) && residual_std_decay_factor > 0 && residual_std_decay_factor <= 1,
            "the factor must be in (0, 1] (1 = a fixed σ), got " + nlohmann::json(residual_std_decay_factor).dump(),
            {{}, {}, "residual_std_decay"});
    require(residual_std_decay_iterations >= 0, "the iterations must be >= 0 (0 = a fixed σ)", {{}, {}, "residual_std_decay"});
    require(!decays_std() || method != "adaptnet", "AdaptNet explores with its own σ; the decay is the residual's",
            {{}, {}, "residual_std_decay"});
    require(std::isfinite(location_facing_weight) && location_facing_weight >= 0 && location_facing_weight <= 1,
            "must be in [0, 1]", {{}, {}, "location_facing_weight"});
    require(location_facing_weight == 0 || task == "location",
            "the facing shaping term is the location task's, not " + task + "'s", {{}, {}, "location_facing_weight"});
    require(std::isfinite(location_position_weight) && location_position_weight >= 0 &&
                location_facing_weight + location_position_weight <= 1,
            "must be >= 0, with location_facing_weight + location_position_weight <= 1", {{}, {}, "location_position_weight"});
    require(location_position_weight == 0 || task == "location",
            "the position shaping term is the location task's, not " + task + "'s", {{}, {}, "location_position_weight"});
    require(std::isfinite(location_min_distance) && std::isfinite(location_max_distance) && location_min_distance > 0 &&
                location_max_distance >= location_min_distance && location_max_distance <= 100,
            "need 0 < min <= max <= 100 m", {{}, {}, "location_distance"});
    require(task == "location" || (location_min_distance == 1.0 && location_max_distance == 5.0),
            "target distances are the location task's, not " + task + "'s", {{}, {}, "location_distance"});
    require(std::isfinite(location_divergence) && location_divergence >= 0, "must be finite and >= 0 m (0 = never)",
            {{}, {}, "location_divergence"});
    require(std::isfinite(location_arrive_distance) && location_arrive_distance >= 0 && location_arrive_distance <= 100,
            "must be in [0, 100] m (0 = off)", {{}, {}, "location_arrive_distance"});
    require(location_arrive_distance == 0 || task == "location",
            "the arrive shaping is the location task's, not " + task + "'s", {{}, {}, "location_arrive_distance"});
    require(std::isfinite(location_reach_bonus) && location_reach_bonus >= 0 && location_reach_bonus <= 1000,
            "must be in [0, 1000] (0 = off)", {{}, {}, "location_reach_bonus"});
    require(location_reach_bonus == 0 || task == "location",
            "the reach bonus is the location task's, not " + task + "'s", {{}, {}, "location_reach_bonus"});
    require(location_divergence == 0 || task == "location",
            "the divergence termination is the location task's, not " + task + "'s", {{}, {}, "location_divergence"});
    require(std::isfinite(strike_approach_weight) && strike_approach_weight >= 0 && strike_approach_weight <= 1,
            "must be in [0, 1]", {{}, {}, "strike_approach_weight"});
    require(strike_approach_weight == 0 || task == "strike",
            "the approach shaping term is the strike task's, not " + task + "'s", {{}, {}, "strike_approach_weight"});
    require(std::isfinite(strike_min_distance) && std::isfinite(strike_max_distance) && strike_min_distance > 0 &&
                strike_max_distance >= strike_min_distance && strike_max_distance <= 100,
            "need 0 < min <= max <= 100 m", {{}, {}, "strike_distance"});
    require(task == "strike" || (strike_min_distance == 1.0 && strike_max_distance == 3.0),
            "box distances are the strike task's, not " + task + "'s", {{}, {}, "strike_distance"});
    require(!strike_end_on_foreign_contact || task == "strike",
            "the foreign-contact termination is the strike task's, not " + task + "'s", {{}, {}, "strike_end_on_foreign_contact"});
    require(strike_next_box_steps >= 0 && strike_next_box_steps <= 100000, "must be in [0, 100000] steps (0 = off)",
            {{}, {}, "strike_next_box_steps"});
    require(strike_next_box_steps == 0 || task == "strike",
            "the next box is the strike task's, not " + task + "'s", {{}, {}, "strike_next_box_steps"});
    for (const double w : objective_weights)
      require(std::isfinite(w) && w >= 0, "every objective weight must be finite and ≥ 0", {{}, {}, "objective_weights"});
    for (std::size_t p = 0; p < part_objective_weights.size(); ++p)
      for (const double w : part_objective_weights[p])
        require(std::isfinite(w) && w >= 0, "every objective weight must be finite and ≥ 0",
                {{}, {}, "part_objective_weights." + std::string(kPartNames[p])});
    require(method != "adaptnet" || !has_part_credit(),
            "per-part credit needs a residual's per-DoF log-probabilities; AdaptNet has none", {{}, {}, "part_objective_weights"});
    if (!goal_parts.empty()) {
      (void)PartMask::parse(goal_parts, "goal_parts");
      require(task == "location" || task == "heading" || task == "strike",
              "goal parts are for the goal tasks (location, heading, strike), not " + task, {{}, {}, "goal_parts"});
    }
    (void)adapt::gain_mode_from_name(gain);
  }
};

/// Per-part σ as JSON: {"left_arm": 0.15, …}, the parts set (> 0) only.
inline nlohmann::json part_std_to_json(const std::array<double, kNumParts>& s) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t p = 0; p < s.size(); ++p)
    if (s[p] > 0) j[std::string(kPartNames[p])] = s[p];
  return j;
}

/// The inverse of part_std_to_json; an unknown part name or a non-number throws naming it.
inline std::array<double, kNumParts> part_std_from_json(const nlohmann::json& j, const std::string& file = {}) {
  std::array<double, kNumParts> s{};
  if (!j.is_object()) throw Error("expected an object {part: σ}", {file, std::nullopt, "residual_part_std"});
  for (const auto& [name, v] : j.items()) {
    const auto part = part_from_name(name);
    if (!part) throw Error("unknown body part '" + name + "'", {file, std::nullopt, "residual_part_std"});
    if (!v.is_number()) throw Error("σ must be a number", {file, std::nullopt, "residual_part_std." + name});
    s[static_cast<std::size_t>(*part)] = v.get<double>();
  }
  return s;
}

/// Per-part objective weights as JSON: {"left_arm": [1, 0], …}, the parts set only.
inline nlohmann::json part_weights_to_json(const std::array<std::vector<double>, kNumParts>& w) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t p = 0; p < w.size(); ++p)
    if (!w[p].empty()) j[std::string(kPartNames[p])] = w[p];
  return j;
}

/// The inverse of part_weights_to_json; an unknown part name or a non-list of numbers throws naming it.
inline std::array<std::vector<double>, kNumParts> part_weights_from_json(const nlohmann::json& j, const std::string& file = {}) {
  std::array<std::vector<double>, kNumParts> w{};
  if (!j.is_object()) throw Error("expected an object {part: [weights]}", {file, std::nullopt, "part_objective_weights"});
  for (const auto& [name, v] : j.items()) {
    const auto part = part_from_name(name);
    if (!part) throw Error("unknown body part '" + name + "'", {file, std::nullopt, "part_objective_weights"});
    const std::string field = "part_objective_weights." + name;
    if (!v.is_array() || v.empty()) throw Error("expected a non-empty list of weights", {file, std::nullopt, field});
    for (const auto& x : v)
      if (!x.is_number()) throw Error("a weight must be a number", {file, std::nullopt, field});
    w[static_cast<std::size_t>(*part)] = v.get<std::vector<double>>();
  }
  return w;
}

/// Splits "PARTS=VALUE" items (part and group names as PartMask::parse) and gives each named part
/// the value `parse_value(value_text, item)` returns; a missing '=' (the message shows `form`) or a
/// part named twice throws naming `field` (a flag). Parts no item names keep Value{}.
template <class Value, class ParseValue>
std::array<Value, kNumParts> parse_part_items(const std::vector<std::string>& items, const std::string& field,
                                              const std::string& form, ParseValue&& parse_value) {
  std::array<Value, kNumParts> out{};
  std::array<bool, kNumParts> given{};
  for (const std::string& item : items) {
    const auto eq = item.rfind('=');
    require(eq != std::string::npos && eq > 0 && eq + 1 < item.size(), "expected " + form + ", got '" + item + "'", {{}, {}, field});
    const PartMask m = PartMask::parse(item.substr(0, eq), field);
    const Value v = parse_value(item.substr(eq + 1), item);
    for (std::size_t p = 0; p < static_cast<std::size_t>(kNumParts); ++p)
      if (m.has(static_cast<BodyPart>(p))) {
        require(!given[p], std::string(kPartNames[p]) + " is given twice", {{}, {}, field});
        given[p] = true;
        out[p] = v;
      }
  }
  return out;
}

/// `text` (one value of `item`) as a number; throws "WHAT 'text' in 'item' is not a number" naming `field`.
inline double parse_item_number(const std::string& text, const std::string& item, const std::string& what, const std::string& field) {
  double v = 0;
  std::size_t used = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;  // (not a number: refused below)
  }
  require(!text.empty() && used == text.size(), what + " '" + text + "' in '" + item + "' is not a number", {{}, {}, field});
  return v;
}

/// Parses "PARTS=w1,w2,…" items ("arms=1,0", "lower_body=0.1,0.9"; part and group names as
/// PartMask::parse) into per-part objective weights; a part named twice, a missing '=', a weight
/// that is not a finite number ≥ 0, or items with different numbers of weights throw naming `field`.
inline std::array<std::vector<double>, kNumParts> parse_part_weights(const std::vector<std::string>& items,
                                                                     const std::string& field) {
  std::size_t count = 0;
  return parse_part_items<std::vector<double>>(
      items, field, "PARTS=w1,w2,... (one weight per objective, e.g. arms=1,0)", [&](const std::string& text, const std::string& item) {
        std::vector<double> weights;
        for (std::size_t start = 0;;) {
          const std::size_t comma = text.find(',', start);
          const double v = parse_item_number(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start), item,
                                             "weight", field);
          require(std::isfinite(v) && v >= 0, "a weight must be finite and >= 0, got '" + item + "'", {{}, {}, field});
          weights.push_back(v);
          if (comma == std::string::npos) break;
          start = comma + 1;
        }
        require(count == 0 || weights.size() == count,
                "every item needs the same number of weights (one per objective), got '" + item + "'", {{}, {}, field});
        count = weights.size();
        return weights;
      });
}

/// Parses "PARTS=σ" items ("arms=0.15", "left_leg,right_leg=0.05"; part and group names as
/// PartMask::parse) into a σ per part (0 where no item names the part); a part named twice, a
/// missing '=', or a σ that is not a positive finite number throws naming `field` (a flag).
inline std::array<double, kNumParts> parse_part_std(const std::vector<std::string>& items, const std::string& field) {
  return parse_part_items<double>(items, field, "PARTS=σ (e.g. arms=0.15)", [&](const std::string& text, const std::string& item) {
    const double v = parse_item_number(text, item, "σ", field);
    require(std::isfinite(v) && v > 0 && v <= 10, "σ must be in (0, 10], got '" + item + "'", {{}, {}, field});
    return v;
  });
}

/// The two-number entry at `key` of a residual_config JSON (`what` says which, e.g. "[min, max]
/// (m)") into `first`, `second` ([a, b] when absent: written before the key existed); anything but
/// two numbers throws naming `file` and `key`.
inline void read_pair(const nlohmann::json& j, const std::string& key, double a, double b, const std::string& what,
                      const std::string& file, double& first, double& second) {
  const auto v = j.value(key, std::vector<double>{a, b});
  if (v.size() != 2) throw Error("expected " + what, {file, std::nullopt, key});
  first = v[0];
  second = v[1];
}

inline nlohmann::json to_json(const ResidualTrainConfig& c) {
  return {{"rl", to_json(c.rl)},
          {"task", c.task},
          {"method", c.method},
          {"new_motions", c.new_motions},
          {"masks", c.masks},
          {"switch_rate", c.switch_rate},
          {"negative_fraction", c.negative_fraction},
          {"blend_resets", c.blend_resets},
          {"objective_weights", c.objective_weights},
          {"part_objective_weights", part_weights_to_json(c.part_objective_weights)},
          {"residual_hidden", c.residual_hidden},
          {"gain", c.gain},
          {"init_gain", c.init_gain},
          {"residual_std", c.residual_std},
          {"residual_part_std", part_std_to_json(c.residual_part_std)},
          {"noise_hold_steps", c.noise_hold_steps},
          {"residual_std_decay", {c.residual_std_decay_factor, static_cast<double>(c.residual_std_decay_iterations)}},
          {"location_facing_weight", c.location_facing_weight},
          {"location_position_weight", c.location_position_weight},
          {"location_distance", {c.location_min_distance, c.location_max_distance}},
          {"location_divergence", c.location_divergence},
          {"location_arrive_distance", c.location_arrive_distance},
          {"location_reach_bonus", c.location_reach_bonus},
          {"strike_approach_weight", c.strike_approach_weight},
          {"strike_distance", {c.strike_min_distance, c.strike_max_distance}},
          {"strike_end_on_foreign_contact", c.strike_end_on_foreign_contact},
          {"strike_next_box_steps", c.strike_next_box_steps},
          {"designated", c.designated},
          {"texts", c.texts},
          {"goal_parts", c.goal_parts},
          {"goal_steps", c.goal_steps},
          {"sample_every", c.sample_every},
          {"goal_trajectories", c.goal_trajectories},
          {"term_window_s", c.term_window_s},
          {"term_threshold", c.term_threshold},
          {"tracking_reward_scale", c.tracking_reward_scale},
          {"generator", c.generator},
          {"base_checkpoint", c.base_checkpoint}};
}

inline ResidualTrainConfig residual_config_from_json(const nlohmann::json& j, const std::string& file = {}) {
  ResidualTrainConfig c;
  try {
    c.rl = config_from_json(j.at("rl"), file);
    c.task = j.at("task");
    c.method = j.at("method");
    c.new_motions = j.at("new_motions").get<std::vector<std::string>>();
    c.masks = j.at("masks").get<std::vector<std::string>>();
    c.switch_rate = j.at("switch_rate");
    c.negative_fraction = j.at("negative_fraction");
    c.blend_resets = j.value("blend_resets", 0.0);  // (absent before it was recorded: every reset from A)
    c.objective_weights = j.at("objective_weights").get<std::vector<double>>();
    // (absent before per-part credit existed: off)
    c.part_objective_weights = part_weights_from_json(j.value("part_objective_weights", nlohmann::json::object()), file);
    c.residual_hidden = j.at("residual_hidden").get<std::vector<Index>>();
    c.gain = j.at("gain");
    c.init_gain = j.at("init_gain");
    c.residual_std = j.value("residual_std", 0.0);  // (absent before it was recorded: the base's σ)
    c.noise_hold_steps = j.value("noise_hold_steps", 1);  // (absent before it existed: fresh noise every step)
    {  // (absent before it existed: a fixed σ)
      double iterations = 0;
      read_pair(j, "residual_std_decay", 1.0, 0.0, "[factor, iterations]", file, c.residual_std_decay_factor, iterations);
      if (!(iterations >= 0 && iterations <= 1e9 && iterations == std::floor(iterations)))
        throw Error("the iterations must be a whole number >= 0", {file, std::nullopt, "residual_std_decay"});
      c.residual_std_decay_iterations = static_cast<int>(iterations);
    }
    c.location_facing_weight = j.value("location_facing_weight", 0.0);  // (absent before it existed: the paper's reward)
    c.location_position_weight = j.value("location_position_weight", 0.0);  // (absent before it existed: the paper's reward)
    // (the three below absent before they existed: every part at residual_std, 1–5 m, no divergence test)
    c.residual_part_std = part_std_from_json(j.value("residual_part_std", nlohmann::json::object()), file);
    read_pair(j, "location_distance", 1.0, 5.0, "[min, max] (m)", file, c.location_min_distance, c.location_max_distance);
    c.location_divergence = j.value("location_divergence", 0.0);
    c.location_arrive_distance = j.value("location_arrive_distance", 0.0);  // (absent before it existed: off)
    c.location_reach_bonus = j.value("location_reach_bonus", 0.0);          // (absent before it existed: off)
    c.strike_approach_weight = j.value("strike_approach_weight", 0.0);  // (absent before it existed: the paper's reward)
    // (the three below absent before they existed: the paper's 1–3 m, other bodies may touch, one box per episode)
    read_pair(j, "strike_distance", 1.0, 3.0, "[min, max] (m)", file, c.strike_min_distance, c.strike_max_distance);
    c.strike_end_on_foreign_contact = j.value("strike_end_on_foreign_contact", false);
    c.strike_next_box_steps = j.value("strike_next_box_steps", 0);
    c.designated = j.at("designated");
    c.texts = j.value("texts", std::vector<std::string>());  // (absent before it was recorded: the pool)
    c.goal_parts = j.value("goal_parts", std::string());  // (absent before goal parts existed: none)
    c.goal_steps = j.at("goal_steps");
    c.sample_every = j.at("sample_every");
    c.goal_trajectories = j.at("goal_trajectories");
    c.term_window_s = j.at("term_window_s");
    c.term_threshold = j.at("term_threshold");
    c.tracking_reward_scale = j.value("tracking_reward_scale", 1.0);  // (absent before it existed: the paper's reward)
    c.generator = j.at("generator");
    c.base_checkpoint = j.at("base_checkpoint");
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("bad residual config: ") + e.what(), {file, std::nullopt, "residual_config"});
  }
  c.validate();
  return c;
}

/// Activation by config name (relu | elu | silu | tanh).
inline nn::Activation residual_activation(const std::string& name) {
  if (name == "relu") return nn::Activation::ReLU;
  if (name == "elu") return nn::Activation::ELU;
  if (name == "silu") return nn::Activation::SiLU;
  if (name == "tanh") return nn::Activation::Tanh;
  throw Error("unknown activation '" + name + "'", {{}, std::nullopt, "net.activation"});
}

/// A frozen stage-1 actor and how its actions become PD targets.
struct FrozenBase {
  rl::GaussianActor<float> actor;
  tasks::ActionSpace actions;  ///< PD target = offset + scale ⊙ a (identity: a is the target)
};

/// The stage-1 actor stored in a base checkpoint (architecture from its "config" section) and its
/// action space (actor/action_offset, actor/action_scale; absent ⇒ identity). Reads only the
/// sections `config`, `actor/params`, `actor/log_std`, `actor/norm/…`, `actor/action_offset`,
/// `actor/action_scale`, so it works on a train-base checkpoint and on a policy-only export.
inline FrozenBase load_base_actor(const Checkpoint& ck, Index obs_dim, Index action_dim) {
  const BaseTrainConfig bc = config_from_string(ck.get_string("config"), "base checkpoint (config)");
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = obs_dim + kNumParts;
  ac.critic_input_dim = obs_dim;
  ac.action_dim = action_dim;
  ac.actor_hidden = bc.net.actor_hidden;
  ac.activation = residual_activation(bc.net.activation);
  ac.init_log_std = bc.net.init_log_std;
  Rng dummy(0);
  FrozenBase out{rl::GaussianActor<float>(ac, dummy), {}};
  ck.copy_to<float>("actor/params", out.actor.mean_net.params());
  ck.copy_to<float>("actor/log_std", out.actor.log_std.params());
  load_normalizer(ck, "actor/norm", out.actor.normalizer);
  load_hidden_groups(ck, out.actor);  // (a base trained with mask.hidden_value = mean)
  if (ck.contains("actor/action_offset")) out.actions.offset = ck.get_vector<float>("actor/action_offset", action_dim);
  if (ck.contains("actor/action_scale")) out.actions.scale = ck.get_vector<float>("actor/action_scale", action_dim);
  out.actions.validate(action_dim, ck.source().empty() ? "actor/action" : ck.source() + ": actor/action");
  return out;
}

/// Rows of a run's goal observation (tasks/goal_task.hpp): 0 for composition; tracking: the
/// designated bodies' next goal_steps frames; location 4, heading 3, strike 15.
inline Index task_goal_dim(const ResidualTrainConfig& c, const Skeleton& skel) {
  if (c.task == "tracking") return tracking::goal_dim(skel, PartMask::parse(c.designated, "designated"), c.goal_steps);
  if (c.task == "location") return 4;
  if (c.task == "heading") return 3;
  if (c.task == "strike") return 15;
  return 0;
}

/// The residual network settings of a run. Tracking with method cml: the base sees the full
/// observation (no mask invariance; see adapt::ResidualConfig::masked_base_input).
inline adapt::ResidualConfig residual_net_config(const ResidualTrainConfig& c, const Skeleton& skel) {
  adapt::ResidualConfig rc;
  rc.hidden = c.residual_hidden;
  rc.activation = residual_activation(c.rl.net.activation);
  rc.gain = adapt::gain_mode_from_name(c.gain);
  rc.init_gain = c.init_gain;
  rc.init_std = c.residual_std;
  rc.part_std = c.residual_part_std;
  rc.masked_base_input = !(c.task == "tracking" && c.method == "cml");
  rc.goal_dim = task_goal_dim(c, skel);
  rc.goal_parts = c.goal_parts.empty() ? PartMask::none() : PartMask::parse(c.goal_parts, "goal_parts");
  return rc;
}

/// A zero base actor for the from-scratch comparison: every DoF residual, base action 0.
inline rl::GaussianActor<float> scratch_base_actor(Index obs_dim, Index action_dim) {
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = obs_dim + kNumParts;
  ac.critic_input_dim = obs_dim;
  ac.action_dim = action_dim;
  ac.actor_hidden = {8};
  Rng r(0);
  rl::GaussianActor<float> a(ac, r);
  a.mean_net.params().setZero();
  return a;
}

/// The scratch method's base: the zero actor and the run config's action space (c.rl.net.action_*,
/// which must be resolved: resolve_action_space; zero / one ⇒ the identity, as before).
inline FrozenBase scratch_base(const ResidualTrainConfig& c, Index obs_dim, Index action_dim) {
  return {scratch_base_actor(obs_dim, action_dim), action_space_of(c.rl, action_dim)};
}

/// An actor with the architecture of a run's frozen base (c.rl.net, which train-residual copies
/// from the base checkpoint; scratch: the zero base). Parameters are placeholders until a
/// checkpoint's base/ sections are loaded.
inline rl::GaussianActor<float> base_actor_like(const ResidualTrainConfig& c, Index obs_dim, Index action_dim) {
  if (c.method == "scratch") return scratch_base_actor(obs_dim, action_dim);
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = obs_dim + kNumParts;
  ac.critic_input_dim = obs_dim;
  ac.action_dim = action_dim;
  ac.actor_hidden = c.rl.net.actor_hidden;
  ac.activation = residual_activation(c.rl.net.activation);
  ac.init_log_std = c.rl.net.init_log_std;
  Rng r(0);
  return rl::GaussianActor<float>(ac, r);
}

/// The residual policy (with its frozen base and the base's action space, base/actor/action_*)
/// stored in a train-residual checkpoint; `config` receives the run's config.
inline adapt::ResidualPolicy<float> residual_policy_from_checkpoint(const Checkpoint& ck, const Skeleton& skel,
                                                                    ResidualTrainConfig* config = nullptr) {
  const ResidualTrainConfig c = residual_config_from_json(nlohmann::json::parse(ck.get_string("residual_config")), "checkpoint");
  const Index obs_dim = observation_dim(skel), A = skel.num_dofs();
  const adapt::ResidualConfig rc = residual_net_config(c, skel);
  Rng init(0);
  adapt::ResidualPolicy<float> pol(base_actor_like(c, obs_dim, A), obs_dim, action_parts(skel), rc, init);
  pol.load(ck, true);
  if (config) *config = c;
  return pol;
}

}  // namespace maskadapt::train
