// The sleeping physical mesh in whole replays (solver.sleep; schedule/simulation.cpp): 0 runs every
// step, a step is skipped only while nothing moved, the tool's contact wakes the mesh, replays stay
// bitwise reproducible across runs and OpenMP thread counts, and the forces stay the full solve's.
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
#if EBH_HAVE_CUDA
#include "solver/physical_mesh_cuda.hpp"
#endif

using namespace ebh;
using namespace ebh::test;

namespace {

/// tube_insert with solver.sleep = `sleep` (mm, the tube's unit).
Capture run(const std::string& sleep, double start, double duration, int threads = 0) {
  return run_tube_insert("solver.sleep=" + sleep, start, duration, threads);
}

}  // namespace

// The tool's approach (no contact in the first 2 s): after the first steps the mesh sleeps, and the
// forces are the full solve's to round-off (a held step differs from the full one by less than the
// sleep length, 1 um here, whose force through k_svc and k_vcs is far below a micronewton).
TEST(Sleeping, ARestingMeshSleepsAndTheForcesAreTheFullSolves) {
  const Capture full = run("0", 0.0, 2.0);
  const Capture asleep = run("0.001", 0.0, 2.0);
  ASSERT_EQ(full.force.size(), asleep.force.size());
  EXPECT_EQ(full.slept_steps(), 0);
  EXPECT_GT(asleep.slept_steps(), static_cast<int>(asleep.slept.size()) / 4) << "the approach must let the mesh sleep";
  for (std::size_t k = 0; k < asleep.slept.size(); ++k) {
    if (asleep.slept[k]) {
      EXPECT_EQ(asleep.iterations[k], 0) << "step " << k;
    }
  }
  EXPECT_EQ(asleep.slept.front(), 0) << "the first step always runs";
  EXPECT_LT(max_force_difference(full, asleep), 1e-9);
}

// In contact the tool moves the virtual mesh by more than the sleep length every period: no step
// that follows a tick in contact sleeps, and the replay matches the full solve.
TEST(Sleeping, ContactWakesTheMesh) {
  const Capture full = run("0", 2.8, 0.6);
  const Capture asleep = run("0.001", 2.8, 0.6);
  const int N = static_cast<int>(asleep.force.size() / std::max<std::size_t>(asleep.slept.size(), 1));
  int in_contact = 0, slept_in_contact = 0;
  for (std::size_t k = 1; k < asleep.slept.size(); ++k) {
    bool contact = false;  // any tick of the period before step k
    for (std::size_t n = (k - 1) * N; n < k * N && n < asleep.contacts.size(); ++n) contact = contact || asleep.contacts[n] > 0;
    in_contact += contact;
    slept_in_contact += contact && asleep.slept[k];
  }
  EXPECT_GT(in_contact, 20) << "the window must be in contact";
  EXPECT_EQ(slept_in_contact, 0);
  EXPECT_LT(max_force_difference(full, asleep), 1e-9);
}

// Whether a step sleeps is decided from the replay's own deterministic state: the same bits on a
// second run and with one OpenMP thread instead of two.
TEST(Sleeping, ReplaysStayBitwiseReproducible) {
  const Capture a = run("0.01", 0.0, 1.5, 2);
  const Capture b = run("0.01", 0.0, 1.5, 2);
  const Capture c = run("0.01", 0.0, 1.5, 1);
  ASSERT_GT(a.slept_steps(), 0);
  expect_same_bits(a, b);
  expect_same_bits(a, c);
}

TEST(Sleeping, ANegativeLengthIsAnErrorNamingTheKey) {
  expect_load_error_naming({"solver.sleep=-1"}, "solver.sleep");
}

// The CUDA backend sleeps where its build has graph conditional nodes (CUDA 13; the device
// decides: tests/cuda, CudaReplay.SleepingSkipsTheStepsOfARestingMesh); other builds warn once and
// run every step.
TEST(Sleeping, TheCudaBackendSleepsWhereItsBuildCanAndWarnsElsewhere) {
  const LoadedReplay in = load_tube_insert("solver.sleep=0.01", Backend::Cuda);
#if EBH_HAVE_CUDA
  const bool can = CudaPhysicalSolver::can_sleep();
#else
  const bool can = false;
#endif
  EXPECT_EQ(in.world->scene.spec.solver.sleep, can ? 1e-5 : 0.0);  // 0.01 mm
  EXPECT_EQ(one_line_warnings_naming(in, "solver.sleep"), can ? 0 : 1);
}
