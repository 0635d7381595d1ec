// Triangle/box overlap (core/triangle_box.h): no false negative against an exact integer
// separating-axis reference, false positives only within the documented margin, and unit grid
// cells that cover every sampled point of a triangle.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <set>
#include <vector>

#include "core/triangle_box.h"
#include "irgrid/io/random.h"

namespace irgrid {
namespace {

// --- Exact reference -------------------------------------------------------------------------
// Every test coordinate is a multiple of 2^-31 of magnitude <= 2^8 (every float of magnitude
// >= 2^-8 in that range is one), so it is an integer of at most 40 bits after scaling by 2^31.
// Edges then take 41 bits, the triangle normal 83 and projections onto it 124: the separating
// axis test in 128-bit integers is exact, and with exact arithmetic its 13 axes decide overlap
// of a closed triangle (or segment, or point) and a closed box.
__extension__ typedef __int128 Int128;
using IVec = std::array<Int128, 3>;
constexpr int kLatticeBits = 31;
constexpr double kMaxCoordinate = 256;

struct Case {
  std::array<Vec3<float>, 3> p;
  Vec3<float> lo, hi;
};

bool on_lattice(double x) {
  const double scaled = std::ldexp(x, kLatticeBits);
  return std::fabs(x) <= kMaxCoordinate && scaled == std::floor(scaled);
}

IVec to_lattice(Vec3<float> v) {
  IVec r;
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(on_lattice(v[k])) << v[k];
    r[k] = Int128(std::int64_t(std::ldexp(double(v[k]), kLatticeBits)));
  }
  return r;
}

IVec operator-(const IVec& a, const IVec& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Int128 dot(const IVec& a, const IVec& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
IVec cross(const IVec& a, const IVec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// The exact verdict and, when apart, a lower bound of the distance (the largest normalised
/// separation over the 13 axes), in world units.
struct ExactResult {
  bool overlap;
  double gap;
};

ExactResult exact_overlap(const Case& c) {
  const IVec p[3] = {to_lattice(c.p[0]), to_lattice(c.p[1]), to_lattice(c.p[2])};
  const IVec lo = to_lattice(c.lo), hi = to_lattice(c.hi);
  const IVec edges[3] = {p[1] - p[0], p[2] - p[1], p[0] - p[2]};
  std::vector<IVec> axes = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, cross(edges[0], edges[1])};
  for (const IVec& e : edges)
    for (int k = 0; k < 3; ++k)
      axes.push_back(cross(e, IVec{k == 0, k == 1, k == 2}));
  ExactResult result{true, 0.0};
  for (const IVec& a : axes) {
    Int128 tri_lo = dot(a, p[0]), tri_hi = tri_lo, box_lo = 0, box_hi = 0;
    for (int i = 1; i < 3; ++i) {
      tri_lo = std::min(tri_lo, dot(a, p[i]));
      tri_hi = std::max(tri_hi, dot(a, p[i]));
    }
    for (int k = 0; k < 3; ++k) {
      box_lo += std::min(a[k] * lo[k], a[k] * hi[k]);
      box_hi += std::max(a[k] * lo[k], a[k] * hi[k]);
    }
    const Int128 separation = std::max(tri_lo - box_hi, box_lo - tri_hi);
    if (separation <= 0) continue;
    long double norm2 = 0;
    for (int k = 0; k < 3; ++k)
      norm2 += (long double)a[k] * (long double)a[k];
    const long double gap = (long double)separation / std::sqrt(norm2);
    result.overlap = false;
    result.gap = std::max(result.gap, double(std::ldexp(gap, -kLatticeBits)));
  }
  return result;
}

// --- The tested function on a case, scaled by 2^scale_exponent (exact: the verdict is the same).
template <typename T>
bool tested_overlap(const Case& c, int scale_exponent = 0, float padding = 0) {
  const auto at = [&](Vec3<float> v) {
    return Vec3<T>{T(std::ldexp(T(v.x), scale_exponent)), T(std::ldexp(T(v.y), scale_exponent)),
                   T(std::ldexp(T(v.z), scale_exponent))};
  };
  return triangle_overlaps_box(at(c.p[0]), at(c.p[1]), at(c.p[2]), at(c.lo), at(c.hi),
                               T(std::ldexp(T(padding), scale_exponent)));
}

/// The magnitude the margin scales with: max over axes of (farthest vertex from the box centre
/// + half extent).
double error_scale(const Case& c) {
  double scale = 0;
  for (int k = 0; k < 3; ++k) {
    const double center = 0.5 * (double(c.lo[k]) + c.hi[k]), half = 0.5 * (c.hi[k] - c.lo[k]);
    for (const auto& v : c.p)
      scale = std::max(scale, std::fabs(v[k] - center) + half);
  }
  return scale;
}

// --- Case generators -------------------------------------------------------------------------
// Constructions use coordinates on a 2^-12 grid of magnitude < 64: sums and midpoints of them
// are still floats, so a vertex placed on a box face lies on it exactly.
struct Generator {
  Pcg32 rng;
  explicit Generator(std::uint64_t seed) { rng.seed(seed, 7); }

  double uniform(double a, double b) { return a + (b - a) * rng.next_float(); }
  int below(int n) { return int(rng.next_u32() % std::uint32_t(n)); }
  bool chance(double p) { return rng.next_float() < p; }
  double log_uniform(double a, double b) { return a * std::pow(b / a, rng.next_float()); }
  static float snap(double x, int bits = 12) {
    return float(std::ldexp(std::round(std::ldexp(x, bits)), -bits));
  }
  int sign() { return chance(0.5) ? 1 : -1; }

  void random_box(Case& c) {
    const bool flat = chance(0.05);  // a box of zero thickness along one axis
    const int flat_axis = below(3);
    for (int k = 0; k < 3; ++k) {
      const double center = uniform(-16, 16);
      const double half = (flat && k == flat_axis) ? 0 : log_uniform(1.0 / 64, 8);
      c.lo[k] = snap(center - half);
      c.hi[k] = snap(center + half);
    }
  }
  double box_size(const Case& c) {
    return std::max({c.hi.x - c.lo.x, c.hi.y - c.lo.y, c.hi.z - c.lo.z, 1.0f / 64});
  }
  /// A point of the box boundary with `bounded` coordinates on a face (1: face, 2: edge,
  /// 3: corner); sides[k] = -1/+1 for the lo/hi face of a bounded axis, 0 for a free one.
  Vec3<float> boundary_point(const Case& c, int bounded, std::array<int, 3>& sides) {
    sides = {0, 0, 0};
    const int first = below(3);
    for (int b = 0; b < bounded; ++b)
      sides[(first + b) % 3] = sign();
    Vec3<float> q;
    for (int k = 0; k < 3; ++k)
      q[k] = sides[k] < 0 ? c.lo[k] : sides[k] > 0 ? c.hi[k] : snap(uniform(c.lo[k], c.hi[k]));
    return q;
  }
  /// An offset that stays in the closed outer half-space of every bounded face.
  Vec3<float> outward_offset(const std::array<int, 3>& sides, double size, bool strict) {
    Vec3<float> w;
    for (int k = 0; k < 3; ++k) {
      const double magnitude = size * rng.next_float();
      if (sides[k] == 0)
        w[k] = snap(sign() * magnitude);
      else
        w[k] = snap(sides[k] * ((!strict && chance(0.25)) ? 0.0 : magnitude + 1.0 / 4096));
    }
    return w;
  }

  /// A vertex on a face, edge or corner; the rest of the triangle outside (or on that face).
  Case vertex_on_boundary(Case c) {
    std::array<int, 3> sides;
    const Vec3<float> q = boundary_point(c, 1 + below(3), sides);
    const double size = log_uniform(1.0 / 256, 4) * box_size(c);
    c.p = {q, q + outward_offset(sides, size, false), q + outward_offset(sides, size, false)};
    return c;
  }
  /// An edge through a box edge or corner point, tangent to the box, the third vertex outside.
  Case edge_through_box_edge(Case c) {
    std::array<int, 3> sides;
    const Vec3<float> q = boundary_point(c, 2 + below(2), sides);
    int i = 0;
    while (sides[i] == 0)
      ++i;
    int j = i + 1;
    while (sides[j] == 0)
      ++j;
    const double size = log_uniform(1.0 / 256, 4) * box_size(c);
    Vec3<float> d;
    for (int k = 0; k < 3; ++k)
      d[k] = snap(uniform(-size, size));
    d[i] = snap(sides[i] * (size * rng.next_float() + 1.0 / 4096));   // one end beyond face i,
    d[j] = snap(-sides[j] * (size * rng.next_float() + 1.0 / 4096));  // the other beyond j
    c.p = {q + d, q - d, q + outward_offset(sides, size, true)};
    return c;
  }
  /// A triangle lying in the plane of a face, overlapping it, touching its border or not.
  Case in_face_plane(Case c) {
    const int k = below(3);
    const float plane = chance(0.5) ? c.lo[k] : c.hi[k];
    for (auto& v : c.p)
      for (int m = 0; m < 3; ++m) {
        const double extent = c.hi[m] - c.lo[m] + 1.0 / 64;
        const int choice = below(4);
        v[m] = m == k        ? plane
               : choice == 0 ? c.lo[m]
               : choice == 1 ? c.hi[m]
                             : snap(uniform(c.lo[m] - extent, c.hi[m] + extent));
      }
    return c;
  }
  /// A triangle whose plane touches the box only at a corner (or along an edge), the touching
  /// point inside the triangle, on one of its edges or at a vertex.
  Case plane_through_corner(Case c) {
    std::array<int, 3> sides;
    const Vec3<float> q = boundary_point(c, 2 + below(2), sides);
    IVec n;
    for (int k = 0; k < 3; ++k)
      n[k] = sides[k] * (1 + below(4));
    const IVec u1 = cross(n, IVec{n[1] == 0, n[1] != 0, 0});  // perpendicular to n, nonzero
    const IVec u2 = cross(n, u1);
    const int shrink = 7 + below(6);  // keeps every vertex on the 2^-12 grid
    const auto in_plane = [&](int a, int b) {
      Vec3<float> w;
      for (int k = 0; k < 3; ++k)
        w[k] = float(std::ldexp(double(a * u1[k] + b * u2[k]), -shrink));
      return w;
    };
    const Vec3<float> a = in_plane(1 + below(3), below(5) - 2),
                      b = in_plane(below(5) - 2, 1 + below(3));
    switch (below(3)) {
      case 0:
        c.p = {q + a, q + b, q - (a + b)};
        break;  // q is the centroid
      case 1:
        c.p = {q + a, q - a, q + b};
        break;  // q on an edge
      default:
        c.p = {q, q + a, q + b};
        break;  // q is a vertex
    }
    return c;
  }
  /// Collinear triangles and points built from the touching constructions.
  Case degenerate(Case c) {
    c = chance(0.5) ? vertex_on_boundary(c) : edge_through_box_edge(c);
    switch (below(3)) {
      case 0:
        c.p[2] = {snap(0.5 * (double(c.p[0].x) + c.p[1].x), 13),
                  snap(0.5 * (double(c.p[0].y) + c.p[1].y), 13),
                  snap(0.5 * (double(c.p[0].z) + c.p[1].z), 13)};
        break;
      case 1:
        c.p[2] = c.p[0];
        break;
      default:
        c.p[1] = c.p[2] = c.p[0];
        break;
    }
    return c;
  }
  Case touching(Case c) {
    switch (below(5)) {
      case 0:
        return vertex_on_boundary(c);
      case 1:
        return edge_through_box_edge(c);
      case 2:
        return in_face_plane(c);
      case 3:
        return plane_through_corner(c);
      default:
        return degenerate(c);
    }
  }
  /// A box and a triangle in general position near it.
  Case generic() {
    Case c;
    random_box(c);
    const double size = log_uniform(1.0 / 1024, 8);
    Vec3<double> center;
    for (int k = 0; k < 3; ++k)
      center[k] =
          0.5 * (double(c.lo[k]) + c.hi[k]) + uniform(-0.6, 0.6) * (c.hi[k] - c.lo[k] + size);
    for (auto& v : c.p)
      for (int k = 0; k < 3; ++k)
        v[k] = snap(center[k] + uniform(-size, size), 20);
    return c;
  }
};

/// One step of x towards `target`: an ulp, but at least 2^-31 so the value stays on the lattice.
float nudge(float x, double target) {
  if (double(x) == target) return x;
  const float step =
      std::nextafter(x, float(target) == x ? (target > x ? 1e30f : -1e30f) : float(target));
  if (on_lattice(step)) return step;
  return float(double(x) + (target > x ? 1 : -1) * std::ldexp(1.0, -kLatticeBits));
}

/// Variants of a touching case moved by one step: all vertices out of or into the box (away
/// from or towards its centre, per coordinate), one coordinate either way, the box shrunk or
/// grown, and the vertices moved out by a clear 2^-10.
std::vector<Case> nudged_variants(const Case& base, Generator& g) {
  std::vector<Case> out(7, base);
  for (int k = 0; k < 3; ++k) {
    const double center = 0.5 * (double(base.lo[k]) + base.hi[k]);
    for (int i = 0; i < 3; ++i) {
      const float x = base.p[i][k];
      const double away = x > center ? 1e30 : x < center ? -1e30 : double(x);
      out[1].p[i][k] = nudge(x, away);
      out[2].p[i][k] = nudge(x, center);
      out[6].p[i][k] = Generator::snap(x + (away > x ? 1 : away < x ? -1 : 0) / 1024.0);
    }
    out[4].lo[k] = nudge(base.lo[k], center);
    out[4].hi[k] = nudge(base.hi[k], center);
    out[5].lo[k] = nudge(base.lo[k], -1e30);
    out[5].hi[k] = nudge(base.hi[k], 1e30);
  }
  float& one = out[3].p[g.below(3)][g.below(3)];
  one = nudge(one, g.chance(0.5) ? 1e30 : -1e30);
  return out;
}

struct Tally {
  long cases = 0, reference_true = 0, false_negatives = 0, false_positives = 0;
  long false_positives_beyond_margin = 0;  ///< apart by more than the margin can explain
  void add(bool tested, const ExactResult& exact, double margin) {
    ++cases;
    reference_true += exact.overlap;
    false_negatives += exact.overlap && !tested;
    false_positives += !exact.overlap && tested;
    false_positives_beyond_margin += !exact.overlap && tested && exact.gap > margin;
  }
  void print(const char* name) const {
    std::printf(
        "%-34s cases %7ld  touching/overlapping %7ld  FN %ld  FP %ld (%.3f%%)  FP beyond margin "
        "%ld\n",
        name, cases, reference_true, false_negatives, false_positives,
        100.0 * false_positives / std::max(1L, cases), false_positives_beyond_margin);
  }
};

/// FP allowed only within 64 eps * scale of the box: the margin is 16u = 8 eps per unit of the
/// axis-weighted scale (<= sqrt(3) * scale), plus the rotation of the rounded axes.
template <typename T>
double margin(const Case& c) {
  return 64 * double(triangle_box_detail::machine_epsilon<T>()) * error_scale(c);
}

struct CaseSets {
  std::vector<Case> generic, near_touching, clear_gap;
  std::array<std::vector<Case>, 6> near_touching_by_variant;  ///< as nudged_variants orders them
};

const CaseSets& case_sets() {
  static const CaseSets sets = [] {
    CaseSets s;
    Generator g(2017);
    for (int n = 0; n < 100000; ++n)
      s.generic.push_back(g.generic());
    for (int n = 0; n < 16000; ++n) {
      Case box;
      g.random_box(box);
      const auto variants = nudged_variants(g.touching(box), g);
      s.near_touching.insert(s.near_touching.end(), variants.begin(), variants.end() - 1);
      for (int v = 0; v < 6; ++v)
        s.near_touching_by_variant[v].push_back(variants[v]);
      s.clear_gap.push_back(variants.back());
    }
    return s;
  }();
  return sets;
}

template <typename T>
Tally tally(const std::vector<Case>& cases, int scale_exponent = 0) {
  Tally t;
  for (const Case& c : cases)
    t.add(tested_overlap<T>(c, scale_exponent), exact_overlap(c), margin<T>(c));
  return t;
}

TEST(TriangleBox, GenericCasesMatchTheExactTest) {
  const auto& cases = case_sets().generic;
  const Tally f = tally<float>(cases), d = tally<double>(cases);
  f.print("generic, float");
  d.print("generic, double");
  EXPECT_GT(f.reference_true, long(cases.size()) / 10);  // both verdicts are well represented
  EXPECT_LT(f.reference_true, long(cases.size()) * 9 / 10);
  EXPECT_EQ(f.false_negatives, 0);
  EXPECT_EQ(d.false_negatives, 0);
  EXPECT_LE(f.false_positives, long(cases.size()) / 10000);
  EXPECT_EQ(d.false_positives, 0);
}

TEST(TriangleBox, NearTouchingCasesAreNeverMissed) {
  const auto& cases = case_sets().near_touching;
  const Tally f = tally<float>(cases), d = tally<double>(cases);
  f.print("near-touching, float");
  d.print("near-touching, double");
  EXPECT_GT(f.reference_true, long(cases.size()) / 2);
  EXPECT_EQ(f.false_negatives, 0);
  EXPECT_EQ(d.false_negatives, 0);
  // Pairs apart by one ulp are within the margin by design; none may be farther apart.
  EXPECT_EQ(f.false_positives_beyond_margin, 0);
  EXPECT_EQ(d.false_positives_beyond_margin, 0);
  const char* names[6] = {"  exactly touching",    "  vertices 1 ulp out",
                          "  vertices 1 ulp in",   "  one coordinate 1 ulp",
                          "  box shrunk by 1 ulp", "  box grown by 1 ulp"};
  long not_moved_apart = 0, not_moved_apart_fp = 0;
  for (int v = 0; v < 6; ++v) {
    const Tally t = tally<float>(case_sets().near_touching_by_variant[v]);
    t.print(names[v]);
    if (v == 0 || v == 2 || v == 5) {
      not_moved_apart += t.cases;
      not_moved_apart_fp += t.false_positives;
    }
  }
  // Variants not moved apart are almost all touching: false positives there must be rare.
  EXPECT_LT(not_moved_apart_fp, not_moved_apart / 100);
  const Tally clear = tally<float>(case_sets().clear_gap);
  clear.print("touching cases moved out by 2^-10");
  EXPECT_EQ(clear.false_negatives, 0);
  EXPECT_GT(clear.cases - clear.reference_true, clear.cases / 2);
  EXPECT_EQ(clear.false_positives, 0);
}

TEST(TriangleBox, HugeAndTinyCoordinatesAreNeverMissed) {
  const auto& sets = case_sets();
  for (const int exponent : {-90, -60, -20, 20, 60, 100}) {
    for (const auto* cases : {&sets.generic, &sets.near_touching}) {
      const Tally f = tally<float>(*cases, exponent);
      char name[64];
      std::snprintf(name, sizeof name, "%s scaled 2^%d, float",
                    cases == &sets.generic ? "generic" : "near-touching", exponent);
      f.print(name);
      EXPECT_EQ(f.false_negatives, 0) << name;
      // Within float's precise range (see the header) the verdicts are as good as unscaled.
      if (std::abs(exponent) <= 20) {
        EXPECT_EQ(f.false_positives_beyond_margin, 0) << name;
      }
    }
  }
}

TEST(TriangleBox, PaddingGrowsTheBox) {
  Generator g(99);
  Tally padded;
  long monotone_violations = 0;
  for (int n = 0; n < 20000; ++n) {
    Case c;
    g.random_box(c);
    c = g.touching(c);
    // Move the triangle out by up to 3 paddings; padded box and the exact reference use
    // multiples of 2^-12, so lo - padding is a float and the reference box is exact.
    const float padding = float(std::ldexp(1 + g.below(8), -12));
    Case moved = c, grown = c;
    for (int k = 0; k < 3; ++k) {
      const double center = 0.5 * (double(c.lo[k]) + c.hi[k]);
      const double shift = std::ldexp(g.below(25), -12) * g.chance(0.8);
      for (auto& v : moved.p)
        v[k] = Generator::snap(v[k] + (v[k] > center ? shift : v[k] < center ? -shift : 0));
      grown.lo[k] = c.lo[k] - padding;
      grown.hi[k] = c.hi[k] + padding;
    }
    grown.p = moved.p;
    const bool with_padding = tested_overlap<float>(moved, 0, padding);
    padded.add(with_padding, exact_overlap(grown), margin<float>(grown));
    monotone_violations += tested_overlap<float>(moved) && !with_padding;
  }
  padded.print("padded boxes, float");
  EXPECT_EQ(padded.false_negatives, 0);
  EXPECT_EQ(padded.false_positives_beyond_margin, 0);
  EXPECT_EQ(monotone_violations, 0);
}

// --- Octants: the shared-work test of the 8 children of a box ----------------------------------
// The case's box becomes octant `bit` of a box twice its size, so the exact verdict of the case
// is the verdict for that octant (its bounds are the case's bounds, copied).
struct OctantCase {
  Vec3<float> lo, mid, hi;
  std::uint32_t bit;
};

OctantCase as_octant(const Case& c, std::uint32_t bit) {
  OctantCase o{c.lo, {}, c.hi, bit};
  for (int k = 0; k < 3; ++k) {
    const float size = c.hi[k] - c.lo[k];
    if (bit >> k & 1) {
      o.mid[k] = c.lo[k];
      o.lo[k] = c.lo[k] - size;
    } else {
      o.mid[k] = c.hi[k];
      o.hi[k] = c.hi[k] + size;
    }
  }
  return o;
}

template <typename T>
std::uint32_t tested_octants(const Case& c, const OctantCase& o, int scale_exponent = 0) {
  const auto at = [&](Vec3<float> v) {
    return Vec3<T>{T(std::ldexp(T(v.x), scale_exponent)), T(std::ldexp(T(v.y), scale_exponent)),
                   T(std::ldexp(T(v.z), scale_exponent))};
  };
  return octants_overlapped(at(c.p[0]), at(c.p[1]), at(c.p[2]), at(o.lo), at(o.mid), at(o.hi), T(0),
                            0xFFu);
}

/// Tally of the octant test on each case placed as a random octant; the margin is taken over
/// the whole box, since the shared frame is its centre.
template <typename T>
Tally octant_tally(const std::vector<Case>& cases, std::uint64_t seed, int scale_exponent = 0) {
  Generator g(seed);
  Tally t;
  for (const Case& c : cases) {
    const OctantCase o = as_octant(c, std::uint32_t(g.below(8)));
    Case whole = c;
    whole.lo = o.lo;
    whole.hi = o.hi;
    t.add((tested_octants<T>(c, o, scale_exponent) >> o.bit & 1) != 0, exact_overlap(c),
          margin<T>(whole));
  }
  return t;
}

TEST(TriangleBox, OctantsMatchTheExactTest) {
  const auto& sets = case_sets();
  const Tally generic = octant_tally<float>(sets.generic, 5),
              touching = octant_tally<float>(sets.near_touching, 6),
              clear = octant_tally<float>(sets.clear_gap, 7),
              generic_double = octant_tally<double>(sets.generic, 5),
              touching_double = octant_tally<double>(sets.near_touching, 6);
  generic.print("octants, generic, float");
  touching.print("octants, near-touching, float");
  clear.print("octants, moved out by 2^-10, float");
  touching_double.print("octants, near-touching, double");
  EXPECT_EQ(generic.false_negatives, 0);
  EXPECT_EQ(touching.false_negatives, 0);
  EXPECT_EQ(clear.false_negatives, 0);
  EXPECT_EQ(generic_double.false_negatives, 0);
  EXPECT_EQ(touching_double.false_negatives, 0);
  EXPECT_LE(generic.false_positives, long(sets.generic.size()) / 10000);
  EXPECT_EQ(generic_double.false_positives, 0);
  EXPECT_EQ(touching.false_positives_beyond_margin, 0);
  EXPECT_EQ(touching_double.false_positives_beyond_margin, 0);
  EXPECT_EQ(clear.false_positives, 0);
  for (const int exponent : {-90, -20, 20, 100}) {
    const Tally scaled = octant_tally<float>(sets.near_touching, 8, exponent);
    EXPECT_EQ(scaled.false_negatives, 0) << "scaled 2^" << exponent;
  }
}

// The host's vector test of 8 octants against the loop the device runs: the same bits for the
// same inputs, NaN and infinities included (a GPU build's octrees must equal the CPU's).
TEST(TriangleBox, VectorOctantTestEqualsThePortableLoop) {
  using triangle_box_detail::separated_octants;
  using triangle_box_detail::separated_octants_portable;
  Generator g(31);
  const float specials[] = {0.f, -0.f, INFINITY, -INFINITY, NAN, 1e-40f, 3e38f};
  const auto value = [&] {
    if (g.chance(0.05)) return specials[g.below(7)];
    return float(g.sign() * g.log_uniform(1e-3, 1e3));
  };
  int differing = 0, separated_any = 0;
  for (int i = 0; i < 200000; ++i) {
    float shift[3][2], extent[3][2];
    for (int k = 0; k < 3; ++k)
      for (int side = 0; side < 2; ++side) {
        shift[k][side] = value();
        extent[k][side] = std::fabs(value());
      }
    const float a = value(), b = value(), tolerance = std::fabs(value()) * 1e-3f;
    const float lowest = std::fmin(a, b), highest = std::fmax(a, b);
    const std::uint32_t vector = separated_octants(shift, extent, lowest, highest, tolerance);
    const std::uint32_t loop =
        separated_octants_portable(shift, extent, lowest, highest, tolerance);
    differing += vector != loop;
    separated_any += loop != 0;
  }
  EXPECT_EQ(differing, 0);
  EXPECT_GT(separated_any, 1000);  // the cases separate octants, not only keep them
}

TEST(TriangleBox, OctantsAgreeWithTheSingleBoxTest) {
  // Every octant of every generic case (all on the exact test's lattice), against the exact
  // verdict and against triangle_overlaps_box on that octant.
  long checked = 0, missed = 0, only_single = 0, only_shared = 0;
  for (const Case& c : case_sets().generic) {
    const OctantCase o = as_octant(c, 0);
    const std::uint32_t mask = tested_octants<float>(c, o);
    for (std::uint32_t bit = 0; bit < 8; ++bit) {
      Case octant = c;
      for (int k = 0; k < 3; ++k) {
        octant.lo[k] = (bit >> k & 1) ? o.mid[k] : o.lo[k];
        octant.hi[k] = (bit >> k & 1) ? o.hi[k] : o.mid[k];
      }
      const bool single = tested_overlap<float>(octant);
      const bool shared = (mask >> bit & 1) != 0;
      ++checked;
      missed += exact_overlap(octant).overlap && !shared;
      only_single += single && !shared;
      only_shared += shared && !single;
    }
  }
  std::printf("octants vs single boxes: %ld checked, %ld only single, %ld only shared\n", checked,
              only_single, only_shared);
  EXPECT_EQ(missed, 0);
  EXPECT_LE(only_shared, checked / 10000);
}

// --- Grid cells --------------------------------------------------------------------------------
constexpr int kGrid = 8;
using Cell = std::array<int, 3>;

/// Every unit cell whose closed box holds the point (several when it lies on a cell face).
void add_cells_holding(Vec3<double> x, std::set<Cell>& cells) {
  int first[3], last[3];
  for (int k = 0; k < 3; ++k) {
    const double f = std::floor(x[k]);
    first[k] = std::max(0, int(f) - (f == x[k] ? 1 : 0));
    last[k] = std::min(kGrid - 1, int(f));
  }
  for (int i = first[0]; i <= last[0]; ++i)
    for (int j = first[1]; j <= last[1]; ++j)
      for (int k = first[2]; k <= last[2]; ++k)
        cells.insert({i, j, k});
}

/// Dense samples of the triangle in double: vertices, edge points (those where an edge crosses
/// an integer plane placed exactly on it), interior points and points on the triangle's
/// crossings with integer planes.
std::set<Cell> sampled_cells(const std::array<Vec3<float>, 3>& tri, Generator& g) {
  std::set<Cell> cells;
  Vec3<double> p[3];
  for (int i = 0; i < 3; ++i)
    p[i] = {tri[i].x, tri[i].y, tri[i].z};
  const auto lerp = [](Vec3<double> a, Vec3<double> b, double t) { return a + (b - a) * t; };
  std::vector<std::pair<Vec3<double>, Vec3<double>>> plane_crossings;
  for (int i = 0; i < 3; ++i) {
    const Vec3<double> a = p[i], b = p[(i + 1) % 3];
    add_cells_holding(a, cells);
    for (int s = 1; s < 64; ++s)
      add_cells_holding(lerp(a, b, s / 64.0), cells);
    for (int k = 0; k < 3; ++k) {
      if (a[k] == b[k]) continue;
      for (int plane = int(std::ceil(std::min(a[k], b[k])));
           plane <= std::floor(std::max(a[k], b[k])); ++plane) {
        Vec3<double> x = lerp(a, b, (plane - a[k]) / (b[k] - a[k]));
        x[k] = plane;
        add_cells_holding(x, cells);
      }
    }
  }
  for (int s = 0; s < 3000; ++s) {
    double u = g.rng.next_float(), v = g.rng.next_float();
    if (u + v > 1) u = 1 - u, v = 1 - v;
    add_cells_holding(p[0] + (p[1] - p[0]) * u + (p[2] - p[0]) * v, cells);
  }
  // Where the triangle crosses an integer plane: the segment between two edge crossings.
  for (int k = 0; k < 3; ++k) {
    const double low = std::min({p[0][k], p[1][k], p[2][k]}),
                 high = std::max({p[0][k], p[1][k], p[2][k]});
    for (int plane = int(std::ceil(low)); plane <= std::floor(high); ++plane) {
      std::vector<Vec3<double>> ends;
      for (int i = 0; i < 3; ++i) {
        const Vec3<double> a = p[i], b = p[(i + 1) % 3];
        if ((a[k] - plane) * (b[k] - plane) > 0 || a[k] == b[k]) continue;
        ends.push_back(lerp(a, b, (plane - a[k]) / (b[k] - a[k])));
      }
      for (std::size_t e = 1; e < ends.size(); ++e)
        for (int s = 0; s <= 64; ++s) {
          Vec3<double> x = lerp(ends[0], ends[e], s / 64.0);
          x[k] = plane;
          add_cells_holding(x, cells);
        }
    }
  }
  return cells;
}

/// A coordinate of the grid: often an integer or half-integer, so vertices and edges lie on
/// cell faces, edges and corners.
float grid_coordinate(Generator& g, double near, double spread) {
  const double x = std::clamp(near + g.uniform(-spread, spread), 0.0, double(kGrid));
  switch (g.below(3)) {
    case 0:
      return float(std::round(x));
    case 1:
      return float(std::round(2 * x) / 2);
    default:
      return Generator::snap(x, 16);
  }
}

TEST(TriangleBox, GridCellsCoverSampledPoints) {
  Generator g(7);
  long float_cells = 0, exact_cells = 0, missed_samples = 0, missed_exact = 0, double_disagree = 0;
  for (int n = 0; n < 1500; ++n) {
    std::array<Vec3<float>, 3> tri;
    const double spread = g.log_uniform(0.25, 4);
    Vec3<double> center{g.uniform(0, kGrid), g.uniform(0, kGrid), g.uniform(0, kGrid)};
    for (auto& v : tri)
      for (int k = 0; k < 3; ++k)
        v[k] = grid_coordinate(g, center[k], spread);
    if (g.chance(0.1)) tri[2] = g.chance(0.5) ? tri[0] : tri[1];  // degenerate
    std::set<Cell> tested;
    for (int i = 0; i < kGrid; ++i)
      for (int j = 0; j < kGrid; ++j)
        for (int k = 0; k < kGrid; ++k) {
          const Vec3<float> lo{float(i), float(j), float(k)}, hi = lo + Vec3<float>{1, 1, 1};
          const bool in_float = triangle_overlaps_box(tri[0], tri[1], tri[2], lo, hi, 0.0f);
          const Case c{tri, lo, hi};
          const bool exact = exact_overlap(c).overlap;
          double_disagree += tested_overlap<double>(c) != exact;
          if (in_float) tested.insert({i, j, k});
          exact_cells += exact;
          missed_exact += exact && !in_float;
        }
    float_cells += long(tested.size());
    for (const Cell& cell : sampled_cells(tri, g))
      missed_samples += !tested.count(cell);
  }
  std::printf(
      "grid cells: float %ld, exact %ld, exact missed %ld, sampled missed %ld, double != exact "
      "%ld\n",
      float_cells, exact_cells, missed_exact, missed_samples, double_disagree);
  EXPECT_EQ(missed_samples, 0);
  EXPECT_EQ(missed_exact, 0);
  EXPECT_LE(float_cells - exact_cells, exact_cells / 100);
  EXPECT_EQ(double_disagree, 0);
}

TEST(TriangleBox, DoubleAgreesWithFloatOnGenericCases) {
  long disagreements = 0;
  for (const Case& c : case_sets().generic)
    disagreements += tested_overlap<float>(c) != tested_overlap<double>(c);
  EXPECT_LE(disagreements, long(case_sets().generic.size()) / 10000);
}

}  // namespace
}  // namespace irgrid
