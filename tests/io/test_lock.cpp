// Exclusive file locks (lib/io/lock.hpp): one holder at a time, the holder's PID for messages, a
// lock file of one's own removed on release, and a lock file removed or renamed over while a
// process waited never lets two in.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "io/lock.hpp"
#include "io_test_util.hpp"

using namespace ebh;
namespace fs = std::filesystem;

namespace {

// flock locks belong to an open file, so a second take in the same process is refused as one in
// another process would be.
TEST(FileLock, OneHolderAtATimeAndItsPid) {
  test::ScratchDir tmp;
  const std::string path = tmp / ".lock";
  {
    FileLock first = FileLock::take(path, true, false);
    ASSERT_TRUE(first.held());
    EXPECT_EQ(FileLock::holder_pid(path), static_cast<long>(getpid()));
    const FileLock second = FileLock::take(path, true, false);
    EXPECT_EQ(second.status(), FileLock::Status::Busy);
    EXPECT_TRUE(fs::exists(path)) << "a refused take leaves the holder's file";
  }
  EXPECT_FALSE(fs::exists(path)) << "a lock file of one's own goes with its lock";
  EXPECT_TRUE(FileLock::take(path, true, false).held());
}

// A lock on a data file (create = false) leaves the file as it is; the file renamed over (an
// atomic write) is locked anew under its name, so the next holder reads what the writer wrote.
TEST(FileLock, ADataFileIsLockedUnderItsName) {
  test::ScratchDir tmp;
  const std::string path = tmp / "baselines.yaml";
  std::ofstream(path) << "old\n";
  EXPECT_INPUT_ERROR(FileLock::take(tmp / "missing.yaml", false, false), "missing.yaml: cannot open the lock");
  FileLock held = FileLock::take(path, false, false);
  ASSERT_TRUE(held.held());
  std::ofstream(tmp / "new.yaml") << "new\n";
  fs::rename(tmp / "new.yaml", path);
  // The renamed-over file is another one: free, while the old one is still held.
  const FileLock next = FileLock::take(path, false, false);
  EXPECT_TRUE(next.held());
  held = FileLock();
  EXPECT_TRUE(fs::exists(path)) << "a data file stays";
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "new");
}

}  // namespace
