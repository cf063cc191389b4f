// The motion VAE round trip, the latent denoiser and the built-in generator end to end.
#include "test_support.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace maskadapt;
using namespace maskadapt::tracking;

namespace {

BuiltinGeneratorConfig small_config() { return test::small_generator_config(128, 16); }

/// Mean body-position error (m) over every future frame and body when each window is encoded to
/// its posterior mean and decoded again.
double round_trip_error(const MotionVae& vae, const PrimitiveDataset& d) {
  const Skeleton& skel = humanoid_skeleton();
  const MatrixXf hn = vae.history_stats.normalize(d.history);
  const MatrixXf fn = vae.future_stats.normalize(d.future);
  const auto [mu, lv] = vae.encode(hn, fn);
  const MatrixXf rec = vae.future_stats.denormalize(vae.decode(hn, mu));
  double err = 0.0;
  Index count = 0;
  for (Index n = 0; n < d.size(); ++n) {
    const Trajectory a = decode_frames<float>(skel, Eigen::Map<const MatrixXf>(rec.col(n).data(), d.frame_dim, d.future_frames));
    const Trajectory b =
        decode_frames<float>(skel, Eigen::Map<const MatrixXf>(d.future.col(n).data(), d.frame_dim, d.future_frames));
    for (Index i = 0; i < a.num_frames(); ++i)
      for (int k = 0; k < skel.num_bodies(); ++k) {
        err += (a.body_pos.block<3, 1>(3 * k, i) - b.body_pos.block<3, 1>(3 * k, i)).norm();
        ++count;
      }
  }
  return err / static_cast<double>(count);
}

}  // namespace

TEST(MotionVae, RoundTripOnTrainingDataAfterShortTraining) {
  const auto data = make_primitive_dataset(humanoid_skeleton(), test::make_clips(), 5, 15, 2);
  Rng rng(42);
  BuiltinGenerator g(humanoid_skeleton(), small_config(), rng);
  GeneratorTrainConfig tc;
  tc.vae_iterations = 400;
  tc.diffusion_iterations = 0;
  tc.batch = 32;
  // Statistics only (no VAE step) to measure the untrained round trip first.
  GeneratorTrainConfig stats_only = tc;
  stats_only.vae_iterations = 0;
  train_generator(g, data, stats_only, rng);
  const double before = round_trip_error(g.vae(), data);
  const auto rep = train_generator(g, data, tc, rng);
  const double after = round_trip_error(g.vae(), data);
  std::printf("VAE round trip: mean body position error %.4f m before, %.4f m after %lld iterations (recon %.4f, kl %.2f, %.1f s)\n",
              before, after, static_cast<long long>(rep.vae_iterations), rep.vae_final.recon, rep.vae_final.kl,
              rep.vae_seconds);
  EXPECT_LT(after, 0.03);  // stated bound: 3 cm mean body-position error on training windows
  EXPECT_LT(after, 0.25 * before);
}

TEST(LatentDenoiser, LearnsTheLatentOfEachText) {
  // Two texts, each with its own fixed latent: after training the guided sampler must return
  // latents near the right one for each text (conditioning really flows through the projection).
  Rng rng(8);
  DenoiserConfig dc;
  dc.text_features = 32;
  dc.text_embed = 8;
  dc.hidden = {64};
  LatentDenoiser den(4, 6, dc, rng);
  const auto s = cosine_schedule(10);
  const HashedTextFeatures tf(32);
  const VectorXf fa = tf.features("raise arms"), fb = tf.features("punch");
  Eigen::Vector4f za(1.0f, -1.0f, 0.5f, 0.0f), zb(-1.0f, 0.5f, 0.0f, 1.0f);
  nn::Adam<float> adam(nn::AdamConfig{3e-3});
  const Index B = 64;
  for (int it = 0; it < 1500; ++it) {
    MatrixXf x0(4, B), f(32, B);
    for (Index j = 0; j < B; ++j) {
      const bool a = j % 2 == 0;
      x0.col(j) = a ? za : zb;
      f.col(j) = a ? fa : fb;
    }
    den.train_step(s, x0, f, MatrixXf::Zero(6, B), adam, rng);
  }
  for (int which = 0; which < 2; ++which) {
    const MatrixXf e = den.embed(which == 0 ? fa : fb);
    const MatrixXf zero = MatrixXf::Zero(8, 1);
    const MatrixXf h = MatrixXf::Zero(6, 1);
    auto pred = [&](const MatrixXf& xt, int t) -> MatrixXf {
      return guided_prediction<float>(den.predict(xt, t, e, h), den.predict(xt, t, zero, h), 2.0);
    };
    const MatrixXf z = ddpm_sample<float>(s, 4, 1, pred, rng);
    const Eigen::Vector4f want = which == 0 ? za : zb, other = which == 0 ? zb : za;
    EXPECT_LT((z.col(0) - want).norm(), 0.5f * (z.col(0) - other).norm()) << "text " << which << ": " << z.transpose();
  }
}

TEST(BuiltinGenerator, GeneratesDeterministicallyAndSavesLoadsExactly) {
  const Skeleton& skel = humanoid_skeleton();
  const auto clips = test::make_clips();
  const auto data = make_primitive_dataset(skel, clips, 5, 15, 3);
  Rng rng(1);
  BuiltinGenerator g(skel, small_config(), rng);
  GeneratorTrainConfig tc;
  tc.vae_iterations = 60;
  tc.diffusion_iterations = 60;
  tc.batch = 16;
  const auto rep = train_generator(g, data, tc, rng);
  EXPECT_EQ(rep.vae_iterations, 60);
  EXPECT_EQ(rep.diffusion_iterations, 60);
  EXPECT_GT(g.latent_scale(), 0.0f);

  const auto [hist, frame] = canonicalize(clips[0].motion.slice(10, 5), 0);
  Rng r1(77), r2(77), r3(78);
  const Trajectory a = g.generate("raise arms", hist, r1);
  const Trajectory b = g.generate("raise arms", hist, r2);
  const Trajectory c = g.generate("raise arms", hist, r3);
  check_generated(skel, a, 15);
  EXPECT_TRUE(a.q == b.q && a.root_pos == b.root_pos);
  EXPECT_FALSE(a.q == c.q);
  // Unconditional (empty prompt) and precomputed-feature conditions work too.
  Rng r4(77), r5(77);
  check_generated(skel, g.generate("", hist, r4), 15);
  const Trajectory via_embedding = g.generate(TextCondition::from_embedding(g.text_encoder().features("raise arms")), hist, r5);
  EXPECT_TRUE(via_embedding.q == a.q);
  Rng r6(1);
  EXPECT_THROW(g.generate(TextCondition::from_embedding(VectorXf::Ones(3)), hist, r6), Error);
  EXPECT_THROW(g.generate("x", hist.slice(0, 4), r6), Error);

  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_test_generator.ckpt").string();
  g.save(path);
  const BuiltinGenerator loaded = BuiltinGenerator::load(path, skel);
  Rng r7(77);
  const Trajectory d = loaded.generate("raise arms", hist, r7);
  EXPECT_TRUE(d.q == a.q && d.root_pos == a.root_pos && d.body_pos == a.body_pos);

  // Autoregressive rollout in the world frame continues from the history's last frame.
  Rng r8(3);
  const Trajectory world = rollout(g, parse_text_schedule("wave hands"), clips[0].motion.slice(0, 5), 40, r8);
  EXPECT_EQ(world.num_frames(), 40);
  EXPECT_LT((world.root_pos.col(0) - clips[0].motion.root_pos.col(4)).head<2>().norm(), 0.5);

  // A damaged file is reported, not loaded.
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(100);
    f.put('\x7f');
  }
  EXPECT_THROW(BuiltinGenerator::load(path, skel), Error);
  std::filesystem::remove(path);
}

namespace {

/// The denoiser's parameters (projection, then network) after training a fresh small generator
/// (seed 5) for `diffusion` iterations with `tc`'s other settings.
VectorXf denoiser_after(const PrimitiveDataset& data, GeneratorTrainConfig tc, Index diffusion,
                        const GeneratorScore& score = {}, GeneratorTrainReport* report = nullptr) {
  Rng rng(5);
  BuiltinGenerator g(humanoid_skeleton(), small_config(), rng);
  tc.vae_iterations = 3;
  tc.diffusion_iterations = diffusion;
  tc.batch = 8;
  const auto rep = train_generator(g, data, tc, rng, {}, score);
  if (report) *report = rep;
  const auto& p = g.denoiser().projection().params();
  const auto& n = g.denoiser().network().params();
  VectorXf all(p.size() + n.size());
  all << p, n;
  return all;
}

}  // namespace

TEST(TrainGenerator, KeepsTheMovingAverageOfTheDenoiserWeights) {
  // With decay d the kept weights are θ̄₃ where θ̄₀ = θ₀ and θ̄ₖ₊₁ = dₖ θ̄ₖ + (1 − dₖ) θₖ₊₁,
  // dₖ = min(d, (1 + k) / (10 + k)); θₖ are the weights of plain runs of k iterations (the EMA draws
  // no random numbers, so every run follows the same stream).
  const auto data = make_primitive_dataset(humanoid_skeleton(), test::make_clips(), 5, 15, 3);
  GeneratorTrainConfig plain;
  std::vector<VectorXf> theta;
  for (Index k = 0; k <= 3; ++k) theta.push_back(denoiser_after(data, plain, k));
  ASSERT_GT((theta[3] - theta[0]).norm(), 0.0f);
  GeneratorTrainConfig ema = plain;
  ema.ema_decay = 0.15;  // between d₀ = 0.1 and d₁ = 2/11, so both branches of the min are used
  VectorXf expect = theta[0];
  for (Index k = 0; k < 3; ++k) {
    const float d = static_cast<float>(std::min(0.15, (1.0 + k) / (10.0 + k)));
    expect = d * expect + (1.0f - d) * theta[static_cast<std::size_t>(k + 1)];
  }
  const VectorXf got = denoiser_after(data, ema, 3);
  EXPECT_LT((got - expect).cwiseAbs().maxCoeff(), 1e-6f);
  EXPECT_GT((got - theta[3]).cwiseAbs().maxCoeff(), 1e-4f) << "the moving average must differ from the last weights";
}

TEST(TrainGenerator, SelectionKeepsTheBestScoredSnapshotExactly) {
  const auto data = make_primitive_dataset(humanoid_skeleton(), test::make_clips(), 5, 15, 3);
  GeneratorTrainConfig tc;
  tc.select_every = 2;
  // A score that peaks at the second snapshot (iteration 4) of 2, 4, 6, 7.
  int calls = 0;
  const GeneratorScore score = [&](const BuiltinGenerator&) { return ++calls == 2 ? 1.0 : 0.0; };
  GeneratorTrainReport rep;
  const VectorXf kept = denoiser_after(data, tc, 7, score, &rep);
  ASSERT_EQ(rep.snapshots.size(), 4u);
  EXPECT_EQ(rep.snapshots[0].iteration, 2);
  EXPECT_EQ(rep.snapshots[3].iteration, 7);
  EXPECT_EQ(rep.selected_iteration, 4);
  EXPECT_EQ(rep.diffusion_iterations, 7);
  // Bit for bit the weights of a plain 4-iteration run: scoring neither draws random numbers nor
  // disturbs the optimiser.
  const VectorXf four = denoiser_after(data, GeneratorTrainConfig{}, 4);
  EXPECT_EQ(kept, four);
  EXPECT_NE(kept, denoiser_after(data, GeneratorTrainConfig{}, 7));
}

TEST(TrainGenerator, RefusesBadSelectionAndAverageSettings) {
  const auto data = make_primitive_dataset(humanoid_skeleton(), test::make_clips(), 5, 15, 3);
  GeneratorTrainConfig tc;
  tc.select_every = 2;  // without a score function
  EXPECT_THROW(denoiser_after(data, tc, 4), Error);
  tc.select_every = 0;
  tc.ema_decay = 1.0;
  EXPECT_THROW(denoiser_after(data, tc, 4), Error);
  tc.ema_decay = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(denoiser_after(data, tc, 4), Error);
}
