// A structured box of tets.
#include "mesh/box_mesh.hpp"

#include <utility>

namespace ebh {

TetMesh make_box_tets(Vec3d lo, Vec3d hi, int nx, int ny, int nz) {
  TetMesh mesh;
  auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        mesh.vertices.push_back({lo.x + (hi.x - lo.x) * i / nx, lo.y + (hi.y - lo.y) * j / ny,
                                 lo.z + (hi.z - lo.z) * k / nz});
  // Kuhn: for each permutation (a, b, c) of the axes, the path 0 -> e_a -> e_a + e_b -> (1,1,1).
  static constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& p : kPerm) {
          int c[3] = {0, 0, 0};
          Tet t;
          t[0] = id(i, j, k);
          for (int s = 0; s < 3; ++s) {
            c[p[s]] = 1;
            t[s + 1] = id(i + c[0], j + c[1], k + c[2]);
          }
          const Vec3d& x0 = mesh.vertices[t[0]];
          if (determinant(Mat3d::from_cols(mesh.vertices[t[1]] - x0, mesh.vertices[t[2]] - x0,
                                           mesh.vertices[t[3]] - x0)) < 0)
            std::swap(t[2], t[3]);
          mesh.tets.push_back(t);
          mesh.tet_group.push_back(0);
        }
  return mesh;
}

}  // namespace ebh
