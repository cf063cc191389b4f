#pragma once
// Helpers shared by the motion tests: where the shared CMU clips are.
#include <cstdlib>
#include <filesystem>
#include <string>

namespace maskadapt::test {

/// <data dir>/motions/cmu, from MASKADAPT_DATA_DIR or the compiled-in default; empty if absent.
inline std::string cmu_dir() {
  std::string base;
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) base = e;
#ifdef MASKADAPT_DEFAULT_DATA_DIR
  if (base.empty()) base = MASKADAPT_DEFAULT_DATA_DIR;
#endif
  const auto dir = std::filesystem::path(base) / "motions" / "cmu";
  return std::filesystem::is_directory(dir) ? dir.string() : std::string();
}

}  // namespace maskadapt::test

#define MASKADAPT_REQUIRE_CMU(dir)                                                                  \
  const std::string dir = ::maskadapt::test::cmu_dir();                                             \
  if (dir.empty())                                                                                  \
  GTEST_SKIP() << "shared CMU clips not found (set MASKADAPT_DATA_DIR to the directory holding "    \
                  "motions/cmu/)"
