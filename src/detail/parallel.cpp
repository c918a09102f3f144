// align3d's thread pool (contract in parallel.hpp). Written by hand, not taken from a library,
// because of one measurement (bench/README.md, "Shared machine"): with OpenMP (GCC's libgomp)
// the threads of a team spin for up to GOMP_SPINCOUNT (300 000) polls between parallel regions,
// and on a machine where another process keeps one core busy the chapter's point-to-plane ICP
// ran 10x slower than on an idle one. libgomp reads OMP_WAIT_POLICY when it loads, before main,
// so a library cannot turn the spinning off for its users. The pool below spins for 50 µs at
// most, then sleeps; it keeps the chunking of the OpenMP loops it replaces, so results are the
// same to the bit. oneTBB (Debian's libtbb-dev; bench/parallel_tbb.cpp) measured about as well:
// the same under load, slower on the chapter scene's short loops, faster on long ones; but
// Debian's build is not instrumented for ThreadSanitizer, which then reports races on race-free
// code. This pool is plain std::thread/atomic/mutex, which TSan sees.
//
// How one call runs (Pool::run): the caller takes the pool (a flag; if it is taken, the call runs
// serially: parallel.hpp), publishes the job, wakes `helpers` workers and works on the job
// itself. Tasks are handed out one at a time from an atomic counter. When no task is left the
// caller closes the job: helpers that had not joined it by then stay out (the caller never waits
// for a thread the scheduler has not run yet), and the caller waits only for the helpers that
// joined to finish their tasks.
#include "detail/parallel.hpp"

#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <utility>

namespace align3d {
namespace {

constexpr int kMaxThreads = 1024;

// How long an idle thread polls before it sleeps. Long enough to bridge the serial steps between
// the loops of one computation (an ICP iteration's median, solve and convergence test take a few
// µs to tens of µs on the chapter scene), short enough that a machine shared with other processes
// loses next to nothing. Waking a sleeping thread costs a system call and, on a VM, 20-100 µs
// before it runs.
constexpr std::chrono::microseconds kSpin{50};

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

// Polls done() for up to kSpin; true as soon as it holds, false if it still does not.
template <class Done>
bool spin_until(Done done) {
  const auto deadline = std::chrono::steady_clock::now() + kSpin;
  for (unsigned i = 1;; ++i) {
    if (done()) return true;
    cpu_relax();
    if (i % 64 == 0 && std::chrono::steady_clock::now() >= deadline) return false;
  }
}

// A counter that threads wait on to change: they poll (spin_until), then sleep on a condition
// variable. bump() takes the mutex only when a thread sleeps. No wake-up is lost: all accesses to
// value_ and sleepers_ are sequentially consistent, so either bump() sees the sleeper, or the
// sleeper, checking under the mutex, sees the new value.
class Signal {
 public:
  std::uint32_t value() const { return value_.load(); }

  void bump() {
    value_.fetch_add(1);
    if (sleepers_.load() > 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      changed_.notify_all();
    }
  }

  // Returns the value once it differs from `seen`.
  std::uint32_t wait_change(std::uint32_t seen) {
    std::uint32_t v = seen;
    if (spin_until([&] { return (v = value()) != seen; })) return v;
    sleepers_.fetch_add(1);
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return (v = value()) != seen; });
    }
    sleepers_.fetch_sub(1);
    return v;
  }

 private:
  std::atomic<std::uint32_t> value_{0};
  std::atomic<int> sleepers_{0};
  std::mutex mutex_;
  std::condition_variable changed_;
};

class Pool {
 public:
  // Runs fn(context, t) for t in [0, count) on the calling thread and up to `helpers` workers.
  // Returns false, having run nothing, when another call owns the pool.
  bool run(std::size_t count, int helpers, detail::TaskFn fn, void* context) {
    if (owned_.exchange(true, std::memory_order_acquire)) return false;
    struct Release {
      std::atomic<bool>& owned;
      ~Release() { owned.store(false, std::memory_order_release); }
    } release{owned_};
    helpers = grow(helpers);
    fn_ = fn;
    context_ = context;
    count_ = count;
    next_.store(0, std::memory_order_relaxed);
    state_.store(kOpen | static_cast<std::uint32_t>(helpers) << kWantedShift,
                 std::memory_order_release);
    for (int i = 0; i < helpers; ++i) workers_[i]->wake.bump();
    work();
    // Close the job, then wait for the helpers that joined it. The last one to leave a closed job
    // bumps done_; `seen` is read before closing, so that bump is not missed.
    std::uint32_t seen = done_.value();
    state_.fetch_and(~kOpen, std::memory_order_acq_rel);
    while (joined(state_.load(std::memory_order_acquire)) != 0) seen = done_.wait_change(seen);
    if (std::exception_ptr error = std::exchange(error_, nullptr)) std::rethrow_exception(error);
    return true;
  }

 private:
  // state_: bit 31 = the job is open; bits 16-30: how many helpers it wants; 0-15: how many
  // joined it and have not left yet.
  static constexpr std::uint32_t kOpen = 1u << 31;
  static constexpr int kWantedShift = 16;
  static std::uint32_t joined(std::uint32_t s) { return s & 0xffffu; }
  static std::uint32_t wanted(std::uint32_t s) { return (s >> kWantedShift) & 0x7fffu; }

  struct Worker {
    Signal wake;  // bumped by the owner of each job this worker is asked to help with
  };

  // Starts workers until there are `helpers` of them (fewer if the system refuses threads);
  // returns how many can help.
  int grow(int helpers) {
    workers_.reserve(static_cast<std::size_t>(helpers));
    while (static_cast<int>(workers_.size()) < helpers) {
      auto worker = std::make_unique<Worker>();
      try {
        std::thread([this, w = worker.get()] { serve(*w); }).detach();
      } catch (const std::system_error&) {
        break;
      }
      workers_.push_back(std::move(worker));
    }
    return std::min(helpers, static_cast<int>(workers_.size()));
  }

  // A worker's life: wait for a wake-up, help with the job if it is still open, repeat.
  void serve(Worker& w) {
    for (std::uint32_t seen = 0;;) {
      seen = w.wake.wait_change(seen);
      help();
    }
  }

  void help() {
    std::uint32_t s = state_.load(std::memory_order_acquire);
    do {
      if (!(s & kOpen) || joined(s) >= wanted(s)) return;
    } while (!state_.compare_exchange_weak(s, s + 1, std::memory_order_acq_rel,
                                           std::memory_order_acquire));
    work();
    s = state_.fetch_sub(1, std::memory_order_acq_rel) - 1;
    if (!(s & kOpen) && joined(s) == 0) done_.bump();
  }

  // Takes tasks until none is left. A task that throws stops the hand-out; the first exception
  // is kept for the owner.
  void work() {
    for (std::size_t t; (t = next_.fetch_add(1, std::memory_order_relaxed)) < count_;) {
      try {
        fn_(context_, t);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex_);
        if (!error_) error_ = std::current_exception();
        next_.store(count_, std::memory_order_relaxed);
      }
    }
  }

  std::atomic<bool> owned_{false};
  std::vector<std::unique_ptr<Worker>> workers_;  // used by the owner only
  // The job: written by the owner before it opens the job, read by the helpers that join it.
  detail::TaskFn fn_ = nullptr;
  void* context_ = nullptr;
  std::size_t count_ = 0;
  alignas(64) std::atomic<std::size_t> next_{0};
  alignas(64) std::atomic<std::uint32_t> state_{0};
  Signal done_;
  std::mutex error_mutex_;
  std::exception_ptr error_;
};

// The process's pool, made on first use and never destroyed (a pool destroyed at exit could
// still be in use by another thread or a static destructor). In a child of fork() the parent's
// workers do not exist: the child forgets the pool (leaks it) and makes its own.
std::atomic<Pool*> g_pool{nullptr};

Pool& pool() {
  if (Pool* p = g_pool.load(std::memory_order_acquire)) return *p;
  static const bool forget_in_child = [] {
    pthread_atfork(nullptr, nullptr, [] { g_pool.store(nullptr, std::memory_order_relaxed); });
    return true;
  }();
  (void)forget_in_child;
  auto fresh = std::make_unique<Pool>();
  Pool* expected = nullptr;
  if (g_pool.compare_exchange_strong(expected, fresh.get(), std::memory_order_acq_rel))
    return *fresh.release();
  return *expected;
}

}  // namespace

int thread_count(int requested) {
  if (requested > 0) return std::min(requested, kMaxThreads);
#ifdef __linux__
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) == 0)
    return std::clamp(CPU_COUNT(&set), 1, kMaxThreads);
#endif
  return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, kMaxThreads);
}

namespace detail {

void run_tasks(std::size_t count, int threads, TaskFn fn, void* context) {
  if (count > 1) {
    const auto used = std::min(static_cast<std::size_t>(thread_count(threads)), count);
    if (used > 1 && pool().run(count, static_cast<int>(used) - 1, fn, context)) return;
  }
  for (std::size_t t = 0; t < count; ++t) fn(context, t);
}

}  // namespace detail
}  // namespace align3d
