// The exact oracle: its conventions on hand-made cases, its culling against no culling, the grid
// against it on every built-in scene and ray kind, and validate_hits' kinds of fault.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "grid_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/exact.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"

namespace irgrid {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

TEST(ExactIntersection, BarycentricsWeighTheSecondAndThirdVertex) {
  // The line meets z = 0 at (1.5, 2) = 0.375 p0 + 0.125 p1 + 0.5 p2: three different weights.
  const Vec3f p0{1, 1, 0}, p1{5, 1, 0}, p2{1, 3, 0};
  const Ray ray{{1, 1.75f, -1}, 0, {0.5f, 0.25f, 1}, kInf};
  const ExactIntersection hit = intersect_exact(ray, p0, p1, p2);
  ASSERT_TRUE(hit.crosses);
  EXPECT_TRUE(hit.in_window);
  EXPECT_EQ(hit.t, 1.0);
  EXPECT_EQ(hit.u, 0.125);
  EXPECT_EQ(hit.v, 0.5);
  // Reversing the winding swaps the roles of p1 and p2, and so u and v; both faces are hit.
  const ExactIntersection reversed = intersect_exact(ray, p0, p2, p1);
  ASSERT_TRUE(reversed.crosses);
  EXPECT_EQ(reversed.u, 0.5);
  EXPECT_EQ(reversed.v, 0.125);
  // Beside the triangle: no crossing, but the plane's t and barycentrics are still exact.
  const ExactIntersection beside =
      intersect_exact({{6, 1.75f, -1}, 0, {0, 0, 1}, kInf}, p0, p1, p2);
  EXPECT_FALSE(beside.crosses);
  EXPECT_EQ(beside.t, 1.0);
  EXPECT_EQ(beside.u, 1.25);
  EXPECT_EQ(beside.v, 0.375);
}

TEST(ExactIntersection, IntervalEndsAreInclusiveAndExact) {
  const Vec3f p0{0, 0, 0}, p1{1, 0, 0}, p2{0, 1, 0};
  const auto window = [&](float tmin, float tmax) {
    return intersect_exact({{0.2f, 0.3f, -1}, tmin, {0, 0, 1}, tmax}, p0, p1, p2).in_window;
  };
  EXPECT_TRUE(window(0, 1));
  EXPECT_TRUE(window(1, 1));
  EXPECT_FALSE(window(0, std::nextafter(1.f, 0.f)));
  EXPECT_FALSE(window(std::nextafter(1.f, 2.f), kInf));
  EXPECT_FALSE(window(2, 1)) << "an empty interval";
  // A ray starting on the triangle hits it at t = 0.
  const ExactIntersection start =
      intersect_exact({{0.2f, 0.3f, 0}, 0, {0, 0, 1}, kInf}, p0, p1, p2);
  EXPECT_TRUE(start.in_window);
  EXPECT_EQ(start.t, 0.0);
}

TEST(ExactIntersection, DecidesWhereDoubleCannot) {
  // The line meets z = 0 at x + y = 1 +- 2^-62: 0.75 + 2^-62 rounds to 0.75 in double, so a
  // double test sees the edge itself on both rays.
  const Vec3f p0{0, 0, 0}, p1{1, 0, 0}, p2{0, 1, 0};
  const float tiny = 0x1p-62f;
  EXPECT_FALSE(intersect_exact({{0.75f, 0.25f, -1}, 0, {tiny, 0, 1}, kInf}, p0, p1, p2).crosses);
  EXPECT_TRUE(intersect_exact({{0.75f, 0.25f, -1}, 0, {-tiny, 0, 1}, kInf}, p0, p1, p2).crosses);
  // t just beyond tmax = 1, by a relative 2^-24.
  const Ray late{{0.25f, 0.25f, -1}, 0, {0, 0, 1 - 0x1p-24f}, 1};
  const ExactIntersection hit = intersect_exact(late, p0, p1, p2);
  EXPECT_TRUE(hit.crosses);
  EXPECT_FALSE(hit.in_window) << "t = 1 / (1 - 2^-24) > 1";
}

TEST(ExactIntersection, DegenerateInputsNeverCross) {
  const Vec3f p0{0, 0, 0}, p1{1, 0, 0}, p2{0, 1, 0};
  EXPECT_FALSE(intersect_exact({{0.2f, 0.2f, -1}, 0, {0, 0, 0}, kInf}, p0, p1, p2).crosses);
  EXPECT_FALSE(intersect_exact({{NAN, 0.2f, -1}, 0, {0, 0, 1}, kInf}, p0, p1, p2).crosses);
  EXPECT_FALSE(intersect_exact({{0.2f, 0.2f, -1}, NAN, {0, 0, 1}, kInf}, p0, p1, p2).crosses);
  const ExactIntersection in_plane =
      intersect_exact({{-1, 0.2f, 0}, 0, {1, 0, 0}, kInf}, p0, p1, p2);
  EXPECT_FALSE(in_plane.crosses);
  EXPECT_TRUE(in_plane.parallel);
  EXPECT_TRUE(std::isnan(in_plane.t));
  EXPECT_FALSE(intersect_exact({{0.2f, 0.2f, -1}, 0, {0, 0, 1}, kInf}, p0, p1, {2, 0, 0}).crosses)
      << "a collinear triangle";
}

/// How many triangles of the scene the whole line of `ray` crosses.
int crossings(const Scene& scene, Ray ray) {
  ray.tmin = -kInf, ray.tmax = kInf;
  int count = 0;
  for (const auto& tri : scene.triangles)
    count +=
        intersect_exact(ray, scene.vertices[tri[0]], scene.vertices[tri[1]], scene.vertices[tri[2]])
            .crosses;
  return count;
}

TEST(ExactIntersection, LinesThroughVerticesAndEdgesCrossAClosedMeshAnEvenNumberOfTimes) {
  // A line crosses a closed surface an even number of times; through a vertex or along an edge
  // point, one triangle around it must claim the crossing, never none or two.
  Pcg32 rng;
  rng.seed(9);
  const auto direction = [&] {
    return std::array<float, 3>{rng.next_float() - 0.5f, rng.next_float() - 0.5f,
                                rng.next_float() - 0.5f};
  };
  for (const char* spec : {"builtin:cube", "builtin:sphere:320"}) {
    const Scene scene = load_scene(spec);
    std::vector<Vec3f> points(scene.vertices.begin(), scene.vertices.end());
    if (std::string(spec) == "builtin:cube")  // its edges are axis-parallel or face diagonals
      for (const auto& tri : scene.triangles)
        for (int e = 0; e < 3; ++e) {
          const Vec3f a = scene.vertices[tri[e]], b = scene.vertices[tri[(e + 1) % 3]];
          points.push_back({0.75f * a[0] + 0.25f * b[0], 0.75f * a[1] + 0.25f * b[1],
                            0.75f * a[2] + 0.25f * b[2]});
        }
    int crossing_lines = 0;
    for (const Vec3f& point : points)
      for (int k = 0; k < 6; ++k) {
        const auto d = direction();
        const int count =
            crossings(scene, {{point[0], point[1], point[2]}, 0, {d[0], d[1], d[2]}, 0});
        EXPECT_EQ(count % 2, 0) << spec << " through " << point[0] << "," << point[1] << ","
                                << point[2];
        crossing_lines += count > 0;
      }
    EXPECT_GT(crossing_lines, int(points.size())) << spec << ": most lines enter the solid";
  }
  // Axis-parallel lines along the cube's edges and through its corners: the face seen edge-on
  // is never crossed, and the line crosses 0 or 2 others.
  const Scene cube = load_scene("builtin:cube");
  for (float a : {-1.f, 0.f, 1.f})
    for (float b : {-1.f, 0.f, 1.f})
      for (int axis = 0; axis < 3; ++axis) {
        Ray ray{{a, b, 0}, 0, {0, 0, 0}, 0};
        std::swap(ray.org[axis], ray.org[2]);
        ray.dir[axis] = 1;
        const int count = crossings(cube, ray);
        EXPECT_TRUE(count == 0 || count == 2) << a << "," << b << " axis " << axis << ": " << count;
      }
}

/// Random rays plus the awkward ones: axis-parallel through vertices, origins on vertices,
/// and cut-offs by tmin and tmax.
std::vector<Ray> awkward_rays(const Scene& scene, std::size_t count) {
  auto rays = random_rays(scene.bounds(), count, 17);
  Pcg32 rng;
  rng.seed(4);
  for (std::size_t k = 0; k < count / 10; ++k) {
    const auto& v = scene.vertices[scene.triangles[rng.next_u32() % scene.triangles.size()][0]];
    for (int axis = 0; axis < 3; ++axis) {
      Ray ray{{v[0], v[1], v[2]}, 0, {0, 0, 0}, kInf};
      ray.org[axis] -= 2 * scene.bounds().diagonal();
      ray.dir[axis] = 1;
      rays.push_back(ray);
      ray.tmin = 2 * scene.bounds().diagonal();  // starts exactly at the vertex
      rays.push_back(ray);
    }
  }
  for (std::size_t i = 0; i < count / 5; ++i) {
    Ray cut = rays[i];
    cut.tmin = 0.1f * rng.next_float();
    cut.tmax = cut.tmin + rng.next_float();
    rays.push_back(cut);
  }
  return rays;
}

TEST(ExactTracer, CullingNeverChangesAnAnswer) {
  for (const char* spec : {"builtin:cornell", "builtin:soup:1500", "builtin:cube",
                           "builtin:hairball:1500", "builtin:teapot-stadium:1500"}) {
    const Scene scene = load_scene(spec);
    const ExactTracer oracle(scene);
    const auto rays = awkward_rays(scene, 1500);
    for (const Query query : {Query::closest, Query::any}) {
      std::vector<Hit> culled(rays.size()), all(rays.size());
      oracle.trace(rays, culled, query);
      oracle.trace_all_triangles(rays, all, query);
      std::size_t hits = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        hits += all[i].hit();
        if (query == Query::closest)
          ASSERT_EQ(std::memcmp(&culled[i], &all[i], sizeof(Hit)), 0) << spec << " ray " << i;
        else
          ASSERT_EQ(culled[i].hit(), all[i].hit()) << spec << " ray " << i;
      }
      EXPECT_GT(hits, rays.size() / 20) << spec;
    }
  }
}

TEST(ExactTracer, GridAgreesOnEveryBuiltinSceneAndRayKind) {
  // The CI sample of `bench --validate --exact`: every ray checked, t, u, v included.
  RayConfig config;
  config.width = 48, config.height = 32, config.spp = 2, config.count = 3000;
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:20000",
                           "builtin:hairball:20000", "builtin:soup:5000", "builtin:sphere"}) {
    const Scene scene = load_scene(spec);
    const auto grid = make_accelerator(scene, Structure::irregular);
    const ExactTracer oracle(scene);
    const Camera camera = scene_views(scene).front();
    std::uint64_t fragile = 0;
    for (const RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random}) {
      const auto rays = generate_rays(scene, camera, kind, config, grid.get());
      const Query query = kind == RayKind::ao ? Query::any : Query::closest;
      std::vector<Hit> hits(rays.size());
      grid->trace(rays, hits, query);
      const Validation v = validate_hits(oracle, scene, rays, hits, query, rays.size());
      EXPECT_EQ(v.checked, rays.size());
      EXPECT_EQ(v.mismatches, 0u) << spec << " " << to_string(kind) << ": "
                                  << (v.examples.empty() ? "" : v.examples.front());
      EXPECT_EQ(v.unlocated, 0u) << "irgrid's any-hit answers say where";
      fragile += v.fragile;
    }
    EXPECT_LT(fragile, 50u) << spec << ": fragile cases are rare";
  }
}

TEST(Validation, CountsEachKindOfFaultSeparately) {
  const Scene scene = load_scene("builtin:cornell");
  const auto grid = make_accelerator(scene, Structure::irregular);
  const ExactTracer oracle(scene);
  RayConfig config;
  config.width = 40, config.height = 30;
  const auto rays =
      generate_rays(scene, scene_views(scene).front(), RayKind::primary, config, nullptr);
  std::vector<Hit> hits(rays.size());
  grid->trace(rays, hits, Query::closest);
  ASSERT_EQ(validate_hits(oracle, scene, rays, hits, Query::closest, rays.size()).mismatches, 0u);
  // Corrupt one aspect of every hit whose u and v differ clearly.
  std::uint64_t corrupted = 0;
  auto with = [&](auto change) {
    std::vector<Hit> bad = hits;
    corrupted = 0;
    for (Hit& h : bad)
      if (h.hit() && std::abs(h.u - h.v) > 0.05f) change(h), ++corrupted;
    return validate_hits(oracle, scene, rays, bad, Query::closest, rays.size());
  };
  const Validation swapped = with([](Hit& h) { std::swap(h.u, h.v); });
  ASSERT_GT(corrupted, 100u);
  EXPECT_EQ(swapped.wrong_uv, corrupted);
  EXPECT_EQ(swapped.wrong_triangle + swapped.wrong_t + swapped.outside_window, 0u);
  EXPECT_EQ(swapped.mismatches, corrupted);
  const Validation far = with([](Hit& h) { h.t *= 1.001f; });
  EXPECT_EQ(far.wrong_t, corrupted);
  EXPECT_EQ(far.wrong_uv, 0u);
  const Validation other = with([&](Hit& h) { h.prim = (h.prim + 1) % scene.triangle_count(); });
  EXPECT_GT(other.wrong_triangle, corrupted * 9 / 10);
  // Any hit: a t beyond tmax is caught; Embree's "occluded, somewhere" (t NaN) is accepted.
  std::vector<Hit> any(rays.size());
  grid->trace(rays, any, Query::any);
  std::vector<Ray> short_rays = rays;
  for (std::size_t i = 0; i < rays.size(); ++i)
    if (any[i].hit()) short_rays[i].tmax = any[i].t;
  auto late = any;
  std::uint64_t moved = 0;
  for (Hit& h : late)
    if (h.hit()) h.t = std::nextafter(h.t, kInf), ++moved;
  const Validation outside =
      validate_hits(oracle, scene, short_rays, late, Query::any, rays.size());
  EXPECT_EQ(outside.outside_window, moved);
  auto unlocated = any;
  for (Hit& h : unlocated)
    if (h.hit()) h = {0, NAN, 0, 0};
  const Validation embree_like =
      validate_hits(oracle, scene, rays, unlocated, Query::any, rays.size());
  EXPECT_EQ(embree_like.mismatches, 0u);
  EXPECT_EQ(embree_like.unlocated, moved);
}

}  // namespace
}  // namespace irgrid
