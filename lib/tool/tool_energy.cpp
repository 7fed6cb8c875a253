#include "tool/tool_energy.hpp"

#include <cmath>

namespace ebh {
namespace {
Eigen::Matrix3d eig(const Mat3d& m) {
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) r(i, j) = m(i, j);
  return r;
}
}  // namespace

ToolPose perturb(const ToolPose& pose, const Vec6& x) {
  ToolPose p;
  p.position = pose.position + Vec3d{x[0], x[1], x[2]};
  p.orientation = normalized(quat_from_rotvec(Vec3d{x[3], x[4], x[5]}) * pose.orientation);
  return p;
}

double coupling_energy(const ToolPose& g, const ToolPose& h, double k_vcs, double k_vct, Vec6* grad, Mat6* hess) {
  const Vec3d dP = g.position - h.position;
  const Vec3d v = rotvec_from_quat(normalized(g.orientation * conjugate(h.orientation)));
  const double theta = norm(v);
  if (grad) {
    *grad << k_vcs * dP.x, k_vcs * dP.y, k_vcs * dP.z, k_vct * v.x, k_vct * v.y, k_vct * v.z;
  }
  if (hess) {
    hess->setZero();
    hess->topLeftCorner<3, 3>() = k_vcs * Eigen::Matrix3d::Identity();
    // (theta/2) cot(theta/2) -> 1 - theta^2/12 for small theta.
    const double half = 0.5 * theta;
    const double c = theta < 1e-4 ? 1.0 - theta * theta / 12.0 : half / std::tan(half);
    Eigen::Matrix3d aa = Eigen::Matrix3d::Zero();
    if (theta > 0) { Eigen::Vector3d a(v.x / theta, v.y / theta, v.z / theta); aa = a * a.transpose(); }
    hess->bottomRightCorner<3, 3>() = k_vct * (aa + c * (Eigen::Matrix3d::Identity() - aa));
  }
  return 0.5 * k_vcs * squared_norm(dP) + 0.5 * k_vct * theta * theta;
}

double contact_energy(std::span<const ContactPoint> contacts, const Vec3d& P, double k_con, Vec6* grad, Mat6* hess) {
  double g[6] = {0, 0, 0, 0, 0, 0};
  double H[36] = {};
  double e = 0.0;
  for (const ContactPoint& c : contacts)
    e += contact_terms(k_con, c.phi, c.gain, c.normal, c.lever - P, c.hess_sd, c.exact, g, H);
  if (grad) for (int i = 0; i < 6; ++i) (*grad)[i] = g[i];
  if (hess) for (int i = 0; i < 6; ++i) for (int j = 0; j < 6; ++j) (*hess)(i, j) = H[6 * i + j];
  return e;
}

double grasp_energy(const GraspState& grasp, std::span<const Vec3d> q, const ToolPose& pose, double k_con,
                    Vec6* grad, Mat6* hess) {
  const Mat3d R = to_matrix(pose.orientation);
  double e = 0.0;
  Vec6 g = Vec6::Zero();
  Mat6 H = Mat6::Zero();
  for (std::size_t j = 0; j < grasp.vertices.size(); ++j) {
    const Vec3d s = R * grasp.local_target[j];
    const Vec3d r = q[grasp.vertices[j]] - pose.position - s;
    e += 0.5 * k_con * squared_norm(r);
    if (grad) {
      const Vec3d sr = cross(s, r);
      g.head<3>() -= k_con * Eigen::Vector3d(r.x, r.y, r.z);
      g.tail<3>() -= k_con * Eigen::Vector3d(sr.x, sr.y, sr.z);
    }
    if (hess) {
      const Eigen::Matrix3d S = eig(skew(s));
      H.topLeftCorner<3, 3>() += k_con * Eigen::Matrix3d::Identity();
      H.topRightCorner<3, 3>() -= k_con * S;
      H.bottomLeftCorner<3, 3>() += k_con * S;
      H.bottomRightCorner<3, 3>() -= k_con * S * S;
      const Mat3d Eww = dot(r, s) * Mat3d::identity() - 0.5 * (outer(r, s) + outer(s, r));
      H.bottomRightCorner<3, 3>() += k_con * eig(Eww);
    }
  }
  if (grad) *grad = g;
  if (hess) *hess = H;
  return e;
}

}  // namespace ebh
