#include <maskadapt/rl/gae.hpp>
#include <maskadapt/rl/replay_buffer.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/nn/chunks.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

using namespace maskadapt;
using namespace maskadapt::rl;

namespace {
MatrixXd row(std::initializer_list<double> v) {
  MatrixXd m(1, static_cast<Index>(v.size()));
  Index i = 0;
  for (double x : v) m(0, i++) = x;
  return m;
}
}  // namespace

// One env, 3 steps, no episode end: hand-computed with γ = 0.5, λ = 0.5.
TEST(Gae, HandComputedThreeSteps) {
  const MatrixXd r = row({1, 2, 3}), v = row({0.5, 1.0, 1.5}), fin = MatrixXd::Zero(1, 3);
  MatrixXd boot(1, 1);
  boot << 2.0;
  std::vector<std::uint8_t> none(3, 0);
  MatrixXd adv, ret;
  compute_gae<double>({0.5, 0.5}, 1, r, v, none, none, fin, boot, adv, ret);
  // δ2 = 3 + 0.5·2 − 1.5 = 2.5;  δ1 = 2 + 0.5·1.5 − 1 = 1.75;  δ0 = 1 + 0.5·1 − 0.5 = 1
  // A2 = 2.5; A1 = 1.75 + 0.25·2.5 = 2.375; A0 = 1 + 0.25·2.375 = 1.59375
  EXPECT_DOUBLE_EQ(adv(0, 2), 2.5);
  EXPECT_DOUBLE_EQ(adv(0, 1), 2.375);
  EXPECT_DOUBLE_EQ(adv(0, 0), 1.59375);
  EXPECT_DOUBLE_EQ(ret(0, 0), 1.59375 + 0.5);
}

// Termination: no bootstrap and no flow of advantage across the boundary.
// Truncation: bootstrap with the final value, but still no flow across the boundary.
TEST(Gae, TerminationVersusTruncation) {
  const MatrixXd r = row({1, 1, 1}), v = row({0, 0, 0});
  MatrixXd fin = MatrixXd::Zero(1, 3);
  fin(0, 1) = 10.0;  // value of the last observation of the episode cut at t = 1
  MatrixXd boot(1, 1);
  boot << 100.0;
  std::vector<std::uint8_t> flag = {0, 1, 0}, none(3, 0);
  MatrixXd adv_term, ret, adv_trunc;
  compute_gae<double>({0.9, 1.0}, 1, r, v, flag, none, fin, boot, adv_term, ret);
  compute_gae<double>({0.9, 1.0}, 1, r, v, none, flag, fin, boot, adv_trunc, ret);
  EXPECT_DOUBLE_EQ(adv_term(0, 2), 1 + 0.9 * 100);
  EXPECT_DOUBLE_EQ(adv_term(0, 1), 1.0);                      // terminal: r only
  EXPECT_DOUBLE_EQ(adv_term(0, 0), 1 + 0.9 * 1.0);            // λ = 1: discounted sum to the end
  EXPECT_DOUBLE_EQ(adv_trunc(0, 2), adv_term(0, 2));          // new episode is unaffected
  EXPECT_DOUBLE_EQ(adv_trunc(0, 1), 1 + 0.9 * 10.0);          // bootstrapped from V(final)
  EXPECT_DOUBLE_EQ(adv_trunc(0, 0), 1 + 0.9 * (1 + 0.9 * 10.0));
}

// With λ = 1 the return equals the brute-force discounted sum of rewards up to the episode end
// plus the discounted bootstrap value — for several envs, objectives and random boundaries.
TEST(Gae, LambdaOneEqualsBruteForceDiscountedSum) {
  Rng rng(7);
  const Index H = 17, N = 3, K = 2;
  const double gamma = 0.93;
  RolloutBuffer<double> buf({H, N, 0, 0, 0, K, 0});
  for (Index c = 0; c < buf.size(); ++c) {
    for (Index k = 0; k < K; ++k) {
      buf.rewards(k, c) = rng.normal();
      buf.values(k, c) = rng.normal();
      buf.final_values(k, c) = rng.normal();
    }
    const double u = rng.uniform();
    buf.terminated[c] = u < 0.1;
    buf.truncated[c] = u >= 0.1 && u < 0.2;
  }
  for (Index e = 0; e < N; ++e)
    for (Index k = 0; k < K; ++k) buf.bootstrap_values(k, e) = rng.normal();
  compute_gae(buf, {gamma, 1.0});
  for (Index k = 0; k < K; ++k)
    for (Index e = 0; e < N; ++e)
      for (Index t = 0; t < H; ++t) {
        double ret = 0, disc = 1;
        for (Index u = t;; ++u) {
          const Index c = buf.column(u, e);
          ret += disc * buf.rewards(k, c);
          disc *= gamma;
          if (buf.terminated[c]) break;
          if (buf.truncated[c]) { ret += disc * buf.final_values(k, c); break; }
          if (u == H - 1) { ret += disc * buf.bootstrap_values(k, e); break; }
        }
        EXPECT_NEAR(buf.returns(k, buf.column(t, e)), ret, 1e-12) << "k " << k << " env " << e << " t " << t;
      }
}

// With λ = 0, A_t is the one-step TD error.
TEST(Gae, LambdaZeroIsTdError) {
  const MatrixXd r = row({1, -2}), v = row({0.3, 0.7}), fin = MatrixXd::Zero(1, 2);
  MatrixXd boot(1, 1);
  boot << -1.0;
  std::vector<std::uint8_t> none(2, 0);
  MatrixXd adv, ret;
  compute_gae<double>({0.99, 0.0}, 1, r, v, none, none, fin, boot, adv, ret);
  EXPECT_DOUBLE_EQ(adv(0, 0), 1 + 0.99 * 0.7 - 0.3);
  EXPECT_DOUBLE_EQ(adv(0, 1), -2 + 0.99 * -1.0 - 0.7);
}

TEST(Gae, RejectsBadInput) {
  MatrixXd r = row({1, std::nan("")}), v = row({0, 0}), fin = MatrixXd::Zero(1, 2), boot = MatrixXd::Zero(1, 1);
  std::vector<std::uint8_t> none(2, 0);
  MatrixXd adv, ret;
  EXPECT_THROW(compute_gae<double>({}, 1, r, v, none, none, fin, boot, adv, ret), Error);
  r(0, 1) = 0;
  EXPECT_THROW(compute_gae<double>({}, 1, r, row({0}), none, none, fin, boot, adv, ret), Error);
  EXPECT_THROW(compute_gae<double>({}, 3, r, v, none, none, fin, boot, adv, ret), Error);
  EXPECT_NO_THROW(compute_gae<double>({}, 1, r, v, none, none, fin, boot, adv, ret));
}

// record_policy_step writes step t into columns t·N … t·N + N − 1 of every per-sample array and
// touches nothing else.
TEST(RolloutBuffer, RecordPolicyStepFillsExactlyItsColumns) {
  const Index H = 3, N = 2;
  RolloutBuffer<float> buf({H, N, 4, 5, 3, 2, 0});
  const MatrixXf obs = MatrixXf::Constant(4, N, 1.f), input = MatrixXf::Constant(5, N, 2.f);
  const MatrixXf act = MatrixXf::Constant(3, N, 3.f), val = MatrixXf::Constant(2, N, 4.f);
  const RowVectorX<float> logp = RowVectorX<float>::Constant(N, 5.f);
  const std::vector<PartMask> masks{PartMask::of(BodyPart::LeftArm), PartMask::all()};
  buf.record_policy_step(1, obs, input, masks, act, logp, val);
  for (Index c = 0; c < buf.size(); ++c) {
    const bool mine = c >= N && c < 2 * N;
    EXPECT_EQ(buf.obs(0, c), mine ? 1.f : 0.f) << c;
    EXPECT_EQ(buf.policy_input(4, c), mine ? 2.f : 0.f) << c;
    EXPECT_EQ(buf.actions(2, c), mine ? 3.f : 0.f) << c;
    EXPECT_EQ(buf.values(1, c), mine ? 4.f : 0.f) << c;
    EXPECT_EQ(buf.log_probs(c), mine ? 5.f : 0.f) << c;
    EXPECT_EQ(buf.masks[static_cast<std::size_t>(c)], mine ? masks[static_cast<std::size_t>(c - N)] : PartMask::none())
        << c;
  }
  const std::vector<PartMask> one_mask{PartMask::all()};
  EXPECT_THROW(buf.record_policy_step(0, obs, input, one_mask, act, logp, val), Error);
}

TEST(RolloutBuffer, LayoutAndMinibatches) {
  RolloutBuffer<float> buf({4, 3, 5, 7, 2, 1, 9});
  EXPECT_EQ(buf.size(), 12);
  EXPECT_EQ(buf.obs.rows(), 5);
  EXPECT_EQ(buf.policy_input.rows(), 7);
  EXPECT_EQ(buf.amp_windows.cols(), 12);
  EXPECT_EQ(buf.column(2, 1), 7);
  EXPECT_EQ(buf.bootstrap_values.cols(), 3);
  Rng rng(3);
  const auto mbs = minibatch_indices(buf.size(), 5, rng);
  ASSERT_EQ(mbs.size(), 5u);
  std::set<Index> seen;
  std::size_t total = 0;
  for (const auto& mb : mbs) {
    EXPECT_GE(mb.size(), 2u);
    EXPECT_LE(mb.size(), 3u);
    total += mb.size();
    seen.insert(mb.begin(), mb.end());
  }
  EXPECT_EQ(total, 12u);
  EXPECT_EQ(seen.size(), 12u);  // a permutation: every sample exactly once
  Rng a(11), b(11);
  EXPECT_EQ(minibatch_indices(100, 4, a), minibatch_indices(100, 4, b));
  EXPECT_THROW(minibatch_indices(3, 4, rng), Error);
  buf.obs.setRandom();
  MatrixXf g;
  gather_columns(buf.obs, {4, 0}, g);
  EXPECT_EQ(g.col(0), buf.obs.col(4));
  EXPECT_EQ(g.col(1), buf.obs.col(0));
}

TEST(ReplayBuffer, FifoOverwriteAndSampling) {
  ReplayBuffer<float> rb(2, 3);
  EXPECT_TRUE(rb.empty());
  MatrixXf out;
  Rng rng(1);
  EXPECT_THROW(rb.sample(1, rng, out), Error);
  MatrixXf x(2, 4);
  x << 0, 1, 2, 3, 10, 11, 12, 13;
  rb.push(x);  // column 0 is overwritten by column 3
  EXPECT_EQ(rb.size(), 3);
  rb.sample(300, rng, out);
  std::set<float> firsts;
  for (Index j = 0; j < out.cols(); ++j) {
    firsts.insert(out(0, j));
    EXPECT_EQ(out(1, j), out(0, j) + 10);
  }
  EXPECT_EQ(firsts, (std::set<float>{1, 2, 3}));
  MatrixXf bad = MatrixXf::Constant(2, 1, std::nanf(""));
  EXPECT_THROW(rb.push(bad), Error);
  EXPECT_THROW(rb.push(MatrixXf::Zero(3, 1)), Error);
}

// Minibatch gathers and replay samples large enough to be copied on the pool: each column is
// the source column it names (the draws stay in the stream's order), with and without a pool; an
// out-of-range index throws before anything is copied.
TEST(ReplayBuffer, GathersAndSamplesOnThePoolEqualTheSerialOnes) {
  const Index d = 200, n = 1500;
  ASSERT_GE(double(d) * double(n), maskadapt::nn::kMinSplitElements);
  Rng fill(3);
  MatrixXf src(d, n);
  for (Index i = 0; i < src.size(); ++i) src.data()[i] = static_cast<float>(fill.normal());
  Rng pick(4);
  const std::vector<Index> idx = minibatch_indices(n, 1, pick)[0];
  ReplayBuffer<float> rb(d, n);
  rb.push(src);
  MatrixXf serial_g, serial_s;
  Rng r1(5);
  gather_columns(src, idx, serial_g);
  rb.sample(n, r1, serial_s);
  for (Index j = 0; j < n; ++j) ASSERT_EQ(serial_g.col(j), src.col(idx[static_cast<std::size_t>(j)])) << j;
  ThreadPool pool(2);
  maskadapt::nn::ScopedPool scope(&pool);
  MatrixXf g, s;
  Rng r2(5);
  gather_columns(src, idx, g);
  rb.sample(n, r2, s);
  EXPECT_EQ(g, serial_g);
  EXPECT_EQ(s, serial_s);
  EXPECT_EQ(r1.uniform_int(1000000), r2.uniform_int(1000000));  // the same number of draws
  std::vector<Index> out_of_range = idx;
  out_of_range.back() = n;
  EXPECT_THROW(gather_columns(src, out_of_range, g), Error);
}
