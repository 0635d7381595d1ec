// core/watertight.h: watertight ray/triangle intersection for host and device, float or double.
//
// Woop, Benthin, Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013. The ray is
// sheared so it runs along +z; the three 2D edge functions are then computed per edge from the
// two vertices alone, so a shared edge gives bit-identical (negated) values in both triangles
// and no ray slips between them. That needs the products to be rounded separately (no fused
// multiply-add): CMake passes -ffp-contract=off and device code uses the _rn intrinsics.
#pragma once

#include "core/platform.h"
#include "core/vec.h"
#include "irgrid/ray.h"

namespace irgrid {

/// a*b - c*d with each product rounded on its own (never contracted into an FMA).
template <typename T>
IRGRID_HD inline T difference_of_products(T a, T b, T c, T d) {
#if IRGRID_ON_DEVICE
  if constexpr (sizeof(T) == 4)
    return __fsub_rn(__fmul_rn(a, b), __fmul_rn(c, d));
  else
    return __dsub_rn(__dmul_rn(a, b), __dmul_rn(c, d));
#else
  return a * b - c * d;
#endif
}

/// a - b*c with the product rounded on its own (never contracted into an FMA).
template <typename T>
IRGRID_HD inline T minus_product(T a, T b, T c) {
#if IRGRID_ON_DEVICE
  if constexpr (sizeof(T) == 4)
    return __fsub_rn(a, __fmul_rn(b, c));
  else
    return __dsub_rn(a, __dmul_rn(b, c));
#else
  return a - b * c;
#endif
}

/// Per-ray constants of the watertight test, as in the paper: the axis kz where the direction
/// is largest, kx and ky the other two (swapped to keep the winding), and the shear
/// x' = x[kx] - sx x[kz], y' = x[ky] - sy x[kz], z' = sz x[kz]. The origin is stored permuted,
/// (org[kx], org[ky], org[kz]), so each triangle reads it without indexing.
template <typename T>
struct WatertightRay {
  Vec3<T> org_k;
  int kx, ky, kz;
  T sx, sy, sz;
  T tmin, tmax;
};

template <typename T>
IRGRID_HD inline WatertightRay<T> make_watertight_ray(const Ray& ray) {
  WatertightRay<T> r;
  const Vec3<T> dir = Vec3<T>::from(ray.dir);
  const T ax = dir.x < 0 ? -dir.x : dir.x, ay = dir.y < 0 ? -dir.y : dir.y;
  const T az = dir.z < 0 ? -dir.z : dir.z;
  r.kz = (ax >= ay && ax >= az) ? 0 : (ay >= az ? 1 : 2);
  r.kx = r.kz == 2 ? 0 : r.kz + 1;
  r.ky = r.kx == 2 ? 0 : r.kx + 1;
  if (dir[r.kz] < 0) {  // keep the winding, so the sign of the edge functions means the same
    const int swap = r.kx;
    r.kx = r.ky;
    r.ky = swap;
  }
  r.sx = dir[r.kx] / dir[r.kz];
  r.sy = dir[r.ky] / dir[r.kz];
  r.sz = T(1) / dir[r.kz];
  r.org_k = {T(ray.org[r.kx]), T(ray.org[r.ky]), T(ray.org[r.kz])};
  r.tmin = T(ray.tmin);
  r.tmax = T(ray.tmax);
  return r;
}

/// One vertex relative to the ray origin, sheared: (x', y', z') of the paper. The coordinates
/// are read by index from the vertex in memory (no selects), each product rounded on its own.
template <typename T>
IRGRID_HD inline void shear_vertex(const WatertightRay<T>& r, const Vec3<T>& p, T& x, T& y, T& z) {
  // Vec3 is three consecutive T, so its coordinates can be addressed as an array.
  const T* c = &p.x;
  const T pz = c[r.kz] - r.org_k.z;
  x = minus_product(c[r.kx] - r.org_k.x, r.sx, pz);
  y = minus_product(c[r.ky] - r.org_k.y, r.sy, pz);
  z = r.sz * pz;
}

/// Whether some of u, v, w are negative and others positive (the ray passes outside an edge).
template <typename T>
IRGRID_HD inline bool mixed_signs(T u, T v, T w) {
  const T lowest = u < v ? (u < w ? u : w) : (v < w ? v : w);
  const T highest = u > v ? (u > w ? u : w) : (v > w ? v : w);
  return lowest < T(0) && highest > T(0);
}

/// Hit distance and barycentrics (u weighs p1, v weighs p2).
template <typename T>
struct TriangleHit {
  T t, u, v;
};

/// Intersects the ray with triangle (p0, p1, p2), both faces. Returns true and fills `hit` when
/// the distance t satisfies r.tmin <= t <= r.tmax and t < t_limit. Degenerate triangles and rays
/// in the triangle's plane never hit.
template <typename T>
IRGRID_HD IRGRID_ALWAYS_INLINE bool intersect_watertight(const WatertightRay<T>& r,
                                                         const Vec3<T>& p0, const Vec3<T>& p1,
                                                         const Vec3<T>& p2, T t_limit,
                                                         TriangleHit<T>& hit) {
  T a_x, a_y, a_z, b_x, b_y, b_z, c_x, c_y, c_z;
  shear_vertex(r, p0, a_x, a_y, a_z);
  shear_vertex(r, p1, b_x, b_y, b_z);
  shear_vertex(r, p2, c_x, c_y, c_z);
  T u = difference_of_products(c_x, b_y, c_y, b_x);
  T v = difference_of_products(a_x, c_y, a_y, c_x);
  T w = difference_of_products(b_x, a_y, b_y, a_x);
  // Rounding is monotonic, so a float edge function has the exact sign of the double one or is
  // 0: mixed nonzero signs are a miss whatever the double test would make of a zero.
  if (mixed_signs(u, v, w)) return false;
  if constexpr (sizeof(T) == 4) {
    // An edge function of exactly zero may be a rounding artefact: redo it in double.
    if (u == T(0) || v == T(0) || w == T(0)) {
      u = T(difference_of_products(double(c_x), double(b_y), double(c_y), double(b_x)));
      v = T(difference_of_products(double(a_x), double(c_y), double(a_y), double(c_x)));
      w = T(difference_of_products(double(b_x), double(a_y), double(b_y), double(a_x)));
      if (mixed_signs(u, v, w)) return false;
    }
  }
  const T det = u + v + w;
  if (det == T(0)) return false;
  const T t_scaled = u * a_z + v * b_z + w * c_z;
  const T inv_det = T(1) / det;
  const T t = t_scaled * inv_det;
  if (!(t >= r.tmin && t <= r.tmax && t < t_limit)) return false;
  hit.t = t;
  hit.u = v * inv_det;
  hit.v = w * inv_det;
  return true;
}

}  // namespace irgrid
