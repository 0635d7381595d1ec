// irgrid/io/exact.h: the exact oracle, a reference that shares no arithmetic with the float test.
//
// The float and double watertight tests (irgrid/kernel/watertight.h) shear the ray into a
// coordinate frame and round every step. The oracle instead decides with exact signs: the side of
// the ray's line against each edge is the sign of det[a - o, b - o, d], found in double with a
// proven error bound (in the style of Shewchuk's adaptive predicates) and, where that bound cannot
// decide, with GMP rationals; t is the exact line/plane intersection N / D, compared with tmin,
// tmax and other hits the same way. docs/validation.md states its conventions.
#pragma once

#include <memory>
#include <span>

#include "irgrid/accelerator.h"
#include "irgrid/io/scene.h"
#include "irgrid/io/validate.h"
#include "irgrid/ray.h"

namespace irgrid {

/// What the oracle knows about a ray and one triangle.
struct ExactIntersection {
  /// The ray's line passes through the triangle. A line exactly through an edge or a vertex is
  /// shifted by an infinitesimal in a fixed direction across it (simulation of simplicity), so of
  /// the triangles around an edge or vertex of a closed mesh exactly one is crossed; at an open
  /// boundary the shift decides. Triangles seen edge-on are never crossed.
  bool crosses = false;
  /// crosses, and tmin <= t <= tmax exactly.
  bool in_window = false;
  /// The line is parallel to the triangle's plane (or lies in it): t, u, v are NaN.
  bool parallel = false;
  /// The line/plane intersection o + t dir and its barycentrics (u weighs the second vertex, v
  /// the third), also when the line passes beside the triangle; within 1e-12 of the exact
  /// values, relative for t, absolute for u and v.
  double t = NAN, u = NAN, v = NAN;
};

/// The oracle's answer for one ray and triangle (p0, p1, p2). Rays with a zero or non-finite
/// direction, a non-finite origin, or a NaN tmin or tmax never cross.
ExactIntersection intersect_exact(const Ray& ray, const Vec3f& p0, const Vec3f& p1,
                                  const Vec3f& p2);

/// The exact oracle over a scene: closest hit = the smallest exact t in [tmin, tmax], ties to the
/// smallest triangle id; any hit = the first crossing triangle found with t in [tmin, tmax]. It
/// skips triangles through a bounding-volume hierarchy of its own whose slab tests are widened
/// by far more than their rounding error, so that no triangle the ray can hit is ever culled
/// (test_exact_oracle.cpp checks it against the oracle without culling).
class ExactTracer final : public HitReference {
 public:
  explicit ExactTracer(const Scene& scene);
  ~ExactTracer() override;
  ExactTracer(const ExactTracer&) = delete;
  ExactTracer& operator=(const ExactTracer&) = delete;
  /// Traces rays[i] into hits[i] for every i, in parallel; t, u, v rounded to float.
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override;
  /// The same without culling: every triangle is tested (slow; for tests).
  void trace_all_triangles(std::span<const Ray> rays, std::span<Hit> hits, Query query) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace irgrid
