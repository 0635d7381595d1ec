// The trusted reference: brute force in double precision, used by tests and bench validation.
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "cpu/structures.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/watertight.h"

namespace irgrid {

void trace_reference_double(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                            Query query) {
  check_trace_spans(rays, hits);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 4), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto r = make_watertight_ray<double>(rays[i]);
      double best_t = std::numeric_limits<double>::infinity();
      Hit best;
      TriangleHit<double> hit;
      for (std::size_t j = 0; j < scene.triangles.size(); ++j) {
        const auto& tri = scene.triangles[j];
        if (!intersect_watertight(r, Vec3d::from(scene.vertices[tri[0]]),
                                  Vec3d::from(scene.vertices[tri[1]]),
                                  Vec3d::from(scene.vertices[tri[2]]), best_t, hit))
          continue;
        best_t = hit.t;
        best = {std::uint32_t(j), float(hit.t), float(hit.u), float(hit.v)};
        if (query == Query::any) break;
      }
      hits[i] = best;
    }
  });
}

}  // namespace irgrid
