// The whole haptic tick on a CUDA device (haptic_cuda.hpp; docs/CUDA.md "Device haptic tick").
//
// A run of ticks is one cooperative launch of ticks_kernel, every block resident. A tick is
// virtual_iterations steps; step s, per virtual vertex j (vertex_step, one thread each):
//   begin (first)   q_start, prediction s (Alg. 2 l. 6) and first iterate x + h v, E_svc target p
//                   from the blended physical result (l. 1), the grasp event of the tick (§5.2,
//                   eq. [10])
//   contact         E_con [3] target of j against the virtual tool held fixed (l. 10): the grasp
//                   target of a held vertex, else the closest point of the deepest collider
//   iteration       one Jacobi step of E_k + E_svc + E_con + E_s (l. 11-16)
//   end (last)      velocity (l. 23), depth of j in the physical tool (the penetration metric)
//   reach           whether the virtual tool's next Newton call can reach j (virtual_tool.cpp's bound)
// then, after the step (after the tick's last tool.newton_calls steps only), the virtual tool's
// Newton call (l. 18-19) on the reachable and held vertices: block 0 (tool_block,
// virtual_tool_tail) in double, with fixed-order block sums, the 6x6 PSD clamp (a Cholesky test,
// else a one-warp Jacobi eigen-decomposition), an Armijo line search, and (last step) the tick's
// outputs into a host-mapped ring (l. 26-27).
//
// The other blocks (vertex_blocks) run the vertices, a chunk of kBlock per block, and hand off to
// block 0 through two counters. A step is pipelined: it runs beside the Newton call before it,
// at the pose before that call. Only a vertex the call can reach can touch the tool at its new
// pose, so those (and the held ones) are deferred: their Jacobi sums go to block 0, which adds
// their contact at the new pose (finish_deferred) and filters the next candidates from a
// superset the other blocks flag (pipelined_lists). A run's first step, a grasp event's step and a
// step with no call before it are unpipelined: released after the call (or the step before), with
// every vertex's contact in place.
//
// The map, one translation unit in the order the parts build on each other:
//   haptic_cuda_profile.cuh   the stage timers (DeviceHapticSetup::profile_stages), compiled out
//                             with EBH_TICK_PROFILE=0
//   haptic_cuda_layout.cuh    constants, the tool's constants and state, MeshDev (the device
//                             arrays and counters), the posed tool, each block's shared memory
//   haptic_cuda_posed.cuh     posing the colliders; float32 early-outs and reach tests; the exact
//                             double queries
//   haptic_cuda_handoff.cuh   the counters between block 0, the vertex blocks and the physical
//                             step's stream; the schedule of a run's steps; the chunks' lists
//   haptic_cuda_surface.cuh   surface contact's per-vertex targets and per-triangle tests (the
//                             kernel with surface contact: haptic_cuda_surface.cu, its own
//                             translation unit)
//   haptic_cuda_vertices.cuh  the vertex side: vertex_step, finish_deferred, the active
//                             region's chunks, vertex_blocks
//   haptic_cuda_tool.cuh      the tool side: the Newton call (virtual_tool_tail), the tick's
//                             outputs, block 0's loop (tool_block)
//   haptic_cuda.cu            ticks_kernel and the host side (CudaHapticTicks)
// The per-term math is shared with the CPU: tool/tool_terms.hpp, tool/newton.hpp,
// solver/virtual_jacobi.hpp, tool/contact.hpp.
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "mesh/quality.hpp"
#include "schedule/haptic_cuda.hpp"
#include "schedule/haptic_cuda_handoff.cuh"
#include "schedule/haptic_cuda_layout.cuh"
#include "schedule/haptic_cuda_profile.cuh"
#include "schedule/haptic_cuda_tool.cuh"
#include "schedule/haptic_cuda_vertices.cuh"
#include "solver/cuda_util.cuh"
#include "solver/device_cuda.hpp"
#include "solver/region_rules.hpp"
#include "solver/virtual_mesh_device.cuh"
#include "tool/surface_contact.hpp"

namespace ebh {
namespace {

/// One run of `count` ticks from tick `tick0` as one cooperative launch (every block resident;
/// block 0 the virtual tool, the others the virtual mesh; hand-off epochs numbered across runs
/// from `epoch0`).
__global__ void __launch_bounds__(kBlock)
    ticks_kernel(MeshDev d, ToolConst t, int count, long long tick0, unsigned long long epoch0) {
  __shared__ BlockShared sm;
  const Schedule S(d, tick0, epoch0);
  if (blockIdx.x == 0) tool_block(d, t, S, count * d.iterations, sm);
  else vertex_blocks(d, t, S, count * d.iterations, sm);
}

Vec3f to_float(const Vec3d& v) { return static_cast<Vec3f>(v); }

/// `count` float32 positions (host memory) into `to`, in double.
void to_double(const Vec3f* from, int count, std::vector<Vec3d>& to) {
  to.resize(count);
  for (int a = 0; a < count; ++a) to[a] = static_cast<Vec3d>(from[a]);
}

/// The virtual mesh's incidence lists (VirtualModelArrays::edge_items: VirtualModel::edge_entries,
/// in their order) for the device tick, column-major: entry u of vertex j at u m + j, so that a
/// warp's 32 vertices load their u-th edges in one coalesced 512-byte line and without waiting for
/// the offsets; rows padded to a multiple of kEdgeChunk.
std::vector<int4> edge_ell(const VirtualModel& M) {
  const int m = M.num_vertices;
  int width = 0;
  for (int j = 0; j < m; ++j) width = std::max(width, M.edge_offsets[j + 1] - M.edge_offsets[j]);
  width = std::max(kEdgeChunk, (width + kEdgeChunk - 1) / kEdgeChunk * kEdgeChunk);
  std::vector<int4> ell(std::size_t(width) * m, make_int4(0, 0, 0, 0));
  for (int j = 0; j < m; ++j)
    for (int k = M.edge_offsets[j]; k < M.edge_offsets[j + 1]; ++k)
      ell[std::size_t(k - M.edge_offsets[j]) * m + j] = cuda::edge_item(M, k);
  return ell;
}

/// A segment and radius whose capsule contains collider c (ToolConst's early-outs), rounded outward.
void bounding_segment(const Collider<double>& c, Vec3f& a, Vec3f& b, float& r) {
  double radius = c.radius;
  Vec3d A = c.a, B = c.b;
  if (c.shape == Shape::Sphere) {
    B = A;
  } else if (c.shape == Shape::Box) {  // along the longest half extent, through the centre
    const Vec3d h = c.half;
    const int k = h.x >= h.y && h.x >= h.z ? 0 : (h.y >= h.z ? 1 : 2);
    Vec3d axis{};
    double rest2 = 0;
    if (k == 0) { axis.x = h.x; rest2 = h.y * h.y + h.z * h.z; }
    if (k == 1) { axis.y = h.y; rest2 = h.x * h.x + h.z * h.z; }
    if (k == 2) { axis.z = h.z; rest2 = h.x * h.x + h.y * h.y; }
    A = c.a - axis;
    B = c.a + axis;
    radius = std::sqrt(rest2);
  }
  a = to_float(A);
  b = to_float(B);
  r = static_cast<float>(radius * (1 + 1e-6) + 1e-7);
}

}  // namespace

namespace {
/// The blocks of a tick kernel the device holds at once, with the L1-first carve-out (as much L1
/// as the kernel's shared memory leaves: L1 serves a large share of its loads), which it sets.
/// The carve-out is the kernel's, process-wide: one thread at a time sets and reads it (replay_batch
/// makes its replays on several threads).
DeviceTickCapacity tick_capacity(const void* kernel) {
  static std::mutex carveout;
  const std::lock_guard<std::mutex> lock(carveout);
  int device = 0, coop = 0, sms = 0, per_sm = 0, most = 0;
  EBH_CUDA_CHECK(cudaGetDevice(&device));
  EBH_CUDA_CHECK(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, device));
  EBH_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  EBH_CUDA_CHECK(cudaFuncSetAttribute(kernel, cudaFuncAttributePreferredSharedMemoryCarveout, cudaSharedmemCarveoutMaxShared));
  EBH_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&most, kernel, kBlock, 0));
  EBH_CUDA_CHECK(cudaFuncSetAttribute(kernel, cudaFuncAttributePreferredSharedMemoryCarveout, cudaSharedmemCarveoutMaxL1));
  EBH_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel, kBlock, 0));
  if (!coop || per_sm * sms < 2) throw std::runtime_error("CudaHapticTicks: the device cannot run the cooperative tick kernel");
  cudaFuncAttributes fa{};
  EBH_CUDA_CHECK(cudaFuncGetAttributes(&fa, kernel));
  DeviceTickCapacity c;
  c.multiprocessors = sms;
  c.blocks_per_sm = per_sm;
  c.blocks_per_sm_shared = std::max(1, most - 1);  // one block's room left for the physical step's
  c.registers = fa.numRegs;
  c.shared_bytes = fa.sharedSizeBytes;
  return c;
}
}  // namespace

DeviceTickCapacity device_tick_capacity(const ToolModel& tool) {
  return tick_capacity(tool.surface ? surface_ticks_kernel_entry() : reinterpret_cast<const void*>(ticks_kernel));
}

bool device_haptic_supported(const ToolModel& tool) {
  return tool.projection == Projection::ClosestPoint && tool.colliders.size() <= static_cast<std::size_t>(kMaxColliders);
}

namespace {
/// Samples the Newton call's list holds with surface contact: twice every triangle's samples at
/// rest (a call reaches a small part of the surface; twice for stretched triangles' extra rows),
/// at least 2^16 and at most 2^22 (44 bytes each: a candidate's point and weight, a contact list
/// entry, a sample's triangle).
int surface_capacity(const SurfaceContactModel& s) {
  double total = 0;
  for (const std::uint8_t n : s.rest_level) total += static_cast<double>(n) * n;
  return static_cast<int>(std::clamp(2.0 * total, 65536.0, 4194304.0));
}
}  // namespace

struct CudaHapticTicks::Impl {
  CudaPhysicalSolver* physical = nullptr;
  int m = 0, n = 0, iterations = 1;
  int grid = 2;                           // ticks_kernel's blocks (all resident): block 0 and the vertices' blocks
  long long ticks = 0, enqueued = 0;
  unsigned long long epoch = 0;           // virtual iterations enqueued so far (Schedule::epoch)
  cudaStream_t stream = nullptr;
  cudaEvent_t q_ready = nullptr, step_done = nullptr;
  std::vector<cudaEvent_t> done;  // per run_ticks handle
  std::vector<std::pair<long long, int>> runs;  // per handle: first tick, count
  int next_handle = 0;
  bool step_in_flight = false;
  // Launches across physical periods (run_ticks_with_steps); not mixed with start_physical_step.
  enum class Steps { Unused, PerPeriod, InLaunch } steps_mode = Steps::Unused;
  int period = 0;                          // DeviceHapticSetup::ticks_per_step
  int step_slots = 64;                     // physical steps in flight at most
  int carveout_beside_steps = -1;          // ticks_kernel's carve-out in that mode (-1: L1-first as in the others)
  long long steps_enqueued = 0, steps_finished = 0;
  cuda::DeviceArray<StepsDev> steps_sync;
  cuda::DeviceArray<Vec3f> xring[3];       // step k's x in xring[ring_slot(k)]
  cuda::PinnedArray<Vec3f> x_slots;        // step k's x for finish_step, at (k % step_slots) n
  std::vector<cudaEvent_t> step_ready;     // per slot: the step's x copied and published
  // The steps' inverted or flat tets (DeviceHapticSetup::physical_tets; none: not counted).
  int tets = 0;
  cuda::DeviceArray<int4> inverted_tets;
  cuda::DeviceArray<signed char> inverted_sign;  // each tet's sign at rest (rest_signs)
  cuda::DeviceArray<unsigned> inverted_sum;      // the step being counted (publish_step zeroes it)
  int* inverted_slots = nullptr;                 // cudaHostAlloc, mapped: step k's count at k % step_slots
  int* inverted_slots_dev = nullptr;             // the same, the device's pointer
  cuda::VirtualModelArrays model;
  cuda::DeviceArray<std::uint8_t> held;
  cuda::DeviceArray<Vec3f> block_cand;
  cuda::DeviceArray<int> block_held, block_counts, block_offsets, held_list, held_slot;
  cuda::DeviceArray<SyncDev> sync;
  cuda::DeviceArray<int4> edge_ell;
  cuda::DeviceArray<SlotPose> slots;
  cuda::DeviceArray<Vec3f> x_prev, x_vis, v, v_scratch, q_start, s, p, q[3];
  cuda::DeviceArray<DeferredVertex> block_deferred;
  cuda::DeviceArray<Vec3d> grasp_local, cand_q;
  cuda::DeviceArray<ToolStateDev> state;
  cuda::DeviceArray<DeviceTickInput> inputs;
  cuda::DeviceArray<Collider<double>> grasp_boxes;
  cuda::DeviceArray<ProfileDev> profile;
  // The active region (DeviceHapticSetup::active_region > 0).
  cuda::DeviceArray<ChunkRegion> chunk_region;
  cuda::DeviceArray<Vec3f> region_offset, region_disp;
  cuda::DeviceArray<unsigned long long> region_awake;
  cuda::DeviceArray<int> chunk_free;
  cuda::DeviceArray<unsigned> region_tick_active;
  cuda::PinnedArray<Vec3f> x_host;   // the physical step's x, copied out beside the ticks
  DeviceTickOutput* ring = nullptr;  // cudaHostAlloc, mapped
  int ring_size = 0;
  MeshDev dev;
  ToolConst tool;
  // Surface contact (the tool's SurfaceContactModel; surface_ticks_kernel).
  bool surface = false;
  SurfaceDev surface_dev;
  cuda::DeviceArray<int4> tri;
  cuda::DeviceArray<int> tri_offsets, tri_entries, tri_counts, tri_list, tri_scan;
  cuda::DeviceArray<double> cand_w;
  cuda::DeviceArray<unsigned long long> tri_arrive, tri_summed, tri_stamp, vertex_stamp;
  cuda::DeviceArray<ulonglong2> tri_masks;
  cuda::DeviceArray<ListedTriangle> listed;
  cuda::DeviceArray<int2> contact;
  cuda::DeviceArray<int4> tri_map;
  cuda::DeviceArray<int> listed_count, sample_listed;
  cuda::DeviceArray<SampleSum> tri_sum;
  int* overflow = nullptr;           // cudaHostAlloc, mapped

  /// The tick kernel of this object's contact.
  const void* kernel() const {
    return surface ? surface_ticks_kernel_entry() : reinterpret_cast<const void*>(ticks_kernel);
  }

  ~Impl() {
    for (cudaEvent_t e : done) cudaEventDestroy(e);
    for (cudaEvent_t e : step_ready) cudaEventDestroy(e);
    if (q_ready) cudaEventDestroy(q_ready);
    if (step_done) cudaEventDestroy(step_done);
    if (ring) cudaFreeHost(ring);
    if (overflow) cudaFreeHost(overflow);
    if (inverted_slots) cudaFreeHost(inverted_slots);
    if (stream) cudaStreamDestroy(stream);
  }

  /// Surface contact's device data (SurfaceDev) from the tool's SurfaceContactModel (m vertices).
  void upload_surface(const SurfaceContactModel& s, int m) {
    Impl& I = *this;
    if (static_cast<int>(s.tri_offsets.size()) != m + 1)
      throw std::invalid_argument("CudaHapticTicks: the surface contact model has another vertex count than the virtual mesh");
    cudaStream_t st = I.stream;
    const int F = static_cast<int>(s.triangles.size());
    std::vector<int4> tri(std::max(F, 1), make_int4(0, 0, 0, 1));
    for (int f = 0; f < F; ++f)
      tri[f] = make_int4(s.triangles[f][0], s.triangles[f][1], s.triangles[f][2], s.rest_level[f]);
    const int chunks = std::max(1, cuda::blocks_for(F, kBlock));
    auto up = [st](auto& arr, const auto& host) {
      arr.allocate(host.size());
      arr.upload(host.data(), st);
    };
    up(I.tri, tri);
    up(I.tri_offsets, s.tri_offsets);
    up(I.tri_entries, s.tri_entries.empty() ? std::vector<int>(1, 0) : s.tri_entries);
    I.tri_counts.allocate(2 * std::size_t(chunks));
    I.tri_list.allocate(std::size_t(chunks) * kBlock);
    I.tri_scan.allocate(std::size_t(chunks) + 1);
    up(I.tri_arrive, std::vector<unsigned long long>(1, 0));
    up(I.tri_summed, std::vector<unsigned long long>(1, 0));
    SurfaceDev& sd = I.surface_dev;
    sd.capacity = surface_capacity(s);
    I.cand_w.allocate(sd.capacity);
    I.contact.allocate(sd.capacity);
    I.listed.allocate(std::size_t(chunks) * kBlock);
    I.tri_map.allocate(tri.size());
    I.sample_listed.allocate(sd.capacity);
    I.tri_sum.allocate(3 * tri.size());
    up(I.listed_count, std::vector<int>(1, 0));
    up(I.tri_stamp, std::vector<unsigned long long>(tri.size(), 0));  // no step's list yet
    up(I.vertex_stamp, std::vector<unsigned long long>(std::max(m, 1), 0));
    I.tri_masks.allocate(tri.size());
    EBH_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&I.overflow), sizeof(int), cudaHostAllocMapped));
    *I.overflow = 0;
    int* overflow_dev = nullptr;
    EBH_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&overflow_dev), I.overflow, 0));
    sd.F = F;
    sd.chunks = F > 0 ? chunks : 0;
    sd.spacing = s.spacing;
    sd.stiffness_factor = s.stiffness_factor;
    sd.tri = I.tri.get();
    sd.tri_offsets = I.tri_offsets.get();
    sd.tri_entries = I.tri_entries.get();
    sd.counts = I.tri_counts.get();
    sd.list = I.tri_list.get();
    sd.offsets = I.tri_scan.get();
    sd.cand_w = I.cand_w.get();
    sd.arrive = I.tri_arrive.get();
    sd.listed = I.listed.get();
    sd.contact = I.contact.get();
    sd.tri_map = I.tri_map.get();
    sd.tri_stamp = I.tri_stamp.get();
    sd.vertex_stamp = I.vertex_stamp.get();
    sd.tri_masks = I.tri_masks.get();
    sd.listed_count = I.listed_count.get();
    sd.sample_listed = I.sample_listed.get();
    sd.summed = I.tri_summed.get();
    sd.tri_sum = I.tri_sum.get();
    sd.overflow = overflow_dev;
  }

  /// The buffer of q that holds the virtual mesh after the last enqueued tick: q[0], or with one
  /// iteration a tick q[1] after an odd count (the two take turns: Schedule::odd).
  const Vec3f* state_buffer() const { return q[iterations == 1 && (enqueued & 1) ? 1 : 0].get(); }

  /// The physical step's q: the virtual mesh after the last enqueued tick (state_buffer), copied
  /// on the ticks' stream; the physical stream `pst` waits for the copy.
  void hand_q_to_physical(cudaStream_t pst) {
    if (m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(physical->device_q(), state_buffer(), m * sizeof(Vec3f), cudaMemcpyDeviceToDevice, stream));
    EBH_CUDA_CHECK(cudaEventRecord(q_ready, stream));
    EBH_CUDA_CHECK(cudaStreamWaitEvent(pst, q_ready, 0));
  }
};

CudaHapticTicks::CudaHapticTicks(const DeviceHapticSetup& S, std::span<const DeviceTickInput> in,
                                 CudaPhysicalSolver& physical)
    : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  if (!S.mesh || !S.tool) throw std::invalid_argument("CudaHapticTicks: no model");
  if (!device_haptic_supported(*S.tool))
    throw std::invalid_argument("CudaHapticTicks: the device tick supports the closest-point projection only");
  const VirtualModel& M = *S.mesh;
  I.physical = &physical;
  I.m = M.num_vertices;
  I.n = static_cast<int>(S.x0.size());
  I.iterations = std::max(1, S.virtual_iterations);
  if (S.newton_calls < 0 || S.newton_calls > I.iterations)
    throw std::invalid_argument("CudaHapticTicks: newton_calls must be 0 (after every step) or in [1, virtual_iterations]");
  I.ticks = static_cast<long long>(in.size());
  I.period = S.ticks_per_step;
  if (I.period < 0) throw std::invalid_argument("CudaHapticTicks: ticks_per_step must not be negative");
  if (S.q0.size() != static_cast<std::size_t>(I.m)) throw std::invalid_argument("CudaHapticTicks: q0 has the wrong size");
  int lo = 0, hi = 0;
  EBH_CUDA_CHECK(cudaDeviceGetStreamPriorityRange(&lo, &hi));
  EBH_CUDA_CHECK(cudaStreamCreateWithPriority(&I.stream, cudaStreamNonBlocking, hi));  // the haptic side first
  EBH_CUDA_CHECK(cudaEventCreateWithFlags(&I.q_ready, cudaEventDisableTiming));
  EBH_CUDA_CHECK(cudaEventCreateWithFlags(&I.step_done, cudaEventDisableTiming));
  I.done.resize(8);
  for (cudaEvent_t& e : I.done) EBH_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming));
  I.runs.resize(I.done.size());
  cudaStream_t st = I.stream;
  auto up = [st](auto& arr, const auto& host) {
    arr.allocate(host.size());
    arr.upload(host.data(), st);
  };
  const int m = I.m;
  if (!S.physical_tets.empty()) {  // the steps inside the launches count their inverted tets
    std::vector<int4> tets(S.physical_tets.size());
    for (std::size_t a = 0; a < tets.size(); ++a) {
      const Tet& k = S.physical_tets[a];
      for (const int v : k)
        if (v < 0 || v >= static_cast<int>(S.physical_rest.size()))
          throw std::invalid_argument("CudaHapticTicks: physical tet " + std::to_string(a) + " names a vertex out of range");
      tets[a] = make_int4(k[0], k[1], k[2], k[3]);
    }
    I.tets = static_cast<int>(tets.size());
    up(I.inverted_tets, tets);
    up(I.inverted_sign, rest_signs(S.physical_rest, S.physical_tets));
    up(I.inverted_sum, std::vector<unsigned>(1, 0u));
  }
  I.model.upload(M, st);
  up(I.edge_ell, edge_ell(M));
  std::vector<Vec3f> x0(I.n), q0(m), zero(m);
  for (int a = 0; a < I.n; ++a) x0[a] = to_float(S.x0[a]);
  for (int j = 0; j < m; ++j) q0[j] = to_float(S.q0[j]);
  I.x_host.allocate(I.n);
  up(I.x_prev, x0);
  up(I.x_vis, x0);
  up(I.v, zero);
  up(I.q[0], q0);
  for (auto* a : {&I.v_scratch, &I.q_start, &I.s, &I.p, &I.q[1], &I.q[2]}) a->allocate(m);
  up(I.held, std::vector<std::uint8_t>(m, 0));
  I.grasp_local.allocate(m);
  const int chunks = std::max(1, cuda::blocks_for(m, kBlock));
  I.surface = S.tool->surface != nullptr;
  if (I.surface) I.upload_surface(*S.tool->surface, m);
  I.surface_dev.lists = S.contact_lists;
  I.surface_dev.masked_samples = S.sample_bits ? kMaskedSamples : 0;
  I.cand_q.allocate(std::max(m, I.surface_dev.capacity));
  I.block_cand.allocate(std::size_t(chunks) * kBlock);
  I.block_held.allocate(std::size_t(chunks) * kBlock);
  I.block_deferred.allocate(std::size_t(chunks) * kBlock);
  I.block_counts.allocate(4 * std::size_t(chunks));
  I.block_offsets.allocate(2 * (std::size_t(chunks) + 1));
  I.held_list.allocate(m);
  I.held_slot.allocate(m);
  up(I.sync, std::vector<SyncDev>(1, SyncDev{0, 0}));
  I.slots.allocate(2);
  if (S.max_blocks < 0 || S.max_blocks == 1)
    throw std::invalid_argument("CudaHapticTicks: max_blocks must be 0 (no cap) or at least 2");
  {  // every block of ticks_kernel resident (its hand-offs spin): at most the device's co-resident blocks
    const DeviceTickCapacity cap = tick_capacity(I.kernel());
    int device = 0;
    EBH_CUDA_CHECK(cudaGetDevice(&device));
    // With the physical steps inside the launches (run_ticks_with_steps), enough shared memory on
    // each tick block's multiprocessor for one block of the step beside it; with the L1-first
    // carve-out the step's blocks fit only on the multiprocessors the ticks leave free (on an H100,
    // 32 of 132), which more than doubles its time.
    cudaFuncAttributes fa{};
    EBH_CUDA_CHECK(cudaFuncGetAttributes(&fa, I.kernel()));
    int reserved = 0, max_shared = 0, major = 0, minor = 0;
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&reserved, cudaDevAttrReservedSharedMemoryPerBlock, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&max_shared, cudaDevAttrMaxSharedMemoryPerMultiprocessor, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device));
    EBH_CUDA_CHECK(cudaDeviceGetAttribute(&minor, cudaDevAttrComputeCapabilityMinor, device));
    // Replays sharing the device (blocks_per_sm > 1): room for that many tick blocks and a step's.
    if (S.blocks_per_sm < 1 || S.blocks_per_sm > cap.blocks_per_sm_shared)
      throw std::invalid_argument("CudaHapticTicks: blocks_per_sm must be in [1, " + std::to_string(cap.blocks_per_sm_shared) + "]");
    const std::size_t need = S.blocks_per_sm * (fa.sharedSizeBytes + std::size_t(reserved)) + physical.block_shared_bytes() +
                             std::size_t(reserved);
    I.carveout_beside_steps = shared_carveout_percent(need, std::size_t(max_shared), shared_memory_configs_kb(major, minor));
    const int most = S.blocks_per_sm == 1 ? cap.alone_grid(chunks)
                                          : S.blocks_per_sm * (cap.multiprocessors - cap.multiprocessors_for_shared_steps());
    I.grid = std::min(chunks + 1, most);  // block 0 runs no chunks
    if (S.max_blocks > 0) I.grid = std::min(I.grid, S.max_blocks);
  }
  ToolStateDev s0{};
  s0.position = s0.anchor_position = S.pose0.position;
  s0.orientation = s0.anchor_orientation = S.pose0.orientation;
  up(I.state, std::vector<ToolStateDev>(1, s0));
  up(I.inputs, std::vector<DeviceTickInput>(in.begin(), in.end()));
  std::vector<Collider<double>> boxes = S.grasp_boxes;
  if (boxes.empty()) boxes.emplace_back();
  up(I.grasp_boxes, boxes);
  I.ring_size = 4096;
  EBH_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&I.ring), I.ring_size * sizeof(DeviceTickOutput), cudaHostAllocMapped));
  DeviceTickOutput* ring_dev = nullptr;
  EBH_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&ring_dev), I.ring, 0));

  MeshDev& d = I.dev;
  d.m = m;
  d.chunks = chunks;
  d.ring = I.ring_size;
  d.k_s = float(M.k_s);
  d.k_svc = float(M.k_svc);
  d.h = float(S.h);
  d.v_scale = float(tick_velocity_scale(S.h, M.damping));
  d.inv_h2 = float(1.0 / (S.h * S.h));
  d.gravity = to_float(M.gravity);
  d.model = I.model.view();
  d.edge_ell = I.edge_ell.get();
  d.x_prev = I.x_prev.get();
  d.x_vis = I.x_vis.get();
  d.q_start = I.q_start.get();
  d.s = I.s.get();
  d.p = I.p.get();
  d.held = I.held.get();
  d.grasp_local = I.grasp_local.get();
  d.block_cand = I.block_cand.get();
  d.block_held = I.block_held.get();
  d.block_counts = I.block_counts.get();
  d.block_offsets = I.block_offsets.get();
  d.iterations = I.iterations;
  d.first_call = S.newton_calls == 0 ? 0 : I.iterations - S.newton_calls;
  d.pipeline = S.pipeline && !I.surface;  // surface contact runs unpipelined steps (haptic_cuda_surface_run.cuh)
  d.pipeline_limit = S.pipeline_limit;
  d.slots = I.slots.get();
  d.q0 = I.q[0].get();
  d.q1 = I.q[1].get();
  d.q2 = I.q[2].get();
  d.v = I.v.get();
  d.v_scratch = I.v_scratch.get();
  d.block_deferred = I.block_deferred.get();
  d.sync = I.sync.get();
  d.cand_q = I.cand_q.get();
  d.held_list = I.held_list.get();
  d.held_slot = I.held_slot.get();
  d.state = I.state.get();
  d.inputs = I.inputs.get();
  d.grasp_boxes = I.grasp_boxes.get();
  d.out = ring_dev;
  if (S.profile_stages) {
    up(I.profile, std::vector<ProfileDev>(1, ProfileDev{}));
    d.profile = I.profile.get();
  }
  if (S.active_region > 0) {
    if (I.surface) throw std::invalid_argument("CudaHapticTicks: the active region needs vertex contact");
    if (S.region_check_ticks < 1) throw std::invalid_argument("CudaHapticTicks: region_check_ticks must be at least 1");
    // Every chunk awake at first (a chunk sleeps after kCalmTicks calm ticks); each vertex's
    // offset its weight's stretch (region_rules.hpp).
    up(I.chunk_region, std::vector<ChunkRegion>(chunks, ChunkRegion{{-1, -1}, 1, 0}));
    std::vector<Vec3f> offset(m);
    for (int j = 0; j < m; ++j) offset[j] = to_float(rest_offset(M.mass[j], M.k_svc, M.gravity));
    up(I.region_offset, offset);
    up(I.region_disp, zero);
    up(I.region_awake, std::vector<unsigned long long>(1, 0));
    std::vector<int> chunk_free(chunks, 0);
    for (int j = 0; j < m; ++j) chunk_free[j / kBlock] += M.pinned[j] ? 0 : 1;
    up(I.chunk_free, chunk_free);
    up(I.region_tick_active, std::vector<unsigned>(2, 0));
    const int calls = S.newton_calls == 0 ? I.iterations : S.newton_calls;
    // A tick's Newton calls, and the one before its first step (a pipelined step runs beside it,
    // at the pose before it): from the pose a tick's first step sees, the tool reaches at most
    // what calls + 1 calls do (the CPU's seeds: simulation.cpp, gather_region_seeds), rounded out.
    const NewtonReach reach = newton_reach_of_calls(newton_limits(S.tool->spec), calls + 1);
    d.region_tol = static_cast<float>(S.active_region);
    d.region_reach_T = static_cast<float>(reach.translation * (1 + 1e-6));
    d.region_reach_th = static_cast<float>(reach.rotation * (1 + 1e-6));
    d.region_check = S.region_check_ticks;
    d.chunk_region = I.chunk_region.get();
    d.region_offset = I.region_offset.get();
    d.region_disp = I.region_disp.get();
    d.region_awake = I.region_awake.get();
    d.chunk_free = I.chunk_free.get();
    d.region_tick_active = I.region_tick_active.get();
  }

  const ToolModel& T = *S.tool;
  ToolConst& t = I.tool;
  t.count = static_cast<int>(T.colliders.size());
  for (int c = 0; c < t.count; ++c) {
    const Collider<double>& a = T.colliders[c];
    t.shape[c] = a;
    bounding_segment(a, t.seg_a[c], t.seg_b[c], t.seg_r[c]);
    // The segment's farthest point from the tool origin (a jaw's frame turns about that origin).
    const double L = std::max(norm(static_cast<Vec3d>(t.seg_a[c])), norm(static_cast<Vec3d>(t.seg_b[c])));
    t.seg_L[c] = static_cast<float>(L * (1 + 1e-6) + 1e-7);
  }
  t.k_con = S.k.k_con;
  t.k_vcs = S.k.k_vcs;
  t.k_vct = S.k.k_vct;
  t.stab_t = T.spec.stabilization_translation;
  t.stab_r = T.spec.stabilization_rotation;
  const NewtonLimits lim = newton_limits(T.spec);
  t.max_step = lim.max_step;
  t.max_rot = lim.max_rot;
  t.newton = lim.iterations;
  t.force_limit = T.spec.force_limit;
  t.torque_limit = T.spec.torque_limit;
  t.soft_margin = T.spec.forceps.soft_margin;
  t.eta = T.spec.forceps.eta;
  t.reach_T = static_cast<float>(lim.reach_translation);
  t.reach_th = static_cast<float>(lim.reach_rotation);
  if (I.surface) I.surface_dev.inv_reach = static_cast<float>(1.0 / (1.0 - lim.reach_rotation) * (1 + 1e-6));
  EBH_CUDA_CHECK(cudaStreamSynchronize(st));
}

CudaHapticTicks::~CudaHapticTicks() = default;

int CudaHapticTicks::capacity() const { return impl_->ring_size; }

void CudaHapticTicks::start_physical_step() {
  Impl& I = *impl_;
  if (I.steps_mode == Impl::Steps::InLaunch)
    throw std::logic_error("CudaHapticTicks::start_physical_step: the physical steps run in the launches (run_ticks_with_steps)");
  I.steps_mode = Impl::Steps::PerPeriod;
  auto* pst = static_cast<cudaStream_t>(I.physical->stream_handle());
  I.hand_q_to_physical(pst);
  I.physical->launch_device_step();
  EBH_CUDA_CHECK(cudaEventRecord(I.step_done, pst));
  if (I.n > 0)  // for the observer's on_step (the copy engine, not the haptic ticks, waits for it)
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_host.get(), I.physical->device_x(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToHost, pst));
  I.step_in_flight = true;
}

void CudaHapticTicks::deliver_physical_step() {
  Impl& I = *impl_;
  if (!I.step_in_flight) throw std::logic_error("CudaHapticTicks::deliver_physical_step: no step was started");
  EBH_CUDA_CHECK(cudaStreamWaitEvent(I.stream, I.step_done, 0));
  if (I.n > 0) {
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_prev.get(), I.x_vis.get(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToDevice, I.stream));
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_vis.get(), I.physical->device_x(), I.n * sizeof(Vec3f), cudaMemcpyDeviceToDevice, I.stream));
  }
}

PhysicalStepReport CudaHapticTicks::finish_physical_step(std::vector<Vec3d>& x) {
  Impl& I = *impl_;
  I.step_in_flight = false;
  const PhysicalStepReport r = I.physical->device_step_report();
  EBH_CUDA_CHECK(cudaStreamSynchronize(static_cast<cudaStream_t>(I.physical->stream_handle())));
  to_double(I.x_host.get(), I.n, x);
  return r;
}

int CudaHapticTicks::run_ticks(int count) {
  Impl& I = *impl_;
  if (I.steps_mode == Impl::Steps::InLaunch)
    throw std::logic_error("CudaHapticTicks::run_ticks: the physical steps run in the launches (run_ticks_with_steps)");
  return launch_ticks(count);
}

int CudaHapticTicks::run_ticks_with_steps(int count) {
  Impl& I = *impl_;
  if (I.steps_mode == Impl::Steps::PerPeriod || (I.steps_mode == Impl::Steps::Unused && I.enqueued > 0))
    throw std::logic_error("CudaHapticTicks::run_ticks_with_steps: not after run_ticks or start_physical_step");
  if (I.period <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: setup.ticks_per_step is 0");
  if (count <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: count must be positive");
  // Checked before any step is enqueued: a step whose ticks never run would wait forever.
  if (count > I.ring_size) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: more ticks than the output ring holds");
  if (I.enqueued + count > I.ticks) throw std::invalid_argument("CudaHapticTicks::run_ticks_with_steps: past the last tick's input");
  const long long N = I.period, a = I.enqueued, b = a + count;
  const long long k0 = (a + N - 1) / N, k1 = (b + N - 1) / N;  // the steps of the periods starting in [a, b)
  if (k1 - I.steps_finished > I.step_slots)
    throw std::logic_error("CudaHapticTicks::run_ticks_with_steps: more physical steps in flight than step_capacity(); "
                           "finish_step the oldest first");
  cudaStream_t pst = static_cast<cudaStream_t>(I.physical->stream_handle());
  const bool first_use = I.steps_mode == Impl::Steps::Unused;
  if (first_use) {  // the ring, the slots, the counters, the carve-out
    I.steps_mode = Impl::Steps::InLaunch;
    // The kernel's attribute (process-wide): a later CudaHapticTicks sets L1-first again.
    if (I.carveout_beside_steps >= 0)
      EBH_CUDA_CHECK(cudaFuncSetAttribute(I.kernel(), cudaFuncAttributePreferredSharedMemoryCarveout,
                                          I.carveout_beside_steps));
    I.physical->set_device_step_slots(I.step_slots);
    I.physical->prepare_device_step();
    for (auto& x : I.xring) x.allocate(std::max(I.n, 1));
    I.x_slots.allocate(std::size_t(I.step_slots) * std::max(I.n, 1));
    I.steps_sync.allocate(1);
    EBH_CUDA_CHECK(cudaMemsetAsync(I.steps_sync.get(), 0, sizeof(StepsDev), I.stream));
    if (I.tets > 0) {
      EBH_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&I.inverted_slots), sizeof(int) * I.step_slots, cudaHostAllocMapped));
      for (int k = 0; k < I.step_slots; ++k) I.inverted_slots[k] = -1;
      EBH_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&I.inverted_slots_dev), I.inverted_slots, 0));
    }
    I.step_ready.resize(I.step_slots);
    for (cudaEvent_t& e : I.step_ready) EBH_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming));
    MeshDev& d = I.dev;
    d.period = I.period;
    for (int k = 0; k < 3; ++k) d.xring[k] = I.xring[k].get();
    d.xring[ring_slot(-1)] = I.x_prev.get();  // the physical result at tick 0 (never overwritten in this mode)
    d.snap_q = I.physical->device_q();
    d.steps = I.steps_sync.get();
    EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));  // the counters zeroed before the physical stream polls them
  }
  // The launch's first tick blends its period's physical results: that of step ka - 1 waited for
  // (before this call's steps take slots: a slot's event is re-recorded by a later step).
  MeshDev& d = I.dev;
  const long long ka = a / N;
  if (ka >= 1) EBH_CUDA_CHECK(cudaStreamWaitEvent(I.stream, I.step_ready[(ka - 1) % I.step_slots], 0));
  d.x_vis = d.xring[ring_slot(ka - 1)];
  d.x_prev = d.xring[ring_slot(ka - 2)];
  const unsigned long long vertex_blocks = static_cast<unsigned long long>(I.grid - 1);
  // Step k: its q (k = 0: the initial mesh, copied on the ticks' stream before they run; k > 0:
  // the ticks' snapshot, waited for), the step, its x into the ring and the host slot, published.
  auto enqueue_step = [&](long long k) {
    const int slot = static_cast<int>(k % I.step_slots);
    if (k == 0) {
      I.hand_q_to_physical(pst);
    } else {
      wait_for_snapshots<<<1, 32, 0, pst>>>(I.steps_sync.get(), static_cast<unsigned long long>(k) * vertex_blocks);
      EBH_CUDA_LAUNCH_CHECK(pst, "wait_for_snapshots");
    }
    I.physical->launch_device_step(slot);
    if (I.n > 0) {
      Vec3f* x = I.xring[ring_slot(k)].get();
      copy_positions<<<cuda::blocks_for(I.n, 256), 256, 0, pst>>>(I.physical->device_x(), x, I.n);
      EBH_CUDA_LAUNCH_CHECK(pst, "copy_positions");
      EBH_CUDA_CHECK(cudaMemcpyAsync(I.x_slots.get() + std::size_t(slot) * I.n, x, I.n * sizeof(Vec3f),
                                     cudaMemcpyDeviceToHost, pst));
    }
    int* count_slot = nullptr;
    if (I.tets > 0) {
      count_inverted<<<std::min(cuda::blocks_for(I.tets, 256), 256), 256, 0, pst>>>(
          I.xring[ring_slot(k)].get(), I.inverted_tets.get(), I.inverted_sign.get(), I.tets, I.inverted_sum.get());
      EBH_CUDA_LAUNCH_CHECK(pst, "count_inverted");
      count_slot = I.inverted_slots_dev + slot;
    }
    publish_step<<<1, 32, 0, pst>>>(I.steps_sync.get(), static_cast<unsigned long long>(k + 1),
                                    count_slot ? I.inverted_sum.get() : nullptr, count_slot);
    EBH_CUDA_LAUNCH_CHECK(pst, "publish_step");
    EBH_CUDA_CHECK(cudaEventRecord(I.step_ready[slot], pst));
  };
  I.steps_enqueued = k1;
  if (first_use) {
    // With lazy module loading (the CUDA 12 default) a kernel's first launch may wait for the
    // device's running kernels; here those can be waiting for it (the ticks for a step's x, the
    // physical stream for the ticks' q), a deadlock. So every kernel of the hand-off is first
    // launched while none of them waits: wait_for_snapshots with nothing to wait for, step 0
    // (which waits for no ticks), the ticks (which wait for step 0 only, at tick N - 1), and
    // only then the steps that wait for the ticks.
    wait_for_snapshots<<<1, 32, 0, pst>>>(I.steps_sync.get(), 0ull);
    EBH_CUDA_LAUNCH_CHECK(pst, "wait_for_snapshots");
    enqueue_step(0);
    const int handle = launch_ticks(count);
    for (long long k = 1; k < k1; ++k) enqueue_step(k);
    return handle;
  }
  for (long long k = k0; k < k1; ++k) enqueue_step(k);
  return launch_ticks(count);
}

int CudaHapticTicks::steps_in_flight() const { return static_cast<int>(impl_->steps_enqueued - impl_->steps_finished); }

int CudaHapticTicks::step_capacity() const { return impl_->step_slots; }

PhysicalStepReport CudaHapticTicks::finish_step(std::vector<Vec3d>& x) {
  Impl& I = *impl_;
  if (I.steps_finished >= I.steps_enqueued) throw std::logic_error("CudaHapticTicks::finish_step: no step in flight");
  const int slot = static_cast<int>(I.steps_finished % I.step_slots);
  ++I.steps_finished;
  PhysicalStepReport r = I.physical->device_step_report(slot);
  EBH_CUDA_CHECK(cudaEventSynchronize(I.step_ready[slot]));
  to_double(I.x_slots.get() + std::size_t(slot) * I.n, I.n, x);
  if (I.inverted_slots) r.inverted = I.inverted_slots[slot];
  return r;
}

int CudaHapticTicks::launch_ticks(int count) {
  Impl& I = *impl_;
  if (count <= 0) throw std::invalid_argument("CudaHapticTicks::run_ticks: count must be positive");
  if (count > I.ring_size) throw std::invalid_argument("CudaHapticTicks::run_ticks: more ticks than the output ring holds");
  if (I.enqueued + count > I.ticks) throw std::invalid_argument("CudaHapticTicks::run_ticks: past the last tick's input");
  {
    int n = count;
    long long tick0 = I.enqueued;
    unsigned long long e = I.epoch;
    if (I.surface) {
      void* args[] = {&I.dev, &I.tool, &I.surface_dev, &n, &tick0, &e};
      EBH_CUDA_CHECK(cudaLaunchCooperativeKernel(I.kernel(), dim3(I.grid), dim3(kBlock), args, 0, I.stream));
      EBH_CUDA_LAUNCH_CHECK(I.stream, "surface_ticks_kernel");  // haptic_cuda_surface.cu
    } else {
      void* args[] = {&I.dev, &I.tool, &n, &tick0, &e};
      EBH_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<void*>(ticks_kernel), dim3(I.grid), dim3(kBlock), args, 0, I.stream));
      EBH_CUDA_LAUNCH_CHECK(I.stream, "ticks_kernel");
    }
    I.epoch += static_cast<unsigned long long>(count) * I.iterations;
  }
  const int handle = I.next_handle;
  I.next_handle = (I.next_handle + 1) % static_cast<int>(I.done.size());
  EBH_CUDA_CHECK(cudaEventRecord(I.done[handle], I.stream));
  I.runs[handle] = {I.enqueued, count};
  I.enqueued += count;
  return handle;
}

void CudaHapticTicks::collect(int handle, std::span<DeviceTickOutput> out) {
  Impl& I = *impl_;
  const auto [first, count] = I.runs.at(handle);
  if (out.size() != static_cast<std::size_t>(count)) throw std::invalid_argument("CudaHapticTicks::collect: wrong size");
  EBH_CUDA_CHECK(cudaEventSynchronize(I.done[handle]));
  if (I.overflow && *I.overflow)
    throw std::runtime_error("device tick: more surface samples near the virtual tool than the " +
                             std::to_string(I.surface_dev.capacity) +
                             " it holds (contact: surface; a virtual mesh stretched far past its rest edge lengths)");
  for (int k = 0; k < count; ++k) out[k] = I.ring[(first + k) % I.ring_size];
}

DeviceTickProfile CudaHapticTicks::profile() {
  Impl& I = *impl_;
  DeviceTickProfile r;
  if (!I.dev.profile) return r;
  ProfileDev p{};
  EBH_CUDA_CHECK(cudaMemcpyAsync(&p, I.dev.profile, sizeof(p), cudaMemcpyDeviceToHost, I.stream));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));
  if (!p.steps || !p.tail_ns) return r;
  const double steps = static_cast<double>(p.steps);
  r.tail_clock_ghz = static_cast<double>(p.tail_cycles) / static_cast<double>(p.tail_ns);
  r.clamp_sweeps = p.clamps ? static_cast<double>(p.sweeps) / static_cast<double>(p.clamps) : 0.0;
  r.definite = p.clamps + p.definite ? static_cast<double>(p.definite) / static_cast<double>(p.clamps + p.definite) : 0.0;
  r.candidates = static_cast<double>(p.candidates) / steps;
  r.unpipelined = static_cast<double>(p.unpipelined) / steps;
  r.listed = static_cast<double>(p.listed) / steps;
  r.updated = p.steps > p.unpipelined ? static_cast<double>(p.updated) / static_cast<double>(p.steps - p.unpipelined) : 0.0;
  for (int k = 0; k < DeviceTickProfile::kStages; ++k) {
    const bool cycles = k <= DeviceTickProfile::Output;  // block 0's, in its cycles
    const bool per_block = k >= DeviceTickProfile::BlockLag && k <= DeviceTickProfile::BlockTriangles;  // summed over blocks
    const double ns = static_cast<double>(p.sum[k]) / (cycles ? r.tail_clock_ghz : 1.0);
    r.mean_us[k] = 1e-3 * ns / (steps * (per_block ? I.grid - 1 : 1));
  }
  return r;
}

double CudaHapticTicks::awake_share() {
  Impl& I = *impl_;
  if (!I.dev.region_awake || I.enqueued == 0) return 1.0;
  unsigned long long awake = 0;
  EBH_CUDA_CHECK(cudaMemcpyAsync(&awake, I.dev.region_awake, sizeof(awake), cudaMemcpyDeviceToHost, I.stream));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));
  return static_cast<double>(awake) / (static_cast<double>(I.enqueued) * I.dev.chunks);
}

void CudaHapticTicks::snapshot(std::vector<Vec3d>& q, std::vector<Vec3d>& x_visible) {
  Impl& I = *impl_;
  std::vector<Vec3f> qf(I.m), xf(I.n);
  if (I.m > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(qf.data(), I.state_buffer(), I.m * sizeof(Vec3f), cudaMemcpyDeviceToHost, I.stream));
  const Vec3f* x_vis = I.x_vis.get();
  if (I.steps_mode == Impl::Steps::InLaunch && I.enqueued > 0) {  // the last enqueued tick's period's
    x_vis = I.dev.xring[ring_slot((I.enqueued - 1) / I.period - 1)];
  }
  if (I.n > 0) EBH_CUDA_CHECK(cudaMemcpyAsync(xf.data(), x_vis, I.n * sizeof(Vec3f), cudaMemcpyDeviceToHost, I.stream));
  EBH_CUDA_CHECK(cudaStreamSynchronize(I.stream));
  to_double(qf.data(), I.m, q);
  to_double(xf.data(), I.n, x_visible);
}

}  // namespace ebh
