// core/construction/compact_cells.h: 32-byte cells written as 16-byte ones.
//
// Pérard-Gayot et al. 2017, §4: halving the cells halves the memory traffic of the one cell read
// per traversal step (and per neighbour looked up while cells expand, expand.h). Two facts make
// 16 bytes enough: voxel coordinates of grids up to 2^16 per axis fit 16 bits, and the build lays
// out the reference ranges in cell order without gaps (cells.h, merge.h), so a cell's end is its
// successor's begin.
#pragma once

#include <cstdint>
#include <string>

#include "core/construction/cells.h"
#include "irgrid/error.h"

namespace irgrid {

/// Writes grid.cells in the compressed layout (num_cells + 1 entries, the last a sentinel whose
/// begin is num_refs) into `out`. Requires fits_compact_cells(grid.info) and ranges in cell
/// order without gaps (Error(internal) otherwise, found by a check on every cell).
template <typename Exec>
void compress_cells(Exec& exec, const GridArrays<Exec>& grid,
                    typename Exec::template Buffer<CompactCell>& out) {
  const std::uint32_t n = grid.info.num_cells;
  if (!fits_compact_cells(grid.info))
    throw Error(ErrorCode::invalid_argument,
                "compressed cells need a virtual grid below 2^16 voxels per axis, this one has " +
                    std::to_string(grid.info.virtual_dims[0]) + " x " +
                    std::to_string(grid.info.virtual_dims[1]) + " x " +
                    std::to_string(grid.info.virtual_dims[2]));
  const Cell* cells = grid.cells.data();
  const std::uint32_t num_refs = grid.info.num_refs;
  const std::uint32_t gaps = exec.transform_reduce(
      "compress cells", n, std::uint32_t(0),
      [] IRGRID_HD(std::uint32_t a, std::uint32_t b) { return a + b; },
      [=] IRGRID_HD(std::size_t i) {
        const std::uint32_t next = i + 1 < n ? cells[i + 1].begin : num_refs;
        return std::uint32_t(cells[i].end != next || (i == 0 && cells[0].begin != 0));
      });
  if (gaps != 0)
    throw Error(ErrorCode::internal, "compress cells: " + std::to_string(gaps) +
                                         " reference ranges are not laid out in cell order");
  out = exec.template allocate<CompactCell>(std::size_t(n) + 1);
  CompactCell* d_out = out.data();
  exec.for_each("compress cells", std::size_t(n) + 1, [=] IRGRID_HD(std::size_t i) {
    if (i == n) {
      d_out[i] = {{0, 0, 0}, {0, 0, 0}, num_refs};
      return;
    }
    const Cell c = cells[i];
    d_out[i] = {{std::uint16_t(c.lo[0]), std::uint16_t(c.lo[1]), std::uint16_t(c.lo[2])},
                {std::uint16_t(c.hi[0]), std::uint16_t(c.hi[1]), std::uint16_t(c.hi[2])},
                c.begin};
  });
}

}  // namespace irgrid
