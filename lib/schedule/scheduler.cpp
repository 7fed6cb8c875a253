#include "schedule/scheduler.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <mutex>
#include <thread>
#include <utility>

#include "core/error.hpp"
#include "solver/shared_loops.hpp"
#if EBH_HAVE_CUDA
#include "schedule/haptic_cuda.hpp"
#endif

namespace ebh {

ThreadSplit split_threads(Mode mode, int haptic) {
  const int total = std::max(1, omp_get_max_threads());
  if (mode == Mode::Lockstep) return {total, total};
  ThreadSplit s;
  s.haptic = std::clamp(haptic > 0 ? haptic : (total + 1) / 2, 1, std::max(1, total - 1));
  s.physical = std::max(1, total - s.haptic);
  // A core for each side: a side with one thread shares its loops with the other's while that one
  // would wait (async only: realtime's physical thread never waits for the ticks' results).
  const bool cores = mode == Mode::Async && s.haptic + s.physical <= total;
  s.shared_physical_loops = cores && s.physical == 1;
  s.shared_virtual_loops = cores && s.haptic == 1;
  return s;
}

namespace {

using Clock = std::chrono::steady_clock;

/// Restores the calling thread's OpenMP thread count when a replay ends.
struct ThreadCountGuard {
  int saved = omp_get_max_threads();
  explicit ThreadCountGuard(int n) { omp_set_num_threads(n); }
  ~ThreadCountGuard() { omp_set_num_threads(saved); }
};

/// One thread that runs the physical step beside the haptic ticks (async mode), created once per
/// replay: a step starts with start() and is collected with wait(); nothing allocates per step, and
/// the thread's OpenMP team is made once (a new thread per step would make a new team each time).
/// `share_step`: the step runs on this thread alone and wait() helps with its loops (SharedLoops)
/// instead of sleeping, so that the waiting haptic thread's core works on the step. `tick_loops`
/// (the haptic side's, VirtualWorkspace::shared): between steps this thread helps with them.
class PhysicalWorker {
 public:
  PhysicalWorker(const World& world, PhysicalSide& physical, const HapticSnapshot& input, int threads,
                 bool share_step, SharedLoops* tick_loops, std::function<bool()> cancel)
      : shared_(share_step ? std::make_unique<SharedLoops>() : nullptr),
        thread_([this, &world, &physical, &input, threads, tick_loops, cancel = std::move(cancel)] {
          omp_set_num_threads(threads);
          std::unique_lock<std::mutex> lock(mx_);
          while (true) {
            if (tick_loops) {  // until start() or the end
              lock.unlock();
              tick_loops->help_until([this] {
                return running_.load(std::memory_order_acquire) || quitting_.load(std::memory_order_acquire);
              });
              lock.lock();
            }
            cv_.wait(lock, [this] { return pending_ || quit_; });
            if (quit_) return;
            lock.unlock();
            std::exception_ptr error;
            try {
              run_physical_step(world, physical, input, shared_.get(), cancel);
            } catch (...) {
              error = std::current_exception();  // handed to the haptic thread by wait()
            }
            lock.lock();
            error_ = error;
            pending_ = false;
            busy_ = false;
            running_.store(false, std::memory_order_release);
            cv_.notify_all();
          }
        }) {}
  ~PhysicalWorker() {
    {
      std::lock_guard<std::mutex> lock(mx_);
      quit_ = true;
      quitting_.store(true, std::memory_order_release);
    }
    cv_.notify_all();
    thread_.join();
  }
  void start() {
    std::lock_guard<std::mutex> lock(mx_);
    pending_ = busy_ = true;
    running_.store(true, std::memory_order_relaxed);
    cv_.notify_all();
  }
  void wait() {
    if (shared_) shared_->help_until([this] { return !running_.load(std::memory_order_acquire); });
    std::unique_lock<std::mutex> lock(mx_);
    cv_.wait(lock, [this] { return !busy_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

 private:
  std::mutex mx_;
  std::condition_variable cv_;
  bool pending_ = false, busy_ = false, quit_ = false;
  std::atomic<bool> running_{false}, quitting_{false};  // busy_ and quit_, for the helping loops
  std::exception_ptr error_;
  std::unique_ptr<SharedLoops> shared_;
  std::thread thread_;  // last: starts after the flags exist
};

/// Whether a physical result becomes visible to the haptic side at tick n (N ticks per step): in
/// async step k's at tick (k+1)N, in lockstep step k's at tick kN (scheduler.hpp).
bool physical_result_arrives(Mode mode, std::int64_t n, int N) {
  return n % N == 0 && (mode == Mode::Lockstep || n > 0);
}

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

#if EBH_HAVE_CUDA
/// Whether a virtual-time replay runs its haptic ticks on the device (schedule/haptic_cuda.hpp):
/// --backend cuda, a tool the device tick supports, and ReplayOptions::device_tick.
bool device_ticks(const World& world, const ReplayOptions& opt) {
  return world.backend == Backend::Cuda && device_haptic_supported(world.tool) && opt.device_tick;
}

/// Whether an async device replay runs its physical steps inside launches of many periods
/// (CudaHapticTicks::run_ticks_with_steps; ReplayOptions::steps_in_launches).
bool steps_in_launches(const ReplayOptions& opt) {
  return opt.mode == Mode::Async && opt.frames_hz <= 0 && opt.steps_in_launches;
}

/// async and lockstep with the whole tick on the device. The host enqueues runs of ticks and
/// collects each run's outputs two runs later; the observer sees the same calls as on the host
/// path, except that timing.total is the wall time of a run divided by its ticks (the stages are
/// not timed one by one) and on_step comes once the step has been waited for. async without mesh
/// frames: runs of whole periods, ~100 ticks, with the physical steps inside them
/// (launch_next); otherwise runs up to the next physical step, which runs between them
/// (run_steps_between_launches; one tick per run where frames are written).
class DeviceReplay {
 public:
  DeviceReplay(const World& world, const Recording& rec, const ReplayOptions& opt, ReplayObserver& obs)
      : world_(world), rec_(rec), opt_(opt), obs_(obs), N_(world.ticks_per_step),
        ticks_(tick_count(world, recording_duration(rec, opt))),
        in_(inputs(world, rec, opt, ticks_)),
        physical_(make_physical_side(world, steps_in_launches(opt))), device_(in_.setup, in_.ticks, *physical_.cuda),
        frames_{opt.frames_hz > 0 ? 1.0 / opt.frames_hz : 0.0} {
    view_.mesh.q = world.initial_virtual;
    view_.visible.x = world.initial_physical.x;
    view_.tool.pose = in_.setup.pose0;
    physical_.beside_ticks = opt.mode == Mode::Async;
  }

  ReplaySummary run() {
    start();
    if (steps_in_launches(opt_)) {
      while (launch_next()) {
      }
    } else {
      run_steps_between_launches();
    }
    return finish();
  }

  /// The replay run one launch at a time (replay_batch interleaves
  /// replays): start(), then launch_next() until it returns false, then finish().
  void start() { wall0_ = last_collect_ = Clock::now(); }
  ReplaySummary finish() {
    s_.virtual_s = replayed_seconds(s_.ticks, world_.h_haptic);
    s_.wall_s = std::chrono::duration<double>(Clock::now() - wall0_).count();
    return s_;
  }

  /// async without mesh frames: enqueues the next launch of whole periods with the physical steps
  /// inside it; step k (from tick kN) is finished once a collected run reaches (k + 1)N. A launch
  /// and its first (unpipelined) step have a fixed cost, which ~100 ticks per launch spread. The
  /// runs two launches back are collected. Returns false, after collecting everything, once the
  /// last tick is enqueued or the observer stopped the replay.
  bool launch_next() {
    const int periods = std::max(1, std::min((100 + N_ - 1) / N_, device_.step_capacity() / 4));
    const int run = std::max(1, std::min(periods * N_, device_.capacity() / 4));
    if (next_ < ticks_) {
      const int count = static_cast<int>(std::min<std::int64_t>(run, ticks_ - next_));
      const std::int64_t steps_after = (next_ + count + N_ - 1) / N_;
      while (steps_after - s_.steps > device_.step_capacity()) finish_steps_to((s_.steps + 1) * N_);
      enqueue(device_.run_ticks_with_steps(count), next_, count);
      next_ += count;
      while (runs_.size() > 2) {
        const std::int64_t end = runs_.front().first + runs_.front().count;
        collect(runs_.size() - 1);
        finish_steps_to(end);
      }
      if (!stopped() && next_ < ticks_) return true;
    }
    collect(0);
    finish_steps_to(std::numeric_limits<std::int64_t>::max());  // the last step's result is recorded, never shown
    return false;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static DeviceReplayInputs inputs(const World& world, const Recording& rec, const ReplayOptions& opt,
                                   std::int64_t ticks) {
    DeviceReplayInputs in = device_replay_inputs(world, rec, rec.start_time() + opt.start, ticks, opt.mode);
    in.setup.max_blocks = opt.device_blocks;
    if (opt.device_blocks > 0) in.setup.blocks_per_sm = device_tick_capacity(world.tool).blocks_per_sm_shared;
    return in;
  }
  struct Run {
    int handle;
    std::int64_t first;
    int count;
  };

  /// Otherwise: runs up to the next physical step, which runs between the launches (async: it
  /// starts at tick kN and is delivered at (k + 1)N; lockstep: delivered at once).
  void run_steps_between_launches() {
    bool in_flight = false;
    double in_flight_t = 0;
    const int max_run = std::max(1, std::min(N_, device_.capacity() / 4));
    for (std::int64_t n = 0; n < ticks_;) {
      const double t = static_cast<double>(n) * world_.h_haptic;
      if (n % N_ == 0) {
        if (opt_.mode == Mode::Async) {
          if (physical_result_arrives(opt_.mode, n, N_)) {
            device_.deliver_physical_step();
            finish_physical_step(in_flight_t);
          }
          device_.start_physical_step();
          in_flight = true;
          in_flight_t = t;
        } else {  // lockstep
          device_.start_physical_step();
          device_.deliver_physical_step();
          finish_physical_step(t);
        }
      }
      int count = static_cast<int>(std::min<std::int64_t>(N_ - n % N_, ticks_ - n));
      count = frames_.period > 0 ? 1 : std::min(count, max_run);
      enqueue(device_.run_ticks(count), n, count);
      n += count;
      collect(2);
      if (frames_.period > 0 && frames_.due(t, world_.h_haptic)) write_frame(t);
      if (stopped()) break;
    }
    if (in_flight) finish_physical_step(in_flight_t);  // the last step's result is recorded, never shown
    collect(0);
  }

  void enqueue(int handle, std::int64_t first, int count) {
    runs_.push_back({handle, first, count});
    s_.ticks += count;
  }

  /// Waits for the oldest runs until `keep` are left and shows their ticks to the observer.
  void collect(std::size_t keep) {
    while (runs_.size() > keep) {
      const Run r = runs_.front();
      runs_.pop_front();
      rows_.resize(static_cast<std::size_t>(r.count));
      device_.collect(r.handle, rows_);
      const auto now = Clock::now();
      const double per_tick = std::chrono::duration<double>(now - last_collect_).count() / r.count;
      last_collect_ = now;
      for (int k = 0; k < r.count; ++k) show_tick(r.first + k, rows_[static_cast<std::size_t>(k)], per_tick);
    }
  }

  /// Tick n's outputs into the observer's view (HapticSide's outputs), checked and shown.
  void show_tick(std::int64_t n, const DeviceTickOutput& o, double per_tick) {
    view_.device = in_.samples[static_cast<std::size_t>(n)];
    view_.output.force = o.force;
    view_.output.torque = o.torque;
    view_.output.force_clamped = o.force_clamped != 0;
    view_.output.torque_clamped = o.torque_clamped != 0;
    check_haptic_tick(world_, n, view_.output, rec_, view_.device);
    view_.tool.pose = {o.position, o.orientation};
    view_.tool.steps_taken = o.newton_steps;
    view_.tool.steps_rejected = o.newton_rejected;
    view_.grasped = o.grasped;
    view_.penetration = o.penetration;
    view_.penetration_physical = o.penetration_physical;
    view_.contact_count = o.contacts;
    view_.active_vertices = o.active;
    view_.timing = HapticTiming{};
    view_.timing.total = per_tick;
    view_.tick = n + 1;
    obs_.on_tick(world_, view_, static_cast<double>(n) * world_.h_haptic);
  }

  /// Finishes the steps of launch_next that started before tick - N (in order).
  void finish_steps_to(std::int64_t tick) {
    while (device_.steps_in_flight() > 0 && (s_.steps + 1) * N_ <= tick) {
      physical_.report = device_.finish_step(physical_.mesh.x);
      physical_.slept = physical_.report.slept;
      record_step(static_cast<double>(s_.steps * N_) * world_.h_haptic);
    }
  }

  /// Waits for the step run_steps_between_launches started at virtual time t.
  void finish_physical_step(double t) {
    physical_.report = device_.finish_physical_step(physical_.mesh.x);
    physical_.slept = physical_.report.slept;
    record_step(t);
  }

  /// physical_.report and physical_.mesh.x hold the next step's results: checked and shown.
  void record_step(double t) {
    ++physical_.step;
    check_physical_step(world_, physical_);
    obs_.on_step(world_, physical_, t);
    ++s_.steps;
  }

  void write_frame(double t) {
    collect(0);
    device_.snapshot(view_.mesh.q, view_.visible.x);
    obs_.on_frame(world_, view_, t);
  }

  bool stopped() {
    if (obs_.should_stop()) s_.stopped = true;
    return s_.stopped;
  }

  const World& world_;
  const Recording& rec_;  ///< the samples' source, named by a tick's health check
  const ReplayOptions& opt_;
  ReplayObserver& obs_;
  const int N_;
  const std::int64_t ticks_;
  const DeviceReplayInputs in_;
  PhysicalSide physical_;
  CudaHapticTicks device_;
  FrameClock frames_;
  HapticSide view_;  ///< what the observer reads: the outputs of one tick
  std::deque<Run> runs_;
  std::int64_t next_ = 0;  ///< the next tick to enqueue (launch_next)
  std::vector<DeviceTickOutput> rows_;
  ReplaySummary s_;
  Clock::time_point wall0_, last_collect_;
};

ReplaySummary replay_device(const World& world, const Recording& rec, const ReplayOptions& opt, ReplayObserver& obs) {
  return DeviceReplay(world, rec, opt, obs).run();
}
#endif

/// async and lockstep: a pure function of (world, recording, options).
ReplaySummary replay_virtual_time(const World& world, const Recording& rec, const ReplayOptions& opt,
                                  ReplayObserver& obs) {
  const double t0 = rec.start_time() + opt.start;
  const std::int64_t ticks = tick_count(world, recording_duration(rec, opt));
  const int N = world.ticks_per_step;
  const ThreadSplit threads = split_threads(opt.mode, opt.haptic_threads);
  // A side with one thread shares its loops with the other side's thread while that one would wait
  // (ThreadSplit; PhysicalWorker; the 2-core machine: both sides), on the CPU backend.
  const bool cpu = world.backend == Backend::Cpu;
  const bool share_step = cpu && threads.shared_physical_loops;
  std::optional<SharedLoops> tick_loops;
  if (cpu && threads.shared_virtual_loops) tick_loops.emplace();
  const ThreadCountGuard haptic_threads(threads.haptic);
  HapticSide haptic = make_haptic_side(world, sample_at(rec, t0));
  if (tick_loops) haptic.workspace.shared = &*tick_loops;
  PhysicalSide physical = make_physical_side(world);
  physical.beside_ticks = opt.mode == Mode::Async;
  HapticSnapshot to_physical;
  PhysicalSnapshot to_haptic;
  // async: physical step k runs on the worker beside ticks kN .. (k+1)N - 1
  std::optional<PhysicalWorker> worker;
  // A run stopped (interrupted) while a long step runs stops the step too: its result is no one's.
  const std::function<bool()> stop = [&obs] { return obs.should_stop(); };
  if (opt.mode == Mode::Async)
    worker.emplace(world, physical, to_physical, threads.physical, share_step, tick_loops ? &*tick_loops : nullptr,
                   stop);
  bool in_flight = false;
  double in_flight_t = 0;
  FrameClock frames{opt.frames_hz > 0 ? 1.0 / opt.frames_hz : 0.0};

  ReplaySummary s;
  const auto wall0 = Clock::now();
  auto finish_step = [&] {  // false: the step was stopped with the run (no result)
    worker->wait();
    in_flight = false;
    if (physical.report.cancelled) return false;
    take_physical_snapshot(physical, to_haptic);
    obs.on_step(world, physical, in_flight_t);
    ++s.steps;
    return true;
  };
  for (std::int64_t n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * world.h_haptic;
    if (n % N == 0) {
      if (opt.mode == Mode::Async) {
        if (physical_result_arrives(opt.mode, n, N)) {  // the step started at tick n - N
          if (!finish_step()) {
            s.stopped = true;
            break;
          }
          deliver_physical_snapshot(world, haptic, to_haptic);
        }
        take_haptic_snapshot(haptic, to_physical);
        in_flight_t = t;
        in_flight = true;
        worker->start();
      } else {  // lockstep
        take_haptic_snapshot(haptic, to_physical);
        run_physical_step(world, physical, to_physical, nullptr, stop);
        if (physical.report.cancelled) {
          s.stopped = true;
          break;
        }
        take_physical_snapshot(physical, to_haptic);
        deliver_physical_snapshot(world, haptic, to_haptic);
        obs.on_step(world, physical, t);
        ++s.steps;
      }
    }
    haptic_tick(world, haptic, sample_at(rec, t0 + t));
    check_haptic_tick(world, n, haptic.output, rec, haptic.device);
    obs.on_tick(world, haptic, t);
    ++s.ticks;
    if (frames.due(t, world.h_haptic)) obs.on_frame(world, haptic, t);
    if (obs.should_stop()) {
      s.stopped = true;
      break;
    }
  }
  if (in_flight) finish_step();  // the last step's result is recorded, never shown
  s.virtual_s = replayed_seconds(s.ticks, world.h_haptic);
  s.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  return s;
}

/// realtime: two threads paced by the wall clock; double-buffered snapshots under a mutex.
ReplaySummary replay_realtime(const World& world, const Recording& rec, const ReplayOptions& opt,
                              ReplayObserver& obs) {
  const double t0 = rec.start_time() + opt.start;
  const std::int64_t ticks = tick_count(world, recording_duration(rec, opt));
  HapticSide haptic = make_haptic_side(world, sample_at(rec, t0));
  PhysicalSide physical = make_physical_side(world);

  std::mutex mx;                      // guards the two published snapshots and their flags
  HapticSnapshot published_q;         // haptic -> physical
  double published_t = 0;             // the virtual time of the tick that published it
  PhysicalSnapshot published_x;       // physical -> haptic
  bool fresh_x = false;
  std::atomic<bool> done{false};
  take_haptic_snapshot(haptic, published_q);
  const ThreadSplit threads = split_threads(Mode::Realtime, opt.haptic_threads);
  const ThreadCountGuard haptic_threads(threads.haptic);

  ReplaySummary s;
  const auto wall0 = Clock::now();
  auto now_s = [&] { return std::chrono::duration<double>(Clock::now() - wall0).count(); };

  std::exception_ptr solver_error;  // a health check's NumericalError, rethrown after the join
  std::thread solver([&] {
    omp_set_num_threads(threads.physical);
    HapticSnapshot local_q;
    PhysicalSnapshot local_x;
    while (!done.load()) try {
      const double t_start = now_s();
      double t_virtual = 0;  // /physical/t: the virtual time of the ticks it ran on, not the wall clock's
      {
        std::lock_guard<std::mutex> lock(mx);
        local_q.q = published_q.q;
        t_virtual = published_t;
      }
      run_physical_step(world, physical, local_q, nullptr, [&done] { return done.load(); });  // the end stops it
      if (physical.report.cancelled) break;
      take_physical_snapshot(physical, local_x);
      {
        std::lock_guard<std::mutex> lock(mx);
        std::swap(published_x, local_x);
        fresh_x = true;
        obs.on_step(world, physical, t_virtual);
        ++s.steps;
      }
      // Pace: at most one physical step per h_p of wall time (unless unpaced).
      const double next = opt.pace_physical ? t_start + world.h_physical : t_start;
      while (!done.load() && now_s() < next) std::this_thread::sleep_for(std::chrono::microseconds(200));
    } catch (...) {
      solver_error = std::current_exception();
      done.store(true);
    }
  });
  // An error on this thread (a tick's health check, an observer's full disk) stops the solver and
  // joins it before it propagates: a joinable thread's destructor would terminate the process.
  struct StopAndJoin {
    std::atomic<bool>& done;
    std::thread& solver;
    ~StopAndJoin() {
      done.store(true);
      if (solver.joinable()) solver.join();
    }
  } stop_and_join{done, solver};

  FrameClock frames{opt.frames_hz > 0 ? 1.0 / opt.frames_hz : 0.0};
  PhysicalSnapshot incoming;
  for (std::int64_t n = 0; n < ticks && !done.load(); ++n) {  // done early: the solver failed
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
    check_haptic_tick(world, n, haptic.output, rec, haptic.device);
    {
      std::lock_guard<std::mutex> lock(mx);
      take_haptic_snapshot(haptic, published_q);
      published_t = t;
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
  if (solver_error) std::rethrow_exception(solver_error);
  s.virtual_s = replayed_seconds(s.ticks, world.h_haptic);
  s.wall_s = now_s();
  return s;
}

}  // namespace

#if EBH_HAVE_CUDA
/// What the device ticks need to know before they run: the device samples, the E_svc blend of each
/// tick (simulation.cpp: physical_targets) and the grasp events (grasp.cpp: update_grasp).
DeviceReplayInputs device_replay_inputs(const World& world, const Recording& rec, double t0, std::int64_t ticks,
                                        Mode mode) {
  DeviceReplayInputs out;
  std::vector<Collider<double>>& grasp_boxes = out.setup.grasp_boxes;
  const int N = world.ticks_per_step;
  const bool grasping = world.scene.spec.stages.grasp && world.tool.has_jaws;
  std::vector<DeviceTickInput>& in = out.ticks;
  in.resize(static_cast<std::size_t>(ticks));
  out.samples.resize(static_cast<std::size_t>(ticks));
  std::int64_t delivered = -1;  // the tick the visible physical result arrived at
  bool closed = false;
  for (std::int64_t n = 0; n < ticks; ++n) {
    const DeviceSample& s = out.samples[static_cast<std::size_t>(n)] = sample_at(rec, t0 + static_cast<double>(n) * world.h_haptic);
    DeviceTickInput& d = in[static_cast<std::size_t>(n)];
    d.position = s.position;
    d.orientation = s.orientation;
    d.jaw = s.jaw;
    const JawOpening jaws = jaw_opening(world.tool, s.jaw);
    d.jaw_cos = jaws.cos;
    d.jaw_sin = jaws.sin;
    if (physical_result_arrives(mode, n, N)) delivered = n;
    if (world.scene.spec.interpolate_physical && delivered >= 0) d.alpha = physical_blend(n, delivered, N);
    if (grasping && jaws_closed(world.tool, s.jaw, closed) != closed) {
      closed = !closed;
      if (closed) {
        grasp_boxes.push_back(grasp_hard_box(world.tool, s.jaw));
        d.grasp = static_cast<int>(grasp_boxes.size());
      } else {
        d.grasp = -1;
      }
    }
  }
  DeviceHapticSetup& setup = out.setup;
  setup.mesh = &world.virtual_mesh;
  setup.tool = &world.tool;
  setup.k = world.scene.spec.stiffness;
  setup.h = world.h_haptic;
  setup.virtual_iterations = world.scene.spec.solver.virtual_iterations;
  setup.newton_calls = world.scene.spec.tool.newton_calls;  // 0 (all): after every step
  setup.q0 = world.initial_virtual;
  setup.x0 = world.initial_physical.x;
  setup.pose0 = {in.front().position, in.front().orientation};
  setup.ticks_per_step = mode == Mode::Async ? N : 0;  // run_ticks_with_steps: async's delivery
  setup.active_region = world.scene.spec.solver.active_region;
  setup.region_check_ticks = N;  // each sleeping chunk's strain check once a physical period
  setup.physical_rest = world.physical_mesh.rest;
  setup.physical_tets = world.physical_mesh.tets;
  return out;
}
#endif

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
  const double n = std::floor(duration / world.h_haptic + 1e-9) + 1;
  if (!(n >= 1 && n <= kMaxReplayTicks))
    throw InputError("a replay of " + std::to_string(duration) + " s makes more than " +
                     std::to_string(static_cast<long long>(kMaxReplayTicks)) + " ticks (the limit)");
  return static_cast<std::int64_t>(n);
}

#if EBH_HAVE_CUDA
namespace {
/// The tick blocks each of `count` replays of `world` gets when they share the device
/// (DeviceTickCapacity::shared_blocks: the multiprocessors for the physical steps left free).
int batch_share(const World& world, int count) {
  return device_tick_capacity(world.tool).shared_blocks() / std::max(count, 1);
}
}  // namespace

int max_batch_replays(const World& world) {
  if (world.backend != Backend::Cuda || !device_haptic_supported(world.tool)) return 0;
  return std::max(0, batch_share(world, 1) / 2);
}

std::vector<BatchOutcome> replay_batch(std::span<const BatchReplay> replays, int at_once) {
  const int count = static_cast<int>(replays.size());
  if (at_once < 1) throw InputError("a batch runs at least 1 replay at once (got " + std::to_string(at_once) + ")");
  const int running_at_once = std::min(count, at_once);
  int share = std::numeric_limits<int>::max();
  for (int i = 0; i < count; ++i) {
    const BatchReplay& r = replays[static_cast<std::size_t>(i)];
    const std::string which = "replay " + std::to_string(i) + " of the batch: ";
    if (!r.world || !r.recording || !r.observer) throw std::invalid_argument(which + "no world, recording or observer");
    if (r.recording->t.empty()) throw InputError(which + "the recording has no samples");
    if (!device_ticks(*r.world, r.options) || !steps_in_launches(r.options))
      throw InputError(which + "a batch runs --backend cuda in async mode with the device tick and no mesh frames");
    share = std::min(share, batch_share(*r.world, running_at_once));
  }
  if (count > 0 && share < 2)
    throw InputError("a batch of " + std::to_string(running_at_once) + " replays at once: this device runs at most " +
                     std::to_string(max_batch_replays(*replays[0].world)) + " of this scene at once");
  std::vector<BatchOutcome> out(static_cast<std::size_t>(count));
  std::vector<std::unique_ptr<DeviceReplay>> running(static_cast<std::size_t>(count));
  std::vector<ReplayOptions> options(static_cast<std::size_t>(count));
  // One replay's failure is its own: it is written down and the others go on.
  auto attempt = [&](int i, auto&& what) {
    auto& r = running[static_cast<std::size_t>(i)];
    try {
      return what();
    } catch (const std::exception& e) {
      out[static_cast<std::size_t>(i)].error = e.what();
      r.reset();  // waits for what it enqueued (every enqueued step's ticks are enqueued too)
      return false;
    }
  };
  // Every replay is made before any runs (their inputs, the physical step's graphs, the uploads:
  // ~50 ms each on the h100's host), on one thread per core; each writes only its own entries.
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < count; ++i) {
    const BatchReplay& r = replays[static_cast<std::size_t>(i)];
    options[static_cast<std::size_t>(i)] = r.options;
    options[static_cast<std::size_t>(i)].device_blocks = share;
    attempt(i, [&] {
      running[static_cast<std::size_t>(i)] =
          std::make_unique<DeviceReplay>(*r.world, *r.recording, options[static_cast<std::size_t>(i)], *r.observer);
      return true;
    });
  }
  // Then at most at_once run side by side, the next starting when one ends.
  int started = 0;
  auto unfinished = [&] { return std::any_of(running.begin(), running.end(), [](const auto& r) { return r != nullptr; }); };
  while (unfinished()) {
    int active = 0;
    for (int i = 0; i < count; ++i) {
      auto& r = running[static_cast<std::size_t>(i)];
      if (!r) continue;
      if (i >= started) {
        if (active >= running_at_once) break;
        r->start();
        started = i + 1;
      }
      ++active;
      if (!attempt(i, [&] { return r->launch_next(); }) && r) {
        out[static_cast<std::size_t>(i)].summary = r->finish();
        r.reset();
      }
    }
  }
  return out;
}
#else
int max_batch_replays(const World&) { return 0; }

std::vector<BatchOutcome> replay_batch(std::span<const BatchReplay> replays, int) {
  if (replays.empty()) return {};
  throw InputError("a batch of replays runs on the CUDA backend, which this build does not have");
}
#endif

ReplaySummary replay(const World& world, const Recording& recording, const ReplayOptions& options,
                     ReplayObserver& observer) {
  if (recording.t.empty()) throw InputError("recording has no samples");
  if (options.mode == Mode::Realtime) return replay_realtime(world, recording, options, observer);
#if EBH_HAVE_CUDA
  if (device_ticks(world, options)) return replay_device(world, recording, options, observer);
#endif
  return replay_virtual_time(world, recording, options, observer);
}

}  // namespace ebh
