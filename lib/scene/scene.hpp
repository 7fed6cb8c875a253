#pragma once
// A scene: what a scenarios/NAME.yaml file says, with every length converted to metres.
//
// YAML schema (every key is validated; unknown keys are errors; an error names the file and
// the dotted key). Lengths are numbers in a declared unit (m, cm, mm or in): `unit` for world
// coordinates (pinned regions, camera), `mesh.unit` for the mesh files and `tool.unit` for the
// tool's sizes, both defaulting to `unit`; stiffnesses, densities, forces and gravity are always SI
// (docs/FORMATS.md, "Length units and the mesh transform").
//
//   name: tube                      # defaults to the file's stem
//   description: "..."
//   unit: mm                        # m | cm | mm: pinned regions and camera (world coordinates)
//   mesh:
//     physical: tube.msh            # Gmsh .msh 2.2/4.1 ASCII, VTK legacy .vtk, Medit .mesh or TetGen .node/.ele (tets), relative to the scene file
//     virtual: boundary             # 'boundary' (the physical mesh's surface), or a surface file (.obj, .stl, .ply, VTK .vtk POLYDATA, .vtp)
//     virtual_refine: 1             # 0 or 1: split each virtual triangle into 4 (paper: denser virtual mesh)
//     min_part_tets: 0              # drop the parts (tets joined by vertices) of fewer tets at load:
//                                   #   a segmentation's specks apart from the organ (0: keep every part)
//     unit: mm                      # the mesh files' unit and translate's (default: unit)
//     transform: {scale: 1, rotvec_deg: [0, 0, 0], translate: [0, 0, 0]}
//                                   # mesh file -> world at load: p = R(rotvec_deg) (scale p) + translate
//   material:
//     density: 1000                 # kg/m^3
//   stiffness:                      # SI; see docs/MODEL.md for how to choose them
//     k_vol: 3000                   # Pa    E_vol [7]  (ARAP ~ shear modulus mu = E / (2 (1 + nu)))
//     k_s: 20                       # N/m   E_s [4]    per virtual-mesh edge
//     k_svc: 50                     # N/m   E_svc [5]  per virtual vertex
//     k_con: 400                    # N/m   E_con [3]  per virtual vertex in contact
//     k_vcs: 300                    # N/m   E_tvc [2]  translation
//     k_vct: 0.3                    # N m/rad E_tvc [2] rotation
//     k_det: 0                      # Pa    E_det (not in the paper; 0 = off): volume stiffness lambda/2,
//                                   #       Poisson's ratio k_det / (2 k_det + k_vol) (docs/MODEL.md)
//     regions:                      # optional: parts of another k_vol, in order (a tet in several: the last)
//       - group: tumour             #   one region as in pinned (a group's tets; a box, sphere or
//         k_vol: 15000              #   half-space: the tets whose centroid is in it) and its k_vol in Pa;
//                                   #   k_det keeps its ratio to k_vol there (the same Poisson's ratio)
//   gravity: [0, 0, -9.81]          # m/s^2
//   damping: 0.0                    # fraction of velocity removed per physical step, [0, 1)
//   pinned:                         # union of regions, world coordinates (after mesh.transform); each one of:
//     - group: back                 #   a physical group name, or the number of a group without one
//                                   #   (Physical Surface(3) = {...}: `group: 3`): its tets' or
//                                   #   triangles' vertices (an element may be in several groups; a
//                                   #   triangle with a vertex no tet uses is removed with that vertex)
//     - box: {min: [x, y, z], max: [x, y, z]}
//     - sphere: {center: [x, y, z], radius: r}
//     - halfspace: {point: [x, y, z], normal: [x, y, z]}   # vertices with (p - point).normal >= 0
//   tool:
//     unit: mm                      # every tool length below (default: unit)
//     kind: hook                    # hook | forceps
//     shaft_radius: 2.5
//     shaft_length: 300
//     hook: {tip_length: 6, tip_radius: 1.0}                # the bent tip, along the tool's local +x
//     forceps: {jaw_length: 20, jaw_width: 5, jaw_thickness: 2, jaw_max_angle_deg: 30,
//               grasp_threshold: 0.2, soft_margin: 2, eta: 1.0}
//                                   # release_threshold: grasp_threshold: the jaw value at or above
//                                   #   which grasped jaws let go (higher: a noisy gripper holds on)
//     force_limit: 3.3              # N (Geomagic Touch)
//     torque_limit: 0               # N m, 0: no limit (a device that renders torque: its own)
//     newton_iterations: 2          # Newton steps on E_tool per Newton call
//     newton_calls: all             # all | 1 .. solver.virtual_iterations: how many of a tick's
//                                   #   virtual-mesh iterations a Newton call follows (the last
//                                   #   ones; all: every one, Algorithm 2 as printed)
//     max_step: 0.5                 # translation limit of one Newton step (tool.unit)
//     max_step_rotation_deg: 0.5    # rotation limit of one Newton step
//     stabilization: {translation: 0, rotation: 0}   # N/m, N m/rad: damps the virtual tool per tick
//   time: {haptic_hz: 1000, physical_hz: 100, interpolate_physical: true}
//                                   # 1 <= physical_hz <= haptic_hz <= kMaxHapticHz (100 kHz),
//                                   # haptic_hz >= 10 (kMinReplayPhysicalHz, kMinReplayHapticHz)
//                                   # interpolate_physical: move the E_svc targets from the previous
//                                   # physical result to the new one over N ticks (false: jump, as
//                                   # Algorithm 2 line 1 is printed)
//   solver:
//     method: chebyshev             # jacobi | chebyshev | direct
//     diagonal: bounded             # bounded | plain: the Jacobi-type methods' D (docs/MODEL.md)
//     physical_iterations: 16       # the committed scenes and `scene init`: 8 (docs/PERFORMANCE.md, "Sweeps")
//     virtual_iterations: 4         # virtual-mesh local-global iterations per haptic tick
//     chebyshev_rho: 0.95           # (0, 1) | auto: the relaxed Jacobi iteration's spectral radius
//                                   #   on this mesh (docs/MODEL.md, "Chebyshev's rho")
//     physical_tolerance: 0.002     # jacobi/chebyshev: iterate past physical_iterations while the step
//     physical_max_iterations: 64   #   leaves more than this many mesh weights unbalanced, up to the
//                                   #   maximum (0: always physical_iterations; docs/MODEL.md)
//     recovery: direct              # direct | none: redo a step the jacobi/chebyshev iterations leave
//     recovery_residual: 100        #   above this many mesh weights unbalanced (or diverged) with the
//                                   #   direct solve (CPU backend; docs/MODEL.md, "Recovery")
//     active_region: 0              # length (unit): iterate only the virtual vertices near the tool and
//                                   #   those displaced from their coupling targets by more than this
//                                   #   (and their neighbours); the rest follow the targets. 0: the
//                                   #   whole virtual mesh (CPU; CUDA per chunk of 128 vertices, vertex
//                                   #   contact: docs/MODEL.md, "The active region")
//     physical_region: 0            # length (unit): iterate only the physical vertices that moved by
//                                   #   more than this in the last step, or under a virtual vertex
//                                   #   that did, and their neighbours; the rest are held. 0: every
//                                   #   vertex (CUDA per patch of vertices: docs/MODEL.md, "The physical
//                                   #   mesh's awake region")
//     sleep: 0                      # length (unit): skip a physical step while nothing moved by more
//                                   #   than this since the last one (docs/MODEL.md, "Sleeping");
//                                   #   0: every step runs
//     virtual_damping: 250          # 1/s: the virtual mesh's velocity is divided by 1 + this h each
//                                   #   tick (h the haptic period; docs/MODEL.md, "Damping of the
//                                   #   virtual mesh"); 0: Algorithm 2 as printed
//   contact: vertices               # vertices | surface: E_con [3] on the virtual mesh's vertices (the
//                                   # paper) or on points of its triangles (docs/MODEL.md, "Contact
//                                   # against the surface")
//   camera: {eye: [x, y, z], target: [x, y, z], up: [0, 0, 1], fov_deg: 40}
//   stages: {grasp: false, frames: false, settle: true}    # skip what a scene doesn't need;
//                                   # settle: start from the static equilibrium under gravity
#include <cmath>
#include <filesystem>
#include <optional>
#include <span>
#include <set>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/units.hpp"
#include "math/vec.hpp"
#include "mesh/degrade.hpp"
#include "mesh/tet_mesh.hpp"

namespace ebh {

struct Stiffness {
  double k_vol = 3000.0;  ///< Pa, E_vol [7]
  double k_s = 20.0;      ///< N/m, E_s [4]
  double k_svc = 50.0;    ///< N/m, E_svc [5]
  double k_con = 400.0;   ///< N/m, E_con [3]
  double k_vcs = 300.0;   ///< N/m, E_tvc [2] translation
  double k_vct = 0.3;     ///< N m / rad, E_tvc [2] rotation
  double k_det = 0.0;     ///< Pa, E_det (energy/volume.hpp; not in the paper): lambda / 2; 0 = off
  /// Virtual edges stiffer than their coupling to the physical mesh: in async mode the two meshes
  /// can drive each other unstable (docs/MODEL.md, "k_s against k_svc"); the scene warns.
  bool edges_outweigh_coupling() const { return k_svc > 0 && k_s > k_svc; }
};

struct PinRegion {
  enum class Kind { Group, Box, Sphere, Halfspace };
  Kind kind = Kind::Box;
  std::string group;    ///< Group: physical group name
  Vec3d a, b;           ///< Box: min, max; Sphere: centre, (radius, 0, 0); Halfspace: point, normal
};

/// A part of the physical mesh of another stiffness (a tumour in an organ, a stiffer capsule): the
/// tets of a group, or those whose centroid lies in a box, sphere or half-space (PinRegion's kinds,
/// world coordinates), and their E_vol stiffness. E_det's keeps its ratio to it (k_det / k_vol,
/// the scene's), so the part has the scene's Poisson's ratio.
struct StiffnessRegion {
  PinRegion region;
  double k_vol = 0;  ///< Pa
};

struct HookSpec {
  double tip_length = 0.006;  ///< m, the bent tip along the tool's local +x
  double tip_radius = 0.001;  ///< m
};

/// The jaws' opening at jaw = 1 lies in (0, kMaxJawAngleDeg) degrees: at 90 each jaw would stand
/// across the shaft. The scene reader and the tool model (build_tool) both hold a spec to it.
inline constexpr double kMaxJawAngleDeg = 90.0;

struct ForcepsSpec {
  double jaw_length = 0.020;         ///< m
  double jaw_width = 0.005;          ///< m
  double jaw_thickness = 0.002;      ///< m
  double jaw_max_angle_deg = 30.0;   ///< opening of each jaw at jaw = 1
  double grasp_threshold = 0.2;      ///< jaw value below which the jaws grasp
  /// Jaw value at or above which grasped jaws let go (>= grasp_threshold); none given: the grasp
  /// threshold, the paper's. Above it, a gripper's noise does not let go and grasp again.
  std::optional<double> release_threshold;
  double release() const { return release_threshold.value_or(grasp_threshold); }
  /// Whether the jaws are closed at the jaw value `jaw`, having been `was_closed`: open jaws close
  /// below the grasp threshold, closed ones open at the release threshold.
  bool closed_at(double jaw, bool was_closed) const { return jaw < (was_closed ? release() : grasp_threshold); }
  double soft_margin = 0.002;        ///< m, soft collider around the hard jaw box [10]
  double eta = 1.0;                  ///< smoothing factor of w(d) = 1 / (1 + eta e^d) [10]
};

struct ToolSpec {
  enum class Kind { Hook, Forceps };
  Kind kind = Kind::Hook;
  double unit = 1.0;             ///< metres per tool length unit in the file (tool.unit)
  std::string unit_name = "m";
  double shaft_radius = 0.0025;  ///< m
  double shaft_length = 0.3;     ///< m, from the rotation centre (tool origin) back along -z
  HookSpec hook;
  ForcepsSpec forceps;
  double force_limit = 3.3;             ///< N
  /// N m, 0: none. A device that renders torque has a limit of its own (a Geomagic Touch renders
  /// none); the virtual tool's rotational coupling k_vct x its lag knows none (a log that turns
  /// the tool half a turn in a tick renders 0.9 N m with the scenes' k_vct).
  double torque_limit = 0.0;
  int newton_iterations = 2;
  /// How many of a tick's virtual-mesh iterations a Newton call of the virtual tool follows: the
  /// last newton_calls of them (docs/MODEL.md, "Newton calls per tick"). 0: all of them (`all`).
  int newton_calls = 0;
  double max_step = 0.0005;             ///< m per Newton step
  double max_step_rotation_deg = 0.5;   ///< per Newton step (its lever is the whole shaft: keep it small)
  /// Stiffness of springs tying the virtual tool to its pose at the start of the tick (N/m and
  /// N m/rad): a viscous damper b = k h_h on the virtual tool that stops active-set chatter (a
  /// tool resting on a few vertices flipping between contact states). 0 = the paper's model.
  double stabilization_translation = 0.0;
  double stabilization_rotation = 0.0;
  /// The scene file gave keys under the other kind's block (tool.forceps on a hook, tool.hook on
  /// forceps): they shape nothing, and the scene warns. The resolved scene writes only the kind's block.
  bool other_kind_keys = false;
};

struct Camera {
  Vec3d eye{0, -0.3, 0.15};
  Vec3d target{0, 0, 0};
  Vec3d up{0, 0, 1};
  double fov_deg = 40.0;
};

struct SolverSpec {
  enum class Method { Jacobi, Chebyshev, Direct };
  enum class Diagonal { Bounded, Plain };
  Method method = Method::Chebyshev;
  Diagonal diagonal = Diagonal::Bounded;
  int physical_iterations = 16;
  int virtual_iterations = 4;
  /// Chebyshev's rho (Wang 2015): chebyshev_rho, or with chebyshev_rho_auto the relaxed Jacobi
  /// iteration's spectral radius on the mesh (PhysicalModel::spectrum; physical_params).
  bool chebyshev_rho_auto = false;
  double chebyshev_rho = 0.95;
  /// The Jacobi-type methods' stopping rule: after physical_iterations, iterations go on while the
  /// residual at the start of the last one (PhysicalStepReport::residual, mesh weights) is above
  /// physical_tolerance, up to physical_max_iterations in all. 0: exactly physical_iterations.
  double physical_tolerance = 0.002;
  int physical_max_iterations = 64;
  /// The Jacobi-type methods' recovery (CPU backend): a step that leaves more than
  /// recovery_residual mesh weights unbalanced (PhysicalStepReport::residual), or a diverged
  /// state, is redone from its start with the direct global solve (docs/MODEL.md, "Recovery").
  enum class Recovery { Direct, None };
  Recovery recovery = Recovery::Direct;
  double recovery_residual = 100;
  /// The virtual mesh's active region (docs/MODEL.md, "The active region"; CUDA per chunk of 128
  /// vertices, vertex contact): the displacement from its coupling target (m) past which a
  /// virtual vertex spreads the region to its neighbours; 0: every virtual vertex is iterated (the
  /// full solve).
  double active_region = 0;
  bool active_region_given = false;  ///< the scene file or an override names it (the CUDA backend warns then)
  /// The physical mesh's awake region (docs/MODEL.md, "The physical mesh's awake region"; CUDA
  /// at the grain of its step's patches): the motion (m) past which a physical vertex, and the
  /// virtual vertices' past which the physical vertices under them, are iterated with their
  /// neighbours; 0: every vertex.
  double physical_region = 0;
  /// The sleeping physical mesh (docs/MODEL.md, "Sleeping"): a physical step is
  /// skipped, the state held, while the last step moved no vertex and the virtual mesh moved no
  /// vertex since then by more than this length (m), and the last step met the tolerance; 0: never.
  double sleep = 0;
  bool sleep_given = false;
  /// The virtual mesh's velocity damping rate alpha (1/s; docs/MODEL.md, "Damping of the virtual
  /// mesh"): the velocity a tick carries into the next one's prediction is divided by 1 + alpha h.
  /// 0: Algorithm 2 as printed.
  double virtual_damping = 250;
};

/// What E_con [3] acts on (the scene's `contact`).
enum class ContactModel { Vertices, Surface };

struct Stages {
  bool grasp = false;   ///< grasp machinery (forceps scenes)
  bool frames = false;  ///< mesh snapshots in the replay output by default
  bool settle = true;   ///< start from the static equilibrium under gravity, not the rest shape
};

/// The fastest haptic loop a replay runs (Hz). Haptic devices tick at 1 kHz, the fastest at a few
/// kHz; 100 kHz leaves room for studies of the rate while a tick count (and the memory a replay
/// keeps per tick) stays within a machine's reach (docs/FORMATS.md, Limits).
inline constexpr double kMaxHapticHz = 100e3;
/// The slowest rates a replay takes (--haptic-hz, time.haptic_hz; --physical-hz, time.physical_hz):
/// a haptic device ticks at >= 1 kHz and the paper's physical mesh steps at 60-100 Hz; slower than
/// 10 Hz and 1 Hz is no haptic or physical loop (a period of 1e300 s steps nothing).
inline constexpr double kMinReplayHapticHz = 10;
inline constexpr double kMinReplayPhysicalHz = 1;
/// A haptic device's loop rate (Hz): a replay below it warns (the force of a press has not
/// converged in the rate: docs/MODEL.md, "Held loads"), and a sweep report takes no configuration
/// below it for a candidate (`ebh sweep report --min-haptic-hz`).
inline constexpr double kDeviceHapticHz = 1000;
/// Whether haptic_hz / physical_hz is a whole number >= 1 (to 1e-9 of it): physical step k
/// starts at tick k N (schedule/scheduler.hpp). The scene reader, the rate options and build_world ask it.
inline bool whole_ticks_per_step(double haptic_hz, double physical_hz) {
  const double ratio = haptic_hz / physical_hz;
  return ratio >= 1.0 - 1e-9 && std::fabs(ratio - std::round(ratio)) <= 1e-9 * ratio;
}

/// Where the mesh files sit in the world: p_world = R(rotvec_deg) (scale p) + translate, p the file's
/// position in metres. Applied at load to the physical mesh and an .obj virtual mesh.
struct MeshTransform {
  double scale = 1.0;   ///< uniform, > 0
  Vec3d rotvec_deg;     ///< rotation vector in degrees (axis times angle), about the file's origin
  Vec3d translate;      ///< m
  bool identity() const { return scale == 1.0 && rotvec_deg == Vec3d{} && translate == Vec3d{}; }
  Mat3d rotation() const;
  Vec3d apply(const Vec3d& p) const;    ///< file position (m) -> world
  Vec3d inverse(const Vec3d& p) const;  ///< world -> file position (m), to rounding
};

/// The parsed scene file. All lengths in metres.
struct SceneSpec {
  std::filesystem::path file;             ///< the scene file itself
  /// The overrides ("key=value", the command line's --set) applied to the file: messages about a
  /// value name the override that gave it (value_source).
  std::vector<std::string> overrides;
  std::string name;
  std::string description;
  double unit = 1.0;                      ///< metres per world length unit (pinned regions, camera)
  std::string unit_name = "m";
  std::filesystem::path physical_mesh;    ///< absolute or relative to the working directory
  double mesh_unit = 1.0;                 ///< metres per mesh-file length unit (mesh.unit)
  std::string mesh_unit_name = "m";
  MeshTransform mesh_transform;           ///< mesh file -> world
  std::optional<std::filesystem::path> virtual_mesh;  ///< empty: the physical mesh's boundary
  int virtual_refine = 0;
  int min_part_tets = 0;                  ///< parts of fewer tets are dropped at load (0: none)
  double density = 1000.0;                ///< kg/m^3
  Stiffness stiffness;
  Vec3d gravity{0, 0, -9.81};
  double damping = 0.0;
  std::vector<PinRegion> pinned;
  std::vector<StiffnessRegion> stiffness_regions;  ///< stiffness.regions, in order: a tet in several takes the last one's
  ToolSpec tool;
  double haptic_hz = 1000.0;
  double physical_hz = 100.0;
  /// The haptic side moves its E_svc targets linearly from the previous physical result to the
  /// newly visible one over the N ticks that follow it, instead of jumping (docs/MODEL.md). In
  /// async mode the jump every N ticks, seen one step late, sustained a ~45 Hz oscillation
  /// where a hook presses inside the tube; false restores Algorithm 2 line 1 as printed.
  bool interpolate_physical = true;
  SolverSpec solver;
  ContactModel contact = ContactModel::Vertices;
  Camera camera;
  Stages stages;
};

/// The virtual tool's Newton calls per haptic tick: tool.newton_calls, or (`all`) one after every
/// virtual-mesh iteration, solver.virtual_iterations.
inline int newton_calls_per_tick(const SceneSpec& s) {
  return s.tool.newton_calls > 0 ? s.tool.newton_calls : s.solver.virtual_iterations;
}

/// A scene with its meshes loaded and scaled to metres.
struct Scene {
  SceneSpec spec;
  TetMesh physical;              ///< the physical mesh (tets), metres
  SurfaceMesh virtual_surface;   ///< the virtual mesh source surface before refinement, metres
  std::vector<int> pinned;       ///< sorted physical-vertex indices that never move
  /// Each physical tet's E_vol stiffness (Pa): stiffness.k_vol, or the last of spec.stiffness_regions that
  /// holds the tet. Empty for a Scene built in code (build_physical_model then takes k_vol, as it
  /// does where code replaced the mesh of a scene without stiffness.regions).
  std::vector<double> tet_k_vol;
  /// The connected parts of the physical mesh (tets sharing a vertex) with no pinned vertex, while
  /// some other part has one: each part's lowest vertex index and its number of vertices.
  std::vector<std::pair<int, int>> free_parts;
  std::vector<std::string> warnings;  ///< non-fatal problems found at load, one line each ("FILE: ...")
};

/// The connected parts of `mesh` (its tets joined by shared vertices) none of whose vertices is in
/// `pinned` (sorted): each part's lowest vertex index and its number of vertices, by that index.
std::vector<std::pair<int, int>> unpinned_parts(const TetMesh& mesh, std::span<const int> pinned);

/// A part of under this fraction of the physical mesh's tets is a speck: of a segmentation, apart
/// from the organ (`mesh.min_part_tets` drops such parts). The committed scenes' parts hold 50%
/// (the gap's two blocks) and 100% of their tets; a part meant to be there that holds less (a thin
/// vessel beside a liver) is kept with a lower mesh.min_part_tets, which `scene init` writes.
inline constexpr double kSpeckFraction = 0.01;
/// The specks among the parts (tets joined by vertices, mesh_parts): (lowest vertex, tets) each.
std::vector<std::pair<int, int>> speck_parts(const TetMesh& mesh);

/// The parts of `mesh` that touch pinned vertices (sorted) only on one line or at one point, so
/// that they can turn about it, held against that only by the coupling's drag: each part's lowest
/// vertex index and its number of pinned vertices. Collinear: every pinned vertex of the part lies
/// within kPinLineTolerance of the part's thickness (its vertices' spread along their least
/// principal axis) from the line through its two farthest ones.
inline constexpr double kPinLineTolerance = 0.01;
std::vector<std::pair<int, int>> parts_pinned_on_a_line(const TetMesh& mesh, std::span<const int> pinned);

/// "" or why the tissue's stiffness hardly reaches the tool: stiffness.k_vol times the virtual
/// mesh's mean edge (as refined at run time: the tissue's stiffness felt at a virtual vertex,
/// docs/MODEL.md "The other stiffnesses") over kTissueOverCoupling times k_svc, which then bounds
/// the rendered stiffness (a block of 5 mm tets, virtual edges 2.5 mm, k_svc 50, pressed 8 mm:
/// 0.83 N at k_vol 3000, 1.40 N at 1e4, 2.16 N at 1e5 and 2.27 N at 1e6; 1e6 with k_svc 2500
/// stops the tool at the surface).
inline constexpr double kTissueOverCoupling = 3;
std::string coupling_bounds_tissue(const Scene& scene);

/// "" or why the rendered force depends on the virtual mesh's resolution: an OBJ whose mean edge
/// (as refined at run time) is under kVirtualFinerThanBoundary of the physical boundary's. E_svc
/// and contact act at each virtual vertex, so a denser surface meets the tool with more springs
/// per area (a hook pressing a block of 2.5 mm tets held 0.27 N with a 1.25 mm OBJ, 0.42 N at 0.63
/// mm, 1.27 N at 0.1 mm). The scenes' own virtual_refine over the boundary is 1/2 .. 1/4.
inline constexpr double kVirtualFinerThanBoundary = 1.0 / 8;
std::string virtual_mesh_much_finer(const Scene& scene);

/// "" or why the physical mesh cannot carry its own weight (no static equilibrium near its rest
/// shape): the weight of a column of its height along gravity over stiffness.k_vol, a strain, is
/// above 1. A scene warning, and the cause settle_under_gravity names when its steps diverge.
std::string too_soft_for_own_weight(const Scene& scene);

/// Parses and validates a scene file. Throws InputError ("FILE: key 'a.b': ...").
SceneSpec load_scene_spec(const std::filesystem::path& file);

/// Removes from the physical mesh as read what build_scene removes before it orients and checks
/// it: the vertices no tet uses, and the parts (tets joined by vertices) of fewer tets than
/// mesh.min_part_tets; each removal is said in `warnings` ("MESH: ..."). `ebh scene refine` and
/// `ebh bench sizes` refine the mesh so cleaned, so that a refined scene has the scene's parts.
/// Throws InputError naming mesh.min_part_tets where it would drop every part.
void clean_physical_mesh(TetMesh& mesh, const SceneSpec& spec, std::vector<std::string>& warnings);

/// Loads the meshes a parsed scene names, converts them to metres, places them (mesh.transform),
/// validates them, resolves the pinned regions and collects the warnings (tissue values, mesh and
/// tool sizes). load_scene is load_scene_spec followed by this.
Scene build_scene(SceneSpec spec);

/// The scene file whose text is `yaml`, as if read from `file` (relative mesh paths resolve
/// beside it, messages name it): `ebh scene init` checks what it writes before writing it.
Scene load_scene_text(const std::string& yaml, const std::filesystem::path& file);
/// The same parsed only (no meshes loaded): `ebh render` reads a replay's `scene_yaml` with it,
/// `mesh_files_must_exist` false (the output holds the meshes; the files may be gone since).
SceneSpec load_scene_spec_text(const std::string& yaml, const std::filesystem::path& file,
                               bool mesh_files_must_exist = true);

/// Loads the scene file and its meshes, validates them, resolves pinned regions.
Scene load_scene(const std::filesystem::path& file);

/// A file a scene reads: the key a replay output records it under with its SHA-256
/// (schedule/replay_output.cpp), what it is in messages, and its path.
struct SceneInputFile {
  std::string key, what;
  std::filesystem::path path;
};
/// The files a scene reads: scene_file, physical_mesh (with physical_mesh_node, _ele, _face for the
/// other files of a TetGen mesh), and virtual_mesh when the scene names one (not the physical
/// mesh's boundary).
std::vector<SceneInputFile> scene_input_files(const SceneSpec& spec);

/// An InputError that an override caused rather than the scene file: a key it names, makes or sets
/// is bad (`--set a.b.c.d=1`: key 'a' is unknown), or its value breaks a rule with another key
/// (time.physical_hz against the file's haptic_hz). what() is "--set 'KEY=VALUE': key 'k': what is
/// wrong"; key_message() is the part after the option, for a caller whose overrides come from
/// elsewhere and are named there (a sweep plan's keys).
class OverrideError : public InputError {
 public:
  OverrideError(const std::string& override_text, const std::string& key_message)
      : InputError(set_option_shown(override_text) + ": " + key_message),
        override_text_(override_text),
        key_message_(key_message) {}

  /// "--set 'KEY=VALUE'" as messages show it: a value of more than 80 characters (100000 nested
  /// lists, say) cut to its first 80 and "...".
  static std::string set_option_shown(const std::string& text) {
    return "--set '" + (text.size() > 80 ? text.substr(0, 80) + "..." : text) + "'";
  }
  const std::string& key_message() const { return key_message_; }
  /// The override refused, "KEY=VALUE" as given (whole: the message shows it cut at 80 characters).
  const std::string& override_text() const { return override_text_; }

 private:
  std::string override_text_, key_message_;
};

/// Where `key`'s value came from, as messages name it: "--set 'KEY=VALUE'" when one of the spec's
/// overrides gave it (the last such), else the scene file.
std::string value_source(const SceneSpec& spec, const std::string& key);
/// The same for a value two keys give together (k_vol against k_svc): the override that gave
/// `key`, else the one that gave `other`, else the scene file.
std::string value_source(const SceneSpec& spec, const std::string& key, const std::string& other);

/// The stiffest contact a haptic device renders (N/m): k_con and k_vcs above it are warned.
inline constexpr double kMaxDeviceStiffness = 1e5;
/// The softest contact worth rendering (N/m): k_con and k_vcs below it are warned (gap_insert with
/// k_con 10: 0.098 N at the peak for 1.63 N, the tool 1.86 mm into the tissue; k_vcs 10: 0.19 N).
inline constexpr double kMinDeviceStiffness = 100;

/// The warnings of the tool's stiffnesses (k_con, k_vcs, k_vct outside a haptic device's range).
/// Not build_scene's: replays that differ only in them share one scene (WorldCache); the replay
/// and `ebh scene` add them.
std::vector<std::string> tool_stiffness_warnings(const SceneSpec& spec);

/// The dotted keys an override "KEY=VALUE" sets: KEY, or where VALUE is a map each of its leaves
/// (`time={haptic_hz: 500}` sets time.haptic_hz); KEY when VALUE does not parse.
std::vector<std::string> override_keys(const std::string& override_text);

/// Throws InputError "--set 'k=2': key 'k' given twice (also --set 'k=1')" when two overrides set
/// one key, or a section and a key in it: the last would win silently.
void check_overrides_once(const std::vector<std::string>& overrides);

/// The scene's warning when stiffness.k_s is above k_svc (the two meshes can drive each other
/// unstable in async mode; docs/MODEL.md, "k_s against k_svc"), or "" when it is not. Not one of
/// build_scene's warnings: the replays whose step runs beside the ticks and `ebh scene` add it (a
/// lockstep replay, which it recommends, does not).
std::string edges_outweigh_coupling_warning(const SceneSpec& spec);

/// The same with overrides "dotted.key=value" (the command line's --set) applied to the file's
/// YAML before validation: `stiffness.k_con=800`, `solver.method=direct`, `gravity=[0,0,0]`.
/// The value is parsed as YAML (yaml_override_value: a plain value keeps its whole text, " #" and
/// all; a YAML tag is refused); a map merges into the file's map key by key (`stiffness={k_vol:
/// 500, k_s: 30}` keeps the other stiffnesses), anything else replaces the key's value. A bad
/// override is an InputError naming it (an OverrideError when the file is fine and the override's
/// key or value is not); two overrides of one key are refused (check_overrides_once).
/// `mesh_files_must_exist` false reads the scene's keys only, its meshes named but not looked for
/// (`ebh synth` checks that a plan names a scene, whose meshes it does not use).
SceneSpec load_scene_spec(const std::filesystem::path& file, const std::vector<std::string>& overrides,
                          bool mesh_files_must_exist = true);
Scene load_scene(const std::filesystem::path& file, const std::vector<std::string>& overrides);

/// The scene as a complete scene file: every key of the schema with the value in effect (defaults,
/// overrides and the rates a replay ran at included), lengths in their units (unit, mesh.unit,
/// tool.unit, each written explicitly), mesh paths absolute. Loading it gives back the same
/// SceneSpec, bit for bit (the replay output's `scene_yaml` attribute, docs/FORMATS.md); only
/// `file` differs.
std::string resolved_scene_yaml(const SceneSpec& spec);

/// The physical-mesh vertices (sorted, unique) inside a pinned region (metres, world coordinates).
/// A group's are those of its tets and triangles (an element may be in several groups); a group
/// the mesh does not name gives none (known_group_names lists those it does).
std::vector<int> region_vertices(const TetMesh& mesh, const PinRegion& region);
/// A region's kind as the scene file names it: group, box, sphere, halfspace.
std::string region_name(PinRegion::Kind kind);
/// The physical tets (ascending) a stiffness region holds: a group's tets (not its triangles), or
/// those whose centroid lies in the box, sphere or half-space.
std::vector<int> region_tets(const TetMesh& mesh, const PinRegion& region);
/// The physical group tags a pinned region's `group` names: the groups of that name or, where none
/// has it, the unnamed group whose number it is ("3" for Gmsh's `Physical Surface(3) = {...}`; a
/// surface and a volume group of that number both).
std::set<int> group_tags(const TetMesh& mesh, const std::string& group);
/// The physical group names of a mesh, sorted, each once, then the numbers of its unnamed groups
/// in increasing order (what a pin's `group` may say).
std::vector<std::string> known_group_names(const TetMesh& mesh);
/// known_group_names for a message: "bottom, tissue, 3 (unnamed)", or "none".
std::string known_groups_text(const TetMesh& mesh);
/// A physical group of a mesh as `ebh scene info` lists it.
struct MeshGroup {
  int tag = 0;       ///< its tag in the mesh (tet_group, triangle_group; 0: the elements of no group)
  int file_tag = 0;  ///< its number in the mesh file (Physical Surface(3), a Medit reference, a TetGen marker)
  std::string name;  ///< "" when unnamed
  long long tets = 0, triangles = 0;  ///< its elements (one in several groups counts in each)
};
/// The groups that a mesh names or that its elements are in, by tag, each with the number the
/// mesh file gives it (TetMesh::group_file_tags; where a reader kept the file's, the tag).
std::vector<MeshGroup> mesh_groups(const TetMesh& mesh);
/// Why a group the mesh file names holds no element (the pin errors say it): an MSH 4.1 file gives
/// elements their groups through $Entities, and one without that section, or with element blocks
/// on entities it does not list (as meshio writes it), has none; an MSH 2.2 element's first tag is
/// its group.
std::string group_without_elements_note(const TetMesh& mesh);
/// For a pin's group that the mesh does not have: ": 'NAME' is a physical group of points|curves
/// in the mesh file, ..." when the file names it at dimension 0 or 1 (pins take groups of tets or
/// triangles), else "".
std::string lower_dimension_group_note(const TetMesh& mesh, const std::string& group);
/// For a pin by group on a mesh read from `mesh_file`: where a .vtk, Medit or TetGen file keeps its
/// groups (": a VTK file's groups are the numbers in its cell array named ..."); "" for Gmsh's.
std::string file_groups_note(const std::filesystem::path& mesh_file);

/// The axis-aligned bounding box of points (lo = hi = 0 for none).
struct BoundingBox {
  Vec3d lo, hi;
  double diagonal() const { return norm(hi - lo); }
  Vec3d centre() const { return 0.5 * (lo + hi); }
};
BoundingBox bounding_box(const std::vector<Vec3d>& points);

/// `v` (a point or an offset in mesh.unit) as the scene's keys take it, "[x, y, z]", to 0.1 mm
/// however large (fixed_text).
std::string mesh_unit_text(const SceneSpec& spec, const Vec3d& v);
/// The mesh.transform.translate that brings `centre` (a point of the placed physical mesh, world
/// metres) to the world's origin: "[x, y, z], in UNIT" (mesh.unit). A mesh far from the origin
/// loses its positions' bits to round-off (float32 on the CUDA backend, double past ~1e6 times its
/// size); near it, it keeps them.
std::string translate_to_origin(const SceneSpec& spec, const Vec3d& centre);

/// The tool's sizes that meet tissue, with their keys under `tool.` ("shaft_radius",
/// "hook.tip_length", ... for the tool's kind), in metres: what the plausibility warnings compare
/// with the physical mesh's bounding-box diagonal (docs/FORMATS.md, "Plausibility warnings").
std::vector<std::pair<std::string, double>> tool_contact_sizes(const ToolSpec& tool);
/// A tool size below kToolSizeMinRatio or above kToolSizeMaxRatio times the physical mesh's
/// bounding-box diagonal is a warning, as is a diagonal outside [kMeshDiagonalMin, kMeshDiagonalMax] m.
inline constexpr double kToolSizeMinRatio = 1e-3;
inline constexpr double kToolSizeMaxRatio = 1.0;
/// The physical mesh's size once placed (mesh.unit, mesh.transform.scale; its farthest vertex from
/// vertex 0) lies in kMinPlacedDiagonal .. kMaxPlacedDiagonal metres: beyond, its tets' volumes
/// underflow or overflow.
inline constexpr double kMinPlacedDiagonal = 1e-30;
inline constexpr double kMaxPlacedDiagonal = 1e30;
/// solver.sleep, solver.physical_region or solver.active_region above this fraction of the physical
/// mesh's bounding-box diagonal warns: the mesh would stay still under the tool (solver.sleep at
/// 0.65% of the own-data organ's skipped 106 steps in contact: +12% peak force).
inline constexpr double kSolverThresholdMaxRatio = 0.001;
/// Soft tissue's densities (kg/m^3): a material.density outside warns.
inline constexpr double kTissueDensityMin = 100;
inline constexpr double kTissueDensityMax = 3000;
/// One Newton call of the virtual tool looks for contacts as far around it as it can move
/// (tool.newton_iterations x tool.max_step): beyond this many times what a hand moves an instrument
/// in a tick (kHandSpeedMax / time.haptic_hz) it weighs far tissue at every step and the ticks cost
/// more for nothing (cholecystectomy_grasp, CPU: 1.1x at 12 mm, 2.2x at 50 mm, 5.6x at 200 mm a
/// call; gap_insert 1.06x at 16 mm, 2.9x at 50 mm). The committed scenes and sweeps reach 0.5-16 mm.
inline constexpr double kNewtonReachMaxTicks = 20;
/// m/s: a hand moves an instrument at well under this (surgical motions ~0.1 m/s).
inline constexpr double kHandSpeedMax = 1.0;
/// degrees: a Newton step is scaled as a whole to its limits, so a turn limit below this caps its
/// translation too and the virtual tool lags the device (gap_insert, 2 s: 0.0001 put 27% of the ticks
/// at the force limit, 0.001 +14% at the peak, 0.01 as 0.5). The committed scenes use 0.5-2.
inline constexpr double kMinStepRotationDeg = 0.01;
inline constexpr double kMeshDiagonalMin = 1e-3;
inline constexpr double kMeshDiagonalMax = 2.0;
/// A virtual mesh more than this many of the physical mesh's diagonals off it is no surface of it:
/// refused where its corners are read (a stray vertex) and once its vertices are paired.
inline constexpr double kVirtualFarOff = 10;


/// One pinned region on one line, lengths in metres: "box min [x, y, z] max [x, y, z] m",
/// "sphere center [..] radius r m", "halfspace point [..] m normal [..]", "group NAME".
std::string describe_pin_region(const PinRegion& r);

/// Degrades the scene's physical mesh (mesh/degrade.hpp) with its pinned vertices kept where
/// they are: the stress meshes of `ebh scene degrade` and `ebh validate stability`.
DegradeReport degrade_physical_mesh(Scene& scene, const DegradeOptions& options);

/// Resolves NAME to <source>/scenarios/NAME.yaml (also looked up relative to the working
/// directory and $EBH_DATA_DIR); any other string is a path. Throws InputError if missing.
std::filesystem::path resolve_scene_path(const std::string& name_or_path);

/// Whether `name` is a scene made from the scene `base` by `ebh scene refine` (BASE_lN) or
/// `ebh scene degrade` (BASE_qQ): its recordings are base's.
bool derived_scene_name(const std::string& name, const std::string& base);

/// The scene file a recording's `scene` attribute names: a scene name (resolve_scene_path), or a
/// scene file's path, relative to the recording's folder (as `ebh import --scene` writes it) or,
/// failing that, to the working directory. Throws InputError "RECORDING: its scene attribute
/// 'NAME': ..." when it names none.
std::filesystem::path resolve_recording_scene(const std::string& attribute, const std::string& recording);

/// What `ebh import --scene` stores for `scene_file` in a recording written to `output`: a name
/// (no folder, no extension) as given; a path relative to the output's folder, so the two can move
/// together.
std::string scene_attribute_for(const std::string& given, const std::filesystem::path& scene_file,
                                const std::filesystem::path& output);

/// A scene or recording as the file that names it gives it (a sweep plan, a gate baselines file):
/// a name (no '/', no extension) or an absolute path as given, a relative path joined to `folder`
/// (that file's), so the file works from any working directory.
std::string data_reference_from(const std::string& given, const std::filesystem::path& folder);

/// What `ebh synth` stores for a plan's `scene` in a recording written to `output`: a name as given
/// (not looked up: a plan may name a scene not made yet); a scene file's path, relative to `folder`
/// (the plan's) unless absolute, that must name a file (resolve_scene_path's InputError) and is
/// stored as scene_attribute_for stores it, relative to the output's folder.
std::string scene_attribute_from(const std::string& given, const std::filesystem::path& folder,
                                 const std::filesystem::path& output);

/// A name to look for in the data folders ("tube"), not a path: no folder and no extension.
bool is_data_name(const std::string& s);

/// The same lookup for any data folder: NAME (no '/', no extension) finds FOLDER/NAME+EXTENSION in
/// $EBH_DATA_DIR, the working directory and the source tree; anything else must be an existing
/// file. `what` names the thing in messages ("scene", "recording").
std::filesystem::path resolve_data_path(const std::string& name_or_path, const std::string& folder,
                                        const std::string& extension, const std::string& what);

/// When `name` (a data name, not a path) resolved to `resolved` outside the source tree while the
/// source tree has another file of that name (other bytes): one line saying which is used, as a
/// scenarios/ or recordings/ folder in the working directory changes what a name means without a
/// word (a gate of the source tree's baselines run from there failed on the working directory's
/// tube). nullopt otherwise, and for a path.
std::optional<std::string> hidden_builtin(const std::string& name, const std::filesystem::path& resolved,
                                          const std::string& folder, const std::string& extension,
                                          const std::string& what);

/// Where names are looked up, in order: $EBH_DATA_DIR (when set), the working directory, the
/// source tree; each once.
std::vector<std::filesystem::path> data_roots();

/// Every FOLDER/*EXTENSION file (extension with its dot: ".h5") of the data roots, sorted by name
/// within a root; a name found in an earlier root hides the same name in later ones, as
/// resolve_data_path would. `recordings: all` in a sweep plan.
std::vector<std::filesystem::path> data_files(const std::string& folder, const std::string& extension);

}  // namespace ebh
