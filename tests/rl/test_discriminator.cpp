#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>

#include <gtest/gtest.h>

#include <cstdio>

using namespace maskadapt;
using namespace maskadapt::rl;

namespace {
template <class T>
MatrixX<T> gaussian(Index dim, Index n, double mean, Rng& rng) {
  return MatrixX<T>::NullaryExpr(dim, n, [&] { return static_cast<T>(mean + rng.normal()); });
}
DiscriminatorConfig small(Index feature_dim, Index cond_dim = 0) {
  DiscriminatorConfig c;
  c.feature_dim = feature_dim;
  c.cond_dim = cond_dim;
  c.hidden = {32, 32};  // test-sized
  c.lr = 1e-3;
  return c;
}
}  // namespace

// Two fixed Gaussian data sets (means ±0.75 in each of 10 dims; Bayes accuracy ≈ 0.99) are
// separated on held-out samples with accuracy > 0.95, with the full regularisation (GP 5, logit
// reg, weight decay) switched on — for both objectives.
TEST(Discriminator, SeparatesTwoGaussians) {
  for (auto kind : {DiscriminatorLoss::BCE, DiscriminatorLoss::LSGAN}) {
    Rng rng(4);
    auto cfg = small(10);
    cfg.loss = kind;
    Discriminator<float> d(cfg, rng);
    const MatrixXf real = gaussian<float>(10, 2048, 0.75, rng), fake = gaussian<float>(10, 2048, -0.75, rng);
    d.update_normalizer(real);
    d.update_normalizer(fake);
    MatrixXf r, f;
    DiscriminatorStats st;
    for (int it = 0; it < 300; ++it) {
      gather_columns(real, minibatch_indices(2048, 16, rng)[0], r);
      gather_columns(fake, minibatch_indices(2048, 16, rng)[0], f);
      st = d.update(r, MatrixXf(), f, MatrixXf());
      ASSERT_FALSE(st.skipped);
    }
    const RowVectorX<float> lr = d.logits(gaussian<float>(10, 1000, 0.75, rng));
    const RowVectorX<float> lf = d.logits(gaussian<float>(10, 1000, -0.75, rng));
    const double acc = ((lr.array() > 0).count() + (lf.array() <= 0).count()) / 2000.0;
    std::printf("%s: held-out accuracy %.3f, last loss %.3f (gp %.4f)\n", kind == DiscriminatorLoss::BCE ? "BCE" : "LSGAN",
                acc, st.loss, st.grad_penalty);
    EXPECT_GT(acc, 0.95);
    EXPECT_GT(st.grad_penalty, 0.0);
    // Rewards are higher for real-looking samples.
    EXPECT_GT(d.reward(gaussian<float>(10, 200, 0.75, rng)).mean(), d.reward(gaussian<float>(10, 200, -0.75, rng)).mean());
  }
}

// The mask-conditioned form: the same two data sets, but which one is "real" depends on the
// conditioning bit; fakes are the same features paired with the other bit (negative expert
// samples). Only a discriminator that uses the conditioning can exceed 0.5 accuracy.
TEST(Discriminator, ConditioningIsUsed) {
  Rng rng(8);
  Discriminator<float> d(small(6, 1), rng);
  const Index n = 64;
  const MatrixXf c1 = MatrixXf::Ones(1, n), c0 = MatrixXf::Zero(1, n);
  for (int it = 0; it < 400; ++it) {
    const MatrixXf a = gaussian<float>(6, n, 1.0, rng), b = gaussian<float>(6, n, -1.0, rng);
    MatrixXf real(6, 2 * n), rc(1, 2 * n), fake(6, 2 * n), fc(1, 2 * n);
    real << a, b;
    rc << c1, c0;  // A under bit 1, B under bit 0
    fake << a, b;
    fc << c0, c1;  // mismatched pairs
    ASSERT_FALSE(d.update(real, rc, fake, fc).skipped);
  }
  const MatrixXf a = gaussian<float>(6, 500, 1.0, rng);
  const RowVectorX<float> under1 = d.logits(a, MatrixXf::Ones(1, 500)), under0 = d.logits(a, MatrixXf::Zero(1, 500));
  const double acc = ((under1.array() > 0).count() + (under0.array() <= 0).count()) / 1000.0;
  std::printf("conditioned: accuracy %.3f\n", acc);
  EXPECT_GT(acc, 0.9);
  // Same features, different mask → different D (and on average "more real" under bit 1).
  EXPECT_TRUE((under1.array() != under0.array()).all());
  EXPECT_GT((under1 - under0).mean(), 1.0f);
  EXPECT_THROW(d.logits(a), Error);               // conditioning is required
}

// The parameter gradient the update uses equals the finite difference of the total loss
// L_obj + GP + logit reg + weight decay (double, no clipping). Real and fake samples run through
// the network as one batch; with ReLU the penalty skips its z̄ pass (f'' = 0).
TEST(Discriminator, UpdateGradientMatchesFiniteDifferences) {
  for (nn::Activation act : {nn::Activation::Tanh, nn::Activation::ReLU}) {
    SCOPED_TRACE(nn::to_string(act));
    Rng rng(12);
    DiscriminatorConfig cfg = small(5, 2);
    cfg.hidden = {6, 4};
    cfg.activation = act;
    cfg.max_grad_norm = 0;
    cfg.lr = 0;  // the step changes nothing, so update() just evaluates L and its gradient
    cfg.logit_reg = 0.3;
    cfg.weight_decay = 0.02;
    Discriminator<double> d(cfg, rng);
    const MatrixXd real = gaussian<double>(5, 7, 0.5, rng), fake = gaussian<double>(5, 6, -0.5, rng);
    const MatrixXd rc = MatrixXd::NullaryExpr(2, 7, [&] { return rng.uniform(); });
    const MatrixXd fc = MatrixXd::NullaryExpr(2, 6, [&] { return rng.uniform(); });
    d.update_normalizer(real);
    for (auto kind : {DiscriminatorLoss::BCE, DiscriminatorLoss::LSGAN}) {
      cfg.loss = kind;
      Rng r2(12);
      Discriminator<double> base(cfg, r2);
      base.normalizer() = d.normalizer();
      const auto st = base.update(real, rc, fake, fc);
      EXPECT_GT(st.grad_penalty, 0);
      EXPECT_GT(st.logit_reg, 0);
      EXPECT_GT(st.weight_decay, 0);
      const VectorXd grad = base.net().grads();
      double max_err = 0;
      for (Index k = 0; k < base.net().num_params(); ++k) {
        auto p = base;
        p.net().params()[k] += 1e-6;
        const double lp = p.update(real, rc, fake, fc).loss;
        p.net().params()[k] -= 2e-6;
        const double fd = (lp - p.update(real, rc, fake, fc).loss) / 2e-6;
        max_err = std::max(max_err, std::abs(fd - grad[k]) / std::max(1.0, std::abs(fd)));
      }
      EXPECT_LT(max_err, 1e-6);
    }
  }
}

TEST(Discriminator, NonFiniteUpdateIsSkipped) {
  Rng rng(2);
  Discriminator<float> d(small(4), rng);
  MatrixXf real = gaussian<float>(4, 8, 0.0, rng), fake = gaussian<float>(4, 8, 1.0, rng);
  real(2, 3) = std::nanf("");
  const VectorXf before = d.net().params();
  const auto st = d.update(real, MatrixXf(), fake, MatrixXf());
  EXPECT_TRUE(st.skipped);
  EXPECT_EQ(VectorXf(d.net().params()), before);
  EXPECT_EQ(d.optimizer().step_count(), 0);
  real(2, 3) = 0;
  EXPECT_FALSE(d.update(real, MatrixXf(), fake, MatrixXf()).skipped);
  EXPECT_NE(VectorXf(d.net().params()), before);
  EXPECT_THROW(d.update(real.topRows(3), MatrixXf(), fake, MatrixXf()), Error);
}

TEST(Discriminator, ReplayMixAndSet) {
  Rng rng(5);
  ReplayBuffer<float> replay(3, 100);
  MatrixXf out;
  const MatrixXf agent1 = MatrixXf::Constant(3, 4, 1.0f), agent2 = MatrixXf::Constant(3, 4, 2.0f);
  mix_with_replay<float>(agent1, replay, 4, rng, out);
  EXPECT_EQ(out, agent1);  // empty replay: agent samples only
  mix_with_replay<float>(agent2, replay, 4, rng, out);
  ASSERT_EQ(out.cols(), 8);
  EXPECT_EQ(out.leftCols(4), agent2);
  EXPECT_EQ(out.rightCols(4), agent1);  // only agent1 was stored before
  EXPECT_EQ(replay.size(), 8);

  DiscriminatorSet<float> set;
  set.add("legs", Discriminator<float>(small(3), rng), 0.7);
  set.add("arms", Discriminator<float>(small(2), rng), 0.3);
  const std::vector<MatrixXf> feats{MatrixXf::Random(3, 5), MatrixXf::Random(2, 5)};
  const MatrixXf r = set.rewards(feats);
  ASSERT_EQ(r.rows(), 2);
  EXPECT_EQ(r.row(0), set.members[0].reward(feats[0]));
  EXPECT_EQ(r.row(1), set.members[1].reward(feats[1]));
  EXPECT_TRUE(set.weighted_reward(r).isApprox(0.7f * r.row(0) + 0.3f * r.row(1)));
  EXPECT_THROW(set.add("bad", Discriminator<float>(small(2), rng), -1), Error);
}
