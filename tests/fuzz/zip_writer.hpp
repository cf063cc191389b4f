#pragma once
/// \file zip_writer.hpp
/// Test-side zip writer for the members maskadapt's own npz writer never produces: deflated
/// members (raw deflate via zlib, as NumPy's savez_compressed / Python's zipfile write them),
/// optionally with zip64 size fields and a zip64 end-of-central-directory record. Used by the npz
/// tests and to generate the fuzzers' seeds (tests/fuzz/seeds.hpp).
#include <zlib.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::test {

inline void put16(std::string& s, std::uint32_t v) {
  s += static_cast<char>(v & 0xff);
  s += static_cast<char>((v >> 8) & 0xff);
}
inline void put32(std::string& s, std::uint32_t v) {
  put16(s, v & 0xffff);
  put16(s, v >> 16);
}
inline void put64(std::string& s, std::uint64_t v) {
  put32(s, static_cast<std::uint32_t>(v));
  put32(s, static_cast<std::uint32_t>(v >> 32));
}

/// Raw deflate (no zlib header) of `data` at level 6.
inline std::string deflate_raw(const std::string& data) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("deflateInit2 failed");
  std::string out(deflateBound(&zs, static_cast<uLong>(data.size())), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw std::runtime_error("deflate did not finish");
  return out;
}

/// A zip of deflated members (name, uncompressed bytes). With `zip64`, every member's sizes are
/// 0xFFFFFFFF in the headers and live in a zip64 extra field, and the end-of-central-directory
/// record points to a zip64 one (entries 0xFFFF, size and offset 0xFFFFFFFF).
inline std::string deflated_zip(const std::vector<std::pair<std::string, std::string>>& members, bool zip64 = false) {
  const std::uint32_t version = zip64 ? 45 : 20;
  std::string z, cd;
  for (const auto& [name, data] : members) {
    const std::string packed = deflate_raw(data);
    const auto crc = static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
    const auto local = static_cast<std::uint32_t>(z.size());
    std::string extra;
    if (zip64) {
      put16(extra, 0x0001);
      put16(extra, 16);
      put64(extra, data.size());    // uncompressed
      put64(extra, packed.size());  // compressed
    }
    const std::uint32_t csize = zip64 ? 0xffffffffu : static_cast<std::uint32_t>(packed.size());
    const std::uint32_t usize = zip64 ? 0xffffffffu : static_cast<std::uint32_t>(data.size());
    // local file header
    put32(z, 0x04034b50);
    put16(z, version); put16(z, 0); put16(z, 8); put16(z, 0); put16(z, 0);
    put32(z, crc); put32(z, csize); put32(z, usize);
    put16(z, static_cast<std::uint32_t>(name.size())); put16(z, static_cast<std::uint32_t>(extra.size()));
    z += name;
    z += extra;
    z += packed;
    // central directory entry
    put32(cd, 0x02014b50);
    put16(cd, version); put16(cd, version); put16(cd, 0); put16(cd, 8); put16(cd, 0); put16(cd, 0);
    put32(cd, crc); put32(cd, csize); put32(cd, usize);
    put16(cd, static_cast<std::uint32_t>(name.size())); put16(cd, static_cast<std::uint32_t>(extra.size()));
    put16(cd, 0); put16(cd, 0); put16(cd, 0);
    put32(cd, 0); put32(cd, local);
    cd += name;
    cd += extra;
  }
  const auto cd_off = static_cast<std::uint32_t>(z.size());
  const auto entries = static_cast<std::uint32_t>(members.size());
  z += cd;
  if (zip64) {
    const auto z64 = static_cast<std::uint64_t>(z.size());
    put32(z, 0x06064b50); put64(z, 44);         // zip64 EOCD record, size of the rest
    put16(z, 45); put16(z, 45); put32(z, 0); put32(z, 0);
    put64(z, entries); put64(z, entries); put64(z, cd.size()); put64(z, cd_off);
    put32(z, 0x07064b50); put32(z, 0); put64(z, z64); put32(z, 1);  // zip64 EOCD locator
  }
  put32(z, 0x06054b50); put16(z, 0); put16(z, 0);
  put16(z, zip64 ? 0xffff : entries); put16(z, zip64 ? 0xffff : entries);
  put32(z, zip64 ? 0xffffffffu : static_cast<std::uint32_t>(cd.size()));
  put32(z, zip64 ? 0xffffffffu : cd_off);
  put16(z, 0);
  return z;
}

}  // namespace maskadapt::test
