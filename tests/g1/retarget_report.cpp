// Quality table of shared clips retargeted onto the G1 (docs/characters.md, "Retargeting onto
// the G1"). Not a test: prints Markdown.
//
//   maskadapt_g1_retarget_report [DATA_DIR] [CLIP.bvh ...]
//
// DATA_DIR defaults to $MASKADAPT_DATA_DIR, else the configured default; clips are paths relative
// to DATA_DIR/motions (default: the list below). Each clip is imported onto the reference humanoid
// (import_motion: 30 Hz, grounded) and retargeted with the default G1RetargetOptions.
#include <maskadapt/g1/retarget_quality.hpp>
#include <maskadapt/motion/quality.hpp>
#include <maskadapt/humanoid/retarget.hpp>

#include "../build_paths.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  using namespace maskadapt;
  using namespace maskadapt::g1;
  std::string base;
  if (argc > 1) base = argv[1];
  if (base.empty())
    if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) base = e;
  if (base.empty()) base = maskadapt::build_paths::default_data_dir();
  const std::filesystem::path motions = std::filesystem::path(base) / "motions";
  if (!std::filesystem::is_directory(motions)) {
    std::fprintf(stderr, "no motions/ under '%s' (pass the data directory or set MASKADAPT_DATA_DIR)\n", base.c_str());
    return 2;
  }
  std::vector<std::string> clips = {"cmu/02_01_walk.bvh",
                                    "cmu/07_01_walk.bvh",
                                    "bandai/locomotion/dataset-2_walk_normal_001.bvh",
                                    "styles/walk.bvh",
                                    "cmu/02_03_run.bvh",
                                    "bandai/locomotion/dataset-2_run_normal_001.bvh",
                                    "bandai/actions/dataset-1_punch_normal_001.bvh",
                                    "styles/SNEAKY.bvh"};
  if (argc > 2) clips.assign(argv + 2, argv + argc);
  std::printf("| clip | frames | source skating (m/s) | G1 skating mean / max (cm/s) | level-foot skating (cm/s) | G1 feet in contact | "
              "limit violations (count, max rad) | penetration max (cm) | end-effector error mean / max (cm) | "
              "feet / hands / head mean (cm) | max joint speed (rad/s) | stance held | ms/frame |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  int failures = 0;
  for (const std::string& rel : clips) {
    const std::string path = (motions / rel).string();
    try {
      const MotionClip src = import_motion(path);
      const QualityReport sq = motion_quality(src, humanoid_description());
      G1RetargetReport rep;
      const auto t0 = std::chrono::steady_clock::now();
      const G1Clip g = retarget_to_g1(src, {}, &rep);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const G1QualityReport q = g1_retarget_quality(g, src);
      std::printf("| %s | %d | %.3f | %.1f / %.1f | %.1f | %.0f%% | %lld, %.3g | %.2f | %.1f / %.1f | %.1f, %.1f / %.1f, %.1f / %.1f | "
                  "%.1f | %.0f%% | %.2f |\n",
                  rel.c_str(), q.frames, sq.foot_skating, 100 * q.foot_skating, 100 * q.foot_skating_max,
                  100 * q.flat_skating, 100 * q.contact_fraction, q.limit_violations, q.limit_excess_max, 100 * q.penetration_max,
                  100 * q.effector_error_mean, 100 * q.effector_error_max, 100 * q.effector_error_by[kLeftFoot],
                  100 * q.effector_error_by[kRightFoot], 100 * q.effector_error_by[kLeftHand],
                  100 * q.effector_error_by[kRightHand], 100 * q.effector_error_by[kHead], q.joint_speed_max,
                  100 * rep.stance_fraction, ms / q.frames);
    } catch (const std::exception& e) {
      std::printf("| %s | error: %s |\n", rel.c_str(), e.what());
      ++failures;
    }
  }
  return failures ? 1 : 0;
}
