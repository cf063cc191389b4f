#pragma once
/// \file prompt_words.hpp
/// A generator's vocabulary, its prompt mapper, and which training label a prompt lands on.
///
/// - `generator_training_labels(g, data_dir)`: the label sets the generator was trained on — its
///   own record ("generator.training_labels", written by `train_generator` since issue 42) or, for
///   older checkpoints such as the shipped models/text_generator.bin, derived from the training data
///   the way `train-generator` (`--data-mix arms`) loads them (`load_generator_corpus` without
///   arm-switch clips: those carry the catalog's and the walks' texts, which the corpus already has).
/// - `make_prompt_mapper(labels, wordnet_dir)`: a `PromptVocabularyMapper` (lexicon.hpp) over the
///   labels' words, with WordNet when its files are there.
/// - `land_prompt(g, prompt, labels)`: the training text nearest to the prompt by the generator's
///   own text embedding (cosine of the learned projection of the — mapped — hashed features).
/// - `unseen_word_paraphrases()`: the paraphrases docs/generator.md reports, each with the label
///   meant (the development list); `heldout_paraphrases()`: a second list, for judging only.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/tracking/arm_data.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/lexicon.hpp>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace maskadapt::tracking {

/// Label sets (each a list of texts naming one behaviour) and where they came from.
struct TrainingLabels {
  std::vector<std::vector<std::string>> sets;
  std::string source;  ///< "the checkpoint" or "derived from the training data under <dir>"
};

/// The distinct non-empty label sets of `clips` (each clip's texts, then its segments' texts), in
/// order of first use (`distinct_label_sets` of builtin_generator.hpp over those lists).
inline std::vector<std::vector<std::string>> distinct_label_sets(const std::vector<LabelledTrajectory>& clips) {
  std::vector<std::vector<std::string>> sets;
  for (const auto& c : clips) {
    sets.push_back(c.texts);
    for (const auto& s : c.segments) sets.push_back(s.texts);
  }
  return distinct_label_sets(sets);
}

/// See the file comment. Throws when the checkpoint has no record and data_dir holds no clips.
inline TrainingLabels generator_training_labels(const BuiltinGenerator& g, const std::string& data_dir,
                                                const Skeleton& skel) {
  if (!g.training_labels().empty()) return {g.training_labels(), "the checkpoint"};
  Rng rng(0);  // (no arm-switch clips are made: nothing is drawn)
  ArmSwitchOptions none;
  none.active_seconds_per_class = 0;
  const GeneratorCorpus corpus = load_generator_corpus(data_dir, skel, rng, none);
  require(corpus.num_real > 0, "the checkpoint does not record its training labels and no training clips were found under '" +
                                   data_dir + "' to derive them (set MASKADAPT_DATA_DIR or --data)", {data_dir, {}, "training labels"});
  return {distinct_label_sets(corpus.clips), "derived from the training data under " + data_dir};
}

/// A mapper over the words of `labels`, with WordNet read from `wordnet_dir` when its files are
/// there (else none: unknown words are dropped, not mapped; `wordnet_available` tells).
inline std::shared_ptr<const PromptVocabularyMapper> make_prompt_mapper(const std::vector<std::vector<std::string>>& labels,
                                                                        const std::filesystem::path& wordnet_dir = default_wordnet_dir()) {
  std::shared_ptr<const WordNet> wn;
  if (wordnet_available(wordnet_dir)) wn = std::make_shared<const WordNet>(WordNet::load(wordnet_dir));
  return std::make_shared<const PromptVocabularyMapper>(LabelSets{labels}, std::move(wn));
}

/// Where a prompt lands among the training labels.
struct PromptLanding {
  PromptMapping mapping;     ///< the prompt as g's mapper maps it (unchanged without a mapper)
  std::size_t label_set = 0; ///< index into the label sets: the first set holding the nearest text
  std::string nearest_text;  ///< the training text nearest by cosine of the learned text embedding
  double cosine = 0.0;
  std::string conditioned_on;  ///< what g featurises (`BuiltinGenerator::conditioning_text`)
  double lexical_score = 0.0;  ///< the mapped prompt's best `lexical_landing` score (0 when unchanged or no mapper)
};

/// The training text whose learned embedding, `g.denoiser().embed(g.text_features(text))` (E), is
/// nearest to the prompt's by cosine (ties: the first in set order). Uses g's prompt mapper when set
/// (a prompt with unseen words is then featurised as the training text it lands on, so it lands there
/// with cosine 1 unless it shares no word with any training text).
inline PromptLanding land_prompt(const BuiltinGenerator& g, const std::string& prompt,
                                 const std::vector<std::vector<std::string>>& label_sets) {
  require(!label_sets.empty(), "no training labels", {{}, {}, "label_sets"});
  PromptLanding r;
  r.mapping = g.prompt_mapper() ? g.prompt_mapper()->map(prompt) : PromptMapping{prompt, prompt, {}};
  r.conditioned_on = g.conditioning_text(prompt);
  if (g.prompt_mapper() && r.mapping.changed()) r.lexical_score = g.prompt_mapper()->lexical_landing(r.mapping.text).score;
  std::vector<std::string> texts;  // every label set's texts in order, and the set each came from
  std::vector<std::size_t> set_of;
  for (std::size_t s = 0; s < label_sets.size(); ++s)
    for (const auto& t : label_sets[s]) {
      texts.push_back(t);
      set_of.push_back(s);
    }
  const auto [i, c] = g.nearest_by_embedding(g.denoiser().embed(g.text_features(TextCondition(prompt))), texts);
  r.label_set = set_of[i];
  r.nearest_text = texts[i];
  r.cosine = c;
  return r;
}

/// True when `text` and `intended` share a label set (the prompt landed on the behaviour meant).
inline bool same_behaviour(const std::string& text, const std::string& intended,
                           const std::vector<std::vector<std::string>>& label_sets) {
  for (const auto& s : label_sets)
    if (std::find(s.begin(), s.end(), text) != s.end() && std::find(s.begin(), s.end(), intended) != s.end()) return true;
  return false;
}

/// A paraphrase and the training label it means.
struct Paraphrase {
  std::string text;
  std::string intended;
};

/// Paraphrases of the training labels made of words outside them (docs/generator.md, "Words it has
/// not seen"). Written down, with the label meant, before their landings were measured.
inline const std::vector<Paraphrase>& unseen_word_paraphrases() {
  static const std::vector<Paraphrase> p = {
      {"raise your hands", "arms high"},          {"lift both arms up", "arms high"},
      {"put your hands up", "arms high"},         {"hands up", "arms high"},
      {"reach for the sky", "arms high"},         {"elevate your arms", "arms high"},
      {"stretch your arms upward", "arms high"},  {"greet with the right hand", "wave right hand"},
      {"signal with the right hand", "wave right hand"}, {"flap your left hand", "wave left hand"},
      {"greet with the left hand", "wave left hand"},    {"greet with both hands", "wave both hands"},
      {"hit with the fist", "punch"},             {"jab", "punch"},
      {"strike", "punch"},                        {"slug someone", "punch"},
      {"uppercut", "punch"},                      {"spar", "punch"},
      {"polish the table", "wipe"},               {"rub the window", "wipe"},
      {"paddle", "swim"},                         {"breaststroke", "swim"},
      {"do the crawl", "swim"},                   {"star jumps", "jumping jack arms"},
      {"hoist an arm", "lift arm"},               {"fence", "swordplay"},
      {"duel with a sabre", "swordplay"},         {"shower", "wash self"},
      {"scrub yourself", "wash self"},            {"gesticulate", "expressive arms"},
      {"animated arms", "expressive arms"},       {"spin your arms", "rotate arms"},
      {"circle your arms", "rotate arms"},        {"twirl the arms", "rotate arms"},
      {"revolve both arms", "rotate arms"},       {"stroll", "walk"},
      {"amble", "walk"},                          {"stride", "walk"},
      {"march", "walk"},                          {"saunter", "walk"},
      {"jog", "run"},                             {"sprint", "run"},
      {"dash", "run"},                            {"leap", "jump"},
      {"hop", "jump"},                            {"punt the ball", "kick"},
  };
  return p;
}

/// A second, held-out list (issue 42): written down, each with the label meant, before any change
/// to the mapping or the landing rule was made and before its landings were measured; used only to
/// judge a change, never to tune one (tuning uses `unseen_word_paraphrases()`). Its content words
/// are outside the training vocabulary and outside the first list's new words; the labels are
/// covered in about the first list's proportions.
inline const std::vector<Paraphrase>& heldout_paraphrases() {
  static const std::vector<Paraphrase> p = {
      {"put both arms in the air", "arms high"},            {"hold your arms aloft", "arms high"},
      {"raise your hands skyward", "arms high"},            {"lift your hands above your head", "arms high"},
      {"extend your arms toward the ceiling", "arms high"}, {"salute with the right hand", "wave right hand"},
      {"beckon with your right hand", "wave right hand"},   {"waggle the left hand", "wave left hand"},
      {"flutter both hands", "wave both hands"},            {"pummel", "punch"},
      {"thump someone", "punch"},                           {"throw a left hook", "punch"},
      {"fistfight", "punch"},                               {"mop the floor", "wipe"},
      {"dust the shelf", "wipe"},                           {"do the backstroke", "swim"},
      {"go for a dip", "swim"},                             {"side straddle hops", "jumping jack arms"},
      {"uplift an arm", "lift arm"},                        {"wield a blade", "swordplay"},
      {"cross swords", "swordplay"},                        {"bathe", "wash self"},
      {"lather yourself", "wash self"},                     {"gesture emphatically", "expressive arms"},
      {"windmill your arms", "rotate arms"},                {"swivel the arms", "rotate arms"},
      {"roll your arms", "rotate arms"},                    {"trudge", "walk"},
      {"wander", "walk"},                                   {"pace", "walk"},
      {"tiptoe", "walk"},                                   {"race", "run"},
      {"scamper", "run"},                                   {"bounce", "jump"},
      {"vault", "jump"},                                    {"boot the football", "kick"},
  };
  return p;
}

}  // namespace maskadapt::tracking
