// `maskadapt checkpoint diff A B`: section-by-section comparison of two checkpoints — which
// sections are bit-identical, and for numeric ones how many elements differ and by how much.
// Used to check a resume or a thread count by hand, and to measure how far two BLAS kernels take
// the same run apart (docs/architecture.md, "What is reproducible").
// `maskadapt checkpoint compact IN --out OUT`: the same training checkpoint without its replay
// buffer (train::drop_replay_buffer), small enough to carry a long run from one machine or
// session to the next; `train-base --resume OUT` continues it.
#include "command_registry.hpp"

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/train/base_trainer.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <set>

namespace {

struct Difference {
  std::int64_t differing = 0;
  double max_abs = 0;  ///< max |a − b| over the elements
  double max_ref = 0;  ///< max |a| over the elements (scale for max_abs)
};

template <class T>
Difference compare_values(const maskadapt::CheckpointSection& a, const maskadapt::CheckpointSection& b) {
  Difference d;
  const auto n = static_cast<std::size_t>(a.numel());
  for (std::size_t i = 0; i < n; ++i) {
    T x, y;
    std::memcpy(&x, a.data.data() + i * sizeof(T), sizeof(T));
    std::memcpy(&y, b.data.data() + i * sizeof(T), sizeof(T));
    if (std::memcmp(&x, &y, sizeof(T)) == 0) continue;
    ++d.differing;
    d.max_abs = std::max(d.max_abs, std::abs(static_cast<double>(x) - static_cast<double>(y)));
    d.max_ref = std::max(d.max_ref, std::abs(static_cast<double>(x)));
  }
  return d;
}

/// Prints the table; returns the number of sections that are not bit-identical.
int diff_checkpoints(const std::string& path_a, const std::string& path_b, bool all) {
  using namespace maskadapt;
  const Checkpoint a = load_checkpoint(path_a), b = load_checkpoint(path_b);
  std::set<std::string> names;
  for (const auto& n : a.names()) names.insert(n);
  for (const auto& n : b.names()) names.insert(n);
  int different = 0, identical = 0;
  std::cout << std::left << std::setw(34) << "section" << std::setw(9) << "dtype" << std::right << std::setw(10)
            << "elements" << std::setw(11) << "differing" << std::setw(14) << "max |a-b|" << std::setw(14) << "max |a|"
            << "\n";
  for (const auto& name : names) {
    const bool in_a = a.contains(name), in_b = b.contains(name);
    if (!in_a || !in_b) {
      ++different;
      std::cout << std::left << std::setw(34) << name << "only in " << (in_a ? path_a : path_b) << "\n";
      continue;
    }
    const auto& sa = a.section(name);
    const auto& sb = b.section(name);
    if (sa.dtype != sb.dtype || sa.shape != sb.shape) {
      ++different;
      std::cout << std::left << std::setw(34) << name << "different type or shape\n";
      continue;
    }
    if (sa.data == sb.data) {
      ++identical;
      if (all)
        std::cout << std::left << std::setw(34) << name << std::setw(9) << dtype_name(sa.dtype) << std::right
                  << std::setw(10) << sa.numel() << std::setw(11) << 0 << "\n";
      continue;
    }
    ++different;
    Difference d;
    switch (sa.dtype) {
      case DType::Float32: d = compare_values<float>(sa, sb); break;
      case DType::Float64: d = compare_values<double>(sa, sb); break;
      case DType::Int64: d = compare_values<std::int64_t>(sa, sb); break;
      case DType::Bytes: d = compare_values<std::uint8_t>(sa, sb); break;
    }
    std::cout << std::left << std::setw(34) << name << std::setw(9) << dtype_name(sa.dtype) << std::right
              << std::setw(10) << sa.numel() << std::setw(11) << d.differing << std::setw(14) << std::setprecision(4)
              << d.max_abs << std::setw(14) << d.max_ref << "\n";
  }
  std::cout << identical << " section(s) bit-identical, " << different << " differ\n";
  return different;
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  CLI::App* ck = app.add_subcommand("checkpoint", "Inspect checkpoints");
  ck->require_subcommand(1);
  struct Args {
    std::string a, b;
    bool all = false, exact = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* diff = ck->add_subcommand("diff", "Compare two checkpoints section by section (bit-identical or by how much)");
  diff->add_option("A", args->a, "first checkpoint")->required()->check(CLI::ExistingFile);
  diff->add_option("B", args->b, "second checkpoint")->required()->check(CLI::ExistingFile);
  diff->add_flag("--all", args->all, "also list the identical sections");
  diff->add_flag("--exact", args->exact, "exit with status 1 unless every section is bit-identical");
  diff->callback([args] {
    const int different = diff_checkpoints(args->a, args->b, args->all);
    if (args->exact && different > 0) throw CLI::RuntimeError(1);
  });
  CLI::App* compact = ck->add_subcommand(
      "compact", "Write a base-training checkpoint without its replay buffer (resumable, a fraction of the size)");
  compact->add_option("IN", args->a, "training checkpoint (train-base)")->required()->check(CLI::ExistingFile);
  compact->add_option("--out", args->b, "compacted checkpoint to write")->required();
  compact->callback([args] {
    using namespace maskadapt;
    Checkpoint c = load_checkpoint(args->a);
    require(c.contains("trainer/iteration") && c.contains("disc/adam"),
            "not a base-training checkpoint (no trainer/iteration or disc/adam section)", {args->a, std::nullopt, "IN"});
    const bool dropped = train::drop_replay_buffer(c);
    save_checkpoint(args->b, c);
    std::cout << "checkpoint compact: " << args->b << " at iteration " << c.get_int("trainer/iteration") << ", "
              << c.get_int("trainer/samples") << " samples"
              << (dropped ? "; replay buffer dropped" : "; it had no replay buffer") << " ("
              << std::filesystem::file_size(args->a) / 1000000.0 << " MB -> " << std::filesystem::file_size(args->b) / 1000000.0
              << " MB)\n";
  });
});

}  // namespace
