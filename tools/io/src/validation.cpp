// Validation of hits against a reference and against exact t, u, v (docs/validation.md).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <fmt/format.h>

#include "irgrid/accelerator.h"
#include "irgrid/io/exact.h"
#include "irgrid/io/random.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/vec.h"
#include "irgrid/kernel/watertight.h"

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

/// What was found wrong (or accepted as fragile) about one ray's answer.
struct Faults {
  bool wrong_triangle = false, wrong_t = false, wrong_uv = false, outside_window = false;
  bool fragile = false, unbounded = false, unlocated = false;
  std::string detail;
  bool any() const { return wrong_triangle || wrong_t || wrong_uv || outside_window; }
};

/// Judges hits against the reference within a distance tolerance, and against exact t, u, v.
class HitJudge {
 public:
  HitJudge(const Scene& scene, double tolerance) : scene_(scene), tolerance_(tolerance) {}

  /// A hit float and exact tests may legitimately disagree on: within the tolerance of the
  /// ray's interval ends or of the triangle's boundary (a ray starting on a surface, or grazing
  /// an open edge). Hits with an unknown distance (NaN) are never fragile.
  bool fragile(const Ray& ray, const Hit& hit) const {
    if (!hit.hit() || !std::isfinite(hit.t) || hit.prim >= scene_.triangles.size()) return false;
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
  void judge_choice(const Ray& ray, const Hit& hit, const Hit& reference, Query query,
                    Faults& faults) const {
    auto robust = [&](const Hit& h) {
      if (fragile(ray, h)) return faults.fragile = true, false;
      return true;
    };
    if (query == Query::any) {
      if (hit.hit() != reference.hit() && robust(hit.hit() ? hit : reference))
        faults.wrong_triangle = true;
      return;
    }
    if (hit.hit() && reference.hit() && hit.prim == reference.prim) return;
    if ((clearly_closer(ray, reference, hit) && robust(reference)) ||
        (clearly_closer(ray, hit, reference) && robust(hit)))
      faults.wrong_triangle = true;
  }

  /// The reported hit against the exact intersection of its ray and triangle.
  void judge_hit(const Ray& ray, const Hit& hit, Query query, Faults& faults) const {
    if (!hit.hit()) return;
    if (query == Query::any && std::isnan(hit.t)) {
      faults.unlocated = true;
      return;
    }
    if (hit.prim >= scene_.triangles.size()) {
      faults.wrong_triangle = true;
      faults.detail = "no such triangle";
      return;
    }
    if (!(hit.t >= ray.tmin && hit.t <= ray.tmax)) faults.outside_window = true;
    const auto& tri = scene_.triangles[hit.prim];
    const Vec3f &p0 = scene_.vertices[tri[0]], &p1 = scene_.vertices[tri[1]],
                &p2 = scene_.vertices[tri[2]];
    const ExactIntersection exact = intersect_exact(ray, p0, p1, p2);
    if (!exact.crosses && !fragile(ray, hit)) {
      faults.wrong_triangle = true;
      faults.detail = "the ray's line misses the reported triangle";
      return;
    }
    if (exact.parallel) return;
    const auto bound = float_test_bound(ray, p0, p1, p2, exact.t);
    if (!bound) {
      faults.unbounded = true;
      return;
    }
    const double t_error = std::abs(double(hit.t) - exact.t);
    const double uv_error =
        std::max(std::abs(double(hit.u) - exact.u), std::abs(double(hit.v) - exact.v));
    faults.wrong_t = !(t_error <= bound->t);
    faults.wrong_uv = !(uv_error <= bound->uv);
    if (faults.wrong_t || faults.wrong_uv)
      faults.detail = fmt::format("exact t={:.9g} u={:.9g} v={:.9g}, bounds t {:.3g} u/v {:.3g}",
                                  exact.t, exact.u, exact.v, bound->t, bound->uv);
  }

 private:
  struct Bound {
    double t, uv;
  };

  /// How far the float test's t and barycentrics may lie from the exact ones: its own error
  /// bounds (float_test_error) with a quarter more, plus the rounding of the result to float.
  /// None where the bounds do not hold (48 x the edge functions' error exceeds their sum) or
  /// cannot be computed in float.
  static std::optional<Bound> float_test_bound(const Ray& ray, const Vec3f& p0, const Vec3f& p1,
                                               const Vec3f& p2, double exact_t) {
    const auto r = make_watertight_ray<float>(ray);
    float x[3], y[3], z[3], depth[3], u, v, w;
    shear_triangle(r, Vec3<float>::from(p0), Vec3<float>::from(p1), Vec3<float>::from(p2), x, y, z,
                   depth);
    edge_functions(x, y, u, v, w);
    const float det = u + v + w;
    if (!(det != 0)) return std::nullopt;
    const float inv_det = 1 / det, t = (u * z[0] + v * z[1] + w * z[2]) * inv_det;
    const auto error = float_test_error<ScalarLanes>(x, y, z, depth, inv_det, t);
    if (!(48 * double(error.edge) <= std::abs(double(det)))) return std::nullopt;
    constexpr double kSlack = 1.25, kFloatRounding = 0x1p-23;
    const Bound bound{kSlack * error.t + kFloatRounding * std::abs(exact_t) + 1e-30,
                      kSlack * 6.4 * double(error.edge) / std::abs(double(det)) + kFloatRounding};
    // Near the float range's ends the bound's own float products overflow (then the float test
    // redoes t in double): no bound to judge by.
    if (!std::isfinite(bound.t) || !std::isfinite(bound.uv)) return std::nullopt;
    return bound;
  }

  const Scene& scene_;
  double tolerance_;
};

std::string describe(std::size_t index, const Ray& ray, const Hit& hit, const Hit& reference,
                     const Faults& faults) {
  auto show = [](const Hit& h) {
    return h.hit() ? fmt::format("triangle {} at t={:.9g} u={:.9g} v={:.9g}", h.prim, h.t, h.u, h.v)
                   : std::string("miss");
  };
  std::string what;
  for (const auto& [fault, name] : {std::pair{faults.wrong_triangle, "wrong triangle"},
                                    {faults.wrong_t, "wrong t"},
                                    {faults.wrong_uv, "wrong u/v"},
                                    {faults.outside_window, "t outside [tmin, tmax]"}})
    if (fault) what += (what.empty() ? "" : ", ") + std::string(name);
  return fmt::format(
      "{}: ray {} (org {:.9g},{:.9g},{:.9g} dir {:.9g},{:.9g},{:.9g} t in [{:.9g}, {:.9g}]): got "
      "{}, reference {}{}{}",
      what, index, ray.org[0], ray.org[1], ray.org[2], ray.dir[0], ray.dir[1], ray.dir[2], ray.tmin,
      ray.tmax, show(hit), show(reference), faults.detail.empty() ? "" : "; ", faults.detail);
}

}  // namespace

Validation validate_hits(const Scene& scene, std::span<const Ray> rays, std::span<const Hit> hits,
                         Query query, std::uint64_t sample, std::uint64_t seed) {
  return validate_hits(ReferenceTracer(scene), scene, rays, hits, query, sample, seed);
}

Validation validate_hits(const HitReference& reference_tracer, const Scene& scene,
                         std::span<const Ray> rays, std::span<const Hit> hits, Query query,
                         std::uint64_t sample, std::uint64_t seed) {
  const auto indices = sample_indices(rays.size(), sample, seed);
  std::vector<Ray> picked(indices.size());
  for (std::size_t k = 0; k < indices.size(); ++k)
    picked[k] = rays[indices[k]];
  std::vector<Hit> reference(picked.size());
  reference_tracer.trace(picked, reference, query);
  const HitJudge judge(scene, 1e-5 * scene.bounds().diagonal());
  std::vector<Faults> faults(indices.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, indices.size(), 64), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      judge.judge_choice(picked[k], hits[indices[k]], reference[k], query, faults[k]);
      judge.judge_hit(picked[k], hits[indices[k]], query, faults[k]);
    }
  });
  Validation result;
  result.checked = indices.size();
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const Faults& f = faults[k];
    result.wrong_triangle += f.wrong_triangle;
    result.wrong_t += f.wrong_t;
    result.wrong_uv += f.wrong_uv;
    result.outside_window += f.outside_window;
    result.fragile += f.fragile && !f.any();
    result.unbounded += f.unbounded;
    result.unlocated += f.unlocated;
    if (!f.any()) continue;
    ++result.mismatches;
    if (result.examples.size() < 5)
      result.examples.push_back(describe(indices[k], picked[k], hits[indices[k]], reference[k], f));
  }
  return result;
}

}  // namespace irgrid
