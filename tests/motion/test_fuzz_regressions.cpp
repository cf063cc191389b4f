// Replays the fuzzers' seed inputs (generated in process, tests/fuzz/seeds.hpp) and every crash
// input they ever found (tests/fuzz/*/regressions): each must either parse or throw
// maskadapt::Error — never crash, hang or throw anything else. The seeds must also parse.
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/motion/npz.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../build_paths.hpp"
#include "../fuzz/seeds.hpp"

using namespace maskadapt;

namespace {
/// Runs `parse` on every file of tests/fuzz/<sub>/regressions; returns how many there were.
int replay_regressions(const std::string& sub, void (*parse)(const std::string&)) {
  int n = 0;
  const auto dir = std::filesystem::path(maskadapt::build_paths::source_dir() + "/tests/fuzz") / sub / "regressions";
  if (!std::filesystem::is_directory(dir)) return 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(e.path(), std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    SCOPED_TRACE(e.path().string());
    try {
      parse(ss.str());
    } catch (const Error&) {
    }
    ++n;
  }
  return n;
}

void parse_npz(const std::string& s) {
  const auto a = npz::parse(s, "fuzz.npz");
  try {
    (void)npz::amass_from_archive(a);
  } catch (const Error&) {
  }
}
}  // namespace

TEST(FuzzRegressions, BvhInputs) {
  const auto seeds = test::bvh_seeds();
  ASSERT_EQ(seeds.size(), 4u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    EXPECT_NO_THROW((void)bvh::parse(bytes, name));
  }
  replay_regressions("bvh", [](const std::string& s) { (void)bvh::parse(s, "fuzz.bvh"); });
}

TEST(FuzzRegressions, NpzInputs) {
  const auto seeds = test::npz_seeds();
  ASSERT_EQ(seeds.size(), 3u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    EXPECT_NO_THROW(parse_npz(bytes));
  }
  replay_regressions("npz", parse_npz);
}
