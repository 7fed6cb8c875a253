#pragma once
// SHA-256 (FIPS 180-4), for the replay output's provenance: the digest of every input file, so a
// result can be traced to the exact bytes it came from (docs/FORMATS.md, "Replay output"). No linked library provides
// one (HDF5, yaml-cpp and Eigen do not), and the algorithm is short.
#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>

namespace ebh {

/// Incremental SHA-256: update() with any number of byte runs, then hex() (64 lowercase digits).
class Sha256 {
 public:
  Sha256();
  void update(std::span<const std::uint8_t> bytes);
  void update(std::string_view bytes);
  /// The digest of everything given so far; the object must not be updated afterwards.
  std::array<std::uint8_t, 32> digest();
  std::string hex();

 private:
  void block(const std::uint8_t* p);
  std::array<std::uint32_t, 8> h_;
  std::array<std::uint8_t, 64> buf_{};
  std::size_t buffered_ = 0;
  std::uint64_t length_ = 0;  ///< bytes given so far
};

/// The hex SHA-256 of a string's bytes.
std::string sha256_hex(std::string_view bytes);

/// The hex SHA-256 of a file's contents. Throws InputError "PATH: cannot read: why".
std::string sha256_file(const std::string& path);

/// sha256_file through `cache` (path -> digest): a path in it is not read again, another is read
/// and added.
const std::string& sha256_file_cached(std::map<std::string, std::string>& cache, const std::string& path);

}  // namespace ebh
