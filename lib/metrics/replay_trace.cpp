// Reading a replay output file (docs/FORMATS.md, "Replay output") into a ReplayTrace, with the HDF5 C API.
#include "metrics/replay_trace.hpp"

#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "core/units.hpp"
#include "io/h5.hpp"
#include "io/paths.hpp"

namespace ebh {
namespace {

/// Closes an HDF5 handle with the matching close function.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

/// Silences HDF5's automatic error printing while alive: failures become InputErrors instead.
class QuietHdf5 {
 public:
  QuietHdf5() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietHdf5() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

std::string shape_str(const std::vector<hsize_t>& dims) {
  std::ostringstream s;
  s << "(";
  for (std::size_t i = 0; i < dims.size(); ++i) s << (i ? "," : "") << dims[i];
  s << ")";
  return s.str();
}

/// The SI unit `ebh replay` gives a dataset of a physical quantity (the start of its `unit`
/// attribute), or nullptr for counts, flags and ratios.
const char* si_unit(const std::string& name) {
  if (name == "/haptic/force") return "N";
  if (name == "/haptic/torque") return "N m";
  if (name == "/haptic/pose_physical" || name == "/haptic/pose_virtual" || name == "/haptic/penetration" ||
      name == "/haptic/penetration_physical")
    return "m";
  if (name == "/haptic/t" || name == "/physical/t" || name.rfind("/timing/", 0) == 0) return "s";
  return nullptr;
}

/// A string attribute of an object (fixed or variable length, one string); "" when absent (an
/// output of an older ebh, or of other code, may lack it). `what` names it in messages ("FILE: root
/// attribute 'scene'"): one that is not one string (an integer, an array) is refused, where it was
/// read as absent (a `unit` of 1 passed the unit check, an integer `scene` showed as none).
std::string string_attribute(hid_t object, const char* name, const std::string& what) {
  if (H5Aexists(object, name) <= 0) return {};
  Handle a(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(a.get()), H5Tclose);
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (const H5T_class_t cls = H5Tget_class(type.get()); cls != H5T_STRING)
    throw InputError(what + " is not a string: it holds " +
                     (cls == H5T_INTEGER ? "an integer" : cls == H5T_FLOAT ? "a floating point number" : "a value of another type"));
  if (const hssize_t n = H5Sget_simple_extent_npoints(space.get()); n != 1)
    throw InputError(what + " holds " + std::to_string(n) + " strings; expected one");
  // The memory type takes the stored character set (h5py writes UTF-8): HDF5 does not convert
  // between ASCII and UTF-8.
  Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
  if (H5Tis_variable_str(type.get()) > 0) {
    H5Tset_size(mem.get(), H5T_VARIABLE);
    char* s = nullptr;
    if (H5Aread(a.get(), mem.get(), &s) < 0 || s == nullptr) throw InputError(what + " cannot be read");
    std::string out(s);
    H5free_memory(s);
    return out;
  }
  const std::size_t n = H5Tget_size(type.get());
  H5Tset_size(mem.get(), n + 1);
  std::string buf(n + 1, '\0');
  if (H5Aread(a.get(), mem.get(), buf.data()) < 0) throw InputError(what + " cannot be read");
  return std::string(buf.c_str());
}

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)), reading_(path_), file_(open(path_), H5Fclose) {}

  /// True when every component of an absolute path ("/a/b") exists (an external link refused).
  bool exists(const std::string& name) const { return h5::path_exists(file_.get(), name, path_); }

  /// Reads a numeric dataset of shape (rows) when cols == 0, else (rows, cols), converted to T.
  /// rows < 0 accepts any length. Returns nullopt when absent and optional.
  template <class T>
  std::optional<std::vector<T>> read(const std::string& name, long rows, int cols, hid_t mem_type,
                                     bool optional) const {
    if (!exists(name)) {
      if (optional) return std::nullopt;
      fail(name, "missing");
    }
    Handle ds(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
    if (!ds.ok()) fail(name, "is not a dataset");
    h5::check_stored_here(ds.get(), path_ + ": " + name, H5Tget_size(mem_type));
    Handle type(H5Dget_type(ds.get()), H5Tclose);
    H5T_class_t cls = H5Tget_class(type.get());
    if (cls != H5T_FLOAT && cls != H5T_INTEGER) fail(name, "is not numeric");
    // Counts and flags are integers: floating point (NaN read as 0 contacts) is another tool's file.
    if (std::is_integral_v<T> && cls != H5T_INTEGER) fail(name, "is stored as floating point numbers; expected integers");
    // The datasets of a physical quantity: floating point in their SI unit, as `ebh replay`
    // writes them; a file of other code that stores them as integers or in other units
    // (force in mN) would give numbers off by the factor, without a word.
    if (const char* unit = si_unit(name)) {
      if (cls != H5T_FLOAT) fail(name, std::string("is stored as integers; expected floating point numbers in ") + unit);
      const std::string given = string_attribute(ds.get(), "unit", path_ + ": dataset '" + name + "' attribute 'unit'");
      if (const std::string why = si_unit_problem(given, unit); !why.empty())
        fail(name, why);
    }
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    int rank = H5Sget_simple_extent_ndims(space.get());
    std::vector<hsize_t> dims(rank > 0 ? rank : 0);
    if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    const int want_rank = cols == 0 ? 1 : 2;
    bool good = rank == want_rank && (rows < 0 || dims[0] == static_cast<hsize_t>(rows)) &&
                (cols == 0 || dims[1] == static_cast<hsize_t>(cols));
    if (!good) {
      std::string n = rows < 0 ? "N" : std::to_string(rows);
      std::string want = cols == 0 ? "(" + n + ")" : "(" + n + "," + std::to_string(cols) + ")";
      fail(name, "has shape " + shape_str(dims) + ", expected " + want +
                     (rows < 0 ? "" : name.rfind("/physical/", 0) == 0 || name == "/timing/physical_step_s"
                                          ? " (N from /physical/t)"
                                          : " (N from /haptic/t)"));
    }
    std::vector<T> out(dims[0] * static_cast<std::size_t>(cols == 0 ? 1 : cols));
    if (!out.empty() && H5Dread(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
      throw InputError(path_ + ": " + name + ": " + h5::read_failure(ds.get()));
    if constexpr (std::is_floating_point_v<T>) within_bound(name, out, cols);
    return out;
  }

  /// Refuses a finite value beyond kMaxReplayValue (non-finite ones are compute_metrics' to count),
  /// naming its index (row and column of a 2-D dataset).
  void within_bound(const std::string& name, const std::vector<double>& values, int cols) const {
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (!std::isfinite(values[i]) || std::fabs(values[i]) <= kMaxReplayValue) continue;
      const std::string at = cols == 0 ? std::to_string(i)
                                       : std::to_string(i / static_cast<std::size_t>(cols)) + " (column " +
                                             std::to_string(i % static_cast<std::size_t>(cols)) + ")";
      // A pose's quaternion (columns 3..6) has no unit.
      const char* unit = cols == 7 && i % 7 >= 3 ? nullptr : si_unit(name);
      fail(name, "holds " + shown_number(values[i]) + (unit ? std::string(" ") + unit : std::string()) + " at index " + at +
                     ", beyond " + shown_number(kMaxReplayValue) + " in magnitude: no replay writes such a value (a "
                     "corrupt or edited file)");
    }
  }

  std::vector<double> doubles(const std::string& name, long rows, int cols = 0) const {
    return *read<double>(name, rows, cols, H5T_NATIVE_DOUBLE, false);
  }
  std::vector<double> optional_doubles(const std::string& name, long rows) const {
    return read<double>(name, rows, 0, H5T_NATIVE_DOUBLE, true).value_or(std::vector<double>{});
  }

  bool has_attr(const std::string& name) const { return H5Aexists(file_.get(), name.c_str()) > 0; }

  /// A numeric root attribute (scalar or one element).
  double number_attr(const std::string& name) const {
    if (H5Aexists(file_.get(), name.c_str()) <= 0) fail_attr(name, "missing");
    Handle a(H5Aopen(file_.get(), name.c_str(), H5P_DEFAULT), H5Aclose);
    Handle type(H5Aget_type(a.get()), H5Tclose);
    H5T_class_t cls = H5Tget_class(type.get());
    Handle space(H5Aget_space(a.get()), H5Sclose);
    if ((cls != H5T_FLOAT && cls != H5T_INTEGER) || H5Sget_simple_extent_npoints(space.get()) != 1)
      fail_attr(name, "is not a number");
    double v = 0;
    if (H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v) < 0) fail_attr(name, "cannot be read");
    return v;
  }

  /// A string root attribute; "" when absent (string_attribute).
  std::string string_attr(const std::string& name) const {
    return string_attribute(file_.get(), name.c_str(), path_ + ": root attribute '" + name + "'");
  }

  [[noreturn]] void fail(const std::string& dataset, const std::string& what) const {
    throw InputError(path_ + ": dataset '" + dataset + "' " + what);
  }
  [[noreturn]] void fail_attr(const std::string& attr, const std::string& what) const {
    throw InputError(path_ + ": root attribute '" + attr + "' " + what);
  }

 private:
  static hid_t open(const std::string& path) { return h5::open_file_read(path); }

  std::string path_;
  CrashNamesInput reading_;  ///< a crash inside HDF5 on a damaged file names it (io/atomic.hpp)
  Handle file_;
};

std::vector<TracePose> poses(const std::vector<double>& rows) {
  std::vector<TracePose> out(rows.size() / 7);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double* r = &rows[7 * i];
    out[i] = {{r[0], r[1], r[2]}, {r[3], r[4], r[5], r[6]}};
  }
  return out;
}

std::vector<Vec3d> vec3s(const std::vector<double>& rows) {
  std::vector<Vec3d> out(rows.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {rows[3 * i], rows[3 * i + 1], rows[3 * i + 2]};
  return out;
}

/// Every quaternion of a pose dataset is a unit quaternion, to kPoseQuatNormTolerance. (0, 0, 0,
/// 0), or components so small that their squares underflow, has no direction, normalises to NaN,
/// and made the stretch angle and the rotational passivity observer NaN with every sample finite
/// (finite: true, the angles null); one of another norm was normalised without a word, the
/// metrics of a file no replay wrote. No replay writes either: the poses are written in double,
/// the virtual tool's orientation normalised every Newton step, the physical tool's interpolated
/// between a recording's normalised samples (slerp), and a diverged one is NaN. A corrupt or edited
/// file, refused naming the row as a finite value beyond kMaxReplayValue is; a non-finite
/// component is compute_metrics' to count.
void rotations(const Reader& in, const std::string& name, const std::vector<TracePose>& poses) {
  const auto finite = [](Quatd r) {
    return std::isfinite(r.w) && std::isfinite(r.x) && std::isfinite(r.y) && std::isfinite(r.z);
  };
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Quatd q = poses[i].q;
    if (!finite(q)) continue;
    const bool rotation = finite(normalized(q));
    const double off = std::fabs(std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z) - 1);
    if (rotation && off <= kPoseQuatNormTolerance) continue;
    in.fail(name, "holds the quaternion (" + shown_number(q.w) + ", " + shown_number(q.x) + ", " + shown_number(q.y) + ", " +
                      shown_number(q.z) + ") at index " + std::to_string(i) + " (columns 3 to 6, qw qx qy qz), " +
                      (rotation ? "whose norm is off 1 by " + shown_number(off) + " (more than " +
                                      shown_number(kPoseQuatNormTolerance) + ")"
                                : std::string("which is no rotation")) +
                      ": no replay writes one (a corrupt or edited file)");
  }
}

/// A time axis (/haptic/t, /physical/t) is finite and strictly increasing. A replay's times are
/// its ticks' and steps' numbers over their rates, finite even in a run that blew up (which writes
/// NaN forces and positions, counted by compute_metrics): a NaN time is a corrupt or edited file,
/// and read, it gave metrics and a sweep's force error from a broken axis (0.18 N for 0.03 N).
void increasing(const Reader& in, const std::string& name, const std::vector<double>& t) {
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i]))
      in.fail(name, "holds " + shown_number(t[i]) + " s at index " + std::to_string(i) +
                        ": a replay's times are finite (a corrupt or edited file)");
    if (i > 0 && !(t[i] > t[i - 1])) in.fail(name, "is not strictly increasing at index " + std::to_string(i));
  }
}

/// A root attribute that says how the file is read (the mode, the contact model) is one of the
/// `values` a replay writes, or absent ("": the file does not say, as an older output's contact):
/// another was read as one of them (`mode: bogus` as async, `contact: surfac` as surface).
void one_of(const Reader& in, const char* name, const std::string& value, std::initializer_list<const char*> values) {
  if (value.empty()) return;
  std::string list;
  for (const char* v : values) {
    if (value == v) return;
    list += (list.empty() ? "" : ", ") + std::string(v);
  }
  in.fail_attr(name, "is '" + clipped(value) + "'; expected one of " + list);
}

/// Ticks are one haptic period apart (/haptic/t is n / haptic_hz): a step under half of it (an
/// edited file) would divide a force change by next to nothing (max |dF/dt| = inf). The times are
/// finite (increasing).
void tick_spacing(const Reader& in, const std::vector<double>& t, double haptic_hz) {
  const double least = 0.5 / haptic_hz;
  for (std::size_t i = 1; i < t.size(); ++i)
    if (t[i] - t[i - 1] < least)
      in.fail("/haptic/t", "steps by " + shown_number(t[i] - t[i - 1]) + " s at index " + std::to_string(i) +
                               ", under half the haptic period (" + shown_number(1 / haptic_hz) + " s at " +
                               shown_number(haptic_hz) + " Hz)");
}

/// A duration, a depth or a count is not negative (a NaN is counted with the file's non-finite
/// values, not refused): `what` names the quantity ("duration", "count"), `unit` its unit.
template <class T>
void not_negative(const Reader& in, const std::string& name, const std::vector<T>& v, const char* what, const char* unit = "") {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i] < 0)
      in.fail(name, std::string("holds a negative ") + what + " at index " + std::to_string(i) + " (" +
                        shown_number(static_cast<double>(v[i])) + (*unit ? std::string(" ") + unit : std::string()) + ")");
}

}  // namespace

long ReplayTrace::frame_ticks() const {
  long n = std::lround(haptic_hz / physical_hz);
  return n < 1 ? 1 : n;
}

ReplayTrace load_replay(const std::string& path) {
  QuietHdf5 quiet;
  Reader in(path);
  ReplayTrace tr;
  tr.path = path;
  // A device recording given where a replay output belongs: say so, not which attribute it lacks.
  if (!in.exists("/haptic") && in.exists("/trajectory"))
    throw InputError(path + ": a device recording (/trajectory), not a replay output (/haptic): replay it first "
                            "(ebh replay SCENE " + path + " -o OUT.h5)");
  // Another HDF5 file (a sweep's summary.h5, a recording of another program): what it lacks first.
  if (!in.exists("/haptic"))
    throw InputError(path + ": no /haptic group: not a replay output (ebh replay writes one; docs/FORMATS.md)");

  tr.haptic_hz = in.number_attr("haptic_hz");
  tr.physical_hz = in.number_attr("physical_hz");
  if (!(tr.haptic_hz > 0) || !std::isfinite(tr.haptic_hz)) in.fail_attr("haptic_hz", "must be a positive number");
  if (tr.haptic_hz > kMaxReplayHapticHz)
    in.fail_attr("haptic_hz", "is " + shown_number(tr.haptic_hz) + " Hz, above " + shown_number(kMaxReplayHapticHz) +
                                  " Hz, the highest haptic rate a scene takes (time.haptic_hz)");
  if (!(tr.physical_hz > 0) || !std::isfinite(tr.physical_hz))
    in.fail_attr("physical_hz", "must be a positive number");
  tr.mode = in.string_attr("mode");
  one_of(in, "mode", tr.mode, {"async", "lockstep", "realtime"});  // schedule/scheduler.hpp mode_name
  tr.scene = in.string_attr("scene");
  tr.recording = in.string_attr("recording");
  tr.backend = in.string_attr("backend");
  tr.version = in.string_attr("version");
  tr.contact = in.string_attr("contact");
  one_of(in, "contact", tr.contact, {"vertices", "surface"});  // the scene's contact (schedule/replay_output.cpp)
  if (in.has_attr("start")) {
    tr.start = in.number_attr("start");
    if (!(tr.start >= 0) || !std::isfinite(tr.start)) in.fail_attr("start", "must be a finite number >= 0 (s into the recording)");
  }

  tr.t = in.doubles("/haptic/t", -1);
  const long n = static_cast<long>(tr.t.size());
  if (n == 0) in.fail("/haptic/t", "is empty: the output holds no ticks");
  increasing(in, "/haptic/t", tr.t);
  // The replay's own count of its ticks: datasets cut to fewer (by another tool, or a copy) would
  // give metrics of part of the run, as if it were the whole.
  if (in.has_attr("ticks")) {
    const double ticks = in.number_attr("ticks");
    if (ticks != static_cast<double>(n)) {
      char why[200];
      std::snprintf(why, sizeof why, "has %ld ticks, but the output's ticks attribute says %.17g: the file was cut "
                    "short or edited since the replay", n, ticks);
      in.fail("/haptic/t", why);
    }
  }
  // The ticks' own spacing against the attribute every rate-dependent metric takes (the FFT's
  // bins, the frame boundaries, the budget): a file edited or written by another tool.
  const double from_t = n >= 2 ? static_cast<double>(n - 1) / (tr.t.back() - tr.t.front()) : 0.0;
  if (n >= 2 && std::fabs(from_t - tr.haptic_hz) > 0.01 * tr.haptic_hz) {
    char why[160];
    std::snprintf(why, sizeof why, "is %g Hz, but /haptic/t has %ld ticks over %g s (%g Hz)", tr.haptic_hz, n,
                  tr.t.back() - tr.t.front(), from_t);
    in.fail_attr("haptic_hz", why);
  }
  tick_spacing(in, tr.t, tr.haptic_hz);
  // The physical rate divides the haptic rate into whole ticks per step, at least 1 Hz (as a
  // replay has it: kMinReplayPhysicalHz): the frame-boundary metric reads its steps from the two.
  auto whole_ticks = [](double ratio) { return ratio >= 1 && std::fabs(ratio - std::round(ratio)) <= 1e-6 * ratio; };
  if (!(tr.physical_hz >= 1) || !whole_ticks(tr.haptic_hz / tr.physical_hz)) {
    // A haptic_hz within 1% of the ticks' rate passes the check above (999.9 for ticks 1 ms
    // apart): where the ticks' own rate is a whole number of ticks per physical step, it is
    // haptic_hz that is wrong, not physical_hz.
    if (n >= 2 && tr.physical_hz >= 1 && whole_ticks(from_t / tr.physical_hz)) {
      char why[300];
      std::snprintf(why, sizeof why, "is %g Hz, which physical_hz (%g Hz) divides into no whole number of ticks per "
                    "step, but /haptic/t's ticks come at %g Hz (%ld ticks over %g s), %.0f a step: this attribute, "
                    "not physical_hz, disagrees with the ticks",
                    tr.haptic_hz, tr.physical_hz, from_t, n, tr.t.back() - tr.t.front(),
                    std::round(from_t / tr.physical_hz));
      in.fail_attr("haptic_hz", why);
    }
    char why[200];
    std::snprintf(why, sizeof why, "is %g Hz: it must be at least 1 Hz and the haptic rate (%g Hz) over it a whole "
                  "number of ticks per step", tr.physical_hz, tr.haptic_hz);
    in.fail_attr("physical_hz", why);
  }
  tr.force = vec3s(in.doubles("/haptic/force", n, 3));
  tr.torque = vec3s(in.doubles("/haptic/torque", n, 3));
  tr.force_clamped = *in.read<std::uint8_t>("/haptic/force_clamped", n, 0, H5T_NATIVE_UINT8, false);
  tr.pose_physical = poses(in.doubles("/haptic/pose_physical", n, 7));
  tr.pose_virtual = poses(in.doubles("/haptic/pose_virtual", n, 7));
  rotations(in, "/haptic/pose_physical", tr.pose_physical);
  rotations(in, "/haptic/pose_virtual", tr.pose_virtual);
  tr.penetration = in.doubles("/haptic/penetration", n);
  tr.penetration_physical = in.optional_doubles("/haptic/penetration_physical", n);
  tr.contacts = *in.read<std::int32_t>("/haptic/contacts", n, 0, H5T_NATIVE_INT32, false);
  tr.active = in.optional_doubles("/haptic/active", n);
  tr.grasped = in.read<std::int32_t>("/haptic/grasped", n, 0, H5T_NATIVE_INT32, true).value_or(std::vector<std::int32_t>{});
  tr.jaw = in.optional_doubles("/haptic/jaw", n);
  tr.haptic_step_s = in.doubles("/timing/haptic_step_s", n);
  not_negative(in, "/timing/haptic_step_s", tr.haptic_step_s, "duration", "s");
  not_negative(in, "/haptic/penetration", tr.penetration, "depth", "m");
  not_negative(in, "/haptic/penetration_physical", tr.penetration_physical, "depth", "m");
  not_negative(in, "/haptic/contacts", tr.contacts, "count");
  not_negative(in, "/haptic/grasped", tr.grasped, "count");
  not_negative(in, "/haptic/active", tr.active, "count");

  tr.physical_t = in.optional_doubles("/physical/t", -1);
  increasing(in, "/physical/t", tr.physical_t);
  const long k = static_cast<long>(tr.physical_t.size());
  if (in.exists("/physical/t")) {
    tr.physical_iterations = in.optional_doubles("/physical/iterations", k);
    tr.physical_residual = in.optional_doubles("/physical/residual", k);
    tr.physical_inverted = in.optional_doubles("/physical/inverted", k);
    tr.physical_awake = in.optional_doubles("/physical/awake", k);
    tr.physical_slept = in.optional_doubles("/physical/slept", k);
    tr.physical_step_s = in.optional_doubles("/timing/physical_step_s", k);
    not_negative(in, "/timing/physical_step_s", tr.physical_step_s, "duration", "s");
    not_negative(in, "/physical/iterations", tr.physical_iterations, "count");
    not_negative(in, "/physical/residual", tr.physical_residual, "residual", "mesh weights");
    not_negative(in, "/physical/inverted", tr.physical_inverted, "count");
    not_negative(in, "/physical/awake", tr.physical_awake, "count");
    not_negative(in, "/physical/slept", tr.physical_slept, "count");
  }
  return tr;
}

}  // namespace ebh
