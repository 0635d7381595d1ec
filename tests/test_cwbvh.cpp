// The compressed wide BVH (Ylitie et al. 2017) on the CPU: its layout, its build's invariants,
// and hits equal to the brute force's bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "baselines/cwbvh_build.h"
#include "cwbvh_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/io/rays.h"
#include "irgrid/kernel/cwbvh_traverse.h"

namespace irgrid {
namespace {

#if !IRGRID_HAS_EMBREE
TEST(Cwbvh, NeedsEmbreeAndSaysSo) {
  try {
    parse_structure("cwbvh");
    FAIL() << "cwbvh parsed in a build without Embree";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("needs Embree"), std::string::npos) << e.what();
  }
}
#else
using testing::cwbvh_workloads;
using testing::expect_same_hits;
using testing::trace_all;

const std::vector<std::string> kBuiltins = {"builtin:cornell",     "builtin:teapot-stadium:4000",
                                            "builtin:soup:3000",   "builtin:hairball:5000",
                                            "builtin:sphere:2000", "builtin:cube"};

TEST(Cwbvh, NodeIs80Bytes) {
  EXPECT_EQ(sizeof(CwbvhNode), 80u);
  EXPECT_EQ(std::string(to_string(Structure::cwbvh)), "cwbvh");
  EXPECT_EQ(parse_structure("cwbvh"), Structure::cwbvh);
}

TEST(Cwbvh, EqualsTheBruteForceBitForBitOnBuiltinScenes) {
  for (const auto& spec : kBuiltins) {
    const Scene scene = load_scene(spec);
    const auto brute = make_accelerator(scene, Structure::brute);
    const auto bvh = make_accelerator(scene, Structure::cwbvh);
    for (const auto& load : cwbvh_workloads(scene, *brute))
      expect_same_hits(trace_all(*brute, load.rays, load.query),
                       trace_all(*bvh, load.rays, load.query), load.query, spec + " " + load.what);
  }
}

TEST(Cwbvh, AnyHitAgreesWithClosestHitOnEveryRay) {
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  for (const auto& load : cwbvh_workloads(scene, *bvh)) {
    const auto closest = trace_all(*bvh, load.rays, Query::closest);
    const auto any = trace_all(*bvh, load.rays, Query::any);
    expect_same_hits(closest, any, Query::any, load.what);
  }
}

/// Every triangle is referenced, each leaf's box overlaps its triangles' boxes, and the stack
/// bound holds.
TEST(Cwbvh, BuildInvariants) {
  for (const auto& spec : kBuiltins) {
    const Scene scene = load_scene(spec);
    const HostCwbvh bvh = build_cwbvh(scene.mesh(), "");
    ASSERT_FALSE(bvh.nodes.empty()) << spec;
    EXPECT_LE(bvh.depth, std::uint32_t(kCwbvhStackSize)) << spec;
    std::vector<bool> seen(scene.triangle_count());
    for (const std::uint32_t id : bvh.refs) {
      ASSERT_LT(id, scene.triangle_count()) << spec;
      seen[id] = true;
    }
    EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](bool s) { return s; })) << spec;
    for (const CwbvhNode& node : bvh.nodes)
      for (int s = 0; s < kCwbvhWidth; ++s) {
        const std::uint32_t meta = node.meta[s];
        if (meta == 0 || ((node.imask >> s) & 1u)) continue;
        for (std::uint32_t k = 0; k < std::uint32_t(std::popcount(meta >> 5)); ++k) {
          const BoxF tri = triangle_box(bvh.triangles[bvh.refs[node.ref_base + (meta & 31u) + k]]);
          for (int a = 0; a < 3; ++a) {
            const float step = cwbvh_step(node.exp[a]);
            EXPECT_LE(cwbvh_plane(node.p[a], node.q_lo[a][s], step), tri.hi[a]) << spec;
            EXPECT_GE(cwbvh_plane(node.p[a], node.q_hi[a][s], step), tri.lo[a]) << spec;
          }
        }
      }
  }
}

TEST(Cwbvh, ReportsItsBuildAndMemory) {
  const Scene scene = load_scene("builtin:cornell");
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  const BuildStats& stats = bvh->build_stats();
  const HostCwbvh host = build_cwbvh(scene.mesh(), "");
  EXPECT_EQ(stats.memory_bytes, host.memory_bytes());
  EXPECT_EQ(stats.memory_bytes % 4, 0u);
  EXPECT_TRUE(stats.phase_ms[std::size_t(BuildPhase::bvh_build)].has_value());
  EXPECT_TRUE(stats.phase_ms[std::size_t(BuildPhase::bvh_compress)].has_value());
  EXPECT_FALSE(stats.phase_ms[std::size_t(BuildPhase::upload)].has_value());
  EXPECT_GT(stats.build_ms, 0.0);
  EXPECT_FALSE(stats.grid.has_value());
  ASSERT_TRUE(stats.bvh.has_value());
  EXPECT_EQ(stats.bvh->nodes, host.nodes.size());
  EXPECT_EQ(stats.bvh->references, host.refs.size());
  EXPECT_EQ(stats.bvh->depth, host.depth);
  EXPECT_EQ(stats.bvh->nodes_bytes + stats.bvh->references_bytes + stats.bvh->triangles_bytes,
            stats.memory_bytes);
}

Scene hand_made(std::vector<Vec3f> vertices, std::vector<std::array<std::uint32_t, 3> > triangles) {
  Scene scene;
  scene.name = "hand-made";
  scene.vertices = std::move(vertices);
  scene.triangles = std::move(triangles);
  return scene;
}

TEST(Cwbvh, OneTriangleIsARootLeafAndIsHit) {
  const Scene scene = hand_made({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  const std::vector<Ray> rays = {{{0.25f, 0.25f, 1}, 0, {0, 0, -1}, INFINITY},
                                 {{2, 2, 1}, 0, {0, 0, -1}, INFINITY}};
  const auto hits = trace_all(*bvh, rays, Query::closest);
  EXPECT_EQ(hits[0].prim, 0u);
  EXPECT_EQ(hits[0].t, 1.f);
  EXPECT_FALSE(hits[1].hit());
}

TEST(Cwbvh, DegenerateTrianglesBuildAndAreNeverHit) {
  // Zero-area triangles only: a point, a segment, and a flat box overall.
  const Scene scene =
      hand_made({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {1, 1, 0}}, {{0, 1, 2}, {3, 3, 3}, {0, 0, 1}});
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  const std::vector<Ray> rays = {{{1, 0, 1}, 0, {0, 0, -1}, INFINITY},
                                 {{1, 1, 1}, 0, {0, 0, -1}, INFINITY},
                                 {{-1, 0, 0}, 0, {1, 0, 0}, INFINITY}};
  for (Query query : {Query::closest, Query::any})
    for (const Hit& hit : trace_all(*bvh, rays, query))
      EXPECT_FALSE(hit.hit());
}

TEST(Cwbvh, StackedCopiesOfOneTriangleGiveTheSmallestId) {
  // 500 copies of one triangle: Embree cannot split them apart; the tree stays within its stack
  // and the closest hit is the first copy, as in the brute force.
  std::vector<std::array<std::uint32_t, 3> > triangles(500, {0, 1, 2});
  const Scene scene = hand_made({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, triangles);
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  const std::vector<Ray> rays = {{{0.2f, 0.3f, 1}, 0, {0, 0, -1}, INFINITY}};
  const auto hits = trace_all(*bvh, rays, Query::closest);
  EXPECT_EQ(hits[0].prim, 0u);
  EXPECT_TRUE(trace_all(*bvh, rays, Query::any)[0].hit());
}

TEST(Cwbvh, RebuildKeepsTheTriangleCountAndTracesTheNewPositions) {
  Scene scene = hand_made({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  for (auto& v : scene.vertices)
    v[2] = -2;  // the triangle moves to z = -2
  bvh->rebuild(scene.mesh());
  const std::vector<Ray> rays = {{{0.25f, 0.25f, 1}, 0, {0, 0, -1}, INFINITY}};
  EXPECT_EQ(trace_all(*bvh, rays, Query::closest)[0].t, 3.f);
  const Scene two = hand_made({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 1}});
  EXPECT_THROW(bvh->rebuild(two.mesh()), Error);
}

#endif  // IRGRID_HAS_EMBREE

}  // namespace
}  // namespace irgrid
