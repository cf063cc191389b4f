// libFuzzer target: the npz/npy reader must parse or throw maskadapt::Error on any input, and an
// archive that parses is then read as AMASS parameters and as a maskadapt clip.
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/npz.hpp>

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    const auto a = maskadapt::npz::parse(bytes, "fuzz.npz");
    try {
      (void)maskadapt::npz::amass_from_archive(a, "fuzz.npz");
    } catch (const maskadapt::Error&) {
    }
    (void)maskadapt::clip_from_archive(a, "fuzz.npz");
  } catch (const maskadapt::Error&) {
  }
  return 0;
}
