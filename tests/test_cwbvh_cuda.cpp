// The CUDA CWBVH traces the same hits as the CPU CWBVH, bit for bit (label gpu: skips without a
// device unless IRGRID_REQUIRE_GPU is set).
#include <gtest/gtest.h>

#include <string>

#if IRGRID_HAS_CUDA
#include <cuda_runtime.h>
#endif

#include "cwbvh_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/rays.h"
#include "irgrid/system.h"
#include "test_requirements.h"

namespace irgrid {
namespace {

const AcceleratorOptions kOnGpu = [] {
  AcceleratorOptions options;
  options.backend = Backend::cuda;
  return options;
}();

TEST(CwbvhCuda, SameHitsAsTheCpuOnBuiltinScenes) {
  IRGRID_SKIP_WITHOUT_GPU();
#if !IRGRID_HAS_EMBREE
  GTEST_SKIP() << "cwbvh needs Embree";
#else
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:4000", "builtin:soup:3000",
                           "builtin:hairball:5000", "builtin:sphere:2000", "builtin:cube"}) {
    const Scene scene = load_scene(spec);
    const auto cpu = make_accelerator(scene, Structure::cwbvh);
    const auto gpu = make_accelerator(scene, Structure::cwbvh, kOnGpu);
    ASSERT_EQ(gpu->backend(), Backend::cuda);
    EXPECT_EQ(gpu->build_stats().memory_bytes, cpu->build_stats().memory_bytes) << spec;
    EXPECT_TRUE(gpu->build_stats().phase_ms[std::size_t(BuildPhase::upload)].has_value());
    for (const auto& load : testing::cwbvh_workloads(scene, *cpu, 96, 64)) {
      testing::expect_same_hits(testing::trace_all(*cpu, load.rays, load.query),
                                testing::trace_all(*gpu, load.rays, load.query), load.query,
                                std::string(spec) + " " + load.what);
      // The counted kernel traces the same hits and counts the same work.
      std::vector<Hit> cpu_hits(load.rays.size()), gpu_hits(load.rays.size());
      std::vector<RayWork> cpu_work(load.rays.size()), gpu_work(load.rays.size());
      cpu->trace_counted(load.rays, cpu_hits, cpu_work, load.query);
      gpu->trace_counted(load.rays, gpu_hits, gpu_work, load.query);
      if (load.query == Query::closest) {
        std::size_t differ = 0;
        for (std::size_t i = 0; i < cpu_work.size(); ++i)
          differ += cpu_work[i].cells != gpu_work[i].cells ||
                    cpu_work[i].triangles != gpu_work[i].triangles;
        EXPECT_EQ(differ, 0u) << spec << " " << load.what << ": rays whose work differs";
      }
    }
  }
#endif
}

TEST(CwbvhCuda, TraceDeviceGivesTheHitsOfTrace) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_CUDA && IRGRID_HAS_EMBREE
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  const auto gpu = make_accelerator(scene, Structure::cwbvh, kOnGpu);
  for (const auto& load : testing::cwbvh_workloads(scene, *gpu, 64, 48)) {
    const std::size_t n = load.rays.size();
    Ray* d_rays = nullptr;
    Hit* d_hits = nullptr;
    ASSERT_EQ(cudaMalloc(&d_rays, n * sizeof(Ray)), cudaSuccess);
    ASSERT_EQ(cudaMalloc(&d_hits, n * sizeof(Hit)), cudaSuccess);
    ASSERT_EQ(cudaMemcpy(d_rays, load.rays.data(), n * sizeof(Ray), cudaMemcpyHostToDevice),
              cudaSuccess);
    gpu->trace_device(d_rays, d_hits, n, load.query, nullptr);
    std::vector<Hit> device(n);
    EXPECT_EQ(cudaMemcpy(device.data(), d_hits, n * sizeof(Hit), cudaMemcpyDeviceToHost),
              cudaSuccess);
    cudaFree(d_rays);
    cudaFree(d_hits);
    testing::expect_same_hits(testing::trace_all(*gpu, load.rays, load.query), device, load.query,
                              "trace_device " + load.what);
  }
#endif
}

TEST(CwbvhCuda, EmptySceneMissesOnTheGpu) {
  IRGRID_SKIP_WITHOUT_GPU();
#if IRGRID_HAS_EMBREE
  Scene empty;
  empty.name = "empty";
  const auto gpu = make_accelerator(empty, Structure::cwbvh, kOnGpu);
  const std::vector<Ray> rays = {{{0, 0, 0}, 0, {1, 0, 0}, 1e30f}};
  for (Query query : {Query::closest, Query::any})
    EXPECT_FALSE(testing::trace_all(*gpu, rays, query)[0].hit());
#endif
}

}  // namespace
}  // namespace irgrid
