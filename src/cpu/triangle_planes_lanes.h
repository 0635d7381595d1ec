// cpu/triangle_planes_lanes.h: triangle_planes_of (cpu/triangle_planes.h) written once over the
// lane operations V of an instruction set (cpu/simd_lanes_avx2.h, cpu/simd_lanes_avx512.h), one
// triangle per lane. cpu/build_lanes_avx2.cpp and build_lanes_avx512.cpp include this after
// their target pragma.
//
// Every lane-wise line mirrors one of triangle_planes, far_plane, apart_above_plane,
// apart_below_plane, floor_to_int or voxel_to_world (core/construction/expand_face.h,
// irgrid/kernel/grid_layout.h) with the same float operations in the same order (no FMA:
// -ffp-contract=off). min_fast(a, b) = a < b ? a : b is V::min(a, b) and max_fast V::max, with
// the same answer on NaN; a negated comparison !(a < b) is the unordered NLT predicate, true on
// NaN as the scalar negation is. Each scalar `while (condition) step;` becomes: the lanes where
// the condition holds step, and drop out once it fails for them.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace irgrid::simd {

template <class V>
struct TrianglePlanesLanes {
  static constexpr int L = V::kLanes;
  using F = typename V::F;
  using I = typename V::I;
  using M = typename V::M;

  template <int kPredicate>
  static M compare(F a, F b) {
    return V::template compare<kPredicate>(a, b);
  }

  /// floor_to_int, lane-wise (x within the int32 range).
  static I floor_to_int(F x) {
    const I truncated = V::truncate(x);
    return V::select(compare<_CMP_GT_OQ>(V::to_float(truncated), x), truncated,
                     V::sub(truncated, V::splat(1)));
  }

  /// The constants of one axis: voxel_to_world's and the comparisons' operands.
  struct Axis {
    F box_lo, size, inv, margin;
    std::int32_t dims;
  };

  static F voxel_to_world(const Axis& x, I v) {
    return V::add(x.box_lo, V::mul(V::to_float(v), x.size));
  }

  /// v stepped by `step` in the lanes of `active` while condition(v) holds in them.
  template <typename Condition>
  static I step_while(I v, std::int32_t step, M active, Condition condition) {
    active = V::both(active, condition(v));
    while (V::any(active)) {
      v = V::select(active, v, V::add(v, V::splat(step)));
      active = V::both(active, condition(v));
    }
    return v;
  }

  /// clamp_to_dims, lane-wise.
  static I clamp_to_dims(I v, std::int32_t dims) {
    v = V::select(V::greater(V::splat(0), v), v, V::splat(0));
    return V::select(V::greater(v, V::splat(dims)), v, V::splat(dims));
  }

  /// One axis of triangle_planes for the lanes of `valid`: up, down, before and after.
  static void axis(const Axis& x, F lo, F hi, M valid, I (&planes)[4]) {
    const I dims = V::splat(x.dims), zero = V::splat(0);
    // up: far_plane<+1> from face -1 with limit dims + 1.
    const F lo_at = V::mul(V::sub(V::sub(lo, x.margin), x.box_lo), x.inv);
    I up = floor_to_int(V::min(V::max(lo_at, V::splat(-1.f)), V::splat(float(x.dims))));
    up = step_while(up, -1, valid, [&](I p) {
      return V::both(V::greater(p, V::splat(-1)),
                     compare<_CMP_NLT_UQ>(V::add(voxel_to_world(x, p), x.margin), lo));
    });
    // down: far_plane<-1> from face dims + 1 with limit dims + 2.
    const F hi_at = V::mul(V::sub(V::add(hi, x.margin), x.box_lo), x.inv);
    I down = V::add(floor_to_int(V::max(V::min(hi_at, V::splat(float(x.dims))), V::splat(-2.f))),
                    V::splat(1));
    down = step_while(down, +1, valid, [&](I p) {
      return V::both(V::greater(V::splat(x.dims + 1), p),
                     compare<_CMP_NGT_UQ>(V::sub(voxel_to_world(x, p), x.margin), hi));
    });
    // before: apart_above_plane(lo, h) is lo - 2 padding > voxel_to_world(h).
    const F lo_less = V::sub(lo, x.margin);
    I before = floor_to_int(V::min(V::max(lo_at, V::splat(0.f)), V::splat(float(x.dims))));
    before = step_while(before, +1, valid, [&](I h) {
      return V::both(V::greater(dims, h),
                     compare<_CMP_GT_OQ>(lo_less, voxel_to_world(x, V::add(h, V::splat(1)))));
    });
    before = step_while(before, -1, valid, [&](I h) {
      return V::both(V::greater(h, zero), compare<_CMP_NGT_UQ>(lo_less, voxel_to_world(x, h)));
    });
    // after: apart_below_plane(hi, l) is hi + 2 padding < voxel_to_world(l).
    const F hi_more = V::add(hi, x.margin);
    I after = floor_to_int(V::min(V::max(hi_at, V::splat(0.f)), V::splat(float(x.dims))));
    after = step_while(after, -1, valid, [&](I l) {
      return V::both(V::greater(l, zero),
                     compare<_CMP_LT_OQ>(hi_more, voxel_to_world(x, V::sub(l, V::splat(1)))));
    });
    after = step_while(after, +1, valid, [&](I l) {
      return V::both(V::greater(dims, l), compare<_CMP_NLT_UQ>(hi_more, voxel_to_world(x, l)));
    });
    planes[0] = clamp_to_dims(up, x.dims);
    planes[1] = clamp_to_dims(down, x.dims);
    planes[2] = before;
    planes[3] = after;
  }

  static void planes_of(const GridInfo& info, const TriangleVertices* triangles,
                        std::uint32_t count, expand_detail::TrianglePlanes* out) {
    Axis axes[3];
    for (int a = 0; a < 3; ++a)
      axes[a] = {V::splat(info.box_lo[a]), V::splat(info.voxel_size[a]),
                 V::splat(info.inv_voxel_size[a]), V::splat(2.f * info.padding),
                 info.virtual_dims[a]};
    // A lane's corner coordinates lie 9 floats after the previous lane's.
    const I corner = V::mul(V::lane_index(), V::splat(9));
    for (std::uint32_t first = 0; first < count; first += L) {
      const std::uint32_t n = count - first < std::uint32_t(L) ? count - first : std::uint32_t(L);
      const M valid = V::lanes((1u << n) - 1);  // n <= 16
      const float* coords = &triangles[first].p0.x;
      alignas(64) std::int32_t lanes[12][L];
      for (int a = 0; a < 3; ++a) {
        const F p0 = V::gather(coords, V::add(corner, V::splat(a)), valid);
        const F p1 = V::gather(coords, V::add(corner, V::splat(3 + a)), valid);
        const F p2 = V::gather(coords, V::add(corner, V::splat(6 + a)), valid);
        // min3 and max3: min_fast(a, min_fast(b, c)).
        const F lo = V::min(p0, V::min(p1, p2)), hi = V::max(p0, V::max(p1, p2));
        I planes[4];
        axis(axes[a], lo, hi, valid, planes);
        for (int k = 0; k < 4; ++k)
          V::store(lanes[3 * k + a], planes[k]);
      }
      for (std::uint32_t l = 0; l < n; ++l) {
        expand_detail::TrianglePlanes& p = out[first + l];
        for (int a = 0; a < 3; ++a) {
          p.up[a] = std::uint16_t(lanes[a][l]);
          p.down[a] = std::uint16_t(lanes[3 + a][l]);
          p.before[a] = std::uint16_t(lanes[6 + a][l]);
          p.after[a] = std::uint16_t(lanes[9 + a][l]);
        }
      }
    }
  }
};

}  // namespace irgrid::simd
