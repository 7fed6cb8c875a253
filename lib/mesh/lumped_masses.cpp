// Lumped vertex masses of a tet mesh (lumped_masses.hpp).
#include "mesh/lumped_masses.hpp"

#include <cmath>

namespace ebh {

std::vector<double> lumped_masses(const TetMesh& mesh, double density) {
  std::vector<double> mass(mesh.vertices.size(), 0.0);
  for (const Tet& t : mesh.tets) {
    const Vec3d& x0 = mesh.vertices[t[0]];
    const double V = std::abs(determinant(Mat3d::from_cols(mesh.vertices[t[1]] - x0, mesh.vertices[t[2]] - x0,
                                                           mesh.vertices[t[3]] - x0))) / 6.0;
    for (int c = 0; c < 4; ++c) mass[t[c]] += density * V / 4.0;
  }
  return mass;
}

}  // namespace ebh
