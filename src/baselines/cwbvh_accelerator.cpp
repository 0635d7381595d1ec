// The compressed wide BVH on the CPU: built by baselines/cwbvh_build.h, traversed one ray at a
// time per oneTBB task by the same header code as the GPU kernel (irgrid/kernel/cwbvh_traverse.h).
#include <tbb/blocked_range.h>

#include "baselines/cwbvh_build.h"
#include "cpu/parallel.h"
#include "cpu/structures.h"
#include "irgrid/kernel/cwbvh_traverse.h"

namespace irgrid {
namespace {

class CwbvhCpu final : public Accelerator {
 public:
  CwbvhCpu(const TriangleMesh& mesh, const AcceleratorOptions& options)
      : options_(options), triangle_count_(mesh.triangle_count) {
    bvh_ = build_cwbvh_timed(mesh, options_, info_);
  }

  Structure structure() const override { return Structure::cwbvh; }
  Backend backend() const override { return Backend::cpu; }
  const BuildStats& build_stats() const override { return info_; }
  bool counts_work() const override { return true; }

  void rebuild(const TriangleMesh& mesh) override {
    check_rebuild(mesh, triangle_count_);
    bvh_ = {};  // traces miss if the build throws
    bvh_ = build_cwbvh_timed(mesh, options_, info_);
  }

  using Accelerator::trace;  // and trace over RayArrays / HitArrays, converting
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    run(rays, hits, {}, query);
  }

  void trace_counted(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                     Query query) const override {
    check_trace_spans(rays, hits);
    if (work.size() != rays.size())
      throw Error(ErrorCode::invalid_argument, "trace_counted: work must have one entry per ray");
    run(rays, hits, work, query);
  }

 private:
  std::span<const TriangleVertices> host_triangles() const override { return bvh_.triangles; }

  template <Query kQuery>
  static Hit trace_one(const CwbvhView& view, const Ray& ray, RayWork* work) {
    if (!work) return traverse_cwbvh<kQuery>(view, ray);
    TraversalCounters counters;
    const Hit hit = traverse_cwbvh<kQuery>(view, ray, &counters);
    *work = {counters.cells, counters.triangles};
    return hit;
  }

  void run(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
           Query query) const {
    const CwbvhView view = bvh_.view();
    irgrid::parallel_for(
        tbb::blocked_range<std::size_t>(0, rays.size(), 64), [&](const auto& range) {
          for (std::size_t i = range.begin(); i != range.end(); ++i) {
            RayWork* w = work.empty() ? nullptr : &work[i];
            hits[i] = query == Query::closest ? trace_one<Query::closest>(view, rays[i], w)
                                              : trace_one<Query::any>(view, rays[i], w);
          }
        });
  }

  AcceleratorOptions options_;
  std::size_t triangle_count_;
  HostCwbvh bvh_;
  BuildStats info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_cwbvh_cpu(const TriangleMesh& mesh,
                                            const AcceleratorOptions& options) {
  return std::make_unique<CwbvhCpu>(mesh, options);
}

}  // namespace irgrid
