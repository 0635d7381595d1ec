// irgrid/io/validate.h: checking a structure's hits against a reference (the double-precision
// brute force, or the exact oracle of irgrid/io/exact.h) and against exact t, u, v.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/io/scene.h"
#include "irgrid/ray.h"

namespace irgrid {

/// Brute force over all triangles in double precision, watertight: the trusted reference that
/// tests and `bench --validate` compare against. Slow; meant for subsets of rays.
void trace_reference_double(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                            Query query);

/// Outcome of comparing hits with the reference on a sample of rays (docs/validation.md).
struct Validation {
  std::uint64_t checked = 0;     ///< rays compared
  std::uint64_t mismatches = 0;  ///< rays with at least one of the faults below
  /// Closest hit: a robust hit, miss or triangle that disagrees with the reference; any hit: a
  /// robust disagreement on occlusion. Both: a reported triangle the ray's line robustly misses.
  std::uint64_t wrong_triangle = 0;
  /// The reported t is further from the exact t of the reported triangle than the float test's
  /// error bound allows.
  std::uint64_t wrong_t = 0;
  /// The reported u or v is further from the exact barycentrics than the bound allows.
  std::uint64_t wrong_uv = 0;
  /// The reported t lies outside [tmin, tmax] (every structure compares its t with both).
  std::uint64_t outside_window = 0;
  /// Disagreements accepted as fragile (not mismatches): a hit or miss within the tolerance of
  /// the interval's ends or of a triangle's boundary.
  std::uint64_t fragile = 0;
  /// Hits whose t, u, v the float test's error bound does not cover (a triangle seen nearly
  /// edge-on, or tiny against its distance: 48 x the edge functions' error exceeds their sum),
  /// so they are not checked.
  std::uint64_t unbounded = 0;
  /// Any-hit answers that say occluded without saying where (t NaN: Embree's occlusion
  /// queries); accepted, but their triangle, t, u and v cannot be checked.
  std::uint64_t unlocated = 0;
  std::vector<std::string> examples;  ///< a few mismatches, described for people
};

/// What validate_hits compares with: traces rays into the hits it trusts.
class HitReference {
 public:
  virtual ~HitReference() = default;
  /// Traces rays[i] into hits[i] for every i.
  virtual void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const = 0;
};

/// The double-precision watertight reference, fast: it returns exactly what
/// trace_reference_double returns (closest hit: the smallest t, ties to the smallest triangle
/// id; any hit: whether any triangle is hit), but skips triangles through a bounding-volume
/// hierarchy whose boxes are padded so that no box a ray touches is ever culled.
class ReferenceTracer final : public HitReference {
 public:
  explicit ReferenceTracer(const Scene& scene);
  ~ReferenceTracer() override;
  ReferenceTracer(const ReferenceTracer&) = delete;
  ReferenceTracer& operator=(const ReferenceTracer&) = delete;
  /// Traces rays[i] into hits[i] for every i, in parallel.
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Compares hits[i] with the reference on `sample` rays chosen at random (all rays when
/// sample >= rays.size()), with a fixed seed. With tol = 1e-5 x scene diagonal: a closest hit
/// is on the wrong triangle when either side has a hit more than tol closer than the other's
/// answer (or the other missed) that is not *fragile*; an any-hit is wrong when the occlusion
/// differs and the side that saw a hit saw one that is not fragile. A fragile hit lies within
/// tol of the ray's interval ends or of its triangle's boundary: float and exact tests may
/// legitimately disagree on it (a ray starting on a surface, or grazing an open edge). Equal
/// ids, or distances within tol (ties on shared edges), always agree. Every reported hit is
/// then checked against the exact intersection of its ray and triangle (intersect_exact): its
/// t lies in [tmin, tmax], the line crosses the triangle (or passes within tol of it), and t,
/// u, v are within the float test's error bounds (float_test_error) of the exact values.
Validation validate_hits(const HitReference& reference, const Scene& scene,
                         std::span<const Ray> rays, std::span<const Hit> hits, Query query,
                         std::uint64_t sample, std::uint64_t seed = 7);

/// The same, building the ReferenceTracer for this one call.
Validation validate_hits(const Scene& scene, std::span<const Ray> rays, std::span<const Hit> hits,
                         Query query, std::uint64_t sample, std::uint64_t seed = 7);

}  // namespace irgrid
