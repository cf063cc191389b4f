// Replays the fuzzers' seed corpora and every crash input they ever found (tests/fuzz/*/):
// each must either parse or throw maskadapt::Error — never crash, hang or throw anything else.
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/motion/npz.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace maskadapt;

namespace {
int replay(const std::string& sub, void (*parse)(const std::string&)) {
  int n = 0;
  const auto root = std::filesystem::path(MASKADAPT_FUZZ_DIR);
  for (const char* kind : {"corpus", "regressions"}) {
    const auto dir = root / sub / kind;
    if (!std::filesystem::is_directory(dir)) continue;
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
  }
  return n;
}
}  // namespace

TEST(FuzzRegressions, BvhInputs) {
  const int n = replay("bvh", [](const std::string& s) { (void)bvh::parse(s, "fuzz.bvh"); });
  EXPECT_GT(n, 0) << "no BVH corpus under " << MASKADAPT_FUZZ_DIR;
}

TEST(FuzzRegressions, NpzInputs) {
  const int n = replay("npz", [](const std::string& s) {
    const auto a = npz::parse(s, "fuzz.npz");
    try {
      (void)npz::amass_from_archive(a);
    } catch (const Error&) {
    }
  });
  EXPECT_GT(n, 0) << "no npz corpus under " << MASKADAPT_FUZZ_DIR;
}
