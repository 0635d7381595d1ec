// GPU brute force equals the CPU brute force hit for hit (label gpu: skips without a device).
#include <gtest/gtest.h>

#include <cstring>

#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/io/rays.h"
#include "irgrid/system.h"
#include "test_requirements.h"

namespace irgrid {
namespace {

void skip_without_gpu() {
  const auto cuda = cuda_status();
  if (cuda.gpus.empty())
    IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_GPU", "no GPU: " << cuda.status);
}

TEST(GpuBruteForce, EqualsCpuBitForBit) {
  skip_without_gpu();
  if (IsSkipped() || HasFatalFailure()) return;
  const Scene scene = load_scene("builtin:cornell");
  AcceleratorOptions gpu_options;
  gpu_options.backend = Backend::cuda;
  const auto gpu = make_accelerator(scene, Structure::brute, gpu_options);
  const auto cpu = make_accelerator(scene, Structure::brute);
  ASSERT_EQ(gpu->backend(), Backend::cuda);
  RayConfig config;
  config.width = 64, config.height = 64, config.spp = 2, config.count = 5000;
  for (RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random}) {
    const auto rays = generate_rays(scene, scene_views(scene).at(0), kind, config, cpu.get());
    const Query query = kind == RayKind::ao ? Query::any : Query::closest;
    std::vector<Hit> gpu_hits(rays.size()), cpu_hits(rays.size());
    gpu->trace(rays, gpu_hits, query);
    cpu->trace(rays, cpu_hits, query);
    EXPECT_EQ(std::memcmp(gpu_hits.data(), cpu_hits.data(), rays.size() * sizeof(Hit)), 0)
        << to_string(kind);
  }
}

TEST(GpuBackend, CudaWithoutDeviceIsAClearError) {
  if (!cuda_status().gpus.empty()) GTEST_SKIP() << "a GPU is present";
  const Scene scene = load_scene("builtin:cube");
  AcceleratorOptions options;
  options.backend = Backend::cuda;
  try {
    make_accelerator(scene, Structure::brute, options);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::no_device);
  }
  options.backend = Backend::automatic;
  EXPECT_EQ(make_accelerator(scene, Structure::brute, options)->backend(), Backend::cpu);
}

}  // namespace
}  // namespace irgrid
