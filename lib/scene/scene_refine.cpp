// `ebh scene refine` (scene/scene_refine.hpp).
#include "scene/scene_refine.hpp"

#include <unistd.h>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "core/error.hpp"
#include "mesh/boundary.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/surface.hpp"
#include "scene/scene.hpp"

namespace ebh {
namespace {

/// "22.5 million", "351 thousand", "8057"; "5.4e+93" beyond a million million; "over 1e308" past
/// what a double holds.
std::string count_words(double n) {
  char buf[48];
  if (!std::isfinite(n)) return "over 1e308";
  if (n >= 1e12) std::snprintf(buf, sizeof buf, "%.3g", n);
  else if (n >= 1e9) std::snprintf(buf, sizeof buf, "%.3g billion", n / 1e9);
  else if (n >= 1'000'000) std::snprintf(buf, sizeof buf, "%.3g million", n / 1e6);
  else if (n >= 10'000) std::snprintf(buf, sizeof buf, "%.3g thousand", n / 1e3);
  else std::snprintf(buf, sizeof buf, "%.0f", n);
  return buf;
}

}  // namespace

std::string gigabytes(double bytes) {
  if (!std::isfinite(bytes)) return "over 1e299 GB";
  char buf[40];
  const double gb = bytes / 1e9;
  std::snprintf(buf, sizeof buf, gb >= 100 && gb < 1e6 ? "%.0f GB" : "%.2g GB", gb);  // 360 GB, not 3.6e+02
  return buf;
}

std::string about_gigabytes(double bytes) { return std::isfinite(bytes) ? "about " + gigabytes(bytes) : gigabytes(bytes); }

double machine_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && size > 0 ? static_cast<double>(pages) * static_cast<double>(size) : 0.0;
}

std::optional<std::string> beyond_machine_memory(double bytes, const std::string& to) {
  const double ram = machine_memory_bytes();
  if (!(ram > 0 && bytes > ram)) return std::nullopt;
  return about_gigabytes(bytes) + " to " + to + ", more than this machine's " + gigabytes(ram) + " of memory";
}

bool refined_within(const RefinedCounts& c, std::int64_t max_tets) {
  // Below 2^53 the estimates are the counts exactly, and so is the limit as a double.
  const double tets = static_cast<double>(std::min(max_tets, kMaxMeshElements));
  return c.tets_estimate <= tets && c.vertices_estimate <= static_cast<double>(kMaxMeshElements);
}

RefineMemory refine_memory(const RefinedCounts& c) {
  // The estimates, which go past the counts' INT64_MAX (a level of 99 asks for ~1e93 tets).
  const double v = std::max(static_cast<double>(c.vertices), c.vertices_estimate),
               t = std::max(static_cast<double>(c.tets), c.tets_estimate);
  RefineMemory m;
  // Writing: the mesh (32 bytes a vertex: position and node id; 20 a tet: corners and group), the
  // previous level's (1/8) and its edge table (48 bytes a parent tet: 6 B a child), and the text
  // (~80 bytes a node line, ~55 an element line) with the doubling of a growing string (x2).
  // Cholecystectomy at level 2 (2.8 million tets): 0.48 GB estimated, 0.44 GB peak measured.
  m.write_bytes = v * (32 + 2 * 80) + t * (20 + 20.0 / 8 + 6 + 2 * 55);
  // Replaying on the CPU: the peak resident memory of `ebh replay` (async, a short window) was
  // 129 MB on the tube at level 1 (64 thousand tets), 523 MB at level 2 (516 thousand) and 2.32 GB
  // on cholecystectomy at level 2 (2.8 million): ~800 bytes a tet and ~80 MB besides.
  m.replay_bytes = 800 * t + 8e7;
  return m;
}

RefinedScene refine_scene(const std::filesystem::path& scene, int levels, const std::filesystem::path& out,
                          std::int64_t max_tets, const std::string& scene_argument, bool keep_virtual) {
  if (levels < 1) throw InputError("--level: expected 1 or more, got " + std::to_string(levels));
  // The scene loads (every check of its own), then the mesh files are read again in their own
  // unit and coordinates, cleaned as build_scene cleans them, and refined there.
  const Scene loaded = load_scene(scene);
  const SceneSpec& spec = loaded.spec;
  TetMesh mesh = read_tet_mesh(spec.physical_mesh);
  std::vector<std::string> said_at_load;  // the load above said them
  clean_physical_mesh(mesh, spec, said_at_load);
  orient_tets(mesh);

  RefinedScene r;
  r.before = refined_counts(mesh, 0);
  r.after = refined_counts(mesh, levels);
  if (!refined_within(r.after, max_tets)) {
    const RefineMemory m = refine_memory(r.after);
    // The user's limit, or else what a mesh can index (which no --max-tets raises).
    const bool over_max = max_tets < kMaxMeshElements && r.after.tets_estimate > static_cast<double>(max_tets);
    // Counts that round to the same words as the limit are said exactly ("13.1 thousand ... over the
    // limit of 13.1 thousand" said nothing).
    std::string tets = count_words(r.after.tets_estimate), limit = count_words(static_cast<double>(max_tets));
    if (over_max && tets == limit) {
      char exact[64];
      std::snprintf(exact, sizeof exact, "%.0f", r.after.tets_estimate);
      tets = exact;
      limit = std::to_string(max_tets);
    }
    throw InputError(scene.string() + ": level " + std::to_string(levels) + " makes " + tets +
                     " tets and " + count_words(r.after.vertices_estimate) + " vertices (" + count_words(static_cast<double>(r.before.tets)) +
                     " tets x 8^" + std::to_string(levels) + "): " + about_gigabytes(m.write_bytes) + " to write and " +
                     about_gigabytes(m.replay_bytes) + " to replay, " +
                     (over_max ? "over the limit of " + limit + " tets (--max-tets raises it)"
                               : "over the " + std::to_string(kMaxMeshElements) +
                                     " tets or vertices a mesh can index (its indices are 32-bit)"));
  }
  if (const auto beyond = beyond_machine_memory(refine_memory(r.after).write_bytes, "write"))
    throw InputError(scene.string() + ": level " + std::to_string(levels) + " makes " +
                     count_words(r.after.tets_estimate) + " tets: " + *beyond +
                     " (the out-of-memory killer would end the run, and others beside it)");
  // The kept virtual mesh: the scene's OBJ as it is, or the boundary before refinement.
  std::optional<SurfaceMesh> kept;
  if (keep_virtual) kept = spec.virtual_mesh ? read_surface(*spec.virtual_mesh) : extract_boundary(mesh);
  for (int l = 0; l < levels; ++l) mesh = refine_tet_mesh(mesh);

  r.scene_file = out;
  r.mesh_file = std::filesystem::path(out).replace_extension(".msh");
  r.name = spec.name + "_l" + std::to_string(levels);
  r.mesh_text = msh22_text(mesh, 1.0);
  YAML::Node root = YAML::LoadFile(spec.file.string());
  root["name"] = r.name;
  root["mesh"]["physical"] = r.mesh_file.filename().string();
  if (kept) {
    r.virtual_file = std::filesystem::path(out).replace_extension(".obj");
    r.virtual_text = obj_text(*kept);
    root["mesh"]["virtual"] = r.virtual_file.filename().string();
  } else if (spec.virtual_mesh) {
    SurfaceMesh surface = read_surface(*spec.virtual_mesh);
    std::vector<std::array<int, 2>> parent;
    for (int l = 0; l < levels; ++l) surface = refine_surface(surface, parent);
    r.virtual_file = std::filesystem::path(out).replace_extension(".obj");
    r.virtual_text = obj_text(surface);
    root["mesh"]["virtual"] = r.virtual_file.filename().string();
  }
  YAML::Emitter yaml;
  yaml << root;
  char header[768];
  std::snprintf(header, sizeof header,
                "# %s with its physical mesh refined %d level%s by `ebh scene refine %s --level %d%s` (every tet into 8\n"
                "# at its edge midpoints): %lld tets and %lld vertices, from %lld and %lld. Groups, pinned regions\n"
                "# and every other key carry over (docs/FORMATS.md, \"ebh scene refine\").\n%s",
                spec.name.c_str(), levels, levels == 1 ? "" : "s",
                escape_unprintable(scene_argument.empty() ? scene.string() : scene_argument).c_str(), levels,
                kept ? " --keep-virtual" : "", static_cast<long long>(r.after.tets),
                static_cast<long long>(r.after.vertices), static_cast<long long>(r.before.tets),
                static_cast<long long>(r.before.vertices),
                kept ? "# The virtual mesh keeps the scene's resolution (not refined).\n" : "");
  r.scene_yaml = std::string(header) + yaml.c_str() + "\n";
  return r;
}

}  // namespace ebh
