// tests/grid_test_support.h: building a grid directly from a scene for the grid tests.
#pragma once

#include <map>
#include <string>

#include "core/build/build_grid.h"
#include "cpu/cpu_executor.h"
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
  for (const auto& tri : scene.triangles)
    grid.triangles.push_back({Vec3<float>::from(scene.vertices[tri[0]]),
                              Vec3<float>::from(scene.vertices[tri[1]]),
                              Vec3<float>::from(scene.vertices[tri[2]])});
  std::map<std::string, double> phases;
  build_grid(exec, grid, config, phases);
  return grid;
}

}  // namespace irgrid::testing
