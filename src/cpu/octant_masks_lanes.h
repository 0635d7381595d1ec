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

  /// A node about to be split (NodeSplit, with its OctantBox), per lane.
  struct NodeLanes {
    F padding, lo[3], mid[3], hi[3];
    F center[3], offset[2][3], half[2][3], farthest_offset[3], largest_half[3];
  };

  /// One node in every lane.
  static NodeLanes splat_node(const NodeSplit& node) {
    NodeLanes n;
    n.padding = V::splat(node.padding);
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = V::splat(node.lo[k]);
      n.mid[k] = V::splat(node.mid[k]);
      n.hi[k] = V::splat(node.hi[k]);
      n.center[k] = V::splat(node.octants.center[k]);
      n.farthest_offset[k] = V::splat(node.octants.farthest_offset[k]);
      n.largest_half[k] = V::splat(node.octants.largest_half[k]);
      for (int side = 0; side < 2; ++side) {
        n.offset[side][k] = V::splat(node.octants.offset[side][k]);
        n.half[side][k] = V::splat(node.octants.half[side][k]);
      }
    }
    return n;
  }

  /// center_and_half, lane-wise.
  static void center_and_half(F lo, F hi, F& center, F& half) {
    center = V::add(V::mul(V::splat(0.5f), lo), V::mul(V::splat(0.5f), hi));
    half = max_of(V::sub(hi, center), V::sub(center, lo));
  }

  /// node_split (with octant_box) of the nodes with lower voxels `lo` and children of `half`
  /// voxels, lane-wise.
  static NodeLanes split_nodes(const GridInfo& info, const I (&lo)[3], std::int32_t half) {
    NodeLanes n;
    n.padding = V::splat(info.padding);
    const auto world = [&](int a, I v) {  // voxel_to_world
      return V::add(V::splat(info.box_lo[a]), V::mul(V::to_float(v), V::splat(info.voxel_size[a])));
    };
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = world(k, lo[k]);
      n.mid[k] = world(k, V::add(lo[k], V::splat(half)));
      n.hi[k] = world(k, V::add(lo[k], V::splat(2 * half)));
      const F outer_lo = V::sub(n.lo[k], n.padding), outer_hi = V::add(n.hi[k], n.padding);
      n.center[k] = V::add(V::mul(V::splat(0.5f), outer_lo), V::mul(V::splat(0.5f), outer_hi));
      F lower_center, upper_center;
      center_and_half(outer_lo, V::add(n.mid[k], n.padding), lower_center, n.half[0][k]);
      center_and_half(V::sub(n.mid[k], n.padding), outer_hi, upper_center, n.half[1][k]);
      n.offset[0][k] = V::sub(lower_center, n.center[k]);
      n.offset[1][k] = V::sub(upper_center, n.center[k]);
      n.farthest_offset[k] = max_of(abs_of(n.offset[0][k]), abs_of(n.offset[1][k]));
      n.largest_half[k] = max_of(n.half[0][k], n.half[1][k]);
    }
    return n;
  }

  /// What child_overlap_mask settles before the exact test: `mask`, the children the
  /// triangle's padded box reaches, and `held`, those of them holding a vertex. The lanes of the
  /// result are settled with mask alone (one child or none, or every child holds a vertex).
  static M settle_cheaply(const NodeLanes& node, const F (&p)[3][3], I& mask, I& held) {
    mask = V::splat(0xFF);
    for (int a = 0; a < 3; ++a) {
      const std::int32_t upper = std::int32_t(upper_octants(a));
      // triangle_box: min3 and max3 are min_fast and max_fast.
      const F lo = V::min(p[0][a], V::min(p[1][a], p[2][a]));
      const F hi = V::max(p[0][a], V::max(p[1][a], p[2][a]));
      mask = clear_where(compare<_CMP_LT_OQ>(V::add(hi, node.padding), node.mid[a]), mask, upper);
      mask = keep_where(compare<_CMP_GT_OQ>(V::sub(lo, node.padding), node.mid[a]), mask, upper);
    }
    const I zero = V::splat(0);
    const M single = V::equal(V::bit_and(mask, V::sub(mask, V::splat(1))), zero);
    held = zero;
    // octants_holding_vertex's bounds.
    F lower_lo[3], lower_hi[3], upper_lo[3], upper_hi[3];
    for (int a = 0; a < 3; ++a) {
      lower_lo[a] = V::sub(node.lo[a], node.padding);
      lower_hi[a] = V::add(node.mid[a], node.padding);
      upper_lo[a] = V::sub(node.mid[a], node.padding);
      upper_hi[a] = V::add(node.hi[a], node.padding);
    }
    for (int i = 0; i < 3; ++i) {
      I in = V::splat(0xFF);
      for (int a = 0; a < 3; ++a) {
        const std::int32_t upper = std::int32_t(upper_octants(a));
        const F x = p[i][a];
        const M lower_half =
            V::both(compare<_CMP_GE_OQ>(x, lower_lo[a]), compare<_CMP_LE_OQ>(x, lower_hi[a]));
        const M upper_half =
            V::both(compare<_CMP_GE_OQ>(x, upper_lo[a]), compare<_CMP_LE_OQ>(x, upper_hi[a]));
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

  static Frame octant_frame(const NodeLanes& b, const F (&p)[3][3]) {
    Frame f;
    const float floor = triangle_box_detail::smallest_normal<float>() /
                        triangle_box_detail::machine_epsilon<float>();
    for (int k = 0; k < 3; ++k) {
      for (int i = 0; i < 3; ++i)
        f.v[i][k] = V::sub(p[i][k], b.center[k]);
      const F farthest = max_of(abs_of(f.v[0][k]), max_of(abs_of(f.v[1][k]), abs_of(f.v[2][k])));
      f.reach[k] = V::add(V::add(V::add(farthest, b.farthest_offset[k]), b.largest_half[k]),
                          V::splat(floor));
    }
    return f;
  }

  /// The octants (bits) whose projections onto `axis` lie apart from the triangle's by more
  /// than rounding could explain (octants_not_separated_along's complement).
  template <int kZero>
  static I separated_along(const F (&axis)[3], const Frame& f, const NodeLanes& b) {
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
        shift[k][side] = V::mul(axis[k], b.offset[side][k]);
        extent[k][side] = V::mul(magnitude[k], b.half[side][k]);
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
  static I separated_octants(const NodeLanes& b, const F (&p)[3][3]) {
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

  /// Triangles whose masks wait for the exact test, packed so that it runs on full registers:
  /// where each mask goes, and the key its source loads the lane from again.
  struct alignas(64) Pending {
    std::int32_t position[2 * L], key[2 * L], candidates[2 * L], held[2 * L];
    int size = 0;
  };

  /// Runs the exact test on the first `count` (<= L) pending triangles and writes their masks.
  template <class Source>
  static void settle_exactly(const Source& source, Pending& pending, int count,
                             std::uint8_t* masks) {
    const M valid = V::lanes((1u << count) - 1);
    NodeLanes node;
    F p[3][3];
    source.load(V::load(pending.key), valid, node, p);
    const I separated = separated_octants(node, p);
    alignas(64) std::int32_t result[L];
    // held | octants_overlapped(candidates): the candidates no axis separates.
    V::store(result, V::bit_or(V::load(pending.held),
                               V::bit_and_not(separated, V::load(pending.candidates))));
    for (int l = 0; l < count; ++l)
      masks[pending.position[l]] = std::uint8_t(result[l]);
    // The rest moves to the front.
    for (int l = count; l < pending.size; ++l) {
      pending.position[l - count] = pending.position[l];
      pending.key[l - count] = pending.key[l];
      pending.candidates[l - count] = pending.candidates[l];
      pending.held[l - count] = pending.held[l];
    }
    pending.size -= count;
  }

  /// The masks of items [0, count) of `source`: item k's (node, triangle) pair is loaded from
  /// its key (source.keys), its mask goes to masks[source.position(k, key)].
  template <class Source>
  static void masks_of(const Source& source, std::uint32_t count, std::uint8_t* masks) {
    Pending pending;
    alignas(64) std::int32_t mask_lanes[L], held_lanes[L], key_lanes[L];
    for (std::uint32_t first = 0; first < count; first += L) {
      const int n = count - first < std::uint32_t(L) ? int(count - first) : L;
      const M valid = V::lanes((1u << n) - 1);
      const I key = source.keys(first, valid);
      NodeLanes node;
      F p[3][3];
      source.load(key, valid, node, p);
      I mask, held;
      const std::uint32_t settled = V::bits(settle_cheaply(node, p, mask, held));
      V::store(mask_lanes, mask);
      V::store(held_lanes, held);
      V::store(key_lanes, key);
      for (int l = 0; l < n; ++l) {
        const std::int32_t position = source.position(first + std::uint32_t(l), key_lanes[l]);
        if (settled >> l & 1) {
          masks[position] = std::uint8_t(mask_lanes[l]);
          continue;
        }
        const int k = pending.size++;
        pending.position[k] = position;
        pending.key[k] = key_lanes[l];
        pending.candidates[k] = mask_lanes[l] & ~held_lanes[l];
        pending.held[k] = held_lanes[l];
      }
      if (pending.size >= L) settle_exactly(source, pending, L, masks);
    }
    while (pending.size > 0)
      settle_exactly(source, pending, pending.size < L ? pending.size : L, masks);
  }

  /// One node's triangles ids[k], masks in order.
  struct OneNode {
    NodeLanes node;
    const TriangleVertices* triangles;
    const std::uint32_t* ids;
    I keys(std::uint32_t first, M valid) const { return V::load_lanes(ids + first, valid); }
    void load(I id, M valid, NodeLanes& n, F (&p)[3][3]) const {
      n = node;
      gather_corners(triangles, id, valid, p);
    }
    std::int32_t position(std::uint32_t k, std::int32_t) const { return std::int32_t(k); }
  };

  /// (node, triangle) pairs picked[k] of a level, each with its own node: masks at the pairs.
  struct LevelPairs {
    const GridInfo* info;
    std::int32_t half;
    const TriangleVertices* triangles;
    const Voxel* node_lo;
    const std::uint32_t *pair_node, *pair_tri, *picked;
    I keys(std::uint32_t first, M valid) const { return V::load_lanes(picked + first, valid); }
    void load(I pair, M valid, NodeLanes& n, F (&p)[3][3]) const {
      const I zero = V::splat(0);
      const I node = V::template gather<4>(zero, pair_node, pair, valid);
      const I words = V::mul(node, V::splat(3));  // a Voxel is 3 words
      I lo[3];
      for (int a = 0; a < 3; ++a)
        lo[a] = V::template gather<4>(zero, node_lo, V::add(words, V::splat(a)), valid);
      n = split_nodes(*info, lo, half);
      gather_corners(triangles, V::template gather<4>(zero, pair_tri, pair, valid), valid, p);
    }
    std::int32_t position(std::uint32_t, std::int32_t pair) const { return pair; }
  };

  static void child_overlap_masks(const NodeSplit& node, const TriangleVertices* triangles,
                                  const std::uint32_t* ids, std::uint32_t count,
                                  std::uint8_t* masks) {
    masks_of(OneNode{splat_node(node), triangles, ids}, count, masks);
  }
};

}  // namespace irgrid::simd
