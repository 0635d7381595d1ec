// cpu/simd_walk.cpp: what the SIMD walks of cpu/simd_walk.h need of the CPU and the grid.
// Compiled for the baseline target; the walks themselves live in simd_walk_avx2.cpp and
// simd_walk_avx512.cpp.
#include "cpu/simd_walk.h"

#include <cstdint>

namespace irgrid {

bool cpu_has(SimdIsa isa) {
  // __builtin_cpu_supports also asks the operating system whether it saves the registers.
  static const bool has_avx2 = __builtin_cpu_supports("avx2");
  static const bool has_avx512 =
      __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
  return isa == SimdIsa::avx512 ? has_avx512 : has_avx2;
}

bool simd_walk_fits(const GridInfo& info) {
  return std::uint64_t(info.num_triangles) * 9 < (1ull << 31) &&
         std::uint64_t(info.num_cells + 1) * 4 < (1ull << 31);
}

}  // namespace irgrid
