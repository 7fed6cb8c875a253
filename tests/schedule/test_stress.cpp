// Numerical stability under abuse: a device trajectory far harsher than a surgeon's hand (1 m/s
// plunges, 40 Hz shaking, fast twisting) and a ten times stiffer contact. Nothing may become
// non-finite, the tissue must not blow up, and the device output must respect its limit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

using namespace ebh;

namespace {

/// 0.6 s at 1 kHz in the tube scene's frame: the hook plunges into the bore at 1 m/s, then shakes
/// +-5 mm at 40 Hz sideways and twists +-20 deg at 10 Hz about its axis.
Recording violent_tube_recording() {
  Recording r;
  r.scene = "tube";
  r.tool = "hook";
  r.description = "stress test";
  const double pi = std::numbers::pi;
  for (int i = 0; i <= 600; ++i) {
    const double t = i * 1e-3;
    const double x = std::min(-0.080 + 1.0 * t, -0.020);  // along the bore, stops 30 mm inside
    const double shake = t > 0.06 ? 0.005 * std::sin(2 * pi * 40 * t) : 0.0;
    const double twist = 20.0 * pi / 180.0 * std::sin(2 * pi * 10 * t);
    r.t.push_back(t);
    r.position.push_back({x, shake, 0.5 * shake});
    // tool +z along world +x (90 deg about y), then the twist about the tool's own axis
    r.orientation.push_back(quat_from_rotvec(Vec3d{0, pi / 2, 0}) * quat_from_rotvec(Vec3d{0, 0, twist}));
    r.jaw.push_back(1.0);
    r.buttons.push_back(0);
  }
  return r;
}

struct Watch : ReplayObserver {
  bool finite = true;
  double max_force = 0, max_penetration = 0, max_displacement = 0;
  const World* world = nullptr;
  void on_tick(const World& w, const HapticSide& h, double) override {
    world = &w;
    for (double v : {h.output.force.x, h.output.force.y, h.output.force.z, h.output.torque.x, h.output.torque.y,
                     h.output.torque.z, h.tool.pose.position.x, h.tool.pose.position.y, h.tool.pose.position.z})
      finite = finite && std::isfinite(v);
    max_force = std::max(max_force, norm(h.output.force));
    max_penetration = std::max(max_penetration, h.penetration);
    for (std::size_t i = 0; i < h.mesh.q.size(); ++i) {
      finite = finite && std::isfinite(h.mesh.q[i].x) && std::isfinite(h.mesh.q[i].y) && std::isfinite(h.mesh.q[i].z);
      max_displacement = std::max(max_displacement, norm(h.mesh.q[i] - w.virtual_mesh.rest[i]));
    }
  }
};

Watch run(const std::vector<std::string>& overrides) {
  const LoadedReplay in = load_replay_inputs("tube", "tube_insert", overrides, std::nullopt, std::nullopt, false);
  Watch w;
  replay(*in.world, violent_tube_recording(), ReplayOptions{}, w);
  std::printf("[ stress ] max |F| %.3f N, max penetration %.3f mm, max virtual-vertex displacement %.3f mm\n",
              w.max_force, 1e3 * w.max_penetration, 1e3 * w.max_displacement);
  return w;
}

}  // namespace

TEST(Stress, ViolentTrajectoryStaysFiniteAndBounded) {
  const Watch w = run({});
  EXPECT_TRUE(w.finite);
  EXPECT_LE(w.max_force, 3.3 + 1e-12);   // the device limit (force_limit), clamped
  EXPECT_GT(w.max_force, 0.5);           // it did hit the tissue hard
  // The tube's bore is 6.8 mm wide and its wall 6.6 mm thick: a virtual vertex moving more than
  // 25 mm from rest would mean the tissue blew up, not that it was pushed.
  EXPECT_LT(w.max_displacement, 0.025);
  EXPECT_LT(w.max_penetration, 0.005);   // the virtual tool stays near the surface (bore radius 3.4 mm)
}

TEST(Stress, TenTimesStifferContactStaysFinite) {
  const Watch w = run({"stiffness.k_con=4000"});
  EXPECT_TRUE(w.finite);
  EXPECT_LE(w.max_force, 3.3 + 1e-12);
  EXPECT_LT(w.max_displacement, 0.025);
}
