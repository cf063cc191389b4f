#pragma once
/// \file serialize.hpp
/// Saving nn objects into a Checkpoint and loading them back, validate-then-copy.
///
/// Section names under a caller-chosen prefix (e.g. "actor"):
///   Mlp              prefix.spec  (JSON string)   prefix.block (4·n array: params|grads|adam_m|adam_v)
///   ParameterBlock   prefix       (4·n array)
///   Adam             prefix.step  (int64)
///   RunningNormalizer prefix.count (f64), prefix.mean, prefix.m2 (f64 vectors)
///   PopArt           prefix.mean, prefix.nu (f64 vectors)
///
/// Every `load_*` checks every section it needs (presence, dtype, shape, spec) BEFORE writing
/// anything, so a failing load leaves the object untouched. To restore several objects
/// atomically, call the matching `check_*` functions for all of them first (or load into copies and
/// move-assign them on success).
#include <string>

#include <nlohmann/json.hpp>

#include "maskadapt/core/checkpoint.hpp"
#include "maskadapt/core/error.hpp"
#include "maskadapt/nn/adam.hpp"
#include "maskadapt/nn/mlp.hpp"
#include "maskadapt/nn/normalizer.hpp"
#include "maskadapt/nn/popart.hpp"

namespace maskadapt::nn {

inline std::string mlp_spec_to_json(const MlpSpec& s) {
  nlohmann::json j;
  j["inputs"] = s.inputs;
  j["hidden"] = s.hidden;
  j["outputs"] = s.outputs;
  j["activation"] = std::string(to_string(s.activation));
  j["output_activation"] = std::string(to_string(s.output_activation));
  return j.dump();
}

/// Parses mlp_spec_to_json's output; throws maskadapt::Error naming `where` on malformed text.
inline MlpSpec mlp_spec_from_json(const std::string& text, const std::string& where = "mlp spec") {
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    MlpSpec s;
    s.inputs = j.at("inputs").get<Index>();
    s.hidden = j.at("hidden").get<std::vector<Index>>();
    s.outputs = j.at("outputs").get<Index>();
    s.activation = activation_from_string(j.at("activation").get<std::string>());
    s.output_activation = activation_from_string(j.at("output_activation").get<std::string>());
    s.validate();
    return s;
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("malformed MLP spec: ") + e.what(), {{}, std::nullopt, where});
  }
}

// ---- ParameterBlock -------------------------------------------------------------------------
template <class T>
void save(Checkpoint& c, const std::string& prefix, const ParameterBlock<T>& b) {
  c.put(prefix, b.storage());
}
template <class T>
void check(const Checkpoint& c, const std::string& prefix, const ParameterBlock<T>& b) {
  (void)c.get_vector<T>(prefix, b.storage().size());
}
template <class T>
void load(const Checkpoint& c, const std::string& prefix, ParameterBlock<T>& b) {
  c.copy_to<T>(prefix, b.storage());  // validates dtype + size before copying
}

// ---- Mlp --------------------------------------------------------------------------------------
template <class T>
void save(Checkpoint& c, const std::string& prefix, const Mlp<T>& net) {
  c.put_string(prefix + ".spec", mlp_spec_to_json(net.spec()));
  save(c, prefix + ".block", net.block());
}
/// Throws unless `prefix` holds an Mlp with exactly net's spec.
template <class T>
void check(const Checkpoint& c, const std::string& prefix, const Mlp<T>& net) {
  const MlpSpec s = mlp_spec_from_json(c.get_string(prefix + ".spec"), prefix + ".spec");
  if (!(s == net.spec()))
    throw Error("architecture mismatch: checkpoint has " + mlp_spec_to_json(s) + ", model is " + mlp_spec_to_json(net.spec()),
                {c.source(), std::nullopt, prefix + ".spec"});
  check(c, prefix + ".block", net.block());
}
template <class T>
void load(const Checkpoint& c, const std::string& prefix, Mlp<T>& net) {
  check(c, prefix, net);
  load(c, prefix + ".block", net.block());
}
/// Builds the network described by the checkpoint.
template <class T>
Mlp<T> load_mlp(const Checkpoint& c, const std::string& prefix) {
  Mlp<T> net(mlp_spec_from_json(c.get_string(prefix + ".spec"), prefix + ".spec"));
  load(c, prefix, net);
  return net;
}

// ---- Adam ---------------------------------------------------------------------------------
template <class T>
void save(Checkpoint& c, const std::string& prefix, const Adam<T>& opt) {
  c.put_int(prefix + ".step", opt.step_count());
}
template <class T>
void check(const Checkpoint& c, const std::string& prefix, const Adam<T>&) {
  require(c.get_int(prefix + ".step") >= 0, "negative step count", {c.source(), std::nullopt, prefix + ".step"});
}
template <class T>
void load(const Checkpoint& c, const std::string& prefix, Adam<T>& opt) {
  Adam<T> tmp = opt;
  check(c, prefix, tmp);
  opt.set_step_count(c.get_int(prefix + ".step"));
}

// ---- RunningNormalizer ----------------------------------------------------------------------
template <class T>
void save(Checkpoint& c, const std::string& prefix, const RunningNormalizer<T>& n) {
  c.put_double(prefix + ".count", n.count());
  c.put(prefix + ".mean", n.mean());
  c.put(prefix + ".m2", n.m2());
}
template <class T>
void check(const Checkpoint& c, const std::string& prefix, const RunningNormalizer<T>& n) {
  RunningNormalizer<T> tmp = n;
  load(c, prefix, tmp);
}
template <class T>
void load(const Checkpoint& c, const std::string& prefix, RunningNormalizer<T>& n) {
  const double count = c.get_double(prefix + ".count");
  const VectorXd mean = c.get_vector<double>(prefix + ".mean", n.dim());
  const VectorXd m2 = c.get_vector<double>(prefix + ".m2", n.dim());
  n.set_state(count, mean, m2);  // validates before assigning
}

// ---- PopArt ---------------------------------------------------------------------------------
template <class T>
void save(Checkpoint& c, const std::string& prefix, const PopArt<T>& p) {
  c.put(prefix + ".mean", p.mean());
  c.put(prefix + ".nu", p.second_moment());
}
template <class T>
void check(const Checkpoint& c, const std::string& prefix, const PopArt<T>& p) {
  PopArt<T> tmp = p;
  load(c, prefix, tmp);
}
template <class T>
void load(const Checkpoint& c, const std::string& prefix, PopArt<T>& p) {
  const VectorXd mean = c.get_vector<double>(prefix + ".mean", p.num_objectives());
  const VectorXd nu = c.get_vector<double>(prefix + ".nu", p.num_objectives());
  p.set_state(mean, nu);
}

}  // namespace maskadapt::nn
