// The CUDA grid equals the CPU grid array for array, bit for bit, and traces the same hits
// (label gpu: every test skips without a device).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

#if IRGRID_HAS_CUDA
#include <cuda_runtime.h>
#endif

#include "core/construction/compress_cells.h"
#include "core/construction/grid_statistics.h"
#include "grid_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/rays.h"
#include "irgrid/system.h"
#include "test_requirements.h"
#if IRGRID_HAS_CUDA
#include "cuda/grid_cuda.h"
#endif

namespace irgrid {
namespace {

/// Shared scenes: $IRGRID_SHARED_SCENES (a bundle on another machine), else the build's path.
std::vector<std::string> shared_scene_paths() {
  const char* env = std::getenv("IRGRID_SHARED_SCENES");
  const std::filesystem::path root = env ? env : IRGRID_SHARED_SCENES;
  std::vector<std::string> paths;
  for (const char* file :
       {"crytek-sponza/sponza.obj.xz", "conference/conference.obj.xz", "crown/crown.obj.xz"})
    if (std::filesystem::exists(root / file)) paths.push_back((root / file).string());
  return paths;
}

const std::vector<std::string> kBuiltins = {"builtin:cornell",     "builtin:teapot-stadium:4000",
                                            "builtin:soup:3000",   "builtin:hairball:5000",
                                            "builtin:sphere:2000", "builtin:cube"};

template <typename T, typename Buffer>
void expect_same_array(const std::vector<T>& gpu, const Buffer& cpu, const std::string& what) {
  ASSERT_EQ(gpu.size(), cpu.size()) << what;
  EXPECT_EQ(std::memcmp(gpu.data(), cpu.data(), gpu.size() * sizeof(T)), 0) << what;
}

#if IRGRID_HAS_CUDA
void expect_same_grid(const Scene& scene, const BuildConfig& config, const std::string& what) {
  const auto cpu = testing::build_test_grid(scene, config);
  const HostGridArrays gpu = build_grid_cuda_arrays(scene.mesh(), config, 1);
  EXPECT_EQ(std::memcmp(&gpu.info, &cpu.info, sizeof(GridInfo)), 0) << what << ": GridInfo";
  expect_same_array(gpu.entries, cpu.entries, what + ": voxel map");
  expect_same_array(gpu.refs, cpu.refs, what + ": references");
  expect_same_array(gpu.empty_radii, cpu.empty_radii, what + ": empty radii");
  // Compressed cells expand in place of the full ones, which the GPU then drops.
  if (config.compress && fits_compact_cells(cpu.info)) {
    CpuExecutor exec;
    CpuExecutor::Buffer<CompactCell> compact;
    compress_cells(exec, cpu, compact);
    expect_same_array(gpu.compact_cells, compact, what + ": compressed cells");
    EXPECT_TRUE(gpu.cells.empty()) << what;
  } else {
    expect_same_array(gpu.cells, cpu.cells, what + ": cells");
    EXPECT_TRUE(gpu.compact_cells.empty()) << what;
  }
}
#endif

TEST(GpuGrid, SameArraysAsTheCpuOnBuiltinScenes) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_CUDA
  for (const auto& spec : kBuiltins) {
    const Scene scene = load_scene(spec);
    for (auto shape : {BuildConfig::Shape::irregular, BuildConfig::Shape::two_level,
                       BuildConfig::Shape::uniform}) {
      BuildConfig config;
      config.shape = shape;
      expect_same_grid(scene, config, spec + " " + std::to_string(int(shape)));
    }
    expect_same_grid(scene, testing::initial_grid_config(), spec + " initial grid");
  }
#endif
}

TEST(GpuGrid, SameArraysAsTheCpuOnSharedScenes) {
  IRGRID_SKIP_WITHOUT_GPU();
  const auto paths = shared_scene_paths();
  if (paths.empty())
    IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_SHARED_SCENES", "no shared scenes found");
#if IRGRID_HAS_CUDA
  for (const auto& path : paths)
    expect_same_grid(load_scene(path), BuildConfig{}, path);
#endif
}

TEST(GpuGrid, RebuildsAreIdenticalAndAllocateNothing) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_CUDA
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  const HostGridArrays once = build_grid_cuda_arrays(scene.mesh(), BuildConfig{}, 1);
  const HostGridArrays thrice = build_grid_cuda_arrays(scene.mesh(), BuildConfig{}, 3);
  EXPECT_EQ(thrice.fresh_allocations_last_build, 0u);
  EXPECT_EQ(std::memcmp(&once.info, &thrice.info, sizeof(GridInfo)), 0);
  expect_same_array(once.entries, thrice.entries, "voxel map");
  expect_same_array(once.cells, thrice.cells, "cells");
  expect_same_array(once.compact_cells, thrice.compact_cells, "compressed cells");
  expect_same_array(once.refs, thrice.refs, "references");
  expect_same_array(once.empty_radii, thrice.empty_radii, "empty radii");
#endif
}

/// The same rays on both backends give the same hits bit for bit, and the same work counts.
void expect_same_hits(const Scene& scene, const std::string& structure, const std::string& what) {
  AcceleratorOptions gpu_options;
  gpu_options.backend = Backend::cuda;
  const auto gpu = make_accelerator(scene, parse_structure(structure), gpu_options);
  const auto cpu = make_accelerator(scene, parse_structure(structure));
  ASSERT_EQ(gpu->backend(), Backend::cuda);
  // The same grid: every count (the peak build memory differs: host bytes vs device bytes).
  const GridStats& g = *gpu->build_stats().grid;
  const GridStats& c = *cpu->build_stats().grid;
  EXPECT_EQ(g.top_level_references, c.top_level_references) << what;
  EXPECT_EQ(g.cells, c.cells) << what;
  EXPECT_EQ(g.references, c.references) << what;
  EXPECT_EQ(g.voxel_map_entries, c.voxel_map_entries) << what;
  EXPECT_EQ(g.top_dims, c.top_dims) << what;
  EXPECT_EQ(g.depth, c.depth) << what;
  EXPECT_EQ(g.compressed_cells, c.compressed_cells) << what;
  EXPECT_EQ(gpu->build_stats().memory_bytes, cpu->build_stats().memory_bytes) << what;
  RayConfig config;
  config.width = 128, config.height = 128, config.spp = 2, config.count = 20000;
  const auto views = scene_views(scene);
  for (std::size_t v = 0; v < views.size(); ++v)
    for (RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random}) {
      const auto rays = generate_rays(scene, views[v], kind, config, cpu.get());
      const Query query = kind == RayKind::ao ? Query::any : Query::closest;
      std::vector<Hit> gpu_hits(rays.size()), cpu_hits(rays.size());
      std::vector<RayWork> gpu_work(rays.size()), cpu_work(rays.size());
      gpu->trace_counted(rays, gpu_hits, gpu_work, query);
      cpu->trace_counted(rays, cpu_hits, cpu_work, query);
      EXPECT_EQ(std::memcmp(gpu_hits.data(), cpu_hits.data(), rays.size() * sizeof(Hit)), 0)
          << what << " view " << v << " " << to_string(kind);
      EXPECT_EQ(std::memcmp(gpu_work.data(), cpu_work.data(), rays.size() * sizeof(RayWork)), 0)
          << what << " view " << v << " " << to_string(kind) << ": work counters";
      gpu->trace(rays, gpu_hits, query);
      EXPECT_EQ(std::memcmp(gpu_hits.data(), cpu_hits.data(), rays.size() * sizeof(Hit)), 0)
          << what << " view " << v << " " << to_string(kind) << " (uncounted)";
    }
}

TEST(GpuGrid, SameHitsAsTheCpuOnBuiltinScenes) {
  IRGRID_SKIP_WITHOUT_GPU();
  for (const auto& spec : kBuiltins)
    for (const char* structure : {"irregular", "two-level", "uniform"})
      expect_same_hits(load_scene(spec), structure, spec + " " + structure);
}

TEST(GpuGrid, SameHitsAsTheCpuOnSharedScenes) {
  IRGRID_SKIP_WITHOUT_GPU();
  const auto paths = shared_scene_paths();
  if (paths.empty())
    IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_SHARED_SCENES", "no shared scenes found");
  for (const auto& path : paths)
    expect_same_hits(load_scene(path), "irregular", path);
}

#if IRGRID_HAS_CUDA
/// rays[i] traced by trace_device on device copies, on a stream of its own.
std::vector<Hit> trace_on_device(const Accelerator& accelerator, const std::vector<Ray>& rays,
                                 Query query) {
  std::vector<Hit> hits(rays.size());
  Ray* d_rays = nullptr;
  Hit* d_hits = nullptr;
  cudaStream_t stream = nullptr;
  EXPECT_EQ(cudaMalloc(&d_rays, rays.size() * sizeof(Ray)), cudaSuccess);
  EXPECT_EQ(cudaMalloc(&d_hits, rays.size() * sizeof(Hit)), cudaSuccess);
  EXPECT_EQ(cudaStreamCreate(&stream), cudaSuccess);
  cudaMemcpyAsync(d_rays, rays.data(), rays.size() * sizeof(Ray), cudaMemcpyHostToDevice, stream);
  accelerator.trace_device(d_rays, d_hits, rays.size(), query, stream);
  cudaMemcpyAsync(hits.data(), d_hits, rays.size() * sizeof(Hit), cudaMemcpyDeviceToHost, stream);
  EXPECT_EQ(cudaStreamSynchronize(stream), cudaSuccess);
  cudaStreamDestroy(stream);
  cudaFree(d_rays);
  cudaFree(d_hits);
  return hits;
}

/// 96 x 64 primary rays of the scene's first view.
std::vector<Ray> camera_rays(const Scene& scene) {
  RayConfig config;
  config.width = 96, config.height = 64;
  return generate_rays(scene, scene_views(scene).front(), RayKind::primary, config, nullptr);
}

/// visit(structure, accelerator, rays) for the irregular grid and brute force on CUDA over the
/// 4,000-triangle teapot stadium, with camera_rays of it.
template <typename Visit>
void for_each_cuda_tracer(Visit&& visit) {
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  const auto rays = camera_rays(scene);
  AcceleratorOptions options;
  options.backend = Backend::cuda;
  for (const Structure structure : {Structure::irregular, Structure::brute})
    visit(structure, *make_accelerator(scene, structure, options), rays);
}
#endif

TEST(GpuGrid, TraceDeviceOnAStreamEqualsTrace) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_CUDA
  for_each_cuda_tracer(
      [](Structure structure, const Accelerator& gpu, const std::vector<Ray>& rays) {
        for (Query query : {Query::closest, Query::any}) {
          std::vector<Hit> expected(rays.size());
          gpu.trace(rays, expected, query);
          const auto hits = trace_on_device(gpu, rays, query);
          EXPECT_EQ(std::memcmp(hits.data(), expected.data(), hits.size() * sizeof(Hit)), 0)
              << to_string(structure);
        }
      });
#endif
}

/// An error the caller's own CUDA work left pending (here a failed cudaMalloc) is reported as
/// theirs before trace_device queues anything, and cleared: the next call traces.
TEST(GpuGrid, TraceDeviceReportsTheCallersPendingErrorAsTheirs) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_CUDA
  for_each_cuda_tracer([](Structure structure, const Accelerator& gpu,
                          const std::vector<Ray>& rays) {
    std::vector<Hit> expected(rays.size());
    gpu.trace(rays, expected, Query::closest);
    // Real arrays, so that a call that wrongly went ahead would only trace.
    Ray* d_rays = nullptr;
    Hit* d_hits = nullptr;
    ASSERT_EQ(cudaMalloc(&d_rays, rays.size() * sizeof(Ray)), cudaSuccess);
    ASSERT_EQ(cudaMalloc(&d_hits, rays.size() * sizeof(Hit)), cudaSuccess);
    ASSERT_EQ(cudaMemcpy(d_rays, rays.data(), rays.size() * sizeof(Ray), cudaMemcpyHostToDevice),
              cudaSuccess);
    void* too_large = nullptr;
    ASSERT_NE(cudaMalloc(&too_large, std::size_t(1) << 62), cudaSuccess);
    try {
      gpu.trace_device(d_rays, d_hits, rays.size(), Query::closest, nullptr);
      ADD_FAILURE() << "no error for " << to_string(structure);
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("an earlier CUDA call"), std::string::npos) << e.what();
    }
    EXPECT_EQ(cudaDeviceSynchronize(), cudaSuccess);
    cudaFree(d_rays);
    cudaFree(d_hits);
    const auto hits = trace_on_device(gpu, rays, Query::closest);
    EXPECT_EQ(std::memcmp(hits.data(), expected.data(), hits.size() * sizeof(Hit)), 0)
        << to_string(structure);
  });
#endif
}

/// trace over the caller's arrays (RayArrays, HitArrays) on CUDA: the hits of the CPU's, and
/// the normals from the triangles copied back from the device, after a rebuild too.
TEST(GpuGrid, CallerArraysWithNormalsTraceAsOnTheCpu) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_CUDA
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  const auto rays = camera_rays(scene);
  std::vector<float> rows;
  for (const Ray& r : rays) {
    rows.insert(rows.end(), r.org, r.org + 3);
    rows.insert(rows.end(), r.dir, r.dir + 3);
  }
  RayArrays in;
  in.count = rays.size();
  in.origins = rows.data(), in.origin_stride = 6;
  in.directions = rows.data() + 3, in.direction_stride = 6;
  AcceleratorOptions options;
  options.backend = Backend::cuda;
  for (const Structure structure : {Structure::irregular, Structure::brute}) {
    const auto gpu = make_accelerator(scene, structure, options);
    const auto cpu = make_accelerator(scene, structure);
    for (int round = 0; round < 2; ++round) {
      std::vector<float> t[2], normals[2];
      std::vector<std::uint32_t> prim[2];
      const Accelerator* both[2] = {gpu.get(), cpu.get()};
      for (int k = 0; k < 2; ++k) {
        t[k].assign(rays.size(), -1.f), normals[k].assign(3 * rays.size(), -1.f);
        prim[k].assign(rays.size(), 0);
        HitArrays out;
        out.t = t[k].data(), out.prim = prim[k].data(), out.normal = normals[k].data();
        both[k]->trace(in, out, Query::closest);
      }
      EXPECT_EQ(prim[0], prim[1]) << to_string(structure) << " round " << round;
      EXPECT_EQ(std::memcmp(t[0].data(), t[1].data(), t[0].size() * 4), 0) << to_string(structure);
      EXPECT_EQ(std::memcmp(normals[0].data(), normals[1].data(), normals[0].size() * 4), 0)
          << to_string(structure) << " round " << round;
      gpu->rebuild(scene.mesh());  // the host copy of the triangles is made again
    }
  }
#endif
}

TEST(GpuGrid, RebuildsReuseThePoolAndEqualFreshBuilds) {
  IRGRID_SKIP_WITHOUT_GPU();
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  AcceleratorOptions options;
  options.backend = Backend::cuda;
  const auto grid = make_accelerator(scene, Structure::irregular, options);
  grid->rebuild(scene.mesh());  // fills the pool
  grid->rebuild(scene.mesh());
  EXPECT_EQ(grid->build_stats().grid->fresh_allocations, 0u);
  const auto cpu = make_accelerator(scene, Structure::irregular);
  RayConfig config;
  config.width = 96, config.height = 64;
  const auto rays =
      generate_rays(scene, scene_views(scene).front(), RayKind::primary, config, nullptr);
  std::vector<Hit> a(rays.size()), b(rays.size());
  grid->trace(rays, a, Query::closest);
  cpu->trace(rays, b, Query::closest);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Hit)), 0);
}

TEST(GpuGrid, CudaWithoutDeviceIsAClearError) {
  if (!testing::gpu_missing()) GTEST_SKIP() << "a GPU is present";
  AcceleratorOptions options;
  options.backend = Backend::cuda;
  try {
    make_accelerator(load_scene("builtin:cube"), Structure::irregular, options);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::no_device);
  }
}

}  // namespace
}  // namespace irgrid
