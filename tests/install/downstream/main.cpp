// Uses a few public headers; prints a deterministic line the test checks.
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <iostream>

int main() {
  maskadapt::Rng rng = maskadapt::Rng::stream(1, 2);
  const auto mask = maskadapt::PartMask::parse("lower_body");
  const maskadapt::Vec3 a(0.1, -0.2, 0.3);
  const auto b = maskadapt::joint_angles_from_rotation(maskadapt::joint_rotation(a));
  std::cout << "downstream ok " << mask.to_string() << " " << ((a - b).norm() < 1e-9) << " "
            << (rng.uniform() < 1.0) << "\n";
  return 0;
}
