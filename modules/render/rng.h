// Deterministic pseudo-random numbers for Monte Carlo rendering and scene
// synthesis: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
// Statistically Good Algorithms for Random Number Generation", pcg32 with the
// XSH-RR output) seeded through SplitMix64.
//
// Written by hand: every pixel and every vertex gets its own stream, seeded
// from (seed, index) in a few instructions, so images are identical whatever
// the thread count and tile order; the standard engines are not made to be
// seeded millions of times (mt19937 carries 2.5 KB of state), and the standard
// distributions differ between library versions.
#pragma once

#include <cmath>
#include <cstdint>

namespace relight {

// SplitMix64 finaliser: a well-mixed 64-bit hash of `x`.
inline uint64_t MixBits(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Combines a seed with an index into a new, well-mixed seed.
inline uint64_t MixSeed(uint64_t seed, uint64_t index) {
  return MixBits(MixBits(seed) ^ (index * 0xD1B54A32D192ED03ull));
}

// PCG32 generator: 64-bit state, 32-bit outputs, period 2^64 per stream.
class Pcg32 {
 public:
  // A generator for (seed, stream); different streams are independent sequences.
  explicit Pcg32(uint64_t seed = 1, uint64_t stream = 0) {
    inc_ = (MixBits(stream) << 1u) | 1u;
    state_ = 0;
    NextUint32();
    state_ += MixBits(seed);
    NextUint32();
  }
  // Next 32 uniformly distributed bits.
  uint32_t NextUint32() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }
  // Uniform double in [0, 1) with 53 random bits.
  double Uniform() {
    const uint64_t hi = NextUint32(), lo = NextUint32();
    return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
  }
  // Uniform double in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [0, n), n > 0 (Lemire's nearly divisionless method is not needed at these n).
  uint32_t UniformInt(uint32_t n) { return static_cast<uint32_t>(Uniform() * n) % n; }
  // Standard normal deviate (Box-Muller, one of the pair).
  double Normal() {
    const double u1 = 1.0 - Uniform(), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

 private:
  uint64_t state_;
  uint64_t inc_;
};

}  // namespace relight
