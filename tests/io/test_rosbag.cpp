// ROS 1 bags imported (io/rosbag.hpp, io/import.hpp): the bags of tests/data/io were written by
// rosbag itself (make_bags.py: the trajectory of the other sample logs), and malformed ones are
// made here from them (random damage: tests/io/fuzz/bag_fuzz.cpp, under the sanitizers).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>
#include <vector>

#include "io/import.hpp"
#include "io/rosbag.hpp"
#include "io_test_util.hpp"

using namespace ebh;

namespace {

const std::string kData = EBH_TEST_DATA_DIR "/io/";

// make_bags.py's sample i: 2 kHz from 1.7e9 s (the header stamp; recorded 0.2 ms later).
Vec3d known_position(std::size_t i) {
  const double k = static_cast<double>(i);
  return Vec3d{(10 + k) * 1e-3, (-5 + 0.5 * k) * 1e-3, 30e-3};
}
// Round-off between the bag's numbers and the ones computed here: the writer's sin and cos against
// quat_from_rotvec's (the turn, rad), 0.8 (1 - i/19) mapped back by --jaw-range 0,0.8 (the jaw),
// a few ulps of numbers below 1; the times (s): 1.7e9 s keeps ~0.24 us in a double.
constexpr double kTurnRoundOff = 1e-12, kJawRoundOff = 1e-12, kTimeRoundOff = 5e-7;

Quatd known_orientation(std::size_t i) {
  return quat_from_rotvec(Vec3d{0, 0, 3.0 * static_cast<double>(i) * std::numbers::pi / 180});
}
double stamp(std::size_t i) { return 1.7e9 + 5e-4 * static_cast<double>(i); }

double quat_angle(Quatd a, Quatd b) { return norm(rotvec_from_quat(conjugate(a) * b)); }

ImportOptions bag_options(const std::string& pose_topic, const std::string& jaw_topic = "",
                          const std::string& frame = "") {
  ImportOptions o;
  o.topic = pose_topic;
  o.jaw_topic = jaw_topic;
  o.frame = frame;
  return o;
}

ImportOptions with_jaw(const std::string& pose_topic, const std::string& jaw_topic) {
  ImportOptions o = bag_options(pose_topic, jaw_topic);
  o.jaw_range = std::pair{0.0, 0.8};  // the gripper's angle in rad, closed .. open
  return o;
}

std::vector<char> bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<char>& b) {
  std::ofstream(path, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
}

/// The offset of the first `text` in b (the test fails without one).
std::size_t find(const std::vector<char>& b, const std::string& text) {
  const auto it = std::search(b.begin(), b.end(), text.begin(), text.end());
  EXPECT_NE(it, b.end()) << "no '" << text << "' in the bag";
  return static_cast<std::size_t>(it - b.begin());
}

/// The same samples, bit for bit but for the orientation's `turn` (rad): bags whose writers
/// computed the quaternions with another sin and cos (JavaScript's, Python's) differ in the last bit.
void expect_same(const Recording& a, const Recording& b, double turn = 0) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.t[i], b.t[i]) << i;
    EXPECT_EQ(a.position[i], b.position[i]) << i;
    if (turn == 0) {
      EXPECT_EQ(a.orientation[i].w, b.orientation[i].w) << i;
      EXPECT_EQ(a.orientation[i].z, b.orientation[i].z) << i;
    } else {
      EXPECT_LE(quat_angle(a.orientation[i], b.orientation[i]), turn) << i;
    }
    EXPECT_EQ(a.jaw[i], b.jaw[i]) << i;
  }
}

}  // namespace

TEST(RosBag, APoseTopicAndItsGripperReadAsTheDeviceLogged) {
  ImportReport report;
  const Recording r = import_log(kData + "sample.bag", with_jaw("", "/psm/jaw/measured_js"), &report);
  ASSERT_EQ(r.size(), 20u);
  for (std::size_t i = 0; i < r.size(); ++i) {
    // The message's float64 as written: the same double
    EXPECT_EQ(r.position[i], known_position(i)) << i;
    EXPECT_NEAR(quat_angle(r.orientation[i], known_orientation(i)), 0, kTurnRoundOff) << i;
    // The header stamp (not the record time, 0.2 ms later): whole nanoseconds, kept to the
    // ~0.24 us a double resolves at 1.7e9 s
    EXPECT_NEAR(r.t[i], stamp(i), kTimeRoundOff) << i;
    EXPECT_NEAR(r.jaw[i], 1.0 - static_cast<double>(i) / 19.0, kJawRoundOff) << i;
    EXPECT_EQ(r.buttons[i], 0) << i;
  }
  // 19 intervals over 9.5 ms, each end known to the ~0.24 us a double keeps at 1.7e9 s: 0.1 Hz
  EXPECT_NEAR(r.rate_hz, 2000, 0.1);
  EXPECT_EQ(report.layout_note,
            "read as a ROS 1 bag: topic /psm/measured_cp (geometry_msgs/PoseStamped, 20 messages), the jaw from "
            "/psm/jaw/measured_js (sensor_msgs/JointState, 20 messages; each pose takes the last at or before it); "
            "times from the messages' header stamps");
  EXPECT_EQ(r.description, "imported from " + kData + "sample.bag (ROS 1 bag, topic /psm/measured_cp)");
  EXPECT_EQ(report.cut_bytes, 0u);
  // Without a jaw topic the jaws are open; a window of the log keeps the bag's times.
  ImportOptions window;
  window.start_s = 0.002;
  window.duration_s = 0.0021;
  const Recording w = import_log(kData + "sample.bag", window);
  ASSERT_EQ(w.size(), 5u);
  EXPECT_EQ(w.position[0], known_position(4));
  EXPECT_EQ(w.jaw[0], 1.0);
}

TEST(RosBag, Bz2AndLz4ChunksReadAsTheUncompressedBag) {
  const Recording plain = import_log(kData + "sample.bag", with_jaw("", "/psm/jaw/measured_js"));
  for (const auto& [file, reads] : {std::pair{"sample_bz2.bag", rosbag_reads("bz2")}, {"sample_lz4.bag", rosbag_reads("lz4")}}) {
    SCOPED_TRACE(file);
    if (reads)
      expect_same(import_log(kData + file, with_jaw("", "/psm/jaw/measured_js")), plain);
    else  // a build without the library says so
      EXPECT_INPUT_ERROR(import_log(kData + file, ImportOptions{}), "-compressed chunk, and this build of ebh has no");
  }
}

TEST(RosBag, TopicsAreChosenByNameAndType) {
  const std::string bag = kData + "topics.bag";
  // Three pose topics: which is the device's is the user's to say.
  EXPECT_INPUT_ERROR(import_log(bag, ImportOptions{}),
                     "topics.bag: several pose topics: /psm1/measured_cp (geometry_msgs/PoseStamped, 20), "
                     "/psm2/measured_cp (geometry_msgs/TransformStamped, 20), /mtm/pose (geometry_msgs/Pose, 20); "
                     "name the device's with --topic");
  const Recording reference = import_log(kData + "sample.bag", ImportOptions{});
  expect_same(import_log(bag, bag_options("/psm2/measured_cp")), reference);
  // A Pose has no header: the bag's record times, said; so with a jaw of std_msgs/Float64.
  ImportReport report;
  const Recording pose = import_log(bag, with_jaw("/mtm/pose", "/mtm/gripper"), &report);
  ASSERT_EQ(pose.size(), 20u);
  for (std::size_t i = 0; i < pose.size(); ++i) {
    EXPECT_EQ(pose.position[i], known_position(i)) << i;
    EXPECT_NEAR(pose.t[i], stamp(i) + 2e-4, kTimeRoundOff) << i;
    EXPECT_NEAR(pose.jaw[i], 1.0 - static_cast<double>(i) / 19.0, kJawRoundOff) << i;
  }
  EXPECT_NE(report.layout_note.find("times from the bag's record times (geometry_msgs/Pose has no header)"),
            std::string::npos)
      << report.layout_note;
  // A stamped pose with a jaw without stamps: one clock for both, the bag's.
  EXPECT_NEAR(import_log(bag, with_jaw("/psm1/measured_cp", "/mtm/gripper")).t[3], stamp(3) + 2e-4, kTimeRoundOff);
  const auto named = [&](const std::string& pose_topic, const std::string& jaw_topic) {
    return import_log(bag, bag_options(pose_topic, jaw_topic));
  };
  EXPECT_INPUT_ERROR(named("/psm3/measured_cp", ""), "topics.bag: --topic /psm3/measured_cp: the bag has no such topic; its "
                     "topics: /tf_static (tf2_msgs/TFMessage, 1), /psm1/measured_cp (geometry_msgs/PoseStamped, 20), ");
  EXPECT_INPUT_ERROR(named("/mtm/gripper", ""), "--topic /mtm/gripper: a std_msgs/Float64 topic (a pose is read from");
  EXPECT_INPUT_ERROR(named("/psm1/measured_cp", "/psm2/measured_cp"),
                     "--jaw-topic /psm2/measured_cp: a geometry_msgs/TransformStamped topic (a jaw opening is read from");
  EXPECT_INPUT_ERROR(named("/psm1/measured_cp", "/mtm/grip"), "--jaw-topic /mtm/grip: the bag has no such topic");
  // The bag's options on another log, and a text log's on a bag.
  ImportOptions on_csv;
  on_csv.topic = "/psm/measured_cp";
  EXPECT_INPUT_ERROR(import_log(kData + "sample.csv", on_csv), "--topic: ", "sample.csv is not a ROS bag");
  ImportOptions time_unit;
  time_unit.time_unit = 1e-9;
  EXPECT_INPUT_ERROR(import_log(bag, time_unit), "--time-unit: ", "is a ROS bag, whose times are ROS times");
  ImportOptions range;
  range.topic = "/psm1/measured_cp";
  range.jaw_range = std::pair{0.0, 0.8};
  EXPECT_INPUT_ERROR(import_log(bag, range), "--jaw-range: ", "without a jaw topic", "--jaw-topic");
}

TEST(RosBag, ARecordingStoppedMidWriteReadsUpToItsLastWholeRecord) {
  test::ScratchDir tmp;
  std::vector<char> b = bytes_of(kData + "sample.bag");
  // The index after the chunk cut short: every message is in the chunk before it.
  const std::size_t index = find(b, std::string("op=\x04", 4));
  std::vector<char> cut(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(index + 3));
  write_bytes(tmp / "stopped.bag.active", cut);
  EXPECT_EQ(log_format_of(tmp / "stopped.bag.active"), LogFormat::rosbag);
  ImportReport report;
  const Recording r = import_log(tmp / "stopped.bag.active", ImportOptions{}, &report);
  EXPECT_EQ(r.size(), 20u);
  EXPECT_GT(report.cut_bytes, 0u);
  // Cut inside the chunk: nothing of it is read, and the message says why.
  const std::size_t chunk = find(b, std::string("op=\x05", 4));
  cut.assign(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(chunk + 200));
  write_bytes(tmp / "early.bag", cut);
  EXPECT_INPUT_ERROR(import_log(tmp / "early.bag", ImportOptions{}), "early.bag: no pose topic",
                     "a record cut short, are left out: a recording stopped while writing it?");
}

TEST(RosBag, MalformedBagsAreRefusedWithTheirPlace) {
  test::ScratchDir tmp;
  const std::vector<char> good = bytes_of(kData + "sample.bag");
  const auto refused = [&](const std::string& name, std::vector<char> b, std::initializer_list<std::string> parts) {
    SCOPED_TRACE(name);
    write_bytes(tmp / name, b);
    try {
      (void)import_log(tmp / name, ImportOptions{});
      ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(tmp / name), std::string::npos) << msg;
      for (const std::string& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << msg << " lacks " << p;
    }
  };
  const auto text = [](const std::string& s) { return std::vector<char>(s.begin(), s.end()); };
  refused("log.bag", text("t,x,y,z,qw,qx,qy,qz\n"), {"not a ROS bag (it starts neither with \"#ROSBAG V2.0\" nor with MCAP's magic)"});
  refused("old.bag", text("#ROSRECORD V1.2\n"), {"a ROS bag of format 1.x: only format 2.0"});
  refused("ros2.db3", text(std::string("SQLite format 3\0", 16)), {"a ROS 2 bag in sqlite3 (.db3): only MCAP ROS 2 bags",
                                                                  "ros2 bag convert"});
  std::vector<char> b = good;
  b[find(b, std::string("op=\x05", 4)) + 3] = 0x09;
  refused("op.bag", b, {": byte ", ": a record of op 9 (format 2.0 has ops 2 to 7)"});
  b = good;  // the standard message's definition under another MD5: another message of that name
  b[find(b, "md5sum=d3812c3c") + 14] = 'd';
  refused("md5.bag", b, {"(a chunk), its byte ", "topic /psm/measured_cp: a geometry_msgs/PoseStamped of another definition (MD5 d3812c3d"});
  b = good;  // the chunk's uncompressed size one byte more than it holds
  const std::size_t size = find(b, "size=") + 5;
  std::uint32_t n;
  std::memcpy(&n, &b[size], 4);
  ++n;
  std::memcpy(&b[size], &n, 4);
  refused("size.bag", b, {"an uncompressed chunk of ", " bytes that names "});
  b = good;  // a record's header length inside the chunk past the chunk's end
  const std::size_t conn = find(b, std::string("op=\x07", 4)) - 8;  // its field length, then the header's
  b[conn + 3] = 0x7f;
  refused("header.bag", b, {"(a chunk), its byte ", "a record's header overruns the chunk"});
  b = good;
  b[find(b, "compression=none") + 12] = 'x';
  refused("codec.bag", b, {"a chunk compressed as 'xone' (ROS bags use none, bz2, lz4 or zstd)"});
}

TEST(RosBag, ATfTopicGivesTheTransformsToOneFrame) {
  // /tf holds world -> psm1_base (a shift of 0.1 m along x) and psm1_base -> psm1_tool in each
  // message; /tf_static world -> camera.
  const std::string bag = kData + "topics.bag";
  const Recording raw = import_log(kData + "sample.bag", ImportOptions{});
  ImportReport report;
  ImportOptions in_base = bag_options("", "", "psm1_tool");
  in_base.root_frame = "psm1_base";
  expect_same(import_log(bag, in_base, &report), raw);
  EXPECT_EQ(report.layout_note,
            "read as a ROS 1 bag: topic /tf (tf2_msgs/TFMessage, 20 messages; 20 transforms psm1_base -> psm1_tool); "
            "times from the messages' header stamps");
  // By default the poses are in the tree's top, world: the shift composed at each time (the
  // link's transforms at the same stamps, so no interpolation and no round-off).
  Recording shifted = raw;
  for (Vec3d& p : shifted.position) p = Vec3d{0.1, 0, 0} + p;
  expect_same(import_log(bag, bag_options("", "", "psm1_tool"), &report), shifted);
  EXPECT_EQ(report.layout_note,
            "read as a ROS 1 bag: topic /tf (tf2_msgs/TFMessage, 20 messages; 20 transforms psm1_base -> psm1_tool, "
            "composed with world -> psm1_base (20, interpolated) into world); times from the messages' header stamps");
  const auto refused = [&](const std::string& topic, const std::string& frame) {
    return import_log(bag, bag_options(topic, "", frame));
  };
  EXPECT_INPUT_ERROR(refused("/tf", ""), "--topic /tf: a tf topic: name the device's frame with --frame; its transforms: "
                                         "world -> psm1_base (20), psm1_base -> psm1_tool (20)");
  EXPECT_INPUT_ERROR(refused("", "psm2_tool"), "--frame psm2_tool: no transform to it in the bag's tf topics; their "
                                               "transforms: world -> camera (1), world -> psm1_base (20), psm1_base -> psm1_tool (20)");
  EXPECT_INPUT_ERROR(refused("/psm1/measured_cp", "psm1_tool"),
                     "--frame psm1_tool: --topic /psm1/measured_cp is a geometry_msgs/PoseStamped, not a tf topic");
  ImportOptions on_csv;
  on_csv.frame = "psm1_tool";
  EXPECT_INPUT_ERROR(import_log(kData + "sample.csv", on_csv), "--frame: ", "is not a ROS bag");
}

TEST(RosBag, AFramesPosesAreComposedWithTheLinksAboveIt) {
  // tf_chain.bag (make_bags.py): world -> base static, base -> arm every fourth sample from sample
  // 2 (linear in time), arm -> /tool the trajectory, stamps from 100 s.
  const std::string bag = kData + "tf_chain.bag";
  const auto chain_time = [](double k) { return 100 + 5e-4 * k; };
  const auto base_arm = [](double k) {  // the link at sample k (fractional between its messages)
    return std::pair{Vec3d{0.01 * k / 20, 0, 0.05}, quat_from_rotvec(Vec3d{2.0 * k * std::numbers::pi / 180, 0, 0})};
  };
  const Vec3d world_base_p{0.1, 0.2, 0.3};
  const Quatd world_base_q = quat_from_rotvec(Vec3d{0, 0, std::numbers::pi / 2});
  // Round-off: the link interpolated between messages 4 samples apart from times near 100 s (1e-14
  // s each, 1e-11 of the 2 ms between them) and composed in double with a quarter turn written by
  // Python's sin and cos: a few 1e-16 of numbers below 1.
  constexpr double kChainRoundOff = 1e-12;
  ImportReport report;
  for (const bool to_world : {true, false}) {
    ImportOptions o = bag_options("", "", "tool");
    if (!to_world) o.root_frame = "base";
    const Recording r = import_log(bag, o, &report);
    ASSERT_EQ(r.size(), 18u) << "samples 0 and 1 precede base -> arm's first transform";
    for (std::size_t n = 0; n < r.size(); ++n) {
      const std::size_t i = n + 2;
      const auto [ap, aq] = base_arm(static_cast<double>(i));
      Vec3d p = ap + rotate(aq, known_position(i));
      Quatd q = aq * known_orientation(i);
      if (to_world) {
        p = world_base_p + rotate(world_base_q, p);
        q = world_base_q * q;
      }
      EXPECT_NEAR(r.t[n], chain_time(static_cast<double>(i)), kChainRoundOff) << i;
      EXPECT_LT(norm(r.position[n] - p), kChainRoundOff) << i;
      EXPECT_LT(quat_angle(r.orientation[n], q), kChainRoundOff) << i;
    }
  }
  EXPECT_EQ(report.layout_note,
            "read as a ROS 1 bag: topic /tf (tf2_msgs/TFMessage, 26 messages; 20 transforms arm -> tool, composed "
            "with base -> arm (6, interpolated) into base; 2 at times outside an interpolated link's transforms left "
            "out); times from the messages' header stamps");
  import_log(bag, bag_options("", "", "tool"), &report);
  EXPECT_NE(report.layout_note.find("composed with base -> arm (6, interpolated), world -> base (1, held) into world"),
            std::string::npos)
      << report.layout_note;
  // In arm's frame: the frame's own transforms, bitwise ("/tool" is tf2's "tool").
  ImportOptions in_arm = bag_options("", "", "/tool");
  in_arm.root_frame = "arm";
  const Recording own = import_log(bag, in_arm);
  ASSERT_EQ(own.size(), 20u);
  for (std::size_t i = 0; i < own.size(); ++i) {
    EXPECT_EQ(own.position[i], known_position(i)) << i;
    EXPECT_LT(quat_angle(own.orientation[i], known_orientation(i)), kTurnRoundOff) << i;
  }
  ImportOptions nowhere = bag_options("", "", "tool");
  nowhere.root_frame = "camera";
  EXPECT_INPUT_ERROR(import_log(bag, nowhere), "--root-frame camera: not above tool in the bag's tf tree; the frames "
                                               "above it: arm, base, world");
  EXPECT_INPUT_ERROR(import_log(bag, bag_options("", "", "probe")),
                     "--frame probe: frame loose above it has two parents, world and base");
  ImportOptions no_frame;
  no_frame.root_frame = "world";
  EXPECT_INPUT_ERROR(import_log(bag, no_frame), "--root-frame: ", "give --frame too");
}

TEST(RosBag, AJointOfSeveralGivesTheJaw) {
  // /psm1/joint_states: yaw, pitch and jaw; the gripper is the third.
  const std::string bag = kData + "topics.bag";
  ImportOptions o = with_jaw("/psm1/measured_cp", "/psm1/joint_states");
  o.jaw_joint = "jaw";
  ImportReport report;
  const Recording r = import_log(bag, o, &report);
  ASSERT_EQ(r.size(), 20u);
  for (std::size_t i = 0; i < r.size(); ++i) EXPECT_NEAR(r.jaw[i], 1.0 - static_cast<double>(i) / 19.0, kJawRoundOff) << i;
  EXPECT_NE(report.layout_note.find("the jaw from /psm1/joint_states joint jaw (sensor_msgs/JointState, 20 messages"),
            std::string::npos)
      << report.layout_note;
  o.jaw_joint = "roll";
  EXPECT_INPUT_ERROR(import_log(bag, o), "topics.bag: /psm1/joint_states message 1: --jaw-joint roll: the joint state names "
                                         "no such joint (its joints: yaw, pitch, jaw)");
  o = with_jaw("/psm1/measured_cp", "/mtm/gripper");
  o.jaw_joint = "jaw";
  EXPECT_INPUT_ERROR(import_log(bag, o), "--jaw-joint jaw: --jaw-topic /mtm/gripper is a std_msgs/Float64, not a sensor_msgs/JointState");
  o.jaw_topic.clear();
  EXPECT_INPUT_ERROR(import_log(bag, o), "--jaw-joint: ", "give --jaw-topic too");
}

TEST(RosBag, Ros2McapBagsReadAsTheRos1Bag) {
  // make_mcap.mjs wrote sample.bag's messages as rosbag2's MCAP storage does (CDR, ros2msg
  // schemas, zstd chunks; sample_none.mcap uncompressed), with topics.bag's /tf.
  const Recording ros1 = import_log(kData + "sample.bag", with_jaw("", "/psm/jaw/measured_js"));
  ImportReport report;
  const double last_bit = 1e-15;
  expect_same(import_log(kData + "sample_none.mcap", with_jaw("", "/psm/jaw/measured_js"), &report), ros1, last_bit);
  EXPECT_EQ(report.layout_note.rfind("read as a ROS 2 bag (MCAP): topic /psm/measured_cp (geometry_msgs/PoseStamped, 20 "
                                     "messages), the jaw from /psm/jaw/measured_js (sensor_msgs/JointState, 20 messages",
                                     0),
            0u)
      << report.layout_note;
  EXPECT_EQ(log_format_of("run.MCAP"), LogFormat::rosbag);
  if (rosbag_reads("zstd"))
    expect_same(import_log(kData + "sample.mcap", with_jaw("", "/psm/jaw/measured_js")), ros1, last_bit);
  else
    EXPECT_INPUT_ERROR(import_log(kData + "sample.mcap", ImportOptions{}), "a zstd-compressed chunk, and this build");
  ImportOptions in_base = bag_options("", "", "psm1_tool");
  in_base.root_frame = "psm1_base";
  expect_same(import_log(kData + "sample_none.mcap", in_base), import_log(kData + "sample.bag", ImportOptions{}), last_bit);
  // Composed with world -> psm1_base from CDR as from ROS 1.
  expect_same(import_log(kData + "sample_none.mcap", bag_options("", "", "psm1_tool")),
              import_log(kData + "topics.bag", bag_options("", "", "psm1_tool")), last_bit);
}

TEST(RosBag, MalformedMcapBagsAreRefusedWithTheirPlace) {
  test::ScratchDir tmp;
  const std::vector<char> good = bytes_of(kData + "sample_none.mcap");
  const auto refused = [&](const std::string& name, const std::vector<char>& b, const std::string& why) {
    write_bytes(tmp / name, b);
    EXPECT_INPUT_ERROR(import_log(tmp / name, with_jaw("", "/psm/jaw/measured_js")), name, why);
  };
  std::vector<char> b = good;  // the first PoseStamped's CDR header made big-endian
  const std::size_t cdr = find(b, std::string("\x00\x01\x00\x00\x00\xf1\x53\x65", 8));
  b[cdr + 1] = 0;
  refused("big.mcap", b, "/psm/measured_cp message 1: a big-endian CDR message");
  b = good;
  const std::size_t joint = find(b, "sensor_msgs/msg/JointState");
  b[joint + 16] = 'X';  // sensor_msgs/msg/XointState: a type not read
  refused("type.mcap", b, "--jaw-topic /psm/jaw/measured_js: a sensor_msgs/XointState topic");
  // Cut in its first chunk, which holds the schemas and channels too: nothing is left, and the
  // message says why.
  b = good;
  b.resize(find(b, "geometry_msgs/msg/PoseStamped") + 400);
  refused("cut.mcap", b, "its topics: none (its last 464 bytes, a record cut short, are left out");
}

TEST(RosBag, AJoyTopicGivesTheButtonsAndAButtonTheJaw) {
  // /touch/buttons: a Joy every other sample, its second button pressed from sample 5 to 12 (a
  // Geomagic Touch grasps with its stylus button).
  const std::string bag = kData + "topics.bag";
  ImportOptions o = bag_options("/psm1/measured_cp");
  o.button_topic = "/touch/buttons";
  o.jaw_button = 1;
  ImportReport report;
  const Recording r = import_log(bag, o, &report);
  ASSERT_EQ(r.size(), 20u);
  for (std::size_t i = 0; i < r.size(); ++i) {
    const bool pressed = i >= 5 && i <= 12;  // held from the message at or before each pose
    EXPECT_EQ(r.buttons[i], pressed ? 2 : 0) << i;
    EXPECT_EQ(r.jaw[i], pressed ? 0.0 : 1.0) << i;
  }
  EXPECT_EQ(report.jaw_button_presses, 1u);
  // The same Joy messages in CDR (make_mcap.mjs).
  ImportOptions mcap = bag_options("/psm/measured_cp");
  mcap.button_topic = "/touch/buttons";
  const Recording m = import_log(kData + "sample_none.mcap", mcap);
  ASSERT_EQ(m.size(), r.size());
  for (std::size_t i = 0; i < m.size(); ++i) EXPECT_EQ(m.buttons[i], r.buttons[i]) << i;
  EXPECT_NE(report.layout_note.find(", the buttons from /touch/buttons (sensor_msgs/Joy, 10 messages, held as the jaw's)"),
            std::string::npos)
      << report.layout_note;
  o.button_topic = "/mtm/gripper";
  EXPECT_INPUT_ERROR(import_log(bag, o), "--button-topic /mtm/gripper: a std_msgs/Float64 topic (buttons are read from "
                                         "sensor_msgs/Joy)");
  ImportOptions on_csv;
  on_csv.button_topic = "/touch/buttons";
  EXPECT_INPUT_ERROR(import_log(kData + "sample.csv", on_csv), "--button-topic: ", "is not a ROS bag");
}
