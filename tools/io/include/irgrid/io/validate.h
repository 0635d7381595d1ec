// irgrid/io/validate.h: checking a structure's hits against the double-precision brute force.
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

/// Outcome of comparing hits with the reference on a sample of rays.
struct Validation {
  std::uint64_t checked = 0;          ///< rays compared
  std::uint64_t mismatches = 0;       ///< rays whose hit disagrees with the reference
  std::vector<std::string> examples;  ///< a few mismatches, described for people
};

/// The double-precision watertight reference, fast: it returns exactly what
/// trace_reference_double returns (closest hit: the smallest t, ties to the smallest triangle
/// id; any hit: whether any triangle is hit), but skips triangles through a bounding-volume
/// hierarchy whose boxes are padded so that no box a ray touches is ever culled.
class ReferenceTracer {
 public:
  explicit ReferenceTracer(const Scene& scene);
  ~ReferenceTracer();
  ReferenceTracer(const ReferenceTracer&) = delete;
  ReferenceTracer& operator=(const ReferenceTracer&) = delete;
  /// Traces rays[i] into hits[i] for every i, in parallel.
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Compares hits[i] with the double-precision reference on `sample` rays chosen at random (all rays
/// when sample >= rays.size()), with a fixed seed. With tol = 1e-5 x scene diagonal: a closest hit
/// is wrong when either side has a hit more than tol closer than the other's answer (or the other
/// missed) that is not *fragile*; an any-hit is wrong when the occlusion differs and the side that
/// saw a hit saw one that is not fragile. A fragile hit lies within tol of the ray's interval ends
/// or of its triangle's boundary: float and double tests may legitimately disagree on it (a ray
/// starting on a surface, or grazing an open edge). Equal ids, or distances within tol (ties on
/// shared edges), always agree.
Validation validate_hits(const ReferenceTracer& reference, const Scene& scene,
                         std::span<const Ray> rays, std::span<const Hit> hits, Query query,
                         std::uint64_t sample, std::uint64_t seed = 7);

/// The same, building the ReferenceTracer for this one call.
Validation validate_hits(const Scene& scene, std::span<const Ray> rays, std::span<const Hit> hits,
                         Query query, std::uint64_t sample, std::uint64_t seed = 7);

}  // namespace irgrid
