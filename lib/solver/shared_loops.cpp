#include "solver/shared_loops.hpp"

#include <thread>

namespace ebh {

void SharedLoops::pause(unsigned& spins) {
  // Mostly the CPU's spin-wait hint; now and then the rest of the time slice, in case the thread
  // waited for shares this core.
  if ((++spins & 63u) == 0) {
    std::this_thread::yield();
    return;
  }
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

void SharedLoops::run_chunks(int n, int chunk, ChunkFn fn, void* body) {
  if (n <= 0) return;
  chunk = std::max(chunk, 1);
  const int chunks = (n - 1) / chunk + 1;
  fn_ = fn;
  body_ = body;
  n_ = n;
  chunk_ = chunk;
  chunks_ = chunks;
  next_.store(0, std::memory_order_relaxed);
  const std::uint64_t g = generation_.load(std::memory_order_relaxed) + 1;  // odd: open
  generation_.store(g, std::memory_order_seq_cst);
  if (leave_first_)
    for (unsigned spins = 0; next_.load(std::memory_order_relaxed) == 0;) pause(spins);
  for (int c; (c = next_.fetch_add(1, std::memory_order_relaxed)) < chunks;)
    fn(body, c * chunk, std::min(n, (c + 1) * chunk));
  // Every chunk is claimed. Close the loop, then wait for the helper to leave it: it stays inside
  // while it runs the chunks it claimed (at most one chunk's wait, the other thread working on
  // it), and one that saw the loop open but has not claimed yet finds it closed and claims
  // nothing. Its leaving (a release) makes its chunks' writes visible here.
  generation_.store(g + 1, std::memory_order_seq_cst);
  for (unsigned spins = 0; inside_.load(std::memory_order_seq_cst) != 0;) pause(spins);
}

bool SharedLoops::help_once() {
  const std::uint64_t g = generation_.load(std::memory_order_acquire);
  if ((g & 1) == 0) return false;
  inside_.fetch_add(1, std::memory_order_seq_cst);
  int ran = 0;
  // Still the loop seen open: the owner cannot close it and publish another before this helper
  // leaves (it waits for inside_ == 0 after closing), so the fields below are that loop's.
  if (generation_.load(std::memory_order_seq_cst) == g) {
    for (int c; (c = next_.fetch_add(1, std::memory_order_relaxed)) < chunks_; ++ran)
      fn_(body_, c * chunk_, std::min(n_, (c + 1) * chunk_));
  }
  inside_.fetch_sub(1, std::memory_order_seq_cst);
  if (ran > 0) helped_.fetch_add(static_cast<std::uint64_t>(ran), std::memory_order_relaxed);
  return ran > 0;
}

}  // namespace ebh
