// SharedLoops: every element of every loop runs exactly once, whichever thread takes its chunk;
// the owner returns only once the helper's chunks are done and their writes visible; a helper
// that arrives between loops, or stops, leaves the owner to finish alone.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "solver/shared_loops.hpp"

namespace ebh {
namespace {

TEST(SharedLoops, EveryElementRunsOnceAndTheOwnerSeesTheHelpersWrites) {
  SharedLoops shared;
  std::atomic<bool> done{false}, started{false};
  std::thread helper([&] {
    shared.help_until([&] {
      started = true;
      return done.load();
    });
  });
  while (!started) std::this_thread::yield();
  const std::thread::id owner = std::this_thread::get_id();
  std::atomic<bool> helper_ran{false};
  std::vector<int> runs;
  std::vector<long long> value;
  for (int loop = 0; loop < 500; ++loop) {
    const int n = 1 + (loop * 37 + 100) % 300, chunk = 1 + loop % 17;  // loop 0: 101 chunks
    runs.assign(n, 0);
    value.assign(n, 0);
    shared.run(n, chunk, [&](int begin, int end) {
      ASSERT_LE(end - begin, chunk);
      if (std::this_thread::get_id() != owner) helper_ran = true;
      // The first loop's first chunk waits (up to 5 s) for the helper to take one: on a loaded
      // machine its thread may not run at once, and the test is of the two together.
      for (int w = 0; loop == 0 && begin == 0 && !helper_ran && w < 5000; ++w)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      for (int a = begin; a < end; ++a) {
        ++runs[a];  // plain writes: only the chunk's own elements
        volatile long long v = 0;  // some work (~1 us), so that the threads' chunks overlap
        for (int k = 0; k < 500; ++k) v = v + a;
        value[a] = v / 500 * loop;
      }
    });
    for (int a = 0; a < n; ++a) {
      ASSERT_EQ(runs[a], 1) << "loop " << loop << " element " << a;
      ASSERT_EQ(value[a], static_cast<long long>(a) * loop);
    }
  }
  done = true;
  helper.join();
  EXPECT_GT(shared.helped_chunks(), 0u);  // it took part (the loops' elements were all checked above)
}

TEST(SharedLoops, TheOwnerWaitsForAChunkTheHelperIsStillRunning) {
  SharedLoops shared;
  std::atomic<bool> done{false}, helper_started{false};
  std::thread helper([&] { shared.help_until([&] { return done.load(); }); });
  std::vector<int> out(64, 0);
  // Chunk 0 is the owner's (it claims first) and lasts until the helper has claimed another; a
  // helper's chunk sleeps too, so the owner may have to wait for it after its own.
  shared.run(64, 1, [&](int begin, int) {
    if (begin != 0) helper_started = true;
    for (int w = 0; begin == 0 && !helper_started && w < 5000; ++w)  // until the helper has one (at most 5 s)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(begin == 0 ? 5 : 1));
    out[begin] = begin + 1;
  });
  for (int a = 0; a < 64; ++a) ASSERT_EQ(out[a], a + 1);
  EXPECT_TRUE(helper_started.load());
  EXPECT_GT(shared.helped_chunks(), 0u);
  done = true;
  helper.join();
}

TEST(SharedLoops, WithoutAHelperTheOwnerRunsEverything) {
  SharedLoops shared;
  int sum = 0;
  shared.run(1000, 7, [&](int begin, int end) {
    for (int a = begin; a < end; ++a) sum += a;
  });
  EXPECT_EQ(sum, 999 * 1000 / 2);
  shared.run(0, 7, [&](int, int) { FAIL() << "an empty loop runs nothing"; });
  EXPECT_FALSE(shared.help_once());  // no loop open
  EXPECT_EQ(shared.helped_chunks(), 0u);
}

}  // namespace
}  // namespace ebh
