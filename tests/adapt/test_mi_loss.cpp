#include <maskadapt/rl/mi_loss.hpp>
#include <maskadapt/nn/adam.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

using namespace maskadapt;

namespace {

// A small observation with elements assigned to parts, and random masks.
struct MiProblem {
  Index obs_dim = 10, action_dim = 3, batch = 16;
  std::vector<BodyPart> parts;
  MatrixXd obs;
  std::vector<PartMask> masks;
  MatrixXd full, masked;

  explicit MiProblem(Rng& rng) {
    for (Index i = 0; i < obs_dim; ++i) parts.push_back(static_cast<BodyPart>(i % kNumParts));
    obs = MatrixXd::NullaryExpr(obs_dim, batch, [&] { return rng.normal(); });
    for (Index j = 0; j < batch; ++j) masks.push_back(PartMask{static_cast<std::uint8_t>(rng.uniform_int(32))});
    masks[0] = PartMask::none();
    rl::unmasked_policy_input<double>(obs, obs_dim + kNumParts, full);
    rl::masked_policy_input<double>(obs, parts, masks, masked);
  }
  rl::ActorCriticConfig config(bool learn_log_std) const {
    rl::ActorCriticConfig c;
    c.policy_input_dim = obs_dim + kNumParts;
    c.critic_input_dim = obs_dim;
    c.action_dim = action_dim;
    c.actor_hidden = {8, 7};
    c.critic_hidden = {4};
    c.activation = nn::Activation::Tanh;
    c.init_log_std = -0.5;
    c.learn_log_std = learn_log_std;
    return c;
  }
};

}  // namespace

TEST(MiLoss, InputLayout) {
  Rng rng(1);
  MiProblem p(rng);
  for (Index j = 0; j < p.batch; ++j) {
    for (Index i = 0; i < p.obs_dim; ++i) {
      EXPECT_EQ(p.full(i, j), p.obs(i, j));
      EXPECT_EQ(p.masked(i, j), p.masks[j].has(p.parts[i]) ? 0.0 : p.obs(i, j));
    }
    for (int b = 0; b < kNumParts; ++b) {
      EXPECT_EQ(p.full(p.obs_dim + b, j), 0.0);
      EXPECT_EQ(p.masked(p.obs_dim + b, j), p.masks[j].has(static_cast<BodyPart>(b)) ? 1.0 : 0.0);
    }
  }
  EXPECT_EQ(p.full.col(0), p.masked.col(0));  // null mask: identical inputs
}

// The gradient the loss adds equals the central finite difference of the whole loss
// (λ·mean KL) w.r.t. every network parameter and the learned log-std — with the target held
// fixed, i.e. the finite difference only perturbs the masked branch's parameters.
TEST(MiLoss, GradientMatchesFiniteDifferences) {
  for (bool learn : {false, true}) {
    Rng rng(5);
    MiProblem p(rng);
    rl::GaussianActor<double> actor(p.config(learn), rng);
    actor.normalizer.update(p.masked);  // a non-trivial input normalisation
    const double lambda = 0.7;
    rl::MiWorkspace<double> w;
    actor.zero_grad();
    const auto r = rl::mi_loss(actor, p.full, p.masked, lambda, w, rl::MiGradient::TargetStopped);
    EXPECT_GT(r.kl, 0.0);
    EXPECT_DOUBLE_EQ(r.loss, lambda * r.kl);
    const VectorXd grad = actor.mean_net.grads();
    const VectorXd grad_ls = actor.log_std.grads();

    // Target means with the unperturbed parameters (stop-gradient).
    MatrixXd nf, mu_full(p.action_dim, p.batch);
    actor.normalize(p.full, nf);
    mu_full = actor.mean_net.forward(nf);
    const MatrixXd ls0 = actor.log_std_col();
    auto loss_at = [&](const rl::GaussianActor<double>& a) {
      MatrixXd nm;
      a.normalize(p.masked, nm);
      const MatrixXd mu_q = a.mean_net.forward(nm);
      return lambda * nn::kl_diag_gaussian<double>(mu_full, ls0, mu_q, a.log_std_col()).mean();
    };
    const double h = 1e-6;
    double max_err = 0;
    for (Index k = 0; k < actor.mean_net.num_params(); ++k) {
      auto a = actor;
      a.mean_net.params()[k] += h;
      const double lp = loss_at(a);
      a.mean_net.params()[k] -= 2 * h;
      const double lm = loss_at(a);
      const double fd = (lp - lm) / (2 * h);
      max_err = std::max(max_err, std::abs(fd - grad[k]) / std::max(1.0, std::abs(fd)));
    }
    EXPECT_LT(max_err, 1e-7) << "learn_log_std " << learn;
    for (Index k = 0; k < p.action_dim; ++k) {
      auto a = actor;
      a.log_std.params()[k] += h;
      const double lp = loss_at(a);
      a.log_std.params()[k] -= 2 * h;
      const double fd = (lp - loss_at(a)) / (2 * h);
      if (learn) EXPECT_NEAR(grad_ls[k], fd, 1e-7);
      else EXPECT_EQ(grad_ls[k], 0.0);  // fixed log-std gets no gradient
    }
  }
}

// The trainers' form: the MI gradient joins the caller's own ∂/∂μ on the masked pass it already
// ran, and one backward carries both. The result equals the surrogate-like term's backward plus
// mi_loss's gradient (two separate passes), in both gradient modes; the KL is the same, and the
// null-mask column (column 0) is not run through the full pass at all.
TEST(MiLoss, SharingTheMaskedPassGivesTheSameGradientAsSeparatePasses) {
  for (const auto mode : {rl::MiGradient::Both, rl::MiGradient::TargetStopped}) {
    for (bool learn : {false, true}) {
      Rng rng(21);
      MiProblem p(rng);
      rl::GaussianActor<double> actor(p.config(learn), rng);
      actor.normalizer.update(p.masked);
      const MatrixXd g_other = MatrixXd::NullaryExpr(p.action_dim, p.batch, [&] { return rng.normal(); });
      const double lambda = 0.9;
      // separate: backward of the other term, then the whole mi_loss
      rl::MiWorkspace<double> w1;
      nn::TrainCache<double> c1;
      MatrixXd nm;
      actor.zero_grad();
      actor.normalize(p.masked, nm);
      actor.mean_net.forward_train(nm, c1);
      actor.mean_net.backward(c1, g_other, actor.mean_net.grads());
      const double kl1 = rl::mi_loss(actor, p.full, p.masked, lambda, w1, mode).kl;
      const VectorXd g1 = actor.mean_net.grads(), ls1 = actor.log_std.grads();
      // shared: one masked pass, MI's ∂/∂μ added to the other term's, one backward
      rl::MiWorkspace<double> w2;
      nn::TrainCache<double> c2;
      actor.zero_grad();
      const MatrixXd& mu = actor.mean_net.forward_train(nm, c2);
      MatrixXd dmu = g_other;
      const double kl2 = rl::mi_loss_on_masked_pass<double>(actor, p.full, p.masked, mu, lambda, w2, mode, dmu).kl;
      actor.mean_net.backward(c2, dmu, actor.mean_net.grads());
      EXPECT_NEAR(kl1, kl2, 1e-12);
      EXPECT_LT((actor.mean_net.grads() - g1).cwiseAbs().maxCoeff(), 1e-12) << rl::to_string(mode) << " " << learn;
      EXPECT_LT((actor.log_std.grads() - ls1).cwiseAbs().maxCoeff(), 1e-12);
      std::vector<Index> masked_columns;  // column 0 (and any other drawn as 0) has the null mask
      for (Index j = 0; j < p.batch; ++j)
        if (!p.masks[static_cast<std::size_t>(j)].empty()) masked_columns.push_back(j);
      EXPECT_EQ(w2.cols, masked_columns);
      EXPECT_LT(masked_columns.size(), static_cast<std::size_t>(p.batch));
    }
  }
}

TEST(MiLoss, LambdaZeroAddsNothingButReportsKl) {
  Rng rng(2);
  MiProblem p(rng);
  rl::GaussianActor<double> actor(p.config(true), rng);
  rl::MiWorkspace<double> w;
  actor.zero_grad();
  const auto r = rl::mi_loss(actor, p.full, p.masked, 0.0, w);
  EXPECT_GT(r.kl, 0.0);
  EXPECT_EQ(r.loss, 0.0);
  EXPECT_EQ(actor.mean_net.grads().squaredNorm(), 0.0);
  EXPECT_EQ(actor.log_std.grads().squaredNorm(), 0.0);
  EXPECT_THROW(rl::mi_loss(actor, p.full, p.masked, -1.0, w), Error);
  EXPECT_THROW(rl::mi_loss<double>(actor, p.full, p.masked.topRows(3), 1.0, w), Error);
}

// The MI term makes the masked policy agree with the unmasked one *during training*. The full
// policy is anchored by a task loss (here: regression of μ(s, m⁰) to a fixed function of s,
// standing in for PPO), as in the method. Phase 1 trains the anchor alone (λ = 0): the masked
// and unmasked policies drift apart. Phase 2 continues with λ = 1: the KL on the fixed batch
// falls well below its phase-1 value, while continuing with λ = 0 keeps it high.
TEST(MiLoss, KlFallsDuringTrainingWithLambda) {
  Rng rng(3);
  MiProblem p(rng);
  const Index B = 64;
  const MatrixXd obs = MatrixXd::NullaryExpr(p.obs_dim, B, [&] { return rng.normal(); });
  std::vector<PartMask> masks;
  for (Index j = 0; j < B; ++j) masks.push_back(PartMask{static_cast<std::uint8_t>(rng.uniform_int(32))});
  MatrixXd full, masked;
  rl::unmasked_policy_input<double>(obs, p.obs_dim + kNumParts, full);
  rl::masked_policy_input<double>(obs, p.parts, masks, masked);
  const MatrixXd A = MatrixXd::NullaryExpr(p.action_dim, p.obs_dim, [&] { return 0.3 * rng.normal(); });
  const MatrixXd target = (A * obs).array().tanh().matrix();
  auto cfg = p.config(false);
  cfg.actor_hidden = {32, 32};
  rl::GaussianActor<double> actor(cfg, rng);
  nn::Adam<double> opt({.lr = 1e-3});
  rl::MiWorkspace<double> w;
  nn::TrainCache<double> cache;
  auto train = [&](rl::GaussianActor<double>& a, nn::Adam<double>& o, double lambda, int iters) {
    double kl = 0;
    for (int it = 0; it < iters; ++it) {
      a.zero_grad();
      const MatrixXd& mu = a.mean_net.forward_train(full, cache);  // no input normalisation (count 0)
      const MatrixXd dmu = (mu - target) * (2.0 / static_cast<double>(mu.size()));
      a.mean_net.backward(cache, dmu, a.mean_net.grads());
      kl = rl::mi_loss(a, full, masked, lambda, w).kl;
      EXPECT_TRUE(o.step(a.mean_net.block()).applied);
    }
    return kl;
  };
  const double kl_anchor = train(actor, opt, 0.0, 300);
  auto control = actor;
  auto control_opt = opt;
  const double kl_mi = train(actor, opt, 1.0, 600);
  const double kl_control = train(control, control_opt, 0.0, 600);
  EXPECT_GT(kl_anchor, 0.3);
  EXPECT_LT(kl_mi, 0.25 * kl_anchor) << "anchor " << kl_anchor << " with MI " << kl_mi;
  EXPECT_GT(kl_control, 0.5 * kl_anchor) << "without MI " << kl_control;
  std::printf("MI training: KL after anchor %.4f, +600 its with lambda 1: %.4f, with lambda 0: %.4f\n", kl_anchor,
              kl_mi, kl_control);
}

// MiGradient::Both (the default): the added gradient is the exact derivative of the whole loss,
// i.e. the finite difference perturbs the parameters of both the target and the masked branch.
TEST(MiLoss, ExactGradientThroughBothSidesMatchesFiniteDifferences) {
  for (bool learn : {false, true}) {
    Rng rng(6);
    MiProblem p(rng);
    rl::GaussianActor<double> actor(p.config(learn), rng);
    actor.normalizer.update(p.masked);
    const double lambda = 0.7;
    rl::MiWorkspace<double> w;
    actor.zero_grad();
    rl::mi_loss(actor, p.full, p.masked, lambda, w);  // default: MiGradient::Both
    const VectorXd grad = actor.mean_net.grads();
    const VectorXd grad_ls = actor.log_std.grads();
    auto loss_at = [&](const rl::GaussianActor<double>& a) {
      MatrixXd nf, nm;
      a.normalize(p.full, nf);
      a.normalize(p.masked, nm);
      return lambda * nn::kl_diag_gaussian<double>(a.mean_net.forward(nf), a.log_std_col(), a.mean_net.forward(nm),
                                                   a.log_std_col()).mean();
    };
    const double h = 1e-6;
    double max_err = 0;
    for (Index k = 0; k < actor.mean_net.num_params(); ++k) {
      auto a = actor;
      a.mean_net.params()[k] += h;
      const double lp = loss_at(a);
      a.mean_net.params()[k] -= 2 * h;
      const double fd = (lp - loss_at(a)) / (2 * h);
      max_err = std::max(max_err, std::abs(fd - grad[k]) / std::max(1.0, std::abs(fd)));
    }
    EXPECT_LT(max_err, 1e-7) << "learn_log_std " << learn;
    for (Index k = 0; k < p.action_dim; ++k) {
      auto a = actor;
      a.log_std.params()[k] += h;
      const double lp = loss_at(a);
      a.log_std.params()[k] -= 2 * h;
      const double fd = (lp - loss_at(a)) / (2 * h);
      // With one log-std shared by p and q, KL's dependence on it cancels exactly: fd = 0.
      if (learn) EXPECT_NEAR(grad_ls[k], fd, 1e-7);
      else EXPECT_EQ(grad_ls[k], 0.0);
    }
  }
}

TEST(MiLoss, GradientModeNames) {
  EXPECT_EQ(rl::mi_gradient_from_string("both"), rl::MiGradient::Both);
  EXPECT_EQ(rl::mi_gradient_from_string("target_stopped"), rl::MiGradient::TargetStopped);
  EXPECT_STREQ(rl::to_string(rl::MiGradient::TargetStopped), "target_stopped");
  EXPECT_EQ(rl::mi_gradient_from_string("target_ema"), rl::MiGradient::TargetEma);
  EXPECT_STREQ(rl::to_string(rl::MiGradient::TargetEma), "target_ema");
  EXPECT_TRUE(rl::has_fixed_target(rl::MiGradient::TargetEma));
  EXPECT_FALSE(rl::has_fixed_target(rl::MiGradient::Both));
  EXPECT_THROW(rl::mi_gradient_from_string("half"), Error);
}

// A target computed before the update (TargetFrozen: the pre-update policy; TargetEma: the
// moving average): the KL and its gradient are the closed forms ½ Σ_i (μq − μp)²/σ² and
// λ/B·(μq − μp)/σ² on the covered columns — MiColumns::Masked: those with a non-null mask, the
// null-mask ones getting exactly 0; MiColumns::All: every column, so a null-mask column (whose
// "masked" pass is the unmasked policy) is anchored to the target. Nothing flows into the network.
TEST(MiLoss, FixedTargetGivesTheClosedFormOnTheColumnsItCovers) {
  for (const auto columns : {rl::MiColumns::Masked, rl::MiColumns::All}) {
    const bool all = columns == rl::MiColumns::All;
    Rng rng(5);
    MiProblem p(rng);
    ASSERT_TRUE(p.masks[0].empty());
    rl::GaussianActor<double> actor(p.config(false), rng);
    const Index d = p.action_dim, B = p.batch;
    const MatrixXd target = MatrixXd::NullaryExpr(d, B, [&] { return rng.normal(); });
    const MatrixXd mu_masked = MatrixXd::NullaryExpr(d, B, [&] { return rng.normal(); });
    const double lambda = 0.7, inv_var = std::exp(-2 * actor.log_std.params()[0]);
    rl::MiWorkspace<double> w;
    MatrixXd dmu = MatrixXd::Zero(d, B);
    actor.zero_grad();
    const auto r = rl::mi_loss_on_fixed_target<double>(actor, target, p.masked, mu_masked, lambda, w, dmu, columns);
    double kl = 0;
    for (Index j = 0; j < B; ++j) {
      const VectorXd diff = mu_masked.col(j) - target.col(j);
      if (!all && p.masks[static_cast<std::size_t>(j)].empty()) {
        EXPECT_EQ(dmu.col(j).squaredNorm(), 0.0) << j;
        continue;
      }
      kl += 0.5 * diff.squaredNorm() * inv_var;
      EXPECT_LT((dmu.col(j) - lambda / static_cast<double>(B) * inv_var * diff).norm(), 1e-12) << j;
    }
    EXPECT_EQ(dmu.col(0).norm() > 0.0, all) << "the null-mask column is anchored only with MiColumns::All";
    EXPECT_NEAR(r.kl, kl / static_cast<double>(B), 1e-12);
    EXPECT_NEAR(r.loss, lambda * r.kl, 1e-12);
    EXPECT_EQ(actor.mean_net.grads().squaredNorm(), 0.0);
    EXPECT_THROW(rl::mi_loss_on_fixed_target<double>(actor, target.leftCols(3), p.masked, mu_masked, lambda, w, dmu, columns),
                 Error);
  }
}

TEST(MiLoss, EmaTargetStepIsTheConvexCombination) {
  Rng rng(2);
  nn::Mlp<double> policy(nn::MlpSpec{4, {5}, 3, nn::Activation::Tanh}, rng);
  nn::Mlp<double> target(nn::MlpSpec{4, {5}, 3, nn::Activation::Tanh}, rng);
  const VectorXd before = target.params();
  rl::update_ema_target(target, policy, 0.25);
  EXPECT_LT((target.params() - (0.75 * before + 0.25 * policy.params())).cwiseAbs().maxCoeff(), 1e-15);
  rl::update_ema_target(target, policy, 1.0);
  EXPECT_EQ(target.params(), policy.params());
  EXPECT_THROW(rl::update_ema_target(target, policy, 0.0), Error);
  EXPECT_THROW(rl::update_ema_target(target, policy, 1.5), Error);
  nn::Mlp<double> other(nn::MlpSpec{4, {6}, 3, nn::Activation::Tanh}, rng);
  EXPECT_THROW(rl::update_ema_target(other, policy, 0.5), Error);
}

// The three target modes on one fixed batch, minimising the MI loss alone (σ e^−2.9 as in the
// trainer, Adam 1e-4, 200 steps; random masks of up to all five parts, so no policy short of a
// constant one is invariant). Why `Both` is the default and why `target_ema` exists: The stopped target that moves with the policy diverges; the exact
// gradient through both sides reaches invariance (here, where every part can be hidden, by making
// the small random outputs constant); the EMA target (recomputed before every step, as the trainer
// does once per iteration; null-mask columns anchored) stays bounded. What none of the three
// can show without PPO beside it — whether the policy keeps its skill — is measured in
// docs/results.md.
TEST(MiLoss, OnAFixedBatchTheStoppedTargetDivergesTheExactGradientConvergesTheEmaTargetStaysBounded) {
  struct Outcome {
    double kl0, kl1, drift;  // masked/unmasked KL before and after; largest move of the unmasked mean
  };
  auto run = [](rl::MiGradient mode) {
    Rng rng(8);
    MiProblem p(rng);
    auto cfg = p.config(false);
    cfg.actor_hidden = {64, 64};
    cfg.activation = nn::Activation::ReLU;
    cfg.init_log_std = -2.9;  // the trainer's σ: a sharp KL
    rl::GaussianActor<double> actor(cfg, rng);
    actor.normalizer.update(p.masked);
    auto unmasked_mu = [&](const rl::GaussianActor<double>& a) {
      MatrixXd nf;
      a.normalize(p.full, nf);
      return MatrixXd(a.mean_net.forward(nf));
    };
    auto masked_unmasked_kl = [&](const rl::GaussianActor<double>& a) {
      MatrixXd nm;
      a.normalize(p.masked, nm);
      return nn::kl_diag_gaussian<double>(unmasked_mu(a), a.log_std_col(), a.mean_net.forward(nm), a.log_std_col()).mean();
    };
    const MatrixXd mu_start = unmasked_mu(actor);
    const double kl0 = masked_unmasked_kl(actor);
    nn::Adam<double> opt({.lr = 1e-4});
    rl::MiWorkspace<double> w;
    nn::TrainCache<double> cache;
    nn::Mlp<double> target = actor.mean_net;
    for (int step = 0; step < 200; ++step) {
      actor.zero_grad();
      if (mode == rl::MiGradient::TargetEma) {
        MatrixXd nf, nm;
        actor.normalize(p.full, nf);
        const MatrixXd mu_target = target.forward(nf);
        actor.normalize(p.masked, nm);
        const MatrixXd& mu = actor.mean_net.forward_train(nm, cache);
        MatrixXd dmu = MatrixXd::Zero(mu.rows(), mu.cols());
        rl::mi_loss_on_fixed_target<double>(actor, mu_target, p.masked, mu, 1.0, w, dmu, rl::MiColumns::All);
        actor.mean_net.backward(cache, dmu, actor.mean_net.grads());
      } else {
        rl::mi_loss(actor, p.full, p.masked, 1.0, w, mode);
      }
      opt.step(actor.mean_net.block());
      if (mode == rl::MiGradient::TargetEma) rl::update_ema_target(target, actor.mean_net, 0.05);
    }
    return Outcome{kl0, masked_unmasked_kl(actor), (unmasked_mu(actor) - mu_start).cwiseAbs().maxCoeff()};
  };
  const Outcome stopped = run(rl::MiGradient::TargetStopped), both = run(rl::MiGradient::Both),
                ema = run(rl::MiGradient::TargetEma);
  std::printf("MI alone, 200 Adam steps (KL before -> after, largest move of the unmasked mean):\n"
              "  target_stopped %.3f -> %.3f, %.3f\n  both           %.3f -> %.3f, %.3f\n"
              "  target_ema     %.3f -> %.3f, %.3f\n",
              stopped.kl0, stopped.kl1, stopped.drift, both.kl0, both.kl1, both.drift, ema.kl0, ema.kl1, ema.drift);
  EXPECT_GT(stopped.kl1, 10 * stopped.kl0);
  EXPECT_LT(both.kl1, 0.1 * both.kl0);
  EXPECT_LT(ema.kl1, 2 * ema.kl0);
  EXPECT_LT(ema.kl1, 0.1 * stopped.kl1);
  EXPECT_LT(ema.drift, 0.5 * stopped.drift);
}
