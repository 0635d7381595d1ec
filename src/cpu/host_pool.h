// cpu/host_pool.h: the CPU build's memory arena, so that rebuilds take no memory from the system.
#pragma once

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace irgrid {

/// Host memory arena with statistics, the CPU counterpart of cuda::DevicePool. Blocks freed
/// during a build go back to the pool instead of to the system, so a rebuild of a frame that
/// needs no larger arrays finds its blocks cached: no page faults, no zero-filling by the
/// kernel, no new mappings. Sizes round up to four classes per power of two (at most 25% unused
/// per block), and a request takes only a block of its own class: a class then holds as many
/// blocks as the most that any build held at once, so a rebuild allocates only when it holds
/// more blocks of a class at once than every earlier build did (which the octree builder's
/// threads can do by finishing in another order). Thread-safe: those threads grow their buffers
/// concurrently.
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
  /// Returns every cached block to the system (after a one-off build, whose cached blocks would
  /// otherwise hold its peak for the grid's life).
  void trim() noexcept;

  /// Blocks that came from the system rather than from the cache, since construction.
  std::uint64_t fresh_allocations() const;
  /// Bytes of cached (free) blocks.
  std::uint64_t cached_bytes() const;

  /// The size a request of `bytes` is rounded up to.
  static std::size_t class_bytes(std::size_t bytes) noexcept;

 private:
  static void* system_allocate(std::size_t class_size);
  static void system_release(void* pointer, std::size_t class_size) noexcept;

  mutable std::mutex mutex_;
  std::unordered_map<std::size_t, std::vector<void*>> cached_;  ///< free blocks by class size
  std::uint64_t fresh_ = 0, cached_bytes_ = 0;
};

}  // namespace irgrid
