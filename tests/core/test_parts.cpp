#include <maskadapt/mask/parts.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;

TEST(PartMask, ParsesNamesAndGroups) {
  EXPECT_EQ(PartMask::parse("left_leg,right_leg"), PartMask::parse("lower_body"));
  EXPECT_EQ(PartMask::parse("upper_body").count(), 3);
  EXPECT_TRUE(PartMask::parse("none").empty());
  EXPECT_EQ(PartMask::parse("all"), PartMask::all());
  EXPECT_EQ(PartMask::parse(" arms ").to_string(), "left_arm,right_arm");
  EXPECT_THROW(PartMask::parse("left_tentacle"), Error);
  EXPECT_THROW(PartMask::parse(""), Error);
}

TEST(PartMask, ComplementAndArray) {
  const PartMask m = PartMask::parse("trunk,right_leg");
  EXPECT_EQ((~m).count(), 3);
  EXPECT_TRUE((m & ~m).empty());
  const auto a = m.as_array<float>();
  EXPECT_EQ(a[0], 1.f);
  EXPECT_EQ(a[4], 1.f);
  EXPECT_EQ(a[1] + a[2] + a[3], 0.f);
}
