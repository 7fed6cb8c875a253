// The replay's health checks (schedule/simulation.hpp): a physical mesh that diverges stops the
// replay with a NumericalError naming the tick, the step and the worst element, in every
// virtual-time mode; the bounded diagonal replays the same mesh without one.
#include <gtest/gtest.h>

#include <string>

#include "io/error.hpp"
#include "mesh/degrade.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

using namespace ebh;

namespace {

struct Count : ReplayObserver {
  int ticks = 0;
  void on_tick(const World&, const HapticSide&, double) override { ++ticks; }
};

/// tube with its physical mesh degraded to a worst mean ratio of 0.02, the given diagonal.
std::shared_ptr<const World> degraded_tube(const std::string& diagonal) {
  Scene scene = load_scene(resolve_scene_path("tube"), {"solver.diagonal=" + diagonal});
  DegradeOptions d;
  d.target_quality = 0.02;
  degrade_physical_mesh(scene, d);
  return build_world(std::move(scene), 1000, 100);
}

TEST(Health, ADivergingPhysicalMeshStopsTheReplayNamingTickStepAndElement) {
  const Recording rec = read_recording(resolve_recording_path("tube_insert"));
  const auto plain = degraded_tube("plain");
  for (Mode mode : {Mode::Async, Mode::Lockstep}) {
    Count count;
    ReplayOptions opt;
    opt.mode = mode;
    opt.duration = 0.5;
    try {
      replay(*plain, rec, opt, count);
      FAIL() << "the plain diagonal on slivers should diverge (" << mode_name(mode) << ")";
    } catch (const NumericalError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("tube.yaml: tick "), std::string::npos) << m;
      EXPECT_NE(m.find(", physical step "), std::string::npos) << m;
      EXPECT_TRUE(m.find("the physical mesh diverged") != std::string::npos ||
                  m.find("the physical mesh is not finite") != std::string::npos) << m;
      EXPECT_NE(m.find("its worst tet"), std::string::npos) << m;
      EXPECT_NE(m.find("use bounded"), std::string::npos) << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    EXPECT_LT(count.ticks, 500) << mode_name(mode);  // stopped early, not at the end
  }
  Count count;
  ReplayOptions opt;
  opt.duration = 0.5;
  EXPECT_NO_THROW(replay(*degraded_tube("bounded"), rec, opt, count));
  EXPECT_EQ(count.ticks, 501);
}

}  // namespace
