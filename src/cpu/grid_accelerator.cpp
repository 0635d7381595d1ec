// The irregular grid (and the uniform and two-level grids) built and traversed on the CPU.
#include <algorithm>
#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>

#include "api/grid_accelerator_base.h"
#include "core/construction/compress_cells.h"
#include "core/release_buffer.h"
#include "cpu/cpu_executor.h"
#include "cpu/parallel.h"
#include "cpu/ray_fields.h"
#include "cpu/structures.h"
#include "cpu/walk_policy.h"
#include "irgrid/error.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {
namespace {

/// The wall time of each executor primitive of a build, longest first: where each phase's
/// time goes, one level down.
std::vector<PrimitiveTime> primitives_by_time(const CpuExecutor& exec) {
  std::vector<PrimitiveTime> out;
  for (const auto& [name, ms] : exec.profile_ms())
    out.push_back({name, ms});
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.ms > b.ms; });
  return out;
}

class GridCpu final : public GridAcceleratorBase {
 public:
  GridCpu(const TriangleMesh& mesh, const AcceleratorOptions& options)
      : GridAcceleratorBase(options) {
    // The first build caches no more than it holds at its peak: the process's memory is then
    // about the build's own. Rebuilds cache every size, so that later frames allocate nothing.
    pool_.set_bound_to_peak(true);
    first_build(mesh);
    pool_.set_bound_to_peak(false);
    // After a one-off build the cached blocks would hold the build's peak for the grid's life;
    // rebuilds keep them, so that later frames take every block from the cache.
    pool_.trim();
  }

  Backend backend() const override { return Backend::cpu; }
  using GridAcceleratorBase::trace;  // over Ray / Hit records

  GridView grid_view() const override { return view(); }

 private:
  void build(const TriangleMesh& mesh) override {
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t fresh_before = pool_.fresh_allocations();
    CpuExecutor exec(&pool_);
    // The arrays of the last grid go first (back to the pool), so a rebuild's peak is one
    // grid's, not two, and the new grid takes the same blocks.
    grid_ = {};
    release_buffer(compact_cells_);
    MemoryMeter::reset_peak();
    const std::int64_t before = MemoryMeter::current();
    grid_.triangles = exec.allocate<TriangleVertices>(0);
    gather_triangles(mesh, grid_.triangles);
    std::uint64_t peak_outside = std::uint64_t(MemoryMeter::peak());
    PhaseBytes phase_peaks{};
    if (!grid_.triangles.empty()) {
      build_grid_and_compress(exec, grid_, compact_cells_, options_.grid, info_.phase_ms,
                              options_.on_phase, &phase_peaks);
    }
    if (options_.grid.huge_pages) move_onto_huge_pages();
    info_.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
    peak_outside = std::max<std::uint64_t>(peak_outside, MemoryMeter::peak());
    const std::uint64_t peak = peaks_beyond(phase_peaks, peak_outside, std::uint64_t(before));
    record_grid_statistics(grid_, !compact_cells_.empty(), options_.grid, peak, info_, phase_peaks);
    info_.grid->fresh_allocations = pool_.fresh_allocations() - fresh_before;
    if (options_.profile_primitives) info_.primitives = primitives_by_time(exec);
  }

  /// The grid's arrays, built on 4 KiB pages (HostPool), onto huge pages: rays read them at
  /// random, and Crown's and Sponza's random rays were 6-10% slower on 4 KiB pages (Intel Xeon VM).
  /// BuildConfig::huge_pages turns it off.
  void move_onto_huge_pages() {
    const auto collapse = [this](auto& buffer) {
      pool_.move_onto_huge_pages(buffer.data(), buffer.capacity() * sizeof(buffer[0]));
    };
    collapse(grid_.triangles);
    collapse(grid_.entries);
    collapse(grid_.cells);
    collapse(grid_.refs);
    collapse(grid_.empty_radii);
    collapse(compact_cells_);
  }

  GridView view() const {
    return make_grid_view(grid_, compact_cells_.empty() ? nullptr : compact_cells_.data());
  }

  void trace_grid(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                  Query query) const override {
    trace_fields(ray_fields(rays), hit_fields(hits), work, query);
  }

  /// The rays walk the caller's arrays in place: no records are made and copied.
  void trace(const RayArrays& rays, const HitArrays& hits, Query query) const override {
    check_ray_arrays(rays);
    if (rays.count == 0) return;
    const HitFields out = hit_fields(hits, grid_.triangles.data());
    if (empty_scene_) {
      for (std::size_t i = 0; i < rays.count; ++i)
        out.write(i, kNoHit, 0, 0, 0);
      return;
    }
    trace_fields(ray_fields(rays), out, {}, query);
  }

  std::span<const TriangleVertices> host_triangles() const override {
    return {grid_.triangles.data(), grid_.triangles.size()};
  }

  void trace_fields(const RayFields& rays, const HitFields& hits, std::span<RayWork> work,
                    Query query) const {
    const bool compact = !compact_cells_.empty();
    if (query == Query::closest)
      compact ? trace_query<Query::closest, CompactCell>(rays, hits, work)
              : trace_query<Query::closest, Cell>(rays, hits, work);
    else
      compact ? trace_query<Query::any, CompactCell>(rays, hits, work)
              : trace_query<Query::any, Cell>(rays, hits, work);
  }

  template <Query kQuery, typename CellT>
  void trace_query(const RayFields& rays, const HitFields& hits, std::span<RayWork> work) const {
    const GridView view = this->view();
    irgrid::parallel_for(
        tbb::blocked_range<std::size_t>(0, rays.size(), 1024), [&](const auto& range) {
          const std::size_t first = range.begin(), count = range.size();
          trace_chunk<kQuery, CellT>(view, info_.memory_bytes, options_.cpu_walk,
                                     rays.subrange(first, count), hits.subrange(first),
                                     work.empty() ? work : work.subspan(first, count));
        });
  }

  HostPool pool_;  // first: it must outlive every buffer below
  GridArrays<CpuExecutor> grid_;
  CpuExecutor::Buffer<CompactCell> compact_cells_;
};

}  // namespace

std::unique_ptr<Accelerator> make_grid_cpu(const TriangleMesh& mesh,
                                           const AcceleratorOptions& options) {
  return std::make_unique<GridCpu>(mesh, options);
}

}  // namespace irgrid
