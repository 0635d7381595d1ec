// tests/grid_test_support.h: building a grid directly from a scene for the grid tests.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <string>

#include "core/build/build_grid.h"
#include "cpu/cpu_executor.h"
#include "cpu/structures.h"
#include "irgrid/scene.h"

namespace irgrid::testing {

/// The initial grid of the paper's §3.1: no merging, no expansion (tests of those phases start
/// from it; tests of the whole build pass BuildConfig{}).
inline BuildConfig initial_grid_config() {
  BuildConfig config;
  config.alpha = 0;
  config.expansion_passes = 0;
  return config;
}

inline GridArrays<CpuExecutor> build_test_grid(const Scene& scene,
                                               const BuildConfig& config = initial_grid_config()) {
  CpuExecutor exec;
  GridArrays<CpuExecutor> grid;
  gather_triangles(scene, grid.triangles);
  std::map<std::string, double> phases;
  build_grid(exec, grid, config, phases);
  return grid;
}

/// Expects two grids to be equal bit for bit: scalars, voxel map (and its level offsets), cells,
/// references and empty radii. The grids may come from different executors.
template <typename GridA, typename GridB>
void expect_same_grid(const GridA& a, const GridB& b) {
  ASSERT_EQ(std::memcmp(&a.info, &b.info, sizeof(GridInfo)), 0);
  EXPECT_EQ(a.level_offsets, b.level_offsets);
  ASSERT_EQ(a.entries.size(), b.entries.size());
  EXPECT_EQ(std::memcmp(a.entries.data(), b.entries.data(), a.entries.size() * sizeof(Entry)), 0);
  ASSERT_EQ(a.cells.size(), b.cells.size());
  EXPECT_EQ(std::memcmp(a.cells.data(), b.cells.data(), a.cells.size() * sizeof(Cell)), 0);
  EXPECT_TRUE(std::equal(a.refs.begin(), a.refs.end(), b.refs.begin(), b.refs.end()));
  EXPECT_TRUE(std::equal(a.empty_radii.begin(), a.empty_radii.end(), b.empty_radii.begin(),
                         b.empty_radii.end()));
}

inline std::uint64_t cell_volume(const Cell& c) {
  return std::uint64_t(c.hi[0] - c.lo[0]) * std::uint64_t(c.hi[1] - c.lo[1]) *
         std::uint64_t(c.hi[2] - c.lo[2]);
}

/// Every cell lies inside the virtual grid and their volumes add up to the grid's (with the voxel
/// map checks of the callers, this shows the cells tile the grid without overlap).
inline void expect_cells_tile_grid(const GridArrays<CpuExecutor>& grid) {
  const GridInfo& info = grid.info;
  ASSERT_EQ(grid.cells.size(), info.num_cells);
  std::uint64_t volume = 0;
  for (const Cell& c : grid.cells) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_LE(0, c.lo[a]);
      ASSERT_LT(c.lo[a], c.hi[a]);
      ASSERT_LE(c.hi[a], info.virtual_dims[a]);
    }
    volume += cell_volume(c);
  }
  EXPECT_EQ(volume,
            std::uint64_t(info.virtual_dims[0]) * info.virtual_dims[1] * info.virtual_dims[2]);
}

}  // namespace irgrid::testing
