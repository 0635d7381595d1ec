// cpu/merge_propose_avx512.cpp: a merge sweep's proposals (cpu/merge_propose.h) in the 16 lanes of
// AVX-512. Only the code below the pragma is compiled for avx512, and it runs only where cpu_has()
// says the CPU has it; the headers it uses are included above the pragma, so that their inline
// functions stay baseline code. (GCC 12's AVX-512 intrinsics trip -Wuninitialized: see
// simd_walk_avx512.cpp.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/construction/merge_lists.h"
#include "core/construction/merge_pairs.h"
#include "core/construction/narrow_cell.h"
#include "cpu/merge_propose.h"
#include "irgrid/kernel/grid_layout.h"

#pragma GCC push_options
#pragma GCC target("avx2,avx512f")

#include "cpu/merge_propose_lanes.h"
#include "cpu/simd_lanes_avx512.h"

namespace irgrid {

template <>
void propose_merges_with<SimdIsa::avx512>(const merge_detail::ProposeInputs& in,
                                          std::uint32_t first, std::uint32_t count) {
  simd::ProposeLanes<simd::Avx512Lanes>::propose(in, first, count);
}

}  // namespace irgrid

#pragma GCC pop_options
