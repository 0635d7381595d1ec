// The GPU's way through the build's templates, run on the CPU: an executor with CudaExecutor's
// build flags (DeviceBuildPath: level-by-level octrees, one item per thread instead of SIMD
// lanes, merge chains by pointer jumping, merged cells into new arrays, no memory estimate)
// builds the same grid as the CPU executor, bit for bit, whatever order for_each runs its bodies
// in and whatever bytes fresh buffers hold (cudaMalloc does not clear them). The CUDA backend's
// tests compare the device's grids with the CPU's too, but only where a GPU is; this one runs
// everywhere, so a phase that only works along the CPU's path fails here first.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/construction/compress_cells.h"
#include "core/construction/device_build_path.h"
#include "grid_test_support.h"

namespace irgrid {
namespace {

enum class BodyOrder { ascending, descending };

/// CpuExecutor with every flag of DeviceBuildPath, its fresh buffers filled with `kFill` and
/// its for_each bodies run one at a time in `kOrder`.
template <BodyOrder kOrder, unsigned char kFill>
struct DevicePathExecutor : CpuExecutor {
  static constexpr std::uint32_t kLookupBatch = DeviceBuildPath::kLookupBatch;
  static constexpr bool kDepthFirstOctrees = DeviceBuildPath::kDepthFirstOctrees;
  static constexpr bool kOctreeMasksInLanes = DeviceBuildPath::kOctreeMasksInLanes;
  static constexpr bool kTrianglePlanesInLanes = DeviceBuildPath::kTrianglePlanesInLanes;
  static constexpr bool kProposesInLanes = DeviceBuildPath::kProposesInLanes;
  static constexpr bool kSerialMergeChains = DeviceBuildPath::kSerialMergeChains;
  static constexpr bool kCompactsInPlace = DeviceBuildPath::kCompactsInPlace;
  static std::uint64_t memory_budget() { return DeviceBuildPath::memory_budget(); }

  template <typename T>
  Buffer<T> allocate(std::size_t n) const {
    Buffer<T> buffer = CpuExecutor::allocate<T>(n);
    if (n != 0) std::memset(static_cast<void*>(buffer.data()), kFill, n * sizeof(T));
    return buffer;
  }

  template <typename F>
  void for_each(const char*, std::size_t n, F&& body) const {
    if (kOrder == BodyOrder::descending)
      for (std::size_t i = n; i-- > 0;)
        body(i);
    else
      for (std::size_t i = 0; i < n; ++i)
        body(i);
  }
};

static_assert(!DevicePathExecutor<BodyOrder::ascending, 0>::kDepthFirstOctrees &&
              !DevicePathExecutor<BodyOrder::ascending, 0>::kCompactsInPlace);

/// A whole build (build_grid_and_compress) by executor Exec.
template <typename Exec>
struct BuiltGrid {
  GridArrays<Exec> grid;
  typename Exec::template Buffer<CompactCell> compact;
  PhaseTimes phases;
};

template <typename Exec>
BuiltGrid<Exec> build_with(const Scene& scene, const BuildConfig& config) {
  Exec exec;
  BuiltGrid<Exec> built;
  gather_triangles(scene.mesh(), built.grid.triangles);
  build_grid_and_compress(exec, built.grid, built.compact, config, built.phases);
  return built;
}

template <typename Exec>
void expect_device_path_builds_the_same(const Scene& scene, const BuildConfig& config,
                                        const BuiltGrid<CpuExecutor>& cpu) {
  const BuiltGrid<Exec> device_path = build_with<Exec>(scene, config);
  testing::expect_same_grid(cpu.grid, device_path.grid);
  EXPECT_TRUE(testing::same_bytes(cpu.compact, device_path.compact));
  // The device path builds its octrees level by level.
  EXPECT_TRUE(device_path.phases[std::size_t(BuildPhase::octree_levels)].has_value());
}

/// The builds the CUDA backend is asked for, and the paths that only some scenes take.
std::vector<std::pair<std::string, BuildConfig>> device_path_configs() {
  std::vector<std::pair<std::string, BuildConfig>> configs;
  configs.emplace_back("defaults", BuildConfig{});
  BuildConfig config;
  config.shape = BuildConfig::Shape::two_level;
  configs.emplace_back("two-level", config);
  config = BuildConfig{};
  config.shape = BuildConfig::Shape::uniform;
  configs.emplace_back("uniform", config);
  config = BuildConfig{};
  config.compress = false;  // 32-byte cells expand
  configs.emplace_back("uncompressed", config);
  config = BuildConfig{};
  config.split_refs = 4;  // count splits everywhere
  configs.emplace_back("split_refs 4", config);
  config = BuildConfig{};
  config.lambda2 = 64;  // deep octrees, more merge sweeps
  configs.emplace_back("lambda2 64", config);
  config = BuildConfig{};
  config.memory_budget = std::uint64_t(1) << 20;  // the budget coarsens the grid
  configs.emplace_back("1 MiB budget", config);
  return configs;
}

class DevicePathBuild : public ::testing::TestWithParam<std::string> {};

TEST_P(DevicePathBuild, BuildsTheCpuGridInEitherBodyOrderFromUnclearedBuffers) {
  const Scene scene = load_scene(GetParam());
  for (const auto& [name, config] : device_path_configs()) {
    SCOPED_TRACE(name);
    const BuiltGrid<CpuExecutor> cpu = build_with<CpuExecutor>(scene, config);
    ASSERT_GT(cpu.grid.info.num_cells, 0u);
    expect_device_path_builds_the_same<DevicePathExecutor<BodyOrder::descending, 0xA5>>(
        scene, config, cpu);
    expect_device_path_builds_the_same<DevicePathExecutor<BodyOrder::ascending, 0xFF>>(scene,
                                                                                       config, cpu);
  }
}

const std::vector<std::string> kScenes = {"builtin:cornell",      "builtin:teapot-stadium:4000",
                                          "builtin:soup:3000",    "builtin:hairball:5000",
                                          "builtin:sphere:2000",  "builtin:cube",
                                          "builtin:overlap:1000", "builtin:stack:3000"};

INSTANTIATE_TEST_SUITE_P(Builtin, DevicePathBuild, ::testing::ValuesIn(kScenes),
                         testing::builtin_scene_test_name);

}  // namespace
}  // namespace irgrid
