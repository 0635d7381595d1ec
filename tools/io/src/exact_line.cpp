// The exact oracle's predicates: filtered double determinants, GMP rationals where they cannot
// decide, and the shift that settles lines exactly through edges and vertices.
#include "exact_line.h"

#include <cmath>

namespace irgrid::exact {
namespace {

constexpr double kUnit = 0x1p-53;  // double's unit roundoff
/// |computed - exact| <= kDeterminantBound x permanent for a 3x3 determinant whose entries are
/// exact or differences rounded once: Shewchuk's orient3d bound is (7 + 56 u) u, and the slack
/// covers the rounding of the permanent itself. Coordinates are floats, so no product of three
/// differences underflows or overflows in double, and the bound holds for every input.
constexpr double kDeterminantBound = 16 * kUnit;
/// Derived bounds (sums and quotients of bounded values) are scaled by this for their own
/// rounding.
constexpr double kBoundSlack = 1 + 1e-9;
/// Values are taken from double only when known this well.
constexpr double kValueTolerance = 1e-13;

/// a . (b x c) with its error bound.
Approx determinant(const Point& a, const Point& b, const Point& c) {
  const double x = b[1] * c[2] - b[2] * c[1], y = b[2] * c[0] - b[0] * c[2],
               z = b[0] * c[1] - b[1] * c[0];
  const double permanent = std::abs(a[0]) * (std::abs(b[1] * c[2]) + std::abs(b[2] * c[1])) +
                           std::abs(a[1]) * (std::abs(b[2] * c[0]) + std::abs(b[0] * c[2])) +
                           std::abs(a[2]) * (std::abs(b[0] * c[1]) + std::abs(b[1] * c[0]));
  return {a[0] * x + a[1] * y + a[2] * z, kDeterminantBound * permanent};
}

using ExactPoint = std::array<mpq_class, 3>;

mpq_class determinant(const ExactPoint& a, const ExactPoint& b, const ExactPoint& c) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

ExactPoint exact_point(const Point& p) {
  return {mpq_class(p[0]), mpq_class(p[1]), mpq_class(p[2])};
}

/// value / divisor and its bound, given bounds on both and |divisor| > its error.
Approx quotient(const Approx& value, const Approx& divisor) {
  const double q = value.value / divisor.value;
  const double error =
      (value.error + std::abs(q) * divisor.error) / (std::abs(divisor.value) - divisor.error) +
      4 * kUnit * std::abs(q);
  return {q, error * kBoundSlack};
}

}  // namespace

Line::Line(const Ray& ray) {
  bool finite = true, nonzero = false;
  for (int a = 0; a < 3; ++a) {
    org[a] = ray.org[a], dir[a] = ray.dir[a];
    finite = finite && std::isfinite(org[a]) && std::isfinite(dir[a]);
    nonzero = nonzero || dir[a] != 0;
  }
  tmin = ray.tmin, tmax = ray.tmax;
  valid = finite && nonzero && !std::isnan(tmin) && !std::isnan(tmax);
  const double ax = std::abs(dir[0]), ay = std::abs(dir[1]), az = std::abs(dir[2]);
  const int largest = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
  shift_first = (largest + 1) % 3;
  shift_second = (largest + 2) % 3;
}

LineTriangle::LineTriangle(const Line& line, const float* p0, const float* p1, const float* p2)
    : line_(&line) {
  const float* p[3] = {p0, p1, p2};
  Point relative[3];
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a) {
      p_[k][a] = p[k][a];
      relative[k][a] = p_[k][a] - line.org[a];
    }
  for (int e = 0; e < 3; ++e)
    side_[e] = determinant(line.dir, relative[e], relative[(e + 1) % 3]);
  n_ = determinant(relative[0], relative[1], relative[2]);
  d_ = {side_[0].value + side_[1].value + side_[2].value,
        (side_[0].error + side_[1].error + side_[2].error +
         3 * kUnit *
             (std::abs(side_[0].value) + std::abs(side_[1].value) + std::abs(side_[2].value))) *
            kBoundSlack};
  if (!line.valid) return;
  // Mixed signs the bound is sure of are a miss without any exact arithmetic.
  int sure[3], lowest = 1, highest = -1;
  for (int e = 0; e < 3; ++e) {
    sure[e] = side_[e].sure_sign();
    if (sure[e] != 0) lowest = std::min(lowest, sure[e]), highest = std::max(highest, sure[e]);
  }
  if (lowest < 0 && highest > 0) return;
  int common = 0;
  for (int e = 0; e < 3; ++e) {
    const int sign = sure[e] != 0 ? sure[e] : exact_side(e);
    if (sign == 0 || (common != 0 && sign != common)) return;
    common = sign;
  }
  crosses_ = true;
}

void LineTriangle::make_exact() {
  if (exact_) return;
  exact_.emplace();
  const ExactPoint org = exact_point(line_->org), dir = exact_point(line_->dir);
  ExactPoint relative[3];
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a)
      relative[k][a] = mpq_class(p_[k][a]) - org[a];
  for (int e = 0; e < 3; ++e)
    exact_->side[e] = determinant(dir, relative[e], relative[(e + 1) % 3]);
  exact_->d = exact_->side[0] + exact_->side[1] + exact_->side[2];
  exact_->n = determinant(relative[0], relative[1], relative[2]);
  if (exact_->d != 0) exact_->t = exact_->n / exact_->d;
}

int LineTriangle::exact_side(int e) {
  make_exact();
  if (const int sign = sgn(exact_->side[e]); sign != 0) return sign;
  // Shifting the origin by h changes the side by -det[h, b - a, d] = -((b - a) x d)[h's axis].
  const Point& a = p_[e];
  const Point& b = p_[(e + 1) % 3];
  ExactPoint edge, dir = exact_point(line_->dir);
  for (int k = 0; k < 3; ++k)
    edge[k] = mpq_class(b[k]) - mpq_class(a[k]);
  for (const int axis : {line_->shift_first, line_->shift_second}) {
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;
    const mpq_class cross = edge[i] * dir[j] - edge[j] * dir[i];
    if (const int sign = sgn(cross); sign != 0) return -sign;
  }
  return 0;  // the edge runs along the line: the triangle is seen edge-on
}

bool LineTriangle::t_in_double() {
  if (t_known_) return true;
  if (std::abs(d_.value) <= d_.error) return false;
  const Approx t = quotient(n_, d_);
  t_ = t.value, t_error_ = t.error, t_known_ = true;
  return true;
}

bool LineTriangle::parallel() {
  if (t_in_double()) return false;
  make_exact();
  return exact_->d == 0;
}

int LineTriangle::compare_t(double x) {
  if (std::isinf(x)) return x > 0 ? -1 : 1;
  if (!exact_ && t_in_double()) {
    if (t_ + t_error_ < x) return -1;
    if (t_ - t_error_ > x) return 1;
  }
  make_exact();
  return cmp(exact_->t, mpq_class(x));
}

int LineTriangle::compare_t(LineTriangle& other) {
  if (!exact_ && !other.exact_ && t_in_double() && other.t_in_double()) {
    if (t_ + t_error_ < other.t_ - other.t_error_) return -1;
    if (t_ - t_error_ > other.t_ + other.t_error_) return 1;
  }
  make_exact();
  other.make_exact();
  return cmp(exact_->t, other.exact_->t);
}

double LineTriangle::t_upper() {
  if (exact_) {  // get_d truncates: within one unit in the last place
    const double t = exact_->t.get_d();
    return t + 4 * kUnit * std::abs(t) + 1e-300;
  }
  return t_in_double() ? t_ + t_error_ : INFINITY;
}

double LineTriangle::t() {
  if (!exact_ && t_in_double() && t_error_ <= kValueTolerance * std::abs(t_)) return t_;
  make_exact();
  return exact_->t.get_d();
}

double LineTriangle::barycentric(int side) {
  if (!exact_ && std::abs(d_.value) > d_.error) {
    const Approx weight = quotient(side_[side], d_);
    if (weight.error <= kValueTolerance) return weight.value;
  }
  make_exact();
  return mpq_class(exact_->side[side] / exact_->d).get_d();
}

}  // namespace irgrid::exact
