#pragma once
// The virtual mesh (paper §3.1): a triangle surface that follows the physical mesh through the
// E_svc [5] coupling and meets the virtual tool through E_con [3] at the haptic rate. Its
// local-global iterations (the soft part of Algorithm 2) minimise
//     E_soft = E_con + E_s + E_svc + E_k       (paper §4.2)
// with the physical points of E_svc held fixed for the whole tick.
//
// A tick, as the scheduler calls it (the virtual tool's Newton steps go between iterations):
//     virtual_begin_tick(model, ws, state, physical_x, h);             // Alg. 2 lines 1, 6
//     for i < iterations:
//         virtual_iteration(model, ws, state, contacts);               // Alg. 2 lines 13-16
//         ... the virtual tool's Newton step against state.q ...
//     virtual_end_tick(model, ws, state);                              // Alg. 2 lines 22-23
//
// Every per-vertex loop gathers (CSR incidence lists) so the result is bitwise identical for any
// OpenMP thread count; no step function allocates. An iteration is two passes: per edge (E_s
// gradients, SIMD), then per vertex (gather over the incident edges and the Jacobi update).
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "energy/contact_target.hpp"
#include "math/vec.hpp"
#include "mesh/tet_mesh.hpp"
#include "solver/virtual_jacobi.hpp"

namespace ebh {

class SharedLoops;

struct Scene;

/// Immutable virtual-mesh model. m = #vertices, E = #edges, F = #triangles.
struct VirtualModel {
  int num_vertices = 0;                      ///< m
  double k_s = 0;                            ///< N/m, E_s [4] per edge
  double k_svc = 0;                          ///< N/m, E_svc [5] per virtual vertex
  double damping = 0;                        ///< 1/s, velocity damping (solver.virtual_damping)
  Vec3d gravity;                             ///< m/s^2
  std::vector<Vec3d> rest;                   ///< #m rest positions q^0, metres
  std::vector<Tri> triangles;                ///< #F counter-clockwise seen from outside
  std::vector<std::array<int, 2>> edges;     ///< #E unique edges (a < b)
  std::vector<Vec3d> rest_edge;              ///< #E q_a^0 - q_b^0
  std::vector<double> mass;                  ///< #m kg (docs/MODEL.md: share of the boundary's physical mass)
  std::vector<std::uint8_t> pinned;          ///< #m 1 when every paired physical vertex is pinned
  // Pairing with the physical mesh (E_svc [5]): p_j = sum_k pair_weight[j][k] x[pair_vertex[j][k]],
  // k < pair_count[j] <= 4. The weights reproduce the rest position: p_j(X) = q_j^0 (to
  // pairing_max_error).
  std::vector<std::array<int, 4>> pair_vertex;     ///< #m physical-vertex indices (-1 unused)
  std::vector<std::array<double, 4>> pair_weight;  ///< #m weights, sum 1
  std::vector<int> pair_count;                     ///< #m 1..4
  double pairing_max_error = 0;                    ///< m, max_j |p_j(X) - q_j^0|
  int pairing_worst = -1;                          ///< the j of pairing_max_error (-1: every error 0)
  // Incidence (CSR), rows = virtual vertices.
  std::vector<int> edge_offsets;   ///< #m+1
  std::vector<int> edge_entries;   ///< 2 e + end: vertex is edges[e][end]
  std::vector<int> tri_offsets;    ///< #m+1
  std::vector<int> tri_entries;    ///< incident triangle indices
  std::vector<double> stiff_diag;  ///< #m k_s * degree + k_svc: the diagonal without mass and contact
  std::vector<double> rest_len;    ///< #E |q_a^0 - q_b^0|
  /// Iterations use the calling thread's OpenMP team (when it has more than one thread) from this
  /// many vertices (or active vertices) on; below it a pass is too short to pay for the team's
  /// fork and barrier at the haptic rate (docs/MODEL.md, virtual_team).
  int parallel_min_vertices = 4096;
};

/// Mutable virtual-mesh state: q and v, both #m.
struct VirtualState {
  std::vector<Vec3d> q;  ///< #m positions, metres
  std::vector<Vec3d> v;  ///< #m velocities, m/s
};

/// Scratch of the virtual-mesh tick, sized once by make_virtual_workspace.
struct VirtualWorkspace {
  double h = 0;                        ///< the tick's step (s)
  std::vector<Vec3d> q_start;          ///< #m positions at the start of the tick
  std::vector<Vec3d> s;                ///< #m prediction
  std::vector<Vec3d> p;                ///< #m E_svc physical points, fixed for the tick
  std::vector<Vec3d> q_next;           ///< #m Jacobi output buffer
  std::vector<Vec3d> contact_kt;       ///< #m sum of k * target over this iteration's contacts
  std::vector<double> contact_k;       ///< #m sum of k over this iteration's contacts
  std::vector<Vec3d> edge_grad;        ///< #E dE_s/dq_a of each edge (a, b) (the local step's output)
  /// The passes over the mesh (or the active region) as chunks shared with a helping thread
  /// (solver/shared_loops.hpp: the async replay's physical thread while it waits for the next
  /// step, with one haptic thread); null: the calling thread's OpenMP team. The same bits.
  SharedLoops* shared = nullptr;
};

/// Builds the virtual mesh of a scene: scene.virtual_surface (or, when empty, the physical mesh's
/// boundary), refined 1 -> 4 when scene.spec.virtual_refine is 1, paired with the physical mesh.
/// Throws InputError when a virtual vertex cannot be paired (no tets).
VirtualModel build_virtual_model(const Scene& scene);

/// A virtual mesh from its own file (mesh.virtual) in another unit or frame than the physical
/// mesh (build_world and `ebh scene info` ask): lying off the physical mesh by more than 1% of its
/// bounding-box diagonal is warned (its E_svc targets pull it onto the physical mesh from the first
/// tick; a surface smoothed outside its segmentation stays well within it) and by more than 10
/// diagonals refused (InputError: a vertex a kilometre away pulled the physical mesh into
/// divergence at tick 10, blamed on a tet); spanning less than 1/20 of that diagonal is warned (a
/// mesh in m read as mm sits inside the physical mesh, 1/1000 of its size, paired without error,
/// and the tool never touches it); one over part of the physical mesh only (over 1% of its boundary
/// vertices farther from the virtual surface than kUncoveredReach diagonals) is warned (a tool
/// there passes through the physical mesh unfelt). Appends the warnings to `warnings`.
void check_virtual_mesh_placement(const Scene& scene, const VirtualModel& vm, std::vector<std::string>& warnings);
/// A smoothed segmentation's surface cuts the corners of its mesh by a few per cent of its size (a
/// 3 mm rounding of a 60 mm box: 2.2 mm, 3.7%); a surface over part of it leaves the rest tens of
/// per cent away.
inline constexpr double kUncoveredReach = 0.05;

/// Whether a pass over `count` vertices of `model` runs on the calling thread's OpenMP team: from
/// model.parallel_min_vertices on, and only where the team has more than one thread. The results
/// do not depend on it (every per-vertex loop gathers).
bool virtual_team(const VirtualModel& model, int count);

VirtualState make_virtual_state(const VirtualModel& model);  ///< rest, at rest
VirtualWorkspace make_virtual_workspace(const VirtualModel& model);

/// Alg. 2 lines 1 and 6: E_svc targets p_j = sum_k w x_k from the latest visible physical
/// positions physical_x (#n), prediction s = q + h v + h^2 g, and the iterations' start
/// q <- q + h v (iteration_start; pinned: q stays).
void virtual_begin_tick(const VirtualModel& model, VirtualWorkspace& ws, VirtualState& state,
                        std::span<const Vec3d> physical_x, double h);

/// One local-global Jacobi iteration on E_s + E_svc + E_k + E_con (Alg. 2 lines 13-16), in place
/// on state.q. contacts: this iteration's E_con constraints (any order; several may name one
/// vertex; processed in the given order, so the result is deterministic).
void virtual_iteration(const VirtualModel& model, VirtualWorkspace& ws, VirtualState& state,
                       std::span<const ContactTarget> contacts);

/// The Jacobi global step of free vertex j (virtual_jacobi.hpp): its new position from q (#m), the
/// edge gradients of this iteration's local step and the contact sums in ws; inv_h2 = 1 / h^2.
/// Shared by virtual_iteration and the active region's iteration (solver/active_region.hpp).
inline Vec3d virtual_vertex_update(const VirtualModel& model, const VirtualWorkspace& ws, const Vec3d* __restrict q,
                                   int j, double inv_h2) {
  const double mh = model.mass[j] * inv_h2;
  const double ck = ws.contact_k[j];
  Vec3d r = inertia_coupling_residual(mh, ws.s[j], q[j], ws.p[j], model.k_svc);
  if (ck != 0.0) r = add_contact_residual(r, ws.contact_kt[j], ck, q[j]);  // 0 without contact
  const Vec3d* __restrict edge_grad = ws.edge_grad.data();
  const int* __restrict entries = model.edge_entries.data();
  for (int k = model.edge_offsets[j]; k < model.edge_offsets[j + 1]; ++k)
    add_edge_residual(r, edge_grad[entries[k] >> 1], (entries[k] & 1) != 0);
  return jacobi_update(q[j], r, mh + model.stiff_diag[j] + ck);
}

/// Alg. 2 lines 22-23: v = (q - q_start) / h.
void virtual_end_tick(const VirtualModel& model, VirtualWorkspace& ws, VirtualState& state);

/// Area-weighted unit vertex normals of the virtual mesh at q (#m) into normals (#m).
void compute_vertex_normals(const VirtualModel& model, std::span<const Vec3d> q, std::span<Vec3d> normals);

/// The physical points p_j = sum_k w x_k (#m) of E_svc for physical positions x (#n).
void paired_points(const VirtualModel& model, std::span<const Vec3d> x, std::span<Vec3d> p);

struct VirtualEnergy {
  double edges = 0;     ///< E_s [4]
  double coupling = 0;  ///< E_svc [5]
  double inertia = 0;   ///< E_k [6]
  double contact = 0;   ///< E_con [3]
  double total() const { return edges + coupling + inertia + contact; }
};

/// The virtual mesh's energy at q (#m) for predictions s (#m, or empty: no E_k), physical points
/// p (#m, or empty: no E_svc), contacts, and step h.
VirtualEnergy virtual_energy(const VirtualModel& model, std::span<const Vec3d> q, std::span<const Vec3d> s,
                             std::span<const Vec3d> p, std::span<const ContactTarget> contacts, double h);

}  // namespace ebh
