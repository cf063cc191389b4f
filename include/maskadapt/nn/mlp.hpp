#pragma once
/// \file mlp.hpp
/// Multi-layer perceptron, samples as columns: y (outputs × B) = f_L(W_L … f_1(W_1 x + b_1) … + b_L).
///
/// All parameters live in ONE flat vector (`params()`, inside a ParameterBlock together with the
/// gradients and Adam moments). Layer l (0-based, L = hidden.size() + 1 layers) occupies
///
///     [ W_l (out_l × in_l, column-major) | b_l (out_l) ]
///
/// in order, layer after layer. `weight(l)` / `bias(l)` are Eigen::Map views into that vector.
///
/// Two forward paths:
///  - `forward(x, y, workspace)`: inference; allocates nothing once `workspace` has seen a batch at
///    least this large (rollouts, one workspace per thread);
///  - `forward_train(x, cache)`: keeps the input, every pre-activation z_l and activation a_l for
///    `backward` (and for double back-propagation: see TrainCache).
///
/// Parallelism: give the workspace or cache a ThreadPool (`ws.pool = &pool`, or set one for a
/// scope with nn::ScopedPool) and every layer's product runs as fixed chunks on it
/// (nn/chunks.hpp), with bias, activation and derivative fused into each chunk. Results are bit-identical with or without a pool and for any pool size. With a
/// pool, keep OpenBLAS at one thread (`limit_blas_threads(1)`).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/rng.hpp"
#include "maskadapt/core/types.hpp"
#include "maskadapt/core/thread_pool.hpp"
#include "maskadapt/nn/activation.hpp"
#include "maskadapt/nn/chunks.hpp"
#include "maskadapt/nn/gemv.hpp"
#include "maskadapt/nn/parameter_block.hpp"

namespace maskadapt::nn {

/// Architecture of an Mlp. Layer l maps layer_inputs(l) → layer_outputs(l).
struct MlpSpec {
  Index inputs = 0;
  std::vector<Index> hidden;  ///< hidden widths, e.g. {1024, 1024, 512} (paper) or {256, 256} (cpu preset)
  Index outputs = 0;
  Activation activation = Activation::ReLU;            ///< after every hidden layer
  Activation output_activation = Activation::Identity;  ///< after the last layer

  Index num_layers() const { return static_cast<Index>(hidden.size()) + 1; }
  Index layer_inputs(Index l) const { return l == 0 ? inputs : hidden[static_cast<std::size_t>(l - 1)]; }
  Index layer_outputs(Index l) const {
    return l == num_layers() - 1 ? outputs : hidden[static_cast<std::size_t>(l)];
  }
  Activation layer_activation(Index l) const { return l == num_layers() - 1 ? output_activation : activation; }
  /// Largest hidden width (0 without hidden layers).
  Index max_hidden() const {
    Index m = 0;
    for (Index h : hidden) m = std::max(m, h);
    return m;
  }
  /// Total parameter count Σ_l out_l·(in_l + 1).
  Index num_params() const {
    Index n = 0;
    for (Index l = 0; l < num_layers(); ++l) n += layer_outputs(l) * (layer_inputs(l) + 1);
    return n;
  }
  /// Throws maskadapt::Error unless every width is positive.
  void validate() const {
    require(inputs > 0, "inputs must be positive, got " + std::to_string(inputs), {{}, std::nullopt, "MlpSpec.inputs"});
    require(outputs > 0, "outputs must be positive, got " + std::to_string(outputs), {{}, std::nullopt, "MlpSpec.outputs"});
    for (std::size_t i = 0; i < hidden.size(); ++i)
      require(hidden[i] > 0, "hidden width must be positive, got " + std::to_string(hidden[i]),
              {{}, std::nullopt, "MlpSpec.hidden[" + std::to_string(i) + "]"});
  }
  bool operator==(const MlpSpec&) const = default;
};

/// Scratch for the inference path: two ping-pong buffers (max_hidden × capacity).
/// One per thread; `Mlp::forward` grows it on first use, then never allocates again for batches
/// ≤ capacity.
template <class T>
struct InferenceWorkspace {
  MatrixX<T> a, b;            ///< (max_hidden × capacity) each
  ThreadPool* pool = nullptr;  ///< optional: run each layer's chunks on it (not owned)
  /// Pre-size for `spec` and batches up to `batch` (optional; forward does it lazily).
  void reserve(const MlpSpec& spec, Index batch) {
    const Index h = spec.max_hidden();
    if (a.rows() < h || a.cols() < batch) a.resize(std::max(a.rows(), h), std::max(a.cols(), batch));
    if (b.rows() < h || b.cols() < batch) b.resize(std::max(b.rows(), h), std::max(b.cols(), batch));
  }
};

/// What backward needs, filled by `Mlp::forward_train`. For layer l:
///   input  (inputs × B)  copy of x (= a_{-1})
///   pre[l] (out_l × B)   z_l = W_l a_{l-1} + b_l
///   post[l](out_l × B)   a_l = f_l(z_l); post.back() is the network output y
/// Double back-propagation (gradient penalty) uses pre[l] with activation_second_derivative and
/// the Mlp's weight(l).
template <class T>
struct TrainCache {
  MatrixX<T> input;
  std::vector<MatrixX<T>> pre;
  std::vector<MatrixX<T>> post;
  MatrixX<T> delta, back;  ///< backward scratch (max width × B), reused between calls
  ThreadPool* pool = nullptr;  ///< optional: run forward_train/backward chunks on it (not owned)

  Index batch() const { return input.cols(); }
  /// Input of layer l: a_{l-1} (in_l × B).
  const MatrixX<T>& layer_input(Index l) const { return l == 0 ? input : post[static_cast<std::size_t>(l - 1)]; }
  /// Network output (outputs × B).
  const MatrixX<T>& output() const { return post.back(); }
};

template <class T>
class Mlp {
 public:
  using Scalar = T;

  Mlp() = default;
  /// All parameters zero; call init().
  explicit Mlp(MlpSpec spec) : spec_(std::move(spec)) {
    spec_.validate();
    block_ = ParameterBlock<T>(spec_.num_params());
    offsets_.resize(static_cast<std::size_t>(spec_.num_layers()));
    Index off = 0;
    for (Index l = 0; l < spec_.num_layers(); ++l) {
      offsets_[static_cast<std::size_t>(l)] = off;
      off += spec_.layer_outputs(l) * (spec_.layer_inputs(l) + 1);
    }
  }
  /// Parameters drawn with init(rng).
  Mlp(MlpSpec spec, Rng& rng) : Mlp(std::move(spec)) { init(rng); }

  /// PyTorch nn.Linear default initialisation, layer by layer: W_l ~ U(±1/√in_l) (that is
  /// kaiming_uniform_(a=√5)), then b_l ~ U(±1/√in_l); draws in storage order (W column-major,
  /// then b). Gradients and Adam moments are zeroed.
  void init(Rng& rng) {
    for (Index l = 0; l < num_layers(); ++l) {
      const double bound = 1.0 / std::sqrt(static_cast<double>(spec_.layer_inputs(l)));
      auto w = weight(l);
      for (Index i = 0; i < w.size(); ++i) w.data()[i] = static_cast<T>(rng.uniform(-bound, bound));
      auto bl = bias(l);
      for (Index i = 0; i < bl.size(); ++i) bl[i] = static_cast<T>(rng.uniform(-bound, bound));
    }
    block_.grads().setZero();
    block_.reset_optimizer_state();
  }

  const MlpSpec& spec() const { return spec_; }
  Index num_layers() const { return spec_.num_layers(); }
  Index inputs() const { return spec_.inputs; }
  Index outputs() const { return spec_.outputs; }
  Index num_params() const { return block_.size(); }

  /// Flat parameters (num_params).
  Eigen::Map<VectorX<T>> params() { return block_.params(); }
  Eigen::Map<const VectorX<T>> params() const { return block_.params(); }
  /// Flat gradient accumulator (num_params), same layout as params().
  Eigen::Map<VectorX<T>> grads() { return block_.grads(); }
  Eigen::Map<const VectorX<T>> grads() const { return block_.grads(); }
  void zero_grad() { block_.zero_grad(); }
  /// [params | grads | adam_m | adam_v] — hand this to Adam and to checkpoints.
  ParameterBlock<T>& block() { return block_; }
  const ParameterBlock<T>& block() const { return block_; }

  /// Offset of W_l / b_l inside params() (and grads()).
  Index weight_offset(Index l) const { return offsets_[static_cast<std::size_t>(l)]; }
  Index bias_offset(Index l) const { return weight_offset(l) + spec_.layer_outputs(l) * spec_.layer_inputs(l); }

  /// W_l (out_l × in_l), a view into params().
  Eigen::Map<MatrixX<T>> weight(Index l) {
    return {block_.params().data() + weight_offset(l), spec_.layer_outputs(l), spec_.layer_inputs(l)};
  }
  Eigen::Map<const MatrixX<T>> weight(Index l) const {
    return {block_.params().data() + weight_offset(l), spec_.layer_outputs(l), spec_.layer_inputs(l)};
  }
  /// b_l (out_l), a view into params().
  Eigen::Map<VectorX<T>> bias(Index l) { return {block_.params().data() + bias_offset(l), spec_.layer_outputs(l)}; }
  Eigen::Map<const VectorX<T>> bias(Index l) const {
    return {block_.params().data() + bias_offset(l), spec_.layer_outputs(l)};
  }
  /// ∂L/∂W_l and ∂L/∂b_l, views into grads().
  Eigen::Map<MatrixX<T>> weight_grad(Index l) {
    return {block_.grads().data() + weight_offset(l), spec_.layer_outputs(l), spec_.layer_inputs(l)};
  }
  Eigen::Map<VectorX<T>> bias_grad(Index l) { return {block_.grads().data() + bias_offset(l), spec_.layer_outputs(l)}; }

  // ---- inference --------------------------------------------------------------------------

  /// y (outputs × B) = net(x), x (inputs × B). No allocation once `ws` holds batch B (it grows
  /// on first use). Thread-safe for distinct workspaces. `y` must not alias `x`.
  void forward(const Eigen::Ref<const MatrixX<T>>& x, Eigen::Ref<MatrixX<T>> y, InferenceWorkspace<T>& ws) const {
    const Index batch = x.cols();
    check_input(x, "forward");
    if (y.rows() != outputs() || y.cols() != batch)  // (messages are built only on failure: no allocation)
      throw Error("output must be " + std::to_string(outputs()) + "x" + std::to_string(batch) + ", got " +
                      std::to_string(y.rows()) + "x" + std::to_string(y.cols()),
                  {{}, std::nullopt, "Mlp::forward.y"});
    const Index L = num_layers();
    if (L > 1) ws.reserve(spec_, batch);
    MatrixX<T>* bufs[2] = {&ws.a, &ws.b};
    ThreadPool* pool = ws.pool ? ws.pool : default_pool();
    for (Index l = 0; l < L; ++l) {
      const Index out = spec_.layer_outputs(l), in = spec_.layer_inputs(l);
      const bool last = l == L - 1;
      if (last) {
        if (l == 0) {
          layer_forward(pool, l, x, y);
        } else {
          layer_forward(pool, l, bufs[(l - 1) & 1]->topLeftCorner(in, batch), y);
        }
      } else {
        auto z = bufs[l & 1]->topLeftCorner(out, batch);
        if (l == 0) {
          layer_forward(pool, l, x, z);
        } else {
          layer_forward(pool, l, bufs[(l - 1) & 1]->topLeftCorner(in, batch), z);
        }
      }
    }
  }

  /// Allocating convenience: returns net(x) (outputs × B).
  MatrixX<T> forward(const Eigen::Ref<const MatrixX<T>>& x) const {
    InferenceWorkspace<T> ws;
    MatrixX<T> y(outputs(), x.cols());
    forward(x, y, ws);
    return y;
  }

  // ---- training ---------------------------------------------------------------------------

  /// Forward pass that fills `cache` (see TrainCache) and returns the output (outputs × B),
  /// a reference into the cache. Reusing a cache with the same batch size allocates nothing.
  const MatrixX<T>& forward_train(const Eigen::Ref<const MatrixX<T>>& x, TrainCache<T>& cache) const {
    check_input(x, "forward_train");
    const Index batch = x.cols(), L = num_layers();
    ThreadPool* pool = cache.pool ? cache.pool : default_pool();
    cache.input.resize(x.rows(), batch);
    for_each_column_chunk(pool, x.rows(), batch, [&](Index c0, Index c1) {
      cache.input.middleCols(c0, c1 - c0) = x.middleCols(c0, c1 - c0);
    });
    cache.pre.resize(static_cast<std::size_t>(L));
    cache.post.resize(static_cast<std::size_t>(L));
    for (Index l = 0; l < L; ++l) {
      const auto i = static_cast<std::size_t>(l);
      const Index out = spec_.layer_outputs(l), in = spec_.layer_inputs(l);
      const Activation act = spec_.layer_activation(l);
      const auto w = weight(l);
      const auto b = bias(l);
      const MatrixX<T>& a = cache.layer_input(l);
      MatrixX<T>& pre = cache.pre[i];
      MatrixX<T>& post = cache.post[i];
      pre.resize(out, batch);
      post.resize(out, batch);
      // pre = W a + b, post = f(pre), block by block along the longer side of (out × B).
      for_each_block(pool, out, batch, worth_chunking(out, in, batch), [&](Index r0, Index nr, Index c0, Index nc) {
        auto z = pre.block(r0, c0, nr, nc);
        z.noalias() = w.middleRows(r0, nr) * a.middleCols(c0, nc);
        z.colwise() += b.segment(r0, nr);
        apply_activation<T>(act, z, post.block(r0, c0, nr, nc));
      });
    }
    return cache.post.back();
  }

  /// Back-propagates dy = ∂L/∂y (outputs × B) through the pass recorded in `cache`:
  /// ADDS ∂L/∂θ into `grad` (num_params, layout of params(); usually grads()) and, when `dx` is
  /// given, writes ∂L/∂x (inputs × B) into it (resized). Uses the cache's scratch buffers.
  void backward(TrainCache<T>& cache, const Eigen::Ref<const MatrixX<T>>& dy, Eigen::Ref<VectorX<T>> grad,
                MatrixX<T>* dx = nullptr) const {
    const Index batch = cache.batch(), L = num_layers();
    if (static_cast<Index>(cache.post.size()) != L || cache.input.rows() != inputs())
      throw Error("cache was not filled by forward_train of this network", {{}, std::nullopt, "Mlp::backward.cache"});
    if (dy.rows() != outputs() || dy.cols() != batch)
      throw Error("dy must be " + std::to_string(outputs()) + "x" + std::to_string(batch) + ", got " +
                      std::to_string(dy.rows()) + "x" + std::to_string(dy.cols()),
                  {{}, std::nullopt, "Mlp::backward.dy"});
    if (grad.size() != num_params())
      throw Error("grad must have " + std::to_string(num_params()) + " entries, got " + std::to_string(grad.size()),
                  {{}, std::nullopt, "Mlp::backward.grad"});
    Index width = std::max(inputs(), outputs());
    width = std::max(width, spec_.max_hidden());
    if (cache.delta.rows() < width || cache.delta.cols() != batch) cache.delta.resize(width, batch);
    if (cache.back.rows() < width || cache.back.cols() != batch) cache.back.resize(width, batch);
    MatrixX<T>* cur = &cache.delta;  // holds δ_l = ∂L/∂z_l
    MatrixX<T>* nxt = &cache.back;   // receives ∂L/∂a_{l-1}
    // δ_{L-1} = dy ⊙ f'(z_{L-1})
    {
      const Index out = outputs();
      auto d = cur->topLeftCorner(out, batch);
      d = dy;
      mul_derivative(d, cache.pre.back(), spec_.output_activation);
    }
    ThreadPool* pool = cache.pool ? cache.pool : default_pool();
    for (Index l = L - 1; l >= 0; --l) {
      const Index out = spec_.layer_outputs(l), in = spec_.layer_inputs(l);
      const auto d = cur->topLeftCorner(out, batch);
      const MatrixX<T>& a = cache.layer_input(l);
      const auto w = weight(l);
      Eigen::Map<MatrixX<T>> gW(grad.data() + weight_offset(l), out, in);
      Eigen::Map<VectorX<T>> gb(grad.data() + bias_offset(l), out);
      const bool split = worth_chunking(out, in, batch);  // both products below are out·in·B
      // gW += d aᵀ along the longer side of gW (out × in; rows on a tie), and gb += Σ_j d_j by
      // the blocks that start at column 0 (all of them when the rows are split, else one).
      for_each_block(pool, out, in, split, [&](Index r0, Index nr, Index c0, Index nc) {
        const auto dr = d.middleRows(r0, nr);
        gW.block(r0, c0, nr, nc).noalias() += dr * a.middleRows(c0, nc).transpose();
        if (c0 == 0) add_column_sum(gb.segment(r0, nr), dr);
      }, /*rows_on_tie=*/true);
      // ∂L/∂a_{l-1} = Wᵀ d (⊙ f'(z_{l-1}) below the first layer), chunked along (in × B).
      MatrixX<T>* da_target = nullptr;
      if (l > 0) {
        da_target = nxt;
      } else if (dx != nullptr) {
        dx->resize(in, batch);
        da_target = dx;
      }
      if (da_target == nullptr) continue;
      auto da = da_target->topLeftCorner(in, batch);
      const MatrixX<T>* z_below = l > 0 ? &cache.pre[static_cast<std::size_t>(l - 1)] : nullptr;
      for_each_block(pool, in, batch, split, [&](Index r0, Index nr, Index c0, Index nc) {
        auto dc = da.block(r0, c0, nr, nc);
        dc.noalias() = w.middleCols(r0, nr).transpose() * d.middleCols(c0, nc);
        if (z_below) mul_derivative(dc, z_below->block(r0, c0, nr, nc), spec_.activation);
      });
      if (l > 0) std::swap(cur, nxt);
    }
  }

 private:
  void check_input(const Eigen::Ref<const MatrixX<T>>& x, const char* where) const {
    if (num_params() == 0)
      throw Error("network is empty (default-constructed)", {{}, std::nullopt, std::string("Mlp::") + where});
    if (x.rows() != inputs())
      throw Error("input must have " + std::to_string(inputs()) + " rows, got " + std::to_string(x.rows()),
                  {{}, std::nullopt, std::string("Mlp::") + where + ".x"});
  }

  /// Z (out × B) = f(W_l X + b_l) for X (in × B), chunked along the longer side of Z.
  template <class X, class Z>
  void layer_forward(ThreadPool* pool, Index l, const X& x, Z&& z) const {
    const auto w = weight(l);
    const auto b = bias(l);
    const Activation act = spec_.layer_activation(l);
    const Index out = z.rows(), batch = z.cols(), in = spec_.layer_inputs(l);
    if (batch == 1 && x.innerStride() == 1 && z.innerStride() == 1) {  // one sample: a streaming GEMV
      // Memory-bound: with a pool, each thread streams its rows of W (same sums, any split).
      const bool split = pool != nullptr && double(out) * double(in) * sizeof(T) >= kMinSplitGemvBytes;
      for_each_chunk(pool, out, split, [&](Index lo, Index hi) {
        gemv_colmajor<T>(hi - lo, in, w.data() + lo, w.outerStride(), x.data(), z.data() + lo);
      });
      bias_activate(z, b, act);
      return;
    }
    for_each_block(pool, out, batch, worth_chunking(out, in, batch), [&](Index r0, Index nr, Index c0, Index nc) {
      auto zc = z.block(r0, c0, nr, nc);
      zc.noalias() = w.middleRows(r0, nr) * x.middleCols(c0, nc);
      bias_activate(zc, b.segment(r0, nr), act);
    });
  }

  /// g (n) += Σ_j d.col(j), a vector add per column (contiguous, vectorised).
  template <class G, class D>
  static void add_column_sum(G&& g, const D& d) {
    for (Index j = 0; j < d.cols(); ++j) g += d.col(j);
  }

  /// z = f(z + b) column by column (one pass over memory).
  template <class Z, class B>
  static void bias_activate(Z&& z, const B& b, Activation act) {
    const Index rows = z.rows();
    for (Index j = 0; j < z.cols(); ++j) {
      auto c = z.col(j);
      switch (act) {
        case Activation::Identity: c += b; break;
        case Activation::ReLU: c = (c + b).cwiseMax(T(0)); break;
        default:
          for (Index i = 0; i < rows; ++i) c[i] = activation_value(act, c[i] + b[i]);
      }
    }
  }

  /// d ⊙= f'(z).
  template <class D, class Zm>
  static void mul_derivative(D&& d, const Zm& z, Activation act) {
    if (act == Activation::Identity) return;
    const Index rows = d.rows();
    for (Index j = 0; j < d.cols(); ++j) {
      auto c = d.col(j);
      const auto zc = z.col(j);
      if (act == Activation::ReLU) {
        c = (zc.array() > T(0)).select(c, T(0));
      } else {
        for (Index i = 0; i < rows; ++i) c[i] *= activation_derivative(act, zc[i]);
      }
    }
  }

  MlpSpec spec_;
  ParameterBlock<T> block_;
  std::vector<Index> offsets_;
};

}  // namespace maskadapt::nn
