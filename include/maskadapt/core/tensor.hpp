#pragma once
/// \file tensor.hpp
/// xtensor aliases and the two bridges the library needs: a row-major N-d view over the memory
/// of a column-major Eigen matrix (no copy), and a finiteness check that names the first bad
/// multi-index.
///
/// Where xtensor is used (docs/architecture.md, "N-d data"): data that is N-d by nature and read
/// or written in bulk — `.npz` members and AMASS parameters (motion/npz.hpp), the generator's
/// training windows (tracking/primitive_dataset.hpp). Linear algebra stays with Eigen (and its
/// BLAS); a tensor view over an Eigen matrix lets both look at one buffer.
///
/// Memory order: xtensor's default is row-major (the last index runs fastest), Eigen's
/// column-major. A column-major (rows × cols) matrix therefore *is* a row-major (cols × rows)
/// tensor, and more generally a column holding k blocks of d values is a (cols × k × d) tensor:
/// `tensor_view(m, {m.cols(), k, d})(n, j, i) == m(j·d + i, n)`.
#include <maskadapt/core/error.hpp>

#include <xtensor/xadapt.hpp>
#include <xtensor/xnoalias.hpp>
#include <xtensor/xtensor.hpp>
#include <xtensor/xview.hpp>

#include <array>
#include <cmath>
#include <cstddef>
#include <functional>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

namespace maskadapt {

/// An owning, row-major tensor of fixed rank N.
template <class T, std::size_t N>
using Tensor = xt::xtensor<T, N>;

namespace detail {

template <std::size_t N>
std::string shape_string(const std::array<std::size_t, N>& s) {
  std::string out = "(";
  for (std::size_t k = 0; k < N; ++k) out += (k ? ", " : "") + std::to_string(s[k]);
  return out + ")";
}

template <class Derived, std::size_t N>
void require_view_fits(const Eigen::PlainObjectBase<Derived>& m, const std::array<std::size_t, N>& shape,
                       const std::string& field) {
  static_assert(!Derived::IsRowMajor, "tensor_view expects a column-major Eigen matrix");
  const std::size_t count = std::accumulate(shape.begin(), shape.end(), std::size_t{1}, std::multiplies<>());
  require(count == static_cast<std::size_t>(m.size()),
          "a tensor of shape " + shape_string(shape) + " needs " + std::to_string(count) + " values, the matrix is " +
              std::to_string(m.rows()) + "x" + std::to_string(m.cols()),
          {{}, std::nullopt, field});
}

}  // namespace detail

/// Row-major view of shape `shape` over the memory of column-major `m` (no copy; writes go to
/// `m`). Valid while `m` is neither resized nor destroyed. Throws naming `field` unless the
/// shape holds exactly m.size() values.
template <class Derived, std::size_t N>
auto tensor_view(Eigen::PlainObjectBase<Derived>& m, const std::array<std::size_t, N>& shape,
                 const std::string& field = {}) {
  detail::require_view_fits(m, shape, field);
  return xt::adapt(m.data(), static_cast<std::size_t>(m.size()), xt::no_ownership(), shape);
}

/// Read-only view of shape `shape` over the memory of `m` (no copy).
template <class Derived, std::size_t N>
auto tensor_view(const Eigen::PlainObjectBase<Derived>& m, const std::array<std::size_t, N>& shape,
                 const std::string& field = {}) {
  detail::require_view_fits(m, shape, field);
  return xt::adapt(m.data(), static_cast<std::size_t>(m.size()), xt::no_ownership(), shape);
}

/// Throws an Error naming `field` (and `file`) at the first NaN or ±inf of `e` in row-major
/// order: "non-finite value (nan) at [1, 4] of a (5, 156) array".
template <class E>
void require_finite_tensor(const xt::xexpression<E>& expr, const std::string& field, const std::string& file = {}) {
  const E& e = expr.derived_cast();
  std::size_t flat = 0;
  for (auto it = e.template cbegin<xt::layout_type::row_major>(); it != e.template cend<xt::layout_type::row_major>();
       ++it, ++flat) {
    const double v = static_cast<double>(*it);
    if (std::isfinite(v)) continue;
    const auto& shape = e.shape();
    std::vector<std::size_t> idx(shape.size());
    std::size_t r = flat;
    for (std::size_t k = shape.size(); k-- > 0;) {
      idx[k] = r % shape[k];
      r /= shape[k];
    }
    std::ostringstream msg;
    msg << "non-finite value (" << v << ") at [";
    for (std::size_t k = 0; k < idx.size(); ++k) msg << (k ? ", " : "") << idx[k];
    msg << "] of a (";
    for (std::size_t k = 0; k < shape.size(); ++k) msg << (k ? ", " : "") << shape[k];
    msg << ") array";
    throw Error(msg.str(), {file, std::nullopt, field});
  }
}

}  // namespace maskadapt
