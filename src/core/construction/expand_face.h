// core/construction/expand_face.h: how far one cell's exit box may grow through one of its faces.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017, §3.3
// (expansion), and ../shared/design/algorithm.md §5. The invariant that keeps traversal exact:
//     every triangle that overlaps a cell's exit box grown by GridInfo::padding is in its list
// (the insertion test establishes it with that padding; traversal relies on the padding to absorb
// the rounding of its float positions). Growth through a face adds a slab S = face x [h, h + d]
// (for the upper face; the lower one is symmetric). The face is walked in tiles, each tile lying
// inside the current exit box of the neighbour N that owns the voxel just outside it, and d never
// exceeds the depth of any such box, so S is covered by those boxes. A triangle overlapping S
// grown by the padding therefore overlaps some N's exit box grown by the padding, so it is in N's
// list by the invariant of N, and it is in C's list too unless it is one of N's *extra* triangles
// (in N's list, not in C's):
//   * subset mode (the paper): any extra triangle forbids growth through the whole face;
//   * partial mode (not in the paper; the talk's slides report +10-20% traversal speed): an extra
//     triangle only caps d so that S stays more than the padding away from the triangle's
//     bounding box, along the axis of growth (rounded down to a multiple of the growth quantum),
//     or it is ignored when its box is more than the padding away from the face's cross-section. A
//     triangle lies inside its box, so it then cannot come within the padding of S either.
// Comparisons use twice the padding: the float rounding of "coordinate ± 2 x padding" is far below
// one padding (about 64 ulps of the scene's largest coordinate), so "apart by more than the
// padding" holds exactly whenever the float comparison claims the doubled margin.
#pragma once

#include <cmath>
#include <cstdint>
#include <type_traits>

#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {
namespace expand_detail {

/// First index in [first, last) of the sorted refs whose value is >= id (last if none).
IRGRID_HD inline std::uint32_t lower_bound_ref(const std::uint32_t* refs, std::uint32_t first,
                                               std::uint32_t last, std::uint32_t id) {
  while (first < last) {
    const std::uint32_t mid = first + (last - first) / 2;
    if (refs[mid] < id)
      first = mid + 1;
    else
      last = mid;
  }
  return first;
}

/// floor(x) for x within the int32 range, exact, without floorf: x86-64's baseline has no
/// rounding instruction, and this runs for every extra triangle of every face.
IRGRID_HD inline std::int32_t floor_to_int(float x) {
  const std::int32_t truncated = std::int32_t(x);
  return float(truncated) > x ? truncated - 1 : truncated;
}

/// A box's bounds, per axis: `lo(a)`, `hi(a)`.
struct StoredBounds {
  const BoxF& box;
  IRGRID_HD float lo(int a) const { return box.lo[a]; }
  IRGRID_HD float hi(int a) const { return box.hi[a]; }
};

/// A triangle's box bounds, each computed when asked (the same values as triangle_box): most
/// extra triangles are settled by their bound along the axis of growth alone.
struct TriangleBounds {
  const TriangleVertices& t;
  IRGRID_HD float lo(int a) const { return min3(t.p0[a], t.p1[a], t.p2[a]); }
  IRGRID_HD float hi(int a) const { return max3(t.p0[a], t.p1[a], t.p2[a]); }
};

/// Where the far plane of cell c's face on kAxis (kDirection +1: the upper face at `face` =
/// c.hi, -1: the lower one at c.lo) stops before `box`, the box of a triangle missing from c's
/// list, for growths up to `limit`: the farthest plane within [face, face + limit] (or
/// [face - limit, face]) that keeps the slab more than the padding away from the box along the
/// axis, or `face`. Conservative: the float floor may cost a voxel, never admit one too many,
/// because every candidate plane is checked with the doubled margin. Validity is monotone in the
/// plane, so the answer is the unlimited one (face -1 up or dims + 1 down, the widest range)
/// clamped to the face's range: TrianglePlanes keeps it per triangle.
template <int kAxis, int kDirection, typename Bounds>
IRGRID_HD inline std::int32_t far_plane(const GridInfo& info, std::int32_t face, const Bounds& box,
                                        std::int32_t limit) {
  const float margin = 2.f * info.padding;
  if (kDirection > 0) {
    // The far plane P = hi + d must stay below box.lo - padding: start from the voxel holding
    // that coordinate and step back while the check fails.
    const float first = (box.lo(kAxis) - margin - info.box_lo[kAxis]) * info.inv_voxel_size[kAxis];
    // floor(first) clamped to [face, face + limit] (NaN -> face); the bounds are integers, so
    // clamping first gives the same plane.
    std::int32_t plane = floor_to_int(min_fast(max_fast(first, float(face)), float(face + limit)));
    while (plane > face && !(voxel_to_world(info, kAxis, plane) + margin < box.lo(kAxis)))
      --plane;
    return plane;
  }
  // The far plane P = lo - d must stay above box.hi + padding.
  const float first = (box.hi(kAxis) + margin - info.box_lo[kAxis]) * info.inv_voxel_size[kAxis];
  // floor(first) + 1 clamped to [face - limit, face] (NaN -> face), clamped before the floor.
  std::int32_t plane =
      floor_to_int(max_fast(min_fast(first, float(face - 1)), float(face - limit - 1))) + 1;
  while (plane < face && !(voxel_to_world(info, kAxis, plane) - margin > box.hi(kAxis)))
    ++plane;
  return plane;
}

/// Whether a box whose lower bound on axis a is `lo` lies more than the padding above plane h
/// (false for a NaN bound). apart_from_cross_section and triangle_planes share it, so that the
/// planes give its answers exactly.
IRGRID_HD inline bool apart_above_plane(const GridInfo& info, int a, float lo, std::int32_t h) {
  return lo - 2.f * info.padding > voxel_to_world(info, a, h);
}
/// Whether a box whose upper bound on axis a is `hi` lies more than the padding below plane l.
IRGRID_HD inline bool apart_below_plane(const GridInfo& info, int a, float hi, std::int32_t l) {
  return hi + 2.f * info.padding < voxel_to_world(info, a, l);
}

/// Whether `box` lies more than the padding away from the cross-section of cell c's face on
/// kAxis (then the triangle cannot reach the slab, however far it grows). A NaN box is never
/// apart.
template <int kAxis, typename Bounds>
IRGRID_HD inline bool apart_from_cross_section(const GridInfo& info, const Cell& c,
                                               const Bounds& box) {
  constexpr int kRow = (kAxis + 1) % 3, kColumn = (kAxis + 2) % 3;
  return apart_above_plane(info, kRow, box.lo(kRow), c.hi[kRow]) ||
         apart_below_plane(info, kRow, box.hi(kRow), c.lo[kRow]) ||
         apart_above_plane(info, kColumn, box.lo(kColumn), c.hi[kColumn]) ||
         apart_below_plane(info, kColumn, box.hi(kColumn), c.lo[kColumn]);
}

/// The largest growth d in [0, limit] of cell c's face on kAxis (kDirection +1: the upper face,
/// -1: the lower one) that keeps the grown slab more than the padding away from `box` (the box
/// of a triangle missing from c's list). The axis and direction are template parameters so
/// that every coordinate is picked at compile time: this runs for every extra triangle of every
/// neighbour of every face.
template <int kAxis, int kDirection, typename Bounds>
IRGRID_HD inline std::int32_t growth_before_box(const GridInfo& info, const Cell& c,
                                                const Bounds& box, std::int32_t limit) {
  // Along the axis first: a triangle beyond the reach of the full growth cannot cap it, whatever
  // the cross-section test below would say, so most far triangles need one bound only.
  const std::int32_t face = kDirection > 0 ? c.hi[kAxis] : c.lo[kAxis];
  const std::int32_t plane = far_plane<kAxis, kDirection>(info, face, box, limit);
  const std::int32_t grown = kDirection > 0 ? plane - face : face - plane;
  if (grown == limit || apart_from_cross_section<kAxis>(info, c, box)) return limit;
  return grown;
}

/// What growth_before_box asks of a triangle's box, answered once per triangle in voxel planes
/// along each axis, clamped to [0, dims] (16 bits: grids of compressed cells; a face's range
/// lies within [0, dims], so clamping keeps every answer). An extra triangle then costs one
/// 24-byte read and integer compares instead of its 36-byte vertices, bounded again for every
/// face that meets it (Sponza bounds 10 M extra triangles; figures in docs/benchmarks.md).
struct TrianglePlanes {
  std::uint16_t up[3];      ///< far_plane<a, +1> from face -1
  std::uint16_t down[3];    ///< far_plane<a, -1> from face dims + 1
  std::uint16_t before[3];  ///< face planes h in [1, dims] apart below box.lo: h <= before
  std::uint16_t after[3];   ///< face planes l in [0, dims - 1] apart above box.hi: l >= after
};
static_assert(sizeof(TrianglePlanes) == 24);

IRGRID_HD inline std::uint16_t clamp_to_dims(std::int32_t plane, std::int32_t dims) {
  return std::uint16_t(plane < 0 ? 0 : plane > dims ? dims : plane);
}

/// The TrianglePlanes of a triangle's box (requires fits_compact_cells(info)). Each threshold
/// starts from the plane its coordinate rounds to and steps while the same float comparison as
/// growth_before_box's says otherwise; the comparisons are monotone in the plane.
template <typename Bounds>
IRGRID_HD inline TrianglePlanes triangle_planes(const GridInfo& info, const Bounds& box) {
  TrianglePlanes planes;
  const auto axis = [&](auto a) {
    constexpr int kAxis = decltype(a)::value;
    const std::int32_t dims = info.virtual_dims[kAxis];
    planes.up[kAxis] = clamp_to_dims(far_plane<kAxis, +1>(info, -1, box, dims + 1), dims);
    planes.down[kAxis] = clamp_to_dims(far_plane<kAxis, -1>(info, dims + 1, box, dims + 2), dims);
    // before: the last plane the box's lower bound lies apart above; after: the first plane its
    // upper bound lies apart below. Each starts where its bound falls and steps to the edge.
    const float margin = 2.f * info.padding, lo = box.lo(kAxis), hi = box.hi(kAxis);
    const float lo_at = (lo - margin - info.box_lo[kAxis]) * info.inv_voxel_size[kAxis];
    std::int32_t h = floor_to_int(min_fast(max_fast(lo_at, 0.f), float(dims)));
    while (h < dims && apart_above_plane(info, kAxis, lo, h + 1))
      ++h;
    while (h > 0 && !apart_above_plane(info, kAxis, lo, h))
      --h;
    planes.before[kAxis] = std::uint16_t(h);
    const float hi_at = (hi + margin - info.box_lo[kAxis]) * info.inv_voxel_size[kAxis];
    std::int32_t l = floor_to_int(min_fast(max_fast(hi_at, 0.f), float(dims)));
    while (l > 0 && apart_below_plane(info, kAxis, hi, l - 1))
      --l;
    while (l < dims && !apart_below_plane(info, kAxis, hi, l))
      ++l;
    planes.after[kAxis] = std::uint16_t(l);
  };
  axis(std::integral_constant<int, 0>());
  axis(std::integral_constant<int, 1>());
  axis(std::integral_constant<int, 2>());
  return planes;
}

/// growth_before_box of a triangle, from its TrianglePlanes: the same answer.
template <int kAxis, int kDirection>
IRGRID_HD inline std::int32_t growth_before_planes(const Cell& c, const TrianglePlanes& planes,
                                                   std::int32_t limit) {
  std::int32_t grown;
  if (kDirection > 0) {
    const std::int32_t face = c.hi[kAxis], plane = planes.up[kAxis];
    grown = plane < face ? 0 : plane - face;
  } else {
    const std::int32_t face = c.lo[kAxis], plane = planes.down[kAxis];
    grown = plane > face ? 0 : face - plane;
  }
  constexpr int kRow = (kAxis + 1) % 3, kColumn = (kAxis + 2) % 3;
  if (grown >= limit || c.hi[kRow] <= planes.before[kRow] || c.lo[kRow] >= planes.after[kRow] ||
      c.hi[kColumn] <= planes.before[kColumn] || c.lo[kColumn] >= planes.after[kColumn])
    return limit;
  return grown;
}

/// What the growth of all cells along one axis reads: the grid and ONE snapshot of the exit
/// boxes, so that the result does not depend on the order in which cells are processed.
/// StoredCell is Cell or CompactCell (with its sentinel; load_cell reads either): a neighbour's box
/// and list cost one 16-byte read in the latter, the most frequent load of the phase.
template <typename StoredCell>
struct ExpandView {
  GridInfo info;
  const Entry* entries;               ///< voxel map: entry-box ownership, never modified
  const StoredCell* cells;            ///< exit boxes before this axis step
  const std::uint32_t* refs;          ///< per-cell lists, sorted ascending and unique
  const TriangleVertices* triangles;  ///< for the boxes of extra triangles (partial mode)
  const TrianglePlanes* planes;       ///< the triangles' TrianglePlanes, or null
  bool partial;                       ///< partial expansion on
  std::int32_t growth_quantum;        ///< partial growth in multiples of this (a power of two)

  IRGRID_HD Cell cell(std::uint32_t k) const { return load_cell(cells, k); }
};

/// Growth through one face.
struct FaceGrowth {
  std::int32_t voxels;    ///< how far the face moves outwards, >= 0
  bool may_grow_further;  ///< limited only by the depth of the neighbours' boxes
};

/// The largest growth in [0, limit] that neighbour n's list allows cell c: limit when n's list
/// is a subset of c's; otherwise 0 in subset mode, and in partial mode the cap set by the
/// boxes of n's extra triangles. Both lists are sorted, so one pass over n's list finds the
/// extras, with a binary search in c's list (from the last position on) only for references
/// past c's next one.
template <int kAxis, int kDirection, typename View>
IRGRID_HD inline std::int32_t growth_allowed_by_list(const View& view, const Cell& c, const Cell& n,
                                                     std::int32_t limit) {
  // A longer list cannot be a subset; partial mode still needs the extras' boxes.
  if (!view.partial && n.end - n.begin > c.end - c.begin) return 0;
  std::uint32_t from = c.begin;
  for (std::uint32_t r = n.begin; r < n.end && limit > 0; ++r) {
    const std::uint32_t id = view.refs[r];
    // Searched only when the id lies past c's next reference.
    if (from < c.end && view.refs[from] < id)
      from = lower_bound_ref(view.refs, from + 1, c.end, id);
    if (from < c.end && view.refs[from] == id) {
      ++from;
      continue;
    }
    if (!view.partial) return 0;
    const std::int32_t cap =
        view.planes ? growth_before_planes<kAxis, kDirection>(c, view.planes[id], limit)
                    : growth_before_box<kAxis, kDirection>(
                          view.info, c, TriangleBounds{view.triangles[id]}, limit);
    // Rounding down only shrinks the slab, and a cap below one quantum ends the scan early.
    if (cap < limit) limit = cap & ~(view.growth_quantum - 1);
  }
  return limit;
}

/// How far cell c (its snapshot exit box) may grow through its face on kAxis in kDirection
/// (+1 or -1). Walks the face in rows of tiles: each tile starts at a voxel just outside the
/// face, whose owner N is found in the voxel map, and spans N's current exit box (clamped to the
/// face) along the row; a row is as tall as its shortest tile. Every tile thus lies inside one
/// neighbour's exit box, which the argument at the top of this file needs.
template <int kAxis, int kDirection, typename View>
IRGRID_HD inline FaceGrowth face_growth(const View& view, const Cell& c) {
  const std::int32_t outside = kDirection > 0 ? c.hi[kAxis] : c.lo[kAxis] - 1;
  if (outside < 0 || outside >= view.info.virtual_dims[kAxis]) return {0, false};
  constexpr int kRow = (kAxis + 1) % 3, kColumn = (kAxis + 2) % 3;
  std::int32_t depth = kMaxVirtualResolution;  // min over neighbours of their box's depth
  std::int32_t allowed = depth;                // min over neighbours of what their lists allow
  Voxel at{};
  at[kAxis] = outside;
  for (std::int32_t j = c.lo[kColumn]; j < c.hi[kColumn] && allowed > 0;) {
    std::int32_t row_end = c.hi[kColumn];
    for (std::int32_t i = c.lo[kRow]; i < c.hi[kRow] && allowed > 0;) {
      at[kRow] = i;
      at[kColumn] = j;
      const Cell n = view.cell(lookup_cell(view.info, view.entries, at));
      // An owner that misses its own voxel means an inconsistent map: give up, never spin.
      if (n.hi[kRow] <= i || n.hi[kColumn] <= j) return {0, false};
      const std::int32_t n_depth =
          kDirection > 0 ? n.hi[kAxis] - c.hi[kAxis] : c.lo[kAxis] - n.lo[kAxis];
      depth = n_depth < depth ? n_depth : depth;
      const std::int32_t limit = allowed < depth ? allowed : depth;
      allowed = growth_allowed_by_list<kAxis, kDirection>(view, c, n, limit);
      // n's exit box holds its entry box, which holds the voxel at (i, j): both advance.
      i = n.hi[kRow] < c.hi[kRow] ? n.hi[kRow] : c.hi[kRow];
      row_end = n.hi[kColumn] < row_end ? n.hi[kColumn] : row_end;
    }
    j = row_end;
  }
  const std::int32_t grown = allowed < depth ? allowed : depth;
  return {grown > 0 ? grown : 0, grown > 0 && grown == depth};
}

}  // namespace expand_detail
}  // namespace irgrid
