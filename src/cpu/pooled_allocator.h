// cpu/pooled_allocator.h: the allocator of the CPU executor's buffers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>
#include <utility>

#include "cpu/host_pool.h"
#include "cpu/memory_meter.h"

namespace irgrid {

/// MeteredAllocator's behaviour (bytes counted by MemoryMeter, huge pages for large buffers,
/// elements default-initialised), with the blocks taken from a HostPool when the allocator
/// carries one. The pool travels with the buffer: moving or swapping buffers moves their
/// allocators too, so each block goes back to the pool that gave it.
template <typename T>
struct PooledAllocator : DefaultInitConstruct {
  using value_type = T;
  using propagate_on_container_move_assignment = std::true_type;
  using propagate_on_container_copy_assignment = std::true_type;
  using propagate_on_container_swap = std::true_type;
  using is_always_equal = std::false_type;

  HostPool* pool = nullptr;  ///< null: the system allocator, as MeteredAllocator does

  PooledAllocator() = default;
  explicit PooledAllocator(HostPool* from) noexcept : pool(from) {}
  template <typename U>
  PooledAllocator(const PooledAllocator<U>& other) noexcept : pool(other.pool) {}

  T* allocate(std::size_t n) {
    if (!pool) return MeteredAllocator<T>().allocate(n);
    if (n > std::size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
    T* p = static_cast<T*>(pool->allocate(n * sizeof(T)));
    MemoryMeter::add(std::int64_t(n * sizeof(T)));
    return p;
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (!pool) return MeteredAllocator<T>().deallocate(p, n);
    MemoryMeter::add(-std::int64_t(n * sizeof(T)));
    pool->release(p, n * sizeof(T));
  }
  template <typename U>
  bool operator==(const PooledAllocator<U>& other) const noexcept {
    return pool == other.pool;
  }
};

}  // namespace irgrid
