#pragma once
// Importing device logs into recordings (`ebh import`, docs/FORMATS.md).
//
// openhaptics: one sample a line, separated as csv's fields (an empty field is an error): the 16
//   numbers of the column-major 4x4 device transform (as hdGetDoublev(HD_CURRENT_TRANSFORM) returns
//   it: translation in elements 12-14; a row-major one is named as such), the jaw opening (1 open,
//   0 closed), then zero or more button states (ints, button i nonzero -> bit i). '#' starts a
//   comment; blank lines are skipped. Times are i / rate_hz (--rate; 1000 Hz assumed, and said,
//   when not given).
// csv: a header naming the columns (any order): t, x, y, z, qw, qx, qy, qz, jaw, buttons; fields
//   separated by a comma (blanks around it included) or by a run of spaces or tabs;
//   x, y, z and the quaternion are required, t optional (else i / rate_hz), jaw defaults to 1,
//   buttons to 0. With t, the recording's rate_hz is 1 / the median interval (nominal_rate).
// rosbag: a ROS 1 bag (`rosbag record`, io/rosbag.hpp): the messages of one pose topic (--topic;
//   by default the bag's only one; with --frame, the transforms to that frame in a tf topic),
//   positions in metres, times from the messages' header stamps
//   (the device's clock) where the pose topic, and the jaw topic if any, carry nonzero ones, else
//   the bag's record times; the jaw from --jaw-topic (a JointState's first position or a number,
//   mapped with --jaw-range), each pose taking the last jaw message at or before its time (the
//   first before it); errors name the topic and the message's index from 1.
// Samples that repeat the previous one exactly (pose, jaw and buttons) are counted. With
// drop_repeats the stale ones (runs of at most kStaleRunMaxS: a device polled faster than it
// updates) are removed; a longer run (a hold: the device at rest) keeps its last sample, and so
// does the log's end; the samples kept keep their times.
// Positions are scaled by the unit (openhaptics default mm, csv default m), then the optional
// tool and world transforms are applied to every pose (io/pose_transform.hpp):
// p' = R_w (p + q t_T) + t_w, q' = q_w q q_T. They are baked into the poses: the recording holds
// poses in ebh's world and tool frames, records them as baked_* attributes (never applied) and
// stores none to apply, so a replay cannot apply them again (and refuses an option of the same
// kind).
#include <optional>
#include <string>
#include <vector>

#include "io/pose_transform.hpp"
#include "io/recording.hpp"

namespace ebh {

enum class LogFormat { openhaptics, csv, rosbag };

struct ImportOptions {
  std::optional<LogFormat> format;  ///< nullopt: log_format_of(path)
  std::optional<double> rate_hz;    ///< sample rate of a log without times; nullopt: kAssumedLogRateHz
  bool drop_repeats = false;        ///< remove stale repeated samples (kStaleRunMaxS)
  /// csv: header names of columns left unread (a logger's other data); each must be in the header.
  std::vector<std::string> skip_columns;
  std::optional<double> unit;       ///< metres per log length unit; nullopt: the format's default
  /// seconds per unit of a CSV log's t column (--time-unit ms|us|ns: a logger's clock in
  /// milliseconds, a ROS export's in nanoseconds); nullopt: seconds, or nanoseconds for a ROS
  /// export's %time (read_csv: a header of %time and field.* columns)
  std::optional<double> time_unit;
  /// The log's jaw values when the jaws are closed and when open (--jaw-range CLOSED,OPEN): mapped
  /// to 0 and 1 linearly and clamped to them (a gripper in degrees, an inverted signal, one
  /// calibrated a little past its ends); nullopt: the log's values are 0 .. 1 already.
  std::optional<std::pair<double, double>> jaw_range;
  /// The jaw from a button (--jaw-button I, bit I of the buttons): closed (0) while it is pressed,
  /// open (1) otherwise, for a device without a gripper (a Geomagic Touch grasps with its stylus
  /// button); the log's jaw must stand still. nullopt: the log's jaw.
  std::optional<int> jaw_button;
  /// A left-handed log (--mirror AXIS): the axis (0 x, 1 y, 2 z) reversed before the transforms
  /// (mirror_poses); nullopt: the log's frame is right-handed, as ebh's.
  std::optional<int> mirror;
  /// rosbag: the pose topic (--topic; empty: the bag's only one), the jaw topic (--jaw-topic;
  /// empty: none, the jaws open), a tf topic's child frame (--frame: its transforms, composed with
  /// the links above it, are the poses) and the frame they are given in (--root-frame; empty: the
  /// top of the frame's tf tree)
  std::string topic, jaw_topic, frame, root_frame;
  std::string jaw_joint;  ///< rosbag: the joint of a JointState jaw topic (--jaw-joint; empty: its first position)
  /// rosbag: a sensor_msgs/Joy topic whose buttons become the samples' (--button-topic; empty:
  /// none pressed), held as the jaw is (--jaw-button takes the jaw from one)
  std::string button_topic;
  PoseTransforms transforms;        ///< world (--transform) and tool (--tool-transform), metres
  std::string scene;
  std::string tool = "hook";
  /// The most samples read: a log with more is refused at the line of the first one past it,
  /// before memory grows with the log. kMaxRecordingSamples; tests lower it.
  std::size_t max_samples = static_cast<std::size_t>(kMaxRecordingSamples);
  /// The window of the log imported (--start, --duration), in seconds from its first sample: a
  /// log longer than a recording holds (kMaxRecordingSamples) is imported a window at a time. The
  /// samples keep the log's times; those outside are not read past their time.
  double start_s = 0;
  std::optional<double> duration_s;
};

/// The memory an import takes a sample at its peak (787 MB resident for a CSV of 3.6 million rows:
/// the samples, their line numbers and the vectors' doubling), said when it runs out.
inline constexpr std::size_t kImportBytesPerSample = 220;

/// The rate of a log without times when no --rate is given (a Geomagic Touch's servo loop).
inline constexpr double kAssumedLogRateHz = 1000;

/// A device logs at 100 Hz to 10 kHz (a Geomagic Touch's servo loop runs at 1 kHz). A log's rate
/// below kMinPlausibleLogRateHz is most likely times in ms, us or ns (or --rate in kHz): import
/// warns naming the unit under which the rate is a device's. A rate above kMaxSampleRateHz is an
/// error (docs/FORMATS.md, Limits).
inline constexpr double kMinPlausibleLogRateHz = 10;
inline constexpr double kDeviceRateLowHz = 100, kDeviceRateHighHz = 10e3;

/// A run of samples that repeat the one before them exactly is, while it lasts at most this long
/// (s), stale: a device polled faster than it updates logs its last sample again until its next
/// update, (poll rate / update rate - 1) times in a row: once for a 500 Hz device logged at 1 kHz,
/// 9 times for the slowest device (kDeviceRateLowHz, 100 Hz) at 1 kHz, 99 times at 10 kHz; none
/// repeats a sample for longer than its update interval, 1 / kDeviceRateLowHz = 10 ms. A longer
/// run is a hold: the device updated and reported the same sample again, at rest (an
/// encoder-quantised device logs the exact same sample while it is still). drop_repeats removes
/// stale samples, so a replay interpolates between real ones instead of holding and jumping, and
/// keeps a hold's last sample, so a replay holds still until the device moves instead of creeping
/// from the hold's first sample toward the next new one. Judged wrongly either way, the cost is
/// small: a hold of at most 10 ms becomes a creep, or the stale run of a slower device one hold
/// and jump. (Counted in samples, the rule took a 100 Hz device's stale runs in a 10 kHz log for
/// holds.)
inline constexpr double kStaleRunMaxS = 1.0 / kDeviceRateLowHz;

/// What an import found besides the samples, for the command's report.
struct ImportReport {
  std::size_t repeats = 0;     ///< samples equal to the previous one in position, orientation, jaw and buttons
  std::size_t removable = 0;   ///< of them, the stale ones drop_repeats removes (the rest end a hold or the log)
  std::size_t holds = 0;       ///< runs of repeats lasting more than kStaleRunMaxS: the device at rest
  bool dropped = false;        ///< the stale ones were removed (ImportOptions::drop_repeats, and repeats > 0)
  bool has_times = false;      ///< the log gave times (csv t column)
  bool rate_assumed = false;   ///< no times and no rate given: kAssumedLogRateHz
  std::string rate_warning;    ///< the rate is below kMinPlausibleLogRateHz: what it likely means
  std::size_t cut_line = 0;    ///< the log's last line had no line end (a logger stopped mid-line): left out
  std::size_t cut_bytes = 0;   ///< rosbag: bytes of a last record cut short (a recording stopped mid-write): left out
  /// What a sample's place in the log is called in the report's "first at ..." (a text log's
  /// lines; a bag's messages of its pose topic, counted from 1)
  std::string place = "line";
  std::size_t duplicate_rows = 0;        ///< csv rows equal to the row before them, t included: left out
  std::size_t first_duplicate_line = 0;  ///< the first of them
  std::string gap_warning;     ///< the times have a gap (kLogGapFactor): where, how long
  std::string stale_warning;   ///< the samples repeat between a slower device's updates (check_recording_stale), kept
  std::size_t jaw_clamped = 0; ///< jaw_range: samples whose mapped jaw lay outside [0, 1], clamped
  std::size_t first_jaw_clamped_line = 0;
  std::size_t jaw_button_presses = 0;  ///< jaw_button: times the button went down (a grasp each)
  /// csv: how a ROS export's columns were read ("read as a ROS export: %time as t (nanoseconds),
  /// field.pose.position.x as x, ...; 3 other fields left unread"); "" for another log
  std::string layout_note;
};

/// An interval between a log's times above this many times the median one (and above two
/// intervals of the slowest device, kDeviceRateLowHz) is a gap in the logging: import warns.
inline constexpr double kLogGapFactor = 10;

/// The format a log's name implies: csv for a `.csv` extension in any case (`LOG.CSV` too),
/// rosbag for `.bag` (and `.bag.active`, a recording stopped before rosbag indexed it), `.mcap`
/// (ROS 2) and `.db3` (ROS 2's sqlite3 storage, refused saying how to convert it),
/// openhaptics for any other.
LogFormat log_format_of(const std::string& path);

/// Reads a log; errors name the file and line ("log.txt:17: ..."). `report`, when given, is filled.
Recording import_log(const std::string& path, const ImportOptions& opt, ImportReport* report = nullptr);

/// The nominal rate of samples at times t (at least two, increasing): 1 / the median interval
/// (median_interval, io/recording.hpp; two samples: their one interval), which gaps in the logging
/// and holds leave be where the mean, (n - 1) / (t_last - t_first), takes them in. Where the mean
/// is the same number to the median interval's round-off (no gap), the mean, whose round-off is
/// the span's. Rounded to the whole number when within 1e-9 of it relatively (or within the
/// round-off of times counted from an epoch: 4 eps |t| over the interval or the span), so a log at
/// 1 kHz gives 1000, not 999.9999999999991, and one at 10 kHz in Unix time 10000, not 9999.99999.
double nominal_rate(const std::vector<double>& t);

/// Parses "--jaw-range CLOSED,OPEN": two finite, different numbers; throws InputError naming the option.
std::pair<double, double> parse_jaw_range(const std::string& text);

/// Parses "--unit m|cm|mm|in" (metres per unit); throws InputError naming the option.
double parse_length_unit(const std::string& name);
/// Seconds per unit for --time-unit: s, ms, us or ns; an InputError naming the option otherwise.
double parse_time_unit(const std::string& name);
/// Parses a transform option, "--transform tx,ty,tz,rx,ry,rz" or "--tool-transform x,y,z,rx,ry,rz":
/// translation in a length unit of `unit_m` metres, rotation vector (axis times angle) in degrees.
/// Throws InputError naming `option`. `ebh replay` parses its options of the same names with it.
RigidTransform parse_rigid_transform(const std::string& option, const std::string& text, double unit_m);

/// Max Frobenius distance between a logged rotation block and its nearest rotation: encoder
/// noise and 6-digit logs stay far below it; a scaled or sheared matrix does not.
inline constexpr double kRotationTolerance = 0.02;

}  // namespace ebh
