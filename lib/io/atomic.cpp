#include "io/atomic.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "io/error.hpp"

namespace ebh {
namespace {

// The signal handler may only touch lock-free atomics and call async-signal-safe functions
// (unlink, _exit), so temporary names live in a fixed table of plain buffers.
constexpr int kSlots = 32;
constexpr std::size_t kPathMax = 4096;
char g_paths[kSlots][kPathMax];
std::atomic<int> g_used[kSlots];  // 0 free, 1 being written, 2 holds a path
volatile std::sig_atomic_t g_interrupted = 0;
std::atomic<bool> g_installed{false};

extern "C" void on_signal(int sig) {
  if (g_interrupted) {
    for (int i = 0; i < kSlots; ++i)
      if (g_used[i].load() == 2) unlink(g_paths[i]);
    _exit(128 + sig);
  }
  g_interrupted = 1;
}

int register_temp(const std::string& path) {
  if (path.size() >= kPathMax) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (g_used[i].compare_exchange_strong(expected, 1)) {
      std::memcpy(g_paths[i], path.c_str(), path.size() + 1);
      g_used[i].store(2);
      return i;
    }
  }
  return -1;  // table full: the file is still removed by the destructor, just not by a 2nd signal
}

void unregister_temp(int slot) {
  if (slot >= 0) g_used[slot].store(0);
}

}  // namespace

void install_interrupt_handlers() {
  if (g_installed.exchange(true)) return;
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool interrupted() { return g_interrupted != 0; }
void set_interrupted(bool value) { g_interrupted = value ? 1 : 0; }

AtomicOutput::AtomicOutput(std::string final_path) : final_(std::move(final_path)) {
  if (final_.empty()) throw InputError("output file name is empty");
  // The output's folder is made when missing (`-o out/run.h5` on a fresh checkout).
  const std::filesystem::path parent = std::filesystem::path(final_).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::exists(parent, ec)) {
    std::filesystem::create_directories(parent, ec);
    if (ec) throw InputError(final_ + ": cannot create the folder " + parent.string() + ": " + ec.message());
  }
  install_interrupt_handlers();
  temp_ = final_ + ".tmp." + std::to_string(static_cast<long>(getpid()));
  std::remove(temp_.c_str());
  slot_ = register_temp(temp_);
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) discard();
  unregister_temp(slot_);
}

void AtomicOutput::discard() {
  if (!committed_) std::remove(temp_.c_str());
}

void AtomicOutput::commit() {
  if (committed_) return;
  if (interrupted()) {
    discard();
    throw InputError(final_ + ": interrupted; nothing written");
  }
  if (access(temp_.c_str(), F_OK) != 0) throw InputError(final_ + ": temporary file " + temp_ + " is missing");
  if (std::rename(temp_.c_str(), final_.c_str()) != 0) {
    int err = errno;
    discard();
    throw InputError(final_ + ": cannot rename the temporary file into place: " + std::strerror(err));
  }
  committed_ = true;
  unregister_temp(slot_);
  slot_ = -1;
}

}  // namespace ebh
