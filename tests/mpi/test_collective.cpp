// The MPI collective against closed forms, under mpirun -np 2 (any K works): the ordered
// all-reduce gives every rank the same bits, equal to the rank-order sum; gathers and broadcasts
// carry byte blobs of different lengths per rank.
#include <maskadapt/mpi/collective.hpp>

#include <gtest/gtest.h>

#include <cstring>
#include <numeric>

using namespace maskadapt;

namespace {

// What rank r contributes at element i: values whose float sum depends on the order.
template <class T>
T contribution(int r, std::size_t i) {
  return static_cast<T>((r + 1) * 0.1) * static_cast<T>(i + 1) + static_cast<T>(r == 0 ? 1e7 : -1e7) / static_cast<T>(i + 1);
}

template <class T>
void expect_ordered_sum(std::size_t n) {
  Collective& c = world();
  std::vector<T> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = contribution<T>(c.rank(), i);
  c.all_reduce_sum(std::span<T>(v));
  for (std::size_t i = 0; i < n; ++i) {
    T expect = contribution<T>(0, i);
    for (int r = 1; r < c.size(); ++r) expect += contribution<T>(r, i);  // rank order
    ASSERT_EQ(0, std::memcmp(&expect, &v[i], sizeof(T))) << "element " << i << " of " << n << ": " << v[i] << " vs " << expect;
  }
  // and every rank holds the same bits
  const auto all = all_gather_concat<T>(c, std::span<const T>(v));
  for (int r = 1; r < c.size(); ++r)
    EXPECT_EQ(0, std::memcmp(all.data(), all.data() + static_cast<std::size_t>(r) * n, n * sizeof(T))) << "rank " << r;
}

}  // namespace

TEST(Collective, RunsOnMoreThanOneRank) {
  EXPECT_GE(world().size(), 2) << "run under mpirun -np 2";
  EXPECT_TRUE(world().distributed());
}

TEST(Collective, AllReduceSumIsTheRankOrderSumOnEveryRankFloat) {
  for (std::size_t n : {0, 1, 2, 3, 7, 1000, 4099}) expect_ordered_sum<float>(n);
}

TEST(Collective, AllReduceSumIsTheRankOrderSumOnEveryRankDouble) {
  for (std::size_t n : {0, 1, 5, 1001}) expect_ordered_sum<double>(n);
}

TEST(Collective, ClosedFormSums) {
  Collective& c = world();
  const int K = c.size(), r = c.rank();
  std::vector<double> v(100);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<double>(i) * (r + 1);
  c.all_reduce_sum(std::span<double>(v));
  for (std::size_t i = 0; i < v.size(); ++i) EXPECT_EQ(v[i], static_cast<double>(i) * K * (K + 1) / 2);
  EXPECT_EQ(all_reduce_sum(c, 1.0), K);
  EXPECT_TRUE(any_rank(c, r == K - 1));
  EXPECT_FALSE(any_rank(c, false));
}

TEST(Collective, GathersAndBroadcastsBlobsOfAnyLength) {
  Collective& c = world();
  const int K = c.size(), r = c.rank();
  const Bytes mine(static_cast<std::size_t>(r + 1) * 3, static_cast<std::uint8_t>(r + 10));
  const auto all = c.all_gather(mine);
  ASSERT_EQ(static_cast<int>(all.size()), K);
  for (int q = 0; q < K; ++q) EXPECT_EQ(all[static_cast<std::size_t>(q)], Bytes(static_cast<std::size_t>(q + 1) * 3, static_cast<std::uint8_t>(q + 10)));
  const auto at_root = c.gather(mine, 0);
  if (r == 0) EXPECT_EQ(at_root, all);
  else EXPECT_TRUE(at_root.empty());
  Bytes b = r == K - 1 ? Bytes{1, 2, 3, 4, 5} : Bytes{};
  c.broadcast(b, K - 1);
  EXPECT_EQ(b, (Bytes{1, 2, 3, 4, 5}));
  c.barrier();
}

TEST(Collective, RequireSameOnAllRanksNamesTheRank) {
  Collective& c = world();
  EXPECT_NO_THROW(require_same_on_all_ranks(c, 7, "x"));
  try {
    require_same_on_all_ranks(c, c.rank(), "envs per rank");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("envs per rank differs between ranks: rank 0 has 0, rank 1 has 1"), std::string::npos)
        << e.what();
  }
}
