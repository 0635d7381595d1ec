// tests/grid_test_support.h: building a grid directly from a scene for the grid tests.
#pragma once

#include <map>
#include <string>

#include "core/build/build_grid.h"
#include "cpu/cpu_executor.h"
#include "irgrid/scene.h"

namespace irgrid::testing {

inline GridArrays<CpuExecutor> build_test_grid(const Scene& scene, const BuildConfig& config = {}) {
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
