#pragma once
// The physical mesh's awake region (solver.physical_region, docs/MODEL.md "The physical mesh's
// awake region"): a physical step iterates only the vertices that move, and the vertices around
// them; every other vertex sleeps: it is held where it is, at rest (v = 0), a fixed corner of the
// tets beside the awake ones. The whole-mesh sleep (solver.sleep) skips a step when nothing moves;
// the region skips the parts of a step where nothing moves (a grasp deforms a few thousand of an
// organ's vertices, the rest lie still).
//
// Who is awake in step k (decided before it, from step k - 1 and the virtual mesh it is given):
//   - every vertex the step before moved by more than `tolerance` (|x_end - x_start| > d: *hot*);
//   - the physical vertices a virtual vertex pairs with (E_svc [5]) when that virtual vertex has
//     moved by more than the tolerance since all of them last saw it (were awake in a step): a
//     contact or a grasp wakes the tissue under the tool;
//   - the neighbours (over the tets' edges) of those, kRegionRings rings deep: the region reaches
//     ahead of the motion, so what the step moves at its border moves by less than the tolerance.
// A step whose region is empty is skipped (the state held, as solver.sleep does). The first step
// iterates every vertex, and so does a step the recovery redoes (the direct solve), after which
// every virtual vertex counts as seen. Pinned vertices never wake.
//
// Inside a step the arithmetic on an awake vertex and on a tet with an awake corner is the whole
// mesh's (physical_mesh.cpp), so a region that holds every vertex gives the whole mesh's bits; the
// residual norm of the stopping rule sums the awake vertices'. The decisions read only the
// replay's state, so replays stay bitwise reproducible across runs and thread counts.
#include <cstdint>
#include <span>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

struct PhysicalModel;
struct PhysicalWorkspace;

/// Rings of neighbours around the hot and seeded vertices that wake with them.
inline constexpr int kRegionRings = 2;

/// The awake region's state and this step's lists (sized by make_physical_region; a step does
/// not allocate). Indices are the step's local vertex indices (PhysicalModel::vertex_order).
struct PhysicalRegion {
  double tolerance = 0;                ///< m (0: every vertex is awake, always)
  bool all = true;                     ///< this step iterates every vertex (the lists below are unused)
  std::vector<int> vertices;           ///< the awake free vertices, ascending
  std::vector<int> tet_blocks;         ///< SIMD tet blocks (local_kernels.hpp) with an awake corner, ascending
  std::vector<int> virtuals;           ///< virtual vertices that pair with an awake vertex, ascending
  std::vector<std::uint8_t> awake;     ///< #n
  std::vector<Vec3d> seen;             ///< #m the virtual mesh as every vertex it pairs with last saw it
  // The neighbours over the tets' edges (CSR, local indices) and scratch of the decision.
  std::vector<int> neighbour_offsets, neighbours;
  std::vector<int> frontier, next;
  std::vector<std::uint8_t> block_mark, virtual_mark;
};

/// The region for `model` with tolerance d (m, > 0).
PhysicalRegion make_physical_region(const PhysicalModel& model, double tolerance);

/// Decides step k's awake vertices (the rules above). `ws` holds the step before (its x_start and
/// x, local order); `whole`: iterate every vertex (the first step, after a recovery). Returns the
/// number of awake vertices (0: nothing to iterate).
int choose_awake(const PhysicalModel& model, const PhysicalWorkspace& ws, std::span<const Vec3d> virtual_q,
                 bool whole, PhysicalRegion& region);

/// After the step ran on `virtual_q`: the virtual vertices every partner of which was awake have
/// now been seen where they are.
void saw_virtual_mesh(const PhysicalModel& model, std::span<const Vec3d> virtual_q, PhysicalRegion& region);

/// The neighbours of every vertex over the tets' edges, as CSR (each list ascending, once each),
/// numbered by `index` (index[a] for model vertex a: PhysicalModel::vertex_local for the local
/// order, empty for the model's own numbering).
void vertex_neighbours(const PhysicalModel& model, std::span<const int> index, std::vector<int>& offsets,
                       std::vector<int>& neighbours);

/// The region at the grain of patches (the CUDA step's blocks, solver/physical_mesh.cu): patch p,
/// the model vertices members[offsets[p] .. offsets[p + 1]), iterates when one of its free
/// vertices is awake by the rules above, that is when a hot or seeded free vertex lies within
/// kRegionRings rings of one of them over free vertices. Its halo lists those vertices (model
/// numbering, ascending): the patch wakes when any of them is hot or seeded.
struct PatchHalos {
  std::vector<int> offsets{0}, vertices;
};
PatchHalos patch_halos(const PhysicalModel& model, std::span<const int> offsets, std::span<const int> members);

}  // namespace ebh
