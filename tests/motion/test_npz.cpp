// npz: our writer → our reader, deflated and zip64 members built here with zlib, corrupt
// archives, AMASS member checks, the xtensor path (members as tensors, AMASS tensors), clip
// save/load.
#include <maskadapt/core/tensor.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/npz.hpp>

#include <gtest/gtest.h>
#include <xtensor/xbuilder.hpp>
#include <xtensor/xmanipulation.hpp>

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
  // the tensors keep the file's (frames × ·) layout; the column-major Eigen matrices written
  // above are (cols × frames) tensors in memory, so their transposed views must match
  EXPECT_TRUE(m.poses == xt::transpose(tensor_view(poses, std::array<std::size_t, 2>{156, N})));
  EXPECT_TRUE(m.trans == xt::transpose(tensor_view(trans, std::array<std::size_t, 2>{3, N})));
  EXPECT_EQ(m.pose(3, 51), Vec3(poses(3, 153), poses(3, 154), poses(3, 155)));
  EXPECT_EQ(m.translation(4), Vec3(trans.row(4).transpose()));
  EXPECT_EQ(m.fps, 120);
  EXPECT_EQ(m.betas.size(), 16u);
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

namespace {

/// The message of the Error `f` throws, with its file and field; fails the test if none.
template <class F>
Error npz_error_from(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no Error thrown";
  return Error("none");
}

bool mentions(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

// A (2 × 3 × 4) tensor of known values and a (5) vector written to a file and read back through
// the xtensor path: shapes, every value, the view lying on the parsed buffer, wrong ranks refused.
TEST(NpzTensor, MembersWrittenAndReadBackAsTensorsKeepShapeAndValues) {
  Tensor<double, 3> x = Tensor<double, 3>::from_shape({2, 3, 4});
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t j = 0; j < 3; ++j)
      for (std::size_t k = 0; k < 4; ++k) x(i, j, k) = 100.0 * i + 10.0 * j + k + 0.5;
  const Tensor<double, 1> v = xt::arange<double>(-2.0, 3.0);  // (5): -2 -1 0 1 2
  npz::Archive a;
  a["x"] = npz::tensor(x);
  a["v"] = npz::tensor(v);
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_npz_tensor_test.npz").string();
  npz::write(path, a);
  const npz::Archive back = npz::read(path);
  std::filesystem::remove(path);

  EXPECT_EQ(back.at("x").shape, (std::vector<std::size_t>{2, 3, 4}));
  const auto xv = npz::member_view<3>(back.at("x"), "x", path);
  ASSERT_EQ(xv.shape(0), 2u);
  ASSERT_EQ(xv.shape(1), 3u);
  ASSERT_EQ(xv.shape(2), 4u);
  EXPECT_EQ(xv(1, 2, 3), 123.5);
  EXPECT_EQ(xv(0, 1, 0), 10.5);
  EXPECT_TRUE(xv == x);
  EXPECT_EQ(&xv(0, 0, 0), back.at("x").values.data());  // a view on the parsed values, no copy
  EXPECT_EQ(&xv(1, 0, 0), back.at("x").values.data() + 12);  // row-major: the last index is contiguous
  const Tensor<double, 3> owned = npz::as_tensor<3>(back.at("x"), "x", path);
  EXPECT_TRUE(owned == x);
  EXPECT_NE(owned.data(), back.at("x").values.data());
  const auto vv = npz::member_view<1>(back.at("v"), "v", path);
  ASSERT_EQ(vv.size(), 5u);
  EXPECT_EQ(vv(0), -2.0);
  EXPECT_EQ(vv(4), 2.0);

  // wrong rank or a text member: refused naming the file and the member
  const Error rank = npz_error_from([&] { (void)npz::member_view<2>(back.at("x"), "x", path); });
  EXPECT_EQ(rank.context().file, path);
  EXPECT_EQ(rank.context().field, "x");
  EXPECT_TRUE(mentions(rank.message(), "expected a 2-D array, got 3 dimensions")) << rank.what();
  npz::Archive t;
  t["name"] = npz::text("walk");
  const Error text = npz_error_from([&] { (void)npz::as_tensor<1>(npz::parse(npz::serialise(t)).at("name"), "name", "t.npz"); });
  EXPECT_EQ(text.context().field, "name");
  EXPECT_TRUE(mentions(text.message(), "not numeric")) << text.what();
}

// A Fortran-ordered 3-D member (NumPy's np.asfortranarray): the file holds element (i, j, k) at
// position i + 2j + 6k; read back, every element sits at its C-order place.
TEST(NpzTensor, FortranOrderedMembersAreReorderedInEveryDimension) {
  std::vector<double> column_major(24);
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t j = 0; j < 3; ++j)
      for (std::size_t k = 0; k < 4; ++k) column_major[i + 2 * j + 6 * k] = 100.0 * i + 10.0 * j + k;
  std::string body(24 * 8, '\0');
  std::memcpy(body.data(), column_major.data(), body.size());
  const auto a = npz::parse(deflated_zip("f.npy", npy("{'descr': '<f8', 'fortran_order': True, 'shape': (2, 3, 4), }", body)));
  const auto f = npz::member_view<3>(a.at("f"), "f");
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t j = 0; j < 3; ++j)
      for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(f(i, j, k), 100.0 * i + 10.0 * j + k) << i << j << k;
  // C order: the flat values count k fastest
  EXPECT_EQ(a.at("f").values[1], 1.0);
  EXPECT_EQ(a.at("f").values[4], 10.0);
  EXPECT_EQ(a.at("f").values[12], 100.0);
}

// AMASS parameters with known values written to a file and read as tensors in the file's layout;
// malformed shapes and values refused naming the file and the member.
TEST(NpzTensor, AmassFileReadsIntoTensorsOfTheFileLayout) {
  const std::size_t T = 3, C = 66;
  Tensor<double, 2> poses = Tensor<double, 2>::from_shape({T, C});  // (frames × 3·joints)
  for (std::size_t t = 0; t < T; ++t)
    for (std::size_t c = 0; c < C; ++c) poses(t, c) = 0.01 * static_cast<double>(t) + 0.001 * static_cast<double>(c);
  Tensor<double, 2> trans = {{0.0, 0.1, 0.9}, {0.2, 0.1, 0.91}, {0.4, 0.1, 0.92}};  // (frames × 3)
  npz::Archive a;
  a["poses"] = npz::tensor(poses);
  a["trans"] = npz::tensor(trans);
  a["mocap_framerate"] = npz::scalar(60.0);
  a["betas"] = npz::tensor(Tensor<double, 2>{{0.5, -0.5}});  // (1, 2): flattened to (2)
  a["gender"] = npz::text("male");
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_npz_amass_tensor_test.npz").string();
  npz::write(path, a);
  const npz::AmassMotion m = npz::read_amass(path);
  EXPECT_EQ(m.num_frames(), 3);
  EXPECT_EQ(m.num_joints(), 22);
  ASSERT_EQ(m.poses.shape(0), T);
  ASSERT_EQ(m.poses.shape(1), C);
  EXPECT_TRUE(m.poses == poses);
  EXPECT_TRUE(m.trans == trans);
  EXPECT_EQ(m.pose(2, 21), Vec3(0.02 + 0.063, 0.02 + 0.064, 0.02 + 0.065));
  EXPECT_EQ(m.pose(1, 0), Vec3(0.01, 0.011, 0.012));
  EXPECT_EQ(m.translation(1), Vec3(0.2, 0.1, 0.91));
  EXPECT_EQ(m.fps, 60.0);
  ASSERT_EQ(m.betas.size(), 2u);
  EXPECT_EQ(m.betas(1), -0.5);
  EXPECT_EQ(m.gender, "male");

  auto refused = [&](const npz::Archive& bad) {
    npz::write(path, bad);
    return npz_error_from([&] { (void)npz::read_amass(path); });
  };
  auto bad = a;
  bad["poses"] = npz::tensor(Tensor<double, 3>::from_shape({T, 22, 3}));  // (frames, joints, 3): not AMASS's layout
  Error e = refused(bad);
  EXPECT_EQ(e.context().file, path);
  EXPECT_EQ(e.context().field, "poses");
  EXPECT_TRUE(mentions(e.message(), "expected shape (frames, 3·joints), got 3 dimensions")) << e.what();
  bad = a;
  bad["poses"] = npz::tensor(xt::view(poses, xt::all(), xt::range(0, 65)));  // 65 columns
  e = refused(bad);
  EXPECT_EQ(e.context().field, "poses");
  EXPECT_TRUE(mentions(e.message(), "got 65 columns")) << e.what();
  bad = a;
  bad["trans"] = npz::tensor(Tensor<double, 2>::from_shape({T + 1, 3}));  // one frame too many
  e = refused(bad);
  EXPECT_EQ(e.context().field, "trans");
  EXPECT_TRUE(mentions(e.message(), "expected shape (3, 3)")) << e.what();
  bad = a;
  Tensor<double, 2> nan = poses;
  nan(1, 4) = std::numeric_limits<double>::infinity();
  bad["poses"] = npz::tensor(nan);
  e = refused(bad);
  EXPECT_EQ(e.context().field, "poses");
  EXPECT_TRUE(mentions(e.message(), "non-finite value (inf) at [1, 4] of a (3, 66) array")) << e.what();
  std::filesystem::remove(path);
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
