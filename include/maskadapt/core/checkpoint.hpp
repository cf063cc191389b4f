#pragma once
/// \file checkpoint.hpp
/// Versioned, checksummed binary checkpoints made of named sections (typed arrays with shapes).
///
/// File layout, version 1 (all integers little-endian):
///
///     offset 0   8 bytes  magic "MASKCKPT"
///            8   u32      format version (kCheckpointVersion)
///           12   u32      number of sections S
///           16   u64      total file size in bytes (detects truncation / trailing bytes)
///           24   S × section:
///                  u32 name length, name bytes (1..4096, unique)
///                  u8 dtype (1 f32, 2 f64, 3 i64, 4 bytes), u8 rank (≤ 8), u16 zero
///                  rank × i64 dims (≥ 0), u64 data byte count (= Π dims · sizeof dtype), data
///           end−4 u32     CRC-32 (zlib) of every byte before it
///
/// Arrays are stored column-major (Eigen's order): a matrix has shape {rows, cols}, a vector {n},
/// a scalar {}. `save_checkpoint` writes `path.tmp`, fsyncs, renames it over `path` and fsyncs the
/// directory, so a crash never leaves a half-written checkpoint under `path`.
/// `load_checkpoint` reads and verifies the WHOLE file (magic, version, size, checksum, every
/// section's bounds) before returning; any problem throws maskadapt::Error naming the file. Loading
/// into live objects should therefore happen only after load_checkpoint returned, and the typed
/// getters validate dtype and shape before anything is copied (see nn/serialize.hpp).
#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/rng.hpp"
#include "maskadapt/core/types.hpp"

namespace maskadapt {

static_assert(std::endian::native == std::endian::little, "checkpoint I/O assumes a little-endian host");

inline constexpr std::uint32_t kCheckpointVersion = 1;
inline constexpr char kCheckpointMagic[8] = {'M', 'A', 'S', 'K', 'C', 'K', 'P', 'T'};

enum class DType : std::uint8_t { Float32 = 1, Float64 = 2, Int64 = 3, Bytes = 4 };

inline std::size_t dtype_size(DType t) {
  switch (t) {
    case DType::Float32: return 4;
    case DType::Float64: return 8;
    case DType::Int64: return 8;
    case DType::Bytes: return 1;
  }
  return 0;
}
inline const char* dtype_name(DType t) {
  switch (t) {
    case DType::Float32: return "float32";
    case DType::Float64: return "float64";
    case DType::Int64: return "int64";
    case DType::Bytes: return "bytes";
  }
  return "unknown";
}
template <class T> constexpr DType dtype_of() {
  if constexpr (std::is_same_v<T, float>) return DType::Float32;
  else if constexpr (std::is_same_v<T, double>) return DType::Float64;
  else if constexpr (std::is_same_v<T, std::int64_t>) return DType::Int64;
  else static_assert(sizeof(T) == 0, "checkpoint arrays must be float, double or std::int64_t");
}

/// One named array.
struct CheckpointSection {
  DType dtype = DType::Bytes;
  std::vector<std::int64_t> shape;  ///< {} scalar, {n} vector, {rows, cols} matrix, …
  std::vector<std::uint8_t> data;   ///< Π shape · dtype_size(dtype) bytes, column-major
  std::int64_t numel() const {
    std::int64_t n = 1;
    for (auto d : shape) n *= d;
    return n;
  }
};

/// An in-memory checkpoint: ordered named sections plus the file it came from (for errors).
class Checkpoint {
 public:
  // ---- writing ------------------------------------------------------------------------------
  /// Stores a raw section (replaces an existing one of the same name).
  void put_raw(const std::string& name, DType dtype, std::vector<std::int64_t> shape, const void* bytes,
               std::size_t num_bytes) {
    require(!name.empty() && name.size() <= 4096, "section name must have 1..4096 characters", {source_, std::nullopt, name});
    CheckpointSection s{dtype, std::move(shape), {}};
    require(static_cast<std::size_t>(s.numel()) * dtype_size(dtype) == num_bytes, "byte count does not match shape",
            {source_, std::nullopt, name});
    s.data.resize(num_bytes);
    if (num_bytes) std::memcpy(s.data.data(), bytes, num_bytes);
    set(name, std::move(s));
  }
  /// Stores an Eigen array of float/double/int64: shape {n} for a column vector, else {rows, cols}.
  template <class Derived>
  void put(const std::string& name, const Eigen::DenseBase<Derived>& a) {
    using T = typename Derived::Scalar;
    const Eigen::Matrix<T, Derived::RowsAtCompileTime, Derived::ColsAtCompileTime> m = a.derived();  // contiguous copy
    std::vector<std::int64_t> shape;
    if (Derived::ColsAtCompileTime == 1) shape = {static_cast<std::int64_t>(m.rows())};
    else shape = {static_cast<std::int64_t>(m.rows()), static_cast<std::int64_t>(m.cols())};
    put_raw(name, dtype_of<T>(), std::move(shape), m.data(), static_cast<std::size_t>(m.size()) * sizeof(T));
  }
  void put_string(const std::string& name, std::string_view text) {
    put_raw(name, DType::Bytes, {static_cast<std::int64_t>(text.size())}, text.data(), text.size());
  }
  void put_int(const std::string& name, std::int64_t v) { put_raw(name, DType::Int64, {}, &v, sizeof v); }
  void put_double(const std::string& name, double v) { put_raw(name, DType::Float64, {}, &v, sizeof v); }
  /// Full generator state (resume continues the stream bit-exactly).
  void put_rng(const std::string& name, const Rng& rng) {
    const Rng::State st = rng.state();
    std::int64_t w[6];
    for (int i = 0; i < 4; ++i) w[i] = std::bit_cast<std::int64_t>(st.s[static_cast<std::size_t>(i)]);
    w[4] = std::bit_cast<std::int64_t>(st.spare_normal);
    w[5] = st.has_spare_normal ? 1 : 0;
    put_raw(name, DType::Int64, {6}, w, sizeof w);
  }
  void erase(const std::string& name) {
    std::erase_if(sections_, [&](const auto& p) { return p.first == name; });
  }

  // ---- reading ------------------------------------------------------------------------------
  bool contains(const std::string& name) const { return find(name) != nullptr; }
  /// Section names in insertion (= file) order.
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& p : sections_) n.push_back(p.first);
    return n;
  }
  std::size_t size() const { return sections_.size(); }
  /// Throws "missing section" naming the file and the section.
  const CheckpointSection& section(const std::string& name) const {
    const CheckpointSection* s = find(name);
    if (!s) throw Error("missing section", {source_, std::nullopt, name});
    return *s;
  }
  /// A float/double/int64 array of exactly `expected` elements (any shape; −1: any size).
  template <class T>
  VectorX<T> get_vector(const std::string& name, Index expected = -1) const {
    const CheckpointSection& s = typed(name, dtype_of<T>());
    if (expected >= 0 && s.numel() != expected)
      throw Error("shape mismatch: expected " + std::to_string(expected) + " elements, found " + std::to_string(s.numel()),
                  {source_, std::nullopt, name});
    VectorX<T> v(s.numel());
    if (v.size()) std::memcpy(v.data(), s.data.data(), s.data.size());
    return v;
  }
  /// A rank-2 array {rows, cols} (−1 accepts any extent).
  template <class T>
  MatrixX<T> get_matrix(const std::string& name, Index rows = -1, Index cols = -1) const {
    const CheckpointSection& s = typed(name, dtype_of<T>());
    if (s.shape.size() != 2 || (rows >= 0 && s.shape[0] != rows) || (cols >= 0 && s.shape[1] != cols))
      throw Error("shape mismatch: expected a " + std::to_string(rows) + "x" + std::to_string(cols) + " matrix, found " +
                      shape_string(s.shape),
                  {source_, std::nullopt, name});
    MatrixX<T> m(s.shape[0], s.shape[1]);
    if (m.size()) std::memcpy(m.data(), s.data.data(), s.data.size());
    return m;
  }
  /// Copies into `out` after checking dtype and that the element count equals out.size().
  template <class T>
  void copy_to(const std::string& name, Eigen::Ref<VectorX<T>> out) const {
    const CheckpointSection& s = typed(name, dtype_of<T>());
    if (s.numel() != out.size())
      throw Error("shape mismatch: expected " + std::to_string(out.size()) + " elements, found " + std::to_string(s.numel()),
                  {source_, std::nullopt, name});
    if (out.size()) std::memcpy(out.data(), s.data.data(), s.data.size());
  }
  std::string get_string(const std::string& name) const {
    const CheckpointSection& s = typed(name, DType::Bytes);
    return std::string(s.data.begin(), s.data.end());
  }
  std::int64_t get_int(const std::string& name) const { return scalar<std::int64_t>(name); }
  double get_double(const std::string& name) const { return scalar<double>(name); }
  Rng::State get_rng(const std::string& name) const {
    const VectorX<std::int64_t> w = get_vector<std::int64_t>(name, 6);
    Rng::State st{};
    for (int i = 0; i < 4; ++i) st.s[static_cast<std::size_t>(i)] = std::bit_cast<std::uint64_t>(w[i]);
    st.spare_normal = std::bit_cast<double>(w[4]);
    st.has_spare_normal = w[5] != 0;
    return st;
  }

  /// The file this checkpoint was loaded from ("" for one built in memory); used in errors.
  const std::string& source() const { return source_; }
  void set_source(std::string s) { source_ = std::move(s); }

  const std::vector<std::pair<std::string, CheckpointSection>>& sections() const { return sections_; }

 private:
  static std::string shape_string(const std::vector<std::int64_t>& shape) {
    std::string s = "{";
    for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
    return s + "}";
  }
  const CheckpointSection* find(const std::string& name) const {
    for (const auto& p : sections_)
      if (p.first == name) return &p.second;
    return nullptr;
  }
  void set(const std::string& name, CheckpointSection s) {
    for (auto& p : sections_)
      if (p.first == name) {
        p.second = std::move(s);
        return;
      }
    sections_.emplace_back(name, std::move(s));
  }
  const CheckpointSection& typed(const std::string& name, DType want) const {
    const CheckpointSection& s = section(name);
    if (s.dtype != want)
      throw Error(std::string("dtype mismatch: expected ") + dtype_name(want) + ", found " + dtype_name(s.dtype),
                  {source_, std::nullopt, name});
    return s;
  }
  template <class T> T scalar(const std::string& name) const {
    const CheckpointSection& s = typed(name, dtype_of<T>());
    if (s.numel() != 1) throw Error("shape mismatch: expected a scalar, found " + shape_string(s.shape), {source_, std::nullopt, name});
    T v;
    std::memcpy(&v, s.data.data(), sizeof v);
    return v;
  }

  std::vector<std::pair<std::string, CheckpointSection>> sections_;
  std::string source_;
};

namespace detail {
inline void put_bytes(std::vector<std::uint8_t>& out, const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  out.insert(out.end(), b, b + n);
}
template <class U> void put_pod(std::vector<std::uint8_t>& out, U v) { put_bytes(out, &v, sizeof v); }

inline std::uint32_t crc32_of(const std::uint8_t* data, std::size_t n) {
  uLong c = ::crc32(0L, Z_NULL, 0);
  while (n > 0) {  // zlib takes uInt lengths
    const uInt chunk = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    c = ::crc32(c, data, chunk);
    data += chunk;
    n -= chunk;
  }
  return static_cast<std::uint32_t>(c);
}

/// Bounds-checked little-endian reader over a byte range; every failure names the file.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size, const std::string& source)
      : p_(data), end_(data + size), base_(data), source_(source) {}
  template <class U> U pod(const char* what) {
    U v;
    bytes(&v, sizeof v, what);
    return v;
  }
  void bytes(void* dst, std::size_t n, const char* what) {
    if (static_cast<std::size_t>(end_ - p_) < n)
      throw Error(std::string("corrupted: ") + what + " runs past the end of the data (offset " +
                      std::to_string(p_ - base_) + ")",
                  {source_, std::nullopt, {}});
    if (n) std::memcpy(dst, p_, n);
    p_ += n;
  }
  std::size_t offset() const { return static_cast<std::size_t>(p_ - base_); }

 private:
  const std::uint8_t *p_, *end_, *base_;
  const std::string& source_;
};
}  // namespace detail

/// The exact bytes save_checkpoint writes.
inline std::vector<std::uint8_t> serialize_checkpoint(const Checkpoint& ckpt) {
  std::vector<std::uint8_t> out;
  detail::put_bytes(out, kCheckpointMagic, 8);
  detail::put_pod<std::uint32_t>(out, kCheckpointVersion);
  detail::put_pod<std::uint32_t>(out, static_cast<std::uint32_t>(ckpt.size()));
  detail::put_pod<std::uint64_t>(out, 0);  // total size, patched below
  for (const auto& [name, s] : ckpt.sections()) {
    detail::put_pod<std::uint32_t>(out, static_cast<std::uint32_t>(name.size()));
    detail::put_bytes(out, name.data(), name.size());
    detail::put_pod<std::uint8_t>(out, static_cast<std::uint8_t>(s.dtype));
    detail::put_pod<std::uint8_t>(out, static_cast<std::uint8_t>(s.shape.size()));
    detail::put_pod<std::uint16_t>(out, 0);
    for (auto d : s.shape) detail::put_pod<std::int64_t>(out, d);
    detail::put_pod<std::uint64_t>(out, s.data.size());
    detail::put_bytes(out, s.data.data(), s.data.size());
  }
  const std::uint64_t total = out.size() + 4;
  std::memcpy(out.data() + 16, &total, 8);
  detail::put_pod<std::uint32_t>(out, detail::crc32_of(out.data(), out.size()));
  return out;
}

/// Parses and fully verifies checkpoint bytes. `source` names the origin in error messages.
inline Checkpoint parse_checkpoint(const std::uint8_t* data, std::size_t size, const std::string& source = "<memory>") {
  const ErrorContext ctx{source, std::nullopt, {}};
  constexpr std::size_t kHeader = 24, kTrailer = 4;
  if (size < 8 || std::memcmp(data, kCheckpointMagic, std::min<std::size_t>(size, 8)) != 0)
    throw Error(size < 8 ? "truncated: " + std::to_string(size) + " bytes, too short to be a maskadapt checkpoint"
                         : std::string("not a maskadapt checkpoint (bad magic)"),
                ctx);
  if (size < kHeader + kTrailer) throw Error("truncated: only " + std::to_string(size) + " bytes", ctx);
  std::uint32_t version, count;
  std::uint64_t total;
  std::memcpy(&version, data + 8, 4);
  std::memcpy(&count, data + 12, 4);
  std::memcpy(&total, data + 16, 8);
  if (version != kCheckpointVersion)
    throw Error("unsupported checkpoint version " + std::to_string(version) + " (this build reads version " +
                    std::to_string(kCheckpointVersion) + ")",
                ctx);
  if (total != size)
    throw Error(total > size ? "truncated: header says " + std::to_string(total) + " bytes, file has " + std::to_string(size)
                             : "corrupted: header says " + std::to_string(total) + " bytes, file has " + std::to_string(size),
                ctx);
  std::uint32_t stored_crc;
  std::memcpy(&stored_crc, data + size - kTrailer, 4);
  const std::uint32_t crc = detail::crc32_of(data, size - kTrailer);
  if (crc != stored_crc) throw Error("corrupted: checksum mismatch (CRC-32 of contents does not match the stored value)", ctx);

  Checkpoint ckpt;
  ckpt.set_source(source);
  detail::ByteReader r(data + kHeader, size - kHeader - kTrailer, source);
  for (std::uint32_t k = 0; k < count; ++k) {
    const auto name_len = r.pod<std::uint32_t>("section name length");
    if (name_len == 0 || name_len > 4096) throw Error("corrupted: section name length " + std::to_string(name_len), ctx);
    std::string name(name_len, '\0');
    r.bytes(name.data(), name_len, "section name");
    const ErrorContext sctx{source, std::nullopt, name};
    if (ckpt.contains(name)) throw Error("corrupted: duplicate section", sctx);
    const auto dtype = r.pod<std::uint8_t>("dtype");
    const auto rank = r.pod<std::uint8_t>("rank");
    const auto reserved = r.pod<std::uint16_t>("reserved");
    if (dtype < 1 || dtype > 4) throw Error("corrupted: unknown dtype " + std::to_string(dtype), sctx);
    if (rank > 8 || reserved != 0) throw Error("corrupted: bad rank/reserved field", sctx);
    std::vector<std::int64_t> shape(rank);
    std::uint64_t numel = 1;
    for (auto& d : shape) {
      d = r.pod<std::int64_t>("shape");
      if (d < 0 || d > (std::int64_t{1} << 40)) throw Error("corrupted: bad dimension " + std::to_string(d), sctx);
      numel *= static_cast<std::uint64_t>(d);
      if (numel > (std::uint64_t{1} << 40)) throw Error("corrupted: array too large", sctx);
    }
    const auto nbytes = r.pod<std::uint64_t>("data size");
    if (nbytes != numel * dtype_size(static_cast<DType>(dtype)))
      throw Error("corrupted: data size " + std::to_string(nbytes) + " does not match the shape", sctx);
    if (nbytes > size) throw Error("truncated: section data runs past the end", sctx);
    std::vector<std::uint8_t> bytes(nbytes);
    r.bytes(bytes.data(), nbytes, "section data");
    ckpt.put_raw(name, static_cast<DType>(dtype), std::move(shape), bytes.data(), bytes.size());
  }
  if (r.offset() != size - kHeader - kTrailer) throw Error("corrupted: trailing bytes after the last section", ctx);
  return ckpt;
}
inline Checkpoint parse_checkpoint(const std::vector<std::uint8_t>& bytes, const std::string& source = "<memory>") {
  return parse_checkpoint(bytes.data(), bytes.size(), source);
}

/// Atomically writes `ckpt` to `path` (via path + ".tmp", fsync, rename, fsync of the directory).
inline void save_checkpoint(const std::filesystem::path& path, const Checkpoint& ckpt) {
  const std::vector<std::uint8_t> bytes = serialize_checkpoint(ckpt);
  const std::string file = path.string();
  const std::string tmp = file + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(std::string("cannot open for writing: ") + std::strerror(errno), {tmp, std::nullopt, {}});
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const std::string err = std::strerror(errno);
      ::close(fd);
      ::unlink(tmp.c_str());
      throw Error("write failed: " + err, {tmp, std::nullopt, {}});
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    const std::string err = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw Error("fsync/close failed: " + err, {tmp, std::nullopt, {}});
  }
  if (::rename(tmp.c_str(), file.c_str()) != 0) {
    const std::string err = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw Error("rename failed: " + err, {file, std::nullopt, {}});
  }
  std::filesystem::path dir = path.parent_path();
  if (dir.empty()) dir = ".";
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

/// Reads and verifies a checkpoint file; throws maskadapt::Error naming the file and the problem.
inline Checkpoint load_checkpoint(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open checkpoint", {file, std::nullopt, {}});
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error("read error", {file, std::nullopt, {}});
  return parse_checkpoint(bytes, file);
}

}  // namespace maskadapt
