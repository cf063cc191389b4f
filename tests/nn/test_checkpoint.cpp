#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "maskadapt/core/checkpoint.hpp"
#include "maskadapt/nn/serialize.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;
namespace fs = std::filesystem;

namespace {
fs::path temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("maskadapt_nn_ckpt_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

Checkpoint small_checkpoint() {
  Checkpoint c;
  Eigen::Matrix<float, 2, 3> m;
  m << 1, 2, 3, 4, 5, std::numeric_limits<float>::quiet_NaN();
  c.put("w", m);
  c.put("v", Eigen::Vector2d(-0.5, 1e300));
  c.put_int("iteration", 42);
  c.put_string("config", R"({"lr":0.001})");
  Rng r(3);
  r.normal();
  c.put_rng("rng", r);
  return c;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}
}  // namespace

TEST(Checkpoint, RoundTripIsBitExact) {
  const Checkpoint c = small_checkpoint();
  const std::vector<std::uint8_t> bytes = serialize_checkpoint(c);
  const Checkpoint back = parse_checkpoint(bytes);
  EXPECT_EQ(back.names(), c.names());
  for (const auto& [name, s] : c.sections()) {
    EXPECT_EQ(back.section(name).dtype, s.dtype) << name;
    EXPECT_EQ(back.section(name).shape, s.shape) << name;
    EXPECT_EQ(back.section(name).data, s.data) << name;  // byte-wise, NaN payload included
  }
  EXPECT_EQ(serialize_checkpoint(back), bytes);
  const Eigen::MatrixXf w = back.get_matrix<float>("w", 2, 3);
  EXPECT_EQ(w(1, 1), 5.f);
  EXPECT_TRUE(std::isnan(w(1, 2)));
  EXPECT_EQ(back.get_vector<double>("v", 2)[1], 1e300);
  EXPECT_EQ(back.get_int("iteration"), 42);
  EXPECT_EQ(back.get_string("config"), R"({"lr":0.001})");
  Rng r(3);
  r.normal();
  Rng restored;
  restored.set_state(back.get_rng("rng"));
  EXPECT_EQ(restored.normal(), r.normal());  // the cached spare normal survives
  EXPECT_EQ(restored(), r());
}

TEST(Checkpoint, EverySingleByteFlipIsDetected) {
  const std::vector<std::uint8_t> good = serialize_checkpoint(small_checkpoint());
  for (std::size_t i = 0; i < good.size(); ++i) {
    for (std::uint8_t mask : {std::uint8_t{0x01}, std::uint8_t{0x80}, std::uint8_t{0xff}}) {
      std::vector<std::uint8_t> bad = good;
      bad[i] ^= mask;
      EXPECT_THROW(parse_checkpoint(bad, "flip.ckpt"), Error) << "byte " << i << " mask " << int(mask);
    }
  }
}

TEST(Checkpoint, EveryTruncationIsDetected) {
  const std::vector<std::uint8_t> good = serialize_checkpoint(small_checkpoint());
  for (std::size_t n = 0; n < good.size(); ++n) {
    const std::string what = error_of([&] { parse_checkpoint(good.data(), n, "cut.ckpt"); });
    EXPECT_NE(what, "(no error)") << "length " << n;
    if (n >= 24) {
      EXPECT_NE(what.find("truncated"), std::string::npos) << what;
    }
  }
  std::vector<std::uint8_t> longer = good;
  longer.push_back(0);
  EXPECT_THROW(parse_checkpoint(longer), Error);
}

TEST(Checkpoint, ErrorsNameTheFileAndTheProblem) {
  const fs::path p = temp_path("errors.ckpt");
  save_checkpoint(p, small_checkpoint());
  EXPECT_FALSE(fs::exists(p.string() + ".tmp"));
  const Checkpoint c = load_checkpoint(p);
  EXPECT_EQ(c.source(), p.string());

  std::string e = error_of([&] { c.section("actor.params"); });
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("missing section"), std::string::npos) << e;
  EXPECT_NE(e.find("actor.params"), std::string::npos) << e;
  e = error_of([&] { c.get_vector<float>("w", 7); });
  EXPECT_NE(e.find("shape mismatch"), std::string::npos) << e;
  e = error_of([&] { c.get_vector<double>("w"); });
  EXPECT_NE(e.find("dtype mismatch"), std::string::npos) << e;
  e = error_of([&] { c.get_matrix<float>("w", 3, 2); });
  EXPECT_NE(e.find("shape mismatch"), std::string::npos) << e;

  // Wrong version (checksum recomputed so the version check itself is what fires).
  std::vector<std::uint8_t> bytes = serialize_checkpoint(small_checkpoint());
  bytes[8] = 99;
  const std::uint32_t crc = maskadapt::detail::crc32_of(bytes.data(), bytes.size() - 4);
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  e = error_of([&] { parse_checkpoint(bytes, "v99.ckpt"); });
  EXPECT_NE(e.find("unsupported checkpoint version 99"), std::string::npos) << e;
  EXPECT_NE(e.find("v99.ckpt"), std::string::npos) << e;

  e = error_of([&] { load_checkpoint(temp_path("does_not_exist.ckpt")); });
  EXPECT_NE(e.find("cannot open"), std::string::npos) << e;

  // A corrupted file on disk.
  {
    std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);
    f.put('\x5a');
  }
  e = error_of([&] { load_checkpoint(p); });
  EXPECT_NE(e.find("checksum"), std::string::npos) << e;
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  fs::remove(p);
}

TEST(Checkpoint, SaveReplacesAtomically) {
  const fs::path p = temp_path("atomic.ckpt");
  Checkpoint a, b;
  a.put_int("x", 1);
  b.put_int("x", 2);
  save_checkpoint(p, a);
  save_checkpoint(p, b);
  EXPECT_EQ(load_checkpoint(p).get_int("x"), 2);
  EXPECT_FALSE(fs::exists(p.string() + ".tmp"));
  EXPECT_THROW(save_checkpoint(temp_path("no_such_dir") / "x.ckpt", a), Error);
  fs::remove(p);
}

TEST(Checkpoint, NnObjectsRoundTripAndFailedLoadsLeaveModelsUntouched) {
  Rng rng(8);
  Mlp<float> net(MlpSpec{5, {7, 6}, 3, Activation::SiLU}, rng);
  net.grads().setRandom();
  net.block().adam_m().setRandom();
  net.block().adam_v().setRandom();
  Adam<float> opt;
  opt.set_step_count(17);
  RunningNormalizer<float> norm(5);
  norm.update(Eigen::MatrixXf::Random(5, 30));
  PopArt<float> popart(3, 0.1);
  popart.update(Eigen::MatrixXf::Random(3, 9) * 10, net);

  Checkpoint c;
  save(c, "actor", net);
  save(c, "actor.opt", opt);
  save(c, "obs_norm", norm);
  save(c, "popart", popart);
  const fs::path p = temp_path("nn.ckpt");
  save_checkpoint(p, c);
  const Checkpoint back = load_checkpoint(p);

  const Mlp<float> net2 = load_mlp<float>(back, "actor");
  EXPECT_EQ(net2.spec(), net.spec());
  EXPECT_EQ(0, std::memcmp(net2.block().storage().data(), net.block().storage().data(),
                           sizeof(float) * net.block().storage().size()));
  Adam<float> opt2;
  load(back, "actor.opt", opt2);
  EXPECT_EQ(opt2.step_count(), 17);
  RunningNormalizer<float> norm2(5);
  load(back, "obs_norm", norm2);
  EXPECT_EQ(norm2.count(), norm.count());
  EXPECT_TRUE(norm2.mean() == norm.mean());
  EXPECT_TRUE(norm2.m2() == norm.m2());
  PopArt<float> popart2(3);
  load(back, "popart", popart2);
  EXPECT_TRUE(popart2.mean() == popart.mean());
  EXPECT_TRUE(popart2.second_moment() == popart.second_moment());

  // Mismatched architecture: error, and the target keeps its parameters.
  Mlp<float> other(MlpSpec{5, {7, 6}, 3, Activation::ReLU}, rng);
  const Eigen::VectorXf before = other.block().storage();
  const std::string e = error_of([&] { load(back, "actor", other); });
  EXPECT_NE(e.find("architecture mismatch"), std::string::npos) << e;
  EXPECT_TRUE(other.block().storage() == before);
  RunningNormalizer<float> wrong_dim(4);
  EXPECT_THROW(load(back, "obs_norm", wrong_dim), Error);
  EXPECT_EQ(wrong_dim.count(), 0);
  EXPECT_THROW(load(back, "critic", other), Error);  // missing section
  EXPECT_TRUE(other.block().storage() == before);
  fs::remove(p);
}
