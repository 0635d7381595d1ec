// Built-in procedural scenes: cornell, teapot-stadium, soup, hairball, sphere, cube, and the
// hostile overlap and stack.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <new>
#include <numbers>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "irgrid/error.h"
#include "irgrid/io/random.h"
#include "irgrid/io/scene.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {
namespace {

constexpr double pi = std::numbers::pi;
constexpr std::uint64_t max_size_parameter = std::uint64_t(1) << 31;
constexpr std::uint64_t max_vertex_count = std::numeric_limits<std::uint32_t>::max();

// ---------------------------------------------------------------------------------------------
// Mesh building helpers

Vec3f to_float(const Vec3d& p) {
  return {float(p.x), float(p.y), float(p.z)};
}

std::uint32_t add_vertex(Scene& scene, const Vec3d& p) {
  scene.vertices.push_back(to_float(p));
  return std::uint32_t(scene.vertices.size() - 1);
}

void add_triangle(Scene& scene, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  scene.triangles.push_back({a, b, c});
}

/// Splits the quad a-b-c-d (counter-clockwise seen from the side its normal points to).
void add_quad(Scene& scene, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  add_triangle(scene, a, b, c);
  add_triangle(scene, a, c, d);
}

/// Rotates p about the y axis by `angle` radians (counter-clockwise seen from +y).
Vec3d rotate_y(const Vec3d& p, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * p.x + s * p.z, p.y, -s * p.x + c * p.z};
}

/// A uniformly distributed point in the unit ball (rejection sampling keeps it exact and
/// free of transcendental functions, so it is identical on every platform).
Vec3d random_in_unit_ball(Pcg32& rng) {
  for (;;) {
    const Vec3d p{2.0 * rng.next_float() - 1.0, 2.0 * rng.next_float() - 1.0,
                  2.0 * rng.next_float() - 1.0};
    if (dot(p, p) <= 1.0) return p;
  }
}

/// A uniformly distributed unit vector; points too close to the centre are rejected so that
/// normalising them loses no precision.
Vec3d random_unit_vector(Pcg32& rng) {
  for (;;) {
    const Vec3d p = random_in_unit_ball(rng);
    if (dot(p, p) >= 0.01) return normalize(p);
  }
}

/// Adds the surface of the unit cube [0,1]^3, split into n x n quads per face and mapped
/// through `to_world` (which must keep handedness). Vertices on the cube's edges and corners
/// are shared between faces, so the surface is closed: every edge lies in exactly two
/// triangles. Normals point outward, or inward when `inward` (a room seen from inside).
void add_lattice_box(Scene& scene, int n, bool inward,
                     const std::function<Vec3d(const Vec3d&)>& to_world) {
  std::map<std::array<int, 3>, std::uint32_t> index_of;
  auto vertex = [&](const std::array<int, 3>& lattice) {
    auto [it, inserted] = index_of.try_emplace(lattice, 0);
    if (inserted) {
      const Vec3d unit{lattice[0] / double(n), lattice[1] / double(n), lattice[2] / double(n)};
      it->second = add_vertex(scene, to_world(unit));
    }
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    // (u_axis, v_axis, axis) is right-handed, so quad (0,0)(1,0)(1,1)(0,1) faces +axis.
    const int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      const bool flip = (side == 0) != inward;
      for (int u = 0; u < n; ++u) {
        for (int v = 0; v < n; ++v) {
          auto corner = [&](int du, int dv) {
            std::array<int, 3> lattice{};
            lattice[axis] = side * n;
            lattice[u_axis] = u + du;
            lattice[v_axis] = v + dv;
            return vertex(lattice);
          };
          const auto a = corner(0, 0), b = corner(1, 0), c = corner(1, 1), d = corner(0, 1);
          if (flip) {
            add_quad(scene, a, d, c, b);
          } else {
            add_quad(scene, a, b, c, d);
          }
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// cube, cornell

Scene make_cube(std::uint64_t /*size*/) {
  Scene scene;
  add_lattice_box(scene, 1, false, [](const Vec3d& u) { return 2.0 * u - Vec3d{1, 1, 1}; });
  return scene;
}

/// A closed box standing on `base_centre` (centre of its bottom face), turned about y.
void add_rotated_box(Scene& scene, const Vec3d& base_centre, const Vec3d& size, double angle) {
  add_lattice_box(scene, 1, false, [&](const Vec3d& u) {
    const Vec3d local{(u.x - 0.5) * size.x, u.y * size.y, (u.z - 0.5) * size.z};
    return base_centre + rotate_y(local, angle);
  });
}

/// The Cornell room spans [-1,1] x [0,2] x [-1,1]; all six walls are present so every ray
/// starting inside hits something.
Scene make_cornell(std::uint64_t /*size*/) {
  Scene scene;
  add_lattice_box(scene, 4, true, [](const Vec3d& u) {
    return Vec3d{2 * u.x - 1, 2 * u.y, 2 * u.z - 1};
  });
  // The boxes float 2 mm above the floor so their bottoms do not overlap floor triangles
  // (coplanar overlaps make the nearest hit ambiguous between backends).
  add_rotated_box(scene, {-0.38, 0.002, -0.45}, {0.5, 1.2, 0.5}, 0.3);  // tall box
  add_rotated_box(scene, {0.38, 0.002, 0.05}, {0.5, 0.5, 0.5}, -0.3);   // short box
  add_rotated_box(scene, {0.0, 1.97, 0.0}, {0.5, 0.02, 0.5}, 0.0);      // ceiling light panel
  scene.views.push_back({{0.0f, 1.0f, 0.97f}, {0.0f, 0.75f, -1.0f}, {0, 1, 0}, 65.0f});
  scene.views.push_back({{-0.85f, 1.75f, 0.85f}, {0.1f, 0.4f, -0.1f}, {0, 1, 0}, 60.0f});
  return scene;
}

// ---------------------------------------------------------------------------------------------
// sphere: a geodesic sphere (icosahedron whose faces are split into f x f triangles)

/// The 12 corners and 20 faces of an icosahedron, faces wound counter-clockwise from outside.
struct Icosahedron {
  std::array<Vec3d, 12> corners;
  std::array<std::array<int, 3>, 20> faces;
};

Icosahedron make_icosahedron() {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  Icosahedron ico{
      {{{-1, g, 0},
        {1, g, 0},
        {-1, -g, 0},
        {1, -g, 0},
        {0, -1, g},
        {0, 1, g},
        {0, -1, -g},
        {0, 1, -g},
        {g, 0, -1},
        {g, 0, 1},
        {-g, 0, -1},
        {-g, 0, 1}}},
      {{{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
        {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}}}};
  for (auto& face : ico.faces) {  // enforce outward winding rather than trust the table
    const Vec3d a = ico.corners[face[0]], b = ico.corners[face[1]], c = ico.corners[face[2]];
    if (dot(cross(b - a, c - a), a + b + c) < 0) std::swap(face[1], face[2]);
  }
  return ico;
}

/// Hands out the vertex of a lattice point of a subdivided icosahedron face, creating it on
/// first use. A point is identified by its (corner, weight) pairs in corner order, so points
/// on edges and corners shared by several faces get one vertex: the sphere has no cracks.
class GeodesicVertices {
 public:
  GeodesicVertices(Scene& scene, const Icosahedron& ico, int frequency)
      : scene_(scene), ico_(ico), frequency_(frequency) {}

  /// The vertex at corner weights (frequency - i - j, i, j) of `face`.
  std::uint32_t at(const std::array<int, 3>& face, int i, int j) {
    std::array<std::pair<int, int>, 3> weights{
        {{face[0], frequency_ - i - j}, {face[1], i}, {face[2], j}}};
    std::sort(weights.begin(), weights.end());
    std::uint64_t key = 0;
    Vec3d sum{0, 0, 0};
    for (const auto& [corner, weight] : weights) {
      if (weight == 0) continue;
      // 4 bits of corner and 14 of weight per slot; a used slot never encodes to 0.
      key = (key << 18) | (std::uint64_t(corner) << 14) | std::uint64_t(weight);
      sum = sum + double(weight) * ico_.corners[corner];
    }
    auto [it, inserted] = index_of_.try_emplace(key, 0);
    if (inserted) it->second = add_vertex(scene_, normalize(sum));
    return it->second;
  }

 private:
  Scene& scene_;
  const Icosahedron& ico_;
  int frequency_;
  std::unordered_map<std::uint64_t, std::uint32_t> index_of_;
};

/// A closed unit sphere with 20 f^2 >= `min_triangles` triangles (the smallest such f).
Scene make_sphere(std::uint64_t min_triangles) {
  int frequency = int(std::sqrt(double(min_triangles) / 20.0));
  while (20 * std::uint64_t(frequency) * std::uint64_t(frequency) < min_triangles)
    ++frequency;
  frequency = std::max(frequency, 1);
  const auto f = std::uint64_t(frequency);
  Scene scene;
  scene.vertices.reserve(10 * f * f + 2);
  scene.triangles.reserve(20 * f * f);
  const Icosahedron ico = make_icosahedron();
  GeodesicVertices vertices(scene, ico, frequency);
  for (const auto& face : ico.faces) {
    for (int i = 0; i < frequency; ++i) {
      for (int j = 0; i + j < frequency; ++j) {
        add_triangle(scene, vertices.at(face, i, j), vertices.at(face, i + 1, j),
                     vertices.at(face, i, j + 1));
        if (i + j + 1 < frequency) {
          add_triangle(scene, vertices.at(face, i + 1, j), vertices.at(face, i + 1, j + 1),
                       vertices.at(face, i, j + 1));
        }
      }
    }
  }
  return scene;
}

// ---------------------------------------------------------------------------------------------
// soup: random triangles in the unit cube

/// One random triangle of edge length up to `max_size`, inside the unit cube and with an area
/// well away from zero (degenerate draws are redrawn from the same generator).
std::array<Vec3f, 3> random_soup_triangle(Pcg32& rng, double max_size) {
  const double size = max_size * (0.25 + 0.75 * rng.next_float());
  const double half = 0.5 * size;
  // Keeping the centre `half` away from the faces keeps every corner inside the cube.
  const Vec3d centre{half + (1 - size) * rng.next_float(), half + (1 - size) * rng.next_float(),
                     half + (1 - size) * rng.next_float()};
  for (;;) {
    const std::array<Vec3f, 3> corners{to_float(centre + half * random_in_unit_ball(rng)),
                                       to_float(centre + half * random_in_unit_ball(rng)),
                                       to_float(centre + half * random_in_unit_ball(rng))};
    const Vec3d a = Vec3d::from(corners[0]), b = Vec3d::from(corners[1]),
                c = Vec3d::from(corners[2]);
    if (length(cross(b - a, c - a)) >= 0.02 * size * size) return corners;
  }
}

/// `count` triangles of three vertices each from corners(rng), the generator seeded by the
/// triangle's index and `stream`: the result ignores the thread count.
template <typename Corners>
Scene independent_triangles(const char* name, std::uint64_t count, std::uint64_t stream,
                            Corners corners) {
  if (3 * count > max_vertex_count) {
    throw Error(ErrorCode::limit_exceeded, "builtin " + std::string(name) + ":" +
                                               std::to_string(count) +
                                               " needs more than 2^32 vertices");
  }
  Scene scene;
  scene.vertices.resize(3 * count);
  scene.triangles.resize(count);
  tbb::parallel_for(tbb::blocked_range<std::uint64_t>(0, count, 4096), [&](const auto& range) {
    for (std::uint64_t i = range.begin(); i != range.end(); ++i) {
      Pcg32 rng;
      rng.seed(hash64(i), stream);
      const std::array<Vec3f, 3> triangle = corners(rng);
      for (int k = 0; k < 3; ++k)
        scene.vertices[3 * i + k] = triangle[k];
      scene.triangles[i] = {std::uint32_t(3 * i), std::uint32_t(3 * i + 1),
                            std::uint32_t(3 * i + 2)};
    }
  });
  return scene;
}

Scene make_soup(std::uint64_t count) {
  // Edges of ~2/cbrt(N) fill the cube with a few overlapping triangles per cell.
  const double max_size = std::min(0.5, 2.0 / std::cbrt(double(count)));
  return independent_triangles("soup", count, 0x50u,
                               [&](Pcg32& rng) { return random_soup_triangle(rng, max_size); });
}

// ---------------------------------------------------------------------------------------------
// overlap and stack: hostile scenes for the grid's construction budget (docs/robustness.md)

/// N triangles whose corners are drawn uniformly from the unit cube: each crosses most of the
/// box, so every cell of any grid overlaps a large share of them (foliage cards, hair, CAD
/// slivers taken to the extreme). Seeded by index, like soup.
Scene make_overlap(std::uint64_t count) {
  return independent_triangles("overlap", count, 0x0Fu, [](Pcg32& rng) {
    std::array<Vec3f, 3> corners;
    for (auto& corner : corners)
      corner = {rng.next_float(), rng.next_float(), rng.next_float()};
    return corners;
  });
}

/// N copies of one slanted triangle, each with its own three vertices: every cell the triangle
/// crosses lists all N copies however finely it is split.
Scene make_stack(std::uint64_t count) {
  if (3 * count > max_vertex_count) {
    throw Error(ErrorCode::limit_exceeded,
                "builtin stack:" + std::to_string(count) + " needs more than 2^32 vertices");
  }
  Scene scene;
  scene.vertices.reserve(3 * count);
  scene.triangles.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    const auto a = add_vertex(scene, {0.0, 0.0, 0.0});
    const auto b = add_vertex(scene, {1.0, 0.25, 0.5});
    const auto c = add_vertex(scene, {0.25, 1.0, 0.75});
    add_triangle(scene, a, b, c);
  }
  return scene;
}

// ---------------------------------------------------------------------------------------------
// hairball: thin ribbon strands wandering inside the unit sphere

constexpr std::uint64_t strand_triangles = 400;  // 200 segments; the last strand may be shorter
constexpr double hair_width = 1e-3;              // 1/1000 of the ball's radius
constexpr double hair_step = 0.02;
constexpr double hair_steer_radius = 0.9;  // beyond it strands turn back towards the centre
// Turns are limited to 30 degrees per step, which keeps every ribbon triangle far from
// degenerate (the step never lines up with the ribbon's width).
constexpr double max_turn_cos = 0.86602540378443864676, max_turn_sin = 0.5;

/// Where a strand is and where it heads; `side` spans the ribbon's width (perpendicular to
/// `direction`), `curl` is the slowly varying bend that gives strands momentum.
struct StrandState {
  Vec3d position, direction, side, curl;
};

StrandState start_strand(Pcg32& rng) {
  StrandState s;
  s.position = 0.85 * random_in_unit_ball(rng);
  s.direction = random_unit_vector(rng);
  // Cross with the axis least aligned with the direction: never near zero.
  const Vec3d a = std::abs(s.direction.x) < 0.5 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  s.side = normalize(cross(s.direction, a));
  s.curl = {0, 0, 0};
  return s;
}

/// Turns unit vector `from` towards `target`, by at most the maximum turn. `fallback` is a
/// unit vector perpendicular to `from`, used when `target` points straight back.
Vec3d turn_towards(const Vec3d& from, const Vec3d& target, const Vec3d& fallback) {
  const double target_length = length(target);
  if (target_length < 1e-12) return from;
  const Vec3d to = target * (1.0 / target_length);
  if (dot(from, to) >= max_turn_cos) return to;
  Vec3d perpendicular = to - dot(to, from) * from;
  const double perpendicular_length = length(perpendicular);
  perpendicular =
      perpendicular_length > 1e-9 ? perpendicular * (1.0 / perpendicular_length) : fallback;
  return normalize(max_turn_cos * from + max_turn_sin * perpendicular);
}

void advance_strand(StrandState& s, Pcg32& rng) {
  s.curl = 0.9 * s.curl + 0.06 * random_in_unit_ball(rng);
  Vec3d target = s.direction + s.curl;
  const double radius = length(s.position);
  if (radius > hair_steer_radius) {
    // Heading outward near the boundary: aim at the heading mirrored at the sphere.
    const Vec3d normal = s.position * (1.0 / radius);
    const double outward = dot(s.direction, normal);
    if (outward > 0) target = s.direction - 2.0 * outward * normal;
  }
  s.direction = turn_towards(s.direction, target, s.side);
  // Parallel transport: keep the ribbon's side perpendicular without spinning it.
  s.side = normalize(s.side - dot(s.side, s.direction) * s.direction);
  s.position = s.position + hair_step * s.direction;
}

/// Writes strand `index` with `triangles` triangles as a triangle strip of triangles + 2
/// vertices (left and right edge of the ribbon alternating) at fixed offsets, so strands can
/// be written in any order.
void write_strand(Scene& scene, std::uint64_t index, std::uint64_t triangles) {
  const std::uint64_t first_vertex = index * (strand_triangles + 2);
  const std::uint64_t first_triangle = index * strand_triangles;
  const std::uint64_t vertex_count = triangles + 2;
  Pcg32 rng;
  rng.seed(hash64(index), 0x4a1bu);  // seeded by index: the result ignores the thread count
  StrandState s = start_strand(rng);
  for (std::uint64_t v = 0; v < vertex_count; v += 2) {
    if (v > 0) advance_strand(s, rng);
    const Vec3d half_width = (0.5 * hair_width) * s.side;
    scene.vertices[first_vertex + v] = to_float(s.position - half_width);
    if (v + 1 < vertex_count)
      scene.vertices[first_vertex + v + 1] = to_float(s.position + half_width);
  }
  for (std::uint64_t t = 0; t < triangles; ++t) {
    const auto base = std::uint32_t(first_vertex + t);
    // Strip winding alternates so all triangles of the ribbon face the same way.
    scene.triangles[first_triangle + t] =
        t % 2 == 0 ? std::array<std::uint32_t, 3>{base, base + 1, base + 2}
                   : std::array<std::uint32_t, 3>{base, base + 2, base + 1};
  }
}

Scene make_hairball(std::uint64_t count) {
  const std::uint64_t strands = (count + strand_triangles - 1) / strand_triangles;
  const std::uint64_t vertices = count + 2 * strands;
  if (vertices > max_vertex_count) {
    throw Error(ErrorCode::limit_exceeded,
                "builtin hairball:" + std::to_string(count) + " needs more than 2^32 vertices");
  }
  Scene scene;
  scene.vertices.resize(vertices);
  scene.triangles.resize(count);
  tbb::parallel_for(tbb::blocked_range<std::uint64_t>(0, strands), [&](const auto& range) {
    for (std::uint64_t k = range.begin(); k != range.end(); ++k) {
      const bool last = k + 1 == strands;
      write_strand(scene, k, last ? count - k * strand_triangles : strand_triangles);
    }
  });
  return scene;
}

// ---------------------------------------------------------------------------------------------
// teapot-stadium: a procedural teapot of size ~1 in a stadium ~1000 times larger

using Point2 = std::array<double, 2>;                  // (radius or x, height)
using ProfilePiece = std::function<Point2(double t)>;  // t in [0, 1]

double polyline_length(const ProfilePiece& piece) {
  double total = 0;
  for (int i = 0; i < 32; ++i) {
    const Point2 a = piece(i / 32.0), b = piece((i + 1) / 32.0);
    total += std::hypot(b[0] - a[0], b[1] - a[1]);
  }
  return total;
}

double total_length(const std::vector<ProfilePiece>& pieces) {
  double total = 0;
  for (const auto& piece : pieces)
    total += polyline_length(piece);
  return total;
}

/// Samples consecutive pieces (each starting where the previous ends) with about `segments`
/// segments in all, spread by length; each piece gets at least one.
std::vector<Point2> sample_profile(const std::vector<ProfilePiece>& pieces, int segments) {
  const double total = total_length(pieces);
  std::vector<Point2> points{pieces.front()(0.0)};
  for (const auto& piece : pieces) {
    const int n = std::max(1, int(std::lround(segments * polyline_length(piece) / total)));
    for (int i = 1; i <= n; ++i)
      points.push_back(piece(double(i) / n));
  }
  return points;
}

/// Revolves a profile (radius, height) about the y axis with `around` segments. A profile
/// point on the axis becomes one pole vertex. Normals point outward when the profile runs
/// from bottom to top.
void add_revolution(Scene& scene, const std::vector<Point2>& profile, int around) {
  std::vector<std::uint32_t> first(profile.size());
  std::vector<bool> pole(profile.size());
  for (std::size_t i = 0; i < profile.size(); ++i) {
    const auto [radius, height] = profile[i];
    pole[i] = radius < 1e-9;
    first[i] = std::uint32_t(scene.vertices.size());
    if (pole[i]) {
      add_vertex(scene, {0, height, 0});
      continue;
    }
    for (int j = 0; j < around; ++j) {
      const double angle = 2 * pi * j / around;
      add_vertex(scene, {radius * std::cos(angle), height, radius * std::sin(angle)});
    }
  }
  auto at = [&](std::size_t i, int j) { return pole[i] ? first[i] : first[i] + j % around; };
  for (std::size_t i = 0; i + 1 < profile.size(); ++i) {
    for (int j = 0; j < around; ++j) {
      const auto a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if (!pole[i + 1]) add_triangle(scene, a, b, c);
      if (!pole[i]) add_triangle(scene, a, c, d);
    }
  }
}

/// A tube of `around` segments about a planar centreline in the z = 0 plane, with open ends.
void add_tube(Scene& scene, const std::vector<Point2>& centre, const std::vector<double>& radii,
              int around) {
  const auto first = std::uint32_t(scene.vertices.size());
  for (std::size_t i = 0; i < centre.size(); ++i) {
    const Point2 ahead = centre[std::min(i + 1, centre.size() - 1)];
    const Point2 behind = centre[i == 0 ? 0 : i - 1];
    const Vec3d tangent = normalize(Vec3d{ahead[0] - behind[0], ahead[1] - behind[1], 0});
    const Vec3d in_plane{-tangent.y, tangent.x, 0}, out_of_plane{0, 0, 1};
    for (int j = 0; j < around; ++j) {
      const double angle = 2 * pi * j / around;
      const Vec3d offset = std::cos(angle) * in_plane + std::sin(angle) * out_of_plane;
      add_vertex(scene, Vec3d{centre[i][0], centre[i][1], 0} + radii[i] * offset);
    }
  }
  auto at = [&](std::size_t i, int j) { return first + std::uint32_t(i * around + j % around); };
  for (std::size_t i = 0; i + 1 < centre.size(); ++i) {
    for (int j = 0; j < around; ++j) {  // (in_plane, out_of_plane, tangent) is right-handed
      add_quad(scene, at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
    }
  }
}

/// Segments around and along a surface of `budget` triangles whose quads should be roughly
/// square, given its circumference and length.
std::pair<int, int> split_budget(double budget, double circumference, double length,
                                 int min_around) {
  const int around =
      std::max(min_around, int(std::lround(std::sqrt(budget / 2 * circumference / length))));
  const int along = std::max(1, int(std::lround(budget / (2.0 * around))));
  return {around, along};
}

/// Body, lid and knob in one profile from the bottom pole to the knob's top pole.
std::vector<ProfilePiece> teapot_body_profile() {
  // Belly: an ellipse arc; the whole pot sits 1 cm above the floor (no coplanar overlap).
  auto belly = [](double angle) {
    return Point2{0.5 * std::sin(angle), 0.24 - 0.3 * std::cos(angle)};
  };
  const double belly_from = 0.7, belly_to = 2.5;
  const Point2 bottom_rim = belly(belly_from), top_rim = belly(belly_to);
  const double knob_from = 0.985;  // where the knob's sphere has the stem's radius
  return {[=](double t) {
            return Point2{bottom_rim[0] * t, bottom_rim[1]};
          },
          [=](double t) { return belly(belly_from + (belly_to - belly_from) * t); },
          [=](double t) {
            return Point2{top_rim[0] + (0.26 - top_rim[0]) * t, top_rim[1]};
          },
          [=](double t) {
            const double angle = 1.35 * t;  // the lid dome
            return Point2{0.26 * std::cos(angle), top_rim[1] + 0.12 * std::sin(angle)};
          },
          [=](double t) {
            const Point2 dome_top{0.26 * std::cos(1.35), top_rim[1] + 0.12 * std::sin(1.35)};
            const Point2 stem_top{0.06 * std::sin(knob_from), 0.69 - 0.06 * std::cos(knob_from)};
            return Point2{dome_top[0] + (stem_top[0] - dome_top[0]) * t,
                          dome_top[1] + (stem_top[1] - dome_top[1]) * t};
          },
          [=](double t) {
            const double angle = knob_from + (pi - knob_from) * t;  // knob ball, ends on the axis
            return Point2{t == 1.0 ? 0.0 : 0.06 * std::sin(angle), 0.69 - 0.06 * std::cos(angle)};
          }};
}

/// Samples a tube's centreline and radius at `rings` points.
void add_sampled_tube(Scene& scene, const std::function<Point2(double)>& centreline,
                      const std::function<double(double)>& radius, int rings, int around) {
  std::vector<Point2> centre;
  std::vector<double> radii;
  for (int i = 0; i < rings; ++i) {
    const double t = double(i) / (rings - 1);
    centre.push_back(centreline(t));
    radii.push_back(radius(t));
  }
  add_tube(scene, centre, radii, around);
}

/// A teapot stand-in of about `triangles` triangles, ~1.5 wide, standing at the origin.
void add_teapot(Scene& scene, std::uint64_t triangles) {
  const double budget = double(triangles);
  const auto body = teapot_body_profile();
  const auto [body_around, body_along] =
      split_budget(0.6 * budget, 2 * pi * 0.4, total_length(body), 6);
  add_revolution(scene, sample_profile(body, std::max(body_along, int(body.size()))), body_around);

  // Handle: an elliptic arc whose ends sink into the body on the -x side.
  const auto [handle_around, handle_along] = split_budget(0.15 * budget, 2 * pi * 0.035, 0.75, 3);
  add_sampled_tube(
      scene,
      [](double t) {
        const double angle = 1.2 + 3.9 * t;
        return Point2{-0.45 + 0.22 * std::cos(angle), 0.27 + 0.16 * std::sin(angle)};
      },
      [](double) { return 0.035; }, handle_along + 1, handle_around);

  // Spout: a tapering quadratic Bezier tube rising from inside the body on the +x side.
  const auto [spout_around, spout_along] = split_budget(0.25 * budget, 2 * pi * 0.065, 0.6, 3);
  add_sampled_tube(
      scene,
      [](double t) {
        const double s = 1 - t;
        return Point2{s * s * 0.3 + 2 * s * t * 0.72 + t * t * 0.8,
                      s * s * 0.15 + 2 * s * t * 0.18 + t * t * 0.52};
      },
      [](double t) { return 0.1 + (0.035 - 0.1) * t; }, spout_along + 1, spout_around);
}

/// Floor, stepped stands, back wall and a roof rim; the sky stays open.
void add_stadium(Scene& scene) {
  const double floor_half = 550;
  const int floor_cells = 4;
  const auto first = std::uint32_t(scene.vertices.size());
  for (int i = 0; i <= floor_cells; ++i) {
    for (int j = 0; j <= floor_cells; ++j) {
      add_vertex(scene, {-floor_half + 2 * floor_half * i / floor_cells, 0,
                         -floor_half + 2 * floor_half * j / floor_cells});
    }
  }
  auto at = [&](int i, int j) { return first + std::uint32_t(i * (floor_cells + 1) + j); };
  for (int i = 0; i < floor_cells; ++i) {
    for (int j = 0; j < floor_cells; ++j) {  // wound to face up (+y)
      add_quad(scene, at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
    }
  }
  // Profile from the roof's inner edge down to the field, so the stands face the field.
  std::vector<Point2> profile{{440, 170}, {500, 150}, {500, 120}};
  const int steps = 24;  // 5 m treads and risers from radius 380 to 500
  for (int k = steps - 1; k >= 0; --k) {
    profile.push_back({380 + 5.0 * k, 5.0 * (k + 1)});
    profile.push_back({380 + 5.0 * k, 5.0 * k});
  }
  add_revolution(scene, profile, 128);
}

Scene make_teapot_stadium(std::uint64_t object_triangles) {
  Scene scene;
  add_teapot(scene, object_triangles);
  add_stadium(scene);
  // Close up: looking down at the pot, so the floor right behind it fills the background.
  scene.views.push_back({{1.3f, 1.2f, 1.8f}, {0.0f, 0.3f, 0.0f}, {0, 1, 0}, 50.0f});
  // From a seat in the stands 450 m away (1.7 m above the tread at radius 445-450).
  scene.views.push_back({{0.0f, 71.7f, 447.5f}, {0.0f, 0.35f, 0.0f}, {0, 1, 0}, 40.0f});
  return scene;
}

// ---------------------------------------------------------------------------------------------
// Registry and spec parsing

struct BuiltinScene {
  const char* name;
  std::uint64_t default_size;  ///< 0: the scene takes no size parameter
  const char* usage;
  const char* description;
  Scene (*make)(std::uint64_t size);
};

constexpr BuiltinScene builtin_scenes[] = {
    {"cornell", 0, "cornell",
     "a closed Cornell room [-1,1]x[0,2]x[-1,1] with two rotated boxes and a light panel "
     "(228 triangles, 2 views)",
     make_cornell},
    {"teapot-stadium", 50000, "teapot-stadium:N",
     "a procedural teapot of about N triangles (default 50000) in an open stadium ~1000x larger "
     "(2 views)",
     make_teapot_stadium},
    {"soup", 10000, "soup:N", "N random triangles in the unit cube (default 10000)", make_soup},
    {"hairball", 100000, "hairball:N",
     "a tangle of N thin strand triangles in the unit sphere (default 100000)", make_hairball},
    {"sphere", 1280, "sphere:N",
     "a closed geodesic unit sphere of 20*f^2 >= N triangles, shared vertices (default 1280)",
     make_sphere},
    {"cube", 0, "cube", "a closed cube [-1,1]^3 of 12 triangles with shared vertices", make_cube},
    {"overlap", 30000, "overlap:N",
     "N large random triangles, corners anywhere in the unit cube (default 30000): hostile",
     make_overlap},
    {"stack", 30000, "stack:N", "N copies of one triangle (default 30000): hostile", make_stack},
};

std::string known_names() {
  std::string names;
  for (const auto& scene : builtin_scenes)
    names += std::string(names.empty() ? "" : ", ") + scene.name;
  return names;
}

std::uint64_t parse_size(const std::string& spec, std::string_view text) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end || value == 0 ||
      value > max_size_parameter) {
    throw Error(ErrorCode::invalid_argument, "builtin scene '" + spec +
                                                 "': N must be an integer in [1, 2^31], got '" +
                                                 std::string(text) + "'");
  }
  return value;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> builtin_scene_names() {
  std::vector<std::pair<std::string, std::string>> names;
  for (const auto& scene : builtin_scenes)
    names.emplace_back(scene.usage, scene.description);
  return names;
}

Scene make_builtin_scene(const std::string& full_spec) {
  const std::string prefix = "builtin:";
  const std::string spec =
      full_spec.starts_with(prefix) ? full_spec.substr(prefix.size()) : full_spec;
  const auto colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  const auto* entry = std::find_if(std::begin(builtin_scenes), std::end(builtin_scenes),
                                   [&](const BuiltinScene& s) { return name == s.name; });
  if (entry == std::end(builtin_scenes)) {
    throw Error(ErrorCode::invalid_argument,
                "unknown builtin scene '" + spec + "' (known: " + known_names() + ")");
  }
  std::uint64_t size = entry->default_size;
  if (colon != std::string::npos) {
    if (entry->default_size == 0) {
      throw Error(ErrorCode::invalid_argument,
                  "builtin scene '" + spec + "': '" + name + "' takes no size parameter N");
    }
    size = parse_size(spec, std::string_view(spec).substr(colon + 1));
  }
  try {
    Scene scene = entry->make(size);
    scene.name = prefix + name;
    scene.source = prefix + spec;
    scene.report.triangles_read = scene.triangles.size();
    scene.report.vertices_read = scene.vertices.size();
    drop_invalid_triangles(scene);
    return scene;
  } catch (const std::bad_alloc&) {  // the library reports every failure as an irgrid::Error
    throw Error(ErrorCode::out_of_memory, "not enough memory for builtin scene '" + spec + "'");
  }
}

}  // namespace irgrid
