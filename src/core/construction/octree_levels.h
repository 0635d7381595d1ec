// core/construction/octree_levels.h: subdivides the top cells into octrees, level by level.
//
// Pérard-Gayot et al. 2017, §3.1 (the "adaptive, dense" start): a node with references and
// depth budget left splits into 2x2x2 children and re-inserts each of its triangles into the
// children it overlaps (exact, conservative test); empty nodes never split, so empty space stays
// as large leaves. Every leaf of every level becomes a cell, empty ones included. The voxel map
// comes out in octree form: one dense block of 8 entries per split node.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "core/construction/memory_budget.h"
#include "core/construction/top_level_refs.h"
#include "core/release_buffer.h"
#include "irgrid/build_config.h"

namespace irgrid {

/// The octree-form result: all levels' entries, cells and (cell, triangle) pairs concatenated.
/// A leaf is named by its rank among all levels' leaves, level after level.
template <typename Exec>
struct OctreeLevels {
  std::vector<typename Exec::template Buffer<Entry>> entries;  ///< one buffer per level
  /// Leaves of each level, as cells; none where the build was asked for the map alone (the
  /// leaves' boxes follow from their place in it: assemble_grid_by_walk).
  std::vector<typename Exec::template Buffer<Cell>> cells;
  std::vector<RefPairs<Exec>> pairs;  ///< (cell, triangle) of each level
  std::uint32_t num_entries = 0, num_cells = 0, num_refs = 0;
  /// The construction budget stopped the octrees at the last level that fit it.
  bool budget_limited = false;
};

/// The nodes of one octree level: their lower voxel and their top cell.
template <typename Exec>
struct LevelNodes {
  typename Exec::template Buffer<Voxel> lo;
  typename Exec::template Buffer<std::uint32_t> top;
  std::uint32_t count = 0;
};

/// The lower voxel of top cell `index` (x-fastest order).
IRGRID_HD inline Voxel top_cell_corner(const GridInfo& info, std::uint32_t index) {
  const auto dx = std::uint32_t(info.top_dims[0]), dy = std::uint32_t(info.top_dims[1]);
  return {std::int32_t(index % dx) << info.shift, std::int32_t(index / dx % dy) << info.shift,
          std::int32_t(index / dx / dy) << info.shift};
}

template <typename Exec>
LevelNodes<Exec> top_level_nodes(Exec& exec, const GridInfo& info) {
  const std::uint32_t count = std::uint32_t(info.top_dims[0]) * std::uint32_t(info.top_dims[1]) *
                              std::uint32_t(info.top_dims[2]);
  LevelNodes<Exec> nodes{exec.template allocate<Voxel>(count),
                         exec.template allocate<std::uint32_t>(count), count};
  Voxel* lo = nodes.lo.data();
  std::uint32_t* top = nodes.top.data();
  exec.for_each("top nodes", count, [=] IRGRID_HD(std::size_t i) {
    lo[i] = top_cell_corner(info, std::uint32_t(i));
    top[i] = std::uint32_t(i);
  });
  return nodes;
}

/// The lower voxel of child `bit` (bit 0 selects the upper x half, bit 1 y, bit 2 z) of the node
/// with lower voxel `lo` and children of `half` voxels.
IRGRID_HD inline Voxel child_corner(Voxel lo, std::int32_t half, std::uint32_t bit) {
  return {lo.x + ((bit & 1) ? half : 0), lo.y + ((bit & 2) ? half : 0),
          lo.z + ((bit & 4) ? half : 0)};
}

/// A node about to be split (lower voxel `lo`, children of `half` voxels) in world units: what
/// child_overlap_mask needs of it, computed once for all of its triangles.
struct NodeSplit {
  Vec3<float> lo, mid, hi;
  triangle_box_detail::OctantBox<float> octants;
  float padding;
};

IRGRID_HD inline NodeSplit node_split(const GridInfo& info, Voxel lo, std::int32_t half) {
  NodeSplit n;
  for (int a = 0; a < 3; ++a) {
    n.lo[a] = voxel_to_world(info, a, lo[a]);
    n.mid[a] = voxel_to_world(info, a, lo[a] + half);
    n.hi[a] = voxel_to_world(info, a, lo[a] + 2 * half);
  }
  n.octants = triangle_box_detail::octant_box(n.lo, n.mid, n.hi, info.padding);
  n.padding = info.padding;
  return n;
}

/// 8-bit mask of the children of a node that the triangle overlaps; bit 0 selects the upper x
/// half, bit 1 y, bit 2 z.
IRGRID_HD inline std::uint32_t child_overlap_mask(const NodeSplit& node,
                                                  const TriangleVertices& t) {
  // Cull by the triangle's padded box against the node's mid-planes first (cheap), then run the
  // exact test on the children left, all at once.
  const BoxF box = triangle_box(t);
  std::uint32_t mask = 0xFF;
  for (int a = 0; a < 3; ++a) {
    if (box.hi[a] + node.padding < node.mid[a]) mask &= ~upper_octants(a);
    if (box.lo[a] - node.padding > node.mid[a]) mask &= upper_octants(a);
  }
  // One child left: the triangle meets the node's padded box (it was kept there by the same
  // conservative test), and every such point lies within that child's padded box.
  if ((mask & (mask - 1)) == 0) return mask;
  // A child holding a vertex overlaps it (exact); the others take the separating-axis test.
  const std::uint32_t held =
      mask & octants_holding_vertex(t, node.lo, node.mid, node.hi, node.padding);
  if (held == mask) return mask;
  return held | octants_overlapped(t.p0, t.p1, t.p2, node.octants, mask & ~held);
}

/// child_overlap_mask of the node with lower voxel `lo` and children of `half` voxels.
IRGRID_HD inline std::uint32_t child_overlap_mask(const GridInfo& info, Voxel lo, std::int32_t half,
                                                  const TriangleVertices& t) {
  return child_overlap_mask(node_split(info, lo, half), t);
}

/// Number of set bits of an 8-bit mask, without a library call (x86-64 without -mpopcnt turns
/// std::popcount into one).
IRGRID_HD inline std::uint32_t popcount8(std::uint32_t x) {
  x = x - ((x >> 1) & 0x55u);
  x = (x & 0x33u) + ((x >> 2) & 0x33u);
  return (x + (x >> 4)) & 0x0Fu;
}

/// Indices i < count with keep(i), in order.
template <typename Exec, typename Keep>
typename Exec::template Buffer<std::uint32_t> select_indices(Exec& exec, const char* name,
                                                             std::uint32_t count, Keep keep,
                                                             std::uint32_t& selected) {
  auto all = exec.template allocate<std::uint32_t>(count);
  auto out = exec.template allocate<std::uint32_t>(count);
  std::uint32_t* d_all = all.data();
  exec.for_each(name, count, [=] IRGRID_HD(std::size_t i) { d_all[i] = std::uint32_t(i); });
  selected = std::uint32_t(
      exec.select_if(name, d_all, out.data(), count,
                     [=] IRGRID_HD(std::size_t, std::uint32_t i) { return keep(i); }));
  return out;
}

inline constexpr std::uint8_t kNoSplit = 0, kSplitByDepth = 1, kSplitByCount = 2;

/// Whether a split sets any of a node's triangles apart from another, or zooms in on them all,
/// from the children masks of all of them folded with atomic_and (cheap on both executors):
/// start from kMasksFolded, fold in fold_mask(mask) per triangle. The high byte keeps the AND
/// of the masks, the low byte the AND of their complements (the complement of their OR). It is
/// false only when every triangle lands in the same two or more children (copies of one
/// triangle, or triangles crossing the node together), where splitting only carves away empty
/// space.
inline constexpr std::uint32_t kMasksFolded = 0xFFFFu;
IRGRID_HD inline std::uint32_t fold_mask(std::uint32_t mask) {
  return 0xFFFF0000u | (mask << 8) | (~mask & 0xFFu);
}
IRGRID_HD inline bool masks_differ(std::uint32_t folded) {
  const std::uint32_t all = (folded >> 8) & 0xFFu, any = ~folded & 0xFFu;
  return all != any || (any & (any - 1)) == 0;
}

/// When an octree node splits: below its top cell's depth while it holds references (or even
/// empty, for the two-level grid) and the split pays (depth_split_pays); and, below
/// count_split_depth, while it holds more than split_refs references and the split separates
/// them (see count_split_separates).
struct OctreeRule {
  const std::int32_t* depths;  ///< per top cell
  bool split_empty;
  std::uint32_t split_refs;
  std::int32_t count_split_depth;
  /// Splits of nodes holding more references than this must pay (depth_split_pays);
  /// 0: every split the rules above allow goes ahead (the baselines, as published).
  std::uint32_t unpaid_refs;
  /// Whether a level's tests stop once its sure splits pass the budget (plan_level); the
  /// octrees are the same either way (GridLimits.ALevelStopsItsTestsEarlyWithTheSameOctrees).
  bool stop_tests_at_budget = true;

  IRGRID_HD bool splits_by_depth(std::int32_t level, std::int32_t top_depth,
                                 std::uint32_t refs) const {
    return level < top_depth && (refs > 0 || split_empty);
  }
  IRGRID_HD bool count_candidate(std::int32_t level, std::uint32_t refs) const {
    return refs > split_refs && level < count_split_depth;
  }
  /// Whether the node's triangles are tested against its children before it is decided.
  IRGRID_HD bool candidate(std::int32_t level, std::int32_t top_depth, std::uint32_t refs) const {
    return splits_by_depth(level, top_depth, refs) || count_candidate(level, refs);
  }
  /// A count split must separate the node's triangles: the children together may hold at most
  /// twice its references. Triangles larger than the children land in several of them, and
  /// splitting further only multiplies the references (a fan around a vertex, or long triangles
  /// along a thin cylinder, land in every child on their path, level after level: Conference's
  /// references grew from 0.78 to 1.46 million with a surface-area test alone, for 1.5% fewer
  /// triangle tests per ray). The bound trades the two (measured on the Intel Xeon VM):
  /// at 1.5 times, the teapot in the stadium's spout kept lists of hundreds of long triangles
  /// (88 tests per view-0 primary ray); at 2 times it takes 45, for 25% more references on
  /// Conference (+8% memory) and 2% more on Crown; with no bound, 39 tests and 75% more
  /// references on Conference.
  IRGRID_HD bool count_split_separates(std::uint32_t refs, std::uint64_t child_refs) const {
    return child_refs <= std::uint64_t(refs) * 2;
  }
  /// A depth split of a node holding many references (more than unpaid_refs) must separate
  /// them as a count split must (count_split_separates) and set some apart from the others
  /// (masks_differ). Triangles larger than the node land in about 4 children each, so where
  /// they dominate, splitting multiplies references level after level: 30,000 triangles
  /// crossing a box took 748 million references and 8 GB (the surface area heuristic, which
  /// still sees a small gain at 3.5 times the references, would not stop them). Copies of one
  /// triangle land in the same children, and splitting them only carves away empty space at
  /// 100,000 triangle tests a node. Fuller nodes in real scenes zoom in on a dense object and
  /// pass both tests.
  /// Whether a candidate node splits whatever its children's references (decide): a depth
  /// split that need not pay.
  IRGRID_HD bool splits_surely(std::int32_t level, std::int32_t top_depth,
                               std::uint32_t refs) const {
    return splits_by_depth(level, top_depth, refs) && (unpaid_refs == 0 || refs <= unpaid_refs);
  }
  IRGRID_HD bool depth_split_pays(std::uint32_t refs, std::uint64_t child_refs, bool differ) const {
    return unpaid_refs == 0 || refs <= unpaid_refs ||
           (differ && count_split_separates(refs, child_refs));
  }
  /// How a candidate node holding `refs` references, `child_refs` in its children, splits;
  /// `differ`: masks_differ of their masks.
  IRGRID_HD std::uint8_t decide(std::int32_t level, std::int32_t top_depth, std::uint32_t refs,
                                std::uint64_t child_refs, bool differ) const {
    if (splits_by_depth(level, top_depth, refs))
      return depth_split_pays(refs, child_refs, differ) ? kSplitByDepth : kNoSplit;
    return count_candidate(level, refs) && (differ || unpaid_refs == 0 || refs <= unpaid_refs) &&
                   count_split_separates(refs, child_refs)
               ? kSplitByCount
               : kNoSplit;
  }
};

/// Per-node decisions of one level: which nodes split, where their children and leaves go.
template <typename Exec>
struct LevelPlan {
  typename Exec::template Buffer<std::uint32_t> child_base;  ///< first child (split nodes)
  typename Exec::template Buffer<std::uint32_t>
      leaf_index;                                      ///< leaf rank among this level's leaves
  typename Exec::template Buffer<std::uint8_t> split;  ///< kNoSplit, kSplitByDepth or ...ByCount
  /// Per pair, its children mask, computed for the pairs of candidate nodes only.
  typename Exec::template Buffer<std::uint8_t> pair_masks;
  /// Per node, its triangles' masks folded (masks_differ).
  typename Exec::template Buffer<std::uint32_t> folded;
  std::uint32_t children = 0, leaves = 0;
  bool budget_stop = false;  ///< no node splits: the next level would pass the budget
};

/// The sum of values[i] (1 where values is null) over the nodes i < n that split.
template <typename Exec>
std::uint64_t sum_where_split(Exec& exec, const char* name, const std::uint8_t* split,
                              const std::uint32_t* values, std::uint32_t n) {
  return exec.transform_reduce(
      name, n, std::uint64_t(0), [] IRGRID_HD(std::uint64_t a, std::uint64_t b) { return a + b; },
      [=] IRGRID_HD(std::size_t i) {
        return split[i] == kNoSplit ? std::uint64_t(0) : values ? std::uint64_t(values[i]) : 1;
      });
}

/// Decides which nodes of a level split. `built` holds the levels above; when the octrees cut
/// after the next level would pass `budget` (octree_fits_budget), no node splits.
template <typename Exec>
LevelPlan<Exec> plan_level(Exec& exec, const GridInfo& info, const TriangleVertices* triangles,
                           const LevelNodes<Exec>& nodes, const RefPairs<Exec>& pairs,
                           const OctreeRule& rule, std::int32_t level,
                           const OctreeLevels<Exec>& built, std::uint64_t budget) {
  const std::uint32_t n = nodes.count;
  LevelPlan<Exec> plan{
      exec.template allocate<std::uint32_t>(n), exec.template allocate<std::uint32_t>(n),
      exec.template allocate<std::uint8_t>(n), exec.template allocate<std::uint8_t>(pairs.count),
      exec.template allocate<std::uint32_t>(n)};
  std::uint32_t *child_base = plan.child_base.data(), *leaf_index = plan.leaf_index.data();
  std::uint8_t *split = plan.split.data(), *pair_masks = plan.pair_masks.data();
  std::uint32_t* folded = plan.folded.data();
  // Until the scans, child_base holds each node's references and leaf_index the references its
  // children would get.
  exec.for_each("level clear", n, [=] IRGRID_HD(std::size_t i) {
    child_base[i] = 0;
    leaf_index[i] = 0;
    folded[i] = kMasksFolded;
  });
  const std::uint32_t *pair_node = pairs.cell.data(), *pair_tri = pairs.tri.data();
  exec.for_each("level count", pairs.count,
                [=] IRGRID_HD(std::size_t i) { atomic_add(&child_base[pair_node[i]], 1u); });
  const std::uint32_t* top = nodes.top.data();
  const Voxel* lo = nodes.lo.data();
  const OctreeRule r = rule;
  bool passes_budget = false;
  if (level < info.shift) {  // nodes of the deepest level never split
    const std::int32_t half = std::int32_t(1) << (info.shift - level - 1);
    const auto plus = [] IRGRID_HD(std::uint64_t a, std::uint64_t b) { return a + b; };
    // Nodes that split whatever their masks give a lower bound of the level's octrees as the
    // masks come in: their count, and the references of their children so far. Once that
    // passes the budget, the level would stop there anyway (octree_fits_budget grows with
    // every count), so the rest of its exact tests are skipped: on builtin:overlap:30000 the
    // level the budget stops took half the build.
    const std::uint64_t sure_splits = exec.transform_reduce(
        "level sure splits", n, std::uint64_t(0), plus, [=] IRGRID_HD(std::size_t i) {
          return std::uint64_t(r.splits_surely(level, r.depths[top[i]], child_base[i]));
        });
    std::uint64_t sure_child_refs = 0;
    const std::size_t chunk = std::max<std::size_t>(pairs.count / 16 + 1, std::size_t(1) << 12);
    for (std::size_t begin = 0; begin < pairs.count && !passes_budget; begin += chunk) {
      const std::size_t count = std::min<std::size_t>(chunk, pairs.count - begin);
      if constexpr (Exec::kOctreeMasksInLanes) {
        // The host: the masks of a body's candidate pairs in SIMD lanes, one pair (with its
        // own node) per lane (level_child_masks).
        constexpr std::size_t kPairsPerBody = 1024;
        const std::uint64_t num_nodes = n, num_pairs = pairs.count;
        exec.for_each("level child counts", (count + kPairsPerBody - 1) / kPairsPerBody,
                      [=](std::size_t b) {
                        const std::size_t first = begin + b * kPairsPerBody,
                                          last = std::min(first + kPairsPerBody, begin + count);
                        std::uint32_t picked[kPairsPerBody] = {};
                        std::uint32_t picks = 0;
                        for (std::size_t i = first; i < last; ++i) {
                          const std::uint32_t node = pair_node[i];
                          if (r.candidate(level, r.depths[top[node]], child_base[node]))
                            picked[picks++] = std::uint32_t(i);
                        }
                        Exec::level_child_masks(info, half, triangles, lo, num_nodes, pair_node,
                                                pair_tri, num_pairs, picked, picks, pair_masks);
                        for (std::uint32_t k = 0; k < picks; ++k) {
                          const std::uint32_t i = picked[k], node = pair_node[i];
                          atomic_add(&leaf_index[node], popcount8(pair_masks[i]));
                          atomic_and(&folded[node], fold_mask(pair_masks[i]));
                        }
                      });
      } else
        exec.for_each("level child counts", count, [=] IRGRID_HD(std::size_t k) {
          const std::size_t i = begin + k;
          const std::uint32_t node = pair_node[i];
          if (!r.candidate(level, r.depths[top[node]], child_base[node])) return;
          const std::uint32_t mask =
              child_overlap_mask(info, lo[node], half, triangles[pair_tri[i]]);
          pair_masks[i] = std::uint8_t(mask);
          atomic_add(&leaf_index[node], popcount8(mask));
          atomic_and(&folded[node], fold_mask(mask));
        });
      if (sure_splits == 0 || !r.stop_tests_at_budget) continue;
      sure_child_refs += exec.transform_reduce(
          "level sure child refs", count, std::uint64_t(0), plus, [=] IRGRID_HD(std::size_t k) {
            const std::uint32_t node = pair_node[begin + k];
            return r.splits_surely(level, r.depths[top[node]], child_base[node])
                       ? std::uint64_t(popcount8(pair_masks[begin + k]))
                       : std::uint64_t(0);
          });
      passes_budget =
          !octree_fits_budget(budget, std::uint64_t(built.num_entries) + n + 8 * sure_splits,
                              std::uint64_t(built.num_cells) + n + 7 * sure_splits,
                              std::uint64_t(built.num_refs) + sure_child_refs);
    }
  }
  if (!passes_budget) {
    exec.for_each("level split", n, [=] IRGRID_HD(std::size_t i) {
      const std::uint32_t refs = child_base[i];
      split[i] =
          r.candidate(level, r.depths[top[i]], refs)
              ? r.decide(level, r.depths[top[i]], refs, leaf_index[i], masks_differ(folded[i]))
              : kNoSplit;
    });
    const std::uint64_t splits = sum_where_split(exec, "level splits", split, nullptr, n);
    if (splits > 0) {
      const std::uint64_t split_refs =
          sum_where_split(exec, "level split refs", split, child_base, n);
      const std::uint64_t child_refs =
          sum_where_split(exec, "level child refs", split, leaf_index, n);
      passes_budget = !octree_fits_budget(
          budget, std::uint64_t(built.num_entries) + n + 8 * splits,
          std::uint64_t(built.num_cells) + (n - splits) + 8 * splits,
          std::uint64_t(built.num_refs) + (pairs.count - split_refs) + child_refs);
    }
  }
  release_buffer(plan.folded);
  if (passes_budget) {
    plan.budget_stop = true;
    exec.for_each("level budget stop", n, [=] IRGRID_HD(std::size_t i) { split[i] = kNoSplit; });
  }
  exec.for_each("level offsets", n, [=] IRGRID_HD(std::size_t i) {
    const bool splits = split[i] != kNoSplit;
    child_base[i] = splits ? 8 : 0;
    leaf_index[i] = splits ? 0 : 1;
  });
  plan.children = exec.exclusive_scan("level children", child_base, child_base, n);
  plan.leaves = exec.exclusive_scan("level leaves", leaf_index, leaf_index, n);
  return plan;
}

/// Writes this level's voxel-map entries and, with `with_cells`, its leaf cells into `out`.
template <typename Exec>
void emit_level_entries_and_cells(Exec& exec, const GridInfo& info, const LevelNodes<Exec>& nodes,
                                  const LevelPlan<Exec>& plan, std::int32_t level, bool with_cells,
                                  OctreeLevels<Exec>& out) {
  auto entries = exec.template allocate<Entry>(nodes.count);
  auto cells = exec.template allocate<Cell>(with_cells ? plan.leaves : 0);
  Entry* d_entries = entries.data();
  Cell* d_cells = cells.data();
  const std::uint32_t *child_base = plan.child_base.data(), *leaf_index = plan.leaf_index.data();
  const std::uint8_t* split = plan.split.data();
  const Voxel* lo = nodes.lo.data();
  const std::uint32_t next_level = out.num_entries + nodes.count, first_cell = out.num_cells;
  const std::int32_t size = std::int32_t(1) << (info.shift - level);
  exec.for_each("level entries", nodes.count, [=] IRGRID_HD(std::size_t i) {
    if (split[i]) {
      d_entries[i] = Entry::inner(1, next_level + child_base[i]);
      return;
    }
    d_entries[i] = Entry::leaf(first_cell + leaf_index[i]);
    if (!with_cells) return;
    const Voxel v = lo[i];
    d_cells[leaf_index[i]] = {{v.x, v.y, v.z}, 0, {v.x + size, v.y + size, v.z + size}, 0};
  });
  out.num_entries += nodes.count;
  out.num_cells += plan.leaves;
  out.entries.push_back(std::move(entries));
  if (with_cells) out.cells.push_back(std::move(cells));
}

/// Moves the pairs of nodes that stay leaves to `out`, as (cell, triangle).
template <typename Exec>
void keep_leaf_pairs(Exec& exec, const RefPairs<Exec>& pairs, const LevelPlan<Exec>& plan,
                     std::uint32_t first_cell, OctreeLevels<Exec>& out) {
  const std::uint32_t *node = pairs.cell.data(), *tri = pairs.tri.data();
  const std::uint8_t* split = plan.split.data();
  std::uint32_t kept = 0;
  const auto picked = select_indices(
      exec, "keep leaf pairs", pairs.count,
      [=] IRGRID_HD(std::uint32_t i) { return !split[node[i]]; }, kept);
  RefPairs<Exec> leaf_pairs{exec.template allocate<std::uint32_t>(kept),
                            exec.template allocate<std::uint32_t>(kept), kept};
  std::uint32_t *cell_out = leaf_pairs.cell.data(), *tri_out = leaf_pairs.tri.data();
  const std::uint32_t *leaf_index = plan.leaf_index.data(), *d_picked = picked.data();
  exec.for_each("keep leaf pairs", kept, [=] IRGRID_HD(std::size_t k) {
    const std::uint32_t i = d_picked[k];
    cell_out[k] = first_cell + leaf_index[node[i]];
    tri_out[k] = tri[i];
  });
  out.num_refs += kept;
  out.pairs.push_back(std::move(leaf_pairs));
}

/// keep_leaf_pairs of a level where no node splits (the last): every pair is kept, in place.
/// The deepest level holds the most pairs (the budget-limited 10M-triangle hairball: 110
/// million), which a selection would hold three times.
template <typename Exec>
void keep_all_pairs(Exec& exec, RefPairs<Exec>& pairs, const LevelPlan<Exec>& plan,
                    std::uint32_t first_cell, OctreeLevels<Exec>& out) {
  std::uint32_t* node = pairs.cell.data();
  const std::uint32_t* leaf_index = plan.leaf_index.data();
  exec.for_each("keep leaf pairs", pairs.count,
                [=] IRGRID_HD(std::size_t i) { node[i] = first_cell + leaf_index[node[i]]; });
  out.num_refs += pairs.count;
  out.pairs.push_back(std::move(pairs));
}

/// The children of the split nodes, and their (child, triangle) pairs (the plan's masks).
/// Consumes the nodes and the pairs.
template <typename Exec>
std::pair<LevelNodes<Exec>, RefPairs<Exec>> split_level(Exec& exec, const GridInfo& info,
                                                        LevelNodes<Exec>& nodes,
                                                        RefPairs<Exec>& pairs,
                                                        const LevelPlan<Exec>& plan,
                                                        std::int32_t level) {
  // Each pair's first child pair, over all pairs (0 children for a leaf's): a selection of
  // the split nodes' pairs and their offsets took more (the 10M hairball's split of level 2).
  const std::uint32_t *node = pairs.cell.data(), *tri = pairs.tri.data();
  const std::uint32_t* child_base = plan.child_base.data();
  const std::uint8_t* split = plan.split.data();
  const std::uint8_t* pair_masks = plan.pair_masks.data();
  auto offsets = exec.template allocate<std::uint32_t>(pairs.count);
  std::uint32_t* d_offsets = offsets.data();
  exec.for_each("split offsets", pairs.count, [=] IRGRID_HD(std::size_t i) {
    d_offsets[i] = split[node[i]] != 0 ? popcount8(pair_masks[i]) : 0;
  });
  // The plan checked the total against the budget, whose bound includes the 30-bit limit.
  const std::uint32_t total =
      exec.exclusive_scan("split offsets", d_offsets, d_offsets, pairs.count);
  RefPairs<Exec> child_pairs{exec.template allocate<std::uint32_t>(total),
                             exec.template allocate<std::uint32_t>(total), total};
  std::uint32_t *cell_out = child_pairs.cell.data(), *tri_out = child_pairs.tri.data();
  exec.for_each("split emit", pairs.count, [=] IRGRID_HD(std::size_t i) {
    if (split[node[i]] == 0) return;
    const std::uint32_t mask = pair_masks[i];
    std::uint32_t out = d_offsets[i];
    for (std::uint32_t bit = 0; bit < 8; ++bit)
      if (mask >> bit & 1) cell_out[out] = child_base[node[i]] + bit, tri_out[out++] = tri[i];
  });
  release_buffer(offsets);
  pairs = {};
  // The children after their pairs: the nodes are fewer than the children, and the pairs
  // are gone before the children are made.
  const std::int32_t half = std::int32_t(1) << (info.shift - level - 1);
  LevelNodes<Exec> children{exec.template allocate<Voxel>(plan.children),
                            exec.template allocate<std::uint32_t>(plan.children), plan.children};
  Voxel* child_lo = children.lo.data();
  std::uint32_t* child_top = children.top.data();
  const Voxel* lo = nodes.lo.data();
  const std::uint32_t* top = nodes.top.data();
  exec.for_each("child nodes", nodes.count, [=] IRGRID_HD(std::size_t i) {
    if (!split[i]) return;
    for (std::uint32_t bit = 0; bit < 8; ++bit) {
      child_lo[child_base[i] + bit] = child_corner(lo[i], half, bit);
      child_top[child_base[i] + bit] = top[i];
    }
  });
  release_buffer(nodes.lo);
  release_buffer(nodes.top);
  return {std::move(children), std::move(child_pairs)};
}

/// Runs the octree subdivision from the top level down, at most to depth info.shift, and stops
/// at the last level whose octrees fit `budget` (construction_budget). Without `with_cells`,
/// the leaves are counted and named but not written as cells.
template <typename Exec>
OctreeLevels<Exec> build_octree_levels(Exec& exec, const GridInfo& info,
                                       const TriangleVertices* triangles, RefPairs<Exec> pairs,
                                       const OctreeRule& rule, std::uint64_t budget,
                                       bool with_cells = true) {
  OctreeLevels<Exec> out;
  LevelNodes<Exec> nodes = top_level_nodes(exec, info);
  for (std::int32_t level = 0;; ++level) {
    LevelPlan<Exec> plan =
        plan_level(exec, info, triangles, nodes, pairs, rule, level, out, budget);
    out.budget_limited |= plan.budget_stop;
    const std::uint32_t first_cell = out.num_cells;
    emit_level_entries_and_cells(exec, info, nodes, plan, level, with_cells, out);
    if (plan.children == 0) {
      nodes = {};
      keep_all_pairs(exec, pairs, plan, first_cell, out);
      break;
    }
    keep_leaf_pairs(exec, pairs, plan, first_cell, out);
    release_buffer(plan.leaf_index);
    auto next = split_level(exec, info, nodes, pairs, plan, level);
    nodes = std::move(next.first);
    pairs = std::move(next.second);
  }
  return out;
}

}  // namespace irgrid
