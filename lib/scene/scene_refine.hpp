#pragma once
// `ebh scene refine`: a scene with its physical mesh refined uniformly (mesh/refine.hpp: every
// tet into 8 per level), for studies of cost against mesh size (`ebh bench sizes`).
//
// What carries over (docs/FORMATS.md, "ebh scene refine"):
// - the physical mesh, written in its file's unit and coordinates (mesh.unit and mesh.transform
//   place it as before); old vertices keep their bits, so every pinned vertex stays pinned;
// - physical groups: each child element keeps its parent's tag, so a group's surface is the same
//   surface, refined; the midpoint of an edge of a group's triangle or tet joins the group;
// - box, sphere and halfspace pins: the same regions (convex: a midpoint of two pinned vertices is
//   pinned), which now also hold the new vertices inside them;
// - the virtual mesh: `boundary` follows the refined physical mesh by itself (4x the triangles a
//   level) and `virtual_refine` still splits it once more, so the virtual mesh keeps its density
//   relative to the physical surface; an OBJ virtual mesh is split 1 -> 4 per level as well (each
//   triangle at its edge midpoints) and written beside the scene;
// - density and every other key: unchanged (masses follow the volume, which refinement keeps).
// With keep_virtual the virtual mesh keeps the scene's resolution instead: the scene's OBJ, or its
// physical boundary before refinement, is written beside the scene as OUT.obj (in the mesh file's
// unit and coordinates; `virtual_refine` still applies), so that only the physical mesh grows (the
// paper's two meshes: the haptic side's resolution chosen apart from the physical one). Refinement
// at the edge midpoints keeps the boundary's shape, so the kept mesh lies on the refined boundary.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>

#include "mesh/refine.hpp"

namespace ebh {

/// The largest physical mesh `ebh scene refine` writes unless told otherwise (--max-tets): 8
/// million tets take about 1.4 GB to write and 6.5 GB to replay on the CPU (refine_memory); the
/// paper's largest scene, cholecystectomy, reaches 2.8 million at level 2 and 22.5 million at 3.
inline constexpr std::int64_t kMaxRefinedTets = 8'000'000;

/// The most tets or vertices a mesh holds, whatever --max-tets says: it indexes them with ints.
inline constexpr std::int64_t kMaxMeshElements = std::numeric_limits<int>::max();

/// Whether a mesh of the counts `after` (refined_counts) is within `max_tets` tets and within
/// kMaxMeshElements tets and vertices. Judged on the counts' double estimates, which do not
/// saturate: a count past INT64_MAX is above every limit, INT64_MAX among them.
bool refined_within(const RefinedCounts& after, std::int64_t max_tets);

/// Host memory a refined mesh takes, from measurements (refine_memory's comment says where).
struct RefineMemory {
  double write_bytes = 0;   ///< `ebh scene refine`: the mesh in memory and its text
  double replay_bytes = 0;  ///< `ebh replay` on the CPU: scene, world, solver workspaces, output
};
RefineMemory refine_memory(const RefinedCounts& counts);

/// This machine's memory in bytes (its physical pages), 0 where that cannot be told. A refinement
/// past it is refused before the kernel's out-of-memory killer ends the run, and others beside it,
/// without a word (--max-tets lifts the count's limit, not this one).
double machine_memory_bytes();
/// "about 26 GB to replay, more than this machine's 25 GB of memory" when `bytes` (what the work
/// `to` takes: "write", "replay") is more than machine_memory_bytes(); nullopt otherwise.
std::optional<std::string> beyond_machine_memory(double bytes, const std::string& to);
/// "1.4 GB"; "over 1e299 GB" past what a double holds. about_gigabytes: "about 1.4 GB".
std::string gigabytes(double bytes);
std::string about_gigabytes(double bytes);

/// What `ebh scene refine` writes, in memory.
struct RefinedScene {
  std::filesystem::path scene_file;    ///< OUT.yaml
  std::filesystem::path mesh_file;     ///< OUT.msh, beside it (`out` of refine_scene: a link's target)
  std::filesystem::path virtual_file;  ///< OUT.obj when the virtual mesh is an OBJ file or kept; else empty
  std::string scene_yaml, mesh_text, virtual_text;
  std::string name;                    ///< the new scene's name: NAME_lLEVEL
  RefinedCounts before, after;         ///< the physical mesh's counts
};

/// Refines the physical mesh of the scene file `scene` (and an OBJ virtual mesh, unless
/// keep_virtual) `levels` times and returns the files of a scene `out` that loads it: its meshes
/// beside it, named by their file names. `out` is the file as it is written: where the output's
/// name is a link, its target (io/atomic.hpp output_target; io/paths.hpp companion_output names
/// the meshes alike), so that the meshes go where the scene, which names them relative to its own
/// folder, is.
/// `scene_argument` is how the user named the scene (for the new file's header). Throws InputError
/// for levels < 1, a scene that does not load, or a refined mesh that refined_within refuses (the
/// message gives the sizes and memory).
RefinedScene refine_scene(const std::filesystem::path& scene, int levels, const std::filesystem::path& out,
                          std::int64_t max_tets = kMaxRefinedTets, const std::string& scene_argument = "",
                          bool keep_virtual = false);

}  // namespace ebh
