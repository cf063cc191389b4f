// Words the generator has not seen (tracking/lexicon.hpp, tracking/prompt_words.hpp): the WordNet
// reader on a small hand-written dictionary (always) and on Debian's wordnet-base files (skipped
// when absent), malformed and missing files, the prompt mapper, and the generator's features.
#include "test_support.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/lexicon.hpp>
#include <maskadapt/tracking/prompt_words.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

using namespace maskadapt;
using namespace maskadapt::tracking;
namespace fs = std::filesystem;

namespace {

/// One synset of the hand-written dictionary; pointers name other synsets by their key.
struct TinySynset {
  std::string key;
  char pos;  // n, v, a, r
  std::vector<std::string> lemmas;
  std::vector<std::pair<std::string, std::string>> pointers;  // (symbol, target key)
};

std::string offset8(std::size_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "%08zu", v);
  return b;
}

const char* suffix(char pos) { return pos == 'n' ? "noun" : pos == 'v' ? "verb" : pos == 'a' ? "adj" : "adv"; }

/// Writes index.*, data.* (with true byte offsets) and *.exc for `synsets` into a fresh folder.
fs::path write_dictionary(const std::string& name, const std::vector<TinySynset>& synsets,
                          const std::map<char, std::string>& exceptions = {}) {
  const fs::path dir = fs::temp_directory_path() / ("maskadapt_wordnet_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string header = "  1 a hand-written test dictionary (header lines start with spaces)\n";
  // Offsets: lines have a fixed shape whatever the offsets' values (8 digits), so lay them out twice.
  std::map<std::string, std::size_t> offset;
  std::map<std::string, char> pos_of;
  for (const auto& s : synsets) pos_of[s.key] = s.pos;
  for (int pass = 0; pass < 2; ++pass) {
    for (const char pos : {'n', 'v', 'a', 'r'}) {
      std::string data = header;
      for (const auto& s : synsets) {
        if (s.pos != pos) continue;
        offset[s.key] = data.size();
        char wcnt[8];
        std::snprintf(wcnt, sizeof wcnt, "%02zx", s.lemmas.size());
        std::string line = offset8(offset[s.key]) + " 29 " + std::string(1, pos) + " " + wcnt;
        for (const auto& l : s.lemmas) line += " " + l + " 0";
        char pcnt[8];
        std::snprintf(pcnt, sizeof pcnt, "%03zu", s.pointers.size());
        line += std::string(" ") + pcnt;
        for (const auto& [sym, target] : s.pointers)
          line += " " + sym + " " + offset8(offset.count(target) ? offset[target] : 0) + " " + std::string(1, pos_of.at(target)) + " 0000";
        line += " | gloss of " + s.key + "  \n";
        data += line;
      }
      if (pass == 1) std::ofstream(dir / ("data." + std::string(suffix(pos))), std::ios::binary) << data;
    }
  }
  for (const char pos : {'n', 'v', 'a', 'r'}) {
    std::map<std::string, std::vector<std::string>> senses;  // lemma → keys in sense order
    for (const auto& s : synsets)
      if (s.pos == pos)
        for (const auto& l : s.lemmas) senses[l].push_back(s.key);
    std::string index = header;
    for (const auto& [lemma, keys] : senses) {
      index += lemma;
      index += ' ';
      index += pos;
      index += " " + std::to_string(keys.size()) + " 0 " + std::to_string(keys.size()) + " 0";
      for (const auto& k : keys) {  // (two appends: GCC 12's -Wrestrict misfires on " " + string&&)
        index += ' ';
        index += offset8(offset.at(k));
      }
      index += "  \n";
    }
    std::ofstream(dir / ("index." + std::string(suffix(pos))), std::ios::binary) << index;
    std::ofstream(dir / (std::string(suffix(pos)) + ".exc"), std::ios::binary)
        << (exceptions.count(pos) ? exceptions.at(pos) : std::string());
  }
  return dir;
}

/// walk ⊂ travel; stroll ⊂ walk; {elevate, raise}; {run}, "ran" an exception of run; {hand} with a
/// part {palm}; nouns {arm}.
fs::path tiny_dictionary(const std::string& name) {
  return write_dictionary(name,
                          {{"travel", 'v', {"travel", "go"}, {}},
                           {"walk", 'v', {"walk"}, {{"@", "travel"}}},
                           {"stroll", 'v', {"stroll", "saunter"}, {{"@", "walk"}}},
                           {"raise", 'v', {"elevate", "raise", "lift"}, {}},
                           {"run", 'v', {"run"}, {}},
                           {"hand", 'n', {"hand", "manus"}, {}},
                           {"palm", 'n', {"palm", "thenar"}, {{"#p", "hand"}}},
                           {"arm", 'n', {"arm"}, {}}},
                          {{'v', "ran run\n"}});
}

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// Replaces line `n` (1-based) of file p by `text`.
void replace_line(const fs::path& p, int n, const std::string& text) {
  std::string s = read(p), out;
  int line = 1;
  std::size_t start = 0;
  while (start < s.size()) {
    const std::size_t end = s.find('\n', start);
    out += (line == n ? text : s.substr(start, end - start)) + "\n";
    start = end + 1;
    ++line;
  }
  std::ofstream(p, std::ios::binary) << out;
}

/// The message of the Error `fn` throws ("" if none).
template <class Fn>
std::string error_of(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

BuiltinGeneratorConfig small_config() { return test::small_generator_config(32, 8); }

const std::vector<std::string> kTexts = {"walk", "raise arms", "wave right hand", "wave with the right hand"};

}  // namespace

TEST(WordNetReader, ReadsAHandWrittenDictionary) {
  const WordNet wn = WordNet::load(tiny_dictionary("read"));
  ASSERT_EQ(wn.senses("stroll", PartOfSpeech::verb).size(), 1u);
  EXPECT_TRUE(wn.senses("stroll", PartOfSpeech::noun).empty());
  const Synset s = wn.synset(PartOfSpeech::verb, wn.senses("stroll", PartOfSpeech::verb)[0]);
  EXPECT_EQ(s.lemmas, (std::vector<std::string>{"stroll", "saunter"}));
  EXPECT_EQ(s.gloss, "gloss of stroll  ");
  EXPECT_EQ(wn.related("stroll", PartOfSpeech::verb, "@"), std::vector<std::string>{"walk"});
  EXPECT_EQ(wn.related("walk", PartOfSpeech::verb, "@"), (std::vector<std::string>{"travel", "go"}));
  EXPECT_EQ(wn.base_forms("ran", PartOfSpeech::verb), std::vector<std::string>{"run"});        // exception list
  EXPECT_EQ(wn.base_forms("strolling", PartOfSpeech::verb), std::vector<std::string>{"stroll"}); // rule "ing" → ""
  EXPECT_EQ(wn.base_forms("palms", PartOfSpeech::noun), std::vector<std::string>{"palm"});
  EXPECT_TRUE(wn.base_forms("xyzzy", PartOfSpeech::noun).empty());
}

TEST(WordNetReader, MissingFileNamesItsPath) {
  const fs::path dir = tiny_dictionary("missing");
  fs::remove(dir / "adj.exc");
  const std::string msg = error_of([&] { (void)WordNet::load(dir); });
  EXPECT_NE(msg.find((dir / "adj.exc").string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("wordnet-base"), std::string::npos) << msg;
  EXPECT_FALSE(wordnet_available(dir));
  const std::string none = error_of([&] { (void)WordNet::load(dir / "nowhere"); });
  EXPECT_NE(none.find((dir / "nowhere").string()), std::string::npos) << none;
}

TEST(WordNetReader, MalformedLinesAreNamedByFileAndLine) {
  {  // index line: the synset count calls for more offsets than the line has (line 3)
    const fs::path dir = tiny_dictionary("bad_index");
    replace_line(dir / "index.verb", 3, "raise v 2 0 2 0 00000001");
    const std::string msg = error_of([&] { (void)WordNet::load(dir); });
    EXPECT_NE(msg.find((dir / "index.verb").string() + ":3:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("synset_cnt"), std::string::npos) << msg;
  }
  {  // index line: a word where a number belongs
    const fs::path dir = tiny_dictionary("bad_number");
    replace_line(dir / "index.noun", 2, "arm n one 0 1 0 00000001");
    const std::string msg = error_of([&] { (void)WordNet::load(dir); });
    EXPECT_NE(msg.find((dir / "index.noun").string() + ":2:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'one'"), std::string::npos) << msg;
  }
  {  // data line whose offset is not where it lies (line 2 of data.noun)
    const fs::path dir = tiny_dictionary("bad_offset");
    std::string s = read(dir / "data.noun");
    const std::size_t at = s.find('\n') + 1;
    s.replace(at, 8, "00000999");
    std::ofstream(dir / "data.noun", std::ios::binary) << s;
    const std::string msg = error_of([&] { (void)WordNet::load(dir); });
    EXPECT_NE(msg.find((dir / "data.noun").string() + ":2:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("999"), std::string::npos) << msg;
  }
  {  // exception line with no base form
    const fs::path dir = tiny_dictionary("bad_exc");
    std::ofstream(dir / "verb.exc", std::ios::binary) << "ran run\nswam\n";
    const std::string msg = error_of([&] { (void)WordNet::load(dir); });
    EXPECT_NE(msg.find((dir / "verb.exc").string() + ":2:"), std::string::npos) << msg;
  }
  {  // a synset line that loads (offset right) but whose word count runs past the line: found when read
    const fs::path dir = tiny_dictionary("bad_synset");
    std::string s = read(dir / "data.verb");
    const std::size_t line2 = s.find('\n') + 1;                 // the first synset ("travel", 2 words)
    s.replace(line2 + 15, 2, "09");                              // w_cnt 02 → 09
    std::ofstream(dir / "data.verb", std::ios::binary) << s;
    const WordNet wn = WordNet::load(dir);
    const std::string msg = error_of([&] { (void)wn.synset(PartOfSpeech::verb, wn.senses("travel", PartOfSpeech::verb)[0]); });
    EXPECT_NE(msg.find((dir / "data.verb").string() + ":2:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("w_cnt"), std::string::npos) << msg;
    const std::string off = error_of([&] { (void)wn.synset(PartOfSpeech::verb, 5); });
    EXPECT_NE(off.find("no synset line starts at byte offset 5"), std::string::npos) << off;
  }
}

TEST(PromptMapper, MapsUnseenWordsThroughTheDictionary) {
  const auto wn = std::make_shared<const WordNet>(WordNet::load(tiny_dictionary("map")));
  const PromptVocabularyMapper m(kTexts, wn);
  EXPECT_TRUE(m.knows("walk") && m.knows("the") && !m.knows("your"));
  EXPECT_EQ(m.map("stroll").text, "walk");                       // hypernym
  EXPECT_EQ(m.map("strolling").text, "walk");                    // base form, then hypernym
  EXPECT_EQ(m.map("elevate your arms").text, "raise arms");      // synonym; "your" dropped
  EXPECT_EQ(m.map("wave the right palm").text, "wave the right hand");  // part of
  const PromptMapping p = m.map("Saunter, please");
  EXPECT_EQ(p.text, "walk");
  ASSERT_EQ(p.words.size(), 2u);
  EXPECT_EQ(p.words[1].how, "stop-word");
  EXPECT_NE(p.describe().find("'Saunter, please' → 'walk'"), std::string::npos) << p.describe();
  // The search is bounded: with no edge allowed, "stroll" reaches nothing and, alone, is an error.
  const PromptVocabularyMapper strict(kTexts, wn, 0);
  EXPECT_EQ(strict.map("elevate arms").text, "raise arms");  // synonyms cost nothing
  EXPECT_FALSE(error_of([&] { (void)strict.map("stroll"); }).empty());
}

TEST(PromptMapper, KnownPromptsAreReturnedAsGiven) {
  const auto wn = std::make_shared<const WordNet>(WordNet::load(tiny_dictionary("known")));
  const PromptVocabularyMapper m(kTexts, wn);
  for (const std::string p : {"wave right hand", "Wave, RIGHT hand!", "raise arms", "walk", "", "  "}) {
    const PromptMapping r = m.map(p);
    EXPECT_EQ(r.text, p);
    EXPECT_FALSE(r.changed());
  }
}

TEST(PromptMapper, PromptOfUnknownWordsOnlyIsAnErrorNamingThem) {
  const auto wn = std::make_shared<const WordNet>(WordNet::load(tiny_dictionary("unknown")));
  for (const auto& m : {PromptVocabularyMapper(kTexts, wn), PromptVocabularyMapper(kTexts, nullptr)}) {
    const std::string msg = error_of([&] { (void)m.map("Xyzzy your qwerty"); });
    EXPECT_NE(msg.find("prompt 'Xyzzy your qwerty'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'xyzzy', 'your', 'qwerty'"), std::string::npos) << msg;
  }
  // One known word is enough; the unknown ones are dropped and said so.
  const PromptMapping r = PromptVocabularyMapper(kTexts, nullptr).map("walk xyzzy");
  EXPECT_EQ(r.text, "walk");
  EXPECT_TRUE(r.words[1].replacement.empty());
  EXPECT_THROW(PromptVocabularyMapper({"", "!!"}, nullptr), Error);
}

TEST(PromptMapper, GeneratorFeaturesOfKnownPromptsAreUnchangedBitForBit) {
  const Skeleton& skel = humanoid_skeleton();
  Rng rng(3);
  BuiltinGenerator plain(skel, small_config(), rng);
  BuiltinGenerator mapped = plain;
  mapped.set_prompt_mapper(std::make_shared<const PromptVocabularyMapper>(
      kTexts, std::make_shared<const WordNet>(WordNet::load(tiny_dictionary("features")))));
  for (const std::string p : {"wave right hand", "Wave, RIGHT hand!", "raise arms", "walk", ""}) {
    const VectorXf a = plain.text_features(TextCondition(p)), b = mapped.text_features(TextCondition(p));
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), sizeof(float) * static_cast<std::size_t>(a.size()))) << p;
  }
  // An unseen prompt is featurised as its mapping; one of unknown words only is refused.
  EXPECT_TRUE(mapped.text_features(TextCondition("elevate your arms")) == plain.text_features(TextCondition("raise arms")));
  EXPECT_FALSE(mapped.text_features(TextCondition("elevate your arms")) == plain.text_features(TextCondition("elevate your arms")));
  EXPECT_NE(error_of([&] { (void)mapped.text_features(TextCondition("xyzzy")); }).find("'xyzzy'"), std::string::npos);
  // Landing: the mapped prompt's nearest training text by the generator's own embedding.
  const std::vector<std::vector<std::string>> sets = {{"walk"}, {"raise arms"}, {"wave right hand", "wave with the right hand"}};
  const PromptLanding l = land_prompt(mapped, "elevate your arms", sets);
  EXPECT_EQ(l.mapping.text, "raise arms");
  EXPECT_EQ(l.nearest_text, "raise arms");
  EXPECT_NEAR(l.cosine, 1.0, 1e-6);
  EXPECT_TRUE(same_behaviour("wave with the right hand", "wave right hand", sets));
  EXPECT_FALSE(same_behaviour("walk", "wave right hand", sets));
}

TEST(PromptMapper, TrainingLabelsAreRecordedSavedAndLoaded) {
  const Skeleton& skel = humanoid_skeleton();
  auto clips = test::make_clips();
  const auto data = make_primitive_dataset(skel, clips, 5, 15, 6);
  Rng rng(1);
  BuiltinGenerator g(skel, small_config(), rng);
  GeneratorTrainConfig tc;
  tc.vae_iterations = 2;
  tc.diffusion_iterations = 2;
  tc.batch = 4;
  (void)train_generator(g, data, tc, rng);
  EXPECT_EQ(g.training_labels(), distinct_label_sets(clips));
  ASSERT_FALSE(g.training_labels().empty());
  const fs::path path = fs::temp_directory_path() / "maskadapt_test_training_labels.ckpt";
  g.save(path);
  const BuiltinGenerator back = BuiltinGenerator::load(path, skel);
  EXPECT_EQ(back.training_labels(), g.training_labels());
  EXPECT_EQ(generator_training_labels(back, "/nonexistent", skel).source, "the checkpoint");
  // Without a record and without data to derive it from: an error that says so.
  BuiltinGenerator old = back;
  old.set_training_labels({});
  EXPECT_NE(error_of([&] { (void)generator_training_labels(old, "/nonexistent", skel); }).find("does not record"), std::string::npos);
  fs::remove(path);
}

// ---- Debian's wordnet-base (skipped without it; scripts/setup.sh installs it) ------------------

class RealWordNet : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!wordnet_available()) GTEST_SKIP() << "WordNet dictionary not found in " << default_wordnet_dir()
                                           << " (apt-get install wordnet-base, or set MASKADAPT_WORDNET_DIR)";
    if (!wn_) wn_ = std::make_shared<const WordNet>(WordNet::load());
  }
  static std::shared_ptr<const WordNet> wn_;
};
std::shared_ptr<const WordNet> RealWordNet::wn_;

TEST_F(RealWordNet, KnownEntries) {
  const WordNet& wn = *wn_;
  // Morphy: exception lists and detachment rules.
  EXPECT_EQ(wn.base_forms("ran", PartOfSpeech::verb), std::vector<std::string>{"run"});
  EXPECT_EQ(wn.base_forms("feet", PartOfSpeech::noun), std::vector<std::string>{"foot"});
  EXPECT_EQ(wn.base_forms("raising", PartOfSpeech::verb), std::vector<std::string>{"raise"});
  // Synonyms: the first verb sense of "hoist" is {hoist, lift, wind} (WordNet 3.0, offset 01455202).
  const auto& hoist = wn.senses("hoist", PartOfSpeech::verb);
  ASSERT_FALSE(hoist.empty());
  EXPECT_EQ(hoist[0], 1455202u);
  EXPECT_EQ(wn.synset(PartOfSpeech::verb, hoist[0]).lemmas, (std::vector<std::string>{"hoist", "lift", "wind"}));
  // A hypernym chain along first senses: stroll → walk → travel.
  const auto first_hypernym = [&](const std::string& lemma) {
    for (const auto& p : wn.synset(PartOfSpeech::verb, wn.senses(lemma, PartOfSpeech::verb)[0]).pointers)
      if (p.symbol == "@") return wn.synset(p.pos, p.offset).lemmas;
    return std::vector<std::string>{};
  };
  EXPECT_EQ(first_hypernym("stroll"), std::vector<std::string>{"walk"});
  EXPECT_EQ(first_hypernym("walk"), (std::vector<std::string>{"travel", "go", "move", "locomote"}));
  EXPECT_EQ(wn.related("fist", PartOfSpeech::noun, "@"), (std::vector<std::string>{"hand", "manus", "mitt", "paw"}));
}

TEST_F(RealWordNet, MapsParaphrasesOntoTheCatalogVocabulary) {
  std::vector<std::string> texts;
  for (const auto& c : arm_catalog()) texts.insert(texts.end(), c.texts.begin(), c.texts.end());
  texts.insert(texts.end(), {"walk", "walk forward", "run", "jump"});
  const PromptVocabularyMapper m(texts, wn_);
  EXPECT_EQ(m.map("raising arms").text, "raise arms");
  EXPECT_EQ(m.map("raise your hands").text, "raise hands");
  EXPECT_EQ(m.map("elevate your arms").text, "raise arms");
  EXPECT_EQ(m.map("hoist an arm").text, "lift arm");
  EXPECT_EQ(m.map("stroll").text, "walk");
  EXPECT_EQ(m.map("jog").text, "run");
  EXPECT_EQ(m.map("ran").text, "run");
  EXPECT_EQ(m.map("twirl the arms").text, "rotate the arms");
  EXPECT_EQ(m.map("duel with a sabre").text, "fight with sword");
  EXPECT_EQ(m.map("strike").text, "punch");  // not the swim's "strokes" (a synonym of its rare sense 4)
  EXPECT_NE(error_of([&] { (void)m.map("xyzzy qwerty"); }).find("'xyzzy', 'qwerty'"), std::string::npos);
  // Landing by word overlap over the catalog's label sets: "raise" (one behaviour) outweighs "hand" (three).
  LabelSets sets;
  for (const auto& c : arm_catalog()) sets.sets.push_back(c.texts);
  sets.sets.insert(sets.sets.end(), {{"walk", "walk forward"}, {"run"}, {"jump"}});
  const PromptVocabularyMapper by_sets(sets, wn_);
  const LexicalLanding l = by_sets.lexical_landing(by_sets.map("raise your hands").text);
  ASSERT_EQ(l.texts.size(), 1u);
  EXPECT_EQ(by_sets.training_texts()[l.texts[0]], "raise arms");
}

// ---- Sense frequencies and the lexical landing (issue 42, the second sitting) -------------------

namespace {

/// "strike": sense 1 {strike} with a hyponym {punch}; sense 2 {strike, stroke} (a synonym of the
/// vocabulary's "strokes" by base form). Without tag counts the synonym of sense 2 wins (penalty 0.25
/// against the hyponym's 2); with sense 1 tagged 20 times and sense 2 never, it costs 2.45 and loses.
fs::path strike_dictionary(const std::string& name, bool with_counts) {
  const fs::path dir = write_dictionary(name, {{"strike1", 'v', {"strike"}, {{"~", "punch"}}},
                                               {"strike2", 'v', {"strike", "stroke"}, {}},
                                               {"punch", 'v', {"punch"}, {}},
                                               {"stroke", 'n', {"stroke"}, {}}});
  if (with_counts) std::ofstream(dir / "cntlist.rev", std::ios::binary) << "strike%2:35:00:: 1 20\nstroke%1:04:00:: 1 4\n";
  return dir;
}

}  // namespace

TEST(WordNetReader, TagCountsAndSensePenalty) {
  const WordNet wn = WordNet::load(strike_dictionary("counts", true));
  EXPECT_TRUE(wn.has_tag_counts());
  EXPECT_EQ(wn.tag_count("strike", PartOfSpeech::verb, 0), 20u);
  EXPECT_EQ(wn.tag_count("strike", PartOfSpeech::verb, 1), 0u);
  EXPECT_EQ(wn.tag_count("stroke", PartOfSpeech::noun, 0), 4u);
  EXPECT_EQ(wn.tag_count("stroke", PartOfSpeech::verb, 0), 0u);
  EXPECT_DOUBLE_EQ(wn.sense_penalty("strike", PartOfSpeech::verb, 0), 0.0);
  EXPECT_DOUBLE_EQ(wn.sense_penalty("strike", PartOfSpeech::verb, 1), 0.5 * std::log2(21.0) + 0.25);
  const WordNet plain = WordNet::load(strike_dictionary("no_counts", false));
  EXPECT_FALSE(plain.has_tag_counts());
  EXPECT_DOUBLE_EQ(plain.sense_penalty("strike", PartOfSpeech::verb, 1), 0.25);  // sense order alone
  // A malformed cntlist.rev line is named by file and line.
  const fs::path dir = strike_dictionary("bad_counts", true);
  std::ofstream(dir / "cntlist.rev", std::ios::binary) << "strike%2:35:00:: 1 20\nstrike%9:35:00:: 2 3\n";
  const std::string msg = error_of([&] { (void)WordNet::load(dir); });
  EXPECT_NE(msg.find((dir / "cntlist.rev").string() + ":2:"), std::string::npos) << msg;
  std::ofstream(dir / "cntlist.rev", std::ios::binary) << "strike%2:35:00:: 1\n";
  EXPECT_NE(error_of([&] { (void)WordNet::load(dir); }).find("cntlist.rev:1:"), std::string::npos);
}

TEST(PromptMapper, RareSensesArePenalised) {
  const std::vector<std::string> texts = {"punch", "swimming strokes"};
  const PromptVocabularyMapper without(texts, std::make_shared<const WordNet>(WordNet::load(strike_dictionary("m0", false))));
  EXPECT_EQ(without.map("strike").text, "strokes");
  const PromptVocabularyMapper with(texts, std::make_shared<const WordNet>(WordNet::load(strike_dictionary("m1", true))));
  EXPECT_EQ(with.map("strike").text, "punch");
  EXPECT_NE(with.map("strike").describe().find("hyponym 'punch'"), std::string::npos) << with.map("strike").describe();
}

TEST(PromptMapper, LexicalLandingIsIdfWeightedCosine) {
  // No WordNet: landing forms are the words. 4 sets; idf = ln(1 + 4/df).
  const PromptVocabularyMapper m(LabelSets{{{"walk"}, {"raise arms", "raise both arms"}, {"wave right hand"}, {"wave both hands"}}},
                                 nullptr);
  const double l5 = std::log(5.0), l3 = std::log(3.0);  // df 1 and df 2 ("both", "wave")
  const LexicalLanding r = m.lexical_landing("raise the hands");  // "the" left out
  const double to_raise_arms = 0.5, to_raise_both_arms = l5 / (std::sqrt(2.0) * std::sqrt(2 * l5 * l5 + l3 * l3)),
               to_wave_both_hands = l5 / (std::sqrt(2.0) * std::sqrt(l5 * l5 + 2 * l3 * l3));
  EXPECT_GT(to_wave_both_hands, to_raise_arms);
  EXPECT_GT(to_raise_arms, to_raise_both_arms);
  EXPECT_NEAR(r.score, to_wave_both_hands, 1e-12);
  EXPECT_EQ(r.texts, std::vector<std::size_t>{4});
  EXPECT_EQ(m.lexical_landing("raise").texts, (std::vector<std::size_t>{1}));  // "raise arms" beats "raise both arms"
  EXPECT_EQ(m.lexical_landing("wave").texts, (std::vector<std::size_t>{4}));   // the co-words of "wave both hands" weigh less
  // Texts with the same weighted words tie and are returned together; no word in common: nothing.
  const PromptVocabularyMapper tie(LabelSets{{{"walk"}, {"wave right hand", "wave with the right hand"}}}, nullptr);
  EXPECT_EQ(tie.lexical_landing("right").texts, (std::vector<std::size_t>{1, 2}));
  EXPECT_TRUE(m.lexical_landing("jump").texts.empty());
  EXPECT_EQ(m.lexical_landing("jump").score, 0.0);
}

TEST(PromptMapper, UnseenPromptsAreConditionedOnTheTrainingTextTheyLandOn) {
  const Skeleton& skel = humanoid_skeleton();
  Rng rng(3);
  BuiltinGenerator g(skel, small_config(), rng);
  const BuiltinGenerator plain = g;
  g.set_prompt_mapper(std::make_shared<const PromptVocabularyMapper>(
      LabelSets{{{"walk"}, {"raise arms"}, {"wave right hand", "wave with the right hand"}}},
      std::make_shared<const WordNet>(WordNet::load(tiny_dictionary("condition")))));
  EXPECT_EQ(g.conditioning_text("walk"), "walk");                     // known: as given
  EXPECT_EQ(g.conditioning_text("elevate your arms"), "raise arms");  // one text lands
  // "wave the right palm" → "wave the right hand": both wave texts score alike; the embedding decides.
  const auto emb = [&](const std::string& t) { return VectorXf(plain.denoiser().embed(plain.text_encoder().features(t))); };
  const VectorXf e = emb("wave the right hand");
  const auto cos = [&](const std::string& t) { const VectorXf f = emb(t); return e.dot(f) / (e.norm() * f.norm()); };
  const std::string expected = cos("wave right hand") >= cos("wave with the right hand") ? "wave right hand" : "wave with the right hand";
  EXPECT_EQ(g.conditioning_text("wave the right palm"), expected);
  EXPECT_TRUE(g.text_features(TextCondition("wave the right palm")) == plain.text_features(TextCondition(expected)));
  const PromptLanding l = land_prompt(g, "wave the right palm", {{"walk"}, {"raise arms"}, {"wave right hand", "wave with the right hand"}});
  EXPECT_EQ(l.conditioned_on, expected);
  EXPECT_EQ(l.nearest_text, expected);
  EXPECT_NEAR(l.cosine, 1.0, 1e-6);
  EXPECT_GT(l.lexical_score, 0.99);
}

TEST_F(RealWordNet, TagCountsOfWordNet30) {
  const WordNet& wn = *wn_;
  if (!wn.has_tag_counts()) GTEST_SKIP() << "no cntlist.rev in " << wn.dir();
  // cntlist.rev: hit%2:35:03:: 1 25 (sense 1) … hit%2:33:02:: 8 3 (sense 8).
  EXPECT_EQ(wn.tag_count("hit", PartOfSpeech::verb, 0), 25u);
  EXPECT_EQ(wn.tag_count("hit", PartOfSpeech::verb, 7), 3u);
  EXPECT_NEAR(wn.sense_penalty("hit", PartOfSpeech::verb, 7), 0.5 * std::log2(26.0 / 4.0) + 1.75, 1e-12);
}
