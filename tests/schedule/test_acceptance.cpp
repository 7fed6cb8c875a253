// Acceptance of the replay as a user judges it: the hook enters the 1 mm gap (narrower than the
// tool) while the virtual tool stays on the tissue's surface.
#include <gtest/gtest.h>

#include <algorithm>

#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

using namespace ebh;

namespace {

/// The deepest point of the virtual tool and its worst penetration over a replay.
struct DepthProbe : ReplayObserver {
  double lowest_tip_z = 1e9, max_penetration = 0;
  double tip_reach = 0;  // how far below the tool's origin its lowest point lies (tool +z = world -z)
  void on_tick(const World&, const HapticSide& h, double) override {
    lowest_tip_z = std::min(lowest_tip_z, h.tool.pose.position.z - tip_reach);
    max_penetration = std::max(max_penetration, h.penetration);
  }
};

}  // namespace

TEST(Acceptance, GapInsertHookEntersTheGapWithoutPenetratingTheTissue) {
  const LoadedReplay in = load_replay_inputs("gap", "gap_insert", {}, std::nullopt, std::nullopt, false);
  const ToolSpec& tool = in.world->scene.spec.tool;
  DepthProbe probe;
  // The hook's lowest point: the straight part and the bent tip's capsule reach tip_length +
  // tip_radius past the origin along the tool's +z (tool/tool_model.hpp), pointing down here.
  probe.tip_reach = tool.hook.tip_length + tool.hook.tip_radius;
  ReplayOptions opt;
  opt.start = 2.0;     // the hook is above the blocks' top faces (z = 0) ...
  opt.duration = 2.7;  // ... and the device reaches its deepest point (z = -18 mm) at 4.5 s
  replay(*in.world, in.recording, opt, probe);
  // What the gap scene promises: the tip at least 10 mm below the top faces, penetration < 1 mm.
  EXPECT_LT(probe.lowest_tip_z, -0.010);
  EXPECT_LT(probe.max_penetration, 0.001);
}
