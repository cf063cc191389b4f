// Closed forms of the noise schedule, the DDPM sampler with a trivial denoiser, and CFG.
#include <maskadapt/tracking/diffusion.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace maskadapt;
using namespace maskadapt::tracking;

TEST(Diffusion, AlphaBarIsTheProductOfAlphas) {
  for (const auto& s : {linear_schedule(10), cosine_schedule(10), linear_schedule(50, 1e-4, 0.02, false)}) {
    double prod = 1.0;
    for (int t = 0; t < s.num_steps(); ++t) {
      EXPECT_NEAR(s.alphas[t], 1.0 - s.betas[t], 1e-15);
      EXPECT_NEAR(s.alpha_bars_prev[t], prod, 1e-15);
      prod *= 1.0 - s.betas[t];
      EXPECT_NEAR(s.alpha_bars[t], prod, 1e-14);
      if (t > 0) {
        EXPECT_LT(s.alpha_bars[t], s.alpha_bars[t - 1]);
      }
    }
  }
}

TEST(Diffusion, CosineScheduleMatchesItsDefinition) {
  const int T = 10;
  const double off = 0.008;
  const auto s = cosine_schedule(T, off, 0.999);
  auto f = [&](double t) { return std::pow(std::cos((t / T + off) / (1 + off) * std::numbers::pi / 2), 2); };
  for (int t = 0; t < T - 1; ++t) EXPECT_NEAR(s.alpha_bars[t], f(t + 1) / f(0), 1e-12) << "t=" << t;
  // The last step is clipped at max_beta: ᾱ_{T−1} = ᾱ_{T−2}·(1 − 0.999).
  EXPECT_NEAR(s.alpha_bars[T - 1], s.alpha_bars[T - 2] * 0.001, 1e-15);
}

TEST(Diffusion, LinearScheduleEndpoints) {
  const auto s = linear_schedule(10, 1e-4, 0.02, true);  // scaled by 1000/10 = 100
  EXPECT_NEAR(s.betas[0], 0.01, 1e-15);
  EXPECT_NEAR(s.betas[9], 0.999, 1e-15);  // 2.0 clipped to 0.999
  EXPECT_LT(s.alpha_bars[9], 1e-3);
}

TEST(Diffusion, RejectsBadBetas) {
  VectorXd b(3);
  b << 0.1, 1.0, 0.2;
  EXPECT_THROW(NoiseSchedule::from_betas(b), Error);
  b << 0.1, std::nan(""), 0.2;
  EXPECT_THROW(NoiseSchedule::from_betas(b), Error);
  EXPECT_THROW(cosine_schedule(0), Error);
}

TEST(Diffusion, PosteriorCoefficientsMatchBayesRule) {
  // q(x_{t−1}|x₀) = N(√ᾱ_{t−1} x₀, 1−ᾱ_{t−1}),  q(x_t|x_{t−1}) = N(√α_t x_{t−1}, β_t):
  // posterior precision 1/(1−ᾱ_{t−1}) + α_t/β_t, mean = var·(√ᾱ_{t−1}x₀/(1−ᾱ_{t−1}) + √α_t x_t/β_t).
  const auto s = cosine_schedule(10);
  for (int t = 1; t < s.num_steps(); ++t) {
    const double abp = s.alpha_bars_prev[t], a = s.alphas[t], b = s.betas[t];
    const double var = 1.0 / (1.0 / (1.0 - abp) + a / b);
    EXPECT_NEAR(s.posterior_variance[t], var, 1e-12 * std::max(1.0, var)) << t;
    EXPECT_NEAR(s.posterior_coef_x0[t], var * std::sqrt(abp) / (1.0 - abp), 1e-12) << t;
    EXPECT_NEAR(s.posterior_coef_xt[t], var * std::sqrt(a) / b, 1e-12) << t;
  }
  EXPECT_DOUBLE_EQ(s.posterior_variance[0], 0.0);
  EXPECT_DOUBLE_EQ(s.posterior_coef_x0[0], 1.0);
  EXPECT_DOUBLE_EQ(s.posterior_coef_xt[0], 0.0);
}

TEST(Diffusion, ForwardNoisingMomentsByMonteCarlo) {
  const auto s = cosine_schedule(10);
  const Index n = 40000;
  Rng rng(7);
  for (int t : {0, 4, 9}) {
    MatrixXd x0 = MatrixXd::Constant(1, n, 1.5);
    MatrixXd eps(1, n);
    for (Index j = 0; j < n; ++j) eps(0, j) = rng.normal();
    const std::vector<int> ts(n, t);
    const MatrixXd xt = q_sample<double>(s, x0, ts, eps);
    const double mean = xt.mean();
    const double var = (xt.array() - mean).square().sum() / (n - 1);
    const double want_var = 1.0 - s.alpha_bars[t];
    EXPECT_NEAR(mean, std::sqrt(s.alpha_bars[t]) * 1.5, 5.0 * std::sqrt(want_var / n)) << t;
    EXPECT_NEAR(var, want_var, 5.0 * want_var * std::sqrt(2.0 / n)) << t;
  }
}

TEST(Diffusion, TwoStepForwardChainMatchesClosedForm) {
  // Noising step by step with q(x_t|x_{t−1}) must give the moments of q(x_t|x₀).
  const auto s = linear_schedule(10);
  const Index n = 40000;
  Rng rng(11);
  const int t = 3;
  double sum = 0, sum2 = 0;
  for (Index j = 0; j < n; ++j) {
    double x = -0.7;
    for (int k = 0; k <= t; ++k) x = std::sqrt(s.alphas[k]) * x + std::sqrt(s.betas[k]) * rng.normal();
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  const double want_var = 1.0 - s.alpha_bars[t];
  EXPECT_NEAR(mean, -0.7 * std::sqrt(s.alpha_bars[t]), 5.0 * std::sqrt(want_var / n));
  EXPECT_NEAR(var, want_var, 5.0 * want_var * std::sqrt(2.0 / n));
}

TEST(Diffusion, SamplerWithConstantDenoiserFollowsTheFormulas) {
  const auto s = cosine_schedule(10);
  const Index dim = 3, batch = 4;
  MatrixXd c(dim, batch);
  c << 1, 2, 3, 4, -1, -2, -3, -4, 0.5, 0.25, 0, 9;
  std::vector<MatrixXd> seen;
  std::vector<int> steps;
  auto denoiser = [&](const MatrixXd& xt, int t) {
    seen.push_back(xt);
    steps.push_back(t);
    return MatrixXd(c);
  };
  Rng rng(123);
  const MatrixXd out = ddpm_sample<double>(s, dim, batch, denoiser, rng);
  // The last step (t = 0) returns x̂₀ itself.
  EXPECT_TRUE(out.isApprox(c, 1e-12));
  // Replay the draws: x_{T−1} ~ N(0, I); x_{t−1} = c1 c + c2 x_t + √β̃_t z.
  ASSERT_EQ(steps.size(), 10u);
  Rng replay(123);
  MatrixXd x(dim, batch);
  for (Index j = 0; j < batch; ++j)
    for (Index i = 0; i < dim; ++i) x(i, j) = replay.normal();
  for (int k = 0; k < 10; ++k) {
    const int t = 9 - k;
    EXPECT_EQ(steps[k], t);
    EXPECT_TRUE(seen[k].isApprox(x, 1e-12)) << "t=" << t;
    MatrixXd next = s.posterior_coef_x0[t] * c + s.posterior_coef_xt[t] * x;
    if (t > 0)
      for (Index j = 0; j < batch; ++j)
        for (Index i = 0; i < dim; ++i) next(i, j) += std::sqrt(s.posterior_variance[t]) * replay.normal();
    x = next;
  }
  EXPECT_TRUE(x.isApprox(out, 1e-12));
}

TEST(Diffusion, PenultimateSampleHasPosteriorMoments) {
  // With x̂₀ ≡ c, x₀ after step t=1 is N(c1_1·c + c2_1·x_1, β̃_1); check the spread of x at the
  // input of the last step over many runs against the chain's closed-form variance.
  const auto s = cosine_schedule(4);
  const Index n = 20000;
  Rng rng(5);
  double sum = 0, sum2 = 0;
  for (Index r = 0; r < n; ++r) {
    double last_input = 0;
    auto denoiser = [&](const MatrixXd& xt, int t) {
      if (t == 0) last_input = xt(0, 0);
      return MatrixXd::Constant(1, 1, 2.0);
    };
    ddpm_sample<double>(s, 1, 1, denoiser, rng);
    sum += last_input;
    sum2 += last_input * last_input;
  }
  // Closed form of the linear-Gaussian chain: x ← c1 c + c2 x + σ z, starting N(0,1).
  double m = 0, v = 1;
  for (int t = 3; t >= 1; --t) {
    m = s.posterior_coef_x0[t] * 2.0 + s.posterior_coef_xt[t] * m;
    v = s.posterior_coef_xt[t] * s.posterior_coef_xt[t] * v + s.posterior_variance[t];
  }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  EXPECT_NEAR(mean, m, 5.0 * std::sqrt(v / n));
  EXPECT_NEAR(var, v, 5.0 * v * std::sqrt(2.0 / n));
}

TEST(Diffusion, GuidanceWeightOneIsTheConditionalPrediction) {
  Rng rng(3);
  MatrixXf cond(5, 7), uncond(5, 7);
  for (Index i = 0; i < cond.size(); ++i) {
    cond.data()[i] = static_cast<float>(rng.normal());
    uncond.data()[i] = static_cast<float>(rng.normal());
  }
  EXPECT_TRUE(guided_prediction<float>(cond, uncond, 1.0) == cond);
  EXPECT_TRUE(guided_prediction<float>(cond, uncond, 0.0) == uncond);
  const MatrixXf g5 = guided_prediction<float>(cond, uncond, 5.0);
  EXPECT_TRUE(g5.isApprox(uncond + 5.0f * (cond - uncond), 1e-6f));
  EXPECT_THROW(guided_prediction<float>(cond, MatrixXf(5, 6), 1.0), Error);
}

TEST(Diffusion, SamplerRejectsBadDenoiserOutput) {
  const auto s = cosine_schedule(3);
  Rng rng(1);
  EXPECT_THROW(ddpm_sample<float>(s, 2, 2, [](const MatrixXf&, int) { return MatrixXf(3, 2); }, rng), Error);
  EXPECT_THROW(ddpm_sample<float>(s, 2, 2, [](const MatrixXf&, int) { return MatrixXf::Constant(2, 2, NAN); }, rng),
               Error);
}

TEST(Diffusion, TrainingBatchUsesQSample) {
  const auto s = cosine_schedule(10);
  Rng rng(9);
  MatrixXf x0 = MatrixXf::Random(4, 64);
  const auto b = make_diffusion_batch<float>(s, x0, rng);
  ASSERT_EQ(b.t.size(), 64u);
  std::vector<int> count(10, 0);
  for (int t : b.t) {
    ASSERT_GE(t, 0);
    ASSERT_LT(t, 10);
    ++count[t];
  }
  EXPECT_TRUE(b.xt.isApprox(q_sample<float>(s, x0, b.t, b.noise)));
  int used = 0;
  for (int c : count) used += c > 0;
  EXPECT_GE(used, 8);  // 64 uniform draws over 10 steps hit nearly all of them
}

TEST(Diffusion, TimestepEmbeddingKnownValues) {
  const VectorXf e = timestep_embedding<float>(3, 4);
  // half = 2: ω = 1, 1/100.
  EXPECT_NEAR(e[0], std::sin(3.0), 1e-6);
  EXPECT_NEAR(e[1], std::sin(0.03), 1e-6);
  EXPECT_NEAR(e[2], std::cos(3.0), 1e-6);
  EXPECT_NEAR(e[3], std::cos(0.03), 1e-6);
  EXPECT_THROW(timestep_embedding<float>(1, 3), Error);
}
