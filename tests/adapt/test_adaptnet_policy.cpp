// AdaptNet baseline (adapt/adaptnet_policy.hpp): zero-init equivalence with the frozen base
// (means and sampled actions bit for bit), exact gradients vs central differences in double
// precision for every trainable block, a frozen base under Adam, checkpoint round trip and
// wrong-size rejection, and the ResidualPolicy surface the stage-2 trainer uses.
#include <maskadapt/adapt/adaptnet_policy.hpp>
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/train/stage2_policy.hpp>

#include <gtest/gtest.h>

#include <concepts>

using namespace maskadapt;

namespace adaptnet_test {  // (named: the adapt tests build as one translation unit)

constexpr Index kAnObs = 12, kAnAct = 9, kAnGoal = 3;

std::vector<BodyPart> an_obs_parts(Index obs) {
  std::vector<BodyPart> p;
  for (Index i = 0; i < obs; ++i) p.push_back(static_cast<BodyPart>(i % kNumParts));
  return p;
}

template <class T>
rl::GaussianActor<T> an_make_base(Rng& rng, nn::Activation act = nn::Activation::ReLU, std::vector<Index> hidden = {16, 12, 8},
                               Index obs = kAnObs, Index A = kAnAct) {
  rl::ActorCriticConfig c;
  c.policy_input_dim = obs + kNumParts;
  c.critic_input_dim = obs;
  c.action_dim = A;
  c.actor_hidden = std::move(hidden);
  c.activation = act;
  c.init_log_std = -1.3;
  rl::GaussianActor<T> a(c, rng);
  MatrixX<T> warm = MatrixX<T>::Random(obs + kNumParts, 64) * T(2);
  warm.bottomRows(kNumParts).setZero();
  a.normalizer.update(warm);
  return a;
}

adapt::AdaptNetConfig config(Index rank = 0, Index goal = kAnGoal) {
  adapt::AdaptNetConfig c;
  c.goal_dim = goal;
  c.goal_hidden = goal > 0 ? std::vector<Index>{8} : std::vector<Index>{};
  c.embed_hidden = {16};
  c.ia_rank = rank;
  return c;
}

template <class T>
adapt::AdaptNetPolicy<T> an_make_policy(adapt::AdaptNetConfig cfg = config(), nn::Activation act = nn::Activation::ReLU,
                                     std::uint64_t seed = 3) {
  Rng rng(seed);
  auto base = an_make_base<T>(rng, act);
  adapt::AdaptNetPolicy<T> p(std::move(base), kAnObs, cfg, rng);
  MatrixX<T> warm = MatrixX<T>::Random(p.input_dim(), 32) * T(3);
  p.residual().normalizer.update(warm);
  return p;
}

/// Every trainable parameter to a non-zero value (the zero-initialised blocks included).
template <class T>
void perturb(adapt::AdaptNetPolicy<T>& p, double amp = 0.3) {
  for (auto* b : p.trainable_blocks()) {
    VectorX<T> r = VectorX<T>::Random(b->size());
    b->params() += r * static_cast<T>(amp);
  }
}

const std::vector<PartMask> some_masks(Index B) {
  std::vector<PartMask> m;
  for (Index j = 0; j < B; ++j) m.push_back(j % 2 ? PartMask::of(BodyPart::LeftArm) : PartMask::none());
  return m;
}

}  // namespace adaptnet_test

using namespace adaptnet_test;

// The adaptation at its zero init: the base's own means, samples and log-probs, bit for bit, for
// batch 1 (GEMV path) and larger batches, full-rank and LoRA IA, whatever the masks.
TEST(AdaptNetPolicy, ZeroInitReproducesTheFrozenBaseExactly) {
  auto lean = config(0);  // G_φ = identity, F_φ one layer, no IA
  lean.goal_hidden = {};
  lean.embed_hidden = {};
  lean.internal_adaptation = false;
  for (const auto& cfg : {config(0), config(4), lean}) {
    const Index rank = cfg.ia_rank;
    const auto pol = an_make_policy<float>(cfg);
    const PartElements pe(an_obs_parts(kAnObs));
    for (Index B : {Index(1), Index(2), Index(7), Index(64)}) {
      const MatrixXf obs = MatrixXf::Random(kAnObs, B) * 1.5f, goals = MatrixXf::Random(kAnGoal, B);
      const auto masks = some_masks(B);
      adapt::AdaptNetWorkspace<float> ws;
      MatrixXf x, mu, act;
      RowVectorX<float> lp;
      pol.build_input(pe, obs, masks, goals, x, ws);
      ASSERT_EQ(x.rows(), kAnObs + kAnGoal);
      Rng r1(11), r2(11);
      pol.act(x, masks, r1, act, lp, mu, ws);
      const MatrixXf base_in = policy_input<float>(pe, obs, std::vector<PartMask>(static_cast<std::size_t>(B)));
      MatrixXf base_act, base_mu, scratch;
      RowVectorX<float> base_lp;
      nn::InferenceWorkspace<float> bws;
      pol.base().act(base_in, r2, base_act, base_lp, base_mu, bws, scratch);
      EXPECT_TRUE((mu.array() == base_mu.array()).all()) << "rank " << rank << " B " << B;
      EXPECT_TRUE((act.array() == base_act.array()).all()) << "rank " << rank << " B " << B;
      EXPECT_TRUE((lp.array() == base_lp.array()).all()) << "rank " << rank << " B " << B;
      // the training pass runs the same arithmetic
      adapt::AdaptNetTrainCache<float> c;
      EXPECT_TRUE((pol.forward_train(x, masks, c).array() == base_mu.array()).all());
    }
  }
}

// The paper-sized base ([1024, 1024, 512] on the 328-D observation), whose products are chunked.
TEST(AdaptNetPolicy, ZeroInitReproducesAPaperSizedBaseExactly) {
  Rng rng(5);
  const Index obs = 328, A = 63;
  auto base = an_make_base<float>(rng, nn::Activation::ReLU, {1024, 1024, 512}, obs, A);
  adapt::AdaptNetConfig cfg;
  cfg.goal_dim = 2;
  const adapt::AdaptNetPolicy<float> pol(std::move(base), obs, cfg, rng);
  const PartElements pe(an_obs_parts(obs));
  for (Index B : {Index(1), Index(48)}) {
    const MatrixXf obs_m = MatrixXf::Random(obs, B), goals = MatrixXf::Random(2, B);
    adapt::AdaptNetWorkspace<float> ws;
    MatrixXf x, mu, act;
    RowVectorX<float> lp;
    pol.build_input(pe, obs_m, {}, goals, x, ws);
    Rng r1(2), r2(2);
    pol.act(x, {}, r1, act, lp, mu, ws);
    const MatrixXf base_in = policy_input<float>(pe, obs_m, std::vector<PartMask>(static_cast<std::size_t>(B)));
    MatrixXf base_act, base_mu, scratch;
    RowVectorX<float> base_lp;
    nn::InferenceWorkspace<float> bws;
    pol.base().act(base_in, r2, base_act, base_lp, base_mu, bws, scratch);
    EXPECT_TRUE((mu.array() == base_mu.array()).all()) << B;
    EXPECT_TRUE((act.array() == base_act.array()).all()) << B;
  }
}

// Trained adaptation moves every DoF (no mask restriction); α = 0 with zero IA is the base again.
TEST(AdaptNetPolicy, AdaptationMovesAllDofsAndScaleZeroTurnsTheInjectionOff) {
  auto pol = an_make_policy<float>();
  perturb(pol);
  const PartElements pe(an_obs_parts(kAnObs));
  const MatrixXf obs = MatrixXf::Random(kAnObs, 4), goals = MatrixXf::Random(kAnGoal, 4);
  adapt::AdaptNetWorkspace<float> ws;
  MatrixXf x, mu, base_mu(kAnAct, 4), scratch;
  pol.build_input(pe, obs, some_masks(4), goals, x, ws);
  pol.mean(x, some_masks(4), mu, ws);
  nn::InferenceWorkspace<float> bws;
  pol.base().mean(policy_input<float>(pe, obs, std::vector<PartMask>(4)), base_mu, bws, scratch);
  EXPECT_TRUE((mu.array() != base_mu.array()).all());
  // only the injection: α = 0 switches it off exactly
  const auto ia = pol.adapter().ia.params().eval();
  pol.adapter().ia.params().setZero();
  pol.set_injection_scale(0.0f);
  pol.mean(x, some_masks(4), mu, ws);
  EXPECT_TRUE((mu.array() == base_mu.array()).all());
  pol.set_injection_scale(1.0f);
  pol.mean(x, some_masks(4), mu, ws);
  EXPECT_FALSE((mu.array() == base_mu.array()).all());
  // a goal changes the action only through the injection
  MatrixXf x2 = x;
  x2.bottomRows(kAnGoal).setConstant(0.7f);
  MatrixXf mu2;
  pol.mean(x2, {}, mu2, ws);
  EXPECT_FALSE((mu2.array() == mu.array()).all());
  pol.adapter().ia.params() = ia;
  pol.zero_adaptation();
  pol.mean(x2, {}, mu2, ws);
  pol.mean(x, {}, mu, ws);
  EXPECT_TRUE((mu2.array() == mu.array()).all());
}

// ∂(Σ_j w_j log p_j + β·mean‖I_φ‖²)/∂θ for θ in E_φ, G_φ, F_φ, η (ΔW, Δb or LoRA B, A) and
// log σ, against central differences in double, with every zero-initialised block perturbed.
TEST(AdaptNetPolicy, GradientsMatchFiniteDifferencesForEveryTrainableBlock) {
  for (int variant = 0; variant < 3; ++variant) {
    const Index rank = variant == 1 ? 3 : 0;
    auto cfg = config(rank);
    cfg.adapt_action_layer = rank > 0;  // (also covers the optional action-layer adaptor)
    if (variant == 2) {  // G_φ = identity, F_φ one layer
      cfg.goal_hidden = {};
      cfg.embed_hidden = {};
    }
    auto pol = an_make_policy<double>(cfg, nn::Activation::Tanh);
    perturb(pol);
    pol.set_injection_scale(0.8);
    const Index B = 5;
    const PartElements pe(an_obs_parts(kAnObs));
    const MatrixXd obs = MatrixXd::Random(kAnObs, B), goals = MatrixXd::Random(kAnGoal, B);
    const auto masks = some_masks(B);
    adapt::AdaptNetWorkspace<double> ws;
    MatrixXd x;
    pol.build_input(pe, obs, masks, goals, x, ws);
    const MatrixXd actions = MatrixXd::Random(kAnAct, B);
    const RowVectorX<double> dlogp = RowVectorX<double>::Random(B);
    const double beta = 0.3;
    auto loss = [&](adapt::AdaptNetPolicy<double>& p) {
      adapt::AdaptNetTrainCache<double> c;
      p.forward_train(x, masks, c);
      RowVectorX<double> lp;
      p.log_prob(c, actions, lp);
      return lp.dot(dlogp) + p.injection_penalty(c, beta);
    };
    adapt::AdaptNetTrainCache<double> c;
    pol.zero_grad();
    pol.forward_train(x, masks, c);
    const double pen = pol.injection_penalty(c, beta);
    EXPECT_GT(pen, 0.0);
    MatrixXd dmu;
    adapt::AdaptNetPolicy<double>::log_prob_mean_grad(c, actions, dlogp, dmu);
    pol.backward(c, dmu);
    const auto blocks = pol.trainable_blocks();
    ASSERT_EQ(blocks.size(), variant == 2 ? 4u : 5u);  // encoder, [goal net], embed, ia, log_std
    const double h = 1e-6;
    for (std::size_t k = 0; k < blocks.size(); ++k) {
      auto p = blocks[k]->params();
      int nonzero = 0;
      for (Index i = 0; i < p.size(); ++i) {
        const double w0 = p[i];
        p[i] = w0 + h;
        const double lplus = loss(pol);
        p[i] = w0 - h;
        const double lminus = loss(pol);
        p[i] = w0;
        const double fd = (lplus - lminus) / (2 * h);
        EXPECT_NEAR(blocks[k]->grads()[i], fd, 1e-6 * (1 + std::abs(fd))) << "rank " << rank << " block " << k << " param " << i;
        nonzero += blocks[k]->grads()[i] != 0.0;
      }
      EXPECT_GT(nonzero, p.size() / 2) << "block " << k;
    }
  }
}

// At the zero init the gradient still reaches the zero-initialised layers (F_φ's last layer, ΔW,
// Δb) — the adaptation can start — while E_φ behind a zero F_φ gets none.
TEST(AdaptNetPolicy, ZeroInitGradientsReachTheZeroInitialisedLayers) {
  auto pol = an_make_policy<double>(config(0), nn::Activation::Tanh);
  const MatrixXd x = MatrixXd::Random(pol.input_dim(), 6), actions = MatrixXd::Random(kAnAct, 6);
  adapt::AdaptNetTrainCache<double> c;
  pol.zero_grad();
  pol.forward_train(x, {}, c);
  MatrixXd dmu;
  adapt::AdaptNetPolicy<double>::log_prob_mean_grad(c, actions, RowVectorX<double>::Ones(6), dmu);
  pol.backward(c, dmu);
  auto& m = pol.adapter();
  EXPECT_GT(m.embed.weight_grad(m.embed.num_layers() - 1).norm(), 0.0);
  EXPECT_GT(m.ia.grads().norm(), 0.0);
  EXPECT_GT(m.log_std.grads().norm(), 0.0);
  EXPECT_EQ(m.encoder.grads().norm(), 0.0);
}

// Adam on trainable_blocks() (as the trainer steps them) moves the adaptation and never the base.
TEST(AdaptNetPolicy, OptimiserStepLeavesTheBaseUnchanged) {
  auto pol = an_make_policy<float>();
  const VectorXf base_params = pol.base().mean_net.params(), base_grads = pol.base().mean_net.grads();
  const VectorXf base_ls = pol.base().log_std.params();
  const VectorXd base_norm = pol.base().normalizer.mean();
  for (auto* b : pol.trainable_blocks()) {
    EXPECT_NE(b, &pol.base().mean_net.block());
    EXPECT_NE(b, &pol.base().log_std);
  }
  const VectorXf embed0 = pol.adapter().embed.params(), ia0 = pol.adapter().ia.params();
  nn::Adam<float> opt({1e-2, 0.9, 0.999, 1e-8, 0.0, false, 1.0});
  const MatrixXf x = MatrixXf::Random(pol.input_dim(), 16), actions = MatrixXf::Random(kAnAct, 16);
  for (int step = 0; step < 3; ++step) {
    adapt::AdaptNetTrainCache<float> c;
    pol.zero_grad();
    pol.forward_train(x, some_masks(16), c);
    MatrixXf dmu;
    adapt::AdaptNetPolicy<float>::log_prob_mean_grad(c, actions, RowVectorX<float>::Constant(16, -1.0f / 16), dmu);
    pol.backward(c, dmu);
    ASSERT_TRUE(opt.step(pol.trainable_blocks()).applied);
  }
  EXPECT_TRUE(pol.base().mean_net.params() == base_params);
  EXPECT_TRUE(pol.base().mean_net.grads() == base_grads);
  EXPECT_TRUE(pol.base().log_std.params() == base_ls);
  EXPECT_TRUE(pol.base().normalizer.mean() == base_norm);
  EXPECT_FALSE(pol.adapter().embed.params() == embed0);
  EXPECT_FALSE(pol.adapter().ia.params() == ia0);
  EXPECT_FALSE(pol.adapter().log_std.params() == base_ls);
}

// save → bytes → load into a differently seeded policy: every section and the means bit for bit.
TEST(AdaptNetPolicy, CheckpointRoundTripIsBitIdentical) {
  auto a = an_make_policy<float>(config(0), nn::Activation::ReLU, 3);
  perturb(a);
  a.residual().normalizer.update(MatrixXf::Random(a.input_dim(), 8));
  Checkpoint ck;
  a.save(ck);
  const Checkpoint back = parse_checkpoint(serialize_checkpoint(ck));
  auto b = an_make_policy<float>(config(0), nn::Activation::ReLU, 17);
  ASSERT_FALSE(b.adapter().encoder.params() == a.adapter().encoder.params());
  b.load(back);
  const auto& ma = a.adapter();
  const auto& mb = b.adapter();
  EXPECT_TRUE(ma.encoder.params() == mb.encoder.params());
  EXPECT_TRUE(ma.goal_net.params() == mb.goal_net.params());
  EXPECT_TRUE(ma.embed.params() == mb.embed.params());
  EXPECT_TRUE(ma.ia.params() == mb.ia.params());
  EXPECT_TRUE(ma.log_std.params() == mb.log_std.params());
  EXPECT_TRUE(ma.normalizer.mean() == mb.normalizer.mean());
  EXPECT_TRUE(a.base().mean_net.params() == b.base().mean_net.params());
  const MatrixXf x = MatrixXf::Random(a.input_dim(), 5);
  adapt::AdaptNetWorkspace<float> ws;
  MatrixXf mu_a, mu_b;
  a.mean(x, {}, mu_a, ws);
  b.mean(x, {}, mu_b, ws);
  EXPECT_TRUE((mu_a.array() == mu_b.array()).all());
  // adapter sections only: b's base stays
  auto c = an_make_policy<float>(config(0), nn::Activation::ReLU, 17);
  const VectorXf c_base = c.base().mean_net.params();
  c.load(back, false);
  EXPECT_TRUE(c.base().mean_net.params() == c_base);
  EXPECT_TRUE(c.adapter().embed.params() == ma.embed.params());
}

// A checkpoint of another shape throws maskadapt::Error naming the section at fault.
TEST(AdaptNetPolicy, LoadRejectsWrongSizesNamingTheSection) {
  auto field_of_load = [](const Checkpoint& ck, adapt::AdaptNetPolicy<float>& p, bool with_base = true) -> std::string {
    try {
      p.load(ck, with_base);
    } catch (const Error& e) {
      return e.context().field;
    }
    return "(no throw)";
  };
  Checkpoint ck;
  an_make_policy<float>(config(0)).save(ck);
  auto other_embed = config(0);
  other_embed.embed_hidden = {};
  auto p1 = an_make_policy<float>(other_embed);
  EXPECT_EQ(field_of_load(ck, p1), "adaptnet/embed");
  auto p2 = an_make_policy<float>(config(2));  // LoRA: η has another size
  EXPECT_EQ(field_of_load(ck, p2), "adaptnet/ia");
  auto no_ia = config(0);
  no_ia.internal_adaptation = false;
  auto p3 = an_make_policy<float>(no_ia);
  EXPECT_EQ(field_of_load(ck, p3), "adaptnet/ia");
  auto other_goal = config(0);
  other_goal.goal_hidden = {5};
  auto p4 = an_make_policy<float>(other_goal);
  EXPECT_EQ(field_of_load(ck, p4), "adaptnet/goal_net");
  auto p5 = an_make_policy<float>(config(0, 4));  // goal_dim 4: the normaliser is wider
  EXPECT_EQ(field_of_load(ck, p5), "adaptnet/goal_net");
  // another base
  Rng rng(3);
  adapt::AdaptNetPolicy<float> p6(an_make_base<float>(rng, nn::Activation::ReLU, {16, 12, 10}), kAnObs, config(0), rng);
  Checkpoint ck6;
  an_make_policy<float>(config(0)).save(ck6);
  ck6.erase("adaptnet/ia");
  ck6.put("adaptnet/ia", VectorXf::Zero(p6.adapter().ia.size()));  // (η sized for p6: the base is next)
  EXPECT_EQ(field_of_load(ck6, p6), "base/actor/params");
}

// The stage-2 trainer's calls on its policy (train::Stage2Policy) compile against both policies.
static_assert(train::Stage2Policy<adapt::ResidualPolicy<float>>);
static_assert(train::Stage2Policy<adapt::AdaptNetPolicy<float>>);

TEST(AdaptNetPolicy, RejectsWrongShapes) {
  const auto pol = an_make_policy<float>();
  const PartElements pe(an_obs_parts(kAnObs));
  adapt::AdaptNetWorkspace<float> ws;
  MatrixXf x, mu;
  EXPECT_THROW(pol.build_input(pe, MatrixXf::Zero(kAnObs + 1, 2), {}, MatrixXf::Zero(kAnGoal, 2), x, ws), Error);
  EXPECT_THROW(pol.build_input(pe, MatrixXf::Zero(kAnObs, 2), {}, MatrixXf::Zero(kAnGoal + 1, 2), x, ws), Error);
  EXPECT_THROW(pol.mean(MatrixXf::Zero(kAnObs, 2), {}, mu, ws), Error);
  Rng rng(1);
  EXPECT_THROW(adapt::AdaptNetPolicy<float>(an_make_base<float>(rng), kAnObs + 1, config(), rng), Error);
  auto bad = config();
  bad.goal_dim = 0;  // goal_hidden without a goal
  EXPECT_THROW(adapt::AdaptNetPolicy<float>(an_make_base<float>(rng), kAnObs, bad, rng), Error);
  // internal adaptation sits on the base layers between latents: 1 … L−2 (here 1, 2)
  ASSERT_EQ(pol.ia_slots().size(), 2u);
  EXPECT_EQ(pol.ia_slots()[0].layer, 1);
  EXPECT_EQ(pol.ia_slots()[1].layer, 2);
}
