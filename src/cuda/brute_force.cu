// The brute-force tracer on the GPU: the same watertight test as the CPU (core/watertight.h).
#include <chrono>

#include "core/watertight.h"
#include "cpu/structures.h"
#include "cuda/device_buffer.cuh"

namespace irgrid {
namespace {

__global__ void __launch_bounds__(128)
    brute_force_kernel(const Ray* rays, Hit* hits, std::size_t ray_count,
                       const TriangleVertices* triangles, std::uint32_t triangle_count, bool any) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= ray_count) return;
  const auto r = make_watertight_ray<float>(rays[i]);
  Hit best;
  TriangleHit<float> hit;
  for (std::uint32_t j = 0; j < triangle_count; ++j) {
    const TriangleVertices& tri = triangles[j];  // read in place: the test indexes it
    if (!intersect_watertight(r, tri.p0, tri.p1, tri.p2, best.t, hit)) continue;
    best = {j, hit.t, hit.u, hit.v};
    if (any) break;
  }
  hits[i] = best;
}

class BruteForceCuda final : public Accelerator {
 public:
  explicit BruteForceCuda(const Scene& scene) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<TriangleVertices> host;
    gather_triangles(scene, host);
    triangles_ = cuda::DeviceBuffer<TriangleVertices>(host.size(), "brute-force triangles");
    triangles_.upload(host.data(), host.size());
    info_.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    info_.phases_ms["upload"] = info_.build_ms;
    info_.memory_bytes = host.size() * sizeof(TriangleVertices);
  }

  std::string structure() const override { return "brute"; }
  std::string backend() const override { return "cuda"; }
  const BuildInfo& build_info() const override { return info_; }

  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    if (rays.empty()) return;
    cuda::DeviceBuffer<Ray> d_rays(rays.size(), "rays");
    cuda::DeviceBuffer<Hit> d_hits(hits.size(), "hits");
    d_rays.upload(rays.data(), rays.size());
    const unsigned blocks = unsigned((rays.size() + 127) / 128);
    brute_force_kernel<<<blocks, 128>>>(d_rays.data(), d_hits.data(), rays.size(),
                                        triangles_.data(), std::uint32_t(triangles_.size()),
                                        query == Query::any);
    IRGRID_CUDA_CHECK_LAUNCH("brute_force_kernel");
    d_hits.download(hits.data(), hits.size());
  }

 private:
  cuda::DeviceBuffer<TriangleVertices> triangles_;
  BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_brute_force_cuda(const Scene& scene) {
  return std::make_unique<BruteForceCuda>(scene);
}

}  // namespace irgrid
