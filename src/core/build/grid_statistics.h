// core/build/grid_statistics.h: what a grid build reports, the same for every backend.
#pragma once

#include <cstdint>

#include "core/grid/layout.h"
#include "core/triangle.h"
#include "irgrid/accelerator.h"
#include "irgrid/build_config.h"

namespace irgrid {

/// The structure name of a grid shape, as --structure spells it.
inline const char* grid_shape_name(BuildConfig::Shape shape) {
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

/// Fills the counts, bytes per array and total bytes of `out` from a built grid's scalars;
/// empty_radii_bytes is the size of its empty radii (0 without them).
inline void record_grid_statistics(const GridInfo& g, std::uint32_t top_level_refs, bool compressed,
                                   std::uint64_t empty_radii_bytes, BuildInfo& out) {
  out.counts["top_level_references"] = top_level_refs;
  out.counts["cells"] = g.num_cells;
  out.counts["references"] = g.num_refs;
  out.counts["entries"] = g.num_entries;
  out.counts["top_x"] = std::uint64_t(g.top_dims[0]);
  out.counts["top_y"] = std::uint64_t(g.top_dims[1]);
  out.counts["top_z"] = std::uint64_t(g.top_dims[2]);
  out.counts["depth"] = std::uint64_t(g.shift);
  out.counts["compressed_cells"] = compressed ? 1 : 0;
  out.bytes = {{"cells", compressed ? (std::uint64_t(g.num_cells) + 1) * sizeof(CompactCell)
                                    : std::uint64_t(g.num_cells) * sizeof(Cell)},
               {"references", std::uint64_t(g.num_refs) * sizeof(std::uint32_t)},
               {"voxel_map", std::uint64_t(g.num_entries) * sizeof(Entry)},
               {"triangles", std::uint64_t(g.num_triangles) * sizeof(TriangleVertices)}};
  if (empty_radii_bytes > 0) out.bytes["empty_radii"] = empty_radii_bytes;
  out.memory_bytes = 0;
  for (const auto& [name, bytes] : out.bytes)
    out.memory_bytes += bytes;
}

}  // namespace irgrid
