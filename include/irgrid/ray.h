// irgrid/ray.h: the plain ray and hit records exchanged with every structure and backend.
#pragma once

#include <cstddef>
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

/// Rays read in place from the caller's own arrays, for callers whose rays are not Ray records:
/// numpy's (N, 6) origin-and-direction rows, a structure of arrays, a renderer's ray struct.
/// Ray i starts at origins[i * origin_stride + 0..2] and points along
/// directions[i * direction_stride + 0..2] over [tmin[i * tmin_stride], tmax[i * tmax_stride]].
/// Strides count floats, not bytes; a stride of 0 gives every ray the same value. A null tmin
/// means 0 and a null tmax +infinity for every ray. (N, 6) rows: origins = rows,
/// directions = rows + 3, both strides 6. Strides of 2^26 floats or more are refused.
struct RayArrays {
  std::size_t count = 0;              ///< rays
  const float* origins = nullptr;     ///< xyz of ray 0, then of ray 1 `origin_stride` floats on
  std::size_t origin_stride = 3;      ///< floats from one ray's origin to the next
  const float* directions = nullptr;  ///< xyz (not necessarily unit length; must not be zero)
  std::size_t direction_stride = 3;   ///< floats from one ray's direction to the next
  const float* tmin = nullptr;        ///< start of each ray's interval; null: 0
  std::size_t tmin_stride = 0;        ///< 0: one tmin for every ray
  const float* tmax = nullptr;        ///< end of each ray's interval; null: +infinity
  std::size_t tmax_stride = 0;        ///< 0: one tmax for every ray
};

/// Where trace writes each ray's hit in the caller's own arrays: ray i's distance into
/// t[i * t_stride], and so on. Any pointer may be null: that output is not written. Strides count
/// elements (floats or uint32), not bytes. On a miss: t = +infinity, prim = kNoHit, u = v = 0,
/// normal = (0, 0, 0), as Hit{} holds; for Query::any, the Hit rules hold for each output.
struct HitArrays {
  float* t = nullptr;             ///< distance in units of |dir|
  std::size_t t_stride = 1;       ///<
  std::uint32_t* prim = nullptr;  ///< triangle index
  std::size_t prim_stride = 1;    ///<
  float* u = nullptr;             ///< barycentric of the triangle's second vertex
  std::size_t u_stride = 1;       ///<
  float* v = nullptr;             ///< barycentric of the third vertex
  std::size_t v_stride = 1;       ///<
  /// xyz of the unit geometric normal (v1 - v0) x (v2 - v0) of the triangle hit (zero for a
  /// degenerate one): triangle_normal of irgrid/kernel/triangle.h.
  float* normal = nullptr;
  std::size_t normal_stride = 3;  ///< floats from one ray's normal to the next
};

/// What a trace call computes for each ray.
enum class Query {
  closest,  ///< the nearest intersection
  any,      ///< whether any intersection exists (occlusion; shadow and AO rays)
};

}  // namespace irgrid
