// irgrid/kernel/grid_layout.h: the irregular grid's plain data, shared verbatim by host and device
// code.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017, §3:
// cells of varying size tile a virtual grid of (top_dims << shift) voxels per axis; a voxel map
// answers "which cell owns this voxel" and each cell lists the triangles that overlap it.
#pragma once

#include <cstdint>

#include "irgrid/kernel/platform.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {

/// Largest virtual-grid resolution per axis: voxel coordinates, their sums and the exit-box
/// coordinates stay far from int32 overflow, and compressed cells fit 16 bits when below 2^16.
inline constexpr std::int32_t kMaxVirtualResolution = 1 << 24;
/// Largest virtual-grid resolution per axis at which compressed cells' 16-bit bounds still fit.
inline constexpr std::int32_t kMaxCompactResolution = 0xffff;
/// Largest number of cells, references and voxel-map entries (30 bits of an entry address them).
inline constexpr std::uint32_t kMaxEntryTarget = (1u << 30) - 1;

/// Scalars of a grid. 96 bytes.
struct GridInfo {
  Vec3<float> box_lo;            ///< 12 B world-space corner of voxel (0,0,0)
  Vec3<float> box_hi;            ///< 12 B opposite corner
  Vec3<float> voxel_size;        ///< 12 B world size of one virtual voxel per axis
  Vec3<float> inv_voxel_size;    ///< 12 B its reciprocal (0 on a flat axis)
  std::int32_t top_dims[3];      ///< 12 B top-level resolution R per axis
  std::int32_t shift;            ///<  4 B octree depth D: the virtual resolution is R << D
  std::int32_t virtual_dims[3];  ///< 12 B R << D per axis
  std::uint32_t num_cells;       ///<  4 B
  std::uint32_t num_refs;        ///<  4 B
  std::uint32_t num_entries;     ///<  4 B voxel-map entries, top level included
  std::uint32_t num_triangles;   ///<  4 B
  float padding;                 ///<  4 B world distance by which the insertion test grows cells
};
static_assert(sizeof(GridInfo) == 96 && alignof(GridInfo) == 4);

/// A cell: its exit box in voxels (the entry box, owned in the voxel map, may be smaller after
/// expansion) and its half-open range in the reference array. 32 bytes.
struct Cell {
  std::int32_t lo[3];   ///< 12 B exit box, inclusive lower voxel
  std::uint32_t begin;  ///<  4 B first reference
  std::int32_t hi[3];   ///< 12 B exit box, exclusive upper voxel
  std::uint32_t end;    ///<  4 B one past the last reference
};
static_assert(sizeof(Cell) == 32 && alignof(Cell) == 4);

/// A compressed cell (the paper's 16-byte cells, §4): the exit box in 16-bit voxel coordinates
/// and the first reference. The last reference is found as the next cell's begin, so the array
/// holds one sentinel cell past the last (its begin is the number of references). 16 bytes.
struct CompactCell {
  std::uint16_t lo[3];  ///< 6 B exit box, inclusive lower voxel
  std::uint16_t hi[3];  ///< 6 B exit box, exclusive upper voxel
  std::uint32_t begin;  ///< 4 B first reference; the end is cells[i + 1].begin
};
static_assert(sizeof(CompactCell) == 16 && alignof(CompactCell) == 4);

/// Bytes of slack after the radii, so that lane-wise 4-byte reads of the last radius stay in the
/// buffer.
inline constexpr std::uint32_t kEmptyRadiiSlack = 3;

/// The octant of a walk's direction: bit a set where the walk descends along axis a. The empty
/// radii (core/build/empty_space.h) are stored per top cell and octant, at top cell x 8 + octant.
IRGRID_HD inline std::uint32_t walk_octant(const bool ascending[3]) {
  return (ascending[0] ? 0u : 1u) | (ascending[1] ? 0u : 2u) | (ascending[2] ? 0u : 4u);
}

/// Whether the grid's voxel coordinates fit compressed cells (every exit-box bound < 2^16).
IRGRID_HD inline bool fits_compact_cells(const GridInfo& info) {
  return info.virtual_dims[0] <= kMaxCompactResolution &&
         info.virtual_dims[1] <= kMaxCompactResolution &&
         info.virtual_dims[2] <= kMaxCompactResolution;
}

/// Cell i in the full layout, from either array.
IRGRID_HD inline Cell load_cell(const Cell* cells, std::uint32_t i) {
  return cells[i];
}
IRGRID_HD inline Cell load_cell(const CompactCell* cells, std::uint32_t i) {
  const CompactCell c = cells[i];
  return {{c.lo[0], c.lo[1], c.lo[2]}, c.begin, {c.hi[0], c.hi[1], c.hi[2]}, cells[i + 1].begin};
}

/// A voxel-map entry, 4 bytes: log_dim in the top 2 bits, a 30-bit index below. log_dim 0: a
/// leaf, the index is a cell. log_dim k in 1..3: an inner node whose children form a dense
/// (2^k)^3 block (x fastest) starting at the index.
struct Entry {
  std::uint32_t bits;  ///< 4 B
  IRGRID_HD static constexpr Entry leaf(std::uint32_t cell) { return {cell}; }
  IRGRID_HD static constexpr Entry inner(std::uint32_t log_dim, std::uint32_t first_child) {
    return {log_dim << 30 | first_child};
  }
  IRGRID_HD constexpr std::uint32_t log_dim() const { return bits >> 30; }
  IRGRID_HD constexpr std::uint32_t index() const { return bits & kMaxEntryTarget; }
};
static_assert(sizeof(Entry) == 4);

/// Integer voxel coordinates.
struct Voxel {
  std::int32_t x, y, z;
  IRGRID_HD constexpr std::int32_t operator[](int a) const { return a == 0 ? x : (a == 1 ? y : z); }
  IRGRID_HD constexpr std::int32_t& operator[](int a) { return a == 0 ? x : (a == 1 ? y : z); }
};

/// World coordinate of the voxel boundary `v` on axis `a`, as the build places planes (the
/// traversal works in voxel units; the insertion padding absorbs the difference in rounding).
IRGRID_HD inline float voxel_to_world(const GridInfo& info, int a, std::int32_t v) {
  return info.box_lo[a] + float(v) * info.voxel_size[a];
}

/// Index of the top-level voxel-map entry holding voxel `v`.
IRGRID_HD inline std::uint32_t top_entry_index(const GridInfo& info, Voxel v) {
  const Voxel top{v.x >> info.shift, v.y >> info.shift, v.z >> info.shift};
  return (std::uint32_t(top.z) * std::uint32_t(info.top_dims[1]) + std::uint32_t(top.y)) *
             std::uint32_t(info.top_dims[0]) +
         std::uint32_t(top.x);
}

/// Index of the child of inner entry `entry` that holds voxel `v`. `level_shift` is the shift
/// of the entry's level (info.shift at the top); it becomes the child's.
IRGRID_HD inline std::uint32_t child_entry_index(Entry entry, Voxel v, std::int32_t& level_shift) {
  const std::uint32_t k = entry.log_dim(), mask = (1u << k) - 1;
  level_shift -= std::int32_t(k);
  const std::uint32_t cx = std::uint32_t(v.x >> level_shift) & mask;
  const std::uint32_t cy = std::uint32_t(v.y >> level_shift) & mask;
  const std::uint32_t cz = std::uint32_t(v.z >> level_shift) & mask;
  return entry.index() + ((cz << k | cy) << k | cx);
}

/// The cell owning voxel `v`: one dependent 4-byte read per map level.
IRGRID_HD inline std::uint32_t lookup_cell(const GridInfo& info, const Entry* entries, Voxel v) {
  Entry entry = entries[top_entry_index(info, v)];
  std::int32_t level_shift = info.shift;
  while (entry.log_dim() != 0)
    entry = entries[child_entry_index(entry, v, level_shift)];
  return entry.index();
}

/// lookup_cell for voxels[0, count) (count <= kMax), into owners: the walks advance one map level
/// at a time, all of them in turn, so that their dependent loads are in flight together.
template <std::uint32_t kMax>
IRGRID_HD inline void lookup_cells(const GridInfo& info, const Entry* entries, const Voxel* voxels,
                                   std::uint32_t count, std::uint32_t* owners) {
  // Zeroed so that GCC, which cannot see count <= kMax, does not warn of uninitialised reads.
  Entry entry[kMax] = {};
  std::int32_t level_shift[kMax] = {};
  for (std::uint32_t k = 0; k < count; ++k) {
    entry[k] = entries[top_entry_index(info, voxels[k])];
    level_shift[k] = info.shift;
  }
  for (bool descending = true; descending;) {
    descending = false;
    for (std::uint32_t k = 0; k < count; ++k)
      if (entry[k].log_dim() != 0) {
        entry[k] = entries[child_entry_index(entry[k], voxels[k], level_shift[k])];
        descending = true;
      }
  }
  for (std::uint32_t k = 0; k < count; ++k)
    owners[k] = entry[k].index();
}

}  // namespace irgrid
