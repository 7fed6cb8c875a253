// The replay's health checks (schedule/simulation.hpp): a physical mesh that diverges stops the
// replay with a NumericalError naming the tick, the step and the worst element, in every
// virtual-time mode; the bounded diagonal replays the same mesh without one; the recovery redoes
// the steps the iterations leave unconverged with the direct solve, which is then what it gives.
#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "core/error.hpp"
#include "mesh/degrade.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

using namespace ebh;

namespace {

struct Count : ReplayObserver {
  int ticks = 0;
  void on_tick(const World&, const HapticSide&, double) override { ++ticks; }
};

struct Forces : ReplayObserver {
  std::vector<Vec3d> force;
  int steps = 0, recovered = 0;
  void on_tick(const World&, const HapticSide& h, double) override { force.push_back(h.output.force); }
  void on_step(const World&, const PhysicalSide& p, double) override {
    ++steps;
    recovered += p.recovered ? 1 : 0;
  }
};

/// tube with its physical mesh degraded to a worst mean ratio of 0.02, the given diagonal and
/// recovery ("none" or "direct").
std::shared_ptr<const World> degraded_tube(const std::string& diagonal, const std::string& recovery = "none") {
  Scene scene = load_scene(resolve_scene_path("tube"), {"solver.diagonal=" + diagonal, "solver.recovery=" + recovery});
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

// The stop names what the user can change on the backend that ran the step: the CUDA backend has
// neither the direct method nor the recovery, so it points at the CPU backend's recovery; fixed
// iterations (no stopping rule) are named as such.
TEST(Health, TheStopNamesWhatTheBackendCanChange) {
  auto stop = [](const World& w) -> std::string {
    PhysicalSide p;
    p.mesh.x = w.physical_mesh.rest;
    p.mesh.x[3].y = std::numeric_limits<double>::quiet_NaN();
    p.step = 1;
    try {
      check_physical_step(w, p);
    } catch (const NumericalError& e) {
      return e.what();
    }
    return "no stop";
  };
  World w = *build_world(load_scene(resolve_scene_path("tube"), {"solver.recovery=none"}), 1000, 100);
  const std::string cpu = stop(w);
  EXPECT_NE(cpu.find("use solver.method=direct"), std::string::npos) << cpu;
  EXPECT_NE(cpu.find("turn solver.recovery back on"), std::string::npos) << cpu;
  EXPECT_EQ(cpu.find("stopping rule"), std::string::npos) << cpu;
  w.backend = Backend::Cuda;
  w.scene.spec.solver.physical_tolerance = 0;
  const std::string cuda = stop(w);
  EXPECT_NE(cuda.find("tube.yaml: tick 0, physical step 0: the physical mesh is not finite"), std::string::npos) << cuda;
  EXPECT_EQ(cuda.find("solver.method=direct"), std::string::npos) << cuda;
  EXPECT_NE(cuda.find("--backend cpu"), std::string::npos) << cuda;
  EXPECT_NE(cuda.find("turn the stopping rule back on"), std::string::npos) << cuda;
  EXPECT_EQ(cuda.find('\n'), std::string::npos) << cuda;
}

// A step whose residual is huge while the mesh stays still (float32 round-off at k_vol = 1e12 on
// the CUDA backend) did not converge; it did not diverge.
TEST(Health, AHugeResidualOfAStillMeshIsNotCalledADivergence) {
  const World w = *build_world(load_scene(resolve_scene_path("tube")), 1000, 100);
  PhysicalSide p;
  p.mesh.x = w.physical_mesh.rest;
  p.mesh.x[3].y += 6e-9;
  p.report.residual = 3.7e4;
  p.step = 1;
  try {
    check_physical_step(w, p);
    FAIL() << "no stop";
  } catch (const NumericalError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("the physical mesh did not converge (residual 3.7e+04 mesh weights)"), std::string::npos) << m;
  }
  p.mesh.x[3].y += 0.01;  // a centimetre: a mesh that moves
  try {
    check_physical_step(w, p);
    FAIL() << "no stop";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("the physical mesh diverged"), std::string::npos) << e.what();
  }
}

// k_s above k_svc is named as a cause only where the step runs beside the ticks: a lockstep step
// (which the hint recommends) cannot be driven by the virtual mesh's lag.
TEST(Health, TheStopNamesKsAboveKsvcOnlyBesideTheTicks) {
  const World w = *build_world(load_scene(resolve_scene_path("gap"), {"stiffness.k_s=100"}), 1000, 100);
  auto stop = [&](bool beside_ticks) -> std::string {
    PhysicalSide p;
    p.mesh.x = w.physical_mesh.rest;
    p.mesh.x[3].y = std::numeric_limits<double>::quiet_NaN();
    p.step = 1;
    p.beside_ticks = beside_ticks;
    try {
      check_physical_step(w, p);
    } catch (const NumericalError& e) {
      return e.what();
    }
    return "no stop";
  };
  const std::string async = stop(true), lockstep = stop(false);
  EXPECT_NE(async.find("stiffness.k_s above k_svc"), std::string::npos) << async;
  EXPECT_NE(async.find("--mode lockstep"), std::string::npos) << async;
  EXPECT_NE(lockstep.find("the physical mesh is not finite"), std::string::npos) << lockstep;
  EXPECT_EQ(lockstep.find("k_svc"), std::string::npos) << lockstep;
  EXPECT_EQ(lockstep.find("lockstep"), std::string::npos) << lockstep;
}

// A non-finite force (a device pose of 1e308 m in the log) stops the replay naming the tick and
// the recording's sample that tick read, by its index and time: the row to look for in the log.
TEST(Health, ANonFiniteForceNamesTheRecordingsSampleTheTickRead) {
  Recording rec = read_recording(resolve_recording_path("tube_insert"));
  ASSERT_EQ(rec.t[40], 0.04);
  rec.position[40] = Vec3d{1e308, 0, 0.03};
  const auto world = build_world(load_scene(resolve_scene_path("tube")), 1000, 100);
  ReplayOptions opt;
  opt.start = 0.02;  // tick 20 reads sample 40
  opt.duration = 0.1;
  Count count;
  try {
    replay(*world, rec, opt, count);
    FAIL() << "no stop";
  } catch (const NumericalError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("tube.yaml: tick 20: the force or torque on the virtual tool is not finite; the tick read the "
                     "device at (1e+308, 0, 0.03) m from the recording's sample 40 (t = 0.04 s)"),
              std::string::npos) << m;
  }
  EXPECT_EQ(count.ticks, 20);
}

// A mesh all but weightless (material.density 1e-9 kg/m^3, warned at load) leaves billions of its
// own weights unbalanced where a tissue's would see a fraction of one: its residual is counted in
// the weights of soft tissue's lightest, so a replay in contact runs on (it stopped at tick 10,
// "diverged" with 4.5e9 mesh weights, the tissue moved 65 um) and its steps are not redone by the
// recovery (29 of 31 were, with the same forces); a real divergence still stops.
TEST(Health, ANearlyWeightlessMeshIsNotCalledDiverged) {
  const Recording rec = read_recording(resolve_recording_path("tube_insert"));
  ReplayOptions opt;
  opt.start = 3;  // the hook in the bore
  opt.duration = 0.3;
  Forces forces;
  EXPECT_NO_THROW(replay(*build_world(load_scene(resolve_scene_path("tube"), {"material.density=1e-9"}), 1000, 100),
                         rec, opt, forces));
  EXPECT_EQ(forces.force.size(), 301u);
  EXPECT_EQ(forces.recovered, 0) << "of " << forces.steps << " steps";
  Count count;

  Scene slivers = load_scene(resolve_scene_path("tube"),
                             {"solver.diagonal=plain", "solver.recovery=none", "material.density=1e-9"});
  DegradeOptions d;
  d.target_quality = 0.02;
  degrade_physical_mesh(slivers, d);
  opt.start = 0;
  try {
    replay(*build_world(std::move(slivers), 1000, 100), rec, opt, count);
    FAIL() << "the plain diagonal on slivers should diverge";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("the physical mesh diverged"), std::string::npos) << e.what();
  }
}

TEST(Health, TheRecoveryRedoesTheDivergingStepsWithTheDirectSolve) {
  const Recording rec = read_recording(resolve_recording_path("tube_insert"));
  ReplayOptions opt;
  opt.duration = 0.5;
  Forces forces;
  ASSERT_NO_THROW(replay(*degraded_tube("plain", "direct"), rec, opt, forces));
  EXPECT_EQ(forces.force.size(), 501u);
  EXPECT_GT(forces.recovered, 0);               // the plain diagonal diverges on these slivers
  EXPECT_LE(forces.recovered, forces.steps);
  Forces bounded;  // the bounded diagonal converges: nothing to redo
  replay(*degraded_tube("bounded", "direct"), rec, opt, bounded);
  EXPECT_EQ(bounded.recovered, 0);
}

TEST(Health, EveryStepRecoveredIsTheDirectMethodToTheBit) {
  // A recovery threshold below any residual redoes every step: the replay is then the direct
  // method's, bit for bit (the same start state, the same factorised matrix, the same iterations).
  const Recording rec = read_recording(resolve_recording_path("tube_insert"));
  ReplayOptions opt;
  opt.duration = 0.3;
  auto world = [](const std::vector<std::string>& set) {
    return build_world(load_scene(resolve_scene_path("tube"), set), 1000, 100);
  };
  Forces recovered, direct;
  replay(*world({"solver.recovery_residual=1e-300"}), rec, opt, recovered);
  replay(*world({"solver.method=direct"}), rec, opt, direct);
  EXPECT_EQ(recovered.recovered, recovered.steps);
  ASSERT_EQ(recovered.force.size(), direct.force.size());
  for (std::size_t i = 0; i < direct.force.size(); ++i) {
    ASSERT_EQ(recovered.force[i].x, direct.force[i].x) << "tick " << i;
    ASSERT_EQ(recovered.force[i].y, direct.force[i].y) << "tick " << i;
    ASSERT_EQ(recovered.force[i].z, direct.force[i].z) << "tick " << i;
  }
}

}  // namespace
