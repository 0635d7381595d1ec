// python/src/arrays.h: numpy rays to irgrid rays, hits to the arrays Python returns.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>

#include "irgrid/accelerator.h"
#include "irgrid/ray.h"

namespace irgrid::python {

/// tmin or tmax of the rays: one value for every ray (count 1) or one per ray.
struct RayBounds {
  const float* values;
  std::size_t count;
  float operator[](std::size_t i) const { return values[count == 1 ? 0 : i]; }
};

/// Ray `i` of rows of 6 floats (origin, direction) over [tmin[i], tmax[i]].
inline Ray ray_of_row(const float* rows, std::size_t i, RayBounds tmin, RayBounds tmax) {
  const float* r = rows + 6 * i;
  return {{r[0], r[1], r[2]}, tmin[i], {r[3], r[4], r[5]}, tmax[i]};
}

/// Storage for n rays or hits that the caller overwrites whole: not zeroed first. Ray and Hit
/// are aggregates, so the allocation itself begins their lifetimes.
struct RawDelete {
  void operator()(void* p) const noexcept { ::operator delete[](p); }
};
template <typename T>
using RawArray = std::unique_ptr<T[], RawDelete>;

template <typename T>
RawArray<T> uninitialized_array(std::size_t n) {
  return RawArray<T>(static_cast<T*>(::operator new[](n * sizeof(T))));
}

/// All n rays of the rows (count_crossings takes a whole batch).
RawArray<Ray> rays_from_rows(const float* rows, std::size_t n, RayBounds tmin, RayBounds tmax);

/// The unit geometric normal of each triangle (triangle_normal of irgrid/kernel/triangle.h: the
/// normals trace writes) into `normals` (3 floats per triangle), from float32 xyz vertices and
/// uint32 triangles.
void triangle_normals(const float* vertices, const std::uint32_t* triangles,
                      std::size_t triangle_count, float* normals);

}  // namespace irgrid::python
