// irgrid-packet-stats: walks the camera rays of a scene's views one by one (traverse_grid's
// walk) and counts, per block of pixels, the cells and references its rays visit against the
// distinct cells of the block and their references: what a packet that visits each of its cells
// once would do (docs/benchmarks.md, camera rays as packets). Per ray it also counts the distinct
// triangles among its references: the tests a mailbox would leave.
#include <cstdio>
#include <exception>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"
#include "irgrid/kernel/grid_traverse.h"

namespace {

using namespace irgrid;

/// Per-block totals over an image.
struct BlockCounts {
  double blocks = 0, ray_cells = 0, ray_refs = 0, ray_triangles = 0, block_cells = 0,
         block_refs = 0;
};

/// Calls visit(cell index, cell) for each cell the walk of `ray` visits, in order.
template <typename Visit>
void walk_cells(const GridView& grid, const Ray& ray, Visit visit) {
  GridWalk w;
  if (!begin_walk(grid.info, ray, w)) return;
  while (true) {
    const std::uint32_t index = lookup_cell(grid.info, grid.entries, w.voxel);
    const Cell cell =
        grid.compact_cells ? load_cell(grid.compact_cells, index) : load_cell(grid.cells, index);
    visit(index, cell);
    CellExit exit = cell_exit(w, cell);
    leave_empty_space(grid, w, cell, exit);
    test_cell_triangles<Query::closest>(grid, cell.begin, cell.end, w, nullptr);
    if (!step_past_cell(grid.info, exit, w)) return;
  }
}

BlockCounts count_blocks(const GridView& grid, const std::vector<Ray>& rays, int width, int height,
                         int block_w, int block_h) {
  BlockCounts c;
  std::unordered_set<std::uint32_t> seen, triangles;
  for (int by = 0; by < height; by += block_h)
    for (int bx = 0; bx < width; bx += block_w) {
      seen.clear();
      ++c.blocks;
      for (int y = by; y < by + block_h && y < height; ++y)
        for (int x = bx; x < bx + block_w && x < width; ++x) {
          triangles.clear();
          walk_cells(grid, rays[std::size_t(y) * std::size_t(width) + std::size_t(x)],
                     [&](std::uint32_t index, const Cell& cell) {
                       const double refs = cell.end - cell.begin;
                       c.ray_cells += 1, c.ray_refs += refs;
                       for (std::uint32_t r = cell.begin; r < cell.end; ++r)
                         triangles.insert(grid.refs[r]);
                       if (seen.insert(index).second) c.block_cells += 1, c.block_refs += refs;
                     });
          c.ray_triangles += double(triangles.size());
        }
    }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Cells and references that the camera rays of each pixel block share"};
  std::string scene_spec, views_file;
  int width = 1024, height = 1024;
  std::vector<std::string> blocks{"16x1", "4x4", "8x8"};
  app.add_option("scene", scene_spec, "Scene file or builtin:NAME[:N]")->required();
  app.add_option("--views-file", views_file, "views.json to take the cameras from");
  app.add_option("--width", width, "Image width")->check(CLI::Range(1, 1 << 15));
  app.add_option("--height", height, "Image height")->check(CLI::Range(1, 1 << 15));
  app.add_option("--blocks", blocks, "Pixel blocks WxH, comma-separated")->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  try {
    std::vector<std::pair<int, int>> sizes;
    for (const std::string& b : blocks) {
      int w = 0, h = 0;
      char tail = 0;
      if (std::sscanf(b.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 1 || h < 1)
        throw irgrid::Error(irgrid::ErrorCode::invalid_argument,
                            fmt::format("--blocks: '{}' is not WxH with positive W and H", b));
      sizes.emplace_back(w, h);
    }
    const Scene scene = load_scene(scene_spec);
    const auto accelerator = make_accelerator(scene.mesh(), Structure::irregular);
    const GridView grid = accelerator->grid_view();
    const std::vector<Camera> views = scene_views(scene, views_file);
    fmt::print(
        "{}: {} x {} camera rays per view; per ray: cells and references visited, and the"
        " distinct triangles among them; per block: distinct cells, their references, and the"
        " references its rays visit in all\n",
        scene_spec, width, height);
    fmt::print("{:>4} {:>6} {:>10} {:>9} {:>14} {:>12} {:>11} {:>13}\n", "view", "block",
               "cells/ray", "refs/ray", "triangles/ray", "block cells", "block refs", "rays' refs");
    for (std::size_t v = 0; v < views.size(); ++v) {
      const std::vector<Ray> rays = primary_rays(views[v], width, height);
      for (const auto& [bw, bh] : sizes) {
        const BlockCounts c = count_blocks(grid, rays, width, height, bw, bh);
        const double n = double(rays.size());
        fmt::print("{:>4} {:>6} {:>10.2f} {:>9.2f} {:>14.2f} {:>12.1f} {:>11.1f} {:>13.1f}\n", v,
                   fmt::format("{}x{}", bw, bh), c.ray_cells / n, c.ray_refs / n,
                   c.ray_triangles / n, c.block_cells / c.blocks, c.block_refs / c.blocks,
                   c.ray_refs / c.blocks);
      }
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "irgrid-packet-stats: {}\n", e.what());
    return 1;
  }
}
