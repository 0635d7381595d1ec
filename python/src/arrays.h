// python/src/arrays.h: numpy rays to irgrid rays, hits to the arrays Python returns.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <span>
#include <vector>

#include "irgrid/ray.h"

namespace irgrid::python {

/// Storage for n rays or hits that the caller overwrites whole: not zeroed first (a pass over
/// 48 bytes a ray that cost Python's cast_rays 5-10% of a trace). Ray and Hit are aggregates,
/// so the allocation itself begins their lifetimes.
struct RawDelete {
  void operator()(void* p) const noexcept { ::operator delete[](p); }
};
template <typename T>
using RawArray = std::unique_ptr<T[], RawDelete>;

template <typename T>
RawArray<T> uninitialized_array(std::size_t n) {
  return RawArray<T>(static_cast<T*>(::operator new[](n * sizeof(T))));
}

/// Rays from n rows of 6 floats (origin, direction), ray i over [tmin[i], tmax[i]].
RawArray<Ray> rays_from_rows(const float* rows, std::size_t n, const float* tmin,
                             const float* tmax);

/// The unit geometric normal (v1 - v0) x (v2 - v0) of each triangle, zero for a degenerate one,
/// into `normals` (3 floats per triangle), from float32 xyz vertices and uint32 triangles.
void triangle_normals(const float* vertices, const std::uint32_t* triangles,
                      std::size_t triangle_count, float* normals);

/// The hits as Python returns them: t (inf on a miss), primitive id (kNoHit on a miss), u, v
/// and the normal of the triangle hit from `triangle_normals` (zero on a miss).
void split_hits(std::span<const Hit> hits, const float* triangle_normals, float* t,
                std::uint32_t* prim, float* uv, float* normals);

}  // namespace irgrid::python
