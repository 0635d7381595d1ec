// cpu/ray_fields.h: where the CPU walks read their rays and write their hits, field by field, so
// that one walk serves Ray / Hit records and the caller's own arrays (RayArrays, HitArrays)
// alike, with no copy in between.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "irgrid/kernel/triangle.h"
#include "irgrid/ray.h"

namespace irgrid {

/// The rays of a batch as eight float fields (origin xyz, tmin, direction xyz, tmax, the order of
/// Ray), each read at base[f] + i * stride[f]: Ray records are eight fields of stride 8.
struct RayFields {
  static constexpr int kFields = 8;
  const float* base[kFields];
  std::uint32_t stride[kFields];  ///< floats; below 2^26, so that lane offsets fit 32 bits
  std::size_t count;

  /// Ray i, as a record.
  Ray operator[](std::size_t i) const {
    const auto at = [&](int f) { return base[f][i * stride[f]]; };
    return {{at(0), at(1), at(2)}, at(3), {at(4), at(5), at(6)}, at(7)};
  }
  std::size_t size() const { return count; }
  /// Rays [first, first + n).
  RayFields subrange(std::size_t first, std::size_t n) const {
    RayFields out = *this;
    for (int f = 0; f < kFields; ++f)
      out.base[f] += first * stride[f];
    out.count = n;
    return out;
  }
};

/// The records of `rays`.
RayFields ray_fields(std::span<const Ray> rays);
/// The caller's arrays (already checked by check_ray_arrays, with at least one ray).
RayFields ray_fields(const RayArrays& rays);

/// The hit record of a walk's result: Hit{} (the miss) when `prim` is kNoHit, whatever t, u, v say.
inline Hit hit_record(std::uint32_t prim, float t, float u, float v) {
  return prim == kNoHit ? Hit{} : Hit{prim, t, u, v};
}

/// Where the hits of a batch go: Hit records, or as HitArrays (null: not written), strides in
/// elements.
struct HitFields {
  /// Hit records (the fields below are null then): one 16-byte store per hit, not four.
  Hit* records;
  float* t;
  std::uint32_t* prim;
  float* u;
  float* v;
  float* normal;
  std::size_t t_stride, prim_stride, u_stride, v_stride, normal_stride;
  /// The triangles by index, for the normals (null when no normal is written).
  const TriangleVertices* triangles;

  /// Writes the hit of ray i: `prim` kNoHit for a miss, whatever t, u, v say.
  void write(std::size_t i, std::uint32_t hit_prim, float hit_t, float hit_u, float hit_v) const {
    const Hit h = hit_record(hit_prim, hit_t, hit_u, hit_v);
    if (records) {
      records[i] = h;
      return;
    }
    write(i, h, normal ? normal_of(h.prim) : Vec3<float>{0, 0, 0});
  }
  void write(std::size_t i, const Hit& h) const { write(i, h.prim, h.t, h.u, h.v); }
  /// Writes the fields of hit `h` (a miss as Hit{} holds it), with its normal already computed
  /// (normal_of).
  void write(std::size_t i, const Hit& h, const Vec3<float>& n) const {
    if (prim) prim[i * prim_stride] = h.prim;
    if (t) t[i * t_stride] = h.t;
    if (u) u[i * u_stride] = h.u;
    if (v) v[i * v_stride] = h.v;
    if (normal) {
      float* out = normal + i * normal_stride;
      out[0] = n.x, out[1] = n.y, out[2] = n.z;
    }
  }
  /// The normal of triangle `hit_prim`, zero for kNoHit.
  Vec3<float> normal_of(std::uint32_t hit_prim) const {
    return hit_prim == kNoHit ? Vec3<float>{0, 0, 0} : triangle_normal(triangles[hit_prim]);
  }
  /// Hits [first, first + n) go to the fields' element first onwards.
  HitFields subrange(std::size_t first) const {
    HitFields out = *this;
    if (records) out.records += first;
    if (t) out.t += first * t_stride;
    if (prim) out.prim += first * prim_stride;
    if (u) out.u += first * u_stride;
    if (v) out.v += first * v_stride;
    if (normal) out.normal += first * normal_stride;
    return out;
  }
};

/// The records of `hits`.
HitFields hit_fields(std::span<Hit> hits);
/// The caller's arrays; `triangles` (by index) for the normals, when hits.normal is set.
HitFields hit_fields(const HitArrays& hits, const TriangleVertices* triangles);

}  // namespace irgrid
