#pragma once
// The virtual mesh's model (virtual_mesh.hpp) in device memory, float32, uploaded once: shared by
// CudaVirtualSolver (virtual_mesh.cu) and the device haptic tick (schedule/haptic_cuda.cu).
// Included by .cu files only: it names CUDA types.
#include <cstdint>
#include <vector>

#include "solver/cuda_util.cuh"
#include "solver/virtual_mesh.hpp"

namespace ebh::cuda {

/// VirtualModelArrays' pointers, for kernel parameters.
struct VirtualModelView {
  const float* mass = nullptr;          // m
  const std::uint8_t* pinned = nullptr; // m
  const float* stiff_diag = nullptr;    // m  k_s deg + k_svc
  const Vec3f* rest_edge = nullptr;     // E
  const int* edge_offsets = nullptr;    // m + 1
  const int4* edge_items = nullptr;     // per incidence entry
  const int* pair_vertex = nullptr;     // 4m
  const float* pair_weight = nullptr;   // 4m
  const int* pair_count = nullptr;      // m
};

/// Incidence entry k of VirtualModel::edge_entries as VirtualModelArrays::edge_items holds it.
inline int4 edge_item(const VirtualModel& M, int k) {
  const int entry = M.edge_entries[k], e = entry >> 1;
  return make_int4(M.edges[e][0], M.edges[e][1], e, entry & 1);
}

struct VirtualModelArrays {
  DeviceArray<float> mass, stiff_diag;   // m   (stiff_diag: k_s deg + k_svc)
  DeviceArray<std::uint8_t> pinned;      // m
  DeviceArray<Vec3f> rest_edge;          // E
  DeviceArray<int> edge_offsets;         // m + 1, into edge_items
  /// Per incidence entry (VirtualModel::edge_entries, in its order): the edge's two vertices, the
  /// edge, and 1 if the vertex is the edge's second (the sign of its spring gradient).
  DeviceArray<int4> edge_items;
  DeviceArray<int> pair_vertex, pair_count;  // 4m, m: the physical points each vertex is paired with
  DeviceArray<float> pair_weight;            // 4m

  VirtualModelView view() const {
    return {mass.get(), pinned.get(), stiff_diag.get(), rest_edge.get(), edge_offsets.get(),
            edge_items.get(), pair_vertex.get(), pair_weight.get(), pair_count.get()};
  }

  void upload(const VirtualModel& M, cudaStream_t st) {
    auto up = [st](auto& arr, const auto& host) {
      arr.allocate(host.size());
      arr.upload(host.data(), st);
    };
    const int m = M.num_vertices, E = static_cast<int>(M.edges.size());
    up(mass, std::vector<float>(M.mass.begin(), M.mass.end()));
    up(stiff_diag, std::vector<float>(M.stiff_diag.begin(), M.stiff_diag.end()));
    up(pinned, M.pinned);
    std::vector<Vec3f> re(E);
    for (int e = 0; e < E; ++e) re[e] = static_cast<Vec3f>(M.rest_edge[e]);
    up(rest_edge, re);
    up(edge_offsets, M.edge_offsets);
    std::vector<int4> items(M.edge_entries.size());
    for (std::size_t k = 0; k < items.size(); ++k) items[k] = edge_item(M, static_cast<int>(k));
    up(edge_items, items);
    std::vector<int> pv(4 * std::size_t(m), 0);
    std::vector<float> pw(4 * std::size_t(m), 0.f);
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < 4; ++k) { pv[4 * j + k] = M.pair_vertex[j][k]; pw[4 * j + k] = float(M.pair_weight[j][k]); }
    up(pair_vertex, pv);
    up(pair_weight, pw);
    up(pair_count, M.pair_count);
  }
};

}  // namespace ebh::cuda
