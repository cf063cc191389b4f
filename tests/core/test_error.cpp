#include <maskadapt/core/error.hpp>

#include <gtest/gtest.h>

#include <limits>

using namespace maskadapt;

TEST(Error, MessageNamesFileLineAndField) {
  Error e("expected 3 channels, got 2", {"walk.bvh", 12, "CHANNELS"});
  EXPECT_STREQ(e.what(), "walk.bvh:12: field 'CHANNELS': expected 3 channels, got 2");
  EXPECT_EQ(e.context().line.value(), 12);
}

TEST(Error, RequireFiniteReportsPosition) {
  Eigen::MatrixXf m = Eigen::MatrixXf::Zero(3, 4);
  EXPECT_NO_THROW(require_finite(m, "obs"));
  m(1, 2) = std::numeric_limits<float>::quiet_NaN();
  try {
    require_finite(m, "obs");
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("field 'obs'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("row 1, col 2"), std::string::npos) << e.what();
  }
}
