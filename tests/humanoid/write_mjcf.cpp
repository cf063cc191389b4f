// Writes the reference humanoid's MJCF to the path given (or stdout).
#include <maskadapt/humanoid/mjcf.hpp>

#include <fstream>
#include <iostream>

int main(int argc, char** argv) {
  const std::string xml = maskadapt::humanoid_mjcf(maskadapt::humanoid_description());
  if (argc < 2) {
    std::cout << xml;
    return 0;
  }
  std::ofstream out(argv[1], std::ios::binary);
  out << xml;
  if (!out) {
    std::cerr << "cannot write " << argv[1] << "\n";
    return 1;
  }
  return 0;
}
