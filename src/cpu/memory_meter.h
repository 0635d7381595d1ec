// cpu/memory_meter.h: counts the bytes the CPU executor's buffers hold, and their peak.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <new>

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

/// std::allocator that reports to MemoryMeter.
template <typename T>
struct MeteredAllocator {
  using value_type = T;
  MeteredAllocator() = default;
  template <typename U>
  MeteredAllocator(const MeteredAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) {
    T* p = std::allocator<T>().allocate(n);
    MemoryMeter::add(std::int64_t(n * sizeof(T)));
    return p;
  }
  void deallocate(T* p, std::size_t n) noexcept {
    MemoryMeter::add(-std::int64_t(n * sizeof(T)));
    std::allocator<T>().deallocate(p, n);
  }
  template <typename U>
  bool operator==(const MeteredAllocator<U>&) const noexcept {
    return true;
  }
};

}  // namespace irgrid
