// cpu/radix_sort.h: stable parallel LSD radix sort of (key, value) pairs on the low key bits
// (oneTBB).
#pragma once

#include <oneapi/tbb/blocked_range.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cpu/memory_meter.h"
#include "cpu/parallel.h"
#include "irgrid/error.h"

namespace irgrid::detail {

/// [0, n) cut into blocks of a size that depends on n only, never on the number of threads, so
/// that every block-wise primitive visits the same blocks in the same order on any machine.
struct BlockPartition {
  std::size_t n = 0;
  std::size_t block_size = 1;
  std::size_t count = 0;  ///< number of blocks; 0 when n == 0

  BlockPartition(std::size_t n_, std::size_t block_size_)
      : n(n_), block_size(std::max<std::size_t>(block_size_, 1)) {
    count = (n + block_size - 1) / block_size;
  }
  std::size_t begin(std::size_t block) const { return block * block_size; }
  std::size_t end(std::size_t block) const { return std::min(n, (block + 1) * block_size); }
};

/// Calls body(block) for every block of `partition`, in parallel.
template <typename F>
void for_each_block(const BlockPartition& partition, F&& body) {
  irgrid::parallel_for(tbb::blocked_range<std::size_t>(0, partition.count, 1),
                       [&](const tbb::blocked_range<std::size_t>& range) {
                         for (std::size_t block = range.begin(); block != range.end(); ++block)
                           body(block);
                       });
}

/// Below this many pairs std::stable_sort beats the radix sort's fixed cost per pass.
inline constexpr std::size_t radix_sort_small_n = 4096;
/// Widest digit: 2^8 buckets keep the per-block histograms and the scatter's open write
/// streams within L1/TLB reach (wider digits save a pass but scatter more slowly here).
inline constexpr int radix_max_digit_bits = 8;
/// At most this many blocks per pass: enough to balance many cores, few enough that the
/// sequential bucket-by-block offset scan stays negligible.
inline constexpr std::size_t radix_max_blocks = 256;
/// At least this many keys per block, so that a histogram row is amortised over its block.
inline constexpr std::size_t radix_min_block_size = std::size_t(1) << 13;

/// The low `key_bits` bits set, in the key type.
template <typename K>
K low_bits_mask(int key_bits) {
  return key_bits >= int(8 * sizeof(K)) ? K(~K(0)) : K((K(1) << key_bits) - 1);
}

/// Reference path for small inputs: std::stable_sort of the pairs on the masked key.
template <typename K, typename V>
void stable_sort_pairs_small(K* keys, V* values, std::size_t n, int key_bits) {
  const K mask = low_bits_mask<K>(key_bits);
  std::vector<std::pair<K, V>> pairs(n);
  for (std::size_t i = 0; i < n; ++i)
    pairs[i] = {keys[i], values[i]};
  std::stable_sort(pairs.begin(), pairs.end(), [mask](const auto& a, const auto& b) {
    return (a.first & mask) < (b.first & mask);
  });
  for (std::size_t i = 0; i < n; ++i)
    keys[i] = pairs[i].first, values[i] = pairs[i].second;
}

/// Turns per-block digit counts (block-major rows) into each block's first output slot per
/// digit: all blocks' digit 0 first, in block order, then digit 1, ... which is what makes
/// the scatter stable. Returns false when one digit holds all n keys (the pass would be a copy).
inline bool digit_counts_to_offsets(std::vector<std::size_t>& table, std::size_t blocks,
                                    std::size_t buckets, std::size_t n) {
  std::size_t running = 0;
  for (std::size_t digit = 0; digit < buckets; ++digit) {
    const std::size_t digit_begin = running;
    for (std::size_t block = 0; block < blocks; ++block) {
      const std::size_t count = table[block * buckets + digit];
      table[block * buckets + digit] = running;
      running += count;
    }
    if (running - digit_begin == n) return false;
  }
  return true;
}

/// One counting-sort pass on the digit (key >> shift) & digit_mask from `in` to `out`.
/// Returns false (and writes nothing) when every key has the same digit.
template <typename K, typename V>
bool radix_pass(const K* keys_in, const V* values_in, K* keys_out, V* values_out,
                const BlockPartition& blocks, int shift, int digit_bits,
                std::vector<std::size_t>& table) {
  const std::size_t buckets = std::size_t(1) << digit_bits;
  const K digit_mask = K(buckets - 1);
  table.assign(blocks.count * buckets, 0);
  for_each_block(blocks, [&](std::size_t block) {
    std::size_t* counts = table.data() + block * buckets;
    for (std::size_t i = blocks.begin(block); i < blocks.end(block); ++i)
      ++counts[(keys_in[i] >> shift) & digit_mask];
  });
  if (!digit_counts_to_offsets(table, blocks.count, buckets, blocks.n)) return false;
  for_each_block(blocks, [&](std::size_t block) {
    std::size_t* next_slot = table.data() + block * buckets;  // this block's row only
    for (std::size_t i = blocks.begin(block); i < blocks.end(block); ++i) {
      const std::size_t slot = next_slot[(keys_in[i] >> shift) & digit_mask]++;
      keys_out[slot] = keys_in[i];
      values_out[slot] = values_in[i];
    }
  });
  return true;
}

/// Stable sort of keys[0, n) with values[0, n) alongside, comparing only the low `key_bits`
/// bits of each key (the higher bits travel with the key but are ignored, like CUB's end_bit).
/// key_bits in [0, 8 * sizeof(K)]; throws Error(invalid_argument) otherwise.
template <typename K, typename V, typename Allocator = MeteredAllocator<K>>
void radix_sort_pairs(K* keys, V* values, std::size_t n, int key_bits,
                      const Allocator& scratch_allocator = {}) {
  static_assert(std::is_integral_v<K> && std::is_unsigned_v<K>, "keys must be unsigned integers");
  if (key_bits < 0 || key_bits > int(8 * sizeof(K)))
    throw Error(ErrorCode::invalid_argument, "sort_pairs: key_bits " + std::to_string(key_bits) +
                                                 " outside [0, " + std::to_string(8 * sizeof(K)) +
                                                 "]");
  if (n < 2 || key_bits == 0) return;
  if (n < radix_sort_small_n) return stable_sort_pairs_small(keys, values, n, key_bits);

  // Fewest passes, then digits as even as possible: 24 bits -> 3 x 8, 13 bits -> 7 + 6.
  const int passes = (key_bits + radix_max_digit_bits - 1) / radix_max_digit_bits;
  const int digit_bits = (key_bits + passes - 1) / passes;
  const BlockPartition blocks(
      n, std::max(radix_min_block_size, (n + radix_max_blocks - 1) / radix_max_blocks));

  // From the executor's allocator, so that a build's peak counts the scratch too and a
  // rebuild takes it from the pool.
  using KeyAllocator = typename std::allocator_traits<Allocator>::template rebind_alloc<K>;
  using ValueAllocator = typename std::allocator_traits<Allocator>::template rebind_alloc<V>;
  std::vector<K, KeyAllocator> scratch_keys(n, KeyAllocator(scratch_allocator));
  std::vector<V, ValueAllocator> scratch_values(n, ValueAllocator(scratch_allocator));
  K* keys_from = keys;
  V* values_from = values;
  K* keys_to = scratch_keys.data();
  V* values_to = scratch_values.data();
  std::vector<std::size_t> table;
  for (int shift = 0; shift < key_bits; shift += digit_bits) {
    const int bits = std::min(digit_bits, key_bits - shift);  // last digit may be narrower
    if (radix_pass(keys_from, values_from, keys_to, values_to, blocks, shift, bits, table)) {
      std::swap(keys_from, keys_to);
      std::swap(values_from, values_to);
    }
  }
  if (keys_from == keys) return;
  for_each_block(blocks, [&](std::size_t block) {
    std::copy(keys_from + blocks.begin(block), keys_from + blocks.end(block),
              keys + blocks.begin(block));
    std::copy(values_from + blocks.begin(block), values_from + blocks.end(block),
              values + blocks.begin(block));
  });
}

}  // namespace irgrid::detail
