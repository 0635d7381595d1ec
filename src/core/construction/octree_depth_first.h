// core/construction/octree_depth_first.h: the initial grid's octrees and cells, one top cell at a
// time.
//
// Pérard-Gayot et al. 2017, §3.1, built in another order: the same grid as build_octree_levels
// followed by assemble_grid (octree_levels.h, cells.h), bit for bit, for executors that set
// kDepthFirstOctrees (the CPU). The level-by-level build suits a GPU: every level is a few wide
// passes. On a CPU those passes stream (node, triangle) pairs through memory level
// after level, then sort them twice (cells into Morton order, references by cell). Here each top
// cell's octree is built depth-first while its few triangles sit in cache, and the parts come
// out already in their final order, so neither sort is needed:
//   * a top cell's triangles ascend (the top-level pairs are sorted by cell, stably) and a split
//     keeps their order in every child, so each list comes out sorted and unique;
//   * the Morton key of a corner interleaves the top cell's coordinates above the bits inside the
//     top cell, and children are visited in Morton order (bit 0 x, bit 1 y, bit 2 z), so the
//     leaves come out in the Morton order of cell_order.h once the top cells are taken in the
//     Morton order of their own corners (valid while corners fit the key: depth_first_applies);
//   * a depth-first walk meets the nodes of one level in the order a breadth-first one lists
//     them, so a split node reserving its block of 8 children at the next level when it is met
//     lays every level out as build_octree_levels does.
// The top cells are cut into chunks, each building into its own growing buffers; a second pass
// copies every chunk to its place and turns its local indices into global ones.
#pragma once

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/construction/cells.h"
#include "core/construction/octree_walk.h"
#include "core/release_buffer.h"

namespace irgrid {

/// What one chunk of consecutive top cells (x-fastest order) built, with local indices: an inner
/// entry at level L names a slot of the chunk's level L + 1, a leaf entry a cell counted from its
/// own top cell's first, and a cell's first reference counts from its top cell's first. Slot k of
/// level 0 is the root of the chunk's k-th top cell. A cell is held as its first reference
/// alone: its box follows from its leaf's place in the octree, its last reference from the next
/// cell's first (or its top cell's count), so the chunks, which the copy holds beside the grid's
/// arrays, take 4 bytes per cell.
template <typename Exec>
struct ChunkOctrees {
  std::vector<typename Exec::template Buffer<Entry>> levels;  ///< entries of each octree level
  typename Exec::template Buffer<std::uint32_t> cell_begins;  ///< each cell's first reference
  typename Exec::template Buffer<std::uint32_t> refs;
};

/// The octrees of all top cells, chunk by chunk, and the per-top-cell totals the copy needs
/// (executor buffers, so that the build's memory peak counts them).
template <typename Exec>
struct TopCellOctrees {
  std::vector<ChunkOctrees<Exec>> chunks;
  typename Exec::template Buffer<std::uint32_t> cells_per_top, refs_per_top;
  std::uint32_t top_cells = 0, levels_per_top = 0, top_cells_per_chunk = 0;
};

namespace depth_first_detail {

/// Entries, cells and references all top cells have built so far, for the budget: a runaway
/// octree (a huge lambda2, overlapping triangles) stops as soon as the totals pass `budget`
/// (octree_fits_budget), long before it would outgrow the machine.
struct RunningTotals {
  std::atomic<std::uint64_t> entries{0}, cells{0}, refs{0};
  /// Top-level pairs of the top cells built so far; `pairs`, those of all (0: no projection).
  std::atomic<std::uint64_t> pairs_done{0};
  std::uint64_t pairs = 0;
  std::uint64_t budget = 0;
};

/// The share of the pairs (1 / kProjectAfter) whose octrees are built before the totals are
/// projected onto all pairs. builtin:hairball:10000000 passes its budget late: waiting for the
/// totals to pass it made its octree phase take 60 s, against 41 s with the projection.
inline constexpr std::uint64_t kProjectAfter = 8;

/// Whether octrees taking `bytes` (octree_peak_bytes) for the first `done` of `pairs` pairs
/// project past `budget` once all are built, at the same bytes per pair; false before
/// 1 / kProjectAfter of the pairs are done.
inline bool projection_passes_budget(std::uint64_t bytes, std::uint64_t done, std::uint64_t pairs,
                                     std::uint64_t budget) {
  return budget != 0 && pairs != 0 && done * kProjectAfter >= pairs &&
         double(bytes) * double(pairs) > double(budget) * double(done);
}

/// Thrown by the builders when the running totals pass the budget (the totals only grow, so
/// the complete octrees would not fit), or when they project past it
/// (projection_passes_budget: they would most likely not fit, and a wrong guess costs time
/// only); build_initial_grid then builds level by level, which stops at the last level that
/// fits. `bytes`: octree_peak_bytes of the totals at the throw.
struct BudgetExceeded {
  std::uint64_t bytes = 0;
};

/// Builds the octree of one top cell into a chunk (the subdivision rule of plan_level).
template <typename Exec>
class TopCellBuilder {
 public:
  TopCellBuilder(const GridInfo& info, const TriangleVertices* triangles, const OctreeRule& rule,
                 ChunkOctrees<Exec>& chunk, RunningTotals& totals)
      : info_(info), triangles_(triangles), rule_(rule), chunk_(chunk), totals_(totals) {}

  /// Builds a top cell (lower voxel `lo`, octree depth `depth`) over its ascending triangles,
  /// its level-0 entry going to slot `slot` of the chunk's level 0.
  void build(Voxel lo, std::int32_t depth, const std::uint32_t* tris, std::uint32_t count,
             std::uint32_t slot) {
    top_depth_ = depth;
    first_cell_ = std::uint32_t(chunk_.cell_begins.size());
    first_ref_ = std::uint32_t(chunk_.refs.size());
    reserve_lists(count);
    std::copy(tris, tris + count, lists_.data());
    lists_top_ = count;
    node(0, lo, 0, count, slot);
    totals_.pairs_done += count;
    flush_totals();
  }

 private:
  void node(std::int32_t level, Voxel lo, std::size_t list_begin, std::uint32_t count,
            std::uint32_t slot) {
    bool split = rule_.splits_by_depth(level, top_depth_, count);
    const std::size_t mask_begin = masks_top_;
    // Children's size; nodes of the deepest level never split.
    const std::int32_t half =
        level < info_.shift ? std::int32_t(1) << (info_.shift - level - 1) : 0;
    if (split || rule_.count_candidate(level, count)) {
      const NodeSplit split_node = node_split(info_, lo, half);
      if (masks_.size() < mask_begin + count) masks_.resize(2 * (mask_begin + count));
      masks_top_ = mask_begin + count;
      std::uint8_t* masks = masks_.data() + mask_begin;
      Exec::child_overlap_masks(split_node, triangles_, info_.num_triangles,
                                lists_.data() + list_begin, count, masks);
      std::uint64_t child_refs = 0;
      std::uint32_t folded = kMasksFolded;
      for (std::uint32_t k = 0; k < count; ++k) {
        child_refs += popcount8(masks[k]);
        folded &= fold_mask(masks[k]);
      }
      split = rule_.decide(level, top_depth_, count, child_refs, masks_differ(folded)) != kNoSplit;
    }
    auto& entries = chunk_.levels[std::size_t(level)];
    if (!split) {
      masks_top_ = mask_begin;
      entries[slot] = Entry::leaf(std::uint32_t(chunk_.cell_begins.size()) - first_cell_);
      chunk_.cell_begins.push_back(std::uint32_t(chunk_.refs.size()) - first_ref_);
      chunk_.refs.insert(chunk_.refs.end(), lists_.data() + list_begin,
                         lists_.data() + list_begin + count);
      pending_refs_ += count;
      ++pending_cells_;
      return;
    }
    auto& children = chunk_.levels[std::size_t(level) + 1];
    const auto base = std::uint32_t(children.size());
    children.resize(base + 8);
    entries[slot] = Entry::inner(1, base);
    pending_entries_ += 8;
    if (pending_entries_ >= kFlushEvery || pending_refs_ >= kFlushEvery) flush_totals();
    for (std::uint32_t bit = 0; bit < 8; ++bit) {
      // Branch-free: every triangle is written, and the end moves on for those in the child.
      const std::size_t child_begin = lists_top_;
      reserve_lists(child_begin + count);
      std::uint32_t* out = lists_.data() + child_begin;
      const std::uint32_t* in = lists_.data() + list_begin;
      const std::uint8_t* masks = masks_.data() + mask_begin;
      std::uint32_t kept = 0;
      for (std::uint32_t k = 0; k < count; ++k) {
        out[kept] = in[k];
        kept += masks[k] >> bit & 1;
      }
      lists_top_ = child_begin + kept;
      node(level + 1, child_corner(lo, half, bit), child_begin, kept, base + bit);
      lists_top_ = child_begin;
    }
    masks_top_ = mask_begin;
  }

  /// Room for `size` entries of the list stack (its contents kept; the vector may move).
  void reserve_lists(std::size_t size) {
    if (lists_.size() < size) lists_.resize(2 * size);
  }

  /// Adds what this builder made since the last call to the shared totals and checks them
  /// against the budget, as the level-by-level build does.
  void flush_totals() {
    const std::uint64_t entries = totals_.entries += pending_entries_;
    const std::uint64_t cells = totals_.cells += pending_cells_;
    const std::uint64_t refs = totals_.refs += pending_refs_;
    pending_entries_ = pending_cells_ = pending_refs_ = 0;
    const std::uint64_t bytes = octree_peak_bytes(entries, cells, refs);
    if (!octree_fits_budget(totals_.budget, entries, cells, refs) ||
        projection_passes_budget(bytes, totals_.pairs_done, totals_.pairs, totals_.budget))
      throw BudgetExceeded{bytes};
  }

  static constexpr std::uint64_t kFlushEvery = 4096;
  const GridInfo& info_;
  const TriangleVertices* triangles_;
  const OctreeRule& rule_;
  ChunkOctrees<Exec>& chunk_;
  RunningTotals& totals_;
  std::int32_t top_depth_ = 0;
  std::uint32_t first_cell_ = 0, first_ref_ = 0;
  std::uint64_t pending_entries_ = 0, pending_cells_ = 0, pending_refs_ = 0;
  /// The triangle lists of the nodes on the current path, each after its parent's, and their
  /// children masks: stacks with their tops, so a node's list is found by its offset (the
  /// vectors may move; they only grow).
  std::vector<std::uint32_t> lists_;
  std::vector<std::uint8_t> masks_;
  std::size_t lists_top_ = 0, masks_top_ = 0;
};

}  // namespace depth_first_detail

namespace depth_first_detail {

/// Whether a pilot predicts that the complete octrees pass `budget`. It builds the octrees of a
/// sample of top cells (those holding the pairs at kPilotSamples evenly spaced ranks of the
/// sorted pairs: a cell is picked in proportion to its references), each stopped once it takes
/// kPilotSlack times its share of the budget (its share of the pairs) or 1/1024 of the budget,
/// and projects their bytes per pair onto all pairs. Cells holding more than 4096 pairs are left
/// out of the sample, and the pilot runs only where the octrees would pass the budget if they
/// held 16 times the top level. On geometry whose octrees would pass the
/// budget many times over (large overlapping triangles) the depth-first build would otherwise
/// run until its totals pass the budget, and the level-by-level build then repeat that work; the
/// pilot's work stays within 1/16 of the budget's. A wrong prediction costs time only: both
/// builds give the same grid.
template <typename Exec>
bool pilot_predicts_budget_exceeded(Exec& exec, const GridInfo& info,
                                    const TriangleVertices* triangles, const OctreeRule& rule,
                                    const std::uint32_t* sorted_cells, const std::uint32_t* tri,
                                    const std::uint32_t* first_tri,
                                    const std::uint32_t* refs_per_top, std::uint32_t pairs,
                                    std::uint64_t budget) {
  constexpr std::uint32_t kPilotSamples = 64;
  constexpr std::uint64_t kPilotSlack = 4, kPilotCellBudgetShare = 1024;
  // A node's work is a test per triangle whatever it outputs: fuller cells are left out, so
  // that the budget bounds the pilot's work too (a stack of copies fills a few cells only).
  constexpr std::uint32_t kPilotMaxCellRefs = 4096;
  // Real scenes' octrees hold a few times the top-level pairs (Sponza: 5 times, in a seventh of
  // its budget): the pilot runs only where 16 times the top level would pass the budget.
  const std::uint32_t top_cells = std::uint32_t(info.top_dims[0]) *
                                  std::uint32_t(info.top_dims[1]) * std::uint32_t(info.top_dims[2]);
  if (budget == 0 || pairs < 64 * kPilotSamples ||
      16 * octree_peak_bytes(top_cells, top_cells, pairs) <= budget)
    return false;
  // Weighted as picked: a cell met at several ranks counts as often.
  std::vector<std::uint32_t> sample, weight;
  std::uint32_t picked = 0;
  for (std::uint32_t k = 0; k < kPilotSamples; ++k) {
    const std::uint32_t cell = sorted_cells[std::uint64_t(2 * k + 1) * pairs / (2 * kPilotSamples)];
    if (refs_per_top[cell] > kPilotMaxCellRefs) continue;
    ++picked;
    if (!sample.empty() && sample.back() == cell) {
      ++weight.back();
    } else {
      sample.push_back(cell);
      weight.push_back(1);
    }
  }
  if (picked == 0) return false;
  std::vector<double> bytes_per_pair(sample.size());
  const std::uint32_t levels = std::uint32_t(info.shift) + 1;
  exec.for_each("octree pilot", sample.size(), [&](std::size_t k) {
    const std::uint32_t t = sample[k], count = refs_per_top[t];
    ChunkOctrees<Exec> chunk;
    chunk.levels.assign(levels, exec.template allocate<Entry>(0));
    chunk.levels[0].resize(1);
    chunk.cell_begins = exec.template allocate<std::uint32_t>(0);
    chunk.refs = exec.template allocate<std::uint32_t>(0);
    RunningTotals totals;
    totals.budget = std::min(kPilotSlack * std::uint64_t(double(budget) * count / pairs),
                             budget / kPilotCellBudgetShare);
    totals.entries = 1;
    TopCellBuilder<Exec> builder(info, triangles, rule, chunk, totals);
    try {
      builder.build(top_cell_corner(info, t), rule.depths[t], tri + first_tri[t], count, 0);
    } catch (const BudgetExceeded&) {  // the totals then hold what it built up to the stop
    }
    bytes_per_pair[k] =
        double(octree_peak_bytes(totals.entries, totals.cells, totals.refs)) / double(count);
  });
  double mean = 0;
  for (std::size_t k = 0; k < sample.size(); ++k)
    mean += weight[k] * bytes_per_pair[k];
  mean /= picked;
  return mean * pairs > double(budget);
}

}  // namespace depth_first_detail

/// Builds the octree of every top cell (pass 1 of 2). `pairs` are the top-level (top cell,
/// triangle) pairs, sorted here by top cell (stably: each cell's triangles ascend) and left valid
/// for build_octree_levels, `refs_per_top` their count per top cell. Requires an executor whose
/// buffers grow on the host (kDepthFirstOctrees) and depth_first_applies(info). Throws
/// BudgetExceeded when the octrees would not fit `budget` (construction_budget), or once an
/// eighth of the pairs projects them past it (projection_passes_budget).
template <typename Exec>
TopCellOctrees<Exec> build_top_cell_octrees(Exec& exec, const GridInfo& info,
                                            const TriangleVertices* triangles,
                                            RefPairs<Exec>& pairs,
                                            const std::uint32_t* refs_per_top,
                                            const OctreeRule& rule, std::uint64_t budget) {
  TopCellOctrees<Exec> out;
  out.top_cells = std::uint32_t(info.top_dims[0]) * std::uint32_t(info.top_dims[1]) *
                  std::uint32_t(info.top_dims[2]);
  out.levels_per_top = std::uint32_t(info.shift) + 1;
  out.top_cells_per_chunk = 64;
  const std::uint32_t n = out.top_cells, per_chunk = out.top_cells_per_chunk;
  // Each top cell's triangles, ascending: the pairs come triangle-major and the sort is stable.
  exec.sort_pairs("octree top-cell lists", pairs.cell.data(), pairs.tri.data(), pairs.count,
                  std::max(1, int(std::bit_width(n))));
  auto first_tri = exec.template allocate<std::uint32_t>(n);
  exec.exclusive_scan("octree top-cell lists", refs_per_top, first_tri.data(), n);
  out.chunks.resize((n + per_chunk - 1) / per_chunk);
  out.cells_per_top = exec.template allocate<std::uint32_t>(n);
  out.refs_per_top = exec.template allocate<std::uint32_t>(n);
  if (depth_first_detail::pilot_predicts_budget_exceeded(
          exec, info, triangles, rule, pairs.cell.data(), pairs.tri.data(), first_tri.data(),
          refs_per_top, pairs.count, budget))
    throw depth_first_detail::BudgetExceeded{};
  depth_first_detail::RunningTotals totals;
  totals.budget = budget;
  totals.pairs = pairs.count;
  totals.entries = n;  // the top level's entries, counted as the level-by-level build does
  ChunkOctrees<Exec>* chunks = out.chunks.data();
  std::uint32_t *cells_per_top = out.cells_per_top.data(), *refs_out = out.refs_per_top.data();
  const std::uint32_t levels = out.levels_per_top;
  const std::uint32_t *tri = pairs.tri.data(), *first = first_tri.data();
  exec.for_each("octree top cells", out.chunks.size(), [&, chunks](std::size_t c) {
    ChunkOctrees<Exec>& chunk = chunks[c];
    const auto top_begin = std::uint32_t(c) * per_chunk;
    const std::uint32_t top_end = std::min(n, top_begin + per_chunk);
    // Grown from the executor's buffers, so that a rebuild takes them from its pool.
    chunk.levels.assign(levels, exec.template allocate<Entry>(0));
    chunk.levels[0].resize(top_end - top_begin);
    chunk.cell_begins = exec.template allocate<std::uint32_t>(0);
    chunk.refs = exec.template allocate<std::uint32_t>(0);
    depth_first_detail::TopCellBuilder<Exec> builder(info, triangles, rule, chunk, totals);
    for (std::uint32_t t = top_begin; t < top_end; ++t) {
      const auto cells_before = std::uint32_t(chunk.cell_begins.size());
      const auto refs_before = std::uint32_t(chunk.refs.size());
      builder.build(top_cell_corner(info, t), rule.depths[t], tri + first[t], refs_per_top[t],
                    t - top_begin);
      cells_per_top[t] = std::uint32_t(chunk.cell_begins.size()) - cells_before;
      refs_out[t] = std::uint32_t(chunk.refs.size()) - refs_before;
    }
    // Grown by doubling, the buffers would hold up to twice what they use until they are
    // copied, beside the grid's arrays (Crown: 108 MiB, the octrees' share of the build's peak).
    // The copy is of a chunk still in cache.
    chunk.cell_begins.shrink_to_fit();
    chunk.refs.shrink_to_fit();
    for (auto& level : chunk.levels)
      level.shrink_to_fit();
  });
  return out;
}

/// Copies the chunks into the grid's arrays (pass 2 of 2): the octree-form voxel map with its
/// level offsets, the cells in Morton order with their ranges (in grid.narrow_cells where the
/// virtual grid fits them and `allow_narrow`, see narrow_cell.h; else in grid.cells), the
/// references. Consumes them.
template <typename Exec>
void assemble_top_cell_octrees(Exec& exec, TopCellOctrees<Exec>& octrees, GridArrays<Exec>& grid,
                               bool allow_narrow = true) {
  const GridInfo& info = grid.info;
  const std::uint32_t n = octrees.top_cells, levels = octrees.levels_per_top;
  const auto chunk_count = std::uint32_t(octrees.chunks.size());
  // Each level's entries: chunk after chunk (the top cells' x-fastest order).
  std::vector<std::uint64_t> chunk_level_base(std::size_t(chunk_count) * levels);
  std::vector<std::uint64_t> level_offsets(levels + 1, 0);
  for (std::uint32_t l = 0; l < levels; ++l) {
    std::uint64_t sum = 0;
    for (std::uint32_t c = 0; c < chunk_count; ++c) {
      chunk_level_base[std::size_t(c) * levels + l] = sum;
      sum += octrees.chunks[c].levels[l].size();
    }
    level_offsets[l + 1] = level_offsets[l] + sum;
  }
  const std::uint64_t num_entries = level_offsets[levels];
  check_entry_count(num_entries);
  // Cells and references: top cell after top cell in the Morton order of their corners.
  auto order = top_cells_in_morton_order(exec, info);
  auto cell_base = exec.template allocate<std::uint32_t>(n);
  auto ref_base = exec.template allocate<std::uint32_t>(n);
  auto ranked = exec.template allocate<std::uint32_t>(n);
  // The builders checked the running totals; cells are fewer than entries.
  const auto num_cells = std::uint32_t(bases_in_order(
      exec, order.data(), octrees.cells_per_top.data(), ranked.data(), cell_base.data(), n));
  const std::uint64_t all_refs = bases_in_order(exec, order.data(), octrees.refs_per_top.data(),
                                                ranked.data(), ref_base.data(), n);
  check_reference_count(all_refs, "octree references");
  const auto num_refs = std::uint32_t(all_refs);
  // The bases hold the order now; its scratch goes before the copy makes the build's peak.
  release_buffer(order);
  release_buffer(ranked);
  ChunkOctrees<Exec>* chunks = octrees.chunks.data();
  const std::uint32_t per_chunk = octrees.top_cells_per_chunk;
  const std::uint32_t *d_cell_base = cell_base.data(), *d_ref_base = ref_base.data();
  const std::uint32_t* cells_per_top = octrees.cells_per_top.data();
  const std::uint32_t* refs_per_top = octrees.refs_per_top.data();
  // Calls visit(t, l, slot, entry, lo) for every entry of chunk c, top cell after top cell,
  // each top cell's octree depth first from its root (walk_octree): `slot` is the entry's index
  // in the grid's entries (level l's offset, the chunk's base there, and its place in the
  // chunk's level), `lo` its node's lower voxel.
  const auto for_each_entry = [&](std::size_t c, const auto& visit) {
    const ChunkOctrees<Exec>& chunk = chunks[c];
    const auto top_begin = std::uint32_t(c) * per_chunk;
    const std::uint32_t top_end = std::min(n, top_begin + per_chunk);
    const std::uint64_t* chunk_base = chunk_level_base.data() + c * levels;
    for (std::uint32_t t = top_begin; t < top_end; ++t)
      walk_octree(
          info, t, t - top_begin,
          [&](std::uint32_t l, std::uint64_t i) { return chunk.levels[l][i]; },
          [&](std::uint32_t l, std::uint64_t i, Entry e, Voxel lo) {
            visit(t, l, level_offsets[l] + chunk_base[l] + i, e, lo);
          });
  };
  // Three passes, each freeing the chunks' part it copied before the next array is made, so
  // that the chunks and the grid's arrays are never all held at once (the build's peak on
  // Sponza was here, before merging's): references, then cells (which read the levels for
  // their sizes), then the entries.
  grid.refs = exec.template allocate<std::uint32_t>(num_refs);
  std::uint32_t* refs = grid.refs.data();
  exec.for_each("octree copy", chunk_count, [&, chunks](std::size_t c) {
    ChunkOctrees<Exec>& chunk = chunks[c];
    const auto top_begin = std::uint32_t(c) * per_chunk;
    const std::uint32_t top_end = std::min(n, top_begin + per_chunk);
    std::uint32_t ref_at = 0, cell_at = 0;
    for (std::uint32_t t = top_begin; t < top_end; ++t) {
      std::copy(chunk.refs.begin() + ref_at, chunk.refs.begin() + (ref_at + refs_per_top[t]),
                refs + d_ref_base[t]);
      ref_at += refs_per_top[t];
      // The cells' first references become the grid's, so that the reference bases go before
      // the cells are made.
      for (std::uint32_t k = cell_at; k < cell_at + cells_per_top[t]; ++k)
        chunk.cell_begins[k] += d_ref_base[t];
      cell_at += cells_per_top[t];
    }
    release_buffer(chunk.refs);
  });
  release_buffer(ref_base);
  release_buffer(octrees.refs_per_top);
  // A top cell's cells are contiguous in the chunk and in the grid; a cell is written where its
  // leaf entry gives its level, hence its size. Narrow cells where the corners fit them.
  const auto copy_cells = [&](auto& buffer) {
    using CellT = std::remove_reference_t<decltype(buffer[0])>;
    buffer = exec.template allocate<CellT>(num_cells);
    CellT* cells = buffer.data();
    exec.for_each("octree copy", chunk_count, [&, chunks](std::size_t c) {
      ChunkOctrees<Exec>& chunk = chunks[c];
      std::uint32_t cell_at = 0, current = std::uint32_t(c) * per_chunk;
      for_each_entry(c, [&](std::uint32_t t, std::uint32_t l, std::uint64_t, Entry e, Voxel lo) {
        for (; current != t; ++current)
          cell_at += cells_per_top[current];
        if (e.log_dim() != 0) return;
        const std::int32_t corner[3] = {lo.x, lo.y, lo.z};
        set_cube(cells[d_cell_base[t] + e.index()], corner,
                 std::int32_t(1) << (info.shift - std::int32_t(l)),
                 chunk.cell_begins[cell_at + e.index()]);
      });
      release_buffer(chunk.cell_begins);
    });
    release_buffer(octrees.cells_per_top);
    // The lists follow the cells without gaps (the same Morton order of top cells, each top
    // cell's cells in its chunk's order).
    end_lists_at_successors(exec, "octree cell ends", cells, num_cells, num_refs);
  };
  if (allow_narrow && fits_compact_cells(info))
    copy_cells(grid.narrow_cells);
  else
    copy_cells(grid.cells);
  grid.entries = exec.template allocate<Entry>(num_entries);
  Entry* entries = grid.entries.data();
  exec.for_each("octree copy", chunk_count, [&, chunks](std::size_t c) {
    const std::uint64_t* chunk_base = chunk_level_base.data() + c * levels;
    for_each_entry(c, [&](std::uint32_t t, std::uint32_t l, std::uint64_t slot, Entry e, Voxel) {
      if (e.log_dim() != 0) {
        entries[slot] =
            Entry::inner(1, std::uint32_t(level_offsets[l + 1] + chunk_base[l + 1] + e.index()));
      } else {
        entries[slot] = Entry::leaf(d_cell_base[t] + e.index());
      }
    });
    chunks[c] = {};  // freed as soon as copied
  });
  grid.level_offsets.clear();
  for (std::uint32_t l = 0; l <= levels; ++l) {
    if (l > 0 && level_offsets[l] == level_offsets[l - 1]) break;  // no deeper nodes
    grid.level_offsets.push_back(std::uint32_t(level_offsets[l]));
  }
  grid.info.num_cells = num_cells;
  grid.info.num_refs = num_refs;
  grid.info.num_entries = std::uint32_t(num_entries);
}

}  // namespace irgrid
