// The CUDA half of GPU arrays in Python (device_kernels.h): memory, streams and three small
// element-wise kernels. Every CUDA call is checked; failures become irgrid::Error.
#include "device_kernels.h"

#include <cuda_runtime.h>

#include <cmath>
#include <string>

#include "hit_split.h"
#include "irgrid/error.h"

namespace irgrid::python::gpu {
namespace {

void check(cudaError_t result, const char* what) {
  if (result == cudaSuccess) return;
  const ErrorCode code = result == cudaErrorMemoryAllocation ? ErrorCode::out_of_memory
                         : result == cudaErrorNoDevice || result == cudaErrorInsufficientDriver
                             ? ErrorCode::no_device
                             : ErrorCode::internal;
  throw Error(code, std::string(what) + ": " + cudaGetErrorString(result));
}

constexpr unsigned kBlock = 256;

unsigned blocks(std::size_t n) {
  return unsigned((n + kBlock - 1) / kBlock);
}

__global__ void pack_rays_kernel(const float* rows, std::size_t n, const float* tmin,
                                 float tmin_value, const float* tmax, float tmax_value, Ray* out) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float* r = rows + 6 * i;
  out[i] = {{r[0], r[1], r[2]},
            tmin ? tmin[i] : tmin_value,
            {r[3], r[4], r[5]},
            tmax ? tmax[i] : tmax_value};
}

__global__ void split_hits_kernel(const Hit* hits, std::size_t n, const float* triangle_normals,
                                  float* t, std::uint32_t* prim, float* uv, float* normals) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  split_hit(i, hits[i], triangle_normals, t, prim, uv, normals);
}

__global__ void occlusions_kernel(const Hit* hits, std::size_t n, bool* occluded) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) occluded[i] = hits[i].prim != kNoHit;
}

}  // namespace

bool available() noexcept {
  return true;
}

void FreeDevice::operator()(void* p) const noexcept {
  cudaFree(p);
}

DeviceMemory allocate(std::size_t bytes, const char* what) {
  void* p = nullptr;
  const cudaError_t result = cudaMalloc(&p, bytes > 0 ? bytes : 1);
  if (result != cudaSuccess) {
    cudaGetLastError();  // so that the next call does not report this failure again
    throw Error(ErrorCode::out_of_memory, std::string(what) + ": cannot allocate " +
                                              std::to_string(bytes) + " bytes on the GPU (" +
                                              cudaGetErrorString(result) + ")");
  }
  return DeviceMemory(p);
}

void upload(void* device, const void* host, std::size_t bytes) {
  if (bytes > 0) check(cudaMemcpy(device, host, bytes, cudaMemcpyHostToDevice), "cudaMemcpy");
}

int current_device() {
  int device = 0;
  check(cudaGetDevice(&device), "cudaGetDevice");
  return device;
}

int device_of(const void* pointer) {
  cudaPointerAttributes attributes{};
  if (cudaPointerGetAttributes(&attributes, pointer) != cudaSuccess) {
    cudaGetLastError();
    return -1;
  }
  switch (attributes.type) {
    case cudaMemoryTypeDevice:
    case cudaMemoryTypeManaged:
    case cudaMemoryTypeHost:  // pinned: readable by kernels of its device
      return attributes.device;
    default:
      return -1;
  }
}

void wait_for(Stream consumer, Stream producer) {
  if (consumer == producer) return;
  cudaEvent_t event;
  check(cudaEventCreateWithFlags(&event, cudaEventDisableTiming), "cudaEventCreate");
  const cudaError_t recorded = cudaEventRecord(event, producer);
  const cudaError_t waited =
      recorded == cudaSuccess ? cudaStreamWaitEvent(consumer, event, 0) : recorded;
  cudaEventDestroy(event);  // released once the wait is done; the wait stays queued
  check(waited, "cudaStreamWaitEvent (stream of the input array)");
}

Scratch::Scratch(std::size_t bytes, Stream stream) : stream_(stream) {
  const cudaError_t result = cudaMallocAsync(&data_, bytes > 0 ? bytes : 1, stream);
  if (result != cudaSuccess) {
    cudaGetLastError();
    throw Error(ErrorCode::out_of_memory, "cannot allocate " + std::to_string(bytes) +
                                              " bytes of scratch memory on the GPU (" +
                                              cudaGetErrorString(result) + ")");
  }
}

Scratch::~Scratch() {
  cudaFreeAsync(data_, stream_);
}

void pack_rays(const float* rows, std::size_t n, const float* tmin, float tmin_value,
               const float* tmax, float tmax_value, Ray* out, Stream stream) {
  if (n == 0) return;
  pack_rays_kernel<<<blocks(n), kBlock, 0, stream>>>(rows, n, tmin, tmin_value, tmax, tmax_value,
                                                     out);
  check(cudaGetLastError(), "pack_rays launch");
}

void split_hits(const Hit* hits, std::size_t n, const float* triangle_normals, float* t,
                std::uint32_t* prim, float* uv, float* normals, Stream stream) {
  if (n == 0) return;
  split_hits_kernel<<<blocks(n), kBlock, 0, stream>>>(hits, n, triangle_normals, t, prim, uv,
                                                      normals);
  check(cudaGetLastError(), "split_hits launch");
}

void occlusions(const Hit* hits, std::size_t n, bool* occluded, Stream stream) {
  if (n == 0) return;
  occlusions_kernel<<<blocks(n), kBlock, 0, stream>>>(hits, n, occluded);
  check(cudaGetLastError(), "occlusions launch");
}

}  // namespace irgrid::python::gpu
