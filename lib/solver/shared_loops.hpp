#pragma once
// Loops a waiting thread may join. In an async replay on two cores (one thread a side) the
// haptic thread waits for each physical step it needs, and the physical thread for the next
// step's start; while one waits, it takes chunks of the other's loops (docs/MODEL.md,
// "Implementation and speed"). Every chunk writes only its own outputs and reads nothing another
// chunk of the same loop writes, so who runs a chunk changes no bit of the result.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <type_traits>

namespace ebh {

class SharedLoops {
 public:
  /// The loop's body over [begin, end).
  using ChunkFn = void (*)(void* body, int begin, int end);

  /// Runs body(begin, end) over [0, n) in chunks of `chunk` elements: the calling thread (the one
  /// owner of this object's loops) runs chunks until none is left, then waits for the chunks a
  /// helper took. Returns when every chunk is done; their writes are then visible to the owner.
  /// The body must not throw (the solvers' loops are arithmetic on preallocated arrays): a chunk
  /// that threw would leave the loop open.
  template <class Body>
  void run(int n, int chunk, Body&& body) {
    using B = std::remove_reference_t<Body>;
    run_chunks(n, chunk, [](void* b, int begin, int end) { (*static_cast<B*>(b))(begin, end); },
               const_cast<void*>(static_cast<const void*>(&body)));
  }
  void run_chunks(int n, int chunk, ChunkFn fn, void* body);

  /// Called by a helping thread: runs chunks of the owner's loops until `stop()` is true, then
  /// returns (stop is polled between chunks and while no loop is open).
  template <class Stop>
  void help_until(Stop&& stop) {
    for (unsigned spins = 0; !stop();)
      if (!help_once()) pause(spins);
  }
  /// Runs chunks of the loop open now, if any; whether it ran one.
  bool help_once();

  /// Chunks the helper ran (a statistic: tests check that it took part).
  std::uint64_t helped_chunks() const { return helped_.load(std::memory_order_relaxed); }

  /// For tests of a helper's part: the owner leaves the first chunk of every loop to a helper and
  /// waits until one has claimed it, so both threads run chunks of every loop however the threads
  /// are scheduled. Set only while a thread is in help_until: without a helper no loop ends.
  void leave_first_chunk_to_helper(bool on) { leave_first_ = on; }

 private:
  static void pause(unsigned& spins);

  // The open loop: written by the owner while no loop is open and no helper is inside, published
  // by an odd `generation_` (release), closed by the next even one.
  ChunkFn fn_ = nullptr;
  void* body_ = nullptr;
  int n_ = 0, chunk_ = 1, chunks_ = 0;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> next_{0};    // the next chunk to claim
  std::atomic<int> inside_{0};  // helpers from their check of the generation to their last chunk's end
  std::atomic<std::uint64_t> helped_{0};
  bool leave_first_ = false;
};

/// Elements per chunk of the solvers' shared loops: a few microseconds of work each.
constexpr int kVertexChunk = 256;    ///< vertices (a gather and an update each)
constexpr int kTetBlockChunk = 32;   ///< SIMD blocks of tets (local_kernels.hpp, kTetLanes each)
constexpr int kEdgeBlockChunk = 64;  ///< SIMD blocks of edges (kEdgeLanes each)

/// body(begin, end) over [0, n): with `shared`, as its chunks of `chunk` elements (SharedLoops::run);
/// without, an orphaned `omp for schedule(static)` over the elements one at a time (inside a
/// parallel region the team shares them, outside one the calling thread runs them all).
template <class Body>
void for_chunks(SharedLoops* shared, int n, int chunk, Body&& body) {
  if (shared) {
    shared->run(n, chunk, body);
    return;
  }
#pragma omp for schedule(static)
  for (int a = 0; a < n; ++a) body(a, a + 1);
}

}  // namespace ebh
