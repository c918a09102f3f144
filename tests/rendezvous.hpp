// A test's way to make sure tasks run on distinct threads at the same time: each task waits at
// the rendezvous for the others, which only finishes if that many threads run them at once.
#pragma once

#include <atomic>
#include <chrono>

namespace align3d {

// Waits until `parties` threads have arrived; false if one has not come within 10 s (the tasks
// were not run on that many threads at once), so a test fails instead of hanging.
class Rendezvous {
 public:
  explicit Rendezvous(int parties) : parties_(parties) {}
  bool arrive_and_wait() {
    arrived_.fetch_add(1);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (arrived_.load() < parties_)
      if (std::chrono::steady_clock::now() > deadline) return false;
    return true;
  }

 private:
  std::atomic<int> arrived_{0};
  const int parties_;
};

}  // namespace align3d
