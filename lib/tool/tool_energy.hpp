#pragma once
// The virtual tool's energy E_tool = E_tvc [2] + E_con [3] (§4.1, Appendix A) with its exact
// gradient and Hessian.
//
// Parameterisation of every derivative here (and of the Newton step): x = (dP, w) in R^6,
//     pose(x) = (P_g + dP, quat_from_rotvec(w) * Q_g),
// a world-frame translation of the rotation centre and a world-frame incremental rotation vector
// applied to the orientation. The appendix's printed formulas (A.4-A.16) have sign slips; the code
// below is derived from the energies and checked against finite differences (tests/tool). The
// per-term math is tool_terms.hpp's, shared with the device tick; these sum it over the contacts.
#include <span>

#include <Eigen/Dense>

#include "math/vec.hpp"
#include "tool/contact.hpp"
#include "tool/grasp.hpp"
#include "tool/tool_model.hpp"
#include "tool/tool_terms.hpp"

namespace ebh {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

/// pose(x) above.
ToolPose perturb(const ToolPose& pose, const Vec6& x);

/// E_tvc [2] = k_vcs/2 |P_g - P_h|^2 + k_vct/2 theta^2, theta = |v|, v = rotvec(R_g R_h^T).
///   gradient:  (k_vcs (P_g - P_h), k_vct v)
///   Hessian:   k_vcs I (+) k_vct [a a^T + (theta/2) cot(theta/2) (I - a a^T)], a = v / theta
///              (the exact Hessian of half the squared geodesic distance on SO(3)).
/// grad/hess may be null.
double coupling_energy(const ToolPose& g, const ToolPose& h, double k_vcs, double k_vct, Vec6* grad, Mat6* hess);

/// E_con [3] of contacts computed at pose P (rotation centre P_g), tissue q held fixed.
/// grad/hess may be null; they are overwritten.
double contact_energy(std::span<const ContactPoint> contacts, const Vec3d& P, double k_con, Vec6* grad, Mat6* hess);

/// Grasp part of E_con [3]: sum k/2 |q_i - (P_g + R_g l_i)|^2 over grasped vertices, with
/// s = R_g l_i, e = q_i - P_g - s:  grad = -k (e, s x e),
///   Hessian = k ([[I, -[s]x], [[s]x, -[s]x^2]] + [[0, 0], [0, (e.s) I - (e s^T + s e^T)/2]]).
/// q: #m virtual positions. grad/hess may be null; they are overwritten.
double grasp_energy(const GraspState& grasp, std::span<const Vec3d> q, const ToolPose& pose, double k_con,
                    Vec6* grad, Mat6* hess);

}  // namespace ebh
