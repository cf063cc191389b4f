// BVH reader/writer: hand-written files (every malformed case names its line), every shared
// CMU clip, read → write → read round trips.
#include <maskadapt/motion/bvh.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "test_util.hpp"

using namespace maskadapt;

namespace {

// A two-joint file with a LAFAN1-like twist: positions on the child joint, ZXY order.
const std::string kGood =
    "HIERARCHY\n"
    "ROOT Hips\n"
    "{\n"
    "\tOFFSET 0 0 0\n"
    "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
    "\tJOINT Leg\n"
    "\t{\n"
    "\t\tOFFSET 0 -10 0\n"
    "\t\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "\t\tEnd Site\n"
    "\t\t{\n"
    "\t\t\tOFFSET 0 -5 0\n"
    "\t\t}\n"
    "\t}\n"
    "}\n"
    "MOTION\n"
    "Frames: 2\n"
    "Frame Time: .0333333\n"
    "1 2 3 0 0 0 0 -10 0 0 0 0\n"
    "1.5 2 3 90 0 0 0 -10 0 0 90 0\n";

/// Expects parse() to throw an Error whose context line is `line` and whose message contains `what`.
void expect_error_at(const std::string& text, long long line, const std::string& what) {
  try {
    bvh::parse(text, "test.bvh");
    FAIL() << "no error; expected one at line " << line << " containing '" << what << "'";
  } catch (const Error& e) {
    ASSERT_TRUE(e.context().line.has_value()) << e.what();
    EXPECT_EQ(*e.context().line, line) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("test.bvh:"), std::string::npos) << e.what();
  }
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  return s.replace(p, from.size(), to);
}

}  // namespace

TEST(Bvh, ParsesHierarchyChannelsAndFrames) {
  const auto m = bvh::parse(kGood);
  ASSERT_EQ(m.num_joints(), 3);  // Hips, Leg, Leg_End
  EXPECT_EQ(m.joints[1].name, "Leg");
  EXPECT_EQ(m.joints[2].name, "Leg_End");
  EXPECT_TRUE(m.joints[2].end_site);
  EXPECT_EQ(m.joints[2].parent, 1);
  EXPECT_EQ(m.num_channels(), 12);
  EXPECT_EQ(m.joints[1].first_channel, 6);
  EXPECT_EQ(m.num_frames(), 2);
  EXPECT_NEAR(m.frame_time, 0.0333333, 1e-12);
  EXPECT_DOUBLE_EQ(m.frames(0, 1), 1.5);
}

TEST(Bvh, ForwardKinematicsFollowsChannelOrder) {
  const auto m = bvh::parse(kGood);
  Matrix3X pos;
  std::vector<Quat> rot;
  bvh::forward_kinematics(m, 1, pos, rot);
  // root: Z 90° then (Y, X) 0 → x axis maps to y; leg offset (0,-10,0) → (10, 0, 0) from (1.5,2,3)
  EXPECT_TRUE(pos.col(0).isApprox(Vec3(1.5, 2, 3)));
  EXPECT_NEAR((pos.col(1) - Vec3(11.5, 2, 3)).norm(), 0, 1e-9);
  // leg: ZXY with X = 90° rotates its -y end offset to -z (in the leg frame), then root Rz(90)
  const Vec3 end_local = Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX())) * Vec3(0, -5, 0);
  const Vec3 expected = pos.col(1) + rot[0] * end_local;
  EXPECT_NEAR((pos.col(2) - expected).norm(), 0, 1e-9);
  EXPECT_NEAR(expected.z(), 3 - 5, 1e-9);
}

TEST(Bvh, AcceptsWhitespaceCrLfTabsCommentsAndExponents) {
  std::string t = kGood;
  // CR LF everywhere, comments, keywords in another case, tab after Frames:, exponent numbers
  std::string crlf;
  for (char c : t) {
    if (c == '\n') crlf += "\r\n";
    else crlf += c;
  }
  crlf = replace(crlf, "ROOT Hips", "# a comment line\r\nroot Hips  // trailing comment");
  crlf = replace(crlf, "Frames: 2", "Frames:\t2");
  crlf = replace(crlf, "1.5 2 3 90", "1.5e0 2 3 9.0E+1");
  crlf += "\r\n\r\n";  // trailing blank lines
  const auto m = bvh::parse(crlf);
  EXPECT_EQ(m.num_frames(), 2);
  EXPECT_DOUBLE_EQ(m.frames(3, 1), 90.0);
}

TEST(Bvh, MalformedInputsNameTheLine) {
  expect_error_at(replace(kGood, "\t{\n\t\tOFFSET 0 -10 0", "\t\tOFFSET 0 -10 0"), 7, "expected '{'");
  expect_error_at(replace(kGood, "\t\t}\n\t}\n}\nMOTION", "\t\t}\n\t}\nMOTION"), 15, "missing '}'");
  expect_error_at(replace(kGood, "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation", "CHANNELS 5 Xposition Yposition Zposition Zrotation Xrotation"), 9, "lists 6");
  expect_error_at(replace(kGood, "Zrotation Xrotation Yrotation", "Zrotation Xrotation Wrotation"), 9, "unknown channel");
  expect_error_at(replace(kGood, "1.5 2 3 90 0 0 0 -10 0 0 90 0", "1.5 2 3 90 0 0 0 -10 0 0 90"), 20, "has 11 values");
  expect_error_at(replace(kGood, "1.5 2 3 90 0 0", "1.5 2 3 ninety 0 0"), 20, "'ninety'");
  expect_error_at(replace(kGood, "1 2 3 0 0 0 0", "1 2 3 nan 0 0 0"), 19, "finite");
  expect_error_at(replace(kGood, "Frames: 2", "Frames: 3"), 17, "has 2 data rows");
  expect_error_at(replace(kGood, "Frames: 2", "Frames: 1"), 20, "more data rows");
  expect_error_at(replace(kGood, "OFFSET 0 -10 0", "OFFSET 0 -10"), 8, "OFFSET needs 3 values");
  expect_error_at(replace(kGood, "MOTION\n", ""), 16, "Frames");
  expect_error_at(replace(kGood, "Frame Time: .0333333", "Frame Time: 0"), 18, "positive");
  expect_error_at(kGood.substr(0, kGood.find("MOTION")), 16, "end of file");
  expect_error_at("HIERARCHY\n}\n", 2, "unmatched '}'");
  expect_error_at("HIERARCHY\nMOTION\nFrames: 0\nFrame Time: 1\n", 2, "before any ROOT");
  expect_error_at("HIERARCHY\nJOINT x\n{\n}\n", 2, "outside of any joint");
  expect_error_at("hello\n", 1, "HIERARCHY");
  expect_error_at("", 1, "end of file");
}

TEST(Bvh, WriteReadRoundTrip) {
  const auto m = bvh::parse(kGood);
  const auto m2 = bvh::parse(bvh::to_string(m));
  ASSERT_EQ(m2.num_joints(), m.num_joints());
  for (int j = 0; j < m.num_joints(); ++j) {
    EXPECT_EQ(m2.joints[j].name, m.joints[j].name);
    EXPECT_EQ(m2.joints[j].parent, m.joints[j].parent);
    EXPECT_EQ(m2.joints[j].channels, m.joints[j].channels);
    EXPECT_TRUE(m2.joints[j].offset.isApprox(m.joints[j].offset));
  }
  EXPECT_TRUE(m2.frames.isApprox(m.frames, 1e-12));
  EXPECT_NEAR(m2.frame_time, m.frame_time, 1e-12);
}

TEST(Bvh, WriterRejectsNonFiniteValues) {
  auto m = bvh::parse(kGood);
  m.frames(0, 0) = std::numeric_limits<double>::quiet_NaN();
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_nan.bvh").string();
  EXPECT_THROW(bvh::write(path, m), Error);
}

TEST(Bvh, ReadsEverySharedCmuClipAndRoundTrips) {
  MASKADAPT_REQUIRE_CMU(dir);
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".bvh") continue;
    SCOPED_TRACE(e.path().filename().string());
    const auto m = bvh::read(e.path().string());
    const bool kick = e.path().filename().string().find("135_04") == 0;
    EXPECT_EQ(m.num_channels(), kick ? 132 : 96);
    EXPECT_NEAR(m.fps(), 120.0, 0.01);
    EXPECT_GT(m.num_frames(), 100);
    EXPECT_EQ(m.joints[0].name, kick ? "hip" : "Hips");
    const auto m2 = bvh::parse(bvh::to_string(m));
    EXPECT_EQ(m2.num_frames(), m.num_frames());
    EXPECT_LT((m2.frames - m.frames).cwiseAbs().maxCoeff(), 1e-6);
    ++files;
  }
  EXPECT_EQ(files, 15);
}

TEST(Bvh, CmuKickFrameCountsFromReadme) {
  MASKADAPT_REQUIRE_CMU(dir);
  const auto m = bvh::read(dir + "/135_04_front_kick.bvh");
  EXPECT_EQ(m.num_frames(), 1317);
  // README: 43 joints; the reader also keeps the 14 End Sites (eyes, 10 finger tips, 2 toe tips)
  int end_sites = 0;
  for (const auto& j : m.joints) end_sites += j.end_site;
  EXPECT_EQ(end_sites, 14);
  EXPECT_EQ(m.num_joints(), 43 + 14);
}
