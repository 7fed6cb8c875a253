#include "schedule/scheduler.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <chrono>
#include <cmath>
#include <optional>
#include <mutex>
#include <thread>
#include <utility>

#include "io/error.hpp"

namespace ebh {
namespace {

using Clock = std::chrono::steady_clock;

/// OpenMP threads for each side. In lockstep the sides take turns and each may use every core;
/// in async and realtime they run at once, so the haptic side keeps one core and the physical
/// step gets the rest (more threads than cores would leave OpenMP's spinning barriers waiting on
/// descheduled threads). Results do not depend on these counts (bitwise, tests/solver).
struct ThreadSplit {
  int haptic = 1, physical = 1;
};

ThreadSplit split_threads(Mode mode) {
  const int total = std::max(1, omp_get_max_threads());
  if (mode == Mode::Lockstep) return {total, total};
  return {1, std::max(1, total - 1)};
}

/// Restores the calling thread's OpenMP thread count when a replay ends.
struct ThreadCountGuard {
  int saved = omp_get_max_threads();
  explicit ThreadCountGuard(int n) { omp_set_num_threads(n); }
  ~ThreadCountGuard() { omp_set_num_threads(saved); }
};

/// One thread that runs the physical step beside the haptic ticks (async mode), created once per
/// replay: a step starts with start() and is collected with wait(); nothing allocates per step, and
/// the thread's OpenMP team is made once (a new thread per step would make a new team each time).
class PhysicalWorker {
 public:
  PhysicalWorker(const World& world, PhysicalSide& physical, const HapticSnapshot& input, int threads)
      : thread_([this, &world, &physical, &input, threads] {
          omp_set_num_threads(threads);
          std::unique_lock<std::mutex> lock(mx_);
          while (true) {
            cv_.wait(lock, [this] { return pending_ || quit_; });
            if (quit_) return;
            lock.unlock();
            std::exception_ptr error;
            try {
              run_physical_step(world, physical, input);
            } catch (...) {
              error = std::current_exception();  // handed to the haptic thread by wait()
            }
            lock.lock();
            error_ = error;
            pending_ = false;
            busy_ = false;
            cv_.notify_all();
          }
        }) {}
  ~PhysicalWorker() {
    {
      std::lock_guard<std::mutex> lock(mx_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void start() {
    std::lock_guard<std::mutex> lock(mx_);
    pending_ = busy_ = true;
    cv_.notify_all();
  }
  void wait() {
    std::unique_lock<std::mutex> lock(mx_);
    cv_.wait(lock, [this] { return !busy_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

 private:
  std::mutex mx_;
  std::condition_variable cv_;
  bool pending_ = false, busy_ = false, quit_ = false;
  std::exception_ptr error_;
  std::thread thread_;  // last: starts after the flags exist
};

double recording_duration(const Recording& rec, const ReplayOptions& opt) {
  const double rest = std::max(0.0, rec.duration() - opt.start);
  return opt.duration > 0 ? std::min(opt.duration, rest) : rest;
}

/// Frame k is due at k / frames_hz; tick n emits every frame due in (t_{n-1}, t_n].
struct FrameClock {
  double period = 0;
  std::int64_t next = 0;
  bool due(double t, double h) {
    if (period <= 0) return false;
    if (next * period > t + 0.5 * h) return false;
    while (next * period <= t + 0.5 * h) ++next;
    return true;
  }
};

/// async and lockstep: a pure function of (world, recording, options).
ReplaySummary replay_virtual_time(const World& world, const Recording& rec, const ReplayOptions& opt,
                                  ReplayObserver& obs) {
  const double t0 = rec.t.front() + opt.start;
  const std::int64_t ticks = tick_count(world, recording_duration(rec, opt));
  const int N = world.ticks_per_step;
  const ThreadSplit threads = split_threads(opt.mode);
  const ThreadCountGuard haptic_threads(threads.haptic);
  HapticSide haptic = make_haptic_side(world, sample_at(rec, t0));
  PhysicalSide physical = make_physical_side(world);
  HapticSnapshot to_physical;
  PhysicalSnapshot to_haptic;
  // async: physical step k runs on the worker beside ticks kN .. (k+1)N - 1
  std::optional<PhysicalWorker> worker;
  if (opt.mode == Mode::Async) worker.emplace(world, physical, to_physical, threads.physical);
  bool in_flight = false;
  double in_flight_t = 0;
  FrameClock frames{opt.frames_hz > 0 ? 1.0 / opt.frames_hz : 0.0};

  ReplaySummary s;
  const auto wall0 = Clock::now();
  auto finish_step = [&] {
    worker->wait();
    in_flight = false;
    take_physical_snapshot(physical, to_haptic);
    obs.on_step(world, physical, in_flight_t);
    ++s.steps;
  };
  for (std::int64_t n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * world.h_haptic;
    if (n % N == 0) {
      if (opt.mode == Mode::Async) {
        if (in_flight) {
          finish_step();
          deliver_physical_snapshot(world, haptic, to_haptic);
        }
        take_haptic_snapshot(haptic, to_physical);
        in_flight_t = t;
        in_flight = true;
        worker->start();
      } else {  // lockstep
        take_haptic_snapshot(haptic, to_physical);
        run_physical_step(world, physical, to_physical);
        take_physical_snapshot(physical, to_haptic);
        deliver_physical_snapshot(world, haptic, to_haptic);
        obs.on_step(world, physical, t);
        ++s.steps;
      }
    }
    haptic_tick(world, haptic, sample_at(rec, t0 + t));
    obs.on_tick(world, haptic, t);
    ++s.ticks;
    if (frames.due(t, world.h_haptic)) obs.on_frame(world, haptic, t);
    if (obs.should_stop()) {
      s.stopped = true;
      break;
    }
  }
  if (in_flight) finish_step();  // the last step's result is recorded, never shown
  s.virtual_s = static_cast<double>(s.ticks) * world.h_haptic;
  s.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  return s;
}

/// realtime: two threads paced by the wall clock; double-buffered snapshots under a mutex.
ReplaySummary replay_realtime(const World& world, const Recording& rec, const ReplayOptions& opt,
                              ReplayObserver& obs) {
  const double t0 = rec.t.front() + opt.start;
  const std::int64_t ticks = tick_count(world, recording_duration(rec, opt));
  HapticSide haptic = make_haptic_side(world, sample_at(rec, t0));
  PhysicalSide physical = make_physical_side(world);

  std::mutex mx;                      // guards the two published snapshots and their flags
  HapticSnapshot published_q;         // haptic -> physical
  PhysicalSnapshot published_x;       // physical -> haptic
  bool fresh_x = false;
  std::atomic<bool> done{false};
  take_haptic_snapshot(haptic, published_q);
  const ThreadSplit threads = split_threads(Mode::Realtime);
  const ThreadCountGuard haptic_threads(threads.haptic);

  ReplaySummary s;
  const auto wall0 = Clock::now();
  auto now_s = [&] { return std::chrono::duration<double>(Clock::now() - wall0).count(); };

  std::thread solver([&] {
    omp_set_num_threads(threads.physical);
    HapticSnapshot local_q;
    PhysicalSnapshot local_x;
    while (!done.load()) {
      const double t_start = now_s();
      {
        std::lock_guard<std::mutex> lock(mx);
        local_q.q = published_q.q;
      }
      run_physical_step(world, physical, local_q);
      take_physical_snapshot(physical, local_x);
      {
        std::lock_guard<std::mutex> lock(mx);
        std::swap(published_x, local_x);
        fresh_x = true;
        obs.on_step(world, physical, t_start);
        ++s.steps;
      }
      // Pace: at most one physical step per h_p of wall time (unless unpaced).
      const double next = opt.pace_physical ? t_start + world.h_physical : t_start;
      while (!done.load() && now_s() < next) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  });

  FrameClock frames{opt.frames_hz > 0 ? 1.0 / opt.frames_hz : 0.0};
  PhysicalSnapshot incoming;
  for (std::int64_t n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * world.h_haptic;
    while (now_s() < t) std::this_thread::yield();  // tick n starts at wall time t_n
    bool got = false;
    {
      std::lock_guard<std::mutex> lock(mx);
      if (fresh_x) {
        std::swap(incoming, published_x);
        fresh_x = false;
        got = true;
      }
    }
    if (got) deliver_physical_snapshot(world, haptic, incoming);
    haptic_tick(world, haptic, sample_at(rec, t0 + t));
    {
      std::lock_guard<std::mutex> lock(mx);
      take_haptic_snapshot(haptic, published_q);
      obs.on_tick(world, haptic, t);
    }
    ++s.ticks;
    if (frames.due(t, world.h_haptic)) obs.on_frame(world, haptic, t);
    if (obs.should_stop()) {
      s.stopped = true;
      break;
    }
  }
  done.store(true);
  solver.join();
  s.virtual_s = static_cast<double>(s.ticks) * world.h_haptic;
  s.wall_s = now_s();
  return s;
}

}  // namespace

Mode parse_mode(const std::string& s) {
  if (s == "async") return Mode::Async;
  if (s == "lockstep") return Mode::Lockstep;
  if (s == "realtime") return Mode::Realtime;
  throw InputError("--mode: expected async, lockstep or realtime, got '" + s + "'");
}

const char* mode_name(Mode m) {
  switch (m) {
    case Mode::Async: return "async";
    case Mode::Lockstep: return "lockstep";
    case Mode::Realtime: return "realtime";
  }
  return "?";
}

std::int64_t tick_count(const World& world, double duration) {
  return static_cast<std::int64_t>(std::floor(duration / world.h_haptic + 1e-9)) + 1;
}

ReplaySummary replay(const World& world, const Recording& recording, const ReplayOptions& options,
                     ReplayObserver& observer) {
  if (recording.t.empty()) throw InputError("recording has no samples");
  if (options.mode == Mode::Realtime) return replay_realtime(world, recording, options, observer);
  return replay_virtual_time(world, recording, options, observer);
}

}  // namespace ebh
