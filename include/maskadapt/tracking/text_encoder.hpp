#pragma once
/// \file text_encoder.hpp
/// Text → feature vector, without downloading any model.
///
/// The built-in `HashedTextFeatures` is a deterministic **stand-in for CLIP**: the text is
/// lower-cased and split into words (runs of letters/digits); every word unigram and every
/// adjacent word bigram is hashed (64-bit FNV-1a) into one of `dim` buckets with a hashed sign
/// (±1), and the vector is L2-normalised. It knows nothing of meaning beyond shared words
/// ("raise arms" and "raise both arms" overlap, "punch" and "kick" do not); the generator learns a
/// linear projection of these features jointly with its denoiser, so the embedding the network
/// sees is trained. The features are identical on every platform (no std::hash).
///
/// Users with real embeddings (e.g. CLIP computed elsewhere) plug them in through
/// `EmbeddingTable`, or through any type satisfying `TextFeaturizer`.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <nlohmann/json.hpp>

#include <cctype>
#include <concepts>
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt::tracking {

/// What the generator needs from a text front end: a fixed dimension and a deterministic map
/// from a prompt to a (dim) float vector. (The generator's learned projection follows it.)
template <class F>
concept TextFeaturizer = requires(const F& f, std::string_view text) {
  { f.dim() } -> std::convertible_to<Index>;
  { f.features(text) } -> std::same_as<VectorXf>;  // (dim)
};

/// Lower-cased words of `text` (runs of ASCII letters/digits; everything else separates).
inline std::vector<std::string> tokenize_words(std::string_view text) {
  std::vector<std::string> words;
  std::string cur;
  for (char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (std::isalnum(c)) {
      cur.push_back(static_cast<char>(std::tolower(c)));
    } else if (!cur.empty()) {
      words.push_back(std::move(cur));
      cur.clear();
    }
  }
  if (!cur.empty()) words.push_back(std::move(cur));
  return words;
}

/// 64-bit FNV-1a of a byte string.
inline std::uint64_t fnv1a64(std::string_view s, std::uint64_t h = 0xcbf29ce484222325ULL) {
  for (char ch : s) {
    h ^= static_cast<unsigned char>(ch);
    h *= 0x100000001b3ULL;
  }
  return h;
}

/// Hashed unigram + bigram features (see file comment). Empty text → the zero vector.
class HashedTextFeatures {
 public:
  explicit HashedTextFeatures(Index dim = 256, float bigram_weight = 0.7f) : dim_(dim), bigram_weight_(bigram_weight) {
    require(dim >= 8, "hashed text feature dimension must be ≥ 8", {{}, {}, "text_dim"});
  }
  Index dim() const { return dim_; }

  VectorXf features(std::string_view text) const {
    VectorXf v = VectorXf::Zero(dim_);
    const auto words = tokenize_words(text);
    for (std::size_t i = 0; i < words.size(); ++i) {
      add(v, "w:" + words[i], 1.0f);
      if (i + 1 < words.size()) add(v, "b:" + words[i] + " " + words[i + 1], bigram_weight_);
    }
    const float n = v.norm();
    if (n > 0.0f) v /= n;
    return v;
  }

 private:
  void add(VectorXf& v, const std::string& token, float w) const {
    const std::uint64_t h = fnv1a64(token);
    const auto bucket = static_cast<Index>(h % static_cast<std::uint64_t>(dim_));
    const float sign = ((h >> 63) & 1u) ? -1.0f : 1.0f;
    v[bucket] += sign * w;
  }

  Index dim_;
  float bigram_weight_;
};

/// Embeddings computed elsewhere (e.g. CLIP), looked up by exact prompt text.
/// JSON file format: {"dim": 512, "embeddings": {"raise arms": [0.1, …], …}}.
class EmbeddingTable {
 public:
  EmbeddingTable() = default;
  explicit EmbeddingTable(Index dim) : dim_(dim) {}

  Index dim() const { return dim_; }
  void add(const std::string& text, const VectorXf& e) {
    require(e.size() == dim_, "embedding for '" + text + "' has " + std::to_string(e.size()) +
                                  " values, expected " + std::to_string(dim_), {{}, {}, "embedding"});
    require_finite(e, "embedding '" + text + "'");
    table_[text] = e;
  }
  bool contains(std::string_view text) const { return table_.count(std::string(text)) > 0; }

  /// Throws (naming the prompt) when the text has no stored embedding.
  VectorXf features(std::string_view text) const {
    const auto it = table_.find(std::string(text));
    require(it != table_.end(), "no embedding stored for prompt '" + std::string(text) + "'", {{}, {}, "text"});
    return it->second;
  }

  static EmbeddingTable load_json(const std::string& path) {
    std::ifstream in(path);
    require(static_cast<bool>(in), "cannot open embedding file", {path, {}, {}});
    nlohmann::json j;
    try {
      in >> j;
    } catch (const std::exception& e) {
      throw Error(std::string("malformed JSON: ") + e.what(), {path, {}, {}});
    }
    require(j.contains("dim") && j["dim"].is_number_integer(), "missing integer 'dim'", {path, {}, "dim"});
    require(j.contains("embeddings") && j["embeddings"].is_object(), "missing object 'embeddings'",
            {path, {}, "embeddings"});
    EmbeddingTable t(j["dim"].get<Index>());
    for (const auto& [text, arr] : j["embeddings"].items()) {
      require(arr.is_array() && static_cast<Index>(arr.size()) == t.dim_,
              "embedding must be an array of 'dim' numbers", {path, {}, "embeddings." + text});
      VectorXf e(t.dim_);
      for (Index i = 0; i < t.dim_; ++i) {
        require(arr[static_cast<std::size_t>(i)].is_number(), "non-numeric value", {path, {}, "embeddings." + text});
        e[i] = arr[static_cast<std::size_t>(i)].get<float>();
      }
      try {
        t.add(text, e);
      } catch (const Error& err) {
        throw Error(err.message(), {path, {}, "embeddings." + text});
      }
    }
    return t;
  }

 private:
  Index dim_ = 0;
  std::map<std::string, VectorXf, std::less<>> table_;
};

static_assert(TextFeaturizer<HashedTextFeatures>);
static_assert(TextFeaturizer<EmbeddingTable>);

}  // namespace maskadapt::tracking
