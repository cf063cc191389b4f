#include <maskadapt/tracking/text_encoder.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace maskadapt;
using namespace maskadapt::tracking;

TEST(TextEncoder, TokenizesLowercaseWords) {
  const auto w = tokenize_words("  Raise, BOTH arms!\tnow2 ");
  ASSERT_EQ(w.size(), 4u);
  EXPECT_EQ(w[0], "raise");
  EXPECT_EQ(w[1], "both");
  EXPECT_EQ(w[2], "arms");
  EXPECT_EQ(w[3], "now2");
}

TEST(TextEncoder, Fnv1aKnownValues) {
  EXPECT_EQ(fnv1a64(""), 0xcbf29ce484222325ULL);
  EXPECT_EQ(fnv1a64("a"), 0xaf63dc4c8601ec8cULL);
}

TEST(TextEncoder, DeterministicAndNormalised) {
  const HashedTextFeatures a(256), b(256);
  const VectorXf x = a.features("wave hands");
  EXPECT_TRUE(x == b.features("wave hands"));
  EXPECT_NEAR(x.norm(), 1.0f, 1e-6f);
  EXPECT_TRUE(x == a.features("Wave   HANDS."));  // case and punctuation do not matter
  EXPECT_EQ(a.features("").norm(), 0.0f);
}

TEST(TextEncoder, DistinctTextsDiffer) {
  const HashedTextFeatures f(256);
  const std::vector<std::string> texts = {"raise arms", "wave hands", "punch", "wash self", "rotate arms",
                                          "arms raise", "walk forward", "kick"};
  for (std::size_t i = 0; i < texts.size(); ++i)
    for (std::size_t j = i + 1; j < texts.size(); ++j)
      EXPECT_GT((f.features(texts[i]) - f.features(texts[j])).norm(), 0.1f) << texts[i] << " vs " << texts[j];
  // Word order matters only through bigrams; shared words give overlap.
  const float overlap = f.features("raise arms").dot(f.features("raise both arms"));
  EXPECT_GT(overlap, 0.3f);
  EXPECT_LT(overlap, 0.999f);
}

TEST(TextEncoder, EmbeddingTableFromJson) {
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_test_emb.json").string();
  {
    std::ofstream out(path);
    out << R"({"dim": 3, "embeddings": {"raise arms": [1, 2, 3], "punch": [0, -1, 0.5]}})";
  }
  const auto t = EmbeddingTable::load_json(path);
  EXPECT_EQ(t.dim(), 3);
  EXPECT_TRUE(t.features("punch").isApprox(Eigen::Vector3f(0, -1, 0.5f)));
  EXPECT_THROW(t.features("kick"), Error);
  {
    std::ofstream out(path);
    out << R"({"dim": 3, "embeddings": {"raise arms": [1, 2]}})";
  }
  try {
    EmbeddingTable::load_json(path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "embeddings.raise arms");
    EXPECT_EQ(e.context().file, path);
  }
  {
    std::ofstream out(path);
    out << "{not json";
  }
  EXPECT_THROW(EmbeddingTable::load_json(path), Error);
  std::remove(path.c_str());
}
