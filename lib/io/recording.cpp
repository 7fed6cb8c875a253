#include "io/recording.hpp"

#include "io/import.hpp"  // kLogGapFactor, kDeviceRateLowHz
#include "core/units.hpp"
#include <cctype>
#include <algorithm>
#include <map>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <sstream>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "io/h5.hpp"

namespace ebh {
namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

bool finite(Vec3d v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// How far p lies outside the box [lo, hi] (0 inside it).
double distance_outside(Vec3d p, Vec3d lo, Vec3d hi) { return norm(cwise_max(lo - p, cwise_max(p - hi, Vec3d{}))); }

/// What is wrong with sample i's time, if anything.
std::optional<std::string> time_defect(const std::vector<double>& t, std::size_t i) {
  if (i == 0) return std::isfinite(t[0]) ? std::nullopt : std::optional<std::string>("time is NaN or Inf");
  std::optional<std::string> bad = ebh::time_defect(t[i - 1], t[i]);
  // Zeros to the end: rows a writer declared and never filled (a logger stopped early, a dataset
  // created at its full size), which HDF5 reads as its fill value.
  if (bad && t[i] == 0 && std::all_of(t.begin() + static_cast<std::ptrdiff_t>(i), t.end(), [](double x) { return x == 0; }))
    *bad += "; the times from here on (" + std::to_string(t.size() - i) +
            " rows) are all 0: rows declared and never written (a logger stopped before it filled the dataset?)";
  return bad;
}

/// The rows [first, last] a replay of `window` interpolates: from the last sample at or before its
/// start to one past the first at or after its end (a tick's time may pass the end by round-off).
/// `t` is strictly increasing, with at least two samples.
std::pair<std::size_t, std::size_t> window_rows(const std::vector<double>& t, const RecordingWindow& w) {
  const std::size_t n = t.size();
  const double t0 = t.front() + w.start;
  std::size_t first = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), t0) - t.begin());
  first = std::min(first == 0 ? 0 : first - 1, n - 2);  // a window past the end: replay_window says so
  std::size_t last = n - 1;
  if (w.duration > 0) {
    const auto end = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), t0 + w.duration) - t.begin());
    last = std::min(end + 1, n - 1);
  }
  return {first, std::max(last, first + 1)};
}

}  // namespace

namespace {

/// The per-sample checks of validate_recording, in place; `before`, where given, is the sample
/// before rec's first (a recording checked in parts: the quaternions' hemispheres continue).
void validate_samples(Recording& rec, const SampleLocator& where, const Quatd* before) {
  auto fail = [&](std::string_view ds, std::size_t i, const std::string& what) {
    throw InputError(where(ds, i) + ": " + what);
  };
  for (std::size_t i = 0; i < rec.t.size(); ++i) {
    if (auto bad = time_defect(rec.t, i)) fail("/trajectory/t", i, *bad);
    if (!finite(rec.position[i])) fail("/trajectory/position", i, "position is NaN or Inf");
    Quatd& q = rec.orientation[i];
    double qn = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    if (!std::isfinite(qn)) fail("/trajectory/orientation", i, "orientation is NaN or Inf");
    if (std::abs(qn - 1.0) > kQuatNormTolerance)
      fail("/trajectory/orientation", i,
           "quaternion norm " + num(qn) + " is not 1 (within " + num(kQuatNormTolerance) + "): " +
               (std::abs(qn - 1.0) < 0.02 ? "written with too few digits? (write 6 or more)"
                                          : "not a unit quaternion (another quantity in these columns: Euler angles, a "
                                            "rotation vector?)"));
    q = Quatd{q.w / qn, q.x / qn, q.y / qn, q.z / qn};
    if (const Quatd* p = i > 0 ? &rec.orientation[i - 1] : before)
      if (p->w * q.w + p->x * q.x + p->y * q.y + p->z * q.z < 0) q = Quatd{-q.w, -q.x, -q.y, -q.z};
    double& j = rec.jaw[i];
    if (!std::isfinite(j)) fail("/trajectory/jaw", i, "jaw is NaN or Inf");
    if (j < -kJawTolerance || j > 1.0 + kJawTolerance) fail("/trajectory/jaw", i, "jaw " + num(j) + " outside [0, 1]");
    j = std::clamp(j, 0.0, 1.0);
  }
}

void check_rate(const Recording& rec, const std::string& file) {
  if (!(std::isfinite(rec.rate_hz) && rec.rate_hz > 0))
    throw InputError(file + ": attribute rate_hz = " + num(rec.rate_hz) + " is not a positive number");
}

/// The rows a recording is read in, a part at a time: HDF5 holds a selection's state per chunk it
/// touches, so one read of millions of rows stored in chunks of a few takes gigabytes (2.7 GB for
/// 3 million rows in chunks of 7, 1.2 GB for 300,000 in chunks of 1); a part's takes a part's
/// (about 1 KB a chunk). A window's samples are kept from them.
constexpr std::size_t kPartRows = 1 << 13;

/// A dataset's rows [first, first + count), read kPartRows at a time.
template <class T>
std::vector<T> read_in_parts(const h5::Dataset& d, const std::vector<std::ptrdiff_t>& expected, std::size_t first,
                             std::size_t count) {
  std::vector<T> out;
  out.reserve(count * (expected.size() > 1 ? static_cast<std::size_t>(expected[1]) : 1));
  for (std::size_t p = first; p < first + count; p += kPartRows) {
    const auto part = d.read_rows<T>(expected, p, std::min(kPartRows, first + count - p));
    out.insert(out.end(), part.data.begin(), part.data.end());
  }
  return out;
}

/// Samples [first, first + count) of a recording file's datasets, as stored (not yet validated).
Recording read_samples(const h5::Group& g, const std::string& path, const std::vector<double>& t, std::size_t first,
                       std::size_t count) {
  const auto n = static_cast<std::ptrdiff_t>(t.size());
  // Every per-sample dataset has the same first dimension as t: the shape check says so.
  const auto pos = read_in_parts<double>(g.dataset("position"), {n, 3}, first, count);
  const auto ori = read_in_parts<double>(g.dataset("orientation"), {n, 4}, first, count);
  auto jaw = read_in_parts<double>(g.dataset("jaw"), {n}, first, count);
  // Read wide and checked: HDF5's conversion to 8 bits clips 256 to 255 and -1 to 0 silently.
  const auto wide_buttons = read_in_parts<std::int64_t>(g.dataset("buttons"), {n}, first, count);
  for (std::size_t i = 0; i < wide_buttons.size(); ++i)
    if (wide_buttons[i] < 0 || wide_buttons[i] > 255)
      throw InputError(path + ": /trajectory/buttons[" + std::to_string(first + i) + "]: " +
                       std::to_string(wide_buttons[i]) + " is not a bitmask of 8 buttons (0 .. 255)");
  Recording rec;
  rec.t.assign(t.begin() + static_cast<std::ptrdiff_t>(first), t.begin() + static_cast<std::ptrdiff_t>(first + count));
  rec.position.resize(count);
  rec.orientation.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    rec.position[i] = {pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]};
    rec.orientation[i] = {ori[4 * i], ori[4 * i + 1], ori[4 * i + 2], ori[4 * i + 3]};
  }
  rec.jaw = std::move(jaw);
  rec.buttons.assign(wide_buttons.begin(), wide_buttons.end());
  return rec;
}

/// A window of the file (rows [lo, hi]) into rec: every sample validated in parts of kPartRows (the
/// same checks and quaternion hemispheres as a whole read), the window's kept, and the outline
/// (every stride-th pose) taken on the way.
void read_window(const h5::Group& g, const std::string& path, const std::vector<double>& t, std::size_t lo,
                 std::size_t hi, Recording& rec) {
  const std::size_t n = t.size(), stride = (n + kOutlineSamples - 1) / kOutlineSamples;
  rec.span = Recording::FileSpan{t.front(), t.back(), lo, {}, {}, stride, {}};
  rec.t.reserve(hi - lo + 1);
  rec.position.reserve(hi - lo + 1);
  rec.orientation.reserve(hi - lo + 1);
  rec.jaw.reserve(hi - lo + 1);
  rec.buttons.reserve(hi - lo + 1);
  Quatd before;
  for (std::size_t first = 0; first < n;) {
    const std::size_t count = std::min(kPartRows, n - first);
    Recording part = read_samples(g, path, t, first, count);
    validate_samples(part, [&path, first](std::string_view ds, std::size_t i) {
      return path + ": " + std::string(ds) + "[" + std::to_string(first + i) + "]";
    }, first > 0 ? &before : nullptr);
    for (std::size_t i = (stride - first % stride) % stride; i < count; i += stride) {
      rec.span->outline.push_back(part.position[i]);
      rec.span->outline_orientation.push_back(part.orientation[i]);
      rec.span->outline_t.push_back(part.t[i]);
    }
    for (std::size_t i = std::max(first, lo); i < first + count && i <= hi; ++i) {
      const std::size_t k = i - first;
      rec.t.push_back(part.t[k]);
      rec.position.push_back(part.position[k]);
      rec.orientation.push_back(part.orientation[k]);
      rec.jaw.push_back(part.jaw[k]);
      rec.buttons.push_back(part.buttons[k]);
    }
    before = part.orientation.back();
    first += count;
  }
}

}  // namespace

std::optional<std::string> time_defect(double previous, double t) {
  if (!std::isfinite(t)) return "time is NaN or Inf";
  if (!(t > previous)) {
    // Equal times far from 0: a clock's epoch seconds at a resolution a double does not hold there
    // (at 1e15 s a double's step is 0.125 s), two different stamps read as one.
    const bool rounded = t == previous && std::abs(t) * 1e-15 > 1e-4;
    return "time not strictly increasing (" + shortest_text(t) + " s after " + shortest_text(previous) + " s)" +
           (rounded ? std::string("; so far from 0 a double holds times only to ") + num(std::abs(t) * 2.2e-16) +
                          " s: count t from the log's start (subtract its first time)"
                    : std::string());
  }
  return std::nullopt;
}

void validate_recording(Recording& rec, const std::string& file, const SampleLocator& where) {
  const std::size_t n = rec.t.size();
  auto too_few = [&] {
    throw InputError(file + ": the recording has " + (n == 0 ? std::string("no samples") : "one sample") +
                     "; a recording needs at least two (a trajectory with a duration)");
  };
  if (n == 0) too_few();
  auto check_len = [&](std::string_view ds, std::size_t len) {
    if (len != n)
      throw InputError(file + ": " + std::string(ds) + ": " + std::to_string(len) + " samples, /trajectory/t has " +
                       std::to_string(n));
  };
  check_len("/trajectory/position", rec.position.size());
  check_len("/trajectory/orientation", rec.orientation.size());
  check_len("/trajectory/jaw", rec.jaw.size());
  check_len("/trajectory/buttons", rec.buttons.size());
  check_rate(rec, file);
  validate_samples(rec, where, nullptr);
  if (n < 2) too_few();  // after the samples: a defect in the one sample is the better message
}

Recording read_recording(const std::string& path, std::optional<RecordingWindow> window) {
  h5::File f = h5::File::open_read(path);
  if (!f.has("trajectory")) {
    // A replay's output given for its recording: say what it is, and where its recording is.
    if (f.has("haptic")) {
      const std::string recording = f.has_attr("recording") ? f.attr_string("recording") : "";
      throw InputError(path + ": a replay output (/haptic), not a device recording (/trajectory)" +
                       (recording.empty() ? std::string() : "; its replay read the recording " + recording));
    }
    throw InputError(path + ": /trajectory: missing group (is it a recording?)");
  }
  h5::Group g = f.group("trajectory");
  // The rows a dataset declares are counted before any is read: a logger that pre-sized its
  // datasets and crashed leaves a small file claiming billions of rows (docs/FORMATS.md, Limits).
  // The other datasets must have t's rows, which their shape check says before reading them.
  const std::vector<double> t = [&g] {
    const h5::Dataset times = g.dataset("t");
    const std::vector<std::size_t> shape = times.shape();
    if (!shape.empty() && static_cast<double>(shape[0]) > kMaxRecordingSamples)
      throw InputError(times.where() + ": " + std::to_string(shape[0]) + " samples declared; the limit is " +
                       std::to_string(static_cast<long long>(kMaxRecordingSamples)) +
                       " samples (2.8 h at 1 kHz): split the recording");
    if (shape.size() != 1) return times.read<double>({-1}).data;  // the shape check says what is wrong
    return read_in_parts<double>(times, {-1}, 0, shape[0]);
  }();
  // One row per sample in each dataset: a dataset of another length is named against t's.
  for (const char* name : {"position", "orientation", "jaw", "buttons"}) {
    if (!g.has(name)) continue;  // its read says it is missing
    const h5::Dataset d = g.dataset(name);
    if (const std::vector<std::size_t> shape = d.shape(); !shape.empty() && shape[0] != t.size())
      throw InputError(d.where() + ": " + std::to_string(shape[0]) + " rows, /trajectory/t " + std::to_string(t.size()) +
                       ": a recording has one row per sample in every dataset (a dataset extended past what was " +
                       "written, or another cut short?)");
  }
  // A window of a long recording: the times say which rows it needs (every time checked first).
  std::optional<std::pair<std::size_t, std::size_t>> rows;
  if (window && t.size() >= 2) {
    for (std::size_t i = 0; i < t.size(); ++i)
      if (auto bad = time_defect(t, i)) throw InputError(path + ": /trajectory/t[" + std::to_string(i) + "]: " + *bad);
    rows = window_rows(t, *window);
  }
  Recording rec = rows ? Recording{} : read_samples(g, path, t, 0, t.size());
  rec.rate_hz = f.attr_double("rate_hz");
  rec.source = f.attr_string("source");
  rec.scene = f.attr_string("scene");
  rec.tool = f.attr_string("tool");
  rec.description = f.attr_string("description");
  if (f.has_attr("generator")) rec.generator = f.attr_string("generator");
  if (f.has_attr("baked_mirror")) {
    rec.baked_mirror = f.attr_string("baked_mirror");
    if (rec.baked_mirror != "x" && rec.baked_mirror != "y" && rec.baked_mirror != "z")
      throw InputError(path + ": attribute baked_mirror: expected x, y or z, got '" + rec.baked_mirror + "'");
  }
  for (const char* kind : {"world", "tool"}) {
    const std::string name = std::string(kind) + "_transform", baked = "baked_" + name;
    auto& apply = kind[0] == 'w' ? rec.transforms.world : rec.transforms.tool;
    auto& done = kind[0] == 'w' ? rec.baked.world : rec.baked.tool;
    if (f.has_attr(name)) apply = from_attribute(f.attr_doubles(name), path, name);
    if (f.has_attr(baked)) done = from_attribute(f.attr_doubles(baked), path, baked);
    if (apply && done)
      throw InputError(path + ": attributes " + name + " and " + baked + ": a " + kind +
                       " transform both still to apply and already in the poses; keep one");
  }

  // A dataset may declare its unit; positions must be in metres (SI inside and in files: docs/FORMATS.md).
  h5::Dataset pd = g.dataset("position");
  if (pd.has_attr("unit") && pd.attr_string("unit") != "m")
    throw InputError(pd.where() + ": unit '" + pd.attr_string("unit") + "', expected 'm'");
  h5::Dataset td = g.dataset("t");
  if (td.has_attr("unit") && td.attr_string("unit") != "s")
    throw InputError(td.where() + ": unit '" + td.attr_string("unit") + "', expected 's'");
  // The quaternion's order, where its unit says it: (x, y, z, w), as scipy and ROS store it, read
  // as (w, x, y, z) would be another rotation of unit norm, which no check would catch.
  if (h5::Dataset od = g.dataset("orientation"); od.has_attr("unit")) {
    std::string order;
    for (char c : od.attr_string("unit"))
      if (std::isalpha(static_cast<unsigned char>(c))) order += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (order.find("xyzw") != std::string::npos && order.find("wxyz") == std::string::npos)
      throw InputError(od.where() + ": unit '" + od.attr_string("unit") + "': a quaternion stored (x, y, z, w); " +
                       "recordings store (w, x, y, z): move the last column first");
  }

  if (rows) {
    check_rate(rec, path);
    read_window(g, path, t, rows->first, rows->second, rec);
  } else {
    validate_recording(rec, path, [&path](std::string_view ds, std::size_t i) {
      return path + ": " + std::string(ds) + "[" + std::to_string(i) + "]";
    });
  }
  // The limit synth and import hold a recording's rate to (a file of another writer's, here).
  if (rec.rate_hz > kMaxSampleRateHz)
    throw InputError(path + ": attribute rate_hz = " + num(rec.rate_hz) + " Hz: over the " + num(kMaxSampleRateHz) +
                     " Hz a device samples at (docs/FORMATS.md, Limits)");
  return rec;
}

void write_recording(const std::string& path, const Recording& rec_in) {
  Recording rec = rec_in;
  validate_recording(rec, path, [&path](std::string_view ds, std::size_t i) {
    return path + ": " + std::string(ds) + "[" + std::to_string(i) + "]";
  });
  const std::size_t n = rec.size();
  std::vector<double> pos(3 * n), ori(4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) pos[3 * i + k] = rec.position[i][k];
    const Quatd& q = rec.orientation[i];
    ori[4 * i] = q.w; ori[4 * i + 1] = q.x; ori[4 * i + 2] = q.y; ori[4 * i + 3] = q.z;
  }
  h5::AtomicFile out(path);
  h5::File& f = out.file();
  h5::Group g = f.create_group("trajectory");
  const h5::WriteOptions z{.compress = true};
  g.write<double>("t", rec.t, {n}, z).set_attr("unit", "s");
  g.write<double>("position", pos, {n, 3}, z).set_attr("unit", "m");
  g.write<double>("orientation", ori, {n, 4}, z).set_attr("unit", "1 (unit quaternion w, x, y, z)");
  g.write<double>("jaw", rec.jaw, {n}, z).set_attr("unit", "1 (0 closed, 1 open)");
  g.write<std::uint8_t>("buttons", rec.buttons, {n}, z).set_attr("unit", "bitmask");
  f.set_attr("rate_hz", rec.rate_hz);
  f.set_attr("source", rec.source);
  f.set_attr("scene", rec.scene);
  f.set_attr("tool", rec.tool);
  f.set_attr("description", rec.description);
  if (!rec.generator.empty()) f.set_attr("generator", rec.generator);
  if (rec.transforms.world) f.set_attr("world_transform", to_attribute(*rec.transforms.world));
  if (rec.transforms.tool) f.set_attr("tool_transform", to_attribute(*rec.transforms.tool));
  if (rec.baked.world) f.set_attr("baked_world_transform", to_attribute(*rec.baked.world));
  if (rec.baked.tool) f.set_attr("baked_tool_transform", to_attribute(*rec.baked.tool));
  if (!rec.baked_mirror.empty()) f.set_attr("baked_mirror", rec.baked_mirror);
  out.commit();
}

void apply_stored_transforms(Recording& rec, const std::string& file) {
  if (rec.transforms.empty()) return;
  apply_pose_transforms(rec.transforms, rec.position, rec.orientation);
  if (rec.span) apply_pose_transforms(rec.transforms, rec.span->outline, rec.span->outline_orientation);
  if (rec.transforms.world) rec.baked.world = rec.transforms.world;
  if (rec.transforms.tool) rec.baked.tool = rec.transforms.tool;
  rec.transforms = {};
  validate_recording(rec, file, [&file](std::string_view ds, std::size_t i) {
    return file + ": " + std::string(ds) + "[" + std::to_string(i) + "] after the pose transforms";
  });
}


DeviceSample sample_at(const Recording& rec, double t) {
  const std::size_t n = rec.size();
  auto at = [&](std::size_t i) {
    return DeviceSample{t, rec.position[i], rec.orientation[i], rec.jaw[i], rec.buttons[i]};
  };
  if (n == 0) return DeviceSample{t, {}, {}, 1.0, 0};
  if (!(t > rec.t.front())) return at(0);
  if (t >= rec.t.back()) return at(n - 1);
  // First sample strictly after t; i0 = the one before it (t0 <= t < t1).
  std::size_t i1 = static_cast<std::size_t>(std::upper_bound(rec.t.begin(), rec.t.end(), t) - rec.t.begin());
  std::size_t i0 = i1 - 1;
  double s = (t - rec.t[i0]) / (rec.t[i1] - rec.t[i0]);
  DeviceSample d;
  d.t = t;
  d.position = rec.position[i0] + s * (rec.position[i1] - rec.position[i0]);
  d.orientation = slerp(rec.orientation[i0], rec.orientation[i1], s);
  d.jaw = rec.jaw[i0] + s * (rec.jaw[i1] - rec.jaw[i0]);
  d.buttons = rec.buttons[i0];
  return d;
}

namespace {
/// path without the samples `drop`.
std::vector<Vec3d> without_samples(const std::vector<Vec3d>& path, const std::vector<std::size_t>& drop) {
  std::vector<Vec3d> out;
  for (std::size_t i = 0; i < path.size(); ++i)
    if (std::find(drop.begin(), drop.end(), i) == drop.end()) out.push_back(path[i]);
  return out;
}
}  // namespace

std::vector<std::size_t> glitch_samples(const std::vector<Vec3d>& path) {
  const std::size_t n = path.size();
  if (n < 20) return {};
  const std::size_t k = std::max<std::size_t>(2, n / 500);  // the most samples a glitch may hold
  Vec3d lo, hi;  // the box of the samples but the k outermost on each side of each axis
  for (int a = 0; a < 3; ++a) {
    std::vector<double> c(n);
    for (std::size_t i = 0; i < n; ++i) c[i] = a == 0 ? path[i].x : a == 1 ? path[i].y : path[i].z;
    std::nth_element(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(k), c.end());
    const double low = c[k];
    std::nth_element(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(n - 1 - k), c.end());
    (a == 0 ? lo.x : a == 1 ? lo.y : lo.z) = low;
    (a == 0 ? hi.x : a == 1 ? hi.y : hi.z) = c[n - 1 - k];
  }
  const double far = std::max(norm(hi - lo), kGlitchMinDistance);
  std::vector<std::pair<double, std::size_t>> out;  // (distance from the box, sample)
  for (std::size_t i = 0; i < n; ++i) {
    const double d = distance_outside(path[i], lo, hi);
    if (!(d <= far)) out.emplace_back(std::isfinite(d) ? d : INFINITY, i);
  }
  if (out.size() > k) return {};  // not a few samples: the path itself
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::size_t> samples;
  for (const auto& [d, i] : out) samples.push_back(i);
  return samples;
}

std::optional<std::string> check_recording_in_scene(const Recording& rec, Vec3d bbox_min, Vec3d bbox_max,
                                                    double margin) {
  Vec3d lo = bbox_min - Vec3d{margin, margin, margin};
  Vec3d hi = bbox_max + Vec3d{margin, margin, margin};
  double worst = 0;
  std::size_t worst_i = 0;
  for (std::size_t i = 0; i < rec.size(); ++i) {
    Vec3d p = rec.position[i];
    const double d = distance_outside(p, lo, hi);
    if (d > worst) { worst = d; worst_i = i; }
  }
  if (worst == 0) return std::nullopt;
  Vec3d p = rec.position[worst_i];
  double extent = norm(bbox_max - bbox_min);
  std::ostringstream o;
  o << "sample " << rec.row(worst_i) << " (t = " << num(rec.t[worst_i]) << " s) at (" << num(p.x) << ", " << num(p.y) << ", "
    << num(p.z) << ") m lies " << num(worst) << " m outside the scene's bounding box (" << num(bbox_min.x) << ", "
    << num(bbox_min.y) << ", " << num(bbox_min.z) << ")..(" << num(bbox_max.x) << ", " << num(bbox_max.y) << ", "
    << num(bbox_max.z) << ") m enlarged by " << num(margin) << " m";
  // A lone sample far from the rest, which fit: a glitch, not a unit.
  const std::vector<std::size_t> glitch = glitch_samples(rec.position);
  const std::vector<Vec3d> rest = without_samples(rec.position, glitch);
  if (!glitch.empty() && glitch.front() == worst_i && std::all_of(rest.begin(), rest.end(), [&](const Vec3d& q) {
        return distance_outside(q, lo, hi) == 0;
      }))
    o << "; the rest of the path lies within it" << (glitch.size() > 1 ? " (" + std::to_string(glitch.size()) + " samples lie out)" : "")
      << ": a glitch in the log? leave that line out";
  else if (extent > 0 && worst > 5 * extent)
    o << "; is the recording in mm or cm instead of metres?";
  return o.str();
}

namespace {

// How a trajectory sits against a box: its extent and its nearest approach, with every position
// scaled by f (a different length unit: the log's numbers times another metres-per-unit).
struct PathFit {
  double extent = 0;         // m, diagonal of the positions' bounding box
  double distance = 0;       // m, smallest distance of a sample from the box (0 inside)
  double farthest = 0;       // m, largest distance of a sample from the box
  Vec3d centre;              // m, centre of the positions' bounding box
};

PathFit fit_path(const std::vector<Vec3d>& path, double f, Vec3d lo, Vec3d hi) {
  Vec3d plo = f * path.front(), phi = plo;
  double nearest = std::numeric_limits<double>::infinity(), farthest = 0;
  for (const Vec3d& raw : path) {
    const Vec3d p = f * raw;
    plo = cwise_min(plo, p);
    phi = cwise_max(phi, p);
    const double d = distance_outside(p, lo, hi);
    nearest = std::min(nearest, d);
    farthest = std::max(farthest, d);
  }
  return {norm(phi - plo), nearest, farthest, 0.5 * (plo + phi)};
}

/// The path's size and place fit the mesh's, and a replay accepts it (no sample beyond
/// replay_outside_margin: a unit under which the replay refuses the recording is no fix).
bool fits(const PathFit& p, double diagonal) {
  return p.extent <= kPathExtentMaxRatio * diagonal && p.extent >= kPathExtentMinRatio * diagonal &&
         p.distance <= kPathMaxDistanceDiagonals * diagonal && p.farthest <= replay_outside_margin(diagonal);
}

const char* unit_label(double metres_per_unit) {
  for (const std::string_view name : kLengthUnitNames)
    if (length_unit_metres(name) == metres_per_unit) return name.data();
  return nullptr;
}

/// The unit in prose: "the log is in inches", not "in in".
std::string unit_word(double metres_per_unit) {
  return metres_per_unit == kMetresPerInch ? "inches" : unit_label(metres_per_unit);
}

// Three significant digits: what a message about sizes needs.
std::string short_num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// An offset to copy into --transform: to 0.1 mm, however far (a mesh 1 km off in %.3g is 1e+03,
// 20 mm wrong).
std::string offset_num(double v) { return fixed_text(v, 4); }

// "95x" or "1/84 of".
std::string ratio_text(double r) {
  char buf[32];
  if (r >= 1) std::snprintf(buf, sizeof buf, "%.3gx", r);
  else std::snprintf(buf, sizeof buf, "1/%.3g of", 1 / r);
  return buf;
}

}  // namespace

namespace {

/// The consecutive samples (at - 1, at) between which change(at) (a distance, an angle) over their
/// time apart is largest, and that rate; how many changes are faster than `limit` and the first of
/// them (its later sample). All 0 without two samples.
/// Also the longest run of consecutive changes faster than `limit`: `run` changes, the last at
/// sample `run_end`.
struct FastestChange {
  std::size_t at = 0;
  double rate = 0;
  std::size_t over = 0, first = 0;
  std::size_t run = 0, run_end = 0;
};
template <class Change>
FastestChange fastest_change(const Recording& rec, double limit, Change change) {
  FastestChange f;
  std::size_t run = 0;
  for (std::size_t i = 1; i < rec.size(); ++i) {
    const double rate = change(i) / (rec.t[i] - rec.t[i - 1]);
    if (rate > f.rate) {
      f.at = i;
      f.rate = rate;
    }
    if (rate > limit && f.over++ == 0) f.first = i;
    run = rate > limit ? run + 1 : 0;
    if (run > f.run) f.run = run, f.run_end = i;
  }
  return f;
}

/// Consecutive changes over a hand's limit from which a log's fast motion is its own, held, not a
/// gap or a reset (one or two changes: a jump, or out and back). Ten samples are 10 ms at 1 kHz.
constexpr std::size_t kSustainedChanges = 10;

/// What the fast changes are: ": a gap or a reset in the log" for a jump, else the run of them
/// ("N changes in a row ... held for T s"), with `held_cause` the likely reasons of such a motion.
std::string fast_change_cause(const Recording& rec, const FastestChange& f, const char* what, const char* held_cause) {
  if (f.run < kSustainedChanges) return ": a gap or a reset in the log";
  const std::size_t from = f.run_end - f.run;
  char line[320];
  std::snprintf(line, sizeof line, ": not a jump but %zu %s in a row from sample %zu to %zu (t = %.15g .. %.15g s), a motion no "
                "hand makes held for %.3g s (%s)",
                f.run, what, rec.row(from), rec.row(f.run_end), rec.t[from], rec.t[f.run_end], rec.t[f.run_end] - rec.t[from],
                held_cause);
  return line;
}

/// ", the fastest of N over LIMIT, the first between samples A and B (t = T s)" where there are
/// others, else "".
std::string others_over(const Recording& rec, const FastestChange& f, const char* what, double limit, const char* unit) {
  if (f.over < 2) return "";
  char line[200];
  std::snprintf(line, sizeof line, "; the fastest of %zu %s over %g %s, the first between samples %zu and %zu (t = %.15g s)",
                f.over, what, limit, unit, rec.row(f.first - 1), rec.row(f.first), rec.t[f.first]);
  return line;
}

/// The angle (rad) the tool turns between samples i - 1 and i.
double turn_angle(const Recording& rec, std::size_t i) {
  const Quatd &a = rec.orientation[i - 1], &b = rec.orientation[i];
  return 2 * std::acos(std::min(1.0, std::abs(a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z)));
}

/// How far the tool moves between samples i - 1 and i (hypot: a jump of 1e200 m is not inf).
double step_length(const Recording& rec, std::size_t i) {
  const Vec3d d = rec.position[i] - rec.position[i - 1];
  return std::hypot(d.x, d.y, d.z);
}

}  // namespace

std::optional<std::string> check_recording_speed(const Recording& rec) {
  const FastestChange f = fastest_change(rec, kToolSpeedMax, [&rec](std::size_t i) { return step_length(rec, i); });
  if (!(f.rate > kToolSpeedMax)) return std::nullopt;
  const std::size_t at = f.at;
  char line[900];
  std::snprintf(line, sizeof line,
                "the tool jumps %.3g m between samples %zu and %zu (the recording's t = %.15g .. %.15g s: %.3g m/s; a hand moves it at "
                "under 1 m/s%s)%s, which a replay passes through in one tick",
                step_length(rec, at), rec.row(at - 1), rec.row(at), rec.t[at - 1], rec.t[at], f.rate,
                others_over(rec, f, "jumps", kToolSpeedMax, "m/s").c_str(),
                fast_change_cause(rec, f, "jumps", "positions logged in a smaller unit than read, or times in a larger one").c_str());
  return std::string(line);
}

double median_interval(const std::vector<double>& t) {
  if (t.size() < 3) return 0;
  std::vector<double> dt(t.size() - 1);
  for (std::size_t i = 0; i + 1 < t.size(); ++i) dt[i] = t[i + 1] - t[i];
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

std::optional<LogGaps> find_log_gaps(const std::vector<double>& t, const std::function<bool(std::size_t)>& still) {
  const std::size_t n = t.size();
  if (n < 3) return std::nullopt;
  LogGaps g;
  g.median = median_interval(t);
  const double bound = std::max(kLogGapFactor * g.median, 2.0 / kDeviceRateLowHz);
  double longest = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double dt = t[i + 1] - t[i];
    if (!(dt > bound) || (still && still(i + 1))) continue;
    ++g.count;
    if (dt > longest) longest = dt, g.longest = i;
  }
  if (g.count == 0) return std::nullopt;
  return g;
}

std::optional<std::string> check_recording_gaps(const Recording& rec) {
  const std::optional<LogGaps> g = find_log_gaps(rec.t, [&rec](std::size_t i) { return repeats_previous(rec, i, rec.jaw); });
  if (!g) return std::nullopt;
  const std::size_t i = g->longest;
  char line[400];
  std::snprintf(line, sizeof line,
                "%s of %.4g s between samples %zu and %zu (the recording's t = %.15g .. %.15g s), %.3g times the median "
                "interval of %.3g ms: the logger missed samples there, and a replay moves the tool in a straight line "
                "across %s",
                g->count == 1 ? "a gap" : (std::to_string(g->count) + " gaps, the longest").c_str(), rec.t[i + 1] - rec.t[i],
                rec.row(i), rec.row(i + 1), rec.t[i], rec.t[i + 1], (rec.t[i + 1] - rec.t[i]) / g->median, g->median * 1e3,
                g->count == 1 ? "it" : "them");
  return std::string(line);
}

std::optional<std::string> check_recording_rate(const Recording& rec) {
  const double median = median_interval(rec.t);
  if (!(median > 0)) return std::nullopt;
  const double rate = 1 / median, ratio = rec.rate_hz / rate;
  char line[400];
  if (rate > kMaxSampleRateHz) {
    std::snprintf(line, sizeof line, "the samples are %.3g s apart (the median interval: %.3g Hz), over the %g Hz a device "
                  "samples at, and a replay passes them all in %.3g s: are the times in seconds?", median, rate,
                  kMaxSampleRateHz, rec.t.back() - rec.t.front());
    return std::string(line);
  }
  if (ratio <= kRateMismatch && ratio >= 1 / kRateMismatch) return std::nullopt;
  const auto near = [ratio](double x) { return ratio > x / 3 && ratio < x * 3; };
  const char* unit = near(1e3) ? "ms" : near(1e6) ? "us" : near(1e9) ? "ns" : nullptr;
  std::snprintf(line, sizeof line, "attribute rate_hz = %g Hz, but the samples are %.3g s apart (the median interval: %.3g "
                "Hz)%s%s%s", rec.rate_hz, median, rate, unit ? ": times in " : "", unit ? unit : "",
                unit ? ", which a replay reads as seconds and plays that much slower than the device moved?"
                     : ": a replay follows the times, not rate_hz");
  return std::string(line);
}

std::size_t button_presses(std::span<const std::uint8_t> buttons, int bit) {
  std::size_t presses = 0;
  for (std::size_t i = 0; i < buttons.size(); ++i)
    presses += ((buttons[i] >> bit) & 1) && (i == 0 || !((buttons[i - 1] >> bit) & 1));
  return presses;
}

bool repeats_previous(const Recording& rec, std::size_t i, std::span<const double> jaw) {
  return rec.position[i] == rec.position[i - 1] && rec.orientation[i] == rec.orientation[i - 1] &&
         (jaw.size() <= i || jaw[i] == jaw[i - 1]) && (rec.buttons.size() <= i || rec.buttons[i] == rec.buttons[i - 1]);
}

std::optional<StaleSamples> find_stale_samples(const Recording& rec) {
  const std::size_t n = rec.t.size();
  if (rec.position.size() != n || rec.orientation.size() != n) return std::nullopt;
  std::map<std::size_t, std::size_t> intervals;  // samples between consecutive changes: how often
  std::size_t last = 0, changes = 0;
  for (std::size_t i = 1; i < n; ++i) {
    if (repeats_previous(rec, i, rec.jaw)) continue;
    if (changes++ > 0) ++intervals[i - last];
    last = i;
  }
  if (changes < kStaleMinChanges) return std::nullopt;
  std::size_t mode = 0, most = 0;
  for (const auto& [interval, count] : intervals)
    if (count > most) most = count, mode = interval;
  const double regular = static_cast<double>(most) / static_cast<double>(changes - 1);
  if (mode < 2 || regular < kStaleRegularFraction) return std::nullopt;
  return StaleSamples{mode, changes, regular};
}

std::optional<std::string> check_recording_stale(const Recording& rec) {
  const std::optional<StaleSamples> s = find_stale_samples(rec);
  if (!s) return std::nullopt;
  const double log_hz = static_cast<double>(rec.t.size() - 1) / (rec.t.back() - rec.t.front());
  const double device_hz = log_hz / static_cast<double>(s->period);
  char line[480];
  std::snprintf(line, sizeof line,
                "the pose changes only every %zu samples (%.0f%% of its %zu changes): a device updating at about %.3g Hz "
                "logged at %.4g Hz, its last sample repeated until the next; a replay holds the tool and jumps it %.3g "
                "times a second, a ripple at that rate in the force (`ebh import --drop-repeats` on the device's log "
                "interpolates between its updates)",
                s->period, 100 * s->regular, s->changes, device_hz, log_hz, device_hz);
  return std::string(line);
}

std::optional<std::string> check_recording_turn(const Recording& rec) {
  const FastestChange f = fastest_change(rec, kToolTurnRateMax, [&rec](std::size_t i) { return turn_angle(rec, i); });
  if (!(f.rate > kToolTurnRateMax)) return std::nullopt;
  const std::size_t at = f.at;
  char line[900];
  std::snprintf(line, sizeof line,
                "the tool turns %.3g degrees between samples %zu and %zu (the recording's t = %.15g .. %.15g s: %.3g rad/s; "
                "a hand turns it at a few%s)%s, which the virtual tool follows at "
                "tool.max_step_rotation_deg a Newton step, rendering its lag as torque meanwhile (tool.torque_limit)",
                turn_angle(rec, at) * 180 / std::numbers::pi, rec.row(at - 1), rec.row(at), rec.t[at - 1], rec.t[at],
                f.rate, others_over(rec, f, "turns", kToolTurnRateMax, "rad/s").c_str(),
                fast_change_cause(rec, f, "turns", "a part that spins, such as a roll joint's encoder, or angles in degrees "
                                  "read as radians").c_str());
  return std::string(line);
}

std::optional<std::string> check_recording_scale(const Recording& rec, Vec3d lo, Vec3d hi,
                                                 std::optional<double> log_unit_m) {
  const double diagonal = norm(hi - lo);
  // The whole file's path, also where a window of it was read: a unit is the file's.
  const std::vector<Vec3d>& path = rec.span ? rec.span->outline : rec.position;
  if (path.empty() || !(diagonal > 0)) return std::nullopt;
  const PathFit now = fit_path(path, 1.0, lo, hi);
  // A tool that never moves has no size to judge (no unit scales it); only its place counts.
  if (fits(now, diagonal) || (now.extent == 0 && now.distance <= kPathMaxDistanceDiagonals * diagonal))
    return std::nullopt;
  // A few samples far from the rest, which fits: a glitch in the log (one corrupt line), not its
  // unit, which fits the rest.
  {
    const std::vector<std::size_t> glitch = glitch_samples(path);
    if (!glitch.empty() && fits(fit_path(without_samples(path, glitch), 1.0, lo, hi), diagonal)) {
      const std::size_t g = glitch.front();
      std::ostringstream o;
      o << "sample ";
      if (rec.span)  // the outline's pose
        o << g * rec.span->outline_stride << " (t = " << rec.span->outline_t[g] << " s)";
      else
        o << rec.row(g) << " (t = " << rec.t[g] << " s)";
      o << " at (" << short_num(path[g].x) << ", " << short_num(path[g].y) << ", " << short_num(path[g].z)
        << ") m lies far from the rest of the path"
        << (glitch.size() > 1 ? " (" + std::to_string(glitch.size()) + " samples do)" : "")
        << ", which fits the physical mesh in this unit: a glitch in the log? leave that line out";
      return o.str();
    }
  }

  // The units the log may have been in: f = true unit / the unit it was read with.
  struct Candidate {
    double f;
    std::string fix;
    const char* unit;  // the unit the log is in, if this is the fix
  };
  // Inches are a fix only named beside a metric one that brings the path to the mesh where they
  // would too: a size cannot tell them from cm (2.54 times apart), and a metric log whose tool offset
  // is not given yet (a gimbal 4 cm behind the tip) comes to the mesh in inches instead of its unit.
  std::vector<Candidate> candidates, inch_candidates;
  const double units[] = {1.0, 1e-2, 1e-3, kMetresPerInch};
  const char* known = log_unit_m ? unit_label(*log_unit_m) : nullptr;
  // Read in inches: only where the import says so (a replay does not know the import's unit).
  for (double used : units)
    for (double truth : units) {
      if (truth == used || (known ? used != *log_unit_m : used == kMetresPerInch)) continue;
      std::string fix = known ? std::string("--unit ") + unit_label(truth)
                              : "the log is in " + unit_word(truth) + ", not " + unit_word(used) +
                                    ": ebh import --unit " + unit_label(truth);
      (truth == kMetresPerInch ? inch_candidates : candidates).push_back({truth / used, fix, unit_label(truth)});
    }
  // A recording of a tool at work touches the tissue: a unit under which the path comes to the
  // mesh's box is the likely fix, the one whose extent is nearest the mesh's size first. "Comes
  // to" within a tenth of its diagonal: a forceps' pose is its jaws' pivot, which holds a grasp
  // some millimetres off the tissue (cholecystectomy_grasp in cm stays 3 mm outside the box; in
  // mm, a unit too small, it entered it, and a replay so imported rendered 0.15 N for 1.0 N).
  const bool size_off = now.extent > kPathExtentMaxRatio * diagonal ||
                        (now.extent > 0 && now.extent < kPathExtentMinRatio * diagonal);
  const auto size_miss = [&](const PathFit& q) { return std::abs(std::log10(q.extent / diagonal)); };
  // A path whose size fits as read (and that is only out of place, or farther out than a replay
  // accepts) takes a unit only where its size fits about as well (within a factor ~3): a path of
  // the right size 0.4 m off enters the box in a unit 10x smaller, but its place is what is wrong.
  const auto no_worse_sized = [&](const PathFit& q) { return size_off || size_miss(q) <= size_miss(now) + 0.5; };
  const Candidate* best = nullptr;
  const Candidate* alternative = nullptr;  // one that comes to the mesh at a worse size: named beside a transform
  PathFit best_fit, alternative_fit;
  for (const Candidate& c : candidates) {
    const PathFit p = fit_path(path, c.f, lo, hi);
    if (!fits(p, diagonal) || !(p.distance <= 0.1 * diagonal)) continue;
    if (no_worse_sized(p) && (!best || size_miss(p) < size_miss(best_fit))) {
      best = &c;
      best_fit = p;
    } else if (!no_worse_sized(p) && (!alternative || size_miss(p) < size_miss(alternative_fit))) {
      alternative = &c;
      alternative_fit = p;
    }
  }
  // Otherwise a path of the right size is in the wrong place (a world transform), and one of the
  // wrong size takes the unit that fits it nearest the mesh.
  if (!best && size_off)
    for (const Candidate& c : candidates) {
      const PathFit p = fit_path(path, c.f, lo, hi);
      if (fits(p, diagonal) && (!best || p.distance < best_fit.distance)) {
        best = &c;
        best_fit = p;
      }
    }

  // Else a unit may give the path a size that fits the mesh but not its place: that unit, and a
  // world transform (the size is the unit's to fix, the place the transform's). Two units a factor
  // 10 apart often both fit the size band; a tool at work moves within about the organ's size, so
  // a unit under which the path is no larger than the mesh comes first, then the nearest size.
  const auto size_fits = [&](const PathFit& q) {
    return q.extent <= kPathExtentMaxRatio * diagonal && q.extent >= kPathExtentMinRatio * diagonal;
  };
  const auto sized_before = [&](const PathFit& a, const PathFit& b) {
    const bool a_larger = a.extent > diagonal, b_larger = b.extent > diagonal;
    return a_larger != b_larger ? !a_larger : size_miss(a) < size_miss(b);
  };
  const Candidate* sized = nullptr;
  PathFit sized_fit;
  if (!best && size_off)
    for (const Candidate& c : candidates) {
      const PathFit p = fit_path(path, c.f, lo, hi);
      if (size_fits(p) && (!sized || sized_before(p, sized_fit))) {
        sized = &c;
        sized_fit = p;
      }
    }

  std::ostringstream o;
  const bool far = now.distance > kPathMaxDistanceDiagonals * diagonal;
  // Near the mesh and of its size, but out of it farther than a replay accepts (through it and
  // out the far side, as a path in cm read with one unit too large does).
  const bool beyond = !far && now.farthest > replay_outside_margin(diagonal);
  const Vec3d start = path.front();
  o << "the tool path ";
  if (size_off)
    o << "spans " << short_num(now.extent) << " m, " << ratio_text(now.extent / diagonal)
      << " the physical mesh's bounding-box diagonal (" << short_num(diagonal) << " m)";
  if (size_off && (far || beyond)) o << ", and ";
  if (far)
    o << "stays at least " << short_num(now.distance) << " m (" << short_num(now.distance / diagonal)
      << " mesh diagonals" << (size_off ? "" : " of " + short_num(diagonal) + " m")
      << ") away from the physical mesh's bounding box, starting at (" << short_num(start.x) << ", "
      << short_num(start.y) << ", " << short_num(start.z) << ") m";
  if (beyond)
    o << "reaches " << short_num(now.farthest) << " m outside the physical mesh's bounding box, beyond the "
      << short_num(replay_outside_margin(diagonal)) << " m a replay accepts (it refuses those samples without --allow-outside)";
  // A path far smaller than the mesh and within its box, or near it, is also a tool held still at
  // the tissue or above it (a press held, a tool resting in it, one hovering with a hand's tremor):
  // nothing to fix then.
  const bool held = size_off && now.extent < kPathExtentMinRatio * diagonal && !far;
  o << (held ? "; a tool held still at or near the tissue needs no fix, else likely fix: " : "; likely fix: ");
  if (best) {
    o << best->fix;
    for (const Candidate& c : inch_candidates)
      if (const PathFit p = fit_path(path, c.f, lo, hi);
          best_fit.distance <= 0.1 * diagonal && fits(p, diagonal) && p.distance <= 0.1 * diagonal) {
        o << " (or, were it in inches, --unit in: the path comes to the mesh in either)";
        break;
      }
    // At replay the log's unit is not known, and the mesh's may be the wrong one instead: the
    // same misfit seen from the other side (`scene init --unit mm` on a mesh written in metres).
    if (!known)
      o << "; or, were the log right, the physical mesh is " << short_num(best->f > 1 ? best->f : 1 / best->f)
        << " times too " << (best->f > 1 ? "large" : "small") << ": check the scene's mesh.unit";
  } else if (beyond && now.distance <= 0.1 * diagonal) {
    // Of the mesh's size and at it, only far out at times: a tool brought from high above (its
    // approach), not a misplaced workspace.
    o << "none if those samples are the tool's approach from afar: replay from where it nears the tissue (--start) "
         "or with --allow-outside";
  } else if (!size_off) {
    const Vec3d off = 0.5 * (lo + hi) - now.centre;
    o << "--transform placing the device's workspace at the mesh (the mesh's centre is (" << offset_num(off.x) << ", "
      << offset_num(off.y) << ", " << offset_num(off.z) << ") m from the path's)";
    if (alternative)
      o << "; or " << alternative->fix << ", under which the path comes to the mesh, spanning "
        << ratio_text(alternative_fit.extent / diagonal) << " its diagonal";
  } else if (sized) {
    const Vec3d off = 0.5 * (lo + hi) - sized_fit.centre;
    o << sized->fix << ", and --transform to place it (in " << sized->unit << " the path spans "
      << short_num(sized_fit.extent) << " m, " << ratio_text(sized_fit.extent / diagonal)
      << " the mesh's diagonal, and the mesh's centre is (" << offset_num(off.x) << ", " << offset_num(off.y) << ", "
      << offset_num(off.z) << ") m from the path's)";
  } else {
    o << "none of m, cm, mm makes it fit: check the log's unit and the scene's";
  }
  return o.str();
}

double replay_window(double start, std::optional<double> duration, double length, double h_haptic,
                     const std::string& recording, const std::string& start_label, const std::string& duration_label) {
  if (!(std::isfinite(start) && start >= 0))
    throw InputError(start_label + " " + shortest_text(start) + ": expected a finite number >= 0 (seconds into " +
                     recording + ")");
  if (!(start < length))
    throw InputError(start_label + " " + shortest_text(start) + ": the recording " + recording + " is " +
                     shortest_text(length) + " s long; start before its end");
  if (duration && !(std::isfinite(*duration) && *duration > 0))
    throw InputError(duration_label + " " + shortest_text(*duration) + ": expected a finite number > 0 (seconds replayed)");
  const double rest = length - start;
  // --start 9.9 --duration 0.1 on a 10 s recording ends at its end: 10 - 9.9 is 0.0999999999999996,
  // which would read as a window cut short. Within a nanosecond of the end the duration stands.
  const double window = duration && start + *duration <= length + 1e-9 ? *duration
                        : duration                                     ? std::min(*duration, rest)
                                                                       : rest;
  // At least one haptic tick, counted as tick_count counts them (floor(window / h + 1e-9) + 1
  // ticks): a shorter window replays the tick at its start alone.
  if (std::floor(window / h_haptic + 1e-9) >= 1) return window;
  const std::string tick = "one haptic tick (" + shown_number(h_haptic) + " s at " + shown_number(1 / h_haptic) +
                           " Hz), which replays a single tick with no force step to measure";
  if (duration && *duration < rest)
    throw InputError(duration_label + " " + shortest_text(*duration) + ": shorter than " + tick +
                     ": expected at least " + shown_number(h_haptic) + " s");
  if (start > 0)
    throw InputError(start_label + " " + shortest_text(start) + ": leaves " + shown_number(rest) + " s of the recording " +
                     recording + " (" + shortest_text(length) + " s long), less than " + tick + ": start at least " +
                     shown_number(h_haptic) + " s before its end");
  throw InputError(recording + ": the recording is " + shown_number(length) + " s long, less than " + tick +
                   ": record at least " + shown_number(h_haptic) + " s");
}

}  // namespace ebh
