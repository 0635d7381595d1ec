// The fast double-precision reference returns exactly what the double brute force returns.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "irgrid/accelerator.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"

namespace irgrid {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Random rays plus the awkward ones: axis-parallel through vertices and edge midpoints,
/// origins on triangle planes, cut-offs by tmin and tmax.
std::vector<Ray> awkward_rays(const Scene& scene) {
  auto rays = random_rays(scene.bounds(), 3000, 11);
  Pcg32 rng;
  rng.seed(3);
  for (std::size_t k = 0; k < 300; ++k) {
    const auto& tri = scene.triangles[rng.next_u32() % scene.triangles.size()];
    const auto& a = scene.vertices[tri[0]];
    const auto& b = scene.vertices[tri[1]];
    const float mid[3] = {0.5f * (a[0] + b[0]), 0.5f * (a[1] + b[1]), 0.5f * (a[2] + b[2])};
    for (int axis = 0; axis < 3; ++axis) {
      Ray ray{{mid[0], mid[1], mid[2]}, 0, {0, 0, 0}, kInf};
      ray.org[axis] = scene.bounds().lo[axis] - 1;
      ray.dir[axis] = 1;
      rays.push_back(ray);
      Ray at_vertex{{a[0], a[1], a[2]}, 0, {0, 0, 0}, kInf};
      at_vertex.org[axis] += 2 * scene.bounds().diagonal();
      at_vertex.dir[axis] = -1;
      rays.push_back(at_vertex);
      at_vertex.tmin = 2 * scene.bounds().diagonal();  // starts exactly at the vertex
      rays.push_back(at_vertex);
    }
  }
  for (std::size_t i = 0; i < 500; ++i) {
    Ray cut = rays[i];
    cut.tmin = 0.1f * rng.next_float();
    cut.tmax = cut.tmin + rng.next_float();
    rays.push_back(cut);
  }
  return rays;
}

TEST(ReferenceTracer, EqualsDoubleBruteForceExactly) {
  for (const char* spec : {"builtin:cornell", "builtin:soup:3000", "builtin:teapot-stadium:2000",
                           "builtin:hairball:3000", "builtin:cube"}) {
    const Scene scene = load_scene(spec);
    const ReferenceTracer reference(scene);
    const auto rays = awkward_rays(scene);
    std::vector<Hit> fast(rays.size()), slow(rays.size());
    reference.trace(rays, fast, Query::closest);
    trace_reference_double(scene, rays, slow, Query::closest);
    std::size_t hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      ASSERT_EQ(std::memcmp(&fast[i], &slow[i], sizeof(Hit)), 0) << spec << " ray " << i;
      hits += slow[i].hit();
    }
    EXPECT_GT(hits, rays.size() / 20) << spec;
    reference.trace(rays, fast, Query::any);
    trace_reference_double(scene, rays, slow, Query::any);
    for (std::size_t i = 0; i < rays.size(); ++i)
      ASSERT_EQ(fast[i].hit(), slow[i].hit()) << spec << " ray " << i;
  }
}

TEST(ReferenceTracer, HandlesEmptyAndDegenerateRays) {
  const Scene scene = load_scene("builtin:cube");
  const ReferenceTracer reference(scene);
  const std::vector<Ray> rays = {{{0, 0, 0}, 0, {0, 0, 0}, kInf},
                                 {{0, 0, -5}, 3, {0, 0, 1}, 2},
                                 {{NAN, 0, -5}, 0, {0, 0, 1}, kInf}};
  std::vector<Hit> hits(rays.size());
  reference.trace(rays, hits, Query::closest);
  for (const Hit& hit : hits)
    EXPECT_FALSE(hit.hit());
}

}  // namespace
}  // namespace irgrid
