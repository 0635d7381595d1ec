// cpu/merge_propose_lanes.h: a merge sweep's proposals (cpu/merge_propose.h) written once over
// the lane operations V of an instruction set, one cell per lane. cpu/build_lanes_avx2.cpp and
// build_lanes_avx512.cpp include this after their target pragma.
//
// Every lane-wise line mirrors one of propose_merges, voxel_past_upper_face, lookup_cell,
// proposes_merge, half_area or empty_merge_keeps_shape (core/construction/merge_pairs.h,
// irgrid/kernel/grid_layout.h) with the same integer and float operations in the same order
// (no FMA: -ffp-contract=off). The lanes that pass every check but the union's size then count
// their lists' union one cell at a time (union_size).
#pragma once

#include <immintrin.h>

#include <bit>
#include <cstdint>
#include <utility>

#include "cpu/map_lookup_lanes.h"

namespace irgrid::simd {

template <class V>
struct ProposeLanes {
  static constexpr int L = V::kLanes;
  using F = typename V::F;
  using I = typename V::I;
  using M = typename V::M;

  template <int kPredicate>
  static M compare(F a, F b) {
    return V::template compare<kPredicate>(a, b);
  }

  /// Narrow cells `index` (lanes of m): corners as 32-bit lanes, the reference range.
  struct Cells {
    I lo[3], hi[3], begin, end;
  };
  static Cells gather_cells(const NarrowCell* cells, I index, M m) {
    static_assert(sizeof(NarrowCell) == 20 && offsetof(NarrowCell, hi) == 6 &&
                  offsetof(NarrowCell, begin) == 12 && offsetof(NarrowCell, end) == 16);
    const I words = V::mul(index, V::splat(5));  // 4-byte words per cell
    const auto word = [&](int k) {
      return V::template gather<4>(V::splat(0), cells, V::add(words, V::splat(k)), m);
    };
    const I low16 = V::splat(0xffff);
    const I w0 = word(0), w1 = word(1), w2 = word(2);
    Cells c;
    c.lo[0] = V::bit_and(w0, low16);
    c.lo[1] = V::template shift_right_logical<16>(w0);
    c.lo[2] = V::bit_and(w1, low16);
    c.hi[0] = V::template shift_right_logical<16>(w1);
    c.hi[1] = V::bit_and(w2, low16);
    c.hi[2] = V::template shift_right_logical<16>(w2);
    c.begin = word(3);
    c.end = word(4);
    return c;
  }

  /// lookup_cell for voxel v of the lanes of m.
  static I lookup_cells(const GridInfo& info, const Entry* entries, const I (&v)[3], M m) {
    using Map = MapLookupLanes<V>;
    I entry = V::template gather<4>(V::splat(0), entries, Map::top_entry_index(info, v), m);
    I level_shift = V::splat(info.shift);
    for (M inner = Map::inner(entry, m); V::any(inner); inner = Map::inner(entry, inner))
      entry = Map::descend(entries, entry, v, level_shift, inner);
    return Map::target(entry);
  }

  /// half_area of the boxes [lo, hi).
  static F half_area(const GridInfo& info, const I (&lo)[3], const I (&hi)[3]) {
    F d[3];
    for (int a = 0; a < 3; ++a)
      d[a] = V::mul(V::to_float(V::sub(hi[a], lo[a])), V::splat(info.voxel_size[a]));
    return V::add(V::add(V::mul(d[0], d[1]), V::mul(d[1], d[2])), V::mul(d[2], d[0]));
  }

  /// empty_merge_keeps_shape of the boxes [lo, hi) merged along `axis`.
  static M keeps_shape(const GridInfo& info, const I (&lo)[3], const I (&hi)[3], int axis,
                       float empty_aspect) {
    if (!(empty_aspect > 0)) return V::all_lanes();
    F thinnest = V::splat(INFINITY), length = V::splat(0.f);
    for (int other = 0; other < 3; ++other) {
      const F side =
          V::mul(V::to_float(V::sub(hi[other], lo[other])), V::splat(info.voxel_size[other]));
      if (other == axis)
        length = side;
      else
        thinnest = V::select(compare<_CMP_LT_OQ>(side, thinnest), thinnest, side);
    }
    return compare<_CMP_LE_OQ>(length, V::mul(V::splat(empty_aspect), thinnest));
  }

  /// sorted_union_size(a, na, b, nb) (core/construction/merge_lists.h): where the shorter list
  /// fits the lanes, it is held in them and each value of the other is compared against all of it
  /// at once (the values are unique, so each matches at most once), which needs no loop-carried
  /// step through both lists as the scalar merge does; longer lists take that merge. Reads
  /// a[0, na) and b[0, nb) only.
  static std::uint32_t union_size(const std::uint32_t* a, std::uint32_t na, const std::uint32_t* b,
                                  std::uint32_t nb) {
    if (na > nb) {
      std::swap(a, b);
      std::swap(na, nb);
    }
    if (na == 0) return nb;
    if (na > std::uint32_t(L)) return sorted_union_size(a, na, b, nb);
    const M valid = V::lanes((2u << (na - 1)) - 1);
    const I values = V::load_lanes(a, valid);
    M shared = V::no_lanes();
    for (std::uint32_t j = 0; j < nb; ++j)
      shared = V::either(shared, V::equal(values, V::splat(std::int32_t(b[j]))));
    return na + nb - std::uint32_t(std::popcount(V::bits(V::both(shared, valid))));
  }

  static void propose(const merge_detail::ProposeInputs& in, std::uint32_t first,
                      std::uint32_t count) {
    const GridInfo& info = in.info;
    const int axis = in.axis;
    const std::uint32_t bit = 1u << axis;
    alignas(64) std::int32_t owner_lanes[L], n1_lanes[L], n2_lanes[L], a_begin[L], b_begin[L];
    alignas(64) float budget_lanes[L], merged_lanes[L];
    for (std::uint32_t base = first; base < first + count; base += L) {
      const int n = first + count - base < std::uint32_t(L) ? int(first + count - base) : L;
      const M valid = V::lanes((1u << n) - 1);
      const I index = V::add(V::lane_index(), V::splat(std::int32_t(base)));
      const Cells a = gather_cells(in.cells, index, valid);
      M walking = valid;
      if (in.quiet) {
        const I quiet = V::load_lanes(in.quiet + base, valid);
        walking =
            V::both(walking, V::equal(V::bit_and(quiet, V::splat(std::int32_t(bit))), V::splat(0)));
      }
      // voxel_past_upper_face
      walking = V::both(walking, V::greater(V::splat(info.virtual_dims[axis]), a.hi[axis]));
      I past[3] = {a.lo[0], a.lo[1], a.lo[2]};
      past[axis] = a.hi[axis];
      std::uint32_t proposing = 0;
      if (V::any(walking)) {
        const I owner = lookup_cells(info, in.entries, past, walking);
        const Cells b = gather_cells(in.cells, owner, walking);
        // proposes_merge: b starts on a's face and has its cross-section.
        M aligned = V::both(walking, V::equal(b.lo[axis], a.hi[axis]));
        for (int other = 0; other < 3; ++other)
          if (other != axis)
            aligned = V::both(aligned, V::both(V::equal(b.lo[other], a.lo[other]),
                                               V::equal(b.hi[other], a.hi[other])));
        const I n1 = V::sub(a.end, a.begin), n2 = V::sub(b.end, b.begin);
        const I zero = V::splat(0);
        const M both_empty = V::both(V::equal(n1, zero), V::equal(n2, zero));
        if (V::any(V::both(aligned, both_empty)))
          aligned = V::but_not(
              V::but_not(keeps_shape(info, a.lo, b.hi, axis, in.empty_aspect), both_empty),
              aligned);
        const F cost = V::splat(in.cost_ratio);
        const F budget = V::add(V::mul(half_area(info, a.lo, a.hi), V::add(V::to_float(n1), cost)),
                                V::mul(half_area(info, b.lo, b.hi), V::add(V::to_float(n2), cost)));
        const F merged_area = half_area(info, a.lo, b.hi);
        const I lower_bound = V::select(V::greater(n1, n2), n2, n1);
        aligned =
            V::but_not(compare<_CMP_GT_OQ>(
                           V::mul(merged_area, V::add(V::to_float(lower_bound), cost)), budget),
                       aligned);
        proposing = V::bits(aligned);
        if (proposing) {
          V::store(owner_lanes, owner);
          V::store(n1_lanes, n1);
          V::store(n2_lanes, n2);
          V::store(a_begin, a.begin);
          V::store(b_begin, b.begin);
          V::store(budget_lanes, budget);
          V::store(merged_lanes, merged_area);
        }
      }
      // No proposal, then the proposing lanes' unions.
      const I none = V::splat(std::int32_t(merge_detail::kNoCell));
      const bool full = n == L;
      if (full) {
        V::store_unaligned(reinterpret_cast<std::int32_t*>(in.next + base), none);
        V::store_unaligned(reinterpret_cast<std::int32_t*>(in.prev + base), none);
        V::store_unaligned(reinterpret_cast<std::int32_t*>(in.union_size + base), V::splat(0));
      } else {
        for (int l = 0; l < n; ++l) {
          in.next[base + l] = in.prev[base + l] = merge_detail::kNoCell;
          in.union_size[base + l] = 0;
        }
      }
      std::uint32_t proposed = 0;
      for (std::uint32_t left = proposing; left != 0; left &= left - 1) {
        const int l = __builtin_ctz(left);
        const auto n1 = std::uint32_t(n1_lanes[l]), n2 = std::uint32_t(n2_lanes[l]);
        const std::uint32_t n12 = union_size(in.refs + a_begin[l], n1, in.refs + b_begin[l], n2);
        if (merged_lanes[l] * (float(n12) + in.cost_ratio) > budget_lanes[l]) continue;
        in.next[base + l] = std::uint32_t(owner_lanes[l]);
        in.union_size[base + l] = n12;
        proposed |= 1u << l;
      }
      if (!in.track) continue;
      // A cell that proposed nothing along the axis stays quiet along it.
      if (full) {
        auto* quiet = reinterpret_cast<std::int32_t*>(in.quiet + base);
        const I bits = V::load_lanes(in.quiet + base, valid);
        V::store_unaligned(quiet, V::select(V::lanes(proposed),
                                            V::bit_or(bits, V::splat(std::int32_t(bit))), bits));
      } else {
        for (int l = 0; l < n; ++l)
          if (!(proposed >> l & 1)) in.quiet[base + l] |= bit;
      }
    }
  }
};

}  // namespace irgrid::simd
