// Ray conversions and triangle normals for the Python module, in parallel over large batches.
#include "arrays.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "irgrid/kernel/triangle.h"

namespace irgrid::python {

namespace {

/// Rays [first, first + count) of the rows into out[0, count). A loop of its own over plain
/// pointers: written into a thread_local vector, each ray cost a call and a TLS lookup.
void convert_rows(const float* rows, std::size_t first, std::size_t count, RayBounds tmin,
                  RayBounds tmax, Ray* out) {
  for (std::size_t i = 0; i < count; ++i)
    out[i] = ray_of_row(rows, first + i, tmin, tmax);
}

}  // namespace

RawArray<Ray> rays_from_rows(const float* rows, std::size_t n, RayBounds tmin, RayBounds tmax) {
  auto rays = uninitialized_array<Ray>(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    convert_rows(rows, range.begin(), range.size(), tmin, tmax, rays.get() + range.begin());
  });
  return rays;
}

void triangle_normals(const float* vertices, const std::uint32_t* triangles,
                      std::size_t triangle_count, float* normals) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangle_count, 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::uint32_t* tri = triangles + 3 * i;
      const auto corner = [&](int k) {
        return Vec3<float>::from(vertices + 3 * std::size_t(tri[k]));
      };
      const Vec3<float> normal = triangle_normal({corner(0), corner(1), corner(2)});
      float* n = normals + 3 * i;
      n[0] = normal.x, n[1] = normal.y, n[2] = normal.z;
    }
  });
}

}  // namespace irgrid::python
