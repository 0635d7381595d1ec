// cpu/walk_policy.h: how the CPU backend walks a chunk of rays: in SIMD lanes, one at a time,
// or interleaved.
//
// Where the CPU has AVX2, every chunk walks in SIMD lanes (cpu/simd_walk.h), 16 of them where it
// has AVX-512: on the 2-core Intel Xeon VM the 8-lane walk beat the other two ways on every ray
// kind of Sponza and Conference, and 16 lanes ran 1.2-1.8x as fast as 8 on Sponza, Conference
// and Crown (Sponza's ao and diffuse rays: 1.0-1.1x). The lanes walk packets where the chunk's
// rays are coherent and the grid is cache-sized (SimdRays::packets: on the same VM Sponza's and
// Conference's camera rays ran 8-33% faster at 1024 x 1024), and independently otherwise:
// packets made random rays about a third slower (their lanes idle until the group's last walk
// ends), and on Crown's 298 MiB grid, whose walks wait on memory, camera rays gained nothing at
// 1024 x 1024 and lost about 5% at 512 x 512. Without AVX2 the choice is between the other two
// ways.
// Interleaving (cpu/interleaved_walk.h) overlaps the cache misses of different rays, at the
// price of bookkeeping: about 14% more time with a single lane on Sponza's primary rays. It pays
// where the rays miss the caches: incoherent rays, and any rays on a grid far larger than the
// caches. Coherent rays on a smaller grid read the cells their neighbours just read, so they
// walk one at a time. Measured on the same VM: interleaving
// gave Sponza's random rays +18-30% and Crown's rays of every kind +8-35%, and cost Sponza's
// primary rays 11-28%.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <span>

#include "cpu/interleaved_walk.h"
#include "cpu/ray_fields.h"
#include "cpu/simd_walk.h"
#include "irgrid/accelerator.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {

/// Grids up to this size walk coherent rays one at a time, or as SIMD packets (above it, the caches
/// hold too little of the grid for neighbouring rays to help each other). Sponza (26 MiB) and
/// Conference (19 MiB) lie below, Crown (298 MiB) above.
inline constexpr std::size_t kCoherentWalkMaxGridBytes = std::size_t(64) << 20;

/// Whether most consecutive rays of `rays` start within a voxel of each other and point the
/// same way to within about 0.8 degrees, as camera rays do. Looks at up to 64 pairs spread over
/// the chunk.
inline bool rays_are_coherent(const GridInfo& info, const RayFields& rays) {
  constexpr float kCosine = 0.9999f;
  constexpr std::size_t kSamples = 64;
  if (rays.size() < 2) return false;
  const std::size_t pairs = rays.size() - 1;
  const std::size_t stride = pairs > kSamples ? pairs / kSamples : 1;
  std::size_t sampled = 0, coherent = 0;
  for (std::size_t i = 1; i < rays.size(); i += stride, ++sampled) {
    const Ray a = rays[i - 1];
    const Ray b = rays[i];
    float dot = 0, aa = 0, bb = 0;
    bool close = true;
    for (int k = 0; k < 3; ++k) {
      dot += a.dir[k] * b.dir[k], aa += a.dir[k] * a.dir[k], bb += b.dir[k] * b.dir[k];
      close &= std::fabs(a.org[k] - b.org[k]) <= info.voxel_size[k];
    }
    coherent += close && dot > 0 && dot * dot >= kCosine * kCosine * aa * bb;
  }
  return 4 * coherent >= 3 * sampled;
}

/// Whether a chunk walks as coherent rays: `rays` are (rays_are_coherent) and the grid's arrays,
/// `grid_bytes`, take at most kCoherentWalkMaxGridBytes.
inline bool walks_as_coherent(const GridInfo& info, std::size_t grid_bytes, const RayFields& rays) {
  return grid_bytes <= kCoherentWalkMaxGridBytes && rays_are_coherent(info, rays);
}

/// The instruction set `walk` (AcceleratorOptions::cpu_walk) runs its SIMD lanes in on this CPU,
/// for grids that fit the SIMD walk; none where it walks one ray at a time or interleaved, or
/// where the CPU lacks the instruction set.
inline std::optional<SimdIsa> simd_isa_of(CpuWalk walk) {
  if (walk == CpuWalk::single || walk == CpuWalk::interleaved) return std::nullopt;
  if (walk == CpuWalk::avx512)
    return cpu_has(SimdIsa::avx512) ? std::optional(SimdIsa::avx512) : std::nullopt;
  if (walk == CpuWalk::avx2)
    return cpu_has(SimdIsa::avx2) ? std::optional(SimdIsa::avx2) : std::nullopt;
  if (cpu_has(SimdIsa::avx512)) return SimdIsa::avx512;
  if (cpu_has(SimdIsa::avx2)) return SimdIsa::avx2;
  return std::nullopt;
}

/// Traces ray i into hit i one ray at a time (work[i] too when work is not empty).
template <Query kQuery, typename CellT>
void trace_one_by_one(const GridView& grid, const RayFields& rays, const HitFields& hits,
                      std::span<RayWork> work) {
  for (std::size_t i = 0; i < rays.size(); ++i) {
    if (work.empty()) {
      hits.write(i, traverse_grid<kQuery, CellT>(grid, rays[i]));
      continue;
    }
    TraversalCounters counters;
    hits.write(i, traverse_grid<kQuery, CellT>(grid, rays[i], &counters));
    work[i] = {counters.cells, counters.triangles};
  }
}

/// Traces a chunk of rays the way that suits it (see the top of this file); `grid_bytes` is the
/// size of the grid's arrays. The hits and the work do not depend on the choice.
template <Query kQuery, typename CellT>
void trace_chunk(const GridView& grid, std::size_t grid_bytes, CpuWalk walk, const RayFields& rays,
                 const HitFields& hits, std::span<RayWork> work) {
  const auto isa = simd_walk_fits(grid.info) ? simd_isa_of(walk) : std::nullopt;
  if (isa) {
    const SimdRays lane_rays =
        walks_as_coherent(grid.info, grid_bytes, rays) ? SimdRays::packets : SimdRays::independent;
    if (isa == SimdIsa::avx512)
      return trace_simd_lanes<SimdIsa::avx512, kQuery, CellT>(grid, rays, hits, work, lane_rays);
    return trace_simd_lanes<SimdIsa::avx2, kQuery, CellT>(grid, rays, hits, work, lane_rays);
  }
  if (walk == CpuWalk::single) return trace_one_by_one<kQuery, CellT>(grid, rays, hits, work);
  if (walk == CpuWalk::interleaved) return trace_interleaved<kQuery, CellT>(grid, rays, hits, work);
  if (walks_as_coherent(grid.info, grid_bytes, rays))
    trace_one_by_one<kQuery, CellT>(grid, rays, hits, work);
  else
    trace_interleaved<kQuery, CellT>(grid, rays, hits, work);
}

}  // namespace irgrid
