// irgrid/kernel.h: one ray through a built grid, from the caller's own code: a CUDA kernel
// (compile with nvcc, --expt-relaxed-constexpr) or a host loop. Header-only; the same code as
// the library's own traversal, so the hits are the same, bit for bit.
#pragma once

#include "irgrid/kernel/grid_traverse.h"
#include "irgrid/ray.h"

namespace irgrid {

/// The nearest hit of `ray` in `grid` (Accelerator::grid_view(): device pointers inside a CUDA
/// kernel, host pointers on the host), as Accelerator::trace with Query::closest returns it.
/// For exact agreement with the library, compile without fused multiply-add contraction
/// (nvcc --fmad=false, g++ -ffp-contract=off): the watertight test rounds each product alone.
IRGRID_HD inline Hit closest_hit(const GridView& grid, const Ray& ray) {
  if (grid.info.num_triangles == 0) return Hit{};
  return grid.compact_cells != nullptr ? traverse_grid<Query::closest, CompactCell>(grid, ray)
                                       : traverse_grid<Query::closest, Cell>(grid, ray);
}

/// Whether `ray` hits anything in `grid` within [tmin, tmax] (occlusion): Hit::prim names a
/// triangle that it hits, or is kNoHit.
IRGRID_HD inline Hit any_hit(const GridView& grid, const Ray& ray) {
  if (grid.info.num_triangles == 0) return Hit{};
  return grid.compact_cells != nullptr ? traverse_grid<Query::any, CompactCell>(grid, ray)
                                       : traverse_grid<Query::any, Cell>(grid, ray);
}

}  // namespace irgrid
