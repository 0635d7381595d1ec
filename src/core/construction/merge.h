// core/construction/merge.h: SAH-driven merging of neighbouring cells, in parallel sweeps per axis.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017, §3.2.
// Which cells pair up in a sweep is decided in merge_pairs.h; here the pairs become cells, by
// rebuilding the arrays or, in sweeps that merge few cells, in place, and sweeps repeat in rounds.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>

#include "core/construction/merge_pairs.h"
#include "core/number_text.h"
#include "core/release_buffer.h"
#include "irgrid/error.h"

namespace irgrid {

namespace merge_detail {

/// Gives `c` a box no proposal can align with: absorbed cells get it, so a lookup that lands on
/// one of their map leaves finds no partner, as it would find none in the cell that absorbed it.
/// (A narrow cell's corners all 0xffff: only a cell on the grid's upper face, which proposes
/// nothing, has that upper coordinate.)
IRGRID_HD inline void make_absorbed(Cell& c) {
  c = {{-1, -1, -1}, 0, {-1, -1, -1}, 0};
}
IRGRID_HD inline void make_absorbed(NarrowCell& c) {
  c = {{0xffff, 0xffff, 0xffff}, {0xffff, 0xffff, 0xffff}, 0, 0};
}

/// The cell that absorbed `c` in place, following earlier absorptions; `c` itself if it is live.
IRGRID_HD inline std::uint32_t live_owner(const std::uint32_t* forward, std::uint32_t c) {
  while (forward[c] != kNoCell)
    c = forward[c];
  return c;
}

/// The bits of a cell's pair byte in a sweep: its chain parity (chain_parity; set: absorbed by
/// its predecessor) and, set by mark_pair_heads, whether it heads a pair.
inline constexpr std::uint8_t kAbsorbedBit = 1, kHeadsPairBit = 2;

/// Whether cell i heads a pair of the sweep (mark_pair_heads).
IRGRID_HD inline bool marked_head(const std::uint8_t* pair_bits, std::size_t i) {
  return (pair_bits[i] & kHeadsPairBit) != 0;
}

/// The cell a marked head absorbs, kept in its upper corner (mark_pair_heads).
IRGRID_HD inline void keep_partner(Cell& head, std::uint32_t partner) {
  head.hi[0] = std::int32_t(partner);
}
IRGRID_HD inline void keep_partner(NarrowCell& head, std::uint32_t partner) {
  head.hi[0] = std::uint16_t(partner);
  head.hi[1] = std::uint16_t(partner >> 16);
}
IRGRID_HD inline std::uint32_t marked_partner(const Cell& head) {
  return std::uint32_t(head.hi[0]);
}
IRGRID_HD inline std::uint32_t marked_partner(const NarrowCell& head) {
  return std::uint32_t(head.hi[0]) | std::uint32_t(head.hi[1]) << 16;
}

/// Whether cell i leaves the array in a rebuilding sweep: absorbed by its predecessor now, or
/// absorbed in place earlier (`absorbed_by`, see apply_merges_in_place; nullptr: none).
IRGRID_HD inline bool leaves_the_array(const std::uint8_t* pair_bits,
                                       const std::uint32_t* absorbed_by, std::size_t i) {
  return (pair_bits[i] & kAbsorbedBit) != 0 || (absorbed_by && absorbed_by[i] != kNoCell);
}

/// Marks the heads of the sweep's pairs in `pair_bits` (the chain parity, kHeadsPairBit added:
/// a head proposed and is not absorbed itself) and writes each head's partner over its upper
/// corner, so that the merges run without the proposals' array of one cell id per cell (at the
/// first sweep, the build's peak): a merged cell takes its whole upper corner from the cell it
/// absorbs (they share their cross-section), so the head's own corner is not read again, and no
/// other cell reads it.
template <typename Exec, typename CellT>
void mark_pair_heads(Exec& exec, std::uint32_t n, CellT* cells, const std::uint32_t* next,
                     std::uint8_t* pair_bits) {
  exec.for_each("merge mark heads", n, [=] IRGRID_HD(std::size_t i) {
    if (pair_bits[i] != 0 || next[i] == kNoCell) return;
    keep_partner(cells[i], next[i]);
    pair_bits[i] = kHeadsPairBit;
  });
}

/// Wakes, per axis, the owner of the voxel below merged cell m's lower corner: a new cell may
/// be its partner now (merge_pairs.h). `forward` resolves cells absorbed in place (nullptr:
/// the map names live cells only).
template <typename CellT>
IRGRID_HD inline void wake_cells_below(const GridInfo& info, const Entry* entries, const CellT& m,
                                       std::uint32_t* quiet, const std::uint32_t* forward) {
  for (int axis = 0; axis < 3; ++axis) {
    if (m.lo[axis] == 0) continue;
    Voxel below{m.lo[0], m.lo[1], m.lo[2]};
    below[axis] = m.lo[axis] - 1;
    std::uint32_t owner = lookup_cell(info, entries, below);
    if (forward) owner = live_owner(forward, owner);
    atomic_and(&quiet[owner], ~(1u << axis));
  }
}

/// The quiet bits of the n cells (propose_merges), made zero where none are yet. They are made
/// on first use, so that the first round, which tracks none and merges most cells, runs
/// without them: an empty buffer stands for all zero.
template <typename Exec>
void make_quiet_bits(Exec& exec, typename Exec::template Buffer<std::uint32_t>& quiet,
                     std::uint32_t n) {
  if (quiet.size() != 0 || n == 0) return;
  quiet = exec.template allocate<std::uint32_t>(n);
  std::uint32_t* d_quiet = quiet.data();
  exec.for_each("merge quiet init", n, [=] IRGRID_HD(std::size_t i) { d_quiet[i] = 0; });
}

/// Turns the resolved pairs (`pair_bits` and the partners of mark_pair_heads) into new cells and
/// references, scans giving the new cell ids and reference offsets, and points every leaf of the
/// voxel map at its new cell. `quiet` (one entry per cell, see propose_merges; empty: all zero,
/// and it stays empty) is carried over to the new cells: cleared for merged cells and, when
/// `track` is set, for the cells below a merged cell's lower corner. Cells absorbed by earlier
/// in-place sweeps (`forward`, see apply_merges_in_place) are dropped, their map leaves pointed
/// at the cell that absorbed them, and `forward` is emptied. `union_size` is overwritten with
/// the new lists' offsets. `cell_buffer`: the grid's cells, in either form (grid.cells or
/// grid.narrow_cells).
template <typename Exec, typename CellBuffer>
void apply_merges(Exec& exec, GridArrays<Exec>& grid, CellBuffer& cell_buffer,
                  std::uint32_t* union_size, const std::uint8_t* pair_bits,
                  typename Exec::template Buffer<std::uint32_t>& quiet,
                  typename Exec::template Buffer<std::uint32_t>& forward, bool track) {
  using CellT = std::remove_cv_t<std::remove_pointer_t<decltype(cell_buffer.data())>>;
  const std::uint32_t n = grid.info.num_cells;
  const CellT* cells = cell_buffer.data();
  const std::uint32_t* refs = grid.refs.data();
  // A cell's new list offset goes where its union's size was, and the new ids are counted once
  // the old references went back: the first sweeps make the build's peak. The new cells take
  // their ends from their successors' begins (the lists follow the cells without gaps).
  std::uint32_t* new_begin = union_size;
  // Odd positions are absorbed; even ones that proposed merge forward.
  const std::uint32_t* absorbed_by = forward.size() != 0 ? forward.data() : nullptr;
  exec.for_each("merge counts", n, [=] IRGRID_HD(std::size_t i) {
    const bool absorbed = leaves_the_array(pair_bits, absorbed_by, i),
               merges = marked_head(pair_bits, i);
    new_begin[i] = absorbed ? 0 : (merges ? new_begin[i] : cells[i].end - cells[i].begin);
  });
  const std::uint32_t num_refs = exec.exclusive_scan("merge ref offsets", new_begin, new_begin, n);
  if (num_refs > kMaxEntryTarget)
    throw Error(ErrorCode::limit_exceeded,
                "merging: " + std::to_string(num_refs) + " references; at most 2^30 - 1");
  // The lists first, then the boxes, so that the old references go back before the new cells
  // are made (the paper's §3.2 writes both in one pass). One thread per surviving cell (the
  // paper copies unmerged lists warp-cooperatively; a CUDA executor may want that for load
  // balance).
  auto merged_refs = exec.template allocate<std::uint32_t>(num_refs);
  std::uint32_t* out_refs = merged_refs.data();
  exec.for_each("merge write lists", n, [=] IRGRID_HD(std::size_t i) {
    // Written by its predecessor, or absorbed in place earlier.
    if (leaves_the_array(pair_bits, absorbed_by, i)) return;
    const CellT a = cells[i];
    std::uint32_t* out = out_refs + new_begin[i];
    if (marked_head(pair_bits, i)) {
      const CellT b = cells[marked_partner(a)];
      write_sorted_union(refs + a.begin, a.end - a.begin, refs + b.begin, b.end - b.begin, out);
    } else {
      copy_list(refs + a.begin, a.end - a.begin, out);
    }
  });
  grid.refs = std::move(merged_refs);
  auto new_id_buffer = exec.template allocate<std::uint32_t>(n);
  std::uint32_t* new_id = new_id_buffer.data();
  exec.for_each("merge cell ids", n, [=] IRGRID_HD(std::size_t i) {
    new_id[i] = leaves_the_array(pair_bits, absorbed_by, i) ? 0 : 1;
  });
  // At most the n cells there were.
  const std::uint32_t num_cells = exec.exclusive_scan("merge cell ids", new_id, new_id, n);
  // Each old cell's new id, written over new_id: a surviving cell's is its own, and an absorbed
  // cell's entry, which only its absorber writes, is read by no one else before the remap.
  std::uint32_t* remap = new_id;
  // In place (kCompactsInPlace): each surviving cell becomes its merged cell where it stands,
  // then the survivors move down to their new ids. A merged cell reads only itself and the cell
  // it absorbs, which no one writes, so the first pass needs no second array.
  constexpr bool in_place = Exec::kCompactsInPlace;
  const bool has_quiet = quiet.size() != 0;
  typename Exec::template Buffer<CellT> merged_cells;
  typename Exec::template Buffer<std::uint32_t> merged_quiet;
  if constexpr (!in_place) {
    merged_cells = exec.template allocate<CellT>(num_cells);
    if (has_quiet) merged_quiet = exec.template allocate<std::uint32_t>(num_cells);
  }
  CellT* out_cells = in_place ? cell_buffer.data() : merged_cells.data();
  const std::uint32_t* old_quiet = has_quiet ? quiet.data() : nullptr;
  std::uint32_t* new_quiet = !has_quiet ? nullptr : in_place ? quiet.data() : merged_quiet.data();
  exec.for_each("merge write cells", n, [=] IRGRID_HD(std::size_t i) {
    if (leaves_the_array(pair_bits, absorbed_by, i)) return;
    CellT merged = cells[i];
    const std::uint32_t id = new_id[i];
    const bool head = marked_head(pair_bits, i);
    if (head) {
      const std::uint32_t partner = marked_partner(merged);
      const CellT b = cells[partner];
      remap[partner] = id;  // the absorbed cell's only writer: it has one predecessor
      for (int axis = 0; axis < 3; ++axis)
        merged.hi[axis] = b.hi[axis];
    }
    merged.begin = new_begin[i];
    const std::size_t at = Exec::kCompactsInPlace ? i : id;
    out_cells[at] = merged;
    if (new_quiet) new_quiet[at] = head ? 0u : old_quiet[i];
  });
  if constexpr (in_place) {
    exec.compact_in_place(
        "merge compact cells", n,
        [=](std::size_t i) { return !leaves_the_array(pair_bits, absorbed_by, i); },
        [=](std::size_t from, std::size_t to) {
          out_cells[to] = out_cells[from];
          if (new_quiet) new_quiet[to] = new_quiet[from];
        });
    cell_buffer.resize(num_cells);
    if (has_quiet) quiet.resize(num_cells);
  }
  // A union's size is exact (proposes_merge), so each list ends where the next cell's begins.
  end_lists_at_successors(exec, "merge cell ends", out_cells, num_cells, num_refs);
  Entry* entries = grid.entries.data();
  exec.for_each("merge remap entries", grid.info.num_entries, [=] IRGRID_HD(std::size_t i) {
    if (entries[i].log_dim() != 0) return;
    const std::uint32_t owner = entries[i].index();
    entries[i] = Entry::leaf(remap[absorbed_by ? live_owner(absorbed_by, owner) : owner]);
  });
  const GridInfo info = grid.info;
  if (track)
    exec.for_each("merge wake neighbours", n, [=] IRGRID_HD(std::size_t i) {
      if (marked_head(pair_bits, i))
        wake_cells_below(info, entries, out_cells[new_id[i]], new_quiet, nullptr);
    });
  if constexpr (!in_place) {
    if (has_quiet) quiet = std::move(merged_quiet);
    cell_buffer = std::move(merged_cells);
  }
  release_buffer(forward);
  grid.info.num_cells = num_cells;
  grid.info.num_refs = num_refs;
}

/// Applies a sweep's pairs in place, for sweeps that merge few cells: rebuilding every array
/// (apply_merges) would cost more than the merges. The lower cell of a pair takes the merged box
/// and a list written past the references in use (the buffer grows when needed); the upper
/// cell stays in the array, absorbed: forward names its absorber, it proposes nothing (all quiet
/// bits) and gets make_absorbed. Its map leaves still name it, so lookups that land there find
/// no partner (see make_absorbed) and waking resolves them through `forward`. The next
/// apply_merges drops absorbed cells and points their leaves at their absorbers, so the grid
/// ends as if every sweep had rebuilt it. The pairs are those of mark_pair_heads. Returns the
/// number of pairs merged, or 0 without merging any when the lists would pass the limit on
/// references (the marks stay, for apply_merges); `union_size` is overwritten when it merges.
/// `cells`: the grid's, in either form.
template <typename Exec, typename CellT>
std::uint32_t apply_merges_in_place(Exec& exec, GridArrays<Exec>& grid, CellT* cells,
                                    std::uint32_t* union_size, const std::uint8_t* pair_bits,
                                    std::uint32_t* quiet,
                                    typename Exec::template Buffer<std::uint32_t>& forward,
                                    bool track) {
  const std::uint32_t n = grid.info.num_cells, used = grid.info.num_refs;
  const std::uint64_t added = exec.transform_reduce(
      "merge in place offsets", n, std::uint64_t(0),
      [] IRGRID_HD(std::uint64_t x, std::uint64_t y) { return x + y; },
      [=] IRGRID_HD(std::size_t i) {
        return std::uint64_t(marked_head(pair_bits, i) ? union_size[i] : 0);
      });
  if (used + added > kMaxEntryTarget) return 0;
  // Each head's list offset goes where its union's size was (no second array of n beside the
  // grown references).
  std::uint32_t* offset = union_size;
  exec.for_each("merge in place offsets", n, [=] IRGRID_HD(std::size_t i) {
    if (!marked_head(pair_bits, i)) offset[i] = 0;
  });
  exec.exclusive_scan("merge in place offsets", offset, offset, n);
  if (used + added > grid.refs.size()) {
    // Room for this sweep's lists and as many again, so that later sweeps rarely grow it.
    const std::uint64_t room =
        std::min<std::uint64_t>(kMaxEntryTarget, used + 2 * added + used / 8);
    auto grown = exec.template allocate<std::uint32_t>(room);
    const std::uint32_t* from = grid.refs.data();
    std::uint32_t* to = grown.data();
    exec.for_each("merge in place grow", used, [=] IRGRID_HD(std::size_t i) { to[i] = from[i]; });
    grid.refs = std::move(grown);
  }
  if (forward.size() == 0) {
    forward = exec.template allocate<std::uint32_t>(n);
    std::uint32_t* d_forward = forward.data();
    exec.for_each("merge in place init", n,
                  [=] IRGRID_HD(std::size_t i) { d_forward[i] = kNoCell; });
  }
  std::uint32_t *refs = grid.refs.data(), *d_forward = forward.data();
  // One writer per pair: its lower cell's thread, the only one reading either cell.
  exec.for_each("merge in place write", n, [=] IRGRID_HD(std::size_t i) {
    if (!marked_head(pair_bits, i)) return;
    const CellT a = cells[i];
    const std::uint32_t j = marked_partner(a);
    const CellT b = cells[j];
    CellT merged = a;
    merged.begin = used + offset[i];
    merged.end = merged.begin + write_sorted_union(refs + a.begin, a.end - a.begin, refs + b.begin,
                                                   b.end - b.begin, refs + merged.begin);
    for (int axis = 0; axis < 3; ++axis)
      merged.hi[axis] = b.hi[axis];
    cells[i] = merged;
    make_absorbed(cells[j]);
    quiet[i] = 0;
    quiet[j] = 7;
    d_forward[j] = std::uint32_t(i);
  });
  const GridInfo info = grid.info;
  const Entry* entries = grid.entries.data();
  if (track)
    exec.for_each("merge in place wake", n, [=] IRGRID_HD(std::size_t i) {
      if (marked_head(pair_bits, i)) wake_cells_below(info, entries, cells[i], quiet, d_forward);
    });
  grid.info.num_refs = std::uint32_t(used + added);
  return exec.transform_reduce(
      "merge in place count", n, std::uint32_t(0),
      [] IRGRID_HD(std::uint32_t x, std::uint32_t y) { return x + y; },
      [=] IRGRID_HD(std::size_t i) { return std::uint32_t(marked_head(pair_bits, i)); });
}

/// One sweep along `axis`: proposals, chain resolution, then the merges, in place when fewer
/// than in_place_below x the cells propose (apply_merges_in_place), else rebuilding the arrays.
/// Leaves the grid untouched when no cell proposes. `absorbed` counts the cells absorbed in
/// place and still in the arrays.
template <typename Exec, typename CellBuffer>
void merge_sweep(Exec& exec, GridArrays<Exec>& grid, CellBuffer& cells, int axis, float cost_ratio,
                 float empty_aspect, typename Exec::template Buffer<std::uint32_t>& quiet,
                 typename Exec::template Buffer<std::uint32_t>& forward, std::uint32_t& absorbed,
                 float in_place_below, bool track) {
  const std::uint32_t n = grid.info.num_cells;
  auto next = exec.template allocate<std::uint32_t>(n);
  auto prev = exec.template allocate<std::uint32_t>(n);
  auto union_size = exec.template allocate<std::uint32_t>(n);
  if (track) make_quiet_bits(exec, quiet, n);
  const std::uint32_t proposals = propose_merges(
      exec, grid, cells.data(), axis, cost_ratio, empty_aspect, next.data(), prev.data(),
      union_size.data(), quiet.size() != 0 ? quiet.data() : nullptr, track);
  if (proposals == 0) return;
  auto pair_bits = chain_parity(exec, next.data(), prev.data(), n);
  release_buffer(prev);  // back to the pool before the merges ask for their arrays of n
  mark_pair_heads(exec, n, cells.data(), next.data(), pair_bits.data());
  release_buffer(next);
  if (double(proposals) < double(in_place_below) * double(n)) {
    make_quiet_bits(exec, quiet, n);  // absorbed cells are marked quiet
    const std::uint32_t merged =
        apply_merges_in_place(exec, grid, cells.data(), union_size.data(), pair_bits.data(),
                              quiet.data(), forward, track);
    absorbed += merged;
    if (merged > 0) return;
  }
  apply_merges(exec, grid, cells, union_size.data(), pair_bits.data(), quiet, forward, track);
  absorbed = 0;
}

/// Drops the cells absorbed by in-place sweeps (apply_merges with no pairs); nothing if none.
template <typename Exec, typename CellBuffer>
void drop_absorbed_cells(Exec& exec, GridArrays<Exec>& grid, CellBuffer& cells,
                         typename Exec::template Buffer<std::uint32_t>& quiet,
                         typename Exec::template Buffer<std::uint32_t>& forward) {
  if (forward.size() == 0) return;
  const std::uint32_t n = grid.info.num_cells;
  auto offsets = exec.template allocate<std::uint32_t>(n);
  auto pair_bits = exec.template allocate<std::uint8_t>(n);  // no pairs
  std::uint8_t* d_pair_bits = pair_bits.data();
  exec.for_each("merge drop absorbed", n, [=] IRGRID_HD(std::size_t i) { d_pair_bits[i] = 0; });
  apply_merges(exec, grid, cells, offsets.data(), d_pair_bits, quiet, forward, false);
}

/// merge_cells on the grid's cells in either form (`cells`: grid.cells or grid.narrow_cells).
template <typename Exec, typename CellBuffer>
void merge_rounds(Exec& exec, GridArrays<Exec>& grid, CellBuffer& cells, float alpha,
                  float cost_ratio, float empty_aspect, float in_place_below) {
  typename Exec::template Buffer<std::uint32_t> quiet;  // made on first use (make_quiet_bits)
  // The first round merges most cells: waking their neighbours would cost more than the
  // proposals it saves in the second round, so quiet cells are tracked from the second on.
  typename Exec::template Buffer<std::uint32_t> forward;
  std::uint32_t absorbed = 0;
  for (bool track = false;; track = true) {
    const std::uint32_t before = grid.info.num_cells - absorbed;
    for (int axis = 0; axis < 3; ++axis)
      merge_sweep(exec, grid, cells, axis, cost_ratio, empty_aspect, quiet, forward, absorbed,
                  in_place_below, track);
    const std::uint32_t after = grid.info.num_cells - absorbed;
    if (after == before || double(after) >= double(alpha) * double(before)) break;
  }
  // No sweep follows: the quiet bits go before the cells absorbed in place are dropped, which
  // writes new lists beside the old ones (the merge phase's peak on the budget-limited 10M
  // hairball).
  release_buffer(quiet);
  drop_absorbed_cells(exec, grid, cells, quiet, forward);
  // Compacted in place, the cells still hold the first sweep's array: down to their size (a
  // copy, beside that array: the merge phase's peak on the hairball).
  if constexpr (Exec::kCompactsInPlace) cells.shrink_to_fit();
}

}  // namespace merge_detail

/// The share of proposing cells below which a sweep merges in place (merge_cells): Sponza's
/// last 9 of 15 sweeps, each merging under 2% of its cells.
inline constexpr float kMergeInPlaceBelow = 1.f / 16;

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
/// Sweeps in which fewer than in_place_below x the cells propose merge in place
/// (merge_detail::apply_merges_in_place; 0: never), which changes the work, not the result.
///
/// Guarantees: cells still tile the virtual grid and the voxel map returns the owner of every
/// voxel; every list is the sorted, duplicate-free union of the lists of the cells merged into
/// it, so no reference is lost; the result is bit-identical for any number of threads. Merges
/// grid.narrow_cells when the assembly made them (narrow_cell.h), which stay narrow.
template <typename Exec>
void merge_cells(Exec& exec, GridArrays<Exec>& grid, float alpha, float cost_ratio,
                 float empty_aspect = 0, float in_place_below = kMergeInPlaceBelow) {
  if (!(cost_ratio >= 0) || !std::isfinite(cost_ratio))
    throw Error(ErrorCode::invalid_argument,
                "cost_ratio = " + number_text(cost_ratio) + " must be a number >= 0");
  if (!(empty_aspect == 0 || (empty_aspect >= 1 && std::isfinite(empty_aspect))))
    throw Error(ErrorCode::invalid_argument, "empty_aspect = " + number_text(empty_aspect) +
                                                 " must be 0 (no bound) or a number >= 1");
  if (!(alpha > 0)) return;
  // Only the host's assemblies make narrow cells.
  if constexpr (Exec::kDepthFirstOctrees) {
    if (grid.narrow_cells.size() != 0) {
      merge_detail::merge_rounds(exec, grid, grid.narrow_cells, alpha, cost_ratio, empty_aspect,
                                 in_place_below);
      return;
    }
  }
  merge_detail::merge_rounds(exec, grid, grid.cells, alpha, cost_ratio, empty_aspect,
                             in_place_below);
}

}  // namespace irgrid
