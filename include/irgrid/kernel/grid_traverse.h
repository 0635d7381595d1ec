// irgrid/kernel/grid_traverse.h: stackless, ordered traversal of an irregular grid, for host and
// device.
//
// Pérard-Gayot et al. 2017, §4: find the cell of the ray's entry voxel in the voxel map, test its
// triangles, stop when the closest hit lies within the cell's exit distance, otherwise step to the
// voxel just past the cell's (expanded) exit box. Robustness: the exit axis advances in integers
// to the cell's far plane and no axis ever steps backwards, so the walk can neither stall nor skip
// a sliver of a cell; the remaining rounding of float positions is covered by the padding of the
// insertion test (GridInfo::padding).
#pragma once

#include <cstdint>

#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/triangle.h"
#include "irgrid/kernel/watertight.h"

namespace irgrid {

/// Read-only views of a grid's arrays, in the memory space of the code that traverses it.
struct GridView {
  GridInfo info;
  const Entry* entries;
  const Cell* cells;                 ///< full cells, or null when the grid is compressed
  const CompactCell* compact_cells;  ///< compressed cells (num_cells + 1), or null
  const std::uint32_t* refs;
  const TriangleVertices* triangles;
  /// Empty radii per top cell and octant (core/build/empty_space.h), or null: no leaps through
  /// empty space.
  const std::uint8_t* empty_radii;
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
/// t_enter > t_leave, and for rays that are not finite (ray_is_finite).
IRGRID_HD inline void clip_to_grid(const GridInfo& info, const Ray& ray, const Vec3<float>& inv_dir,
                                   float& t_enter, float& t_leave) {
  t_enter = ray.tmin;
  t_leave = ray.tmax;
  if (!ray_is_finite(ray)) {
    t_enter = 1.f, t_leave = 0.f;
    return;
  }
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

/// One ray's walk through the grid: its constants and the voxel of the cell it is in.
struct GridWalk {
  WatertightRay<float> shear;  ///< the triangle test's per-ray constants
  WalkRay walk;                ///< the cell walk's per-ray constants
  Voxel voxel;                 ///< a voxel of the current cell (its entry voxel)
  float t_leave;               ///< where the ray leaves the grid box, or its tmax
  Hit best;                    ///< closest hit so far (prim kNoHit: none; t starts at tmax)
};

/// Starts the walk of `ray`: false when it misses the grid box within [tmin, tmax].
IRGRID_HD inline bool begin_walk(const GridInfo& info, const Ray& ray, GridWalk& w) {
  const Vec3<float> inv_dir{1.f / ray.dir[0], 1.f / ray.dir[1], 1.f / ray.dir[2]};
  float t_enter;
  clip_to_grid(info, ray, inv_dir, t_enter, w.t_leave);
  if (!(t_enter <= w.t_leave)) return false;
  w.best = {kNoHit, ray.tmax, 0.f, 0.f};
  w.shear = make_watertight_ray<float>(ray);
  w.walk = make_walk_ray(info, ray, inv_dir);
  for (int a = 0; a < 3; ++a)  // a parallel axis stays at the origin (t_enter may be infinite)
    w.voxel[a] = voxel_at(
        info, a, w.walk.dir[a] == 0.f ? w.walk.org[a] : walk_position(info, w.walk, a, t_enter));
  return true;
}

/// Where the walk leaves a cell: the exit box's far plane per axis and the t of each (a
/// parallel axis is crossed at +infinity); t_exit is the nearest, capped at t_leave.
struct CellExit {
  std::int32_t far[3];
  float t_axis[3];
  float t_exit;
};

/// Where walk w leaves a box of voxels whose far plane on axis a is far[a].
IRGRID_HD inline CellExit exit_through(const GridWalk& w, const std::int32_t far[3]) {
  CellExit e;
  e.t_exit = w.t_leave;
  for (int a = 0; a < 3; ++a) {
    e.far[a] = far[a];
    e.t_axis[a] = float(far[a]) * w.walk.t_per_voxel[a] + w.walk.t_at_plane0[a];
    e.t_exit = min_fast(e.t_axis[a], e.t_exit);
  }
  return e;
}

/// Where walk w leaves `cell` (through the cell's exit box).
IRGRID_HD inline CellExit cell_exit(const GridWalk& w, const Cell& cell) {
  std::int32_t far[3];
  for (int a = 0; a < 3; ++a)
    far[a] = w.walk.ascending[a] ? cell.hi[a] : cell.lo[a];
  return exit_through(w, far);
}

/// Where walk w leaves the empty space ahead of it, when w is in a cell without references and
/// that is farther than e, the cell's exit: the cube of top cells from w's top cell towards the
/// octant of w's direction, as far as that octant's empty radius (core/build/empty_space.h),
/// clipped to the grid; none of its cells holds triangles. Nothing changes without radii
/// (grid.empty_radii null) or with radius 0. The step past the cube is the step past a cell
/// (step_past_cell): the cube, like an exit box, holds w's voxel, is made of whole voxels, and is
/// left through its far planes.
IRGRID_HD inline void leave_empty_space(const GridView& grid, const GridWalk& w, const Cell& cell,
                                        CellExit& e) {
  if (cell.begin != cell.end || !grid.empty_radii) return;
  const GridInfo& info = grid.info;
  const std::int32_t radius =
      grid.empty_radii[8 * top_entry_index(info, w.voxel) + walk_octant(w.walk.ascending)];
  if (radius == 0) return;  // an empty octree node in a top cell with triangles
  std::int32_t far[3];
  for (int a = 0; a < 3; ++a) {
    const std::int32_t top = w.voxel[a] >> info.shift;
    // Statements, not one conditional expression shifted: g++ 12 with -fsanitize=undefined
    // compiled that expression with the descending branch on ascending axes (the walk then
    // left the grid sideways and missed hits; GridTraversal.*WalksEqualSingleWalks).
    std::int32_t far_top;
    if (w.walk.ascending[a]) {
      far_top = top + radius;
      if (far_top > info.top_dims[a]) far_top = info.top_dims[a];
    } else {
      far_top = top - (radius - 1);
      if (far_top < 0) far_top = 0;
    }
    far[a] = far_top << info.shift;
  }
  const CellExit cube = exit_through(w, far);
  if (cube.t_exit > e.t_exit) e = cube;
}

/// Tests the triangles of references [begin, end) and keeps the closest hit in w.best (ties on t
/// go to the smaller id, as in the brute force). Any hit: true as soon as one is found.
template <Query kQuery>
IRGRID_HD inline bool test_cell_triangles(const GridView& grid, std::uint32_t begin,
                                          std::uint32_t end, GridWalk& w,
                                          TraversalCounters* counters) {
  TriangleHit<float> hit;
  for (std::uint32_t r = begin; r < end; ++r) {
    const std::uint32_t id = grid.refs[r];
    const TriangleVertices& tri = grid.triangles[id];
    if (counters) ++counters->triangles;
    if (!intersect_watertight(w.shear, tri.p0, tri.p1, tri.p2, float(INFINITY), hit)) continue;
    if (hit.t > w.best.t || (hit.t == w.best.t && id > w.best.prim)) continue;
    w.best = {id, hit.t, hit.u, hit.v};
    if constexpr (kQuery == Query::any) return true;
  }
  return false;
}

/// After a cell's triangles: false when the walk is over (the closest hit lies within the cell,
/// or the ray leaves the grid); otherwise moves w.voxel into the next cell.
IRGRID_HD inline bool step_past_cell(const GridInfo& info, const CellExit& e, GridWalk& w) {
  if (w.best.prim != kNoHit && w.best.t <= e.t_exit) return false;
  // t_exit is now finite and equals some t_axis exactly (min_fast skips NaN and keeps values).
  if (!(e.t_exit < w.t_leave)) return false;
  // Robust step: the exit axes jump in integers past the far plane, so the walk always
  // advances; the other axes follow the exit point, clamped to the cell's extent and never
  // stepping back, so no sliver of a cell is skipped.
  bool inside = true;
  for (int a = 0; a < 3; ++a) {
    const bool up = w.walk.ascending[a];
    std::int32_t v;
    if (e.t_axis[a] == e.t_exit) {
      v = up ? e.far[a] : e.far[a] - 1;
      inside &= std::uint32_t(v) < std::uint32_t(info.virtual_dims[a]);
    } else {
      v = voxel_at(info, a, walk_position(info, w.walk, a, e.t_exit));
      const std::int32_t at = w.voxel[a];
      v = up ? (v < at ? at : (v >= e.far[a] ? e.far[a] - 1 : v))
             : (v > at ? at : (v < e.far[a] ? e.far[a] : v));
    }
    w.voxel[a] = v;
  }
  return inside;
}

/// The walk's answer: its closest (or any) hit, or Hit{} when none.
IRGRID_HD inline Hit walk_result(const GridWalk& w) {
  return w.best.prim == kNoHit ? Hit{} : w.best;
}

/// Traces one ray. Closest hit: the nearest triangle in [tmin, tmax]; any hit: the first found.
/// CellT picks the cell layout the view holds (Cell or CompactCell); the walk is the same.
template <Query kQuery, typename CellT = Cell>
IRGRID_HD IRGRID_ALWAYS_INLINE Hit traverse_grid(const GridView& grid, const Ray& ray,
                                                 TraversalCounters* counters = nullptr) {
  GridWalk w;
  if (!begin_walk(grid.info, ray, w)) return Hit{};
  const CellT* cells = cell_array<CellT>(grid);
  while (true) {
    const Cell cell = load_cell(cells, lookup_cell(grid.info, grid.entries, w.voxel));
    if (counters) ++counters->cells;
    CellExit exit = cell_exit(w, cell);
    leave_empty_space(grid, w, cell, exit);
    if (test_cell_triangles<kQuery>(grid, cell.begin, cell.end, w, counters)) break;
    if (!step_past_cell(grid.info, exit, w)) break;
  }
  return walk_result(w);
}

}  // namespace irgrid
