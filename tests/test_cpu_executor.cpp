// CpuExecutor primitives against their std:: counterparts over awkward sizes, plus determinism.
#include <gtest/gtest.h>
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/release_buffer.h"
#include "cpu/cpu_executor.h"
#include "cpu/host_pool.h"
#include "cpu/memory_meter.h"
#include "irgrid/error.h"
#include "irgrid/io/scene.h"
#include "irgrid/irgrid.h"

namespace irgrid {
namespace {

/// splitmix64 (Steele, Lea, Flood): a tiny generator whose stream depends only on the seed.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

 private:
  std::uint64_t state_;
};

/// 0, 1, 2, 3, primes and 2^k - 1, 2^k, 2^k + 1 up to 2^max_log2 + 1, where block and digit
/// boundaries of the primitives tend to break.
std::vector<std::size_t> awkward_sizes(int max_log2 = 20) {
  std::vector<std::size_t> sizes = {0, 1, 2, 3, 1009, 65537};
  for (int k = 4; k <= max_log2; k += 4)
    for (std::size_t size :
         {(std::size_t(1) << k) - 1, std::size_t(1) << k, (std::size_t(1) << k) + 1})
      sizes.push_back(size);
  return sizes;
}

template <typename T>
std::vector<T> random_values(std::size_t n, std::uint64_t seed) {
  SplitMix64 rng(seed);
  std::vector<T> values(n);
  for (T& value : values)
    value = T(rng.next());
  return values;
}

/// Runs f with TBB limited to `threads` threads.
template <typename F>
auto with_threads(int threads, F f) {
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  return f();
}

// ---------------------------------------------------------------------------------------------
// exclusive_scan

template <typename T>
void check_exclusive_scan(std::size_t n, std::uint64_t seed) {
  const CpuExecutor executor;
  const std::vector<T> input = random_values<T>(n, seed);  // full range: sums wrap around
  std::vector<T> expected(n);
  std::exclusive_scan(input.begin(), input.end(), expected.begin(), T(0));
  const T expected_total = std::accumulate(input.begin(), input.end(), T(0));

  std::vector<T> output(n, T(0xdead));
  EXPECT_EQ(executor.exclusive_scan("scan", input.data(), output.data(), n), expected_total);
  EXPECT_EQ(output, expected) << "out of place, n = " << n;

  std::vector<T> in_place = input;
  EXPECT_EQ(executor.exclusive_scan("scan", in_place.data(), in_place.data(), n), expected_total);
  EXPECT_EQ(in_place, expected) << "in place, n = " << n;
}

TEST(CpuExecutorScan, MatchesStdExclusiveScan) {
  for (std::size_t n : awkward_sizes()) {
    check_exclusive_scan<std::uint32_t>(n, 1 + n);
    check_exclusive_scan<std::uint64_t>(n, 2 + n);
  }
}

// ---------------------------------------------------------------------------------------------
// reduce and transform_reduce

TEST(CpuExecutorReduce, MatchesStdOnIntegers) {
  const CpuExecutor executor;
  const auto sum = [](std::uint64_t a, std::uint64_t b) { return a + b; };
  const auto min = [](std::uint32_t a, std::uint32_t b) { return std::min(a, b); };
  const auto max = [](std::uint32_t a, std::uint32_t b) { return std::max(a, b); };
  for (std::size_t n : awkward_sizes()) {
    const auto values = random_values<std::uint32_t>(n, 10 + n);
    const std::vector<std::uint64_t> wide(values.begin(), values.end());
    EXPECT_EQ(executor.reduce("sum", wide.data(), n, std::uint64_t(7), sum),
              std::accumulate(wide.begin(), wide.end(), std::uint64_t(7)));
    const std::uint32_t expected_min =
        n ? std::min(0xfffffff0u, *std::min_element(values.begin(), values.end())) : 0xfffffff0u;
    EXPECT_EQ(executor.reduce("min", values.data(), n, 0xfffffff0u, min), expected_min);
    const std::uint32_t expected_max =
        n ? std::max(3u, *std::max_element(values.begin(), values.end())) : 3u;
    EXPECT_EQ(executor.reduce("max", values.data(), n, 3u, max), expected_max);
  }
}

TEST(CpuExecutorReduce, MatchesStdMinMaxOnFloats) {
  const CpuExecutor executor;
  const auto min = [](float a, float b) { return std::min(a, b); };
  const auto max = [](float a, float b) { return std::max(a, b); };
  const float inf = std::numeric_limits<float>::infinity();
  for (std::size_t n : awkward_sizes()) {
    SplitMix64 rng(20 + n);
    std::vector<float> values(n);
    for (float& value : values)
      value = float(std::int64_t(rng.next() >> 40) - (1 << 23)) * 0.37f;
    const float expected_min = n ? *std::min_element(values.begin(), values.end()) : inf;
    const float expected_max = n ? *std::max_element(values.begin(), values.end()) : -inf;
    EXPECT_EQ(executor.reduce("min", values.data(), n, inf, min), expected_min);
    EXPECT_EQ(executor.reduce("max", values.data(), n, -inf, max), expected_max);
  }
}

TEST(CpuExecutorReduce, TransformReduceMatchesALoop) {
  const CpuExecutor executor;
  for (std::size_t n : awkward_sizes()) {
    const auto square_mod = [](std::size_t i) { return std::uint64_t(i) * i % 1000003u; };
    std::uint64_t expected_sum = 11, expected_max = 0;
    for (std::size_t i = 0; i < n; ++i) {
      expected_sum += square_mod(i);
      expected_max = std::max(expected_max, square_mod(i));
    }
    EXPECT_EQ(executor.transform_reduce("sum", n, std::uint64_t(11), std::plus<>(), square_mod),
              expected_sum);
    const auto max = [](std::uint64_t a, std::uint64_t b) { return std::max(a, b); };
    EXPECT_EQ(executor.transform_reduce("max", n, std::uint64_t(0), max, square_mod), expected_max);
  }
}

// ---------------------------------------------------------------------------------------------
// sort_pairs

enum class KeyDistribution { uniform, few_distinct };

/// Keys whose low key_bits bits are uniform, or take only 3 values (many ties, so stability
/// shows); the bits above key_bits are always random, to check they are ignored yet kept.
template <typename K>
std::vector<K> make_keys(std::size_t n, int key_bits, KeyDistribution distribution,
                         std::uint64_t seed) {
  SplitMix64 rng(seed);
  const K mask = detail::low_bits_mask<K>(key_bits);
  std::vector<K> keys(n);
  for (K& key : keys) {
    const K random = K(rng.next());
    key = distribution == KeyDistribution::uniform
              ? random
              : K((random & ~mask) | (K(rng.next() % 3) & mask));
  }
  return keys;
}

template <typename K, typename V>
void check_sort_pairs(std::size_t n, int key_bits, KeyDistribution distribution) {
  const CpuExecutor executor;
  std::vector<K> keys = make_keys<K>(n, key_bits, distribution, n * 131 + key_bits);
  std::vector<V> values(n);
  std::iota(values.begin(), values.end(), V(0));  // the original position reveals stability

  std::vector<std::pair<K, V>> expected(n);
  for (std::size_t i = 0; i < n; ++i)
    expected[i] = {keys[i], values[i]};
  const K mask = detail::low_bits_mask<K>(key_bits);
  std::stable_sort(expected.begin(), expected.end(), [mask](const auto& a, const auto& b) {
    return (a.first & mask) < (b.first & mask);
  });

  executor.sort_pairs("sort", keys.data(), values.data(), n, key_bits);
  for (std::size_t i = 0; i < n; ++i) {
    if (keys[i] == expected[i].first && values[i] == expected[i].second) continue;
    FAIL() << "n = " << n << ", key_bits = " << key_bits << ", key size " << sizeof(K)
           << ", distribution " << int(distribution) << ": first difference at " << i;
  }
}

/// Every key_bits on every size up to 2^16 + 1; larger sizes with fewer key_bits, for time.
template <typename K, typename V>
void check_sort_pairs_over_sizes(const std::vector<int>& all_key_bits,
                                 const std::vector<int>& large_key_bits) {
  for (std::size_t n : awkward_sizes()) {
    const bool large = n > 70000;
    for (int key_bits : large ? large_key_bits : all_key_bits) {
      check_sort_pairs<K, V>(n, key_bits, KeyDistribution::uniform);
      if (!large) check_sort_pairs<K, V>(n, key_bits, KeyDistribution::few_distinct);
    }
  }
}

TEST(CpuExecutorSort, StableOnUint32KeysLikeStdStableSort) {
  check_sort_pairs_over_sizes<std::uint32_t, std::uint32_t>({1, 7, 8, 13, 24, 32}, {13, 32});
}

TEST(CpuExecutorSort, StableOnUint64KeysLikeStdStableSort) {
  check_sort_pairs_over_sizes<std::uint64_t, std::uint32_t>({1, 7, 8, 13, 24, 32, 40, 64},
                                                            {40, 64});
}

TEST(CpuExecutorSort, ManyEqualKeysOnWideKeyBitsSkipEmptyDigitsAndStayStable) {
  for (std::size_t n : {std::size_t(4097), std::size_t(100003), (std::size_t(1) << 20) + 1}) {
    check_sort_pairs<std::uint64_t, std::uint64_t>(n, 64, KeyDistribution::few_distinct);
    check_sort_pairs<std::uint32_t, std::uint64_t>(n, 24, KeyDistribution::few_distinct);
  }
}

TEST(CpuExecutorSort, ZeroKeyBitsLeavesInputAndBadKeyBitsThrow) {
  const CpuExecutor executor;
  auto keys = random_values<std::uint32_t>(5000, 3);
  std::vector<std::uint32_t> values(keys.size());
  std::iota(values.begin(), values.end(), 0u);
  const auto original_keys = keys;
  const auto original_values = values;
  executor.sort_pairs("sort", keys.data(), values.data(), keys.size(), 0);
  EXPECT_EQ(keys, original_keys);
  EXPECT_EQ(values, original_values);
  EXPECT_THROW(executor.sort_pairs("sort", keys.data(), values.data(), keys.size(), 33), Error);
  EXPECT_THROW(executor.sort_pairs("sort", keys.data(), values.data(), keys.size(), -1), Error);
}

// ---------------------------------------------------------------------------------------------
// select_if

TEST(CpuExecutorSelect, MatchesStdCopyIf) {
  const CpuExecutor executor;
  for (std::size_t n : awkward_sizes()) {
    const auto input = random_values<std::uint64_t>(n, 40 + n);
    const auto check = [&](auto keep, const char* what) {
      std::vector<std::uint64_t> expected;
      for (std::size_t i = 0; i < n; ++i)
        if (keep(i, input[i])) expected.push_back(input[i]);
      std::vector<std::uint64_t> output(n + 1, 0xdead);
      const std::size_t count = executor.select_if("select", input.data(), output.data(), n, keep);
      ASSERT_EQ(count, expected.size()) << what << ", n = " << n;
      EXPECT_TRUE(std::equal(expected.begin(), expected.end(), output.begin())) << what;
      EXPECT_EQ(output[count], 0xdeadu) << what << ": wrote past the selection";
    };
    check([](std::size_t, std::uint64_t v) { return v % 2 == 0; }, "even values");
    check([](std::size_t i, std::uint64_t) { return i % 3 == 1; }, "every third index");
    check([](std::size_t, std::uint64_t v) { return v % 1000 == 0; }, "rare");
    check([](std::size_t, std::uint64_t) { return true; }, "all");
    check([](std::size_t, std::uint64_t) { return false; }, "none");
  }
}

// ---------------------------------------------------------------------------------------------
// for_each, determinism across thread counts, profile

TEST(CpuExecutorForEach, VisitsEveryIndexOnce) {
  const CpuExecutor executor;
  for (std::size_t n : awkward_sizes()) {
    std::vector<std::atomic<int>> visits(n);
    executor.for_each("visit", n, [&](std::size_t i) { visits[i].fetch_add(1); });
    EXPECT_TRUE(std::all_of(visits.begin(), visits.end(), [](const auto& v) { return v == 1; }))
        << "n = " << n;
  }
}

/// Every primitive's outputs, as raw bytes, for one input of size n.
std::vector<std::uint8_t> all_primitive_outputs(std::size_t n) {
  const CpuExecutor executor;
  std::vector<std::uint8_t> bytes;
  const auto append = [&bytes](const void* data, std::size_t size) {
    const auto* first = static_cast<const std::uint8_t*>(data);
    bytes.insert(bytes.end(), first, first + size);
  };
  auto keys = random_values<std::uint32_t>(n, 99);
  auto values = executor.allocate<std::uint32_t>(n);
  executor.for_each("iota", n, [v = values.data()](std::size_t i) { v[i] = std::uint32_t(i); });
  executor.sort_pairs("sort", keys.data(), values.data(), n, 27);
  append(keys.data(), n * sizeof(keys[0]));
  append(values.data(), n * sizeof(values[0]));

  // A float sum is not associative: equal bits show the grouping does not follow the threads.
  std::vector<float> floats(n);
  for (std::size_t i = 0; i < n; ++i)
    floats[i] = float(keys[i] % 10007) * 1.37e-3f;
  const float float_sum = executor.reduce("sum", floats.data(), n, 0.0f, std::plus<>());
  append(&float_sum, sizeof(float_sum));

  const std::uint32_t total = executor.exclusive_scan("scan", keys.data(), keys.data(), n);
  append(&total, sizeof(total));
  append(keys.data(), n * sizeof(keys[0]));
  auto selected = executor.allocate<std::uint32_t>(n);
  const std::size_t count =
      executor.select_if("select", values.data(), selected.data(), n,
                         [](std::size_t i, std::uint32_t v) { return (v ^ i) % 5 == 0; });
  append(selected.data(), count * sizeof(selected[0]));
  return bytes;
}

TEST(CpuExecutorDeterminism, OutputsAreBitIdenticalWithOneOrTwoThreads) {
  for (std::size_t n : {std::size_t(65537), (std::size_t(1) << 20) + 1}) {
    const auto one_thread = with_threads(1, [n] { return all_primitive_outputs(n); });
    const auto two_threads = with_threads(2, [n] { return all_primitive_outputs(n); });
    EXPECT_TRUE(one_thread == two_threads) << "n = " << n;
    EXPECT_TRUE(all_primitive_outputs(n) == one_thread) << "default threads, n = " << n;
  }
}

TEST(CpuExecutorProfile, AccumulatesWallTimeByNameUntilReset) {
  CpuExecutor executor;
  const auto sleep_2ms = [](std::size_t) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  };
  executor.for_each("sleepy", 1, sleep_2ms);
  const double after_one = executor.profile_ms().at("sleepy");
  EXPECT_GE(after_one, 2.0);
  executor.for_each("sleepy", 1, sleep_2ms);
  EXPECT_GE(executor.profile_ms().at("sleepy"), after_one + 2.0);

  std::vector<std::uint32_t> data(10, 1);
  executor.exclusive_scan("scan", data.data(), data.data(), data.size());
  executor.reduce("reduce", data.data(), data.size(), 0u, std::plus<>());
  executor.sort_pairs("sort", data.data(), data.data() + 5, 5, 32);
  EXPECT_EQ(executor.profile_ms().size(), 4u);
  EXPECT_EQ(executor.profile_ms().count("reduce"), 1u);
  executor.synchronize();
  executor.reset_profile();
  EXPECT_TRUE(executor.profile_ms().empty());
}

TEST(CpuExecutorBuffers, LargeBuffersAreHugePageAlignedAndMetered) {
  CpuExecutor executor;
  const std::int64_t before = MemoryMeter::current();
  {
    auto small = executor.allocate<std::uint32_t>(1000);
    auto large = executor.allocate<std::uint32_t>(kHugePageBytes / 4 + 1);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(large.data()) % kHugePageBytes, 0u);
    EXPECT_EQ(MemoryMeter::current() - before, std::int64_t(4000 + kHugePageBytes + 4));
    large.back() = 7;  // the whole buffer is usable
    EXPECT_EQ(large.back(), 7u);
  }
  EXPECT_EQ(MemoryMeter::current(), before);
}

TEST(CpuExecutorBuffers, ReleaseGivesTheMemoryBackWhereBracesKeepIt) {
  CpuExecutor executor;
  const std::int64_t before = MemoryMeter::current();
  auto kept = executor.allocate<std::uint32_t>(1000);
  auto released = executor.allocate<std::uint32_t>(1000);
  kept = {};  // vector's initializer-list assignment: empty, capacity kept
  release_buffer(released);
  EXPECT_TRUE(kept.empty());
  EXPECT_EQ(kept.capacity(), 1000u);
  EXPECT_EQ(released.capacity(), 0u);
  EXPECT_EQ(MemoryMeter::current() - before, std::int64_t(4000));
}

// The build's buffers that an accelerator still holds after building are the grid it reports,
// not more: the 32-byte cells that compression replaces go back at once.
TEST(CpuExecutorBuffers, AGridAcceleratorHoldsTheMemoryItReports) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  Scene stretched = scene;  // the same triangles moved, for a rebuild with other cells
  for (Vec3f& v : stretched.vertices)
    v[0] *= 2.5f;
  const std::int64_t before = MemoryMeter::current();
  const auto grid = make_accelerator(scene, Structure::irregular);
  ASSERT_TRUE(grid->build_stats().grid.has_value());
  EXPECT_TRUE(grid->build_stats().grid->compressed_cells);
  EXPECT_EQ(MemoryMeter::current() - before, std::int64_t(grid->build_stats().memory_bytes));
  const std::uint64_t first_cells = grid->build_stats().grid->cells;
  grid->rebuild(stretched.mesh());
  EXPECT_NE(grid->build_stats().grid->cells, first_cells);
  EXPECT_EQ(MemoryMeter::current() - before, std::int64_t(grid->build_stats().memory_bytes));
}

}  // namespace
}  // namespace irgrid

namespace irgrid {
namespace {

TEST(HostPool, ClassesRoundUpByAtMostAQuarterOrToWholeHugePages) {
  EXPECT_EQ(HostPool::class_bytes(1), 256u);
  EXPECT_EQ(HostPool::class_bytes(256), 256u);
  EXPECT_EQ(HostPool::class_bytes(257), 320u);  // 5 x 64
  EXPECT_EQ(HostPool::class_bytes(kHugePageBytes), kHugePageBytes);
  EXPECT_EQ(HostPool::class_bytes(kHugePageBytes + 1), 2 * kHugePageBytes);
  EXPECT_EQ(HostPool::class_bytes(5 * kHugePageBytes / 2), 3 * kHugePageBytes);
  for (std::size_t bytes :
       {std::size_t(1000), std::size_t(4097), std::size_t(123457), std::size_t(1) << 20,
        std::size_t(3) << 20, std::size_t(11) << 20, (std::size_t(1) << 33) + 1}) {
    const std::size_t rounded = HostPool::class_bytes(bytes);
    EXPECT_GE(rounded, bytes);
    EXPECT_LE(rounded, std::max(bytes + bytes / 4, bytes + kHugePageBytes - 1)) << bytes;
    if (bytes > kHugePageBytes) EXPECT_EQ(rounded % kHugePageBytes, 0u) << bytes;
    EXPECT_EQ(HostPool::class_bytes(rounded), rounded) << bytes;
  }
}

/// Bytes of `[p, p + bytes)` the kernel backs with transparent huge pages (/proc/self/smaps).
std::size_t huge_page_bytes_in(const void* p, std::size_t bytes) {
  std::ifstream smaps("/proc/self/smaps");
  const auto at = reinterpret_cast<std::uintptr_t>(p);
  std::string line;
  bool inside = false;
  std::size_t total = 0;
  while (std::getline(smaps, line)) {
    std::uintptr_t begin = 0, end = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> begin >> dash >> end && dash == '-') {
      inside = begin < at + bytes && at < end;
    } else if (inside && line.rfind("AnonHugePages:", 0) == 0) {
      total += std::stoull(line.substr(14)) * 1024;
    }
  }
  return total;
}

TEST(HostPool, ABlockMovedOntoHugePagesKeepsItsContents) {
  HostPool pool;
  const std::size_t bytes = 2 * kHugePageBytes + 12345;  // a class of three huge pages
  auto* block = static_cast<std::uint32_t*>(pool.allocate(bytes));
  const std::size_t words = bytes / 4;
  for (std::size_t i = 0; i < words; ++i)
    block[i] = std::uint32_t(i * 2654435761u);
  const bool moved = pool.move_onto_huge_pages(block, bytes);
  for (std::size_t i = 0; i < words; ++i)
    ASSERT_EQ(block[i], std::uint32_t(i * 2654435761u)) << i;
  // Where the kernel moved it (Linux 6.1 and later, huge pages not off), every page is huge.
  if (moved) EXPECT_GE(huge_page_bytes_in(block, bytes), 3 * kHugePageBytes);
  EXPECT_FALSE(pool.move_onto_huge_pages(nullptr, bytes));
  void* small = pool.allocate(1000);
  EXPECT_FALSE(pool.move_onto_huge_pages(small, 1000));  // a malloc block: left alone
  pool.release(small, 1000);
  pool.release(block, bytes);
}

TEST(HostPool, ReleasedBlocksServeTheNextRequestsOfTheirClass) {
  HostPool pool;
  void* a = pool.allocate(5000);
  void* b = pool.allocate(std::size_t(3) << 20);  // huge-page aligned
  EXPECT_EQ(pool.fresh_allocations(), 2u);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(b) % kHugePageBytes, 0u);
  std::memset(b, 1, std::size_t(3) << 20);
  pool.release(a, 5000);
  pool.release(b, std::size_t(3) << 20);
  EXPECT_EQ(pool.allocate(5001), a);  // same class
  EXPECT_EQ(pool.allocate((std::size_t(3) << 20) - 7), b);
  EXPECT_EQ(pool.fresh_allocations(), 2u);
  pool.release(a, 5001);
  pool.release(b, (std::size_t(3) << 20) - 7);
  EXPECT_GT(pool.cached_bytes(), 0u);
  pool.trim();
  EXPECT_EQ(pool.cached_bytes(), 0u);
}

TEST(HostPool, ARequestTakesACachedBlockUpToTwiceItsClass) {
  HostPool pool;
  void* big = pool.allocate(2560);
  pool.release(big, 2560);
  void* smaller = pool.allocate(2000);  // class 2048: the cached 2560 block is within 2x
  EXPECT_EQ(smaller, big);
  EXPECT_EQ(pool.fresh_allocations(), 1u);
  pool.release(smaller, 2000);  // goes back under its true class, 2560
  EXPECT_EQ(pool.cached_bytes(), 2560u);
  EXPECT_EQ(pool.allocate(2100), big);  // 2100 rounds up to 2560
  pool.release(big, 2100);
  void* tiny = pool.allocate(1000);  // class 1024: 2560 is more than twice as large
  EXPECT_NE(tiny, big);
  EXPECT_EQ(pool.fresh_allocations(), 2u);
  pool.release(tiny, 1000);
  EXPECT_EQ(pool.cached_bytes(), 2560u + 1024u);
}

TEST(HostPool, ACacheLimitReturnsTheLeastRecentlyFreedBlocksFirst) {
  HostPool pool;
  pool.set_cache_limit(12288 + 5120);
  void* older = pool.allocate(4096);
  void* newer = pool.allocate(5120);
  pool.release(older, 4096);
  pool.release(newer, 5120);
  EXPECT_EQ(pool.cached_bytes(), 4096u + 5120u);  // within the limit: both stay
  // A fresh block of a class neither serves would pass the limit: the older block goes.
  void* other = pool.allocate(12000);
  EXPECT_EQ(pool.fresh_allocations(), 3u);
  EXPECT_EQ(pool.cached_bytes(), 5120u);
  EXPECT_EQ(pool.allocate(5120), newer);
  // Blocks in use are never taken back: the pool holds more than the limit while they live.
  EXPECT_EQ(pool.cached_bytes(), 0u);
  pool.release(other, 12000);
  pool.release(newer, 5120);
  EXPECT_EQ(pool.cached_bytes(), 12288u + 5120u);  // releasing adds nothing to what it holds
  pool.set_cache_limit(6000);                      // a lower limit applies at once
  EXPECT_EQ(pool.cached_bytes(), 5120u);
  pool.set_cache_limit(0);  // no limit
  void* again = pool.allocate(100000);
  pool.release(again, 100000);
  EXPECT_EQ(pool.cached_bytes(), 5120u + HostPool::class_bytes(100000));
}

TEST(HostPool, BoundToItsPeakItCachesNoMoreThanItHasGivenOutAtOnce) {
  HostPool pool;
  pool.set_bound_to_peak(true);
  void* older = pool.allocate(4096);
  pool.release(older, 4096);
  EXPECT_EQ(pool.cached_bytes(), 4096u);
  // A fresh 5120-byte block: with the cached one the pool would hold 9216 bytes, more than the
  // 5120 it ever gave out at once, so the cached block goes back first.
  void* newer = pool.allocate(5000);
  EXPECT_EQ(pool.fresh_allocations(), 2u);
  EXPECT_EQ(pool.cached_bytes(), 0u);
  pool.release(newer, 5000);
  EXPECT_EQ(pool.allocate(5000), newer);  // a request its cache serves takes nothing more
  pool.release(newer, 5000);
  // Not bound, the pool keeps a block of every size it passed through.
  pool.set_bound_to_peak(false);
  void* other = pool.allocate(9000);
  pool.release(other, 9000);
  EXPECT_EQ(pool.cached_bytes(), 5120u + HostPool::class_bytes(9000));
}

TEST(HostPool, ExecutorBuffersComeFromThePoolAndGoBackToIt) {
  HostPool pool;
  const CpuExecutor exec(&pool);
  const void* first = nullptr;
  {
    auto buffer = exec.allocate<std::uint32_t>(100000);
    first = buffer.data();
    auto grown = exec.allocate<std::uint32_t>(0);
    for (std::uint32_t i = 0; i < 5000; ++i)
      grown.push_back(i);  // growth takes its blocks from the pool too
    auto moved = std::move(grown);
    EXPECT_EQ(moved.back(), 4999u);
  }
  const std::uint64_t fresh = pool.fresh_allocations();
  auto again = exec.allocate<std::uint32_t>(100000);
  EXPECT_EQ(static_cast<const void*>(again.data()), first);
  EXPECT_EQ(pool.fresh_allocations(), fresh);
}

// Sanitizers bring allocators of their own, with their own ways of returning pages.
#if defined(__linux__) && defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && \
    !defined(__SANITIZE_THREAD__)
/// The process's resident bytes (/proc/self/statm).
std::uint64_t resident_bytes() {
  unsigned long long size = 0, resident = 0;
  std::FILE* statm = std::fopen("/proc/self/statm", "r");
  if (!statm) return 0;
  const int read = std::fscanf(statm, "%llu %llu", &size, &resident);
  std::fclose(statm);
  return read == 2 ? resident * 4096ull : 0;
}

TEST(HostPool, TrimReturnsTheHeapPagesOfSmallBlocks) {
  // Small blocks live in malloc's heap, and a block still in use above them keeps the heap from
  // shrinking from its top: their pages stay resident unless malloc is asked to return them.
  constexpr std::size_t kBlock = 64 << 10, kCount = 2048;  // 128 MiB
  HostPool pool;
  std::vector<void*> blocks;
  for (std::size_t k = 0; k < kCount; ++k) {
    blocks.push_back(pool.allocate(kBlock));
    std::memset(blocks.back(), 1, kBlock);
  }
  void* above = std::malloc(64);
  const std::uint64_t in_use = resident_bytes();
  ASSERT_GT(in_use, kBlock * kCount);
  for (void* block : blocks)
    pool.release(block, kBlock);
  pool.trim();
  const std::uint64_t trimmed = resident_bytes();
  std::free(above);
  EXPECT_LT(trimmed + kBlock * kCount * 3 / 4, in_use);
}

TEST(HostPool, LargeBlocksSentBackLeaveNoResidentPages) {
  // glibc serves blocks below its mmap threshold from its heap, and the threshold rises to the
  // size of each mapped block freed (here 16 MiB): the pool's 4 MiB blocks then live in the heap
  // too, and those its cache limit sends back stayed resident (Crown's process held 140 MiB of
  // them at its peak).
  void* volatile mapped = std::malloc(std::size_t(16) << 20);  // volatile: not elided
  std::free(mapped);
  constexpr std::size_t kBlock = std::size_t(4) << 20, kCount = 72;  // 288 MiB
  HostPool pool;
  std::vector<void*> blocks, between;  // small blocks still in use between them, as in a build
  for (std::size_t k = 0; k < kCount; ++k) {
    blocks.push_back(pool.allocate(kBlock));
    std::memset(blocks.back(), 1, kBlock);
    between.push_back(std::malloc(64));
  }
  const std::uint64_t in_use = resident_bytes();
  ASSERT_GT(in_use, kBlock * kCount);
  for (void* block : blocks)
    pool.release(block, kBlock);
  pool.set_cache_limit(1);  // sends every cached block back, no trim()
  const std::uint64_t sent_back = resident_bytes();
  for (void* block : between)
    std::free(block);
  EXPECT_EQ(pool.cached_bytes(), 0u);
  EXPECT_LT(sent_back + kBlock * kCount * 3 / 4, in_use);
}
#endif

}  // namespace
}  // namespace irgrid
