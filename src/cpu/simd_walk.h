// cpu/simd_walk.h: eight grid walks in the lanes of AVX2 registers, one ray per lane.
//
// The walk of core/grid/traverse.h spends most of its instructions on bookkeeping that is the
// same for every ray (the voxel-map descent, the exit distances, the step) and on triangle tests
// that a cell's few triangles cannot fill a SIMD register with. Running one ray per lane instead
// (as ISPC's "programs" or Embree's ray streams do) gives every step and every test eight rays
// at once: the map and the triangles are read with gathers, the exit and step arithmetic and
// the watertight triangle test (Woop et al. 2013) are lane-wise, and the tests of all lanes'
// cells are packed into full batches. Only a test with an edge function of exactly zero (redone
// in double) or a NaN falls back to the scalar test. Every lane repeats the scalar walk's
// operations in the same order, so the hits and work counters are those of traverse_grid, bit
// for bit.
#pragma once

#include <span>

#include "core/grid/traverse.h"
#include "irgrid/accelerator.h"

namespace irgrid {

/// Walks per group of the SIMD walk: the 32-bit lanes of an AVX2 register.
inline constexpr int kSimdWalkLanes = 8;
/// Sets of kSimdWalkLanes walks per thread, advanced phase by phase together so that the
/// memory accesses of one set overlap the work of the others.
inline constexpr int kSimdWalkGroups = 4;

/// Whether this CPU has AVX2 and the grid's arrays fit the walk's 32-bit gather indices (9
/// floats per triangle: fewer than 2^31 / 9 triangles; cells read in 8-byte units: fewer than
/// 2^29 cells).
bool simd_walk_supported(const GridInfo& info);

/// Traces rays[i] into hits[i] (and the work of each into work[i] when work is not empty) with
/// kSimdWalkLanes walks in SIMD lanes. The same hits and work as traverse_grid<kQuery, CellT>
/// per ray, bit for bit. Requires simd_walk_supported(grid.info).
template <Query kQuery, typename CellT>
void trace_simd_lanes(const GridView& grid, std::span<const Ray> rays, std::span<Hit> hits,
                      std::span<RayWork> work);

}  // namespace irgrid
