// The exact oracle over a scene: exact ray/triangle decisions behind a conservative BVH of its own.
//
// The hierarchy's boxes are the exact float bounds of their triangles, unpadded; the slab test
// instead widens each slab's parameter interval by 1e-12 of its scale, far more than the relative
// rounding error of its double arithmetic (a few 1e-16), so the computed interval always contains
// the exact one and a box the segment [tmin, tmax] touches is never culled.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "cpu/structures.h"
#include "exact_line.h"
#include "irgrid/io/exact.h"

namespace irgrid {

using exact::Line;
using exact::LineTriangle;

ExactIntersection intersect_exact(const Ray& ray, const Vec3f& p0, const Vec3f& p1,
                                  const Vec3f& p2) {
  const Line line(ray);
  LineTriangle test(line, p0.data(), p1.data(), p2.data());
  ExactIntersection result;
  if (!line.valid) return result;
  result.crosses = test.crosses();
  result.parallel = test.parallel();
  if (result.parallel) return result;
  result.in_window =
      result.crosses && test.compare_t(line.tmin) >= 0 && test.compare_t(line.tmax) <= 0;
  result.t = test.t(), result.u = test.u(), result.v = test.v();
  return result;
}

struct ExactTracer::Impl {
  struct Node {
    float lo[3], hi[3];
    std::uint32_t first;  ///< inner node: the left child (the right one follows it)
    std::uint32_t count;  ///< leaf: triangles from triangles[first]; 0 for inner nodes
    int axis;             ///< inner node: the children split the centres along this axis
  };
  static constexpr std::uint32_t kLeafSize = 4;

  std::vector<std::array<float, 9>> triangles;  ///< vertices, in hierarchy order
  std::vector<std::uint32_t> ids;               ///< scene index of each
  std::vector<Node> nodes;
  double largest_coordinate = 0;

  explicit Impl(const Scene& scene);
  void build(std::uint32_t node, std::uint32_t first, std::uint32_t count,
             std::vector<std::array<double, 3>>& centres);
  Hit trace(const Ray& ray, Query query, bool cull) const;
};

ExactTracer::Impl::Impl(const Scene& scene) {
  std::vector<std::array<double, 3>> centres;
  for (std::uint32_t id = 0; id < scene.triangles.size(); ++id) {
    std::array<float, 9> t;
    std::array<double, 3> centre{};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) {
        t[3 * k + a] = scene.vertices[scene.triangles[id][k]][a];
        centre[a] += t[3 * k + a];
        largest_coordinate = std::max(largest_coordinate, std::abs(double(t[3 * k + a])));
      }
    triangles.push_back(t);
    ids.push_back(id);
    centres.push_back(centre);
  }
  nodes.push_back({});
  nodes.reserve(2 * triangles.size() / kLeafSize + 2);
  if (!triangles.empty()) build(0, 0, std::uint32_t(triangles.size()), centres);
}

/// Median splits on the widest axis of the centres; depth <= log2(triangles) + 1.
void ExactTracer::Impl::build(std::uint32_t node, std::uint32_t first, std::uint32_t count,
                              std::vector<std::array<double, 3>>& centres) {
  Node box{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, first, count, 0};
  double centre_lo[3] = {INFINITY, INFINITY, INFINITY},
         centre_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::uint32_t i = first; i < first + count; ++i)
    for (int a = 0; a < 3; ++a) {
      for (int k = 0; k < 3; ++k) {
        box.lo[a] = std::min(box.lo[a], triangles[i][3 * k + a]);
        box.hi[a] = std::max(box.hi[a], triangles[i][3 * k + a]);
      }
      centre_lo[a] = std::min(centre_lo[a], centres[i][a]);
      centre_hi[a] = std::max(centre_hi[a], centres[i][a]);
    }
  nodes[node] = box;
  if (count <= kLeafSize) return;
  int axis = 0;
  for (int a = 1; a < 3; ++a)
    if (centre_hi[a] - centre_lo[a] > centre_hi[axis] - centre_lo[axis]) axis = a;
  const std::uint32_t half = count / 2;
  std::vector<std::uint32_t> order(count);
  std::iota(order.begin(), order.end(), first);
  std::nth_element(order.begin(), order.begin() + half, order.end(),
                   [&](std::uint32_t a, std::uint32_t b) {
                     return centres[a][axis] < centres[b][axis] ||
                            (centres[a][axis] == centres[b][axis] && a < b);
                   });
  // Apply the permutation to the three parallel arrays.
  std::vector<std::array<float, 9>> t(count);
  std::vector<std::uint32_t> id(count);
  std::vector<std::array<double, 3>> c(count);
  for (std::uint32_t i = 0; i < count; ++i)
    t[i] = triangles[order[i]], id[i] = ids[order[i]], c[i] = centres[order[i]];
  std::copy(t.begin(), t.end(), triangles.begin() + first);
  std::copy(id.begin(), id.end(), ids.begin() + first);
  std::copy(c.begin(), c.end(), centres.begin() + first);
  const auto left = std::uint32_t(nodes.size());
  nodes[node].first = left, nodes[node].count = 0, nodes[node].axis = axis;
  nodes.push_back({});
  nodes.push_back({});
  build(left, first, half, centres);
  build(left + 1, first + half, count - half, centres);
}

namespace {

/// A ray's slab-test constants: for each axis 1 / dir and the widening of that axis' interval.
struct Slabs {
  double org[3], inv[3], widen[3];
  bool flat[3];  ///< dir is 0 on this axis: the line stays in the plane org[a]
  Slabs(const Line& line, double largest_coordinate) {
    for (int a = 0; a < 3; ++a) {
      org[a] = line.org[a];
      flat[a] = line.dir[a] == 0;
      inv[a] = flat[a] ? 0 : 1 / line.dir[a];
      widen[a] = 1e-12 * (largest_coordinate + std::abs(org[a])) * std::abs(inv[a]);
    }
  }
  /// The widened parameter interval of the line in the box, clipped to [near, far]; empty (and
  /// false) when the line misses it there.
  template <typename Box>
  bool clip(const Box& box, double& near, double& far) const {
    for (int a = 0; a < 3; ++a) {
      if (flat[a]) {
        if (org[a] < box.lo[a] || org[a] > box.hi[a]) return false;
        continue;
      }
      double t0 = (box.lo[a] - org[a]) * inv[a], t1 = (box.hi[a] - org[a]) * inv[a];
      if (t0 > t1) std::swap(t0, t1);
      near = std::max(near, t0 - widen[a]);
      far = std::min(far, t1 + widen[a]);
    }
    return near <= far;
  }
};

}  // namespace

Hit ExactTracer::Impl::trace(const Ray& ray, Query query, bool cull) const {
  const Line line(ray);
  Hit result;
  if (!line.valid || triangles.empty()) return result;
  const Slabs slabs(line, largest_coordinate);
  std::optional<LineTriangle> best;
  std::uint32_t best_id = kNoHit;
  // Whether triangle i is hit in [tmin, tmax] and before the best so far (ties to the smaller
  // id); makes it the best when it is.
  auto consider = [&](std::uint32_t i) {
    const auto& t = triangles[i];
    LineTriangle test(line, &t[0], &t[3], &t[6]);
    if (!test.crosses() || test.compare_t(line.tmin) < 0 || test.compare_t(line.tmax) > 0)
      return false;
    if (best) {
      const int order = test.compare_t(*best);
      if (order > 0 || (order == 0 && ids[i] > best_id)) return false;
    }
    best.emplace(std::move(test));
    best_id = ids[i];
    return true;
  };
  if (!cull) {
    for (std::uint32_t i = 0; i < triangles.size(); ++i)
      if (consider(i) && query == Query::any) break;
  } else {
    std::uint32_t stack[128];  // depth <= 33 for 2^32 triangles, one pending sibling per level
    int size = 0;
    stack[size++] = 0;
    while (size > 0) {
      const Node& node = nodes[stack[--size]];
      double near = line.tmin, far = best ? std::min(line.tmax, best->t_upper()) : line.tmax;
      if (!slabs.clip(node, near, far)) continue;
      if (node.count == 0) {  // the child nearer the origin first
        const bool left_first = line.dir[node.axis] >= 0;
        stack[size++] = node.first + (left_first ? 1 : 0);
        stack[size++] = node.first + (left_first ? 0 : 1);
        continue;
      }
      bool done = false;
      for (std::uint32_t i = node.first; i < node.first + node.count && !done; ++i)
        done = consider(i) && query == Query::any;
      if (done) break;
    }
  }
  if (!best) return result;
  return {best_id, float(best->t()), float(best->u()), float(best->v())};
}

ExactTracer::ExactTracer(const Scene& scene) : impl_(std::make_unique<Impl>(scene)) {}
ExactTracer::~ExactTracer() = default;

void ExactTracer::trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const {
  check_trace_spans(rays, hits);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 16), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      hits[i] = impl_->trace(rays[i], query, true);
  });
}

void ExactTracer::trace_all_triangles(std::span<const Ray> rays, std::span<Hit> hits,
                                      Query query) const {
  check_trace_spans(rays, hits);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 4), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      hits[i] = impl_->trace(rays[i], query, false);
  });
}

}  // namespace irgrid
