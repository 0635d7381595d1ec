// core/build/merge.h: SAH-driven merging of neighbouring cells, in parallel sweeps per axis.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017, §3.2:
// two cells that touch along an axis and share their cross-section form a box; they merge when
// the surface area heuristic does not get worse. Sweeps run along x, then y, then z, and rounds
// of three sweeps repeat while a round removes enough cells (../shared/design/algorithm.md §4).
//
// One sweep merges disjoint pairs only. Proposals c -> next(c) form chains along the axis; the
// chains are resolved in parallel by list ranking (pointer jumping, O(log length) passes) instead
// of the reference code's serial walk from each chain head:
//   * every cell learns the parity of its distance from the head of its chain;
//   * a cell at even distance that proposed merges with its successor, which is at odd distance;
//   * a cell at odd distance is absorbed by its predecessor and proposes nothing itself.
// This is exactly the pairing of the serial walk (positions 0+1, 2+3, ...), so the result does
// not depend on the order in which threads run, and every pass is a plain for_each.
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
#include <string>
#include <utility>

#include "core/build/cells.h"
#include "core/build/merge_lists.h"
#include "irgrid/error.h"

namespace irgrid {

namespace merge_detail {

/// Marks "no cell" in the proposal, predecessor and ancestor arrays.
inline constexpr std::uint32_t kNoCell = 0xffffffffu;

/// Half the surface area, in world units, of the voxel box [lo, hi). The factor 2 cancels in the
/// cost comparison.
IRGRID_HD inline float half_area(const GridInfo& info, const std::int32_t* lo,
                                 const std::int32_t* hi) {
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
IRGRID_HD inline bool empty_merge_keeps_shape(const GridInfo& info, const std::int32_t* lo,
                                              const std::int32_t* hi, int axis,
                                              float empty_aspect) {
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
IRGRID_HD inline bool voxel_past_upper_face(const GridInfo& info, const Cell& a, int axis,
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
IRGRID_HD inline bool proposes_merge(const GridInfo& info, const Cell* cells,
                                     const std::uint32_t* refs, const Cell& a, std::uint32_t c2,
                                     int axis, float cost_ratio, float empty_aspect,
                                     std::uint32_t& union_size) {
  const Cell b = cells[c2];
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
IRGRID_HD inline std::uint32_t merge_partner(const GridInfo& info, const Entry* entries,
                                             const Cell* cells, const std::uint32_t* refs,
                                             std::uint32_t c1, int axis, float cost_ratio,
                                             float empty_aspect, std::uint32_t& union_size) {
  const Cell a = cells[c1];
  Voxel past{};
  if (!voxel_past_upper_face(info, a, axis, past)) return kNoCell;
  const std::uint32_t c2 = lookup_cell(info, entries, past);
  return proposes_merge(info, cells, refs, a, c2, axis, cost_ratio, empty_aspect, union_size)
             ? c2
             : kNoCell;
}

/// Proposals of one sweep: next[c] (kNoCell if none), union_size[c] and prev[next[c]] = c (a
/// cell has at most one aligned predecessor, so that write has a single writer). quiet[c] holds
/// one bit per axis: set, c is known to propose nothing along it and is skipped; a cell found to
/// propose nothing gets the bit. Returns the number of proposals.
template <typename Exec>
std::uint32_t propose_merges(Exec& exec, const GridArrays<Exec>& grid, int axis, float cost_ratio,
                             float empty_aspect, std::uint32_t* next, std::uint32_t* prev,
                             std::uint32_t* union_size, std::uint32_t* quiet, bool track) {
  const GridInfo info = grid.info;
  const Entry* entries = grid.entries.data();
  const Cell* cells = grid.cells.data();
  const std::uint32_t* refs = grid.refs.data();
  const std::uint32_t bit = 1u << axis, n = info.num_cells;
  // Each body proposes for a batch of cells, walking their voxel-map lookups side by side: each
  // walk is a chain of dependent loads, and the walks of a batch are in flight together.
  constexpr std::uint32_t kBatch = Exec::kLookupBatch;
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
      if ((quiet[i] & bit) == 0 && voxel_past_upper_face(info, cells[i], axis, past[walks]))
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

/// Parity (0 even, 1 odd) of every cell's distance from the head of its proposal chain, by
/// pointer jumping over prev: each pass adds the parity of the current ancestor and jumps to its
/// ancestor, so ceil(log2(longest chain)) passes suffice. Only cells with a predecessor take part
/// (a head's parity is 0), so later sweeps, with few proposals, touch few cells. Passes read one
/// pair of arrays and write the other, so no pass reads what it writes and the result is
/// deterministic; cells that do not take part hold the same values in both.
template <typename Exec>
typename Exec::template Buffer<std::uint8_t> chain_parity(Exec& exec, const std::uint32_t* prev,
                                                          std::uint32_t n) {
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
  for (;;) {
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

/// Turns the resolved pairs into new cells and references, scans giving the new cell ids and
/// reference offsets, and points every leaf of the voxel map at its new cell. `quiet` (one entry
/// per cell, see propose_merges) is carried over to the new cells: cleared for merged cells and,
/// when `track` is set, for the cells below a merged cell's lower corner.
template <typename Exec>
void apply_merges(Exec& exec, GridArrays<Exec>& grid, const std::uint32_t* next,
                  const std::uint32_t* union_size, const std::uint8_t* parity,
                  typename Exec::template Buffer<std::uint32_t>& quiet, bool track) {
  const std::uint32_t n = grid.info.num_cells;
  const Cell* cells = grid.cells.data();
  const std::uint32_t* refs = grid.refs.data();
  auto new_id_buffer = exec.template allocate<std::uint32_t>(n);
  auto new_begin_buffer = exec.template allocate<std::uint32_t>(n);
  std::uint32_t *new_id = new_id_buffer.data(), *new_begin = new_begin_buffer.data();
  // Odd positions are absorbed; even ones that proposed merge forward.
  exec.for_each("merge counts", n, [=] IRGRID_HD(std::size_t i) {
    const bool absorbed = parity[i] != 0, merges = !absorbed && next[i] != kNoCell;
    new_id[i] = absorbed ? 0 : 1;
    new_begin[i] = absorbed ? 0 : (merges ? union_size[i] : cells[i].end - cells[i].begin);
  });
  const std::uint32_t num_cells = exec.exclusive_scan("merge cell ids", new_id, new_id, n);
  const std::uint32_t num_refs = exec.exclusive_scan("merge ref offsets", new_begin, new_begin, n);
  if (num_cells > kMaxEntryTarget || num_refs > kMaxEntryTarget)
    throw Error(ErrorCode::limit_exceeded, "merging: " + std::to_string(num_cells) + " cells, " +
                                               std::to_string(num_refs) +
                                               " references; at most 2^30 - 1 each");
  auto merged_cells = exec.template allocate<Cell>(num_cells);
  auto merged_refs = exec.template allocate<std::uint32_t>(num_refs);
  auto remap_buffer = exec.template allocate<std::uint32_t>(n);
  auto merged_quiet = exec.template allocate<std::uint32_t>(num_cells);
  Cell* out_cells = merged_cells.data();
  std::uint32_t *out_refs = merged_refs.data(), *remap = remap_buffer.data();
  const std::uint32_t* old_quiet = quiet.data();
  std::uint32_t* new_quiet = merged_quiet.data();
  // One thread per surviving cell writes its box and list (the paper copies unmerged lists
  // warp-cooperatively; a CUDA executor may want that for load balance).
  exec.for_each("merge write", n, [=] IRGRID_HD(std::size_t i) {
    if (parity[i] != 0) return;  // written by its predecessor
    const Cell a = cells[i];
    const std::uint32_t id = new_id[i], begin = new_begin[i];
    remap[i] = id;
    std::uint32_t count = a.end - a.begin;
    Cell merged = a;
    if (next[i] != kNoCell) {
      const Cell b = cells[next[i]];
      remap[next[i]] = id;  // the absorbed cell's only writer: it has one predecessor
      count = write_sorted_union(refs + a.begin, a.end - a.begin, refs + b.begin, b.end - b.begin,
                                 out_refs + begin);
      for (int axis = 0; axis < 3; ++axis)
        merged.hi[axis] = b.hi[axis];
    } else {
      copy_list(refs + a.begin, count, out_refs + begin);
    }
    merged.begin = begin;
    merged.end = begin + count;
    out_cells[id] = merged;
    new_quiet[id] = next[i] != kNoCell ? 0u : old_quiet[i];
  });
  Entry* entries = grid.entries.data();
  exec.for_each("merge remap entries", grid.info.num_entries, [=] IRGRID_HD(std::size_t i) {
    if (entries[i].log_dim() == 0) entries[i] = Entry::leaf(remap[entries[i].index()]);
  });
  const GridInfo info = grid.info;
  if (track)
    exec.for_each("merge wake neighbours", n, [=] IRGRID_HD(std::size_t i) {
      if (parity[i] != 0 || next[i] == kNoCell) return;
      const Cell m = out_cells[new_id[i]];
      for (int axis = 0; axis < 3; ++axis) {
        if (m.lo[axis] == 0) continue;
        Voxel below{m.lo[0], m.lo[1], m.lo[2]};
        below[axis] = m.lo[axis] - 1;
        atomic_and(&new_quiet[lookup_cell(info, entries, below)], ~(1u << axis));
      }
    });
  quiet = std::move(merged_quiet);
  grid.cells = std::move(merged_cells);
  grid.refs = std::move(merged_refs);
  grid.info.num_cells = num_cells;
  grid.info.num_refs = num_refs;
}

/// One sweep along `axis`: proposals, chain resolution, rebuild. Leaves the grid untouched when
/// no cell proposes.
template <typename Exec>
void merge_sweep(Exec& exec, GridArrays<Exec>& grid, int axis, float cost_ratio, float empty_aspect,
                 typename Exec::template Buffer<std::uint32_t>& quiet, bool track) {
  const std::uint32_t n = grid.info.num_cells;
  auto next = exec.template allocate<std::uint32_t>(n);
  auto prev = exec.template allocate<std::uint32_t>(n);
  auto union_size = exec.template allocate<std::uint32_t>(n);
  if (propose_merges(exec, grid, axis, cost_ratio, empty_aspect, next.data(), prev.data(),
                     union_size.data(), quiet.data(), track) == 0)
    return;
  const auto parity = chain_parity(exec, prev.data(), n);
  apply_merges(exec, grid, next.data(), union_size.data(), parity.data(), quiet, track);
}

}  // namespace merge_detail

/// Merges neighbouring cells while the SAH does not get worse (§3.2). Runs after assemble_grid
/// on any form of the voxel map (octree form or compacted): only leaf entries change, so the
/// map keeps its shape and grid.level_offsets stays valid.
///
/// Rounds of sweeps along x, y and z repeat while a round leaves fewer than alpha x the cells it
/// started with (and removes at least one, so alpha >= 1 terminates too); alpha <= 0 (or NaN)
/// disables merging. cost_ratio is the SAH's C_t / C_i (>= 0, finite; Error(invalid_argument)
/// otherwise). empty_aspect bounds the aspect ratio of merged empty cells (empty_merge_keeps_shape;
/// 0 or >= 1, finite; 0 disables the bound).
///
/// Guarantees: cells still tile the virtual grid and the voxel map returns the owner of every
/// voxel; every list is the sorted, duplicate-free union of the lists of the cells merged into
/// it, so no reference is lost; the result is bit-identical for any number of threads.
template <typename Exec>
void merge_cells(Exec& exec, GridArrays<Exec>& grid, float alpha, float cost_ratio,
                 float empty_aspect = 0) {
  if (!(cost_ratio >= 0) || !std::isfinite(cost_ratio))
    throw Error(ErrorCode::invalid_argument,
                "cost_ratio = " + std::to_string(cost_ratio) + " must be a number >= 0");
  if (!(empty_aspect == 0 || (empty_aspect >= 1 && std::isfinite(empty_aspect))))
    throw Error(ErrorCode::invalid_argument, "empty_aspect = " + std::to_string(empty_aspect) +
                                                 " must be 0 (no bound) or a number >= 1");
  if (!(alpha > 0)) return;
  auto quiet = exec.template allocate<std::uint32_t>(grid.info.num_cells);
  std::uint32_t* d_quiet = quiet.data();
  exec.for_each("merge quiet init", grid.info.num_cells,
                [=] IRGRID_HD(std::size_t i) { d_quiet[i] = 0; });
  // The first round merges most cells: waking their neighbours would cost more than the
  // proposals it saves in the second round, so quiet cells are tracked from the second on.
  for (bool track = false;; track = true) {
    const std::uint32_t before = grid.info.num_cells;
    for (int axis = 0; axis < 3; ++axis)
      merge_detail::merge_sweep(exec, grid, axis, cost_ratio, empty_aspect, quiet, track);
    const std::uint32_t after = grid.info.num_cells;
    if (after == before || double(after) >= double(alpha) * double(before)) break;
  }
}

}  // namespace irgrid
