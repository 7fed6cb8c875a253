#pragma once
// The interface between collision (lib/tool) and the virtual-mesh solver (lib/solver):
// one E_con [3] constraint, k/2 |q_vertex - target|^2, with the target computed by collision
// detection against the virtual tool (pressing, §5.1) or by a grasp (pulling, §5.2, eq. [10]).
#include "math/vec.hpp"

namespace ebh {

struct ContactTarget {
  int vertex = -1;     ///< virtual-mesh vertex index
  Vec3d target;        ///< q_proj, metres
  double stiffness = 0;  ///< N/m (k_con, or k_con scaled by a grasp weight)
};

}  // namespace ebh
