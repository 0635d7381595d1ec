// cpu/structures.h: constructors of the structures, for the factory in api/accelerator.cpp.
#pragma once

#include <chrono>
#include <memory>
#include <span>
#include <string>

#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {

std::unique_ptr<Accelerator> make_brute_force_cpu(const TriangleMesh& mesh);
/// The irregular grid, or the uniform / two-level grid selected by options.grid.shape.
std::unique_ptr<Accelerator> make_grid_cpu(const TriangleMesh& mesh,
                                           const AcceleratorOptions& options);
#if IRGRID_HAS_EMBREE
/// Embree 3 over the mesh; `packets`: traces packets of 8 consecutive rays (rtcIntersect8),
/// otherwise one ray at a time (rtcIntersect1). `config` goes to rtcNewDevice.
std::unique_ptr<Accelerator> make_embree_cpu(const TriangleMesh& mesh, bool packets,
                                             const std::string& config);
/// The compressed wide BVH (baselines/cwbvh_build.h), traversed on the CPU with oneTBB.
std::unique_ptr<Accelerator> make_cwbvh_cpu(const TriangleMesh& mesh,
                                            const AcceleratorOptions& options);
#if IRGRID_HAS_CUDA
/// The same CWBVH, built on the host and traversed on the GPU.
std::unique_ptr<Accelerator> make_cwbvh_cuda(const TriangleMesh& mesh,
                                             const AcceleratorOptions& options);
#endif
#endif
#if IRGRID_HAS_CUDA
std::unique_ptr<Accelerator> make_brute_force_cuda(const TriangleMesh& mesh);
/// The grids of make_grid_cpu, built and traversed on the GPU (the same grid, bit for bit).
std::unique_ptr<Accelerator> make_grid_cuda(const TriangleMesh& mesh,
                                            const AcceleratorOptions& options);
#endif

/// Copies the mesh's triangles, in order, into `out` in the tracers' layout (any vector type).
template <typename Vector>
void gather_triangles(const TriangleMesh& mesh, Vector& out) {
  out.resize(mesh.triangle_count);
  for (std::size_t i = 0; i < mesh.triangle_count; ++i) {
    const std::uint32_t* tri = mesh.indices + 3 * i;
    out[i] = {Vec3<float>::from(mesh.vertex(tri[0])), Vec3<float>::from(mesh.vertex(tri[1])),
              Vec3<float>::from(mesh.vertex(tri[2]))};
  }
}

/// check_mesh, and that a rebuild keeps the triangle count `built` of the first build.
inline void check_rebuild(const TriangleMesh& mesh, std::size_t built) {
  check_mesh(mesh);
  if (mesh.triangle_count != built)
    throw Error(ErrorCode::invalid_argument,
                "rebuild: the mesh has " + std::to_string(mesh.triangle_count) +
                    " triangles, the structure was built over " + std::to_string(built) +
                    " (rebuild takes new positions of the same triangles)");
}

/// Throws Error{invalid_argument} unless rays and hits have the same length.
void check_trace_spans(std::span<const Ray> rays, std::span<Hit> hits);

/// Throws Error{invalid_argument} for RayArrays that trace(RayArrays, HitArrays) cannot read:
/// rays without origins or directions, a stride of 2^26 floats or more.
void check_ray_arrays(const RayArrays& rays);

/// Milliseconds since `start`.
template <typename Clock>
double elapsed_ms(typename Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace irgrid
