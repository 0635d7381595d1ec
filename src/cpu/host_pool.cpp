// The CPU build's memory arena (host_pool.h).
#include "cpu/host_pool.h"

#include <algorithm>
#include <bit>
#include <new>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "cpu/memory_meter.h"

namespace irgrid {
namespace {

constexpr std::size_t kMinClassBytes = 256;
constexpr std::size_t kSmallAlignment = 64;  // a cache line: SIMD loads never straddle blocks

std::size_t alignment_for(std::size_t class_size) {
  return class_size >= kHugePageBytes ? kHugePageBytes : kSmallAlignment;
}

/// Bytes of blocks given back to malloc after which the pool asks it to return the free pages
/// of its heaps to the system (return_heap_pages).
constexpr std::uint64_t kHeapReturnBytes = std::uint64_t(256) << 20;

/// glibc's highest mmap threshold on 64-bit systems: larger blocks are always mapped on their
/// own, and freeing them unmaps them.
constexpr std::size_t kAlwaysMappedBytes = std::size_t(32) << 20;

/// malloc's heaps give the system back only their top: the free pages below stay resident.
/// Small blocks always live there, and so do large ones: glibc maps a block of its own only
/// above its mmap threshold, which rises to the size of each mapped block freed (up to
/// 32 MiB). The depth-first octrees of a 10M-triangle hairball left 4.8 GiB of small blocks
/// behind when the build went on level by level; the large blocks the pool's bound sends back
/// kept Crown's process at 821-826 MiB instead of 681-686 (Intel Xeon VM, 2026-12-07). glibc's
/// malloc_trim also releases free pages inside the heaps.
void return_heap_pages() noexcept {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace

std::size_t HostPool::class_bytes(std::size_t bytes) noexcept {
  if (bytes <= kMinClassBytes) return kMinClassBytes;
  // Keep the top three bits: classes 4, 5, 6 and 7 times a power of two, and whole huge pages
  // from there up (move_onto_huge_pages covers a block to its end).
  const int step_bits = int(std::bit_width(bytes - 1)) - 3;
  std::size_t step = std::size_t(1) << step_bits;
  if (bytes > kHugePageBytes) step = std::max(step, kHugePageBytes);
  return (bytes + step - 1) & ~(step - 1);
}

void* HostPool::system_allocate(std::size_t class_size) {
  return ::operator new(class_size, std::align_val_t(alignment_for(class_size)));
}

void HostPool::system_release(void* pointer, std::size_t class_size) noexcept {
  ::operator delete(pointer, std::align_val_t(alignment_for(class_size)));
  if (class_size > kAlwaysMappedBytes) return;
  heap_released_ += class_size;
  if (heap_released_ >= kHeapReturnBytes) {
    heap_released_ = 0;
    return_heap_pages();
  }
}

void* HostPool::allocate(std::size_t bytes) {
  const std::size_t size = class_bytes(bytes);
  {
    const std::lock_guard lock(mutex_);
    // The smallest cached block of this class or of a larger one up to twice its size.
    for (auto found = cached_.lower_bound(size); found != cached_.end() && found->first <= 2 * size;
         ++found) {
      if (found->second.empty()) continue;
      void* pointer = found->second.back().pointer;
      if (found->first != size) larger_.emplace(pointer, found->first);
      found->second.pop_back();
      cached_bytes_ -= found->first;
      given_bytes_ += found->first;
      return pointer;
    }
    ++fresh_;
    given_bytes_ += size;
    given_peak_ = std::max(given_peak_, given_bytes_);
    evict_past_limit();
  }
  try {
    return system_allocate(size);
  } catch (...) {
    const std::lock_guard lock(mutex_);
    given_bytes_ -= size;
    throw;
  }
}

void HostPool::release(void* pointer, std::size_t bytes) noexcept {
  if (!pointer) return;
  std::size_t size = class_bytes(bytes);
  const std::lock_guard lock(mutex_);
  if (const auto found = larger_.find(pointer); found != larger_.end()) {
    size = found->second;
    larger_.erase(found);
  }
  given_bytes_ -= size;
  try {
    cached_[size].push_back({pointer, ++releases_});
    cached_bytes_ += size;
  } catch (...) {  // no room to file it: give it back instead
    system_release(pointer, size);
  }
}

bool HostPool::move_onto_huge_pages(void* pointer, std::size_t bytes) noexcept {
  std::size_t size = class_bytes(bytes);
  if (!pointer || size < kHugePageBytes) return false;  // malloc's: not aligned to huge pages
  {
    const std::lock_guard lock(mutex_);
    if (const auto found = larger_.find(pointer); found != larger_.end()) size = found->second;
  }
  return collapse_into_huge_pages(pointer, size);
}

void HostPool::trim() noexcept {
  const std::lock_guard lock(mutex_);
  for (auto& [size, blocks] : cached_)
    for (const Cached& block : blocks)
      system_release(block.pointer, size);
  cached_.clear();
  cached_bytes_ = 0;
  // Also the pages of blocks the build freed to malloc directly (its octree builders' stacks).
  heap_released_ = 0;
  return_heap_pages();
}

void HostPool::set_cache_limit(std::uint64_t bytes) noexcept {
  const std::lock_guard lock(mutex_);
  limit_ = bytes;
  evict_past_limit();
}

void HostPool::set_bound_to_peak(bool on) noexcept {
  const std::lock_guard lock(mutex_);
  bound_to_peak_ = on;
}

void HostPool::evict_past_limit() noexcept {
  std::uint64_t bound = limit_;
  if (bound_to_peak_) bound = bound == 0 ? given_peak_ : std::min(bound, given_peak_);
  // Linear in the classes per eviction: a build caches a few dozen classes.
  while (bound != 0 && cached_bytes_ != 0 && given_bytes_ + cached_bytes_ > bound) {
    auto oldest = cached_.end();
    for (auto it = cached_.begin(); it != cached_.end(); ++it)
      if (!it->second.empty() && (oldest == cached_.end() ||
                                  it->second.front().freed_at < oldest->second.front().freed_at))
        oldest = it;
    system_release(oldest->second.front().pointer, oldest->first);
    oldest->second.erase(oldest->second.begin());
    cached_bytes_ -= oldest->first;
    if (oldest->second.empty()) cached_.erase(oldest);
  }
}

std::uint64_t HostPool::fresh_allocations() const {
  const std::lock_guard lock(mutex_);
  return fresh_;
}

std::uint64_t HostPool::cached_bytes() const {
  const std::lock_guard lock(mutex_);
  return cached_bytes_;
}

}  // namespace irgrid
