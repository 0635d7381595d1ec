// The watertight triangle test: no ray slips through shared edges or vertices of closed meshes,
// and the float test agrees with the double-precision reference.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>

#include "grid_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/random.h"
#include "irgrid/io/scene.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/watertight.h"

namespace irgrid {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

Ray ray_towards(Vec3<float> origin, Vec3<float> target) {
  const auto dir = target - origin;
  return {{origin.x, origin.y, origin.z}, 0.f, {dir.x, dir.y, dir.z}, kInf};
}

Vec3<float> random_point_on_sphere(Pcg32& rng, float radius) {
  const float z = 1 - 2 * rng.next_float(), phi = 6.2831853f * rng.next_float();
  const float r = std::sqrt(std::max(0.f, 1 - z * z));
  return Vec3<float>{r * std::cos(phi), r * std::sin(phi), z} * radius;
}

/// A point on the mesh where triangles meet (a vertex or a point on an edge), in float as the
/// rays will see it, with the triangles that share it.
struct SharedPoint {
  Vec3<float> position;
  std::vector<std::size_t> triangles;
};

std::vector<SharedPoint> vertices_and_edge_points(const Scene& scene) {
  std::vector<SharedPoint> points(scene.vertices.size());
  for (std::size_t v = 0; v < points.size(); ++v)
    points[v].position = Vec3<float>::from(scene.vertices[v]);
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::size_t>> edges;
  for (std::size_t t = 0; t < scene.triangles.size(); ++t)
    for (int e = 0; e < 3; ++e) {
      const auto a = scene.triangles[t][e], b = scene.triangles[t][(e + 1) % 3];
      points[a].triangles.push_back(t);
      edges[{std::min(a, b), std::max(a, b)}].push_back(t);
    }
  for (const auto& [edge, triangles] : edges) {
    const auto a = Vec3<float>::from(scene.vertices[edge.first]);
    const auto b = Vec3<float>::from(scene.vertices[edge.second]);
    points.push_back({(a + b) * 0.5f, triangles});
    points.push_back({a + (b - a) * 0.3f, triangles});
  }
  return points;
}

/// Whether every triangle at the point clearly faces `origin`, or every one clearly faces away,
/// so that a ray from the origin through the point crosses the surface there instead of grazing
/// a silhouette (where a miss is legitimate).
bool crosses_transversally(const Scene& scene, const SharedPoint& point, Vec3<float> origin) {
  const auto to_point = normalize(Vec3d::from(&point.position.x) - Vec3d::from(&origin.x));
  int facing = 0, away = 0;
  for (std::size_t t : point.triangles) {
    const auto& tri = scene.triangles[t];
    const auto p0 = Vec3d::from(scene.vertices[tri[0]]);
    const auto n = normalize(
        cross(Vec3d::from(scene.vertices[tri[1]]) - p0, Vec3d::from(scene.vertices[tri[2]]) - p0));
    const double cosine = dot(n, to_point);
    facing += cosine < -0.05;
    away += cosine > 0.05;
  }
  const auto all = int(point.triangles.size());
  return facing == all || away == all;
}

/// Aims rays from `origins` exactly at every vertex and edge point that they cross transversally;
/// counts the rays that miss. Returns {rays, misses}.
std::pair<std::size_t, std::size_t> count_leaks(const Scene& scene,
                                                const std::vector<Vec3<float>>& origins) {
  std::vector<Ray> rays;
  for (const auto& point : vertices_and_edge_points(scene))
    for (const auto& origin : origins)
      if (crosses_transversally(scene, point, origin))
        rays.push_back(ray_towards(origin, point.position));
  std::vector<Hit> hits(rays.size());
  make_accelerator(scene, Structure::brute)->trace(rays, hits, Query::closest);
  std::size_t leaks = 0;
  for (const Hit& hit : hits)
    leaks += !hit.hit();
  return {rays.size(), leaks};
}

TEST(Watertight, RaysFromOutsideAtEdgesAndVerticesNeverSlipThrough) {
  for (const char* spec : {"builtin:cube", "builtin:sphere:500"}) {
    const Scene scene = load_scene(spec);
    Pcg32 rng;
    rng.seed(1);
    std::vector<Vec3<float>> origins;
    for (int i = 0; i < 24; ++i)
      origins.push_back(random_point_on_sphere(rng, 7.3f));
    const auto [rays, leaks] = count_leaks(scene, origins);
    EXPECT_GT(rays, 500u) << spec;
    EXPECT_EQ(leaks, 0u) << spec;
  }
}

TEST(Watertight, RaysFromInsideAtEdgesAndVerticesNeverSlipThrough) {
  for (const char* spec : {"builtin:cube", "builtin:sphere:500"}) {
    const Scene scene = load_scene(spec);
    const std::vector<Vec3<float>> origins = {
        {0, 0, 0}, {0.1f, -0.2f, 0.3f}, {-0.31f, 0.05f, 0.12f}, {0.4f, 0.4f, -0.4f}};
    const auto [rays, leaks] = count_leaks(scene, origins);
    EXPECT_GT(rays, 100u) << spec;
    EXPECT_EQ(leaks, 0u) << spec;
  }
}

TEST(Watertight, AxisParallelRaysThroughEdgesOfTheCube) {
  const Scene scene = load_scene("builtin:cube");
  std::vector<Ray> rays;
  for (float a : {-1.f, -0.5f, 0.f, 0.5f, 1.f})
    for (float b : {-1.f, -0.5f, 0.f, 0.5f, 1.f}) {
      rays.push_back({{a, b, -5}, 0, {0, 0, 1}, kInf});
      rays.push_back({{a, -5, b}, 0, {0, 1, 0}, kInf});
      rays.push_back({{-5, a, b}, 0, {1, 0, 0}, kInf});
    }
  std::vector<Hit> hits(rays.size());
  make_accelerator(scene, Structure::brute)->trace(rays, hits, Query::closest);
  // Every ray enters through the near face, its edges or its corners (even those lying in the
  // plane of a side face): the boundary of a triangle belongs to it.
  for (std::size_t i = 0; i < rays.size(); ++i) {
    ASSERT_TRUE(hits[i].hit()) << "ray " << i;
    EXPECT_FLOAT_EQ(hits[i].t, 4.f) << "ray " << i;
  }
}

TEST(Watertight, IntervalIsInclusiveAndRespected) {
  const auto r = make_watertight_ray<float>({{0.2f, 0.2f, -1}, 0, {0, 0, 1}, 1});
  TriangleHit<float> hit{};
  const Vec3<float> p0{0, 0, 0}, p1{1, 0, 0}, p2{0, 1, 0};
  EXPECT_TRUE(intersect_watertight(r, p0, p1, p2, kInf, hit));
  EXPECT_FLOAT_EQ(hit.t, 1.f);
  EXPECT_FLOAT_EQ(hit.u, 0.2f);
  EXPECT_FLOAT_EQ(hit.v, 0.2f);
  EXPECT_FALSE(intersect_watertight(r, p0, p1, p2, 1.f, hit)) << "t_limit is exclusive";
  const auto short_ray = make_watertight_ray<float>({{0.2f, 0.2f, -1}, 0, {0, 0, 1}, 0.99f});
  EXPECT_FALSE(intersect_watertight(short_ray, p0, p1, p2, kInf, hit));
  const auto late_ray = make_watertight_ray<float>({{0.2f, 0.2f, -1}, 1.01f, {0, 0, 1}, kInf});
  EXPECT_FALSE(intersect_watertight(late_ray, p0, p1, p2, kInf, hit));
}

TEST(Watertight, BarycentricsWeighTheSecondAndThirdVertex) {
  // u and v differ (and differ from 1 - u - v), so swapping them, or naming the wrong vertex,
  // fails: p = (1 - u - v) p0 + u p1 + v p2.
  const Vec3<float> p0{1, 1, 0}, p1{5, 1, 0}, p2{1, 3, 0};
  const Vec3<float> target{1.5f, 2, 0};  // (1 - u - v) p0 + u p1 + v p2, u = 0.125, v = 0.5
  for (const float dz : {1.f, -1.f}) {
    const Ray ray = {{target.x, target.y, -2 * dz}, 0, {0, 0, dz}, kInf};
    TriangleHit<float> hit{};
    ASSERT_TRUE(intersect_watertight(make_watertight_ray<float>(ray), p0, p1, p2, kInf, hit));
    EXPECT_FLOAT_EQ(hit.t, 2.f);
    EXPECT_FLOAT_EQ(hit.u, 0.125f);
    EXPECT_FLOAT_EQ(hit.v, 0.5f);
  }
  // The same through a structure, with the vertices in a scene and a slanted ray.
  const Scene scene = testing::scene_from_triangles(
      {std::array<Vec3f, 3>{Vec3f{1, 1, 0}, Vec3f{5, 1, 0}, Vec3f{1, 3, 0}}});
  ASSERT_EQ(scene.triangle_count(), 1u);
  const std::vector<Ray> rays = {{{1, 1.75f, -1}, 0, {0.5f, 0.25f, 1}, kInf}};
  std::vector<Hit> hits(1);
  make_accelerator(scene, Structure::irregular)->trace(rays, hits, Query::closest);
  ASSERT_TRUE(hits[0].hit());
  EXPECT_FLOAT_EQ(hits[0].t, 1.f);
  EXPECT_FLOAT_EQ(hits[0].u, 0.125f);
  EXPECT_FLOAT_EQ(hits[0].v, 0.5f);
}

TEST(Watertight, DegenerateTrianglesAndRaysInThePlaneNeverHit) {
  TriangleHit<float> hit{};
  const auto r = make_watertight_ray<float>({{0.2f, 0.2f, -1}, 0, {0, 0, 1}, kInf});
  EXPECT_FALSE(intersect_watertight(r, {0, 0, 0}, {1, 0, 0}, {2, 0, 0}, kInf, hit));
  EXPECT_FALSE(intersect_watertight(r, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, kInf, hit));
  const auto in_plane = make_watertight_ray<float>({{-1, 0.2f, 0}, 0, {1, 0, 0}, kInf});
  EXPECT_FALSE(intersect_watertight(in_plane, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, kInf, hit));
}

TEST(Watertight, FloatAgreesWithDoubleReferenceOnARandomSoup) {
  const Scene scene = load_scene("builtin:soup:2000");
  Pcg32 rng;
  rng.seed(5);
  std::vector<Ray> rays(4000);
  for (auto& ray : rays) {
    const auto o = random_point_on_sphere(rng, 2.f) + Vec3<float>{0.5f, 0.5f, 0.5f};
    const Vec3<float> target{rng.next_float(), rng.next_float(), rng.next_float()};
    const auto d = target - o;
    ray = {{o.x, o.y, o.z}, 0, {d.x, d.y, d.z}, kInf};
  }
  std::vector<Hit> hits(rays.size()), reference(rays.size());
  make_accelerator(scene, Structure::brute)->trace(rays, hits, Query::closest);
  trace_reference_double(scene, rays, reference, Query::closest);
  std::size_t hit_count = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(hits[i].prim, reference[i].prim) << "ray " << i;
    if (!hits[i].hit()) continue;
    ++hit_count;
    EXPECT_NEAR(hits[i].t, reference[i].t, 1e-4f * reference[i].t);
    EXPECT_NEAR(hits[i].u, reference[i].u, 1e-3f);
    EXPECT_NEAR(hits[i].v, reference[i].v, 1e-3f);
  }
  EXPECT_GT(hit_count, rays.size() / 4) << "the test must exercise hits";
}

TEST(Watertight, FloatTNearALongSliversPlaneAgreesWithDouble) {
  // Before t_needs_double, 5% of these rays got a wrong hit or miss: a hit at t = 10.4 on a plane
  // 0.4 behind the origin, or a miss of one 0.1 ahead.
  const Scene scene = testing::scene_from_triangles(testing::sliver_beside_square_triangles());
  const auto rays = testing::rays_near_the_slivers_plane(20000, 3);
  std::vector<Hit> hits(rays.size()), reference(rays.size());
  make_accelerator(scene, Structure::brute)->trace(rays, hits, Query::closest);
  trace_reference_double(scene, rays, reference, Query::closest);
  const auto hit_count =
      std::count_if(reference.begin(), reference.end(), [](const Hit& hit) { return hit.hit(); });
  EXPECT_GT(hit_count, 2000) << "the test must exercise hits";
  testing::expect_hits_match_reference(scene, rays, hits, reference, 0.05, "brute force");
}

TEST(Watertight, NeedsDoubleOnlyWhereTheFloatTIsInDoubt) {
  // A unit triangle 5 units ahead: t is known to a few ulps, so no redo, whatever tmin and
  // tmax, unless one of them lies within that error of t.
  const auto r = make_watertight_ray<float>({{0.2f, 0.2f, -5}, 0, {0, 0, 1}, kInf});
  const Vec3<float> p[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  float x[3], y[3], z[3], depth[3], u, v, w;
  shear_triangle(r, p[0], p[1], p[2], x, y, z, depth);
  edge_functions(x, y, u, v, w);
  const float det = u + v + w, t = (u * z[0] + v * z[1] + w * z[2]) / det;
  ASSERT_FLOAT_EQ(t, 5.f);
  const auto needs = [&](float tmin, float tmax) {
    return t_needs_double<ScalarLanes>(x, y, z, depth, det, 1 / det, t, tmin, tmax);
  };
  EXPECT_FALSE(needs(0, kInf));
  EXPECT_FALSE(needs(5.1f, kInf)) << "surely before tmin";
  EXPECT_FALSE(needs(0, 4.9f)) << "surely after tmax";
  EXPECT_TRUE(needs(std::nextafter(t, 6.f), kInf)) << "tmin within the error of t";
  EXPECT_TRUE(needs(0, std::nextafter(t, 4.f))) << "tmax within the error of t";
  // Three rays near the long sliver's plane that the float test got wrong before its redo: a
  // hit at t = 43.05 instead of 0.88, a hit at 15.68 on a plane behind the origin, and a miss
  // of a plane 0.096 ahead.
  const Vec3<float> sliver[3] = {{0, 0, 0}, {1e5f, 0, 0}, {1e5f, 1, 1}};
  const std::vector<Ray> rays = {{{64047.2773f, -0.403385103f, 0.461094677f},
                                  0,
                                  {-0.68335402f, 0.589982867f, -0.390385389f},
                                  kInf},
                                 {{63622.0469f, 0.242202282f, -0.00944197178f},
                                  0,
                                  {-0.960756898f, 0.398730516f, -0.553178191f},
                                  kInf},
                                 {{96614.7266f, 0.590633214f, 0.611440599f},
                                  0,
                                  {0.968763828f, 0.95939362f, 0.741668582f},
                                  kInf}};
  const bool expected[3] = {true, false, true};
  const double expected_t[3] = {0.881790852, 0, 0.0955672595};
  for (int i = 0; i < 3; ++i) {
    TriangleHit<float> hit{};
    const bool hits = intersect_watertight(make_watertight_ray<float>(rays[i]), sliver[0],
                                           sliver[1], sliver[2], kInf, hit);
    ASSERT_EQ(hits, expected[i]) << "ray " << i;
    if (hits) EXPECT_NEAR(hit.t, expected_t[i], 1e-5) << "ray " << i;
  }
}

}  // namespace
}  // namespace irgrid
