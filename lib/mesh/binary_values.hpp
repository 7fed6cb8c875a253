#pragma once
// The binary numbers of the mesh readers (VTK legacy and XML, PLY): an integer or a float of 1-8
// bytes in either byte order. Internal to lib/mesh (the readers); the caller has checked that the
// bytes are there.
#include <bit>
#include <climits>
#include <cstdint>

namespace ebh::detail {

/// The `bytes` bytes at `p` as an unsigned integer, the file's byte order being big- or little-endian.
inline std::uint64_t load_bits(const char* p, int bytes, bool big_endian) {
  std::uint64_t u = 0;
  for (int k = 0; k < bytes; ++k) u = (u << 8) | static_cast<unsigned char>(p[big_endian ? k : bytes - 1 - k]);
  return u;
}

/// The float (4 bytes) or double (8) whose bits are `u`.
inline double bits_as_real(std::uint64_t u, int bytes) {
  return bytes == 4 ? static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(u))) : std::bit_cast<double>(u);
}

/// The integer of `bytes` bytes whose bits are `u`: sign-extended, or an unsigned one past the
/// signed range as LLONG_MAX (out of every range a reader checks).
inline long long bits_as_integer(std::uint64_t u, int bytes, bool is_signed) {
  if (!is_signed) return u > static_cast<std::uint64_t>(LLONG_MAX) ? LLONG_MAX : static_cast<long long>(u);
  const int shift = 64 - 8 * bytes;
  return static_cast<long long>(static_cast<std::int64_t>(u << shift) >> shift);
}

}  // namespace ebh::detail
