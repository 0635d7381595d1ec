// cpu/cpu_executor.h: the oneTBB executor: the parallel primitives every build phase is written in.
#pragma once

#include <oneapi/tbb/blocked_range.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cpu/host_memory.h"
#include "cpu/memory_meter.h"
#include "cpu/merge_propose.h"
#include "cpu/octant_masks.h"
#include "cpu/parallel.h"
#include "cpu/pooled_allocator.h"
#include "cpu/radix_sort.h"
#include "cpu/triangle_planes.h"

namespace irgrid {

/// Runs data-parallel primitives on the host with oneTBB. Algorithms are templates over an
/// executor and use only the calls below, so the CUDA executor can offer the same ones (a
/// generic kernel for for_each, CUB for the rest) and the same code builds on both backends.
///
/// Every primitive is deterministic: for the same inputs the outputs are bit-identical
/// whatever the number of TBB threads, because work is cut into blocks that depend on n only
/// and partial results are combined in block order.
///
/// Each call adds its wall time to a profile entry named by its `name` argument. Calls must be
/// made from one thread at a time and never from inside another primitive's body.
class CpuExecutor {
 public:
  /// Cells a latency-bound body handles together (see merge propose): walks through the voxel
  /// map are chains of dependent loads, and a core keeps the loads of several walks in flight.
  static constexpr std::uint32_t kLookupBatch = 16;

  /// The initial grid's octrees are built one top cell at a time, in cache, into growing host
  /// buffers (core/construction/octree_depth_first.h); the result equals the level-by-level
  /// build's.
  static constexpr bool kDepthFirstOctrees = true;

  /// The octrees' children masks come from child_overlap_masks, a node's triangles at once.
  static constexpr bool kOctreeMasksInLanes = true;
  /// masks[k] = child_overlap_mask(node, triangles[ids[k]]) for k < count: many triangles at
  /// once in SIMD lanes (cpu/octant_masks.h), the same masks.
  static void child_overlap_masks(const NodeSplit& node, const TriangleVertices* triangles,
                                  std::uint64_t num_triangles, const std::uint32_t* ids,
                                  std::uint32_t count, std::uint8_t* masks) {
    irgrid::child_overlap_masks(node, triangles, num_triangles, ids, count, masks);
  }

  /// level_child_masks (cpu/octant_masks.h): a level's pairs, each with its own node.
  static void level_child_masks(const GridInfo& info, std::int32_t half,
                                const TriangleVertices* triangles, const Voxel* node_lo,
                                std::uint64_t num_nodes, const std::uint32_t* pair_node,
                                const std::uint32_t* pair_tri, std::uint64_t num_pairs,
                                const std::uint32_t* picked, std::uint32_t count,
                                std::uint8_t* masks) {
    irgrid::level_child_masks(info, half, triangles, node_lo, num_nodes, pair_node, pair_tri,
                              num_pairs, picked, count, masks);
  }

  /// A merge sweep's proposals over narrow cells run in SIMD lanes, one cell per lane, where
  /// proposes_in_lanes says so (cpu/merge_propose.h): the same proposals.
  static constexpr bool kProposesInLanes = true;
  static bool proposes_in_lanes(const GridInfo& info) { return irgrid::proposes_in_lanes(info); }
  static void propose_merges_in_lanes(const merge_detail::ProposeInputs& in, std::uint32_t first,
                                      std::uint32_t count) {
    irgrid::propose_merges_in_lanes(in, first, count);
  }

  /// The expansion's triangle planes come from triangle_planes_of, many triangles at once in
  /// SIMD lanes (cpu/triangle_planes.h), the same planes.
  static constexpr bool kTrianglePlanesInLanes = true;
  static void triangle_planes(const GridInfo& info, const TriangleVertices* triangles,
                              std::uint32_t count, expand_detail::TrianglePlanes* out) {
    irgrid::triangle_planes_of(info, triangles, count, out);
  }

  /// Merging pairs the cells of each proposal chain by walking it from its head in one body
  /// (core/construction/merge_pairs.h, chain_parity), not by pointer jumping.
  static constexpr bool kSerialMergeChains = true;

  /// Merging writes the merged cells over the old ones and compacts them in place
  /// (compact_in_place), instead of into new arrays beside the old: the first sweep held both,
  /// the build's memory peak.
  static constexpr bool kCompactsInPlace = true;

  /// Bytes of host memory the build may still take (0 when unknown): the build stops with an
  /// error naming its parameters before it would outgrow them (check_memory_budget), instead of
  /// being killed by the system or its container.
  static std::uint64_t memory_budget() { return host_memory_available(); }

  /// The most bytes the buffers held at once since reset_memory_peak(). Here the whole
  /// process's buffers (MemoryMeter): builds running side by side share it.
  static std::uint64_t memory_peak() { return std::uint64_t(MemoryMeter::peak()); }
  /// Starts a new peak from the bytes the buffers hold now.
  static void reset_memory_peak() { MemoryMeter::reset_peak(); }

  /// Buffers come from `pool` when it is given (it must outlive them), so that rebuilds reuse
  /// the blocks of earlier builds; from the system allocator otherwise.
  explicit CpuExecutor(HostPool* pool = nullptr) : pool_(pool) {}

  /// Memory the primitives work on; host vectors here, device buffers on the CUDA executor.
  /// Algorithm code reaches elements only through the executor's calls or, inside a
  /// for_each body, through raw pointers taken with buffer.data() beforehand. Their bytes are
  /// counted by MemoryMeter, so a build can report its peak.
  template <typename T>
  using Buffer = std::vector<T, PooledAllocator<T>>;

  /// A buffer of n elements. Contents are unspecified (left uninitialised here, as on the
  /// device), so callers must write before they read. A buffer of 0 elements that grows later
  /// (push_back, resize) grows from the executor's pool too.
  template <typename T>
  Buffer<T> allocate(std::size_t n) const {
    return Buffer<T>(n, PooledAllocator<T>(pool_));
  }

  /// Bounds the memory the pool holds for this build, its cached blocks included, by the
  /// construction budget (HostPool::set_cache_limit).
  void limit_cached_memory(std::uint64_t bytes) const {
    if (pool_) pool_->set_cache_limit(bytes);
  }

  /// Gives the pool's cached blocks back to the system (HostPool::trim): after the depth-first
  /// octrees are abandoned, their many small blocks fit none of the level-by-level buffers.
  void release_cached_memory() const {
    if (pool_) pool_->trim();
  }

  /// Calls body(i) once for every i in [0, n), in parallel and in no particular order.
  /// Bodies must not write to the same location; they may run concurrently.
  template <typename F>
  void for_each(const char* name, std::size_t n, F&& body) const {
    const PhaseTimer timer(*this, name);
    irgrid::parallel_for(tbb::blocked_range<std::size_t>(0, n),
                         [&](const tbb::blocked_range<std::size_t>& range) {
                           for (std::size_t i = range.begin(); i != range.end(); ++i)
                             body(i);
                         });
  }

  /// out[i] = in[0] + ... + in[i - 1] for i in [0, n); returns the sum of all n inputs
  /// (0 when n == 0). Integer types only, with wrap-around on overflow. in == out is allowed;
  /// otherwise the ranges must not overlap.
  template <typename T>
  T exclusive_scan(const char* name, const T* in, T* out, std::size_t n) const {
    static_assert(std::is_integral_v<T>,
                  "exclusive_scan is exact (deterministic) on integers only");
    const PhaseTimer timer(*this, name);
    if (n < parallel_scan_min_n) return sequential_exclusive_scan(in, out, 0, n, T(0), true);
    return irgrid::parallel_scan(
        tbb::blocked_range<std::size_t>(0, n, scan_grain_size), T(0),
        [in, out](const tbb::blocked_range<std::size_t>& range, T running, bool is_final) {
          return sequential_exclusive_scan(in, out, range.begin(), range.end(), running, is_final);
        },
        [](T left, T right) { return T(left + right); });
  }

  /// init op in[0] op ... op in[n - 1], for op associative and commutative (sum, min or max
  /// over integers; min or max over floats). Returns init when n == 0. The grouping of the
  /// operations depends on n only, so even a float sum is reproducible run to run.
  template <typename T, typename Op>
  T reduce(const char* name, const T* in, std::size_t n, T init, Op op) const {
    return transform_reduce(name, n, init, op, [in](std::size_t i) { return in[i]; });
  }

  /// init op f(0) op ... op f(n - 1), with the same contract as reduce; f(i) computes the
  /// element so no temporary buffer is needed. f must be pure (it runs concurrently).
  template <typename T, typename Op, typename F>
  T transform_reduce(const char* name, std::size_t n, T init, Op op, F f) const {
    const PhaseTimer timer(*this, name);
    const detail::BlockPartition blocks(n, reduce_block_size);
    std::vector<T> partials(blocks.count, init);
    detail::for_each_block(blocks, [&](std::size_t block) {
      T accumulated = f(blocks.begin(block));
      for (std::size_t i = blocks.begin(block) + 1; i < blocks.end(block); ++i)
        accumulated = op(accumulated, f(i));
      partials[block] = accumulated;
    });
    T result = init;
    for (const T& partial : partials)
      result = op(result, partial);
    return result;
  }

  /// Stable sort of keys[0, n) by their low `key_bits` bits (CUB's begin_bit = 0,
  /// end_bit = key_bits), with values[0, n) permuted alongside. K is an unsigned integer
  /// (uint32 or uint64); key_bits is in [0, 8 * sizeof(K)] (Error(invalid_argument)
  /// otherwise). Bits above key_bits are kept in the keys but do not affect the order. Uses
  /// scratch memory for one more copy of the keys and values.
  template <typename K, typename V>
  void sort_pairs(const char* name, K* keys, V* values, std::size_t n, int key_bits) const {
    const PhaseTimer timer(*this, name);
    detail::radix_sort_pairs(keys, values, n, key_bits, PooledAllocator<K>(pool_));
  }

  /// Stable compaction: copies in[i] to out, in increasing i, for every i where
  /// keep(i, in[i]) is true, and returns how many were copied. in and out must not overlap.
  /// keep must be pure: it runs concurrently and may be called more than once per element.
  template <typename T, typename Pred>
  std::size_t select_if(const char* name, const T* in, T* out, std::size_t n, Pred keep) const {
    const PhaseTimer timer(*this, name);
    const detail::BlockPartition blocks(n, select_block_size);
    std::vector<std::size_t> block_offsets(blocks.count);
    detail::for_each_block(blocks, [&](std::size_t block) {
      std::size_t kept = 0;
      for (std::size_t i = blocks.begin(block); i < blocks.end(block); ++i)
        kept += keep(i, in[i]);
      block_offsets[block] = kept;
    });
    std::size_t total = 0;
    for (std::size_t& offset : block_offsets)
      total += std::exchange(offset, total);
    detail::for_each_block(blocks, [&](std::size_t block) {
      T* next = out + block_offsets[block];
      for (std::size_t i = blocks.begin(block); i < blocks.end(block); ++i)
        if (keep(i, in[i])) *next++ = in[i];
    });
    return total;
  }

  /// Stable compaction in place: for every i in [0, n) where keep(i), in increasing i,
  /// move(i, to) moves element i (of each array being compacted) to position `to`, the number
  /// of kept elements before it; returns how many were kept. For arrays too large to hold twice:
  /// blocks compact to their own fronts in parallel, then one thread moves each block's kept
  /// elements down into place, in order (a move's target never lies past its source). keep must
  /// be pure and must not read the arrays being moved.
  template <typename Keep, typename Move>
  std::size_t compact_in_place(const char* name, std::size_t n, Keep keep, Move move) const {
    const PhaseTimer timer(*this, name);
    const detail::BlockPartition blocks(n, select_block_size);
    std::vector<std::size_t> kept(blocks.count);
    detail::for_each_block(blocks, [&](std::size_t block) {
      const std::size_t begin = blocks.begin(block);
      std::size_t to = begin;
      for (std::size_t i = begin; i < blocks.end(block); ++i) {
        if (!keep(i)) continue;
        if (i != to) move(i, to);
        ++to;
      }
      kept[block] = to - begin;
    });
    std::size_t total = 0;
    for (std::size_t block = 0; block < blocks.count; ++block) {
      const std::size_t begin = blocks.begin(block);
      if (total != begin)
        for (std::size_t k = 0; k < kept[block]; ++k)
          move(begin + k, total + k);
      total += kept[block];
    }
    return total;
  }

  /// Waits for all submitted work. A no-op here (every call above returns when done); the
  /// CUDA executor waits for its stream.
  void synchronize() const {}

  /// Accumulated wall time in milliseconds per phase name, since construction or the last
  /// reset_profile().
  const std::map<std::string, double>& profile_ms() const { return profile_ms_; }

  /// Clears the accumulated phase times.
  void reset_profile() { profile_ms_.clear(); }

 private:
  /// Below this many elements a sequential scan beats spawning tasks.
  static constexpr std::size_t parallel_scan_min_n = std::size_t(1) << 15;
  static constexpr std::size_t scan_grain_size = std::size_t(1) << 14;
  static constexpr std::size_t reduce_block_size = std::size_t(1) << 14;
  static constexpr std::size_t select_block_size = std::size_t(1) << 14;

  /// Exclusive scan of in[begin, end) starting from `running`; writes out only when
  /// `write` (TBB's pre-scan pass only sums). Reads in[i] before writing out[i], so in == out
  /// works. Returns the running sum after `end`.
  template <typename T>
  static T sequential_exclusive_scan(const T* in, T* out, std::size_t begin, std::size_t end,
                                     T running, bool write) {
    for (std::size_t i = begin; i < end; ++i) {
      const T value = in[i];
      if (write) out[i] = running;
      running = T(running + value);
    }
    return running;
  }

  /// Adds the wall time of its scope to the profile entry `name`.
  class PhaseTimer {
   public:
    PhaseTimer(const CpuExecutor& executor, const char* name)
        : executor_(executor), name_(name), start_(std::chrono::steady_clock::now()) {}
    ~PhaseTimer() {
      const std::chrono::duration<double, std::milli> elapsed =
          std::chrono::steady_clock::now() - start_;
      executor_.profile_ms_[name_] += elapsed.count();
    }
    PhaseTimer(const PhaseTimer&) = delete;
    PhaseTimer& operator=(const PhaseTimer&) = delete;

   private:
    const CpuExecutor& executor_;
    const char* name_;
    std::chrono::steady_clock::time_point start_;
  };

  // Mutable so that the primitives stay const (as on the CUDA executor, where they only
  // enqueue work); touched only by the calling thread, never by TBB workers.
  mutable std::map<std::string, double> profile_ms_;
  HostPool* pool_ = nullptr;
};

}  // namespace irgrid
