#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;

TEST(MaskApply, ZeroesExactlyTheAssignedElements) {
  const auto parts = observation_parts(humanoid_skeleton());
  const PartElements pe(parts);
  Rng r(1);
  const Index batch = 32;
  MatrixXf obs(328, batch);
  for (Index k = 0; k < obs.size(); ++k) obs.data()[k] = static_cast<float>(r.normal()) + 3.0f;  // never 0
  std::vector<PartMask> masks;
  for (int b = 0; b < batch; ++b) masks.push_back(PartMask{static_cast<std::uint8_t>(b)});  // all 32 masks
  MatrixXf masked = obs;
  apply_masks(pe, std::span<const PartMask>(masks), masked);
  for (Index b = 0; b < batch; ++b)
    for (Index j = 0; j < 328; ++j) {
      if (masks[static_cast<std::size_t>(b)].has(parts[static_cast<std::size_t>(j)])) ASSERT_EQ(masked(j, b), 0.0f) << j << "," << b;
      else ASSERT_EQ(masked(j, b), obs(j, b)) << j << "," << b;
    }
  // Sizes of the humanoid's part groups: each of the 4 limbs has 4 bodies × 15 elements.
  EXPECT_EQ(pe.of_part[static_cast<int>(BodyPart::LeftArm)].size(), 60u);
  EXPECT_EQ(pe.of_part[static_cast<int>(BodyPart::Trunk)].size(), 328u - 4 * 60u);
}

TEST(MaskApply, PolicyInputIsMaskedStateAndMaskBits) {
  const PartElements pe(observation_parts(humanoid_skeleton()));
  Rng r(2);
  MatrixXf obs = MatrixXf::Random(328, 3);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::parse("left_arm,right_leg"), PartMask::all()};
  const MatrixXf in = policy_input<float>(pe, obs, masks);
  ASSERT_EQ(in.rows(), 333);
  EXPECT_TRUE(in.col(0).head(328).isApprox(obs.col(0)));
  EXPECT_EQ(in.col(0).tail(5), VectorXf::Zero(5));
  EXPECT_EQ(in.col(1).tail(5), (VectorXf(5) << 0, 1, 0, 0, 1).finished());
  EXPECT_EQ(in.col(2).head(328), VectorXf::Zero(328));
  EXPECT_EQ(in.col(2).tail(5), VectorXf::Ones(5));
  // keep_vector agrees with apply_masks.
  const VectorXf keep = keep_vector<float>(pe, masks[1]);
  EXPECT_EQ(in.col(1).head(328), obs.col(1).cwiseProduct(keep));
}

TEST(MaskApply, RejectsShapeMismatches) {
  const PartElements pe(observation_parts(humanoid_skeleton()));
  MatrixXf obs = MatrixXf::Zero(328, 2);
  const std::vector<PartMask> one = {PartMask::none()};
  EXPECT_THROW(apply_masks(pe, std::span<const PartMask>(one), obs), Error);
  MatrixXf wrong = MatrixXf::Zero(300, 1);
  EXPECT_THROW(apply_masks(pe, std::span<const PartMask>(one), wrong), Error);
  MatrixXf out(332, 2);
  const std::vector<PartMask> two(2);
  EXPECT_THROW(build_policy_input<float>(pe, obs, two, out), Error);
}
