// irgrid/kernel/triangle.h: triangles as the tracers store them, and their bounding boxes.
#pragma once

#include <cmath>
#include <cstdint>

#include "irgrid/kernel/platform.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {

/// The three vertices of a triangle, 36 bytes: what the watertight test reads.
struct TriangleVertices {
  Vec3<float> p0, p1, p2;  ///< 3 x 12 B
};
static_assert(sizeof(TriangleVertices) == 36 && alignof(TriangleVertices) == 4);

/// The unit geometric normal (p1 - p0) x (p2 - p0), zero for a degenerate triangle. In double:
/// the edges and products of float coordinates are exact there, so slivers and large coordinates
/// keep their direction.
IRGRID_HD inline Vec3<float> triangle_normal(const TriangleVertices& t) {
  const double e1[3] = {double(t.p1.x) - t.p0.x, double(t.p1.y) - t.p0.y, double(t.p1.z) - t.p0.z};
  const double e2[3] = {double(t.p2.x) - t.p0.x, double(t.p2.y) - t.p0.y, double(t.p2.z) - t.p0.z};
  const double x = e1[1] * e2[2] - e1[2] * e2[1], y = e1[2] * e2[0] - e1[0] * e2[2],
               z = e1[0] * e2[1] - e1[1] * e2[0];
  const double length = sqrt(x * x + y * y + z * z);
  const double scale = length > 0 ? 1 / length : 0;
  return {float(x * scale), float(y * scale), float(z * scale)};
}

/// Axis-aligned box in world space.
struct BoxF {
  Vec3<float> lo, hi;
};

IRGRID_HD inline float min3(float a, float b, float c) {
  return min_fast(a, min_fast(b, c));
}
IRGRID_HD inline float max3(float a, float b, float c) {
  return max_fast(a, max_fast(b, c));
}

IRGRID_HD inline BoxF triangle_box(const TriangleVertices& t) {
  return {
      {min3(t.p0.x, t.p1.x, t.p2.x), min3(t.p0.y, t.p1.y, t.p2.y), min3(t.p0.z, t.p1.z, t.p2.z)},
      {max3(t.p0.x, t.p1.x, t.p2.x), max3(t.p0.y, t.p1.y, t.p2.y), max3(t.p0.z, t.p1.z, t.p2.z)}};
}

IRGRID_HD inline BoxF box_union(const BoxF& a, const BoxF& b) {
  return {{min_fast(a.lo.x, b.lo.x), min_fast(a.lo.y, b.lo.y), min_fast(a.lo.z, b.lo.z)},
          {max_fast(a.hi.x, b.hi.x), max_fast(a.hi.y, b.hi.y), max_fast(a.hi.z, b.hi.z)}};
}

/// Whether p lies in [lo - padding, hi + padding] on every axis.
IRGRID_HD inline bool point_in_box(const Vec3<float>& p, const Vec3<float>& lo,
                                   const Vec3<float>& hi, float padding) {
  return p.x >= lo.x - padding && p.x <= hi.x + padding && p.y >= lo.y - padding &&
         p.y <= hi.y + padding && p.z >= lo.z - padding && p.z <= hi.z + padding;
}

/// A cheap exact accept before the separating-axis test: a vertex inside the box means overlap.
IRGRID_HD inline bool vertex_in_box(const TriangleVertices& t, const Vec3<float>& lo,
                                    const Vec3<float>& hi, float padding) {
  return point_in_box(t.p0, lo, hi, padding) || point_in_box(t.p1, lo, hi, padding) ||
         point_in_box(t.p2, lo, hi, padding);
}

/// The octants (bit 0 selects the upper x half, bit 1 y, bit 2 z) in the upper half along `axis`.
IRGRID_HD constexpr std::uint32_t upper_octants(int axis) {
  return axis == 0 ? 0xAAu : (axis == 1 ? 0xCCu : 0xF0u);
}

/// The octants of the box [lo, hi] split at mid (bit 0 selects the upper x half, bit 1 y, bit 2
/// z), each grown by `padding`, that hold a vertex of the triangle: vertex_in_box for all eight.
IRGRID_HD inline std::uint32_t octants_holding_vertex(const TriangleVertices& t,
                                                      const Vec3<float>& lo, const Vec3<float>& mid,
                                                      const Vec3<float>& hi, float padding) {
  const Vec3<float> vertices[3] = {t.p0, t.p1, t.p2};
  std::uint32_t held = 0;
  for (int i = 0; i < 3; ++i) {
    std::uint32_t in = 0xFF;
    for (int a = 0; a < 3; ++a) {
      const float x = vertices[i][a];
      if (!(x >= lo[a] - padding && x <= mid[a] + padding)) in &= upper_octants(a);
      if (!(x >= mid[a] - padding && x <= hi[a] + padding)) in &= ~upper_octants(a);
    }
    held |= in;
  }
  return held;
}

}  // namespace irgrid
