// cpu/octant_masks_lanes.h: child_overlap_masks (cpu/octant_masks.h) written once over the lane
// operations V of an instruction set (cpu/simd_lanes_avx2.h, cpu/simd_lanes_avx512.h), one
// triangle per lane. cpu/build_lanes_avx2.cpp and build_lanes_avx512.cpp include this after their
// target pragma.
//
// Every lane-wise line mirrors one of child_overlap_mask (core/construction/octree_levels.h),
// octants_holding_vertex (irgrid/kernel/triangle.h) or octants_overlapped (core/triangle_box.h)
// with the same float operations in the same order (no FMA: -ffp-contract=off). The scalar
// helpers' answers on NaN and signed zeros are kept: min_of(a, b) = b < a ? b : a is
// V::min(b, a), min_fast(a, b) = a < b ? a : b is V::min(a, b), and negation multiplies by -1.
// The exact test ANDs its 13 axes' verdicts in one go where the scalar test stops once no
// candidate is left: the same mask either way.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace irgrid::simd {

template <class V>
struct OctantMaskLanes {
  static constexpr int L = V::kLanes;
  using F = typename V::F;
  using I = typename V::I;
  using M = typename V::M;

  template <int kPredicate>
  static M compare(F a, F b) {
    return V::template compare<kPredicate>(a, b);
  }
  static F min_of(F a, F b) { return V::min(b, a); }
  static F max_of(F a, F b) { return V::max(b, a); }
  static F negate(F x) { return V::mul(x, V::splat(-1.f)); }
  static F abs_of(F x) { return V::select(compare<_CMP_LT_OQ>(x, V::splat(0.f)), x, negate(x)); }
  /// `mask` with `bits` cleared in the lanes of m.
  static I clear_where(M m, I mask, std::int32_t bits) {
    return V::select(m, mask, V::bit_and(mask, V::splat(~bits)));
  }
  /// `mask` cut to `bits` in the lanes of m.
  static I keep_where(M m, I mask, std::int32_t bits) {
    return V::select(m, mask, V::bit_and(mask, V::splat(bits)));
  }

  /// dot_without<kZero>(a, b), lane-wise.
  template <int kZero>
  static F dot_without(const F (&a)[3], const F (&b)[3]) {
    if constexpr (kZero == 0)
      return V::add(V::mul(a[1], b[1]), V::mul(a[2], b[2]));
    else if constexpr (kZero == 1)
      return V::add(V::mul(a[0], b[0]), V::mul(a[2], b[2]));
    else if constexpr (kZero == 2)
      return V::add(V::mul(a[0], b[0]), V::mul(a[1], b[1]));
    else
      return V::add(V::add(V::mul(a[0], b[0]), V::mul(a[1], b[1])), V::mul(a[2], b[2]));
  }

  /// Triangles ids[k] (lanes of `valid`), corner i axis a in p[i][a].
  static void gather_corners(const TriangleVertices* triangles, I ids, M valid, F (&p)[3][3]) {
    const float* coords = &triangles[0].p0.x;
    const I base = V::add(V::template shift_left<3>(ids), ids);  // 9 floats each
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a)
        p[i][a] = V::gather(coords, V::add(base, V::splat(3 * i + a)), valid);
  }

  /// What child_overlap_mask settles before the exact test: `mask`, the children the
  /// triangle's padded box reaches, and `held`, those of them holding a vertex. The lanes of the
  /// result are settled with mask alone (one child or none, or every child holds a vertex).
  static M settle_cheaply(const NodeSplit& node, const F (&p)[3][3], I& mask, I& held) {
    const F padding = V::splat(node.padding);
    mask = V::splat(0xFF);
    for (int a = 0; a < 3; ++a) {
      const std::int32_t upper = std::int32_t(upper_octants(a));
      // triangle_box: min3 and max3 are min_fast and max_fast.
      const F lo = V::min(p[0][a], V::min(p[1][a], p[2][a]));
      const F hi = V::max(p[0][a], V::max(p[1][a], p[2][a]));
      const F mid = V::splat(node.mid[a]);
      mask = clear_where(compare<_CMP_LT_OQ>(V::add(hi, padding), mid), mask, upper);
      mask = keep_where(compare<_CMP_GT_OQ>(V::sub(lo, padding), mid), mask, upper);
    }
    const I zero = V::splat(0);
    const M single = V::equal(V::bit_and(mask, V::sub(mask, V::splat(1))), zero);
    held = zero;
    for (int i = 0; i < 3; ++i) {
      I in = V::splat(0xFF);
      for (int a = 0; a < 3; ++a) {
        const std::int32_t upper = std::int32_t(upper_octants(a));
        const F x = p[i][a];
        const M lower_half = V::both(compare<_CMP_GE_OQ>(x, V::splat(node.lo[a] - node.padding)),
                                     compare<_CMP_LE_OQ>(x, V::splat(node.mid[a] + node.padding)));
        const M upper_half = V::both(compare<_CMP_GE_OQ>(x, V::splat(node.mid[a] - node.padding)),
                                     compare<_CMP_LE_OQ>(x, V::splat(node.hi[a] + node.padding)));
        in = keep_where(V::but_not(lower_half, V::all_lanes()), in, upper);
        in = clear_where(V::but_not(upper_half, V::all_lanes()), in, upper);
      }
      held = V::bit_or(held, in);
    }
    held = V::bit_and(held, mask);
    return V::either(single, V::equal(held, mask));
  }

  /// The triangle in the frame of the octants' centre (octant_frame).
  struct Frame {
    F v[3][3];   // corner i minus the centre, axis a
    F reach[3];  // per axis
  };

  static Frame octant_frame(const triangle_box_detail::OctantBox<float>& b, const F (&p)[3][3]) {
    Frame f;
    const float floor = triangle_box_detail::smallest_normal<float>() /
                        triangle_box_detail::machine_epsilon<float>();
    for (int k = 0; k < 3; ++k) {
      for (int i = 0; i < 3; ++i)
        f.v[i][k] = V::sub(p[i][k], V::splat(b.center[k]));
      const F farthest = max_of(abs_of(f.v[0][k]), max_of(abs_of(f.v[1][k]), abs_of(f.v[2][k])));
      f.reach[k] = V::add(
          V::add(V::add(farthest, V::splat(b.farthest_offset[k])), V::splat(b.largest_half[k])),
          V::splat(floor));
    }
    return f;
  }

  /// The octants (bits) whose projections onto `axis` lie apart from the triangle's by more
  /// than rounding could explain (octants_not_separated_along's complement).
  template <int kZero>
  static I separated_along(const F (&axis)[3], const Frame& f,
                           const triangle_box_detail::OctantBox<float>& b) {
    using triangle_box_detail::machine_epsilon;
    using triangle_box_detail::smallest_normal;
    const F d0 = dot_without<kZero>(axis, f.v[0]), d1 = dot_without<kZero>(axis, f.v[1]),
            d2 = dot_without<kZero>(axis, f.v[2]);
    const F magnitude[3] = {abs_of(axis[0]), abs_of(axis[1]), abs_of(axis[2])};
    const F tolerance = V::add(
        V::mul(V::splat(8.f * machine_epsilon<float>()), dot_without<kZero>(magnitude, f.reach)),
        V::splat(16.f * smallest_normal<float>()));
    const F lowest = min_of(d0, min_of(d1, d2)), highest = max_of(d0, max_of(d1, d2));
    F shift[3][2], extent[3][2];
    for (int k = 0; k < 3; ++k)
      for (int side = 0; side < 2; ++side) {
        shift[k][side] = V::mul(axis[k], V::splat(b.offset[side][k]));
        extent[k][side] = V::mul(magnitude[k], V::splat(b.half[side][k]));
      }
    I separated = V::splat(0);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) {
        const F shift_xy = V::add(shift[0][x], shift[1][y]);
        const F extent_xy = V::add(extent[0][x], extent[1][y]);
        for (int z = 0; z < 2; ++z) {
          const F s = V::add(shift_xy, shift[2][z]);
          const F radius = V::add(extent_xy, extent[2][z]);
          const M apart =
              V::either(compare<_CMP_GT_OQ>(V::sub(V::sub(lowest, s), radius), tolerance),
                        compare<_CMP_GT_OQ>(V::sub(V::sub(s, highest), radius), tolerance));
          separated = V::bit_or(separated, V::keep(apart, V::splat(1 << (x | y << 1 | z << 2))));
        }
      }
    return separated;
  }

  /// octants_overlapped's verdict on all 8 octants: the octants some axis separates.
  static I separated_octants(const triangle_box_detail::OctantBox<float>& b, const F (&p)[3][3]) {
    const Frame f = octant_frame(b, p);
    const F zero = V::splat(0.f), one = V::splat(1.f);
    I separated = separated_along<1>({one, zero, zero}, f, b);
    separated = V::bit_or(separated, separated_along<0>({zero, one, zero}, f, b));
    separated = V::bit_or(separated, separated_along<0>({zero, zero, one}, f, b));
    F e[3][3];  // e0 = v1 - v0, e1 = v2 - v1, e2 = v0 - v2
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k)
        e[i][k] = V::sub(f.v[(i + 1) % 3][k], f.v[i][k]);
    const F normal[3] = {V::sub(V::mul(e[0][1], e[1][2]), V::mul(e[0][2], e[1][1])),
                         V::sub(V::mul(e[0][2], e[1][0]), V::mul(e[0][0], e[1][2])),
                         V::sub(V::mul(e[0][0], e[1][1]), V::mul(e[0][1], e[1][0]))};
    separated = V::bit_or(separated, separated_along<-1>(normal, f, b));
    for (int i = 0; i < 3; ++i) {
      separated = V::bit_or(separated, separated_along<0>({zero, e[i][2], negate(e[i][1])}, f, b));
      separated = V::bit_or(separated, separated_along<1>({negate(e[i][2]), zero, e[i][0]}, f, b));
      separated = V::bit_or(separated, separated_along<2>({e[i][1], negate(e[i][0]), zero}, f, b));
    }
    return separated;
  }

  /// Triangles whose masks wait for the exact test, packed so that it runs on full registers.
  struct alignas(64) Pending {
    std::int32_t position[2 * L], id[2 * L], candidates[2 * L], held[2 * L];
    int size = 0;
  };

  /// Runs the exact test on the first L pending triangles (fewer at the end) and writes their
  /// masks.
  static void settle_exactly(const NodeSplit& node, const TriangleVertices* triangles,
                             Pending& pending, int count, std::uint8_t* masks) {
    const M valid = V::lanes((1u << count) - 1);
    F p[3][3];
    gather_corners(triangles, V::load(pending.id), valid, p);
    const I separated = separated_octants(node.octants, p);
    alignas(64) std::int32_t result[L];
    // held | octants_overlapped(candidates): the candidates no axis separates.
    V::store(result, V::bit_or(V::load(pending.held),
                               V::bit_and_not(separated, V::load(pending.candidates))));
    for (int l = 0; l < count; ++l)
      masks[pending.position[l]] = std::uint8_t(result[l]);
    // The rest moves to the front.
    for (int l = count; l < pending.size; ++l) {
      pending.position[l - count] = pending.position[l];
      pending.id[l - count] = pending.id[l];
      pending.candidates[l - count] = pending.candidates[l];
      pending.held[l - count] = pending.held[l];
    }
    pending.size -= count;
  }

  static void child_overlap_masks(const NodeSplit& node, const TriangleVertices* triangles,
                                  const std::uint32_t* ids, std::uint32_t count,
                                  std::uint8_t* masks) {
    Pending pending;
    alignas(64) std::int32_t mask_lanes[L], held_lanes[L], id_lanes[L];
    for (std::uint32_t first = 0; first < count; first += L) {
      const int n = count - first < std::uint32_t(L) ? int(count - first) : L;
      const M valid = V::lanes((1u << n) - 1);
      const I id = V::load_lanes(ids + first, valid);
      F p[3][3];
      gather_corners(triangles, id, valid, p);
      I mask, held;
      const std::uint32_t settled = V::bits(settle_cheaply(node, p, mask, held));
      V::store(mask_lanes, mask);
      V::store(held_lanes, held);
      V::store(id_lanes, id);
      for (int l = 0; l < n; ++l) {
        if (settled >> l & 1) {
          masks[first + l] = std::uint8_t(mask_lanes[l]);
          continue;
        }
        const int k = pending.size++;
        pending.position[k] = std::int32_t(first + l);
        pending.id[k] = id_lanes[l];
        pending.candidates[k] = mask_lanes[l] & ~held_lanes[l];
        pending.held[k] = held_lanes[l];
      }
      if (pending.size >= L) settle_exactly(node, triangles, pending, L, masks);
    }
    while (pending.size > 0)
      settle_exactly(node, triangles, pending, pending.size < L ? pending.size : L, masks);
  }
};

}  // namespace irgrid::simd
