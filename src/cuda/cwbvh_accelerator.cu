// The compressed wide BVH on the GPU: built on the host (baselines/cwbvh_build.h), uploaded,
// and traversed one ray per thread by the same header code as the CPU
// (irgrid/kernel/cwbvh_traverse.h).
#include <chrono>
#include <mutex>

#include "api/lazy_host_triangles.h"
#include "baselines/cwbvh_build.h"
#include "cpu/structures.h"
#include "cuda/device_buffer.cuh"
#include "irgrid/kernel/cwbvh_traverse.h"

namespace irgrid {
namespace {

constexpr unsigned kTraceThreads = 128;

template <Query kQuery, bool kCounted>
__global__ void __launch_bounds__(kTraceThreads)
    cwbvh_kernel(CwbvhView bvh, const Ray* __restrict__ rays, Hit* __restrict__ hits,
                 RayWork* __restrict__ work, std::size_t count) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= count) return;
  if constexpr (kCounted) {
    TraversalCounters counters;
    hits[i] = traverse_cwbvh<kQuery>(bvh, rays[i], &counters);
    work[i] = {counters.cells, counters.triangles};
  } else {
    hits[i] = traverse_cwbvh<kQuery>(bvh, rays[i]);
  }
}

template <typename T>
cuda::DeviceBuffer<T> to_device(const std::vector<T>& host, const char* what) {
  cuda::DeviceBuffer<T> device(host.size(), what);
  if (!host.empty()) device.upload(host.data(), host.size());
  return device;
}

class CwbvhCuda final : public Accelerator {
 public:
  CwbvhCuda(const TriangleMesh& mesh, const AcceleratorOptions& options)
      : options_(options), triangle_count_(mesh.triangle_count) {
    build(mesh);
  }

  Structure structure() const override { return Structure::cwbvh; }
  Backend backend() const override { return Backend::cuda; }
  const BuildStats& build_stats() const override { return info_; }
  bool counts_work() const override { return true; }

  void rebuild(const TriangleMesh& mesh) override {
    check_rebuild(mesh, triangle_count_);
    build(mesh);
  }

  using Accelerator::trace;  // and trace over RayArrays / HitArrays, converting
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    trace_staged(rays, hits, {}, query);
  }

  void trace_counted(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                     Query query) const override {
    check_trace_spans(rays, hits);
    if (work.size() != rays.size())
      throw Error(ErrorCode::invalid_argument, "trace_counted: work must have one entry per ray");
    trace_staged(rays, hits, work, query);
  }

  void trace_device(const Ray* d_rays, Hit* d_hits, std::size_t count, Query query,
                    CUstream_st* stream) const override {
    if (count == 0) return;
    IRGRID_CUDA_CHECK_NONE_PENDING("trace_device");
    launch(query, d_rays, d_hits, nullptr, count, stream);
    IRGRID_CUDA_CHECK_ASYNC_LAUNCH("cwbvh traversal kernel");
  }

 private:
  std::span<const TriangleVertices> host_triangles() const override {
    return host_triangles_.get([&](auto& out) { triangles_.download_all(out); });
  }

  void build(const TriangleMesh& mesh) {
    host_triangles_.reset();
    nodes_ = {}, refs_ = {}, triangles_ = {};  // misses until the build succeeds
    const auto start = std::chrono::steady_clock::now();
    const HostCwbvh bvh = build_cwbvh_timed(mesh, options_, info_);
    const auto upload_start = std::chrono::steady_clock::now();
    nodes_ = to_device(bvh.nodes, "cwbvh nodes");
    refs_ = to_device(bvh.refs, "cwbvh references");
    triangles_ = to_device(bvh.triangles, "cwbvh triangles");
    IRGRID_CUDA_CHECK(cudaDeviceSynchronize());
    info_.phase_ms[std::size_t(BuildPhase::upload)] =
        elapsed_ms<std::chrono::steady_clock>(upload_start);
    info_.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
    if (options_.on_phase) options_.on_phase(BuildPhase::upload);
  }

  CwbvhView view() const {
    return {nodes_.data(), refs_.data(), triangles_.data(), std::uint32_t(nodes_.size())};
  }

  /// Uploads the rays, runs the kernel, downloads the hits (and work). One batch at a time:
  /// the staging buffers are shared, so callers are serialised.
  void trace_staged(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                    Query query) const {
    if (rays.empty()) return;
    const std::lock_guard lock(mutex_);
    reserve(rays_, rays.size(), "rays");
    reserve(hits_, rays.size(), "hits");
    if (!work.empty()) reserve(work_, rays.size(), "per-ray work counters");
    rays_.upload(rays.data(), rays.size());
    launch(query, rays_.data(), hits_.data(), work.empty() ? nullptr : work_.data(), rays.size(),
           nullptr);
    IRGRID_CUDA_CHECK_LAUNCH("cwbvh traversal kernel");
    hits_.download(hits.data(), hits.size());
    if (!work.empty()) work_.download(work.data(), work.size());
  }

  void launch(Query query, const Ray* rays, Hit* hits, RayWork* work, std::size_t count,
              cudaStream_t stream) const {
    const unsigned blocks = unsigned((count + kTraceThreads - 1) / kTraceThreads);
    const CwbvhView bvh = view();
    if (query == Query::closest && work)
      cwbvh_kernel<Query::closest, true>
          <<<blocks, kTraceThreads, 0, stream>>>(bvh, rays, hits, work, count);
    else if (query == Query::closest)
      cwbvh_kernel<Query::closest, false>
          <<<blocks, kTraceThreads, 0, stream>>>(bvh, rays, hits, nullptr, count);
    else if (work)
      cwbvh_kernel<Query::any, true>
          <<<blocks, kTraceThreads, 0, stream>>>(bvh, rays, hits, work, count);
    else
      cwbvh_kernel<Query::any, false>
          <<<blocks, kTraceThreads, 0, stream>>>(bvh, rays, hits, nullptr, count);
  }

  template <typename T>
  static void reserve(cuda::DeviceBuffer<T>& buffer, std::size_t count, const char* what) {
    if (buffer.size() < count) {
      buffer.reset();
      buffer = cuda::DeviceBuffer<T>(count, what);
    }
  }

  AcceleratorOptions options_;
  std::size_t triangle_count_;
  BuildStats info_;
  cuda::DeviceBuffer<CwbvhNode> nodes_;
  cuda::DeviceBuffer<std::uint32_t> refs_;
  cuda::DeviceBuffer<TriangleVertices> triangles_;
  LazyHostTriangles host_triangles_;  // for trace(RayArrays, HitArrays) with normals
  mutable std::mutex mutex_;
  mutable cuda::DeviceBuffer<Ray> rays_;
  mutable cuda::DeviceBuffer<Hit> hits_;
  mutable cuda::DeviceBuffer<RayWork> work_;
};

}  // namespace

std::unique_ptr<Accelerator> make_cwbvh_cuda(const TriangleMesh& mesh,
                                             const AcceleratorOptions& options) {
  return std::make_unique<CwbvhCuda>(mesh, options);
}

}  // namespace irgrid
