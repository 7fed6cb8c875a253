// `ebh scene init`: writes the scene text for a user's mesh and loads it back (scene_init.hpp).
#include "scene/scene_init.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <system_error>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "core/units.hpp"

namespace ebh {
namespace {

namespace fs = std::filesystem;

/// The shortest text that reads back to v.
std::string fmt(double v) {
  char b[32];
  const auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

/// v to 4 significant digits (sizes: where exactness buys nothing).
std::string round4(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

/// A coordinate v of a mesh of `size` (> 0) to 4 significant digits of the size (1/1000 of it or
/// finer), wherever the mesh lies: 4 digits of the coordinate itself put the pin cut of a mesh at z
/// = 100001.3 .. 100021.3 mm at 1e+05, below all of it, and a camera's eye and target at one point.
std::string round_within(double v, double size) {
  if (!(size > 0) || !std::isfinite(size)) return fmt(v);
  const double step = std::floor(std::log10(size)) - 3;  // the last digit kept, as a power of 10
  const double lead = std::floor(std::log10(std::max(std::fabs(v), size)));
  char b[40];
  std::snprintf(b, sizeof b, "%.*g", static_cast<int>(std::clamp(lead - step + 1, 1.0, 17.0)), v);
  return b;
}

/// The coordinates of a mesh of `size` as round_within writes them: a function for vec().
struct Within {
  double size;
  std::string operator()(double v) const { return round_within(v, size); }
};

template <class Format = std::string (*)(double)>
std::string vec(const Vec3d& v, Format f = fmt) {
  std::string s = "[";
  s += f(v.x);
  s += ", ";
  s += f(v.y);
  s += ", ";
  s += f(v.z);
  return s + "]";
}

/// A YAML double-quoted scalar of UTF-8 text: a quote and a backslash escaped, and the control
/// characters (a line break in a file name: raw, YAML folds it to a space, naming another file).
std::string quoted(const std::string& s) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') out += "\\n";
    else if (c == '\t') out += "\\t";
    else if (c == '\r') out += "\\r";
    else if (u < 0x20 || u == 0x7f) out += std::string("\\x") + kHex[u >> 4] + kHex[u & 0xf];
    else out += c;
  }
  return out + "\"";
}

/// Refuses a name the scene file must hold exactly (a file's path, a group of the mesh) that is not
/// UTF-8 text, which the scene file is: `what` says whose name it is ("MESH: the mesh file's name").
void require_utf8(const std::string& name, const std::string& what, const std::string& fix) {
  const std::string byte = first_invalid_utf8_byte(name);
  if (byte.empty()) return;
  throw InputError(what + " is not UTF-8 text (byte " + byte + ", a Latin-1 name?), which a scene file cannot hold: " +
                   fix);
}

std::string join(const std::vector<std::string>& v, const std::string& sep = ", ") {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

/// The numbers of a --pin SPEC after its "kind:", each finite.
std::vector<double> pin_numbers(const std::string& spec, const std::string& list, std::size_t count, const std::string& form) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = list.find(',', start);
    const std::string item = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    double v = 0;
    const char* b = item.data();
    const char* e = item.data() + item.size();
    if (b != e && *b == '+') ++b;
    const auto [p, ec] = std::from_chars(b, e, v);
    if (ec != std::errc() || p != e || b == e || !std::isfinite(v))
      throw InputError("--pin " + spec + ": '" + item + "' is not a finite number (expected " + form + ")");
    out.push_back(v);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (out.size() != count)
    throw InputError("--pin " + spec + ": expected " + form + " (" + std::to_string(count) + " numbers), got " +
                     std::to_string(out.size()));
  return out;
}

/// A --pin SPEC as a region (metres), and the YAML of it (in the scene's unit, as written).
struct Pin {
  PinRegion region;
  std::string yaml;
};

Pin parse_pin(const std::string& spec, double unit, const std::string& mesh_name) {
  const std::size_t colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  Pin pin;
  if (kind == "group") {
    if (rest.empty()) throw InputError("--pin " + spec + ": expected group:NAME");
    require_utf8(rest, "--pin " + spec + ": the group's name",
                 "rename the group in " + mesh_name + " (or pin a box or sphere)");
    pin.region.kind = PinRegion::Kind::Group;
    pin.region.group = rest;
    pin.yaml = "group: " + quoted(rest);
  } else if (kind == "sphere") {
    const auto v = pin_numbers(spec, rest, 4, "sphere:x,y,z,r");
    if (!(v[3] > 0)) throw InputError("--pin " + spec + ": the radius must be > 0");
    pin.region.kind = PinRegion::Kind::Sphere;
    pin.region.a = Vec3d{v[0], v[1], v[2]} * unit;
    pin.region.b = {v[3] * unit, 0, 0};
    pin.yaml = "sphere: {center: " + vec({v[0], v[1], v[2]}) + ", radius: " + fmt(v[3]) + "}";
  } else if (kind == "box") {
    const auto v = pin_numbers(spec, rest, 6, "box:x0,y0,z0,x1,y1,z1");
    if (!(v[0] <= v[3] && v[1] <= v[4] && v[2] <= v[5]))
      throw InputError("--pin " + spec + ": expected x0 <= x1, y0 <= y1, z0 <= z1 (the box's min corner first)");
    pin.region.kind = PinRegion::Kind::Box;
    pin.region.a = Vec3d{v[0], v[1], v[2]} * unit;
    pin.region.b = Vec3d{v[3], v[4], v[5]} * unit;
    pin.yaml = "box: {min: " + vec({v[0], v[1], v[2]}) + ", max: " + vec({v[3], v[4], v[5]}) + "}";
  } else {
    throw InputError("--pin " + spec + ": expected sphere:x,y,z,r, box:x0,y0,z0,x1,y1,z1 or group:NAME");
  }
  return pin;
}

/// The tool of a new scene, in mm: a 5 mm laparoscopic instrument (shaft 5 mm across, 330 mm
/// working length), an L-hook's 6 mm tip of 1 mm radius, a grasper's 20 mm jaws 2 mm thick.
/// Its force limit (N) and thinnest part (m: the tip's radius, half a jaw's thickness) set the
/// contact stiffness the scene writes (surface contact's floor, docs/MODEL.md).
constexpr double kInitForceLimit = 3.3, kInitThinnestPart = 0.001;
std::string tool_yaml(bool forceps) {
  std::string y =
      "tool:\n"
      "  unit: mm                      # the tool's sizes, whatever the mesh's unit\n"
      "  kind: " + std::string(forceps ? "forceps" : "hook") + "\n"
      "  shaft_radius: 2.5             # a 5 mm instrument\n"
      "  shaft_length: 330             # its usual working length\n";
  if (forceps) {
    y += "  forceps: {jaw_length: 20, jaw_width: 5, jaw_thickness: 2, jaw_max_angle_deg: 30,\n"
         "            grasp_threshold: 0.2, release_threshold: 0.3, soft_margin: 2, eta: 1.0}\n";
  } else {
    y += "  hook: {tip_length: 6, tip_radius: 1.0}   # the L-hook's bent tip\n";
  }
  y += "  force_limit: " + fmt(kInitForceLimit) + "              # N (Geomagic Touch)\n"
       "  newton_iterations: 1\n"
       "  max_step: 0.5                 # mm per Newton step\n"
       "  max_step_rotation_deg: 0.5\n";
  return y;
}

}  // namespace

const std::vector<TissuePreset>& tissue_presets() {
  static const std::vector<TissuePreset> presets = {
      {"liver", 2000, 1080, "MR elastography of healthy livers: shear modulus about 2 kPa"},
      {"gallbladder", 3000, 1070, "a bile-filled sac whose wall stiffens it: between liver and uterus (no whole-organ measurement)"},
      {"uterus", 4000, 1100, "elastography of the non-pregnant myometrium: shear modulus a few kPa"},
      {"generic", 3000, 1000, "the committed organ scenes' value: soft abdominal tissue"},
  };
  return presets;
}

std::string shell_word(const std::string& a) {
  if (!a.empty() && a.find_first_of(" \t\n\r'\"$`\\;&|<>()*?[]{}~#!") == std::string::npos) return a;
  std::string q = "'";
  for (const char c : a)  // a line break would end the YAML comment the command stands in
    q += c == '\'' ? std::string("'\\''") : c == '\n' ? std::string("\\n") : c == '\r' ? std::string("\\r") : std::string(1, c);
  return q + "'";
}

SceneInit make_scene(const SceneInitOptions& o) {
  const std::optional<double> unit_m = length_unit_metres(o.unit);
  if (!unit_m) throw InputError("--unit: expected one of " + std::string(kLengthUnitList) + ", got '" + o.unit + "'");
  const double unit = *unit_m;
  const auto& presets = tissue_presets();
  const auto preset = std::find_if(presets.begin(), presets.end(), [&](const TissuePreset& p) { return p.name == o.tissue; });
  if (preset == presets.end()) throw InputError("--tissue: expected liver, gallbladder, uterus or generic, got '" + o.tissue + "'");
  if (o.tool != "hook" && o.tool != "forceps") throw InputError("--tool: expected hook or forceps, got '" + o.tool + "'");
  const bool forceps = o.tool == "forceps";

  // The mesh as the new scene will load it (mesh errors name the mesh file and line).
  SceneSpec probe;
  probe.file = o.out;
  probe.physical_mesh = o.mesh;
  probe.unit = probe.mesh_unit = probe.tool.unit = unit;
  probe.unit_name = probe.mesh_unit_name = probe.tool.unit_name = o.unit;
  Scene mesh_only = build_scene(probe);
  // Specks of a segmentation apart from the organ would float free (or stop a replay under
  // gravity): dropped at load (loaded again without them), the scene saying so.
  const std::vector<std::pair<int, int>> specks = speck_parts(mesh_only.physical);
  // Every part a speck: no organ to keep (a tet soup, whose tets share no vertex: an export that
  // writes each element's nodes apart), which the drop below would refuse by a key the user never
  // wrote.
  std::size_t speck_tets = 0;
  int largest = 0;
  for (const auto& [lowest, tets] : specks) {
    speck_tets += static_cast<std::size_t>(tets);
    largest = std::max(largest, tets);
  }
  if (!specks.empty() && speck_tets == mesh_only.physical.tets.size())
    throw InputError(o.mesh.string() + ": its " + std::to_string(speck_tets) + " tets fall apart into " +
                     std::to_string(specks.size()) + " parts of at most " + std::to_string(largest) +
                     (largest == 1 ? " tet" : " tets") + ", none an organ" +
                     (specks.size() == speck_tets ? " (no two tets share a vertex: each element's nodes were written "
                                                    "apart; merge the coincident nodes, e.g. Gmsh's Coherence)"
                                                  : ""));
  for (const auto& [lowest, tets] : specks) probe.min_part_tets = std::max(probe.min_part_tets, tets + 1);
  const TetMesh whole = specks.empty() ? TetMesh{} : mesh_only.physical;  // with the specks, for the pins' errors
  if (!specks.empty()) mesh_only = build_scene(probe);
  const TetMesh& mesh = mesh_only.physical;
  const std::size_t n = mesh.vertices.size();
  const BoundingBox box = bounding_box(mesh.vertices);
  const Within coordinate{box.diagonal() / unit};  // in the scene's unit, to 1/1000 of the mesh's size
  const std::string mesh_name = o.mesh.string();

  // Pinned regions: the user's, each checked, or the lowest layer along gravity (-z).
  std::vector<std::string> pin_yaml;
  std::set<int> pinned;
  std::string pin_note, pin_warning;
  for (const std::string& spec : o.pins) {
    const Pin pin = parse_pin(spec, unit, mesh_name);
    const std::vector<int> v = region_vertices(mesh, pin.region);
    if (v.empty() && !specks.empty() && !region_vertices(whole, pin.region).empty())
      throw InputError("--pin " + spec + ": the region holds only vertices of the parts apart from the organ that " +
                       "scene init drops as specks (" + std::to_string(specks.size()) +
                       (specks.size() == 1 ? " part" : " parts") + " of under " +
                       shown_number(100 * kSpeckFraction) + "% of the mesh's tets each: mesh.min_part_tets: " +
                       std::to_string(probe.min_part_tets) + "): pin a region of the organ, or keep the parts " +
                       "(mesh.min_part_tets: 0 in the scene written)");
    if (v.empty()) {
      if (pin.region.kind == PinRegion::Kind::Group) {
        const std::vector<std::string> known = known_group_names(mesh);
        if (std::find(known.begin(), known.end(), pin.region.group) == known.end())
          throw InputError("--pin " + spec + ": " + mesh_name + " has no physical group '" + pin.region.group + "' (" +
                           (known.empty() ? std::string("it has no groups") : "its groups: " + known_groups_text(mesh)) + ")" +
                           lower_dimension_group_note(mesh, pin.region.group) + file_groups_note(o.mesh));
        throw InputError("--pin " + spec + ": the region pins no vertex of " + mesh_name + ": " +
                         group_without_elements_note(mesh));
      }
      throw InputError("--pin " + spec + ": the region pins no vertex of " + mesh_name + " (its bounding box: " +
                       vec(box.lo / unit, coordinate) + " .. " + vec(box.hi / unit, coordinate) + " " + o.unit + ")");
    }
    pinned.insert(v.begin(), v.end());
    pin_yaml.push_back(pin.yaml);
  }
  if (o.pins.empty()) {
    // the vertices within 5% of the height of the lowest point, widened until at least 3 (a
    // triangle: no rigid motion left) are held
    const double height = box.hi.z - box.lo.z;
    const Vec3d centre = 0.5 * (box.lo + box.hi);
    // the cut to 1/1000 of the height (to 1/1000 of a thin slab's diagonal it could round below it)
    const Within cut_text{height / unit};
    std::size_t first_layer = 0;  // the vertices the first band (5%) held
    for (double fraction = 0.05; pinned.size() < 3; fraction *= 2) {
      if (fraction >= 1) throw InputError(mesh_name + ": no layer of vertices at the bottom to pin; give --pin");
      // the point as the scene writes it, and the region as the scene will read it
      const std::string px = coordinate(centre.x / unit), py = coordinate(centre.y / unit),
                        cut = cut_text((box.lo.z + fraction * height) / unit);
      PinRegion r;
      r.kind = PinRegion::Kind::Halfspace;
      r.a = Vec3d{std::stod(px), std::stod(py), std::stod(cut)} * unit;
      r.b = {0, 0, -1};
      const std::vector<int> v = region_vertices(mesh, r);
      pinned = std::set<int>(v.begin(), v.end());
      if (fraction == 0.05) first_layer = pinned.size();
      if (pinned.size() >= 3) {
        pin_yaml = {"halfspace: {point: [" + px + ", " + py + ", " + cut + "], normal: [0, 0, -1]}"};
        pin_note = "no --pin given: pinned the lowest " + fmt(fraction * 100) + "% of the mesh's height (z <= " +
                   cut + " " + o.unit + ", " + std::to_string(pinned.size()) + " vertices); give --pin to choose";
        // Widened: a stray vertex or a spike below the organ holds the band's bottom, and the band
        // that reaches the organ's own bottom layer may hold much of it (one node of a 40 mm cube
        // pulled 30 mm down: the lowest 80%, 196 of 343 vertices, the peak force 1.28 -> 1.86 N).
        if (fraction > 0.05) {
          int lowest = 0;
          for (std::size_t a = 1; a < n; ++a)
            if (mesh.vertices[a].z < mesh.vertices[lowest].z) lowest = static_cast<int>(a);
          pin_warning = mesh_name + ": no --pin given: the lowest 5% of the mesh's height holds " +
                        std::to_string(first_layer) + (first_layer == 1 ? " vertex" : " vertices") +
                        " (the lowest, vertex " + std::to_string(lowest) + ", at z = " +
                        cut_text(mesh.vertices[lowest].z / unit) + " " + o.unit +
                        ": a stray vertex or a spike below the organ?), so the pinned band was widened to the lowest " +
                        fmt(fraction * 100) + "%: " + std::to_string(pinned.size()) + " of " + std::to_string(n) +
                        " vertices held still; give --pin to choose";
        }
      }
    }
  } else {
    pin_note = "pinned " + std::to_string(pinned.size()) + " vertices (" + join(o.pins, ", ") + ")";
  }
  if (pinned.size() == n)
    throw InputError("--pin: the regions pin all " + std::to_string(n) + " vertices of " + mesh_name +
                     ": nothing could move; pin a smaller region");

  // The camera: the bounding box from the front (-y) and above (+z), all of it in a 40 degree view.
  const Vec3d centre = 0.5 * (box.lo + box.hi) / unit;
  const double diagonal = box.diagonal() / unit;
  const double distance = 1.2 * (0.5 * diagonal) / std::tan(20.0 * std::numbers::pi / 180.0);
  const Vec3d eye = centre + distance * normalized(Vec3d{0, -1, 0.6});

  std::error_code ec;
  fs::path mesh_path = fs::absolute(o.mesh, ec);
  const fs::path written = o.written.empty() ? o.out : o.written;
  const fs::path relative = fs::relative(mesh_path, fs::absolute(written, ec).parent_path(), ec);
  // relative when the mesh sits in the scene's folder or below it, so the two move together
  if (!ec && !relative.empty() && *relative.begin() != "..") mesh_path = relative;
  // The scene names the mesh file exactly, and is UTF-8 text.
  require_utf8(mesh_path.string(),
               mesh_name + (first_invalid_utf8(o.mesh.filename().string()) != std::string::npos
                                ? ": the mesh file's name"
                                : ": the mesh file's path as the scene names it (" + mesh_path.string() + ")"),
               "rename it");

  const std::string name = o.out.stem().string();
  require_utf8(name, "-o " + o.out.string() + ": the scene's name (its file's name)", "rename it");
  const auto arg = shell_word;
  std::string cmd = "ebh scene init " + arg(o.mesh.string()) + " -o " + arg(o.out.string()) + " --unit " + arg(o.unit) +
                    " --tissue " + arg(o.tissue) + " --tool " + arg(o.tool);
  for (const auto& p : o.pins) cmd += " --pin " + arg(p);
  std::string y;
  // "text  # comment", the comments lined up
  auto line = [&y](const std::string& text, const std::string& comment) {
    y += text + std::string(text.size() < 32 ? 32 - text.size() : 1, ' ') + "# " + comment + "\n";
  };
  y += "# Made by `" + escape_unprintable(cmd) + "`.\n";  // a comment, read by people
  y += "# Physical mesh: " + std::to_string(n) + " vertices, " + std::to_string(mesh.tets.size()) +
       " tets; bounding box " + vec(box.lo / unit, coordinate) + " .. " + vec(box.hi / unit, coordinate) + " " + o.unit +
       " (diagonal " + round4(diagonal) + ").\n";
  y += "# Schema: lib/scene/scene.hpp; units and the mesh transform: docs/FORMATS.md; stiffnesses: docs/MODEL.md.\n";
  y += "name: " + quoted(name) + "\n";
  y += "description: " + quoted(o.mesh.filename().string() + ": " + o.tissue + ", " + o.tool) + "\n";
  line("unit: " + o.unit, "pinned regions and camera (world coordinates)");
  y += "mesh:\n";
  y += "  physical: " + quoted(mesh_path.string()) + "\n";
  line("  unit: " + o.unit, "the mesh file's unit");
  y += "  # transform: {scale: 1, rotvec_deg: [0, 0, 0], translate: [0, 0, 0]}   # places the mesh; pins stay in the world\n";
  line("  virtual: boundary", "the virtual mesh: the physical mesh's surface ...");
  line("  virtual_refine: 1", "... split in 4 per triangle: a finer surface to deform");
  std::string speck_note;
  if (!specks.empty()) {
    speck_note = "dropped " + std::to_string(specks.size()) + (specks.size() == 1 ? " part" : " parts") +
                 " of under " + fmt(100 * kSpeckFraction) + "% of the mesh's tets each (specks of a segmentation?): " +
                 "mesh.min_part_tets: " + std::to_string(probe.min_part_tets) + "; set 0 to keep them";
    line("  min_part_tets: " + std::to_string(probe.min_part_tets),
         std::to_string(specks.size()) + " apart from the organ, each under " + fmt(100 * kSpeckFraction) +
             "% of its tets: dropped at load (0 keeps them)");
  }
  y += "material:\n";
  line("  density: " + fmt(preset->density), "kg/m^3, " + o.tissue);
  line("stiffness:", "SI (docs/MODEL.md)");
  line("  k_vol: " + fmt(preset->k_vol), "Pa, " + o.tissue + ": " + preset->source);
  line("  k_s: 20", "N/m, virtual-mesh edges");
  line("  k_svc: 50", "N/m, virtual vertex to physical mesh");
  // Surface contact renders at least F_limit / (1.5 x the thinnest part) (a lower k_con is
  // raised, and a replay warns): the scene writes what it renders.
  line("  k_con: " + fmt(std::ceil(kInitForceLimit / (1.5 * kInitThinnestPart))),
       "N/m, contact: surface contact's floor for this tool (docs/MODEL.md); vertex contact: the paper's 400");
  line("  k_vcs: 300", "N/m, virtual tool to physical tool");
  line("  k_vct: 0.3", "N m/rad");
  {
    // A mesh of several labelled parts (an organ and a tumour): how to give one its own stiffness.
    std::map<int, long long> tets_of;
    for (int g : mesh.tet_group) ++tets_of[g];
    if (tets_of.size() > 1) {
      y += "  # The mesh's tets are in " + std::to_string(tets_of.size()) + " groups (";
      bool first = true;
      for (const auto& [g, count] : tets_of) {
        const auto named = mesh.group_names.find(g);
        // in a comment: a name's line break or Latin-1 byte escaped, not breaking the YAML
        y += std::string(first ? "" : ", ") +
             (named != mesh.group_names.end() ? escape_unprintable(named->second) : std::to_string(g)) + ": " +
             std::to_string(count) + " tets";
        first = false;
      }
      y += "):\n  # a part of its own stiffness is a region (docs/MODEL.md, \"Parts of another stiffness\"), e.g.\n";
      y += "  # regions:\n  #   - {group: NAME, k_vol: " + fmt(5 * preset->k_vol) + "}   # a tumour ~5x its tissue\n";
    }
  }
  y += "# An organ segmented in situ already has the shape its surroundings hold it in: gravity on top\n";
  y += "# of that would count it twice. Set [0, 0, -9.81] (world z up) to study an unsupported organ.\n";
  y += "gravity: [0, 0, 0]\n";
  y += "damping: 0.05\n";
  if (o.pins.empty()) y += "# " + pin_note + "\n";
  y += "pinned:\n";
  for (const auto& p : pin_yaml) y += "  - " + p + "\n";
  y += tool_yaml(forceps);
  y += "# The tool against the virtual mesh's triangles: no part of it slips between vertices, where the\n";
  y += "# paper's vertex contact (`vertices`) lets a tool pushed in at a hand's speed through (docs/MODEL.md).\n";
  y += "contact: surface\n";
  y += "time: {haptic_hz: 1000, physical_hz: 100}\n";
  y += "solver: {method: chebyshev, physical_iterations: 8, virtual_iterations: 4, chebyshev_rho: 0.95}\n";
  y += "camera: {eye: " + vec(eye, coordinate) + ", target: " + vec(centre, coordinate) + ", up: [0, 0, 1], fov_deg: 40}\n";
  y += "stages: {grasp: " + std::string(forceps ? "true" : "false") + ", frames: false}\n";

  SceneInit out;
  out.yaml = y;
  out.scene = load_scene_text(y, written);
  if (!pin_warning.empty()) out.scene.warnings.push_back(pin_warning);
  out.pin_note = pin_note;
  out.speck_note = speck_note;
  // The virtual mesh's edges after virtual_refine's split (each edge halved) against the tool.
  std::vector<double> edges;
  const SurfaceMesh& surface = out.scene.virtual_surface;
  for (const Tri& t : surface.triangles)
    for (int k = 0; k < 3; ++k)
      edges.push_back(0.5 * norm(surface.vertices[t[k]] - surface.vertices[t[(k + 1) % 3]]));
  if (!edges.empty()) {
    std::nth_element(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(edges.size() / 2), edges.end());
    const double median = edges[edges.size() / 2];
    if (median > kInitCoarseEdge * kInitThinnestPart)
      out.resolution_note = "the virtual mesh's edges (median " + round4(median / unit) + " " + o.unit + ") are " +
                            round4(median / kInitThinnestPart) + " times the tool's thinnest part (" +
                            round4(kInitThinnestPart / unit) + " " + o.unit +
                            "): the force shows where the tool lands on a triangle (dips while pressing on, pushes "
                            "sideways); `ebh scene refine " + arg(o.out.string()) + " -o " +
                            arg((o.out.parent_path() / (o.out.stem().string() + "_l1" + o.out.extension().string())).string()) +
                            "` halves them";
  }
  if (out.scene.pinned.size() != pinned.size())  // the file must pin what was checked here
    throw std::logic_error("scene init: the written scene pins " + std::to_string(out.scene.pinned.size()) +
                           " vertices, not the " + std::to_string(pinned.size()) + " checked");
  return out;
}

}  // namespace ebh
