#pragma once
// Device recordings (DESIGN.md §4): one tool trajectory per HDF5 file.
//   /trajectory/t            (N,)   float64  s      strictly increasing
//   /trajectory/position     (N, 3) float64  m      tool frame origin (shaft's distal end), world
//   /trajectory/orientation  (N, 4) float64  1      unit quaternion (w, x, y, z), tool -> world
//   /trajectory/jaw          (N,)   float64  1      0 closed .. 1 open
//   /trajectory/buttons      (N,)   uint8    bitmask  bit i = device button i pressed
//   root attributes: rate_hz, source ("synthetic" | "device"), scene, tool, description
//   (optional: generator — the command that made the file)
// Every dataset has a `unit` attribute. See docs/FORMATS.md.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

struct Recording {
  std::vector<double> t;             ///< N sample times, s, strictly increasing
  std::vector<Vec3d> position;       ///< N tool-frame origins, m
  std::vector<Quatd> orientation;    ///< N unit quaternions (w, x, y, z)
  std::vector<double> jaw;           ///< N jaw openings, 0 closed .. 1 open
  std::vector<std::uint8_t> buttons; ///< N button bitmasks
  double rate_hz = 1000.0;           ///< nominal sample rate
  std::string source = "synthetic";  ///< "synthetic" or "device"
  std::string scene;                 ///< scenario to replay it with (scenarios/NAME.yaml)
  std::string tool;                  ///< "hook" or "forceps"
  std::string description;
  std::string generator;             ///< command and version that produced it (optional)

  std::size_t size() const { return t.size(); }
  double duration() const { return t.empty() ? 0.0 : t.back() - t.front(); }
};

/// The device state at one instant.
struct DeviceSample {
  double t = 0;
  Vec3d position;
  Quatd orientation;
  double jaw = 1;
  std::uint8_t buttons = 0;
};

/// Names a defective sample in an error message: where(dataset, index) -> "rec.h5: /trajectory/t[12]"
/// for a file, "log.txt:15" for a text log.
using SampleLocator = std::function<std::string(std::string_view dataset, std::size_t index)>;

/// A device samples at most as fast as a haptic loop ticks (scene/scene.hpp kMaxHapticHz).
inline constexpr double kMaxSampleRateHz = 100e3;
/// The most samples a recording is made with (synth): 10 million is 2.8 hours at 1 kHz and about
/// 2 GB of memory while it is written (~200 bytes a sample: the samples, a validated copy and the
/// packed datasets; docs/FORMATS.md, Limits).
inline constexpr double kMaxRecordingSamples = 10e6;

/// Checks a recording sample by sample and normalises its quaternions in place (and flips each
/// to the hemisphere of its predecessor so interpolation takes the short arc). Throws InputError
/// "WHERE: what" for: fewer than two samples (a trajectory has a duration), length mismatch,
/// NaN/Inf, time not strictly increasing, a quaternion whose
/// norm is off by more than kQuatNormTolerance, a jaw outside [0, 1] (beyond kJawTolerance).
void validate_recording(Recording& rec, const std::string& file, const SampleLocator& where);
inline constexpr double kQuatNormTolerance = 1e-3;  // float32 round trips and 4-digit logs pass
inline constexpr double kJawTolerance = 1e-9;       // jaw in [-tol, 1 + tol] is clamped to [0, 1]

/// Reads and validates a recording (messages name the file, dataset and sample index).
Recording read_recording(const std::string& path);
/// Validates and writes a recording atomically (temporary name, renamed when complete).
void write_recording(const std::string& path, const Recording& rec);

/// Spherical linear interpolation on the shortest arc, s in [0, 1].
Quatd slerp(Quatd a, Quatd b, double s);

/// The device state at time t: linear position and jaw, slerp orientation, buttons of the last
/// sample at or before t; clamped to the first/last sample outside the recording. O(log N).
DeviceSample sample_at(const Recording& rec, double t);

/// A one-line message when the trajectory lies outside the scene's bounding box enlarged by
/// `margin` metres on every side (a recording in mm read as m lands kilometres away), naming the
/// farthest sample; nullopt when it fits.
std::optional<std::string> check_recording_in_scene(const Recording& rec, Vec3d bbox_min, Vec3d bbox_max,
                                                    double margin);

}  // namespace ebh
