// irgrid/kernel/vec.h: a small 3-vector for host and device code, in float or double.
#pragma once

#include <cmath>

#include "irgrid/kernel/platform.h"

namespace irgrid {

template <typename T>
struct Vec3 {
  T x, y, z;

  IRGRID_HD constexpr T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  IRGRID_HD constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  template <typename U>
  IRGRID_HD static constexpr Vec3 from(const U* p) {
    return {T(p[0]), T(p[1]), T(p[2])};
  }
  template <typename U>
  IRGRID_HD static constexpr Vec3 from(const U& a) {
    return {T(a[0]), T(a[1]), T(a[2])};
  }
};

using Vec3d = Vec3<double>;

template <typename T>
IRGRID_HD constexpr Vec3<T> operator+(Vec3<T> a, Vec3<T> b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <typename T>
IRGRID_HD constexpr Vec3<T> operator-(Vec3<T> a, Vec3<T> b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <typename T>
IRGRID_HD constexpr Vec3<T> operator-(Vec3<T> a) {
  return {-a.x, -a.y, -a.z};
}
template <typename T>
IRGRID_HD constexpr Vec3<T> operator*(Vec3<T> a, T s) {
  return {a.x * s, a.y * s, a.z * s};
}
template <typename T>
IRGRID_HD constexpr Vec3<T> operator*(T s, Vec3<T> a) {
  return a * s;
}
template <typename T>
IRGRID_HD constexpr T dot(Vec3<T> a, Vec3<T> b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename T>
IRGRID_HD constexpr Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T>
IRGRID_HD inline T length(Vec3<T> a) {
  return std::sqrt(dot(a, a));
}
template <typename T>
IRGRID_HD inline Vec3<T> normalize(Vec3<T> a) {
  return a * (T(1) / length(a));
}

}  // namespace irgrid
