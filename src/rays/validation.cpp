// Validation of hits against the double-precision brute force (docs/benchmarks.md).
#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "core/random.h"
#include "irgrid/accelerator.h"
#include "irgrid/validate.h"

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

bool agrees(const Hit& hit, const Hit& reference, Query query, double tolerance) {
  if (query == Query::any) return hit.hit() == reference.hit();
  if (!hit.hit() || !reference.hit()) return hit.hit() == reference.hit();
  return hit.prim == reference.prim || std::abs(double(hit.t) - double(reference.t)) <= tolerance;
}

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
  const double tolerance = 1e-5 * scene.bounds().diagonal();
  Validation result;
  result.checked = indices.size();
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const Hit& hit = hits[indices[k]];
    if (agrees(hit, reference[k], query, tolerance)) continue;
    ++result.mismatches;
    if (result.examples.size() < 5)
      result.examples.push_back(describe(indices[k], picked[k], hit, reference[k]));
  }
  return result;
}

}  // namespace irgrid
