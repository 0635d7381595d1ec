// cpu/structures.h: constructors of the structures, for the factory in accelerator.cpp.
#pragma once

#include <memory>
#include <span>

#include "core/triangle.h"
#include "irgrid/accelerator.h"

namespace irgrid {

std::unique_ptr<Accelerator> make_brute_force_cpu(const Scene& scene);
/// The irregular grid, or the uniform / two-level grid selected by config.shape.
std::unique_ptr<Accelerator> make_grid_cpu(const Scene& scene, const BuildConfig& config,
                                           const PhaseObserver& on_phase = {});
#if IRGRID_HAS_EMBREE
/// Embree 3 over the scene; `packets`: traces packets of 8 consecutive rays (rtcIntersect8),
/// otherwise one ray at a time (rtcIntersect1).
std::unique_ptr<Accelerator> make_embree_cpu(const Scene& scene, bool packets);
#endif
#if IRGRID_HAS_CUDA
std::unique_ptr<Accelerator> make_brute_force_cuda(const Scene& scene);
/// The grids of make_grid_cpu, built and traversed on the GPU (the same grid, bit for bit).
std::unique_ptr<Accelerator> make_grid_cuda(const Scene& scene, const BuildConfig& config,
                                            const PhaseObserver& on_phase = {});
#endif

/// Appends the scene's triangles, in order, to `out` in the tracers' layout (any vector type).
template <typename Vector>
void gather_triangles(const Scene& scene, Vector& out) {
  out.resize(scene.triangles.size());
  for (std::size_t i = 0; i < scene.triangles.size(); ++i) {
    const auto& tri = scene.triangles[i];
    out[i] = {Vec3<float>::from(scene.vertices[tri[0]]), Vec3<float>::from(scene.vertices[tri[1]]),
              Vec3<float>::from(scene.vertices[tri[2]])};
  }
}

/// Throws Error{invalid_argument} unless rays and hits have the same length.
void check_trace_spans(std::span<const Ray> rays, std::span<Hit> hits);

}  // namespace irgrid
