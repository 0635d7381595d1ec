// Tracing rays that live in GPU memory: the checks only C++ can make (which device a pointer is
// on), the launches on the caller's stream, and the device arrays handed back to Python.
#include "gpu_arrays.h"

#include <initializer_list>
#include <iterator>
#include <string>

#include "device_kernels.h"

namespace irgrid::python {
namespace {

template <typename T>
using DeviceArray = nb::ndarray<nb::array_api, T, nb::device::cuda>;

std::string device_name(int device) {
  return device < 0 ? std::string("host memory") : "cuda:" + std::to_string(device);
}

/// Throws unless `pointer` (the array called `name`) lies on the scene's device.
void require_on_device(std::uintptr_t pointer, const char* name, int device) {
  const int found = gpu::device_of(reinterpret_cast<const void*>(pointer));
  if (found != device)
    throw Error(ErrorCode::invalid_argument, std::string(name) + ": the array is in " +
                                                 device_name(found) + ", the Scene is on " +
                                                 device_name(device) + " (copy it there first)");
}

/// Throws unless the rays and the scene can meet: the scene traces on CUDA, every array lies on
/// its device, and that device is this thread's current one (the launches go there).
void require_same_device(const DeviceScene& scene, const DeviceRays& rays) {
  if (scene.accelerator->backend() != Backend::cuda)
    throw Error(ErrorCode::invalid_argument,
                "rays: a GPU array needs a Scene built with backend='cuda'; this one traces on "
                "the CPU");
  if (rays.count == 0) return;
  require_on_device(rays.rows, "rays", scene.device);
  if (rays.tmin) require_on_device(rays.tmin, "tmin", scene.device);
  if (rays.tmax) require_on_device(rays.tmax, "tmax", scene.device);
  const int current = gpu::current_device();
  if (current != scene.device)
    throw Error(ErrorCode::invalid_argument, "the current CUDA device is " + device_name(current) +
                                                 ", the Scene's is " + device_name(scene.device) +
                                                 " (select it, e.g. torch.cuda.device(" +
                                                 std::to_string(scene.device) + "))");
}

/// Device memory for `shape` elements of T, handed to Python: freed when its last user (the
/// framework's array made from it) lets go.
template <typename T>
DeviceArray<T> to_python(gpu::DeviceMemory memory, std::initializer_list<std::size_t> shape,
                         int device) {
  T* data = static_cast<T*>(memory.release());
  nb::capsule owner(data, [](void* p) noexcept { gpu::FreeDevice{}(p); });
  return DeviceArray<T>(data, shape.size(), std::data(shape), owner, nullptr, nb::dtype<T>(),
                        nb::device::cuda::value, device);
}

gpu::Stream stream_of(std::uintptr_t handle) {
  return reinterpret_cast<gpu::Stream>(handle);
}

/// Packs the rays and traces them into `hits` (device memory for rays.count hits).
void trace(const DeviceScene& scene, const DeviceRays& rays, Hit* hits, Query query) {
  const gpu::Stream stream = stream_of(rays.stream);
  gpu::Scratch packed(rays.count * sizeof(Ray), stream);
  Ray* device_rays = static_cast<Ray*>(packed.get());
  gpu::pack_rays(reinterpret_cast<const float*>(rays.rows), rays.count,
                 reinterpret_cast<const float*>(rays.tmin), rays.tmin_value,
                 reinterpret_cast<const float*>(rays.tmax), rays.tmax_value, device_rays, stream);
  scene.accelerator->trace_device(device_rays, hits, rays.count, query, stream);
}

/// Queues the closest hits of `rays` into `out` (every array rays.count long).
void queue_closest(const DeviceScene& scene, const DeviceRays& rays, const DeviceHits& out) {
  if (rays.count == 0) return;
  const gpu::Stream stream = stream_of(rays.stream);
  gpu::Scratch hits(rays.count * sizeof(Hit), stream);
  Hit* device_hits = static_cast<Hit*>(hits.get());
  trace(scene, rays, device_hits, Query::closest);
  gpu::split_hits(device_hits, rays.count, scene.normals, reinterpret_cast<float*>(out.t),
                  reinterpret_cast<std::uint32_t*>(out.prim), reinterpret_cast<float*>(out.uv),
                  reinterpret_cast<float*>(out.normals), stream);
}

/// Queues whether each ray of `rays` hits anything into occluded[i].
void queue_any(const DeviceScene& scene, const DeviceRays& rays, bool* occluded) {
  if (rays.count == 0) return;
  const gpu::Stream stream = stream_of(rays.stream);
  gpu::Scratch hits(rays.count * sizeof(Hit), stream);
  Hit* device_hits = static_cast<Hit*>(hits.get());
  trace(scene, rays, device_hits, Query::any);
  gpu::occlusions(device_hits, rays.count, occluded, stream);
}

std::string dtype_name(nb::dlpack::dtype dtype) {
  using Code = nb::dlpack::dtype_code;
  const std::string bits =
      std::to_string(dtype.bits) + (dtype.lanes != 1 ? "x" + std::to_string(dtype.lanes) : "");
  switch (Code(dtype.code)) {
    case Code::Int:
      return "int" + bits;
    case Code::UInt:
      return "uint" + bits;
    case Code::Float:
      return "float" + bits;
    case Code::Bfloat:
      return "bfloat" + bits;
    case Code::Complex:
      return "complex" + bits;
    case Code::Bool:
      return "bool";
    default:
      return "dlpack type code " + std::to_string(dtype.code) + " of " + bits + " bits";
  }
}

}  // namespace

nb::tuple cast_rays_on_device(const DeviceScene& scene, const DeviceRays& rays) {
  require_same_device(scene, rays);
  const std::size_t n = rays.count;
  gpu::DeviceMemory t, prim, uv, normals;
  {
    nb::gil_scoped_release release;
    t = gpu::allocate(n * sizeof(float), "t_hit");
    prim = gpu::allocate(n * sizeof(std::uint32_t), "primitive_ids");
    uv = gpu::allocate(n * 2 * sizeof(float), "primitive_uvs");
    normals = gpu::allocate(n * 3 * sizeof(float), "primitive_normals");
    queue_closest(
        scene, rays,
        {reinterpret_cast<std::uintptr_t>(t.get()), reinterpret_cast<std::uintptr_t>(prim.get()),
         reinterpret_cast<std::uintptr_t>(uv.get()),
         reinterpret_cast<std::uintptr_t>(normals.get())});
  }
  return nb::make_tuple(to_python<float>(std::move(t), {n}, scene.device),
                        to_python<std::uint32_t>(std::move(prim), {n}, scene.device),
                        to_python<float>(std::move(uv), {n, 2}, scene.device),
                        to_python<float>(std::move(normals), {n, 3}, scene.device));
}

void cast_rays_into(const DeviceScene& scene, const DeviceRays& rays, const DeviceHits& out) {
  require_same_device(scene, rays);
  if (rays.count > 0) {
    require_on_device(out.t, "out['t_hit']", scene.device);
    require_on_device(out.prim, "out['primitive_ids']", scene.device);
    require_on_device(out.uv, "out['primitive_uvs']", scene.device);
    require_on_device(out.normals, "out['primitive_normals']", scene.device);
  }
  nb::gil_scoped_release release;
  queue_closest(scene, rays, out);
}

nb::ndarray<nb::array_api, bool, nb::device::cuda> test_occlusions_on_device(
    const DeviceScene& scene, const DeviceRays& rays) {
  require_same_device(scene, rays);
  const std::size_t n = rays.count;
  gpu::DeviceMemory occluded;
  {
    nb::gil_scoped_release release;
    occluded = gpu::allocate(n * sizeof(bool), "occluded");
    queue_any(scene, rays, static_cast<bool*>(occluded.get()));
  }
  return to_python<bool>(std::move(occluded), {n}, scene.device);
}

void test_occlusions_into(const DeviceScene& scene, const DeviceRays& rays,
                          std::uintptr_t occluded) {
  require_same_device(scene, rays);
  if (rays.count > 0) require_on_device(occluded, "out", scene.device);
  nb::gil_scoped_release release;
  queue_any(scene, rays, reinterpret_cast<bool*>(occluded));
}

nb::tuple dlpack_layout(const nb::ndarray<>& array) {
  nb::list shape, strides;
  for (std::size_t i = 0; i < array.ndim(); ++i) {
    shape.append(array.shape(i));
    if (array.stride_ptr()) strides.append(array.stride(i));
  }
  const auto data = reinterpret_cast<std::uintptr_t>(array.data_handle()) + array.byte_offset();
  return nb::make_tuple(data, nb::tuple(shape),
                        array.stride_ptr() ? nb::object(nb::tuple(strides)) : nb::none(),
                        dtype_name(array.dtype()), array.device_type(), array.device_id());
}

void stream_wait(std::uintptr_t consumer, std::uintptr_t producer) {
  gpu::wait_for(stream_of(consumer), stream_of(producer));
}

}  // namespace irgrid::python
