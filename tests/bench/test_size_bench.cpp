// `ebh bench sizes` (bench/size_bench.hpp): the log-log slope, and a short run of two sizes of the
// smallest committed scene on the CPU.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "../mesh/test_util.hpp"
#include "bench/size_bench.hpp"
#include "core/error.hpp"
#include "io/atomic.hpp"
#include "mesh/mesh_io.hpp"
#include "scene/scene_init.hpp"

namespace ebh {
namespace {

TEST(SizeBench, SlopeOfAPowerLaw) {
  // cost = 3 tets^1.5 exactly in log-log; a round-off of the logs only (1e-12).
  const std::vector<double> tets = {8e3, 6.4e4, 5.12e5}, cost = {3 * std::pow(8e3, 1.5), 3 * std::pow(6.4e4, 1.5),
                                                                   3 * std::pow(5.12e5, 1.5)};
  EXPECT_NEAR(log_log_slope(tets, cost), 1.5, 1e-12);
  // Least squares, not the end points: a middle point above the line leaves the slope of the ends.
  EXPECT_NEAR(log_log_slope(tets, {1, 8, 64}), 1.0, 1e-12);
  EXPECT_NEAR(log_log_slope(tets, {1, 16, 64}), 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(log_log_slope({8e3}, {1.0})));
  EXPECT_TRUE(std::isnan(log_log_slope(tets, {NAN, NAN, 2.0})));  // one usable size
  EXPECT_TRUE(std::isnan(log_log_slope({10, 10}, {1, 2})));       // one tet count
}

/// 0.05 s of tube_insert from 1.8 s (in contact) at the tube's levels first .. last.
SizeBenchOptions short_tube_window(int first, int last) {
  SizeBenchOptions o;
  o.scene = "tube";
  o.recording = "tube_insert";
  o.start = 1.8;
  o.seconds = 0.05;
  o.first_level = first;
  o.last_level = last;
  return o;
}

TEST(SizeBench, TwoSizesOfTheTube) {
  const std::vector<SizeResult> r = run_size_bench(short_tube_window(0, 1));
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].tets, 8057);
  EXPECT_EQ(r[1].tets, 8 * 8057);
  EXPECT_EQ(r[1].vertices, 14014);  // 2150 vertices + 11864 edges
  // The virtual mesh follows the refined boundary (virtual_refine 1 on top): the tube's surface is
  // a torus (Euler characteristic 0), whose vertex count grows exactly 4x a level.
  EXPECT_EQ(r[0].virtual_vertices, 6628);
  EXPECT_EQ(r[1].virtual_vertices, 4 * 6628);
  for (const SizeResult& s : r) {
    EXPECT_EQ(s.ticks, 51);  // 0.05 s at 1 kHz: ticks 0 .. 50
    EXPECT_EQ(s.steps, 6);
    EXPECT_GT(s.physical_step.median, 0);
    EXPECT_GE(s.physical_step.p99, s.physical_step.median);
    EXPECT_GT(s.haptic_tick.median, 0);
    EXPECT_GE(s.haptic_tick.p99, s.haptic_tick.median);
    EXPECT_GT(s.real_time_factor, 0);
    EXPECT_GT(s.host_peak_bytes, 0);
    EXPECT_EQ(s.device_peak_bytes, -1);
  }
  // 8x the tets is more work a step: far more than timer noise on any machine.
  EXPECT_GT(r[1].physical_step.median, 2 * r[0].physical_step.median);
}

TEST(SizeBench, OverridesApplyToEverySize) {
  SizeBenchOptions o = short_tube_window(0, 0);
  o.overrides = {"time.physical_hz=50", "solver.active_region=0.001"};
  const std::vector<SizeResult> r = run_size_bench(o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].ticks, 51);
  EXPECT_EQ(r[0].steps, 3);  // 50 Hz: ticks 0, 20, 40 (6 at the scene's 100 Hz)
}

// Steps skipped with the mesh at rest (solver.physical_region) are counted, not timed: their 0 s
// made the step's median 0 (here 5 of the window's 6 steps sleep before the tool arrives).
TEST(SizeBench, SkippedStepsAreCountedNotTimed) {
  SizeBenchOptions o = short_tube_window(0, 0);
  o.start = 0;
  o.overrides = {"solver.physical_region=0.001"};
  const std::vector<SizeResult> r = run_size_bench(o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].steps, 6);
  EXPECT_GT(r[0].skipped_steps, 0);
  EXPECT_LT(r[0].skipped_steps, r[0].steps);
  EXPECT_GT(r[0].physical_step.median, 0);
}

TEST(SizeBench, AnInterruptEndsTheRun) {
  SizeBenchOptions o;
  o.scene = "tube";
  o.recording = "tube_insert";
  o.last_level = 1;
  set_interrupted(true);  // as SIGINT would (io/atomic.hpp)
  try {
    run_size_bench(o);
    ADD_FAILURE() << "ran through an interrupt";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "interrupted at level 0; no results");
  }
  set_interrupted(false);
}

TEST(SizeBench, RefusesBeforeAnyWork) {
  SizeBenchOptions o;
  o.scene = "tube";
  o.recording = "tube_insert";
  o.last_level = 3;
  o.max_tets = 100000;
  try {
    run_size_bench(o);
    ADD_FAILURE() << "level 3 accepted under a limit of 100000 tets";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("level 3 of "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("makes 4125184 tets, over the limit of 100000"), std::string::npos) << e.what();
  }
  o.last_level = 99;
  try {
    run_size_bench(o);
    ADD_FAILURE() << "level 99 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("makes 2.05e+93 tets, over the limit of 100000"), std::string::npos) << e.what();
  }
  o.last_level = 1;
  o.overrides = {"solver.active_regio=0.001"};
  try {
    run_size_bench(o);
    ADD_FAILURE() << "a misspelt override accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'solver.active_regio': unknown key"), std::string::npos) << e.what();
  }
  o.overrides.clear();
  o.first_level = 2;
  o.last_level = 1;
  EXPECT_THROW(run_size_bench(o), InputError);
  o.last_level = 2;
  o.mode = Mode::Realtime;
  EXPECT_THROW(run_size_bench(o), InputError);
  // A window under one haptic tick of the scene (under --set) replays one tick: no cost to measure.
  o.mode = Mode::Async;
  o.first_level = o.last_level = 0;
  o.seconds = 1e-320;
  try {
    (void)check_size_bench(o);
    ADD_FAILURE() << "--seconds 1e-320 accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--seconds 1e-320: shorter than one haptic tick (0.001 s at 1000 Hz), which replays a "
                                     "single tick with no force step to measure: expected at least 0.001 s");
  }
  o.seconds = 0.005;
  EXPECT_NO_THROW((void)check_size_bench(o));
  o.overrides = {"time.haptic_hz=100", "time.physical_hz=100"};
  try {
    (void)check_size_bench(o);
    ADD_FAILURE() << "--seconds 0.005 accepted at 100 Hz";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--seconds 0.005: shorter than one haptic tick (0.01 s at 100 Hz)"), std::string::npos)
        << e.what();
  }
}

// The limit is checked on the mesh as the scene loads it and as each size refines it: without the
// speck that mesh.min_part_tets drops (`scene init` writes it), 1200 tets at level 0 and 9600 at
// level 1, where the speck's 6 counted once made 9648 and a limit of 9600 refused the run.
TEST(SizeBench, TheLimitCountsTheSceneWithoutTheSpecksItDrops) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "ebh_size_bench_specks";
  std::filesystem::create_directories(dir);
  SceneInitOptions init;
  init.mesh = dir / "specks.msh";
  init.out = dir / "specks.yaml";
  std::ofstream(init.mesh, std::ios::binary) << msh22_text(test::block_with_a_speck(50));
  std::ofstream(init.out, std::ios::binary) << make_scene(init).yaml;
  SizeBenchOptions o;
  o.scene = init.out.string();
  o.recording = "tube_insert";
  o.seconds = 0.05;
  o.last_level = 1;
  o.max_tets = 9600;
  EXPECT_NO_THROW((void)check_size_bench(o));
  o.max_tets = 9599;
  try {
    (void)check_size_bench(o);
    ADD_FAILURE() << "9600 tets accepted under a limit of 9599";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("makes 9600 tets, over the limit of 9599"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ebh
