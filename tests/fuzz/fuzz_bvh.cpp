// libFuzzer target: the BVH reader must parse or throw maskadapt::Error on any input; a parsed
// motion must survive writing and re-reading and forward kinematics.
#include <maskadapt/motion/bvh.hpp>

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto m = maskadapt::bvh::parse(text, "fuzz.bvh");
    if (m.num_frames() > 0 && m.num_joints() < 200) {
      maskadapt::Matrix3X pos;
      std::vector<maskadapt::Quat> rot;
      maskadapt::bvh::forward_kinematics(m, 0, pos, rot);
    }
    if (m.frames.size() < 100000) {
      const auto again = maskadapt::bvh::parse(maskadapt::bvh::to_string(m, 17), "rewritten.bvh");
      if (again.num_frames() != m.num_frames() || again.num_channels() != m.num_channels()) __builtin_trap();
    }
  } catch (const maskadapt::Error&) {
  }
  return 0;
}
