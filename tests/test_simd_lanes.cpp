// The lane operations of the SIMD walk whose contract is more than one intrinsic: pair_lanes,
// which hands idle lanes their next walks (cpu/simd_walk_lanes.h), on each instruction set
// this CPU has.
#include <immintrin.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cpu/simd_walk.h"

// Each instruction set's header and the function that calls it are compiled for that set only,
// as in cpu/simd_walk_avx2.cpp and cpu/simd_walk_avx512.cpp.
#pragma GCC push_options
#pragma GCC target("avx2")
#include "cpu/simd_lanes_avx2.h"
namespace {
void pair_lanes_avx2(std::uint32_t takers, std::uint32_t givers, std::int32_t* out) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out),
                      irgrid::simd::Avx2Lanes::pair_lanes(takers, givers));
}
}  // namespace
#pragma GCC pop_options

#pragma GCC push_options
#pragma GCC target("avx512f,avx512vl")
#include "cpu/simd_lanes_avx512.h"
namespace {
void pair_lanes_avx512(std::uint32_t takers, std::uint32_t givers, std::int32_t* out) {
  _mm512_storeu_si512(out, irgrid::simd::Avx512Lanes::pair_lanes(takers, givers));
}
}  // namespace
#pragma GCC pop_options

namespace irgrid {
namespace {

using PairLanes = void (*)(std::uint32_t, std::uint32_t, std::int32_t*);

/// Checks that the k-th lowest lane of `takers` holds the index of the k-th lowest lane of
/// `givers`, and every other lane 0.
void expect_pairs(PairLanes pair_lanes, int lanes, std::uint32_t takers, std::uint32_t givers) {
  std::int32_t out[16];
  pair_lanes(takers, givers, out);
  std::uint32_t taker = takers, giver = givers;
  for (; taker != 0; taker &= taker - 1, giver &= giver - 1)
    ASSERT_EQ(out[__builtin_ctz(taker)], __builtin_ctz(giver))
        << "takers " << takers << ", givers " << givers;
  for (int l = 0; l < lanes; ++l)
    if (!(takers >> l & 1)) ASSERT_EQ(out[l], 0) << "lane " << l << ", takers " << takers;
}

/// `count` distinct lanes of `lanes`, at random.
std::uint32_t random_lanes(std::mt19937& rng, int lanes, int count) {
  std::vector<int> order(static_cast<std::size_t>(lanes));
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  std::uint32_t set = 0;
  for (int k = 0; k < count; ++k)
    set |= 1u << order[std::size_t(k)];
  return set;
}

TEST(SimdLanes, Avx2PairsTheKthTakerWithTheKthGiver) {
  if (!cpu_has(SimdIsa::avx2)) GTEST_SKIP() << "this CPU has no AVX2";
  // Every pair of 8-lane sets of the same size.
  for (std::uint32_t takers = 0; takers < 256; ++takers)
    for (std::uint32_t givers = 0; givers < 256; ++givers)
      if (__builtin_popcount(takers) == __builtin_popcount(givers))
        expect_pairs(pair_lanes_avx2, 8, takers, givers);
}

TEST(SimdLanes, Avx512PairsTheKthTakerWithTheKthGiver) {
  if (!cpu_has(SimdIsa::avx512)) GTEST_SKIP() << "this CPU has no AVX-512";
  expect_pairs(pair_lanes_avx512, 16, 0, 0);
  expect_pairs(pair_lanes_avx512, 16, 0xffff, 0xffff);
  expect_pairs(pair_lanes_avx512, 16, 0x8000, 0x0001);
  expect_pairs(pair_lanes_avx512, 16, 0x0001, 0x8000);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20000; ++trial) {
    const int count = int(rng() % 17);
    expect_pairs(pair_lanes_avx512, 16, random_lanes(rng, 16, count), random_lanes(rng, 16, count));
  }
}

}  // namespace
}  // namespace irgrid
