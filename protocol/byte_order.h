// Little-endian load and store of integers: the one byte order every Loam file and message
// uses (wire frames, log segments, region payloads, snapshots, stamp images).
//
// The functions take raw pointers and do no bounds checks: the caller has already checked
// that sizeof(T) bytes are there (ReadStream::bits, the codec's `need`). Unaligned pointers
// are fine. On a little-endian host each call is one memcpy, which compilers lower to a
// single load or store, so the codec's hot loops may call them per sample.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

namespace loam {

static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big,
              "mixed-endian hosts are not supported");

namespace byte_order_detail {
// std::byteswap is C++23; only a big-endian host needs this.
template <typename U>
constexpr U byteswap(U u) {
  U r = 0;
  for (size_t i = 0; i < sizeof(U); ++i) {
    if constexpr (sizeof(U) > 1) r = static_cast<U>(r << 8);
    r = static_cast<U>(r | (u & 0xFFu));
    if constexpr (sizeof(U) > 1) u = static_cast<U>(u >> 8);
  }
  return r;
}
}  // namespace byte_order_detail

// Writes v as sizeof(T) little-endian bytes at p.
template <typename T>
requires(std::is_integral_v<T> && !std::is_same_v<T, bool>) inline void store_le(uint8_t* p, T v) {
  using U = std::make_unsigned_t<T>;
  U u = static_cast<U>(v);
  if constexpr (std::endian::native == std::endian::big) u = byte_order_detail::byteswap(u);
  std::memcpy(p, &u, sizeof u);
}

// Reads sizeof(T) little-endian bytes at p.
template <typename T>
requires(std::is_integral_v<T> && !std::is_same_v<T, bool>) inline T load_le(const uint8_t* p) {
  using U = std::make_unsigned_t<T>;
  U u;
  std::memcpy(&u, p, sizeof u);
  if constexpr (std::endian::native == std::endian::big) u = byte_order_detail::byteswap(u);
  return static_cast<T>(u);
}

// Appends v to out as sizeof(T) little-endian bytes.
template <typename T>
requires(std::is_integral_v<T> && !std::is_same_v<T, bool>) inline void append_le(std::vector<uint8_t>& out,
                                                                                  T v) {
  const size_t at = out.size();
  out.resize(at + sizeof(T));
  store_le<T>(out.data() + at, v);
}

}  // namespace loam
