#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/sampler.hpp>

#include <gtest/gtest.h>

#include <map>

using namespace maskadapt;

TEST(MaskSampler, RandomFollowsProbabilityAndSizeBound) {
  const MaskSampler s = MaskSampler::random(0.8, 3);
  EXPECT_EQ(s.choices().size(), 25u);  // C(5,1) + C(5,2) + C(5,3)
  Rng r(1);
  const int n = 50000;
  int null_count = 0;
  std::map<std::uint8_t, int> hist;
  for (int i = 0; i < n; ++i) {
    const PartMask m = s.sample(r);
    ASSERT_LE(m.count(), 3);
    if (m.empty()) ++null_count;
    else ++hist[m.bits];
  }
  // P(null) = 0.2: 4σ ≈ 0.0072.
  EXPECT_NEAR(null_count / double(n), 0.2, 0.0072);
  // Every allowed subset appears, uniformly: expected 0.8·n/25 = 1600 each, σ ≈ 39.
  EXPECT_EQ(hist.size(), 25u);
  for (const auto& [bits, count] : hist) EXPECT_NEAR(count, 1600, 200) << PartMask{bits}.to_string();
}

TEST(MaskSampler, SeededAndReproducible) {
  const MaskSampler s = MaskSampler::random();
  Rng a(42), b(42), c(43);
  std::vector<std::uint8_t> sa, sb, sc;
  for (int i = 0; i < 100; ++i) sa.push_back(s.sample(a).bits), sb.push_back(s.sample(b).bits), sc.push_back(s.sample(c).bits);
  EXPECT_EQ(sa, sb);
  EXPECT_NE(sa, sc);
}

TEST(MaskSampler, EdgeProbabilitiesAndBounds) {
  Rng r(2);
  const MaskSampler never = MaskSampler::random(0.0, 3), always1 = MaskSampler::random(1.0, 1);
  for (int i = 0; i < 200; ++i) {
    EXPECT_TRUE(never.sample(r).empty());
    EXPECT_EQ(always1.sample(r).count(), 1);
  }
  EXPECT_THROW(MaskSampler::random(1.5), Error);
  EXPECT_THROW(MaskSampler::random(0.5, 0), Error);
  EXPECT_THROW(MaskSampler::random(0.5, 6), Error);
}

TEST(MaskSampler, FixedIgnoresTimeAndRng) {
  const PartMask legs = PartMask::parse("legs");
  const MaskSampler s = MaskSampler::fixed(legs);
  Rng r(3);
  const auto before = r.state().s;
  EXPECT_EQ(s.sample(r, 0.0), legs);
  EXPECT_EQ(s.sample(r, 100.0), legs);
  EXPECT_EQ(r.state().s, before);
}

TEST(MaskSampler, ScheduleFromText) {
  const MaskSampler s = MaskSampler::scheduled("0:lower_body,5:upper_body");
  Rng r(0);
  EXPECT_EQ(s.sample(r, 0.0), PartMask::parse("left_leg,right_leg"));
  EXPECT_EQ(s.sample(r, 4.999), PartMask::parse("lower_body"));
  EXPECT_EQ(s.sample(r, 5.0), PartMask::parse("trunk,left_arm,right_arm"));
  EXPECT_EQ(s.sample(r, 1e6), PartMask::parse("upper_body"));
  // Multi-part entries, ';' separators, a late start (null mask before it).
  const auto sched = parse_mask_schedule("1.5:left_leg,right_arm; 2.5:none");
  ASSERT_EQ(sched.size(), 2u);
  EXPECT_DOUBLE_EQ(sched[0].time, 1.5);
  EXPECT_EQ(sched[0].mask, PartMask::of(BodyPart::LeftLeg) | PartMask::of(BodyPart::RightArm));
  const MaskSampler t = MaskSampler::scheduled(sched);
  EXPECT_TRUE(t.sample(r, 1.0).empty());
  EXPECT_EQ(t.sample(r, 2.0).count(), 2);
  EXPECT_TRUE(t.sample(r, 3.0).empty());
}

TEST(MaskSampler, ScheduleErrorsNameTheProblem) {
  auto message = [](const char* text) {
    try {
      parse_mask_schedule(text, "eval.mask");
    } catch (const Error& e) {
      EXPECT_EQ(e.context().field, "eval.mask");
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("0:legs,x:arms").find("bad time 'x'"), std::string::npos);
  EXPECT_NE(message("5:legs,2:arms").find("must increase"), std::string::npos);
  EXPECT_NE(message("0:tail").find("unknown body part 'tail'"), std::string::npos);
  EXPECT_NE(message("legs").find("has no time"), std::string::npos);
  EXPECT_NE(message("").find("empty"), std::string::npos);
  EXPECT_NE(message("-1:legs").find("bad time"), std::string::npos);
  EXPECT_NE(message("nan:legs").find("bad time"), std::string::npos);
}
