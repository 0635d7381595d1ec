// Every crossing along a ray (inside/outside tests of closed meshes), from closest-hit traces.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/error.h"

namespace irgrid {

void count_crossings(const Accelerator& accelerator, std::span<const Ray> rays,
                     std::span<std::uint32_t> counts) {
  if (rays.size() != counts.size())
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("count_crossings: {} rays but room for {} counts", rays.size(), counts.size()));
  std::fill(counts.begin(), counts.end(), 0u);
  // The rays still walking, each restarted just past its last hit. A triangle's plane is
  // crossed once, so meeting the last triangle again is rounding (the float test's t may lie an
  // ulp or so below the exact one) and never counts; nor does a hit within kSameCrossing of the
  // last one (the other side of a shared edge or vertex).
  constexpr float kSameCrossing = 0x1p-20f;
  struct Walk {
    std::size_t ray;
    std::uint32_t last_prim;
    float last_t;
  };
  std::vector<Ray> active(rays.begin(), rays.end());
  std::vector<Walk> walks(rays.size());
  for (std::size_t i = 0; i < walks.size(); ++i)
    walks[i] = {i, kNoHit, -INFINITY};
  std::vector<Hit> hits;
  while (!active.empty()) {
    hits.resize(active.size());
    accelerator.trace(active, hits, Query::closest);
    std::size_t kept = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      const Hit& hit = hits[k];
      if (!hit.hit()) continue;
      Walk walk = walks[k];
      const bool same = hit.prim == walk.last_prim ||
                        hit.t <= walk.last_t + kSameCrossing * std::fabs(walk.last_t);
      if (!same) {
        ++counts[walk.ray];
        walk.last_prim = hit.prim;
        walk.last_t = hit.t;
      }
      Ray next = active[k];
      // max: never step back, even if a structure reported t a rounding below tmin.
      next.tmin = std::nextafter(std::fmax(hit.t, next.tmin), INFINITY);
      if (!(next.tmin <= next.tmax)) continue;  // past the interval's end (or t = +inf)
      active[kept] = next;
      walks[kept++] = walk;
    }
    active.resize(kept);
    walks.resize(kept);
  }
}

}  // namespace irgrid
