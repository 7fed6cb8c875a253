#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <numbers>

#include "io/h5.hpp"
#include "io/recording.hpp"
#include "core/units.hpp"
#include "io_test_util.hpp"

using namespace ebh;

namespace {

Recording make_recording(std::size_t n = 10) {
  Recording r;
  for (std::size_t i = 0; i < n; ++i) {
    double t = 0.001 * static_cast<double>(i);
    r.t.push_back(t);
    r.position.push_back({0.01 * t, -0.02, 0.03 + t});
    r.orientation.push_back(quat_from_rotvec(Vec3d{0, 0, 0.1 * static_cast<double>(i)}));
    r.jaw.push_back(1.0 - static_cast<double>(i) / static_cast<double>(n));
    r.buttons.push_back(i >= n / 2 ? 1 : 0);
  }
  r.rate_hz = 1000;
  r.source = "synthetic";
  r.scene = "tube";
  r.tool = "hook";
  r.description = "test";
  return r;
}

// Writes the raw layout of `r` with one defect applied by `mutate` (called on the flat arrays
// before writing) so read_recording's checks can be exercised one at a time.
struct RawRecording {
  std::vector<double> t, pos, ori, jaw;
  std::vector<std::uint8_t> buttons;
  explicit RawRecording(const Recording& r) {
    t = r.t;
    jaw = r.jaw;
    buttons = r.buttons;
    for (std::size_t i = 0; i < r.size(); ++i) {
      pos.insert(pos.end(), {r.position[i].x, r.position[i].y, r.position[i].z});
      const Quatd& q = r.orientation[i];
      ori.insert(ori.end(), {q.w, q.x, q.y, q.z});
    }
  }
  void write(const std::string& path, const std::function<void(h5::Group&)>& extra = {},
             const std::string& skip = "") const {
    h5::File f = h5::File::create(path);
    h5::Group g = f.create_group("trajectory");
    if (skip != "t") g.write<double>("t", t, {t.size()});
    if (skip != "position") g.write<double>("position", pos, {pos.size() / 3, 3});
    if (skip != "orientation") g.write<double>("orientation", ori, {ori.size() / 4, 4});
    if (skip != "jaw") g.write<double>("jaw", jaw, {jaw.size()});
    if (skip != "buttons") g.write<std::uint8_t>("buttons", buttons, {buttons.size()});
    f.set_attr("rate_hz", 1000.0);
    if (skip != "scene") f.set_attr("scene", "tube");
    f.set_attr("source", "synthetic");
    f.set_attr("tool", "hook");
    f.set_attr("description", "raw");
    if (extra) extra(g);
  }
};

}  // namespace

TEST(Recording, WriteReadRoundTripIsExact) {
  test::ScratchDir tmp;
  Recording r = make_recording();
  r.generator = "unit test";
  write_recording(tmp / "r.h5", r);
  Recording b = read_recording(tmp / "r.h5");
  ASSERT_EQ(b.size(), r.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_EQ(b.t[i], r.t[i]);
    EXPECT_EQ(b.position[i], r.position[i]);
    // Unit quaternions are renormalised on write and read: equal to round-off (1 ulp-ish).
    EXPECT_NEAR(b.orientation[i].w, r.orientation[i].w, 1e-15);
    EXPECT_NEAR(b.orientation[i].z, r.orientation[i].z, 1e-15);
    EXPECT_EQ(b.jaw[i], r.jaw[i]);
    EXPECT_EQ(b.buttons[i], r.buttons[i]);
  }
  EXPECT_EQ(b.rate_hz, 1000.0);
  EXPECT_EQ(b.scene, "tube");
  EXPECT_EQ(b.tool, "hook");
  EXPECT_EQ(b.source, "synthetic");
  EXPECT_EQ(b.description, "test");
  EXPECT_EQ(b.generator, "unit test");
  // Every dataset carries a unit.
  h5::File f = h5::File::open_read(tmp / "r.h5");
  for (const char* ds : {"t", "position", "orientation", "jaw", "buttons"})
    EXPECT_TRUE(f.group("trajectory").dataset(ds).has_attr("unit")) << ds;
  EXPECT_EQ(f.group("trajectory").dataset("position").attr_string("unit"), "m");
}

TEST(Recording, SchemaDefectsNameDatasetAndIndex) {
  test::ScratchDir tmp;
  const Recording good = make_recording();
  const std::string p = tmp / "bad.h5";
  auto defect = [&](const std::function<void(RawRecording&)>& mutate, const std::string& skip = "") {
    RawRecording raw(good);
    mutate(raw);
    raw.write(p, {}, skip);
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();

  defect([](RawRecording&) {}, "jaw");
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/jaw", "missing dataset");
  // Positions stored as (N, 2).
  {
    RawRecording raw(good);
    h5::File f = h5::File::create(p);
    h5::Group g = f.create_group("trajectory");
    g.write<double>("t", raw.t, {10});
    g.write<double>("position", std::vector<double>(20, 0.0), {10, 2});
  }
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/position", "shape (10, 2), expected (10, 3)");
  {
    RawRecording raw(good);
    raw.write(p, [&](h5::Group&) {}, "buttons");
    h5::File f = h5::File::open_write(p);
    f.group("trajectory").write<double>("buttons", std::vector<double>(10, 0.0), {10});
  }
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/buttons", "type floating point, expected integer (of any width)");
  {  // buttons as numpy bools: h5py stores an enumeration of int8 (FALSE 0, TRUE 1)
    RawRecording raw(good);
    raw.write(p, [&](h5::Group&) {}, "buttons");
    const hid_t file = H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t type = H5Tenum_create(H5T_NATIVE_INT8);
    for (const auto& [name, value] : {std::pair<const char*, std::int8_t>{"FALSE", 0}, {"TRUE", 1}})
      H5Tenum_insert(type, name, &value);
    const hsize_t dims[1] = {10};
    const hid_t space = H5Screate_simple(1, dims, nullptr);
    const hid_t d = H5Dcreate2(file, "/trajectory/buttons", type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const std::vector<std::int8_t> pressed(10, 1);
    H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, pressed.data());
    H5Dclose(d);
    H5Sclose(space);
    H5Tclose(type);
    H5Fclose(file);
  }
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/buttons", "type enumerated (as h5py stores a bool");
  {  // int32 buttons beyond 8 bits: HDF5's conversion would clip them to 255 silently
    RawRecording raw(good);
    raw.write(p, [&](h5::Group&) {}, "buttons");
    h5::File f = h5::File::open_write(p);
    std::vector<std::int32_t> wide(10, 0);
    wide[7] = 256;
    f.group("trajectory").write<std::int32_t>("buttons", wide, {10});
  }
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/buttons[7]", "256 is not a bitmask of 8 buttons");
  defect([](RawRecording& r) { r.jaw.pop_back(); });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/jaw: 9 rows, /trajectory/t 10: a recording has one row per sample");
  defect([&](RawRecording& r) { r.pos[3 * 4 + 1] = nan; });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/position[4]", "NaN");
  defect([](RawRecording& r) { r.t[6] = r.t[5]; });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/t[6]", "not strictly increasing");
  // Rows declared and never written read as zeros to the end: said as such.
  defect([](RawRecording& r) {
    for (std::size_t i = 7; i < r.t.size(); ++i) r.t[i] = 0;
  });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/t[7]", "the times from here on (3 rows) are all 0: rows declared and never written");
  defect([](RawRecording& r) { r.ori[4 * 3] *= 1.2; });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/orientation[3]", "norm");
  defect([](RawRecording& r) { r.jaw[2] = 1.5; });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/jaw[2]", "outside [0, 1]");
  defect([](RawRecording& r) { r.jaw[2] = std::numeric_limits<double>::infinity(); });
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/jaw[2]", "NaN or Inf");
  defect([](RawRecording&) {}, "scene");
  EXPECT_INPUT_ERROR(read_recording(p), p, "missing attribute 'scene'");
  // A quaternion whose unit says (x, y, z, w): another rotation of unit norm if read as (w, x, y, z).
  {
    RawRecording raw(good);
    raw.write(p, [&](h5::Group&) {}, "orientation");
    h5::File f = h5::File::open_write(p);
    f.group("trajectory").write<double>("orientation", raw.ori, {10, 4}).set_attr("unit", "quaternion (x, y, z, w)");
  }
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory/orientation", "stored (x, y, z, w)");
  {
    h5::File f = h5::File::create(p);
    f.write<double>("t", std::vector<double>{0}, {1});
  }
  EXPECT_INPUT_ERROR(read_recording(p), p, "/trajectory", "missing group");
  {  // a replay's output given for its recording
    h5::File f = h5::File::create(p);
    f.write<double>("/haptic/t", std::vector<double>{0}, {1});
    f.set_attr("recording", "/data/press.h5");
  }
  EXPECT_INPUT_ERROR(read_recording(p), p,
                     "a replay output (/haptic), not a device recording (/trajectory); its replay read the recording "
                     "/data/press.h5");
}

TEST(Recording, SlightlyOffQuaternionIsNormalised) {
  test::ScratchDir tmp;
  RawRecording raw(make_recording());
  for (int k = 0; k < 4; ++k) raw.ori[4 * 5 + k] *= 1.0004;  // within kQuatNormTolerance = 1e-3
  raw.write(tmp / "q.h5");
  Recording r = read_recording(tmp / "q.h5");
  const Quatd& q = r.orientation[5];
  EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-15);
}

TEST(Recording, WriteRejectsBadRecordingAndLeavesNoFile) {
  test::ScratchDir tmp;
  Recording r = make_recording();
  r.t[3] = r.t[2];
  EXPECT_INPUT_ERROR(write_recording(tmp / "w.h5", r), "/trajectory/t[3]");
  EXPECT_EQ(tmp.entries(), 0u);
}

// A logger that pre-sized its datasets and crashed leaves a small file whose datasets declare
// far more rows than were written (unwritten chunks cost no space). Writes such a dataset with
// the HDF5 API itself: the project's layer only writes what it holds.
static void declare_rows(const std::string& path, const char* name, hsize_t rows, hsize_t cols) {
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  hid_t g = H5Gopen2(f, "trajectory", H5P_DEFAULT);
  H5Ldelete(g, name, H5P_DEFAULT);
  const hsize_t dims[2] = {rows, cols}, maxdims[2] = {H5S_UNLIMITED, cols}, chunk[2] = {1024, cols};
  const int rank = cols == 0 ? 1 : 2;
  hid_t space = H5Screate_simple(rank, dims, maxdims);
  hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl, rank, chunk);
  hid_t d = H5Dcreate2(g, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  EXPECT_GE(d, 0);
  H5Dclose(d);
  H5Pclose(dcpl);
  H5Sclose(space);
  H5Gclose(g);
  H5Fclose(f);
}

TEST(Recording, DeclaredRowsAreCheckedBeforeAnythingIsRead) {
  test::ScratchDir tmp;
  const std::string p = tmp / "claim.h5";
  // t declares 30 million rows, 3 times the limit: refused naming the file and dataset, before
  // the 240 MB of t (and the 2 GB of the rest) are allocated.
  RawRecording(make_recording()).write(p);
  declare_rows(p, "t", 30'000'000, 0);
  EXPECT_INPUT_ERROR(read_recording(p), p + ": /trajectory/t: 30000000 samples declared", "the limit is 10000000");
  // t is sane but position declares 1e10 rows: its shape check comes before its read.
  RawRecording(make_recording()).write(p);
  declare_rows(p, "position", 10'000'000'000ull, 3);
  EXPECT_INPUT_ERROR(read_recording(p), p + ": /trajectory/position: 10000000000 rows, /trajectory/t 10");
}

TEST(SampleAt, InterpolatesAndClamps) {
  Recording r;
  r.t = {0.0, 1.0, 3.0};
  r.position = {{0, 0, 0}, {1, 2, 3}, {3, 2, 1}};
  r.orientation = {Quatd{}, quat_from_rotvec(Vec3d{0, 0, std::numbers::pi / 2}), quat_from_rotvec(Vec3d{0, 0, std::numbers::pi / 2})};
  r.jaw = {1.0, 0.0, 0.5};
  r.buttons = {0, 1, 3};

  DeviceSample a = sample_at(r, 0.25);
  EXPECT_NEAR(norm(a.position - Vec3d{0.25, 0.5, 0.75}), 0, 1e-15);
  EXPECT_NEAR(a.jaw, 0.75, 1e-15);
  EXPECT_EQ(a.buttons, 0);  // held from the sample before
  // slerp midpoint of identity and 90 deg about z: 45 deg about z.
  DeviceSample m = sample_at(r, 0.5);
  Vec3d w = rotvec_from_quat(m.orientation);
  EXPECT_NEAR(norm(w - Vec3d{0, 0, std::numbers::pi / 4}), 0, 1e-12);  // acos/sin round-off
  DeviceSample b = sample_at(r, 2.0);
  EXPECT_NEAR(norm(b.position - Vec3d{2, 2, 2}), 0, 1e-15);
  EXPECT_EQ(b.buttons, 1);
  EXPECT_EQ(sample_at(r, 1.0).buttons, 1);  // exactly at a sample: that sample's buttons
  // Clamped ends.
  EXPECT_EQ(sample_at(r, -5.0).position, r.position[0]);
  EXPECT_EQ(sample_at(r, 99.0).position, r.position[2]);
  EXPECT_EQ(sample_at(r, 99.0).buttons, 3);
  EXPECT_EQ(sample_at(r, 99.0).jaw, 0.5);
}

TEST(SampleAt, SlerpTakesTheShortArc) {
  Quatd a = quat_from_rotvec(Vec3d{0, 0, 0.1});
  Quatd b = quat_from_rotvec(Vec3d{0, 0, 0.3});
  Quatd nb{-b.w, -b.x, -b.y, -b.z};  // the same rotation on the other hemisphere
  Vec3d w = rotvec_from_quat(slerp(a, nb, 0.5));
  EXPECT_NEAR(norm(w - Vec3d{0, 0, 0.2}), 0, 1e-12);
}

TEST(SceneCheck, FlagsATrajectoryFarOutside) {
  Recording r = make_recording();
  Vec3d lo{-0.1, -0.1, -0.1}, hi{0.1, 0.1, 0.1};
  EXPECT_FALSE(check_recording_in_scene(r, lo, hi, 0.05).has_value());
  for (auto& p : r.position) p = 1000.0 * p + Vec3d{50, 0, 0};  // mm read as m; the last sample is farthest
  auto msg = check_recording_in_scene(r, lo, hi, 0.05);
  ASSERT_TRUE(msg.has_value());
  EXPECT_NE(msg->find("sample 9"), std::string::npos) << *msg;
  EXPECT_NE(msg->find("mm or cm"), std::string::npos) << *msg;
}

// Unit sanity: a path against a 10 cm mesh at the origin, read in the right unit and in others.
namespace {
/// A recording of three samples at these positions (in the unit the log was read in).
Recording path_of(Vec3d a, Vec3d b, Vec3d c) {
  Recording r = make_recording(3);
  r.position = {a, b, c};
  return r;
}
Recording press_path(double metres_per_unit) {
  // 3 cm above the mesh's top, pressing 1 cm into it, 2 cm sideways: logged in cm.
  return path_of(Vec3d{0, 0, 8} * metres_per_unit, Vec3d{0, 0, 4} * metres_per_unit, Vec3d{2, 0, 4} * metres_per_unit);
}
const Vec3d kLo{-0.05, -0.05, -0.05}, kHi{0.05, 0.05, 0.05};  // diagonal 0.173 m
}  // namespace

TEST(UnitSanity, APathInTheRightUnitFits) {
  EXPECT_FALSE(check_recording_scale(press_path(1e-2), kLo, kHi, 1e-2).has_value());
  EXPECT_FALSE(check_recording_scale(press_path(1e-2), kLo, kHi, std::nullopt).has_value());
}

TEST(UnitSanity, ALogReadInTheWrongUnitNamesTheRightOne) {
  // cm read as m: 100x too large and far away; at import the fix is the option.
  auto w = check_recording_scale(press_path(1.0), kLo, kHi, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("the tool path spans 4.47 m, 25.8x the physical mesh's bounding-box diagonal (0.173 m)"),
            std::string::npos) << *w;
  EXPECT_NE(w->find("likely fix: --unit cm"), std::string::npos) << *w;
  // The same recording at replay, where the unit the log was read with is not known.
  w = check_recording_scale(press_path(1.0), kLo, kHi, std::nullopt);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: the log is in cm, not m: ebh import --unit cm; or, were the log right, the physical "
                    "mesh is 100 times too small: check the scene's mesh.unit"),
            std::string::npos)
      << *w;
  // m read as mm: 1/1000 the size, a dot inside the mesh.
  w = check_recording_scale(press_path(1e-5), kLo, kHi, 1e-3);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("spans 4.47e-05 m, 1/3.87e+03 of the physical mesh's"), std::string::npos) << *w;
  EXPECT_NE(w->find("likely fix: --unit m"), std::string::npos) << *w;
  // ... which a tool held still in the tissue (a press held, with tremor) also is: said as such.
  EXPECT_NE(w->find("; a tool held still at or near the tissue needs no fix, else likely fix: --unit m"),
            std::string::npos) << *w;
  // ... and one hovering with a hand's tremor above the tissue (a window of a hover).
  Recording hover = press_path(1e-5);
  for (Vec3d& p : hover.position) p.z += kHi.z + 0.03;  // 30 mm above the box
  w = check_recording_scale(hover, kLo, kHi, std::nullopt);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("; a tool held still at or near the tissue needs no fix, else"), std::string::npos) << *w;
  // The cm log read as m lies far outside the box: no hold to mention.
  EXPECT_EQ(check_recording_scale(press_path(1.0), kLo, kHi, 1.0)->find("held still"), std::string::npos);
}

// A log in inches (a Polhemus tracker's default) read as mm: 1/25.4 of its size. Read as cm it
// comes to the mesh too (2.54 times apart, which a size cannot tell): the metric unit is the fix,
// with inches named beside it.
TEST(UnitSanity, InchesAreNamedBesideAMetricFix) {
  const double inch_read_as_mm = 1e-2 / kMetresPerInch * 1e-3;
  auto w = check_recording_scale(press_path(inch_read_as_mm), kLo, kHi, 1e-3);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: --unit cm (or, were it in inches, --unit in: the path comes to the mesh in either)"),
            std::string::npos) << *w;
  EXPECT_FALSE(check_recording_scale(press_path(1e-2), kLo, kHi, kMetresPerInch).has_value());  // read in inches
  // A cm log read as mm whose logged point stops short of the mesh (a mesh 25 cm along x, the log's
  // tool offset not given yet: the path reaches 10 cm): in inches it would come to the mesh, which is
  // no sign of inches. The fix named is cm (its size), and inches are not named.
  const Vec3d lo{0.2, -0.05, -0.05}, hi{0.3, 0.05, 0.05};
  Recording short_of = press_path(1e-2);
  for (Vec3d& p : short_of.position) p = (p + Vec3d{0.25, 0, 0}) / kMetresPerInch * 1e-3;
  w = check_recording_scale(short_of, lo, hi, std::nullopt);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: the log is in cm, not mm: ebh import --unit cm;"), std::string::npos) << *w;
  EXPECT_EQ(w->find("--unit in"), std::string::npos) << *w;
}

TEST(UnitSanity, AToolThatNeverMovesIsJudgedByItsPlaceAlone) {
  Recording r = press_path(1e-2);
  for (Vec3d& p : r.position) p = Vec3d{0, 0, 0.08};
  EXPECT_FALSE(check_recording_scale(r, kLo, kHi, 1e-2).has_value());
  for (Vec3d& p : r.position) p = Vec3d{0, 0, 0.8};
  auto w = check_recording_scale(r, kLo, kHi, 1e-2);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("stays at least 0.75 m"), std::string::npos) << *w;
  EXPECT_NE(w->find("likely fix: --transform"), std::string::npos) << *w;
}

TEST(UnitSanity, APathFarFromTheMeshAsksForAWorldTransform) {
  // The right size, 1 m away: no unit brings it to the mesh; placing the workspace does.
  Recording r = press_path(1e-2);
  for (Vec3d& p : r.position) p += Vec3d{1, 0, 0};
  auto w = check_recording_scale(r, kLo, kHi, 1e-2);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("stays at least 0.95 m (5.48 mesh diagonals of 0.173 m) away from the physical mesh's bounding "
                    "box, starting at (1, 0, 0.08) m"),
            std::string::npos) << *w;
  EXPECT_NE(w->find("likely fix: --transform placing the device's workspace at the mesh (the mesh's centre is (-1.01, "
                    "0, -0.06) m from the path's)"),
            std::string::npos) << *w;
  // A kilometre away (a mesh in scanner coordinates): the offset to 0.1 mm, not 1e+03 (20 mm off).
  Recording far = press_path(1e-2);
  for (Vec3d& p : far.position) p += Vec3d{1000.02, -1000.02, 0};
  w = check_recording_scale(far, kLo, kHi, 1e-2);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("(the mesh's centre is (-1000.03, 1000.02, -0.06) m from the path's)"), std::string::npos) << *w;
  // Just inside 2 diagonals, but farther than a replay accepts (one diagonal, replay_outside_margin):
  // said, as the replay would refuse it.
  for (Vec3d& p : r.position) p += Vec3d{-1 + 0.05 + 0.34, 0, -0.08};
  w = check_recording_scale(r, kLo, kHi, 1e-2);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("the tool path reaches 0.36 m outside the physical mesh's bounding box, beyond the 0.173 m a replay "
                    "accepts (it refuses those samples without --allow-outside); likely fix: --transform"),
            std::string::npos)
      << *w;
  // In mm it would come to the mesh, at 1/39 of its size: named beside the transform, which one
  // is right the user knows (a grasp on a large organ moves that little).
  EXPECT_NE(w->find("; or --unit mm, under which the path comes to the mesh, spanning 1/38.7 of its diagonal"),
            std::string::npos)
      << *w;
  EXPECT_TRUE(check_recording_in_scene(r, kLo, kHi, replay_outside_margin(norm(kHi - kLo))).has_value());
  // Within it: no warning.
  for (Vec3d& p : r.position) p += Vec3d{-0.2, 0, 0};
  EXPECT_FALSE(check_recording_scale(r, kLo, kHi, 1e-2).has_value());
  EXPECT_FALSE(check_recording_in_scene(r, kLo, kHi, replay_outside_margin(norm(kHi - kLo))).has_value());
}

// One corrupt line (x = 99999 in a log in mm) is a glitch, not a unit: the rest of the path fits.
TEST(UnitSanity, ALoneSampleFarFromTheRestIsAGlitch) {
  Recording r = make_recording(1000);  // 1 s pressing 90 mm down through the box's top
  for (std::size_t i = 0; i < r.size(); ++i) r.position[i] = {0, 0, 0.08 - 0.09 * static_cast<double>(i) / 1000};
  EXPECT_FALSE(check_recording_scale(r, kLo, kHi, 1e-3).has_value());
  EXPECT_TRUE(glitch_samples(r.position).empty());
  r.position[300].x = 99.999;
  EXPECT_EQ(glitch_samples(r.position), (std::vector<std::size_t>{300}));
  auto w = check_recording_scale(r, kLo, kHi, 1e-3);
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(*w, "sample 300 (t = 0.3 s) at (100, 0, 0.053) m lies far from the rest of the path, which fits the physical "
                "mesh in this unit: a glitch in the log? leave that line out");
  auto e = check_recording_in_scene(r, kLo, kHi, replay_outside_margin(norm(kHi - kLo)));
  ASSERT_TRUE(e.has_value());
  EXPECT_NE(e->find("; the rest of the path lies within it: a glitch in the log? leave that line out"), std::string::npos) << *e;
  EXPECT_EQ(e->find("mm or cm"), std::string::npos) << *e;
  // The whole path 1 m off as well: the glitch is no explanation of the refusal.
  Recording off = r;
  for (Vec3d& p : off.position) p.y += 1;
  e = check_recording_in_scene(off, kLo, kHi, replay_outside_margin(norm(kHi - kLo)));
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->find("the rest of the path lies within it"), std::string::npos) << *e;
  // A value past what a double's square holds (1e200): the same, not "spans inf m".
  r.position[300].x = 1e200;
  w = check_recording_scale(r, kLo, kHi, 1e-3);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("sample 300 (t = 0.3 s) at (1e+200, 0, 0.053) m lies far from the rest"), std::string::npos) << *w;
  // Many samples away (a stretch of the log in another frame): the path itself, not a glitch.
  for (std::size_t i = 300; i < 400; ++i) r.position[i].x = 99.999;
  EXPECT_TRUE(glitch_samples(r.position).empty());
}

// A tool brought down from 25 cm above the tissue into it: of the mesh's size and at it, far out
// only in its approach; no unit and no transform is the fix.
TEST(UnitSanity, AnApproachFromHighAboveIsNoMisplacement) {
  Recording r = path_of({0, 0, 0.3}, {0, 0, 0.1}, {0, 0, -0.02});
  const auto w = check_recording_scale(r, kLo, kHi, 1e-3);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: none if those samples are the tool's approach from afar: replay from where it nears the "
                    "tissue (--start) or with --allow-outside"),
            std::string::npos)
      << *w;
}

TEST(UnitSanity, AGraspHeldOffTheTissueIsAtTheMesh) {
  // A forceps' pose is its jaws' pivot: a grasp on the top of the gap's blocks (z <= 0) holds it
  // 3 mm above them. Logged in cm, read as metres: in cm it comes within 3 mm of the box; in mm
  // (10x too small) within 0.3 mm, but at a tenth of the size.
  const Vec3d lo{-0.0305, -0.025, -0.03}, hi{0.0305, 0.025, 0};
  Recording r = path_of({2, 0, 3.5}, {2, 0, 0.3}, {0.5, 0, 0.3});
  auto w = check_recording_scale(r, lo, hi, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: --unit cm"), std::string::npos) << *w;
  for (Vec3d& p : r.position) p *= 1e-2;
  EXPECT_FALSE(check_recording_scale(r, lo, hi, 1e-2).has_value());
}

TEST(UnitSanity, NoUnitIsNamedUnderWhichAReplayRefusesThePath) {
  // A press in mm read as metres over a 60 x 40 x 30 mm block (top at z = 15 mm): from 15 mm
  // above the top to 8 mm into it. In cm it has the block's size nearer than in mm (2.9x its
  // diagonal against 0.29x) and enters it, but goes 65 mm out of its bottom: a replay refuses that.
  const Vec3d lo{-0.03, -0.02, -0.015}, hi{0.03, 0.02, 0.015};
  Recording r = path_of({0, 0, 30}, {0, 0, 15}, {0, 0, 7});
  auto w = check_recording_scale(r, lo, hi, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: --unit mm"), std::string::npos) << *w;
  // Read in cm: the replay would refuse it, so it is said, with the unit that fits.
  for (Vec3d& p : r.position) p *= 1e-2;
  w = check_recording_scale(r, lo, hi, 1e-2);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("the tool path reaches 0.285 m outside the physical mesh's bounding box, beyond the 0.1 m a replay "
                    "accepts (it refuses those samples without --allow-outside); likely fix: --unit mm"),
            std::string::npos)
      << *w;
}

TEST(UnitSanity, ALogInTheWrongUnitAndPlaceNamesTheUnitAndATransform) {
  // Logged in mm 60 cm from the mesh, read as m: 258x the mesh's size and 600 m away. In mm it
  // has a size that fits but stays away (in cm too, 2.58x the mesh: a path larger than the mesh
  // comes second), so the fix is the unit and a transform, not "none of m, cm, mm".
  Recording r = press_path(1.0);
  for (Vec3d& p : r.position) p = 10.0 * p + Vec3d{600, 0, 0};
  auto w = check_recording_scale(r, kLo, kHi, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("the tool path spans 44.7 m, 258x the physical mesh's bounding-box diagonal"), std::string::npos)
      << *w;
  EXPECT_NE(w->find("likely fix: --unit mm, and --transform to place it (in mm the path spans 0.0447 m, 1/3.87 of the "
                    "mesh's diagonal, and the mesh's centre is (-0.61, 0, -0.06) m from the path's)"),
            std::string::npos) << *w;
  // At replay, where the log's unit is not known.
  w = check_recording_scale(r, kLo, kHi, std::nullopt);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("likely fix: the log is in mm, not m: ebh import --unit mm, and --transform to place it"),
            std::string::npos) << *w;
}

// A recording with gaps in its times (written by another program: import did not see it) is told at
// replay, naming the samples; regular times and the committed recordings are not.
TEST(LogGaps, AGapInARecordingsTimesIsNamed) {
  Recording r;
  for (int i = 0; i < 200; ++i) {
    r.t.push_back(0.001 * i + (i >= 120 ? 0.05 : 0.0) + (i >= 150 ? 0.03 : 0.0));  // 51 and 31 ms between samples
    r.position.push_back({1e-5 * i, 0, 0});  // moving: a gap the replay crosses in a straight line
    r.orientation.push_back({});
    r.jaw.push_back(1);
  }
  const auto w = check_recording_gaps(r);
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(w->rfind("2 gaps, the longest of 0.051 s between samples 119 and 120 (the recording's t = 0.119 .. 0.17 s), 51 "
                     "times the median interval of 1 ms", 0),
            0u)
      << *w;
  // A hold kept by `ebh import --drop-repeats` (its first and last sample, alike) is no gap: the
  // device stood still across it, and the replay holds the tool as it did.
  Recording held = r;
  held.position[120] = held.position[119];
  const auto w_held = check_recording_gaps(held);
  ASSERT_TRUE(w_held.has_value());
  EXPECT_EQ(w_held->rfind("a gap of 0.031 s between samples 149 and 150", 0), 0u) << *w_held;
  held.position[150] = held.position[149];
  EXPECT_FALSE(check_recording_gaps(held).has_value());
  r.t.resize(110);
  r.position.resize(110);
  r.orientation.resize(110);
  r.jaw.resize(110);
  EXPECT_FALSE(check_recording_gaps(r).has_value());
  for (const char* name : {"tube_insert", "gap_grasp", "cholecystectomy_press", "gynaecology_grasp"})
    EXPECT_FALSE(check_recording_gaps(read_recording(std::string(EBH_SOURCE_DIR) + "/recordings/" + name + ".h5")))
        << name;
}

// A 100 Hz device logged at 1 kHz: the pose changes every 10th sample, said with the device's
// rate; the committed recordings (encoder-quantised: 39-60% of their samples repeat the one before)
// are not, nor a quantised slow motion whose changes come 1, 2, 3 ... samples apart.
TEST(StaleSamples, ADeviceSlowerThanItsLoggerIsNamed) {
  for (const char* name : {"tube_insert", "tube_grasp", "gap_insert", "gap_grasp", "cholecystectomy_press",
                           "cholecystectomy_grasp", "gynaecology_press", "gynaecology_grasp"}) {
    const Recording r = read_recording(std::string(EBH_SOURCE_DIR) + "/recordings/" + name + ".h5");
    EXPECT_FALSE(check_recording_stale(r).has_value()) << name << ": " << check_recording_stale(r).value_or("");
    Recording stale = r;  // the same motion seen by a 100 Hz device, each update logged ten times
    for (std::size_t i = 0; i < stale.t.size(); ++i) {
      const std::size_t held = i / 10 * 10;
      stale.position[i] = r.position[held];
      stale.orientation[i] = r.orientation[held];
      stale.jaw[i] = r.jaw[held];
      stale.buttons[i] = r.buttons[held];
    }
    const std::optional<StaleSamples> s = find_stale_samples(stale);
    ASSERT_TRUE(s.has_value()) << name;
    EXPECT_EQ(s->period, 10u) << name;
    const std::optional<std::string> w = check_recording_stale(stale);
    ASSERT_TRUE(w.has_value());
    EXPECT_NE(w->find("changes only every 10 samples"), std::string::npos) << *w;
    EXPECT_NE(w->find("a device updating at about 100 Hz logged at 1000 Hz"), std::string::npos) << *w;
  }
  Recording slow;  // 0.3 mm/s quantised to 1 um with a 0.2 mm/s wobble: changes at irregular intervals
  for (int i = 0; i < 5000; ++i) {
    const double t = 0.001 * i;
    slow.t.push_back(t);
    slow.position.push_back({std::round((3e-4 * t + 2e-4 / 20 * std::sin(20 * t)) / 1e-6) * 1e-6, 0, 0});
    slow.orientation.push_back({});
    slow.jaw.push_back(1);
    slow.buttons.push_back(0);
  }
  EXPECT_FALSE(find_stale_samples(slow).has_value());
}

// A jump in the log (50 m/s for one sample) is named with its samples and speed; a hand's motion
// (make_recording's 1 m/s) and the committed recordings are not.
TEST(ToolSpeed, AJumpInTheLogIsNamed) {
  Recording r = make_recording();
  EXPECT_FALSE(check_recording_speed(r).has_value());
  r.position[6] += Vec3d{0.05, 0, 0};  // 5 cm out and back within 2 ms
  const auto w = check_recording_speed(r);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("jumps 0.05 m between samples 5 and 6 (the recording's t = 0.005 .. 0.006 s: 50 m/s"), std::string::npos) << *w;
  // Out and back are two jumps: the fastest is named, and how many there are and the first (the
  // advice to cut the log at one would leave the other).
  EXPECT_NE(w->find("; the fastest of 2 jumps over 10 m/s, the first between samples 5 and 6 (t = 0.006 s)): a gap"),
            std::string::npos) << *w;
  Recording step = make_recording();
  for (std::size_t i = 6; i < step.size(); ++i) step.position[i] += Vec3d{0.05, 0, 0};  // one jump, no way back
  ASSERT_TRUE(check_recording_speed(step).has_value());
  EXPECT_EQ(check_recording_speed(step)->find("the fastest of"), std::string::npos) << *check_recording_speed(step);
  // A jump whose square overflows (a garbled sample) is its length, not inf.
  Recording far = make_recording();
  far.position[6] = Vec3d{1e297, 0, 0};
  ASSERT_TRUE(check_recording_speed(far).has_value());
  EXPECT_NE(check_recording_speed(far)->find("jumps 1e+297 m between samples 5 and 6"), std::string::npos)
      << *check_recording_speed(far);
  for (const char* name : {"tube_insert", "tube_grasp", "gap_insert", "gap_grasp", "cholecystectomy_press",
                           "cholecystectomy_grasp", "gynaecology_press", "gynaecology_grasp"}) {
    const auto c = check_recording_speed(read_recording(std::string(EBH_SOURCE_DIR) + "/recordings/" + name + ".h5"));
    EXPECT_FALSE(c.has_value()) << name << ": " << *c;
  }
}

// Times that do not go with rate_hz (another program's file with t in ms: a replay 1000 times
// slower than the device moved) are named, with the likely unit; a gap or a hold does not move the
// median, and the committed recordings agree with their rate.
TEST(RecordingRate, TimesThatDoNotGoWithRateHzAreNamed) {
  Recording r = make_recording(20);
  EXPECT_FALSE(check_recording_rate(r).has_value());
  for (std::size_t i = 15; i < r.size(); ++i) r.t[i] += 5;  // a 5 s gap
  EXPECT_FALSE(check_recording_rate(r).has_value());
  Recording ms = make_recording(20);
  for (double& t : ms.t) t *= 1000;
  ASSERT_TRUE(check_recording_rate(ms).has_value());
  EXPECT_EQ(*check_recording_rate(ms), "attribute rate_hz = 1000 Hz, but the samples are 1 s apart (the median interval: 1 "
                                       "Hz): times in ms, which a replay reads as seconds and plays that much slower than "
                                       "the device moved?");
  Recording odd = make_recording(20);
  for (double& t : odd.t) t *= 100;
  ASSERT_TRUE(check_recording_rate(odd).has_value());
  EXPECT_NE(check_recording_rate(odd)->find("(the median interval: 10 Hz): a replay follows the times, not rate_hz"),
            std::string::npos) << *check_recording_rate(odd);
  Recording dense = make_recording(20);
  for (double& t : dense.t) t *= 1e-3;
  ASSERT_TRUE(check_recording_rate(dense).has_value());
  EXPECT_NE(check_recording_rate(dense)->find("the samples are 1e-06 s apart (the median interval: 1e+06 Hz), over the "
                                              "100000 Hz a device samples at"),
            std::string::npos) << *check_recording_rate(dense);
  for (const char* name : {"tube_insert", "gap_grasp", "cholecystectomy_grasp", "gynaecology_press"}) {
    const auto c = check_recording_rate(read_recording(std::string(EBH_SOURCE_DIR) + "/recordings/" + name + ".h5"));
    EXPECT_FALSE(c.has_value()) << name << ": " << *c;
  }
}

// A turn no hand makes (half a turn between two samples, a device reset) is named like a jump; the
// committed recordings' turns are a hand's.
TEST(ToolTurn, ATurnInTheLogIsNamed) {
  Recording r = make_recording();
  for (std::size_t i = 0; i < r.size(); ++i)  // 10 rad/s about z
    r.orientation[i] = quat_from_rotvec(Vec3d{0, 0, 0.01 * static_cast<double>(i)});
  EXPECT_FALSE(check_recording_turn(r).has_value());
  for (std::size_t i = 7; i < r.size(); ++i) r.orientation[i] = r.orientation[i] * quat_from_rotvec(Vec3d{0, 0, 3.0});
  const auto w = check_recording_turn(r);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("turns 172 degrees between samples 6 and 7 (the recording's t = 0.006 .. 0.007 s: 3.01e+03 rad/s"),
            std::string::npos) << *w;
  EXPECT_NE(w->find("): a gap or a reset in the log, which"), std::string::npos) << *w;
  // A spin held over many samples (100 rad/s for 30 ms: a roll encoder, angles in degrees read as
  // radians) is the log's own motion, not a gap to cut: said with its run of samples.
  Recording spin = make_recording(60);
  for (std::size_t i = 0; i < spin.size(); ++i)
    spin.orientation[i] = quat_from_rotvec(Vec3d{0, 0, 0.1 * static_cast<double>(std::clamp<std::size_t>(i, 20, 50))});
  const auto s = check_recording_turn(spin);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->find("a gap or a reset"), std::string::npos) << *s;
  EXPECT_NE(s->find(": not a jump but 30 turns in a row from sample 20 to 50 (t = 0.02 .. 0.05 s), a motion no hand makes "
                    "held for 0.03 s (a part that spins"),
            std::string::npos) << *s;
  for (const char* name : {"tube_insert", "tube_grasp", "gap_insert", "gap_grasp", "cholecystectomy_press",
                           "cholecystectomy_grasp", "gynaecology_press", "gynaecology_grasp"}) {
    const auto c = check_recording_turn(read_recording(std::string(EBH_SOURCE_DIR) + "/recordings/" + name + ".h5"));
    EXPECT_FALSE(c.has_value()) << name << ": " << *c;
  }
}

// A rate no device samples at, in a file another writer made: refused at the limit synth and import
// hold to (docs/FORMATS.md, Limits).
TEST(Recording, ARateOverTheLimitIsRefused) {
  test::ScratchDir tmp;
  Recording r = make_recording();
  r.rate_hz = 1e6;
  write_recording(tmp / "fast.h5", r);
  EXPECT_INPUT_ERROR(read_recording(tmp / "fast.h5"), "fast.h5: attribute rate_hz = 1000000 Hz: over the 100000 Hz");
}

TEST(Recording, OneSampleIsNotATrajectory) {
  // A replay needs a duration: the message names the file and says so (it used to blame a
  // --start that was never given).
  test::ScratchDir tmp;
  const std::string path = tmp / "one.h5";
  {
    h5::File f = h5::File::create(path);
    h5::Group g = f.create_group("trajectory");
    g.write<double>("t", std::vector<double>{0.5}, {1});
    g.write<double>("position", std::vector<double>{0, 0, 0}, {1, 3});
    g.write<double>("orientation", std::vector<double>{1, 0, 0, 0}, {1, 4});
    g.write<double>("jaw", std::vector<double>{1}, {1});
    g.write<std::uint8_t>("buttons", std::vector<std::uint8_t>{0}, {1});
    f.set_attr("rate_hz", 1000.0);
    for (const char* a : {"source", "scene", "tool", "description"}) f.set_attr(a, "x");
    f.close();
  }
  EXPECT_INPUT_ERROR(read_recording(path), "one.h5: the recording has one sample; a recording needs at least two");
}

// A window of a long recording (read_recording with a window): only the samples a replay of it
// interpolates are kept, and they are the whole read's bit for bit, also where the file's
// quaternions change sign from sample to sample (the hemispheres continue across the parts it is
// read in), so a replay of the window renders what it rendered from the whole file.
TEST(RecordingWindow, KeepsTheWholeReadsSamplesOfTheWindowBitForBit) {
  const std::size_t n = 200'003;  // many parts and a bit
  Recording r = make_recording(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = r.t[i];
    r.position[i] = {0.02 * std::sin(3 * t), 0.01 * std::cos(2 * t), 0.001 * t};
    r.orientation[i] = quat_from_rotvec(Vec3d{0.3 * std::sin(t), 0.2, 0.7 * t});
    if (i % 3 == 1) r.orientation[i] = Quatd{-r.orientation[i].w, -r.orientation[i].x, -r.orientation[i].y, -r.orientation[i].z};
    r.jaw[i] = 0.5 + 0.5 * std::sin(t);
  }
  test::ScratchDir tmp;
  const std::string path = tmp / "window.h5";
  RawRecording(r).write(path);
  const Recording whole = read_recording(path);
  EXPECT_FALSE(whole.span);
  const Recording w = read_recording(path, RecordingWindow{131.0005, 0.25});  // rows 131000 .. 131252
  ASSERT_TRUE(w.span);
  EXPECT_EQ(w.span->first_row, 131000u);
  EXPECT_EQ(w.size(), 253u);  // from the sample at the start to one past the first at the end
  EXPECT_EQ(w.start_time(), whole.t.front());
  EXPECT_EQ(w.duration(), whole.duration());
  for (std::size_t i = 0; i < w.size(); ++i) {
    const std::size_t k = w.row(i);
    ASSERT_EQ(w.t[i], whole.t[k]);
    ASSERT_EQ(w.position[i], whole.position[k]);
    ASSERT_EQ(w.orientation[i].w, whole.orientation[k].w) << k;
    ASSERT_EQ(w.orientation[i].z, whole.orientation[k].z) << k;
    ASSERT_EQ(w.jaw[i], whole.jaw[k]);
  }
  // Every time a replay of the window asks for, its ends and a round-off past the end included.
  const double t0 = w.start_time() + 131.0005, t1 = t0 + 0.25;
  for (double t : {t0, t0 + 1e-7, 0.5 * (t0 + t1), t1, std::nextafter(t1, 1e9), t1 + 1e-6}) {
    const DeviceSample a = sample_at(w, t), b = sample_at(whole, t);
    EXPECT_EQ(a.position, b.position) << t;
    EXPECT_EQ(a.orientation.x, b.orientation.x) << t;
    EXPECT_EQ(a.jaw, b.jaw) << t;
  }
  // The outline the unit check judges spans the file: its first pose and one every stride.
  EXPECT_EQ(w.span->outline.size(), (n + 1) / 2);  // stride 2 for 200003 samples (at most 131072)
  EXPECT_EQ(w.span->outline[1], whole.position[2]);
  // A window from the start to the end is the whole recording.
  const Recording all = read_recording(path, RecordingWindow{0, 0});
  EXPECT_EQ(all.size(), n);
  EXPECT_EQ(all.orientation.back().y, whole.orientation.back().y);
}

// Every sample is checked, also outside the window, and messages name the file's rows.
TEST(RecordingWindow, ChecksEverySampleAndNamesTheFilesRow) {
  const std::size_t n = 70'000;
  test::ScratchDir tmp;
  const std::string path = tmp / "window_bad.h5";
  RawRecording raw(make_recording(n));
  raw.jaw[68'123] = 1.5;
  raw.write(path);
  EXPECT_INPUT_ERROR(read_recording(path, RecordingWindow{1.0, 0.5}), "window_bad.h5: /trajectory/jaw[68123]: jaw 1.5");
  raw.jaw[68'123] = 1;
  const double kept = raw.t[69'000];
  raw.t[69'000] = raw.t[68'999];
  raw.write(path);
  EXPECT_INPUT_ERROR(read_recording(path, RecordingWindow{1.0, 0.5}), "/trajectory/t[69000]: time not strictly increasing");
  raw.t[69'000] = kept;
  raw.pos[3 * 1'100] = std::numeric_limits<double>::quiet_NaN();
  raw.write(path);
  EXPECT_INPUT_ERROR(read_recording(path, RecordingWindow{1.0, 0.5}), "/trajectory/position[1100]: position is NaN");
}

// The unit check judges the whole file's path, also where a window of it was read: a window of a
// tool hovering still above the tissue is no sign of a log in the wrong unit.
TEST(RecordingWindow, TheUnitCheckJudgesTheWholePath) {
  const std::size_t n = 70'000;
  Recording r = make_recording(n);
  for (std::size_t i = 0; i < n; ++i)  // across a 40 mm box for 10 s, then hovering 5 mm above it
    r.position[i] = i < 10'000 ? Vec3d{-0.02 + 4e-6 * static_cast<double>(i), 0, 0}
                               : Vec3d{0.02, 0, 0.025 + 1e-9 * static_cast<double>(i % 7)};
  test::ScratchDir tmp;
  write_recording(tmp / "hover.h5", r);
  const Vec3d lo{-0.02, -0.02, -0.02}, hi{0.02, 0.02, 0.02};
  const Recording w = read_recording(tmp / "hover.h5", RecordingWindow{50, 1});
  EXPECT_EQ(check_recording_scale(w, lo, hi, std::nullopt), std::nullopt);
  Recording alone = w;  // the window's samples as a recording of their own
  alone.span.reset();
  EXPECT_NE(check_recording_scale(alone, lo, hi, std::nullopt), std::nullopt);
}
