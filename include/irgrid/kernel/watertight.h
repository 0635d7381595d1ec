// irgrid/kernel/watertight.h: watertight ray/triangle intersection for host and device, float or
// double.
//
// Woop, Benthin, Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013. The ray is
// sheared so it runs along +z; the three 2D edge functions are then computed per edge from the
// two vertices alone, so a shared edge gives bit-identical (negated) values in both triangles
// and no ray slips between them. That needs the products to be rounded separately (no fused
// multiply-add): CMake passes -ffp-contract=off and device code uses the _rn intrinsics.
#pragma once

#include <math.h>

#include "irgrid/kernel/platform.h"
#include "irgrid/kernel/vec.h"
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

/// Whether a ray's origin and direction are finite. A ray with an infinite or NaN component has
/// no well-defined points, and every structure misses it: the watertight test would otherwise
/// meet every triangle ahead at t = 0 (an infinite direction shears to z' = 0), and Embree
/// asserts on it.
IRGRID_HD inline bool ray_is_finite(const Ray& ray) {
  bool finite = true;
  for (int a = 0; a < 3; ++a)  // x - x is 0 for finite x, NaN for infinities and NaN
    finite &= ray.org[a] - ray.org[a] == 0.f && ray.dir[a] - ray.dir[a] == 0.f;
  return finite;
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

/// One vertex relative to the ray origin, sheared: (x', y', z') of the paper, and its depth
/// along the kz axis before scaling (what t_needs_double bounds the shear's rounding with). The
/// coordinates are read by index from the vertex in memory (no selects), each product rounded
/// on its own.
template <typename T>
IRGRID_HD inline void shear_vertex(const WatertightRay<T>& r, const Vec3<T>& p, T& x, T& y, T& z,
                                   T& depth) {
  // Vec3 is three consecutive T, so its coordinates can be addressed as an array.
  const T* c = &p.x;
  depth = c[r.kz] - r.org_k.z;
  x = minus_product(c[r.kx] - r.org_k.x, r.sx, depth);
  y = minus_product(c[r.ky] - r.org_k.y, r.sy, depth);
  z = r.sz * depth;
}

/// shear_vertex for the three vertices, into arrays indexed by vertex.
template <typename T>
IRGRID_HD inline void shear_triangle(const WatertightRay<T>& r, const Vec3<T>& p0,
                                     const Vec3<T>& p1, const Vec3<T>& p2, T (&x)[3], T (&y)[3],
                                     T (&z)[3], T (&depth)[3]) {
  shear_vertex(r, p0, x[0], y[0], z[0], depth[0]);
  shear_vertex(r, p1, x[1], y[1], z[1], depth[1]);
  shear_vertex(r, p2, x[2], y[2], z[2], depth[2]);
}

/// The paper's edge functions of the sheared vertices, each from the two vertices of its edge
/// alone: u = x2 y1 - y2 x1 (the edge p1 p2, opposite p0), v and w likewise.
template <typename T>
IRGRID_HD inline void edge_functions(const T (&x)[3], const T (&y)[3], T& u, T& v, T& w) {
  u = difference_of_products(x[2], y[1], y[2], x[1]);
  v = difference_of_products(x[0], y[2], y[0], x[2]);
  w = difference_of_products(x[1], y[0], y[1], x[0]);
}

/// Float operations for one ray under the names of the SIMD walk's lane operations
/// (cpu/simd_lanes_avx512.h, cpu/simd_lanes_avx2.h), so a formula written once serves both.
struct ScalarLanes {
  using F = float;
  using M = bool;
  IRGRID_HD static F splat(float x) { return x; }
  IRGRID_HD static F add(F a, F b) { return a + b; }
  IRGRID_HD static F sub(F a, F b) { return a - b; }
  IRGRID_HD static F mul(F a, F b) { return a * b; }
  IRGRID_HD static F min(F a, F b) { return a < b ? a : b; }  // b when either is NaN, as minps
  IRGRID_HD static F max(F a, F b) { return a > b ? a : b; }  // b when either is NaN, as maxps
  IRGRID_HD static F abs(F a) { return fabsf(a); }
  IRGRID_HD static M less(F a, F b) { return a < b; }
  IRGRID_HD static M less_equal(F a, F b) { return a <= b; }
  IRGRID_HD static M both(M a, M b) { return a && b; }
  IRGRID_HD static M either(M a, M b) { return a || b; }
  /// b and not a.
  IRGRID_HD static M but_not(M a, M b) { return !a && b; }
  IRGRID_HD static M all_lanes() { return true; }
};

/// Error bounds of the float test for a ray that passed the inside test (edge functions of one
/// sign, det = their sum nonzero), from the vertices as shear_vertex gives them: `edge` bounds
/// each edge function's error, and `t` the error of t = (u z0 + v z1 + w z2) / det while
/// 48 edge <= |det|. The barycentrics (edge functions / det) are then off by at most
/// 6.4 edge / |det| in all.
///
/// t is the average of the vertices' depths weighted by the edge functions. The shear leaves
/// each x', y' off by about 2^-24 times the vertex's distance, so the weights of a small or thin
/// triangle far along the ray can be off by percents; t then errs by that times the spread of
/// the depths. When the vertices lie far along the ray on both sides of it, as with a ray near
/// the plane of a long sliver, that can exceed the distance to the triangle (t = 10.4 for a
/// plane 0.4 behind the origin). The bound below is a forward error analysis of the float
/// operations in the style of Pharr, Jakob, Humphreys, "Physically Based Rendering" (3rd ed.,
/// §3.9.6), with gamma_n = n 2^-24 rounded up, the shear's error taken from the vertices'
/// unscaled depths (rays need not be of unit length), and the weights' errors multiplying the
/// spread of the depths instead of their size: the weights sum to one, so a common depth
/// cancels. Written once for one ray (ScalarLanes) and for the SIMD walk's lanes, with the same
/// operations in the same order, so both get the same bounds.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push  // see cpu/simd_walk_avx2.cpp on -Wpsabi
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
template <typename A>
struct FloatTestError {
  typename A::F edge, t;
};

template <typename A>
IRGRID_HD IRGRID_ALWAYS_INLINE FloatTestError<A> float_test_error(
    const typename A::F (&x)[3], const typename A::F (&y)[3], const typename A::F (&z)[3],
    const typename A::F (&depth)[3], const typename A::F& inv_det, const typename A::F& t) {
  using F = typename A::F;
  // No lambdas: they would not inherit the SIMD walk's target options.
  const F max_xy =
      A::max(A::max(A::max(A::abs(x[0]), A::abs(x[1])), A::max(A::abs(x[2]), A::abs(y[0]))),
             A::max(A::abs(y[1]), A::abs(y[2])));
  const F max_depth = A::max(A::max(A::abs(depth[0]), A::abs(depth[1])), A::abs(depth[2]));
  const F z_hi = A::max(A::max(z[0], z[1]), z[2]), z_lo = A::min(A::min(z[0], z[1]), z[2]);
  const F max_z = A::max(z_hi, A::sub(A::splat(0.f), z_lo));
  const float unit = 0x1p-24f;
  // Sheared x', y' = (p - o) - s depth with |s| <= 1: off by at most 5 unit (max_xy + max_depth)
  // = 5 unit g. An edge function a b - c d: its rounding and its inputs' errors,
  // 2 (3 unit m^2 + 2 m 5 unit g + (5 unit g)^2) <= (26 unit m + 50 unit^2 g) g.
  const F g = A::add(max_xy, max_depth);
  const F error_e =
      A::mul(A::add(A::mul(A::splat(26 * unit), max_xy), A::mul(A::splat(50 * unit * unit), g)), g);
  // The weights e / det are off by at most 6.4 error_e / |det| in all (given 48 error_e <= |det|),
  // times the depths' distance from their midpoint, at most spread / 2 + 4 unit max_z; the sum,
  // z's rounding and the division add 7 unit max_z + 5 unit |t|. All times 1.02 for the rounding
  // of this bound.
  const F abs_t = A::abs(t);
  const F error_t = A::add(
      A::add(A::mul(A::splat(7.2f * unit), max_z), A::mul(A::splat(5.1f * unit), abs_t)),
      A::mul(A::mul(error_e, A::abs(inv_det)), A::add(A::mul(A::splat(3.4f), A::sub(z_hi, z_lo)),
                                                      A::mul(A::splat(27 * unit), max_z))));
  return {error_e, error_t};
}

/// Whether the float test's t of a ray that passed the inside test may be on the wrong side of
/// tmin or tmax, or be off by more than 2^-6 (1.6%) of itself (float_test_error's bounds): then
/// t_in_double must decide. x, y, z, depth are the three vertices as shear_vertex gives them.
template <typename A>
IRGRID_HD IRGRID_ALWAYS_INLINE typename A::M t_needs_double(
    const typename A::F (&x)[3], const typename A::F (&y)[3], const typename A::F (&z)[3],
    const typename A::F (&depth)[3], const typename A::F& det, const typename A::F& inv_det,
    const typename A::F& t, const typename A::F& tmin, const typename A::F& tmax) {
  const FloatTestError<A> error = float_test_error<A>(x, y, z, depth, inv_det, t);
  const typename A::F abs_t = A::abs(t);
  // Sure when t is off by less than its distance to tmin and to tmax (then it is on the right
  // side of both) and, where it is a hit, than 2^-6 of itself, so the closest of several hits
  // is not mistaken by more than that. Tests behind the origin are often known less well
  // relative to their small t, and need not be. With 2^-10, 28% of Sponza's random rays (which
  // start near large walls) redid a t in double and traced 13% slower; with 2^-6, 2%. NaN
  // compares false: such tests go to double too.
  const auto sure_side = A::less(error.t, A::min(A::abs(A::sub(t, tmin)), A::abs(A::sub(t, tmax))));
  const auto outside = A::either(A::less(t, tmin), A::less(tmax, t));
  const auto sure_value =
      A::either(A::less_equal(error.t, A::mul(A::splat(0x1p-6f), abs_t)), outside);
  const auto sure =
      A::both(A::both(A::less_equal(A::mul(A::splat(64.f), error.edge), A::abs(det)), sure_side),
              sure_value);
  return A::but_not(sure, A::all_lanes());
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

/// The distance t of the float test, recomputed in double from the same float ray constants and
/// vertices (their shear is then exact or nearly, and the edge functions carry 29 more bits).
/// False when the ray lies in the triangle's plane.
IRGRID_HD inline bool t_in_double(const WatertightRay<float>& r, const Vec3<float>& p0,
                                  const Vec3<float>& p1, const Vec3<float>& p2, double& t) {
  const WatertightRay<double> rd{Vec3<double>::from(r.org_k),
                                 r.kx,
                                 r.ky,
                                 r.kz,
                                 double(r.sx),
                                 double(r.sy),
                                 double(r.sz),
                                 double(r.tmin),
                                 double(r.tmax)};
  double x[3], y[3], z[3], depth[3], u, v, w;
  shear_triangle(rd, Vec3<double>::from(p0), Vec3<double>::from(p1), Vec3<double>::from(p2), x, y,
                 z, depth);
  edge_functions(x, y, u, v, w);
  const double det = u + v + w;
  if (det == 0) return false;
  t = (u * z[0] + v * z[1] + w * z[2]) / det;
  return true;
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
  T x[3], y[3], z[3], depth[3], u, v, w;
  shear_triangle(r, p0, p1, p2, x, y, z, depth);
  edge_functions(x, y, u, v, w);
  // Rounding is monotonic, so a float edge function has the exact sign of the double one or is
  // 0: mixed nonzero signs are a miss whatever the double test would make of a zero.
  if (mixed_signs(u, v, w)) return false;
  if constexpr (sizeof(T) == 4) {
    // An edge function of exactly zero may be a rounding artefact: redo it in double.
    if (u == T(0) || v == T(0) || w == T(0)) {
      const double xd[3] = {x[0], x[1], x[2]}, yd[3] = {y[0], y[1], y[2]};
      double ud, vd, wd;
      edge_functions(xd, yd, ud, vd, wd);
      u = T(ud), v = T(vd), w = T(wd);
      if (mixed_signs(u, v, w)) return false;
    }
  }
  const T det = u + v + w;
  if (det == T(0)) return false;
  const T t_scaled = u * z[0] + v * z[1] + w * z[2];
  const T inv_det = T(1) / det;
  T t = t_scaled * inv_det;
  if constexpr (sizeof(T) == 4) {
    // The inside test above is watertight; only t may have cancelled. Keep the barycentrics.
    if (t_needs_double<ScalarLanes>(x, y, z, depth, det, inv_det, t, r.tmin, r.tmax)) {
      double exact;
      if (!t_in_double(r, p0, p1, p2, exact)) return false;
      t = T(exact);
    }
  }
  if (!(t >= r.tmin && t <= r.tmax && t < t_limit)) return false;
  hit.t = t;
  hit.u = v * inv_det;
  hit.v = w * inv_det;
  return true;
}

}  // namespace irgrid
