#pragma once
// The device haptic tick's stage timers (DeviceHapticSetup::profile_stages), kept out of the
// tick's logic (part of haptic_cuda.cu's translation unit): block 0 marks its stages in SM cycles
// (TailMarks), each vertex block its own in global-timer ns (BlockClock); ProfileDev gathers them.
// A build with EBH_TICK_PROFILE=0 compiles them to nothing: profile_stages is then ignored and
// CudaHapticTicks::profile() reports zeros.
#include <cuda_runtime.h>

#include "schedule/haptic_cuda.hpp"

#ifndef EBH_TICK_PROFILE
#define EBH_TICK_PROFILE 1
#endif

namespace ebh {
namespace {

/// Stage times of the device tick, summed over steps in DeviceTickProfile's order: block 0's in SM
/// cycles, the other blocks' in global-timer ns.
struct ProfileDev {
  unsigned long long sum[DeviceTickProfile::kStages];
  unsigned long long steps, unpipelined, updated, candidates, clamps, sweeps, definite, listed;
  unsigned long long tail_cycles, tail_ns;  // block 0's SM cycles and time (its clock rate)
  unsigned long long release_ns[2];         // the release of step s (slot s & 1)
  unsigned long long vertices_max[2];       // step s's slowest block (slot s & 1)
  unsigned long long triangles_max[2];      // step s's slowest block's triangle pass (surface contact)
};

#if EBH_TICK_PROFILE

__device__ __forceinline__ unsigned long long global_ns() {
  unsigned long long t;
  asm volatile("mov.u64 %0, %%globaltimer;" : "=l"(t));
  return t;
}

/// Block 0's stage marks, kept by its thread 0 in registers (SM cycles) for the whole run and
/// written to the ProfileDev once at its end, so that profiling adds no memory round trips.
struct TailMarks {
  bool on = false;
  unsigned long long start_ns = 0, start_clock = 0, last = 0;
  unsigned long long cycles[DeviceTickProfile::kStages] = {};
  int clamps = 0, sweeps = 0, definite = 0, candidates = 0, updated = 0, unpipelined = 0, listed = 0;
  __device__ void begin(const ProfileDev* p) {
    on = p && threadIdx.x == 0;
    if (!on) return;
    start_ns = global_ns();
    start_clock = last = clock64();
  }
  /// Closes stage k at now (thread 0 only).
  __device__ void mark(int k) {
    if (!on || threadIdx.x != 0) return;
    const unsigned long long t = clock64();
    cycles[k] += t - last;
    last = t;
  }
  /// The Newton call's candidates; a PSD clamp's Jacobi sweeps (-1: the matrix was positive
  /// definite); block 0's own vertices of a pipelined step; an unpipelined step; a step whose
  /// vertices read a contact list (surface contact).
  __device__ void count_candidates(int n) { if (on) candidates += n; }
  __device__ void count_clamp(int s) {
    if (on && s >= 0) { ++clamps; sweeps += s; }
    if (on && s < 0) ++definite;
  }
  __device__ void count_updated(int n) { if (on) updated += n; }
  __device__ void count_unpipelined() { if (on) ++unpipelined; }
  __device__ void count_listed() { if (on) ++listed; }
  __device__ void end(ProfileDev* p, int steps) {
    if (!on) return;
    for (int k = DeviceTickProfile::Wait; k <= DeviceTickProfile::Output; ++k) p->sum[k] += cycles[k];
    p->tail_cycles += clock64() - start_clock;
    p->tail_ns += global_ns() - start_ns;
    p->clamps += clamps;
    p->sweeps += sweeps;
    p->definite += definite;
    p->candidates += candidates;
    p->updated += updated;
    p->unpipelined += unpipelined;
    p->listed += listed;
    p->steps += steps;
  }
};

/// Block 0 releases step s: when, for the vertex blocks' lag.
__device__ __forceinline__ void profile_release(ProfileDev* p, int s) {
  if (p) p->release_ns[s & 1] = global_ns();
}

/// Block 0 has every vertex block's arrival of step s (thread 0): the slowest block's
/// vertices into the sum.
__device__ __forceinline__ void profile_arrivals(ProfileDev* p, int s) {
  if (p && threadIdx.x == 0) {
    p->sum[DeviceTickProfile::BlockVerticesMax] += p->vertices_max[s & 1];
    p->sum[DeviceTickProfile::BlockTrianglesMax] += p->triangles_max[s & 1];
    p->vertices_max[s & 1] = 0;
    p->triangles_max[s & 1] = 0;
  }
}

/// A vertex block's stages of one step, by its thread 0 in global-timer ns: released (the lag after
/// block 0's release), posed (its setup), then per chunk the vertices and the lists; with surface
/// contact, after its chunks, the wait for every block's and its triangle pass.
struct BlockClock {
  bool on = false;
  unsigned long long start = 0, setup = 0, vertices = 0, chunks = 0, chunk = 0;
  unsigned long long arrived = 0, tri_begin = 0, triangles = 0;
  __device__ explicit BlockClock(const ProfileDev* p) : on(p && threadIdx.x == 0) {}
  __device__ void released() { if (on) start = global_ns(); }
  __device__ void posed() { if (on) setup = global_ns(); }
  __device__ void chunk_begin() { if (on) chunk = global_ns(); }
  __device__ void chunk_vertices_done() { if (on) vertices += global_ns() - chunk; }
  __device__ void chunk_end() { if (on) chunks += global_ns() - chunk; }
  __device__ void chunks_arrived() { if (on) arrived = tri_begin = global_ns(); }
  __device__ void triangles_begin() { if (on) tri_begin = global_ns(); }
  __device__ void triangles_end() { if (on) triangles = global_ns() - tri_begin; }
  /// Step s's stages into p (atomics: every vertex block adds its own).
  __device__ void report(ProfileDev* p, int s) const {
    if (!on) return;
    atomicAdd(&p->sum[DeviceTickProfile::BlockLag], start - p->release_ns[s & 1]);
    atomicAdd(&p->sum[DeviceTickProfile::BlockSetup], setup - start);
    atomicAdd(&p->sum[DeviceTickProfile::BlockVertices], vertices);
    atomicAdd(&p->sum[DeviceTickProfile::BlockLists], chunks - vertices);
    atomicAdd(&p->sum[DeviceTickProfile::BlockTriangleWait], tri_begin - arrived);
    atomicAdd(&p->sum[DeviceTickProfile::BlockTriangles], triangles);
    atomicMax(&p->vertices_max[s & 1], vertices);
    atomicMax(&p->triangles_max[s & 1], triangles);
  }
};

#else  // EBH_TICK_PROFILE == 0: every timer compiles to nothing.

struct TailMarks {
  static constexpr bool on = false;
  __device__ void begin(const ProfileDev*) {}
  __device__ void mark(int) {}
  __device__ void count_candidates(int) {}
  __device__ void count_clamp(int) {}
  __device__ void count_updated(int) {}
  __device__ void count_unpipelined() {}
  __device__ void count_listed() {}
  __device__ void end(ProfileDev*, int) {}
};
__device__ __forceinline__ void profile_release(ProfileDev*, int) {}
__device__ __forceinline__ void profile_arrivals(ProfileDev*, int) {}
struct BlockClock {
  __device__ explicit BlockClock(const ProfileDev*) {}
  __device__ void released() {}
  __device__ void posed() {}
  __device__ void chunk_begin() {}
  __device__ void chunk_vertices_done() {}
  __device__ void chunk_end() {}
  __device__ void chunks_arrived() {}
  __device__ void triangles_begin() {}
  __device__ void triangles_end() {}
  __device__ void report(ProfileDev*, int) const {}
};

#endif

}  // namespace
}  // namespace ebh
