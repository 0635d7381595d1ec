// Validation of hits against the double-precision brute force (docs/benchmarks.md).
#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "irgrid/accelerator.h"
#include "irgrid/io/random.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {
namespace {

/// `sample` distinct indices below `count`, ascending (a partial Fisher-Yates shuffle).
std::vector<std::size_t> sample_indices(std::size_t count, std::uint64_t sample,
                                        std::uint64_t seed) {
  std::vector<std::size_t> indices(count);
  std::iota(indices.begin(), indices.end(), std::size_t(0));
  if (sample >= count) return indices;
  Pcg32 rng;
  rng.seed(hash64(seed));
  for (std::size_t i = 0; i < sample; ++i) {
    const std::uint64_t span = count - i;
    const std::size_t j =
        i + std::size_t((std::uint64_t(rng.next_u32()) << 32 | rng.next_u32()) % span);
    std::swap(indices[i], indices[j]);
  }
  indices.resize(sample);
  std::sort(indices.begin(), indices.end());
  return indices;
}

/// Distance from point p to segment [a, b].
double distance_to_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = b - a;
  const double length2 = dot(ab, ab);
  const double s = length2 > 0 ? std::clamp(dot(p - a, ab) / length2, 0.0, 1.0) : 0.0;
  return length(p - (a + ab * s));
}

/// Judges hits against the reference within a distance tolerance.
class HitJudge {
 public:
  HitJudge(const Scene& scene, double tolerance) : scene_(scene), tolerance_(tolerance) {}

  /// A hit float and double may legitimately disagree on: within the tolerance of the ray's
  /// interval ends or of the triangle's boundary (a ray starting on a surface, or grazing an
  /// open edge). Hits with an unknown distance (NaN) are never fragile.
  bool fragile(const Ray& ray, const Hit& hit) const {
    if (!hit.hit() || !std::isfinite(hit.t)) return false;
    const Vec3d dir = Vec3d::from(ray.dir);
    const double speed = length(dir);
    if (std::abs(double(hit.t) - ray.tmin) * speed <= tolerance_) return true;
    if (std::isfinite(ray.tmax) && std::abs(double(ray.tmax) - hit.t) * speed <= tolerance_)
      return true;
    const auto& tri = scene_.triangles[hit.prim];
    const Vec3d p0 = Vec3d::from(scene_.vertices[tri[0]]),
                p1 = Vec3d::from(scene_.vertices[tri[1]]),
                p2 = Vec3d::from(scene_.vertices[tri[2]]);
    const Vec3d point = Vec3d::from(ray.org) + dir * double(hit.t);
    return std::min({distance_to_segment(point, p0, p1), distance_to_segment(point, p1, p2),
                     distance_to_segment(point, p2, p0)}) <= tolerance_;
  }

  /// Whether `a` is a hit clearly (beyond the tolerance) closer than `b`.
  bool clearly_closer(const Ray& ray, const Hit& a, const Hit& b) const {
    if (!a.hit()) return false;
    if (!b.hit()) return true;
    return (double(b.t) - double(a.t)) * length(Vec3d::from(ray.dir)) > tolerance_;
  }

  /// Closest hit: wrong when either side has a robust hit clearly before the other's answer.
  /// Any hit: wrong when the occlusion differs and the side that saw a hit saw a robust one.
  bool agrees(const Ray& ray, const Hit& hit, const Hit& reference, Query query) const {
    if (query == Query::any) {
      if (hit.hit() == reference.hit()) return true;
      return hit.hit() ? fragile(ray, hit) : fragile(ray, reference);
    }
    if (hit.hit() && reference.hit() && hit.prim == reference.prim) return true;
    if (clearly_closer(ray, reference, hit) && !fragile(ray, reference)) return false;
    if (clearly_closer(ray, hit, reference) && !fragile(ray, hit)) return false;
    return true;
  }

 private:
  const Scene& scene_;
  double tolerance_;
};

std::string describe(std::size_t index, const Ray& ray, const Hit& hit, const Hit& reference) {
  auto show = [](const Hit& h) {
    return h.hit() ? fmt::format("triangle {} at t={:.9g}", h.prim, h.t) : std::string("miss");
  };
  return fmt::format(
      "ray {} (org {:.9g},{:.9g},{:.9g} dir {:.9g},{:.9g},{:.9g}): got {}, reference {}", index,
      ray.org[0], ray.org[1], ray.org[2], ray.dir[0], ray.dir[1], ray.dir[2], show(hit),
      show(reference));
}

}  // namespace

Validation validate_hits(const Scene& scene, std::span<const Ray> rays, std::span<const Hit> hits,
                         Query query, std::uint64_t sample, std::uint64_t seed) {
  return validate_hits(ReferenceTracer(scene), scene, rays, hits, query, sample, seed);
}

Validation validate_hits(const ReferenceTracer& reference_tracer, const Scene& scene,
                         std::span<const Ray> rays, std::span<const Hit> hits, Query query,
                         std::uint64_t sample, std::uint64_t seed) {
  const auto indices = sample_indices(rays.size(), sample, seed);
  std::vector<Ray> picked(indices.size());
  for (std::size_t k = 0; k < indices.size(); ++k)
    picked[k] = rays[indices[k]];
  std::vector<Hit> reference(picked.size());
  reference_tracer.trace(picked, reference, query);
  const HitJudge judge(scene, 1e-5 * scene.bounds().diagonal());
  Validation result;
  result.checked = indices.size();
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const Hit& hit = hits[indices[k]];
    if (judge.agrees(picked[k], hit, reference[k], query)) continue;
    ++result.mismatches;
    if (result.examples.size() < 5)
      result.examples.push_back(describe(indices[k], picked[k], hit, reference[k]));
  }
  return result;
}

}  // namespace irgrid
