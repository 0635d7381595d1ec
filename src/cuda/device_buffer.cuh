// cuda/device_buffer.cuh: an owning, typed device allocation; an OOM names the sizes involved.
#pragma once

#include <cstddef>
#include <utility>

#include "cuda/check.cuh"

namespace irgrid::cuda {

template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t count, const char* what) : count_(count) {
    if (count == 0) return;
    const cudaError_t result = cudaMalloc(&data_, count * sizeof(T));
    if (result == cudaErrorMemoryAllocation) throw_allocation_error(count * sizeof(T), what);
    check(result, what, __FILE__, __LINE__);
  }
  ~DeviceBuffer() {
    if (data_) cudaFree(data_);
  }
  DeviceBuffer(DeviceBuffer&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), count_(std::exchange(other.count_, 0)) {}
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(count_, other.count_);
    return *this;
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  T* data() const { return data_; }
  std::size_t size() const { return count_; }

  /// Copies `count` elements from the host; count must not exceed size().
  void upload(const T* host, std::size_t count) {
    IRGRID_CUDA_CHECK(cudaMemcpy(data_, host, count * sizeof(T), cudaMemcpyHostToDevice));
  }
  void download(T* host, std::size_t count) const {
    IRGRID_CUDA_CHECK(cudaMemcpy(host, data_, count * sizeof(T), cudaMemcpyDeviceToHost));
  }

 private:
  T* data_ = nullptr;
  std::size_t count_ = 0;
};

}  // namespace irgrid::cuda
