// python/src/device_kernels.h: the CUDA side of GPU arrays in Python: device memory, streams,
// and kernels that turn (n, 6) rays into irgrid rays and hits into the arrays Python returns.
// Plain C++ declarations, so that the nanobind code never sees CUDA headers; a build without
// CUDA links device_kernels_none.cpp, whose functions throw.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "irgrid/ray.h"

struct CUstream_st;

namespace irgrid::python::gpu {

using Stream = CUstream_st*;

/// Whether this extension was built with CUDA (false: every other function throws Error).
bool available() noexcept;

/// Device memory from cudaMalloc, freed with cudaFree (which waits for the device's queued
/// work, so memory handed to Python may be dropped at any time).
struct FreeDevice {
  void operator()(void* p) const noexcept;
};
using DeviceMemory = std::unique_ptr<void, FreeDevice>;

/// `bytes` of device memory on the current device (at least one byte). Throws
/// Error{out_of_memory} naming `what`.
DeviceMemory allocate(std::size_t bytes, const char* what);

/// Copies `bytes` from host to device memory and waits.
void upload(void* device, const void* host, std::size_t bytes);

/// The current CUDA device of this thread.
int current_device();

/// The device that holds `pointer`, or -1 for memory a kernel cannot read (host memory that is
/// neither pinned nor managed).
int device_of(const void* pointer);

/// Makes `consumer` wait for the work queued so far on `producer` (an event between them).
void wait_for(Stream consumer, Stream producer);

/// Stream-ordered scratch memory: allocated and freed on `stream` (cudaMallocAsync).
class Scratch {
 public:
  Scratch(std::size_t bytes, Stream stream);
  ~Scratch();
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  void* get() const { return data_; }

 private:
  void* data_ = nullptr;
  Stream stream_;
};

/// out[i] = ray i of `rows` (n rows of origin xyz, direction xyz) over [tmin, tmax], where a
/// null `tmin` / `tmax` array means the same value for every ray. Queued on `stream`.
void pack_rays(const float* rows, std::size_t n, const float* tmin, float tmin_value,
               const float* tmax, float tmax_value, Ray* out, Stream stream);

/// The closest hits as Python returns them (what the library's trace writes into HitArrays for
/// host rays): t (inf on a miss), primitive id, uv and the hit triangle's normal from
/// `triangle_normals` (zero on a miss). Queued on `stream`.
void split_hits(const Hit* hits, std::size_t n, const float* triangle_normals, float* t,
                std::uint32_t* prim, float* uv, float* normals, Stream stream);

/// occluded[i] = hits[i] is a hit. Queued on `stream`.
void occlusions(const Hit* hits, std::size_t n, bool* occluded, Stream stream);

}  // namespace irgrid::python::gpu
