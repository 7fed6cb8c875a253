// The physical mesh's awake region in whole replays (solver.physical_region; schedule/simulation.cpp,
// solver/physical_region.hpp): a resting mesh skips its steps, the tool's contact wakes the tissue
// under it and no more, the forces stay near the whole mesh's, replays stay bitwise reproducible
// across runs and OpenMP thread counts, and the key's errors and the CUDA backend's warning.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"
#include "tube_capture.hpp"

using namespace ebh;
using namespace ebh::test;

namespace {

/// tube_insert with solver.physical_region = `d` (mm, the tube's unit).
Capture run(const std::string& d, double start, double duration, int threads = 0) {
  return run_tube_insert("solver.physical_region=" + d, start, duration, threads);
}

}  // namespace

// The tool's approach and entry (contact from about 1.6 s): while the tool is away the mesh's steps
// are skipped once it has come to rest; in contact the steps iterate a region, not the mesh; the
// forces stay within two millinewtons of the whole mesh's.
TEST(PhysicalRegionReplay, ContactWakesARegionAndTheForcesStayTheWholeMeshs) {
  const Capture whole = run("0", 0.0, 2.5);
  const Capture region = run("0.001", 0.0, 2.5);
  ASSERT_EQ(whole.force.size(), region.force.size());
  for (const int a : whole.awake) EXPECT_EQ(a, -1) << "the region is off";
  ASSERT_FALSE(region.awake.empty());
  EXPECT_EQ(region.awake.front(), region.free) << "the first step iterates every vertex";
  int skipped = 0, partial = 0;
  for (std::size_t k = 0; k < region.awake.size(); ++k) {
    skipped += region.slept[k];
    EXPECT_EQ(region.slept[k] != 0, region.awake[k] == 0) << "step " << k;
    partial += region.awake[k] > 0 && region.awake[k] < region.free;
  }
  EXPECT_GT(skipped, 20) << "the approach must let the mesh rest";
  EXPECT_GT(partial, 20) << "the contact must wake a region";
  int in_contact = 0;
  for (const int c : region.contacts) in_contact += c > 0;
  ASSERT_GT(in_contact, 300) << "the window must hold contact";
  EXPECT_LT(max_force_difference(whole, region), 2e-3);  // 0.7 mN when written
}

// Who is awake is decided from the replay's own deterministic state: the same bits on a second run
// and with one OpenMP thread instead of two.
TEST(PhysicalRegionReplay, ReplaysStayBitwiseReproducible) {
  const Capture a = run("0.001", 1.5, 1.0, 2);
  const Capture b = run("0.001", 1.5, 1.0, 2);
  const Capture c = run("0.001", 1.5, 1.0, 1);
  expect_same_bits(a, b);
  expect_same_bits(a, c);
}

TEST(PhysicalRegionReplay, ANegativeLengthIsAnErrorNamingTheKey) {
  expect_load_error_naming({"solver.physical_region=-1"}, "solver.physical_region");
}

// The direct method solves every vertex at once: a region with it is refused, naming the key.
TEST(PhysicalRegionReplay, TheDirectMethodRefusesARegion) {
  expect_load_error_naming({"solver.physical_region=0.001", "solver.method=direct"}, "solver.physical_region");
}

// The CUDA backend keeps the region (its step iterates it at the grain of its patches): no warning.
TEST(PhysicalRegionReplay, TheCudaBackendKeepsIt) {
  const LoadedReplay in = load_tube_insert("solver.physical_region=0.001", Backend::Cuda);
  EXPECT_DOUBLE_EQ(in.world->scene.spec.solver.physical_region, 1e-6);
  EXPECT_EQ(one_line_warnings_naming(in, "solver.physical_region"), 0);
}
