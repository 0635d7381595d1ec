// The octree's children masks in SIMD lanes (cpu/octant_masks.h) against child_overlap_mask
// (core/construction/octree_levels.h) one triangle at a time: the same bits for every triangle,
// generic, touching the node's mid-planes, degenerate, huge, tiny, infinite and not a number,
// whatever the count (full registers and partial ones), with every array ending at an
// inaccessible page (tests/guarded_arrays.h), so that a lane reading past one faults.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/construction/octree_levels.h"
#include "cpu/octant_masks.h"
#include "guarded_arrays.h"
#include "irgrid/io/random.h"

namespace irgrid {
namespace {

struct Random {
  Pcg32 rng;
  explicit Random(std::uint64_t seed) { rng.seed(seed, 11); }
  double uniform(double a, double b) { return a + (b - a) * rng.next_float(); }
  int below(int n) { return int(rng.next_u32() % std::uint32_t(n)); }
  bool chance(double p) { return rng.next_float() < p; }
};

NodeSplit random_node(Random& r) {
  NodeSplit n;
  for (int a = 0; a < 3; ++a) {
    // Nodes far from the origin too, where rounding is large against the node.
    const double offset = r.chance(0.3) ? r.uniform(-1e5, 1e5) : 0.0;
    const float lo = float(offset + r.uniform(-8, 8)), half = float(r.uniform(0.01, 4));
    n.lo[a] = lo;
    n.mid[a] = lo + half;
    n.hi[a] = lo + 2 * half;
  }
  n.padding = r.chance(0.5) ? 0.f : float(r.uniform(0, 1e-3));
  n.octants = triangle_box_detail::octant_box(n.lo, n.mid, n.hi, n.padding);
  return n;
}

/// A coordinate near the node on axis a: anywhere around it, on one of its planes or a few
/// units in the last place off it (touching cases, where the test's margin decides), or one of
/// the values that stress NaN handling and overflow.
float random_coordinate(Random& r, const NodeSplit& n, int a) {
  static const float specials[] = {INFINITY, -INFINITY, NAN, 3e38f, -3e38f, 1e-40f, 0.f, -0.f};
  if (r.chance(0.01)) return specials[r.below(8)];
  if (r.chance(0.2)) {
    const float planes[] = {n.lo[a], n.mid[a], n.hi[a], n.mid[a] - n.padding, n.mid[a] + n.padding};
    float x = planes[r.below(5)];
    for (int ulps = r.below(40) - 20; ulps != 0; ulps += ulps > 0 ? -1 : 1)
      x = std::nextafter(x, ulps > 0 ? INFINITY : -INFINITY);
    return x;
  }
  const float span = n.hi[a] - n.lo[a];
  return float(r.uniform(n.lo[a] - span, n.hi[a] + span));
}

std::vector<TriangleVertices> random_triangles(Random& r, const NodeSplit& n, int count) {
  std::vector<TriangleVertices> triangles(static_cast<std::size_t>(count));
  for (TriangleVertices& t : triangles) {
    for (int a = 0; a < 3; ++a) {
      t.p0[a] = random_coordinate(r, n, a);
      // Small triangles around the first corner, large ones anywhere, some degenerate.
      const bool small = r.chance(0.5);
      const float reach = (n.hi[a] - n.lo[a]) * 0.05f;
      t.p1[a] = small ? t.p0[a] + float(r.uniform(-reach, reach)) : random_coordinate(r, n, a);
      t.p2[a] = r.chance(0.05) ? t.p1[a]
                : small        ? t.p0[a] + float(r.uniform(-reach, reach))
                               : random_coordinate(r, n, a);
    }
  }
  return triangles;
}

struct Comparison {
  long compared = 0, differing = 0, exact = 0, partial = 0;
};

/// Compares `lanes` (one of the child_overlap_masks forms) with child_overlap_mask over many
/// nodes, triangle counts from 1 to 70 and ids in shuffled order.
template <typename Lanes>
Comparison compare_with_scalar(Lanes lanes) {
  Random r(2026);
  Comparison c;
  for (int round = 0; round < 600; ++round) {
    const NodeSplit node = random_node(r);
    testing::GuardedArrays arrays;
    const TriangleVertices* triangles = arrays.copy(random_triangles(r, node, 96));
    const auto count = std::uint32_t(1 + r.below(70));
    // The last triangle often, and the last id last.
    std::uint32_t* ids = arrays.make<std::uint32_t>(count);
    for (std::uint32_t k = 0; k < count; ++k)
      ids[k] = std::uint32_t(r.chance(0.2) ? 95 : r.below(96));
    std::uint8_t* masks = arrays.make<std::uint8_t>(count);
    lanes(node, triangles, ids, count, masks);
    for (std::uint32_t k = 0; k < count; ++k) {
      const TriangleVertices& t = triangles[ids[k]];
      const std::uint32_t expected = child_overlap_mask(node, t);
      ++c.compared;
      c.differing += masks[k] != expected;
      // How often the exact test decided (a child left out that the box reaches).
      std::uint32_t reached = 0xFF;
      const BoxF box = triangle_box(t);
      for (int a = 0; a < 3; ++a) {
        if (box.hi[a] + node.padding < node.mid[a]) reached &= ~upper_octants(a);
        if (box.lo[a] - node.padding > node.mid[a]) reached &= upper_octants(a);
      }
      c.exact += expected != reached;
      c.partial += expected != 0 && expected != 0xFF;
    }
  }
  return c;
}

void expect_same_masks(const Comparison& c) {
  EXPECT_EQ(c.differing, 0) << "of " << c.compared;
  // The cases reach every branch: the exact test drops children the box reaches.
  EXPECT_GT(c.exact, c.compared / 50);
  EXPECT_GT(c.partial, c.compared / 4);
}

template <SimdIsa kIsa>
void expect_lanes_equal_scalar() {
  if (!cpu_has(kIsa)) GTEST_SKIP() << "this CPU lacks the instruction set";
  expect_same_masks(
      compare_with_scalar([](const NodeSplit& node, const TriangleVertices* triangles,
                             const std::uint32_t* ids, std::uint32_t count, std::uint8_t* masks) {
        child_overlap_masks_in_lanes<kIsa>(node, triangles, ids, count, masks);
      }));
}

TEST(OctantMasks, Avx2LanesGiveTheScalarMasks) {
  expect_lanes_equal_scalar<SimdIsa::avx2>();
}

TEST(OctantMasks, Avx512LanesGiveTheScalarMasks) {
  expect_lanes_equal_scalar<SimdIsa::avx512>();
}

TEST(OctantMasks, DispatchGivesTheScalarMasks) {
  expect_same_masks(
      compare_with_scalar([](const NodeSplit& node, const TriangleVertices* triangles,
                             const std::uint32_t* ids, std::uint32_t count, std::uint8_t* masks) {
        child_overlap_masks(node, triangles, 96, ids, count, masks);
      }));
}

/// level_child_masks in the lanes of kIsa against child_overlap_mask pair by pair: each pair
/// with its own node, nodes of one size on a grid placed anywhere, only the picked pairs written.
template <SimdIsa kIsa>
void expect_level_lanes_equal_scalar() {
  if (!cpu_has(kIsa)) GTEST_SKIP() << "this CPU lacks the instruction set";
  Random r(1207);
  long compared = 0, differing = 0, left_out = 0, untouched = 0;
  for (int round = 0; round < 300; ++round) {
    GridInfo info{};
    const double offset = r.chance(0.3) ? r.uniform(-1e5, 1e5) : 0.0;
    for (int a = 0; a < 3; ++a) {
      info.box_lo[a] = float(offset + r.uniform(-8, 8));
      info.voxel_size[a] = float(r.uniform(1e-3, 0.5));
    }
    info.padding = r.chance(0.5) ? 0.f : float(r.uniform(0, 1e-3));
    const std::int32_t half = std::int32_t(1) << r.below(5);
    testing::GuardedArrays arrays;
    Voxel* node_lo = arrays.make<Voxel>(40);
    for (int k = 0; k < 40; ++k)
      node_lo[k] = {2 * half * r.below(64), 2 * half * r.below(64), 2 * half * r.below(64)};
    const auto pairs = std::uint32_t(1 + r.below(90));
    std::uint32_t* pair_node = arrays.make<std::uint32_t>(pairs);
    std::uint32_t* pair_tri = arrays.make<std::uint32_t>(pairs);
    TriangleVertices* triangles = arrays.make<TriangleVertices>(pairs);
    std::vector<std::uint32_t> picks;
    for (std::uint32_t p = 0; p < pairs; ++p) {
      // The last node often; the pairs' triangles in reverse, so the last pair's is the first.
      pair_node[p] = std::uint32_t(r.chance(0.2) ? 39 : r.below(40));
      pair_tri[p] = pairs - 1 - p;
      // A triangle around its pair's node, as a level's pairs are.
      triangles[pair_tri[p]] =
          random_triangles(r, node_split(info, node_lo[pair_node[p]], half), 1)[0];
      if (r.chance(0.8)) picks.push_back(p);
    }
    const std::uint32_t* picked = arrays.copy(picks);
    std::uint8_t* masks = arrays.make<std::uint8_t>(pairs);
    std::memset(masks, 0xA5, pairs);
    level_child_masks_in_lanes<kIsa>(info, half, triangles, node_lo, pair_node, pair_tri, picked,
                                     std::uint32_t(picks.size()), masks);
    std::vector<bool> is_picked(pairs);
    for (const std::uint32_t p : picks)
      is_picked[p] = true;
    for (std::uint32_t p = 0; p < pairs; ++p) {
      if (!is_picked[p]) {
        ++left_out;
        untouched += masks[p] == 0xA5;
        continue;
      }
      ++compared;
      differing +=
          masks[p] != child_overlap_mask(info, node_lo[pair_node[p]], half, triangles[pair_tri[p]]);
    }
  }
  EXPECT_EQ(differing, 0) << "of " << compared;
  EXPECT_GT(compared, 5000);
  EXPECT_EQ(untouched, left_out);  // pairs left out keep their bytes
  EXPECT_GT(left_out, 500);
}

TEST(OctantMasks, Avx2LevelLanesGiveTheScalarMasks) {
  expect_level_lanes_equal_scalar<SimdIsa::avx2>();
}

TEST(OctantMasks, Avx512LevelLanesGiveTheScalarMasks) {
  expect_level_lanes_equal_scalar<SimdIsa::avx512>();
}

}  // namespace
}  // namespace irgrid
