#pragma once
// Lumped vertex masses of a tet mesh (E_k [6]'s M on the physical mesh, and what the virtual mesh
// borrows from it).
#include <vector>

#include "mesh/tet_mesh.hpp"

namespace ebh {

/// density * V_t / 4 to each corner of every tet t. Returns #V, kg (density in kg/m^3).
std::vector<double> lumped_masses(const TetMesh& mesh, double density);

}  // namespace ebh
