// Ray and hit conversions for the Python module, in parallel over large batches.
#include "arrays.h"

#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace irgrid::python {

RawArray<Ray> rays_from_rows(const float* rows, std::size_t n, const float* tmin,
                             const float* tmax) {
  auto rays = uninitialized_array<Ray>(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const float* r = rows + 6 * i;
      rays[i] = {{r[0], r[1], r[2]}, tmin[i], {r[3], r[4], r[5]}, tmax[i]};
    }
  });
  return rays;
}

void triangle_normals(const float* vertices, const std::uint32_t* triangles,
                      std::size_t triangle_count, float* normals) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangle_count, 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::uint32_t* tri = triangles + 3 * i;
      const float* a = vertices + 3 * std::size_t(tri[0]);
      const float* b = vertices + 3 * std::size_t(tri[1]);
      const float* c = vertices + 3 * std::size_t(tri[2]);
      const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
      const double e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
      const double x = e1[1] * e2[2] - e1[2] * e2[1], y = e1[2] * e2[0] - e1[0] * e2[2],
                   z = e1[0] * e2[1] - e1[1] * e2[0];
      const double length = std::sqrt(x * x + y * y + z * z);
      const double scale = length > 0 ? 1 / length : 0;
      float* n = normals + 3 * i;
      n[0] = float(x * scale), n[1] = float(y * scale), n[2] = float(z * scale);
    }
  });
}

void split_hits(std::span<const Hit> hits, const float* triangle_normals, float* t,
                std::uint32_t* prim, float* uv, float* normals) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, hits.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Hit& h = hits[i];
      prim[i] = h.prim;
      float* n = normals + 3 * i;
      if (!h.hit()) {
        t[i] = std::numeric_limits<float>::infinity();
        uv[2 * i] = uv[2 * i + 1] = 0;
        n[0] = n[1] = n[2] = 0;
        continue;
      }
      t[i] = h.t, uv[2 * i] = h.u, uv[2 * i + 1] = h.v;
      const float* source = triangle_normals + 3 * std::size_t(h.prim);
      n[0] = source[0], n[1] = source[1], n[2] = source[2];
    }
  });
}

}  // namespace irgrid::python
