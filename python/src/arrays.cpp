// Ray and hit conversions for the Python module, in parallel over large batches.
#include "arrays.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "hit_split.h"

namespace irgrid::python {

namespace {
// Rays traced per call: the SIMD walk's lanes run dry at the end of each call, and the call's
// own parallel loop cuts it into pieces of its grain. 65536 took 5% less time than 16384 per
// cast_rays of 1M random rays on Sponza (Intel Xeon VM, 2 threads), and as long as 262144.
constexpr std::size_t kChunk = 65536;

/// Rays [first, first + count) of the rows into out[0, count). A loop of its own over plain
/// pointers: written into a thread_local vector, each ray cost a call and a TLS lookup (5% of
/// cast_rays on 1M random rays).
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

void trace_rows(const Accelerator& accelerator, const float* rows, std::size_t n, RayBounds tmin,
                RayBounds tmax, Query query,
                const std::function<void(std::size_t, std::span<const Hit>)>& consume) {
  if (accelerator.backend() != Backend::cpu) {
    const auto rays = rays_from_rows(rows, n, tmin, tmax);
    const auto hits = uninitialized_array<Hit>(n);
    accelerator.trace({rays.get(), n}, {hits.get(), n}, query);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& r) {
      consume(r.begin(), {hits.get() + r.begin(), r.size()});
    });
    return;
  }
  // The partitioner may hand out ranges longer than the grain: each goes kChunk rays at a time,
  // through buffers kept per thread (reused from call to call, so their pages stay mapped).
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const auto& range) {
    thread_local std::vector<Ray> rays;
    thread_local std::vector<Hit> hits;
    if (rays.size() < std::min(kChunk, range.size())) {
      rays.resize(std::min(kChunk, range.size()));
      hits.resize(rays.size());
    }
    for (std::size_t first = range.begin(); first < range.end(); first += kChunk) {
      const std::size_t count = std::min(kChunk, range.end() - first);
      convert_rows(rows, first, count, tmin, tmax, rays.data());
      // Isolated: while its own parallel_for waits, this thread must not take up another range
      // of the outer loop, which would reuse the buffers.
      tbb::this_task_arena::isolate([&] {
        accelerator.trace({rays.data(), count}, {hits.data(), count}, query);
      });
      consume(first, {hits.data(), count});
    }
  });
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

void split_hits(std::size_t first, std::span<const Hit> hits, const float* triangle_normals,
                float* t, std::uint32_t* prim, float* uv, float* normals) {
  constexpr std::size_t kAhead = 16;  // the normals are read at random: ask for them early
  for (std::size_t k = 0; k < hits.size(); ++k) {
    if (k + kAhead < hits.size() && hits[k + kAhead].hit())
      __builtin_prefetch(triangle_normals + 3 * std::size_t(hits[k + kAhead].prim));
    split_hit(first + k, hits[k], triangle_normals, t, prim, uv, normals);
  }
}

}  // namespace irgrid::python
