// tests/cwbvh_test_support.h: the rays the CWBVH tests trace, and hit comparisons bit for bit.
#pragma once

#include <gtest/gtest.h>

#include <bit>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/io/rays.h"

namespace irgrid::testing {

/// One batch of standard rays of a scene.
struct CwbvhWorkload {
  std::vector<Ray> rays;
  Query query;
  std::string what;
};

/// Primary, ao, diffuse and random rays from every view of `scene`, small images; secondary
/// rays from `source`'s primary hits.
inline std::vector<CwbvhWorkload> cwbvh_workloads(const Scene& scene, const Accelerator& source,
                                                  int width = 48, int height = 32) {
  RayConfig config;
  config.width = width, config.height = height, config.spp = 2,
  config.count = std::uint64_t(width) * std::uint64_t(height);
  std::vector<CwbvhWorkload> loads;
  const auto views = scene_views(scene);
  for (std::size_t v = 0; v < views.size(); ++v)
    for (RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random})
      loads.push_back({generate_rays(scene, views[v], kind, config, &source),
                       kind == RayKind::ao ? Query::any : Query::closest,
                       std::string(to_string(kind)) + " view " + std::to_string(v)});
  return loads;
}

/// Closest hits: the same triangle and the same t, u, v bit for bit. Any hits: the same answer
/// to "occluded?" (which triangle occludes depends on the order of the walk).
inline void expect_same_hits(const std::vector<Hit>& expected, const std::vector<Hit>& actual,
                             Query query, const std::string& what) {
  ASSERT_EQ(expected.size(), actual.size()) << what;
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const Hit& e = expected[i];
    const Hit& a = actual[i];
    const bool same =
        query == Query::any
            ? e.hit() == a.hit()
            : e.prim == a.prim &&
                  (!e.hit() ||
                   (std::bit_cast<std::uint32_t>(e.t) == std::bit_cast<std::uint32_t>(a.t) &&
                    std::bit_cast<std::uint32_t>(e.u) == std::bit_cast<std::uint32_t>(a.u) &&
                    std::bit_cast<std::uint32_t>(e.v) == std::bit_cast<std::uint32_t>(a.v)));
    if (same) continue;
    if (++wrong <= 3)
      ADD_FAILURE() << what << ": ray " << i << " expected prim " << e.prim << " t " << e.t
                    << ", got prim " << a.prim << " t " << a.t;
  }
  EXPECT_EQ(wrong, 0u) << what << ": rays that differ of " << expected.size();
}

/// Traces `rays` with `accelerator`, returning the hits.
inline std::vector<Hit> trace_all(const Accelerator& accelerator, const std::vector<Ray>& rays,
                                  Query query) {
  std::vector<Hit> hits(rays.size());
  accelerator.trace(rays, hits, query);
  return hits;
}

}  // namespace irgrid::testing
