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
#include <utility>

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

/// The top cells [lo, hi] (inclusive, per axis) that the triangle's padded box overlaps.
IRGRID_HD inline void top_cells_of_box(const GridInfo& info, const Vec3<float>& top_size,
                                       const TriangleVertices& t, std::int32_t (&lo)[3],
                                       std::int32_t (&hi)[3]) {
  const BoxF box = triangle_box(t);
  for (int a = 0; a < 3; ++a) {
    const float inv = 1.0f / top_size[a], last = float(info.top_dims[a] - 1);
    lo[a] = std::int32_t(
        min_fast(max_fast(floorf((box.lo[a] - info.padding - info.box_lo[a]) * inv), 0.f), last));
    hi[a] = std::int32_t(
        min_fast(max_fast(floorf((box.hi[a] + info.padding - info.box_lo[a]) * inv), 0.f), last));
  }
}

/// Clips the convex polygon[0, count) to the half space axis >= bound (keep_above) or
/// axis <= bound, in place; returns the new count (at most count + 1).
IRGRID_HD inline int clip_polygon(Vec3<float>* polygon, int count, int axis, float bound,
                                  bool keep_above) {
  Vec3<float> clipped[7];
  int kept = 0;
  for (int k = 0; k < count; ++k) {
    const Vec3<float>& a = polygon[k];
    const Vec3<float>& b = polygon[k + 1 < count ? k + 1 : 0];
    const bool a_in = keep_above ? a[axis] >= bound : a[axis] <= bound;
    const bool b_in = keep_above ? b[axis] >= bound : b[axis] <= bound;
    if (a_in) clipped[kept++] = a;
    if (a_in != b_in) {
      const float s = (bound - a[axis]) / (b[axis] - a[axis]);
      clipped[kept++] = {a.x + s * (b.x - a.x), a.y + s * (b.y - a.y), a.z + s * (b.z - a.z)};
    }
  }
  for (int k = 0; k < kept; ++k)
    polygon[k] = clipped[k];
  return kept;
}

/// The x extent [x_lo, x_hi] of triangle t clipped to the slab y in [y_lo, y_hi], z in
/// [z_lo, z_hi] (Sutherland-Hodgman against the slab's four planes); false when they do not
/// meet. A non-finite extent makes the caller's comparisons keep the whole row.
IRGRID_HD inline bool x_extent_in_slab(const TriangleVertices& t, float y_lo, float y_hi,
                                       float z_lo, float z_hi, float& x_lo, float& x_hi) {
  // A triangle clipped by four planes keeps at most 3 + 4 vertices.
  Vec3<float> polygon[7] = {t.p0, t.p1, t.p2};
  int count = clip_polygon(polygon, 3, 1, y_lo, true);
  count = clip_polygon(polygon, count, 1, y_hi, false);
  count = clip_polygon(polygon, count, 2, z_lo, true);
  count = clip_polygon(polygon, count, 2, z_hi, false);
  if (count == 0) return false;
  x_lo = x_hi = polygon[0].x;
  for (int k = 1; k < count; ++k) {
    x_lo = min_fast(polygon[k].x, x_lo);
    x_hi = max_fast(polygon[k].x, x_hi);
  }
  return true;
}

/// Calls visit(top cell index) for every top cell the triangle overlaps (padded exact test), in
/// ascending index order. A triangle whose box spans several cells along x has each row of cells
/// (fixed y, z) cut down to the x extent of the triangle within the row's slab: a large triangle
/// overlaps about its area's worth of the cells of its box, not their volume. Two clips per row:
///   * against the padded slab grown by a quarter cell, the extent one cell wider on each side
///     bounds the candidates: the cells left out lie a quarter cell or more from the triangle,
///     so the exact test would reject them too, whatever its rounding;
///   * against the unpadded slab (the cells' own cross-section), the extent [a, b] holds the x
///     of triangle points within a few ulps of the slab (the clipped vertices are points of the
///     triangle up to rounding, and the triangle is convex): a cell whose x range meets [a, b]
///     holds such a point within its padded box (the padding is 64 ulps of the scene's largest
///     coordinate), which the exact test, conservative, would accept: it is taken untested.
/// The result is the cells the exact test alone gives.
template <typename Visit>
IRGRID_HD void for_each_top_cell_overlapped(const GridInfo& info, const Vec3<float>& top_size,
                                            const TriangleVertices& t, Visit&& visit) {
  std::int32_t lo[3], hi[3];
  top_cells_of_box(info, top_size, t, lo, hi);
  const float inv_x = 1.0f / top_size[0];
  for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
    for (std::int32_t y = lo[1]; y <= hi[1]; ++y) {
      const float y_lo = info.box_lo.y + float(y) * top_size.y,
                  y_hi = info.box_lo.y + float(y + 1) * top_size.y,
                  z_lo = info.box_lo.z + float(z) * top_size.z,
                  z_hi = info.box_lo.z + float(z + 1) * top_size.z;
      std::int32_t x_first = lo[0], x_last = hi[0];
      bool some_sure = false;  // cells whose x range meets [sure_lo, sure_hi] overlap
      float sure_lo = 0.f, sure_hi = 0.f;
      if (hi[0] - lo[0] >= 3) {
        const float y_margin = info.padding + 0.25f * top_size.y,
                    z_margin = info.padding + 0.25f * top_size.z;
        float x_lo, x_hi;
        if (!x_extent_in_slab(t, y_lo - y_margin, y_hi + y_margin, z_lo - z_margin, z_hi + z_margin,
                              x_lo, x_hi))
          continue;
        const float first = (x_lo - info.padding - info.box_lo.x) * inv_x - 1.f,
                    last = (x_hi + info.padding - info.box_lo.x) * inv_x + 1.f;
        // Comparisons written so that NaN keeps the whole row.
        if (first > float(lo[0])) x_first = std::int32_t(min_fast(floorf(first), float(hi[0])));
        if (last < float(hi[0])) x_last = std::int32_t(max_fast(floorf(last), float(lo[0])));
        some_sure = x_extent_in_slab(t, y_lo, y_hi, z_lo, z_hi, sure_lo, sure_hi);
      }
      for (std::int32_t x = x_first; x <= x_last; ++x) {
        const Vec3<float> cell_lo{info.box_lo.x + float(x) * top_size.x, y_lo, z_lo},
            cell_hi{info.box_lo.x + float(x + 1) * top_size.x, y_hi, z_hi};
        if ((some_sure && cell_lo.x <= sure_hi && cell_hi.x >= sure_lo) ||
            vertex_in_box(t, cell_lo, cell_hi, info.padding) ||
            triangle_overlaps_box(t.p0, t.p1, t.p2, cell_lo, cell_hi, info.padding))
          visit((std::uint32_t(z) * std::uint32_t(info.top_dims[1]) + std::uint32_t(y)) *
                    std::uint32_t(info.top_dims[0]) +
                std::uint32_t(x));
      }
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

/// An upper bound of the top-level references, in O(triangles): the top cells of each
/// triangle's box. It tells a top grid far too fine for the budget before the exact count,
/// which tests every one of those cells, is paid for.
template <typename Exec>
std::uint64_t top_level_refs_bound(Exec& exec, const TriangleVertices* triangles,
                                   const GridInfo& info) {
  const Vec3<float> size = top_cell_size(info);
  return exec.transform_reduce(
      "top-level bound", info.num_triangles, std::uint64_t(0),
      [] IRGRID_HD(std::uint64_t a, std::uint64_t b) { return a + b; },
      [=] IRGRID_HD(std::size_t i) {
        std::int32_t lo[3], hi[3];
        top_cells_of_box(info, size, triangles[i], lo, hi);
        return std::uint64_t(hi[0] - lo[0] + 1) * std::uint64_t(hi[1] - lo[1] + 1) *
               std::uint64_t(hi[2] - lo[2] + 1);
      });
}

/// Counts the top cells each triangle overlaps into offsets[0..n) (the buffer holds n + 1) and
/// returns their total, for the budget to be checked before the pairs are made.
template <typename Exec>
std::uint64_t count_top_level_refs(Exec& exec, const TriangleVertices* triangles,
                                   const GridInfo& info, std::uint32_t* d_offsets) {
  const Vec3<float> size = top_cell_size(info);
  exec.for_each("top-level count", info.num_triangles, [=] IRGRID_HD(std::size_t i) {
    std::uint32_t count = 0;
    for_each_top_cell_overlapped(info, size, triangles[i], [&](std::uint32_t) { ++count; });
    d_offsets[i] = count;
  });
  return wide_sum(exec, "top-level total", d_offsets, info.num_triangles);
}

/// Emits the (top cell, triangle) pairs, triangle-major (so each cell's triangles ascend), from
/// the counts count_top_level_refs left in `offsets` (their `total`).
template <typename Exec>
RefPairs<Exec> emit_top_level_refs(Exec& exec, const TriangleVertices* triangles,
                                   const GridInfo& info,
                                   typename Exec::template Buffer<std::uint32_t> offsets,
                                   std::uint64_t total) {
  const std::uint32_t n = info.num_triangles;
  const Vec3<float> size = top_cell_size(info);
  std::uint32_t* d_offsets = offsets.data();
  check_reference_count(total, "top-level references");
  check_memory_budget(
      exec.memory_budget(), top_level_pair_bytes(total),
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

/// The (top cell, triangle) pairs of `info`'s top grid (count_top_level_refs, then
/// emit_top_level_refs).
template <typename Exec>
RefPairs<Exec> emit_top_level_refs(Exec& exec, const TriangleVertices* triangles,
                                   const GridInfo& info) {
  auto offsets = exec.template allocate<std::uint32_t>(std::size_t(info.num_triangles) + 1);
  const std::uint64_t total = count_top_level_refs(exec, triangles, info, offsets.data());
  return emit_top_level_refs(exec, triangles, info, std::move(offsets), total);
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
