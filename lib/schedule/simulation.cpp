#include "schedule/simulation.hpp"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "energy/quadratic.hpp"
#include "mesh/quality.hpp"
#include "mesh/surface.hpp"
#include "tool/contact.hpp"
#include "tool/newton.hpp"
#include "tool/surface_contact.hpp"
#include "tool/grasp.hpp"
#if EBH_HAVE_CUDA
#include "schedule/haptic_cuda.hpp"
#endif

namespace ebh {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Times one stage into `slot` (wall clock; timings are the only non-deterministic output).
template <class F>
void timed(double& slot, F&& stage) {
  const auto t0 = Clock::now();
  stage();
  slot = seconds_since(t0);
}

ToolPose pose_of(const DeviceSample& s) { return {s.position, s.orientation}; }

/// Whether the CUDA backend's device tick runs the active region for this tool: vertex contact,
/// a tool the device tick supports (schedule/haptic_cuda.hpp).
bool cuda_active_region([[maybe_unused]] const ToolModel& tool) {
#if EBH_HAVE_CUDA
  return !tool.surface && device_haptic_supported(tool);
#else
  return false;
#endif
}

/// Whether the CUDA physical step can sleep in this build (graph conditional nodes).
bool cuda_physical_sleep() {
#if EBH_HAVE_CUDA
  return CudaPhysicalSolver::can_sleep();
#else
  return false;
#endif
}

#if !EBH_HAVE_CUDA
[[noreturn]] void throw_no_cuda_build() {
  throw InputError("--backend cuda: this build has no CUDA backend (configure with -DEBH_WITH_CUDA=ON where nvcc is installed)");
}
#endif

/// Normals are read only by the paper's inverse-normal projection; the closest-point default
/// skips them.
std::span<const Vec3d> normals_if_needed(const World& world, const HapticSide& h) {
  if (world.tool.projection == Projection::InverseNormal) return h.normals;
  return {};
}

// ---- Algorithm 2, one stage a function -------------------------------------------------------

/// Line 4: the physical tool X_h follows the device.
void read_device(HapticSide& h, const DeviceSample& sample) {
  h.device = sample;
  h.tool.anchor = h.tool.pose;  // the virtual tool's pose at the start of this tick
}

/// The physical positions this tick's E_svc targets come from: the visible result, or (with
/// time.interpolate_physical) a linear blend from the previous result reaching it N ticks after
/// it arrived. Returns the positions and a version that changes whenever they do.
std::pair<std::span<const Vec3d>, std::int64_t> physical_targets(const World& world, HapticSide& h) {
  if (!world.scene.spec.interpolate_physical || h.previous_x.empty()) return {h.visible.x, h.visible.step};
  const double a = physical_blend(h.tick, h.delivered_tick, world.ticks_per_step);
  if (a >= 1.0) return {h.visible.x, h.visible.step};
  for (std::size_t i = 0; i < h.visible.x.size(); ++i) h.targets_x[i] = lerp(h.previous_x[i], h.visible.x[i], a);
  return {h.targets_x, -2 - h.tick};  // a version no physical step number takes
}

/// The active region's seeds (solver/active_region.hpp): the virtual vertices the virtual tool
/// can reach in this tick's Newton calls (the broad phase around its pose, which adds the grid's
/// margin), or with surface contact the corners of the triangles whose samples it can reach, and
/// the grasped vertices.
void gather_region_seeds(const World& world, HapticSide& h) {
  h.region_seeds.clear();
  const NewtonReach reach = newton_reach_of_calls(newton_limits(world.tool.spec), newton_calls_per_tick(world.scene.spec));
  const double T = reach.translation, th = reach.rotation;
  const PosedTool posed = pose_tool(world.tool, h.tool.pose, h.device.jaw);
  if (world.tool.surface) {
    gather_samples(*world.tool.surface, posed, h.mesh.q, h.grid, T, th, {}, h.tool.surface_scratch, h.region_samples);
    for (const SurfaceSample& p : h.region_samples)
      for (const int v : world.tool.surface->triangles[p.triangle]) h.region_seeds.push_back(v);
  } else {
    gather_candidates(posed, h.mesh.q, h.grid, T, th, h.region_seeds);
  }
  h.region_seeds.insert(h.region_seeds.end(), h.tool.grasp.vertices.begin(), h.tool.grasp.vertices.end());
}

/// physical_targets for the active region, which blends the paired points instead of the
/// physical positions (solver/active_region.hpp).
PhysicalTargets region_targets(const World& world, const HapticSide& h) {
  if (!world.scene.spec.interpolate_physical || h.previous_x.empty()) return {h.visible.x, h.visible.x, 1.0, h.visible.step};
  return {h.previous_x, h.visible.x, physical_blend(h.tick, h.delivered_tick, world.ticks_per_step), h.visible.step,
          h.previous_step};
}

/// Lines 1 and 6: E_svc targets from the physical mesh, inertial prediction of q (on the active
/// region, or the whole virtual mesh).
void sync_physical_targets(const World& world, HapticSide& h) {
  if (h.region) {
    gather_region_seeds(world, h);
    virtual_begin_tick_active(world.virtual_mesh, h.workspace, *h.region, h.mesh, region_targets(world, h),
                              world.h_haptic, h.region_seeds);
  } else {
    const auto [physical_x, version] = physical_targets(world, h);
#if EBH_HAVE_CUDA
    if (h.cuda) {
      h.workspace.q_start = h.mesh.q;  // the tick's start, for the broad phase's drift bound
      h.cuda->begin_tick(physical_x, version, world.h_haptic, h.mesh.q);
    } else
#endif
    virtual_begin_tick(world.virtual_mesh, h.workspace, h.mesh, physical_x, world.h_haptic);
  }
  h.tool.call_fresh = false;  // q moved to its prediction: the last Newton call's contacts are stale
  if (world.tool.projection == Projection::InverseNormal)
    compute_vertex_normals(world.virtual_mesh, h.mesh.q, h.normals);
}

/// §5.2: the jaws closing past the threshold grasp, opening releases (forceps scenes only).
void update_grasp_stage(const World& world, HapticSide& h) {
  if (!world.scene.spec.stages.grasp || !world.tool.has_jaws) return;
  update_grasp(world.tool, h.tool.pose, h.device.jaw, h.mesh.q, h.grid, h.tool.grasp);
}

/// Lines 10-16: contact (and grasp) targets of the virtual tool held fixed, then one local-global
/// iteration of the virtual mesh.
void virtual_mesh_iteration(const World& world, HapticSide& h) {
  h.contacts.clear();
  virtual_mesh_targets(world.tool, world.scene.spec.stiffness, h.device.jaw, h.mesh.q, normals_if_needed(world, h),
                       h.grid, h.tool, h.contacts);
#if EBH_HAVE_CUDA
  if (h.cuda)
    h.cuda->iteration(h.contacts, h.mesh.q);
  else
#endif
  if (h.region)
    virtual_iteration_active(world.virtual_mesh, h.workspace, *h.region, h.mesh, h.contacts);
  else
    virtual_iteration(world.virtual_mesh, h.workspace, h.mesh, h.contacts);
  h.contact_count = static_cast<int>(h.contacts.size());
}

/// Lines 18-19: Newton steps of the virtual tool on E_tool with the virtual mesh held fixed.
void virtual_tool_iteration(const World& world, HapticSide& h) {
  update_virtual_tool(world.tool, world.scene.spec.stiffness, pose_of(h.device), h.device.jaw, h.mesh.q,
                      normals_if_needed(world, h), h.grid, h.tool);
}

/// Lines 22-27: velocities, the force and torque for the device, penetration depths.
void emit_output(const World& world, HapticSide& h) {
  // The broad phase tolerates a bounded drift of q from where it was built.
  if (h.region) {
    h.grid.note_motion(virtual_end_tick_active(world.virtual_mesh, h.workspace, *h.region, h.mesh));
    h.active_vertices = static_cast<int>(h.region->vertices.size());
  } else {
#if EBH_HAVE_CUDA
    if (h.cuda)
      h.cuda->end_tick();
    else
#endif
    virtual_end_tick(world.virtual_mesh, h.workspace, h.mesh);
    double moved = 0;
    for (std::size_t i = 0; i < h.mesh.q.size(); ++i)
      moved = std::max(moved, squared_norm(h.mesh.q[i] - h.workspace.q_start[i]));
    h.grid.note_motion(std::sqrt(moved));
  }
  h.output = tool_output(world.tool, world.scene.spec.stiffness, pose_of(h.device), h.tool);
  h.grasped = static_cast<int>(h.tool.grasp.vertices.size());
  // The virtual tool's contacts at its final pose are at hand from its last Newton step.
  h.penetration = 0;
  for (const ContactPoint& c : h.tool.contacts) h.penetration = std::max(h.penetration, c.depth);
  h.penetration_physical =
      world.tool.surface
          ? surface_penetration_depth(*world.tool.surface, world.tool, pose_of(h.device), h.device.jaw, h.mesh.q, h.grid,
                                      h.tool.grasp.held, h.tool.surface_scratch)
          : penetration_depth(world.tool, pose_of(h.device), h.device.jaw, h.mesh.q, h.grid, h.tool.grasp.held);
}

/// Settling that moves a vertex more than this fraction of the physical mesh's bounding-box
/// diagonal is warned: the committed scenes under gravity settle by 1% (gap: 0.44 mm) and less, a
/// 200 x 10 x 10 mm bar of soft tissue pinned at one end hangs down by 146%.
constexpr double kSettleSagWarnRatio = 0.1;

/// The static equilibrium of the physical mesh under gravity (no contact, coupling satisfied):
/// static steps (h = 1e3 s leaves M / h^2 ~ 1e-9 of the stiffness while the prediction keeps
/// the full weight M g) with the exact global solve until no vertex moves more than 5 um in a
/// step, at most 25 steps: large sags (a liver hanging from its back strip moves centimetres)
/// converge slowly under local-global iterations, and the dynamic replay (with its damping)
/// absorbs what is left, which is then a fraction of a millimetre. `capped`: it stopped at the cap
/// with a vertex still moving (warned).
int settle_under_gravity(const Scene& scene, PhysicalState& state, std::vector<std::string>& warnings, bool& capped) {
  const std::string where = scene.spec.file.string();
  if (scene.pinned.empty())
    throw InputError(where + ": nothing is pinned, so under gravity the physical mesh has no static equilibrium "
                             "to start from (pin a region, or set stages.settle: false or gravity: [0, 0, 0])");
  if (!scene.free_parts.empty())
    throw InputError(where + ": " + std::to_string(scene.free_parts.size()) +
                     " part(s) of the physical mesh touch no pinned vertex (the first holds " +
                     vertex_name(scene.physical, scene.free_parts.front().first) + " and " +
                     std::to_string(scene.free_parts.front().second) +
                     " vertices), so under gravity they have no static equilibrium to start from (pin each part, "
                     "or set stages.settle: false or gravity: [0, 0, 0])");
  PhysicalModelOptions opt;
  opt.h = 1e3;
  opt.factorize = true;
  const PhysicalModel statics = build_physical_model(scene, nullptr, opt);
  PhysicalWorkspace ws = make_physical_workspace(statics);
  state = make_physical_state(statics);
  PhysicalStepParams params;
  params.method = SolverSpec::Method::Direct;
  params.iterations = 4;
  constexpr int kMaxSteps = 25;
  constexpr double kSettled = 5e-6;  // m per static step
  std::vector<Vec3d> before;
  double moved = 0;
  int steps = 0;
  while (steps < kMaxSteps) {
    before = state.x;
    const PhysicalStepReport report = physical_step(statics, ws, state, {}, params);
    ++steps;
    const std::string problem = physical_state_problem(statics, state.x, report);
    if (!problem.empty()) {
      const std::string soft = too_soft_for_own_weight(scene);
      throw NumericalError(where + ": settling under gravity, static step " + std::to_string(steps) + ": " + problem +
                           (soft.empty() ? "" : "; " + soft));
    }
    moved = 0;
    for (std::size_t i = 0; i < before.size(); ++i) moved = std::max(moved, norm(state.x[i] - before[i]));
    if (moved < kSettled) break;
  }
  capped = moved >= kSettled;
  if (capped) {
    char line[256];
    std::snprintf(line, sizeof line,
                  "%s: settling under gravity stopped at its cap of %d static steps with a vertex still moving "
                  "%.3g mm per step: the replay starts before the physical mesh has settled",
                  where.c_str(), kMaxSteps, moved * 1e3);
    warnings.emplace_back(line);
  }
  // A mesh that hangs far from its shape (a slender part pinned at one end droops from it): the
  // replay's tissue is not the mesh the user drew.
  int most = 0;
  double sag = 0;
  for (std::size_t i = 0; i < state.x.size(); ++i)
    if (const double d = norm(state.x[i] - scene.physical.vertices[i]); d > sag) {
      sag = d;
      most = static_cast<int>(i);
    }
  const double diagonal = bounding_box(scene.physical.vertices).diagonal();
  if (sag > kSettleSagWarnRatio * diagonal) {
    char line[512];
    std::snprintf(line, sizeof line,
                  "%s: under gravity the physical mesh %s %.3g mm from its shape in the mesh file (%s; %.0f%% of its "
                  "bounding-box diagonal): it hangs from its pins; an organ segmented in situ is already held "
                  "(gravity: [0, 0, 0]), else pin more of it",
                  where.c_str(), capped ? "moved" : "settles", sag * 1e3,
                  vertex_name(scene.physical, most).c_str(), 100 * sag / diagonal);
    warnings.emplace_back(line);
  }
  for (Vec3d& v : state.v) v = Vec3d{};
  return steps;
}

/// The world's virtual tool from its scene (the only part of a world the tool's stiffnesses touch
/// besides the spec: WorldCache).
void build_world_tool(World& w) {
  w.tool = build_tool(w.scene.spec.tool);
  if (w.scene.spec.contact == ContactModel::Surface)
    attach_surface_contact(w.tool, w.virtual_mesh.triangles, w.virtual_mesh.rest, w.scene.spec.stiffness.k_con);
}

}  // namespace

std::shared_ptr<const World> build_world(Scene scene, double haptic_hz, double physical_hz, Backend backend) {
  const std::string where = scene.spec.file.string();
  if (!(haptic_hz >= kMinReplayHapticHz) || !(physical_hz >= kMinReplayPhysicalHz) || physical_hz > haptic_hz ||
      !(haptic_hz <= kMaxHapticHz)) {
    char why[300];
    std::snprintf(why, sizeof why,
                  "rates must satisfy %g <= physical_hz <= haptic_hz <= %g Hz, haptic_hz >= %g Hz (got haptic %s Hz, "
                  "physical %s Hz)",
                  kMinReplayPhysicalHz, kMaxHapticHz, kMinReplayHapticHz, shortest_text(haptic_hz).c_str(),
                  shortest_text(physical_hz).c_str());
    throw InputError(where + ": " + why);
  }
  const double ratio = haptic_hz / physical_hz;
  if (!whole_ticks_per_step(haptic_hz, physical_hz))
    throw InputError(where + ": haptic_hz / physical_hz must be a whole number of ticks per physical step (got " +
                     std::to_string(ratio) + ")");
  auto w = std::make_shared<World>();
  w->backend = backend;
  w->scene = std::move(scene);
  w->h_haptic = 1.0 / haptic_hz;
  w->h_physical = 1.0 / physical_hz;
  w->ticks_per_step = static_cast<int>(std::lround(ratio));
  w->scene.spec.haptic_hz = haptic_hz;
  w->scene.spec.physical_hz = physical_hz;
  w->virtual_mesh = build_virtual_model(w->scene);
  check_virtual_mesh_placement(w->scene, w->virtual_mesh, w->scene.warnings);
  w->physical_mesh = build_physical_model(w->scene, &w->virtual_mesh, physical_model_options(w->scene.spec));
  w->physical_params = physical_params(w->scene.spec.solver, w->physical_mesh);
  if (backend == Backend::Cuda) {
    w->float32_floor = float32_residual_floor(w->physical_mesh);
    if (std::string line = float32_placement_warning(w->scene.spec, w->physical_mesh, w->float32_floor); !line.empty())
      w->scene.warnings.push_back(std::move(line));
  }
  if (w->physical_params.method == SolverSpec::Method::Chebyshev &&
      w->physical_params.chebyshev_rho > kChebyshevRhoWarn) {
    char line[480];
    std::snprintf(line, sizeof line,
                  ": key 'solver.chebyshev_rho': Chebyshev's rho is %.4g%s: so near 1 its weights (up to %.2f) amplify what the local steps' "
                  "rotations change between iterations, and steps can blow up (a sliver mesh's did from 0.997; "
                  "docs/MODEL.md, \"Chebyshev's rho\"); the scenes' 0.95 or solver.method: direct is safer",
                  w->physical_params.chebyshev_rho, w->scene.spec.solver.chebyshev_rho_auto ? " (auto: this mesh's relaxed Jacobi rate)" : "",
                  2 / (1 + std::sqrt(1 - w->physical_params.chebyshev_rho * w->physical_params.chebyshev_rho)));
    w->scene.warnings.push_back(value_source(w->scene.spec, "solver.chebyshev_rho") + line);
  }
  build_world_tool(*w);
  if (w->tool.surface) {
    const std::string mesh = w->scene.spec.virtual_mesh ? w->scene.spec.virtual_mesh->string() : where;
    for (const std::string& line : surface_contact_warnings(*w->tool.surface, w->virtual_mesh.rest))
      w->scene.warnings.push_back(mesh + ": " + line);
    // One Newton step longer than the tool's thinnest part can carry that part through the surface
    // between two ticks (a 0.3 mm tip with 0.5 mm steps: the force fell from 1.4 to 0.2 N).
    const ToolSpec& t = w->scene.spec.tool;
    if (t.max_step > w->tool.surface->spacing) {
      char line[320];
      std::snprintf(line, sizeof line,
                    ": tool.max_step = %.4g mm is above the tool's thinnest part (%.4g mm): with contact: surface one "
                    "Newton step can carry that part through the surface; set tool.max_step at most %.4g (tool.unit, %s)",
                    t.max_step * 1e3, w->tool.surface->spacing * 1e3, w->tool.surface->spacing / t.unit,
                    t.unit_name.c_str());
      w->scene.warnings.push_back(value_source(w->scene.spec, "tool.max_step") + line);
    }
    // The stiffness floor follows the force limit: a limit far above a device's makes a contact
    // stiffer than any device renders, against which the virtual mesh's iterations do not settle
    // (a 1000 N limit: 6.7e5 N/m, the force moving by 0.2 N with the coordinates' round-off).
    const double k_surface = w->scene.spec.stiffness.k_con * w->tool.surface->stiffness_factor;
    if (w->tool.surface->stiffness_factor > 1 && k_surface > kMaxDeviceStiffness) {  // k_con itself: tool_stiffness_warnings
      char line[360];
      std::snprintf(line, sizeof line,
                    ": with contact: surface the stiffness floor F_limit / (1.5 x the tool's thinnest part) raises "
                    "k_con to %.3g N/m (tool.force_limit %.4g N over %.4g mm), beyond the %.0e N/m a haptic device "
                    "renders: the virtual mesh's iterations do not settle against it; lower tool.force_limit",
                    k_surface, t.force_limit, w->tool.surface->spacing * 1e3, kMaxDeviceStiffness);
      w->scene.warnings.push_back(value_source(w->scene.spec, "tool.force_limit") + line);
    }
  } else if (const double gap = median_circumradius(w->virtual_mesh.rest, w->virtual_mesh.triangles),
             thinnest = thinnest_part(w->tool);
             thinnest < 0.5 * gap) {
    // Vertex contact feels a tool part only through the virtual vertices inside it: a part narrower
    // than the gaps between them passes through the surface touching none (a 0.3 mm needle tip
    // pressed 1.5 mm into the gap's block, whose triangles' circumradius is 0.8 mm: in contact on 1%
    // of the ticks, 0.004 N; with contact: surface 0.29 N). The committed scenes' tools are 0.66 to
    // 1.4 times their meshes' median circumradius.
    const bool hook = w->scene.spec.tool.kind == ToolSpec::Kind::Hook;
    char line[480];
    std::snprintf(line, sizeof line,
                  ": the tool's thinnest part (%.3g mm: %s) is under half the virtual mesh's typical triangle "
                  "circumradius (%.3g mm, the median): with contact: vertices (the paper's) it fits between the "
                  "virtual vertices and can pass through the surface touching none, rendering no force; contact: "
                  "surface tests the triangles (docs/MODEL.md, \"Contact against the surface\")",
                  thinnest * 1e3, hook ? "tool.hook.tip_radius or tool.shaft_radius" :
                                         "half tool.forceps.jaw_thickness or jaw_width, or tool.shaft_radius",
                  gap * 1e3);
    w->scene.warnings.push_back(value_source(w->scene.spec, "contact") + line);
  }
  if (backend == Backend::Cuda && w->scene.spec.solver.sleep > 0 && !cuda_physical_sleep()) {
    if (w->scene.spec.solver.sleep_given)
      w->scene.warnings.push_back(where + ": key 'solver.sleep': the CUDA backend runs every physical step and ignores "
                                        "it (docs/MODEL.md, \"Sleeping\")");
    w->scene.spec.solver.sleep = 0;
  }
  if (backend == Backend::Cuda && w->scene.spec.solver.active_region > 0 && !cuda_active_region(w->tool)) {
    if (w->scene.spec.solver.active_region_given)
      w->scene.warnings.push_back(where + ": key 'solver.active_region': the CUDA backend's device tick has it with vertex "
                                        "contact and the closest-point projection only; this scene's tick iterates the "
                                        "whole virtual mesh and ignores it (docs/CUDA.md, \"The active region\")");
    w->scene.spec.solver.active_region = 0;
  }
  w->initial_physical = make_physical_state(w->physical_mesh);
  if (w->scene.spec.stages.settle && squared_norm(w->scene.spec.gravity) > 0)
    w->settle_steps = settle_under_gravity(w->scene, w->initial_physical, w->scene.warnings, w->settle_capped);
  w->initial_virtual.assign(w->virtual_mesh.rest.size(), Vec3d{});
  paired_points(w->virtual_mesh, w->initial_physical.x, w->initial_virtual);
  return w;
}

std::shared_ptr<const World> WorldCache::get(SceneSpec spec, double haptic_hz, double physical_hz, Backend backend) {
  // The key: everything in effect but the tool's stiffnesses, the rates and the backend.
  SceneSpec keyed = spec;
  keyed.stiffness.k_con = keyed.stiffness.k_vcs = keyed.stiffness.k_vct = 0;
  char rates[96];
  std::snprintf(rates, sizeof rates, "%.17g %.17g %d\n", haptic_hz, physical_hz, static_cast<int>(backend));
  const std::string key = spec.file.string() + "\n" + rates + resolved_scene_yaml(keyed);
  std::shared_future<std::shared_ptr<const World>> future;
  std::promise<std::shared_ptr<const World>> promise;
  bool first = false;
  {
    std::lock_guard lock(mutex_);
    auto [it, inserted] = entries_.try_emplace(key);
    if (inserted) {
      it->second = promise.get_future().share();
      first = true;
      ++built_;
    }
    future = it->second;
  }
  if (first) {
    try {
      promise.set_value(build_world(build_scene(spec), haptic_hz, physical_hz, backend));
    } catch (...) {
      promise.set_exception(std::current_exception());  // every user of the entry gets the error
    }
  }
  const std::shared_ptr<const World> base = future.get();  // waits while another thread builds it
  if (first) return base;
  const Stiffness& k = base->scene.spec.stiffness;
  if (k.k_con == spec.stiffness.k_con && k.k_vcs == spec.stiffness.k_vcs && k.k_vct == spec.stiffness.k_vct)
    return base;
  auto w = std::make_shared<World>(*base);
  w->scene.spec.stiffness.k_con = spec.stiffness.k_con;
  w->scene.spec.stiffness.k_vcs = spec.stiffness.k_vcs;
  w->scene.spec.stiffness.k_vct = spec.stiffness.k_vct;
  w->scene.spec.overrides = spec.overrides;  // messages name this replay's overrides
  build_world_tool(*w);
  return w;
}

int WorldCache::built() const {
  std::lock_guard lock(mutex_);
  return built_;
}

HapticSide make_haptic_side(const World& world, const DeviceSample& first_sample) {
  HapticSide h;
  h.mesh = make_virtual_state(world.virtual_mesh);
  h.mesh.q = world.initial_virtual;
  h.workspace = make_virtual_workspace(world.virtual_mesh);
  if (world.backend == Backend::Cpu && world.scene.spec.solver.active_region > 0) {
    // Interpolated targets move every tick: the strain check runs a slice a tick, each vertex once
    // a physical period, rather than all of them on the tick a result arrives (the tick's tail).
    h.region = make_active_region(world.virtual_mesh, world.scene.spec.solver.active_region,
                                  world.scene.spec.interpolate_physical ? world.ticks_per_step : 1);
    h.region_seeds.reserve(h.mesh.q.size());
  }
  h.normals.assign(h.mesh.q.size(), Vec3d{});
  compute_vertex_normals(world.virtual_mesh, h.mesh.q, h.normals);
  init_virtual_tool(h.tool, h.mesh.q.size(), pose_of(first_sample));
  h.contacts.reserve(h.mesh.q.size() * 2);
  h.visible.x = world.initial_physical.x;
  h.visible.step = -1;
  h.grid.rebuild(h.mesh.q, world.grid_margin);
  h.device = first_sample;
  if (world.backend == Backend::Cuda) {
#if EBH_HAVE_CUDA
    h.cuda = std::make_unique<CudaVirtualSolver>(world.virtual_mesh);
    h.cuda->upload_state(h.mesh);
#else
    throw_no_cuda_build();
#endif
  }
  return h;
}

PhysicalSide make_physical_side(const World& world, bool beside_ticks) {
  PhysicalSide p;
  p.mesh = world.initial_physical;
  p.workspace = make_physical_workspace(world.physical_mesh);
  if (world.backend == Backend::Cpu && world.scene.spec.solver.physical_region > 0)
    p.region = std::make_unique<PhysicalRegion>(
        make_physical_region(world.physical_mesh, world.scene.spec.solver.physical_region));
  if (world.backend == Backend::Cuda) {
#if EBH_HAVE_CUDA
    CudaPhysicalOptions options;
    options.beside_ticks = beside_ticks;
    options.sleep = world.scene.spec.solver.sleep;
    options.region = world.scene.spec.solver.physical_region;
    p.cuda = std::make_unique<CudaPhysicalSolver>(world.physical_mesh, world.physical_params, options);
    p.cuda->upload_state(p.mesh);
#else
    (void)beside_ticks;
    throw_no_cuda_build();
#endif
  }
  return p;
}

void take_haptic_snapshot(const HapticSide& haptic, HapticSnapshot& out) { out.q = haptic.mesh.q; }

void take_physical_snapshot(const PhysicalSide& physical, PhysicalSnapshot& out) {
  out.x = physical.mesh.x;
  out.step = physical.step - 1;
}

void deliver_physical_snapshot(const World& world, HapticSide& haptic, const PhysicalSnapshot& snapshot) {
  if (world.scene.spec.interpolate_physical) {
    haptic.previous_x.swap(haptic.visible.x);
    haptic.previous_step = haptic.visible.step;
    haptic.targets_x.resize(snapshot.x.size());
  }
  haptic.delivered_tick = haptic.tick;
  haptic.visible.x = snapshot.x;
  haptic.visible.step = snapshot.step;
  haptic.grid.rebuild(haptic.mesh.q, world.grid_margin);
}

double physical_blend(std::int64_t n, std::int64_t delivered, int N) {
  const std::int64_t since = n - delivered + 1;
  return since >= N ? 1.0 : static_cast<double>(since) / N;
}

void haptic_tick(const World& world, HapticSide& h, const DeviceSample& sample) {
  HapticTiming& t = h.timing;
  const auto t0 = Clock::now();
  timed(t.device, [&] { read_device(h, sample); });
  timed(t.physical_sync, [&] { sync_physical_targets(world, h); });
  timed(t.grasp, [&] { update_grasp_stage(world, h); });
  t.virtual_mesh = t.virtual_tool = 0;
  // Lines 8-21; a Newton call follows the last tool.newton_calls iterations (all by default).
  const int iterations = world.scene.spec.solver.virtual_iterations;
  const int first_call = iterations - newton_calls_per_tick(world.scene.spec);
  h.newton_calls = 0;
  for (int i = 0; i < iterations; ++i) {
    double a = 0, b = 0;
    timed(a, [&] { virtual_mesh_iteration(world, h); });
    if (i >= first_call) {
      timed(b, [&] { virtual_tool_iteration(world, h); });
      ++h.newton_calls;
    }
    t.virtual_mesh += a;
    t.virtual_tool += b;
  }
  timed(t.output, [&] { emit_output(world, h); });
  t.total = seconds_since(t0);
  ++h.tick;
}

namespace {
/// The recording's samples a device sample at the recording's time t was read from (sample_at):
/// "the recording's sample I (t = T s)", or "... samples I and J (t = T0 .. T1 s)" where it
/// interpolates; I and J are the file's rows.
std::string samples_read(const Recording& rec, double t) {
  const auto time = [](double v) {  // a log's own clock may count from 1970: all its digits
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.15g", v);
    return std::string(buf);
  };
  const std::size_t n = rec.size();
  const std::size_t after = static_cast<std::size_t>(std::upper_bound(rec.t.begin(), rec.t.end(), t) - rec.t.begin());
  const auto one = [&](std::size_t i) {
    return "the recording's sample " + std::to_string(rec.row(i)) + " (t = " + time(rec.t[i]) + " s)";
  };
  if (n == 0) return "no sample";
  if (after == 0) return one(0);
  if (after == n || rec.t[after - 1] == t) return one(after - 1);
  return "the recording at t = " + time(t) + " s, between its samples " + std::to_string(rec.row(after - 1)) + " and " +
         std::to_string(rec.row(after)) + " (t = " + time(rec.t[after - 1]) + " .. " + time(rec.t[after]) + " s)";
}
}  // namespace

void check_haptic_tick(const World& world, std::int64_t tick, const ToolOutput& output, const Recording& rec,
                       const DeviceSample& sample) {
  const auto ok = [](const Vec3d& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (ok(output.force) && ok(output.torque)) return;
  char pose[96];
  std::snprintf(pose, sizeof pose, "(%g, %g, %g) m", sample.position.x, sample.position.y, sample.position.z);
  throw NumericalError(world.scene.spec.file.string() + ": tick " + std::to_string(tick) +
                       ": the force or torque on the virtual tool is not finite; the tick read the device at " + pose +
                       " from " + samples_read(rec, sample.t));
}

namespace {

/// check_physical_step with the health check's finding already made ("" when healthy).
void stop_on_physical_problem(const World& world, const PhysicalSide& p, const std::string& problem) {
  if (problem.empty()) return;
  const std::int64_t k = p.step - 1;
  const SolverSpec& solver = world.scene.spec.solver;
  // What the user can change: the CUDA backend has neither the direct method nor the recovery.
  const std::string raise = " (the iterations did not converge: raise solver.physical_iterations" +
                            std::string(solver.physical_tolerance == 0
                                            ? ", or turn the stopping rule back on (solver.physical_tolerance=0.002)"
                                            : "");
  std::string hint = p.recovered ? " (also after redoing the step with the direct solve)"
                     : solver.method == SolverSpec::Method::Direct ? ""
                     : solver.diagonal == SolverSpec::Diagonal::Plain
                         ? " (solver.diagonal=plain diverges on such tets: use bounded)"
                     : world.backend == Backend::Cuda
                         ? raise + ", or replay with --backend cpu, whose recovery redoes such a step with the direct solve)"
                     : solver.recovery == SolverSpec::Recovery::None
                         ? raise + ", use solver.method=direct, or turn solver.recovery back on)"
                         : raise + " or use solver.method=direct)";
  // The device's float32 alone leaves this mesh that far from balance at rest: no iteration count helps.
  if (float32_round_off(world, p.report.residual))
    hint += "; this mesh's float32 round-off alone leaves " + shown_number(world.float32_floor) +
            " mesh weights unbalanced at rest (`ebh scene info`: its tets are too flat for the device's float32): "
            "replay with --backend cpu, or remesh";
  // The scene-load warning's cause, named where it shows (docs/MODEL.md, "k_s against k_svc").
  if (p.beside_ticks && world.scene.spec.stiffness.edges_outweigh_coupling())
    hint += "; stiffness.k_s above k_svc can make the two meshes drive each other unstable in async mode: raise k_svc "
            "or replay --mode lockstep";
  const double alpha = world.scene.spec.solver.virtual_damping;
  const double h = world.h_haptic, h_default = 1 / SceneSpec{}.haptic_hz;
  const double per_tick_default = SolverSpec{}.virtual_damping * h_default;  // 250 / s at 1 kHz
  if (alpha == 0) {
    hint += "; solver.virtual_damping is 0: the virtual mesh's velocity, carried from tick to tick, can make the two "
            "meshes drive each other unstable with few solver.virtual_iterations (docs/MODEL.md, \"Damping of the virtual mesh\")";
  } else if (alpha * h < per_tick_default) {
    // The damping is a rate per second: at a haptic rate above 1 kHz a tick keeps more of the velocity
    // (tube_insert at 10 kHz / 1 kHz diverged in async mode with 250 / s; 2500 / s or lockstep completed).
    // The velocity a tick keeps: h times the factor on q - q_start (energy/quadratic.hpp).
    const double kept = h * tick_velocity_scale(h, alpha);
    const double kept_default = h_default * tick_velocity_scale(h_default, SolverSpec{}.virtual_damping);
    hint += "; at " + shown_number(1 / h) + " Hz the virtual mesh keeps " + shown_number(kept) +
            " of its velocity a tick (" + shown_number(kept_default) +
            " at the scenes' 1 kHz), which can make the two meshes drive each other unstable: raise "
            "solver.virtual_damping to about " + shown_number(per_tick_default / h) + " / s" +
            (p.beside_ticks ? " or replay --mode lockstep" : "") + " (docs/MODEL.md, \"Damping of the virtual mesh\")";
  }
  throw NumericalError(world.scene.spec.file.string() + ": tick " + std::to_string(k * world.ticks_per_step) +
                       ", physical step " + std::to_string(k) + ": " + problem + hint);
}

}  // namespace

void check_physical_step(const World& world, const PhysicalSide& p) {
  stop_on_physical_problem(world, p, physical_state_problem(world.physical_mesh, p.mesh.x, p.report));
}

namespace {
/// Whether the physical step may be skipped (SolverSpec::sleep): a step ran before and met the
/// stopping rule's tolerance (when there is one), it moved no vertex by more than the sleep length
/// (|v| h, the state it ends in being at rest within that), and no virtual vertex, the step's only
/// input that changes, moved by more than the sleep length since that step. A contact or a grasp
/// moves the virtual mesh and so wakes it.
bool physical_mesh_asleep(const World& world, const PhysicalSide& p, const HapticSnapshot& snapshot) {
  const double d = world.scene.spec.solver.sleep, h = world.h_physical;
  if (p.step == 0 || p.ran_with.size() != snapshot.q.size() || p.recovered) return false;
  const double tolerance = world.physical_params.tolerance;  // 0: fixed iterations, no residual test
  if (tolerance > 0 && !(p.report.residual <= tolerance)) return false;
  const double d2 = d * d;
  for (const Vec3d& v : p.mesh.v)
    if (squared_norm(v) * (h * h) > d2) return false;
  for (std::size_t j = 0; j < snapshot.q.size(); ++j)
    if (squared_norm(snapshot.q[j] - p.ran_with[j]) > d2) return false;
  return true;
}

/// A skipped step (solver.sleep, or an empty awake region): the state held, at rest.
void hold_physical_state(PhysicalSide& p) {
  for (Vec3d& v : p.mesh.v) v = Vec3d{};
  p.report.iterations = 0;
  p.report.residual_reduction = 1;
  p.report.time_s = p.report.local_s = p.report.global_s = 0;
  p.report.slept = true;
  p.report.awake = 0;
  p.slept = true;
  p.recovered = false;
  ++p.step;
}
}  // namespace

void run_physical_step(const World& world, PhysicalSide& p, const HapticSnapshot& snapshot, SharedLoops* shared,
                       const std::function<bool()>& cancel) {
#if EBH_HAVE_CUDA
  if (p.cuda) {
    p.report = p.cuda->step(p.mesh, snapshot.q);
    p.slept = p.report.slept;
    ++p.step;
    check_physical_step(world, p);
    return;
  }
#endif
  const PhysicalModel& model = world.physical_mesh;
  const SolverSpec& solver = world.scene.spec.solver;
  p.slept = solver.sleep > 0 && physical_mesh_asleep(world, p, snapshot);
  if (p.slept) {
    hold_physical_state(p);
    return;
  }
  PhysicalRegion* region = p.region.get();
  if (region && choose_awake(model, p.workspace, snapshot.q, p.step == 0, *region) == 0) {
    hold_physical_state(p);  // nothing moves: the step is skipped, as a sleeping mesh's
    return;
  }
  if (solver.sleep > 0) p.ran_with = snapshot.q;  // keeps its capacity: no allocation after the first step
  const bool can_recover =
      solver.recovery == SolverSpec::Recovery::Direct && solver.method != SolverSpec::Method::Direct;
  if (can_recover) p.start = p.mesh;  // the vectors keep their capacity: no allocation after the first step
  p.report = physical_step(model, p.workspace, p.mesh, snapshot.q, world.physical_params, nullptr, shared, region, cancel);
  if (p.report.cancelled) return;
  std::string problem = physical_state_problem(model, p.mesh.x, p.report);  // the health check, once
  p.recovered = can_recover && (p.report.residual > solver.recovery_residual || !problem.empty());
  if (p.recovered) {
    double time_s = p.report.time_s;
    if (!p.recovery_direct) {  // the factorisation is the recovering step's work: in its time
      const auto t0 = std::chrono::steady_clock::now();
      p.recovery_direct = factorize_global_matrix(assemble_global_matrix(model), world.scene.spec.file.string());
      p.recovery_factorize_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      time_s += p.recovery_factorize_s;
    }
    p.mesh = p.start;
    PhysicalStepParams direct = world.physical_params;
    direct.method = SolverSpec::Method::Direct;
    p.report = physical_step(model, p.workspace, p.mesh, snapshot.q, direct, p.recovery_direct.get(), shared, nullptr,
                             cancel);
    p.report.time_s += time_s;
    if (p.report.cancelled) return;
    problem = physical_state_problem(model, p.mesh.x, p.report);
    if (region) region->all = true;  // the direct solve moved every vertex
  }
  if (region) {
    saw_virtual_mesh(model, snapshot.q, *region);
    p.report.awake = region->all ? model.num_free : static_cast<int>(region->vertices.size());
  }
  ++p.step;
  stop_on_physical_problem(world, p, problem);
}

}  // namespace ebh
