// Writes the fuzzers' seed inputs (tests/fuzz/seeds.hpp) into <dir>/bvh and <dir>/npz.
//   make_seeds build-fuzz/seeds
#include <filesystem>
#include <fstream>
#include <iostream>

#include "seeds.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_seeds DIR\n";
    return 2;
  }
  const std::filesystem::path root = argv[1];
  const std::pair<const char*, maskadapt::test::Seeds> sets[] = {{"bvh", maskadapt::test::bvh_seeds()},
                                                                 {"npz", maskadapt::test::npz_seeds()}};
  for (const auto& [target, seeds] : sets) {
    std::filesystem::create_directories(root / target);
    for (const auto& [name, bytes] : seeds) {
      std::ofstream out(root / target / name, std::ios::binary);
      out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      if (!out) {
        std::cerr << "make_seeds: cannot write " << (root / target / name) << "\n";
        return 1;
      }
    }
  }
  return 0;
}
