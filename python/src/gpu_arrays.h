// python/src/gpu_arrays.h: tracing rays that live in GPU memory (CuPy, PyTorch, JAX, Numba
// arrays) without a host round trip. The Python layer (irgrid/_gpu.py) checks dtypes, shapes
// and layouts and picks the stream; these functions check devices, queue the work on that
// stream and return new device arrays.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstddef>
#include <cstdint>

#include "irgrid/irgrid.h"

namespace irgrid::python {

namespace nb = nanobind;

/// Rays on the device as Python hands them over: `count` rows of 6 float32 (origin, direction)
/// at `rows`, and per-ray tmin / tmax arrays or (null pointers) one value for every ray. The
/// work goes on `stream` (a cudaStream_t; 0 the legacy default stream).
struct DeviceRays {
  std::uintptr_t rows = 0;
  std::size_t count = 0;
  std::uintptr_t tmin = 0;
  float tmin_value = 0;
  std::uintptr_t tmax = 0;
  float tmax_value = 0;
  std::uintptr_t stream = 0;
};

/// The arrays an accelerator on the CUDA backend traces device rays against: the device it was
/// built on and its triangles' unit normals in device memory (3 floats per triangle).
struct DeviceScene {
  const Accelerator* accelerator = nullptr;
  int device = -1;
  const float* normals = nullptr;
};

/// Caller-given device arrays for closest hits of rays.count rays: t (floats), primitive ids
/// (32-bit), uv (2 floats a ray), normals (3 floats a ray), C-contiguous.
struct DeviceHits {
  std::uintptr_t t = 0, prim = 0, uv = 0, normals = 0;
};

/// Closest hits of device rays: (t_hit, primitive_ids, primitive_uvs, primitive_normals) as
/// new device arrays (nanobind's DLPack arrays), ready when `rays.stream` reaches this point.
/// Throws Error{invalid_argument} naming the array that lies on another device than the scene.
nb::tuple cast_rays_on_device(const DeviceScene& scene, const DeviceRays& rays);

/// The same into the caller's arrays `out`, queued on rays.stream.
void cast_rays_into(const DeviceScene& scene, const DeviceRays& rays, const DeviceHits& out);

/// Whether each device ray hits anything in its interval, as a new device bool array.
nb::ndarray<nb::array_api, bool, nb::device::cuda> test_occlusions_on_device(
    const DeviceScene& scene, const DeviceRays& rays);

/// The same into the caller's array of rays.count bytes (bool or uint8) at `occluded`.
void test_occlusions_into(const DeviceScene& scene, const DeviceRays& rays,
                          std::uintptr_t occluded);

/// What a DLPack array (a capsule, or an object with __dlpack__) holds: (data pointer, shape,
/// strides in elements, dtype name such as "float32", DLPack device type, device id), for the
/// Python layer's checks. The memory stays the producer's.
nb::tuple dlpack_layout(const nb::ndarray<>& array);

/// Makes `consumer` wait for the work queued on `producer` (both cudaStream_t), for inputs
/// whose __cuda_array_interface__ names a stream other than the one the trace runs on.
void stream_wait(std::uintptr_t consumer, std::uintptr_t producer);

}  // namespace irgrid::python
