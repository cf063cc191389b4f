#pragma once
/// \file collective.hpp
/// The operations a trainer needs to run as one of K cooperating processes ("ranks"), behind an
/// interface that knows nothing of MPI. `SingleProcess` is rank 0 of 1: every operation is the
/// identity, so a trainer written against `Collective` runs unchanged (and, on its K = 1 path,
/// bit-identically to code that never heard of ranks). `maskadapt/mpi/collective.hpp`
/// (target maskadapt::mpi, option MASKADAPT_WITH_MPI) implements it over MPI.
///
/// Determinism: all_reduce_sum forms every element's sum in rank order, ((x₀ + x₁) + x₂) + …,
/// on every rank, so all ranks get the same bits, and two runs of the same layout (same K, same
/// inputs) get the same bits. A tree- or ring-ordered MPI_Allreduce gives neither promise.
/// docs/distributed.md describes how the trainer uses these operations and what they cost.
#include <maskadapt/core/error.hpp>

#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace maskadapt {

using Bytes = std::vector<std::uint8_t>;

/// One process of a K-process job (the interface; see SingleProcess and mpi::MpiCollective).
/// Every operation except rank/size/abort is collective: all ranks call it, in the same order,
/// with buffers of the sizes the operation names.
class Collective {
 public:
  virtual ~Collective() = default;
  /// This process's index in [0, size()).
  virtual int rank() const = 0;
  /// Number of processes K.
  virtual int size() const = 0;

  /// In place on every rank: data[i] ← Σ_r data_r[i], summed in rank order (see the file comment).
  /// `data` has the same length on every rank.
  virtual void all_reduce_sum(std::span<float> data) = 0;
  virtual void all_reduce_sum(std::span<double> data) = 0;
  /// Every rank's `mine` (any lengths), on every rank, in rank order.
  virtual std::vector<Bytes> all_gather(std::span<const std::uint8_t> mine) = 0;
  /// On `root`: every rank's `mine` in rank order; elsewhere: empty.
  virtual std::vector<Bytes> gather(std::span<const std::uint8_t> mine, int root) = 0;
  /// `data` on every rank becomes root's `data` (any length).
  virtual void broadcast(Bytes& data, int root) = 0;
  virtual void barrier() = 0;
  /// Stops the whole job: prints `message` (which should name this rank) to stderr and ends
  /// every rank with exit code `code`. Not collective: any one rank may call it.
  [[noreturn]] virtual void abort(const std::string& message, int code = 1) = 0;

  bool is_root() const { return rank() == 0; }
  bool distributed() const { return size() > 1; }
};

/// Rank 0 of 1: the reductions and gathers are the identity; abort throws maskadapt::Error
/// (a library never ends the process itself).
class SingleProcess final : public Collective {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void all_reduce_sum(std::span<float>) override {}
  void all_reduce_sum(std::span<double>) override {}
  std::vector<Bytes> all_gather(std::span<const std::uint8_t> mine) override { return {Bytes(mine.begin(), mine.end())}; }
  std::vector<Bytes> gather(std::span<const std::uint8_t> mine, int) override { return {Bytes(mine.begin(), mine.end())}; }
  void broadcast(Bytes&, int) override {}
  void barrier() override {}
  [[noreturn]] void abort(const std::string& message, int = 1) override {
    throw Error(message, {{}, std::nullopt, "Collective::abort"});
  }
};

/// The single-process collective (a process-wide instance).
inline SingleProcess& single_process() {
  static SingleProcess s;
  return s;
}

/// The collective of this process: single_process() unless a launcher-aware main installed
/// another (examples/maskadapt/main.cpp installs an mpi::MpiCollective under mpirun).
inline Collective*& world_slot() {
  static Collective* w = &single_process();
  return w;
}
inline Collective& world() { return *world_slot(); }

// ---- helpers built on the interface ------------------------------------------------------------

/// Bytes of a trivially copyable array.
template <class T>
Bytes to_bytes(std::span<const T> v) {
  Bytes b(v.size() * sizeof(T));
  if (!b.empty()) std::memcpy(b.data(), v.data(), b.size());
  return b;
}

/// A trivially copyable array back from bytes (throws if the size is not a multiple of T's).
template <class T>
std::vector<T> from_bytes(const Bytes& b, const char* what = "Collective bytes") {
  require(b.size() % sizeof(T) == 0, "received " + std::to_string(b.size()) + " bytes, not a whole number of elements",
          {{}, std::nullopt, what});
  std::vector<T> v(b.size() / sizeof(T));
  if (!b.empty()) std::memcpy(v.data(), b.data(), b.size());
  return v;
}

/// Every rank's `mine` concatenated in rank order, on every rank.
template <class T>
std::vector<T> all_gather_concat(Collective& c, std::span<const T> mine) {
  const Bytes b = to_bytes(mine);
  std::vector<T> out;
  for (const Bytes& part : c.all_gather(b)) {
    const auto v = from_bytes<T>(part);
    out.insert(out.end(), v.begin(), v.end());
  }
  return out;
}

/// Sum of one value over ranks (rank order).
inline double all_reduce_sum(Collective& c, double v) {
  c.all_reduce_sum(std::span<double>(&v, 1));
  return v;
}

/// Whether `flag` is true on any rank (a collective OR; e.g. "some rank wants to stop").
inline bool any_rank(Collective& c, bool flag) { return all_reduce_sum(c, flag ? 1.0 : 0.0) > 0; }

/// Throws unless every rank passes the same `value` (e.g. a network size, an env count):
/// "<what> differs between ranks: rank 0 has 16, rank 1 has 8".
inline void require_same_on_all_ranks(Collective& c, std::int64_t value, const std::string& what) {
  const auto all = all_gather_concat<std::int64_t>(c, std::span<const std::int64_t>(&value, 1));
  for (std::size_t r = 1; r < all.size(); ++r)
    require(all[r] == all[0], what + " differs between ranks: rank 0 has " + std::to_string(all[0]) + ", rank " +
                                  std::to_string(r) + " has " + std::to_string(all[r]),
            {{}, std::nullopt, what});
}

}  // namespace maskadapt
