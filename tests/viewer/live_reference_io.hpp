// What the live viewer's native reference writers (live_reference.cpp,
// live_tracking_reference.cpp) share: numbers and body states as JSON, writing a JSON file, and
// their main(): `maskadapt_viewer_<tool> MODELS_DIR OUT_DIR [--no-native]`.
#pragma once

#include <maskadapt/core/error.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

namespace maskadapt::live_reference {

using nlohmann::json;

/// The entries of a vector or matrix (column-major, as stored) as a flat JSON array of doubles.
json vec(const auto& v) {
  json a = json::array();
  for (Index i = 0; i < v.size(); ++i) a.push_back(static_cast<double>(v.data()[i]));
  return a;
}

/// Body states as flat arrays: pos, lin_vel, ang_vel 3 per body, rot_xyzw 4 per body.
inline json body_states_json(const BodyStates& b) {
  json pos = json::array(), rot = json::array(), lin = json::array(), ang = json::array();
  for (int i = 0; i < b.num_bodies(); ++i) {
    for (int k = 0; k < 3; ++k) {
      pos.push_back(b.pos(k, i));
      lin.push_back(b.lin_vel(k, i));
      ang.push_back(b.ang_vel(k, i));
    }
    const Quat& q = b.rot[static_cast<std::size_t>(i)];
    for (double c : {q.x(), q.y(), q.z(), q.w()}) rot.push_back(c);
  }
  return {{"pos", pos}, {"rot_xyzw", rot}, {"lin_vel", lin}, {"ang_vel", ang}};
}

/// Writes `j` to `p` (json::dump(indent): -1 compact) and says so as "<tool>: wrote <p>".
inline void write_json_file(const std::string& tool, const std::filesystem::path& p, const json& j, int indent) {
  std::ofstream f(p);
  if (!f) throw Error("cannot open for writing", {p.string(), std::nullopt, {}});
  f << j.dump(indent) << "\n";
  if (!f) throw Error("write failed", {p.string(), std::nullopt, {}});
  std::cout << tool << ": wrote " << p.string() << "\n";
}

/// main() of a reference writer: usage (exit 2) without MODELS_DIR OUT_DIR, else creates OUT_DIR
/// and runs body(MODELS_DIR, OUT_DIR, native) (native false with --no-native); a maskadapt::Error
/// is printed as "<tool>: <what>" (exit 1).
template <class Body>
int reference_main(int argc, char** argv, const std::string& tool, Body&& body) try {
  if (argc < 3) {
    std::cerr << "usage: maskadapt_viewer_" << tool << " MODELS_DIR OUT_DIR [--no-native]\n";
    return 2;
  }
  const std::filesystem::path models = argv[1], out = argv[2];
  const bool native = !(argc > 3 && std::string(argv[3]) == "--no-native");
  std::filesystem::create_directories(out);
  body(models, out, native);
  return 0;
} catch (const maskadapt::Error& e) {
  std::cerr << tool << ": " << e.what() << "\n";
  return 1;
}

}  // namespace maskadapt::live_reference
