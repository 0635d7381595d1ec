// The fields of Ray / Hit records and of the caller's arrays.
#include "cpu/ray_fields.h"

#include <cstddef>
#include <limits>

namespace irgrid {

RayFields ray_fields(std::span<const Ray> rays) {
  static_assert(sizeof(Ray) == RayFields::kFields * sizeof(float));
  const float* first = rays.empty() ? nullptr : &rays[0].org[0];
  RayFields out{};
  for (int f = 0; f < RayFields::kFields; ++f)
    out.base[f] = first ? first + f : nullptr, out.stride[f] = RayFields::kFields;
  out.count = rays.size();
  return out;
}

RayFields ray_fields(const RayArrays& rays) {
  // What a null tmin or tmax stands for, read with stride 0.
  static constexpr float kZero = 0, kInfinity = std::numeric_limits<float>::infinity();
  RayFields out{};
  for (int k = 0; k < 3; ++k) {
    out.base[k] = rays.origins + k, out.stride[k] = std::uint32_t(rays.origin_stride);
    out.base[4 + k] = rays.directions + k, out.stride[4 + k] = std::uint32_t(rays.direction_stride);
  }
  out.base[3] = rays.tmin ? rays.tmin : &kZero;
  out.stride[3] = rays.tmin ? std::uint32_t(rays.tmin_stride) : 0;
  out.base[7] = rays.tmax ? rays.tmax : &kInfinity;
  out.stride[7] = rays.tmax ? std::uint32_t(rays.tmax_stride) : 0;
  out.count = rays.count;
  return out;
}

HitFields hit_fields(std::span<Hit> hits) {
  HitFields out{};
  out.records = hits.data();
  return out;
}

HitFields hit_fields(const HitArrays& hits, const TriangleVertices* triangles) {
  return {nullptr,       hits.t,        hits.prim,          hits.u,
          hits.v,        hits.normal,   hits.t_stride,      hits.prim_stride,
          hits.u_stride, hits.v_stride, hits.normal_stride, hits.normal ? triangles : nullptr};
}

}  // namespace irgrid
