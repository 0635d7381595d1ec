// The structure factory and the names of the API's enums.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <tbb/blocked_range.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include "cpu/parallel.h"
#include "cpu/ray_fields.h"
#include "cpu/structures.h"
#include "cpu/walk_policy.h"
#include "irgrid/error.h"
#include "irgrid/system.h"

namespace irgrid {
namespace {

constexpr std::array kStructureNames = {std::pair{Structure::irregular, "irregular"},
                                        std::pair{Structure::two_level, "two-level"},
                                        std::pair{Structure::uniform, "uniform"},
                                        std::pair{Structure::brute, "brute"},
                                        std::pair{Structure::embree, "embree"},
                                        std::pair{Structure::embree_packets, "embree-packets"},
                                        std::pair{Structure::cwbvh, "cwbvh"}};

constexpr std::array kBackendNames = {std::pair{Backend::cpu, "cpu"},
                                      std::pair{Backend::cuda, "cuda"},
                                      std::pair{Backend::automatic, "auto"}};

constexpr std::array kCpuWalkNames = {
    std::pair{CpuWalk::automatic, "auto"}, std::pair{CpuWalk::avx512, "avx512"},
    std::pair{CpuWalk::avx2, "avx2"}, std::pair{CpuWalk::single, "single"},
    std::pair{CpuWalk::interleaved, "interleaved"}};

constexpr std::array<const char*, kBuildPhaseCount> kBuildPhaseNames = {"top grid",
                                                                        "top-level references",
                                                                        "octree levels",
                                                                        "empty space",
                                                                        "cells and references",
                                                                        "merge",
                                                                        "voxel map",
                                                                        "expansion",
                                                                        "compress",
                                                                        "bvh build",
                                                                        "bvh compress",
                                                                        "upload"};

template <typename Enum, std::size_t N>
const char* name_of(const std::array<std::pair<Enum, const char*>, N>& names, Enum value) {
  for (const auto& [e, name] : names)
    if (e == value) return name;
  return "?";
}

/// Throws unless the CPU can run the SIMD walk `walk` forces.
void check_cpu_walk(CpuWalk walk) {
  const auto lacks = [](SimdIsa isa) { return !cpu_has(isa); };
  if ((walk == CpuWalk::avx512 && lacks(SimdIsa::avx512)) ||
      (walk == CpuWalk::avx2 && lacks(SimdIsa::avx2)))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("cpu walk '{}': this CPU lacks that instruction set", to_string(walk)));
}

}  // namespace

const char* version() noexcept {
  return IRGRID_VERSION;
}

const char* to_string(Structure structure) noexcept {
  return name_of(kStructureNames, structure);
}

bool is_grid(Structure structure) noexcept {
  return structure == Structure::irregular || structure == Structure::two_level ||
         structure == Structure::uniform;
}

Structure parse_structure(std::string_view name) {
  for (const auto& [structure, spelling] : kStructureNames)
    if (name == spelling) {
      const auto compiled = available_structures();
      if (std::find(compiled.begin(), compiled.end(), structure) != compiled.end())
        return structure;
    }
  std::vector<const char*> names;
  for (const Structure s : available_structures())
    names.push_back(to_string(s));
#if !IRGRID_HAS_EMBREE
  for (const auto& [structure, spelling] : kStructureNames)
    if (name == spelling)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("structure '{}' needs Embree, and this build has none (configure "
                              "with -DIRGRID_ENABLE_EMBREE=ON and libembree-dev; this build has: "
                              "{})",
                              name, fmt::join(names, ", ")));
#endif
  throw Error(
      ErrorCode::invalid_argument,
      fmt::format("unknown structure '{}' (this build has: {})", name, fmt::join(names, ", ")));
}

const char* to_string(Backend backend) noexcept {
  return name_of(kBackendNames, backend);
}

Backend parse_backend(std::string_view name) {
  for (const auto& [backend, spelling] : kBackendNames)
    if (name == spelling) return backend;
  throw Error(ErrorCode::invalid_argument,
              fmt::format("unknown backend '{}' (expected cpu, cuda or auto)", name));
}

const char* to_string(CpuWalk walk) noexcept {
  return name_of(kCpuWalkNames, walk);
}

CpuWalk parse_cpu_walk(std::string_view name) {
  if (name == "simd") return CpuWalk::automatic;
  for (const auto& [walk, spelling] : kCpuWalkNames)
    if (name == spelling) return walk;
  throw Error(ErrorCode::invalid_argument,
              fmt::format("unknown cpu walk '{}' (expected auto, simd, avx512, avx2, single or "
                          "interleaved)",
                          name));
}

const char* cpu_walk_in_use(CpuWalk walk) {
  if (walk == CpuWalk::single) return "single";
  if (walk == CpuWalk::interleaved) return "interleaved";
  const auto isa = simd_isa_of(walk);
  return !isa ? "scalar" : *isa == SimdIsa::avx512 ? "avx512" : "avx2";
}

const char* to_string(BuildPhase phase) noexcept {
  const auto index = std::size_t(phase);
  return index < kBuildPhaseNames.size() ? kBuildPhaseNames[index] : "?";
}

void check_trace_spans(std::span<const Ray> rays, std::span<Hit> hits) {
  if (rays.size() != hits.size())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("trace: {} rays but room for {} hits", rays.size(), hits.size()));
}

void check_ray_arrays(const RayArrays& rays) {
  if (rays.count == 0) return;
  if (!rays.origins || !rays.directions)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("trace: RayArrays of {} rays without {}", rays.count,
                            rays.origins ? "directions" : "origins"));
  constexpr std::size_t kLargestStride = (std::size_t(1) << 26) - 1;
  for (const auto& [name, stride] :
       {std::pair{"origin_stride", rays.origin_stride},
        std::pair{"direction_stride", rays.direction_stride},
        std::pair{"tmin_stride", rays.tmin_stride}, std::pair{"tmax_stride", rays.tmax_stride}})
    if (stride > kLargestStride)
      throw Error(
          ErrorCode::invalid_argument,
          fmt::format("trace: RayArrays::{} {} exceeds {} floats", name, stride, kLargestStride));
}

void Accelerator::trace(const RayArrays& rays, const HitArrays& hits, Query query) const {
  check_ray_arrays(rays);
  if (rays.count == 0) return;
  const RayFields in = ray_fields(rays);
  const HitFields out = hit_fields(hits, hits.normal ? host_triangles().data() : nullptr);
  const auto trace_converted = [&](std::size_t first, std::size_t count, Ray* ray_buffer,
                                   Hit* hit_buffer) {
    for (std::size_t i = 0; i < count; ++i)
      ray_buffer[i] = in[first + i];
    trace(std::span<const Ray>(ray_buffer, count), std::span<Hit>(hit_buffer, count), query);
    for (std::size_t i = 0; i < count; ++i)
      out.write(first + i, hit_buffer[i]);
  };
  if (backend() != Backend::cpu) {  // one batch: each call is a round trip to the device
    std::vector<Ray> ray_buffer(rays.count);
    std::vector<Hit> hit_buffer(rays.count);
    trace_converted(0, rays.count, ray_buffer.data(), hit_buffer.data());
    return;
  }
  // Pieces of kPiece rays per thread, through buffers of its own: no batch-sized copy of the
  // rays and hits is written and read again. trace's own loop runs inside, isolated, so that
  // while it waits this thread takes up no other piece (which would reuse the buffers).
  constexpr std::size_t kPiece = 65536;
  irgrid::parallel_for(
      tbb::blocked_range<std::size_t>(0, rays.count, kPiece), [&](const auto& range) {
        std::vector<Ray> ray_buffer(std::min(kPiece, range.size()));
        std::vector<Hit> hit_buffer(ray_buffer.size());
        for (std::size_t first = range.begin(); first < range.end(); first += kPiece) {
          const std::size_t count = std::min(kPiece, range.end() - first);
          tbb::this_task_arena::isolate(
              [&] { trace_converted(first, count, ray_buffer.data(), hit_buffer.data()); });
        }
      });
}

void Accelerator::trace_counted(std::span<const Ray>, std::span<Hit>, std::span<RayWork>,
                                Query) const {
  throw Error(
      ErrorCode::invalid_argument,
      fmt::format("structure '{}' does not count its work per ray", to_string(structure())));
}

void Accelerator::trace_device(const Ray*, Hit*, std::size_t, Query, CUstream_st*) const {
  throw Error(ErrorCode::invalid_argument,
              fmt::format("trace_device: structure '{}' on the {} backend has no device memory "
                          "(build it with Backend::cuda)",
                          to_string(structure()), to_string(backend())));
}

GridView Accelerator::grid_view() const {
  throw Error(ErrorCode::invalid_argument,
              fmt::format("grid_view: structure '{}' is not a grid", to_string(structure())));
}

std::vector<Structure> available_structures() {
  std::vector<Structure> structures{Structure::irregular};
#if IRGRID_HAS_EMBREE
  structures.push_back(Structure::embree);
  structures.push_back(Structure::embree_packets);
  structures.push_back(Structure::cwbvh);  // built with Embree's BVH builder
#endif
  structures.push_back(Structure::two_level);
  structures.push_back(Structure::uniform);
  structures.push_back(Structure::brute);
  return structures;
}

Backend resolve_backend(Backend backend) {
  if (backend == Backend::cpu) return backend;
  const auto cuda = cuda_status();
  if (!cuda.gpus.empty()) return Backend::cuda;
  if (backend == Backend::automatic) return Backend::cpu;
  throw Error(ErrorCode::no_device, fmt::format("backend cuda: {}", cuda.status));
}

std::unique_ptr<Accelerator> make_accelerator(const TriangleMesh& mesh, Structure structure,
                                              const AcceleratorOptions& options) {
  const auto compiled = available_structures();
  if (std::find(compiled.begin(), compiled.end(), structure) == compiled.end())
    parse_structure(to_string(structure));  // throws, naming the structures of this build
  const Backend backend = resolve_backend(options.backend);
  check_mesh(mesh);
  check_cpu_walk(options.cpu_walk);
  if (structure == Structure::brute) {
#if IRGRID_HAS_CUDA
    if (backend == Backend::cuda) return make_brute_force_cuda(mesh);
#endif
    return make_brute_force_cpu(mesh);
  }
  if (is_grid(structure)) {
    AcceleratorOptions grid_options = options;
    grid_options.grid.shape = structure == Structure::irregular   ? BuildConfig::Shape::irregular
                              : structure == Structure::two_level ? BuildConfig::Shape::two_level
                                                                  : BuildConfig::Shape::uniform;
#if IRGRID_HAS_CUDA
    if (backend == Backend::cuda) return make_grid_cuda(mesh, grid_options);
#endif
    return make_grid_cpu(mesh, grid_options);
  }
#if IRGRID_HAS_EMBREE
  if (structure == Structure::cwbvh) {
#if IRGRID_HAS_CUDA
    if (backend == Backend::cuda) return make_cwbvh_cuda(mesh, options);
#endif
    return make_cwbvh_cpu(mesh, options);
  }
  if (backend == Backend::cuda && options.backend == Backend::cuda)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("structure '{}' runs on the cpu backend only", to_string(structure)));
  return make_embree_cpu(mesh, structure == Structure::embree_packets, options.embree_config);
#else
  throw Error(ErrorCode::internal, "unreachable: structure check");
#endif
}

}  // namespace irgrid
