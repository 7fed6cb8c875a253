#include "tool/virtual_tool.hpp"

#include <algorithm>
#include <cmath>

#include "tool/newton.hpp"

namespace ebh {
namespace {

/// Contacts of the candidates (vertices, or surface samples) against the tool at `pose` (grasped
/// vertices excluded).
void detect_at(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
               std::span<const Vec3d> normals, const VirtualToolState& st, std::vector<ContactPoint>& out) {
  if (tool.surface)
    sample_narrow_phase(*tool.surface, pose_tool(tool, pose, jaw), st.samples, q, out);
  else
    narrow_phase(pose_tool(tool, pose, jaw), tool.projection, st.candidates, q, normals, st.grasp.held, out);
}

/// E_tool [2]+[3] at `pose` from already detected contacts; grad/hess/step may be null.
double energy_at(const ToolModel& tool, const Stiffness& k, const ToolPose& physical, const ToolPose& pose,
                 std::span<const Vec3d> q, const VirtualToolState& st, std::span<const ContactPoint> contacts,
                 Vec6* grad, Mat6* hess_step) {
  Vec6 g_tvc, g_con, g_gr;
  Mat6 H_con, H_gr;
  const bool d = grad != nullptr;
  double e = coupling_energy(pose, physical, k.k_vcs, k.k_vct, d ? &g_tvc : nullptr, nullptr);
  // Stabilisation (ToolSpec): the same spring form as E_tvc [2], tying X_g to its pose at the
  // start of the tick; zero at a steady state, so it changes no equilibrium, only the approach.
  const double s_t = tool.spec.stabilization_translation, s_r = tool.spec.stabilization_rotation;
  if (s_t > 0 || s_r > 0) {
    Vec6 g_s;
    e += coupling_energy(pose, st.anchor, s_t, s_r, d ? &g_s : nullptr, nullptr);
    if (d) g_tvc += g_s;
  }
  e += contact_energy(contacts, pose.position, k.k_con, d ? &g_con : nullptr, hess_step ? &H_con : nullptr);
  e += grasp_energy(st.grasp, q, pose, k.k_con, d ? &g_gr : nullptr, hess_step ? &H_gr : nullptr);
  if (grad) *grad = g_tvc + g_con + g_gr;
  if (hess_step) {
    Mat6 Hc = H_con + H_gr;
    if (st.hessian == NewtonHessian::GaussNewton) {
      Hc.setZero();
      for (const ContactPoint& c : contacts) {
        const Vec3d rn = cross(c.lever - pose.position, c.normal);
        Vec6 J;
        J << c.normal.x, c.normal.y, c.normal.z, rn.x, rn.y, rn.z;
        J *= c.gain;
        Hc += k.k_con * c.weight * J * J.transpose();
      }
      Hc += H_gr;  // the grasp energy's Hessian is PSD up to its (e.s) term; clamp below
    }
    Eigen::SelfAdjointEigenSolver<Mat6> es(0.5 * (Hc + Hc.transpose()));
    const Vec6 lambda = es.eigenvalues().cwiseMax(0.0);
    *hess_step = es.eigenvectors() * lambda.asDiagonal() * es.eigenvectors().transpose();
    hess_step->topLeftCorner<3, 3>() += k.k_vcs * Eigen::Matrix3d::Identity();
    hess_step->bottomRightCorner<3, 3>() += (k.k_vct + s_r) * Eigen::Matrix3d::Identity();
    hess_step->topLeftCorner<3, 3>() += s_t * Eigen::Matrix3d::Identity();
  }
  return e;
}

}  // namespace

void init_virtual_tool(VirtualToolState& st, std::size_t m, const ToolPose& pose) {
  st.pose = pose;
  st.anchor = pose;
  init_grasp(st.grasp, m);
  st.candidates.clear();
  st.candidates.reserve(m);
  st.contacts.clear();
  st.contacts.reserve(m);
  st.trial.clear();
  st.trial.reserve(m);
  st.energy = 0.0;
  st.steps_taken = st.steps_rejected = 0;
}

void update_virtual_tool(const ToolModel& tool, const Stiffness& k, const ToolPose& physical, double jaw,
                         std::span<const Vec3d> q, std::span<const Vec3d> normals, VertexGrid& grid,
                         VirtualToolState& st) {
  const NewtonLimits lim = newton_limits(tool.spec);
  const int iterations = lim.iterations;
  const double max_step = lim.max_step, max_rot = lim.max_rot;
  // Broad phase once per call, covering every pose the step limits let the iterations reach.
  st.candidates.clear();
  const PosedTool start = pose_tool(tool, st.pose, jaw);
  const double T = lim.reach_translation, th = lim.reach_rotation;
  if (tool.surface)
    gather_samples(*tool.surface, start, q, grid, T, th, st.grasp.held, st.surface_scratch, st.samples);
  else  // the vertices one of this call's iterates can reach: the Newton iterations test only those
    gather_reachable(start, q, grid, T, th, st.candidates);
  st.steps_taken = st.steps_rejected = 0;

  detect_at(tool, st.pose, jaw, q, normals, st, st.contacts);
  Vec6 g;
  Mat6 H;
  double E = energy_at(tool, k, physical, st.pose, q, st, st.contacts, &g, &H);
  for (int it = 0; it < iterations; ++it) {
    Vec6 dx = H.ldlt().solve(-g);  // eq. (9) with the positive definite H_step
    if (!dx.allFinite()) { ++st.steps_rejected; break; }
    const double scale = std::min({1.0, max_step / std::max(dx.head<3>().norm(), 1e-300),
                                   max_rot / std::max(dx.tail<3>().norm(), 1e-300)});
    dx *= scale;
    const double slope = g.dot(dx);  // < 0: H_step is positive definite
    // Converged: the predicted decrease is below round-off of E (no halving could show it).
    if (!newton_decrease_visible(slope, E)) break;
    if (newton_step_roundoff(dx.head<3>().norm(), dx.tail<3>().norm(), st.pose.position)) break;
    double alpha = 1.0;
    bool accepted = false;
    for (int h = 0; h < kNewtonMaxHalvings; ++h, alpha *= 0.5) {
      const ToolPose trial = perturb(st.pose, alpha * dx);
      detect_at(tool, trial, jaw, q, normals, st, st.trial);
      const double Et = energy_at(tool, k, physical, trial, q, st, st.trial, nullptr, nullptr);
      if (armijo_accepts(Et, E, alpha, slope)) {
        st.pose = trial;
        st.contacts.swap(st.trial);
        accepted = true;
        break;
      }
    }
    if (!accepted) { ++st.steps_rejected; break; }
    ++st.steps_taken;
    E = energy_at(tool, k, physical, st.pose, q, st, st.contacts, &g, &H);
  }
  st.energy = E;
  st.call_fresh = true;  // st.contacts are the final pose's at this q (virtual_mesh_targets)
}

double tool_energy(const ToolModel& tool, const Stiffness& k, const ToolPose& physical, double jaw,
                   std::span<const Vec3d> q, std::span<const Vec3d> normals, VertexGrid& grid,
                   VirtualToolState& st) {
  st.candidates.clear();
  if (tool.surface)
    gather_samples(*tool.surface, pose_tool(tool, st.pose, jaw), q, grid, 0.0, 0.0, st.grasp.held,
                   st.surface_scratch, st.samples);
  else
    gather_candidates(pose_tool(tool, st.pose, jaw), q, grid, 0.0, 0.0, st.candidates);
  detect_at(tool, st.pose, jaw, q, normals, st, st.contacts);
  st.call_fresh = false;  // no Newton call's: found with no reach
  return energy_at(tool, k, physical, st.pose, q, st, st.contacts, nullptr, nullptr);
}

void virtual_mesh_targets(const ToolModel& tool, const Stiffness& k, double jaw, std::span<const Vec3d> q,
                          std::span<const Vec3d> normals, VertexGrid& grid, VirtualToolState& st,
                          std::vector<ContactTarget>& out) {
  if (st.call_fresh && !tool.surface) {
    // The Newton call's contacts at this pose and q: detect_contacts' set and targets (the same
    // vertex_contact, grasped vertices excluded alike), in the candidates' order; the mesh sums
    // its targets per vertex, so the order changes no bit.
    for (const ContactPoint& c : st.contacts) out.push_back({c.vertex, c.target, k.k_con});
  } else if (tool.surface && st.call_fresh)
    sample_targets(*tool.surface, pose_tool(tool, st.pose, jaw), st.samples, q, k.k_con, st.surface_scratch, out);
  else if (tool.surface)
    surface_contact_targets(*tool.surface, tool, st.pose, jaw, q, grid, k.k_con, st.grasp.held, st.surface_scratch,
                            out);
  else
    detect_contacts(tool, st.pose, jaw, q, normals, grid, k.k_con, out, st.grasp.held);
  grasp_targets(st.grasp, st.pose, k.k_con, out);
  st.call_fresh = false;  // the iteration these targets are for moves q
}

ToolOutput tool_output(const ToolModel& tool, const Stiffness& k, const ToolPose& physical,
                       const VirtualToolState& st) {
  const CouplingOutput<double> c = coupling_output(st.pose.position, st.pose.orientation, physical.position,
                                                    physical.orientation, k.k_vcs, k.k_vct, tool.spec.force_limit,
                                                    tool.spec.torque_limit);
  return {c.force, c.torque, c.force_clamped, c.torque_clamped};
}

}  // namespace ebh
