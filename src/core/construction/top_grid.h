// core/construction/top_grid.h: the grid box and the top-level resolution (phase 1 of the build).
//
// Pérard-Gayot et al. 2017, §3.1: the top level is a uniform grid whose resolution follows
// Cleary et al., "Design and analysis of a parallel ray tracing computer" (1983): about λ1 x N
// cubic cells over the scene box. Flat axes (zero extent) get one cell and the density is taken
// over the remaining axes, so flat scenes still get square cells.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/construction/memory_budget.h"
#include "core/number_text.h"
#include "irgrid/build_config.h"
#include "irgrid/error.h"
#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {

/// World distance by which every insertion test grows a cell: far above the rounding of the
/// traversal's float positions (about 64 ulps of the largest coordinate), far below a voxel.
inline float insertion_padding(const BoxF& box) {
  float magnitude = 0;
  for (int a = 0; a < 3; ++a)
    magnitude = std::fmax(magnitude, std::fmax(std::fabs(box.lo[a]), std::fabs(box.hi[a])));
  return std::fmax(magnitude * 0x1p-17f, 1e-30f);
}

/// How far plan_top_grid grows the triangles' box on each side: 4 paddings. An axis along which
/// the triangles span no more than this is flat (one top cell, left out of Cleary's density).
inline float grid_margin(const GridInfo& info) {
  return 4 * info.padding;
}

/// Top cells no thicker than this along an axis are flat there when their octree depth is
/// planned (octree_depth): a flat axis's box is its triangles' span (at most one margin) plus a
/// margin on each side.
inline float flat_cell_extent(const GridInfo& info) {
  return 3 * grid_margin(info);
}

/// x^k for k in 1..3 with correctly rounded products only (no libm), so host and device agree.
IRGRID_HD inline double power_of(double x, int k) {
  return k == 1 ? x : (k == 2 ? x * x : x * x * x);
}

/// Cleary's resolution for `count` primitives in a box of extents `extent` and density λ:
/// cells of side s with (product of non-flat extents) / s^k = λ x count, k non-flat axes.
/// Each axis gets floor(extent / s) cells, computed as the largest integer n with
/// n^k x s^k <= extent^k: libm's pow only gives the first guess, and the answer is settled by
/// IEEE products and quotients that every compiler and GPU rounds alike, so the CPU and CUDA
/// builds choose the same resolutions bit for bit.
IRGRID_HD inline void cleary_resolution(const Vec3<float>& extent, double density, double count,
                                        float flat, double out[3]) {
  double volume = 1;
  int axes = 0;
  for (int a = 0; a < 3; ++a)
    if (extent[a] > flat) volume *= extent[a], ++axes;
  const bool none = axes == 0 || !(count > 0) || !(density > 0);
  const double side_power = none ? 0 : volume / (density * count);  // s^k
  for (int a = 0; a < 3; ++a) {
    if (!(extent[a] > flat)) {
      out[a] = 1.0;
      continue;
    }
    if (none || !(side_power > 0)) {
      out[a] = 0.0;
      continue;
    }
    const double guess = floor(double(extent[a]) / pow(side_power, 1.0 / axes));
    const double bound = power_of(double(extent[a]), axes);
    // A non-finite extent or density has no resolution: the callers reject 2^40 (and the search
    // below would count up to it, one cell at a time).
    if (guess != guess || !(bound - bound == 0)) {
      out[a] = 0x1p40;
      continue;
    }
    // Beyond 2^40 the callers reject the resolution anyway; keep the products finite.
    double n = fmin(fmax(guess, 0.0), 0x1p40);
    while (n > 0 && power_of(n, axes) * side_power > bound)
      n -= 1;
    while (n < 0x1p40 && power_of(n + 1, axes) * side_power <= bound)
      n += 1;
    out[a] = n;
  }
}

/// Plans the top grid over the triangles' box: fills box, top_dims and padding of the result.
template <typename Exec>
GridInfo plan_top_grid(Exec& exec, const TriangleVertices* triangles, std::uint32_t count,
                       const BuildConfig& config) {
  if (!(config.lambda1 > 0) || !std::isfinite(config.lambda1))
    throw Error(ErrorCode::invalid_argument,
                "lambda1 = " + number_text(config.lambda1) + " must be a positive number");
  const float inf = std::numeric_limits<float>::infinity();
  const BoxF empty{{inf, inf, inf}, {-inf, -inf, -inf}};
  const BoxF box = exec.transform_reduce(
      "scene box", count, empty,
      [] IRGRID_HD(const BoxF& a, const BoxF& b) { return box_union(a, b); },
      [triangles] IRGRID_HD(std::size_t i) { return triangle_box(triangles[i]); });
  GridInfo info{};
  info.num_triangles = count;
  info.padding = insertion_padding(box);
  // Grow the box so that padded triangles lie inside and no axis has zero extent.
  const float margin = grid_margin(info);
  Vec3<float> extent;
  for (int a = 0; a < 3; ++a) {
    info.box_lo[a] = box.lo[a] - margin;
    info.box_hi[a] = box.hi[a] + margin;
    extent[a] = box.hi[a] - box.lo[a];
    // Float positions along the grid need a finite box and extent: a scene wider than the
    // float range (3.4e38) cannot be gridded.
    if (!std::isfinite(info.box_hi[a] - info.box_lo[a]))
      throw Error(ErrorCode::limit_exceeded,
                  std::string("the triangles span ") + number_text(box.lo[a]) + " to " +
                      number_text(box.hi[a]) + " along " + "xyz"[a] +
                      ": a grid's box must be narrower than the float range (3.4e38); scale the "
                      "scene down");
  }
  double dims[3];
  cleary_resolution(extent, config.lambda1, count, margin, dims);
  double total = 1;
  for (int a = 0; a < 3; ++a) {
    info.top_dims[a] =
        std::int32_t(std::fmin(std::fmax(dims[a], 1.0), double(kMaxVirtualResolution)));
    total *= info.top_dims[a];
  }
  if (total > kMaxEntryTarget || dims[0] > kMaxVirtualResolution ||
      dims[1] > kMaxVirtualResolution || dims[2] > kMaxVirtualResolution)
    throw Error(ErrorCode::limit_exceeded,
                "lambda1 = " + number_text(config.lambda1) + " asks for a top grid of " +
                    number_text(dims[0]) + " x " + number_text(dims[1]) + " x " +
                    number_text(dims[2]) + " cells; the limit is 2^30 cells and 2^24 per axis");
  // Per top cell: its voxel-map entry, octree depth, reference count, empty radii (8 bytes)
  // and the depth-first octrees' offsets, about 32 bytes in all.
  check_memory_budget(
      exec.memory_budget(), std::uint64_t(total) * 32,
      [&] {
        return "lambda1 = " + number_text(config.lambda1) + ": a top grid of " +
               number_text(total) + " cells";
      },
      "lower lambda1");
  return info;
}

/// Finishes the grid's geometry once the octree depth D is known: virtual resolution R << D.
inline void set_virtual_resolution(GridInfo& info, std::int32_t shift) {
  info.shift = shift;
  for (int a = 0; a < 3; ++a) {
    info.virtual_dims[a] = info.top_dims[a] << shift;
    info.voxel_size[a] = (info.box_hi[a] - info.box_lo[a]) / float(info.virtual_dims[a]);
    info.inv_voxel_size[a] = 1.0f / info.voxel_size[a];
  }
}

/// Largest octree depth D (at most 20) at which R << D stays within `resolution` per axis and
/// voxels stay at least twice the insertion padding wide on every axis. Finer voxels cannot
/// separate triangles (each one lists every triangle within the padding) and multiply cells: the
/// octree splits all three axes, and a flat scene's box, 8 paddings thick, would otherwise be
/// cut into slices far thinner than the padding, all those near the plane holding its triangles
/// (an 80,000-triangle plane took 76 s and 980 MiB to build).
inline std::int32_t deepest_octree_depth_within(const GridInfo& info, std::int64_t resolution) {
  std::int32_t depth = 0;
  while (depth < 20) {
    bool fits = true;
    for (int a = 0; a < 3; ++a) {
      const std::int64_t voxels = std::int64_t(info.top_dims[a]) << (depth + 1);
      fits &= voxels <= resolution && double(info.box_hi[a] - info.box_lo[a]) / double(voxels) >=
                                          2.0 * double(info.padding);
    }
    if (!fits) break;
    ++depth;
  }
  return depth;
}

/// Largest octree depth the virtual grid allows: R << D stays within kMaxVirtualResolution,
/// voxels no thinner than twice the padding.
inline std::int32_t max_octree_depth(const GridInfo& info) {
  return deepest_octree_depth_within(info, kMaxVirtualResolution);
}

/// Finest octree depth at which the virtual grid still fits 16-bit compressed cells (voxels no
/// thinner than twice the padding).
inline std::int32_t compact_octree_depth(const GridInfo& info) {
  return deepest_octree_depth_within(info, kMaxCompactResolution);
}

}  // namespace irgrid
