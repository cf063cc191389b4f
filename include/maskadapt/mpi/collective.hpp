#pragma once
/// \file mpi/collective.hpp
/// maskadapt::Collective over MPI (target maskadapt::mpi; the only folder that includes <mpi.h>).
///
///   maskadapt::mpi::Session session(&argc, &argv);   // MPI_Init … MPI_Finalize (RAII)
///   maskadapt::mpi::MpiCollective world;             // MPI_COMM_WORLD (a duplicate)
///
/// all_reduce_sum is deterministic and bandwidth-optimal at once: a reduce-scatter done by hand
/// (MPI_Alltoallv: rank j receives every rank's j-th slice and sums the K slices in rank order)
/// followed by an MPI_Allgatherv of the summed slices. Each rank sends and receives
/// 2·(K−1)/K of the buffer, as a ring all-reduce does, and every element's sum is
/// ((x₀ + x₁) + x₂) + …, whatever the network or the MPI library's algorithm choice.
#include <maskadapt/core/collective.hpp>

#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

namespace maskadapt::mpi {

/// Whether this process was started by an MPI launcher (mpirun / mpiexec / srun): then
/// MPI_Init joins the job. Without one, a program can stay a plain single process and never
/// touch MPI (OpenMPI's "singleton" start forks a daemon, which some containers refuse).
inline bool launched_by_mpi() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(v) != nullptr) return true;
  return false;
}

/// MPI_Init in the constructor, MPI_Finalize in the destructor; nothing at all when `enable`
/// is false (then `active()` is false and the program uses maskadapt::single_process()).
class Session {
 public:
  Session(int* argc, char*** argv, bool enable = launched_by_mpi()) {
    if (!enable) return;
    int already = 0;
    MPI_Initialized(&already);
    if (!already) {
      MPI_Init(argc, argv);
      owns_ = true;
    }
    active_ = true;
  }
  ~Session() {
    if (!owns_) return;
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Finalize();
  }
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  bool active() const { return active_; }

 private:
  bool owns_ = false, active_ = false;
};

/// Collective over an MPI communicator (default: a duplicate of MPI_COMM_WORLD, so the
/// library's messages never mix with the caller's). MPI must be initialised (Session).
class MpiCollective final : public Collective {
 public:
  explicit MpiCollective(MPI_Comm comm = MPI_COMM_WORLD) {
    MPI_Comm_dup(comm, &comm_);
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
  }
  ~MpiCollective() override {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Comm_free(&comm_);
  }
  MpiCollective(const MpiCollective&) = delete;
  MpiCollective& operator=(const MpiCollective&) = delete;

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  MPI_Comm comm() const { return comm_; }

  void all_reduce_sum(std::span<float> data) override { ordered_all_reduce(data, MPI_FLOAT); }
  void all_reduce_sum(std::span<double> data) override { ordered_all_reduce(data, MPI_DOUBLE); }

  std::vector<Bytes> all_gather(std::span<const std::uint8_t> mine) override {
    std::vector<int> counts(static_cast<std::size_t>(size_)), displs;
    const int n = checked_int(mine.size());
    MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
    Bytes all(total(counts, displs));
    MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, comm_);
    return split(all, counts, displs);
  }

  std::vector<Bytes> gather(std::span<const std::uint8_t> mine, int root) override {
    std::vector<int> counts(static_cast<std::size_t>(size_)), displs;
    const int n = checked_int(mine.size());
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, root, comm_);
    Bytes all;
    if (rank_ == root) all.resize(total(counts, displs));
    MPI_Gatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, root, comm_);
    if (rank_ != root) return {};
    return split(all, counts, displs);
  }

  void broadcast(Bytes& data, int root) override {
    long long n = static_cast<long long>(data.size());
    MPI_Bcast(&n, 1, MPI_LONG_LONG, root, comm_);
    data.resize(static_cast<std::size_t>(n));
    checked_int(data.size());
    MPI_Bcast(data.data(), static_cast<int>(n), MPI_BYTE, root, comm_);
  }

  void barrier() override { MPI_Barrier(comm_); }

  [[noreturn]] void abort(const std::string& message, int code = 1) override {
    std::cerr << message << std::endl;
    std::fflush(stderr);
    MPI_Abort(comm_, code);
    std::_Exit(code);  // (MPI_Abort does not return)
  }

 private:
  static int checked_int(std::size_t n) {
    require(n <= static_cast<std::size_t>(INT_MAX), "message of " + std::to_string(n) + " elements exceeds MPI's int count",
            {{}, std::nullopt, "MpiCollective"});
    return static_cast<int>(n);
  }
  static std::size_t total(const std::vector<int>& counts, std::vector<int>& displs) {
    displs.assign(counts.size(), 0);
    std::size_t t = 0;
    for (std::size_t r = 0; r < counts.size(); ++r) {
      displs[r] = checked_int(t);
      t += static_cast<std::size_t>(counts[r]);
    }
    checked_int(t);
    return t;
  }
  static std::vector<Bytes> split(const Bytes& all, const std::vector<int>& counts, const std::vector<int>& displs) {
    std::vector<Bytes> out(counts.size());
    for (std::size_t r = 0; r < counts.size(); ++r)
      out[r].assign(all.begin() + displs[r], all.begin() + displs[r] + counts[r]);
    return out;
  }

  /// Slice j of an n-element buffer: [n·j/K, n·(j+1)/K).
  std::size_t slice_begin(std::size_t n, int j) const {
    return n * static_cast<std::size_t>(j) / static_cast<std::size_t>(size_);
  }

  template <class T>
  void ordered_all_reduce(std::span<T> data, MPI_Datatype type) {
    const std::size_t n = data.size();
    if (size_ == 1 || n == 0) return;
    checked_int(n);
    const auto K = static_cast<std::size_t>(size_);
    // 1. reduce-scatter: rank j receives slice j of every rank's buffer (K pieces, rank order)
    std::vector<int> send_counts(K), send_displs(K), recv_counts(K), recv_displs(K);
    for (std::size_t j = 0; j < K; ++j) {
      send_displs[j] = static_cast<int>(slice_begin(n, static_cast<int>(j)));
      send_counts[j] = static_cast<int>(slice_begin(n, static_cast<int>(j) + 1)) - send_displs[j];
    }
    const std::size_t lo = slice_begin(n, rank_), len = slice_begin(n, rank_ + 1) - lo;
    for (std::size_t r = 0; r < K; ++r) {
      recv_counts[r] = static_cast<int>(len);
      recv_displs[r] = static_cast<int>(r * len);
    }
    pieces_<T>().resize(K * len);
    auto& pieces = pieces_<T>();
    MPI_Alltoallv(data.data(), send_counts.data(), send_displs.data(), type, pieces.data(), recv_counts.data(),
                  recv_displs.data(), type, comm_);
    // 2. my slice summed in rank order: ((p₀ + p₁) + p₂) + …
    for (std::size_t i = 0; i < len; ++i) {
      T s = pieces[i];
      for (std::size_t r = 1; r < K; ++r) s += pieces[r * len + i];
      pieces[i] = s;
    }
    // 3. all-gather the summed slices back into data (in place)
    std::vector<int> counts(K), displs(K);
    for (std::size_t j = 0; j < K; ++j) {
      displs[j] = send_displs[j];
      counts[j] = send_counts[j];
    }
    MPI_Allgatherv(pieces.data(), static_cast<int>(len), type, data.data(), counts.data(), displs.data(), type, comm_);
  }

  template <class T>
  std::vector<T>& pieces_() {
    if constexpr (std::is_same_v<T, float>) return pieces_f_;
    else return pieces_d_;
  }

  MPI_Comm comm_ = MPI_COMM_NULL;
  int rank_ = 0, size_ = 1;
  std::vector<float> pieces_f_;
  std::vector<double> pieces_d_;
};

}  // namespace maskadapt::mpi
