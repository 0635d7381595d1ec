// cuda/device_buffer.cuh: an owning, typed device allocation; an OOM names the sizes involved.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "cuda/check.cuh"
#include "cuda/device_pool.cuh"

namespace irgrid::cuda {

/// n elements of T in device memory, from cudaMalloc or, when given one, from a DevicePool
/// (which must outlive the buffer). Contents start unspecified.
template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(std::size_t count, const char* what, DevicePool* pool = nullptr,
               cudaStream_t stream = nullptr)
      : count_(count), pool_(pool) {
    if (count == 0) return;
    if (pool) {
      data_ = static_cast<T*>(pool->allocate(count * sizeof(T), what, stream));
      return;
    }
    const cudaError_t result = cudaMalloc(&data_, count * sizeof(T));
    if (result == cudaErrorMemoryAllocation) throw_allocation_error(count * sizeof(T), what);
    check(result, what, __FILE__, __LINE__);
  }
  ~DeviceBuffer() { reset(); }
  DeviceBuffer(DeviceBuffer&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)),
        count_(std::exchange(other.count_, 0)),
        pool_(std::exchange(other.pool_, nullptr)) {}
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(count_, other.count_);
    std::swap(pool_, other.pool_);
    return *this;
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  T* data() const { return data_; }
  std::size_t size() const { return count_; }
  bool empty() const { return count_ == 0; }

  /// Frees the memory (back to the pool when it came from one).
  void reset() noexcept {
    if (data_) {
      if (pool_)
        pool_->release(data_, count_ * sizeof(T));
      else
        cudaFree(data_);
    }
    data_ = nullptr;
    count_ = 0;
  }

  /// Copies `count` elements from the host; count must not exceed size(). The copy runs on the
  /// legacy default stream: a pageable copy may return before the data reached the device, so
  /// work on other streams must wait for that stream (or use the overload below).
  void upload(const T* host, std::size_t count) {
    if (count == 0) return;  // an empty buffer's data() is null
    IRGRID_CUDA_CHECK(cudaMemcpy(data_, host, count * sizeof(T), cudaMemcpyHostToDevice));
  }
  /// Copies `count` elements from the host in `stream` order and waits for the copy, so work
  /// enqueued on `stream` afterwards sees the data and `host` may be freed on return.
  void upload(const T* host, std::size_t count, cudaStream_t stream) {
    if (count == 0) return;
    IRGRID_CUDA_CHECK(
        cudaMemcpyAsync(data_, host, count * sizeof(T), cudaMemcpyHostToDevice, stream));
    IRGRID_CUDA_CHECK(cudaStreamSynchronize(stream));
  }
  void download(T* host, std::size_t count) const {
    if (count == 0) return;
    IRGRID_CUDA_CHECK(cudaMemcpy(host, data_, count * sizeof(T), cudaMemcpyDeviceToHost));
  }
  /// Copies every element to the host, into `host` (resized).
  void download_all(std::vector<T>& host) const {
    host.resize(count_);
    if (count_ > 0) download(host.data(), count_);
  }

 private:
  T* data_ = nullptr;
  std::size_t count_ = 0;
  DevicePool* pool_ = nullptr;
};

}  // namespace irgrid::cuda
