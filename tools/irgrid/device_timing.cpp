// Timing CUDA traces from device memory (kernel and launch, no host copies), as
// ../shared/design/benchmarks.md asks: "kernel/traversal time only, ray generation and copies
// excluded".
#include "device_timing.h"

#include <chrono>

#include <fmt/format.h>

#include "irgrid/error.h"

#if IRGRID_HAS_CUDA
#include <cuda_runtime.h>
#endif

namespace irgrid::cli {
namespace {

#if IRGRID_HAS_CUDA
void check(cudaError_t result, const char* what) {
  if (result != cudaSuccess)
    throw Error(
        result == cudaErrorMemoryAllocation ? ErrorCode::out_of_memory : ErrorCode::internal,
        fmt::format("bench: {} failed: {}", what, cudaGetErrorString(result)));
}

/// A device allocation freed on scope exit.
template <typename T>
struct DeviceArray {
  T* data = nullptr;
  explicit DeviceArray(std::size_t count) {
    check(cudaMalloc(&data, count * sizeof(T)), "cudaMalloc of the bench's rays and hits");
  }
  ~DeviceArray() { cudaFree(data); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
};
#endif

}  // namespace

std::vector<double> time_device_traces(const Accelerator& accelerator, std::span<const Ray> rays,
                                       std::span<Hit> hits, Query query, int repeat) {
#if IRGRID_HAS_CUDA
  std::vector<double> times;
  if (rays.empty()) return std::vector<double>(std::size_t(repeat), 0.0);
  DeviceArray<Ray> d_rays(rays.size());
  DeviceArray<Hit> d_hits(rays.size());
  check(cudaMemcpy(d_rays.data, rays.data(), rays.size_bytes(), cudaMemcpyHostToDevice),
        "uploading the rays");
  const auto trace = [&] {
    accelerator.trace_device(d_rays.data, d_hits.data, rays.size(), query, nullptr);
    check(cudaDeviceSynchronize(), "the traversal kernel");
  };
  trace();  // warm-up
  for (int i = 0; i < repeat; ++i) {
    const auto start = std::chrono::steady_clock::now();
    trace();
    times.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
  }
  check(cudaMemcpy(hits.data(), d_hits.data, rays.size() * sizeof(Hit), cudaMemcpyDeviceToHost),
        "downloading the hits");
  return times;
#else
  (void)accelerator, (void)rays, (void)hits, (void)query, (void)repeat;
  throw Error(ErrorCode::invalid_argument, "bench: this build has no CUDA backend");
#endif
}

}  // namespace irgrid::cli
