// The irregular grid (and the uniform and two-level grids) built and traversed on the GPU: the
// build phases of src/core/build instantiated for the CUDA executor, and one traversal kernel.
#include <chrono>
#include <mutex>

#include "core/build/compress_cells.h"
#include "core/grid/traverse.h"
#include "cpu/structures.h"
#include "cuda/cuda_executor.cuh"
#include "cuda/grid_cuda.h"
#include "grid_accelerator_base.h"

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

/// build_grid_and_compress, then waits for the device (kernel errors surface here).
void build_on_device(CudaExecutor& exec, GridArrays<CudaExecutor>& grid,
                     CudaExecutor::Buffer<CompactCell>& compact, const BuildConfig& config,
                     std::map<std::string, double>& phases_ms, const PhaseObserver& on_phase = {}) {
  build_grid_and_compress(exec, grid, compact, config, phases_ms, on_phase);
  exec.synchronize();
}

CudaExecutor::Buffer<TriangleVertices> upload_triangles(const CudaExecutor& exec,
                                                        const Scene& scene) {
  std::vector<TriangleVertices> host;
  gather_triangles(scene, host);
  auto device = exec.allocate<TriangleVertices>(host.size());
  // On the executor's stream: after its earlier work on a recycled block, before the build.
  device.upload(host.data(), host.size(), exec.stream());
  return device;
}

template <typename T>
std::vector<T> to_host(const cuda::DeviceBuffer<T>& buffer) {
  std::vector<T> host(buffer.size());
  if (!host.empty()) buffer.download(host.data(), host.size());
  return host;
}

class GridCuda final : public GridAcceleratorBase {
 public:
  GridCuda(const Scene& scene, const BuildConfig& config, const PhaseObserver& on_phase)
      : GridAcceleratorBase(config) {
    const auto start = std::chrono::steady_clock::now();
    grid_.triangles = upload_triangles(exec_, scene);
    exec_.pool().reset_peak();
    empty_scene_ = grid_.triangles.empty();
    if (!empty_scene_) {
      build_on_device(exec_, grid_, compact_cells_, config, info_.phases_ms, on_phase);
      if (!compact_cells_.empty()) grid_.cells.reset();
    }
    exec_.pool().trim();
    info_.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    record_grid_statistics(grid_.info, grid_.top_level_refs, !compact_cells_.empty(),
                           grid_.empty_radii.size(), info_);
    info_.counts["peak_build_bytes"] = exec_.pool().peak();
  }

  std::string backend() const override { return "cuda"; }

 private:
  GridView view() const { return grid_view(grid_, compact_cells_.data()); }

  /// Uploads the rays, runs the kernel for this grid's cell layout and query, downloads the
  /// hits. One batch at a time: the staging buffers are shared, so callers are serialised.
  void trace_grid(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                  Query query) const override {
    const std::lock_guard lock(mutex_);
    reserve(rays_, rays.size(), "rays");
    reserve(hits_, rays.size(), "hits");
    if (!work.empty()) reserve(work_, rays.size(), "per-ray work counters");
    rays_.upload(rays.data(), rays.size());
    const bool compact = !compact_cells_.empty(), counted = !work.empty();
    if (query == Query::closest)
      launch<Query::closest>(compact, counted, rays.size());
    else
      launch<Query::any>(compact, counted, rays.size());
    hits_.download(hits.data(), hits.size());
    if (counted) work_.download(work.data(), work.size());
  }

  template <Query kQuery>
  void launch(bool compact, bool counted, std::size_t count) const {
    const auto blocks = unsigned((count + kTraceThreads - 1) / kTraceThreads);
    const GridView grid = view();
    if (compact && counted)
      trace_kernel<kQuery, CompactCell, true>
          <<<blocks, kTraceThreads>>>(grid, rays_.data(), hits_.data(), work_.data(), count);
    else if (compact)
      trace_kernel<kQuery, CompactCell, false>
          <<<blocks, kTraceThreads>>>(grid, rays_.data(), hits_.data(), nullptr, count);
    else if (counted)
      trace_kernel<kQuery, Cell, true>
          <<<blocks, kTraceThreads>>>(grid, rays_.data(), hits_.data(), work_.data(), count);
    else
      trace_kernel<kQuery, Cell, false>
          <<<blocks, kTraceThreads>>>(grid, rays_.data(), hits_.data(), nullptr, count);
    IRGRID_CUDA_CHECK_LAUNCH("grid traversal kernel");
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
  CudaExecutor::Buffer<CompactCell> compact_cells_;
  mutable std::mutex mutex_;
  mutable cuda::DeviceBuffer<Ray> rays_;
  mutable cuda::DeviceBuffer<Hit> hits_;
  mutable cuda::DeviceBuffer<RayWork> work_;
};

}  // namespace

std::unique_ptr<Accelerator> make_grid_cuda(const Scene& scene, const BuildConfig& config,
                                            const PhaseObserver& on_phase) {
  return std::make_unique<GridCuda>(scene, config, on_phase);
}

HostGridArrays build_grid_cuda_arrays(const Scene& scene, const BuildConfig& config, int builds) {
  if (builds < 1)
    throw Error(ErrorCode::invalid_argument, "build_grid_cuda_arrays: builds must be >= 1");
  CudaExecutor exec;
  HostGridArrays out;
  for (int b = 0; b < builds; ++b) {
    const std::uint64_t fresh_before = exec.pool().fresh_allocations();
    GridArrays<CudaExecutor> grid;
    CudaExecutor::Buffer<CompactCell> compact;
    grid.triangles = upload_triangles(exec, scene);
    std::map<std::string, double> phases;
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
