// Device-resident timing for `bench` (device_timing.h): plain CUDA runtime calls, no kernels.
#include "device_timing.h"

#include <fmt/format.h>

#include "irgrid/error.h"

#if IRGRID_HAS_CUDA
#include <cuda_runtime.h>
#endif

namespace irgrid::cli {

#if IRGRID_HAS_CUDA
namespace {

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess)
    throw Error(
        status == cudaErrorMemoryAllocation ? ErrorCode::out_of_memory : ErrorCode::internal,
        fmt::format("bench device timing: {} failed: {}", what, cudaGetErrorString(status)));
}

/// Device memory freed on every path out of time_trace_on_device.
struct DeviceBlock {
  void* pointer = nullptr;
  DeviceBlock(std::size_t bytes, const char* what) { check(cudaMalloc(&pointer, bytes), what); }
  ~DeviceBlock() { cudaFree(pointer); }
  DeviceBlock(const DeviceBlock&) = delete;
  DeviceBlock& operator=(const DeviceBlock&) = delete;
};

struct EventPair {
  cudaEvent_t start = nullptr, stop = nullptr;
  EventPair() {
    check(cudaEventCreate(&start), "cudaEventCreate");
    check(cudaEventCreate(&stop), "cudaEventCreate");
  }
  ~EventPair() {
    cudaEventDestroy(start);
    cudaEventDestroy(stop);
  }
  EventPair(const EventPair&) = delete;
  EventPair& operator=(const EventPair&) = delete;
};

}  // namespace

std::optional<DeviceTiming> time_trace_on_device(const Accelerator& accelerator,
                                                 std::span<const Ray> rays, Query query,
                                                 int repeat) {
  if (accelerator.backend() != Backend::cuda || rays.empty()) return std::nullopt;
  DeviceBlock d_rays(rays.size_bytes(), "cudaMalloc of the rays");
  DeviceBlock d_hits(rays.size() * sizeof(Hit), "cudaMalloc of the hits");
  check(cudaMemcpy(d_rays.pointer, rays.data(), rays.size_bytes(), cudaMemcpyHostToDevice),
        "upload of the rays");
  // Poisoned, so that a launch that leaves a hit unwritten shows up as a difference from trace().
  check(cudaMemset(d_hits.pointer, 0xff, rays.size() * sizeof(Hit)), "cudaMemset of the hits");
  const auto* device_rays = static_cast<const Ray*>(d_rays.pointer);
  auto* device_hits = static_cast<Hit*>(d_hits.pointer);
  EventPair events;
  DeviceTiming timing;
  accelerator.trace_device(device_rays, device_hits, rays.size(), query);  // warm-up
  check(cudaDeviceSynchronize(), "the warm-up launch");
  for (int i = 0; i < repeat; ++i) {
    check(cudaEventRecord(events.start), "cudaEventRecord");
    accelerator.trace_device(device_rays, device_hits, rays.size(), query);
    check(cudaEventRecord(events.stop), "cudaEventRecord");
    check(cudaEventSynchronize(events.stop), "a timed launch");
    float ms = 0;
    check(cudaEventElapsedTime(&ms, events.start, events.stop), "cudaEventElapsedTime");
    timing.times_ms.push_back(ms);
  }
  timing.hits.resize(rays.size());
  check(cudaMemcpy(timing.hits.data(), d_hits.pointer, rays.size() * sizeof(Hit),
                   cudaMemcpyDeviceToHost),
        "download of the hits");
  return timing;
}

#else

std::optional<DeviceTiming> time_trace_on_device(const Accelerator&, std::span<const Ray>, Query,
                                                 int) {
  return std::nullopt;
}

#endif

}  // namespace irgrid::cli
