// core/construction/grid_statistics.h: what a grid build reports, the same for every backend.
#pragma once

#include <cstdint>

#include "irgrid/accelerator.h"
#include "irgrid/build_config.h"
#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {

/// Turns the executor's memory peak of each phase (PhaseClock) into bytes beyond `before`, the
/// tally the build started from, and returns the build's peak beyond it: the largest of them
/// and of `peak_outside`, the executor's peak outside the phases.
inline std::uint64_t peaks_beyond(PhaseBytes& phase_peaks, std::uint64_t peak_outside,
                                  std::uint64_t before) {
  std::uint64_t most = peak_outside;
  for (auto& peak : phase_peaks) {
    if (!peak) continue;
    most = *peak > most ? *peak : most;
    *peak = *peak > before ? *peak - before : 0;
  }
  return most > before ? most - before : 0;
}

/// Fills the grid statistics and total bytes of `out` from a built grid's arrays (`compressed`:
/// with 16-byte cells) and the build's transient memory: peak_build_bytes, and phase_peaks per
/// phase (peaks_beyond).
template <typename Arrays>
void record_grid_statistics(const Arrays& grid, bool compressed, const BuildConfig& config,
                            std::uint64_t peak_build_bytes, BuildStats& out,
                            const PhaseBytes& phase_peaks = {}) {
  const GridInfo& g = grid.info;
  const std::uint32_t top_level_refs = grid.top_level_refs;
  GridStats s;
  s.budget_bytes = grid.budget_bytes;
  s.budget_limited = grid.budget_limited;
  s.top_level_references = top_level_refs;
  s.cells = g.num_cells;
  s.references = g.num_refs;
  s.voxel_map_entries = g.num_entries;
  for (int a = 0; a < 3; ++a)
    s.top_dims[a] = std::uint32_t(g.top_dims[a]);
  s.depth = std::uint32_t(g.shift);
  s.compressed_cells = compressed;
  s.lambda2_used = config.shape == BuildConfig::Shape::irregular
                       ? effective_lambda2(config, top_level_refs)
                       : double(config.lambda2);
  s.cells_bytes = compressed ? (std::uint64_t(g.num_cells) + 1) * sizeof(CompactCell)
                             : std::uint64_t(g.num_cells) * sizeof(Cell);
  s.references_bytes = std::uint64_t(g.num_refs) * sizeof(std::uint32_t);
  s.voxel_map_bytes = std::uint64_t(g.num_entries) * sizeof(Entry);
  s.triangles_bytes = std::uint64_t(g.num_triangles) * sizeof(TriangleVertices);
  s.empty_radii_bytes = grid.empty_radii.size();
  s.peak_build_bytes = peak_build_bytes;
  s.phase_peak_bytes = phase_peaks;
  out.memory_bytes = s.cells_bytes + s.references_bytes + s.voxel_map_bytes + s.triangles_bytes +
                     s.empty_radii_bytes;
  out.grid = s;
}

}  // namespace irgrid
