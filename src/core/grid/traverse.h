// core/grid/traverse.h: stackless, ordered traversal of an irregular grid, for host and device.
//
// Pérard-Gayot et al. 2017, §4: find the cell of the ray's entry voxel in the voxel map, test its
// triangles, stop when the closest hit lies within the cell's exit distance, otherwise step to the
// voxel just past the cell's (expanded) exit box. Robustness: the exit axis advances in integers
// to the cell's far plane and no axis ever steps backwards, so the walk can neither stall nor skip
// a sliver of a cell; the remaining rounding of float positions is covered by the padding of the
// insertion test (GridInfo::padding).
#pragma once

#include <cstdint>

#include "core/grid/layout.h"
#include "core/triangle.h"
#include "core/watertight.h"

namespace irgrid {

/// Read-only views of a grid's arrays, in the memory space of the code that traverses it.
struct GridView {
  GridInfo info;
  const Entry* entries;
  const Cell* cells;                 ///< full cells, or null when the grid is compressed
  const CompactCell* compact_cells;  ///< compressed cells (num_cells + 1), or null
  const std::uint32_t* refs;
  const TriangleVertices* triangles;
};

/// The view's cell array of layout CellT (Cell or CompactCell).
template <typename CellT>
IRGRID_HD inline const CellT* cell_array(const GridView& grid) {
  if constexpr (sizeof(CellT) == sizeof(Cell))
    return grid.cells;
  else
    return grid.compact_cells;
}

/// Work done for one ray, for heat maps and statistics.
struct TraversalCounters {
  std::uint32_t cells = 0;      ///< cells visited
  std::uint32_t triangles = 0;  ///< ray/triangle tests
};

/// The ray's parameter interval inside the grid box, clipped to [tmin, tmax]; empty when
/// t_enter > t_leave.
IRGRID_HD inline void clip_to_grid(const GridInfo& info, const Ray& ray, const Vec3<float>& inv_dir,
                                   float& t_enter, float& t_leave) {
  t_enter = ray.tmin;
  t_leave = ray.tmax;
  for (int a = 0; a < 3; ++a) {
    if (ray.dir[a] == 0.f) {
      if (ray.org[a] < info.box_lo[a] || ray.org[a] > info.box_hi[a]) t_enter = 1.f, t_leave = 0.f;
      continue;
    }
    float t0 = (info.box_lo[a] - ray.org[a]) * inv_dir[a],
          t1 = (info.box_hi[a] - ray.org[a]) * inv_dir[a];
    if (t0 > t1) {
      const float swap = t0;
      t0 = t1;
      t1 = swap;
    }
    t_enter = max_fast(t0, t_enter);  // a NaN (0 x inf on a plane through the origin) is skipped
    t_leave = min_fast(t1, t_leave);
  }
}

/// The voxel after leaving `cell` at distance t_exit through the planes of the axes in
/// `exit_axes` (bit a set: axis a). Exit axes jump to the neighbouring voxel of the far plane;
/// the others follow the exit point, clamped inside the cell and never behind `voxel`.
IRGRID_HD inline Voxel next_voxel(const GridInfo& info, const Ray& ray, const Cell& cell,
                                  Voxel voxel, float t_exit, unsigned exit_axes) {
  Voxel next = voxel;
  for (int a = 0; a < 3; ++a) {
    const float d = ray.dir[a];
    if (exit_axes >> a & 1) {
      next[a] = d > 0 ? cell.hi[a] : cell.lo[a] - 1;
      continue;
    }
    if (d == 0.f) continue;
    std::int32_t v = world_to_voxel(info, a, ray.org[a] + t_exit * d);
    v = v < cell.lo[a] ? cell.lo[a] : (v >= cell.hi[a] ? cell.hi[a] - 1 : v);
    next[a] = d > 0 ? (v > voxel[a] ? v : voxel[a]) : (v < voxel[a] ? v : voxel[a]);
  }
  return next;
}

/// Traces one ray. Closest hit: the nearest triangle in [tmin, tmax]; any hit: the first found.
/// CellT picks the cell layout the view holds (Cell or CompactCell); the walk is the same.
template <Query kQuery, typename CellT = Cell>
IRGRID_HD inline Hit traverse_grid(const GridView& grid, const Ray& ray,
                                   TraversalCounters* counters = nullptr) {
  Hit best{kNoHit, ray.tmax, 0.f, 0.f};
  const Vec3<float> inv_dir{1.f / ray.dir[0], 1.f / ray.dir[1], 1.f / ray.dir[2]};
  float t_enter, t_leave;
  clip_to_grid(grid.info, ray, inv_dir, t_enter, t_leave);
  if (!(t_enter <= t_leave)) return Hit{};
  const auto shear = make_watertight_ray<float>(ray);
  Voxel voxel;
  for (int a = 0; a < 3; ++a)
    voxel[a] = world_to_voxel(grid.info, a, ray.org[a] + t_enter * ray.dir[a]);
  const CellT* cells = cell_array<CellT>(grid);
  while (true) {
    const Cell cell = load_cell(cells, lookup_cell(grid.info, grid.entries, voxel));
    if (counters) ++counters->cells;
    float t_exit = t_leave;
    float t_axis[3];
    for (int a = 0; a < 3; ++a) {
      const float d = ray.dir[a];
      t_axis[a] =
          d == 0.f ? t_leave
                   : (voxel_to_world(grid.info, a, d > 0 ? cell.hi[a] : cell.lo[a]) - ray.org[a]) *
                         inv_dir[a];
      t_exit = min_fast(t_axis[a], t_exit);
    }
    TriangleHit<float> hit;
    for (std::uint32_t r = cell.begin; r < cell.end; ++r) {
      const std::uint32_t id = grid.refs[r];
      const TriangleVertices& tri = grid.triangles[id];
      if (counters) ++counters->triangles;
      if (!intersect_watertight(shear, tri.p0, tri.p1, tri.p2, float(INFINITY), hit)) continue;
      // Ties on t go to the smaller id, as in the brute force.
      if (hit.t > best.t || (hit.t == best.t && id > best.prim)) continue;
      best = {id, hit.t, hit.u, hit.v};
      if constexpr (kQuery == Query::any) return best;
    }
    if (best.prim != kNoHit && best.t <= t_exit) return best;
    if (!(t_exit < t_leave)) break;
    unsigned exit_axes = 0;
    for (int a = 0; a < 3; ++a)
      exit_axes |= (ray.dir[a] != 0.f && t_axis[a] == t_exit) ? 1u << a : 0u;
    voxel = next_voxel(grid.info, ray, cell, voxel, t_exit, exit_axes);
    bool inside = true;
    for (int a = 0; a < 3; ++a)
      inside &= voxel[a] >= 0 && voxel[a] < grid.info.virtual_dims[a];
    if (!inside) break;
  }
  return best.prim == kNoHit ? Hit{} : best;
}

}  // namespace irgrid
