// Seeded random numbers with a fixed, documented algorithm so results are reproducible across
// compilers and standard libraries (std distributions are implementation-defined).
// Generator: SplitMix64. uniform_index(n) = floor(next() * n / 2^64).
#pragma once
#include <cstdint>

namespace trellis {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  // A stream derived from (seed, stream): used for one independent stream per iteration.
  static Rng stream(std::uint64_t seed, std::uint64_t stream_id) {
    Rng r(seed ^ (0x9E3779B97F4A7C15ull * (stream_id + 1)));
    r.next();
    return r;
  }
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform integer in [0, n), n > 0.
  std::uint64_t uniform_index(std::uint64_t n) {
    return static_cast<std::uint64_t>((static_cast<unsigned __int128>(next()) * n) >> 64);
  }
  // Uniform double in [0, 1).
  double uniform01() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

}  // namespace trellis
