#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <numbers>
#include <utility>

#include "io/import.hpp"
#include "io_test_util.hpp"

using namespace ebh;

namespace {

const std::string kData = EBH_TEST_DATA_DIR "/io/";

// The trajectory both sample logs hold (see their header comments): sample i = 0..19.
Vec3d known_position(std::size_t i) {
  double k = static_cast<double>(i);
  return Vec3d{10 + k, -5 + 0.5 * k, 30} * 1e-3;
}
Quatd known_orientation(std::size_t i) {
  return quat_from_rotvec(Vec3d{0, 0, 3.0 * static_cast<double>(i) * std::numbers::pi / 180});
}

double quat_angle(Quatd a, Quatd b) { return norm(rotvec_from_quat(conjugate(a) * b)); }

void expect_known(const Recording& r, double dt) {
  ASSERT_EQ(r.size(), 20u);
  for (std::size_t i = 0; i < r.size(); ++i) {
    // The logs print 9 significant digits: 1e-9 relative on mm values below 100.
    EXPECT_NEAR(norm(r.position[i] - known_position(i)), 0, 1e-10) << i;
    EXPECT_NEAR(quat_angle(r.orientation[i], known_orientation(i)), 0, 1e-8) << i;
    EXPECT_NEAR(r.jaw[i], 1.0 - static_cast<double>(i) / 19.0, 1e-9) << i;
    EXPECT_EQ(r.buttons[i], i >= 10 ? 1 : 0) << i;
    EXPECT_NEAR(r.t[i], dt * static_cast<double>(i), 1e-15) << i;
  }
  EXPECT_EQ(r.source, "device");
}

}  // namespace

TEST(Import, OpenHapticsLogMatchesTheKnownTrajectory) {
  ImportOptions opt;
  opt.scene = "tube";
  Recording r = import_log(kData + "sample_openhaptics.txt", opt);  // default: mm, 1000 Hz
  expect_known(r, 1e-3);
  EXPECT_EQ(r.rate_hz, 1000.0);
  EXPECT_EQ(r.scene, "tube");
}

TEST(Import, CsvLogMatchesTheKnownTrajectory) {
  ImportOptions opt;
  Recording r = import_log(kData + "sample.csv", opt);  // default: m, t column
  expect_known(r, 5e-4);
  EXPECT_EQ(r.rate_hz, 2000.0);  // intervals of 0.5 ms, rounded: within 1e-9 of 2000
}

// A ROS CSV export (rostopic echo -p of a PoseStamped): its %time in nanoseconds as t, the pose's
// fields as x, y, z, qx, qy, qz, qw, its header's fields left unread, said in the report; a
// TransformStamped's translation and rotation read the same; --time-unit still rules %time.
TEST(Import, RosCsvExportReadsItsPoseAndClock) {
  ImportReport report;
  const Recording r = import_log(kData + "sample_ros.csv", ImportOptions{}, &report);
  ASSERT_EQ(r.size(), 20u);
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_NEAR(norm(r.position[i] - known_position(i)), 0, 1e-10) << i;
    EXPECT_NEAR(quat_angle(r.orientation[i], known_orientation(i)), 0, 1e-8) << i;
    // 1.7e9 s from the epoch: the nanoseconds read as a double and scaled keep about 0.4 us
    EXPECT_NEAR(r.t[i] - 1.7e9, 5e-4 * static_cast<double>(i), 1e-6) << i;
    EXPECT_EQ(r.jaw[i], 1.0);  // open: the message has no jaw
  }
  // 19 intervals over 9.5 ms, each end known to the ~0.24 us a double keeps at 1.7e9 s: 0.1 Hz
  EXPECT_NEAR(r.rate_hz, 2000, 0.1);
  EXPECT_EQ(report.layout_note,
            "read as a ROS export: %time as t (nanoseconds), field.pose.position.x as x, field.pose.position.y as y, "
            "field.pose.position.z as z, field.pose.orientation.x as qx, field.pose.orientation.y as qy, "
            "field.pose.orientation.z as qz, field.pose.orientation.w as qw; 3 other fields left unread");
  test::ScratchDir tmp;
  std::ifstream in(kData + "sample_ros.csv");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"field.pose.position", "field.transform.translation"},
                                 {"field.pose.orientation", "field.transform.rotation"}})
    for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at)) text.replace(at, from.size(), to);
  std::ofstream(tmp / "transform.csv") << text;
  const Recording tf = import_log(tmp / "transform.csv", ImportOptions{});
  ASSERT_EQ(tf.size(), 20u);
  EXPECT_EQ(tf.position[7], r.position[7]);
  ImportOptions us;
  us.time_unit = 1e-6;  // a clock the user says is in microseconds: 1000 times slower than ns
  // 9.5 s from 1.7e12 s, whose doubles keep ~0.24 ms: 5e-5 of the rate at most
  EXPECT_NEAR(import_log(kData + "sample_ros.csv", us).rate_hz, 2, 1e-4);
  // Two poses in one message: both give x; said, with the option that leaves one unread.
  std::ofstream(tmp / "two.csv") << "%time,field.pose.position.x,field.goal.position.x\n1,0,0\n";
  EXPECT_INPUT_ERROR(import_log(tmp / "two.csv", ImportOptions{}),
                     "two.csv:1: column 'x' appears twice (read as a ROS export: field.pose.position.x and "
                     "field.goal.position.x both give it; --skip-column one of them)");
  // Without a pose's fields it is no pose log: said as a ROS export.
  std::ofstream(tmp / "twist.csv") << "%time,field.linear.x,field.linear.y,field.linear.z\n1,0,0,0\n2,0,0,0\n";
  EXPECT_INPUT_ERROR(import_log(tmp / "twist.csv", ImportOptions{}), "twist.csv:1: missing column 'x' (read as a ROS export");
}

// --start / --duration: the samples in the window, from the log's first sample, keep their times
// (the log's own, or i / rate); a window past the log's end is refused saying how long it is.
TEST(Import, AWindowOfTheLogKeepsItsTimes) {
  ImportOptions opt;
  opt.start_s = 5e-3;
  opt.duration_s = 4.5e-3;
  const Recording oh = import_log(kData + "sample_openhaptics.txt", opt);  // 1000 Hz: samples 5 .. 9
  ASSERT_EQ(oh.size(), 5u);
  for (std::size_t k = 0; k < oh.size(); ++k) {
    EXPECT_EQ(oh.t[k], static_cast<double>(k + 5) / 1000.0) << k;
    EXPECT_NEAR(norm(oh.position[k] - known_position(k + 5)), 0, 1e-10) << k;
  }
  opt.start_s = 2.4e-3;
  opt.duration_s = 1.5e-3;
  const Recording csv = import_log(kData + "sample.csv", opt);  // 2000 Hz: samples 5 .. 7
  ASSERT_EQ(csv.size(), 3u);
  EXPECT_NEAR(csv.t.front(), 2.5e-3, 1e-15);
  EXPECT_NEAR(norm(csv.position.back() - known_position(7)), 0, 1e-10);
  opt.duration_s.reset();
  opt.start_s = 0.25;
  EXPECT_INPUT_ERROR(import_log(kData + "sample.csv", opt), kData + "sample.csv: no samples in the window --start 0.25",
                     "the log's samples span 0.0095 s from its first");
  // A window that holds one sample: said with the window, not as a recording of one sample.
  opt.start_s = 9.2e-3;
  EXPECT_INPUT_ERROR(import_log(kData + "sample.csv", opt), kData + "sample.csv: one sample in the window --start 0.0092",
                     "a recording needs at least two: widen the window");
}

TEST(Import, TransformMapsTheLogFrameToTheWorld) {
  ImportOptions opt;
  opt.transforms.world = parse_rigid_transform("--transform", "0,0,10,0,0,90", parse_length_unit("mm"));
  Recording r = import_log(kData + "sample_openhaptics.txt", opt);
  Quatd rz = quat_from_rotvec(Vec3d{0, 0, std::numbers::pi / 2});
  for (std::size_t i = 0; i < r.size(); ++i) {
    Vec3d expect = rotate(rz, known_position(i)) + Vec3d{0, 0, 0.01};
    EXPECT_NEAR(norm(r.position[i] - expect), 0, 1e-10);
    EXPECT_NEAR(quat_angle(r.orientation[i], rz * known_orientation(i)), 0, 1e-8);
  }
}

TEST(Import, UnitOptionScalesPositions) {
  ImportOptions opt;
  opt.unit = parse_length_unit("cm");
  Recording r = import_log(kData + "sample_openhaptics.txt", opt);
  EXPECT_NEAR(norm(r.position[0] - 10.0 * known_position(0)), 0, 1e-12);
  EXPECT_INPUT_ERROR(parse_length_unit("inch"), "--unit", "inch");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "1,2,3", 1.0), "--transform", "6");
  // a rotation vector's angle past a turn (1e300 overflowed its length into a NaN pose)
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "0,0,0,1e300,0,0", 1.0), "--transform",
                     "the rotation vector's angle is inf degrees; give one of at most 360");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "0,0,0,300,300,0", 1.0), "angle is 424.3 degrees");
  EXPECT_NO_THROW(parse_rigid_transform("--tool-transform", "0,0,0,0,0,-360", 1.0));
  // numbers as a log or an option writes them: a subnormal is one, hexadecimal and 1e400 are not
  EXPECT_NO_THROW(parse_rigid_transform("--transform", "0,0,0,1e-320,0,0", 1.0));
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "0x1,0,0,0,0,0", 1.0), "--transform: x:", "'0x1' is not a number");
  EXPECT_INPUT_ERROR(parse_rigid_transform("--transform", "1e400,0,0,0,0,0", 1.0), "--transform: x:",
                     "'1e400' is beyond the range of a number");
  // named as the expected form names them (not "value 0" for the first)
  EXPECT_INPUT_ERROR(parse_rigid_transform("--tool-transform", "0,0,0,0,nan,0", 1.0), "--tool-transform: ry is not finite, got 'nan'");
}

namespace {
/// Writes `bytes` (as given: NULs and byte-order marks too) to `path`; returns the path.
std::string write_log(const std::string& path, const std::string& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  return path;
}
}  // namespace

TEST(Import, DefectsNameFileAndLine) {
  test::ScratchDir tmp;
  ImportOptions opt;
  const std::string bad = kData + "bad_rotation.txt";
  EXPECT_INPUT_ERROR(import_log(bad, opt), "bad_rotation.txt:14", "not a rotation");
  auto write = [&](const std::string& name, const std::string& bytes) { return write_log(tmp / name, bytes); };
  std::string p = write("a.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n# c\n0.001,0,0,abc,1,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "a.csv:4", "z", "'abc' is not a number");
  // ... and a column name of megabytes too.
  p = write("long_header.csv", "t,x,y,z,qw,qx,qy," + std::string(300000, 'Q') + "\n0,0,0,0,1,0,0,0\n");
  try {
    (void)import_log(p, opt);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown column '" + std::string(40, 'Q') + "... (300000 bytes)'"), std::string::npos);
    EXPECT_LT(std::string(e.what()).size(), 300u);
  }
  // Lines ended by a carriage return alone (Excel's "CSV (Macintosh)"): not an empty log.
  p = write("mac.csv", "t,x,y,z,qw,qx,qy,qz\r0,0,0,0,1,0,0,0\r0.001,0,0,0,1,0,0,0\r");
  EXPECT_INPUT_ERROR(import_log(p, opt), "mac.csv:1: lines end in a carriage return alone (classic Mac line ends)");
  // A field of megabytes (a broken export) is quoted by its start and its length, not whole.
  for (const std::string& field : {std::string(100001, '1'), "1" + std::string(100000, 'x')}) {
    p = write("long.csv", "t,x,y,z,qw,qx,qy,qz\n0," + field + ",0,0,1,0,0,0\n");
    try {
      (void)import_log(p, opt);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("long.csv:2: x: '" + field.substr(0, 40) + "... (100001 bytes)' is "), std::string::npos) << msg.substr(0, 200);
      EXPECT_LT(msg.size(), 300u);
    }
  }
  // A time that is not a number: named at its line wherever it is (a NaN failed the window's test
  // and its row was left out unsaid; one first made the log empty, one last its rate 0).
  for (const std::string nan_t : {"nan", "-inf", "inf"})
    for (int row = 0; row < 3; ++row) {
      std::string text = "t,x,y,z,qw,qx,qy,qz\n";
      for (int i = 0; i < 3; ++i) text += (i == row ? nan_t : std::to_string(0.001 * i)) + ",0,0,0,1,0,0,0\n";
      p = write("nan_t.csv", text);
      EXPECT_INPUT_ERROR(import_log(p, opt), "nan_t.csv:" + std::to_string(row + 2) + ": t is " + nan_t +
                                                 ": a sample's time must be a finite number");
    }
  p = write("b.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0,0,0,0.001,1,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "b.csv:3", "not strictly increasing");
  // A quote not closed on its line: said, not only counted.
  p = write("quote.csv", "t,x,y,z,qw,qx,qy,qz\n\"0,0,0,0,1,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "quote.csv:2: 1 fields, the header has 8; a quote (\") on the line is not closed");
  // Epoch times (a ROS export) shown to the digit that tells them apart, not as 1.7e+09 twice.
  p = write("epoch.csv", "t,x,y,z,qw,qx,qy,qz\n1700000000.002,0,0,0,1,0,0,0\n1700000000.001,0,0,0.001,1,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "epoch.csv:3: time not strictly increasing (1700000000.001 s after 1700000000.002 s)");
  p = write("c.csv", "t,x,y,qw,qx,qy,qz\n0,0,0,1,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "c.csv:1", "missing column 'z'");
  p = write("d.csv", "x,y,z,qw,qx,qy,qz,jaw\n0,0,0,1,0,0,0,1\n0,0,0,2,0,0,0,1\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "d.csv:3", "quaternion norm 2");
  p = write("d2.csv", "x,y,z,qw,qx,qy,qz\n0,0,0,0.71,0.71,0,0\n");  // 2 digits of 0.7071...: the order is not it
  EXPECT_INPUT_ERROR(import_log(p, opt), "d2.csv:2", "quaternion norm 1.00409163 is not 1 (within 0.001): written with too few digits?");
  p = write("time.csv", "time,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "time.csv:1: unknown column 'time'", "the samples' times? name the column t (seconds)");
  // Euler angles where the quaternion is read: not to be skipped (the orientation would be lost).
  p = write("euler.csv", "t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "euler.csv:1: unknown column 'roll'",
                     "angles of the tool's orientation? a CSV log gives it as the unit quaternion qw, qx, qy, qz");
  // An OpenHaptics log saved as .csv: read as CSV, its first line has 18 numbers.
  p = write("oh.csv", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "oh.csv:1: no header line", "(18 of them: an OpenHaptics log's 16 transform "
                                                                      "elements, jaw and buttons? --format openhaptics reads it)");
  p = write("e.csv", "x,y,z,qw,qx,qy,qz,jaw\n0,0,0,1,0,0,0,1.5\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "e.csv:2", "jaw 1.5 outside [0, 1]");
  p = write("f.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "f.txt:1", "16 fields");
  p = write("g.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n1 0 0 5 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "g.txt:2", "homogeneous");
  // a time column before the matrix: the bottom row one field later; ';' between the fields
  p = write("times.txt", "0.001 1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "times.txt:1", "homogeneous", "one field later: a column before the 16 elements");
  // the matrix written row by row: the translation in elements 3, 7, 11 (the jaw of 1 must not
  // read as the bottom row shifted by one)
  p = write("rowmajor.txt", "1 0 0 10 0 1 0 20 0 0 1 30 0 0 0 1 1\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "rowmajor.txt:1", "homogeneous", "row-major? elements 3, 7, 11 hold (10, 20, 30)");
  // an empty field: named, not read as one separator (which shifted the fields after it)
  p = write("dblcomma.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n1.0,,0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "dblcomma.txt:2: field 2 (element 1) is empty",
                     "two separators with nothing between them");
  p = write("endcomma.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0,\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "endcomma.txt:1: field 19 (button 1) is empty", "a separator ends the line");
  p = write("spaced.txt", "1, 0 ,0,0,0,1,0,0,0,0,1,0,5,6,7,1, 1 , 0\n1\t0\t0 0  0 1 0 0 0 0 1 0 5 6 8 1 1 0\n");
  EXPECT_EQ(import_log(p, opt).size(), 2u);  // a comma with blanks around it, or a run of blanks: one separator
  p = write("semi.txt", "1;0;0;0;0;1;0;0;0;0;1;0;5;6;7;1;1;0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "semi.txt:1", "1 fields", "not ';'");
  // a log written with decimal commas: every number splits in two
  p = write("h.txt", "1 0 0 0 0 1 0 0 0 0 1 0 2,5 6,25 7,5 1 1 0 0,5 0,5 0,5 0,5 0,5 0,5 0,5 0,5\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "h.txt:1", "more than 8 button states (decimal commas? write the numbers with a '.'");
  p = write("i.txt", "1 0 0 0 0 1 0 0 0 0 1 0 2.5 6 7 1 1 0 1 1 1 1 1 1 1 1 1\n");  // too many buttons, no commas
  try {
    import_log(p, opt);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), p + ":1: more than 8 button states");
  }
  // A line with a field fewer or more than the first sample's: the fields after it move (element
  // 14 missing read the jaw as element 15 and button 0 as the jaw).
  p = write("short.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0\n1 0 0 0 0 1 0 0 0 0 1 0 5 6 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "short.txt:2: 17 fields, but line 1, the first sample, has 18: a value missing or added?");
  // Decimal commas in fewer than 25 fields: said, not "row-major?".
  p = write("comma.txt", "1 0 0 0 0 1 0 0 0 0 1 0 2,5 6 7 1 1\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "comma.txt:1: not a homogeneous transform",
                     "(elements 3, 7, 11, 15 must be 0, 0, 0, 1; decimal commas? write the numbers with a '.'");
  // A decimal comma in one line of a log whose other numbers have points (a value typed in by
  // hand): said of that line, naming the number; of the first sample's line where the line whose
  // fields differ from it is another; in the jaw, whose decimals become a button.
  p = write("one_comma.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5.5 6.5 7 1 1 0\n1 0 0 0 0 1 0 0 0 0 1 0 5.5 6.5 7 1 1 0\n"
                             "1 0 0 0 0 1 0 0 0 0 1 0 5,5 6.5 7 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "one_comma.txt:3: 19 fields, but line 1, the first sample, has 18 (decimal "
                                         "commas? write the numbers with a '.': 5.5, not 5,5)");
  p = write("first_comma.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5.5 6 7 1 1,0 0\n1 0 0 0 0 1 0 0 0 0 1 0 5.5 6 7 1 1 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "first_comma.txt:2: 18 fields, but line 1, the first sample, has 19 (decimal "
                                         "commas? write the numbers with a '.': 1.0, not 1,0 in line 1)");
  p = write("jaw_comma.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5.5 6 7 1 0,75 0\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "jaw_comma.txt:1: button 0 (a state, 0 or 1; decimal commas? write the numbers "
                                         "with a '.': 0.75, not 0,75): '75' is not an integer in 0..1");
  // Fields separated by commas have commas between digits too: no decimal comma there.
  p = write("csv_like.txt", "1,0,0,0,0,1,0,0,0,0,1,0,5.5,6,7,1,1,0\n1,0,0,0,0,1,0,0,0,0,1,0,5.5,6,7,1,1\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "csv_like.txt:2: 17 fields, but line 1, the first sample, has 18: a value "
                                         "missing or added?");
  // A button state is 0 or 1: a counter after the buttons would press button 1 on every sample.
  p = write("counter.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0 0\n1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0 1\n"
                           "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1 0 2\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "counter.txt:3: button 1 (a state, 0 or 1; a counter or another column after the "
                                         "buttons?): '2' is not an integer in 0..1");
  p = write("h.txt", "# only comments\n\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "h.txt", "no samples");
  EXPECT_INPUT_ERROR(import_log(tmp / "absent.txt", opt), "absent.txt", "cannot open");
}

TEST(Import, FoldersAndBinaryFilesAreNotLogs) {
  test::ScratchDir tmp;
  ImportOptions opt;
  EXPECT_INPUT_ERROR(import_log(tmp.dir.string(), opt), "is a folder, not a file");
  {
    std::FILE* f = std::fopen((tmp / "png.csv").c_str(), "wb");
    std::fwrite("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 1, 16, f);
    std::fclose(f);
  }
  EXPECT_INPUT_ERROR(import_log(tmp / "png.csv", opt), "png.csv:2: byte 0x1a: not a text file");
}

// What spreadsheets write: a UTF-8 byte-order mark and CRLF line ends are read as the plain log;
// UTF-16 and ';'-separated columns are refused with what to change.
TEST(Import, SpreadsheetCsvFilesAreReadOrRefusedWithWhatToChange) {
  test::ScratchDir tmp;
  ImportOptions opt;
  auto write = [&](const std::string& name, const std::string& bytes) { return write_log(tmp / name, bytes); };
  const Recording r =
      import_log(write("bom.csv", "\xEF\xBB\xBFt,x,y,z,qw,qx,qy,qz\r\n0,0.1,0,0,1,0,0,0\r\n0.001,0.2,0,0,1,0,0,0\r\n"), opt);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r.position[1].x, 0.2);
  EXPECT_EQ(r.t[1], 0.001);
  EXPECT_INPUT_ERROR(import_log(write("utf16.csv", std::string("\xFF\xFEt\0,\0x\0", 8)), opt),
                     "utf16.csv:1: UTF-16 text", "save the log as UTF-8");
  EXPECT_INPUT_ERROR(import_log(write("semi.csv", "t;x;y;z;qw;qx;qy;qz\n0;0;0;0;1;0;0;0\n"), opt),
                     "semi.csv:1: unknown column", "not ';'");
}

// What Python writes: quoted fields (csv.QUOTE_NONNUMERIC, QUOTE_ALL) are read; a header that
// numpy.savetxt commented out, pandas' unnamed index column and units in the header are named.
TEST(Import, CsvFromPythonIsReadOrNamed) {
  test::ScratchDir tmp;
  ImportOptions opt;
  auto write = [&](const std::string& name, const std::string& bytes) { return write_log(tmp / name, bytes); };
  const Recording q = import_log(
      write("quoted.csv", "\"t\",\"x\",\"y\",\"z\",\"qw\",\"qx\",\"qy\",\"qz\"\n\"0\",\"0.1\",0,0,1,0,0,0\n0.001,0.2,0,0,1,0,0,0\n"),
      opt);
  ASSERT_EQ(q.size(), 2u);
  EXPECT_EQ(q.position[0].x, 0.1);
  EXPECT_EQ(q.t[1], 0.001);
  EXPECT_INPUT_ERROR(
      import_log(write("savetxt.csv", "# t,x,y,z,qw,qx,qy,qz\n0.0,0.1,0,0,1,0,0,0\n0.001,0.2,0,0,1,0,0,0\n"), opt),
      "savetxt.csv:2: no header line", "numpy.savetxt");
  EXPECT_INPUT_ERROR(import_log(write("pandas.csv", ",t,x,y,z,qw,qx,qy,qz\n0,0,0.1,0,0,1,0,0,0\n"), opt),
                     "pandas.csv:1: column 1 has no name", "index=False");
  EXPECT_INPUT_ERROR(import_log(write("units.csv", "t [s],x,y,z,qw,qx,qy,qz\n0,0.1,0,0,1,0,0,0\n"), opt),
                     "units.csv:1: '[s]': units in the header are not read", "--unit");
}

// What a logger stopped mid-line or retrying leaves, and numbers a spreadsheet wrote in another
// locale: a last line without a line end is left out (its last number may be cut: 0.0452001 read
// as 0.04), a row written twice, time included, is left out, a comma inside quotes is the
// field's, and a decimal comma is named.
TEST(Import, CutLinesRepeatedRowsAndDecimalCommas) {
  test::ScratchDir tmp;
  ImportOptions opt;
  auto write = [&](const std::string& name, const std::string& bytes) { return write_log(tmp / name, bytes); };
  const std::string head = "t,x,y,z,qw,qx,qy,qz\n0,0,0,0.045,1,0,0,0\n0.001,0,0,0.0451,1,0,0,0\n";
  ImportReport report;
  Recording r = import_log(write("cut.csv", head + "0.002,0,0,0.04"), opt, &report);
  EXPECT_EQ(r.size(), 2u);
  EXPECT_EQ(report.cut_line, 4u);
  EXPECT_EQ(import_log(write("whole.csv", head + "0.002,0,0,0.0452,1,0,0,0\n"), opt, &report).size(), 3u);
  EXPECT_EQ(report.cut_line, 0u);
  // OpenHaptics: the jaw of the cut line would have read 0 (closed) for 0.75
  const std::string oh = "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 0.75\n1 0 0 0 0 1 0 0 0 0 1 0 5 6 8 1 0.75\n";
  r = import_log(write("oh_cut.txt", oh + "1 0 0 0 0 1 0 0 0 0 1 0 5 6 9 1 0."), opt, &report);
  EXPECT_EQ(r.size(), 2u);
  EXPECT_EQ(report.cut_line, 3u);
  EXPECT_INPUT_ERROR(import_log(write("only_cut.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0"), opt),
                     "only_cut.csv: no samples", "line 2, has no line end");

  r = import_log(write("twice.csv", head + "0.001,0,0,0.0451,1,0,0,0\n0.002,0,0,0.0452,1,0,0,0\n"), opt, &report);
  EXPECT_EQ(r.size(), 3u);
  EXPECT_EQ(report.duplicate_rows, 1u);
  EXPECT_EQ(report.first_duplicate_line, 4u);
  EXPECT_EQ(r.t[2], 0.002);

  EXPECT_INPUT_ERROR(import_log(write("quoted_comma.csv", "t,x,y,z,qw,qx,qy,qz\n0,\"0,002\",0,0,1,0,0,0\n"), opt),
                     "quoted_comma.csv:2: x: '0,002' is not a number (a decimal comma?");
  EXPECT_INPUT_ERROR(import_log(write("tab_comma.csv", "t\tx\ty\tz\tqw\tqx\tqy\tqz\n0\t0,5\t0\t0\t1\t0\t0\t0\n"), opt),
                     "tab_comma.csv:2: 9 fields, the header has 8 (numbers with a decimal comma?");
  // a quote inside a quoted field is written twice
  EXPECT_INPUT_ERROR(import_log(write("quote.csv", "t,x,y,z,qw,qx,qy,qz\n0,\"1\"\"\",0,0,1,0,0,0\n"), opt),
                     "quote.csv:2: x: '1\"' is not a number");
}

// A logger's other data (a force sensor's columns) is refused as an unknown column, naming the
// option that leaves it unread; a skipped column must be in the header.
TEST(Import, OtherColumnsAreSkippedWhenNamed) {
  test::ScratchDir tmp;
  ImportOptions opt;
  const std::string p = write_log(tmp / "force.csv", "t,x,y,z,qw,qx,qy,qz,force_x\n0,0.1,0,0,1,0,0,0,0.5\n"
                                                       "0.001,0.2,0,0,1,0,0,0,0.6\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "force.csv:1: unknown column 'force_x'", "--skip-column force_x leaves it unread");
  opt.skip_columns = {"force_x"};
  const Recording r = import_log(p, opt);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r.position[1].x, 0.2);
  opt.skip_columns = {"force_y"};
  EXPECT_INPUT_ERROR(import_log(p, opt), "force.csv:1: --skip-column force_y: the header has no such column");
}

// A jaw in the log's own range (a gripper in degrees, a signal that is 1 when closed, one that
// runs a little past its ends) is mapped by --jaw-range; without it, a value outside [0, 1] names
// the option.
TEST(Import, TheJawRangeMapsTheLogsJawValues) {
  test::ScratchDir tmp;
  ImportOptions opt;
  const std::string p = write_log(tmp / "jaw.csv", "t,x,y,z,qw,qx,qy,qz,jaw\n0,0,0,0,1,0,0,0,30\n"
                                                     "0.001,0,0,0,1,0,0,0,7.5\n0.002,0,0,0,1,0,0,0,-0.3\n"
                                                     "0.003,0,0,0,1,0,0,0,-0.5\n");
  EXPECT_INPUT_ERROR(import_log(p, opt), "jaw.csv:2: jaw 30 outside [0, 1]", "--jaw-range CLOSED,OPEN");
  opt.jaw_range = parse_jaw_range("0,30");  // degrees, 0 closed
  ImportReport report;
  Recording r = import_log(p, opt, &report);
  EXPECT_EQ(r.jaw, (std::vector<double>{1.0, 0.25, 0.0, 0.0}));
  EXPECT_EQ(report.jaw_clamped, 2u);  // -0.3 and -0.5 degrees: past closed
  EXPECT_EQ(report.first_jaw_clamped_line, 4u);
  EXPECT_EQ(report.repeats, 0u);  // two readings the clamp made equal: no repeat (--drop-repeats keeps them)
  opt.jaw_range = parse_jaw_range("30,0");  // 30 when closed: inverted
  r = import_log(p, opt);
  EXPECT_EQ(r.jaw[0], 0.0);
  EXPECT_EQ(r.jaw[1], 0.75);
  EXPECT_INPUT_ERROR(parse_jaw_range("1,1"), "--jaw-range '1,1': the closed and open values are the same");
  EXPECT_INPUT_ERROR(parse_jaw_range("0,nan"), "--jaw-range '0,nan': expected CLOSED,OPEN");
  EXPECT_INPUT_ERROR(parse_jaw_range("0,1,2"), "expected CLOSED,OPEN");
  EXPECT_INPUT_ERROR(parse_jaw_range("-1e308,1e308"), "the span from closed to open is not a finite number");
  // A log without a jaw column has open samples, which a range must not map (0,255 made them
  // closed: a grasp from start to end on a forceps scene).
  const std::string no_jaw = write_log(tmp / "no_jaw.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.001,0,0,0,1,0,0,0\n");
  opt.jaw_range = parse_jaw_range("0,255");
  EXPECT_INPUT_ERROR(import_log(no_jaw, opt), "--jaw-range: " + no_jaw + " has no jaw column (its samples are taken open, 1)");
}

// A device without a gripper grasps with a button: --jaw-button I closes the jaws while bit I of
// the buttons is set, counting the presses; a logged jaw that moves (a gripper's) is not replaced,
// and the jaw comes from the button or from a range, not both.
TEST(Import, TheJawFollowsAButtonWhenAsked) {
  test::ScratchDir tmp;
  ImportOptions opt;
  const std::string p = write_log(tmp / "button.csv", "t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0,1,0,0,0,0\n"
                                                        "0.001,0,0,0,1,0,0,0,2\n0.002,0,0,0,1,0,0,0,3\n"
                                                        "0.003,0,0,0,1,0,0,0,1\n0.004,0,0,0,1,0,0,0,2\n");
  EXPECT_EQ(import_log(p, opt).jaw, (std::vector<double>{1, 1, 1, 1, 1}));  // no jaw column: open
  opt.jaw_button = 1;
  ImportReport report;
  EXPECT_EQ(import_log(p, opt, &report).jaw, (std::vector<double>{1, 0, 0, 1, 0}));
  EXPECT_EQ(report.jaw_button_presses, 2u);
  opt.jaw_button = 0;
  EXPECT_EQ(import_log(p, opt, &report).jaw, (std::vector<double>{1, 1, 0, 0, 1}));
  EXPECT_EQ(report.jaw_button_presses, 1u);
  opt.jaw_button = 5;
  EXPECT_EQ(import_log(p, opt, &report).jaw, (std::vector<double>{1, 1, 1, 1, 1}));
  EXPECT_EQ(report.jaw_button_presses, 0u);
  const std::string gripper = write_log(tmp / "gripper.csv", "t,x,y,z,qw,qx,qy,qz,jaw,buttons\n0,0,0,0,1,0,0,0,1,0\n"
                                                               "0.001,0,0,0,1,0,0,0,1,1\n0.002,0,0,0,1,0,0,0,0.5,1\n");
  opt.jaw_button = 0;
  EXPECT_INPUT_ERROR(import_log(gripper, opt), "gripper.csv:4: --jaw-button 0: the log's jaw moves (1 at its first "
                                               "sample, 0.5 here)");
  opt.jaw_range = parse_jaw_range("0,1");
  EXPECT_INPUT_ERROR(import_log(p, opt), "--jaw-button and --jaw-range: the jaw comes from one of them");
}

// A gap in a log's times (the logger missed samples) is named: a replay glides across it.
TEST(Import, GapsInTheTimesAreNamed) {
  test::ScratchDir tmp;
  ImportOptions opt;
  std::string text = "t,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i < 100; ++i) {
    const double t = i < 50 ? i * 1e-3 : 2.0 + i * 1e-3;
    text += std::to_string(t) + ",0,0," + std::to_string(0.001 * i) + ",1,0,0,0\n";
  }
  ImportReport report;
  import_log(write_log(tmp / "gap.csv", text), opt, &report);
  EXPECT_NE(report.gap_warning.find("a gap of 2.001 s between lines 51 and 52 (t = 0.049 .. 2.05 s)"), std::string::npos)
      << report.gap_warning;
  import_log(kData + "sample.csv", opt, &report);
  EXPECT_EQ(report.gap_warning, "");
  // An hour's gap in a 1 kHz log in seconds pulls the mean rate below a device's: not times in ms.
  text = "t,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i < 500; ++i)
    text += std::to_string(i < 250 ? i * 1e-3 : 3600.0 + i * 1e-3) + ",0,0," + std::to_string(0.001 * i) + ",1,0,0,0\n";
  import_log(write_log(tmp / "hour.csv", text), opt, &report);
  EXPECT_NE(report.gap_warning.find("a gap of 3600"), std::string::npos) << report.gap_warning;
  EXPECT_EQ(report.rate_warning, "") << "the rate between the samples is a device's";
}

// The recording's rate_hz is the device's, 1 / the median interval, as the rate checks take it:
// a gap in the logging leaves it be (the mean over the span, which it pulled down, gave 285 Hz for
// 1 s missing from a 1 kHz log of 1.4 s, and 0.14 Hz for an hour's).
TEST(Import, TheRateOfALogWithAGapIsItsMedianIntervals) {
  test::ScratchDir tmp;
  ImportOptions opt;
  ImportReport report;
  std::string text = "t,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i < 400; ++i)
    text += std::to_string(i < 200 ? i * 1e-3 : 1.0 + i * 1e-3) + ",0,0," + std::to_string(1e-5 * i) + ",1,0,0,0\n";
  const Recording r = import_log(write_log(tmp / "second.csv", text), opt, &report);
  EXPECT_NE(static_cast<double>(r.size() - 1) / r.duration(), 1000.0);
  EXPECT_EQ(r.rate_hz, 1000.0);
  EXPECT_EQ(r.rate_hz, nominal_rate(r.t));
  EXPECT_NE(report.gap_warning.find("a gap of 1.001 s between lines 201 and 202"), std::string::npos) << report.gap_warning;
  EXPECT_EQ(report.rate_warning, "");
  // Written and read back: the attribute a replay's rate check compares with the times.
  write_recording(tmp / "second.h5", r);
  const Recording back = read_recording(tmp / "second.h5");
  EXPECT_EQ(back.rate_hz, 1000.0);
  EXPECT_EQ(check_recording_rate(back), std::nullopt);
  text = "t,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i < 500; ++i)
    text += std::to_string(i < 250 ? i * 1e-3 : 3600.0 + i * 1e-3) + ",0,0," + std::to_string(1e-5 * i) + ",1,0,0,0\n";
  EXPECT_EQ(import_log(write_log(tmp / "hour.csv", text), opt).rate_hz, 1000.0);
}

// The separators the docs promise: a comma (blanks around it included) or a run of spaces or
// tabs, in the header as in the rows; an empty cell between commas is named, not skipped. A
// `.CSV` name is a CSV log; a CSV log under another name, read as OpenHaptics, says --format csv.
TEST(Import, CsvFieldsAreSeparatedByCommasOrRunsOfBlanks) {
  test::ScratchDir tmp;
  ImportOptions opt;
  auto write = [&](const std::string& name, const std::string& bytes) { return write_log(tmp / name, bytes); };
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"comma.csv", "t,x,y,z,qw,qx,qy,qz\n0,0.1,0,0,1,0,0,0\n0.001,0.2,0,0,1,0,0,0\n"},
           {"comma_space.csv", "t, x, y, z, qw, qx, qy, qz\n0, 0.1, 0, 0, 1, 0, 0, 0\n0.001 ,0.2 , 0,0,1,0,0,0\n"},
           {"tabs.csv", "t\tx\ty\tz\tqw\tqx\tqy\tqz\n0\t0.1\t0\t0\t1\t0\t0\t0\n0.001\t0.2\t0\t0\t1\t0\t0\t0\n"},
           {"spaces.csv", "t  x y z qw qx qy qz\n0 0.1   0 0 1 0 0 0\n0.001 \t0.2 0 0 1 0 0 0\n"},
           {"UPPER.CSV", "t,x,y,z,qw,qx,qy,qz\n0,0.1,0,0,1,0,0,0\n0.001,0.2,0,0,1,0,0,0\n"}}) {
    const Recording r = import_log(write(name, text), opt);
    ASSERT_EQ(r.size(), 2u) << name;
    EXPECT_EQ(r.position[1].x, 0.2) << name;
    EXPECT_EQ(r.t[1], 0.001) << name;
  }
  EXPECT_EQ(log_format_of("a/b.Csv"), LogFormat::csv);
  EXPECT_EQ(log_format_of("a.csv/log.txt"), LogFormat::openhaptics);
  EXPECT_INPUT_ERROR(import_log(write("empty_cell.csv", "t,x,y,z,qw,qx,qy,qz\n0,,0,0,1,0,0,0\n"), opt),
                     "empty_cell.csv:2: x: '' is not a number");
  EXPECT_INPUT_ERROR(import_log(write("log.txt", "t,x,y,z,qw,qx,qy,qz\n0,0.1,0,0,1,0,0,0\n"), opt),
                     "log.txt:1: 8 fields", "a CSV log with a header needs --format csv");
  opt.format = LogFormat::csv;
  EXPECT_EQ(import_log(write("log2.txt", "t x y z qw qx qy qz\n0 0 0 0 1 0 0 0\n1e-3 0 0 1 1 0 0 0\n"), opt).size(), 2u);
}

// Repeated samples (a device polled faster than it updates): counted, and with drop_repeats
// removed while the others keep the times the log gave them.
TEST(Import, CountsAndDropsRepeatedSamples) {
  ImportOptions opt;
  ImportReport report;
  Recording r = import_log(kData + "repeats.csv", opt, &report);
  EXPECT_EQ(r.size(), 6u);
  EXPECT_EQ(report.repeats, 2u);
  EXPECT_FALSE(report.dropped);
  EXPECT_EQ(r.rate_hz, 1000.0);  // 5 intervals over 5 ms
  opt.drop_repeats = true;
  r = import_log(kData + "repeats.csv", opt, &report);
  EXPECT_TRUE(report.dropped);
  EXPECT_EQ(report.repeats, 2u);
  EXPECT_EQ(r.t, (std::vector<double>{0.000, 0.001, 0.004, 0.005}));
  EXPECT_EQ(r.buttons, (std::vector<std::uint8_t>{0, 0, 0, 1}));
  EXPECT_EQ(r.rate_hz, 1000.0);  // the log's rate: the kept samples are a subset of its ticks
}

// A 250 Hz device logged at 1 kHz, each update logged four times: said when kept (the replay would
// hold and jump the tool 250 times a second), not when dropped.
TEST(Import, ADeviceSlowerThanTheLogIsSaid) {
  test::ScratchDir tmp;
  std::string text = "t,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i < 400; ++i)
    text += std::to_string(i * 1e-3) + ",0,0," + std::to_string(1e-5 * (i / 4)) + ",1,0,0,0\n";
  ImportOptions opt;
  ImportReport report;
  import_log(write_log(tmp / "stale.csv", text), opt, &report);
  EXPECT_NE(report.stale_warning.find("the pose changes only every 4 samples (100% of its 99 changes): a device updating "
                                      "at about 250 Hz logged at 1000 Hz"),
            std::string::npos)
      << report.stale_warning;
  opt.drop_repeats = true;
  import_log(write_log(tmp / "stale.csv", text), opt, &report);
  EXPECT_EQ(report.stale_warning, "");
  import_log(kData + "sample.csv", ImportOptions{}, &report);
  EXPECT_EQ(report.stale_warning, "");
}

// A hold (the device at rest: repeats lasting more than kStaleRunMaxS) is not stale: it keeps
// its last sample, so the replay holds still until the device moves, and the log's last sample is
// kept, so a log ending at rest keeps its length. Short runs (a device updating at a third of the
// logging rate) are still dropped.
TEST(Import, DroppingRepeatsKeepsHoldsAndTheLogsEnd) {
  test::ScratchDir tmp;
  // 1 kHz: 0..29 ms moving, each new sample logged three times (two stale repeats); 30..80 ms at
  // rest (50 repeats of sample 30); 81..89 ms moving; 90..200 ms at rest until the log ends.
  std::vector<double> z;
  for (int i = 0; i < 30; ++i) z.push_back(i / 3);
  for (int i = 30; i <= 80; ++i) z.push_back(10);
  for (int i = 81; i < 90; ++i) z.push_back(10 + (i - 80));
  for (int i = 90; i <= 200; ++i) z.push_back(20);
  std::string text = "t,x,y,z,qw,qx,qy,qz\n";
  for (std::size_t i = 0; i < z.size(); ++i) text += std::to_string(1e-3 * static_cast<double>(i)) + ",0,0," +
                                                     std::to_string(1e-3 * z[i]) + ",1,0,0,0\n";
  const std::string path = write_log(tmp / "hold.csv", text);
  ImportOptions opt;
  ImportReport report;
  const Recording all = import_log(path, opt, &report);
  EXPECT_EQ(report.repeats, 20u + 50 + 110);
  EXPECT_EQ(report.holds, 2u);
  EXPECT_EQ(report.removable, 20u + 49 + 109);
  EXPECT_FALSE(report.dropped);
  opt.drop_repeats = true;
  const Recording r = import_log(path, opt, &report);
  EXPECT_TRUE(report.dropped);
  EXPECT_EQ(report.holds, 2u);
  EXPECT_EQ(r.size(), all.size() - report.removable);
  EXPECT_EQ(r.t.back(), all.t.back());  // the duration unchanged: the hold at the end is kept
  EXPECT_EQ(r.rate_hz, all.rate_hz);
  // The stale repeats are gone: 3 ms between the samples of the motion, interpolated linearly.
  EXPECT_EQ(r.t[1], all.t[3]);
  EXPECT_NEAR(sample_at(r, 0.0015).position.z, 0.0005, 1e-12);
  // Still through both holds, moving again one sample interval after each.
  for (double t : {0.031, 0.055, 0.0795, 0.080}) EXPECT_EQ(sample_at(r, t).position.z, 0.010) << t;
  EXPECT_GT(sample_at(r, 0.0805).position.z, 0.010);
  for (double t : {0.091, 0.150, 0.200}) EXPECT_EQ(sample_at(r, t).position.z, 0.020) << t;
  // A short run at the log's end: dropped but for the last sample, the duration unchanged.
  const Recording end =
      import_log(write_log(tmp / "end.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.001,0,0,0.001,1,0,0,0\n"
                                            "0.002,0,0,0.001,1,0,0,0\n0.003,0,0,0.001,1,0,0,0\n"),
                 opt, &report);
  EXPECT_EQ(end.t, (std::vector<double>{0.0, 0.001, 0.003}));
  EXPECT_EQ(report.holds, 0u);
  EXPECT_EQ(report.removable, 1u);
  // A 100 Hz device logged at 10 kHz repeats each sample 99 times (9.9 ms): stale, not 20 holds
  // (as a rule counting samples took them); its rest after 0.2 s (50 ms) is one hold.
  std::string fast = "t,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i <= 2500; ++i)
    fast += std::to_string(1e-4 * i) + ",0,0," + std::to_string(1e-3 * std::min(i / 100, 20)) + ",1,0,0,0\n";
  const Recording f = import_log(write_log(tmp / "fast.csv", fast), opt, &report);
  EXPECT_EQ(report.holds, 1u);
  EXPECT_EQ(f.size(), 21u + 1);  // the 21 updates and the log's end
  EXPECT_NEAR(f.t.back(), 0.25, 1e-12);
}

TEST(Import, ALogWithoutTimesTakesTheGivenRateAndKeepsTimesWhenDropping) {
  ImportOptions opt;
  opt.rate_hz = 250;
  opt.drop_repeats = true;
  ImportReport report;
  const Recording r = import_log(kData + "repeats_openhaptics.txt", opt, &report);
  EXPECT_EQ(report.repeats, 2u);
  EXPECT_FALSE(report.rate_assumed);
  EXPECT_EQ(r.rate_hz, 250.0);
  // samples 0, 2, 3 of 0..4, and 4, the log's last: the recording keeps its length
  EXPECT_EQ(r.t, (std::vector<double>{0.0, 2 / 250.0, 3 / 250.0, 4 / 250.0}));
  ImportOptions plain;
  import_log(kData + "repeats_openhaptics.txt", plain, &report);
  EXPECT_TRUE(report.rate_assumed);  // said by ebh import
}

// A log is read up to the samples a recording holds: one more stops the import at that line,
// before the rest of the log is read (a later defect is never reached) or held in memory.
TEST(Import, ALogPastTheSampleLimitStopsAtTheFirstSampleBeyondIt) {
  test::ScratchDir tmp;
  EXPECT_EQ(ImportOptions{}.max_samples, static_cast<std::size_t>(kMaxRecordingSamples));
  ImportOptions opt;
  opt.max_samples = 3;
  {
    std::FILE* f = std::fopen((tmp / "long.csv").c_str(), "w");
    std::fputs("x,y,z,qw,qx,qy,qz\n# comment\n0,0,0,1,0,0,0\n0,0,1,1,0,0,0\n\n0,0,2,1,0,0,0\n0,0,3,1,0,0,0\nnot a sample\n", f);
    std::fclose(f);
  }
  EXPECT_INPUT_ERROR(import_log(tmp / "long.csv", opt), tmp / "long.csv:7: more than 3 samples",
                     "import it a window at a time (--start S --duration S)");
  // a window of the log within the limit is read, the lines after it not
  opt.start_s = 1.5e-3;
  opt.duration_s = 2e-3;
  EXPECT_EQ(import_log(tmp / "long.csv", opt, nullptr).size(), 2u);  // samples 2 and 3 (at 1000 Hz)
  opt.start_s = 0;
  opt.duration_s.reset();
  {
    std::FILE* f = std::fopen((tmp / "long.txt").c_str(), "w");
    for (int i = 0; i < 4; ++i) std::fputs("1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1 1\n", f);
    std::fputs("garbage\n", f);
    std::fclose(f);
  }
  EXPECT_INPUT_ERROR(import_log(tmp / "long.txt", opt), tmp / "long.txt:4: more than 3 samples");
  opt.max_samples = 4;  // exactly at the limit: read
  {
    std::FILE* f = std::fopen((tmp / "four.txt").c_str(), "w");
    for (int i = 0; i < 4; ++i) std::fprintf(f, "1 0 0 0 0 1 0 0 0 0 1 0 5 6 %d 1 1\n", i);
    std::fclose(f);
  }
  EXPECT_EQ(import_log(tmp / "four.txt", opt).size(), 4u);
}

// A device logs at 100 Hz to 10 kHz: times in ms, us or ns read as seconds make a rate 1e3, 1e6 or
// 1e9 times too low, refused naming the unit (a warning with --time-unit s, which says the times
// are seconds: an exit 0 and a recording at 1 Hz went on into a script's replay); times that give
// more than the 100 kHz limit are refused naming the file and column.
TEST(Import, ALogsTimesInTheWrongUnitAreNamed) {
  test::ScratchDir tmp;
  auto log = [&](const std::string& name, double seconds_per_unit) {
    std::FILE* f = std::fopen((tmp / name).c_str(), "w");
    std::fputs("t,x,y,z,qw,qx,qy,qz\n", f);
    for (int i = 0; i < 5; ++i) std::fprintf(f, "%.17g,0,0,%d,1,0,0,0\n", 1e-3 * i / seconds_per_unit, i);
    std::fclose(f);
    return tmp / name;
  };
  ImportOptions opt;
  ImportReport report;
  EXPECT_EQ(import_log(log("s.csv", 1), opt, &report).rate_hz, 1000.0);
  EXPECT_EQ(report.rate_warning, "");
  for (const auto& [unit, symbol, per_s] : {std::tuple{"milliseconds", "ms", 1e-3}, {"microseconds", "us", 1e-6},
                                            {"nanoseconds", "ns", 1e-9}}) {
    const std::string file = log(std::string(unit) + ".csv", per_s);
    EXPECT_INPUT_ERROR(import_log(file, opt), file + ": column t: the times give",
                       std::string("the times look like ") + unit + " (1000 Hz): import again with --time-unit " + symbol +
                           " (--time-unit s keeps them as seconds)");
    ImportOptions as_seconds = opt;
    as_seconds.time_unit = 1.0;
    EXPECT_EQ(import_log(file, as_seconds, &report).size(), 5u);
    EXPECT_NE(report.rate_warning.find(std::string("column t: the times give ") + (per_s == 1e-3 ? "1 Hz" : "")),
              std::string::npos)
        << report.rate_warning;
    EXPECT_NE(report.rate_warning.find(std::string("the times look like ") + unit + " (1000 Hz): import again with "
                                       "--time-unit " + symbol),
              std::string::npos)
        << report.rate_warning;
    // Read in that unit: the times in seconds, 1 ms apart.
    ImportOptions in_unit = opt;
    in_unit.time_unit = parse_time_unit(symbol);
    const Recording r = import_log(file, in_unit, &report);
    EXPECT_EQ(r.rate_hz, 1000.0) << symbol;
    // 4e-3 / per_s units times per_s: exact but for the round-off of a division and a product
    EXPECT_NEAR(r.t.back(), 0.004, 1e-15) << symbol;
    EXPECT_EQ(report.rate_warning, "") << symbol;
  }
  EXPECT_INPUT_ERROR(parse_time_unit("min"), "--time-unit: 'min' is not one of s, ms, us, ns");
  ImportOptions no_times;
  no_times.time_unit = 1e-3;
  EXPECT_INPUT_ERROR(import_log(kData + "repeats_openhaptics.txt", no_times), "--time-unit: ",
                     "has no t column");
  // 1 us apart in a log stamped in seconds would be 1 MHz: ten times the limit.
  EXPECT_INPUT_ERROR(import_log(log("fast.csv", 1e3), opt), tmp / "fast.csv: column t: the times give 1e+06 Hz",
                     "beyond the 100 kHz limit", "t must be in seconds");
  // A log without times: --rate in kHz instead of Hz.
  opt.rate_hz = 1;
  import_log(kData + "repeats_openhaptics.txt", opt, &report);
  EXPECT_NE(report.rate_warning.find("--rate 1 Hz is below 10 Hz"), std::string::npos) << report.rate_warning;
  EXPECT_NE(report.rate_warning.find("--rate 1000?"), std::string::npos) << report.rate_warning;
  opt.rate_hz = 250;
  import_log(kData + "repeats_openhaptics.txt", opt, &report);
  EXPECT_EQ(report.rate_warning, "");
}

// Times counted from an epoch keep |t| 2^-52 s of resolution: a Unix time (1.7e9 s) leaves 1 kHz
// samples 4e-7 s (0.04%, fine); 1e12 s, 2.2e-4 s (22%: said, with the fix).
TEST(Import, TimesFromAFarEpochAreSaidToBeRounded) {
  test::ScratchDir tmp;
  auto log = [&](const std::string& name, double epoch) {
    std::FILE* f = std::fopen((tmp / name).c_str(), "w");
    std::fputs("t,x,y,z,qw,qx,qy,qz\n", f);
    for (int i = 0; i < 5; ++i) std::fprintf(f, "%.17g,0,0,%d,1,0,0,0\n", epoch + 1e-3 * i, i);
    std::fclose(f);
    return tmp / name;
  };
  ImportOptions opt;
  ImportReport report;
  import_log(log("unix.csv", 1.7e9), opt, &report);
  EXPECT_EQ(report.rate_warning, "");
  import_log(log("far.csv", 1e12), opt, &report);
  EXPECT_NE(report.rate_warning.find("column t: times near 1e+12 s keep only 0.0002"), std::string::npos)
      << report.rate_warning;
  EXPECT_NE(report.rate_warning.find("count t from the log's start"), std::string::npos) << report.rate_warning;
  // Farther still, 1 ms steps read as one time: said as the rounding it is, not only as times out of order.
  EXPECT_INPUT_ERROR(import_log(log("farther.csv", 1e15), opt), "farther.csv:3: time not strictly increasing",
                     "so far from 0 a double holds times only to", "count t from the log's start");
}

TEST(Import, NominalRateIsExactForWholeRates) {
  std::vector<double> t;
  for (int i = 0; i <= 1000; ++i) t.push_back(0.001 * i);  // 1 kHz with the rounding of 0.001 i
  EXPECT_EQ(nominal_rate(t), 1000.0);
  EXPECT_EQ(nominal_rate({0.0, 0.3, 0.6}), 2 / 0.6);  // not near a whole number: kept as is
  // 1e-7 off: not rounded; of two intervals the median is the longer (median_interval)
  EXPECT_EQ(nominal_rate({0.0, 0.5, 1.0000001}), 1 / (1.0000001 - 0.5));
  EXPECT_EQ(nominal_rate({0.0, 0.25}), 4.0);  // two samples: their one interval
  // A gap: the median interval's rate, not the mean's (4 intervals over 1.003 s)
  EXPECT_EQ(nominal_rate({0.0, 0.001, 0.002, 1.002, 1.003}), 1000.0);
  // 10 kHz in Unix time: the times' round-off (2.4e-7 s at 1.7e9 s) is the rate's, not a rate
  std::vector<double> unix_t;
  for (int i = 0; i <= 3336; ++i) unix_t.push_back(1.7e9 + 0.1 + i * 1e-4);  // 9999.99867 Hz from the span
  EXPECT_NE(static_cast<double>(unix_t.size() - 1) / (unix_t.back() - unix_t.front()), 10000.0);
  EXPECT_EQ(nominal_rate(unix_t), 10000.0);
  // and a rate that is truly off the whole number, at the epoch, is kept
  std::vector<double> off_t;
  for (int i = 0; i <= 20000; ++i) off_t.push_back(1.7e9 + i * 1.001e-4);
  EXPECT_NE(nominal_rate(off_t), 10000.0);
}
