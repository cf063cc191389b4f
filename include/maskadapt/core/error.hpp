#pragma once
/// \file error.hpp
/// The one exception type of maskadapt. It carries *where* the problem is: a file, a line,
/// a field or a tensor name, so that bad input is reported, never silently propagated.
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Core>

namespace maskadapt {

/// Context attached to an Error. Every member is optional; what() prints the ones that are set:
/// "file.bvh:12: field 'CHANNELS': expected 3 channels, got 2".
struct ErrorContext {
  std::string file;                 ///< path of the file being read/written, if any
  std::optional<long long> line;    ///< 1-based line number inside `file`, if meaningful
  std::string field;                ///< name of the field / tensor / option / column at fault
};

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message, ErrorContext context = {})
      : std::runtime_error(format(message, context)), message_(message), context_(std::move(context)) {}

  const std::string& message() const noexcept { return message_; }
  const ErrorContext& context() const noexcept { return context_; }

 private:
  static std::string format(const std::string& message, const ErrorContext& c) {
    std::ostringstream out;
    if (!c.file.empty()) {
      out << c.file;
      if (c.line) out << ":" << *c.line;
      out << ": ";
    } else if (c.line) {
      out << "line " << *c.line << ": ";
    }
    if (!c.field.empty()) out << "field '" << c.field << "': ";
    out << message;
    return out.str();
  }

  std::string message_;
  ErrorContext context_;
};

/// Throw an Error unless `condition` holds.
inline void require(bool condition, const std::string& message, ErrorContext context = {}) {
  if (!condition) throw Error(message, std::move(context));
}

/// Throw an Error naming `field` if any coefficient of `x` is NaN or ±inf.
template <class Derived>
void require_finite(const Derived& x, const std::string& field, const std::string& file = {}) {
  if (!x.allFinite()) {
    const auto v = x.eval();  // only on the failure path
    Eigen::Index bad = 0;
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      if (!std::isfinite(static_cast<double>(v.data()[i]))) { bad = i; break; }
    }
    std::ostringstream msg;
    msg << "non-finite value (" << v.data()[bad] << ") at (row " << bad % v.rows() << ", col "
        << bad / v.rows() << ") of a " << v.rows() << "x" << v.cols() << " array";
    throw Error(msg.str(), {file, std::nullopt, field});
  }
}

}  // namespace maskadapt
