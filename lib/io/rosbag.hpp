#pragma once
// ROS bags: ROS 1's (the rosbag format 2.0 that `rosbag record` writes, wiki.ros.org/Bags/Format/2.0)
// and ROS 2's MCAP files (`ros2 bag record`'s default storage, mcap.dev/spec): the messages of a
// pose topic, and optionally of a jaw topic, for `ebh import` (io/import.hpp).
//
// The records are read in file order from the start (the index at the end is not needed, so a
// bag whose recording was stopped before it was indexed, `*.bag.active`, reads up to its last
// whole record; a record cut short there is left out and counted). Chunks are uncompressed, bz2
// or lz4 (rosbag record --bz2 / --lz4), zstd or lz4 in MCAP, each where the build has the library.
// Pose messages: geometry_msgs/PoseStamped, TransformStamped, Pose and Transform, and the
// transforms to one child frame in a tf topic (tf2_msgs/TFMessage, tf/tfMessage), composed with
// the transforms above it in the bag's tf tree up to its top or a named frame; jaw messages:
// sensor_msgs/JointState (its first position, or a named joint's) and std_msgs/Float64 or Float32;
// button messages: sensor_msgs/Joy.
// A ROS 1 type is known by its name and its definition's MD5 sum (a message of another definition
// under the same name is refused, naming both sums); a ROS 2 type by its name (pkg/msg/Type, CDR
// encoded; MCAP holds no sum). Sizes are checked against the bytes that hold them before any
// allocation.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

/// One message's times: when the bag recorded it, and its header's stamp (the device's clock)
/// where its type has a header (0 when not, or not set).
struct BagTimes {
  double record = 0, stamp = 0;
};

struct BagPose {
  BagTimes t;
  Vec3d position;    ///< as the message holds it (ROS: metres)
  Quatd orientation;
};

struct BagJaw {
  BagTimes t;
  double value = 0;  ///< the joint's position (a gripper's angle, rad) or the number
};

struct BagButtons {
  BagTimes t;
  int bits = 0;      ///< button i pressed: bit i
};

/// A topic of the bag: its name, its message type, and how many messages it has.
struct BagTopic {
  std::string name, type;
  std::size_t messages = 0;
};

/// What to read: the pose topic (empty: the bag's only one; with `frame`, its only tf topic with
/// transforms to that frame), the jaw topic (empty: none), for a tf topic the child frame, and for
/// a JointState jaw topic the joint (empty: its first position), and the button topic (empty:
/// none); with `frame`, the frame its poses are given in (`root_frame`; empty: the top of the
/// frame's tf tree).
struct BagRequest {
  std::string pose_topic, jaw_topic, frame, jaw_joint, button_topic, root_frame;
};

/// A link of the tf tree above the requested frame that its poses were composed with.
struct BagLink {
  std::string parent, child;
  std::size_t transforms = 0;
  /// from a tf_static topic (or a single transform): its last transform at every time; else
  /// interpolated at each pose's time (linear in translation, slerp in rotation), as tf does
  bool held = false;
};

struct BagContents {
  std::string kind;                 ///< "ROS 1 bag" or "ROS 2 bag (MCAP)"
  std::vector<BagTopic> topics;     ///< every topic the bag records, in the order first seen
  std::string pose_topic, pose_type, jaw_type;
  /// With a frame (a tf topic): the frames from the one its poses are given in (the tree's top or
  /// the requested root) down to the requested frame, and the links above the frame's own that its
  /// transforms were composed with (top first); poses at times outside an interpolated link's
  /// transforms are left out (tf cannot look them up), counted in `outside_links`.
  std::vector<std::string> frame_chain;
  std::vector<BagLink> links;
  std::size_t outside_links = 0;
  std::vector<BagPose> poses;       ///< the pose topic's messages, in the bag's order
  std::vector<BagJaw> jaw;          ///< the jaw topic's (none without one)
  std::vector<BagButtons> buttons;  ///< the button topic's (none without one)
  std::size_t cut_bytes = 0;        ///< bytes of a last record cut short (a recording stopped mid-write), left out
};

/// Reads the messages `request` names. Throws InputError naming the file, and the record's byte
/// offset or the message (topic and its index from 1) where it is wrong.
BagContents read_rosbag(const std::string& path, const BagRequest& request);

/// Whether this build reads chunks compressed with `codec`: "none", "bz2", "lz4" or "zstd".
bool rosbag_reads(const std::string& codec);

}  // namespace ebh
