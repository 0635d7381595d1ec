// The irregular grid (and the uniform and two-level grids) built and traversed on the CPU.
#include <algorithm>
#include <chrono>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/build/build_grid.h"
#include "core/grid/traverse.h"
#include "cpu/cpu_executor.h"
#include "cpu/structures.h"
#include "irgrid/error.h"

namespace irgrid {
namespace {

const char* shape_name(BuildConfig::Shape shape) {
  switch (shape) {
    case BuildConfig::Shape::irregular:
      return "irregular";
    case BuildConfig::Shape::two_level:
      return "two-level";
    case BuildConfig::Shape::uniform:
      return "uniform";
  }
  return "grid";
}

class GridCpu final : public Accelerator {
 public:
  GridCpu(const Scene& scene, const BuildConfig& config) : name_(shape_name(config.shape)) {
    const auto start = std::chrono::steady_clock::now();
    CpuExecutor exec;
    MemoryMeter::reset_peak();
    const std::int64_t before = MemoryMeter::current();
    gather_triangles(scene, grid_.triangles);
    if (!grid_.triangles.empty()) build_grid(exec, grid_, config, info_.phases_ms);
    info_.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    record_statistics();
    info_.counts["peak_build_bytes"] = std::uint64_t(MemoryMeter::peak() - before);
  }

  std::string structure() const override { return name_; }
  std::string backend() const override { return "cpu"; }
  const BuildInfo& build_info() const override { return info_; }

  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    if (grid_.triangles.empty()) {
      std::fill(hits.begin(), hits.end(), Hit{});
      return;
    }
    const GridView view = this->view();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 64), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        hits[i] = query == Query::closest ? traverse_grid<Query::closest>(view, rays[i])
                                          : traverse_grid<Query::any>(view, rays[i]);
    });
  }

  void trace_counted(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                     Query query) const override {
    check_trace_spans(rays, hits);
    if (work.size() != rays.size())
      throw Error(ErrorCode::invalid_argument, "trace_counted: one RayWork per ray expected");
    if (grid_.triangles.empty()) {
      std::fill(hits.begin(), hits.end(), Hit{});
      std::fill(work.begin(), work.end(), RayWork{});
      return;
    }
    const GridView view = this->view();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 64), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        TraversalCounters counters;
        hits[i] = query == Query::closest ? traverse_grid<Query::closest>(view, rays[i], &counters)
                                          : traverse_grid<Query::any>(view, rays[i], &counters);
        work[i] = {counters.cells, counters.triangles};
      }
    });
  }

  /// The grid's arrays, for tests and statistics.
  GridView view() const {
    return {grid_.info, grid_.entries.data(), grid_.cells.data(), grid_.refs.data(),
            grid_.triangles.data()};
  }

 private:
  void record_statistics() {
    const GridInfo& g = grid_.info;
    info_.counts = {{"cells", g.num_cells},
                    {"references", g.num_refs},
                    {"entries", g.num_entries},
                    {"top_x", std::uint64_t(g.top_dims[0])},
                    {"top_y", std::uint64_t(g.top_dims[1])},
                    {"top_z", std::uint64_t(g.top_dims[2])},
                    {"depth", std::uint64_t(g.shift)}};
    info_.bytes = {{"cells", std::uint64_t(g.num_cells) * sizeof(Cell)},
                   {"references", std::uint64_t(g.num_refs) * sizeof(std::uint32_t)},
                   {"voxel_map", std::uint64_t(g.num_entries) * sizeof(Entry)},
                   {"triangles", std::uint64_t(grid_.triangles.size()) * sizeof(TriangleVertices)}};
    info_.memory_bytes = 0;
    for (const auto& [name, bytes] : info_.bytes)
      info_.memory_bytes += bytes;
  }

  std::string name_;
  GridArrays<CpuExecutor> grid_;
  BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_grid_cpu(const Scene& scene, const BuildConfig& config) {
  return std::make_unique<GridCpu>(scene, config);
}

}  // namespace irgrid
