// The brute-force tracer on the GPU: the same watertight test as the CPU
// (irgrid/kernel/watertight.h).
#include <chrono>

#include "api/lazy_host_triangles.h"
#include "cpu/structures.h"
#include "cuda/device_buffer.cuh"
#include "irgrid/kernel/watertight.h"

namespace irgrid {
namespace {

__global__ void __launch_bounds__(128)
    brute_force_kernel(const Ray* rays, Hit* hits, std::size_t ray_count,
                       const TriangleVertices* triangles, std::uint32_t triangle_count, bool any) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= ray_count) return;
  Hit best;
  if (!ray_is_finite(rays[i])) {
    hits[i] = best;
    return;
  }
  const auto r = make_watertight_ray<float>(rays[i]);
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
  explicit BruteForceCuda(const TriangleMesh& mesh) {
    triangles_ = cuda::DeviceBuffer<TriangleVertices>(mesh.triangle_count, "brute-force triangles");
    upload(mesh);
  }

  Structure structure() const override { return Structure::brute; }
  Backend backend() const override { return Backend::cuda; }
  const BuildStats& build_stats() const override { return info_; }

  void rebuild(const TriangleMesh& mesh) override {
    check_rebuild(mesh, triangles_.size());
    upload(mesh);  // into the same device buffer
  }

  using Accelerator::trace;  // and trace over RayArrays / HitArrays, converting
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    if (rays.empty()) return;
    cuda::DeviceBuffer<Ray> d_rays(rays.size(), "rays");
    cuda::DeviceBuffer<Hit> d_hits(hits.size(), "hits");
    d_rays.upload(rays.data(), rays.size());
    launch(d_rays.data(), d_hits.data(), rays.size(), query, nullptr);
    IRGRID_CUDA_CHECK_LAUNCH("brute_force_kernel");
    d_hits.download(hits.data(), hits.size());
  }

  void trace_device(const Ray* d_rays, Hit* d_hits, std::size_t count, Query query,
                    CUstream_st* stream) const override {
    if (count == 0) return;
    IRGRID_CUDA_CHECK_NONE_PENDING("trace_device");
    launch(d_rays, d_hits, count, query, stream);
  }

 private:
  std::span<const TriangleVertices> host_triangles() const override {
    return host_triangles_.get([&](auto& out) { triangles_.download_all(out); });
  }

  void upload(const TriangleMesh& mesh) {
    host_triangles_.reset();
    const auto start = std::chrono::steady_clock::now();
    std::vector<TriangleVertices> host;
    gather_triangles(mesh, host);
    triangles_.upload(host.data(), host.size());
    info_.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
    info_.memory_bytes = host.size() * sizeof(TriangleVertices);
  }

  void launch(const Ray* d_rays, Hit* d_hits, std::size_t count, Query query,
              cudaStream_t stream) const {
    const unsigned blocks = unsigned((count + 127) / 128);
    brute_force_kernel<<<blocks, 128, 0, stream>>>(d_rays, d_hits, count, triangles_.data(),
                                                   std::uint32_t(triangles_.size()),
                                                   query == Query::any);
    IRGRID_CUDA_CHECK_ASYNC_LAUNCH("brute_force_kernel");
  }

  cuda::DeviceBuffer<TriangleVertices> triangles_;
  LazyHostTriangles host_triangles_;  // for trace(RayArrays, HitArrays) with normals
  BuildStats info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_brute_force_cuda(const TriangleMesh& mesh) {
  return std::make_unique<BruteForceCuda>(mesh);
}

}  // namespace irgrid
