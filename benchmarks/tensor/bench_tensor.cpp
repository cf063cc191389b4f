// xtensor where N-d data lives (issue 43): each place that moved to xtensor against the code it
// replaced, in the same run (docs/benchmarks.md, "xtensor"). Every pair is checked to give the
// same numbers before it is timed.
//
//   BM_NpzFortranMember/variant:0  npz::parse of a Fortran-ordered (2000 × 156) float64 member:
//                                  the library, whose reorder is an index loop
//   BM_NpzFortranMember/variant:1  the same bytes parsed without the reorder, then the xtensor
//                                  form that was tried and reverted: a column-major view
//                                  assigned to a row-major one
//   BM_NpzFortranMember/variant:2  … then the other xtensor form: transpose of the reversed shape
//   BM_NpzFortranMember/variant:3  the parse alone, no reorder (the floor all three share)
//   BM_AmassFromArchive/xtensor:1  npz::amass_from_archive: checks on views of the parsed
//                                  members, one copy into (frames × ·) tensors
//   BM_AmassFromArchive/xtensor:0  as before: Eigen copies of the members, checked, transposed
//   BM_PrimitiveDataset/xtensor:1  tracking::make_primitive_dataset: windows written through
//                                  (N × H × D) views into the preallocated columns
//   BM_PrimitiveDataset/xtensor:0  as before: one matrix per window, copied column by column
#include "../bench_main.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/npz.hpp>
#include <maskadapt/tracking/primitive_dataset.hpp>

#include <xtensor/xmanipulation.hpp>
#include <xtensor/xnoalias.hpp>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace {

using namespace maskadapt;
using namespace maskadapt::tracking;

constexpr std::size_t kFrames = 2000, kCols = 156;  // a 67-s SMPL-H clip at 30 Hz

double value_at(std::size_t t, std::size_t c) { return std::sin(0.01 * double(t) + 0.1 * double(c)); }

/// A stored .npz with one (kFrames × kCols) float64 member "poses": its values laid out in
/// Fortran (column-major) or C order, and its header's fortran_order flag set as asked.
std::string poses_npz(bool fortran_bytes, bool fortran_flag) {
  npz::Array p;
  p.descr = "<f8";
  p.shape = {kFrames, kCols};
  p.values.resize(kFrames * kCols);
  for (std::size_t t = 0; t < kFrames; ++t)
    for (std::size_t c = 0; c < kCols; ++c) p.values[fortran_bytes ? t + kFrames * c : t * kCols + c] = value_at(t, c);
  npz::Archive a;
  a["poses"] = std::move(p);
  std::string bytes = npz::serialise(a);  // the writer stores the values in the order given
  if (fortran_flag) {
    // the one member is stored at offset 0: flip its header's flag (same length) and put the
    // new CRC-32 into the local header (offset 14) and the central directory entry (offset 16)
    const std::size_t h = bytes.find("'fortran_order': False");
    bytes.replace(h, 22, "'fortran_order': True ");
    auto u16 = [&](std::size_t at) {
      return std::size_t(std::uint8_t(bytes[at])) | std::size_t(std::uint8_t(bytes[at + 1])) << 8;
    };
    const std::size_t blob_at = 30 + u16(26), blob_len = u16(18) | u16(20) << 16;
    const auto crc = static_cast<std::uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(bytes.data() + blob_at), static_cast<uInt>(blob_len)));
    const std::size_t cd = bytes.find(std::string("PK\x01\x02", 4));
    for (const std::size_t at : {std::size_t{14}, cd + 16})
      for (int k = 0; k < 4; ++k) bytes[at + k] = static_cast<char>((crc >> (8 * k)) & 0xff);
  }
  return bytes;
}

/// The reorder as an xtensor column-major view assigned to a row-major buffer (tried, reverted).
void reorder_xtensor_layouts(std::vector<double>& values, const std::vector<std::size_t>& shape) {
  const auto file_order =
      xt::adapt<xt::layout_type::column_major>(values.data(), values.size(), xt::no_ownership(), shape);
  std::vector<double> c(values.size());
  auto c_order = xt::adapt<xt::layout_type::row_major>(c.data(), c.size(), xt::no_ownership(), shape);
  xt::noalias(c_order) = file_order;
  values.swap(c);
}

/// The reorder as the transpose of the file order read row-major with the reversed shape (tried, reverted).
void reorder_xtensor_transpose(std::vector<double>& values, const std::vector<std::size_t>& shape) {
  const std::vector<std::size_t> reversed(shape.rbegin(), shape.rend());
  const auto file_order = xt::adapt(values.data(), values.size(), xt::no_ownership(), reversed);
  std::vector<double> c(values.size());
  auto c_order = xt::adapt(c.data(), c.size(), xt::no_ownership(), shape);
  xt::noalias(c_order) = xt::transpose(file_order);
  values.swap(c);
}

void BM_NpzFortranMember(benchmark::State& state) {
  const auto variant = state.range(0);
  const std::string fortran = poses_npz(true, true), unflagged = poses_npz(true, false);
  const std::vector<double> c_order = npz::parse(poses_npz(false, false)).at("poses").values;
  npz::Array x1 = npz::parse(unflagged).at("poses"), x2 = x1;
  reorder_xtensor_layouts(x1.values, x1.shape);
  reorder_xtensor_transpose(x2.values, x2.shape);
  if (npz::parse(fortran).at("poses").values != c_order || x1.values != c_order || x2.values != c_order) {
    state.SkipWithError("the reorders disagree");
    return;
  }
  for (auto _ : state) {
    if (variant == 0) {
      npz::Archive a = npz::parse(fortran);
      benchmark::DoNotOptimize(a.at("poses").values.data());
    } else {
      npz::Archive a = npz::parse(unflagged);
      npz::Array& p = a.at("poses");
      if (variant == 1) reorder_xtensor_layouts(p.values, p.shape);
      if (variant == 2) reorder_xtensor_transpose(p.values, p.shape);
      benchmark::DoNotOptimize(p.values.data());
    }
  }
}
BENCHMARK(BM_NpzFortranMember)->DenseRange(0, 3)->ArgNames({"variant"})->Unit(benchmark::kMicrosecond);

/// AMASS tensors as the reader built them before xtensor: Eigen copies, transposed to columns.
struct AmassEigen {
  MatrixXd poses, trans;  // (3·joints × frames), (3 × frames)
};
AmassEigen amass_eigen(const npz::Archive& ar) {
  const MatrixXd poses = npz::as_matrix(npz::member(ar, "poses"), "poses");  // (N × 3J)
  const MatrixXd trans = npz::as_matrix(npz::member(ar, "trans"), "trans");  // (N × 3)
  require(poses.cols() >= 66 && poses.cols() % 3 == 0 && trans.cols() == 3 && trans.rows() == poses.rows(), "shapes");
  require_finite(poses, "poses");
  require_finite(trans, "trans");
  return {poses.transpose(), trans.transpose()};
}

void BM_AmassFromArchive(benchmark::State& state) {
  const bool lib = state.range(0) == 1;
  npz::Archive a;
  a["poses"] = npz::parse(poses_npz(false, false)).at("poses");
  Tensor<double, 2> trans = Tensor<double, 2>::from_shape({kFrames, 3});
  for (std::size_t t = 0; t < kFrames; ++t)
    for (std::size_t c = 0; c < 3; ++c) trans(t, c) = value_at(t, c + 7);
  a["trans"] = npz::tensor(trans);
  a["mocap_framerate"] = npz::scalar(30.0);
  const npz::AmassMotion m = npz::amass_from_archive(a);
  const AmassEigen e = amass_eigen(a);
  for (std::size_t t = 0; t < kFrames; t += 97)
    for (std::size_t c = 0; c < kCols; ++c)
      if (m.poses(t, c) != e.poses(Index(c), Index(t)) || m.trans(t, c % 3) != e.trans(Index(c % 3), Index(t))) {
        state.SkipWithError("the two readers disagree");
        return;
      }
  for (auto _ : state) {
    if (lib) {
      const npz::AmassMotion x = npz::amass_from_archive(a);
      benchmark::DoNotOptimize(x.poses.data());
    } else {
      const AmassEigen x = amass_eigen(a);
      benchmark::DoNotOptimize(x.poses.data());
    }
  }
}
BENCHMARK(BM_AmassFromArchive)->Arg(1)->Arg(0)->ArgNames({"xtensor"})->Unit(benchmark::kMicrosecond);

/// n frames of the humanoid walking in a turning line and swinging its arms and legs.
Trajectory bench_motion(Index n, double phase) {
  const Skeleton& skel = humanoid_skeleton();
  Trajectory t = Trajectory::zeros(skel, n);
  double x = 0, y = 0, yaw = 0.3;
  for (Index i = 0; i < n; ++i) {
    const double w = 2.0 * 3.14159265 * 1.1 * double(i) / 30.0 + phase;
    yaw += 0.2 / 30.0;
    x += std::cos(yaw) / 30.0;
    y += std::sin(yaw) / 30.0;
    t.root_pos.col(i) = Vec3(x, y, 0.9 + 0.02 * std::sin(2 * w));
    t.root_rot[std::size_t(i)] = Quat(Eigen::AngleAxisd(yaw, Vec3::UnitZ()));
    for (Index d = 0; d < t.q.rows(); ++d) t.q(d, i) = 0.3 * std::sin(w + 0.37 * double(d));
  }
  compute_body_positions(skel, t);
  return t;
}

/// make_primitive_dataset before the views: every window encoded into a matrix of its own, the
/// matrices' columns copied into the dataset at the end (labels left out: identical in both).
PrimitiveDataset dataset_per_window_matrices(const Skeleton& skel, const std::vector<LabelledTrajectory>& clips, Index H,
                                             Index F, Index stride) {
  PrimitiveDataset d;
  d.history_frames = H;
  d.future_frames = F;
  d.frame_dim = frame_feature_dim(skel);
  const Index D = d.frame_dim, W = H + F;
  std::vector<MatrixXf> windows;
  for (const auto& clip : clips) {
    if (clip.motion.num_frames() < W) continue;
    Trajectory world = clip.motion;
    compute_body_positions(skel, world);
    for (Index s = 0; s + W <= world.num_frames(); s += stride)
      windows.push_back(encode_frames<float>(skel, canonicalize(world.slice(s, W), 0).first));
  }
  const Index N = static_cast<Index>(windows.size());
  d.history.resize(H * D, N);
  d.future.resize(F * D, N);
  for (Index n = 0; n < N; ++n) {
    const MatrixXf& w = windows[static_cast<std::size_t>(n)];
    d.history.col(n) = Eigen::Map<const VectorXf>(w.data(), H * D);
    d.future.col(n) = Eigen::Map<const VectorXf>(w.data() + H * D, F * D);
  }
  return d;
}

void BM_PrimitiveDataset(benchmark::State& state) {
  const bool lib = state.range(0) == 1;
  const Skeleton& skel = humanoid_skeleton();
  std::vector<LabelledTrajectory> clips;
  for (int c = 0; c < 4; ++c) clips.push_back({"clip" + std::to_string(c), {"walk"}, bench_motion(300, 0.7 * c), {}});
  const Index H = 5, F = 15, stride = 2;  // the generator's windows; 141 per clip
  const PrimitiveDataset a = make_primitive_dataset(skel, clips, H, F, stride);
  const PrimitiveDataset b = dataset_per_window_matrices(skel, clips, H, F, stride);
  if (a.history != b.history || a.future != b.future) {
    state.SkipWithError("the two builders disagree");
    return;
  }
  for (auto _ : state) {
    const PrimitiveDataset d =
        lib ? make_primitive_dataset(skel, clips, H, F, stride) : dataset_per_window_matrices(skel, clips, H, F, stride);
    benchmark::DoNotOptimize(d.history.data());
  }
  state.counters["windows"] = double(a.size());
}
BENCHMARK(BM_PrimitiveDataset)->Arg(1)->Arg(0)->ArgNames({"xtensor"})->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) { return maskadapt::bench::run_benchmarks(argc, argv); }
