// Writes the G1-like robot's MJCF to the path given (or stdout): maskadapt_g1_mjcf assets/g1.xml
#include <maskadapt/g1/mjcf.hpp>

#include <fstream>
#include <iostream>

int main(int argc, char** argv) {
  const std::string xml = maskadapt::g1::g1_mjcf(maskadapt::g1::g1_description());
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
