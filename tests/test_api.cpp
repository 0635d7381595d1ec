// The library API as an embedder uses it: meshes from raw arrays, enums, typed statistics,
// concurrent traces, rebuilds, and the single-ray traversal of irgrid/kernel.h on the host.
#include <gtest/gtest.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <cstring>
#include <thread>
#include <vector>

#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"
#include "irgrid/irgrid.h"
#include "ray_test_support.h"

namespace irgrid {
namespace {

/// Rays of every standard kind over a scene's first view, small enough for a unit test.
std::vector<Ray> mixed_rays(const Scene& scene) {
  return testing::mixed_rays(scene, 64, 48, 4000);
}

bool same_hits(const std::vector<Hit>& a, const std::vector<Hit>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Hit)) == 0;
}

TEST(Api, EnumsRoundTripThroughTheirNames) {
  for (const Structure s : available_structures())
    EXPECT_EQ(parse_structure(to_string(s)), s);
  for (const Backend b : {Backend::cpu, Backend::cuda, Backend::automatic})
    EXPECT_EQ(parse_backend(to_string(b)), b);
  for (const CpuWalk w :
       {CpuWalk::automatic, CpuWalk::avx512, CpuWalk::avx2, CpuWalk::single, CpuWalk::interleaved})
    EXPECT_EQ(parse_cpu_walk(to_string(w)), w);
  EXPECT_EQ(parse_cpu_walk("simd"), CpuWalk::automatic);
  EXPECT_STREQ(to_string(BuildPhase::top_grid), "top grid");
  EXPECT_STREQ(to_string(BuildPhase::compress), "compress");
  EXPECT_THROW(parse_structure("kd-tree"), Error);
  EXPECT_THROW(parse_cpu_walk("avx9000"), Error);
}

TEST(Api, Float4PaddedVerticesGiveTheSameGridAsPackedOnes) {
  const Scene scene = load_scene("builtin:teapot-stadium:2000");
  std::vector<float> padded;
  for (const auto& v : scene.vertices)
    padded.insert(padded.end(), {v[0], v[1], v[2], -1e30f});  // the padding is never read
  TriangleMesh mesh = scene.mesh();
  mesh.vertices = padded.data();
  mesh.vertex_stride = 4 * sizeof(float);
  const auto a = make_accelerator(scene.mesh(), Structure::irregular);
  const auto b = make_accelerator(mesh, Structure::irregular);
  EXPECT_EQ(a->build_stats().grid->cells, b->build_stats().grid->cells);
  EXPECT_EQ(a->build_stats().memory_bytes, b->build_stats().memory_bytes);
  const auto rays = mixed_rays(scene);
  std::vector<Hit> ha(rays.size()), hb(rays.size());
  a->trace(rays, ha, Query::closest);
  b->trace(rays, hb, Query::closest);
  EXPECT_TRUE(same_hits(ha, hb));
}

TEST(Api, TheMeshIsCopiedSoItsArraysMayGoAway) {
  const Scene scene = load_scene("builtin:cornell");
  std::vector<float> vertices(&scene.vertices[0][0],
                              &scene.vertices[0][0] + 3 * scene.vertices.size());
  std::vector<std::uint32_t> indices(&scene.triangles[0][0],
                                     &scene.triangles[0][0] + 3 * scene.triangles.size());
  TriangleMesh mesh{vertices.data(), scene.vertices.size(), 12, indices.data(),
                    scene.triangles.size()};
  const auto grid = make_accelerator(mesh, Structure::irregular);
  const auto rays = mixed_rays(scene);
  std::vector<Hit> before(rays.size()), after(rays.size());
  grid->trace(rays, before, Query::closest);
  std::fill(vertices.begin(), vertices.end(), 0.f);
  vertices.clear();
  vertices.shrink_to_fit();
  grid->trace(rays, after, Query::closest);
  EXPECT_TRUE(same_hits(before, after));
}

TEST(Api, BadMeshesNameTheProblem) {
  const float vertices[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::uint32_t good[] = {0, 1, 2}, bad[] = {0, 1, 3};
  const auto message = [](const TriangleMesh& mesh) -> std::string {
    try {
      make_accelerator(mesh, Structure::irregular);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(message({vertices, 3, 12, bad, 1}).find("vertex 3"), std::string::npos);
  EXPECT_NE(message({vertices, 3, 10, good, 1}).find("vertex_stride 10"), std::string::npos);
  EXPECT_NE(message({nullptr, 3, 12, good, 1}).find("null"), std::string::npos);
  const float nan_vertex[] = {0, 0, 0, 1, 0, 0, 0, NAN, 0};
  EXPECT_NE(message({nan_vertex, 3, 12, good, 1}).find("not finite"), std::string::npos);
  EXPECT_NO_THROW(make_accelerator(TriangleMesh{}, Structure::irregular));  // empty is valid
}

TEST(Api, ConcurrentTracesFromEightThreadsAgreeWithOneTrace) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  const auto rays = mixed_rays(scene);
  for (const Structure structure : available_structures()) {
    const auto accelerator = make_accelerator(scene, structure);
    std::vector<Hit> expected(rays.size());
    accelerator->trace(rays, expected, Query::closest);
    std::vector<std::vector<Hit>> results(8, std::vector<Hit>(rays.size()));
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; ++t)
      threads.emplace_back([&, t] {
        for (int round = 0; round < 3; ++round)
          accelerator->trace(rays, results[std::size_t(t)],
                             round == 1 ? Query::any : Query::closest);
      });
    for (auto& thread : threads)
      thread.join();
    for (const auto& hits : results)
      EXPECT_TRUE(same_hits(hits, expected)) << to_string(structure);
  }
}

TEST(Api, RebuildGivesWhatAFreshBuildGives) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  Scene moved = scene;
  for (auto& v : moved.vertices)  // a twist about the vertical axis: every triangle moves
    v = {v[0] * 0.8f - v[2] * 0.6f, v[1] + 0.1f * v[0], v[0] * 0.6f + v[2] * 0.8f};
  const auto rays = mixed_rays(scene);
  for (const Structure structure : available_structures()) {
    const auto rebuilt = make_accelerator(scene, structure);
    rebuilt->rebuild(moved.mesh());
    const auto fresh = make_accelerator(moved, structure);
    std::vector<Hit> a(rays.size()), b(rays.size());
    for (Query query : {Query::closest, Query::any}) {
      rebuilt->trace(rays, a, query);
      fresh->trace(rays, b, query);
      EXPECT_TRUE(same_hits(a, b)) << to_string(structure);
    }
    if (fresh->build_stats().grid) {
      EXPECT_EQ(rebuilt->build_stats().grid->cells, fresh->build_stats().grid->cells);
      EXPECT_EQ(rebuilt->build_stats().memory_bytes, fresh->build_stats().memory_bytes);
    }
    rebuilt->rebuild(scene.mesh());  // and back
    const auto original = make_accelerator(scene, structure);
    rebuilt->trace(rays, a, Query::closest);
    original->trace(rays, b, Query::closest);
    EXPECT_TRUE(same_hits(a, b)) << to_string(structure) << " rebuilt back";
  }
}

TEST(Api, CpuRebuildsTakeEveryBlockFromThePool) {
  const Scene scene = load_scene("builtin:teapot-stadium:20000");
  // One thread: the octree builder's threads grow their buffers in an order that decides how
  // many blocks of a size are live together; alone, every rebuild asks for the same blocks in
  // the same order.
  tbb::task_arena one_thread(1);
  one_thread.execute([&] {
    const auto grid = make_accelerator(scene, Structure::irregular);
    EXPECT_GT(grid->build_stats().grid->fresh_allocations, 0u);
    // The first rebuilds fill the pool (the first build's cache was trimmed); a block taken for a
    // smaller class can make a later request of its own class allocate, once, and that request
    // can displace another: here the last fresh block comes in the fifth rebuild.
    for (int frame = 0; frame < 5; ++frame)
      grid->rebuild(scene.mesh());
    for (int frame = 0; frame < 3; ++frame) {
      grid->rebuild(scene.mesh());
      EXPECT_EQ(grid->build_stats().grid->fresh_allocations, 0u) << "frame " << frame;
    }
  });
  // With every thread, once the pool has settled (three rebuilds, as above), later rebuilds
  // allocate only where a size class is busier than before.
  const auto grid = make_accelerator(scene, Structure::irregular);
  std::uint64_t filling = 0;
  for (int frame = 0; frame < 3; ++frame) {
    grid->rebuild(scene.mesh());
    filling += grid->build_stats().grid->fresh_allocations;
  }
  std::uint64_t later = 0;
  for (int frame = 0; frame < 3; ++frame) {
    grid->rebuild(scene.mesh());
    later += grid->build_stats().grid->fresh_allocations;
  }
  EXPECT_LT(later * 20, filling) << filling << " blocks filled the pool, " << later << " more";
}

TEST(Api, RebuildRefusesAnotherTriangleCountAndKeepsTracing) {
  const Scene scene = load_scene("builtin:cornell");
  const auto grid = make_accelerator(scene, Structure::irregular);
  TriangleMesh fewer = scene.mesh();
  fewer.triangle_count -= 1;
  try {
    grid->rebuild(fewer);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
    EXPECT_NE(std::string(e.what()).find("triangles"), std::string::npos);
  }
  const auto rays = mixed_rays(scene);
  std::vector<Hit> a(rays.size()), b(rays.size());
  grid->trace(rays, a, Query::closest);
  make_accelerator(scene, Structure::irregular)->trace(rays, b, Query::closest);
  EXPECT_TRUE(same_hits(a, b)) << "a refused rebuild leaves the grid as it was";
}

TEST(Api, AGridLeftOnSmallPagesHasTheSameArraysAndHits) {
  // builtin:sphere:200000's arrays span several huge pages, so the default build moves them.
  const Scene scene = load_scene("builtin:sphere:200000");
  AcceleratorOptions small_pages;
  small_pages.grid.huge_pages = false;
  const auto moved = make_accelerator(scene, Structure::irregular);
  const auto left = make_accelerator(scene, Structure::irregular, small_pages);
  const GridView a = moved->grid_view(), b = left->grid_view();
  ASSERT_EQ(a.info.num_cells, b.info.num_cells);
  ASSERT_EQ(a.info.num_refs, b.info.num_refs);
  ASSERT_EQ(a.info.num_entries, b.info.num_entries);
  EXPECT_EQ(std::memcmp(a.refs, b.refs, a.info.num_refs * sizeof(a.refs[0])), 0);
  EXPECT_EQ(std::memcmp(a.entries, b.entries, a.info.num_entries * sizeof(a.entries[0])), 0);
  ASSERT_TRUE(a.compact_cells && b.compact_cells);
  EXPECT_EQ(std::memcmp(a.compact_cells, b.compact_cells,
                        (a.info.num_cells + 1) * sizeof(a.compact_cells[0])),
            0);
  const auto rays = mixed_rays(scene);
  std::vector<Hit> ha(rays.size()), hb(rays.size());
  moved->trace(rays, ha, Query::closest);
  left->trace(rays, hb, Query::closest);
  EXPECT_TRUE(same_hits(ha, hb));
}

TEST(Api, TheHeaderOnlyTraversalMatchesTrace) {
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:3000"})
    for (const bool compress : {true, false}) {
      const Scene scene = load_scene(spec);
      AcceleratorOptions options;
      options.grid.compress = compress;
      const auto grid = make_accelerator(scene, Structure::irregular, options);
      const GridView view = grid->grid_view();
      const auto rays = mixed_rays(scene);
      std::vector<Hit> closest(rays.size()), any(rays.size());
      grid->trace(rays, closest, Query::closest);
      grid->trace(rays, any, Query::any);
      std::size_t differing = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        const Hit c = closest_hit(view, rays[i]), a = any_hit(view, rays[i]);
        differing += std::memcmp(&c, &closest[i], sizeof(Hit)) != 0 || a.hit() != any[i].hit();
      }
      EXPECT_EQ(differing, 0u) << spec << (compress ? " compressed" : " full cells");
    }
  EXPECT_FALSE(closest_hit(make_accelerator(TriangleMesh{}, Structure::irregular)->grid_view(),
                           Ray{{0, 0, 0}, 0, {1, 0, 0}, 1})
                   .hit());
}

TEST(Api, CountedCrossingsTellInsideFromOutsideOfAClosedMesh) {
  const Scene sphere = load_scene("builtin:sphere:5000");  // the closed unit sphere
  Pcg32 rng(11);
  std::vector<Ray> rays(20000);
  std::vector<bool> inside(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i) {
    Ray& r = rays[i];
    for (int a = 0; a < 3; ++a)
      r.org[a] = 2.4f * rng.next_float() - 1.2f, r.dir[a] = rng.next_float() - 0.5f;
    r.tmin = 0, r.tmax = INFINITY;
    const float d2 = r.org[0] * r.org[0] + r.org[1] * r.org[1] + r.org[2] * r.org[2];
    inside[i] = d2 < 0.98f;                      // the mesh lies between radius 0.99 and 1
    if (d2 > 0.98f && d2 < 1.02f) r.org[0] = 5;  // no origins near the surface
  }
  for (const Structure structure : available_structures()) {
    const auto accelerator = make_accelerator(sphere, structure);
    std::vector<std::uint32_t> counts(rays.size());
    count_crossings(*accelerator, rays, counts);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < rays.size(); ++i)
      wrong += (counts[i] % 2 == 1) != inside[i] || counts[i] > 2;
    EXPECT_EQ(wrong, 0u) << to_string(structure);
  }
}

TEST(Api, DeviceCallsOnTheCpuBackendAreClearErrors) {
  const Scene scene = load_scene("builtin:cube");
  const auto grid = make_accelerator(scene, Structure::irregular);
  EXPECT_THROW(grid->trace_device(nullptr, nullptr, 1, Query::closest), Error);
  EXPECT_THROW(make_accelerator(scene, Structure::brute)->grid_view(), Error);
}

TEST(Api, BuildStatsAreTyped) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  const auto grid = make_accelerator(scene, Structure::irregular);
  const BuildStats& stats = grid->build_stats();
  ASSERT_TRUE(stats.grid.has_value());
  const GridStats& g = *stats.grid;
  EXPECT_GT(g.cells, 0u);
  EXPECT_GE(g.references, g.cells / 2);
  EXPECT_EQ(stats.memory_bytes, g.cells_bytes + g.references_bytes + g.voxel_map_bytes +
                                    g.triangles_bytes + g.empty_radii_bytes);
  EXPECT_EQ(g.triangles_bytes, scene.triangle_count() * 36);
  EXPECT_GE(g.lambda2_used, 2.4);
  for (const BuildPhase phase : {BuildPhase::top_grid, BuildPhase::merge, BuildPhase::expansion})
    EXPECT_TRUE(stats.phase_ms[std::size_t(phase)].has_value()) << to_string(phase);
  // A memory peak for every phase that ran, and the build's peak is the largest of them.
  std::uint64_t largest = 0;
  for (std::size_t p = 0; p < kBuildPhaseCount; ++p) {
    EXPECT_EQ(g.phase_peak_bytes[p].has_value(), stats.phase_ms[p].has_value())
        << to_string(BuildPhase(p));
    if (g.phase_peak_bytes[p]) largest = std::max(largest, *g.phase_peak_bytes[p]);
  }
  EXPECT_GE(*g.phase_peak_bytes[std::size_t(BuildPhase::merge)], g.triangles_bytes);
  EXPECT_EQ(g.peak_build_bytes, largest);
  EXPECT_TRUE(stats.primitives.empty());
  AcceleratorOptions options;
  options.profile_primitives = true;
  EXPECT_FALSE(
      make_accelerator(scene, Structure::irregular, options)->build_stats().primitives.empty());
  EXPECT_FALSE(make_accelerator(scene, Structure::brute)->build_stats().grid.has_value());
}

TEST(Api, EveryCpuWalkTheCpuHasGivesTheSameHits) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  const auto rays = mixed_rays(scene);
  std::vector<Hit> expected(rays.size()), hits(rays.size());
  make_accelerator(scene, Structure::irregular)->trace(rays, expected, Query::closest);
  for (const CpuWalk walk :
       {CpuWalk::avx512, CpuWalk::avx2, CpuWalk::single, CpuWalk::interleaved}) {
    AcceleratorOptions options;
    options.cpu_walk = walk;
    if (std::string(cpu_walk_in_use(walk)) != to_string(walk)) {
      EXPECT_THROW(make_accelerator(scene, Structure::irregular, options), Error)
          << to_string(walk);
      continue;
    }
    make_accelerator(scene, Structure::irregular, options)->trace(rays, hits, Query::closest);
    EXPECT_TRUE(same_hits(hits, expected)) << to_string(walk);
  }
}

}  // namespace
}  // namespace irgrid
