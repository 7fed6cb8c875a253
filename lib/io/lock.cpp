#include "io/lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <utility>

#include "core/error.hpp"
#include "io/atomic.hpp"

namespace ebh {

FileLock::FileLock(FileLock&& other) noexcept { *this = std::move(other); }

FileLock& FileLock::operator=(FileLock&& other) noexcept {
  if (this != &other) {
    release();
    path_ = std::move(other.path_);
    error_ = std::move(other.error_);
    fd_ = std::exchange(other.fd_, -1);
    remove_ = other.remove_;
    status_ = std::exchange(other.status_, Status::Unsupported);
  }
  return *this;
}

FileLock::~FileLock() { release(); }

void FileLock::release() noexcept {
  if (fd_ < 0) return;
  // Removed only while it is still the file locked here: no one else removes it then (only a
  // holder does), so this never removes another process's lock file.
  struct stat held {}, now {};
  if (remove_ && status_ == Status::Taken && ::fstat(fd_, &held) == 0 && ::stat(path_.c_str(), &now) == 0 &&
      held.st_dev == now.st_dev && held.st_ino == now.st_ino)
    ::unlink(path_.c_str());
  ::close(fd_);  // releases the lock
  fd_ = -1;
  status_ = Status::Unsupported;
}

FileLock FileLock::take(const std::string& path, bool create, bool wait) {
  for (;;) {
    FileLock l;
    l.path_ = path;
    l.remove_ = create;
    l.fd_ = ::open(path.c_str(), O_RDWR | O_CLOEXEC | (create ? O_CREAT : 0), 0666);
    if (l.fd_ < 0 && !create && (errno == EACCES || errno == EROFS)) l.fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (l.fd_ < 0) {
      const int err = errno;
      throw InputError(path + ": cannot open the lock: " + os_reason(err));
    }
    while (::flock(l.fd_, LOCK_EX | (wait ? 0 : LOCK_NB)) != 0) {
      const int err = errno;
      if (err == EINTR && !interrupted()) continue;
      l.release();
      if (err == EINTR) throw InputError(path + ": interrupted while waiting for its lock");
      l.status_ = err == EWOULDBLOCK ? Status::Busy : Status::Unsupported;
      l.error_ = os_reason(err);
      return l;
    }
    // The file may have been removed or renamed over while this process waited for it: then the
    // lock is on a file no one else will look at; lock the one under the name now.
    struct stat held {}, now {};
    if (::fstat(l.fd_, &held) != 0 || ::stat(path.c_str(), &now) != 0 || held.st_dev != now.st_dev ||
        held.st_ino != now.st_ino) {
      l.remove_ = false;
      continue;  // l's destructor closes it
    }
    l.status_ = Status::Taken;
    if (create) {
      const std::string pid = std::to_string(static_cast<long>(::getpid())) + "\n";
      if (::ftruncate(l.fd_, 0) != 0 || ::pwrite(l.fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
        // the lock holds all the same; only the message of a second process lacks the PID
      }
    }
    return l;
  }
}

long FileLock::holder_pid(const std::string& path) {
  // The holder writes its PID just after taking the lock: a moment to wait for it.
  for (int attempt = 0; attempt < 50; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
      char buf[32] = {};
      const ssize_t n = ::read(fd, buf, sizeof buf - 1);
      ::close(fd);
      char* end = nullptr;
      const long pid = n > 0 ? std::strtol(buf, &end, 10) : 0;
      if (pid > 0) return pid;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return 0;
}

}  // namespace ebh
