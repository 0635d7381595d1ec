// cpu/map_lookup_lanes.h: lookup_cell (irgrid/kernel/grid_layout.h) lane-wise, one voxel per
// lane, over the lane operations V of an instruction set: the SIMD walk's cells
// (cpu/simd_walk_lanes.h) and a merge sweep's partners (cpu/merge_propose_lanes.h). Included
// after a target pragma, as those are. The callers run the descent themselves, level by level,
// so that the walk can interleave the levels of several groups of lanes.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace irgrid::simd {

template <class V>
struct MapLookupLanes {
  using I = typename V::I;
  using M = typename V::M;

  /// top_entry_index of voxel v.
  static I top_entry_index(const GridInfo& info, const I (&v)[3]) {
    const I top_x = V::shift_right(v[0], info.shift);
    const I top_y = V::shift_right(v[1], info.shift);
    const I top_z = V::shift_right(v[2], info.shift);
    return V::add(V::mul(V::add(V::mul(top_z, V::splat(info.top_dims[1])), top_y),
                         V::splat(info.top_dims[0])),
                  top_x);
  }

  /// Whether `entry` is an inner node's (log_dim > 0), in the lanes of m.
  static M inner(I entry, M m) {
    return V::both(m, V::greater(V::template shift_right_logical<30>(entry), V::splat(0)));
  }

  /// One level of the descent to voxel v in the lanes of `inner`: the child entry
  /// (child_entry_index) replaces `entry` there, and level_shift moves down by the node's
  /// log_dim (0 in the other lanes, whose entries are leaves or idle).
  static I descend(const Entry* entries, I entry, const I (&v)[3], I& level_shift, M inner) {
    const I one = V::splat(1);
    const I k = V::template shift_right_logical<30>(entry);
    const I mask = V::sub(V::shift_left(one, k), one);
    level_shift = V::sub(level_shift, k);
    const I cx = V::bit_and(V::shift_right(v[0], level_shift), mask);
    const I cy = V::bit_and(V::shift_right(v[1], level_shift), mask);
    const I cz = V::bit_and(V::shift_right(v[2], level_shift), mask);
    const I child = V::bit_or(V::shift_left(V::bit_or(V::shift_left(cz, k), cy), k), cx);
    const I index = V::add(target(entry), child);
    return V::template gather<4>(entry, entries, index, inner);
  }

  /// The cell or node an entry names.
  static I target(I entry) { return V::bit_and(entry, V::splat(std::int32_t(kMaxEntryTarget))); }
};

}  // namespace irgrid::simd
