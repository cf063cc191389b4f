// `maskadapt motion info|import|export`: inspect, retarget and convert motion files.
//
//   maskadapt motion info FILE [--joint-map MAP.json] [--markdown]
//   maskadapt motion import FILE --out CLIP.npz [--joint-map MAP.json] [--fps 30] [--from S] [--to S] [--loop] [--label TEXT]…
//                           [--character humanoid|g1]
//   maskadapt motion export CLIP --bvh OUT.bvh [--z-up]
//
// FILE / CLIP: a BVH file (retargeted onto the humanoid), an AMASS .npz, a maskadapt clip .npz,
// or a built-in clip `synthetic:walk|arms|kick|jump`. `import --character g1` retargets the humanoid
// clip further onto the G1-like robot (g1/retarget.hpp) and writes a G1 clip (g1/clip.hpp's .npz
// format), printing the quality figures of g1/retarget_quality.hpp.
#include "cli_checks.hpp"
#include "command_registry.hpp"

#include <maskadapt/g1/retarget.hpp>
#include <maskadapt/g1/retarget_quality.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/quality.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/humanoid/synthetic.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace {

using namespace maskadapt;

struct MotionOptions {
  std::string file, out, bvh_out, joint_map;
  std::string character = "humanoid";  ///< import: humanoid | g1
  double fps = 30.0;
  double from_s = 0.0, to_s = -1.0;  ///< import: the time range kept (s; to < 0: to the end)
  bool loop = false, markdown = false, z_up = false;
  bool fps_given = false;  ///< --fps was on the command line
  std::vector<std::string> labels;
};

/// Loads any supported source as a humanoid clip.
MotionClip load_any(const MotionOptions& o, RetargetReport* rep) {
  if (o.file.rfind("synthetic:", 0) == 0) {
    MotionClip c = synthetic_clip(o.file);
    if (rep) {
      *rep = RetargetReport{};
      rep->source_frames = c.num_frames();
      rep->source_fps = c.fps;
    }
    return c;
  }
  RetargetOptions ro;
  ro.target_fps = o.fps;
  std::unique_ptr<JointMap> map;
  if (!o.joint_map.empty()) map = std::make_unique<JointMap>(read_joint_map(o.joint_map));
  return import_motion(o.file, ro, rep, map.get());
}

void info(const MotionOptions& o) {
  const bool is_bvh = std::filesystem::path(o.file).extension() == ".bvh";
  std::string source;
  if (is_bvh) {
    const bvh::Motion m = bvh::read(o.file);
    int moving = 0;
    for (const auto& j : m.joints) moving += !j.end_site;
    char buf[256];
    std::snprintf(buf, sizeof(buf), "BVH: %d frames at %.2f fps (%.2f s), %d joints + %d end sites, %d channels",
                  m.num_frames(), m.fps(), (m.num_frames() - 1) * m.frame_time, moving, m.num_joints() - moving,
                  m.num_channels());
    source = buf;
  }
  RetargetReport rep;
  const MotionClip c = load_any(o, &rep);
  const QualityReport q = motion_quality(c, humanoid_description());
  const std::string name = std::filesystem::path(o.file).filename().string();
  if (o.markdown) {
    std::printf("| %s | %d | %.0f | %.2f | %.3f | %.3f | %.3f | %.1f | %.1f%% | %.1f%% | %.1f%% |\n", name.c_str(),
                rep.source_frames, rep.source_fps, q.duration, q.root_height_mean, q.foot_skating, q.foot_skating_max,
                1000 * q.penetration_max, 100 * rep.clamped_fraction, 100 * q.self_collision_fraction,
                100 * q.contact_fraction);
    return;
  }
  std::cout << name << "\n";
  if (!source.empty()) std::cout << source << "\n";
  std::printf("humanoid clip: %d frames at %.0f fps (%.2f s), %d joints (%d DoF), loop %s\n", c.num_frames(), c.fps,
              c.duration(), humanoid_skeleton().num_bodies() - 1, c.num_dofs(), c.loop ? "yes" : "no");
  if (!c.labels.empty()) {
    std::cout << "labels:";
    for (const auto& l : c.labels) std::cout << " \"" << l << "\"";
    std::cout << "\n";
  }
  if (is_bvh)
    std::printf("retargeting: root scale %.3f, ground shift %+.3f m, %.2f%% of DoF-frames clamped to limits "
                "(max %.3f rad)%s\n",
                rep.root_scale, rep.ground_shift, 100 * rep.clamped_fraction, rep.max_limit_excess,
                rep.unmapped.empty() ? "" : ", unmapped bodies follow their parents");
  std::cout << q.to_string() << "\n";
}

void import_cmd(const MotionOptions& o) {
  MotionClip c = load_any(o, nullptr);
  // Built-in clips and maskadapt clips keep their own rate; only BVH / AMASS sources are resampled.
  require(!o.fps_given || std::abs(c.fps - o.fps) < 1e-9,
          "only BVH and AMASS sources are resampled; this one stays at its own " + std::to_string(c.fps) + " fps",
          {o.file, std::nullopt, "--fps"});
  if (o.from_s > 0 || o.to_s >= 0) {
    try {
      c = slice_seconds(c, o.from_s, o.to_s, "--from", "--to");
    } catch (const Error& e) {
      throw Error(e.message(), {o.file, std::nullopt, e.context().field});
    }
  }
  if (!o.labels.empty()) c.labels = o.labels;
  if (o.loop) c.loop = true;
  if (o.character == "g1") {
    require(o.labels.empty(), "G1 clips carry no text labels (import onto the humanoid to label a clip)",
            {o.file, std::nullopt, "--label"});
    g1::G1RetargetReport rep;
    const g1::G1Clip g = g1::retarget_to_g1(c, {}, &rep);
    g1::save_g1_clip(o.out, g);
    std::printf("wrote %s: G1 clip, %d frames at %.0f fps (%.2f s), %d joints\n", o.out.c_str(), g.num_frames(), g.fps,
                g.duration(), g1::kNumJoints);
    std::printf("retargeting: root scale %.3f, hand scale %.3f, head scale %.3f; IK iterations %.1f per frame (all "
                "passes), max %d in one solve, %d unconverged solves; feet in stance %.0f%%, root lowered up to %.1f cm, "
                "%d frames lifted (max %.1f cm)\n",
                rep.root_scale, rep.effector_scale, rep.head_scale, rep.mean_iterations, rep.max_iterations,
                rep.unconverged_frames, 100 * rep.stance_fraction, 100 * rep.max_offset, rep.lifted_frames,
                100 * rep.max_lift);
    std::cout << g1::g1_retarget_quality(g, c).to_string() << "\n";
    return;
  }
  save_clip(o.out, c);
  std::printf("wrote %s: %d frames at %.0f fps (%.2f s)\n", o.out.c_str(), c.num_frames(), c.fps, c.duration());
}

void export_cmd(const MotionOptions& o) {
  const MotionClip c = load_any(o, nullptr);
  bvh::write(o.bvh_out, clip_to_bvh(c, humanoid_skeleton(), !o.z_up));
  std::printf("wrote %s: %d frames at %.0f fps, %s\n", o.bvh_out.c_str(), c.num_frames(), c.fps,
              o.z_up ? "Z-up" : "Y-up (Blender: import with the default axes)");
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto opt = std::make_shared<MotionOptions>();
  CLI::App* motion = app.add_subcommand("motion", "Inspect, retarget and convert motion files (BVH, AMASS .npz, clips)");
  motion->require_subcommand(1);

  CLI::App* inf = motion->add_subcommand("info", "Frames, fps, duration, joints and the quality report of a motion");
  inf->add_option("file", opt->file, "BVH, .npz or synthetic:walk|arms|kick|jump")->required();
  inf->add_option("--joint-map", opt->joint_map, "joint map JSON for an unknown BVH skeleton");
  inf->add_flag("--markdown", opt->markdown, "print one Markdown table row (docs/motion.md)");
  inf->callback([opt] { info(*opt); });

  CLI::App* imp = motion->add_subcommand(
      "import", "Retarget a motion onto the humanoid (or further onto the G1 robot) and save it as a clip (.npz)");
  imp->add_option("file", opt->file, "BVH, AMASS .npz or synthetic:NAME")->required();
  imp->add_option("--out", opt->out, "output clip (.npz)")->required();
  imp->add_option("--joint-map", opt->joint_map, "joint map JSON for an unknown BVH skeleton");
  imp->add_option("--fps", opt->fps, "output frame rate (Hz)")->check(maskadapt::cli::positive_real(1000));
  imp->add_option("--from", opt->from_s, "keep the frames from this time on (s from the first frame)")
      ->check(maskadapt::cli::non_negative_real());
  imp->add_option("--to", opt->to_s, "… up to this time (s, inclusive; default: the last frame)")
      ->check(maskadapt::cli::non_negative_real());
  imp->add_flag("--loop", opt->loop, "mark the clip as cyclic");
  imp->add_option("--label", opt->labels, "text label (repeatable)");
  imp->add_option("--character", opt->character,
                  "character of the output clip: humanoid (default) or g1 (retargeted onto the G1 robot, a G1 clip)")
      ->check(maskadapt::cli::one_of({"humanoid", "g1"}));
  imp->callback([opt, imp] {
    opt->fps_given = imp->count("--fps") > 0;
    import_cmd(*opt);
  });

  CLI::App* exp = motion->add_subcommand("export", "Write a clip as BVH (opens in Blender)");
  exp->add_option("clip", opt->file, "clip .npz, BVH, AMASS .npz or synthetic:NAME")->required();
  exp->add_option("--bvh", opt->bvh_out, "output BVH file")->required();
  exp->add_flag("--z-up", opt->z_up, "keep the humanoid's Z-up axes (channels = hinge angles)");
  exp->callback([opt] { export_cmd(*opt); });
});

}  // namespace
