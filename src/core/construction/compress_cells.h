// core/construction/compress_cells.h: the whole build with the paper's 16-byte cells (§4).
//
// The cells are compressed before they expand (build_grid), so that the expansion, whose most
// frequent load is a neighbour's cell, reads 16 bytes per neighbour, and the 32-byte cells are
// gone for the rest of the build. compact_cells.h writes them.
#pragma once

#include "core/construction/build_grid.h"
#include "core/construction/compact_cells.h"

namespace irgrid {

/// The whole build (build_grid) with its cells compressed when config.compress is on and the
/// grid fits them: then `compact` holds the cells and grid.cells is empty; otherwise `compact`
/// is left empty and grid.cells holds them.
template <typename Exec>
void build_grid_and_compress(Exec& exec, GridArrays<Exec>& grid,
                             typename Exec::template Buffer<CompactCell>& compact,
                             const BuildConfig& config, PhaseTimes& phases_ms,
                             const PhaseObserver& on_phase = {},
                             PhaseBytes* phase_peaks = nullptr) {
  build_grid(exec, grid, config, phases_ms, on_phase, phase_peaks,
             config.compress ? &compact : nullptr);
}

}  // namespace irgrid
