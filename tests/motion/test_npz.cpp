// npz: our writer → our reader, deflated and zip64 members built here with zlib, corrupt
// archives, AMASS member checks, clip save/load.
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/npz.hpp>

#include <gtest/gtest.h>

#include <filesystem>

#include "../fuzz/seeds.hpp"

using namespace maskadapt;

namespace {

using test::put16;

/// A zip with one deflated member (raw deflate via zlib), as Python's zipfile writes it.
std::string deflated_zip(const std::string& name, const std::string& data) {
  return test::deflated_zip({{name, data}});
}

/// A hand-built .npy blob with an arbitrary header (dtype / order tests).
std::string npy(const std::string& dict, const std::string& body) {
  std::string h = dict;
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  put16(out, static_cast<std::uint32_t>(h.size()));
  return out + h + body;
}

template <class T>
std::string raw(std::initializer_list<T> v) {
  std::string s(v.size() * sizeof(T), '\0');
  std::memcpy(s.data(), std::data(v), s.size());
  return s;
}

}  // namespace

TEST(Npz, WriteReadRoundTrip) {
  MatrixXd m(2, 3);
  m << 1, 2, 3, 4, 5, -6.5;
  npz::Archive a;
  a["m"] = npz::matrix(m);
  a["s"] = npz::scalar(120.0);
  a["v"] = npz::vector(VectorXd::LinSpaced(5, 0, 1));
  a["t"] = npz::text("walk forward");
  const auto b = npz::parse(npz::serialise(a));
  ASSERT_EQ(b.size(), 4u);
  EXPECT_EQ(npz::as_matrix(b.at("m"), "m"), m);
  EXPECT_EQ(b.at("m").shape, (std::vector<std::size_t>{2, 3}));
  EXPECT_DOUBLE_EQ(npz::as_scalar(b.at("s"), "s"), 120.0);
  EXPECT_EQ(b.at("v").shape, (std::vector<std::size_t>{5}));
  EXPECT_EQ(b.at("t").text, "walk forward");
  EXPECT_FALSE(b.at("t").numeric);
}

TEST(Npz, ReadsDeflatedMembersAndOtherDtypes) {
  // float32, Fortran order (2 × 3): column-major bytes 0 3 1 4 2 5 → rows (0 1 2) (3 4 5)
  const std::string f32 = npy("{'descr': '<f4', 'fortran_order': True, 'shape': (2, 3), }",
                              raw<float>({0, 3, 1, 4, 2, 5}));
  auto a = npz::parse(deflated_zip("poses.npy", f32));
  MatrixXd expect(2, 3);
  expect << 0, 1, 2, 3, 4, 5;
  EXPECT_EQ(npz::as_matrix(a.at("poses"), "poses"), expect);
  // int16, big-endian float64, bool
  a = npz::parse(deflated_zip("i.npy", npy("{'descr': '<i2', 'fortran_order': False, 'shape': (2,), }", raw<std::int16_t>({-2, 7}))));
  EXPECT_EQ(a.at("i").values, (std::vector<double>{-2, 7}));
  std::string be(8, '\0');
  const double x = 1.25;
  std::uint64_t u;
  std::memcpy(&u, &x, 8);
  for (int i = 0; i < 8; ++i) be[i] = static_cast<char>((u >> (8 * (7 - i))) & 0xff);
  a = npz::parse(deflated_zip("b.npy", npy("{'descr': '>f8', 'fortran_order': False, 'shape': (), }", be)));
  EXPECT_DOUBLE_EQ(npz::as_scalar(a.at("b"), "b"), 1.25);
  // a pickled member is kept as unsupported and only fails when used
  a = npz::parse(deflated_zip("o.npy", npy("{'descr': '|O', 'fortran_order': False, 'shape': (), }", "x")));
  EXPECT_FALSE(a.at("o").supported);
  EXPECT_THROW(npz::as_scalar(a.at("o"), "o"), Error);
}

// Deflated members behind zip64 size fields and a zip64 end-of-central-directory record (what
// NumPy writes for large arrays) read back to exactly what was written, AMASS layout included.
TEST(Npz, Zip64DeflatedArchiveReadsBackExactly) {
  const npz::Archive amass = test::amass_seed_archive();
  const std::string bytes = test::deflated_zip(test::npy_members(amass), /*zip64=*/true);
  const npz::Archive back = npz::parse(bytes, "zip64.npz");
  ASSERT_EQ(back.size(), amass.size());
  for (const auto& [name, array] : amass) {
    ASSERT_TRUE(back.count(name)) << name;
    EXPECT_EQ(back.at(name).shape, array.shape) << name;
    EXPECT_EQ(back.at(name).values, array.values) << name;
    EXPECT_EQ(back.at(name).text, array.text) << name;
  }
  const npz::AmassMotion m = npz::amass_from_archive(back, "zip64.npz");
  EXPECT_EQ(m.gender, "neutral");
  EXPECT_EQ(m.betas.size(), 4);
  EXPECT_EQ(npz::as_matrix(back.at("poses"), "poses"), npz::as_matrix(amass.at("poses"), "poses"));
  // The zip64 record is really used: without its locator the archive is rejected by name.
  const std::size_t eocd = bytes.size() - 22;
  std::string broken = bytes;
  broken[eocd - 20] = 'X';
  EXPECT_THROW(npz::parse(broken, "zip64.npz"), Error);
}

TEST(Npz, CorruptArchivesThrowNamingTheMember) {
  npz::Archive a;
  a["poses"] = npz::matrix(MatrixXd::Ones(4, 66));
  const std::string good = npz::serialise(a);
  EXPECT_THROW(npz::parse("not a zip at all, clearly not", "x.npz"), Error);
  EXPECT_THROW(npz::parse(good.substr(0, good.size() / 2), "x.npz"), Error);  // truncated
  std::string flipped = good;
  flipped[200] ^= 0x40;  // inside the member data → CRC mismatch
  try {
    npz::parse(flipped, "x.npz");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, "x.npz");
    EXPECT_EQ(e.context().field, "poses.npy");
    EXPECT_NE(std::string(e.what()).find("CRC"), std::string::npos) << e.what();
  }
  // data shorter than the header's shape claims
  EXPECT_THROW(npz::parse(deflated_zip("p.npy", npy("{'descr': '<f8', 'fortran_order': False, 'shape': (100, 3), }", raw<double>({1, 2}))), "x.npz"), Error);
  // corrupt deflate stream
  std::string z = deflated_zip("p.npy", npy("{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }", raw<double>({1, 2})));
  z[40] ^= 0xff;
  EXPECT_THROW(npz::parse(z, "x.npz"), Error);
}

TEST(Npz, AmassMembersAreChecked) {
  const int N = 5;
  npz::Archive a;
  MatrixXd poses = MatrixXd::Random(N, 156) * 0.3;
  MatrixXd trans = MatrixXd::Random(N, 3);
  a["poses"] = npz::matrix(poses);
  a["trans"] = npz::matrix(trans);
  a["mocap_framerate"] = npz::scalar(120);
  a["betas"] = npz::vector(VectorXd::Ones(16));
  a["gender"] = npz::text("female");
  const auto m = npz::amass_from_archive(npz::parse(npz::serialise(a)));
  EXPECT_EQ(m.num_frames(), N);
  EXPECT_EQ(m.num_joints(), 52);
  EXPECT_EQ(m.poses, poses.transpose());
  EXPECT_EQ(m.trans, trans.transpose());
  EXPECT_EQ(m.fps, 120);
  EXPECT_EQ(m.betas.size(), 16);
  EXPECT_EQ(m.gender, "female");

  auto missing = a;
  missing.erase("trans");
  try {
    npz::amass_from_archive(missing, "clip.npz");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "trans");
  }
  auto bad = a;
  bad["trans"] = npz::matrix(MatrixXd::Zero(N, 2));
  EXPECT_THROW(npz::amass_from_archive(bad), Error);
  bad = a;
  bad["poses"] = npz::matrix(MatrixXd::Zero(N, 60));
  EXPECT_THROW(npz::amass_from_archive(bad), Error);
  bad = a;
  bad["poses"] = npz::text("oops");
  EXPECT_THROW(npz::amass_from_archive(bad), Error);
  bad = a;
  MatrixXd nan = poses;
  nan(1, 1) = std::numeric_limits<double>::quiet_NaN();
  bad["poses"] = npz::matrix(nan);
  EXPECT_THROW(npz::amass_from_archive(bad), Error);
}

TEST(Clip, SaveLoadRoundTrip) {
  MotionClip c;
  c.name = "test";
  c.labels = {"walk forward", "walk"};
  c.description = "hand made";
  c.fps = 30;
  c.loop = true;
  c.resize(4, 63);
  c.q.setRandom();
  c.root_pos.setRandom();
  for (int t = 0; t < 4; ++t) c.set_rot(t, Quat(Eigen::AngleAxisd(0.3 * t, Vec3(1, 2, 3).normalized())));
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_clip_test.npz").string();
  save_clip(path, c);
  const MotionClip d = load_clip(path);
  EXPECT_EQ(d.name, c.name);
  EXPECT_EQ(d.labels, c.labels);
  EXPECT_EQ(d.description, c.description);
  EXPECT_EQ(d.fps, c.fps);
  EXPECT_EQ(d.loop, c.loop);
  EXPECT_EQ(d.q, c.q);
  EXPECT_EQ(d.root_pos, c.root_pos);
  EXPECT_EQ(d.root_rot, c.root_rot);
  // a plain npz without the format tag is refused with a clear error
  npz::Archive other;
  other["q"] = npz::matrix(MatrixXd::Zero(2, 2));
  EXPECT_THROW(clip_from_archive(other, "other.npz"), Error);
  std::filesystem::remove(path);
}
