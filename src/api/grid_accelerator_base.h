// api/grid_accelerator_base.h: what the CPU and CUDA grid accelerators share.
#pragma once

#include <algorithm>
#include <span>

#include "core/construction/cells.h"
#include "core/construction/grid_statistics.h"
#include "cpu/structures.h"
#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {

/// The traversal's view of a built grid (its arrays in the executor's memory space); `compact`
/// is the compressed cell array, or null when the grid keeps full cells.
template <typename Exec>
GridView make_grid_view(const GridArrays<Exec>& grid, const CompactCell* compact) {
  return {grid.info,
          grid.entries.data(),
          compact ? nullptr : grid.cells.data(),
          compact,
          grid.refs.data(),
          grid.triangles.data(),
          grid.empty_radii.empty() ? nullptr : grid.empty_radii.data()};
}

/// The structure, the build figures, rebuilds and the checks of trace / trace_counted, for
/// grids on any backend; a backend implements build (over the mesh's triangles) and trace_grid
/// (for a grid with at least one triangle).
class GridAcceleratorBase : public Accelerator {
 public:
  Structure structure() const override { return structure_; }
  const BuildStats& build_stats() const override { return info_; }

  using Accelerator::trace;  // over RayArrays / HitArrays: converted, or walked in place
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

  void rebuild(const TriangleMesh& mesh) override {
    check_rebuild(mesh, triangle_count_);
    empty_scene_ = true;  // until the build succeeds: a failed rebuild leaves no half grid
    info_ = {};
    build(mesh);
    empty_scene_ = mesh.triangle_count == 0;
  }

 protected:
  explicit GridAcceleratorBase(const AcceleratorOptions& options)
      : options_(options),
        structure_(options.grid.shape == BuildConfig::Shape::irregular   ? Structure::irregular
                   : options.grid.shape == BuildConfig::Shape::two_level ? Structure::two_level
                                                                         : Structure::uniform) {}

  /// The first build: call from the derived constructor.
  void first_build(const TriangleMesh& mesh) {
    triangle_count_ = mesh.triangle_count;
    build(mesh);
    empty_scene_ = mesh.triangle_count == 0;
  }

  /// Builds the grid over `mesh` (already checked) into the backend's arrays, reusing them,
  /// and fills info_.
  virtual void build(const TriangleMesh& mesh) = 0;

  /// Traces rays[i] into hits[i], and counts work into work[i] unless work is empty. Called only
  /// with matching spans, at least one ray, and a grid over at least one triangle.
  virtual void trace_grid(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayWork> work,
                          Query query) const = 0;

  AcceleratorOptions options_;
  BuildStats info_;
  bool empty_scene_ = true;  ///< no triangles (or no grid yet): every ray misses

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

  Structure structure_;
  std::size_t triangle_count_ = 0;
};

}  // namespace irgrid
