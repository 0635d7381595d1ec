// cpu/simd_walk.h: grid walks in the lanes of SIMD registers, one ray per lane: 8 lanes with
// AVX2, 16 with AVX-512.
//
// The walk of irgrid/kernel/grid_traverse.h spends most of its instructions on bookkeeping that is
// the same for every ray (the voxel-map descent, the exit distances, the step) and on triangle
// tests that a cell's few triangles cannot fill a SIMD register with. Running one ray per lane
// instead (as ISPC's "programs" or Embree's ray streams do) gives every step and every test a
// register of rays at once: the map and the triangles are read with gathers, the exit and step
// arithmetic and the watertight triangle test (Woop et al. 2013) are lane-wise, and the tests of
// all lanes' cells are packed into full batches. Only a test with an edge function of exactly zero
// (redone in double) or a NaN falls back to the scalar test. Every lane repeats the scalar walk's
// operations in the same order, so the hits and work counters are those of traverse_grid, bit
// for bit, whatever the instruction set. The walk is written once (cpu/simd_walk_lanes.h) over
// the lane operations of each instruction set (cpu/simd_lanes_avx2.h, cpu/simd_lanes_avx512.h).
#pragma once

#include <span>

#include "cpu/ray_fields.h"
#include "irgrid/accelerator.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {

/// The instruction sets the SIMD walk is compiled for.
enum class SimdIsa {
  avx2,    ///< 8 lanes per group
  avx512,  ///< 16 lanes per group (AVX-512F and VL)
};

/// Rays each thread keeps in flight: groups of lanes (4 of 16 with AVX-512, 8 of 8 with AVX2),
/// advanced phase by phase together so that the memory accesses of one group overlap the work
/// of the others. Four groups of 8 left AVX2's walk 2-25% slower on Crown, whose grid waits on
/// memory most (measured on the Intel Xeon VM).
inline constexpr int kSimdWalkRaysInFlight = 64;

/// Whether this CPU (and its operating system) runs `isa`. AVX-512 asks for VL besides F: GCC
/// 12 emits 256-bit EVEX forms (vextracti32x4 on ymm) in the 512-bit lanes' code, which CPUs
/// with F alone (Xeon Phi) would fault on.
bool cpu_has(SimdIsa isa);

/// Whether the grid's arrays fit the walk's 32-bit gather indices (9 floats per triangle: fewer
/// than 2^31 / 9 triangles; cells read in 8-byte units: fewer than 2^29 cells).
bool simd_walk_fits(const GridInfo& info);

/// How the SIMD walk gives rays to its lanes.
enum class SimdRays {
  /// A lane takes the next ray as soon as its walk ends: no lane idles (incoherent rays).
  independent,
  /// A group of lanes takes the next L rays together once all its walks have ended, and the
  /// lanes that share a cell test its triangles together, one triangle for all of them with its
  /// corners broadcast instead of gathered, where that takes fewer instructions: the packets of
  /// coherent grid traversal (Wald et al., "Ray Tracing Animated Scenes using Coherent Grid
  /// Traversal", SIGGRAPH 2006), kept per lane so that every ray still walks its own cells. For
  /// rays that start together and point the same way (camera rays, in image order).
  packets,
};

/// Traces ray i of `rays` into hit i of `hits` (and the work of each into work[i] when work is
/// not empty) with walks in the SIMD lanes of `kIsa`, given to the lanes as `lane_rays` says. The
/// same hits and work as traverse_grid<kQuery, CellT> per ray, bit for bit, either way. Requires
/// cpu_has(kIsa) and simd_walk_fits(grid.info).
template <SimdIsa kIsa, Query kQuery, typename CellT>
void trace_simd_lanes(const GridView& grid, const RayFields& rays, const HitFields& hits,
                      std::span<RayWork> work, SimdRays lane_rays);

}  // namespace irgrid
