#pragma once
// The device haptic tick's data (part of haptic_cuda.cu's translation unit): its constants, the
// tool's constants and state, the mesh's device arrays and hand-off counters (MeshDev, a plain
// struct of pointers passed by value), the posed tool, and each block's shared memory.
#include <cuda_runtime.h>

#include <cstdint>

#include "schedule/haptic_cuda.hpp"
#include "schedule/haptic_cuda_profile.cuh"
#include "solver/virtual_mesh_device.cuh"
#include "tool/collider.hpp"
#include "tool/tool_model.hpp"

namespace ebh {
namespace {

constexpr int kBlock = 128;
constexpr int kWarps = kBlock / 32;
constexpr int kTailOffsets = 512;  // chunks whose list offsets the tail keeps in shared memory
constexpr int kCache = kBlock;      // candidates and held vertices the tail keeps in shared memory
constexpr int kReleaseThread = kBlock - 32;  // block 0's thread that releases the vertex blocks
constexpr int kPhysicalPoseThread = 64;      // block 0's first thread that poses the physical tool
constexpr int kEdgeChunk = 8;       // incident edges loaded at once (a surface vertex has ~6)
constexpr int kSums = 28;           // E, gradient (6), upper Hessian (21)
// A float32 signed distance above this (m) is certainly positive in double: the exact double tests
// run only below it (float's error on tool-sized coordinates is ~1e-7 m).
constexpr float kFloatSlack = 1e-5f;

/// The tool's constants (kernel parameter).
struct ToolConst {
  int count = 0;
  Collider<double> shape[kMaxColliders];
  // Early-outs: a segment (a, b, collider frame) and radius whose capsule contains collider c, so
  // the distance to that capsule is a lower bound of the collider's signed distance.
  Vec3f seg_a[kMaxColliders], seg_b[kMaxColliders];
  float seg_r[kMaxColliders];
  float seg_L[kMaxColliders];  // the segment's farthest point from the tool origin (pipelined reach)
  double k_con = 0, k_vcs = 0, k_vct = 0, stab_t = 0, stab_r = 0;
  double max_step = 0, max_rot = 0;
  int newton = 1;
  double force_limit = 0, torque_limit = 0;
  double soft_margin = 1, eta = 1;
  float reach_T = 0, reach_th = 0;  // candidates: translation and rotation one call can reach
};

/// The virtual tool's state on the device (one instance).
struct ToolStateDev {
  Vec3d position;
  Quatd orientation;
  Vec3d anchor_position;
  Quatd anchor_orientation;
};

/// Colliders posed for one tool pose and jaw value.
struct Posed {
  Rigid<double> world[kMaxColliders];
  Rigid<double> frame;  // tool frame -> world
  Vec3f seg_a[kMaxColliders], seg_u[kMaxColliders];  // bounding segments in the world: start, unit axis
  float seg_len[kMaxColliders], seg_r[kMaxColliders];
  Vec3f origin_f;       // frame.t, rounded
};

/// The grid's hand-off counters (ticks_kernel): arrivals of the vertex blocks, and the last epoch
/// block 0 released; both count from the object's first run.
struct SyncDev {
  unsigned long long arrive, release;
};

/// The hand-offs between the ticks and the physical steps of a launch across physical periods
/// (run_ticks_with_steps), each counter on its own line, away from the ticks' counters (SyncDev):
/// `snapped`, the vertex blocks' q snapshots so far (each block counts one per period after the
/// first); `done`, the physical steps whose x is in the ring.
struct StepsDev {
  unsigned long long snapped;
  unsigned long long pad_[15];
  unsigned long long done;
};

/// The virtual tool's pose that block 0 publishes with a step's release (MeshDev::slots); each
/// vertex block poses the colliders from it (pose_colliders: the same bits as block 0's).
struct SlotPose {
  Vec3d P;
  Quatd Q;
  int ahead = 0;  // the step runs pipelined, beside the Newton call before it (tool_block's choice)
};

/// A vertex a pipelined step left to block 0 (vertex_step<true>), at its place in its chunk's
/// list 1: what block 0 needs besides its contact, in one record.
struct alignas(16) DeferredVertex {
  Vec3f q;        // the iterate
  Vec3f r;        // the Jacobi sums without the contact
  Vec3f q_start;  // the tick's start (the velocity on its last step)
  float D;        // the diagonal without the contact; 0: pinned
  int j;
  int slot;       // -2: not held; held: its entry in TailShared::held_q, or -1
};

/// A chunk's place in the active region (MeshDev::chunk_region; docs/CUDA.md, "The active region"),
/// written by the block that runs the chunk but for `wake`.
struct ChunkRegion {
  // wake[T & 1] == T: a hot neighbour of one of its vertices at tick T - 1 wakes it at tick T (atomicMax
  // at T - 1's last step; read at T's first step, which with one iteration a tick is the other
  // entry's last step)
  long long wake[2];
  int awake;  // iterated this tick (decided at its first step)
  int calm;   // consecutive calm ticks while awake
};

struct MeshDev {
  int m = 0, chunks = 0, ring = 1;  // chunks of kBlock vertices (a block of the grid runs several when needed)
  int iterations = 1;               // virtual iterations per tick
  int first_call = 0;               // a Newton call follows a tick's steps from this one on (tool.newton_calls)
  bool pipeline = true;             // DeviceHapticSetup::pipeline
  int pipeline_limit = 0;           // DeviceHapticSetup::pipeline_limit
  float k_s = 0, k_svc = 0, h = 0, v_scale = 0, inv_h2 = 0;  // v_scale: tick_velocity_scale
  Vec3f gravity;
  cuda::VirtualModelView model;
  const Vec3f* x_prev = nullptr;  // the physical result before the visible one (the launch's first tick's)
  const Vec3f* x_vis = nullptr;   // the visible physical result
  // A launch across physical periods (run_ticks_with_steps; period 0: a launch within one period):
  // period k (ticks k period ..) blends x_prev = step k - 2's x and x_vis = step k - 1's, found in
  // xring[ring_slot(k)] (the physical result at tick 0 for k < 0). The first step of a tick
  // that starts period k > 0 copies q into snap_q, step k's input.
  int period = 0;
  const Vec3f* xring[4] = {};  // ring_slot(k): step k's entry
  Vec3f* snap_q = nullptr;
  StepsDev* steps = nullptr;
  Vec3f* q0 = nullptr;            // the virtual mesh at the tick's end; q1, q2: the iterates between
  Vec3f* q1 = nullptr;
  Vec3f* q2 = nullptr;
  Vec3f* v = nullptr;             // velocities: the last tick's (iteration 0 reads them), this tick's
  Vec3f* v_scratch = nullptr;     // one virtual iteration per tick: the velocities' second buffer (Schedule::odd)
  SyncDev* sync = nullptr;
  const int4* edge_ell = nullptr;  // edge_ell(): edge item u of vertex j at u m + j
  // 2: the virtual tool's pose for step s's vertices (slot s & 1), published by block 0 with the
  // step's release: the pose the step's contacts use, or (a pipelined step, which runs beside the
  // Newton call that moves the tool) the pose before that call.
  SlotPose* slots = nullptr;
  Vec3f* q_start = nullptr;
  Vec3f* s = nullptr;
  Vec3f* p = nullptr;
  std::uint8_t* held = nullptr;
  Vec3d* grasp_local = nullptr;
  // Per chunk, two lists of its vertices in vertex order: (unpipelined steps) the reachable and the
  // held ones; (pipelined) those that may be reachable after the call and those deferred to block 0.
  Vec3f* block_cand = nullptr;      // chunks * kBlock: list 0 (the vertex's new iterate)
  int* block_held = nullptr;        // chunks * kBlock: list 1 (unpipelined steps)
  DeferredVertex* block_deferred = nullptr;  // chunks * kBlock: list 1 (pipelined steps)
  int* block_counts = nullptr;      // chunks * 4: list 0, list 1, contacts, penetration (float bits)
  int* block_offsets = nullptr;     // 2 (chunks + 1)
  Vec3d* cand_q = nullptr;          // m
  int* held_list = nullptr;         // m
  int* held_slot = nullptr;         // m: a held vertex's entry in TailShared::held_q, or -1
  ToolStateDev* state = nullptr;
  const DeviceTickInput* inputs = nullptr;
  const Collider<double>* grasp_boxes = nullptr;
  // The active region (DeviceHapticSetup::active_region; region_tol 0: every chunk each tick): a
  // chunk of kBlock vertices sleeps, its vertices following their E_svc targets, while none of
  // them can be reached or is held, moving or pulled off by its edges (docs/CUDA.md).
  float region_tol = 0;
  float region_reach_T = 0, region_reach_th = 0;  // what a tick's Newton calls can reach
  int region_check = 1;              // a sleeping chunk c's strain check: on ticks t with (t + c) % region_check == 0
  ChunkRegion* chunk_region = nullptr;      // chunks
  Vec3f* region_offset = nullptr;    // m: where a vertex stands from its E_svc point while its chunk sleeps
  Vec3f* region_disp = nullptr;      // m: its displacement from there at the last tick's end (awake chunks)
  unsigned long long* region_awake = nullptr;  // chunk-ticks awake so far (one count per awake chunk and tick)
  int* chunk_free = nullptr;         // chunks: their free (not pinned) vertices
  // [2]: the free vertices of the chunks awake at a tick, by the tick's parity (block 0 takes the
  // count into the tick's output and zeroes it; the next tick's chunks add to the other entry)
  unsigned* region_tick_active = nullptr;
  DeviceTickOutput* out = nullptr;  // host-mapped ring of `ring` rows
  ProfileDev* profile = nullptr;    // stage timestamps, or null
};

/// The entry of MeshDev::xring (and of CudaHapticTicks' ring) that holds step k's x: k % 3, or 3,
/// the physical result at tick 0, for k < 0. Period k blends ring_slot(k - 2) and ring_slot(k - 1).
__host__ __device__ __forceinline__ int ring_slot(long long k) { return k >= 0 ? static_cast<int>(k % 3) : 3; }

/// A triangle of a step's candidate list (surface_lists): its corners, its samples' rows and
/// weight, how far its corners move to the next tick's first iterates (0 but after a tick's last
/// step), whether the Newton call may reach it (triangle_step), and the samples of the list's
/// triangles before it.
struct ListedTriangle {
  double w;
  Vec3f a, b, c;
  int f, n, base;
  float shift;
  bool newton;
  ulonglong2 masks;  // SurfaceDev::tri_masks' entry, for a triangle of at most kMaskedSamples samples
};

/// The most samples of a triangle whose tests the vertex blocks' triangle pass makes, one bit each
/// (SurfaceDev::tri_masks); block 0 tests the samples of a larger one itself (list_samples).
constexpr int kMaskedSamples = 64;

/// A vector and a scalar in double, one 32-byte load (SurfaceDev::tri_sum).
struct alignas(32) SampleSum {
  double x, y, z, w;
};

/// Flag of a chunk list's entry (SurfaceDev::list): the triangle is listed for the next step's
/// contacts only, not for the Newton call.
constexpr int kContactOnly = 1 << 30;

/// Surface contact's device data (scene `contact: surface`; surface_ticks_kernel's parameter, by
/// value): the virtual mesh's triangles (SurfaceContactModel) and the lists of the triangles and
/// samples near the virtual tool. docs/CUDA.md, "Surface contact".
struct SurfaceDev {
  int F = 0, chunks = 0;            // triangles; chunks of kBlock triangles (the vertex blocks run them as their vertex chunks)
  int capacity = 0;                 // samples the Newton call's list holds (MeshDev::cand_q, cand_w)
  bool lists = true;                // DeviceHapticSetup::contact_lists
  int masked_samples = 0;           // a triangle of at most this many samples has tri_masks
                                    //   (kMaskedSamples; 0 without DeviceHapticSetup::sample_bits)
  double spacing = 0, stiffness_factor = 1;  // SurfaceContactModel's
  float inv_reach = 1;              // 1 / (1 - reach_th): a triangle's bounding radius in the reach bound
  const int4* tri = nullptr;        // F: corners (x, y, z), rows at rest (w)
  const int* tri_offsets = nullptr; // m + 1: vertex j's triangles are tri_entries[tri_offsets[j] .. tri_offsets[j + 1])
  const int* tri_entries = nullptr;
  int* counts = nullptr;            // 2 chunks: the chunk's candidate triangles, its deepest physical-tool depth (float bits)
  int* list = nullptr;              // chunks * kBlock: each chunk's candidate triangles, in triangle order
  int* offsets = nullptr;           // chunks + 1: the lists' offsets (block 0's scan)
  double* cand_w = nullptr;         // capacity: the candidate samples' weights (their points: MeshDev::cand_q)
  unsigned long long* arrive = nullptr;  // the vertex blocks' arrivals after their triangles, one per step
  int* overflow = nullptr;          // host-mapped: set when a list of samples passed `capacity`
  // The contact list (block 0 after a step with a Newton call, surface_lists; read by the next
  // step's vertices, surface_contact_target): the samples that can touch the tool at any pose the
  // call can reach, at the step's q or (after a tick's last step) at the next tick's first iterates.
  ListedTriangle* listed = nullptr;  // chunks * kBlock: the triangles of the chunks' lists
  int* listed_count = nullptr;       // 1: the listed triangles
  int* sample_listed = nullptr;      // capacity: the listed triangle (its index in `listed`) of each
                                     //   of their samples, in order
  int2* contact = nullptr;           // capacity: (triangle, sample index in for_each_sample's order)
  int4* tri_map = nullptr;           // F: a listed triangle's samples contact[x .. y), its rows z,
                                     //   its samples inside the tool w (listed_triangle_sums)
  unsigned long long* tri_stamp = nullptr;  // F: the epoch of the step whose list holds the triangle
  unsigned long long* vertex_stamp = nullptr;  // m: the epoch of the step whose list holds one of
                                               //   the vertex's triangles
  ulonglong2* tri_masks = nullptr;   // F: a listed triangle's samples (bit k: sample k, at most
                                     //   kMaskedSamples) the Newton call can reach (x) and the
                                     //   contact list holds (y), from the triangle pass (triangle_chunk)
  // The contacts of the list's samples before the next step's vertices (listed_triangle_sums):
  SampleSum* tri_sum = nullptr;      // 3 F: per listed triangle and corner i, sum of w k_con b_i (q_i +
                                     //   y_proj - y) over its samples inside (xyz) and of w k_con b_i (w)
  unsigned long long* summed = nullptr;  // the vertex blocks' arrivals after those sums, one per step
};

struct TailShared {
  double sums[kWarps][kSums + 1];
  double total[kSums];
  float clamp_scratch[42];
  double dx[6], g[6];
  int warp_contacts[kWarps];
  unsigned warp_pen[kWarps];   // float bits of a non-negative depth
  int offsets[2 * (kTailOffsets + 1)];
  double E, slope, depth;
  int flag, nc, nh;
  int contacts;                // the step's vertices in contact (the tick's output on its last step)
  unsigned pen_bits;           // the step's deepest physical-tool penetration (float bits)
  int posed_current;           // whether the posed tool is at (P, Q) after the Newton call
  // The first kCache entries of the Newton call's lists (the rest in d.cand_q, d.held_list): read
  // by every evaluation and trial of the call, so kept here, entry i by thread i.
  Vec3d cand[kCache];          // a candidate's q
  Vec3d held_local[kCache], held_q[kCache];  // a held vertex's grasp point (tool frame) and q (its
                                             // slot: MeshDev::held_slot; the q of pipelined steps: finish_deferred)
  Vec3d P;
  Quatd Q;
  Vec3d trial_P;
  Quatd trial_Q;
  Vec3d anchor_P;  // the tool's pose at the tick's start (stabilisation)
  Quatd anchor_Q;
  double coupling_E, coupling_g[6];
};

/// The shared memory of a block of ticks_kernel.
struct BlockShared {
  alignas(16) unsigned char posed_raw[sizeof(Posed)], physical_raw[sizeof(Posed)], input_raw[sizeof(DeviceTickInput)],
      tail_raw[sizeof(TailShared)];
  int warp_counts[kWarps][3];
  unsigned warp_pen[kWarps];
  __device__ Posed& posed() { return *reinterpret_cast<Posed*>(posed_raw); }
  __device__ Posed& physical() { return *reinterpret_cast<Posed*>(physical_raw); }
  __device__ DeviceTickInput& in() { return *reinterpret_cast<DeviceTickInput*>(input_raw); }
  __device__ TailShared& tail() { return *reinterpret_cast<TailShared*>(tail_raw); }
};

/// What one vertex's step reports for its chunk's lists.
struct VertexFlags {
  bool list0 = false, list1 = false, contact = false;
  float pen = 0.f;  // depth in the physical tool (last step)
  int targets = 0;  // surface contact: the vertex's E_con targets (samples inside the tool, or 1 when held)
  Vec3f q{};        // the new iterate
};

}  // namespace
}  // namespace ebh
