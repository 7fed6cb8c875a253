#include "tool/grasp.hpp"

#include "tool/contact.hpp"

namespace ebh {

void init_grasp(GraspState& g, std::size_t m) {
  g.closed = false;
  g.vertices.clear();
  g.local_target.clear();
  g.weight.clear();
  g.vertices.reserve(m);
  g.local_target.reserve(m);
  g.weight.reserve(m);
  g.held.assign(m, 0);
}

int update_grasp(const ToolModel& tool, const ToolPose& pose, double jaw, std::span<const Vec3d> q,
                 VertexGrid& grid, GraspState& g) {
  if (!tool.has_jaws) return 0;
  if (g.held.size() != q.size()) init_grasp(g, q.size());
  const ForcepsSpec& f = tool.spec.forceps;
  const bool closed = jaws_closed(tool, jaw, g.closed);
  if (closed == g.closed) return 0;
  g.closed = closed;
  if (!closed) {  // release
    for (const int i : g.vertices) g.held[i] = 0;
    g.vertices.clear();
    g.local_target.clear();
    g.weight.clear();
    return -1;
  }
  // Grasp, once at the closing: candidates within soft_margin of the hard box.
  PosedTool box;
  box.count = 1;
  box.shape[0] = grasp_hard_box(tool, jaw);
  box.world[0] = to_rigid(pose);
  box.reach[0] = 0.0;
  std::vector<int>& cand = g.vertices;  // reuse capacity: filtered in place below
  cand.clear();
  g.local_target.clear();
  g.weight.clear();
  gather_candidates(box, q, grid, f.soft_margin, 0.0, cand);
  const Rigid<double> frame = to_rigid(pose);
  const Collider<double>& hb = box.shape[0];
  std::size_t kept = 0;
  for (std::size_t j = 0; j < cand.size(); ++j) {
    const int i = cand[j];
    const Vec3d ls = apply_inverse(frame, q[i]);
    const double sd = signed_distance_local(hb, ls);
    if (!grasp_reaches(sd, f.soft_margin)) continue;
    const GraspPoint<double> p = grasp_point(hb, ls, sd, f.soft_margin, f.eta);
    cand[kept++] = i;
    g.local_target.push_back(p.local);
    g.weight.push_back(p.weight);
    g.held[i] = 1;
  }
  cand.resize(kept);
  return +1;
}

void grasp_targets(const GraspState& g, const ToolPose& pose, double k_con, std::vector<ContactTarget>& out) {
  const Rigid<double> frame = to_rigid(pose);
  for (std::size_t j = 0; j < g.vertices.size(); ++j)
    out.push_back({g.vertices[j], apply(frame, g.local_target[j]), k_con});
}

}  // namespace ebh
