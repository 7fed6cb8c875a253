// WorldCache (schedule/simulation.hpp): replays whose scenes differ only in the virtual tool's
// stiffnesses share one built world (ebh replay --batch builds each scene once), a world derived
// that way replays bitwise as one built on its own, and every other difference builds its own.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "core/error.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"
#include "tool/surface_contact.hpp"

using namespace ebh;

namespace {

SceneSpec spec_of(const std::string& scene, const std::vector<std::string>& overrides) {
  return load_scene_spec(resolve_scene_path(scene), overrides);
}

struct Capture : ReplayObserver {
  std::vector<Vec3d> force, torque;
  std::vector<Vec3d> x;  // the last step's physical positions
  void on_tick(const World&, const HapticSide& h, double) override {
    force.push_back(h.output.force);
    torque.push_back(h.output.torque);
  }
  void on_step(const World&, const PhysicalSide& p, double) override { x = p.mesh.x; }
};

Capture run(const World& world, const Recording& recording) {
  ReplayOptions opt;
  opt.start = 1.8;  // tube_insert: the hook in the tube
  opt.duration = 0.4;
  Capture c;
  replay(world, recording, opt, c);
  return c;
}

bool same_bits(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3d)) == 0;
}

}  // namespace

TEST(WorldCache, ReplaysThatDifferInTheToolsStiffnessesShareOneWorld) {
  WorldCache cache;
  const auto a = cache.get(spec_of("tube", {}), 1000, 100, Backend::Cpu);
  const auto again = cache.get(spec_of("tube", {}), 1000, 100, Backend::Cpu);
  EXPECT_EQ(a.get(), again.get());  // the same scene: the same object
  const auto b = cache.get(spec_of("tube", {"stiffness.k_con=800", "stiffness.k_vcs=150", "stiffness.k_vct=0.2"}),
                           1000, 100, Backend::Cpu);
  EXPECT_EQ(cache.built(), 1);
  ASSERT_NE(a.get(), b.get());
  EXPECT_EQ(b->scene.spec.stiffness.k_con, 800);
  EXPECT_EQ(b->scene.spec.stiffness.k_vcs, 150);
  EXPECT_EQ(b->scene.spec.stiffness.k_vct, 0.2);
  EXPECT_EQ(b->scene.spec.stiffness.k_vol, a->scene.spec.stiffness.k_vol);
  EXPECT_EQ(b->physical_mesh.num_tets, a->physical_mesh.num_tets);
  EXPECT_EQ(b->physical_mesh.diag, a->physical_mesh.diag);
  EXPECT_EQ(b->scene.warnings, a->scene.warnings);
}

TEST(WorldCache, OtherKeysAndOtherRatesBuildTheirOwnWorld) {
  WorldCache cache;
  const auto a = cache.get(spec_of("tube", {}), 1000, 100, Backend::Cpu);
  const auto b = cache.get(spec_of("tube", {"stiffness.k_vol=4000"}), 1000, 100, Backend::Cpu);
  const auto c = cache.get(spec_of("tube", {}), 1000, 50, Backend::Cpu);
  const auto d = cache.get(spec_of("tube", {"solver.physical_iterations=12"}), 1000, 100, Backend::Cpu);
  EXPECT_EQ(cache.built(), 4);
  EXPECT_NE(a->physical_mesh.k_vol, b->physical_mesh.k_vol);
  EXPECT_EQ(c->ticks_per_step, 20);
  EXPECT_EQ(d->physical_params.iterations, 12);
}

// A world the cache derived (another k_con, with surface contact, whose samples' stiffness comes
// from k_con) replays tick for tick to the bit as the world built on its own.
TEST(WorldCache, ADerivedWorldReplaysBitwiseAsOneBuiltOnItsOwn) {
  const std::vector<std::string> first{"contact=surface"}, second{"contact=surface", "stiffness.k_con=650"};
  WorldCache cache;
  RecordingFile rec = read_replay_recording("tube_insert");
  const LoadedReplay base = load_replay_scene(RecordingFile(rec), "tube", first, std::nullopt, std::nullopt, false,
                                              Backend::Cpu, {}, &cache);
  const LoadedReplay derived = load_replay_scene(RecordingFile(rec), "tube", second, std::nullopt, std::nullopt, false,
                                                 Backend::Cpu, {}, &cache);
  EXPECT_EQ(cache.built(), 1);
  const LoadedReplay alone = load_replay_inputs("tube", "tube_insert", second, std::nullopt, std::nullopt, false);
  ASSERT_TRUE(derived.world->tool.surface && alone.world->tool.surface);
  EXPECT_EQ(derived.world->tool.surface->stiffness_factor, alone.world->tool.surface->stiffness_factor);
  EXPECT_NE(derived.world->tool.surface->stiffness_factor, base.world->tool.surface->stiffness_factor);
  const Capture d = run(*derived.world, derived.recording), s = run(*alone.world, alone.recording),
                b = run(*base.world, base.recording);
  ASSERT_GT(d.force.size(), 100u);
  EXPECT_TRUE(same_bits(d.force, s.force));
  EXPECT_TRUE(same_bits(d.torque, s.torque));
  EXPECT_TRUE(same_bits(d.x, s.x));
  EXPECT_FALSE(same_bits(d.force, b.force));  // k_con matters here: the replay is in contact
}

// A world that cannot be built fails every replay that needs it, also those that waited for it
// on other threads, with the one-line error.
TEST(WorldCache, AWorldThatFailsFailsEveryReplayThatNeedsIt) {
  WorldCache cache;
  std::vector<std::string> errors(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] {
      try {
        cache.get(spec_of("tube", {"stiffness.k_con=" + std::to_string(400 + i)}), 1000, 300, Backend::Cpu);
      } catch (const InputError& e) {
        errors[i] = e.what();
      }
    });
  for (std::thread& t : threads) t.join();
  for (const std::string& e : errors) {
    EXPECT_NE(e.find("whole number of ticks"), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos);
  }
  EXPECT_EQ(cache.built(), 1);
}
