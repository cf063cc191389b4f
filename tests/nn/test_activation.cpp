#include <gtest/gtest.h>

#include "maskadapt/core/rng.hpp"
#include "maskadapt/nn/activation.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {
const Activation kAll[] = {Activation::Identity, Activation::ReLU, Activation::ELU, Activation::SiLU, Activation::Tanh};
}

TEST(Activation, KnownValues) {
  EXPECT_DOUBLE_EQ(activation_value(Activation::ReLU, -2.0), 0.0);
  EXPECT_DOUBLE_EQ(activation_value(Activation::ReLU, 3.0), 3.0);
  EXPECT_DOUBLE_EQ(activation_value(Activation::ELU, -1.0), std::exp(-1.0) - 1.0);
  EXPECT_DOUBLE_EQ(activation_value(Activation::SiLU, 0.0), 0.0);
  EXPECT_NEAR(activation_value(Activation::SiLU, 2.0), 2.0 / (1.0 + std::exp(-2.0)), 1e-15);
  EXPECT_NEAR(activation_value(Activation::SiLU, -800.0), 0.0, 1e-300);  // no overflow
  EXPECT_DOUBLE_EQ(activation_value(Activation::Tanh, 0.5), std::tanh(0.5));
  EXPECT_DOUBLE_EQ(activation_value(Activation::Identity, -7.25), -7.25);
}

TEST(Activation, FirstAndSecondDerivativesMatchFiniteDifferences) {
  Rng rng(7);
  const double h = 1e-5;
  for (Activation a : kAll) {
    for (int k = 0; k < 200; ++k) {
      double z = rng.uniform(-4.0, 4.0);
      if (std::abs(z) < 1e-3) z += 0.01;  // away from the ReLU/ELU kink
      const double d1 = (activation_value(a, z + h) - activation_value(a, z - h)) / (2 * h);
      const double d2 = (activation_derivative(a, z + h) - activation_derivative(a, z - h)) / (2 * h);
      EXPECT_NEAR(activation_derivative(a, z), d1, 1e-8 * std::max(1.0, std::abs(d1))) << to_string(a) << " z=" << z;
      EXPECT_NEAR(activation_second_derivative(a, z), d2, 1e-8 * std::max(1.0, std::abs(d2))) << to_string(a) << " z=" << z;
    }
  }
}

TEST(Activation, MatrixVersionsMatchScalar) {
  Rng rng(3);
  Eigen::MatrixXd z(4, 5);
  for (Index i = 0; i < z.size(); ++i) z.data()[i] = rng.normal() * 2;
  for (Activation a : kAll) {
    Eigen::MatrixXd v(4, 5), d(4, 5), dd(4, 5);
    apply_activation<double>(a, z, v);
    activation_derivative<double>(a, z, d);
    activation_second_derivative<double>(a, z, dd);
    for (Index i = 0; i < z.size(); ++i) {
      EXPECT_EQ(v.data()[i], activation_value(a, z.data()[i]));
      EXPECT_EQ(d.data()[i], activation_derivative(a, z.data()[i]));
      EXPECT_EQ(dd.data()[i], activation_second_derivative(a, z.data()[i]));
    }
  }
}

TEST(Activation, StringRoundTripAndError) {
  for (Activation a : kAll) EXPECT_EQ(activation_from_string(to_string(a)), a);
  EXPECT_THROW(activation_from_string("gelu"), Error);
}
