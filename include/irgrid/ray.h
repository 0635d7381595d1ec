// irgrid/ray.h: the plain ray and hit records exchanged with every structure and backend.
#pragma once

#include <cstdint>
#include <limits>

namespace irgrid {

/// One ray, 32 bytes, the layout of irgrid's ray files (8 float32, little endian).
/// Points on the ray are org + t * dir for tmin <= t <= tmax; dir need not be normalised.
struct Ray {
  float org[3];  ///< 12 B origin
  float tmin;    ///< 4 B  start of the valid interval
  float dir[3];  ///< 12 B direction (not necessarily unit length; must not be zero)
  float tmax;    ///< 4 B  end of the valid interval (may be +infinity)
};
static_assert(sizeof(Ray) == 32 && alignof(Ray) == 4);

/// The primitive id of a miss: all bits set.
inline constexpr std::uint32_t kNoHit = 0xFFFFFFFFu;

/// One hit, 16 bytes, the layout of irgrid's hit files.
/// Closest hit: the nearest triangle with tmin <= t <= tmax; barycentrics u, v weigh the
/// triangle's second and third vertex (p = (1-u-v) v0 + u v1 + v v2), as in Embree.
/// Any hit: prim != kNoHit when the ray is occluded; which triangle it names, and t, u, v,
/// depend on the structure.
struct Hit {
  std::uint32_t prim = kNoHit;                       ///< 4 B triangle index, kNoHit on a miss
  float t = std::numeric_limits<float>::infinity();  ///< 4 B distance in units of |dir|
  float u = 0;                                       ///< 4 B barycentric of v1
  float v = 0;                                       ///< 4 B barycentric of v2
  bool hit() const { return prim != kNoHit; }
};
static_assert(sizeof(Hit) == 16 && alignof(Hit) == 4);

/// What a trace call computes for each ray.
enum class Query {
  closest,  ///< the nearest intersection
  any,      ///< whether any intersection exists (occlusion; shadow and AO rays)
};

}  // namespace irgrid
