#pragma once
// splitmix64 (Steele, Lea & Flood 2014): a tiny generator that gives the same numbers on every
// platform (std:: distributions differ between standard libraries), for everything that must be
// reproducible from a seed: synthetic trajectories, degraded meshes, Lanczos start vectors.
#include <cstdint>

namespace ebh {

struct SplitMix64 {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  ///< [0, 1)
};

}  // namespace ebh
