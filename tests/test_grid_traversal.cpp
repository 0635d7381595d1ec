// Grid traversal equals the double-precision reference on adversarial rays, degenerate scenes
// and extreme parameters.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "api/grid_accelerator_base.h"
#include "core/construction/compress_cells.h"
#include "cpu/interleaved_walk.h"
#include "cpu/simd_walk.h"
#include "cpu/walk_policy.h"
#include "grid_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"

namespace irgrid {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Rays that start on cell faces and grid boundaries, run along grid planes and axes, start
/// inside cells with tmin > 0, stop early with tmax, and come from far outside.
std::vector<Ray> adversarial_rays(const Scene& scene) {
  const auto grid = testing::build_test_grid(scene);
  const GridInfo& info = grid.info;
  std::vector<Ray> rays = random_rays(scene.bounds(), 2000, 5);
  Pcg32 rng;
  rng.seed(99);
  auto plane = [&](int a, const Cell& c, bool upper) {
    return voxel_to_world(info, a, upper ? c.hi[a] : c.lo[a]);
  };
  for (int k = 0; k < 1500 && !grid.cells.empty(); ++k) {
    const Cell& c = grid.cells[rng.next_u32() % grid.cells.size()];
    const int a = int(rng.next_u32() % 3);
    Ray ray{};
    for (int b = 0; b < 3; ++b)
      ray.org[b] = plane(b, c, false) + rng.next_float() * (plane(b, c, true) - plane(b, c, false));
    ray.org[a] = plane(a, c, rng.next_u32() & 1);  // exactly on a face
    if (k % 3 == 0) {                              // along an axis
      ray.dir[int(rng.next_u32() % 3)] = (rng.next_u32() & 1) ? 1.f : -1.f;
    } else {
      for (float& d : ray.dir)
        d = rng.next_float() - 0.5f;
    }
    ray.tmin = (k % 5 == 0) ? 0.01f * scene.bounds().diagonal() : 0.f;
    ray.tmax = (k % 7 == 0) ? 0.2f * scene.bounds().diagonal() : kInf;
    testing::append_with_far_start(rays, ray, 10 * scene.bounds().diagonal());
  }
  testing::append_axis_rays_through_vertices(scene, rays);
  return rays;
}

void expect_exact(const Scene& scene, const std::string& structure, const BuildConfig& config,
                  const std::vector<Ray>& rays, const std::string& what) {
  AcceleratorOptions options;
  options.grid = config;
  const auto accelerator = make_accelerator(scene, parse_structure(structure), options);
  const ReferenceTracer reference(scene);
  for (Query query : {Query::closest, Query::any}) {
    std::vector<Hit> hits(rays.size());
    accelerator->trace(rays, hits, query);
    const auto result = validate_hits(reference, scene, rays, hits, query, rays.size());
    EXPECT_EQ(result.mismatches, 0u)
        << what << " " << structure << (query == Query::any ? " any" : " closest") << ": "
        << (result.examples.empty() ? "" : result.examples[0]);
  }
}

TEST(GridTraversal, CompressedAndFullCellsGiveIdenticalHits) {
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:3000", "builtin:soup:2000"}) {
    const Scene scene = load_scene(spec);
    const std::vector<Ray> rays = adversarial_rays(scene);
    AcceleratorOptions full, compressed;
    full.grid.compress = false;
    compressed.grid.compress = true;
    const auto a = make_accelerator(scene, Structure::irregular, full);
    const auto b = make_accelerator(scene, Structure::irregular, compressed);
    EXPECT_FALSE(a->build_stats().grid->compressed_cells);
    EXPECT_TRUE(b->build_stats().grid->compressed_cells);
    EXPECT_EQ(b->build_stats().grid->cells_bytes * 2,
              a->build_stats().grid->cells_bytes + 32);  // half, plus the 16-byte sentinel
    for (Query query : {Query::closest, Query::any}) {
      std::vector<Hit> hits_a(rays.size()), hits_b(rays.size());
      a->trace(rays, hits_a, query);
      b->trace(rays, hits_b, query);
      EXPECT_EQ(std::memcmp(hits_a.data(), hits_b.data(), rays.size() * sizeof(Hit)), 0) << spec;
    }
  }
}

TEST(GridTraversal, AdversarialRaysOnBuiltinScenes) {
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:3000", "builtin:soup:2000",
                           "builtin:hairball:4000", "builtin:cube"}) {
    const Scene scene = load_scene(spec);
    const auto rays = adversarial_rays(scene);
    for (const char* structure : {"irregular", "two-level", "uniform"})
      expect_exact(scene, structure, {}, rays, spec);
  }
}

TEST(GridTraversal, LeapsThroughEmptySpaceVisitFewerCellsForTheSameHits) {
  for (const char* spec : {"builtin:teapot-stadium:3000", "builtin:cornell", "builtin:soup:2000"}) {
    const Scene scene = load_scene(spec);
    std::vector<Ray> rays = adversarial_rays(scene);
    const std::vector<Ray> camera = primary_rays(auto_camera(scene.bounds()), 64, 64);
    rays.insert(rays.end(), camera.begin(), camera.end());
    AcceleratorOptions walled, leaping;
    walled.grid.skip_empty = false;
    leaping.grid.skip_empty = true;
    const auto a = make_accelerator(scene, Structure::irregular, walled);
    const auto b = make_accelerator(scene, Structure::irregular, leaping);
    EXPECT_EQ(a->build_stats().grid->empty_radii_bytes, 0u);
    EXPECT_GT(b->build_stats().grid->empty_radii_bytes, 0u);
    expect_exact(scene, "irregular", leaping.grid, rays, spec);
    std::vector<Hit> hits_a(rays.size()), hits_b(rays.size());
    std::vector<RayWork> work_a(rays.size()), work_b(rays.size());
    a->trace_counted(rays, hits_a, work_a, Query::closest);
    b->trace_counted(rays, hits_b, work_b, Query::closest);
    std::uint64_t cells_a = 0, cells_b = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      // The same closest triangle, or another at the same distance (a tie decided by which
      // cells were tested).
      EXPECT_TRUE(hits_a[i].prim == hits_b[i].prim || hits_a[i].t == hits_b[i].t)
          << spec << " ray " << i;
      cells_a += work_a[i].cells, cells_b += work_b[i].cells;
    }
    // A stadium is mostly empty space; in a closed room every top cell holds triangles. (After
    // a leap a ray may enter cells it would have passed inside a wider exit box, so a ray can
    // test a few more triangles than without leaps.)
    if (std::string(spec).starts_with("builtin:teapot-stadium"))
      EXPECT_LT(cells_b, cells_a) << spec;
    else
      EXPECT_LE(cells_b, cells_a) << spec;
  }
}

/// Random rays with tiny, subnormal and huge direction components.
std::vector<Ray> extreme_direction_rays(const Scene& scene) {
  std::vector<Ray> rays = random_rays(scene.bounds(), 600, 17);
  const float extremes[] = {1e-30f, -1e-39f, 1e-45f, 3e30f, -3e38f};
  for (std::size_t i = 0; i < rays.size(); ++i) {
    rays[i].dir[i % 3] = extremes[i % 5];
    if (i % 4 == 0) rays[i].dir[(i + 1) % 3] = extremes[(i / 5) % 5];
  }
  return rays;
}

/// A way of walking a chunk of rays on the CPU (cpu/walk_policy.h, interleaved_walk.h,
/// simd_walk.h); each must give every ray the hit and the work of its own walk.
template <Query kQuery, typename CellT>
using ChunkWalk = void (*)(const GridView&, const RayFields&, const HitFields&, std::span<RayWork>);

template <Query kQuery, typename CellT, typename Walk = ChunkWalk<kQuery, CellT>>
void expect_walk_equals_single(Walk walk, const GridView& view, const std::vector<Ray>& rays,
                               const std::string& what) {
  std::vector<Hit> single(rays.size()), walked(rays.size());
  std::vector<RayWork> single_work(rays.size()), walked_work(rays.size());
  trace_one_by_one<kQuery, CellT>(view, ray_fields(rays), hit_fields(single), single_work);
  walk(view, ray_fields(rays), hit_fields(walked), walked_work);
  EXPECT_EQ(std::memcmp(single.data(), walked.data(), rays.size() * sizeof(Hit)), 0) << what;
  std::size_t same_work = 0;
  for (std::size_t i = 0; i < rays.size(); ++i)
    same_work += single_work[i].cells == walked_work[i].cells &&
                 single_work[i].triangles == walked_work[i].triangles;
  EXPECT_EQ(same_work, rays.size()) << what;
  // Without counters: the same hits.
  std::fill(walked.begin(), walked.end(), Hit{0, -1.f, -1.f, -1.f});
  walk(view, ray_fields(rays), hit_fields(walked), {});
  EXPECT_EQ(std::memcmp(single.data(), walked.data(), rays.size() * sizeof(Hit)), 0) << what;
}

template <Query kQuery>
void expect_interleaved_equals_single(const GridView& view, const std::vector<Ray>& rays,
                                      const std::string& what) {
  expect_walk_equals_single<kQuery, Cell>(trace_interleaved<kQuery, Cell>, view, rays, what);
}

/// Adversarial rays of three built-in scenes, more rays than lanes and fewer, some of them
/// missing the grid box, and rays with extreme directions: every ray must get the hit and the work
/// of its own walk, whatever lane it ran in and whenever that lane was refilled.
template <typename Check>
void for_adversarial_ray_sets(Check check) {
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:3000", "builtin:soup:2000"}) {
    const Scene scene = load_scene(spec);
    const auto grid = testing::build_test_grid(scene, BuildConfig{});
    const std::vector<Ray> rays = adversarial_rays(scene);
    const std::vector<Ray> few(rays.begin(), rays.begin() + 3);
    const std::vector<Ray> extreme = extreme_direction_rays(scene);
    check(grid, rays, spec);
    check(grid, few, std::string(spec) + " (3 rays)");
    check(grid, extreme, std::string(spec) + " (extreme directions)");
    // Camera rays in image order: neighbouring lanes share cells (the SIMD walk's packets).
    check(grid, primary_rays(auto_camera(scene.bounds()), 97, 61),
          std::string(spec) + " (camera rays)");
  }
  // Rays whose float t needs its redo in double (the lanes leave those tests to the scalar one).
  const Scene sliver = testing::scene_from_triangles(testing::sliver_beside_square_triangles());
  check(testing::build_test_grid(sliver, BuildConfig{}),
        testing::rays_near_the_slivers_plane(3000, 11), "sliver beside a square");
}

TEST(GridTraversal, InterleavedWalksEqualSingleWalks) {
  for_adversarial_ray_sets([](const auto& grid, const auto& rays, const std::string& what) {
    const GridView view = make_grid_view(grid, nullptr);
    expect_interleaved_equals_single<Query::closest>(view, rays, what);
    expect_interleaved_equals_single<Query::any>(view, rays, what);
  });
}

/// The SIMD walk of `kIsa` with its lanes given rays as `lane_rays` says, as a ChunkWalk.
template <SimdIsa kIsa, Query kQuery, typename CellT>
auto simd_walk(SimdRays lane_rays) {
  return [lane_rays](const GridView& view, const RayFields& rays, const HitFields& hits,
                     std::span<RayWork> work) {
    trace_simd_lanes<kIsa, kQuery, CellT>(view, rays, hits, work, lane_rays);
  };
}

// The SIMD walk of `kIsa` against single walks, lanes given rays either way, with both cell
// layouts: the full cells of the build, and the compressed ones.
template <SimdIsa kIsa>
void expect_simd_walks_equal_single_walks() {
  for_adversarial_ray_sets([](const auto& grid, const auto& rays, const std::string& what) {
    ASSERT_TRUE(simd_walk_fits(grid.info));
    const GridView view = make_grid_view(grid, nullptr);
    CpuExecutor exec;
    CpuExecutor::Buffer<CompactCell> compact;
    compress_cells(exec, grid, compact);
    const GridView compact_view = make_grid_view(grid, compact.data());
    for (const SimdRays lane_rays : {SimdRays::independent, SimdRays::packets}) {
      const std::string how = what + (lane_rays == SimdRays::packets ? ", packets" : "");
      expect_walk_equals_single<Query::closest, Cell>(
          simd_walk<kIsa, Query::closest, Cell>(lane_rays), view, rays, how);
      expect_walk_equals_single<Query::any, Cell>(simd_walk<kIsa, Query::any, Cell>(lane_rays),
                                                  view, rays, how);
      expect_walk_equals_single<Query::closest, CompactCell>(
          simd_walk<kIsa, Query::closest, CompactCell>(lane_rays), compact_view, rays,
          how + ", compressed");
      expect_walk_equals_single<Query::any, CompactCell>(
          simd_walk<kIsa, Query::any, CompactCell>(lane_rays), compact_view, rays,
          how + ", compressed");
    }
  });
}

TEST(GridTraversal, SimdWalksEqualSingleWalks) {
  if (!cpu_has(SimdIsa::avx2)) GTEST_SKIP() << "this CPU has no AVX2";
  expect_simd_walks_equal_single_walks<SimdIsa::avx2>();
}

TEST(GridTraversal, Avx512WalksEqualSingleWalks) {
  if (!cpu_has(SimdIsa::avx512)) GTEST_SKIP() << "this CPU has no AVX-512";
  expect_simd_walks_equal_single_walks<SimdIsa::avx512>();
}

TEST(WalkPolicy, CameraRaysAreCoherentRandomRaysAreNot) {
  const Scene scene = load_scene("builtin:cornell");
  const auto grid = testing::build_test_grid(scene, BuildConfig{});
  const std::vector<Ray> camera = primary_rays(auto_camera(scene.bounds()), 256, 4);
  const std::vector<Ray> random = random_rays(scene.bounds(), 256, 3);
  EXPECT_TRUE(rays_are_coherent(grid.info, ray_fields(std::span(camera).subspan(0, 256))));
  EXPECT_FALSE(rays_are_coherent(grid.info, ray_fields(random)));
  EXPECT_FALSE(rays_are_coherent(grid.info, ray_fields(std::span(camera).subspan(0, 1))));
  // Both ways give the same hits and work, so the choice only changes the speed.
  const GridView view = make_grid_view(grid, nullptr);
  expect_interleaved_equals_single<Query::closest>(view, camera, "camera rays");
  expect_interleaved_equals_single<Query::closest>(view, random, "random rays");
}

TEST(GridTraversal, RaysWithExtremeDirectionComponents) {
  // Tiny, subnormal and huge direction components: plane times that underflow or overflow must
  // neither stall the walk nor send it off the ray's path.
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:3000"}) {
    const Scene scene = load_scene(spec);
    const std::vector<Ray> rays = extreme_direction_rays(scene);
    expect_exact(scene, "irregular", {}, rays, spec);
    expect_exact(scene, "brute", {}, rays, spec);
  }
}

TEST(GridTraversal, DegenerateScenes) {
  const std::vector<std::pair<std::string, std::vector<std::array<Vec3f, 3>>>> scenes = {
      {"one triangle", {{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}}},
      {"coplanar axis-aligned",
       {{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}},
        {{{1, 0, 0}, {1, 1, 0}, {0, 1, 0}}},
        {{{2, 0, 0}, {3, 0, 0}, {2, 5, 0}}},
        {{{-4, -4, 0}, {-3, -4, 0}, {-4, -3, 0}}}}},
      {"flat in y", {{{{0, 2, 0}, {1, 2, 0}, {0, 2, 1}}}, {{{5, 2, 5}, {6, 2, 5}, {5, 2, 7}}}}},
      {"tiny and huge",
       {{{{0, 0, 0}, {1e-4f, 0, 0}, {0, 1e-4f, 0}}},
        {{{-1e4f, -1e4f, 5}, {1e4f, -1e4f, 5}, {0, 1e4f, 5}}}}},
      {"flat mesh", testing::flat_mesh_triangles(30)},
  };
  for (const auto& [what, triangles] : scenes) {
    const Scene scene = testing::scene_from_triangles(triangles);
    const auto rays = adversarial_rays(scene);
    for (const char* structure : {"irregular", "two-level", "uniform"})
      expect_exact(scene, structure, {}, rays, what);
  }
}

TEST(GridTraversal, RaysNearALongSliversPlaneGetTheDoubleT) {
  const Scene scene = testing::scene_from_triangles(testing::sliver_beside_square_triangles());
  const auto rays = testing::rays_near_the_slivers_plane(20000, 4);
  std::vector<Hit> reference(rays.size());
  trace_reference_double(scene, rays, reference, Query::closest);
  for (const char* structure : {"irregular", "two-level", "uniform"}) {
    std::vector<Hit> hits(rays.size());
    make_accelerator(scene, parse_structure(structure))->trace(rays, hits, Query::closest);
    testing::expect_hits_match_reference(scene, rays, hits, reference, 0.05, structure);
  }
}

TEST(GridTraversal, ScenesWithoutValidTrianglesMissEverything) {
  const Scene scene = testing::scene_from_triangles({{{{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}}});
  ASSERT_EQ(scene.triangle_count(), 0u);
  const auto accelerator = make_accelerator(scene, Structure::irregular);
  const std::vector<Ray> rays = {{{0, 0, 0}, 0, {1, 1, 1}, kInf}};
  std::vector<Hit> hits(1);
  accelerator->trace(rays, hits, Query::closest);
  EXPECT_FALSE(hits[0].hit());
}

TEST(GridTraversal, ExtremeParameters) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  const auto rays = adversarial_rays(scene);
  std::vector<BuildConfig> configs(6);
  configs[0].lambda1 = 1e-4f;
  configs[1].lambda1 = 8.f;
  configs[2].lambda2 = 0.f;
  configs[3].lambda2 = 64.f;
  configs[4].alpha = 0.f, configs[4].expansion_passes = 0;
  configs[5].alpha = 1.f;
  for (std::size_t i = 0; i < configs.size(); ++i)
    expect_exact(scene, "irregular", configs[i], rays, "config " + std::to_string(i));
}

}  // namespace
}  // namespace irgrid
