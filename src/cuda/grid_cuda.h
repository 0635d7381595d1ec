// cuda/grid_cuda.h: host-side access to the CUDA grid build, for tests that compare backends.
#pragma once

#include <cstdint>
#include <vector>

#include "irgrid/build_config.h"
#include "irgrid/kernel/grid_layout.h"
#include "irgrid/mesh.h"

namespace irgrid {

/// A grid's arrays copied back from the device.
struct HostGridArrays {
  GridInfo info{};
  std::vector<Entry> entries;
  std::vector<Cell> cells;                 ///< the full cells; empty when compact_cells hold them
  std::vector<CompactCell> compact_cells;  ///< empty unless config.compress and they fit
  std::vector<std::uint32_t> refs;
  std::vector<std::uint8_t> empty_radii;  ///< empty unless the grid skips empty space
  /// Device allocations that reached the driver during the last of the builds (0 when the
  /// arena served them all).
  std::uint64_t fresh_allocations_last_build = 0;
};

/// Builds the grid of `mesh` `builds` times (>= 1) on the GPU with one executor, dropping each
/// result before the next, and returns the arrays of the last build. Throws Error(no_device)
/// without a GPU.
HostGridArrays build_grid_cuda_arrays(const TriangleMesh& mesh, const BuildConfig& config,
                                      int builds);

}  // namespace irgrid
