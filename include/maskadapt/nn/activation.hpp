#pragma once
/// \file activation.hpp
/// Element-wise activation functions with their first AND second derivatives.
///
/// Derivatives are taken with respect to the pre-activation z (not expressed through the
/// output), so double back-propagation (e.g. the AMP discriminator's gradient penalty) can use
/// `activation_second_derivative(act, z)` directly on the pre-activations cached by
/// `Mlp::forward_train`.
///
/// | activation | f(z)                 | f'(z)                   | f''(z)                          |
/// |------------|----------------------|-------------------------|---------------------------------|
/// | Identity   | z                    | 1                       | 0                               |
/// | ReLU       | max(z, 0)            | [z > 0]                 | 0                               |
/// | ELU (α=1)  | z>0 ? z : e^z − 1    | z>0 ? 1 : e^z           | z>0 ? 0 : e^z                   |
/// | SiLU       | z·σ(z)               | σ(1 + z(1 − σ))         | σ(1 − σ)(2 + z(1 − 2σ))         |
/// | Tanh       | tanh z               | 1 − tanh² z             | −2 tanh z (1 − tanh² z)         |
///
/// At the ReLU/ELU kink (z = 0) the derivative from the left is used (0 for ReLU, 1 for ELU),
/// as PyTorch does.
#include <cmath>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/types.hpp"

namespace maskadapt::nn {

enum class Activation { Identity, ReLU, ELU, SiLU, Tanh };

/// "identity", "relu", "elu", "silu", "tanh".
inline std::string_view to_string(Activation a) {
  switch (a) {
    case Activation::Identity: return "identity";
    case Activation::ReLU: return "relu";
    case Activation::ELU: return "elu";
    case Activation::SiLU: return "silu";
    case Activation::Tanh: return "tanh";
  }
  return "unknown";
}

/// Inverse of to_string (also accepts "none" and "linear" for Identity, "swish" for SiLU);
/// throws maskadapt::Error naming the bad value.
inline Activation activation_from_string(std::string_view s) {
  if (s == "identity" || s == "none" || s == "linear") return Activation::Identity;
  if (s == "relu") return Activation::ReLU;
  if (s == "elu") return Activation::ELU;
  if (s == "silu" || s == "swish") return Activation::SiLU;
  if (s == "tanh") return Activation::Tanh;
  throw Error("unknown activation '" + std::string(s) + "' (expected identity, relu, elu, silu or tanh)",
              {{}, std::nullopt, "activation"});
}

namespace detail {
template <class T> inline T sigmoid(T z) {
  // Stable for large |z|.
  if (z >= T(0)) return T(1) / (T(1) + std::exp(-z));
  const T e = std::exp(z);
  return e / (T(1) + e);
}
}  // namespace detail

/// f(z).
template <class T> inline T activation_value(Activation a, T z) {
  switch (a) {
    case Activation::Identity: return z;
    case Activation::ReLU: return z > T(0) ? z : T(0);
    case Activation::ELU: return z > T(0) ? z : std::expm1(z);
    case Activation::SiLU: return z * detail::sigmoid(z);
    case Activation::Tanh: return std::tanh(z);
  }
  return z;
}

/// f'(z), derivative with respect to the pre-activation z.
template <class T> inline T activation_derivative(Activation a, T z) {
  switch (a) {
    case Activation::Identity: return T(1);
    case Activation::ReLU: return z > T(0) ? T(1) : T(0);
    case Activation::ELU: return z > T(0) ? T(1) : std::exp(z);
    case Activation::SiLU: {
      const T s = detail::sigmoid(z);
      return s * (T(1) + z * (T(1) - s));
    }
    case Activation::Tanh: {
      const T t = std::tanh(z);
      return T(1) - t * t;
    }
  }
  return T(1);
}

/// f''(z), second derivative with respect to the pre-activation z.
template <class T> inline T activation_second_derivative(Activation a, T z) {
  switch (a) {
    case Activation::Identity: return T(0);
    case Activation::ReLU: return T(0);
    case Activation::ELU: return z > T(0) ? T(0) : std::exp(z);
    case Activation::SiLU: {
      const T s = detail::sigmoid(z);
      return s * (T(1) - s) * (T(2) + z * (T(1) - T(2) * s));
    }
    case Activation::Tanh: {
      const T t = std::tanh(z);
      return T(-2) * t * (T(1) - t * t);
    }
  }
  return T(0);
}

/// out = f(z), element-wise; `out` may alias `z` (same shape, any strides).
template <class T>
void apply_activation(Activation a, const Eigen::Ref<const MatrixX<T>>& z, Eigen::Ref<MatrixX<T>> out) {
  const Index rows = z.rows(), cols = z.cols();
  switch (a) {
    case Activation::Identity:
      if (out.data() != z.data()) out = z;
      return;
    case Activation::ReLU:
      for (Index j = 0; j < cols; ++j) out.col(j) = z.col(j).cwiseMax(T(0));
      return;
    default:
      for (Index j = 0; j < cols; ++j)
        for (Index i = 0; i < rows; ++i) out(i, j) = activation_value(a, z(i, j));
  }
}

/// out = f'(z), element-wise.
template <class T>
void activation_derivative(Activation a, const Eigen::Ref<const MatrixX<T>>& z, Eigen::Ref<MatrixX<T>> out) {
  for (Index j = 0; j < z.cols(); ++j)
    for (Index i = 0; i < z.rows(); ++i) out(i, j) = activation_derivative(a, z(i, j));
}

/// out = f''(z), element-wise.
template <class T>
void activation_second_derivative(Activation a, const Eigen::Ref<const MatrixX<T>>& z, Eigen::Ref<MatrixX<T>> out) {
  for (Index j = 0; j < z.cols(); ++j)
    for (Index i = 0; i < z.rows(); ++i) out(i, j) = activation_second_derivative(a, z(i, j));
}

}  // namespace maskadapt::nn
