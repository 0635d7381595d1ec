// grid_accelerator_base.h: what the CPU and CUDA grid accelerators share.
#pragma once

#include <algorithm>
#include <span>
#include <string>

#include "core/build/cells.h"
#include "core/build/grid_statistics.h"
#include "core/grid/traverse.h"
#include "cpu/structures.h"
#include "irgrid/accelerator.h"
#include "irgrid/error.h"

namespace irgrid {

/// The traversal's view of a built grid (its arrays in the executor's memory space); `compact`
/// is the compressed cell array, or null when the grid keeps full cells.
template <typename Exec>
GridView grid_view(const GridArrays<Exec>& grid, const CompactCell* compact) {
  return {grid.info,
          grid.entries.data(),
          grid.cells.data(),
          compact,
          grid.refs.data(),
          grid.triangles.data(),
          grid.empty_radii.empty() ? nullptr : grid.empty_radii.data()};
}

/// The name, the build figures and the checks of trace / trace_counted, for grids on any
/// backend; a backend implements trace_grid for a grid with at least one triangle.
class GridAcceleratorBase : public Accelerator {
 public:
  std::string structure() const override { return name_; }
  const BuildInfo& build_info() const override { return info_; }

  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    trace_checked(rays, hits, {}, query);
  }

  bool counts_work() const override { return true; }

  void trace_counted(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                     Query query) const override {
    check_trace_spans(rays, hits);
    if (work.size() != rays.size())
      throw Error(ErrorCode::invalid_argument, "trace_counted: one RayWork per ray expected");
    trace_checked(rays, hits, work, query);
  }

 protected:
  explicit GridAcceleratorBase(const BuildConfig& config) : name_(grid_shape_name(config.shape)) {}

  /// Traces rays[i] into hits[i], and counts work into work[i] unless work is empty. Called only
  /// with matching spans, at least one ray, and a grid over at least one triangle.
  virtual void trace_grid(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                          Query query) const = 0;

  BuildInfo info_;
  bool empty_scene_ = false;  ///< no triangles: every ray misses

 private:
  void trace_checked(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                     Query query) const {
    if (rays.empty()) return;
    if (empty_scene_) {
      std::fill(hits.begin(), hits.end(), Hit{});
      std::fill(work.begin(), work.end(), RayWork{});
      return;
    }
    trace_grid(rays, hits, work, query);
  }

  std::string name_;
};

}  // namespace irgrid
