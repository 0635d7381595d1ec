// The fast double-precision reference: brute-force results, with a conservative BVH for culling.
//
// A ray can only hit a triangle whose bounding box it touches, so culling by boxes changes no
// result as long as no touched box is ever culled. The boxes are therefore padded by far more
// than any rounding error of the double-precision slab test (1e-9 of the scene diagonal, against
// relative errors near 1e-16), and ties are broken like the brute force: the smallest t, then
// the smallest triangle id.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "cpu/structures.h"
#include "irgrid/io/validate.h"
#include "irgrid/kernel/watertight.h"

namespace irgrid {

struct ReferenceTracer::Impl {
  struct Node {
    Vec3d lo, hi;
    std::uint32_t first;  ///< inner node: index of the left child (right = first + 1)
    std::uint32_t count;  ///< leaf: number of triangles from order[first]; 0 for inner nodes
  };
  struct Triangle {
    Vec3d p0, p1, p2;
  };
  static constexpr std::uint32_t kLeafSize = 4;
  static constexpr int kMaxDepth = 96;

  std::vector<Triangle> triangles;
  std::vector<std::uint32_t> order;
  std::vector<Node> nodes;
  double padding = 0;

  explicit Impl(const Scene& scene);
  void build(std::uint32_t node, std::uint32_t first, std::uint32_t count,
             std::vector<Vec3d>& centroids, int depth);
  Hit trace(const Ray& ray, Query query) const;
};

ReferenceTracer::Impl::Impl(const Scene& scene) {
  triangles.reserve(scene.triangles.size());
  std::vector<Vec3d> centroids;
  centroids.reserve(scene.triangles.size());
  for (const auto& tri : scene.triangles) {
    triangles.push_back({Vec3d::from(scene.vertices[tri[0]]), Vec3d::from(scene.vertices[tri[1]]),
                         Vec3d::from(scene.vertices[tri[2]])});
    const auto& t = triangles.back();
    centroids.push_back((t.p0 + t.p1 + t.p2) * (1.0 / 3.0));
  }
  padding = 1e-9 * std::max(double(scene.bounds().diagonal()), 1e-30);
  order.resize(triangles.size());
  std::iota(order.begin(), order.end(), 0u);
  nodes.reserve(2 * triangles.size() / kLeafSize + 2);
  nodes.push_back({});
  if (!triangles.empty()) build(0, 0, std::uint32_t(triangles.size()), centroids, 0);
}

void ReferenceTracer::Impl::build(std::uint32_t node, std::uint32_t first, std::uint32_t count,
                                  std::vector<Vec3d>& centroids, int depth) {
  Vec3d lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  Vec3d centre_lo = lo, centre_hi = hi;
  for (std::uint32_t i = first; i < first + count; ++i) {
    const Triangle& t = triangles[order[i]];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min({lo[a], t.p0[a], t.p1[a], t.p2[a]});
      hi[a] = std::max({hi[a], t.p0[a], t.p1[a], t.p2[a]});
      centre_lo[a] = std::min(centre_lo[a], centroids[order[i]][a]);
      centre_hi[a] = std::max(centre_hi[a], centroids[order[i]][a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    lo[a] -= padding + 1e-12 * std::abs(lo[a]);
    hi[a] += padding + 1e-12 * std::abs(hi[a]);
  }
  nodes[node].lo = lo, nodes[node].hi = hi;
  const Vec3d extent = centre_hi - centre_lo;
  const int axis =
      extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  if (count <= kLeafSize || depth >= kMaxDepth || extent[axis] <= 0) {
    nodes[node].first = first, nodes[node].count = count;
    return;
  }
  const std::uint32_t half = count / 2;
  std::nth_element(order.begin() + first, order.begin() + first + half,
                   order.begin() + first + count, [&](std::uint32_t a, std::uint32_t b) {
                     return centroids[a][axis] < centroids[b][axis] ||
                            (centroids[a][axis] == centroids[b][axis] && a < b);
                   });
  const auto left = std::uint32_t(nodes.size());
  nodes[node].first = left, nodes[node].count = 0;
  nodes.push_back({});
  nodes.push_back({});
  build(left, first, half, centroids, depth + 1);
  build(left + 1, first + half, count - half, centroids, depth + 1);
}

namespace {

/// Entry distance of the ray into the box, or +infinity when it misses [tmin, tmax].
double box_entry(const Vec3d& lo, const Vec3d& hi, const Vec3d& org, const Vec3d& inv_dir,
                 const Vec3d& dir, double tmin, double tmax) {
  double near = tmin, far = tmax;
  for (int a = 0; a < 3; ++a) {
    if (dir[a] == 0) {
      if (org[a] < lo[a] || org[a] > hi[a]) return INFINITY;
      continue;
    }
    double t0 = (lo[a] - org[a]) * inv_dir[a], t1 = (hi[a] - org[a]) * inv_dir[a];
    if (t0 > t1) std::swap(t0, t1);
    near = std::fmax(near, t0);  // fmax/fmin ignore a NaN: the interval then stays wider
    far = std::fmin(far, t1);
  }
  return near <= far ? near : INFINITY;
}

}  // namespace

Hit ReferenceTracer::Impl::trace(const Ray& ray, Query query) const {
  Hit best;
  if (triangles.empty()) return best;
  const auto r = make_watertight_ray<double>(ray);
  const Vec3d org = Vec3d::from(ray.org), dir = Vec3d::from(ray.dir);
  const Vec3d inv_dir{1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z};
  const double tmin = ray.tmin, tmax = ray.tmax;
  double best_t = INFINITY;
  std::uint32_t stack[kMaxDepth + 4];  // at most one pending sibling per level
  int size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const Node& node = nodes[stack[--size]];
    // Boxes entered after the best hit cannot hold a closer one (nor an equal one, as the
    // entry distance of a padded box is strictly below every t inside it).
    if (box_entry(node.lo, node.hi, org, inv_dir, dir, tmin, std::fmin(tmax, best_t)) == INFINITY)
      continue;
    if (node.count == 0) {
      stack[size++] = node.first + 1;
      stack[size++] = node.first;
      continue;
    }
    for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
      const std::uint32_t id = order[i];
      const Triangle& t = triangles[id];
      TriangleHit<double> hit;
      if (!intersect_watertight(r, t.p0, t.p1, t.p2, double(INFINITY), hit)) continue;
      if (hit.t > best_t || (hit.t == best_t && id > best.prim)) continue;
      best_t = hit.t;
      best = {id, float(hit.t), float(hit.u), float(hit.v)};
      if (query == Query::any) return best;
    }
  }
  return best;
}

ReferenceTracer::ReferenceTracer(const Scene& scene) : impl_(std::make_unique<Impl>(scene)) {}
ReferenceTracer::~ReferenceTracer() = default;

void ReferenceTracer::trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const {
  check_trace_spans(rays, hits);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 16), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      hits[i] = impl_->trace(rays[i], query);
  });
}

}  // namespace irgrid
