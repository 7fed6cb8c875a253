#pragma once
// Exclusive locks on files (flock(2)), for work that must not run twice at once on the same files
// (two sweeps into one folder, two updates of one baselines file). A lock is held while its
// FileLock lives and dies with the process however it ends (SIGKILL included), so there is never
// a stale lock to remove by hand.
//
// A lock file may be removed by its holder (FileLock::remove_on_release): whoever then takes the
// lock checks that the name still points at the file it locked, and otherwise locks the file now
// there, so a removed (or renamed-over) lock file never lets two processes in at once.
#include <string>

namespace ebh {

class FileLock {
 public:
  enum class Status {
    Taken,        ///< held by this object
    Busy,         ///< another process holds it (non-blocking take)
    Unsupported,  ///< the file system takes no locks (error(): the reason)
  };
  FileLock() = default;
  FileLock(FileLock&& other) noexcept;
  FileLock& operator=(FileLock&& other) noexcept;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  /// Releases the lock (removing the file first when remove_on_release and it is still the one
  /// locked).
  ~FileLock();

  /// Takes an exclusive lock on `path`. `create`: the file is made when missing, this process's
  /// PID is written into it once taken and it is removed on release (a lock file of one's own);
  /// otherwise it must exist and is left as it is (a lock on a data file). `wait`: blocks until
  /// the lock is free (an interrupt, io/atomic.hpp, ends the wait with InputError); else returns
  /// Busy at once. Throws InputError "PATH: cannot open the lock: reason" when it cannot open it.
  static FileLock take(const std::string& path, bool create, bool wait);

  Status status() const { return status_; }
  bool held() const { return status_ == Status::Taken; }
  /// Unsupported: the operating system's reason.
  const std::string& error() const { return error_; }
  /// The PID written in a lock file of one's own (create), or 0 when it holds none: whom a Busy
  /// lock belongs to.
  static long holder_pid(const std::string& path);

 private:
  void release() noexcept;
  std::string path_, error_;
  int fd_ = -1;
  bool remove_ = false;
  Status status_ = Status::Unsupported;
};

}  // namespace ebh
