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

/// Per-ray constants of the cell walk, in voxel units: world x maps to (x - box_lo) / voxel_size,
/// a per-axis scale, so the ray parameter t is the same in both spaces. The voxel plane v is
/// crossed at t = v * t_per_voxel + t_at_plane0, one multiply and one add per axis and step.
struct WalkRay {
  float org[3];          ///< origin in voxels
  float dir[3];          ///< the ray's direction (world units), 0 where parallel or flat
  float t_per_voxel[3];  ///< voxel_size x (1 / ray.dir), or 0 where parallel
  float t_at_plane0[3];  ///< t of plane 0, (box_lo - ray.org) x (1 / ray.dir), or +infinity
  bool ascending[3];     ///< dir >= 0: the walk leaves cells through their hi planes
};

/// inv_dir holds 1 / ray.dir per axis (shared with clip_to_grid: no divisions here).
IRGRID_HD inline WalkRay make_walk_ray(const GridInfo& info, const Ray& ray,
                                       const Vec3<float>& inv_dir) {
  WalkRay w;
  for (int a = 0; a < 3; ++a) {
    w.org[a] = (ray.org[a] - info.box_lo[a]) * info.inv_voxel_size[a];
    w.dir[a] = ray.dir[a];
    // The plane terms come from world values, so a huge direction cannot overflow them.
    const float t_per_voxel = info.voxel_size[a] * inv_dir[a];
    const float t_at_plane0 = (info.box_lo[a] - ray.org[a]) * inv_dir[a];
    // Parallel: a zero direction or a flat axis, or plane times beyond float range (a direction
    // too small to cross a voxel, or a plane too far away, within any representable t).
    const bool parallel = ray.dir[a] == 0.f || info.inv_voxel_size[a] == 0.f ||
                          !(t_per_voxel > -INFINITY && t_per_voxel < INFINITY) ||
                          !(t_at_plane0 > -INFINITY && t_at_plane0 < INFINITY);
    if (parallel) w.dir[a] = 0.f;
    w.t_per_voxel[a] = parallel ? 0.f : t_per_voxel;
    w.t_at_plane0[a] = parallel ? float(INFINITY) : t_at_plane0;
    w.ascending[a] = !(w.dir[a] < 0.f);
  }
  return w;
}

/// The walk's position at t on axis a, in voxels. The world displacement t x dir comes first: a
/// direction near the float limit would overflow in voxel units.
IRGRID_HD inline float walk_position(const GridInfo& info, const WalkRay& walk, int a, float t) {
  return walk.org[a] + (t * walk.dir[a]) * info.inv_voxel_size[a];
}

/// The voxel holding the walk position `p` (voxel units) on axis `a`, clamped to the grid; NaN
/// gives 0.
IRGRID_HD inline std::int32_t voxel_at(const GridInfo& info, int a, float p) {
  return std::int32_t(min_fast(max_fast(p, 0.f), float(info.virtual_dims[a] - 1)));
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
  const WalkRay walk = make_walk_ray(grid.info, ray, inv_dir);
  Voxel voxel;
  for (int a = 0; a < 3; ++a)  // a parallel axis stays at the origin (t_enter may be infinite)
    voxel[a] =
        voxel_at(grid.info, a,
                 walk.dir[a] == 0.f ? walk.org[a] : walk_position(grid.info, walk, a, t_enter));
  const CellT* cells = cell_array<CellT>(grid);
  while (true) {
    const Cell cell = load_cell(cells, lookup_cell(grid.info, grid.entries, voxel));
    if (counters) ++counters->cells;
    // The exit box's far plane per axis; a parallel axis is crossed at +infinity.
    std::int32_t far[3];
    float t_axis[3], t_exit = t_leave;
    for (int a = 0; a < 3; ++a) {
      far[a] = walk.ascending[a] ? cell.hi[a] : cell.lo[a];
      t_axis[a] = float(far[a]) * walk.t_per_voxel[a] + walk.t_at_plane0[a];
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
    // t_exit is now finite and equals some t_axis exactly (min_fast skips NaN and keeps values).
    if (!(t_exit < t_leave)) break;
    // Robust step: the exit axes jump in integers past the far plane, so the walk always
    // advances; the other axes follow the exit point, clamped to the cell's extent and never
    // stepping back, so no sliver of a cell is skipped.
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      std::int32_t v;
      if (t_axis[a] == t_exit) {
        v = walk.ascending[a] ? far[a] : far[a] - 1;
        inside &= std::uint32_t(v) < std::uint32_t(grid.info.virtual_dims[a]);
      } else {
        v = voxel_at(grid.info, a, walk_position(grid.info, walk, a, t_exit));
        v = walk.ascending[a] ? (v < voxel[a] ? voxel[a] : (v >= far[a] ? far[a] - 1 : v))
                              : (v > voxel[a] ? voxel[a] : (v < far[a] ? far[a] : v));
      }
      voxel[a] = v;
    }
    if (!inside) break;
  }
  return best.prim == kNoHit ? Hit{} : best;
}

}  // namespace irgrid
