// core/construction/expand.h: exit-box expansion, the last phase of the build.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017, §3.3:
// entry and exit boundaries are decoupled. The voxel map keeps each cell's own box (where rays
// enter it); the box stored in the cell (where rays leave it) grows over neighbours whose
// triangles it already lists, so traversal skips them and stops earlier. Each pass grows along
// x, then y, then z; along one axis every cell tries both directions, reading one snapshot of
// the boxes and writing its new extent along the axis to a second buffer, copied into the boxes
// once all are grown, so the result does not depend on scheduling. Why the growth keeps
// traversal exact, and the partial mode, are explained in expand_face.h.
#pragma once

#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/construction/cells.h"
#include "core/construction/expand_face.h"

namespace irgrid {

namespace expand_detail {

/// A cell's extent along one axis, [lo, hi) in voxels: what one axis step changes. Eight bytes
/// per cell beside the boxes, not a second array of boxes (32 bytes per cell): the build's
/// memory peak on the hairball was the expansion's.
struct AxisExtent {
  std::int32_t lo, hi;
};
static_assert(sizeof(AxisExtent) == 8);

/// A cell's new extent along kAxis, in either cell form.
template <int kAxis>
IRGRID_HD inline void set_extent(Cell& c, AxisExtent e) {
  c.lo[kAxis] = e.lo;
  c.hi[kAxis] = e.hi;
}
template <int kAxis>
IRGRID_HD inline void set_extent(CompactCell& c, AxisExtent e) {
  c.lo[kAxis] = std::uint16_t(e.lo);
  c.hi[kAxis] = std::uint16_t(e.hi);
}

/// Grows every cell along kAxis (both directions): the new extents of the boxes in `cells`
/// (grid.info.num_cells of them, Cell or CompactCell) go to `out`, then, once every cell has
/// read the old boxes, into the boxes.
/// `can_grow` holds one bit per face (bit 2 * kAxis for the lower face, 2 * kAxis + 1 for the
/// upper one) and cell; a face whose bit is clear stays where it is, and the bit is cleared when
/// the face did not grow by the full depth of its neighbours (blocked by the grid boundary or by
/// a list): the same neighbours still own the voxels past that face in later passes, so it would
/// mostly be blocked again. The bits only save work: clearing one never makes the grid wrong.
template <int kAxis, typename Exec, typename StoredCell>
void expand_axis(Exec& exec, const GridArrays<Exec>& grid, StoredCell* cells, AxisExtent* out,
                 std::uint8_t* can_grow, const TrianglePlanes* planes, bool partial,
                 std::int32_t growth_quantum) {
  const ExpandView<StoredCell> view{grid.info,        grid.entries.data(),   cells,
                                    grid.refs.data(), grid.triangles.data(), planes,
                                    partial,          growth_quantum};
  constexpr auto down_bit = std::uint8_t(1u << (2 * kAxis)),
                 up_bit = std::uint8_t(2u << (2 * kAxis));
  exec.for_each("expand cells", grid.info.num_cells, [=] IRGRID_HD(std::size_t i) {
    const Cell snapshot = view.cell(std::uint32_t(i));
    AxisExtent extent{snapshot.lo[kAxis], snapshot.hi[kAxis]};
    std::uint8_t faces = can_grow[i];
    // Both directions read the snapshot box; the two slabs are disjoint and each is safe on its
    // own, so their union is too.
    if (faces & up_bit) {
      const FaceGrowth up = face_growth<kAxis, +1>(view, snapshot);
      extent.hi += up.voxels;
      if (!up.may_grow_further) faces = std::uint8_t(faces & ~up_bit);
    }
    if (faces & down_bit) {
      const FaceGrowth down = face_growth<kAxis, -1>(view, snapshot);
      extent.lo -= down.voxels;
      if (!down.may_grow_further) faces = std::uint8_t(faces & ~down_bit);
    }
    can_grow[i] = faces;
    out[i] = extent;
  });
  // Every cell read the snapshot: the boxes take their new extents now.
  exec.for_each("expand apply", grid.info.num_cells,
                [=] IRGRID_HD(std::size_t i) { set_extent<kAxis>(cells[i], out[i]); });
}

/// expand_cells over the boxes in `cells`.
template <typename Exec, typename StoredCell>
void expand_boxes(Exec& exec, const GridArrays<Exec>& grid, StoredCell* cells, int passes,
                  bool partial, std::int32_t growth_quantum) {
  const std::uint32_t count = grid.info.num_cells;
  if (passes <= 0 || count == 0) return;
  auto extents = exec.template allocate<AxisExtent>(count);
  auto can_grow = exec.template allocate<std::uint8_t>(count);
  std::uint8_t* d_can_grow = can_grow.data();
  exec.for_each("expand flags", count, [=] IRGRID_HD(std::size_t i) { d_can_grow[i] = 0x3f; });
  // Partial growth settles extra triangles from their TrianglePlanes (16-bit planes: grids
  // that fit compressed cells).
  typename Exec::template Buffer<TrianglePlanes> planes;
  if (partial && fits_compact_cells(grid.info)) {
    const std::size_t count = grid.triangles.size();
    planes = exec.template allocate<TrianglePlanes>(count);
    TrianglePlanes* d_planes = planes.data();
    const TriangleVertices* d_triangles = grid.triangles.data();
    const GridInfo info = grid.info;
    if constexpr (Exec::kTrianglePlanesInLanes) {
      // Batches of triangles, each in SIMD lanes.
      constexpr std::size_t kBatch = 1024;
      exec.for_each("triangle planes", (count + kBatch - 1) / kBatch, [=](std::size_t b) {
        const std::size_t first = b * kBatch;
        const std::size_t size = count - first < kBatch ? count - first : kBatch;
        Exec::triangle_planes(info, d_triangles + first, std::uint32_t(size), d_planes + first);
      });
    } else {
      exec.for_each("triangle planes", count, [=] IRGRID_HD(std::size_t t) {
        d_planes[t] = triangle_planes(info, TriangleBounds{d_triangles[t]});
      });
    }
  }
  const TrianglePlanes* d_planes = planes.empty() ? nullptr : planes.data();
  const auto grow_along = [&](auto axis) {
    expand_axis<decltype(axis)::value>(exec, grid, cells, extents.data(), d_can_grow, d_planes,
                                       partial, growth_quantum);
  };
  for (int pass = 0; pass < passes; ++pass) {
    grow_along(std::integral_constant<int, 0>());
    grow_along(std::integral_constant<int, 1>());
    grow_along(std::integral_constant<int, 2>());
    // No face left that may grow: later passes would copy every box unchanged (a huge
    // --expansion-passes once ran for minutes doing only that).
    const std::uint8_t any_face =
        exec.reduce("expand any face", d_can_grow, count, std::uint8_t(0),
                    [] IRGRID_HD(std::uint8_t a, std::uint8_t b) { return std::uint8_t(a | b); });
    if (any_face == 0) break;
  }
}

}  // namespace expand_detail

/// Grows the exit boxes of all cells of `grid` in `passes` passes (x, y, z each; 0 or less:
/// nothing; fewer once no face may grow), in place of grid.cells. With `partial`, a cell may also
/// grow part-way into neighbours that hold triangles it does not list (not in the paper), in steps
/// of growth_quantum voxels (a power of two).
///
/// Requires a valid grid: cells tile the virtual grid (their boxes may already be expanded exit
/// boxes), every list sorted ascending and unique, the voxel map answering each voxel's owner,
/// and every triangle that overlaps a cell's box grown by info.padding in the cell's list.
/// Guarantees the same of the result with the exit boxes: each contains the cell's previous box
/// and stays inside the grid; the voxel map, the references and the ranges are unchanged.
/// Deterministic: the result depends on the inputs only, not on the number of threads.
template <typename Exec>
void expand_cells(Exec& exec, GridArrays<Exec>& grid, int passes, bool partial,
                  std::int32_t growth_quantum = 1) {
  expand_detail::expand_boxes(exec, grid, grid.cells.data(), passes, partial, growth_quantum);
}

/// expand_cells on the same grid's cells in the compressed form (compress_cells, with their
/// sentinel) instead of grid.cells, which it neither reads nor changes: the same boxes result.
template <typename Exec>
void expand_compact_cells(Exec& exec, const GridArrays<Exec>& grid,
                          typename Exec::template Buffer<CompactCell>& compact, int passes,
                          bool partial, std::int32_t growth_quantum = 1) {
  expand_detail::expand_boxes(exec, grid, compact.data(), passes, partial, growth_quantum);
}

}  // namespace irgrid
