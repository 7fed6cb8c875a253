#include "tool/tool_energy.hpp"

#include <cmath>

#include "tool/newton.hpp"

namespace ebh {

ToolPose perturb(const ToolPose& pose, const Vec6& x) {
  ToolPose p;
  p.position = pose.position + Vec3d{x[0], x[1], x[2]};
  p.orientation = trial_orientation(Vec3d{x[3], x[4], x[5]}, pose.orientation);
  return p;
}

double coupling_energy(const ToolPose& g, const ToolPose& h, double k_vcs, double k_vct, Vec6* grad, Mat6* hess) {
  const CouplingOffset<double> o = coupling_offset(g.position, g.orientation, h.position, h.orientation);
  if (grad) {
    double gr[6];
    coupling_gradient(o, k_vcs, k_vct, gr);
    *grad << gr[0], gr[1], gr[2], gr[3], gr[4], gr[5];
  }
  if (hess) {
    const Vec3d v = o.v;
    const double theta = norm(v);
    hess->setZero();
    hess->topLeftCorner<3, 3>() = k_vcs * Eigen::Matrix3d::Identity();
    // (theta/2) cot(theta/2) -> 1 - theta^2/12 for small theta.
    const double half = 0.5 * theta;
    const double c = theta < 1e-4 ? 1.0 - theta * theta / 12.0 : half / std::tan(half);
    Eigen::Matrix3d aa = Eigen::Matrix3d::Zero();
    if (theta > 0) { Eigen::Vector3d a(v.x / theta, v.y / theta, v.z / theta); aa = a * a.transpose(); }
    hess->bottomRightCorner<3, 3>() = k_vct * (aa + c * (Eigen::Matrix3d::Identity() - aa));
  }
  return coupling_energy_value<CouplingAngle::OfNorm>(o, k_vcs, k_vct);
}

double contact_energy(std::span<const ContactPoint> contacts, const Vec3d& P, double k_con, Vec6* grad, Mat6* hess) {
  double g[6] = {0, 0, 0, 0, 0, 0};
  double H[36] = {};
  double e = 0.0;
  for (const ContactPoint& c : contacts)
    e += contact_terms(k_con * c.weight, c.phi, c.gain, c.normal, c.lever - P, c.hess_sd, c.exact, g, H);
  if (grad) for (int i = 0; i < 6; ++i) (*grad)[i] = g[i];
  if (hess) for (int i = 0; i < 6; ++i) for (int j = 0; j < 6; ++j) (*hess)(i, j) = H[6 * i + j];
  return e;
}

double grasp_energy(const GraspState& grasp, std::span<const Vec3d> q, const ToolPose& pose, double k_con,
                    Vec6* grad, Mat6* hess) {
  const Mat3d R = to_matrix(pose.orientation);
  double e = 0.0;
  double g[6] = {0, 0, 0, 0, 0, 0};
  double H[36] = {};
  for (std::size_t j = 0; j < grasp.vertices.size(); ++j) {
    const GraspOffset<double> o = grasp_offset(R, pose.position, grasp.local_target[j], q[grasp.vertices[j]]);
    e += grasp_energy_term(k_con, o);
    if (grad || hess) grasp_derivative_terms<GraspRotation::Split>(k_con, o, g, H);
  }
  if (grad) for (int i = 0; i < 6; ++i) (*grad)[i] = g[i];
  if (hess) for (int i = 0; i < 6; ++i) for (int j = 0; j < 6; ++j) (*hess)(i, j) = H[6 * i + j];
  return e;
}

}  // namespace ebh
