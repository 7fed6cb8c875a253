// `ebh bench sizes --backend cuda` (bench/size_bench.hpp): two sizes of the tube on the device,
// with the device memory each takes (skipped without a device).
#include <gtest/gtest.h>

#include <string>

#include "bench/size_bench.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif

namespace {
using namespace ebh;

#if EBH_HAVE_CUDA
TEST(CudaSizes, TwoSizesOfTheTubeOnTheDevice) {
  std::string why;
  if (!cuda_device_available(&why)) GTEST_SKIP() << why;
  SizeBenchOptions o;
  o.scene = "tube";
  o.recording = "tube_insert";
  o.start = 1.8;
  o.seconds = 0.2;
  o.first_level = 0;
  o.last_level = 1;
  o.backend = Backend::Cuda;
  const std::vector<SizeResult> r = run_size_bench(o);
  ASSERT_EQ(r.size(), 2u);
  for (const SizeResult& s : r) {
    EXPECT_EQ(s.ticks, 201);
    EXPECT_EQ(s.steps, 21);
    EXPECT_GT(s.physical_step.median, 0);
    EXPECT_GT(s.haptic_tick.median, 0);
    EXPECT_GT(s.real_time_factor, 0);
    // The device solvers hold the mesh, its model and the iterates: megabytes at the least.
    EXPECT_GT(s.device_peak_bytes, 1 << 20) << "level " << s.level;
  }
  // 8x the tets: more device memory (the model is per tet), whatever the allocator's granularity.
  EXPECT_GT(r[1].device_peak_bytes, r[0].device_peak_bytes);
}
#endif

}  // namespace
