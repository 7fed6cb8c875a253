// Scene files: parse and validate every key (schema in scene.hpp), load and check the meshes,
// convert lengths to metres and place the meshes in the world once, resolve pinned regions, warn
// about sizes no organ or instrument has.
#include "scene/scene.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <sstream>
#include <tuple>
#include <map>
#include <set>
#include <system_error>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "core/partial_output.hpp"
#include "core/units.hpp"
#include "core/number_text.hpp"
#include "core/yaml_error.hpp"
#include "ebh/version.hpp"
#include "math/rotvec_input.hpp"
#include "mesh/boundary.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"

namespace ebh {
namespace {

namespace fs = std::filesystem;

/// Why `p` is not a file to read: "file not found", "is a folder, not a file", "is not a regular
/// file" (a device, a pipe) or "cannot be opened: " and the OS reason where it cannot be looked
/// up (a symbolic link that loops, a folder that may not be searched); empty when it is one.
std::string not_a_file(const fs::path& p) {
  std::error_code ec;
  const fs::file_status st = fs::status(p, ec);
  if (fs::is_regular_file(st)) return "";
  if (st.type() == fs::file_type::none) return "cannot be opened: " + ec.message();
  if (fs::is_directory(st)) return "is a folder, not a file";
  if (fs::exists(st)) return "is not a regular file (a device, pipe or socket)";
  if (fs::is_symlink(fs::symlink_status(p, ec)))
    return "is a link to " + fs::read_symlink(p, ec).string() + ", which does not exist";
  return "file not found";
}

/// `folder / p` with its `..` and `.` taken out, as messages and outputs name it, where that names the
/// same file: through a linked folder `..` is the link target's parent, which the OS follows and the
/// text does not (alias/sc/../meshes is real/meshes, not alias/meshes), so there the joined path is
/// kept as it is.
fs::path joined_path(const fs::path& folder, const fs::path& p) {
  const fs::path joined = folder / p, normal = joined.lexically_normal();
  std::error_code ec;
  if (fs::exists(joined, ec) && !fs::equivalent(joined, normal, ec)) return joined;
  return normal;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

/// The override that gave `key` its value: one of whose keys (override_keys: a map's leaves) is
/// `key`, holds it (a list or a value set whole: `gravity=[0,0,0]`) or lies under it (maps made
/// along its path: `a.b.c.d=1` for key a); the last such when several do. Null when the file gave it.
const std::string* override_giving(const std::vector<std::string>& overrides, const std::string& key) {
  auto under = [](const std::string& a, const std::string& b) {  // key a lies under key b
    return a.size() > b.size() && a.compare(0, b.size(), b) == 0 && (a[b.size()] == '.' || a[b.size()] == '[');
  };
  const std::string* found = nullptr;
  for (const std::string& o : overrides)
    for (const std::string& k : override_keys(o))
      if (k == key || under(key, k) || under(k, key)) found = &o;
  return found;
}

/// The folder the paths in `file` start from: its own, or where `file` is a link, that of the
/// file at the end of its links, where a file written through a link is (docs/FORMATS.md, "How
/// outputs are written": its paths are relative to the target's folder). A loop is the file's own
/// folder (its read fails first).
fs::path own_folder(const fs::path& file) {
  return fs::path(link_end(file.string()).value_or(file.string())).parent_path();
}

/// Parses and validates the YAML tree. Every check names the dotted key, and the override
/// ("key=value", applied to the tree before) that gave the key its value when one did.
class SpecReader {
 public:
  explicit SpecReader(const fs::path& file, const std::vector<std::string>& overrides = {},
                      bool mesh_files_must_exist = true)
      : file_(file), overrides_(overrides), mesh_files_must_exist_(mesh_files_must_exist) {}

  /// Throws "FILE: key 'KEY': WHAT", or an OverrideError when an override gave `key` its value, or
  /// else one of `also` (the other keys of a rule between keys; then that key is named).
  [[noreturn]] void fail(const std::string& key, const std::string& what,
                         std::initializer_list<const char*> also = {}) const {
    if (const std::string* o = override_of(key)) throw OverrideError(*o, "key '" + key + "': " + what);
    for (const char* k : also)
      if (const std::string* o = override_of(k)) throw OverrideError(*o, "key '" + std::string(k) + "': " + what);
    throw InputError(file_.string() + ": key '" + key + "': " + what);
  }

  /// override_giving over this reader's overrides.
  const std::string* override_of(const std::string& key) const { return override_giving(overrides_, key); }

  /// The entries of a map node, checked (yaml_map_entries: text keys among `allowed`, each once).
  std::map<std::string, YAML::Node> entries(const YAML::Node& node, const std::string& key,
                                            const std::vector<std::string>& allowed) const {
    std::map<std::string, YAML::Node> out;
    // yaml-cpp hands out nodes that share the tree: keep them as they are
    for (auto& [name, value] : yaml_map_entries(node, key, allowed, [&](const YAML::Node&, const std::string& k,
                                                                        const std::string& what) { fail(k, what); }))
      out.emplace(name, value);
    return out;
  }

  double number(const YAML::Node& n, const std::string& key, const char* expected = "a number") const {
    if (!n.IsScalar()) fail(key, std::string("expected ") + expected + ", got " + yaml_shown(n));
    const std::string& s = n.Scalar();
    const char* b = s.data();
    const char* e = s.data() + s.size();
    if (b != e && *b == '+') ++b;
    double v = 0;
    auto [p, ec] = std::from_chars(b, e, v);
    if (ec != std::errc() || p != e || b == e || !std::isfinite(v))
      fail(key, std::string("expected ") + expected + ", got " + yaml_shown(n));
    return v;
  }
  double positive(const YAML::Node& n, const std::string& key) const {
    const double v = number(n, key, "a positive number");
    if (!(v > 0)) fail(key, "expected a positive number, got " + yaml_shown(n));
    return v;
  }
  double non_negative(const YAML::Node& n, const std::string& key) const {
    const double v = number(n, key, "a number >= 0");
    if (!(v >= 0)) fail(key, "expected a number >= 0, got " + yaml_shown(n));
    return v;
  }
  /// A number in the interval (lo, hi) / [lo, hi], open or closed at each end as given.
  /// `also` (e.g. "auto or ") names what else the key takes, in the message.
  double in_range(const YAML::Node& n, const std::string& key, double lo, bool lo_closed, double hi, bool hi_closed,
                  const char* also = "") const {
    char range[96];
    std::snprintf(range, sizeof range, "%sa number in %c%g, %g%c", also, lo_closed ? '[' : '(', lo, hi,
                  hi_closed ? ']' : ')');
    const double v = number(n, key, range);
    const bool ok = (lo_closed ? v >= lo : v > lo) && (hi_closed ? v <= hi : v < hi);
    if (!ok) fail(key, std::string("expected ") + range + ", got " + yaml_shown(n));
    return v;
  }
  /// A whole number in [lo, hi]; `word` (when given) is also accepted and gives `word_value`.
  int integer(const YAML::Node& n, const std::string& key, int lo, int hi, const char* word = nullptr,
              int word_value = 0) const {
    if (word && n.IsScalar() && n.Scalar() == word) return word_value;
    const std::string expected = (word ? std::string(word) + " or " : std::string()) + "a whole number in [" +
                                 std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!n.IsScalar()) fail(key, "expected " + expected + ", got " + yaml_shown(n));
    const std::string& s = n.Scalar();
    long long v = 0;
    auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size() || s.empty() || v < lo || v > hi)
      fail(key, "expected " + expected + ", got " + yaml_shown(n));
    return static_cast<int>(v);
  }
  bool boolean(const YAML::Node& n, const std::string& key) const {
    if (n.IsScalar()) {
      const std::string& s = n.Scalar();
      if (s == "true" || s == "True" || s == "TRUE") return true;
      if (s == "false" || s == "False" || s == "FALSE") return false;
    }
    fail(key, "expected true or false, got " + yaml_shown(n));
  }
  std::string text(const YAML::Node& n, const std::string& key, bool allow_empty = true) const {
    if (!n.IsScalar()) fail(key, "expected text, got " + yaml_shown(n));
    if (!allow_empty && n.Scalar().empty()) fail(key, "expected non-empty text");
    // A NUL ("\0" in a quoted string) would end a file name where the system reads it: another file.
    if (n.Scalar().find('\0') != std::string::npos) fail(key, "contains a NUL byte (\\0)");
    return n.Scalar();
  }
  /// One of `names`; returns its index.
  int choice(const YAML::Node& n, const std::string& key, const std::vector<std::string>& names) const {
    if (n.IsScalar()) {
      auto it = std::find(names.begin(), names.end(), n.Scalar());
      if (it != names.end()) return static_cast<int>(it - names.begin());
    }
    fail(key, "expected one of " + join(names) + ", got " + yaml_shown(n));
  }
  Vec3d vec3(const YAML::Node& n, const std::string& key) const {
    if (!n.IsSequence() || n.size() != 3) fail(key, "expected a list of 3 numbers [x, y, z], got " + yaml_shown(n));
    Vec3d v;
    for (int i = 0; i < 3; ++i) v[i] = number(n[static_cast<std::size_t>(i)], key + "[" + std::to_string(i) + "]");
    return v;
  }
  Vec3d nonzero_vec3(const YAML::Node& n, const std::string& key) const {
    const Vec3d v = vec3(n, key);
    if (!(norm(v) > 0)) fail(key, "expected a non-zero vector");
    return v;
  }
  /// A length in the given unit (metres per unit; default the scene's `unit`), returned in metres.
  double length(const YAML::Node& n, const std::string& key) const { return length(n, key, unit_); }
  /// A positive length in `unit` metres, in metres: one so small that it is 0 in metres (5e-324 mm)
  /// is refused as what it is, not passed on as 0.
  double length(const YAML::Node& n, const std::string& key, double unit) const {
    const double v = positive(n, key), metres = v * unit;
    if (!(metres >= std::numeric_limits<double>::min()) || !std::isfinite(metres))
      fail(key, yaml_shown(n) + " is " + shown_number(metres) + " m: expected a length a double carries, " +
                    shown_number(std::numeric_limits<double>::min()) + " .. " +
                    shown_number(std::numeric_limits<double>::max()) + " m");
    return metres;
  }
  /// A length unit key (kLengthUnitNames): its metres per unit and name.
  std::pair<double, std::string> length_unit(const YAML::Node& n, const std::string& key) const {
    static const std::vector<std::string> names(kLengthUnitNames.begin(), kLengthUnitNames.end());
    const std::string name = names[choice(n, key, names)];
    return {*length_unit_metres(name), name};
  }

  const YAML::Node& required(const std::map<std::string, YAML::Node>& e, const std::string& name,
                             const std::string& key) const {
    auto it = e.find(name);
    if (it == e.end()) fail(key.empty() ? name : key + "." + name, "missing (required)");
    return it->second;
  }

  /// A mesh path, relative to the scene file, that must exist.
  fs::path mesh_path(const YAML::Node& n, const std::string& key) const {
    fs::path p = text(n, key, false);
    if (p.is_relative()) p = joined_path(own_folder(file_), p);
    if (!mesh_files_must_exist_) return p;
    if (const std::string why = not_a_file(p); !why.empty())
      fail(key, why == "file not found" ? why + ": " + p.string() : p.string() + " " + why);
    return p;
  }

  SceneSpec read(const YAML::Node& root) {
    SceneSpec s;
    s.file = file_;
    s.overrides = overrides_;
    s.name = file_.stem().string();
    const auto top = entries(root, "", {"name", "description", "unit", "mesh", "material", "stiffness", "gravity",
                                        "damping", "pinned", "tool", "time", "solver", "contact", "camera", "stages"});
    if (auto it = top.find("unit"); it != top.end()) {
      std::tie(s.unit, s.unit_name) = length_unit(it->second, "unit");
      unit_ = s.unit;
    }
    // mesh.unit and tool.unit default to it
    s.mesh_unit = s.tool.unit = s.unit;
    s.mesh_unit_name = s.tool.unit_name = s.unit_name;
    for (const auto& [name, n] : top) {
      if (name == "name") s.name = text(n, "name", false);
      else if (name == "description") s.description = text(n, "description");
      else if (name == "mesh") read_mesh(n, s);
      else if (name == "material") {
        const auto e = entries(n, "material", {"density"});
        if (auto d = e.find("density"); d != e.end()) s.density = positive(d->second, "material.density");
      } else if (name == "stiffness") {
        read_stiffness(n, s.stiffness);
        if (n.IsMap() && n["regions"]) read_stiffness_regions(n["regions"], s);
      }
      else if (name == "gravity") s.gravity = vec3(n, "gravity");
      else if (name == "damping") s.damping = in_range(n, "damping", 0, true, 1, false);
      else if (name == "pinned") read_pinned(n, s);
      else if (name == "tool") read_tool(n, s.tool);
      else if (name == "time") read_time(n, s);
      else if (name == "solver") read_solver(n, s.solver);
      else if (name == "camera") read_camera(n, s.camera);
      else if (name == "contact")
        s.contact = choice(n, "contact", {"vertices", "surface"}) == 0 ? ContactModel::Vertices : ContactModel::Surface;
      else if (name == "stages") {
        const auto e = entries(n, "stages", {"grasp", "frames", "settle"});
        if (auto g = e.find("grasp"); g != e.end()) s.stages.grasp = boolean(g->second, "stages.grasp");
        if (auto f = e.find("frames"); f != e.end()) s.stages.frames = boolean(f->second, "stages.frames");
        if (auto f = e.find("settle"); f != e.end()) s.stages.settle = boolean(f->second, "stages.settle");
      }
    }
    if (!top.count("mesh")) fail("mesh", "missing (required: mesh.physical names the physical mesh)");
    if (s.tool.forceps.release() < s.tool.forceps.grasp_threshold)
      fail("tool.forceps.release_threshold", "expected at least tool.forceps.grasp_threshold (" +
                                                 shown_number(s.tool.forceps.grasp_threshold) + "), got " +
                                                 shown_number(s.tool.forceps.release()),
           {"tool.forceps.grasp_threshold"});
    if (s.tool.newton_calls > s.solver.virtual_iterations)
      fail("tool.newton_calls", "expected all or at most solver.virtual_iterations (" +
                                    std::to_string(s.solver.virtual_iterations) + "), got " +
                                    std::to_string(s.tool.newton_calls), {"solver.virtual_iterations"});
    if (s.solver.physical_region > 0 && s.solver.method == SolverSpec::Method::Direct)
      fail("solver.physical_region",
           "the direct method solves for every vertex at once; use chebyshev or jacobi, or physical_region 0",
           {"solver.method"});
    check_physical_limits(s);
    return s;
  }

  /// Values no tissue has and double arithmetic cannot carry through a step (h^2 k, M g over
  /// millions of steps) are errors; values merely unusual for soft tissue are warnings
  /// (physical_warnings, at load_scene).

  void check_physical_limits(const SceneSpec& s) const {
    constexpr double kMaxGravity = 1e3;     // m/s^2, 100 g
    constexpr double kMaxStiffness = 1e12;  // Pa or N/m: five times steel's Young's modulus
    constexpr double kMaxDensity = 1e5;     // kg/m^3: five times osmium
    if (!(norm(s.gravity) <= kMaxGravity))
      fail("gravity", "|g| = " + shown_number(norm(s.gravity)) + " m/s^2 is beyond 100 g (1000 m/s^2)");
    const std::pair<const char*, double> k[] = {{"k_vol", s.stiffness.k_vol}, {"k_s", s.stiffness.k_s},
                                                {"k_svc", s.stiffness.k_svc}, {"k_con", s.stiffness.k_con},
                                                {"k_vcs", s.stiffness.k_vcs}, {"k_vct", s.stiffness.k_vct},
                                                {"k_det", s.stiffness.k_det}};
    for (const auto& [name, value] : k)
      if (value > kMaxStiffness)
        fail(std::string("stiffness.") + name, shown_number(value) + " is beyond 1e12 (Pa, N/m or N m/rad): no tissue or tool is that stiff");
    for (std::size_t i = 0; i < s.stiffness_regions.size(); ++i)
      if (s.stiffness_regions[i].k_vol > kMaxStiffness)
        fail("stiffness.regions[" + std::to_string(i) + "].k_vol",
             shown_number(s.stiffness_regions[i].k_vol) + " is beyond 1e12 (Pa): no tissue is that stiff");
    if (s.density > kMaxDensity) fail("material.density", shown_number(s.density) + " kg/m^3 is beyond 1e5");
  }

 private:
  void read_mesh(const YAML::Node& n, SceneSpec& s) const {
    const auto e = entries(n, "mesh", {"physical", "virtual", "virtual_refine", "min_part_tets", "unit", "transform"});
    if (auto u = e.find("unit"); u != e.end()) std::tie(s.mesh_unit, s.mesh_unit_name) = length_unit(u->second, "mesh.unit");
    if (auto t = e.find("transform"); t != e.end()) {
      const auto f = entries(t->second, "mesh.transform", {"scale", "rotvec_deg", "translate"});
      MeshTransform& x = s.mesh_transform;
      if (auto it = f.find("scale"); it != f.end()) x.scale = positive(it->second, "mesh.transform.scale");
      if (auto it = f.find("rotvec_deg"); it != f.end()) {
        x.rotvec_deg = vec3(it->second, "mesh.transform.rotvec_deg");
        if (const std::string why = rotvec_deg_problem(x.rotvec_deg); !why.empty()) fail("mesh.transform.rotvec_deg", why);
      }
      if (auto it = f.find("translate"); it != f.end())
        x.translate = vec3(it->second, "mesh.transform.translate") * s.mesh_unit;
    }
    s.physical_mesh = mesh_path(required(e, "physical", "mesh"), "mesh.physical");
    if (auto v = e.find("virtual"); v != e.end()) {
      const std::string t = text(v->second, "mesh.virtual", false);
      if (t != "boundary") {
        if (const std::string ext = lower_extension(t);
            ext != ".obj" && ext != ".stl" && ext != ".ply" && ext != ".vtk" && ext != ".vtp")
          fail("mesh.virtual", "expected 'boundary' or a surface file (.obj, .stl, .ply, .vtk, .vtp), got " + yaml_shown(v->second));
        s.virtual_mesh = mesh_path(v->second, "mesh.virtual");
      }
    }
    if (auto r = e.find("virtual_refine"); r != e.end()) s.virtual_refine = integer(r->second, "mesh.virtual_refine", 0, 1);
    if (auto m = e.find("min_part_tets"); m != e.end())
      s.min_part_tets = integer(m->second, "mesh.min_part_tets", 0, std::numeric_limits<int>::max());
  }

  void read_stiffness(const YAML::Node& n, Stiffness& k) const {
    const auto e = entries(n, "stiffness", {"k_vol", "k_s", "k_svc", "k_con", "k_vcs", "k_vct", "k_det", "regions"});
    const std::pair<const char*, double*> fields[] = {{"k_vol", &k.k_vol}, {"k_s", &k.k_s},     {"k_svc", &k.k_svc},
                                                      {"k_con", &k.k_con}, {"k_vcs", &k.k_vcs}, {"k_vct", &k.k_vct}};
    for (const auto& [name, dst] : fields)
      if (auto it = e.find(name); it != e.end()) *dst = positive(it->second, std::string("stiffness.") + name);
    if (auto it = e.find("k_det"); it != e.end()) k.k_det = non_negative(it->second, "stiffness.k_det");
  }

  void read_pinned(const YAML::Node& n, SceneSpec& s) const {
    if (n.IsNull()) return;  // "pinned:" with nothing: no region
    if (!n.IsSequence()) fail("pinned", "expected a list of regions, got " + yaml_shown(n));
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string key = "pinned[" + std::to_string(i) + "]";
      const auto e = entries(n[i], key, {"group", "box", "sphere", "halfspace"});
      if (e.size() != 1) fail(key, "expected exactly one of group, box, sphere, halfspace");
      s.pinned.push_back(region(*e.begin(), key));
    }
  }

  void read_stiffness_regions(const YAML::Node& n, SceneSpec& s) const {
    if (n.IsNull()) return;
    if (!n.IsSequence()) fail("stiffness.regions", "expected a list of parts (a region and its k_vol), got " + yaml_shown(n));
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string key = "stiffness.regions[" + std::to_string(i) + "]";
      auto e = entries(n[i], key, {"group", "box", "sphere", "halfspace", "k_vol"});
      StiffnessRegion m;
      const auto k = e.find("k_vol");
      if (k == e.end()) fail(key, "expected k_vol (Pa), the part's stiffness");
      m.k_vol = positive(k->second, key + ".k_vol");
      e.erase(k);
      if (e.size() != 1) fail(key, "expected exactly one of group, box, sphere, halfspace beside k_vol");
      m.region = region(*e.begin(), key);
      s.stiffness_regions.push_back(m);
    }
  }

  /// One region of `key` (pinned[i], stiffness.regions[i]): its kind and its value.
  PinRegion region(const std::pair<const std::string, YAML::Node>& entry, const std::string& key) const {
    const auto& [kind, v] = entry;
    const std::string k = key + "." + kind;
    PinRegion r;
    if (kind == "group") {
      r.kind = PinRegion::Kind::Group;
      r.group = text(v, k, false);
    } else if (kind == "box") {
      r.kind = PinRegion::Kind::Box;
      const auto b = entries(v, k, {"min", "max"});
      r.a = vec3(required(b, "min", k), k + ".min") * unit_;
      r.b = vec3(required(b, "max", k), k + ".max") * unit_;
      if (!(r.a.x <= r.b.x && r.a.y <= r.b.y && r.a.z <= r.b.z)) fail(k + ".max", "expected max >= min in every coordinate");
    } else if (kind == "sphere") {
      r.kind = PinRegion::Kind::Sphere;
      const auto b = entries(v, k, {"center", "radius"});
      r.a = vec3(required(b, "center", k), k + ".center") * unit_;
      r.b = {length(required(b, "radius", k), k + ".radius"), 0, 0};
    } else {
      r.kind = PinRegion::Kind::Halfspace;
      const auto b = entries(v, k, {"point", "normal"});
      r.a = vec3(required(b, "point", k), k + ".point") * unit_;
      r.b = normalized(nonzero_vec3(required(b, "normal", k), k + ".normal"));
    }
    return r;
  }

  void read_tool(const YAML::Node& n, ToolSpec& t) const {
    const auto e = entries(n, "tool", {"unit", "kind", "shaft_radius", "shaft_length", "hook", "forceps", "force_limit",
                                       "torque_limit", "newton_iterations", "newton_calls", "max_step", "max_step_rotation_deg",
                                       "stabilization"});
    if (auto u = e.find("unit"); u != e.end()) std::tie(t.unit, t.unit_name) = length_unit(u->second, "tool.unit");
    const double unit = t.unit;
    for (const auto& [name, v] : e) {
      const std::string k = "tool." + name;
      if (name == "unit") continue;
      else if (name == "kind") t.kind = choice(v, k, {"hook", "forceps"}) == 0 ? ToolSpec::Kind::Hook : ToolSpec::Kind::Forceps;
      else if (name == "shaft_radius") t.shaft_radius = length(v, k, unit);
      else if (name == "shaft_length") t.shaft_length = length(v, k, unit);
      else if (name == "force_limit") t.force_limit = positive(v, k);
      else if (name == "torque_limit") t.torque_limit = non_negative(v, k);
      else if (name == "newton_iterations") t.newton_iterations = integer(v, k, 1, 100);
      else if (name == "newton_calls") t.newton_calls = integer(v, k, 1, 100000, "all", 0);
      else if (name == "max_step") t.max_step = length(v, k, unit);
      else if (name == "max_step_rotation_deg") t.max_step_rotation_deg = in_range(v, k, 0, false, 180, true);
      else if (name == "stabilization") {
        const auto h = entries(v, k, {"translation", "rotation"});
        if (auto it = h.find("translation"); it != h.end())
          t.stabilization_translation = non_negative(it->second, k + ".translation");
        if (auto it = h.find("rotation"); it != h.end())
          t.stabilization_rotation = non_negative(it->second, k + ".rotation");
      } else if (name == "hook") {
        const auto h = entries(v, k, {"tip_length", "tip_radius"});
        if (auto it = h.find("tip_length"); it != h.end()) t.hook.tip_length = length(it->second, k + ".tip_length", unit);
        if (auto it = h.find("tip_radius"); it != h.end()) t.hook.tip_radius = length(it->second, k + ".tip_radius", unit);
      } else if (name == "forceps") {
        const auto f = entries(v, k, {"jaw_length", "jaw_width", "jaw_thickness", "jaw_max_angle_deg", "grasp_threshold",
                                      "release_threshold",
                                      "soft_margin", "eta"});
        for (const auto& [fname, fv] : f) {
          const std::string fk = k + "." + fname;
          if (fname == "jaw_length") t.forceps.jaw_length = length(fv, fk, unit);
          else if (fname == "jaw_width") t.forceps.jaw_width = length(fv, fk, unit);
          else if (fname == "jaw_thickness") t.forceps.jaw_thickness = length(fv, fk, unit);
          else if (fname == "jaw_max_angle_deg") t.forceps.jaw_max_angle_deg = in_range(fv, fk, 0, false, kMaxJawAngleDeg, false);
          else if (fname == "grasp_threshold") t.forceps.grasp_threshold = in_range(fv, fk, 0, false, 1, true);  // jaw < 0 never: no grasp
          else if (fname == "release_threshold") t.forceps.release_threshold = in_range(fv, fk, 0, false, 1, true);
          else if (fname == "soft_margin") t.forceps.soft_margin = length(fv, fk, unit);
          else if (fname == "eta") t.forceps.eta = positive(fv, fk);
        }
      }
    }
    const char* other = t.kind == ToolSpec::Kind::Hook ? "forceps" : "hook";
    if (auto it = e.find(other); it != e.end()) t.other_kind_keys = it->second.IsMap() && it->second.size() > 0;
  }

  void read_time(const YAML::Node& n, SceneSpec& s) const {
    const auto e = entries(n, "time", {"haptic_hz", "physical_hz", "interpolate_physical"});
    if (auto it = e.find("interpolate_physical"); it != e.end())
      s.interpolate_physical = boolean(it->second, "time.interpolate_physical");
    if (auto it = e.find("haptic_hz"); it != e.end())
      s.haptic_hz = in_range(it->second, "time.haptic_hz", kMinReplayHapticHz, true, kMaxHapticHz, true);
    if (auto it = e.find("physical_hz"); it != e.end())
      s.physical_hz = in_range(it->second, "time.physical_hz", kMinReplayPhysicalHz, true, kMaxHapticHz, true);
    // physical step k starts at tick k N (schedule/scheduler.hpp): N = haptic_hz / physical_hz must be whole
    const double ratio = s.haptic_hz / s.physical_hz;
    if (!whole_ticks_per_step(s.haptic_hz, s.physical_hz))
      fail("time.physical_hz", "haptic_hz / physical_hz must be a whole number >= 1, got " + shown_number(s.haptic_hz) +
                                   " / " + shown_number(s.physical_hz) + " = " + shortest_text(ratio),
           {"time.haptic_hz"});
  }

  void read_solver(const YAML::Node& n, SolverSpec& sv) const {
    const auto e = entries(n, "solver", {"method", "diagonal", "physical_iterations", "virtual_iterations", "chebyshev_rho",
                                             "physical_tolerance", "physical_max_iterations", "recovery",
                                             "recovery_residual", "active_region", "physical_region", "sleep",
                                             "virtual_damping"});
    if (auto it = e.find("method"); it != e.end()) {
      const int m = choice(it->second, "solver.method", {"jacobi", "chebyshev", "direct"});
      sv.method = m == 0 ? SolverSpec::Method::Jacobi : m == 1 ? SolverSpec::Method::Chebyshev : SolverSpec::Method::Direct;
    }
    if (auto it = e.find("diagonal"); it != e.end())
      sv.diagonal = choice(it->second, "solver.diagonal", {"bounded", "plain"}) == 0 ? SolverSpec::Diagonal::Bounded
                                                                                    : SolverSpec::Diagonal::Plain;
    if (auto it = e.find("physical_iterations"); it != e.end())
      sv.physical_iterations = integer(it->second, "solver.physical_iterations", 1, 100000);
    if (auto it = e.find("virtual_iterations"); it != e.end())
      sv.virtual_iterations = integer(it->second, "solver.virtual_iterations", 1, 100000);
    if (auto it = e.find("chebyshev_rho"); it != e.end()) {
      sv.chebyshev_rho_auto = it->second.IsScalar() && it->second.Scalar() == "auto";
      if (!sv.chebyshev_rho_auto) sv.chebyshev_rho = in_range(it->second, "solver.chebyshev_rho", 0, false, 1, false, "auto or ");
    }
    if (auto it = e.find("physical_tolerance"); it != e.end())
      sv.physical_tolerance = in_range(it->second, "solver.physical_tolerance", 0, true, 1e4, true);
    if (auto it = e.find("physical_max_iterations"); it != e.end())
      sv.physical_max_iterations = integer(it->second, "solver.physical_max_iterations", 1, 100000);
    if (auto it = e.find("recovery"); it != e.end())
      sv.recovery = choice(it->second, "solver.recovery", {"direct", "none"}) == 0 ? SolverSpec::Recovery::Direct
                                                                                 : SolverSpec::Recovery::None;
    if (auto it = e.find("recovery_residual"); it != e.end())
      sv.recovery_residual = in_range(it->second, "solver.recovery_residual", 0, false, 1e4, true);
    if (auto it = e.find("active_region"); it != e.end()) {
      sv.active_region = non_negative(it->second, "solver.active_region") * unit_;
      sv.active_region_given = true;
    }
    if (auto it = e.find("physical_region"); it != e.end()) {
      sv.physical_region = non_negative(it->second, "solver.physical_region") * unit_;
    }
    if (auto it = e.find("sleep"); it != e.end()) {
      sv.sleep = non_negative(it->second, "solver.sleep") * unit_;
      sv.sleep_given = true;
    }
    if (auto it = e.find("virtual_damping"); it != e.end())
      sv.virtual_damping = in_range(it->second, "solver.virtual_damping", 0, true, 1e6, true);
  }

  void read_camera(const YAML::Node& n, Camera& c) const {
    const auto e = entries(n, "camera", {"eye", "target", "up", "fov_deg"});
    if (auto it = e.find("eye"); it != e.end()) c.eye = vec3(it->second, "camera.eye") * unit_;
    if (auto it = e.find("target"); it != e.end()) c.target = vec3(it->second, "camera.target") * unit_;
    if (auto it = e.find("up"); it != e.end()) c.up = normalized(nonzero_vec3(it->second, "camera.up"));
    if (auto it = e.find("fov_deg"); it != e.end()) c.fov_deg = in_range(it->second, "camera.fov_deg", 0, false, 180, false);
    if (!(norm(c.eye - c.target) > 0))
      fail("camera.target", "camera.eye and camera.target are the same point: the camera looks nowhere", {"camera.eye"});
  }

  fs::path file_;
  std::vector<std::string> overrides_;
  bool mesh_files_must_exist_ = true;  ///< false: a replay's stored scene, whose meshes the output holds
  double unit_ = 1.0;
};

}  // namespace

std::string region_name(PinRegion::Kind k) {
  switch (k) {
    case PinRegion::Kind::Group: return "group";
    case PinRegion::Kind::Box: return "box";
    case PinRegion::Kind::Sphere: return "sphere";
    case PinRegion::Kind::Halfspace: return "halfspace";
  }
  return "region";
}

namespace {

/// For each pinned region of `spec`, why a group of `raw` (the mesh as read) will pin nothing once
/// the vertices no tet uses are removed (remove_unreferenced_vertices drops the triangles that use
/// one): "its triangles use node 77, which belongs to no tet, and were removed with it (MESH:
/// removed 1 vertices used by no tet)"; "" for the others. Read before the removal, said in the
/// error of a group that then pins nothing (the removal's warning is printed only after loading).
std::vector<std::string> groups_removed_with_unused_vertices(const TetMesh& raw, const SceneSpec& spec) {
  std::vector<std::string> why(spec.pinned.size());
  const int nv = static_cast<int>(raw.vertices.size());
  std::vector<char> used(raw.vertices.size(), 0);
  for (const Tet& t : raw.tets)
    for (int v : t)
      if (v >= 0 && v < nv) used[v] = 1;
  const auto removed = std::count(used.begin(), used.end(), 0);
  if (removed == 0) return why;
  for (std::size_t i = 0; i < spec.pinned.size(); ++i) {
    const PinRegion& r = spec.pinned[i];
    if (r.kind != PinRegion::Kind::Group) continue;
    const std::set<int> tags = group_tags(raw, r.group);
    std::set<int> unused;
    for (int f : elements_in_groups(raw.triangle_group, raw.triangle_more_groups, raw.triangles.size(), tags))
      for (int v : raw.triangles[f])
        if (v >= 0 && v < nv && !used[v]) unused.insert(v);
    if (unused.empty()) continue;
    std::string nodes;
    int shown = 0;
    for (int v : unused) {
      if (++shown > 5) {
        nodes += ", ...";
        break;
      }
      nodes += (nodes.empty() ? "" : ", ") + std::to_string(static_cast<std::size_t>(v) < raw.file_node_ids.size()
                                                                ? raw.file_node_ids[v]
                                                                : static_cast<long long>(v));
    }
    why[i] = "its triangles use node" + std::string(unused.size() > 1 ? "s " : " ") + nodes + ", which belong" +
             (unused.size() > 1 ? "" : "s") + " to no tet, and were removed with " + (unused.size() > 1 ? "them" : "it") +
             " (" + spec.physical_mesh.string() + ": removed " + std::to_string(removed) + " vertices used by no tet)";
  }
  return why;
}

/// "unknown group 'NAME' (known groups in FILE: ...)" and where the mesh's format keeps its groups,
/// when the physical mesh has no group `group`; else "".
std::string unknown_group(const Scene& scene, const std::string& group) {
  const std::vector<std::string> known = known_group_names(scene.physical);
  if (std::find(known.begin(), known.end(), group) != known.end()) return "";
  return "unknown group '" + group + "' (known groups in " + scene.spec.physical_mesh.string() + ": " +
         known_groups_text(scene.physical) + ")" + lower_dimension_group_note(scene.physical, group) +
         file_groups_note(scene.spec.physical_mesh);
}

/// The vertices a region pins, or an InputError naming the scene file and the region's key when the
/// region is a group the mesh does not have or pins nothing (`why_none`, when given, says why).
std::vector<int> pinned_by(const Scene& scene, std::size_t index, const std::string& why_none) {
  const PinRegion& r = scene.spec.pinned[index];
  const std::string key = "pinned[" + std::to_string(index) + "]." + region_name(r.kind);
  std::vector<int> v = region_vertices(scene.physical, r);
  if (!v.empty()) return v;
  if (r.kind == PinRegion::Kind::Group)
    if (const std::string unknown = unknown_group(scene, r.group); !unknown.empty())
      throw InputError(value_source(scene.spec, key) + ": key '" + key + "': " + unknown);
  // A region the file gives can miss a mesh that an override moved or replaced: say which.
  std::string moved;
  for (const char* k : {"mesh.physical", "mesh.transform", "mesh.unit", "unit"})
    if (const std::string* o = override_giving(scene.spec.overrides, k); o && moved.empty())
      moved = " (the mesh as " + OverrideError::set_option_shown(*o) + " gives it)";
  // A group the file names that no element is in: an MSH 4.1 file assigns groups through $Entities.
  const std::string empty_group = r.kind == PinRegion::Kind::Group ? ": " + group_without_elements_note(scene.physical) : "";
  throw InputError(value_source(scene.spec, key) + ": key '" + key + "': the " + region_name(r.kind) +
                   (r.kind == PinRegion::Kind::Group ? " '" + r.group + "'" : "") + " pins no vertex of the physical mesh" +
                   moved + (!why_none.empty() ? ": " + why_none : empty_group));
}

/// Each tet's k_vol: stiffness.k_vol, then each of stiffness.regions over its tets in turn. A region
/// that holds no tet (a group the mesh does not have, or no tet's centroid in it) is an InputError
/// naming its key, as a pinned region that pins nothing is.
std::vector<double> tet_stiffness(const Scene& scene) {
  std::vector<double> k(scene.physical.tets.size(), scene.spec.stiffness.k_vol);
  for (std::size_t i = 0; i < scene.spec.stiffness_regions.size(); ++i) {
    const StiffnessRegion& m = scene.spec.stiffness_regions[i];
    const std::vector<int> tets = region_tets(scene.physical, m.region);
    if (tets.empty()) {
      const std::string key = "stiffness.regions[" + std::to_string(i) + "]." + region_name(m.region.kind);
      const bool group = m.region.kind == PinRegion::Kind::Group;
      const std::string unknown = group ? unknown_group(scene, m.region.group) : "";
      throw InputError(value_source(scene.spec, key) + ": key '" + key + "': " +
                       (!unknown.empty() ? unknown
                        : group          ? "the group '" + m.region.group + "' holds no tet of the physical mesh (a surface "
                                           "group: a part's stiffness is its tets')"
                                         : "no tet of the physical mesh has its centroid in the " + region_name(m.region.kind)));
    }
    for (int t : tets) k[static_cast<std::size_t>(t)] = m.k_vol;
  }
  return k;
}

/// Warnings for sizes no organ or laparoscopic instrument has: the physical mesh's bounding-box
/// diagonal outside 1 mm .. 2 m, a tool size that meets tissue larger than that diagonal or below
/// a thousandth of it, a shaft radius outside 0.5 .. 10 mm or a shaft length outside 50 mm .. 1 m.
/// Each is the usual sign of a length in the wrong unit and names the keys to check.
std::vector<std::string> size_warnings(const SceneSpec& s, const TetMesh& mesh) {
  std::vector<std::string> out;
  if (mesh.vertices.empty()) return out;
  const double diagonal = bounding_box(mesh.vertices).diagonal();
  const std::string file = s.file.string() + ": ";
  auto in_unit = [](double metres, double unit, const std::string& name) {
    return shown_number(metres / unit) + " " + name;
  };
  if (diagonal < kMeshDiagonalMin || diagonal > kMeshDiagonalMax)
    out.push_back(file + "the physical mesh's bounding-box diagonal is " + in_unit(diagonal, s.mesh_unit, s.mesh_unit_name) +
                  (s.mesh_unit == 1.0 ? std::string() : " (" + shown_number(diagonal) + " m)") +
                  ": organs are 1 mm .. 2 m across; is mesh.unit (" + s.mesh_unit_name + ")" +
                  (s.mesh_transform.scale == 1.0 ? std::string()
                                                 : " or mesh.transform.scale (" + shown_number(s.mesh_transform.scale) + ")") +
                  " right?");
  const ToolSpec& t = s.tool;
  const std::string units = "is tool.unit (" + t.unit_name + "), mesh.unit (" + s.mesh_unit_name + ")" +
                            (s.mesh_transform.scale == 1.0
                                 ? std::string(" right?")
                                 : " or mesh.transform.scale (" + shown_number(s.mesh_transform.scale) + ") right?");
  for (const auto& [key, size] : tool_contact_sizes(t)) {
    const std::string value = "tool." + key + " = " + in_unit(size, t.unit, t.unit_name);
    const std::string diag = " the physical mesh's bounding-box diagonal (" + in_unit(diagonal, t.unit, t.unit_name) + ")";
    const std::string from = value_source(s, "tool." + key) + ": ";
    if (size > kToolSizeMaxRatio * diagonal) out.push_back(from + value + " is larger than" + diag + ": " + units);
    else if (size < kToolSizeMinRatio * diagonal) out.push_back(from + value + " is below 1/1000 of" + diag + ": " + units);
  }
  if (t.shaft_radius < 0.5e-3 || t.shaft_radius > 10e-3)
    out.push_back(value_source(s, "tool.shaft_radius") + ": tool.shaft_radius = " + in_unit(t.shaft_radius, t.unit, t.unit_name) +
                  (t.unit_name == "mm" ? std::string() : " (" + shown_number(t.shaft_radius * 1e3) + " mm)") +
                  ": laparoscopic shafts are 3-12 mm across, and this one is " +
                  (t.shaft_radius < 0.5e-3 ? "under 1 mm" : "over 20 mm") + "; is tool.unit (" + t.unit_name +
                  ") right? (a needle or a micro-instrument of this size needs no change)");
  if (t.shaft_length < 0.05 || t.shaft_length > 1.0)
    out.push_back(value_source(s, "tool.shaft_length") + ": tool.shaft_length = " + in_unit(t.shaft_length, t.unit, t.unit_name) +
                  (t.unit_name == "m" ? std::string() : " (" + shown_number(t.shaft_length) + " m)") +
                  ": laparoscopic shafts are about 0.3-0.45 m long; is tool.unit (" +
                  t.unit_name + ") right?");
  // The Newton calls' reach: what a call looks through, not only how far it may move.
  if (const double reach = t.newton_iterations * t.max_step, hand_tick = kHandSpeedMax / s.haptic_hz;
      reach > kNewtonReachMaxTicks * hand_tick) {
    out.push_back(value_source(s, "tool.newton_iterations", "tool.max_step") +
                  ": tool.newton_iterations x tool.max_step = " + std::to_string(t.newton_iterations) + " x " +
                  in_unit(t.max_step, t.unit, t.unit_name) + " = " + in_unit(reach, t.unit, t.unit_name) +
                  ": each Newton call of the virtual tool looks for contacts that far around it, over " +
                  shown_number(kNewtonReachMaxTicks) + " times what a hand moves an instrument in a tick (" +
                  shown_number(kHandSpeedMax) + " m/s at " + shown_number(s.haptic_hz) + " Hz: " +
                  in_unit(hand_tick, t.unit, t.unit_name) +
                  "), so every step weighs far tissue and the ticks cost more (cholecystectomy_grasp: 2.2 times at "
                  "50 mm, 5.6 times at 200 mm); the committed scenes and sweeps reach 0.5-16 mm a call");
  }
  if (t.max_step_rotation_deg < kMinStepRotationDeg)
    out.push_back(value_source(s, "tool.max_step_rotation_deg") + ": tool.max_step_rotation_deg = " +
                  shown_number(t.max_step_rotation_deg) +
                  ": a Newton step is scaled as a whole to its limits, so a turn limit this small caps its translation "
                  "too: the virtual tool lags the device, and the lag is rendered as force (gap_insert: 0.0001 put 27% "
                  "of the ticks at the force limit); the committed scenes use 0.5-2 degrees");
  // The solver's movement thresholds are tolerances of a few micrometres (the committed scenes and
  // sweeps use 0.0003 .. 0.03 mm): one beyond 0.1% of the mesh's size holds the mesh, or the virtual
  // mesh, still under every touch of the tool, and the replay's forces come from a frozen tissue.
  const std::pair<const char*, double> thresholds[] = {{"solver.sleep", s.solver.sleep},
                                                       {"solver.physical_region", s.solver.physical_region},
                                                       {"solver.active_region", s.solver.active_region}};
  for (const auto& [key, value] : thresholds)
    if (value > kSolverThresholdMaxRatio * diagonal)
      out.push_back(value_source(s, key) + ": " + key + " = " + in_unit(value, s.unit, s.unit_name) +
                    " is over 0.1% of the physical mesh's " +
                    "bounding-box diagonal (" + in_unit(diagonal, s.unit, s.unit_name) +
                    "): a movement threshold that large keeps the mesh still under the tool (the committed scenes use " +
                    "0.0003 .. 0.03 mm; its unit is the scene's unit, " + s.unit_name + ")");
  return out;
}

}  // namespace

namespace {

/// `value` into `target`: a map into a map key by key (so `--set 'stiffness={k_vol: 500}'` sets
/// k_vol and keeps the section's other keys), anything else replacing what was there.
void merge_into(YAML::Node target, const YAML::Node& value) {
  if (!value.IsMap() || !target.IsMap()) {
    target = value;
    return;
  }
  for (const auto& kv : value) {
    if (kv.first.IsScalar()) merge_into(target[kv.first.Scalar()], kv.second);
    else target[kv.first] = kv.second;  // not a key of the schema: the reader names it
  }
}

/// The dotted keys under `key` that `value` sets: its leaves where it is a map, else `key`.
void leaf_keys(const std::string& key, const YAML::Node& value, std::vector<std::string>& out) {
  if (!value.IsMap() || value.size() == 0) {
    out.push_back(key);
    return;
  }
  for (const auto& kv : value) leaf_keys(key + "." + (kv.first.IsScalar() ? kv.first.Scalar() : "?"), kv.second, out);
}

/// A map in an override's value that names a key twice: refused as in a scene file (yaml-cpp
/// keeps both, and merge_into would take the last without a word).
void refuse_repeated_keys(const YAML::Node& value, const std::string& key, const std::string& text) {
  if (!value.IsMap()) return;
  std::vector<std::string> seen;
  for (const auto& kv : value) {
    if (!kv.first.IsScalar()) continue;  // not a key of the schema: the reader names it
    const std::string name = kv.first.Scalar();
    if (std::find(seen.begin(), seen.end(), name) != seen.end())
      throw OverrideError(text, "key '" + key + "." + name + "' given twice in the value");
    seen.push_back(name);
    refuse_repeated_keys(kv.second, key + "." + name, text);
  }
}

/// Applies one "a.b.c=value" override to the YAML tree (creating maps along the way).
void apply_override(YAML::Node root, const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(OverrideError::set_option_shown(text) + ": expected key=value (e.g. stiffness.k_con=800)");
  const std::string key = text.substr(0, eq), value = text.substr(eq + 1);
  YAML::Node parsed;
  try {
    parsed = yaml_override_value(value);
  } catch (const YAML::Exception& e) {
    throw InputError(OverrideError::set_option_shown(text) + ": in the value: " + yaml_parse_problem(e));
  }
  yaml_refuse_tags(parsed, key, [&text](const YAML::Node&, const std::string& k, const std::string& what) {
    throw OverrideError(text, "key '" + k + "': " + what);
  });
  refuse_repeated_keys(parsed, key, text);
  std::vector<YAML::Node> path{root};
  std::size_t start = 0;
  while (true) {
    const auto dot = key.find('.', start);
    const std::string part = key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (part.empty()) throw InputError(OverrideError::set_option_shown(text) + ": empty key component");
    if (!path.back().IsMap() && path.back().IsDefined() && !path.back().IsNull())
      throw OverrideError(text, "key '" + key.substr(0, start ? start - 1 : 0) + "': " + yaml_shown(path.back()) + ", not a map");
    if (dot == std::string::npos) {
      merge_into(path.back()[part], parsed);
      return;
    }
    path.push_back(path.back()[part]);
    start = dot + 1;
  }
}

/// Parses scene YAML text; syntax errors name `file` and the line.
YAML::Node parse_scene_yaml(const std::string& text, const fs::path& file) {
  // Another kind of file given where a scene goes (the mesh, the recording) is named as such.
  if (text.starts_with("\x89HDF\r\n\x1a\n"))
    throw InputError(file.string() + ": an HDF5 file (a recording or a replay output?), not a scene file (YAML)");
  const std::string ext = lower_extension(file);
  const std::string head = text.substr(0, 256);
  const char* mesh = text.starts_with("# vtk DataFile")                               ? "a VTK mesh"
                     : head.find("<VTKFile") != std::string::npos                     ? "a VTK XML mesh"
                     : head.find("MeshVersionFormatted") != std::string::npos         ? "a Medit mesh"
                     : ext == ".node" || ext == ".ele"                                ? "a TetGen mesh"
                     : text.starts_with("ply\n") || text.starts_with("ply\r\n")       ? "a PLY surface"
                                                                                      : nullptr;
  const bool surface = head.find("DATASET POLYDATA") != std::string::npos || head.find("\"PolyData\"") != std::string::npos ||
                       (mesh && std::string_view(mesh) == "a PLY surface");
  if (mesh && surface)
    throw InputError(file.string() + ": " + mesh + ", not a scene file (YAML): a surface is a scene's mesh.virtual");
  if (mesh)
    throw InputError(file.string() + ": " + mesh + ", not a scene file (YAML): `ebh scene init " + file.string() +
                     " -o scene.yaml` writes a scene for it");
  // The text goes into every replay output (its scene_yaml attribute, UTF-8): bytes of another
  // encoding (Latin-1 from an old editor) are named here, not carried into the outputs.
  if (const std::size_t bad = first_invalid_utf8(text); bad != std::string::npos) {
    const std::string byte = first_invalid_utf8_byte(text);
    const long line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(bad), '\n');
    throw InputError(file.string() + ":" + std::to_string(line) + ": byte " + byte +
                     " is not UTF-8 text: save the scene file as UTF-8");
  }
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(yaml_parse_error(file.string(), e));
  } catch (const YAML::Exception& e) {
    throw InputError(file.string() + ": cannot read scene file: " + e.msg);
  }
  const YAML::Node root = only_yaml_document(documents, file.string(), "a scene file");
  if (!root.IsDefined() || root.IsNull()) throw InputError(file.string() + ": empty scene file");
  if (!root.IsMap()) {
    const std::size_t start = text.find_first_not_of(" \t\r\n");
    const bool gmsh = start != std::string::npos && text.compare(start, 4, "$Mes") == 0;
    throw InputError(file.string() + ": not a scene file: a scene is a YAML map of keys (mesh, tool, ...), this file holds " +
                     yaml_shown(root) +
                     (gmsh ? "; it is a Gmsh mesh: `ebh scene init " + file.string() + " -o scene.yaml` writes a scene for it"
                           : ""));
  }
  yaml_refuse_tags_in(file.string(), root);
  return root;
}

YAML::Node read_scene_yaml(const fs::path& file) {
  if (is_partial_output(file.string())) throw InputError(partial_input_message(file.string()));
  if (const std::string why = not_a_file(file); !why.empty())
    throw InputError(file.string() + ": " + (why == "file not found" ? "scene file not found" : why));
  errno = 0;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string() + ": cannot open scene file" + (errno ? std::string(": ") + std::strerror(errno) : ""));
  std::stringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw InputError(file.string() + ": cannot read scene file");
  return parse_scene_yaml(text.str(), file);
}

SceneSpec read_spec(const YAML::Node& root, const fs::path& file, const std::vector<std::string>& overrides = {},
                    bool mesh_files_must_exist = true) {
  try {
    return SpecReader(file, overrides, mesh_files_must_exist).read(root);
  } catch (const YAML::Exception& e) {  // defensive: a yaml-cpp accessor that throws on odd input
    throw InputError(file.string() + ": malformed scene file: " + e.msg);
  }
}

}  // namespace

Mat3d MeshTransform::rotation() const { return to_matrix(quat_from_rotvec(rotvec_deg * (std::numbers::pi / 180.0))); }

Vec3d MeshTransform::apply(const Vec3d& p) const { return rotation() * (scale * p) + translate; }

Vec3d MeshTransform::inverse(const Vec3d& p) const { return (transpose(rotation()) * (p - translate)) / scale; }

std::string mesh_unit_text(const SceneSpec& spec, const Vec3d& v) {
  const int decimals = std::max(0, static_cast<int>(std::ceil(std::log10(spec.mesh_unit / 1e-4) - 1e-9)));
  return "[" + fixed_text(v.x, decimals) + ", " + fixed_text(v.y, decimals) + ", " + fixed_text(v.z, decimals) + "]";
}

std::string translate_to_origin(const SceneSpec& spec, const Vec3d& centre) {
  return mesh_unit_text(spec, (spec.mesh_transform.translate - centre) / spec.mesh_unit) + ", in " + spec.mesh_unit_name;
}

BoundingBox bounding_box(const std::vector<Vec3d>& points) {
  if (points.empty()) return {};
  BoundingBox b{points.front(), points.front()};
  for (const Vec3d& p : points) {
    b.lo = cwise_min(b.lo, p);
    b.hi = cwise_max(b.hi, p);
  }
  return b;
}

std::vector<std::pair<std::string, double>> tool_contact_sizes(const ToolSpec& t) {
  if (t.kind == ToolSpec::Kind::Hook)
    return {{"shaft_radius", t.shaft_radius}, {"hook.tip_length", t.hook.tip_length}, {"hook.tip_radius", t.hook.tip_radius}};
  return {{"shaft_radius", t.shaft_radius},
          {"forceps.jaw_length", t.forceps.jaw_length},
          {"forceps.jaw_width", t.forceps.jaw_width},
          {"forceps.jaw_thickness", t.forceps.jaw_thickness}};
}

namespace {
/// The tags of a mesh's elements' groups that have no name (0, no group, aside).
std::set<int> unnamed_group_tags(const TetMesh& mesh) {
  std::set<int> tags(mesh.tet_group.begin(), mesh.tet_group.end());
  tags.insert(mesh.triangle_group.begin(), mesh.triangle_group.end());
  for (const auto& [i, tag] : mesh.tet_more_groups) tags.insert(tag);
  for (const auto& [i, tag] : mesh.triangle_more_groups) tags.insert(tag);
  tags.erase(0);
  for (const auto& [tag, name] : mesh.group_names) tags.erase(tag);
  return tags;
}
}  // namespace

std::vector<std::string> known_group_names(const TetMesh& mesh) {
  std::set<std::string> names;
  for (const auto& [tag, name] : mesh.group_names) names.insert(name);
  std::vector<std::string> out(names.begin(), names.end());
  for (int tag : unnamed_group_tags(mesh)) out.push_back(std::to_string(tag));
  return out;
}

std::string file_groups_note(const std::filesystem::path& mesh_file) {
  const std::string ext = lower_extension(mesh_file);
  if (ext == ".vtk" || ext == ".vtu")
    return ": a VTK file's groups are the numbers in its cell array named gmsh:physical, CellEntityIds, medit:ref, "
           "MaterialIds, material, region(s), label(s), subdomain or domain (read_vtk); or pin a box or a half-space";
  if (ext == ".mesh" || ext == ".node" || ext == ".ele")
    return std::string(": a ") + (ext == ".mesh" ? "Medit file's groups are its tets' references (by number) and its "
                                                   "triangles' (surface_N)"
                                                 : "TetGen mesh's groups are its region attributes (by number, tetgen -A) "
                                                   "and its faces' boundary markers (surface_N)") +
           "; or pin a box or a half-space";
  return "";
}

std::string known_groups_text(const TetMesh& mesh) {
  // known_group_names lists the unnamed groups' numbers last.
  std::vector<std::string> out = known_group_names(mesh);
  for (std::size_t i = out.size() - unnamed_group_tags(mesh).size(); i < out.size(); ++i) out[i] += " (unnamed)";
  return out.empty() ? std::string("none") : join(out);
}

std::vector<MeshGroup> mesh_groups(const TetMesh& mesh) {
  std::map<int, MeshGroup> groups;
  for (const auto& [tag, name] : mesh.group_names) groups[tag].name = name;
  for (int g : mesh.tet_group) ++groups[g].tets;
  for (int g : mesh.triangle_group) ++groups[g].triangles;
  for (const auto& [t, g] : mesh.tet_more_groups) ++groups[g].tets;
  for (const auto& [f, g] : mesh.triangle_more_groups) ++groups[g].triangles;
  std::vector<MeshGroup> out;
  for (auto& [tag, g] : groups) {
    g.tag = tag;
    const auto in_file = mesh.group_file_tags.find(tag);
    g.file_tag = in_file == mesh.group_file_tags.end() ? tag : in_file->second;
    out.push_back(std::move(g));
  }
  return out;
}

std::set<int> group_tags(const TetMesh& mesh, const std::string& group) {
  std::set<int> tags;
  for (const auto& [tag, name] : mesh.group_names)
    if (name == group) tags.insert(tag);
  if (tags.empty())
    for (int tag : unnamed_group_tags(mesh))
      if (std::to_string(tag) == group) tags.insert(tag);
  return tags;
}

namespace {
/// Whether point p lies in a box, sphere or half-space region (false for a group).
bool in_region(const Vec3d& p, const PinRegion& r) {
  switch (r.kind) {
    case PinRegion::Kind::Box: return p.x >= r.a.x && p.y >= r.a.y && p.z >= r.a.z && p.x <= r.b.x && p.y <= r.b.y && p.z <= r.b.z;
    case PinRegion::Kind::Sphere: return norm(p - r.a) <= r.b.x;
    case PinRegion::Kind::Halfspace: return dot(p - r.a, r.b) >= 0.0;
    case PinRegion::Kind::Group: return false;
  }
  return false;
}
}  // namespace

std::vector<int> region_tets(const TetMesh& m, const PinRegion& r) {
  if (r.kind == PinRegion::Kind::Group)
    return elements_in_groups(m.tet_group, m.tet_more_groups, m.tets.size(), group_tags(m, r.group));
  std::vector<int> out;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    const Tet& e = m.tets[t];
    const Vec3d centroid = 0.25 * (m.vertices[e[0]] + m.vertices[e[1]] + m.vertices[e[2]] + m.vertices[e[3]]);
    if (in_region(centroid, r)) out.push_back(static_cast<int>(t));
  }
  return out;
}

std::vector<int> region_vertices(const TetMesh& m, const PinRegion& r) {
  std::vector<int> out;
  if (r.kind == PinRegion::Kind::Group) {
    const std::set<int> tags = group_tags(m, r.group);
    for (int t : elements_in_groups(m.tet_group, m.tet_more_groups, m.tets.size(), tags))
      out.insert(out.end(), m.tets[t].begin(), m.tets[t].end());
    for (int f : elements_in_groups(m.triangle_group, m.triangle_more_groups, m.triangles.size(), tags))
      out.insert(out.end(), m.triangles[f].begin(), m.triangles[f].end());
  } else {
    for (std::size_t v = 0; v < m.vertices.size(); ++v)
      if (in_region(m.vertices[v], r)) out.push_back(static_cast<int>(v));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::string> override_keys(const std::string& text) {
  const std::string key = text.substr(0, text.find('='));
  std::vector<std::string> out;
  YAML::Node value;
  try {
    if (key.size() < text.size()) value = yaml_override_value(text.substr(key.size() + 1));
  } catch (const YAML::Exception&) {
  }
  leaf_keys(key, value, out);
  return out;
}

void check_overrides_once(const std::vector<std::string>& overrides) {
  // One key within the other (a section and a key in it) counts as the same key.
  const auto overlap = [](const std::string& a, const std::string& b) {
    const std::string& shorter = a.size() <= b.size() ? a : b;
    const std::string& longer = a.size() <= b.size() ? b : a;
    return longer.compare(0, shorter.size(), shorter) == 0 &&
           (longer.size() == shorter.size() || longer[shorter.size()] == '.');
  };
  std::vector<std::vector<std::string>> keys;
  for (std::size_t i = 0; i < overrides.size(); ++i) {
    keys.push_back(override_keys(overrides[i]));
    for (std::size_t j = 0; j < i; ++j)
      for (const std::string& a : keys[i])
        for (const std::string& b : keys[j])
          if (overlap(a, b))
            throw InputError(OverrideError::set_option_shown(overrides[i]) + ": key '" + (a.size() >= b.size() ? a : b) +
                             "' given twice (also " + OverrideError::set_option_shown(overrides[j]) + ")");
  }
}

SceneSpec load_scene_spec(const fs::path& file, const std::vector<std::string>& overrides, bool mesh_files_must_exist) {
  check_overrides_once(overrides);
  YAML::Node root = read_scene_yaml(file);
  for (const auto& o : overrides) apply_override(root, o);
  return read_spec(root, file, overrides, mesh_files_must_exist);
}

Scene load_scene(const fs::path& file) { return load_scene(file, {}); }

SceneSpec load_scene_spec(const fs::path& file) { return load_scene_spec(file, {}); }

std::vector<SceneInputFile> scene_input_files(const SceneSpec& spec) {
  std::vector<SceneInputFile> files{{"scene_file", "the scene file", spec.file},
                                    {"physical_mesh", "the scene's physical mesh", spec.physical_mesh}};
  // A mesh of several files (TetGen's .node, .ele, .face): each of them, keyed by its extension.
  for (const fs::path& f : tet_mesh_companions(spec.physical_mesh)) {
    const std::string ext = lower_extension(f).substr(1);
    files.push_back({"physical_mesh_" + ext, "the scene's physical mesh (its ." + ext + ")", f});
  }
  if (spec.virtual_mesh) files.push_back({"virtual_mesh", "the scene's virtual mesh", *spec.virtual_mesh});
  return files;
}

Scene load_scene(const fs::path& file, const std::vector<std::string>& overrides) {
  return build_scene(load_scene_spec(file, overrides));
}

Scene load_scene_text(const std::string& yaml, const fs::path& file) { return build_scene(load_scene_spec_text(yaml, file)); }

SceneSpec load_scene_spec_text(const std::string& yaml, const fs::path& file, bool mesh_files_must_exist) {
  return read_spec(parse_scene_yaml(yaml, file), file, {}, mesh_files_must_exist);
}

std::string group_without_elements_note(const TetMesh& mesh) {
  if (mesh.elements_off_entities > 0)
    return "the mesh file names the group, but " + std::to_string(mesh.elements_off_entities) +
           " of its triangles and tets, from line " + std::to_string(mesh.first_off_entities_line) +
           ", lie on entities that its $Entities section does not list (MSH 4.1 as meshio writes it), so their groups "
           "are unknown: write the mesh as MSH 2.2 (meshio: file_format=\"gmsh22\"), re-export it with Gmsh, or pin "
           "a box";
  if (mesh.msh_major == 2)
    return "the mesh file names the group, but no element of it is in the group (an MSH 2.2 element's first tag "
           "is its physical group: the file's elements give others, or none)";
  return "the mesh file names the group, but no element of it is in the group (MSH 4.1 gives elements their "
         "groups through its $Entities section: a file without one has none; re-export it with Gmsh)";
}

std::string lower_dimension_group_note(const TetMesh& mesh, const std::string& group) {
  const auto it = mesh.point_curve_groups.find(group);
  if (it == mesh.point_curve_groups.end()) return "";
  return std::string(": '") + group + "' is a physical group of " + (it->second == 0 ? "points" : "curves") +
         " in the mesh file, and pins take groups of tets or triangles: pin a box around its place, or a physical "
         "surface";
}

std::string value_source(const SceneSpec& spec, const std::string& key) {
  const std::string* o = override_giving(spec.overrides, key);
  return o ? OverrideError::set_option_shown(*o) : spec.file.string();
}

std::string value_source(const SceneSpec& spec, const std::string& key, const std::string& other) {
  return override_giving(spec.overrides, key) ? value_source(spec, key) : value_source(spec, other);
}

namespace {
/// Throws "FILE: key 'KEY': WHAT", or the OverrideError of the override that gave the key its value.
[[noreturn]] void fail_scene_key(const SceneSpec& spec, const std::string& key, const std::string& what) {
  if (const std::string* o = override_giving(spec.overrides, key)) throw OverrideError(*o, "key '" + key + "': " + what);
  throw InputError(spec.file.string() + ": key '" + key + "': " + what);
}

// The tool's springs and the device's limit: a haptic device renders about 0.1 .. 10 kN/m and a
// few newtons (a Geomagic Touch: 3.3 N); the virtual mesh's springs act per surface vertex. Ranges
// around them, which no committed scene or sweep leaves: values beyond are typing errors or render
// next to nothing (5e-324 no force, 1e12 a torque of meganewton metres; k_con and k_vcs:
// kMinDeviceStiffness).
struct Plausible {
  const char* key;
  double value, low, high;
  const char* unit;
  const char* what;
};
constexpr const char* kDeviceStiffness = "a haptic device's stiffness (about 0.1 .. 10 kN/m)";
constexpr double kMaxDetOverVol = 50;  // stiffness.k_det over k_vol: Poisson's ratio 0.495
constexpr double kMaxStabilizationRatio = 10;  // tool.stabilization over its coupling (k_vcs, k_vct)
constexpr const char* kSurfaceSpring = "a tissue surface spring's stiffness per vertex";

/// "" or the warning of a value outside its plausible range, naming where the value came from.
std::string implausible(const SceneSpec& spec, const Plausible& p) {
  if (p.value >= p.low && p.value <= p.high) return "";
  return value_source(spec, p.key) + ": " + p.key + " = " + shown_number(p.value) + " " + p.unit + " is outside " +
         shown_number(p.low) + " .. " + shown_number(p.high) + " " + p.unit + ", the range of " + p.what;
}

/// The number of tets of each part (mesh_parts: indexed by the part's lowest vertex; 0 elsewhere).
std::vector<int> tets_per_part(const TetMesh& mesh, const std::vector<int>& part) {
  std::vector<int> tets(mesh.vertices.size(), 0);
  for (const Tet& t : mesh.tets) ++tets[part[t[0]]];
  return tets;
}

/// mesh.min_part_tets: removes the parts (tets joined by vertices) of fewer tets, with the vertices
/// and triangles only they use, and says so; refuses a value that leaves no part.
void drop_small_parts(TetMesh& mesh, const SceneSpec& spec, const std::string& mesh_file,
                      std::vector<std::string>& warnings) {
  const int least = spec.min_part_tets;
  const std::vector<int> part = mesh_parts(mesh);
  const std::vector<int> tets = tets_per_part(mesh, part);
  const int largest = *std::max_element(tets.begin(), tets.end());
  if (largest < least)
    fail_scene_key(spec, "mesh.min_part_tets",
                   std::to_string(least) + " drops every part of " + mesh_file + " (its largest holds " +
                       std::to_string(largest) + " tets)");
  int dropped = 0, kept = 0, dropped_tets = 0, biggest = 0;
  for (const int n : tets)
    if (n >= least) {
      ++kept;
    } else if (n > 0) {
      ++dropped;
      dropped_tets += n;
      biggest = std::max(biggest, n);
    }
  if (dropped == 0) return;
  std::vector<int> index(mesh.tets.size(), -1);  // old tet -> new
  std::size_t k = 0;
  const bool ids = mesh.file_tet_ids.size() == mesh.tets.size();
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    if (tets[part[mesh.tets[t][0]]] < least) continue;
    index[t] = static_cast<int>(k);
    mesh.tets[k] = mesh.tets[t];
    mesh.tet_group[k] = mesh.tet_group[t];
    if (ids) mesh.file_tet_ids[k] = mesh.file_tet_ids[t];
    ++k;
  }
  mesh.tets.resize(k);
  mesh.tet_group.resize(k);
  if (ids) mesh.file_tet_ids.resize(k);
  std::vector<std::pair<int, int>> more;
  for (const auto& [t, tag] : mesh.tet_more_groups)
    if (index[t] >= 0) more.push_back({index[t], tag});
  mesh.tet_more_groups = std::move(more);
  remove_unreferenced_vertices(mesh);  // the parts' vertices and the triangles on them
  warnings.push_back(value_source(spec, "mesh.min_part_tets") + ": mesh.min_part_tets " + std::to_string(least) +
                     ": dropped " + std::to_string(dropped) + (dropped == 1 ? " part" : " parts") + " of " + mesh_file +
                     " (" + std::to_string(dropped_tets) + " tets; the largest " + std::to_string(biggest) + "), kept " +
                     std::to_string(kept));
}
}  // namespace

namespace {
/// Refuses a virtual surface a corner of whose faces lies more than kVirtualFarOff diagonals outside
/// the physical mesh's bounding box: the surface in another unit or frame, or one stray vertex (an
/// exporter's FLT_MAX for a point it could not place). `placed`: the surface's vertices in the
/// world (metres), `physical` the physical mesh's. Checked before the surface's vertices are
/// welded, whose tolerance such a corner would stretch, and before they are paired, whose
/// distances a vertex at 1e300 overflows.
void refuse_far_virtual_corners(const std::string& virtual_file, const std::vector<Tri>& triangles,
                                const std::vector<Vec3d>& placed, const BoundingBox& physical) {
  const auto outside = [](double x, double lo, double hi) { return std::max({lo - x, x - hi, 0.0}); };
  double farthest = 0;
  int at = -1;
  for (const Tri& t : triangles)
    for (const int v : t) {
      const Vec3d& p = placed[v];
      // hypot: no overflow of the squares at 1e300
      const double d = std::hypot(outside(p.x, physical.lo.x, physical.hi.x), outside(p.y, physical.lo.y, physical.hi.y),
                                  outside(p.z, physical.lo.z, physical.hi.z));
      if (d > farthest) {
        farthest = d;
        at = v;
      }
    }
  const double diagonal = physical.diagonal();
  if (at < 0 || !(farthest > kVirtualFarOff * diagonal)) return;
  const Vec3d& p = placed[at];
  char buf[320];
  std::snprintf(buf, sizeof buf, "%.3g m off the physical mesh (the virtual vertex at %.4g, %.4g, %.4g m lies that far "
                "outside its bounding box), more than %g times its diagonal (%.3g m)", farthest, p.x, p.y, p.z,
                kVirtualFarOff, diagonal);
  throw InputError(virtual_file + ": mesh.virtual: the virtual mesh lies up to " + buf +
                   ": it is not a surface of this mesh; is it in mesh.unit and the physical mesh's frame "
                   "(mesh.transform places both)?");
}
}  // namespace

void clean_physical_mesh(TetMesh& mesh, const SceneSpec& spec, std::vector<std::string>& warnings) {
  const std::string mesh_file = spec.physical_mesh.string();
  if (const int removed = remove_unreferenced_vertices(mesh); removed > 0)
    warnings.push_back(mesh_file + ": removed " + std::to_string(removed) + " vertices used by no tet");
  if (spec.min_part_tets > 0) drop_small_parts(mesh, spec, mesh_file, warnings);
}

std::vector<std::string> tool_stiffness_warnings(const SceneSpec& spec) {
  std::vector<std::string> out;
  for (const Plausible& p : {Plausible{"stiffness.k_con", spec.stiffness.k_con, kMinDeviceStiffness, kMaxDeviceStiffness, "N/m",
                                       kDeviceStiffness},
                             Plausible{"stiffness.k_vcs", spec.stiffness.k_vcs, kMinDeviceStiffness, kMaxDeviceStiffness, "N/m",
                                       kDeviceStiffness},
                             Plausible{"stiffness.k_vct", spec.stiffness.k_vct, 1e-4, 100, "N m/rad",
                                       "a haptic device's rotational stiffness"}})
    if (std::string w = implausible(spec, p); !w.empty()) out.push_back(std::move(w));
  // The stabilisation springs tie the virtual tool to its pose at the tick's start: stiffer than the
  // coupling many times over, they hold it back from a moving device (1e6 N/m against k_vcs 300: a
  // 21 mm lag, the force at the limit, in free motion).
  struct Spring {
    const char* key;
    double value;
    const char* coupling_key;
    double coupling;
  };
  for (const Spring& s : {Spring{"tool.stabilization.translation", spec.tool.stabilization_translation, "stiffness.k_vcs",
                                 spec.stiffness.k_vcs},
                          Spring{"tool.stabilization.rotation", spec.tool.stabilization_rotation, "stiffness.k_vct",
                                 spec.stiffness.k_vct}})
    if (s.value > kMaxStabilizationRatio * s.coupling)
      out.push_back(value_source(spec, s.key) + ": " + s.key + " = " + shown_number(s.value) + " is " +
                    shown_number(s.value / s.coupling) + " times " + s.coupling_key +
                    ": the virtual tool moves about 1/" + shown_number(1 + s.value / s.coupling) +
                    " of the way to the device a tick and lags behind a moving device, rendered as force");
  return out;
}

namespace {
/// "N times" for a ratio over k_svc; a denormal k_svc makes it overflow: no "inf times".
std::string times_text(double ratio) {
  char times[48];
  if (ratio <= 1e6) std::snprintf(times, sizeof times, "%.3g times", ratio);
  else std::snprintf(times, sizeof times, "more than a million times");
  return times;
}
}  // namespace

std::string edges_outweigh_coupling_warning(const SceneSpec& spec) {
  if (!spec.stiffness.edges_outweigh_coupling()) return "";
  return value_source(spec, "stiffness.k_s") + ": stiffness.k_s is " + times_text(spec.stiffness.k_s / spec.stiffness.k_svc) +
         " k_svc: in async mode (the default) the virtual and the physical mesh can drive "
         "each other unstable (the gap and tube scenes diverge with no tool contact at 2 times); "
         "raise k_svc with k_s, or replay --mode lockstep (docs/MODEL.md, \"k_s against k_svc\")";
}

Scene build_scene(SceneSpec spec_in) {
  Scene scene;
  scene.spec = std::move(spec_in);
  const SceneSpec& spec = scene.spec;
  // Soft tissue: shear modulus ~100 Pa (brain) to ~1 MPa (tendon), density ~900-1100 kg/m^3.
  // A value out of range that a larger unit puts in range was most likely written in it (a
  // density of 1.06 in g/cm^3, a k_vol of 5 in kPa): " (in UNIT? V UNIT is W SI)", else "".
  const auto unit_hint = [](double v, double lo, double hi, const char* si,
                            std::initializer_list<std::pair<const char*, double>> units) {
    for (const auto& [name, factor] : units)
      if (v * factor >= lo && v * factor <= hi)
        return " (in " + std::string(name) + "? " + shown_number(v) + " " + name + " is " + shown_number(v * factor) + " " +
               si + ")";
    return std::string();
  };
  const auto check_tissue_k_vol = [&](const std::string& key, double k_vol) {
    if (k_vol < 10 || k_vol > 1e8)
      scene.warnings.push_back(value_source(spec, key) + ": " + key + " = " + shown_number(k_vol) +
                               " Pa is outside soft tissue's 10 Pa .. 100 MPa" +
                               unit_hint(k_vol, 10, 1e8, "Pa", {{"kPa", 1e3}, {"MPa", 1e6}}));
  };
  check_tissue_k_vol("stiffness.k_vol", spec.stiffness.k_vol);
  for (std::size_t i = 0; i < spec.stiffness_regions.size(); ++i)
    check_tissue_k_vol("stiffness.regions[" + std::to_string(i) + "].k_vol", spec.stiffness_regions[i].k_vol);
  // E_det's volume stiffness: Poisson's ratio k_det / (2 k_det + k_vol). Tissue is 0.45-0.49 (k_det
  // 4.5-25 times k_vol); beyond 50 times (0.495) the local-global iterations make little headway
  // (333 times on the cholecystectomy: 0.27 mesh weights left by the stopping rule, 0.5 by 64
  // direct iterations).
  if (spec.stiffness.k_det > kMaxDetOverVol * spec.stiffness.k_vol)
    scene.warnings.push_back(value_source(spec, "stiffness.k_det") + ": stiffness.k_det = " + shown_number(spec.stiffness.k_det) +
                             " Pa is " + shown_number(spec.stiffness.k_det / spec.stiffness.k_vol) +
                             " times k_vol (Poisson's ratio " +
                             shown_number(spec.stiffness.k_det / (2 * spec.stiffness.k_det + spec.stiffness.k_vol)) +
                             "; tissue's is 0.45-0.49, k_det 4.5-25 times k_vol): so near incompressible, the physical "
                             "solve's iterations make little headway and its steps stay unbalanced");
  // physical_iterations is the fewest a step runs; the stopping rule adds more up to
  // physical_max_iterations. A minimum above that maximum runs every step that long for nothing the
  // tolerance asked (gap_insert at 1000: 23 times slower, the same forces to 4 digits).
  if (const SolverSpec& sv = spec.solver; sv.method != SolverSpec::Method::Direct && sv.physical_tolerance > 0 &&
                                          sv.physical_iterations > sv.physical_max_iterations)
    scene.warnings.push_back(value_source(spec, "solver.physical_iterations") + ": solver.physical_iterations = " +
                             std::to_string(sv.physical_iterations) +
                             " is the fewest iterations a physical step runs, above solver.physical_max_iterations (" +
                             std::to_string(sv.physical_max_iterations) + ") up to which the stopping rule adds them: every "
                             "step runs " + std::to_string(sv.physical_iterations) +
                             " where the tolerance is met sooner; for a closer solve lower solver.physical_tolerance (" +
                             shown_number(sv.physical_tolerance) + " mesh weights)");
  if (spec.density < kTissueDensityMin || spec.density > kTissueDensityMax)
    scene.warnings.push_back(value_source(spec, "material.density") + ": material.density = " + shown_number(spec.density) +
                             " kg/m^3 is outside soft tissue's " + shown_number(kTissueDensityMin) + " .. " +
                             shown_number(kTissueDensityMax) + " kg/m^3" +
                             unit_hint(spec.density, kTissueDensityMin, kTissueDensityMax, "kg/m^3", {{"g/cm^3", 1e3}}));
  if (norm(spec.gravity) > 2 * 9.81)
    scene.warnings.push_back(value_source(spec, "gravity") + ": |gravity| = " + shown_number(norm(spec.gravity)) + " m/s^2 is over 2 g");
  for (const Plausible& p : {Plausible{"stiffness.k_s", spec.stiffness.k_s, 0.01, 1e6, "N/m", kSurfaceSpring},
                             Plausible{"stiffness.k_svc", spec.stiffness.k_svc, 0.01, 1e6, "N/m", kSurfaceSpring},
                             Plausible{"tool.force_limit", spec.tool.force_limit, 0.01, 100, "N",
                                       "a haptic device's force (a Geomagic Touch: 3.3 N)"}})
    if (std::string w = implausible(spec, p); !w.empty()) scene.warnings.push_back(std::move(w));
  if (spec.tool.other_kind_keys) {
    const bool hook = spec.tool.kind == ToolSpec::Kind::Hook;
    const std::string block = hook ? "tool.forceps" : "tool.hook";
    scene.warnings.push_back(value_source(spec, block) + ": " + block + " is given, but tool.kind is " +
                             (hook ? "hook" : "forceps") + ": its keys are not used");
  }
  const std::string mesh_file = spec.physical_mesh.string();

  // The physical mesh: read, drop unused vertices and small parts, orient, validate, then scale to
  // metres and place it in the world (mesh.unit, mesh.transform).
  TetMesh mesh = read_tet_mesh(spec.physical_mesh);
  const std::vector<std::string> pins_removed = groups_removed_with_unused_vertices(mesh, spec);
  clean_physical_mesh(mesh, spec, scene.warnings);
  if (mesh.elements_off_entities > 0 && !mesh.group_names.empty())
    scene.warnings.push_back(mesh_file + ":" + std::to_string(mesh.first_off_entities_line) + ": " +
                             std::to_string(mesh.elements_off_entities) +
                             " of its triangles and tets lie on entities that $Entities does not list (MSH 4.1 as meshio "
                             "writes it): read without their physical groups");
  // Coordinates so large that a tet's volume (a product of three differences) overflows: the
  // file's, or (below) after mesh.unit and mesh.transform.scale. Told as such, not as flat tets.
  auto check_magnitude = [&mesh](const std::string& where, const char* after) {
    constexpr double kLimit = 1e100;
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const Vec3d& p = mesh.vertices[v];
      const double m = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
      if (!(m <= kLimit)) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "vertex %zu%s has a coordinate of %g%s: beyond %g, where the tets' volumes overflow",
                      v, v < mesh.file_node_ids.size() ? (" (node " + std::to_string(mesh.file_node_ids[v]) + ")").c_str() : "",
                      m, after, kLimit);
        throw InputError(where + ": " + buf);
      }
    }
  };
  check_magnitude(mesh_file, "");
  const Orientation o = orient_tets(mesh);
  if (const std::string w = orientation_warning(o, mesh); !w.empty()) scene.warnings.push_back(mesh_file + ": " + w);
  const MeshReport report = validate_mesh(mesh);
  if (report.fatal()) {
    std::string why = mesh_file + ": " + report.fatal_message(mesh);
    // Tets flipped one by one that then overlap their neighbours were turned inside out, not
    // only written in another vertex order.
    if (o.kind == Orientation::Kind::Mixed && !report.overlapping_tets.empty())
      why += " (after flipping the " + std::to_string(o.negative) +
             " negatively oriented tets: tets inside out among their neighbours, a tangled mesh)";
    throw InputError(why);
  }
  for (const auto& w : report.warnings()) scene.warnings.push_back(mesh_file + ": " + w);
  auto place = [&spec](std::vector<Vec3d>& vertices) {
    for (Vec3d& p : vertices) p *= spec.mesh_unit;
    // a rotation and a uniform scale keep the tets' orientation and quality
    if (!spec.mesh_transform.identity())
      for (Vec3d& p : vertices) p = spec.mesh_transform.apply(p);
  };
  // Placed, the mesh must keep its shape: a scale that shrinks it below 1e-30 m or grows it past
  // 1e30 m (its tets' volumes, cubes of lengths, underflow or overflow) or a translation so far that
  // the coordinates' round-off swallows the mesh (1e300 m) is refused naming its key.
  // The mesh's size: its farthest vertex from vertex 0, which a rotation keeps.
  auto max_abs = [](const Vec3d& v) { return std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}); };
  auto size = [&mesh] {
    double d = 0;
    for (const Vec3d& p : mesh.vertices) d = std::max(d, norm(p - mesh.vertices.front()));  // 0 when empty
    return d;
  };
  const double file_size = size();
  // In the file's unit and frame, which the virtual mesh's file shares: its weld's scale.
  const BoundingBox file_box = bounding_box(mesh.vertices);
  const double file_diagonal = file_box.diagonal();
  const double expected = file_size * spec.mesh_unit * spec.mesh_transform.scale;
  place(mesh.vertices);
  if (file_size > 0 && !(expected >= kMinPlacedDiagonal && expected <= kMaxPlacedDiagonal))
    fail_scene_key(spec, "mesh.transform.scale",
                   shown_number(spec.mesh_transform.scale) + " makes the physical mesh's size " + shown_number(expected) +
                       " m (" + shown_number(file_size) + " " + spec.mesh_unit_name + " in the file): expected " +
                       shown_number(kMinPlacedDiagonal) + " .. " + shown_number(kMaxPlacedDiagonal) +
                       " m, where its tets' volumes neither underflow nor overflow");
  if (const double placed = size(); !(std::fabs(placed - expected) <= 1e-6 * expected)) {
    const std::string round_off = "where the coordinates' round-off changes its size from " + shown_number(expected) +
                                  " to " + shown_number(placed) + " m";
    // What took the mesh that far: the translation, where it is longer than the file's coordinates
    // put the mesh from the origin and leaves it farther, else those coordinates (a segmentation
    // left in its scanner's frame).
    const Vec3d centre = bounding_box(mesh.vertices).centre();
    const double own = norm(file_box.centre()) * spec.mesh_unit * spec.mesh_transform.scale;  // m
    if (norm(spec.mesh_transform.translate) > own && norm(centre) > own)
      fail_scene_key(spec, "mesh.transform.translate",
                     "moves the physical mesh " + shown_number(max_abs(spec.mesh_transform.translate)) + " m away, " +
                         round_off + ": expected a translation near the mesh's size");
    // mesh.unit, the scale and the rotation round the file's coordinates before the translation
    // applies; a translation alone adds exactly to coordinates of about its size (Sterbenz), so
    // with none of them the right one brings the mesh back whole.
    std::string rounded_by;
    if (spec.mesh_unit != 1) rounded_by = "mesh.unit (" + spec.mesh_unit_name + ")";
    if (spec.mesh_transform.scale != 1) rounded_by += (rounded_by.empty() ? "" : ", ") + std::string("mesh.transform.scale");
    if (spec.mesh_transform.rotvec_deg != Vec3d{})
      rounded_by += (rounded_by.empty() ? "" : ", ") + std::string("mesh.transform.rotvec_deg");
    const std::string fix =
        rounded_by.empty()
            ? "move it near the origin (mesh.transform.translate: " + translate_to_origin(spec, centre) + ")"
            : "move it near the origin in its file (subtract its centre " + mesh_unit_text(spec, file_box.centre()) + " " +
                  spec.mesh_unit_name + " from every vertex): " + rounded_by +
                  " rounds the file's coordinates before mesh.transform.translate applies, so no translation keeps its shape";
    throw InputError(mesh_file + ": the mesh's vertices lie " + shown_number(own) + " m from the origin (its centre), " +
                     round_off + ": " + fix);
  }
  check_magnitude(spec.file.string() + ": mesh.unit, mesh.transform.scale and mesh.transform.translate", " m once placed");
  scene.physical = std::move(mesh);

  // The virtual mesh's source surface.
  if (spec.virtual_mesh) {
    scene.virtual_surface = read_surface(*spec.virtual_mesh);
    std::vector<Vec3d> placed = scene.virtual_surface.vertices;
    place(placed);
    refuse_far_virtual_corners(spec.virtual_mesh->string(), scene.virtual_surface.triangles, placed,
                               bounding_box(scene.physical.vertices));
    // A triangle soup (an STL converted to OBJ) has no edges between its faces until its vertices
    // at one position are one.
    // A seam exported twice, its copies a round-off apart, is welded too: left open, the tool
    // slipped through it with surface contact.
    // Of the faces' corners: a stray point far off would stretch the box and the weld with it. A
    // stray corner of a face within the far-off limit above does so too, so the box is taken no
    // larger than the physical mesh's, which the surface covers (a corner 2 km off a 100 mm
    // surface once welded 506 of its 530 vertices, itself among them, and the surface loaded).
    std::vector<Vec3d> corners;
    corners.reserve(3 * scene.virtual_surface.triangles.size());
    for (const Tri& t : scene.virtual_surface.triangles)
      for (const int v : t) corners.push_back(scene.virtual_surface.vertices[v]);
    const double weld = kSurfaceWeldTolerance * std::min(bounding_box(corners).diagonal(), file_diagonal);
    if (const MergedVertices merged = merge_coincident_surface_vertices(scene.virtual_surface, weld); merged.vertices > 0) {
      const std::string faces = std::to_string(merged.faces) + (merged.faces == 1 ? " face" : " faces");
      if (scene.virtual_surface.triangles.empty())
        throw InputError(spec.virtual_mesh->string() + ": every face has a repeated vertex once the vertices at one position "
                         "are merged (" + std::to_string(merged.vertices) + " merged)");
      const std::string near = merged.near == 0 ? ""
                               : " (" + std::to_string(merged.near) + " of them a round-off apart, within " +
                                     shown_number(weld) + " file units: a seam exported twice)";
      scene.warnings.push_back(spec.virtual_mesh->string() + ": merged " + std::to_string(merged.vertices) +
                               " vertices at the position of another" + near +
                               (merged.faces > 0 ? " and removed the " + faces + " left with a repeated vertex" : ""));
    }
    if (const int repeated = remove_repeated_surface_faces(scene.virtual_surface); repeated > 0)
      scene.warnings.push_back(spec.virtual_mesh->string() + ": removed " + std::to_string(repeated) +
                               (repeated == 1 ? " face that repeats another's vertices (surface contact would count "
                                                "it twice)"
                                              : " faces that repeat another's vertices (surface contact would count "
                                                "them twice)"));
    const int flat = remove_flat_surface_faces(scene.virtual_surface);
    if (scene.virtual_surface.triangles.empty())
      throw InputError(spec.virtual_mesh->string() + ": every face has no area (its corners on one line)");
    if (flat > 0)
      scene.warnings.push_back(spec.virtual_mesh->string() + ": removed " + std::to_string(flat) +
                               (flat == 1 ? " face" : " faces") + " with no area (corners on one line): " +
                               (flat == 1 ? "it covers" : "they cover") + " nothing, and " +
                               (flat == 1 ? "its" : "their") + " edges would read as a hole");
    if (const int removed = remove_unused_surface_vertices(scene.virtual_surface); removed > 0)
      scene.warnings.push_back(spec.virtual_mesh->string() + ": removed " + std::to_string(removed) +
                               " vertices used by no face");
    place(scene.virtual_surface.vertices);
  } else {
    scene.virtual_surface = extract_boundary(scene.physical);
  }
  for (auto& w : size_warnings(spec, scene.physical)) scene.warnings.push_back(std::move(w));
  if (std::string w = too_soft_for_own_weight(scene); !w.empty()) scene.warnings.push_back(spec.file.string() + ": " + w);

  // Pinned regions (world coordinates, scaled when the file was read).
  for (std::size_t i = 0; i < spec.pinned.size(); ++i) {
    const std::vector<int> v = pinned_by(scene, i, pins_removed[i]);
    scene.pinned.insert(scene.pinned.end(), v.begin(), v.end());
  }
  std::sort(scene.pinned.begin(), scene.pinned.end());
  scene.pinned.erase(std::unique(scene.pinned.begin(), scene.pinned.end()), scene.pinned.end());
  scene.tet_k_vol = tet_stiffness(scene);
  // A pinned region that holds all of the mesh, or only some of its parts: the tool meets a rigid
  // body, or drags a part through the coupling (settle_under_gravity refuses it under gravity).
  const std::string where = spec.file.string();
  const int nv = static_cast<int>(scene.physical.vertices.size());
  // What a replay then does (settle_under_gravity): it refuses to start, with no equilibrium to settle to.
  const std::string refused = spec.stages.settle && squared_norm(spec.gravity) > 0
                                  ? "; a replay refuses it under gravity, with no static equilibrium to start from "
                                    "(or set stages.settle: false or gravity: [0, 0, 0])"
                                  : "";
  if (nv > 0 && static_cast<int>(scene.pinned.size()) == nv)
    scene.warnings.push_back(where + ": pinned: every vertex of the physical mesh is pinned, so it cannot move and "
                                     "the tool meets a rigid body (pin a region of it)");
  if (nv > 0 && scene.pinned.empty())
    scene.warnings.push_back(where + ": pinned: nothing is pinned, so the physical mesh floats free, held only by "
                                     "its coupling to the virtual mesh, which drags it like a thick fluid: under "
                                     "gravity it sinks slowly instead of falling, and the tool feels that drag, not "
                                     "tissue held in place (docs/MODEL.md, \"Held loads\"; pin a region of it)" +
                                     refused);
  if (std::string w = coupling_bounds_tissue(scene); !w.empty())
    scene.warnings.push_back(value_source(spec, "stiffness.k_vol", "stiffness.k_svc") + ": " + w);
  if (std::string w = virtual_mesh_much_finer(scene); !w.empty())
    scene.warnings.push_back(spec.virtual_mesh->string() + ": mesh.virtual: " + w);
  if (!scene.pinned.empty() && static_cast<int>(scene.pinned.size()) < nv) {
    const std::vector<std::pair<int, int>> turning = parts_pinned_on_a_line(scene.physical, scene.pinned);
    if (!turning.empty()) {
      const auto& [first, count] = turning.front();
      scene.warnings.push_back(
          where + ": pinned: " + std::to_string(turning.size()) + " part(s) of the physical mesh (the first holds " +
          vertex_name(scene.physical, first) + ") are pinned at " + std::to_string(count) +
          (count == 1 ? " vertex" : " vertices on one line") +
          ": they can turn about " + (count == 1 ? "it" : "that line") +
          ", held only by their coupling to the virtual mesh, and the tool feels that drag, falling while it is held "
          "(docs/MODEL.md, \"Held loads\"): pin a region that spans a face of each part");
    }
  }
  if (!scene.pinned.empty()) {
    scene.free_parts = unpinned_parts(scene.physical, scene.pinned);
    if (!scene.free_parts.empty()) {
      int free_vertices = 0;
      for (const auto& [first, count] : scene.free_parts) free_vertices += count;
      const auto& [first, count] = scene.free_parts.front();
      // The free parts that are specks, which mesh.min_part_tets drops.
      int specks = 0, most = 0;
      for (const auto& [lowest, tets] : speck_parts(scene.physical))
        if (std::any_of(scene.free_parts.begin(), scene.free_parts.end(), [&](const auto& f) { return f.first == lowest; })) {
          ++specks;
          most = std::max(most, tets);
        }
      const std::string drop = specks == 0 ? std::string()
                                           : "; " + std::to_string(specks) + " of them hold under " +
                                                 shown_number(100 * kSpeckFraction) +
                                                 "% of the mesh's tets each (a segmentation's specks?): mesh.min_part_tets: " +
                                                 std::to_string(most + 1) + " drops them";
      scene.warnings.push_back(
          where + ": pinned: " + std::to_string(scene.free_parts.size()) + " part(s) of the physical mesh (" +
          std::to_string(free_vertices) + " of its " + std::to_string(nv) +
          " vertices; the first holds " + vertex_name(scene.physical, first) + " and " + std::to_string(count) +
          " vertices) touch no pinned vertex: they float free, held only by their coupling to the virtual mesh, "
          "which drags them like a thick fluid (the tool feels that drag; docs/MODEL.md, \"Held loads\"): pin "
          "each part" + drop + refused);
    }
  }
  return scene;
}

std::string too_soft_for_own_weight(const Scene& scene) {
  const SceneSpec& spec = scene.spec;
  const double g = norm(spec.gravity);
  if (!(g > 0) || !(spec.stiffness.k_vol > 0) || scene.physical.vertices.empty()) return "";
  const Vec3d down = spec.gravity / g;
  double lo = dot(scene.physical.vertices.front(), down), hi = lo;
  for (const Vec3d& x : scene.physical.vertices) {
    lo = std::min(lo, dot(x, down));
    hi = std::max(hi, dot(x, down));
  }
  const double strain = spec.density * g * (hi - lo) / spec.stiffness.k_vol;
  if (!(strain > 1)) return "";
  return "the tissue is too soft to carry its own weight: material.density x |gravity| x the mesh's height along "
         "gravity (" + shown_number(hi - lo) + " m) / stiffness.k_vol = " + shown_number(strain) +
         " (above 1 it sags by more than its own height): raise stiffness.k_vol, or set gravity: [0, 0, 0] where the "
         "organ is held by its surroundings";
}

std::vector<std::pair<int, int>> parts_pinned_on_a_line(const TetMesh& mesh, std::span<const int> pinned) {
  const int n = static_cast<int>(mesh.vertices.size());
  const std::vector<int> part = mesh_parts(mesh);  // the part's lowest vertex
  std::vector<std::vector<int>> pins(n);
  for (const int i : pinned) pins[part[i]].push_back(i);
  // Each pinned part's thickness: the spread of its vertices along their least principal axis (a
  // vessel 2 mm across and 200 mm long is 2 mm thick; pins across its end face span a face of it,
  // which the box's diagonal, 200 mm, took for a line).
  std::vector<std::vector<int>> members(n);
  for (int i = 0; i < n; ++i)
    if (!pins[part[i]].empty()) members[part[i]].push_back(i);
  std::vector<std::pair<int, int>> parts;
  for (int p = 0; p < n; ++p) {
    const std::vector<int>& v = pins[p];
    if (v.empty() || members[p].size() < 2) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const int i : members[p]) mean += Eigen::Vector3d(mesh.vertices[i].x, mesh.vertices[i].y, mesh.vertices[i].z);
    mean /= static_cast<double>(members[p].size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const int i : members[p]) {
      const Eigen::Vector3d d = Eigen::Vector3d(mesh.vertices[i].x, mesh.vertices[i].y, mesh.vertices[i].z) - mean;
      cov += d * d.transpose();
    }
    const Eigen::Vector3d axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0);
    const Vec3d least{axis.x(), axis.y(), axis.z()};
    double near = 1e300, far = -1e300;
    for (const int i : members[p]) {
      near = std::min(near, dot(mesh.vertices[i], least));
      far = std::max(far, dot(mesh.vertices[i], least));
    }
    const double tol = kPinLineTolerance * (far - near);
    // The line through the pinned vertex farthest from the first and the one farthest from that.
    const auto farthest = [&](const Vec3d& from) {
      int best = v.front();
      for (const int i : v)
        if (norm(mesh.vertices[i] - from) > norm(mesh.vertices[best] - from)) best = i;
      return best;
    };
    const Vec3d a = mesh.vertices[farthest(mesh.vertices[v.front()])];
    const Vec3d b = mesh.vertices[farthest(a)];
    const double length = norm(b - a);
    bool on_line = true;
    for (const int i : v) {
      const Vec3d d = mesh.vertices[i] - a;
      const double off = length > tol ? norm(cross(d, b - a)) / length : norm(d);
      if (off > tol) {
        on_line = false;
        break;
      }
    }
    if (on_line) parts.emplace_back(p, static_cast<int>(v.size()));
  }
  return parts;
}

namespace {
/// The mean edge length of a triangle surface (each face's three edges; 0 for none).
double mean_edge(const SurfaceMesh& surface) {
  if (surface.triangles.empty()) return 0;
  double sum = 0;
  for (const auto& t : surface.triangles)
    for (int a = 0; a < 3; ++a) sum += norm(surface.vertices[t[a]] - surface.vertices[t[(a + 1) % 3]]);
  return sum / (3.0 * static_cast<double>(surface.triangles.size()));
}
}  // namespace

std::string virtual_mesh_much_finer(const Scene& scene) {
  if (!scene.spec.virtual_mesh || scene.virtual_surface.triangles.empty()) return "";
  const double edge = mean_edge(scene.virtual_surface) / std::ldexp(1.0, scene.spec.virtual_refine);
  const double boundary = mean_edge(extract_boundary(scene.physical));
  if (!(edge < kVirtualFinerThanBoundary * boundary)) return "";
  char line[600];
  std::snprintf(line, sizeof line,
                "the virtual mesh's edges (%.3g mm on average, as refined) are 1/%.3g of the physical mesh's boundary "
                "edges (%.3g mm): E_svc and contact act at each virtual vertex, so the tool meets %.3g times more "
                "springs per area than at the boundary's resolution and the rendered force grows with the density "
                "(docs/MODEL.md, \"The other stiffnesses\"); a coarser OBJ (or a lower mesh.virtual_refine) renders "
                "the tissue, a finer one its surface's resolution",
                edge * 1e3, boundary / edge, boundary * 1e3, (boundary / edge) * (boundary / edge));
  return line;
}

std::string coupling_bounds_tissue(const Scene& scene) {
  const SceneSpec& spec = scene.spec;
  const SurfaceMesh& surface = scene.virtual_surface;
  if (surface.triangles.empty() || !(spec.stiffness.k_svc > 0)) return "";
  // Each level of virtual_refine halves the edges.
  const double edge = mean_edge(surface) / std::ldexp(1.0, spec.virtual_refine);
  const double felt = spec.stiffness.k_vol * edge;
  if (!(felt > kTissueOverCoupling * spec.stiffness.k_svc)) return "";
  char line[512];
  std::snprintf(line, sizeof line,
                "stiffness.k_vol x the virtual mesh's mean edge (%.3g Pa x %.3g mm = %.3g N/m) is %s "
                "stiffness.k_svc (%.3g N/m): the coupling, not the tissue, sets what the tool feels, the virtual surface "
                "giving way over the physical one (a stiffer tissue renders little harder); raise k_svc to about k_vol "
                "x the edge (docs/MODEL.md, \"The other stiffnesses\")",
                spec.stiffness.k_vol, edge * 1e3, felt, times_text(felt / spec.stiffness.k_svc).c_str(),
                spec.stiffness.k_svc);
  return line;
}

std::vector<std::pair<int, int>> speck_parts(const TetMesh& mesh) {
  const std::vector<int> part = mesh_parts(mesh);
  const std::vector<int> tets = tets_per_part(mesh, part);
  std::vector<std::pair<int, int>> specks;
  for (std::size_t i = 0; i < tets.size(); ++i)
    if (tets[i] > 0 && tets[i] < kSpeckFraction * static_cast<double>(mesh.tets.size()))
      specks.emplace_back(static_cast<int>(i), tets[i]);
  return specks;
}

std::vector<std::pair<int, int>> unpinned_parts(const TetMesh& mesh, std::span<const int> pinned) {
  const int n = static_cast<int>(mesh.vertices.size());
  const std::vector<int> part = mesh_parts(mesh);  // the part's lowest vertex
  std::vector<int> size(n, 0);
  std::vector<char> held(n, 0), used(n, 0);
  for (const Tet& t : mesh.tets)
    for (int k = 0; k < 4; ++k) used[t[k]] = 1;
  for (int i = 0; i < n; ++i)
    if (used[i]) ++size[part[i]];
  for (const int i : pinned) held[part[i]] = 1;
  std::vector<std::pair<int, int>> parts;
  for (int i = 0; i < n; ++i)
    if (size[i] > 0 && part[i] == i && !held[i]) parts.emplace_back(i, size[i]);
  return parts;
}

bool derived_scene_name(const std::string& name, const std::string& base) {
  for (const char* derived : {"_l", "_q"})
    if (name.size() > base.size() + 2 && name.compare(0, base.size(), base) == 0 &&
        name.compare(base.size(), 2, derived) == 0 && std::isdigit(static_cast<unsigned char>(name[base.size() + 2])))
      return true;
  return false;
}

bool is_data_name(const std::string& s) { return s.find('/') == std::string::npos && fs::path(s).extension().empty(); }

fs::path resolve_data_path(const std::string& name_or_path, const std::string& folder, const std::string& extension,
                           const std::string& what) {
  if (name_or_path.empty()) throw InputError(what + ": expected a " + what + " name or a path, got nothing");
  std::error_code ec;
  if (!is_data_name(name_or_path)) {
    if (const std::string why = not_a_file(name_or_path); !why.empty())
      throw InputError(name_or_path + ": " + (why == "file not found" ? what + " file not found" : why));
    return name_or_path;
  }
  std::string looked;
  for (const fs::path& root : data_roots()) {
    const fs::path p = root / folder / (name_or_path + extension);
    if (fs::is_regular_file(p, ec)) return p;
    // There but no file to read (a link in a loop or to nothing, a folder): said, not passed over
    // for a file of that name in a later folder, nor called missing.
    if (fs::symlink_status(p, ec).type() != fs::file_type::not_found && !ec)
      throw InputError(p.string() + ": " + not_a_file(p.string()));
    looked += (looked.empty() ? "" : ", ") + p.string();
  }
  // A name is looked up, never read from the working folder: what is there of that name is said.
  std::string here;
  if (fs::symlink_status(name_or_path, ec).type() != fs::file_type::not_found && !ec)
    here = fs::is_directory(name_or_path, ec) ? "; " + name_or_path + " in the working folder is a folder"
                                               : "; a name is looked up there: give the file in the working folder as ./" +
                                                     name_or_path;
  throw InputError(name_or_path + ": no such " + what + " (looked for " + looked + ")" + here);
}

std::optional<std::string> hidden_builtin(const std::string& name, const fs::path& resolved, const std::string& folder,
                                          const std::string& extension, const std::string& what) {
  if (!is_data_name(name)) return std::nullopt;
  const fs::path builtin = fs::path(kSourceDir) / folder / (name + extension);
  std::error_code ec;
  if (!fs::is_regular_file(builtin, ec) || fs::equivalent(builtin, resolved, ec)) return std::nullopt;
  // A copy is the same data either way (a recording may be large: sizes first, then in blocks).
  const auto same_bytes = [&ec](const fs::path& a, const fs::path& b) {
    if (fs::file_size(a, ec) != fs::file_size(b, ec) || ec) return false;
    std::ifstream x(a, std::ios::binary), y(b, std::ios::binary);
    std::vector<char> bx(1 << 16), by(1 << 16);
    while (x && y) {
      x.read(bx.data(), static_cast<std::streamsize>(bx.size()));
      y.read(by.data(), static_cast<std::streamsize>(by.size()));
      if (x.gcount() != y.gcount() || !std::equal(bx.begin(), bx.begin() + x.gcount(), by.begin())) return false;
    }
    return x.eof() && y.eof();
  };
  if (same_bytes(builtin, resolved)) return std::nullopt;
  return name + ": the " + what + " " + resolved.string() + " is used, not ebh's own " + builtin.string() +
         ", which differs: a name is looked up in $EBH_DATA_DIR, the working directory, then ebh's source tree "
         "(give a path to choose)";
}

std::vector<fs::path> data_roots() {
  std::error_code ec;
  std::vector<fs::path> roots;
  auto add = [&roots](fs::path p) {
    if (!p.empty() && std::find(roots.begin(), roots.end(), p) == roots.end()) roots.push_back(std::move(p));
  };
  if (const char* env = std::getenv("EBH_DATA_DIR"); env && *env) add(env);
  add(fs::current_path(ec));
  add(kSourceDir);
  return roots;
}

std::vector<fs::path> data_files(const std::string& folder, const std::string& extension) {
  std::vector<fs::path> found;
  std::vector<std::string> names;
  for (const fs::path& root : data_roots()) {
    std::vector<fs::path> here;
    std::error_code ec;
    for (fs::directory_iterator it(root / folder, ec), end; !ec && it != end; it.increment(ec))
      if (it->path().extension() == extension && fs::is_regular_file(it->path(), ec)) here.push_back(it->path());
    std::sort(here.begin(), here.end());
    for (fs::path& p : here) {
      const std::string name = p.stem().string();
      if (std::find(names.begin(), names.end(), name) != names.end()) continue;  // hidden by an earlier root
      names.push_back(name);
      found.push_back(std::move(p));
    }
  }
  return found;
}

fs::path resolve_scene_path(const std::string& name_or_path) {
  return resolve_data_path(name_or_path, "scenarios", ".yaml", "scene");
}

fs::path resolve_recording_scene(const std::string& attribute, const std::string& recording) {
  const std::string where = recording + ": its scene attribute '" + attribute + "'";
  if (attribute.empty())
    throw InputError(recording + ": its scene attribute is empty: the recording names no scene (`ebh import LOG -o REC "
                     "--scene SCENE` records it)");
  // A relative path is the recording's own (scene_attribute_for writes it so): only beside it (a
  // recording read through a link: beside the link's target, where it was written). A file of that
  // name in the working folder is another scene (a copy with other stiffnesses), which a
  // validation once replayed without a word.
  if (!is_data_name(attribute) && fs::path(attribute).is_relative()) {
    const fs::path beside = joined_path(own_folder(recording), attribute);
    std::error_code ec;
    if (fs::is_regular_file(beside, ec)) return beside;
    throw InputError(where + ": no such file beside the recording (" + beside.string() +
                     "): move the scene there, or replay the recording with the scene named");
  }
  try {
    return resolve_scene_path(attribute);
  } catch (const InputError& e) {
    throw InputError(where + ": " + e.what());
  }
}

std::string scene_attribute_for(const std::string& given, const fs::path& scene_file, const fs::path& output) {
  if (is_data_name(given)) return given;
  std::error_code ec;
  const fs::path folder = fs::absolute(output, ec).parent_path();
  const fs::path rel = fs::absolute(scene_file, ec).lexically_normal().lexically_relative(folder.lexically_normal());
  return rel.empty() ? fs::absolute(scene_file, ec).lexically_normal().string() : rel.string();
}

std::string data_reference_from(const std::string& given, const fs::path& folder) {
  if (is_data_name(given) || fs::path(given).is_absolute()) return given;
  return joined_path(folder, given).string();
}

std::string scene_attribute_from(const std::string& given, const fs::path& folder, const fs::path& output) {
  if (is_data_name(given)) return given;
  return scene_attribute_for(given, resolve_scene_path(data_reference_from(given, folder)), output);
}

}  // namespace ebh

namespace ebh {
namespace {

/// The number that, read from a file in `unit` (metres per unit) and multiplied by it as
/// SpecReader does, gives back exactly `metres`: metres / unit, nudged by an ulp or two when the
/// division rounds the other way, so a resolved scene reloads to the same bits.
double in_file_unit(double metres, double unit) {
  double y = metres / unit;
  for (int i = 0; i < 4 && y * unit != metres; ++i)
    y = std::nextafter(y, y * unit < metres ? HUGE_VAL : -HUGE_VAL);
  return y;
}

}  // namespace

std::string resolved_scene_yaml(const SceneSpec& s) {
  const double u = s.unit;
  YAML::Emitter y;
  y.SetDoublePrecision(17);  // every double reads back to the same bits
  const ToolSpec& t = s.tool;
  auto length = [&](double metres) { return in_file_unit(metres, u); };
  auto tool_length = [&](double metres) { return in_file_unit(metres, t.unit); };
  // a vector of lengths in `unit` metres per unit (0: not a length)
  auto vec = [&](const Vec3d& v, double unit) {
    y << YAML::Flow << YAML::BeginSeq;
    for (double c : {v.x, v.y, v.z}) y << (unit > 0 ? in_file_unit(c, unit) : c);
    y << YAML::EndSeq;
  };
  // A pinned or stiffness region: its kind's key and value, in the map being written.
  auto region = [&](const PinRegion& r) {
    y << YAML::Key << region_name(r.kind) << YAML::Value;
    switch (r.kind) {
      case PinRegion::Kind::Group: y << r.group; break;
      case PinRegion::Kind::Box:
        y << YAML::BeginMap << YAML::Key << "min" << YAML::Value;
        vec(r.a, u);
        y << YAML::Key << "max" << YAML::Value;
        vec(r.b, u);
        y << YAML::EndMap;
        break;
      case PinRegion::Kind::Sphere:
        y << YAML::BeginMap << YAML::Key << "center" << YAML::Value;
        vec(r.a, u);
        y << YAML::Key << "radius" << YAML::Value << length(r.b.x) << YAML::EndMap;
        break;
      case PinRegion::Kind::Halfspace:
        y << YAML::BeginMap << YAML::Key << "point" << YAML::Value;
        vec(r.a, u);
        y << YAML::Key << "normal" << YAML::Value;
        vec(r.b, 0);
        y << YAML::EndMap;
        break;
    }
  };
  y << YAML::BeginMap;
  y << YAML::Key << "name" << YAML::Value << s.name;
  y << YAML::Key << "description" << YAML::Value << s.description;
  y << YAML::Key << "unit" << YAML::Value << s.unit_name;
  y << YAML::Key << "mesh" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "physical" << YAML::Value << fs::absolute(s.physical_mesh).lexically_normal().string();
  y << YAML::Key << "virtual" << YAML::Value
    << (s.virtual_mesh ? fs::absolute(*s.virtual_mesh).lexically_normal().string() : std::string("boundary"));
  y << YAML::Key << "virtual_refine" << YAML::Value << s.virtual_refine;
  if (s.min_part_tets > 0) y << YAML::Key << "min_part_tets" << YAML::Value << s.min_part_tets;
  y << YAML::Key << "unit" << YAML::Value << s.mesh_unit_name;
  y << YAML::Key << "transform" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "scale" << YAML::Value << s.mesh_transform.scale;
  y << YAML::Key << "rotvec_deg" << YAML::Value;
  vec(s.mesh_transform.rotvec_deg, 0);
  y << YAML::Key << "translate" << YAML::Value;
  vec(s.mesh_transform.translate, s.mesh_unit);
  y << YAML::EndMap << YAML::EndMap;
  y << YAML::Key << "material" << YAML::Value << YAML::BeginMap << YAML::Key << "density" << YAML::Value << s.density
    << YAML::EndMap;
  const Stiffness& k = s.stiffness;
  y << YAML::Key << "stiffness" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "k_vol" << YAML::Value << k.k_vol << YAML::Key << "k_s" << YAML::Value << k.k_s;
  y << YAML::Key << "k_svc" << YAML::Value << k.k_svc << YAML::Key << "k_con" << YAML::Value << k.k_con;
  y << YAML::Key << "k_vcs" << YAML::Value << k.k_vcs << YAML::Key << "k_vct" << YAML::Value << k.k_vct;
  if (k.k_det > 0) y << YAML::Key << "k_det" << YAML::Value << k.k_det;
  if (!s.stiffness_regions.empty()) {
    y << YAML::Key << "regions" << YAML::Value << YAML::BeginSeq;
    for (const StiffnessRegion& m : s.stiffness_regions) {
      y << YAML::BeginMap;
      region(m.region);
      y << YAML::Key << "k_vol" << YAML::Value << m.k_vol << YAML::EndMap;
    }
    y << YAML::EndSeq;
  }
  y << YAML::EndMap;
  y << YAML::Key << "gravity" << YAML::Value;
  vec(s.gravity, 0);
  y << YAML::Key << "damping" << YAML::Value << s.damping;
  y << YAML::Key << "pinned" << YAML::Value << YAML::BeginSeq;
  for (const PinRegion& r : s.pinned) {
    y << YAML::BeginMap;
    region(r);
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
  y << YAML::Key << "tool" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "unit" << YAML::Value << t.unit_name;
  y << YAML::Key << "kind" << YAML::Value << (t.kind == ToolSpec::Kind::Hook ? "hook" : "forceps");
  y << YAML::Key << "shaft_radius" << YAML::Value << tool_length(t.shaft_radius);
  y << YAML::Key << "shaft_length" << YAML::Value << tool_length(t.shaft_length);
  if (t.kind == ToolSpec::Kind::Hook) {  // the other kind's block shapes nothing
    y << YAML::Key << "hook" << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "tip_length" << YAML::Value << tool_length(t.hook.tip_length);
    y << YAML::Key << "tip_radius" << YAML::Value << tool_length(t.hook.tip_radius) << YAML::EndMap;
  } else {
    const ForcepsSpec& f = t.forceps;
    y << YAML::Key << "forceps" << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "jaw_length" << YAML::Value << tool_length(f.jaw_length);
    y << YAML::Key << "jaw_width" << YAML::Value << tool_length(f.jaw_width);
    y << YAML::Key << "jaw_thickness" << YAML::Value << tool_length(f.jaw_thickness);
    y << YAML::Key << "jaw_max_angle_deg" << YAML::Value << f.jaw_max_angle_deg;
    y << YAML::Key << "grasp_threshold" << YAML::Value << f.grasp_threshold;
    y << YAML::Key << "release_threshold" << YAML::Value << f.release();  // in effect, given or not
    y << YAML::Key << "soft_margin" << YAML::Value << tool_length(f.soft_margin);
    y << YAML::Key << "eta" << YAML::Value << f.eta << YAML::EndMap;
  }
  y << YAML::Key << "force_limit" << YAML::Value << t.force_limit;
  y << YAML::Key << "torque_limit" << YAML::Value << t.torque_limit;
  y << YAML::Key << "newton_iterations" << YAML::Value << t.newton_iterations;
  y << YAML::Key << "newton_calls" << YAML::Value;
  if (t.newton_calls == 0) y << "all"; else y << t.newton_calls;
  y << YAML::Key << "max_step" << YAML::Value << tool_length(t.max_step);
  y << YAML::Key << "max_step_rotation_deg" << YAML::Value << t.max_step_rotation_deg;
  y << YAML::Key << "stabilization" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "translation" << YAML::Value << t.stabilization_translation;
  y << YAML::Key << "rotation" << YAML::Value << t.stabilization_rotation << YAML::EndMap;
  y << YAML::EndMap;
  y << YAML::Key << "time" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "haptic_hz" << YAML::Value << s.haptic_hz;
  y << YAML::Key << "physical_hz" << YAML::Value << s.physical_hz;
  y << YAML::Key << "interpolate_physical" << YAML::Value << s.interpolate_physical << YAML::EndMap;
  const SolverSpec& sv = s.solver;
  y << YAML::Key << "solver" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "method" << YAML::Value
    << (sv.method == SolverSpec::Method::Jacobi ? "jacobi" : sv.method == SolverSpec::Method::Chebyshev ? "chebyshev" : "direct");
  y << YAML::Key << "diagonal" << YAML::Value << (sv.diagonal == SolverSpec::Diagonal::Bounded ? "bounded" : "plain");
  y << YAML::Key << "physical_iterations" << YAML::Value << sv.physical_iterations;
  y << YAML::Key << "virtual_iterations" << YAML::Value << sv.virtual_iterations;
  y << YAML::Key << "chebyshev_rho";
  if (sv.chebyshev_rho_auto) y << YAML::Value << "auto";
  else y << YAML::Value << sv.chebyshev_rho;
  y << YAML::Key << "physical_tolerance" << YAML::Value << sv.physical_tolerance;
  y << YAML::Key << "physical_max_iterations" << YAML::Value << sv.physical_max_iterations;
  y << YAML::Key << "recovery" << YAML::Value << (sv.recovery == SolverSpec::Recovery::Direct ? "direct" : "none");
  y << YAML::Key << "recovery_residual" << YAML::Value << sv.recovery_residual;
  y << YAML::Key << "active_region" << YAML::Value << sv.active_region / u;
  y << YAML::Key << "physical_region" << YAML::Value << sv.physical_region / u;
  y << YAML::Key << "sleep" << YAML::Value << sv.sleep / u;
  y << YAML::Key << "virtual_damping" << YAML::Value << sv.virtual_damping << YAML::EndMap;
  y << YAML::Key << "contact" << YAML::Value << (s.contact == ContactModel::Surface ? "surface" : "vertices");
  y << YAML::Key << "camera" << YAML::Value << YAML::BeginMap << YAML::Key << "eye" << YAML::Value;
  vec(s.camera.eye, u);
  y << YAML::Key << "target" << YAML::Value;
  vec(s.camera.target, u);
  y << YAML::Key << "up" << YAML::Value;
  vec(s.camera.up, 0);
  y << YAML::Key << "fov_deg" << YAML::Value << s.camera.fov_deg << YAML::EndMap;
  y << YAML::Key << "stages" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "grasp" << YAML::Value << s.stages.grasp;
  y << YAML::Key << "frames" << YAML::Value << s.stages.frames;
  y << YAML::Key << "settle" << YAML::Value << s.stages.settle << YAML::EndMap;
  y << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

std::string describe_pin_region(const PinRegion& r) {
  char b[256];
  switch (r.kind) {
    case PinRegion::Kind::Group: return "group " + r.group;
    case PinRegion::Kind::Box:
      std::snprintf(b, sizeof b, "box min [%.17g, %.17g, %.17g] max [%.17g, %.17g, %.17g] m", r.a.x, r.a.y, r.a.z,
                    r.b.x, r.b.y, r.b.z);
      break;
    case PinRegion::Kind::Sphere:
      std::snprintf(b, sizeof b, "sphere center [%.17g, %.17g, %.17g] radius %.17g m", r.a.x, r.a.y, r.a.z, r.b.x);
      break;
    case PinRegion::Kind::Halfspace:
      std::snprintf(b, sizeof b, "halfspace point [%.17g, %.17g, %.17g] m normal [%.17g, %.17g, %.17g]", r.a.x, r.a.y,
                    r.a.z, r.b.x, r.b.y, r.b.z);
      break;
  }
  return b;
}

DegradeReport degrade_physical_mesh(Scene& scene, const DegradeOptions& options) {
  std::vector<std::uint8_t> fixed(scene.physical.vertices.size(), 0);
  for (int p : scene.pinned) fixed[p] = 1;
  return degrade_mesh_quality(scene.physical, fixed, options);
}

}  // namespace ebh
