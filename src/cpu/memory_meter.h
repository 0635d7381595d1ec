// cpu/memory_meter.h: counts the bytes the CPU executor's buffers hold, and their peak.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace irgrid {

/// Process-wide tally of bytes held by MeteredAllocator; builds read the peak to report their
/// transient memory. Concurrent builds in one process share the tally.
class MemoryMeter {
 public:
  static void add(std::int64_t bytes) {
    const std::int64_t now = current_.fetch_add(bytes, std::memory_order_relaxed) + bytes;
    std::int64_t seen = peak_.load(std::memory_order_relaxed);
    while (now > seen && !peak_.compare_exchange_weak(seen, now, std::memory_order_relaxed)) {
    }
  }
  static std::int64_t current() { return current_.load(std::memory_order_relaxed); }
  static std::int64_t peak() { return peak_.load(std::memory_order_relaxed); }
  /// Starts a new peak measurement from the current tally.
  static void reset_peak() { peak_.store(current(), std::memory_order_relaxed); }

 private:
  static inline std::atomic<std::int64_t> current_{0}, peak_{0};
};

/// Buffers of at least this size are aligned to it and asked to be backed by transparent huge
/// pages: the grid's arrays are read at random by incoherent rays, and with 4 KiB pages most of
/// those reads also miss the TLB.
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

/// Asks the kernel for huge pages over [p, p + bytes) (p aligned to kHugePageBytes); a no-op
/// where transparent huge pages are off or unknown.
inline void advise_huge_pages(void* p, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  madvise(p, (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1), MADV_HUGEPAGE);
#else
  (void)p, (void)bytes;
#endif
}

/// Moves the whole huge pages inside [p, p + bytes) onto huge pages now (Linux's MADV_COLLAPSE,
/// 6.1 and later: the kernel copies them into fresh huge pages) and marks them for huge pages,
/// so that older kernels' khugepaged collapses them later. For arrays written on 4 KiB pages
/// and then read at random for a long time: the finished grid. Returns whether the kernel
/// collapsed them (false where unsupported, where transparent huge pages are off, and when
/// the range holds no whole huge page).
inline bool collapse_into_huge_pages(void* p, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr int kCollapse = 25;  // MADV_COLLAPSE, which Debian 12's headers do not name yet
  const auto at = reinterpret_cast<std::uintptr_t>(p), huge = std::uintptr_t(kHugePageBytes);
  const std::uintptr_t first = (at + huge - 1) & ~(huge - 1), last = (at + bytes) & ~(huge - 1);
  if (last <= first) return false;
  void* const start = reinterpret_cast<void*>(first);
  madvise(start, last - first, MADV_HUGEPAGE);
  return madvise(start, last - first, kCollapse) == 0;
#else
  (void)p, (void)bytes;
  return false;
#endif
}

/// The allocators' construct: default-initialises instead of value-initialising, so a buffer of
/// trivial elements is not zero-filled (the executor's contract leaves contents unspecified, and
/// every phase writes before it reads), which saves a pass over memory per allocation.
struct DefaultInitConstruct {
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

/// std::allocator that reports to MemoryMeter.
template <typename T>
struct MeteredAllocator : DefaultInitConstruct {
  using value_type = T;
  MeteredAllocator() = default;
  template <typename U>
  MeteredAllocator(const MeteredAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) {
    if (n > std::size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
    const std::size_t bytes = n * sizeof(T);
    T* p;
    if (bytes >= kHugePageBytes) {
      p = static_cast<T*>(::operator new(bytes, std::align_val_t(kHugePageBytes)));
      advise_huge_pages(p, bytes);
    } else {
      p = std::allocator<T>().allocate(n);
    }
    MemoryMeter::add(std::int64_t(bytes));
    return p;
  }
  void deallocate(T* p, std::size_t n) noexcept {
    const std::size_t bytes = n * sizeof(T);
    MemoryMeter::add(-std::int64_t(bytes));
    if (bytes >= kHugePageBytes)
      ::operator delete(p, std::align_val_t(kHugePageBytes));
    else
      std::allocator<T>().deallocate(p, n);
  }
  template <typename U>
  bool operator==(const MeteredAllocator<U>&) const noexcept {
    return true;
  }
};

}  // namespace irgrid
