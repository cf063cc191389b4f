#pragma once
/// \file npz.hpp
/// NumPy `.npz` archives (a zip of `.npy` members): reader (stored or deflated members, zip64
/// as NumPy writes it) and writer (stored members), plus the AMASS motion reader.
///
/// The zip container is read from its central directory; every offset and size is bounds-checked
/// and every member's CRC-32 verified, so a corrupt or truncated file gives an Error naming the
/// file and member rather than a crash. The `.npy` members are parsed here too (header dict,
/// dtype, shape, C or Fortran order) rather than by `xt::load_npy`: xtensor 0.24 reads the 16-bit
/// header length through a signed `char` (lengths with the low byte ≥ 128 come out wrong) and
/// trusts the shape for its allocation without comparing it with the bytes present, which a
/// fuzzer turns into crashes. The format is small; see numpy/lib/format.py.
///
/// Numeric members (`<f8 <f4 <i8 <i4 <i2 |i1 |u1 |b1`, little- or big-endian) are converted to
/// double; text members (`<U…` / `|S…`) to std::string; other dtypes (pickled objects) are kept
/// as unsupported and only fail when accessed.
///
/// N-d access goes through xtensor (core/tensor.hpp): `member_view<N>` is a row-major tensor of
/// the member's NumPy shape over the parsed values (no copy), `as_tensor<N>` an owning copy,
/// `tensor(x)` a member built from a fixed-rank xtensor expression. `as_matrix` remains for members that
/// go straight into Eigen algebra.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/tensor.hpp>
#include <maskadapt/core/types.hpp>

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt::npz {

/// One `.npy` member.
struct Array {
  std::vector<std::size_t> shape;  ///< NumPy shape (empty for a 0-d scalar)
  std::vector<double> values;      ///< elements in C (row-major) order, converted to double
  std::string text;                ///< contents of a text member (dtype U or S)
  std::string descr;               ///< NumPy dtype string as stored, e.g. "<f8"
  bool numeric = true;             ///< false for text or unsupported members
  bool supported = true;           ///< false for dtypes this reader does not decode (e.g. pickles)

  std::size_t size() const { return values.size(); }
  int ndim() const { return static_cast<int>(shape.size()); }
};

/// Members by name (without the ".npy" suffix).
using Archive = std::map<std::string, Array>;

// ---------------------------------------------------------------------------------------------
// Building arrays
// ---------------------------------------------------------------------------------------------

/// A 2-D array with NumPy shape (rows, cols) from an Eigen matrix (same element layout as m(r, c)).
inline Array matrix(const Eigen::Ref<const MatrixXd>& m) {
  Array a;
  a.descr = "<f8";
  a.shape = {static_cast<std::size_t>(m.rows()), static_cast<std::size_t>(m.cols())};
  a.values.resize(static_cast<std::size_t>(m.size()));
  for (Index r = 0; r < m.rows(); ++r)
    for (Index c = 0; c < m.cols(); ++c) a.values[static_cast<std::size_t>(r * m.cols() + c)] = m(r, c);
  return a;
}
/// A 1-D array of shape (n).
inline Array vector(const Eigen::Ref<const VectorXd>& v) {
  Array a;
  a.descr = "<f8";
  a.shape = {static_cast<std::size_t>(v.size())};
  a.values.assign(v.data(), v.data() + v.size());
  return a;
}
/// A 0-d scalar.
inline Array scalar(double x) {
  Array a;
  a.descr = "<f8";
  a.values = {x};
  return a;
}
/// A member with the shape and row-major values of a fixed-rank xtensor expression (e.g. a
/// Tensor<double, 2> of shape (frames, 3) gives NumPy shape (frames, 3)).
template <class E>
Array tensor(const xt::xexpression<E>& x) {
  const Tensor<double, std::tuple_size_v<std::decay_t<decltype(x.derived_cast().shape())>>> t = x.derived_cast();
  Array a;
  a.descr = "<f8";
  a.shape.assign(t.shape().begin(), t.shape().end());
  a.values.assign(t.data(), t.data() + t.size());
  return a;
}
/// A 0-d text member (dtype <U n).
inline Array text(std::string s) {
  Array a;
  a.numeric = false;
  a.descr = "<U" + std::to_string(std::max<std::size_t>(s.size(), 1));
  a.text = std::move(s);
  return a;
}

// ---------------------------------------------------------------------------------------------
// Reading arrays out of an archive with checks
// ---------------------------------------------------------------------------------------------

/// The member `name`; throws naming the file and member if absent.
inline const Array& member(const Archive& ar, const std::string& name, const std::string& file = {}) {
  auto it = ar.find(name);
  if (it == ar.end()) {
    std::string have;
    for (auto& [k, v] : ar) have += (have.empty() ? "" : ", ") + k;
    throw Error("missing member (the archive has: " + (have.empty() ? std::string("nothing") : have) + ")",
                {file, std::nullopt, name});
  }
  return it->second;
}

/// A numeric member as a (rows × cols) matrix; 1-D arrays become (n × 1). Checks dims.
inline MatrixXd as_matrix(const Array& a, const std::string& name, const std::string& file = {}) {
  require(a.supported && a.numeric, "member is not numeric (dtype " + a.descr + ")", {file, std::nullopt, name});
  require(a.ndim() == 1 || a.ndim() == 2,
          "expected a 1-D or 2-D array, got " + std::to_string(a.ndim()) + " dimensions", {file, std::nullopt, name});
  const auto rows = static_cast<Index>(a.shape[0]);
  const Index cols = a.ndim() == 2 ? static_cast<Index>(a.shape[1]) : 1;
  MatrixXd m(rows, cols);
  for (Index r = 0; r < rows; ++r)
    for (Index c = 0; c < cols; ++c) m(r, c) = a.values[static_cast<std::size_t>(r * cols + c)];
  return m;
}

/// A numeric N-d member as a read-only row-major tensor of its NumPy shape over the parsed values
/// (no copy; valid while `a` lives): for a (frames, 3·joints) member, view(t, c) is frame t's
/// value c. Throws naming `file` and member `name` unless the member is numeric with N dims.
template <std::size_t N>
auto member_view(const Array& a, const std::string& name, const std::string& file = {}) {
  require(a.supported && a.numeric, "member is not numeric (dtype " + a.descr + ")", {file, std::nullopt, name});
  require(a.shape.size() == N,
          "expected a " + std::to_string(N) + "-D array, got " + std::to_string(a.ndim()) + " dimensions",
          {file, std::nullopt, name});
  std::array<std::size_t, N> shape{};
  std::copy(a.shape.begin(), a.shape.end(), shape.begin());
  return xt::adapt(a.values.data(), a.values.size(), xt::no_ownership(), shape);
}

/// The same member as an owning tensor (one copy), for data that outlives the archive.
template <std::size_t N>
Tensor<double, N> as_tensor(const Array& a, const std::string& name, const std::string& file = {}) {
  return member_view<N>(a, name, file);
}

/// A numeric member holding exactly one value (0-d or shape (1)).
inline double as_scalar(const Array& a, const std::string& name, const std::string& file = {}) {
  require(a.supported && a.numeric, "member is not numeric (dtype " + a.descr + ")", {file, std::nullopt, name});
  require(a.values.size() == 1, "expected a scalar, got " + std::to_string(a.values.size()) + " values",
          {file, std::nullopt, name});
  return a.values[0];
}

// ---------------------------------------------------------------------------------------------
// .npy
// ---------------------------------------------------------------------------------------------
namespace detail {

inline std::uint32_t u16(const unsigned char* p) { return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8); }
inline std::uint32_t u32(const unsigned char* p) { return u16(p) | (u16(p + 2) << 16); }
inline std::uint64_t u64(const unsigned char* p) { return std::uint64_t(u32(p)) | (std::uint64_t(u32(p + 4)) << 32); }

/// Value of key `key` in a NumPy header dict literal, or fails.
inline std::string dict_value(std::string_view h, std::string_view key, const ErrorContext& ctx) {
  std::size_t k = std::string_view::npos;
  for (char q : {'\'', '"'}) {
    const std::string quoted = std::string(1, q) + std::string(key) + std::string(1, q);
    k = h.find(quoted);
    if (k != std::string_view::npos) {
      k += quoted.size();
      break;
    }
  }
  if (k == std::string_view::npos) throw Error("npy header lacks '" + std::string(key) + "'", ctx);
  while (k < h.size() && (h[k] == ' ')) ++k;
  if (k >= h.size() || h[k] != ':') throw Error("malformed npy header near '" + std::string(key) + "'", ctx);
  ++k;
  while (k < h.size() && h[k] == ' ') ++k;
  if (k >= h.size()) throw Error("malformed npy header", ctx);
  std::size_t e = k;
  if (h[k] == '(') {
    e = h.find(')', k);
    if (e == std::string_view::npos) throw Error("unterminated shape tuple in npy header", ctx);
    return std::string(h.substr(k, e - k + 1));
  }
  if (h[k] == '\'' || h[k] == '"') {
    e = h.find(h[k], k + 1);
    if (e == std::string_view::npos) throw Error("unterminated string in npy header", ctx);
    return std::string(h.substr(k + 1, e - k - 1));
  }
  while (e < h.size() && h[e] != ',' && h[e] != '}') ++e;
  std::string v(h.substr(k, e - k));
  while (!v.empty() && v.back() == ' ') v.pop_back();
  return v;
}

/// Parses one .npy blob. `ctx` names file and member for errors.
inline Array parse_npy(std::string_view blob, const ErrorContext& ctx) {
  const auto* p = reinterpret_cast<const unsigned char*>(blob.data());
  if (blob.size() < 10 || std::memcmp(p, "\x93NUMPY", 6) != 0) throw Error("not a .npy array (bad magic)", ctx);
  const int major = p[6];
  std::size_t hlen, hstart;
  if (major == 1) {
    hlen = u16(p + 8);
    hstart = 10;
  } else if (major == 2 || major == 3) {
    if (blob.size() < 12) throw Error("truncated .npy header", ctx);
    hlen = u32(p + 8);
    hstart = 12;
  } else {
    throw Error("unsupported .npy version " + std::to_string(major), ctx);
  }
  if (hlen > blob.size() - hstart) throw Error("truncated .npy header", ctx);
  const std::string_view header = blob.substr(hstart, hlen);
  const std::string_view data = blob.substr(hstart + hlen);

  Array a;
  a.descr = dict_value(header, "descr", ctx);
  const std::string fortran = dict_value(header, "fortran_order", ctx);
  if (fortran != "True" && fortran != "False") throw Error("bad fortran_order '" + fortran + "'", ctx);
  const std::string shape_s = dict_value(header, "shape", ctx);
  // shape "(a, b,)"
  std::size_t count = 1;
  {
    std::size_t i = 1;
    while (i + 1 < shape_s.size()) {
      while (i + 1 < shape_s.size() && (shape_s[i] == ' ' || shape_s[i] == ',')) ++i;
      if (i + 1 >= shape_s.size()) break;
      std::size_t d = 0;
      bool any = false;
      while (i + 1 < shape_s.size() && shape_s[i] >= '0' && shape_s[i] <= '9') {
        if (d > (std::size_t(1) << 40)) throw Error("npy dimension too large", ctx);
        d = d * 10 + std::size_t(shape_s[i] - '0');
        ++i;
        any = true;
      }
      if (!any) throw Error("malformed shape '" + shape_s + "'", ctx);
      if (a.shape.size() >= 32) throw Error("too many dimensions", ctx);
      a.shape.push_back(d);
      if (d != 0 && count > (std::size_t(1) << 40) / d) throw Error("npy array too large", ctx);
      count *= d;
    }
  }
  // dtype "<f8": byte order, kind, item size; anything else (objects "|O", structured dtypes)
  // is kept as an unsupported member that fails only when used
  auto unsupported = [&] {
    a.supported = false;
    a.numeric = false;
    return a;
  };
  if (a.descr.size() < 3) return unsupported();
  const char order = a.descr[0];
  const char kind = a.descr[1];
  std::size_t item = 0;
  for (std::size_t i = 2; i < a.descr.size(); ++i) {
    if (a.descr[i] < '0' || a.descr[i] > '9' || item > 100000) return unsupported();
    item = item * 10 + std::size_t(a.descr[i] - '0');
  }
  if (order != '<' && order != '>' && order != '|' && order != '=') return unsupported();
  if (item == 0) return unsupported();
  const std::size_t char_size = kind == 'U' ? 4 : 1;
  const std::size_t elem_bytes = item * ((kind == 'U') ? char_size : 1);
  if (count != 0 && elem_bytes > (std::size_t(1) << 40) / count) throw Error("npy array too large", ctx);
  const std::size_t nbytes = count * elem_bytes;
  if (data.size() < nbytes)
    throw Error("npy data is truncated: " + std::to_string(data.size()) + " bytes for " + std::to_string(count) +
                    " elements of dtype " + a.descr,
                ctx);
  const auto* d = reinterpret_cast<const unsigned char*>(data.data());
  const bool big = order == '>';

  if (kind == 'U' || kind == 'S') {
    a.numeric = false;
    for (std::size_t i = 0; i < count * item; ++i) {
      std::uint32_t c = 0;
      if (kind == 'U') c = big ? (std::uint32_t(d[4 * i]) << 24 | std::uint32_t(d[4 * i + 1]) << 16 | std::uint32_t(d[4 * i + 2]) << 8 | d[4 * i + 3])
                               : u32(d + 4 * i);
      else c = d[i];
      if (c == 0) continue;
      a.text += c < 128 ? static_cast<char>(c) : '?';
    }
    return a;
  }
  const bool is_float = kind == 'f' && (item == 4 || item == 8);
  const bool is_int = (kind == 'i' || kind == 'u') && (item == 1 || item == 2 || item == 4 || item == 8);
  const bool is_bool = kind == 'b' && item == 1;
  if (!is_float && !is_int && !is_bool) {
    a.supported = false;
    a.numeric = false;
    return a;
  }
  a.values.resize(count);
  unsigned char tmp[8];
  for (std::size_t i = 0; i < count; ++i) {
    const unsigned char* e = d + i * item;
    for (std::size_t b = 0; b < item; ++b) tmp[b] = big ? e[item - 1 - b] : e[b];
    double v = 0;
    if (is_float && item == 8) {
      std::uint64_t u = u64(tmp);
      double x;
      std::memcpy(&x, &u, 8);
      v = x;
    } else if (is_float) {
      std::uint32_t u = u32(tmp);
      float x;
      std::memcpy(&x, &u, 4);
      v = x;
    } else if (is_bool) {
      v = tmp[0] != 0;
    } else {
      std::uint64_t u = 0;
      for (std::size_t b = 0; b < item; ++b) u |= std::uint64_t(tmp[b]) << (8 * b);
      if (kind == 'i' && item < 8 && (u >> (8 * item - 1)) & 1u) u |= ~std::uint64_t(0) << (8 * item);  // sign-extend
      v = kind == 'i' ? static_cast<double>(static_cast<std::int64_t>(u)) : static_cast<double>(u);
    }
    a.values[i] = v;
  }
  if (fortran == "True" && a.shape.size() > 1) {
    // column-major → row-major. (An xtensor column-major view assigned to a row-major one, or
    // the transpose of the reversed shape, did the same 1.5× slower: docs/architecture.md.)
    std::vector<double> c(count);
    const std::size_t nd = a.shape.size();
    std::vector<std::size_t> idx(nd, 0);
    for (std::size_t f = 0; f < count; ++f) {
      // idx = multi-index of Fortran position f
      std::size_t r = 0;
      for (std::size_t k = 0; k < nd; ++k) r = r * a.shape[k] + idx[k];
      c[r] = a.values[f];
      for (std::size_t k = 0; k < nd; ++k) {
        if (++idx[k] < a.shape[k]) break;
        idx[k] = 0;
      }
    }
    a.values.swap(c);
  }
  return a;
}

/// Serialises one array as a version-1.0 .npy blob (C order, little-endian <f8 or <U).
inline std::string npy_bytes(const Array& a) {
  std::string shape = "(";  // NumPy's repr: (), (n,), (a, b)
  for (std::size_t i = 0; i < a.shape.size(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape[i]);
  shape += a.shape.size() == 1 ? ",)" : ")";
  std::string descr;
  std::string body;
  if (!a.numeric) {
    const std::size_t n = std::max<std::size_t>(a.text.size(), 1);
    descr = "<U" + std::to_string(n);
    require(a.shape.empty(), "text members must be 0-d", {{}, {}, "text"});
    body.assign(4 * n, '\0');
    for (std::size_t i = 0; i < a.text.size(); ++i) body[4 * i] = a.text[i];
  } else {
    descr = "<f8";
    std::size_t count = 1;
    for (auto s : a.shape) count *= s;
    require(count == a.values.size(), "array has " + std::to_string(a.values.size()) + " values for its shape",
            {{}, {}, "shape"});
    body.resize(8 * count);
    for (std::size_t i = 0; i < count; ++i) {
      std::uint64_t u;
      std::memcpy(&u, &a.values[i], 8);
      for (int b = 0; b < 8; ++b) body[8 * i + b] = static_cast<char>((u >> (8 * b)) & 0xff);
    }
  }
  std::string header = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  const std::size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>((header.size() >> 8) & 0xff);
  out += header;
  out += body;
  return out;
}

// ---------------------------------------------------------------------------------------------
// zip container
// ---------------------------------------------------------------------------------------------

inline std::string inflate_raw(std::string_view in, std::size_t expected, const ErrorContext& ctx) {
  std::string out(expected, '\0');
  z_stream zs{};
  if (inflateInit2(&zs, -MAX_WBITS) != Z_OK) throw Error("zlib inflateInit failed", ctx);
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(expected);
  const int rc = inflate(&zs, Z_FINISH);
  const std::size_t produced = expected - zs.avail_out;
  inflateEnd(&zs);
  if (rc != Z_STREAM_END || produced != expected)
    throw Error("corrupt deflate data (zlib code " + std::to_string(rc) + ", " + std::to_string(produced) + " of " +
                    std::to_string(expected) + " bytes)",
                ctx);
  return out;
}

}  // namespace detail

/// Parses an .npz archive held in memory. `file` is used in error messages.
inline Archive parse(std::string_view bytes, const std::string& file = "<npz>") {
  using detail::u16;
  using detail::u32;
  using detail::u64;
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = bytes.size();
  const ErrorContext fctx{file, std::nullopt, {}};
  // End of central directory: last occurrence of PK\5\6 within the trailing 64 KiB + 22 bytes.
  if (n < 22) throw Error("not a zip/npz file (too short)", fctx);
  std::size_t eocd = std::string_view::npos;
  for (std::size_t i = n - 22 + 1; i-- > (n > 65557 ? n - 65557 : 0);) {
    if (p[i] == 'P' && p[i + 1] == 'K' && p[i + 2] == 5 && p[i + 3] == 6) {
      eocd = i;
      break;
    }
  }
  if (eocd == std::string_view::npos) throw Error("not a zip/npz file (no end-of-central-directory record)", fctx);
  std::uint64_t entries = u16(p + eocd + 10);
  std::uint64_t cd_size = u32(p + eocd + 12);
  std::uint64_t cd_off = u32(p + eocd + 16);
  if (entries == 0xffff || cd_size == 0xffffffffu || cd_off == 0xffffffffu) {
    // zip64: locator sits just before the EOCD
    if (eocd < 20 || u32(p + eocd - 20) != 0x07064b50u) throw Error("zip64 archive without a zip64 locator", fctx);
    const std::uint64_t z = u64(p + eocd - 20 + 8);
    if (z > n || n - z < 56 || u32(p + z) != 0x06064b50u) throw Error("corrupt zip64 end-of-central-directory record", fctx);
    entries = u64(p + z + 32);
    cd_size = u64(p + z + 40);
    cd_off = u64(p + z + 48);
  }
  if (cd_off > n || cd_size > n - cd_off) throw Error("central directory lies outside the file", fctx);
  if (entries > cd_size / 46) throw Error("central directory entry count does not fit its size", fctx);

  Archive out;
  std::size_t c = static_cast<std::size_t>(cd_off);
  const std::size_t cd_end = static_cast<std::size_t>(cd_off + cd_size);
  for (std::uint64_t e = 0; e < entries; ++e) {
    if (cd_end - c < 46 || u32(p + c) != 0x02014b50u) throw Error("corrupt central directory entry", fctx);
    const std::uint32_t flags = u16(p + c + 8);
    const std::uint32_t method = u16(p + c + 10);
    const std::uint32_t crc = u32(p + c + 16);
    std::uint64_t csize = u32(p + c + 20);
    std::uint64_t usize = u32(p + c + 24);
    const std::size_t name_len = u16(p + c + 28), extra_len = u16(p + c + 30), comment_len = u16(p + c + 32);
    std::uint64_t local = u32(p + c + 42);
    if (cd_end - c - 46 < name_len + extra_len + comment_len) throw Error("corrupt central directory entry", fctx);
    std::string name(bytes.substr(c + 46, name_len));
    const ErrorContext ctx{file, std::nullopt, name};
    // zip64 extended information
    std::size_t x = c + 46 + name_len;
    const std::size_t x_end = x + extra_len;
    while (x_end - x >= 4) {
      const std::uint32_t id = u16(p + x), len = u16(p + x + 2);
      if (x_end - x - 4 < len) throw Error("corrupt zip extra field", ctx);
      if (id == 0x0001) {
        std::size_t q = x + 4;
        const std::size_t q_end = q + len;
        auto take = [&](std::uint64_t& v) {
          if (v != 0xffffffffu) return;
          if (q_end - q < 8) throw Error("corrupt zip64 extra field", ctx);
          v = u64(p + q);
          q += 8;
        };
        take(usize);
        take(csize);
        take(local);
      }
      x += 4 + len;
    }
    c += 46 + name_len + extra_len + comment_len;
    if (flags & 1u) throw Error("encrypted zip members are not supported", ctx);
    if (local > n || n - local < 30 || u32(p + local) != 0x04034b50u) throw Error("corrupt local file header", ctx);
    const std::uint64_t data_off = local + 30 + u16(p + local + 26) + u16(p + local + 28);
    if (data_off > n || csize > n - data_off) throw Error("member data lies outside the file (truncated?)", ctx);
    const std::string_view raw = bytes.substr(static_cast<std::size_t>(data_off), static_cast<std::size_t>(csize));
    if (usize > (std::uint64_t(1) << 30)) throw Error("member too large (" + std::to_string(usize) + " bytes)", ctx);
    std::string inflated;
    std::string_view blob;
    if (method == 0) {
      if (usize != csize) throw Error("stored member with different compressed and uncompressed sizes", ctx);
      blob = raw;
    } else if (method == 8) {
      // deflate expands at most ~1032:1; reject absurd claims before allocating
      if (usize > 1100 * (csize + 16)) throw Error("implausible deflate ratio (corrupt sizes)", ctx);
      inflated = detail::inflate_raw(raw, static_cast<std::size_t>(usize), ctx);
      blob = inflated;
    } else {
      throw Error("unsupported zip compression method " + std::to_string(method), ctx);
    }
    const auto actual_crc = static_cast<std::uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(blob.data()), static_cast<uInt>(blob.size())));
    if (actual_crc != crc) throw Error("CRC-32 mismatch (corrupt member)", ctx);
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) name.resize(name.size() - 4);
    out[name] = detail::parse_npy(blob, {file, std::nullopt, name});
  }
  return out;
}

/// Reads an .npz file.
inline Archive read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  require(static_cast<bool>(in), "cannot open npz file", {path, std::nullopt, {}});
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

/// Serialises an archive as a zip of stored (uncompressed) .npy members.
inline std::string serialise(const Archive& ar) {
  std::string out, cd;
  auto put16 = [](std::string& s, std::uint32_t v) {
    s += static_cast<char>(v & 0xff);
    s += static_cast<char>((v >> 8) & 0xff);
  };
  auto put32 = [&](std::string& s, std::uint32_t v) {
    put16(s, v & 0xffff);
    put16(s, v >> 16);
  };
  std::uint32_t count = 0;
  for (const auto& [key, arr] : ar) {
    const std::string name = key + ".npy";
    const std::string blob = detail::npy_bytes(arr);
    require(blob.size() < 0xffffffffu && out.size() < 0xffffffffu, "npz writer: member too large", {{}, {}, key});
    const auto crc = static_cast<std::uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(blob.data()), static_cast<uInt>(blob.size())));
    const auto offset = static_cast<std::uint32_t>(out.size());
    put32(out, 0x04034b50u);
    put16(out, 20);
    put16(out, 0);  // flags
    put16(out, 0);  // stored
    put16(out, 0);
    put16(out, 0x21);  // 1980-01-01
    put32(out, crc);
    put32(out, static_cast<std::uint32_t>(blob.size()));
    put32(out, static_cast<std::uint32_t>(blob.size()));
    put16(out, static_cast<std::uint32_t>(name.size()));
    put16(out, 0);
    out += name;
    out += blob;

    put32(cd, 0x02014b50u);
    put16(cd, 20);
    put16(cd, 20);
    put16(cd, 0);
    put16(cd, 0);
    put16(cd, 0);
    put16(cd, 0x21);
    put32(cd, crc);
    put32(cd, static_cast<std::uint32_t>(blob.size()));
    put32(cd, static_cast<std::uint32_t>(blob.size()));
    put16(cd, static_cast<std::uint32_t>(name.size()));
    put16(cd, 0);
    put16(cd, 0);
    put16(cd, 0);
    put16(cd, 0);
    put32(cd, 0);
    put32(cd, offset);
    cd += name;
    ++count;
  }
  const auto cd_off = static_cast<std::uint32_t>(out.size());
  out += cd;
  put32(out, 0x06054b50u);
  put16(out, 0);
  put16(out, 0);
  put16(out, count);
  put16(out, count);
  put32(out, static_cast<std::uint32_t>(cd.size()));
  put32(out, cd_off);
  put16(out, 0);
  return out;
}

/// Writes an .npz file (stored members; NumPy's np.load reads it).
inline void write(const std::string& path, const Archive& ar) {
  const std::string bytes = serialise(ar);
  std::ofstream out(path, std::ios::binary);
  require(static_cast<bool>(out), "cannot open file for writing", {path, std::nullopt, {}});
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  require(static_cast<bool>(out), "write failed", {path, std::nullopt, {}});
}

// ---------------------------------------------------------------------------------------------
// AMASS
// ---------------------------------------------------------------------------------------------

/// An AMASS clip (SMPL / SMPL-H / SMPL-X parameters) in the file's own layout: one row per frame.
struct AmassMotion {
  Tensor<double, 2> poses;  ///< (frames × 3·joints) axis-angle of SMPL joint j in columns [3j, 3j+3) (rad), SMPL y-up body frame
  Tensor<double, 2> trans;  ///< (frames × 3) root translation (m), SMPL/AMASS world frame
  double fps = 0;           ///< mocap_framerate (or mocap_frame_rate)
  Tensor<double, 1> betas;  ///< (num_betas) shape coefficients (may be empty)
  std::string gender;       ///< "male" / "female" / "neutral" if present

  int num_frames() const { return static_cast<int>(poses.shape(0)); }
  int num_joints() const { return static_cast<int>(poses.shape(1) / 3); }
  /// Axis-angle (rad) of SMPL joint j at frame t.
  Vec3 pose(int t, int j) const {
    const auto r = static_cast<std::size_t>(t), c = static_cast<std::size_t>(3 * j);
    return {poses(r, c), poses(r, c + 1), poses(r, c + 2)};
  }
  /// Root translation (m) at frame t.
  Vec3 translation(int t) const {
    const auto r = static_cast<std::size_t>(t);
    return {trans(r, 0), trans(r, 1), trans(r, 2)};
  }
};

/// Reads AMASS parameters from an archive; checks members, shapes and values. The checks run on
/// views of the parsed members; each array is copied once, into its tensor.
inline AmassMotion amass_from_archive(const Archive& ar, const std::string& file = {}) {
  AmassMotion m;
  const Array& poses_member = member(ar, "poses", file);
  require(poses_member.supported && poses_member.numeric, "member is not numeric (dtype " + poses_member.descr + ")",
          {file, std::nullopt, "poses"});
  require(poses_member.ndim() == 2, "expected shape (frames, 3·joints), got " + std::to_string(poses_member.ndim()) +
                                        " dimensions",
          {file, std::nullopt, "poses"});
  const auto poses = member_view<2>(poses_member, "poses", file);  // (frames × 3·joints), no copy
  const std::size_t frames = poses.shape(0), cols = poses.shape(1);
  require(cols >= 66 && cols % 3 == 0,
          "expected (frames, 3·joints) with at least the 22 body joints (66 columns), got " + std::to_string(cols) +
              " columns",
          {file, std::nullopt, "poses"});
  const Array& trans_member = member(ar, "trans", file);
  require(trans_member.supported && trans_member.numeric, "member is not numeric (dtype " + trans_member.descr + ")",
          {file, std::nullopt, "trans"});
  require(trans_member.ndim() == 2 && trans_member.shape[1] == 3 && trans_member.shape[0] == frames,
          "expected shape (" + std::to_string(frames) + ", 3)", {file, std::nullopt, "trans"});
  const auto trans = member_view<2>(trans_member, "trans", file);  // (frames × 3), no copy
  require(frames >= 1, "clip has no frames", {file, std::nullopt, "poses"});
  require_finite_tensor(poses, "poses", file);
  require_finite_tensor(trans, "trans", file);
  m.poses = poses;
  m.trans = trans;
  const std::string fps_key = ar.count("mocap_framerate") ? "mocap_framerate" : "mocap_frame_rate";
  m.fps = as_scalar(member(ar, fps_key, file), fps_key, file);
  require(std::isfinite(m.fps) && m.fps > 0 && m.fps < 10000, "frame rate must be positive", {file, std::nullopt, fps_key});
  if (auto it = ar.find("betas"); it != ar.end() && it->second.numeric) {
    // (num_betas): any shape, flattened (AMASS stores (16,), some exports (1, 10))
    m.betas = xt::adapt(it->second.values.data(), it->second.values.size(), xt::no_ownership(),
                        std::array<std::size_t, 1>{it->second.values.size()});
    require_finite_tensor(m.betas, "betas", file);
  }
  if (auto it = ar.find("gender"); it != ar.end() && !it->second.numeric) m.gender = it->second.text;
  return m;
}

inline AmassMotion read_amass(const std::string& path) { return amass_from_archive(read(path), path); }

}  // namespace maskadapt::npz
