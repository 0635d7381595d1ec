// Cell merging (Pérard-Gayot et al. 2017, §3.2): merged cells still tile the grid, the voxel map
// finds them, every list is the exact sorted union of the merged cells' lists, the SAH cost does
// not grow, the result does not depend on the thread count, and traversal stays exact.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>

#include "core/construction/device_build_path.h"
#include "core/construction/merge.h"
#include "core/triangle_box.h"
#include "cpu/merge_propose.h"
#include "grid_test_support.h"
#include "guarded_arrays.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {
namespace {

using Grid = GridArrays<CpuExecutor>;

const std::vector<std::string> kScenes = {"builtin:cornell", "builtin:teapot-stadium:4000",
                                          "builtin:soup:3000", "builtin:hairball:5000",
                                          "builtin:sphere:2000"};

constexpr float kAlpha = 0.995f, kCostRatio = 1.f, kEmptyAspect = BuildConfig{}.empty_aspect;

Grid merged_copy(const Grid& grid, float alpha = kAlpha, float cost_ratio = kCostRatio,
                 float empty_aspect = kEmptyAspect, float in_place_below = kMergeInPlaceBelow) {
  CpuExecutor exec;
  Grid copy = grid;
  merge_cells(exec, copy, alpha, cost_ratio, empty_aspect, in_place_below);
  return copy;
}

/// A scene's grid before and after merging, built once per scene for all tests.
struct MergeCase {
  Scene scene;
  Grid before, after;
  double merge_ms = 0;
};

const MergeCase& merge_case(const std::string& spec) {
  static std::map<std::string, MergeCase> cache;
  auto found = cache.find(spec);
  if (found != cache.end()) return found->second;
  MergeCase& c = cache[spec];
  c.scene = load_scene(spec);
  c.before = testing::build_test_grid(c.scene);
  const auto start = std::chrono::steady_clock::now();
  c.after = merged_copy(c.before);
  c.merge_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return c;
}

bool same_grid(const Grid& a, const Grid& b) {
  return std::memcmp(&a.info, &b.info, sizeof(GridInfo)) == 0 &&
         a.entries.size() == b.entries.size() &&
         std::memcmp(a.entries.data(), b.entries.data(), a.entries.size() * sizeof(Entry)) == 0 &&
         a.cells.size() == b.cells.size() &&
         std::memcmp(a.cells.data(), b.cells.data(), a.cells.size() * sizeof(Cell)) == 0 &&
         a.refs == b.refs;
}

/// The grid's total SAH cost up to a constant: sum of half area x (references + C).
double sah_cost(const Grid& grid) {
  double cost = 0;
  for (const Cell& c : grid.cells)
    cost += double(merge_detail::half_area(grid.info, c.lo, c.hi)) *
            (double(c.end - c.begin) + kCostRatio);
  return cost;
}

class GridMerge : public ::testing::TestWithParam<std::string> {};

TEST_P(GridMerge, CellCountDrops) {
  const MergeCase& c = merge_case(GetParam());
  std::printf("[ merge    ] %-28s cells %8u -> %8u, references %8u -> %8u, %.2f ms\n",
              GetParam().c_str(), c.before.info.num_cells, c.after.info.num_cells,
              c.before.info.num_refs, c.after.info.num_refs, c.merge_ms);
  EXPECT_LT(c.after.info.num_cells, c.before.info.num_cells);
  EXPECT_LE(c.after.info.num_refs, c.before.info.num_refs);
}

/// Merging replayed one round per merge_cells call (a tiny positive alpha runs exactly one),
/// stopping where a round keeps kAlpha of the cells.
Grid merged_round_by_round(Grid grid, float in_place_below = kMergeInPlaceBelow) {
  for (int round = 0; round < 100; ++round) {
    const std::uint32_t before = grid.info.num_cells;
    grid = merged_copy(grid, 1e-30f, kCostRatio, kEmptyAspect, in_place_below);
    if (grid.info.num_cells == before ||
        double(grid.info.num_cells) >= double(kAlpha) * double(before))
      break;
  }
  return grid;
}

TEST_P(GridMerge, RoundsRepeatUntilOneKeepsAlphaOfTheCells) {
  const MergeCase& c = merge_case(GetParam());
  EXPECT_TRUE(same_grid(merged_round_by_round(c.before), c.after));
}

TEST_P(GridMerge, CellsTileTheVirtualGridExactly) {
  const Grid& grid = merge_case(GetParam()).after;
  testing::expect_cells_tile_grid(grid);
}

TEST_P(GridMerge, VoxelMapReturnsTheMergedCells) {
  testing::expect_voxel_map_finds_owners(merge_case(GetParam()).after, 23);
}

TEST_P(GridMerge, ListsAreSortedUniqueAndCoverTheReferenceArray) {
  const Grid& grid = merge_case(GetParam()).after;
  ASSERT_EQ(grid.refs.size(), grid.info.num_refs);
  std::uint32_t expected_begin = 0;
  for (const Cell& c : grid.cells) {
    ASSERT_EQ(c.begin, expected_begin) << "lists are packed in cell order";
    ASSERT_LE(c.begin, c.end);
    for (std::uint32_t r = c.begin + 1; r < c.end; ++r)
      ASSERT_LT(grid.refs[r - 1], grid.refs[r]);
    for (std::uint32_t r = c.begin; r < c.end; ++r)
      ASSERT_LT(grid.refs[r], grid.info.num_triangles);
    expected_begin = c.end;
  }
  EXPECT_EQ(expected_begin, grid.info.num_refs);
}

TEST_P(GridMerge, EveryListIsTheUnionOfTheCellsMergedIntoIt) {
  const MergeCase& c = merge_case(GetParam());
  std::vector<std::vector<std::uint32_t>> expected(c.after.info.num_cells);
  for (const Cell& old : c.before.cells) {
    const std::uint32_t id =
        lookup_cell(c.after.info, c.after.entries.data(), Voxel{old.lo[0], old.lo[1], old.lo[2]});
    const Cell& merged = c.after.cells[id];
    for (int a = 0; a < 3; ++a)
      ASSERT_TRUE(merged.lo[a] <= old.lo[a] && old.hi[a] <= merged.hi[a]) << "cell split";
    expected[id].insert(expected[id].end(), c.before.refs.begin() + old.begin,
                        c.before.refs.begin() + old.end);
  }
  for (std::uint32_t id = 0; id < c.after.info.num_cells; ++id) {
    auto& list = expected[id];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    const Cell& merged = c.after.cells[id];
    ASSERT_TRUE(std::equal(list.begin(), list.end(), c.after.refs.begin() + merged.begin,
                           c.after.refs.begin() + merged.end))
        << "cell " << id;
  }
}

TEST_P(GridMerge, EveryTriangleTouchingACellIsInItsList) {
  EXPECT_GT(testing::check_lists_cover_exit_boxes(merge_case(GetParam()).after, 0.f, "merged"), 0u);
}

TEST_P(GridMerge, SahCostDoesNotGrow) {
  const MergeCase& c = merge_case(GetParam());
  EXPECT_LE(sah_cost(c.after), sah_cost(c.before) * (1 + 1e-5));
}

TEST_P(GridMerge, AlphaZeroOrBelowChangesNothing) {
  const Grid& before = merge_case(GetParam()).before;
  for (float alpha : {0.f, -1.f, std::numeric_limits<float>::quiet_NaN()})
    EXPECT_TRUE(same_grid(merged_copy(before, alpha), before)) << "alpha " << alpha;
}

TEST_P(GridMerge, SameResultWhateverTheThreadCount) {
  const MergeCase& c = merge_case(GetParam());
  auto merge_with = [&](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
    return merged_copy(c.before);
  };
  const Grid one = merge_with(1), two = merge_with(2);
  EXPECT_TRUE(same_grid(one, two));
  EXPECT_TRUE(same_grid(one, c.after));
}

TEST_P(GridMerge, InPlaceSweepsGiveTheSameGridAsRebuildingOnes) {
  // Never in place, the default (sweeps with few proposals), every sweep in place.
  const MergeCase& c = merge_case(GetParam());
  const Grid rebuilt = merged_copy(c.before, kAlpha, kCostRatio, kEmptyAspect, 0.f);
  EXPECT_TRUE(same_grid(rebuilt, c.after));
  EXPECT_TRUE(same_grid(merged_copy(c.before, kAlpha, kCostRatio, kEmptyAspect, 2.f), rebuilt));
  // Rounds replayed one by one, each ending with its absorbed cells dropped, agree too.
  EXPECT_TRUE(same_grid(merged_round_by_round(c.before, 2.f), rebuilt));
}

/// The CPU executor merging as the CUDA executor does: chains by pointer jumping, merged cells
/// written to new arrays.
struct GpuWayExecutor : CpuExecutor {
  static constexpr bool kSerialMergeChains = DeviceBuildPath::kSerialMergeChains;
  static constexpr bool kCompactsInPlace = DeviceBuildPath::kCompactsInPlace;
};

TEST_P(GridMerge, TheGpuWayOfMergingGivesTheSameGrid) {
  const MergeCase& c = merge_case(GetParam());
  for (const float in_place_below : {0.f, kMergeInPlaceBelow, 2.f}) {
    GpuWayExecutor exec;
    GridArrays<GpuWayExecutor> gpu_way;
    gpu_way.info = c.before.info;
    gpu_way.entries = c.before.entries;
    gpu_way.cells = c.before.cells;
    gpu_way.refs = c.before.refs;
    gpu_way.triangles = c.before.triangles;
    merge_cells(exec, gpu_way, kAlpha, kCostRatio, kEmptyAspect, in_place_below);
    Grid same;
    same.info = gpu_way.info;
    same.entries = gpu_way.entries;
    same.cells = gpu_way.cells;
    same.refs = gpu_way.refs;
    EXPECT_TRUE(same_grid(same, c.after)) << "in place below " << in_place_below;
  }
}

/// Chains of proposals as next/prev arrays: cells [first, first + length) linked in order.
void link_chain(std::vector<std::uint32_t>& next, std::vector<std::uint32_t>& prev,
                std::uint32_t first, std::uint32_t length) {
  for (std::uint32_t k = 0; k + 1 < length; ++k) {
    next[first + k] = first + k + 1;
    prev[first + k + 1] = first + k;
  }
}

TEST(GridMergeChains, PointerJumpingGivesTheSerialWalksParities) {
  // Chains of 1 to 300 cells (longer than 2^8, so the jumps need 9 passes) between lone cells.
  const std::uint32_t n = 2000;
  std::vector<std::uint32_t> next(n, merge_detail::kNoCell), prev(n, merge_detail::kNoCell);
  for (std::uint32_t first = 0, length = 1; first + length <= n;
       first += length + 1, length = length * 3 % 301 + 1)
    link_chain(next, prev, first, length);
  CpuExecutor serial;
  GpuWayExecutor jumping;
  const auto walked = merge_detail::chain_parity(serial, next.data(), prev.data(), n);
  const auto jumped = merge_detail::chain_parity(jumping, next.data(), prev.data(), n);
  ASSERT_EQ(walked.size(), jumped.size());
  for (std::uint32_t i = 0; i < n; ++i)
    EXPECT_EQ(walked[i], jumped[i]) << "cell " << i;
}

// A cycle cannot come from proposals along an axis; were one there, pointer jumping would loop
// for ever (a GPU build would hang), so it is reported instead.
TEST(GridMergeChains, PointerJumpingReportsACycleInsteadOfLooping) {
  const std::uint32_t n = 64;
  std::vector<std::uint32_t> next(n, merge_detail::kNoCell), prev(n, merge_detail::kNoCell);
  link_chain(next, prev, 10, 5);
  next[14] = 10;
  prev[10] = 14;
  GpuWayExecutor jumping;
  try {
    merge_detail::chain_parity(jumping, next.data(), prev.data(), n);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::internal);
    EXPECT_NE(std::string(e.what()).find("cycle"), std::string::npos) << e.what();
  }
}

// The merged cells are compacted in place; their array ends at its size, not the first sweep's.
TEST_P(GridMerge, MergedCellsTakeNoMoreMemoryThanTheirCount) {
  const MergeCase& c = merge_case(GetParam());
  EXPECT_EQ(c.after.cells.size(), c.after.info.num_cells);
  EXPECT_EQ(c.after.cells.capacity(), c.after.info.num_cells);
}

/// Random rays through the scene box, and rays that start on faces of merged cells.
std::vector<Ray> test_rays(const Scene& scene, const Grid& grid) {
  std::vector<Ray> rays = random_rays(scene.bounds(), 3000, 41);
  Pcg32 rng;
  rng.seed(5);
  for (int k = 0; k < 2000; ++k) {
    const Cell& c = grid.cells[rng.next_u32() % grid.cells.size()];
    Ray ray{{0, 0, 0}, 0, {0, 0, 0}, std::numeric_limits<float>::infinity()};
    for (int a = 0; a < 3; ++a) {
      const float lo = voxel_to_world(grid.info, a, c.lo[a]);
      const float hi = voxel_to_world(grid.info, a, c.hi[a]);
      ray.org[a] = lo + rng.next_float() * (hi - lo);
      ray.dir[a] = rng.next_float() - 0.5f;
    }
    const int face_axis = int(rng.next_u32() % 3);
    ray.org[face_axis] = voxel_to_world(grid.info, face_axis,
                                        (rng.next_u32() & 1) ? c.hi[face_axis] : c.lo[face_axis]);
    if (k % 4 == 0)  // along an axis
      for (int a = 0; a < 3; ++a)
        ray.dir[a] = a == face_axis ? 1.f : 0.f;
    rays.push_back(ray);
  }
  return rays;
}

template <Query kQuery>
std::uint64_t traversal_mismatches(const MergeCase& c, const ReferenceTracer& reference,
                                   const std::vector<Ray>& rays) {
  const Grid& grid = c.after;
  const GridView view{grid.info, grid.entries.data(), grid.cells.data(),
                      nullptr,   grid.refs.data(),    grid.triangles.data()};
  std::vector<Hit> hits(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i)
    hits[i] = traverse_grid<kQuery>(view, rays[i]);
  const auto result = validate_hits(reference, c.scene, rays, hits, kQuery, rays.size());
  EXPECT_EQ(result.checked, rays.size());
  if (!result.examples.empty()) ADD_FAILURE() << result.examples[0];
  return result.mismatches;
}

TEST_P(GridMerge, TraversalOfTheMergedGridMatchesTheReference) {
  const MergeCase& c = merge_case(GetParam());
  const ReferenceTracer reference(c.scene);
  const auto rays = test_rays(c.scene, c.after);
  EXPECT_EQ(traversal_mismatches<Query::closest>(c, reference, rays), 0u);
  EXPECT_EQ(traversal_mismatches<Query::any>(c, reference, rays), 0u);
}

/// build_grid's phases up to assemble_grid: the voxel map still in octree form.
Grid build_octree_form_grid(const Scene& scene) {
  CpuExecutor exec;
  Grid grid;
  for (const auto& tri : scene.triangles)
    grid.triangles.push_back({Vec3<float>::from(scene.vertices[tri[0]]),
                              Vec3<float>::from(scene.vertices[tri[1]]),
                              Vec3<float>::from(scene.vertices[tri[2]])});
  PhaseTimes phases_ms;
  PhaseClock clock(exec, phases_ms);
  build_initial_grid(exec, grid, BuildConfig{}, clock);
  widen_cells(exec, grid);
  return grid;
}

TEST(CellOrder, SpreadBitsPutsBitKAtBit3K) {
  EXPECT_EQ(spread_bits_by_3(0), 0u);
  EXPECT_EQ(spread_bits_by_3(0b101), 0b1000001u);
  EXPECT_EQ(spread_bits_by_3(0x1fffff), 0x1249249249249249ull);
  EXPECT_EQ(spread_bits_by_3(0x200000), 0u) << "only the low 21 bits";
}

TEST_P(GridMerge, InitialCellsFollowTheMortonOrderOfTheirCorners) {
  const MergeCase& c = merge_case(GetParam());
  const Grid grid = build_octree_form_grid(c.scene);
  ASSERT_GT(grid.info.num_cells, 1u);
  for (std::uint32_t id = 1; id < grid.info.num_cells; ++id)
    ASSERT_LT(morton_key(grid.cells[id - 1].lo, 0), morton_key(grid.cells[id].lo, 0))
        << "cell " << id;
  // The renumbering kept the map and the lists consistent with the cells.
  for (std::uint32_t id = 0; id < grid.info.num_cells; ++id) {
    const Cell& cell = grid.cells[id];
    ASSERT_EQ(
        lookup_cell(grid.info, grid.entries.data(), Voxel{cell.lo[0], cell.lo[1], cell.lo[2]}), id);
  }
}

TEST_P(GridMerge, MergingTheOctreeFormMapThenCompactingGivesTheSameCells) {
  const MergeCase& c = merge_case(GetParam());
  CpuExecutor exec;
  Grid grid = build_octree_form_grid(c.scene);
  const std::vector<std::uint32_t> level_offsets = grid.level_offsets;
  merge_cells(exec, grid, kAlpha, kCostRatio, kEmptyAspect);
  EXPECT_EQ(grid.level_offsets, level_offsets) << "the map keeps its shape";
  compact_map(exec, grid);
  ASSERT_EQ(grid.info.num_cells, c.after.info.num_cells);
  EXPECT_EQ(std::memcmp(grid.cells.data(), c.after.cells.data(), grid.cells.size() * sizeof(Cell)),
            0);
  EXPECT_EQ(grid.refs, c.after.refs);
  for (std::uint32_t id = 0; id < grid.info.num_cells; ++id) {
    const Cell& cell = grid.cells[id];
    ASSERT_EQ(
        lookup_cell(grid.info, grid.entries.data(), Voxel{cell.lo[0], cell.lo[1], cell.lo[2]}), id);
  }
}

/// `grid` with its cells in the narrow form only (narrow_cell.h).
Grid narrowed(const Grid& grid) {
  CpuExecutor exec;
  Grid narrow = grid;
  narrow.narrow_cells = exec.allocate<NarrowCell>(grid.info.num_cells);
  for (std::uint32_t i = 0; i < grid.info.num_cells; ++i) {
    const Cell& cell = grid.cells[i];
    NarrowCell& to = narrow.narrow_cells[i];
    for (int a = 0; a < 3; ++a) {
      to.lo[a] = std::uint16_t(cell.lo[a]);
      to.hi[a] = std::uint16_t(cell.hi[a]);
    }
    to.begin = cell.begin;
    to.end = cell.end;
  }
  release_buffer(narrow.cells);
  return narrow;
}

/// Merges `scene`'s octree-form grid in both cell forms and expects the same grid, in-place
/// sweeps included.
void expect_narrow_cells_merge_as_full_cells_do(const Scene& scene, std::uint32_t min_cells = 0) {
  CpuExecutor exec;
  const Grid initial = build_octree_form_grid(scene);
  ASSERT_TRUE(fits_compact_cells(initial.info));
  ASSERT_GE(initial.info.num_cells, min_cells);
  for (const float in_place_below : {0.f, kMergeInPlaceBelow, 1.f}) {
    SCOPED_TRACE(in_place_below);
    Grid full = initial, narrow = narrowed(initial);
    merge_cells(exec, full, kAlpha, kCostRatio, kEmptyAspect, in_place_below);
    merge_cells(exec, narrow, kAlpha, kCostRatio, kEmptyAspect, in_place_below);
    ASSERT_EQ(narrow.narrow_cells.size(), narrow.info.num_cells) << "merged as narrow cells";
    widen_cells(exec, narrow);
    EXPECT_TRUE(same_grid(narrow, full));
  }
}

// Merging works on the depth-first assembly's narrow cells (narrow_cell.h) or on full cells, with
// the same result.
TEST_P(GridMerge, NarrowCellsMergeAsFullCellsDo) {
  expect_narrow_cells_merge_as_full_cells_do(merge_case(GetParam()).scene);
}

// A narrow cell keeps its partner's id in both halves of its upper corner: ids past 16 bits.
TEST(GridMergeNarrow, PartnersPast65535MergeAsFullCellsDo) {
  expect_narrow_cells_merge_as_full_cells_do(load_scene("builtin:sphere:60000"), 1u << 17);
}

/// A sweep's proposals in the lanes of kIsa (cpu/merge_propose.h) against merge_partner, cell by
/// cell: every axis, quiet cells skipped, quiet bits tracked or not, batches of every length,
/// every array ending at an inaccessible page (a lane reading past one faults).
template <SimdIsa kIsa>
void expect_lane_proposals_as_merge_partner() {
  if (!cpu_has(kIsa)) GTEST_SKIP() << "this CPU lacks the instruction set";
  for (const char* name : {"builtin:sphere:20000", "builtin:teapot-stadium:20000",
                           "builtin:hairball:20000", "builtin:cornell"}) {
    SCOPED_TRACE(name);
    const Grid grid = narrowed(build_octree_form_grid(load_scene(name)));
    const std::uint32_t n = grid.info.num_cells;
    testing::GuardedArrays arrays;
    const NarrowCell* cells = arrays.copy(grid.narrow_cells);
    const Entry* entries = arrays.copy(grid.entries);
    const std::uint32_t* refs = arrays.copy(grid.refs);
    Pcg32 rng;
    rng.seed(n, 5);
    long proposals = 0;
    // At 1.5 two empty cubes are too long to merge; at 0 any empty cells may.
    for (const float empty_aspect : {kEmptyAspect, 1.5f, 0.f})
      for (int axis = 0; axis < 3; ++axis)
        for (const bool track : {false, true}) {
          std::uint32_t* next = arrays.make<std::uint32_t>(n);
          std::uint32_t* prev = arrays.make<std::uint32_t>(n);
          std::uint32_t* union_size = arrays.make<std::uint32_t>(n);
          std::uint32_t* quiet = arrays.make<std::uint32_t>(n);
          std::vector<std::uint32_t> quiet_before(n);
          for (std::uint32_t c = 0; c < n; ++c) {
            next[c] = prev[c] = union_size[c] = 7;
            quiet[c] = quiet_before[c] = rng.next_u32() % 4 == 0 ? 7u : 0u;
          }
          const merge_detail::ProposeInputs in{grid.info, entries,    cells,        refs,
                                               axis,      kCostRatio, empty_aspect, next,
                                               prev,      union_size, quiet,        track};
          for (std::uint32_t first = 0; first < n;) {
            const std::uint32_t count = std::min(n - first, 1 + rng.next_u32() % 40);
            propose_merges_with<kIsa>(in, first, count);
            first += count;
          }
          for (std::uint32_t c = 0; c < n; ++c) {
            std::uint32_t size = 0;
            const std::uint32_t partner =
                quiet_before[c] >> axis & 1
                    ? merge_detail::kNoCell
                    : merge_detail::merge_partner(grid.info, entries, cells, refs, c, axis,
                                                  kCostRatio, empty_aspect, size);
            ASSERT_EQ(next[c], partner) << "cell " << c << " axis " << axis;
            ASSERT_EQ(union_size[c], partner == merge_detail::kNoCell ? 0 : size);
            ASSERT_EQ(prev[c], merge_detail::kNoCell);
            const bool quieted = track && partner == merge_detail::kNoCell;
            ASSERT_EQ(quiet[c], quiet_before[c] | (quieted ? 1u << axis : 0u));
            proposals += partner != merge_detail::kNoCell;
          }
        }
    EXPECT_GT(proposals, n / 10);  // the cells propose, not only decline
  }
}

TEST(GridMergeLanes, Avx2ProposalsAreMergePartners) {
  expect_lane_proposals_as_merge_partner<SimdIsa::avx2>();
}
TEST(GridMergeLanes, Avx512ProposalsAreMergePartners) {
  expect_lane_proposals_as_merge_partner<SimdIsa::avx512>();
}

// Merging skips the proposals of cells it knows to be quiet (merge.h). At alpha = 1 it runs
// until a round merges nothing, so no cell may then have a merge left to propose along any axis.
TEST_P(GridMerge, AtAlphaOneNoCellHasAMergeLeft) {
  const Grid grid = merged_copy(merge_case(GetParam()).before, 1.f);
  for (int axis = 0; axis < 3; ++axis)
    for (std::uint32_t id = 0; id < grid.info.num_cells; ++id) {
      std::uint32_t union_size = 0;
      ASSERT_EQ(merge_detail::merge_partner(grid.info, grid.entries.data(), grid.cells.data(),
                                            grid.refs.data(), id, axis, kCostRatio, kEmptyAspect,
                                            union_size),
                merge_detail::kNoCell)
          << "cell " << id << " axis " << axis;
    }
}

// The proposals are computed in batches of CpuExecutor::kLookupBatch cells with their map walks
// interleaved (merge_pairs.h); each must be the one merge_partner finds for its cell alone, and a
// quiet cell proposes nothing. (All cases but the sphere end in a partial batch.)
TEST_P(GridMerge, BatchedProposalsEqualSingleCellProposals) {
  const Grid& grid = merge_case(GetParam()).before;
  const std::uint32_t n = grid.info.num_cells;
  CpuExecutor exec;
  std::vector<std::uint32_t> next(n), prev(n), union_size(n), quiet(n);
  for (int axis = 0; axis < 3; ++axis) {
    for (std::uint32_t i = 0; i < n; ++i)
      quiet[i] = i % 7 == 3 ? 1u << axis : 0u;
    const std::uint32_t proposals = merge_detail::propose_merges(
        exec, grid, grid.cells.data(), axis, kCostRatio, kEmptyAspect, next.data(), prev.data(),
        union_size.data(), quiet.data(), true);
    std::uint32_t expected_proposals = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
      std::uint32_t size = 0;
      const std::uint32_t partner =
          i % 7 == 3 ? merge_detail::kNoCell
                     : merge_detail::merge_partner(grid.info, grid.entries.data(),
                                                   grid.cells.data(), grid.refs.data(), i, axis,
                                                   kCostRatio, kEmptyAspect, size);
      ASSERT_EQ(next[i], partner) << "cell " << i << " axis " << axis;
      if (partner == merge_detail::kNoCell) {
        EXPECT_NE(quiet[i] & (1u << axis), 0u) << "cell " << i << " is quiet now";
        continue;
      }
      ++expected_proposals;
      EXPECT_EQ(union_size[i], size);
      EXPECT_EQ(prev[partner], i);
    }
    EXPECT_EQ(proposals, expected_proposals);
    EXPECT_GT(proposals, 0u);
  }
}

/// The largest aspect ratio (longest over shortest side, world units) among empty cells.
double widest_empty_cell(const Grid& grid) {
  double widest = 0;
  for (const Cell& c : grid.cells) {
    if (c.end != c.begin) continue;
    double longest = 0, shortest = INFINITY;
    for (int a = 0; a < 3; ++a) {
      const double side = double(c.hi[a] - c.lo[a]) * grid.info.voxel_size[a];
      longest = std::max(longest, side);
      shortest = std::min(shortest, side);
    }
    widest = std::max(widest, longest / shortest);
  }
  return widest;
}

// Empty cells start as octree nodes, shaped like a top cell; a merge along an axis keeps that
// side within empty_aspect times the thinnest other one, so no empty cell grows wider than
// max(empty_aspect, the top cell's aspect ratio).
TEST_P(GridMerge, EmptyCellsKeepABoundedAspectRatio) {
  const MergeCase& c = merge_case(GetParam());
  const Grid bounded = merged_copy(c.before, 1.f),
             unbounded = merged_copy(c.before, 1.f, kCostRatio, 0.f);
  const GridInfo& info = c.before.info;
  double top_longest = 0, top_shortest = INFINITY;
  for (int a = 0; a < 3; ++a) {
    const double side = double(info.voxel_size[a]) * double(1 << info.shift);
    top_longest = std::max(top_longest, side);
    top_shortest = std::min(top_shortest, side);
  }
  const double bound = std::max(double(kEmptyAspect), top_longest / top_shortest) * (1 + 1e-5);
  EXPECT_LE(widest_empty_cell(bounded), bound);
  EXPECT_GT(widest_empty_cell(unbounded), bound) << "the SAH alone makes slabs here";
  EXPECT_LT(bounded.info.num_cells, c.before.info.num_cells) << "empty cells still merge";
  std::printf("%-28s widest empty cell: %.1f bounded, %.1f with the SAH alone\n",
              GetParam().c_str(), widest_empty_cell(bounded), widest_empty_cell(unbounded));
}

TEST(GridMergeLimits, EmptyAspectBelowOneIsRejected) {
  const Scene scene = load_scene("builtin:cube");
  BuildConfig config;
  config.empty_aspect = 0.5f;
  try {
    testing::build_test_grid(scene, config);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
    EXPECT_NE(std::string(e.what()).find("empty_aspect"), std::string::npos);
  }
}

INSTANTIATE_TEST_SUITE_P(Builtin, GridMerge, ::testing::ValuesIn(kScenes),
                         testing::builtin_scene_test_name);

TEST(GridMergeParameters, AlphaOneAndAboveStopWhenNothingMerges) {
  const MergeCase& c = merge_case("builtin:cornell");
  const Grid one = merged_copy(c.before, 1.f), four = merged_copy(c.before, 4.f);
  EXPECT_LE(one.info.num_cells, c.after.info.num_cells);
  EXPECT_TRUE(same_grid(one, four));
  EXPECT_TRUE(same_grid(merged_copy(one, 1.f), one)) << "a fixed point: nothing left to merge";
}

TEST(GridMergeParameters, InvalidCostRatioNamesTheValue) {
  const Grid& before = merge_case("builtin:cornell").before;
  for (float bad :
       {-1.f, std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()}) {
    try {
      merged_copy(before, kAlpha, bad);
      ADD_FAILURE() << "cost_ratio " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
      EXPECT_NE(std::string(e.what()).find("cost_ratio"), std::string::npos);
    }
  }
}

TEST(GridMergeParameters, HigherCostRatioMergesMore) {
  const MergeCase& c = merge_case("builtin:teapot-stadium:4000");
  const Grid cheap = merged_copy(c.before, kAlpha, 0.f), dear = merged_copy(c.before, kAlpha, 8.f);
  EXPECT_LT(dear.info.num_cells, cheap.info.num_cells);
}

TEST(GridMergeLists, SortedUnionOfSortedLists) {
  const std::uint32_t a[] = {1, 4, 5, 9}, b[] = {0, 4, 9, 12, 13};
  std::uint32_t out[9] = {};
  EXPECT_EQ(sorted_union_size(a, 4, b, 5), 7u);
  EXPECT_EQ(sorted_union_size(a, 0, b, 5), 5u);
  EXPECT_EQ(sorted_union_size(a, 4, b, 0), 4u);
  ASSERT_EQ(write_sorted_union(a, 4, b, 5, out), 7u);
  const std::uint32_t expected[] = {0, 1, 4, 5, 9, 12, 13};
  EXPECT_TRUE(std::equal(expected, expected + 7, out));
}

}  // namespace
}  // namespace irgrid
