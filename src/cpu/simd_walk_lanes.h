// cpu/simd_walk_lanes.h: the SIMD walk of cpu/simd_walk.h, written once over the lane
// operations V of an instruction set (cpu/simd_lanes_avx2.h: 8 lanes, cpu/simd_lanes_avx512.h:
// 16 lanes). Each instruction set's file includes this after its target pragma and instantiates
// it with its V, so every function here is compiled for that instruction set alone.
//
// Every lane-wise operation below mirrors one line of irgrid/kernel/grid_traverse.h or
// irgrid/kernel/watertight.h with the same float operations in the same order (no FMA:
// -ffp-contract=off), and V::min / V::max return their second operand on NaN exactly as min_fast(a,
// b) = a < b ? a : b does.
#pragma once

#include <immintrin.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "cpu/map_lookup_lanes.h"
#include "cpu/prefetch_triangle.h"
#include "cpu/staged_hits.h"
#include "irgrid/accelerator.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid::simd {

/// The walk of groups of V::kLanes rays, one per lane, kGroups groups per thread.
template <class V, int kGroups>
struct LaneWalk {
  static constexpr int L = V::kLanes;
  static constexpr int G = kGroups;
  using F = typename V::F;
  using I = typename V::I;
  using M = typename V::M;

  template <int kPredicate>
  static M compare(F a, F b) {
    return V::template compare<kPredicate>(a, b);
  }

  /// The walks' per-ray values, one array slot per lane (structure of arrays). Every member is
  /// a row of L 4-byte values, so walks move between them as whole rows (move_lanes).
  struct alignas(64) Lanes {
    float org[3][L];               // WalkRay::org
    float dir[3][L];               // WalkRay::dir
    float t_per_voxel[3][L];       // WalkRay::t_per_voxel
    float t_at_plane0[3][L];       // WalkRay::t_at_plane0
    std::int32_t ascending[3][L];  // WalkRay::ascending, as -1 (true) or 0
    std::int32_t voxel[3][L];      // GridWalk::voxel
    float t_leave[L];
    float best_t[L], best_u[L], best_v[L];  // GridWalk::best
    std::int32_t best_prim[L];
    float org_k[3][L];        // WatertightRay::org_k
    float shear[3][L];        // WatertightRay::sx, sy, sz
    float tmin[L], tmax[L];   // WatertightRay::tmin, tmax
    std::int32_t axis[3][L];  // WatertightRay::kx, ky, kz
  };
  static constexpr std::size_t kLaneRows = sizeof(Lanes) / (4 * L);
  static_assert(sizeof(Lanes) == kLaneRows * 4 * L, "Lanes holds rows of L 4-byte values only");

  /// Moves walks from `from` into `to`: lane l of `to` takes slot source[l] of `from`, for the
  /// lanes of `taking`. Whole rows, one permute and blend each: copying lane by lane, with 4-byte
  /// stores into rows read back whole, took a quarter of the walk on short (random) rays.
  static void move_lanes(Lanes& to, const Lanes& from, I source, M taking) {
    auto* t = reinterpret_cast<std::int32_t*>(&to);
    const auto* f = reinterpret_cast<const std::int32_t*>(&from);
#pragma GCC unroll 64
    for (std::size_t row = 0; row < kLaneRows; ++row)
      V::store(t + row * L,
               V::select(taking, V::load(t + row * L), V::permute(V::load(f + row * L), source)));
  }

  /// The cell each lane is in, per round.
  struct alignas(64) LaneCells {
    std::int32_t lo[3][L], hi[3][L];  // exit box
    std::int32_t begin[L], end[L];    // references
    std::int32_t empty_radius[L];     // of the top cell in the walk's octant; 0: no leap
  };

  /// Per lane: v[k] for k in 0..2.
  static F pick(const F v[3], I k) {
    return V::select(V::equal(k, V::splat(2)), V::select(V::equal(k, V::splat(1)), v[0], v[1]),
                     v[2]);
  }

  /// walk_position, lane-wise: the walk position at t on axis a, in voxels.
  static F walk_position(const GridInfo& info, int a, F walk_org, F walk_dir, F t) {
    return V::add(walk_org, V::mul(V::mul(t, walk_dir), V::splat(info.inv_voxel_size[a])));
  }
  /// voxel_at, lane-wise: the voxel holding position p on axis a, clamped to the grid.
  static I voxel_at(const GridInfo& info, int a, F p) {
    return V::truncate(V::min(V::max(p, V::splat(0.f)), V::splat(float(info.virtual_dims[a] - 1))));
  }

  /// Per field of RayFields: lane l's offset from the field of the group's first ray.
  struct FieldOffsets {
    I lane[RayFields::kFields];
    explicit FieldOffsets(const RayFields& rays) {
      for (int f = 0; f < RayFields::kFields; ++f)
        lane[f] = V::mul(V::lane_index(), V::splat(std::int32_t(rays.stride[f])));
    }
  };

  /// begin_walk, lane-wise, for the lanes of `starting`: lane l begins ray `first` + l of
  /// `rays` (read with gathers at `offsets`). Writes the walks into s and returns the lanes whose
  /// ray enters the grid (where begin_walk returns true); the other lanes of s hold no walk.
  /// kRecords: the rays are Ray records (all fields from one base, 8 floats apart).
  template <bool kRecords>
  static M begin_walks(const GridInfo& info, const RayFields& rays, const FieldOffsets& offsets,
                       std::size_t first, Lanes& s, M starting) {
    const auto read = [&](int f) {
      if constexpr (kRecords)
        return V::gather(rays.base[0] + 8 * first, V::add(offsets.lane[0], V::splat(f)), starting);
      return V::gather(rays.base[f] + first * rays.stride[f], offsets.lane[f], starting);
    };
    const F org[3] = {read(0), read(1), read(2)}, tmin = read(3);
    const F dir[3] = {read(4), read(5), read(6)}, tmax = read(7);
    const F zero = V::splat(0.f), one = V::splat(1.f), infinity = V::splat(INFINITY);
    F inv_dir[3];
    for (int a = 0; a < 3; ++a)
      inv_dir[a] = V::div(one, dir[a]);
    // clip_to_grid
    F t_enter = tmin, t_leave = tmax;
    for (int a = 0; a < 3; ++a) {
      const F lo = V::splat(info.box_lo[a]), hi = V::splat(info.box_hi[a]);
      const M flat = compare<_CMP_EQ_OQ>(dir[a], zero);
      const M outside = V::either(compare<_CMP_LT_OQ>(org[a], lo), compare<_CMP_GT_OQ>(org[a], hi));
      const F t0 = V::mul(V::sub(lo, org[a]), inv_dir[a]);
      const F t1 = V::mul(V::sub(hi, org[a]), inv_dir[a]);
      const M swap = compare<_CMP_GT_OQ>(t0, t1);
      const F near = V::select(swap, t0, t1), far = V::select(swap, t1, t0);
      const M missed = V::both(flat, outside);
      t_enter = V::select(flat, V::max(near, t_enter), V::select(missed, t_enter, one));
      t_leave = V::select(flat, V::min(far, t_leave), V::select(missed, t_leave, zero));
    }
    // ray_is_finite: x - x is 0 only for finite x.
    M finite = starting;
    for (int a = 0; a < 3; ++a)
      finite = V::both(finite, V::both(compare<_CMP_EQ_OQ>(V::sub(org[a], org[a]), zero),
                                       compare<_CMP_EQ_OQ>(V::sub(dir[a], dir[a]), zero)));
    const M enters = V::both(finite, compare<_CMP_LE_OQ>(t_enter, t_leave));
    // make_watertight_ray
    F magnitude[3];
    for (int a = 0; a < 3; ++a)
      magnitude[a] = V::select(compare<_CMP_LT_OQ>(dir[a], zero), dir[a], V::sub(zero, dir[a]));
    const M x_largest = V::both(compare<_CMP_GE_OQ>(magnitude[0], magnitude[1]),
                                compare<_CMP_GE_OQ>(magnitude[0], magnitude[2]));
    const M y_over_z = compare<_CMP_GE_OQ>(magnitude[1], magnitude[2]);
    const I c0 = V::splat(0), c1 = V::splat(1), c2 = V::splat(2);
    const I kz = V::select(x_largest, V::select(y_over_z, c2, c1), c0);
    const I kx0 = V::select(V::equal(kz, c2), V::add(kz, c1), c0);
    const I ky0 = V::select(V::equal(kx0, c2), V::add(kx0, c1), c0);
    const F dir_z = pick(dir, kz);
    const M flip = compare<_CMP_LT_OQ>(dir_z, zero);
    const I kx = V::select(flip, kx0, ky0), ky = V::select(flip, ky0, kx0);
    const F shear[3] = {V::div(pick(dir, kx), dir_z), V::div(pick(dir, ky), dir_z),
                        V::div(one, dir_z)};
    const I axis[3] = {kx, ky, kz};
    for (int k = 0; k < 3; ++k) {
      V::store(s.org_k[k], pick(org, axis[k]));
      V::store(s.shear[k], shear[k]);
      V::store(s.axis[k], axis[k]);
    }
    V::store(s.tmin, tmin);
    V::store(s.tmax, tmax);
    V::store(s.t_leave, t_leave);
    V::store(s.best_t, tmax);
    V::store(s.best_u, zero);
    V::store(s.best_v, zero);
    V::store(s.best_prim, V::splat(std::int32_t(kNoHit)));
    // make_walk_ray, then the entry voxel
    for (int a = 0; a < 3; ++a) {
      const F walk_org =
          V::mul(V::sub(org[a], V::splat(info.box_lo[a])), V::splat(info.inv_voxel_size[a]));
      const F t_per_voxel = V::mul(V::splat(info.voxel_size[a]), inv_dir[a]);
      const F t_at_plane0 = V::mul(V::sub(V::splat(info.box_lo[a]), org[a]), inv_dir[a]);
      const F minus_infinity = V::splat(-INFINITY);
      const auto finite = [&](F v) {
        return V::both(compare<_CMP_GT_OQ>(v, minus_infinity), compare<_CMP_LT_OQ>(v, infinity));
      };
      const M flat_axis = info.inv_voxel_size[a] == 0.f ? V::all_lanes() : V::no_lanes();
      const M parallel =
          V::either(V::either(compare<_CMP_EQ_OQ>(dir[a], zero), flat_axis),
                    V::but_not(V::both(finite(t_per_voxel), finite(t_at_plane0)), V::all_lanes()));
      const F walk_dir = V::select(parallel, dir[a], zero);
      V::store(s.org[a], walk_org);
      V::store(s.dir[a], walk_dir);
      V::store(s.t_per_voxel[a], V::select(parallel, t_per_voxel, zero));
      V::store(s.t_at_plane0[a], V::select(parallel, t_at_plane0, infinity));
      V::store(s.ascending[a], V::as_int(compare<_CMP_NLT_UQ>(walk_dir, zero)));
      const F position = V::select(compare<_CMP_EQ_OQ>(walk_dir, zero),
                                   walk_position(info, a, walk_org, walk_dir, t_enter), walk_org);
      V::store(s.voxel[a], voxel_at(info, a, position));
    }
    return enters;
  }

  /// Field `kOffset` (in bytes) of the structs of `kStride` bytes at `base`, for the cells
  /// `index` of the lanes of `mask` (0 elsewhere).
  template <int kOffset, int kStride>
  static I gather_field(const void* base, I index, M mask) {
    static_assert(kStride % 8 == 0, "gathers scale indices by at most 8");
    const void* field = static_cast<const char*>(base) + kOffset;
    const I scaled = V::mul(index, V::splat(kStride / 8));
    return V::template gather<8>(V::splat(0), field, scaled, mask);
  }

  /// load_cell, lane-wise: the cells `index` of the lanes of `mask` into c.
  static void load_cells(const Cell* cells, I index, M mask, LaneCells& c) {
    static_assert(offsetof(Cell, begin) == 12 && offsetof(Cell, hi) == 16 &&
                  offsetof(Cell, end) == 28 && sizeof(Cell) == 32);
    V::store(c.lo[0], gather_field<0, 32>(cells, index, mask));
    V::store(c.lo[1], gather_field<4, 32>(cells, index, mask));
    V::store(c.lo[2], gather_field<8, 32>(cells, index, mask));
    V::store(c.begin, gather_field<12, 32>(cells, index, mask));
    V::store(c.hi[0], gather_field<16, 32>(cells, index, mask));
    V::store(c.hi[1], gather_field<20, 32>(cells, index, mask));
    V::store(c.hi[2], gather_field<24, 32>(cells, index, mask));
    V::store(c.end, gather_field<28, 32>(cells, index, mask));
  }
  static void load_cells(const CompactCell* cells, I index, M mask, LaneCells& c) {
    static_assert(offsetof(CompactCell, hi) == 6 && offsetof(CompactCell, begin) == 12 &&
                  sizeof(CompactCell) == 16);
    const I low16 = V::splat(0xffff);
    const I lo01 = gather_field<0, 16>(cells, index, mask);  // lo[0], lo[1]
    const I lo2hi0 = gather_field<4, 16>(cells, index, mask);
    const I hi12 = gather_field<8, 16>(cells, index, mask);
    V::store(c.lo[0], V::bit_and(lo01, low16));
    V::store(c.lo[1], V::template shift_right_logical<16>(lo01));
    V::store(c.lo[2], V::bit_and(lo2hi0, low16));
    V::store(c.hi[0], V::template shift_right_logical<16>(lo2hi0));
    V::store(c.hi[1], V::bit_and(hi12, low16));
    V::store(c.hi[2], V::template shift_right_logical<16>(hi12));
    V::store(c.begin, gather_field<12, 16>(cells, index, mask));
    V::store(c.end, gather_field<16 + 12, 16>(cells, index, mask));  // the next cell's begin
  }

  /// cell_exit, lane-wise: the far plane and its t per axis, and the nearest t capped at
  /// t_leave.
  struct LaneExit {
    I far[3];
    F t_axis[3];
    F t_exit;
  };

  /// exit_through, lane-wise: where each lane leaves a box whose far plane on axis a is far[a].
  static LaneExit exit_through(const Lanes& s, const I far[3]) {
    LaneExit e;
    e.t_exit = V::load(s.t_leave);
    for (int a = 0; a < 3; ++a) {
      e.far[a] = far[a];
      e.t_axis[a] =
          V::add(V::mul(V::to_float(far[a]), V::load(s.t_per_voxel[a])), V::load(s.t_at_plane0[a]));
      e.t_exit = V::min(e.t_axis[a], e.t_exit);
    }
    return e;
  }

  /// cell_exit, then leave_empty_space for the lanes in empty cells with an empty radius.
  static LaneExit cell_exits(const GridInfo& info, const Lanes& s, const LaneCells& c) {
    M up[3];
    I far[3];
    for (int a = 0; a < 3; ++a) {
      up[a] = V::as_mask(V::load(s.ascending[a]));
      far[a] = V::select(up[a], V::load(c.lo[a]), V::load(c.hi[a]));
    }
    LaneExit e = exit_through(s, far);
    const I zero = V::splat(0), radius = V::load(c.empty_radius);
    const M leaps = V::both(V::greater(radius, zero), V::equal(V::load(c.begin), V::load(c.end)));
    if (!V::any(leaps)) return e;
    const I shift = V::splat(info.shift);
    for (int a = 0; a < 3; ++a) {
      const I top = V::shift_right(V::load(s.voxel[a]), info.shift);
      const I hi = V::add(top, radius), lo = V::sub(top, V::sub(radius, V::splat(1)));
      const I dims = V::splat(info.top_dims[a]);
      far[a] = V::shift_left(V::select(up[a], V::select(V::greater(lo, zero), zero, lo),
                                       V::select(V::greater(dims, hi), dims, hi)),
                             shift);
    }
    const LaneExit cube = exit_through(s, far);
    const M wider = V::both(leaps, compare<_CMP_GT_OQ>(cube.t_exit, e.t_exit));
    for (int a = 0; a < 3; ++a) {
      e.far[a] = V::select(wider, e.far[a], cube.far[a]);
      e.t_axis[a] = V::select(wider, e.t_axis[a], cube.t_axis[a]);
    }
    e.t_exit = V::select(wider, e.t_exit, cube.t_exit);
    return e;
  }

  /// The triangle tests of one round, packed from the cells of all lanes, each lane's in its
  /// reference order: test p is triangle prim[p] against the ray of lane lane[p]. They run in
  /// batches of L.
  struct alignas(64) TestList {
    static constexpr int kCapacity = 16 * L;
    // Appends write whole rows of L, so each array has L slots of slack; slots past `size`
    // stay valid lanes for the permutes.
    std::int32_t lane[kCapacity + L] = {};
    std::uint32_t prim[kCapacity + L] = {};
    std::int32_t ordinal[kCapacity + L];  // the test's place among its cell's references
    int size = 0;

    /// Appends the tests of lane `l` against refs[k] for k < count (count <= L and <= the room
    /// left), with ordinals from `ordinal0`: one masked row, no branch.
    void append_row(int l, const std::uint32_t* refs, int count, int ordinal0) {
      const I slot = V::lane_index();
      const I ids = V::load_lanes(refs, V::greater(V::splat(count), slot));  // no overread
      V::store_unaligned(reinterpret_cast<std::int32_t*>(prim + size), ids);
      V::store_unaligned(lane + size, V::splat(l));
      V::store_unaligned(ordinal + size, V::add(slot, V::splat(ordinal0)));
      size += count;
    }
    /// append_row for any count <= the room left.
    void append(int l, const std::uint32_t* refs, int count, int ordinal0) {
      for (int j = 0; j < count; j += L)
        append_row(l, refs + j, count - j < L ? count - j : L, ordinal0 + j);
    }
  };
  /// The most references a cell may have for a round to list its tests in one go: L cells of
  /// this many fill the list (L references with AVX-512; 2 L with AVX2, whose 8 lanes would
  /// otherwise send every cell of 9 to 16 references down the slower path).
  static constexpr int kCellRefsInOneGo = TestList::kCapacity / L;
  static_assert(kCellRefsInOneGo >= L, "L cells of at most L references each fit the list");

  /// What the lane-wise triangle test found for a batch of tests, bit p for test first + p.
  struct alignas(64) BatchHits {
    float t[L], u[L], v[L];  // where `hits` has the bit: intersect_watertight's hit
    std::uint32_t hits;      // intersect_watertight returns true
    std::uint32_t scalar;    // left to the scalar test (an edge function is zero or not a number,
                             // or t may have cancelled)
  };

  /// A batch's rays, lane by lane: the WatertightRay values of each test's ray.
  struct BatchRays {
    I axis[3];  // kx, ky, kz
    F org_k[3], shear[3], tmin, tmax;
  };

  /// What intersect_lanes finds, in registers: t, u, v where `hit` has the lane.
  struct LaneHits {
    F t, u, v;
    M hit;     // intersect_watertight returns true
    M scalar;  // left to the scalar test
  };
  /// intersect_watertight, lane-wise, for the tests of the lanes of `slots`: each lane's triangle
  /// corners p[j] (x, y, z on the world axes kx, ky, kz of its ray, as shear_vertex reads them)
  /// against its ray, with the same operations in the same order. Tests whose edge functions are
  /// not all nonzero numbers, or whose t may have cancelled (t_needs_double), are left to the
  /// scalar test and its redos in double. Both ways of feeding tests (test_listed_triangles,
  /// test_one_triangle) end here, so they agree bit for bit. kEarlyMiss: when every lane of
  /// `slots` misses on the edge functions' signs alone, return at once, before the division
  /// and the t bound (only what hit lanes read is skipped). test_one_triangle takes it: its lanes
  /// test one triangle, which often lies beside all of their rays; a gathered batch's lanes test
  /// different triangles and rarely all miss (measured in docs/benchmarks.md).
  template <bool kEarlyMiss = false>
  static LaneHits intersect_lanes(const F (&px)[3], const F (&py)[3], const F (&pz)[3],
                                  const BatchRays& r, M slots) {
    F x[3], y[3], z[3], depth[3];
    for (int j = 0; j < 3; ++j) {  // shear_vertex for p0, p1, p2
      depth[j] = V::sub(pz[j], r.org_k[2]);
      x[j] = V::sub(V::sub(px[j], r.org_k[0]), V::mul(r.shear[0], depth[j]));
      y[j] = V::sub(V::sub(py[j], r.org_k[1]), V::mul(r.shear[1], depth[j]));
      z[j] = V::mul(r.shear[2], depth[j]);
    }
    // a = p0, b = p1, c = p2: u = c_x b_y - c_y b_x, v = a_x c_y - a_y c_x, w = b_x a_y - b_y a_x.
    const F u = V::sub(V::mul(x[2], y[1]), V::mul(y[2], x[1]));
    const F v = V::sub(V::mul(x[0], y[2]), V::mul(y[0], x[2]));
    const F w = V::sub(V::mul(x[1], y[0]), V::mul(y[1], x[0]));
    const F zero = V::splat(0.f);
    const M negative =
        V::either(V::either(compare<_CMP_LT_OQ>(u, zero), compare<_CMP_LT_OQ>(v, zero)),
                  compare<_CMP_LT_OQ>(w, zero));
    const M positive =
        V::either(V::either(compare<_CMP_GT_OQ>(u, zero), compare<_CMP_GT_OQ>(v, zero)),
                  compare<_CMP_GT_OQ>(w, zero));
    const M numbers = V::both(compare<_CMP_ORD_Q>(u, v), compare<_CMP_ORD_Q>(w, w));
    const M some_zero =
        V::either(V::either(compare<_CMP_EQ_OQ>(u, zero), compare<_CMP_EQ_OQ>(v, zero)),
                  compare<_CMP_EQ_OQ>(w, zero));
    // Mixed nonzero signs: a miss whatever the double redo would make of a zero.
    const M missed = V::both(V::both(negative, positive), numbers);
    M scalar = V::but_not(missed, V::either(some_zero, V::but_not(numbers, V::all_lanes())));
    if constexpr (kEarlyMiss) {
      if (!V::any(V::but_not(missed, slots))) return {u, u, u, V::no_lanes(), V::no_lanes()};
    }
    const F det = V::add(V::add(u, v), w);
    const F t_scaled = V::add(V::add(V::mul(u, z[0]), V::mul(v, z[1])), V::mul(w, z[2]));
    const F inv_det = V::div(V::splat(1.f), det);
    const F t = V::mul(t_scaled, inv_det);
    const M nonzero_det = compare<_CMP_NEQ_UQ>(det, zero);
    // Tests whose t may have cancelled go to the scalar test too (its redo of t in double).
    const M inside =
        V::both(V::both(slots, nonzero_det), V::but_not(V::either(missed, scalar), V::all_lanes()));
    if (V::any(inside))
      scalar = V::either(scalar, V::both(inside, t_needs_double<V>(x, y, z, depth, det, inv_det, t,
                                                                   r.tmin, r.tmax)));
    const M in_range =
        V::both(V::both(compare<_CMP_GE_OQ>(t, r.tmin), compare<_CMP_LE_OQ>(t, r.tmax)),
                V::both(compare<_CMP_LT_OQ>(t, V::splat(INFINITY)), nonzero_det));
    const M hit = V::but_not(V::either(missed, scalar), in_range);
    return {t, V::mul(v, inv_det), V::mul(w, inv_det), V::both(slots, hit), V::both(slots, scalar)};
  }

  /// intersect_lanes for tests first + p (p < count <= L, first a multiple of it) of `tests`:
  /// each against the ray of its lane, the triangles read with gathers.
  static void test_listed_triangles(const GridView& grid, const Lanes& s, const TestList& tests,
                                    int first, int count, BatchHits& out) {
    const M slots = V::lanes((1u << count) - 1);
    const float* coords = &grid.triangles[0].p0.x;
    const I lane = V::load(tests.lane + first);
    const I prim = V::load(reinterpret_cast<const std::int32_t*>(tests.prim + first));
    const I base = V::add(V::template shift_left<3>(prim), prim);  // 9 floats each
    // Each test takes its lane's ray constants.
    const auto ray_int = [&](const std::int32_t* v) { return V::permute(V::load(v), lane); };
    const auto ray_float = [&](const float* v) { return V::permute(V::load(v), lane); };
    BatchRays r;
    for (int k = 0; k < 3; ++k) {
      r.axis[k] = ray_int(s.axis[k]);
      r.org_k[k] = ray_float(s.org_k[k]);
      r.shear[k] = ray_float(s.shear[k]);
    }
    r.tmin = ray_float(s.tmin);
    r.tmax = ray_float(s.tmax);
    F px[3], py[3], pz[3];
    for (int j = 0; j < 3; ++j) {
      const I vertex = V::add(base, V::splat(3 * j));
      px[j] = V::gather(coords, V::add(vertex, r.axis[0]), slots);
      py[j] = V::gather(coords, V::add(vertex, r.axis[1]), slots);
      pz[j] = V::gather(coords, V::add(vertex, r.axis[2]), slots);
    }
    const LaneHits found = intersect_lanes(px, py, pz, r, slots);
    V::store(out.t, found.t);
    V::store(out.u, found.u);
    V::store(out.v, found.v);
    out.hits = V::bits(found.hit);
    out.scalar = V::bits(found.scalar);
  }

  /// The rays of a group's lanes as test_one_triangle reads them, with each lane's choice of
  /// world axis per ray axis (kx, ky, kz) as masks: one = 1, two = 2, neither = 0.
  struct alignas(64) LaneRays {
    BatchRays rays;
    M one[3], two[3];
  };
  static void load_lane_rays(const Lanes& s, LaneRays& out) {
    for (int k = 0; k < 3; ++k) {
      out.rays.axis[k] = V::load(s.axis[k]);
      out.rays.org_k[k] = V::load(s.org_k[k]);
      out.rays.shear[k] = V::load(s.shear[k]);
      out.one[k] = V::equal(out.rays.axis[k], V::splat(1));
      out.two[k] = V::equal(out.rays.axis[k], V::splat(2));
    }
    out.rays.tmin = V::load(s.tmin);
    out.rays.tmax = V::load(s.tmax);
  }

  /// intersect_lanes of one triangle against the ray of every lane of `lanes`: the coordinates
  /// are broadcast, not gathered (the test of rays that share a cell).
  static LaneHits test_one_triangle(const TriangleVertices& tri, const LaneRays& r, M lanes) {
    const Vec3<float>* corner[3] = {&tri.p0, &tri.p1, &tri.p2};
    F px[3], py[3], pz[3];
    for (int j = 0; j < 3; ++j) {
      const F world[3] = {V::splat(corner[j]->x), V::splat(corner[j]->y), V::splat(corner[j]->z)};
      F* on_axis[3] = {&px[j], &py[j], &pz[j]};
      for (int k = 0; k < 3; ++k)
        *on_axis[k] = V::select(r.two[k], V::select(r.one[k], world[0], world[1]), world[2]);
    }
    return intersect_lanes<true>(px, py, pz, r.rays, lanes);
  }

  /// intersect_watertight for lane l's ray, for the tests intersect_lanes leaves to it (with its
  /// redos in double).
  static bool scalar_test(const TriangleVertices& tri, const Lanes& s, int l,
                          TriangleHit<float>& hit) {
    const WatertightRay<float> ray{{s.org_k[0][l], s.org_k[1][l], s.org_k[2][l]},
                                   s.axis[0][l],
                                   s.axis[1][l],
                                   s.axis[2][l],
                                   s.shear[0][l],
                                   s.shear[1][l],
                                   s.shear[2][l],
                                   s.tmin[l],
                                   s.tmax[l]};
    return intersect_watertight(ray, tri.p0, tri.p1, tri.p2, float(INFINITY), hit);
  }

  /// step_past_cell, lane-wise, for lanes whose walk goes on; returns the lanes whose walk ends
  /// (the closest hit lies within the cell, or the ray leaves the grid).
  static M step_lanes(const GridInfo& info, Lanes& s, const LaneExit& e) {
    const F best_t = V::load(s.best_t);
    const M has_hit =
        V::but_not(V::equal(V::load(s.best_prim), V::splat(std::int32_t(kNoHit))), V::all_lanes());
    M ends = V::both(has_hit, compare<_CMP_LE_OQ>(best_t, e.t_exit));
    ends = V::either(ends, compare<_CMP_NLT_UQ>(e.t_exit, V::load(s.t_leave)));
    M outside = V::no_lanes();
    const I minus_one = V::splat(-1);
    for (int a = 0; a < 3; ++a) {
      const M up = V::as_mask(V::load(s.ascending[a]));
      const M is_exit = compare<_CMP_EQ_OQ>(e.t_axis[a], e.t_exit);
      const I far = e.far[a], far_below = V::add(far, minus_one);
      const I dims = V::splat(info.virtual_dims[a]);
      // The exit axis: past the far plane; outside the grid when not in [0, dims).
      const I jumped = V::select(up, far_below, far);
      // The other axes: voxel_at(walk_position(t_exit)), kept within the cell and never back.
      const I v =
          voxel_at(info, a, walk_position(info, a, V::load(s.org[a]), V::load(s.dir[a]), e.t_exit));
      const I at = V::load(s.voxel[a]);
      const I up_v =
          V::select(V::greater(at, v), V::select(V::greater(v, far_below), v, far_below), at);
      const I down_v = V::select(V::greater(v, at), V::select(V::greater(far, v), v, far), at);
      const I followed = V::select(up, down_v, up_v);
      V::store(s.voxel[a], V::select(is_exit, followed, jumped));
      const M in_grid = V::both(V::greater(jumped, minus_one), V::greater(dims, jumped));
      outside = V::either(outside, V::but_not(in_grid, is_exit));
    }
    return V::either(ends, outside);
  }

  /// One set of L walks in flight, with the cells and tests of its current round.
  struct alignas(64) Group {
    Lanes s{};
    LaneCells c{};
    TestList list;
    std::int32_t cells_visited[L] = {}, triangles_tested[L] = {};  // TraversalCounters
    std::uint32_t ray_of[L] = {};
    std::uint32_t active = 0;     // lanes with a walk
    std::uint32_t hit_lanes = 0;  // any hit: lanes that found one this round
    // This round's cells tested one triangle for all their lanes (plan_shared_tests), when the
    // round takes that way: the lanes in each, and its references.
    int shared_cells = 0;
    std::uint32_t shared_lanes[L];
    std::int32_t shared_begin[L], shared_count[L];
  };

  /// What a batch of gathered tests (test_listed_triangles) costs against a batch of one
  /// triangle for all lanes (test_one_triangle), whose corners are broadcast. Tuned on Sponza's
  /// camera rays on the Intel Xeon VM (1024 x 1024): 2 did best with 16 lanes (1, 3, 4 and 6
  /// were 1-18% slower) and with 8 (1 and 3 were 1-4% slower); more broadcast tests leave too
  /// many lanes idle.
  static constexpr int kGatheredBatchCost = 2;

  /// Plans this round's tests of `group` cell by cell, one triangle for all lanes in the cell,
  /// where that takes fewer batches, weighted by kGatheredBatchCost, than listing each lane's
  /// tests and gathering them (rays that share cells, as camera rays do). Returns whether it
  /// did; then the round's tests are not listed. Requests the planned triangles.
  static bool plan_shared_tests(const GridView& grid, Group& group, I cell_refs) {
    const LaneCells& c = group.c;
    alignas(64) std::int32_t count[L];
    V::store(count, cell_refs);
    const I begin = V::load(c.begin), end = V::load(c.end);
    std::uint32_t remaining = V::bits(V::greater(cell_refs, V::splat(0)));
    int cells = 0, broadcast_batches = 0, tests = 0;
    while (remaining != 0) {
      const int l = __builtin_ctz(remaining);
      const std::uint32_t same = V::bits(
          V::both(V::both(V::equal(begin, V::splat(c.begin[l])), V::equal(end, V::splat(c.end[l]))),
                  V::lanes(remaining)));
      group.shared_lanes[cells] = same;
      group.shared_begin[cells] = c.begin[l];
      group.shared_count[cells] = count[l];
      broadcast_batches += count[l];
      tests += count[l] * __builtin_popcount(same);
      remaining &= ~same;
      ++cells;
    }
    if (cells == 0 || broadcast_batches > kGatheredBatchCost * ((tests + L - 1) / L)) return false;
    group.shared_cells = cells;
    for (int cell = 0; cell < cells; ++cell) {
      const std::uint32_t* refs = grid.refs + group.shared_begin[cell];
      for (int k = 0; k < group.shared_count[cell]; ++k)
        prefetch_triangle(grid.triangles + refs[k]);
    }
    return true;
  }

  /// The cell of each active lane's voxel (lookup_cell, lane-wise), for every group: one gather
  /// per map level, then the cell's fields. The groups descend together, so that the gathers
  /// of one group wait for memory while the others' are in flight too.
  template <typename CellT>
  static void find_cells(const GridView& grid, const CellT* cells, Group (&groups)[G]) {
    using Map = MapLookupLanes<V>;
    const GridInfo& info = grid.info;
    const I zero = V::splat(0);
    I v[G][3], entry[G], level_shift[G];
    M inner[G];
    for (int g = 0; g < G; ++g) {
      const M active = V::lanes(groups[g].active);
      for (int a = 0; a < 3; ++a)
        v[g][a] = V::load(groups[g].s.voxel[a]);
      const I top = Map::top_entry_index(info, v[g]);
      entry[g] = V::template gather<4>(zero, grid.entries, top, active);
      level_shift[g] = V::splat(info.shift);
      inner[g] = Map::inner(entry[g], active);
      // Top cells with triangles store radius 0, so the radii are read for every active lane:
      // masking them by the entry would make this read wait for the entry's.
      I radius = zero;
      if (grid.empty_radii) {
        const Lanes& s = groups[g].s;
        const I octant = V::bit_or(V::bit_or(V::bit_and_not(V::load(s.ascending[0]), V::splat(1)),
                                             V::bit_and_not(V::load(s.ascending[1]), V::splat(2))),
                                   V::bit_and_not(V::load(s.ascending[2]), V::splat(4)));
        const I index = V::add(V::template shift_left<3>(top), octant);
        radius = V::bit_and(V::template gather<1>(zero, grid.empty_radii, index, active),
                            V::splat(0xff));
      }
      V::store(groups[g].c.empty_radius, radius);
    }
    for (bool descending = true; descending;) {
      descending = false;
      for (int g = 0; g < G; ++g) {
        if (!V::any(inner[g])) continue;
        descending = true;
        entry[g] = Map::descend(grid.entries, entry[g], v[g], level_shift[g], inner[g]);
        inner[g] = Map::inner(entry[g], inner[g]);
      }
    }
    for (int g = 0; g < G; ++g)
      load_cells(cells, Map::target(entry[g]), V::lanes(groups[g].active), groups[g].c);
    // The reference lists are read next, one group after another: requested here, the lists of
    // all groups are in flight at once. (Idle lanes request one too: that costs less than
    // picking the active ones.)
    for (int g = 0; g < G; ++g) {
      const LaneCells& c = groups[g].c;
#pragma GCC unroll 16
      for (int l = 0; l < L; ++l)
        __builtin_prefetch(grid.refs + std::uint32_t(c.begin[l]));
    }
  }

  /// How many batches of L rays ahead the walk requests the rays it will begin.
  static constexpr std::size_t kRaysAhead = 4;

  /// The memory the rays are read from: each field that a set of rays reads, once (Ray records
  /// keep all eight fields in one stream; numpy rows have one for the origins and directions),
  /// found once per call: looking for them before each prefetch cost 8% of random rays' walk.
  struct RayStreams {
    const float* base[4] = {};
    std::uint32_t stride[4] = {};
    int count = 0;
    explicit RayStreams(const RayFields& rays) {
      for (const int f : {0, 4, 3, 7}) {  // origins, directions, tmin, tmax
        if (rays.stride[f] == 0) continue;
        bool covered = false;  // by an earlier field of the same records
        for (int j = 0; j < count; ++j)
          covered |= stride[j] == rays.stride[f] && rays.base[f] >= base[j] &&
                     rays.base[f] < base[j] + stride[j];
        if (!covered) base[count] = rays.base[f], stride[count++] = rays.stride[f];
      }
    }
    /// Asks for the cache lines of rays [first, first + n).
    void prefetch(std::size_t first, std::size_t n) const {
      for (int k = 0; k < count; ++k) {
        const char* begin = reinterpret_cast<const char*>(base[k] + first * stride[k]);
        const std::size_t bytes = n * stride[k] * sizeof(float);
        for (std::size_t byte = 0; byte < bytes; byte += 64)
          __builtin_prefetch(begin + byte);
      }
    }
  };

  /// trace_simd_lanes of cpu/simd_walk.h.
  template <Query kQuery, typename CellT>
  static void trace(const GridView& grid, const RayFields& rays, const HitFields& hits,
                    std::span<RayWork> work, SimdRays lane_rays) {
    // Two copies of the walk: Hit records as the walk had them before the caller's arrays came
    // (3-5% of camera and random rays' speed hung on the difference), and staged fields.
    if (hits.records && is_records(rays)) {
      RecordHits out{hits.records};
      walk<kQuery, CellT, true>(grid, rays, out, work, lane_rays);
      return;
    }
    StagedHits out(hits, rays.size());
    walk<kQuery, CellT, false>(grid, rays, out, work, lane_rays);
    out.finish(rays.size());
  }

  /// Whether `rays` are Ray records: every field 8 floats apart, from consecutive addresses.
  static bool is_records(const RayFields& rays) {
    for (int f = 0; f < RayFields::kFields; ++f)
      if (rays.stride[f] != RayFields::kFields || rays.base[f] != rays.base[0] + f) return false;
    return true;
  }

  /// trace, with the hits going to `out` (RecordHits or StagedHits); kRecordRays: `rays` are
  /// Ray records (is_records).
  template <Query kQuery, typename CellT, bool kRecordRays, typename Out>
  static void walk(const GridView& grid, const RayFields& rays, Out& out, std::span<RayWork> work,
                   SimdRays lane_rays) {
    const bool packets = lane_rays == SimdRays::packets;
    const CellT* cells = cell_array<CellT>(grid);
    const TriangleVertices* triangles = grid.triangles;
    const bool counted = !work.empty();
    Group groups[G];
    const FieldOffsets offsets(rays);
    const RayStreams streams(rays);
    Lanes staged{};                  // walks begun ahead, L rays at a time
    std::size_t staged_first = 0;    // the ray of slot 0 of `staged`; slot k holds ray + k
    std::uint32_t staged_ready = 0;  // slots of `staged` whose ray enters the grid, not yet taken
    std::size_t next = 0;
    // Gives the lanes of `idle` in `group` the next rays that enter the grid; rays that miss it
    // are answered at once. Returns the lanes that got one.
    const auto start = [&](Group& group, std::uint32_t idle) {
      std::uint32_t started = 0;
      while (idle != 0) {
        if (staged_ready == 0) {
          if (next == rays.size()) break;
          const std::size_t count = rays.size() - next < L ? rays.size() - next : L;
          const std::uint32_t starting = (1u << count) - 1;
          // The rays a few batches ahead: their lane-wise reads would otherwise wait on memory.
          const std::size_t ahead = next + kRaysAhead * L;
          if (ahead < rays.size())
            streams.prefetch(ahead, rays.size() - ahead < L ? rays.size() - ahead : L);
          out.make_room(next, count);
          staged_ready = V::bits(
              begin_walks<kRecordRays>(grid.info, rays, offsets, next, staged, V::lanes(starting)));
          staged_first = next;
          for (std::uint32_t slot = 0; slot < count; ++slot) {
            if (staged_ready >> slot & 1) continue;
            out.write(next + slot, kNoHit, 0, 0, 0);
            if (counted) work[next + slot] = {};
          }
          next += count;
          continue;
        }
        // The k-th idle lane takes the k-th ready slot; all of them move at once, and nothing
        // is written lane by lane (rows read back whole would wait for such stores).
        std::uint32_t taken = 0, given = 0;
        for (std::uint32_t i = idle, r = staged_ready; i != 0 && r != 0; i &= i - 1, r &= r - 1) {
          taken |= i & (0u - i);
          given |= r & (0u - r);
        }
        const I source = V::pair_lanes(taken, given);
        const M moving = V::lanes(taken);
        move_lanes(group.s, staged, source, moving);
        auto* ray_of = reinterpret_cast<std::int32_t*>(group.ray_of);
        V::store(ray_of, V::select(moving, V::load(ray_of),
                                   V::add(V::splat(std::int32_t(staged_first)), source)));
        V::store(group.cells_visited, V::select(moving, V::load(group.cells_visited), V::splat(0)));
        V::store(group.triangles_tested,
                 V::select(moving, V::load(group.triangles_tested), V::splat(0)));
        idle &= ~taken;
        staged_ready &= ~given;
        started |= taken;
      }
      return started;
    };
    // Runs the listed tests of `group` and keeps each lane's closest (or any) hit.
    const auto run_tests = [&](Group& group) {
      Lanes& s = group.s;
      TestList& list = group.list;
      // All batches first, then their hits: a batch's hits decide branches, and looking at them
      // between batches would hold each batch back until the one before it had finished.
      BatchHits batches[TestList::kCapacity / L];
      for (int first = 0, b = 0; first < list.size; first += L, ++b)
        test_listed_triangles(grid, s, list, first, list.size - first < L ? list.size - first : L,
                              batches[b]);
      for (int first = 0, b = 0; first < list.size; first += L, ++b) {
        const BatchHits& batch = batches[b];
        // Only the tests that hit, or need the scalar test, are looked at one by one, in order.
        for (std::uint32_t bits = batch.hits | batch.scalar; bits != 0; bits &= bits - 1) {
          const int p = __builtin_ctz(bits);
          const int l = list.lane[first + p];
          if (kQuery == Query::any && (group.hit_lanes >> l & 1)) continue;
          const std::uint32_t id = list.prim[first + p];
          TriangleHit<float> hit{batch.t[p], batch.u[p], batch.v[p]};
          if ((batch.scalar >> p & 1) && !scalar_test(grid.triangles[id], s, l, hit)) continue;
          // As traverse_grid: the nearer hit, or the lower id at equal t.
          const float best_t = s.best_t[l];
          if (hit.t > best_t || (hit.t == best_t && id > std::uint32_t(s.best_prim[l]))) continue;
          s.best_t[l] = hit.t;
          s.best_u[l] = hit.u;
          s.best_v[l] = hit.v;
          s.best_prim[l] = std::int32_t(id);
          if constexpr (kQuery == Query::any) {
            group.hit_lanes |= 1u << l;
            group.triangles_tested[l] += list.ordinal[first + p] + 1;  // the tests up to this hit
          }
        }
      }
      list.size = 0;
    };
    // Runs the tests plan_shared_tests planned for `group`, in each cell's reference order, and
    // keeps each lane's closest (or any) hit.
    const auto run_shared_tests = [&](Group& group) {
      Lanes& s = group.s;
      LaneRays r;
      load_lane_rays(s, r);
      // run_tests' rule for the closest hit, lane-wise (each lane has one test per triangle), on
      // the best hits in registers: no branch on a test's outcome, so the tests of consecutive
      // triangles overlap.
      F best_t = V::load(s.best_t), best_u = V::load(s.best_u), best_v = V::load(s.best_v);
      I best_prim = V::load(s.best_prim);
      I tested = V::load(group.triangles_tested);
      const I no_hit = V::splat(std::int32_t(kNoHit));
      for (int cell = 0; cell < group.shared_cells; ++cell) {
        const std::uint32_t* refs = grid.refs + group.shared_begin[cell];
        M lanes = V::lanes(group.shared_lanes[cell]);
        for (int k = 0; k < group.shared_count[cell]; ++k) {
          if constexpr (kQuery == Query::any) {
            lanes = V::but_not(V::lanes(group.hit_lanes), lanes);
            if (!V::any(lanes)) break;
          }
          const std::uint32_t id = refs[k];
          LaneHits found = test_one_triangle(triangles[id], r, lanes);
          if (V::any(found.scalar)) {  // rare: edge functions of zero, or t in doubt
            alignas(64) float t[L], u[L], v[L];
            V::store(t, found.t);
            V::store(u, found.u);
            V::store(v, found.v);
            for (std::uint32_t bits = V::bits(found.scalar); bits != 0; bits &= bits - 1) {
              const int l = __builtin_ctz(bits);
              TriangleHit<float> hit{t[l], u[l], v[l]};
              if (!scalar_test(triangles[id], s, l, hit)) continue;
              t[l] = hit.t, u[l] = hit.u, v[l] = hit.v;
              found.hit = V::either(found.hit, V::lanes(1u << l));
            }
            found.t = V::load(t), found.u = V::load(u), found.v = V::load(v);
          }
          // Ids fit 31 bits, so `id` above the best one unsigned is: a best hit, with a lower id.
          const I ids = V::splat(std::int32_t(id));
          const M id_above = V::but_not(V::equal(best_prim, no_hit), V::greater(ids, best_prim));
          const M nearer = V::either(compare<_CMP_LT_OQ>(found.t, best_t),
                                     V::but_not(id_above, compare<_CMP_EQ_OQ>(found.t, best_t)));
          const M kept = V::both(found.hit, nearer);
          best_t = V::select(kept, best_t, found.t);
          best_u = V::select(kept, best_u, found.u);
          best_v = V::select(kept, best_v, found.v);
          best_prim = V::select(kept, best_prim, ids);
          if constexpr (kQuery == Query::any) {
            group.hit_lanes |= V::bits(kept);
            tested = V::add(tested, V::keep(kept, V::splat(k + 1)));  // the tests up to this hit
          }
        }
      }
      V::store(s.best_t, best_t);
      V::store(s.best_u, best_u);
      V::store(s.best_v, best_v);
      V::store(s.best_prim, best_prim);
      V::store(group.triangles_tested, tested);
      group.shared_cells = 0;
    };
    // Lists the tests of the cells of `group`, each lane's in its reference order, and requests
    // their triangles. Runs the tests early only when the list fills.
    const auto list_tests = [&](Group& group, I cell_refs) {
      if (packets && plan_shared_tests(grid, group, cell_refs)) return;
      const LaneCells& c = group.c;
      TestList& list = group.list;
      if (!V::any(V::greater(cell_refs, V::splat(kCellRefsInOneGo)))) {
        // The usual round: every cell has at most kCellRefsInOneGo references, and all fit the
        // list. The rows of each lane whose cell has references (most cells a ray crosses are
        // empty: skipping their rows beat writing every row without branches on Crown and
        // Conference), then the triangles of every listed test (slots past the size hold
        // earlier, valid ids).
        alignas(64) std::int32_t count[L];
        V::store(count, cell_refs);
        for (std::uint32_t bits = V::bits(V::greater(cell_refs, V::splat(0))); bits != 0;
             bits &= bits - 1) {
          const int l = __builtin_ctz(bits);
          if constexpr (kCellRefsInOneGo == L)
            list.append_row(l, grid.refs + c.begin[l], count[l], 0);
          else
            list.append(l, grid.refs + c.begin[l], count[l], 0);
        }
        for (int row = 0; row < list.size; row += L) {
#pragma GCC unroll 16
          for (int k = 0; k < L; ++k)
            prefetch_triangle(triangles + list.prim[row + k]);
        }
        return;
      }
      for (std::uint32_t bits = group.active; bits != 0; bits &= bits - 1) {
        const int l = __builtin_ctz(bits);
        const std::int32_t begin = c.begin[l], count = c.end[l] - begin;
        for (std::int32_t done = 0; done < count;) {
          if (kQuery == Query::any && (group.hit_lanes >> l & 1)) break;
          const int room = TestList::kCapacity - list.size;
          const int take = count - done < room ? count - done : room;
          const std::uint32_t* ids = list.prim + list.size;
          list.append(l, grid.refs + begin + done, take, done);
          for (int k = 0; k < take; ++k)
            prefetch_triangle(triangles + ids[k]);
          done += take;
          if (list.size == TestList::kCapacity) run_tests(group);
        }
      }
    };

    bool walking = false;
    for (Group& group : groups)
      walking |= (group.active = start(group, (1u << L) - 1)) != 0;
    while (walking) {
      // Every phase runs for all groups before the next phase, so that one group's loads are
      // in flight while another computes.
      find_cells(grid, cells, groups);
      LaneExit exit[G];
      I cell_refs[G];  // references per lane's cell, 0 in idle lanes
      for (int g = 0; g < G; ++g) {
        exit[g] = cell_exits(grid.info, groups[g].s, groups[g].c);
        groups[g].hit_lanes = 0;
        cell_refs[g] = V::sub(V::load(groups[g].c.end), V::load(groups[g].c.begin));
        list_tests(groups[g], cell_refs[g]);
      }
      walking = false;
      for (int g = 0; g < G; ++g) {
        Group& group = groups[g];
        if (group.active == 0) continue;
        if (group.list.size > 0) run_tests(group);
        if (group.shared_cells > 0) run_shared_tests(group);
        const M lanes = V::lanes(group.active);
        // Every listed test counts, except those past an any-hit query's hit (counted above).
        const M whole_cells =
            kQuery == Query::any ? V::but_not(V::lanes(group.hit_lanes), lanes) : lanes;
        V::store(group.triangles_tested,
                 V::add(V::load(group.triangles_tested), V::keep(whole_cells, cell_refs[g])));
        const std::uint32_t ended =
            (V::bits(step_lanes(grid.info, group.s, exit[g])) | group.hit_lanes) & group.active;
        V::store(group.cells_visited,
                 V::add(V::load(group.cells_visited), V::keep(lanes, V::splat(1))));
        const Lanes& s = group.s;
        for (std::uint32_t bits = ended; bits != 0; bits &= bits - 1) {
          const int l = __builtin_ctz(bits);
          const auto prim = std::uint32_t(s.best_prim[l]);
          const std::uint32_t ray = group.ray_of[l];
          out.write(ray, prim, s.best_t[l], s.best_u[l], s.best_v[l]);
          if (counted)
            work[ray] = {std::uint32_t(group.cells_visited[l]),
                         std::uint32_t(group.triangles_tested[l])};
        }
        if (!packets)
          group.active = (group.active & ~ended) | start(group, ended);
        else if ((group.active &= ~ended) == 0)
          group.active = start(group, (1u << L) - 1);
        walking |= group.active != 0;
      }
    }
  }
};

}  // namespace irgrid::simd
