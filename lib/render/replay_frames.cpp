#include "render/replay_frames.hpp"

#include <hdf5.h>

#include <cmath>
#include <sstream>

#include "core/error.hpp"
#include "core/units.hpp"
#include "io/h5.hpp"

namespace ebh {
namespace {

std::string attr_or(const h5::File& f, const char* name) {
  if (!f.has_attr(name)) return {};
  try {
    return f.attr_string(name);
  } catch (const InputError&) {
    return {};  // present but not a string: treated as absent (only used to find the scene)
  }
}

/// Refuses a dataset whose `unit` attribute is not `si`, the unit `ebh replay` writes (or starts
/// it: "m, 1 (...)"): positions rewritten in mm by another program would be drawn 1000 times too
/// large and away from the tool, without a word. `si` is nullptr for indices and ratios. The rule
/// is `ebh metrics`' (core/units.hpp, si_unit_problem): no unit attribute is taken as SI.
void check_unit(const h5::Dataset& d, const char* si) {
  if (si == nullptr || !d.has_attr("unit")) return;
  if (const std::string why = si_unit_problem(d.attr_string("unit"), si); !why.empty())
    throw InputError(d.where() + ": " + why);
}

template <class T>
h5::Array<T> read_checked(const h5::File& f, const std::string& name, const std::vector<std::ptrdiff_t>& shape,
                          const char* si_unit) {
  if (!f.has(name)) throw InputError(f.file() + ": /" + name + ": missing");
  const h5::Dataset d = f.dataset(name);
  check_unit(d, si_unit);
  return d.read<T>(shape);
}

template <std::size_t K>
std::vector<std::array<int, K>> indices(const h5::Array<std::int32_t>& a, std::size_t vertices, const std::string& where) {
  std::vector<std::array<int, K>> out(a.rows());
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t k = 0; k < K; ++k) {
      const std::int32_t v = a.data[K * i + k];
      if (v < 0 || static_cast<std::size_t>(v) >= vertices)
        throw InputError(where + ": row " + std::to_string(i) + " refers to vertex " + std::to_string(v) + " of " +
                         std::to_string(vertices));
      out[i][k] = v;
    }
  return out;
}

ToolPose pose_of(const double* p) {
  ToolPose pose;
  pose.position = {p[0], p[1], p[2]};
  Quatd q{p[3], p[4], p[5], p[6]};
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  // A stored quaternion is unit up to float rounding; a zero or non-finite one (a blown-up run, a
  // damaged file) is kept as it is, no rotation: the render leaves such a pose out and says so
  // (drawn unrotated, the tool pointed where the run never had it).
  pose.orientation = (n > 0 && std::isfinite(n)) ? Quatd{q.w / n, q.x / n, q.y / n, q.z / n} : q;
  return pose;
}

}  // namespace

ReplayFrames open_replay_frames(const std::string& path) {
  const h5::File f = h5::File::open_read(path);
  ReplayFrames r;
  r.file = path;
  r.scene_name = attr_or(f, "scene");
  r.scene_file = attr_or(f, "scene_file");
  r.scene_yaml = attr_or(f, "scene_yaml");
  r.scene_file_sha256 = attr_or(f, "scene_file_sha256");
  r.tool_kind = attr_or(f, "tool");
  if (f.has_attr("overrides_list")) {
    std::istringstream in(attr_or(f, "overrides_list"));
    for (std::string line; std::getline(in, line);) r.overrides.push_back(line);
  } else {
    std::istringstream in(attr_or(f, "overrides"));
    for (std::string tok; in >> tok;) {
      if (tok.find('=') == std::string::npos && !r.overrides.empty()) r.overrides.back() += " " + tok;
      else r.overrides.push_back(tok);
    }
  }
  if (f.has_attr("virtual_s")) {
    try {
      r.replay_s = f.attr_double("virtual_s");
    } catch (const InputError&) {
      r.replay_s = 0.0;
    }
  }
  if (f.has_attr("shaft_radius")) {
    try {
      r.shaft_radius = f.attr_double("shaft_radius");
    } catch (const InputError&) {
      r.shaft_radius = 0.0;
    }
  }
  // A device recording given where a replay output belongs: said as `ebh metrics` says it, not
  // which group it lacks.
  if (!f.has("frames") && !f.has("haptic") && f.has("trajectory"))
    throw InputError(path + ": a device recording (/trajectory), not a replay output (/frames): replay it first, with "
                            "mesh snapshots (ebh replay SCENE " + path + " -o OUT.h5 --frames-hz N)");
  if (!f.has("frames"))
    throw InputError(path + ": /frames: no mesh snapshots in this file (replay with --frames-hz N)");

  const auto rest = read_checked<float>(f, "mesh/virtual_rest", {-1, 3}, "m");
  r.virtual_rest.resize(rest.rows());
  for (std::size_t i = 0; i < r.virtual_rest.size(); ++i)
    r.virtual_rest[i] = {rest.data[3 * i], rest.data[3 * i + 1], rest.data[3 * i + 2]};
  r.triangles = indices<3>(read_checked<std::int32_t>(f, "mesh/virtual_triangles", {-1, 3}, nullptr), r.virtual_rest.size(),
                           path + ": /mesh/virtual_triangles");
  // An empty surface would render the tools alone, as if the tissue were out of view.
  if (r.triangles.empty()) throw InputError(path + ": /mesh/virtual_triangles: no triangles: the virtual mesh has no surface to draw");
  const auto prest = read_checked<float>(f, "mesh/physical_rest", {-1, 3}, "m");
  r.physical_vertices = prest.rows();
  r.physical_tets = indices<4>(read_checked<std::int32_t>(f, "mesh/physical_tets", {-1, 4}, nullptr), r.physical_vertices,
                               path + ": /mesh/physical_tets").size();

  r.t = read_checked<double>(f, "frames/t", {-1}, "s").data;
  const std::size_t F = r.t.size();
  if (F == 0) throw InputError(path + ": /frames/t: no frames (the replay ended before the first snapshot)");
  // The frames are drawn in file order and titled with their time, which the time bar and a
  // video's rate read: a NaN or a step back is a file edited or written by another program (as
  // `ebh metrics` refuses a /haptic/t that does not increase).
  for (std::size_t i = 0; i < F; ++i) {
    if (!std::isfinite(r.t[i]))
      throw InputError(path + ": /frames/t: " + std::to_string(r.t[i]) + " at index " + std::to_string(i) +
                       ": expected finite times");
    if (i > 0 && !(r.t[i] > r.t[i - 1]))
      throw InputError(path + ": /frames/t: is not strictly increasing at index " + std::to_string(i));
  }
  const auto F_ = static_cast<std::ptrdiff_t>(F);
  r.jaw = read_checked<double>(f, "frames/jaw", {F_}, nullptr).data;
  const auto poses = read_checked<double>(f, "frames/tool_poses", {F_, 2, 7}, "m");
  r.poses.resize(F);
  for (std::size_t i = 0; i < F; ++i) r.poses[i] = {pose_of(&poses.data[14 * i]), pose_of(&poses.data[14 * i + 7])};
  const auto m = static_cast<std::ptrdiff_t>(r.virtual_rest.size()), n = static_cast<std::ptrdiff_t>(r.physical_vertices);
  // Shapes only (the positions themselves are read frame by frame).
  for (const auto& [name, rows] : {std::pair{"frames/virtual_positions", m}, std::pair{"frames/physical_positions", n}}) {
    if (!f.has(name)) throw InputError(path + ": /" + name + ": missing");
    const h5::Dataset d = f.dataset(name);
    check_unit(d, "m");
    d.require_stored(sizeof(float));  // read frame by frame below
    const auto s = d.shape();
    if (s.size() != 3 || s[0] != F || s[1] != static_cast<std::size_t>(rows) || s[2] != 3)
      throw InputError(path + ": /" + name + ": expected shape (" + std::to_string(F) + ", " + std::to_string(rows) +
                       ", 3) to match /frames/t and /mesh");
  }
  return r;
}

void ReplayFrames::read_virtual_positions(std::size_t f, std::vector<Vec3f>& out) const {
  const std::string where = file + ": /frames/virtual_positions";
  if (f >= frame_count()) throw InputError(where + ": frame " + std::to_string(f) + " out of range");
  h5::silence_errors();
  h5::Handle file_id(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!file_id.valid()) throw InputError(file + ": cannot open HDF5 file");
  h5::Handle ds(H5Dopen2(file_id.get(), "/frames/virtual_positions", H5P_DEFAULT));
  if (!ds.valid()) throw InputError(where + ": cannot open the dataset");
  h5::Handle space(H5Dget_space(ds.get()));
  static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f must be three packed floats");
  const hsize_t m = virtual_rest.size();
  const hsize_t start[3] = {f, 0, 0}, count[3] = {1, m, 3};
  h5::Handle mem(H5Screate_simple(3, count, nullptr));
  out.resize(m);
  if (!space.valid() || !mem.valid() ||
      H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
      H5Dread(ds.get(), H5T_NATIVE_FLOAT, mem.get(), space.get(), H5P_DEFAULT, out.data()) < 0)
    throw InputError(where + ": " + h5::read_failure(ds.get(), "frame " + std::to_string(f)));
}

}  // namespace ebh
