// The irregular grid (and the uniform and two-level grids) built and traversed on the GPU: the
// build phases of src/core/build instantiated for the CUDA executor, and one traversal kernel.
#include <chrono>
#include <mutex>

#include "api/grid_accelerator_base.h"
#include "api/lazy_host_triangles.h"
#include "core/construction/compress_cells.h"
#include "cpu/structures.h"
#include "cuda/cuda_executor.cuh"
#include "cuda/grid_cuda.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {
namespace {

constexpr unsigned kTraceThreads = 128;

/// One thread per ray; the grid arrays are read through the read-only cache (const
/// __restrict__ views and uniform loads of GridInfo from the kernel parameters).
template <Query kQuery, typename CellT, bool kCounted>
__global__ void __launch_bounds__(kTraceThreads)
    trace_kernel(GridView grid, const Ray* __restrict__ rays, Hit* __restrict__ hits,
                 RayWork* __restrict__ work, std::size_t count) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= count) return;
  if constexpr (kCounted) {
    TraversalCounters counters;
    hits[i] = traverse_grid<kQuery, CellT>(grid, rays[i], &counters);
    work[i] = {counters.cells, counters.triangles};
  } else {
    hits[i] = traverse_grid<kQuery, CellT>(grid, rays[i]);
  }
}

/// Writes a miss into each of the first `count` hits (a grid over no triangles).
__global__ void fill_misses_kernel(Hit* hits, std::size_t count) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < count) hits[i] = Hit{};
}

/// build_grid_and_compress, then waits for the device (kernel errors surface here).
void build_on_device(CudaExecutor& exec, GridArrays<CudaExecutor>& grid,
                     CudaExecutor::Buffer<CompactCell>& compact, const BuildConfig& config,
                     PhaseTimes& phases_ms, const PhaseObserver& on_phase = {},
                     PhaseBytes* phase_peaks = nullptr) {
  build_grid_and_compress(exec, grid, compact, config, phases_ms, on_phase, phase_peaks);
  exec.synchronize();
}

CudaExecutor::Buffer<TriangleVertices> upload_triangles(const CudaExecutor& exec,
                                                        const TriangleMesh& mesh) {
  std::vector<TriangleVertices> host;
  gather_triangles(mesh, host);
  auto device = exec.allocate<TriangleVertices>(host.size());
  // On the executor's stream: after its earlier work on a recycled block, before the build.
  device.upload(host.data(), host.size(), exec.stream());
  return device;
}

template <typename T>
std::vector<T> to_host(const cuda::DeviceBuffer<T>& buffer) {
  std::vector<T> host;
  buffer.download_all(host);
  return host;
}

class GridCuda final : public GridAcceleratorBase {
 public:
  GridCuda(const TriangleMesh& mesh, const AcceleratorOptions& options)
      : GridAcceleratorBase(options) {
    first_build(mesh);
    // After a one-off build the cached blocks would hold the build's peak for the grid's life;
    // rebuilds keep them, so that later frames take every block from the cache.
    exec_.pool().trim();
  }

  Backend backend() const override { return Backend::cuda; }

  GridView grid_view() const override { return view(); }

  void trace_device(const Ray* d_rays, Hit* d_hits, std::size_t count, Query query,
                    CUstream_st* stream) const override {
    if (count == 0) return;
    IRGRID_CUDA_CHECK_NONE_PENDING("trace_device");
    if (empty_scene_) {
      fill_misses_kernel<<<blocks_for(count), kTraceThreads, 0, stream>>>(d_hits, count);
      IRGRID_CUDA_CHECK_ASYNC_LAUNCH("miss fill kernel");
      return;
    }
    launch(query, !compact_cells_.empty(), d_rays, d_hits, nullptr, count, stream);
    IRGRID_CUDA_CHECK_ASYNC_LAUNCH("grid traversal kernel");
  }

 private:
  std::span<const TriangleVertices> host_triangles() const override {
    return host_triangles_.get([&](auto& out) { grid_.triangles.download_all(out); });
  }

  void build(const TriangleMesh& mesh) override {
    host_triangles_.reset();
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t fresh_before = exec_.pool().fresh_allocations();
    // The last grid's blocks go back to the pool first, for this build to take them again.
    grid_ = {};
    compact_cells_ = {};
    grid_.triangles = upload_triangles(exec_, mesh);
    exec_.pool().reset_peak();
    PhaseBytes phase_peaks{};
    if (!grid_.triangles.empty()) {
      build_on_device(exec_, grid_, compact_cells_, options_.grid, info_.phase_ms,
                      options_.on_phase, &phase_peaks);
    }
    info_.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
    // The pool's peaks count every block it gave out, the triangles' included.
    const std::uint64_t peak = peaks_beyond(phase_peaks, exec_.pool().peak(), 0);
    record_grid_statistics(grid_, !compact_cells_.empty(), options_.grid, peak, info_, phase_peaks);
    info_.grid->fresh_allocations = exec_.pool().fresh_allocations() - fresh_before;
  }

  GridView view() const {
    return make_grid_view(grid_, compact_cells_.empty() ? nullptr : compact_cells_.data());
  }

  static unsigned blocks_for(std::size_t count) {
    return unsigned((count + kTraceThreads - 1) / kTraceThreads);
  }

  /// Uploads the rays, runs the kernel for this grid's cell layout and query, downloads the
  /// hits. One batch at a time: the staging buffers are shared, so callers are serialised.
  void trace_grid(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                  Query query) const override {
    const std::lock_guard lock(mutex_);
    reserve(rays_, rays.size(), "rays");
    reserve(hits_, rays.size(), "hits");
    if (!work.empty()) reserve(work_, rays.size(), "per-ray work counters");
    rays_.upload(rays.data(), rays.size());
    launch(query, !compact_cells_.empty(), rays_.data(), hits_.data(),
           work.empty() ? nullptr : work_.data(), rays.size(), nullptr);
    IRGRID_CUDA_CHECK_LAUNCH("grid traversal kernel");
    hits_.download(hits.data(), hits.size());
    if (!work.empty()) work_.download(work.data(), work.size());
  }

  /// Queues the traversal kernel for this grid's cell layout and `query` on `stream`; counts
  /// the work per ray when `work` is not null.
  void launch(Query query, bool compact, const Ray* rays, Hit* hits, RayWork* work,
              std::size_t count, cudaStream_t stream) const {
    if (query == Query::closest)
      launch_query<Query::closest>(compact, rays, hits, work, count, stream);
    else
      launch_query<Query::any>(compact, rays, hits, work, count, stream);
  }

  template <Query kQuery>
  void launch_query(bool compact, const Ray* rays, Hit* hits, RayWork* work, std::size_t count,
                    cudaStream_t stream) const {
    const unsigned blocks = blocks_for(count);
    const GridView grid = view();
    if (compact && work)
      trace_kernel<kQuery, CompactCell, true>
          <<<blocks, kTraceThreads, 0, stream>>>(grid, rays, hits, work, count);
    else if (compact)
      trace_kernel<kQuery, CompactCell, false>
          <<<blocks, kTraceThreads, 0, stream>>>(grid, rays, hits, nullptr, count);
    else if (work)
      trace_kernel<kQuery, Cell, true>
          <<<blocks, kTraceThreads, 0, stream>>>(grid, rays, hits, work, count);
    else
      trace_kernel<kQuery, Cell, false>
          <<<blocks, kTraceThreads, 0, stream>>>(grid, rays, hits, nullptr, count);
  }

  template <typename T>
  static void reserve(cuda::DeviceBuffer<T>& buffer, std::size_t count, const char* what) {
    if (buffer.size() < count) {
      buffer.reset();  // free first: the old and new staging buffers need not coexist
      buffer = cuda::DeviceBuffer<T>(count, what);
    }
  }

  CudaExecutor exec_;  // first: its memory pool must outlive every buffer below
  GridArrays<CudaExecutor> grid_;
  LazyHostTriangles host_triangles_;  // for trace(RayArrays, HitArrays) with normals
  CudaExecutor::Buffer<CompactCell> compact_cells_;
  mutable std::mutex mutex_;
  mutable cuda::DeviceBuffer<Ray> rays_;
  mutable cuda::DeviceBuffer<Hit> hits_;
  mutable cuda::DeviceBuffer<RayWork> work_;
};

}  // namespace

std::unique_ptr<Accelerator> make_grid_cuda(const TriangleMesh& mesh,
                                            const AcceleratorOptions& options) {
  return std::make_unique<GridCuda>(mesh, options);
}

HostGridArrays build_grid_cuda_arrays(const TriangleMesh& mesh, const BuildConfig& config,
                                      int builds) {
  if (builds < 1)
    throw Error(ErrorCode::invalid_argument, "build_grid_cuda_arrays: builds must be >= 1");
  CudaExecutor exec;
  HostGridArrays out;
  for (int b = 0; b < builds; ++b) {
    const std::uint64_t fresh_before = exec.pool().fresh_allocations();
    GridArrays<CudaExecutor> grid;
    CudaExecutor::Buffer<CompactCell> compact;
    grid.triangles = upload_triangles(exec, mesh);
    PhaseTimes phases;
    build_on_device(exec, grid, compact, config, phases);
    if (b + 1 < builds) continue;
    out.info = grid.info;
    out.entries = to_host(grid.entries);
    out.cells = to_host(grid.cells);
    out.compact_cells = to_host(compact);
    out.refs = to_host(grid.refs);
    out.empty_radii = to_host(grid.empty_radii);
    out.fresh_allocations_last_build = exec.pool().fresh_allocations() - fresh_before;
  }
  return out;
}

}  // namespace irgrid
