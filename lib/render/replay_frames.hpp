#pragma once
// The mesh snapshots of a replay output (docs/FORMATS.md), read for rendering and for the XDMF
// index. The small per-frame arrays (times, jaw, tool poses) and the rest topology are read at
// open; the positions of one frame are read on demand (an HDF5 hyperslab), so a long replay with
// a large mesh is never held in memory at once.
//
//   /mesh/virtual_rest       (m, 3)    m      virtual mesh at rest
//   /mesh/virtual_triangles  (Fv, 3)   index  virtual mesh triangles
//   /mesh/physical_rest      (n, 3)    m      physical mesh at rest
//   /mesh/physical_tets      (T, 4)    index  physical mesh tets
//   /frames/t                (F,)      s
//   /frames/jaw              (F,)      1      0 closed .. 1 open
//   /frames/tool_poses       (F, 2, 7) m, 1   row 0 physical tool, row 1 virtual tool
//   /frames/virtual_positions  (F, m, 3) float32
//   /frames/physical_positions (F, n, 3) float32
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "math/vec.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

struct ReplayFrames {
  std::string file;                            ///< the replay output's path
  std::string scene_name;                      ///< root attribute `scene` ("" if absent)
  std::string scene_file;                      ///< root attribute `scene_file` ("" if absent)
  std::string scene_yaml;                      ///< root attribute `scene_yaml`: the scene the replay ran ("" if absent)
  std::string scene_file_sha256;               ///< root attribute `scene_file_sha256` ("" if absent)
  std::string tool_kind;                       ///< root attribute `tool` ("" if absent)
  double shaft_radius = 0.0;                   ///< root attribute `shaft_radius` (0 if absent)
  double replay_s = 0.0;                       ///< root attribute `virtual_s`: the window replayed (0 if absent)
  /// The --set overrides: root attribute `overrides_list` (one per line) split into lines, or, in
  /// files written before it, `overrides` (joined with spaces) split at spaces, a piece without
  /// '=' continuing the previous value.
  std::vector<std::string> overrides;

  std::vector<Vec3f> virtual_rest;             ///< #m rest positions of the virtual mesh
  std::vector<std::array<int, 3>> triangles;   ///< #Fv virtual mesh triangles
  std::size_t physical_vertices = 0;           ///< n
  std::size_t physical_tets = 0;               ///< T

  std::vector<double> t;                       ///< #F frame times
  std::vector<double> jaw;                     ///< #F jaw values
  /// #F [physical tool, virtual tool]; a quaternion normalised, one that is zero or not finite kept
  /// as stored (no rotation: a pose to leave out)
  std::vector<std::array<ToolPose, 2>> poses;

  std::size_t frame_count() const { return t.size(); }
  std::size_t virtual_vertices() const { return virtual_rest.size(); }

  /// Reads /frames/virtual_positions[f] into `out` (resized to m). Throws InputError on a read
  /// failure (naming the file and dataset).
  void read_virtual_positions(std::size_t f, std::vector<Vec3f>& out) const;
};

/// Opens a replay output and checks every dataset above (shape, index range, at least one frame,
/// the SI unit of each length and time where a `unit` attribute gives one, finite and strictly
/// increasing frame times, at least one triangle).
/// Throws InputError "FILE: /frames: ..." for a file without snapshots, "FILE: /mesh/...: ..."
/// for a bad topology.
ReplayFrames open_replay_frames(const std::string& path);

}  // namespace ebh
