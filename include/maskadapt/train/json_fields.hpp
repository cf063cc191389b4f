#pragma once
/// \file json_fields.hpp
/// Strict reading of JSON config objects: every field is type-checked, unknown keys are
/// rejected, and every error names the file and the dotted field path ("ppo.actor_lr").
#include <maskadapt/core/error.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

namespace maskadapt::train {

/// Reads the members of one JSON object. Call `get` for every field the schema knows, then
/// `finish()`, which throws if the object held any key that was never asked for.
class JsonObjectReader {
 public:
  /// `path` is the dotted prefix of this object ("" at the top level); `file` names the source.
  JsonObjectReader(const nlohmann::json& object, std::string path, std::string file)
      : j_(object), path_(std::move(path)), file_(std::move(file)) {
    if (!j_.is_object()) fail(path_.empty() ? "config" : path_, "expected a JSON object, got " + type_name(j_));
  }

  /// Reads `key` into `out` if present (leaves `out` untouched otherwise).
  template <class T>
  void get(const std::string& key, T& out) {
    known_.insert(key);
    auto it = j_.find(key);
    if (it == j_.end()) return;
    read_value(*it, field(key), out);
  }

  /// A nested object reader for `key` (an empty object when absent).
  JsonObjectReader child(const std::string& key) {
    known_.insert(key);
    auto it = j_.find(key);
    static const nlohmann::json empty = nlohmann::json::object();
    return JsonObjectReader(it == j_.end() ? empty : *it, field(key), file_);
  }

  /// Throws naming the first key that no `get`/`child` asked for.
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!known_.count(it.key())) {
        std::string allowed;
        for (const auto& k : known_) allowed += (allowed.empty() ? "" : ", ") + k;
        fail(field(it.key()), "unknown key (allowed here: " + allowed + ")");
      }
  }

  std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw Error(message, {file_, std::nullopt, field});
  }

 private:
  static std::string type_name(const nlohmann::json& v) { return v.type_name(); }

  void read_value(const nlohmann::json& v, const std::string& f, bool& out) const {
    if (!v.is_boolean()) fail(f, "expected true/false, got " + type_name(v));
    out = v.get<bool>();
  }
  void read_value(const nlohmann::json& v, const std::string& f, double& out) const {
    if (!v.is_number()) fail(f, "expected a number, got " + type_name(v));
    out = v.get<double>();
    if (!std::isfinite(out)) fail(f, "expected a finite number");
  }
  template <class I>
    requires std::is_integral_v<I>
  void read_value(const nlohmann::json& v, const std::string& f, I& out) const {
    if (!v.is_number_integer()) fail(f, "expected an integer, got " + type_name(v) + " " + v.dump());
    if (v.is_number_unsigned()) {
      const auto u = v.get<std::uint64_t>();
      if (u > static_cast<std::uint64_t>(std::numeric_limits<I>::max())) fail(f, "integer out of range: " + v.dump());
      out = static_cast<I>(u);
    } else {
      const auto s = v.get<std::int64_t>();
      if (s < static_cast<std::int64_t>(std::numeric_limits<I>::min()) ||
          (s > 0 && static_cast<std::uint64_t>(s) > static_cast<std::uint64_t>(std::numeric_limits<I>::max())))
        fail(f, "integer out of range: " + v.dump());
      out = static_cast<I>(s);
    }
  }
  void read_value(const nlohmann::json& v, const std::string& f, std::string& out) const {
    if (!v.is_string()) fail(f, "expected a string, got " + type_name(v));
    out = v.get<std::string>();
  }
  template <class E>
  void read_value(const nlohmann::json& v, const std::string& f, std::vector<E>& out) const {
    if (!v.is_array()) fail(f, "expected an array, got " + type_name(v));
    std::vector<E> r(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) read_value(v[i], f + "[" + std::to_string(i) + "]", r[i]);
    out = std::move(r);
  }

  const nlohmann::json& j_;
  std::string path_;
  std::string file_;
  std::set<std::string> known_;
};

}  // namespace maskadapt::train
