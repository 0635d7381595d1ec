// core/construction/merge_pairs.h: which cells propose to merge in a sweep, and how chains pair up.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017, §3.2:
// two cells that touch along an axis and share their cross-section form a box; they merge when
// the surface area heuristic does not get worse. Sweeps run along x, then y, then z, and rounds
// of three sweeps repeat while a round removes enough cells (../shared/design/algorithm.md §4).
//
// One sweep merges disjoint pairs only. Proposals c -> next(c) form chains along the axis; the
// CPU walks each chain from its head, as the reference code does, the GPU resolves them by list
// ranking (pointer jumping, O(log length) passes); both give the same pairs:
//   * every cell learns the parity of its distance from the head of its chain;
//   * a cell at even distance that proposed merges with its successor, which is at odd distance;
//   * a cell at odd distance is absorbed by its predecessor and proposes nothing itself.
// This is the pairing of the serial walk (positions 0+1, 2+3, ...), so the result does not
// depend on the order in which threads run.
//
// Later rounds merge few cells, so most proposals would be recomputed from unchanged inputs. A
// cell's proposal along an axis depends only on the cell and on the owner of the voxel past its
// upper face, and it can only name a cell whose lower corner lies just past that face. So a
// cell that proposed nothing stays quiet along that axis until it is itself merged, or a new
// (merged) cell appears whose lower corner is the voxel next to it: the merge step wakes the
// owner of the voxel below each new cell's corner, per axis. Quiet cells skip the proposal.
#pragma once

#include <cmath>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/construction/cells.h"
#include "core/construction/merge_lists.h"
#include "core/construction/narrow_cell.h"
#include "irgrid/error.h"

namespace irgrid {

namespace merge_detail {

/// Marks "no cell" in the proposal, predecessor and ancestor arrays.
inline constexpr std::uint32_t kNoCell = 0xffffffffu;

/// Half the surface area, in world units, of the voxel box [lo, hi). The factor 2 cancels in the
/// cost comparison. Corners of either cell form (Cell, NarrowCell).
template <typename Coord>
IRGRID_HD inline float half_area(const GridInfo& info, const Coord* lo, const Coord* hi) {
  const float dx = float(hi[0] - lo[0]) * info.voxel_size[0];
  const float dy = float(hi[1] - lo[1]) * info.voxel_size[1];
  const float dz = float(hi[2] - lo[2]) * info.voxel_size[2];
  return dx * dy + dy * dz + dz * dx;
}

/// Whether two empty cells may merge along `axis` into the box [lo, hi) (voxels): its length
/// along the axis, in world units, stays within empty_aspect times its thinnest other side
/// (empty_aspect 0: always). The SAH alone merges empty cells into long slabs (merging two
/// empty cells always lowers it), which rays crossing them must step through one by one;
/// keeping the aspect ratio bounded keeps empty space in block-like cells. Not in the paper.
template <typename Coord>
IRGRID_HD inline bool empty_merge_keeps_shape(const GridInfo& info, const Coord* lo,
                                              const Coord* hi, int axis, float empty_aspect) {
  if (!(empty_aspect > 0)) return true;
  float thinnest = INFINITY;
  for (int other = 0; other < 3; ++other) {
    const float side = float(hi[other] - lo[other]) * info.voxel_size[other];
    if (other != axis && side < thinnest) thinnest = side;
  }
  return float(hi[axis] - lo[axis]) * info.voxel_size[axis] <= empty_aspect * thinnest;
}

/// The voxel just past the upper face of cell `a` along `axis`, where a merge partner would have
/// its lower corner; false when that face lies on the grid's boundary.
template <typename CellT>
IRGRID_HD inline bool voxel_past_upper_face(const GridInfo& info, const CellT& a, int axis,
                                            Voxel& past) {
  if (a.hi[axis] >= info.virtual_dims[axis]) return false;
  past = Voxel{a.lo[0], a.lo[1], a.lo[2]};
  past[axis] = a.hi[axis];
  return true;
}

/// Whether cell `c1` (box `a`) proposes to merge with c2, the owner of the voxel past its upper
/// face along `axis`, and the size of the union of their lists in `union_size` when it does.
/// c2 must start on that face and have a's cross-section, and the merged cell must cost no more
/// than the two: SA(c1 ∪ c2)(n12 + C) <= SA(c1)(n1 + C) + SA(c2)(n2 + C). Two empty cells must
/// also pass empty_merge_keeps_shape.
template <typename CellT>
IRGRID_HD inline bool proposes_merge(const GridInfo& info, const CellT* cells,
                                     const std::uint32_t* refs, const CellT& a, std::uint32_t c2,
                                     int axis, float cost_ratio, float empty_aspect,
                                     std::uint32_t& union_size) {
  const CellT b = cells[c2];
  if (b.lo[axis] != a.hi[axis]) return false;
  for (int other = 0; other < 3; ++other)
    if (other != axis && (b.lo[other] != a.lo[other] || b.hi[other] != a.hi[other])) return false;
  const std::uint32_t n1 = a.end - a.begin, n2 = b.end - b.begin;
  if (n1 == 0 && n2 == 0 && !empty_merge_keeps_shape(info, a.lo, b.hi, axis, empty_aspect))
    return false;
  const float budget = half_area(info, a.lo, a.hi) * (float(n1) + cost_ratio) +
                       half_area(info, b.lo, b.hi) * (float(n2) + cost_ratio);
  const float merged_area = half_area(info, a.lo, b.hi);
  // The union holds at least the longer list: if even that is too expensive, skip the walk.
  const std::uint32_t lower_bound = n1 > n2 ? n1 : n2;
  if (merged_area * (float(lower_bound) + cost_ratio) > budget) return false;
  const std::uint32_t n12 = sorted_union_size(refs + a.begin, n1, refs + b.begin, n2);
  if (merged_area * (float(n12) + cost_ratio) > budget) return false;
  union_size = n12;
  return true;
}

/// The cell that `c1` proposes to merge with along `axis` (kNoCell if none), and the size of the
/// union of their lists in `union_size` when there is one (see proposes_merge). The one-cell
/// form of what propose_merges computes for batches of cells.
template <typename CellT>
IRGRID_HD inline std::uint32_t merge_partner(const GridInfo& info, const Entry* entries,
                                             const CellT* cells, const std::uint32_t* refs,
                                             std::uint32_t c1, int axis, float cost_ratio,
                                             float empty_aspect, std::uint32_t& union_size) {
  const CellT a = cells[c1];
  Voxel past{};
  if (!voxel_past_upper_face(info, a, axis, past)) return kNoCell;
  const std::uint32_t c2 = lookup_cell(info, entries, past);
  return proposes_merge(info, cells, refs, a, c2, axis, cost_ratio, empty_aspect, union_size)
             ? c2
             : kNoCell;
}

/// What a sweep's proposals read and write (propose_merges), for executors that make them in
/// SIMD lanes (Exec::kProposesInLanes: the host's, cpu/merge_propose.h) over narrow cells.
struct ProposeInputs {
  GridInfo info;
  const Entry* entries;
  const NarrowCell* cells;
  const std::uint32_t* refs;
  int axis;
  float cost_ratio, empty_aspect;
  std::uint32_t *next, *prev, *union_size, *quiet;  ///< quiet may be null unless track
  bool track;
};

/// Proposals of one sweep: next[c] (kNoCell if none), union_size[c] and prev[next[c]] = c (a
/// cell has at most one aligned predecessor, so that write has a single writer). quiet[c] holds
/// one bit per axis: set, c is known to propose nothing along it and is skipped; a cell found to
/// propose nothing gets the bit when `track` is set. quiet may be null (all bits clear) when
/// `track` is not. `cells` are the grid's, in either form. Returns the number of proposals.
template <typename Exec, typename CellT>
std::uint32_t propose_merges(Exec& exec, const GridArrays<Exec>& grid, const CellT* cells, int axis,
                             float cost_ratio, float empty_aspect, std::uint32_t* next,
                             std::uint32_t* prev, std::uint32_t* union_size, std::uint32_t* quiet,
                             bool track) {
  const GridInfo info = grid.info;
  const Entry* entries = grid.entries.data();
  const std::uint32_t* refs = grid.refs.data();
  const std::uint32_t bit = 1u << axis, n = info.num_cells;
  // Each body proposes for a batch of cells, walking their voxel-map lookups side by side: each
  // walk is a chain of dependent loads, and the walks of a batch are in flight together.
  constexpr std::uint32_t kBatch = Exec::kLookupBatch;
  bool proposed = false;
  if constexpr (Exec::kProposesInLanes && std::is_same_v<CellT, NarrowCell>) {
    if (Exec::proposes_in_lanes(info)) {
      const ProposeInputs in{info,         entries, cells, refs,       axis,  cost_ratio,
                             empty_aspect, next,    prev,  union_size, quiet, track};
      constexpr std::uint32_t kCells = 4 * kBatch;
      exec.for_each("merge propose", (n + kCells - 1) / kCells, [=](std::size_t b) {
        const auto first = std::uint32_t(b * kCells);
        Exec::propose_merges_in_lanes(in, first, n - first < kCells ? n - first : kCells);
      });
      proposed = true;
    }
  }
  if (!proposed)
    exec.for_each("merge propose", (n + kBatch - 1) / kBatch, [=] IRGRID_HD(std::size_t b) {
      const auto first = std::uint32_t(b * kBatch);
      const std::uint32_t count = n - first < kBatch ? n - first : kBatch;
      std::uint32_t walking[kBatch], owners[kBatch];
      Voxel past[kBatch];
      std::uint32_t walks = 0;
      for (std::uint32_t k = 0; k < count; ++k) {
        const std::uint32_t i = first + k;
        next[i] = kNoCell;
        union_size[i] = 0;
        prev[i] = kNoCell;
        if ((quiet == nullptr || (quiet[i] & bit) == 0) &&
            voxel_past_upper_face(info, cells[i], axis, past[walks]))
          walking[walks++] = i;
      }
      lookup_cells<kBatch>(info, entries, past, walks, owners);
      for (std::uint32_t w = 0; w < walks; ++w) {
        const std::uint32_t i = walking[w];
        std::uint32_t size = 0;
        if (proposes_merge(info, cells, refs, cells[i], owners[w], axis, cost_ratio, empty_aspect,
                           size)) {
          next[i] = owners[w];
          union_size[i] = size;
        }
      }
      if (track)
        for (std::uint32_t k = 0; k < count; ++k)
          if (next[first + k] == kNoCell) quiet[first + k] |= bit;
    });
  exec.for_each("merge link", info.num_cells, [=] IRGRID_HD(std::size_t i) {
    if (next[i] != kNoCell) prev[next[i]] = std::uint32_t(i);
  });
  return exec.transform_reduce(
      "merge count proposals", info.num_cells, std::uint32_t(0),
      [] IRGRID_HD(std::uint32_t x, std::uint32_t y) { return x + y; },
      [=] IRGRID_HD(std::size_t i) { return std::uint32_t(next[i] != kNoCell); });
}

/// Parity (0 even, 1 odd) of every cell's distance from the head of its proposal chain (`next`
/// and `prev` from propose_merges; a cell without a predecessor has parity 0).
///
/// Executors with kSerialMergeChains walk each chain from its head in one body, which writes
/// the parity of every cell it passes: O(n) work and no memory but the result. Chains along an
/// axis are short next to the number of cells, so the walks keep a CPU's threads busy; on a
/// GPU a long chain would hold up its warp.
///
/// Otherwise by pointer jumping over prev: each pass adds the parity of the current ancestor and
/// jumps to its ancestor, so ceil(log2(longest chain)) passes suffice. Only cells with a
/// predecessor take part (a head's parity is 0), so later sweeps, with few proposals, touch few
/// cells. Passes read one pair of arrays and write the other, so no pass reads what it writes and
/// the result is deterministic; cells that do not take part hold the same values in both.
template <typename Exec>
typename Exec::template Buffer<std::uint8_t> chain_parity(Exec& exec, const std::uint32_t* next,
                                                          const std::uint32_t* prev,
                                                          std::uint32_t n) {
  if constexpr (Exec::kSerialMergeChains) {
    auto parity_buffer = exec.template allocate<std::uint8_t>(n);
    std::uint8_t* parity = parity_buffer.data();
    exec.for_each("merge chain walk", n, [=](std::size_t i) {
      if (prev[i] != kNoCell) return;  // written by the walk from its chain's head
      parity[i] = 0;
      std::uint8_t distance = 1;
      for (std::uint32_t c = next[i]; c != kNoCell; c = next[c], distance ^= 1)
        parity[c] = distance;
    });
    return parity_buffer;
  }
  auto parity_a = exec.template allocate<std::uint8_t>(n);
  auto parity_b = exec.template allocate<std::uint8_t>(n);
  auto ancestor_a = exec.template allocate<std::uint32_t>(n);
  auto ancestor_b = exec.template allocate<std::uint32_t>(n);
  std::uint8_t *parity = parity_a.data(), *parity_next = parity_b.data();
  std::uint32_t *ancestor = ancestor_a.data(), *ancestor_next = ancestor_b.data();
  exec.for_each("merge rank init", n, [=] IRGRID_HD(std::size_t i) {
    ancestor[i] = ancestor_next[i] = prev[i];
    parity[i] = parity_next[i] = prev[i] != kNoCell;
  });
  std::uint32_t count = 0;
  const auto members = select_indices(
      exec, "merge rank members", n, [=] IRGRID_HD(std::uint32_t i) { return prev[i] != kNoCell; },
      count);
  const std::uint32_t* member = members.data();
  // Each pass doubles the distance jumped, so a chain of fewer than 2^32 cells resolves within
  // 32 passes; more means prev holds a cycle (proposals along an axis cannot form one), which
  // would otherwise loop here for ever.
  for (int pass = 0;; ++pass) {
    if (pass > 32)
      throw Error(ErrorCode::internal, "merging: proposal chains that do not end (a cycle)");
    const std::uint32_t pending = exec.transform_reduce(
        "merge rank check", count, std::uint32_t(0),
        [] IRGRID_HD(std::uint32_t x, std::uint32_t y) { return x + y; },
        [=] IRGRID_HD(std::size_t k) { return std::uint32_t(ancestor[member[k]] != kNoCell); });
    if (pending == 0) break;
    exec.for_each("merge rank jump", count, [=] IRGRID_HD(std::size_t k) {
      const std::uint32_t i = member[k], up = ancestor[i];
      parity_next[i] = up == kNoCell ? parity[i] : std::uint8_t(parity[i] ^ parity[up]);
      ancestor_next[i] = up == kNoCell ? kNoCell : ancestor[up];
    });
    std::swap(parity, parity_next);
    std::swap(ancestor, ancestor_next);
  }
  // The final parities sit in whichever buffer the last pass wrote.
  return parity == parity_a.data() ? std::move(parity_a) : std::move(parity_b);
}

}  // namespace merge_detail
}  // namespace irgrid
