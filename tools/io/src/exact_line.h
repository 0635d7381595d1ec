// tools/io/src/exact_line.h: the exact oracle's signs and distances for one ray and one triangle.
#pragma once

#include <array>
#include <optional>

#include <gmpxx.h>

#include "irgrid/ray.h"

namespace irgrid::exact {

using Point = std::array<double, 3>;

/// A double and a bound on its distance from the exact value it stands for.
struct Approx {
  double value = 0, error = 0;
  /// +1 or -1 when the bound decides the sign, else 0.
  int sure_sign() const { return value > error ? 1 : (value < -error ? -1 : 0); }
};

/// A ray in double (exactly: every float is a double), with the axes along which its origin is
/// shifted by infinitesimals to decide lines exactly through an edge or vertex: o + e a1 + e^2 a2
/// for the two axes a1, a2 other than the direction's largest, so the shift is never along the
/// line and the shifted line meets no edge line through a vertex it passes through.
struct Line {
  Point org{}, dir{};
  double tmin = 0, tmax = 0;
  int shift_first = 0, shift_second = 1;
  /// Finite origin and direction, a nonzero direction, tmin and tmax not NaN.
  bool valid = false;
  explicit Line(const Ray& ray);
};

/// The line of a ray against one triangle. With s_e = det[a - o, b - o, d] for the edges
/// e = (p0 p1), (p1 p2), (p2 p0), the line crosses the triangle when the three signs agree (after
/// the shift above for zeros); D = s_0 + s_1 + s_2 = d . n and N = det[p0 - o, p1 - o, p2 - o]
/// give t = N / D, and the barycentrics are u = s_2 / D (of p1), v = s_0 / D (of p2). Everything
/// is first computed in double with an error bound and recomputed exactly where that bound
/// cannot decide.
class LineTriangle {
 public:
  LineTriangle(const Line& line, const float* p0, const float* p1, const float* p2);

  bool crosses() const { return crosses_; }
  /// The line is parallel to the plane (D = 0 exactly): no t.
  bool parallel();
  /// The sign of t - x, exactly; needs !parallel(). x may be infinite.
  int compare_t(double x);
  /// The sign of t - other.t, exactly; needs both !parallel().
  int compare_t(LineTriangle& other);
  /// A bound above t (+infinity when double cannot bound it); needs !parallel().
  double t_upper();
  /// t, u, v within 1e-12 of the exact values (relative for t, absolute for u, v); need
  /// !parallel().
  double t();
  double u() { return barycentric(2); }
  double v() { return barycentric(0); }

 private:
  struct Exact {
    mpq_class side[3], n, d, t;
  };
  /// The side of the line against edge e, exactly, with the shift deciding zeros; 0 only for an
  /// edge parallel to the line.
  int exact_side(int e);
  void make_exact();
  /// Whether the double bound on D excludes zero; then t_ and t_error_ hold t.
  bool t_in_double();
  double barycentric(int side);

  const Line* line_;
  Point p_[3];
  Approx side_[3], n_, d_;
  bool crosses_ = false;
  double t_ = 0, t_error_ = 0;
  bool t_known_ = false;
  std::optional<Exact> exact_;
};

}  // namespace irgrid::exact
