// cpu/simd_walk_avx2.cpp: the SIMD walk of cpu/simd_walk.h in the 8 lanes of AVX2.
//
// Only the code below the pragma is compiled for avx2; it runs only where cpu_has() says the
// CPU has it. Every header the walk uses is included above the pragma, so that their inline
// functions stay baseline code (one copy of each is kept for the whole program).
#include <immintrin.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "cpu/ray_fields.h"
#include "cpu/simd_walk.h"
#include "cpu/staged_hits.h"
#include "irgrid/accelerator.h"
#include "irgrid/kernel/grid_traverse.h"

#pragma GCC push_options
#pragma GCC target("avx2")
// irgrid/kernel/watertight.h's t_needs_double is baseline code (included above) that the walk
// instantiates with AVX2 vectors and always inlines; GCC still warns, where the template is
// instantiated at the end of this file, that an out-of-line copy would return its lane mask (a
// vector here, a mask register with AVX-512) differently.
#pragma GCC diagnostic ignored "-Wpsabi"

#include "cpu/simd_lanes_avx2.h"
#include "cpu/simd_walk_lanes.h"

namespace irgrid {

template <SimdIsa kIsa, Query kQuery, typename CellT>
void trace_simd_lanes(const GridView& grid, const RayFields& rays, const HitFields& hits,
                      std::span<RayWork> work, SimdRays lane_rays) {
  static_assert(kIsa == SimdIsa::avx2);
  simd::LaneWalk<simd::Avx2Lanes, kSimdWalkRaysInFlight / simd::Avx2Lanes::kLanes>::template trace<
      kQuery, CellT>(grid, rays, hits, work, lane_rays);
}

template void trace_simd_lanes<SimdIsa::avx2, Query::closest, Cell>(const GridView&,
                                                                    const RayFields&,
                                                                    const HitFields&,
                                                                    std::span<RayWork>, SimdRays);
template void trace_simd_lanes<SimdIsa::avx2, Query::any, Cell>(const GridView&, const RayFields&,
                                                                const HitFields&,
                                                                std::span<RayWork>, SimdRays);
template void trace_simd_lanes<SimdIsa::avx2, Query::closest, CompactCell>(
    const GridView&, const RayFields&, const HitFields&, std::span<RayWork>, SimdRays);
template void trace_simd_lanes<SimdIsa::avx2, Query::any, CompactCell>(
    const GridView&, const RayFields&, const HitFields&, std::span<RayWork>, SimdRays);

}  // namespace irgrid

#pragma GCC pop_options
