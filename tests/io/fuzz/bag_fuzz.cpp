// Mutation test of the ROS bag reader (io/rosbag.cpp): the bags of tests/data/io (ROS 1:
// uncompressed, bz2, lz4; ROS 2 MCAP: zstd, uncompressed) are mutated at random (fixed seed: every run is the same) and each result must either
// read or throw InputError. Built with AddressSanitizer and UBSan (tests/fuzz.cmake), so an
// out-of-bounds read, an overflow or an allocation sized by a damaged length fails the run.
//
// usage: test_bag_fuzz DATA_DIR [MUTATIONS]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <unistd.h>

#include "core/error.hpp"
#include "io/rosbag.hpp"

namespace fs = std::filesystem;

namespace {

using Rng = std::mt19937_64;

std::size_t pick(Rng& rng, std::size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); }

void mutate_once(std::string& s, Rng& rng) {
  // Lengths and counts a damaged bag may name: past the record, past 1 GiB, the most a field holds.
  static const std::uint32_t kLengths[] = {0, 1, 3, 4, 0x7fffffffu, 0x80000000u, 0xffffffffu, 0x40000001u, 1u << 20};
  switch (pick(rng, 5)) {
    case 0:  // truncate
      s.resize(pick(rng, s.size() + 1));
      break;
    case 1: {  // garbage bytes
      const std::size_t n = 1 + pick(rng, 8);
      for (std::size_t k = 0; k < n && !s.empty(); ++k) s[pick(rng, s.size())] = static_cast<char>(pick(rng, 256));
      break;
    }
    case 2: {  // a 4-byte little-endian length or count replaced
      if (s.size() < 4) break;
      const std::uint32_t v = kLengths[pick(rng, sizeof kLengths / sizeof *kLengths)];
      std::memcpy(&s[pick(rng, s.size() - 3)], &v, 4);
      break;
    }
    case 3:  // bytes deleted
      if (!s.empty()) s.erase(pick(rng, s.size()), 1 + pick(rng, 16));
      break;
    default:  // a byte inserted
      s.insert(pick(rng, s.size() + 1), 1, static_cast<char>(pick(rng, 256)));
      break;
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: test_bag_fuzz DATA_DIR [MUTATIONS]\n");
    return 2;
  }
  const fs::path dir = argv[1];
  const long mutations = argc > 2 ? std::atol(argv[2]) : 2000;
  const fs::path tmp = fs::temp_directory_path() / ("ebh_bag_fuzz_" + std::to_string(getpid()) + ".bag");
  Rng rng(20261202);
  long read = 0, refused = 0;
  for (const char* name :
       {"sample.bag", "sample_bz2.bag", "sample_lz4.bag", "topics.bag", "tf_chain.bag", "sample.mcap", "sample_none.mcap"}) {
    std::ifstream in(dir / name, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string good = ss.str();
    if (good.empty()) {
      std::fprintf(stderr, "test_bag_fuzz: cannot read %s\n", (dir / name).c_str());
      return 2;
    }
    const bool topics = std::strcmp(name, "topics.bag") == 0, mcap = std::strstr(name, ".mcap") != nullptr;
    const bool chain = std::strcmp(name, "tf_chain.bag") == 0;
    for (long k = 0; k < mutations; ++k) {
      std::string s = good;
      const std::size_t n = 1 + pick(rng, 3);
      for (std::size_t m = 0; m < n; ++m) mutate_once(s, rng);
      std::ofstream(tmp, std::ios::binary).write(s.data(), static_cast<std::streamsize>(s.size()));
      try {
        (void)ebh::read_rosbag(tmp.string(),
                               chain    ? ebh::BagRequest{"", "", "tool", "", "", ""}
                               : topics ? ebh::BagRequest{"", "/psm1/joint_states", "psm1_tool", "jaw", "/touch/buttons", ""}
                               : mcap ? ebh::BagRequest{"", "/psm/jaw/measured_js", "psm1_tool", "jaw", "/touch/buttons", ""}
                                      : ebh::BagRequest{"", "/psm/jaw/measured_js", "", "", "", ""});
        ++read;
      } catch (const ebh::InputError&) {
        ++refused;
      }
    }
  }
  fs::remove(tmp);
  std::printf("test_bag_fuzz: %ld mutated bags: %ld read, %ld refused\n", read + refused, read, refused);
  return read > 0 && refused > 0 ? 0 : 1;
}
