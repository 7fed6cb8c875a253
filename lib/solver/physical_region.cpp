// The physical mesh's awake region (see physical_region.hpp).
#include "solver/physical_region.hpp"

#include <algorithm>

#include "solver/local_kernels.hpp"
#include "solver/physical_mesh.hpp"

namespace ebh {

void vertex_neighbours(const PhysicalModel& model, std::span<const int> index, std::vector<int>& offsets,
                       std::vector<int>& neighbours) {
  const int n = model.num_vertices;
  auto id = [&](int a) { return index.empty() ? a : index[a]; };
  // Every other corner of an incident tet, once each (sorted).
  std::vector<std::vector<int>> adjacent(n);
  for (const Tet& t : model.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        if (a != b) adjacent[id(t[a])].push_back(id(t[b]));
  offsets.assign(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    std::vector<int>& list = adjacent[i];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    offsets[i + 1] = offsets[i] + static_cast<int>(list.size());
  }
  neighbours.clear();
  neighbours.reserve(offsets[n]);
  for (const std::vector<int>& list : adjacent) neighbours.insert(neighbours.end(), list.begin(), list.end());
}

PhysicalRegion make_physical_region(const PhysicalModel& model, double tolerance) {
  PhysicalRegion r;
  r.tolerance = tolerance;
  const int n = model.num_vertices;
  vertex_neighbours(model, model.vertex_local, r.neighbour_offsets, r.neighbours);
  r.awake.assign(n, 0);
  r.vertices.reserve(n);
  r.frontier.reserve(n);
  r.next.reserve(n);
  r.block_mark.assign(tet_blocks(model.num_tets), 0);
  r.tet_blocks.reserve(r.block_mark.size());
  r.virtual_mark.assign(model.num_virtual, 0);
  r.virtuals.reserve(model.num_virtual);
  r.seen.assign(model.num_virtual, Vec3d{});
  return r;
}

namespace {
/// Wakes free vertex i (once), queueing it in `into`.
inline void wake(const PhysicalLocalArrays& L, PhysicalRegion& r, int i, std::vector<int>& into) {
  if (r.awake[i] || L.pinned[i]) return;
  r.awake[i] = 1;
  into.push_back(i);
}
}  // namespace

int choose_awake(const PhysicalModel& model, const PhysicalWorkspace& ws, std::span<const Vec3d> virtual_q,
                 bool whole, PhysicalRegion& r) {
  const int n = model.num_vertices;
  const PhysicalLocalArrays& L = model.local;
  if (whole) {
    r.all = true;
    return model.num_free;
  }
  std::fill(r.awake.begin(), r.awake.end(), std::uint8_t{0});
  r.frontier.clear();
  const double d2 = r.tolerance * r.tolerance;
  for (int i = 0; i < n; ++i)  // hot: moved by more than d in the step before
    if (squared_norm(ws.x[i] - ws.x_start[i]) > d2) wake(L, r, i, r.frontier);
  for (std::size_t j = 0; j < virtual_q.size(); ++j)  // seeds: the virtual mesh moved under them
    if (squared_norm(virtual_q[j] - r.seen[j]) > d2)
      for (int c = 0; c < model.pair_count[j]; ++c) wake(L, r, L.pair_vertex[j][c], r.frontier);
  for (int ring = 0; ring < kRegionRings && !r.frontier.empty(); ++ring) {
    r.next.clear();
    for (const int i : r.frontier)
      for (int k = r.neighbour_offsets[i]; k < r.neighbour_offsets[i + 1]; ++k) wake(L, r, r.neighbours[k], r.next);
    r.frontier.swap(r.next);
  }
  r.vertices.clear();
  for (int i = 0; i < n; ++i)
    if (r.awake[i]) r.vertices.push_back(i);
  const int count = static_cast<int>(r.vertices.size());
  r.all = count == model.num_free;
  if (r.all || count == 0) return count;
  // The tet blocks with an awake corner and the virtual vertices an awake vertex pairs with.
  std::fill(r.block_mark.begin(), r.block_mark.end(), std::uint8_t{0});
  std::fill(r.virtual_mark.begin(), r.virtual_mark.end(), std::uint8_t{0});
  for (const int i : r.vertices) {
    for (int k = L.tet_offsets[i]; k < L.tet_offsets[i + 1]; ++k) r.block_mark[L.force_entries[k] / 4 / kTetLanes] = 1;
    for (int k = L.cpl_offsets[i]; k < L.cpl_offsets[i + 1]; ++k) r.virtual_mark[L.cpl_virtual[k]] = 1;
  }
  r.tet_blocks.clear();
  for (int b = 0; b < static_cast<int>(r.block_mark.size()); ++b)
    if (r.block_mark[b]) r.tet_blocks.push_back(b);
  r.virtuals.clear();
  for (int j = 0; j < static_cast<int>(r.virtual_mark.size()); ++j)
    if (r.virtual_mark[j]) r.virtuals.push_back(j);
  return count;
}

void saw_virtual_mesh(const PhysicalModel& model, std::span<const Vec3d> virtual_q, PhysicalRegion& r) {
  const PhysicalLocalArrays& L = model.local;
  for (std::size_t j = 0; j < virtual_q.size(); ++j) {
    if (!r.all) {
      bool every = true;
      for (int c = 0; c < model.pair_count[j]; ++c) {
        const int i = L.pair_vertex[j][c];
        every = every && (r.awake[i] || L.pinned[i]);
      }
      if (!every) continue;
    }
    r.seen[j] = virtual_q[j];
  }
}

PatchHalos patch_halos(const PhysicalModel& model, std::span<const int> offsets, std::span<const int> members) {
  const int n = model.num_vertices;
  std::vector<int> first, adjacent;
  vertex_neighbours(model, {}, first, adjacent);
  PatchHalos h;
  std::vector<int> mark(n, -1), frontier, next, halo;
  for (int p = 0; p + 1 < static_cast<int>(offsets.size()); ++p) {
    // A breadth-first search from the patch's free vertices over free vertices, kRegionRings deep:
    // the rings choose_awake spreads over, walked the other way.
    halo.clear();
    frontier.clear();
    auto reach = [&](int a, std::vector<int>& into) {
      if (model.pinned[a] || mark[a] == p) return;
      mark[a] = p;
      into.push_back(a);
      halo.push_back(a);
    };
    for (int k = offsets[p]; k < offsets[p + 1]; ++k) reach(members[k], frontier);
    for (int ring = 0; ring < kRegionRings && !frontier.empty(); ++ring) {
      next.clear();
      for (const int a : frontier)
        for (int k = first[a]; k < first[a + 1]; ++k) reach(adjacent[k], next);
      frontier.swap(next);
    }
    std::sort(halo.begin(), halo.end());
    h.vertices.insert(h.vertices.end(), halo.begin(), halo.end());
    h.offsets.push_back(static_cast<int>(h.vertices.size()));
  }
  return h;
}

}  // namespace ebh
