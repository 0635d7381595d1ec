// The brute-force tracer on the CPU: every ray against every triangle, in parallel with oneTBB.
#include <chrono>

#include <tbb/blocked_range.h>

#include "cpu/parallel.h"
#include "cpu/structures.h"
#include "irgrid/kernel/watertight.h"

namespace irgrid {
namespace {

class BruteForceCpu final : public Accelerator {
 public:
  explicit BruteForceCpu(const TriangleMesh& mesh) { build(mesh); }

  Structure structure() const override { return Structure::brute; }
  Backend backend() const override { return Backend::cpu; }
  const BuildStats& build_stats() const override { return info_; }

  void rebuild(const TriangleMesh& mesh) override {
    check_rebuild(mesh, triangles_.size());
    build(mesh);
  }

  using Accelerator::trace;  // and trace over RayArrays / HitArrays, converting
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    irgrid::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 16),
                         [&](const auto& range) {
                           for (std::size_t i = range.begin(); i != range.end(); ++i)
                             hits[i] = trace_one(rays[i], query);
                         });
  }

 private:
  std::span<const TriangleVertices> host_triangles() const override { return triangles_; }

  void build(const TriangleMesh& mesh) {
    const auto start = std::chrono::steady_clock::now();
    gather_triangles(mesh, triangles_);
    info_.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
    info_.memory_bytes = triangles_.size() * sizeof(TriangleVertices);
  }

  Hit trace_one(const Ray& ray, Query query) const {
    Hit best;
    if (!ray_is_finite(ray)) return best;
    const auto r = make_watertight_ray<float>(ray);
    TriangleHit<float> hit;
    for (std::size_t j = 0; j < triangles_.size(); ++j) {
      const auto& tri = triangles_[j];
      if (!intersect_watertight(r, tri.p0, tri.p1, tri.p2, best.t, hit)) continue;
      best = {std::uint32_t(j), hit.t, hit.u, hit.v};
      if (query == Query::any) break;
    }
    return best;
  }

  std::vector<TriangleVertices> triangles_;
  BuildStats info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_brute_force_cpu(const TriangleMesh& mesh) {
  return std::make_unique<BruteForceCpu>(mesh);
}

}  // namespace irgrid
