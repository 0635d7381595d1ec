// cuda/device_pool.cuh: the build's device memory arena, a caching allocator from CUB.
//
// Buffers freed during a build go back to the pool instead of cudaFree, so a rebuild of the same
// scene finds every block it asks for already cached and allocates nothing from the driver.
#pragma once

#include <cub/util_allocator.cuh>

#include <cstddef>
#include <cstdint>

#include "cuda/check.cuh"

namespace irgrid::cuda {

/// Device memory arena with statistics. Sizes round up to powers of two from 256 B to 2 GiB, so
/// a block freed by one phase serves any request of its size class later; larger requests go to
/// the driver each time.
class DevicePool {
 public:
  // Bins 2^8 .. 2^31: CUB computes the largest bin size in `unsigned int`, so 2^31 is the top.
  DevicePool() : allocator_(2u, 8u, 31u, kUnlimited) {}
  DevicePool(const DevicePool&) = delete;
  DevicePool& operator=(const DevicePool&) = delete;

  /// `bytes` of device memory usable on `stream`; throws Error(out_of_memory) naming `what`,
  /// the size and the free memory when it does not fit.
  void* allocate(std::size_t bytes, const char* what, cudaStream_t stream) {
    if (bytes == 0) return nullptr;
    const std::uint64_t before = reserved_bytes();
    void* pointer = nullptr;
    cudaError_t result = allocator_.DeviceAllocate(&pointer, bytes, stream);
    if (result == cudaErrorMemoryAllocation) {
      allocator_.FreeAllCached();
      cudaGetLastError();
      result = allocator_.DeviceAllocate(&pointer, bytes, stream);
    }
    if (result == cudaErrorMemoryAllocation) throw_allocation_error(bytes, what);
    check(result, what, __FILE__, __LINE__);
    if (reserved_bytes() > before) ++fresh_allocations_;
    in_use_ += bytes;
    peak_ = in_use_ > peak_ ? in_use_ : peak_;
    return pointer;
  }

  void release(void* pointer, std::size_t bytes) noexcept {
    if (!pointer) return;
    allocator_.DeviceFree(pointer);
    in_use_ -= bytes;
  }

  /// Returns every cached block to the driver (after a one-off build: the arena pays off only
  /// for rebuilds, and cached blocks would otherwise hold the build's peak for the grid's life).
  void trim() { allocator_.FreeAllCached(); }
  /// Keeps at most `bytes` cached (0: no bound); blocks freed past it go back to the driver.
  void set_cache_limit(std::uint64_t bytes) {
    check(allocator_.SetMaxCachedBytes(bytes == 0 ? kUnlimited : std::size_t(bytes)),
          "device pool cache limit", __FILE__, __LINE__);
  }

  /// Allocations that reached the driver (not served from the cache) since construction.
  std::uint64_t fresh_allocations() const { return fresh_allocations_; }
  /// Bytes requested and not yet released, and their peak since reset_peak().
  std::uint64_t in_use() const { return in_use_; }
  std::uint64_t peak() const { return peak_; }
  void reset_peak() { peak_ = in_use_; }

 private:
  static constexpr std::size_t kUnlimited = ~std::size_t(0);

  std::uint64_t reserved_bytes() {
    int device = 0;
    cudaGetDevice(&device);
    const auto& totals = allocator_.cached_bytes[device];
    return totals.free + totals.live;
  }

  cub::CachingDeviceAllocator allocator_;
  std::uint64_t fresh_allocations_ = 0, in_use_ = 0, peak_ = 0;
};

}  // namespace irgrid::cuda
