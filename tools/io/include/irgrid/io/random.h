// irgrid/io/random.h: small deterministic random numbers (PCG32, splitmix64) for host and device
// code.
#pragma once

#include <cstdint>

#include "irgrid/kernel/platform.h"

namespace irgrid {

/// splitmix64 finaliser: a fast, well-mixing 64-bit hash. Use it to turn an index (a strand,
/// a pixel, a sample) into an independent seed, so results do not depend on thread scheduling.
IRGRID_HD constexpr std::uint64_t hash64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

/// PCG32 (O'Neill, XSH-RR variant): 64-bit state, 32-bit output. Identical results on every
/// platform and compiler, unlike the std:: distributions. Default-constructed it is seeded
/// with (0, 0); call seed() with distinct streams for independent sequences.
struct Pcg32 {
  std::uint64_t state = 0;
  std::uint64_t increment = 1;  ///< always odd; selects the stream

  /// Seeds the generator; different `stream` values give independent sequences.
  IRGRID_HD constexpr void seed(std::uint64_t initial_state, std::uint64_t stream = 0) {
    state = 0;
    increment = (stream << 1u) | 1u;
    next_u32();
    state += initial_state;
    next_u32();
  }

  /// The next uniformly distributed 32-bit value.
  IRGRID_HD constexpr std::uint32_t next_u32() {
    const std::uint64_t old = state;
    state = old * 6364136223846793005ull + increment;
    const auto xorshifted = std::uint32_t(((old >> 18u) ^ old) >> 27u);
    const auto rotation = std::uint32_t(old >> 59u);
    return (xorshifted >> rotation) | (xorshifted << ((32u - rotation) & 31u));
  }

  /// A uniform float in [0, 1) with 24 random mantissa bits (never rounds up to 1).
  IRGRID_HD constexpr float next_float() { return float(next_u32() >> 8) * 0x1.0p-24f; }
};

}  // namespace irgrid
