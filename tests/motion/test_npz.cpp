// npz: our writer → our reader, deflated and zip64 members built here with zlib, corrupt
// archives, AMASS member checks, clip save/load.
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/npz.hpp>

#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>

using namespace maskadapt;

namespace {

void put16(std::string& s, std::uint32_t v) {
  s += static_cast<char>(v & 0xff);
  s += static_cast<char>((v >> 8) & 0xff);
}
void put32(std::string& s, std::uint32_t v) {
  put16(s, v & 0xffff);
  put16(s, v >> 16);
}

/// A zip with one deflated member (raw deflate via zlib), as Python's zipfile writes it.
std::string deflated_zip(const std::string& name, const std::string& data) {
  z_stream zs{};
  deflateInit2(&zs, 6, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&zs, data.size()), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  const auto crc = static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
  std::string z;
  put32(z, 0x04034b50);
  put16(z, 20); put16(z, 0); put16(z, 8); put16(z, 0); put16(z, 0);
  put32(z, crc); put32(z, static_cast<std::uint32_t>(out.size())); put32(z, static_cast<std::uint32_t>(data.size()));
  put16(z, static_cast<std::uint32_t>(name.size())); put16(z, 0);
  z += name;
  z += out;
  const auto cd_off = static_cast<std::uint32_t>(z.size());
  std::string cd;
  put32(cd, 0x02014b50);
  put16(cd, 20); put16(cd, 20); put16(cd, 0); put16(cd, 8); put16(cd, 0); put16(cd, 0);
  put32(cd, crc); put32(cd, static_cast<std::uint32_t>(out.size())); put32(cd, static_cast<std::uint32_t>(data.size()));
  put16(cd, static_cast<std::uint32_t>(name.size())); put16(cd, 0); put16(cd, 0); put16(cd, 0); put16(cd, 0);
  put32(cd, 0); put32(cd, 0);
  cd += name;
  z += cd;
  put32(z, 0x06054b50); put16(z, 0); put16(z, 0); put16(z, 1); put16(z, 1);
  put32(z, static_cast<std::uint32_t>(cd.size())); put32(z, cd_off); put16(z, 0);
  return z;
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
