// The scheduler's contracts (docs/MODEL.md, "Between the two rates"): virtual-time replays are pure functions of their
// inputs (bitwise, any thread count), async delivers step k's result at tick (k+1)N, lockstep at
// once, and the output file appears only when complete.
#include <gtest/gtest.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>
#include <vector>

#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "schedule/replay_inputs.hpp"
#include "io/paths.hpp"
#include "schedule/replay_output.hpp"
#include "schedule/scheduler.hpp"
#if EBH_HAVE_CUDA
#include "schedule/haptic_cuda.hpp"
#endif

using namespace ebh;

namespace {

/// Captures everything deterministic a replay produces (timings excluded).
struct Capture : ReplayObserver {
  std::vector<double> values;               // force, torque, poses, penetration per tick
  std::vector<std::int64_t> visible_step;   // the physical step visible at each tick
  std::vector<double> step_t;
  void on_tick(const World&, const HapticSide& h, double) override {
    const Vec3d f = h.output.force, tq = h.output.torque, p = h.tool.pose.position;
    const Quatd q = h.tool.pose.orientation;
    values.insert(values.end(), {f.x, f.y, f.z, tq.x, tq.y, tq.z, p.x, p.y, p.z, q.w, q.x, q.y, q.z, h.penetration});
    for (const Vec3d& v : h.mesh.q) values.insert(values.end(), {v.x, v.y, v.z});
    visible_step.push_back(h.visible.step);
  }
  void on_step(const World&, const PhysicalSide&, double t) override { step_t.push_back(t); }
};

const LoadedReplay& tube() {
  static const LoadedReplay in = load_replay_inputs("tube", "tube_insert", {}, std::nullopt, std::nullopt, false);
  return in;
}

/// The part of tube_insert where the hook enters the bore (contacts happen), shortened.
Recording entering_bore(double seconds) {
  Recording r = tube().recording;
  // Start at 2.8 s, when the hook reaches the tube's end (x = -50 mm); keep `seconds` of it.
  std::size_t a = 0;
  while (a < r.t.size() && r.t[a] < 2.8) ++a;
  std::size_t b = a;
  while (b < r.t.size() && r.t[b] < r.t[a] + seconds) ++b;
  auto cut = [&](auto& v) { v = std::vector<typename std::decay_t<decltype(v)>::value_type>(v.begin() + a, v.begin() + b); };
  cut(r.t); cut(r.position); cut(r.orientation); cut(r.jaw); cut(r.buttons);
  return r;
}

Capture run(Mode mode, const Recording& rec, int threads, int haptic_threads = 0) {
  omp_set_num_threads(threads);
  Capture c;
  ReplayOptions opt;
  opt.mode = mode;
  opt.haptic_threads = haptic_threads;
  replay(*tube().world, rec, opt, c);
  return c;
}

}  // namespace

TEST(Scheduler, AsyncReplayIsBitwiseReproducibleAcrossRunsAndThreadCounts) {
  const Recording rec = entering_bore(0.25);
  const Capture a = run(Mode::Async, rec, 2), b = run(Mode::Async, rec, 2), c = run(Mode::Async, rec, 1);
  ASSERT_FALSE(a.values.empty());
  EXPECT_EQ(a.values, b.values);  // bitwise: std::vector<double> == compares exactly
  EXPECT_EQ(a.values, c.values);
}

TEST(Scheduler, AsyncReplayWithTheStepSharedIsBitwiseThatOfAPhysicalTeam) {
  // 2 threads: one a side, and the waiting haptic thread helps the physical step (SharedLoops);
  // 3 threads with one haptic: the step on an OpenMP team of 2.
  const Recording rec = entering_bore(0.1);
  const Capture shared = run(Mode::Async, rec, 2), team = run(Mode::Async, rec, 3, 1);
  ASSERT_FALSE(shared.values.empty());
  EXPECT_EQ(shared.values, team.values);
}

TEST(Scheduler, AsyncReplayWithAHapticTeamIsBitwiseThatOfOneThread) {
  // tube's 6628 virtual vertices are above parallel_min_vertices: 2 haptic threads iterate them as
  // a team (virtual_team), beside a 1-thread physical step.
  ASSERT_GE(tube().world->virtual_mesh.num_vertices, tube().world->virtual_mesh.parallel_min_vertices);
  const Recording rec = entering_bore(0.1);
  const Capture team = run(Mode::Async, rec, 3, 2), one = run(Mode::Async, rec, 1);
  ASSERT_FALSE(team.values.empty());
  EXPECT_EQ(team.values, one.values);
}

TEST(Scheduler, SplitsTheThreadsBetweenTheSides) {
  const int saved = omp_get_max_threads();
  auto split = [](int total, Mode mode, int haptic) {
    omp_set_num_threads(total);
    const ThreadSplit s = split_threads(mode, haptic);
    return std::pair{s.haptic, s.physical};
  };
  EXPECT_EQ(split(1, Mode::Async, 0), std::pair(1, 1));
  EXPECT_EQ(split(2, Mode::Async, 0), std::pair(1, 1));  // the 2-core machine: one each, as before
  EXPECT_EQ(split(3, Mode::Async, 0), std::pair(2, 1));
  EXPECT_EQ(split(16, Mode::Async, 0), std::pair(8, 8));
  EXPECT_EQ(split(16, Mode::Realtime, 4), std::pair(4, 12));
  EXPECT_EQ(split(16, Mode::Async, 40), std::pair(15, 1));  // the physical step keeps one
  EXPECT_EQ(split(16, Mode::Lockstep, 4), std::pair(16, 16));  // the sides take turns
  // Which side's loops the other side's thread helps with (a core for each side, async).
  auto shared = [](int total, Mode mode, int haptic) {
    omp_set_num_threads(total);
    const ThreadSplit s = split_threads(mode, haptic);
    return std::pair{s.shared_physical_loops, s.shared_virtual_loops};
  };
  EXPECT_EQ(shared(2, Mode::Async, 0), std::pair(true, true));    // the 2-core machine: both
  EXPECT_EQ(shared(1, Mode::Async, 0), std::pair(false, false));  // one core for both sides
  EXPECT_EQ(shared(3, Mode::Async, 0), std::pair(true, false));   // the haptic side has a team of 2
  EXPECT_EQ(shared(3, Mode::Async, 1), std::pair(false, true));   // the physical step has a team of 2
  EXPECT_EQ(shared(16, Mode::Async, 0), std::pair(false, false));
  EXPECT_EQ(shared(2, Mode::Realtime, 0), std::pair(false, false));
  EXPECT_EQ(shared(2, Mode::Lockstep, 0), std::pair(false, false));
  omp_set_num_threads(saved);
}

#if EBH_HAVE_CUDA
TEST(Scheduler, ADeviceReplayAloneGetsABlockPerChunkWhileAFifthOfTheMultiprocessorsStaysFree) {
  DeviceTickCapacity cap;  // an H100's or H200's 132 multiprocessors, one tick block each
  cap.multiprocessors = 132;
  cap.blocks_per_sm = 1;
  ASSERT_EQ(cap.alone_blocks(), 99);  // a quarter (33) left to the physical steps
  EXPECT_EQ(cap.alone_grid(52), 53);   // tube: below the quarter's cap
  EXPECT_EQ(cap.alone_grid(99), 100);  // cholecystectomy: a block per chunk, 32 left
  EXPECT_EQ(cap.alone_grid(104), 105);  // the most that leaves a fifth (27)
  EXPECT_EQ(cap.alone_grid(105), 99);  // past it: the quarter's cap, a block runs several chunks
  EXPECT_EQ(cap.alone_grid(208), 99);
}
#endif

TEST(Scheduler, LockstepReplayIsBitwiseReproducible) {
  const Recording rec = entering_bore(0.1);
  const Capture a = run(Mode::Lockstep, rec, 2), b = run(Mode::Lockstep, rec, 1);
  EXPECT_EQ(a.values, b.values);
}

TEST(Scheduler, AsyncDeliversStepKAtTickKPlus1TimesN) {
  const Recording rec = entering_bore(0.05);
  const Capture c = run(Mode::Async, rec, 1);
  const int N = tube().world->ticks_per_step;
  for (std::size_t n = 0; n < c.visible_step.size(); ++n) {
    const std::int64_t k = static_cast<std::int64_t>(n) / N;  // step k started at tick kN
    EXPECT_EQ(c.visible_step[n], k - 1) << "tick " << n;      // its predecessor is visible
  }
  // Step k started at t = k N h_h.
  for (std::size_t k = 0; k < c.step_t.size(); ++k)
    EXPECT_DOUBLE_EQ(c.step_t[k], static_cast<double>(k * N) * tube().world->h_haptic);
}

TEST(Scheduler, LockstepShowsEachStepAtOnce) {
  const Recording rec = entering_bore(0.05);
  const Capture c = run(Mode::Lockstep, rec, 1);
  const int N = tube().world->ticks_per_step;
  for (std::size_t n = 0; n < c.visible_step.size(); ++n)
    EXPECT_EQ(c.visible_step[n], static_cast<std::int64_t>(n) / N) << "tick " << n;
}

TEST(Scheduler, AsyncAndLockstepDifferOnlyByLatency) {
  // Same inputs, different delivery: both must touch the tissue and stay finite, and differ.
  const Recording rec = entering_bore(0.2);
  const Capture a = run(Mode::Async, rec, 2), l = run(Mode::Lockstep, rec, 2);
  ASSERT_EQ(a.values.size(), l.values.size());
  EXPECT_NE(a.values, l.values);
  for (double v : a.values) ASSERT_TRUE(std::isfinite(v));
}

TEST(Scheduler, PhysicalTargetsMoveLinearlyBetweenResults) {
  // time.interpolate_physical (default on): over the N ticks after a physical result becomes
  // visible, the E_svc targets go from the previous result to it in equal steps.
  struct Probe : ReplayObserver {
    int N = 0;
    int checked = 0;
    double worst = 0;
    void on_tick(const World& w, const HapticSide& h, double) override {
      if (h.previous_x.empty()) return;
      const std::int64_t since = h.tick - 1 - h.delivered_tick + 1;  // h.tick was advanced
      if (since >= w.ticks_per_step) return;
      const double a = static_cast<double>(since) / w.ticks_per_step;
      for (std::size_t i = 0; i < h.visible.x.size(); i += 97) {
        const Vec3d expect = h.previous_x[i] + a * (h.visible.x[i] - h.previous_x[i]);
        worst = std::max(worst, norm(h.targets_x[i] - expect));
      }
      ++checked;
    }
  } probe;
  ASSERT_TRUE(tube().world->scene.spec.interpolate_physical);
  ReplayOptions opt;
  replay(*tube().world, entering_bore(0.05), opt, probe);
  EXPECT_GT(probe.checked, 20);
  EXPECT_EQ(probe.worst, 0.0);  // the same expression in the same order: bitwise
}

// tool.newton_calls (Algorithm 2 lines 17-20 after only the last N of the V iterations): N = V is
// the default bit for bit; each tick makes N calls; the paper's configuration (3 iterations, one
// call of one Newton step) runs; and the one call of a tick is made at the tick's final virtual
// mesh: repeating it from the tool's state before the tick on the q the tick ends with gives the
// tick's pose to round-off.
TEST(Scheduler, NewtonCallsFollowTheLastVirtualIterations) {
  const Recording rec = entering_bore(0.1);
  auto world_with = [](const std::vector<std::string>& overrides) {
    return load_replay_inputs("tube", "tube_insert", overrides, std::nullopt, std::nullopt, false).world;
  };
  struct Counter : Capture {
    std::vector<int> calls;
    void on_tick(const World& w, const HapticSide& h, double t) override {
      Capture::on_tick(w, h, t);
      calls.push_back(h.newton_calls);
    }
  };
  auto capture = [&](const World& w) {
    Counter c;
    ReplayOptions opt;
    opt.mode = Mode::Lockstep;
    replay(w, rec, opt, c);
    return c;
  };
  const int V = tube().world->scene.spec.solver.virtual_iterations;
  ASSERT_GE(V, 3);
  const Counter all = capture(*tube().world);
  const Counter same = capture(*world_with({"tool.newton_calls=" + std::to_string(V)}));
  EXPECT_EQ(all.values, same.values);  // bitwise
  EXPECT_EQ(all.calls, std::vector<int>(all.calls.size(), V));
  const Counter two = capture(*world_with({"tool.newton_calls=2"}));
  EXPECT_EQ(two.calls, std::vector<int>(two.calls.size(), 2));
  EXPECT_NE(two.values, all.values);  // the knob changes the result
  const auto paper = world_with({"solver.virtual_iterations=3", "tool.newton_calls=1", "tool.newton_iterations=1"});
  const Counter p = capture(*paper);
  ASSERT_EQ(p.calls.size(), all.calls.size());
  EXPECT_EQ(p.calls, std::vector<int>(p.calls.size(), 1));
  for (double v : p.values) ASSERT_TRUE(std::isfinite(v));

  // Where the one call sits: ticks driven by hand, each checked against update_virtual_tool on the
  // tick's final q from the tool's state at the tick's start.
  const World& w = *paper;
  HapticSide h = make_haptic_side(w, sample_at(rec, rec.t.front()));
  int in_contact = 0;
  for (std::size_t n = 0; n < 100; ++n) {
    const DeviceSample sample = sample_at(rec, rec.t.front() + static_cast<double>(n) * w.h_haptic);
    VirtualToolState before = h.tool;
    VertexGrid grid = h.grid;
    haptic_tick(w, h, sample);
    before.anchor = before.pose;
    update_virtual_tool(w.tool, w.scene.spec.stiffness, {sample.position, sample.orientation}, sample.jaw, h.mesh.q,
                        {}, grid, before);
    // 1e-12: round-off only (the contact sums may run in another order when the broad phase
    // rebuilt itself within the tick); a call at another iteration's q moves the pose by the
    // virtual mesh's motion within a tick, micrometres.
    const Quatd a = before.pose.orientation, b = h.tool.pose.orientation;
    ASSERT_LE(norm(before.pose.position - h.tool.pose.position), 1e-12) << "tick " << n;
    ASSERT_LE(std::fabs(a.w - b.w) + std::fabs(a.x - b.x) + std::fabs(a.y - b.y) + std::fabs(a.z - b.z), 1e-12)
        << "tick " << n;
    in_contact += !h.tool.contacts.empty();
  }
  EXPECT_GT(in_contact, 10) << "the window must have contact, or the check above shows nothing";
}

// Realtime mode paces both sides by the wall clock; where the ticks fall behind it (3 ms each
// here), the physical steps go on, and /physical/t is still the virtual time of the ticks they ran
// on, within the replay's window (it was the wall clock: 18.6 s in a 0.3 s output).
TEST(Scheduler, RealtimeStepTimesAreVirtualWhenTheTicksFallBehind) {
  struct Slow : Capture {
    double last_t = 0;
    void on_tick(const World& w, const HapticSide& h, double t) override {
      Capture::on_tick(w, h, t);
      last_t = t;
      std::this_thread::sleep_for(std::chrono::milliseconds(3));
    }
  } slow;
  omp_set_num_threads(2);
  ReplayOptions opt;
  opt.mode = Mode::Realtime;
  opt.duration = 0.05;
  replay(*tube().world, entering_bore(0.2), opt, slow);
  ASSERT_GT(slow.step_t.size(), 5u);  // ~150 ms of wall time at 100 Hz
  for (std::size_t k = 0; k < slow.step_t.size(); ++k) {
    EXPECT_LE(slow.step_t[k], slow.last_t) << k;
    if (k > 0) {
      EXPECT_GE(slow.step_t[k], slow.step_t[k - 1]) << k;
    }
  }
}

// An error on the ticks' thread (here an observer's full disk) stops the physical thread and
// propagates: the solver's thread, still running, used to terminate the process.
TEST(Scheduler, RealtimeErrorOnTheTicksThreadPropagates) {
  struct FullDisk : Capture {
    void on_frame(const World&, const HapticSide&, double) override {
      throw InputError("out.h5: cannot write the appended rows: No space left on device");
    }
  } full;
  ReplayOptions opt;
  opt.mode = Mode::Realtime;
  opt.duration = 0.05;
  opt.frames_hz = 100;
  try {
    replay(*tube().world, entering_bore(0.2), opt, full);
    ADD_FAILURE() << "the observer's error did not propagate";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

TEST(Scheduler, TickCountCoversTheDuration) {
  const World& w = *tube().world;
  EXPECT_EQ(tick_count(w, 0.0), 1);
  EXPECT_EQ(tick_count(w, 1.0), 1001);   // ticks 0..1000 at 1 kHz
  EXPECT_EQ(tick_count(w, 0.0105), 11);  // a partial tick is not run
  // the ticks of a window replay the window, not one tick more
  EXPECT_NEAR(replayed_seconds(tick_count(w, 1.0), w.h_haptic), 1.0, 1e-12);  // 1000 x 0.001: round-off
  EXPECT_EQ(replayed_seconds(tick_count(w, 0.0), w.h_haptic), 0.0);
}

TEST(ReplayOutput, WritesTheDesignLayoutAndOnlyWhenComplete) {
  const auto dir = std::filesystem::temp_directory_path() / "ebh_test_replay_output";
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "out.h5").string();
  std::filesystem::remove(out);
  const Recording rec = entering_bore(0.05);
  const World& w = *tube().world;
  ReplayOptions opt;
  opt.frames_hz = 100;
  {
    ReplayWriter writer(out, w, ReplayMetadata{}, tick_count(w, rec.duration()), true);
    const ReplaySummary s = replay(w, rec, opt, writer);
    EXPECT_NEAR(s.virtual_s, rec.duration(), 1e-12);  // 50 x 0.001 against 0.05: round-off
    EXPECT_FALSE(std::filesystem::exists(out));  // still under its temporary name
    writer.commit(s);
  }
  ASSERT_TRUE(std::filesystem::exists(out));
  h5::File f = h5::File::open_read(out);
  const std::size_t n = f.read<double>("haptic/t").rows();
  EXPECT_EQ(n, static_cast<std::size_t>(tick_count(w, rec.duration())));
  for (const char* name : {"haptic/force", "haptic/torque", "haptic/pose_physical", "haptic/pose_virtual"})
    EXPECT_EQ(f.dataset(name).shape()[0], n) << name;
  EXPECT_EQ(f.dataset("haptic/pose_virtual").shape()[1], 7u);
  EXPECT_EQ(f.dataset("physical/iterations").shape()[0], f.dataset("timing/physical_step_s").shape()[0]);
  EXPECT_EQ(f.dataset("frames/virtual_positions").shape()[1], w.virtual_mesh.rest.size());
  EXPECT_EQ(f.attr_string("scene"), "tube");
}

// An output its disk cannot hold is refused before the replay, not after its whole run.
TEST(ReplayOutput, AnOutputLargerThanTheFreeSpaceIsRefusedFirst) {
  const World& w = *tube().world;
  const std::string out = (std::filesystem::temp_directory_path() / "ebh_free_space.h5").string();
  const std::optional<std::uint64_t> free = free_bytes_for(out);
  if (!free) GTEST_SKIP() << "the temporary folder's free space cannot be told";
  const double duration = 1000;
  const double per_frame_s = estimate_replay_size(w, duration, 1).file_bytes - estimate_replay_size(w, duration, 0).file_bytes;
  const double frames_hz = 1.5 * static_cast<double>(*free) / per_frame_s;  // 1.5 times what fits
  if (estimate_replay_size(w, duration, frames_hz).file_bytes > kMaxReplayOutputBytes)
    GTEST_SKIP() << "more free space than the output limit";
  try {
    check_replay_size(w, duration, frames_hz, "rec.h5", out);
    ADD_FAILURE() << "an output larger than the free space was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(out + ": the output takes about "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("and its folder's file system has"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(check_replay_size(w, 1.0, 0, "rec.h5", out));
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(ReplayOutput, AnInterruptedReplayLeavesNoFile) {
  const auto dir = std::filesystem::temp_directory_path() / "ebh_test_replay_interrupt";
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "out.h5").string();
  std::filesystem::remove(out);
  const Recording rec = entering_bore(0.05);
  const World& w = *tube().world;
  {
    ReplayWriter writer(out, w, ReplayMetadata{}, tick_count(w, rec.duration()), false);
    set_interrupted(true);
    const ReplaySummary s = replay(w, rec, ReplayOptions{}, writer);
    set_interrupted(false);
    EXPECT_TRUE(s.stopped);
    EXPECT_EQ(s.ticks, 1);
  }  // not committed: the destructor removes the temporary file
  EXPECT_FALSE(std::filesystem::exists(out));
  for (const auto& e : std::filesystem::directory_iterator(dir)) ADD_FAILURE() << "left behind: " << e.path();
}
