// irgrid/io/rays.h: the standard benchmark rays (primary, ao, diffuse, random) and ray files.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/scene.h"
#include "irgrid/ray.h"

namespace irgrid {

/// The four standard ray kinds of docs/benchmarks.md.
enum class RayKind { primary, ao, diffuse, random };

/// "primary", "ao", "diffuse", "random".
const char* to_string(RayKind kind) noexcept;
/// Parses a kind name; throws Error{invalid_argument} naming the value.
RayKind parse_ray_kind(const std::string& name);

/// Most secondary rays per primary hit that secondary_rays accepts.
inline constexpr int kMaxSamplesPerHit = 1 << 16;

/// Parameters of ray generation. The same parameters always give the same rays.
struct RayConfig {
  int width = 1024;   ///< image width for primary-derived kinds
  int height = 1024;  ///< image height
  int spp = 4;        ///< secondary rays per primary hit (ao, diffuse), 1..kMaxSamplesPerHit
  std::uint64_t count = 1u << 20;  ///< number of rays for `random`
  std::uint64_t seed = 0x1a2b3c4d;
};

/// One pinhole ray per pixel centre, row-major from the top-left pixel, tmin = 0, tmax = inf.
std::vector<Ray> primary_rays(const Camera& camera, int width, int height);

/// For every primary hit (in ray order) `spp` cosine-weighted directions about the geometric
/// normal flipped to face the primary ray; origin offset by 1e-4 x scene diagonal along that
/// normal; tmax = 0.1 x diagonal for ao, infinity for diffuse. Directions are unit length.
std::vector<Ray> secondary_rays(const Scene& scene, std::span<const Ray> primary,
                                std::span<const Hit> primary_hits, RayKind kind, int spp,
                                std::uint64_t seed);

/// Origins uniform in the scene box, directions uniform on the sphere, tmax = infinity.
std::vector<Ray> random_rays(const Box3f& box, std::uint64_t count, std::uint64_t seed);

/// Generates rays of `kind` for `camera`; ao and diffuse trace the primary rays with `tracer`
/// (which primary and random rays do not need: it may then be null).
std::vector<Ray> generate_rays(const Scene& scene, const Camera& camera, RayKind kind,
                               const RayConfig& config, const Accelerator* tracer);

/// Ray file formats: irgrid's 32-byte records (origin, tmin, direction, tmax) and the 24-byte
/// records of the paper's reference code (origin, direction; tmin/tmax given for all rays).
enum class RayFormat { irgrid, hagrid };
RayFormat parse_ray_format(const std::string& name);

/// Writes rays; hagrid's format drops tmin/tmax. Throws Error{io} naming the path.
void write_rays(const std::string& path, std::span<const Ray> rays, RayFormat format);
/// Reads rays; for hagrid's format every ray gets [tmin, tmax]. Throws Error{io} naming the
/// path for an unreadable file or a size that is not a whole number of records.
std::vector<Ray> read_rays(const std::string& path, RayFormat format, float tmin = 0,
                           float tmax = std::numeric_limits<float>::infinity());
/// Writes 16-byte hit records in ray order.
void write_hits(const std::string& path, std::span<const Hit> hits);

}  // namespace irgrid
