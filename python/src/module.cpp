// irgrid._irgrid: the C++ side of the Python package. The Python layer (irgrid/__init__.py)
// checks shapes and dtypes and hands over C-contiguous float32 / uint32 arrays, or for rays in
// GPU memory (irgrid/_gpu.py) device pointers and a stream (gpu_arrays.h).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "arrays.h"
#include "device_kernels.h"
#include "gpu_arrays.h"
#include "irgrid/io/scene.h"
#include "irgrid/irgrid.h"
#include "result_memory.h"

namespace nb = nanobind;

namespace irgrid::python {
namespace {

using FloatRows = nb::ndarray<const float, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using IndexRows = nb::ndarray<const std::uint32_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Floats = nb::ndarray<const float, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

/// A numpy array of `shape` that owns new memory (result_memory.h).
template <typename T>
nb::ndarray<nb::numpy, T> new_array(std::initializer_list<std::size_t> shape) {
  std::size_t count = 1;
  for (std::size_t extent : shape)
    count *= extent;
  // The capsule keeps the size for the release: the block's bytes, at the pointer's side.
  struct Owned {
    void* data;
    std::size_t bytes;
  };
  auto* owned = new Owned{nullptr, count * sizeof(T)};
  try {
    owned->data = acquire_result_memory(owned->bytes);
  } catch (...) {
    delete owned;
    throw;
  }
  nb::capsule owner(owned, [](void* p) noexcept {
    auto* o = static_cast<Owned*>(p);
    release_result_memory(o->data, o->bytes);
    delete o;
  });
  return nb::ndarray<nb::numpy, T>(static_cast<T*>(owned->data), shape.size(), std::data(shape),
                                   owner);
}

void require_columns(const FloatRows& rows, std::size_t columns, const char* what) {
  if (rows.shape(1) != columns)
    throw Error(ErrorCode::invalid_argument,
                std::string(what) + ": expected " + std::to_string(columns) + " columns");
}

/// tmin or tmax: one value for every row (a 1-element array) or one per row.
RayBounds bounds_of(const FloatRows& rows, const Floats& values, const char* what) {
  require_columns(rows, 6, "rays");
  if (values.shape(0) != 1 && values.shape(0) != rows.shape(0))
    throw Error(ErrorCode::invalid_argument,
                std::string(what) + ": one value, or one per ray expected");
  return {values.data(), values.shape(0)};
}

/// Rows of (origin, direction) with their bounds, as the library reads them in place.
RayArrays ray_arrays(const FloatRows& rows, const Floats& tmin, const Floats& tmax) {
  const RayBounds lo = bounds_of(rows, tmin, "tmin"), hi = bounds_of(rows, tmax, "tmax");
  RayArrays in;
  in.count = rows.shape(0);
  in.origins = rows.data(), in.origin_stride = 6;
  in.directions = rows.data() + 3, in.direction_stride = 6;
  in.tmin = lo.values, in.tmin_stride = lo.count == 1 ? 0 : 1;
  in.tmax = hi.values, in.tmax_stride = hi.count == 1 ? 0 : 1;
  return in;
}

/// One built structure over a mesh, with the mesh's arrays kept for normals and rebuilds.
class PyAccelerator {
 public:
  PyAccelerator(const FloatRows& vertices, const IndexRows& triangles, const std::string& structure,
                const std::string& backend, const BuildConfig& config) {
    require_columns(vertices, 3, "vertices");
    if (triangles.shape(1) != 3)
      throw Error(ErrorCode::invalid_argument, "triangles: expected 3 columns");
    vertices_.assign(vertices.data(), vertices.data() + vertices.size());
    triangles_.assign(triangles.data(), triangles.data() + triangles.size());
    AcceleratorOptions options;
    options.backend = parse_backend(backend);
    options.grid = config;
    const Structure chosen = parse_structure(structure);
    nb::gil_scoped_release release;
    accelerator_ = make_accelerator(mesh(), chosen, options);
    if (accelerator_->backend() == Backend::cuda) device_ = gpu::current_device();
    update_normals();
  }

  std::string structure() const { return to_string(accelerator_->structure()); }
  std::string backend() const { return to_string(accelerator_->backend()); }
  std::uint64_t memory_bytes() const { return accelerator_->build_stats().memory_bytes; }

  /// The rows are read and the results written in place by the library's trace: no copy of
  /// either is made (docs/benchmarks.md: the copies cost a tenth of the walk's speed).
  nb::tuple cast_rays(const FloatRows& rows, const Floats& tmin, const Floats& tmax) const {
    const RayArrays in = ray_arrays(rows, tmin, tmax);
    const std::size_t n = in.count;
    auto t = new_array<float>({n});
    auto prim = new_array<std::uint32_t>({n});
    auto uv = new_array<float>({n, 2});
    auto normals = new_array<float>({n, 3});
    HitArrays out;
    out.t = t.data(), out.prim = prim.data();
    out.u = uv.data(), out.u_stride = 2;
    out.v = uv.data() + 1, out.v_stride = 2;
    out.normal = normals.data();
    {
      nb::gil_scoped_release release;
      accelerator_->trace(in, out, Query::closest);
    }
    return nb::make_tuple(t, prim, uv, normals);
  }

  nb::ndarray<nb::numpy, bool> test_occlusions(const FloatRows& rows, const Floats& tmin,
                                               const Floats& tmax) const {
    const RayArrays in = ray_arrays(rows, tmin, tmax);
    const std::size_t n = in.count;
    auto occluded = new_array<bool>({n});
    {
      nb::gil_scoped_release release;
      const auto prim = uninitialized_array<std::uint32_t>(n);
      HitArrays out;
      out.prim = prim.get();
      accelerator_->trace(in, out, Query::any);
      for (std::size_t i = 0; i < n; ++i)
        occluded.data()[i] = prim[i] != kNoHit;
    }
    return occluded;
  }

  nb::ndarray<nb::numpy, std::int32_t> count_intersections(const FloatRows& rows,
                                                           const Floats& tmin,
                                                           const Floats& tmax) const {
    const RayBounds lo = bounds_of(rows, tmin, "tmin"), hi = bounds_of(rows, tmax, "tmax");
    const std::size_t n = rows.shape(0);
    auto out = new_array<std::int32_t>({n});
    {
      nb::gil_scoped_release release;
      const auto rays = rays_from_rows(rows.data(), n, lo, hi);
      std::vector<std::uint32_t> counts(n);
      count_crossings(*accelerator_, {rays.get(), n}, counts);
      std::memcpy(out.data(), counts.data(), n * sizeof(std::int32_t));
    }
    return out;
  }

  void rebuild(const FloatRows& vertices) {
    require_columns(vertices, 3, "vertices");
    if (vertices.size() != vertices_.size())
      throw Error(ErrorCode::invalid_argument,
                  "rebuild: " + std::to_string(vertices.shape(0)) + " vertices, the scene has " +
                      std::to_string(vertices_.size() / 3) + " (rebuild takes new positions)");
    std::vector<float> previous(vertices.data(), vertices.data() + vertices.size());
    previous.swap(vertices_);
    nb::gil_scoped_release release;
    try {
      accelerator_->rebuild(mesh());
    } catch (...) {
      vertices_.swap(previous);
      throw;
    }
    update_normals();
  }

  /// cast_rays for rays in GPU memory (gpu_arrays.h).
  nb::tuple cast_rays_on_device(const DeviceRays& rays) const {
    return python::cast_rays_on_device(device_scene(), rays);
  }

  /// test_occlusions for rays in GPU memory.
  nb::ndarray<nb::array_api, bool, nb::device::cuda> test_occlusions_on_device(
      const DeviceRays& rays) const {
    return python::test_occlusions_on_device(device_scene(), rays);
  }

  /// cast_rays_on_device into the caller's device arrays.
  void cast_rays_into(const DeviceRays& rays, const DeviceHits& out) const {
    python::cast_rays_into(device_scene(), rays, out);
  }

  /// test_occlusions_on_device into the caller's device array.
  void test_occlusions_into(const DeviceRays& rays, std::uintptr_t occluded) const {
    python::test_occlusions_into(device_scene(), rays, occluded);
  }

  /// Phase name -> value, for the phases that have one (PhaseTimes, PhaseBytes).
  template <typename T>
  static nb::dict per_phase(const std::array<std::optional<T>, kBuildPhaseCount>& values) {
    nb::dict out;
    for (std::size_t p = 0; p < kBuildPhaseCount; ++p)
      if (values[p]) out[to_string(BuildPhase(p))] = *values[p];
    return out;
  }

  nb::dict stats() const {
    const BuildStats& s = accelerator_->build_stats();
    nb::dict out;
    out["structure"] = structure();
    out["backend"] = backend();
    out["triangles"] = triangles_.size() / 3;
    out["build_ms"] = s.build_ms;
    out["memory_bytes"] = s.memory_bytes;
    out["build_phases_ms"] = per_phase(s.phase_ms);
    if (s.grid) {
      const GridStats& g = *s.grid;
      out["cells"] = g.cells;
      out["references"] = g.references;
      out["voxel_map_entries"] = g.voxel_map_entries;
      out["top_level_references"] = g.top_level_references;
      out["top_dims"] = nb::make_tuple(g.top_dims[0], g.top_dims[1], g.top_dims[2]);
      out["depth"] = g.depth;
      out["compressed_cells"] = g.compressed_cells;
      out["lambda2_used"] = g.lambda2_used;
      out["peak_build_bytes"] = g.peak_build_bytes;
      out["build_phase_peak_bytes"] = per_phase(g.phase_peak_bytes);
      out["budget_bytes"] = g.budget_bytes;
      out["budget_limited"] = g.budget_limited;
    }
    return out;
  }

 private:
  TriangleMesh mesh() const {
    return {vertices_.data(), vertices_.size() / 3, 3 * sizeof(float), triangles_.data(),
            triangles_.size() / 3};
  }

  /// On the CUDA backend, the geometric normal of every triangle in device memory, for the
  /// hits' normals of rays from GPU arrays (the library writes those of host rays).
  void update_normals() {
    if (device_ < 0) return;
    std::vector<float> normals(triangles_.size());
    triangle_normals(vertices_.data(), triangles_.data(), triangles_.size() / 3, normals.data());
    const std::size_t bytes = normals.size() * sizeof(float);
    if (!device_normals_) device_normals_ = gpu::allocate(bytes, "triangle normals");
    gpu::upload(device_normals_.get(), normals.data(), bytes);
  }

  DeviceScene device_scene() const {
    return {accelerator_.get(), device_, static_cast<const float*>(device_normals_.get())};
  }

  std::vector<float> vertices_;
  std::vector<std::uint32_t> triangles_;
  std::unique_ptr<Accelerator> accelerator_;
  int device_ = -1;                   ///< the CUDA device of the structure; -1 on the CPU
  gpu::DeviceMemory device_normals_;  ///< 3 floats per triangle, on device_
};

/// OBJ or PLY (also .gz / .xz) as (vertices float32 (V, 3), triangles uint32 (T, 3)); invalid
/// triangles are dropped as the command-line tool drops them.
nb::tuple load(const std::string& path) {
  Scene scene;
  {
    nb::gil_scoped_release release;
    scene = load_scene(path);
  }
  auto vertices = new_array<float>({scene.vertices.size(), 3});
  auto triangles = new_array<std::uint32_t>({scene.triangles.size(), 3});
  std::memcpy(vertices.data(), scene.vertices.data(), scene.vertices.size() * 3 * sizeof(float));
  std::memcpy(triangles.data(), scene.triangles.data(),
              scene.triangles.size() * 3 * sizeof(std::uint32_t));
  return nb::make_tuple(vertices, triangles);
}

std::vector<std::string> backends() {
  std::vector<std::string> out = {"cpu"};
  if (!cuda_status().gpus.empty()) out.push_back("cuda");
  return out;
}

}  // namespace
}  // namespace irgrid::python

NB_MODULE(_irgrid, m) {
  using namespace irgrid;
  using python::PyAccelerator;
  m.doc() = "irgrid: irregular grids for ray tracing (C++ core)";
  nb::exception<Error>(m, "Error", PyExc_RuntimeError);
  m.def("version", [] { return std::string(version()); });
  m.def("backends", &python::backends, "Backends that can run here: 'cpu', and 'cuda' with a GPU");
  m.def("cuda_status", [] { return cuda_status().status; });
  m.def("structures", [] {
    std::vector<std::string> names;
    for (const Structure s : available_structures())
      names.push_back(to_string(s));
    return names;
  });
  m.def("load", &python::load, nb::arg("path"));
  m.def("has_cuda", &python::gpu::available, "Whether this build can take GPU arrays");
  m.def("dlpack_layout", &python::dlpack_layout, nb::arg("array").noconvert());
  m.def("stream_wait", &python::stream_wait, nb::arg("consumer"), nb::arg("producer"));
  nb::class_<BuildConfig>(m, "BuildConfig")
      .def(nb::init<>())
      .def_rw("lambda1", &BuildConfig::lambda1)
      .def_rw("lambda2", &BuildConfig::lambda2)
      .def_rw("min_cells", &BuildConfig::min_cells)
      .def_rw("split_refs", &BuildConfig::split_refs)
      .def_rw("alpha", &BuildConfig::alpha)
      .def_rw("cost_ratio", &BuildConfig::cost_ratio)
      .def_rw("empty_aspect", &BuildConfig::empty_aspect)
      .def_rw("expansion_passes", &BuildConfig::expansion_passes)
      .def_rw("partial_expansion", &BuildConfig::partial_expansion)
      .def_rw("skip_empty", &BuildConfig::skip_empty)
      .def_rw("compress", &BuildConfig::compress)
      .def_rw("huge_pages", &BuildConfig::huge_pages)
      .def_rw("memory_budget", &BuildConfig::memory_budget);
  nb::class_<PyAccelerator>(m, "Accelerator")
      .def(nb::init<const python::FloatRows&, const python::IndexRows&, const std::string&,
                    const std::string&, const BuildConfig&>(),
           nb::arg("vertices"), nb::arg("triangles"), nb::arg("structure"), nb::arg("backend"),
           nb::arg("config"))
      .def_prop_ro("structure", &PyAccelerator::structure)
      .def_prop_ro("backend", &PyAccelerator::backend)
      .def_prop_ro("memory_bytes", &PyAccelerator::memory_bytes)
      .def_prop_ro("stats", &PyAccelerator::stats)
      .def("cast_rays", &PyAccelerator::cast_rays, nb::arg("rays"), nb::arg("tmin"),
           nb::arg("tmax"))
      .def("test_occlusions", &PyAccelerator::test_occlusions, nb::arg("rays"), nb::arg("tmin"),
           nb::arg("tmax"))
      .def("count_intersections", &PyAccelerator::count_intersections, nb::arg("rays"),
           nb::arg("tmin"), nb::arg("tmax"))
      .def("rebuild", &PyAccelerator::rebuild, nb::arg("vertices"))
      // Rays in GPU memory (irgrid/_gpu.py): rows, count, tmin, tmin_value, tmax, tmax_value,
      // stream, then the output pointers of the *_into forms.
      .def(
          "cast_rays_on_device",
          [](const PyAccelerator& self, std::uintptr_t rows, std::size_t count, std::uintptr_t tmin,
             float tmin_value, std::uintptr_t tmax, float tmax_value, std::uintptr_t stream) {
            return self.cast_rays_on_device(
                {rows, count, tmin, tmin_value, tmax, tmax_value, stream});
          })
      .def(
          "test_occlusions_on_device",
          [](const PyAccelerator& self, std::uintptr_t rows, std::size_t count, std::uintptr_t tmin,
             float tmin_value, std::uintptr_t tmax, float tmax_value, std::uintptr_t stream) {
            return self.test_occlusions_on_device(
                {rows, count, tmin, tmin_value, tmax, tmax_value, stream});
          })
      .def(
          "cast_rays_into",
          [](const PyAccelerator& self, std::uintptr_t rows, std::size_t count, std::uintptr_t tmin,
             float tmin_value, std::uintptr_t tmax, float tmax_value, std::uintptr_t stream,
             std::uintptr_t t, std::uintptr_t prim, std::uintptr_t uv, std::uintptr_t normals) {
            self.cast_rays_into({rows, count, tmin, tmin_value, tmax, tmax_value, stream},
                                {t, prim, uv, normals});
          })
      .def("test_occlusions_into",
           [](const PyAccelerator& self, std::uintptr_t rows, std::size_t count,
              std::uintptr_t tmin, float tmin_value, std::uintptr_t tmax, float tmax_value,
              std::uintptr_t stream, std::uintptr_t occluded) {
             self.test_occlusions_into({rows, count, tmin, tmin_value, tmax, tmax_value, stream},
                                       occluded);
           });
}
