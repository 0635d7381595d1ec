// cpu/simd_walk_avx512.cpp: the SIMD walk of cpu/simd_walk.h in the 16 lanes of AVX-512.
//
// Only the code below the pragma is compiled for avx512; it runs only where cpu_has() says the
// CPU has it. Every header the walk uses is included above the pragma, so that their inline
// functions stay baseline code (one copy of each is kept for the whole program).
// GCC 12's AVX-512 intrinsics leave registers undefined with `__m512i __Y = __Y;`, which
// -Wuninitialized and -Wmaybe-uninitialized flag at every use (the value is never read). The
// warnings point into the intrinsics' header, so they are silenced for its lines alone.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

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
#pragma GCC target("avx2,avx512f,avx512vl")

#include "cpu/simd_lanes_avx512.h"
#include "cpu/simd_walk_lanes.h"

namespace irgrid {

template <SimdIsa kIsa, Query kQuery, typename CellT>
void trace_simd_lanes(const GridView& grid, const RayFields& rays, const HitFields& hits,
                      std::span<RayWork> work, SimdRays lane_rays) {
  static_assert(kIsa == SimdIsa::avx512);
  simd::LaneWalk<simd::Avx512Lanes, kSimdWalkRaysInFlight / simd::Avx512Lanes::kLanes>::
      template trace<kQuery, CellT>(grid, rays, hits, work, lane_rays);
}

template void trace_simd_lanes<SimdIsa::avx512, Query::closest, Cell>(const GridView&,
                                                                      const RayFields&,
                                                                      const HitFields&,
                                                                      std::span<RayWork>, SimdRays);
template void trace_simd_lanes<SimdIsa::avx512, Query::any, Cell>(const GridView&, const RayFields&,
                                                                  const HitFields&,
                                                                  std::span<RayWork>, SimdRays);
template void trace_simd_lanes<SimdIsa::avx512, Query::closest, CompactCell>(
    const GridView&, const RayFields&, const HitFields&, std::span<RayWork>, SimdRays);
template void trace_simd_lanes<SimdIsa::avx512, Query::any, CompactCell>(
    const GridView&, const RayFields&, const HitFields&, std::span<RayWork>, SimdRays);

}  // namespace irgrid

#pragma GCC pop_options
