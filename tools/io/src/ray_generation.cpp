// The standard benchmark rays of docs/benchmarks.md: primary, ao, diffuse and random.
// Every ray draws its random numbers from a generator seeded by (seed, ray index), so the rays
// do not depend on the thread count or schedule.
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "irgrid/error.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {
namespace {

constexpr double kPi = std::numbers::pi;

void store(Ray& ray, const Vec3d& org, double tmin, const Vec3d& dir, double tmax) {
  ray = {{float(org.x), float(org.y), float(org.z)},
         float(tmin),
         {float(dir.x), float(dir.y), float(dir.z)},
         float(tmax)};
}

/// An orthonormal basis around unit n (Duff et al., "Building an Orthonormal Basis, Revisited",
/// JCGT 2017): no branch on a "least aligned axis", continuous except at n.z = -0.
void orthonormal_basis(const Vec3d& n, Vec3d& b1, Vec3d& b2) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double b = n.x * n.y * a;
  b1 = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
  b2 = {b, sign + n.y * n.y * a, -n.y};
}

Pcg32 ray_generator(std::uint64_t seed, std::uint64_t index) {
  Pcg32 rng;
  rng.seed(hash64(seed ^ hash64(index)), index);
  return rng;
}

void for_each_index(std::size_t count, const auto& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      body(i);
  });
}

}  // namespace

const char* to_string(RayKind kind) noexcept {
  switch (kind) {
    case RayKind::primary:
      return "primary";
    case RayKind::ao:
      return "ao";
    case RayKind::diffuse:
      return "diffuse";
    case RayKind::random:
      return "random";
  }
  return "unknown";
}

RayKind parse_ray_kind(const std::string& name) {
  for (RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random})
    if (name == to_string(kind)) return kind;
  throw Error(ErrorCode::invalid_argument,
              fmt::format("unknown ray kind '{}' (expected primary, ao, diffuse or random)", name));
}

std::vector<Ray> primary_rays(const Camera& camera, int width, int height) {
  if (width <= 0 || height <= 0 || std::uint64_t(width) * std::uint64_t(height) > (1ull << 31))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("image size {}x{} is not between 1x1 and 2^31 pixels", width, height));
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(camera.eye[a]) || !std::isfinite(camera.target[a]) ||
        !std::isfinite(camera.up[a]))
      throw Error(ErrorCode::invalid_argument, "camera: eye, target and up must be finite numbers");
  if (!(camera.fov_deg > 0 && camera.fov_deg < 180))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("camera: field of view {} degrees is not in (0, 180)", camera.fov_deg));
  const Vec3d eye = Vec3d::from(camera.eye);
  const Vec3d forward = normalize(Vec3d::from(camera.target) - eye);
  const Vec3d right = normalize(cross(forward, Vec3d::from(camera.up)));
  const Vec3d up = cross(right, forward);
  if (!std::isfinite(right.x + right.y + right.z))
    throw Error(ErrorCode::invalid_argument,
                "camera: eye equals target, or up is parallel to the view");
  const double tan_half = std::tan(0.5 * camera.fov_deg * kPi / 180.0);
  const double aspect = double(width) / double(height);
  std::vector<Ray> rays(std::size_t(width) * std::size_t(height));
  for_each_index(rays.size(), [&](std::size_t i) {
    const double x = double(i % std::size_t(width)) + 0.5, y = double(i / std::size_t(width)) + 0.5;
    const double px = (2.0 * x / width - 1.0) * tan_half * aspect;
    const double py = (1.0 - 2.0 * y / height) * tan_half;
    store(rays[i], eye, 0.0, normalize(forward + right * px + up * py), INFINITY);
  });
  return rays;
}

std::vector<Ray> secondary_rays(const Scene& scene, std::span<const Ray> primary,
                                std::span<const Hit> primary_hits, RayKind kind, int spp,
                                std::uint64_t seed) {
  if (kind != RayKind::ao && kind != RayKind::diffuse)
    throw Error(ErrorCode::invalid_argument, "secondary_rays: kind must be ao or diffuse");
  if (spp <= 0 || spp > kMaxSamplesPerHit)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("spp {} is not in 1..{}", spp, kMaxSamplesPerHit));
  if (primary.size() != primary_hits.size())
    throw Error(ErrorCode::invalid_argument, "secondary_rays: one hit per primary ray expected");
  std::vector<std::size_t> hit_rays;
  for (std::size_t i = 0; i < primary_hits.size(); ++i)
    if (primary_hits[i].hit()) hit_rays.push_back(i);
  const double diagonal = scene.bounds().diagonal();
  const double offset = 1e-4 * diagonal;
  const double tmax = kind == RayKind::ao ? 0.1 * diagonal : INFINITY;
  std::vector<Ray> rays(hit_rays.size() * std::size_t(spp));
  for_each_index(hit_rays.size(), [&](std::size_t h) {
    const std::size_t i = hit_rays[h];
    const Hit& hit = primary_hits[i];
    const auto& tri = scene.triangles.at(hit.prim);
    const Vec3d p0 = Vec3d::from(scene.vertices[tri[0]]), p1 = Vec3d::from(scene.vertices[tri[1]]),
                p2 = Vec3d::from(scene.vertices[tri[2]]);
    Vec3d normal = normalize(cross(p1 - p0, p2 - p0));
    if (dot(normal, Vec3d::from(primary[i].dir)) > 0) normal = -normal;
    const Vec3d point = p0 * (1.0 - hit.u - hit.v) + p1 * double(hit.u) + p2 * double(hit.v);
    const Vec3d origin = point + normal * offset;
    Vec3d b1, b2;
    orthonormal_basis(normal, b1, b2);
    Pcg32 rng = ray_generator(seed, i);
    for (int s = 0; s < spp; ++s) {
      // Cosine-weighted hemisphere (Malley's method: uniform disk, projected up).
      const double r = std::sqrt(double(rng.next_float())), phi = 2 * kPi * rng.next_float();
      const double x = r * std::cos(phi), y = r * std::sin(phi);
      const double z = std::sqrt(std::max(0.0, 1.0 - x * x - y * y));
      store(rays[h * spp + s], origin, 0.0, normalize(b1 * x + b2 * y + normal * z), tmax);
    }
  });
  return rays;
}

std::vector<Ray> random_rays(const Box3f& box, std::uint64_t count, std::uint64_t seed) {
  if (count > (1ull << 32) - 1)
    throw Error(ErrorCode::limit_exceeded, fmt::format("{} rays exceed 2^32 - 1", count));
  if (box.empty()) throw Error(ErrorCode::invalid_argument, "random rays need a non-empty scene");
  std::vector<Ray> rays(count);
  const Vec3d lo = Vec3d::from(box.lo), extent = Vec3d::from(box.hi) - lo;
  for_each_index(rays.size(), [&](std::size_t i) {
    Pcg32 rng = ray_generator(seed, i);
    const Vec3d origin{lo.x + extent.x * rng.next_float(), lo.y + extent.y * rng.next_float(),
                       lo.z + extent.z * rng.next_float()};
    const double z = 1.0 - 2.0 * rng.next_float(), phi = 2 * kPi * rng.next_float();
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    store(rays[i], origin, 0.0, {r * std::cos(phi), r * std::sin(phi), z}, INFINITY);
  });
  return rays;
}

std::vector<Ray> generate_rays(const Scene& scene, const Camera& camera, RayKind kind,
                               const RayConfig& config, const Accelerator* tracer) {
  if (kind == RayKind::random) return random_rays(scene.bounds(), config.count, config.seed);
  auto primary = primary_rays(camera, config.width, config.height);
  if (kind == RayKind::primary) return primary;
  if (!tracer) throw Error(ErrorCode::invalid_argument, "ao and diffuse rays need a tracer");
  std::vector<Hit> hits(primary.size());
  tracer->trace(primary, hits, Query::closest);
  return secondary_rays(scene, primary, hits, kind, config.spp, config.seed);
}

}  // namespace irgrid
