// `ebh import LOG -o REC.h5 [--format openhaptics|csv|rosbag] [--topic T] [--frame F]
//  [--jaw-topic T [--jaw-joint J]] [--button-topic T] [--rate HZ] [--unit m|cm|mm|in] [--time-unit s|ms|us|ns]
//  [--transform "tx,ty,tz,rx,ry,rz"] [--tool-transform "x,y,z,rx,ry,rz"] [--scene NAME]
//  [--tool hook|forceps] [--drop-repeats]`: a device log (OpenHaptics-style transforms, CSV or a ROS bag) into
// a recording, its poses mapped to ebh's frames. With --scene, the path is checked against the
// scene's physical mesh (unit sanity, a warning). Formats: docs/FORMATS.md.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command.hpp"
#include "core/error.hpp"
#include "ebh/version.hpp"
#include "io/atomic.hpp"
#include "io/import.hpp"
#include "io/paths.hpp"
#include "io/recording.hpp"
#include "options.hpp"
#include "scene/scene.hpp"

namespace {

struct ImportArgs {
  std::string log, output, format, unit, time_unit, transform, tool_transform, scene, tool;  // tool: empty, the default
  std::string topic, jaw_topic, frame, root_frame, jaw_joint, button_topic;
  std::optional<double> rate_hz;
  bool drop_repeats = false;
  std::vector<std::string> skip_columns;
  std::string jaw_range;
  std::optional<int> jaw_button;
  std::string mirror;  // empty: a right-handed log
  double start = 0;
  std::optional<double> duration;
};

void run(const ImportArgs& a) {
  ebh::ImportOptions opt;
  if (a.format == "openhaptics") opt.format = ebh::LogFormat::openhaptics;
  else if (a.format == "csv") opt.format = ebh::LogFormat::csv;
  else if (a.format == "rosbag") opt.format = ebh::LogFormat::rosbag;
  else if (!a.format.empty()) throw ebh::InputError("--format: '" + a.format + "' is not openhaptics, csv or rosbag");
  if (!a.tool.empty() && a.tool != "hook" && a.tool != "forceps")
    throw ebh::InputError("--tool: '" + a.tool + "' is not hook or forceps");
  // The recording names the scene it is replayed with: a known scene name or a scene file.
  std::filesystem::path scene_file;
  if (!a.scene.empty()) {
    try {
      scene_file = ebh::resolve_scene_path(a.scene);
    } catch (const ebh::InputError& e) {
      throw ebh::InputError(std::string("--scene: ") + e.what());
    }
  }
  // The log and, with --scene, the scene's files are inputs the recording must not replace.
  std::vector<ebh::RoleFile> inputs{{a.log, "the log"}};
  std::optional<ebh::Scene> scene;
  if (!scene_file.empty()) {
    scene = ebh::load_scene(scene_file);
    for (const ebh::SceneInputFile& f : ebh::scene_input_files(scene->spec)) inputs.push_back({f.path.string(), f.what});
  }
  ebh::check_outputs({{a.output, "the recording to write"}}, inputs);
  opt.rate_hz = a.rate_hz;
  if (!a.unit.empty()) opt.unit = ebh::parse_length_unit(a.unit);
  if (!a.time_unit.empty()) opt.time_unit = ebh::parse_time_unit(a.time_unit);
  // The transforms' translations are in the log's unit (its format's default when --unit is absent).
  const ebh::LogFormat format = opt.format.value_or(ebh::log_format_of(a.log));
  const double log_unit = opt.unit ? *opt.unit : (format == ebh::LogFormat::openhaptics ? 1e-3 : 1.0);
  if (!a.transform.empty()) opt.transforms.world = ebh::parse_rigid_transform("--transform", a.transform, log_unit);
  if (!a.tool_transform.empty())
    opt.transforms.tool = ebh::parse_rigid_transform("--tool-transform", a.tool_transform, log_unit);
  if (!a.mirror.empty()) opt.mirror = ebh::parse_mirror_axis(a.mirror);
  // The scene's physical mesh, for the unit sanity check (loaded before any output is written).
  std::optional<ebh::BoundingBox> mesh_box;
  if (scene) mesh_box = ebh::bounding_box(scene->physical.vertices);
  // A scene file is named relative to the recording's folder, where readers look first (the folder
  // of the file written: a link's target's).
  opt.scene = scene_file.empty() ? a.scene : ebh::scene_attribute_for(a.scene, scene_file, ebh::output_target(a.output));
  // The tool the log's device held: by default the scene's (a forceps scene's log is a forceps
  // log), else a hook. One given that differs from the scene's is recorded as given, with a warning,
  // as replay warns of a forceps log on a hook scene: the scene's tool is what a replay moves.
  const char* scene_tool =
      !scene ? nullptr : scene->spec.tool.kind == ebh::ToolSpec::Kind::Forceps ? "forceps" : "hook";
  opt.tool = !a.tool.empty() ? a.tool : scene_tool ? scene_tool : "hook";
  opt.drop_repeats = a.drop_repeats;
  opt.start_s = a.start;
  opt.duration_s = a.duration;
  opt.skip_columns = a.skip_columns;
  if (!a.jaw_range.empty()) opt.jaw_range = ebh::parse_jaw_range(a.jaw_range);
  opt.jaw_button = a.jaw_button;
  if (!opt.skip_columns.empty() && format != ebh::LogFormat::csv)
    throw ebh::InputError(std::string("--skip-column: ") +
                          (format == ebh::LogFormat::rosbag ? "a ROS bag is read by topic (--topic)"
                                                            : "an OpenHaptics log has no named columns") +
                          " (--skip-column is for a CSV log)");
  opt.topic = a.topic;
  opt.jaw_topic = a.jaw_topic;
  opt.frame = a.frame;
  opt.root_frame = a.root_frame;
  opt.jaw_joint = a.jaw_joint;
  opt.button_topic = a.button_topic;
  ebh::ImportReport report;
  ebh::Recording rec = ebh::import_log(a.log, opt, &report);
  rec.generator = std::string("ebh import (ebh ") + ebh::kVersion + ")";
  ebh::write_recording(a.output, rec);
  if (report.rate_assumed)
    std::fprintf(stderr, "ebh: warning: %s: the log has no times; assumed %g Hz (give --rate HZ)\n", a.log.c_str(),
                 ebh::kAssumedLogRateHz);
  if (report.has_times && a.rate_hz)
    std::fprintf(stderr, "ebh: warning: %s: the log has a t column; --rate %s is not used\n", a.log.c_str(),
                 ebh::cli::format_number(*a.rate_hz).c_str());
  if (!report.rate_warning.empty())
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.log.c_str(), report.rate_warning.c_str());
  if (report.cut_line)
    std::fprintf(stderr,
                 "ebh: warning: %s:%zu: the last line has no line end (a logger stopped while writing it?): left out, "
                 "as its last number may be cut short; end it with a newline to keep it\n",
                 a.log.c_str(), report.cut_line);
  if (report.cut_bytes)
    std::fprintf(stderr,
                 "ebh: warning: %s: its last %zu bytes are a record cut short (a recording stopped while writing it?): "
                 "left out\n",
                 a.log.c_str(), report.cut_bytes);
  if (report.duplicate_rows)
    std::fprintf(stderr, "ebh: warning: %s: %zu %s the row before, time included (the first at line %zu): left out\n",
                 a.log.c_str(), report.duplicate_rows, report.duplicate_rows == 1 ? "row repeats" : "rows repeat",
                 report.first_duplicate_line);
  if (report.jaw_clamped)
    std::fprintf(stderr,
                 "ebh: warning: %s: %zu samples' jaw lay outside --jaw-range %s (the first at %s %zu): clamped to "
                 "%s\n",
                 a.log.c_str(), report.jaw_clamped, a.jaw_range.c_str(), report.place.c_str(), report.first_jaw_clamped_line,
                 report.jaw_clamped == 1 ? "its end" : "its ends");
  if (a.jaw_button && report.jaw_button_presses == 0)
    std::fprintf(stderr, "ebh: warning: %s: --jaw-button %d: the button is never pressed in the log: the jaws stay "
                 "open (button I is bit I of the buttons, 0 the first)\n", a.log.c_str(), *a.jaw_button);
  if (!report.gap_warning.empty())
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.log.c_str(), report.gap_warning.c_str());
  if (!report.stale_warning.empty())
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.log.c_str(), report.stale_warning.c_str());
  if (scene_tool && opt.tool != scene_tool)
    std::fprintf(stderr,
                 "ebh: warning: %s: --tool %s, but the scene's tool is a %s: the recording says %s, and a replay with "
                 "this scene moves a %s (without --tool the recording takes the scene's tool)\n",
                 a.log.c_str(), opt.tool.c_str(), scene_tool, opt.tool.c_str(), scene_tool);
  // A jaw that opens and closes past the grasp threshold is a forceps' log; taken as the hook of
  // the scene's, it is recorded as a hook's, and no replay says the grasp is lost. (A jaw that
  // never moves is a device without a gripper.)
  if (a.tool.empty() && scene_tool && std::string(scene_tool) == "hook" && !rec.jaw.empty()) {
    const auto [closed, open] = std::minmax_element(rec.jaw.begin(), rec.jaw.end());
    const double threshold = scene->spec.tool.forceps.grasp_threshold;
    if (*closed < threshold && *open >= threshold)
      std::fprintf(stderr,
                   "ebh: warning: %s: the jaw closes to %g (below the grasp threshold %g) at the recording's t = %.3f s, "
                   "but the scene's tool is a hook, so the recording says hook: a forceps log? give --tool forceps "
                   "(a replay on a forceps scene grasps; on this one it says the grasp is lost)\n",
                   a.log.c_str(), *closed, threshold, rec.t[static_cast<std::size_t>(closed - rec.jaw.begin())]);
  }
  if (mesh_box)
    if (auto w = ebh::check_recording_scale(rec, mesh_box->lo, mesh_box->hi, log_unit))
      std::fprintf(stderr, "ebh: warning: %s: %s\n", a.log.c_str(), w->c_str());
  if (auto w = ebh::check_recording_speed(rec)) std::fprintf(stderr, "ebh: warning: %s: %s\n", a.log.c_str(), w->c_str());
  if (auto w = ebh::check_recording_turn(rec)) std::fprintf(stderr, "ebh: warning: %s: %s\n", a.log.c_str(), w->c_str());
  std::printf("%s: %zu samples, %.6g s, %.10g Hz, tool %s\n", a.output.c_str(), rec.size(), rec.duration(), rec.rate_hz,
              rec.tool.c_str());
  if (!report.layout_note.empty()) std::printf("  %s\n", ebh::escape_unprintable(report.layout_note).c_str());
  // A hold (repeats lasting more than kStaleRunMaxS: the device at rest) keeps its last sample.
  const auto count = [](std::size_t n, const char* one, const char* many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
  };
  const std::string holds = count(report.holds, "hold", "holds");
  const std::string longer = "repeats lasting more than " + ebh::cli::format_number(ebh::kStaleRunMaxS * 1e3) + " ms";
  if (report.dropped)
    std::printf("  dropped %s that repeated the previous pose, jaw and buttons exactly; kept %s (%s: the device at "
                "rest)\n",
                count(report.removable, "sample", "samples").c_str(), holds.c_str(), longer.c_str());
  else
    std::printf("  %s the previous pose, jaw and buttons exactly%s\n",
                (count(report.repeats, "sample repeats", "consecutive samples repeat")).c_str(),
                report.repeats == 0 ? ""
                                    : (" (--drop-repeats removes " + std::to_string(report.removable) + ", keeping " +
                                       holds + " of " + longer + ")").c_str());
}

void setup(CLI::App& root) {
  auto args = std::make_shared<ImportArgs>();
  CLI::App* c =
      root.add_subcommand("import", "Convert a device log (OpenHaptics transforms, CSV or a ROS 1/2 bag) to a recording");
  c->add_option("log", args->log, "device log (text, a ROS 1 bag or a ROS 2 MCAP file)")->required();
  c->add_option("-o,--output", args->output, "recording to write (HDF5)")->required();
  c->add_option("--format", args->format,
                "openhaptics, csv or rosbag (default: csv for *.csv, rosbag for *.bag and *.mcap, else openhaptics)");
  c->add_option("--topic", args->topic,
                "rosbag: the device's pose topic (geometry_msgs/PoseStamped, TransformStamped, Pose or Transform; "
                "default: the bag's only one)");
  c->add_option("--frame", args->frame,
                "rosbag: the device's frame in a tf topic (tf2_msgs/TFMessage): the transforms to it, composed with "
                "the tf links above it (tf_static's held, the others interpolated at each pose's time), are the "
                "poses (the tf topic with such transforms; --topic names one)");
  c->add_option("--root-frame", args->root_frame,
                "rosbag, with --frame: the frame the poses are given in, a frame above --frame's in the tf tree "
                "(default: the tree's top)");
  c->add_option("--button-topic", args->button_topic,
                "rosbag: a sensor_msgs/Joy topic whose buttons are the samples' (button i pressed: bit i), held as "
                "the jaw is; with --jaw-button I a device without a gripper grasps (default: none pressed)");
  c->add_option("--jaw-joint", args->jaw_joint,
                "rosbag: the gripper's joint by name in a JointState --jaw-topic of several joints (default: its first)");
  c->add_option("--jaw-topic", args->jaw_topic,
                "rosbag: the gripper's topic (sensor_msgs/JointState's first position, or std_msgs/Float64 or "
                "Float32), mapped with --jaw-range; each pose takes the last message at or before it (default: none, "
                "the jaws open)");
  c->add_option("--rate", args->rate_hz, "sample rate in Hz when the log has no t column (default: 1000, said)")
      ->check(ebh::cli::finite_number(0, ebh::kMaxSampleRateHz, true, "Hz"));
  c->add_option("--unit", args->unit, "length unit of the log: m, cm, mm or in (default: mm openhaptics, m csv and rosbag)");
  c->add_option("--time-unit", args->time_unit,
                "unit of a CSV log's t column: s, ms, us or ns (a logger's clock in milliseconds, a ROS export's in "
                "nanoseconds; default: s)");
  c->add_option("--transform", args->transform,
                "log frame -> world: \"tx,ty,tz,rx,ry,rz\" (translation in the log's unit, rotation vector in degrees)");
  c->add_option("--tool-transform", args->tool_transform,
                "log tool frame -> ebh's, applied in the tool's frame (p' = p + q t, q' = q q_T): \"x,y,z,rx,ry,rz\" "
                "(translation in the log's unit, rotation vector in degrees)");
  c->add_option("--mirror", args->mirror,
                "a left-handed log (a Unity export, a device whose axis runs the other way): the axis, x, y or z, "
                "reversed in positions and orientations before --transform and --tool-transform (root attribute "
                "baked_mirror)");
  c->add_option("--scene", args->scene, "scenario to replay it with (root attribute scene)");
  c->add_option("--tool", args->tool,
                "the tool the log's device held, hook or forceps (root attribute tool; default: the scene's tool with "
                "--scene, else hook)");
  c->add_option("--jaw-range", args->jaw_range,
                "the log's jaw values when closed and when open, \"CLOSED,OPEN\" (mapped to 0 and 1 and clamped; "
                "default: the log's are 0 closed .. 1 open)");
  c->add_option("--jaw-button", args->jaw_button,
                "the jaw from button I (0 the first state after the jaw; bit I of a CSV's buttons): closed while it "
                "is pressed, open otherwise, for a device without a gripper (a Geomagic Touch grasps with its stylus "
                "button); the log's jaw must stand still")
      ->check(ebh::cli::whole_number(0, 7));
  c->add_option("--skip-column", args->skip_columns,
                "csv: a column of the log to leave unread (a force or a timestamp of another clock; repeatable)");
  c->add_option("--start", args->start,
                "import from S seconds after the log's first sample (a log longer than a recording holds, 2.8 h at "
                "1 kHz, is imported a window at a time; the samples keep the log's times)")
      ->check(ebh::cli::finite_number(0, ebh::cli::kNoUpperLimit));
  c->add_option("--duration", args->duration, "import S seconds from --start (default: the rest of the log)")
      ->check(ebh::cli::finite_number(0, ebh::cli::kNoUpperLimit, true));
  c->add_flag("--drop-repeats", args->drop_repeats,
              "remove the samples that repeat the previous pose, jaw and buttons exactly for up to " +
                  ebh::cli::format_number(ebh::kStaleRunMaxS * 1e3) +
                  " ms (stale samples); a longer run (a hold) and the log keep their last sample; the rest keep "
                  "their times");
  c->callback([args] { run(*args); });
}

}  // namespace

EBH_COMMAND(setup);
