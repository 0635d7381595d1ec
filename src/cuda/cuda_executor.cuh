// cuda/cuda_executor.cuh: the CUDA executor: the CpuExecutor's primitives on one stream.
//
// for_each is a generic grid-stride kernel over a __host__ __device__ lambda; scans,
// reductions, radix sorts and selections are thin wrappers over CUB. Every build phase in
// src/core/build is written against these calls only, so the same templates build the grid on
// both backends. Results equal the CPU executor's bit for bit: scans and reductions are used on
// integers and on float min/max only (exact in any grouping), the radix sort and the flagged
// selection are stable.
#pragma once

#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/transform_iterator.h>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_select.cuh>

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <type_traits>

#include "core/construction/device_build_path.h"
#include "cuda/device_buffer.cuh"
#include "irgrid/error.h"

namespace irgrid {

namespace cuda_detail {

template <typename F>
__global__ void for_each_kernel(std::size_t n, F body) {
  const std::size_t stride = std::size_t(gridDim.x) * blockDim.x;
  for (std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x; i < n; i += stride)
    body(i);
}

template <typename Pred, typename T>
__global__ void flag_kernel(std::size_t n, const T* in, std::uint8_t* flags, Pred keep) {
  const std::size_t stride = std::size_t(gridDim.x) * blockDim.x;
  for (std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x; i < n; i += stride)
    flags[i] = keep(i, in[i]) ? 1 : 0;
}

/// Blocks for a grid-stride launch over n items.
inline unsigned launch_blocks(std::size_t n, unsigned threads) {
  const std::size_t wanted = (n + threads - 1) / threads;
  return unsigned(wanted < (std::size_t(1) << 20) ? wanted : (std::size_t(1) << 20));
}

}  // namespace cuda_detail

/// Runs the build's data-parallel primitives on one CUDA stream (see CpuExecutor for the
/// contract of every call; the differences are noted here). Buffers live in device memory and
/// come from the executor's DevicePool, which must outlive them: keep the executor alive as long
/// as the grid it built. Calls that return a value to the host (scan totals, reductions,
/// selection counts) wait for the stream; the rest only enqueue work. Its build flags
/// (DeviceBuildPath) pick the phases' GPU ways.
class CudaExecutor : public DeviceBuildPath {
 public:
  template <typename T>
  using Buffer = cuda::DeviceBuffer<T>;

  CudaExecutor() { IRGRID_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking)); }
  ~CudaExecutor() {
    if (stream_) cudaStreamDestroy(stream_);
  }
  CudaExecutor(const CudaExecutor&) = delete;
  CudaExecutor& operator=(const CudaExecutor&) = delete;

  template <typename T>
  Buffer<T> allocate(std::size_t n) const {
    return Buffer<T>(n, "grid build buffer", pool_.get(), stream_);
  }

  template <typename F>
  void for_each(const char* name, std::size_t n, F&& body) const {
    if (n == 0) return;
    cuda_detail::for_each_kernel<<<cuda_detail::launch_blocks(n, kThreads), kThreads, 0, stream_>>>(
        n, body);
    cuda::check(cudaGetLastError(), name, __FILE__, __LINE__);
  }

  template <typename T>
  T exclusive_scan(const char* name, const T* in, T* out, std::size_t n) const {
    static_assert(std::is_integral_v<T>,
                  "exclusive_scan is exact (deterministic) on integers only");
    if (n == 0) return T(0);
    T last_in{};
    copy_to_host(&last_in, in + n - 1, name);  // before the scan: in may be out
    run_cub(name, [&](void* scratch, std::size_t& bytes) {
      return cub::DeviceScan::ExclusiveSum(scratch, bytes, in, out, n, stream_);
    });
    T last_out{};
    copy_to_host(&last_out, out + n - 1, name);
    return T(last_out + last_in);
  }

  template <typename T, typename Op>
  T reduce(const char* name, const T* in, std::size_t n, T init, Op op) const {
    return transform_reduce(name, n, init, op,
                            [in] __host__ __device__(std::size_t i) { return in[i]; });
  }

  template <typename T, typename Op, typename F>
  T transform_reduce(const char* name, std::size_t n, T init, Op op, F f) const {
    if (n == 0) return init;
    const auto items =
        thrust::make_transform_iterator(thrust::counting_iterator<std::size_t>(0), f);
    const auto result = allocate<T>(1);
    run_cub(name, [&](void* scratch, std::size_t& bytes) {
      return cub::DeviceReduce::Reduce(scratch, bytes, items, result.data(), n, op, init, stream_);
    });
    T value{};
    copy_to_host(&value, result.data(), name);
    return value;
  }

  /// Stable radix sort by the low key_bits bits (CUB's DeviceRadixSort::SortPairs), then the
  /// sorted copies go back into keys and values.
  template <typename K, typename V>
  void sort_pairs(const char* name, K* keys, V* values, std::size_t n, int key_bits) const {
    if (key_bits < 0 || key_bits > int(8 * sizeof(K)))
      throw Error(ErrorCode::invalid_argument,
                  std::string(name) + ": key_bits = " + std::to_string(key_bits) + " outside [0, " +
                      std::to_string(8 * sizeof(K)) + "]");
    if (n <= 1 || key_bits == 0) return;
    auto keys_out = allocate<K>(n);
    auto values_out = allocate<V>(n);
    run_cub(name, [&](void* scratch, std::size_t& bytes) {
      return cub::DeviceRadixSort::SortPairs(scratch, bytes, keys, keys_out.data(), values,
                                             values_out.data(), n, 0, key_bits, stream_);
    });
    cuda::check(
        cudaMemcpyAsync(keys, keys_out.data(), n * sizeof(K), cudaMemcpyDeviceToDevice, stream_),
        name, __FILE__, __LINE__);
    cuda::check(cudaMemcpyAsync(values, values_out.data(), n * sizeof(V), cudaMemcpyDeviceToDevice,
                                stream_),
                name, __FILE__, __LINE__);
  }

  /// Stable: flags from keep(i, in[i]), then CUB's DeviceSelect::Flagged, which keeps the
  /// selected items in order (unlike a flagged partition, nothing is reversed).
  template <typename T, typename Pred>
  std::size_t select_if(const char* name, const T* in, T* out, std::size_t n, Pred keep) const {
    if (n == 0) return 0;
    auto flags = allocate<std::uint8_t>(n);
    cuda_detail::flag_kernel<<<cuda_detail::launch_blocks(n, kThreads), kThreads, 0, stream_>>>(
        n, in, flags.data(), keep);
    cuda::check(cudaGetLastError(), name, __FILE__, __LINE__);
    const auto selected = allocate<std::uint64_t>(1);
    run_cub(name, [&](void* scratch, std::size_t& bytes) {
      return cub::DeviceSelect::Flagged(scratch, bytes, in, flags.data(), out, selected.data(), n,
                                        stream_);
    });
    std::uint64_t count = 0;
    copy_to_host(&count, selected.data(), name);
    return std::size_t(count);
  }

  /// Waits for the stream and reports any asynchronous kernel error.
  void synchronize() const {
    cuda::check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize", __FILE__, __LINE__);
  }

  /// Phase times come from PhaseClock (wall time between stream synchronisations); the
  /// individual primitives are not timed on the device, so this stays empty.
  const std::map<std::string, double>& profile_ms() const { return profile_ms_; }
  void reset_profile() { profile_ms_.clear(); }

  cudaStream_t stream() const { return stream_; }
  cuda::DevicePool& pool() const { return *pool_; }
  /// Bounds the bytes the pool keeps cached by the construction budget
  /// (CpuExecutor::limit_cached_memory).
  void limit_cached_memory(std::uint64_t bytes) const { pool_->set_cache_limit(bytes); }
  /// The most bytes the pool gave out at once since reset_memory_peak()
  /// (CpuExecutor::memory_peak).
  std::uint64_t memory_peak() const { return pool_->peak(); }
  void reset_memory_peak() const { pool_->reset_peak(); }

 private:
  static constexpr unsigned kThreads = 256;

  /// Runs a CUB device algorithm: call(scratch, bytes) once with a null scratch to learn the
  /// size, then with scratch memory from the pool. The scratch is never null on the second call
  /// (a null pointer would make it another size query that does no work).
  template <typename Call>
  void run_cub(const char* name, Call&& call) const {
    std::size_t bytes = 0;
    cuda::check(call(nullptr, bytes), name, __FILE__, __LINE__);
    const auto scratch = allocate<std::uint8_t>(bytes > 0 ? bytes : 1);
    cuda::check(call(scratch.data(), bytes), name, __FILE__, __LINE__);
  }

  /// Copies one value to the host, waiting for the stream (and surfacing kernel errors).
  template <typename T>
  void copy_to_host(T* host, const T* device, const char* name) const {
    cuda::check(cudaMemcpyAsync(host, device, sizeof(T), cudaMemcpyDeviceToHost, stream_), name,
                __FILE__, __LINE__);
    cuda::check(cudaStreamSynchronize(stream_), name, __FILE__, __LINE__);
  }

  cudaStream_t stream_ = nullptr;
  std::unique_ptr<cuda::DevicePool> pool_ = std::make_unique<cuda::DevicePool>();
  std::map<std::string, double> profile_ms_;
};

}  // namespace irgrid
