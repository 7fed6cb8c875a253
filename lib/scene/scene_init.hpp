#pragma once
// `ebh scene init`: a complete, commented scene file for a user's own physical mesh, with the
// tool as a real 5 mm laparoscopic instrument (in mm, whatever the mesh's unit), stiffness and
// density from a tissue preset, a camera on the mesh's bounding box, solver settings as in the
// committed scenes, and pinned regions from the command line or, without one, the lowest layer of
// vertices along gravity (docs/FORMATS.md, "ebh scene init"; the presets: docs/MODEL.md).
#include <filesystem>
#include <string>
#include <vector>

#include "scene/scene.hpp"

namespace ebh {

/// A tissue's stiffness and density for a new scene. `k_vol` is the shear modulus (docs/MODEL.md,
/// "What k_vol means"); `source` says where the numbers come from, for the scene file's comment.
struct TissuePreset {
  std::string name;
  double k_vol;     ///< Pa
  double density;   ///< kg/m^3
  std::string source;
};

/// liver, gallbladder, uterus, generic (docs/MODEL.md, "Tissue presets").
const std::vector<TissuePreset>& tissue_presets();

struct SceneInitOptions {
  std::filesystem::path mesh;     ///< the physical mesh (Gmsh .msh 2.2 or 4.1, VTK .vtk, Medit .mesh, TetGen .node/.ele)
  std::filesystem::path out;      ///< the scene file to write; the mesh path in it is relative to its folder
  /// The file `out` writes: `out`, or where `out` is a link the file it names (io/atomic.hpp
  /// output_target), whose folder the mesh path is relative to; empty: `out`.
  std::filesystem::path written;
  std::string unit = "mm";        ///< the mesh file's unit, also the scene's (pins, camera)
  std::vector<std::string> pins;  ///< "sphere:x,y,z,r", "box:x0,y0,z0,x1,y1,z1", "group:NAME" (lengths in `unit`)
  std::string tissue = "generic";
  std::string tool = "hook";      ///< hook | forceps
};

/// An argument as a shell reads it back: as it is, or in single quotes where it holds a space, a
/// quote or another character the shell takes (a line break written as \n: the command stands in a
/// YAML comment and in printed hints).
std::string shell_word(const std::string& a);

struct SceneInit {
  std::string yaml;      ///< the scene file's text
  Scene scene;           ///< that text loaded (as the file will load)
  std::string pin_note;  ///< how the pinned vertices were chosen, one line
  std::string speck_note;  ///< "" or the specks mesh.min_part_tets drops, one line
  /// "" or, where the virtual mesh's edges are over kInitCoarseEdge times the tool's thinnest part,
  /// what that does to the force and how to refine it, one line
  std::string resolution_note;
};

/// Virtual mesh edges (the median) over the tool's thinnest part beyond which `ebh scene init` says
/// the mesh is coarse for the tool: a 1 mm hook tip on an own block's 2 mm edges rendered where it
/// landed on a triangle (pressing on, the force dipped 20%, and a straight press pushed sideways
/// at up to 0.38 of the normal force); on 1 mm edges a 7% dip and 0.01.
inline constexpr double kInitCoarseEdge = 1.5;

/// Makes the scene and loads it back. Throws InputError naming the option (--unit, --tissue,
/// --tool, --pin SPEC) or the mesh file: a mesh that does not load, a group the mesh lacks, a
/// region that pins no vertex, regions that pin every vertex.
SceneInit make_scene(const SceneInitOptions& options);

}  // namespace ebh
