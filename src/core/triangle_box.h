// core/triangle_box.h: conservative triangle/box overlap test for host and device, float or double.
//
// Akenine-Möller, "Fast 3D Triangle-Box Overlap Testing", JGT 6(1), 2001: a triangle and a box
// are disjoint iff their projections onto one of 13 axes are disjoint (separating axis theorem):
// the 3 box face normals (the triangle's bounding box against the box), the triangle normal
// (its plane against the box) and the 9 cross products of a triangle edge with a box edge.
// As in the paper, the triangle is moved into the frame of the box centre first, so rounding
// errors scale with the distance to the box rather than with the absolute coordinates.
//
// Conservative in floating point (the builder must never drop a triangle that touches a cell):
// * The theorem holds for *any* axis, so an axis computed with rounding errors (an edge, a cross
//   product) is still a valid candidate: only the projections onto it need care. A zero axis
//   (a degenerate triangle, an edge parallel to a box edge) projects everything to 0 and so
//   never separates; for a collinear triangle or a point the remaining axes are still complete.
// * Projections onto an axis a are compared with a margin. With u = eps/2, v = p - c the
//   translated vertices (one rounding each) and h the half extents (one rounding each), every
//   projection d_i = a.v_i and the box radius r = |a|.h are off from the exact values by at most
//   (gamma_3 + u) * sum_k |a_k| R_k ~ 4u sum_k |a_k| R_k, where R_k = max_i |v_ik| + h_k.
//   A separation claim compares two such values, so the exact gap is at least the computed one
//   minus ~8u sum_k |a_k| R_k (a little more for the final subtraction). The margin
//       tol = 8 eps sum_k |a_k| (R_k + tiny/eps) + 16 tiny   (= 16u sum_k |a_k| R_k + ...)
//   is twice that, which also covers the rounding of tol itself and contracted multiply-adds;
//   the tiny (smallest normal) terms cover underflow, flush-to-zero included, where relative
//   bounds fail. A touching case has an exact gap <= 0 on every axis, so it is never separated.
//   (tests/test_triangle_box.cpp: with 0.5 eps instead of 8 eps the float test misses touching
//   cases; with 1 eps it does not, so the margin is about 8x what rounding takes in practice.)
// * Overflow gives an infinite or NaN margin (tol grows with every product in the projections),
//   and comparisons with it are false: "not separated", again on the safe side.
// Float is precise for triangles whose size and distance to the box lie within ~1e-12..1e12
// (the normal axis costs size^2, its projections size^3); outside that it degrades to
// reporting overlap, never to missing one.
//
// octants_overlapped answers the same question for the 8 octants of a box at once. The axes
// depend on the triangle only, so each axis projects the triangle once, in the frame of the box
// centre C, and an octant only shifts that projection by a.o, where o is its centre's offset
// from C; its radius |a|.h takes its own half extents, as in center_on_box. The shift, its
// rounding and the extra subtraction add at most ~3u sum_k |a_k| |o_k| to the errors above; the
// margin takes R_k = max_i |v_ik| + max |o_k| + max h_k, so it still holds twice the error bound.
#pragma once

#include <cstdint>

#if defined(__SSE2__) && !defined(__CUDA_ARCH__)
#include <emmintrin.h>
#endif

#include "irgrid/kernel/platform.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {
namespace triangle_box_detail {

/// Machine epsilon (spacing of T just above 1); a constexpr function so device code may use it.
template <typename T>
IRGRID_HD constexpr T machine_epsilon() {
  return sizeof(T) == 4 ? T(0x1p-23) : T(0x1p-52);
}
/// Smallest normal number of T: the absolute error bound of one operation that underflows.
template <typename T>
IRGRID_HD constexpr T smallest_normal() {
  return sizeof(T) == 4 ? T(0x1p-126) : T(0x1p-1022);
}

template <typename T>
IRGRID_HD constexpr T abs_of(T x) {
  return x < T(0) ? -x : x;
}
template <typename T>
IRGRID_HD constexpr T min_of(T a, T b) {
  return b < a ? b : a;
}
template <typename T>
IRGRID_HD constexpr T max_of(T a, T b) {
  return a < b ? b : a;
}
template <typename T>
IRGRID_HD constexpr Vec3<T> abs_of(Vec3<T> a) {
  return {abs_of(a.x), abs_of(a.y), abs_of(a.z)};
}

/// The triangle in the frame of the (padded) box centre, with the magnitudes its error bounds
/// scale with.
template <typename T>
struct CenteredTriangle {
  Vec3<T> v0, v1, v2;  ///< vertices minus the box centre
  Vec3<T> half;        ///< half extents of the padded box around that centre
  Vec3<T> reach;       ///< per axis: max_i |v_ik| + half_k + tiny/eps (see the header comment)
};

/// A centre of [lo, hi] and the half extent from it to the farther end. Any centre will do;
/// halving first cannot overflow. Measured from the rounded centre, the half extent describes a
/// box holding [lo, hi] up to one rounding, which the margin accounts for.
template <typename T>
IRGRID_HD inline void center_and_half(T lo, T hi, T& center, T& half) {
  center = T(0.5) * lo + T(0.5) * hi;
  half = max_of(hi - center, center - lo);
}

template <typename T>
IRGRID_HD inline CenteredTriangle<T> center_on_box(Vec3<T> p0, Vec3<T> p1, Vec3<T> p2,
                                                   Vec3<T> box_lo, Vec3<T> box_hi, T padding) {
  CenteredTriangle<T> t;
  const T floor = smallest_normal<T>() / machine_epsilon<T>();
  for (int k = 0; k < 3; ++k) {
    // lo - padding <= lo after rounding (and hi + padding >= hi): the padded box holds the box.
    const T lo = box_lo[k] - padding, hi = box_hi[k] + padding;
    T center;
    center_and_half(lo, hi, center, t.half[k]);
    t.v0[k] = p0[k] - center;
    t.v1[k] = p1[k] - center;
    t.v2[k] = p2[k] - center;
    const T farthest = max_of(abs_of(t.v0[k]), max_of(abs_of(t.v1[k]), abs_of(t.v2[k])));
    t.reach[k] = farthest + t.half[k] + floor;
  }
  return t;
}

/// a . b where component kZero of a is known to be 0 (kZero = -1: none). Skipping the zero
/// term gives the same value for finite b (0 x b_k = +-0 changes no sum) and saves work the
/// compiler may not drop itself (0 x inf is NaN).
template <int kZero, typename T>
IRGRID_HD inline T dot_without(Vec3<T> a, Vec3<T> b) {
  if constexpr (kZero == 0)
    return a.y * b.y + a.z * b.z;
  else if constexpr (kZero == 1)
    return a.x * b.x + a.z * b.z;
  else if constexpr (kZero == 2)
    return a.x * b.x + a.y * b.y;
  else
    return dot(a, b);
}

/// True only when the projections of triangle and box onto `axis` are disjoint by more than
/// rounding could explain (see the header comment); a zero axis never separates. kZero names a
/// component of the axis known to be 0 (-1: none).
template <int kZero = -1, typename T>
IRGRID_HD inline bool separated_along(Vec3<T> axis, const CenteredTriangle<T>& t) {
  const T d0 = dot_without<kZero>(axis, t.v0), d1 = dot_without<kZero>(axis, t.v1),
          d2 = dot_without<kZero>(axis, t.v2);
  const Vec3<T> magnitude = abs_of(axis);
  const T radius = dot_without<kZero>(magnitude, t.half);
  const T tolerance = T(8) * machine_epsilon<T>() * dot_without<kZero>(magnitude, t.reach) +
                      T(16) * smallest_normal<T>();
  const T lowest = min_of(d0, min_of(d1, d2)), highest = max_of(d0, max_of(d1, d2));
  // Written as "gap > tolerance" so that a NaN or infinite tolerance (overflow) never separates.
  return lowest - radius > tolerance || -highest - radius > tolerance;
}

/// separated_along for the unit axis k (a box face normal): the projections are coordinates.
template <int k, typename T>
IRGRID_HD inline bool separated_along_unit(const CenteredTriangle<T>& t) {
  const T lowest = min_of(t.v0[k], min_of(t.v1[k], t.v2[k]));
  const T highest = max_of(t.v0[k], max_of(t.v1[k], t.v2[k]));
  const T tolerance = T(8) * machine_epsilon<T>() * t.reach[k] + T(16) * smallest_normal<T>();
  return lowest - t.half[k] > tolerance || -highest - t.half[k] > tolerance;
}

/// The three axes edge x (unit box edge along x, y, z), written out: no rounding at all.
template <typename T>
IRGRID_HD IRGRID_ALWAYS_INLINE bool edge_separates(Vec3<T> edge, const CenteredTriangle<T>& t) {
  return separated_along<0>(Vec3<T>{T(0), edge.z, -edge.y}, t) ||
         separated_along<1>(Vec3<T>{-edge.z, T(0), edge.x}, t) ||
         separated_along<2>(Vec3<T>{edge.y, -edge.x, T(0)}, t);
}

/// A box split into 8 octants (bit 0 selects the upper x half, bit 1 y, bit 2 z), each grown by
/// the padding, described in the frame of the whole box's centre C: what octants_overlapped
/// needs of the box, computed once for all the triangles tested against it.
template <typename T>
struct OctantBox {
  Vec3<T> center;     ///< C
  Vec3<T> offset[2];  ///< centre of the lower [0] and upper [1] octants minus C, per axis
  Vec3<T> half[2];    ///< half extents of the lower and upper octants' padded boxes
  Vec3<T> farthest_offset, largest_half;  ///< per axis: max |offset|, max half
};

template <typename T>
IRGRID_HD inline OctantBox<T> octant_box(Vec3<T> lo, Vec3<T> mid, Vec3<T> hi, T padding) {
  OctantBox<T> b;
  for (int k = 0; k < 3; ++k) {
    const T outer_lo = lo[k] - padding, outer_hi = hi[k] + padding;
    b.center[k] = T(0.5) * outer_lo + T(0.5) * outer_hi;
    // The octants' padded intervals, described by centre and half extent as in center_on_box.
    T lower_center, upper_center;
    center_and_half(outer_lo, mid[k] + padding, lower_center, b.half[0][k]);
    center_and_half(mid[k] - padding, outer_hi, upper_center, b.half[1][k]);
    b.offset[0][k] = lower_center - b.center[k];
    b.offset[1][k] = upper_center - b.center[k];
    b.farthest_offset[k] = max_of(abs_of(b.offset[0][k]), abs_of(b.offset[1][k]));
    b.largest_half[k] = max_of(b.half[0][k], b.half[1][k]);
  }
  return b;
}

/// An OctantBox with a triangle in its frame.
template <typename T>
struct OctantFrame {
  Vec3<T> v0, v1, v2;  ///< vertices minus C
  Vec3<T> offset[2];   ///< as in OctantBox
  Vec3<T> half[2];     ///< as in OctantBox
  Vec3<T> reach;       ///< per axis: max_i |v_ik| + max |offset_k| + max half_k + tiny/eps
};

template <typename T>
IRGRID_HD inline OctantFrame<T> octant_frame(Vec3<T> p0, Vec3<T> p1, Vec3<T> p2,
                                             const OctantBox<T>& b) {
  OctantFrame<T> f;
  const T floor = smallest_normal<T>() / machine_epsilon<T>();
  for (int k = 0; k < 3; ++k) {
    f.half[0][k] = b.half[0][k];
    f.half[1][k] = b.half[1][k];
    f.offset[0][k] = b.offset[0][k];
    f.offset[1][k] = b.offset[1][k];
    f.v0[k] = p0[k] - b.center[k];
    f.v1[k] = p1[k] - b.center[k];
    f.v2[k] = p2[k] - b.center[k];
    const T farthest = max_of(abs_of(f.v0[k]), max_of(abs_of(f.v1[k]), abs_of(f.v2[k])));
    f.reach[k] = farthest + b.farthest_offset[k] + b.largest_half[k] + floor;
  }
  return f;
}

/// The octants (bit x | y << 1 | z << 2) whose projection onto an axis, centre
/// (shift[0][x] + shift[1][y]) + shift[2][z] and radius (extent[0][x] + extent[1][y]) +
/// extent[2][z], lies farther than `tolerance` below `lowest` or above `highest`. NaN or
/// infinite values separate nothing. Without branches: the outcomes follow no pattern a branch
/// predictor could learn.
template <typename T>
IRGRID_HD IRGRID_ALWAYS_INLINE std::uint32_t separated_octants_portable(const T (&shift)[3][2],
                                                                        const T (&extent)[3][2],
                                                                        T lowest, T highest,
                                                                        T tolerance) {
  std::uint32_t separated = 0;
  for (std::uint32_t bit = 0; bit < 8; ++bit) {
    const std::uint32_t x = bit & 1, y = bit >> 1 & 1, z = bit >> 2 & 1;
    const T s = (shift[0][x] + shift[1][y]) + shift[2][z];
    const T radius = (extent[0][x] + extent[1][y]) + extent[2][z];
    const bool apart = ((lowest - s) - radius > tolerance) | ((s - highest) - radius > tolerance);
    separated |= std::uint32_t(apart) << bit;
  }
  return separated;
}

/// separated_octants_portable, the same bits; on the host in float, 4 octants (one z half) per
/// SSE vector with the same operations in the same order (8% off Sponza's octree phase).
template <typename T>
IRGRID_HD IRGRID_ALWAYS_INLINE std::uint32_t separated_octants(const T (&shift)[3][2],
                                                               const T (&extent)[3][2], T lowest,
                                                               T highest, T tolerance) {
#if defined(__SSE2__) && !defined(__CUDA_ARCH__)
  if constexpr (sizeof(T) == sizeof(float)) {
    const __m128 shift_xy = _mm_setr_ps(shift[0][0] + shift[1][0], shift[0][1] + shift[1][0],
                                        shift[0][0] + shift[1][1], shift[0][1] + shift[1][1]);
    const __m128 extent_xy = _mm_setr_ps(extent[0][0] + extent[1][0], extent[0][1] + extent[1][0],
                                         extent[0][0] + extent[1][1], extent[0][1] + extent[1][1]);
    const __m128 low = _mm_set1_ps(lowest), high = _mm_set1_ps(highest);
    const __m128 margin = _mm_set1_ps(tolerance);
    std::uint32_t separated = 0;
    for (int z = 0; z < 2; ++z) {
      const __m128 s = _mm_add_ps(shift_xy, _mm_set1_ps(shift[2][z]));
      const __m128 radius = _mm_add_ps(extent_xy, _mm_set1_ps(extent[2][z]));
      // _mm_cmpgt_ps is false on NaN, as `>` is.
      const __m128 apart = _mm_or_ps(_mm_cmpgt_ps(_mm_sub_ps(_mm_sub_ps(low, s), radius), margin),
                                     _mm_cmpgt_ps(_mm_sub_ps(_mm_sub_ps(s, high), radius), margin));
      separated |= std::uint32_t(_mm_movemask_ps(apart)) << (4 * z);
    }
    return separated;
  }
#endif
  return separated_octants_portable(shift, extent, lowest, highest, tolerance);
}

/// `mask` less the octants whose projections onto `axis` are disjoint from the triangle's by
/// more than rounding could explain; kZero as in separated_along.
template <int kZero = -1, typename T>
IRGRID_HD IRGRID_ALWAYS_INLINE std::uint32_t octants_not_separated_along(Vec3<T> axis,
                                                                         const OctantFrame<T>& f,
                                                                         std::uint32_t mask) {
  const T d0 = dot_without<kZero>(axis, f.v0), d1 = dot_without<kZero>(axis, f.v1),
          d2 = dot_without<kZero>(axis, f.v2);
  const Vec3<T> magnitude = abs_of(axis);
  const T tolerance = T(8) * machine_epsilon<T>() * dot_without<kZero>(magnitude, f.reach) +
                      T(16) * smallest_normal<T>();
  const T lowest = min_of(d0, min_of(d1, d2)), highest = max_of(d0, max_of(d1, d2));
  // Per axis and side, the terms of the octant centre's projection and of its radius.
  T shift[3][2], extent[3][2];
  for (int k = 0; k < 3; ++k)
    for (int side = 0; side < 2; ++side) {
      shift[k][side] = axis[k] * f.offset[side][k];
      extent[k][side] = magnitude[k] * f.half[side][k];
    }
  return mask & ~separated_octants(shift, extent, lowest, highest, tolerance);
}

}  // namespace triangle_box_detail

/// Whether triangle (p0, p1, p2) overlaps the closed box [box_lo, box_hi] grown by `padding`
/// (an absolute distance >= 0) on every side. Conservative: touching counts as overlap and
/// rounding never turns a touching or overlapping pair into "no overlap", for any triangle
/// (degenerate ones included) and any finite coordinates; it may answer true for pairs that
/// are apart by a few units in the last place of their coordinates relative to the box centre.
/// Requires box_lo <= box_hi.
template <typename T>
IRGRID_HD IRGRID_ALWAYS_INLINE bool triangle_overlaps_box(Vec3<T> p0, Vec3<T> p1, Vec3<T> p2,
                                                          Vec3<T> box_lo, Vec3<T> box_hi,
                                                          T padding) {
  using namespace triangle_box_detail;
  const CenteredTriangle<T> t = center_on_box(p0, p1, p2, box_lo, box_hi, padding);
  // Box face normals first: the triangle's bounding box against the box, the cheapest test.
  if (separated_along_unit<0>(t) || separated_along_unit<1>(t) || separated_along_unit<2>(t))
    return false;
  const Vec3<T> e0 = t.v1 - t.v0, e1 = t.v2 - t.v1, e2 = t.v0 - t.v2;
  // The triangle's plane against the box.
  if (separated_along(cross(e0, e1), t)) return false;
  return !(edge_separates(e0, t) || edge_separates(e1, t) || edge_separates(e2, t));
}

/// Which of the 8 octants of `box` (octant_box: [lo, hi] split at mid, bit 0 selects the upper
/// x half, bit 1 y, bit 2 z, each grown by the padding) the triangle overlaps, among the bits of
/// `candidates`. Conservative like triangle_overlaps_box (the header comment says why), with
/// the triangle's projections onto the 13 axes shared by the octants. Requires lo <= mid <= hi.
template <typename T>
IRGRID_HD inline std::uint32_t octants_overlapped(Vec3<T> p0, Vec3<T> p1, Vec3<T> p2,
                                                  const triangle_box_detail::OctantBox<T>& box,
                                                  std::uint32_t candidates) {
  using namespace triangle_box_detail;
  const OctantFrame<T> f = octant_frame(p0, p1, p2, box);
  std::uint32_t mask = candidates;
  mask = octants_not_separated_along<1>(Vec3<T>{T(1), T(0), T(0)}, f, mask);
  mask = octants_not_separated_along<0>(Vec3<T>{T(0), T(1), T(0)}, f, mask);
  mask = octants_not_separated_along<0>(Vec3<T>{T(0), T(0), T(1)}, f, mask);
  const Vec3<T> e0 = f.v1 - f.v0, e1 = f.v2 - f.v1, e2 = f.v0 - f.v2;
  if (mask) mask = octants_not_separated_along(cross(e0, e1), f, mask);
  const Vec3<T> edges[3] = {e0, e1, e2};
  for (int i = 0; i < 3 && mask; ++i) {
    const Vec3<T> e = edges[i];
    mask = octants_not_separated_along<0>(Vec3<T>{T(0), e.z, -e.y}, f, mask);
    mask = octants_not_separated_along<1>(Vec3<T>{-e.z, T(0), e.x}, f, mask);
    mask = octants_not_separated_along<2>(Vec3<T>{e.y, -e.x, T(0)}, f, mask);
  }
  return mask;
}

/// octants_overlapped for the box [lo, hi] split at mid; the form above lets many triangles
/// share the box's half of the work.
template <typename T>
IRGRID_HD inline std::uint32_t octants_overlapped(Vec3<T> p0, Vec3<T> p1, Vec3<T> p2, Vec3<T> lo,
                                                  Vec3<T> mid, Vec3<T> hi, T padding,
                                                  std::uint32_t candidates) {
  return octants_overlapped(p0, p1, p2, triangle_box_detail::octant_box(lo, mid, hi, padding),
                            candidates);
}

}  // namespace irgrid
