// World and tool transforms of device poses (lib/io/pose_transform.hpp): the formula against
// homogeneous matrices, the attribute layout, and `ebh import` baking them into the poses.
#include <gtest/gtest.h>

#include <array>
#include <numbers>

#include "io/import.hpp"
#include "io/pose_transform.hpp"
#include "io/recording.hpp"
#include "io_test_util.hpp"

using namespace ebh;

namespace {

constexpr double kDeg = std::numbers::pi / 180;

// A pose as a 4x4 homogeneous matrix, row-major: [R p; 0 1].
using Mat4 = std::array<std::array<double, 4>, 4>;
Mat4 matrix(Vec3d p, Quatd q) {
  Mat4 m{};
  const Vec3d c[3] = {rotate(q, Vec3d{1, 0, 0}), rotate(q, Vec3d{0, 1, 0}), rotate(q, Vec3d{0, 0, 1})};
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) m[r][k] = c[k][r];
    m[r][3] = p[r];
  }
  m[3][3] = 1;
  return m;
}
Mat4 operator*(const Mat4& a, const Mat4& b) {
  Mat4 m{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) m[r][c] += a[r][k] * b[k][c];
  return m;
}
double max_diff(const Mat4& a, const Mat4& b) {
  double d = 0;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) d = std::max(d, std::abs(a[r][c] - b[r][c]));
  return d;
}

}  // namespace

TEST(PoseTransform, ToolOnTheRightWorldOnTheLeftAsHomogeneousMatrices) {
  // world * pose * tool: the world transform acts in the world frame, the tool transform in the
  // tool's own frame (its offset turns with the tool).
  const RigidTransform world{{0.1, -0.2, 0.05}, quat_from_rotvec(Vec3d{0.3, -0.5, 0.2})};
  const RigidTransform tool{{0.01, 0.02, -0.04}, quat_from_rotvec(Vec3d{std::numbers::pi, 0, 0})};
  std::vector<Vec3d> p{{0.03, 0.01, -0.02}, {-0.01, 0.05, 0.07}};
  std::vector<Quatd> q{quat_from_rotvec(Vec3d{0.1, 0.7, -0.4}), quat_from_rotvec(Vec3d{-1.2, 0.2, 0.9})};
  const auto p0 = p;
  const auto q0 = q;
  apply_pose_transforms({world, tool}, p, q);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Mat4 expect = matrix(world.translation, world.rotation) * matrix(p0[i], q0[i]) *
                        matrix(tool.translation, tool.rotation);
    // Products of a few unit rotations: round-off of order 1e-16 per operation.
    EXPECT_LT(max_diff(matrix(p[i], q[i]), expect), 1e-14) << i;
  }
}

TEST(PoseTransform, AStylusFlipAndTipOffset) {
  // A stylus pointing down world -z whose frame has +z up toward the handle (a Geomagic Touch's),
  // with the tip 4 cm along the pointing direction: x,y,z,rx,ry,rz = 0,0,-4,180,0,0 in cm.
  std::vector<Vec3d> p{{0.01, 0.02, 0.10}};
  std::vector<Quatd> q{Quatd{}};
  const RigidTransform tool = parse_rigid_transform("--tool-transform", "0,0,-4,180,0,0", 1e-2);
  apply_pose_transforms({std::nullopt, tool}, p, q);
  EXPECT_LT(norm(p[0] - Vec3d{0.01, 0.02, 0.06}), 1e-15);                  // the tip
  EXPECT_LT(norm(rotate(q[0], Vec3d{0, 0, 1}) - Vec3d{0, 0, -1}), 1e-15);  // ebh's +z: handle -> tip
  // Empty transforms leave the poses as they are.
  const auto p1 = p;
  const auto q1 = q;
  apply_pose_transforms({}, p, q);
  EXPECT_EQ(p[0], p1[0]);
  EXPECT_EQ(q[0].w, q1[0].w);
}

TEST(PoseTransform, OptionsAndAttributesSayWhatIsWrong) {
  EXPECT_INPUT_ERROR(parse_rigid_transform("--tool-transform", "0,0,-4,180,0", 1e-2), "--tool-transform",
                     "expected 6 comma-separated numbers", "'0,0,-4,180,0'");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--tool-transform", "0,0,x,0,0,0", 1e-2), "--tool-transform: z:",
                     "'x' is not a number");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "0,0,inf,0,0,0", 1e-2), "--transform: z is not finite, got 'inf'");
  const RigidTransform t{{0.1, 0.2, 0.3}, quat_from_rotvec(Vec3d{0, 90 * kDeg, 0})};
  const RigidTransform back = from_attribute(to_attribute(t), "rec.h5", "tool_transform");
  EXPECT_EQ(back.translation, t.translation);
  EXPECT_NEAR(back.rotation.y, t.rotation.y, 1e-16);
  EXPECT_INPUT_ERROR(from_attribute({0, 0, 0, 1, 0, 0}, "rec.h5", "tool_transform"), "rec.h5: attribute tool_transform",
                     "6 numbers, expected 7");
  EXPECT_INPUT_ERROR(from_attribute({0, 0, 0, 2, 0, 0, 0}, "rec.h5", "world_transform"),
                     "rec.h5: attribute world_transform", "quaternion norm 2");
  EXPECT_INPUT_ERROR(from_attribute({0, 0, std::nan(""), 1, 0, 0, 0}, "rec.h5", "world_transform"), "value 2",
                     "NaN");
  // A translation no placement has (a scene is at most 2 m across) is refused where it is given,
  // before the poses' coordinates overflow; 100 m is the limit, in the option's unit (mm here).
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "1e308,0,0,0,0,0", 1.0),
                     "--transform 1e308,0,0,0,0,0: the translation is 1e+308 m long; give one of at most 100 m");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "1.7e308,1.7e308,1.7e308,0,0,0", 1.0),
                     "the translation is over 1.798e+308 m long");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--tool-transform", "0,0,100001,0,0,0", 1e-3),
                     "--tool-transform 0,0,100001,0,0,0: the translation is 100 m long");
  EXPECT_EQ(parse_rigid_transform("--transform", "0,0,100000,0,0,0", 1e-3).translation, Vec3d(0, 0, 100));
  EXPECT_INPUT_ERROR(from_attribute({0, 1e300, 0, 1, 0, 0, 0}, "rec.h5", "world_transform"),
                     "rec.h5: attribute world_transform: the translation is 1e+300 m long");
}

TEST(PoseTransform, ImportBakesTheTransformsAndStoresNoneToApply) {
  // One design: `ebh import` applies its transforms to the poses and writes none to apply, only
  // the record of what it baked, so a replay cannot apply them a second time.
  test::ScratchDir tmp;
  ImportOptions plain, moved;
  moved.transforms.tool = parse_rigid_transform("--tool-transform", "0,0,-40,180,0,0", 1e-3);
  moved.transforms.world = parse_rigid_transform("--transform", "5,0,0,0,0,90", 1e-3);
  const std::string log = EBH_TEST_DATA_DIR "/io/sample_openhaptics.txt";
  const Recording a = import_log(log, plain), b = import_log(log, moved);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    std::vector<Vec3d> p{a.position[i]};
    std::vector<Quatd> q{a.orientation[i]};
    apply_pose_transforms(moved.transforms, p, q);
    EXPECT_LT(norm(b.position[i] - p[0]), 1e-15) << i;
  }
  EXPECT_NE(b.description.find("tool transform translation (0, 0, -0.04) m, rotation vector (180, 0, 0) deg applied"),
            std::string::npos) << b.description;
  write_recording(tmp / "b.h5", b);
  const Recording r = read_recording(tmp / "b.h5");
  EXPECT_TRUE(r.transforms.empty());
  ASSERT_TRUE(r.baked.tool && r.baked.world);
  EXPECT_EQ(r.baked.tool->translation, (Vec3d{0, 0, -0.04}));
  EXPECT_EQ(r.position[3], b.position[3]);
}

// A left-handed log (its y axis the other way): --mirror y turns every pose into the right-handed
// frame: positions and the tool's axes in the world are the log's with y negated, the
// orientation a rotation still, recorded in the description and the baked_mirror attribute.
TEST(PoseTransform, ALeftHandedLogIsMirroredIntoEbhsFrame) {
  test::ScratchDir tmp;
  ImportOptions plain, mirrored;
  mirrored.mirror = parse_mirror_axis("y");
  const std::string log = EBH_TEST_DATA_DIR "/io/sample_openhaptics.txt";
  const Recording a = import_log(log, plain), b = import_log(log, mirrored);
  ASSERT_EQ(a.size(), b.size());
  const auto flip = [](Vec3d v) { return Vec3d{v.x, -v.y, v.z}; };
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(b.position[i], flip(a.position[i])) << i;
    // The mirrored tool's axes are the log's axes mirrored (M R M e = M R e' for e' = M e): its
    // +z (handle to tip) as the mirror image of the log's, and a right-handed frame (a rotation).
    // Unit vectors turned by unit quaternions: equal to a few ulps (the mirror only negates).
    for (const Vec3d e : {Vec3d{1, 0, 0}, Vec3d{0, 1, 0}, Vec3d{0, 0, 1}})
      EXPECT_LT(norm(rotate(b.orientation[i], flip(e)) - flip(rotate(a.orientation[i], e))), 1e-15) << i;
    const Quatd& q = b.orientation[i];
    EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-15);
  }
  EXPECT_NE(b.description.find("a left-handed log, its y axis reversed"), std::string::npos) << b.description;
  write_recording(tmp / "m.h5", b);
  EXPECT_EQ(read_recording(tmp / "m.h5").baked_mirror, "y");
  EXPECT_EQ(read_recording(tmp / "m.h5").position[2], b.position[2]);
  try {
    (void)parse_mirror_axis("-y");
    ADD_FAILURE() << "-y was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--mirror: expected the axis that runs the other way, x, y or z, got '-y'");
  }
}

TEST(PoseTransform, AKindBothToApplyAndBakedIsRejected) {
  test::ScratchDir tmp;
  Recording r = import_log(EBH_TEST_DATA_DIR "/io/sample_openhaptics.txt", ImportOptions{});
  r.transforms.tool = RigidTransform{};
  r.baked.tool = RigidTransform{};
  write_recording(tmp / "both.h5", r);
  EXPECT_INPUT_ERROR(read_recording(tmp / "both.h5"), "both.h5: attributes tool_transform and baked_tool_transform",
                     "keep one");
}

TEST(PoseTransform, ARecordingKeepsItsStoredTransformsAndRawPoses) {
  // A recording made elsewhere may keep device poses and say how to map them; reading and
  // writing it back keeps both as they are (replay applies them: tests/schedule).
  test::ScratchDir tmp;
  Recording r = import_log(EBH_TEST_DATA_DIR "/io/sample_openhaptics.txt", ImportOptions{});
  r.transforms.tool = RigidTransform{{0, 0, -0.04}, quat_from_rotvec(Vec3d{std::numbers::pi, 0, 0})};
  write_recording(tmp / "raw.h5", r);
  const Recording back = read_recording(tmp / "raw.h5");
  ASSERT_TRUE(back.transforms.tool.has_value());
  EXPECT_FALSE(back.transforms.world.has_value());
  EXPECT_EQ(back.transforms.tool->translation, r.transforms.tool->translation);
  EXPECT_EQ(back.position[5], r.position[5]);  // not applied on read
}
