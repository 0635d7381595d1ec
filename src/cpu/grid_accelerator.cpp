// The irregular grid (and the uniform and two-level grids) built and traversed on the CPU.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/build/compress_cells.h"
#include "core/grid/traverse.h"
#include "cpu/cpu_executor.h"
#include "cpu/structures.h"
#include "cpu/walk_policy.h"
#include "grid_accelerator_base.h"
#include "irgrid/error.h"

namespace irgrid {
namespace {

/// Prints the wall time of each executor primitive of a build to stderr, longest first: where
/// each of build_phases_ms goes, one level down (IRGRID_PRIMITIVE_PROFILE, README).
void print_primitive_profile(const CpuExecutor& exec) {
  std::vector<std::pair<double, std::string>> by_time;
  for (const auto& [name, ms] : exec.profile_ms())
    by_time.emplace_back(ms, name);
  std::sort(by_time.rbegin(), by_time.rend());
  for (const auto& [ms, name] : by_time)
    std::fprintf(stderr, "  primitive %-28s %9.2f ms\n", name.c_str(), ms);
}

class GridCpu final : public GridAcceleratorBase {
 public:
  GridCpu(const Scene& scene, const BuildConfig& config, const PhaseObserver& on_phase)
      : GridAcceleratorBase(config) {
    const auto start = std::chrono::steady_clock::now();
    CpuExecutor exec;
    MemoryMeter::reset_peak();
    const std::int64_t before = MemoryMeter::current();
    gather_triangles(scene, grid_.triangles);
    empty_scene_ = grid_.triangles.empty();
    if (!empty_scene_) {
      build_grid_and_compress(exec, grid_, compact_cells_, config, info_.phases_ms, on_phase);
      if (!compact_cells_.empty()) grid_.cells = {};
    }
    info_.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    record_grid_statistics(grid_.info, grid_.top_level_refs, !compact_cells_.empty(),
                           grid_.empty_radii.size(), info_);
    info_.counts["peak_build_bytes"] = std::uint64_t(MemoryMeter::peak() - before);
    if (std::getenv("IRGRID_PRIMITIVE_PROFILE")) print_primitive_profile(exec);
  }

  std::string backend() const override { return "cpu"; }

 private:
  GridView view() const { return grid_view(grid_, compact_cells_.data()); }

  void trace_grid(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                  Query query) const override {
    if (!compact_cells_.empty())
      trace_layout<CompactCell>(rays, hits, work, query);
    else
      trace_layout<Cell>(rays, hits, work, query);
  }

  template <typename CellT>
  void trace_layout(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                    Query query) const {
    if (query == Query::closest)
      trace_query<Query::closest, CellT>(rays, hits, work);
    else
      trace_query<Query::any, CellT>(rays, hits, work);
  }

  template <Query kQuery, typename CellT>
  void trace_query(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work) const {
    const GridView view = this->view();
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, rays.size(), 1024), [&](const auto& range) {
          const std::size_t first = range.begin(), count = range.size();
          trace_chunk<kQuery, CellT>(view, info_.memory_bytes, rays.subspan(first, count),
                                     hits.subspan(first, count),
                                     work.empty() ? work : work.subspan(first, count));
        });
  }

  GridArrays<CpuExecutor> grid_;
  CpuExecutor::Buffer<CompactCell> compact_cells_;
};

}  // namespace

std::unique_ptr<Accelerator> make_grid_cpu(const Scene& scene, const BuildConfig& config,
                                           const PhaseObserver& on_phase) {
  return std::make_unique<GridCpu>(scene, config, on_phase);
}

}  // namespace irgrid
