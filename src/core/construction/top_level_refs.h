// core/construction/top_level_refs.h: (top cell, triangle) pairs and the octree depth of each top
// cell.
//
// Pérard-Gayot et al. 2017, §3.1: every triangle is inserted into the top cells it overlaps
// (candidates from its bounding box, kept by an exact, conservative triangle/box test), then each
// top cell's octree depth follows Cleary's formula with density λ2 over its own reference count.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include "core/construction/top_grid.h"
#include "core/triangle_box.h"
#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {

/// Pairs of (cell or node index, triangle index), cell-major order not implied.
template <typename Exec>
struct RefPairs {
  typename Exec::template Buffer<std::uint32_t> cell, tri;
  std::uint32_t count = 0;
};

/// Calls visit(top cell index) for every top cell the triangle overlaps (padded exact test).
template <typename Visit>
IRGRID_HD void for_each_top_cell_overlapped(const GridInfo& info, const Vec3<float>& top_size,
                                            const TriangleVertices& t, Visit&& visit) {
  const BoxF box = triangle_box(t);
  std::int32_t lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    const float inv = 1.0f / top_size[a], last = float(info.top_dims[a] - 1);
    lo[a] = std::int32_t(
        min_fast(max_fast(floorf((box.lo[a] - info.padding - info.box_lo[a]) * inv), 0.f), last));
    hi[a] = std::int32_t(
        min_fast(max_fast(floorf((box.hi[a] + info.padding - info.box_lo[a]) * inv), 0.f), last));
  }
  for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
    for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
      for (std::int32_t x = lo[0]; x <= hi[0]; ++x) {
        const std::int32_t cell[3] = {x, y, z};
        Vec3<float> cell_lo, cell_hi;
        for (int a = 0; a < 3; ++a) {
          cell_lo[a] = info.box_lo[a] + float(cell[a]) * top_size[a];
          cell_hi[a] = info.box_lo[a] + float(cell[a] + 1) * top_size[a];
        }
        if (vertex_in_box(t, cell_lo, cell_hi, info.padding) ||
            triangle_overlaps_box(t.p0, t.p1, t.p2, cell_lo, cell_hi, info.padding))
          visit((std::uint32_t(z) * std::uint32_t(info.top_dims[1]) + std::uint32_t(y)) *
                    std::uint32_t(info.top_dims[0]) +
                std::uint32_t(x));
      }
}

inline Vec3<float> top_cell_size(const GridInfo& info) {
  return {(info.box_hi.x - info.box_lo.x) / float(info.top_dims[0]),
          (info.box_hi.y - info.box_lo.y) / float(info.top_dims[1]),
          (info.box_hi.z - info.box_lo.z) / float(info.top_dims[2])};
}

/// values[0] + ... + values[n - 1] in 64 bits: the total a 32-bit scan over the same values
/// would wrap, so limits are checked on it before the scan and before any allocation.
template <typename Exec>
std::uint64_t wide_sum(Exec& exec, const char* name, const std::uint32_t* values, std::size_t n) {
  return exec.transform_reduce(
      name, n, std::uint64_t(0), [] IRGRID_HD(std::uint64_t a, std::uint64_t b) { return a + b; },
      [=] IRGRID_HD(std::size_t i) { return std::uint64_t(values[i]); });
}

/// Throws Error{limit_exceeded} when `count` references do not fit the 30-bit limit.
inline void check_reference_count(std::uint64_t count, const char* phase) {
  if (count > kMaxEntryTarget)
    throw Error(ErrorCode::limit_exceeded,
                std::string(phase) + ": " + std::to_string(count) +
                    " references exceed the limit of 2^30 - 1 (lower lambda1/lambda2)");
}

/// Throws Error{limit_exceeded} when `count` voxel-map entries do not fit the 30-bit limit.
inline void check_entry_count(std::uint64_t count) {
  if (count > kMaxEntryTarget)
    throw Error(ErrorCode::limit_exceeded,
                "voxel map: " + std::to_string(count) +
                    " entries exceed the limit of 2^30 - 1 (lower lambda2 or min_cells)");
}

/// Emits the (top cell, triangle) pairs, triangle-major (so each cell's triangles ascend).
template <typename Exec>
RefPairs<Exec> emit_top_level_refs(Exec& exec, const TriangleVertices* triangles,
                                   const GridInfo& info) {
  const std::uint32_t n = info.num_triangles;
  const Vec3<float> size = top_cell_size(info);
  auto offsets = exec.template allocate<std::uint32_t>(n + 1);
  std::uint32_t* d_offsets = offsets.data();
  exec.for_each("top-level count", n, [=] IRGRID_HD(std::size_t i) {
    std::uint32_t count = 0;
    for_each_top_cell_overlapped(info, size, triangles[i], [&](std::uint32_t) { ++count; });
    d_offsets[i] = count;
  });
  const std::uint64_t total = wide_sum(exec, "top-level total", d_offsets, n);
  check_reference_count(total, "top-level references");
  // The pairs (8 bytes each), and as much again while the octrees sort them into top cells.
  check_memory_budget(
      exec.memory_budget(), total * 16,
      [&] { return std::to_string(total) + " top-level references"; }, "lower lambda1");
  exec.exclusive_scan("top-level offsets", d_offsets, d_offsets, n);
  RefPairs<Exec> pairs{exec.template allocate<std::uint32_t>(total),
                       exec.template allocate<std::uint32_t>(total), std::uint32_t(total)};
  std::uint32_t *d_cell = pairs.cell.data(), *d_tri = pairs.tri.data();
  exec.for_each("top-level emit", n, [=] IRGRID_HD(std::size_t i) {
    std::uint32_t k = d_offsets[i];
    for_each_top_cell_overlapped(info, size, triangles[i], [&](std::uint32_t cell) {
      d_cell[k] = cell;
      d_tri[k] = std::uint32_t(i);
      ++k;
    });
  });
  return pairs;
}

/// Octree depth of a top cell holding `count` references: Cleary's resolution with λ2 inside
/// the cell, rounded up to a power of two (integer arithmetic, identical on host and device).
/// Axes along which the cell is no thicker than `flat` (flat_cell_extent) are left out of the
/// density, as in the top grid: a flat scene's cells then get the depth their area asks for,
/// not the far greater one a volume a few paddings thick would.
IRGRID_HD inline std::int32_t octree_depth(const Vec3<float>& cell_size, float lambda2,
                                           std::uint32_t count, std::int32_t max_depth,
                                           float flat) {
  double dims[3];
  cleary_resolution(cell_size, lambda2, count, flat, dims);
  const double largest = fmax(dims[0], fmax(dims[1], dims[2]));
  if (!(largest > 1)) return 0;
  // ceil(log2(largest)) for an integer largest >= 2: the bit width of largest - 1.
  std::uint64_t below = std::uint64_t(fmin(largest, 0x1p40)) - 1;
  std::int32_t depth = 0;
  while (below != 0)
    below >>= 1, ++depth;
  return depth < max_depth ? depth : max_depth;
}

}  // namespace irgrid
