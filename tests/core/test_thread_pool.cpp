#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/thread_pool.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

using namespace maskadapt;

TEST(ThreadPool, EveryIndexRunsExactlyOnce) {
  for (std::size_t threads : {1u, 2u, 3u, 8u}) {
    ThreadPool pool(threads);
    std::vector<std::atomic<int>> hits(1001);
    pool.parallel_for(0, hits.size(), [&](std::size_t i) { hits[i]++; });
    for (auto& h : hits) ASSERT_EQ(h.load(), 1) << threads << " threads";
  }
}

TEST(ThreadPool, ASlowIndexDoesNotHoldUpTheRestOfItsHalf) {
  // Index 0 blocks until indices 8…63 have run. With the range split statically in halves,
  // 8…31 would sit behind it on the same thread (it would time out); with stealing, the other
  // thread takes them in grains of 32 / 8 = 4 once its own half is done.
  ThreadPool pool(2);
  constexpr std::size_t n = 64, first_awaited = 8;
  std::atomic<std::size_t> done{0};
  bool saw_all = false;
  pool.parallel_for(0, n, [&](std::size_t i) {
    if (i == 0) {
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
      while (done.load() < n - first_awaited && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      saw_all = done.load() >= n - first_awaited;
    } else if (i >= first_awaited) {
      done++;
    }
  });
  EXPECT_TRUE(saw_all) << "indices " << first_awaited << "…" << n - 1 << " waited behind the slow index 0";
}

TEST(ThreadPool, PerIndexStreamsGiveThreadCountIndependentResults) {
  auto run = [](std::size_t threads) {
    ThreadPool pool(threads);
    std::vector<double> out(257);
    for (int rep = 0; rep < 3; ++rep)
      pool.parallel_for(0, out.size(), [&](std::size_t i) {
        Rng r = Rng::stream(123 + rep, i);
        out[i] += r.normal();
      });
    return out;
  };
  const auto a = run(1), b = run(2), c = run(5);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, c);
}

TEST(ThreadPool, ExceptionsPropagateToCaller) {
  ThreadPool pool(3);
  EXPECT_THROW(pool.parallel_for(0, 100, [](std::size_t i) { if (i == 77) throw Error("boom"); }), Error);
  // The pool is still usable afterwards.
  std::atomic<int> n{0};
  pool.parallel_for(0, 10, [&](std::size_t) { n++; });
  EXPECT_EQ(n.load(), 10);
}

TEST(ThreadPool, NestedParallelForRunsSeriallyInsteadOfDeadlocking) {
  ThreadPool pool(2);
  std::vector<std::atomic<int>> hits(8 * 16);
  std::atomic<int> nested_in_region{0};
  EXPECT_FALSE(ThreadPool::in_parallel_region());
  pool.parallel_for(0, 8, [&](std::size_t i) {
    EXPECT_TRUE(ThreadPool::in_parallel_region());
    pool.parallel_for(0, 16, [&](std::size_t k) {
      if (ThreadPool::in_parallel_region()) nested_in_region++;
      hits[i * 16 + k]++;
    });
  });
  EXPECT_FALSE(ThreadPool::in_parallel_region());
  for (auto& h : hits) ASSERT_EQ(h.load(), 1);
  EXPECT_EQ(nested_in_region.load(), 8 * 16);
}

TEST(ThreadPool, ForEachIndexRunsInOrderWithoutAPoolAndOnceEachWithOne) {
  std::vector<std::size_t> order;
  for_each_index(nullptr, 5, [&](std::size_t i) { order.push_back(i); });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
  for_each_index(nullptr, 0, [&](std::size_t) { ADD_FAILURE() << "body called for n = 0"; });

  ThreadPool pool(2);
  std::vector<std::atomic<int>> hits(1000);
  for_each_index(&pool, hits.size(), [&](std::size_t i) { hits[i].fetch_add(1); });
  for (const auto& h : hits) EXPECT_EQ(h.load(), 1);
  for_each_index(&pool, 0, [&](std::size_t) { ADD_FAILURE() << "body called for n = 0"; });
}
