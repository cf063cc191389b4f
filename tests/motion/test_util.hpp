#pragma once
// Helpers shared by the motion tests: where the shared CMU clips are.
#include "../build_paths.hpp"

#include <cstdlib>
#include <filesystem>
#include <string>

namespace maskadapt::test {

/// <data dir>/motions/cmu, from MASKADAPT_DATA_DIR or the compiled-in default; empty if absent.
inline std::string cmu_dir() {
  std::string base;
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) base = e;
  if (base.empty()) base = maskadapt::build_paths::default_data_dir();
  const auto dir = std::filesystem::path(base) / "motions" / "cmu";
  return std::filesystem::is_directory(dir) ? dir.string() : std::string();
}

}  // namespace maskadapt::test

#define MASKADAPT_REQUIRE_CMU(dir)                                                                  \
  const std::string dir = ::maskadapt::test::cmu_dir();                                             \
  if (dir.empty())                                                                                  \
  GTEST_SKIP() << "shared CMU clips not found (set MASKADAPT_DATA_DIR to the directory holding "    \
                  "motions/cmu/)"

namespace maskadapt::test {

/// <data dir>/motions/<sub> (e.g. "bandai/locomotion"), from MASKADAPT_DATA_DIR or the
/// compiled-in default; empty if absent.
inline std::string motions_dir(const std::string& sub) {
  std::string base;
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) base = e;
  if (base.empty()) base = maskadapt::build_paths::default_data_dir();
  const auto dir = std::filesystem::path(base) / "motions" / sub;
  return !base.empty() && std::filesystem::is_directory(dir) ? dir.string() : std::string();
}

/// The data directory itself (holding motions/), or empty.
inline std::string data_base_dir() {
  const std::string d = motions_dir(".");
  return d.empty() ? d : std::filesystem::path(d).parent_path().parent_path().string();
}

}  // namespace maskadapt::test

#define MASKADAPT_REQUIRE_MOTIONS(dir, sub)                                                         \
  const std::string dir = ::maskadapt::test::motions_dir(sub);                                      \
  if (dir.empty())                                                                                  \
  GTEST_SKIP() << "shared motions/" sub " not found (set MASKADAPT_DATA_DIR to the directory "      \
                  "holding motions/)"
