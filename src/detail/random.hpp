// A seeded random source whose output is the same on every platform and standard library
// (std::*_distribution are implementation-defined, which would break "same seed, same bytes").
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace align3d {

// SplitMix64 (Steele, Lea and Flood 2014): a counter-based mixer, the same on every platform; the
// seed of stream k is splitmix64(base ^ k) or splitmix64(base + γ·k).
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  std::uint64_t below(std::uint64_t n) { return n ? engine_() % n : 0; }
  double normal() {                     // Box-Muller; one variate per call keeps the stream simple
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace align3d
