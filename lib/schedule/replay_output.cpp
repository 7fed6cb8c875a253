#include "schedule/replay_output.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "tool/newton.hpp"
#include "tool/surface_contact.hpp"
#include "ebh/commit.hpp"
#include "ebh/version.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "mesh/quality.hpp"
#include "io/sha256.hpp"

namespace ebh {
namespace {

void push3(std::vector<double>& v, Vec3d a) { v.insert(v.end(), {a.x, a.y, a.z}); }
void push_pose(std::vector<double>& v, Vec3d p, Quatd q) { v.insert(v.end(), {p.x, p.y, p.z, q.w, q.x, q.y, q.z}); }

const char* method_name(SolverSpec::Method m) {
  switch (m) {
    case SolverSpec::Method::Jacobi: return "jacobi";
    case SolverSpec::Method::Chebyshev: return "chebyshev";
    case SolverSpec::Method::Direct: return "direct";
  }
  return "?";
}

/// Every parameter that shapes the result, as root attributes.
void write_parameters(h5::File& f, const World& w) {
  const SceneSpec& s = w.scene.spec;
  f.set_attr("haptic_hz", s.haptic_hz);
  f.set_attr("physical_hz", s.physical_hz);
  f.set_attr("interpolate_physical", static_cast<std::int64_t>(s.interpolate_physical));
  f.set_attr("k_vol", s.stiffness.k_vol);
  f.set_attr("k_s", s.stiffness.k_s);
  f.set_attr("k_svc", s.stiffness.k_svc);
  f.set_attr("k_con", s.stiffness.k_con);
  // With surface contact, the k_con its samples get (at least its floor: docs/MODEL.md).
  if (w.tool.surface) f.set_attr("k_con_surface", s.stiffness.k_con * w.tool.surface->stiffness_factor);
  f.set_attr("k_vcs", s.stiffness.k_vcs);
  f.set_attr("k_vct", s.stiffness.k_vct);
  f.set_attr("k_det", s.stiffness.k_det);
  f.set_attr("density", s.density);
  f.set_attr("damping", s.damping);
  f.set_attr("gravity", std::vector<double>{s.gravity.x, s.gravity.y, s.gravity.z});
  f.set_attr("solver_method", method_name(s.solver.method));
  f.set_attr("physical_iterations", static_cast<std::int64_t>(s.solver.physical_iterations));
  f.set_attr("virtual_iterations", static_cast<std::int64_t>(s.solver.virtual_iterations));
  f.set_attr("virtual_damping", s.solver.virtual_damping);
  f.set_attr("chebyshev_rho", w.physical_params.chebyshev_rho);  // the value used: `auto`'s on this mesh
  f.set_attr("chebyshev_rho_auto", static_cast<std::int64_t>(s.solver.chebyshev_rho_auto));
  f.set_attr("physical_tolerance", s.solver.physical_tolerance);
  f.set_attr("physical_max_iterations", static_cast<std::int64_t>(s.solver.physical_max_iterations));
  f.set_attr("virtual_refine", static_cast<std::int64_t>(s.virtual_refine));
  f.set_attr("contact", s.contact == ContactModel::Surface ? "surface" : "vertices");
  f.set_attr("active_region", s.solver.active_region);
  f.set_attr("physical_region", s.solver.physical_region);
  f.set_attr("sleep", s.solver.sleep);
  f.set_attr("recovery", s.solver.recovery == SolverSpec::Recovery::Direct ? "direct" : "none");
  f.set_attr("recovery_residual", s.solver.recovery_residual);
  f.set_attr("tool", s.tool.kind == ToolSpec::Kind::Hook ? "hook" : "forceps");
  f.set_attr("force_limit", s.tool.force_limit);
  f.set_attr("torque_limit", s.tool.torque_limit);
  f.set_attr("newton_iterations", static_cast<std::int64_t>(s.tool.newton_iterations));
  f.set_attr("newton_calls", static_cast<std::int64_t>(newton_calls_per_tick(s)));
  f.set_attr("max_step", s.tool.max_step);
  f.set_attr("max_step_rotation_deg", s.tool.max_step_rotation_deg);
  // The tool's geometry, in metres like every length here (length_unit).
  f.set_attr("length_unit", "m");
  f.set_attr("shaft_radius", s.tool.shaft_radius);
  f.set_attr("shaft_length", s.tool.shaft_length);
  if (s.tool.kind == ToolSpec::Kind::Hook) {
    f.set_attr("hook_tip_length", s.tool.hook.tip_length);
    f.set_attr("hook_tip_radius", s.tool.hook.tip_radius);
  } else {
    const ForcepsSpec& fc = s.tool.forceps;
    f.set_attr("forceps_jaw_length", fc.jaw_length);
    f.set_attr("forceps_jaw_width", fc.jaw_width);
    f.set_attr("forceps_jaw_thickness", fc.jaw_thickness);
    f.set_attr("forceps_jaw_max_angle_deg", fc.jaw_max_angle_deg);
    f.set_attr("forceps_grasp_threshold", fc.grasp_threshold);
    f.set_attr("forceps_release_threshold", fc.release());
    f.set_attr("forceps_soft_margin", fc.soft_margin);
    f.set_attr("forceps_eta", fc.eta);
  }
  std::string regions;
  for (const PinRegion& r : s.pinned) {
    if (!regions.empty()) regions += '\n';
    regions += describe_pin_region(r);
  }
  f.set_attr("pinned_regions", regions);
  f.set_attr("pinned_vertices", static_cast<std::int64_t>(w.scene.pinned.size()));
  f.set_attr("solver_diagonal", s.solver.diagonal == SolverSpec::Diagonal::Bounded ? "bounded" : "plain");
  f.set_attr("stabilization_translation", s.tool.stabilization_translation);
  f.set_attr("stabilization_rotation", s.tool.stabilization_rotation);
  f.set_attr("grasp", static_cast<std::int64_t>(s.stages.grasp));
  f.set_attr("settle_steps", static_cast<std::int64_t>(w.settle_steps));
  f.set_attr("projection", w.tool.projection == Projection::ClosestPoint ? "closest_point" : "inverse_normal");
}

std::string absolute(const std::string& path) {
  return std::filesystem::absolute(path).lexically_normal().string();
}

/// Where the run came from (docs/FORMATS.md, "Replay output"): every input file by absolute path and SHA-256, the
/// scene as it was resolved, the overrides, the window, and the build that ran it.
void write_provenance(h5::File& f, const World& w, const ReplayMetadata& meta) {
  const SceneSpec& s = w.scene.spec;
  auto input = [&](const std::string& key, const std::string& path) {
    const std::string where = absolute(path);
    f.set_attr(key, where);
    f.set_attr(key + "_sha256", meta.digests ? sha256_file_cached(*meta.digests, where) : sha256_file(path));
  };
  for (const SceneInputFile& file : scene_input_files(s)) input(file.key, file.path.string());
  if (!meta.recording.empty()) input("recording", meta.recording);
  else f.set_attr("recording", "");  // a replay of a recording built in memory (tests)
  f.set_attr("scene_yaml", resolved_scene_yaml(s));
  std::string overrides, overrides_list;
  for (const auto& o : meta.overrides) {
    if (!overrides.empty()) overrides += ' ';
    overrides += o;
    if (!overrides_list.empty()) overrides_list += '\n';
    overrides_list += o;
  }
  f.set_attr("overrides", overrides);
  f.set_attr("overrides_list", overrides_list);
  // The options as given (to replay again with them) and what was applied, in a recording's layout.
  f.set_attr("transform_option", meta.transforms.world);
  f.set_attr("tool_transform_option", meta.transforms.tool);
  if (meta.applied.world) f.set_attr("world_transform", to_attribute(*meta.applied.world));
  if (meta.applied.tool) f.set_attr("tool_transform", to_attribute(*meta.applied.tool));
  f.set_attr("start", meta.start);
  f.set_attr("duration", meta.duration);
  f.set_attr("frames_hz", meta.frames_hz);
  f.set_attr("version", std::string(kVersion));
  f.set_attr("git_commit", std::string(kGitCommit));
  f.set_attr("build_type", std::string(kBuildType));
  f.set_attr("compiler", std::string(kCompiler));
}

void write_rest_mesh(h5::File& f, const World& w) {
  h5::Group m = f.create_group("mesh");
  std::vector<double> q;
  for (const Vec3d& p : w.virtual_mesh.rest) push3(q, p);
  m.write<double>("virtual_rest", q, {w.virtual_mesh.rest.size(), 3}).set_attr("unit", "m");
  std::vector<std::int32_t> tri;
  for (const Tri& t : w.virtual_mesh.triangles) tri.insert(tri.end(), {t[0], t[1], t[2]});
  m.write<std::int32_t>("virtual_triangles", tri, {w.virtual_mesh.triangles.size(), 3}).set_attr("unit", "index");
  std::vector<double> x;
  for (const Vec3d& p : w.physical_mesh.rest) push3(x, p);
  m.write<double>("physical_rest", x, {w.physical_mesh.rest.size(), 3}).set_attr("unit", "m");
  std::vector<std::int32_t> tets;
  for (const Tet& t : w.physical_mesh.tets) tets.insert(tets.end(), {t[0], t[1], t[2], t[3]});
  m.write<std::int32_t>("physical_tets", tets, {w.physical_mesh.tets.size(), 4}).set_attr("unit", "index");
}

}  // namespace

namespace {
// Whole numbers as such ("10000000 ticks"), others with 4 significant digits ("1e+303").
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, std::fabs(v) < 1e15 && v == std::floor(v) ? "%.0f" : "%.4g", v);
  return buf;
}
std::string bytes(double b) {
  const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (b >= 1024 && u < 4) { b /= 1024; ++u; }
  if (u == 4 && b >= 1024) return num(b) + " TiB";
  return num(b) + " " + units[u];
}
}  // namespace

ReplaySize estimate_replay_size(const World& world, double duration, double frames_hz) {
  ReplaySize r;
  r.ticks = std::floor(duration / world.h_haptic + 1e-9) + 1;  // as tick_count(), in double: no overflow
  r.frames = frames_hz > 0 ? std::floor(duration * frames_hz + 1e-9) + 1 : 0;
  const double steps = r.ticks / world.ticks_per_step + 2;
  const double step_bytes = 5 * 8 + 8;  // /physical and the step timings
  r.memory_bytes = r.ticks * kReplayBytesPerTick + steps * step_bytes;
  const double m = static_cast<double>(world.virtual_mesh.rest.size());
  const double nx = static_cast<double>(world.physical_mesh.rest.size());
  const double frame_bytes = 12 * (m + nx) + 16 * 8;  // float32 positions, t, jaw, two poses
  const double mesh_bytes = 24 * (m + nx) + 12 * static_cast<double>(world.virtual_mesh.triangles.size()) +
                            16 * static_cast<double>(world.physical_mesh.tets.size());
  r.file_bytes = r.memory_bytes + r.frames * frame_bytes + mesh_bytes;
  return r;
}

void check_replay_size(const World& world, double duration, double frames_hz, const std::string& recording,
                       const std::string& output) {
  const ReplaySize r = estimate_replay_size(world, duration, frames_hz);
  if (!(r.ticks <= kMaxReplayTicks))
    throw InputError(recording + ": replaying " + num(duration) + " s at " + num(1.0 / world.h_haptic) + " Hz makes " +
                     num(r.ticks) + " ticks; the limit is " + num(kMaxReplayTicks) + " ticks (" +
                     bytes(kMaxReplayTicks * kReplayBytesPerTick) +
                     " of rows held in memory): replay a shorter window (--start, --duration) or at a lower rate");
  if (!(r.file_bytes <= kMaxReplayOutputBytes))
    throw InputError(output + ": " + num(r.frames) + " mesh snapshots (" + num(frames_hz) + " per s over " +
                     num(duration) + " s) make an output of " + bytes(r.file_bytes) + "; the limit is " +
                     bytes(kMaxReplayOutputBytes) + ": lower --frames-hz or replay a shorter window");
  // The output is written at the end (the snapshots as they come): a disk that cannot hold it
  // would fail the replay after its whole run.
  if (const std::optional<std::uint64_t> free = free_bytes_for(output); free && r.file_bytes > static_cast<double>(*free))
    throw InputError(output + ": the output takes about " + bytes(r.file_bytes) +
                     (r.frames > 0 ? " (" + num(r.frames) + " mesh snapshots, " + num(frames_hz) + " per s)" : std::string()) +
                     ", and its folder's file system has " + bytes(static_cast<double>(*free)) +
                     " free: free space, lower --frames-hz or replay a shorter window");
}

std::string cpu_description() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  }
  return "unknown CPU";
}

ReplayWriter::ReplayWriter(const std::string& out_path, const World& world, const ReplayMetadata& meta,
                           std::int64_t expected_ticks, bool frames)
    : out_(out_path), frames_(frames) {
  const NewtonReach reach = newton_reach_of_calls(newton_limits(world.tool.spec), newton_calls_per_tick(world.scene.spec));
  reach_ = reach.translation;
  turn_reach_ = reach.rotation;
  const auto n = static_cast<std::size_t>(expected_ticks);
  // The ticks' rows stay in memory until the end (the file is written whole, atomically): a long
  // replay under a memory limit says so here, with what it needs, rather than "out of memory".
  try {
    for (auto* v : {&t_, &pen_, &pen_h_, &jaw_, &tm_total_, &tm_device_, &tm_sync_, &tm_grasp_, &tm_vmesh_, &tm_vtool_,
                    &tm_output_})
      v->reserve(n);
    force_.reserve(3 * n);
    torque_.reserve(3 * n);
    pose_h_.reserve(7 * n);
    pose_g_.reserve(7 * n);
    fclamp_.reserve(n);
    tclamp_.reserve(n);
    contacts_.reserve(n);
    grasped_.reserve(n);
    const std::size_t steps = n / static_cast<std::size_t>(world.ticks_per_step) + 2;
    for (auto* v : {&pt_, &residual_, &reduction_, &tm_step_, &tm_local_, &tm_global_}) v->reserve(steps);
    iterations_.reserve(steps);
  } catch (const std::bad_alloc&) {
    char line[400];
    std::snprintf(line, sizeof line,
                  ": out of memory for the replay's %zu ticks, kept in memory until the output is written whole "
                  "(about %.3g MB at ~%.0f bytes a tick): replay a window of the recording (--start, --duration), "
                  "or give the process more memory (ulimit -v, the job's limit)",
                  n, static_cast<double>(n) * kReplayBytesPerTick / 1e6, kReplayBytesPerTick);
    throw InputError(out_path + line);
  }

  h5::File& f = out_.file();
  f.set_attr("scene", world.scene.spec.name);
  f.set_attr("mode", meta.mode);
  f.set_attr("backend", meta.backend);
  f.set_attr("device", meta.device);
  f.set_attr("threads", static_cast<std::int64_t>(omp_get_max_threads()));
  if (meta.backend == "cpu") {  // the CPU backend's split of them between the sides
    f.set_attr("haptic_threads", static_cast<std::int64_t>(meta.threads.haptic));
    f.set_attr("physical_threads", static_cast<std::int64_t>(meta.threads.physical));
    f.set_attr("shared_physical_loops", static_cast<std::int64_t>(meta.threads.shared_physical_loops));
    f.set_attr("shared_virtual_loops", static_cast<std::int64_t>(meta.threads.shared_virtual_loops));
  }
  write_provenance(f, world, meta);
  write_parameters(f, world);
  write_rest_mesh(f, world);
  if (frames_) {
    h5::Group g = f.create_group("frames");
    const std::size_t m = world.virtual_mesh.rest.size(), nx = world.physical_mesh.rest.size();
    f_t_ = g.create_appendable<double>("t", {}, 64);
    f_jaw_ = g.create_appendable<double>("jaw", {}, 64);
    f_q_ = g.create_appendable<float>("virtual_positions", {m, 3}, 1);
    f_x_ = g.create_appendable<float>("physical_positions", {nx, 3}, 1);
    f_pose_ = g.create_appendable<double>("tool_poses", {2, 7}, 64);
    f_t_.set_attr("unit", "s");
    f_jaw_.set_attr("unit", "1 (0 closed, 1 open)");
    f_q_.set_attr("unit", "m");
    f_x_.set_attr("unit", "m");
    f_pose_.set_attr("unit", "m, 1 (row 0 physical tool, row 1 virtual tool: px py pz qw qx qy qz)");
    scratch_f_.reserve(3 * std::max(m, nx));
  }
}

void ReplayWriter::on_tick(const World&, const HapticSide& h, double t) {
  t_.push_back(t);
  push3(force_, h.output.force);
  push3(torque_, h.output.torque);
  fclamp_.push_back(h.output.force_clamped);
  tclamp_.push_back(h.output.torque_clamped);
  push_pose(pose_h_, h.device.position, h.device.orientation);
  push_pose(pose_g_, h.tool.pose.position, h.tool.pose.orientation);
  pen_.push_back(h.penetration);
  pen_h_.push_back(h.penetration_physical);
  jaw_.push_back(h.device.jaw);
  contacts_.push_back(h.contact_count);
  grasped_.push_back(h.grasped);
  active_.push_back(h.active_vertices);
  tm_total_.push_back(h.timing.total);
  tm_device_.push_back(h.timing.device);
  tm_sync_.push_back(h.timing.physical_sync);
  tm_grasp_.push_back(h.timing.grasp);
  tm_vmesh_.push_back(h.timing.virtual_mesh);
  tm_vtool_.push_back(h.timing.virtual_tool);
  tm_output_.push_back(h.timing.output);
  const double f = norm(h.output.force);
  if (f > peak_force_ || std::isnan(f)) peak_force_ = f;
  const double torque = norm(h.output.torque);
  if (torque > peak_torque_ || std::isnan(torque)) peak_torque_ = torque;
  if (h.penetration > max_penetration_) max_penetration_ = h.penetration;
  clamped_ += h.output.force_clamped ? 1 : 0;
  in_contact_ += h.contact_count > 0 ? 1 : 0;
  free_clamped_ += h.output.force_clamped && h.contact_count == 0 ? 1 : 0;
  free_torque_clamped_ += h.output.torque_clamped && h.contact_count == 0 ? 1 : 0;
  if (pose_h_.size() >= 14) {
    const double* p = pose_h_.data() + pose_h_.size() - 14;  // the tick before's px py pz qw qx qy qz, then this one's
    const double step = norm(Vec3d{p[7] - p[0], p[8] - p[1], p[9] - p[2]});
    if (step > max_device_step_) max_device_step_ = step;
    if (step > reach_ * (1 + 1e-9)) ++outpaced_;
    const double cos_half = std::min(1.0, std::abs(p[3] * p[10] + p[4] * p[11] + p[5] * p[12] + p[6] * p[13]));
    const double turn = 2 * std::acos(cos_half);
    if (turn > max_device_turn_) max_device_turn_ = turn;
    if (turn > turn_reach_ * (1 + 1e-9)) ++outturned_;
  }
}

double short_step_yardstick(const PhysicalStepParams& params) {
  if (params.tolerance == 0) return SolverSpec{}.physical_tolerance;
  return params.method == SolverSpec::Method::Direct ? params.tolerance : 0;
}

void ReplayWriter::on_step(const World& w, const PhysicalSide& p, double t) {
  const PhysicalStepParams& params = w.physical_params;
  capped_steps_ += params.adaptive() && !p.recovered && p.report.iterations >= params.max_iterations &&
                   p.report.residual > params.tolerance;
  // Stopped by the stall rule well above the tolerance: the iteration made no headway on this mesh
  // (slivers: ~1e3 relaxed Jacobi iterations per tenfold) and the step's answer is not converged.
  // A step of the device's float32 stalls at its round-off floor, up to ~1.6x the default
  // tolerance on the committed scenes (docs/MODEL.md, "The stopping rule"): below the factor.
  if (params.adaptive() && !p.recovered && !p.slept && p.report.iterations < params.max_iterations &&
      p.report.residual > kStalledResidualFactor * params.tolerance &&
      p.report.residual <= w.scene.spec.solver.recovery_residual) {
    if (stalled_steps_++ == 0) first_stalled_t_ = t;
    max_stalled_ = std::max(max_stalled_, p.report.residual);
  }
  // A fixed iteration count runs its iterations and stops: nothing else says when they were too
  // few. The direct method (a stiffness far above the others left 0.9 mesh weights after 8, 0.5
  // after 64), and any method under physical_tolerance 0, the paper's fixed K (tube_grasp with 8
  // Chebyshev iterations: the residual grew from step to step, 28 mesh weights at 3 s), judged
  // against the default tolerance.
  if (const double yardstick = short_step_yardstick(params);
      yardstick > 0 && !p.recovered && !p.slept && p.report.residual > kStalledResidualFactor * yardstick &&
      p.report.residual <= w.scene.spec.solver.recovery_residual) {
    if (short_steps_++ == 0) first_short_t_ = t;
    max_short_ = std::max(max_short_, p.report.residual);
  }
  // Far from balance, whatever stopped the step (the cap, a stall, fixed iterations, the direct
  // method's local-global iterations): the recovery's line, which the CUDA backend and
  // solver.recovery=none do not act on. NaN counts: the health check names it.
  if (!(p.report.residual <= w.scene.spec.solver.recovery_residual)) {
    if (unbalanced_steps_++ == 0) first_unbalanced_t_ = t;
    if (!(p.report.residual <= max_unbalanced_)) max_unbalanced_ = p.report.residual;
  }
  pt_.push_back(t);
  iterations_.push_back(p.report.iterations);
  const int inverted = p.report.inverted >= 0 ? inverted_tets_.record(p.report.inverted)
                                             : inverted_tets_.count(w.physical_mesh.rest, w.physical_mesh.tets, p.mesh.x);
  inverted_.push_back(inverted);
  if (inverted > 0 && first_inverted_t_ < 0) first_inverted_t_ = t;
  residual_.push_back(p.report.residual);
  reduction_.push_back(p.report.residual_reduction);
  recovered_.push_back(p.recovered ? 1 : 0);
  slept_.push_back(p.slept ? 1 : 0);
  slept_steps_ += p.slept ? 1 : 0;
  awake_.push_back(p.report.awake);
  recovered_steps_ += p.recovered ? 1 : 0;
  recovery_factorize_s_ = p.recovery_factorize_s;
  tm_step_.push_back(p.report.time_s);
  tm_local_.push_back(p.report.local_s);
  tm_global_.push_back(p.report.global_s);
}

void ReplayWriter::on_frame(const World&, const HapticSide& h, double t) {
  if (!frames_) return;
  f_t_.append_row(std::span<const double>(&t, 1));
  f_jaw_.append_row(std::span<const double>(&h.device.jaw, 1));
  auto append_positions = [this](h5::Appender<float>& a, const std::vector<Vec3d>& p) {
    scratch_f_.clear();
    for (const Vec3d& v : p) scratch_f_.insert(scratch_f_.end(), {float(v.x), float(v.y), float(v.z)});
    a.append(scratch_f_);
  };
  append_positions(f_q_, h.mesh.q);
  append_positions(f_x_, h.visible.x);
  const double poses[14] = {h.device.position.x, h.device.position.y, h.device.position.z,
                            h.device.orientation.w, h.device.orientation.x, h.device.orientation.y,
                            h.device.orientation.z, h.tool.pose.position.x, h.tool.pose.position.y,
                            h.tool.pose.position.z, h.tool.pose.orientation.w, h.tool.pose.orientation.x,
                            h.tool.pose.orientation.y, h.tool.pose.orientation.z};
  f_pose_.append(std::span<const double>(poses, 14));
}

bool ReplayWriter::should_stop() { return interrupted(); }

namespace {
/// The mean of a region's per-tick or per-step sizes; -1 when the region is off (its entries -1).
double region_mean(const std::vector<std::int32_t>& sizes) {
  if (sizes.empty() || sizes.front() < 0) return -1;
  double sum = 0;
  for (const std::int32_t a : sizes) sum += a;
  return sum / static_cast<double>(sizes.size());
}
}  // namespace

double ReplayWriter::active_mean() const { return region_mean(active_); }
double ReplayWriter::awake_mean() const { return region_mean(awake_); }

void ReplayWriter::commit(const ReplaySummary& s) {
  finish(s);
  publish();
}

void ReplayWriter::finish(const ReplaySummary& s) {
  h5::File& f = out_.file();
  const std::size_t n = t_.size(), k = pt_.size();
  // Every dataset carries its unit (SI; docs/FORMATS.md).
  auto unit = [](h5::Dataset d, const char* u) { d.set_attr("unit", u); };
  h5::Group hg = f.create_group("haptic");
  unit(hg.write<double>("t", t_, {n}), "s");
  unit(hg.write<double>("force", force_, {n, 3}), "N");
  unit(hg.write<double>("torque", torque_, {n, 3}), "N m");
  unit(hg.write<std::uint8_t>("force_clamped", fclamp_, {n}), "1");
  unit(hg.write<std::uint8_t>("torque_clamped", tclamp_, {n}), "1");
  unit(hg.write<double>("pose_physical", pose_h_, {n, 7}), "m, 1 (px py pz qw qx qy qz)");
  unit(hg.write<double>("pose_virtual", pose_g_, {n, 7}), "m, 1 (px py pz qw qx qy qz)");
  unit(hg.write<double>("penetration", pen_, {n}), "m");
  unit(hg.write<double>("penetration_physical", pen_h_, {n}), "m");
  unit(hg.write<double>("jaw", jaw_, {n}), "1 (0 closed, 1 open)");
  unit(hg.write<std::int32_t>("contacts", contacts_, {n}), "count");
  unit(hg.write<std::int32_t>("grasped", grasped_, {n}), "count");
  if (!active_.empty() && active_.front() >= 0)  // the active region is on (HapticSide::active_vertices)
    unit(hg.write<std::int32_t>("active", active_, {n}), "vertices (iterated: solver.active_region)");
  h5::Group pg = f.create_group("physical");
  unit(pg.write<double>("t", pt_, {k}), "s");
  unit(pg.write<std::int32_t>("iterations", iterations_, {k}), "count");
  unit(pg.write<double>("residual", residual_, {k}), "1 (unbalanced force / mesh weight)");
  unit(pg.write<double>("residual_reduction", reduction_, {k}), "1 (last / first iteration)");
  unit(pg.write<std::uint8_t>("recovered", recovered_, {k}), "1 (redone with the direct solve)");
  unit(pg.write<std::int32_t>("inverted", inverted_, {k}), "tets (inverted or flat after the step)");
  unit(pg.write<std::uint8_t>("slept", slept_, {k}), "1 (skipped, the state held: solver.sleep or an empty awake region)");
  if (!awake_.empty() && awake_.front() >= 0)  // the awake region is on (PhysicalStepReport::awake)
    unit(pg.write<std::int32_t>("awake", awake_, {k}), "vertices (iterated: solver.physical_region)");
  h5::Group tg = f.create_group("timing");
  unit(tg.write<double>("haptic_step_s", tm_total_, {n}), "s");
  unit(tg.write<double>("device_s", tm_device_, {n}), "s");
  unit(tg.write<double>("physical_sync_s", tm_sync_, {n}), "s");
  unit(tg.write<double>("grasp_s", tm_grasp_, {n}), "s");
  unit(tg.write<double>("virtual_mesh_s", tm_vmesh_, {n}), "s");
  unit(tg.write<double>("virtual_tool_s", tm_vtool_, {n}), "s");
  unit(tg.write<double>("output_s", tm_output_, {n}), "s");
  unit(tg.write<double>("physical_step_s", tm_step_, {k}), "s");
  unit(tg.write<double>("physical_local_s", tm_local_, {k}), "s");
  unit(tg.write<double>("physical_global_s", tm_global_, {k}), "s");
  f.set_attr("ticks", static_cast<std::int64_t>(s.ticks));
  f.set_attr("steps", static_cast<std::int64_t>(s.steps));
  f.set_attr("virtual_s", s.virtual_s);
  f.set_attr("wall_s", s.wall_s);
  out_.close_and_sync();
}

}  // namespace ebh
