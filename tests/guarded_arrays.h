// tests/guarded_arrays.h: arrays that end where an inaccessible page begins, so that any read
// past their last element faults at once. AddressSanitizer does not see SIMD gathers and masked
// loads, so the tests of the build's lanes give them their inputs and outputs from here.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstring>
#include <new>
#include <type_traits>
#include <vector>

namespace irgrid::testing {

/// Owns the mappings of the arrays it makes; they live as long as it does.
class GuardedArrays {
 public:
  GuardedArrays() = default;
  GuardedArrays(const GuardedArrays&) = delete;
  GuardedArrays& operator=(const GuardedArrays&) = delete;
  ~GuardedArrays() {
    for (const Mapping& m : mappings_)
      munmap(m.base, m.bytes);
  }

  /// n elements of T, zero-filled, the last one just before a PROT_NONE page.
  template <typename T>
  T* make(std::size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto page = std::size_t(sysconf(_SC_PAGESIZE));
    const std::size_t bytes = (n * sizeof(T) + page - 1) / page * page;
    void* mapped =
        mmap(nullptr, bytes + page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) throw std::bad_alloc();
    char* base = static_cast<char*>(mapped);
    mappings_.push_back({base, bytes + page});
    if (mprotect(base + bytes, page, PROT_NONE) != 0) throw std::bad_alloc();
    // sizeof(T) is a multiple of alignof(T), and the page boundary is aligned for any T.
    return reinterpret_cast<T*>(base + bytes - n * sizeof(T));
  }

  /// A copy of `values` placed as make() places its arrays.
  template <typename T, typename Allocator>
  T* copy(const std::vector<T, Allocator>& values) {
    T* out = make<T>(values.size());
    if (!values.empty())
      std::memcpy(static_cast<void*>(out), values.data(), values.size() * sizeof(T));
    return out;
  }

 private:
  struct Mapping {
    char* base;
    std::size_t bytes;
  };
  std::vector<Mapping> mappings_;
};

}  // namespace irgrid::testing
