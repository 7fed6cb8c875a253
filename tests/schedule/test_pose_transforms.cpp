// Pose transforms on replay (schedule/replay_inputs.hpp): the options in the scene's unit, a
// recording's stored transforms applied exactly once, and the same kind from both refused.
#include <gtest/gtest.h>

#include <numbers>

#include "../io/io_test_util.hpp"
#include "io/import.hpp"
#include "io/recording.hpp"
#include "schedule/replay_inputs.hpp"

using namespace ebh;

namespace {

LoadedReplay load(const std::string& recording, const ReplayTransformOptions& tr) {
  return load_replay_inputs("tube", recording, {}, std::nullopt, std::nullopt, false, Backend::Cpu, tr);
}

// The tool transform of a device whose stylus +z points back toward the handle, with the tip
// 40 mm along the stylus, and the device poses it maps to the given ones: q = q' q_T^-1,
// p = p' - R(q) t.
const RigidTransform kStylus{{0, 0, -0.04}, quat_from_rotvec(Vec3d{std::numbers::pi, 0, 0})};
Recording in_device_frames(Recording rec) {
  for (std::size_t i = 0; i < rec.size(); ++i) {
    rec.orientation[i] = rec.orientation[i] * conjugate(kStylus.rotation);
    rec.position[i] = rec.position[i] - rotate(rec.orientation[i], kStylus.translation);
  }
  rec.transforms.tool = kStylus;
  return rec;
}

}  // namespace

TEST(ReplayTransforms, OptionsAreInTheScenesUnit) {
  // tube is in mm: --transform 1,0,0,... moves the workspace 1 mm; --tool-transform turns the tool.
  const LoadedReplay plain = load("tube_insert", {});
  const LoadedReplay moved = load("tube_insert", {"1,0,0,0,0,0", "0,0,2,0,0,90"});
  ASSERT_TRUE(moved.transforms.world && moved.transforms.tool);
  EXPECT_EQ(moved.transforms.world->translation, (Vec3d{1e-3, 0, 0}));
  for (std::size_t i : {std::size_t{0}, plain.recording.size() / 2}) {
    const Quatd q = plain.recording.orientation[i];
    const Vec3d expect = plain.recording.position[i] + rotate(q, Vec3d{0, 0, 2e-3}) + Vec3d{1e-3, 0, 0};
    EXPECT_LT(norm(moved.recording.position[i] - expect), 1e-15) << i;
    EXPECT_LT(norm(rotate(moved.recording.orientation[i], Vec3d{1, 0, 0}) - rotate(q, Vec3d{0, 1, 0})), 1e-15) << i;
  }
  EXPECT_INPUT_ERROR(load("tube_insert", {"", "0,0,2,0,0"}), "--tool-transform", "expected 6 comma-separated numbers");
}

TEST(ReplayTransforms, ARecordingsStoredTransformIsAppliedOnceAndOnlyOnce) {
  test::ScratchDir tmp;
  const LoadedReplay plain = load("tube_insert", {});
  write_recording(tmp / "device.h5", in_device_frames(plain.recording));
  const LoadedReplay in = load(tmp / "device.h5", {});
  // Applied: the poses are back in ebh's frames, and nothing is left for a second application.
  ASSERT_TRUE(in.transforms.tool.has_value());
  EXPECT_TRUE(in.recording.transforms.empty());
  EXPECT_TRUE(in.recording.baked.tool.has_value());
  double worst = 0;
  for (std::size_t i = 0; i < in.recording.size(); ++i)
    worst = std::max(worst, norm(in.recording.position[i] - plain.recording.position[i]));
  EXPECT_LT(worst, 1e-15);  // round-off of two rotations of a 4 cm offset
  // The same kind given again on the command line would move the tool twice: refused.
  EXPECT_INPUT_ERROR(load(tmp / "device.h5", {"", "0,0,-40,180,0,0"}), "--tool-transform: the recording",
                     "device.h5 stores a tool_transform", "would transform the poses twice");
  // The other kind composes: the workspace moved 1 mm after the stored tool transform.
  const LoadedReplay both = load(tmp / "device.h5", {"1,0,0,0,0,0", ""});
  EXPECT_LT(norm(both.recording.position[7] - (plain.recording.position[7] + Vec3d{1e-3, 0, 0})), 1e-15);
}

TEST(ReplayTransforms, AnImportedRecordingReplaysAsImported) {
  // import bakes its transforms and stores none: a replay without options gives the poses exactly
  // as import wrote them, transformed once.
  test::ScratchDir tmp;
  ImportOptions opt;
  opt.transforms.tool = parse_rigid_transform("--tool-transform", "0,0,-40,180,0,0", 1e-3);
  const std::string log = EBH_TEST_DATA_DIR "/io/sample_openhaptics.txt";
  write_recording(tmp / "imported.h5", import_log(log, opt));
  const Recording raw = import_log(log, ImportOptions{});
  const LoadedReplay in = load(tmp / "imported.h5", {});
  EXPECT_TRUE(in.transforms.empty());
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const Vec3d once = raw.position[i] + rotate(raw.orientation[i], Vec3d{0, 0, -0.04});
    EXPECT_LT(norm(in.recording.position[i] - once), 1e-15) << i;
  }
  // The same tool transform given again at replay would be a second one: refused, naming the fix.
  EXPECT_INPUT_ERROR(load(tmp / "imported.h5", {"", "0,0,-40,180,0,0"}), "--tool-transform: the recording",
                     "imported.h5's poses already include a tool_transform", "import the log again");
  // A world transform was not baked: it applies.
  EXPECT_NO_THROW(load(tmp / "imported.h5", {"1,0,0,0,0,0", ""}));
}
