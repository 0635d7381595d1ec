// core/construction/narrow_cell.h: the initial grid's cells in 20 bytes, while they are merged.
//
// The initial grid holds the most cells of the build (Sponza: 878 K, against 351 K merged), and
// its assembly and first merge sweep make the build's memory peak: a Cell's 32 bytes were the
// largest array there. Where the virtual grid fits 16 bits per axis (fits_compact_cells, as the
// finished grid's 16-byte cells need anyway), the host's assemblies (octree_depth_first.h,
// cells_by_walk.h) write their cells in this form, merging works on it, and the cells are widened
// to Cell once merged (widen_cells, cells.h). The reference range stays explicit (begin and end):
// merging in place writes lists past the others, so an end is not always the next cell's begin
// there.
#pragma once

#include <cstdint>

#include "irgrid/kernel/grid_layout.h"

namespace irgrid {

/// A cell with 16-bit corners (virtual grids of at most kMaxCompactResolution voxels per axis).
struct NarrowCell {
  std::uint16_t lo[3];  ///<  6 B inclusive lower voxel
  std::uint16_t hi[3];  ///<  6 B exclusive upper voxel
  std::uint32_t begin;  ///<  4 B first reference
  std::uint32_t end;    ///<  4 B one past the last reference
};
static_assert(sizeof(NarrowCell) == 20 && alignof(NarrowCell) == 4);

/// The box [lo, lo + size) with no references yet, in either cell form.
IRGRID_HD inline void set_cube(Cell& c, const std::int32_t lo[3], std::int32_t size,
                               std::uint32_t begin) {
  c = {{lo[0], lo[1], lo[2]}, begin, {lo[0] + size, lo[1] + size, lo[2] + size}, begin};
}
IRGRID_HD inline void set_cube(NarrowCell& c, const std::int32_t lo[3], std::int32_t size,
                               std::uint32_t begin) {
  for (int a = 0; a < 3; ++a) {
    c.lo[a] = std::uint16_t(lo[a]);
    c.hi[a] = std::uint16_t(lo[a] + size);
  }
  c.begin = c.end = begin;
}

/// The wide form of a narrow cell.
IRGRID_HD inline Cell widened(const NarrowCell& c) {
  return {{c.lo[0], c.lo[1], c.lo[2]}, c.begin, {c.hi[0], c.hi[1], c.hi[2]}, c.end};
}

}  // namespace irgrid
