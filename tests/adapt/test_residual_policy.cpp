// Residual policy: zero-init equivalence with the base, masked-DoF restriction, the null mask,
// PD targets through the base's action space (normalised bases) and its checkpoint sections,
// gradients vs finite differences; the mask-conditioned discriminator's inputs (blends,
// negative experts, conditioning).
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/tasks/composition.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

using namespace maskadapt;
using RowVectorXf = RowVectorX<float>;

namespace {

constexpr Index kObs = 12, kAct = 9;
// 4 bodies' worth of DoFs: trunk (3), left arm (3), left leg (3)
std::vector<BodyPart> dof_parts() {
  return {BodyPart::Trunk, BodyPart::Trunk, BodyPart::Trunk, BodyPart::LeftArm, BodyPart::LeftArm, BodyPart::LeftArm,
          BodyPart::LeftLeg, BodyPart::LeftLeg, BodyPart::LeftLeg};
}
std::vector<BodyPart> obs_parts() {
  std::vector<BodyPart> p;
  for (Index i = 0; i < kObs; ++i) p.push_back(i < 4 ? BodyPart::Trunk : i < 8 ? BodyPart::LeftArm : BodyPart::LeftLeg);
  return p;
}

rl::GaussianActor<float> make_base(Rng& rng) {
  rl::ActorCriticConfig c;
  c.policy_input_dim = kObs + kNumParts;
  c.critic_input_dim = kObs;
  c.action_dim = kAct;
  c.actor_hidden = {16, 8};
  c.init_log_std = -1.3;
  rl::GaussianActor<float> a(c, rng);
  MatrixXf warm = MatrixXf::Random(kObs + kNumParts, 64) * 2.0f;
  a.normalizer.update(warm);
  return a;
}

adapt::ResidualPolicy<float> make_policy(adapt::GainMode g = adapt::GainMode::PerDof, Index goal_dim = 0,
                                         nn::Activation act = nn::Activation::ReLU) {
  Rng rng(3);
  adapt::ResidualConfig rc;
  rc.activation = act;
  rc.hidden = {16};
  rc.gain = g;
  rc.goal_dim = goal_dim;
  return adapt::ResidualPolicy<float>(make_base(rng), kObs, dof_parts(), rc, rng);
}

/// The composite's samples and the base's on its own masked input, drawn from the same stream.
struct SideBySide {
  MatrixXf x, mu, act, base_mu, base_act;
  RowVectorXf lp;
};
SideBySide sample_beside_the_base(const adapt::ResidualPolicy<float>& pol, const MatrixXf& obs,
                                  const std::vector<PartMask>& masks) {
  const PartElements pe(obs_parts());
  SideBySide s;
  adapt::ResidualWorkspace<float> ws;
  pol.build_input(pe, obs, masks, MatrixXf(), s.x, ws);
  Rng r1(11), r2(11);
  pol.act(s.x, masks, r1, s.act, s.lp, s.mu, ws);
  const MatrixXf base_in = policy_input<float>(pe, obs, masks);
  MatrixXf scratch;
  RowVectorXf base_lp;
  nn::InferenceWorkspace<float> bws;
  pol.base().act(base_in, r2, s.base_act, base_lp, s.base_mu, bws, scratch);
  return s;
}

}  // namespace

TEST(ResidualPolicy, ZeroInitCompositeEqualsBaseExactly) {
  const auto pol = make_policy();
  const MatrixXf obs = MatrixXf::Random(kObs, 6);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm), PartMask::parse("left_leg,trunk"),
                                       PartMask::all(), PartMask::of(BodyPart::RightArm), PartMask::of(BodyPart::LeftLeg)};
  // the base on its masked input, sampled from the same stream
  const auto [x, mu, act, base_mu, base_act, lp] = sample_beside_the_base(pol, obs, masks);
  EXPECT_TRUE((mu.array() == base_mu.array()).all());
  EXPECT_TRUE((act.array() == base_act.array()).all());
  // the residual input carries the base action and the mask bits
  EXPECT_TRUE((x.middleRows(kObs, kAct).array() == base_mu.array()).all());
  EXPECT_EQ(x(kObs + kAct + 1, 1), 1.0f);  // left arm bit of column 1
  EXPECT_EQ(x(kObs + kAct + 1, 0), 0.0f);
}

TEST(ResidualPolicy, ResidualMovesOnlyMaskedDofsAndNullMaskIsTheBase) {
  auto pol = make_policy();
  pol.residual().mean_net.params().setRandom();  // a trained, non-zero residual
  pol.gain().params().setConstant(1.7f);
  const PartElements pe(obs_parts());
  const MatrixXf obs = MatrixXf::Random(kObs, 3);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm), PartMask::of(BodyPart::RightArm)};
  adapt::ResidualWorkspace<float> ws;
  MatrixXf x, mu, act;
  RowVectorXf lp;
  pol.build_input(pe, obs, masks, MatrixXf(), x, ws);
  pol.mean(x, masks, mu, ws);
  const MatrixXf base_mu = x.middleRows(kObs, kAct);
  // null mask / a part with no DoFs here: exactly the base, and log-prob 0 (no gradient)
  EXPECT_TRUE((mu.col(0).array() == base_mu.col(0).array()).all());
  EXPECT_TRUE((mu.col(2).array() == base_mu.col(2).array()).all());
  Rng r(5);
  pol.act(x, masks, r, act, lp, mu, ws);
  EXPECT_EQ(lp[0], 0.0f);
  EXPECT_EQ(lp[2], 0.0f);
  EXPECT_NE(lp[1], 0.0f);
  // left arm: only DoFs 3..5 differ from the base
  for (Index i = 0; i < kAct; ++i) {
    if (i >= 3 && i < 6) EXPECT_NE(mu(i, 1), base_mu(i, 1)) << i;
    else EXPECT_EQ(mu(i, 1), base_mu(i, 1)) << i;
  }
}

TEST(ResidualPolicy, GoalPartsMoveBesideTheMaskWhileTheBaseStillSeesThem) {
  // goal parts (the legs, to walk to a target) are moved on every sample, masked or not, and stay
  // out of the base's hidden parts and the input's mask bits
  Rng rng(3), r1(5), r2(5);
  const rl::GaussianActor<float> base = make_base(rng);
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.gain = adapt::GainMode::PerDof;
  adapt::ResidualPolicy<float> plain(base, kObs, dof_parts(), rc, r1);  // the same base and draws, no goal parts
  rc.goal_parts = PartMask::of(BodyPart::LeftLeg);
  adapt::ResidualPolicy<float> pol(base, kObs, dof_parts(), rc, r2);
  pol.residual().mean_net.params().setRandom();
  plain.residual().mean_net.params() = pol.residual().mean_net.params();
  pol.gain().params().setConstant(1.7f);
  plain.gain().params().setConstant(1.7f);
  const PartElements pe(obs_parts());
  const MatrixXf obs = MatrixXf::Random(kObs, 2);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm)};
  adapt::ResidualWorkspace<float> ws, ws2;
  MatrixXf x, x_plain, mu, mu_plain;
  pol.build_input(pe, obs, masks, MatrixXf(), x, ws);
  plain.build_input(pe, obs, masks, MatrixXf(), x_plain, ws2);
  EXPECT_TRUE((x.array() == x_plain.array()).all());  // the base's input and the mask bits are the mask's alone
  pol.mean(x, masks, mu, ws);
  plain.mean(x_plain, masks, mu_plain, ws2);
  const MatrixXf base_mu = x.middleRows(kObs, kAct);
  for (Index i = 0; i < kAct; ++i) {
    const bool leg = i >= 6, arm = i >= 3 && i < 6;
    // null mask: only the legs move; left arm masked: arms and legs
    EXPECT_EQ(mu(i, 0) != base_mu(i, 0), leg) << i;
    EXPECT_EQ(mu(i, 1) != base_mu(i, 1), leg || arm) << i;
    // where both policies move a DoF they agree (same residual, same input)
    if (arm) {
      EXPECT_EQ(mu(i, 1), mu_plain(i, 1)) << i;
    }
  }
}

namespace {
/// The gradient tests' setup: a smooth (tanh) policy with small random residual weights, and a
/// batch of four random observations under four different masks (left arm, all, none, left leg)
/// with random actions.
struct MixedMaskBatch {
  adapt::ResidualPolicy<float> pol;
  std::vector<PartMask> masks = {PartMask::of(BodyPart::LeftArm), PartMask::all(), PartMask::none(),
                                 PartMask::of(BodyPart::LeftLeg)};
  MatrixXf x, actions;
  explicit MixedMaskBatch(adapt::GainMode mode) : pol(make_policy(mode, 0, nn::Activation::Tanh)) {
    pol.residual().mean_net.params().setRandom();
    pol.residual().mean_net.params() *= 0.3f;
    const PartElements pe(obs_parts());
    const MatrixXf obs = MatrixXf::Random(kObs, 4);
    adapt::ResidualWorkspace<float> ws;
    pol.build_input(pe, obs, masks, MatrixXf(), x, ws);
    actions = MatrixXf::Random(kAct, 4);
  }
};
}  // namespace

TEST(ResidualPolicy, GradientsMatchFiniteDifferences) {
  for (auto mode : {adapt::GainMode::Scalar, adapt::GainMode::PerDof}) {
    MixedMaskBatch batch(mode);  // smooth, so central differences apply
    auto& pol = batch.pol;
    const auto& masks = batch.masks;
    const MatrixXf& x = batch.x;
    const MatrixXf& actions = batch.actions;
    const RowVectorXf dlogp = RowVectorXf::Random(4);
    auto loss = [&](adapt::ResidualPolicy<float>& p) {
      adapt::ResidualTrainCache<float> c;
      p.forward_train(x, masks, c);
      RowVectorXf lp;
      p.log_prob(c, actions, lp);
      return static_cast<double>(lp.dot(dlogp));
    };
    adapt::ResidualTrainCache<float> c;
    pol.zero_grad();
    pol.forward_train(x, masks, c);
    MatrixXf dmu;
    adapt::ResidualPolicy<float>::log_prob_mean_grad(c, actions, dlogp, dmu);
    pol.backward(c, dmu);
    const float h = 2e-3f;
    for (Index i = 0; i < pol.gain().params().size(); ++i) {
      const float w0 = pol.gain().params()[i];
      pol.gain().params()[i] = w0 + h;
      const double lp = loss(pol);
      pol.gain().params()[i] = w0 - h;
      const double lm = loss(pol);
      pol.gain().params()[i] = w0;
      EXPECT_NEAR(pol.gain().grads()[i], (lp - lm) / (2 * h), 2e-2 * (1 + std::abs((lp - lm) / (2 * h)))) << i;
    }
    auto p = pol.residual().mean_net.params();
    for (Index i = 0; i < p.size(); i += 7) {
      const float w0 = p[i];
      p[i] = w0 + h;
      const double lp = loss(pol);
      p[i] = w0 - h;
      const double lm = loss(pol);
      p[i] = w0;
      EXPECT_NEAR(pol.residual().mean_net.grads()[i], (lp - lm) / (2 * h), 2e-2 * (1 + std::abs((lp - lm) / (2 * h)))) << i;
    }
  }
}

// Per-DoF log-probabilities (per-part credit): summed over the rows of a column they are that
// column's log_prob bit for bit, rows the residual does not move are 0; the per-row gradient with
// every row's weight equal to its column's is log_prob_mean_grad's, and against central
// differences of Σ_ij dlogp_ij · log_prob_rows_ij it is the derivative with respect to μ̂.
TEST(ResidualPolicy, PerRowLogProbsSumToTheLogProbAndTheirGradientIsExact) {
  MixedMaskBatch batch(adapt::GainMode::PerDof);
  const auto& pol = batch.pol;
  const MatrixXf& actions = batch.actions;
  adapt::ResidualTrainCache<float> c;
  pol.forward_train(batch.x, batch.masks, c);
  RowVectorXf lp;
  pol.log_prob(c, actions, lp);
  MatrixXf rows;
  pol.log_prob_rows(c, actions, rows);
  ASSERT_EQ(rows.rows(), kAct);
  ASSERT_EQ(rows.cols(), 4);
  for (Index j = 0; j < 4; ++j) {
    float sum = 0;
    for (Index i = 0; i < kAct; ++i) {
      sum += rows(i, j);
      if (c.sel(i, j) == 0.0f) {
        EXPECT_EQ(rows(i, j), 0.0f) << i << "," << j;
      }
    }
    EXPECT_EQ(sum, lp[j]) << "column " << j;
  }
  const RowVectorXf dlogp = RowVectorXf::Random(4);
  MatrixXf dmu_cols, dmu_rows;
  adapt::ResidualPolicy<float>::log_prob_mean_grad(c, actions, dlogp, dmu_cols);
  adapt::ResidualPolicy<float>::log_prob_rows_mean_grad(c, actions, dlogp.replicate(kAct, 1), dmu_rows);
  EXPECT_TRUE(dmu_rows == dmu_cols);
  // against central differences in μ̂ (double precision of the same formula)
  const MatrixXf w = MatrixXf::Random(kAct, 4);
  adapt::ResidualPolicy<float>::log_prob_rows_mean_grad(c, actions, w, dmu_rows);
  for (Index j = 0; j < 4; ++j)
    for (Index i = 0; i < kAct; ++i) {
      if (c.sel(i, j) == 0.0f) {
        EXPECT_EQ(dmu_rows(i, j), 0.0f);
        continue;
      }
      const double a = actions(i, j), s = std::exp(static_cast<double>(c.log_std(i, j))), h = 1e-4;
      auto term = [&](double mu) { const double z = (a - mu) / s; return w(i, j) * (-0.5 * z * z); };
      const double mu = c.mu(i, j);
      EXPECT_NEAR(dmu_rows(i, j), (term(mu + h) - term(mu - h)) / (2 * h), 1e-3 * (1 + std::abs(dmu_rows(i, j))));
    }
}

TEST(ResidualPolicy, RejectsWrongShapes) {
  const auto pol = make_policy(adapt::GainMode::Scalar, 4);
  const PartElements pe(obs_parts());
  adapt::ResidualWorkspace<float> ws;
  MatrixXf x;
  const std::vector<PartMask> masks(2);
  EXPECT_THROW(pol.build_input(pe, MatrixXf::Zero(kObs + 1, 2), masks, MatrixXf::Zero(4, 2), x, ws), Error);
  EXPECT_THROW(pol.build_input(pe, MatrixXf::Zero(kObs, 2), masks, MatrixXf::Zero(3, 2), x, ws), Error);
  EXPECT_NO_THROW(pol.build_input(pe, MatrixXf::Zero(kObs, 2), masks, MatrixXf::Zero(4, 2), x, ws));
  EXPECT_EQ(x.rows(), kObs + kAct + kNumParts + 4);
  Rng rng(1);
  EXPECT_THROW(adapt::ResidualPolicy<float>(make_base(rng), kObs + 1, dof_parts(), {}, rng), Error);
}

TEST(ResidualPolicy, CheckpointRoundTrip) {
  auto a = make_policy();
  a.residual().mean_net.params().setRandom();
  a.gain().params().setRandom();
  Checkpoint ck;
  a.save(ck);
  auto b = make_policy();
  b.load(ck);
  EXPECT_EQ(a.residual().mean_net.params(), b.residual().mean_net.params());
  EXPECT_EQ(a.gain().params(), b.gain().params());
}

TEST(ResidualPolicy, WiderResidualSigmaKeepsTheBaseMeanAndScalesOnlyTheMaskedNoise) {
  Rng rng(3);
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.init_std = 0.3;
  const adapt::ResidualPolicy<float> pol(make_base(rng), kObs, dof_parts(), rc, rng);
  const MatrixXf obs = MatrixXf::Random(kObs, 4);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm), PartMask::parse("left_leg,trunk"),
                                       PartMask::all()};
  const auto [x, mu, act, base_mu, base_act, lp] = sample_beside_the_base(pol, obs, masks);
  MatrixXf ls;
  EXPECT_TRUE((mu.array() == base_mu.array()).all());  // the mean is still the base's, bit for bit
  pol.log_std(masks, ls);
  const float sigma_base = std::exp(-1.3f), sigma_res = 0.3f;
  const float half_log_2pi = 0.5f * std::log(2.0f * std::numbers::pi_v<float>);
  for (Index j = 0; j < 4; ++j) {
    const VectorXf sel = adapt::dof_selector<float>(dof_parts(), masks[static_cast<std::size_t>(j)]);
    float expected_lp = 0;
    for (Index i = 0; i < kAct; ++i) {
      const float sigma = sel[i] != 0 ? sigma_res : sigma_base;
      EXPECT_NEAR(std::exp(ls(i, j)), sigma, 1e-6f) << i << "," << j;
      // same normal draw, scaled by the row's σ: masked rows wider, unmasked rows the base's sample
      EXPECT_NEAR(act(i, j) - mu(i, j), (base_act(i, j) - base_mu(i, j)) * sigma / sigma_base, 1e-5f) << i << "," << j;
      if (sel[i] != 0) {
        const float z = (act(i, j) - mu(i, j)) / sigma_res;
        expected_lp += -0.5f * z * z - std::log(sigma_res) - half_log_2pi;
      }
    }
    EXPECT_NEAR(lp[j], expected_lp, 1e-4f) << j;  // log-prob over the masked rows only, at σ_ψ
  }
  EXPECT_EQ(lp[0], 0.0f);
  // σ_ψ travels in the checkpoint: a default-σ policy loaded from it samples with 0.3
  Checkpoint ck;
  pol.save(ck);
  auto back = make_policy(adapt::GainMode::Scalar);
  back.load(ck);
  EXPECT_EQ(back.residual().log_std.params(), pol.residual().log_std.params());
  // bad values name the field
  for (const double bad : {-0.1, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    rc.init_std = bad;
    Rng r(1);
    try {
      adapt::ResidualPolicy<float>(make_base(r), kObs, dof_parts(), rc, r);
      ADD_FAILURE() << "init_std " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("residual.init_std"), std::string::npos) << e.what();
    }
  }
}

TEST(ResidualPolicy, PerPartSigmaOverridesInitStdOnThatPartsDofsOnly) {
  Rng rng(5);
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.init_std = 0.2;                                              // every adapted DoF …
  rc.part_std[static_cast<std::size_t>(BodyPart::LeftArm)] = 0.4;  // … but the left arm's
  rc.part_std[static_cast<std::size_t>(BodyPart::RightLeg)] = 0.05;
  const adapt::ResidualPolicy<float> pol(make_base(rng), kObs, dof_parts(), rc, rng);
  const std::vector<PartMask> masks = {PartMask::all(), PartMask::of(BodyPart::Trunk)};
  MatrixXf ls;
  pol.log_std(masks, ls);
  const float sigma_base = std::exp(-1.3f);
  for (Index i = 0; i < kAct; ++i) {
    const BodyPart p = dof_parts()[static_cast<std::size_t>(i)];
    const float want = p == BodyPart::LeftArm ? 0.4f : p == BodyPart::RightLeg ? 0.05f : 0.2f;
    EXPECT_NEAR(std::exp(ls(i, 0)), want, 1e-6f) << i;                                  // every part adapted
    EXPECT_NEAR(std::exp(ls(i, 1)), p == BodyPart::Trunk ? 0.2f : sigma_base, 1e-6f) << i;  // the trunk only
  }
  // bad values name the part's field
  for (const double bad : {-0.1, std::numeric_limits<double>::quiet_NaN()}) {
    adapt::ResidualConfig b = rc;
    b.part_std[static_cast<std::size_t>(BodyPart::RightArm)] = bad;
    Rng r(1);
    try {
      adapt::ResidualPolicy<float>(make_base(r), kObs, dof_parts(), b, r);
      ADD_FAILURE() << "part_std " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("residual.part_std.right_arm"), std::string::npos) << e.what();
    }
  }
}

// ---- composition data ----------------------------------------------------------------------

TEST(Composition, BlendedRealSamplesTakeBOnMaskedPartsAndAElsewhere) {
  const Skeleton& skel = humanoid_skeleton();
  MotionLibrary a(skel), b(skel);
  a.add(synthetic_walk());
  b.add(synthetic_kick());
  const PartMask lower = PartMask::parse("lower_body");
  const tasks::BlendedMotionSet set(a, b, {lower, PartMask::parse("arms")});
  const MotionClip& bl = set.library(0).clip(0);
  ASSERT_EQ(bl.num_frames(), a.clip(0).num_frames());
  const int T = std::min(bl.num_frames(), b.clip(0).num_frames());
  for (int t = 0; t < T; ++t)
    for (int body = 1; body < skel.num_bodies(); ++body) {
      const int k = humanoid_skeleton().dof_offset(body);
      const Vec3 want = lower.has(skel.parts[static_cast<std::size_t>(body)]) ? Vec3(b.clip(0).q.col(t).segment<3>(k))
                                                                               : Vec3(a.clip(0).q.col(t).segment<3>(k));
      EXPECT_EQ(Vec3(bl.q.col(t).segment<3>(k)), want) << "frame " << t << " body " << body;
    }
  EXPECT_EQ(bl.root_pos, a.clip(0).root_pos);
  // real samples carry their mask's bits; negatives never do
  Rng rng(4);
  MatrixXf w, c;
  std::vector<PartMask> ms;
  set.sample_real(rng, 16, w, c, &ms);
  ASSERT_EQ(w.rows(), set.window_dim());
  for (Index j = 0; j < 16; ++j) EXPECT_EQ(c.col(j), tasks::mask_bits({ms[static_cast<std::size_t>(j)]}).col(0));
  const tasks::BlendedMotionSet one(a, b, {lower});
  one.sample_negative(rng, 32, w, c);
  const VectorXf lower_bits = tasks::mask_bits({lower}).col(0);
  for (Index j = 0; j < 32; ++j) EXPECT_NE(c.col(j), lower_bits);
}

// The windows computed on a pool are the serial ones, bit for bit, and the draws leave the RNG
// in the same state (so a run's samples do not depend on its thread count).
TEST(Composition, BlendedSamplesOnAPoolAreTheSerialOnes) {
  const Skeleton& skel = humanoid_skeleton();
  MotionLibrary a(skel), b(skel);
  a.add(synthetic_walk());
  b.add(synthetic_kick());
  const tasks::BlendedMotionSet set(a, b, {PartMask::parse("lower_body"), PartMask::parse("arms")});
  ThreadPool pool(3);
  Rng serial(9), pooled(9);
  MatrixXf w1, c1, w2, c2;
  set.sample_real(serial, 37, w1, c1);
  set.sample_real(pooled, 37, w2, c2, nullptr, &pool);
  EXPECT_TRUE(w1 == w2);
  EXPECT_TRUE(c1 == c2);
  set.sample_negative(serial, 21, w1, c1);
  set.sample_negative(pooled, 21, w2, c2, &pool);
  EXPECT_TRUE(w1 == w2);
  EXPECT_TRUE(c1 == c2);
  EXPECT_EQ(serial.uniform_int(1u << 30), pooled.uniform_int(1u << 30));
  EXPECT_GT(w1.cwiseAbs().sum(), 0.0f);  // (not a pair of empty batches)
}

TEST(Composition, WindowRowsSelectExactlyThePartsElements) {
  const auto parts = obs_parts();
  const auto rows = tasks::window_rows(parts, PartMask::of(BodyPart::LeftArm), 2);
  EXPECT_EQ(rows, (std::vector<Index>{4, 5, 6, 7, 16, 17, 18, 19}));
  MatrixXf x = MatrixXf::Random(2 * kObs, 3), out;
  tasks::select_rows(x, rows, out);
  EXPECT_EQ(out.row(5), x.row(17));
}

TEST(Composition, EpisodeMasksDrawFromTheSetAndSwitch) {
  const std::vector<PartMask> set = {PartMask::parse("lower_body"), PartMask::parse("arms")};
  tasks::EpisodeMasks fixed(set, 8, 0.0, 1.0 / 30, 1);
  for (int s = 0; s < 100; ++s)
    for (Index e = 0; e < 8; ++e) {
      const PartMask before = fixed.masks()[static_cast<std::size_t>(e)];
      fixed.maybe_switch(e);
      EXPECT_EQ(fixed.masks()[static_cast<std::size_t>(e)], before);
    }
  tasks::EpisodeMasks sw(set, 8, 3.0, 1.0 / 30, 1);  // ~ every 10 steps
  int switches = 0;
  for (int s = 0; s < 300; ++s)
    for (Index e = 0; e < 8; ++e) {
      const PartMask before = sw.masks()[static_cast<std::size_t>(e)];
      sw.maybe_switch(e);
      const PartMask after = sw.masks()[static_cast<std::size_t>(e)];
      EXPECT_TRUE(after == set[0] || after == set[1]);
      switches += after != before;
    }
  EXPECT_GT(switches, 150);  // expectation 240
  EXPECT_LT(switches, 330);
  EXPECT_THROW(tasks::parse_mask_set({"none"}), Error);
}

TEST(Composition, ConditioningChangesTheDiscriminatorOutput) {
  Rng rng(9);
  rl::DiscriminatorConfig dc;
  dc.feature_dim = 10;
  dc.cond_dim = kNumParts;
  dc.hidden = {16, 16};
  rl::Discriminator<float> d(dc, rng);
  const MatrixXf x = MatrixXf::Random(10, 1).replicate(1, 3);
  const MatrixXf c = tasks::mask_bits({PartMask::parse("lower_body"), PartMask::parse("arms"), PartMask::parse("lower_body")});
  const RowVectorXf l = d.logits(x, c);
  EXPECT_NE(l[0], l[1]);
  EXPECT_EQ(l[0], l[2]);
  // after training on blends vs the same windows with a mismatched mask, D prefers the true mask
  dc.lr = 3e-3;
  rl::Discriminator<float> t(dc, rng);
  const MatrixXf feats = MatrixXf::Random(10, 64);
  const MatrixXf real_c = tasks::mask_bits(std::vector<PartMask>(64, PartMask::parse("lower_body")));
  const MatrixXf fake_c = tasks::mask_bits(std::vector<PartMask>(64, PartMask::parse("arms")));
  for (int i = 0; i < 200; ++i) t.update(feats, real_c, feats, fake_c);
  EXPECT_GT(t.logits(feats, real_c).mean(), t.logits(feats, fake_c).mean() + 1.0f);
}

// CML-style baseline: with masked_base_input = false the base runs on the full observation with
// the null mask, so its action does not depend on the adapted mask (ours: it does, via s̄ and m);
// the residual input still carries the mask bits.
TEST(ResidualPolicy, UnmaskedBaseInputIgnoresTheMask) {
  Rng rng(3);
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.masked_base_input = false;
  const adapt::ResidualPolicy<float> cml(make_base(rng), kObs, dof_parts(), rc, rng);
  const auto ours = make_policy();
  const PartElements pe(obs_parts());
  MatrixXf obs = MatrixXf::Random(kObs, 1);
  obs = obs.replicate(1, 2).eval();
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm)};
  adapt::ResidualWorkspace<float> ws;
  MatrixXf x_cml, x_ours;
  cml.build_input(pe, obs, masks, MatrixXf(), x_cml, ws);
  ours.build_input(pe, obs, masks, MatrixXf(), x_ours, ws);
  // cml: identical base actions for both masks, equal to the base on [s ; 0]
  EXPECT_TRUE((x_cml.middleRows(kObs, kAct).col(0).array() == x_cml.middleRows(kObs, kAct).col(1).array()).all());
  const std::vector<PartMask> null_masks(2, PartMask::none());
  const MatrixXf full_in = policy_input<float>(pe, obs, null_masks);
  MatrixXf base_mu(kAct, 2), scratch;
  nn::InferenceWorkspace<float> bws;
  cml.base().mean(full_in, base_mu, bws, scratch);
  EXPECT_TRUE((x_cml.middleRows(kObs, kAct).array() == base_mu.array()).all());
  // ours: masking the left arm changes the base action
  EXPECT_FALSE((x_ours.middleRows(kObs, kAct).col(0).array() == x_ours.middleRows(kObs, kAct).col(1).array()).all());
  // both carry the mask bits
  EXPECT_EQ(x_cml(kObs + kAct + 1, 1), 1.0f);
  EXPECT_EQ(x_cml(kObs + kAct + 1, 0), 0.0f);
}

// ---- the base's action space (normalised actions) ------------------------------------------
// (a suite of its own, defined last: its Eigen Random draws come after every other test's, so
// running the whole binary feeds the older tests the same std::rand sequence as before)

namespace {

// A normalised action space for the 9 test DoFs: offset ≠ 0, scale ≠ 1 on every DoF.
tasks::ActionSpace normalised_space() {
  tasks::ActionSpace s;
  s.offset.resize(kAct);
  s.scale.resize(kAct);
  for (Index i = 0; i < kAct; ++i) {
    s.offset[i] = 0.1f * static_cast<float>(i) - 0.35f;
    s.scale[i] = 0.4f + 0.15f * static_cast<float>(i);
  }
  return s;
}

adapt::ResidualPolicy<float> make_normalised_policy() {
  Rng rng(3);
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.gain = adapt::GainMode::PerDof;
  return adapt::ResidualPolicy<float>(make_base(rng), kObs, dof_parts(), rc, rng, normalised_space());
}

}  // namespace

// A base with normalised actions: the PD targets are offset + scale ⊙ â with â = w ⊙ a_base + Δa
// on masked DoFs (all in normalised units) and exactly the base's own targets offset + scale ⊙
// a_base elsewhere; Δa = 0 and w = 1 reproduce the base's targets bit for bit.
TEST(ResidualPolicyActions, NormalisedBaseTargetsAreOffsetPlusScaleOfTheComposite) {
  const tasks::ActionSpace space = normalised_space();
  auto pol = make_normalised_policy();
  ASSERT_FALSE(pol.actions().identity());
  const PartElements pe(obs_parts());
  const MatrixXf obs = MatrixXf::Random(kObs, 3);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm), PartMask::parse("trunk,left_leg")};
  adapt::ResidualWorkspace<float> ws;
  MatrixXf x, mu, targets;
  pol.build_input(pe, obs, masks, MatrixXf(), x, ws);
  const MatrixXf base_mu = x.middleRows(kObs, kAct);
  // zero-initialised residual, w = 1: the base's own PD targets
  pol.mean(x, masks, mu, ws);
  pol.to_targets(mu, targets);
  for (Index j = 0; j < 3; ++j)
    for (Index i = 0; i < kAct; ++i) EXPECT_EQ(targets(i, j), space.offset[i] + space.scale[i] * base_mu(i, j)) << i << "," << j;
  // a trained residual and per-DoF gains
  pol.residual().mean_net.params().setRandom();
  for (Index i = 0; i < kAct; ++i) pol.gain().params()[i] = 0.6f + 0.1f * static_cast<float>(i);
  pol.mean(x, masks, mu, ws);
  pol.to_targets(mu, targets);
  MatrixXf delta(kAct, 3), scratch;
  nn::InferenceWorkspace<float> rws;
  pol.residual().mean(x, delta, rws, scratch);  // Δa on every row (applied on masked rows only)
  for (Index j = 0; j < 3; ++j)
    for (Index i = 0; i < kAct; ++i) {
      const bool masked = masks[static_cast<std::size_t>(j)].has(dof_parts()[static_cast<std::size_t>(i)]);
      const float a_hat = masked ? pol.gain().params()[i] * base_mu(i, j) + delta(i, j) : base_mu(i, j);
      EXPECT_EQ(targets(i, j), space.offset[i] + space.scale[i] * a_hat) << i << "," << j;
      if (!masked) EXPECT_EQ(targets(i, j), space.offset[i] + space.scale[i] * base_mu(i, j)) << "unmasked DoF moved";
      else EXPECT_NE(targets(i, j), space.offset[i] + space.scale[i] * base_mu(i, j)) << "masked DoF " << i << " unchanged";
    }
  // the identity action space: the targets are â itself
  const auto id = make_policy();
  EXPECT_TRUE(id.actions().identity());
  id.to_targets(mu, targets);
  EXPECT_TRUE((targets.array() == mu.array()).all());
  // a wrongly sized action space is rejected naming the field
  tasks::ActionSpace bad = space;
  bad.scale.conservativeResize(kAct - 1);
  Rng rng(3);
  try {
    const adapt::ResidualPolicy<float> p(make_base(rng), kObs, dof_parts(), {}, rng, bad);
    ADD_FAILURE() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "base.actions.scale");
  }
}

// The base's action space travels with the base sections; an identity base writes none (its
// checkpoint is what it was before action spaces), and a checkpoint without them loads the identity.
TEST(ResidualPolicyActions, CheckpointCarriesTheBaseActionSpace) {
  const auto a = make_normalised_policy();
  Checkpoint ck;
  a.save(ck);
  ASSERT_TRUE(ck.contains("base/actor/action_offset") && ck.contains("base/actor/action_scale"));
  auto b = make_policy();
  b.load(ck);
  EXPECT_TRUE(b.actions().offset == a.actions().offset);
  EXPECT_TRUE(b.actions().scale == a.actions().scale);
  Checkpoint plain;
  make_policy().save(plain);
  EXPECT_FALSE(plain.contains("base/actor/action_offset") || plain.contains("base/actor/action_scale"));
  b.load(plain);
  EXPECT_TRUE(b.actions().identity());
  auto c = make_normalised_policy();
  c.load(ck, false);  // residual sections only: the base (and its action space) stay
  EXPECT_TRUE(c.actions().scale == a.actions().scale);
}

// The action-bound penalty of a normalised space is on the PD targets: its gradient with respect
// to the (normalised) actions matches central differences of weight·Σ excess(offset + scale ⊙ a)².
TEST(ResidualPolicyActions, BoundPenaltyIsOnTheTargets) {
  tasks::ActionSpace space = normalised_space();
  space.offset.array() += 2.8f;  // some targets beyond +π, none beyond −π
  MatrixXf a(kAct, 4);
  for (Index j = 0; j < 4; ++j)
    for (Index i = 0; i < kAct; ++i) a(i, j) = 0.25f * static_cast<float>((i + 2 * j) % 7) - 0.5f;
  const float bound = static_cast<float>(M_PI), w = 0.3f;
  auto penalty = [&](const MatrixXf& x) {
    MatrixXf t(kAct, 4);
    space.to_targets(x, t);
    double p = 0;
    for (Index k = 0; k < t.size(); ++k) {
      const double e = std::max(0.0, t(k) - static_cast<double>(bound)) + std::min(0.0, t(k) + static_cast<double>(bound));
      p += w * e * e;
    }
    return p;
  };
  MatrixXf grad = MatrixXf::Zero(kAct, 4), work;
  space.add_bound_penalty_grad(a, bound, w, work, grad);
  int active = 0;
  for (Index k = 0; k < a.size(); ++k) {
    MatrixXf ap = a, am = a;
    const float h = 1e-3f;
    ap(k) += h;
    am(k) -= h;
    const double fd = (penalty(ap) - penalty(am)) / (2.0 * h);
    EXPECT_NEAR(grad(k), fd, 1e-2 * (1 + std::abs(fd))) << k;
    active += grad(k) != 0.0f;
  }
  EXPECT_GT(active, 0);
  EXPECT_LT(active, a.size());
  // the identity: the targets are a itself (the old penalty on μ)
  const tasks::ActionSpace id;
  MatrixXf g_id = MatrixXf::Zero(kAct, 4);
  const MatrixXf big = a * 5.0f;
  id.add_bound_penalty_grad(big, bound, w, work, g_id);
  const MatrixXf old = w * ((big.array() - bound).max(0.0f) + (big.array() + bound).min(0.0f)) * 2.0f;
  EXPECT_TRUE((g_id.array() == old.array()).all());
}
