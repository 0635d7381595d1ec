// cpu/host_pool.h: the CPU build's memory arena, so that rebuilds take no memory from the system.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace irgrid {

/// Host memory arena with statistics, the CPU counterpart of cuda::DevicePool. Blocks freed
/// during a build go back to the pool instead of to the system, so a rebuild of a frame that
/// needs no larger arrays finds its blocks cached: no page faults, no zero-filling by the
/// kernel, no new mappings. Sizes round up to four classes per power of two (at most 25% unused
/// per block), and from the huge-page size up to whole huge pages. A request takes the smallest
/// cached block of its class or of a larger class up to twice its size (a block keeps its true
/// class when it comes back): the phases of one build free blocks of one size and ask for slightly
/// different ones, and a fresh block costs the kernel's page faults and zero-filling (a fifth of a
/// Sponza build's time before this reuse). Blocks more than twice as large stay cached for requests
/// of their size. With a cache limit (set_cache_limit), the blocks the pool holds, given out and
/// cached, stay within it wherever caching is what would pass it: the least recently freed cached
/// blocks go back to the system first. Blocks come from malloc, whose heaps keep the pages of
/// freed blocks resident (large blocks too, below glibc's sliding mmap threshold): after giving
/// back 256 MiB of blocks, and on trim, the pool asks malloc to return its free pages (glibc's
/// malloc_trim). Blocks stay on the pages the system gives (4 KiB where transparent huge pages are
/// on request only, as on Debian): most are build temporaries written once, and on a VM with free
/// page reporting a fresh huge page cost 2.6–3.0 ms per MiB to fault in against 0.4 for 4 KiB
/// pages (Intel Xeon VM, 2026-12-06), a tenth to a fifth of Sponza's build; the finished grid's
/// arrays move onto huge pages at the end (collapse_into_huge_pages), which traversal needs.
/// Thread-safe: the octree builder's threads grow their buffers concurrently.
class HostPool {
 public:
  HostPool() = default;
  HostPool(const HostPool&) = delete;
  HostPool& operator=(const HostPool&) = delete;
  /// Every block must have been released.
  ~HostPool() { trim(); }

  /// `bytes` of host memory (aligned to 64 bytes, to the huge page size from that size up);
  /// throws std::bad_alloc when the system has none left.
  void* allocate(std::size_t bytes);
  /// Returns a block that allocate(bytes) gave, with the same `bytes`.
  void release(void* pointer, std::size_t bytes) noexcept;
  /// Moves the block that allocate(bytes) gave at `pointer` onto huge pages, to its end
  /// (collapse_into_huge_pages; blocks from the huge-page size up are aligned to it and whole
  /// huge pages); nothing for smaller blocks. Returns whether the kernel moved it.
  bool move_onto_huge_pages(void* pointer, std::size_t bytes) noexcept;
  /// Returns every cached block to the system (after a one-off build, whose cached blocks would
  /// otherwise hold its peak for the grid's life).
  void trim() noexcept;
  /// Bounds what the pool holds, given-out blocks and cached ones together, by `bytes` (0: no
  /// bound), by returning cached blocks to the system, the least recently freed first. Blocks
  /// in use are never taken back, so the pool may hold more while they do. A build sets its
  /// construction budget here: without it, arrays that grow phase after phase (the octree
  /// levels of a budget-limited build) left the pool holding every size they had passed
  /// through, twice the build's live peak on builtin:hairball:10000000.
  void set_cache_limit(std::uint64_t bytes) noexcept;
  /// With `on`, the pool also holds at most the most bytes it has given out at once: when a
  /// request must come from the system, cached blocks go back first, the least recently freed
  /// first, until it would. For a one-off build: its process then holds the build's peak, not
  /// that peak plus a cached block of every size the build passed through. Rebuilds want the
  /// opposite (every size cached, so that a frame allocates nothing), hence the switch.
  void set_bound_to_peak(bool on) noexcept;

  /// Blocks that came from the system rather than from the cache, since construction.
  std::uint64_t fresh_allocations() const;
  /// Bytes of cached (free) blocks.
  std::uint64_t cached_bytes() const;

  /// The size a request of `bytes` is rounded up to.
  static std::size_t class_bytes(std::size_t bytes) noexcept;

 private:
  /// A free block and when it was freed (a count of releases), for least-recently-freed order.
  struct Cached {
    void* pointer;
    std::uint64_t freed_at;
  };

  static void* system_allocate(std::size_t class_size);
  /// Gives a block back to the system. Called with mutex_ held.
  void system_release(void* pointer, std::size_t class_size) noexcept;
  /// Returns the least recently freed cached blocks to the system until the pool is within its
  /// limit (and, bound to its peak, within given_peak_) or holds none cached. Called with
  /// mutex_ held.
  void evict_past_limit() noexcept;

  mutable std::mutex mutex_;
  /// Free blocks by class size; each class's oldest first.
  std::map<std::size_t, std::vector<Cached>> cached_;
  std::unordered_map<void*, std::size_t> larger_;  ///< blocks given out for a smaller class
  std::uint64_t fresh_ = 0, cached_bytes_ = 0, given_bytes_ = 0, releases_ = 0, limit_ = 0;
  /// The most bytes given out at once since construction, and whether it bounds the pool.
  std::uint64_t given_peak_ = 0;
  bool bound_to_peak_ = false;
  /// Bytes of blocks given back since malloc last returned its free pages.
  std::uint64_t heap_released_ = 0;
};

}  // namespace irgrid
