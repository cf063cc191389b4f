#pragma once
/// \file lexicon.hpp
/// Words a generator has not seen → words it has, through WordNet.
///
/// The built-in generator only knows the words of the texts it was trained on (the labels of its
/// clips: "arms high", "raise arms", "wave right hand", "walk", …). `HashedTextFeatures` hashes any
/// other word into a bucket whose projection was never trained, so "raise your hands" and "jog"
/// would condition it on noise. This header maps a prompt onto the training vocabulary *before*
/// featurisation:
///
/// - `WordNet` reads the WordNet 3.0 dictionary (Debian's `wordnet-base`: `index.{noun,verb,adj,adv}`,
///   `data.*`, `*.exc` under /usr/share/wordnet, or `$MASKADAPT_WORDNET_DIR`). Index and exception
///   files are parsed on load; each data file is kept in memory and a synset's line is parsed when
///   asked for (WordNet's own byte-offset access). A malformed line throws `Error` naming the file
///   and the 1-based line; a missing file names its path. `base_forms` is WordNet's *morphy*
///   (exception lists, then the detachment rules: "ran" → "run", "raising" → "raise"). When the
///   folder has `cntlist.rev` (the Semantic Concordance's sense tag counts), `tag_count` and
///   `sense_penalty` say how rare a sense is.
/// - `PromptVocabularyMapper` holds the vocabulary (the lower-cased words of the training texts)
///   and maps every word of a prompt (see `map` for the exact, deterministic rule): known words stay;
///   a known word's inflection → that word; otherwise the nearest known lemma in WordNet's graph
///   (synonyms, then one step of derivation / similarity / pertainym / verb group / part-of, or of
///   hypernym, …); unknown stop-words ("your", "a", "please") and words that reach nothing are
///   dropped. A prompt with words of which none is known and none maps throws `Error` naming the
///   prompt and its unknown words. A prompt whose words are all known is returned unchanged (so its
///   features are bit-for-bit those of the unmapped prompt). The search penalises rare word senses.
///   `lexical_landing` says which training texts a mapped prompt shares most idf-weighted words with
///   (`BuiltinGenerator::conditioning_text` conditions the generator on one of them).
#include <maskadapt/core/error.hpp>
#include <maskadapt/tracking/text_encoder.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <queue>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace maskadapt::tracking {

/// WordNet's four syntactic categories (satellite adjectives, ss_type 's', count as adjective).
enum class PartOfSpeech { noun = 0, verb = 1, adjective = 2, adverb = 3 };

/// The order in which the mapper tries them (actions first: prompts are mostly commands).
inline constexpr std::array<PartOfSpeech, 4> kPartsOfSpeech = {PartOfSpeech::verb, PartOfSpeech::noun,
                                                               PartOfSpeech::adjective, PartOfSpeech::adverb};

/// "noun", "verb", "adj", "adv": the suffix of WordNet's file names.
inline const char* wordnet_file_suffix(PartOfSpeech p) {
  switch (p) {
    case PartOfSpeech::noun: return "noun";
    case PartOfSpeech::verb: return "verb";
    case PartOfSpeech::adjective: return "adj";
    case PartOfSpeech::adverb: return "adv";
  }
  return "?";
}

/// One pointer of a synset: "@" hypernym, "~" hyponym, "+" derivationally related, "&" similar to, …
struct SynsetPointer {
  std::string symbol;
  PartOfSpeech pos = PartOfSpeech::noun;
  std::uint64_t offset = 0;  ///< byte offset of the target synset in data.<pos>
};

/// One synset, parsed from its data.<pos> line.
struct Synset {
  PartOfSpeech pos = PartOfSpeech::noun;
  std::uint64_t offset = 0;
  std::vector<std::string> lemmas;  ///< lower-cased, collocations joined by '_' ("swimming_stroke")
  std::vector<SynsetPointer> pointers;
  std::string gloss;
};

/// Where the dictionary is: $MASKADAPT_WORDNET_DIR, else $WNSEARCHDIR (WordNet's own variable),
/// else Debian's /usr/share/wordnet.
inline std::filesystem::path default_wordnet_dir() {
  for (const char* var : {"MASKADAPT_WORDNET_DIR", "WNSEARCHDIR"})
    if (const char* e = std::getenv(var); e && *e) return e;
  return "/usr/share/wordnet";
}

/// True when `dir` holds the twelve dictionary files `WordNet::load` reads.
inline bool wordnet_available(const std::filesystem::path& dir = default_wordnet_dir()) {
  for (const auto pos : kPartsOfSpeech) {
    const std::string s = wordnet_file_suffix(pos);
    for (const auto& f : {"index." + s, "data." + s, s + ".exc"})
      if (!std::filesystem::is_regular_file(dir / f)) return false;
  }
  return true;
}

class WordNet {
 public:
  /// Reads index.<pos>, <pos>.exc and data.<pos> for the four parts of speech from `dir`.
  /// Throws Error naming the path of a missing file, or the file and line of a malformed one.
  static WordNet load(const std::filesystem::path& dir = default_wordnet_dir()) {
    WordNet wn;
    wn.dir_ = dir;
    for (const auto pos : kPartsOfSpeech) {
      Part& part = wn.parts_[static_cast<std::size_t>(pos)];
      const std::string s = wordnet_file_suffix(pos);
      part.data_path = (dir / ("data." + s)).string();
      part.data = read_file(part.data_path);
      check_data_offsets(part.data, part.data_path);
      parse_index(read_file((dir / ("index." + s)).string()), (dir / ("index." + s)).string(), pos, part);
      parse_exceptions(read_file((dir / (s + ".exc")).string()), (dir / (s + ".exc")).string(), part);
    }
    if (const auto cnt = dir / "cntlist.rev"; std::filesystem::is_regular_file(cnt)) {
      wn.parse_tag_counts(read_file(cnt.string()), cnt.string());
      wn.has_tag_counts_ = true;
    }
    return wn;
  }

  /// True when the folder had `cntlist.rev` (the sense tag counts of the Semantic Concordance;
  /// Debian's wordnet-base ships it). Without it every tag count is 0.
  bool has_tag_counts() const { return has_tag_counts_; }

  /// How often sense `k` (0-based, index order) of `lemma` as `pos` was tagged in the Semantic
  /// Concordance (cntlist.rev; 0 when not listed). E.g. "hit" as a verb: 25 for sense 1, 3 for sense 8.
  std::uint32_t tag_count(std::string_view lemma, PartOfSpeech pos, std::size_t k) const {
    const auto& m = parts_[static_cast<std::size_t>(pos)].tag_counts;
    const auto it = m.find(std::string(lemma));
    return it == m.end() || k >= it->second.size() ? 0u : it->second[k];
  }

  /// How rare sense `k` (0-based) of `lemma` as `pos` is, in the mapper's cost units:
  ///   0.5 · log2((max_j tag_j + 1) / (tag_k + 1)) + 0.25 · k
  /// (tag counts over the lemma's senses as `pos`; the second term follows WordNet's sense order,
  /// itself by frequency, and is all there is without tag counts). 0 for the first, most tagged sense;
  /// "hit" sense 8 (3 tags against 25): 0.5·log2(26/4) + 1.75 ≈ 3.1.
  double sense_penalty(std::string_view lemma, PartOfSpeech pos, std::size_t k) const {
    const std::size_t n = senses(lemma, pos).size();
    std::uint32_t most = 0;
    for (std::size_t j = 0; j < n; ++j) most = std::max(most, tag_count(lemma, pos, j));
    return 0.5 * std::log2((most + 1.0) / (tag_count(lemma, pos, k) + 1.0)) + 0.25 * static_cast<double>(k);
  }

  const std::filesystem::path& dir() const { return dir_; }

  /// Synset offsets of `lemma` (lower case, collocations with '_') as `pos`, most frequent sense
  /// first; empty when WordNet does not list it.
  const std::vector<std::uint64_t>& senses(std::string_view lemma, PartOfSpeech pos) const {
    static const std::vector<std::uint64_t> none;
    const auto& idx = parts_[static_cast<std::size_t>(pos)].index;
    const auto it = idx.find(std::string(lemma));
    return it == idx.end() ? none : it->second;
  }
  bool contains(std::string_view lemma, PartOfSpeech pos) const { return !senses(lemma, pos).empty(); }

  /// The synset at byte `offset` of data.<pos>. Throws (file and line) when no synset line starts
  /// there or the line is malformed.
  Synset synset(PartOfSpeech pos, std::uint64_t offset) const {
    const Part& part = parts_[static_cast<std::size_t>(pos)];
    const std::string& d = part.data;
    const auto line_of = [&](std::uint64_t at) {
      return 1 + static_cast<long long>(std::count(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(std::min<std::uint64_t>(at, d.size())), '\n'));
    };
    if (offset >= d.size() || (offset > 0 && d[offset - 1] != '\n'))  // (line_of counts lines: only on failure)
      throw Error("no synset line starts at byte offset " + std::to_string(offset), {part.data_path, line_of(offset), {}});
    const std::size_t end = d.find('\n', offset);
    const std::string_view line(d.data() + offset, (end == std::string::npos ? d.size() : end) - offset);
    try {
      return parse_synset(line, pos);
    } catch (const Error& e) {
      throw Error(e.message(), {part.data_path, line_of(offset), e.context().field});
    }
  }

  /// WordNet's morphy: the base forms of `word` as `pos` that WordNet lists — the word itself when
  /// listed, then its exception-list bases ("ran" → "run"), then the detachment rules' results
  /// ("raising" → "raise", "hands" → "hand"). In that order, without repeats.
  std::vector<std::string> base_forms(std::string_view word, PartOfSpeech pos) const {
    static const std::array<std::vector<std::pair<std::string_view, std::string_view>>, 4> rules = {{
        {{"s", ""}, {"ses", "s"}, {"xes", "x"}, {"zes", "z"}, {"ches", "ch"}, {"shes", "sh"}, {"men", "man"}, {"ies", "y"}},
        {{"s", ""}, {"ies", "y"}, {"es", "e"}, {"es", ""}, {"ed", "e"}, {"ed", ""}, {"ing", "e"}, {"ing", ""}},
        {{"er", ""}, {"est", ""}, {"er", "e"}, {"est", "e"}},
        {},
    }};
    const Part& part = parts_[static_cast<std::size_t>(pos)];
    std::vector<std::string> out;
    const auto add = [&](const std::string& w) {
      if (contains(w, pos) && std::find(out.begin(), out.end(), w) == out.end()) out.push_back(w);
    };
    const std::string w(word);
    add(w);
    if (const auto it = part.exceptions.find(w); it != part.exceptions.end())
      for (const auto& b : it->second) add(b);
    for (const auto& [suffix, ending] : rules[static_cast<std::size_t>(pos)])
      if (w.size() > suffix.size() && w.compare(w.size() - suffix.size(), suffix.size(), suffix) == 0)
        add(w.substr(0, w.size() - suffix.size()) + std::string(ending));
    return out;
  }

  /// Lemmas of the synsets `pointer` leads to from `lemma`'s senses as `pos` (sense order, no repeats);
  /// e.g. related(“jog”, verb, "@") are jog's hypernyms' lemmas. Convenience for inspection and tests.
  std::vector<std::string> related(std::string_view lemma, PartOfSpeech pos, std::string_view pointer) const {
    std::vector<std::string> out;
    for (const auto off : senses(lemma, pos))
      for (const auto& p : synset(pos, off).pointers)
        if (p.symbol == pointer)
          for (auto& l : synset(p.pos, p.offset).lemmas)
            if (std::find(out.begin(), out.end(), l) == out.end()) out.push_back(std::move(l));
    return out;
  }

 private:
  struct Part {
    std::unordered_map<std::string, std::vector<std::uint64_t>> index;        ///< lemma → synset offsets
    std::unordered_map<std::string, std::vector<std::string>> exceptions;     ///< inflected form → bases
    std::string data;                                                         ///< data.<pos>, whole
    std::string data_path;
    std::unordered_map<std::string, std::vector<std::uint32_t>> tag_counts;   ///< lemma → tag count per sense (cntlist.rev)
  };

  /// cntlist.rev line: sense_key sense_number tag_cnt, the key "lemma%ss_type:lex_filenum:lex_id:head:head_id"
  /// (ss_type 1 noun, 2 verb, 3 adjective, 4 adverb, 5 satellite adjective).
  void parse_tag_counts(const std::string& text, const std::string& path) {
    for_each_entry(text, path, [&](std::string_view line, std::uint64_t) {
      const auto t = split_spaces(line);
      require(t.size() == 3, "a cntlist.rev line needs sense_key, sense_number and tag_cnt, got " + std::to_string(t.size()) +
                                 " fields", {{}, {}, "tag count"});
      const std::size_t pct = t[0].find('%');
      require(pct != std::string_view::npos && pct > 0 && pct + 1 < t[0].size() && t[0][pct + 1] >= '1' && t[0][pct + 1] <= '5',
              "a sense key is lemma%ss_type:…, ss_type 1–5, got '" + std::string(t[0]) + "'", {{}, {}, "sense_key"});
      static constexpr std::array<PartOfSpeech, 5> by_type = {PartOfSpeech::noun, PartOfSpeech::verb, PartOfSpeech::adjective,
                                                              PartOfSpeech::adverb, PartOfSpeech::adjective};
      const PartOfSpeech pos = by_type[static_cast<std::size_t>(t[0][pct + 1] - '1')];
      const auto sense = parse_number(t[1], 10, "sense_number");
      require(sense >= 1 && sense <= 1000, "sense_number must be 1…1000, got " + std::to_string(sense), {{}, {}, "sense_number"});
      const auto count = parse_number(t[2], 10, "tag_cnt");
      const std::string lemma = lower_case(std::string(t[0].substr(0, pct)));
      auto& v = parts_[static_cast<std::size_t>(pos)].tag_counts[lemma];
      if (v.size() < sense) v.resize(sense, 0u);
      v[sense - 1] += static_cast<std::uint32_t>(std::min<std::uint64_t>(count, 1u << 30));
    });
  }

  static std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    require(static_cast<bool>(in), "cannot open WordNet dictionary file (install Debian's wordnet-base, or set "
                                   "MASKADAPT_WORDNET_DIR to the folder holding index.noun, data.noun, noun.exc, …)",
            {path, {}, {}});
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }

  static std::vector<std::string_view> split_spaces(std::string_view line) {
    std::vector<std::string_view> t;
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && line[i] == ' ') ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ') ++j;
      if (j > i) t.push_back(line.substr(i, j - i));
      i = j;
    }
    return t;
  }

  /// Unsigned number in `base` (10 or 16), the whole field; throws naming `what` otherwise.
  static std::uint64_t parse_number(std::string_view s, int base, const std::string& what) {
    require(!s.empty() && s.size() <= 16, "expected a number for " + what + ", got '" + std::string(s) + "'", {{}, {}, what});
    std::uint64_t v = 0;
    const char* const end = s.data() + s.size();
    const auto [stop, ec] = std::from_chars(s.data(), end, v, base);
    require(ec == std::errc{} && stop == end, "expected a " + std::string(base == 16 ? "hexadecimal" : "decimal") +
                                                  " number for " + what + ", got '" + std::string(s) + "'", {{}, {}, what});
    return v;
  }

  /// `s` with ASCII letters lower-cased (WordNet's lemmas: "Achilles" → "achilles").
  static std::string lower_case(std::string s) {
    for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  }

  static PartOfSpeech pos_from_char(std::string_view s, const std::string& what) {
    require(s.size() == 1, "expected a part-of-speech letter (n, v, a, s, r) for " + what + ", got '" + std::string(s) + "'",
            {{}, {}, what});
    switch (s[0]) {
      case 'n': return PartOfSpeech::noun;
      case 'v': return PartOfSpeech::verb;
      case 'a': case 's': return PartOfSpeech::adjective;
      case 'r': return PartOfSpeech::adverb;
      default: break;
    }
    throw Error("expected a part-of-speech letter (n, v, a, s, r) for " + what + ", got '" + std::string(s) + "'", {{}, {}, what});
  }

  /// Calls fn(line, 1-based line number) for every line that is not part of the license header
  /// (those start with a space), rethrowing fn's Error with the file and line.
  template <class Fn>
  static void for_each_entry(const std::string& text, const std::string& path, Fn&& fn) {
    long long number = 0;
    std::size_t start = 0;
    while (start < text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      ++number;
      std::string_view line(text.data() + start, end - start);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      if (!line.empty() && line[0] != ' ') {
        try {
          fn(line, static_cast<std::uint64_t>(start));
        } catch (const Error& e) {
          throw Error(e.message(), {path, number, e.context().field});
        }
      }
      start = end + 1;
    }
  }

  /// index.<pos> line: lemma pos synset_cnt p_cnt [ptr_symbol…] sense_cnt tagsense_cnt offset…
  static void parse_index(const std::string& text, const std::string& path, PartOfSpeech pos, Part& part) {
    for_each_entry(text, path, [&](std::string_view line, std::uint64_t) {
      const auto t = split_spaces(line);
      require(t.size() >= 7, "an index line needs at least 7 fields (lemma pos synset_cnt p_cnt sense_cnt "
                             "tagsense_cnt offset), got " + std::to_string(t.size()), {{}, {}, "index entry"});
      require(pos_from_char(t[1], "pos") == pos, "part of speech '" + std::string(t[1]) + "' in the index of " +
                                                     wordnet_file_suffix(pos) + "s", {{}, {}, "pos"});
      const auto synsets = parse_number(t[2], 10, "synset_cnt");
      const auto pointers = parse_number(t[3], 10, "p_cnt");
      require(t.size() == 6 + pointers + synsets, "synset_cnt " + std::to_string(synsets) + " and p_cnt " +
                                                       std::to_string(pointers) + " call for " + std::to_string(6 + pointers + synsets) +
                                                       " fields, the line has " + std::to_string(t.size()), {{}, {}, "synset_cnt"});
      (void)parse_number(t[4 + pointers], 10, "sense_cnt");
      (void)parse_number(t[5 + pointers], 10, "tagsense_cnt");
      std::vector<std::uint64_t> offsets;
      for (std::size_t i = 6 + pointers; i < t.size(); ++i) offsets.push_back(parse_number(t[i], 10, "synset_offset"));
      part.index[std::string(t[0])] = std::move(offsets);
    });
  }

  /// <pos>.exc line: inflected base [base…]
  static void parse_exceptions(const std::string& text, const std::string& path, Part& part) {
    for_each_entry(text, path, [&](std::string_view line, std::uint64_t) {
      const auto t = split_spaces(line);
      require(t.size() >= 2, "an exception line needs an inflected form and at least one base form", {{}, {}, "exception"});
      auto& bases = part.exceptions[std::string(t[0])];
      for (std::size_t i = 1; i < t.size(); ++i) bases.emplace_back(t[i]);
    });
  }

  /// Every data line starts with its own byte offset (WordNet's invariant that offsets rely on).
  static void check_data_offsets(const std::string& text, const std::string& path) {
    for_each_entry(text, path, [&](std::string_view line, std::uint64_t at) {
      const std::size_t sp = line.find(' ');
      const auto own = parse_number(line.substr(0, sp), 10, "synset_offset");
      require(own == at, "synset line says offset " + std::to_string(own) + " but starts at byte " + std::to_string(at),
              {{}, {}, "synset_offset"});
    });
  }

  /// data.<pos> line: offset lex_filenum ss_type w_cnt(hex) [word lex_id(hex)]… p_cnt [sym offset pos src/tgt]… [frames] | gloss
  static Synset parse_synset(std::string_view line, PartOfSpeech pos) {
    const std::size_t bar = line.find(" | ");
    const auto t = split_spaces(bar == std::string_view::npos ? line : line.substr(0, bar));
    Synset s;
    s.pos = pos;
    require(t.size() >= 4, "a synset line needs offset, lex_filenum, ss_type and w_cnt", {{}, {}, "synset"});
    s.offset = parse_number(t[0], 10, "synset_offset");
    (void)parse_number(t[1], 10, "lex_filenum");
    require(pos_from_char(t[2], "ss_type") == pos, "ss_type '" + std::string(t[2]) + "' in the data of " +
                                                       wordnet_file_suffix(pos) + "s", {{}, {}, "ss_type"});
    const auto words = parse_number(t[3], 16, "w_cnt");
    std::size_t i = 4;
    require(t.size() >= i + 2 * words + 1, "w_cnt " + std::to_string(words) + " words do not fit the line", {{}, {}, "w_cnt"});
    for (std::uint64_t w = 0; w < words; ++w, i += 2) {
      std::string lemma = lower_case(std::string(t[i].substr(0, t[i].find('('))));  // drops adjective markers "(a)", "(p)", "(ip)"
      (void)parse_number(t[i + 1], 16, "lex_id");
      s.lemmas.push_back(std::move(lemma));
    }
    const auto pointers = parse_number(t[i], 10, "p_cnt");
    ++i;
    require(t.size() >= i + 4 * pointers, "p_cnt " + std::to_string(pointers) + " pointers do not fit the line", {{}, {}, "p_cnt"});
    for (std::uint64_t p = 0; p < pointers; ++p, i += 4) {
      SynsetPointer ptr;
      ptr.symbol = std::string(t[i]);
      ptr.offset = parse_number(t[i + 1], 10, "pointer offset");
      ptr.pos = pos_from_char(t[i + 2], "pointer pos");
      require(t[i + 3].size() == 4, "pointer source/target must be 4 hexadecimal digits", {{}, {}, "source/target"});
      (void)parse_number(t[i + 3], 16, "source/target");
      s.pointers.push_back(std::move(ptr));
    }
    if (bar != std::string_view::npos) s.gloss = std::string(line.substr(bar + 3));
    return s;
  }

  std::filesystem::path dir_;
  std::array<Part, 4> parts_;
  bool has_tag_counts_ = false;
};

/// Function words dropped from a prompt when the vocabulary does not have them (documented list:
/// articles, possessives and pronouns, a few prepositions/particles and politeness words). A word
/// of the vocabulary is never dropped ("the", "with" and "both" are in the training texts).
inline const std::set<std::string, std::less<>>& prompt_stop_words() {
  static const std::set<std::string, std::less<>> s = {
      "a", "an", "the", "your", "yours", "yourself", "my", "mine", "myself", "his", "her", "hers", "its", "our",
      "their", "them", "him", "it", "me", "us", "you", "i", "he", "she", "we", "they", "this", "that", "these",
      "those", "of", "to", "at", "on", "by", "for", "from", "into", "onto", "and", "or", "then", "while", "as",
      "please", "now", "just", "do", "does", "can", "could", "would", "should", "will", "be", "is", "are", "some",
      "one", "all", "so", "very", "again", "let", "lets", "s"};
  return s;
}

/// How one word of a prompt was mapped.
struct WordMapping {
  std::string word;         ///< as tokenized (lower case)
  std::string replacement;  ///< the known word(s) it became; empty when dropped
  std::string how;          ///< "known", "inflection of 'hand'", "synonym (verb 'jog', sense 1)", "hypernym …", "stop-word", "no known word within reach"
};

/// A prompt mapped onto a vocabulary.
struct PromptMapping {
  std::string prompt;              ///< as given
  std::string text;                ///< what to featurise: `prompt` itself when every word is known, else the mapped words joined by spaces
  std::vector<WordMapping> words;  ///< one per word of the prompt
  bool changed() const { return text != prompt; }
  /// "'raise your hands' → 'raise hands'" (or "'walk' (all words known)").
  std::string describe() const {
    if (!changed()) return "'" + prompt + "' (all words known)";
    std::string s = "'" + prompt + "' → '" + text + "' (";
    bool first = true;
    for (const auto& w : words) {
      if (w.how == "known") continue;
      s += (first ? "" : "; ") + w.word + (w.replacement.empty() ? " dropped: " : " → " + w.replacement + ": ") + w.how;
      first = false;
    }
    return s + ")";
  }
};

/// Training texts grouped by the behaviour they name (each set: the texts of one label), for the
/// mapper's lexical landing (`PromptVocabularyMapper::lexical_landing`).
struct LabelSets {
  std::vector<std::vector<std::string>> sets;
};

/// The training texts a mapped prompt shares most meaning-bearing words with (see `lexical_landing`).
struct LexicalLanding {
  double score = 0.0;              ///< the best TF-IDF cosine (0: no word in common with any text)
  std::vector<std::size_t> texts;  ///< indices into `training_texts()` scoring it (within 1e-9), in order; empty when 0
};

/// Maps prompts onto a vocabulary through WordNet (see the file comment and `map`).
class PromptVocabularyMapper {
 public:
  /// As below, with the texts grouped into label sets: the lexical landing's word weights count
  /// label sets (a word of many behaviours — "hand" — weighs less than one of a single behaviour).
  PromptVocabularyMapper(const LabelSets& labels, std::shared_ptr<const WordNet> wordnet, int max_search_cost = 3)
      : PromptVocabularyMapper(flatten(labels), std::move(wordnet), max_search_cost) {
    set_of_text_.clear();
    for (std::size_t s = 0; s < labels.sets.size(); ++s)
      for (std::size_t k = 0; k < labels.sets[s].size(); ++k) set_of_text_.push_back(s);
    build_landing();
  }

  /// `training_texts`: the texts whose words form the vocabulary. `wordnet`: may be null — then only
  /// known words and stop-words are handled, other words dropped. `max_search_cost`: the most a
  /// WordNet path may cost (see `map`).
  PromptVocabularyMapper(const std::vector<std::string>& training_texts, std::shared_ptr<const WordNet> wordnet,
                         int max_search_cost = 3)
      : wordnet_(std::move(wordnet)), max_search_cost_(max_search_cost) {
    require(max_search_cost >= 0, "the WordNet search cost limit must be ≥ 0", {{}, {}, "max_search_cost"});
    for (const auto& t : training_texts)
      for (auto& w : tokenize_words(t)) vocabulary_.insert(std::move(w));
    require(!vocabulary_.empty(), "the training texts hold no word", {{}, {}, "training_texts"});
    // Each known word's WordNet base forms lead back to it ("circle" → "circles"); the word itself
    // wins over another word with the same base (insertion in sorted order: deterministic).
    if (wordnet_)
      for (const auto& w : vocabulary_)
        for (const auto pos : kPartsOfSpeech)
          for (const auto& b : wordnet_->base_forms(w, pos)) {
            auto& slot = known_base_[b];
            if (slot.empty() || b == w) slot = w;
          }
    training_texts_ = training_texts;
    for (std::size_t i = 0; i < training_texts_.size(); ++i) set_of_text_.push_back(i);  // each text its own set
    build_landing();
  }

  /// The training texts, in the order given (the label sets' texts in set order).
  const std::vector<std::string>& training_texts() const { return training_texts_; }

  /// The word the lexical landing compares: the shortest of its WordNet base forms as noun and verb
  /// (first found on ties; "arms" → "arm", "jumping" → "jump", "strokes" → "stroke"), else itself.
  std::string landing_form(const std::string& w) const {
    if (!wordnet_) return w;
    std::string best;
    for (const auto pos : {PartOfSpeech::noun, PartOfSpeech::verb})
      for (const auto& b : wordnet_->base_forms(w, pos))
        if (best.empty() || b.size() < best.size()) best = b;
    return best.empty() ? w : best;
  }

  /// Which training texts a (mapped) prompt lands on by its words: each text and the prompt are
  /// bags of landing forms of their words, stop-words and "with", "in" left out; a form weighs
  /// idf = ln(1 + N / df) (N label sets, df of them that use it; a form no set uses counts df = 1),
  /// and the score is the cosine of the weighted bags. Returns the best score and every text
  /// scoring it (within 1e-9); no texts when the best is 0. Deterministic.
  LexicalLanding lexical_landing(std::string_view mapped_text) const {
    const auto v = landing_vector(mapped_text);
    LexicalLanding r;
    std::vector<double> score(training_texts_.size(), 0.0);
    for (std::size_t i = 0; i < training_texts_.size(); ++i) score[i] = cosine(v, text_vectors_[i]);
    for (const double c : score) r.score = std::max(r.score, c);
    if (r.score <= 0.0) return r;
    for (std::size_t i = 0; i < score.size(); ++i)
      if (score[i] >= r.score - 1e-9) r.texts.push_back(i);
    return r;
  }

  const std::set<std::string, std::less<>>& vocabulary() const { return vocabulary_; }
  bool knows(std::string_view word) const { return vocabulary_.count(word) > 0; }
  const WordNet* wordnet() const { return wordnet_.get(); }

  /// Maps each word of `prompt` (tokenize_words), in this order of rules:
  /// 1. in the vocabulary → kept;
  /// 2. an unknown stop-word (`prompt_stop_words`) → dropped;
  /// 3. a base form (morphy, parts of speech in the order verb, noun, adjective, adverb) that is a
  ///    known word, or the base form of one → that word ("raising" → "raise"; "circle" → "circles",
  ///    the known word whose base form it is);
  /// 4. a best-first search of WordNet's graph from the word's senses (every base form, every part of
  ///    speech), ordered by (path cost + the start sense's `WordNet::sense_penalty`, discovery order —
  ///    parts of speech verb, noun, adjective, adverb, senses in index order): the first synset
  ///    holding a known lemma (a lemma of the vocabulary, the base form of one, or a
  ///    collocation "jumping_jack" all of whose parts are known) gives the replacement. Edge costs:
  ///    synonyms (same synset) 0; derivation "+", similar "&", pertainym "\", verb group "$", also
  ///    "^", participle "<", attribute "=", part holonym "#p" (palm → hand) 1; hypernym "@"/"@i" 1;
  ///    hyponym "~"/"~i" 2, and only from the word's own senses. A path's cost, and its cost plus the
  ///    sense penalty, are at most `max_search_cost` (default 3), so a synonym of a rare sense no longer
  ///    beats a near word of a frequent one ("strike": the swim's "strokes" through its sense 4 lost
  ///    to "punch" through sense 1);
  /// 5. otherwise → dropped ("no known word within reach").
  /// When every word is kept (rule 1 only) the prompt is returned unchanged. When the prompt has
  /// words but none is known and none maps, throws Error naming the prompt and its unknown words.
  /// An empty prompt (no words: the unconditional case) is returned unchanged.
  PromptMapping map(std::string_view prompt) const {
    PromptMapping m;
    m.prompt = std::string(prompt);
    const auto words = tokenize_words(prompt);
    bool all_known = true;
    std::string mapped;
    for (const auto& w : words) {
      WordMapping wm = map_word(w);
      if (wm.how != "known") all_known = false;
      if (!wm.replacement.empty()) mapped += (mapped.empty() ? "" : " ") + wm.replacement;
      m.words.push_back(std::move(wm));
    }
    if (words.empty() || all_known) {
      m.text = m.prompt;
      return m;
    }
    if (mapped.empty()) {
      std::string list;
      for (const auto& w : m.words) list += (list.empty() ? "'" : ", '") + w.word + "'";
      throw Error("prompt '" + m.prompt + "' has no word the generator knows and none maps onto one" +
                      std::string(wordnet_ ? " through WordNet" : " (WordNet not loaded)") + ": " + list +
                      " — use words of its training texts (e.g. '" + *vocabulary_.begin() + "'; `maskadapt map-prompt --vocabulary` lists them)",
                  {{}, {}, "prompt"});
    }
    m.text = mapped;
    return m;
  }

 private:
  /// The known word(s) a WordNet lemma stands for ("" if none): the lemma itself, the vocabulary
  /// word whose base form it is, or, for a collocation, its parts' known words joined by spaces when
  /// every part has one ("swimming_stroke" → "swimming strokes").
  std::string known_for_lemma(const std::string& lemma) const {
    if (lemma.find('_') == std::string::npos) {
      if (knows(lemma)) return lemma;
      if (const auto it = known_base_.find(lemma); it != known_base_.end()) return it->second;
      return {};
    }
    std::string out;
    std::size_t s = 0;
    while (s <= lemma.size()) {
      std::size_t e = lemma.find('_', s);
      if (e == std::string::npos) e = lemma.size();
      const std::string part = known_for_lemma(lemma.substr(s, e - s));
      if (part.empty()) return {};
      out += (out.empty() ? "" : " ") + part;
      s = e + 1;
    }
    return out;
  }

  WordMapping map_word(const std::string& w) const {
    if (knows(w)) return {w, w, "known"};
    if (prompt_stop_words().count(w)) return {w, "", "stop-word"};
    if (!wordnet_) return {w, "", "not in the vocabulary (WordNet not loaded)"};
    std::vector<std::pair<std::string, PartOfSpeech>> bases;  // (base form, pos), in rule order
    for (const auto pos : kPartsOfSpeech)
      for (const auto& b : wordnet_->base_forms(w, pos)) {
        bases.emplace_back(b, pos);
        if (const std::string k = known_for_lemma(b); !k.empty() && b != w)
          return {w, k, "inflection of '" + b + "' (" + wordnet_file_suffix(pos) + ")"};
      }
    // Best-first search. Key: (total = path cost + the start sense's rarity penalty, discovery order).
    struct Node {
      double total;
      int cost;
      std::size_t order;
      PartOfSpeech pos;
      std::uint64_t offset;
      std::string path;  ///< how we got here, for the explanation
      bool from_start;
    };
    const auto later = [](const Node& a, const Node& b) {
      return std::tie(a.total, a.order) > std::tie(b.total, b.order);
    };
    std::priority_queue<Node, std::vector<Node>, decltype(later)> frontier(later);
    std::size_t order = 0;
    for (const auto& [b, pos] : bases) {
      const auto& offs = wordnet_->senses(b, pos);
      for (std::size_t k = 0; k < offs.size(); ++k) {
        const double penalty = wordnet_->sense_penalty(b, pos, k);
        if (penalty > max_search_cost_) continue;
        frontier.push({penalty, 0, order++, pos, offs[k],
                       std::string(wordnet_file_suffix(pos)) + " '" + b + "' sense " + std::to_string(k + 1), true});
      }
    }
    std::set<std::pair<int, std::uint64_t>> done;
    while (!frontier.empty()) {
      const Node n = frontier.top();
      frontier.pop();
      if (!done.insert({static_cast<int>(n.pos), n.offset}).second) continue;
      const Synset s = wordnet_->synset(n.pos, n.offset);
      for (const auto& l : s.lemmas)
        if (const std::string k = known_for_lemma(l); !k.empty())
          return {w, k, (n.cost == 0 ? "synonym: " : "") + n.path + (n.cost == 0 ? "" : " → '" + l + "'")};
      for (const auto& p : s.pointers) {
        int step = 0;
        std::string name;
        if (p.symbol == "@" || p.symbol == "@i") { step = 1; name = "hypernym"; }
        else if (p.symbol == "+") { step = 1; name = "derived"; }
        else if (p.symbol == "&") { step = 1; name = "similar"; }
        else if (p.symbol == "\\") { step = 1; name = "pertainym"; }
        else if (p.symbol == "$") { step = 1; name = "verb group"; }
        else if (p.symbol == "^") { step = 1; name = "see also"; }
        else if (p.symbol == "<") { step = 1; name = "participle of"; }
        else if (p.symbol == "=") { step = 1; name = "attribute"; }
        else if (p.symbol == "#p") { step = 1; name = "part of"; }
        else if ((p.symbol == "~" || p.symbol == "~i") && n.from_start) { step = 2; name = "hyponym"; }
        else continue;
        if (n.cost + step > max_search_cost_ || n.total + step > max_search_cost_ || done.count({static_cast<int>(p.pos), p.offset}))
          continue;
        const Synset target_head = wordnet_->synset(p.pos, p.offset);
        frontier.push({n.total + step, n.cost + step, order++, p.pos, p.offset,
                       n.path + " → " + name + " '" + (target_head.lemmas.empty() ? "?" : target_head.lemmas.front()) + "'",
                       false});
      }
    }
    return {w, "", "no known word within reach in WordNet"};
  }

  static std::vector<std::string> flatten(const LabelSets& l) {
    std::vector<std::string> t;
    for (const auto& s : l.sets) t.insert(t.end(), s.begin(), s.end());
    return t;
  }

  using Bag = std::map<std::string, double, std::less<>>;  ///< landing form → weight (sorted: deterministic sums)

  static bool landing_ignores(const std::string& w) {
    return w == "with" || w == "in" || prompt_stop_words().count(w) > 0;
  }

  Bag landing_vector(std::string_view text) const {
    Bag v;
    for (const auto& w : tokenize_words(text)) {
      if (landing_ignores(w)) continue;
      const std::string f = landing_form(w);
      const auto it = idf_.find(f);
      v[f] += it == idf_.end() ? std::log(1.0 + static_cast<double>(num_sets_)) : it->second;
    }
    return v;
  }

  static double cosine(const Bag& a, const Bag& b) {
    double dot = 0.0, na = 0.0, nb = 0.0;
    for (const auto& [k, x] : a) {
      na += x * x;
      if (const auto it = b.find(k); it != b.end()) dot += x * it->second;
    }
    for (const auto& [k, x] : b) nb += x * x;
    return na > 0.0 && nb > 0.0 ? dot / std::sqrt(na * nb) : 0.0;
  }

  /// idf over the label sets (set_of_text_), then each training text's weighted bag.
  void build_landing() {
    std::map<std::string, std::set<std::size_t>, std::less<>> sets_of;
    num_sets_ = 0;
    for (std::size_t i = 0; i < training_texts_.size(); ++i) {
      num_sets_ = std::max(num_sets_, set_of_text_[i] + 1);
      for (const auto& w : tokenize_words(training_texts_[i]))
        if (!landing_ignores(w)) sets_of[landing_form(w)].insert(set_of_text_[i]);
    }
    idf_.clear();
    for (const auto& [f, ss] : sets_of) idf_[f] = std::log(1.0 + static_cast<double>(num_sets_) / static_cast<double>(ss.size()));
    text_vectors_.clear();
    for (const auto& t : training_texts_) text_vectors_.push_back(landing_vector(t));
  }

  std::set<std::string, std::less<>> vocabulary_;
  std::vector<std::string> training_texts_;
  std::vector<std::size_t> set_of_text_;  ///< label set of each training text
  std::size_t num_sets_ = 0;
  std::map<std::string, double, std::less<>> idf_;
  std::vector<Bag> text_vectors_;
  std::map<std::string, std::string, std::less<>> known_base_;  ///< WordNet base form → vocabulary word
  std::shared_ptr<const WordNet> wordnet_;
  int max_search_cost_ = 3;
};

}  // namespace maskadapt::tracking
