// CUDA device discovery and error checking (host code, compiled by the C++ compiler).
#include <fmt/format.h>

#include "cuda/check.cuh"
#include "irgrid/system.h"

namespace irgrid {
namespace cuda {

void check(cudaError_t result, const char* call, const char* file, int line) {
  if (result == cudaSuccess) return;
  const ErrorCode code = result == cudaErrorMemoryAllocation ? ErrorCode::out_of_memory
                         : (result == cudaErrorNoDevice || result == cudaErrorInsufficientDriver)
                             ? ErrorCode::no_device
                             : ErrorCode::internal;
  throw Error(code, fmt::format("cuda: {} failed at {}:{}: {} ({})", call, file, line,
                                cudaGetErrorName(result), cudaGetErrorString(result)));
}

void throw_allocation_error(std::size_t bytes, const char* what) {
  cudaGetLastError();  // clear the allocation error so later calls are not blamed for it
  throw Error(ErrorCode::out_of_memory,
              fmt::format("cuda: cannot allocate {} ({:.1f} MiB needed); {}", what,
                          bytes / 1048576.0, memory_summary()));
}

std::string memory_summary() {
  std::size_t free_bytes = 0, total_bytes = 0;
  if (cudaMemGetInfo(&free_bytes, &total_bytes) != cudaSuccess) return "device memory unknown";
  return fmt::format("{:.1f} MiB free of {:.1f} MiB", free_bytes / 1048576.0,
                     total_bytes / 1048576.0);
}

}  // namespace cuda

CudaStatus cuda_status() {
  CudaStatus status;
  status.compiled = true;
  int driver = 0, runtime = 0;
  cudaDriverGetVersion(&driver);
  cudaRuntimeGetVersion(&runtime);
  int count = 0;
  const cudaError_t result = cudaGetDeviceCount(&count);
  if (result != cudaSuccess) {
    cudaGetLastError();
    status.status =
        driver == 0 ? std::string("no CUDA device: no NVIDIA driver is installed")
        : result == cudaErrorInsufficientDriver
            ? fmt::format("driver too old: driver supports CUDA {}.{}, irgrid needs {}.{}",
                          driver / 1000, driver % 1000 / 10, runtime / 1000, runtime % 1000 / 10)
            : fmt::format("no CUDA device: {}", cudaGetErrorString(result));
    return status;
  }
  for (int i = 0; i < count; ++i) {
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, i) != cudaSuccess) continue;
    GpuInfo gpu;
    gpu.index = i;
    gpu.name = prop.name;
    gpu.memory_bytes = prop.totalGlobalMem;
    gpu.compute_major = prop.major;
    gpu.compute_minor = prop.minor;
    gpu.multiprocessors = prop.multiProcessorCount;
    std::size_t free_bytes = 0, total_bytes = 0;
    if (cudaSetDevice(i) == cudaSuccess && cudaMemGetInfo(&free_bytes, &total_bytes) == cudaSuccess)
      gpu.free_bytes = free_bytes;
    status.gpus.push_back(gpu);
  }
  if (count > 0) cudaSetDevice(0);
  cudaGetLastError();  // a failed probe must not be reported later by an unrelated call
  status.status = fmt::format("driver CUDA {}.{}, runtime {}.{}", driver / 1000, driver % 1000 / 10,
                              runtime / 1000, runtime % 1000 / 10);
  return status;
}

}  // namespace irgrid
