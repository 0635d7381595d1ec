// Invariants of the built grid: the initial grid's cells tile the grid and the voxel map finds
// the owner of every voxel; after the whole build (merging and expansion included) lists are
// sorted and unique and no triangle touching a cell's exit box is missing from its list.
#include <gtest/gtest.h>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <utility>

#include "core/construction/compress_cells.h"
#include "core/construction/device_build_path.h"
#include "core/triangle_box.h"
#include "grid_test_support.h"
#include "irgrid/io/random.h"

namespace irgrid {
namespace {

using testing::build_test_grid;

const std::vector<std::string> kScenes = {"builtin:cornell",     "builtin:teapot-stadium:4000",
                                          "builtin:soup:3000",   "builtin:hairball:5000",
                                          "builtin:sphere:2000", "builtin:cube"};

class GridBuild : public ::testing::TestWithParam<std::string> {};

TEST_P(GridBuild, CellsTileTheVirtualGridExactly) {
  const auto grid = build_test_grid(load_scene(GetParam()));
  testing::expect_cells_tile_grid(grid);
}

TEST_P(GridBuild, VoxelMapReturnsTheCellContainingEachVoxel) {
  testing::expect_voxel_map_finds_owners(build_test_grid(load_scene(GetParam())), 17);
}

// Finer voxels than the insertion padding cannot separate triangles; the octree never makes
// them (deepest_octree_depth_within).
void expect_voxels_at_least_two_paddings_wide(const GridInfo& info, const std::string& what) {
  for (int a = 0; a < 3; ++a)
    EXPECT_GE(double(info.box_hi[a] - info.box_lo[a]) / double(info.virtual_dims[a]),
              2.0 * double(info.padding))
        << what << ", axis " << a;
}

TEST_P(GridBuild, VoxelsAreAtLeastTwoPaddingsWide) {
  const auto grid = build_test_grid(load_scene(GetParam()), BuildConfig{});
  expect_voxels_at_least_two_paddings_wide(grid.info, GetParam());
}

TEST(GridBuildShapes, FlatAndThinScenesDoNotMultiplyCells) {
  // An octree splits all three axes. A flat scene's box is a few paddings thick, and its top
  // cells once got the octree depth of that thin volume: 80,000 triangles in a plane made 25
  // million cells (76 s, 980 MiB); the sliver's build ran out of memory.
  // Measured on this 7,200-triangle plane before and after the fix: the initial grid's cells
  // 10.9 million -> 53,824, the merged and expanded grid's 2.24 million -> 13,744.
  const Scene flat = testing::scene_from_triangles(testing::flat_mesh_triangles(60));
  const auto initial = build_test_grid(flat, testing::initial_grid_config());
  expect_voxels_at_least_two_paddings_wide(initial.info, "flat mesh");
  EXPECT_LE(initial.cells.size(), 16 * flat.triangles.size()) << "flat mesh, initial grid";
  EXPECT_LE(build_test_grid(flat, BuildConfig{}).cells.size(), 4 * flat.triangles.size())
      << "flat mesh";
  const Scene sliver = testing::scene_from_triangles(testing::sliver_beside_square_triangles());
  const auto grid = build_test_grid(sliver, BuildConfig{});
  expect_voxels_at_least_two_paddings_wide(grid.info, "sliver");
  EXPECT_LE(grid.cells.size(), 1000u) << "sliver";
}

TEST_P(GridBuild, BatchedLookupsEqualSingleLookups) {
  // lookup_cells interleaves the map walks of a batch; every batch size up to its bound must
  // give each voxel the owner lookup_cell finds, whatever depths the walks in a batch reach.
  const auto grid = build_test_grid(load_scene(GetParam()));
  const GridInfo& info = grid.info;
  Pcg32 rng;
  rng.seed(23);
  constexpr std::uint32_t kMax = 16;
  for (int batch = 0; batch < 2000; ++batch) {
    const std::uint32_t count = std::uint32_t(batch) % (kMax + 1);
    Voxel voxels[kMax];
    std::uint32_t owners[kMax];
    for (std::uint32_t k = 0; k < count; ++k)
      voxels[k] = Voxel{std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[0])),
                        std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[1])),
                        std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[2]))};
    lookup_cells<kMax>(info, grid.entries.data(), voxels, count, owners);
    for (std::uint32_t k = 0; k < count; ++k)
      ASSERT_EQ(owners[k], lookup_cell(info, grid.entries.data(), voxels[k]))
          << "batch " << batch << " voxel " << k;
  }
}

TEST_P(GridBuild, ListsAreSortedUniqueAndCoverTheReferenceArray) {
  const auto grid = build_test_grid(load_scene(GetParam()), BuildConfig{});
  std::uint64_t listed = 0;
  for (const Cell& c : grid.cells) {
    ASSERT_LE(c.begin, c.end);
    ASSERT_LE(c.end, grid.info.num_refs);
    for (std::uint32_t r = c.begin + 1; r < c.end; ++r)
      ASSERT_LT(grid.refs[r - 1], grid.refs[r]);
    for (std::uint32_t r = c.begin; r < c.end; ++r)
      ASSERT_LT(grid.refs[r], grid.info.num_triangles);
    listed += c.end - c.begin;
  }
  EXPECT_EQ(listed, grid.info.num_refs);
}

TEST_P(GridBuild, EveryTriangleTouchingACellIsInItsList) {
  const auto grid = build_test_grid(load_scene(GetParam()), BuildConfig{});
  EXPECT_GT(testing::check_lists_cover_exit_boxes(grid, 0.f, "defaults"), 0u);
}

// The world box of the top cells from `top` towards `octant` as far as `radius` (>= 1), clipped
// to the grid: the cube a walk leaps across (leave_empty_space).
std::pair<Vec3<float>, Vec3<float>> empty_cube(const GridInfo& info, const std::int32_t top[3],
                                               std::uint32_t octant, std::int32_t radius) {
  Vec3<float> lo, hi;
  for (int a = 0; a < 3; ++a) {
    const bool up = !(octant >> a & 1);
    const std::int32_t first = up ? top[a] : std::max(top[a] - (radius - 1), 0);
    const std::int32_t last = up ? std::min(top[a] + radius, info.top_dims[a]) : top[a] + 1;
    lo[a] = voxel_to_world(info, a, first << info.shift);
    hi[a] = voxel_to_world(info, a, last << info.shift);
  }
  return {lo, hi};
}

TEST_P(GridBuild, EmptyRadiiReachTheNearestTopCellWithTriangles) {
  const Scene scene = load_scene(GetParam());
  const auto grid = build_test_grid(scene, BuildConfig{});
  const GridInfo& info = grid.info;
  const std::uint32_t top_cells =
      std::uint32_t(info.top_dims[0] * info.top_dims[1] * info.top_dims[2]);
  ASSERT_EQ(grid.empty_radii.size(), 8 * std::size_t(top_cells) + kEmptyRadiiSlack);
  const auto overlapped = [&](const std::pair<Vec3<float>, Vec3<float>>& box, float padding) {
    for (std::uint32_t t = 0; t < info.num_triangles; ++t) {
      const auto& tri = grid.triangles[t];
      if (triangle_overlaps_box(tri.p0, tri.p1, tri.p2, box.first, box.second, padding))
        return true;
    }
    return false;
  };
  Pcg32 rng;
  rng.seed(5);
  int leaps = 0, bounded = 0;
  for (int k = 0; k < 300; ++k) {
    const std::uint32_t cell = rng.next_u32() % top_cells, octant = rng.next_u32() % 8;
    const std::int32_t top[3] = {
        std::int32_t(cell % std::uint32_t(info.top_dims[0])),
        std::int32_t(cell / std::uint32_t(info.top_dims[0]) % std::uint32_t(info.top_dims[1])),
        std::int32_t(cell / std::uint32_t(info.top_dims[0]) / std::uint32_t(info.top_dims[1]))};
    const std::int32_t radius = grid.empty_radii[8 * cell + octant];
    // The cube a walk leaps across holds no triangle ...
    if (radius > 0) {
      ++leaps;
      EXPECT_FALSE(overlapped(empty_cube(info, top, octant, radius), 0.f))
          << "top cell " << cell << ", octant " << octant << ", radius " << radius;
    }
    // ... and one top cell more reaches one the build found triangles in.
    if (radius < std::int32_t(kMaxEmptyRadius)) {
      ++bounded;
      EXPECT_TRUE(overlapped(empty_cube(info, top, octant, radius + 1), info.padding))
          << "top cell " << cell << ", octant " << octant << ", radius " << radius;
    }
  }
  EXPECT_GT(bounded, 0);
  if (GetParam() == "builtin:teapot-stadium:4000") EXPECT_GT(leaps, 0);
}

TEST(GridBuild, EmptyRadiiOnlyForIrregularGridsThatSkipEmptySpace) {
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  BuildConfig config;
  config.skip_empty = false;
  EXPECT_TRUE(build_test_grid(scene, config).empty_radii.empty());
  config.skip_empty = true;
  config.shape = BuildConfig::Shape::two_level;
  EXPECT_TRUE(build_test_grid(scene, config).empty_radii.empty());
}

TEST_P(GridBuild, SameGridWhateverTheThreadCount) {
  const Scene scene = load_scene(GetParam());
  auto build_with = [&](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
    return build_test_grid(scene,
                           BuildConfig{});  // the whole build, merging and expansion included
  };
  const auto one = build_with(1);
  testing::expect_same_grid(one, build_with(2));
  // More threads than this machine has cores (an arena of 7, whatever the machine), so that
  // blocks finish in other orders.
  tbb::task_arena seven(7);
  seven.execute([&] { testing::expect_same_grid(one, build_test_grid(scene, BuildConfig{})); });
}

/// The CPU executor with the GPU's way of building octrees: level by level, then assembled.
struct LevelByLevelExecutor : CpuExecutor {
  static constexpr bool kDepthFirstOctrees = DeviceBuildPath::kDepthFirstOctrees;
};

TEST_P(GridBuild, DepthFirstOctreesEqualTheLevelByLevelBuild) {
  const Scene scene = load_scene(GetParam());
  std::vector<BuildConfig> configs(7, testing::initial_grid_config());
  configs[1] = BuildConfig{};  // merging and expansion read the octree-form map
  configs[2].split_refs = 0;   // the paper's depths only
  configs[3].split_refs = 4;   // count splits everywhere
  configs[4].lambda2 = 0;
  configs[5].shape = BuildConfig::Shape::two_level;  // empty nodes split too
  configs[6].shape = BuildConfig::Shape::uniform;
  for (const BuildConfig& config : configs) {
    SCOPED_TRACE(::testing::Message()
                 << "lambda2 " << config.lambda2 << ", split_refs " << config.split_refs
                 << ", shape " << int(config.shape) << ", alpha " << config.alpha);
    const auto depth_first = build_test_grid(scene, config);
    LevelByLevelExecutor exec;
    GridArrays<LevelByLevelExecutor> level_by_level;
    gather_triangles(scene.mesh(), level_by_level.triangles);
    PhaseTimes phases;
    build_grid(exec, level_by_level, config, phases);
    ASSERT_TRUE(phases[std::size_t(BuildPhase::octree_levels)].has_value());
    testing::expect_same_grid(depth_first, level_by_level);
  }
}

TEST_P(GridBuild, RangesFollowTheCellOrderAndCompressLosslessly) {
  for (const BuildConfig& config : {testing::initial_grid_config(), BuildConfig{}}) {
    const auto grid = build_test_grid(load_scene(GetParam()), config);
    std::uint32_t expected_begin = 0;
    for (const Cell& c : grid.cells) {
      ASSERT_EQ(c.begin, expected_begin) << "a gap or overlap between reference ranges";
      expected_begin = c.end;
    }
    EXPECT_EQ(expected_begin, grid.info.num_refs);
    ASSERT_TRUE(fits_compact_cells(grid.info));
    CpuExecutor exec;
    CpuExecutor::Buffer<CompactCell> compact;
    compress_cells(exec, grid, compact);
    ASSERT_EQ(compact.size(), grid.cells.size() + 1);
    for (std::uint32_t i = 0; i < grid.info.num_cells; ++i) {
      const Cell a = grid.cells[i], b = load_cell(compact.data(), i);
      ASSERT_EQ(std::memcmp(&a, &b, sizeof(Cell)), 0) << "cell " << i;
    }
  }
}

TEST_P(GridBuild, CompressedCellsExpandToTheSameBoxes) {
  // build_grid with a compact output expands the 16-byte cells in place of the 32-byte ones
  // (and drops those): the boxes must be the full cells' expanded, compressed afterwards.
  BuildConfig subset;
  subset.partial_expansion = false;
  for (const BuildConfig& config : {BuildConfig{}, subset}) {
    const Scene scene = load_scene(GetParam());
    const auto wide = build_test_grid(scene, config);
    ASSERT_TRUE(fits_compact_cells(wide.info));
    CpuExecutor exec;
    CpuExecutor::Buffer<CompactCell> expected, compact;
    compress_cells(exec, wide, expected);
    GridArrays<CpuExecutor> grid;
    gather_triangles(scene.mesh(), grid.triangles);
    PhaseTimes phases;
    build_grid(exec, grid, config, phases, {}, nullptr, &compact);
    EXPECT_TRUE(grid.cells.empty());
    EXPECT_TRUE(phases[std::size_t(BuildPhase::compress)].has_value());
    ASSERT_EQ(compact.size(), expected.size());
    EXPECT_EQ(std::memcmp(compact.data(), expected.data(), compact.size() * sizeof(CompactCell)),
              0);
    // Everything else is the same too (the wide cells stand in for the dropped ones).
    grid.cells.assign(wide.cells.begin(), wide.cells.end());
    testing::expect_same_grid(wide, grid);
  }
}

INSTANTIATE_TEST_SUITE_P(Builtin, GridBuild, ::testing::ValuesIn(kScenes),
                         testing::builtin_scene_test_name);

TEST(GridLimits, ClearyResolutionIsTheFloorOfExtentOverSide) {
  Pcg32 rng;
  rng.seed(7);
  for (int k = 0; k < 20000; ++k) {
    const Vec3<float> extent{std::ldexp(rng.next_float() + 0.01f, int(rng.next_u32() % 20) - 10),
                             std::ldexp(rng.next_float() + 0.01f, int(rng.next_u32() % 20) - 10),
                             k % 4 == 0 ? 0.f : rng.next_float() + 0.01f};
    const double density = std::ldexp(double(rng.next_float()) + 0.01, int(rng.next_u32() % 8) - 4);
    const double count = double(rng.next_u32() % 100000 + 1);
    double dims[3];
    cleary_resolution(extent, density, count, 0.f, dims);
    int axes = 0;
    long double volume = 1;
    for (int a = 0; a < 3; ++a)
      if (extent[a] > 0) volume *= extent[a], ++axes;
    const long double side = std::pow(volume / ((long double)density * count), 1.0L / axes);
    for (int a = 0; a < 3; ++a) {
      if (!(extent[a] > 0)) {
        EXPECT_EQ(dims[a], 1.0);
        continue;
      }
      const long double exact = extent[a] / side;
      // Equal to the floor except where the quotient sits within rounding of an integer.
      if (std::fabs(exact - std::round(exact)) < 1e-9L * exact) continue;
      EXPECT_EQ(dims[a], double(std::floor(exact))) << "axis " << a << " extent " << extent[a];
    }
  }
}

TEST(GridLimits, ClearyResolutionOfAnInfiniteExtentIsOverTheLimitAtOnce) {
  // Such an extent once made the guess NaN and the search count up to 2^40, one at a time.
  const float inf = std::numeric_limits<float>::infinity();
  double dims[3];
  cleary_resolution(Vec3<float>{inf, 1.f, 1.f}, 0.12, 1000, 0.f, dims);
  EXPECT_EQ(dims[0], 0x1p40);
  cleary_resolution(Vec3<float>{3e38f, 3e38f, 3e38f}, 0.12, 1000, 0.f, dims);
  EXPECT_GT(dims[0], 1.0) << "the widest finite extents still get a resolution";
}

TEST(GridLimits, AScenePastTheFloatRangeIsAnErrorNotAHang) {
  // Its triangles span -1.8e38 to 1.8e38: their box's extent is infinite in float.
  const Scene scene = testing::scene_from_triangles(
      {{Vec3f{-1.8e38f, -1.8e38f, 0}, Vec3f{1.8e38f, -1.8e38f, 0}, Vec3f{0, 1.8e38f, 0}},
       {Vec3f{0, 0, 1}, Vec3f{1, 0, 1}, Vec3f{0, 1, 1}}});
  for (const BuildConfig::Shape shape :
       {BuildConfig::Shape::irregular, BuildConfig::Shape::uniform}) {
    BuildConfig config;
    config.shape = shape;
    try {
      build_test_grid(scene, config);
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::limit_exceeded);
      EXPECT_NE(std::string(e.what()).find("-1.8e+38 to 1.8e+38 along x"), std::string::npos)
          << e.what();
    }
  }
}

std::uint32_t most_references_per_cell(const GridArrays<CpuExecutor>& grid) {
  std::uint32_t most = 0;
  for (const Cell& c : grid.cells)
    most = std::max(most, c.end - c.begin);
  return most;
}

TEST(OctreeSplit, NodesAboveTheThresholdSplitWhileItSeparatesTheirTriangles) {
  // The teapot shares its top cell with large floor triangles, so the paper's one depth per top
  // cell leaves hundreds of references in its cells (docs/benchmarks.md).
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  BuildConfig paper = testing::initial_grid_config();
  paper.split_refs = 0;
  const auto paper_grid = build_test_grid(scene, paper);
  ASSERT_GT(most_references_per_cell(paper_grid), 200u);

  BuildConfig by_count = testing::initial_grid_config();
  by_count.split_refs = 32;
  const auto grid = build_test_grid(scene, by_count);
  const std::int32_t compact_depth = compact_octree_depth(grid.info);
  EXPECT_GE(grid.info.shift, compact_depth);
  EXPECT_TRUE(fits_compact_cells(grid.info)) << "the count rule alone keeps cells compressible";
  const OctreeRule rule{nullptr, false, by_count.split_refs, compact_depth};
  const std::int32_t finest = std::int32_t(1) << (grid.info.shift - compact_depth);
  std::size_t above = 0;
  for (const Cell& c : grid.cells) {
    const std::uint32_t refs = c.end - c.begin;
    if (refs <= by_count.split_refs) continue;
    // A cell still above the threshold is at the compact depth, or a node whose split into
    // octants would not have separated its triangles.
    ++above;
    const std::int32_t size = c.hi[0] - c.lo[0];
    if (size <= finest) continue;
    std::uint32_t child_refs = 0;
    for (std::uint32_t r = c.begin; r < c.end; ++r)
      child_refs += popcount8(child_overlap_mask(grid.info, {c.lo[0], c.lo[1], c.lo[2]}, size / 2,
                                                 grid.triangles[grid.refs[r]]));
    EXPECT_FALSE(rule.count_split_separates(refs, child_refs))
        << "cell of " << refs << " references, " << size << " voxels wide";
  }
  EXPECT_LT(above, grid.cells.size() / 100);
  EXPECT_LT(most_references_per_cell(grid), most_references_per_cell(paper_grid) / 2);
}

// The separation bound: a count split may at most double a node's references (thin tubes of
// long triangles need that much: octree_levels.h), computed without overflow.
TEST(OctreeSplit, ASplitSeparatesWhileTheChildrenHoldAtMostTwiceTheReferences) {
  const OctreeRule rule{nullptr, false, 64, 10};
  EXPECT_TRUE(rule.count_split_separates(100, 100));
  EXPECT_TRUE(rule.count_split_separates(100, 200));
  EXPECT_FALSE(rule.count_split_separates(100, 201));
  EXPECT_FALSE(rule.count_split_separates(100, 800));
  EXPECT_TRUE(rule.count_split_separates(0xffffffffu, 0xffffffffu));
  EXPECT_FALSE(rule.count_split_separates(0x7fffffffu, 0xffffffffu));
}

TEST(OctreeSplit, ThresholdAboveEveryCountGivesThePaperGrid) {
  const Scene scene = load_scene("builtin:sphere:2000");
  BuildConfig paper = testing::initial_grid_config();
  paper.split_refs = 0;
  BuildConfig unreachable = paper;
  unreachable.split_refs = 1u << 30;
  const auto a = build_test_grid(scene, paper), b = build_test_grid(scene, unreachable);
  EXPECT_EQ(a.info.shift, b.info.shift);
  ASSERT_EQ(a.cells.size(), b.cells.size());
  EXPECT_EQ(0, std::memcmp(a.cells.data(), b.cells.data(), a.cells.size() * sizeof(Cell)));
  EXPECT_EQ(a.refs.size(), b.refs.size());
}

TEST(SmallScenes, Lambda2IsRaisedOnlyBelowMinCells) {
  BuildConfig config;
  config.lambda2 = 2.5f;
  config.min_cells = 1000;
  EXPECT_DOUBLE_EQ(effective_lambda2(config, 100), 10.0);  // 2.5 x 100 < 1000
  EXPECT_DOUBLE_EQ(effective_lambda2(config, 400), 2.5);   // exactly 1000
  EXPECT_DOUBLE_EQ(effective_lambda2(config, 4000), 2.5);
  EXPECT_DOUBLE_EQ(effective_lambda2(config, 0), 2.5);
  config.min_cells = 0;
  EXPECT_DOUBLE_EQ(effective_lambda2(config, 1), 2.5);
}

TEST(SmallScenes, ARaisedLambda2BuildsTheGridThatLambda2WouldBuild) {
  // The Cornell room's 228 triangles make about 500 top-level references, far below the
  // default min_cells: its grid is the one the paper's rule builds with the raised λ2.
  const Scene scene = load_scene("builtin:cornell");
  const auto raised = build_test_grid(scene, BuildConfig{});
  BuildConfig explicit_lambda2;
  explicit_lambda2.min_cells = 0;
  explicit_lambda2.lambda2 = float(effective_lambda2(BuildConfig{}, raised.top_level_refs));
  EXPECT_GT(explicit_lambda2.lambda2, 10 * BuildConfig{}.lambda2);
  const auto paper = build_test_grid(scene, explicit_lambda2);
  testing::expect_same_grid(raised, paper);
  BuildConfig unraised;
  unraised.min_cells = 0;
  EXPECT_GT(raised.info.shift, build_test_grid(scene, unraised).info.shift);
}

TEST(SmallScenes, TheBaselinesKeepThePapersLambda2) {
  const Scene scene = load_scene("builtin:cornell");
  for (const auto shape : {BuildConfig::Shape::two_level, BuildConfig::Shape::uniform}) {
    BuildConfig with, without;
    with.shape = without.shape = shape;
    without.min_cells = 0;
    testing::expect_same_grid(build_test_grid(scene, with), build_test_grid(scene, without));
  }
}

/// The CPU executor on a machine with 1 MiB of memory, with either octree build.
struct TinyMemoryExecutor : CpuExecutor {
  static std::uint64_t memory_budget() { return std::uint64_t(1) << 20; }
};
struct TinyMemoryLevelByLevelExecutor : TinyMemoryExecutor {
  static constexpr bool kDepthFirstOctrees = false;
};

template <typename Exec>
GridArrays<Exec> build_on(const Scene& scene, const BuildConfig& config) {
  Exec exec;
  GridArrays<Exec> grid;
  gather_triangles(scene.mesh(), grid.triangles);
  PhaseTimes phases;
  build_grid(exec, grid, config, phases);
  return grid;
}

TEST(GridLimits, OctreesThatOutgrowTheMemoryStopAtTheLastLevelThatFits) {
  // A huge lambda2 once ran the octrees until the system killed the process, then stopped with
  // an error; now they stop at the last level that fits half the machine's memory (here 1 MiB),
  // the same grid whichever way they are built.
  const Scene scene = load_scene("builtin:teapot-stadium:4000");
  for (const BuildConfig& config : {testing::initial_grid_config(), BuildConfig{}}) {
    const auto depth_first = build_on<TinyMemoryExecutor>(scene, config);
    const auto level_by_level = build_on<TinyMemoryLevelByLevelExecutor>(scene, config);
    testing::expect_same_grid(depth_first, level_by_level);
    EXPECT_TRUE(depth_first.budget_limited);
    EXPECT_TRUE(level_by_level.budget_limited);
    EXPECT_EQ(depth_first.budget_bytes, std::uint64_t(1) << 19);
    if (config.alpha == 0)
      EXPECT_LE(octree_peak_bytes(depth_first.info.num_entries, depth_first.info.num_cells,
                                  depth_first.info.num_refs),
                depth_first.budget_bytes);
  }
}

TEST(GridLimits, BudgetLimitedOctreesEqualEitherWay) {
  // Budgets that stop the octrees at different levels, and splits that do not pay (overlap).
  for (const char* spec :
       {"builtin:teapot-stadium:3000", "builtin:overlap:2000", "builtin:stack:3000"}) {
    const Scene scene = load_scene(spec);
    for (std::uint64_t budget : {std::uint64_t(0), std::uint64_t(1) << 22, std::uint64_t(1) << 20,
                                 std::uint64_t(300) << 10}) {
      SCOPED_TRACE(::testing::Message() << spec << ", budget " << budget);
      BuildConfig config;
      config.memory_budget = budget;
      const auto depth_first = build_on<CpuExecutor>(scene, config);
      const auto level_by_level = build_on<LevelByLevelExecutor>(scene, config);
      testing::expect_same_grid(depth_first, level_by_level);
      EXPECT_EQ(depth_first.budget_limited, level_by_level.budget_limited);
    }
  }
}

/// What build_initial_grid hands the depth-first octrees of `spec`: the top grid, its pairs
/// sorted by top cell, the depths and the octree rule.
struct DepthFirstInputs {
  CpuExecutor exec;
  GridArrays<CpuExecutor> grid;
  RefPairs<CpuExecutor> pairs;
  OctreeDepths<CpuExecutor> depths;
  std::vector<std::uint32_t> first;  ///< each top cell's first pair
  BuildConfig config;

  explicit DepthFirstInputs(const std::string& spec, const BuildConfig& settings = {})
      : config(settings) {
    gather_triangles(load_scene(spec).mesh(), grid.triangles);
    grid.budget_bytes = construction_budget(config, grid.triangles.size(), exec.memory_budget());
    auto counts = plan_top_grid_within_budget(exec, grid, config);
    pairs = emit_top_level_refs(exec, grid.triangles.data(), grid.info, std::move(counts.offsets),
                                counts.total);
    depths = plan_octree_depths(exec, grid.info, pairs, config);
    exec.sort_pairs("pairs", pairs.cell.data(), pairs.tri.data(), pairs.count, 32);
    first.resize(top_cells());
    exec.exclusive_scan("first", depths.refs_per_top_cell.data(), first.data(), top_cells());
  }
  std::uint32_t top_cells() const {
    return std::uint32_t(grid.info.top_dims[0]) * std::uint32_t(grid.info.top_dims[1]) *
           std::uint32_t(grid.info.top_dims[2]);
  }
  OctreeRule rule() const {
    return {depths.per_top_cell.data(), false, config.split_refs, depths.count_split,
            kUnpaidSplitRefs};
  }
  /// The depth-first octrees within `budget` (BudgetExceeded otherwise).
  TopCellOctrees<CpuExecutor> octrees(std::uint64_t budget) {
    return build_top_cell_octrees(exec, grid.info, grid.triangles.data(), pairs,
                                  depths.refs_per_top_cell.data(), rule(), budget);
  }
};

/// Whether the depth-first build's pilot predicts that the octrees of `spec` pass their budget,
/// from the inputs build_initial_grid gives it.
bool pilot_predicts_exceeding(const std::string& spec) {
  DepthFirstInputs in(spec);
  return depth_first_detail::pilot_predicts_budget_exceeded(
      in.exec, in.grid.info, in.grid.triangles.data(), in.rule(), in.pairs.cell.data(),
      in.pairs.tri.data(), in.first.data(), in.depths.refs_per_top_cell.data(), in.pairs.count,
      in.grid.budget_bytes);
}

/// octree_peak_bytes of complete depth-first octrees.
std::uint64_t octree_bytes(const TopCellOctrees<CpuExecutor>& octrees) {
  std::uint64_t entries = 0, cells = 0, refs = 0;
  for (const auto& chunk : octrees.chunks)
    for (const auto& level : chunk.levels)
      entries += level.size();
  for (std::uint32_t t = 0; t < octrees.top_cells; ++t)
    cells += octrees.cells_per_top[t], refs += octrees.refs_per_top[t];
  return octree_peak_bytes(entries, cells, refs);
}

TEST(GridLimits, DepthFirstOctreesProjectedPastTheBudgetStopEarly) {
  // Deep octrees over a hairball: many times the top level, so the pilot leaves them alone
  // (it runs only past 16 times the top level) and only the projection can stop them early.
  BuildConfig deep;
  deep.lambda1 = 0.01f;
  deep.lambda2 = 16;
  DepthFirstInputs in("builtin:hairball:20000", deep);
  const std::uint64_t complete = octree_bytes(in.octrees(std::uint64_t(1) << 60));
  const std::uint64_t top_level = octree_peak_bytes(in.top_cells(), in.top_cells(), in.pairs.count);
  ASSERT_GT(complete, 32 * top_level) << "the pilot would run";
  // Half the octrees' bytes: the build stops on the projection, long before its totals pass.
  try {
    in.octrees(complete / 2);
    FAIL() << "octrees of twice the budget were built";
  } catch (const depth_first_detail::BudgetExceeded& stop) {
    EXPECT_GT(stop.bytes, 0u) << "stopped by the pilot";
    EXPECT_LT(stop.bytes, complete / 4) << "stopped by the totals, not the projection";
  }
  // A budget they fit with room to spare: no projection stops them.
  EXPECT_EQ(octree_bytes(in.octrees(complete + complete / 4)), complete);
  EXPECT_TRUE(depth_first_detail::projection_passes_budget(200, 1, 8, 1000));
  EXPECT_FALSE(depth_first_detail::projection_passes_budget(200, 1, 9, 1000)) << "under 1/8";
  EXPECT_FALSE(depth_first_detail::projection_passes_budget(100, 1, 8, 1000));
}

// The depth-first assembly writes narrow cells where the virtual grid fits 16 bits per axis
// (narrow_cell.h), full cells otherwise: both forms must hold the same cells.
TEST(GridBuild, NarrowAndFullCellsOfTheDepthFirstAssemblyAreTheSame) {
  for (const char* spec : {"builtin:teapot-stadium:3000", "builtin:hairball:5000"}) {
    SCOPED_TRACE(spec);
    DepthFirstInputs in(spec, testing::initial_grid_config());
    ASSERT_TRUE(fits_compact_cells(in.grid.info));
    GridArrays<CpuExecutor> narrow = in.grid, full = in.grid;
    auto octrees = in.octrees(std::uint64_t(1) << 60);
    assemble_top_cell_octrees(in.exec, octrees, narrow);
    octrees = in.octrees(std::uint64_t(1) << 60);
    assemble_top_cell_octrees(in.exec, octrees, full, false);
    EXPECT_EQ(narrow.cells.size(), 0u);
    ASSERT_EQ(narrow.narrow_cells.size(), narrow.info.num_cells);
    EXPECT_EQ(full.narrow_cells.size(), 0u);
    widen_cells(in.exec, narrow);
    EXPECT_EQ(narrow.narrow_cells.capacity(), 0u) << "released";
    testing::expect_same_grid(narrow, full);
  }
}

TEST(GridBuild, WalkingTheLevelsAssemblesTheGridSortingThemDoes) {
  // The CPU's budget-limited path: the level-by-level octrees without cells, assembled by
  // walking the map (cells_by_walk.h), in both cell forms, against the GPU's assembly (a sort of
  // the levels' cells and of all pairs). Budgets that stop the octrees at several levels; empty
  // nodes that split (the two-level grid's rule); a single top cell.
  BuildConfig one_top_cell;
  one_top_cell.lambda1 = 1e-6f;
  struct Case {
    const char* spec;
    BuildConfig config;
    bool split_empty;
  };
  bool some_limited = false;
  for (const Case& c :
       {Case{"builtin:teapot-stadium:3000", {}, false}, Case{"builtin:hairball:5000", {}, false},
        Case{"builtin:overlap:2000", {}, false}, Case{"builtin:hairball:5000", {}, true},
        Case{"builtin:hairball:5000", one_top_cell, false}}) {
    DepthFirstInputs in(c.spec, c.config);
    ASSERT_TRUE(depth_first_applies(in.grid.info));
    ASSERT_TRUE(fits_compact_cells(in.grid.info));
    if (c.config.lambda1 == one_top_cell.lambda1) ASSERT_EQ(in.top_cells(), 1u);
    OctreeRule rule = in.rule();
    rule.split_empty = c.split_empty;
    for (const std::uint64_t budget :
         {std::uint64_t(1) << 40, std::uint64_t(1) << 22, std::uint64_t(1) << 20}) {
      SCOPED_TRACE(::testing::Message()
                   << c.spec << ", split_empty " << c.split_empty << ", top cells "
                   << in.top_cells() << ", budget " << budget);
      const auto levels = [&](bool with_cells) {
        RefPairs<CpuExecutor> copy{in.exec.allocate<std::uint32_t>(in.pairs.count),
                                   in.exec.allocate<std::uint32_t>(in.pairs.count), in.pairs.count};
        std::copy_n(in.pairs.cell.data(), in.pairs.count, copy.cell.data());
        std::copy_n(in.pairs.tri.data(), in.pairs.count, copy.tri.data());
        return build_octree_levels(in.exec, in.grid.info, in.grid.triangles.data(), std::move(copy),
                                   rule, budget, with_cells);
      };
      GridArrays<CpuExecutor> sorted = in.grid, narrow = in.grid, wide = in.grid;
      auto with_cells = levels(true);
      assemble_grid(in.exec, with_cells, sorted);
      auto without_cells = levels(false);
      some_limited |= without_cells.budget_limited;
      EXPECT_TRUE(without_cells.cells.empty());
      EXPECT_EQ(without_cells.num_cells, sorted.info.num_cells);
      {
        auto cellless = levels(false);
        GridArrays<CpuExecutor> unsorted = in.grid;
        EXPECT_THROW(assemble_grid(in.exec, cellless, unsorted), Error) << "no cells to sort";
      }
      assemble_grid_by_walk(in.exec, without_cells, narrow);
      EXPECT_TRUE(narrow.cells.empty());
      ASSERT_EQ(narrow.narrow_cells.size(), narrow.info.num_cells);
      widen_cells(in.exec, narrow);
      testing::expect_same_grid(sorted, narrow);
      without_cells = levels(false);
      assemble_grid_by_walk(in.exec, without_cells, wide, false);
      EXPECT_TRUE(wide.narrow_cells.empty());
      testing::expect_same_grid(sorted, wide);
    }
  }
  EXPECT_TRUE(some_limited);
}

TEST(GridLimits, ALevelStopsItsTestsEarlyWithTheSameOctrees) {
  // The level-by-level build stops a level's triangle/child tests once the splits that must
  // happen pass the budget; the octrees must be those of a level that ran all its tests.
  for (const char* spec : {"builtin:overlap:2000", "builtin:teapot-stadium:3000"}) {
    CpuExecutor exec;
    GridArrays<CpuExecutor> grid;
    gather_triangles(load_scene(spec).mesh(), grid.triangles);
    const BuildConfig config;
    grid.budget_bytes = construction_budget(config, grid.triangles.size(), exec.memory_budget());
    auto counts = plan_top_grid_within_budget(exec, grid, config);
    auto pairs = emit_top_level_refs(exec, grid.triangles.data(), grid.info,
                                     std::move(counts.offsets), counts.total);
    const auto depths = plan_octree_depths(exec, grid.info, pairs, config);
    const auto octrees = [&](std::uint64_t budget, bool stop_early) {
      OctreeRule rule{depths.per_top_cell.data(), false, config.split_refs, depths.count_split,
                      kUnpaidSplitRefs};
      rule.stop_tests_at_budget = stop_early;
      RefPairs<CpuExecutor> copy{exec.allocate<std::uint32_t>(pairs.count),
                                 exec.allocate<std::uint32_t>(pairs.count), pairs.count};
      std::copy_n(pairs.cell.data(), pairs.count, copy.cell.data());
      std::copy_n(pairs.tri.data(), pairs.count, copy.tri.data());
      return build_octree_levels(exec, grid.info, grid.triangles.data(), std::move(copy), rule,
                                 budget);
    };
    const auto complete = octrees(std::uint64_t(1) << 40, true);
    ASSERT_FALSE(complete.budget_limited) << spec;
    const std::uint64_t peak =
        octree_peak_bytes(complete.num_entries, complete.num_cells, complete.num_refs);
    bool some_stopped = false;
    for (const std::uint64_t budget : {peak, peak - 1, peak / 2, peak / 4, peak / 16}) {
      SCOPED_TRACE(::testing::Message() << spec << ", budget " << budget);
      const auto early = octrees(budget, true), late = octrees(budget, false);
      EXPECT_EQ(early.budget_limited, late.budget_limited);
      EXPECT_EQ(early.num_entries, late.num_entries);
      EXPECT_EQ(early.num_cells, late.num_cells);
      EXPECT_EQ(early.num_refs, late.num_refs);
      EXPECT_EQ(early.budget_limited, budget < peak);
      some_stopped |= early.budget_limited;
    }
    EXPECT_TRUE(some_stopped);
  }
}

TEST(GridLimits, APilotSendsOnlyOctreesFarPastTheBudgetToTheLevelByLevelBuild) {
  // Large triangles crossing the box: the complete octrees would take many budgets, and the
  // depth-first build would run through one of them before it found out.
  EXPECT_TRUE(pilot_predicts_exceeding("builtin:overlap:30000"));
  // Scenes whose octrees fit, and a stack whose full top cells the pilot leaves out.
  for (const char* spec : {"builtin:teapot-stadium:20000", "builtin:hairball:20000",
                           "builtin:stack:30000", "builtin:cornell"})
    EXPECT_FALSE(pilot_predicts_exceeding(spec)) << spec;
}

TEST(GridLimits, ATopGridThatOutgrowsTheMemoryStopsBeforeItIsAllocated) {
  // 2^20 top cells of about 32 bytes each exceed the 1 MiB machine before any octree is built.
  const Scene scene = load_scene("builtin:cube");
  TinyMemoryExecutor exec;
  GridArrays<TinyMemoryExecutor> grid;
  gather_triangles(scene.mesh(), grid.triangles);
  BuildConfig config;
  config.lambda1 = float(1 << 20) / float(grid.triangles.size());
  PhaseTimes phases;
  try {
    build_grid(exec, grid, config, phases);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::out_of_memory);
    EXPECT_NE(std::string(e.what()).find("lower lambda1"), std::string::npos) << e.what();
    EXPECT_EQ(phases[std::size_t(BuildPhase::octree_levels)].has_value(), false)
        << "stopped before the octrees";
  }
}

TEST(GridLimits, InvalidParametersNameTheValue) {
  const Scene scene = load_scene("builtin:cube");
  BuildConfig config;
  config.lambda1 = 0;
  try {
    build_test_grid(scene, config);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
    EXPECT_NE(std::string(e.what()).find("lambda1"), std::string::npos);
  }
  config = {};
  config.lambda1 = 1e12f;
  EXPECT_THROW(build_test_grid(scene, config), Error);
  config = {};
  config.lambda2 = -1;
  EXPECT_THROW(build_test_grid(scene, config), Error);
}

}  // namespace
}  // namespace irgrid
