// cpu/memory_meter.h: counts the bytes the CPU executor's buffers hold, and their peak.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>
#include <utility>

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
  /// Default-initialises instead of value-initialising: a buffer of trivial elements is not
  /// zero-filled (the executor's contract leaves contents unspecified, and every phase writes
  /// before it reads), which saves a pass over memory per allocation.
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  template <typename U>
  bool operator==(const MeteredAllocator<U>&) const noexcept {
    return true;
  }
};

}  // namespace irgrid
