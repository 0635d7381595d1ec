// Exit-box expansion (Pérard-Gayot et al. 2017, §3.3; partial expansion, design notes §5): every
// triangle touching a cell's exit box stays in its list, exit boxes hold the entry boxes and stay
// in the grid, cells do grow, traversal stays exact, the result does not depend on the thread
// count, and zero passes change nothing. Also reports the traversal work before and after.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <tuple>

#include "core/construction/expand.h"
#include "core/triangle_box.h"
#include "cpu/triangle_planes.h"
#include "grid_test_support.h"
#include "guarded_arrays.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {
namespace {

using Grid = GridArrays<CpuExecutor>;

constexpr float kInf = std::numeric_limits<float>::infinity();

const std::vector<std::string> kScenes = {"builtin:cornell", "builtin:teapot-stadium:4000",
                                          "builtin:soup:3000", "builtin:hairball:5000",
                                          "builtin:sphere:2000"};

/// The expansion settings under test: passes, partial expansion and its growth quantum.
struct Setting {
  int passes;
  bool partial;
  std::int32_t quantum = 1;
  bool operator<(const Setting& o) const {
    return std::tie(passes, partial, quantum) < std::tie(o.passes, o.partial, o.quantum);
  }
  std::string name() const {
    return std::to_string(passes) + (passes == 1 ? " pass" : " passes") +
           (partial ? ", partial" : ", subset only") +
           (quantum > 1 ? " in steps of " + std::to_string(quantum) : "");
  }
};
const std::vector<Setting> kSettings = {{1, false}, {1, true}, {3, false}, {3, true}, {3, true, 4}};

Grid expanded_copy(const Grid& grid, Setting setting) {
  CpuExecutor exec;
  Grid copy = grid;
  expand_cells(exec, copy, setting.passes, setting.partial, setting.quantum);
  return copy;
}

/// A scene's grid before expansion and after each setting, built once for all tests.
struct ExpandCase {
  Scene scene;
  Grid before;
  std::map<Setting, Grid> after;
  std::map<Setting, double> expand_ms;
};

const ExpandCase& expand_case(const std::string& spec) {
  static std::map<std::string, ExpandCase> cache;
  auto found = cache.find(spec);
  if (found != cache.end()) return found->second;
  ExpandCase& c = cache[spec];
  c.scene = load_scene(spec);
  BuildConfig config;
  config.expansion_passes = 0;  // in case the builder expands by itself: start unexpanded
  c.before = testing::build_test_grid(c.scene, config);
  for (const Setting& setting : kSettings) {
    const auto start = std::chrono::steady_clock::now();
    c.after[setting] = expanded_copy(c.before, setting);
    c.expand_ms[setting] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return c;
}

bool same_cells(const Grid& a, const Grid& b) {
  return a.cells.size() == b.cells.size() &&
         std::memcmp(a.cells.data(), b.cells.data(), a.cells.size() * sizeof(Cell)) == 0;
}

GridView view_of(const Grid& grid) {
  return {grid.info, grid.entries.data(), grid.cells.data(),
          nullptr,   grid.refs.data(),    grid.triangles.data()};
}

class GridExpand : public ::testing::TestWithParam<std::string> {};

TEST_P(GridExpand, EveryTriangleTouchingAnExitBoxIsInItsList) {
  const ExpandCase& c = expand_case(GetParam());
  for (const Setting& setting : kSettings) {
    const Grid& grid = c.after.at(setting);
    EXPECT_GT(testing::check_lists_cover_exit_boxes(grid, 0.f, setting.name()), 0u);
    // Stronger: expansion keeps the insertion test's padding (half of it here, which leaves room
    // for the rounding of the top-level boxes), which traversal relies on.
    testing::check_lists_cover_exit_boxes(grid, 0.5f * grid.info.padding,
                                          setting.name() + ", padded");
  }
}

TEST_P(GridExpand, ExitBoxesHoldEntryBoxesAndStayInTheGrid) {
  const ExpandCase& c = expand_case(GetParam());
  const GridInfo& info = c.before.info;
  for (const Setting& setting : kSettings) {
    const Grid& grid = c.after.at(setting);
    ASSERT_EQ(std::memcmp(&grid.info, &info, sizeof(GridInfo)), 0);
    ASSERT_EQ(grid.entries.size(), c.before.entries.size());
    ASSERT_EQ(std::memcmp(grid.entries.data(), c.before.entries.data(),
                          grid.entries.size() * sizeof(Entry)),
              0)
        << "the voxel map must keep the entry boxes";
    ASSERT_EQ(grid.refs, c.before.refs);
    ASSERT_EQ(grid.cells.size(), c.before.cells.size());
    for (std::uint32_t id = 0; id < info.num_cells; ++id) {
      const Cell &exit = grid.cells[id], &entry = c.before.cells[id];
      ASSERT_EQ(exit.begin, entry.begin);
      ASSERT_EQ(exit.end, entry.end);
      for (int a = 0; a < 3; ++a) {
        ASSERT_LE(0, exit.lo[a]) << setting.name();
        ASSERT_LE(exit.lo[a], entry.lo[a]) << setting.name();
        ASSERT_LE(entry.hi[a], exit.hi[a]) << setting.name();
        ASSERT_LE(exit.hi[a], info.virtual_dims[a]) << setting.name();
      }
      ASSERT_EQ(lookup_cell(info, grid.entries.data(), {entry.lo[0], entry.lo[1], entry.lo[2]}),
                id);
      ASSERT_EQ(lookup_cell(info, grid.entries.data(),
                            {entry.hi[0] - 1, entry.hi[1] - 1, entry.hi[2] - 1}),
                id);
    }
  }
}

TEST_P(GridExpand, CellsGrow) {
  const ExpandCase& c = expand_case(GetParam());
  for (const Setting& setting : kSettings) {
    const Grid& grid = c.after.at(setting);
    std::size_t grown = 0;
    std::uint64_t volume_before = 0, volume_after = 0;
    for (std::size_t id = 0; id < grid.cells.size(); ++id) {
      grown += testing::cell_volume(grid.cells[id]) > testing::cell_volume(c.before.cells[id]);
      volume_before += testing::cell_volume(c.before.cells[id]);
      volume_after += testing::cell_volume(grid.cells[id]);
    }
    EXPECT_GT(grown, 0u) << setting.name();
    std::printf("%-28s %-22s %7zu cells, %6zu grew, exit/entry volume %.2f, %.1f ms\n",
                GetParam().c_str(), setting.name().c_str(), grid.cells.size(), grown,
                double(volume_after) / double(volume_before), c.expand_ms.at(setting));
  }
}

/// Random rays, rays starting on entry and exit faces (along axes and in random directions,
/// some with tmin > 0 or a short tmax, and the same lines from far outside), and axis-parallel
/// rays through vertices and edge midpoints.
std::vector<Ray> test_rays(const Scene& scene, const Grid& before, const Grid& after) {
  const GridInfo& info = before.info;
  const float diagonal = scene.bounds().diagonal();
  std::vector<Ray> rays = random_rays(scene.bounds(), 2000, 11);
  Pcg32 rng;
  rng.seed(23);
  for (int k = 0; k < 2000; ++k) {
    const std::size_t id = rng.next_u32() % after.cells.size();
    const Cell& c = (k & 1) ? after.cells[id] : before.cells[id];
    const int axis = int(rng.next_u32() % 3);
    Ray ray{};
    for (int b = 0; b < 3; ++b) {
      const float lo = voxel_to_world(info, b, c.lo[b]), hi = voxel_to_world(info, b, c.hi[b]);
      ray.org[b] = lo + rng.next_float() * (hi - lo);
    }
    ray.org[axis] = voxel_to_world(info, axis, (rng.next_u32() & 1) ? c.hi[axis] : c.lo[axis]);
    if (k % 3 == 0) {
      ray.dir[int(rng.next_u32() % 3)] = (rng.next_u32() & 1) ? 1.f : -1.f;
    } else {
      for (float& d : ray.dir)
        d = rng.next_float() - 0.5f;
    }
    ray.tmin = (k % 5 == 0) ? 0.01f * diagonal : 0.f;
    ray.tmax = (k % 7 == 0) ? 0.2f * diagonal : kInf;
    testing::append_with_far_start(rays, ray, 10 * diagonal);
  }
  testing::append_axis_rays_through_vertices(scene, rays);
  return rays;
}

template <Query kQuery>
std::vector<Hit> trace_grid(const Grid& grid, const std::vector<Ray>& rays,
                            TraversalCounters* counters = nullptr) {
  const GridView view = view_of(grid);
  std::vector<Hit> hits(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i)
    hits[i] = traverse_grid<kQuery>(view, rays[i], counters);
  return hits;
}

TEST_P(GridExpand, TraversalStaysExact) {
  const ExpandCase& c = expand_case(GetParam());
  const ReferenceTracer reference(c.scene);
  for (const Setting& setting : kSettings) {
    const Grid& grid = c.after.at(setting);
    const auto rays = test_rays(c.scene, c.before, grid);
    for (Query query : {Query::closest, Query::any}) {
      const auto hits = query == Query::closest ? trace_grid<Query::closest>(grid, rays)
                                                : trace_grid<Query::any>(grid, rays);
      const auto result = validate_hits(reference, c.scene, rays, hits, query, rays.size());
      EXPECT_EQ(result.checked, rays.size());
      EXPECT_EQ(result.mismatches, 0u)
          << setting.name() << (query == Query::any ? " any" : " closest") << ": "
          << (result.examples.empty() ? "" : result.examples[0]);
    }
  }
}

TEST_P(GridExpand, SameCellsWhateverTheThreadCount) {
  const ExpandCase& c = expand_case(GetParam());
  for (const Setting& setting : {Setting{3, false}, Setting{3, true}}) {
    auto expand_with = [&](int threads) {
      tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
      return expanded_copy(c.before, setting);
    };
    const Grid one = expand_with(1), two = expand_with(2);
    EXPECT_TRUE(same_cells(one, two)) << setting.name();
    EXPECT_TRUE(same_cells(one, c.after.at(setting))) << setting.name();
  }
}

TEST_P(GridExpand, ZeroPassesChangeNothing) {
  const ExpandCase& c = expand_case(GetParam());
  for (int passes : {0, -1})
    for (bool partial : {false, true})
      EXPECT_TRUE(same_cells(expanded_copy(c.before, {passes, partial}), c.before));
}

TEST_P(GridExpand, PassesStopOnceNoFaceMayGrow) {
  // A million passes once ran for minutes copying boxes that could no longer change; now the
  // passes stop at that fixed point, which a thousand passes reach as well.
  const ExpandCase& c = expand_case(GetParam());
  for (bool partial : {false, true}) {
    const Grid settled = expanded_copy(c.before, {1000, partial});
    EXPECT_TRUE(same_cells(expanded_copy(c.before, {1000000, partial}), settled));
  }
}

INSTANTIATE_TEST_SUITE_P(Builtin, GridExpand, ::testing::ValuesIn(kScenes),
                         testing::builtin_scene_test_name);

/// A voxel grid of 16^3 unit voxels from the origin, for hand-checked caps.
GridInfo unit_grid(float padding) {
  GridInfo info{};
  info.box_hi = {16, 16, 16};
  info.voxel_size = {1, 1, 1};
  info.inv_voxel_size = {1, 1, 1};
  for (int a = 0; a < 3; ++a)
    info.top_dims[a] = 16, info.virtual_dims[a] = 16;
  info.padding = padding;
  return info;
}

TEST(GridExpandFace, FloorToIntIsExactOnBothSidesOfZero) {
  using expand_detail::floor_to_int;
  EXPECT_EQ(floor_to_int(2.7f), 2);
  EXPECT_EQ(floor_to_int(3.f), 3);
  EXPECT_EQ(floor_to_int(0.f), 0);
  EXPECT_EQ(floor_to_int(-0.f), 0);
  EXPECT_EQ(floor_to_int(-0.5f), -1);
  EXPECT_EQ(floor_to_int(-1.f), -1);
  EXPECT_EQ(floor_to_int(-1.0000001f), -2);
  EXPECT_EQ(floor_to_int(0.99999994f), 0);
  EXPECT_EQ(floor_to_int(16777215.f), 16777215);
}

TEST(GridExpandFace, PartialGrowthStopsBeforeTheFirstExtraTriangle) {
  const GridInfo info = unit_grid(1e-3f);
  const Cell c{{2, 2, 2}, 0, {4, 4, 4}, 0};
  const auto up = [&](const BoxF& box, std::int32_t limit) {
    return expand_detail::growth_before_box<0, +1>(info, c, expand_detail::StoredBounds{box},
                                                   limit);
  };
  const auto down = [&](const BoxF& box, std::int32_t limit) {
    return expand_detail::growth_before_box<0, -1>(info, c, expand_detail::StoredBounds{box},
                                                   limit);
  };
  // Upper x face at 4: a box starting at x = 7.5 lets the face move to plane 7.
  EXPECT_EQ(up({{7.5f, 3, 3}, {9, 3.5f, 3.5f}}, 10), 3);
  // A box starting exactly on plane 7 (or within twice the padding of it) stops the face at 6.
  EXPECT_EQ(up({{7.f, 3, 3}, {9, 3.5f, 3.5f}}, 10), 2);
  EXPECT_EQ(up({{7.0015f, 3, 3}, {9, 3.5f, 3.5f}}, 10), 2);
  // The neighbours' depth still bounds the growth.
  EXPECT_EQ(up({{7.5f, 3, 3}, {9, 3.5f, 3.5f}}, 1), 1);
  // A box reaching into the face's plane allows nothing.
  EXPECT_EQ(up({{3.9f, 3, 3}, {9, 3.5f, 3.5f}}, 10), 0);
  // Lower x face at 2: a box ending at x = 0.5 lets it move to plane 1.
  EXPECT_EQ(down({{0, 3, 3}, {0.5f, 3.5f, 3.5f}}, 10), 1);
  EXPECT_EQ(down({{0, 3, 3}, {1.f, 3.5f, 3.5f}}, 10), 0);
  // Boxes beside the face's cross-section do not limit; touching it (with the padding) does.
  EXPECT_EQ(up({{5, 5, 3}, {9, 6, 3.5f}}, 10), 10);
  EXPECT_EQ(up({{5.5f, 4, 3}, {9, 6, 3.5f}}, 10), 1);
  EXPECT_EQ(up({{5.5f, 3, 4.0015f}, {9, 3, 6}}, 10), 1);
  EXPECT_EQ(up({{5.5f, 3, 4.0025f}, {9, 3, 6}}, 10), 10);
  EXPECT_EQ(up({{5.5f, 0, 0}, {9, 1.9975f, 3}}, 10), 10);
  // A NaN box allows nothing.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(up({{nan, nan, nan}, {nan, nan, nan}}, 10), 0);
  EXPECT_EQ(down({{nan, nan, nan}, {nan, nan, nan}}, 10), 0);
}

/// growth_before_planes against growth_before_box for both faces of c on kAxis that may grow
/// (inside the grid), with limits within the room past each face.
template <int kAxis>
void expect_planes_answer_as_the_box(const GridInfo& info, const Cell& c, const BoxF& box,
                                     Pcg32& rng) {
  using namespace expand_detail;
  const TrianglePlanes planes = triangle_planes(info, StoredBounds{box});
  const std::int32_t room_up = info.virtual_dims[kAxis] - c.hi[kAxis], room_down = c.lo[kAxis];
  if (room_up > 0) {
    const std::int32_t limit = 1 + std::int32_t(rng.next_u32() % std::uint32_t(room_up));
    EXPECT_EQ((growth_before_planes<kAxis, +1>(c, planes, limit)),
              (growth_before_box<kAxis, +1>(info, c, StoredBounds{box}, limit)))
        << "axis " << kAxis << " up, limit " << limit;
  }
  if (room_down > 0) {
    const std::int32_t limit = 1 + std::int32_t(rng.next_u32() % std::uint32_t(room_down));
    EXPECT_EQ((growth_before_planes<kAxis, -1>(c, planes, limit)),
              (growth_before_box<kAxis, -1>(info, c, StoredBounds{box}, limit)))
        << "axis " << kAxis << " down, limit " << limit;
  }
}

TEST(GridExpandFace, TrianglePlanesGiveTheBoxTestsAnswers) {
  // The expansion's per-triangle planes must reproduce growth_before_box exactly (the grids stay
  // bit for bit the same): boxes near, on and between planes of voxels whose world positions
  // round (an offset origin, non-power-of-two sizes), boxes past the grid, NaN boxes.
  Pcg32 rng;
  rng.seed(11);
  GridInfo info{};
  info.box_lo = {-3.3f, 1000.1f, 0.7f};
  info.voxel_size = {0.37f, 0.013f, 1.9f};
  const std::int32_t dims[3] = {53, 900, 17};
  for (int a = 0; a < 3; ++a) {
    info.inv_voxel_size[a] = 1.f / info.voxel_size[a];
    info.virtual_dims[a] = dims[a];
    info.box_hi[a] = info.box_lo[a] + float(dims[a]) * info.voxel_size[a];
  }
  info.padding = 1e-4f;
  const auto coordinate = [&](int a) {
    // A plane's world position, nudged by a few multiples of the margin or at random.
    const std::int32_t plane = std::int32_t(rng.next_u32() % std::uint32_t(dims[a] + 3)) - 1;
    const float at = voxel_to_world(info, a, plane);
    switch (rng.next_u32() % 3) {
      case 0:
        return at + info.padding * (float(int(rng.next_u32() % 9)) - 4.f) * 0.5f;
      case 1:
        return std::nextafter(at, rng.next_u32() % 2 ? 1e9f : -1e9f);
      default:
        return at + rng.next_float() * info.voxel_size[a] * 3.f;
    }
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < 20000; ++k) {
    BoxF box;
    for (int a = 0; a < 3; ++a) {
      const float p = coordinate(a), q = coordinate(a);
      box.lo[a] = std::min(p, q);
      box.hi[a] = std::max(p, q);
    }
    if (k % 500 == 0) box.lo[k / 500 % 3] = nan;
    if (k % 700 == 0) box.hi[k / 700 % 3] = nan;
    Cell c{};
    for (int a = 0; a < 3; ++a) {
      const std::int32_t lo = std::int32_t(rng.next_u32() % std::uint32_t(dims[a]));
      c.lo[a] = lo;
      c.hi[a] = lo + 1 + std::int32_t(rng.next_u32() % std::uint32_t(dims[a] - lo));
    }
    SCOPED_TRACE(::testing::Message() << "case " << k);
    expect_planes_answer_as_the_box<0>(info, c, box, rng);
    expect_planes_answer_as_the_box<1>(info, c, box, rng);
    expect_planes_answer_as_the_box<2>(info, c, box, rng);
    if (HasFailure()) return;
  }
}

/// triangle_planes of each of `triangles`, one at a time.
std::vector<expand_detail::TrianglePlanes> scalar_planes(
    const GridInfo& info, const std::vector<TriangleVertices>& triangles) {
  std::vector<expand_detail::TrianglePlanes> planes;
  for (const TriangleVertices& t : triangles)
    planes.push_back(expand_detail::triangle_planes(info, expand_detail::TriangleBounds{t}));
  return planes;
}

/// `planes_of` (triangle_planes_in_lanes or triangle_planes_of) against triangle_planes, triangle
/// by triangle: corners on, a few ulps off and between the planes of voxels whose world
/// positions round, outside the grid, huge, infinite and NaN; grids of a few shapes and
/// paddings; counts from 1 to 70, the arrays ending at inaccessible pages.
template <typename PlanesOf>
void expect_planes_as_one_at_a_time(PlanesOf planes_of) {
  Pcg32 rng;
  rng.seed(1207);
  long compared = 0, differing = 0, stepped = 0;
  for (int round = 0; round < 400; ++round) {
    GridInfo info{};
    const float offset = round % 3 == 0 ? 1e5f : 0.f;
    for (int a = 0; a < 3; ++a) {
      info.box_lo[a] = offset + (rng.next_float() - 0.5f) * 20.f;
      info.voxel_size[a] = 0.003f + rng.next_float() * 0.7f;
      info.inv_voxel_size[a] = 1.f / info.voxel_size[a];
      info.virtual_dims[a] = 1 + std::int32_t(rng.next_u32() % 2000);
      info.box_hi[a] = info.box_lo[a] + float(info.virtual_dims[a]) * info.voxel_size[a];
    }
    info.padding = round % 4 == 0 ? 0.f : rng.next_float() * 1e-3f;
    const auto coordinate = [&](int a) {
      static const float specials[] = {INFINITY, -INFINITY, NAN, 3e38f, -3e38f, 0.f};
      const std::uint32_t kind = rng.next_u32() % 100;
      if (kind < 2) return specials[rng.next_u32() % 6];
      const std::int32_t plane =
          std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[a] + 5)) - 2;
      const float at = voxel_to_world(info, a, plane);
      if (kind < 40) return at + info.padding * (float(int(rng.next_u32() % 9)) - 4.f) * 0.5f;
      if (kind < 60) {
        float x = at;
        for (int ulps = int(rng.next_u32() % 17) - 8; ulps != 0; ulps += ulps > 0 ? -1 : 1)
          x = std::nextafter(x, ulps > 0 ? INFINITY : -INFINITY);
        return x;
      }
      return at + rng.next_float() * info.voxel_size[a] * 4.f;
    };
    const auto count = std::uint32_t(1 + rng.next_u32() % 70);
    std::vector<TriangleVertices> triangles(count);
    for (TriangleVertices& t : triangles)
      for (int a = 0; a < 3; ++a) {
        t.p0[a] = coordinate(a);
        t.p1[a] = rng.next_u32() % 4 ? coordinate(a) : t.p0[a];
        t.p2[a] = coordinate(a);
      }
    const auto expected = scalar_planes(info, triangles);
    testing::GuardedArrays arrays;
    const TriangleVertices* in = arrays.copy(triangles);
    auto* out = arrays.make<expand_detail::TrianglePlanes>(count);
    planes_of(info, in, count, out);
    for (std::uint32_t k = 0; k < count; ++k) {
      ++compared;
      differing += std::memcmp(&out[k], &expected[k], sizeof(expand_detail::TrianglePlanes)) != 0;
      // How often the rounded guess needed a step (the cases reach the loops).
      const BoxF box = triangle_box(triangles[k]);
      const float at = (box.lo[0] - 2.f * info.padding - info.box_lo[0]) * info.inv_voxel_size[0];
      stepped += std::isfinite(at) && at > 0.f && at < float(info.virtual_dims[0]) &&
                 expected[k].before[0] != std::uint16_t(expand_detail::floor_to_int(at));
    }
  }
  EXPECT_EQ(differing, 0) << "of " << compared;
  EXPECT_GT(compared, 10000);
  EXPECT_GT(stepped, compared / 50);
}

template <SimdIsa kIsa>
void expect_lanes_planes_as_one_at_a_time() {
  if (!cpu_has(kIsa)) GTEST_SKIP() << "this CPU lacks the instruction set";
  expect_planes_as_one_at_a_time([](const GridInfo& info, const TriangleVertices* triangles,
                                    std::uint32_t count, expand_detail::TrianglePlanes* out) {
    triangle_planes_in_lanes<kIsa>(info, triangles, count, out);
  });
}

TEST(GridExpandFace, Avx2LanesGiveTheTrianglePlanes) {
  expect_lanes_planes_as_one_at_a_time<SimdIsa::avx2>();
}

TEST(GridExpandFace, Avx512LanesGiveTheTrianglePlanes) {
  expect_lanes_planes_as_one_at_a_time<SimdIsa::avx512>();
}

TEST(GridExpandFace, DispatchGivesTheTrianglePlanes) {
  expect_planes_as_one_at_a_time(
      [](const GridInfo& info, const TriangleVertices* triangles, std::uint32_t count,
         expand_detail::TrianglePlanes* out) { triangle_planes_of(info, triangles, count, out); });
}

/// Mean cells visited and triangles tested per ray.
struct Work {
  double cells = 0, triangles = 0;
};

Work mean_work(const Grid& grid, const std::vector<Ray>& rays) {
  TraversalCounters counters;
  trace_grid<Query::closest>(grid, rays, &counters);
  return {double(counters.cells) / double(rays.size()),
          double(counters.triangles) / double(rays.size())};
}

TEST(GridExpandReport, TraversalWorkBeforeAndAfter) {
  for (const char* spec : {"builtin:teapot-stadium:4000", "builtin:cornell"}) {
    const ExpandCase& c = expand_case(spec);
    const auto camera = scene_views(c.scene).at(0);
    const std::vector<std::pair<const char*, std::vector<Ray>>> ray_sets = {
        {"primary", primary_rays(camera, 128, 128)},
        {"random", random_rays(c.scene.bounds(), 50000, 3)}};
    for (const auto& [kind, rays] : ray_sets) {
      const Work before = mean_work(c.before, rays);
      std::printf("%-28s %-8s %-22s cells/ray %7.2f  triangles/ray %7.2f\n", spec, kind,
                  "unexpanded", before.cells, before.triangles);
      for (const Setting& setting : kSettings) {
        const Work after = mean_work(c.after.at(setting), rays);
        std::printf("%-28s %-8s %-22s cells/ray %7.2f  triangles/ray %7.2f\n", spec, kind,
                    setting.name().c_str(), after.cells, after.triangles);
        EXPECT_LE(after.cells, before.cells) << spec << " " << kind << " " << setting.name();
      }
    }
  }
}

}  // namespace
}  // namespace irgrid
